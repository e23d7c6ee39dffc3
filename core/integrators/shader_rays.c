/* Rays a shader traces while it is evaluated: core/integrators/shader_rays.py's ShaderRays for one hit, the Ambient
 * Occlusion and Bevel nodes (graph.c's OP_AO and OP_BEVEL call these through the ShadingPoint's `rays`). */

struct ShaderRays {
    Intersect8 intersect;
    Occluded8 occluded;
    void *scene;
    const GeometryTables *geometry;
    double seed;
};

/* shader_rays.local_hits for one ray at `time` in the shutter: the hits of O + t D, t in (0, t_max), on the object
 * `owner`, stepping past other objects' triangles (LOCAL_STEPS surfaces in all), each surface counted once (a
 * triangle met again right after itself is stepped past uncounted); the nearest `most` into prim..t.
 * Returns how many it met (at most `most` + 1: it stops looking there). */
static int64_t local_hits(const ShaderRays *rays, const double *O, const double *D, double t_max, double time,
                          int64_t owner, int most, int64_t *geometry, int64_t *prim, int64_t *instance, double *u,
                          double *v, double *t)
{
    int64_t count = 0;
    double start = 0.0;
    int64_t last_g = -1, last_p = -1, last_j = -1;      /* the triangle met last */
    if (!(t_max > 0.0)) return 0;
    for (int step = 0; step < LOCAL_STEPS; step++) {
        double here[3];
        for (int c = 0; c < 3; c++) here[c] = O[c] + start * D[c];
        RayHitPacket packet;
        int valid[PACKET] ALIGNED(32);
        set_lane(&packet.ray, 0, here, D, t_max - start);
        set_time(&packet.ray, 0, time);
        close_packet(&packet.ray, valid, 1);
        clear_hits(&packet);
        rays->intersect(valid, rays->scene, &packet, NULL);
        if (packet.hit.geomID[0] == INVALID_ID) break;
        double at = start + (double)packet.ray.tfar[0];
        int64_t g = (int64_t)packet.hit.geomID[0], p = (int64_t)packet.hit.primID[0], j = instance_of(&packet.hit, 0);
        int again = g == last_g && p == last_p && j == last_j;
        last_g = g; last_p = p; last_j = j;
        if (!again && owner_of(rays->geometry, g, p, j) == owner) {
            if (count < most) {
                geometry[count] = g; prim[count] = p; instance[count] = j;
                u[count] = (double)packet.hit.u[0]; v[count] = (double)packet.hit.v[0]; t[count] = at;
            }
            count++;
        }
        /* (at least the robust offset of the point met: Embree's float32 rays far from the origin) */
        double met[3];
        for (int c = 0; c < 3; c++) met[c] = O[c] + at * D[c];
        start = at + at_least(at_least(1e-5 * at_least(at, 1e-3), 1e-7), ROBUST_ULPS * FLOAT32_EPSILON * largest3(met));
        if (count > most || !(start < t_max)) break;
    }
    return count;
}

/* ShaderRays.ambient_occlusion for one hit: the share of `samples` cosine-distributed rays about N (-N with
 * AO_INSIDE) that nothing (with AO_ONLY_LOCAL: nothing of the hit's object) blocks within `distance`. */
