/* The table of BSDFs: each BSDF's C file, and bsdf_eval / bsdf_sample switching on a closure's kind (generated
 * from core/materials/registry.py by tools/make_boundary.py). */
#include "bsdfs.gen.c"

/* Whether closures of kind `kind` are deltas: only their sampled directions carry light. */
/* (a BSSRDF's sample counts as a delta's: its weight over the chance of picking it, closures.sample_closures) */
INLINE int bsdf_is_delta(int kind) { return bsdf_is(kind, BSDF_FLAG_SINGULAR | BSDF_FLAG_SUBSURFACE); }

/* Whether closures of kind `kind` are glossy or mirror reflections, what the Reflective Caustics switch takes away
 * (materials.reflective: labelled glossy or singular, reflection only). */
INLINE int bsdf_is_reflective(int kind)
{
    return bsdf_is(kind, BSDF_FLAG_GLOSSY | BSDF_FLAG_SINGULAR) && bsdf_is(kind, BSDF_FLAG_REFLECTION)
           && !bsdf_is(kind, BSDF_FLAG_TRANSMISSION);
}

/* ConstantShader.shade's caustics filter (materials.caustics_filtered): whether the FILTER_* bits `caustics` take
 * closures of kind `kind` away, a reflective one with FILTER_REFLECTIVE, glass with both bits. */
INLINE int caustics_take(int kind, int caustics)
{
    int both = FILTER_REFLECTIVE | FILTER_REFRACTIVE;
    if (bsdf_is(kind, BSDF_FLAG_GLASS_TYPE)) return (caustics & both) == both;
    return bsdf_is_reflective(kind) && (caustics & FILTER_REFLECTIVE) != 0;
}

/* ------------------------------------------------------------------------------------------------
 * A hit's closures together (core/materials/closures.py)
 * --------------------------------------------------------------------------------------------- */

/* closures.bump_shadowing for one closure whose normal differs from the hit's sd->N: 0 where wi and the
 * closure's N lie on different sides of the smooth surface; for diffuse closures of a material with Bump Map
 * Correction on (`soften`), GGX's G1 at |Ns.wi| of a roughness growing with the angle between N and Ns. */
INLINE double bump_shadowing(const double *Ns, const double *N, const double *wi, int soften)
{
    double cos_si = dot3(Ns, wi), cos_sn = dot3(Ns, N), cos_ni = dot3(N, wi);
    if (cos_si * cos_sn * cos_ni < 0.0) return 0.0;
    if (!soften) return 1.0;
    double cos_i = fabs(cos_si), cos_d = fabs(cos_sn);
    if (cos_d >= 1.0 || cos_i >= 1.0) return 1.0;
    if (cos_i < 1e-6) return 0.0;
    double tan2_d = 1.0 / (cos_d * cos_d) - 1.0;
    double alpha2 = clamp01(0.125 * tan2_d);
    double tan2_i = (1.0 - cos_i * cos_i) / (cos_i * cos_i);
    return 2.0 / (1.0 + sqrt(1.0 + alpha2 * tan2_i));
}

/* closures.terminator_term: Cycles' Shading Offset bend of a closure's light arriving at cosine cos_in to its
 * normal, with the object's frequency multiplier (> 1). */
INLINE double terminator_term(double cos_in, double multiplier)
{
    if (cos_in > 1.0) cos_in = 1.0;
    double bent = cos(acos(cos_in) * multiplier);
    return bent > 0.0 && cos_in > 0.0 ? bent / cos_in : 0.0;
}

/* closures.eval_closures for one hit: f cos = sum of weight x f cos; pdf = sampling-weighted mean. A closure
 * whose normal is not the hit's (sd->N) is shadowed by bump_shadowing; the light of every closure is bent by the
 * object's Shading Offset (terminator_term) where it arrives in front of the closure's normal. */
/* direct.closures_left_out for one closure: whether a light sample on an object hidden from the rays `hidden`
 * (HIDDEN_FROM_* bits) leaves closure kind `kind` out, by its closure type (diffuse, glossy, transmission; glass
 * only if hidden from both glossy and transmission rays). */
INLINE int closure_left_out(int kind, int hidden)
{
    if (hidden == 0) return 0;
    int both = HIDDEN_FROM_GLOSSY | HIDDEN_FROM_TRANSMISSION;
    return (bsdf_is(kind, BSDF_FLAG_DIFFUSE_TYPE) && (hidden & HIDDEN_FROM_DIFFUSE) != 0)
           || (bsdf_is(kind, BSDF_FLAG_GLOSSY_TYPE) && (hidden & HIDDEN_FROM_GLOSSY) != 0)
           || (bsdf_is(kind, BSDF_FLAG_TRANSMISSION_TYPE) && (hidden & HIDDEN_FROM_TRANSMISSION) != 0)
           || (bsdf_is(kind, BSDF_FLAG_GLASS_TYPE) && (hidden & both) == both);
}

