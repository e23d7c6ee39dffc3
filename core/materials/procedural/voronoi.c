/* core/materials/procedural/voronoi.py at one hit, operation for operation: a[0] the output block (Distance, Color,
 * Position, W, Radius), a[1] Vector, a[2] W, a[3] Scale, a[4] Detail, a[5] Roughness, a[6] Lacunarity,
 * a[7] Smoothness, a[8] Exponent, a[9] Randomness; a[10] the dimensions - 1, a[11] the feature (FEATURES),
 * a[12] the metric (METRICS), a[13] normalize. Points are float arrays of d = 1..4 components. */

#include <float.h>

typedef struct VoronoiParams {
    float scale, detail, roughness, lacunarity, smoothness, exponent, randomness, max_distance;
    int metric, normalize, feature;
} VoronoiParams;

/* voronoi.py total */
INLINE float voronoi_total(const float *v, int d)
{
    if (d == 4) return (v[0] + v[1]) + (v[2] + v[3]);
    float s = v[0];
    for (int k = 1; k < d; k++) s += v[k];
    return s;
}

/* voronoi.py power */
INLINE float voronoi_pow(float x, float e) { return (float)pow((double)x, (double)e); }

/* voronoi.py distance */
INLINE float voronoi_distance(const float *a, const float *b, int d, const VoronoiParams *P, int bound)
{
    if (d == 1) return fabsf(b[0] - a[0]);
    float t[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    switch (P->metric) {
    case 0: {
        for (int k = 0; k < d; k++) t[k] = (a[k] - b[k]) * (a[k] - b[k]);
        float s = voronoi_total(t, d);
        return bound ? s : sqrtf(s);
    }
    case 1:
        for (int k = 0; k < d; k++) t[k] = fabsf(a[k] - b[k]);
        return voronoi_total(t, d);
    case 2: {
        float m = fabsf(a[0] - b[0]);
        for (int k = 1; k < d; k++) { float x = fabsf(a[k] - b[k]); m = x > m ? x : m; }
        return m;
    }
    default: {
        for (int k = 0; k < d; k++) t[k] = voronoi_pow(fabsf(a[k] - b[k]), P->exponent);
        float s = voronoi_total(t, d);
        return bound ? s : voronoi_pow(s, 1.0f / P->exponent);
    }
    }
}

/* voronoi.py dot */
INLINE float voronoi_dot(const float *a, const float *b, int d)
{
    float t[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int k = 0; k < d; k++) t[k] = a[k] * b[k];
    return voronoi_total(t, d);
}

/* voronoi.py offsets: the index-th offset of -reach..reach per axis, x fastest. */
INLINE void voronoi_offset(int index, int d, int reach, int *offset)
{
    for (int k = 0; k < d; k++) {
        offset[k] = index % (2 * reach + 1) - reach;
        index /= 2 * reach + 1;
    }
}

/* voronoi.py split */
INLINE void voronoi_split(const float *coord, int d, int *cell, float *cell_f, float *local)
{
    for (int k = 0; k < d; k++) {
        cell_f[k] = floorf(coord[k]);
        cell[k] = (int)cell_f[k];
        local[k] = coord[k] - cell_f[k];
    }
}

/* voronoi.py cell_point */
INLINE void voronoi_cell_point(const int *cell, const float *cell_f, const int *offset, int d, float randomness,
                               float *point)
{
    if (d == 1) {
        float o = (float)offset[0];
        point[0] = o + hash_float(cell_f[0] + o) * randomness;
        return;
    }
    int k[4] = {0};
    float h[4] = {0.0f};
    for (int j = 0; j < d; j++) k[j] = cell[j] + offset[j];
    hash_int_to_float(k, d, h);
    for (int j = 0; j < d; j++) point[j] = (float)offset[j] + h[j] * randomness;
}

/* voronoi.py cell_color */
INLINE void voronoi_cell_color(const int *cell, const float *cell_f, const int *offset, int d, float *color)
{
    if (d == 1) {
        float x = cell_f[0] + (float)offset[0];
        color[0] = hash_float(x); color[1] = hash_float2(x, 1.0f); color[2] = hash_float2(x, 2.0f);
        return;
    }
    int k[4] = {0};
    for (int j = 0; j < d; j++) k[j] = cell[j] + offset[j];
    hash_int_to_float3(k, d, color);
}

/* An octave's distance, colour and position (d components). */
typedef struct VoronoiOctave { float distance, color[3], position[4]; } VoronoiOctave;

/* voronoi.py f1 */
INLINE void voronoi_f1(const float *coord, int d, const VoronoiParams *P, VoronoiOctave *out)
{
    int cell[4] = {0}, offset[4] = {0}, target[4] = {0, 0, 0, 0};
    float cell_f[4] = {0.0f}, local[4] = {0.0f}, point[4] = {0.0f}, position[4] = {0, 0, 0, 0}, best = FLT_MAX;
    voronoi_split(coord, d, cell, cell_f, local);
    int count = d == 1 ? 3 : d == 2 ? 9 : d == 3 ? 27 : 81;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 1, offset);
        voronoi_cell_point(cell, cell_f, offset, d, P->randomness, point);
        float dist = voronoi_distance(point, local, d, P, 1);
        if (dist < best) {
            best = dist;
            for (int k = 0; k < d; k++) { target[k] = offset[k]; position[k] = point[k]; }
        }
    }
    out->distance = voronoi_distance(position, local, d, P, 0);
    voronoi_cell_color(cell, cell_f, target, d, out->color);
    for (int k = 0; k < d; k++) out->position[k] = position[k] + cell_f[k];
}

