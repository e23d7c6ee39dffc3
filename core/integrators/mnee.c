/* Shadow caustics: manifold next-event estimation, core/integrators/mnee.py for one light sample at a time.
 *
 * A receiver's light sample of a caustics lamp whose shadow ray meets caster glass (Cycles' Shadow Caustics): the
 * straight ray collects up to MNEE_MAX_CAUSTIC_CASTERS smooth refractive interfaces (mnee_seed), Newton's method on
 * the specular manifold moves them until each obeys Snell's law (mnee_newton: constraints, block-tridiagonal solve,
 * projection back onto each object), and the path found replaces the light sample: the receiver's f cos towards the
 * first interface, the light's emission, the generalised geometry term (mnee_transfer) and each interface's
 * transmittance (mnee_interface), its shadow ray from the last interface to the light. Rare lanes: one scalar walk
 * per lane (direct.c's light-sampling block calls mnee_block). The same numbers as the Python reference, for the
 * lights it walks (mnee.walks: point and spot lamps, area lamps with a spread, suns); path.c culls a caster's BSDF
 * rays on a path that left a receiver from finding a caustics lamp (BlockHits.cull), whose light MNEE brings.
 * Cycles' source: intern/cycles/kernel/integrator/mnee.h. */

#define MNEE_MAX_ITERATIONS 64
#define MNEE_MAX_INTERSECTION_COUNT 10
#define MNEE_SOLVER_THRESHOLD 0.001
#define MNEE_MINIMUM_STEP_SIZE 0.0001
#define MNEE_MAX_CAUSTIC_CASTERS 6
#define MNEE_MIN_DISTANCE 0.001
#define MNEE_MIN_PROGRESS_DISTANCE 0.0001
#define MNEE_MIN_DETERMINANT 0.0001
#define MNEE_PROJECTION_DISTANCE_MULTIPLIER 2.0
#define MNEE_G_CLAMP 2.0
#define MNEE_CASTER 1
#define MNEE_RECEIVER 2

/* mnee.Vertex for one vertex: the point and its tangent frame (dp_du, dp_dv about ng), the smooth normal n and its
 * derivatives, where it is (Embree's geometry, prim, instance; barycentrics u, v), its object and its triangle. */
typedef struct {
    double p[3], dp_du[3], dp_dv[3], n[3], ng[3], dn_du[3], dn_dv[3];
    double u, v;
    int64_t geometry, prim, instance, owner;
    Triangle tri;
} MneeVertex;

/* A chain of c interfaces: vertices, the relative index across each seen from its front (eta), the sampled
 * microfacet offsets h and the refractive closure's slot at each. */
typedef struct {
    int c;
    MneeVertex x[MNEE_MAX_CAUSTIC_CASTERS];
    double eta[MNEE_MAX_CAUSTIC_CASTERS], h[MNEE_MAX_CAUSTIC_CASTERS][2];
    int slot[MNEE_MAX_CAUSTIC_CASTERS];
} MneeChain;

/* mnee.unit: out = a / |a| (|a| floored at 1e-300); returns |a|. */
INLINE double mn_unit(const double *a, double *out)
{
    double length = sqrt(dot3(a, a));
    double inv = 1.0 / (length > 1e-300 ? length : 1e-300);
    for (int c = 0; c < 3; c++) out[c] = a[c] * inv;
    return length;
}

/* The part of d across the unit H, negated: -(d - H (d.H)). */
INLINE void mn_neg_across(const double *d, const double *H, double *out)
{
    double k = dot3(d, H);
    for (int c = 0; c < 3; c++) out[c] = -(d[c] - H[c] * k);
}

/* mnee.make_orthonormals: unit tangents a, b with a x b = N (Cycles' make_orthonormals). */
INLINE void mn_orthonormals(const double *N, double *a, double *b)
{
    double t[3];
    if (N[0] == N[1] && N[0] == N[2]) { t[0] = N[2] - N[1]; t[1] = N[0] + N[2]; t[2] = -N[1] - N[0]; }
    else { t[0] = N[2] - N[1]; t[1] = N[0] - N[2]; t[2] = N[1] - N[0]; }
    mn_unit(t, a);
    cross3(N, a, b);
}

/* mnee.inverse22: inv = M^-1; returns 0 where |det| < MNEE_MIN_DETERMINANT. */
INLINE int mn_inverse22(const double M[2][2], double inv[2][2])
{
    double det = M[0][0] * M[1][1] - M[0][1] * M[1][0];
    int ok = fabs(det) >= MNEE_MIN_DETERMINANT;
    double safe = ok ? det : 1.0;
    inv[0][0] = M[1][1] / safe; inv[0][1] = -M[0][1] / safe;
    inv[1][0] = -M[1][0] / safe; inv[1][1] = M[0][0] / safe;
    return ok;
}

INLINE void mn_mat_mat(const double A[2][2], const double B[2][2], double out[2][2])
{
    double r[2][2];
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) r[i][j] = A[i][0] * B[0][j] + A[i][1] * B[1][j];
    memcpy(out, r, sizeof r);
}

INLINE void mn_mat_vec(const double M[2][2], const double *x, double *out)
{
    double r0 = M[0][0] * x[0] + M[0][1] * x[1], r1 = M[1][0] * x[0] + M[1][1] * x[1];
    out[0] = r0; out[1] = r1;
}

/* shadows.error_bound for one point P (3) on triangle V (9): ROBUST_ULPS float32 ulps of the largest coordinate. */
INLINE double mn_error_bound(const double *P, const double *V)
{
    double m = largest3(P);
    for (int k = 0; k < 3; k++) if (largest3(V + 3 * k) > m) m = largest3(V + 3 * k);
    return ROBUST_ULPS * FLOAT32_EPSILON * m;
}

