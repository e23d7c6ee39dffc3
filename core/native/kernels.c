/* Primer's compiled kernels: the render loop's arithmetic, one sample at a time.
 *
 * Every function here is the twin of numpy code in core/ (named beside each one) and computes the
 * same numbers, in the same float64, in the same order of steps. The numpy code is the readable
 * reference; this file exists only because numpy makes a pass over memory per operation, so a
 * shading point costs a few hundred numpy passes, while here it is one pass with the values in
 * registers. tests/test_kernels.py checks each kernel against its twin, and whole renders against
 * the numpy path.
 *
 * Conventions. Arrays arrive from numpy as contiguous row-major buffers: an (n, 3) float64 array is
 * `double *` with row i at [3 i]. Ray queries stay in Python (Embree, through embreex): these
 * kernels only prepare rays and use their answers. No function keeps state or allocates, so any
 * number of threads may call them at once; ctypes releases Python's GIL around each call.
 *
 * Built by tools/build_kernels.py (`make kernels`), loaded by core/kernels.py.
 */
#define _POSIX_C_SOURCE 199309L   /* clock_gettime */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#define PRIMER_KERNELS_ABI 8

#define PI 3.14159265358979323846
#define FLOAT32_EPSILON (1.0 / 16777216.0)   /* 2^-24, core/shadows.py */
#define ROBUST_ULPS 8.0
#define T_INFINITY 1e37f                    /* core/intersect.py: Embree's "infinite" t_far */

#if defined(_WIN32)
#define EXPORT __declspec(dllexport)
#define INLINE static __forceinline
#define BYTE_SWAP(x) _byteswap_ulong(x)
#else
#define EXPORT __attribute__((visibility("default")))
#define INLINE static inline __attribute__((always_inline))
#define BYTE_SWAP(x) __builtin_bswap32(x)
#endif

/* The kernels whose loops run over blocks of samples are compiled twice on x86-64 Linux with GCC:
 * for any x86-64 (SSE2, 2 doubles per instruction) and for x86-64-v3 (AVX2, 4 doubles), and the
 * loader picks the one the processor runs (an ifunc). Both compute the same numbers: no fused
 * multiply-add either way. Elsewhere they are compiled once, for the compiler's default target. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define SIMD_CLONES
#endif

/* ------------------------------------------------------------------------------------------------
 * Small vector helpers
 * --------------------------------------------------------------------------------------------- */

INLINE double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* max(x, floor) and min(x, ceiling) for a number floor / ceiling: as fmax / fmin (a NaN x gives the
 * bound), but in a form the compiler can vectorize. */
INLINE double at_least(double x, double floor) { return x > floor ? x : floor; }
INLINE double at_most(double x, double ceiling) { return x < ceiling ? x : ceiling; }

/* Seconds on a monotonic clock (0 where there is none: Embree's share then goes uncounted). */
static double now(void)
{
#if defined(CLOCK_MONOTONIC)
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
#else
    return 0.0;
#endif
}

/* The kernels time Embree's queries block by block, thousands of times a chunk. Reading the clock
 * costs about 100 ns under this hypervisor (perf put the reads at 2.6% of a render's samples), so
 * they count the processor's time-stamp counter instead (a few ns, and steady on any x86-64 of the
 * last 15 years), and a Stopwatch turns the ticks into seconds with the clock read at both ends of
 * the kernel call. Elsewhere a tick is a nanosecond of the clock. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <x86intrin.h>
INLINE uint64_t ticks(void) { return __rdtsc(); }
#elif defined(_M_X64)
#include <intrin.h>
INLINE uint64_t ticks(void) { return __rdtsc(); }
#else
INLINE uint64_t ticks(void) { return (uint64_t)(1e9 * now()); }
#endif

typedef struct { double seconds; uint64_t ticks; } Stopwatch;

INLINE Stopwatch stopwatch(void) { Stopwatch w = {now(), ticks()}; return w; }

/* Seconds per tick since `started` (0 where the clock or the counter did not move). */
INLINE double seconds_per_tick(Stopwatch started)
{
    Stopwatch stopped = stopwatch();
    double seconds = stopped.seconds - started.seconds;
    return stopped.ticks > started.ticks && seconds > 0.0 ? seconds / (double)(stopped.ticks - started.ticks) : 0.0;
}

INLINE double largest3(const double *a)
{
    double m = fabs(a[0]);
    if (fabs(a[1]) > m) m = fabs(a[1]);
    if (fabs(a[2]) > m) m = fabs(a[2]);
    return m;
}

