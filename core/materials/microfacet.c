/* The GGX microfacet BSDF: core/materials/microfacet.py (its docstring has the model and the sources).
 * p: alpha, fresnel, ior, f0 (3), f90 or F82's b (3), energy_scale, alpha_y, tangent (3): anisotropic where
 * the tangent is not zero and alpha_y differs from alpha (microfacet.is_anisotropic); a thin film's thickness and
 * index at 16 and 17. */

enum { MF_ALPHA = 0, MF_FRESNEL = 1, MF_IOR = 2, MF_F0 = 3, MF_F90 = 6, MF_ENERGY = 9, MF_ALPHA_Y = 10, MF_TANGENT = 11,
       MF_PARAMS = 14, MF_THICKNESS = 16, MF_FILM_IOR = 17 };   /* thin film (past glass's tints): nm, index */
enum { FRESNEL_NONE = 0, FRESNEL_DIELECTRIC = 1, FRESNEL_SCHLICK_IOR = 2, FRESNEL_F82_TINT = 3, FRESNEL_THIN_FILM = 4,
       FRESNEL_THIN_FILM_F82 = 5 };
#define ROUGHNESS_SQ_THRESHOLD 2e-10

/* Exact Fresnel reflectance of a dielectric of relative index eta at cos_i: microfacet.fresnel_dielectric. */
INLINE double fresnel_dielectric(double cos_i, double eta)
{
    cos_i = fabs(cos_i);
    double sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin_t2 >= 1.0) return 1.0;
    double cos_t = sqrt(at_least(1.0 - sin_t2, 0.0));
    double r_s = (cos_i - eta * cos_t) / at_least(cos_i + eta * cos_t, 1e-300);
    double r_p = (eta * cos_i - cos_t) / at_least(eta * cos_i + cos_t, 1e-300);
    return 0.5 * (r_s * r_s + r_p * r_p);
}

INLINE double F0_from_ior(double ior) { double r = (ior - 1.0) / (ior + 1.0); return r * r; }

/* microfacet.fresnel: the reflectance of the closure's Fresnel model at cos_HI. */
INLINE void microfacet_fresnel(const double *p, double cos_HI, double *F)
{
    int mode = (int)p[MF_FRESNEL];
    if (mode == FRESNEL_DIELECTRIC || mode == FRESNEL_SCHLICK_IOR) {
        double real = fresnel_dielectric(cos_HI, p[MF_IOR]);
        if (mode == FRESNEL_DIELECTRIC) { F[0] = F[1] = F[2] = real; return; }
        double F0_real = F0_from_ior(p[MF_IOR]);
        double s = clamp01((real - F0_real) / at_least(1.0 - F0_real, 1e-300));
        for (int c = 0; c < 3; c++) F[c] = p[MF_F0 + c] + (p[MF_F90 + c] - p[MF_F0 + c]) * s;
    } else if (mode == FRESNEL_F82_TINT) {
        double s = clamp01(1.0 - cos_HI), s5 = s * s * s * s * s;
        for (int c = 0; c < 3; c++)
            F[c] = clamp01(p[MF_F0 + c] + (1.0 - p[MF_F0 + c]) * s5 - p[MF_F90 + c] * (cos_HI * s5 * s));
    } else if (mode == FRESNEL_THIN_FILM) {
        thin_film_fresnel(cos_HI, p[MF_IOR], p + MF_F0, p[MF_THICKNESS], p[MF_FILM_IOR], F);
    } else if (mode == FRESNEL_THIN_FILM_F82) {
        thin_film_metal(cos_HI, p + MF_F0, p + MF_F90, p[MF_THICKNESS], p[MF_FILM_IOR], F);
    } else {
        F[0] = F[1] = F[2] = 1.0;
    }
}

/* Microfacet.albedo: the colour passes' albedo, its Fresnel at N.wo (no transmission). */
INLINE void microfacet_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    microfacet_fresnel(c->p, clamp01(dot3(c->N, wo)), R);
    T[0] = T[1] = T[2] = 0.0;
}

