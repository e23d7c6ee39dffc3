/* Phase functions: core/volumes/phase.py. Henyey and Greenstein's, which media scatter with (integrators/volume.c)
   and subsurface walks step with (integrators/subsurface.c), and the Phase menu's others (Fournier-Forand, Draine,
   Rayleigh, Mie): a medium's Phase (a kind PHASE_... and PHASE_PARAMETERS numbers), evaluated by phase_eval and
   sampled by phase_sample. */

/* A stretch's phase function (phase.Phases' row): its kind, its numbers (phase.Phase.parameters; HG's first is g). */
typedef struct {
    int64_t kind;
    double p[PHASE_PARAMETERS];
    /* lobes 0: that one phase function; else a heterogeneous medium's point mixes `lobes` of them (phase.PhaseMix:
     * each closure's kind, numbers and weight, its sigma_s summed over channels), as Cycles keeps its closures */
    int64_t lobes;
    int64_t kinds[PHASE_LOBES];
    double lobe[PHASE_LOBES][PHASE_PARAMETERS];
    double weight[PHASE_LOBES];
} Phase;

/* phase.henyey_greenstein: (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5). */
INLINE double henyey_greenstein(double cos_theta, double g)
{
    double denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(denom));
}

/* phase.around: wi (3) at cos theta from -wo (3), at azimuth 2 pi u1 about it. */
INLINE void phase_direction(const double *wo, double cos_theta, double u1, double *wi)
{
    cos_theta = cos_theta < -1.0 ? -1.0 : (cos_theta > 1.0 ? 1.0 : cos_theta);
    double sin_theta = sqrt(at_least(1.0 - cos_theta * cos_theta, 0.0)), phi = 2.0 * PI * u1;
    double axis[3] = {-wo[0], -wo[1], -wo[2]}, T[3], B[3];
    orthonormal_frame(axis, T, B);
    double a = sin_theta * cos(phi), b = sin_theta * sin(phi);
    for (int c = 0; c < 3; c++) wi[c] = (a * T[c] + b * B[c]) + cos_theta * axis[c];
}

/* HenyeyGreenstein.sample_cos: the cdf's inverse (uniform where |g| < 1e-3). */
INLINE double hg_sample_cos(double g, double u0)
{
    double cos_theta;
    if (fabs(g) < 1e-3) cos_theta = 1.0 - 2.0 * u0;
    else {
        double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u0);
        cos_theta = (1.0 + g * g - s * s) / (2.0 * g);
    }
    return cos_theta < -1.0 ? -1.0 : (cos_theta > 1.0 ? 1.0 : cos_theta);
}

/* HenyeyGreenstein.sample: a direction wi (3) for a viewer along wo (3) from numbers u (2), its pdf returned. */
INLINE double sample_henyey_greenstein(const double *wo, double g, const double *u, double *wi)
{
    double cos_theta = hg_sample_cos(g, u[0]);
    phase_direction(wo, cos_theta, u[1], wi);
    return henyey_greenstein(cos_theta, g);
}

/* HenyeyGreenstein.eval_cos: 1 / 4 pi where |g| < 1e-3 (Cycles' phase_henyey_greenstein). */
static double hg_eval(double cos_theta, double g)
{
    return fabs(g) < 1e-3 ? 0.25 / PI : henyey_greenstein(cos_theta, g);
}

/* phase.rayleigh: 3 (1 + cos^2 theta) / (16 pi). */
static double rayleigh_eval(double cos_theta)
{
    return (0.1875 / PI) * (1.0 + cos_theta * cos_theta);
}

/* Rayleigh.sample_cos: a = 2 - 4 u0, x = -(sqrt(1 + a^2) + a)^(-1/3), cos theta = 1/x - x. */
static double rayleigh_sample_cos(double u0)
{
    double a = 2.0 - 4.0 * u0, inv_u = -1.0 / cbrt(sqrt(1.0 + a * a) + a);
    return 1.0 / inv_u - inv_u;
}

/* Draine.eval_cos: Rayleigh where |g| < 1e-3 and alpha > 0.999, HG where |alpha| < 1e-3. */
static double draine_eval(double cos_theta, double g, double a)
{
    if (fabs(g) < 1e-3 && a > 0.999) return rayleigh_eval(cos_theta);
    if (fabs(a) < 1e-3) return hg_eval(cos_theta, g);
    double fac = 1.0 + g * g - 2.0 * g * cos_theta;
    return ((1.0 - g * g) * (1.0 + a * cos_theta * cos_theta))
           / ((1.0 + a * (1.0 + 2.0 * g * g) / 3.0) * 4.0 * PI * fac * sqrt(fac));
}

/* Draine.sample_cos: the cdf's closed-form inverse (phase.draine_sample_cos; the cube-root form where |g| < 1e-2),
 * Rayleigh's and HG's in their special cases. */