/* Unit direction and distance from p to q (a zero vector where they coincide): lights._direction_to. */
INLINE double direction_to(const double *p, const double *q, double *L)
{
    double w[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    double d = sqrt(dot3(w, w));
    double inverse = d > 0.0 ? 1.0 / d : 0.0;
    L[0] = w[0] * inverse; L[1] = w[1] * inverse; L[2] = w[2] * inverse;
    return d;
}

/* cos and sin of phi in [0, 2 pi), the way vectors.cos_sin takes them (cos in float32, sin from it). */
INLINE void cos_sin(double phi, double *c, double *s)
{
    double cosine = (double)cosf((float)phi);
    if (cosine > 1.0) cosine = 1.0;
    if (cosine < -1.0) cosine = -1.0;
    *c = cosine;
    *s = copysign(sqrt(1.0 - cosine * cosine), PI - phi);
}

/* Two unit vectors completing a unit axis to an orthonormal frame: lights.orthonormal_frame. */
INLINE void orthonormal_frame(const double *axis, double *t, double *b)
{
    double x = axis[0], y = axis[1], z = axis[2];
    double sign = z >= 0.0 ? 1.0 : -1.0;
    double a = -1.0 / (sign + z);
    double c = x * y * a;
    t[0] = 1.0 + sign * x * x * a; t[1] = sign * c; t[2] = -sign * x;
    b[0] = c; b[1] = sign + y * y * a; b[2] = -y;
}

/* ------------------------------------------------------------------------------------------------
 * Sampling: core/sampling.py, bit for bit
 * --------------------------------------------------------------------------------------------- */

INLINE uint32_t hash_u32(uint32_t x)
{
    uint32_t state = x * 747796405u + 2891336453u;
    uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

INLINE uint32_t reverse_bits(uint32_t x)
{
    /* Swap neighbouring bits, pairs and nibbles, then the four bytes in one instruction. */
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    return BYTE_SWAP(x);
}

INLINE uint32_t laine_karras(uint32_t x, uint32_t seed)
{
    x += seed;
    x ^= x * 0x6C50B47Cu;
    x ^= x * 0xB82F1E52u;
    x ^= x * 0xC7AFE638u;
    x ^= x * 0x8D22F6E6u;
    return x;
}

INLINE uint32_t sobol_y_mirrored(uint32_t y)
{
    y ^= (y >> 1) & 0x55555555u;
    y ^= (y >> 2) & 0x33333333u;
    y ^= (y >> 4) & 0x0F0F0F0Fu;
    y ^= (y >> 8) & 0x00FF00FFu;
    y ^= (y >> 16) & 0x0000FFFFu;
    return y;
}

INLINE uint32_t combine_seed(uint32_t seed, uint32_t value)
{
    return seed ^ (value + (seed << 6) + (seed >> 2));
}

/* The stream of (seed, dimension): sampling._pixel_key before the pixel is mixed in. */
INLINE uint32_t stream_of(int64_t seed, int64_t dimension)
{
    return hash_u32((uint32_t)((uint64_t)seed * 0x9E3779B9ull + (uint64_t)dimension * 0x85EBCA6Bull));
}

/* The index-th point of a pixel's progressive pattern: sampling.sample_2d for one sample. */
INLINE void sample_2d(uint32_t stream, int64_t pixel, int64_t index, double *u)
{
    uint32_t key = hash_u32((uint32_t)pixel ^ stream);
    uint32_t shuffled = reverse_bits(laine_karras(reverse_bits((uint32_t)index), key));
    uint32_t x = reverse_bits(laine_karras(shuffled, combine_seed(key, 1)));
    uint32_t y = reverse_bits(laine_karras(sobol_y_mirrored(shuffled), combine_seed(key, 2)));
    u[0] = x * (1.0 / 4294967296.0);
    u[1] = y * (1.0 / 4294967296.0);
}

/* sampling.sample_2d over arrays: pixel, index (n,) int64 -> out (n, 2) float64. */
EXPORT void primer_sample_2d(int64_t seed, const int64_t *pixel, const int64_t *index, int64_t dimension,
                             int64_t n, double *out)
{
    uint32_t stream = stream_of(seed, dimension);
    for (int64_t i = 0; i < n; i++)
        sample_2d(stream, pixel[i], index[i], out + 2 * i);
}

/* Samples are handled BLOCK at a time, one quantity per column (structure of arrays): each step is
 * then one loop over the block's lanes with no branches, which the compiler turns into SIMD
 * instructions (4 doubles or 8 integers at once with AVX2). The arithmetic of each lane is
 * exactly the one-sample arithmetic beside it. */
#define BLOCK 64

/* sample_2d for n <= BLOCK samples: pixel, index (n,) their keys -> x, y (n,) the point. */
SIMD_CLONES __attribute__((noinline)) static void sample_lanes(int64_t n, uint32_t stream,
                                                               const uint32_t *restrict pixel,
                                                               const uint32_t *restrict index,
                                                               double *restrict x, double *restrict y)
{
    for (int64_t k = 0; k < n; k++) {
        uint32_t key = hash_u32(pixel[k] ^ stream);
        uint32_t shuffled = reverse_bits(laine_karras(reverse_bits(index[k]), key));
        x[k] = reverse_bits(laine_karras(shuffled, combine_seed(key, 1))) * (1.0 / 4294967296.0);
        y[k] = reverse_bits(laine_karras(sobol_y_mirrored(shuffled), combine_seed(key, 2))) * (1.0 / 4294967296.0);
    }
}

/* ------------------------------------------------------------------------------------------------
 * Camera rays: render._render_chunk steps 1-2 and camera.generate_rays, for PERSP and ORTHO
 * --------------------------------------------------------------------------------------------- */

typedef struct {
    double orthographic;        /* 0: pinhole (PERSP), 1: parallel rays (ORTHO) */
    double left, right, bottom, top;   /* camera.viewplane */
    double clip_start, clip_end;
    double rotation[9];         /* camera-to-world rotation, row-major */
    double eye[3];              /* the camera's position minus the geometry's origin */
    double renormalize;         /* 1 when the rotation is not orthonormal (a sheared parent) */
} CameraRecord;

/* A block of camera samples: their pixels' keys and positions, their points, their rays. */
typedef struct {
    int64_t n;
    uint32_t pixel[BLOCK], index[BLOCK];
    double column[BLOCK], row[BLOCK];            /* the pixel's x and y on the image */
    double u[2][BLOCK];                          /* the sample's point inside its pixel */
    double O[3][BLOCK], D[3][BLOCK], t[BLOCK];
} CameraBlock;

/* One camera ray per lane (inlined once per camera kind, so that the loop has no branch). */
INLINE void camera_lanes(CameraBlock *restrict b, const CameraRecord *restrict record, int64_t width,
                         int64_t height, int orthographic, int renormalize)
{
    const CameraRecord camera = *record;   /* a local copy: every lane may read every field */
    const double *R = camera.rotation;
    for (int64_t k = 0; k < b->n; k++) {
        /* 1. The sample's position on the image plane. */
        double raster_x = b->column[k] + b->u[0][k];
        double raster_y = b->row[k] + b->u[1][k];
        double plane_x = camera.left + (raster_x / (double)width) * (camera.right - camera.left);
        double plane_y = camera.top - (raster_y / (double)height) * (camera.top - camera.bottom);
        /* 2. The ray in the camera's frame, starting on the near clip plane. */
        double o[3], d[3], t;
        if (!orthographic) {
            double length = sqrt(plane_x * plane_x + plane_y * plane_y + 1.0);
            d[0] = plane_x / length; d[1] = plane_y / length; d[2] = -1.0 / length;
            double cos_to_axis = -d[2];
            double start = camera.clip_start / cos_to_axis;
            o[0] = d[0] * start; o[1] = d[1] * start; o[2] = d[2] * start;
            t = (camera.clip_end - camera.clip_start) / cos_to_axis;
        } else {
            o[0] = plane_x; o[1] = plane_y; o[2] = -camera.clip_start;
            d[0] = 0.0; d[1] = 0.0; d[2] = -1.0;
            t = camera.clip_end - camera.clip_start;
        }
        /* 3. Into the camera-relative world frame. */
        double O[3], D[3];
        for (int c = 0; c < 3; c++) {
            O[c] = R[3 * c] * o[0] + R[3 * c + 1] * o[1] + R[3 * c + 2] * o[2] + camera.eye[c];
            D[c] = R[3 * c] * d[0] + R[3 * c + 1] * d[1] + R[3 * c + 2] * d[2];
        }
        if (renormalize) {
            double length = sqrt(dot3(D, D));
            D[0] /= length; D[1] /= length; D[2] /= length;
        }
        for (int c = 0; c < 3; c++) { b->O[c][k] = O[c]; b->D[c][k] = D[c]; }
        b->t[k] = t;
    }
}

SIMD_CLONES __attribute__((noinline)) static void camera_block(CameraBlock *restrict b,
                                                               const CameraRecord *restrict camera,
                                                               int64_t width, int64_t height)
{
    int orthographic = camera->orthographic != 0.0, renormalize = camera->renormalize != 0.0;
    if (orthographic) {
        if (renormalize) camera_lanes(b, camera, width, height, 1, 1);
        else camera_lanes(b, camera, width, height, 1, 0);
    } else {
        if (renormalize) camera_lanes(b, camera, width, height, 0, 1);
        else camera_lanes(b, camera, width, height, 0, 0);
    }
}

/* The camera rays of samples start .. start + BLOCK - 1 of p pixels' spp samples each (sample j
 * of pixel k is sample first[k] + j of its pattern): their keys, points and rays, into b. */
INLINE void camera_samples(CameraBlock *b, const CameraRecord *camera, uint32_t stream, int64_t width,
                           int64_t height, const int64_t *pixels, const int64_t *first, int64_t spp, int64_t start,
                           int64_t total)
{
    b->n = total - start < BLOCK ? total - start : BLOCK;
    int64_t k = start / spp, j = start % spp;
    int64_t pixel = pixels[k];
    double column = (double)(pixel % width), row = (double)(pixel / width);   /* (one division per pixel) */
    for (int64_t lane = 0; lane < b->n; lane++) {
        b->pixel[lane] = (uint32_t)pixel;
        b->index[lane] = (uint32_t)(first[k] + j);
        b->column[lane] = column;
        b->row[lane] = row;
        if (++j == spp && lane + 1 < b->n) {
            j = 0;
            pixel = pixels[++k];
            column = (double)(pixel % width);
            row = (double)(pixel / width);
        }
    }
    sample_lanes(b->n, stream, b->pixel, b->index, b->u[0], b->u[1]);
    camera_block(b, camera, width, height);
}

/* The camera rays of `spp` samples in each of `p` pixels, camera-relative: render._render_chunk
 * steps 1-2 and camera.generate_rays, for PERSP and ORTHO.
 * pixels, first: (p,) int64 (first: samples each pixel already has); width, height: the image.
 * Out: origins, directions (p spp, 3) float64; t_max (p spp,) float64. */
EXPORT void primer_camera_rays(const CameraRecord *camera, int64_t seed, int64_t width, int64_t height,
                               const int64_t *pixels, const int64_t *first, int64_t p, int64_t spp,
                               double *origins, double *directions, double *t_max)
{
    uint32_t stream = stream_of(seed, 0);
    int64_t total = p * spp;
    CameraBlock b;
    for (int64_t start = 0; start < total; start += BLOCK) {
        camera_samples(&b, camera, stream, width, height, pixels, first, spp, start, total);
        for (int64_t lane = 0; lane < b.n; lane++) {
            int64_t i = start + lane;
            for (int c = 0; c < 3; c++) { origins[3 * i + c] = b.O[c][lane]; directions[3 * i + c] = b.D[c][lane]; }
            t_max[i] = b.t[lane];
        }
    }
}

/* ------------------------------------------------------------------------------------------------
 * Hit surfaces: WorldGeometry.triangle_data and shading.surface_at_hits
 * --------------------------------------------------------------------------------------------- */

/* What shading needs of the copied triangles `prim`: WorldGeometry._copied_data plus the albedo.
 * vertices (v, 3) float32; triangles (t, 3) int32; face_normals (t, 3) float64; material (t,) int32;
 * albedo (a, 3) float64; smooth_index (t,) int32 (-1 flat) or NULL; corner_normals (s, 3, 3) float32.
 * Out per hit: corners (m, 3, 3), Ng (m, 3), albedo_out (m, 3) float64; smooth (m,) uint8;
 * normals (m, 3, 3) float64 (written for smooth hits only). */
/* One hit's copied triangle f: its corners (3, 3) and corner normals (3, 3) widened to double, its
 * face normal and albedo; returns whether it is smooth (normals written only then). */
INLINE int copied_triangle(int64_t f, const float *vertices, const int32_t *triangles, const double *face_normals,
                           const int32_t *material, const double *albedo, const int32_t *smooth_index,
                           const float *corner_normals, double *corners, double *Ng, double *albedo_out,
                           double *normals)
{
    for (int k = 0; k < 3; k++) {
        const float *V = vertices + 3 * (int64_t)triangles[3 * f + k];
        for (int c = 0; c < 3; c++) corners[3 * k + c] = (double)V[c];
    }
    for (int c = 0; c < 3; c++) {
        Ng[c] = face_normals[3 * f + c];
        albedo_out[c] = albedo[3 * (int64_t)material[f] + c];
    }
    int32_t row = smooth_index ? smooth_index[f] : -1;
    if (row >= 0)
        for (int c = 0; c < 9; c++) normals[c] = (double)corner_normals[9 * (int64_t)row + c];
    return row >= 0;
}

EXPORT void primer_copied_triangles(const int64_t *prim, int64_t m, const float *vertices, const int32_t *triangles,
                                    const double *face_normals, const int32_t *material, const double *albedo,
                                    const int32_t *smooth_index, const float *corner_normals,
                                    double *corners, double *Ng, double *albedo_out, uint8_t *smooth, double *normals)
{
    for (int64_t i = 0; i < m; i++)
        smooth[i] = (uint8_t)copied_triangle(prim[i], vertices, triangles, face_normals, material, albedo,
                                             smooth_index, corner_normals, corners + 9 * i, Ng + 3 * i,
                                             albedo_out + 3 * i, normals + 9 * i);
}

/* The surface of one hit: shading.hit_points, surface_at_hits, shadows.error_bound and, for the
 * terminator fix, shadows.terminator_points. O, D: its ray; t, u, v: Embree's answer; V: the
 * corners (3, 3); ng: the face normal, turned to face the viewer in place; normals: the corner
 * normals (3, 3) when smooth. Out: P (3) the point I, n (3) the shading normal, *offset, and Q (3),
 * the terminator fix's point, when Q is not NULL and the hit is smooth. */
INLINE void surface_at(const double *O, const double *D, double t, double u, double v, const double *V,
                       double *ng, int smooth, const double *normals, double *P, double *n, double *offset,
                       double *Q)
{
    double w = 1.0 - u - v;
    /* 1. I: the float64 ray meets the triangle's plane, unless that disagrees with Embree's t. */
    double to_corner[3] = {V[0] - O[0], V[1] - O[1], V[2] - O[2]};
    double t_plane = dot3(to_corner, ng) / dot3(D, ng);
    if (fabs(t_plane - t) <= 1e-5 * fabs(t) + 1e-30) {
        for (int c = 0; c < 3; c++) P[c] = O[c] + t_plane * D[c];
    } else {
        for (int c = 0; c < 3; c++) P[c] = w * V[c] + u * V[3 + c] + v * V[6 + c];
    }
    /* 2. The face normal, flipped when the triangle was hit from behind (N.D > 0). */
    double side = dot3(ng, D) > 0.0 ? -1.0 : 1.0;
    for (int c = 0; c < 3; c++) { ng[c] *= side; n[c] = ng[c]; }
    /* 3. The robust offset: ROBUST_ULPS float32 ulps of the largest coordinate involved. */
    double magnitude = largest3(P);
    for (int k = 0; k < 3; k++) if (largest3(V + 3 * k) > magnitude) magnitude = largest3(V + 3 * k);
    *offset = ROBUST_ULPS * FLOAT32_EPSILON * magnitude;
    if (!smooth) return;
    /* 4. Smooth triangles: the corner normals (turned with the face) interpolated and renormalised. */
    double cn[9];
    for (int c = 0; c < 9; c++) cn[c] = normals[c] * side;
    double s[3];
    for (int c = 0; c < 3; c++) s[c] = w * cn[c] + u * cn[3 + c] + v * cn[6 + c];
    double length = sqrt(dot3(s, s));
    if (isfinite(length) && length > 0.0)
        for (int c = 0; c < 3; c++) n[c] = s[c] / length;
    /* 5. The terminator fix's point: I projected onto each corner's tangent plane where it lies
     *    below it, the projections interpolated with the barycentrics. */
    if (Q != NULL) {
        double weight[3] = {w, u, v};
        Q[0] = Q[1] = Q[2] = 0.0;
        for (int k = 0; k < 3; k++) {
            const double *corner = V + 3 * k, *normal = cn + 3 * k;
            double to_point[3] = {P[0] - corner[0], P[1] - corner[1], P[2] - corner[2]};
            double below = dot3(to_point, normal);
            if (below > 0.0) below = 0.0;
            for (int c = 0; c < 3; c++)
                Q[c] += weight[k] * (corner[c] + (to_point[c] - below * normal[c]));
        }
    }
}

/* surface_at for m hits.
 * In: ray (m,) int64 row of each hit's ray in origins / directions (n, 3) float64; t, u, v (m,) float64;
 * corners (m, 3, 3), Ng (m, 3) float64; smooth (m,) uint8; normals (m, 3, 3) float64 (smooth hits).
 * Out: I, N (m, 3) float64; Ng turned to face the viewer, in place; offset (m,) float64;
 * lifted (m, 3) float64 or NULL: the terminator fix's points, for smooth hits. */
EXPORT void primer_surfaces(const int64_t *ray, int64_t m, const double *origins, const double *directions,
                            const double *t, const double *u, const double *v, const double *corners,
                            double *Ng, const uint8_t *smooth, const double *normals,
                            double *I, double *N, double *offset, double *lifted)
{
    for (int64_t i = 0; i < m; i++)
        surface_at(origins + 3 * ray[i], directions + 3 * ray[i], t[i], u[i], v[i], corners + 9 * i, Ng + 3 * i,
                   smooth[i], normals + 9 * i, I + 3 * i, N + 3 * i, offset + i, lifted ? lifted + 3 * i : NULL);
}

/* ------------------------------------------------------------------------------------------------
 * Lights: core/lights.py's sample_light for one point and one sample
 * --------------------------------------------------------------------------------------------- */

enum { LIGHT_POINT = 0, LIGHT_SPOT = 1, LIGHT_SUN = 2, LIGHT_AREA = 3 };

/* One light, prepared by core/kernels.py (`light_record`): everything that does not depend on the
 * shading point. Only doubles, so that its layout is the same on every compiler. */
typedef struct {
    double kind;            /* LIGHT_* */
    double samples;         /* light samples per camera sample (1 for lights without extent) */
    double dimension;       /* the sampling dimension of its pattern: 16 + 4 * index */
    double delta;           /* 1: no extent (exact, one direction) */
    double color[3];
    double position[3];     /* point and spot: the centre; area: the centre */
    double direction[3];    /* spot: unit axis; sun: unit direction towards the sun; area: unit normal */
    double axis_u[3], axis_v[3];      /* area: the two edge vectors */
    double ellipse;         /* area: 1 for DISK and ELLIPSE */
    double area;            /* area: emitting area */
    double radiance;        /* area: P / (pi A); sphere: P / (4 pi^2 R^2) */
    double power, radius, soft_falloff;
    double strength;        /* sun: irradiance at normal incidence (delta) or carried by each sample (disk) */
    double sun_t[3], sun_b[3], sun_cos_max;      /* sun disk: the cone's frame and half-angle */
    double spot_frame;      /* 1: the spot has a (scaled) frame: use spot_inverse */
    double spot_inverse[9]; /* world to spot-local, row-major */
    double spot_cos_half, spot_blend_width;
    double spread_narrow;   /* area: 1 when spread < pi */
    double spread_tan_half, spread_norm;
} LightRecord;

typedef struct {
    double L[3];
    double distance;
    double strength;
    double position[3];
} LightSample;

/* A direction uniform in solid angle within the cone (axis, t, b, cos_max): lights._sample_cone. */
INLINE void sample_cone(const double *axis, const double *t, const double *b, double cos_max,
                               const double *u, double *L)
{
    double cos_theta = 1.0 - u[0] * (1.0 - cos_max);
    double sin_theta = sqrt(at_least(1.0 - cos_theta * cos_theta, 0.0));
    double cos_phi, sin_phi;
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    for (int c = 0; c < 3; c++)
        L[c] = t[c] * (sin_theta * cos_phi) + b[c] * (sin_theta * sin_phi) + axis[c] * cos_theta;
}

/* Blender's spot cone factor for light leaving along -L: lights.spot_attenuation. */
INLINE double spot_factor(const LightRecord *light, const double *L)
{
    /* The angle to the axis, in a spot's (scaled) frame when it has one; both computed, one chosen. */
    double plain = -dot3(L, light->direction);
    const double *M = light->spot_inverse;
    double local[3];
    for (int c = 0; c < 3; c++) local[c] = -(M[3 * c] * L[0] + M[3 * c + 1] * L[1] + M[3 * c + 2] * L[2]);
    double length = sqrt(dot3(local, local));
    double framed = -local[2] / (length > 0.0 ? length : 1.0);
    double cos_angle = light->spot_frame == 0.0 ? plain : framed;
    /* A hard edge without blend; else smoothstep across the blend. */
    double hard = cos_angle > light->spot_cos_half ? 1.0 : 0.0;
    double x = (cos_angle - light->spot_cos_half) / light->spot_blend_width;
    x = x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x);
    double smooth = x * x * (3.0 - 2.0 * x);
    return light->spot_blend_width <= 0.0 ? hard : smooth;
}

/* The sun: one direction (no extent), or a direction in its disk's cone. */
INLINE void sample_sun(const LightRecord *light, const double *u, LightSample *out)
{
    if (light->delta != 0.0) {
        for (int c = 0; c < 3; c++) out->L[c] = light->direction[c];
    } else {
        sample_cone(light->direction, light->sun_t, light->sun_b, light->sun_cos_max, u, out->L);
    }
    out->distance = INFINITY;
    out->strength = light->strength;
    out->position[0] = out->position[1] = out->position[2] = 0.0;
}

/* The lecture's point light: I = P / (4 pi), attenuated by 1 / r^2 (and a spot's cone, after). */
INLINE void sample_point(const LightRecord *light, const double *P, LightSample *out)
{
    double d = direction_to(P, light->position, out->L);
    out->distance = d;
    double strength = light->power * (1.0 / (4.0 * PI)) * (1.0 / (d * d));
    out->strength = d > 0.0 ? strength : 0.0;
    for (int c = 0; c < 3; c++) out->position[c] = light->position[c];
}

/* A sphere (or, with soft falloff, a disk facing P): the cone it covers, sampled uniformly. */
INLINE void sample_sphere(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    double axis[3], t[3], b[3];
    double d = direction_to(P, light->position, axis);
    double R = light->radius, sin2_max;
    if (light->soft_falloff != 0.0) {
        sin2_max = R * R / (R * R + d * d);
    } else {
        d = at_least(d, R * (1.0 + 1e-9));
        sin2_max = at_most((R / d) * (R / d), 1.0);
    }
    double cos_max = sqrt(1.0 - sin2_max);
    orthonormal_frame(axis, t, b);
    sample_cone(axis, t, b, cos_max, u, out->L);
    double cos_to_center = dot3(out->L, axis);
    if (light->soft_falloff != 0.0) {
        out->distance = d / at_least(cos_to_center, 1e-300);
    } else {
        double h = d * cos_to_center;
        out->distance = h - sqrt(at_least(h * h - (d * d - R * R), 0.0));
    }
    out->strength = light->radiance * 2.0 * PI * (1.0 - cos_max);
    for (int c = 0; c < 3; c++) out->position[c] = P[c] + out->L[c] * out->distance;
}

/* Where on a DISK or ELLIPSE area light the sample u falls, in its unit square's frame: the
 * concentric map of the square onto the unit disk (Shirley-Chiu), halved. */
INLINE void area_disk_point(const double *u, double *x, double *y)
{
    double a = 2.0 * u[0] - 1.0, bb = 2.0 * u[1] - 1.0;
    int use_a = fabs(a) > fabs(bb);
    double r = use_a ? a : bb;
    double ratio = r == 0.0 ? 0.0 : (use_a ? bb : a) / r;
    double phi = use_a ? (PI / 4) * ratio : (PI / 2) - (PI / 4) * ratio;
    double cos_phi, sin_phi;
    cos_sin(phi < 0.0 ? phi + 2.0 * PI : phi, &cos_phi, &sin_phi);
    *x = 0.5 * r * cos_phi;
    *y = 0.5 * r * sin_phi;
}

/* A one-sided area light's point (x, y) (in [-1/2, 1/2]^2 of its edges), seen from P:
 * E_normal = L_e cos(theta_light) A / d^2, narrowed by the spread. */
INLINE void sample_area(const LightRecord *light, const double *P, double x, double y, LightSample *out)
{
    for (int c = 0; c < 3; c++)
        out->position[c] = x * light->axis_u[c] + y * light->axis_v[c] + light->position[c];
    double d = direction_to(P, out->position, out->L);
    double cos_light = -dot3(out->L, light->direction);
    /* (Each value is computed whatever the tests say, then chosen: loops over many samples need
     * no branches then. Values thrown away may be inf or NaN.) */
    double geometry = cos_light * light->area / (d * d);
    geometry = (cos_light > 0.0) & (d > 0.0) ? geometry : 0.0;
    if (light->spread_narrow != 0.0) {
        double tan_theta = sqrt(at_least(1.0 - cos_light * cos_light, 0.0)) / cos_light;
        double narrowed = at_least(light->spread_tan_half - tan_theta, 0.0) / light->spread_norm;
        geometry *= cos_light > 0.0 ? narrowed : 0.0;
    }
    out->distance = d;
    out->strength = light->radiance * geometry;
}

/* Light from `light` arriving at point P for the unit-square sample u: lights.sample_light. */
INLINE void sample_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    int kind = (int)light->kind;
    if (kind == LIGHT_SUN) {
        sample_sun(light, u, out);
    } else if (kind == LIGHT_POINT || kind == LIGHT_SPOT) {
        if (light->delta != 0.0) sample_point(light, P, out);
        else sample_sphere(light, P, u, out);
        if (kind == LIGHT_SPOT) out->strength *= spot_factor(light, out->L);
    } else {
        double x = u[0] - 0.5, y = u[1] - 0.5;
        if (light->ellipse != 0.0) area_disk_point(u, &x, &y);
        sample_area(light, P, x, y, out);
    }
}