/* Smith's Lambda for GGX at `cosine`, and the GGX distribution at cos_NH. */
INLINE double lambda_ggx(double alpha2, double cosine)
{
    double tan2 = at_least(1.0 / at_least(cosine * cosine, 1e-300) - 1.0, 0.0);
    return 0.5 * (sqrt(1.0 + alpha2 * tan2) - 1.0);
}

INLINE double D_ggx(double alpha2, double cos_NH)
{
    double c2 = at_most(cos_NH * cos_NH, 1.0);
    double d = 1.0 - c2 + alpha2 * c2;
    return alpha2 / (PI * d * d);
}

/* microfacet.is_anisotropic: a non-zero tangent and alpha_y != alpha. */
INLINE int mf_is_anisotropic(const double *p)
{
    return (p[MF_TANGENT] != 0.0 || p[MF_TANGENT + 1] != 0.0 || p[MF_TANGENT + 2] != 0.0) && p[MF_ALPHA_Y] != p[MF_ALPHA];
}

/* microfacet.tangent_frame: Y = normalize(N x T), X = Y x N. */
INLINE void mf_tangent_frame(const double *N, const double *T, double *X, double *Y)
{
    Y[0] = N[1] * T[2] - N[2] * T[1];
    Y[1] = N[2] * T[0] - N[0] * T[2];
    Y[2] = N[0] * T[1] - N[1] * T[0];
    double length = at_least(sqrt(dot3(Y, Y)), 1e-300);
    for (int k = 0; k < 3; k++) Y[k] /= length;
    X[0] = Y[1] * N[2] - Y[2] * N[1];
    X[1] = Y[2] * N[0] - Y[0] * N[2];
    X[2] = Y[0] * N[1] - Y[1] * N[0];
}

/* microfacet.lambda_aniso and D_aniso, in the tangent frame (x, y, z). */
INLINE double lambda_aniso(double ax, double ay, double x, double y, double z)
{
    double z2 = at_least(z * z, 1e-300);
    return 0.5 * (sqrt(1.0 + ((ax * x) * (ax * x) + (ay * y) * (ay * y)) / z2) - 1.0);
}

INLINE double D_aniso(double ax, double ay, double x, double y, double z)
{
    double s = (x / ax) * (x / ax) + (y / ay) * (y / ay) + z * z;
    return 1.0 / (PI * ax * ay * s * s);
}

/* microfacet.lambda_beckmann_tan2: Walter et al.'s fit of Beckmann's Lambda from alpha^2 tan^2 (0 below 0.39). */
INLINE double lambda_beckmann_tan2(double alpha2_tan2)
{
    if (!(alpha2_tan2 >= 0.39)) return 0.0;
    double a = 1.0 / sqrt(alpha2_tan2);
    return ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a);
}

INLINE double lambda_beckmann(double alpha2, double cosine)
{
    return lambda_beckmann_tan2(alpha2 * at_least(1.0 / at_least(cosine * cosine, 1e-300) - 1.0, 0.0));
}

INLINE double lambda_aniso_beckmann(double ax, double ay, double x, double y, double z)
{
    double z2 = at_least(z * z, 1e-300);
    return lambda_beckmann_tan2(((ax * x) * (ax * x) + (ay * y) * (ay * y)) / z2);
}

/* microfacet.D_beckmann and D_aniso_beckmann (0 for a normal in the surface's plane). */
INLINE double D_beckmann(double alpha2, double cos_NH)
{
    double c2 = at_most(cos_NH * cos_NH, 1.0);
    if (!(c2 > 0.0)) return 0.0;
    return 1.0 / (exp((1.0 - c2) / (c2 * alpha2)) * PI * alpha2 * (c2 * c2));
}

