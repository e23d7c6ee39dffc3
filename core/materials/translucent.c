/* The Translucent BSDF: core/materials/translucent.py. f cos = max(-N.wi, 0) / pi; cosine-weighted sampling
 * around -N. */

INLINE void translucent_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)wo;
    double e = at_least(-dot3(c->N, wi), 0.0) * (1.0 / PI);
    f_cos[0] = f_cos[1] = f_cos[2] = e;
    *pdf = e;
}

/* Lambert's hemisphere, turned to the far side. */
INLINE void translucent_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    Closure turned = *c;
    for (int k = 0; k < 3; k++) turned.N[k] = -c->N[k];
    lambert_sample(&turned, wo, u, out);
}
