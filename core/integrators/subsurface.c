/* The subsurface random walk: core/integrators/subsurface.py for one path, inside the mesh a BSSRDF closure's ray
 * entered (Cycles' Random Walk and Random Walk (Skin); Chiang, Kutz and Burley 2016). A homogeneous medium per colour
 * channel whose single-scattering albedo makes a half-space reflect the surface colour; steps of free flight in a
 * channel chosen by the path's weight, directions from Henyey-Greenstein or Dwivedi's guiding, weighed by the
 * balance heuristic over channels and strategies; the exit is the first step whose ray meets the same object's
 * surface (shader_rays.c local_hits). The same sampling dimensions as the Python, so the kernels agree to rounding.
 * direct.c bsdf_rays calls it where a sampled closure is a BSSRDF; path.c lights the exit as a white Lambert.
 * Christensen-Burley's closures (SUBSURFACE_DISK) take subsurface_disk instead: Cycles' disk projection, a chord
 * probed through a disk about the entry (subsurface.disk), and after a diffuse bounce are Lambert closures
 * (burley_as_diffuse). A walk's exit takes the media across from its entry (walk_media, subsurface.media_across). */

/* MAX_STEPS, SIMILARITY_STEPS, MIN_ALPHA, OWN_HITS and THROUGHPUT_EPSILON are subsurface.py's (SUBSURFACE_DIMENSION:
 * boundary.gen.h). */
#define WALK_MAX_STEPS 256
#define WALK_SIMILARITY_STEPS 9
#define WALK_MIN_ALPHA 0.2
#define WALK_OWN_HITS 4
#define WALK_THROUGHPUT_EPSILON 1e-6
#define DISK_MAX_HITS 4         /* subsurface.DISK_MAX_HITS (Cycles' BSSRDF_MAX_HITS) */
#define BURLEY_TRUNCATE 16.0    /* materials/subsurface.py BURLEY_TRUNCATE, BURLEY_TRUNCATE_CDF */
#define BURLEY_TRUNCATE_CDF 0.9963790093708328

/* Where a walk left the mesh (subsurface.walk's returns for one path). */
typedef struct {
    int exits;                  /* 1: it met the object's surface; 0: it ran out of steps or weight */
    int64_t geometry, prim, instance;
    double u, v;                /* the exit's triangle and barycentrics */
    double P[3], D[3], t;       /* the exit, the last step's direction and length */
    double weight[3];           /* the path's weight after the walk (0 where it found no exit) */
} WalkExit;

/* subsurface.remap's polynomial in g of degree 7 with coefficients c. */
INLINE double walk_fit(const double *c, double g)
{
    double sum = 0.0, power = 1.0;
    for (int i = 0; i < 8; i++) { sum += c[i] * power; power *= g; }
    return sum;
}

/* subsurface.remap for one channel: the single-scattering albedo whose walk reflects `albedo` with anisotropy g. */
static double walk_remap(double albedo, double g)
{
    static const double a[8] = {1.8260523782, -1.28451056436, -1.79904629312, 9.19393289202, -22.8215585862,
                                32.0234874259, -23.6264803333, 7.21067002658};
    static const double b[8] = {0.0, 31.1491581433, -201.847017512, 841.576016723, -2018.09288505, 2731.71560286,
                                -1935.41424244, 559.009054474};
    static const double c[8] = {1.09686102424, -0.394704063468, 1.05258115941, -8.83963712726, 28.8643230661,
                                -46.8802913581, 38.5402837518, -12.7181042538};
    static const double d[8] = {0.496310210422, 0.360146581622, -2.15139309747, 17.8896899217, -55.2984010333,
                                82.065982243, -58.5106008578, 15.8478295021};
    static const double e[8] = {0.0, 76.7316253952, -594.356773233, 2448.8834203, -5576.68528998, 7116.60171912,
                                -4763.54467887, 1303.5318055};
    static const double f[8] = {2.40602999408, -2.51814844609, 9.18494908356, -79.2191708682, 259.082868209,
                                -403.613804597, 302.85712436, -87.4370473567};
    double A = walk_fit(a, g), B = 4.98511194385 + 0.127355959438 * exp(walk_fit(b, g)), C = walk_fit(c, g);
    double D = walk_fit(d, g), E = 4.23190299701 + 0.00310603949088 * exp(walk_fit(e, g)), F = walk_fit(f, g);
    double blend = pow(albedo, 0.25);
    double alpha = (1.0 - blend) * A * pow(atan(B * albedo), C) + blend * D * pow(atan(E * albedo), F);
    return alpha < 0.0 ? 0.0 : (alpha > 0.999999 ? 0.999999 : alpha);
}