/* One ray O + t D (t < t_max) through Embree: 1 where it hits, with Embree's answer. */
static int mn_intersect(const DirectSettings *ds, const double *O, const double *D, double t_max, double time,
                        int64_t *geometry, int64_t *prim, int64_t *instance, double *u, double *v, double *t)
{
    RayHitPacket one;
    int valid[PACKET] ALIGNED(32);
    set_lane(&one.ray, 0, O, D, t_max);
    set_time(&one.ray, 0, time);
    close_packet(&one.ray, valid, 1);
    clear_hits(&one);
    ds->intersect(valid, ds->scene, &one, NULL);
    if (one.hit.geomID[0] == INVALID_ID) return 0;
    *geometry = (int64_t)one.hit.geomID[0];
    *prim = (int64_t)one.hit.primID[0];
    *instance = instance_of(&one.hit, 0);
    *u = (double)one.hit.u[0];
    *v = (double)one.hit.v[0];
    *t = (double)one.ray.tfar[0];
    return 1;
}

/* The shadow caustics bits of an object (mnee.CASTER, RECEIVER; 0 for none). */
INLINE int mn_flags(const GeometryTables *g, int64_t owner)
{
    return g->caustics != NULL && owner >= 0 ? (int)g->caustics[owner] : 0;
}

/* Whether a closure kind is a caster's refractive closure (mnee.refractive_kinds). */
INLINE int mn_refractive(int kind)
{
    return kind == BSDF_GLASS || kind == BSDF_ROUGH_GLASS || kind == BSDF_BECKMANN_GLASS;
}

/* mnee.vertex_at for one vertex: at barycentrics (u, v) of Embree's triangle (geometry, prim, instance). */
static void mnee_vertex(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance, double u, double v,
                        double time, MneeVertex *x)
{
    Triangle *tri = &x->tri;
    memset(tri, 0, sizeof *tri);
    tri->object = -1;
    hit_triangle(g, geometry, prim, instance, 1, time, tri);
    const double *V = tri->V;
    double w = 1.0 - u - v, N0[3], N1[3], N2[3], f[3], dp_du[3], dp_dv[3], dn_du[3], dn_dv[3], a[3], b[3];
    for (int c = 0; c < 3; c++) {
        N0[c] = tri->smooth ? tri->normals[c] : tri->Ng[c];
        N1[c] = tri->smooth ? tri->normals[3 + c] : tri->Ng[c];
        N2[c] = tri->smooth ? tri->normals[6 + c] : tri->Ng[c];
        x->p[c] = w * V[c] + u * V[3 + c] + v * V[6 + c];
        f[c] = w * N0[c] + u * N1[c] + v * N2[c];
    }
    double n_len = mn_unit(f, x->n);
    for (int c = 0; c < 3; c++) { dn_du[c] = (N1[c] - N0[c]) / n_len; dn_dv[c] = (N2[c] - N0[c]) / n_len; }
    double ku = dot3(x->n, dn_du), kv = dot3(x->n, dn_dv);
    for (int c = 0; c < 3; c++) { dn_du[c] -= x->n[c] * ku; dn_dv[c] -= x->n[c] * kv; }
    /* The edges orthonormalised, and the normal's derivatives by the same linear map. */
    for (int c = 0; c < 3; c++) { dp_du[c] = V[3 + c] - V[c]; dp_dv[c] = V[6 + c] - V[c]; }
    double inv = 1.0 / sqrt(dot3(dp_du, dp_du));
    for (int c = 0; c < 3; c++) { dp_du[c] *= inv; dn_du[c] *= inv; }
    double along = dot3(dp_du, dp_dv);
    for (int c = 0; c < 3; c++) { dp_dv[c] -= along * dp_du[c]; dn_dv[c] -= along * dn_du[c]; }
    inv = 1.0 / sqrt(dot3(dp_dv, dp_dv));
    for (int c = 0; c < 3; c++) { dp_dv[c] *= inv; dn_dv[c] *= inv; }
    /* A frame about the face normal that does not depend on the triangle; the derivatives turned into it. */
    mn_orthonormals(tri->Ng, a, b);
    double cos_t = dot3(dp_du, a), sin_t = -dot3(dp_dv, a);
    for (int c = 0; c < 3; c++) {
        x->dn_du[c] = cos_t * dn_du[c] - sin_t * dn_dv[c];
        x->dn_dv[c] = sin_t * dn_du[c] + cos_t * dn_dv[c];
        x->dp_du[c] = a[c];
        x->dp_dv[c] = b[c];
        x->ng[c] = tri->Ng[c];
    }
    x->u = u; x->v = v;
    x->geometry = geometry; x->prim = prim; x->instance = instance;
    x->owner = owner_of(g, geometry, prim, instance);
}

/* The 2x2 block [[a.s, b.s], [a.t, b.t]]. */
INLINE void mn_frame_rows(const double *a, const double *b, const double *s, const double *t, double out[2][2])
{
    out[0][0] = dot3(a, s); out[0][1] = dot3(b, s);
    out[1][0] = dot3(a, t); out[1][1] = dot3(b, t);
}

/* A vertex's constraint (H in its frame s, t) moved by its neighbour v along v's dp_du, dp_dv: the direction w towards
 * v changes by (dp - w (w . dp)) / distance (il: 1 / the distance), through mn_neg_across into H, as the 2x2 block
 * [[dH_du.s, dH_dv.s], [dH_du.t, dH_dv.t]] (A for the previous vertex, Cn for the next). */
