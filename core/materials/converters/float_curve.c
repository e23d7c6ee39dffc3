/* core/materials/converters/float_curve.py FloatCurve at one hit: a[0] the output, a[1] the factor, a[2] the input,
 * a[3] the start of its baked table in the program's table floats (curves.h). */
INLINE void float_curve_texture(const int *a, double *reg, const double *tables)
{
    curves_at(tables + a[3], 1, reg, a[1], a[2], reg + a[0]);
}
