/* A chunk of a render in one call: camera rays, their hits, the integrator, the film's sums.
 *
 * The compiled twin of core/render.py's reference chunk (camera -> integrator -> film) for p pixels
 * of spp samples each, BLOCK camera samples at a time: each block's rays, hits, surfaces and shadow
 * rays live in the cache and on the stack, and its samples go straight into their pixels' sums. */

/* rays.camera_cones: the ray cone camera ray `lane` of block b leaves with from its camera-relative origin O (graph.c
 * camera_cone in the camera's frame, made of the camera record c): its footprint there into *cone, its widening into
 * *spread; under a panoramic camera camera.c panorama_cone at the sample's (u, v) (the pinhole's, as Cycles). */
NOINLINE static void camera_cone_of(const ChunkParams *params, const CameraRecord *c, const CameraBlock *b,
                                    int64_t lane, const double *O, double *cone, double *spread)
{
    if (c->kind != CAMERA_PERSP && c->kind != CAMERA_ORTHO) {
        double raster_x = b->column[lane] + b->u[0][lane], raster_y = b->row[lane] + b->u[1][lane];
        double u = raster_x / (double)params->width + c->shift_x;
        double v = ((double)params->height - raster_y) / (double)params->height + c->shift_y;
        panorama_cone(c, (int)c->kind, u, v, params->width, params->height, cone, spread);
        return;
    }
    double P[3], f[7] = {c->left, c->right, c->bottom, c->top, c->kind == CAMERA_PERSP, (double)params->width,
                         (double)params->height};
    /* (Cycles' worldtocamera, camera.world_to_camera: the transpose of the rotation with its axes' scale cleared,
     * and z flipped so that it points along the view, as the window's d = P / P.z wants) */
    for (int i = 0; i < 3; i++) {
        const double axis[3] = {c->rotation[i], c->rotation[3 + i], c->rotation[6 + i]};
        double length = sqrt(dot3(axis, axis));
        P[i] = ((axis[0] * (O[0] - c->eye[0]) + axis[1] * (O[1] - c->eye[1])) + axis[2] * (O[2] - c->eye[2])) / length;
    }
    P[2] = -P[2];
    *cone = camera_cone(P, f, spread);
}

/* The ray cone camera ray `lane` of block b carries (graph.LightPath cone, spread): camera_cone_of where some program
 * of the render reads a cone (params->cones: rays.cones_read) and there is a camera; else UNKNOWN_CONE and 0, which
 * nothing then reads. */
INLINE void camera_ray_cone(const ChunkParams *params, const CameraBlock *b, int64_t lane, const double *O,
                            double *cone, double *spread)
{
    *cone = UNKNOWN_CONE;
    *spread = 0.0;
    if (params->cones && params->camera != NULL) camera_cone_of(params, params->camera, b, lane, O, cone, spread);
}

/* The media each camera lane of block b starts in (rays.camera_media), into H->lane_inside and lane_start, with the
 * extinction and emission along it (H->lane_sigma, lane_emission); in the catcher-only scene (params->split, catcher.py
 * catcher_split) lane_inside is empty and lane_start the stack its path goes on with from its hit. Rays from the
 * point the last walk started at take its stack (the walk goes up from the ray's origin whatever way it looks: a
 * perspective camera with Clip Start 0 walks once per block). */
static void camera_lane_media(const ChunkParams *params, const CameraBlock *b, BlockHits *H)
{
    double walked[3] = {NAN, NAN, NAN};
    VolumeStack stack;
    stack_empty(&stack);
    for (int64_t k = 0; k < b->n; k++) {
        double O[3] = {b->O[0][k], b->O[1][k], b->O[2][k]};
        if (b->valid[k] && !(O[0] == walked[0] && O[1] == walked[1] && O[2] == walked[2])) {
            camera_media(params->media, params->geometry, (Intersect8)params->intersect8, params->scene, O, &stack);
            for (int c = 0; c < 3; c++) walked[c] = O[c];
        }
        H->lane_inside[k] = stack;
        H->lane_start[k] = stack;
        if (params->split) stack_empty(H->lane_inside + k);    /* (catcher.py catcher_split: no medium to the catcher) */
        medium_along(params->media, H->lane_inside + k, H->lane_sigma[k], H->lane_emission[k]);
    }
}

