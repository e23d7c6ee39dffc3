/* Area lights: core/lights/area.py, a one-sided planar emitter: a square or rectangle sampled over its spherical
 * rectangle where it is large against its distance, else (and a disk or ellipse) uniformly over its area. */

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

/* AreaLight.sample for the unit-square sample u: over the spherical rectangle (pdf 1 / Omega, E_normal L_e / pdf)
 * where AreaLight.spherical, else uniform in area. */
INLINE void sample_area_light(const LightRecord *light, const double *P, const double *u, LightSample *out)
{
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
    lamp_sample_tint(light, out);
}

INLINE int area_hit(const LightRecord *light, const double *O, const double *D, double t_max, LightHit *out)
{
    if (!area_light_hit(light, O, D, t_max, out)) return 0;
    lamp_hit_tint(light, O, D, out);
    return 1;
}
