/* A perfect mirror: core/materials/mirror.py. A delta BSDF: f and pdf are 0, `sample` reflects. */

INLINE void mirror_f(const Closure *c, const double *N, const double *wo, const double *wi, double *f)
{
    (void)c; (void)N; (void)wo; (void)wi;
    f[0] = f[1] = f[2] = 0.0;
}

INLINE double mirror_pdf(const Closure *c, const double *N, const double *wo, const double *wi)
{
    (void)c; (void)N; (void)wo; (void)wi;
    return 0.0;
}

/* R = 2 (N.wo) N - wo, with weight colour and pdf inf (0 where R falls below the surface). */
INLINE void mirror_sample(const Closure *c, const double *N, const double *wo, const double *u, BsdfSample *out)
{
    (void)u;
    double cosine = dot3(N, wo);
    for (int k = 0; k < 3; k++) out->wi[k] = 2.0 * cosine * N[k] - wo[k];
    int above = dot3(N, out->wi) > 0.0;
    for (int k = 0; k < 3; k++) out->weight[k] = above ? c->color[k] : 0.0;
    out->pdf = above ? INFINITY : 0.0;
}
