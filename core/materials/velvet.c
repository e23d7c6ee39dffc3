/* The Ashikhmin velvet BSDF: core/materials/velvet.py. f cos = D G / (4 N.wo), D the inverted Gaussian of the
 * half-vector's angle; uniform hemisphere sampling. p: 1 / sigma^2 (velvet_params). */

enum { VELVET_INV_SIGMA2 = 0 };

/* velvet.params_of for one hit: 1 / sigma^2 from the Roughness (sigma clamped to 0.01..1). */
INLINE void velvet_params(double roughness, double *p)
{
    double sigma = at_least(clamp01(roughness), 0.01);
    p[VELVET_INV_SIGMA2] = 1.0 / (sigma * sigma);
}

INLINE void velvet_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    double cos_v = dot3(c->N, wo), cos_l = dot3(c->N, wi);
    double H[3] = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
    double length = at_least(sqrt(dot3(H, H)), 1e-300);
    for (int j = 0; j < 3; j++) H[j] /= length;
    double cos_nh = dot3(c->N, H), cos_hv = fabs(dot3(wo, H));
    double value = 0.0;
    if (cos_v > 0.0 && cos_l > 0.0 && fabs(cos_nh) < 1.0 - 1e-5 && cos_hv > 1e-5) {
        double ratio = at_least(cos_nh / cos_hv, 1e-5);
        double G = at_most(1.0, at_most(2.0 * fabs(ratio * cos_v), 2.0 * fabs(ratio * cos_l)));
        double sin2 = 1.0 - cos_nh * cos_nh, inv = c->p[VELVET_INV_SIGMA2];
        double D = exp(-(cos_nh * cos_nh / sin2) * inv) * inv / (PI * sin2 * sin2);
        value = 0.25 * D * G / cos_v;
    }
    f_cos[0] = f_cos[1] = f_cos[2] = value;
    *pdf = cos_l > 0.0 ? 1.0 / (2.0 * PI) : 0.0;
}

/* Uniform over the hemisphere around N: cos theta = u0, azimuth 2 pi u1; weight f cos / pdf. */
INLINE void velvet_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    double z = u[0], radius = sqrt(at_least(1.0 - z * z, 0.0)), cos_phi, sin_phi, t[3], b[3];
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    orthonormal_frame(c->N, t, b);
    for (int j = 0; j < 3; j++) out->wi[j] = t[j] * (radius * cos_phi) + b[j] * (radius * sin_phi) + c->N[j] * z;
    double f_cos[3], pdf;
    velvet_eval(c, wo, out->wi, f_cos, &pdf);
    out->pdf = pdf;
    for (int j = 0; j < 3; j++) out->weight[j] = pdf > 0.0 ? f_cos[j] / pdf : 0.0;
}
