/* Scattering along a path's rays: core/integrators/volume.py, one ray at a time.
 *
 * On each stretch of a ray through a scattering medium, one point drawn by free flight (a channel picked by
 * throughput x albedo, an exponential distance truncated at the stretch's end) gathers light samples with shadow rays
 * through the media, weighed by MIS against one phase-sampled ray; towards each lamp with a position a second point
 * drawn by equi-angular sampling gathers that lamp's light; the two points are weighed by the balance heuristic on
 * their densities of the distance. With Volume Bounces a path goes on from where it scatters (volume_chain: free
 * flight untruncated decides whether it collides or passes, scatter_or_pass; the paths that reach a surface are
 * Arrivals that path.c appends to its next vertex block). The same sampling dimensions as the Python, so the kernels
 * agree to rounding. */

/* (the Henyey-Greenstein phase function: core/volumes/phase.c) */

/* volume.channel_odds: the chance (3) free flight picks each channel, by |throughput| x albedo. */
INLINE void channel_odds(const double *sigma_t, const double *sigma_s, const double *throughput, double *odds)
{
    double share[3];
    for (int c = 0; c < 3; c++) share[c] = fabs(throughput[c]) * (sigma_t[c] > 0.0 ? sigma_s[c] / sigma_t[c] : 0.0);
    double total = (share[0] + share[1]) + share[2];
    for (int c = 0; c < 3; c++) odds[c] = total > 0.0 ? share[c] / total : 0.0;
}

/* volume.distance_pdf: the density of free flight choosing s on a stretch of length t (the channels' mixture). */
INLINE double distance_pdf(const double *sigma_t, const double *odds, double t, double s)
{
    double each[3];
    for (int c = 0; c < 3; c++) {
        double reach = -expm1(-sigma_t[c] * t);
        each[c] = odds[c] > 0.0 ? odds[c] * sigma_t[c] * exp(-sigma_t[c] * s) / (reach > 0.0 ? reach : 1.0) : 0.0;
    }
    return (each[0] + each[1]) + each[2];
}

/* volume.equiangular for one ray O + s D, 0 <= s < t, towards X: with u >= 0 the distance it draws goes to *s; its
 * pdf (0: none) returned for *s. */
INLINE double equiangular(const double *O, const double *D, double t, const double *X, double u, double *s)
{
    double w[3], off[3];
    for (int c = 0; c < 3; c++) w[c] = X[c] - O[c];
    double delta = dot3(w, D);
    for (int c = 0; c < 3; c++) off[c] = w[c] - delta * D[c];
    double h = sqrt(dot3(off, off));
    h = at_least(h, 1e-9 * at_least(fabs(delta), 1.0));
    double a = atan2(-delta, h), b = isfinite(t) ? atan2(t - delta, h) : 0.5 * PI;
    if (u >= 0.0) {
        double x = delta + h * tan(a + u * (b - a));
        *s = x < 0.0 ? 0.0 : (x > t ? t : x);
    }
    return b > a ? h / ((b - a) * (h * h + (*s - delta) * (*s - delta))) : 0.0;
}

/* Whether light l is aimed at by equi-angular sampling (volume.equiangular_lamps: a position or an area lamp, not
 * hidden from Volume Scatter rays). */
INLINE int equiangular_lamp(const LightRecord *light)
{
    return light_is((int)light->kind, LIGHT_FLAG_POSITION | LIGHT_FLAG_AREA)
           && ((int)light->hidden & HIDDEN_FROM_VOLUME_SCATTER) == 0;   /* (not one hidden from Volume Scatter) */
}

/* A stretch's free-flight point (in_scattering): the ray O, D over [0, t), its distance s and that distance's pdf. */
typedef struct {
    const double *O, *D;
    double t, s, pdf;
} FreeFlight;

/* volume.scattered_light at one point P (3) of phase function `phase` in the media `inside`, seen along wo (3): the
 * light per unit sigma_s into L (3, zeroed here). flight: the free-flight point P is (each equi-angular lamp's light samples
 * there weighed against that lamp's equi-angular points by the balance heuristic), or NULL; only: a light's index (an equi-angular point: its samples alone, no phase ray), or
 * -1; onward: where the path goes on along the phase ray (Volume Bounces), that ray (the light behind the
 * transparent surfaces it meets is then the path's to find), or NULL. groups: (ds->groups, 3) L by the group of its
 * source (zeroed here; lightgroups.py: a light sample's light's, the phase ray's finds', the media's emission by
 * emission_group), or NULL. ao: 1 where the phase ray is Fast GI's short ray (fast_gi_scatter; not with onward): it
 * looks ds->ao_distance far, its media only absorb and emit (all but the world's left where it meets nothing), and
 * the world it escapes to counts ds->ao_factor times. Returns the shadow rays traced. */