INLINE double D_aniso_beckmann(double ax, double ay, double x, double y, double z)
{
    double c2 = z * z;
    if (!(c2 > 0.0)) return 0.0;
    double slope2 = (x / ax) * (x / ax) + (y / ay) * (y / ay);
    return exp(-slope2 / c2) / (PI * (ax * ay) * (c2 * c2));
}

/* The distribution's D, Lambda and anisotropic twins: Beckmann's where `beckmann`, else GGX's. */
INLINE double mf_D(int beckmann, double alpha2, double cos_NH)
{
    return beckmann ? D_beckmann(alpha2, cos_NH) : D_ggx(alpha2, cos_NH);
}

INLINE double mf_lambda(int beckmann, double alpha2, double cosine)
{
    return beckmann ? lambda_beckmann(alpha2, cosine) : lambda_ggx(alpha2, cosine);
}

INLINE double mf_D_aniso(int beckmann, double ax, double ay, double x, double y, double z)
{
    return beckmann ? D_aniso_beckmann(ax, ay, x, y, z) : D_aniso(ax, ay, x, y, z);
}

INLINE double mf_lambda_aniso(int beckmann, double ax, double ay, double x, double y, double z)
{
    return beckmann ? lambda_aniso_beckmann(ax, ay, x, y, z) : lambda_aniso(ax, ay, x, y, z);
}

/* Microfacet.eval with GGX's distribution, or Beckmann's where `beckmann` (beckmann.c). */
INLINE void microfacet_eval_with(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf,
                                 int beckmann)
{
    const double *p = c->p;
    int aniso = mf_is_anisotropic(p);
    double alpha2 = aniso ? p[MF_ALPHA] * p[MF_ALPHA_Y] : p[MF_ALPHA] * p[MF_ALPHA];
    double cos_NI = dot3(c->N, wo), cos_NO = dot3(c->N, wi);
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
    if (!(cos_NI > 0.0 && cos_NO > 0.0 && alpha2 > ROUGHNESS_SQ_THRESHOLD)) return;
    double H[3] = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
    double length = at_least(sqrt(dot3(H, H)), 1e-300);
    for (int k = 0; k < 3; k++) H[k] /= length;
    double common, lambda_I, lambda_O;
    if (aniso) {
        double X[3], Y[3], ax = p[MF_ALPHA], ay = p[MF_ALPHA_Y];
        mf_tangent_frame(c->N, p + MF_TANGENT, X, Y);
        common = mf_D_aniso(beckmann, ax, ay, dot3(X, H), dot3(Y, H), dot3(c->N, H)) / cos_NI * 0.25;
        lambda_I = mf_lambda_aniso(beckmann, ax, ay, dot3(X, wo), dot3(Y, wo), cos_NI);
        lambda_O = mf_lambda_aniso(beckmann, ax, ay, dot3(X, wi), dot3(Y, wi), cos_NO);
    } else {
        common = mf_D(beckmann, alpha2, dot3(c->N, H)) / cos_NI * 0.25;
        lambda_I = mf_lambda(beckmann, alpha2, cos_NI); lambda_O = mf_lambda(beckmann, alpha2, cos_NO);
    }
    *pdf = common / (1.0 + lambda_I);
    double scale = common / (1.0 + lambda_I + lambda_O) * p[MF_ENERGY];
    double F[3];
    microfacet_fresnel(p, dot3(H, wo), F);
    for (int k = 0; k < 3; k++) f_cos[k] = F[k] * scale;
}

INLINE void microfacet_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    microfacet_eval_with(c, wo, wi, f_cos, pdf, 0);
}

