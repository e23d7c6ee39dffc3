/* Hair: core/materials/hair.py. Chiang's model of the Principled Hair BSDF (chiang_hair_*: the paths R, TT, TRT and
 * the residual, each A_p M_p N_p, in the fibre's frame X = the tangent, Y = X x wo, Z = X x Y) and the Hair BSDF's
 * Reflection and Transmission (hair_reflection_*, hair_transmission_*: eval = pdf). The same arithmetic in the
 * same order as the Python. p: hair.py's slots (chiang_params, HairNode.setup: nodes.c principled_hair_node,
 * hair_node). */

enum { HAIR_SIGMA = 0, HAIR_V = 3, HAIR_S = 4, HAIR_M0 = 5, HAIR_ALPHA = 6, HAIR_ETA = 7, HAIR_H = 8, HAIR_X = 9 };
enum { HAIR_RU = 0, HAIR_RV = 1, HAIR_OFFSET = 2, HAIR_T = 3 };
#define HAIR_LN_2PI 1.8378770664093453

/* hair.safe_normalize: v over its length, 0 where the length is 0. */
INLINE void hair_normalize(const double *v, double *out)
{
    double length = sqrt(dot3(v, v));
    for (int k = 0; k < 3; k++) out[k] = length > 0.0 ? v[k] / length : 0.0;
}

INLINE double hair_cos_from_sin(double s) { return sqrt(at_least(1.0 - s * s, 0.0)); }
INLINE double hair_asin(double s) { return asin(s < -1.0 ? -1.0 : (s > 1.0 ? 1.0 : s)); }

/* hair.fresnel_cos: Cycles' fresnel_dielectric_cos. */
INLINE double hair_fresnel(double cos_i, double eta)
{
    double c = fabs(cos_i);
    double g = eta * eta - 1.0 + c * c;
    if (!(g > 0.0)) return 1.0;
    g = sqrt(g);
    double A = (g - c) / (g + c);
    double B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * A * A * (1.0 + B * B);
}

/* hair.bessel_I0: the series, stopped where a term no longer changes the sum. */
INLINE double hair_bessel_I0(double x)
{
    x = x * x;
    double val = 1.0 + 0.25 * x, power = x * x, factorial = 1.0, four = 16.0;
    for (int i = 2; i < 10; i++) {
        factorial *= (double)(i * i);
        double next = val + power / (four * factorial);
        if (next == val) return val;
        val = next;
        power = power * x;
        four *= 4.0;
    }
    return val;
}

INLINE double hair_log_bessel_I0(double x)
{
    if (x > 12.0) return x + 0.5 * (1.0 / (8.0 * x) - HAIR_LN_2PI - log(x));
    return log(hair_bessel_I0(x));
}

INLINE double hair_logistic(double x, double s)
{
    double v = exp(-fabs(x) / s);
    return v / (s * ((1.0 + v) * (1.0 + v)));
}

INLINE double hair_logistic_cdf(double x, double s)
{
    double arg = -x / s;
    return arg > 88.0 ? 0.0 : 1.0 / (1.0 + exp(arg));
}

INLINE double hair_trimmed_logistic(double x, double s)
{
    double scale = 1.0 - 2.0 * hair_logistic_cdf(-PI, s);
    double val = hair_logistic(x, s);
    return scale != 0.0 ? val / scale : 0.0;
}

INLINE double hair_sample_trimmed_logistic(double u, double s)
{
    double low = hair_logistic_cdf(-PI, s);
    double x = -s * log(1.0 / (u * (1.0 - 2.0 * low) + low) - 1.0);
    return x < -PI ? -PI : (x > PI ? PI : x);
}

INLINE double hair_wrap_angle(double a)
{
    return (a + PI) - 2.0 * PI * floor((a + PI) / (2.0 * PI)) - PI;
}

INLINE double hair_delta_phi(int p, double gamma_o, double gamma_t)
{
    return 2.0 * p * gamma_t - 2.0 * gamma_o + p * PI;
}

/* hair.longitudinal: M_p, in logs where v <= 0.1. */
INLINE double hair_longitudinal(double sin_i, double cos_i, double sin_o, double cos_o, double v)
{
    double inv_v = 1.0 / v;
    double cos_arg = cos_i * cos_o * inv_v, sin_arg = sin_i * sin_o * inv_v;
    if (v <= 0.1) return exp(hair_log_bessel_I0(cos_arg) - sin_arg - inv_v + 0.6931 + log(0.5 * inv_v));
    return exp(-sin_arg) * hair_bessel_I0(cos_arg) / (sinh(inv_v) * 2.0 * v);
}

INLINE double hair_gray(const double *c)
{
    return (HAIR_GRAY_R * c[0] + HAIR_GRAY_G * c[1]) + HAIR_GRAY_B * c[2];
}