INLINE void mn_neighbour_block(const MneeVertex *v, const double *w, double il, const double *H, const double *s,
                               const double *t, double out[2][2])
{
    double ku = dot3(w, v->dp_du), kv = dot3(w, v->dp_dv), e_u[3], e_v[3], dH_du[3], dH_dv[3];
    for (int k = 0; k < 3; k++) {
        e_u[k] = (v->dp_du[k] - w[k] * ku) * il;
        e_v[k] = (v->dp_dv[k] - w[k] * kv) * il;
    }
    mn_neg_across(e_u, H, dH_du);
    mn_neg_across(e_v, H, dH_dv);
    mn_frame_rows(dH_du, dH_dv, s, t, out);
}

/* mnee.constraints for one chain: C (c, 2) and the blocks A, B, Cn (c, 2, 2); returns 0 where two vertices lie within
 * MNEE_MIN_DISTANCE. I: the receiver point; target: the light point, or the direction to the light where `fixed`. */
static int mnee_constraints(const MneeChain *ch, const double *I, const double *target, int fixed, double C[][2],
                            double A[][2][2], double B[][2][2], double Cn[][2][2])
{
    int c = ch->c, ok = 1;
    for (int i = 0; i < c; i++) {
        const MneeVertex *x = ch->x + i;
        const double *prev = i == 0 ? I : ch->x[i - 1].p;
        double d[3], wi[3], wo[3], ili, ilo;
        for (int k = 0; k < 3; k++) d[k] = prev[k] - x->p[k];
        ili = mn_unit(d, wi);
        if (i == c - 1) {
            for (int k = 0; k < 3; k++) d[k] = fixed ? target[k] : target[k] - x->p[k];
            ilo = mn_unit(d, wo);
            if (fixed) ilo = 1.0;
        } else {
            for (int k = 0; k < 3; k++) d[k] = ch->x[i + 1].p[k] - x->p[k];
            ilo = mn_unit(d, wo);
        }
        ok &= (ili >= MNEE_MIN_DISTANCE) & (ilo >= MNEE_MIN_DISTANCE);
        ili = 1.0 / (ili > 1e-300 ? ili : 1e-300);
        ilo = 1.0 / (ilo > 1e-300 ? ilo : 1e-300);
        double eta = dot3(wi, x->ng) < 0.0 ? 1.0 / ch->eta[i] : ch->eta[i];
        double H[3];
        for (int k = 0; k < 3; k++) d[k] = -(wi[k] + eta * wo[k]);
        double lh = mn_unit(d, H);
        double ilh = 1.0 / (lh > 1e-300 ? lh : 1e-300);
        ilo = ilo * eta * ilh;
        ili = ili * ilh;
        /* The shading frame (s, t) about n. */
        double dpn = dot3(x->dp_du, x->n), s[3], t[3];
        for (int k = 0; k < 3; k++) d[k] = x->dp_du[k] - dpn * x->n[k];
        double ls = mn_unit(d, s);
        double inv_s = 1.0 / (ls > 1e-300 ? ls : 1e-300);
        cross3(x->n, s, t);
        double dH_du[3], dH_dv[3], e_u[3], e_v[3];
        if (i > 0)
            mn_neighbour_block(ch->x + i - 1, wi, ili, H, s, t, A[i]);
        else
            memset(A[i], 0, sizeof(double[2][2]));
        int last_fixed = fixed && i == c - 1;
        double wiu = dot3(wi, x->dp_du), wiv = dot3(wi, x->dp_dv), wou = dot3(wo, x->dp_du), wov = dot3(wo, x->dp_dv);
        for (int k = 0; k < 3; k++) {
            if (last_fixed) {
                e_u[k] = ili * (-x->dp_du[k] + wi[k] * wiu);
                e_v[k] = ili * (-x->dp_dv[k] + wi[k] * wiv);
            } else {
                e_u[k] = -x->dp_du[k] * (ili + ilo) + wi[k] * (wiu * ili) + wo[k] * (wou * ilo);
                e_v[k] = -x->dp_dv[k] * (ili + ilo) + wi[k] * (wiv * ili) + wo[k] * (wov * ilo);
            }
        }
        mn_neg_across(e_u, H, dH_du);
        mn_neg_across(e_v, H, dH_dv);
        double ds_du[3], ds_dv[3], dt_du[3], dt_dv[3], c1[3], c2[3];
        double au = dot3(x->dp_du, x->dn_du), av = dot3(x->dp_du, x->dn_dv);
        for (int k = 0; k < 3; k++) {
            ds_du[k] = -inv_s * (au * x->n[k] + dpn * x->dn_du[k]);
            ds_dv[k] = -inv_s * (av * x->n[k] + dpn * x->dn_dv[k]);
        }
        double su = dot3(s, ds_du), sv = dot3(s, ds_dv);
        for (int k = 0; k < 3; k++) { ds_du[k] -= s[k] * su; ds_dv[k] -= s[k] * sv; }
        cross3(x->dn_du, s, c1); cross3(x->n, ds_du, c2);
        for (int k = 0; k < 3; k++) dt_du[k] = c1[k] + c2[k];
        cross3(x->dn_dv, s, c1); cross3(x->n, ds_dv, c2);
        for (int k = 0; k < 3; k++) dt_dv[k] = c1[k] + c2[k];
        B[i][0][0] = dot3(dH_du, s) + dot3(H, ds_du);
        B[i][0][1] = dot3(dH_dv, s) + dot3(H, ds_dv);
        B[i][1][0] = dot3(dH_du, t) + dot3(H, dt_du);
        B[i][1][1] = dot3(dH_dv, t) + dot3(H, dt_dv);
        if (i < c - 1)
            mn_neighbour_block(ch->x + i + 1, wo, ilo, H, s, t, Cn[i]);
        else
            memset(Cn[i], 0, sizeof(double[2][2]));
        C[i][0] = dot3(s, H) - ch->h[i][0];
        C[i][1] = dot3(t, H) - ch->h[i][1];
    }
    return ok;
}

/* mnee.solve_steps: dx (c, 2) the tangent steps that zero the linearised constraint (block-tridiagonal LU); 0 where
 * a pivot block is singular. */