/* closures.bump_shadowing of closure c at wi: 1 where its normal is the hit's; is_eval 0 where c sampled wi itself
 * (Cycles' bsdf_sample: a non-diffuse closure is not shadowed there). */
INLINE double closure_shadowing(const ShaderResult *sd, const Closure *c, const double *wi, int is_eval)
{
    if (c->N[0] == sd->N[0] && c->N[1] == sd->N[1] && c->N[2] == sd->N[2]) return 1.0;
    int diffuse = bsdf_is(c->kind, BSDF_FLAG_DIFFUSE_TYPE);
    if (!is_eval && !diffuse) return 1.0;
    return bump_shadowing(sd->N, c->N, wi, diffuse && !sd->uncorrected);     /* (softened: Bump Map Correction) */
}

/* shader_eval for a light sample on an object hidden from the rays `hidden` (0: none): the closures it leaves
 * out add neither f cos nor pdf, their sampling weight still counts (closures.eval_closures' left_out); the closure
 * in slot `sampled` (-1: none) the one that sampled wi (eval_closures' sampled: closure_shadowing's is_eval 0). */
INLINE double shader_eval_sampled(const ShaderResult *sd, const double *wo, const double *wi, double *f_cos,
                                  int hidden, int sampled)
{
    double numerator = 0.0, total = 0.0;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = sd->c + k;
        if (closure_left_out(c->kind, hidden)) continue;
        double value[3], pdf;
        bsdf_eval(c, wo, wi, value, &pdf);
        double term = closure_shadowing(sd, c, wi, k != sampled);
        if (term != 1.0) {
            for (int j = 0; j < 3; j++) value[j] *= term;
            if (term == 0.0) pdf = 0.0;
        }
        if (sd->terminator > 1.0) {
            double cos_in = dot3(wi, c->N);
            if (cos_in >= 0.0) for (int j = 0; j < 3; j++) value[j] *= terminator_term(cos_in, sd->terminator);
        }
        for (int j = 0; j < 3; j++) f_cos[j] += c->weight[j] * value[j];
        numerator += c->sample_weight * pdf;
    }
    for (int k = 0; k < sd->n; k++) total += sd->c[k].sample_weight;
    return total > 0.0 ? numerator / total : 0.0;
}

/* shader_eval_sampled of a light's direction (no closure sampled it). */
INLINE double shader_eval_seen(const ShaderResult *sd, const double *wo, const double *wi, double *f_cos, int hidden)
{
    return shader_eval_sampled(sd, wo, wi, f_cos, hidden, -1);
}

INLINE double shader_eval(const ShaderResult *sd, const double *wo, const double *wi, double *f_cos)
{
    return shader_eval_seen(sd, wo, wi, f_cos, 0);
}

/* A sampled direction of a hit's closures (closures.ClosureSample for one hit). */
typedef struct {
    double wi[3];
    double weight[3];       /* f cos / pdf, closure weights included */
    double pdf;             /* inf for a delta closure, 0 where nothing was sampled */
    int delta;
    int kind;               /* the sampled closure's BSDF kind (-1 where none): a path counts bounces by it */
    int slot;               /* which of the hit's closures was sampled (a BSSRDF's walk reads its parameters) */
} ClosureSample;

/* closures.sampled_across_face: whether direction wi sampled from closure c leaves on the other side of the face
 * (Ng, facing the viewer) than of c's own normal, a sample Cycles' closures refuse (not Transparent, Ray Portal,
 * BSSRDF or hair closures: BSDF_FLAG_ANY_FACE). */
INLINE int sampled_across_face(const Closure *c, const double *Ng, const double *wi)
{
    if (bsdf_is(c->kind, BSDF_FLAG_STRAIGHT | BSDF_FLAG_SUBSURFACE | BSDF_FLAG_ANY_FACE)) return 0;
    return (dot3(Ng, wi) > 0.0) != (dot3(c->N, wi) > 0.0);
}

/* Whether a hit's closures are one Lambert on the hit's own normal sd->N with no Shading Offset: shader_sample and
 * kind_shares then take lambert_shader_sample's and kind_shares' short ways (the same operations, so the same numbers). */
INLINE int lambert_alone(const ShaderResult *sd)
{
    const Closure *c = sd->c;
    return sd->n == 1 && c->kind == BSDF_LAMBERT && sd->terminator <= 1.0 && c->N[0] == sd->N[0]
           && c->N[1] == sd->N[1] && c->N[2] == sd->N[2]
           && !bsdf_is(c->kind, BSDF_FLAG_SINGULAR | BSDF_FLAG_SUBSURFACE | BSDF_FLAG_OWN_WEIGHT);
}

