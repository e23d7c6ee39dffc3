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
