/* Area lights: core/lights/area.py, a one-sided planar emitter: a square or rectangle sampled over its spherical
 * rectangle where it is large against its distance, else (and a disk or ellipse) uniformly over its area; under a
 * narrow spread, only the part of it that can light the point (area_spread_region, Cycles'
 * area_light_spread_clamp_light). */

/* (emitters.c, included after this file, defines these: the spherical rectangle of Urena et al.) */
INLINE double rectangle_solid_angle(const double *P, const double *R);
INLINE void spherical_rectangle_sample(const double *P, const double *R, const double *u, double *L, double *t,
                                       double *pdf);

/* AreaLight.rectangle: the light as [corner, edge u, edge v] (9,) where it is a rectangle (its edges at right
 * angles to each other and its direction, to 1e-9; not a disk or ellipse): 1, else 0. */
INLINE int area_rectangle(const LightRecord *light, double *R)
{
    const double *U = light->axis_u, *V = light->axis_v;
    double lu = sqrt(dot3(U, U)), lv = sqrt(dot3(V, V));
    if (light->ellipse != 0.0 || !(lu * lv > 0.0) || fabs(dot3(U, V)) > 1e-9 * lu * lv
        || fabs(dot3(U, light->direction)) > 1e-9 * lu || fabs(dot3(V, light->direction)) > 1e-9 * lv) return 0;
    for (int c = 0; c < 3; c++) {
        R[c] = light->position[c] - 0.5 * U[c] - 0.5 * V[c];
        R[3 + c] = U[c];
        R[6 + c] = V[c];
    }
    return 1;
}

/* AreaLight.spherical for one point: whether the rectangle R's spherical sampling serves P (P's height over the
 * plane below AREA_NEAR of its diagonals). */
INLINE int area_spherical(const LightRecord *light, const double *R, const double *P)
{
    double to_P[3] = {P[0] - R[0], P[1] - R[1], P[2] - R[2]};
    double diagonal[3] = {R[3] + R[6], R[4] + R[7], R[5] + R[8]};
    double height = dot3(to_P, light->direction);
    return height * height < AREA_NEAR * AREA_NEAR * dot3(diagonal, diagonal);
}

/* area.spread_attenuation for a light whose Spread is below 180 degrees, at cos(theta_light) cos_light > 0: its
 * narrowing (tan h - tan theta)+ / norm; 1 for a light of full spread. */
INLINE double area_spread(const LightRecord *light, double cos_light)
{
    if (light->spread_narrow == 0.0) return 1.0;
    double tan_theta = sqrt(at_least(1.0 - cos_light * cos_light, 0.0)) / cos_light;
    return at_least(light->spread_tan_half - tan_theta, 0.0) / light->spread_norm;
}

/* AreaLight.spread_clamps: a spread below 180 degrees on a lamp whose edges meet each other and its direction at
 * right angles (to 1e-9): it samples only the part of it that can light the point (area_spread_region). */
INLINE int area_spread_clamps(const LightRecord *light)
{
    const double *U = light->axis_u, *V = light->axis_v;
    double lu = sqrt(dot3(U, U)), lv = sqrt(dot3(V, V));
    return light->spread_narrow != 0.0 && lu * lv > 0.0 && fabs(dot3(U, V)) <= 1e-9 * lu * lv
           && fabs(dot3(U, light->direction)) <= 1e-9 * lu && fabs(dot3(V, light->direction)) <= 1e-9 * lv;
}

/* area.SpreadRegion for one point: the region's centre, full edges U, V, whether it is an ellipse (else a
 * rectangle) and whether it is empty. */
typedef struct {
    double center[3], U[3], V[3];
    int round, empty;
} SpreadRegion;

/* AreaLight.spread_region for one point P (Cycles' area_light_spread_clamp_light): the clamped rectangle of a
 * square or rectangle; for an ellipse that, the spread disk or the whole lamp; for a disk the lens's rectangle, the
 * spread disk or the whole lamp; the smallest. */