/* subsurface.flight_pdf for one channel: exp(-sigma t), times sigma unless the flight `exits`. */
INLINE double walk_flight_pdf(double sigma, double t, int exits)
{
    double T = exp(-sigma * t);
    return exits ? T : sigma * T;
}

/* subsurface.walk for one path: from the hit s (on geometry, prim, instance) into the mesh along D with the BSSRDF
 * closure c (its parameters and normal), `weight` (3) the closure's weight into the walk and `carried` (3) what the
 * path carried to the hit (both choose the colour channels); the keys pixel, sample and the vertex's `dimension`.
 * Fills out; returns the rays traced. */
NOINLINE static int64_t subsurface_walk(const ShaderRays *rays, const Surface *s, int64_t geometry, int64_t prim,
                                        int64_t instance, const Closure *c, const double *D, const double *weight,
                                        const double *carried, int64_t pixel, int64_t sample, int64_t dimension,
                                        WalkExit *out)
{
    const double *N = c->N, *P0 = s->I;
    int64_t owner = owner_of(rays->geometry, geometry, prim, instance), traced = 0;
    double g0 = c->p[SUBSURFACE_ANISOTROPY];
    /* 1. The medium's coefficients per channel, and Dwivedi's guiding terms from the largest alpha. */
    double sigma_t0[3], sigma_s0[3], alpha[3], tp[3], sigma_t_star[3], sigma_s_star[3];
    for (int j = 0; j < 3; j++) {
        double albedo = c->p[SUBSURFACE_ALBEDO + j];
        alpha[j] = walk_remap(albedo, g0);
        sigma_t0[j] = 1.0 / at_least(c->p[SUBSURFACE_RADIUS + j], 1e-16) / (1.0 - g0);
        tp[j] = albedo != 0.0 ? weight[j] / albedo : 0.0;
        if (alpha[j] < WALK_MIN_ALPHA) { tp[j] = tp[j] * alpha[j] / WALK_MIN_ALPHA; alpha[j] = WALK_MIN_ALPHA; }
        sigma_s0[j] = sigma_t0[j] * alpha[j];
        sigma_s_star[j] = sigma_s0[j] * (1.0 - g0);
        sigma_t_star[j] = sigma_t0[j] - sigma_s0[j] + sigma_s_star[j];
    }
    double top = at_least(alpha[0], at_least(alpha[1], alpha[2]));
    double length = 1.0 / sqrt(1.0 - pow(top, 2.44294 - 0.0215813 * top + 0.578637 / top));
    double phase_log = log((length + 1.0) / at_least(length - 1.0, 1e-300));
    double guided0 = 1.0 - at_least(0.5, pow(fabs(g0), 0.125));
    double P[3] = {P0[0], P0[1], P0[2]}, Dw[3] = {D[0], D[1], D[2]}, T0[3], B0[3];
    orthonormal_frame(N, T0, B0);
    int opposite = 0;
    double opposite_distance = 0.0;
    out->exits = 0;
    out->geometry = out->prim = out->instance = 0;
    out->u = out->v = out->t = 0.0;
    int alive = isfinite(length) && length > 1.0;
    for (int step = 0; step < WALK_MAX_STEPS && alive; step++) {
        /* 2a. This step's coefficients (isotropic with the similarity relation after SIMILARITY_STEPS). */
        int late = step > WALK_SIMILARITY_STEPS;
        const double *sigma_t = late ? sigma_t_star : sigma_t0, *sigma_s = late ? sigma_s_star : sigma_s0;
        double g = late ? 0.0 : g0, guided_fraction = late ? 0.75 : guided0;
        int64_t dim = dimension + SUBSURFACE_DIMENSION + 3 * (int64_t)step;
        double r0[2], r1[2], r2[2];
        sample_2d(stream_of((int64_t)rays->seed, dim), pixel, sample, r0);
        sample_2d(stream_of((int64_t)rays->seed, dim + 1), pixel, sample, r1);
        sample_2d(stream_of((int64_t)rays->seed, dim + 2), pixel, sample, r2);
        /* 2b. The channel, in proportion to weight x alpha (uniform where that is all 0). */
        double w[3], channel_pdf[3];
        for (int j = 0; j < 3; j++) w[j] = fabs(tp[j] * alpha[j] * carried[j]);
        double total = w[0] + w[1] + w[2];
        for (int j = 0; j < 3; j++) channel_pdf[j] = total > 0.0 ? w[j] / total : 1.0 / 3.0;
        double running = 0.0;
        int channel = 0;
        for (int j = 0; j < 3; j++) { running += channel_pdf[j]; channel += running <= r0[0]; }
        channel = channel < 2 ? channel : 2;
        double sample_sigma = sigma_t[channel];
        double forward_factor = 0.0, backward_factor = 0.0, forward_stretch = 1.0, backward_stretch = 1.0;
        double backward_fraction = 0.0;
        if (step > 0) {
            /* 2c. The direction: guided (Dwivedi, forward or backward) or from the phase function. */
            int guided = r1[0] < guided_fraction;
            double d = length, across[3];
            for (int j = 0; j < 3; j++) across[j] = P[j] - P0[j];
            double x = -dot3(across, N);
            x = at_most(at_least(x, 0.0), opposite_distance);
            if (opposite) backward_fraction = 1.0 / (1.0 + exp((opposite_distance - 2.0 * x) / d));
            int backward = opposite && r1[1] < backward_fraction;
            double cos_guided = d - (d + 1.0) * exp(-r2[0] * phase_log);
            if (backward) cos_guided = -cos_guided;
            double sin_guided = sqrt(at_least(1.0 - cos_guided * cos_guided, 0.0)), cos_phi, sin_phi;
            cos_sin(2.0 * PI * r2[1], &cos_phi, &sin_phi);
            double guided_D[3], phase_D[3], wo[3] = {-Dw[0], -Dw[1], -Dw[2]};
            for (int j = 0; j < 3; j++)
                guided_D[j] = ((sin_guided * cos_phi) * T0[j] + (sin_guided * sin_phi) * B0[j]) + cos_guided * N[j];
            double phase_pdf = sample_henyey_greenstein(wo, g, r2, phase_D);
            double hg_pdf = guided ? henyey_greenstein(dot3(Dw, guided_D), g) : phase_pdf;
            double cos_theta = guided ? cos_guided : dot3(phase_D, N);
            for (int j = 0; j < 3; j++) Dw[j] = guided ? guided_D[j] : phase_D[j];
            forward_factor = (1.0 / (2.0 * PI)) / ((d - cos_theta) * phase_log) / hg_pdf;
            backward_factor = (1.0 / (2.0 * PI)) / ((d + cos_theta) * phase_log) / hg_pdf;
            forward_stretch = 1.0 - cos_theta / d;
            backward_stretch = 1.0 + cos_theta / d;
            if (guided) sample_sigma *= backward ? backward_stretch : forward_stretch;
        }
        /* 2d. The distance, and a local ray cast as far (the first step: at least 10 mean free paths, to find an
         *     opposite side for the backward guiding; from the entry itself, its own triangle left out). */
        double t = -log(1.0 - r0[1]) / sample_sigma, reach = t;
        if (step == 0) reach = at_least(t, 10.0 / at_most(sigma_t[0], at_most(sigma_t[1], sigma_t[2])));
        int64_t hg[WALK_OWN_HITS], hp[WALK_OWN_HITS], hi[WALK_OWN_HITS];
        double hu[WALK_OWN_HITS], hv[WALK_OWN_HITS], ht[WALK_OWN_HITS];
        int most = step == 0 ? WALK_OWN_HITS : 1;
        int64_t count = local_hits(rays, P, Dw, reach, s->time, owner, most, hg, hp, hi, hu, hv, ht);
        traced++;
        int slot = count > 0 ? 0 : -1;
        if (step == 0) {                        /* (subsurface.first_other: the nearest on another triangle) */
            slot = -1;
            for (int k = 0; k < most && k < count && slot < 0; k++)
                if (!(hg[k] == geometry && hp[k] == prim && hi[k] == instance)) slot = k;
        }
        int met = slot >= 0;
        double t_hit = met ? ht[slot] : INFINITY;
        if (step == 0) {
            opposite = met;
            if (met) {
                double far[3];
                for (int j = 0; j < 3; j++) far[j] = (P[j] + t_hit * Dw[j]) - P0[j];
                opposite_distance = -dot3(far, N);
            }
        }
        int leaves = met && t_hit < t;
        if (leaves) t = t_hit;
        for (int j = 0; j < 3; j++) P[j] = P[j] + t * Dw[j];
        /* 2e. The weight: each channel's flight over the mixture of channels and strategies. */
        double denominator = 0.0, gain[3];
        for (int j = 0; j < 3; j++) {
            double pdf = walk_flight_pdf(sigma_t[j], t, leaves);
            if (step > 0) {
                double ahead = walk_flight_pdf(forward_stretch * sigma_t[j], t, leaves) * forward_factor;
                if (opposite) {
                    double back = walk_flight_pdf(backward_stretch * sigma_t[j], t, leaves) * backward_factor;
                    ahead = ahead * (1.0 - backward_fraction) + back * backward_fraction;
                }
                pdf = pdf * (1.0 - guided_fraction) + ahead * guided_fraction;
            }
            denominator += channel_pdf[j] * pdf;
            double T = exp(-sigma_t[j] * t);
            gain[j] = leaves ? T : sigma_s[j] * T;
        }
        for (int j = 0; j < 3; j++) tp[j] *= denominator > 0.0 ? gain[j] / denominator : 0.0;
        /* 2f. A walk that left: its exit; one too faint: the end. */
        out->t = t;
        if (leaves) {
            out->exits = 1;
            out->geometry = hg[slot]; out->prim = hp[slot]; out->instance = hi[slot];
            out->u = hu[slot]; out->v = hv[slot];
            break;
        }
        double largest = at_least(fabs(tp[0]), at_least(fabs(tp[1]), fabs(tp[2])));
        alive = !(largest < WALK_THROUGHPUT_EPSILON) && isfinite(tp[0]) && isfinite(tp[1]) && isfinite(tp[2]);
    }
    for (int j = 0; j < 3; j++) {
        out->P[j] = P[j];
        out->D[j] = Dw[j];
        out->weight[j] = out->exits ? tp[j] : 0.0;
    }
    return traced;
}

