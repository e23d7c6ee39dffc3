/* The BSSRDF closure: core/materials/subsurface.py. The compiled kernel does not walk subsurface scattering: a
   render with a subsurface closure runs the Python reference (core/render/__init__.py subsurface_reason), and C
   never sets one up. A BSSRDF has no value for a pair of directions, and samples none here. */

INLINE void subsurface_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)c; (void)wo; (void)wi;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
}

INLINE void subsurface_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    (void)c; (void)wo; (void)u;
    for (int k = 0; k < 3; k++) { out->wi[k] = 0.0; out->weight[k] = 0.0; }
    out->pdf = 0.0;
}