/* ------------------------------------------------------------------------------------------------
 * Shadow rays: shading.direct_light's steps 1-3 with core/shadows.py, for lights l0 .. l1 - 1
 * --------------------------------------------------------------------------------------------- */

typedef struct {
    double robust;            /* 1: robust offsets (shadows.robust_rays); 0: the lecture's epsilon */
    double epsilon;
    double terminator_fix;    /* 1: lift smooth points (lifted != NULL) */
    double terminator_offset;
    double seed;
} ShadowSettings;

/* Light samples, BLOCK at a time (see sample_lanes). */
typedef struct {
    int64_t n;                                   /* lanes in use */
    int64_t hit[BLOCK];                          /* the hit each light sample belongs to */
    uint32_t pixel[BLOCK], index[BLOCK];         /* its random-number keys */
    double u[2][BLOCK];                          /* its point in the unit square */
    double P[3][BLOCK], N[3][BLOCK], Ng[3][BLOCK], lifted[3][BLOCK];
    double offset[BLOCK], smooth[BLOCK];
    double L[3][BLOCK], distance[BLOCK], strength[BLOCK], position[3][BLOCK];
    double origin[3][BLOCK], D[3][BLOCK], t[BLOCK], weight[BLOCK];
    double keep[BLOCK];                          /* 1: the ray can carry light */
} SampleBlock;

