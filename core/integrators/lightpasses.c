/* Light passes: core/integrators/lightpasses.py. Each pass kind's share of a hit's closures' f cos at a
 * direction (a light sample's, or a BSDF-sampled ray's), which splits that direction's light between
 * Diffuse, Glossy and Transmission; and a stretch of a path through media, whose scattered light is Volume
 * (direct at a path's first scattering event, before any real bounce) or its surface bounce's kinds' (indirect). */

/* PASS_* and LIGHT_CHANNELS (the three kinds direct, then indirect, RGB each) come from lightpasses.py. */

/* lightpasses.closure_kinds for one closure c: its pass kind for light from wi towards wo (-1: none), by its closure
 * type; glass by the side of c's normal the light comes from. */
INLINE int pass_kind(const Closure *c, const double *wo, const double *wi)
{
    if (bsdf_is(c->kind, BSDF_FLAG_DIFFUSE_TYPE)) return PASS_DIFFUSE;
    if (bsdf_is(c->kind, BSDF_FLAG_GLOSSY_TYPE)) return PASS_GLOSSY;
    if (bsdf_is(c->kind, BSDF_FLAG_TRANSMISSION_TYPE)) return PASS_TRANSMISSION;
    if (bsdf_is(c->kind, BSDF_FLAG_GLASS_TYPE))
        return dot3(c->N, wo) * dot3(c->N, wi) > 0.0 ? PASS_GLOSSY : PASS_TRANSMISSION;
    return -1;
}

/* lightpasses.kind_shares for one hit: each pass kind's part of the closures' f cos at wi (shader_eval_sampled,
 * the same closures left out for `hidden`, the closure in slot `sampled` the one that sampled wi, -1: none) over
 * all kinds' parts, per channel; 0 where that sum is 0. */
INLINE void kind_shares(const ShaderResult *sd, const double *wo, const double *wi, int hidden, int sampled,
                        double shares[PASS_KINDS][3])
{
    double total[3] = {0.0, 0.0, 0.0};
    int kinds = 0;                      /* (bit p: some closure of kind p added to shares[p]) */
    for (int p = 0; p < PASS_KINDS; p++) shares[p][0] = shares[p][1] = shares[p][2] = 0.0;
    if (hidden == 0 && lambert_alone(sd)) {
        /* One Lambert on the hit's normal (bsdf.c lambert_alone): its kind's row as the loop below makes it, and the
         * one-kind rule's 1 or 0 where it applies (else the loop's way). */
        const Closure *c = sd->c;
        int p = pass_kind(c, wo, wi);
        if (p >= 0) {
            double value[3], pdf, row[3];
            lambert_eval(c, wo, wi, value, &pdf);
            for (int j = 0; j < 3; j++) row[j] = 0.0 + c->weight[j] * value[j];
            if (row[0] >= 0.0 && row[1] >= 0.0 && row[2] >= 0.0 && row[0] < INFINITY && row[1] < INFINITY
                && row[2] < INFINITY) {
                for (int j = 0; j < 3; j++) shares[p][j] = row[j] != 0.0 ? 1.0 : 0.0;
                return;
            }
        }
    }
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = sd->c + k;
        int p = pass_kind(c, wo, wi);
        if (p < 0 || closure_left_out(c->kind, hidden)) continue;
        double value[3], pdf;
        bsdf_eval(c, wo, wi, value, &pdf);
        double term = closure_shadowing(sd, c, wi, k != sampled);
        if (term != 1.0)
            for (int j = 0; j < 3; j++) value[j] *= term;
        for (int j = 0; j < 3; j++) shares[p][j] += c->weight[j] * value[j];
        kinds |= 1 << p;
    }
    if (kinds != 0 && (kinds & (kinds - 1)) == 0) {
        /* One kind alone (every hit of one Lambert closure): its row is the total, so x / x is 1 where x is finite and
         * above 0, and the other rows 0 / x are +0: the same numbers without the divisions (else: divided). */
        int p = 0;
        while (!(kinds & (1 << p))) p++;
        double *row = shares[p];
        if (row[0] >= 0.0 && row[1] >= 0.0 && row[2] >= 0.0 && row[0] < INFINITY && row[1] < INFINITY
            && row[2] < INFINITY) {
            for (int j = 0; j < 3; j++) row[j] = row[j] != 0.0 ? 1.0 : 0.0;
            return;
        }
    }
    for (int p = 0; p < PASS_KINDS; p++)
        for (int j = 0; j < 3; j++) total[j] += shares[p][j];
    for (int p = 0; p < PASS_KINDS; p++)
        for (int j = 0; j < 3; j++) shares[p][j] = total[j] != 0.0 ? shares[p][j] / total[j] : 0.0;
}

