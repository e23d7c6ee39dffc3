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

/* sky.disc_xyz of a Sky Texture's disc (SunLight.limb), in RGB and with its intensity folded in: the radiance along
 * D, bottom to top linear in elevation, limb-darkened; 0 outside the disc or below the earth's edge. */
INLINE void sun_limb(const LightRecord *light, const double *D, double *out)
{
    double elevation = light->limb_sun[0], rotation = light->limb_sun[1], size = light->limb_sun[2];
    double z = D[2] < -1.0 ? -1.0 : D[2] > 1.0 ? 1.0 : D[2], e = 0.5 * PI - acos(z);
    double sun[3] = {-cos(elevation) * sin(rotation), cos(elevation) * cos(rotation), sin(elevation)};
    double minus[3], plus[3];
    for (int c = 0; c < 3; c++) { minus[c] = D[c] - sun[c]; plus[c] = D[c] + sun[c]; out[c] = 0.0; }
    double angle = 2.0 * atan2(sqrt(dot3(minus, minus)), sqrt(dot3(plus, plus)));
    double half = 0.5 * size;
    if (!(angle < half && e > light->limb_sun[3])) return;
    double y = (e - elevation) / size + 0.5, r = angle / half, under = 1.0 - r * r;
    double darkening = 1.0 - SKY_LIMB * (1.0 - sqrt(under > 0.0 ? under : 0.0));
    for (int c = 0; c < 3; c++)
        out[c] = ((1.0 - y) * light->limb_bottom[c] + y * light->limb_top[c]) * (1.0 * darkening);
}

/* SunLight.hit: a ray that escapes the scene (t_max inf) inside the sun's disk sees S / (pi sin^2 a) (a Sky
 * Texture's disc: its limb-darkened radiance, sun_limb). */
INLINE int sun_light_hit(const LightRecord *light, const double *D, double t_max, LightHit *out)
{
    int inside = (dot3(D, light->direction) >= light->sun_cos_max) & (t_max == INFINITY);
    if (!inside) return 0;
    out->t = INFINITY;
    if (light->limb) sun_limb(light, D, out->radiance);
    else for (int c = 0; c < 3; c++) out->radiance[c] = light->radiance * ies_lamp_factor(light, D) * light->color[c];
    out->pdf = cone_pdf(light->sun_cos_max);
    return 1;
}

/* The table's entries (lights.gen.c): SunLight.sample and SunLight.hit (a sun with a disk only). */
INLINE void sun_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                       const double *u, LightSample *out)
{
    (void)ctx; (void)P; (void)N;
    sample_sun_light(light, u, out);
    out->strength *= ies_lamp_factor(light, out->L);
    lamp_color(light, out);
}

INLINE int sun_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    (void)O;
    if (light->delta != 0.0 || !sun_light_hit(light, D, t_max, out)) return 0;
    return 1;
}
