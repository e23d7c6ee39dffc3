/* The Ray Portal BSDF: core/materials/portal.py. A delta that teleports: the ray goes on along the closure's
 * Direction (zero: its own, -wo), weight 1; where it leaves from is the integrators' (direct.c portal_origin). */

#define PORTAL_POSITION_SET 0
#define PORTAL_POSITION 1
#define PORTAL_DIRECTION 4

INLINE void portal_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)c; (void)wo; (void)wi;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
}

/* portal.direction: the unit Direction, or -wo where it is zero. */
INLINE void portal_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    (void)u;
    const double *D = c->p + PORTAL_DIRECTION;
    double length = sqrt(D[0] * D[0] + D[1] * D[1] + D[2] * D[2]);
    for (int k = 0; k < 3; k++) { out->wi[k] = length > 0.0 ? D[k] / length : -wo[k]; out->weight[k] = 1.0; }
    out->pdf = INFINITY;
}