/* Step 2: the block's nearest hits, 8 rays at a time; the rays that hit kept, with their surfaces. */
NOINLINE static void block_hits(const ChunkParams *params, const CameraBlock *b, BlockHits *H, LanePasses *passes,
                       int64_t *traced, uint64_t *embree)
{
    Intersect8 intersect = (Intersect8)params->intersect8;
    int lift = params->shadows->terminator_fix != 0.0;
    ShaderRays rays = {intersect, (Occluded8)params->occluded8, params->scene, params->geometry, params->seed};
    RayHitPacket packet;
    int valid[PACKET] ALIGNED(32);
    int64_t lane_of[PACKET];
    H->m = 0;
    for (int64_t k = 0; k < b->n; k++) { H->t[k] = b->t[k]; H->held[k] = 0.0; }
    if (params->media != NULL) camera_lane_media(params, b, H);
    for (int64_t at = 0; at < b->n; at += PACKET) {
        /* a. The next 8 camera rays that have a ray (a fisheye's samples outside its circle have none). */
        int lanes = 0;
        int64_t next = at;
        for (; next < b->n && next < at + PACKET; next++) {
            if (!b->valid[next]) continue;
            double o[3] = {b->O[0][next], b->O[1][next], b->O[2][next]};
            double d[3] = {b->D[0][next], b->D[1][next], b->D[2][next]};
            set_lane(&packet.ray, lanes, o, d, b->t[next]);
            set_time(&packet.ray, lanes, b->time[next]);     /* (where moving objects are for this camera ray) */
            lane_of[lanes++] = next;
        }
        if (lanes == 0) continue;
        close_packet(&packet.ray, valid, lanes);
        clear_hits(&packet);
        uint64_t start = ticks();
        intersect(valid, params->scene, &packet, NULL);
        *embree += ticks() - start;
        *traced += lanes;
        /* b. The surface at each hit (core/geometry/surface.py) and its material: closures, emission. */
        for (int k = 0; k < lanes; k++) {
            if (packet.hit.geomID[k] != INVALID_ID && params->geometry->hidden != NULL) {
                int64_t lane = lane_of[k];
                double O[3] = {b->O[0][lane], b->O[1][lane], b->O[2][lane]};
                double D[3] = {b->D[0][lane], b->D[1][lane], b->D[2][lane]};
                see_past_hidden(params->geometry, intersect, params->scene, &packet, k, O, D, b->t[lane],
                                HIDDEN_FROM_CAMERA, b->time[lane]);
            }
            if (packet.hit.geomID[k] == INVALID_ID) continue;
            int64_t lane = lane_of[k], h = H->m++;
            H->t[lane] = (double)packet.ray.tfar[k];
            double O[3] = {b->O[0][lane], b->O[1][lane], b->O[2][lane]};
            double D[3] = {b->D[0][lane], b->D[1][lane], b->D[2][lane]};
            Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
            hit_triangle(params->geometry, (int64_t)packet.hit.geomID[k], (int64_t)packet.hit.primID[k],
                         instance_of(&packet.hit, k), 1, b->time[lane], &tri);
            surface_at(O, D, (double)packet.ray.tfar[k], (double)packet.hit.u[k], (double)packet.hit.v[k], &tri,
                       lift, H->s + h);
            for (int c = 0; c < 3; c++) H->wo[3 * h + c] = -D[c];
            H->geometry[h] = (int64_t)packet.hit.geomID[k];
            H->prim[h] = (int64_t)packet.hit.primID[k];
            H->instance[h] = instance_of(&packet.hit, k);
            H->bary[2 * h] = (double)packet.hit.u[k];
            H->bary[2 * h + 1] = (double)packet.hit.v[k];
            /* (a camera path's origin: where its rays through clear surfaces meet lamps from, path.py's mis_origin) */
            for (int c = 0; c < 3; c++) H->mis_origin[3 * h + c] = O[c];
            hit_closures(H, h);
            /* (what clamping and the Light Path node read: a path's throughput and bounces, 1 and 0 at the camera's
             * hit, and its camera ray's flags) */
            for (int c = 0; c < 3; c++) H->throughput[3 * h + c] = 1.0;
            H->bounce[h] = H->diffuse[h] = H->glossy[h] = H->transmission[h] = H->transparent[h] = H->portal[h] = 0;
            camera_ray_cone(params, b, lane, O, H->cone + h, H->spread + h);
            H->flags[h] = PATH_CAMERA;
            H->min_pdf[h] = INFINITY;           /* (no bounce yet: Cycles' min_ray_pdf, which the Bevel node reads) */
            LightPath camera = path_at(H, h, PATH_CAMERA);
            /* (its shader AOVs into the lane's, passes.c: a camera chain's first vertex) */
            ShaderKeys keys = {&rays, (int64_t)b->pixel[lane], (int64_t)b->index[lane], 0, 0, passes_aov(passes, lane)};
            shade_hit(params->graphs, params->geometry, params->materials + H->s[h].material, &tri, H->s + h,
                      (int64_t)packet.hit.geomID[k], (int64_t)packet.hit.primID[k], instance_of(&packet.hit, k),
                      (double)packet.hit.u[k], (double)packet.hit.v[k], H->wo + 3 * h, &camera, &keys,
                      0, H->sd + h);
            H->seen_by[h] = HIDDEN_FROM_CAMERA;
            double weight[3];                   /* a holdout object or node: a hole in the film (path.hold_out) */
            if (hold_out(H->sd + h, hidden_from(params->geometry, (int64_t)packet.hit.geomID[k],
                                                (int64_t)packet.hit.primID[k], instance_of(&packet.hit, k), HOLDOUT),
                         weight))
                H->held[lane] += (weight[0] + weight[1] + weight[2]) / 3.0;
            H->lane[h] = lane;
            H->pixel[h] = (int64_t)b->pixel[lane];
            H->sample[h] = (int64_t)b->index[lane];
            for (int c = 0; c < 3; c++) H->L[3 * h + c] = H->sd[h].emission[c];
            /* (what clamping reads: a path's throughput and bounces at the camera's hit: what the media let through
             *  to it, 1 without media, and 0) */
            for (int c = 0; c < 3; c++) H->throughput[3 * h + c] = 1.0;
            if (params->media != NULL) {
                H->inside[h] = H->lane_start[lane];
                March march;                    /* (a heterogeneous medium: marched, field.c) */
                const March *m = stretch_march(params->media, &H->lane_inside[lane], O, D, H->t[lane],
                                               H->lane_sigma[lane], H->lane_emission[lane], &march);
                stretch_transmittance(m, H->lane_sigma[lane], H->t[lane], H->throughput + 3 * h);
            }
            H->bounce[h] = 0;
            if (params->clamp_direct < INFINITY) {
                double f = clamp_scale(H->L + 3 * h, H->throughput + 3 * h, params->clamp_direct, 1.0);
                for (int c = 0; c < 3; c++) H->L[3 * h + c] *= f;
            }
            if (H->groups != NULL) {            /* (its emission goes to its object's light group) */
                for (int64_t i = 0; i < 3 * H->group_count; i++) H->groups[3 * h * H->group_count + i] = 0.0;
                add_to_group(H->groups, H->group_count, h,
                             group_of_hit(params->instance_groups, params->geometry, (int64_t)packet.hit.geomID[k],
                                          (int64_t)packet.hit.primID[k], instance_of(&packet.hit, k)),
                             H->L + 3 * h, 1.0);
            }
        }
    }
}

/* features.in_media for the camera rays of block b (path.py's camera, rays.camera_back): each lane's reach and what
 * the media in front of it write (features_in_march through heterogeneous ones) (work->camera_features, added to
 * the lane's features with what the camera sees); back (3) becomes the direction back towards the camera, the normal
 * a path that scatters in a medium gets. */
static void camera_lane_features(const ChunkParams *params, const CameraBlock *b, const BlockHits *H, PathWork *work,
                                 double *back)
{
    const CameraRecord *camera = params->camera;
    double length = 0.0;
    for (int c = 0; c < 3; c++) back[c] = camera != NULL ? camera->rotation[3 * c + 2] : 0.0;
    for (int c = 0; c < 3; c++) length += back[c] * back[c];
    for (int c = 0; c < 3; c++) back[c] = length > 0.0 ? back[c] / sqrt(length) : 0.0;
    double one[3] = {1.0, 1.0, 1.0};
    for (int64_t lane = 0; lane < BLOCK; lane++) {
        work->reach[lane] = 1.0;
        for (int i = 0; i < FEATURE_CHANNELS; i++) work->camera_features[lane][i] = 0.0;
        if (lane >= b->n || !b->valid[lane] || params->media == NULL) continue;
        double O[3] = {b->O[0][lane], b->O[1][lane], b->O[2][lane]}, D[3] = {b->D[0][lane], b->D[1][lane], b->D[2][lane]};
        features_along(work->camera_features[lane], work->reach + lane, one, one, params->media, &H->lane_inside[lane],
                       O, D, H->t[lane], back);
    }
}

/* The integrator at the block's hits: the radiance each sends towards the camera, into H->L, and what media
 * scatter along each camera ray of block b into H->lane_scattered. Returns the shadow rays; embree[0] += ticks in
 * occlusion queries, embree[1] in the BSDF rays' nearest hits. */
