/* Direct lighting: core/integrators/direct.py, the lecture's ray tracer, for a block of hits.
 *
 * For every light, every sample of it at every hit: where the light comes from (core/lights), the
 * lecture's two tests (N.L > 0 and Ng.L > 0), one shadow ray from a point safely off the surface
 * (shadows.c), and what gets through, f cos (the hit's closures at L) E_normal / samples times the
 * light's colour, added to the hit's radiance (which starts as the light the hit emits itself). The samples go BLOCK at a time through SIMD lanes, their
 * shadow rays 8 at a time through Embree's packets, while all of it is still in the cache. */

/* The hits of one block of camera samples, one row per hit (at most BLOCK). */
typedef struct {
    int64_t m;
    int64_t lane[BLOCK];                         /* the camera sample (lane of the block) it belongs to */
    int64_t pixel[BLOCK], sample[BLOCK];         /* its random-number keys */
    Surface s[BLOCK];
    ShaderResult sd[BLOCK];                      /* the material there: closures, emission */
    Closure *closures;                           /* (BLOCK, room) the hits' closures (hit_closures) */
    double *storage;                             /* (BLOCK, room, STORAGE_STRIDE) their parameters, where nodes set them up */
    int64_t room;                                /* closures per hit: ChunkParams.closure_room */
    double wo[3 * BLOCK];                        /* towards the viewer */
    double L[3 * BLOCK];                         /* the radiance it sends towards the viewer */
    double t[BLOCK];                             /* each camera lane's ray length: its hit, or its t_max */
    uint8_t traced[BLOCK];                       /* 1: the hit traces a BSDF ray (direct.wants_bsdf_ray) */
    uint8_t lambert[BLOCK];                      /* 1: its material is one Lambert closure on the shading normal
                                                  * (and no Shading Offset bends it) */
    uint8_t through[BLOCK];                      /* 1: a closure refracts light from behind (direct.lets_light_through) */
    double albedo[3 * BLOCK];                    /* and that closure's weight */
    double throughput[3 * BLOCK];                /* a path's throughput at the hit (path.c; 1 at the camera's) */
    int32_t diffuse[BLOCK], glossy[BLOCK];       /* a path's diffuse, glossy and transmission bounces so far */
    int32_t transmission[BLOCK], transparent[BLOCK], bounce[BLOCK];   /* (transparent ones are no bounce) */
    int32_t portal[BLOCK];                       /* of the transparent ones, Ray Portals (Portal Depth) */
    double cone[BLOCK], spread[BLOCK];           /* the ray cone of the ray that found it (graph.LightPath) */
    int32_t flags[BLOCK];                        /* the PATH_* bits of the ray that found it (graph.LightPath) */
    double mis_pdf[BLOCK];                       /* the pdf of a path's last real bounce (inf: the camera's) */
    double min_pdf[BLOCK];                       /* the smallest pdf of its real bounces (Cycles' min_ray_pdf; the Bevel) */
    double mis_origin[3 * BLOCK];                /* its ray origin, and its light-tree normal (0: unknown), from which */
    double mis_n[3 * BLOCK];                     /* MIS measures the light pdfs (direct.BsdfRay.mis_O, mis_N) */
    uint64_t mis_receiver[BLOCK];                /* and the light set of its object (Cycles' mis_ray_object) */
    uint8_t after_diffuse[BLOCK];                /* 1: that bounce was diffuse (the caustics switches) */
    uint8_t exiting[BLOCK];                      /* 1: it is a subsurface walk's exit (path.c; subsurface.c) */
    uint8_t cull[BLOCK];                         /* 1: its rays find no caustics lamp (path.c; mnee.c), 0 elsewhere */
    int32_t seen_by[BLOCK];                      /* the kind of ray that reached it (HIDDEN_FROM_*, direct.ray_kind) */
    double held[BLOCK];                          /* per camera lane: the alpha holdouts take away (path.hold_out) */
    /* The light passes (lightpasses.c), where asked for: what a first hit gathers split by pass kind (not its
     * emission), and a path's shares by kind, set at its first real bounce. */
    double parts[BLOCK][PASS_KINDS][3];
    double shares[BLOCK][PASS_KINDS][3];
    /* The light groups (lightgroups.py), where asked for: what each hit gathers (L's share of it) by the group
     * of its source, (BLOCK, group_count, 3) beside the block; NULL: none. */
    double *groups;
    int64_t group_count;
    /* The denoising features (features.c), where asked for: whether a path still looks for its feature vertex, its
     * feature throughput, and what the hit's rays found (before the path's throughput). */
    uint8_t looking[BLOCK];
    double feature_tp[3 * BLOCK];
    double found[3 * BLOCK];
    /* Where it is: Embree's geometry, primitive and placement, and the barycentrics (the first-hit passes). */
    int64_t geometry[BLOCK], prim[BLOCK], instance[BLOCK];
    double bary[2 * BLOCK];
    double cutoff[BLOCK];                        /* its object's Shadow Terminator Geometry Offset (direct_light) */
    /* Participating media (core/volumes/media.c), where the render has some: the volume stack of the ray that reached
     * each hit, a path's volume-only boundaries crossed (no transparent bounce), and per camera lane the stack its
     * ray starts in with the extinction and emission along it. */
    VolumeStack inside[BLOCK];
    int32_t bounds[BLOCK];
    int32_t volume[BLOCK];                       /* a path's scattering events in media so far (Volume Bounces) */
    VolumeStack lane_inside[BLOCK];
    VolumeStack lane_start[BLOCK];               /* (the catcher-only scene: the stack at the catcher, ChunkParams.split) */
    double lane_sigma[BLOCK][3], lane_emission[BLOCK][3];
    double lane_scattered[BLOCK][3];             /* what the media scatter towards each camera lane (volume.c) */
} BlockHits;

/* The LightPath (graph.py) of the path at hit h of H, with the flags `flags` (its own: H->flags[h]). */
INLINE LightPath path_at(const BlockHits *H, int64_t h, int flags)
{
    LightPath p = {flags, H->bounce[h], H->diffuse[h], H->glossy[h], H->transmission[h], H->transparent[h],
                   H->portal[h], H->cone[h], H->spread[h]};
    return p;
}

/* Make hit h's ShaderResult ready to shade: its room for closures and their parameters in the block's buffers, no
 * caustics filter. */
INLINE void hit_closures(BlockHits *H, int64_t h)
{
    ShaderResult *sd = H->sd + h;
    sd->n = 0;
    sd->room = (int)H->room;
    sd->c = H->closures + h * H->room;
    sd->storage = H->storage + h * H->room * STORAGE_STRIDE;
    sd->caustics = 0;
    sd->blur = 0.0;
    sd->terminator = 1.0;
    sd->uncorrected = 0;
}

/* lightgroups.GroupLight.add for one contribution: value (3) x scale to row `row` of a (rows, count, 3) group
 * buffer, in group `group` (NONE, -1: nowhere). */
INLINE void add_to_group(double *groups, int64_t count, int64_t row, int64_t group, const double *value, double scale)
{
    if (groups == NULL || group < 0) return;
    double *out = groups + 3 * (row * count + group);
    for (int c = 0; c < 3; c++) out[c] += value[c] * scale;
}

/* Add the light groups `from` (G, 3) times scale (3, per channel) to `to` (G, 3); nothing where `to` is NULL. */
INLINE void add_groups(double *to, const double *from, int64_t G, const double *scale)
{
    if (to == NULL) return;
    for (int64_t g = 0; g < G; g++)
        for (int c = 0; c < 3; c++) to[3 * g + c] += from[3 * g + c] * scale[c];
}

/* The light group of the object an Embree hit is on (lightgroups.LightGroups.of_prims). */
INLINE int64_t group_of_hit(const int32_t *instance_groups, const GeometryTables *g, int64_t geometry, int64_t prim,
                            int64_t instance)
{
    if (instance_groups == NULL) return -1;
    int64_t owner = owner_of(g, geometry, prim, instance);
    return owner >= 0 ? (int64_t)instance_groups[owner] : -1;
}

/* A BSDF ray that hit a surface: where a path may go on from hit h (path.c). */
typedef struct {
    int64_t h;
    int hit;                                     /* 1: it hit a surface (a ray that escapes is kept where media scatter) */
    double O[3], D[3], t, u, v;
    int64_t geometry, prim, instance;
    double time;                                 /* its path's time in the shutter (where moving objects are) */
    double weight[3];                            /* f cos / pdf of the sampled closures */
    int kind;                                    /* the sampled closure's BSDF kind */
    int transmit;                                /* 1: it went through the surface */
    int walked;                                  /* 1: a subsurface walk's ray to its exit (subsurface.c) */
    double pdf;                                  /* the pdf MIS weighs what it finds with (inf: none) */
    double mis_O[3], mis_N[3];                   /* where MIS measures the light pdfs from (the last real bounce) */
    int seen_as;                                 /* its kind: the HIDDEN_FROM_* bit of objects it passes */
    LightPath path;                              /* the path it carries past the bounce (rays.path_after) */
    uint64_t receiver;                           /* the light set of the object it left (Light Linking) */
    double shares[PASS_KINDS][3];                /* its pass kinds' shares (lightpasses.c; light passes only) */
    VolumeStack inside;                          /* the media it crosses (media.c; with media only) */
    double attenuation[3];                       /* what they let through to its hit (1 without media) */
    int ao;                                      /* 1: Fast GI's short ray: its path ends at its hit */
    int cull;                                    /* 1: it finds no caustics lamp (BlockHits.cull of its hit) */
} PathRay;

/* direct.nearest_seen for lane k of a packet whose rays are of the kind `bit` (HIDDEN_FROM_*): while the lane's
 * hit is on an object hidden from that kind, the ray goes on past it (one ray at a time: only rays meeting such
 * an object come here), until it meets a seen object or nothing; the lane's hit and tfar (from O) are replaced. */
INLINE void see_past_hidden(const GeometryTables *g, Intersect8 intersect, void *scene, RayHitPacket *packet, int k,
                            const double *O, const double *D, double t_max, int bit, double time)
{
    while (packet->hit.geomID[k] != INVALID_ID
           && hidden_from(g, (int64_t)packet->hit.geomID[k], (int64_t)packet->hit.primID[k], instance_of(&packet->hit, k),
                          bit)) {
        /* On from just past the hidden triangle, for what is left of the ray. */
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(g, (int64_t)packet->hit.geomID[k], (int64_t)packet->hit.primID[k], instance_of(&packet->hit, k), 0,
                     time, &tri);
        Surface s;
        surface_at(O, D, (double)packet->ray.tfar[k], (double)packet->hit.u[k], (double)packet->hit.v[k], &tri, 0, &s);
        double P[3], gone[3];
        spawn_ray(s.I, s.Ng, D, s.offset, P);
        for (int c = 0; c < 3; c++) gone[c] = P[c] - O[c];
        double travelled = dot3(gone, D);
        RayHitPacket one;
        int valid[PACKET] ALIGNED(32);
        set_lane(&one.ray, 0, P, D, t_max - travelled);
        set_time(&one.ray, 0, time);
        close_packet(&one.ray, valid, 1);
        clear_hits(&one);
        intersect(valid, scene, &one, NULL);
        packet->hit.geomID[k] = one.hit.geomID[0];
        packet->hit.primID[k] = one.hit.primID[0];
        packet->hit.instID[0][k] = one.hit.instID[0][0];
        packet->hit.instPrimID[0][k] = one.hit.instPrimID[0][0];
        packet->hit.u[k] = one.hit.u[0];
        packet->hit.v[k] = one.hit.v[0];
        packet->ray.tfar[k] = (float)(travelled + (double)one.ray.tfar[0]);
    }
}

