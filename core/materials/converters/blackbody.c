/* converters/blackbody.py blackbody(t, clip=False): the fit's Rec.709 colour of temperature t in kelvin (float32
 * sums) into out (3), unclipped (negative outside the gamut: the Principled Volume's black body); a NaN temperature
 * reads as the coldest. */
INLINE void blackbody_unclipped(float t, double *out)
{
    float c[3];
    if (t >= 12000.0f) { for (int k = 0; k < 3; k++) c[k] = BLACKBODY_HOT[k]; }
    else if (t < 800.0f || t != t) { for (int k = 0; k < 3; k++) c[k] = BLACKBODY_COLD[k]; }
    else {
        int i = 0;
        while (i < 6 && t >= BLACKBODY_STARTS[i + 1]) i++;
        const float *r = BLACKBODY_R + 3 * i, *g = BLACKBODY_G + 3 * i, *b = BLACKBODY_B + 4 * i;
        float inv = 1.0f / t;
        c[0] = (r[0] * inv + r[1] * t) + r[2];
        c[1] = (g[0] * inv + g[1] * t) + g[2];
        c[2] = ((b[0] * t + b[1]) * t + b[2]) * t + b[3];
    }
    for (int k = 0; k < 3; k++) out[k] = (double)c[k];
}

/* core/materials/converters/blackbody.py Blackbody.evaluate at one hit: a[0] the output Color, a[1] Temperature.
 * The fit's tables (BLACKBODY_*) are generated from the class. */
INLINE void blackbody_texture(const int *a, double *reg)
{
    double c[3];
    blackbody_unclipped((float)reg[a[1]], c);
    for (int k = 0; k < 3; k++) reg[a[0] + k] = c[k] > 0.0 ? c[k] : 0.0;
}
