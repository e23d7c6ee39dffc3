/* What every BSDF's C file shares (core/materials/base.py, closures.py): closures and samples.
 *
 * Conventions as in base.py: wo points towards the viewer, wi towards the light, both unit; a
 * closure's N is its own unit normal on the viewer's side; eval returns f cos (0 below N) and the
 * pdf of its own sampling. */

/* A closure's kind (BSDF_*) and what it is (BSDF_FLAG_*, bsdf_is) come from the table of BSDFs, generated into
 * core/native/boundary.gen.h from core/materials/registry.py. */

#define MAX_CLOSURES 8          /* closures.MAX_CLOSURES */
/* The closures a caustics filter takes away at a hit that a diffuse bounce's ray reached (closures.FILTER_*). */
enum { FILTER_REFLECTIVE = 1, FILTER_REFRACTIVE = 2 };
#define CLOSURE_PARAMS 32       /* closures.PARAMS */
#define NODE_PARAMS 40          /* closures.NODE_PARAMS: a shader node's inputs, a MaterialRecord's rows */

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

/* A material at one hit (closures.ShaderResult for one hit). storage: MAX_CLOSURES x CLOSURE_PARAMS
 * doubles the hit's shader may write its closures' parameters into (NULL where none is needed). */
typedef struct {
    int n;
    Closure c[MAX_CLOSURES];
    double emission[3];
    double transparency[3];
    double holdout[3];      /* the Holdout nodes' weight (closures.ShaderResult.holdout; 0: none) */
    double N[3];
    double *storage;
    const double *glossy;   /* the normal glossy lobes get while a node sets up (nodes.c), NULL: N */
    const double *hit_N;    /* the hit's own normal while a node with its own normal sets up (nodes.c), NULL: N */
    int caustics;           /* FILTER_* bits the caller sets before shading (0: every closure) */
} ShaderResult;

/* A direction sampled from one BSDF (base.BsdfSample for one hit). */
typedef struct {
    double wi[3];
    double weight[3];       /* f cos / pdf, without the closure's weight */
    double pdf;             /* inf for a delta BSDF, 0 where nothing was sampled */
} BsdfSample;

/* One material of the scene's MaterialTable, as core/integrators/compiled.py packs it. program 0: a
 * ConstantShader, n closures the same at every hit but for their normal. program 1: a NodeShader, n shader
 * nodes (kind: nodes.c NODE_*, weight, p: the node's inputs) set up per hit (nodes.c); graph: 0, or 1 + its
 * node graph's program in the render's GraphTables (graph.c), which overwrites inputs per hit. Only doubles. */
typedef struct {
    double n;
    double program;
    double graph;
    double kind[MAX_CLOSURES];
    double weight[MAX_CLOSURES][3];
    double sample_weight[MAX_CLOSURES];
    double p[MAX_CLOSURES][NODE_PARAMS];   /* a closure's CLOSURE_PARAMS, or a node's NODE_PARAMS inputs */
    double emission[3];
    double transparency[3];
    double shadow_opaque;   /* 1: opaque to shadow rays even where it lets light through (Transparent Shadows off) */
    double may_pass;        /* 1: it may let light through somewhere (a Transparent node, alpha) */
    double graph_emits;     /* 1: its node graph gives its emission (a texture): evaluated where light lands */
} MaterialRecord;