/* materials/subsurface.burley_pdf for one channel: the truncated profile of d as a density in the distance r (0 at
 * r = 0, from 16 d on, and where d is 0). */
INLINE double burley_pdf(double d, double r)
{
    if (!(d > 0.0) || r == 0.0 || !(r < BURLEY_TRUNCATE * d)) return 0.0;
    double e3 = exp(-r / (3.0 * d));
    return (e3 * e3 * e3 + e3) / (4.0 * d) / BURLEY_TRUNCATE_CDF;
}

/* materials/subsurface.burley_root: the distance (in units of d) where the profile's cumulative reaches xi. */
INLINE double burley_root(double xi)
{
    double x = xi <= 0.9 ? exp(xi * xi * 2.4) - 1.0 : 15.0;
    for (int i = 0; i < 10; i++) {
        double e3 = exp(-x / 3.0), e = e3 * e3 * e3;
        double f = 1.0 - 0.25 * e - 0.75 * e3 - xi, slope = 0.25 * e + 0.25 * e3;
        if (!(fabs(f) >= 1e-6) || slope == 0.0) break;
        x = at_least(x - f / slope, 0.0);
    }
    return x;
}

/* subsurface.disk for one path (Cycles' subsurface_disk): from the hit s (on geometry, prim, instance) with the
 * Christensen-Burley closure c (radius: d per channel), `weight` (3) the closure's weight, the keys pixel, sample and
 * the vertex's `dimension`: the exit (out->P the exit point, out->D its outward face normal on the side the entry
 * was seen from, out->t the probe's distance to it) and the weight after it. Returns the rays traced (1). */
