/* core/materials/converters/wavelength.py Wavelength.evaluate at one hit: a[0] the output Color, a[1] Wavelength.
 * CIE_COLOR_MATCH and XYZ_TO_RGB are generated from the class. */
INLINE void wavelength_texture(const int *a, double *reg)
{
    float ii = ((float)reg[a[1]] - 380.0f) * (1.0f / 5.0f), xyz[3] = {0.0f, 0.0f, 0.0f};
    int i = (ii == ii && fabsf(ii) < 1e9f) ? (int)ii : -1;
    if (i >= 0 && i < 80) {
        float t = ii - (float)i;
        for (int k = 0; k < 3; k++) {
            float lo = CIE_COLOR_MATCH[3 * i + k], hi = CIE_COLOR_MATCH[3 * i + 3 + k];
            xyz[k] = lo + t * (hi - lo);
        }
    }
    for (int j = 0; j < 3; j++) {
        float v = ((XYZ_TO_RGB[3 * j] * xyz[0] + XYZ_TO_RGB[3 * j + 1] * xyz[1]) + XYZ_TO_RGB[3 * j + 2] * xyz[2])
                  * (1.0f / 2.52f);
        reg[a[0] + j] = v > 0.0f ? v : 0.0f;
    }
}
