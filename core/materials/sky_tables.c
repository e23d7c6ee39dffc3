/* The scattering skies' XYZ tables: core/materials/sky.py multiple_scattering_xyz (with the atmosphere's transmittance
 * table it reads, Atmosphere.precompute) and single_scattering_xyz, the same arithmetic in the same order, in double.
 * Python runs each step over every direction at once; here each direction runs its steps. The models' scalars are
 * the SKY_MS_* and SKY_SS_* constants, their per-wavelength arrays come in the arguments (sky.py's MS_*, SS_*). */

static double sky_max0(double a) { return a < 0.0 ? 0.0 : a; }                     /* np.maximum(a, 0.0) */

static double sky_clip(double a, double lo, double hi) { return a < lo ? lo : a > hi ? hi : a; }    /* np.clip */

/* np.linalg.norm of a 3-vector (numpy adds x0^2 + x1^2 first). */
static double sky_norm3(const double *x) { return sqrt((x[0] * x[0] + x[1] * x[1]) + x[2] * x[2]); }

static double sky_dot3(const double *a, const double *b) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }

/* sky.ray_sphere: the distance along unit d from o to the sphere of `radius` about the origin, the near root when
 * outside, the far when inside; -1 where the ray misses or leaves it. */
static double sky_ray_sphere(const double *o, const double *d, double radius)
{
    double b = sky_dot3(o, d), c = sky_dot3(o, o) - radius * radius;
    double disc = b * b - c, root = sqrt(sky_max0(disc));
    double t = disc >= b * b ? -b + root : -b - root;
    return ((c > 0.0 && b > 0.0) || disc < 0.0) ? -1.0 : t;
}

/* np.interp(x, xp, ...)'s place of x among n increasing nodes xp: j with xp[j] <= x < xp[j + 1]; -1 below xp[0]
 * (or NaN: -2), n - 1 at or above xp[n - 1]. */
static int64_t sky_interp_at(double x, const double *xp, int64_t n)
{
    if (isnan(x)) return -2;
    if (x < xp[0]) return -1;
    if (x >= xp[n - 1]) return n - 1;
    int64_t lo = 0, hi = n - 1;                         /* xp[lo] <= x < xp[hi] */
    while (hi - lo > 1) {
        int64_t mid = (lo + hi) / 2;
        if (xp[mid] <= x) lo = mid; else hi = mid;
    }
    return lo;
}

/* np.interp(x, xp, fp) with x at place j (sky_interp_at), fp read every `stride` doubles: fp's ends outside,
 * linear between. */
static double sky_interp(double x, int64_t j, const double *xp, const double *fp, int64_t n, int64_t stride)
{
    if (j == -2) return x;
    if (j == -1) return fp[0];
    if (j == n - 1) return fp[(n - 1) * stride];
    double a = fp[j * stride], b = fp[(j + 1) * stride];
    if (xp[j] == x) return a;
    double slope = (b - a) / (xp[j + 1] - xp[j]);
    double y = slope * (x - xp[j]) + a;
    if (isnan(y)) {
        y = slope * (x - xp[j + 1]) + b;
        if (isnan(y) && a == b) y = a;
    }
    return y;
}

/* np.linspace(start, stop, n): node i, the last exactly `stop`. */
static double sky_linspace(double start, double stop, int64_t n, int64_t i)
{
    return i == n - 1 ? stop : (double)i * ((stop - start) / (double)(n - 1)) + start;
}

/* --- Multiple scattering ------------------------------------------------------------------------------------------ */

/* The multiple-scattering sky's atmosphere: its densities, the per-wavelength arrays, its transmittance table. */
typedef struct {
    const SkyMultipleArgs *a;
    const double *table;                                /* (ROWS, COLUMNS, 4) */
    double ground[SKY_MS_TRANSMITTANCE_COLUMNS];        /* at_ground's nodes: linspace(-1, 1, COLUMNS) */
    double zenith[SKY_MS_TRANSMITTANCE_ROWS];           /* to_zenith's: linspace(0, 1, ROWS) */
    double from_ground[SKY_MS_WAVELENGTHS];              /* to_zenith at the ground */
} SkyAtmosphere;

