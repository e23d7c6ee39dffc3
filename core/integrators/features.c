/* Denoising features: core/integrators/features.py, along the compiled chunk's paths (path.c, chunk.c).
 *
 * A path looks for its feature vertex from the camera on: while it looks, what it sees emit adds feature
 * throughput x its contribution to the lane's albedo; the first hit whose diffuse-like closures carry more than a
 * quarter of the sampling weight writes its diffuse albedo and normal and ends the looking; a specular one
 * multiplies the feature throughput by its specular albedo. Cycles 5.0's rule (kernel/film/denoising_passes.h). */

/* features.diffuse_like for one closure: a singular BSDF is specular-like; one with an alpha parameter is
 * diffuse-like above ROUGH_ALPHA; any other is diffuse-like. */
INLINE int diffuse_like(const Closure *c)
{
    if (bsdf_is(c->kind, BSDF_FLAG_SINGULAR)) return 0;
    int alpha = BSDF_ALPHA_PARAM[c->kind];
    return alpha < 0 || c->p[alpha] > ROUGH_ALPHA;
}

/* features.vertex_features for one hit: its diffuse and specular albedo (3 each), its closures' normal weighed by
 * their sampling weights (3; 0 where they have none), and whether it is the feature vertex. */
INLINE int feature_vertex(const ShaderResult *sd, double *diffuse, double *specular, double *normal)
{
    double total = 0.0, nonspecular = 0.0;
    for (int j = 0; j < 3; j++) diffuse[j] = specular[j] = normal[j] = 0.0;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = sd->c + k;
        if (c->kind < 0) continue;
        int like = diffuse_like(c);
        double *albedo = like ? diffuse : specular;
        for (int j = 0; j < 3; j++) { albedo[j] += c->weight[j]; normal[j] += c->sample_weight * c->N[j]; }
        total += c->sample_weight;
        if (like) nonspecular += c->sample_weight;
    }
    if (total > 0.0)
        for (int j = 0; j < 3; j++) normal[j] /= total;
    return total == 0.0 || 4.0 * nonspecular > total;
}

/* features.at_vertex for the hits of H whose paths still look: the emission they see (H->L, which holds just that
 * before the lights are gathered), then the feature vertex (into lanes: (BLOCK, FEATURE_CHANNELS) albedo, normal),
 * times each lane's reach (features.in_media). */
INLINE void features_at_vertex(BlockHits *H, double (*lanes)[FEATURE_CHANNELS], const double *reach)
{
    for (int64_t h = 0; h < H->m; h++) {
        if (!H->looking[h]) continue;
        double *out = lanes[H->lane[h]], *ftp = H->feature_tp + 3 * h, odds = reach[H->lane[h]];
        const double *tp = H->throughput + 3 * h;
        for (int c = 0; c < 3; c++) out[c] += ftp[c] * tp[c] * H->L[3 * h + c];
        double diffuse[3], specular[3], normal[3];
        if (feature_vertex(H->sd + h, diffuse, specular, normal)) {
            for (int c = 0; c < 3; c++) { out[c] += odds * (ftp[c] * diffuse[c]); out[3 + c] += odds * normal[c]; }
            H->looking[h] = 0;
        } else {
            for (int c = 0; c < 3; c++) ftp[c] *= specular[c];
        }
    }
}

/* The tail of features.in_media for one path's ray that scatters: what it lets through T (3) and the integral of
 * T sigma_s over it (scattered, 3): albedo (into lane[0..2]) += ftp x tp x scattered, normal (lane[3..5]) += *reach
 * (1 - P) back, *reach *= P, the odds of passing (T weighed by Cycles' channel pdf |tp (scattered tp + T)|). */
INLINE void features_write(double *lane, double *reach, const double *ftp, const double *tp, const double *T,
                           const double *scattered, const double *back)
{
    double total = 0.0, passing = 0.0;
    for (int c = 0; c < 3; c++) {
        double share = fabs(tp[c] * (scattered[c] * tp[c] + T[c]));
        total += share;
        passing += share * T[c];
    }
    double P = total > 0.0 ? passing / total : (T[0] + T[1] + T[2]) / 3.0;
    for (int c = 0; c < 3; c++) {
        lane[c] += ftp[c] * tp[c] * scattered[c];
        lane[3 + c] += (*reach * (1.0 - P)) * back[c];
    }
    *reach *= P;
}