static int64_t scattered_light(const DirectSettings *ds, const PathLimits *limits, const double *P, const double *wo,
                               const Phase *phase, const VolumeStack *inside, int64_t pixel, int64_t sample,
                               int64_t dimension, int bounce, const FreeFlight *flight, int64_t only, double *L,
                               PhaseRay *onward, double *groups, int ao)
{
    int64_t rays = 0;
    double zero[3] = {0.0, 0.0, 0.0};
    L[0] = L[1] = L[2] = 0.0;
    if (groups != NULL)
        for (int64_t i = 0; i < 3 * ds->groups; i++) groups[i] = 0.0;
    /* 1. Light samples, each with its shadow ray through the media. */
    for (int64_t l = 0; l < ds->n_lights; l++) {
        const LightRecord *light = ds->lights + l;
        if (only >= 0 && l != only) continue;
        int hittable = light->hittable != 0.0, extent = light->delta == 0.0;
        if (ds->sampling == SAMPLE_BSDF && extent && light->use_mis != 0 && hittable) continue;
        if (((int)light->hidden & HIDDEN_FROM_VOLUME_SCATTER) != 0) continue;   /* (SHADER_EXCLUDE_SCATTER) */
        int64_t count = (int64_t)light->samples;
        for (int64_t j = 0; j < count; j++) {
            double u[2] = {0.0, 0.0};
            if (extent)
                sample_2d(stream_of((int64_t)ds->seed, (int64_t)light->dimension + dimension + LIGHT_SHIFT), pixel,
                          sample * count + j, u);
            LightSample ls;
            ls.emitter = -1;
            ls.hidden = 0;
            LightPath lit = {PATH_EMISSION, bounce, 0, 0, 0, 0, 0, 0.0, 0.0};   /* (a light's own shading) */
            sample_light_for(light, ds->context, P, zero, u, &lit, &ls);
            if (light_is((int)light->kind, LIGHT_FLAG_INFINITE) && ds->context->world->samples_seen != 0
                && (ls.strength > 0.0 || ls.strength < 0.0))
                world_seen(ds->context->world, ls.L, &lit, ls.color);   /* (volume.world_samples_seen) */
            const EmitterTables *e = ds->context->emitters;
            if (light_is((int)light->kind, LIGHT_FLAG_EMITTER) && e->textured != NULL && ls.strength > 0.0
                && e->textured[ls.emitter]) {
                /* (a textured emitter: what its node graph emits where the sample landed) */
                int64_t geometry, prim, instance;
                unflat_prim(ds->geometry, e->prim[ls.emitter], &geometry, &prim, &instance);
                LightPath emitted = {PATH_EMISSION, bounce, 0, 0, 0, 0, 0, 0.0, 0.0};   /* (a light's own shading) */
                graph_emission(ds, geometry, prim, instance, P, ls.L, ls.distance, STILL_TIME, &emitted, NULL,
                               ls.color);
            }
            if (!(ls.strength > 0.0 || ls.strength < 0.0)) continue;
            if ((ls.hidden & HIDDEN_FROM_VOLUME_SCATTER) != 0) continue;   /* (an emitter's object hidden so) */
            if (light->max_bounces < 1024 && bounce > light->max_bounces) continue;
            /* (Light and Shadow Linking: a medium receives as the default set 0; an emitter links by its object) */
            uint64_t lights = light->light_membership, blockers = light->shadow_membership;
            if (light_is((int)light->kind, LIGHT_FLAG_EMITTER) && ds->geometry->links != NULL && ls.emitter >= 0) {
                int64_t geometry, prim, instance;
                unflat_prim(ds->geometry, e->prim[ls.emitter], &geometry, &prim, &instance);
                lights = links_of(ds->geometry, geometry, prim, instance, 2);
                blockers = links_of(ds->geometry, geometry, prim, instance, 3);
            }
            if (lights != ALL_SETS && !in_sets(lights, 0)) continue;
            double T[1][3] = {{1.0, 1.0, 1.0}};
            if (light->cast_shadow != 0 && ds->transmitter != NULL) {   /* (media make every render's shadows transparent) */
                double origin[1][3], D[1][3], t;
                /* (Ray Depth: one deeper, as a shadow ray's) */
                LightPath shadow = {PATH_SHADOW, bounce, 0, 0, 0, 0, 0, 0.0, 0.0};
                shadow_ray(P, zero, P, 0.0, 0.0, ls.L, ls.distance, ls.position, ls.normal, 1, 0.0, origin[0], D[0],
                           &t);
                transmit_packet(ds->transmitter, 1, origin, D, &t, &STILL_TIME, &shadow, &blockers, inside, T);
                rays++;
            }
            double cos_theta = -wo[0] * ls.L[0] + -wo[1] * ls.L[1] + -wo[2] * ls.L[2];
            double p = phase->kind == PHASE_HENYEY_GREENSTEIN && phase->lobes == 0
                           ? henyey_greenstein(cos_theta, phase->p[0]) : phase_eval(phase, cos_theta);
            double w = ls.strength * (1.0 / (double)count);
            if (flight != NULL && equiangular_lamp(light)) {
                double s = flight->s;
                w = w * (flight->pdf / (flight->pdf + equiangular(flight->O, flight->D, flight->t, light->position, -1.0,
                                                                  &s)));
            }
            if (extent && light->use_mis != 0 && hittable && ds->mis && blockers == ALL_SETS)
                w = w * power_heuristic(mis_samples(light) * ls.pdf, p);   /* (shadow-linked: light samples alone) */
            double value[3];
            for (int c = 0; c < 3; c++) { value[c] = (w * p) * ls.color[c] * T[0][c]; L[c] += value[c]; }
            if (groups != NULL)                          /* (an emitter's group is its object's) */
                add_to_group(groups, ds->groups, 0,
                             ls.emitter >= 0 && e != NULL && e->group != NULL ? e->group[ls.emitter] : light->group,
                             value, 1.0);
        }
    }
    /* 2. One phase-sampled direction: the light its ray finds (its weight p / pdf is 1). */
    if (only >= 0 || !(ds->bsdf_rays || ds->media->emits != 0 || onward != NULL)) return rays;
    double u[2], wi[3];
    sample_2d(stream_of((int64_t)ds->seed, PHASE_DIMENSION + dimension), pixel, sample, u);
    double pdf = phase_sample(phase, wo, u, wi);
    RayHitPacket packet;
    int valid[PACKET] ALIGNED(32);
    double reach = ao ? ds->ao_distance : INFINITY;      /* (Fast GI's short ray: AO Distance far) */
    set_lane(&packet.ray, 0, P, wi, reach);
    close_packet(&packet.ray, valid, 1);
    clear_hits(&packet);
    ds->intersect(valid, ds->scene, &packet, NULL);
    if (packet.hit.geomID[0] != INVALID_ID && ds->geometry->hidden != NULL)     /* (objects hidden from it) */
        see_past_hidden(ds->geometry, ds->intersect, ds->scene, &packet, 0, P, wi, reach,
                        HIDDEN_FROM_VOLUME_SCATTER, STILL_TIME);
    int hit = packet.hit.geomID[0] != INVALID_ID;
    VolumeStack along = *inside;                         /* (a short ray that meets nothing: the world's alone) */
    if (ao && !hit) stack_empty(&along);
    inside = &along;
    double t = hit ? (double)packet.ray.tfar[0] : INFINITY, sigma_t[3], emission[3];
    if (onward != NULL) {
        for (int c = 0; c < 3; c++) onward->wi[c] = wi[c];
        onward->pdf = pdf;
        onward->hit = hit;
        onward->t = t;
        onward->u = (double)packet.hit.u[0];
        onward->v = (double)packet.hit.v[0];
        onward->geometry = (int64_t)packet.hit.geomID[0];
        onward->prim = (int64_t)packet.hit.primID[0];
        onward->instance = instance_of(&packet.hit, 0);
    }
    medium_along(ds->media, inside, sigma_t, emission);
    March march;                                         /* (through a heterogeneous medium: its march, field.c) */
    const March *marched = stretch_march(ds->media, inside, P, wi, t, sigma_t, emission, &march);
    if (!ds->gather) {
        double emitted[3] = {0.0, 0.0, 0.0};
        stretch_emitted(marched, sigma_t, emission, t, emitted);
        for (int c = 0; c < 3; c++) L[c] += emitted[c];
        add_to_group(groups, ds->groups, 0, emission_group(ds->media, inside, ds->world_group), emitted, 1.0);
        return rays;
    }
    double light_L[3] = {0.0, 0.0, 0.0};
    LightPath scatter = {PATH_VOLUME_SCATTER, bounce + 1, 0, 0, 0, 0, 0, 0.0, 0.0};   /* (volume.scatter_paths) */
    FindingRay finding = {P, wi, hit, hit ? t : reach, (int64_t)packet.hit.geomID[0], (int64_t)packet.hit.primID[0],
                          instance_of(&packet.hit, 0), pdf, ds->mis, 0, NULL, NULL, HIDDEN_FROM_VOLUME_SCATTER, &scatter, 0,
                          sigma_t, emission, NULL,
                          inside, STILL_TIME, ao, 0};     /* (a render with media moves no object; no caster culls it) */
    gather_light(ds, &finding, light_L, groups);
    for (int c = 0; c < 3; c++) L[c] += light_L[c];
    if (!hit || ds->transmitter == NULL || onward != NULL) return rays;
    /* Straight on through the transparent surfaces it meets, to the light behind them. */
    PathRay r;
    r.h = 0;
    r.t = t;
    r.u = (double)packet.hit.u[0];
    r.v = (double)packet.hit.v[0];
    r.geometry = (int64_t)packet.hit.geomID[0];
    r.prim = (int64_t)packet.hit.primID[0];
    r.instance = instance_of(&packet.hit, 0);
    r.pdf = pdf;
    r.seen_as = HIDDEN_FROM_VOLUME_SCATTER;
    r.kind = -1;
    r.transmit = 0;
    r.inside = *inside;
    r.path = scatter;
    r.receiver = 0;                                      /* (a medium receives as the default set: Light Linking) */
    r.ao = ao;
    r.cull = 0;                                          /* (a medium scatters: no caster culls its ray, mnee.c) */
    stretch_transmittance(marched, sigma_t, t, r.attenuation);
    for (int c = 0; c < 3; c++) { r.O[c] = P[c]; r.D[c] = wi[c]; r.weight[c] = 1.0; r.mis_O[c] = P[c]; r.mis_N[c] = 0.0; }
    double behind[3] = {0.0, 0.0, 0.0};
    through_transparent(&r, 0, limits, ds, r.weight, INFINITY, behind, groups);
    for (int c = 0; c < 3; c++) L[c] += behind[c];
    return rays;
}