/* direct.goes_through: whether a direction sampled from a closure of kind `kind` counts as going through the
 * surface: a diffuse closure's by its class (a Lambert reflects, a translucent surface transmits), any other's by
 * the side of the face it leaves to (`transmit`). */
INLINE int goes_through(int kind, int transmit)
{
    if (bsdf_is(kind, BSDF_FLAG_DIFFUSE)) return bsdf_is(kind, BSDF_FLAG_TRANSMISSION);
    return transmit;
}

/* direct.ray_kind: the kind of the ray a bounce sends (the HIDDEN_FROM_* bit of the objects it passes): through
 * the surface a transmission ray, a diffuse reflection's a diffuse ray, any other reflection's a glossy ray;
 * straight through a Transparent closure the kind of the ray that arrived, `previous`. */
INLINE int ray_kind(int kind, int transmit, int previous)
{
    if (bsdf_is(kind, BSDF_FLAG_STRAIGHT)) return previous;
    if (goes_through(kind, transmit)) return HIDDEN_FROM_TRANSMISSION;
    return bsdf_is(kind, BSDF_FLAG_DIFFUSE) ? HIDDEN_FROM_DIFFUSE : HIDDEN_FROM_GLOSSY;
}

/* rays.path_after: the path a bounce's ray carries on from `p` (Cycles' path_state_next), the sampled closure of
 * kind `kind` through the face (transmit) or not, a delta (singular) or not. Straight through a Transparent closure:
 * one more transparent surface, the flags kept (a Ray Portal: one more portal too); any other closure: one more
 * bounce of its kind, and the flags its labels give (REFLECT or TRANSMIT; DIFFUSE, GLOSSY, or GLOSSY and SINGULAR).
 * The ray leaves with the path's ray cone as it was at the hit, t along the ray that reached it (Cycles' dP; dD
 * kept, 0 into a subsurface walk). clear: the bounce went through glass under Transparent Glass's threshold
 * (clears_glass), after which a path that cleared the film still does (CLEAR_GLASS). */
INLINE LightPath path_after(LightPath p, int kind, int transmit, int singular, double t, int clear)
{
    p.cone = p.cone + t * p.spread;
    if (bsdf_is(kind, BSDF_FLAG_STRAIGHT)) {
        p.transparent++;
        p.portal += bsdf_is(kind, BSDF_FLAG_PORTAL);     /* (Cycles' portal_bounce: Portal Depth) */
        return p;
    }
    if (bsdf_is(kind, BSDF_FLAG_SUBSURFACE)) { p.flags &= ~PATH_CLEARS_FILM; p.spread = 0.0; return p; }
    int through = goes_through(kind, transmit), diffuse = bsdf_is(kind, BSDF_FLAG_DIFFUSE);
    singular = singular || bsdf_is(kind, BSDF_FLAG_SINGULAR);
    p.bounce++;
    p.transmission += through;
    p.diffuse += !through && diffuse;
    p.glossy += !through && !diffuse;
    p.flags = (through ? PATH_TRANSMIT : PATH_REFLECT)
              | (diffuse ? PATH_DIFFUSE : (singular ? PATH_GLOSSY | PATH_SINGULAR : PATH_GLOSSY))
              | (clear && (p.flags & PATH_CLEARS_FILM) != 0 ? PATH_CLEAR_GLASS : 0);
    return p;
}

/* base.specular_roughness_squared for one closure: 0 for a SINGULAR BSDF, alpha_x alpha_y for a microfacet lobe
 * (BSDF_SPECULAR_ALPHA_PARAMS), 1 for any other (Cycles' bsdf_get_specular_roughness_squared). */
INLINE double specular_roughness_squared(const Closure *c)
{
    if (bsdf_is(c->kind, BSDF_FLAG_SINGULAR)) return 0.0;
    const int *where = BSDF_SPECULAR_ALPHA_PARAMS[c->kind];
    return where[0] >= 0 ? c->p[where[0]] * c->p[where[1]] : 1.0;
}

/* rays.clears_glass for one sampled closure c whose ray went through the face (transmit) or not: whether it keeps a
 * camera path clear under Transparent Glass's `threshold` (-1: off), Cycles' LABEL_TRANSMIT_TRANSPARENT. */
INLINE int clears_glass(const Closure *c, int transmit, double threshold)
{
    return threshold >= 0.0 && transmit && !bsdf_is(c->kind, BSDF_FLAG_DIFFUSE)
           && specular_roughness_squared(c) <= threshold;
}

/* path.hold_out for one hit of a camera path; object: 1 on a holdout object. Returns whether the hit holds out
 * at all, with weight (3) the share of the pixel's alpha it takes away (before the path's throughput). A holdout
 * object: weight = 1 - transparency, and the shader keeps only its Transparent closures and emits nothing. Else
 * the Holdout nodes' weight sd->holdout, the other closures kept; where it is exactly 1 the path stops there (no
 * closures, no emission). */
INLINE int hold_out(ShaderResult *sd, int object, double *weight)
{
    int n = 0;
    if (!object) {
        for (int c = 0; c < 3; c++) weight[c] = sd->holdout[c];
        if (weight[0] == 0.0 && weight[1] == 0.0 && weight[2] == 0.0) return 0;
        if (weight[0] == 1.0 && weight[1] == 1.0 && weight[2] == 1.0) {
            sd->n = 0;
            for (int c = 0; c < 3; c++) sd->emission[c] = 0.0;
        }
        return 1;
    }
    for (int c = 0; c < 3; c++) { weight[c] = 1.0 - sd->transparency[c]; sd->emission[c] = 0.0; }
    for (int k = 0; k < sd->n; k++)
        if (bsdf_is(sd->c[k].kind, BSDF_FLAG_STRAIGHT)) sd->c[n++] = sd->c[k];
    sd->n = n;
    return 1;
}

typedef struct {
    int64_t n;
    PathRay r[BLOCK];
} PathRays;

/* Light samples of one light, BLOCK at a time (structure of arrays, see sample_lanes). */
typedef struct {
    int64_t n;                                   /* lanes in use */
    int64_t hit[BLOCK];                          /* the hit each light sample belongs to */
    uint32_t pixel[BLOCK], index[BLOCK];         /* its random-number keys */
    double u[2][BLOCK];                          /* its point in the unit square */
    double P[3][BLOCK], N[3][BLOCK], Ng[3][BLOCK], lifted[3][BLOCK];
    double offset[BLOCK], smooth[BLOCK], through[BLOCK], cutoff[BLOCK];
    double time[BLOCK];                          /* its path's time in the shutter (where a moving emitter is) */
    double albedo[3][BLOCK], lambert[BLOCK];     /* the hit's one Lambert closure, where it has just that */
    double L[3][BLOCK], distance[BLOCK], strength[BLOCK], position[3][BLOCK], color[3][BLOCK], pdf[BLOCK];
    double light_normal[3][BLOCK];               /* the face normal of the emissive triangle sampled (else zero) */
    double origin[3][BLOCK], D[3][BLOCK], t[BLOCK], weight[BLOCK];
    double keep[BLOCK];                          /* 1: the ray can carry light */
    double f[3][BLOCK];                          /* f cos of the lane's hit's closures, for its light direction */
    double pdf_bsdf[BLOCK];                      /* and the pdf their sampling gives that direction (MIS) */
    int hidden[BLOCK];                           /* the HIDDEN_FROM_* bits of the sample's object (emitters) */
    int64_t emitter[BLOCK];                      /* the emissive triangle sampled (emitters) */
    int32_t group[BLOCK];                        /* the light group of its source (lightgroups.py; -1: none) */
    uint64_t blockers[BLOCK];                    /* its source's shadow membership (Shadow Linking; ALL_SETS: any) */
} SampleBlock;

/* Step 0: samples first .. first + n - 1 of a light with `count` samples per hit (sample s is sample
 * s % count of hit s / count): their hits' data, gathered into columns. */
SIMD_CLONES NOINLINE static void gather_block(SampleBlock *b, const BlockHits *H, int64_t first, int64_t n,
                                              int64_t count, int lift)
{
    int64_t i = first / count, j = first % count;
    b->n = n;
    for (int64_t k = 0; k < n; k++) {
        const Surface *s = H->s + i;
        b->hit[k] = i;
        b->pixel[k] = (uint32_t)H->pixel[i];
        b->index[k] = (uint32_t)(H->sample[i] * count + j);
        for (int c = 0; c < 3; c++) {
            b->P[c][k] = s->I[c];
            b->N[c][k] = s->N[c];
            b->Ng[c][k] = s->Ng[c];
            b->lifted[c][k] = lift && s->smooth ? s->lifted[c] : s->I[c];
        }
        b->offset[k] = s->offset;
        b->time[k] = s->time;
        b->cutoff[k] = lift ? H->cutoff[i] : 0.0;
        b->smooth[k] = s->smooth ? 1.0 : 0.0;
        b->through[k] = H->through[i] ? 1.0 : 0.0;
        b->lambert[k] = H->lambert[i] ? 1.0 : 0.0;
        for (int c = 0; c < 3; c++) b->albedo[c][k] = H->albedo[3 * i + c];
        if (++j == count) { j = 0; i++; }
    }
}

/* A light sample into the block's columns. */
INLINE void store_sample(SampleBlock *b, int64_t k, const LightSample *ls)
{
    for (int c = 0; c < 3; c++) {
        b->L[c][k] = ls->L[c];
        b->position[c][k] = ls->position[c];
        b->light_normal[c][k] = ls->normal[c];
    }
    b->distance[k] = ls->distance;
    b->strength[k] = ls->strength;
    b->pdf[k] = ls->pdf;
}

/* Step 1: where the light comes from (Light.sample through the lights' table). The most common kinds
 * get loops of their own, with no branch, which the compiler turns into SIMD lanes; the same numbers. */
