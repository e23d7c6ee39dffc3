/* The BSSRDF closure: core/materials/subsurface.py. No value for a pair of directions; its sample is the direction
   the walk starts along, into the surface: refracted through a GGX normal the viewer sees (Random Walk (Skin): half
   the time cosine-weighted around -N, else with alpha 1), weight 1 and pdf inf (Christensen-Burley's disk: -N,
   never failing). The walk itself is
   core/integrators/subsurface.c; the closure's set-up, nodes.c subsurface_add. */

#define SUBSURFACE_RADIUS 0     /* subsurface.RADIUS, ALBEDO, ANISOTROPY, IOR, ALPHA, SKIN, BUMP: the closure's
                                   parameter slots */
#define SUBSURFACE_ALBEDO 3
#define SUBSURFACE_ANISOTROPY 6
#define SUBSURFACE_IOR 7
#define SUBSURFACE_ALPHA 8
#define SUBSURFACE_SKIN 9
#define SUBSURFACE_BUMP 10
#define SUBSURFACE_DISK 11      /* 1: Christensen-Burley, Cycles' disk projection (integrators/subsurface.c) */
#define SUBSURFACE_MIN_RADIUS 1e-8   /* subsurface.MIN_RADIUS: radii below it scatter as diffuse */

/* subsurface.dipole_Rd: the diffuse reflectance of a dipole of single-scattering albedo alpha'. */
INLINE double dipole_Rd(double alpha_prime, double fourthird_A)
{
    double s = sqrt(3.0 * (1.0 - alpha_prime));
    return 0.5 * alpha_prime * (1.0 + exp(-fourthird_A * s)) * exp(-s);
}

/* subsurface.dipole_alpha_prime: the alpha' whose dipole reflects rd (12 bisection steps; 0 below 1e-4, 0.999999
   from 0.995). */
INLINE double dipole_alpha_prime(double rd, double fourthird_A)
{
    double lo = 0.0, hi = 1.0, mid = 0.5;
    for (int i = 0; i < 12; i++) {
        mid = 0.5 * (lo + hi);
        if (dipole_Rd(mid, fourthird_A) < rd) lo = mid;
        else hi = mid;
    }
    return rd < 1e-4 ? 0.0 : (rd >= 0.995 ? 0.999999 : mid);
}

/* subsurface.scaled_radius for one channel: the walk's mean free path from the node's radius: x 1 / (4 pi) (Random
   Walk), the radius itself (mfp: Blender 5.2's Random Walk), or for Skin x sqrt(3 (1 - alpha')) with alpha' the
   dipole's for the colour and index. */
INLINE double scaled_radius(double radius, double albedo, double ior, int skin, int mfp)
{
    if (!skin) return mfp ? radius : radius * (0.25 / PI);
    double inv_eta = 1.0 / ior;
    double F_dr = inv_eta * (-1.440 * inv_eta + 0.710) + 0.668 + 0.0636 * ior;
    double fourthird_A = (4.0 / 3.0) * (1.0 + F_dr) / (1.0 - F_dr);
    return radius * sqrt(3.0 * (1.0 - dipole_alpha_prime(albedo, fourthird_A)));
}

INLINE void subsurface_eval(const Closure *c, const double *wo, const double *wi, double *f_cos, double *pdf)
{
    (void)c; (void)wo; (void)wi;
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0;
    *pdf = 0.0;
}

INLINE void subsurface_sample(const Closure *c, const double *wo, const double *u, BsdfSample *out)
{
    const double *N = c->N;
    int skin = c->p[SUBSURFACE_SKIN] != 0.0;
    int diffuse = skin && u[0] < 0.5;
    double ux = skin ? (diffuse ? 2.0 * u[0] : 2.0 * (u[0] - 0.5)) : u[0];
    double uu[2] = {ux < nextafter(1.0, 0.0) ? ux : nextafter(1.0, 0.0), u[1]};
    double cos_NI = dot3(N, wo);
    if (diffuse) {
        /* Lambert's cosine-weighted hemisphere, around -N. */
        double axis[3] = {-N[0], -N[1], -N[2]}, t[3], b[3], cos_phi, sin_phi;
        double r = sqrt(uu[0]);
        cos_sin(2.0 * PI * uu[1], &cos_phi, &sin_phi);
        double x = r * cos_phi, y = r * sin_phi, z = sqrt(at_least(1.0 - uu[0], 0.0));
        orthonormal_frame(axis, t, b);
        for (int k = 0; k < 3; k++) out->wi[k] = (t[k] * x + b[k] * y) + axis[k] * z;
    } else {
        double X[3], Y[3], H[3], local_H[3];
        orthonormal_frame(N, X, Y);
        double local_I[3] = {dot3(X, wo), dot3(Y, wo), cos_NI};
        if (!(cos_NI > 0.0)) { local_I[0] = 0.0; local_I[1] = 0.0; local_I[2] = 1.0; }
        double alpha = skin ? 1.0 : c->p[SUBSURFACE_ALPHA];
        alpha = alpha > 1e-7 ? alpha : 1e-7;
        sample_visible_normal(local_I, alpha, alpha, uu, local_H);
        for (int k = 0; k < 3; k++) H[k] = X[k] * local_H[0] + Y[k] * local_H[1] + N[k] * local_H[2];
        double neta = 1.0 / c->p[SUBSURFACE_IOR];
        double cos_HI = dot3(H, wo);
        double root = sqrt(at_least(1.0 - neta * neta * (1.0 - cos_HI * cos_HI), 0.0));
        root = root > 1e-7 ? root : 1e-7;
        double d[3];
        for (int k = 0; k < 3; k++) d[k] = -neta * wo[k] + (neta * cos_HI - root) * H[k];
        double length = sqrt(dot3(d, d));
        for (int k = 0; k < 3; k++) out->wi[k] = d[k] / length;
    }
    int disk = c->p[SUBSURFACE_DISK] != 0.0;
    if (disk) for (int k = 0; k < 3; k++) out->wi[k] = -N[k];
    int ok = diffuse || cos_NI > 0.0 || disk;
    for (int k = 0; k < 3; k++) out->weight[k] = ok ? 1.0 : 0.0;
    out->pdf = ok ? INFINITY : 0.0;
}