/* Atmosphere.extinction: molecular scattering, aerosol scattering and total extinction (4 each) at altitude h km. */
static void sky_ms_extinction(const SkyMultipleArgs *a, double h, double *molecular, double *aerosol_scattering,
                              double *total)
{
    double aerosol = a->aerosol * SKY_MS_AEROSOL_BASE * (exp(-h / SKY_MS_AEROSOL_HEIGHT)
                                                         + SKY_MS_AEROSOL_BACKGROUND / SKY_MS_AEROSOL_BASE);
    double log_h = log(h < 1e-4 ? 1e-4 : h), centred = log_h - 3.22261;
    double ozone = a->ozone * 3.78547397e20 * exp(-(centred * centred) * 5.55555555 - log_h);
    double falloff = exp(-0.07771971 * pow(h, 1.16364243));
    for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) {
        molecular[k] = a->air * a->molecular[k] * falloff;
        aerosol_scattering[k] = a->aerosol_scattering[k] * aerosol;
        total[k] = ((molecular[k] + aerosol_scattering[k]) + a->aerosol_absorption[k] * aerosol)
                   + a->ozone_cross_section[k] * ozone;
    }
}

/* Atmosphere.transmittance: from normalised altitude `altitude` to the top of the atmosphere towards cos(zenith) c,
 * 64 midpoint steps of the extinction. */
static void sky_ms_transmittance(const SkyMultipleArgs *a, double c, double altitude, double *out)
{
    double s = sqrt(sky_max0(1.0 - c * c));
    double D[3] = {-s, 0.0, c}, O[3] = {0.0, 0.0, SKY_MS_EARTH + altitude * SKY_MS_THICKNESS};
    double dt = sky_ray_sphere(O, D, SKY_MS_TOP) / SKY_MS_STEPS;
    double depth[SKY_MS_WAVELENGTHS] = {0.0}, molecular[SKY_MS_WAVELENGTHS], aerosol[SKY_MS_WAVELENGTHS];
    double total[SKY_MS_WAVELENGTHS];
    for (int step = 0; step < SKY_MS_STEPS; step++) {
        double t = ((double)step + 0.5) * dt, x[3];
        for (int i = 0; i < 3; i++) x[i] = O[i] + D[i] * t;
        sky_ms_extinction(a, sky_max0(sky_norm3(x) - SKY_MS_EARTH), molecular, aerosol, total);
        for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) depth[k] += total[k] * dt;
    }
    for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) out[k] = exp(-depth[k]);
}

/* Atmosphere.precompute: the table at its nodes, cos(zenith) 2 x / (COLUMNS - 1) - 1, altitude y / (ROWS - 1). */
static void sky_ms_transmittance_table(const SkyMultipleArgs *a, double *table)
{
    for (int64_t y = 0; y < SKY_MS_TRANSMITTANCE_ROWS; y++)
        for (int64_t x = 0; x < SKY_MS_TRANSMITTANCE_COLUMNS; x++) {
            double u = (double)x / (double)(SKY_MS_TRANSMITTANCE_COLUMNS - 1);
            double v = (double)y / (double)(SKY_MS_TRANSMITTANCE_ROWS - 1);
            sky_ms_transmittance(a, u * 2.0 - 1.0, v,
                                 table + (y * SKY_MS_TRANSMITTANCE_COLUMNS + x) * SKY_MS_WAVELENGTHS);
        }
}

/* Atmosphere.lookup: the table bilinear between its nodes, both coordinates clamped to [0, 1]. */
static void sky_ms_lookup(const SkyAtmosphere *m, double c, double altitude, double *out)
{
    const int64_t rows = SKY_MS_TRANSMITTANCE_ROWS, columns = SKY_MS_TRANSMITTANCE_COLUMNS;
    double x = (double)(columns - 1) * sky_clip(c * 0.5 + 0.5, 0.0, 1.0);
    double y = (double)(rows - 1) * sky_clip(altitude, 0.0, 1.0);
    int64_t x1 = (int64_t)x, y1 = (int64_t)y;
    int64_t x2 = x1 + 1 < columns - 1 ? x1 + 1 : columns - 1, y2 = y1 + 1 < rows - 1 ? y1 + 1 : rows - 1;
    double fx = x - (double)x1, fy = y - (double)y1;
    const double *t = m->table;
    for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) {
        double a11 = t[(y1 * columns + x1) * SKY_MS_WAVELENGTHS + k], a12 = t[(y1 * columns + x2) * SKY_MS_WAVELENGTHS + k];
        double a21 = t[(y2 * columns + x1) * SKY_MS_WAVELENGTHS + k], a22 = t[(y2 * columns + x2) * SKY_MS_WAVELENGTHS + k];
        double bottom = a11 + fx * (a12 - a11), top = a21 + fx * (a22 - a21);
        out[k] = bottom + fy * (top - bottom);
    }
}

