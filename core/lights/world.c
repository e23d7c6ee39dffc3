/* The world: core/lights/world.py. A constant colour, or an equirectangular image importance-sampled
 * by a map of its brightness x sin(theta). */

/* world.direction_to_uv of a unit direction already in texture space, and sin theta of its row (sin(pi v), as
 * sqrt(1 - z^2): one libm call fewer than the reference's sine). */
INLINE void world_uv(const double *d, double *u, double *v, double *sin_theta)
{
    double z = d[2] < -1.0 ? -1.0 : (d[2] > 1.0 ? 1.0 : d[2]);
    *u = (PI - atan2(d[1], d[0])) / (2.0 * PI);
    *v = 1.0 - acos(z) / PI;
    *sin_theta = sqrt((1.0 - z) * (1.0 + z));
}

/* world.uv_to_direction, and sin theta of the direction. */
INLINE void world_direction(double u, double v, double *d, double *sin_theta)
{
    double phi = PI - 2.0 * PI * u, theta = PI * (1.0 - v);
    *sin_theta = sin(theta);
    d[0] = *sin_theta * cos(phi);
    d[1] = *sin_theta * sin(phi);
    d[2] = cos(theta);
}

/* The rotation world -> texture (R D), and back (R^T D). */
INLINE void world_to_texture(const WorldTables *w, const double *D, double *out)
{
    const double *R = w->rotation;
    for (int c = 0; c < 3; c++) out[c] = R[3 * c] * D[0] + R[3 * c + 1] * D[1] + R[3 * c + 2] * D[2];
}

/* world.bilinear_equirect: linear interpolation, texel centres at (i + 0.5) / W, u repeats, v extends. */
INLINE void world_lookup(const WorldTables *w, double u, double v, double *out)
{
    int64_t W = (int64_t)w->width, H = (int64_t)w->height;
    double x = u * (double)W - 0.5, y = v * (double)H - 0.5;
    double x0 = floor(x), y0 = floor(y), fx = x - x0, fy = y - y0;
    int64_t xa = ((int64_t)x0 % W + W) % W, xb = (((int64_t)x0 + 1) % W + W) % W;
    int64_t ya = (int64_t)y0, yb = (int64_t)y0 + 1;
    ya = ya < 0 ? 0 : (ya > H - 1 ? H - 1 : ya);
    yb = yb < 0 ? 0 : (yb > H - 1 ? H - 1 : yb);
    const float *p = w->image;
    for (int c = 0; c < 3; c++) {
        double top = (double)p[3 * (ya * W + xa) + c] * (1.0 - fx) + (double)p[3 * (ya * W + xb) + c] * fx;
        double bottom = (double)p[3 * (yb * W + xa) + c] * (1.0 - fx) + (double)p[3 * (yb * W + xb) + c] * fx;
        out[c] = top * (1.0 - fy) + bottom * fy;
    }
}

/* World.radiance at texture coordinates u, v: the image's bilinear texel times the strength. */
INLINE void world_radiance_uv(const WorldTables *w, double u, double v, double *out)
{
    world_lookup(w, u, v, out);
    for (int c = 0; c < 3; c++) out[c] *= w->strength;
}

/* WorldLight.pdf of a direction in map cell (x, y) whose sin theta is given: f / (total 2 pi^2 sin theta). */
INLINE double world_cell_pdf(const WorldTables *w, int64_t x, int64_t y, double sin_theta)
{
    return sin_theta > 0.0 ? w->map[y * (int64_t)w->map_width + x] / (w->total * 2.0 * PI * PI * sin_theta) : 0.0;
}

/* WorldLight.pdf at texture coordinates u, v of a direction whose sin theta is given (its map cell's). */
INLINE double world_pdf_uv(const WorldTables *w, double u, double v, double sin_theta)
{
    int64_t mw = (int64_t)w->map_width, mh = (int64_t)w->map_height;
    int64_t x = (int64_t)(u * (double)mw), y = (int64_t)(v * (double)mh);
    x = x < 0 ? 0 : (x > mw - 1 ? mw - 1 : x);
    y = y < 0 ? 0 : (y > mh - 1 ? mh - 1 : y);
    return world_cell_pdf(w, x, y, sin_theta);
}

