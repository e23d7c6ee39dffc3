/* Hit triangles and their surfaces: WorldGeometry.triangle_data and core/geometry/surface.py.
 *
 * A hit is on a copied triangle (Embree's geometry 0: every placement's triangles copied into one
 * soup) or on a placement of an instanced mesh (geometry m + 1: one prototype, many transforms,
 * core/geometry/instancing.py). Either way, shading gets the triangle's camera-relative corners,
 * its face normal, its material row and, on smooth triangles, its corner normals. */

/* The rays an object may hide from (HIDDEN_FROM_*) and the holdout flag come from core/visibility.py. */

/* What shading needs of one hit triangle. */
typedef struct {
    double V[9];        /* corners, camera-relative: corner k at [3 k] */
    double Ng[3];       /* unit front-side normal */
    double normals[9];  /* corner normals (smooth triangles only) */
    int smooth;
    int32_t material;
    double time;        /* the time in the shutter it is placed at (a moving object's; 0.5 when nothing moves) */
    int64_t object;     /* its object (Scene.instances entry, owner_of; -1: none), hit_triangle's only */
} Triangle;

/* v / |v|, or 0 where |v| is 0, infinite or NaN: normals.safe_normalize (|v|^2 summed as numpy's
 * einsum sums three products: the first and last, then the middle). */
INLINE void unit_or_zero(const double *v, double *out)
{
    double length = sqrt((v[0] * v[0] + v[2] * v[2]) + v[1] * v[1]);
    int ok = isfinite(length) && length > 0.0;
    for (int c = 0; c < 3; c++) out[c] = ok ? v[c] / length : 0.0;
}