/* Step 0: samples first .. first + n - 1 of a light with `count` samples per hit (sample s is
 * sample s % count of hit s / count): their hits' data, gathered into columns. */
SIMD_CLONES __attribute__((noinline)) static void gather_block(SampleBlock *b, int64_t first, int64_t n, int64_t count,
                         const double *I, const double *N, const double *Ng, const double *offset,
                         const uint8_t *smooth, const double *lifted, const int64_t *pixel, const int64_t *sample)
{
    int64_t i = first / count, j = first % count;
    b->n = n;
    for (int64_t k = 0; k < n; k++) {
        b->hit[k] = i;
        b->pixel[k] = (uint32_t)pixel[i];
        b->index[k] = (uint32_t)(sample[i] * count + j);
        for (int c = 0; c < 3; c++) {
            b->P[c][k] = I[3 * i + c];
            b->N[c][k] = N[3 * i + c];
            b->Ng[c][k] = Ng[3 * i + c];
            b->lifted[c][k] = lifted != NULL && smooth[i] ? lifted[3 * i + c] : I[3 * i + c];   /* (unset for flat hits) */
        }
        b->offset[k] = offset[i];
        b->smooth[k] = smooth[i] ? 1.0 : 0.0;
        if (++j == count) { j = 0; i++; }
    }
}

/* Step 2: where the light comes from (lights.sample_light). The common kinds have loops of their
 * own with no branches; the rest (which need cos) go one sample at a time. */
INLINE void store_sample(SampleBlock *b, int64_t k, const LightSample *ls)
{
    for (int c = 0; c < 3; c++) { b->L[c][k] = ls->L[c]; b->position[c][k] = ls->position[c]; }
    b->distance[k] = ls->distance;
    b->strength[k] = ls->strength;
}

SIMD_CLONES __attribute__((noinline)) static void light_block(SampleBlock *restrict b, const LightRecord *restrict record)
{
    /* A local copy: the compiler may then read its fields in every lane, whichever value is chosen. */
    const LightRecord copy = *record, *light = &copy;
    int kind = (int)light->kind;
    if (kind == LIGHT_AREA && light->ellipse == 0.0) {
        for (int64_t k = 0; k < b->n; k++) {
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]};
            LightSample ls;
            sample_area(light, P, b->u[0][k] - 0.5, b->u[1][k] - 0.5, &ls);
            store_sample(b, k, &ls);
        }
    } else if (kind == LIGHT_SUN && light->delta != 0.0) {
        double zero[2] = {0.0, 0.0};
        for (int64_t k = 0; k < b->n; k++) {
            LightSample ls;
            sample_sun(light, zero, &ls);
            store_sample(b, k, &ls);
        }
    } else if (kind == LIGHT_POINT && light->delta != 0.0) {
        for (int64_t k = 0; k < b->n; k++) {
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]};
            LightSample ls;
            sample_point(light, P, &ls);
            store_sample(b, k, &ls);
        }
    } else {
        for (int64_t k = 0; k < b->n; k++) {
            double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]}, u[2] = {b->u[0][k], b->u[1][k]};
            LightSample ls;
            sample_light(light, P, u, &ls);
            store_sample(b, k, &ls);
        }
    }
}

/* Step 3: the lecture's two tests, then the shadow ray: shadows.robust_rays when `robust`, else
 * shadows.epsilon_rays. (Inlined once for each method, so that the loop has no branch.) */
INLINE void ray_lanes(SampleBlock *restrict b, const ShadowSettings *restrict settings, int lifted, double samples,
                      int robust)
{
    double lift = lifted && settings->terminator_offset > 0.0 ? 1.0 : 0.0;
    double fix = settings->terminator_fix != 0.0 ? 1.0 : 0.0;
    double cutoff = settings->terminator_offset, epsilon = settings->epsilon;
    for (int64_t k = 0; k < b->n; k++) {
        double P[3] = {b->P[0][k], b->P[1][k], b->P[2][k]}, L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]};
        double n[3] = {b->N[0][k], b->N[1][k], b->N[2][k]}, ng[3] = {b->Ng[0][k], b->Ng[1][k], b->Ng[2][k]};
        /* a. N.L > 0 and Ng.L > 0 (smooth points lifted by the terminator fix leave that to their ray). */
        double NL = dot3(n, L), NgL = dot3(ng, L);
        double cosine = at_least(NL, 0.0);
        int face_allows = (NgL > 0.0) | ((fix * b->smooth[k]) != 0.0);
        b->keep[k] = (cosine != 0.0) & face_allows & (b->strength[k] > 0.0) ? 1.0 : 0.0;
        /* b. The origin: I, or the terminator fix's blend towards the lifted point (amount 0 elsewhere). */
        double amount = NL < cutoff ? 2.0 - (NgL + NL) / cutoff : 1.0 - NgL / cutoff;
        amount = amount < 0.0 ? 0.0 : (amount > 1.0 ? 1.0 : amount);
        amount = (lift * b->smooth[k]) != 0.0 ? amount : 0.0;
        double origin[3], D[3], t;
        for (int c = 0; c < 3; c++) origin[c] = P[c] + amount * (b->lifted[c][k] - P[c]);
        if (robust) {
            /* c. Off the surface along Ng by the error bound, towards the light point, stopping short
             *    of it by the rounding at its own coordinates; a sun's ray keeps its direction. */
            for (int c = 0; c < 3; c++) origin[c] += b->offset[k] * ng[c];
            double Q[3] = {b->position[0][k], b->position[1][k], b->position[2][k]};
            double w[3] = {Q[0] - origin[0], Q[1] - origin[1], Q[2] - origin[2]};
            double length = sqrt(dot3(w, w));
            double inverse = 1.0 / at_least(length, 1e-300);
            double stop = length - ROBUST_ULPS * FLOAT32_EPSILON * largest3(Q);
            int finite = b->distance[k] < INFINITY;
            for (int c = 0; c < 3; c++) D[c] = finite ? w[c] * inverse : L[c];
            t = finite ? at_least(stop, 0.0) : b->distance[k];
        } else {
            /* c'. The lecture's epsilon: origin I + epsilon L, t_max = distance - 2 epsilon. */
            for (int c = 0; c < 3; c++) { origin[c] += epsilon * L[c]; D[c] = L[c]; }
            t = at_least(b->distance[k] - 2.0 * epsilon, 0.0);
        }
        for (int c = 0; c < 3; c++) { b->origin[c][k] = origin[c]; b->D[c][k] = D[c]; }
        b->t[k] = t;
        b->weight[k] = b->strength[k] * cosine * (1.0 / samples);
    }
}

SIMD_CLONES __attribute__((noinline)) static void ray_block(SampleBlock *restrict b, const ShadowSettings *restrict settings,
                                                int lifted, double samples)
{
    if (settings->robust != 0.0) ray_lanes(b, settings, lifted, samples, 1);
    else ray_lanes(b, settings, lifted, samples, 0);
}

/* Steps 0-3 for samples first .. of one light: the block's hits, sample points, light samples and
 * rays (b.keep marks the rays that can carry light). In: as primer_shadow_rays; lifted already
 * NULL unless the terminator fix is on. */
INLINE void shadow_block(SampleBlock *b, const ShadowSettings *settings, const LightRecord *light, int64_t first,
                         int64_t m, const double *I, const double *N, const double *Ng, const double *offset,
                         const uint8_t *smooth, const double *lifted, const int64_t *pixel, const int64_t *sample)
{
    int64_t count = (int64_t)light->samples, total = m * count;
    gather_block(b, first, total - first < BLOCK ? total - first : BLOCK, count,
                 I, N, Ng, offset, smooth, lifted, pixel, sample);
    if (light->delta == 0.0)
        sample_lanes(b->n, stream_of((int64_t)settings->seed, (int64_t)light->dimension), b->pixel, b->index,
                     b->u[0], b->u[1]);
    else
        for (int64_t k = 0; k < b->n; k++) b->u[0][k] = b->u[1][k] = 0.0;
    light_block(b, light);
    ray_block(b, settings, lifted != NULL, (double)count);
}

/* Step 4: the block's rays that can carry light, written from row r on as Embree takes them
 * (float32, t_max clamped to its "infinite"); returns the next free row, or -1 past capacity. */
INLINE int64_t keep_rays(const SampleBlock *b, int64_t r, int64_t capacity, float *origins, float *directions,
                         float *t_max, int32_t *owner, double *weight)
{
    for (int64_t k = 0; k < b->n; k++) {
        if (b->keep[k] == 0.0) continue;
        if (r >= capacity) return -1;
        for (int c = 0; c < 3; c++) {
            origins[3 * r + c] = (float)b->origin[c][k];
            directions[3 * r + c] = (float)b->D[c][k];
        }
        t_max[r] = b->t[k] < (double)T_INFINITY ? (float)b->t[k] : T_INFINITY;
        owner[r] = (int32_t)b->hit[k];
        weight[r] = b->weight[k];
        r++;
    }
    return r;
}

/* Build one shadow ray per (hit, light, light sample) that can carry light, compacted.
 * In: I, N, Ng (m, 3) float64 (Ng facing the viewer); offset (m,) float64; smooth (m,) uint8;
 * lifted (m, 3) float64 or NULL; pixel, sample (m,) int64 the keys of each hit's random numbers.
 * Out, for ray r < the returned count (at most capacity): origins, directions (r, 3) float32,
 * t_max (r,) float32, owner (r,) int32 hit, light_of (r,) int32 light, weight (r,) float64: what the
 * ray adds to E when unoccluded, strength * max(N.L, 0) / samples. Returns -1 if capacity is short. */
EXPORT int64_t primer_shadow_rays(const ShadowSettings *settings, const LightRecord *lights, int64_t l0, int64_t l1,
                                  const double *I, const double *N, const double *Ng, const double *offset,
                                  const uint8_t *smooth, const double *lifted,
                                  const int64_t *pixel, const int64_t *sample, int64_t m, int64_t capacity,
                                  float *origins, float *directions, float *t_max,
                                  int32_t *owner, int32_t *light_of, double *weight)
{
    SampleBlock b;
    int64_t r = 0;
    const double *lift_from = settings->terminator_fix != 0.0 ? lifted : NULL;
    for (int64_t l = l0; l < l1; l++) {
        int64_t total = m * (int64_t)lights[l].samples;
        for (int64_t first = 0; first < total; first += BLOCK) {
            shadow_block(&b, settings, lights + l, first, m, I, N, Ng, offset, smooth, lift_from, pixel, sample);
            int64_t next = keep_rays(&b, r, capacity, origins, directions, t_max, owner, weight);
            if (next < 0) return -1;
            for (; r < next; r++) light_of[r] = (int32_t)l;
        }
    }
    return r;
}

/* Add the unoccluded shadow rays' light: E[owner] += weight * colour (shading.direct_light, step 4).
 * blocked: (r,) uint8 Embree's answers; E: (m, 3) float64, added to. */
