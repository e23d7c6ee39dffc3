/* Emissive meshes as one light: core/lights/emitters.py. A triangle chosen by the light tree
 * (core/lights/light_tree.py), then a direction
 * towards it: uniform over the spherical triangle near it (Arvo), uniform in its area far from it; a quad lamp (two
 * triangles as one emitter, MeshEmitters.partner) over its spherical rectangle (Urena et al. 2013) or its area; a
 * moving emitter's where it is at the path's time (emitter_at). */

#define EMIT_FRONT 1
#define EMIT_BACK 2

INLINE void unit3(const double *v, double *out)
{
    double length = sqrt(dot3(v, v));
    for (int c = 0; c < 3; c++) out[c] = v[c] / length;
}

INLINE void cross_product(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* light_tree.py: the tree's node rows (TREE_FIELDS doubles each), its columns TREE_<NAME>, TREE_CLAMP and
 * TREE_HORIZON: all made there (core/native/boundary.gen.h). */

/* A shading point as the tree's walk sees it: P, N (zero: unknown), and what every node's importance would otherwise
 * make again from N alone (|N| per axis, whether N is known), made once per walk. */
typedef struct {
    const double *P, *N;
    double N_abs[3];
    int known_normal;
} TreeReceiver;

/* The walk's receiver for P (3,) and N (3,), zero: unknown. */
INLINE TreeReceiver tree_receiver(const double *P, const double *N)
{
    TreeReceiver r = {P, N, {fabs(N[0]), fabs(N[1]), fabs(N[2])}, dot3(N, N) > 0.0};
    return r;
}

/* light_tree.importance for one node row seen from receiver r (P with normal N, zero: unknown): the upper and
 * lower bounds of what it sends P, energy x the cosine bounds at the receiver and the emitter / distance^2 (Cycles'
 * light_tree_importance); the upper 0 only where nothing of it lights P, the lower 0 wherever some may not
 * (lower NULL: the upper bound alone, and none of the lower bound's work: pass a literal NULL, so that the inlined
 * copy drops it). In cosines: cos(a - b) = cos a cos b + sin a sin b, all angles in [0, pi]. The box's centre,
 * diagonal and half its length come with the row (light_tree.with_cosines, the same numbers as made here before). */
INLINE void light_tree_importance(const double *node, const TreeReceiver *r, double *upper, double *lower)
{
    const double *P = r->P, *N = r->N;
    const double *lo = node, *hi = node + 3, *axis = node + TREE_AXIS, *centre = node + TREE_CENTRE;
    const double *diagonal = node + TREE_DIAGONAL;
    double v[3] = {centre[0] - P[0], centre[1] - P[1], centre[2] - P[2]};
    *upper = 0.0;
    if (lower != NULL) *lower = 0.0;
    double d = sqrt(dot3(v, v));
    double half = node[TREE_HALF];
    /* Nothing where the whole box lies on or below P's tangent plane (above it by no more than light_tree.HORIZON of
     * its distance and size: coplanar to rounding). */
    int known_normal = r->known_normal;
    if (known_normal && !(dot3(N, v) + 0.5 * dot3(r->N_abs, diagonal) > TREE_HORIZON * (d + half))) return;
    double distance = at_least(d, TREE_CLAMP * 2.0 * half);
    double scale = node[TREE_ENERGY] / (distance * distance);
    *upper = scale;
    int inside_box = 1;
    for (int c = 0; c < 3; c++) inside_box &= (P[c] >= lo[c]) & (P[c] <= hi[c]);
    if (inside_box || d <= 0.0) return;
    /* theta_u: the half-angle around the direction w to the centre that holds the box's corners (cos^2
     * of each corner's angle, all of them in front, else the cone passes a hemisphere: every direction). */
    double w[3] = {v[0] / d, v[1] / d, v[2] / d};
    /* Each corner's offset from P takes lo[c] - P[c] or hi[c] - P[c] on each axis, so its terms of w . offset and
     * |offset|^2 are two products per axis, made once: the same numbers as corner by corner, summed in dot3's
     * order. A rounded sum never decreases when a term grows, so the corner with each axis' lesser term has the
     * least w . offset of the eight: all are in front exactly where it is (one test, before the eight sums). */
    double along_of[2][3], square_of[2][3], least_of[3];
    for (int c = 0; c < 3; c++) {
        double near = lo[c] - P[c], far = hi[c] - P[c];
        along_of[0][c] = w[c] * near;
        along_of[1][c] = w[c] * far;
        square_of[0][c] = near * near;
        square_of[1][c] = far * far;
        least_of[c] = along_of[0][c] < along_of[1][c] ? along_of[0][c] : along_of[1][c];
    }
    if (!(least_of[0] + least_of[1] + least_of[2] > 0.0)) return;
    /* (The smallest along^2 / length^2 kept as a fraction, compared by cross-multiplying: one division, not 8.) */
    double least_along2 = 1.0, least_length2 = 1.0, farthest2 = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        int x = corner & 1, y = (corner >> 1) & 1, z = (corner >> 2) & 1;
        double along = along_of[x][0] + along_of[y][1] + along_of[z][2];
        double length2 = square_of[x][0] + square_of[y][1] + square_of[z][2];
        double along2 = along * along;
        int less = along2 * least_length2 < least_along2 * length2;
        least_along2 = less ? along2 : least_along2;
        least_length2 = less ? length2 : least_length2;
        if (lower != NULL) farthest2 = at_least(farthest2, length2);
    }
    double cos2_u = least_along2 / least_length2;
    double cos_u = sqrt(cos2_u < 1.0 ? cos2_u : 1.0), sin_u = sqrt(at_least(1.0 - cos2_u, 0.0));
    /* The receiver: cos(max(theta_i - theta_u, 0)), at least 0; 1 where N is unknown. The lower bound:
     * cos(theta_i + theta_u), at least 0. */
    double cos_incidence = 1.0, cos_incidence_least = 1.0;
    if (known_normal) {
        double cos_i = dot3(N, w), sin_i = sqrt(at_least(1.0 - cos_i * cos_i, 0.0));
        if (!(cos_i >= cos_u)) cos_incidence = at_least(cos_i * cos_u + sin_i * sin_u, 0.0);
        if (lower != NULL) cos_incidence_least = at_least(cos_i * cos_u - sin_i * sin_u, 0.0);
    }
    /* The emitter: theta' = max(theta - theta_u - theta_o, 0), cos theta' where theta' < theta_e, else 0 (1 where
     * theta <= theta_u or theta - theta_u <= theta_o, its other terms then unused). The lower bound:
     * cos(theta + theta_u + theta_o) where theta + theta_u <= theta_e - theta_o (theta, theta_u <= pi / 2). */
    double cos_t = -dot3(axis, w), sin_t = sqrt(at_least(1.0 - cos_t * cos_t, 0.0));
    double cos_outgoing = 1.0;
    if (!(cos_t >= cos_u)) {
        double cos_1 = cos_t * cos_u + sin_t * sin_u;
        if (!(cos_1 >= node[TREE_COS_O])) {
            double sin_1 = at_least(sin_t * cos_u - cos_t * sin_u, 0.0);
            double cos_2 = cos_1 * node[TREE_COS_O] + sin_1 * node[TREE_SIN_O];
            cos_outgoing = cos_2 > node[TREE_COS_E] ? at_least(cos_2, 0.0) : 0.0;
        }
    }
    *upper = scale * (cos_incidence * cos_outgoing);
    if (lower == NULL) return;
    double cos_3 = cos_t * cos_u - sin_t * sin_u, sin_3 = sin_t * cos_u + cos_t * sin_u;
    double cos_4 = cos_3 * node[TREE_COS_O] - sin_3 * node[TREE_SIN_O];
    double cos_outgoing_least = (cos_t >= 0.0) && (cos_3 >= node[TREE_COS_EO]) ? at_least(cos_4, 0.0) : 0.0;
    /* The lower bound's distance: the upper one's for an inner node, to the farthest corner for a leaf. */
    double far = node[TREE_RIGHT] < 0.0 ? sqrt(farthest2) : distance;
    *lower = node[TREE_ENERGY] / (far * far) * (cos_incidence_least * cos_outgoing_least);
}

