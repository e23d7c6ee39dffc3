/* The table of BSDFs: a closure's `kind` tag picks its functions (core/materials/__init__.py). */

INLINE void bsdf_f(const Closure *c, const double *N, const double *wo, const double *wi, double *f)
{
    switch (c->kind) {
    case BSDF_MIRROR: mirror_f(c, N, wo, wi, f); break;
    default: lambert_f(c, N, wo, wi, f); break;
    }
}

INLINE double bsdf_pdf(const Closure *c, const double *N, const double *wo, const double *wi)
{
    switch (c->kind) {
    case BSDF_MIRROR: return mirror_pdf(c, N, wo, wi);
    default: return lambert_pdf(c, N, wo, wi);
    }
}

INLINE void bsdf_sample(const Closure *c, const double *N, const double *wo, const double *u, BsdfSample *out)
{
    switch (c->kind) {
    case BSDF_MIRROR: mirror_sample(c, N, wo, u, out); break;
    default: lambert_sample(c, N, wo, u, out); break;
    }
}

/* The closure of material row `material` (a constant material: no work per hit beyond a copy). */
INLINE void closure_of(const MaterialRecord *materials, int32_t material, Closure *c)
{
    const MaterialRecord *m = materials + material;
    c->kind = (int)m->kind;
    for (int k = 0; k < 3; k++) c->color[k] = m->color[k];
}

/* f, pdf and a sample of each hit's BSDF over arrays (for the tests): kind (n,) int32, color, N, wo, wi
 * (n, 3), u (n, 2) float64 -> f (n, 3), pdf (n,), sampled wi (n, 3), weight (n, 3), sampled pdf (n,). */
EXPORT void primer_bsdf(int64_t n, const int32_t *kind, const double *color, const double *N, const double *wo,
                        const double *wi, const double *u, double *f, double *pdf, double *sampled, double *weight,
                        double *sampled_pdf)
{
    for (int64_t i = 0; i < n; i++) {
        Closure c = {kind[i], {color[3 * i], color[3 * i + 1], color[3 * i + 2]}};
        bsdf_f(&c, N + 3 * i, wo + 3 * i, wi + 3 * i, f + 3 * i);
        pdf[i] = bsdf_pdf(&c, N + 3 * i, wo + 3 * i, wi + 3 * i);
        BsdfSample s;
        bsdf_sample(&c, N + 3 * i, wo + 3 * i, u + 2 * i, &s);
        for (int k = 0; k < 3; k++) { sampled[3 * i + k] = s.wi[k]; weight[3 * i + k] = s.weight[k]; }
        sampled_pdf[i] = s.pdf;
    }
}

EXPORT int64_t primer_material_record_size(void) { return (int64_t)sizeof(MaterialRecord); }
