/* The Oren-Nayar BSDF: core/materials/oren_nayar.py. f cos = N.wi (A + B t + multi (1 - E(N.wi))); cosine
 * sampling. p: A, B, multi (3), set up per hit (oren_nayar.params_of, nodes.c oren_nayar_params). */

enum { ON_A = 0, ON_B = 1, ON_MULTI = 2 };

/* oren_nayar.G: E(mu) = A pi + B G(mu). */
INLINE double oren_nayar_G(double mu)
{
    if (mu < 1e-6) return (PI / 2.0 - 2.0 / 3.0) - mu;
    double c = mu > 1.0 ? 1.0 : mu;
    double s = sqrt(at_least(1.0 - c * c, 0.0)), theta = acos(c);
    return s * (theta - 2.0 / 3.0 - s * c) + (2.0 / 3.0) * (s / c) * (1.0 - s * s * s);
}

/* oren_nayar.params_of for one hit: the closure's parameters from roughness, colour and mu_o = N.wo. */
INLINE void oren_nayar_params(double roughness, const double *albedo, double mu_o, double *p)
{
    double sigma = clamp01(roughness);
    double a = 1.0 / (PI + sigma * (PI / 2.0 - 2.0 / 3.0)), b = sigma * a;
    double E_avg = a * PI + ((2.0 * PI - 5.6) / 3.0) * b;
    double E_o = a * PI + b * oren_nayar_G(at_least(mu_o, 0.0));
    p[ON_A] = a;
    p[ON_B] = b;
    for (int j = 0; j < 3; j++) {
        double E_ms = (1.0 / PI) * albedo[j] * albedo[j] * (E_avg / (1.0 - E_avg)) / (1.0 - albedo[j] * (1.0 - E_avg));
        p[ON_MULTI + j] = E_ms * (1.0 - E_o);
    }
}

INLINE void oren_nayar_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    const double *p = c->p;
    double nl = at_least(dot3(c->N, wi), 0.0), nv = at_least(dot3(c->N, wo), 0.0);
    double t = dot3(wi, wo) - nl * nv;
    if (t > 0.0) t /= (nl > nv ? nl : nv) + 1.1754943508222875e-38;
    double E_l = p[ON_A] * PI + p[ON_B] * oren_nayar_G(nl);
    for (int j = 0; j < 3; j++) f_cos[j] = ((p[ON_A] + p[ON_B] * t) + p[ON_MULTI + j] * (1.0 - E_l)) * nl;
    *pdf = nl * (1.0 / PI);
}

INLINE void oren_nayar_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    lambert_sample(c, wo, u, out);
    double f_cos[3], pdf;
    oren_nayar_eval(c, wo, out->wi, f_cos, &pdf);
    out->pdf = pdf;
    for (int j = 0; j < 3; j++) out->weight[j] = pdf > 0.0 ? f_cos[j] / pdf : 0.0;
}