static double draine_sample_cos(double g, double a, double u0)
{
    if (fabs(g) < 1e-3 && a > 0.999) return rayleigh_sample_cos(u0);
    if (fabs(a) < 1e-3) return hg_sample_cos(g, u0);
    if (fabs(g) < 1e-2) {
        double ia = 1.0 / a, b2 = (3.0 + a) * ia * (0.5 - u0);
        double inv_u = -1.0 / cbrt(b2 + sqrt(b2 * b2 + ia * ia * ia));
        return 1.0 / inv_u - inv_u / a;
    }
    double g2 = g * g, g3 = g * g2, g4 = g2 * g2, g6 = g2 * g4;
    double t1a = a * (g4 - 1.0);
    double t2 = -1296.0 * (g2 - 1.0) * (a - a * g2) * t1a * (4.0 * g2 + a * ((1.0 + g2) * (1.0 + g2)));
    double t9 = 2.0 + g2 + g3 * (1.0 + 2.0 * g2) * (2.0 * u0 - 1.0);
    double t3 = 3.0 * g2 * (1.0 + g * (2.0 * u0 - 1.0)) + a * t9;
    double t4a = 432.0 * (t1a * t1a * t1a) + t2 + 432.0 * (a * (1.0 - g2)) * (t3 * t3);
    double t10 = a * (2.0 * g4 - g2 - g6), t4b = 144.0 * t10;
    double t4 = t4a + sqrt(-4.0 * (t4b * t4b * t4b) + t4a * t4a);
    double inv_t4p3 = 1.0 / cbrt(t4), cbrt2 = cbrt(2.0);
    double t6 = (2.0 * t1a + 48.0 * cbrt2 * t10 * inv_t4p3 + 1.0 / (3.0 * cbrt2 * inv_t4p3)) / (a * (1.0 - g2));
    double t5 = 6.0 * (1.0 + g2) + t6;
    double t7 = 6.0 * (1.0 + g2) - (8.0 * t3) / (a * (g2 - 1.0) * sqrt(t5)) - t6;
    double root = sqrt(t7) - sqrt(t5);
    return (1.0 + g2 - 0.25 * (root * root)) / (2.0 * g);
}

/* phase.ff_delta: 4 sin^2(theta/2) / (3 (n - 1)^2), h = sin^2(theta/2). */
INLINE double ff_delta(double n, double h)
{
    return 4.0 * h / (3.0 * ((n - 1.0) * (n - 1.0)));
}

/* FournierForand._pf: p from delta, delta^v and h = sin^2(theta/2) (the Taylor form where |1 - delta| < 1e-3). */
static double ff_pf(const double *p, double cos_theta, double delta, double pow_delta_v, double h)
{
    double v = p[1], m_delta = 1.0 - delta, m_pow = 1.0 - pow_delta_v, pf;
    if (fabs(m_delta) < 1e-3)
        pf = v * ((v - 1.0) - (v + 1.0) / h) / (8.0 * PI)
             + v * (v + 1.0) * m_delta * (2.0 * (v - 1.0) - (2.0 * v + 1.0) / h) / (24.0 * PI);
    else
        pf = (v * m_delta - m_pow + (delta * m_pow - v * m_delta) / h) / (4.0 * PI * (m_delta * m_delta) * pow_delta_v);
    return pf + p[2] / (16.0 * PI) * (3.0 * cos_theta * cos_theta - 1.0);
}

/* FournierForand.eval_cos: 0 where |cos theta| >= 1. */
static double ff_eval(const double *p, double cos_theta)
{
    if (fabs(cos_theta) >= 1.0) return 0.0;
    double h = 0.5 * (1.0 - cos_theta), delta = ff_delta(p[0], h);
    return ff_pf(p, cos_theta, delta, pow(delta, p[1]), h);
}

/* FournierForand.sample_cos: Newton's method on the cdf from 50 degrees, 20 steps at most, never past 1 (nor at it:
 * its pole, where Cycles' pdf is 0 and the sample lost, is the float just below it here). */
static double ff_sample_cos(const double *p, double u0)
{
    double v = p[1], cos_theta = 0.64278760968;
    for (int it = 0; it < 20; it++) {
        double h = 0.5 * (1.0 - cos_theta), delta = ff_delta(p[0], h), pow_delta_v = pow(delta, v);
        double m_delta = 1.0 - delta, m_pow = 1.0 - pow_delta_v, cdf;
        if (fabs(m_delta) < 1e-3) cdf = 1.0 + v * (1.0 - h) * (1.0 - 0.5 * (v + 1.0) * m_delta);
        else cdf = (1.0 - pow_delta_v * delta - m_pow * h) / (m_delta * pow_delta_v);
        cdf = cdf + p[2] / 8.0 * cos_theta * (1.0 - cos_theta * cos_theta);
        double step = cos_theta + (cdf - u0) / (2.0 * PI * ff_pf(p, cos_theta, delta, pow_delta_v, h));
        if (step >= 1.0) step = at_least(0.5 * (cos_theta + 1.0), 0.99);
        if (fabs(cos_theta - step) < 1e-6 || step == 1.0) return at_most(step, nextafter(1.0, 0.0));
        cos_theta = step;
    }
    return cos_theta;
}