INLINE void area_spread_region(const LightRecord *light, const double *P, SpreadRegion *g)
{
    const double *n = light->direction, *c = light->position, *axis_u = light->axis_u, *axis_v = light->axis_v;
    double lu = sqrt(dot3(axis_u, axis_u)), lv = sqrt(dot3(axis_v, axis_v));
    double eu[3], ev[3], to_P[3], foot[3], from_c[3];
    for (int k = 0; k < 3; k++) {
        eu[k] = axis_u[k] / lu;
        ev[k] = axis_v[k] / lv;
        to_P[k] = P[k] - c[k];
    }
    double h = dot3(to_P, n), r = h * light->spread_tan_half;
    for (int k = 0; k < 3; k++) {
        foot[k] = P[k] - h * n[k];
        from_c[k] = foot[k] - c[k];
    }
    double su = dot3(from_c, eu), sv = dot3(from_c, ev);
    double lo_u = at_least(su - r, -0.5 * lu), hi_u = at_most(su + r, 0.5 * lu);
    double lo_v = at_least(sv - r, -0.5 * lv), hi_v = at_most(sv + r, 0.5 * lv);
    g->empty = !(h > 0.0) || lo_u >= hi_u || lo_v >= hi_v;
    double mid_u = 0.5 * (lo_u + hi_u), mid_v = 0.5 * (lo_v + hi_v);
    for (int k = 0; k < 3; k++) {
        g->center[k] = c[k] + mid_u * eu[k] + mid_v * ev[k];
        g->U[k] = (hi_u - lo_u) * eu[k];
        g->V[k] = (hi_v - lo_v) * ev[k];
    }
    g->round = 0;
    if (light->ellipse == 0.0) return;
    double spread_area = PI * r * r, lamp_area = 0.25 * PI * lu * lv;
    int rectangle, use_spread;
    if (fabs(lu - lv) <= 1e-9 * (lu > lv ? lu : lv)) {              /* a disk: how the two disks meet */
        double R = 0.5 * lu, d = hypot(su, sv);
        g->empty = !(h > 0.0) || d >= R + r;
        int inner = d <= fabs(R - r);
        double lens_u = R + r - d, chord = d + (r * r - R * R) / d;
        double lens_v = fabs(R * R - r * r) >= d * d ? 2.0 * (R < r ? R : r)
                        : sqrt(at_least((2.0 * r) * (2.0 * r) - chord * chord, 0.0));
        rectangle = !inner && lens_u * lens_v < (lamp_area < spread_area ? lamp_area : spread_area);
        use_spread = inner ? r < R : !rectangle && spread_area < lamp_area;
        if (rectangle) {
            double to_center[3], across[3];
            for (int k = 0; k < 3; k++) to_center[k] = (c[k] - foot[k]) / d;    /* (d > 0 outside `inner`) */
            cross3(n, to_center, across);
            for (int k = 0; k < 3; k++) {
                g->center[k] = 0.5 * (c[k] + foot[k] + (r - R) * to_center[k]);
                g->U[k] = lens_u * to_center[k];
                g->V[k] = lens_v * across[k];
            }
        }
    } else {                                                        /* an ellipse */
        rectangle = (hi_u - lo_u) * (hi_v - lo_v) < (lamp_area < spread_area ? lamp_area : spread_area);
        use_spread = !rectangle && spread_area < lamp_area;
    }
    if (rectangle) return;
    g->round = 1;
    for (int k = 0; k < 3; k++) {
        g->center[k] = use_spread ? c[k] + su * eu[k] + sv * ev[k] : c[k];
        g->U[k] = use_spread ? 2.0 * r * eu[k] : axis_u[k];
        g->V[k] = use_spread ? 2.0 * r * ev[k] : axis_v[k];
    }
}

/* SpreadRegion's area: |U x V|, times pi / 4 for an ellipse; and its rectangle [corner, U, V] (9,). */
INLINE double spread_region_area(const SpreadRegion *g, double *R)
{
    double w[3];
    cross3(g->U, g->V, w);
    for (int k = 0; k < 3; k++) {
        R[k] = g->center[k] - 0.5 * g->U[k] - 0.5 * g->V[k];
        R[3 + k] = g->U[k];
        R[6 + k] = g->V[k];
    }
    return sqrt(dot3(w, w)) * (g->round ? 0.25 * PI : 1.0);
}

