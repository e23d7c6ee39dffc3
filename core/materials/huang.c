/* Hair, Huang's model: core/materials/huang.py (the Principled Hair BSDF's microfacet fibre, Cycles'
 * bsdf_principled_hair_huang.h). The same arithmetic in the same order as the Python, one hit at a time; the local
 * frame is (X the major axis, Y the tangent, Z), p huang.py's slots (huang_params: nodes.c huang_hair_node). Its
 * random numbers come from a counter-based generator seeded by a hash of the directions' bits (huang.seed_of,
 * huang.number). */

enum { HUANG_SIGMA = 0, HUANG_ROUGH = 3, HUANG_TILT = 4, HUANG_ETA = 5, HUANG_B = 6, HUANG_H = 7, HUANG_R = 8,
       HUANG_TT = 9, HUANG_TRT = 10, HUANG_X = 11, HUANG_Y = 14, HUANG_COVERAGE = 17 };

/* huang.seed_of: a splitmix-like hash of the bits of n doubles. */
INLINE uint64_t huang_seed(const double *x, int n)
{
    uint64_t h = 0;
    for (int i = 0; i < n; i++) {
        uint64_t bits;
        memcpy(&bits, x + i, sizeof bits);
        h = h ^ bits;
        h = h * 0x9E3779B97F4A7C15ULL;
        h = h ^ (h >> 29);
    }
    return h;
}

/* huang.number: the j-th number in [0, 1) of quadrature step `step` (splitmix64's finaliser of seed + counter). */
INLINE double huang_number(uint64_t seed, uint64_t step, uint64_t j)
{
    uint64_t z = seed + (step * 8ULL + j + 1ULL) * 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z = z ^ (z >> 31);
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

INLINE double huang_max(double a, double b) { return (isnan(a) || isnan(b)) ? NAN : (a > b ? a : b); }
INLINE double huang_min(double a, double b) { return (isnan(a) || isnan(b)) ? NAN : (a < b ? a : b); }
INLINE double huang_clip1(double x) { return x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x); }
INLINE double huang_cos_theta(const double *w) { return sqrt(at_least(w[0] * w[0] + w[2] * w[2], 0.0)); }
INLINE double huang_dir_phi(const double *w) { return atan2(w[0], w[2]); }

INLINE double huang_to_phi(double gamma, double b, int circ)
{
    return circ ? gamma : atan2(b * sin(gamma), cos(gamma));
}

INLINE double huang_h_to_gamma(double h, double b, const double *wi, int circ)
{
    return circ ? -asin(huang_clip1(h)) : atan2(wi[2], -b * wi[0]) - acos(huang_clip1(-h));
}

INLINE double huang_phi_to_h(double phi, double b, const double *wi, int circ)
{
    if (circ) return -sin(phi);
    double gamma = atan2(sin(phi), b * cos(phi)), c = huang_cos_theta(wi);
    return -(wi[2] / c) * sin(gamma) + b * (wi[0] / c) * cos(gamma);
}

INLINE double huang_d_gamma_d_h(const double *wi, double gamma, double b, int circ)
{
    double c = huang_cos_theta(wi);
    double d = circ ? cos(gamma) : (wi[2] / c) * cos(gamma) + b * (wi[0] / c) * sin(gamma);
    return d != 0.0 ? 1.0 / d : 0.0;
}

INLINE double huang_chord(double g1, double g2, double b)
{
    double d0 = sin(g1) - sin(g2), d1 = b * cos(g1) - b * cos(g2);
    return sqrt(d0 * d0 + d1 * d1);
}

INLINE void huang_sphg_dir(double theta, double gamma, double b, int circ, double *out)
{
    double st = sin(theta), ct = cos(theta), sg = sin(gamma), cg = cos(gamma), sp, cp;
    if (circ || fabs(cg) < 1e-6) { sp = sg; cp = cg; }
    else {
        double tan_phi = b * (sg / cg);
        cp = (cg > 0.0 ? 1.0 : -1.0) / sqrt(tan_phi * tan_phi + 1.0);
        sp = cp * tan_phi;
    }
    out[0] = sp * ct; out[1] = st; out[2] = cp * ct;
}

INLINE double huang_arc_length(double e2, double gamma)
{
    double s = sin(gamma);
    return e2 == 0.0 ? 1.0 : sqrt(at_least(1.0 - e2 * (s * s), 0.0));
}

