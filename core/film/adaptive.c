/* Adaptive sampling: core/film/adaptive.py unconverged, one pass over the image instead of numpy's twenty. */

/* The first k in 0 .. p with pixels[k] >= i (pixels ascending). */
INLINE int64_t first_at_least(const int64_t *pixels, int64_t p, int64_t i)
{
    int64_t lo = 0, hi = p;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (pixels[mid] < i) lo = mid + 1; else hi = mid;
    }
    return lo;
}

/* Whether pixels (p,) int64 are distinct flat indices of an image of `size` pixels, ascending. */
SIMD_CLONES NOINLINE static int64_t ascending(const AscendingArgs *a)
{
    const int64_t *pixels = a->pixels;
    if (a->p == 0) return 1;
    int64_t ascending = pixels[0] >= 0 && pixels[a->p - 1] < a->size;
    for (int64_t k = 1; k < a->p; k++) ascending &= pixels[k] > pixels[k - 1];
    return ascending;
}

/* The contrast of each pixel x of a row to a neighbour, both sampled (else 0): to x - 1 in the same
 * row (`up` NULL: c[x] for x >= 1, c[0] = 0) or to x in the row `up` (c[x] for every x). m, n: the
 * row's means and counts; up, n_up: the other row's. In SIMD lanes. */
SIMD_CLONES NOINLINE static void contrast_lanes(int64_t width, const double *restrict m,
                                                                 const int64_t *restrict n,
                                                                 const double *restrict up,
                                                                 const int64_t *restrict n_up, double *restrict c)
{
    if (up == NULL) {
        c[0] = 0.0;
        for (int64_t x = 1; x < width; x++)
            c[x] = ((n[x] > 0) & (n[x - 1] > 0)) ? contrast(m[x], m[x - 1]) : 0.0;
    } else {
        for (int64_t x = 0; x < width; x++)
            c[x] = ((n[x] > 0) & (n_up[x] > 0)) ? contrast(m[x], up[x]) : 0.0;
    }
}

/* e[x] = the largest of e[x] and c[x] (a NaN c leaves e), for x < n. */
INLINE void raise_to(int64_t n, double *restrict e, const double *restrict c)
{
    for (int64_t x = 0; x < n; x++) e[x] = at_least(c[x], e[x]);
}

/* The pixels of rows y0 .. y1 - 1 that need another pass (adaptive.unconverged): a subset of
 * `pixels`, in their order. Rows can be decided apart (the threads of a render take a band each):
 * a pixel's answer reads its neighbours' noise flags, and their edges read the means one row further,
 * so the work covers the rows y0 - 2 .. y1 + 1, the window, and decides only y0 .. y1 - 1.
 * total (H W, 4), squares (H W, 2) float64 and count (H W,) int64 are the running sums; pixels
 * (p,) int64 the region's pixels, ascending; first the first pass's size (0: no edge test).
 * known_error, known_mean (H W,) float64: every sampled pixel's pixel_error and pixel_mean, as
 * primer_add_pixels keeps them (else NULL: worked out here, for the window).
 * Scratch, one value per pixel of the window (at most (y1 - y0 + 4) W): error and mean float64,
 * noisy and grown uint8; row (W,) float64. Out: wanted (at most p) int64; returns how many.
 * Where the window's pixels are all of one run (a first pass over every pixel), the loops run over
 * the run itself instead of the list, in SIMD lanes. */
