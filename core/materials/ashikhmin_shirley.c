/* The Ashikhmin-Shirley BSDF: core/materials/ashikhmin_shirley.py (its docstring has the model). p: microfacet.c's
 * slots (alpha, alpha_y and the tangent; anisotropic where mf_is_anisotropic). */

#define AS_ALPHA_MIN 1e-4

/* ashikhmin_shirley.alphas: alpha_x, and alpha_y (alpha_x where isotropic). */
INLINE int as_alphas(const double *p, double *ax, double *ay)
{
    int aniso = mf_is_anisotropic(p);
    *ax = p[MF_ALPHA];
    *ay = aniso ? p[MF_ALPHA_Y] : p[MF_ALPHA];
    return aniso;
}

INLINE double as_exponent(double alpha) { return 2.0 / (alpha * alpha) - 2.0; }

INLINE void ashikhmin_shirley_albedo(const Closure *c, const double *wo, double *R, double *T)
{
    (void)c; (void)wo;
    R[0] = R[1] = R[2] = 1.0;
    T[0] = T[1] = T[2] = 0.0;
}

INLINE void ashikhmin_shirley_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    const double *N = c->N;
    double ax, ay;
    int aniso = as_alphas(c->p, &ax, &ay);
    double cos_NI = dot3(N, wo), cos_NO = dot3(N, wi);
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
    if (!(at_least(ax, ay) > AS_ALPHA_MIN && cos_NI >= 0.0 && cos_NO >= 0.0)) return;
    cos_NI = at_least(cos_NI, 1e-6);
    cos_NO = at_least(cos_NO, 1e-6);
    double H[3] = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
    double length = at_least(sqrt(dot3(H, H)), 1e-300);
    for (int k = 0; k < 3; k++) H[k] /= length;
    double cos_HI = at_least(fabs(dot3(H, wo)), 1e-6), cos_NH = at_least(dot3(N, H), 1e-6);
    double pump = 1.0 / at_least(1e-6, cos_HI * at_least(cos_NI, cos_NO));
    double n_x = as_exponent(ax), n_y = as_exponent(ay), lobe, norm;
    if (aniso) {
        double X[3], Y[3];
        mf_tangent_frame(N, c->p + MF_TANGENT, X, Y);
        double cos_HX = dot3(H, X), cos_HY = dot3(H, Y);
        if (cos_NH < 1.0) {
            double e = (n_x * cos_HX * cos_HX + n_y * cos_HY * cos_HY) / (1.0 - cos_NH * cos_NH);
            lobe = pow(cos_NH, e);
        } else {
            lobe = 1.0;
        }
        norm = sqrt((n_x + 1.0) * (n_y + 1.0)) / (8.0 * PI);
    } else {
        lobe = pow(cos_NH, n_x);
        norm = (n_x + 1.0) / (8.0 * PI);
    }
    double out = cos_NO * norm * lobe * pump;
    f_cos[0] = f_cos[1] = f_cos[2] = out;
    *pdf = norm * lobe / cos_HI;
}

/* ashikhmin_shirley.first_quadrant: phi and cos theta of a half vector in the lobe's first quadrant. */
INLINE void as_first_quadrant(double n_x, double n_y, double u0, double u1, double *phi, double *cos_theta)
{
    *phi = atan(sqrt((n_x + 1.0) / (n_y + 1.0)) * tan(0.5 * PI * u0));
    double cos_phi = cos(*phi), sin_phi = sin(*phi);
    *cos_theta = pow(u1, 1.0 / (n_x * cos_phi * cos_phi + n_y * sin_phi * sin_phi + 1.0));
}

INLINE void ashikhmin_shirley_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    const double *N = c->N;
    double ax, ay;
    int aniso = as_alphas(c->p, &ax, &ay);
    double cos_NI = dot3(N, wo);
    double n_x = as_exponent(at_least(ax, 1e-300)), n_y = as_exponent(at_least(ay, 1e-300));
    /* 1. The frame: the tangent's where anisotropic. */
    double t[3], b[3];
    if (aniso) mf_tangent_frame(N, c->p + MF_TANGENT, t, b);
    else orthonormal_frame(N, t, b);
    /* 2. The half vector's angles. */
    double phi = 2.0 * PI * u[0], cos_theta = pow(u[1], 1.0 / (n_x + 1.0));
    if (aniso) {
        int quadrant = (int)(u[0] * 4.0);
        if (quadrant > 3) quadrant = 3;
        double u0 = quadrant == 0 ? 4.0 * u[0] : quadrant == 1 ? 4.0 * (0.5 - u[0])
                  : quadrant == 2 ? 4.0 * (u[0] - 0.5) : 4.0 * (1.0 - u[0]);
        double q_phi;
        as_first_quadrant(n_x, n_y, u0, u[1], &q_phi, &cos_theta);
        phi = quadrant == 0 ? q_phi : quadrant == 1 ? PI - q_phi : quadrant == 2 ? PI + q_phi : 2.0 * PI - q_phi;
    }
    /* 3. The half vector, turned to face wo, and the direction made from it (Cycles' arithmetic). */
    double sin_theta = sqrt(at_least(1.0 - cos_theta * cos_theta, 0.0));
    double cos_phi = cos(phi), sin_phi = sin(phi), H[3];
    for (int k = 0; k < 3; k++) H[k] = (t[k] * (sin_theta * cos_phi) + b[k] * (sin_theta * sin_phi)) + N[k] * cos_theta;
    double cos_HI = dot3(H, wo);
    if (cos_HI < 0.0) for (int k = 0; k < 3; k++) H[k] = -H[k];
    double raw[3];
    for (int k = 0; k < 3; k++) raw[k] = 2.0 * cos_HI * H[k] - wo[k];
    /* 4. Its value and pdf from eval at that vector as it is (longer than 1 where H was turned, as Cycles
     *    evaluates it), and the direction made unit for the ray. */
    double f_cos[3];
    ashikhmin_shirley_eval(c, wo, raw, f_cos, &out->pdf);
    double length = at_least(sqrt(dot3(raw, raw)), 1e-300);
    for (int k = 0; k < 3; k++) out->wi[k] = raw[k] / length;
    if (!(cos_NI > 0.0)) out->pdf = 0.0;
    for (int k = 0; k < 3; k++) out->weight[k] = out->pdf > 0.0 ? f_cos[k] / out->pdf : 0.0;
}