INLINE int huang_visible(const double *v, const double *m, const double *h)
{
    return dot3(v, h) > 0.0 && dot3(v, m) > 0.0;
}

INLINE double huang_G(double alpha2, double ci, double co)
{
    return 1.0 / ((1.0 + lambda_ggx(alpha2, ci)) + lambda_ggx(alpha2, co));
}

INLINE double huang_Go(double alpha2, double ci, double co)
{
    double li = lambda_ggx(alpha2, ci);
    return (1.0 + li) / ((1.0 + li) + lambda_ggx(alpha2, co));
}

INLINE double huang_energy_scale(double mu, double sqrt_rough, double eta)
{
    double z = sqrt(fabs((eta - 1.0) / (eta + 1.0)));
    return 1.0 / lookup_3d(eta < 1.0 ? GGX_GLASS_INV_E : GGX_GLASS_E, 16, sqrt_rough, mu, z);
}

/* huang.fresnel_t: the reflectance, and the refracted cosine (negative; 0 under total reflection). */
INLINE double huang_fresnel_t(double cos_i, double eta, double *cos_t)
{
    double s = eta * eta - (1.0 - cos_i * cos_i);
    if (s <= 0.0) { *cos_t = 0.0; return 1.0; }
    double c = fabs(cos_i), ct = -sqrt(s) / eta;
    *cos_t = ct;
    double rs = (c + eta * ct) / (c - eta * ct), rp = (ct + eta * c) / (eta * c - ct);
    return 0.5 * (rs * rs + rp * rp);
}

INLINE void huang_refract(const double *i, const double *n, double cos_t, double inv_eta, double *out)
{
    double a = inv_eta * dot3(n, i) + cos_t;
    for (int k = 0; k < 3; k++) out[k] = a * n[k] - inv_eta * i[k];
}

INLINE void huang_reflect(const double *i, const double *n, double *out)
{
    double a = 2.0 * dot3(i, n);
    for (int k = 0; k < 3; k++) out[k] = i[k] - a * n[k];
}

/* huang.visible_normal: Heitz's 2018 sampler in float64 (the angle's cosine and sine too). */
INLINE void huang_visible_normal(const double *local_wo, double alpha, const double *u, double *H)
{
    double v[3] = {alpha * local_wo[0], alpha * local_wo[1], local_wo[2]};
    double length = sqrt(dot3(v, v));
    for (int k = 0; k < 3; k++) v[k] = v[k] / length;
    double lensq = v[0] * v[0] + v[1] * v[1];
    double T1[3] = {1.0, 0.0, 0.0}, T2[3];
    if (!(lensq <= 1e-7)) {
        double inv = 1.0 / sqrt(lensq);
        T1[0] = -v[1] * inv; T1[1] = v[0] * inv; T1[2] = 0.0;
    }
    cross3(v, T1, T2);
    double r = sqrt(u[0]), angle = 2.0 * PI * u[1];
    double t1 = r * cos(angle), t2 = r * sin(angle);
    double blend = 0.5 * (1.0 + v[2]);
    t2 = (1.0 - blend) * sqrt(at_least(1.0 - t1 * t1, 0.0)) + blend * t2;
    double lift = sqrt(at_least((1.0 - t1 * t1) - t2 * t2, 0.0)), h[3];
    for (int k = 0; k < 3; k++) h[k] = (T1[k] * t1 + T2[k] * t2) + v[k] * lift;
    H[0] = alpha * h[0]; H[1] = alpha * h[1]; H[2] = at_least(h[2], 0.0);
    length = sqrt(dot3(H, H));
    for (int k = 0; k < 3; k++) H[k] = H[k] / length;
}

/* huang.sample_wh: a visible GGX normal about the mesonormal wm. */
INLINE void huang_sample_wh(double rough, const double *wi, const double *wm, const double *u, double *wh)
{
    double x = wm[0], y = wm[1], z = wm[2], a[3], t[3], local[3], H[3];
    if (x != y || x != z) { a[0] = z - y; a[1] = x - z; a[2] = y - x; }
    else { a[0] = z - y; a[1] = x + z; a[2] = -y - x; }
    double length = sqrt(dot3(a, a));
    for (int k = 0; k < 3; k++) a[k] = a[k] / length;
    cross3(wm, a, t);
    local[0] = dot3(wi, a); local[1] = dot3(wi, t); local[2] = dot3(wi, wm);
    huang_visible_normal(local, rough, u, H);
    for (int k = 0; k < 3; k++) wh[k] = (H[0] * a[k] + H[1] * t[k]) + H[2] * wm[k];
}

