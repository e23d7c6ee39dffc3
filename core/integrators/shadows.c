/* Shadow rays: core/integrators/shadows.py. From a point safely off the surface towards a light sample. */

/* shadows.spawn_ray: the origin O of a ray leaving point I along D, `step` off the surface along its face normal Ng,
 * on the side D goes to. */
INLINE void spawn_ray(const double *I, const double *Ng, const double *D, double step, double *O)
{
    double side = dot3(Ng, D) < 0.0 ? -1.0 : 1.0;
    for (int c = 0; c < 3; c++) O[c] = I[c] + (step * side) * Ng[c];
}

/* The shadow ray of one light sample: shadows.robust_rays when `robust`, else shadows.epsilon_rays,
 * from I (or the terminator fix's blend towards the lifted point) towards the sampled light point.
 * P, ng, lifted: the hit's point, face normal (facing the viewer) and terminator point; offset: its
 * robust offset; amount: how far towards `lifted` to move (0 off smooth hits or without the fix);
 * L, distance, position, light_normal: the light sample (light_normal: the unit face normal of the emissive
 * triangle it lies on, zero for other lights). Out: origin, D, *t. */
INLINE void shadow_ray(const double *P, const double *ng, const double *lifted, double offset, double amount,
                       const double *L, double distance, const double *position, const double *light_normal,
                       int robust, double epsilon, double *origin, double *D, double *t)
{
    for (int c = 0; c < 3; c++) origin[c] = P[c] + amount * (lifted[c] - P[c]);
    if (robust) {
        /* Off the surface along Ng by the error bound, towards the light point, stopping short of it by
         * the rounding of the float32 ray: ulps of the largest of its coordinates, the origin's and the
         * length; a sun's ray keeps its direction. A light point on an emissive triangle: the ray ends that far
         * off its surface too, along its face normal on the origin's side (a ray that grazes the emitter would
         * otherwise meet it short of the end: Embree's hit on its plane moves along the ray by the rounding
         * over the sine of the angle). */
        for (int c = 0; c < 3; c++) origin[c] += offset * ng[c];
        double w[3] = {position[0] - origin[0], position[1] - origin[1], position[2] - origin[2]};
        double length = sqrt(dot3(w, w));
        double magnitude = fmax(fmax(largest3(position), largest3(origin)), length);
        double end_offset = ROBUST_ULPS * FLOAT32_EPSILON * magnitude;
        double facing = light_normal[0] * -w[0] + light_normal[1] * -w[1] + light_normal[2] * -w[2];
        double side = facing < 0.0 ? -1.0 : 1.0;
        for (int c = 0; c < 3; c++) w[c] = w[c] + (side * end_offset) * light_normal[c];
        length = sqrt(dot3(w, w));
        double inverse = 1.0 / at_least(length, 1e-300);
        double stop = length - end_offset;
        int finite = distance < INFINITY;
        for (int c = 0; c < 3; c++) D[c] = finite ? w[c] * inverse : L[c];
        *t = finite ? at_least(stop, 0.0) : distance;
    } else {
        /* The lecture's epsilon: origin I + epsilon L, t_max = distance - 2 epsilon. */
        for (int c = 0; c < 3; c++) { origin[c] += epsilon * L[c]; D[c] = L[c]; }
        *t = at_least(distance - 2.0 * epsilon, 0.0);
    }
}

/* shadows.terminator_amount: how much of the terminator lift to apply, 0..1, as Cycles blends it. */
INLINE double terminator_amount(double NL, double NgL, double cutoff)
{
    double amount = NL < cutoff ? 2.0 - (NgL + NL) / cutoff : 1.0 - NgL / cutoff;
    return amount < 0.0 ? 0.0 : (amount > 1.0 ? 1.0 : amount);
}
