/* core/materials/converters/bright_contrast.py BrightContrast.evaluate at one hit: a[0] the output Color, a[1] Color,
 * a[2] Brightness, a[3] Contrast. */
INLINE void bright_contrast_texture(const int *a, double *reg)
{
    float contrast = (float)reg[a[3]], m = 1.0f + contrast, b = (float)reg[a[2]] - contrast * 0.5f, r[3];
    for (int k = 0; k < 3; k++) {
        float v = m * (float)reg[a[1] + k] + b;
        r[k] = v > 0.0f ? v : 0.0f;
    }
    for (int k = 0; k < 3; k++) reg[a[0] + k] = r[k];
}