/* hair.Fibre for one hit. */
typedef struct {
    double X[3], Y[3], Z[3];
    double sin_o, cos_o, phi_o, gamma_o, gamma_t;
    double A[4][3], energy[4], angles[6];
    const double *p;
} Fibre;

INLINE void fibre_of(const double *p, const double *wo, Fibre *f)
{
    double c[3];
    f->p = p;
    hair_normalize(p + HAIR_X, f->X);
    cross3(f->X, wo, c);
    hair_normalize(c, f->Y);
    cross3(f->X, f->Y, c);
    hair_normalize(c, f->Z);
    f->sin_o = dot3(wo, f->X);
    f->cos_o = hair_cos_from_sin(f->sin_o);
    f->phi_o = atan2(dot3(wo, f->Z), dot3(wo, f->Y));
    double eta = p[HAIR_ETA];
    double cos_t = at_least(hair_cos_from_sin(f->sin_o / eta), 1e-30);
    double sin_gamma_o = p[HAIR_H], cos_gamma_o = hair_cos_from_sin(sin_gamma_o);
    f->gamma_o = hair_asin(sin_gamma_o);
    double sin_gamma_t = sin_gamma_o * f->cos_o / sqrt(at_least(eta * eta - f->sin_o * f->sin_o, 1e-30));
    f->gamma_t = hair_asin(sin_gamma_t);
    double chord = 2.0 * hair_cos_from_sin(sin_gamma_t) / cos_t, T[3];
    for (int k = 0; k < 3; k++) T[k] = exp(-p[HAIR_SIGMA + k] * chord);
    double fr = hair_fresnel(f->cos_o * cos_gamma_o, eta);
    /* hair.attenuation */
    for (int k = 0; k < 3; k++) {
        double Tf = T[k] * fr;
        f->A[0][k] = fr;
        f->A[1][k] = (1.0 - fr) * (1.0 - fr) * T[k];
        f->A[2][k] = f->A[1][k] * T[k] * fr;
        f->A[3][k] = f->A[2][k] * ((1.0 - Tf) != 0.0 ? Tf / (1.0 - Tf) : 0.0);
    }
    f->energy[0] = fr;
    for (int i = 1; i < 4; i++) f->energy[i] = hair_gray(f->A[i]);
    double total = ((f->energy[0] + f->energy[1]) + f->energy[2]) + f->energy[3];
    double scale = total != 0.0 ? 1.0 / total : 0.0;
    for (int i = 0; i < 4; i++) f->energy[i] *= scale;
    /* hair.tilted_angles */
    double s1 = sin(p[HAIR_ALPHA]), c1 = hair_cos_from_sin(s1);
    double s2 = 2.0 * s1 * c1, c2 = c1 * c1 - s1 * s1;
    double s4 = 2.0 * s2 * c2, c4 = c2 * c2 - s2 * s2;
    double so = f->sin_o, co = f->cos_o;
    f->angles[0] = so * c2 - co * s2; f->angles[1] = fabs(co * c2 + so * s2);
    f->angles[2] = so * c1 + co * s1; f->angles[3] = fabs(co * c1 - so * s1);
    f->angles[4] = so * c4 + co * s4; f->angles[5] = fabs(co * c4 - so * s4);
}

INLINE double fibre_variance(const Fibre *f, int p)
{
    double v = f->p[HAIR_V];
    return p == 0 ? f->p[HAIR_M0] : (p == 1 ? 0.25 * v : 4.0 * v);
}

/* Fibre.scatter: f cos and pdf towards (theta_i, phi = phi_i - phi_o). */
INLINE double fibre_scatter(const Fibre *f, double sin_i, double cos_i, double phi, double *f_cos)
{
    double s = f->p[HAIR_S], pdf = 0.0;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    for (int p = 0; p < 3; p++) {
        double Mp = hair_longitudinal(sin_i, cos_i, f->angles[2 * p], f->angles[2 * p + 1], fibre_variance(f, p));
        double Np = hair_trimmed_logistic(hair_wrap_angle(phi - hair_delta_phi(p, f->gamma_o, f->gamma_t)), s);
        for (int k = 0; k < 3; k++) f_cos[k] += f->A[p][k] * (Mp * Np);
        pdf += f->energy[p] * Mp * Np;
    }
    double Mp = hair_longitudinal(sin_i, cos_i, f->sin_o, f->cos_o, 4.0 * f->p[HAIR_V]);
    double Np = 1.0 / (2.0 * PI);
    for (int k = 0; k < 3; k++) f_cos[k] += f->A[3][k] * (Mp * Np);
    pdf += f->energy[3] * Mp * Np;
    return pdf;
}