INLINE void cross3(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* Copied triangle f (WorldGeometry._copied_data): its corners widened to double, face normal and material. */
INLINE void copied_triangle(const GeometryTables *g, int64_t f, int want_smooth, Triangle *out)
{
    for (int k = 0; k < 3; k++) {
        const float *V = g->vertices + 3 * (int64_t)g->triangles[3 * f + k];
        for (int c = 0; c < 3; c++) out->V[3 * k + c] = (double)V[c];
    }
    for (int c = 0; c < 3; c++) out->Ng[c] = g->face_normals[3 * f + c];
    out->material = g->material[f];
    int32_t row = want_smooth && g->smooth_index ? g->smooth_index[f] : -1;
    out->smooth = row >= 0;
    if (out->smooth)
        for (int c = 0; c < 9; c++) out->normals[c] = (double)g->corner_normals[9 * (int64_t)row + c];
}

/* InstancedMesh.placements: placement j's [L | T] (3 x 4, row-major), a moving one's at `time`. */
INLINE void placement_at(const InstancedTables *mesh, int64_t j, double time, double *M)
{
    if (mesh->motion == NULL) {
        const float *A = mesh->transforms + 12 * j;
        for (int c = 0; c < 12; c++) M[c] = (double)A[c];
        return;
    }
    double L[9], T[3];
    decomposed_at(mesh->motion, (int64_t)mesh->motion_steps, time, L, T);
    for (int i = 0; i < 3; i++) {
        for (int c = 0; c < 3; c++) M[4 * i + c] = L[3 * i + c];
        M[4 * i + 3] = T[i];
    }
}

/* InstancedMesh.object_corners for one vertex: its object-space point, a deforming mesh's at `time` (linear between
 * the two vertex steps around it). */
INLINE void object_point(const InstancedTables *mesh, int64_t vertex, double time, double *p)
{
    if (mesh->vertex_steps == NULL) {
        const float *P = mesh->vertices + 3 * vertex;
        for (int c = 0; c < 3; c++) p[c] = (double)P[c];
        return;
    }
    int64_t last = (int64_t)mesh->vertex_step_count - 1;
    int64_t step = (int64_t)(time * (double)last);
    if (step > last - 1) step = last - 1;
    double t = time * (double)last - (double)step;
    int64_t stride = 3 * (int64_t)mesh->vertex_count;
    const float *a = mesh->vertex_steps + step * stride + 3 * vertex, *b = a + stride;
    for (int c = 0; c < 3; c++) p[c] = (1.0 - t) * (double)a[c] + t * (double)b[c];
}

/* InstancedMesh.object_normals for one vertex: its object-space unit normal at `time`, linear between the two normal
 * steps around it, normalised (Cycles' motion_triangle_normals). */
INLINE void object_normal(const InstancedTables *mesh, int64_t vertex, double time, double *n)
{
    int64_t last = (int64_t)mesh->vertex_step_count - 1;
    int64_t step = (int64_t)(time * (double)last);
    if (step > last - 1) step = last - 1;
    double t = time * (double)last - (double)step, mixed[3];
    int64_t stride = 3 * (int64_t)mesh->vertex_count;
    const float *a = mesh->normal_steps + step * stride + 3 * vertex, *b = a + stride;
    for (int c = 0; c < 3; c++) mixed[c] = (1.0 - t) * (double)a[c] + t * (double)b[c];
    unit_or_zero(mixed, n);
}

/* Triangle `local` of placement j of an instanced mesh (WorldGeometry._instanced_data), a moving one's at `time`:
 * the corners placed by [L | T], the normal of the placed corners (turned back for a mirroring placement), the
 * corner normals turned by L's cofactor matrix (N' = cof(L) N, the sign of det L kept). */
INLINE void instanced_triangle(const InstancedTables *mesh, int64_t j, int64_t local, int want_smooth, double time,
                               Triangle *out)
{
    double M[12];
    placement_at(mesh, j, time, M);
    for (int k = 0; k < 3; k++) {
        double p[3];
        object_point(mesh, (int64_t)mesh->triangles[3 * local + k], time, p);
        for (int i = 0; i < 3; i++) out->V[3 * k + i] = (M[4 * i] * p[0] + M[4 * i + 1] * p[1] + M[4 * i + 2] * p[2]) + M[4 * i + 3];
    }
    double e1[3], e2[3], n[3];
    for (int c = 0; c < 3; c++) { e1[c] = out->V[3 + c] - out->V[c]; e2[c] = out->V[6 + c] - out->V[c]; }
    cross3(e1, e2, n);
    unit_or_zero(n, out->Ng);
    double flip = (double)mesh->flip[j];
    for (int c = 0; c < 3; c++) out->Ng[c] *= flip;
    out->material = mesh->material[(int64_t)mesh->material_row[j] * (int64_t)mesh->triangle_count + local];
    int32_t row = want_smooth ? mesh->smooth_index[local] : -1;
    out->smooth = row >= 0;
    if (!out->smooth) return;
    /* The cofactor matrix: its columns b x c, c x a, a x b for the columns a, b, c of L. */
    double a[3] = {M[0], M[4], M[8]}, b[3] = {M[1], M[5], M[9]}, cc[3] = {M[2], M[6], M[10]};
    double bc[3], ca[3], ab[3];
    cross3(b, cc, bc); cross3(cc, a, ca); cross3(a, b, ab);
    for (int k = 0; k < 3; k++) {
        const double *N = mesh->corner_normals + 9 * (int64_t)row + 3 * k;
        double moved[3];
        if (mesh->normal_steps != NULL) {        /* a deforming mesh's normal where it is at `time` */
            object_normal(mesh, (int64_t)mesh->triangles[3 * local + k], time, moved);
            N = moved;
        }
        double w[3];
        for (int i = 0; i < 3; i++) w[i] = ((bc[i] * N[0] + ca[i] * N[1]) + ab[i] * N[2]) * flip;
        unit_or_zero(w, out->normals + 3 * k);
    }
}

/* WorldGeometry.owners for one Embree hit: the Scene.instances entry of the object hit (-1: none). */
INLINE int64_t owner_of(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance)
{
    return geometry <= 0 ? (int64_t)g->instance[prim] : (int64_t)g->meshes[geometry - 1].owner[instance];
}

/* The hit triangle of Embree's answer (geometry id, primitive, placement), copied or instanced; a moving one where
 * it is at the ray's `time`. */
INLINE void hit_triangle(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance, int want_smooth,
                         double time, Triangle *out)
{
    if (geometry <= 0) copied_triangle(g, prim, want_smooth, out);
    else instanced_triangle(g->meshes + (geometry - 1), instance, prim, want_smooth, time, out);
    out->time = time;
    out->object = g->instance != NULL || geometry > 0 ? owner_of(g, geometry, prim, instance) : -1;
}

/* The material row of an Embree hit: hit_triangle's `material` alone, without reading or placing its corners. */
INLINE int32_t hit_material(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance)
{
    if (geometry <= 0) return g->material[prim];
    const InstancedTables *mesh = g->meshes + (geometry - 1);
    return mesh->material[(int64_t)mesh->material_row[instance] * (int64_t)mesh->triangle_count + prim];
}

/* WorldGeometry.hidden for one Embree hit: whether its object hides from the rays of `bit`. */
INLINE int hidden_from(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance, int bit)
{
    if (g->hidden == NULL) return 0;
    int64_t owner = owner_of(g, geometry, prim, instance);
    return owner >= 0 && (g->hidden[owner] & bit) != 0;
}

/* Every light or shadow set (core/lights/linking.py ALL_SETS): the membership of an emitter that is not linked. */
#define ALL_SETS UINT64_MAX

/* WorldGeometry.links for one Embree hit: column `column` of its object's instance_links (0 light set, 1 shadow set,
 * 2 light membership, 3 shadow membership), or the unlinked default. */
INLINE uint64_t links_of(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance, int column)
{
    int64_t owner = g->links == NULL ? -1 : owner_of(g, geometry, prim, instance);
    if (owner < 0) return column < 2 ? 0 : ALL_SETS;
    return g->links[4 * owner + column];
}

/* WorldGeometry.terminator_offsets for one Embree hit: its object's Shadow Terminator Geometry Offset, or
 * `fallback` (the render's) where it has none. */
INLINE double terminator_offset_of(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance,
                                   double fallback)
{
    int64_t owner = g->terminator == NULL ? -1 : owner_of(g, geometry, prim, instance);
    double own = owner < 0 ? -1.0 : g->terminator[2 * owner];
    return own >= 0.0 ? own : fallback;
}

/* WorldGeometry.ao_distances for one Embree hit: its object's own Fast GI AO Distance where nonzero, else `fallback`
 * (the render's). */
INLINE double ao_distance_of(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance, double fallback)
{
    int64_t owner = g->ao_distance == NULL ? -1 : owner_of(g, geometry, prim, instance);
    double own = owner < 0 ? 0.0 : g->ao_distance[owner];
    return own != 0.0 ? own : fallback;
}

/* WorldGeometry.terminator_multipliers for one Embree hit: its object's Shading Offset multiplier (1: none). */
INLINE double terminator_multiplier_of(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance)
{
    int64_t owner = g->terminator == NULL ? -1 : owner_of(g, geometry, prim, instance);
    return owner < 0 ? 1.0 : g->terminator[2 * owner + 1];
}

/* linking.in_sets: whether bit `set` of `membership` is set. */
INLINE int in_sets(uint64_t membership, uint64_t set)
{
    return ((membership >> set) & 1u) != 0;
}

/* A hit's surface (core/geometry/surface.py), with what its shadow rays need. */
typedef struct {
    double I[3];        /* the hit point */
    double N[3];        /* shading normal, facing the viewer */
    double Ng[3];       /* face normal, facing the viewer */
    double offset;      /* the robust shadow-ray offset (shadows.error_bound) */
    double lifted[3];   /* the terminator fix's point (smooth hits, when asked for) */
    int smooth;
    int32_t material;
    int backfacing;     /* 1: the ray hit the triangle from behind (leaves a closed object) */
    double t;           /* Embree's distance along the ray (the Light Path node's Ray Length) */
    double time;        /* its ray's time in the shutter: the rays it sends carry it (object motion blur) */
    int64_t object;     /* its triangle's object (Triangle.object): which medium it bounds (media.c medium_column) */
} Surface;

/* The surface of one hit: surface.hit_points, surface_at_hits, shadows.error_bound and, for the
 * terminator fix, shadows.terminator_points. O, D: its ray; t, u, v: Embree's answer. */
INLINE void surface_at(const double *O, const double *D, double t, double u, double v, const Triangle *tri,
                       int want_lift, Surface *s)
{
    const double *V = tri->V;
    double w = 1.0 - u - v;
    s->t = t;
    s->time = tri->time;
    s->object = tri->object;
    s->smooth = tri->smooth;
    s->material = tri->material;
    /* 1. I: the float64 ray meets the triangle's plane, unless that disagrees with Embree's t. */
    double to_corner[3] = {V[0] - O[0], V[1] - O[1], V[2] - O[2]};
    double t_plane = dot3(to_corner, tri->Ng) / dot3(D, tri->Ng);
    if (fabs(t_plane - t) <= 1e-5 * fabs(t) + 1e-30) {
        for (int c = 0; c < 3; c++) s->I[c] = O[c] + t_plane * D[c];
    } else {
        for (int c = 0; c < 3; c++) s->I[c] = w * V[c] + u * V[3 + c] + v * V[6 + c];
    }
    /* 2. The face normal, flipped when the triangle was hit from behind (N.D > 0). */
    double side = dot3(tri->Ng, D) > 0.0 ? -1.0 : 1.0;
    s->backfacing = side < 0.0;
    for (int c = 0; c < 3; c++) { s->Ng[c] = tri->Ng[c] * side; s->N[c] = s->Ng[c]; }
    /* 3. The robust offset: ROBUST_ULPS float32 ulps of the largest coordinate involved. */
    double magnitude = largest3(s->I);
    for (int k = 0; k < 3; k++) if (largest3(V + 3 * k) > magnitude) magnitude = largest3(V + 3 * k);
    s->offset = ROBUST_ULPS * FLOAT32_EPSILON * magnitude;
    if (!tri->smooth) return;
    /* 4. Smooth triangles: the corner normals (turned with the face) interpolated and renormalised. */
    double cn[9];
    for (int c = 0; c < 9; c++) cn[c] = tri->normals[c] * side;
    double n[3];
    for (int c = 0; c < 3; c++) n[c] = w * cn[c] + u * cn[3 + c] + v * cn[6 + c];
    double length = sqrt(dot3(n, n));
    if (isfinite(length) && length > 0.0)
        for (int c = 0; c < 3; c++) s->N[c] = n[c] / length;
    /* 5. The terminator fix's point: I projected onto each corner's tangent plane where it lies
     *    below it, the projections interpolated with the barycentrics. */
    if (want_lift) {
        double weight[3] = {w, u, v};
        s->lifted[0] = s->lifted[1] = s->lifted[2] = 0.0;
        for (int k = 0; k < 3; k++) {
            const double *corner = V + 3 * k, *normal = cn + 3 * k;
            double to_point[3] = {s->I[0] - corner[0], s->I[1] - corner[1], s->I[2] - corner[2]};
            double below = dot3(to_point, normal);
            if (below > 0.0) below = 0.0;
            for (int c = 0; c < 3; c++)
                s->lifted[c] += weight[k] * (corner[c] + (to_point[c] - below * normal[c]));
        }
    }
}


/* The scene a shader's Ambient Occlusion and Bevel nodes trace (core/integrators/shader_rays.c). */
typedef struct ShaderRays ShaderRays;

/* What those nodes trace with at one hit: the scene, the keys of their random numbers (the hit's pixel and sample,
 * its vertex's dimension shift) and whether its path bounced with a pdf below BEVEL_MIN_PDF (then Bevel keeps N). */
typedef struct {
    const ShaderRays *rays;
    int64_t pixel, sample, dimension;
    int blurry;
    double *aov;        /* where the hit's shader AOVs are added (its camera chain's lane: passes.c passes_aov), NULL:
                         * none */
} ShaderKeys;

/* What a material's node graph reads at one hit (core/materials/graph.py ShadingPoint). */
typedef struct {
    double attributes[MAX_ATTRIBUTES], d_du[MAX_ATTRIBUTES], d_dv[MAX_ATTRIBUTES];
    int width;
    double random;
    double N[3];
    double side;        /* +1: the front was hit, -1: the back */
    double L[9];        /* the object's linear transform, row-major */
    double dPdu[3], dPdv[3];
    double Ng[3];       /* the face normal, facing the viewer */
    LightPath path;     /* the path that reached the hit (graph.LightPath): the Light Path node asks */
    double I[3];        /* back along that ray (the material's wo): the Fresnel and Layer Weight nodes ask */
    double P[3];        /* the world point (camera-relative I plus the origin): the Geometry node's Position */
    double u, v;        /* the barycentrics: its Parametric */
    double t;           /* the distance along the ray: the Light Path node's Ray Length */
    const double *info; /* the object's row of geometry.instance_info: location, colour, alpha, pass index, then its
                           Object and Instancer attributes (RGBA each) */
    int64_t info_width; /* its columns (a column past them reads 0) */
    const ShaderRays *rays;   /* the scene to trace (Ambient Occlusion, Bevel), or NULL: they trace nothing */
    const Surface *surface;   /* the hit's surface (camera-relative point, robust offset), with `rays` only */
    int64_t geometry, prim, instance;   /* Embree's answer for the hit (its object), with `rays` only */
    int64_t pixel, sample, dimension;   /* the keys of its random numbers, with `rays` only */
    int blurry;                         /* 1: its path bounced with a pdf below BEVEL_MIN_PDF (Bevel keeps N) */
    double *aov;        /* where its AOV Output nodes add their values (graph.aov_values), NULL: the ops after
                           AOV_START do not run (Cycles' NODE_AOV_START) */
} ShadingPoint;

/* The Object Info of a scene without instances (no hit reads past its OBJECT_INFO_WIDTH columns then). */
static const double NO_INFO[OBJECT_INFO_WIDTH] = {0.0};

/* surface.shading_point for one hit on triangle `tri` (Embree's geometry, primitive, placement) with
 * surface `s` at barycentrics (u, v): the attributes interpolated (w at corner 0, u at 1, v at 2) and
 * their changes along u and v, the object's random number and transform, the side hit, the edges. */
INLINE void shading_point_at(const GeometryTables *g, int64_t geometry, int64_t prim, int64_t instance,
                             const Triangle *tri, const Surface *s, double u, double v, ShadingPoint *sp)
{
    int64_t row = 0, object = 0;
    if (geometry <= 0) {
        row = g->attribute_row != NULL ? (int64_t)g->attribute_row[prim] : 0;
        object = g->instance != NULL ? (int64_t)g->instance[prim] : 0;
        for (int c = 0; c < 9; c++) sp->L[c] = g->instance_linear != NULL ? g->instance_linear[9 * object + c] : (c % 4 == 0);
    } else {
        const InstancedTables *mesh = g->meshes + (geometry - 1);
        row = mesh->attribute_row != NULL ? (int64_t)mesh->attribute_row[prim] : 0;
        object = (int64_t)mesh->owner[instance];
        double A[12];
        placement_at(mesh, instance, s->time, A);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) sp->L[3 * i + j] = A[4 * i + j];
    }
    sp->random = g->instance_random != NULL ? g->instance_random[object] : 0.0;
    sp->info = g->instance_info != NULL ? g->instance_info + g->info_width * object : NO_INFO;
    sp->info_width = g->instance_info != NULL ? g->info_width : OBJECT_INFO_WIDTH;
    int width = g->attributes != NULL ? (int)g->attribute_width : 0;
    sp->width = width;
    if (width > 0) {
        const float *corner = g->attributes + 3 * (int64_t)width * row;
        double w = 1.0 - u - v;
        for (int k = 0; k < width; k++) {
            double c0 = (double)corner[k], c1 = (double)corner[width + k], c2 = (double)corner[2 * width + k];
            sp->attributes[k] = (w * c0 + u * c1) + v * c2;
            sp->d_du[k] = c1 - c0;
            sp->d_dv[k] = c2 - c0;
        }
    }
    sp->side = dot3(tri->Ng, s->Ng) < 0.0 ? -1.0 : 1.0;
    for (int c = 0; c < 3; c++) {
        sp->N[c] = s->N[c];
        sp->Ng[c] = s->Ng[c];
        sp->dPdu[c] = tri->V[3 + c] - tri->V[c];
        sp->dPdv[c] = tri->V[6 + c] - tri->V[c];
        sp->P[c] = s->I[c] + (g->origin != NULL ? g->origin[c] : 0.0);
    }
    sp->u = u;
    sp->v = v;
    sp->t = s->t;
    sp->rays = NULL;
    sp->surface = s;
    sp->geometry = geometry;
    sp->prim = prim;
    sp->instance = instance;
    sp->pixel = sp->sample = sp->dimension = 0;
    sp->blurry = 0;
}

