/* Phase functions: core/volumes/phase.py. Henyey and Greenstein's, which media scatter with (integrators/volume.c)
   and subsurface walks step with (integrators/subsurface.c). */

/* phase.henyey_greenstein: (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5). */
INLINE double henyey_greenstein(double cos_theta, double g)
{
    double denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(denom));
}

/* HenyeyGreenstein.sample: a direction wi (3) for a viewer along wo (3) from numbers u (2), its pdf returned. */
INLINE double sample_henyey_greenstein(const double *wo, double g, const double *u, double *wi)
{
    double cos_theta;
    if (fabs(g) < 1e-3) cos_theta = 1.0 - 2.0 * u[0];
    else {
        double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u[0]);
        cos_theta = (1.0 + g * g - s * s) / (2.0 * g);
    }
    cos_theta = cos_theta < -1.0 ? -1.0 : (cos_theta > 1.0 ? 1.0 : cos_theta);
    double sin_theta = sqrt(at_least(1.0 - cos_theta * cos_theta, 0.0)), phi = 2.0 * PI * u[1];
    double axis[3] = {-wo[0], -wo[1], -wo[2]}, T[3], B[3];
    orthonormal_frame(axis, T, B);
    double a = sin_theta * cos(phi), b = sin_theta * sin(phi);
    for (int c = 0; c < 3; c++) wi[c] = (a * T[c] + b * B[c]) + cos_theta * axis[c];
    return henyey_greenstein(cos_theta, g);
}