/* ChiangHair.albedo: Cycles' estimate, exp(-sqrt(sigma) scale(v)) + f, all reflected. */
INLINE void chiang_hair_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    const double *p = c->p;
    double X[3];
    hair_normalize(p + HAIR_X, X);
    double cos_o = hair_cos_from_sin(dot3(wo, X));
    double f = hair_fresnel(cos_o * hair_cos_from_sin(p[HAIR_H]), p[HAIR_ETA]);
    double x = p[HAIR_V];
    double scale = (((((0.245 * x) + 5.574) * x - 10.73) * x + 2.532) * x - 0.215) * x + 5.969;
    for (int k = 0; k < 3; k++) { R[k] = exp(-sqrt(at_least(p[HAIR_SIGMA + k], 0.0)) * scale) + f; T[k] = 0.0; }
}

INLINE void chiang_hair_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    Fibre f;
    fibre_of(c->p, wo, &f);
    double sin_i = dot3(wi, f.X);
    double phi_i = atan2(dot3(wi, f.Z), dot3(wi, f.Y));
    *pdf = fibre_scatter(&f, sin_i, hair_cos_from_sin(sin_i), phi_i - f.phi_o, f_cos);
}

INLINE void chiang_hair_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    Fibre f;
    fibre_of(c->p, wo, &f);
    /* 1. A path by the luminance shares. */
    double z = u[2];
    int path = 3;
    for (int p = 0; p < 3; p++) {
        if (z < f.energy[p]) { path = p; break; }
        z = z - f.energy[p];
    }
    z = z / f.energy[path];
    /* 2. theta_i from the path's longitudinal lobe. */
    double v = path == 0 ? f.p[HAIR_M0] : (path == 1 ? 0.25 * f.p[HAIR_V] : 4.0 * f.p[HAIR_V]);
    double sin_t = path < 3 ? f.angles[2 * path] : f.sin_o, cos_t = path < 3 ? f.angles[2 * path + 1] : f.cos_o;
    z = z > 1e-5 ? z : 1e-5;
    double fac = 1.0 + v * log(z + (1.0 - z) * exp(-2.0 / v));
    double sin_i = -fac * sin_t + hair_cos_from_sin(fac) * cos(2.0 * PI * u[1]) * cos_t;
    double cos_i = hair_cos_from_sin(sin_i);
    /* 3. phi about the path's deflection (uniform for the residual). */
    double phi = path < 3 ? hair_delta_phi(path, f.gamma_o, f.gamma_t) + hair_sample_trimmed_logistic(u[0], f.p[HAIR_S])
                          : 2.0 * PI * u[0];
    double phi_i = f.phi_o + phi, f_cos[3];
    double pdf = fibre_scatter(&f, sin_i, cos_i, phi, f_cos);
    for (int k = 0; k < 3; k++)
        out->wi[k] = ((cos_i * cos(phi_i)) * f.Y[k] + (cos_i * sin(phi_i)) * f.Z[k]) + sin_i * f.X[k];
    int sampled = pdf > 0.0 && isfinite(pdf) && isfinite(f_cos[0]) && isfinite(f_cos[1]) && isfinite(f_cos[2]);
    for (int k = 0; k < 3; k++) out->weight[k] = sampled ? f_cos[k] / pdf : 0.0;
    out->pdf = sampled ? pdf : 0.0;
}

/* hair.hair_frame: locy (wo across T, unit) and theta_r. */
INLINE double hair_frame(const double *p, const double *wo, double *locy)
{
    const double *T = p + HAIR_T;
    double Iz = dot3(T, wo), d[3];
    for (int k = 0; k < 3; k++) d[k] = wo[k] - T[k] * Iz;
    hair_normalize(d, locy);
    return PI / 2.0 - acos(Iz < -1.0 ? -1.0 : (Iz > 1.0 ? 1.0 : Iz));
}

INLINE void hair_theta_lobe(const double *p, double theta_r, double *a, double *b)
{
    double r1 = p[HAIR_RU], offset = p[HAIR_OFFSET];
    *a = atan(((PI / 2.0 + theta_r) * 0.5 - offset) / r1);
    *b = atan(((-PI / 2.0 + theta_r) * 0.5 - offset) / r1);
}

/* hair.sample_theta: theta_i drawn from the Cauchy lobe by u0, with the lobe's ends *a, *b for its pdf. */
INLINE double hair_sample_theta(const double *p, double theta_r, double u0, double *a, double *b)
{
    hair_theta_lobe(p, theta_r, a, b);
    double t = p[HAIR_RU] * tan(u0 * (*a - *b) + *b);
    return 2.0 * (t + p[HAIR_OFFSET]) - theta_r;
}

INLINE double hair_theta_pdf(const double *p, double a, double b, double theta_i, double theta_r)
{
    double r1 = p[HAIR_RU];
    double t = (theta_i + theta_r) * 0.5 - p[HAIR_OFFSET];
    return r1 / (2.0 * (t * t + r1 * r1) * (a - b) * cos(theta_i));
}

