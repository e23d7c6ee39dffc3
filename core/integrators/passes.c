/* First-hit render passes: core/integrators/passes.py, along the compiled chunk's camera chains (chunk.c, path.c,
 * direct.c's BSDF rays).
 *
 * A camera chain is the camera ray and the rays it sends straight on through Transparent closures. At each of its
 * vertices the data passes (sample 0's position, ids and depth until the first opaque-enough vertex, whose normal and
 * UV are summed), the closures' colours, the emission, the ambient occlusion and Cryptomatte's entries; along its
 * rays the lamps the camera sees and the world where they escape. AO_DIMENSION, PASS_* and the
 * PassTables record come from passes.py (core/native/boundary.gen.h). */

/* Each camera lane's first-hit passes in a block (passes.DataPasses), where asked for. */
struct LanePasses {
    const PassTables *tables;
    double values[BLOCK][PASS_CHANNELS_MAX + AOV_CHANNELS_MAX];   /* the passes' sums, in tables->offset's channels,
                                                                   * then the shader AOVs' from tables->aov_base */
    uint8_t done[BLOCK];                        /* 1: the chain met its opaque-enough vertex */
    int64_t entries[BLOCK];                     /* Cryptomatte entries met so far */
    double *mattes;                             /* (BLOCK, room, 4): weight, then the id of each kind asked for */
    int64_t room;                               /* entries a lane keeps at most: its chain's vertices */
    int transparent_bounces;                    /* a chain's transparent bounces at most */
    Transmitter ao;                             /* the ambient occlusion ray's way through transparent surfaces */
};

/* Start a block: nothing written for any lane. */
INLINE void passes_clear(LanePasses *lp)
{
    for (int64_t k = 0; k < BLOCK; k++) {
        for (int64_t i = 0; i < lp->tables->channels; i++) lp->values[k][i] = 0.0;
        lp->done[k] = 0;
        lp->entries[k] = 0;
    }
}

/* Where the shader of a hit on lane `lane`'s camera chain adds its AOV Output nodes' values (ShaderKeys.aov): the
 * lane's shader AOVs, while its chain has not met its opaque-enough vertex (Cycles' svm_node_aov_check: a camera
 * path before PATH_RAY_SINGLE_PASS_DONE); NULL where no AOV is asked for (lp NULL or no AOV channels). */
INLINE double *passes_aov(LanePasses *lp, int64_t lane)
{
    if (lp == NULL || lp->tables->aov_base < 0 || lp->done[lane]) return NULL;
    return lp->values[lane] + lp->tables->aov_base;
}

/* DataPasses.add / set for one lane: value (the pass's channels) times `scale` into pass `pass`, if asked for. */
INLINE void pass_add(LanePasses *lp, int64_t lane, int pass, const double *value, const double *scale)
{
    int at = (int)lp->tables->offset[pass];
    if (at < 0) return;
    for (int c = 0; c < PASS_WIDTH[pass]; c++) lp->values[lane][at + c] += value[c] * (scale != NULL ? scale[c] : 1.0);
}

INLINE void pass_set(LanePasses *lp, int64_t lane, int pass, const double *value)
{
    int at = (int)lp->tables->offset[pass];
    if (at < 0) return;
    for (int c = 0; c < PASS_WIDTH[pass]; c++) lp->values[lane][at + c] = value != NULL ? value[c] : 0.0;
}

/* passes.closure_albedos for one hit seen from wo: its closures' weight x albedo by closure type. */
INLINE void closure_albedos(const ShaderResult *sd, const double *wo, double *diffuse, double *glossy,
                            double *transmission)
{
    for (int c = 0; c < 3; c++) diffuse[c] = glossy[c] = transmission[c] = 0.0;
    for (int k = 0; k < sd->n; k++) {
        const Closure *cl = sd->c + k;
        if (cl->kind < 0 || !bsdf_is(cl->kind, BSDF_FLAG_DIFFUSE_TYPE | BSDF_FLAG_GLOSSY_TYPE
                                                | BSDF_FLAG_TRANSMISSION_TYPE | BSDF_FLAG_GLASS_TYPE))
            continue;
        double R[3], T[3];
        bsdf_albedo(cl, wo, R, T);
        for (int c = 0; c < 3; c++) {
            if (bsdf_is(cl->kind, BSDF_FLAG_DIFFUSE_TYPE)) diffuse[c] += cl->weight[c] * R[c];
            if (bsdf_is(cl->kind, BSDF_FLAG_GLOSSY_TYPE | BSDF_FLAG_GLASS_TYPE)) glossy[c] += cl->weight[c] * R[c];
            if (bsdf_is(cl->kind, BSDF_FLAG_TRANSMISSION_TYPE | BSDF_FLAG_GLASS_TYPE))
                transmission[c] += cl->weight[c] * T[c];
        }
    }
}

