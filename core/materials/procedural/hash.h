/* Cycles' hash functions (util/hash.h) for the procedural textures: core/materials/procedural/hash.py.
 * lookup3's final (and mix for four words) on uint32_t; a float hashes by its bits; a hash becomes a float in
 * [0, 1] as (float)h x 2^-32. */

#define LOOKUP3_ROT(x, k) (((x) << (k)) | ((x) >> (32 - (k))))

/* hash.py _final: lookup3's final mix; returns c. */
INLINE uint32_t lookup3_final(uint32_t a, uint32_t b, uint32_t c)
{
    c ^= b; c -= LOOKUP3_ROT(b, 14);
    a ^= c; a -= LOOKUP3_ROT(c, 11);
    b ^= a; b -= LOOKUP3_ROT(a, 25);
    c ^= b; c -= LOOKUP3_ROT(b, 16);
    a ^= c; a -= LOOKUP3_ROT(c, 4);
    b ^= a; b -= LOOKUP3_ROT(a, 14);
    c ^= b; c -= LOOKUP3_ROT(b, 24);
    return c;
}

INLINE uint32_t hash_uint(uint32_t kx)
{
    uint32_t a = 0xdeadbeefu + (1u << 2) + 13u;
    return lookup3_final(a + kx, a, a);
}

INLINE uint32_t hash_uint2(uint32_t kx, uint32_t ky)
{
    uint32_t a = 0xdeadbeefu + (2u << 2) + 13u;
    return lookup3_final(a + kx, a + ky, a);
}

INLINE uint32_t hash_uint3(uint32_t kx, uint32_t ky, uint32_t kz)
{
    uint32_t a = 0xdeadbeefu + (3u << 2) + 13u;
    return lookup3_final(a + kx, a + ky, a + kz);
}

/* hash.py hash_uint4: lookup3's mix of three words, then final with the fourth. */
INLINE uint32_t hash_uint4(uint32_t kx, uint32_t ky, uint32_t kz, uint32_t kw)
{
    uint32_t init = 0xdeadbeefu + (4u << 2) + 13u, a = init + kx, b = init + ky, c = init + kz;
    a -= c; a ^= LOOKUP3_ROT(c, 4); c += b;
    b -= a; b ^= LOOKUP3_ROT(a, 6); a += c;
    c -= b; c ^= LOOKUP3_ROT(b, 8); b += a;
    a -= c; a ^= LOOKUP3_ROT(c, 16); c += b;
    b -= a; b ^= LOOKUP3_ROT(a, 19); a += c;
    c -= b; c ^= LOOKUP3_ROT(b, 4); b += a;
    return lookup3_final(a + kw, b, c);
}

#undef LOOKUP3_ROT

/* hash.py uint_to_float */
INLINE float hash_to_float(uint32_t h) { return (float)h * (1.0f / 4294967296.0f); }

/* hash.py float_bits */
INLINE uint32_t float_bits(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

INLINE float hash_float(float x) { return hash_to_float(hash_uint(float_bits(x))); }
INLINE float hash_float2(float x, float y) { return hash_to_float(hash_uint2(float_bits(x), float_bits(y))); }
INLINE float hash_float3(float x, float y, float z)
{
    return hash_to_float(hash_uint3(float_bits(x), float_bits(y), float_bits(z)));
}
INLINE float hash_float4(float x, float y, float z, float w)
{
    return hash_to_float(hash_uint4(float_bits(x), float_bits(y), float_bits(z), float_bits(w)));
}

/* hash.py hash_pcg: PCG on d = 2..4 words, wrapping at 32 bits, the shift by 16 sign-extending; then [0, 2^31). */
INLINE void hash_pcg(const int *k, int d, uint32_t *v)
{
    for (int j = 0; j < d; j++) v[j] = (uint32_t)k[j] * 1664525u + 1013904223u;
    for (int round = 0; round < 2; round++) {
        if (d == 2) { v[0] += v[1] * 1664525u; v[1] += v[0] * 1664525u; }
        else if (d == 3) { v[0] += v[1] * v[2]; v[1] += v[2] * v[0]; v[2] += v[0] * v[1]; }
        else { v[0] += v[1] * v[3]; v[1] += v[2] * v[0]; v[2] += v[0] * v[1]; v[3] += v[1] * v[2]; }
        if (round == 0)
            for (int j = 0; j < d; j++) v[j] ^= (uint32_t)((int32_t)v[j] >> 16);
    }
    for (int j = 0; j < d; j++) v[j] &= 0x7FFFFFFFu;
}

/* hash.py hash_int_to_float: out (d) in [0, 1]. */
INLINE void hash_int_to_float(const int *k, int d, float *out)
{
    uint32_t v[4] = {0u, 0u, 0u, 0u};
    hash_pcg(k, d, v);
    for (int j = 0; j < d; j++) out[j] = (float)v[j] * (1.0f / 2147483648.0f);
}

/* hash.py hash_int_to_float3 */
INLINE void hash_int_to_float3(const int *k, int d, float *out)
{
    int k3[4] = {k[0], k[1], d > 2 ? k[2] : 0, d > 3 ? k[3] : 0};
    float f[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    hash_int_to_float(k3, d == 2 ? 3 : d, f);
    out[0] = f[0]; out[1] = f[1]; out[2] = f[2];
}