SIMD_CLONES NOINLINE static void light_block(SampleBlock *restrict b, const LightRecord *restrict record,
                                             const LightContext *restrict ctx)
{
    const LightRecord copy = *record, *light = &copy;   /* a local copy: every lane may read every field */
    int kind = (int)light->kind;
    /* (a lamp with an IES Texture, a falloff or a node program takes the table's way, which applies them) */
    if (kind == LIGHT_AREA && light->ellipse == 0.0 && light->has_ies == 0 && light->has_falloff == 0
        && light->lamp_graph == NULL) {
        for (int64_t k = 0; k < b->n; k++) {
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]};
            LightSample ls;
            double u[2] = {b->u[0][k], b->u[1][k]};
            sample_area_light(light, P, u, &ls);      /* (its spherical rectangle, or its area) */
            ls.normal[0] = ls.normal[1] = ls.normal[2] = 0.0;   /* (a lamp: no surface to stop off) */
            store_sample(b, k, &ls);
            b->hidden[k] = 0;
        }
    } else if (kind == LIGHT_POINT && light->delta != 0.0 && light->has_ies == 0 && light->has_falloff == 0
               && light->lamp_graph == NULL) {
        for (int64_t k = 0; k < b->n; k++) {
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]};
            LightSample ls;
            sample_point(light, P, &ls);
            ls.normal[0] = ls.normal[1] = ls.normal[2] = 0.0;
            store_sample(b, k, &ls);
            b->hidden[k] = 0;
        }
    } else if (kind == LIGHT_EMITTERS && lone_quad(ctx->emitters) >= 0) {
        /* One quad lamp and nothing else to pick (Cornell boxes): its spherical rectangle in SIMD lanes, the lanes it
         * does not suit by sample_emitters itself; the same numbers either way. */
        const EmitterTables *e = ctx->emitters;
        int64_t i = lone_quad(e);
        uint8_t slow[BLOCK];
        quad_lamp_lanes(e, i, b->n, b->P, b->u, b->L, b->distance, b->strength, b->pdf, b->position, slow);
        int hidden = e->hidden != NULL ? (int)e->hidden[i] : 0;
        int32_t group = e->group != NULL ? e->group[i] : light->group;
        for (int c = 0; c < 3; c++)
            for (int64_t k = 0; k < b->n; k++) {
                b->light_normal[c][k] = e->normal[3 * i + c];
                b->color[c][k] = e->emission[3 * i + c];
            }
        for (int64_t k = 0; k < b->n; k++) {
            b->hidden[k] = hidden;
            b->emitter[k] = i;
            b->group[k] = group;
        }
        for (int64_t k = 0; k < b->n; k++) {
            if (!slow[k]) continue;
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]}, u[2] = {b->u[0][k], b->u[1][k]};
            LightSample ls;
            sample_emitters(e, P, NULL, u, b->time[k], &ls);     /* (one leaf: no normal weighs the pick) */
            store_sample(b, k, &ls);
        }
        return;
    } else {
        for (int64_t k = 0; k < b->n; k++) {
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]}, u[2] = {b->u[0][k], b->u[1][k]};
            /* (the light tree's normal, direct.tree_normals: unknown where a closure lets light through) */
            double N[3] = {b->N[0][k], b->N[1][k], b->N[2][k]};
            if (b->through[k] != 0.0) N[0] = N[1] = N[2] = 0.0;
            LightSample ls;
            ls.emitter = -1;
            ls.hidden = 0;
            if (kind == LIGHT_EMITTERS) sample_emitters(ctx->emitters, P, N, u, b->time[k], &ls);   /* (at its time) */
            else sample_light(light, ctx, P, N, u, &ls);
            store_sample(b, k, &ls);
            for (int c = 0; c < 3; c++) b->color[c][k] = ls.color[c];
            b->hidden[k] = ls.hidden;
            b->emitter[k] = ls.emitter;
            /* (an emitter's group is its object's) */
            const EmitterTables *e = ctx->emitters;
            b->group[k] = ls.emitter >= 0 && e != NULL && e->group != NULL ? e->group[ls.emitter] : light->group;
        }
        return;
    }
    /* (A lamp's colour and group are the same for all its samples: filled apart, so the loops above stay SIMD.) */
    for (int c = 0; c < 3; c++)
        for (int64_t k = 0; k < b->n; k++) b->color[c][k] = light->color[c];
    for (int64_t k = 0; k < b->n; k++) b->group[k] = light->group;
}

/* Step 2: the lecture's two tests, then the shadow ray (shadows.c) and the sample's scalar weight
 * E_normal / samples. (Inlined once for each offset method, so that the loop has no branch.) */
INLINE void ray_lanes(SampleBlock *restrict b, const ShadowSettings *restrict settings, int lift, double samples,
                      int robust)
{
    double lifting = lift ? 1.0 : 0.0;
    double fix = settings->terminator_fix != 0.0 ? 1.0 : 0.0;
    double epsilon = settings->epsilon;
    for (int64_t k = 0; k < b->n; k++) {
        double cutoff = b->cutoff[k];
        double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]}, L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]};
        double n[3] = {b->N[0][k], b->N[1][k], b->N[2][k]}, ng[3] = {b->Ng[0][k], b->Ng[1][k], b->Ng[2][k]};
        double lifted[3] = {b->lifted[0][k], b->lifted[1][k], b->lifted[2][k]};
        double position[3] = {b->position[0][k], b->position[1][k], b->position[2][k]};
        double light_normal[3] = {b->light_normal[0][k], b->light_normal[1][k], b->light_normal[2][k]};
        /* a. N.L > 0 and Ng.L > 0 (smooth points lifted by the terminator fix leave that to their ray); a
         *    surface that lets light through from behind takes light from both sides, reached from behind
         *    by a ray from its back (no lift): where the fix lifts, the lights behind N, else behind the face
         *    (vertex.reaching_from_behind: Cycles' shadow_ray_offset, its own face then not skipped). */
        double NL = dot3(n, L), NgL = dot3(ng, L);
        int lifts = (lifting * b->smooth[k]) != 0.0 && cutoff > 0.0;
        int through = b->through[k] != 0.0, behind = through & (lifts ? NL < 0.0 : NgL < 0.0);
        double cosine = through ? fabs(NL) : at_least(NL, 0.0);
        int face_allows = (NgL > 0.0) | ((fix * b->smooth[k]) != 0.0) | through;
        /* (a negative lamp takes light away, as in Cycles) */
        b->keep[k] = ((cosine != 0.0) & face_allows & ((b->strength[k] > 0.0) | (b->strength[k] < 0.0))) ? 1.0 : 0.0;
        if (behind) for (int c = 0; c < 3; c++) ng[c] = -ng[c];
        /* b. The ray, from I or the terminator fix's blend towards the lifted point (amount 0 elsewhere). */
        double amount = lifts && !behind ? terminator_amount(NL, NgL, cutoff) : 0.0;
        double origin[3], D[3], t;
        shadow_ray(P, ng, lifted, b->offset[k], amount, L, b->distance[k], position, light_normal, robust, epsilon,
                   origin, D, &t);
        for (int c = 0; c < 3; c++) { b->origin[c][k] = origin[c]; b->D[c][k] = D[c]; }
        b->t[k] = t;
        b->weight[k] = b->strength[k] * (1.0 / samples);
    }
}

SIMD_CLONES NOINLINE static void ray_block(SampleBlock *restrict b, const ShadowSettings *restrict settings,
                                           int lift, double samples)
{
    if (settings->robust != 0.0) ray_lanes(b, settings, lift, samples, 1);
    else ray_lanes(b, settings, lift, samples, 0);
}

/* Step 3: f cos of each lane's hit's closures for the light's direction (the BSDFs' table); blocks whose
 * hits are all one Lambert closure in a loop of their own (SIMD lanes), the same numbers. */
static void bsdf_block(SampleBlock *restrict b, const BlockHits *restrict H, int want_pdf)
{
    int lambert = 1;
    for (int64_t k = 0; k < b->n; k++) lambert &= (b->lambert[k] != 0.0) & (b->hidden[k] == 0);
    if (lambert) {
        for (int64_t k = 0; k < b->n; k++) {
            double e = at_least(b->N[0][k] * b->L[0][k] + b->N[1][k] * b->L[1][k] + b->N[2][k] * b->L[2][k], 0.0)
                       * (1.0 / PI);
            for (int j = 0; j < 3; j++) b->f[j][k] = b->albedo[j][k] * e;
            b->pdf_bsdf[k] = e;          /* (one closure: its own pdf) */
        }
        (void)want_pdf;
        return;
    }
    for (int64_t k = 0; k < b->n; k++) {
        int64_t h = b->hit[k];
        double L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]}, f[3];
        b->pdf_bsdf[k] = shader_eval_seen(H->sd + h, H->wo + 3 * h, L, f, b->hidden[k]);
        for (int c = 0; c < 3; c++) b->f[c][k] = f[c];
    }
}

/* The first-hit passes of a block's camera lanes (passes.c). */
typedef struct LanePasses LanePasses;

/* Step 4: the rays that can carry light go into packets, Embree answers each packet of 8, and what
 * gets through, (weight colour) f cos, is added to its hit's radiance in ray order. Returns the rays traced. */
typedef struct Transmitter Transmitter;
/* What transparent shadows read (shadows.transmittance): the scene's queries, tables and materials. */
struct Transmitter {
    Intersect8 intersect;
    void *scene;
    const GeometryTables *geometry;
    const MaterialRecord *materials;
    const GraphTables *graphs;
    int limit;                  /* the most transparent surfaces a shadow ray passes */
    const MediaTables *media;   /* the media shadow rays cross (media.c), or NULL: none */
};
INLINE void transmit_packet(const Transmitter *tr, int lanes, double O[][3], double D[][3], const double *t,
                            const double *times, const LightPath *paths, const uint64_t *blockers,
                            const VolumeStack *stacks, double T[][3]);

/* clamp.scale: the factor that caps a contribution value x throughput x count (channel sum) at limit (inf: none). */
INLINE double clamp_scale(const double *value, const double *throughput, double limit, double count)
{
    if (!(limit < INFINITY)) return 1.0;
    double total = 0.0;
    for (int c = 0; c < 3; c++) total += fabs(value[c] * throughput[c] * count);
    return total > limit ? limit / total : 1.0;
}

/* The cap on what hit h of H gathers: Clamp Direct at a path's first vertex, Clamp Indirect after a bounce. */
INLINE double clamp_limit(const BlockHits *H, int64_t h, const double *caps)
{
    return H->bounce[h] == 0 ? caps[0] : caps[1];
}

INLINE int64_t occlude_block(const SampleBlock *b, Occluded8 occluded8, void *scene, double *L_out,
                             const Transmitter *transmitter, const BlockHits *H, const double *caps, double count,
                             double (*parts)[PASS_KINDS][3], int cast_shadow)
{
    RayPacket ray;
    int valid[PACKET] ALIGNED(32);
    int64_t owner[PACKET], sample_of[PACKET], rays = 0;
    uint64_t blockers[PACKET];
    double value[PACKET][3], O[PACKET][3], D[PACKET][3], t[PACKET], T[PACKET][3], times[PACKET];
    LightPath paths[PACKET];
    VolumeStack stacks[PACKET];
    const MediaTables *media = transmitter != NULL ? transmitter->media : NULL;
    int lanes = 0;
    for (int64_t k = 0; k <= b->n; k++) {
        if (k < b->n) {
            if (b->keep[k] == 0.0) continue;
            for (int c = 0; c < 3; c++) { O[lanes][c] = b->origin[c][k]; D[lanes][c] = b->D[c][k]; }
            t[lanes] = b->t[k];
            set_lane(&ray, lanes, O[lanes], D[lanes], b->t[k]);
            times[lanes] = H->s[b->hit[k]].time;          /* (its path's time: where moving objects block it) */
            set_time(&ray, lanes, times[lanes]);
            owner[lanes] = b->hit[k];
            paths[lanes] = path_at(H, b->hit[k], PATH_SHADOW);      /* (a shadow ray: SHADOW alone) */
            /* (Cycles' shadow ray: the hit's footprint, not widening: dP = sd->dP, dD = 0) */
            paths[lanes].cone = paths[lanes].cone + H->s[b->hit[k]].t * paths[lanes].spread;
            paths[lanes].spread = 0.0;
            sample_of[lanes] = k;
            blockers[lanes] = b->blockers[k];
            if (media != NULL) {
                /* The media the shadow ray starts in: the hit's, into or out of its own where the light is behind it. */
                const Surface *sf = H->s + b->hit[k];
                double N[3] = {b->N[0][k], b->N[1][k], b->N[2][k]}, L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]};
                stacks[lanes] = H->inside[b->hit[k]];
                stack_cross(media, stacks + lanes, sf, dot3(N, L) < 0.0);
            }
            for (int c = 0; c < 3; c++) value[lanes][c] = (b->weight[k] * b->color[c][k]) * b->f[c][k];
            if (caps != NULL) {
                /* Sample clamping: the sample as the one-sample estimate it stands for (x count). */
                double f = clamp_scale(value[lanes], H->throughput + 3 * b->hit[k], clamp_limit(H, b->hit[k], caps), count);
                for (int c = 0; c < 3; c++) value[lanes][c] *= f;
            }
            if (++lanes < PACKET) continue;
        }
        if (lanes == 0) continue;
        if (!cast_shadow) {
            /* A lamp with Cast Shadow off: no shadow ray, its light passes whatever stands in the way. */
            for (int lane = 0; lane < lanes; lane++) {
                T[lane][0] = T[lane][1] = T[lane][2] = 1.0;
                double *e = L_out + 3 * owner[lane];
                for (int c = 0; c < 3; c++) e[c] += value[lane][c];
                add_to_group(H->groups, H->group_count, owner[lane], b->group[sample_of[lane]], value[lane], 1.0);
            }
        } else if (transmitter != NULL) {
            /* Transparent shadows: each ray carries the product of the transparencies it passes. */
            transmit_packet(transmitter, lanes, O, D, t, times, paths, blockers, media != NULL ? stacks : NULL, T);
            for (int lane = 0; lane < lanes; lane++) {
                double *e = L_out + 3 * owner[lane], got[3];
                for (int c = 0; c < 3; c++) { got[c] = value[lane][c] * T[lane][c]; e[c] += got[c]; }
                add_to_group(H->groups, H->group_count, owner[lane], b->group[sample_of[lane]], got, 1.0);
            }
        } else {
            close_packet(&ray, valid, lanes);
            occluded8(valid, scene, &ray, NULL);
            for (int lane = 0; lane < lanes; lane++) {
                if (ray.tfar[lane] < 0.0f) { T[lane][0] = T[lane][1] = T[lane][2] = 0.0; continue; }   /* blocked */
                T[lane][0] = T[lane][1] = T[lane][2] = 1.0;
                double *e = L_out + 3 * owner[lane];
                for (int c = 0; c < 3; c++) e[c] += value[lane][c];
                add_to_group(H->groups, H->group_count, owner[lane], b->group[sample_of[lane]], value[lane], 1.0);
            }
        }
        if (parts != NULL) {
            /* The light passes: a first hit's light sample split by the kinds' shares of f cos at its direction. */
            for (int lane = 0; lane < lanes; lane++) {
                int64_t h = owner[lane], k = sample_of[lane];
                if (H->bounce[h] != 0) continue;
                double L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]}, shares[PASS_KINDS][3], got[3];
                for (int c = 0; c < 3; c++) got[c] = value[lane][c] * T[lane][c];
                kind_shares(H->sd + h, H->wo + 3 * h, L, b->hidden[k], -1, shares);
                add_split(parts[h], got, &shares[0][0]);
            }
        }
        rays += cast_shadow ? lanes : 0;
        lanes = 0;
    }
    return rays;
}