/* passes.average_normal for one hit: its closures' normals weighed by |mean weight| (Transparent left out),
 * normalised; the shading normal where they have none. */
INLINE void average_normal(const ShaderResult *sd, double *out)
{
    double total[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < sd->n; k++) {
        const Closure *cl = sd->c + k;
        if (cl->kind < 0 || bsdf_is(cl->kind, BSDF_FLAG_STRAIGHT)) continue;
        double w = fabs((cl->weight[0] + cl->weight[1] + cl->weight[2]) / 3.0);
        for (int c = 0; c < 3; c++) total[c] += w * cl->N[c];
    }
    double length = sqrt(dot3(total, total));
    for (int c = 0; c < 3; c++) out[c] = length > 0.0 ? total[c] / length : sd->N[c];
}

/* surface.hit_attributes for `count` floats from `offset` of the hit on `prim` of geometry `geometry` (0: the
 * copied triangles, m: instanced mesh m - 1) at barycentrics u, v, into out (count). */
INLINE void attributes_at(const GeometryTables *g, int64_t geometry, int64_t prim, double u, double v, int offset,
                          int count, double *out)
{
    int64_t row = 0;
    if (geometry <= 0) row = g->attribute_row != NULL ? (int64_t)g->attribute_row[prim] : 0;
    else if (g->meshes[geometry - 1].attribute_row != NULL) row = (int64_t)g->meshes[geometry - 1].attribute_row[prim];
    int64_t width = (int64_t)g->attribute_width;
    const float *corner = g->attributes + 3 * width * row;
    double w = 1.0 - u - v;
    for (int c = 0; c < count; c++)
        out[c] = (w * (double)corner[offset + c] + u * (double)corner[width + offset + c])
                 + v * (double)corner[2 * width + offset + c];
}

/* passes.uv_at for one hit (Embree's geometry, prim at barycentrics u, v): (u, v, 1) of the UV map at float
 * `offset` of the attributes ((0, 0, 1) without one). */
INLINE void uv_at(const GeometryTables *g, int64_t geometry, int64_t prim, double u, double v, int offset, double *out)
{
    out[0] = out[1] = 0.0;
    out[2] = 1.0;
    if (offset < 0 || g->attributes == NULL) return;
    attributes_at(g, geometry, prim, u, v, offset, 2, out);
}

/* A point h (4) in a frame's camera space (or a direction, h[3] 1) on the raster, xy (2): through a panoramic
 * camera's projection inverted (its Window, panorama_window) times the image's size, else h's x and y, divided by
 * h[3] where `divide` (a point through the world-to-raster transform) and as they are where not (a direction). */
INLINE void vector_raster(const PassTables *pt, const double *h, int divide, double *xy)
{
    if (pt->vector_panorama != 0) {
        double uv[3];
        panorama_window(h, pt->vector_window, uv);
        xy[0] = uv[0] * pt->vector_size[0];
        xy[1] = uv[1] * pt->vector_size[1];
        return;
    }
    xy[0] = divide ? h[0] / h[3] : h[0];
    xy[1] = divide ? h[1] / h[3] : h[1];
}

/* The Vector pass's (before - now, now - after) of the three frames' raster places (3 x 2) into out (4). */
INLINE void vector_differences(double raster[3][2], double *out)
{
    for (int c = 0; c < 2; c++) {
        out[c] = raster[0][c] - raster[1][c];
        out[2 + c] = raster[1][c] - raster[2][c];
    }
}

