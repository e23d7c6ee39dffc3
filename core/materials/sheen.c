/* The microfiber sheen BSDF: core/materials/sheen.py. f cos = pdf = D(wi), an LTC lobe stretched by
 * M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]] in the frame of wo; exact sampling through M. p: a, b, set up per hit
 * (sheen_params); the albedo R goes into the closure's weight. a, b, R: Zeltner, Burley, Chiang 2022's table, as
 * Cycles reads it (sheen_table.h). */

#include "sheen_table.h"

enum { SHEEN_A = 0, SHEEN_B = 1 };
#define SHEEN_ROUGHNESS_MIN 1e-3        /* sheen.ROUGHNESS_MIN */
#define SHEEN_INVALID 1e-5              /* sheen.INVALID */

/* sheen.params_of for one hit: p[A], p[B] from roughness and mu_o = N.wo (clamped as Cycles does) read from the
 * table; returns R (0 where the table has no valid lobe: no sheen). */
INLINE double sheen_params(double roughness, double mu_o, double *p)
{
    double r = roughness < SHEEN_ROUGHNESS_MIN ? SHEEN_ROUGHNESS_MIN : (roughness > 1.0 ? 1.0 : roughness);
    double mu = clamp01(mu_o);
    p[SHEEN_A] = lookup_2d(SHEEN_LTC, 32, 32, mu, r);
    p[SHEEN_B] = lookup_2d(SHEEN_LTC + 32 * 32, 32, 32, mu, r);
    double R = lookup_2d(SHEEN_LTC + 2 * 32 * 32, 32, 32, mu, r);
    if (fabs(p[SHEEN_A]) >= SHEEN_INVALID && R >= SHEEN_INVALID) return R;
    p[SHEEN_A] = 1.0;                   /* (any finite lobe: its weight R is 0) */
    return 0.0;
}

/* sheen.frame: T along wo's part tangent to N, Bt = N x T (a fixed tangent where wo is N itself). */
INLINE void sheen_frame(const double *N, const double *wo, double *T, double *Bt)
{
    double d = dot3(N, wo);
    for (int j = 0; j < 3; j++) T[j] = wo[j] - d * N[j];
    double length = sqrt(dot3(T, T));
    if (length < 1e-12) {
        double other[3] = {0.0, 0.0, 0.0};
        other[fabs(N[0]) < 0.9 ? 0 : 1] = 1.0;
        double e = dot3(N, other);
        for (int j = 0; j < 3; j++) T[j] = other[j] - e * N[j];
        length = sqrt(dot3(T, T));
    }
    for (int j = 0; j < 3; j++) T[j] /= length;
    Bt[0] = N[1] * T[2] - N[2] * T[1];
    Bt[1] = N[2] * T[0] - N[0] * T[2];
    Bt[2] = N[0] * T[1] - N[1] * T[0];
}

/* sheen.ltc_density: (z / pi) a^2 / |M^-1 w|^4 at local coordinates x, y, z; 0 where z <= 0. */
INLINE double sheen_density(double a, double b, double x, double y, double z)
{
    if (!(z > 0.0)) return 0.0;
    double length_sq = (a * x + b * z) * (a * x + b * z) + (a * y) * (a * y) + z * z;
    return z * a * a / (PI * length_sq * length_sq);
}

INLINE void sheen_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    double T[3], Bt[3];
    sheen_frame(c->N, wo, T, Bt);
    double D = sheen_density(c->p[SHEEN_A], c->p[SHEEN_B], dot3(T, wi), dot3(Bt, wi), dot3(c->N, wi));
    f_cos[0] = f_cos[1] = f_cos[2] = D;
    *pdf = D;
}

/* A cosine-distributed direction (a point uniform on the disk, lifted), mapped by M and normalized: weight 1. */
INLINE void sheen_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    double a = c->p[SHEEN_A], b = c->p[SHEEN_B];
    double radius = sqrt(u[0]), cos_phi, sin_phi;
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    double x = radius * cos_phi, y = radius * sin_phi, z = sqrt(at_least(1.0 - u[0], 0.0));
    double local[3] = {(x - b * z) / a, y / a, z};
    double length = sqrt(dot3(local, local));
    for (int j = 0; j < 3; j++) local[j] /= length;
    double T[3], Bt[3];
    sheen_frame(c->N, wo, T, Bt);
    for (int j = 0; j < 3; j++) out->wi[j] = local[0] * T[j] + local[1] * Bt[j] + local[2] * c->N[j];
    double n = sqrt(dot3(out->wi, out->wi));
    for (int j = 0; j < 3; j++) out->wi[j] /= n;
    out->pdf = sheen_density(a, b, local[0], local[1], local[2]);
    for (int j = 0; j < 3; j++) out->weight[j] = out->pdf > 0.0 ? 1.0 : 0.0;
}
