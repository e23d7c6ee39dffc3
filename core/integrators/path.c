/* Path tracing: core/integrators/path.py. Every vertex is a block of hits that direct.c lights (light
 * samples, and a BSDF ray that gathers what it finds); the BSDF rays that hit a surface become the next
 * block of vertices, within the bounce limits and Russian roulette. */

/* VERTEX_DIMENSIONS and ROULETTE_DIMENSION come from path.py (core/native/boundary.gen.h). */

/* Russian roulette's probability that a path carrying `largest` (the largest channel of its throughput, >= 0) goes
 * on: min(max(sqrt(t), ROULETTE_KEEP t), 1), never below Cycles' min(sqrt(t), 1) (path.py survival). */
INLINE double survival(double largest)
{
    return at_most(at_least(sqrt(largest), ROULETTE_KEEP * largest), 1.0);
}

/* A path's bounce limits (RenderSettings, Cycles' meaning) and where Russian roulette starts. */
typedef struct {
    int max_bounces, diffuse_bounces, glossy_bounces, transmission_bounces, transparent_bounces, roulette_from;
    int volume_bounces;                        /* how often a path goes on from where it scatters in media */
} PathLimits;

/* A scattering point's phase-sampled ray where the path goes on along it (volume.scattered_light's phase_out): its
 * direction and pdf, and what it hit (hit 0: it escaped, t inf). */
typedef struct {
    double wi[3], pdf, t, u, v;
    int hit;
    int64_t geometry, prim, instance;
} PhaseRay;

/* A path that scattered in media and reached a surface (volume.multiple_scattering's arrivals): its throughput
 * there, its last ray from O along ray.wi, its bounces and scattering events so far, the media it is in; the other
 * counters and its camera lane are those of the vertex it came from. */
typedef struct {
    double throughput[3], O[3];
    PhaseRay ray;
    int bounce, volume;
    VolumeStack inside;
    int64_t lane, pixel, sample;
    double min_pdf;                            /* the smallest pdf of its real bounces and phase rays */
    int diffuse, glossy, transmission, transparent, portal, bounds;
    double cone, spread;                       /* its ray cone from the scattering point (arrival_cone) */
    double shares[PASS_KINDS][3];              /* its path's light passes' shares (lightpasses.c stretch_shares) */
} Arrival;

/* path.with_arrivals' ray cone for arrival a, whose path's ray had `cone` and `spread`: a scattering point has no
 * footprint and its ray keeps the spread (Cycles: dP 0, dD kept); an unknown cone stays unknown. */
static void arrival_cone(Arrival *a, double cone, double spread)
{
    a->cone = cone < 0.0 ? UNKNOWN_CONE : 0.0;
    a->spread = cone < 0.0 ? 0.0 : spread;
}

/* What a chunk's paths need beyond the camera's block: two blocks of vertices to alternate between, the
 * BSDF rays that go on, and each camera lane's light from vertices after the first. */
typedef struct {
    BlockHits a, b;
    PathRays rays;
    double extra[BLOCK][3];
    double light[BLOCK][LIGHT_CHANNELS];       /* each camera lane's light passes (lightpasses.c), where asked for */
    double lane_light[BLOCK][LIGHT_CHANNELS];  /* the same of what the media scatter along each camera ray and its
                                                * chains bring (chunk.c), beside its hit's path's */
    double *groups;                            /* (BLOCK, G, 3) each camera lane's light groups from vertices after
                                                * the first (lightgroups.py), or NULL */
    double features[BLOCK][FEATURE_CHANNELS];  /* each camera lane's denoising features (features.c), where asked for */
    double reach[BLOCK];                       /* each camera lane's odds of looking on past its media (features.c) */
    double camera_features[BLOCK][FEATURE_CHANNELS];   /* what the media in front of each camera lane write */
    Arrival arrivals[BLOCK];                   /* the paths that scattered along a block's rays and reached a surface */
    int64_t n_arrivals;
    BlockHits c;                               /* the camera rays' arrivals, a block of vertex 0 (chunk.c) */
    double *lane_groups;                       /* (BLOCK, G, 3) by light group, what the camera rays' chains bring
                                                * each lane beside the media's own light (chunk.c), or NULL */
} PathWork;

/* path.filter_glossy_roughness for one hit: the roughness its microfacet lobes are raised to after bounces of smallest
 * pdf min_pdf, 0.5 sqrt(1 - min_pdf / filter_glossy) where that is below 1, else 0 (and 0 with the setting off). */