NOINLINE static int64_t integrate(const ChunkParams *params, const CameraBlock *b, BlockHits *H, PathWork *work,
                         LanePasses *passes, uint64_t *embree)
{
    Transmitter transmitter = {(Intersect8)params->intersect8, params->scene, params->geometry, params->materials,
                               params->graphs, (int)params->transparent_bounces, params->media};
    /* (Fast GI's Add rays pass transparent surfaces as the Ambient Occlusion pass's: no media, passes.c) */
    Transmitter ao_transmitter = {(Intersect8)params->intersect8, params->scene, params->geometry, params->materials,
                                  params->graphs, (int)params->transparent_bounces, NULL};
    DirectSettings ds = {
        .shadows = params->shadows, .lights = params->lights, .n_lights = (int64_t)params->light_count,
        .context = params->light_context, .occluded = (Occluded8)params->occluded8,
        .intersect = (Intersect8)params->intersect8, .scene = params->scene, .geometry = params->geometry,
        .materials = params->materials, .mis = (int)params->sampling == SAMPLE_MIS && params->bsdf_rays != 0.0,
        .sampling = (int)params->sampling, .bsdf_rays = params->bsdf_rays != 0.0, .emissive = params->emissive != 0.0,
        .everywhere = params->everywhere != 0.0, .seed = params->seed, .dimension = 0,
        .gather = params->bsdf_rays != 0.0 && (int)params->sampling != SAMPLE_LIGHT, .continuing = NULL,
        .graphs = params->graphs, .transmitter = params->see_through != 0.0 ? &transmitter : NULL,
        .caustics = (int)params->caustics, .filter_glossy = params->filter_glossy, .caps = {params->clamp_direct, params->clamp_indirect},
        .clamping = params->clamp_direct < INFINITY || params->clamp_indirect < INFINITY,
        .light_passes = params->light_passes != 0.0 && work != NULL,
        .groups = H->groups != NULL ? H->group_count : 0, .instance_groups = params->instance_groups,
        .world_group = (int64_t)params->world_group, .features = params->features != 0.0 && work != NULL,
        .passes = passes, .media = params->media, .film_transparent = params->transparent != 0.0,
        .clear_glass = params->clear_glass,
        .ao_bounces = (int)params->ao_bounces, .ao_factor = params->ao_factor, .ao_distance = params->ao_distance,
        .ao_additive_factor = params->ao_additive_factor, .ao_transmitter = &ao_transmitter,
        .mnee = params->mnee != 0,
        .mnee_limits = {(int)params->max_bounces, (int)params->diffuse_bounces, (int)params->transmission_bounces},
    };
    if (ds.features) camera_lane_features(params, b, H, work, ds.back);
    /* The path tracer's bounce limits; the direct tracer's through transparent surfaces: no bounces but those. */
    PathLimits limits = {(int)params->max_bounces, (int)params->diffuse_bounces, (int)params->glossy_bounces,
                         (int)params->transmission_bounces, (int)params->transparent_bounces,
                         (int)params->roulette_from, (int)params->volume_bounces};
    PathLimits clear_only = {0, 0, 0, 0, (int)params->transparent_bounces, (int)params->roulette_from, 0};
    int64_t scattering_rays = 0;
    if (params->media != NULL && params->media->scatters != 0 && work != NULL) {
        /* The light the media scatter towards the camera along its rays (volume.c), lane by lane (their light passes
         * into work->lane_light, which render_chunk reads only where media scatter). */
        if (ds.light_passes)
            for (int64_t k = 0; k < BLOCK; k++)
                for (int i = 0; i < LIGHT_CHANNELS; i++) work->lane_light[k][i] = 0.0;
        double one[3] = {1.0, 1.0, 1.0}, through[BLOCK][3];
        ds.everywhere = 1;
        /* (with Volume Bounces a camera ray's path goes on from where it scatters: volume.c volume_chain) */
        /* (not where its scattering event's phase ray is Fast GI's: volume.volume_bounces_left) */
        int chains = (int)params->integrator == INTEGRATOR_PATH && limits.volume_bounces > 0 && limits.max_bounces >= 1
                     && !fast_gi_scatter(&ds, 0, 0, 0);
        work->n_arrivals = 0;
        double *lane_groups = ds.groups > 0 ? work->lane_groups : NULL;
        if (lane_groups != NULL)
            for (int64_t i = 0; i < BLOCK * 3 * ds.groups; i++) lane_groups[i] = 0.0;
        for (int64_t lane = 0; lane < b->n; lane++) {
            H->lane_scattered[lane][0] = H->lane_scattered[lane][1] = H->lane_scattered[lane][2] = 0.0;
            if (!b->valid[lane]) continue;
            double O[3] = {b->O[0][lane], b->O[1][lane], b->O[2][lane]}, D[3] = {b->D[0][lane], b->D[1][lane], b->D[2][lane]};
            /* (the light passes: Volume Direct at a camera ray's first scattering event, Volume Indirect after it,
             *  lightpasses.c add_scattered; a path that scattered is volume from then on) */
            double volume_only[PASS_KINDS][3];
            stretch_shares(0, NULL, volume_only);
            if (chains) {
                Arrival *a = work->arrivals + work->n_arrivals;
                int arrived = 0;
                double later[3] = {0.0, 0.0, 0.0};
                scattering_rays += volume_chain(&ds, &limits, O, D, H->t[lane], H->lane_inside + lane, one,
                                                (int64_t)b->pixel[lane], (int64_t)b->index[lane], 0, 0, 0, 0, 0,
                                                H->lane_scattered[lane], later, through[lane], a, &arrived,
                                                lane_groups != NULL ? lane_groups + 3 * lane * ds.groups : NULL);
                if (ds.light_passes) {
                    add_scattered(work->lane_light[lane], H->lane_scattered[lane], 0, volume_only, 1);
                    add_scattered(work->lane_light[lane], later, 0, volume_only, 0);
                    for (int p = 0; p < PASS_KINDS; p++)
                        for (int c = 0; c < 3; c++) a->shares[p][c] = volume_only[p][c];
                }
                for (int c = 0; c < 3; c++) H->lane_scattered[lane][c] += later[c];
                if (arrived) {
                    double cone, spread;            /* (its camera ray's cone: path.with_arrivals) */
                    camera_ray_cone(params, b, lane, O, &cone, &spread);
                    arrival_cone(a, cone, spread);
                    a->min_pdf = a->ray.pdf;
                    a->lane = lane;
                    a->pixel = (int64_t)b->pixel[lane];
                    a->sample = (int64_t)b->index[lane];
                    a->diffuse = a->glossy = a->transmission = a->transparent = a->portal = a->bounds = 0;
                    work->n_arrivals++;
                }
                continue;
            }
            double found_groups[3 * MAX_LIGHT_GROUPS];
            scattering_rays += in_scattering(&ds, (int)params->integrator == INTEGRATOR_PATH ? &limits : &clear_only,
                                             O, D, H->t[lane], H->lane_inside + lane, one, (int64_t)b->pixel[lane],
                                             (int64_t)b->index[lane], 0, 0, H->lane_scattered[lane],
                                             lane_groups != NULL ? found_groups : NULL, fast_gi_scatter(&ds, 0, 0, 0));
            if (lane_groups != NULL)            /* (its light groups, by the source of each light scattered) */
                add_groups(lane_groups + 3 * lane * ds.groups, found_groups, ds.groups, one);
            if (ds.light_passes) add_scattered(work->lane_light[lane], H->lane_scattered[lane], 0, volume_only, 1);
        }
        if (chains) {
            /* The camera's hits: their paths go on with what a path passing to them carries (0 where it
             * scattered), and so does what they emit (path.py: the camera's hits' throughput is camera_through),
             * clamped through it (block_hits clamped it through the media's transmittance instead: undone), to
             * Combined and to the Denoising Albedo (features.at_vertex: H->L is 0 by the time trace_paths reads it). */
            for (int64_t h = 0; h < H->m; h++) {
                int64_t lane = H->lane[h];
                double rescale = 1.0;
                if (params->clamp_direct < INFINITY) {
                    double before = clamp_scale(H->sd[h].emission, H->throughput + 3 * h, params->clamp_direct, 1.0);
                    double after = clamp_scale(H->sd[h].emission, through[lane], params->clamp_direct, 1.0);
                    rescale = before > 0.0 ? after / before : 0.0;
                    for (int c = 0; c < 3; c++) H->L[3 * h + c] = H->sd[h].emission[c] * after;
                }
                if (lane_groups != NULL)            /* (and so their emission's light groups) */
                    for (int64_t i = 0; i < 3 * ds.groups; i++) {
                        lane_groups[3 * lane * ds.groups + i] += through[lane][i % 3]
                                                                 * (H->groups[3 * h * ds.groups + i] * rescale);
                        H->groups[3 * h * ds.groups + i] = 0.0;
                    }
                if (ds.features)                    /* (the emission their paths see while they look: features.c) */
                    for (int c = 0; c < 3; c++) work->camera_features[lane][c] += through[lane][c] * H->L[3 * h + c];
                for (int c = 0; c < 3; c++) {
                    H->lane_scattered[lane][c] += through[lane][c] * H->L[3 * h + c];
                    H->L[3 * h + c] = 0.0;
                    H->throughput[3 * h + c] = through[lane][c];
                }
            }
            /* The paths that scattered along the camera rays and reached a surface: a block of vertex 0 of their
             * own, whose light joins what the media scatter towards their lanes. */
            if (work->n_arrivals > 0) {
                BlockHits *C = &work->c;
                C->m = 0;
                for (int64_t i = 0; i < work->n_arrivals; i++) arrive(&ds, work->arrivals + i, -1, C);
                scattering_rays += trace_paths(C, &ds, &limits, work, embree, 1);
                for (int64_t lane = 0; lane < b->n; lane++) {
                    for (int c = 0; c < 3; c++) H->lane_scattered[lane][c] += work->extra[lane][c];
                    if (ds.light_passes)            /* (their light passes: Volume Indirect, by their shares) */
                        for (int i = 0; i < LIGHT_CHANNELS; i++) work->lane_light[lane][i] += work->light[lane][i];
                    if (lane_groups != NULL)
                        for (int64_t i = 0; i < 3 * ds.groups; i++)
                            lane_groups[3 * lane * ds.groups + i] += work->groups[3 * lane * ds.groups + i];
                }
            }
        }
    }
    switch ((int)params->integrator) {
    case INTEGRATOR_PATH:
        ds.everywhere = 1;
        return scattering_rays + trace_paths(H, &ds, &limits, work, embree, 0);
    case INTEGRATOR_DIRECT:
        if (params->see_through != 0.0 || params->walks != 0.0) {   /* (integrators.for_render) */
            ds.everywhere = 1;
            return scattering_rays + trace_paths(H, &ds, &clear_only, work, embree, 0);
        }
        /* fall through */
    default: {
        if (ds.light_passes) {
            clear_parts(H);
            for (int64_t h = 0; h < H->m; h++)      /* (the hits' lanes' rows: the only ones written and read) */
                for (int i = 0; i < LIGHT_CHANNELS; i++) work->light[H->lane[h]][i] = 0.0;
        }
        if (ds.features) {                          /* (the camera's hits: features.c) */
            for (int64_t h = 0; h < H->m; h++)
                for (int i = 0; i < FEATURE_CHANNELS; i++) work->features[H->lane[h]][i] = 0.0;
            for (int64_t h = 0; h < H->m; h++) {
                H->looking[h] = 1;
                for (int c = 0; c < 3; c++) { H->feature_tp[3 * h + c] = 1.0; H->found[3 * h + c] = 0.0; }
            }
            features_at_vertex(H, work->features, work->reach);
        }
        if (passes != NULL)                         /* (the camera's hits: passes.c) */
            for (int64_t h = 0; h < H->m; h++) passes_at_vertex(passes, &ds, H, h, 0);
        choose_bsdf_rays(H, &ds);
        int64_t rays = direct_light(H, &ds, embree);
        if (ds.bsdf_rays && ds.sampling != SAMPLE_LIGHT) embree[1] += bsdf_rays(H, &ds);
        if (ds.features) features_found(H, work->features);
        if (ds.light_passes) add_light_passes(H, work);     /* (all of it direct: the camera's hits) */
        return rays;
    }
    }
}

