/* Cycles' Perlin noise and its fractals in float: core/materials/procedural/perlin.py, operation for operation.
 * Points are float arrays of d = 1..4 components. */

/* perlin.py fade */
INLINE float perlin_fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

/* perlin.py lerp: Cycles' mix. */
INLINE float perlin_lerp(float a, float b, float t) { return a + t * (b - a); }

/* perlin.py gradient: the dot product of hash h's gradient with the offset f (d components). */
INLINE float perlin_gradient(uint32_t h, const float *f, int d)
{
    if (d == 1) {
        h &= 15u;
        float g = 1.0f + (float)(h & 7u);
        return ((h & 8u) ? -g : g) * f[0];
    }
    if (d == 2) {
        h &= 7u;
        float u = h < 4u ? f[0] : f[1], v = 2.0f * (h < 4u ? f[1] : f[0]);
        return ((h & 1u) ? -u : u) + ((h & 2u) ? -v : v);
    }
    if (d == 3) {
        h &= 15u;
        float u = h < 8u ? f[0] : f[1], vt = (h == 12u || h == 14u) ? f[0] : f[2], v = h < 4u ? f[1] : vt;
        return ((h & 1u) ? -u : u) + ((h & 2u) ? -v : v);
    }
    h &= 31u;
    float u = h < 24u ? f[0] : f[1], v = h < 16u ? f[1] : f[2], s = h < 8u ? f[2] : f[3];
    return ((h & 1u) ? -u : u) + ((h & 2u) ? -v : v) + ((h & 4u) ? -s : s);
}

/* The value at the lattice corner cell + offset (offset's bit k: +1 along axis k). */
INLINE float perlin_corner(const int *cell, const float *frac, int d, int offset)
{
    uint32_t c[4];
    float f[4];
    for (int k = 0; k < d; k++) {
        int one = (offset >> k) & 1;
        c[k] = (uint32_t)(cell[k] + one);
        f[k] = one ? frac[k] - 1.0f : frac[k];
    }
    uint32_t h = d == 1 ? hash_uint(c[0]) : d == 2 ? hash_uint2(c[0], c[1]) : d == 3 ? hash_uint3(c[0], c[1], c[2])
                                                                           : hash_uint4(c[0], c[1], c[2], c[3]);
    return perlin_gradient(h, f, d);
}

/* perlin.py perlin: the corners blended along the axes order[0] (innermost) .. order[d - 1] (outermost). */
INLINE float perlin(const float *p, int d)
{
    int cell[4];
    float frac[4], faded[4], values[16];
    for (int k = 0; k < d; k++) {
        float fl = floorf(p[k]);
        cell[k] = (int)fl;
        frac[k] = p[k] - fl;
        faded[k] = perlin_fade(frac[k]);
    }
    static const int orders[5][4] = {{0}, {0}, {0, 1}, {0, 1, 2}, {3, 0, 1, 2}};
    const int *order = orders[d];
    /* values[j]: the corner whose offset along order[0], order[1], ... is bit 0, 1, ... of j. */
    int corners = 1 << d;
    for (int j = 0; j < corners; j++) {
        int offset = 0;
        for (int k = 0; k < d; k++) offset |= ((j >> k) & 1) << order[k];
        values[j] = perlin_corner(cell, frac, d, offset);
    }
    for (int k = 0; k < d; k++) {
        int half = corners >> (k + 1);
        for (int j = 0; j < half; j++) values[j] = perlin_lerp(values[2 * j], values[2 * j + 1], faded[order[k]]);
    }
    return values[0];
}

/* Cycles' wrap of a coordinate at 100000 (fmodf is exact; below the period it returns x itself, without the call). */
INLINE float perlin_wrap(float x)
{
    float wrapped = fabsf(x) < 100000.0f ? x : fmodf(x, 100000.0f);
    return wrapped + (fabsf(x) >= 1000000.0f ? 0.5f : 0.0f);
}

/* perlin.py snoise in D dimensions, D a constant: the lattice loops unrolled by the compiler. */
#define PERLIN_SNOISE_OF(D, SCALE)                                                                                   \
    NOINLINE static float perlin_snoise_##D(const float *p)                                                          \
    {                                                                                                                \
        float q[4] = {0.0f, 0.0f, 0.0f, 0.0f};                                                                       \
        for (int k = 0; k < D; k++) q[k] = perlin_wrap(p[k]);                                                        \
        return SCALE * perlin(q, D);                                                                                 \
    }
PERLIN_SNOISE_OF(1, 0.25f)
PERLIN_SNOISE_OF(2, 0.6616f)
PERLIN_SNOISE_OF(3, 0.9820f)
PERLIN_SNOISE_OF(4, 0.8344f)

/* perlin.py snoise: p's d (1..4) components wrapped as Cycles wraps them, Perlin noise there, scaled per d. */
INLINE float perlin_snoise(const float *p, int d)
{
    return d == 3 ? perlin_snoise_3(p) : d == 2 ? perlin_snoise_2(p) : d == 1 ? perlin_snoise_1(p) : perlin_snoise_4(p);
}

/* snoise at p x s (each component). */
INLINE float perlin_snoise_scaled(const float *p, float s, int d)
{
    float q[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int k = 0; k < d; k++) q[k] = s * p[k];
    return perlin_snoise(q, d);
}