/* volume.in_scattering for one ray O, D (3) over [0, t) (inf: to the world) in the media `inside`, carrying
 * `throughput` (3, not included): the light its media scatter towards O, into L (3, zeroed here). dimension: the
 * vertex's shift of the sampling dimensions; bounce: the real bounces the path made (a light's Max Bounces);
 * groups: (ds->groups, 3) L by group (zeroed here), or NULL; ao: 1 where its scattering points' phase rays are Fast
 * GI's (fast_gi_scatter). Returns the shadow rays traced. */
static int64_t in_scattering(const DirectSettings *ds, const PathLimits *limits, const double *O, const double *D,
                             double t, const VolumeStack *inside, const double *throughput, int64_t pixel,
                             int64_t sample, int64_t dimension, int bounce, double *L, double *groups, int ao);

/* volume.equiangular_light: each lamp with a position adds the light scattered at its equi-angular point on O, D
 * over [0, t), lit by that lamp alone and weighed by the balance heuristic against free flight (odds), into L (3):
 * in a marched medium m (its march gives the coefficients and transmittance there; phase: the phase function of
 * a homogeneous one, NULL: that of the heterogeneous one at the point, phase_at) or, m NULL, in the homogeneous one
 * of sigma_t, sigma_s (3) and phase function `phase`. collision: 1 where free flight is untruncated
 * (march_collision: a path that scatters or goes on), 0 truncated at t. groups: (ds->groups, 3) what is added to
 * L by group, added to, or NULL. Returns the shadow rays traced. */