/* What a camera ray brings back besides its hit: the world where it escapes (when the camera sees it and
 * the film is not transparent), the lamps with extent it passes before t and the suns' discs where it escapes
 * (rays.lamps_seen). groups: (G, 3)
 * the same by the group of each source (lightgroups.py), added to, or NULL. sigma: the extinction (3) of the media
 * the ray crosses, or NULL: each keeps exp(-sigma t) of its light over its distance (inf: the world); march: the
 * ray's march through heterogeneous media (field.c), or NULL. */
INLINE void camera_sees(const ChunkParams *params, const double *O, const double *D, double t, int hit, double *out,
                        double *groups, const double *sigma, const March *march)
{
    out[0] = out[1] = out[2] = 0.0;
    const WorldTables *world = params->light_context->world;
    if (!hit && world->camera != 0.0 && params->transparent == 0.0) {
        LightPath camera = {PATH_CAMERA, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
        world_seen(world, D, &camera, out);                 /* (a world's graph, per ray) */
        if (sigma != NULL) {
            double kept[3];
            stretch_transmittance(march, sigma, INFINITY, kept);
            for (int c = 0; c < 3; c++) out[c] *= kept[c];
        }
        add_to_group(groups, params->light_groups, 0, params->world_group, out, 1.0);
    }
    for (int64_t l = 0; l < (int64_t)params->light_count; l++) {
        const LightRecord *light = params->lights + l;
        LightHit lh;
        if (camera_sees_lamp(light, O, D, t, hit, &lh)) {
            if (sigma != NULL) {
                double kept[3];
                stretch_transmittance(march, sigma, lh.t, kept);
                for (int c = 0; c < 3; c++) lh.radiance[c] *= kept[c];
            }
            for (int c = 0; c < 3; c++) out[c] += lh.radiance[c];
            add_to_group(groups, params->light_groups, 0, light->group, lh.radiance, 1.0);
        }
    }
}

/* The light groups' buffer `part` (0 .. 5) of six (BLOCK, G, 3) buffers in one allocation, made at the first
 * call; NULL without groups (G = 0) or memory. */
INLINE double *work_groups(double **storage, int64_t G, int part)
{
    if (G <= 0) return NULL;
    if (*storage == NULL) *storage = (double *)calloc((size_t)(6 * BLOCK * 3 * G), sizeof(double));
    return *storage != NULL ? *storage + part * BLOCK * 3 * G : NULL;
}

/* Free a chunk's LanePasses (NULL: none). */
INLINE void free_passes(LanePasses *passes)
{
    if (passes == NULL) return;
    free(passes->mattes);
    free(passes);
}

/* Give `count` blocks of hits their room for closures, `room` per hit, in one allocation (*closures, then their
 * parameters; free it with free(*closures)). Returns 0 without memory. */
INLINE int block_closures(BlockHits **blocks, int count, int64_t room, Closure **closures)
{
    size_t per_block = (size_t)(BLOCK * room);
    size_t bytes = (size_t)count * per_block * (sizeof(Closure) + STORAGE_STRIDE * sizeof(double));
    *closures = (Closure *)malloc(bytes);
    if (*closures == NULL) return 0;
    double *storage = (double *)(*closures + (size_t)count * per_block);
    for (int i = 0; i < count; i++) {
        blocks[i]->room = room;
        blocks[i]->closures = *closures + (size_t)i * per_block;
        blocks[i]->storage = storage + (size_t)i * per_block * STORAGE_STRIDE;
    }
    return 1;
}

/* catcher.caught for one camera ray O, D (up to t_max, at `time`, of sample `index` of `pixel`) whose first hit is
 * triangle (geometry, prim, instance) at t, barycentrics u, v: whether it meets a shadow catcher there or straight
 * through purely clear surfaces in front of one (catcher.clear_at: every closure a Transparent BSDF, no emission, no
 * holdout; a camera path's transparent bounces, within the transparent-bounce limit). Returns 1 where it does, with
 * T (3) what those surfaces and the media along the way let through and front (3) the lamps the camera sees in
 * front of the catcher, each times what the surfaces and media before it let through (not clamped); groups: (G, 3)
 * the lamps past the first clear surface by the group of each (the first stretch's are the caller's, camera_sees),
 * times the same, added to (Cycles writes a lamp a camera path hits before its split to the lamp's group), or NULL.
 * Media: the camera ray starts in `stack` (its extinction `sigma` (3) and `march` on the first stretch, as
 * camera_sees), or stack NULL: none; each clear surface passed changes it (stack_cross), and what the later
 * stretches' media emit, times what comes before, is added to glow (3) (catcher.py front_media, media_along; the
 * first stretch's is the lane's own). room: a March for those stretches. sd: room for closures (its room, c and storage set), used here. */
NOINLINE static int catcher_behind(const ChunkParams *params, const double *O, const double *D, double t_max,
                                   double time, int64_t geometry, int64_t prim, int64_t instance, double u, double v,
                                   double t, int64_t pixel, int64_t index, ShaderResult *sd, double *T, double *front,
                                   const VolumeStack *stack, const double *sigma, const March *march, March *room,
                                   double *glow, double *groups)
{
    int64_t G = groups != NULL ? (int64_t)params->light_groups : 0;
    VolumeStack inside;
    if (stack != NULL) inside = *stack;
    Intersect8 intersect = (Intersect8)params->intersect8;
    ShaderRays rays = {intersect, (Occluded8)params->occluded8, params->scene, params->geometry, params->seed};
    double o[3] = {O[0], O[1], O[2]};
    int passed = 0;
    for (int c = 0; c < 3; c++) { T[c] = 1.0; front[c] = 0.0; }
    for (;;) {
        int catcher = hidden_from(params->geometry, geometry, prim, instance, SHADOW_CATCHER);
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(params->geometry, geometry, prim, instance, 1, time, &tri);
        const MaterialRecord *m = params->materials + tri.material;
        if (!catcher && (m->may_pass == 0 || passed + 1 >= (int)params->transparent_bounces
                         || hidden_from(params->geometry, geometry, prim, instance, HOLDOUT)))
            return 0;
        /* This stretch's media: the lane's on the first, the stack's past a clear surface. */
        const double *sg = NULL;
        const March *mm = NULL;
        double stretch_sigma[3], stretch_e[3];
        if (stack != NULL && passed == 0) {
            sg = sigma;
            mm = march;
        } else if (stack != NULL) {
            medium_along(params->media, &inside, stretch_sigma, stretch_e);
            mm = stretch_march(params->media, &inside, o, D, t, stretch_sigma, stretch_e, room);
            sg = stretch_sigma;
            double emitted[3] = {0.0, 0.0, 0.0};
            stretch_emitted(mm, sg, stretch_e, t, emitted);
            for (int c = 0; c < 3; c++) glow[c] += T[c] * emitted[c];
            if (G > 0) {                        /* (in its medium's light group, as the first stretch's: media.c) */
                double part[3] = {T[0] * emitted[0], T[1] * emitted[1], T[2] * emitted[2]};
                add_to_group(groups, G, 0, emission_group(params->media, &inside, params->world_group), part, 1.0);
            }
        }
        double seen[3], part[3 * MAX_LIGHT_GROUPS];  /* the lamps along this stretch, through what comes before */
        for (int64_t i = 0; i < 3 * G; i++) part[i] = 0.0;
        camera_sees(params, o, D, t, 1, seen, passed > 0 && G > 0 ? part : NULL, sg, mm);
        for (int c = 0; c < 3; c++) front[c] += T[c] * seen[c];
        for (int64_t i = 0; i < 3 * G; i++) groups[i] += T[i % 3] * part[i];
        if (sg != NULL) {
            double kept[3];
            stretch_transmittance(mm, sg, t, kept);
            for (int c = 0; c < 3; c++) T[c] *= kept[c];
        }
        if (catcher) return 1;
        /* The surface: clear, and what it lets through. */
        Surface s;
        surface_at(o, D, t, u, v, &tri, 0, &s);
        double wo[3] = {-D[0], -D[1], -D[2]};
        sd->n = 0;
        sd->caustics = 0;
        sd->blur = 0.0;
        sd->terminator = 1.0;
        sd->uncorrected = 0;
        LightPath path = {PATH_CAMERA, 0, 0, 0, 0, passed, 0, 0.0, 0.0};
        ShaderKeys keys = {&rays, pixel, index, 0, 0, NULL};
        shade_hit(params->graphs, params->geometry, m, &tri, &s, geometry, prim, instance, u, v, wo, &path, &keys, 0, sd);
        for (int i = 0; i < sd->n; i++) {
            const double *w = sd->c[i].weight;
            if (!bsdf_is(sd->c[i].kind, BSDF_FLAG_STRAIGHT) && (w[0] != 0.0 || w[1] != 0.0 || w[2] != 0.0)) return 0;
        }
        for (int c = 0; c < 3; c++)
            if (sd->emission[c] != 0.0 || sd->holdout[c] != 0.0) return 0;
        for (int c = 0; c < 3; c++) T[c] *= sd->transparency[c];
        if (!(T[0] > 0.0 || T[1] > 0.0 || T[2] > 0.0)) return 0;
        if (stack != NULL) stack_cross(params->media, &inside, &s, 1);
        /* On from just past it, straight ahead (the camera's clipping end stays). */
        double next[3];
        spawn_ray(s.I, s.Ng, D, s.offset, next);
        double gone = (next[0] - O[0]) * D[0] + (next[1] - O[1]) * D[1] + (next[2] - O[2]) * D[2];
        for (int c = 0; c < 3; c++) o[c] = next[c];
        passed++;
        RayHitPacket packet;
        int valid[PACKET] ALIGNED(32);
        set_lane(&packet.ray, 0, o, D, t_max - gone);
        set_time(&packet.ray, 0, time);
        close_packet(&packet.ray, valid, 1);
        clear_hits(&packet);
        intersect(valid, params->scene, &packet, NULL);
        if (packet.hit.geomID[0] != INVALID_ID && params->geometry->hidden != NULL)
            see_past_hidden(params->geometry, intersect, params->scene, &packet, 0, o, D, t_max - gone,
                            HIDDEN_FROM_CAMERA, time);
        if (packet.hit.geomID[0] == INVALID_ID) return 0;
        t = (double)packet.ray.tfar[0];
        geometry = (int64_t)packet.hit.geomID[0];
        prim = (int64_t)packet.hit.primID[0];
        instance = instance_of(&packet.hit, 0);
        u = (double)packet.hit.u[0];
        v = (double)packet.hit.v[0];
    }
}

/* A sample's share of the shadow catchers' matte and background (catcher.py sample_rows) into its pixel's sums
 * row (CATCHER_CHANNELS): its RGBA s where its camera ray along D did not meet a catcher first, where it did
 * (`caught`, through clear surfaces and media that let T (3) through: catcher_behind, front_media) the lamps the
 * camera sees in front of it, `front` (3), with what the media in front emit, `emitted` (3), capped here by Clamp
 * Direct, and what they scatter, `scattered` (3, not capped), alpha 1 - mean(T) and one caught sample; behind: it
 * was caught or escaped, so the world along D is behind it (times T where caught; where the film is not transparent
 * and the camera sees the world). */
INLINE void catcher_matte(const ChunkParams *params, const double *s, int caught, const double *T, const double *front,
                          const double *emitted, const double *scattered, int behind, const double *D, double *row)
{
    if (caught) {
        double one[3] = {1.0, 1.0, 1.0}, seen[3];
        for (int c = 0; c < 3; c++) seen[c] = front[c] + emitted[c];
        double f = clamp_scale(seen, one, params->clamp_direct, 1.0);
        for (int c = 0; c < 3; c++) row[c] += finite_or_zero(seen[c] * f + scattered[c]);
        row[3] += 1.0 - (T[0] + T[1] + T[2]) / 3.0;
        row[10] += 1.0;
    } else {
        for (int c = 0; c < 4; c++) row[c] += s[c];
    }
    const WorldTables *world = params->light_context->world;
    if (behind && world->camera != 0.0 && params->transparent == 0.0) {
        LightPath camera = {PATH_CAMERA, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
        double seen[3];
        world_seen(world, D, &camera, seen);
        for (int c = 0; c < 3; c++) row[7 + c] += finite_or_zero(seen[c] * (caught ? T[c] : 1.0));
    }
}

/* The light of block b's caught samples (`caught` per lane) in the catcher-only scene `alone` (its params, with the
 * chunk's seed): their camera rays traced again there (the objects that are not catchers hidden from every ray) and
 * followed by its integrator, each lane's light times what the clear surfaces in front of its catcher let through,
 * through[lane] (3), added to its pixel's row of `sums` (channels 4..6, catcher.py K). H and work are reused (the block's own sums are in already); the light groups are put aside meanwhile. Returns
 * the shadow rays; traced and spent as render_chunk's. */
static int64_t catcher_light(const ChunkParams *alone, const ChunkArgs *a, CameraBlock *b, BlockHits *H,
                             PathWork *work, const uint8_t *caught, const double (*through)[3], int64_t start,
                             int64_t *traced, uint64_t *spent, double *sums)
{
    int any = 0;
    for (int64_t lane = 0; lane < b->n; lane++) {
        b->valid[lane] = caught[lane];
        any |= caught[lane];
    }
    if (!any) return 0;
    double *groups = H->groups;
    int64_t group_count = H->group_count;
    H->groups = NULL;
    H->group_count = 0;
    uint64_t begin = ticks(), before = spent[0], embree[2] = {0, 0};
    block_hits(alone, b, H, NULL, traced, spent);
    int64_t rays = integrate(alone, b, H, work, NULL, embree);
    spent[1] += embree[0];
    spent[0] += embree[1];
    spent[2] += (ticks() - begin) - (spent[0] - before);
    for (int64_t h = 0; h < H->m; h++) {
        int64_t lane = H->lane[h];
        double *row = sums + CATCHER_CHANNELS * ((start + lane) / a->spp);
        for (int c = 0; c < 3; c++)
            row[4 + c] += finite_or_zero(through[lane][c] * (H->L[3 * h + c] + work->extra[lane][c]));
    }
    /* (with Volume Bounces integrate moves the hits' own light, the catcher's emission, into its lane's scattered
     *  light, with what its media scatter: none along these rays, which cross no medium to their catcher) */
    if (alone->media != NULL && alone->media->scatters != 0)
        for (int64_t lane = 0; lane < b->n; lane++) {
            if (!caught[lane]) continue;
            double *row = sums + CATCHER_CHANNELS * ((start + lane) / a->spp);
            for (int c = 0; c < 3; c++) row[4 + c] += finite_or_zero(through[lane][c] * H->lane_scattered[lane][c]);
        }
    H->groups = groups;
    H->group_count = group_count;
    return rays;
}

/* Render spp samples in each of p pixels: samples first[k] .. first[k] + spp - 1 of pixel k's pattern.
 * pixels, first: (p,) int64. Out: the pixels' sums (out->rgba, squares, hits, zeroed here first) and
 * the chunk's counts and seconds (added to). */
static void render_chunk(const ChunkArgs *a)
{
    const ChunkParams *params = a->params;
    ChunkOut *out = a->out;
    int64_t width = (int64_t)params->width, height = (int64_t)params->height, total = a->p * a->spp;
    uint32_t stream = stream_of((int64_t)params->seed, 0), lens_stream = stream_of((int64_t)params->seed, LENS_DIMENSION);
    uint32_t time_stream = stream_of((int64_t)params->seed, TIME_DIMENSION);
    Stopwatch started = stopwatch();
    uint64_t spent[3] = {0, 0, 0};        /* ticks: nearest hits, occlusion, shading (as out->seconds) */
    int64_t traced = 0, shadow_rays = 0;
    CameraBlock b;
    BlockHits H;
    March lane_march;                    /* (a camera ray's march through heterogeneous media: field.c) */
    March catcher_march;                 /* (and one past a clear surface in front of a catcher: catcher_behind) */
    PathWork *work = NULL;
    int light_passes = params->light_passes != 0.0 && out->light != NULL;
    int64_t G = out->groups != NULL && params->light_groups > 0 && params->light_groups <= MAX_LIGHT_GROUPS
                ? (int64_t)params->light_groups : 0;
    double *group_storage = NULL;                   /* the light groups (lightgroups.py): H's, a's, b's, the lanes' */
    H.groups = work_groups(&group_storage, G, 0);
    H.group_count = G;
    int features = params->features != 0.0 && out->features != NULL;   /* the denoising features (features.c) */
    LanePasses *passes = NULL;                      /* the first-hit passes (passes.c) */
    if (params->passes != NULL && (out->passes != NULL || out->mattes != NULL)) {
        passes = (LanePasses *)malloc(sizeof(LanePasses));
        if (passes == NULL) { free(group_storage); return; }
        passes->tables = params->passes;
        passes->transparent_bounces = (int)params->transparent_bounces;
        passes->room = (int64_t)params->transparent_bounces + 1;
        passes->mattes = (double *)malloc((size_t)(BLOCK * passes->room * 4) * sizeof(double));
        Transmitter ao = {(Intersect8)params->intersect8, params->scene, params->geometry, params->materials,
                          params->graphs, (int)params->transparent_bounces, NULL};
        passes->ao = ao;
        if (passes->mattes == NULL) { free(passes); free(group_storage); return; }
    }
    /* Shadow catchers (catcher.py): the caught samples are followed again in the catcher-only scene's params. */
    const ChunkParams *alone = out->catcher != NULL ? (const ChunkParams *)params->catcher : NULL;
    int catching = alone != NULL;
    /* (with Volume Bounces a camera ray's path goes on from where it scatters: integrate's chains) */
    int chains = (int)params->integrator == INTEGRATOR_PATH && params->volume_bounces > 0 && params->max_bounces >= 1
                 && !fast_gi_scatter_past((int)params->ao_bounces, 0, 0, 0);
    uint8_t caught[BLOCK];
    double through[BLOCK][3], front[BLOCK][3];      /* (what clear surfaces in front of a catcher let through; lamps) */
    double front_emitted[BLOCK][3], front_scattered[BLOCK][3];   /* (what the media in front of it emit, scatter) */
    ShaderResult clear_sd;                          /* (room for the closures of those surfaces: catcher_behind) */
    int64_t clear_room = params->closure_room < 1 ? 1 : (int64_t)params->closure_room;
    clear_sd.room = (int)clear_room;
    clear_sd.c = NULL;
    clear_sd.storage = NULL;
    if (catching) {
        clear_sd.c = (Closure *)malloc((size_t)clear_room * (sizeof(Closure) + STORAGE_STRIDE * sizeof(double)));
        if (clear_sd.c == NULL) { free(group_storage); free_passes(passes); return; }
        clear_sd.storage = (double *)(clear_sd.c + clear_room);
    }
    if ((int)params->integrator == INTEGRATOR_PATH || params->see_through != 0.0 || params->walks != 0.0 || light_passes
        || features || catching) {
        work = (PathWork *)malloc(sizeof(PathWork));
        if (work == NULL) { free(group_storage); free_passes(passes); free(clear_sd.c); return; }   /* (the caller finds no samples counted) */
        work->a.groups = work_groups(&group_storage, G, 1);
        work->b.groups = work_groups(&group_storage, G, 2);
        work->groups = work_groups(&group_storage, G, 3);
        work->c.groups = work_groups(&group_storage, G, 4);
        work->lane_groups = work_groups(&group_storage, G, 5);
        work->a.group_count = work->b.group_count = work->c.group_count = G;
    }
    if (G > 0 && group_storage == NULL) { free(work); free_passes(passes); free(clear_sd.c); return; }
    /* Room for every closure a hit of the scene's materials sets up (no limit of their own). */
    BlockHits *blocks[4] = {&H, work != NULL ? &work->a : NULL, work != NULL ? &work->b : NULL,
                            work != NULL ? &work->c : NULL};
    Closure *closures = NULL;
    if (!block_closures(blocks, work != NULL ? 4 : 1, params->closure_room < 1 ? 1 : (int64_t)params->closure_room,
                        &closures)) {
        free(work);
        free(group_storage);
        free_passes(passes);
        free(clear_sd.c);
        return;
    }
    for (int64_t k = 0; k < a->p; k++) {
        for (int c = 0; c < 4; c++) out->rgba[4 * k + c] = 0.0;
        if (out->squares != NULL) out->squares[2 * k] = out->squares[2 * k + 1] = 0.0;
        out->hits[k] = 0;
        if (out->nonfinite != NULL) out->nonfinite[k] = 0;
        if (light_passes)
            for (int i = 0; i < LIGHT_CHANNELS; i++) out->light[LIGHT_CHANNELS * k + i] = 0.0;
        for (int64_t i = 0; i < 3 * G; i++) out->groups[3 * G * k + i] = 0.0;
        if (features)
            for (int i = 0; i < FEATURE_CHANNELS; i++) out->features[FEATURE_CHANNELS * k + i] = 0.0;
        if (passes != NULL && out->passes != NULL)
            for (int64_t i = 0; i < params->passes->channels; i++) out->passes[params->passes->channels * k + i] = 0.0;
        if (passes != NULL && out->mattes != NULL)
            for (int64_t i = 0; i < 2 * params->passes->matte_count * params->passes->slots; i++)
                out->mattes[2 * params->passes->matte_count * params->passes->slots * k + i] = 0.0;
        if (catching)
            for (int i = 0; i < CATCHER_CHANNELS; i++) out->catcher[CATCHER_CHANNELS * k + i] = 0.0;
    }
    /* Whether camera rays can see more than the hit and a constant background: lamps, an image or graph world. */
    int sees_more = (params->light_context->world->image != NULL || params->light_context->world->seen != NULL)
                    && params->light_context->world->camera != 0.0;
    for (int64_t l = 0; l < (int64_t)params->light_count; l++) {
        const LightRecord *light = params->lights + l;
        sees_more |= light->hittable != 0.0 && light->camera != 0.0
                     && light_is((int)light->kind, LIGHT_FLAG_POSITION | LIGHT_FLAG_AREA | LIGHT_FLAG_DISTANT);
    }
    for (int64_t start = 0; start < total; start += BLOCK) {
        /* 0. A cancelled render stops here (render.py drops the chunk). */
        if (params->stop != NULL && *(volatile const int32_t *)params->stop != 0) break;
        /* 1. The block's camera rays (camera.c). */
        camera_samples(&b, params->camera, stream, lens_stream, time_stream, width, height, a->pixels, a->first, a->spp, start,
                       total);
        /* 2. Their nearest hits and the surfaces there. */
        uint64_t begin = ticks();
        uint64_t before = spent[0];
        if (passes != NULL) passes_clear(passes);  /* (before the camera's hits: their shaders write the AOVs) */
        block_hits(params, &b, &H, passes, &traced, spent);
        /* 3. The light each hit sends towards the camera. */
        uint64_t embree[2] = {0, 0};
        shadow_rays += integrate(params, &b, &H, work, passes, embree);
        spent[1] += embree[0];
        spent[0] += embree[1];
        spent[2] += (ticks() - begin) - (spent[0] - before);      /* (occlusion queries included, as before) */
        /* 4. Every sample of the block into its pixel's sums (film.c), in sample order. */
        int64_t h = 0, k = start / a->spp, j = start % a->spp;
        for (int64_t lane = 0; lane < b.n; lane++, j++) {
            if (j == a->spp) { j = 0; k++; }
            double s[4] = {0.0, 0.0, 0.0, 0.0}, seen[3 * MAX_LIGHT_GROUPS];
            double *groups = G > 0 ? out->groups + 3 * G * k : NULL;      /* (the pixel's light groups) */
            for (int64_t i = 0; i < 3 * G; i++) seen[i] = 0.0;
            int is_hit = h < H.m && H.lane[h] == lane;
            const double *sigma = params->media != NULL ? H.lane_sigma[lane] : NULL;
            const March *marched = NULL;                /* (the camera ray's march through heterogeneous media) */
            if (sigma != NULL && b.valid[lane] && params->media->fields != NULL) {
                double O[3] = {b.O[0][lane], b.O[1][lane], b.O[2][lane]}, D[3] = {b.D[0][lane], b.D[1][lane], b.D[2][lane]};
                marched = stretch_march(params->media, &H.lane_inside[lane], O, D, H.t[lane], sigma,
                                        H.lane_emission[lane], &lane_march);
            }
            caught[lane] = 0;
            for (int c = 0; c < 3; c++) front_emitted[lane][c] = front_scattered[lane][c] = 0.0;
            if (catching && is_hit) {               /* (its catcher, at once or through clear surfaces: catcher.caught) */
                double O[3] = {b.O[0][lane], b.O[1][lane], b.O[2][lane]}, D[3] = {b.D[0][lane], b.D[1][lane], b.D[2][lane]};
                caught[lane] = (uint8_t)catcher_behind(params, O, D, b.t[lane], b.time[lane], H.geometry[h], H.prim[h],
                                                       H.instance[h], H.bary[2 * h], H.bary[2 * h + 1], H.t[lane],
                                                       (int64_t)b.pixel[lane], (int64_t)b.index[lane], &clear_sd,
                                                       through[lane], front[lane],
                                                       sigma != NULL ? &H.lane_inside[lane] : NULL, sigma, marched,
                                                       &catcher_march, front_emitted[lane], groups != NULL ? seen : NULL);
            }
            if (b.valid[lane] && sees_more) {
                double O[3] = {b.O[0][lane], b.O[1][lane], b.O[2][lane]}, D[3] = {b.D[0][lane], b.D[1][lane], b.D[2][lane]};
                camera_sees(params, O, D, H.t[lane], is_hit, s, groups != NULL ? seen : NULL, sigma, marched);
            } else if (b.valid[lane] && !is_hit) {
                double kept[3] = {1.0, 1.0, 1.0};
                if (sigma != NULL) stretch_transmittance(marched, sigma, INFINITY, kept);
                for (int c = 0; c < 3; c++) s[c] = params->background[c] * kept[c];
                if (params->world_group >= 0 && groups != NULL && params->transparent == 0.0
                    && params->light_context->world->camera != 0.0)
                    add_to_group(seen, G, 0, params->world_group, s, 1.0);
            }
            if (sigma != NULL && b.valid[lane]) {       /* the media's emission along the camera ray */
                double emitted[3] = {0.0, 0.0, 0.0};    /* (its light group: the medium's object's, media.c) */
                stretch_emitted(marched, sigma, H.lane_emission[lane], H.t[lane], emitted);
                for (int c = 0; c < 3; c++) s[c] += emitted[c];
                if (caught[lane])
                    for (int c = 0; c < 3; c++) front_emitted[lane][c] += emitted[c];
                if (groups != NULL)
                    add_to_group(seen, G, 0, emission_group(params->media, &H.lane_inside[lane], params->world_group),
                                 emitted, 1.0);
            }
            double f = 1.0;
            int scattering = params->media != NULL && params->media->scatters != 0 && work != NULL && b.valid[lane];
            if (params->clamp_direct < INFINITY) {      /* what the camera sees itself: a direct contribution */
                double one[3] = {1.0, 1.0, 1.0};
                f = clamp_scale(s, one, params->clamp_direct, 1.0);
                for (int c = 0; c < 3; c++) s[c] *= f;
            }
            /* (the auxiliary sums take each sample's channel that is NaN or beyond the film as 0, as the image) */
            if (caught[lane] && G > 0) {                /* (a caught sample's groups: capped as its matte's lamps) */
                double one[3] = {1.0, 1.0, 1.0}, matte[3];
                for (int c = 0; c < 3; c++) matte[c] = front[lane][c] + front_emitted[lane][c];
                f = clamp_scale(matte, one, params->clamp_direct, 1.0);
            }
            for (int64_t i = 0; i < 3 * G; i++) seen[i] *= f;
            if (features && b.valid[lane]) {            /* (what the camera sees itself, then its path's) */
                double *fk = out->features + FEATURE_CHANNELS * k;
                for (int i = 0; i < FEATURE_CHANNELS; i++)
                    fk[i] += finite_or_zero((i < 3 ? s[i] : 0.0) + (is_hit ? work->features[lane][i] : 0.0)
                                            + work->camera_features[lane][i]);
            }
            if (scattering) {                           /* what its media scatter towards it (not clamped) */
                for (int c = 0; c < 3; c++) s[c] += H.lane_scattered[lane][c];
                /* (in front of a catcher: the matte's, its light passes and groups kept, as Cycles writes them before
                 *  its split; with Volume Bounces left to the pass, catcher.py front_media) */
                int kept = !caught[lane] || !chains;
                if (caught[lane] && !chains)
                    for (int c = 0; c < 3; c++) front_scattered[lane][c] = H.lane_scattered[lane][c];
                if (light_passes && kept)               /* (and its light passes: integrate's lane_light) */
                    for (int i = 0; i < LIGHT_CHANNELS; i++)
                        out->light[LIGHT_CHANNELS * k + i] += finite_or_zero(work->lane_light[lane][i]);
                if (G > 0 && work->lane_groups != NULL && kept)   /* (and its chains' light groups) */
                    for (int64_t i = 0; i < 3 * G; i++) seen[i] += work->lane_groups[3 * G * lane + i];
            }
            if (passes != NULL && b.valid[lane]) {      /* (what the camera ray passes and escapes to, then its chain's) */
                double O[3] = {b.O[0][lane], b.O[1][lane], b.O[2][lane]}, D[3] = {b.D[0][lane], b.D[1][lane], b.D[2][lane]};
                double one[3] = {1.0, 1.0, 1.0};
                DirectSettings seen = {.lights = params->lights, .n_lights = (int64_t)params->light_count,
                                       .context = params->light_context, .media = params->media};
                passes_along_ray(passes, &seen, lane, (int64_t)b.index[lane], one, O, D, is_hit, H.t[lane],
                                 params->media != NULL ? &H.lane_inside[lane] : NULL);
                int64_t width = 2 * params->passes->matte_count * params->passes->slots;
                passes_to_pixel(passes, lane, out->passes != NULL ? out->passes + params->passes->channels * k : NULL,
                                out->mattes != NULL ? out->mattes + width * k : NULL);
            }
            if (is_hit) {
                /* (the camera's hit's light, through what the media let through to it: 1 without media) */
                for (int c = 0; c < 3; c++) s[c] += params->media != NULL ? H.throughput[3 * h + c] * H.L[3 * h + c]
                                                                          : H.L[3 * h + c];
                /* (a path that met a catcher writes no light groups and no light passes, as in Cycles: catcher.py) */
                if (!caught[lane])
                    for (int64_t i = 0; i < 3 * G; i++)
                        seen[i] += params->media != NULL ? H.throughput[3 * h + i % 3] * H.groups[3 * G * h + i]
                                                         : H.groups[3 * G * h + i];
                if (work != NULL && ((int)params->integrator == INTEGRATOR_PATH || params->see_through != 0.0
                                     || params->walks != 0.0)) {
                    for (int c = 0; c < 3; c++) s[c] += work->extra[lane][c];
                    if (!caught[lane])
                        for (int64_t i = 0; i < 3 * G; i++) seen[i] += work->groups[3 * G * lane + i];
                }
                if (light_passes && !caught[lane])
                    for (int i = 0; i < LIGHT_CHANNELS; i++)
                        out->light[LIGHT_CHANNELS * k + i] += finite_or_zero(work->light[lane][i]);
                s[3] = 1.0 - H.held[lane];          /* the holes holdout objects make (path.hold_out) */
                h++;
                out->hits[k]++;
            } else if (b.valid[lane]) {
                s[3] = params->background[3];
            } else {
                s[0] = s[1] = s[2] = 0.0;   /* outside a fisheye's image circle: opaque black */
                s[3] = 1.0;
            }
            for (int64_t i = 0; i < 3 * G; i++) groups[i] += finite_or_zero(seen[i]);
            /* A channel that is NaN or beyond the float32 film goes in as 0, counted (film.py finite_samples). */
            int bad = 0;
            for (int c = 0; c < 4; c++)
                if (!(fabs(s[c]) <= FILM_MAX)) { s[c] = 0.0; bad = 1; }
            if (bad && out->nonfinite != NULL) out->nonfinite[k]++;
            add_sample(s, params->luminance, out->rgba + 4 * k, out->squares != NULL ? out->squares + 2 * k : NULL);
            if (catching) {
                double D[3] = {b.D[0][lane], b.D[1][lane], b.D[2][lane]};
                catcher_matte(params, s, caught[lane], through[lane], front[lane], front_emitted[lane],
                              front_scattered[lane], b.valid[lane] && (caught[lane] || !is_hit), D,
                              out->catcher + CATCHER_CHANNELS * k);
            }
        }
        /* 5. The caught samples again, in the catcher-only scene: their light there (catcher.py K). */
        if (catching) shadow_rays += catcher_light(alone, a, &b, &H, work, caught, (const double (*)[3])through, start, &traced,
                                                    spent, out->catcher);
    }
    free(work);
    free(group_storage);
    free(closures);
    free_passes(passes);
    free(clear_sd.c);
    out->counts[0] += traced;
    out->counts[1] += shadow_rays;
    double scale = seconds_per_tick(started);
    for (int i = 0; i < 3; i++) out->seconds[i] += (double)spent[i] * scale;
}