/* Veach's power heuristic a^2 / (a^2 + b^2): 1 for a = inf (a delta strategy), 0 for a = 0 (direct.power_heuristic). */
INLINE double power_heuristic(double a, double b)
{
    if (a == INFINITY) return 1.0;
    if (!(a > 0.0)) return 0.0;
    double w = a * a / (a * a + b * b);
    return w == w ? w : 0.0;
}

/* The count MIS weighs a light's samples as: its samples, or 1 for a light that casts no shadow or has a Max Bounces,
 * as Cycles weighs its one sample per hit (vertex.mis_count). */
INLINE double mis_samples(const LightRecord *light)
{
    return light->cast_shadow != 0 && light->max_bounces >= 1024 ? (double)light->samples : 1.0;
}

/* How a render finds lights with extent: SAMPLE_* (RenderSettings.light_sampling, core/integrators/compiled.py). */

/* What direct_light reads besides the block's hits. */
typedef struct {
    const ShadowSettings *shadows;
    const LightRecord *lights;
    int64_t n_lights;
    const LightContext *context;
    Occluded8 occluded;
    Intersect8 intersect;
    void *scene;
    const GeometryTables *geometry;
    const MaterialRecord *materials;
    int mis;                    /* 1: weigh light samples against BSDF samples */
    int sampling;               /* SAMPLE_* */
    int bsdf_rays;              /* 1: trace one BSDF-sampled ray per hit */
    int emissive;               /* 1: some material emits (BSDF rays add what they hit emits) */
    int everywhere;             /* 1: every hit traces a BSDF ray (emitters or the world light the scene) */
    double seed;
    int64_t dimension;          /* a path's later vertices shift every sampling dimension by this */
    int gather;                 /* 1: BSDF rays add the light they find (lamps, emitters, the world) */
    PathRays *continuing;       /* where BSDF rays that hit a surface are kept for a path, or NULL */
    const MediaTables *media;   /* the render's media (core/volumes/media.c), or NULL: none */
    const GraphTables *graphs;  /* the materials' node-graph programs, or NULL (a path shades its vertices) */
    const Transmitter *transmitter;   /* transparent shadows, where some material lets light through; or NULL */
    int caustics;               /* the FILTER_* bits of hits a diffuse bounce's ray reached (path.caustics_bits) */
    double filter_glossy;       /* Cycles' Filter Glossy (0: off): path.filter_glossy_roughness */
    double caps[2];             /* sample clamping's caps (direct, indirect; clamp.limits) */
    int clamping;               /* 1: some cap is finite */
    int light_passes;           /* 1: first hits split what they gather by pass kind into BlockHits.parts */
    int64_t groups;             /* the light groups (lightgroups.py): hits gather by group into BlockHits.groups */
    const int32_t *instance_groups;   /* each object's group, or NULL */
    int64_t world_group;        /* the world's group (-1: none) */
    int features;               /* 1: BSDF rays add what they find to BlockHits.found (the denoising features) */
    double back[3];             /* the features' normal where a path scatters in a medium (rays.camera_back) */
    LanePasses *passes;         /* the first-hit passes (passes.c) the camera chains write, or NULL */
    int film_transparent;       /* 1: Film > Transparent (camera paths' rays that escape see no world) */
    double clear_glass;         /* Film > Transparent Glass: threshold^4 of alpha_x alpha_y (rays.clear_glass_threshold),
                                 * -1: off */
    int ao_bounces;             /* Fast GI (Replace): rays past these bounces are short (fast_gi_ray); 0: off */
    double ao_factor, ao_distance;   /* Fast GI: the world's scale for short rays, and how far they look */
    double ao_additive_factor;  /* Fast GI (Add): ambient occlusion at every path vertex times this (0: off) */
    const Transmitter *ao_transmitter;   /* what Add's rays pass (transparent surfaces, no media) */
    int mnee;                   /* 1: Shadow Caustics walk for caustics lamps (ChunkParams.mnee; mnee.c) */
    int mnee_limits[3];         /* the bounce limits a walked chain must fit: Max, Diffuse, Transmission Bounces */
} DirectSettings;

/* vertex.fast_gi_ray for one ray carrying `path` (its counters past the bounce that sent it): whether it is Fast GI's
 * short ray (Cycles' path_state_ao_bounce): bounce - transmission - (glossy > 0) + 1 past ao_bounces. */
INLINE int fast_gi_ray(const DirectSettings *ds, const LightPath *path)
{
    if (ds->ao_bounces == 0) return 0;
    return path->bounce - path->transmission - (path->glossy > 0) + 1 > ds->ao_bounces;
}

/* vertex.fast_gi_scatter: whether the phase ray of a scattering point on a ray whose path has made `bounce` real
 * bounces (`transmission`, `glossy` of them) is Fast GI's short ray (AO Bounces ao_bounces, 0: off), the scattering
 * event one more bounce. */
INLINE int fast_gi_scatter_past(int ao_bounces, int bounce, int transmission, int glossy)
{
    if (ao_bounces == 0) return 0;
    return (bounce + 1) - transmission - (glossy > 0) + 1 > ao_bounces;
}

INLINE int fast_gi_scatter(const DirectSettings *ds, int bounce, int transmission, int glossy)
{
    return fast_gi_scatter_past(ds->ao_bounces, bounce, transmission, glossy);
}

/* path.py: a camera chain's ray from hit h straight on through a transparent surface (passes.c). */
INLINE void passes_straight_on(LanePasses *lp, const DirectSettings *ds, const BlockHits *H, int64_t h,
                               const double *weight, const double *O, const double *D, int hit, double t,
                               const VolumeStack *inside);


/* shadows.transmittance for up to 8 shadow rays (O, D0, t: float64 origins, directions, lengths; paths: the
 * LightPath each carries, whose Transparent Depth grows by each surface passed): T, the share of light each carries
 * through the transparent surfaces it passes (0 where something opaque, or more than tr->limit surfaces less those
 * its path passed, is in the way); objects hidden from shadow rays are passed as if not there, and objects outside
 * the blocker sets of each ray's light (blockers: per lane, its shadow membership; NULL: all block).
 * Past a surface each ray goes on towards its own end point O + t D0 (short of the light), which stays put.
 * stacks: (lanes,) the media each ray starts in, or NULL (none): every stretch keeps exp(-sigma_t t) of the light,
 * volume-only boundaries count as no surface passed (VOLUME_BOUNDS_MAX at most), and each surface the ray goes
 * through changes its media. */