static int mnee_solve(int c, double C[][2], double A[][2][2], double B[][2][2], double Cn[][2][2], double dx[][2])
{
    double Li[MNEE_MAX_CAUSTIC_CASTERS][2][2], R[MNEE_MAX_CAUSTIC_CASTERS][2], M[2][2], S[2][2], r[2];
    int ok = mn_inverse22(B[0], Li[0]);
    R[0][0] = C[0][0]; R[0][1] = C[0][1];
    for (int i = 1; i < c; i++) {
        mn_mat_mat(A[i], Li[i - 1], M);
        mn_mat_mat(M, Cn[i - 1], S);
        for (int j = 0; j < 2; j++)
            for (int k = 0; k < 2; k++) S[j][k] = B[i][j][k] - S[j][k];
        ok &= mn_inverse22(S, Li[i]);
        mn_mat_vec(M, R[i - 1], r);
        R[i][0] = C[i][0] - r[0]; R[i][1] = C[i][1] - r[1];
    }
    mn_mat_vec(Li[c - 1], R[c - 1], dx[c - 1]);
    for (int i = c - 2; i >= 0; i--) {
        mn_mat_vec(Cn[i], dx[i + 1], r);
        double q[2] = {R[i][0] - r[0], R[i][1] - r[1]};
        mn_mat_vec(Li[i], q, dx[i]);
    }
    return ok;
}

/* mnee.project for one ray: from `origin` (on a triangle of face normal start_Ng, corners start_V) towards `goal`,
 * out to twice that distance, past up to MNEE_MAX_INTERSECTION_COUNT other surfaces: 1 where it meets object
 * `owner`, with Embree's answer there. */
static int mnee_project(const DirectSettings *ds, const double *origin, const double *start_Ng, const double *start_V,
                        const double *goal, int64_t owner, double time, int64_t *geometry, int64_t *prim,
                        int64_t *instance, double *u, double *v)
{
    double d[3], D[3], O[3];
    for (int c = 0; c < 3; c++) d[c] = goal[c] - origin[c];
    double t_left = mn_unit(d, D) * MNEE_PROJECTION_DISTANCE_MULTIPLIER;
    spawn_ray(origin, start_Ng, D, mn_error_bound(origin, start_V), O);
    if (!(t_left > 0.0)) return 0;
    for (int n = 0; n < MNEE_MAX_INTERSECTION_COUNT; n++) {
        double t;
        if (!mn_intersect(ds, O, D, t_left, time, geometry, prim, instance, u, v, &t)) return 0;
        if (owner_of(ds->geometry, *geometry, *prim, *instance) == owner) return 1;
        Triangle tri;
        memset(&tri, 0, sizeof tri);
        hit_triangle(ds->geometry, *geometry, *prim, *instance, 0, time, &tri);
        double P[3];
        for (int c = 0; c < 3; c++) P[c] = O[c] + D[c] * t;
        spawn_ray(P, tri.Ng, D, mn_error_bound(P, tri.V), O);
        t_left -= t;
    }
    return 0;
}

/* mnee.newton for one chain, walked in place: 1 where it reaches the manifold. I, Ng, V: the receiver point, its face
 * normal towards the light and its triangle's corners. */
static int mnee_newton(const DirectSettings *ds, MneeChain *ch, const double *I, const double *Ng, const double *V,
                       const double *target, int fixed, double time)
{
    int c = ch->c, resolve = 1;
    double beta = 0.1, dx[MNEE_MAX_CAUSTIC_CASTERS][2];
    double C[MNEE_MAX_CAUSTIC_CASTERS][2], A[MNEE_MAX_CAUSTIC_CASTERS][2][2], B[MNEE_MAX_CAUSTIC_CASTERS][2][2];
    double Cn[MNEE_MAX_CAUSTIC_CASTERS][2][2];
    MneeVertex tentative[MNEE_MAX_CAUSTIC_CASTERS];
    for (int iteration = 0; iteration < MNEE_MAX_ITERATIONS; iteration++) {
        if (resolve) {
            if (!mnee_constraints(ch, I, target, fixed, C, A, B, Cn)) return 0;
            double norm = 0.0;
            for (int i = 0; i < c; i++) {
                double e = sqrt(C[i][0] * C[i][0] + C[i][1] * C[i][1]);
                if (e > norm) norm = e;
            }
            if (norm < MNEE_SOLVER_THRESHOLD) return 1;
            if (!mnee_solve(c, C, A, B, Cn, dx)) return 0;
        }
        /* Tentative vertices: a step in each tangent plane, projected back onto the vertex's object. */
        int reduce = 0;
        for (int i = 0; i < c; i++) {
            const MneeVertex *x = ch->x + i;
            tentative[i] = *x;
            if (reduce) continue;
            double step[3], goal[3];
            for (int k = 0; k < 3; k++) {
                step[k] = beta * (dx[i][0] * x->dp_du[k] + dx[i][1] * x->dp_dv[k]);
                goal[k] = x->p[k] - step[k];
            }
            const double *origin, *o_Ng, *o_V;
            if (i == 0) {           /* (the first step may end below the receiver: step the other way) */
                double below[3] = {goal[0] - I[0], goal[1] - I[1], goal[2] - I[2]};
                if (dot3(Ng, below) <= 0.0)
                    for (int k = 0; k < 3; k++) goal[k] = x->p[k] + step[k];
                origin = I; o_Ng = Ng; o_V = V;
            } else {
                origin = ch->x[i - 1].p; o_Ng = ch->x[i - 1].ng; o_V = ch->x[i - 1].tri.V;
            }
            int64_t geometry, prim, instance;
            double u, v;
            if (!mnee_project(ds, origin, o_Ng, o_V, goal, x->owner, time, &geometry, &prim, &instance, &u, &v)) {
                reduce = 1;
                continue;
            }
            mnee_vertex(ds->geometry, geometry, prim, instance, u, v, time, tentative + i);
            double moved[3] = {tentative[i].p[0] - x->p[0], tentative[i].p[1] - x->p[1], tentative[i].p[2] - x->p[2]};
            if (sqrt(dot3(moved, moved)) < MNEE_MIN_PROGRESS_DISTANCE) return 0;     /* (stuck) */
        }
        /* Every tentative interface must still refract: the receiver's and the light's sides on opposite sides. */
        if (!reduce)
            for (int i = 0; i < c; i++) {
                const MneeVertex *x = tentative + i;
                const double *prev = i == 0 ? I : tentative[i - 1].p;
                double wi[3], wo[3];
                for (int k = 0; k < 3; k++) {
                    wi[k] = prev[k] - x->p[k];
                    wo[k] = i == c - 1 ? (fixed ? target[k] : target[k] - x->p[k]) : tentative[i + 1].p[k] - x->p[k];
                }
                if (dot3(x->n, wi) * dot3(x->n, wo) >= 0.0) reduce = 1;
            }
        if (reduce) {
            beta *= 0.5;
            resolve = 0;
            if (beta < MNEE_MINIMUM_STEP_SIZE) return 0;
        } else {
            for (int i = 0; i < c; i++) ch->x[i] = tentative[i];
            resolve = 1;
            beta = beta * 2.0 < 1.0 ? beta * 2.0 : 1.0;
        }
    }
    return 0;
}