/* light_tree.py's rules (EmitterTables.rule). */
#define TREE_CYCLES 0
#define TREE_UPPER 1
#define TREE_POWER 2

/* LightTree.branch_left: the probability of the inner node's left child, its share of the upper importance bounds
 * (TREE_UPPER, the renders'), or the mean of that and its share of the lower bounds (TREE_CYCLES, Cycles'
 * get_left_probability); by power where both children's upper bounds are 0, or TREE_POWER. */
INLINE double light_tree_branch_left(const EmitterTables *e, const double *node, const TreeReceiver *r)
{
    const double *left = e->nodes + TREE_FIELDS * (int64_t)node[TREE_LEFT];
    const double *right = e->nodes + TREE_FIELDS * (int64_t)node[TREE_RIGHT];
    if (e->rule == TREE_POWER) return left[TREE_ENERGY] / (left[TREE_ENERGY] + right[TREE_ENERGY]);
    /* Twins (light_tree.twins, decided once at the build: the node's TWINS field): 1/2 each wherever P is, as their
     * importances would give to within light_tree.TWIN_TOLERANCE (the two triangles of a quad lamp), and unbiased all
     * the same (the same 1/2 in pick and pick_probability); both importances skipped. */
    if (node[TREE_TWINS] != 0.0) return 0.5;
    double upper_left, lower_left = 0.0, upper_right, lower_right = 0.0;
    int cycles = e->rule == TREE_CYCLES;
    if (cycles) {
        light_tree_importance(left, r, &upper_left, &lower_left);
        light_tree_importance(right, r, &upper_right, &lower_right);
    } else {    /* (the renders': the upper bounds alone, their inlined copies without the lower bounds' work) */
        light_tree_importance(left, r, &upper_left, NULL);
        light_tree_importance(right, r, &upper_right, NULL);
    }
    double upper = upper_left + upper_right, lower = lower_left + lower_right;
    if (!(upper > 0.0)) return left[TREE_ENERGY] / (left[TREE_ENERGY] + right[TREE_ENERGY]);
    double by_upper = upper_left / upper;
    if (!cycles) return by_upper;
    double by_lower = lower > 0.0 ? lower_left / lower
                                  : 0.5 * ((upper_left > 0.0 ? 1.0 : 0.0) + (upper_right == 0.0 ? 1.0 : 0.0));
    return 0.5 * (by_upper + by_lower);
}

/* LightTree.pick: the emitter the walk down the tree from P (normal N) with *u in [0, 1) reaches, and
 * its probability; *u becomes the number rescaled to [0, 1) within the emitter's share, for reuse. */
INLINE int64_t emitter_pick(const EmitterTables *e, const double *P, const double *N, double *u, double *probability)
{
    const double *node = e->nodes;
    TreeReceiver r = tree_receiver(P, N);
    double p = 1.0, x = *u;
    while (node[TREE_RIGHT] >= 0.0) {
        double p_left = light_tree_branch_left(e, node, &r);
        if (x < p_left) {
            p *= p_left;
            x = x / p_left;
            node = e->nodes + TREE_FIELDS * (int64_t)node[TREE_LEFT];
        } else {
            p *= 1.0 - p_left;
            x = (x - p_left) / (1.0 - p_left);
            node = e->nodes + TREE_FIELDS * (int64_t)node[TREE_RIGHT];
        }
        x = x < 0.0 ? 0.0 : x;
        x = x > 1.0 - 0x1p-53 ? 1.0 - 0x1p-53 : x;
    }
    *probability = p;
    *u = x;
    return -1 - (int64_t)node[TREE_LEFT];
}