INLINE void transmit_packet(const Transmitter *tr, int lanes, double O[][3], double D0[][3], const double *t,
                            const double *times, const LightPath *paths, const uint64_t *blockers,
                            const VolumeStack *stacks, double T[][3])
{
    double origin[PACKET][3], left[PACKET], D[PACKET][3], end[PACKET][3];
    int alive[PACKET], passed[PACKET], crossed[PACKET];
    VolumeStack inside[PACKET];
    const MediaTables *media = stacks != NULL ? tr->media : NULL;
    for (int l = 0; l < lanes; l++) {
        crossed[l] = 0;
        if (media != NULL) inside[l] = shadow_stack(media, stacks + l);
        for (int c = 0; c < 3; c++) { T[l][c] = 1.0; origin[l][c] = O[l][c]; D[l][c] = D0[l][c]; }
        for (int c = 0; c < 3; c++) end[l][c] = O[l][c] + (isfinite(t[l]) ? t[l] : 0.0) * D0[l][c];
        left[l] = t[l];
        alive[l] = 1;
        passed[l] = 0;
    }
    for (;;) {
        RayHitPacket packet;
        int valid[PACKET] ALIGNED(32), lane_of[PACKET], n = 0;
        for (int l = 0; l < lanes; l++)
            if (alive[l]) {
                set_lane(&packet.ray, n, origin[l], D[l], left[l]);
                set_time(&packet.ray, n, times[l]);
                lane_of[n++] = l;
            }
        if (n == 0) return;
        close_packet(&packet.ray, valid, n);
        clear_hits(&packet);
        tr->intersect(valid, tr->scene, &packet, NULL);
        for (int k = 0; k < n; k++) {
            int l = lane_of[k];
            int met = packet.hit.geomID[k] != INVALID_ID;
            if (media != NULL) {
                /* The stretch up to the surface met (or to the light): what its media let through. */
                double sigma[3], e[3], kept[3], reach = met ? (double)packet.ray.tfar[k] : left[l];
                medium_along(media, inside + l, sigma, e);
                March march;                    /* (through a heterogeneous medium: its march, field.c) */
                const March *m = stretch_march(media, inside + l, origin[l], D[l], reach, sigma, e, &march);
                stretch_transmittance(m, sigma, reach, kept);
                for (int c = 0; c < 3; c++) T[l][c] *= kept[c];
            }
            if (!met) { alive[l] = 0; continue; }
            int64_t geometry = (int64_t)packet.hit.geomID[k], prim = (int64_t)packet.hit.primID[k];
            int64_t instance = instance_of(&packet.hit, k);
            int hidden = hidden_from(tr->geometry, geometry, prim, instance, HIDDEN_FROM_SHADOW);
            if (blockers != NULL && blockers[l] != ALL_SETS)      /* Shadow Linking: only its blocker sets stop it */
                hidden |= !in_sets(blockers[l], links_of(tr->geometry, geometry, prim, instance, 1));
            Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
            hit_triangle(tr->geometry, geometry, prim, instance, 1, times[l], &tri);
            int boundary = is_boundary(media, tri.material);
            /* (Cycles: a shadow ray passes what is left of the path's transparent bounces, the limit less its count) */
            if (!hidden && !boundary && passed[l] >= tr->limit - paths[l].transparent) {
                T[l][0] = T[l][1] = T[l][2] = 0.0; alive[l] = 0; continue;
            }
            passed[l] += !hidden && !boundary;
            crossed[l] += boundary;
            if (crossed[l] > VOLUME_BOUNDS_MAX) { T[l][0] = T[l][1] = T[l][2] = 0.0; alive[l] = 0; continue; }
            /* The surface passed: what its material lets through, seen along the ray. */
            double u = (double)packet.hit.u[k], v = (double)packet.hit.v[k];
            Surface s;
            surface_at(origin[l], D[l], (double)packet.ray.tfar[k], u, v, &tri, 0, &s);
            if (!hidden) {
                double wo[3] = {-D[l][0], -D[l][1], -D[l][2]};
                ShaderResult sd;
                no_closures(&sd);                   /* (only what it lets through counts) */
                LightPath path = paths[l];
                path.transparent += passed[l] - 1;
                /* (Ray Length: the distance from the shadow ray's start: Cycles measures each hit of its one ray) */
                double gone[3] = {s.I[0] - O[l][0], s.I[1] - O[l][1], s.I[2] - O[l][2]};
                s.t = sqrt(dot3(gone, gone));
                shade_hit(tr->graphs, tr->geometry, tr->materials + s.material, &tri, &s, geometry, prim, instance, u,
                          v, wo, &path, NULL, 0, &sd);
                double passes = tr->materials[s.material].shadow_opaque != 0.0 ? 0.0 : 1.0;
                /* (a Ray Portal's weight: as Cycles' shadow rays count it, portal.shadow_transparency) */
                int clear = sd.transparency[0] != 0.0 || sd.transparency[1] != 0.0 || sd.transparency[2] != 0.0;
                for (int c = 0; c < 3; c++) T[l][c] *= clear ? (sd.transparency[c] + sd.portal[c]) * passes : 0.0;
            }
            if (media != NULL) stack_cross(media, inside + l, &s, !hidden);
            /* On from just past that surface, for what is left of the way to the light: towards the ray's own
             * end point, so that the step off the surface (along its normal) does not carry the end onto the
             * light (Cycles moves only the start of its one shadow ray). A sun's ray keeps its direction. */
            double w[3];
            spawn_ray(s.I, s.Ng, D[l], s.offset, origin[l]);
            if (isfinite(t[l])) {
                for (int c = 0; c < 3; c++) w[c] = end[l][c] - origin[l][c];
                double length = sqrt(dot3(w, w));
                int ahead = dot3(w, D0[l]) > 0.0;
                for (int c = 0; c < 3; c++) D[l][c] = ahead ? w[c] / at_least(length, 1e-300) : D[l][c];
                left[l] = ahead ? length : 0.0;
            }
            alive[l] = T[l][0] > 0.0 || T[l][1] > 0.0 || T[l][2] > 0.0;
        }
    }
}

/* direct.barycentrics for one point P in the plane of triangle V: P = (1 - u - v) V0 + u V1 + v V2. */
INLINE void point_barycentrics(const double *V, const double *P, double *u, double *v)
{
    double e1[3], e2[3], d[3];
    for (int c = 0; c < 3; c++) { e1[c] = V[3 + c] - V[c]; e2[c] = V[6 + c] - V[c]; d[c] = P[c] - V[c]; }
    double d11 = dot3(e1, e1), d12 = dot3(e1, e2), d22 = dot3(e2, e2), p1 = dot3(d, e1), p2 = dot3(d, e2);
    double det = d11 * d22 - d12 * d12;
    *u = det > 0.0 ? (d22 * p1 - d12 * p2) / det : 1.0 / 3.0;
    *v = det > 0.0 ? (d11 * p2 - d12 * p1) / det : 1.0 / 3.0;
}

/* The surface s and material sd (its emission, transparency and holdout: no closures, no_closures) of triangle tri
 * (Embree's geometry, prim, instance) where the ray O + t D, carrying the path `path`, meets it at barycentrics
 * (u, v); emission_only: only sd->emission is read afterwards (shade_graph). */
INLINE void shade_along(const DirectSettings *ds, const Triangle *tri, int64_t geometry, int64_t prim,
                        int64_t instance, const double *O, const double *D, double t, double u, double v,
                        const LightPath *path, const ShaderKeys *keys, int emission_only, Surface *s,
                        ShaderResult *sd)
{
    surface_at(O, D, t, u, v, tri, 0, s);
    double wo[3] = {-D[0], -D[1], -D[2]};
    no_closures(sd);
    shade_hit(ds->graphs, ds->geometry, ds->materials + tri->material, tri, s, geometry, prim, instance, u, v, wo,
              path, keys, emission_only, sd);
}

/* direct.graph_emission for one point O + t D on triangle (geometry, prim, instance): what its material's node
 * graph emits back along -D (a texture's emission) to a ray carrying the path `path`; the barycentrics come from
 * the point. */
NOINLINE static void graph_emission(const DirectSettings *ds, int64_t geometry, int64_t prim, int64_t instance,
                           const double *O, const double *D, double t, double time, const LightPath *path,
                           const ShaderKeys *keys, double *out)
{
    Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
    hit_triangle(ds->geometry, geometry, prim, instance, 1, time, &tri);
    double P[3] = {O[0] + t * D[0], O[1] + t * D[1], O[2] + t * D[2]}, u, v;
    point_barycentrics(tri.V, P, &u, &v);
    Surface s;
    ShaderResult sd;
    shade_along(ds, &tri, geometry, prim, instance, O, D, t, u, v, path, keys, 1, &s, &sd);
    for (int c = 0; c < 3; c++) out[c] = sd.emission[c];
}

/* The Embree geometry, primitive and placement of WorldGeometry's flat triangle index `flat` (flat_prim's inverse). */
INLINE void unflat_prim(const GeometryTables *g, int64_t flat, int64_t *geometry, int64_t *prim, int64_t *instance)
{
    *geometry = 0; *prim = flat; *instance = 0;
    for (int64_t m = 0; m < (int64_t)g->instanced; m++) {
        const InstancedTables *mesh = g->meshes + m;
        int64_t first = (int64_t)mesh->first_prim, count = (int64_t)mesh->triangle_count;
        if (flat >= first && flat < first + count * (int64_t)mesh->placements) {
            *geometry = m + 1;
            *instance = (flat - first) / count;
            *prim = (flat - first) % count;
            return;
        }
    }
}

/* direct.textured_samples: the emitters' samples in the block that landed on a textured triangle bring what its
 * node graph emits there, in place of the triangle's estimate; the light's shading carries EMISSION alone and the
 * counts of the path at the lit hit (Cycles' light_sample_shader_eval). */
static void textured_block(SampleBlock *b, const BlockHits *H, const DirectSettings *ds)
{
    const EmitterTables *e = ds->context->emitters;
    for (int64_t k = 0; k < b->n; k++) {
        if (!(b->strength[k] > 0.0) || !e->textured[b->emitter[k]]) continue;
        int64_t geometry, prim, instance;
        unflat_prim(ds->geometry, e->prim[b->emitter[k]], &geometry, &prim, &instance);
        double O[3] = {b->P[0][k], b->P[1][k], b->P[2][k]}, D[3] = {b->L[0][k], b->L[1][k], b->L[2][k]}, out[3];
        LightPath path = path_at(H, b->hit[k], PATH_EMISSION);
        path.cone = path.spread = 0.0;      /* (no footprint, as Cycles' light samples) */
        graph_emission(ds, geometry, prim, instance, O, D, b->distance[k], b->time[k], &path, NULL, out);
        for (int c = 0; c < 3; c++) b->color[c][k] = out[c];
    }
}

/* A lamp's node program (lamp_graph.c) for each sample in the block, seen by the path at its hit: EMISSION alone and
 * that vertex's counts (Cycles' light_sample_shader_eval reads the integrator state's). */
static void lamp_tint_block(SampleBlock *b, const BlockHits *H, const LightRecord *light)
{
    for (int64_t k = 0; k < b->n; k++) {
        if (!(b->strength[k] > 0.0 || b->strength[k] < 0.0)) continue;
        LightPath path = path_at(H, b->hit[k], PATH_EMISSION);
        double position[3] = {b->position[0][k], b->position[1][k], b->position[2][k]};
        double leaving[3] = {-b->L[0][k], -b->L[1][k], -b->L[2][k]};
        double color[3] = {b->color[0][k], b->color[1][k], b->color[2][k]};
        lamp_graph_tint(light, position, leaving, b->distance[k], &path, color);
        for (int c = 0; c < 3; c++) b->color[c][k] = color[c];
    }
}

/* vertex.world_samples_seen: the world's samples in the block with the colour its program gives each for the path at
 * its hit (EMISSION alone, that vertex's counts; World.samples_seen: a graph reading Light Path's depths). */
static void world_seen_block(SampleBlock *b, const BlockHits *H, const WorldTables *world)
{
    for (int64_t k = 0; k < b->n; k++) {
        if (!(b->strength[k] > 0.0 || b->strength[k] < 0.0)) continue;
        LightPath path = path_at(H, b->hit[k], 0);     /* (world_seen adds EMISSION) */
        path.cone = path.spread = 0.0;
        double D[3] = {b->L[0][k], b->L[1][k], b->L[2][k]}, color[3];
        world_seen(world, D, &path, color);
        for (int c = 0; c < 3; c++) b->color[c][k] = color[c];
    }
}

/* compiled.graph_emission (primer_graph_emission): what n points O + t D on triangles prim (WorldGeometry's flat
 * indices) emit back along -D by their materials' node graphs, to rays other than the camera's with no path and no
 * footprint (the emitters' estimates: emitters.mean_graph_emission); the frame's geometry; nothing traced. */
static void graph_emission_rows(const GraphEmissionArgs *a)
{
    DirectSettings ds = {.geometry = a->geometry, .materials = a->materials, .graphs = a->graphs};
    LightPath path = {0};
    for (int64_t k = 0; k < a->n; k++) {
        int64_t geometry, prim, instance;
        unflat_prim(a->geometry, a->prim[k], &geometry, &prim, &instance);
        graph_emission(&ds, geometry, prim, instance, a->O + 3 * k, a->D + 3 * k, a->t[k], STILL_TIME, &path, NULL,
                       a->emission + 3 * k);
    }
}

/* Direct light at the block's hits, added to H->L: every light's samples, BLOCK at a time. Returns the
 * shadow rays traced; embree_ticks[0] += the time inside Embree's occlusion queries. */