/* hair.light_angles: theta_i, and the cosine of the light's azimuth from locy. */
INLINE double hair_light_angles(const double *p, const double *wi, const double *locy, double *cos_phi)
{
    const double *T = p + HAIR_T;
    double z = dot3(T, wi), d[3], y[3];
    for (int k = 0; k < 3; k++) d[k] = wi[k] - T[k] * z;
    hair_normalize(d, y);
    *cos_phi = dot3(y, locy);
    return PI / 2.0 - acos(z < -1.0 ? -1.0 : (z > 1.0 ? 1.0 : z));
}

INLINE void hair_direction(const double *p, const double *locy, double theta_i, double phi, double *wi)
{
    const double *T = p + HAIR_T;
    double locx[3];
    cross3(locy, T, locx);
    double c = cos(theta_i), s = sin(theta_i);
    for (int k = 0; k < 3; k++) wi[k] = ((cos(phi) * c) * locy[k] - (sin(phi) * c) * locx[k]) + s * T[k];
}

INLINE void hair_reflection_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    const double *p = c->p;
    double locy[3], cos_phi, a, b;
    double theta_r = hair_frame(p, wo, locy);
    double theta_i = hair_light_angles(p, wi, locy, &cos_phi);
    *pdf = 0.0;
    if (dot3(c->N, wi) >= 0.0 && PI / 2.0 - fabs(theta_i) >= 0.001 && cos_phi >= 0.0) {
        double r2 = p[HAIR_RV];
        double phi = acos(cos_phi > 1.0 ? 1.0 : cos_phi) / r2;
        phi = fabs(phi) < PI ? phi : PI;
        hair_theta_lobe(p, theta_r, &a, &b);
        *pdf = cos(phi * 0.5) * 0.25 / r2 * hair_theta_pdf(p, a, b, theta_i, theta_r);
    }
    f_cos[0] = f_cos[1] = f_cos[2] = *pdf;
}

INLINE void hair_reflection_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    const double *p = c->p;
    double locy[3], a, b;
    double theta_r = hair_frame(p, wo, locy);
    double r2 = p[HAIR_RV];
    double theta_i = hair_sample_theta(p, theta_r, u[0], &a, &b);
    double phi = 2.0 * hair_asin(1.0 - 2.0 * u[1]) * r2;
    double pdf = fabs(cos(phi * 0.5) * 0.25 / r2 * hair_theta_pdf(p, a, b, theta_i, theta_r));
    if (PI / 2.0 - fabs(theta_i) < 0.001 || !isfinite(pdf)) pdf = 0.0;
    hair_direction(p, locy, theta_i, phi, out->wi);
    out->pdf = pdf;
    for (int k = 0; k < 3; k++) out->weight[k] = pdf > 0.0 ? 1.0 : 0.0;
}

/* HairTransmission.albedo: all transmitted. */
INLINE void hair_transmission_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    (void)c; (void)wo;
    for (int k = 0; k < 3; k++) { R[k] = 0.0; T[k] = 1.0; }
}

INLINE void hair_transmission_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    const double *p = c->p;
    double locy[3], cos_phi, a, b;
    double theta_r = hair_frame(p, wo, locy);
    double theta_i = hair_light_angles(p, wi, locy, &cos_phi);
    *pdf = 0.0;
    if (dot3(c->N, wi) < 0.0 && PI / 2.0 - fabs(theta_i) >= 0.001) {
        double r2 = p[HAIR_RV];
        hair_theta_lobe(p, theta_r, &a, &b);
        double cc = 2.0 * atan(PI / 2.0 / r2);
        double q = PI - acos(cos_phi < -1.0 ? -1.0 : (cos_phi > 1.0 ? 1.0 : cos_phi));
        *pdf = r2 / (cc * (q * q + r2 * r2)) * hair_theta_pdf(p, a, b, theta_i, theta_r);
    }
    f_cos[0] = f_cos[1] = f_cos[2] = *pdf;
}

INLINE void hair_transmission_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    const double *p = c->p;
    double locy[3], a, b;
    double theta_r = hair_frame(p, wo, locy);
    double r2 = p[HAIR_RV];
    double theta_i = hair_sample_theta(p, theta_r, u[0], &a, &b);
    double cc = 2.0 * atan(PI / 2.0 / r2);
    double q = r2 * tan(cc * (u[1] - 0.5));
    double pdf = fabs(r2 / (cc * (q * q + r2 * r2)) * hair_theta_pdf(p, a, b, theta_i, theta_r));
    if (PI / 2.0 - fabs(theta_i) < 0.001 || !isfinite(pdf)) pdf = 0.0;
    hair_direction(p, locy, theta_i, q + PI, out->wi);
    out->pdf = pdf;
    for (int k = 0; k < 3; k++) out->weight[k] = pdf > 0.0 ? 1.0 : 0.0;
}
