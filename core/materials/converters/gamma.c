/* core/materials/converters/gamma.py Gamma.evaluate at one hit: a[0] the output Color, a[1] Color, a[2] Gamma. */
INLINE void gamma_texture(const int *a, double *reg)
{
    float gamma = (float)reg[a[2]], r[3];
    for (int k = 0; k < 3; k++) {
        float c = (float)reg[a[1] + k];
        r[k] = gamma == 0.0f ? 1.0f : (c > 0.0f ? (float)pow((double)c, (double)gamma) : c);
    }
    for (int k = 0; k < 3; k++) reg[a[0] + k] = r[k];
}