EXPORT void primer_add_light(const LightRecord *lights, int64_t r, const int32_t *owner, const int32_t *light_of,
                             const double *weight, const uint8_t *blocked, double *E)
{
    for (int64_t k = 0; k < r; k++) {
        if (blocked[k]) continue;
        const double *color = lights[light_of[k]].color;
        double *e = E + 3 * (int64_t)owner[k];
        for (int c = 0; c < 3; c++) e[c] += weight[k] * color[c];
    }
}

/* ------------------------------------------------------------------------------------------------
 * Film: render._render_chunk step 5, the box filter's per-pixel sums
 * --------------------------------------------------------------------------------------------- */

/* A hit sample's value: RGBA (albedo / pi * E, 1). albedo, E: (3,). */
INLINE void hit_value(const double *albedo, const double *E, double *s)
{
    for (int c = 0; c < 3; c++) s[c] = albedo[c] * (1.0 / PI) * E[c];
    s[3] = 1.0;
}

/* Add a sample's RGBA s to its pixel's sums: sum (4,), and its squared luminance and alpha to
 * squares (2,) unless squares is NULL. */
INLINE void add_sample(const double *s, const double *luminance, double *sum, double *squares)
{
    for (int c = 0; c < 4; c++) sum[c] += s[c];
    if (squares != NULL) {
        double y = luminance[0] * s[0] + luminance[1] * s[1] + luminance[2] * s[2];
        squares[0] += y * y;
        squares[1] += s[3] * s[3];
    }
}

/* Sum each pixel's samples. n = p spp samples, pixel by pixel.
 * valid: (n,) uint8 camera rays traced, or NULL (all); background: RGBA of a traced ray that misses;
 * hit_sample (m,) int64 the hits' sample rows, ascending; albedo, E (m, 3) float64: radiance =
 * albedo / pi * E. Out: rgba (p, 4), squares (p, 2) (luminance^2 and alpha^2, when squares != NULL)
 * float64, hits (p,) int64 hit samples per pixel. Each sample's value is made as it is summed (no
 * image of samples in between). Returns 0, or -1 if hit_sample is not ascending. */
EXPORT int64_t primer_film(int64_t p, int64_t spp, const uint8_t *valid, const double *background,
                           const int64_t *hit_sample, int64_t m, const double *albedo, const double *E,
                           const double *luminance, double *rgba, double *squares, int64_t *hits)
{
    int64_t h = 0;             /* the next hit, in sample order */
    for (int64_t k = 0; k < p; k++) {
        double sum[4] = {0.0, 0.0, 0.0, 0.0}, square[2] = {0.0, 0.0};
        int64_t hit_count = 0;
        for (int64_t j = 0; j < spp; j++) {
            int64_t i = k * spp + j;
            double s[4];
            if (h < m && hit_sample[h] < i) return -1;
            if (h < m && hit_sample[h] == i) {
                hit_value(albedo + 3 * h, E + 3 * h, s);
                h++;
                hit_count++;
            } else if (valid == NULL || valid[i]) {
                for (int c = 0; c < 4; c++) s[c] = background[c];
            } else {
                s[0] = s[1] = s[2] = 0.0;   /* outside a fisheye's image circle: opaque black */
                s[3] = 1.0;
            }
            add_sample(s, luminance, sum, square);
        }
        for (int c = 0; c < 4; c++) rgba[4 * k + c] = sum[c];
        if (squares != NULL) { squares[2 * k] = square[0]; squares[2 * k + 1] = square[1]; }
        hits[k] = hit_count;
    }
    return h == m ? 0 : -1;
}

/* ------------------------------------------------------------------------------------------------
 * Ray queries in packets: core/intersect.py's Tracer, through Embree's rtcIntersect8 / rtcOccluded8
 * --------------------------------------------------------------------------------------------- */

/* Embree 4's packet records (rtcore_ray.h), 8 rays wide, structure of arrays. Embree reads the
 * fields in this order; the hit's instance fields are sized for one instance level with instance
 * arrays (RTC_MAX_INSTANCE_LEVEL_COUNT 1), which is how embreex's Embree is built
 * (tests/test_intersect.py compares every answer with embreex's own queries). The spare rows keep
 * an Embree built for more levels from writing past the record; the kernels never read them. */
#define PACKET 8
typedef struct {
    float org_x[PACKET], org_y[PACKET], org_z[PACKET], tnear[PACKET];
    float dir_x[PACKET], dir_y[PACKET], dir_z[PACKET], time[PACKET];
    float tfar[PACKET];
    uint32_t mask[PACKET], id[PACKET], flags[PACKET];
} __attribute__((aligned(32))) RayPacket;

typedef struct {
    float Ng_x[PACKET], Ng_y[PACKET], Ng_z[PACKET];
    float u[PACKET], v[PACKET];
    uint32_t primID[PACKET], geomID[PACKET];
    uint32_t instID[1][PACKET];
    uint32_t instPrimID[1][PACKET];
    uint32_t spare[14][PACKET];
} __attribute__((aligned(32))) HitPacket;

typedef struct { RayPacket ray; HitPacket hit; } RayHitPacket;

/* Embree's functions, passed in as addresses by core/intersect.py (the library embreex loaded). */
typedef void (*Occluded8)(const int *valid, void *scene, RayPacket *ray, void *arguments);
typedef void (*Intersect8)(const int *valid, void *scene, RayHitPacket *rayhit, void *arguments);

#define INVALID_ID 0xFFFFFFFFu

/* Rays first .. first + PACKET - 1 of a batch of n into a packet: valid[k] -1 for a ray, 0 past n.
 * REAL is the batch's type: float rays go in as they are; double rays are rounded to float here,
 * t_max clamped to Embree's "infinite" first (core/intersect.py's _f32_rays, one value at a time). */
#define FILL_PACKET(name, REAL)                                                                        \
    INLINE void name(RayPacket *ray, int *valid, int64_t first, int64_t n,                             \
                     const REAL *origins, const REAL *directions, const REAL *t_max)                   \
    {                                                                                                  \
        for (int k = 0; k < PACKET; k++) {                                                             \
            int64_t i = first + k < n ? first + k : n - 1;                                             \
            valid[k] = first + k < n ? -1 : 0;                                                         \
            ray->org_x[k] = (float)origins[3 * i];                                                     \
            ray->org_y[k] = (float)origins[3 * i + 1];                                                 \
            ray->org_z[k] = (float)origins[3 * i + 2];                                                 \
            ray->dir_x[k] = (float)directions[3 * i];                                                  \
            ray->dir_y[k] = (float)directions[3 * i + 1];                                              \
            ray->dir_z[k] = (float)directions[3 * i + 2];                                              \
            ray->tnear[k] = 0.0f;                                                                      \
            ray->time[k] = 0.0f;                                                                       \
            ray->tfar[k] = t_max[i] > (REAL)T_INFINITY ? T_INFINITY : (float)t_max[i];                 \
            ray->mask[k] = INVALID_ID;                                                                 \
            ray->id[k] = 0;                                                                            \
            ray->flags[k] = 0;                                                                         \
        }                                                                                              \
    }
FILL_PACKET(fill_packet, float)
FILL_PACKET(fill_packet_double, double)

/* Which placement of an instance array lane k hit (Embree's instPrimID), or -1 off any instance. */
INLINE int64_t instance_of(const HitPacket *hit, int k)
{
    return hit->instID[0][k] != INVALID_ID && hit->instPrimID[0][k] != INVALID_ID ? (int64_t)hit->instPrimID[0][k] : -1;
}

/* A nearest-hit packet of double rays first .. (see fill_packet), its hit fields set to "none". */
INLINE void fill_hit_packet(RayHitPacket *packet, int *valid, int64_t first, int64_t n, const double *origins,
                            const double *directions, const double *t_max)
{
    fill_packet_double(&packet->ray, valid, first, n, origins, directions, t_max);
    for (int k = 0; k < PACKET; k++) {
        packet->hit.geomID[k] = INVALID_ID;
        packet->hit.primID[k] = INVALID_ID;
        packet->hit.instID[0][k] = INVALID_ID;
        packet->hit.instPrimID[0][k] = INVALID_ID;
    }
}

/* Whether anything lies on each ray within (0, t_max): Tracer.occluded.
 * origins, directions (n, 3), t_max (n,) float32 -> blocked (n,) uint8. Embree marks an occluded
 * ray by setting its tfar to -inf, as embreex reads it. */
INLINE void occlude(Occluded8 occluded8, void *scene, int64_t n, const float *origins, const float *directions,
                    const float *t_max, uint8_t *blocked)
{
    RayPacket ray;
    int valid[PACKET] __attribute__((aligned(32)));
    for (int64_t first = 0; first < n; first += PACKET) {
        fill_packet(&ray, valid, first, n, origins, directions, t_max);
        occluded8(valid, scene, &ray, NULL);
        for (int k = 0; k < PACKET && first + k < n; k++) blocked[first + k] = ray.tfar[k] < 0.0f;
    }
}

/* Steps 4-6 of a block of light samples (see primer_shade): the rays that can carry light go into
 * packets as keep_rays and fill_packet would write them, Embree answers each packet of 8, and the
 * light of those that get through is added to E (m, 3) in ray order. Returns the rays traced. */
INLINE int64_t occlude_block(const SampleBlock *b, const LightRecord *light, Occluded8 occluded8, void *scene,
                             double *E)
{
    RayPacket ray;
    int valid[PACKET] __attribute__((aligned(32)));
    int64_t owner[PACKET], rays = 0;
    double weight[PACKET];
    int lanes = 0;
    for (int64_t k = 0; k <= b->n; k++) {
        if (k < b->n) {
            if (b->keep[k] == 0.0) continue;
            ray.org_x[lanes] = (float)b->origin[0][k];
            ray.org_y[lanes] = (float)b->origin[1][k];
            ray.org_z[lanes] = (float)b->origin[2][k];
            ray.dir_x[lanes] = (float)b->D[0][k];
            ray.dir_y[lanes] = (float)b->D[1][k];
            ray.dir_z[lanes] = (float)b->D[2][k];
            ray.tnear[lanes] = 0.0f;
            ray.time[lanes] = 0.0f;
            ray.tfar[lanes] = b->t[k] < (double)T_INFINITY ? (float)b->t[k] : T_INFINITY;
            ray.mask[lanes] = INVALID_ID;
            ray.id[lanes] = 0;
            ray.flags[lanes] = 0;
            owner[lanes] = b->hit[k];
            weight[lanes] = b->weight[k];
            valid[lanes] = -1;
            if (++lanes < PACKET) continue;
        }
        if (lanes == 0) continue;
        for (int lane = lanes; lane < PACKET; lane++) {        /* an unused lane: a copy, switched off */
            ray.org_x[lane] = ray.org_x[0]; ray.org_y[lane] = ray.org_y[0]; ray.org_z[lane] = ray.org_z[0];
            ray.dir_x[lane] = ray.dir_x[0]; ray.dir_y[lane] = ray.dir_y[0]; ray.dir_z[lane] = ray.dir_z[0];
            ray.tnear[lane] = 0.0f; ray.time[lane] = 0.0f; ray.tfar[lane] = ray.tfar[0];
            ray.mask[lane] = INVALID_ID; ray.id[lane] = 0; ray.flags[lane] = 0;
            valid[lane] = 0;
        }
        occluded8(valid, scene, &ray, NULL);
        for (int lane = 0; lane < lanes; lane++) {
            if (ray.tfar[lane] < 0.0f) continue;               /* blocked */
            double *e = E + 3 * owner[lane];
            for (int c = 0; c < 3; c++) e[c] += weight[lane] * light->color[c];
        }
        rays += lanes;
        lanes = 0;
    }
    return rays;
}

