/* The Lambert BSDF: core/materials/lambert.py. f = colour / pi; cosine-weighted sampling. */

INLINE void lambert_f(const Closure *c, const double *N, const double *wo, const double *wi, double *f)
{
    (void)N; (void)wo; (void)wi;
    for (int k = 0; k < 3; k++) f[k] = c->color[k] * (1.0 / PI);
}

INLINE double lambert_pdf(const Closure *c, const double *N, const double *wo, const double *wi)
{
    (void)c; (void)wo;
    return at_least(dot3(N, wi), 0.0) * (1.0 / PI);
}

/* A point uniform on the unit disk (polar map), lifted onto the hemisphere around N: weight = colour. */
INLINE void lambert_sample(const Closure *c, const double *N, const double *wo, const double *u, BsdfSample *out)
{
    (void)wo;
    double r = sqrt(u[0]);
    double cos_phi, sin_phi;
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    double x = r * cos_phi, y = r * sin_phi;
    double z = sqrt(at_least(1.0 - u[0], 0.0));
    double t[3], b[3];
    orthonormal_frame(N, t, b);
    for (int k = 0; k < 3; k++) out->wi[k] = (t[k] * x + b[k] * y) + N[k] * z;
    out->pdf = z * (1.0 / PI);
    for (int k = 0; k < 3; k++) out->weight[k] = out->pdf > 0.0 ? c->color[k] : 0.0;
}
