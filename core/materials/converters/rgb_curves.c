/* core/materials/converters/rgb_curves.py RGBCurves at one hit: a[0] the output, a[1] the factor, a[2] the input,
 * a[3] the start of its baked table in the program's table floats (curves.h). */
INLINE void rgb_curves_texture(const int *a, double *reg, const double *tables)
{
    curves_at(tables + a[3], 3, reg, a[1], a[2], reg + a[0]);
}
