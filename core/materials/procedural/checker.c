/* core/materials/procedural/checker.py CheckerTexture.evaluate at one hit: a[0] the output block (Colour, Fac),
 * a[1] Vector, a[2] Color1, a[3] Color2, a[4] Scale. */
INLINE void checker_texture(const int *a, double *reg)
{
    float scale = (float)reg[a[4]];
    int cell[3];
    for (int k = 0; k < 3; k++) {
        float p = ((float)reg[a[1] + k] * scale + 0.000001f) * 0.999999f;
        cell[k] = abs((int)floorf(p)) % 2;
    }
    double fac = ((cell[0] == cell[1]) == cell[2]) ? 1.0 : 0.0;
    const double *color = reg + (fac == 1.0 ? a[2] : a[3]);
    double *out = reg + a[0];
    out[0] = color[0]; out[1] = color[1]; out[2] = color[2];
    out[3] = fac;
}