static int64_t equiangular_lamps(const DirectSettings *ds, const PathLimits *limits, const March *m,
                                 const double *sigma_t, const double *sigma_s, const Phase *phase, const double *odds,
                                 int collision, const double *O, const double *D, double t, const VolumeStack *inside,
                                 int64_t pixel, int64_t sample, int64_t dimension, int bounce, double *L,
                                 double *groups)
{
    double lit_groups[3 * MAX_LIGHT_GROUPS];
    double wo[3] = {-D[0], -D[1], -D[2]};
    int64_t rays = 0;
    for (int64_t l = 0; l < ds->n_lights; l++) {
        const LightRecord *light = ds->lights + l;
        if (!equiangular_lamp(light)) continue;
        double v[2], s_e = 0.0;
        sample_2d(stream_of((int64_t)ds->seed, EQUIANGULAR_DIMENSION + l + dimension), pixel, sample, v);
        double pdf_e = equiangular(O, D, t, light->position, v[0], &s_e);
        if (!(pdf_e > 0.0)) continue;
        double w, at_t[3], at_s[3], kept[3], X[3], lit[3];
        Phase here = {PHASE_HENYEY_GREENSTEIN, {0.0}, 0, {0}, {{0.0}}, {0.0}};
        for (int c = 0; c < 3; c++) X[c] = O[c] + s_e * D[c];
        if (m != NULL) {
            w = pdf_e / (pdf_e + (collision ? march_collision_pdf(m, odds, s_e) : march_pdf(m, odds, s_e)));
            double g = march_true_at(m, s_e, at_t, at_s);
            if (phase != NULL) here = *phase;
            else phase_at(ds->media, inside, X, g, &here);     /* (a heterogeneous medium: its phase there) */
            march_transmittance(m, s_e, kept);
        } else {
            w = pdf_e / (pdf_e + distance_pdf(sigma_t, odds, t, s_e));
            here = *phase;
            for (int c = 0; c < 3; c++) at_s[c] = sigma_s[c];
            beer_lambert(sigma_t, s_e, kept);
        }
        rays += scattered_light(ds, limits, X, wo, &here, inside, pixel, sample, dimension, bounce, NULL, l, lit,
                                NULL, groups != NULL ? lit_groups : NULL, 0);
        double scale[3];
        for (int c = 0; c < 3; c++) { scale[c] = (kept[c] * at_s[c]) * (w / pdf_e); L[c] += scale[c] * lit[c]; }
        add_groups(groups, lit_groups, ds->groups, scale);
    }
    return rays;
}

/* volume.marched_scattering: in_scattering for a ray O, D over [0, t) in a heterogeneous medium (its march m,
 * field.c): free flight inverting the optical depth of a channel picked by throughput x the ray's albedo (its optical
 * depths' ratio), weight T(s) sigma_s(s) / pdf(s), and each lamp's equi-angular point weighed against it by the
 * balance heuristic; into L (3, zeroed by the caller) and by group into groups ((ds->groups, 3), zeroed by the
 * caller, or NULL); ao: in_scattering's. Returns the shadow rays traced. */