/* perlin.py fbm */
INLINE float perlin_fbm(const float *p, int d, float detail, float roughness, float lacunarity, int normalize)
{
    float fscale = 1.0f, amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
    for (int i = 0; i <= (int)detail; i++) {
        float t = perlin_snoise_scaled(p, fscale, d);
        sum += t * amp;
        maxamp += amp;
        amp *= roughness;
        fscale *= lacunarity;
    }
    float rmd = detail - floorf(detail);
    if (rmd != 0.0f) {
        float t = perlin_snoise_scaled(p, fscale, d);
        float sum2 = sum + t * amp;
        return normalize ? perlin_lerp(0.5f * sum / maxamp + 0.5f, 0.5f * sum2 / (maxamp + amp) + 0.5f, rmd)
                         : perlin_lerp(sum, sum2, rmd);
    }
    return normalize ? 0.5f * sum / maxamp + 0.5f : sum;
}

/* p *= s in place. */
INLINE void perlin_scale(float *p, float s, int d) { for (int k = 0; k < d; k++) p[k] *= s; }

/* perlin.py multifractal */
INLINE float perlin_multifractal(const float *point, int d, float detail, float roughness, float lacunarity)
{
    float p[4] = {0.0f, 0.0f, 0.0f, 0.0f}, value = 1.0f, pwr = 1.0f;
    memcpy(p, point, sizeof(float) * (size_t)d);
    for (int i = 0; i <= (int)detail; i++) {
        value *= (pwr * perlin_snoise(p, d) + 1.0f);
        pwr *= roughness;
        perlin_scale(p, lacunarity, d);
    }
    float rmd = detail - floorf(detail);
    if (rmd != 0.0f) value *= (rmd * pwr * perlin_snoise(p, d) + 1.0f);
    return value;
}

/* perlin.py hetero_terrain */
INLINE float perlin_hetero_terrain(const float *point, int d, float detail, float roughness, float lacunarity,
                                   float offset)
{
    float p[4] = {0.0f, 0.0f, 0.0f, 0.0f}, pwr = roughness;
    memcpy(p, point, sizeof(float) * (size_t)d);
    float value = offset + perlin_snoise(p, d);
    perlin_scale(p, lacunarity, d);
    for (int i = 1; i <= (int)detail; i++) {
        float increment = (perlin_snoise(p, d) + offset) * pwr * value;
        value += increment;
        pwr *= roughness;
        perlin_scale(p, lacunarity, d);
    }
    float rmd = detail - floorf(detail);
    if (rmd != 0.0f) {
        float increment = (perlin_snoise(p, d) + offset) * pwr * value;
        value += rmd * increment;
    }
    return value;
}

/* perlin.py hybrid_multifractal */
INLINE float perlin_hybrid_multifractal(const float *point, int d, float detail, float roughness, float lacunarity,
                                        float offset, float gain)
{
    float p[4] = {0.0f, 0.0f, 0.0f, 0.0f}, pwr = 1.0f, value = 0.0f, weight = 1.0f;
    memcpy(p, point, sizeof(float) * (size_t)d);
    for (int i = 0; (weight > 0.001f) && (i <= (int)detail); i++) {
        weight = weight < 1.0f ? weight : 1.0f;
        float signal = (perlin_snoise(p, d) + offset) * pwr;
        pwr *= roughness;
        value += weight * signal;
        weight *= gain * signal;
        perlin_scale(p, lacunarity, d);
    }
    float rmd = detail - floorf(detail);
    if ((rmd != 0.0f) && (weight > 0.001f)) {
        weight = weight < 1.0f ? weight : 1.0f;
        float signal = (perlin_snoise(p, d) + offset) * pwr;
        value += rmd * weight * signal;
    }
    return value;
}

/* perlin.py ridged_multifractal */
INLINE float perlin_ridged_multifractal(const float *point, int d, float detail, float roughness, float lacunarity,
                                        float offset, float gain)
{
    float p[4] = {0.0f, 0.0f, 0.0f, 0.0f}, pwr = roughness;
    memcpy(p, point, sizeof(float) * (size_t)d);
    float signal = offset - fabsf(perlin_snoise(p, d));
    signal *= signal;
    float value = signal;
    for (int i = 1; i <= (int)detail; i++) {
        perlin_scale(p, lacunarity, d);
        float weight = signal * gain;
        weight = weight < 0.0f ? 0.0f : (weight > 1.0f ? 1.0f : weight);
        signal = offset - fabsf(perlin_snoise(p, d));
        signal *= signal;
        signal *= weight;
        value += signal * pwr;
        pwr *= roughness;
    }
    return value;
}

/* perlin.py fractal: the fractal of NOISE_TYPES[kind]. */
NOINLINE static float perlin_fractal(int kind, const float *p, int d, float detail, float roughness, float lacunarity,
                            float offset, float gain, int normalize)
{
    switch (kind) {
    case 0: return perlin_multifractal(p, d, detail, roughness, lacunarity);
    case 1: return perlin_fbm(p, d, detail, roughness, lacunarity, normalize);
    case 2: return perlin_hybrid_multifractal(p, d, detail, roughness, lacunarity, offset, gain);
    case 3: return perlin_ridged_multifractal(p, d, detail, roughness, lacunarity, offset, gain);
    default: return perlin_hetero_terrain(p, d, detail, roughness, lacunarity, offset);
    }
}