/* World.radiance: the radiance arriving from direction D (world space). */
INLINE void world_radiance(const WorldTables *w, const double *D, double *out)
{
    if (w->image == NULL) {
        for (int c = 0; c < 3; c++) out[c] = w->color[c];
        return;
    }
    double local[3], u, v, sin_theta;
    world_to_texture(w, D, local);
    world_uv(local, &u, &v, &sin_theta);
    world_radiance_uv(w, u, v, out);
}

/* WorldLight.pdf of direction D (world space). */
INLINE double world_pdf(const WorldTables *w, const double *D)
{
    double local[3], u, v, sin_theta;
    world_to_texture(w, D, local);
    world_uv(local, &u, &v, &sin_theta);
    return world_pdf_uv(w, u, v, sin_theta);
}

/* World.radiance and WorldLight.pdf of direction D together (a BSDF ray that escapes, weighed by MIS): one
 * conversion to texture coordinates for both where the world is an image. */
INLINE double world_radiance_pdf(const WorldTables *w, const double *D, double *out)
{
    if (w->image == NULL) {
        for (int c = 0; c < 3; c++) out[c] = w->color[c];
        return world_pdf(w, D);
    }
    double local[3], u, v, sin_theta;
    world_to_texture(w, D, local);
    world_uv(local, &u, &v, &sin_theta);
    world_radiance_uv(w, u, v, out);
    return world_pdf_uv(w, u, v, sin_theta);
}

/* WorldLight.sample for u (2,): a row by the marginal distribution, a column within it. */
INLINE void sample_world(const WorldTables *w, const double *u, LightSample *out)
{
    int64_t mw = (int64_t)w->map_width, mh = (int64_t)w->map_height;
    int64_t lo = 0, hi = mh;                             /* the last row with rows[y] <= u0 */
    while (hi - lo > 1) { int64_t mid = lo + (hi - lo) / 2; if (w->rows[mid] <= u[0]) lo = mid; else hi = mid; }
    int64_t y = lo;
    double dy = (u[0] - w->rows[y]) / at_least(w->rows[y + 1] - w->rows[y], 1e-300);
    const double *row = w->columns + y * (mw + 1);
    int64_t below = 0, above = mw + 1;                   /* how many entries of the row are <= u1 (binary search) */
    while (above > below) { int64_t mid = below + (above - below) / 2; if (row[mid] <= u[1]) below = mid + 1; else above = mid; }
    int64_t x = below - 1;
    x = x < 0 ? 0 : (x > mw - 1 ? mw - 1 : x);
    double dx = (u[1] - row[x]) / at_least(row[x + 1] - row[x], 1e-300);
    dx = dx < 0.0 ? 0.0 : (dx > 1.0 ? 1.0 : dx);
    dy = dy < 0.0 ? 0.0 : (dy > 1.0 ? 1.0 : dy);
    double uu = ((double)x + dx) / (double)mw, vv = ((double)y + dy) / (double)mh;
    double local[3], sin_theta;
    world_direction(uu, vv, local, &sin_theta);
    const double *R = w->rotation;                       /* back from texture space: R^T */
    for (int c = 0; c < 3; c++) out->L[c] = R[c] * local[0] + R[3 + c] * local[1] + R[6 + c] * local[2];
    double pdf = world_cell_pdf(w, x, y, sin_theta);
    out->pdf = pdf;
    out->strength = pdf > 0.0 ? 1.0 / pdf : 0.0;
    out->distance = INFINITY;
    if (w->image != NULL)                                /* (the radiance at the sampled u, v: no way back through L) */
        world_radiance_uv(w, uu, vv, out->color);
    else
        world_radiance(w, out->L, out->color);
    out->position[0] = out->position[1] = out->position[2] = 0.0;
}

