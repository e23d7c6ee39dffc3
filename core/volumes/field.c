/* Heterogeneous media: core/volumes/field.py, one ray at a time.
 *
 * A heterogeneous medium's node graph (graph.c run_program) runs at points inside it (`field_at`: Field.at), and a
 * ray's stretch through the media is cut into pieces (`march_of`: field.py March): piece 0 before the box of the
 * heterogeneous media, at most MAX_PIECES pieces inside it (each with its midpoint's coefficients: of at most
 * field_step within the fine box, doubling in length away from it), the last after it. The march is the proposal
 * (free flight, its pdfs); its estimates are made unbiased as field.py's: residual ratio tracking for every
 * transmittance (`march_track`, `march_transmittance`), the true coefficients at sampled points (`march_true_at`), a
 * uniform share where it has a hole (`march_share`), and the emission's control variate corrected at one point
 * (`march_emitted`). The same constants (STEPS_ACROSS, MAX_PIECES, MAX_DOUBLINGS, TRACKING_SAFETY, UNIFORM_SHARE,
 * KEY_GRID, EMISSION_DRAW) and the same sums as the Python, and each ray's walks drawn from the same stream (its
 * key), so the kernels agree to rounding but where a ray's key differs. */

/* The pieces of one ray O + s D over [0, t): `n` pieces (K + 2), their ends edges[0..n], each piece's extinction,
 * scattering and emission (3) and anisotropy-weighted scattering, and the optical depth tau (3) at each end. */
typedef struct {
    int n;
    double edges[MAX_PIECES + 3];
    double sigma_t[MAX_PIECES + 2][3], sigma_s[MAX_PIECES + 2][3], emission[MAX_PIECES + 2][3];
    double gs[MAX_PIECES + 2];
    double tau[MAX_PIECES + 3][3];
    /* Residual ratio tracking (march_track; tracked 0: none, as March.uniform): the media and the ray, the
     * homogeneous part, each piece's midpoint, control slope (3) and majorant, the majorant's integral M at each
     * edge, and the ray's stream key. */
    int tracked;
    const MediaTables *media;
    VolumeStack stack;
    /* The fields the ray is in (its stack's and the world's, in the chain's order) and how many times: the march's
     * loops over them, not the whole chain (a render may have a field per object: media.py per_object). */
    const VolumeField *in[MAX_MEDIA + 1];
    double in_count[MAX_MEDIA + 1];
    int in_n;
    double O[3], D[3], hom_t[3], hom_s[3], hom_e[3], hom_gs;
    double mid[MAX_PIECES + 2], slope[MAX_PIECES + 2][3], mu[MAX_PIECES + 2], M[MAX_PIECES + 3];
    double eslope[MAX_PIECES + 2][3];    /* the emission's control slope (March.emitted) */
    double share;                        /* March.uniform_share: UNIFORM_SHARE where the march has a hole, else 0 */
    uint64_t key;
} March;

/* tracking.py mix: splitmix64's finaliser. */
INLINE uint64_t tracking_mix(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* tracking.py ray_keys for one ray: its origin's and direction's coordinates on a grid of KEY_GRID mixed in turn. */
INLINE uint64_t tracking_key(const double *O, const double *D)
{
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int c = 0; c < 6; c++) {
        double x = floor((c < 3 ? O[c] : D[c - 3]) * KEY_GRID);
        x = x < -KEY_LIMIT ? -KEY_LIMIT : (x > KEY_LIMIT ? KEY_LIMIT : x);
        h = tracking_mix(h ^ (uint64_t)(int64_t)x);
    }
    return h;
}

