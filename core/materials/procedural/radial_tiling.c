/* core/materials/procedural/radial_tiling.py RadialTiling.evaluate at one hit: a[0] the output block (Segment
 * Coordinates, Segment ID, Segment Width, Segment Rotation), a[1] Vector, a[2] Sides, a[3] Roundness, a[4] Normalize
 * (0 or 1). In float32 as Cycles' svm_node_radial_tiling; the branches and names follow radial_tiling.py. */

#define RT_PI 3.1415926535897932f
#define RT_2PI 6.2831853071795864f

/* u on a straight edge: lab tan(|bisector - angle in segment|), negative before the bisector. */
static float rt_straight(float lab, float bisector, float sdc)
{
    float u = lab * tanf(fabsf(bisector - sdc));
    return sdc < bisector ? -u : u;
}

/* u (unsigned) on a rounded corner: the edge's part l sin(a), then the arc's (radial_tiling.py _rounded). */
static float rt_rounded(float l, float a, float cab, float spline)
{
    float c = l * cosf(a);
    float u = l * sinf(a);
    if (cab < spline) return u + (c * cab + 0.5f * (1.0f - c) * (cab * cab) / spline);
    return u + (spline * (0.5f * c - 0.5f) + cab);
}

/* The normalising divisors of u measured from the bisector's length lab and from the point's distance l. */
static float rt_norm_edge(float lab, float a, float spline, float roundness, float bevel)
{
    return lab * tanf(a) + spline * (0.5f * lab + 0.5f) + roundness * bevel;
}

static float rt_norm_arc(float l, float a, float spline, float roundness, float bevel)
{
    return l * sinf(a) + spline * (0.5f * l * cosf(a) + 0.5f) + roundness * bevel;
}

static float rt_mix(float a, float b, float t) { return a + t * (b - a); }

/* (lab, u, width) on the rounded corner of a regular segment; out[0..2]. */
static void rt_regular_rounded(float l, float sab, float snd, float sdc, float r, float sdbs, float bsab,
                               int normalize, float *out)
{
    float ns = sdc - (float)(sdc > sab) * snd;
    float center = (1.0f - r) / cosf(sab);
    float cn = cosf(ns) * center;
    float lab = l / (cn + sqrtf(cn * cn + r * r - center * center));
    float spline = (1.0f - r) * sdbs;
    float cab = sdbs - fabsf(ns);
    float u = rt_rounded(l, bsab, cab, spline);
    if (sdc < sab) u = -u;
    if (normalize)
        u /= rt_mix(rt_norm_edge(lab, bsab, spline, r, sdbs), rt_norm_arc(l, bsab, spline, r, sdbs), cab / sdbs);
    out[0] = lab; out[1] = u; out[2] = tanf(bsab) + spline + r * sdbs;
}

/* Fractional Sides, Roundness > 0 (radial_tiling.py _irregular_circular): out (lab, u, width, rotation). */
static void rt_irregular_circular(float l, float x, float y, float xac, float sab, float snd, float seg, float sdc,
                                  float sides, float r, int normalize, float *out)
{
    float sdbs = sab - atanf((1.0f - r) * tanf(sab));
    float las = RT_PI - floorf(sides) * sab;
    float lsd = 2.0f * las;
    float ilbs = las - atanf((1.0f - r) * tanf(las));
    float radius = r * tanf(las) / tanf(0.5f * (sab + las));
    float d = cosf(las - ilbs);
    float cx = cosf(ilbs) / d - radius * cosf(las);
    float cy = radius * sinf(las) - sinf(ilbs) / d;
    float ox = cx + radius * cosf(sab), oy = cy + radius * sinf(sab);
    float xolbs = atanf(oy / ox);
    float olbs_ab = sab - xolbs;
    float bsab = sab - sdbs;
    float spline = (1.0f - r) * sdbs;
    float width_regular = tanf(bsab) + spline + r * sdbs;
    float effective = 1.0f - tanf(sab - xolbs) / tanf(sab);
    float spline_outer = (1.0f - effective) * xolbs;
    if (xac >= xolbs && xac < RT_2PI - lsd - xolbs) {
        if ((sdc >= sdbs && sdc < snd - sdbs) || xac >= RT_2PI - lsd - sdbs || xac < sdbs) {
            float lab = l * cosf(sab - sdc);
            float u = rt_straight(lab, sab, sdc);
            if (normalize) {
                if (xac >= RT_2PI - lsd - sab || xac < sab)
                    u /= rt_norm_edge(lab, olbs_ab, spline_outer, effective, xolbs);
                else u /= rt_norm_edge(lab, bsab, spline, r, sdbs);
            }
            out[0] = lab; out[1] = u; out[2] = width_regular;
        }
        else {
            rt_regular_rounded(l, sab, snd, sdc, r, sdbs, bsab, normalize, out);
        }
        out[3] = seg * snd + sab;
        return;
    }
    float ilbs_ab = las - ilbs;
    float ratio = cosf(sab) / cosf(las);
    float inner_spline = (1.0f - r) * ilbs;
    float width_last = tanf(ilbs_ab) + ratio * (inner_spline * ((0.5f / ratio) + 0.5f) + r * ilbs);
    if (xac >= RT_2PI - lsd + ilbs && xac < RT_2PI - ilbs) {        /* the last segment's straight edge */
        float lla = l * cosf(las - sdc);
        float lab = ratio * lla;
        float u = rt_straight(lab, las, sdc);
        if (normalize) u /= ratio * rt_norm_edge(lla, ilbs_ab, inner_spline, r, ilbs);
        out[0] = lab; out[1] = u; out[2] = width_last; out[3] = seg * snd + las;
        return;
    }
    /* The arcs joining the last segment to its neighbours (mirrored about the last bisector). */
    float m = atan2f(y, x);
    if (xac >= RT_2PI - lsd - xolbs && xac < RT_2PI - las) m = -(m + lsd);
    float t = sinf(m) * cy + cosf(m) * cx;
    float lla = l / (t + sqrtf(t * t + radius * radius - cx * cx - cy * cy));
    float lab = ratio * lla;
    float u;
    if (m < 0.0f) {
        float cab = ilbs - fabsf(m);
        float c = l * cosf(ilbs_ab);
        u = ratio * l * sinf(ilbs_ab);
        if (cab < inner_spline) u += ratio * (c * cab + 0.5f * (1.0f - c) * (cab * cab) / inner_spline);
        else u += ratio * (inner_spline * (0.5f * c - 0.5f) + cab);
        if (sdc < las) u = -u;
        if (normalize)
            u /= ratio * rt_mix(rt_norm_edge(lla, ilbs_ab, inner_spline, r, ilbs),
                                rt_norm_arc(l, ilbs_ab, inner_spline, r, ilbs), cab / ilbs);
        out[2] = width_last; out[3] = seg * snd + las;
    }
    else {
        float cab = xolbs - fabsf(m);
        u = rt_rounded(l, olbs_ab, cab, spline_outer);
        if (sdc < sab) u = -u;
        if (normalize)
            u /= rt_mix(rt_norm_edge(lab, olbs_ab, spline_outer, effective, xolbs),
                        rt_norm_arc(l, olbs_ab, spline_outer, effective, xolbs), cab / xolbs);
        out[2] = width_regular; out[3] = seg * snd + sab;
    }
    out[0] = lab; out[1] = u;
}

