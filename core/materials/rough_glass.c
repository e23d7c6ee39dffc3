/* Rough glass: core/materials/rough_glass.py (its docstring has the model). GGX microfacets that reflect or
 * refract; p: as smooth glass's (glass.c), with alpha in slot 0 and the energy scale in MF_ENERGY. */

/* rough_glass.half_vector: the microfacet normal sending wi to wo (reflection, or refraction where
 * `transmit`), unit, and |eta wi + wo| (or |wo + wi|). */
INLINE double rough_glass_half_vector(const double *wo, const double *wi, double eta, int transmit, double *H)
{
    for (int k = 0; k < 3; k++) H[k] = transmit ? -(eta * wi[k] + wo[k]) : wo[k] + wi[k];
    double length = at_least(sqrt(dot3(H, H)), 1e-300);
    for (int k = 0; k < 3; k++) H[k] /= length;
    return length;
}

/* RoughGlass.albedo: the colour passes' albedo, its reflected and transmitted shares of light arriving at N.wo. */
INLINE void rough_glass_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    glass_shares(c->p, clamp01(dot3(c->N, wo)), R, T);
}

/* How often the sampler reflects at a microfacet with shares R, T (1 where neither carries light). */
INLINE double rough_glass_p_reflect(const double *R, const double *T, double *total)
{
    double mean_R = (R[0] + R[1] + R[2]) / 3.0;
    *total = mean_R + (T[0] + T[1] + T[2]) / 3.0;
    return *total > 0.0 ? mean_R / *total : 1.0;
}

/* RoughGlass.eval with GGX's distribution, or Beckmann's where `beckmann` (beckmann_glass.c). */
INLINE void rough_glass_eval_with(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf,
                                  int beckmann)
{
    const double *N = c->N, *p = c->p;
    double alpha2 = p[MF_ALPHA] * p[MF_ALPHA], eta = p[MF_IOR];
    double cos_NO = dot3(N, wo), cos_NI = dot3(N, wi);
    int transmit = cos_NI < 0.0;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
    /* 1. The microfacet normal that sends wi to wo, on N's side. */
    double H[3];
    double length = rough_glass_half_vector(wo, wi, eta, transmit, H);
    if (dot3(N, H) < 0.0) for (int k = 0; k < 3; k++) H[k] = -H[k];
    double cos_HO = dot3(H, wo), cos_HI = dot3(H, wi);
    /* 2. Pairs with the viewer above the surface (every such pair, as Cycles: rough_glass.connects). */
    if (!(cos_NO > 0.0 && cos_NI != 0.0 && alpha2 > ROUGHNESS_SQ_THRESHOLD)) return;
    /* 3. What it reflects and refracts, and how often the sampler picks each. */
    double R[3], T[3], total;
    glass_shares(p, clamp01(fabs(cos_HO)), R, T);
    double p_reflect = rough_glass_p_reflect(R, T, &total);
    double lobe = transmit ? 1.0 - p_reflect : p_reflect;
    /* 4. D times the Jacobian from H to wi, over N.wo; then masking and shadowing. */
    double jacobian = transmit ? eta * eta * fabs(cos_HO * cos_HI) / (length * length) : 0.25;
    double common = mf_D(beckmann, alpha2, dot3(N, H)) / cos_NO * jacobian;
    double lambda_O = mf_lambda(beckmann, alpha2, cos_NO), lambda_I = mf_lambda(beckmann, alpha2, fabs(cos_NI));
    *pdf = common * lobe / (1.0 + lambda_O);
    double scale = common / (1.0 + lambda_O + lambda_I) * p[MF_ENERGY];
    for (int k = 0; k < 3; k++) f_cos[k] = (transmit ? T[k] : R[k]) * scale;
}

INLINE void rough_glass_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    rough_glass_eval_with(c, wo, wi, f_cos, pdf, 0);
}

/* RoughGlass.sample with GGX's visible normals, or Beckmann's where `beckmann`. */
INLINE void rough_glass_sample_with(const Closure *c, const double *wo, const double *u, BsdfSample *out, int beckmann)
{
    const double *N = c->N, *p = c->p;
    double eta = p[MF_IOR];
    /* 1. A microfacet normal the viewer sees. */
    double t[3], b[3];
    orthonormal_frame(N, t, b);
    double local[3] = {dot3(t, wo), dot3(b, wo), dot3(N, wo)};
    if (!(local[2] > 0.0)) { local[0] = 0.0; local[1] = 0.0; local[2] = 1.0; }
    double h[3], H[3];
    if (beckmann) sample_visible_normal_beckmann(local, p[MF_ALPHA], p[MF_ALPHA], u, h);
    else sample_visible_normal(local, p[MF_ALPHA], p[MF_ALPHA], u, h);
    for (int k = 0; k < 3; k++) H[k] = (t[k] * h[0] + b[k] * h[1]) + N[k] * h[2];
    /* 2. Reflect or refract at it, in proportion to what it reflects and refracts. */
    double cos_HO = dot3(H, wo), R[3], T[3], total;
    glass_shares(p, clamp01(cos_HO), R, T);
    int reflect = u[2] < rough_glass_p_reflect(R, T, &total);
    double cos_t = sqrt(at_least(1.0 - (1.0 - cos_HO * cos_HO) / (eta * eta), 0.0));
    for (int k = 0; k < 3; k++)
        out->wi[k] = reflect ? 2.0 * cos_HO * H[k] - wo[k] : -wo[k] / eta + (cos_HO / eta - cos_t) * H[k];
    /* 3. Its value and pdf, from eval (a direction on the wrong side of N is no sample). */
    double f_cos[3];
    rough_glass_eval_with(c, wo, out->wi, f_cos, &out->pdf, beckmann);
    double cos_NI = dot3(N, out->wi);
    if (!(total > 0.0 && (reflect ? cos_NI > 0.0 : cos_NI < 0.0))) out->pdf = 0.0;
    for (int k = 0; k < 3; k++) out->weight[k] = out->pdf > 0.0 ? f_cos[k] / out->pdf : 0.0;
}

INLINE void rough_glass_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    rough_glass_sample_with(c, wo, u, out, 0);
}
