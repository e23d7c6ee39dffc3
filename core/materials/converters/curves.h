/* core/materials/converters/curves.py: Cycles' curve lookup of a baked table (min_x, max_x, extrapolate, then
 * CURVE_TABLE_SIZE rows of k columns), blended with the input by the factor, in float32. */

/* curves.lookup of column j of k at position f. */
INLINE float curve_lookup(const double *rows, int k, int j, float f, int extrapolate)
{
    const int last = CURVE_TABLE_SIZE - 1;
#define ROW(i) ((float)rows[(i) * k + j])
    if (extrapolate && f < 0.0f) return ROW(0) + (ROW(0) - ROW(1)) * -f * (float)last;
    if (extrapolate && f > 1.0f) return ROW(last) + (ROW(last) - ROW(last - 1)) * (f - 1.0f) * (float)last;
    float x = (f > 0.0f ? (f < 1.0f ? f : 1.0f) : 0.0f) * (float)last;
    int i = (int)x;
    i = i < 0 ? 0 : (i > last ? last : i);
    float t = x - (float)i, v = ROW(i);
    if (t > 0.0f) v = (1.0f - t) * v + t * ROW(i + 1 < last ? i + 1 : last);
#undef ROW
    return v;
}

/* curves.curves for one hit: out[0..k) from the value at reg[value], the factor at reg[fac], the table at `table`. */
INLINE void curves_at(const double *table, int k, const double *reg, int fac_register, int value_register, double *out)
{
    float min_x = (float)table[0], range = (float)table[1] - min_x, fac = (float)reg[fac_register], r[3];
    for (int j = 0; j < k; j++) {
        float v = (float)reg[value_register + j];
        float mapped = curve_lookup(table + 3, k, j, (v - min_x) / range, table[2] != 0.0);
        r[j] = (1.0f - fac) * v + fac * mapped;
    }
    for (int j = 0; j < k; j++) out[j] = r[j];
}