/* passes.vector_at for one hit of instance `object` at the world point P (on `prim` of geometry `geometry` at
 * barycentrics u, v): (before - now, now - after) on the raster and its weight 1, into out (5); 0 motion where
 * still. A deforming instance's point then is its mesh's motion attribute at the hit carried by its object's
 * transform then (Cycles' vertex motion), any other's P carried by its transform's change; seen by the camera then
 * through its world-to-raster transform, or a panoramic camera's projection inverted (its Window, panorama_window,
 * times the image's size). */
INLINE void vector_at(const PassTables *pt, const GeometryTables *g, int64_t geometry, int64_t prim, double u, double v,
                      int64_t object, const double *P, double *out)
{
    for (int c = 0; c < 4; c++) out[c] = 0.0;
    out[4] = 1.0;
    if (pt->vector_still != 0 || pt->vector_before == NULL) return;
    int64_t row = object < 0 ? 0 : (object >= pt->vector_rows ? pt->vector_rows - 1 : object);
    int deformed = pt->vector_deformed != NULL && pt->vector_deformed[row] != 0 && g->attributes != NULL;
    double raster[3][2];
    for (int k = 0; k < 3; k++) {
        const double *move = k == 0 ? pt->vector_before + 12 * row : (k == 2 ? pt->vector_after + 12 * row : NULL);
        double Q[3], h[4], local[3];
        const double *from = P;
        if (move != NULL && deformed) {
            attributes_at(g, geometry, prim, u, v, k == 0 ? (int)pt->vector_offset_before : (int)pt->vector_offset_after,
                          3, local);
            move = pt->vector_objects + 12 * (2 * row + k / 2);
            from = local;
        }
        for (int i = 0; i < 3; i++)
            Q[i] = move == NULL ? P[i] : ((move[4 * i] * from[0] + move[4 * i + 1] * from[1]) + move[4 * i + 2] * from[2])
                                         + move[4 * i + 3];
        const double *R = pt->vector_raster + 16 * k;
        for (int i = 0; i < 4; i++) h[i] = ((R[4 * i] * Q[0] + R[4 * i + 1] * Q[1]) + R[4 * i + 2] * Q[2]) + R[4 * i + 3];
        vector_raster(pt, h, 1, raster[k]);         /* (h: the point in the camera's space then) */
    }
    vector_differences(raster, out);
}

/* passes.world_vector_at for one camera ray of unit direction D that sees the world (Blender 5.2's Cycles,
 * camera_motion_vector_direction): (before - now, now - after) of the direction's place at infinity and its weight 1,
 * into out (5): each frame's world-to-camera rotation (vector_raster's 3 x 3), through a panoramic camera's
 * projection inverted (times the image's size), else the x and y rows of the world-to-raster's 3 x 3, undivided. */
INLINE void world_vector_at(const PassTables *pt, const double *D, double *out)
{
    for (int c = 0; c < 4; c++) out[c] = 0.0;
    out[4] = 1.0;
    if (pt->vector_still != 0 || pt->vector_before == NULL) return;
    double n = sqrt(dot3(D, D)), d[3];
    for (int i = 0; i < 3; i++) d[i] = D[i] / (n > 1e-300 ? n : 1e-300);
    double raster[3][2];
    for (int k = 0; k < 3; k++) {
        const double *R = pt->vector_raster + 16 * k;
        double h[4];
        for (int i = 0; i < 3; i++) h[i] = (R[4 * i] * d[0] + R[4 * i + 1] * d[1]) + R[4 * i + 2] * d[2];
        h[3] = 1.0;
        vector_raster(pt, h, 0, raster[k]);         /* (h: the direction in the camera's space then) */
    }
    vector_differences(raster, out);
}

/* passes.ambient_occlusion for one hit: what a cosine-distributed ray about N carries back through transparent
 * surfaces within ao_distance (out, 3), 0 where it leaves below the face. */
