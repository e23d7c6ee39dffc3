/* What every part of Primer's C code shares: the platform's words, small vector helpers, a clock.
 *
 * The C code is the compiled twin of the Python reference in core/: each part's C file sits beside
 * the Python it mirrors (core/lights/point.c beside core/lights/point.py, ...) and computes the same
 * float64 numbers in the same order of steps. core/native/primer.c includes every part's file into
 * one library (one translation unit, so that the compiler can inline across parts).
 *
 * Conventions. Arrays arrive from numpy as contiguous row-major buffers: an (n, 3) float64 array is
 * `double *` with row i at [3 i]. Records made in Python (a light, the camera, a chunk's
 * parameters) hold only doubles and pointers, so their layout is the same on every compiler. No
 * function keeps state or allocates, so any number of threads may call them at once; ctypes
 * releases Python's GIL around each call.
 */
#ifndef PRIMER_H
#define PRIMER_H

#define _POSIX_C_SOURCE 199309L   /* clock_gettime */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <time.h>

#define PI 3.14159265358979323846
#define FLOAT32_EPSILON (1.0 / 16777216.0)   /* 2^-24, core/integrators/shadows.py */
#define ROBUST_ULPS 8.0
#define T_INFINITY 1e37f                    /* core/geometry/intersect.py: Embree's "infinite" t_far */

/* Exported by name: a DLL's export table on Windows (MSVC or MinGW), default visibility elsewhere
 * (the build hides every other symbol with -fvisibility=hidden). */
#if defined(_WIN32)
#define EXPORT __declspec(dllexport)
#else
#define EXPORT __attribute__((visibility("default")))
#endif

/* MSVC's spellings, and GCC's and Clang's (MinGW's headers define __forceinline as `extern inline`,
 * which cannot be static, so a Clang or GCC build for Windows takes the attributes too).
 * INLINE functions are inlined at every call. The few large ones called from several places once per hit
 * (the node-graph interpreter run_program, shade_graph, gather_light, graph_emission, through_transparent)
 * are `NOINLINE static` instead: inlined everywhere, they made the one translation unit take 9.5 minutes of
 * GCC -O3 (2.9 without), for 2.5 % fewer instructions (callgrind, a path-traced emitter scene). So are the
 * integrators' per-block steps called from both integrate and trace_paths (trace_paths, direct_light, bsdf_rays,
 * choose_bsdf_rays, passes_at_vertex): inlined twice they made integrate 1.6 MB of code and the -O3 build over
 * 12 minutes of CPU (4 without). tests/test_kernel_functions.py keeps every function under 700 kB. */
#if defined(_MSC_VER)
#define INLINE static __forceinline
#define NOINLINE __declspec(noinline)
#define BYTE_SWAP(x) _byteswap_ulong(x)
#define ALIGNED(n) __declspec(align(n))
#else
#define INLINE static inline __attribute__((always_inline))
#define NOINLINE __attribute__((noinline))
#define BYTE_SWAP(x) __builtin_bswap32(x)
#define ALIGNED(n) __attribute__((aligned(n)))
#endif

/* The loops over blocks of samples are compiled twice on x86-64 Linux with GCC: for any x86-64
 * (SSE2, 2 doubles per instruction) and for x86-64-v3 (AVX2, 4 doubles), and the loader picks the
 * one the processor runs (an ifunc). Both compute the same numbers: no fused multiply-add either
 * way. Elsewhere they are compiled once, for the compiler's default target. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define SIMD_CLONES
#endif

/* Samples are handled BLOCK at a time, one quantity per column (structure of arrays): each step is
 * then one loop over the block's lanes with no branches, which the compiler turns into SIMD. */
#define BLOCK 64

/* ------------------------------------------------------------------------------------------------
 * Small vector helpers
 * --------------------------------------------------------------------------------------------- */

INLINE double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* max(x, floor) and min(x, ceiling): as fmax / fmin (a NaN x gives the bound), but vectorizable. */
INLINE double at_least(double x, double floor) { return x > floor ? x : floor; }
INLINE double at_most(double x, double ceiling) { return x < ceiling ? x : ceiling; }
INLINE double clamp01(double x) { return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x); }

INLINE double largest3(const double *a)
{
    double m = fabs(a[0]);
    if (fabs(a[1]) > m) m = fabs(a[1]);
    if (fabs(a[2]) > m) m = fabs(a[2]);
    return m;
}

/* Unit direction and distance from p to q (a zero vector where they coincide): lights.base.direction_to. */
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

/* Two unit vectors completing a unit axis to an orthonormal frame: vectors.orthonormal_frame. */
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
 * A clock for Embree's share of the time
 * --------------------------------------------------------------------------------------------- */

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

/* The render times Embree's queries block by block, thousands of times a chunk. Reading the clock
 * costs about 100 ns under a hypervisor, so it counts the processor's time-stamp counter instead (a
 * few ns), and a Stopwatch turns the ticks into seconds with the clock read at both ends of the
 * call. Elsewhere a tick is a nanosecond of the clock. */
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

#endif