/* A ClosureSample of closure slot `slot` that is no sample yet: no direction, weight or pdf (kind -1). */
INLINE void no_closure_sample(int slot, ClosureSample *out)
{
    out->delta = 0;
    out->kind = -1;
    out->slot = slot;
    out->pdf = 0.0;
    out->weight[0] = out->weight[1] = out->weight[2] = 0.0;
    out->wi[0] = out->wi[1] = out->wi[2] = 0.0;
}

/* shader_sample for a lambert_alone hit, step by step as the loops there run for one closure (0.0 + x where they
 * start a sum at 0, closure_shadowing 1 on the closure's own normal): no loops, no table switch. */
INLINE void lambert_shader_sample(const ShaderResult *sd, const double *wo, const double *u, double pick,
                                  const double *Ng, ClosureSample *out)
{
    const Closure *c = sd->c;
    double total = 0.0 + c->sample_weight;
    int chosen = total <= pick * total ? 1 : 0;         /* (the running sum after the one closure is the total) */
    no_closure_sample(chosen, out);
    if (chosen >= 1) return;
    double u3[3] = {u[0], u[1], 0.5};                   /* (Lambert reads no third number) */
    BsdfSample s;
    lambert_sample(c, wo, u3, &s);
    for (int j = 0; j < 3; j++) out->wi[j] = s.wi[j];
    if (Ng != NULL && s.pdf > 0.0 && sampled_across_face(c, Ng, s.wi)) return;
    out->kind = c->kind;
    if (!(s.pdf > 0.0)) { out->kind = -1; return; }
    double value[3], pdf_e, f_cos[3];
    lambert_eval(c, wo, out->wi, value, &pdf_e);
    for (int j = 0; j < 3; j++) f_cos[j] = 0.0 + c->weight[j] * value[j];
    double numerator = 0.0 + c->sample_weight * pdf_e;
    double pdf = total > 0.0 ? numerator / total : 0.0;
    for (int j = 0; j < 3; j++) out->weight[j] = pdf > 0.0 ? f_cos[j] / pdf : 0.0;
    out->pdf = pdf;
    if (!(pdf > 0.0)) out->kind = -1;
}

/* closures.sample_closures for one hit: pick a closure by sampling weight, sample it; unless a delta,
 * weight and pdf from all closures at that direction (an OWN_WEIGHT closure its own sampled share of them).
 * Ng: the hit's face normal (facing the viewer), or NULL: a direction sampled across the face is no sample. */
INLINE void shader_sample(const ShaderResult *sd, const double *wo, const double *u, double pick, const double *Ng,
                          ClosureSample *out)
{
    if (lambert_alone(sd)) { lambert_shader_sample(sd, wo, u, pick, Ng, out); return; }
    double total = 0.0, running = 0.0;
    for (int k = 0; k < sd->n; k++) total += sd->c[k].sample_weight;
    int chosen = 0;
    for (int k = 0; k < sd->n; k++) {
        running += sd->c[k].sample_weight;
        if (running <= pick * total) chosen = k + 1;
    }
    no_closure_sample(chosen, out);
    if (sd->n == 0 || chosen >= sd->n) return;
    const Closure *c = sd->c + chosen;
    /* Where `pick` fell inside the chosen closure's share: a third number for a BSDF that chooses between
     * lobes (rough glass), uniform and independent of the choice of closure (closures.sample_closures). */
    double share = c->sample_weight, before = 0.0;
    for (int k = 0; k < chosen; k++) before += sd->c[k].sample_weight;
    double within = share > 0.0 ? (pick * total - before) / share : 0.5;
    double u3[3] = {u[0], u[1], within < 0.0 ? 0.0 : (within >= 1.0 ? nextafter(1.0, 0.0) : within)};
    BsdfSample s;
    bsdf_sample(c, wo, u3, &s);
    for (int j = 0; j < 3; j++) out->wi[j] = s.wi[j];
    if (Ng != NULL && s.pdf > 0.0 && sampled_across_face(c, Ng, s.wi)) return;     /* (pdf 0, kind -1) */
    out->kind = c->kind;
    if (bsdf_is_delta(c->kind)) {
        double probability = c->sample_weight / total;
        for (int j = 0; j < 3; j++) out->weight[j] = c->weight[j] * s.weight[j] / at_least(probability, 1e-300);
        out->pdf = s.pdf;
        out->delta = 1;
        if (!(s.pdf > 0.0)) out->kind = -1;
        return;
    }
    if (!(s.pdf > 0.0)) { out->kind = -1; return; }
    double f_cos[3];
    double pdf = shader_eval_sampled(sd, wo, out->wi, f_cos, 0, chosen);
    if (bsdf_is(c->kind, BSDF_FLAG_OWN_WEIGHT)) {       /* closures.own_weight: its sample's share, not its eval's */
        double f_e[3], pdf_e, f_s[3], pdf_s = s.pdf;
        bsdf_eval(c, wo, out->wi, f_e, &pdf_e);
        for (int j = 0; j < 3; j++) f_s[j] = s.weight[j] * s.pdf;
        double term = closure_shadowing(sd, c, out->wi, 0);
        if (term != 1.0) {
            for (int j = 0; j < 3; j++) { f_e[j] *= term; f_s[j] *= term; }
            if (term == 0.0) { pdf_e = 0.0; pdf_s = 0.0; }
        }
        double cos_in = dot3(out->wi, c->N);
        if (sd->terminator > 1.0 && cos_in >= 0.0) {
            double bend = terminator_term(cos_in, sd->terminator);
            for (int j = 0; j < 3; j++) { f_e[j] *= bend; f_s[j] *= bend; }
        }
        for (int j = 0; j < 3; j++) f_cos[j] += c->weight[j] * (f_s[j] - f_e[j]);
        pdf += c->sample_weight * (pdf_s - pdf_e) / total;
    }
    for (int j = 0; j < 3; j++) out->weight[j] = pdf > 0.0 ? f_cos[j] / pdf : 0.0;
    out->pdf = pdf;
    if (!(pdf > 0.0)) out->kind = -1;
}

