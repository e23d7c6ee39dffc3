/* core/materials/procedural/magic.py MagicTexture.evaluate at one hit: a[0] the output block (Colour, Fac), a[1]
 * Vector, a[2] Scale, a[3] Distortion; a[4] the depth (0 to 10). */

/* sin or cos of a float in double, rounded to float (as magic.py's sine and cosine). */
INLINE float magic_sin(float t) { return (float)sin((double)t); }
INLINE float magic_cos(float t) { return (float)cos((double)t); }

NOINLINE static void magic_texture(const int *a, double *reg)
{
    int depth = a[4];
    float scale = (float)reg[a[2]], distortion = (float)reg[a[3]];
    float px = fmodf((float)reg[a[1]], 6.283185307f), py = fmodf((float)reg[a[1] + 1], 6.283185307f);
    float pz = fmodf((float)reg[a[1] + 2], 6.283185307f);
    float x = magic_sin((px + py + pz) * 5.0f * scale);
    float y = magic_cos((-px + py - pz) * 5.0f * scale);
    float z = -magic_cos((-px - py + pz) * 5.0f * scale);
    if (depth > 0) {
        x *= distortion; y *= distortion; z *= distortion;
        y = -magic_cos(x - y + z) * distortion;
        if (depth > 1) x = magic_cos(x - y - z) * distortion;
        if (depth > 2) z = magic_sin(-x - y - z) * distortion;
        if (depth > 3) x = -magic_cos(-x + y - z) * distortion;
        if (depth > 4) y = -magic_sin(-x + y + z) * distortion;
        if (depth > 5) y = -magic_cos(-x + y + z) * distortion;
        if (depth > 6) x = magic_cos(x + y + z) * distortion;
        if (depth > 7) z = magic_sin(x + y - z) * distortion;
        if (depth > 8) x = -magic_cos(-x - y + z) * distortion;
        if (depth > 9) y = -magic_sin(x - y + z) * distortion;
    }
    if (distortion != 0.0f) {
        float twice = distortion * 2.0f;
        x /= twice; y /= twice; z /= twice;
    }
    double *out = reg + a[0];
    out[0] = (double)(0.5f - x); out[1] = (double)(0.5f - y); out[2] = (double)(0.5f - z);
    out[3] = (double)(((0.5f - x) + (0.5f - y) + (0.5f - z)) * (1.0f / 3.0f));
}
