/* Thin-film iridescence: core/materials/thin_film.py (its docstring has the model and the source).
 * thickness in nm; indices relative to the ambient medium; RGB results. */

#include "thin_film_table.h"

#define THIN_FILM_THICKNESS_CUTOFF 0.1   /* thin_film.THICKNESS_CUTOFF */

/* thin_film._lookup: table (3 x THIN_FILM_TABLE_SIZE) at the optical path difference opd (nm) into S. */
INLINE void thin_film_lookup(const double *table, double opd, double *S)
{
    double x = opd / THIN_FILM_OPD_MAX;
    if (!(x > 0.0)) x = 0.0;
    if (x > 1.0) x = 1.0;
    x *= THIN_FILM_TABLE_SIZE - 1;
    int i = (int)x;
    if (i > THIN_FILM_TABLE_SIZE - 1) i = THIN_FILM_TABLE_SIZE - 1;
    int j = i + 1 < THIN_FILM_TABLE_SIZE ? i + 1 : THIN_FILM_TABLE_SIZE - 1;
    double t = x - i;
    for (int c = 0; c < 3; c++)
        S[c] = (1.0 - t) * table[c * THIN_FILM_TABLE_SIZE + i] + t * table[c * THIN_FILM_TABLE_SIZE + j];
}

/* thin_film.sensitivity: the R, G, B sensitivities S to the optical path difference opd (nm). */
INLINE void thin_film_sensitivity(double opd, double *S) { thin_film_lookup(THIN_FILM_S, opd, S); }

/* thin_film.polarized: the s and p reflectances R, the cosine behind the face, the signs of r_s and r_p;
 * returns 1 under total internal reflection. */
INLINE int thin_film_polarized(double cos_i, double eta, double *R, double *cos_t, double *sign)
{
    double sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    *cos_t = sqrt(at_least(1.0 - sin_t2, 0.0));
    double r_s = (cos_i - eta * *cos_t) / at_least(cos_i + eta * *cos_t, 1e-300);
    double r_p = (eta * cos_i - *cos_t) / at_least(eta * cos_i + *cos_t, 1e-300);
    R[0] = r_s * r_s;
    R[1] = r_p * r_p;
    sign[0] = r_s >= 0.0 ? 1.0 : -1.0;
    sign[1] = r_p >= 0.0 ? 1.0 : -1.0;
    return sin_t2 >= 1.0;
}

/* thin_film.airy: one polarisation's RGB reflectance R of a film between faces R12, R23 with phase flips
 * phasor and optical path difference opd. */
INLINE void thin_film_airy(double R12, double R23, double phasor, double opd, double *R)
{
    double T121 = 1.0 - R12, R123 = R12 * R23, r123 = sqrt(R123);
    double Rs = T121 * T121 * R23 / at_least(1.0 - R123, 1e-300);
    double Cm = Rs - T121, turn = phasor, S[3];
    for (int c = 0; c < 3; c++) R[c] = R12 + Rs;
    for (int m = 1; m < 4; m++) {
        Cm = Cm * r123;
        thin_film_sensitivity(m * opd, S);
        for (int c = 0; c < 3; c++) R[c] += 2.0 * Cm * turn * S[c];
        turn = turn * phasor;
    }
}

/* thin_film.iridescence: the RGB reflectance F of a substrate of index eta under a film of index film_ior. */
INLINE void thin_film_iridescence(double cos_i, double eta, double thickness, double film_ior, double *F)
{
    cos_i = fabs(cos_i);
    if (thickness < 1.0) {
        double x = clamp01(thickness);
        film_ior = 1.0 + (film_ior - 1.0) * x * x * (3.0 - 2.0 * x);
    }
    double R12[2], R23[2], sign12[2], sign23[2], cos_2, cos_3, R_s[3], R_p[3];
    int tir = thin_film_polarized(cos_i, film_ior, R12, &cos_2, sign12);
    tir |= thin_film_polarized(cos_2, eta / film_ior, R23, &cos_3, sign23);
    if (tir) { F[0] = F[1] = F[2] = 1.0; return; }
    double opd = 2.0 * film_ior * thickness * cos_2;
    thin_film_airy(R12[0], R23[0], -sign12[0] * sign23[0], opd, R_s);
    thin_film_airy(R12[1], R23[1], -sign12[1] * sign23[1], opd, R_p);
    for (int c = 0; c < 3; c++) F[c] = clamp01(0.5 * (R_s[c] + R_p[c]));
}

/* thin_film.fresnel: the Principled's iridescent Fresnel F at cos_i, scaled per channel towards f0 / F0(eta). */
INLINE void thin_film_fresnel(double cos_i, double eta, const double *f0, double thickness, double film_ior,
                              double *F)
{
    thin_film_iridescence(cos_i, eta, thickness, film_ior, F);
    double r = (eta - 1.0) / (eta + 1.0), F0_real = r * r;
    if (!(F0_real > 1e-5) || (F[0] == 1.0 && F[1] == 1.0 && F[2] == 1.0)) return;
    for (int c = 0; c < 3; c++) {
        double s = clamp01((F[c] - 1.0) / (F0_real - 1.0));
        F[c] = F[c] * (1.0 + (f0[c] / F0_real - 1.0) * s);
    }
}

