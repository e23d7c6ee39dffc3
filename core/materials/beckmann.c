/* The Beckmann microfacet BSDF: core/materials/beckmann.py. Microfacet's eval and sample (microfacet.c) with
 * Beckmann's D, Lambda and visible normals; p: as microfacet.c's. */

INLINE void beckmann_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    microfacet_albedo(c, wo, R, T);
}

INLINE void beckmann_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    microfacet_eval_with(c, wo, wi, f_cos, pdf, 1);
}

INLINE void beckmann_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    microfacet_sample_with(c, wo, u, out, 1);
}