static int64_t marched_scattering(const DirectSettings *ds, const PathLimits *limits, const March *m, const double *O,
                                  const double *D, double t, const VolumeStack *inside, const double *throughput,
                                  int64_t pixel, int64_t sample, int64_t dimension, int bounce, double *L,
                                  double *groups, int ao)
{
    double point_groups[3 * MAX_LIGHT_GROUPS];
    double tau_t[3], tau_s[3], odds[3], u[2], s = 0.0, wo[3] = {-D[0], -D[1], -D[2]};
    int64_t rays = 0;
    march_totals(m, tau_t, tau_s);
    channel_odds(tau_t, tau_s, throughput, odds);
    /* 1. The free-flight point, its weight T(s) sigma_s(s) / pdf(s). */
    sample_2d(stream_of((int64_t)ds->seed, DISTANCE_DIMENSION + dimension), pixel, sample, u);
    double pdf = march_free_flight(m, odds, u, &s);
    if (pdf > 0.0) {
        double sigma_t[3], sigma_s[3], kept[3], P[3], scattered[3];
        Phase phase;
        double g = march_true_at(m, s, sigma_t, sigma_s);
        march_transmittance(m, s, kept);
        for (int c = 0; c < 3; c++) P[c] = O[c] + s * D[c];
        phase_at(ds->media, inside, P, g, &phase);       /* (a heterogeneous medium: its phase function there) */
        FreeFlight flight = {O, D, t, s, pdf};
        rays += scattered_light(ds, limits, P, wo, &phase, inside, pixel, sample, dimension, bounce, &flight, -1,
                                scattered, NULL, groups != NULL ? point_groups : NULL, ao);
        double scale[3];
        for (int c = 0; c < 3; c++) { scale[c] = kept[c] * sigma_s[c] / pdf; L[c] = scale[c] * scattered[c]; }
        add_groups(groups, point_groups, ds->groups, scale);
    }
    /* 2. Each lamp with a position: a point by equi-angular sampling, lit by that lamp alone. */
    rays += equiangular_lamps(ds, limits, m, NULL, NULL, NULL, odds, 0, O, D, t, inside, pixel, sample, dimension,
                              bounce, L, groups);
    return rays;
}

static int64_t in_scattering(const DirectSettings *ds, const PathLimits *limits, const double *O, const double *D,
                             double t, const VolumeStack *inside, const double *throughput, int64_t pixel,
                             int64_t sample, int64_t dimension, int bounce, double *L, double *groups, int ao)
{
    const MediaTables *media = ds->media;
    double sigma_t[3], emission[3], sigma_s[3], g;
    Phase phase;
    L[0] = L[1] = L[2] = 0.0;
    if (groups != NULL)
        for (int64_t i = 0; i < 3 * ds->groups; i++) groups[i] = 0.0;
    medium_along(media, inside, sigma_t, emission);
    medium_scattering(media, inside, sigma_s, &g, &phase);
    if (media->fields != NULL && in_field(media, inside)) {     /* (a heterogeneous medium: on its march) */
        if (!stretch_scatters(media, inside, sigma_s)) return 0;
        March march;
        march_of(media, inside, O, D, t, sigma_t, sigma_s, emission, g, &march);
        return marched_scattering(ds, limits, &march, O, D, t, inside, throughput, pixel, sample, dimension, bounce,
                                  L, groups, ao);
    }
    if (!(sigma_s[0] > 0.0 || sigma_s[1] > 0.0 || sigma_s[2] > 0.0)) return 0;
    /* 1. Where the ray scatters (free flight), and its weight T(s) sigma_s / pdf(s). */
    double u[2], odds[3];
    sample_2d(stream_of((int64_t)ds->seed, DISTANCE_DIMENSION + dimension), pixel, sample, u);
    channel_odds(sigma_t, sigma_s, throughput, odds);
    int channel = (u[1] >= odds[0]) + (u[1] >= odds[0] + odds[1]) + (u[1] >= (odds[0] + odds[1]) + odds[2]);
    channel = channel > 2 ? 2 : channel;
    double sigma_c = sigma_t[channel] > 0.0 ? sigma_t[channel] : 1.0;
    double s = -log1p(-u[0] * -expm1(-sigma_c * t)) / sigma_c;
    double pdf = ((odds[0] + odds[1]) + odds[2]) > 0.0 ? distance_pdf(sigma_t, odds, t, s) : 0.0;
    if (!(pdf > 0.0)) return 0;
    double weight[3], kept[3], P[3], wo[3] = {-D[0], -D[1], -D[2]};
    beer_lambert(sigma_t, s, kept);
    for (int c = 0; c < 3; c++) { weight[c] = kept[c] * sigma_s[c] / pdf; P[c] = O[c] + s * D[c]; }
    /* 2. The light scattered there, each lamp's samples weighed against its equi-angular points (3.). */
    FreeFlight flight = {O, D, t, s, pdf};
    double scattered[3], point_groups[3 * MAX_LIGHT_GROUPS];
    int64_t rays = scattered_light(ds, limits, P, wo, &phase, inside, pixel, sample, dimension, bounce, &flight, -1,
                                   scattered, NULL, groups != NULL ? point_groups : NULL, ao);
    for (int c = 0; c < 3; c++) L[c] = weight[c] * scattered[c];
    add_groups(groups, point_groups, ds->groups, weight);
    /* 3. Each lamp with a position: a point by equi-angular sampling, lit by that lamp alone. */
    rays += equiangular_lamps(ds, limits, NULL, sigma_t, sigma_s, &phase, odds, 0, O, D, t, inside, pixel, sample,
                              dimension, bounce, L, groups);
    return rays;
}

/* Where a path that scatters goes on (volume.scatter_or_pass's onward rays): scattered 1 where it collided at P, its
 * weight T(s) sigma_s(s) / pdf(s) and its phase ray. */
typedef struct {
    int scattered;
    double P[3], weight[3];
    PhaseRay ray;
} Onward;

/* volume.scatter_or_pass for one ray O, D (3) over [0, t) in the media `inside` whose path goes on from where it
 * scatters, carrying `throughput` (3): untruncated free flight (a channel by throughput x albedo) decides whether it
 * collides in its media or goes on to its end. Into L (3) the light gathered at the collision (light samples and
 * the phase ray's finds, weighed by MIS) and at each lamp's equi-angular point, per unit throughput; into through
 * (3) what a path that goes on to the end carries on, T(t) / P(no collision), 0 where it collided; into next where
 * it collided and its phase ray. groups: (ds->groups, 3) L by group (zeroed here), or NULL. Returns the shadow
 * rays traced. */