/* Cycles' calculate_out_variables at one point: out (v, u, Segment Width, Segment Rotation). */
static void rt_out_variables(int normalize, float sides, float r, float x, float y, float *out)
{
    float l = sqrtf(x * x + y * y);
    float xac = atan2f(y, x) + (float)(y < 0.0f) * RT_2PI;
    float sab = RT_PI / sides;
    float snd = 2.0f * sab;
    float seg = floorf(xac / snd);
    float sdc = xac - seg * snd;
    float rotation = seg * snd + sab;
    if (sides - floorf(sides) == 0.0f) {
        if (r == 0.0f) {                                        /* a sharp regular polygon */
            float lab = l * cosf(sab - sdc);
            float u = rt_straight(lab, sab, sdc);
            if (normalize && sides != 2.0f) u /= lab * tanf(sab);
            out[0] = lab; out[1] = u; out[2] = sides != 2.0f ? tanf(sab) : 0.0f; out[3] = rotation;
        }
        else if (r == 1.0f) {                                   /* circles */
            float u = fabsf(sab - sdc);
            if (sdc < sab) u = -u;
            if (normalize) u /= sab;
            out[0] = l; out[1] = u; out[2] = sab; out[3] = rotation;
        }
        else {
            float sdbs = sab - atanf((1.0f - r) * tanf(sab));
            float bsab = sab - sdbs;
            if (sdc >= snd - sdbs || sdc < sdbs) {
                rt_regular_rounded(l, sab, snd, sdc, r, sdbs, bsab, normalize, out);
            }
            else {
                float lab = l * cosf(sab - sdc);
                float spline = (1.0f - r) * sdbs;
                float u = rt_straight(lab, sab, sdc);
                if (normalize) u /= rt_norm_edge(lab, bsab, spline, r, sdbs);
                out[0] = lab; out[1] = u; out[2] = tanf(bsab) + spline + r * sdbs;
            }
            out[3] = rotation;
        }
    }
    else if (r == 0.0f) {
        float las = RT_PI - floorf(sides) * sab;
        if (xac < RT_2PI - 2.0f * las) {                        /* the regular segments */
            float lab = l * cosf(sab - sdc);
            float u = rt_straight(lab, sab, sdc);
            if (normalize) u /= lab * tanf(sab);
            out[0] = lab; out[1] = u; out[2] = tanf(sab); out[3] = rotation;
        }
        else {                                                  /* the last, narrower one */
            float ratio = cosf(sab) / cosf(las);
            float lla = l * cosf(las - sdc);
            float lab = ratio * lla;
            float u = rt_straight(lab, las, sdc);
            if (normalize) u /= ratio * lla * tanf(las);
            out[0] = lab; out[1] = u; out[2] = tanf(las); out[3] = seg * snd + las;
        }
    }
    else {
        rt_irregular_circular(l, x, y, xac, sab, snd, seg, sdc, sides, r, normalize, out);
    }
    if (x == 0.0f && y == 0.0f) out[1] = 0.0f;
    if (normalize) out[1] = 0.5f * out[1] + 0.5f;
    else out[0] -= 1.0f;
}

INLINE void radial_tiling_texture(const int *a, double *reg)
{
    float x = (float)reg[a[1]], y = (float)reg[a[1] + 1];
    float sides = fmaxf((float)reg[a[2]], 2.0f);
    float r = fminf(fmaxf((float)reg[a[3]], 0.0f), 1.0f);
    float v[4];
    rt_out_variables(a[4], sides, r, x, y, v);
    double *out = reg + a[0];
    out[0] = (double)v[1]; out[1] = (double)v[0]; out[2] = 0.0;
    out[3] = (double)floorf(sides * ((atan2f(y, x) / RT_2PI) + (float)(y < 0.0f)));
    out[4] = (double)v[2]; out[5] = (double)v[3];
}