/* lightpasses.sample_shares for one BSDF-sampled ray s of a hit (transmit: it went through the surface):
 * kind_shares at its direction, a delta closure's own pass kind alone (glass by `transmit`), none for a
 * Transparent closure's ray. */
INLINE void sample_shares(const ShaderResult *sd, const double *wo, const ClosureSample *s, int transmit,
                          double shares[PASS_KINDS][3])
{
    if (!s->delta) {
        kind_shares(sd, wo, s->wi, 0, s->slot, shares);
        return;
    }
    for (int p = 0; p < PASS_KINDS; p++) shares[p][0] = shares[p][1] = shares[p][2] = 0.0;
    int p = -1;
    if (bsdf_is(s->kind, BSDF_FLAG_STRAIGHT)) p = -1;
    else if (bsdf_is(s->kind, BSDF_FLAG_DIFFUSE_TYPE)) p = PASS_DIFFUSE;
    else if (bsdf_is(s->kind, BSDF_FLAG_GLOSSY_TYPE)) p = PASS_GLOSSY;
    else if (bsdf_is(s->kind, BSDF_FLAG_TRANSMISSION_TYPE)) p = PASS_TRANSMISSION;
    else if (bsdf_is(s->kind, BSDF_FLAG_GLASS_TYPE)) p = transmit ? PASS_TRANSMISSION : PASS_GLOSSY;
    if (p >= 0) shares[p][0] = shares[p][1] = shares[p][2] = 1.0;
}

/* Add contribution value (RGB) shared out by `shares` (PASS_KINDS x 3, row by row) to parts[kind][channel]. */
INLINE void add_split(double parts[PASS_KINDS][3], const double *value, const double *shares)
{
    for (int p = 0; p < PASS_KINDS; p++)
        for (int j = 0; j < 3; j++) parts[p][j] += value[j] * shares[3 * p + j];
}

/* lightpasses.stretch_shares for one stretch of a path: the shares (PASS_KINDS x 3) of the light media scatter along
 * it and of what the path gathers after scattering there: volume where the path made no real bounce before the
 * stretch (bounces 0), else the path's own `shares` (PASS_KINDS x 3, row by row). */
INLINE void stretch_shares(int bounces, const double *shares, double out[PASS_KINDS][3])
{
    for (int p = 0; p < PASS_KINDS; p++)
        for (int c = 0; c < 3; c++)
            out[p][c] = bounces == 0 ? (p == PASS_VOLUME ? 1.0 : 0.0) : shares[3 * p + c];
}

/* lightpasses.add_scattered for one stretch: the light value (3, throughput included) its media scattered into a
 * camera lane's light passes out (LIGHT_CHANNELS): direct where the path made no real bounce before the stretch
 * (bounces 0) and the light was gathered at its first scattering event (at_first_event), else indirect, split by
 * the stretch's shares (stretch_shares). */
INLINE void add_scattered(double *out, const double *value, int bounces, double shares[PASS_KINDS][3],
                          int at_first_event)
{
    int base = bounces == 0 && at_first_event ? 0 : PASS_KINDS;
    for (int p = 0; p < PASS_KINDS; p++)
        for (int c = 0; c < 3; c++) out[3 * (base + p) + c] += value[c] * shares[p][c];
}