/* mnee.transfer for one chain: |det dx1/dx_light| (the light point in its tangent plane about light_Ng; a sun's
 * direction per solid angle) into *det; 0 where a pivot block is singular. */
static int mnee_transfer(const MneeChain *ch, const double *I, const double *target, int fixed, const double *light_Ng,
                         double *det)
{
    int c = ch->c;
    double C[MNEE_MAX_CAUSTIC_CASTERS][2], A[MNEE_MAX_CAUSTIC_CASTERS][2][2], B[MNEE_MAX_CAUSTIC_CASTERS][2][2];
    double Cn[MNEE_MAX_CAUSTIC_CASTERS][2][2], U[MNEE_MAX_CAUSTIC_CASTERS][2][2], Li[2][2], S[2][2];
    int ok = mnee_constraints(ch, I, target, fixed, C, A, B, Cn);
    ok &= mn_inverse22(B[0], Li);
    for (int i = 1; i < c; i++) {
        mn_mat_mat(Li, Cn[i - 1], U[i - 1]);
        mn_mat_mat(A[i], U[i - 1], S);
        for (int j = 0; j < 2; j++)
            for (int k = 0; k < 2; k++) S[j][k] = B[i][j][k] - S[j][k];
        ok &= mn_inverse22(S, Li);
    }
    const MneeVertex *m = ch->x + c - 1;
    double d[3], s[3], t[3], wi[3], H[3], dc[2][2];
    double k0 = dot3(m->dp_du, m->n);
    for (int k = 0; k < 3; k++) d[k] = m->dp_du[k] - k0 * m->n[k];
    mn_unit(d, s);
    cross3(m->n, s, t);
    const double *prev = c == 1 ? I : ch->x[c - 2].p;
    for (int k = 0; k < 3; k++) d[k] = prev[k] - m->p[k];
    mn_unit(d, wi);
    double eta = dot3(wi, m->ng) < 0.0 ? 1.0 / ch->eta[c - 1] : ch->eta[c - 1], scale = 1.0;
    if (fixed) {
        /* The light fixed: a direction (theta, phi) about n. */
        const double *wo = target;
        for (int k = 0; k < 3; k++) d[k] = -(wi[k] + eta * wo[k]);
        double lh = mn_unit(d, H);
        double ilo = -eta / (lh > 1e-300 ? lh : 1e-300);
        double cos_theta = dot3(wo, m->n), sin_theta = sqrt(fmax(1.0 - cos_theta * cos_theta, 0.0));
        double cos_phi = dot3(wo, s), sin_phi = sqrt(fmax(1.0 - cos_phi * cos_phi, 0.0));
        double da[3], db[3];
        for (int k = 0; k < 3; k++) {
            da[k] = ilo * (cos_theta * (cos_phi * s[k] + sin_phi * t[k]) - sin_theta * m->n[k]);
            db[k] = (ilo * sin_theta) * (-sin_phi * s[k] + cos_phi * t[k]);
        }
        double ka = dot3(da, H), kb = dot3(db, H);
        for (int k = 0; k < 3; k++) { da[k] -= H[k] * ka; db[k] -= H[k] * kb; }
        mn_frame_rows(da, db, s, t, dc);
        scale = 1.0 / fmax(MNEE_MIN_DISTANCE, fabs(sin_theta));
    } else {
        /* A light point moving in its tangent plane. */
        double wo[3], du[3], dv[3], eu[3], ev[3];
        for (int k = 0; k < 3; k++) d[k] = target[k] - m->p[k];
        double lo = mn_unit(d, wo);
        for (int k = 0; k < 3; k++) d[k] = -(wi[k] + eta * wo[k]);
        double lhp = mn_unit(d, H);
        double ilo = eta / (lo > 1e-300 ? lo : 1e-300) / (lhp > 1e-300 ? lhp : 1e-300);
        mn_orthonormals(light_Ng, du, dv);
        double ku = dot3(wo, du), kv = dot3(wo, dv);
        for (int k = 0; k < 3; k++) { eu[k] = (du[k] - wo[k] * ku) * ilo; ev[k] = (dv[k] - wo[k] * kv) * ilo; }
        double a[3], b[3];
        mn_neg_across(eu, H, a);
        mn_neg_across(ev, H, b);
        mn_frame_rows(a, b, s, t, dc);
    }
    double T[2][2];
    mn_mat_mat(Li, dc, T);
    for (int j = 0; j < 2; j++)
        for (int k = 0; k < 2; k++) T[j][k] = -T[j][k];
    for (int i = c - 2; i >= 0; i--) {
        mn_mat_mat(U[i], T, T);
        for (int j = 0; j < 2; j++)
            for (int k = 0; k < 2; k++) T[j][k] = -T[j][k];
    }
    *det = fabs(T[0][0] * T[1][1] - T[0][1] * T[1][0]) * scale;
    return ok;
}

