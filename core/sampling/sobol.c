/* The sample pattern: core/sampling/sobol.py, bit for bit.
 *
 * The index-th point of a pixel's own progressive pattern in the unit square: one Sobol
 * (0,2)-sequence, its order shuffled and each coordinate Owen-scrambled (Burley's hash-based
 * scrambling), with a key per (seed, pixel, dimension). */

INLINE uint32_t hash_u32(uint32_t x)
{
    uint32_t state = x * 747796405u + 2891336453u;
    uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

INLINE uint32_t reverse_bits(uint32_t x)
{
    /* Swap neighbouring bits, pairs and nibbles, then the four bytes in one instruction. */
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    return BYTE_SWAP(x);
}

INLINE uint32_t laine_karras(uint32_t x, uint32_t seed)
{
    x += seed;
    x ^= x * 0x6C50B47Cu;
    x ^= x * 0xB82F1E52u;
    x ^= x * 0xC7AFE638u;
    x ^= x * 0x8D22F6E6u;
    return x;
}

INLINE uint32_t sobol_y_mirrored(uint32_t y)
{
    y ^= (y >> 1) & 0x55555555u;
    y ^= (y >> 2) & 0x33333333u;
    y ^= (y >> 4) & 0x0F0F0F0Fu;
    y ^= (y >> 8) & 0x00FF00FFu;
    y ^= (y >> 16) & 0x0000FFFFu;
    return y;
}

INLINE uint32_t combine_seed(uint32_t seed, uint32_t value)
{
    return seed ^ (value + (seed << 6) + (seed >> 2));
}

/* The stream of (seed, dimension): sobol._pixel_key before the pixel is mixed in. */
INLINE uint32_t stream_of(int64_t seed, int64_t dimension)
{
    return hash_u32((uint32_t)((uint64_t)seed * 0x9E3779B9ull + (uint64_t)dimension * 0x85EBCA6Bull));
}

/* The index-th point of a pixel's progressive pattern: sobol.sample_2d for one sample. */
INLINE void sample_2d(uint32_t stream, int64_t pixel, int64_t index, double *u)
{
    uint32_t key = hash_u32((uint32_t)pixel ^ stream);
    uint32_t shuffled = reverse_bits(laine_karras(reverse_bits((uint32_t)index), key));
    uint32_t x = reverse_bits(laine_karras(shuffled, combine_seed(key, 1)));
    uint32_t y = reverse_bits(laine_karras(sobol_y_mirrored(shuffled), combine_seed(key, 2)));
    u[0] = x * (1.0 / 4294967296.0);
    u[1] = y * (1.0 / 4294967296.0);
}

/* sample_2d for n <= BLOCK samples in SIMD lanes: pixel, index (n,) their keys -> x, y (n,) the point. */
SIMD_CLONES NOINLINE static void sample_lanes(int64_t n, uint32_t stream, const uint32_t *restrict pixel,
                                              const uint32_t *restrict index, double *restrict x,
                                              double *restrict y)
{
    for (int64_t k = 0; k < n; k++) {
        uint32_t key = hash_u32(pixel[k] ^ stream);
        uint32_t shuffled = reverse_bits(laine_karras(reverse_bits(index[k]), key));
        x[k] = reverse_bits(laine_karras(shuffled, combine_seed(key, 1))) * (1.0 / 4294967296.0);
        y[k] = reverse_bits(laine_karras(sobol_y_mirrored(shuffled), combine_seed(key, 2))) * (1.0 / 4294967296.0);
    }
}

/* sample_lanes' first coordinates alone (x (n,)), where the second would go unused: the same numbers. */
SIMD_CLONES NOINLINE static void sample_lanes_x(int64_t n, uint32_t stream, const uint32_t *restrict pixel,
                                                const uint32_t *restrict index, double *restrict x)
{
    for (int64_t k = 0; k < n; k++) {
        uint32_t key = hash_u32(pixel[k] ^ stream);
        uint32_t shuffled = reverse_bits(laine_karras(reverse_bits(index[k]), key));
        x[k] = reverse_bits(laine_karras(shuffled, combine_seed(key, 1))) * (1.0 / 4294967296.0);
    }
}

/* sobol.sample_2d over arrays: pixel, index (n,) int64 -> out (n, 2) float64 (for the tests). */
static void sample_2d_rows(const Sample2dArgs *a)
{
    uint32_t stream = stream_of(a->seed, a->dimension);
    for (int64_t i = 0; i < a->n; i++)
        sample_2d(stream, a->pixel[i], a->index[i], a->out + 2 * i);
}