static int64_t scatter_or_pass(const DirectSettings *ds, const PathLimits *limits, const double *O, const double *D,
                               double t, const VolumeStack *inside, const double *throughput, int64_t pixel,
                               int64_t sample, int64_t dimension, int bounce, double *L, double *through, Onward *next,
                               double *groups)
{
    const MediaTables *media = ds->media;
    double sigma_t[3], emission[3], sigma_s[3], g;
    Phase phase;
    L[0] = L[1] = L[2] = 0.0;
    if (groups != NULL)
        for (int64_t i = 0; i < 3 * ds->groups; i++) groups[i] = 0.0;
    next->scattered = 0;
    medium_along(media, inside, sigma_t, emission);
    medium_scattering(media, inside, sigma_s, &g, &phase);
    March march;
    double odds[3];
    int varying = media->fields != NULL && in_field(media, inside);
    if (varying) {                                  /* (a heterogeneous medium: its march, field.c) */
        march_of(media, inside, O, D, t, sigma_t, sigma_s, emission, g, &march);
        march_transmittance(&march, t, through);
        if (!stretch_scatters(media, inside, sigma_s)) return 0;
        double tau_t[3], tau_s[3];
        march_totals(&march, tau_t, tau_s);
        channel_odds(tau_t, tau_s, throughput, odds);
    } else {
        beer_lambert(sigma_t, t, through);
        if (!(sigma_s[0] > 0.0 || sigma_s[1] > 0.0 || sigma_s[2] > 0.0)) return 0;
        march_uniform(sigma_t, sigma_s, emission, g, t, &march);
        channel_odds(sigma_t, sigma_s, throughput, odds);
    }
    /* 1. Collide or pass: what a passing path carries on. */
    double u[2], s = 0.0, p_pass = 1.0;
    int passed = 0;
    sample_2d(stream_of((int64_t)ds->seed, DISTANCE_DIMENSION + dimension), pixel, sample, u);
    double pdf = march_collision(&march, odds, u, &s, &passed, &p_pass);
    int none = ((odds[0] + odds[1]) + odds[2]) <= 0.0;
    passed = passed || none || !(pdf > 0.0);
    p_pass = none ? 1.0 : p_pass;
    for (int c = 0; c < 3; c++) through[c] = passed ? through[c] / (p_pass > 0.0 ? p_pass : 1.0) : 0.0;
    /* 2. Each lamp with a position: a point by equi-angular sampling, lit by that lamp alone, weighed against the
     *    collisions by the balance heuristic. */
    int64_t rays = equiangular_lamps(ds, limits, &march, NULL, NULL, varying ? NULL : &phase, odds, 1, O, D, t, inside,
                                     pixel, sample, dimension, bounce, L, groups);
    if (passed) return rays;
    /* 3. The collision: the light scattered there, and the phase ray the path goes on along. */
    double at_t[3], at_s[3], kept[3], light[3], wo[3] = {-D[0], -D[1], -D[2]};
    double g_here = march_true_at(&march, s, at_t, at_s);
    Phase here = phase;
    march_transmittance(&march, s, kept);
    for (int c = 0; c < 3; c++) { next->weight[c] = kept[c] * at_s[c] / pdf; next->P[c] = O[c] + s * D[c]; }
    if (varying) phase_at(media, inside, next->P, g_here, &here);   /* (its phase function there) */
    FreeFlight flight = {O, D, t, s, pdf};
    double point_groups[3 * MAX_LIGHT_GROUPS];
    rays += scattered_light(ds, limits, next->P, wo, &here, inside, pixel, sample, dimension, bounce, &flight, -1,
                            light, &next->ray, groups != NULL ? point_groups : NULL, 0);
    for (int c = 0; c < 3; c++) L[c] += next->weight[c] * light[c];
    add_groups(groups, point_groups, ds->groups, next->weight);
    next->scattered = 1;
    return rays;
}

/* volume.multiple_scattering for one ray O, D (3) over [0, t) (inf: to the world) in the media `inside` whose path,
 * carrying `throughput` (3), has Volume Bounces left (limits->volume_bounces) after `bounce` bounces and `volume`
 * scattering events: it scatters or goes on (scatter_or_pass); where it scattered it goes on along its phase ray,
 * whose own stretch scatters or goes on again while it has bounces left, and otherwise gathers its single
 * scattering (in_scattering) and goes on to its hit. Adds to L (3) the light found, throughput included; into
 * through (3) what the path going on to the ray's own end carries on (0 where it scattered); where a scattered path
 * reached a surface, *arrived 1 and its arrival (its throughput, ray, bounces and media; the caller fills the rest).
 * dimension: the stretch's shift of sampling dimensions, each later event CHAIN_SHIFT more. later: where the light
 * found at the events after the stretch's own goes instead of L (3, added to; the light passes'
 * multiple_scattering events), or NULL: L. groups: (ds->groups, 3) all the light found (L's and later's) by group,
 * added to, or NULL. transmission, glossy: the path's bounces of those kinds (Fast GI's count: where a stretch's
 * event would send Fast GI's phase ray, the path ends there, volume.volume_bounces_left). Returns the shadow rays
 * traced. */
