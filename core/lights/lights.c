/* The table of lights: each light's C file, and sample_light / light_hit switching on a light's kind (generated
 * from core/lights/__init__.py's LIGHT_TYPES by tools/make_boundary.py). */
#include "lights.gen.c"

/* Light.sample over arrays (for the tests): points (n, 3), u (n, 3) float64 -> L (n, 3), distance,
 * strength, pdf (n,), position (n, 3), color (n, 3) float64. */
static void sample_light_rows(const LightRecord *light, const LightContext *ctx, int64_t n, const double *points,
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
static void light_hit_rows(const LightRecord *light, int64_t n, const double *origins, const double *directions,
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

