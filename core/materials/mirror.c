/* A perfect mirror: core/materials/mirror.py. A delta BSDF: eval is 0, `sample` reflects. */

INLINE void mirror_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)c; (void)wo; (void)wi;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
}

/* R = 2 (N.wo) N - wo, with weight 1 and pdf inf (0 where R falls below the surface). */
INLINE void mirror_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    (void)u;
    const double *N = c->N;
    double cosine = dot3(N, wo);
    for (int k = 0; k < 3; k++) out->wi[k] = 2.0 * cosine * N[k] - wo[k];
    int above = dot3(N, out->wi) > 0.0;
    for (int k = 0; k < 3; k++) out->weight[k] = above ? 1.0 : 0.0;
    out->pdf = above ? INFINITY : 0.0;
}