SIMD_CLONES NOINLINE static int64_t unconverged(const UnconvergedArgs *args)
{
    /* (what the loops below read, once: the flags they write as bytes could be any field to the compiler) */
    const int64_t width = args->width, height = args->height, p = args->p, first = args->first;
    const int64_t *pixels = args->pixels, *count = args->count;
    const double threshold = args->threshold;
    double *error = args->error, *row = args->row;
    uint8_t *noisy = args->noisy, *grown = args->grown;
    /* 0. The window (rows a .. b - 1, pixels base .. base + size - 1) and the region's pixels in it;
     *    scratch is indexed from base. */
    int64_t y0 = args->y0 > 0 ? args->y0 : 0, y1 = args->y1 < height ? args->y1 : height;
    int64_t a = y0 - 2 > 0 ? y0 - 2 : 0, b = y1 + 2 < height ? y1 + 2 : height;
    int64_t base = a * width, size = (b - a) * width;
    int64_t k0 = first_at_least(pixels, p, base), k1 = first_at_least(pixels, p, base + size);
    if (k0 == k1 || y0 >= y1) return 0;
    /* The region's pixels in the window are lo .. hi - 1 (from base) when they form one run. */
    int64_t lo = pixels[k0] - base, hi = pixels[k1 - 1] - base + 1;
    int run = hi - lo == k1 - k0;
    /* 1. Noisy pixels of the region: their noise as kept, or worked out (every pixel from the first
     *    to the last at once); the same for the window's means. noise_of and mean_of start at base. */
    const double *noise_of = args->known_error != NULL ? args->known_error + base : error;
    const double *mean_of = args->known_mean != NULL ? args->known_mean + base : args->mean;
    if (args->known_error == NULL)
        noise_lanes(pixels[k0], pixels[k1 - 1] + 1, args->total, args->squares, count, args->weights, error + lo);
    if (first > 0 && args->known_mean == NULL)
        mean_lanes(base, base + size, args->total, count, args->weights, args->mean);
    for (int64_t i = 0; i < size; i++) noisy[i] = 0;
    if (run)
        for (int64_t i = lo; i < hi; i++) noisy[i] = noise_of[i] > threshold;
    else
        for (int64_t k = k0; k < k1; k++) noisy[pixels[k] - base] = noise_of[pixels[k] - base] > threshold;
    /* 2. Pixels with only the first pass's samples beside an edge (a contrast to a neighbour, both
     *    sampled, above threshold * first): each pair's contrast once, then each pixel's largest (the
     *    largest of non-negative numbers, in whatever order). */
    if (first > 0) {
        double *edge = error;                  /* (the noise is used up) */
        for (int64_t i = 0; i < size; i++) edge[i] = 0.0;
        for (int64_t y = a; y < b; y++) {
            const double *m = mean_of + (y - a) * width;
            const int64_t *n = count + y * width;
            double *e = edge + (y - a) * width;
            contrast_lanes(width, m, n, NULL, NULL, row);          /* across: (x - 1, x) */
            raise_to(width, e, row);
            raise_to(width - 1, e, row + 1);
            if (y == a) continue;
            contrast_lanes(width, m, n, m - width, n - width, row);     /* down: (y - 1, y) */
            raise_to(width, e, row);
            raise_to(width, e - width, row);
        }
        double limit = threshold * (double)first;
        const int64_t *counts = count + base;
        if (run)
            for (int64_t i = lo; i < hi; i++) noisy[i] |= (counts[i] <= first) & (edge[i] > limit);
        else
            for (int64_t k = k0; k < k1; k++) {
                int64_t i = pixels[k] - base;
                if (counts[i] <= first && edge[i] > limit) noisy[i] = 1;
            }
    }
    /* 3. Grow by one pixel in each of the 8 directions (columns, then rows), for rows y0 .. y1 - 1;
     *    keep the region's. */
    for (int64_t y = y0; y < y1; y++) {
        int64_t i0 = (y - a) * width;
        const uint8_t *above = y > 0 ? noisy + i0 - width : noisy + i0;
        const uint8_t *below = y + 1 < height ? noisy + i0 + width : noisy + i0;
        for (int64_t x = 0; x < width; x++) grown[i0 + x] = noisy[i0 + x] | above[x] | below[x];
    }
    for (int64_t y = y0; y < y1; y++) {
        const uint8_t *g = grown + (y - a) * width;
        uint8_t *out = noisy + (y - a) * width;      /* (reused: rows y0 - 1 and y1 are read no more) */
        out[0] = g[0] | (width > 1 ? g[1] : 0);
        for (int64_t x = 1; x + 1 < width; x++) out[x] = g[x - 1] | g[x] | g[x + 1];
        if (width > 1) out[width - 1] = g[width - 2] | g[width - 1];
    }
    int64_t r = 0, from = y0 * width - base, to = y1 * width - base;
    if (run) {
        for (int64_t i = lo > from ? lo : from; i < (hi < to ? hi : to); i++) {
            args->wanted[r] = base + i;
            r += noisy[i];
        }
        return r;
    }
    for (int64_t k = first_at_least(pixels, p, y0 * width); k < p && pixels[k] < y1 * width; k++)
        if (noisy[pixels[k] - base]) args->wanted[r++] = pixels[k];
    return r;
}

