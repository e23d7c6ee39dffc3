/* What every BSDF's C file shares (core/materials/base.py, closures.py): closures and samples.
 *
 * Conventions as in base.py: wo points towards the viewer, wi towards the light, both unit; a
 * closure's N is its own unit normal on the viewer's side; eval returns f cos (0 below N) and the
 * pdf of its own sampling. */

/* A closure's kind (BSDF_*) and what it is (BSDF_FLAG_*, bsdf_is) come from the table of BSDFs, generated into
 * core/native/boundary.gen.h from core/materials/registry.py, with CLOSURE_PARAMS, NODE_PARAMS, the
 * caustics filter's FILTER_* bits and a material's record (MaterialRecord). */


/* One closure at a hit: a BSDF of the table, its weight, its sampling weight, its normal, and its
 * CLOSURE_PARAMS parameters: a constant material's row (no copy per hit), or a row of the hit's own
 * parameter storage where a shader computed them. */
typedef struct {
    int kind;
    double weight[3];
    double sample_weight;
    double N[3];
    const double *p;
} Closure;

/* A material at one hit (closures.ShaderResult for one hit). Its caller makes the room: c, room closures (as many
 * as a hit of the scene's materials sets up, ChunkParams.closure_room: no limit of its own), and storage, room x
 * STORAGE_STRIDE doubles the hit's shader may write its closures' parameters into. Where a caller reads only the
 * emission, transparency and holdout, it makes none (no_closures): room 0, c and storage NULL. */
typedef struct {
    int n;
    int room;               /* closures c has room for: a shader sets up at most as many (nodes.c closure_add) */
    Closure *c;
    double emission[3];
    double transparency[3];
    double holdout[3];      /* the Holdout nodes' weight (closures.ShaderResult.holdout; 0: none) */
    double portal[3];       /* the Ray Portal closures' weight set up here, even without room (portal.portal_weight) */
    double N[3];
    double *storage;
    const double *glossy;   /* the normal glossy lobes get while a node sets up (nodes.c), NULL: N */
    const double *hit_N;    /* the hit's own normal while a node with its own normal sets up (nodes.c), NULL: N */
    int caustics;           /* FILTER_* bits the caller sets before shading (0: every closure) */
    double blur;            /* the roughness Filter Glossy raises microfacet lobes to, set before shading (0: none;
                             * path.filter_glossy_roughness, nodes.roughen) */
    double terminator;      /* the object's Shadow Terminator Shading Offset multiplier (closures.terminator_term;
                             * shade_hit sets it, 1 or less: none) */
    int uncorrected;        /* 1: the material has Bump Map Correction off (Closures.uncorrected; shade_material sets
                             * it) */
} ShaderResult;

#define STORAGE_STRIDE 18           /* doubles of a hit's storage per closure (a glass closure's, with a thin film) */

/* nodes.roughen for one closure: a lobe that roughens (BSDF_FLAG_ROUGHENS) gets its blurred params (alpha and
 * alpha_y for microfacet lobes, v, s, m0 for Chiang's hair, the roughness for Huang's) of at least `blur` (Cycles'
 * bsdf_blur). */
INLINE void roughen(int kind, double *row, double blur)
{
    if (!bsdf_is(kind, BSDF_FLAG_ROUGHENS)) return;
    for (int i = 0; i < 3; i++) {
        int j = BSDF_BLURRED_PARAMS[kind][i];
        if (j >= 0 && row[j] < blur) row[j] = blur;
    }
}

/* A ShaderResult made to hold only what a material emits and lets through (a shadow ray's, a transparent
 * surface passed, a texture's emission): no room for closures. */
INLINE void no_closures(ShaderResult *sd)
{
    sd->n = sd->room = 0;
    sd->portal[0] = sd->portal[1] = sd->portal[2] = 0.0;
    sd->c = NULL;
    sd->storage = NULL;
    sd->caustics = 0;
    sd->blur = 0.0;
    sd->terminator = 1.0;
    sd->uncorrected = 0;
}

/* A direction sampled from one BSDF (base.BsdfSample for one hit). */
typedef struct {
    double wi[3];
    double weight[3];       /* f cos / pdf, without the closure's weight */
    double pdf;             /* inf for a delta BSDF, 0 where nothing was sampled */
} BsdfSample;