/* microfacet.sample_visible_normal: a normal the viewer sees, in the frame where N = z (Heitz 2018). */
INLINE void sample_visible_normal(const double *local_wo, double alpha, double alpha_y, const double *u, double *H)
{
    double v[3] = {alpha * local_wo[0], alpha_y * local_wo[1], local_wo[2]};
    double length = sqrt(dot3(v, v));
    for (int k = 0; k < 3; k++) v[k] /= length;
    double lensq = v[0] * v[0] + v[1] * v[1];
    double T1[3] = {1.0, 0.0, 0.0}, T2[3];
    if (lensq > 1e-7) {
        double inv = 1.0 / sqrt(lensq);
        T1[0] = -v[1] * inv; T1[1] = v[0] * inv; T1[2] = 0.0;
    }
    T2[0] = v[1] * T1[2] - v[2] * T1[1];
    T2[1] = v[2] * T1[0] - v[0] * T1[2];
    T2[2] = v[0] * T1[1] - v[1] * T1[0];
    double r = sqrt(u[0]), cos_phi, sin_phi;
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    double t1 = r * cos_phi, t2 = r * sin_phi;
    double blend = 0.5 * (1.0 + v[2]);
    t2 = (1.0 - blend) * sqrt(at_least(1.0 - t1 * t1, 0.0)) + blend * t2;
    double lift = sqrt(at_least(1.0 - t1 * t1 - t2 * t2, 0.0));
    double h[3];
    for (int k = 0; k < 3; k++) h[k] = T1[k] * t1 + T2[k] * t2 + v[k] * lift;
    H[0] = alpha * h[0]; H[1] = alpha_y * h[1]; H[2] = at_least(h[2], 0.0);
    length = sqrt(dot3(H, H));
    for (int k = 0; k < 3; k++) H[k] /= length;
}

/* microfacet.erf: the error function to 1.5e-7 (Abramowitz and Stegun 7.1.26). */
INLINE double mf_erf(double x)
{
    double ax = fabs(x), t = 1.0 / (1.0 + 0.3275911 * ax);
    double poly = ((((1.061405429 * t - 1.453152027) * t + 1.421413741) * t - 0.284496736) * t + 0.254829592) * t;
    return (x < 0.0 ? -1.0 : 1.0) * (1.0 - poly * exp(-ax * ax));
}

/* microfacet.erfinv: the inverse error function (Giles 2010's single-precision polynomials, in double). */
INLINE double mf_erfinv(double x)
{
    x = x < -1.0 + 1e-15 ? -1.0 + 1e-15 : (x > 1.0 - 1e-15 ? 1.0 - 1e-15 : x);
    double w = -log((1.0 - x) * (1.0 + x)), p;
    if (w < 5.0) {
        static const double c[8] = {3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087,
                                    -0.00125372503, -0.00417768164, 0.246640727, 1.50140941};
        double wc = w - 2.5;
        p = 2.81022636e-08;
        for (int k = 0; k < 8; k++) p = c[k] + p * wc;
    } else {
        static const double c[8] = {0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773,
                                    -0.0076224613, 0.00943887047, 1.00167406, 2.83297682};
        double wt = sqrt(w) - 3.0;
        p = -0.000200214257;
        for (int k = 0; k < 8; k++) p = c[k] + p * wt;
    }
    return p * x;
}

enum { BECKMANN_NEWTON_STEPS = 6 };

/* microfacet.sample_visible_normal_beckmann: a Beckmann normal the viewer sees, in the frame where N = z
 * (Heitz and d'Eon 2014; the slope along the view found by Newton steps on erf, kept in their bracket). */
