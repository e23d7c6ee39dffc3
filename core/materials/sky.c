/* Cycles' Sky Texture at one direction: core/materials/sky.py evaluate, the same arithmetic in the same order. The
 * op's floats (f, SKY_AT_* places) hold everything Python precomputed: the model, the sun, the disc, the XYZ to RGB
 * matrix, then the scattering models' XYZ table or the analytic models' numbers. */

INLINE double sky_clamped_cos(double c) { return c < -1.0 ? -1.0 : c > 1.0 ? 1.0 : c; }

INLINE int64_t sky_clamped_index(int64_t i, int64_t n) { return i < 0 ? 0 : i > n - 1 ? n - 1 : i; }

/* sky.table_xyz: the table's XYZ along D, linear between texel centres, edges clamped (NaN where D is not finite). */
INLINE void sky_table_xyz(const double *f, const double *D, double *xyz)
{
    int64_t height = (int64_t)f[SKY_AT_HEIGHT], width = (int64_t)f[SKY_AT_WIDTH];
    const double *table = f + SKY_AT_PAYLOAD;
    double e = 0.5 * PI - acos(sky_clamped_cos(D[2]));
    double turns = (-atan2(D[1], D[0]) - 0.5 * PI + f[SKY_AT_ROTATION]) / (2.0 * PI);
    double u = turns - floor(turns);
    double v = copysign(sqrt(fabs(e) * (2.0 / PI)), e) * 0.5 + 0.5;
    double x = u * (double)width - 0.5, y = v * (double)height - 0.5;
    if (!isfinite(x) || !isfinite(y)) { xyz[0] = xyz[1] = xyz[2] = NAN; return; }
    double x0 = floor(x), y0 = floor(y), fx = x - x0, fy = y - y0;
    int64_t xi = (int64_t)x0, yi = (int64_t)y0;
    int64_t xa = sky_clamped_index(xi, width), xb = sky_clamped_index(xi + 1, width);
    int64_t ya = sky_clamped_index(yi, height) * width, yb = sky_clamped_index(yi + 1, height) * width;
    for (int c = 0; c < 3; c++) {
        double aa = table[3 * (ya + xa) + c], ab = table[3 * (ya + xb) + c];
        double ba = table[3 * (yb + xa) + c], bb = table[3 * (yb + xb) + c];
        double below = aa + fx * (ab - aa), above = ba + fx * (bb - ba);
        xyz[c] = below + fy * (above - below);
    }
}

/* sky.disc_xyz: the sun disc's XYZ along D added to xyz, where D is within its half angle and above the earth's edge:
 * bottom to top linear in elevation, times intensity and the limb darkening. */
INLINE void sky_add_disc(const double *f, const double *D, double *xyz)
{
    double elevation = f[SKY_AT_ELEVATION], rotation = f[SKY_AT_ROTATION], size = f[SKY_AT_SIZE];
    double e = 0.5 * PI - acos(sky_clamped_cos(D[2]));
    double sun[3] = {-cos(elevation) * sin(rotation), cos(elevation) * cos(rotation), sin(elevation)};
    double minus[3], plus[3];
    for (int c = 0; c < 3; c++) { minus[c] = D[c] - sun[c]; plus[c] = D[c] + sun[c]; }
    double angle = 2.0 * atan2(sqrt(dot3(minus, minus)), sqrt(dot3(plus, plus)));
    double half = 0.5 * size;
    if (!(angle < half && e > f[SKY_AT_HORIZON])) return;
    double y = (e - elevation) / size + 0.5, r = angle / half, under = 1.0 - r * r;
    double darkening = 1.0 - SKY_LIMB * (1.0 - sqrt(under > 0.0 ? under : 0.0));
    for (int c = 0; c < 3; c++)
        xyz[c] += ((1.0 - y) * f[SKY_AT_BOTTOM + c] + y * f[SKY_AT_TOP + c]) * (f[SKY_AT_INTENSITY] * darkening);
}