/* Where on a DISK or ELLIPSE light the sample u falls, in its unit square's frame: the concentric
 * map of the square onto the unit disk (Shirley-Chiu), halved (area.concentric_disk). */
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

/* The light's point (x, y) (in [-1/2, 1/2]^2 of its edges), seen from P: E_normal = L_e cos(theta_light)
 * A / d^2, narrowed by the spread; pdf = d^2 / (cos(theta_light) A). (Each value is computed whatever
 * the tests say, then chosen: loops over many samples need no branches. Values thrown away may be
 * inf or NaN.) */
INLINE void sample_area(const LightRecord *light, const double *P, double x, double y, LightSample *out)
{
    for (int c = 0; c < 3; c++)
        out->position[c] = x * light->axis_u[c] + y * light->axis_v[c] + light->position[c];
    double d = direction_to(P, out->position, out->L);
    double cos_light = -dot3(out->L, light->direction);
    double geometry = cos_light * light->area / (d * d);
    double pdf = d * d / (cos_light * light->area);
    geometry = ((cos_light > 0.0) & (d > 0.0)) ? geometry : 0.0;
    pdf = ((cos_light > 0.0) & (d > 0.0)) ? pdf : 0.0;
    geometry *= cos_light > 0.0 ? area_spread(light, cos_light) : 0.0;
    out->distance = d;
    out->strength = light->radiance * geometry;
    out->pdf = pdf;
}

/* AreaLight.sample_spread_region: a sample from P's spread region (over its spherical rectangle where it is a near
 * rectangle, else uniform in its area); none (pdf 0) where it is empty or the point falls outside a round lamp. */
INLINE void sample_area_spread(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    SpreadRegion g;
    area_spread_region(light, P, &g);
    double R[9];
    double area = spread_region_area(&g, R);
    double x = u[0] - 0.5, y = u[1] - 0.5, pdf, t;
    if (g.round) area_disk_point(u, &x, &y);
    int spherical = !g.round && !g.empty && area_spherical(light, R, P);
    if (spherical) {
        spherical_rectangle_sample(P, R, u, out->L, &t, &pdf);
        for (int c = 0; c < 3; c++) out->position[c] = P[c] + t * out->L[c];
    } else {
        for (int c = 0; c < 3; c++) out->position[c] = x * g.U[c] + y * g.V[c] + g.center[c];
        t = direction_to(P, out->position, out->L);
    }
    double cos_light = -dot3(out->L, light->direction);
    int facing = (cos_light > 0.0) & (t > 0.0) & !g.empty;
    if (light->ellipse != 0.0) {                                    /* (the region may reach past the lamp) */
        double offset[3] = {out->position[0] - light->position[0], out->position[1] - light->position[1],
                            out->position[2] - light->position[2]};
        double lx = dot3(offset, light->axis_u) / dot3(light->axis_u, light->axis_u);
        double ly = dot3(offset, light->axis_v) / dot3(light->axis_v, light->axis_v);
        facing &= lx * lx + ly * ly <= 0.25 * (1.0 + 1e-9);
    }
    if (!spherical) pdf = t * t / (cos_light * area);
    pdf = facing ? pdf : 0.0;
    double geometry = pdf > 0.0 ? 1.0 / pdf : 0.0;
    geometry *= facing ? area_spread(light, cos_light) : 0.0;
    out->distance = t;
    out->strength = light->radiance * geometry;
    out->pdf = pdf;
}

/* AreaLight.spread_region_pdf: the pdf with which sample_area_spread from O picks the lamp point t away along a ray
 * meeting it at cos(theta_light) cos_light > 0 (1 / Omega of a near rectangle, else t^2 / (cos A_region)). */
INLINE double area_spread_pdf(const LightRecord *light, const double *O, double cos_light, double t)
{
    SpreadRegion g;
    area_spread_region(light, O, &g);
    if (g.empty) return 0.0;
    double R[9];
    double area = spread_region_area(&g, R);
    if (!g.round && area_spherical(light, R, O)) {
        double omega = rectangle_solid_angle(O, R);
        return omega > 0.0 ? 1.0 / omega : 0.0;
    }
    return t * t / (cos_light * area);
}

