/* What every light's C file shares: the light record and the light sample (core/lights/base.py). */

enum { LIGHT_POINT = 0, LIGHT_SPOT = 1, LIGHT_SUN = 2, LIGHT_AREA = 3 };

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
} LightRecord;

/* Light arriving at one point (lights.base.LightSample for one sample). */
typedef struct {
    double L[3];            /* unit direction towards the light */
    double distance;        /* to the sampled light point (inf for the sun) */
    double strength;        /* irradiance at normal incidence per unit of the light's colour: L_e / pdf */
    double pdf;             /* solid-angle pdf of L (inf for lights without extent) */
    double position[3];     /* the sampled light point */
} LightSample;

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
