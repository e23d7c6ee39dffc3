/* The table of lights: a light's `kind` tag picks its functions (core/lights/__init__.py LIGHT_TYPES). */

/* Light from `light` arriving at point P for the unit-square sample u (and for emitters u[2], the
 * pick): Light.sample. ctx: the emitters' and the world's tables. N: the normal the emitters' light tree
 * weighs by (direct.tree_normals; NULL or zero: unknown). */
INLINE void sample_light(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                         const double *u, LightSample *out)
{
    out->hidden = 0;
    switch ((int)light->kind) {
    case LIGHT_POINT: sample_point_light(light, P, u, out); break;
    case LIGHT_SPOT: sample_spot_light(light, P, u, out); break;
    case LIGHT_SUN: sample_sun_light(light, u, out); break;
    case LIGHT_EMITTERS: sample_emitters(ctx->emitters, P, N, u, out); return;
    case LIGHT_WORLD: sample_world(ctx->world, u, out); return;
    default: sample_area_light(light, P, u, out); break;
    }
    for (int c = 0; c < 3; c++) out->color[c] = light->color[c];
}

/* Light.hit for Blender's lamps: whether a ray from O along D meets `light` before t_max. */
INLINE int light_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    switch ((int)light->kind) {
    case LIGHT_POINT:
    case LIGHT_SPOT: return light->delta == 0.0 ? point_light_hit(light, O, D, t_max, out) : 0;
    case LIGHT_SUN: return light->delta == 0.0 ? sun_light_hit(light, D, t_max, out) : 0;
    case LIGHT_AREA: return area_light_hit(light, O, D, t_max, out);
    default: return 0;
    }
}

/* Light.sample over arrays (for the tests): points (n, 3), u (n, 3) float64 -> L (n, 3), distance,
 * strength, pdf (n,), position (n, 3), color (n, 3) float64. */
EXPORT void primer_sample_light(const LightRecord *light, const LightContext *ctx, int64_t n, const double *points,
                                const double *u, double *L, double *distance, double *strength, double *pdf,
                                double *position, double *color)
{
    for (int64_t i = 0; i < n; i++) {
        LightSample s;
        sample_light(light, ctx, points + 3 * i, NULL, u + 3 * i, &s);
        for (int c = 0; c < 3; c++) {
            L[3 * i + c] = s.L[c];
            position[3 * i + c] = s.position[c];
            color[3 * i + c] = s.color[c];
        }
        distance[i] = s.distance;
        strength[i] = s.strength;
        pdf[i] = s.pdf;
    }
}

/* Light.hit over arrays (for the tests): origins, directions (n, 3), t_max (n,) -> hit (n,) uint8,
 * t (n,), radiance (n, 3), pdf (n,). */
EXPORT void primer_light_hit(const LightRecord *light, int64_t n, const double *origins, const double *directions,
                             const double *t_max, uint8_t *hit, double *t, double *radiance, double *pdf)
{
    for (int64_t i = 0; i < n; i++) {
        LightHit h = {0.0, {0.0, 0.0, 0.0}, 0.0};
        hit[i] = (uint8_t)light_hit(light, origins + 3 * i, directions + 3 * i, t_max[i], &h);
        t[i] = hit[i] ? h.t : INFINITY;
        pdf[i] = hit[i] ? h.pdf : 0.0;
        for (int c = 0; c < 3; c++) radiance[3 * i + c] = hit[i] ? h.radiance[c] : 0.0;
    }
}

EXPORT int64_t primer_light_record_size(void) { return (int64_t)sizeof(LightRecord); }
EXPORT int64_t primer_emitter_tables_size(void) { return (int64_t)sizeof(EmitterTables); }
EXPORT int64_t primer_world_tables_size(void) { return (int64_t)sizeof(WorldTables); }
