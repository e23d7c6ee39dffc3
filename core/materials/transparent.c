/* The Transparent BSDF: core/materials/transparent.py. A delta BSDF: the ray goes on straight, weight 1. */

INLINE void transparent_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)c; (void)wo; (void)wi;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
}

INLINE void transparent_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    (void)c; (void)u;
    for (int k = 0; k < 3; k++) { out->wi[k] = -wo[k]; out->weight[k] = 1.0; }
    out->pdf = INFINITY;
}