EXPORT void primer_occluded(void *function, void *scene, int64_t n, const float *origins, const float *directions,
                            const float *t_max, uint8_t *blocked)
{
    occlude((Occluded8)function, scene, n, origins, directions, t_max, blocked);
}

/* The nearest hit in (0, t_max) of each ray: Tracer.intersect.
 * origins, directions (n, 3), t_max (n,) float64 (rounded to float32 here) -> t (n,) float64 (inf where missed), prim (n,)
 * int64 (-1 where missed), geometry (n,) int32 Embree's geomID (-1 where missed), u, v (n,) float64,
 * instance (n,) int64 the placement hit in an instance array (-1: a copied triangle, or missed). */
EXPORT void primer_intersect(void *function, void *scene, int64_t n, const double *origins, const double *directions,
                             const double *t_max, double *t, int64_t *prim, int32_t *geometry, double *u, double *v,
                             int64_t *instance)
{
    Intersect8 intersect8 = (Intersect8)function;
    RayHitPacket packet;
    int valid[PACKET] __attribute__((aligned(32)));
    for (int64_t first = 0; first < n; first += PACKET) {
        fill_hit_packet(&packet, valid, first, n, origins, directions, t_max);
        intersect8(valid, scene, &packet, NULL);
        for (int k = 0; k < PACKET && first + k < n; k++) {
            int64_t i = first + k;
            int hit = packet.hit.geomID[k] != INVALID_ID;
            t[i] = hit ? (double)packet.ray.tfar[k] : INFINITY;
            prim[i] = hit ? (int64_t)packet.hit.primID[k] : -1;
            geometry[i] = hit ? (int32_t)packet.hit.geomID[k] : -1;
            u[i] = hit ? (double)packet.hit.u[k] : 0.0;
            v[i] = hit ? (double)packet.hit.v[k] : 0.0;
            instance[i] = hit ? instance_of(&packet.hit, k) : -1;
        }
    }
}

/* camera_samples, then the block's rays row by row as the packets take them: O, D (BLOCK, 3) and
 * t_max (BLOCK,) float64 (rows b.n and up unused). */
INLINE void block_rays(CameraBlock *b, const CameraRecord *camera, uint32_t stream, int64_t width, int64_t height,
                       const int64_t *pixels, const int64_t *first, int64_t spp, int64_t start, int64_t total,
                       double *O, double *D, double *t_max)
{
    camera_samples(b, camera, stream, width, height, pixels, first, spp, start, total);
    for (int64_t lane = 0; lane < b->n; lane++) {
        for (int c = 0; c < 3; c++) { O[3 * lane + c] = b->O[c][lane]; D[3 * lane + c] = b->D[c][lane]; }
        t_max[lane] = b->t[lane];
    }
}

/* Camera rays made and traced in one pass, 8 at a time, keeping only those that hit: primer_camera_rays,
 * then Tracer.intersect, then the gather of the hits, with no array of rays in between.
 * In: as primer_camera_rays; intersect8, scene: Embree's rtcIntersect8 and the RTCScene.
 * Out, for hit h < the returned count (at most p spp): sample (h,) int64 the hit's row among the
 * chunk's p spp samples; origins, directions (h, 3), t (h,) float64 its ray and distance; prim (h,)
 * int64, geometry (h,) int32, u, v (h,) float64 Embree's answer, instance (h,) int64 the placement
 * of an instance array it hit (-1: a copied triangle). embree_seconds[0] += time in Embree. */
EXPORT int64_t primer_primary(const CameraRecord *camera, int64_t seed, int64_t width, int64_t height,
                              const int64_t *pixels, const int64_t *first, int64_t p, int64_t spp,
                              void *intersect8, void *scene, int64_t *sample, double *origins, double *directions,
                              double *t, int64_t *prim, int32_t *geometry, double *u, double *v, int64_t *instance,
                              double *embree_seconds)
{
    Intersect8 intersect = (Intersect8)intersect8;
    uint32_t stream = stream_of(seed, 0);
    int64_t total = p * spp, m = 0;
    uint64_t embree = 0;
    Stopwatch started = stopwatch();
    CameraBlock b;
    RayHitPacket packet;
    int valid[PACKET] __attribute__((aligned(32)));
    double O[3 * BLOCK], D[3 * BLOCK], t_max[BLOCK];
    for (int64_t start = 0; start < total; start += BLOCK) {
        /* 1. The block's camera rays, as primer_camera_rays makes them. */
        block_rays(&b, camera, stream, width, height, pixels, first, spp, start, total, O, D, t_max);
        /* 2. Embree's nearest hits, 8 rays at a time; 3. the rays that hit, kept. */
        uint64_t begin = ticks();
        for (int64_t at = 0; at < b.n; at += PACKET) {
            fill_hit_packet(&packet, valid, at, b.n, O, D, t_max);
            intersect(valid, scene, &packet, NULL);
            for (int lane = 0; lane < PACKET && at + lane < b.n; lane++) {
                if (packet.hit.geomID[lane] == INVALID_ID) continue;
                int64_t row = at + lane;
                sample[m] = start + row;
                for (int c = 0; c < 3; c++) {
                    origins[3 * m + c] = O[3 * row + c];
                    directions[3 * m + c] = D[3 * row + c];
                }
                t[m] = (double)packet.ray.tfar[lane];
                prim[m] = (int64_t)packet.hit.primID[lane];
                geometry[m] = (int32_t)packet.hit.geomID[lane];
                u[m] = (double)packet.hit.u[lane];
                v[m] = (double)packet.hit.v[lane];
                instance[m] = instance_of(&packet.hit, lane);
                m++;
            }
        }
        embree += ticks() - begin;
    }
    embree_seconds[0] += (double)embree * seconds_per_tick(started);
    return m;
}

/* For core/kernels.py's checks: this file's interface version and its records' sizes. */
EXPORT int64_t primer_kernels_abi(void) { return PRIMER_KERNELS_ABI; }
EXPORT int64_t primer_light_record_size(void) { return (int64_t)sizeof(LightRecord); }
EXPORT int64_t primer_camera_record_size(void) { return (int64_t)sizeof(CameraRecord); }
EXPORT int64_t primer_shadow_settings_size(void) { return (int64_t)sizeof(ShadowSettings); }

/* ------------------------------------------------------------------------------------------------
 * Shading in one stream: shadow rays made, traced and added up block by block
 * --------------------------------------------------------------------------------------------- */

/* primer_shadow_rays, Tracer.occluded and primer_add_light in one pass: each block of light samples
 * becomes its shadow rays, Embree answers them 8 at a time, and the light of those that get through
 * goes into E, while all of it is still in the cache; no array of rays is ever made. The rays, the
 * answers and the order of the sums are those of the three steps (tests/test_kernels.py compares).
 * In: as primer_shadow_rays; occluded8, scene: Embree's rtcOccluded8 and the RTCScene.
 * Out: E (m, 3) float64, added to; embree_ticks[0] += the time inside Embree, in ticks. Returns the rays. */
INLINE int64_t shade_lights(const ShadowSettings *settings, const LightRecord *lights, int64_t l0, int64_t l1,
                            const double *I, const double *N, const double *Ng, const double *offset,
                            const uint8_t *smooth, const double *lifted, const int64_t *pixel, const int64_t *sample,
                            int64_t m, Occluded8 occluded, void *scene, double *E, uint64_t *embree_ticks)
{
    SampleBlock b;
    int64_t rays = 0;
    uint64_t embree = 0;
    const double *lift_from = settings->terminator_fix != 0.0 ? lifted : NULL;
    for (int64_t l = l0; l < l1; l++) {
        const LightRecord *light = lights + l;
        int64_t total = m * (int64_t)light->samples;
        for (int64_t first = 0; first < total; first += BLOCK) {
            /* 1. The block's rays, as primer_shadow_rays makes them. */
            shadow_block(&b, settings, light, first, m, I, N, Ng, offset, smooth, lift_from, pixel, sample);
            /* 2. Embree's answers, 8 rays at a time; 3. the light of the rays that get through. */
            uint64_t start = ticks();
            rays += occlude_block(&b, light, occluded, scene, E);
            embree += ticks() - start;
        }
    }
    embree_ticks[0] += embree;
    return rays;
}

EXPORT int64_t primer_shade(const ShadowSettings *settings, const LightRecord *lights, int64_t l0, int64_t l1,
                            const double *I, const double *N, const double *Ng, const double *offset,
                            const uint8_t *smooth, const double *lifted, const int64_t *pixel, const int64_t *sample,
                            int64_t m, void *occluded8, void *scene, double *E, double *embree_seconds)
{
    Stopwatch started = stopwatch();
    uint64_t embree = 0;
    int64_t rays = shade_lights(settings, lights, l0, l1, I, N, Ng, offset, smooth, lifted, pixel, sample, m,
                                (Occluded8)occluded8, scene, E, &embree);
    embree_seconds[0] += (double)embree * seconds_per_tick(started);
    return rays;
}

/* ------------------------------------------------------------------------------------------------
 * A chunk in one stream: camera rays, hits, surfaces, shadow rays and film, block by block
 * --------------------------------------------------------------------------------------------- */

/* The copied triangles' tables (core/kernels.py CopiedArrays), as primer_copied_triangles takes them. */
typedef struct {
    const float *vertices;
    const int32_t *triangles;
    const double *face_normals;
    const int32_t *material;
    const double *albedo;
    const int32_t *smooth_index;
    const float *corner_normals;
} CopiedTables;

/* The hits of one block of camera samples, one row per hit (at most BLOCK). */
typedef struct {
    int64_t m;
    int64_t lane[BLOCK];                         /* the camera sample (lane of the block) it belongs to */
    int64_t pixel[BLOCK], sample[BLOCK];         /* its random-number keys */
    double I[3 * BLOCK], N[3 * BLOCK], Ng[3 * BLOCK], lifted[3 * BLOCK], offset[BLOCK];
    double albedo[3 * BLOCK], E[3 * BLOCK];
    uint8_t smooth[BLOCK];
} BlockHits;

