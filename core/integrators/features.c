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
 * before the lights are gathered), then the feature vertex (into lanes: (BLOCK, FEATURE_CHANNELS) albedo, normal). */
INLINE void features_at_vertex(BlockHits *H, double (*lanes)[FEATURE_CHANNELS])
{
    for (int64_t h = 0; h < H->m; h++) {
        if (!H->looking[h]) continue;
        double *out = lanes[H->lane[h]], *ftp = H->feature_tp + 3 * h;
        const double *tp = H->throughput + 3 * h;
        for (int c = 0; c < 3; c++) out[c] += ftp[c] * tp[c] * H->L[3 * h + c];
        double diffuse[3], specular[3], normal[3];
        if (feature_vertex(H->sd + h, diffuse, specular, normal)) {
            for (int c = 0; c < 3; c++) { out[c] += ftp[c] * diffuse[c]; out[3 + c] = normal[c]; }
            H->looking[h] = 0;
        } else {
            for (int c = 0; c < 3; c++) ftp[c] *= specular[c];
        }
    }
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
