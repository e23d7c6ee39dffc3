/* Sun lights: core/lights/sun.py. One direction (no extent), or a direction in its disk's cone. */

INLINE void sample_sun_light(const LightRecord *light, const double *u, LightSample *out)
{
    if (light->delta != 0.0) {
        for (int c = 0; c < 3; c++) out->L[c] = light->direction[c];
        out->pdf = INFINITY;
    } else {
        sample_cone(light->direction, light->sun_t, light->sun_b, light->sun_cos_max, u, out->L);
        out->pdf = cone_pdf(light->sun_cos_max);
    }
    out->distance = INFINITY;
    out->strength = light->strength;
    out->position[0] = out->position[1] = out->position[2] = 0.0;
}

/* SunLight.hit: a ray that escapes the scene (t_max inf) inside the sun's disk sees S / (pi sin^2 a). */
INLINE int sun_light_hit(const LightRecord *light, const double *D, double t_max, LightHit *out)
{
    int inside = (dot3(D, light->direction) >= light->sun_cos_max) & (t_max == INFINITY);
    if (!inside) return 0;
    out->t = INFINITY;
    for (int c = 0; c < 3; c++) out->radiance[c] = light->radiance * light->color[c];
    out->pdf = cone_pdf(light->sun_cos_max);
    return 1;
}

/* The table's entries (lights.gen.c): SunLight.sample and SunLight.hit (a sun with a disk only). */
INLINE void sun_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                       const double *u, LightSample *out)
{
    (void)ctx; (void)P; (void)N;
    sample_sun_light(light, u, out);
    lamp_color(light, out);
}

INLINE int sun_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    (void)O;
    return light->delta == 0.0 ? sun_light_hit(light, D, t_max, out) : 0;
}