/* phase.clamp_g: |g| <= 1 - 1e-3, its sign kept (Cycles' HG and Draine setups). */
INLINE double phase_clamp_g(double g)
{
    double limit = 1.0 - 1e-3, a = fabs(g) < limit ? fabs(g) : limit;
    return g > 0.0 ? a : (g < 0.0 ? -a : 0.0);
}

/* phase.mie_parameters: Jendersie and d'Eon's fit (g_HG, g_D, alpha, w) of droplets of diameter d (micrometres),
 * into out (4), in its four ranges of d (exact sin, cos, log and exp). */
static void mie_fit(double diameter, double *out)
{
    double d = diameter > 0.0 ? diameter : 0.0, log_d = log(d), log_log = log(log_d);
    if (d <= 0.1) {
        out[0] = 13.8 * d * d;
        out[1] = 1.1456 * d * sin(9.29044 * d);
        out[2] = 250.0;
        out[3] = 0.252977 - 312.983 * pow(d, 4.3);
    } else if (d < 1.5) {
        double a = (log_d - 0.238604) * (log_d + 1.00667), b = 0.507522 - 0.15677 * log_d;
        double c = 1.19692 * cos(a / b) + 1.37932 * log_d + 0.0625835;
        out[0] = 0.862 - 0.143 * log_d * log_d;
        out[1] = 0.379685 * cos(c) + 0.344213;
        out[2] = 250.0;
        out[3] = 0.146209 * cos(3.38707 * log_d + 2.11193) + 0.316072 + 0.0778917 * log_d;
    } else if (d < 5.0) {
        out[0] = 0.0604931 * log_log + 0.940256;
        out[1] = 0.500411 - 0.081287 / (-2.0 * log_d + tan(log_d) + 1.27551);
        out[2] = 7.30354 * log_d + 6.31675;
        out[3] = 0.026914 * (log_d - cos(5.68947 * (log_log - 0.0292149))) + 0.3764;
    } else {
        out[0] = exp(-0.0990567 / (d - 1.67154));
        out[1] = exp(-2.20679 / (d + 3.91029) - 0.428934);
        out[2] = exp(3.62489 - 8.29288 / (d + 5.52825));
        out[3] = exp(-0.599085 / (d - 0.641583) - 0.665888);
    }
}

/* phase.parameters_at at one point: the phase function of `kind` set up from a closure's inputs there (anisotropy,
 * IOR, backscatter, alpha, diameter), as Cycles' svm_alloc_closure_volume_scatter, into *phase. */
static NOINLINE void phase_setup(int64_t kind, double anisotropy, double ior, double backscatter, double alpha,
                                 double diameter, Phase *phase)
{
    phase->kind = kind;
    phase->lobes = 0;
    for (int k = 0; k < PHASE_PARAMETERS; k++) phase->p[k] = 0.0;
    if (kind == PHASE_FOURNIER_FORAND) {        /* (FournierForand.of: Cycles' volume_fournier_forand_setup) */
        double B = fabs(backscatter) < 0.5 - 1e-3 ? fabs(backscatter) : 0.5 - 1e-3;
        double n = ior > 1.0 + 1e-3 ? ior : 1.0 + 1e-3;
        double d90 = ff_delta(n, 0.5), d180 = ff_delta(n, 1.0);
        double v = -log(2.0 * B * (d90 - 1.0) + 1.0) / log(d90);
        phase->p[0] = n;
        phase->p[1] = v;
        phase->p[2] = (pow(d180, -v) - 1.0) / (d180 - 1.0);
    } else if (kind == PHASE_DRAINE) {
        phase->p[0] = phase_clamp_g(anisotropy);
        phase->p[1] = alpha;
    } else if (kind == PHASE_MIE) {
        mie_fit(diameter, phase->p);
        phase->p[0] = phase_clamp_g(phase->p[0]);
        phase->p[1] = phase_clamp_g(phase->p[1]);
    } else if (kind != PHASE_RAYLEIGH) {
        phase->kind = PHASE_HENYEY_GREENSTEIN;
        phase->p[0] = phase_clamp_g(anisotropy);
    }
}

