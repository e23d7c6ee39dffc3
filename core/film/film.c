/* The film: core/film/film.py and the noise estimates of core/film/adaptive.py, per pixel.
 *
 * A chunk's samples go straight into their pixels' sums (RGBA, and for adaptive sampling the squared
 * luminance and alpha); the chunk that adds a pixel's samples to the film renews its noise estimate. */

/* The largest float32 (film.py FILM_MAX): the image is float32, so a sample beyond it is infinite there. */
#define FILM_MAX 3.4028234663852886e38

/* x, or 0 where it is NaN or beyond the float32 film (a sample's channel of an auxiliary sum, as film.py's). */
INLINE double finite_or_zero(double x)
{
    return fabs(x) <= FILM_MAX ? x : 0.0;
}

/* Add a sample's RGBA s to its pixel's sums: sum (4,), and its squared luminance and alpha to
 * squares (2,) unless squares is NULL. */
INLINE void add_sample(const double *s, const double *luminance, double *sum, double *squares)
{
    for (int c = 0; c < 4; c++) sum[c] += s[c];
    if (squares != NULL) {
        double y = luminance[0] * s[0] + luminance[1] * s[1] + luminance[2] * s[2];
        squares[0] += y * y;
        squares[1] += s[3] * s[3];
    }
}

/* Adaptive sampling's noise estimate of one pixel (core/film/adaptive.py), shared with adaptive.c. */

#define DARK 0.1                /* core/film/adaptive.py */

/* Luminance of an RGBA sum (adaptive.LUMINANCE), summed in numpy's einsum order. */
INLINE double luminance_of(const double *rgba, const double *weights)
{
    return rgba[0] * weights[0] + rgba[1] * weights[1] + rgba[2] * weights[2];
}

/* adaptive.edge_contrast's relative difference of two neighbours' mean luminances. */
INLINE double contrast(double a, double b)
{
    return fabs(a - b) / sqrt((0.5 * (a + b)) * (0.5 * (a + b)) + DARK * DARK);
}

/* adaptive.relative_noise of pixel i, without branches (so that loops over pixels vectorise). */
INLINE double pixel_error(int64_t i, const double *restrict total, const double *restrict squares,
                          const int64_t *restrict count, const double *w)
{
    double n = (double)(int32_t)count[i];     /* (through int32, which SIMD converts: counts are small) */
    double luminance = luminance_of(total + 4 * i, w) / n, alpha = total[4 * i + 3] / n;
    double variance_y = at_least(squares[2 * i] / n - luminance * luminance, 0.0) * n / (n - 1.0);
    double variance_a = at_least(squares[2 * i + 1] / n - alpha * alpha, 0.0) * n / (n - 1.0);
    double error_y = sqrt(variance_y / n) / sqrt(luminance * luminance + DARK * DARK);
    double error_a = sqrt(variance_a / n);
    double larger = error_y > error_a ? error_y : error_a;
    larger = ((error_y != error_y) | (error_a != error_a)) ? NAN : larger;     /* np.maximum keeps NaN */
    return n >= 2.0 ? larger : INFINITY;
}

/* Pixel i's mean luminance over max(count, 1) samples (adaptive.edge_contrast's). */
INLINE double pixel_mean(int64_t i, const double *restrict total, const int64_t *restrict count, const double *w)
{
    double n = (double)(int32_t)count[i];
    return luminance_of(total + 4 * i, w) / (n > 1.0 ? n : 1.0);
}

/* pixel_error of pixels lo .. hi - 1 into error[i - lo]. */
SIMD_CLONES NOINLINE static void noise_lanes(int64_t lo, int64_t hi, const double *restrict total,
                                                              const double *restrict squares,
                                                              const int64_t *restrict count,
                                                              const double *restrict weights,
                                                              double *restrict error)
{
    double w[3] = {weights[0], weights[1], weights[2]};
    for (int64_t i = lo; i < hi; i++) error[i - lo] = pixel_error(i, total, squares, count, w);
}

/* pixel_mean of pixels lo .. hi - 1 into mean[i - lo]. */
SIMD_CLONES NOINLINE static void mean_lanes(int64_t lo, int64_t hi, const double *restrict total,
                                                             const int64_t *restrict count,
                                                             const double *restrict weights, double *restrict mean)
{
    double w[3] = {weights[0], weights[1], weights[2]};
    for (int64_t i = lo; i < hi; i++) mean[i - lo] = pixel_mean(i, total, count, w);
}

/* Add a chunk's per-pixel sums into the render's running sums, in place (Film.add):
 * rgba (p, 4), squares (p, 2) float64 and hits (p,) int64 of pixels (p,) int64, spp samples each,
 * into total (H W, 4), squares_sum (H W, 2) float64, count and hits_sum (H W,) int64. With error
 * and mean (H W,) float64 (else NULL), also the pixels' new pixel_error and pixel_mean, which the
 * noise test between passes then reads instead of working them out for every pixel itself. The
 * chunks of a pass have pixels of their own, so the threads rendering them may add at the same time. */
static void add_pixels(const AddPixelsArgs *a)
{
    int64_t p = a->p;
    const int64_t *pixels = a->pixels;
    for (int64_t k = 0; k < p; k++) {
        int64_t i = pixels[k];
        for (int c = 0; c < 4; c++) a->total[4 * i + c] += a->rgba[4 * k + c];
        a->squares_sum[2 * i] += a->squares[2 * k];
        a->squares_sum[2 * i + 1] += a->squares[2 * k + 1];
        a->count[i] += a->spp;
        a->hits_sum[i] += a->hits[k];
    }
    if (a->error == NULL || a->mean == NULL || p == 0) return;
    /* A run of neighbouring pixels (a first pass's chunk) in SIMD lanes; any others one by one. */
    int64_t run = 1;
    while (run < p && pixels[run] == pixels[0] + run) run++;
    if (run == p) {
        noise_lanes(pixels[0], pixels[0] + p, a->total, a->squares_sum, a->count, a->weights, a->error + pixels[0]);
        mean_lanes(pixels[0], pixels[0] + p, a->total, a->count, a->weights, a->mean + pixels[0]);
        return;
    }
    double w[3] = {a->weights[0], a->weights[1], a->weights[2]};
    for (int64_t k = 0; k < p; k++) {
        a->error[pixels[k]] = pixel_error(pixels[k], a->total, a->squares_sum, a->count, w);
        a->mean[pixels[k]] = pixel_mean(pixels[k], a->total, a->count, w);
    }
}

/* The image from the running sums: each pixel's mean over max(count, 1) samples (Film.image's
 * box filter). total (n, 4) float64, count (n,) int64 -> out (n, 4) float32. */
static void resolve_rows(const ResolveArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        double samples = (double)(a->count[i] > 1 ? a->count[i] : 1);
        for (int c = 0; c < 4; c++) a->out[4 * i + c] = (float)(a->total[4 * i + c] / samples);
    }
}