/* LightTree.pick_probability: the probability that emitter_pick from P (normal N) reaches emitter i,
 * the same products in the same order along i's path. */
INLINE double emitter_pick_probability(const EmitterTables *e, int64_t i, const double *P, const double *N)
{
    const double *node = e->nodes;
    TreeReceiver r = tree_receiver(P, N);
    double p = 1.0;
    int64_t path = e->path[i];
    for (int64_t level = 0; level < e->depth[i]; level++) {
        double p_left = light_tree_branch_left(e, node, &r);
        if ((path >> level) & 1) {
            p *= 1.0 - p_left;
            node = e->nodes + TREE_FIELDS * (int64_t)node[TREE_RIGHT];
        } else {
            p *= p_left;
            node = e->nodes + TREE_FIELDS * (int64_t)node[TREE_LEFT];
        }
    }
    return p;
}

static const double UNKNOWN_NORMAL[3] = {0.0, 0.0, 0.0};

/* The solid angle of the spherical triangle of unit vectors A, B, C (Van Oosterom and Strackee). */
INLINE double unit_triangle_solid_angle(const double *A, const double *B, const double *C)
{
    double bc[3];
    cross_product(B, C, bc);
    double triple = fabs(dot3(A, bc));
    return 2.0 * atan2(triple, 1.0 + dot3(A, B) + dot3(B, C) + dot3(C, A));
}

/* The unit directions A, B, C from P to the corners of triangle V (9,). */
INLINE void unit_corners(const double *P, const double *V, double *A, double *B, double *C)
{
    double *unit[3] = {A, B, C}, w[3];
    for (int k = 0; k < 3; k++) {
        for (int c = 0; c < 3; c++) w[c] = V[3 * k + c] - P[c];
        unit3(w, unit[k]);
    }
}

/* emitters.solid_angle: the solid angle of triangle V seen from P. */
INLINE double triangle_solid_angle(const double *P, const double *V)
{
    double A[3], B[3], C[3];
    unit_corners(P, V, A, B, C);
    return unit_triangle_solid_angle(A, B, C);
}

/* emitters.spherical_triangle_sample for one point: the direction L, the distance to the plane along
 * it, and pdf 1 / Omega. */
INLINE void spherical_triangle_sample(const double *P, const double *V, const double *u, double *L, double *t,
                                      double *pdf)
{
    double A[3], B[3], C[3];
    unit_corners(P, V, A, B, C);
    /* The solid angle Omega, and the angle alpha at A as its cosine and sine from the unit normals of the great
     * circles A-B and A-C (their cross product is parallel to A): no inverse trigonometry. */
    double omega = unit_triangle_solid_angle(A, B, C);
    double n1[3], n2[3], n12[3];
    cross_product(A, B, n1);
    cross_product(A, C, n2);
    double l1 = at_least(sqrt(dot3(n1, n1)), 1e-300), l2 = at_least(sqrt(dot3(n2, n2)), 1e-300);
    for (int c = 0; c < 3; c++) { n1[c] /= l1; n2[c] /= l2; }
    cross_product(n1, n2, n12);
    double cos_alpha = dot3(n1, n2), sin_alpha = fabs(dot3(A, n12));
    cos_alpha = cos_alpha < -1.0 ? -1.0 : (cos_alpha > 1.0 ? 1.0 : cos_alpha);
    /* 1. A sub-triangle of area u0 Omega, its third vertex C' on the arc from A to C: s, tt the sine and
     * cosine of (u0 Omega - alpha) by the angle-difference identities. */
    double area_hat = u[0] * omega;
    double sin_hat = sin(area_hat), cos_hat = cos(area_hat);
    double s = sin_hat * cos_alpha - cos_hat * sin_alpha, tt = cos_hat * cos_alpha + sin_hat * sin_alpha;
    double cos_c = dot3(A, B);
    double uu = tt - cos_alpha, vv = s + sin_alpha * cos_c;
    double q = ((vv * tt - uu * s) * cos_alpha - vv) / ((vv * s + uu * tt) * sin_alpha);
    q = q != q ? 1.0 : (q < -1.0 ? -1.0 : (q > 1.0 ? 1.0 : q));
    double ca = dot3(C, A), perp[3];
    for (int c = 0; c < 3; c++) perp[c] = C[c] - ca * A[c];
    double lp = at_least(sqrt(dot3(perp, perp)), 1e-300);
    double C_hat[3];
    double sin_q = sqrt(at_least(1.0 - q * q, 0.0));      /* (once, not per axis) */
    for (int c = 0; c < 3; c++) C_hat[c] = q * A[c] + sin_q * (perp[c] / lp);
    /* 2. A point on the arc from B to C' at height u1. */
    double cb = dot3(C_hat, B);
    double z = 1.0 - u[1] * (1.0 - cb);
    double wb[3];
    for (int c = 0; c < 3; c++) wb[c] = C_hat[c] - cb * B[c];
    double lw = at_least(sqrt(dot3(wb, wb)), 1e-300);
    double Lr[3];
    double sin_z = sqrt(at_least(1.0 - z * z, 0.0));
    for (int c = 0; c < 3; c++) Lr[c] = z * B[c] + sin_z * (wb[c] / lw);
    unit3(Lr, L);
    /* 3. The distance to the planar triangle along L. */
    double e1[3], e2[3], n[3], to_V[3];
    for (int c = 0; c < 3; c++) { e1[c] = V[3 + c] - V[c]; e2[c] = V[6 + c] - V[c]; to_V[c] = V[c] - P[c]; }
    cross_product(e1, e2, n);
    double distance = dot3(to_V, n) / dot3(L, n);
    *t = isfinite(distance) && distance > 0.0 ? distance : 0.0;
    double p = omega > 0.0 ? 1.0 / omega : 0.0;
    *pdf = isfinite(p) ? p : 0.0;
}

