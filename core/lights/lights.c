/* The table of lights: each light's C file, and sample_light / light_hit switching on a light's kind (generated
 * from core/lights/__init__.py's LIGHT_TYPES by tools/make_boundary.py). */
#include "lights.gen.c"

/* rays.lamps_seen for one lamp and one camera ray O, D that ends at t (its hit, where `hit`, else where it escapes):
 * whether the ray sees the lamp (hittable and visible to the camera: a lamp with extent before t, a sun's disc only
 * where the ray escapes, as Cycles' shade_background adds distant lights, unless its Multiple Importance is off),
 * its radiance in *lh. */
INLINE int camera_sees_lamp(const LightRecord *light, const double *O, const double *D, double t, int hit, LightHit *lh)
{
    if (light->hittable == 0.0 || light->camera == 0.0) return 0;
    if (light_is((int)light->kind, LIGHT_FLAG_DISTANT))                 /* (with Multiple Importance off: no disc) */
        return !hit && light->use_mis != 0 && light_hit(light, O, D, INFINITY, lh);
    return light_is((int)light->kind, LIGHT_FLAG_POSITION | LIGHT_FLAG_AREA) && light_hit(light, O, D, t, lh);
}

/* Light.sample over arrays (for the tests): points (n, 3), u (n, 3) float64 -> L (n, 3), distance,
 * strength, pdf (n,), position (n, 3), color (n, 3) float64. */
static void sample_light_rows(const SampleLightArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        LightSample s;
        sample_light(a->light, a->context, a->points + 3 * i, NULL, a->u + 3 * i, &s);
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
        uint8_t hit = (uint8_t)light_hit(a->light, a->origins + 3 * i, a->directions + 3 * i, a->t_max[i], &h);
        a->hit[i] = hit;
        a->t[i] = hit ? h.t : INFINITY;
        a->pdf[i] = hit ? h.pdf : 0.0;
        for (int c = 0; c < 3; c++) a->radiance[3 * i + c] = hit ? h.radiance[c] : 0.0;
    }
}

