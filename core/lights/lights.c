/* The table of lights: each light's C file, and sample_light / light_hit switching on a light's kind (generated
 * from core/lights/__init__.py's LIGHT_TYPES by tools/make_boundary.py). */
#include "lights.gen.c"

/* sample_light at a vertex of the path `path` (its counts; NULL: no bounces): a lamp's node program (lamp_graph.c)
 * sees them, as Cycles' light_sample_shader_eval reads the integrator state's. */
INLINE void sample_light_for(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                             const double *u, const LightPath *path, LightSample *out)
{
    sample_light(light, ctx, P, N, u, out);
    lamp_sample_tint(light, out, path);
}

/* light_hit for a ray carrying the path `path` (after its bounce; NULL: no bounces), which a lamp's node program
 * sees. */
INLINE int light_hit_for(const LightRecord *light, const double *O, const double *D, double t_max,
                         const LightPath *path, LightHit *out)
{
    if (!light_hit(light, O, D, t_max, out)) return 0;
    lamp_hit_tint(light, O, D, out, path);
    return 1;
}

/* rays.lamps_seen for one lamp and one camera ray O, D that ends at t (its hit, where `hit`, else where it escapes):
 * whether the ray sees the lamp (hittable and visible to the camera: a lamp with extent before t, a sun's disc only
 * where the ray escapes, as Cycles' shade_background adds distant lights, unless its Multiple Importance is off),
 * its radiance in *lh. */
INLINE int camera_sees_lamp(const LightRecord *light, const double *O, const double *D, double t, int hit, LightHit *lh)
{
    if (light->hittable == 0.0 || light->camera == 0.0) return 0;
    if (light_is((int)light->kind, LIGHT_FLAG_DISTANT))                 /* (with Multiple Importance off: no disc) */
        return !hit && light->use_mis != 0 && light_hit_for(light, O, D, INFINITY, NULL, lh);
    return light_is((int)light->kind, LIGHT_FLAG_POSITION | LIGHT_FLAG_AREA) && light_hit_for(light, O, D, t, NULL, lh);
}

/* Light.sample over arrays (for the tests): points (n, 3), u (n, 3) float64 -> L (n, 3), distance,
 * strength, pdf (n,), position (n, 3), color (n, 3) float64. */
static void sample_light_rows(const SampleLightArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        LightSample s;
        sample_light_for(a->light, a->context, a->points + 3 * i, NULL, a->u + 3 * i, NULL, &s);
        for (int c = 0; c < 3; c++) {
            a->L[3 * i + c] = s.L[c];
            a->position[3 * i + c] = s.position[c];
            a->color[3 * i + c] = s.color[c];
        }
        a->distance[i] = s.distance;
        a->strength[i] = s.strength;
        a->pdf[i] = s.pdf;
    }
}

/* Light.hit over arrays (for the tests): origins, directions (n, 3), t_max (n,) -> hit (n,) uint8,
 * t (n,), radiance (n, 3), pdf (n,). */
static void light_hit_rows(const LightHitArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        LightHit h = {0.0, {0.0, 0.0, 0.0}, 0.0};
        uint8_t hit = (uint8_t)light_hit_for(a->light, a->origins + 3 * i, a->directions + 3 * i, a->t_max[i], NULL, &h);
        a->hit[i] = hit;
        a->t[i] = hit ? h.t : INFINITY;
        a->pdf[i] = hit ? h.pdf : 0.0;
        for (int c = 0; c < 3; c++) a->radiance[3 * i + c] = hit ? h.radiance[c] : 0.0;
    }
}

