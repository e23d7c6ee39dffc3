/* core/materials/converters/rgb_to_bw.py RGBToBW.evaluate at one hit: a[0] the output Val, a[1] Color. */
INLINE void rgb_to_bw_texture(const int *a, double *reg)
{
    const double *c = reg + a[1];
    reg[a[0]] = ((float)c[0] * RGB_TO_Y[0] + (float)c[1] * RGB_TO_Y[1]) + (float)c[2] * RGB_TO_Y[2];
}