/* direct.wants_bsdf_ray: whether each hit traces a BSDF ray, into H->traced. */
NOINLINE static void choose_bsdf_rays(BlockHits *H, const DirectSettings *ds)
{
    for (int64_t h = 0; h < H->m; h++) {
        const ShaderResult *sd = H->sd + h;
        int glossy = 0;
        int through = 0;
        for (int k = 0; k < sd->n; k++) {
            int kind = sd->c[k].kind;
            glossy |= !bsdf_is(kind, BSDF_FLAG_DIFFUSE);
            /* (direct.lets_light_through: a transmission that is not a delta takes light samples from behind) */
            through |= bsdf_is(kind, BSDF_FLAG_TRANSMISSION) && !bsdf_is(kind, BSDF_FLAG_SINGULAR);
        }
        H->through[h] = (uint8_t)through;
        H->traced[h] = (uint8_t)(ds->bsdf_rays && (ds->everywhere || glossy));
        /* The common material, one Lambert closure on the shading normal, as columns bsdf_block reads. */
        const Closure *c = sd->c;
        H->lambert[h] = (uint8_t)((sd->n == 1) & (c->kind == BSDF_LAMBERT) & (c->sample_weight > 0.0)
                                  & (sd->terminator <= 1.0) & (c->N[0] == H->s[h].N[0]) & (c->N[1] == H->s[h].N[1]) & (c->N[2] == H->s[h].N[2]));
        for (int j = 0; j < 3; j++) H->albedo[3 * h + j] = c->weight[j];
    }
}

/* WorldGeometry's flat triangle index of an Embree hit (copied, or a placement of an instanced mesh). */
INLINE int64_t flat_prim(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance)
{
    if (geometry <= 0) return prim;
    const InstancedTables *mesh = g->meshes + (geometry - 1);
    return (int64_t)mesh->first_prim + instance * (int64_t)mesh->triangle_count + prim;
}

/* vertex.lights_itself: an emitter's light samples on the very triangle they light, towards the side it is lit
 * from (Ng.L > 0; Ng.L < 0 for light through it from behind), carry nothing, as Cycles skips them. */
INLINE void skip_own_triangle(SampleBlock *b, const BlockHits *H, const DirectSettings *ds)
{
    const EmitterTables *e = ds->context->emitters;
    for (int64_t k = 0; k < b->n; k++) {
        int64_t h = b->hit[k];
        int64_t own = flat_prim(ds->geometry, H->geometry[h], H->prim[h], H->instance[h]);
        if (b->emitter[k] < 0) continue;
        int64_t other = e->partner != NULL ? e->partner[b->emitter[k]] : -1;    /* (a quad: either triangle) */
        if (e->prim[b->emitter[k]] != own && !(other >= 0 && e->prim[other] == own)) continue;
        double L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]};
        double n[3] = {b->N[0][k], b->N[1][k], b->N[2][k]}, ng[3] = {b->Ng[0][k], b->Ng[1][k], b->Ng[2][k]};
        double NgL = dot3(ng, L);
        if ((dot3(n, L) < 0.0 ? -NgL : NgL) > 0.0) b->strength[k] = 0.0;
    }
}

/* Light and shadow linking (core/lights/linking.py, vertex.py): each sample's source's shadow membership into
 * b->blockers, and no light from a source that does not light its hit's object (linking.lights_receivers). */
INLINE void link_block(SampleBlock *b, const BlockHits *H, const DirectSettings *ds, const LightRecord *light)
{
    const GeometryTables *g = ds->geometry;
    int emitter = light_is((int)light->kind, LIGHT_FLAG_EMITTER);
    for (int64_t k = 0; k < b->n; k++) {
        uint64_t lights = light->light_membership, shadows = light->shadow_membership;
        if (emitter && g->links != NULL && b->emitter[k] >= 0) {
            int64_t geometry, prim, instance;
            unflat_prim(g, ds->context->emitters->prim[b->emitter[k]], &geometry, &prim, &instance);
            lights = links_of(g, geometry, prim, instance, 2);
            shadows = links_of(g, geometry, prim, instance, 3);
        }
        b->blockers[k] = shadows;
        int64_t h = b->hit[k];
        if (lights != ALL_SETS && !in_sets(lights, links_of(g, H->geometry[h], H->prim[h], H->instance[h], 0)))
            b->strength[k] = 0.0;
    }
}

/* Shadow caustics for a block of a caustics lamp's samples (mnee.c, included after this file). */
static void mnee_block(SampleBlock *b, const BlockHits *H, const DirectSettings *ds, const LightRecord *light,
                       int64_t count);

NOINLINE static int64_t direct_light(BlockHits *H, const DirectSettings *ds, uint64_t *embree_ticks)
{
    const ShadowSettings *settings = ds->shadows;
    SampleBlock b;
    int64_t rays = 0;
    uint64_t embree = 0;
    int lift = settings->terminator_fix != 0.0;
    if (lift)                                    /* (each hit's object's own offset, or the render's) */
        for (int64_t h = 0; h < H->m; h++)
            H->cutoff[h] = terminator_offset_of(ds->geometry, H->geometry[h], H->prim[h], H->instance[h],
                                                settings->terminator_offset);
    for (int64_t l = 0; l < ds->n_lights; l++) {
        const LightRecord *light = ds->lights + l;
        int weighed = ds->mis && light->delta == 0.0 && light->hittable != 0.0 && light->use_mis != 0;
        if (ds->sampling == SAMPLE_BSDF && light->delta == 0.0 && light->hittable != 0.0 && light->use_mis != 0)
            continue;
        int64_t count = (int64_t)light->samples, total = H->m * count;
        for (int64_t first = 0; first < total; first += BLOCK) {
            gather_block(&b, H, first, total - first < BLOCK ? total - first : BLOCK, count, lift);
            if (light->delta == 0.0) {
                sample_lanes(b.n, stream_of((int64_t)ds->seed, (int64_t)light->dimension + ds->dimension), b.pixel, b.index,
                             b.u[0], b.u[1]);
            } else {
                for (int64_t k = 0; k < b.n; k++) b.u[0][k] = b.u[1][k] = 0.0;
            }
            light_block(&b, light, ds->context);
            if (light->lamp_graph != NULL) lamp_tint_block(&b, H, light);   /* (its tree, for each hit's path) */
            if (light_is((int)light->kind, LIGHT_FLAG_INFINITE) && ds->context->world->samples_seen != 0)
                world_seen_block(&b, H, ds->context->world);
            if (light->hidden != 0)                      /* a lamp's Ray Visibility: closures it leaves out */
                for (int64_t k = 0; k < b.n; k++) b.hidden[k] |= (int)light->hidden;
            if (light_is((int)light->kind, LIGHT_FLAG_EMITTER) && ds->context->emitters->textured != NULL)
                textured_block(&b, H, ds);
            if (light_is((int)light->kind, LIGHT_FLAG_EMITTER)) skip_own_triangle(&b, H, ds);
            link_block(&b, H, ds, light);
            if (light->max_bounces < 1024)              /* a light's Max Bounces: no samples at later hits */
                for (int64_t k = 0; k < b.n; k++)
                    if (H->bounce[b.hit[k]] > light->max_bounces) b.strength[k] = 0.0;
            ray_block(&b, settings, lift, (double)count);
            bsdf_block(&b, H, weighed);
            if (weighed)
                for (int64_t k = 0; k < b.n; k++)
                    if (H->traced[b.hit[k]] && b.blockers[k] == ALL_SETS)   /* (shadow-linked: samples alone) */
                        b.weight[k] = b.weight[k] * power_heuristic(mis_samples(light) * b.pdf[k], b.pdf_bsdf[k]);
            if (ds->mnee && ((int)light->caustics & 2) != 0 && ds->geometry->caustics != NULL)   /* (Shadow Caustics, mnee.c) */
                mnee_block(&b, H, ds, light, count);
            uint64_t start = ticks();
            rays += occlude_block(&b, ds->occluded, ds->scene, H->L, ds->transmitter, H,
                                  ds->clamping ? ds->caps : NULL, (double)count, ds->light_passes ? H->parts : NULL,
                                  light->cast_shadow != 0);
            embree += ticks() - start;
        }
    }
    embree_ticks[0] += embree;
    return rays;
}

/* A ray that brings back the light it finds (direct.gather_light's): from O along the unit D, ending at its hit
 * (geometry, prim, instance) at t, or escaping (hit 0); what it finds is weighed by MIS against each light's own
 * samples (where use_mis) with pdf, the pdf of the bounce that sent it. camera: 1 for a camera path's ray (a holdout
 * it hits emits nothing). P: where the light samples MIS weighs against were taken (the last real bounce's ray
 * origin; NULL: O), N the normal the light tree weighed the emitters by there (NULL: unknown). */
typedef struct {
    const double *O, *D;
    int hit;
    double t;
    int64_t geometry, prim, instance;
    double pdf;
    int use_mis, camera;
    const double *P, *N;
    int seen_as;            /* the ray's kind (HIDDEN_FROM_* bit): it passes lamps hidden from that kind */
    const LightPath *path;  /* the path it carries (the emitter it hits is shaded for it) */
    uint64_t receiver;      /* the light set of the object the ray left: it finds only emitters that light it */
    const double *sigma, *emission;   /* the extinction and emission (3) of the media it crosses, or NULL: none */
    /* What the Ambient Occlusion and Bevel nodes of a textured emitter it hits trace with (the next vertex's keys), or
     * NULL: they trace nothing. */
    const ShaderKeys *keys;
    const VolumeStack *inside;        /* the media it crosses (with sigma), for a march through heterogeneous ones */
    double time;            /* its time in the shutter (its path's): where a moving emitter it hit is */
    int ao;                 /* 1: Fast GI's short ray: the world it escapes to is scaled by ds->ao_factor */
    int cull;               /* 1: it finds no caustics lamp (a caster's ray on a path that left a receiver: mnee.c) */
} FindingRay;

/* direct.gather_light for one FindingRay: lamps with extent in front of its hit (they never block), the emission of
 * the surface hit, or the world, each weighed by MIS (a constant world with weight 1); added to light_L. A ray
 * straight on through transparent surfaces from P finds a light at |O + t D - P| from P (Cycles' mis_origin); an
 * emitter's radiance is the actual hit's; a lamp is met where the line from P meets it past O (the disk facing P for
 * a round lamp with soft falloff, as its light samples there saw it). groups_L: (ds->groups, 3) what it adds by the
 * group of each source (lightgroups.py), added to, or NULL. */
/* vertex.unlinked_finds' opposite for a ray other than the camera's: whether the emitter object it hit lights the
 * object the ray left (Light Linking) and has no blocker sets (Shadow Linking: its light samples alone find it). */
INLINE int finds_emitter(const GeometryTables *g, const FindingRay *ray)
{
    return in_sets(links_of(g, ray->geometry, ray->prim, ray->instance, 2), ray->receiver)
           && links_of(g, ray->geometry, ray->prim, ray->instance, 3) == ALL_SETS;
}

/* Whether a material may emit light: its node graph gives its emission, or its constant emission is not zero. */
INLINE int may_emit(const MaterialRecord *m)
{
    return m->graph_emits != 0 || m->emission[0] != 0.0 || m->emission[1] != 0.0 || m->emission[2] != 0.0;
}

