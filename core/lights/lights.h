/* What every light's C file shares: the light record and the light sample (core/lights/base.py). */

/* A light's kind (LIGHT_*) and what it is (LIGHT_FLAG_*, light_is) come from the table of lights, generated into
 * core/native/boundary.gen.h from core/lights/__init__.py. */

/* One light, prepared by its class's `pack` (core/lights/<kind>.py): everything that does not depend on
 * the shading point. Only doubles, so that its layout is the same on every compiler. */
typedef struct {
    double kind;            /* LIGHT_*: its class's place in core/lights/__init__.py's LIGHT_TYPES */
    double samples;         /* light samples per camera sample (1 for lights without extent) */
    double dimension;       /* the sampling dimension of its pattern: 16 + 4 * index */
    double delta;           /* 1: no extent (exact, one direction) */
    double color[3];
    double position[3];     /* point and spot: the centre; area: the centre */
    double direction[3];    /* spot: unit axis; sun: unit direction towards the sun; area: unit normal */
    double axis_u[3], axis_v[3];      /* area: the two edge vectors */
    double ellipse;         /* area: 1 for DISK and ELLIPSE */
    double area;            /* area: emitting area */
    double radiance;        /* area: P / (pi A); sphere: P / (4 pi^2 R^2) */
    double power, radius, soft_falloff;
    double strength;        /* sun: irradiance at normal incidence (delta) or carried by each sample (disk) */
    double sun_t[3], sun_b[3], sun_cos_max;      /* sun disk: the cone's frame and half-angle */
    double spot_frame;      /* 1: the spot has a (scaled) frame: use spot_inverse */
    double spot_inverse[9]; /* world to spot-local, row-major */
    double spot_cos_half, spot_blend_width;
    double spread_narrow;   /* area: 1 when spread < pi */
    double spread_tan_half, spread_norm;
    double hittable;        /* 1: rays can meet it (it has extent): BSDF rays find it, weighed by MIS */
    double camera;          /* 1: camera rays see it (Ray Visibility > Camera) */
} LightRecord;

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
} LightSample;

/* Where a ray meets a light it was not aimed at (lights.base.LightHit for one ray). */
typedef struct {
    double t;               /* distance to it (inf for the sun) */
    double radiance[3];     /* RGB radiance towards the ray's origin */
    double pdf;             /* the pdf `sample` would have given the direction */
} LightHit;

/* The emissive triangles as one light (core/lights/emitters.py MeshEmitters), camera-relative. */
typedef struct {
    const double *corners;      /* (t, 3, 3) */
    const double *normal;       /* (t, 3) unit front-side normals */
    const double *area;         /* (t,) */
    const double *emission;     /* (t, 3) radiance */
    const int32_t *sides;       /* (t,) FRONT 1 | BACK 2 */
    const double *nodes;        /* (k, 14) the light tree's nodes (core/lights/light_tree.py), root first */
    const int64_t *path;        /* (t,) each emitter's branch bits from the root (bit l: 1 = right) */
    const int64_t *depth;       /* (t,) each emitter's steps from the root to its leaf */
    const int64_t *sorted_prim; /* (t,) WorldGeometry's flat triangle index of each, ascending */
    const int64_t *order;       /* (t,) the emitter of each sorted_prim */
    double count;               /* t */
    const uint8_t *hidden;      /* (t,) each triangle's object's Ray Visibility bits (HIDDEN_FROM_*), or NULL */
    const uint8_t *textured;    /* (t,) 1: its material's node graph gives its emission (direct.c), or NULL */
    const int64_t *prim;        /* (t,) WorldGeometry's flat triangle index of each */
} EmitterTables;

/* The world (core/lights/world.py World and WorldLight): a constant colour or an equirectangular image. */
typedef struct {
    const float *image;         /* (H, W, 3) linear radiance, or NULL for a constant world */
    const double *map;          /* (h, w) importance map, or NULL */
    const double *rows;         /* (h + 1,) cumulative over rows */
    const double *columns;      /* (h, w + 1) cumulative within each row */
    double width, height;       /* the image's W, H */
    double map_width, map_height, total;
    double color[3];            /* a constant world's radiance */
    double strength;
    double rotation[9];         /* world to texture, row-major */
    double camera;              /* 1: camera rays see it */
    double lights;              /* 1: it lights surfaces */
} WorldTables;

/* spot.c's cone factor, which point.c's hit applies to a spot. */
static inline double spot_factor(const LightRecord *light, const double *L);

/* What the lights a render makes of its scene need besides their records. */
typedef struct {
    const EmitterTables *emitters;
    const WorldTables *world;
} LightContext;

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