/* tracking.py stream: the i-th uniform number in [0, 1) of the stream `key`. */
INLINE double tracking_u(uint64_t key, int64_t i)
{
    uint64_t z = tracking_mix(key + 0x9E3779B97F4A7C15ull * (uint64_t)(i + 1));
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

/* grids.taps: the voxels grid g interpolates object-space point local (3) from (8 trilinear, 64 tricubic): their
 * weights (0 outside the grid's box) and values' pointers (NULL outside) into weight[64], value[64]; returns
 * how many. */
static int grid_taps(const VolumeField *f, int g, const double *local, double *weight, const float **value)
{
    const double *row = f->grid_table + GRID_COLUMNS * g, *m = row + 8;
    const float *values = f->voxels + (int64_t)row[0];
    int64_t dims[3] = {(int64_t)row[1], (int64_t)row[2], (int64_t)row[3]}, C = (int64_t)row[4], base[3];
    int cubic = row[20] != 0.0, taps = cubic ? 4 : 2;
    double w[3][4];
    for (int r = 0; r < 3; r++) {
        double P = (((local[0] * m[4 * r] + local[1] * m[4 * r + 1]) + local[2] * m[4 * r + 2]) + m[4 * r + 3])
                   - row[5 + r];
        double b = floor(P), t = P - b;
        base[r] = (int64_t)b - cubic;
        if (cubic) {                                    /* (grids.cubic_weights) */
            w[r][0] = (((-1.0 / 6.0) * t + 0.5) * t - 0.5) * t + (1.0 / 6.0);
            w[r][1] = ((0.5 * t - 1.0) * t) * t + (2.0 / 3.0);
            w[r][2] = ((-0.5 * t + 0.5) * t + 0.5) * t + (1.0 / 6.0);
            w[r][3] = (1.0 / 6.0) * t * t * t;
        } else {
            w[r][0] = 1.0 - t;
            w[r][1] = t;
        }
    }
    for (int corner = 0; corner < taps * taps * taps; corner++) {
        int o[3] = {corner / (taps * taps), (corner / taps) % taps, corner % taps};
        int64_t index[3];
        int inside = 1;
        for (int r = 0; r < 3; r++) {
            index[r] = base[r] + o[r];
            inside &= index[r] >= 0 && index[r] < dims[r];
        }
        weight[corner] = inside ? (w[0][o[0]] * w[1][o[1]]) * w[2][o[2]] : 0.0;
        value[corner] = inside ? values + ((index[0] * dims[1] + index[1]) * dims[2] + index[2]) * C : NULL;
    }
    return taps * taps * taps;
}

/* grids.sample: grid g's RGBA (4) at object-space point local (3): trilinear over the voxels around its index point
 * (a tricubic B-spline over 4^3 where the grid is cubic), 0 outside the grid's box, alpha 1. */
static void grid_sample(const VolumeField *f, int g, const double *local, double *rgba)
{
    double weight[64], sum[3] = {0.0, 0.0, 0.0};
    const float *value[64];
    int C = (int)f->grid_table[GRID_COLUMNS * g + 4], n = grid_taps(f, g, local, weight, value);
    for (int k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) sum[c] += weight[k] * (value[k] ? (double)value[k][C == 3 ? c : 0] : 0.0);
    for (int c = 0; c < 3; c++) rgba[c] = sum[c];
    rgba[3] = 1.0;
}

/* Field.coordinates and the volume shading point Field.at runs its program at: the camera-relative point P (3) in
 * world space, its Generated and Object coordinates, a volume-scatter path; its object's Object Info (VolumeField.info,
 * random: the placement and zeros, or for a medium kept per object that object's own row and random number). */
INLINE void field_point(const VolumeField *f, const double *P, ShadingPoint *sp)
{
    double world[3], local[3];
    for (int c = 0; c < 3; c++) world[c] = P[c] + f->origin[c];
    for (int r = 0; r < 3; r++)
        local[r] = ((world[0] * f->matrix[4 * r] + world[1] * f->matrix[4 * r + 1]) + world[2] * f->matrix[4 * r + 2])
                   + f->matrix[4 * r + 3];
    sp->width = 6 + GRID_WIDTH * f->grid_count;
    for (int k = 0; k < sp->width; k++) sp->attributes[k] = sp->d_du[k] = sp->d_dv[k] = 0.0;
    for (int g = 0; g < f->grid_count; g++) grid_sample(f, g, local, sp->attributes + 6 + GRID_WIDTH * g);
    for (int c = 0; c < 3; c++) {
        sp->attributes[c] = (f->size[c] != 0.0 ? (local[c] - f->location[c]) / (2.0 * f->size[c]) : 0.0) + 0.5;
        sp->attributes[3 + c] = local[c];
        sp->N[c] = sp->Ng[c] = sp->I[c] = c == 2;
        sp->dPdu[c] = c == 0;
        sp->dPdv[c] = c == 1;
        sp->P[c] = world[c];
    }
    for (int c = 0; c < 9; c++) sp->L[c] = f->linear[c];
    sp->info = f->info;
    sp->info_width = f->info_width;
    sp->rays = NULL;                                    /* (a medium's graph traces nothing) */
    sp->random = f->random;
    sp->side = 1.0;
    LightPath path = {PATH_VOLUME_SCATTER, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
    sp->path = path;
    sp->u = sp->v = 0.0;
    sp->t = 0.0;
}

/* One closure's input `row` (VOLUME_INPUT_*) at the point: its register's floats (a narrower register repeated),
 * else its constant, into v (3). */
INLINE void field_input(const VolumeField *f, int64_t k, int row, const double *reg, double *v)
{
    const double *in = f->inputs + 5 * (VOLUME_INPUTS * k + row);
    int register_ = (int)in[0], width = (int)in[1];
    for (int c = 0; c < 3; c++) v[c] = register_ < 0 ? in[2 + c] : reg[register_ + (c < width ? c : 0)];
}

/* HG's anisotropy as the closures clamp it: |g| <= 1 - 1e-3. */
INLINE double clamp_anisotropy(double g)
{
    double limit = 1.0 - 1e-3, a = fabs(g) < limit ? fabs(g) : limit;
    return g > 0.0 ? a : (g < 0.0 ? -a : 0.0);
}


/* Field.at at one camera-relative point P (3): the medium's sigma_a, sigma_s, emission (3) and gs (the closures'
 * anisotropies times their scattering), each closure as field.closure_at; mix not NULL: also Field.phase_at, each
 * closure that scatters there added to the mixture *mix as a lobe (its phase function set up from its inputs there,
 * weight `count` x its sigma_s summed over channels) while it has room (PHASE_LOBES). */
static void field_at(const VolumeField *f, const double *P, double *sigma_a, double *sigma_s, double *emission,
                     double *gs, Phase *mix, double count)
{
    ShadingPoint sp;
    double reg[MAX_REGISTERS];
    field_point(f, P, &sp);
    run_program(f->graph, 0, &sp, NULL, reg);
    for (int c = 0; c < 3; c++) sigma_a[c] = sigma_s[c] = emission[c] = 0.0;
    *gs = 0.0;
    for (int64_t k = 0; k < (int64_t)f->closures; k++) {
        double w = f->weights[k], a[3] = {0.0, 0.0, 0.0}, s[3] = {0.0, 0.0, 0.0}, e[3] = {0.0, 0.0, 0.0}, g = 0.0;
        double color[3], density[3], x[3], y[3];
        int kind = f->kinds[k];
        field_input(f, k, VOLUME_INPUT_COLOR, reg, color);
        field_input(f, k, VOLUME_INPUT_DENSITY, reg, density);
        double d = w * (density[0] > 0.0 ? density[0] : 0.0);
        if (kind == VOLUME_CLOSURE_COEFFICIENTS) {
            field_input(f, k, VOLUME_INPUT_ABSORPTION, reg, x);
            field_input(f, k, VOLUME_INPUT_SCATTER, reg, y);
            field_input(f, k, VOLUME_INPUT_EMISSION, reg, e);
            for (int c = 0; c < 3; c++) { a[c] = w * x[c]; s[c] = w * y[c]; e[c] = w * e[c]; }
            field_input(f, k, VOLUME_INPUT_ANISOTROPY, reg, x);
            g = clamp_anisotropy(x[0]);
        } else if (kind == VOLUME_CLOSURE_EMISSION) {
            field_input(f, k, VOLUME_INPUT_STRENGTH, reg, x);
            for (int c = 0; c < 3; c++) e[c] = (w * x[0]) * color[c];
        } else if (kind == VOLUME_CLOSURE_ABSORPTION) {
            for (int c = 0; c < 3; c++) a[c] = d * (1.0 - color[c]);
        } else if (kind == VOLUME_CLOSURE_SCATTER) {
            field_input(f, k, VOLUME_INPUT_ANISOTROPY, reg, x);
            g = clamp_anisotropy(x[0]);
            for (int c = 0; c < 3; c++) s[c] = d * color[c];
        } else {                                        /* Principled Volume (svm_node_principled_volume) */
            field_input(f, k, VOLUME_INPUT_ANISOTROPY, reg, x);
            g = clamp_anisotropy(x[0]);
            field_input(f, k, VOLUME_INPUT_ABSORPTION_COLOR, reg, x);
            for (int c = 0; c < 3; c++) {
                double absorption = sqrt(x[c] > 0.0 ? x[c] : 0.0);
                s[c] = d > 0.0 ? color[c] * d : 0.0;
                a[c] = d > 0.0 ? ((1.0 - color[c] > 0.0 ? 1.0 - color[c] : 0.0)
                                  * (1.0 - absorption > 0.0 ? 1.0 - absorption : 0.0)) * d : 0.0;
            }
            field_input(f, k, VOLUME_INPUT_EMISSION_STRENGTH, reg, x);
            field_input(f, k, VOLUME_INPUT_EMISSION_COLOR, reg, y);
            for (int c = 0; c < 3; c++) e[c] = x[0] > 0.0 ? (w * x[0]) * y[c] : 0.0;
            field_input(f, k, VOLUME_INPUT_BLACKBODY_INTENSITY, reg, x);
            field_input(f, k, VOLUME_INPUT_TEMPERATURE, reg, y);
            double amount = x[0], odds[64];
            const float *voxel[64];
            /* (a Temperature Attribute's grid, which Cycles looks up stochastically: the voxels' glows averaged) */
            int hot = f->hot[k], taps = hot >= 0 ? grid_taps(f, hot, sp.attributes + 3, odds, voxel) : 1;
            for (int j = 0; j < taps && amount > 0.0; j++) {
                double v = hot >= 0 ? (voxel[j] ? (double)voxel[j][0] : 0.0) : 1.0;
                double t = hot >= 0 ? y[0] * (v > 0.0 ? v : 0.0) : y[0];
                t = t > 0.0 ? t : 0.0;
                double intensity = STEFAN_BOLTZMANN * (1.0 + amount * (pow(t, 4.0) - 1.0));
                if (intensity > 0.0) {                      /* (a black body's glow, tinted) */
                    double tint[3], bb[3];
                    field_input(f, k, VOLUME_INPUT_BLACKBODY_TINT, reg, tint);
                    blackbody_unclipped((float)t, bb);
                    for (int c = 0; c < 3; c++) {
                        double glow = (tint[c] * intensity) * bb[c];
                        e[c] = e[c] + w * (hot >= 0 ? odds[j] * glow : glow);
                    }
                }
            }
        }
        double share = 1.0;                             /* (linked Mix Shader factors above it) */
        for (int64_t j = 0; j < (int64_t)f->factor_count; j++) {
            const double *row = f->factors + 3 * j;
            if ((int64_t)row[0] != k) continue;
            double v = reg[(int)row[1]];
            v = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
            share = share * (row[2] != 0.0 ? v : 1.0 - v);
        }
        double part = g * ((s[0] + s[1]) + s[2]);
        double weight = count * ((s[0] * share + s[1] * share) + s[2] * share);
        if (mix != NULL && weight > 0.0 && mix->lobes < PHASE_LOBES) {   /* (Field.phase_at: set up here) */
            double an[3], io[3], bs[3], al[3], di[3];
            Phase one;
            field_input(f, k, VOLUME_INPUT_ANISOTROPY, reg, an);
            field_input(f, k, VOLUME_INPUT_IOR, reg, io);
            field_input(f, k, VOLUME_INPUT_BACKSCATTER, reg, bs);
            field_input(f, k, VOLUME_INPUT_ALPHA, reg, al);
            field_input(f, k, VOLUME_INPUT_DIAMETER, reg, di);
            phase_setup(f->phases[k], an[0], io[0], bs[0], al[0], di[0], &one);
            mix->kinds[mix->lobes] = one.kind;
            for (int c = 0; c < PHASE_PARAMETERS; c++) mix->lobe[mix->lobes][c] = one.p[c];
            mix->weight[mix->lobes++] = weight;
        }
        for (int c = 0; c < 3; c++) {
            sigma_a[c] += a[c] * share;
            sigma_s[c] += s[c] * share;
            emission[c] += e[c] * share;
        }
        *gs += part * share;
    }
}

/* How many times a ray with the volume stack `stack` is in the field f: its column's count, 1 in the world's
 * (column -1: every ray, Media.along). */
INLINE double field_count(const VolumeField *f, const VolumeStack *stack)
{
    return f->column < 0 ? 1.0 : (double)stack_count(stack, f->column);
}

/* Whether a ray with the volume stack `stack` is in a heterogeneous medium (Stretch.varying). */
INLINE int in_field(const MediaTables *media, const VolumeStack *stack)
{
    for (const VolumeField *f = media != NULL ? media->fields : NULL; f != NULL; f = f->next)
        if (field_count(f, stack) > 0.0) return 1;
    return 0;
}

/* March.track for one ray's K inner pieces: each inner piece's midpoint, control slope (central, one-sided at the
 * box's ends, 0 for a lone piece) and majorant (TRACKING_SAFETY x the largest second difference over the channels,
 * a boundary piece its neighbour's, at least 1 / the stretch in the box), M at the edges, the stream key. */
static void march_track(March *m, int K)
{
    double d2[MAX_PIECES + 2];
    for (int j = 0; j < m->n; j++) {
        m->mid[j] = 0.5 * (m->edges[j] + m->edges[j + 1]);
        m->mu[j] = 0.0;
        d2[j] = 0.0;
        for (int c = 0; c < 3; c++) m->slope[j][c] = m->eslope[j][c] = 0.0;
    }
    for (int j = 1; j <= K; j++) {
        int left = j >= 2, right = j + 1 <= K;
        for (int c = 0; c < 3; c++) {
            double (*s)[3] = m->sigma_t;
            m->slope[j][c] = left && right ? (s[j + 1][c] - s[j - 1][c]) / (m->mid[j + 1] - m->mid[j - 1])
                             : right ? (s[j + 1][c] - s[j][c]) / (m->mid[j + 1] - m->mid[j])
                             : left ? (s[j][c] - s[j - 1][c]) / (m->mid[j] - m->mid[j - 1]) : 0.0;
            double (*e)[3] = m->emission;
            m->eslope[j][c] = left && right ? (e[j + 1][c] - e[j - 1][c]) / (m->mid[j + 1] - m->mid[j - 1])
                              : right ? (e[j + 1][c] - e[j][c]) / (m->mid[j + 1] - m->mid[j])
                              : left ? (e[j][c] - e[j - 1][c]) / (m->mid[j] - m->mid[j - 1]) : 0.0;
            if (left && right) {
                double x = (s[j + 1][c] - s[j][c]) - (s[j][c] - s[j - 1][c]);
                x = x < 0.0 ? -x : x;
                d2[j] = x > d2[j] ? x : d2[j];
            }
        }
    }
    double spread[MAX_PIECES + 2];
    for (int j = 1; j <= K; j++) spread[j] = d2[j];
    if (K >= 3) { spread[1] = d2[2]; spread[K] = d2[K - 1]; }
    double a = m->edges[1], b = m->edges[K + 1], floor_ = b > a ? 1.0 / (b - a) : 0.0;
    for (int j = 1; j <= K; j++) {
        double mu = TRACKING_SAFETY * spread[j];
        m->mu[j] = b > a ? (mu > floor_ ? mu : floor_) : 0.0;
    }
    m->M[0] = 0.0;
    for (int j = 0; j < m->n; j++) {
        double width = m->edges[j + 1] - m->edges[j];
        m->M[j + 1] = m->M[j] + (m->mu[j] > 0.0 ? m->mu[j] * width : 0.0);
    }
    m->key = tracking_key(m->O, m->D);
    m->tracked = 1;
    int hole = 0;                         /* (an inner piece of no extinction at its midpoint: March.track) */
    for (int j = 1; j <= K; j++)
        hole |= m->sigma_t[j][0] <= 0.0 && m->sigma_t[j][1] <= 0.0 && m->sigma_t[j][2] <= 0.0
                && m->edges[j + 1] - m->edges[j] > 0.0;
    m->share = hole && b > a ? UNIFORM_SHARE : 0.0;
}

/* March.fields_at: the media's true coefficients at distance x along the march's ray: extinction, scattering (3)
 * and the anisotropy-weighted scattering returned (the homogeneous part plus each field's times the ray's count). */
static double march_fields_at(const March *m, double x, double *sigma_t, double *sigma_s)
{
    double P[3], sa[3] = {0.0, 0.0, 0.0}, ss[3] = {0.0, 0.0, 0.0}, sg = 0.0;
    for (int c = 0; c < 3; c++) P[c] = m->O[c] + x * m->D[c];
    for (int i = 0; i < m->in_n; i++) {
        const VolumeField *f = m->in[i];
        double count = m->in_count[i], fa[3], fs[3], fe[3], fg;
        field_at(f, P, fa, fs, fe, &fg, NULL, 0.0);
        for (int c = 0; c < 3; c++) { sa[c] += count * fa[c]; ss[c] += count * fs[c]; }
        sg += count * fg;
    }
    for (int c = 0; c < 3; c++) { sigma_t[c] = m->hom_t[c] + (sa[c] + ss[c]); sigma_s[c] = m->hom_s[c] + ss[c]; }
    return m->hom_gs + sg;
}

/* March.fields_at's emission (3) at distance x along the march's ray (the homogeneous part plus each field's). */
static void march_fields_emission(const March *m, double x, double *emission)
{
    double P[3], se[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < 3; c++) P[c] = m->O[c] + x * m->D[c];
    for (int i = 0; i < m->in_n; i++) {
        const VolumeField *f = m->in[i];
        double count = m->in_count[i], fa[3], fs[3], fe[3], fg;
        field_at(f, P, fa, fs, fe, &fg, NULL, 0.0);
        for (int c = 0; c < 3; c++) se[c] += count * fe[c];
    }
    for (int c = 0; c < 3; c++) emission[c] = m->hom_e[c] + se[c];
}

/* field.py doublings: the fewest pieces doubling from step (step, 2 step, 4 step, ...) that cover the length gap. */
INLINE int doublings(double gap, double step)
{
    int k = 0;
    for (int i = 0; i < MAX_DOUBLINGS; i++) k += step * (ldexp(1.0, k) - 1.0) < gap;
    return k;
}

/* The span [near, far] of the line O + t D (3 each) inside the box low .. high (3 each), by slabs: near > far where
 * it misses; a slab the line runs along (0 x inf) is no bound. */
INLINE void box_span(const double *O, const double *D, const double *low, const double *high, double *near,
                     double *far)
{
    *near = -INFINITY;
    *far = INFINITY;
    for (int c = 0; c < 3; c++) {
        double inverse = 1.0 / D[c];
        double t0 = (low[c] - O[c]) * inverse, t1 = (high[c] - O[c]) * inverse;
        double lo = t0 < t1 ? t0 : t1, hi = t0 > t1 ? t0 : t1;
        lo = lo != lo ? -INFINITY : lo;
        hi = hi != hi ? INFINITY : hi;
        *near = lo > *near ? lo : *near;
        *far = hi < *far ? hi : *far;
    }
}

/* field.py March for one ray O + s D (3 each) over [0, t) (inf: to the world) in the media `stack`, whose
 * homogeneous part is sigma_t, sigma_s, emission (3) and g (Media.along), into m. */
static void march_of(const MediaTables *media, const VolumeStack *stack, const double *O, const double *D, double t,
                     const double *sigma_t, const double *sigma_s, const double *emission, double g, March *m)
{
    /* 0. The fields the ray is in, in the chain's order (at most its stack's and the world's). */
    m->in_n = 0;
    for (const VolumeField *f = media->fields; f != NULL && m->in_n < MAX_MEDIA + 1; f = f->next) {
        double count = field_count(f, stack);
        if (!(count > 0.0)) continue;
        m->in[m->in_n] = f;
        m->in_count[m->in_n++] = count;
    }
    /* 1. Where the ray is in the media's box: [a, b) within [0, t). */
    double near, far;
    box_span(O, D, media->field_low, media->field_high, &near, &far);
    double a = near > 0.0 ? near : 0.0;
    a = a < t ? a : t;
    double b = far > a ? far : a;
    b = b < t ? b : t;
    b = isfinite(b) ? b : a;
    /* 2. The pieces inside the box, their midpoints' coefficients (the homogeneous media's added): of field_step
     *    within the fine box [c, d), doubling away from it before and after (a world medium's padding). */
    double step = media->field_step, c = a, d = b;
    box_span(O, D, media->field_fine_low, media->field_fine_high, &near, &far);
    c = near > a ? near : a;
    c = c < b ? c : b;
    d = far > c ? far : c;
    d = d < b ? d : b;
    int before = doublings(c - a, step), after = doublings(b - d, step);
    double pieces = ceil((d - c) / step), fewest = before + after > 0 ? 0.0 : 1.0;
    double most = (double)(MAX_PIECES - before - after);
    pieces = pieces < fewest ? fewest : (pieces > most ? most : pieces);
    pieces = pieces != pieces ? fewest : pieces;
    int middle = (int)pieces, K = before + middle + after;
    double length = middle > 0 ? (d - c) / pieces : 0.0, gs_h = g * ((sigma_s[0] + sigma_s[1]) + sigma_s[2]);
    double diagonal = 0.0;                         /* (the box's: the world's probes after it) */
    for (int c = 0; c < 3; c++) {
        double side = media->field_high[c] - media->field_low[c];
        diagonal += side * side;
    }
    diagonal = isfinite(diagonal) ? sqrt(diagonal) : 0.0;
    m->n = K + 2;
    m->edges[0] = 0.0;
    for (int j = 0; j < K; j++)
        m->edges[1 + j] = j == 0 ? a
                          : j < before ? c - step * (ldexp(1.0, before - j) - 1.0)
                          : j < before + middle ? c + length * (double)(j - before)
                          : d + step * (ldexp(1.0, j - before - middle) - 1.0);
    m->edges[K + 1] = b;
    m->edges[K + 2] = t;
    for (int j = 0; j < K + 2; j++) {
        double sa[3] = {0.0, 0.0, 0.0}, ss[3] = {0.0, 0.0, 0.0}, se[3] = {0.0, 0.0, 0.0}, sg = 0.0;
        /* (an outer piece of some length: the world's medium, unbounded, held at its value where the ray enters
         * the box, before it, or leaves it, after it) */
        int outer = (j == 0 && a > 0.0) || (j == K + 1 && t - b > 0.0);
        if ((j >= 1 && j <= K && b > a) || outer) {
            int fine = j - 1 >= before && j - 1 < before + middle;
            double mid = j == 0 ? a : j == K + 1 ? b
                         : fine ? c + length * ((double)(j - 1 - before) + 0.5)
                         : 0.5 * (m->edges[j] + m->edges[j + 1]), P[3];
            for (int c = 0; c < 3; c++) P[c] = O[c] + mid * D[c];
            for (int i = 0; i < m->in_n; i++) {
                const VolumeField *f = m->in[i];
                double count = m->in_count[i], fa[3], fs[3], fe[3], fg;
                if (outer && f->column >= 0) continue;
                field_at(f, P, fa, fs, fe, &fg, NULL, 0.0);
                if (outer) {                           /* (before and after the box: the probes' mean, March) */
                    for (int k = 1; k < WORLD_PROBES; k++) {
                        double Q[3], qa[3], qs[3], qe[3], qg, reach = diagonal * (pow(2.0, (double)k) - 1.0);
                        double x = j == K + 1 ? b + reach : (a - reach > 0.0 ? a - reach : 0.0);
                        for (int c = 0; c < 3; c++) Q[c] = O[c] + x * D[c];
                        field_at(f, Q, qa, qs, qe, &qg, NULL, 0.0);
                        for (int c = 0; c < 3; c++) { fa[c] += qa[c]; fs[c] += qs[c]; fe[c] += qe[c]; }
                        fg += qg;
                    }
                    for (int c = 0; c < 3; c++) {
                        fa[c] /= (double)WORLD_PROBES;
                        fs[c] /= (double)WORLD_PROBES;
                        fe[c] /= (double)WORLD_PROBES;
                    }
                    fg /= (double)WORLD_PROBES;
                }
                for (int c = 0; c < 3; c++) { sa[c] += count * fa[c]; ss[c] += count * fs[c]; se[c] += count * fe[c]; }
                sg += count * fg;
            }
        }
        int inner = (j >= 1 && j <= K) || outer;
        for (int c = 0; c < 3; c++) {
            m->sigma_t[j][c] = inner ? sigma_t[c] + (sa[c] + ss[c]) : sigma_t[c];
            m->sigma_s[j][c] = inner ? sigma_s[c] + ss[c] : sigma_s[c];
            m->emission[j][c] = inner ? emission[c] + se[c] : emission[c];
        }
        m->gs[j] = inner ? gs_h + sg : gs_h;
    }
    /* 3. The optical depth at each end. */
    for (int c = 0; c < 3; c++) m->tau[0][c] = 0.0;
    for (int j = 0; j < K + 2; j++) {
        double width = m->edges[j + 1] - m->edges[j];
        for (int c = 0; c < 3; c++)
            m->tau[j + 1][c] = m->tau[j][c] + (m->sigma_t[j][c] > 0.0 ? m->sigma_t[j][c] * width : 0.0);
    }
    /* 4. What ratio tracking corrects its estimates by. */
    m->media = media;
    m->stack = *stack;
    for (int c = 0; c < 3; c++) {
        m->O[c] = O[c];
        m->D[c] = D[c];
        m->hom_t[c] = sigma_t[c];
        m->hom_s[c] = sigma_s[c];
        m->hom_e[c] = emission[c];
    }
    m->hom_gs = gs_h;
    march_track(m, K);
}

/* March.piece: the piece distance s lies in (the last one at or past the end). */
INLINE int march_piece(const March *m, double s)
{
    int k = 0;
    for (int j = 1; j < m->n; j++) k += m->edges[j] <= s;
    return k < m->n - 1 ? k : m->n - 1;
}

/* March.transmittance: an unbiased estimate (3) of the true transmittance to distance s along the ray (inf: to its
 * end), residual ratio tracking against the control (march_track); exp(-tau(s)) of a march with no field. */
static void march_transmittance(const March *m, double s, double *T)
{
    int k = march_piece(m, s);
    if (!m->tracked) {
        for (int c = 0; c < 3; c++) {
            double sigma = m->sigma_t[k][c];
            T[c] = exp(-(m->tau[k][c] + (sigma > 0.0 ? sigma * (s - m->edges[k]) : 0.0)));
        }
        return;
    }
    double start = m->edges[k], mid = m->mid[k], half = mid - start, mu = m->mu[k];
    for (int c = 0; c < 3; c++) {         /* (March.control_depth) */
        double sigma = m->sigma_t[k][c], slope = m->slope[k][c];
        double flat = sigma > 0.0 ? sigma * (s - start) : 0.0;
        double bent = slope != 0.0 ? (0.5 * slope) * ((s - mid) * (s - mid) - half * half) : 0.0;
        T[c] = exp(-((m->tau[k][c] + flat) + bent));
    }
    double reach = m->M[k] + (mu > 0.0 ? mu * (s - start) : 0.0), target = 0.0;
    if (!(T[0] > 0.0 || T[1] > 0.0 || T[2] > 0.0)) return;     /* (the control lets nothing through: T is 0) */
    for (int64_t i = 0; reach > 0.0; i++) {
        target += -log1p(-tracking_u(m->key, i));
        if (target >= reach) break;
        int j = 0;
        for (int q = 1; q <= m->n; q++) j += m->M[q] <= target;
        j = j < m->n - 1 ? j : m->n - 1;
        double mj = m->mu[j], x = m->edges[j] + (target - m->M[j]) / mj, sigma_t[3], sigma_s[3];
        march_fields_at(m, x, sigma_t, sigma_s);
        for (int c = 0; c < 3; c++) {
            double control = m->sigma_t[j][c] + m->slope[j][c] * (x - m->mid[j]);
            T[c] *= 1.0 - (sigma_t[c] - control) / mj;
        }
    }
}

/* field.py slope_integral: the integral over y in [0, 1] of (y - 1/2) exp(-u y); the series below 1e-3. */
INLINE double slope_integral(double u)
{
    if (fabs(u) < 1e-3) return u * (-1.0 / 12.0 + u * (1.0 / 24.0 - u / 80.0));
    return (-expm1(-u) - u * exp(-u)) / (u * u) + expm1(-u) / (2.0 * u);
}

/* March.emitted: the light (3) the pieces' emission sends to the ray's start, and where an emitting field is in
 * the box the correction at one point that makes it unbiased there; added to out. */
static void march_emitted(const March *m, double *out)
{
    double total[3];
    for (int c = 0; c < 3; c++) {
        double sum = 0.0;
        for (int j = 0; j < m->n; j++) {
            double e = m->emission[j][c], sigma = m->sigma_t[j][c], width = m->edges[j + 1] - m->edges[j];
            if (e == 0.0) continue;
            double each = (sigma > 0.0 ? e * -expm1(-sigma * width) / sigma : e * width) * exp(-m->tau[j][c]);
            sum += each != each ? 0.0 : each;
        }
        total[c] = sum;
    }
    if (m->tracked) {                     /* (the control's linear part: slope_integral per inner piece) */
        for (int c = 0; c < 3; c++) {
            double sum = 0.0;
            for (int j = 1; j <= m->n - 2; j++) {
                double w = m->edges[j + 1] - m->edges[j], k = m->eslope[j][c];
                double bent = k != 0.0 ? ((k * (w * w)) * slope_integral(m->sigma_t[j][c] * w)) * exp(-m->tau[j][c])
                                       : 0.0;
                sum += bent != bent ? 0.0 : bent;
            }
            total[c] += sum;
        }
    }
    int emits = 0;
    for (int i = 0; m->tracked && i < m->in_n; i++)
        emits |= m->in[i]->emits != 0;
    double a = m->edges[1], b = m->edges[m->n - 1];
    if (emits && b > a) {
        double s = a + tracking_u(m->key, (int64_t)EMISSION_DRAW) * (b - a), T[3], e_true[3];
        march_transmittance(m, s, T);
        int k = march_piece(m, s);
        march_fields_emission(m, s, e_true);
        for (int c = 0; c < 3; c++) {
            double sigma = m->sigma_t[k][c];                /* (March.depth) */
            double tau = m->tau[k][c] + (sigma > 0.0 ? sigma * (s - m->edges[k]) : 0.0);
            double control = m->emission[k][c] + m->eslope[k][c] * (s - m->mid[k]);
            total[c] += (e_true[c] * T[c] - control * exp(-tau)) * (b - a);
        }
    }
    int last = m->n - 1;                  /* (a homogeneous medium's emission after the box: T at the box's end) */
    const double *e_last = m->emission[last];
    if (m->tracked && b > a && (e_last[0] != 0.0 || e_last[1] != 0.0 || e_last[2] != 0.0)) {
        double T[3], w = m->edges[last + 1] - m->edges[last];
        march_transmittance(m, b, T);
        for (int c = 0; c < 3; c++) {
            double e = e_last[c], sigma = m->sigma_t[last][c];
            double after = e != 0.0 ? (sigma > 0.0 ? e * -expm1(-sigma * w) / sigma : e * w) : 0.0;
            double more = after * (T[c] - exp(-m->tau[last][c]));
            total[c] += more != more ? 0.0 : more;
        }
    }
    for (int c = 0; c < 3; c++) out[c] += total[c];
}

/* What a stretch of a ray lets through: Beer-Lambert on its homogeneous extinction sigma_t (3), or its march where
 * it has one (NULL: none) (Stretch.transmittance), over distance s, into T (3). */
INLINE void stretch_transmittance(const March *m, const double *sigma_t, double s, double *T)
{
    if (m != NULL) march_transmittance(m, s, T);
    else beer_lambert(sigma_t, s, T);
}

/* volumes.emitted for a stretch of length t: its homogeneous closed form, or its march's sum; added to out. */
INLINE void stretch_emitted(const March *m, const double *sigma_t, const double *e, double t, double *out)
{
    if (m != NULL) march_emitted(m, out);
    else add_media_emission(sigma_t, e, t, out);
}

/* The march of a ray O, D over [0, t) in the media `stack` with homogeneous part sigma_t, emission (3), into m where
 * it is in a heterogeneous medium: m, else NULL (the homogeneous closed forms hold). */
static const March *stretch_march(const MediaTables *media, const VolumeStack *stack, const double *O,
                                  const double *D, double t, const double *sigma_t, const double *emission, March *m)
{
    if (media == NULL || media->fields == NULL || !in_field(media, stack)) return NULL;
    double sigma_s[3], g;
    medium_scattering(media, stack, sigma_s, &g, NULL);
    march_of(media, stack, O, D, t, sigma_t, sigma_s, emission, g, m);
    return m;
}

/* March.depth: the optical depth tau (3) from the ray's start to distance s. */
INLINE void march_depth(const March *m, double s, double *tau)
{
    int k = march_piece(m, s);
    for (int c = 0; c < 3; c++) {
        double sigma = m->sigma_t[k][c];
        tau[c] = m->tau[k][c] + (sigma > 0.0 ? sigma * (s - m->edges[k]) : 0.0);
    }
}

/* March.at: the extinction and scattering (3) of the piece at distance s, its anisotropy returned. */
INLINE double march_at(const March *m, double s, double *sigma_t, double *sigma_s)
{
    int k = march_piece(m, s);
    for (int c = 0; c < 3; c++) { sigma_t[c] = m->sigma_t[k][c]; sigma_s[c] = m->sigma_s[k][c]; }
    double total = (sigma_s[0] + sigma_s[1]) + sigma_s[2];
    return total > 0.0 ? m->gs[k] / total : 0.0;
}

/* March.true_at: the media's extinction and scattering (3) at distance s itself (not its piece's midpoint), its
 * anisotropy returned: what an estimate divides the march's pdf into. */
static double march_true_at(const March *m, double s, double *sigma_t, double *sigma_s)
{
    int k = march_piece(m, s);
    if (!m->tracked || k < 1 || k > m->n - 2) return march_at(m, s, sigma_t, sigma_s);
    double gs = march_fields_at(m, s, sigma_t, sigma_s);
    double total = (sigma_s[0] + sigma_s[1]) + sigma_s[2];
    return total > 0.0 ? gs / total : 0.0;
}

/* media.Stretch.phases_at at one point P (3) of a ray in the media `stack` (in a heterogeneous medium), g the
 * march's sigma_s-weighted mean anisotropy there: the mixture (phase.PhaseMix) of the homogeneous media's phase
 * function (weight their sigma_s summed over channels) and every closure that scatters there (Field.phase_at), at
 * most PHASE_LOBES in that order, as Cycles keeps each closure; HG of g where none scatters there; into *phase. */
static NOINLINE void phase_at(const MediaTables *media, const VolumeStack *stack, const double *P, double g,
                              Phase *phase)
{
    double sigma_s[3], g_h;
    Phase own;
    medium_scattering(media, stack, sigma_s, &g_h, &own);
    double weight = (sigma_s[0] + sigma_s[1]) + sigma_s[2];
    phase->lobes = 0;
    if (weight > 0.0) {
        phase->kinds[0] = own.kind;
        for (int c = 0; c < PHASE_PARAMETERS; c++) phase->lobe[0][c] = own.p[c];
        phase->weight[0] = weight;
        phase->lobes = 1;
    }
    for (const VolumeField *f = media->fields; f != NULL; f = f->next) {
        double count = field_count(f, stack), fa[3], fs[3], fe[3], fg;
        if (!(count > 0.0) || !f->scatters) continue;
        field_at(f, P, fa, fs, fe, &fg, phase, count);
    }
    phase->kind = PHASE_HENYEY_GREENSTEIN;
    for (int c = 0; c < PHASE_PARAMETERS; c++) phase->p[c] = 0.0;
    phase->p[0] = g;
    if (phase->lobes > 0) {                     /* (the first lobe's, for code that reads one phase function) */
        phase->kind = phase->kinds[0];
        for (int c = 0; c < PHASE_PARAMETERS; c++) phase->p[c] = phase->lobe[0][c];
    }
}

/* March.totals: the optical depths of extinction and of scattering (3 each) over the finite pieces. */
INLINE void march_totals(const March *m, double *tau_t, double *tau_s)
{
    for (int c = 0; c < 3; c++) tau_t[c] = tau_s[c] = 0.0;
    for (int j = 0; j < m->n; j++) {
        double width = m->edges[j + 1] - m->edges[j];
        width = isfinite(width) ? width : 0.0;
        for (int c = 0; c < 3; c++) { tau_t[c] += m->sigma_t[j][c] * width; tau_s[c] += m->sigma_s[j][c] * width; }
    }
}

/* March.uniform_share: the odds that free flight draws its distance uniformly in the box's stretch [*a, *b). */
INLINE double march_share(const March *m, double *a, double *b)
{
    *a = m->edges[1];
    *b = m->edges[m->n - 1];
    return m->tracked ? m->share : 0.0;
}

/* March.split: whether u picks the uniform share, u rescaled into *u0. */
INLINE int march_split(double share, double u, double *u0)
{
    int pick = u < share;
    *u0 = pick ? u / (share > 0.0 ? share : 1.0) : (u - share) / (1.0 - share);
    return pick;
}

/* March.share_pdf: the mixture of the march's density at s and the uniform share over [a, b). */
INLINE double march_share_pdf(double share, double a, double b, double s, double march)
{
    int inside = s >= a && s < b && share > 0.0;
    return march * (1.0 - share) + (inside ? share / (b - a) : 0.0);
}

/* March.pdf: the density of free flight (channels by odds (3)) choosing distance s, truncated at the ray's end,
 * with the uniform share. */
INLINE double march_pdf(const March *m, const double *odds, double s)
{
    double sigma[3], scattering[3], tau[3], each[3], a, b;
    march_at(m, s, sigma, scattering);
    march_depth(m, s, tau);
    for (int c = 0; c < 3; c++) {
        double reach = -expm1(-m->tau[m->n][c]);
        each[c] = odds[c] > 0.0 && reach > 0.0 ? odds[c] * sigma[c] * exp(-tau[c]) / reach : 0.0;
    }
    double share = march_share(m, &a, &b);
    return march_share_pdf(share, a, b, s, (each[0] + each[1]) + each[2]);
}

/* March.free_flight: a distance by numbers u (2) (u[1] the channel by odds (3), u[0] inverting that channel's
 * optical depth truncated at the end) into *s; its pdf returned (0: none, *s 0). */
INLINE double march_free_flight(const March *m, const double *odds, const double *u, double *s)
{
    int channel = (u[1] >= odds[0]) + (u[1] >= odds[0] + odds[1]) + (u[1] >= (odds[0] + odds[1]) + odds[2]);
    channel = channel > 2 ? 2 : channel;
    double a, b, u0, share = march_share(m, &a, &b);
    int pick = march_split(share, u[0], &u0);
    double end = m->tau[m->n][channel], target = -log1p(-u0 * -expm1(-end));
    int k = 0;
    for (int j = 1; j <= m->n; j++) k += m->tau[j][channel] <= target;
    k = k < m->n - 1 ? k : m->n - 1;
    double sigma = m->sigma_t[k][channel];
    double x = m->edges[k] + (sigma > 0.0 ? (target - m->tau[k][channel]) / sigma : 0.0);
    x = pick ? a + u0 * (b - a) : x;
    x = x < m->edges[m->n] ? x : m->edges[m->n];
    double pdf = march_pdf(m, odds, x);
    int ok = ((odds[0] + odds[1]) + odds[2]) > 0.0 && (pick || end > 0.0) && isfinite(x) && pdf > 0.0;
    *s = ok ? x : 0.0;
    return ok ? pdf : 0.0;
}

/* March.uniform: the one-piece march of a ray over [0, t) through homogeneous media of sigma_t, sigma_s, emission (3)
 * and anisotropy g, into m. */
INLINE void march_uniform(const double *sigma_t, const double *sigma_s, const double *emission, double g, double t,
                          March *m)
{
    m->n = 1;
    m->edges[0] = 0.0;
    m->edges[1] = t;
    for (int c = 0; c < 3; c++) {
        m->sigma_t[0][c] = sigma_t[c];
        m->sigma_s[0][c] = sigma_s[c];
        m->emission[0][c] = emission[c];
        m->tau[0][c] = 0.0;
        m->tau[1][c] = sigma_t[c] > 0.0 ? sigma_t[c] * t : 0.0;
    }
    m->gs[0] = g * ((sigma_s[0] + sigma_s[1]) + sigma_s[2]);
    m->tracked = 0;
}

/* March.collision_pdf: the density of untruncated free flight (channels by odds (3)) drawing distance s: the
 * channels' mixture of sigma(s) exp(-tau(s)). */
INLINE double march_collision_pdf(const March *m, const double *odds, double s)
{
    double sigma[3], scattering[3], tau[3], each[3], a, b;
    march_at(m, s, sigma, scattering);
    march_depth(m, s, tau);
    for (int c = 0; c < 3; c++) each[c] = odds[c] * sigma[c] * exp(-tau[c]);
    double share = march_share(m, &a, &b);
    return march_share_pdf(share, a, b, s, (each[0] + each[1]) + each[2]);
}

/* March.collision: untruncated free flight by numbers u (2) (u[1] the channel by odds (3), u[0] an optical depth
 * -log(1 - u[0]) of it): the distance into *s (the end where it passes), whether the depth lies past the end into
 * *passed and the chance of that (the channels' mixture of exp(-tau(end))) into *p_pass; its pdf returned (0 where
 * it passed). */
INLINE double march_collision(const March *m, const double *odds, const double *u, double *s, int *passed,
                              double *p_pass)
{
    int channel = (u[1] >= odds[0]) + (u[1] >= odds[0] + odds[1]) + (u[1] >= (odds[0] + odds[1]) + odds[2]);
    channel = channel > 2 ? 2 : channel;
    double a, b, u0, share = march_share(m, &a, &b);
    int pick = march_split(share, u[0], &u0);
    double target = -log1p(-(u0 < 1.0 - 1e-16 ? u0 : 1.0 - 1e-16));
    *passed = !pick && target >= m->tau[m->n][channel];
    int k = 0;
    for (int j = 1; j <= m->n; j++) k += m->tau[j][channel] <= target;
    k = k < m->n - 1 ? k : m->n - 1;
    double sigma = m->sigma_t[k][channel];
    double x = m->edges[k] + (sigma > 0.0 ? (target - m->tau[k][channel]) / sigma : 0.0);
    x = pick ? a + u0 * (b - a) : x;
    *s = *passed ? m->edges[m->n] : x;
    double pdf = march_collision_pdf(m, odds, *passed ? 0.0 : x);
    double each[3];
    for (int c = 0; c < 3; c++) each[c] = odds[c] * exp(-m->tau[m->n][c]);
    *p_pass = ((each[0] + each[1]) + each[2]) * (1.0 - share);
    return *passed ? 0.0 : pdf;
}

/* Stretch.scatters for one ray: whether its media scatter (or may: a heterogeneous one that scatters). */
INLINE int stretch_scatters(const MediaTables *media, const VolumeStack *stack, const double *sigma_s)
{
    if (sigma_s[0] > 0.0 || sigma_s[1] > 0.0 || sigma_s[2] > 0.0) return 1;
    for (const VolumeField *f = media->fields; f != NULL; f = f->next)
        if (f->scatters != 0 && field_count(f, stack) > 0.0) return 1;
    return 0;
}

/* A stretch's march built where first asked for (lazy_march): the ray, its media and their homogeneous part. */
typedef struct {
    const MediaTables *media;
    const VolumeStack *stack;            /* NULL: no media known (no march) */
    const double *O, *D;
    double t;
    const double *sigma_t, *emission;
    int built;                           /* 0: not yet asked, 1: marched, -1: homogeneous (no march) */
    March march;
} LazyMarch;

/* A LazyMarch of the stretch O + s D over [0, t) through the media `stack` (NULL: none) of extinction sigma_t and
 * emission (3 each, or NULL), not yet marched. Its fields are set one by one: an initialiser would zero the march's
 * tables (tens of kilobytes) on every call, marched or not. */
INLINE void lazy_march_start(LazyMarch *lazy, const MediaTables *media, const VolumeStack *stack, const double *O,
                             const double *D, double t, const double *sigma_t, const double *emission)
{
    lazy->media = media;
    lazy->stack = stack;
    lazy->O = O;
    lazy->D = D;
    lazy->t = t;
    lazy->sigma_t = sigma_t;
    lazy->emission = emission;
    lazy->built = 0;
}

/* The march of a LazyMarch's stretch (stretch_march), built on the first call; NULL where it needs none. */
INLINE const March *lazy_march(LazyMarch *lazy)
{
    if (lazy->built == 0)
        lazy->built = lazy->stack != NULL && lazy->sigma_t != NULL
                      && stretch_march(lazy->media, lazy->stack, lazy->O, lazy->D, lazy->t, lazy->sigma_t,
                                       lazy->emission, &lazy->march) != NULL ? 1 : -1;
    return lazy->built > 0 ? &lazy->march : NULL;
}
