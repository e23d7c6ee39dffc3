/* Node graphs: core/materials/graph.py. A material's compiled program (ops on numbered registers) run
 * at one hit; its outputs overwrite the shader nodes' inputs, weights and normals before the setups. */

/* The op codes (OP_*), the path's flags (PATH_*) and record (LightPath), the Light Path outputs (LP_*), the outputs
 * (OUT_*), OP_WIDTH, MAX_REGISTERS and BUMP_STEP come from core/materials/graph.py (core/native/boundary.gen.h). */

/* The ShadingPoint a program reads: core/geometry/triangles.c. */

/* graph.safe_divide: a / b, 0 where b is 0. */
INLINE double safe_div(double a, double b) { return b != 0.0 ? a / b : 0.0; }

/* graph.smooth_min */
INLINE double smooth_min(double a, double b, double k)
{
    double m = a < b ? a : (b < a ? b : (a != a ? a : b));
    if (k == 0.0) return m;
    double gap = k - fabs(a - b), h = (gap > 0.0 ? gap : 0.0) / k;
    return m - h * h * h * k * (1.0 / 6.0);
}

/* graph.math_op */
INLINE double math_op(int op, double a, double b, double c)
{
    switch (op) {
    case 0: return a + b;
    case 1: return a - b;
    case 2: return a * b;
    case 3: return safe_div(a, b);
    case 4: return a * b + c;
    case 5: if (a < 0.0 && b != trunc(b)) return 0.0; return b == 0.0 ? 1.0 : pow(a, b);
    case 6: return (a > 0.0 && b > 0.0) ? safe_div(log(a), log(b)) : 0.0;
    case 7: return a > 0.0 ? sqrt(a) : 0.0;
    case 8: return a > 0.0 ? 1.0 / sqrt(a) : 0.0;
    case 9: return fabs(a);
    case 10: return exp(a);
    case 11: return a < b ? a : (b < a ? b : (a != a ? a : b));
    case 12: return a > b ? a : (b > a ? b : (a != a ? a : b));
    case 13: return a < b ? 1.0 : 0.0;
    case 14: return a > b ? 1.0 : 0.0;
    case 15: return a > 0.0 ? 1.0 : (a < 0.0 ? -1.0 : a);
    case 16: return fabs(a - b) <= (c > 1e-5 ? c : 1e-5) ? 1.0 : 0.0;
    case 17: return floor(a + 0.5);
    case 18: return floor(a);
    case 19: return ceil(a);
    case 20: return trunc(a);
    case 21: return a - floor(a);
    case 22: return b != 0.0 ? fmod(a, b) : 0.0;
    case 23: return b != 0.0 ? a - floor(a / b) * b : 0.0;
    case 24: { double span = b - c; return span != 0.0 ? a - span * floor((a - c) / span) : c; }
    case 25: return floor(safe_div(a, b)) * b;
    case 26: { if (b == 0.0) return 0.0; double x = (a - b) / (b * 2.0); return fabs((x - floor(x)) * b * 2.0 - b); }
    case 27: return sin(a);
    case 28: return cos(a);
    case 29: return tan(a);
    case 30: return asin(a < -1.0 ? -1.0 : (a > 1.0 ? 1.0 : a));
    case 31: return acos(a < -1.0 ? -1.0 : (a > 1.0 ? 1.0 : a));
    case 32: return atan(a);
    case 33: return atan2(a, b);
    case 34: return sinh(a);
    case 35: return cosh(a);
    case 36: return tanh(a);
    case 37: return a * (PI / 180.0);
    case 38: return a * (180.0 / PI);
    case 39: return smooth_min(a, b, c);
    case 40: return -smooth_min(-a, -b, c);
    default: return 0.0;
    }
}

/* graph.mix_color for one channel. */
INLINE double mix_channel(int blend, double t, double c1, double c2)
{
    double tm = 1.0 - t;
    switch (blend) {
    case 0: return tm * c1 + t * c2;
    case 1: return tm * c1 + t * (c1 < c2 ? c1 : c2);
    case 2: return c1 * (tm + t * c2);
    case 3: { double tmp = tm + t * c2; return tmp <= 0.0 ? 0.0 : clamp01(1.0 - safe_div(1.0 - c1, tmp)); }
    case 4: return tm * c1 + t * (c1 > c2 ? c1 : c2);
    case 5: return 1.0 - (tm + t * (1.0 - c2)) * (1.0 - c1);
    case 6: {
        if (c1 == 0.0) return c1;
        double tmp = 1.0 - t * c2;
        if (tmp <= 0.0) return 1.0;
        double q = safe_div(c1, tmp);
        return q < 1.0 ? q : 1.0;
    }
    case 7: return tm * c1 + t * (c1 + c2);
    case 8: return c1 < 0.5 ? c1 * (tm + 2.0 * t * c2) : 1.0 - (tm + 2.0 * t * (1.0 - c2)) * (1.0 - c1);
    case 9: return tm * c1 + t * (c1 - c2);
    case 10: return c2 != 0.0 ? tm * c1 + t * safe_div(c1, c2) : c1;
    case 11: return tm * c1 + t * fabs(c1 - c2);
    case 12: { double v = tm * c1 + t * (c1 + c2 - 2.0 * c1 * c2); return v > 0.0 ? v : 0.0; }
    case 13: { double screen = 1.0 - (1.0 - c2) * (1.0 - c1); return tm * c1 + t * ((1.0 - c1) * c2 * c1 + c1 * screen); }
    case 14: return c1 + t * (2.0 * c2 - 1.0);
    default: return c1;
    }
}

/* graph.mix_hsv: the blends 15 to 18 (Hue, Saturation, Value, Color) in float32. */
INLINE void mix_hsv(int blend, double td, const double *c1, const double *c2, double *out)
{
    float t = (float)td, a[3], b[3], hsv[3], hsv2[3], rgb[3];
    for (int j = 0; j < 3; j++) { a[j] = (float)c1[j]; b[j] = (float)c2[j]; rgb[j] = a[j]; }
    rgb_to_hsv_f(a, hsv);
    rgb_to_hsv_f(b, hsv2);
    if (blend == 15 || blend == 18) {
        if (hsv2[1] != 0.0f) {
            float mixed[3];
            hsv[0] = hsv2[0];
            if (blend == 18) hsv[1] = hsv2[1];
            hsv_to_rgb_f(hsv, mixed);
            for (int j = 0; j < 3; j++) rgb[j] = a[j] + t * (mixed[j] - a[j]);
        }
    } else if (blend == 16) {
        if (hsv[1] != 0.0f) {
            hsv[1] = (1.0f - t) * hsv[1] + t * hsv2[1];
            hsv_to_rgb_f(hsv, rgb);
        }
    } else {
        hsv[2] = (1.0f - t) * hsv[2] + t * hsv2[2];
        hsv_to_rgb_f(hsv, rgb);
    }
    for (int j = 0; j < 3; j++) out[j] = rgb[j];
}