INLINE void huang_trrt(double T, double R, const double *A, double *out)
{
    double T_avg = at_least(1.0 - R, 1e-5), s = T * (R * R) * T_avg;
    for (int k = 0; k < 3; k++) out[k] = s * A[k] * A[k] * A[k] / (1.0 - A[k] * (1.0 - T_avg));
}

/* huang.frame_z: Z = X x Y, unit. */
INLINE void huang_frame_z(const double *p, double *Z)
{
    double c[3];
    cross3(p + HUANG_X, p + HUANG_Y, c);
    hair_normalize(c, Z);
}

INLINE void huang_local(const double *p, const double *w, double *out)
{
    double Z[3];
    huang_frame_z(p, Z);
    out[0] = dot3(w, p + HUANG_X); out[1] = dot3(w, p + HUANG_Y); out[2] = dot3(w, Z);
}

/* huang.radius_of: the projected radius seen from the local view I. */
INLINE double huang_radius(double b, const double *I)
{
    double e2 = 1.0 - b * b;
    return e2 == 0.0 ? 1.0 : sqrt(1.0 - e2 * (I[0] * I[0]) / (I[0] * I[0] + I[2] * I[2]));
}

INLINE int huang_finite3(const double *x) { return isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]); }

/* HuangHair.albedo: a round, smooth fibre's paths summed, all reflected. */
INLINE void huang_hair_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    const double *p = c->p;
    double wi[3], wt[3], cos_t, h = p[HUANG_H];
    huang_local(p, wo, wi);
    double wmi[3] = {h, 0.0, sqrt(at_least(1.0 - h * h, 0.0))};
    double f = huang_fresnel_t(dot3(wmi, wi), p[HUANG_ETA], &cos_t);
    huang_refract(wi, wmi, cos_t, 1.0 / p[HUANG_ETA], wt);
    for (int k = 0; k < 3; k++) {
        double A = exp(2.0 * p[HUANG_SIGMA + k] * (cos_t / (1.0 - wt[1] * wt[1])));
        double num = (A - 2.0 * f * A) + f, den = 1.0 - f * A;
        R[k] = den != 0.0 ? num / den : 0.0;
        T[k] = 0.0;
    }
}

INLINE int huang_intervals(double length, double step) { return (int)(2.0 * ceil(length / step * 0.5)); }

/* huang.eval_r: the R path by Simpson's rule over h in [lo, hi]. */
static NOINLINE double huang_eval_r(const double *p, const double *wi, const double *wo, double lo, double hi)
{
    if (!(p[HUANG_R] > 0.0)) return 0.0;
    double b = p[HUANG_B], rough = p[HUANG_ROUGH], e2 = 1.0 - b * b, alpha2 = rough * rough, wh[3];
    int circ = b == 1.0;
    for (int k = 0; k < 3; k++) wh[k] = wi[k] + wo[k];
    double length = sqrt(dot3(wh, wh));
    for (int k = 0; k < 3; k++) wh[k] = wh[k] / length;
    int count = huang_intervals(hi - lo, rough * 0.7);
    double res = (hi - lo) / count, integral = 0.0;
    for (int i = 0; i <= count; i++) {
        double h = lo + i * res, wm[3];
        double gamma = huang_h_to_gamma(h, b, wi, circ);
        huang_sphg_dir(p[HUANG_TILT], gamma, b, circ, wm);
        double flat[3] = {wm[0] * 1.0, wm[1] * 0.0, wm[2] * 1.0};
        if (!(huang_visible(wi, flat, wh) && huang_visible(wo, flat, wh))) continue;
        double weight = (i == 0 || i == count ? 0.5 : (double)(i % 2 + 1)) * huang_d_gamma_d_h(wi, gamma, b, circ);
        double cos_mi = dot3(wm, wi);
        double G = huang_G(alpha2, cos_mi, dot3(wm, wo));
        integral += weight * D_ggx(alpha2, dot3(wm, wh)) * G * huang_arc_length(e2, gamma)
                    * huang_energy_scale(cos_mi, sqrt(rough), p[HUANG_ETA]);
    }
    integral *= 2.0 / 3.0 * res;
    double F = hair_fresnel(dot3(wi, wh), p[HUANG_ETA]);
    return p[HUANG_R] * 0.25 * F * integral;
}

