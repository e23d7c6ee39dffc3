/* Rough glass with the Beckmann distribution: core/materials/beckmann_glass.py. Rough glass's eval and sample
 * (rough_glass.c) with Beckmann's D, Lambda and visible normals; p: as glass.c's. */

INLINE void beckmann_glass_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    rough_glass_albedo(c, wo, R, T);
}

INLINE void beckmann_glass_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    rough_glass_eval_with(c, wo, wi, f_cos, pdf, 1);
}

INLINE void beckmann_glass_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    rough_glass_sample_with(c, wo, u, out, 1);
}