/* sky.perez: Perez' sky luminance distribution with Preetham's five coefficients lam. */
INLINE double sky_perez(const double *lam, double theta, double gamma)
{
    double c = cos(gamma);
    return (1.0 + lam[0] * exp(lam[1] / cos(theta))) * ((1.0 + lam[2] * exp(lam[3] * gamma)) + lam[4] * (c * c));
}

/* The analytic models' angles along D: the zenith angle theta (clamped just above the horizon afterwards) and gamma,
 * the angle to the sun at (phi, theta) n[0], n[1]. */
INLINE void sky_angles(const double *n, const double *D, double *theta, double *gamma)
{
    double t = acos(sky_clamped_cos(D[2])), phi = -atan2(D[1], D[0]) + 0.5 * PI;
    double cos_gamma = sin(n[1]) * sin(t) * cos(phi - n[0]) + cos(n[1]) * cos(t);
    *gamma = acos(sky_clamped_cos(cos_gamma));
    *theta = t < 0.5 * PI - 0.001 ? t : 0.5 * PI - 0.001;
}

/* sky.preetham_xyz: Preetham's xyY from Perez' function (numbers n: sun phi, theta, zenith Y x y, 3 x 5 lam), to
 * XYZ. */
INLINE void sky_preetham_xyz(const double *n, const double *D, double *xyz)
{
    double theta, gamma;
    sky_angles(n, D, &theta, &gamma);
    double Y = n[2] * sky_perez(n + 5, theta, gamma), x = n[3] * sky_perez(n + 10, theta, gamma);
    double y = n[4] * sky_perez(n + 15, theta, gamma);
    xyz[0] = y != 0.0 ? x / y * Y : 0.0;
    xyz[1] = Y;
    xyz[2] = y != 0.0 && Y != 0.0 ? (1.0 - x - y) / y * Y : 0.0;
}

/* sky.hosek_xyz: Hosek and Wilkie's nine-parameter function per channel (numbers n: sun phi, theta, the three
 * radiances, 3 x 9 parameters A .. I) times the channel's radiance. */
INLINE void sky_hosek_xyz(const double *n, const double *D, double *xyz)
{
    double theta, gamma;
    sky_angles(n, D, &theta, &gamma);
    double cos_theta = cos(theta), c = cos(gamma);
    for (int k = 0; k < 3; k++) {
        const double *p = n + 5 + 9 * k;
        double mie = (1.0 + c * c) / pow(1.0 + p[8] * p[8] - 2.0 * p[8] * c, 1.5);
        xyz[k] = n[2 + k] * (1.0 + p[0] * exp(p[1] / (cos_theta + 0.01)))
                 * ((((p[2] + p[3] * exp(p[4] * gamma)) + p[5] * c * c) + p[6] * mie) + p[7] * sqrt(cos_theta));
    }
}

/* The SKY op: the sky's scene-linear RGB along D (as it comes, not normalised) from its floats f: the model's XYZ
 * (the table's with the disc where the header draws one), plus the probe XYZ, by the header's matrix, negative
 * channels 0 (NaN kept, as numpy's maximum), Hosek / Wilkie's then scaled by 2 pi / 683. */
INLINE void sky_op(const double *f, const double *D, double *out)
{
    int kind = (int)f[SKY_AT_KIND];
    double xyz[3];
    if (kind == SKY_PREETHAM) sky_preetham_xyz(f + SKY_AT_PAYLOAD, D, xyz);
    else if (kind == SKY_HOSEK_WILKIE) sky_hosek_xyz(f + SKY_AT_PAYLOAD, D, xyz);
    else {
        sky_table_xyz(f, D, xyz);
        if (f[SKY_AT_SIZE] > 0.0) sky_add_disc(f, D, xyz);
    }
    for (int c = 0; c < 3; c++) xyz[c] += f[SKY_AT_PROBE + c];
    const double *M = f + SKY_AT_XYZ_TO_RGB;
    for (int c = 0; c < 3; c++) {
        double r = (xyz[0] * M[3 * c] + xyz[1] * M[3 * c + 1]) + xyz[2] * M[3 * c + 2];
        r = isnan(r) || r > 0.0 ? r : 0.0;
        out[c] = kind == SKY_HOSEK_WILKIE ? r * SKY_HOSEK_SCALE : r;
    }
}
