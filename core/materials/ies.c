/* IES light profiles: core/materials/ies.py's evaluation (Cycles' kernel_ies_interp and svm_node_ies). A profile's
 * table holds its h angles, its v angles (radians, ascending), then its intensity by h then v (ies.table). Lamps
 * (core/lights/ies.c) and the IES Texture op of the node graphs (converters/ies_texture.c) evaluate profiles here. */

/* Cycles' cubic_interp: the Catmull-Rom cubic through b (x = 0) and c (x = 1), with neighbours a and d. */
static inline double ies_cubic(double a, double b, double c, double d, double x)
{
    return 0.5 * (((d + 3.0 * (b - c) - a) * x + (2.0 * a - 5.0 * b + 4.0 * c - d)) * x + (c - a)) * x + b;
}

/* interpolate_ies_vertical: column h of the intensity I (v_num per column) along v at v_i + v_frac; a neighbour
 * outside repeats the one across the pole where the table reaches it, else the nearest inner value. */
static inline double ies_column(const double *I, int h, int v_i, int v_num, double v_frac, int wrap_vlow,
                                int wrap_vhigh)
{
    const double *col = I + (int64_t)h * v_num;
    double b = col[v_i], c = col[v_i + 1];
    double a = v_i > 0 ? col[v_i - 1] : (wrap_vlow ? col[1] : b);
    double d = v_i + 2 < v_num ? col[v_i + 2] : (wrap_vhigh ? col[v_num - 2] : c);
    return ies_cubic(a, b, c, d, v_frac);
}

/* ies.evaluate: the profile `table` (h_num, v_num) at angles h, v (radians); 0 outside the table. */
NOINLINE static double ies_evaluate(const double *table, int h_num, int v_num, double h, double v)
{
    if (h_num < 2 || v_num < 2) return 0.0;
    const double *H = table, *V = table + h_num, *I = table + h_num + v_num;
    if (!((v >= V[0]) & (v < V[v_num - 1]) & (h >= H[0]) & (h < H[h_num - 1]))) return 0.0;
    /* Cycles' wrap flags in its 32-bit floats (ies.wraps): 2 pi - 1e-7 and pi - 1e-7 round back to 2 pi and pi. */
    const float tiny = 1e-7f, two_pi = (float)(2.0 * PI), pi = (float)PI;
    int wrap_h = ((float)H[0] < tiny) & ((float)H[h_num - 1] > two_pi - tiny);
    int wrap_vlow = (float)V[0] < tiny, wrap_vhigh = (float)V[v_num - 1] > pi - tiny;
    int h_i = 0, v_i = 0;
    while (H[h_i + 1] < h) h_i++;
    while (V[v_i + 1] < v) v_i++;
    double h_frac = (h - H[h_i]) / (H[h_i + 1] - H[h_i]);
    double v_frac = (v - V[v_i]) / (V[v_i + 1] - V[v_i]);
    double b = ies_column(I, h_i, v_i, v_num, v_frac, wrap_vlow, wrap_vhigh);
    double c = ies_column(I, h_i + 1, v_i, v_num, v_frac, wrap_vlow, wrap_vhigh);
    double a = h_i > 0 ? ies_column(I, h_i - 1, v_i, v_num, v_frac, wrap_vlow, wrap_vhigh)
                       : (wrap_h ? ies_column(I, h_num - 2, v_i, v_num, v_frac, wrap_vlow, wrap_vhigh) : b);
    double d = h_i + 2 < h_num ? ies_column(I, h_i + 2, v_i, v_num, v_frac, wrap_vlow, wrap_vhigh)
                               : (wrap_h ? ies_column(I, 1, v_i, v_num, v_frac, wrap_vlow, wrap_vhigh) : b);
    return at_least(ies_cubic(a, b, c, d, h_frac), 0.0);
}

/* ies.ies_fac for one Vector: strength x the profile at v = acos(-z), h = atan2(x, y) + pi of the unit vector. */
NOINLINE static double ies_fac(const double *table, int h_num, int v_num, double strength, const double *vector)
{
    double length = sqrt(dot3(vector, vector));
    double inverse = length > 0.0 ? 1.0 / length : 1.0;
    double z = -vector[2] * inverse;
    double v = acos(z < -1.0 ? -1.0 : (z > 1.0 ? 1.0 : z));
    double h = atan2(vector[0] * inverse, vector[1] * inverse) + PI;
    return strength * ies_evaluate(table, h_num, v_num, h, v);
}

/* ies.ies_fac over arrays (for the tests): vectors (n, 3) -> fac (n,) float64. */
static void ies_fac_rows(const IESFacArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) a->fac[i] = ies_fac(a->table, a->h_num, a->v_num, a->strength, a->vectors + 3 * i);
}