/* The table's entries (lights.gen.c): WorldLight.sample; rays find the world where they escape, not here. */
INLINE void world_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                         const double *u, LightSample *out)
{
    (void)light; (void)P; (void)N;
    sample_world(ctx->world, u, out);
}

INLINE int world_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    (void)light; (void)O; (void)D; (void)t_max; (void)out;
    return 0;
}

/* A map row's running sums cdf (w + 1) divided by their total `sum` where it is positive (world.running_sums). */
INLINE void normalise_sums(double *cdf, int64_t w, double sum)
{
    double scale = sum > 0.0 ? sum : 1.0;
    for (int64_t j = 0; j <= w; j++) cdf[j] /= scale;
}

/* world.WorldLight.of's map, rows row_start .. row_end - 1: each cell's value linear between the texel centres of
 * the one-channel image (u repeats, v extends) times its row's sine, the row's running sums normalised to 1 (where
 * positive) and its total; the same operations in the same order as world.bilinear_grid and numpy's cumsum. Without
 * `columns` (a map that compensated_rows changes next) only the values and totals. Each column's texels and weight
 * are the same in every row: found once. */
static void world_map_rows(const WorldMapArgs *a)
{
    int64_t W = a->width, H = a->height, w = a->map_width, h = a->map_height;
    int64_t *left = (int64_t *)malloc((size_t)(2 * w) * sizeof(int64_t)), *right = left + w;
    double *weight = (double *)malloc((size_t)w * sizeof(double));
    if (left == NULL || weight == NULL) { free(left); free(weight); return; }
    for (int64_t j = 0; j < w; j++) {
        double x = ((double)j + 0.5) / (double)w * (double)W - 0.5;
        double x0 = floor(x);
        weight[j] = x - x0;
        left[j] = ((int64_t)x0 % W + W) % W;
        right[j] = (((int64_t)x0 + 1) % W + W) % W;
    }
    for (int64_t i = a->row_start; i < a->row_end; i++) {
        double y = ((double)i + 0.5) / (double)h * (double)H - 0.5;
        double y0 = floor(y), fy = y - y0;
        int64_t ya = (int64_t)y0, yb = (int64_t)y0 + 1;
        ya = ya < 0 ? 0 : (ya > H - 1 ? H - 1 : ya);
        yb = yb < 0 ? 0 : (yb > H - 1 ? H - 1 : yb);
        const double *top = a->values + ya * W, *bottom = a->values + yb * W;
        double *f = a->map + i * w, sum = 0.0;
        double *cdf = a->columns != NULL ? a->columns + i * (w + 1) : NULL;
        if (cdf != NULL) cdf[0] = 0.0;
        for (int64_t j = 0; j < w; j++) {
            double fx = weight[j];
            double upper = top[left[j]] * (1.0 - fx) + top[right[j]] * fx;
            double lower = bottom[left[j]] * (1.0 - fx) + bottom[right[j]] * fx;
            f[j] = (upper * (1.0 - fy) + lower * fy) * a->sines[i];
            sum += f[j];
            if (cdf != NULL) cdf[j + 1] = sum;
        }
        a->totals[i] = sum;
        if (cdf != NULL) normalise_sums(cdf, w, sum);
    }
    free(left);
    free(weight);
}

/* world.compensated_map, rows row_start .. row_end - 1 in place: each value less `less` times its row's sine,
 * floored at 0, and the row's running sums and total as world_map_rows makes them (numpy's operations, in order). */
static void compensated_rows(const CompensatedMapArgs *a)
{
    int64_t w = a->map_width;
    for (int64_t i = a->row_start; i < a->row_end; i++) {
        double *f = a->map + i * w, *cdf = a->columns + i * (w + 1), sum = 0.0, shift = a->less * a->sines[i];
        cdf[0] = 0.0;
        for (int64_t j = 0; j < w; j++) {
            double g = f[j] - shift;
            f[j] = g > 0.0 ? g : 0.0;
            sum += f[j];
            cdf[j + 1] = sum;
        }
        a->totals[i] = sum;
        normalise_sums(cdf, w, sum);
    }
}