/* voronoi.py f2 */
INLINE void voronoi_f2(const float *coord, int d, const VoronoiParams *P, VoronoiOctave *out)
{
    int cell[4] = {0}, offset[4] = {0}, o1[4] = {0, 0, 0, 0}, o2[4] = {0, 0, 0, 0};
    float cell_f[4] = {0.0f}, local[4] = {0.0f}, point[4] = {0.0f};
    float p1[4] = {0, 0, 0, 0}, p2[4] = {0, 0, 0, 0}, d1 = FLT_MAX, d2 = FLT_MAX;
    voronoi_split(coord, d, cell, cell_f, local);
    int count = d == 1 ? 3 : d == 2 ? 9 : d == 3 ? 27 : 81;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 1, offset);
        voronoi_cell_point(cell, cell_f, offset, d, P->randomness, point);
        float dist = voronoi_distance(point, local, d, P, 0);
        if (dist < d1) {
            d2 = d1; d1 = dist;
            for (int k = 0; k < d; k++) { o2[k] = o1[k]; o1[k] = offset[k]; p2[k] = p1[k]; p1[k] = point[k]; }
        } else if (dist < d2) {
            d2 = dist;
            for (int k = 0; k < d; k++) { o2[k] = offset[k]; p2[k] = point[k]; }
        }
    }
    out->distance = d2;
    voronoi_cell_color(cell, cell_f, o2, d, out->color);
    for (int k = 0; k < d; k++) out->position[k] = p2[k] + cell_f[k];
}

/* voronoi.py smoothstep */
INLINE float voronoi_smoothstep(float x) { return x < 0.0f ? 0.0f : (x >= 1.0f ? 1.0f : (3.0f - 2.0f * x) * (x * x)); }

/* voronoi.py smooth_f1 */
INLINE void voronoi_smooth_f1(const float *coord, int d, const VoronoiParams *P, VoronoiOctave *out)
{
    int cell[4] = {0}, offset[4] = {0};
    float cell_f[4] = {0.0f}, local[4] = {0.0f}, point[4] = {0.0f}, color[3] = {0.0f};
    float sd = 0.0f, sc[3] = {0, 0, 0}, sp[4] = {0, 0, 0, 0}, h = -1.0f, s = P->smoothness;
    voronoi_split(coord, d, cell, cell_f, local);
    int count = d == 1 ? 5 : d == 2 ? 25 : d == 3 ? 125 : 625;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 2, offset);
        voronoi_cell_point(cell, cell_f, offset, d, P->randomness, point);
        float dist = voronoi_distance(point, local, d, P, 0);
        h = h == -1.0f ? 1.0f : voronoi_smoothstep(0.5f + 0.5f * (sd - dist) / s);
        float correction = s * h * (1.0f - h);
        sd = (sd + h * (dist - sd)) - correction;
        correction = correction / (1.0f + 3.0f * s);
        voronoi_cell_color(cell, cell_f, offset, d, color);
        for (int k = 0; k < 3; k++) sc[k] = (sc[k] + h * (color[k] - sc[k])) - correction;
        for (int k = 0; k < d; k++) sp[k] = (sp[k] + h * (point[k] - sp[k])) - correction;
    }
    out->distance = sd;
    for (int k = 0; k < 3; k++) out->color[k] = sc[k];
    for (int k = 0; k < d; k++) out->position[k] = cell_f[k] + sp[k];
}