INLINE double filter_glossy_roughness(double filter_glossy, double min_pdf)
{
    if (!(filter_glossy > 0.0)) return 0.0;
    double ratio = min_pdf / filter_glossy;
    return ratio < 1.0 ? 0.5 * sqrt(1.0 - (ratio > 0.0 ? ratio : 0.0)) : 0.0;
}

/* path.bounce_kind: whether a sampled closure makes a transparent bounce (no bounce), and whether it was labelled
 * diffuse; the counts of each kind of bounce are the ray's path (PathRay.path, direct.c path_after). */
INLINE int is_labelled_diffuse(int kind) { return bsdf_is(kind, BSDF_FLAG_DIFFUSE); }
INLINE int is_transparent_bounce(int kind) { return bsdf_is(kind, BSDF_FLAG_STRAIGHT); }

/* path.through_transparent for one ray r of hit h whose path has ended at its bounce limits, after `clear`
 * transparent surfaces: the light behind the transparent surfaces it meets (each multiplies by its
 * transparency; the ray goes straight on and gathers as a BSDF ray does, weighed by MIS with the pdf of the
 * path's last real bounce and the light pdfs measured from there, r->mis_O and r->mis_N), up to the
 * transparent-bounce limit (volume-only boundaries not counted; each surface passed changes the ray's media, whose
 * stretches keep exp(-sigma_t t) and add their emission); added to found (r's weight included, each find capped at `cap` seen through the
 * path's throughput at h). The caller calls it only where BSDF rays gather (not with light samples alone).
 * groups: (ds->groups, 3) the same by the group of each source, added to, or NULL. */
NOINLINE static void through_transparent(const PathRay *r, int clear, const PathLimits *limits, const DirectSettings *ds,
                                const double *throughput, double cap, double *found, double *groups)
{
    double T[3], O[3] = {r->O[0], r->O[1], r->O[2]};
    for (int c = 0; c < 3; c++) T[c] = r->weight[c] * r->attenuation[c];
    VolumeStack inside = r->inside;
    const double *D = r->D;
    int64_t geometry = r->geometry, prim = r->prim, instance = r->instance;
    double u = r->u, v = r->v, t = r->t;
    LightPath path = r->path;                   /* (each surface passed: one more transparent one) */
    int use_mis = ds->mis && isfinite(r->pdf);
    for (;;) {
        /* 1. The surface met: what it lets through, seen along the ray. */
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(ds->geometry, geometry, prim, instance, 1, r->time, &tri);
        const MaterialRecord *material = ds->materials + tri.material;
        if (material->may_pass == 0.0) return;
        Surface s;
        ShaderResult sd;
        shade_along(ds, &tri, geometry, prim, instance, O, D, t, u, v, &path, NULL, 0, &s, &sd);
        for (int c = 0; c < 3; c++) T[c] *= sd.transparency[c];
        clear += !is_boundary(ds->media, tri.material);
        path.transparent = clear;
        if (ds->media != NULL) stack_cross(ds->media, &inside, &s, 1);
        if (!(T[0] > 0.0 || T[1] > 0.0 || T[2] > 0.0) || clear > limits->transparent_bounces) return;
        /* 2. On from just past it, straight ahead, gathering what the ray finds. */
        spawn_ray(s.I, s.Ng, D, s.offset, O);
        RayHitPacket packet;
        int valid[PACKET] ALIGNED(32);
        /* (Fast GI's short ray: as short past each surface, by the object of the surface passed) */
        double t_max = r->ao ? ao_distance_of(ds->geometry, geometry, prim, instance, ds->ao_distance) : INFINITY;
        set_lane(&packet.ray, 0, O, D, t_max);
        set_time(&packet.ray, 0, r->time);
        close_packet(&packet.ray, valid, 1);
        clear_hits(&packet);
        ds->intersect(valid, ds->scene, &packet, NULL);
        if (packet.hit.geomID[0] != INVALID_ID && ds->geometry->hidden != NULL)
            see_past_hidden(ds->geometry, ds->intersect, ds->scene, &packet, 0, O, D, t_max, r->seen_as, r->time);
        int hit = packet.hit.geomID[0] != INVALID_ID;
        double light_L[3] = {0.0, 0.0, 0.0}, groups_L[3 * MAX_LIGHT_GROUPS];
        for (int64_t i = 0; i < 3 * ds->groups; i++) groups_L[i] = 0.0;
        t = hit ? (double)packet.ray.tfar[0] : INFINITY;
        geometry = (int64_t)packet.hit.geomID[0];
        prim = (int64_t)packet.hit.primID[0];
        instance = instance_of(&packet.hit, 0);
        double sigma[3] = {0.0, 0.0, 0.0}, emission[3] = {0.0, 0.0, 0.0};
        if (ds->media != NULL) {                    /* (a short ray that meets nothing: the world's medium alone) */
            if (r->ao && !hit) stack_empty(&inside);
            medium_along(ds->media, &inside, sigma, emission);
        }
        FindingRay finding = {O, D, hit, hit ? t : t_max, geometry, prim, instance, r->pdf, use_mis, 0, r->mis_O,
                              r->mis_N, (int)r->seen_as, &path, r->receiver, ds->media != NULL ? sigma : NULL, emission,
                              NULL, ds->media != NULL ? &inside : NULL, r->time, r->ao, r->cull};
        gather_light(ds, &finding, light_L, groups != NULL ? groups_L : NULL);
        for (int c = 0; c < 3; c++) light_L[c] *= T[c];
        double f = clamp_scale(light_L, throughput, cap, 1.0);
        for (int c = 0; c < 3; c++) found[c] += light_L[c] * f;
        if (groups != NULL)                         /* (the same weight: T up to this stretch's start) */
            for (int64_t g = 0; g < ds->groups; g++)
                for (int c = 0; c < 3; c++) groups[3 * g + c] += groups_L[3 * g + c] * T[c] * f;
        if (ds->media != NULL) {                    /* (and what reaches the next surface) */
            double kept[3];
            March march;                            /* (through a heterogeneous medium: its march, field.c) */
            stretch_transmittance(stretch_march(ds->media, &inside, O, D, t, sigma, emission, &march), sigma, t, kept);
            for (int c = 0; c < 3; c++) T[c] *= kept[c];
        }
        /* 3. A ray that met another surface goes on. */
        if (!hit) return;
        u = (double)packet.hit.u[0];
        v = (double)packet.hit.v[0];
    }
}