/* thin_film.conductor for one channel: the reflectance R (both polarisations: the F82 curve of the metal's F0
 * relative to the film through F82) and the phase shifts (re, im) of r_s and r_p at a metal n + ik met inside a
 * film of index film at cos_i. */
INLINE void thin_film_conductor(double cos_i, double film, double n, double k, double F82, double *R, double *phase_s,
                                double *phase_p)
{
    double c = cos_i, n1 = film;
    double t1 = n * n - k * k - n1 * n1 * (1.0 - c * c);
    double t2 = sqrt(t1 * t1 + (2.0 * n * k) * (2.0 * n * k));
    double u2 = at_least(0.5 * (t2 + t1), 0.0), v2 = at_least(0.5 * (t2 - t1), 0.0);
    double u = sqrt(u2), v = sqrt(v2);
    double n_rel = n / n1, k_rel = k / n1, k_rel2 = k_rel * k_rel;
    double F0 = ((n_rel - 1.0) * (n_rel - 1.0) + k_rel2) / ((n_rel + 1.0) * (n_rel + 1.0) + k_rel2);
    double f = 6.0 / 7.0, f5 = f * f * f * f * f;
    double B = (7.0 / (f5 * f)) * (F0 + (1.0 - F0) * f5 - F82);
    double s = clamp01(1.0 - c), s5 = s * s * s * s * s;
    *R = clamp01(F0 + (1.0 - F0) * s5 - B * (c * s5 * s));
    double a = n1 * c;
    double re[2], im[2];
    re[0] = a * a - u2 - v2;
    im[0] = -2.0 * a * v;
    double N2_re = n * n - k * k, N2_im = 2.0 * n * k, m2 = (n * n + k * k) * c;
    re[1] = m2 * m2 - n1 * n1 * (u2 + v2);
    im[1] = 2.0 * a * (N2_im * u - N2_re * v);
    double *out[2] = {phase_s, phase_p};
    for (int q = 0; q < 2; q++) {
        double mag = sqrt(re[q] * re[q] + im[q] * im[q]);
        out[q][0] = mag == 0.0 ? 1.0 : re[q] / mag;
        out[q][1] = mag == 0.0 ? 0.0 : im[q] / mag;
    }
}

/* thin_film.airy_complex for one channel c: the film's reflectance over a face R23 with the complex phasor
 * (re, im), optical path difference opd. */
INLINE double thin_film_airy_complex(int c, double R12, double R23, const double *phasor, double opd)
{
    double T121 = 1.0 - R12, R123 = R12 * R23, r123 = sqrt(R123);
    double Rs = T121 * T121 * R23 / at_least(1.0 - R123, 1e-300);
    double R = R12 + Rs, Cm = Rs - T121, turn[2] = {phasor[0], phasor[1]}, S[3], S_im[3];
    for (int m = 1; m < 4; m++) {
        Cm = Cm * r123;
        thin_film_lookup(THIN_FILM_S, m * opd, S);
        thin_film_lookup(THIN_FILM_S_IM, m * opd, S_im);
        R += Cm * 2.0 * (turn[0] * S[c] + turn[1] * S_im[c]);
        double re = turn[0] * phasor[0] - turn[1] * phasor[1];
        turn[1] = turn[0] * phasor[1] + turn[1] * phasor[0];
        turn[0] = re;
    }
    return R;
}

/* thin_film.metal: the RGB reflectance F of the Principled's F82-tint metal (f0, b) under a film of index
 * film_ior, thickness nm, at cos_i. */
INLINE void thin_film_metal(double cos_i, const double *f0, const double *b, double thickness, double film_ior,
                            double *F)
{
    cos_i = fabs(cos_i);
    if (thickness < 1.0) {
        double x = clamp01(thickness);
        film_ior = 1.0 + (film_ior - 1.0) * x * x * (3.0 - 2.0 * x);
    }
    double R12[2], sign12[2], cos_2;
    int tir = thin_film_polarized(cos_i, film_ior, R12, &cos_2, sign12);
    if (tir) { F[0] = F[1] = F[2] = 1.0; return; }
    double opd = 2.0 * film_ior * thickness * cos_2;
    double g_cos = 1.0 / 7.0, gs = clamp01(1.0 - g_cos), gs5 = gs * gs * gs * gs * gs;
    for (int c = 0; c < 3; c++) {
        double g = clamp01(f0[c] + (1.0 - f0[c]) * gs5 - b[c] * (g_cos * gs5 * gs));
        double r = at_most(f0[c], 0.999), root = sqrt(r);
        double outer = (1.0 + root) / (1.0 - root);
        double n = outer + ((1.0 - r) / (1.0 + r) - outer) * g;
        double k = sqrt(at_least((r * (n + 1.0) * (n + 1.0) - (n - 1.0) * (n - 1.0)) / (1.0 - r), 0.0));
        double R23, phase_s[2], phase_p[2];
        thin_film_conductor(cos_2, film_ior, n, k, g, &R23, phase_s, phase_p);
        double ps[2] = {phase_s[0] * -sign12[0], phase_s[1] * -sign12[0]};
        double pp[2] = {phase_p[0] * -sign12[1], phase_p[1] * -sign12[1]};
        double R_s = thin_film_airy_complex(c, R12[0], R23, ps, opd);
        double R_p = thin_film_airy_complex(c, R12[1], R23, pp, opd);
        F[c] = clamp01(0.5 * (R_s + R_p));
    }
}