/* voronoi.py distance_to_edge */
INLINE float voronoi_distance_to_edge(const float *coord, int d, float randomness)
{
    int cell[4] = {0}, offset[4] = {0};
    float cell_f[4] = {0.0f}, local[4] = {0.0f}, point[4] = {0.0f}, to_point[4] = {0.0f};
    float closest[4] = {0, 0, 0, 0}, best = FLT_MAX;
    voronoi_split(coord, d, cell, cell_f, local);
    if (d == 1) {
        float x = local[0], mid = hash_float(cell_f[0]) * randomness;
        float left = -1.0f + hash_float(cell_f[0] - 1.0f) * randomness;
        float right = 1.0f + hash_float(cell_f[0] + 1.0f) * randomness;
        float a = fabsf((mid + left) / 2.0f - x), b = fabsf((mid + right) / 2.0f - x);
        return a < b ? a : b;
    }
    int count = d == 2 ? 9 : d == 3 ? 27 : 81;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 1, offset);
        voronoi_cell_point(cell, cell_f, offset, d, randomness, point);
        for (int k = 0; k < d; k++) to_point[k] = point[k] - local[k];
        float dist = voronoi_dot(to_point, to_point, d);
        if (dist < best) { best = dist; for (int k = 0; k < d; k++) closest[k] = to_point[k]; }
    }
    best = FLT_MAX;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 1, offset);
        voronoi_cell_point(cell, cell_f, offset, d, randomness, point);
        float across[4] = {0.0f}, unit[4] = {0.0f}, middle[4] = {0.0f};
        for (int k = 0; k < d; k++) { to_point[k] = point[k] - local[k]; across[k] = to_point[k] - closest[k]; }
        if (voronoi_dot(across, across, d) > 0.0001f) {
            float length = sqrtf(voronoi_dot(across, across, d)), inverse = 1.0f / length;
            for (int k = 0; k < d; k++) {
                unit[k] = d == 3 ? across[k] / length : across[k] * inverse;
                middle[k] = (closest[k] + to_point[k]) / 2.0f;
            }
            float edge = voronoi_dot(middle, unit, d);
            best = edge < best ? edge : best;
        }
    }
    return best;
}

/* voronoi.py n_sphere_radius */
INLINE float voronoi_n_sphere_radius(const float *coord, int d, float randomness)
{
    int cell[4] = {0}, offset[4] = {0}, closest_offset[4] = {0, 0, 0, 0};
    float cell_f[4] = {0.0f}, local[4] = {0.0f}, point[4] = {0.0f}, gap[4] = {0.0f};
    float closest[4] = {0, 0, 0, 0}, other[4] = {0, 0, 0, 0}, best = FLT_MAX;
    voronoi_split(coord, d, cell, cell_f, local);
    int count = d == 1 ? 3 : d == 2 ? 9 : d == 3 ? 27 : 81;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 1, offset);
        voronoi_cell_point(cell, cell_f, offset, d, randomness, point);
        for (int k = 0; k < d; k++) gap[k] = point[k] - local[k];
        float dist = d == 1 ? fabsf(gap[0]) : voronoi_dot(gap, gap, d);
        if (dist < best) {
            best = dist;
            for (int k = 0; k < d; k++) { closest[k] = point[k]; closest_offset[k] = offset[k]; }
        }
    }
    best = FLT_MAX;
    for (int index = 0; index < count; index++) {
        voronoi_offset(index, d, 1, offset);
        int any = 0, moved[4] = {0};
        for (int k = 0; k < d; k++) { any |= offset[k] != 0; moved[k] = closest_offset[k] + offset[k]; }
        if (!any) continue;
        voronoi_cell_point(cell, cell_f, moved, d, randomness, point);
        for (int k = 0; k < d; k++) gap[k] = closest[k] - point[k];
        float dist = d == 1 ? fabsf(gap[0]) : voronoi_dot(gap, gap, d);
        if (dist < best) { best = dist; for (int k = 0; k < d; k++) other[k] = point[k]; }
    }
    for (int k = 0; k < d; k++) gap[k] = other[k] - closest[k];
    float length = d == 1 ? fabsf(gap[0]) : sqrtf(voronoi_dot(gap, gap, d));
    return length / 2.0f;
}