/* graph.safe_normalize: v / |v| in place, 0 where |v| is 0. */
INLINE void safe_normalize3(double *v)
{
    double length = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int j = 0; j < 3; j++) v[j] = length > 0.0 ? v[j] / length : 0.0;
}

/* graph.map_range */
INLINE double map_range(int kind, int clamp, double value, double from_min, double from_max, double to_min,
                        double to_max, double steps)
{
    double factor;
    if (kind <= 1) {
        factor = safe_div(value - from_min, from_max - from_min);
        if (kind == 1) factor = steps > 0.0 ? floor(factor * (steps + 1.0)) / steps : 0.0;
        double result = to_min + factor * (to_max - to_min);
        if (clamp) {
            double lo = to_min > to_max ? to_max : to_min, hi = to_min > to_max ? to_min : to_max;
            result = result < lo ? lo : (result > hi ? hi : result);
        }
        return result;
    }
    double e0 = from_min, e1 = from_max;
    int flip = from_min > from_max;
    if (flip) { e0 = from_max; e1 = from_min; }
    if (kind == 2) {
        double t = safe_div(value - e0, e1 - e0);
        factor = value < e0 ? 0.0 : (value >= e1 ? 1.0 : t * t * (3.0 - 2.0 * t));
    } else {
        double t = clamp01(safe_div(value - e0, e1 - e0));
        factor = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    }
    if (flip) factor = 1.0 - factor;
    return to_min + factor * (to_max - to_min);
}

/* graph.normal_map */
INLINE void normal_map(const double *color, double strength, int tangent, const ShadingPoint *sp,
                       const double *attributes, const double *fallback, double *out)
{
    for (int j = 0; j < 3; j++) out[j] = fallback[j];
    if (tangent < 0) return;
    double c[3] = {2.0 * (color[0] - 0.5) * strength, 2.0 * (color[1] - 0.5) * strength, 0.0};
    c[2] = 1.0 + clamp01(strength) * (2.0 * (color[2] - 0.5) - 1.0);
    const double *t = attributes + tangent;
    double sign = attributes[tangent + 3], T[3], n[3], B[3], v[3];
    for (int i = 0; i < 3; i++) {
        T[i] = (sp->L[3 * i] * t[0] + sp->L[3 * i + 1] * t[1]) + sp->L[3 * i + 2] * t[2];
        n[i] = sp->N[i] * sp->side;
    }
    cross3(n, T, B);
    for (int i = 0; i < 3; i++) v[i] = (c[0] * T[i] + c[1] * (sign * B[i])) + c[2] * n[i];
    safe_normalize3(v);
    int ok = 1, zero = 1;
    for (int i = 0; i < 3; i++) { v[i] *= sp->side; ok &= isfinite(v[i]) != 0; zero &= v[i] == 0.0; }
    if (ok && !zero) for (int i = 0; i < 3; i++) out[i] = v[i];
}

/* graph.tangent_space: a tangent-space Vector Displacement offset (x along T, y along N, z along the bitangent) in
 * object space; T the mesh's tangent, or dPdu normalised where it has none. */
INLINE void tangent_space(const double *v, int tangent, const ShadingPoint *sp, double *out)
{
    double normal[3], T[3], B[3], stored[4] = {0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i < 3; i++) normal[i] = (sp->L[i] * sp->N[0] + sp->L[3 + i] * sp->N[1]) + sp->L[6 + i] * sp->N[2];
    safe_normalize3(normal);
    if (tangent >= 0) for (int j = 0; j < 4; j++) stored[j] = sp->attributes[tangent + j];
    int missing = stored[0] == 0.0 && stored[1] == 0.0 && stored[2] == 0.0 && stored[3] == 0.0;
    for (int j = 0; j < 3; j++) T[j] = missing ? sp->dPdu[j] : stored[j];
    if (missing) safe_normalize3(T);
    cross3(normal, T, B);
    safe_normalize3(B);
    double sign = missing ? 1.0 : stored[3];
    for (int j = 0; j < 3; j++) out[j] = (T[j] * v[0] + normal[j] * v[1]) + B[j] * sign * v[2];
}

/* graph.tangent: Cycles' Tangent node, radial about an axis of Generated (uv_map 0) or a UV map's tangent, in
 * world space as a normal is (cofactor of the object's linear transform), then N x normalize(T x N). */
INLINE void tangent_node(const double *source, int uv_map, int axis, const ShadingPoint *sp, double *out)
{
    double t[3], g[3] = {source[0] - 0.5, source[1] - 0.5, source[2] - 0.5};
    if (uv_map) { t[0] = source[0]; t[1] = source[1]; t[2] = source[2]; }
    else if (axis == 0) { t[0] = 0.0; t[1] = -g[2]; t[2] = g[1]; }
    else if (axis == 1) { t[0] = -g[2]; t[1] = 0.0; t[2] = g[0]; }
    else { t[0] = -g[1]; t[1] = g[0]; t[2] = 0.0; }
    double m0[3], m1[3], m2[3], c12[3], c20[3], c01[3], T[3], u[3];
    for (int i = 0; i < 3; i++) { m0[i] = sp->L[3 * i]; m1[i] = sp->L[3 * i + 1]; m2[i] = sp->L[3 * i + 2]; }
    cross3(m1, m2, c12); cross3(m2, m0, c20); cross3(m0, m1, c01);
    for (int i = 0; i < 3; i++) T[i] = (t[0] * c12[i] + t[1] * c20[i]) + t[2] * c01[i];
    cross3(T, sp->N, u);
    safe_normalize3(u);
    cross3(sp->N, u, out);
}

/* graph.fresnel_cos: Cycles' fresnel_dielectric_cos, the reflectance of relative index eta at |cos_i|; 1 under
 * total internal reflection. */
INLINE double fresnel_cos(double cos_i, double eta)
{
    double c = fabs(cos_i), g2 = eta * eta - 1.0 + c * c;
    if (!(g2 > 0.0)) return 1.0;
    double g = sqrt(g2), A = (g - c) / (g + c), B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * A * A * (1.0 + B * B);
}

/* graph.view_cosine: I.normal, the shading normal where the Normal input is unlinked. */
INLINE double view_cosine(const double *normal, const ShadingPoint *sp)
{
    return dot3(sp->I, normal != NULL ? normal : sp->N);
}

/* graph.fresnel: Cycles' Fresnel node. */
INLINE double fresnel_node(double ior, const double *normal, const ShadingPoint *sp)
{
    double eta = ior > 1e-5 ? ior : 1e-5;
    if (sp->side < 0.0) eta = 1.0 / eta;
    return fresnel_cos(view_cosine(normal, sp), eta);
}