/* huang.eval_residual: TT, TRT and the rest, Simpson's rule over h with random microfacet normals. */
static NOINLINE void huang_eval_residual(const double *p, const double *wi, const double *o, double lo, double hi,
                                         uint64_t seed, double *out)
{
    out[0] = out[1] = out[2] = 0.0;
    if (!(p[HUANG_TT] > 0.0 || p[HUANG_TRT] > 0.0)) return;
    double b = p[HUANG_B], rough = p[HUANG_ROUGH], eta = p[HUANG_ETA];
    int circ = b == 1.0;
    double e2 = 1.0 - b * b, inv_eta = 1.0 / eta, alpha2 = rough * rough, sqrt_rough = sqrt(rough);
    const double *mu_a = p + HUANG_SIGMA;
    int count = huang_intervals(hi - lo, rough * 0.8);
    double res = (hi - lo) / count;
    double S_tt[3] = {0.0, 0.0, 0.0}, S_trt[3] = {0.0, 0.0, 0.0}, S_trrt[3] = {0.0, 0.0, 0.0};
    double no[3] = {-o[0], -o[1], -o[2]};
    for (int i = 0; i <= count; i++) {
        double h = lo + i * res, wmi[3], wmi_[3], wh1[3], u1[2];
        double gamma_mi = huang_h_to_gamma(h, b, wi, circ);
        huang_sphg_dir(p[HUANG_TILT], gamma_mi, b, circ, wmi);
        huang_sphg_dir(0.0, gamma_mi, b, circ, wmi_);
        u1[0] = huang_number(seed, (uint64_t)i, 0);
        u1[1] = huang_number(seed, (uint64_t)i, 1);
        huang_sample_wh(rough, wi, wmi, u1, wh1);
        double cos_hi1 = dot3(wi, wh1);
        if (!(cos_hi1 > 0.0)) continue;
        double cos_mi1 = dot3(wi, wmi), cos_t1, wt[3], nwt[3], wmt[3], wmt_[3];
        double T1 = 1.0 - huang_fresnel_t(cos_hi1, eta, &cos_t1);
        double scale1 = huang_energy_scale(cos_mi1, sqrt_rough, eta);
        huang_refract(wi, wh1, cos_t1, inv_eta, wt);
        for (int k = 0; k < 3; k++) nwt[k] = -wt[k];
        double phi_t = huang_dir_phi(wt);
        double gamma_mt = 2.0 * huang_to_phi(phi_t, b, circ) - gamma_mi;
        huang_sphg_dir(-p[HUANG_TILT], gamma_mt, b, circ, wmt);
        huang_sphg_dir(0.0, gamma_mt, b, circ, wmt_);
        double cos_mo1 = dot3(nwt, wmi), cos_mi2 = dot3(nwt, wmt);
        double G1o = huang_Go(alpha2, cos_mi1, cos_mo1);
        if (!(huang_visible(wi, wmi, wh1) && huang_visible(nwt, wmi, wh1) && huang_visible(wi, wmi_, wh1)
              && huang_visible(nwt, wmi_, wh1))) continue;
        double weight = (i == 0 || i == count ? 0.5 : (double)(i % 2 + 1))
                        * huang_d_gamma_d_h(wi, gamma_mi, b, circ);
        double length = circ ? 2.0 * cos(gamma_mi - phi_t) : -huang_chord(gamma_mi, gamma_mt + PI, b);
        double A_t[3], ct_wt = huang_cos_theta(wt);
        for (int k = 0; k < 3; k++) A_t[k] = exp(mu_a[k] / ct_wt * length);
        double scale2 = huang_energy_scale(cos_mi2, sqrt_rough, inv_eta);
        /* TT */
        if (p[HUANG_TT] > 0.0 && dot3(o, wt) >= inv_eta - 1e-5) {
            double wh2[3];
            for (int k = 0; k < 3; k++) wh2[k] = -wt[k] + inv_eta * o[k];
            double rcp2 = 1.0 / sqrt(dot3(wh2, wh2));
            for (int k = 0; k < 3; k++) wh2[k] = wh2[k] * rcp2;
            double cos_mh2 = dot3(wmt, wh2);
            if (cos_mh2 >= 0.0) {
                double cos_hi2 = dot3(nwt, wh2), cos_ho2 = dot3(no, wh2), cos_mo2 = dot3(no, wmt);
                double T2 = (1.0 - hair_fresnel(cos_hi2, inv_eta)) * scale2;
                double D2 = D_ggx(alpha2, cos_mh2);
                double G2 = huang_G(alpha2, cos_mi2, cos_mo2);
                double scalar = weight * T1 * scale1 * T2 * D2 * G1o * G2, result[3];
                for (int k = 0; k < 3; k++)
                    result[k] = scalar * A_t[k] / cos_mo1 * (cos_mi1 * cos_hi2 * cos_ho2 * (rcp2 * rcp2));
                if (huang_finite3(result)) {
                    double s = p[HUANG_TT] * huang_arc_length(e2, gamma_mt);
                    for (int k = 0; k < 3; k++) S_tt[k] += s * result[k];
                }
            }
        }
        /* TRT and beyond */
        if (!(p[HUANG_TRT] > 0.0)) continue;
        double u2[2], wh2[3], wtr[3], nwtr[3], rest[3];
        u2[0] = huang_number(seed, (uint64_t)i, 2);
        u2[1] = huang_number(seed, (uint64_t)i, 3);
        huang_sample_wh(rough, nwt, wmt, u2, wh2);
        double cos_hi2 = dot3(nwt, wh2);
        if (!(cos_hi2 > 0.0)) continue;
        double R2 = hair_fresnel(cos_hi2, inv_eta);
        huang_trrt(T1, R2, A_t, rest);
        for (int k = 0; k < 3; k++) rest[k] = weight * rest[k];
        huang_reflect(wt, wh2, wtr);
        for (int k = 0; k < 3; k++) { wtr[k] = -wtr[k]; nwtr[k] = -wtr[k]; }
        if (dot3(nwtr, o) < inv_eta - 1e-5) {
            for (int k = 0; k < 3; k++) S_trrt[k] += rest[k];
            continue;
        }
        if (!(huang_visible(nwt, wmt, wh2) && huang_visible(nwtr, wmt, wh2) && huang_visible(nwt, wmt_, wh2)
              && huang_visible(nwtr, wmt_, wh2))) continue;
        double phi_tr = huang_dir_phi(wtr), wmtr[3], wmtr_[3], wh3[3];
        double gamma_mtr = gamma_mi - 2.0 * (huang_to_phi(phi_t, b, circ) - huang_to_phi(phi_tr, b, circ)) + PI;
        huang_sphg_dir(-p[HUANG_TILT], gamma_mtr, b, circ, wmtr);
        huang_sphg_dir(0.0, gamma_mtr, b, circ, wmtr_);
        for (int k = 0; k < 3; k++) wh3[k] = wtr[k] + inv_eta * o[k];
        double rcp3 = 1.0 / sqrt(dot3(wh3, wh3));
        for (int k = 0; k < 3; k++) wh3[k] = wh3[k] * rcp3;
        double cos_mh3 = dot3(wmtr, wh3);
        if (cos_mh3 < 0.0 || !(huang_visible(wtr, wmtr, wh3) && huang_visible(no, wmtr, wh3))
            || !(huang_visible(wtr, wmtr_, wh3) && huang_visible(no, wmtr_, wh3))) {
            for (int k = 0; k < 3; k++) S_trrt[k] += rest[k];
            continue;
        }
        double cos_hi3 = dot3(wh3, wtr), cos_ho3 = dot3(wh3, no), cos_mi3 = dot3(wmtr, wtr);
        double T3 = (1.0 - hair_fresnel(cos_hi3, inv_eta)) * huang_energy_scale(cos_mi3, sqrt_rough, inv_eta);
        double D3 = D_ggx(alpha2, cos_mh3);
        double len3 = circ ? 2.0 * fabs(cos(phi_tr - gamma_mt)) : huang_chord(gamma_mtr, gamma_mt, b);
        double A_tr[3], ct_wtr = huang_cos_theta(wtr), result[3];
        for (int k = 0; k < 3; k++) A_tr[k] = exp(mu_a[k] / ct_wtr * -len3);
        double cos_mo2 = dot3(wmt, nwtr);
        double G2o = huang_Go(alpha2, cos_mi2, cos_mo2);
        double G3 = huang_G(alpha2, cos_mi3, dot3(wmtr, no));
        double scalar = weight * T1 * scale1 * R2 * scale2 * T3 * D3 * G1o * G2o * G3;
        for (int k = 0; k < 3; k++)
            result[k] = scalar * A_t[k] * A_tr[k] / (cos_mo1 * cos_mo2)
                        * (cos_mi1 * cos_mi2 * cos_hi3 * cos_ho3 * (rcp3 * rcp3));
        if (huang_finite3(result)) {
            double s = p[HUANG_TRT] * huang_arc_length(e2, gamma_mtr);
            for (int k = 0; k < 3; k++) S_trt[k] += s * result[k];
        }
        for (int k = 0; k < 3; k++) S_trrt[k] += rest[k];
    }
    double M = hair_longitudinal(wi[1], huang_cos_theta(wi), o[1], huang_cos_theta(o), 4.0 * rough);
    double m = M * (1.0 / (2.0 * PI)) * (2.0 / PI), simpson = 2.0 / 3.0 * res;
    for (int k = 0; k < 3; k++) out[k] = ((S_tt[k] + S_trt[k]) * (inv_eta * inv_eta) + S_trrt[k] * m) * simpson;
}