NOINLINE static void gather_light(const DirectSettings *ds, const FindingRay *ray, double *light_L, double *groups_L)
{
    const double *O = ray->O, *D = ray->D, *P = ray->P, *N = ray->N;
    int hit = ray->hit, use_mis = ray->use_mis, camera = ray->camera;
    double t_limit = ray->t, pdf_b = ray->pdf;
    int64_t geometry = ray->geometry, prim = ray->prim, instance = ray->instance;
    const LightContext *ctx = ds->context;
    const double *sigma = ray->sigma;
    /* The media's emission along the ray up to its hit (no light sample finds it: not weighed); a heterogeneous
     * medium's by its march (field.c), built once where something asks for it (what the media let through below). */
    LazyMarch lazy;
    lazy_march_start(&lazy, ds->media, ray->inside, O, D, hit ? t_limit : INFINITY, sigma, ray->emission);
    if (sigma != NULL && ds->media != NULL && ds->media->emits != 0) {
        double emitted[3] = {0.0, 0.0, 0.0};            /* (its light group: the medium's object's, media.c) */
        stretch_emitted(lazy_march(&lazy), sigma, ray->emission, hit ? t_limit : INFINITY, emitted);
        for (int c = 0; c < 3; c++) light_L[c] += emitted[c];
        add_to_group(groups_L, ds->groups, 0, emission_group(ds->media, ray->inside, ds->world_group), emitted, 1.0);
    }
    int away = P != NULL && (P[0] != O[0] || P[1] != O[1] || P[2] != O[2]);
    double t_mis = t_limit, t_start = 0.0;      /* from P: how far the ray's end (inf: none) and its start O are */
    if (away) {
        double d[3];
        for (int c = 0; c < 3; c++) d[c] = O[c] - P[c];
        t_start = sqrt(dot3(d, d));
        if (hit) {
            for (int c = 0; c < 3; c++) d[c] = O[c] + t_limit * D[c] - P[c];
            t_mis = sqrt(dot3(d, d));
        }
    }
    int64_t emitters_index = -1, world_index = -1;
    for (int64_t l = 0; l < ds->n_lights; l++) {
        if (light_is((int)ds->lights[l].kind, LIGHT_FLAG_EMITTER)) emitters_index = l;
        if (light_is((int)ds->lights[l].kind, LIGHT_FLAG_INFINITE)) world_index = l;
    }
    /* a. Lamps with extent in front of the hit. */
    for (int64_t l = 0; l < ds->n_lights; l++) {
        const LightRecord *light = ds->lights + l;
        if (light->hittable == 0.0 || !light_is((int)light->kind, LIGHT_FLAG_POSITION | LIGHT_FLAG_DISTANT | LIGHT_FLAG_AREA))
            continue;                                   /* (emitters and the world are found below) */
        if (((int)light->hidden & ray->seen_as) != 0) continue;     /* a lamp's Ray Visibility */
        if (ray->cull && ((int)light->caustics & 1) != 0) continue; /* (Shadow Caustics: MNEE brings its light) */
        if (ray->seen_as != HIDDEN_FROM_CAMERA && !in_sets(light->light_membership, ray->receiver))
            continue;                                               /* Light Linking (camera rays see it) */
        /* Multiple Importance off: light samples alone find it; camera rays still see a lamp (not a sun disk) */
        if (light->use_mis == 0 && (ray->seen_as != HIDDEN_FROM_CAMERA || light_is((int)light->kind, LIGHT_FLAG_DISTANT)))
            continue;
        LightHit lh;
        if (away) {
            /* The lamp as the light samples at P see it (a round lamp with soft falloff: the disk facing P), met
             * on this stretch of the line, past O: its pdf from P, the radiance it sends along D. */
            if (!light_hit_for(light, P, D, t_mis, ray->path, &lh) || !(lh.t > t_start)) continue;
        } else if (!light_hit_for(light, O, D, t_limit, ray->path, &lh)) continue;
        if (sigma != NULL) {                            /* (what the media let through from the lamp) */
            double kept[3];
            stretch_transmittance(lazy_march(&lazy), sigma, away ? lh.t - t_start : lh.t, kept);
            for (int c = 0; c < 3; c++) lh.radiance[c] *= kept[c];
        }
        double w = use_mis ? power_heuristic(pdf_b, mis_samples(light) * lh.pdf) : 1.0;
        for (int c = 0; c < 3; c++) light_L[c] += lh.radiance[c] * w;
        add_to_group(groups_L, ds->groups, 0, light->group, lh.radiance, w);
    }
    /* b. An emissive surface the ray hits, weighed against the emitters' own samples. */
    /* (a camera path's ray, through Transparent closures, finds a holdout emitting nothing: a hole, path.hold_out) */
    /* (a surface whose material emits nothing is skipped: it would add 0 x w, w finite, to what is already there) */
    const MaterialRecord *material = hit && ds->emissive
        ? ds->materials + hit_material(ds->geometry, geometry, prim, instance) : NULL;
    if (material != NULL && may_emit(material) && !(camera && hidden_from(ds->geometry, geometry, prim, instance, HOLDOUT))
        && (ray->seen_as == HIDDEN_FROM_CAMERA || ds->geometry->links == NULL || finds_emitter(ds->geometry, ray))) {
        const double *emitted = material->emission;
        double textured[3];
        if (material->graph_emits != 0) {                 /* a texture's emission, where the ray landed */
            graph_emission(ds, geometry, prim, instance, O, D, t_limit, ray->time, ray->path, ray->keys, textured);
            emitted = textured;
        }
        int64_t index = emitters_index >= 0
            ? emitter_of_prim(ctx->emitters, flat_prim(ds->geometry, geometry, prim, instance)) : -1;
        double pdf_l = index >= 0 ? emitter_pdf(ctx->emitters, index, away ? P : O, N, D, t_mis, ray->time) : 0.0;
        double n_l = emitters_index >= 0 ? mis_samples(ds->lights + emitters_index) : 1.0;
        double w = use_mis ? power_heuristic(pdf_b, n_l * pdf_l) : 1.0;
        double through[3];
        if (sigma != NULL) {                            /* (what the media let through from the surface) */
            double kept[3];
            stretch_transmittance(lazy_march(&lazy), sigma, t_limit, kept);
            for (int c = 0; c < 3; c++) through[c] = emitted[c] * kept[c];
            emitted = through;
        }
        for (int c = 0; c < 3; c++) light_L[c] += emitted[c] * w;
        if (groups_L != NULL)
            add_to_group(groups_L, ds->groups, 0, group_of_hit(ds->instance_groups, ds->geometry, geometry, prim, instance),
                         emitted, w);
    }
    /* c. The world, where the ray escapes and its kind sees it (a camera path's ray, straight on through clear
     *    surfaces, where the camera does and the film is opaque; any other where the world lights: Cycles'
     *    visibility by the ray's flags): a constant world with weight 1, an image by MIS. */
    int camera_kind = ray->path != NULL && (ray->path->flags & PATH_CAMERA) != 0;
    int clear_glass = ray->path != NULL && (ray->path->flags & PATH_CLEAR_GLASS) != 0;
    int sees_world = camera_kind ? ctx->world->camera != 0.0 && !ds->film_transparent
                                 : ctx->world->lights != 0.0 && (ray->seen_as & ctx->world->hidden) == 0
                                   && !(clear_glass && ds->film_transparent);
    if (!hit && sees_world) {
        double L_world[3], pdf_world = 0.0;              /* (a camera path's: the world's graph per ray) */
        int weighed = world_index >= 0 && use_mis;
        world_seen_pdf(ctx->world, D, ray->path, L_world, weighed ? &pdf_world : NULL);
        if (sigma != NULL) {                            /* (an escaping ray through a medium keeps exp(-sigma inf)) */
            double kept[3];
            stretch_transmittance(lazy_march(&lazy), sigma, INFINITY, kept);
            for (int c = 0; c < 3; c++) L_world[c] *= kept[c];
        }
        double w = 1.0;
        if (weighed)
            w = power_heuristic(pdf_b, mis_samples(ds->lights + world_index) * pdf_world);
        if (ray->ao)                                    /* (Fast GI: its MIS weight kept, as Cycles') */
            for (int c = 0; c < 3; c++) L_world[c] *= ds->ao_factor;
        for (int c = 0; c < 3; c++) light_L[c] += L_world[c] * w;
        add_to_group(groups_L, ds->groups, 0, ds->world_group, L_world, w);
    }
}

/* direct.bsdf_ray's subsurface walk from hit h of H along the BSSRDF sample s (its closure, s->slot; or
 * Christensen-Burley's disk, subsurface_disk): the walk's exit (none where the direction was not below the face), and the ray O, D (3 each) that reaches it from outside,
 * from beyond the exit back along the walk's last step (subsurface.exit_ray). */
NOINLINE static void walk_from(const BlockHits *H, int64_t h, const DirectSettings *ds, const ShaderRays *traced,
                               const ClosureSample *s, WalkExit *walk, double *O, double *D)
{
    const Surface *sf = H->s + h;
    walk->exits = 0;
    for (int c = 0; c < 3; c++) walk->weight[c] = O[c] = D[c] = 0.0;
    walk->t = 0.0;
    const Closure *bssrdf = H->sd[h].c + s->slot;
    if (bssrdf->p[SUBSURFACE_DISK] != 0.0)              /* (Christensen-Burley: the disk, no walk) */
        subsurface_disk(traced, sf, H->geometry[h], H->prim[h], H->instance[h], bssrdf, s->weight, H->pixel[h],
                        H->sample[h], ds->dimension, walk);
    else if (!(dot3(sf->Ng, s->wi) < 0.0)) return;      /* (an entry above Ng fails, as Cycles') */
    else
        subsurface_walk(traced, sf, H->geometry[h], H->prim[h], H->instance[h], bssrdf, s->wi, s->weight,
                        H->throughput + 3 * h, H->pixel[h], H->sample[h], ds->dimension, walk);
    double back = at_least(walk->t, 1e-6);
    for (int c = 0; c < 3; c++) { O[c] = walk->P[c] + walk->D[c] * back; D[c] = -walk->D[c]; }
}

/* portal.origins for one camera-relative hit at I: a portal closure's ray (params p) leaves from its Position (a world
 * point, minus the geometry's `origin`) where that is linked and more than 1e-9 (squared) away from the hit; O (3) is
 * left alone (the step off the surface) elsewhere. */
INLINE void portal_origin(const double *p, const double *I, const double *origin, double *O)
{
    double P[3], gap[3];
    for (int c = 0; c < 3; c++) { P[c] = p[PORTAL_POSITION + c] - origin[c]; gap[c] = P[c] - I[c]; }
    if (p[PORTAL_POSITION_SET] != 0.0 && dot3(gap, gap) > 1e-9)
        for (int c = 0; c < 3; c++) O[c] = P[c];
}

/* The light one direction sampled from each hit's closures finds (direct.bsdf_ray): a lamp with extent
 * in front of what the ray hits, an emissive surface it hits, or the world it escapes to, weighed by
 * MIS against that light's own samples (1 for a constant world); added to H->L. Returns Embree's ticks. */