/* emitters.area_sample for one point: a point uniform in the triangle's area (Heitz's map). */
INLINE void triangle_area_sample(const double *P, const double *V, const double *normal, double area,
                                 const double *u, double *L, double *t, double *pdf)
{
    double a = u[0], b = u[1];
    if (b > a) { a = 0.5 * a; b = b - a; }
    else { b = 0.5 * b; a = a - b; }
    double point[3], w[3];
    for (int c = 0; c < 3; c++) {
        point[c] = (1.0 - a - b) * V[c] + a * V[3 + c] + b * V[6 + c];
        w[c] = point[c] - P[c];
    }
    double d = sqrt(dot3(w, w));
    for (int c = 0; c < 3; c++) L[c] = d > 0.0 ? w[c] / d : 0.0;
    double cos_light = fabs(dot3(normal, L));
    double p = d * d / (cos_light * area);
    *t = d;
    *pdf = isfinite(p) ? p : 0.0;
}

/* emitters.rectangle_area: the area of rectangle R (9,) [corner, edge u, edge v]. */
INLINE double rectangle_area(const double *R)
{
    double c[3];
    cross_product(R + 3, R + 6, c);
    return sqrt(dot3(c, c));
}

/* emitters.rectangle_constants for one rectangle R (9,): what its frame needs wherever it is seen from, F (12,) =
 * x, y its unit edges, z = x cross y, lx, ly its edge lengths and its area (EmitterTables.rect_frame holds a quad
 * lamp's, made once at set-up by the same operations: the same numbers as made here per sample). */
INLINE void rectangle_constants(const double *R, double *F)
{
    double lx = sqrt(dot3(R + 3, R + 3)), ly = sqrt(dot3(R + 6, R + 6));
    for (int c = 0; c < 3; c++) { F[c] = R[3 + c] / lx; F[3 + c] = R[6 + c] / ly; }
    cross_product(F, F + 3, F + 6);
    F[9] = lx;
    F[10] = ly;
    F[11] = rectangle_area(R);
}

/* emitters.rectangle_frame for one point: rectangle R (its rectangle_constants F) seen from P in Urena et al.'s local
 * frame, x, y, z (3,) and ext = {x0, x1, y0, y1, z0}, nz (4,) the z components of the unit normals of the planes
 * through P and its edges, and turn = {S, cos(g2 + g3), sin(g2 + g3)}: the solid angle S = -(g0 + g1 + g2 + g3) and
 * the paper's k - pi as a unit complex number, g_k the asin terms (interior angles pi/2 - g_k). No asin: each
 * corner's cos g_k + i sin g_k, sin g_k = -nz_k nz_k+1 and cos g_k = |z0| |corner k + 1| / (rho_k rho_k+1) (rho_k:
 * the length of plane k's raw normal; free of the cancellation in sqrt(1 - sin^2)), multiplied in pairs A (corners 0,
 * 1) and B (2, 3); -AB = e^(i(pi - S)), pi - S in (-pi, pi): one atan2, no wrap-around. Where P is on the plane (z0
 * not < 0: every cos g_k 0) S is the four asin's sum. */
INLINE void rectangle_frame(const double *P, const double *R, const double *F, double *x, double *y, double *z,
                            double *ext, double *nz, double *turn)
{
    double lx = F[9], ly = F[10], d[3];
    for (int c = 0; c < 3; c++) { x[c] = F[c]; y[c] = F[3 + c]; z[c] = F[6 + c]; d[c] = R[c] - P[c]; }
    double z0 = dot3(d, z);
    if (z0 > 0.0) {
        for (int c = 0; c < 3; c++) z[c] = -z[c];
        z0 = -z0;
    }
    double x0 = dot3(d, x), y0 = dot3(d, y);
    double x1 = x0 + lx, y1 = y0 + ly;
    ext[0] = x0; ext[1] = x1; ext[2] = y0; ext[3] = y1; ext[4] = z0;
    double raw[4] = {-y0, x1, y1, -x0}, rho[4], sin_g[4], cos_g[4];
    for (int k = 0; k < 4; k++) {
        rho[k] = sqrt(raw[k] * raw[k] + z0 * z0);
        nz[k] = raw[k] / rho[k];
    }
    for (int k = 0; k < 4; k++) {          /* (unclamped: atan2 takes them as they are, asin below clamps) */
        int next = (k + 1) & 3;
        sin_g[k] = -nz[k] * nz[next];
        cos_g[k] = -z0 * sqrt(raw[k] * raw[k] + raw[next] * raw[next] + z0 * z0) / (rho[k] * rho[next]);
    }
    double re_A = cos_g[0] * cos_g[1] - sin_g[0] * sin_g[1], im_A = cos_g[0] * sin_g[1] + sin_g[0] * cos_g[1];
    double re_B = cos_g[2] * cos_g[3] - sin_g[2] * sin_g[3], im_B = cos_g[2] * sin_g[3] + sin_g[2] * cos_g[3];
    double S;
    if (z0 < 0.0) {
        S = PI - atan2(-(re_A * im_B + im_A * re_B), -(re_A * re_B - im_A * im_B));
    } else {
        double g[4];
        for (int k = 0; k < 4; k++) g[k] = asin(sin_g[k] < -1.0 ? -1.0 : (sin_g[k] > 1.0 ? 1.0 : sin_g[k]));
        S = -(g[0] + g[1] + g[2] + g[3]);
    }
    turn[0] = S;
    turn[1] = re_B;
    turn[2] = im_B;
}

/* emitters.rectangle_solid_angle for one point, rectangle R with its rectangle_constants F. */
INLINE double rectangle_solid_angle_of(const double *P, const double *R, const double *F)
{
    double x[3], y[3], z[3], ext[5], nz[4], turn[3];
    rectangle_frame(P, R, F, x, y, z, ext, nz, turn);
    double S = turn[0];
    return S == S ? S : 0.0;
}

