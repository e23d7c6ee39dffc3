/* core/materials/converters/combine_color.py CombineColor.evaluate at one hit: a[0] the output Color, a[1] Red
 * (or Hue), a[2] Green (Saturation), a[3] Blue (Value or Lightness), a[4] the mode (COLOR_MODES). */
INLINE void combine_color_texture(const int *a, double *reg)
{
    float c[3] = {(float)reg[a[1]], (float)reg[a[2]], (float)reg[a[3]]}, r[3] = {c[0], c[1], c[2]};
    if (a[4] == 1) hsv_to_rgb_f(c, r);
    else if (a[4] == 2) hsl_to_rgb_f(c, r);
    for (int k = 0; k < 3; k++) reg[a[0] + k] = r[k];
}