/* graph.layer_weight: Cycles' Layer Weight node, out[0] Fresnel and out[1] Facing. */
INLINE void layer_weight(double blend, const double *normal, const ShadingPoint *sp, double *out)
{
    double cos_i = view_cosine(normal, sp), eta = 1.0 - blend > 1e-5 ? 1.0 - blend : 1e-5;
    if (!(sp->side < 0.0)) eta = 1.0 / eta;
    double f = fabs(cos_i), b = blend < 0.0 ? 0.0 : (blend > 1.0 - 1e-5 ? 1.0 - 1e-5 : blend);
    if (blend != 0.5) f = pow(f, b < 0.5 ? 2.0 * b : 0.5 / (1.0 - b));
    out[0] = fresnel_cos(cos_i, eta);
    out[1] = 1.0 - f;
}

/* graph.geometry: Cycles' Geometry node output `output` (graph.GEOMETRY_OUTPUTS) at the hit or the bump's point a
 * step du, dv in the barycentrics from it (graph.bump_step). */
INLINE void geometry_node(int output, double du, double dv, const ShadingPoint *sp, double *out)
{
    switch (output) {
    case GEOM_POSITION: for (int j = 0; j < 3; j++) out[j] = (sp->P[j] + du * sp->dPdu[j]) + dv * sp->dPdv[j]; break;
    case GEOM_NORMAL: for (int j = 0; j < 3; j++) out[j] = sp->N[j]; break;
    case GEOM_TRUE_NORMAL: for (int j = 0; j < 3; j++) out[j] = sp->Ng[j]; break;
    case GEOM_INCOMING: for (int j = 0; j < 3; j++) out[j] = sp->I[j]; break;
    case GEOM_OBJECT_NORMAL:
        for (int i = 0; i < 3; i++) out[i] = (sp->L[i] * sp->N[0] + sp->L[3 + i] * sp->N[1]) + sp->L[6 + i] * sp->N[2];
        safe_normalize3(out);
        break;
    case GEOM_REFLECTION: {
        double IN = 2.0 * dot3(sp->I, sp->N);
        for (int j = 0; j < 3; j++) out[j] = IN * sp->N[j] - sp->I[j];
        break;
    }
    case GEOM_PARAMETRIC: { double u = sp->u + du, v = sp->v + dv; out[0] = 1.0 - u - v; out[1] = u; out[2] = 0.0; break; }
    default: out[0] = sp->side < 0.0 ? 1.0 : 0.0; break;
    }
}

/* graph.light_path_output: the Light Path node's output `output` (LP_*) at the hit, from the path that reached it. */
INLINE double light_path_output(int output, const ShadingPoint *sp)
{
    const LightPath *p = &sp->path;
    switch (output) {
    case LP_IS_CAMERA_RAY: return (p->flags & PATH_CAMERA) != 0;
    case LP_IS_SHADOW_RAY: return (p->flags & PATH_SHADOW) != 0;
    case LP_IS_DIFFUSE_RAY: return (p->flags & PATH_DIFFUSE) != 0;
    case LP_IS_GLOSSY_RAY: return (p->flags & PATH_GLOSSY) != 0;
    case LP_IS_SINGULAR_RAY: return (p->flags & PATH_SINGULAR) != 0;
    case LP_IS_REFLECTION_RAY: return (p->flags & PATH_REFLECT) != 0;
    case LP_IS_TRANSMISSION_RAY: return (p->flags & PATH_TRANSMIT) != 0;
    case LP_IS_VOLUME_SCATTER_RAY: return (p->flags & PATH_VOLUME_SCATTER) != 0;
    case LP_RAY_LENGTH: return sp->t;
    case LP_RAY_DEPTH: return (double)p->bounce + ((p->flags & (PATH_SHADOW | PATH_EMISSION)) != 0);
    case LP_DIFFUSE_DEPTH: return (double)p->diffuse;
    case LP_GLOSSY_DEPTH: return (double)p->glossy;
    case LP_TRANSPARENT_DEPTH: return (double)p->transparent;
    case LP_TRANSMISSION_DEPTH: return (double)p->transmission;
    case LP_PORTAL_DEPTH: return (double)p->portal;
    default: return 0.0;
    }
}

/* graph.wireframe: Cycles' Wireframe node in world units, from corner 0 of the triangle. */
INLINE double wireframe(double size, double du, double dv, const ShadingPoint *sp)
{
    double u = sp->u + du, v = sp->v + dv;
    double P[3], corners[3][3], width = (0.5 * size) * (0.5 * size);
    for (int j = 0; j < 3; j++) {
        P[j] = u * sp->dPdu[j] + v * sp->dPdv[j];
        corners[0][j] = 0.0;
        corners[1][j] = sp->dPdu[j];
        corners[2][j] = sp->dPdv[j];
    }
    for (int k = 0; k < 3; k++) {
        const double *a = corners[k], *b = corners[k ? k - 1 : 2];
        double edge[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]}, dir[3] = {P[0] - a[0], P[1] - a[1], P[2] - a[2]}, c[3];
        cross3(edge, dir, c);
        if (dot3(c, c) < dot3(edge, edge) * width) return 1.0;
    }
    return 0.0;
}

/* graph.panorama_window: Cycles' Window under a panoramic camera of a point p in the camera's frame; f: the type
 * (2 + its place in graph.PANORAMA_WINDOWS) and its numbers. */
