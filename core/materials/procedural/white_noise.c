/* core/materials/procedural/white_noise.py WhiteNoiseTexture.evaluate at one hit: a[0] the output block (Value,
 * Color), a[1] Vector, a[2] W, a[3] the dimensions - 1. */
INLINE void white_noise_texture(const int *a, double *reg)
{
    float x = (float)reg[a[1]], y = (float)reg[a[1] + 1], z = (float)reg[a[1] + 2], w = (float)reg[a[2]];
    float r[4];
    switch (a[3]) {
    case 0: r[0] = hash_float(w); r[1] = r[0]; r[2] = hash_float2(w, 1.0f); r[3] = hash_float2(w, 2.0f); break;
    case 1:
        r[0] = hash_float2(x, y); r[1] = r[0]; r[2] = hash_float3(x, y, 1.0f); r[3] = hash_float3(x, y, 2.0f);
        break;
    case 2:
        r[0] = hash_float3(x, y, z); r[1] = r[0];
        r[2] = hash_float4(x, y, z, 1.0f); r[3] = hash_float4(x, y, z, 2.0f);
        break;
    default:
        r[0] = hash_float4(x, y, z, w); r[1] = r[0];
        r[2] = hash_float4(z, x, w, y); r[3] = hash_float4(w, z, y, x);
        break;
    }
    double *out = reg + a[0];
    for (int k = 0; k < 4; k++) out[k] = (double)r[k];
}
