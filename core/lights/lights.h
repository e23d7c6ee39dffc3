/* What every light's C file shares: the light sample and hit (core/lights/base.py); the records (LightRecord,
 * EmitterTables, WorldTables, LightContext) are generated from core/lights into core/native/boundary.gen.h. */

/* A light's kind (LIGHT_*) and what it is (LIGHT_FLAG_*, light_is) come from the table of lights, generated into
 * core/native/boundary.gen.h from core/lights/__init__.py. */

/* Light arriving at one point (lights.base.LightSample for one sample). */
typedef struct {
    double L[3];            /* unit direction towards the light */
    double distance;        /* to the sampled light point (inf for the sun) */
    double strength;        /* irradiance at normal incidence per unit of the light's colour: L_e / pdf */
    double pdf;             /* solid-angle pdf of L (inf for lights without extent) */
    double position[3];     /* the sampled light point */
    double color[3];        /* the RGB the strength is of: the light's colour, or an emitter's radiance */
    int hidden;             /* the HIDDEN_FROM_* bits of an emitter's object (0 for other lights) */
    int64_t emitter;        /* the emissive triangle sampled (EmitterTables' index; emitters only) */
    double normal[3];       /* that triangle's unit face normal (emitters only; zero for other lights): a shadow
                             * ray stops off its surface (shadows.c shadow_ray) */
} LightSample;

/* Where a ray meets a light it was not aimed at (lights.base.LightHit for one ray). */
typedef struct {
    double t;               /* distance to it (inf for the sun) */
    double radiance[3];     /* RGB radiance towards the ray's origin */
    double pdf;             /* the pdf `sample` would have given the direction */
} LightHit;

/* spot.c's cone factor, which point.c's hit applies to a spot. */
static inline double spot_factor(const LightRecord *light, const double *L);

/* A direction uniform in solid angle within the cone (axis, t, b, cos_max): lights.base.sample_cone. */
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

/* The pdf 1 / (2 pi (1 - cos a)) of a direction uniform in a cone of half-angle a: lights.base.cone_pdf. */
INLINE double cone_pdf(double cos_max) { return 1.0 / (2.0 * PI * (1.0 - cos_max)); }

/* lamp_graph.c (included after graph.c): what a lamp's node program gives at its point P for light leaving along
 * `leaving` towards a point t away, reaching the path `path` (its counts: the Light Path node's depths; NULL: no
 * bounces), multiplied into `color` (3); nothing without a program. */
static void lamp_graph_tint(const LightRecord *light, const double *P, const double *leaving, double t,
                            const LightPath *path, double *color);

/* lamp_graph_tint for a light sample at a vertex of path `path`: leaving along -L from its sampled point. */
INLINE void lamp_sample_tint(const LightRecord *light, LightSample *out, const LightPath *path)
{
    if (light->lamp_graph == NULL) return;
    double leaving[3] = {-out->L[0], -out->L[1], -out->L[2]};
    lamp_graph_tint(light, out->position, leaving, out->distance, path, out->color);
}

/* lamp_graph_tint for a ray from O along D that met the lamp at out->t, carrying `path` (after its bounce). */
INLINE void lamp_hit_tint(const LightRecord *light, const double *O, const double *D, LightHit *out,
                          const LightPath *path)
{
    if (light->lamp_graph == NULL) return;
    double P[3], leaving[3];
    for (int c = 0; c < 3; c++) {
        P[c] = O[c] + D[c] * out->t;
        leaving[c] = -D[c];
    }
    lamp_graph_tint(light, P, leaving, out->t, path, out->radiance);
}
