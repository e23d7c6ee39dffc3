/* The Toon BSDF's two components: core/materials/toon.py. f cos = I(angle) / (2 pi (1 - cos sample_angle)) of the
 * angle between wi and N (diffuse_toon) or R, the view mirrored about N (glossy_toon); uniform sampling of the cone.
 * p: max_angle, smooth (radians), set up per hit (toon.params_of, nodes.c toon_node). */

enum { TOON_MAX_ANGLE = 0, TOON_SMOOTH = 1 };

/* toon.intensity: 1 within the cone, falling linearly to 0 across its rim. */
INLINE double toon_intensity(const double *p, double angle)
{
    double max_angle = p[TOON_MAX_ANGLE], smooth = p[TOON_SMOOTH];
    if (angle < max_angle) return 1.0;
    if (angle < max_angle + smooth && smooth != 0.0) return 1.0 - (angle - max_angle) / smooth;
    return 0.0;
}

/* toon.cone: the sampled cone's half-angle and its uniform pdf. */
INLINE double toon_cone(const double *p, double *sample_angle)
{
    double a = p[TOON_MAX_ANGLE] + p[TOON_SMOOTH];
    *sample_angle = a < PI / 2.0 ? a : PI / 2.0;
    double s = sin(0.5 * *sample_angle);
    return 1.0 / (2.0 * PI * (2.0 * s * s));
}

/* toon.cone_eval: f cos and pdf of light from wi at its angle with `axis`, where `valid`. */
INLINE void toon_cone_eval(const double *p, const double *axis, const double *wi, int valid, double *f_cos,
                           double *pdf)
{
    double angle = acos(clamp01(dot3(axis, wi)));
    double sample_angle, cone_pdf = toon_cone(p, &sample_angle);
    *pdf = valid && angle < sample_angle ? cone_pdf : 0.0;
    double value = *pdf * toon_intensity(p, angle);
    f_cos[0] = f_cos[1] = f_cos[2] = value;
}

/* toon.cone_sample: a direction uniform in the cone around `axis`; returns the angle it makes with it. */
INLINE double toon_cone_sample(const double *p, const double *axis, const double *u, double *wi, double *pdf)
{
    double sample_angle;
    *pdf = toon_cone(p, &sample_angle);
    double s = sin(0.5 * sample_angle);
    double cos_theta = 1.0 - u[0] * (2.0 * s * s);
    double sin_theta = sqrt(at_least(1.0 - cos_theta * cos_theta, 0.0));
    double cos_phi, sin_phi, t[3], b[3];
    cos_sin(2.0 * PI * u[1], &cos_phi, &sin_phi);
    orthonormal_frame(axis, t, b);
    for (int k = 0; k < 3; k++) wi[k] = (t[k] * (sin_theta * cos_phi) + b[k] * (sin_theta * sin_phi)) + axis[k] * cos_theta;
    return acos(cos_theta < -1.0 ? -1.0 : (cos_theta > 1.0 ? 1.0 : cos_theta));
}

/* toon.mirrored: R = 2 (N.wo) N - wo. */
INLINE void toon_mirrored(const double *N, const double *wo, double *R)
{
    double d = 2.0 * dot3(N, wo);
    for (int k = 0; k < 3; k++) R[k] = d * N[k] - wo[k];
}

INLINE void diffuse_toon_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)wo;
    toon_cone_eval(c->p, c->N, wi, dot3(c->N, wi) >= 0.0, f_cos, pdf);
}

INLINE void diffuse_toon_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    (void)wo;
    double angle = toon_cone_sample(c->p, c->N, u, out->wi, &out->pdf);
    double weight = toon_intensity(c->p, angle);
    for (int k = 0; k < 3; k++) out->weight[k] = weight;
}

INLINE void glossy_toon_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    double R[3];
    toon_mirrored(c->N, wo, R);
    toon_cone_eval(c->p, R, wi, dot3(c->N, wo) > 0.0 && dot3(c->N, wi) > 0.0, f_cos, pdf);
}

INLINE void glossy_toon_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    double R[3];
    toon_mirrored(c->N, wo, R);
    double angle = toon_cone_sample(c->p, R, u, out->wi, &out->pdf);
    int sampled = dot3(c->N, wo) > 0.0 && dot3(c->N, out->wi) > 0.0;
    double weight = sampled ? toon_intensity(c->p, angle) : 0.0;
    if (!sampled) out->pdf = 0.0;
    for (int k = 0; k < 3; k++) out->weight[k] = weight;
}