/* emitters.rectangle_solid_angle for one point. */
INLINE double rectangle_solid_angle(const double *P, const double *R)
{
    double F[12];
    rectangle_constants(R, F);
    return rectangle_solid_angle_of(P, R, F);
}

/* spherical_rectangle_sample_of's steps 1 and 2 once the angle is drawn: the point (xu, yv) on the rectangle
 * [x0, x1] x [y0, y1] at depth z0 (its frame's coordinates) whose direction leaves the solid angle a (sin_a, cos_a)
 * left of it, turned by the unit complex number (re, im) (the paper's g2 + g3, its pi taken out by flipping signs;
 * b0, b1 the first and third edges' normals' z), then uniform in the height of the direction's projection by u1.
 * Branch-free, so that quad_lamp_lanes' loop over a block stays SIMD. */
INLINE void rectangle_point_at(double sin_a, double cos_a, double re, double im, double b0, double b1, double x0,
                               double x1, double y0, double y1, double z0, double u1, double *xu_out, double *yv_out)
{
    /* 1. x: where the solid angle left of it is a. */
    double sin_au = sin_a * re + cos_a * im, cos_au = cos_a * re - sin_a * im;
    double fu = sin_au != 0.0 ? (cos_au * b0 + b1) / sin_au : 0.0;
    double cu = copysign(1.0 / sqrt(fu * fu + b0 * b0), fu);
    cu = cu < -1.0 ? -1.0 : (cu > 1.0 ? 1.0 : cu);
    double xu = -(cu * z0) / at_least(sqrt(at_least(1.0 - cu * cu, 0.0)), 1e-300);
    xu = xu == xu ? xu : 0.0;
    xu = xu < x0 ? x0 : (xu > x1 ? x1 : xu);
    /* 2. y: uniform in the height of the direction's projection between its values at the two ends. */
    double d2 = xu * xu + z0 * z0;
    double h0 = y0 / sqrt(d2 + y0 * y0), h1 = y1 / sqrt(d2 + y1 * y1);
    double hv = h0 + u1 * (h1 - h0);
    *xu_out = xu;
    *yv_out = hv * hv < 1.0 - 1e-12 ? hv * sqrt(d2 / (1.0 - hv * hv)) : y1;
}

/* emitters.spherical_rectangle_sample for one point: the direction L uniform over the spherical rectangle R (with its
 * rectangle_constants F) subtends from P by u (2,), the distance to its point, pdf 1 / Omega (Urena, Fajardo and
 * King 2013). */
INLINE void spherical_rectangle_sample_of(const double *P, const double *R, const double *F, const double *u,
                                          double *L, double *t, double *pdf)
{
    double x[3], y[3], z[3], ext[5], nz[4], turn[3];
    rectangle_frame(P, R, F, x, y, z, ext, nz, turn);
    double x0 = ext[0], x1 = ext[1], y0 = ext[2], y1 = ext[3], z0 = ext[4];
    double S = turn[0];
    S = S == S ? S : 0.0;
    double b0 = nz[0], b1 = nz[2];
    /* 1. x: the solid angle left of it u0 S (the paper's au = u0 S + k, k = pi + g2 + g3, its pi taken out by
     * flipping signs): sin and cos of u0 S turned by g2 + g3 (turn's unit complex number). */
    double sin_a = sin(u[0] * S), cos_a = cos(u[0] * S);
    double xu, yv;
    rectangle_point_at(sin_a, cos_a, turn[1], turn[2], b0, b1, x0, x1, y0, y1, z0, u[1], &xu, &yv);
    double w[3];
    for (int c = 0; c < 3; c++) w[c] = xu * x[c] + yv * y[c] + z0 * z[c];
    double length = sqrt(dot3(w, w));
    double p = S > 0.0 ? 1.0 / S : 0.0;
    int ok = isfinite(length) && length > 0.0 && isfinite(p);
    for (int c = 0; c < 3; c++) L[c] = ok ? w[c] / length : 0.0;
    *t = ok ? length : 0.0;
    *pdf = ok ? p : 0.0;
}

/* emitters.spherical_rectangle_sample for one point (spherical_rectangle_sample_of, the constants made here). */
INLINE void spherical_rectangle_sample(const double *P, const double *R, const double *u, double *L, double *t,
                                       double *pdf)
{
    double F[12];
    rectangle_constants(R, F);
    spherical_rectangle_sample_of(P, R, F, u, L, t, pdf);
}

/* emitters.rectangle_area_sample for one point: corner + u0 edge u + u1 edge v of area A, pdf t^2 / (|cos| A). */
INLINE void rectangle_area_sample(const double *P, const double *R, double area, const double *normal, const double *u,
                                  double *L, double *t, double *pdf)
{
    double w[3];
    for (int c = 0; c < 3; c++) w[c] = R[c] + u[0] * R[3 + c] + u[1] * R[6 + c] - P[c];
    double d = sqrt(dot3(w, w));
    for (int c = 0; c < 3; c++) L[c] = d > 0.0 ? w[c] / d : 0.0;
    double cos_light = fabs(dot3(normal, L));
    double p = d * d / (cos_light * area);
    *t = d;
    *pdf = isfinite(p) ? p : 0.0;
}

/* emitters.rectangle_side_and_way's second half: whether the quad R of area A uses the spherical rectangle from a
 * point at `height` from its plane: its diagonal^2 > delta^2, delta = h / (2 A). */
INLINE int rectangle_spherical(const double *R, double area, double height)
{
    double diagonal[3] = {R[3] + R[6], R[4] + R[7], R[5] + R[8]};
    double delta = height / (2.0 * area);
    return dot3(diagonal, diagonal) > delta * delta;
}