NOINLINE static int64_t volume_chain(const DirectSettings *ds, const PathLimits *limits, const double *O,
                                     const double *D, double t, const VolumeStack *inside, const double *throughput,
                                     int64_t pixel, int64_t sample, int64_t dimension, int bounce, int volume,
                                     int transmission, int glossy, double *L, double *later, double *through,
                                     Arrival *arrival, int *arrived, double *groups)
{
    double *after_L = later != NULL ? later : L;
    double light[3], carried[3] = {throughput[0], throughput[1], throughput[2]};
    double step_groups[3 * MAX_LIGHT_GROUPS], *found_groups = groups != NULL ? step_groups : NULL;
    Onward onward, after;
    *arrived = 0;
    int64_t rays = scatter_or_pass(ds, limits, O, D, t, inside, throughput, pixel, sample, dimension, bounce, light,
                                   through, &onward, found_groups);
    for (int c = 0; c < 3; c++) L[c] += throughput[c] * light[c];
    add_groups(groups, found_groups, ds->groups, throughput);
    for (int64_t step = 1; onward.scattered; step++) {
        for (int c = 0; c < 3; c++) carried[c] *= onward.weight[c];
        bounce++;
        volume++;
        const double *P = onward.P, *wi = onward.ray.wi;
        double reach = onward.ray.hit ? onward.ray.t : INFINITY, carry[3];
        int64_t dim = dimension + step * CHAIN_SHIFT;
        after.scattered = 0;
        int short_phase = fast_gi_scatter(ds, bounce, transmission, glossy);
        if (!(volume < limits->volume_bounces && bounce + 1 <= limits->max_bounces) || short_phase) {
            /* a. The path ends at its next scattering event: its single scattering, and on to the hit with T. */
            double found[3], sigma_t[3], emission[3], kept[3];
            rays += in_scattering(ds, limits, P, wi, reach, inside, carried, pixel, sample, dim, bounce, found,
                                  found_groups, short_phase);
            for (int c = 0; c < 3; c++) after_L[c] += carried[c] * found[c];
            add_groups(groups, found_groups, ds->groups, carried);
            medium_along(ds->media, inside, sigma_t, emission);
            March march;
            stretch_transmittance(stretch_march(ds->media, inside, P, wi, reach, sigma_t, emission, &march), sigma_t,
                                  reach, kept);
            for (int c = 0; c < 3; c++) carry[c] = carried[c] * kept[c];
        } else {
            /* b. It scatters again or goes on. */
            double passing[3];
            rays += scatter_or_pass(ds, limits, P, wi, reach, inside, carried, pixel, sample, dim, bounce, light,
                                    passing, &after, found_groups);
            for (int c = 0; c < 3; c++) { after_L[c] += carried[c] * light[c]; carry[c] = carried[c] * passing[c]; }
            add_groups(groups, found_groups, ds->groups, carried);
        }
        /* c. A path that reaches a surface arrives there, the next vertex of its path. */
        if (onward.ray.hit && (carry[0] != 0.0 || carry[1] != 0.0 || carry[2] != 0.0)) {
            *arrived = 1;
            for (int c = 0; c < 3; c++) { arrival->throughput[c] = carry[c]; arrival->O[c] = P[c]; }
            arrival->ray = onward.ray;
            arrival->bounce = bounce;
            arrival->volume = volume;
            arrival->inside = *inside;
        }
        onward = after;
    }
    return rays;
}

/* path.py's scattering on a vertex block's BSDF rays (rays of H): each ray the path may still bounce on (within its
 * bounce limits, past Russian roulette, hit or not) adds its media's light, seen through the path's throughput x
 * the ray's weight / q, to its camera lane's light in work->extra: with Volume Bounces left its chain
 * (volume_chain: the ray's attenuation becomes what a path passing to its hit carries on, and a ray whose path
 * scattered hits nothing more; paths that scattered and reached a surface go to work->arrivals), else its single
 * scattering. Returns the shadow rays traced. */