INLINE void sample_visible_normal_beckmann(const double *local_wo, double alpha, double alpha_y, const double *u,
                                           double *H)
{
    /* 1. Stretch the view direction to unit roughness. */
    double v[3] = {alpha * local_wo[0], alpha_y * local_wo[1], local_wo[2]};
    double length = sqrt(dot3(v, v));
    for (int k = 0; k < 3; k++) v[k] /= length;
    double sx, sy;
    if (v[2] >= 0.99999) {
        /* 2. At normal incidence the slopes are a 2D Gaussian. */
        double r = sqrt(-log(at_least(u[0], 1e-300))), cos_u, sin_u;
        cos_sin(2.0 * PI * u[1], &cos_u, &sin_u);
        sx = r * cos_u; sy = r * sin_u;
    } else {
        /* 3. The slope along the view from its CDF (1 + erf(x) + K exp(-x^2)), solved for b = erf(x); across it a
         *    Gaussian. */
        double cos_t = v[2], sin_t = sqrt(at_least(1.0 - cos_t * cos_t, 0.0));
        double tan_t = sin_t / cos_t, cot_t = 1.0 / tan_t;
        double erf_a = mf_erf(cot_t), exp_a2 = exp(-cot_t * cot_t), K = tan_t / sqrt(PI);
        double y_approx = u[0] * (1.0 + erf_a + K * (1.0 - erf_a * erf_a));
        double y_exact = u[0] * (1.0 + erf_a + K * exp_a2);
        double b = (0.5 - sqrt(K * (K - y_approx + 1.0) + 0.25)) / K;
        double x = mf_erfinv(b);
        double low_b = -1.0, low_f = -y_exact, high_b = erf_a;
        double f = 1.0 + b + K * exp(-x * x) - y_exact;
        for (int step = 0; step < BECKMANN_NEWTON_STEPS; step++) {
            if ((low_f < 0.0) == (f < 0.0)) { low_b = b; low_f = f; } else { high_b = b; }
            double newton = b - f / (1.0 - x * tan_t);
            b = (newton >= low_b && newton <= high_b) ? newton : 0.5 * (low_b + high_b);
            x = mf_erfinv(b);
            f = 1.0 + b + K * exp(-x * x) - y_exact;
        }
        double slope_y = mf_erfinv(2.0 * u[1] - 1.0);
        /* 4. Turned to the view's azimuth. */
        double cos_phi = v[0] / sin_t, sin_phi = v[1] / sin_t;
        sx = cos_phi * x - sin_phi * slope_y;
        sy = sin_phi * x + cos_phi * slope_y;
    }
    /* 5. Unstretched, and made a normal. */
    H[0] = -(sx * alpha); H[1] = -(sy * alpha_y); H[2] = 1.0;
    length = sqrt(dot3(H, H));
    for (int k = 0; k < 3; k++) H[k] /= length;
}

/* Microfacet.sample with GGX's visible normals, or Beckmann's where `beckmann`. */
INLINE void microfacet_sample_with(const Closure *c, const double *wo, const double *u, BsdfSample *out, int beckmann)
{
    const double *N = c->N;
    double t[3], b[3], alpha_y = c->p[MF_ALPHA];
    if (mf_is_anisotropic(c->p)) {
        mf_tangent_frame(N, c->p + MF_TANGENT, t, b);
        alpha_y = c->p[MF_ALPHA_Y];
    } else {
        orthonormal_frame(N, t, b);
    }
    double local[3] = {dot3(t, wo), dot3(b, wo), dot3(N, wo)};
    if (!(local[2] > 0.0)) { local[0] = 0.0; local[1] = 0.0; local[2] = 1.0; }
    double h[3], H[3];
    if (beckmann) sample_visible_normal_beckmann(local, c->p[MF_ALPHA], alpha_y, u, h);
    else sample_visible_normal(local, c->p[MF_ALPHA], alpha_y, u, h);
    for (int k = 0; k < 3; k++) H[k] = (t[k] * h[0] + b[k] * h[1]) + N[k] * h[2];
    double cos_HI = dot3(H, wo);
    for (int k = 0; k < 3; k++) out->wi[k] = 2.0 * cos_HI * H[k] - wo[k];
    double f_cos[3];
    microfacet_eval_with(c, wo, out->wi, f_cos, &out->pdf, beckmann);
    for (int k = 0; k < 3; k++) out->weight[k] = out->pdf > 0.0 ? f_cos[k] / out->pdf : 0.0;
}

INLINE void microfacet_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    microfacet_sample_with(c, wo, u, out, 0);
}