/* primer_primary, primer_copied_triangles and primer_surfaces, primer_shade and primer_film for a
 * chunk of p pixels of spp samples (render._render_chunk steps 1-5), BLOCK camera samples at a time:
 * each block's rays, hits,
 * surfaces and shadow rays live in the cache and on the stack, and its samples go straight into
 * their pixels' sums. The rays, the answers and every sum are those of the separate kernels, in the
 * same order (tests/test_kernels.py renders both ways).
 * In: as primer_primary and primer_shade (all of the lights), the copied triangles' tables; background,
 * luminance as primer_film takes them. Out: rgba (p, 4), squares (p, 2) or NULL, hits (p,) as
 * primer_film writes them; counts[0] += shadow rays; seconds[0] += time in Embree's nearest-hit
 * queries, seconds[1] in its occlusion queries, seconds[2] shading (surfaces and shadow rays). */
EXPORT void primer_samples(const CameraRecord *camera, int64_t seed, int64_t width, int64_t height,
                           const int64_t *pixels, const int64_t *first, int64_t p, int64_t spp, void *intersect8,
                           void *occluded8, void *scene, const CopiedTables *tables, const ShadowSettings *settings,
                           const LightRecord *lights, int64_t n_lights, const double *background,
                           const double *luminance, double *rgba, double *squares, int64_t *hits, int64_t *counts,
                           double *seconds)
{
    Intersect8 intersect = (Intersect8)intersect8;
    Occluded8 occluded = (Occluded8)occluded8;
    uint32_t stream = stream_of(seed, 0);
    int64_t total = p * spp, shadow_rays = 0;
    int fix = settings->terminator_fix != 0.0;
    Stopwatch started = stopwatch();
    uint64_t spent[3] = {0, 0, 0};        /* ticks: nearest hits, occlusion, shading (as seconds[0..2]) */
    CameraBlock b;
    RayHitPacket packet;
    int valid[PACKET] __attribute__((aligned(32)));
    double O[3 * BLOCK], D[3 * BLOCK], t_max[BLOCK], t[BLOCK], u[BLOCK], v[BLOCK];
    int64_t prim[BLOCK];
    BlockHits H;
    for (int64_t k = 0; k < p; k++) {
        for (int c = 0; c < 4; c++) rgba[4 * k + c] = 0.0;
        if (squares != NULL) squares[2 * k] = squares[2 * k + 1] = 0.0;
        hits[k] = 0;
    }
    for (int64_t start = 0; start < total; start += BLOCK) {
        /* 1. The block's camera rays (primer_camera_rays). */
        block_rays(&b, camera, stream, width, height, pixels, first, spp, start, total, O, D, t_max);
        /* 2. Their nearest hits, 8 at a time; the rays that hit kept (primer_primary). */
        uint64_t begin = ticks();
        H.m = 0;
        for (int64_t at = 0; at < b.n; at += PACKET) {
            fill_hit_packet(&packet, valid, at, b.n, O, D, t_max);
            intersect(valid, scene, &packet, NULL);
            for (int lane = 0; lane < PACKET && at + lane < b.n; lane++) {
                if (packet.hit.geomID[lane] == INVALID_ID) continue;
                H.lane[H.m] = at + lane;
                t[H.m] = (double)packet.ray.tfar[lane];
                prim[H.m] = (int64_t)packet.hit.primID[lane];
                u[H.m] = (double)packet.hit.u[lane];
                v[H.m] = (double)packet.hit.v[lane];
                H.m++;
            }
        }
        uint64_t traced = ticks();
        spent[0] += traced - begin;
        /* 3. The surface at each hit (primer_copied_triangles, primer_surfaces). */
        for (int64_t h = 0; h < H.m; h++) {
            int64_t lane = H.lane[h];
            double corners[9], normals[9] = {0.0};     /* (normals: read only when smooth) */
            int is_smooth = copied_triangle(prim[h], tables->vertices, tables->triangles, tables->face_normals,
                                            tables->material, tables->albedo, tables->smooth_index,
                                            tables->corner_normals, corners, H.Ng + 3 * h, H.albedo + 3 * h, normals);
            H.smooth[h] = (uint8_t)is_smooth;
            surface_at(O + 3 * lane, D + 3 * lane, t[h], u[h], v[h], corners, H.Ng + 3 * h, is_smooth, normals,
                       H.I + 3 * h, H.N + 3 * h, H.offset + h, fix ? H.lifted + 3 * h : NULL);
            H.pixel[h] = (int64_t)b.pixel[lane];
            H.sample[h] = (int64_t)b.index[lane];
            H.E[3 * h] = H.E[3 * h + 1] = H.E[3 * h + 2] = 0.0;
        }
        /* 4. Each light's shadow rays, Embree's answers and the light that gets through (primer_shade). */
        shadow_rays += shade_lights(settings, lights, 0, n_lights, H.I, H.N, H.Ng, H.offset, H.smooth, H.lifted,
                                    H.pixel, H.sample, H.m, occluded, scene, H.E, spent + 1);
        spent[2] += ticks() - traced;
        /* 5. Every sample of the block into its pixel's sums (primer_film), in sample order. */
        int64_t h = 0, k = start / spp, j = start % spp;
        for (int64_t lane = 0; lane < b.n; lane++, j++) {
            if (j == spp) { j = 0; k++; }
            double s[4];
            if (h < H.m && H.lane[h] == lane) {
                hit_value(H.albedo + 3 * h, H.E + 3 * h, s);
                h++;
                hits[k]++;
            } else {
                for (int c = 0; c < 4; c++) s[c] = background[c];
            }
            add_sample(s, luminance, rgba + 4 * k, squares != NULL ? squares + 2 * k : NULL);
        }
    }
    counts[0] += shadow_rays;
    double scale = seconds_per_tick(started);
    for (int i = 0; i < 3; i++) seconds[i] += (double)spent[i] * scale;
}

/* ------------------------------------------------------------------------------------------------
 * Adaptive sampling: adaptive.unconverged, one pass over the image instead of numpy's twenty
 * --------------------------------------------------------------------------------------------- */

#define DARK 0.1                /* core/adaptive.py */

/* Luminance of an RGBA sum (adaptive.LUMINANCE), summed in numpy's einsum order. */
INLINE double luminance_of(const double *rgba, const double *weights)
{
    return rgba[0] * weights[0] + rgba[1] * weights[1] + rgba[2] * weights[2];
}

/* adaptive.edge_contrast's relative difference of two neighbours' mean luminances. */
INLINE double contrast(double a, double b)
{
    return fabs(a - b) / sqrt((0.5 * (a + b)) * (0.5 * (a + b)) + DARK * DARK);
}

/* adaptive.relative_noise of pixel i, without branches (so that loops over pixels vectorise). */
INLINE double pixel_error(int64_t i, const double *restrict total, const double *restrict squares,
                          const int64_t *restrict count, const double *w)
{
    double n = (double)(int32_t)count[i];     /* (through int32, which SIMD converts: counts are small) */
    double luminance = luminance_of(total + 4 * i, w) / n, alpha = total[4 * i + 3] / n;
    double variance_y = at_least(squares[2 * i] / n - luminance * luminance, 0.0) * n / (n - 1.0);
    double variance_a = at_least(squares[2 * i + 1] / n - alpha * alpha, 0.0) * n / (n - 1.0);
    double error_y = sqrt(variance_y / n) / sqrt(luminance * luminance + DARK * DARK);
    double error_a = sqrt(variance_a / n);
    double larger = error_y > error_a ? error_y : error_a;
    larger = (error_y != error_y) | (error_a != error_a) ? NAN : larger;     /* np.maximum keeps NaN */
    return n >= 2.0 ? larger : INFINITY;
}

/* Pixel i's mean luminance over max(count, 1) samples (adaptive.edge_contrast's). */
INLINE double pixel_mean(int64_t i, const double *restrict total, const int64_t *restrict count, const double *w)
{
    double n = (double)(int32_t)count[i];
    return luminance_of(total + 4 * i, w) / (n > 1.0 ? n : 1.0);
}

/* pixel_error of pixels lo .. hi - 1 into error[i - lo]. */
SIMD_CLONES __attribute__((noinline)) static void noise_lanes(int64_t lo, int64_t hi, const double *restrict total,
                                                              const double *restrict squares,
                                                              const int64_t *restrict count,
                                                              const double *restrict weights,
                                                              double *restrict error)
{
    double w[3] = {weights[0], weights[1], weights[2]};
    for (int64_t i = lo; i < hi; i++) error[i - lo] = pixel_error(i, total, squares, count, w);
}

/* pixel_mean of pixels lo .. hi - 1 into mean[i - lo]. */
SIMD_CLONES __attribute__((noinline)) static void mean_lanes(int64_t lo, int64_t hi, const double *restrict total,
                                                             const int64_t *restrict count,
                                                             const double *restrict weights, double *restrict mean)
{
    double w[3] = {weights[0], weights[1], weights[2]};
    for (int64_t i = lo; i < hi; i++) mean[i - lo] = pixel_mean(i, total, count, w);
}

/* Add a chunk's per-pixel sums into the render's running sums, in place (render.render's store):
 * rgba (p, 4), squares (p, 2) float64 and hits (p,) int64 of pixels (p,) int64, spp samples each,
 * into total (H W, 4), squares_sum (H W, 2) float64, count and hits_sum (H W,) int64. With error
 * and mean (H W,) float64 (else NULL), also the pixels' new pixel_error and pixel_mean, which the
 * noise test between passes then reads instead of working them out for every pixel itself. The
 * chunks of a pass have pixels of their own, so the threads rendering them may add at the same time. */
EXPORT void primer_add_pixels(int64_t p, const int64_t *pixels, int64_t spp, const double *rgba, const double *squares,
                              const int64_t *hits, double *total, double *squares_sum, int64_t *count, int64_t *hits_sum,
                              const double *weights, double *error, double *mean)
{
    for (int64_t k = 0; k < p; k++) {
        int64_t i = pixels[k];
        for (int c = 0; c < 4; c++) total[4 * i + c] += rgba[4 * k + c];
        squares_sum[2 * i] += squares[2 * k];
        squares_sum[2 * i + 1] += squares[2 * k + 1];
        count[i] += spp;
        hits_sum[i] += hits[k];
    }
    if (error == NULL || mean == NULL || p == 0) return;
    /* A run of neighbouring pixels (a first pass's chunk) in SIMD lanes; any others one by one. */
    int64_t run = 1;
    while (run < p && pixels[run] == pixels[0] + run) run++;
    if (run == p) {
        noise_lanes(pixels[0], pixels[0] + p, total, squares_sum, count, weights, error + pixels[0]);
        mean_lanes(pixels[0], pixels[0] + p, total, count, weights, mean + pixels[0]);
        return;
    }
    double w[3] = {weights[0], weights[1], weights[2]};
    for (int64_t k = 0; k < p; k++) {
        error[pixels[k]] = pixel_error(pixels[k], total, squares_sum, count, w);
        mean[pixels[k]] = pixel_mean(pixels[k], total, count, w);
    }
}

/* The image from the running sums: each pixel's mean over max(count, 1) samples (render.render's
 * box filter). total (n, 4) float64, count (n,) int64 -> out (n, 4) float32. */