NOINLINE static uint64_t bsdf_rays(BlockHits *H, const DirectSettings *ds)
{
    uint32_t stream = stream_of((int64_t)ds->seed, 2 + ds->dimension);
    uint32_t pick_stream = stream_of((int64_t)ds->seed, 3 + ds->dimension);
    uint64_t embree = 0;
    ShaderRays traced = {ds->intersect, ds->occluded, ds->scene, ds->geometry, ds->seed};
    RayHitPacket packet;
    int valid[PACKET] ALIGNED(32);
    int64_t owner[PACKET];
    ClosureSample sampled[PACKET];
    double origin[PACKET][3];
    int kinds[PACKET];
    LightPath after[PACKET];
    int ao[PACKET];                              /* 1: Fast GI's short ray (fast_gi_ray) */
    double t_max[PACKET];
    /* The hits' sample points (sobol.sample_2d, the same numbers) all at once in SIMD lanes: each hit's direction
     * (u) and the number that picks its closure (pick: the first coordinate alone, its second unused). */
    uint32_t key_pixel[BLOCK], key_index[BLOCK];
    double u0[BLOCK], u1[BLOCK], pick0[BLOCK];
    for (int64_t h = 0; h < H->m; h++) {
        key_pixel[h] = (uint32_t)H->pixel[h];
        key_index[h] = (uint32_t)H->sample[h];
    }
    sample_lanes(H->m, stream, key_pixel, key_index, u0, u1);
    sample_lanes_x(H->m, pick_stream, key_pixel, key_index, pick0);
    int lanes = 0;
    for (int64_t h = 0; h <= H->m; h++) {
        if (h < H->m) {
            /* a. A direction from the hit's closures, and the ray that leaves on its side. */
            ClosureSample *s = sampled + lanes;
            if (!H->traced[h]) continue;
            double u[2] = {u0[h], u1[h]};
            const Surface *sf = H->s + h;
            shader_sample(H->sd + h, H->wo + 3 * h, u, pick0[h], sf->Ng, s);
            if (!(s->pdf > 0.0)) continue;
            spawn_ray(sf->I, sf->Ng, s->wi, ds->shadows->robust != 0.0 ? sf->offset : ds->shadows->epsilon, origin[lanes]);
            if (bsdf_is(s->kind, BSDF_FLAG_PORTAL)) portal_origin(H->sd[h].c[s->slot].p, sf->I, ds->geometry->origin, origin[lanes]);
            /* The path it carries past the bounce; Fast GI's short ray looks ao_distance far. */
            int transmit = dot3(sf->Ng, s->wi) < 0.0;
            kinds[lanes] = ray_kind(s->kind, transmit, H->seen_by[h]);
            after[lanes] = path_after(path_at(H, h, H->flags[h]), s->kind, transmit, s->delta, sf->t,
                                      clears_glass(H->sd[h].c + s->slot, transmit, ds->clear_glass));
            ao[lanes] = fast_gi_ray(ds, after + lanes) && !bsdf_is(s->kind, BSDF_FLAG_SUBSURFACE);
            t_max[lanes] = ao[lanes] ? ao_distance_of(ds->geometry, H->geometry[h], H->prim[h], H->instance[h],
                                                      ds->ao_distance) : INFINITY;
            set_lane(&packet.ray, lanes, origin[lanes], s->wi, t_max[lanes]);
            set_time(&packet.ray, lanes, sf->time);
            owner[lanes] = h;
            if (++lanes < PACKET) continue;
        }
        if (lanes == 0) continue;
        /* b. Embree's nearest hits, 8 at a time. */
        close_packet(&packet.ray, valid, lanes);
        clear_hits(&packet);
        uint64_t start = ticks();
        ds->intersect(valid, ds->scene, &packet, NULL);
        for (int k = 0; k < lanes; k++) {
            /* Each ray passes the objects hidden from its kind (direct.nearest_seen). */
            const ClosureSample *s = sampled + k;
            if (packet.hit.geomID[k] != INVALID_ID && ds->geometry->hidden != NULL)
                see_past_hidden(ds->geometry, ds->intersect, ds->scene, &packet, k, origin[k], s->wi, t_max[k],
                                kinds[k], H->s[owner[k]].time);
        }
        embree += ticks() - start;
        for (int k = 0; k < lanes; k++) {
            const ClosureSample *s = sampled + k;
            const double *O = origin[k], *D = s->wi, *weight = s->weight;
            int hit = packet.hit.geomID[k] != INVALID_ID;
            double t_limit = hit ? (double)packet.ray.tfar[k] : INFINITY;
            double hit_u = (double)packet.hit.u[k], hit_v = (double)packet.hit.v[k];
            int64_t hit_geometry = (int64_t)packet.hit.geomID[k], hit_prim = (int64_t)packet.hit.primID[k];
            int64_t hit_instance = instance_of(&packet.hit, k);
            /* Into a BSSRDF: a walk inside the mesh, and a ray that reaches its exit from outside instead of the one
             * traced (direct.bsdf_ray, subsurface.exit_ray). */
            int walked = bsdf_is(s->kind, BSDF_FLAG_SUBSURFACE);
            WalkExit walk;
            double exit_O[3], exit_D[3];
            if (walked) {
                walk_from(H, owner[k], ds, &traced, s, &walk, exit_O, exit_D);
                O = exit_O;
                D = exit_D;
                weight = walk.weight;
                hit = walk.exits;
                t_limit = hit ? at_least(walk.t, 1e-6) : INFINITY;
                hit_u = walk.u; hit_v = walk.v;
                hit_geometry = walk.geometry; hit_prim = walk.prim; hit_instance = walk.instance;
                kinds[k] = H->seen_by[owner[k]];
            }
            double pdf_b = s->delta ? INFINITY : s->pdf;
            int use_mis = ds->mis && !s->delta;
            /* The light-tree normal as its light samples had it (zero: unknown), and where MIS measures from. */
            const double *N = H->through[owner[k]] ? NULL : H->s[owner[k]].N;
            const double *P = O;
            int64_t h = owner[k];
            uint64_t receiver = links_of(ds->geometry, H->geometry[h], H->prim[h], H->instance[h], 0);
            if (bsdf_is(s->kind, BSDF_FLAG_STRAIGHT) && ds->continuing != NULL) {
                /* Straight through a transparent surface: still the last real bounce's ray (direct.bsdf_ray); through a
                 * portal no longer (MIS skipped: pdf inf). */
                if (!bsdf_is(s->kind, BSDF_FLAG_PORTAL)) {
                    pdf_b = H->mis_pdf[owner[k]];
                    use_mis = ds->mis && isfinite(pdf_b);
                    P = H->mis_origin + 3 * owner[k];
                    N = H->mis_n + 3 * owner[k];
                }
                receiver = H->mis_receiver[owner[k]];    /* (Light Linking: the last real bounce's object) */
            }
            double light_L[3] = {0.0, 0.0, 0.0}, shares[PASS_KINDS][3];
            int first = ds->light_passes && H->bounce[owner[k]] == 0;
            /* The ray's media (the hit's own where it went through the surface), and what they let through to its
             * hit (direct.bsdf_ray's media_beyond). */
            VolumeStack inside;
            double sigma[3] = {0.0, 0.0, 0.0}, emission[3] = {0.0, 0.0, 0.0}, attenuation[3] = {1.0, 1.0, 1.0};
            int transmit = !walked && dot3(H->s[owner[k]].Ng, D) < 0.0;
            if (ds->media != NULL) {
                const Surface *sf = H->s + owner[k];
                inside = H->inside[owner[k]];
                stack_cross(ds->media, &inside, sf, goes_through(s->kind, transmit));
                if (walked && walk.exits)       /* (a walk's exit: the media across from its entry, walk_media) */
                    walk_media(ds->media, ds->geometry, ds->intersect, ds->scene, sf->I, walk.P,
                               owner_of(ds->geometry, H->geometry[owner[k]], H->prim[owner[k]], H->instance[owner[k]]),
                               &inside);
                /* (Fast GI's short ray that meets nothing leaves every mesh's medium: Cycles' volume_stack_clean) */
                if (ao[k] && !hit) stack_empty(&inside);
                medium_along(ds->media, &inside, sigma, emission);
                March march;                    /* (through a heterogeneous medium: its march, field.c) */
                if (!walked)                    /* (the walk's ray is no ray through the medium outside) */
                    stretch_transmittance(stretch_march(ds->media, &inside, O, D, t_limit, sigma, emission, &march),
                                          sigma, t_limit, attenuation);
            }
            if (first)
                sample_shares(H->sd + owner[k], H->wo + 3 * owner[k], s, dot3(H->s[owner[k]].Ng, D) < 0.0, shares);
            /* (and a camera path's escape with a transparent film: how clear it leaves the film, path.c) */
            int clears = !hit && ds->film_transparent && (after[k].flags & PATH_CLEARS_FILM) != 0;
            if ((hit || clears || (ds->media != NULL && ds->media->scatters != 0)) && ds->continuing != NULL) {
                PathRay *r = ds->continuing->r + ds->continuing->n++;
                r->h = owner[k];
                r->hit = hit;
                r->t = t_limit;
                r->u = hit_u;
                r->v = hit_v;
                r->geometry = hit_geometry;
                r->prim = hit_prim;
                r->instance = hit_instance;
                r->time = H->s[owner[k]].time;
                r->kind = s->kind;
                r->walked = walked;
                r->transmit = transmit;
                r->pdf = pdf_b;
                r->seen_as = kinds[k];
                r->path = after[k];
                r->receiver = receiver;
                r->ao = ao[k];
                r->cull = ds->mnee ? H->cull[owner[k]] : 0;
                for (int c = 0; c < 3; c++) { r->O[c] = O[c]; r->D[c] = D[c]; r->weight[c] = weight[c]; }
                for (int c = 0; c < 3; c++) { r->mis_O[c] = P[c]; r->mis_N[c] = N != NULL ? N[c] : 0.0; }
                for (int c = 0; c < 3; c++) r->attenuation[c] = attenuation[c];
                if (ds->media != NULL) r->inside = inside;
                if (first)
                    for (int p = 0; p < PASS_KINDS; p++)
                        for (int c = 0; c < 3; c++) r->shares[p][c] = shares[p][c];
            }
            if (ds->passes != NULL && H->bounce[owner[k]] == 0 && bsdf_is(s->kind, BSDF_FLAG_STRAIGHT))
                passes_straight_on(ds->passes, ds, H, owner[k], s->weight, O, D, hit, t_limit,
                                   ds->media != NULL ? &inside : NULL);
            if (!ds->gather || walked) continue;     /* (a walk's exit gathers at the next vertex) */
            double groups_L[3 * MAX_LIGHT_GROUPS];
            for (int64_t i = 0; i < 3 * ds->groups; i++) groups_L[i] = 0.0;
            /* (the surface it hits is the next vertex: its Ambient Occlusion and Bevel nodes trace with its keys) */
            int clear = bsdf_is(s->kind, BSDF_FLAG_STRAIGHT);
            double below = H->min_pdf[h], next_min = clear || !(pdf_b < below) ? below : pdf_b;
            ShaderKeys next = {&traced, H->pixel[h], H->sample[h], ds->dimension + VERTEX_DIMENSIONS,
                               next_min < BEVEL_MIN_PDF, NULL};
            FindingRay finding = {O, D, hit, hit ? t_limit : t_max[k], (int64_t)packet.hit.geomID[k],
                                  (int64_t)packet.hit.primID[k], instance_of(&packet.hit, k), pdf_b, use_mis,
                                  kinds[k] == HIDDEN_FROM_CAMERA, P, N, kinds[k], after + k, receiver,
                                  ds->media != NULL ? sigma : NULL, emission, &next,
                                  ds->media != NULL ? &inside : NULL, H->s[owner[k]].time, ao[k],
                                  ds->mnee ? H->cull[owner[k]] : 0};
            gather_light(ds, &finding, light_L, H->groups != NULL ? groups_L : NULL);
            double *L = H->L + 3 * owner[k], found[3];
            for (int c = 0; c < 3; c++) found[c] = s->weight[c] * light_L[c];
            double f = ds->clamping ? clamp_scale(found, H->throughput + 3 * owner[k],
                                                  clamp_limit(H, owner[k], ds->caps), 1.0) : 1.0;
            for (int c = 0; c < 3; c++) L[c] += found[c] * f;
            if (ds->features)
                for (int c = 0; c < 3; c++) H->found[3 * owner[k] + c] += found[c] * f;
            if (H->groups != NULL)                 /* (the same weight and cap, by the group of each find) */
                for (int64_t g = 0; g < ds->groups; g++) {
                    double got[3];
                    for (int c = 0; c < 3; c++) got[c] = s->weight[c] * groups_L[3 * g + c];
                    add_to_group(H->groups, H->group_count, owner[k], g, got, f);
                }
            if (first) {
                for (int c = 0; c < 3; c++) found[c] *= f;
                add_split(H->parts[owner[k]], found, &shares[0][0]);
            }
        }
        lanes = 0;
    }
    return embree;
}
