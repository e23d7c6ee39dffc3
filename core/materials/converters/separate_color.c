/* core/materials/converters/separate_color.py SeparateColor.evaluate at one hit: a[0] the output block (three
 * channels), a[1] Color, a[2] the mode (COLOR_MODES). */
INLINE void separate_color_texture(const int *a, double *reg)
{
    float c[3] = {(float)reg[a[1]], (float)reg[a[1] + 1], (float)reg[a[1] + 2]}, r[3] = {c[0], c[1], c[2]};
    if (a[2] == 1) rgb_to_hsv_f(c, r);
    else if (a[2] == 2) rgb_to_hsl_f(c, r);
    for (int k = 0; k < 3; k++) reg[a[0] + k] = r[k];
}