/* mnee.sample_h for one interface: the microfacet offset h (2) sampled from GGX or Beckmann (kind) of roughness
 * alpha_x, alpha_y from u (2); 0 where smooth. */
static void mnee_sample_h(int kind, double alpha_x, double alpha_y, const double *u, double *h)
{
    h[0] = h[1] = 0.0;
    if (!(alpha_x > 0.0 && alpha_y > 0.0)) return;
    int iso = alpha_x == alpha_y;
    double phi;
    if (iso) phi = u[1] * 2.0 * PI;
    else {
        phi = atan(alpha_y / alpha_x * tan(2.0 * PI * u[1] + 0.5 * PI));
        if (u[1] > 0.5) phi += PI;
    }
    double cp = cos(phi), sp = sin(phi);
    double alpha2 = iso ? alpha_x * alpha_x : 1.0 / (cp * cp / (alpha_x * alpha_x) + sp * sp / (alpha_y * alpha_y));
    double tan2 = kind == BSDF_BECKMANN_GLASS ? alpha2 * -log(1.0 - u[0]) : alpha2 * u[0] / (1.0 - u[0]);
    double cos2 = 1.0 / (1.0 + tan2), sin_t = sqrt(fmax(1.0 - cos2, 0.0));
    h[0] = cp * sin_t;
    h[1] = sp * sin_t;
}

/* mnee.interface_weight for one interface: what closure c passes (3) from wi (the receiver's side) to wo (the
 * light's): its weight times (1 - F) at the refracting microfacet times G |h.wi| / |n.wi (n.h)^2|. */
static void mnee_interface(const Closure *cl, const double *wi, const double *wo, double *out)
{
    const double *p = cl->p;
    double ior = p[MF_IOR], d[3], Ht[3], R[3], T[3];
    double cosNI = dot3(cl->N, wi), cosNO = dot3(cl->N, wo);
    for (int k = 0; k < 3; k++) d[k] = -(ior * wo[k] + wi[k]);
    mn_unit(d, Ht);
    double cosHI = dot3(Ht, wi), cosM = dot3(cl->N, Ht);
    double alpha2 = p[MF_ALPHA] * p[MF_ALPHA];
    double lam = cl->kind == BSDF_BECKMANN_GLASS ? lambda_beckmann(alpha2, cosNI) + lambda_beckmann(alpha2, cosNO)
                                                 : lambda_ggx(alpha2, cosNI) + lambda_ggx(alpha2, cosNO);
    double G = alpha2 > 0.0 ? 1.0 / (1.0 + lam) : 1.0;
    glass_shares(p, cosHI, R, T);
    double denom = cosNI * cosM * cosM;
    double scale = G * fabs(cosHI / (fabs(denom) > 0.0 ? denom : INFINITY));
    for (int k = 0; k < 3; k++) out[k] = cl->weight[k] * T[k] * scale;
}

/* Shade a caster's surface s (triangle tri, Embree's geometry, prim, instance) for a shadow ray leaving along -wo into
 * sd (its closures in cl, storage). */