static double shader_ao(const ShadingPoint *sp, const double *N, double distance, int samples, int flags)
{
    const ShaderRays *rays = sp->rays;
    const Surface *s = sp->surface;
    if (samples < 1 || !(distance > 0.0)) return 1.0;
    double around[3];
    for (int c = 0; c < 3; c++) around[c] = (flags & AO_INSIDE) ? -N[c] : N[c];
    int64_t owner = owner_of(rays->geometry, sp->geometry, sp->prim, sp->instance);
    uint32_t stream = stream_of((int64_t)rays->seed, AO_NODE_DIMENSION + sp->dimension);
    int64_t open = 0;
    for (int j = 0; j < samples; j++) {
        double u[2];
        sample_2d(stream, sp->pixel, sp->sample * samples + j, u);
        Closure lobe = {0, {1.0, 1.0, 1.0}, 1.0, {around[0], around[1], around[2]}, NULL};
        BsdfSample b;
        lambert_sample(&lobe, NULL, u, &b);
        double O[3], side = dot3(s->Ng, b.wi) < 0.0 ? -1.0 : 1.0;
        for (int c = 0; c < 3; c++) O[c] = s->I[c] + (s->offset * side) * s->Ng[c];
        if (flags & AO_ONLY_LOCAL) {
            int64_t g, p, i;
            double hu, hv, ht;
            open += local_hits(rays, O, b.wi, distance, s->time, owner, 1, &g, &p, &i, &hu, &hv, &ht) == 0;
        } else {
            RayPacket ray;
            int valid[PACKET] ALIGNED(32);
            set_lane(&ray, 0, O, b.wi, (double)(float)distance);
            set_time(&ray, 0, s->time);
            close_packet(&ray, valid, 1);
            rays->occluded(valid, rays->scene, &ray, NULL);
            open += !(ray.tfar[0] < 0.0f);
        }
    }
    return (double)open / (double)samples;
}

/* shader_rays.orthonormals: two unit tangents T, B with the unit N (Cycles' make_orthonormals). */
INLINE void orthonormals(const double *N, double *T, double *B)
{
    double a[3];
    if (N[0] != N[1] || N[0] != N[2]) { a[0] = N[2] - N[1]; a[1] = N[0] - N[2]; a[2] = N[1] - N[0]; }
    else { a[0] = N[2] - N[1]; a[1] = N[0] + N[2]; a[2] = -N[1] - N[0]; }
    double length = sqrt(dot3(a, a));
    for (int c = 0; c < 3; c++) T[c] = a[c] / length;
    cross3(N, T, B);
}

/* shader_rays.cubic: the planar cubic falloff 10 (R - r)^3 / (pi R^5), 0 from r = R on. */
INLINE double bevel_cubic(double radius, double r)
{
    if (!(r < radius)) return 0.0;
    double f = radius - r;
    return 10.0 * (f * f * f) / (PI * pow(radius, 5.0));
}

/* shader_rays.cubic_root: where the cubic falloff's cumulative reaches xi, by Newton's method from 0.25. */
INLINE double bevel_cubic_root(double xi)
{
    double x = 0.25;
    for (int i = 0; i < 10; i++) {
        double x2 = x * x;
        double f = 10.0 * x2 - 20.0 * x2 * x + 15.0 * x2 * x2 - 4.0 * x2 * x2 * x - xi;
        double slope = 20.0 * (x * (1.0 - x)) * ((1.0 - x) * (1.0 - x));
        if (!(fabs(f) >= 1e-6) || slope == 0.0) break;
        x = x - f / slope;
        x = x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x);
    }
    return x;
}

/* ShaderRays.bevel for one hit: the object's smooth normals within `radius` averaged as Cycles' svm_bevel weighs
 * them, turned to the side the hit was seen from; the shading normal where nothing was found, radius <= 0,
 * samples < 1, or where the path bounced with a pdf below BEVEL_MIN_PDF (sp->blurry). */
