/* The BSSRDF closure: core/materials/subsurface.py. No value for a pair of directions; its sample is the direction
   the walk starts along, into the surface: refracted through a GGX normal the viewer sees (Random Walk (Skin): half
   the time cosine-weighted around -N, else with alpha 1), weight 1 and pdf inf. The compiled kernel does not walk:
   a render with a subsurface closure runs the Python reference (core/render/__init__.py subsurface_reason). */

#define SUBSURFACE_IOR 7        /* subsurface.IOR, ALPHA, SKIN: the closure's parameter slots */
#define SUBSURFACE_ALPHA 8
#define SUBSURFACE_SKIN 9

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
    int ok = diffuse || cos_NI > 0.0;
    for (int k = 0; k < 3; k++) out->weight[k] = ok ? 1.0 : 0.0;
    out->pdf = ok ? INFINITY : 0.0;
}