INLINE void panorama_window(const double *p, const double *f, double *out)
{
    double P[3] = {p[0], p[1], p[2]}, D[3], u, v;
    safe_normalize3(P);
    int kind = (int)f[4] - 2;
    if (kind == 2) { D[0] = P[0]; D[1] = -P[2]; D[2] = P[1]; }
    else { D[0] = P[2]; D[1] = -P[0]; D[2] = P[1]; }
    if (kind == 0) {                                            /* equirectangular */
        u = (atan2(D[1], D[0]) - f[1]) / f[0];
        double c = D[2] / sqrt(dot3(D, D));
        v = (acos(c < -1.0 ? -1.0 : (c > 1.0 ? 1.0 : c)) - f[3]) / f[2];
    } else if (kind == 1) {                                     /* equiangular cube map face */
        u = 0.5 - atan2(D[1], D[0]) * (2.0 / PI);
        v = atan2(D[2], D[0]) * (2.0 / PI) + 0.5;
    } else if (kind == 2) {                                     /* mirror ball */
        D[1] -= 1.0;
        double div = 2.0 * sqrt(at_least(-0.5 * D[1], 0.0));
        if (div > 0.0) for (int j = 0; j < 3; j++) D[j] = D[j] / div;
        u = 0.5 * (D[0] + 1.0);
        v = 0.5 * (D[2] + 1.0);
    } else if (kind == 6) {                                     /* the polynomial fisheye: graph.polynomial_radius */
        double c = D[0] < -1.0 ? -1.0 : (D[0] > 1.0 ? 1.0 : D[0]), theta = -acos(c), r = (theta - f[0]) / f[1];
        for (int step = 0; step < POLYNOMIAL_STEPS; step++) {
            double r2 = r * r;
            double F = theta - (f[0] + (((f[1] * r + f[2] * r2) + f[3] * (r2 * r)) + f[5] * (r2 * r2)));
            double dF = ((f[1] + 2.0 * f[2] * r) + 3.0 * f[3] * r2) + 4.0 * f[5] * (r2 * r);
            double moved = F / dF;
            r = r + moved;
            if (fabs(moved) < POLYNOMIAL_STOP) break;
        }
        double across = sqrt(D[1] * D[1] + D[2] * D[2]);
        u = 0.5 - (r * safe_div(D[1], across)) / f[6];
        v = (r * safe_div(D[2], across)) / f[7] + 0.5;
    } else if (kind == 5) {                                     /* central cylindrical */
        double z = safe_div(D[2], sqrt(D[0] * D[0] + D[1] * D[1]));
        u = (atan2(D[1], D[0]) - f[0]) / (f[1] - f[0]);
        v = (z - f[2]) / (f[3] - f[2]);
    } else {                                                    /* the fisheyes */
        double across = sqrt(D[1] * D[1] + D[2] * D[2]), r, width = 1.0, height = 1.0;
        if (kind == 3) r = atan2(across, D[0]) / f[0];
        else {
            double c = D[0] < -1.0 ? -1.0 : (D[0] > 1.0 ? 1.0 : D[0]);
            r = 2.0 * f[0] * sin(0.5 * acos(c));
            width = f[1];
            height = f[2];
        }
        double y = safe_div(D[1], across), z = safe_div(D[2], across);
        u = 0.5 - (r * y) / width;
        v = (r * z) / height + 0.5;
    }
    out[0] = u;
    out[1] = v;
    out[2] = 0.0;
}

/* graph.curve_normal: Cycles' Curves Info Tangent Normal from the curve's object-space tangent T. */
INLINE void curve_normal(const double *t, const ShadingPoint *sp, double *out)
{
    double T[3];
    for (int i = 0; i < 3; i++) T[i] = (sp->L[3 * i] * t[0] + sp->L[3 * i + 1] * t[1]) + sp->L[3 * i + 2] * t[2];
    double length2 = dot3(T, T);
    if (!(length2 > 0.0)) { out[0] = out[1] = out[2] = 0.0; return; }
    double along = dot3(T, sp->I) / length2;
    for (int i = 0; i < 3; i++) out[i] = sp->I[i] - along * T[i];
    safe_normalize3(out);
}

/* graph.orthonormals: Cycles' make_orthonormals of a unit N. */
INLINE void make_orthonormals(const double *N, double *a, double *b)
{
    int equal = N[0] == N[1] && N[0] == N[2];
    a[0] = N[2] - N[1];
    a[1] = equal ? N[0] + N[2] : N[0] - N[2];
    a[2] = equal ? -N[1] - N[0] : N[1] - N[0];
    double length = sqrt(dot3(a, a));
    for (int j = 0; j < 3; j++) a[j] = a[j] / length;
    cross3(N, a, b);
}

/* graph.camera_cones: the ray cone of the camera ray through P (camera frame): its footprint at P, and how fast it
 * widens along the ray into *widening; f: the window (left, right, bottom, top, perspective, width, height). */
static double camera_cone(const double *P, const double *f, double *widening)
{
    double sx = (f[1] - f[0]) / f[5], sy = (f[3] - f[2]) / f[6];
    if (f[4] == 0.0) {
        *widening = 0.0;
        return fabs(sx);
    }
    double d[3] = {safe_div(P[0], P[2]), safe_div(P[1], P[2]), 1.0}, unit[3], spread = 0.0;
    double length = sqrt(dot3(d, d));
    for (int j = 0; j < 3; j++) unit[j] = d[j] / length;
    for (int k = 0; k < 2; k++) {
        double moved[3] = {d[0] + (k == 0 ? sx : 0.0), d[1] + (k == 1 ? sy : 0.0), d[2] + 0.0};
        double m = sqrt(dot3(moved, moved));
        for (int j = 0; j < 3; j++) moved[j] = moved[j] / m - unit[j];
        spread = spread + sqrt(dot3(moved, moved));
    }
    *widening = 0.5 * spread;
    return sqrt(dot3(P, P)) * (0.5 * spread);
}

/* graph.pixel_width: a pixel's width at P (camera frame) as Cycles' Wireframe node measures it for Pixel Size;
 * f: the window (left, right, bottom, top, perspective, width, height; perspective >= 2: a panorama's). After a
 * bounce (or a portal), on shadow rays, in a light's own shading (no footprint: no wire) and under a panoramic
 * camera, the path's ray cone where it carries one. */
/* graph.ray_footprint: the ray's footprint at P (camera frame), Cycles' sd->dP (pixel_width's; the FOOTPRINT op). */
NOINLINE static double ray_footprint(const double *P, const double *f, const ShadingPoint *sp)
{
    double widening, footprint = f[4] >= 2.0 ? 0.0 : camera_cone(P, f, &widening);
    const LightPath *p = &sp->path;
    int left = p->bounce > 0 || p->portal > 0 || (p->flags & (PATH_SHADOW | PATH_EMISSION)) != 0 || f[4] >= 2.0;
    if (left && p->cone >= 0.0)
        footprint = p->cone + sp->t * p->spread;
    return footprint;
}

INLINE double pixel_width(const double *P, const double *f, const ShadingPoint *sp)
{
    double footprint = ray_footprint(P, f, sp);
    double axes[2][3], across = 0.0;
    make_orthonormals(sp->Ng, axes[0], axes[1]);
    for (int k = 0; k < 2; k++) {
        double along = dot3(axes[k], sp->I), projected[3];
        for (int j = 0; j < 3; j++) projected[j] = axes[k][j] - along * sp->I[j];
        across = across + sqrt(dot3(projected, projected));
    }
    return footprint * (0.5 * across);
}

/* graph.bump_differentials: the ray's differentials dPdx, dPdy across the surface at the hit as Cycles' Bump reads
 * them (the path's footprint along make_orthonormals of Ng; 0: none, the bump flat); where the cone is unknown
 * (UNKNOWN_CONE), BUMP_STEP of the edges V1 - V0, V2 - V0. Returns 1 where the footprint is known. */