NOINLINE static int64_t subsurface_disk(const ShaderRays *rays, const Surface *s, int64_t geometry, int64_t prim,
                                        int64_t instance, const Closure *c, const double *weight, int64_t pixel,
                                        int64_t sample, int64_t dimension, WalkExit *out)
{
    const double *P0 = s->I, *Ng = s->Ng, *radius = c->p + SUBSURFACE_RADIUS;
    int64_t owner = owner_of(rays->geometry, geometry, prim, instance);
    double u[2], u2[2], T0[3], B0[3];
    sample_2d(stream_of((int64_t)rays->seed, dimension + SUBSURFACE_DIMENSION), pixel, sample, u);
    sample_2d(stream_of((int64_t)rays->seed, dimension + SUBSURFACE_DIMENSION + 1), pixel, sample, u2);
    out->exits = 0;
    out->geometry = out->prim = out->instance = 0;
    out->u = out->v = out->t = 0.0;
    for (int j = 0; j < 3; j++) out->P[j] = out->D[j] = out->weight[j] = 0.0;
    /* 1. The plane: across Ng (1/2), across T or across B (1/4 each). */
    orthonormals(Ng, T0, B0);
    int axis = u[1] < 0.5 ? 0 : (u[1] < 0.75 ? 1 : 2);
    double y = axis == 0 ? 2.0 * u[1] : (axis == 1 ? (u[1] - 0.5) * 4.0 : (u[1] - 0.75) * 4.0);
    const double *disk_N = axis == 0 ? Ng : (axis == 1 ? T0 : B0);
    const double *disk_T = axis == 1 ? Ng : T0, *disk_B = axis == 2 ? Ng : B0;
    double pick[3] = {axis == 0 ? 0.5 : 0.25, axis == 1 ? 0.5 : 0.25, axis == 2 ? 0.5 : 0.25};
    /* 2. The distance on the disk (materials/subsurface.burley_sample) and the chord through it. */
    int channels = 0;
    for (int j = 0; j < 3; j++) channels += radius[j] > 0.0;
    double x = u[0] * (double)channels, d = 0.0;
    double rank = floor(x) < (double)(channels - 1) ? floor(x) : (double)(channels - 1);
    rank = rank > 0.0 ? rank : 0.0;
    for (int j = 0, seen = 0; j < 3; j++)
        if (radius[j] > 0.0) { if ((double)seen == rank) d = radius[j]; seen++; }
    double r = burley_root((x - rank) * BURLEY_TRUNCATE_CDF) * d, Rm = BURLEY_TRUNCATE * d;
    double h = sqrt(at_least(Rm * Rm - r * r, 0.0)), phi = 2.0 * PI * y, cx = r * cos(phi), cy = r * sin(phi);
    double O[3], D[3];
    for (int j = 0; j < 3; j++) {
        O[j] = ((P0[j] + disk_N[j] * h) + cx * disk_T[j]) + cy * disk_B[j];
        D[j] = -disk_N[j];
    }
    int64_t hg[LOCAL_STEPS], hp[LOCAL_STEPS], hi[LOCAL_STEPS];
    double hu[LOCAL_STEPS], hv[LOCAL_STEPS], ht[LOCAL_STEPS];
    int64_t count = local_hits(rays, O, D, 2.0 * h, s->time, owner, LOCAL_STEPS, hg, hp, hi, hu, hv, ht);
    /* 3. The surfaces weighed: DISK_MAX_HITS consecutive ones from a random start where there are more. */
    int64_t n = count < LOCAL_STEPS ? count : LOCAL_STEPS, used = n < DISK_MAX_HITS ? n : DISK_MAX_HITS, start = 0;
    double scale = 1.0;
    if (n > DISK_MAX_HITS) {
        double first = floor(u2[1] * (double)n);
        start = (int64_t)(first < (double)(n - 1) ? first : (double)(n - 1));
        scale = (double)n / DISK_MAX_HITS;
    }
    double pdf = 0.0, back = s->backfacing ? -1.0 : 1.0;
    for (int j = 0; j < 3; j++) pdf += burley_pdf(radius[j], r);
    pdf /= (double)(channels > 1 ? channels : 1);
    double weights[DISK_MAX_HITS][3], normal[DISK_MAX_HITS][3], mean[DISK_MAX_HITS];
    int64_t slot_of[DISK_MAX_HITS];
    for (int i = 0; i < DISK_MAX_HITS; i++) {
        slot_of[i] = 0;
        mean[i] = 0.0;
        for (int j = 0; j < 3; j++) weights[i][j] = normal[i][j] = 0.0;
        if (i >= used) continue;
        int64_t k = (start + i) % n;
        slot_of[i] = k;
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(rays->geometry, hg[k], hp[k], hi[k], 0, s->time, &tri);
        for (int j = 0; j < 3; j++) normal[i][j] = tri.Ng[j] * back;
        double pN = pick[0] * fabs(dot3(disk_N, normal[i])), pT = pick[1] * fabs(dot3(disk_T, normal[i]));
        double pB = pick[2] * fabs(dot3(disk_B, normal[i]));
        double w = pN > 0.0 ? pN / at_least((pN * pN + pT * pT) + pB * pB, 1e-300) : 0.0;
        w = w * scale;
        double gap[3];
        for (int j = 0; j < 3; j++) gap[j] = (O[j] - disk_N[j] * ht[k]) - P0[j];
        double distance = sqrt(dot3(gap, gap));
        for (int j = 0; j < 3; j++) weights[i][j] = (pdf > 0.0 ? burley_pdf(radius[j], distance) / pdf : 0.0) * w;
        mean[i] = (fabs(weights[i][0]) + fabs(weights[i][1]) + fabs(weights[i][2])) / 3.0;
    }
    /* 4. One surface in proportion to its mean weight; the path keeps the sum. */
    double total = 0.0;
    for (int i = 0; i < DISK_MAX_HITS; i++) total += mean[i];
    double target = u2[0] * total, partial = 0.0;
    int chosen = 0;
    for (int i = 0; i < DISK_MAX_HITS; i++) { partial += mean[i]; chosen += partial <= target; }
    chosen = chosen < DISK_MAX_HITS - 1 ? chosen : DISK_MAX_HITS - 1;
    if (!(total > 0.0) || !(mean[chosen] > 0.0)) return 1;
    int64_t k = slot_of[chosen];
    double share = total / mean[chosen];
    out->exits = 1;
    out->geometry = hg[k]; out->prim = hp[k]; out->instance = hi[k];
    out->u = hu[k]; out->v = hv[k];
    out->t = at_least(ht[k], 1e-6);
    for (int j = 0; j < 3; j++) {
        out->P[j] = O[j] - disk_N[j] * ht[k];
        out->D[j] = normal[chosen][j];
        out->weight[j] = (weight[j] * weights[chosen][j]) * share;
    }
    return 1;
}