EXPORT void primer_resolve(int64_t n, const double *total, const int64_t *count, float *out)
{
    for (int64_t i = 0; i < n; i++) {
        double samples = (double)(count[i] > 1 ? count[i] : 1);
        for (int c = 0; c < 4; c++) out[4 * i + c] = (float)(total[4 * i + c] / samples);
    }
}

/* The first k in 0 .. p with pixels[k] >= i (pixels ascending). */
INLINE int64_t first_at_least(const int64_t *pixels, int64_t p, int64_t i)
{
    int64_t lo = 0, hi = p;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (pixels[mid] < i) lo = mid + 1; else hi = mid;
    }
    return lo;
}

/* Whether pixels (p,) int64 are distinct flat indices of an image of `size` pixels, ascending. */
EXPORT SIMD_CLONES int64_t primer_ascending(const int64_t *pixels, int64_t p, int64_t size)
{
    if (p == 0) return 1;
    int64_t ascending = pixels[0] >= 0 && pixels[p - 1] < size;
    for (int64_t k = 1; k < p; k++) ascending &= pixels[k] > pixels[k - 1];
    return ascending;
}

/* The contrast of each pixel x of a row to a neighbour, both sampled (else 0): to x - 1 in the same
 * row (`up` NULL: c[x] for x >= 1, c[0] = 0) or to x in the row `up` (c[x] for every x). m, n: the
 * row's means and counts; up, n_up: the other row's. In SIMD lanes. */
SIMD_CLONES __attribute__((noinline)) static void contrast_lanes(int64_t width, const double *restrict m,
                                                                 const int64_t *restrict n,
                                                                 const double *restrict up,
                                                                 const int64_t *restrict n_up, double *restrict c)
{
    if (up == NULL) {
        c[0] = 0.0;
        for (int64_t x = 1; x < width; x++)
            c[x] = (n[x] > 0) & (n[x - 1] > 0) ? contrast(m[x], m[x - 1]) : 0.0;
    } else {
        for (int64_t x = 0; x < width; x++)
            c[x] = (n[x] > 0) & (n_up[x] > 0) ? contrast(m[x], up[x]) : 0.0;
    }
}

/* e[x] = the largest of e[x] and c[x] (a NaN c leaves e), for x < n. */
INLINE void raise_to(int64_t n, double *restrict e, const double *restrict c)
{
    for (int64_t x = 0; x < n; x++) e[x] = at_least(c[x], e[x]);
}

/* The pixels of rows y0 .. y1 - 1 that need another pass (adaptive.unconverged): a subset of
 * `pixels`, in their order. Rows can be decided apart (the threads of a render take a band each):
 * a pixel's answer reads its neighbours' noise flags, and their edges read the means one row further,
 * so the work covers the rows y0 - 2 .. y1 + 1, the window, and decides only y0 .. y1 - 1.
 * total (H W, 4), squares (H W, 2) float64 and count (H W,) int64 are the running sums; pixels
 * (p,) int64 the region's pixels, ascending; first the first pass's size (0: no edge test).
 * known_error, known_mean (H W,) float64: every sampled pixel's pixel_error and pixel_mean, as
 * primer_add_pixels keeps them (else NULL: worked out here, for the window).
 * Scratch, one value per pixel of the window (at most (y1 - y0 + 4) W): error and mean float64,
 * noisy and grown uint8; row (W,) float64. Out: wanted (at most p) int64; returns how many.
 * Where the window's pixels are all of one run (a first pass over every pixel), the loops run over
 * the run itself instead of the list, in SIMD lanes. */
EXPORT SIMD_CLONES int64_t primer_unconverged(int64_t width, int64_t height, int64_t y0, int64_t y1,
                                              const double *total, const double *squares, const int64_t *count,
                                              const double *weights, const int64_t *pixels, int64_t p,
                                              double threshold, int64_t first, const double *known_error,
                                              const double *known_mean, double *error, double *mean,
                                              uint8_t *noisy, uint8_t *grown, double *row, int64_t *wanted)
{
    /* 0. The window (rows a .. b - 1, pixels base .. base + size - 1) and the region's pixels in it;
     *    scratch is indexed from base. */
    y0 = y0 > 0 ? y0 : 0;
    y1 = y1 < height ? y1 : height;
    int64_t a = y0 - 2 > 0 ? y0 - 2 : 0, b = y1 + 2 < height ? y1 + 2 : height;
    int64_t base = a * width, size = (b - a) * width;
    int64_t k0 = first_at_least(pixels, p, base), k1 = first_at_least(pixels, p, base + size);
    if (k0 == k1 || y0 >= y1) return 0;
    /* The region's pixels in the window are lo .. hi - 1 (from base) when they form one run. */
    int64_t lo = pixels[k0] - base, hi = pixels[k1 - 1] - base + 1;
    int run = hi - lo == k1 - k0;
    /* 1. Noisy pixels of the region: their noise as kept, or worked out (every pixel from the first
     *    to the last at once); the same for the window's means. noise_of and mean_of start at base. */
    const double *noise_of = known_error != NULL ? known_error + base : error;
    const double *mean_of = known_mean != NULL ? known_mean + base : mean;
    if (known_error == NULL)
        noise_lanes(pixels[k0], pixels[k1 - 1] + 1, total, squares, count, weights, error + lo);
    if (first > 0 && known_mean == NULL) mean_lanes(base, base + size, total, count, weights, mean);
    for (int64_t i = 0; i < size; i++) noisy[i] = 0;
    if (run)
        for (int64_t i = lo; i < hi; i++) noisy[i] = noise_of[i] > threshold;
    else
        for (int64_t k = k0; k < k1; k++) noisy[pixels[k] - base] = noise_of[pixels[k] - base] > threshold;
    /* 2. Pixels with only the first pass's samples beside an edge (a contrast to a neighbour, both
     *    sampled, above threshold * first): each pair's contrast once, then each pixel's largest (the
     *    largest of non-negative numbers, in whatever order). */
    if (first > 0) {
        double *edge = error;                  /* (the noise is used up) */
        for (int64_t i = 0; i < size; i++) edge[i] = 0.0;
        for (int64_t y = a; y < b; y++) {
            const double *m = mean_of + (y - a) * width;
            const int64_t *n = count + y * width;
            double *e = edge + (y - a) * width;
            contrast_lanes(width, m, n, NULL, NULL, row);          /* across: (x - 1, x) */
            raise_to(width, e, row);
            raise_to(width - 1, e, row + 1);
            if (y == a) continue;
            contrast_lanes(width, m, n, m - width, n - width, row);     /* down: (y - 1, y) */
            raise_to(width, e, row);
            raise_to(width, e - width, row);
        }
        double limit = threshold * (double)first;
        const int64_t *counts = count + base;
        if (run)
            for (int64_t i = lo; i < hi; i++) noisy[i] |= (counts[i] <= first) & (edge[i] > limit);
        else
            for (int64_t k = k0; k < k1; k++) {
                int64_t i = pixels[k] - base;
                if (counts[i] <= first && edge[i] > limit) noisy[i] = 1;
            }
    }
    /* 3. Grow by one pixel in each of the 8 directions (columns, then rows), for rows y0 .. y1 - 1;
     *    keep the region's. */
    for (int64_t y = y0; y < y1; y++) {
        int64_t i0 = (y - a) * width;
        const uint8_t *above = y > 0 ? noisy + i0 - width : noisy + i0;
        const uint8_t *below = y + 1 < height ? noisy + i0 + width : noisy + i0;
        for (int64_t x = 0; x < width; x++) grown[i0 + x] = noisy[i0 + x] | above[x] | below[x];
    }
    for (int64_t y = y0; y < y1; y++) {
        const uint8_t *g = grown + (y - a) * width;
        uint8_t *out = noisy + (y - a) * width;      /* (reused: rows y0 - 1 and y1 are read no more) */
        out[0] = g[0] | (width > 1 ? g[1] : 0);
        for (int64_t x = 1; x + 1 < width; x++) out[x] = g[x - 1] | g[x] | g[x + 1];
        if (width > 1) out[width - 1] = g[width - 2] | g[width - 1];
    }
    int64_t r = 0, from = y0 * width - base, to = y1 * width - base;
    if (run) {
        for (int64_t i = lo > from ? lo : from; i < (hi < to ? hi : to); i++) {
            wanted[r] = base + i;
            r += noisy[i];
        }
        return r;
    }
    for (int64_t k = first_at_least(pixels, p, y0 * width); k < p && pixels[k] < y1 * width; k++)
        if (noisy[pixels[k] - base]) wanted[r++] = pixels[k];
    return r;
}

/* ------------------------------------------------------------------------------------------------
 * Placing copies (core/geometry.py): face normals and turned corner normals, in one pass each
 * --------------------------------------------------------------------------------------------- */

/* normals.safe_normalize of one vector v (3,) into out: v / |v|, or 0 where |v| is 0, infinite or NaN.
 * (|v|^2 summed as numpy's einsum sums three products: the first and last, then the middle.) */
INLINE void unit_or_zero(const double *v, double *out)
{
    double length = sqrt((v[0] * v[0] + v[2] * v[2]) + v[1] * v[1]);
    int ok = isfinite(length) && length > 0.0;
    for (int c = 0; c < 3; c++) out[c] = ok ? v[c] / length : 0.0;
}

/* normals.face_normals: each triangle's unit normal (e1 x e2 normalised, zero where degenerate) and
 * area (0.5 |e1 x e2|, 0 where not finite), the same steps in the same order. vertices (v, 3)
 * float64, triangles (t, 3) int64 -> normals (t, 3), area (t,) float64. */
EXPORT void primer_face_normals(int64_t t, const double *vertices, const int64_t *triangles, double *normals,
                                double *area)
{
    for (int64_t i = 0; i < t; i++) {
        const double *p0 = vertices + 3 * triangles[3 * i], *p1 = vertices + 3 * triangles[3 * i + 1];
        const double *p2 = vertices + 3 * triangles[3 * i + 2];
        double a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        double b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        double n[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        double half = 0.5 * sqrt((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]);      /* (np.linalg.norm's order) */
        area[i] = isfinite(half) ? half : 0.0;
        unit_or_zero(n, normals + 3 * i);
    }
}

/* geometry._place_copies' step 6: corner normals turned by the inverse transpose, N' = N M^-1 (row
 * vectors), normalised. corners (., 3, 3) float64 object-space corner normals, rows (n,) int64 the
 * triangles' rows in it; inverse (p, 3, 3) float64 M^-1 of each placement, placement (n,) int64 each
 * triangle's -> out (n, 3, 3) float64; vectors.rows_times_each and normals.safe_normalize's order. */
EXPORT void primer_turn_normals(int64_t n, const double *corners, const int64_t *rows, const double *inverse,
                                const int64_t *placement, double *out)
{
    for (int64_t i = 0; i < n; i++) {
        const double *A = corners + 9 * rows[i], *B = inverse + 9 * placement[i];
        for (int r = 0; r < 3; r++) {
            double v[3];
            for (int c = 0; c < 3; c++) v[c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
            unit_or_zero(v, out + 9 * i + 3 * r);
        }
    }
}
