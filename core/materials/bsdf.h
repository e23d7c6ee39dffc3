/* What every BSDF's C file shares (core/materials/base.py): a hit's closure and a sampled direction.
 *
 * Conventions as in base.py: wo points towards the viewer, wi towards the light, both unit; N is the
 * unit shading normal facing the viewer; f is returned without the cosine. */

enum { BSDF_LAMBERT = 0, BSDF_MIRROR = 1 };

/* One material of the scene's MaterialTable (core/materials/__init__.py), as C reads it. */
typedef struct {
    double kind;            /* BSDF_*: its class's place in BSDF_TYPES */
    double color[3];
} MaterialRecord;

/* The BSDF at one hit: which one, and its parameters there. */
typedef struct {
    int kind;
    double color[3];
} Closure;

/* A direction sampled from a BSDF (base.BsdfSample for one hit). */
typedef struct {
    double wi[3];
    double weight[3];       /* f |N.wi| / pdf */
    double pdf;             /* inf for a delta BSDF, 0 where nothing was sampled */
} BsdfSample;