/* subsurface.burley_as_diffuse for one hit a path reached after some diffuse bounce: its Christensen-Burley closures
 * become Lambert ones of their weight, sampling weight their mean weight (Cycles' PATH_RAY_DIFFUSE_ANCESTOR). */
INLINE void burley_as_diffuse(ShaderResult *sd)
{
    for (int k = 0; k < sd->n; k++) {
        Closure *c = sd->c + k;
        if (!bsdf_is(c->kind, BSDF_FLAG_SUBSURFACE) || c->p == NULL || c->p[SUBSURFACE_DISK] == 0.0) continue;
        c->kind = BSDF_LAMBERT;
        c->sample_weight = fabs((c->weight[0] + c->weight[1] + c->weight[2]) / 3.0);
    }
}

/* subsurface.exit_normal for one exit's shader sd: its shading normal, or where a BSSRDF closure there has a linked
 * Normal (BUMP), the BSSRDF closures' normals weighed by their mean weight, normalised; into N (3). */
INLINE void walk_exit_normal(const ShaderResult *sd, double *N)
{
    double total[3] = {0.0, 0.0, 0.0};
    int bumped = 0;
    for (int j = 0; j < 3; j++) N[j] = sd->N[j];
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = sd->c + k;
        if (!bsdf_is(c->kind, BSDF_FLAG_SUBSURFACE)) continue;
        bumped |= c->p != NULL && c->p[SUBSURFACE_BUMP] != 0.0;
        double w = fabs((c->weight[0] + c->weight[1] + c->weight[2]) / 3.0);
        for (int j = 0; j < 3; j++) total[j] += w * c->N[j];
    }
    double size = sqrt(dot3(total, total));
    if (bumped && size > 0.0)
        for (int j = 0; j < 3; j++) N[j] = total[j] / size;
}

