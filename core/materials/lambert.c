/* The Lambert BSDF: core/materials/lambert.py. f cos = max(N.wi, 0) / pi; cosine-weighted sampling. */

INLINE void lambert_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)wo;
    double e = at_least(dot3(c->N, wi), 0.0) * (1.0 / PI);
    f_cos[0] = f_cos[1] = f_cos[2] = e;
    *pdf = e;
}

/* A point uniform on the unit disk (polar map), lifted onto the hemisphere around N: weight 1. */
INLINE void lambert_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    (void)wo;
    const double *N = c->N;
    double r = sqrt(u[0]);
    double cos_phi, sin_phi;
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    double x = r * cos_phi, y = r * sin_phi;
    double z = sqrt(at_least(1.0 - u[0], 0.0));
    double t[3], b[3];
    orthonormal_frame(N, t, b);
    for (int k = 0; k < 3; k++) out->wi[k] = (t[k] * x + b[k] * y) + N[k] * z;
    out->pdf = z * (1.0 / PI);
    for (int k = 0; k < 3; k++) out->weight[k] = out->pdf > 0.0 ? 1.0 : 0.0;
}
