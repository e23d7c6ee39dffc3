/* Null scattering: ratio tracking (transmittance) and weighted delta tracking (free flight) over per-piece
 * majorants, the twin of core/volumes/tracking.py (see its docstring for the estimators). Its density is a table
 * (tracking.py's table_density); the integrators use field.c's residual ratio tracking on the march instead (issue 35). */

/* A tabulated density along a ray: `count` values over [0, length], nodes interpolated linearly or constant cells. */
typedef struct {
    const double *values;
    int64_t count;
    int64_t linear;
    double length;
} TrackingTable;

/* sigma_t at distance s of a table (tracking.py's table_density). */
static double tracking_density(const TrackingTable *table, double s)
{
    double f = s / table->length;
    if (table->linear) {
        double x = (f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f) * (double)(table->count - 1);
        int64_t k = (int64_t)x;
        if (k > table->count - 2) k = table->count - 2;
        return table->values[k] + (table->values[k + 1] - table->values[k]) * (x - (double)k);
    }
    int64_t k = (int64_t)(f * (double)table->count);
    if (k < 0) k = 0;
    if (k > table->count - 1) k = table->count - 1;
    return table->values[k];
}

/* A uniform number in [0, 1) from a splitmix64 stream (the rows' own stream, not the renderer's sequences). */
static double tracking_uniform(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

/* The next tentative collision of a walk at s in piece *piece: advances s (and *piece past pieces it leaves);
 * returns 1 with the piece's majorant in *mu where it lands inside a piece, 0 where the walk leaves the last piece. */
static int tracking_step(const double *edges, const double *mu_bar, int64_t pieces, int64_t *piece, double *s,
                         double *mu, uint64_t *state)
{
    while (*piece < pieces) {
        double m = mu_bar[*piece];
        double step = m > 0.0 ? -log1p(-tracking_uniform(state)) / m : INFINITY;
        double end = edges[*piece + 1];
        if (*s + step >= end) {           /* memoryless: restart at the next piece's start */
            *s = end;
            *piece += 1;
            continue;
        }
        *s += step;
        *mu = m;
        return 1;
    }
    return 0;
}

/* One ratio-tracking estimate of exp(-integral sigma_t) over [edges[0], edges[pieces]]. */
static double ratio_tracking(const TrackingTable *table, const double *edges, const double *mu_bar, int64_t pieces,
                             uint64_t *state)
{
    double T_hat = 1.0, s = edges[0], mu = 0.0;
    int64_t piece = 0;
    while (tracking_step(edges, mu_bar, pieces, &piece, &s, &mu, state))
        T_hat *= 1.0 - tracking_density(table, s) / mu;
    return T_hat;
}

/* One weighted delta-tracking free flight: returns the real collision's distance (INFINITY: none), its weight in *w. */
static double delta_tracking(const TrackingTable *table, const double *edges, const double *mu_bar, int64_t pieces,
                             uint64_t *state, double *w)
{
    double s = edges[0], mu = 0.0;
    int64_t piece = 0;
    *w = 1.0;
    while (tracking_step(edges, mu_bar, pieces, &piece, &s, &mu, state)) {
        double sigma = tracking_density(table, s);
        int bounded = sigma <= mu;
        double q = bounded ? sigma / mu : sigma / (2.0 * sigma - mu);
        int real = tracking_uniform(state) < q;
        if (!bounded) *w *= (real ? 1.0 : -1.0) * (2.0 * sigma - mu) / mu;
        if (real) return s;
    }
    return INFINITY;
}

static void tracking_rows(const TrackingRowsArgs *a)
{
    TrackingTable table = {a->values, a->count, a->linear, a->length};
    for (int64_t i = 0; i < a->n; i++) {
        /* each row's stream starts at a hashed state (consecutive splitmix states would overlap rows' streams) */
        uint64_t state = ((uint64_t)a->seed << 32) ^ (uint64_t)i;
        tracking_uniform(&state);
        state = (state ^ (state >> 31)) * 0xD6E8FEB86659FD93ull;
        state ^= state >> 32;
        state *= 0xD6E8FEB86659FD93ull;
        a->transmittance[i] = ratio_tracking(&table, a->edges, a->mu_bar, a->pieces, &state);
        a->distance[i] = delta_tracking(&table, a->edges, a->mu_bar, a->pieces, &state, &a->weight[i]);
    }
}