/* features.in_media for one path's ray through homogeneous media (sigma_t, sigma_s (3) over t, inf: it escapes)
 * while it looks: features_write with T = exp(-sigma_t t) and the integral sigma_s / sigma_t (1 - T); nothing where
 * the media only absorb. */
INLINE void features_in_media(double *lane, double *reach, const double *ftp, const double *tp, const double *sigma_t,
                              const double *sigma_s, double t, const double *back)
{
    if (!(sigma_s[0] > 0.0 || sigma_s[1] > 0.0 || sigma_s[2] > 0.0)) return;
    double T[3], albedo[3];
    for (int c = 0; c < 3; c++) {
        int positive = sigma_t[c] > 0.0;
        T[c] = positive ? exp(-sigma_t[c] * t) : 1.0;
        albedo[c] = positive ? sigma_s[c] / sigma_t[c] * (1.0 - T[c]) : 0.0;
    }
    features_write(lane, reach, ftp, tp, T, albedo, back);
}

/* features.in_media for one path's ray O + s D (3 each) over [0, t) (inf: it escapes) in the media `stack`, which
 * hold a heterogeneous one (in_field), of homogeneous part sigma_t, emission (3) (medium_along): its march (field.c)
 * and features_write with T = exp(-tau(t)) and the integral of T sigma_s summed over the pieces in order
 * (features.march_scattered); nothing where no piece scatters. Its own NOINLINE call: a march is tens of kilobytes. */
NOINLINE static void features_in_march(double *lane, double *reach, const double *ftp, const double *tp,
                                       const MediaTables *media, const VolumeStack *stack, const double *O,
                                       const double *D, double t, const double *sigma_t, const double *emission,
                                       const double *back)
{
    double sigma_s[3], g;
    medium_scattering(media, stack, sigma_s, &g, NULL);
    if (!stretch_scatters(media, stack, sigma_s)) return;
    March m;
    march_of(media, stack, O, D, t, sigma_t, sigma_s, emission, g, &m);
    int some = 0;
    double T[3], scattered[3] = {0.0, 0.0, 0.0};
    for (int j = 0; j < m.n; j++) {
        double width = m.edges[j + 1] - m.edges[j];
        for (int c = 0; c < 3; c++) {
            double st = m.sigma_t[j][c], ss = m.sigma_s[j][c];
            some |= ss > 0.0;
            double each = st > 0.0 ? exp(-m.tau[j][c]) * (ss / st * -expm1(-st * width)) : 0.0;
            scattered[c] = scattered[c] + (each != each ? 0.0 : each);
        }
    }
    if (!some) return;
    for (int c = 0; c < 3; c++) T[c] = exp(-m.tau[m.n][c]);
    features_write(lane, reach, ftp, tp, T, scattered, back);
}

/* features.in_media for one path's ray O + s D (3 each) over [0, t) (inf: it escapes) in the media `stack` while it
 * looks: marched where one of them is heterogeneous (features_in_march), else features_in_media of the stack's
 * coefficients (medium_along, medium_scattering). */
NOINLINE static void features_along(double *lane, double *reach, const double *ftp, const double *tp,
                                    const MediaTables *media, const VolumeStack *stack, const double *O,
                                    const double *D, double t, const double *back)
{
    double sigma_t[3], emission[3], sigma_s[3], g;
    medium_along(media, stack, sigma_t, emission);
    if (media->fields != NULL && in_field(media, stack)) {
        features_in_march(lane, reach, ftp, tp, media, stack, O, D, t, sigma_t, emission, back);
        return;
    }
    medium_scattering(media, stack, sigma_s, &g, NULL);
    features_in_media(lane, reach, ftp, tp, sigma_t, sigma_s, t, back);
}

/* features.found: what the hits' rays found (H->found, before the path's throughput) where their paths still look. */
INLINE void features_found(const BlockHits *H, double (*lanes)[FEATURE_CHANNELS])
{
    for (int64_t h = 0; h < H->m; h++) {
        if (!H->looking[h]) continue;
        double *out = lanes[H->lane[h]];
        for (int c = 0; c < 3; c++) out[c] += H->feature_tp[3 * h + c] * H->throughput[3 * h + c] * H->found[3 * h + c];
    }
}