INLINE void ambient_occlusion(const LanePasses *lp, const Surface *s, int64_t pixel, int64_t sample, double seed,
                              int64_t dimension, double *out)
{
    double u[2];
    sample_2d(stream_of((int64_t)seed, AO_DIMENSION + dimension), pixel, sample, u);
    Closure around = {0, {1.0, 1.0, 1.0}, 1.0, {s->N[0], s->N[1], s->N[2]}, NULL};
    BsdfSample b;
    lambert_sample(&around, NULL, u, &b);
    out[0] = out[1] = out[2] = 0.0;
    if (!(dot3(s->Ng, b.wi) > 0.0)) return;
    double O[1][3], D[1][3] = {{b.wi[0], b.wi[1], b.wi[2]}}, T[1][3], t = lp->tables->ao_distance;
    spawn_ray(s->I, s->Ng, b.wi, s->offset, O[0]);
    LightPath shadow = {PATH_SHADOW, 0, 0, 0, 0, 0, 0, 0.0, 0.0};     /* (a shadow ray from a camera chain's hit) */
    transmit_packet(&lp->ao, 1, O, D, &t, &s->time, &shadow, NULL, NULL, T);
    for (int c = 0; c < 3; c++) out[c] = T[0][c];
}

/* passes.mist at the camera-relative hit I (3): clamp((d - start) / depth, 0, 1) ^ falloff, d the distance from the
 * camera (along its forward axis for an orthographic camera). */
INLINE double mist_at(const PassTables *pt, const double *I)
{
    double towards[3];
    for (int c = 0; c < 3; c++) towards[c] = I[c] + pt->camera_offset[c];
    double d = pt->ortho != 0 ? fabs(dot3(towards, pt->forward)) : sqrt(dot3(towards, towards));
    double m = (d - pt->mist_start) * pt->mist_inv_depth;
    m = m < 0.0 ? 0.0 : (m > 1.0 ? 1.0 : m);
    return pt->mist_falloff == 1.0 ? m : pow(m, pt->mist_falloff);
}

/* passes.at_vertex for hit h of H, on a camera chain (no real bounce yet), the chain's `vertex`-th. */
NOINLINE static void passes_at_vertex(LanePasses *lp, const DirectSettings *ds, const BlockHits *H, int64_t h, int vertex)
{
    const PassTables *pt = lp->tables;
    const GeometryTables *g = ds->geometry;
    const ShaderResult *sd = H->sd + h;
    const Surface *s = H->s + h;
    const double *tp = H->throughput + 3 * h;
    int64_t lane = H->lane[h];
    double transparency[3], alpha[3];
    for (int c = 0; c < 3; c++) { transparency[c] = at_least(sd->transparency[c], 0.0); alpha[c] = 1.0 - transparency[c]; }
    int64_t object = owner_of(g, H->geometry[h], H->prim[h], H->instance[h]);
    /* 1. Until the chain's opaque-enough vertex: sample 0's position, ids and depth, overwritten at each vertex. */
    if (!lp->done[lane] && H->sample[h] == 0) {
        double P[3], camera[3], one[1];
        for (int c = 0; c < 3; c++) { P[c] = s->I[c] + pt->origin[c]; camera[c] = s->I[c] + pt->camera_offset[c]; }
        pass_set(lp, lane, PASS_POSITION, P);
        one[0] = pt->object_index[object];
        pass_set(lp, lane, PASS_OBJECT_INDEX, one);
        one[0] = pt->material_index[s->material];
        pass_set(lp, lane, PASS_MATERIAL_INDEX, one);
        one[0] = (camera[0] * pt->forward[0] + camera[1] * pt->forward[1]) + camera[2] * pt->forward[2];
        pass_set(lp, lane, PASS_Z_DEPTH, one);
    }
    /* 2. The opaque-enough vertex: the normal and UV, summed over samples; the chain's data passes are done. */
    if (!lp->done[lane] && (alpha[0] + alpha[1] + alpha[2]) / 3.0 >= pt->alpha_threshold) {
        double value[3];
        if (pt->offset[PASS_AVERAGE_NORMAL] >= 0) {       /* (each only where its pass is written) */
            average_normal(sd, value);
            pass_add(lp, lane, PASS_AVERAGE_NORMAL, value, NULL);
        }
        if (pt->offset[PASS_UV] >= 0) {
            uv_at(g, H->geometry[h], H->prim[h], H->bary[2 * h], H->bary[2 * h + 1], (int)pt->uv_offset, value);
            pass_add(lp, lane, PASS_UV, value, NULL);
        }
        if (pt->offset[PASS_VECTOR] >= 0) {
            double P[3], motion[5];
            for (int c = 0; c < 3; c++) P[c] = s->I[c] + pt->origin[c];
            vector_at(pt, g, H->geometry[h], H->prim[h], H->bary[2 * h], H->bary[2 * h + 1], object, P, motion);
            pass_add(lp, lane, PASS_VECTOR, motion, NULL);
        }
        lp->done[lane] = 1;
    }
    /* 3. Cryptomatte: this surface's share of the pixel, for its object, material and asset. */
    if (pt->matte_count > 0 && lp->entries[lane] < lp->room) {
        double *entry = lp->mattes + 4 * (lane * lp->room + lp->entries[lane]++);
        entry[0] = ((tp[0] + tp[1] + tp[2]) / 3.0) * (1.0 - (transparency[0] + transparency[1] + transparency[2]) / 3.0);
        for (int k = 0; k < pt->matte_count; k++) {
            int kind = (int)pt->matte_kind[k];
            entry[1 + k] = kind == 1 ? pt->material_ids[s->material] : (kind == 2 ? pt->asset_ids : pt->object_ids)[object];
        }
    }
    /* 4. The closures' colours, the emission, and the ambient occlusion, seen through the chain. */
    if (pt->offset[PASS_DIFFUSE_COLOR] >= 0 || pt->offset[PASS_GLOSSY_COLOR] >= 0 || pt->offset[PASS_TRANSMISSION_COLOR] >= 0) {
        double diffuse[3], glossy[3], transmission[3];
        closure_albedos(sd, H->wo + 3 * h, diffuse, glossy, transmission);
        pass_add(lp, lane, PASS_DIFFUSE_COLOR, diffuse, tp);
        pass_add(lp, lane, PASS_GLOSSY_COLOR, glossy, tp);
        pass_add(lp, lane, PASS_TRANSMISSION_COLOR, transmission, tp);
    }
    pass_add(lp, lane, PASS_EMISSION, sd->emission, tp);
    if (pt->offset[PASS_AMBIENT_OCCLUSION] >= 0) {
        double open[3];
        ambient_occlusion(lp, s, H->pixel[h], H->sample[h], ds->seed, (int64_t)vertex * VERTEX_DIMENSIONS, open);
        for (int c = 0; c < 3; c++) open[c] *= tp[c] * alpha[c];
        pass_add(lp, lane, PASS_AMBIENT_OCCLUSION, open, NULL);
    }
    if (pt->offset[PASS_MIST] >= 0) {
        double kept[1] = {(1.0 - mist_at(pt, s->I)) * (tp[0] * alpha[0] + tp[1] * alpha[1] + tp[2] * alpha[2]) / 3.0};
        pass_add(lp, lane, PASS_MIST, kept, NULL);
    }
}