/* path.fast_gi_added for hit h of H (Fast GI's Add): alpha x the sum of its diffuse-type closures' weights x
 * ao_additive_factor where one cosine-distributed ray about their weighted normal escapes within ao_distance (times
 * the transparency of the surfaces it passes), into added (3); zero where it has no diffuse closure. */
NOINLINE static void fast_gi_added(const DirectSettings *ds, const BlockHits *H, int64_t h, double *added)
{
    const ShaderResult *sd = H->sd + h;
    const Surface *s = H->s + h;
    double weight[3] = {0.0, 0.0, 0.0}, total[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < 3; c++) added[c] = 0.0;
    for (int k = 0; k < sd->n; k++) {
        const Closure *cl = sd->c + k;
        /* (path.is_ao_closure: Cycles' CLOSURE_IS_BSDF_DIFFUSE, the diffuse type less the BSSRDFs) */
        if (cl->kind < 0 || !bsdf_is(cl->kind, BSDF_FLAG_DIFFUSE_TYPE) || bsdf_is(cl->kind, BSDF_FLAG_SUBSURFACE))
            continue;
        double w = fabs((cl->weight[0] + cl->weight[1] + cl->weight[2]) / 3.0);
        for (int c = 0; c < 3; c++) { weight[c] += cl->weight[c]; total[c] += w * cl->N[c]; }
    }
    if (weight[0] == 0.0 && weight[1] == 0.0 && weight[2] == 0.0) return;
    double length = sqrt(dot3(total, total)), u[2];
    Closure around = {0, {1.0, 1.0, 1.0}, 1.0, {0.0, 0.0, 0.0}, NULL};
    for (int c = 0; c < 3; c++) around.N[c] = length > 0.0 ? total[c] / length : s->N[c];
    sample_2d(stream_of((int64_t)ds->seed, AO_DIMENSION + ds->dimension), H->pixel[h], H->sample[h], u);
    BsdfSample b;
    lambert_sample(&around, NULL, u, &b);
    if (!(dot3(s->Ng, b.wi) > 0.0)) return;
    double O[1][3], D[1][3] = {{b.wi[0], b.wi[1], b.wi[2]}}, T[1][3], t = ds->ao_distance;
    spawn_ray(s->I, s->Ng, b.wi, s->offset, O[0]);
    LightPath shadow = {PATH_SHADOW, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
    transmit_packet(ds->ao_transmitter, 1, O, D, &t, &s->time, &shadow, NULL, NULL, T);
    for (int c = 0; c < 3; c++) {
        double alpha = 1.0 - sd->transparency[c];
        alpha = alpha < 0.0 ? 0.0 : (alpha > 1.0 ? 1.0 : alpha);
        added[c] = alpha * T[0][c] * (weight[c] * ds->ao_additive_factor);
    }
}

/* Vertex m of the block `next`: the surface (geometry, prim, instance, barycentrics u, v) that a ray along D reached
 * carrying throughput tp; its light, light groups and closures cleared. */
INLINE void begin_vertex(BlockHits *next, int64_t m, int64_t geometry, int64_t prim, int64_t instance, double u,
                         double v, const double *D, const double *tp)
{
    next->geometry[m] = geometry;
    next->prim[m] = prim;
    next->instance[m] = instance;
    next->bary[2 * m] = u;
    next->bary[2 * m + 1] = v;
    for (int c = 0; c < 3; c++) {
        next->wo[3 * m + c] = -D[c];
        next->L[3 * m + c] = 0.0;
        next->throughput[3 * m + c] = tp[c];
    }
    if (next->groups != NULL)
        for (int64_t i = 0; i < 3 * next->group_count; i++) next->groups[3 * m * next->group_count + i] = 0.0;
    hit_closures(next, m);
}

/* path.py steps b-d: the vertices after `vertex`, where the BSDF rays of H that hit a surface and may
 * still bounce there go on (Russian roulette from limits->roulette_from); their surfaces and materials. */
INLINE void next_vertices(BlockHits *H, const PathRays *rays, int vertex, const PathLimits *limits,
                          const DirectSettings *ds, BlockHits *next, double *held)
{
    int lift = ds->shadows->terminator_fix != 0.0;
    uint32_t roulette = stream_of((int64_t)ds->seed, ROULETTE_DIMENSION + (int64_t)(vertex + 1) * VERTEX_DIMENSIONS);
    ShaderRays traced = {ds->intersect, ds->occluded, ds->scene, ds->geometry, ds->seed};
    next->m = 0;
    for (int64_t i = 0; i < rays->n; i++) {
        const PathRay *r = rays->r + i;
        int64_t h = r->h;
        if (!r->hit) {                          /* (kept for the media's scattering along it alone: volume.c) */
            /* A camera path (through clear surfaces alone) that escapes with a transparent film: the film is as
             * clear as what it brings through, and no world (path.py; Cycles' PATH_RAY_TRANSPARENT_BACKGROUND). */
            if (ds->film_transparent && (r->path.flags & PATH_CLEARS_FILM) != 0) {
                double sum = 0.0;
                for (int c = 0; c < 3; c++) sum += H->throughput[3 * h + c] * (r->weight[c] * r->attenuation[c]);
                held[H->lane[h]] += sum / 3.0;
            }
            continue;
        }
        /* a. The bounce limits. */
        int d = r->path.diffuse, g = r->path.glossy, tr = r->path.transmission;
        int see_through = is_transparent_bounce(r->kind), bounces = r->path.bounce;
        /* (a volume-only boundary is no transparent bounce: Cycles counts those crossings apart) */
        int boundary = see_through && is_boundary(ds->media, H->s[h].material);
        int clear = r->path.transparent - boundary, crossed = H->bounds[h] + boundary;
        /* (the surface after the last transparent bounce allowed ends the path: Cycles' terminate-on-next-surface,
         *  its emission already gathered by the ray) */
        if (clear > limits->transparent_bounces || (see_through && !boundary && clear >= limits->transparent_bounces))
            continue;
        /* (Fast GI's short ray ends its path where it meets a surface, as past the limits: path.py) */
        if (bounces > limits->max_bounces || d > limits->diffuse_bounces || g > limits->glossy_bounces
            || tr > limits->transmission_bounces || r->ao) {
            /* Past its bounce limits the path still looks through the transparent surfaces its ray meets. */
            /* (found lands in H->L, which the path's throughput multiplies: give it r's weight alone) */
            /* (nothing with light samples alone, whose BSDF rays gather nothing: path.through_transparent) */
            if (ds->transmitter != NULL && ds->gather) {
                double found[3] = {0.0, 0.0, 0.0};
                double cap = ds->clamping ? clamp_limit(H, h, ds->caps) : INFINITY;
                through_transparent(r, clear, limits, ds, H->throughput + 3 * h, cap, found,
                                    H->groups != NULL ? H->groups + 3 * h * H->group_count : NULL);
                for (int c = 0; c < 3; c++) H->L[3 * h + c] += found[c];
                if (ds->features)
                    for (int c = 0; c < 3; c++) H->found[3 * h + c] += found[c];
                if (ds->light_passes && H->bounce[h] == 0) add_split(H->parts[h], found, &r->shares[0][0]);
            }
            continue;
        }
        if (crossed > VOLUME_BOUNDS_MAX) continue;
        /* b. The throughput (times what the media let through to the hit), and Russian roulette, which decides from
         *    the throughput before the media (path.py). */
        double tp[3], carried[3];
        for (int c = 0; c < 3; c++) {
            carried[c] = H->throughput[3 * h + c] * r->weight[c];
            tp[c] = H->throughput[3 * h + c] * (r->weight[c] * r->attenuation[c]);
        }
        if (bounces >= limits->roulette_from && !see_through && !r->walked) {   /* (a walk plays none) */
            double largest = at_least(fabs(carried[0]), at_least(fabs(carried[1]), fabs(carried[2])));
            double q = survival(largest), u[2];
            sample_2d(roulette, H->pixel[h], H->sample[h], u);
            if (!(u[0] < q)) continue;
            for (int c = 0; c < 3; c++) tp[c] = tp[c] / q;
        }
        if (!(isfinite(tp[0]) && isfinite(tp[1]) && isfinite(tp[2]))) continue;
        /* c. The next vertex: the surface the ray hit, its material seen from the ray. */
        int64_t m = next->m++;
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(ds->geometry, r->geometry, r->prim, r->instance, 1, r->time, &tri);
        surface_at(r->O, r->D, r->t, r->u, r->v, &tri, lift, next->s + m);
        begin_vertex(next, m, r->geometry, r->prim, r->instance, r->u, r->v, r->D, tp);
        /* A transparent bounce (and a walk) keeps the kind of the last real one; after a diffuse one, the caustics
         * filter. */
        int after_diffuse = see_through || r->walked ? H->after_diffuse[h] : is_labelled_diffuse(r->kind);
        next->after_diffuse[m] = (uint8_t)after_diffuse;
        next->sd[m].caustics = after_diffuse ? ds->caustics : 0;
        /* (Cycles' min_ray_pdf: the smallest pdf of the path's real bounces; the Bevel node and Filter Glossy read it) */
        next->min_pdf[m] = see_through || !(r->pdf < H->min_pdf[h]) ? H->min_pdf[h] : r->pdf;
        next->sd[m].blur = filter_glossy_roughness(ds->filter_glossy, next->min_pdf[m]);
        /* (a camera chain's vertex, straight on through a transparent surface: its shader AOVs, passes.c) */
        ShaderKeys keys = {&traced, H->pixel[h], H->sample[h], (int64_t)(vertex + 1) * VERTEX_DIMENSIONS,
                           next->min_pdf[m] < BEVEL_MIN_PDF,
                           bounces == 0 && !r->walked ? passes_aov(ds->passes, H->lane[h]) : NULL};
        shade_hit(ds->graphs, ds->geometry, ds->materials + next->s[m].material, &tri, next->s + m, r->geometry,
                  r->prim, r->instance, r->u, r->v, next->wo + 3 * m, &r->path, &keys, 0, next->sd + m);
        /* A walk's exit is lit as a white Lambert surface (subsurface.c walk_exit_shader). */
        next->exiting[m] = (uint8_t)r->walked;
        if (r->walked) walk_exit_shader(next->sd + m);
        /* After a diffuse bounce Christensen-Burley is a Lambert closure (Cycles' PATH_RAY_DIFFUSE_ANCESTOR). */
        if (d > 0 || after_diffuse) burley_as_diffuse(next->sd + m);
        next->flags[m] = r->path.flags;             /* (through clear surfaces: still the camera's) */
        next->seen_by[m] = r->seen_as;
        if (bounces == 0) {
            /* A camera path through clear surfaces meets a holdout object or node: a hole in the film (path.hold_out). */
            double weight[3];
            if (hold_out(next->sd + m, hidden_from(ds->geometry, r->geometry, r->prim, r->instance, HOLDOUT), weight))
                held[H->lane[h]] += (tp[0] * weight[0] + tp[1] * weight[1] + tp[2] * weight[2]) / 3.0;
        }
        next->lane[m] = H->lane[h];
        next->pixel[m] = H->pixel[h];
        next->sample[m] = H->sample[h];
        next->diffuse[m] = d;
        next->glossy[m] = g;
        next->transmission[m] = tr;
        next->transparent[m] = clear;
        next->portal[m] = r->path.portal;
        next->cone[m] = r->path.cone;
        next->spread[m] = r->path.spread;
        next->bounds[m] = crossed;
        next->volume[m] = H->volume[h];
        if (ds->media != NULL) next->inside[m] = r->inside;
        next->mis_pdf[m] = r->pdf;
        next->mis_receiver[m] = r->receiver;
        for (int c = 0; c < 3; c++) { next->mis_origin[3 * m + c] = r->mis_O[c]; next->mis_n[3 * m + c] = r->mis_N[c]; }
        next->bounce[m] = bounces;
        next->looking[m] = H->looking[h];
        for (int c = 0; c < 3; c++) next->feature_tp[3 * m + c] = H->feature_tp[3 * h + c];
        if (ds->light_passes) {
            /* A path's shares are those of its first real bounce's ray, kept from then on. */
            const double *from = H->bounce[h] == 0 && !see_through ? &r->shares[0][0] : &H->shares[h][0][0];
            for (int p = 0; p < PASS_KINDS; p++)
                for (int c = 0; c < 3; c++) next->shares[m][p][c] = from[3 * p + c];
        }
    }
}

/* path.with_arrivals for one path: the vertex after `vertex` where arrival a (a path that scattered in media, volume.c
 * volume_chain) reached a surface, appended to next: its surface and material, seen from its phase ray as a volume
 * scatter ray, its counters and light passes' shares (volume: lightpasses.c stretch_shares), no feature vertex of
 * its own. */
NOINLINE static void arrive(const DirectSettings *ds, const Arrival *a, int vertex, BlockHits *next)
{
    int lift = ds->shadows->terminator_fix != 0.0;
    ShaderRays traced = {ds->intersect, ds->occluded, ds->scene, ds->geometry, ds->seed};
    int64_t m = next->m++;
    const PhaseRay *r = &a->ray;
    Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
    hit_triangle(ds->geometry, r->geometry, r->prim, r->instance, 1, STILL_TIME, &tri);
    surface_at(a->O, r->wi, r->t, r->u, r->v, &tri, lift, next->s + m);
    begin_vertex(next, m, r->geometry, r->prim, r->instance, r->u, r->v, r->wi, a->throughput);
    for (int c = 0; c < 3; c++) {
        next->mis_origin[3 * m + c] = a->O[c];
        next->mis_n[3 * m + c] = 0.0;
        next->feature_tp[3 * m + c] = 1.0;
    }
    next->after_diffuse[m] = 0;
    next->sd[m].caustics = 0;
    next->min_pdf[m] = a->min_pdf;
    next->sd[m].blur = filter_glossy_roughness(ds->filter_glossy, a->min_pdf);
    LightPath path = {PATH_VOLUME_SCATTER, a->bounce, a->diffuse, a->glossy, a->transmission, a->transparent,
                      a->portal, a->cone, a->spread};
    ShaderKeys keys = {&traced, a->pixel, a->sample, (int64_t)(vertex + 1) * VERTEX_DIMENSIONS,
                       a->min_pdf < BEVEL_MIN_PDF, NULL};
    shade_hit(ds->graphs, ds->geometry, ds->materials + next->s[m].material, &tri, next->s + m, r->geometry, r->prim,
              r->instance, r->u, r->v, next->wo + 3 * m, &path, &keys, 0, next->sd + m);
    if (a->diffuse > 0) burley_as_diffuse(next->sd + m);     /* (subsurface.burley_as_diffuse, as path.py) */
    next->exiting[m] = 0;
    next->flags[m] = PATH_VOLUME_SCATTER;
    next->seen_by[m] = HIDDEN_FROM_VOLUME_SCATTER;   /* (reached by a phase ray) */
    next->lane[m] = a->lane;
    next->pixel[m] = a->pixel;
    next->sample[m] = a->sample;
    next->diffuse[m] = a->diffuse;
    next->glossy[m] = a->glossy;
    next->transmission[m] = a->transmission;
    next->transparent[m] = a->transparent;
    next->portal[m] = a->portal;
    next->cone[m] = a->cone;
    next->spread[m] = a->spread;
    next->bounds[m] = a->bounds;
    next->volume[m] = a->volume;
    next->inside[m] = a->inside;
    next->mis_pdf[m] = r->pdf;
    next->mis_receiver[m] = 0;                  /* (a medium receives as the default set: Light Linking) */
    next->bounce[m] = a->bounce;
    next->looking[m] = 0;
    if (ds->light_passes)
        for (int p = 0; p < PASS_KINDS; p++)
            for (int c = 0; c < 3; c++) next->shares[m][p][c] = a->shares[p][c];
}

/* Zero what the hits of H gather for the light passes. */
INLINE void clear_parts(BlockHits *H)
{
    for (int64_t h = 0; h < H->m; h++)
        for (int p = 0; p < PASS_KINDS; p++) H->parts[h][p][0] = H->parts[h][p][1] = H->parts[h][p][2] = 0.0;
}

/* path.py's light passes at one vertex block H: direct, what first hits (no real bounce yet) gathered split by
 * kind (H->parts); indirect, all later vertices gather (H->L) split by their paths' shares; both times the
 * path's throughput, into work->light per camera lane. */
INLINE void add_light_passes(const BlockHits *H, PathWork *work)
{
    for (int64_t h = 0; h < H->m; h++) {
        double *out = work->light[H->lane[h]];
        const double *tp = H->throughput + 3 * h;
        if (H->bounce[h] == 0) {                /* (the branch once per hit, not per channel: the same sums) */
            for (int p = 0; p < PASS_KINDS; p++)
                for (int c = 0; c < 3; c++) out[3 * p + c] += tp[c] * H->parts[h][p][c];
        } else {
            for (int p = 0; p < PASS_KINDS; p++)
                for (int c = 0; c < 3; c++) out[3 * (PASS_KINDS + p) + c] += tp[c] * H->L[3 * h + c] * H->shares[h][p][c];
        }
    }
}

static int64_t bounce_scattering(const BlockHits *H, PathRays *rays, int vertex, const PathLimits *limits,
                                 const DirectSettings *ds, PathWork *work);

/* The paths of a block's camera hits H: vertex 0 is lit into H->L (the film adds it), later vertices add
 * throughput x their light into work->extra per camera lane. arrivals: 1 where H is a block of camera rays'
 * arrivals (volume.c volume_chain; its rows set up by arrive), whose vertex 0 adds to work->extra too. Returns the
 * shadow rays traced. */
NOINLINE static int64_t trace_paths(BlockHits *H, DirectSettings *ds, const PathLimits *limits, PathWork *work,
                           uint64_t *embree, int arrivals)
{
    int64_t shadow_rays = 0;
    for (int64_t k = 0; k < BLOCK; k++) work->extra[k][0] = work->extra[k][1] = work->extra[k][2] = 0.0;
    if (work->groups != NULL)
        for (int64_t i = 0; i < BLOCK * 3 * ds->groups; i++) work->groups[i] = 0.0;
    /* The features' and light passes' rows: every lane's for arrivals (chunk.c reads them all), else only the rows of
     * H's lanes, the only ones the paths write and render_chunk reads (a hit's lane). */
    if (ds->features)
        for (int64_t h = 0; h < (arrivals ? BLOCK : H->m); h++) {
            double *row = work->features[arrivals ? h : H->lane[h]];
            for (int i = 0; i < FEATURE_CHANNELS; i++) row[i] = 0.0;
        }
    if (ds->light_passes)
        for (int64_t h = 0; h < (arrivals ? BLOCK : H->m); h++) {
            double *row = work->light[arrivals ? h : H->lane[h]];
            for (int i = 0; i < LIGHT_CHANNELS; i++) row[i] = 0.0;
        }
    for (int64_t h = 0; h < (arrivals ? 0 : H->m); h++) {
        /* (the throughput: what the media let through to the camera's hit, 1 without media: chunk.c block_hits) */
        H->diffuse[h] = H->glossy[h] = H->transmission[h] = H->transparent[h] = H->portal[h] = 0;
        H->bounce[h] = H->bounds[h] = 0;
        H->flags[h] = PATH_CAMERA;
        H->mis_pdf[h] = H->min_pdf[h] = INFINITY;
        H->mis_receiver[h] = 0;                   /* (the camera's: it sees every emitter) */
        for (int c = 0; c < 3; c++) H->mis_n[3 * h + c] = 0.0;   /* (mis_origin: the camera ray's, chunk.c) */
        H->after_diffuse[h] = 0;
        H->volume[h] = 0;
        H->exiting[h] = 0;
        H->looking[h] = 1;
        H->feature_tp[3 * h] = H->feature_tp[3 * h + 1] = H->feature_tp[3 * h + 2] = 1.0;
        if (ds->light_passes)
            for (int p = 0; p < PASS_KINDS; p++) H->shares[h][p][0] = H->shares[h][p][1] = H->shares[h][p][2] = 0.0;
    }
    BlockHits *current = H, *next = &work->a;
    uint8_t ancestor[BLOCK];                    /* per camera lane: its path left a receiver (shadow caustics, mnee.c) */
    for (int64_t k = 0; k < BLOCK; k++) ancestor[k] = 0;
    for (int vertex = 0; current->m > 0; vertex++) {
        /* Shadow caustics: a caster's BSDF ray on a path that left a receiver finds no caustics lamp (Cycles'
         * PATH_MNEE_CULL_LIGHT_CONNECTION after PATH_MNEE_RECEIVER_ANCESTOR): MNEE brings that light. */
        if (ds->mnee)
            for (int64_t h = 0; h < current->m; h++) {
                int flags = mn_flags(ds->geometry, owner_of(ds->geometry, current->geometry[h], current->prim[h],
                                                            current->instance[h]));
                current->cull[h] = (flags & MNEE_CASTER) != 0 && ancestor[current->lane[h]];
                if (flags & MNEE_RECEIVER) ancestor[current->lane[h]] = 1;
            }
        /* a. What the vertex gathers: light samples, and the light its BSDF ray finds. */
        ds->dimension = (int64_t)vertex * VERTEX_DIMENSIONS;
        choose_bsdf_rays(current, ds);
        for (int64_t h = 0; h < current->m; h++) current->traced[h] = 1;
        if (ds->light_passes) clear_parts(current);
        if (ds->passes != NULL)                     /* (the vertices of camera chains: no real bounce yet; passes.c) */
            for (int64_t h = 0; h < current->m; h++)
                if (current->bounce[h] == 0 && !current->exiting[h])   /* (a walk's exit is no camera chain's) */
                    passes_at_vertex(ds->passes, ds, current, h, vertex);
        if (ds->features) {                         /* (the emission seen here, the feature vertex: features.c) */
            features_at_vertex(current, work->features, work->reach);
            for (int64_t i = 0; i < 3 * current->m; i++) current->found[i] = 0.0;
        }
        shadow_rays += direct_light(current, ds, embree);
        if (ds->ao_additive_factor != 0.0)          /* (Fast GI's Add: to Combined alone, unclamped, as Cycles') */
            for (int64_t h = 0; h < current->m; h++) {
                double added[3];
                fast_gi_added(ds, current, h, added);
                for (int c = 0; c < 3; c++)
                    work->extra[current->lane[h]][c] += current->throughput[3 * h + c] * added[c];
            }
        work->rays.n = 0;
        ds->continuing = &work->rays;
        embree[1] += bsdf_rays(current, ds);
        /* b. The light media scatter along those rays (volume.c; with Volume Bounces a path may scatter there and go
         *    on from where it did, its ray then ending there), then where the paths go on (ended ones add the light
         *    behind transparent surfaces to their vertex's), the scattered ones' arrivals at surfaces with them. */
        work->n_arrivals = 0;
        if (ds->media != NULL && ds->media->scatters != 0)
            shadow_rays += bounce_scattering(current, &work->rays, vertex, limits, ds, work);
        next_vertices(current, &work->rays, vertex, limits, ds, next, H->held);
        for (int64_t i = 0; i < work->n_arrivals; i++) arrive(ds, work->arrivals + i, vertex, next);
        if (ds->features) features_found(current, work->features);
        if (vertex > 0 || arrivals)
            for (int64_t h = 0; h < current->m; h++) {
                for (int c = 0; c < 3; c++)
                    work->extra[current->lane[h]][c] += current->throughput[3 * h + c] * current->L[3 * h + c];
                if (work->groups != NULL)            /* (the same, by group) */
                    for (int64_t g = 0; g < ds->groups; g++)
                        for (int c = 0; c < 3; c++)
                            work->groups[3 * (current->lane[h] * ds->groups + g) + c]
                                += current->throughput[3 * h + c] * current->groups[3 * (h * ds->groups + g) + c];
            }
        if (ds->light_passes) add_light_passes(current, work);
        current = next;
        next = next == &work->a ? &work->b : &work->a;
    }
    ds->continuing = NULL;
    ds->dimension = 0;
    return shadow_rays;
}
