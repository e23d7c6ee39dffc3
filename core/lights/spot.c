/* Spot lights: core/lights/spot.py, a point light masked by Blender's spot cone. */

/* Blender's spot cone factor for light leaving along -L: SpotLight.attenuation. */
static inline double spot_factor(const LightRecord *light, const double *L)
{
    /* The angle to the axis, in a spot's (scaled) frame when it has one; both computed, one chosen. */
    double plain = -dot3(L, light->direction);
    const double *M = light->spot_inverse;
    double local[3];
    for (int c = 0; c < 3; c++) local[c] = -(M[3 * c] * L[0] + M[3 * c + 1] * L[1] + M[3 * c + 2] * L[2]);
    double length = sqrt(dot3(local, local));
    double framed = -local[2] / (length > 0.0 ? length : 1.0);
    double cos_angle = light->spot_frame == 0.0 ? plain : framed;
    /* A hard edge without blend; else smoothstep across the blend. */
    double hard = cos_angle > light->spot_cos_half ? 1.0 : 0.0;
    double x = (cos_angle - light->spot_cos_half) / light->spot_blend_width;
    x = x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x);
    double smooth = x * x * (3.0 - 2.0 * x);
    return light->spot_blend_width <= 0.0 ? hard : smooth;
}

/* SpotLight.sample: the point light's sample, times the cone factor from the (sampled) light point. */
INLINE void sample_spot_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    sample_point_light(light, P, u, out);
    out->strength *= spot_factor(light, out->L);
}

/* The table's entries (lights.gen.c): SpotLight.sample and SpotLight.hit (a round spot only). */
INLINE void spot_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                        const double *u, LightSample *out)
{
    (void)ctx; (void)N;
    sample_spot_light(light, P, u, out);
    out->strength *= ies_lamp_factor(light, out->L) * lamp_falloff(light, out->distance);
    lamp_color(light, out);
}

INLINE int spot_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    if (light->delta != 0.0 || !point_light_hit(light, O, D, t_max, 1, out)) return 0;
    return 1;
}