static int bump_differentials(const ShadingPoint *sp, double *dPdx, double *dPdy)
{
    const LightPath *p = &sp->path;
    double footprint = p->cone + sp->t * p->spread;
    if (footprint < 0.0) footprint = 0.0;
    if (!(p->cone >= 0.0)) {
        for (int j = 0; j < 3; j++) { dPdx[j] = BUMP_STEP * sp->dPdu[j]; dPdy[j] = BUMP_STEP * sp->dPdv[j]; }
        return 0;
    }
    double a[3], b[3];
    make_orthonormals(sp->Ng, a, b);
    for (int j = 0; j < 3; j++) { dPdx[j] = footprint * a[j]; dPdy[j] = footprint * b[j]; }
    return 1;
}

/* graph.bump_step: the step *du, *dv in the barycentrics from the hit to a bump's point `where` (0 the hit, 1 and 2
 * its steps) for a Bump of Filter Width `width`: dPdx or dPdy times the width solved on the triangle's edges; where
 * the footprint is unknown, BUMP_STEP along V1 - V0 or V2 - V0. */
static void bump_step(int where, double width, const ShadingPoint *sp, double *du, double *dv)
{
    double dPdx[3], dPdy[3];
    *du = 0.0;
    *dv = 0.0;
    if (where == 0) return;
    if (!bump_differentials(sp, dPdx, dPdy)) {
        *du = where == 1 ? BUMP_STEP : 0.0;
        *dv = where == 2 ? BUMP_STEP : 0.0;
        return;
    }
    const double *d = where == 1 ? dPdx : dPdy;
    double uu = dot3(sp->dPdu, sp->dPdu), uv = dot3(sp->dPdu, sp->dPdv), vv = dot3(sp->dPdv, sp->dPdv);
    double du_d = dot3(sp->dPdu, d), dv_d = dot3(sp->dPdv, d), det = uu * vv - uv * uv;
    *du = width * safe_div(vv * du_d - uv * dv_d, det);
    *dv = width * safe_div(uu * dv_d - uv * du_d, det);
}

/* object_matrix for the bump over the unmoved surface (one call site of the INLINE one; defined after it). */
static void object_matrix_of(const ShadingPoint *sp, int mode, double *out);

/* graph.undisplaced_differentials: bump_differentials over the surface before it moved, the barycentric steps the
 * footprint takes on the moved triangle (`moved`, width 1) along the unmoved one's edges (sp's). Returns known. */
static int undisplaced_differentials(const ShadingPoint *sp, const ShadingPoint *moved, double *dPdx, double *dPdy)
{
    double ignored[2][3], du, dv;
    int known = bump_differentials(moved, ignored[0], ignored[1]);
    for (int where = 1; where <= 2; where++) {
        double *d = where == 1 ? dPdx : dPdy;
        bump_step(where, 1.0, moved, &du, &dv);
        for (int j = 0; j < 3; j++) d[j] = du * sp->dPdu[j] + dv * sp->dPdv[j];
    }
    return known;
}

/* graph.bump: normalize(width |det| N - distance sign(det) surfgrad) from bump_differentials (width 1 where the
 * footprint is unknown); with `moved` (not NULL: the hit on the displaced mesh, sp undisplaced_point's), from
 * undisplaced_differentials and in object space (Cycles' bump_in_object_space for Displacement and Bump). */
INLINE void bump(const double *normal, double strength, double distance, double h_c, double h_x, double h_y,
                 int invert, double width, const ShadingPoint *sp, const ShadingPoint *moved, double *out)
{
    double dPdx[3], dPdy[3], Rx[3], Ry[3], inv[12], n_in[3];
    if (!(moved ? undisplaced_differentials(sp, moved, dPdx, dPdy) : bump_differentials(sp, dPdx, dPdy))) width = 1.0;
    for (int j = 0; j < 3; j++) n_in[j] = normal[j];
    if (moved) {                /* (Displacement and Bump's bump runs in object space: bump_in_object_space) */
        const double *L = sp->L;
        double x[3], y[3];
        object_matrix_of(sp, 3, inv);
        for (int i = 0; i < 3; i++) {
            n_in[i] = (L[i] * normal[0] + L[3 + i] * normal[1]) + L[6 + i] * normal[2];
            x[i] = (inv[4 * i] * dPdx[0] + inv[4 * i + 1] * dPdx[1]) + inv[4 * i + 2] * dPdx[2];
            y[i] = (inv[4 * i] * dPdy[0] + inv[4 * i + 1] * dPdy[1]) + inv[4 * i + 2] * dPdy[2];
        }
        safe_normalize3(n_in);
        for (int j = 0; j < 3; j++) { dPdx[j] = x[j]; dPdy[j] = y[j]; }
    }
    normal = n_in;
    cross3(dPdy, normal, Rx);
    cross3(normal, dPdx, Ry);
    double det = dot3(dPdx, Rx), scale = invert ? -distance : distance;
    double sgn = det > 0.0 ? 1.0 : (det < 0.0 ? -1.0 : 0.0);
    strength = strength > 0.0 ? strength : 0.0;
    double v[3];
    for (int j = 0; j < 3; j++)
        v[j] = (width * fabs(det)) * normal[j] - (scale * sgn) * ((h_x - h_c) * Rx[j] + (h_y - h_c) * Ry[j]);
    safe_normalize3(v);
    if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) {
        for (int j = 0; j < 3; j++) out[j] = normal[j];
    } else {
        for (int j = 0; j < 3; j++) out[j] = strength * v[j] + (1.0 - strength) * normal[j];
        safe_normalize3(out);
    }
    if (moved) {                /* back to the world: the inverse's transpose */
        double w[3];
        for (int i = 0; i < 3; i++) w[i] = (inv[i] * out[0] + inv[4 + i] * out[1]) + inv[8 + i] * out[2];
        safe_normalize3(w);
        for (int j = 0; j < 3; j++) out[j] = w[j];
    }
}

/* graph.run for one hit: reg holds the program's registers afterwards. */
/* graph.object_matrices for one hit: the 3 x 4 transform (12 floats, row by row) of `mode` (0 object to world, 1
 * world to object, 2 and 3 their linear parts alone, 4 the inverse's linear part transposed, 5 the linear part
 * transposed) from the object's linear part sp->L (row-major) and its location sp->info[0..2]. */