/* passes.along_ray for one ray of lane `lane`'s camera chain, with the chain's throughput there: from O along the
 * unit D to t (its hit where `hit`, else where it escapes): the lamps with extent the camera sees that it passes, the
 * world where it escapes, and where it escapes with the data passes not done, the world's shader AOVs, the
 * direction's motion (Blender 5.2's Vector pass: world_vector_at) and sample 0's back to 0. */
INLINE void passes_along_ray(LanePasses *lp, const DirectSettings *ds, int64_t lane, int64_t sample,
                             const double *throughput, const double *O, const double *D, int hit, double t,
                             const VolumeStack *inside)
{
    const PassTables *pt = lp->tables;
    /* (the media along the ray, where it crosses some: what they let through and emit, as in Combined) */
    double sigma[3] = {0.0, 0.0, 0.0}, emission[3] = {0.0, 0.0, 0.0}, kept[3];
    const March *m = NULL;
    March march;
    int media = inside != NULL && ds->media != NULL;
    if (media) {
        medium_along(ds->media, inside, sigma, emission);
        m = stretch_march(ds->media, inside, O, D, t, sigma, emission, &march);
    }
    if (pt->offset[PASS_EMISSION] >= 0) {
        double seen[3] = {0.0, 0.0, 0.0};
        for (int64_t l = 0; l < ds->n_lights; l++) {
            LightHit lh;
            if (camera_sees_lamp(ds->lights + l, O, D, t, hit, &lh)) {
                if (media) {
                    stretch_transmittance(m, sigma, lh.t, kept);
                    for (int c = 0; c < 3; c++) lh.radiance[c] *= kept[c];
                }
                for (int c = 0; c < 3; c++) seen[c] += lh.radiance[c];
            }
        }
        /* (a medium the camera sees is Cycles' Emission: film_write_volume_emission on a path with no pass yet) */
        if (media) stretch_emitted(m, sigma, emission, t, seen);
        pass_add(lp, lane, PASS_EMISSION, seen, throughput);
    }
    if (hit) return;
    if (pt->offset[PASS_ENVIRONMENT] >= 0 && pt->world_camera != 0.0) {
        double L[3];
        LightPath camera = {PATH_CAMERA, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
        world_seen(ds->context->world, D, &camera, L);     /* (a camera chain's ray: a world's graph per ray) */
        if (media) {
            stretch_transmittance(m, sigma, INFINITY, kept);
            for (int c = 0; c < 3; c++) L[c] *= kept[c];
        }
        pass_add(lp, lane, PASS_ENVIRONMENT, L, throughput);
    }
    if (pt->world_aovs != NULL && pt->aov_base >= 0 && !lp->done[lane]) {
        /* (the world's AOV Output nodes: Cycles' svm_node_aov_check on a camera path not yet done, unweighed) */
        LightPath camera = {PATH_CAMERA, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
        world_graph_aovs(pt->world_aovs, D, &camera, lp->values[lane] + pt->aov_base);
    }
    if (pt->offset[PASS_VECTOR] >= 0 && pt->vector_world != 0 && pt->vector_still == 0 && !lp->done[lane]) {
        /* (Blender 5.2's Cycles: film_write_data_passes_background writes the direction's motion, weight 1) */
        double motion[5];
        world_vector_at(pt, D, motion);
        pass_add(lp, lane, PASS_VECTOR, motion, NULL);
    }
    if (!lp->done[lane] && sample == 0) {
        pass_set(lp, lane, PASS_POSITION, NULL);
        pass_set(lp, lane, PASS_OBJECT_INDEX, NULL);
        pass_set(lp, lane, PASS_MATERIAL_INDEX, NULL);
        pass_set(lp, lane, PASS_Z_DEPTH, NULL);
    }
}

/* path.py: the ray of hit h of H, on a camera chain, straight on through a transparent surface with weight (3), from
 * O along D to t (its hit where `hit`): passes.along_ray with the chain's throughput past the surface, within the
 * transparent-bounce limit. */
INLINE void passes_straight_on(LanePasses *lp, const DirectSettings *ds, const BlockHits *H, int64_t h,
                               const double *weight, const double *O, const double *D, int hit, double t,
                               const VolumeStack *inside)
{
    if (H->transparent[h] + 1 > lp->transparent_bounces) return;
    double tp[3];
    for (int c = 0; c < 3; c++) tp[c] = H->throughput[3 * h + c] * weight[c];
    passes_along_ray(lp, ds, H->lane[h], H->sample[h], tp, O, D, hit, t, inside);
}

/* cryptomatte.fill_slots for one entry: id (a float32's value, never 0) of weight into a pixel's slots (slots, 2). */
INLINE void matte_slot(double *slot, int64_t slots, double id, double weight)
{
    if (weight == 0.0) return;
    for (int64_t k = 0; k < slots; k++) {
        if (slot[2 * k] == 0.0) { slot[2 * k] = id; slot[2 * k + 1] = weight; return; }
        if (slot[2 * k] == id || k == slots - 1) { slot[2 * k + 1] += weight; return; }
    }
}

/* A lane's first-hit passes into its pixel's sums: values (channels) added (each channel NaN or beyond the film as
 * 0), its Cryptomatte entries into the pixel's slots (matte_count, slots, 2) in the order met. */
INLINE void passes_to_pixel(const LanePasses *lp, int64_t lane, double *values, double *mattes)
{
    const PassTables *pt = lp->tables;
    if (values != NULL)
        for (int64_t i = 0; i < pt->channels; i++) values[i] += finite_or_zero(lp->values[lane][i]);
    if (mattes == NULL) return;
    for (int64_t e = 0; e < lp->entries[lane]; e++) {
        const double *entry = lp->mattes + 4 * (lane * lp->room + e);
        if (!(entry[0] > 0.0) || !isfinite(entry[0])) continue;
        for (int k = 0; k < pt->matte_count; k++)
            matte_slot(mattes + 2 * k * pt->slots, pt->slots, entry[1 + k], entry[0]);
    }
}
