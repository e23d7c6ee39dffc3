/* core/materials/procedural/noise.py NoiseTexture.evaluate at one hit: a[0] the output block (Fac, Color), a[1]
 * Vector, a[2] W, a[3] Scale, a[4] Detail, a[5] Roughness, a[6] Lacunarity, a[7] Offset, a[8] Gain, a[9] Distortion;
 * a[10] the dimensions - 1, a[11] the fractal (perlin.NOISE_TYPES), a[12] normalize, a[13] 1: Color is read. */

/* noise.py random_offset: the seed's offset in [100, 200] along each of d axes. */
INLINE void noise_random_offset(float seed, int d, float *out)
{
    if (d == 1) { out[0] = 100.0f + hash_float(seed) * 100.0f; return; }
    for (int k = 0; k < d; k++) out[k] = 100.0f + hash_float2(seed, (float)k) * 100.0f;
}

/* The fractal at p + the seed's offset. */
INLINE float noise_at_offset(const float *p, int d, float seed, int kind, float detail, float roughness,
                             float lacunarity, float offset, float gain, int normalize)
{
    float shift[4] = {0.0f, 0.0f, 0.0f, 0.0f}, q[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    noise_random_offset(seed, d, shift);
    for (int k = 0; k < d; k++) q[k] = p[k] + shift[k];
    return perlin_fractal(kind, q, d, detail, roughness, lacunarity, offset, gain, normalize);
}

NOINLINE static void noise_texture(const int *a, double *reg)
{
    int d = a[10] + 1, kind = a[11], normalize = a[12];
    float scale = (float)reg[a[3]], detail = (float)reg[a[4]], roughness = (float)reg[a[5]];
    float lacunarity = (float)reg[a[6]], offset = (float)reg[a[7]], gain = (float)reg[a[8]];
    float distortion = (float)reg[a[9]];
    detail = detail < 0.0f ? 0.0f : (detail > 15.0f ? 15.0f : detail);
    roughness = roughness > 0.0f ? roughness : 0.0f;
    float v[3], w = (float)reg[a[2]] * scale, p[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int k = 0; k < 3; k++) v[k] = (float)reg[a[1] + k] * scale;
    if (d == 1) p[0] = w;
    else { for (int k = 0; k < d && k < 3; k++) p[k] = v[k]; if (d == 4) p[3] = w; }
    if (distortion != 0.0f) {
        float shift[4] = {0.0f, 0.0f, 0.0f, 0.0f}, q[4] = {0.0f, 0.0f, 0.0f, 0.0f}, moved[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        for (int j = 0; j < d; j++) {
            noise_random_offset((float)j, d, shift);
            for (int k = 0; k < d; k++) q[k] = p[k] + shift[k];
            moved[j] = perlin_snoise(q, d) * distortion;
        }
        for (int k = 0; k < d; k++) p[k] += moved[k];
    }
    float value = perlin_fractal(kind, p, d, detail, roughness, lacunarity, offset, gain, normalize);
    double *out = reg + a[0];
    out[0] = (double)value;
    out[1] = out[2] = out[3] = 0.0;
    if (a[13]) {
        out[1] = (double)value;
        out[2] = (double)noise_at_offset(p, d, (float)d, kind, detail, roughness, lacunarity, offset, gain, normalize);
        out[3] = (double)noise_at_offset(p, d, (float)(d + 1), kind, detail, roughness, lacunarity, offset, gain,
                                         normalize);
    }
}