INLINE void object_matrix(const ShadingPoint *sp, int mode, double *out)
{
    const double *L = sp->L, *loc = sp->info;
    double inv[9];
    double det = L[0] * (L[4] * L[8] - L[5] * L[7]) - L[1] * (L[3] * L[8] - L[5] * L[6])
                 + L[2] * (L[3] * L[7] - L[4] * L[6]);
    if (det != 0.0) {
        inv[0] = (L[4] * L[8] - L[5] * L[7]) / det; inv[1] = (L[2] * L[7] - L[1] * L[8]) / det;
        inv[2] = (L[1] * L[5] - L[2] * L[4]) / det; inv[3] = (L[5] * L[6] - L[3] * L[8]) / det;
        inv[4] = (L[0] * L[8] - L[2] * L[6]) / det; inv[5] = (L[2] * L[3] - L[0] * L[5]) / det;
        inv[6] = (L[3] * L[7] - L[4] * L[6]) / det; inv[7] = (L[1] * L[6] - L[0] * L[7]) / det;
        inv[8] = (L[0] * L[4] - L[1] * L[3]) / det;
    } else {
        for (int k = 0; k < 9; k++) inv[k] = (k % 4 == 0) ? 1.0 : 0.0;
    }
    const double *M = (mode == 0 || mode == 2) ? L : inv;
    int transposed = mode >= 4;
    if (mode == 5) M = L;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) out[4 * i + j] = transposed ? M[3 * j + i] : M[3 * i + j];
        out[4 * i + 3] = mode == 0 ? loc[i] : mode == 1 ? -(inv[3 * i] * loc[0] + inv[3 * i + 1] * loc[1]
                                                            + inv[3 * i + 2] * loc[2]) : 0.0;
    }
}

/* The nodes that trace rays (graph.RAYTRACE_OPS), defined with the integrators (core/integrators/shader_rays.c):
 * ShaderRays.ambient_occlusion and ShaderRays.bevel for one hit. */
static double shader_ao(const ShadingPoint *sp, const double *N, double distance, int samples, int flags);
static void shader_bevel(const ShadingPoint *sp, double radius, int samples, double *out);

NOINLINE static void object_matrix_of(const ShadingPoint *sp, int mode, double *out)
{
    object_matrix(sp, mode, out);
}

/* graph.undisplaced_point: *out (a copy of the hit sp) with P, dPdu, dPdv from the object-space attribute at
 * `position` (the vertices before they moved) in world space and N the unit normal before they moved (the attribute
 * at `normal`, to world space, flipped where the back was hit), as Cycles' ENTER_BUMP_EVAL. */
static void undisplaced_point(int position, int normal, const ShadingPoint *sp, ShadingPoint *out)
{
    double M[12], T[12], n[3];
    const double *p = sp->attributes + position, *pu = sp->d_du + position, *pv = sp->d_dv + position;
    const double *q = sp->attributes + normal;
    object_matrix_of(sp, 0, M);
    object_matrix_of(sp, 4, T);
    for (int j = 0; j < 3; j++) n[j] = q[j];
    safe_normalize3(n);
    for (int i = 0; i < 3; i++) {
        const double *row = M + 4 * i, *nrow = T + 4 * i;
        out->P[i] = ((row[0] * p[0] + row[1] * p[1]) + row[2] * p[2]) + row[3];
        out->dPdu[i] = (row[0] * pu[0] + row[1] * pu[1]) + row[2] * pu[2];
        out->dPdv[i] = (row[0] * pv[0] + row[1] * pv[1]) + row[2] * pv[2];
        out->N[i] = (nrow[0] * n[0] + nrow[1] * n[1]) + nrow[2] * n[2];
    }
    safe_normalize3(out->N);
    for (int j = 0; j < 3; j++) out->N[j] *= sp->side;
}

/* graph.run for one hit: program `program` of G at the hit into the registers reg; live: NULL (every op runs), or
 * one flag per op (GraphTables.emission_ops from the program's first op): an op whose flag is 0 is skipped, its
 * registers left unwritten (graph.live_ops: nothing that is read depends on them). */
