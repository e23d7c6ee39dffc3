/* Smooth glass: core/materials/glass.py. A delta BSDF: reflect or refract in the shares Fresnel gives.
 * p: the microfacet's slots (fresnel, ior = relative eta, f0, f90), then the reflection and transmission tints. */

enum { GLASS_REFLECT_TINT = 10, GLASS_TRANSMIT_TINT = 13 };

INLINE void glass_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)c; (void)wo; (void)wi;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
}

/* glass.shares: the reflected and transmitted shares R, T of light arriving at cos_i. */
INLINE void glass_shares(const double *p, double cos_i, double *R, double *T)
{
    double F[3];
    microfacet_fresnel(p, cos_i, F);
    int inside = 1.0 - (1.0 - cos_i * cos_i) / (p[MF_IOR] * p[MF_IOR]) <= 0.0;
    for (int k = 0; k < 3; k++) {
        R[k] = (inside ? 1.0 : F[k]) * p[GLASS_REFLECT_TINT + k];
        T[k] = (inside ? 0.0 : 1.0 - F[k]) * p[GLASS_TRANSMIT_TINT + k];
    }
}

/* Glass.albedo: the colour passes' albedo, its reflected and transmitted shares of light arriving at N.wo. */
INLINE void glass_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    glass_shares(c->p, clamp01(dot3(c->N, wo)), R, T);
}

INLINE void glass_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    const double *N = c->N, *p = c->p;
    double cos_i = dot3(N, wo), eta = p[MF_IOR], R[3], T[3];
    glass_shares(p, clamp01(cos_i), R, T);
    double mean_R = (R[0] + R[1] + R[2]) / 3.0, mean_T = (T[0] + T[1] + T[2]) / 3.0, total = mean_R + mean_T;
    double p_reflect = total > 0.0 ? mean_R / total : 1.0;
    int reflect = u[2] < p_reflect;     /* (the pick's rescaled number, as glass.py) */
    double cos_t = sqrt(at_least(1.0 - (1.0 - cos_i * cos_i) / (eta * eta), 0.0));
    for (int k = 0; k < 3; k++) {
        out->wi[k] = reflect ? 2.0 * cos_i * N[k] - wo[k] : -wo[k] / eta + (cos_i / eta - cos_t) * N[k];
        out->weight[k] = reflect ? R[k] / at_least(p_reflect, 1e-300) : T[k] / at_least(1.0 - p_reflect, 1e-300);
    }
    int ok = cos_i > 0.0 && total > 0.0;
    if (!ok) out->weight[0] = out->weight[1] = out->weight[2] = 0.0;
    out->pdf = ok ? INFINITY : 0.0;
}
