/* Area lights: core/lights/area.py, a one-sided planar emitter sampled uniformly over its area. */

/* Where on a DISK or ELLIPSE light the sample u falls, in its unit square's frame: the concentric
 * map of the square onto the unit disk (Shirley-Chiu), halved (area.concentric_disk). */
INLINE void area_disk_point(const double *u, double *x, double *y)
{
    double a = 2.0 * u[0] - 1.0, bb = 2.0 * u[1] - 1.0;
    int use_a = fabs(a) > fabs(bb);
    double r = use_a ? a : bb;
    double ratio = r == 0.0 ? 0.0 : (use_a ? bb : a) / r;
    double phi = use_a ? (PI / 4) * ratio : (PI / 2) - (PI / 4) * ratio;
    double cos_phi, sin_phi;
    cos_sin(phi < 0.0 ? phi + 2.0 * PI : phi, &cos_phi, &sin_phi);
    *x = 0.5 * r * cos_phi;
    *y = 0.5 * r * sin_phi;
}

/* The light's point (x, y) (in [-1/2, 1/2]^2 of its edges), seen from P: E_normal = L_e cos(theta_light)
 * A / d^2, narrowed by the spread; pdf = d^2 / (cos(theta_light) A). (Each value is computed whatever
 * the tests say, then chosen: loops over many samples need no branches. Values thrown away may be
 * inf or NaN.) */
INLINE void sample_area(const LightRecord *light, const double *P, double x, double y, LightSample *out)
{
    for (int c = 0; c < 3; c++)
        out->position[c] = x * light->axis_u[c] + y * light->axis_v[c] + light->position[c];
    double d = direction_to(P, out->position, out->L);
    double cos_light = -dot3(out->L, light->direction);
    double geometry = cos_light * light->area / (d * d);
    double pdf = d * d / (cos_light * light->area);
    geometry = ((cos_light > 0.0) & (d > 0.0)) ? geometry : 0.0;
    pdf = ((cos_light > 0.0) & (d > 0.0)) ? pdf : 0.0;
    if (light->spread_narrow != 0.0) {
        double tan_theta = sqrt(at_least(1.0 - cos_light * cos_light, 0.0)) / cos_light;
        double narrowed = at_least(light->spread_tan_half - tan_theta, 0.0) / light->spread_norm;
        geometry *= cos_light > 0.0 ? narrowed : 0.0;
    }
    out->distance = d;
    out->strength = light->radiance * geometry;
    out->pdf = pdf;
}

/* AreaLight.sample for the unit-square sample u. */
INLINE void sample_area_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    double x = u[0] - 0.5, y = u[1] - 0.5;
    if (light->ellipse != 0.0) area_disk_point(u, &x, &y);
    sample_area(light, P, x, y, out);
}

/* AreaLight.hit: a ray meets the light's plane from its emitting side inside its shape: radiance
 * P / (pi A) (spread applied) and the pdf `sample` gives that direction, t^2 / (cos A). */
INLINE int area_light_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    const double *n = light->direction, *U = light->axis_u, *V = light->axis_v;
    double cos_light = -dot3(D, n);
    if (!(cos_light > 0.0)) return 0;                           /* the back, or along the plane */
    double to_center[3] = {light->position[0] - O[0], light->position[1] - O[1], light->position[2] - O[2]};
    double t = dot3(to_center, n) / -cos_light;
    if (!((t > 0.0) & (t < t_max))) return 0;
    double X[3];
    for (int c = 0; c < 3; c++) X[c] = O[c] + t * D[c] - light->position[c];
    /* The point in the light's own coordinates: solve the 2 x 2 Gram system of its edges. */
    double uu = dot3(U, U), uv = dot3(U, V), vv = dot3(V, V), xu = dot3(X, U), xv = dot3(X, V);
    double det = uu * vv - uv * uv;
    double x = (vv * xu - uv * xv) / det, y = (uu * xv - uv * xu) / det;
    int inside = light->ellipse != 0.0 ? x * x + y * y <= 0.25 : (fabs(x) <= 0.5) & (fabs(y) <= 0.5);
    int hit = (cos_light > 0.0) & (t > 0.0) & (t < t_max) & inside;
    if (!hit) return 0;
    double attenuation = 1.0;
    if (light->spread_narrow != 0.0) {
        double tan_theta = sqrt(at_least(1.0 - cos_light * cos_light, 0.0)) / cos_light;
        attenuation = at_least(light->spread_tan_half - tan_theta, 0.0) / light->spread_norm;
    }
    out->t = t;
    attenuation *= ies_lamp_factor(light, D) * lamp_falloff(light, t);
    for (int c = 0; c < 3; c++) out->radiance[c] = light->radiance * attenuation * light->color[c];
    out->pdf = t * t / (cos_light * light->area);
    return 1;
}

/* The table's entries (lights.gen.c): AreaLight.sample and AreaLight.hit. */
INLINE void area_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                        const double *u, LightSample *out)
{
    (void)ctx; (void)N;
    sample_area_light(light, P, u, out);
    out->strength *= ies_lamp_factor(light, out->L) * lamp_falloff(light, out->distance);
    lamp_color(light, out);
    lamp_sample_tint(light, out);
}

INLINE int area_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    if (!area_light_hit(light, O, D, t_max, out)) return 0;
    lamp_hit_tint(light, O, D, out);
    return 1;
}