/* ------------------------------------------------------------------------------------------------
 * Placing copies (core/geometry/geometry.py): face normals and turned corner normals, in one pass each
 * --------------------------------------------------------------------------------------------- */

/* normals.face_normals: each triangle's unit normal (e1 x e2 normalised, zero where degenerate) and
 * area (0.5 |e1 x e2|, 0 where not finite). vertices (v, 3) float64, triangles (t, 3) int64 ->
 * normals (t, 3), area (t,) float64. */
static void face_normals_rows(const FaceNormalsArgs *a)
{
    for (int64_t i = 0; i < a->t; i++) {
        const int64_t *corner = a->triangles + 3 * i;
        const double *p0 = a->vertices + 3 * corner[0], *p1 = a->vertices + 3 * corner[1];
        const double *p2 = a->vertices + 3 * corner[2];
        double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        double n[3];
        cross3(e1, e2, n);
        double half = 0.5 * sqrt((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]);      /* (np.linalg.norm's order) */
        a->area[i] = isfinite(half) ? half : 0.0;
        unit_or_zero(n, a->normals + 3 * i);
    }
}

/* geometry._place_copies' corner normals turned by the inverse transpose, N' = N M^-1 (row vectors),
 * normalised. corners (., 3, 3) float64, rows (n,) int64 the triangles' rows in it; inverse (p, 3, 3)
 * float64, placement (n,) int64 -> out (n, 3, 3) float64. */
static void turn_normals_rows(const TurnNormalsArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        const double *A = a->corners + 9 * a->rows[i], *B = a->inverse + 9 * a->placement[i];
        for (int r = 0; r < 3; r++) {
            double v[3];
            for (int c = 0; c < 3; c++) v[c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
            unit_or_zero(v, a->out + 9 * i + 3 * r);
        }
    }
}