/* voronoi.py fractal */
INLINE void voronoi_fractal_in(const float *coord, int d, const VoronoiParams *P, VoronoiOctave *out)
{
    float amplitude = 1.0f, max_amplitude = 0.0f, scale = 1.0f, p[4] = {0.0f}, moved[4] = {0.0f}, inverse;
    int zero_input = P->detail == 0.0f || P->roughness == 0.0f;
    out->distance = 0.0f;
    for (int k = 0; k < 3; k++) out->color[k] = 0.0f;
    for (int k = 0; k < 4; k++) out->position[k] = 0.0f;
    for (int i = 0; i <= ceilf(P->detail); i++) {
        VoronoiOctave octave;
        for (int k = 0; k < d; k++) p[k] = coord[k] * scale;
        if (P->feature == 1) voronoi_f2(p, d, P, &octave);
        else if (P->feature == 2 && P->smoothness != 0.0f) voronoi_smooth_f1(p, d, P, &octave);
        else voronoi_f1(p, d, P, &octave);
        if (zero_input) {
            max_amplitude = 1.0f;
            *out = octave;
            break;
        }
        inverse = 1.0f / scale;
        for (int k = 0; k < d; k++) moved[k] = octave.position[k] * inverse;
        if (i <= P->detail) {
            max_amplitude += amplitude;
            out->distance += octave.distance * amplitude;
            for (int k = 0; k < 3; k++) out->color[k] += octave.color[k] * amplitude;
            for (int k = 0; k < d; k++) out->position[k] += amplitude * (moved[k] - out->position[k]);
            scale *= P->lacunarity;
            amplitude *= P->roughness;
        } else {
            float r = P->detail - floorf(P->detail);
            if (r != 0.0f) {
                max_amplitude += r * ((max_amplitude + amplitude) - max_amplitude);
                out->distance += r * ((out->distance + octave.distance * amplitude) - out->distance);
                for (int k = 0; k < 3; k++)
                    out->color[k] += r * ((out->color[k] + octave.color[k] * amplitude) - out->color[k]);
                for (int k = 0; k < d; k++) {
                    float inner = out->position[k] + amplitude * (moved[k] - out->position[k]);
                    out->position[k] += r * (inner - out->position[k]);
                }
            }
        }
    }
    if (P->normalize) {
        out->distance /= max_amplitude * P->max_distance;
        for (int k = 0; k < 3; k++) out->color[k] /= max_amplitude;
    }
    inverse = 1.0f / P->scale;
    for (int k = 0; k < d; k++) out->position[k] = P->scale != 0.0f ? out->position[k] * inverse : 0.0f;
}

/* voronoi_fractal in three dimensions, the common case: d a constant, so that the cell loops unroll. */
NOINLINE static void voronoi_fractal_3(const float *coord, const VoronoiParams *P, VoronoiOctave *out)
{
    voronoi_fractal_in(coord, 3, P, out);
}

/* voronoi_fractal in d = 1, 2 or 4 dimensions. */
NOINLINE static void voronoi_fractal_any(const float *coord, int d, const VoronoiParams *P, VoronoiOctave *out)
{
    voronoi_fractal_in(coord, d, P, out);
}

/* voronoi.py fractal: the octaves' feature at coord (d components) summed. */
INLINE void voronoi_fractal(const float *coord, int d, const VoronoiParams *P, VoronoiOctave *out)
{
    if (d == 3) voronoi_fractal_3(coord, P, out);
    else voronoi_fractal_any(coord, d, P, out);
}