NOINLINE static void run_program(const GraphTables *G, int program, const ShadingPoint *hit, const double *live,
                                 double *reg)
{
    const ShadingPoint *sp = hit;       /* after a SET_NORMAL: `bumped`, the hit with Set Normal's normal */
    ShadingPoint bumped;
    ShadingPoint flat;                  /* inside UNDISPLACED: the hit before the surface moved, and */
    const ShadingPoint *moved = NULL;   /* the hit on the moved surface */
    const double *info = G->programs + PROGRAM_INFO * program;
    const double *ops = G->ops + OP_WIDTH * (int64_t)info[0], *ramps = G->ramps + (int64_t)info[7];
    const int32_t *args = G->args + (OP_WIDTH - 1) * (int64_t)info[0];     /* (the arguments, read as they are) */
    if (live != NULL) live += (int64_t)info[0];
    int64_t n_ops = (int64_t)info[1], n_constants = (int64_t)info[3];
    const double *constants = G->constants + (int64_t)info[2];
    for (int64_t k = 0; k < n_constants; k++) reg[k] = constants[k];
    double offset_attr[MAX_ATTRIBUTES];
    const double *attributes = sp->attributes;
    double step_u = 0.0, step_v = 0.0;  /* the bump's evaluation point (OFFSET): its step from the hit */
    for (int64_t o = 0; o < n_ops; o++) {
        if (live != NULL && live[o] == 0.0) continue;
        const double *op = ops + OP_WIDTH * o;
        const int *a = args + (OP_WIDTH - 1) * o;
        double *out = reg + (a[0] >= 0 ? a[0] : 0);
        switch ((int)op[0]) {
        case OP_ATTR:
            for (int j = 0; j < a[3]; j++) out[j] = (a[1] >= 0 && j < a[2]) ? attributes[a[1] + j] : 0.0;
            break;
        case OP_RANDOM: out[0] = sp->random; break;
        case OP_OBJECT_INFO:
            for (int j = 0; j < a[2]; j++) out[j] = a[1] + j < sp->info_width ? sp->info[a[1] + j] : 0.0;
            break;
        case OP_OBJECT_MATRIX: object_matrix(sp, a[1], out); break;
        case OP_LIGHT_PATH: out[0] = light_path_output(a[1], sp); break;
        case OP_OFFSET:
            bump_step(a[0], a[0] ? reg[a[1]] : 0.0, moved ? moved : sp, &step_u, &step_v);
            if (a[0] == 0) { attributes = sp->attributes; break; }
            for (int j = 0; j < sp->width; j++)
                offset_attr[j] = (sp->attributes[j] + step_u * sp->d_du[j]) + step_v * sp->d_dv[j];
            attributes = offset_attr;
            break;
        case OP_IMAGE:
            texture_lookup(G->textures, a[2], reg[a[1]], reg[a[1] + 1], a[3], a[4], a[5], out);
            break;
        case OP_MAPPING: {
            const double *v = reg + a[1], *loc = reg + a[2], *rot = reg + a[3], *scale = reg + a[4];
            double cx = cos(rot[0]), cy = cos(rot[1]), cz = cos(rot[2]), sx = sin(rot[0]), sy = sin(rot[1]), sz = sin(rot[2]);
            double M[9] = {cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz,
                           cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz,
                           -sy, cy * sx, cy * cx};
            double w[3], r[3];
            switch (a[5]) {
            case 0: case 2:
                for (int j = 0; j < 3; j++) w[j] = v[j] * scale[j];
                for (int i = 0; i < 3; i++) r[i] = (M[3 * i] * w[0] + M[3 * i + 1] * w[1]) + M[3 * i + 2] * w[2];
                if (a[5] == 0) for (int j = 0; j < 3; j++) r[j] += loc[j];
                break;
            case 1:
                for (int j = 0; j < 3; j++) w[j] = v[j] - loc[j];
                for (int i = 0; i < 3; i++) r[i] = safe_div((M[i] * w[0] + M[3 + i] * w[1]) + M[6 + i] * w[2], scale[i]);
                break;
            default:
                for (int j = 0; j < 3; j++) w[j] = safe_div(v[j], scale[j]);
                for (int i = 0; i < 3; i++) r[i] = (M[3 * i] * w[0] + M[3 * i + 1] * w[1]) + M[3 * i + 2] * w[2];
                safe_normalize3(r);
                break;
            }
            for (int j = 0; j < 3; j++) out[j] = r[j];
            break;
        }
        case OP_MATH: {
            double v = math_op(a[1], reg[a[2]], reg[a[3]], reg[a[4]]);
            out[0] = a[5] ? clamp01(v) : v;
            break;
        }
        case OP_MIX_COLOR: {
            double t = reg[a[2]], r[3];
            if (a[6]) t = clamp01(t);
            if (a[1] >= 15) mix_hsv(a[1], t, reg + a[3], reg + a[4], r);
            for (int j = 0; j < 3; j++) {
                if (a[1] < 15) r[j] = mix_channel(a[1], t, reg[a[3] + j], reg[a[4] + j]);
                if (a[5]) r[j] = clamp01(r[j]);
            }
            for (int j = 0; j < 3; j++) out[j] = r[j];
            break;
        }
        case OP_MIX_FLOAT: {
            int w = a[5] < 0 ? -a[5] : a[5];
            double r[3];
            for (int j = 0; j < w; j++) {
                double t = reg[a[1] + (a[5] == 3 ? j : 0)];
                if (a[4]) t = clamp01(t);
                r[j] = (1.0 - t) * reg[a[2] + j] + t * reg[a[3] + j];
            }
            for (int j = 0; j < w; j++) out[j] = r[j];
            break;
        }
        case OP_RAMP: {
            double f = reg[a[1]];
            f = (f != f) ? 0.0 : clamp01(f) * (double)(a[3] - 1);
            int k = (int)f;
            k = k < 0 ? 0 : (k > a[3] - 1 ? a[3] - 1 : k);
            double t = f - k;
            const double *lo = ramps + a[2] + 4 * k, *hi = ramps + a[2] + 4 * (k + 1 < a[3] ? k + 1 : a[3] - 1);
            for (int j = 0; j < 4; j++) out[j] = (a[4] && t > 0.0) ? (1.0 - t) * lo[j] + t * hi[j] : lo[j];
            break;
        }
        case OP_INVERT: {
            double fac = reg[a[1]], r[3];
            for (int j = 0; j < 3; j++) r[j] = fac * (1.0 - reg[a[2] + j]) + (1.0 - fac) * reg[a[2] + j];
            for (int j = 0; j < 3; j++) out[j] = r[j];
            break;
        }
        case OP_HSV: {          /* Cycles' svm_node_hsv, in float32 (the colour model of converters/color.h) */
            float color[3], hsv[3], rgb[3], fac = (float)reg[a[4]];
            for (int j = 0; j < 3; j++) color[j] = (float)reg[a[5] + j];
            rgb_to_hsv_f(color, hsv);
            float h = hsv[0] + (float)reg[a[1]] + 0.5f;
            hsv[0] = h - floorf(h);
            float s = hsv[1] * (float)reg[a[2]];
            hsv[1] = s < 0.0f ? 0.0f : s > 1.0f ? 1.0f : s;
            hsv[2] = hsv[2] * (float)reg[a[3]];
            hsv_to_rgb_f(hsv, rgb);
            for (int j = 0; j < 3; j++) {
                float v = fac * rgb[j] + (1.0f - fac) * color[j];
                out[j] = v > 0.0f ? v : 0.0f;
            }
            break;
        }
        case OP_COPY: { double r[3]; for (int j = 0; j < a[2]; j++) r[j] = reg[a[1] + j]; for (int j = 0; j < a[2]; j++) out[j] = r[j]; break; }
        case OP_CLAMP: {
            double value = reg[a[1]], lo = reg[a[2]], hi = reg[a[3]];
            if (a[4] && lo > hi) { double s = lo; lo = hi; hi = s; }
            value = value > lo ? value : lo;
            out[0] = value < hi ? value : hi;
            break;
        }
        case OP_MAP_RANGE:
            out[0] = map_range(a[7], a[8], reg[a[1]], reg[a[2]], reg[a[3]], reg[a[4]], reg[a[5]], reg[a[6]]);
            break;
        case OP_NORMAL_MAP: { double r[3]; normal_map(reg + a[1], reg[a[2]], a[3], hit, attributes, sp->N, r); for (int j = 0; j < 3; j++) out[j] = r[j]; break; }
        case OP_BUMP: {
            double r[3] = {0.0, 0.0, 0.0};          /* (a light's own shading: no bump, as Cycles' light mask) */
            if (!(sp->path.flags & PATH_EMISSION))
                bump(a[6] < 0 ? sp->N : reg + a[6], reg[a[1]], reg[a[2]], reg[a[3]], reg[a[4]], reg[a[5]], a[7],
                     reg[a[8]], sp, moved, r);
            for (int j = 0; j < 3; j++) out[j] = r[j];
            break;
        }
        case OP_CONVERT: {
            const double *s = reg + a[1];
            if (a[2] == 0) out[0] = ((double)RGB_TO_Y[0] * s[0] + (double)RGB_TO_Y[1] * s[1]) + (double)RGB_TO_Y[2] * s[2];
            else if (a[2] == 1) out[0] = (s[0] + s[1] + s[2]) * (1.0 / 3.0);
            else { double v = s[0]; out[0] = out[1] = out[2] = v; }
            break;
        }
        case OP_TANGENT: { double r[3]; tangent_node(reg + a[1], a[2], a[3], sp, r); for (int j = 0; j < 3; j++) out[j] = r[j]; break; }
        case OP_SCALE: { double f = reg[a[2]], r[3]; for (int j = 0; j < 3; j++) r[j] = reg[a[1] + j] * f; for (int j = 0; j < 3; j++) out[j] = r[j]; break; }
        case OP_GEOMETRY: {
            double r[3];
            geometry_node(a[1], step_u, step_v, sp, r);
            for (int j = 0; j < (a[1] == GEOM_BACKFACING ? 1 : 3); j++) out[j] = r[j];
            break;
        }
        case OP_TRANSFORM: {
            const double *M = reg + a[2], *p = reg + a[1];
            double r[3];
            for (int i = 0; i < 3; i++) r[i] = ((p[0] * M[4 * i] + p[1] * M[4 * i + 1]) + p[2] * M[4 * i + 2]) + M[4 * i + 3];
            for (int j = 0; j < 3; j++) out[j] = r[j];
            break;
        }
        case OP_WINDOW: {
            const double *p = reg + a[1], *f = reg + a[2];
            if (f[4] >= 2.0) { panorama_window(p, f, out); break; }
            double x = f[4] != 0.0 ? safe_div(p[0], p[2]) : p[0], y = f[4] != 0.0 ? safe_div(p[1], p[2]) : p[1];
            out[0] = (x - f[0]) / (f[1] - f[0]);
            out[1] = (y - f[2]) / (f[3] - f[2]);
            out[2] = 0.0;
            break;
        }
        case OP_WIREFRAME: out[0] = wireframe(reg[a[1]], step_u, step_v, sp); break;
        case OP_AO: {           /* Color x AO, then AO; 1 where the shader traces nothing (sp->rays NULL) */
            double normal[3];
            for (int j = 0; j < 3; j++) normal[j] = a[3] < 0 ? sp->N[j] : reg[a[3] + j];
            safe_normalize3(normal);
            double ao = sp->rays == NULL ? 1.0 : shader_ao(sp, normal, reg[a[2]], a[4], a[5]), r[3];
            for (int j = 0; j < 3; j++) r[j] = reg[a[1] + j] * ao;
            for (int j = 0; j < 3; j++) out[j] = r[j];
            out[3] = ao;
            break;
        }
        case OP_BEVEL: {        /* the shading normal where the shader traces nothing; a linked Normal keeps its detail */
            double r[3];
            if (sp->rays == NULL) for (int j = 0; j < 3; j++) r[j] = sp->N[j];
            else shader_bevel(sp, reg[a[1]], a[3], r);
            if (a[2] >= 0) {
                for (int j = 0; j < 3; j++) r[j] = reg[a[2] + j] + (r[j] - sp->N[j]);
                safe_normalize3(r);
            }
            for (int j = 0; j < 3; j++) out[j] = r[j];
            break;
        }
        case OP_TANGENT_SPACE: { double r[3]; tangent_space(reg + a[1], a[2], sp, r); for (int j = 0; j < 3; j++) out[j] = r[j]; break; }
        case OP_UNDISPLACED:            /* graph.py run: the bump over the surface before it moved, and back */
            if (a[0]) {
                flat = *sp;
                undisplaced_point(a[1], a[2], sp, &flat);
                moved = sp;
                sp = &flat;
            } else if (moved) {
                double n[3] = {sp->N[0], sp->N[1], sp->N[2]};
                bumped = *moved;
                for (int j = 0; j < 3; j++) bumped.N[j] = n[j];
                sp = &bumped;
                moved = NULL;
            }
            break;
        case OP_AOV_START:              /* the ops after it feed shader AOVs alone: only where the hit writes them */
            if (sp->aov == NULL) return;
            break;
        case OP_SET_NORMAL: {           /* graph.py run: unit, the hit's own where it is zero */
            double n[3] = {reg[a[0]], reg[a[0] + 1], reg[a[0] + 2]};
            safe_normalize3(n);
            bumped = *sp;
            if (n[0] != 0.0 || n[1] != 0.0 || n[2] != 0.0) for (int j = 0; j < 3; j++) bumped.N[j] = n[j];
            sp = &bumped;
            break;
        }
        case OP_CURVE_NORMAL: { double r[3]; curve_normal(reg + a[1], sp, r); for (int j = 0; j < 3; j++) out[j] = r[j]; break; }
        case OP_FOOTPRINT: out[0] = ray_footprint(reg + a[1], reg + a[2], sp); break;
        case OP_PIXEL_SIZE: out[0] = reg[a[1]] * pixel_width(reg + a[2], reg + a[3], sp); break;
        case OP_CAMERA_DATA: {
            const double *p = reg + a[1];
            double r[3] = {p[0], p[1], p[2]}, depth = p[2], distance = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
            safe_normalize3(r);
            for (int j = 0; j < 3; j++) out[j] = r[j];
            out[3] = depth;
            out[4] = distance;
            break;
        }
        case OP_FRESNEL: out[0] = fresnel_node(reg[a[1]], a[2] < 0 ? NULL : reg + a[2], sp); break;
        case OP_LAYER_WEIGHT: { double r[2]; layer_weight(reg[a[1]], a[2] < 0 ? NULL : reg + a[2], sp, r); out[0] = r[0]; out[1] = r[1]; break; }
        case OP_SKY: { double r[3]; sky_op(ramps + a[2], reg + a[1], r); for (int j = 0; j < 3; j++) out[j] = r[j]; break; }
        default:     /* the procedural textures (procedural.gen.c), then the converters (converters.gen.c); any
                        other op poisons its output rather than leaving it stale */
            if (!procedural_op((int)op[0], a, reg) && !converter_op((int)op[0], a, reg, ramps)) out[0] = NAN;
            break;
        }
    }
}

