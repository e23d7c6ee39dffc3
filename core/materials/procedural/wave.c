/* core/materials/procedural/wave.py WaveTexture.evaluate at one hit: a[0] the output block (Colour, Fac), a[1]
 * Vector, a[2] Scale, a[3] Distortion, a[4] Detail, a[5] Detail Scale, a[6] Detail Roughness, a[7] Phase Offset;
 * a[8] the wave type (bands, rings), a[9] the bands' direction, a[10] the rings' direction, a[11] the profile. */
NOINLINE static void wave_texture(const int *a, double *reg)
{
    int bands = a[9], rings = a[10], profile = a[11];
    float scale = (float)reg[a[2]], distortion = (float)reg[a[3]], detail = (float)reg[a[4]];
    float dscale = (float)reg[a[5]], droughness = (float)reg[a[6]], phase = (float)reg[a[7]];
    float p[3], n;
    for (int k = 0; k < 3; k++) p[k] = ((float)reg[a[1] + k] * scale + 0.000001f) * 0.999999f;
    if (a[8] == 0) n = bands == 3 ? (p[0] + p[1] + p[2]) * 10.0f : p[bands] * 20.0f;
    else {
        float r[3] = {p[0], p[1], p[2]};
        if (rings != 3) r[rings] = 0.0f;
        n = sqrtf(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) * 20.0f;
    }
    n += phase;
    if (distortion != 0.0f) {
        float q[3] = {p[0] * dscale, p[1] * dscale, p[2] * dscale};
        n += distortion * (perlin_fbm(q, 3, detail, droughness, 2.0f, 1) * 2.0f - 1.0f);
    }
    float f;
    if (profile == 0) f = 0.5f + 0.5f * (float)sin((double)(n - 1.570796327f));
    else if (profile == 1) { n /= 6.283185307f; f = n - floorf(n); }
    else { n /= 6.283185307f; f = fabsf(n - floorf(n + 0.5f)) * 2.0f; }
    double *out = reg + a[0];
    out[0] = out[1] = out[2] = out[3] = (double)f;
}