/* Quad lamp triangle i's rectangle_constants (of its rectangle R): the table's row (EmitterTables.rect_frame), else
 * made into `made` (12,). */
INLINE const double *quad_constants(const EmitterTables *e, int64_t i, const double *R, double *made)
{
    if (e->rect_frame != NULL) return e->rect_frame + 12 * i;
    rectangle_constants(R, made);
    return made;
}

/* MeshEmitters.lead: emitter i, or its quad's lead (the lower index of the two) where it is half of one. */
INLINE int64_t emitter_lead(const EmitterTables *e, int64_t i)
{
    if (e->partner == NULL) return i;
    int64_t other = e->partner[i];
    return other >= 0 && other < i ? other : i;
}

/* Whether the triangle uses solid-angle sampling from P: its longest edge^2 > delta^2, delta = h / (2 A). */
INLINE int emitter_spherical(const double *V, double height, double area)
{
    /* (the three edges written out: no index arithmetic, the same numbers in the same order) */
    double e0[3] = {V[3] - V[0], V[4] - V[1], V[5] - V[2]};
    double e1[3] = {V[6] - V[3], V[7] - V[4], V[8] - V[5]};
    double e2[3] = {V[0] - V[6], V[1] - V[7], V[2] - V[8]};
    double l0 = dot3(e0, e0), l1 = dot3(e1, e1), l2 = dot3(e2, e2);
    double longest = l0 > 0.0 ? l0 : 0.0;
    longest = l1 > longest ? l1 : longest;
    longest = l2 > longest ? l2 : longest;
    double delta = height / (2.0 * area);
    return longest > delta * delta;
}

/* MeshEmitters.corners_at for emitter i of instanced mesh m, moving, at `time` in the shutter: its corners placed as
 * triangles.c places them for rays then (hit_triangle's corners) into placed (9,), its unit normal and area into
 * normal and *area. Returns placed. */
NOINLINE static const double *moving_emitter_at(const EmitterTables *e, int64_t i, int32_t m, double time,
                                                double *placed, double *normal, double *area)
{
    const GeometryTables *g = (const GeometryTables *)e->geometry;
    const InstancedTables *mesh = g->meshes + m;
    int64_t local = (e->prim[i] - (int64_t)mesh->first_prim) % (int64_t)mesh->triangle_count;
    int64_t j = (e->prim[i] - (int64_t)mesh->first_prim) / (int64_t)mesh->triangle_count;
    Triangle tri;
    hit_triangle(g, (int64_t)m + 1, local, j, 0, time, &tri);     /* (the corners as rays meet them then) */
    for (int k = 0; k < 9; k++) placed[k] = tri.V[k];
    double e1[3], e2[3], cross[3];         /* (the unflipped normal and area, as the table's still rows have them) */
    for (int c = 0; c < 3; c++) { e1[c] = placed[3 + c] - placed[c]; e2[c] = placed[6 + c] - placed[c]; }
    cross_product(e1, e2, cross);
    double length = sqrt(dot3(cross, cross));
    for (int c = 0; c < 3; c++) normal[c] = length > 0.0 ? cross[c] / length : 0.0;
    *area = 0.5 * length;
    return placed;
}

/* MeshEmitters.corners_at for emitter i at `time` in the shutter (time < 0: the frame): its corners (9,), unit
 * normal and area, the table's row for a still one (inline: no call for the common case), a moving one's from
 * moving_emitter_at into placed, normal and *area. Returns the corners. */
INLINE const double *emitter_at(const EmitterTables *e, int64_t i, double time, double *placed, double *normal,
                                double *area)
{
    int32_t m = e->mesh != NULL && e->geometry != NULL && time >= 0.0 ? e->mesh[i] : -1;
    if (m >= 0) return moving_emitter_at(e, i, m, time, placed, normal, area);
    for (int c = 0; c < 3; c++) normal[c] = e->normal[3 * i + c];
    *area = e->area[i];
    return e->corners + 9 * i;
}

/* MeshEmitters.sample for one point with normal N (NULL or zero: unknown) at `time` in the shutter (where a moving
 * emitter is; < 0: the frame): u (2,) the unit-square point, whose first number also picks the triangle. */
NOINLINE static void sample_emitters(const EmitterTables *e, const double *P, const double *N, const double *u_in,
                                     double time, LightSample *out)
{
    double pick, u[2] = {u_in[0], u_in[1]};
    int64_t i = emitter_pick(e, P, N != NULL ? N : UNKNOWN_NORMAL, &u[0], &pick);
    double placed[9], normal[3], area;
    const double *V = emitter_at(e, i, time, placed, normal, &area);
    int quad = e->partner != NULL && e->partner[i] >= 0;     /* (a quad lamp's lead: its rectangle) */
    const double *R = quad ? e->rect + 9 * i : V;
    double to_V[3] = {R[0] - P[0], R[1] - P[1], R[2] - P[2]};
    double height = dot3(normal, to_V);
    int side = height > 0.0 ? EMIT_BACK : EMIT_FRONT;
    int allowed = (e->sides[i] & side) != 0;
    double pdf_direction, made[12];
    if (quad) {
        const double *F = quad_constants(e, i, R, made);
        if (rectangle_spherical(R, F[11], height))
            spherical_rectangle_sample_of(P, R, F, u, out->L, &out->distance, &pdf_direction);
        else rectangle_area_sample(P, R, F[11], normal, u, out->L, &out->distance, &pdf_direction);
    } else if (emitter_spherical(V, height, area)) {
        spherical_triangle_sample(P, V, u, out->L, &out->distance, &pdf_direction);
    } else {
        triangle_area_sample(P, V, normal, area, u, out->L, &out->distance, &pdf_direction);
    }
    double pdf = pick * pdf_direction;
    int ok = allowed & (pdf > 0.0) & isfinite(pdf);
    out->strength = ok ? 1.0 / pdf : 0.0;
    out->pdf = ok ? pdf : 0.0;
    out->hidden = e->hidden != NULL ? (int)e->hidden[i] : 0;
    out->emitter = i;
    for (int c = 0; c < 3; c++) {
        out->position[c] = P[c] + out->L[c] * out->distance;
        out->color[c] = e->emission[3 * i + c];
        out->normal[c] = normal[c];
    }
}

