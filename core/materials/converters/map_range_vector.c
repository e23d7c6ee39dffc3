/* core/materials/converters/map_range_vector.py MapRangeVector.evaluate at one hit: a[0] the output Vector, a[1]
 * Vector, a[2] From Min, a[3] From Max, a[4] To Min, a[5] To Max, a[6] Steps, a[7] the type (MAP_RANGE_TYPES),
 * a[8] clamp. */
INLINE void map_range_vector_texture(const int *a, double *reg)
{
    float r[3];
    for (int k = 0; k < 3; k++) {
        float v = (float)reg[a[1] + k], from_min = (float)reg[a[2] + k], from_max = (float)reg[a[3] + k];
        float to_min = (float)reg[a[4] + k], to_max = (float)reg[a[5] + k], steps = (float)reg[a[6] + k];
        float span = from_max - from_min, f = span != 0.0f ? (v - from_min) / span : 0.0f;
        if (a[7] == 1) f = steps > 0.0f ? floorf(f * (steps + 1.0f)) / steps : 0.0f;
        else if (a[7] >= 2) {
            f = f > 0.0f ? (f < 1.0f ? f : 1.0f) : 0.0f;
            f = a[7] == 2 ? (3.0f - 2.0f * f) * (f * f) : f * f * f * (f * (f * 6.0f - 15.0f) + 10.0f);
        }
        r[k] = to_min + f * (to_max - to_min);
        if (a[8] && a[7] <= 1) {
            float lo = to_min < to_max ? to_min : to_max, hi = to_min < to_max ? to_max : to_min;
            r[k] = r[k] > lo ? r[k] : lo;
            r[k] = r[k] < hi ? r[k] : hi;
        }
    }
    for (int k = 0; k < 3; k++) reg[a[0] + k] = r[k];
}