/* Atmosphere.multiple: the light scattered towards a point many times (the fit), plus the ground's scattered once. */
static void sky_ms_multiple(const SkyAtmosphere *m, double c, double altitude, double distance, double *out)
{
    const int64_t rows = SKY_MS_TRANSMITTANCE_ROWS, columns = SKY_MS_TRANSMITTANCE_COLUMNS;
    double ratio = SKY_MS_EARTH / distance;
    double omega = 2.0 * PI * (1.0 - sqrt(sky_max0(1.0 - ratio * ratio)));
    double g = omega / (4.0 * PI) * (SKY_MS_GROUND_ALBEDO / PI) * c;
    double fit = 1.0 / (1.0 + 5.0 * exp(-17.92 * c));
    double cc = sky_clip(c, -1.0, 1.0), h = sky_clip(altitude, 0.0, 1.0);
    const double *last = m->table + (columns - 1) * SKY_MS_WAVELENGTHS;      /* the last column, its rows apart */
    int64_t j_ground = sky_interp_at(cc, m->ground, columns), j_point = sky_interp_at(h, m->zenith, rows);
    for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) {
        double at_ground = sky_interp(cc, j_ground, m->ground, m->table + k, columns, SKY_MS_WAVELENGTHS);
        double to_point = sky_interp(h, j_point, m->zenith, last + k, rows, columns * SKY_MS_WAVELENGTHS);
        out[k] = m->a->multiple[k] * fit + g * at_ground * (m->from_ground[k] / to_point);
    }
}

/* Atmosphere.inscattering: the light scattered towards `origin` along unit D of `length` km, 64 steps, each
 * integrated analytically over its extinction. */
static void sky_ms_inscattering(const SkyAtmosphere *m, const double *sun, const double *origin, const double *D,
                                double length, double *light)
{
    const SkyMultipleArgs *a = m->a;
    double cos_theta = -sky_dot3(D, sun);
    double molecular_phase = (3.0 / 16.0 / PI) * (1.0 + cos_theta * cos_theta);
    double den = 1.0 + SKY_MS_G * SKY_MS_G + 2.0 * SKY_MS_G * cos_theta;
    double aerosol_phase = (1.0 - SKY_MS_G * SKY_MS_G) / (4.0 * PI) / (den * sqrt(den));
    double dt = length / SKY_MS_STEPS, transmitted[SKY_MS_WAVELENGTHS];
    for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) { light[k] = 0.0; transmitted[k] = 1.0; }
    for (int step = 0; step < SKY_MS_STEPS; step++) {
        double t = ((double)step + 0.5) * dt, x[3];
        for (int i = 0; i < 3; i++) x[i] = origin[i] + D[i] * t;
        double r = sky_norm3(x), h = sky_max0(r - SKY_MS_EARTH), altitude = h / SKY_MS_THICKNESS;
        double cos_sun = sky_dot3(x, sun) / r;
        double molecular[SKY_MS_WAVELENGTHS], aerosol[SKY_MS_WAVELENGTHS], total[SKY_MS_WAVELENGTHS];
        double to_sun[SKY_MS_WAVELENGTHS], multiple[SKY_MS_WAVELENGTHS];
        sky_ms_extinction(a, h, molecular, aerosol, total);
        sky_ms_lookup(m, cos_sun, altitude, to_sun);
        sky_ms_multiple(m, cos_sun, altitude, r, multiple);
        for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) {
            double S = a->sun[k] * (molecular[k] * (molecular_phase * to_sun[k] + multiple[k])
                                    + aerosol[k] * (aerosol_phase * to_sun[k] + multiple[k]));
            double through = exp(-dt * total[k]);
            light[k] += transmitted[k] * (S - S * through) / (total[k] < 1e-7 ? 1e-7 : total[k]);
            transmitted[k] *= through;
        }
    }
}

/* sky.multiple_scattering_xyz: the table's XYZ (height, 2 (width / 2), 3) of the left half's directions, each
 * ray to the ground or the top of the atmosphere, mirrored; the transmittance table written on the way. */