/* The ShaderResult of a constant material at a hit with shading normal N (sd->storage is left alone); its closures
 * only where sd has room (none where the caller reads only emission and transparency, no_closures). */
INLINE void shade_constant(const MaterialRecord *m, const double *N, ShaderResult *sd)
{
    sd->n = 0;
    for (int j = 0; j < 3; j++) sd->portal[j] = 0.0;
    for (int k = 0; k < (int)m->n; k++)
        if (bsdf_is((int)m->kind[k], BSDF_FLAG_PORTAL))
            for (int j = 0; j < 3; j++) sd->portal[j] += m->weight[3 * k + j];
    for (int k = 0; k < (int)m->n && sd->n < sd->room; k++) {
        int kind = (int)m->kind[k];
        if (caustics_take(kind, sd->caustics)) continue;      /* ConstantShader.shade's caustics filter */
        Closure *c = sd->c + sd->n++;
        c->kind = kind;
        c->sample_weight = m->sample_weight[k];
        for (int j = 0; j < 3; j++) { c->weight[j] = m->weight[3 * k + j]; c->N[j] = N[j]; }
        c->p = m->p + (int64_t)NODE_PARAMS * k;
        if (sd->blur > 0.0 && bsdf_is(kind, BSDF_FLAG_ROUGHENS) && sd->storage != NULL) {
            double *row = sd->storage + STORAGE_STRIDE * (sd->n - 1);     /* (Filter Glossy blurs a copy) */
            for (int j = 0; j < STORAGE_STRIDE; j++) row[j] = c->p[j];
            roughen(kind, row, sd->blur);
            c->p = row;
        }
    }
    for (int j = 0; j < 3; j++) {
        sd->emission[j] = m->emission[j];
        sd->transparency[j] = m->transparency[j];
        sd->holdout[j] = 0.0;
        sd->N[j] = N[j];
    }
}

/* eval and sample of one closure per row (for the tests): kind (n,) int32; weight, N, Ns (the hit's), wo, wi (n, 3),
 * params (n, PARAMS), u (n, 2), pick (n,) float64 -> f_cos (n, 3), pdf (n,), and a sample from the
 * single closure: sampled wi (n, 3), weight (n, 3), sampled pdf (n,). */
static void bsdf_rows(const BsdfArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        const double *weight = a->weight + 3 * i, *N = a->N + 3 * i, *wo = a->wo + 3 * i;
        ShaderResult sd;
        Closure one;
        no_closures(&sd);
        sd.n = sd.room = 1;
        sd.c = &one;
        Closure *c = sd.c;
        c->kind = a->kind[i];
        c->sample_weight = fabs((weight[0] + weight[1] + weight[2]) / 3.0);
        for (int j = 0; j < 3; j++) { c->weight[j] = weight[j]; c->N[j] = N[j]; sd.N[j] = a->Ns[3 * i + j]; }
        c->p = a->params + CLOSURE_PARAMS * i;
        a->pdf[i] = shader_eval(&sd, wo, a->wi + 3 * i, a->f_cos + 3 * i);
        ClosureSample s;
        shader_sample(&sd, wo, a->u + 2 * i, 0.5, NULL, &s);
        for (int j = 0; j < 3; j++) { a->sampled[3 * i + j] = s.wi[j]; a->sampled_weight[3 * i + j] = s.weight[j]; }
        a->sampled_pdf[i] = s.pdf;
    }
}