INLINE void huang_hair_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    const double *p = c->p;
    double I[3], O[3];
    *pdf = 1.0;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    huang_local(p, wo, I);
    huang_local(p, wi, O);
    /* huang.integration_range */
    double b = p[HUANG_B];
    int circ = b == 1.0;
    double tan_tilt = tan(p[HUANG_TILT]);
    double tan_o = O[1] / huang_cos_theta(O), tan_i = I[1] / huang_cos_theta(I);
    double half_span = acos(huang_max(-tan_tilt * tan_i, 0.0));
    if (tan_tilt * tan_o < -1.0 || isnan(half_span)) return;
    double phi_i = circ ? 0.0 : huang_dir_phi(I);
    double lo = huang_phi_to_h(phi_i + half_span, b, I, circ), hi = huang_phi_to_h(phi_i - half_span, b, I, circ);
    double r = huang_radius(b, I), half_pixel = p[HUANG_COVERAGE], dh = 2.0;
    if (r > half_pixel) {
        double near_lo = huang_max(-r, p[HUANG_H] - half_pixel), near_hi = huang_min(r, p[HUANG_H] + half_pixel);
        dh = (near_hi - near_lo) / r;
        lo = huang_max(lo, near_lo);
        hi = huang_min(hi, near_hi);
    }
    lo = huang_max(lo / r, -0.999);
    hi = huang_min(hi / r, 0.999);
    if (!(lo < hi)) return;
    double area = huang_cos_theta(I) * dh, rest[3];
    double x[6] = {wo[0], wo[1], wo[2], wi[0], wi[1], wi[2]};
    uint64_t seed = huang_seed(x, 6);
    double R = huang_eval_r(p, I, O, lo, hi);
    huang_eval_residual(p, I, O, lo, hi, seed, rest);
    for (int k = 0; k < 3; k++) f_cos[k] = (R + rest[k]) / area;
}