static int64_t bounce_scattering(const BlockHits *H, PathRays *rays, int vertex, const PathLimits *limits,
                                 const DirectSettings *ds, PathWork *work)
{
    uint32_t roulette = stream_of((int64_t)ds->seed, ROULETTE_DIMENSION + (int64_t)(vertex + 1) * VERTEX_DIMENSIONS);
    int64_t shadow_rays = 0;
    double *groups = ds->groups > 0 ? work->groups : NULL;   /* (each camera lane's light groups, as work->extra) */
    double found_groups[3 * MAX_LIGHT_GROUPS];
    for (int64_t i = 0; i < rays->n; i++) {
        PathRay *r = rays->r + i;
        int64_t h = r->h;
        if (r->walked) continue;    /* (a walk's exit ray is no ray through the media: the exit is shaded at once) */
        /* a. The bounce limits, as next_vertices counts them. */
        int see_through = is_transparent_bounce(r->kind);
        int boundary = see_through && is_boundary(ds->media, H->s[h].material);
        int clear = r->path.transparent - boundary, bounces = r->path.bounce;
        if (clear > limits->transparent_bounces || bounces > limits->max_bounces
            || r->path.diffuse > limits->diffuse_bounces || r->path.glossy > limits->glossy_bounces
            || r->path.transmission > limits->transmission_bounces)
            continue;
        /* b. Russian roulette, from the throughput before the media. */
        double carried[3], q = 1.0;
        for (int c = 0; c < 3; c++) carried[c] = H->throughput[3 * h + c] * r->weight[c];
        if (bounces >= limits->roulette_from && !see_through && !r->walked) {     /* (a walk plays none) */
            double largest = at_least(fabs(carried[0]), at_least(fabs(carried[1]), fabs(carried[2]))), u[2];
            q = survival(largest);
            sample_2d(roulette, H->pixel[h], H->sample[h], u);
            if (!(u[0] < q)) continue;
        }
        for (int c = 0; c < 3; c++) carried[c] = carried[c] / q;
        if (ds->features && H->looking[h])     /* (the media along it, where its path still looks: features.in_media) */
            features_along(work->features[H->lane[h]], work->reach + H->lane[h], H->feature_tp + 3 * h, carried,
                           ds->media, &r->inside, r->O, r->D, r->hit ? r->t : INFINITY, ds->back);
        /* (Fast GI's short ray: its media only absorb and emit, Cycles' PATH_RAY_TERMINATE_AFTER_VOLUME; path.py) */
        if (r->ao) continue;
        /* c. The light its media scatter towards it; for the light passes, by the stretch's shares (lightpasses.c
         *    stretch_shares: a path's shares are those of its first real bounce's ray, as next_vertices keeps them). */
        double L[3] = {0.0, 0.0, 0.0}, shares[PASS_KINDS][3] = {{0.0}};    /* (read only with the light passes) */
        if (ds->light_passes)
            stretch_shares(bounces, H->bounce[h] == 0 && !see_through ? &r->shares[0][0] : &H->shares[h][0][0],
                           shares);
        int64_t dimension = (int64_t)(vertex + 1) * VERTEX_DIMENSIONS;
        if (H->volume[h] < limits->volume_bounces && bounces + 1 <= limits->max_bounces
            && !fast_gi_scatter(ds, bounces, r->path.transmission, r->path.glossy)) {
            double through[3];
            int arrived = 0;
            Arrival *a = work->arrivals + work->n_arrivals;
            double later[3] = {0.0, 0.0, 0.0};
            double one[3] = {1.0, 1.0, 1.0};
            if (groups != NULL)                      /* (volume_chain adds to them) */
                for (int64_t i = 0; i < 3 * ds->groups; i++) found_groups[i] = 0.0;
            shadow_rays += volume_chain(ds, limits, r->O, r->D, r->hit ? r->t : INFINITY, &r->inside, carried,
                                        H->pixel[h], H->sample[h], dimension, bounces, H->volume[h],
                                        r->path.transmission, r->path.glossy, L, later, through, a, &arrived,
                                        groups != NULL ? found_groups : NULL);
            if (groups != NULL)                      /* (its light groups: the chain's, throughput included) */
                add_groups(groups + 3 * ds->groups * H->lane[h], found_groups, ds->groups, one);
            for (int c = 0; c < 3; c++) work->extra[H->lane[h]][c] += L[c] + later[c];
            if (ds->light_passes) {
                add_scattered(work->light[H->lane[h]], L, bounces, shares, 1);
                add_scattered(work->light[H->lane[h]], later, bounces, shares, 0);
                if (arrived)
                    for (int p = 0; p < PASS_KINDS; p++)
                        for (int c = 0; c < 3; c++) a->shares[p][c] = shares[p][c];
            }
            for (int c = 0; c < 3; c++) r->attenuation[c] = through[c];
            if (!(through[0] != 0.0 || through[1] != 0.0 || through[2] != 0.0)) r->hit = 0;
            if (arrived) {
                /* (its smallest pdf: its bounce's and its phase ray's, Cycles' min_ray_pdf) */
                double before = see_through || !(r->pdf < H->min_pdf[h]) ? H->min_pdf[h] : r->pdf;
                a->min_pdf = a->ray.pdf < before ? a->ray.pdf : before;
                a->lane = H->lane[h];
                a->pixel = H->pixel[h];
                a->sample = H->sample[h];
                a->diffuse = r->path.diffuse;
                a->glossy = r->path.glossy;
                a->transmission = r->path.transmission;
                a->transparent = clear;
                a->portal = r->path.portal;
                a->bounds = H->bounds[h] + boundary;
                arrival_cone(a, r->path.cone, r->path.spread);
                work->n_arrivals++;
            }
            continue;
        }
        shadow_rays += in_scattering(ds, limits, r->O, r->D, r->hit ? r->t : INFINITY, &r->inside, carried,
                                     H->pixel[h], H->sample[h], dimension, bounces, L,
                                     groups != NULL ? found_groups : NULL,
                                     fast_gi_scatter(ds, bounces, r->path.transmission, r->path.glossy));
        for (int c = 0; c < 3; c++) {
            L[c] *= carried[c];
            work->extra[H->lane[h]][c] += L[c];
        }
        if (groups != NULL)                          /* (its light groups, through the same weight) */
            add_groups(groups + 3 * ds->groups * H->lane[h], found_groups, ds->groups, carried);
        if (ds->light_passes) add_scattered(work->light[H->lane[h]], L, bounces, shares, 1);
    }
    return shadow_rays;
}