/* The quad lamp whose emitter every light sample takes, where the light tree is one leaf (the root) holding a still quad
 * lamp with its constants made once (EmitterTables.rect_frame): its lead emitter's index, else -1 (sample_emitters
 * walks). Its pick probability is then 1 and the sample's number is the walk's own (the walk takes no step). */
INLINE int64_t lone_quad(const EmitterTables *e)
{
    if (e == NULL || e->nodes[TREE_RIGHT] >= 0.0 || e->partner == NULL || e->rect_frame == NULL || e->rect == NULL)
        return -1;
    int64_t i = -1 - (int64_t)e->nodes[TREE_LEFT];
    if (e->partner[i] < 0 || (e->mesh != NULL && e->geometry != NULL && e->mesh[i] >= 0)) return -1;
    return i;
}

/* sample_emitters for n points P (3, BLOCK columns) with numbers u (2, BLOCK) on lone_quad's lamp i, as loops over the
 * lanes with no branch (SIMD lanes where inlined into a SIMD_CLONES loop; only atan2 and sin/cos run a lane at a time):
 * the same operations in the same order, so the same numbers, for every lane that samples the spherical rectangle
 * from in front of or behind its plane (not on it: z0 < 0 after the frame's flip). Into L, distance, strength, pdf and
 * position; `slow` 1 marks the other lanes (far enough for area sampling, or on the lamp's plane), which the caller
 * samples with sample_emitters itself. */
INLINE void quad_lamp_lanes(const EmitterTables *e, int64_t i, int64_t n, double P[3][BLOCK], double u[2][BLOCK],
                            double L[3][BLOCK], double *distance, double *strength, double *pdf,
                            double position[3][BLOCK], uint8_t *slow)
{
    const double *R = e->rect + 9 * i, *F = e->rect_frame + 12 * i;
    double normal[3] = {e->normal[3 * i], e->normal[3 * i + 1], e->normal[3 * i + 2]};
    double X[3] = {F[0], F[1], F[2]}, Y[3] = {F[3], F[4], F[5]}, Z[3] = {F[6], F[7], F[8]};
    double lx = F[9], ly = F[10], area = F[11], corner[3] = {R[0], R[1], R[2]};
    double diagonal[3] = {R[3] + R[6], R[4] + R[7], R[5] + R[8]};
    double diagonal2 = dot3(diagonal, diagonal);
    int sides = e->sides[i];
    double ya[BLOCK], xa[BLOCK], re_b[BLOCK], im_b[BLOCK], n0[BLOCK], n2[BLOCK], ext[5][BLOCK], flip[BLOCK];
    double allowed[BLOCK], S[BLOCK], sin_a[BLOCK], cos_a[BLOCK];
    /* 1. The frame (rectangle_frame) up to atan2's arguments, and which lanes take this way. */
    for (int64_t k = 0; k < n; k++) {
        double d[3] = {corner[0] - P[0][k], corner[1] - P[1][k], corner[2] - P[2][k]};
        double height = dot3(normal, d);
        int side = height > 0.0 ? EMIT_BACK : EMIT_FRONT;
        allowed[k] = (sides & side) != 0 ? 1.0 : 0.0;
        double delta = height / (2.0 * area);
        int spherical = diagonal2 > delta * delta;          /* (rectangle_spherical) */
        double z0 = dot3(d, Z);
        int flipped = z0 > 0.0;
        z0 = flipped ? -z0 : z0;
        flip[k] = flipped ? -1.0 : 1.0;
        double x0 = dot3(d, X), y0 = dot3(d, Y);
        double x1 = x0 + lx, y1 = y0 + ly;
        ext[0][k] = x0; ext[1][k] = x1; ext[2][k] = y0; ext[3][k] = y1; ext[4][k] = z0;
        double raw[4] = {-y0, x1, y1, -x0}, rho[4], nz[4], sin_g[4], cos_g[4];
        for (int j = 0; j < 4; j++) {
            rho[j] = sqrt(raw[j] * raw[j] + z0 * z0);
            nz[j] = raw[j] / rho[j];
        }
        for (int j = 0; j < 4; j++) {
            int next = (j + 1) & 3;
            sin_g[j] = -nz[j] * nz[next];
            cos_g[j] = -z0 * sqrt(raw[j] * raw[j] + raw[next] * raw[next] + z0 * z0) / (rho[j] * rho[next]);
        }
        double re_A = cos_g[0] * cos_g[1] - sin_g[0] * sin_g[1], im_A = cos_g[0] * sin_g[1] + sin_g[0] * cos_g[1];
        double re_B = cos_g[2] * cos_g[3] - sin_g[2] * sin_g[3], im_B = cos_g[2] * sin_g[3] + sin_g[2] * cos_g[3];
        ya[k] = -(re_A * im_B + im_A * re_B);
        xa[k] = -(re_A * re_B - im_A * im_B);
        re_b[k] = re_B; im_b[k] = im_B; n0[k] = nz[0]; n2[k] = nz[2];
        slow[k] = (uint8_t)(!spherical | !(z0 < 0.0));
    }
    /* 2. The solid angle and the turn of its first number, a lane at a time (libm). */
    for (int64_t k = 0; k < n; k++) {
        double s = PI - atan2(ya[k], xa[k]);
        S[k] = s == s ? s : 0.0;
        sin_a[k] = sin(u[0][k] * S[k]);
        cos_a[k] = cos(u[0][k] * S[k]);
    }
    /* 3. The direction (spherical_rectangle_sample_of's steps 1 and 2), its pdf and the sample. */
    for (int64_t k = 0; k < n; k++) {
        double x0 = ext[0][k], x1 = ext[1][k], y0 = ext[2][k], y1 = ext[3][k], z0 = ext[4][k];
        double z[3] = {Z[0] * flip[k], Z[1] * flip[k], Z[2] * flip[k]};
        double b0 = n0[k], b1 = n2[k];
        double xu, yv;
        rectangle_point_at(sin_a[k], cos_a[k], re_b[k], im_b[k], b0, b1, x0, x1, y0, y1, z0, u[1][k], &xu, &yv);
        double w[3];
        for (int c = 0; c < 3; c++) w[c] = xu * X[c] + yv * Y[c] + z0 * z[c];
        double length = sqrt(dot3(w, w));
        double p = S[k] > 0.0 ? 1.0 / S[k] : 0.0;
        int ok = (fabs(length) < INFINITY) & (length > 0.0) & (fabs(p) < INFINITY);     /* (isfinite) */
        double t = ok ? length : 0.0, pdf_direction = ok ? p : 0.0;
        double dir[3];
        for (int c = 0; c < 3; c++) dir[c] = ok ? w[c] / length : 0.0;
        double full = 1.0 * pdf_direction;                   /* (the pick's probability, 1, times it) */
        int kept = (allowed[k] != 0.0) & (full > 0.0) & (fabs(full) < INFINITY);
        strength[k] = kept ? 1.0 / full : 0.0;
        pdf[k] = kept ? full : 0.0;
        distance[k] = t;
        for (int c = 0; c < 3; c++) {
            L[c][k] = dir[c];
            position[c][k] = P[c][k] + dir[c] * t;
        }
    }
}