/* voronoi.py fractal_distance_to_edge */
INLINE float voronoi_fractal_distance_to_edge(const float *coord, int d, const VoronoiParams *P)
{
    float amplitude = 1.0f, max_amplitude = P->max_distance, scale = 1.0f, distance = 8.0f, p[4] = {0.0f};
    int zero_input = P->detail == 0.0f || P->roughness == 0.0f;
    for (int i = 0; i <= ceilf(P->detail); i++) {
        for (int k = 0; k < d; k++) p[k] = coord[k] * scale;
        float octave = voronoi_distance_to_edge(p, d, P->randomness);
        if (zero_input) { distance = octave; break; }
        float smaller = octave / scale;
        smaller = distance < smaller ? distance : smaller;
        float full_max = max_amplitude + amplitude * (P->max_distance / scale - max_amplitude);
        float full = distance + amplitude * (smaller - distance);
        if (i <= P->detail) {
            max_amplitude = full_max;
            distance = full;
            scale *= P->lacunarity;
            amplitude *= P->roughness;
        } else {
            float r = P->detail - floorf(P->detail);
            if (r != 0.0f) {
                max_amplitude = max_amplitude + r * (full_max - max_amplitude);
                float least = distance < full ? distance : full;
                distance = distance + r * (least - distance);
            }
        }
    }
    if (P->normalize) distance /= max_amplitude;
    return distance;
}

NOINLINE static void voronoi_texture(const int *a, double *reg)
{
    VoronoiParams P;
    int d = a[10] + 1;
    P.feature = a[11]; P.metric = a[12]; P.normalize = a[13];
    P.scale = (float)reg[a[3]];
    P.detail = (float)reg[a[4]]; P.roughness = (float)reg[a[5]]; P.lacunarity = (float)reg[a[6]];
    P.smoothness = (float)reg[a[7]] / 2.0f; P.exponent = (float)reg[a[8]]; P.randomness = (float)reg[a[9]];
    P.detail = P.detail < 0.0f ? 0.0f : (P.detail > 15.0f ? 15.0f : P.detail);
    P.roughness = P.roughness < 0.0f ? 0.0f : (P.roughness > 1.0f ? 1.0f : P.roughness);
    P.randomness = P.randomness < 0.0f ? 0.0f : (P.randomness > 1.0f ? 1.0f : P.randomness);
    P.smoothness = P.smoothness < 0.0f ? 0.0f : (P.smoothness > 0.5f ? 0.5f : P.smoothness);
    float coord[4] = {0.0f}, v[3] = {0.0f}, w = (float)reg[a[2]] * P.scale;
    for (int k = 0; k < 3; k++) v[k] = (float)reg[a[1] + k] * P.scale;
    if (d == 1) coord[0] = w;
    else { for (int k = 0; k < d && k < 3; k++) coord[k] = v[k]; if (d == 4) coord[3] = w; }
    double *out = reg + a[0];
    for (int k = 0; k < 9; k++) out[k] = 0.0;
    float half = 0.5f + 0.5f * P.randomness;
    if (P.feature == 3) {
        P.max_distance = half;
        out[0] = (double)voronoi_fractal_distance_to_edge(coord, d, &P);
        return;
    }
    if (P.feature == 4) {
        out[8] = (double)voronoi_n_sphere_radius(coord, d, P.randomness);
        return;
    }
    float reach = half;
    if (d > 1) {
        float zero[4] = {0, 0, 0, 0}, corner[4] = {half, half, half, half};
        reach = voronoi_distance(zero, corner, d, &P, 0);
    }
    P.max_distance = reach * (P.feature == 1 ? 2.0f : 1.0f);
    VoronoiOctave result;
    voronoi_fractal(coord, d, &P, &result);
    out[0] = (double)result.distance;
    for (int k = 0; k < 3; k++) out[1 + k] = (double)result.color[k];
    if (d == 1) out[7] = (double)result.position[0];
    else {
        for (int k = 0; k < d && k < 3; k++) out[4 + k] = (double)result.position[k];
        if (d == 4) out[7] = (double)result.position[3];
    }
}