/* subsurface.subsurface_shader for one exit: sd becomes one white Lambert closure on the exit normal, with no
 * emission, transparency or holdout (Cycles' subsurface_shader_data_setup); sd->N (the hit's own normal) stays. */
INLINE void walk_exit_shader(ShaderResult *sd)
{
    double N[3];
    walk_exit_normal(sd, N);
    for (int j = 0; j < 3; j++) sd->emission[j] = sd->transparency[j] = sd->holdout[j] = 0.0;
    sd->n = 0;
    sd->portal[0] = sd->portal[1] = sd->portal[2] = 0.0;
    if (sd->room < 1) return;
    Closure *c = sd->c;
    c->kind = BSDF_LAMBERT;
    c->sample_weight = 1.0;
    c->p = NULL;
    for (int j = 0; j < 3; j++) { c->weight[j] = 1.0; c->N[j] = N[j]; }
    sd->n = 1;
}

/* subsurface.media_across for one walk that entered the object `owner` at P0 and left it at P1 (3 each): its stack
 * updated by every surface of another object with a medium on the segment from P0 to P1, entered through a front
 * face and left through a back face as the segment meets them (stack_cross; Cycles'
 * integrator_volume_stack_update_for_subsurface), passing CAMERA_MEDIA_HITS surfaces at most. */
