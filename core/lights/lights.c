/* The table of lights: a light's `kind` tag picks its sampling function (core/lights/__init__.py). */

/* Light from `light` arriving at point P for the unit-square sample u: Light.sample. */
INLINE void sample_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    switch ((int)light->kind) {
    case LIGHT_POINT: sample_point_light(light, P, u, out); break;
    case LIGHT_SPOT: sample_spot_light(light, P, u, out); break;
    case LIGHT_SUN: sample_sun_light(light, u, out); break;
    default: sample_area_light(light, P, u, out); break;
    }
}

/* Light.sample over arrays (for the tests): points, u (n, 3), (n, 2) float64 -> L (n, 3), distance,
 * strength, pdf (n,), position (n, 3) float64. */
EXPORT void primer_sample_light(const LightRecord *light, int64_t n, const double *points, const double *u,
                                double *L, double *distance, double *strength, double *pdf, double *position)
{
    for (int64_t i = 0; i < n; i++) {
        LightSample s;
        sample_light(light, points + 3 * i, u + 2 * i, &s);
        for (int c = 0; c < 3; c++) { L[3 * i + c] = s.L[c]; position[3 * i + c] = s.position[c]; }
        distance[i] = s.distance;
        strength[i] = s.strength;
        pdf[i] = s.pdf;
    }
}

EXPORT int64_t primer_light_record_size(void) { return (int64_t)sizeof(LightRecord); }