/* The table's entries (lights.gen.c): MeshEmitters.sample (moving emitters where they are at the frame: direct.c's
 * light samples call sample_emitters with their path's time); rays meet emitters as the surfaces they hit, not here. */
INLINE void emitters_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                            const double *u, LightSample *out)
{
    (void)light;
    sample_emitters(ctx->emitters, P, N, u, -1.0, out);
}

INLINE int emitters_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    (void)light; (void)O; (void)D; (void)t_max; (void)out;
    return 0;
}

/* MeshEmitters.pdf_of_hits: the pdf `sample` gives direction D from O (normal N, NULL or zero: unknown,
 * as sample_emitters had it) to emitter i at distance t, the ray's `time` in the shutter (a moving emitter where it
 * is then, as sample_emitters places it; < 0: the frame). */
INLINE double emitter_pdf(const EmitterTables *e, int64_t i, const double *O, const double *N, const double *D,
                          double t, double time)
{
    i = emitter_lead(e, i);                 /* (either triangle of a quad lamp: the quad's pdf) */
    double placed[9], normal[3], area;
    const double *V = emitter_at(e, i, time, placed, normal, &area);
    int quad = e->partner != NULL && e->partner[i] >= 0;
    const double *R = quad ? e->rect + 9 * i : V;
    double to_V[3] = {R[0] - O[0], R[1] - O[1], R[2] - O[2]};
    double height = dot3(normal, to_V);
    int side = height > 0.0 ? EMIT_BACK : EMIT_FRONT;
    if ((e->sides[i] & side) == 0) return 0.0;
    double pdf_direction, made[12];
    if (quad) {
        const double *F = quad_constants(e, i, R, made);
        if (rectangle_spherical(R, F[11], height)) pdf_direction = 1.0 / rectangle_solid_angle_of(O, R, F);
        else pdf_direction = t * t / (fabs(dot3(normal, D)) * F[11]);
    } else if (emitter_spherical(V, height, area)) {
        pdf_direction = 1.0 / triangle_solid_angle(O, V);
    } else {
        pdf_direction = t * t / (fabs(dot3(normal, D)) * area);
    }
    double pdf = emitter_pick_probability(e, i, O, N != NULL ? N : UNKNOWN_NORMAL) * pdf_direction;
    return isfinite(pdf) ? pdf : 0.0;
}

/* MeshEmitters.index_of_prim: the emitter of WorldGeometry triangle `prim`, or -1. */
INLINE int64_t emitter_of_prim(const EmitterTables *e, int64_t prim)
{
    int64_t lo = 0, hi = (int64_t)e->count;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (e->sorted_prim[mid] < prim) lo = mid + 1; else hi = mid;
    }
    return lo < (int64_t)e->count && e->sorted_prim[lo] == prim ? e->order[lo] : -1;
}

/* LightTree.pick over arrays (for the tests): points, normals (n, 3), u (n,) -> index (n,) int64,
 * probability (n,) float64. */
static void emitter_pick_rows(const EmitterPickArgs *a)
{
    for (int64_t k = 0; k < a->n; k++) {
        double u = a->u[k];
        a->index[k] = emitter_pick(a->emitters, a->points + 3 * k, a->normals + 3 * k, &u, a->probability + k);
    }
}

/* LightTree.pick_probability over arrays (for the tests): points, normals (n, 3), index (n,) int64 ->
 * probability (n,) float64. */
static void emitter_pick_probability_rows(const EmitterPickArgs *a)
{
    for (int64_t k = 0; k < a->n; k++)
        a->probability[k] = emitter_pick_probability(a->emitters, a->index[k], a->points + 3 * k, a->normals + 3 * k);
}

/* MeshEmitters.pdf_of_hits over arrays (for the tests): origins, normals, directions (n, 3), t (n,), index (n,)
 * int64 -> pdf (n,) float64, at the frame. */
static void emitter_pdf_rows(const EmitterPdfArgs *a)
{
    for (int64_t k = 0; k < a->n; k++)
        a->pdf[k] = emitter_pdf(a->emitters, a->index[k], a->origins + 3 * k, a->normals + 3 * k, a->directions + 3 * k,
                                a->t[k], -1.0);
}