/* huang.sample_huang: one path through the fibre, its weight the lobes' energy, pdf 1. */
INLINE void huang_hair_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    const double *p = c->p;
    double x[6] = {wo[0], wo[1], wo[2], u[0], u[1], u[2]};
    uint64_t seed = huang_seed(x, 6);
    double draws[8];
    for (int j = 0; j < 8; j++) draws[j] = huang_number(seed, 0, (uint64_t)j);
    double wi[3];
    huang_local(p, wo, wi);
    double b = p[HUANG_B], rough = p[HUANG_ROUGH], eta = p[HUANG_ETA];
    int circ = b == 1.0;
    double inv_eta = 1.0 / eta, alpha2 = rough * rough, sqrt_rough = sqrt(rough);
    const double *mu_a = p + HUANG_SIGMA;
    out->pdf = 0.0;
    for (int k = 0; k < 3; k++) { out->wi[k] = 0.0; out->weight[k] = 0.0; }
    double radius = huang_radius(b, wi);
    double h = radius > p[HUANG_COVERAGE] ? p[HUANG_H] / radius : u[1] * 2.0 - 1.0;
    double gamma_mi = huang_h_to_gamma(h, b, wi, circ), wmi_[3], wmi[3];
    huang_sphg_dir(0.0, gamma_mi, b, circ, wmi_);
    double st = sin(p[HUANG_TILT]), ct = cos(p[HUANG_TILT]);
    wmi[0] = wmi_[0] * ct; wmi[1] = st; wmi[2] = wmi_[2] * ct;
    double cos_mi1 = dot3(wmi, wi);
    if (cos_mi1 < 0.0 || dot3(wmi_, wi) < 0.0) return;
    double wh1[3], wr[3], u1[2] = {u[2], draws[0]};
    huang_sample_wh(rough, wi, wmi, u1, wh1);
    huang_reflect(wi, wh1, wr);
    for (int k = 0; k < 3; k++) wr[k] = -wr[k];
    if (!huang_visible(wi, wmi_, wh1)) return;
    double cos_t1, R1 = huang_fresnel_t(dot3(wi, wh1), eta, &cos_t1);
    double scale1 = huang_energy_scale(cos_mi1, sqrt_rough, eta);
    double R = p[HUANG_R] * R1 * scale1 * (double)huang_visible(wr, wmi_, wh1)
               * huang_Go(alpha2, cos_mi1, dot3(wmi, wr));
    double wt[3], nwt[3], wmt[3], wmt_[3], wh2[3], wtr[3], u2[2] = {draws[1], draws[2]};
    huang_refract(wi, wh1, cos_t1, inv_eta, wt);
    for (int k = 0; k < 3; k++) nwt[k] = -wt[k];
    double phi_t = huang_dir_phi(wt);
    double gamma_mt = 2.0 * huang_to_phi(phi_t, b, circ) - gamma_mi;
    huang_sphg_dir(-p[HUANG_TILT], gamma_mt, b, circ, wmt);
    huang_sphg_dir(0.0, gamma_mt, b, circ, wmt_);
    huang_sample_wh(rough, nwt, wmt, u2, wh2);
    huang_reflect(wt, wh2, wtr);
    for (int k = 0; k < 3; k++) wtr[k] = -wtr[k];
    double TT[3] = {0.0, 0.0, 0.0}, TRT[3] = {0.0, 0.0, 0.0}, TRRT[3] = {0.0, 0.0, 0.0};
    double wtt[3] = {0.0, 0.0, 0.0}, wtrt[3] = {0.0, 0.0, 0.0}, wtrrt[3] = {0.0, 0.0, 0.0};
    double cos_mi2 = dot3(nwt, wmt);
    if (cos_mi2 > 0.0 && huang_visible(nwt, wmi_, wh1) && huang_visible(nwt, wmt_, wh2)) {
        double length = circ ? 2.0 * cos(phi_t - gamma_mi) : -huang_chord(gamma_mi, gamma_mt + PI, b);
        double A_t[3], ct_wt = huang_cos_theta(wt);
        for (int k = 0; k < 3; k++) A_t[k] = exp(mu_a[k] / ct_wt * length);
        double cos_t2, R2 = huang_fresnel_t(dot3(nwt, wh2), inv_eta, &cos_t2);
        double T1 = (1.0 - R1) * scale1 * huang_Go(alpha2, cos_mi1, dot3(wmi, nwt));
        double T2 = 1.0 - R2;
        double scale2 = huang_energy_scale(cos_mi2, sqrt_rough, inv_eta);
        double nwtt[3];
        huang_refract(nwt, wh2, cos_t2, eta, wtt);
        for (int k = 0; k < 3; k++) nwtt[k] = -wtt[k];
        if (dot3(wmt, nwtt) > 0.0 && T2 > 0.0 && huang_visible(nwtt, wmt_, wh2)) {
            double y = T2 * scale2 * huang_Go(alpha2, cos_mi2, dot3(wmt, nwtt));
            for (int k = 0; k < 3; k++) TT[k] = (p[HUANG_TT] * T1) * A_t[k] * y;
        }
        double phi_tr = huang_dir_phi(wtr), wmtr[3], wh3[3], nwtr[3];
        for (int k = 0; k < 3; k++) nwtr[k] = -wtr[k];
        double gamma_mtr = gamma_mi - 2.0 * (huang_to_phi(phi_t, b, circ) - huang_to_phi(phi_tr, b, circ)) + PI;
        huang_sphg_dir(-p[HUANG_TILT], gamma_mtr, b, circ, wmtr);
        double u3[2] = {draws[3], draws[4]};
        huang_sample_wh(rough, wtr, wmtr, u3, wh3);
        double cos_t3, R3 = huang_fresnel_t(dot3(wtr, wh3), inv_eta, &cos_t3);
        huang_refract(wtr, wh3, cos_t3, eta, wtrt);
        double cos_mi3 = dot3(wmtr, wtr);
        if (cos_mi3 > 0.0) {
            double len3 = circ ? 2.0 * fabs(cos(phi_tr - gamma_mt)) : huang_chord(gamma_mt, gamma_mtr, b);
            double A_tr[3], TR[3], ct_wtr = huang_cos_theta(wtr);
            for (int k = 0; k < 3; k++) A_tr[k] = exp(mu_a[k] / ct_wtr * -len3);
            double y = huang_energy_scale(cos_mi3, sqrt_rough, inv_eta) * huang_Go(alpha2, cos_mi2, dot3(wmt, nwtr));
            for (int k = 0; k < 3; k++) TR[k] = (T1 * R2 * scale2) * A_t[k] * A_tr[k] * y;
            double T3 = 1.0 - R3, nwtrt[3], flat3[3] = {wmtr[0] * 1.0, wmtr[1] * 0.0, wmtr[2] * 1.0};
            for (int k = 0; k < 3; k++) nwtrt[k] = -wtrt[k];
            if (T3 > 0.0 && huang_visible(wtr, flat3, wh3) && huang_visible(nwtrt, flat3, wh3)) {
                double y3 = T3 * huang_Go(alpha2, cos_mi3, dot3(wmtr, nwtrt));
                for (int k = 0; k < 3; k++) TRT[k] = p[HUANG_TRT] * TR[k] * y3;
            }
            double z = at_least(draws[5], 1e-5), m1 = draws[6], m2 = draws[7];
            double fac = 1.0 + 4.0 * rough * log(z + (1.0 - z) * exp(-0.5 / rough));
            double sin_o = -fac * wi[1] + sqrt(at_least(1.0 - fac * fac, 0.0)) * cos(2.0 * PI * m1)
                           * huang_cos_theta(wi);
            double cos_o = sqrt(at_least(1.0 - sin_o * sin_o, 0.0)), phi_o = 2.0 * PI * m2;
            wtrrt[0] = sin(phi_o) * cos_o; wtrrt[1] = sin_o; wtrrt[2] = cos(phi_o) * cos_o;
            double T_avg = at_least(0.5 * (T2 + T3), 1e-5), back[3], rwh3[3];
            huang_reflect(wtr, wh3, rwh3);
            for (int k = 0; k < 3; k++) back[k] = -rwh3[k];
            double y2 = R3 * huang_Go(alpha2, cos_mi3, dot3(wmtr, back));
            for (int k = 0; k < 3; k++) {
                double A_avg = sqrt(A_t[k] * A_tr[k]);
                double A_res = A_avg * T_avg / (1.0 - A_avg * (1.0 - T_avg));
                TRRT[k] = TR[k] * A_res * y2;
            }
        }
    }
    double tt = (TT[0] + TT[1] + TT[2]) / 3.0, trt = (TRT[0] + TRT[1] + TRT[2]) / 3.0;
    double rest = (TRRT[0] + TRRT[1] + TRRT[2]) / 3.0;
    double total = ((R + tt) + trt) + rest;
    double pick = u[0] * total, colour[3], *local;
    if (pick < R) { local = wr; colour[0] = colour[1] = colour[2] = 1.0; }
    else if (pick < R + tt) { local = wtt; for (int k = 0; k < 3; k++) colour[k] = TT[k] / tt; }
    else if (pick < (R + tt) + trt) { local = wtrt; for (int k = 0; k < 3; k++) colour[k] = TRT[k] / trt; }
    else { local = wtrrt; for (int k = 0; k < 3; k++) colour[k] = TRRT[k] / rest; }
    double weight[3];
    for (int k = 0; k < 3; k++) weight[k] = colour[k] * total;
    if (!(total != 0.0 && huang_finite3(weight) && huang_finite3(local))) return;
    double Z[3];
    huang_frame_z(p, Z);
    for (int k = 0; k < 3; k++) {
        out->wi[k] = (local[0] * p[HUANG_X + k] + local[1] * p[HUANG_Y + k]) + local[2] * Z[k];
        out->weight[k] = weight[k];
    }
    out->pdf = 1.0;
}