/* AreaLight.sample for the unit-square sample u: over the spherical rectangle (pdf 1 / Omega, E_normal L_e / pdf)
 * where AreaLight.spherical, else uniform in area; under a narrow spread, from P's spread region. */
INLINE void sample_area_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
    if (area_spread_clamps(light)) {
        sample_area_spread(light, P, u, out);
        return;
    }
    double R[9];
    if (area_rectangle(light, R) && area_spherical(light, R, P)) {
        double t, pdf;
        spherical_rectangle_sample(P, R, u, out->L, &t, &pdf);
        for (int c = 0; c < 3; c++) out->position[c] = P[c] + t * out->L[c];
        double cos_light = -dot3(out->L, light->direction);
        int facing = (cos_light > 0.0) & (t > 0.0) & (pdf > 0.0);
        double geometry = facing ? 1.0 / pdf : 0.0;
        geometry *= facing ? area_spread(light, cos_light) : 0.0;
        out->distance = t;
        out->strength = light->radiance * geometry;
        out->pdf = facing ? pdf : 0.0;
        return;
    }
    double x = u[0] - 0.5, y = u[1] - 0.5;
    if (light->ellipse != 0.0) area_disk_point(u, &x, &y);
    sample_area(light, P, x, y, out);
}

/* AreaLight.hit: a ray meets the light's plane from its emitting side inside its shape: radiance
 * P / (pi A) (spread applied) and the pdf `sample` gives that direction (1 / Omega, or t^2 / (cos A)). */
INLINE int area_light_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    const double *n = light->direction, *U = light->axis_u, *V = light->axis_v;
    double cos_light = -dot3(D, n);
    if (!(cos_light > 0.0)) return 0;                           /* the back, or along the plane */
    double to_center[3] = {light->position[0] - O[0], light->position[1] - O[1], light->position[2] - O[2]};
    double t = dot3(to_center, n) / -cos_light;
    if (!((t > 0.0) & (t < t_max))) return 0;
    double X[3];
    for (int c = 0; c < 3; c++) X[c] = O[c] + t * D[c] - light->position[c];
    /* The point in the light's own coordinates: solve the 2 x 2 Gram system of its edges. */
    double uu = dot3(U, U), uv = dot3(U, V), vv = dot3(V, V), xu = dot3(X, U), xv = dot3(X, V);
    double det = uu * vv - uv * uv;
    double x = (vv * xu - uv * xv) / det, y = (uu * xv - uv * xu) / det;
    int inside = light->ellipse != 0.0 ? x * x + y * y <= 0.25 : (fabs(x) <= 0.5) & (fabs(y) <= 0.5);
    int hit = (cos_light > 0.0) & (t > 0.0) & (t < t_max) & inside;
    if (!hit) return 0;
    double attenuation = area_spread(light, cos_light);             /* (cos_light > 0 here) */
    out->t = t;
    attenuation *= ies_lamp_factor(light, D) * lamp_falloff(light, t);
    for (int c = 0; c < 3; c++) out->radiance[c] = light->radiance * attenuation * light->color[c];
    out->pdf = t * t / (cos_light * light->area);
    double R[9];
    if (area_rectangle(light, R) && area_spherical(light, R, O)) {
        double omega = rectangle_solid_angle(O, R);
        out->pdf = omega > 0.0 ? 1.0 / omega : 0.0;
    }
    if (area_spread_clamps(light)) out->pdf = area_spread_pdf(light, O, cos_light, t);
    return 1;
}

/* The table's entries (lights.gen.c): AreaLight.sample and AreaLight.hit. */
INLINE void area_sample(const LightRecord *light, const LightContext *ctx, const double *P, const double *N,
                        const double *u, LightSample *out)
{
    (void)ctx; (void)N;
    sample_area_light(light, P, u, out);
    out->strength *= ies_lamp_factor(light, out->L) * lamp_falloff(light, out->distance);
    lamp_color(light, out);
}

INLINE int area_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    if (!area_light_hit(light, O, D, t_max, out)) return 0;
    return 1;
}