static void walk_media(const MediaTables *media, const GeometryTables *geometry, Intersect8 intersect, void *scene,
                       const double *P0, const double *P1, int64_t owner, VolumeStack *stack)
{
    if (media->count == 0) return;                  /* (the world's medium alone: no mesh to go into or out of) */
    double gap[3], D[3], P[3];
    for (int c = 0; c < 3; c++) gap[c] = P1[c] - P0[c];
    double length = sqrt(dot3(gap, gap));
    if (!(length > 0.0)) return;
    for (int c = 0; c < 3; c++) { D[c] = gap[c] / length; P[c] = P0[c]; }
    for (int step = 0; step < CAMERA_MEDIA_HITS; step++) {
        /* a. The next surface along the segment, short of its end. */
        double from[3];
        for (int c = 0; c < 3; c++) from[c] = P[c] - P0[c];
        double reach = length - dot3(from, D);
        if (!(reach > 0.0)) return;
        RayHitPacket packet;
        int valid[PACKET] ALIGNED(32);
        set_lane(&packet.ray, 0, P, D, reach);
        close_packet(&packet.ray, valid, 1);
        clear_hits(&packet);
        intersect(valid, scene, &packet, NULL);
        if (packet.hit.geomID[0] == INVALID_ID) return;
        int64_t g = (int64_t)packet.hit.geomID[0], prim = (int64_t)packet.hit.primID[0];
        int64_t instance = instance_of(&packet.hit, 0);
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(geometry, g, prim, instance, 0, STILL_TIME, &tri);   /* (a render with media moves no object) */
        Surface s;
        surface_at(P, D, (double)packet.ray.tfar[0], (double)packet.hit.u[0], (double)packet.hit.v[0], &tri, 0, &s);
        /* b. Another object's medium entered or left (the walk's own object: the walk enters and leaves it). */
        stack_cross(media, stack, &s, s.object != owner);
        /* c. On from just past it (shadows.spawn_ray, on the side D goes to). */
        double side = dot3(s.Ng, D) < 0.0 ? -1.0 : 1.0;
        for (int c = 0; c < 3; c++) P[c] = s.I[c] + (s.offset * side) * s.Ng[c];
    }
}
