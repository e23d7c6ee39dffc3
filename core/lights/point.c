/* Point lights: core/lights/point.py. */

/* The lecture's point light: I = P / (4 pi), attenuated by 1 / r^2. */
INLINE void sample_point(const LightRecord *light, const double *P, LightSample *out)
{
    double d = direction_to(P, light->position, out->L);
    out->distance = d;
    double strength = light->power * (1.0 / (4.0 * PI)) * (1.0 / (d * d));
    out->strength = d > 0.0 ? strength : 0.0;
    out->pdf = INFINITY;
    for (int c = 0; c < 3; c++) out->position[c] = light->position[c];
}

/* RoundLight.cone's half-angle: the cosine of the cone a round light of radius R covers from distance *d (a disk
 * facing the point with soft falloff, else a sphere, *d then kept just outside it). */
INLINE double round_light_cos_max(const LightRecord *light, double *d)
{
    double R = light->radius, sin2_max;
    if (light->soft_falloff != 0.0) {
        sin2_max = R * R / (R * R + *d * *d);
    } else {
        *d = at_least(*d, R * (1.0 + 1e-9));
        sin2_max = at_most((R / *d) * (R / *d), 1.0);
    }
    return sqrt(1.0 - sin2_max);
}

/* PointLight.hit: a ray meets a round light (the disk facing its origin with soft falloff, else the
 * sphere) within the cone the light covers from the origin; radiance P / (4 pi^2 R^2); the cone's pdf.
 * Returns whether it met it before t_max; `spot`: apply a spot's cone to what leaves. */
INLINE int point_light_hit(const LightRecord *light, const double *O, const double *D, double t_max, int spot,
                           LightHit *out)
{
    double axis[3];
    double d = direction_to(O, light->position, axis);
    double R = light->radius, cos_max = round_light_cos_max(light, &d);
    double cos_to_center = dot3(D, axis), t;
    if (!(cos_to_center >= cos_max)) return 0;                  /* outside the cone the light covers */
    if (light->soft_falloff != 0.0) {
        t = d / cos_to_center;
    } else {
        double b = d * cos_to_center;
        t = b - sqrt(at_least(b * b - (d * d - R * R), 0.0));
    }
    int hit = (cos_to_center >= cos_max) & (cos_to_center > 0.0) & (t > 0.0) & (t < t_max);
    if (!hit) return 0;
    out->t = t;
    double radiance = light->radiance;
    if (spot) radiance *= spot_factor(light, D);               /* (D: towards the light) */
    radiance *= ies_lamp_factor(light, D) * lamp_falloff(light, t);
    for (int c = 0; c < 3; c++) out->radiance[c] = radiance * light->color[c];
    out->pdf = cone_pdf(cos_max);
    return 1;
}

/* A sphere (or, with soft falloff, a disk facing P): the cone it covers, sampled uniformly. */
INLINE void sample_sphere(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    double axis[3], t[3], b[3];
    double d = direction_to(P, light->position, axis);
    double R = light->radius, cos_max = round_light_cos_max(light, &d);
    orthonormal_frame(axis, t, b);
    sample_cone(axis, t, b, cos_max, u, out->L);
    double cos_to_center = dot3(out->L, axis);
    if (light->soft_falloff != 0.0) {
        out->distance = d / at_least(cos_to_center, 1e-300);
    } else {
        double h = d * cos_to_center;
        out->distance = h - sqrt(at_least(h * h - (d * d - R * R), 0.0));
    }
    out->strength = light->radiance * 2.0 * PI * (1.0 - cos_max);
    out->pdf = cone_pdf(cos_max);
    for (int c = 0; c < 3; c++) out->position[c] = P[c] + out->L[c] * out->distance;
}

/* PointLight.sample: exact without a radius, else a direction in the cone the light covers. */
INLINE void sample_point_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    if (light->delta != 0.0) sample_point(light, P, out);
    else sample_sphere(light, P, u, out);
}

/* A lamp's sample carries the lamp's colour. */
INLINE void lamp_color(const LightRecord *light, LightSample *out)
{
    for (int c = 0; c < 3; c++) out->color[c] = light->color[c];
}

/* The table's entries (lights.gen.c): PointLight.sample and PointLight.hit (a round light only). */
INLINE void point_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                         const double *u, LightSample *out)
{
    (void)ctx; (void)N;
    sample_point_light(light, P, u, out);
    out->strength *= ies_lamp_factor(light, out->L) * lamp_falloff(light, out->distance);
    lamp_color(light, out);
}

INLINE int point_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    if (light->delta != 0.0 || !point_light_hit(light, O, D, t_max, 0, out)) return 0;
    return 1;
}