/* Phase.eval_cos of any kind: p at cos theta = dot(-wo, wi) (of one phase function: lobes ignored). */
static NOINLINE double phase_eval_one(const Phase *phase, double cos_theta)
{
    const double *p = phase->p;
    switch (phase->kind) {
    case PHASE_FOURNIER_FORAND: return ff_eval(p, cos_theta);
    case PHASE_DRAINE: return draine_eval(cos_theta, p[0], p[1]);
    case PHASE_RAYLEIGH: return rayleigh_eval(cos_theta);
    case PHASE_MIE: return (1.0 - p[3]) * hg_eval(cos_theta, p[0]) + p[3] * draine_eval(cos_theta, p[1], p[2]);
    default: return henyey_greenstein(cos_theta, p[0]);
    }
}

/* Phase.sample of any kind: a direction wi (3) for a viewer along wo (3) from numbers u (2), its pdf returned (p
 * there: eval / pdf = 1). HG's is sample_henyey_greenstein's, bit for bit. */
static NOINLINE double phase_sample_one(const Phase *phase, const double *wo, const double *u, double *wi)
{
    const double *p = phase->p;
    double cos_theta;
    switch (phase->kind) {
    case PHASE_FOURNIER_FORAND: cos_theta = ff_sample_cos(p, u[0]); break;
    case PHASE_DRAINE: cos_theta = draine_sample_cos(p[0], p[1], u[0]); break;
    case PHASE_RAYLEIGH: cos_theta = rayleigh_sample_cos(u[0]); break;
    case PHASE_MIE:
        if (u[0] < p[3]) cos_theta = draine_sample_cos(p[1], p[2], u[0] / p[3]);
        else cos_theta = hg_sample_cos(p[0], at_most((u[0] - p[3]) / (1.0 - p[3]), 1.0));
        break;
    default: return sample_henyey_greenstein(wo, p[0], u, wi);
    }
    phase_direction(wo, cos_theta, u[1], wi);
    return phase_eval_one(phase, cos_theta);
}

/* The lobe l of a mixture as a phase function of its own, into *one. */
INLINE void phase_lobe(const Phase *phase, int64_t l, Phase *one)
{
    one->kind = phase->kinds[l];
    for (int k = 0; k < PHASE_PARAMETERS; k++) one->p[k] = phase->lobe[l][k];
    one->lobes = 0;
}

/* PhaseMix.eval / Phase.eval_cos: a mixture's weight-averaged p (Cycles' _volume_shader_phase_eval_mis), else the
 * one phase function's. */
static NOINLINE double phase_eval(const Phase *phase, double cos_theta)
{
    if (phase->lobes == 0) return phase_eval_one(phase, cos_theta);
    double sum = 0.0, total = 0.0;
    for (int64_t l = 0; l < phase->lobes; l++) {
        Phase one;
        phase_lobe(phase, l, &one);
        sum += phase_eval_one(&one, cos_theta) * phase->weight[l];
        total += phase->weight[l];
    }
    return total > 0.0 ? sum / total : 0.0;
}

/* PhaseMix.sample / Phase.sample: a mixture picks one lobe by weight with u[0] (Cycles' volume_shader_phase_pick,
 * the number rescaled) and samples it, that lobe's pdf returned (Cycles' phase ray: eval / pdf 1, its MIS pdf). */
static NOINLINE double phase_sample(const Phase *phase, const double *wo, const double *u, double *wi)
{
    if (phase->lobes == 0) return phase_sample_one(phase, wo, u, wi);
    double v[2] = {u[0], u[1]}, sum = phase->weight[0];
    int64_t picked = 0;
    for (int64_t l = 1; l < phase->lobes; l++) {
        sum += phase->weight[l];
        double threshold = sum > 0.0 ? phase->weight[l] / sum : 0.0;
        if (v[0] < threshold) { picked = l; v[0] = v[0] / threshold; }
        else v[0] = (v[0] - threshold) / (1.0 - threshold);
    }
    Phase one;
    phase_lobe(phase, picked, &one);
    return phase_sample_one(&one, wo, v, wi);
}

/* primer_phase_rows (phase.compiled_rows): n rows of kind, parameters (n, PHASE_PARAMETERS), wo, wi (n, 3) and u
 * (n, 2): p(wo, wi) into eval (n,), a sampled direction into sampled (n, 3) and its pdf into pdf (n,). */
static void phase_rows(const PhaseRowsArgs *a)
{
    for (int64_t i = 0; i < a->n; i++) {
        Phase phase;
        phase.kind = a->kind[i];
        phase.lobes = 0;
        for (int k = 0; k < PHASE_PARAMETERS; k++) phase.p[k] = a->parameters[PHASE_PARAMETERS * i + k];
        const double *wo = a->wo + 3 * i, *wi = a->wi + 3 * i;
        a->eval[i] = phase_eval(&phase, -wo[0] * wi[0] + -wo[1] * wi[1] + -wo[2] * wi[2]);
        a->pdf[i] = phase_sample(&phase, wo, a->u + 2 * i, a->sampled + 3 * i);
    }
}