static void sky_multiple_scattering_table(const SkyMultipleArgs *a)
{
    SkyAtmosphere m = {a, a->transmittance, {0.0}, {0.0}, {0.0}};
    sky_ms_transmittance_table(a, a->transmittance);
    for (int64_t i = 0; i < SKY_MS_TRANSMITTANCE_COLUMNS; i++)
        m.ground[i] = sky_linspace(-1.0, 1.0, SKY_MS_TRANSMITTANCE_COLUMNS, i);
    for (int64_t i = 0; i < SKY_MS_TRANSMITTANCE_ROWS; i++)
        m.zenith[i] = sky_linspace(0.0, 1.0, SKY_MS_TRANSMITTANCE_ROWS, i);
    const int64_t last = (SKY_MS_TRANSMITTANCE_COLUMNS - 1) * SKY_MS_WAVELENGTHS;
    const int64_t stride = SKY_MS_TRANSMITTANCE_COLUMNS * SKY_MS_WAVELENGTHS;
    int64_t j_ground = sky_interp_at(0.0, m.zenith, SKY_MS_TRANSMITTANCE_ROWS);
    for (int k = 0; k < SKY_MS_WAVELENGTHS; k++)
        m.from_ground[k] = sky_interp(0.0, j_ground, m.zenith, m.table + last + k, SKY_MS_TRANSMITTANCE_ROWS, stride);
    double clamped = a->altitude < 1.0 ? 1.0 : a->altitude;
    clamped = clamped > 99999.0 ? 99999.0 : clamped;
    double observer[3] = {0.0, 0.0, SKY_MS_EARTH + clamped / 1000.0};
    double cos_sun = cos(0.5 * PI - a->elevation);
    double sun[3] = {-sqrt(sky_max0(1.0 - cos_sun * cos_sun)), 0.0, cos_sun};
    int64_t width = a->width, height = a->height, half = width / 2;
    for (int64_t y = 0; y < height; y++)
        for (int64_t x = 0; x < half; x++) {
            double azimuth = 2.0 * PI * ((double)x + 0.5) / (double)width;
            double l = ((double)y + 0.5) / (double)height * 2.0 - 1.0;
            double e = copysign(l * l, l) * (0.5 * PI);
            double D[3] = {cos(e) * cos(azimuth), cos(e) * sin(azimuth), sin(e)};
            double ground = sky_ray_sphere(observer, D, SKY_MS_EARTH);
            double length = ground < 0.0 ? sky_ray_sphere(observer, D, SKY_MS_TOP) : ground;
            double light[SKY_MS_WAVELENGTHS];
            sky_ms_inscattering(&m, sun, observer, D, length, light);
            double *left = a->xyz + (y * 2 * half + x) * 3, *right = a->xyz + (y * 2 * half + 2 * half - 1 - x) * 3;
            for (int c = 0; c < 3; c++) {
                double sum = 0.0;
                for (int k = 0; k < SKY_MS_WAVELENGTHS; k++) sum += light[k] * a->to_xyz[k * 3 + c];
                left[c] = right[c] = sum;
            }
        }
}

/* --- Single scattering -------------------------------------------------------------------------------------------- */

/* sky.ss_density: Rayleigh, Mie and ozone densities at height h m above sea level. */
static void sky_ss_density(double h, double *out)
{
    out[0] = exp(-h / SKY_SS_RAYLEIGH_HEIGHT);
    out[1] = exp(-h / SKY_SS_MIE_HEIGHT);
    out[2] = sky_max0(1.0 - fabs(h - 25000.0) / 15000.0);
}

/* sky.ss_top_distance: the distance from P along unit D to the top of the atmosphere (the far root). */
static double sky_ss_top_distance(const double *P, const double *D)
{
    double b = 2.0 * sky_dot3(D, P), c = sky_dot3(P, P) - SKY_SS_TOP * SKY_SS_TOP;
    return 0.5 * (-b + sqrt(b * b - 4.0 * c));
}

/* sky.ss_optical_depth: the Rayleigh, Mie and ozone optical depths from P along D to the top, 8 quadrature nodes. */
static void sky_ss_optical_depth(const SkySingleArgs *a, const double *P, const double *D, double *depth)
{
    double length = sky_ss_top_distance(P, D);
    depth[0] = depth[1] = depth[2] = 0.0;
    for (int n = 0; n < SKY_SS_NODES; n++) {
        double t = a->nodes[n] * length, q[3], density[3];
        for (int i = 0; i < 3; i++) q[i] = P[i] + t * D[i];
        sky_ss_density(sky_norm3(q) - SKY_SS_EARTH, density);
        for (int j = 0; j < 3; j++) depth[j] += density[j] * a->weights[n];
    }
    for (int j = 0; j < 3; j++) depth[j] *= length;
}