/* graph.valid_reflection: Cycles' ensure_valid_specular_reflection of a node's unit normal N in place. */
INLINE void valid_reflection(const double *Ng, const double *wo, double *N)
{
    double NI = dot3(N, wo), R[3];
    for (int j = 0; j < 3; j++) R[j] = 2.0 * NI * N[j] - wo[j];
    double Iz = dot3(wo, Ng), threshold = 0.9 * Iz < 0.01 ? 0.9 * Iz : 0.01;
    if (!(dot3(Ng, R) < threshold)) return;
    double NNg = dot3(N, Ng), X[3];
    for (int j = 0; j < 3; j++) X[j] = N[j] - NNg * Ng[j];
    double length = sqrt(dot3(X, X));
    for (int j = 0; j < 3; j++) X[j] = length > 0.0 ? X[j] / length : N[j];
    double Ix = dot3(wo, X);
    double a = Ix * Ix + Iz * Iz, b = 2.0 * (a + Iz * threshold), c = (threshold + Iz) * (threshold + Iz);
    double root = sqrt(at_least(b * b - 4.0 * a * c, 0.0)), a_safe = a != 0.0 ? a : 1.0;
    double Nz2 = Ix < 0.0 ? 0.25 * (b + root) / a_safe : 0.25 * (b - root) / a_safe;
    double Nx = sqrt(at_least(1.0 - Nz2, 0.0)), Nz = sqrt(at_least(Nz2, 0.0));
    for (int j = 0; j < 3; j++) N[j] = Nx * X[j] + Nz * Ng[j];
}