static void mnee_shade(const DirectSettings *ds, const Triangle *tri, const Surface *s, int64_t geometry, int64_t prim,
                       int64_t instance, double u, double v, const double *wo, ShaderResult *sd, Closure *cl,
                       double *storage, int room)
{
    no_closures(sd);
    sd->room = room;
    sd->c = cl;
    sd->storage = storage;
    LightPath path = {PATH_SHADOW, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
    shade_hit(ds->graphs, ds->geometry, ds->materials + tri->material, tri, s, geometry, prim, instance, u, v, wo,
              &path, NULL, 0, sd);
}

/* mnee.seed_chains for one light sample: the caster interfaces its straight shadow ray from the receiver hit sf
 * (along L, `distance` to the light) crosses, into ch; returns their count, 0 where none or where one is not
 * walkable (not smooth, no refractive closure, more than MNEE_MAX_CAUSTIC_CASTERS). */
static int mnee_seed(const DirectSettings *ds, const Surface *sf, const double *L, double distance, const double *u_h,
                     int room, MneeChain *ch)
{
    Closure cl[room];
    double storage[room * STORAGE_STRIDE];
    int finite = isfinite(distance);
    double t_left = finite ? distance : INFINITY, O[3], D[3] = {L[0], L[1], L[2]};
    spawn_ray(sf->I, sf->Ng, D, sf->offset, O);
    ch->c = 0;
    for (int n = 0; n < MNEE_MAX_INTERSECTION_COUNT; n++) {
        int64_t geometry, prim, instance;
        double u, v, t;
        if (!mn_intersect(ds, O, D, t_left, sf->time, &geometry, &prim, &instance, &u, &v, &t)) break;
        Triangle tri;
        memset(&tri, 0, sizeof tri);
        hit_triangle(ds->geometry, geometry, prim, instance, 1, sf->time, &tri);
        Surface s;
        surface_at(O, D, t, u, v, &tri, 0, &s);
        if (mn_flags(ds->geometry, tri.object) & MNEE_CASTER) {
            double wo[3] = {-D[0], -D[1], -D[2]};
            ShaderResult sd;
            mnee_shade(ds, &tri, &s, geometry, prim, instance, u, v, wo, &sd, cl, storage, room);
            int slot = -1;
            for (int k = 0; k < sd.n && slot < 0; k++) if (mn_refractive(sd.c[k].kind)) slot = k;
            if (ch->c >= MNEE_MAX_CAUSTIC_CASTERS || !s.smooth || slot < 0) return 0;
            const double *p = sd.c[slot].p;
            MneeVertex *x = ch->x + ch->c;
            x->geometry = geometry; x->prim = prim; x->instance = instance; x->u = u; x->v = v;
            ch->eta[ch->c] = s.backfacing ? 1.0 / p[MF_IOR] : p[MF_IOR];
            mnee_sample_h(sd.c[slot].kind, p[MF_ALPHA], p[MF_ALPHA], u_h, ch->h[ch->c]);
            ch->slot[ch->c] = slot;
            ch->c++;
        }
        spawn_ray(s.I, s.Ng, D, s.offset, O);
        t_left = finite ? t_left - t : INFINITY;
    }
    return ch->c;
}

/* mnee.sample for one light sample of a walked lamp (mnee.walks) at hit h of H: where a path through
 * the casters is found, f (3) its value before the light's colour and 1 / count, the shadow ray O, D, t from the last
 * interface to the light and `first` the direction from the receiver to its first interface; returns 1 then, else 0
 * (the ordinary light sample stays). L, distance, position, strength, color: the light sample. */
static int mnee_sample(const DirectSettings *ds, const BlockHits *H, int64_t h, const LightRecord *light,
                       const double *L, double distance, const double *position, double strength, const double *color,
                       const double *u_h, double *f, double *O, double *D, double *t_out, double *first)
{
    const Surface *sf = H->s + h;
    int room = H->room < 1 ? 1 : (int)H->room;
    MneeChain ch;
    int c = mnee_seed(ds, sf, L, distance, u_h, room, &ch);
    if (c == 0) return 0;
    /* (a chain past the render's bounce limits is not walked: its interfaces are bounces, the receiver a diffuse one) */
    if (H->transmission[h] + c - 1 > ds->mnee_limits[2] || H->diffuse[h] + 1 > ds->mnee_limits[1]
        || H->bounce[h] + c > ds->mnee_limits[0])
        return 0;
    for (int i = 0; i < c; i++)
        mnee_vertex(ds->geometry, ch.x[i].geometry, ch.x[i].prim, ch.x[i].instance, ch.x[i].u, ch.x[i].v, sf->time,
                    ch.x + i);
    const double *I = sf->I;
    double Ng[3], side = dot3(sf->Ng, L) < 0.0 ? -1.0 : 1.0;
    for (int k = 0; k < 3; k++) Ng[k] = sf->Ng[k] * side;
    Triangle receiver;
    memset(&receiver, 0, sizeof receiver);
    hit_triangle(ds->geometry, H->geometry[h], H->prim[h], H->instance[h], 0, sf->time, &receiver);
    int fixed = (int)light->kind == LIGHT_SUN;
    double target[3];
    for (int k = 0; k < 3; k++) target[k] = fixed ? L[k] : position[k];
    if (!mnee_newton(ds, &ch, I, Ng, receiver.V, target, fixed, sf->time)) return 0;
    /* The light seen from the last interface (mnee.light_values): a sun's strength per solid angle; a point's
     * intensity in the direction its light leaves (its strength there times t^2), facing the last vertex. */
    const MneeVertex *last = ch.x + c - 1;
    double emitted, light_Ng[3], d[3], w0[3], fc[3];
    if (fixed) {
        emitted = strength;
        for (int k = 0; k < 3; k++) light_Ng[k] = -L[k];
    } else {
        double Dl[3];
        for (int k = 0; k < 3; k++) d[k] = position[k] - last->p[k];
        double tl = mn_unit(d, Dl);
        int kind = (int)light->kind;
        int sphere = (kind == LIGHT_POINT || kind == LIGHT_SPOT) && light->radius > 0.0 && light->soft_falloff == 0;
        if (kind == LIGHT_AREA || sphere) {
            /* The light point held; its radiance towards the last vertex over the pdf of that direction there, in
             * the light's area measure (Cycles' area_light_mnee_sample_update; point_light_mnee_sample_update's
             * sphere: its cone's pdf times |cos| / t^2 at the point). */
            LightHit seen;
            int met = light_hit(light, last->p, Dl, tl * (1.0 + 1e-9) + 1e-9, &seen);
            if (sphere) {
                double r[3] = {position[0] - light->position[0], position[1] - light->position[1],
                               position[2] - light->position[2]};
                mn_unit(r, light_Ng);
            } else {
                for (int k = 0; k < 3; k++) light_Ng[k] = light->direction[k];
            }
            double pdf_area = met ? seen.pdf * fabs(-dot3(Dl, light_Ng)) / (tl * tl) : 0.0;
            double colour = color[0] + color[1] + color[2];
            double per_colour = met ? (seen.radiance[0] + seen.radiance[1] + seen.radiance[2])
                                      / (colour > 1e-300 ? colour : 1e-300) : 0.0;
            emitted = met && pdf_area > 0.0 ? per_colour / pdf_area : 0.0;
        } else {
            /* A point (or a disk facing the point) of the intensity it sends in the direction its light leaves: the
             * lamp as a point at the sampled light point, its strength at the last vertex times t^2. */
            LightRecord here = *light;
            here.radius = 0.0;
            here.delta = 1;
            for (int k = 0; k < 3; k++) here.position[k] = position[k];
            LightSample ls;
            double zero[3] = {0.0, 0.0, 0.0}, u0[2] = {0.0, 0.0};
            ls.emitter = -1;
            ls.hidden = 0;
            sample_light(&here, ds->context, last->p, zero, u0, &ls);
            emitted = ls.strength * tl * tl;
            for (int k = 0; k < 3; k++) light_Ng[k] = -Dl[k];
        }
    }
    for (int k = 0; k < 3; k++) d[k] = ch.x[0].p[k] - I[k];
    double w0_len = mn_unit(d, w0);
    shader_eval(H->sd + h, H->wo + 3 * h, w0, fc);
    double det;
    int ok = mnee_transfer(&ch, I, target, fixed, light_Ng, &det);
    double G = fabs(dot3(w0, ch.x[0].n)) / (w0_len * w0_len) * det;
    if (G > MNEE_G_CLAMP) G = MNEE_G_CLAMP;
    double through[3];
    for (int k = 0; k < 3; k++) through[k] = fc[k] * (emitted * G);
    /* Each interface: seen from where the path comes from, nothing else in the way, and what it lets through. */
    const double *start = I, *start_Ng = Ng, *start_V = receiver.V;
    Closure cl[room];
    double storage[room * STORAGE_STRIDE];
    for (int i = 0; i < c && ok; i++) {
        const MneeVertex *x = ch.x + i;
        double Di[3], Oi[3];
        for (int k = 0; k < 3; k++) d[k] = x->p[k] - start[k];
        double dist = mn_unit(d, Di);
        spawn_ray(start, start_Ng, Di, mn_error_bound(start, start_V), Oi);
        int64_t geometry, prim, instance;
        double u, v, th;
        if (mn_intersect(ds, Oi, Di, dist + MNEE_MIN_DISTANCE, sf->time, &geometry, &prim, &instance, &u, &v, &th)
            && (owner_of(ds->geometry, geometry, prim, instance) != x->owner || fabs(th - dist) > MNEE_MIN_DISTANCE))
            ok = 0;
        Surface s;
        surface_at(Oi, Di, dist, x->u, x->v, &x->tri, 0, &s);
        double wo[3] = {-Di[0], -Di[1], -Di[2]}, wnext[3], passed[3];
        ShaderResult sd;
        mnee_shade(ds, &x->tri, &s, x->geometry, x->prim, x->instance, x->u, x->v, wo, &sd, cl, storage, room);
        int slot = ch.slot[i];
        if (slot >= sd.n || !mn_refractive(sd.c[slot].kind)) { ok = 0; break; }
        for (int k = 0; k < 3; k++)
            d[k] = i == c - 1 ? (fixed ? target[k] : target[k] - x->p[k]) : ch.x[i + 1].p[k] - x->p[k];
        mn_unit(d, wnext);
        mnee_interface(sd.c + slot, wo, wnext, passed);
        for (int k = 0; k < 3; k++) through[k] *= passed[k];
        start = x->p; start_Ng = x->ng; start_V = x->tri.V;
    }
    if (!ok || !isfinite(through[0]) || !isfinite(through[1]) || !isfinite(through[2])) return 0;
    /* The shadow ray from the last interface to the light. */
    double Ll[3], face[3], zero[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < 3; k++) d[k] = fixed ? target[k] : target[k] - last->p[k];
    double t_last = mn_unit(d, Ll);
    if (fixed) t_last = INFINITY;
    double fs = dot3(last->ng, Ll) < 0.0 ? -1.0 : 1.0;
    for (int k = 0; k < 3; k++) face[k] = last->ng[k] * fs;
    shadow_ray(last->p, face, last->p, mn_error_bound(last->p, start_V), 0.0, Ll, t_last, fixed ? last->p : target,
               zero, 1, 0.0, O, D, t_out);
    for (int k = 0; k < 3; k++) { f[k] = through[k]; first[k] = w0[k]; }
    return 1;
}

/* vertex.shadow_caustics for one SampleBlock of a walked lamp (light->caustics bit 2) with `count` samples per hit: a
 * caster's samples from behind it (N.L < 0) are dropped; a receiver's samples in front of it walk, and where a path is
 * found the lane carries it instead (its f, weight, shadow ray and, for the light passes, L the direction to the
 * first interface), with no MIS (as Cycles: the walk replaces the light sample). */
static void mnee_block(SampleBlock *b, const BlockHits *H, const DirectSettings *ds, const LightRecord *light,
                       int64_t count)
{
    uint32_t stream = stream_of((int64_t)ds->seed, (int64_t)light->dimension + ds->dimension + 2);
    for (int64_t k = 0; k < b->n; k++) {
        if (b->keep[k] == 0.0) continue;
        int64_t h = b->hit[k];
        int flags = mn_flags(ds->geometry, owner_of(ds->geometry, H->geometry[h], H->prim[h], H->instance[h]));
        if (flags == 0) continue;
        double L[3] = {b->L[0][k], b->L[1][k], b->L[2][k]}, N[3] = {b->N[0][k], b->N[1][k], b->N[2][k]};
        int behind = dot3(N, L) < 0.0;
        if ((flags & MNEE_CASTER) && behind) { b->keep[k] = 0.0; continue; }
        if (!(flags & MNEE_RECEIVER) || behind) continue;
        double u_h[2], position[3] = {b->position[0][k], b->position[1][k], b->position[2][k]};
        double f[3], O[3], D[3], t, first[3], color[3] = {b->color[0][k], b->color[1][k], b->color[2][k]};
        sample_2d(stream, (int64_t)b->pixel[k], (int64_t)b->index[k], u_h);
        if (!mnee_sample(ds, H, h, light, L, b->distance[k], position, b->strength[k], color, u_h, f, O,
                         D, &t, first))
            continue;
        for (int c = 0; c < 3; c++) {
            b->f[c][k] = f[c];
            b->origin[c][k] = O[c];
            b->D[c][k] = D[c];
            b->L[c][k] = first[c];
        }
        b->t[k] = t;
        b->weight[k] = 1.0 / (double)count;
    }
}