/* sky.single_scattering_xyz: the upper half's left half of directions, 32 segments each to the top of the atmosphere
 * adding the sunlight each scatters towards the observer, mirrored; the lower half the horizon row, faded. */
static void sky_single_scattering_table(const SkySingleArgs *a)
{
    enum { W = SKY_SS_WAVELENGTHS };
    double clamped = a->altitude < 1.0 ? 1.0 : a->altitude;
    clamped = clamped > 59999.0 ? 59999.0 : clamped;
    double observer[3] = {0.0, 0.0, SKY_SS_EARTH + clamped};
    double sun[3] = {cos(a->elevation), 0.0, sin(a->elevation)};
    double scale[3] = {a->air, a->aerosol, a->ozone};
    double mie_extinction = 1.11 * SKY_SS_MIE, g2 = SKY_SS_G * SKY_SS_G;
    int64_t width = a->width, height = a->height, half_w = width / 2, half_h = height / 2, row = 2 * half_w;
    for (int64_t y = half_h; y < height; y++)
        for (int64_t x = 0; x < half_w; x++) {
            double rise = (double)y / (double)half_h - 1.0;
            double latitude = 0.5 * PI * (rise * rise);
            double longitude = 2.0 * PI / (double)width * (double)x - PI;
            double D[3] = {cos(latitude) * cos(longitude), cos(latitude) * sin(longitude), sin(latitude)};
            double segment = sky_ss_top_distance(observer, D) / SKY_SS_STEPS;
            double mu = sky_dot3(D, sun);
            double phase[2] = {0.1875 / PI * (1.0 + mu * mu),
                               3.0 * (1.0 - g2) * (1.0 + mu * mu)
                               / (8.0 * PI * (2.0 + g2) * pow(1.0 + g2 - 2.0 * SKY_SS_G * mu, 1.5))};
            double depth[3] = {0.0, 0.0, 0.0}, spectrum[W] = {0.0}, P[3];
            for (int i = 0; i < 3; i++) P[i] = observer[i] + 0.5 * segment * D[i];
            for (int step = 0; step < SKY_SS_STEPS; step++) {
                double density[3], to_sun[3], total[3];
                sky_ss_density(sky_norm3(P) - SKY_SS_EARTH, density);
                for (int j = 0; j < 3; j++) {
                    density[j] = scale[j] * density[j];
                    depth[j] += segment * density[j];
                }
                double b = 2.0 * sky_dot3(P, sun);
                int lit = !(sun[2] < 0.0 && b * b - 4.0 * (sky_dot3(P, P) - SKY_SS_EARTH * SKY_SS_EARTH) >= 0.0);
                sky_ss_optical_depth(a, P, sun, to_sun);
                for (int j = 0; j < 3; j++) total[j] = depth[j] + scale[j] * to_sun[j];
                double rayleigh = phase[0] * density[0], mie = phase[1] * density[1];
                for (int w = 0; w < W; w++) {
                    double attenuation = exp(-((total[0] * a->rayleigh[w] + total[1] * mie_extinction)
                                               + total[2] * a->ozone_cross_section[w]));
                    double scattered = rayleigh * a->rayleigh[w] + mie * SKY_SS_MIE;
                    spectrum[w] += (lit ? attenuation * scattered : 0.0) * a->irradiance[w] * segment;
                }
                for (int i = 0; i < 3; i++) P[i] = P[i] + segment * D[i];
            }
            double *left = a->xyz + (y * row + x) * 3, *right = a->xyz + (y * row + row - 1 - x) * 3;
            for (int c = 0; c < 3; c++) {
                double sum = 0.0;
                for (int w = 0; w < W; w++) sum += spectrum[w] * a->cmf[w * 3 + c];
                left[c] = right[c] = sum * SKY_SS_STEP_LAMBDA;
            }
        }
    const double *horizon = a->xyz + half_h * row * 3;
    for (int64_t y = 0; y < half_h; y++) {
        double fall = (double)y / (double)half_h - 1.0;
        double z = sin(0.5 * PI * (fall * fall));
        double fade = z < 0.4 ? pow(1.0 - 2.5 * z, 3.0) : 0.0;
        for (int64_t i = 0; i < row * 3; i++) a->xyz[y * row * 3 + i] = horizon[i] * fade;
    }
}