static void shader_bevel(const ShadingPoint *sp, double radius, int samples, double *out)
{
    const ShaderRays *rays = sp->rays;
    const Surface *s = sp->surface;
    for (int c = 0; c < 3; c++) out[c] = sp->N[c];
    if (samples < 1 || !(radius > 0.0) || sp->blurry) return;
    int64_t owner = owner_of(rays->geometry, sp->geometry, sp->prim, sp->instance);
    uint32_t stream = stream_of((int64_t)rays->seed, BEVEL_DIMENSION + sp->dimension);
    double T0[3], B0[3], total[3] = {0.0, 0.0, 0.0};
    orthonormals(s->Ng, T0, B0);
    for (int j = 0; j < samples; j++) {
        double u[2];
        sample_2d(stream, sp->pixel, sp->sample * samples + j, u);
        /* 1. The disk's plane: across Ng (1/2), across T or across B (1/4 each). */
        int axis = u[0] < 0.5 ? 0 : (u[0] < 0.75 ? 1 : 2);
        double x = axis == 0 ? 2.0 * u[0] : (axis == 1 ? (u[0] - 0.5) * 4.0 : (u[0] - 0.75) * 4.0);
        const double *disk_N = axis == 0 ? s->Ng : (axis == 1 ? T0 : B0);
        const double *disk_T = axis == 1 ? s->Ng : T0, *disk_B = axis == 2 ? s->Ng : B0;
        double pick[3] = {axis == 0 ? 0.5 : 0.25, axis == 1 ? 0.5 : 0.25, axis == 2 ? 0.5 : 0.25};
        /* 2. The point on the disk and the probe through it. */
        double r = bevel_cubic_root(u[1]) * radius, h = sqrt(at_least(radius * radius - r * r, 0.0));
        double phi = 2.0 * PI * x, cx = r * cos(phi), cy = r * sin(phi), O[3], D[3];
        for (int c = 0; c < 3; c++) {
            O[c] = s->I[c] + disk_N[c] * h + (cx * disk_T[c] + cy * disk_B[c]);
            D[c] = -disk_N[c];
        }
        int64_t g[BEVEL_MAX_HITS], p[BEVEL_MAX_HITS], i[BEVEL_MAX_HITS];
        double hu[BEVEL_MAX_HITS], hv[BEVEL_MAX_HITS], ht[BEVEL_MAX_HITS];
        int64_t count = local_hits(rays, O, D, 2.0 * h, s->time, owner, BEVEL_MAX_HITS, g, p, i, hu, hv, ht);
        /* 3. Each hit's smooth normal, weighed by the planes' MIS and the falloff at its true distance. */
        for (int64_t k = 0; k < count && k < BEVEL_MAX_HITS; k++) {
            Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
            hit_triangle(rays->geometry, g[k], p[k], i[k], 1, s->time, &tri);
            double N[3] = {tri.Ng[0], tri.Ng[1], tri.Ng[2]};
            if (tri.smooth) {
                double w = 1.0 - hu[k] - hv[k], n[3];
                for (int c = 0; c < 3; c++)
                    n[c] = w * tri.normals[c] + hu[k] * tri.normals[3 + c] + hv[k] * tri.normals[6 + c];
                double length = sqrt(dot3(n, n));
                if (isfinite(length) && length > 0.0) for (int c = 0; c < 3; c++) N[c] = n[c] / length;
            }
            double pN = pick[0] * fabs(dot3(disk_N, tri.Ng)), pT = pick[1] * fabs(dot3(disk_T, tri.Ng));
            double pB = pick[2] * fabs(dot3(disk_B, tri.Ng));
            double w = pN > 0.0 ? pN / at_least(pN * pN + pT * pT + pB * pB, 1e-300) : 0.0;
            w = w * (double)(count > BEVEL_MAX_HITS ? count : BEVEL_MAX_HITS) / BEVEL_MAX_HITS;
            double hit_P[3], d[3];
            for (int c = 0; c < 3; c++) { hit_P[c] = O[c] + ht[k] * D[c]; d[c] = hit_P[c] - s->I[c]; }
            w = w * bevel_cubic(radius, sqrt(dot3(d, d))) / at_least(bevel_cubic(radius, r), 1e-300);
            for (int c = 0; c < 3; c++) total[c] += w * N[c];
        }
    }
    double length = sqrt(dot3(total, total));
    if (!(length > 0.0)) return;
    for (int c = 0; c < 3; c++) out[c] = total[c] / length * sp->side;
}
