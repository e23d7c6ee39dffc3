/* Shader nodes: core/materials/nodes.py. Each node of a material sets up its closures at a hit; the
 * Principled BSDF lays out its layers as Cycles does. A closure's parameters go into the hit's storage.
 * Each node's setup is <name>_node here; setup_node, generated from core/materials/registry.py's NODE_TYPES
 * (nodes.gen.c), picks it by the node's kind (NODE_*, core/native/boundary.gen.h). */

#define WEIGHT_CUTOFF 1e-5          /* closures.WEIGHT_CUTOFF */

/* ClosureBuilder.add: a closure of `kind` with `weight`; its sampling weight is |mean(allocated)| x factor;
 * none below the cutoff. params (MF_PARAMS doubles, or NULL) go into the hit's storage. The caller made room for
 * every closure the hit's material sets up (ChunkParams.closure_room), or none (no_closures). */
INLINE void closure_add(ShaderResult *sd, int kind, const double *weight, const double *allocated, double factor,
                        const double *params)
{
    double sample_weight = fabs((allocated[0] + allocated[1] + allocated[2]) / 3.0);
    if (!(sample_weight >= WEIGHT_CUTOFF) || sd->n >= sd->room) return;
    Closure *c = sd->c + sd->n;
    c->kind = kind;
    c->sample_weight = sample_weight * factor;
    for (int j = 0; j < 3; j++) { c->weight[j] = weight[j]; c->N[j] = sd->N[j]; }
    c->p = NULL;
    if (params != NULL) {
        double *row = sd->storage + STORAGE_STRIDE * sd->n;
        for (int j = 0; j < STORAGE_STRIDE; j++) row[j] = params[j];
        c->p = row;
        if (sd->blur > 0.0) roughen(kind, row, sd->blur);
    }
    sd->n++;
}

/* subsurface.add_subsurface: Cycles' BSSRDF closure of `weight` (bssrdf_setup) on the node's glossy normal, radius
   (3) the node's radius x scale, the clamped colour `albedo` (3), anisotropy, ior (clamped to 0..0.9 and 1.01..3.8),
   the entry's GGX alpha, the Subsurface Method number `method` (SUBSURFACE_BURLEY: the disk); channels with too small
   a radius go to a Lambert closure first. Its sampling weight: |mean weight| x the channels it walks. */
NOINLINE static void subsurface_add(ShaderResult *sd, const double *weight, const double *radius, const double *albedo,
                                    double anisotropy, double ior, double alpha, double method)
{
    double w[3], diffuse[3], kept[3], v[STORAGE_STRIDE] = {0.0}, saved[3] = {sd->N[0], sd->N[1], sd->N[2]};
    int channels = 0, skin = method == RANDOM_WALK_SKIN, mfp = method == RANDOM_WALK_MFP;
    int on = fabs((weight[0] + weight[1] + weight[2]) / 3.0) >= WEIGHT_CUTOFF;
    ior = ior < 1.01 ? 1.01 : (ior > 3.8 ? 3.8 : ior);
    for (int j = 0; j < 3; j++) {
        double r = at_least(radius[j], 0.0);
        int small = r < SUBSURFACE_MIN_RADIUS;
        w[j] = on ? weight[j] : 0.0;
        diffuse[j] = small ? w[j] : 0.0;
        kept[j] = small ? 0.0 : w[j];
        channels += !small;
        v[SUBSURFACE_RADIUS + j] = small ? 0.0 : scaled_radius(r, albedo[j], ior, skin, mfp);
        v[SUBSURFACE_ALBEDO + j] = albedo[j];
    }
    v[SUBSURFACE_ANISOTROPY] = anisotropy < 0.0 ? 0.0 : (anisotropy > 0.9 ? 0.9 : anisotropy);
    v[SUBSURFACE_IOR] = ior;
    v[SUBSURFACE_ALPHA] = skin ? 1.0 : alpha;
    v[SUBSURFACE_SKIN] = skin;
    v[SUBSURFACE_BUMP] = sd->glossy != NULL;     /* (the node's own Normal input: a linked one) */
    v[SUBSURFACE_DISK] = method == SUBSURFACE_BURLEY;
    if (sd->glossy != NULL) for (int j = 0; j < 3; j++) sd->N[j] = sd->glossy[j];
    closure_add(sd, BSDF_LAMBERT, diffuse, diffuse, 1.0, NULL);
    if (channels > 0) closure_add(sd, BSDF_SUBSURFACE, kept, kept, (double)channels, v);
    for (int j = 0; j < 3; j++) sd->N[j] = saved[j];
}

/* nodes.layering_weight: what a layer with `albedo` leaves of `weight` for the layers below. */
INLINE void layering_weight(const double *albedo, double *weight)
{
    double largest = -INFINITY;
    for (int j = 0; j < 3; j++) {
        double ratio = weight[j] != 0.0 ? albedo[j] / weight[j] : 0.0;
        largest = ratio > largest ? ratio : largest;
    }
    double keep = clamp01(1.0 - largest);
    for (int j = 0; j < 3; j++) weight[j] *= keep;
}

INLINE double dielectric_Fss(double eta)
{
    if (eta < 1.0) return 0.997118 + eta * (0.1014 - eta * (0.965241 + eta * 0.130607));
    return (eta - 1.0) / (4.08567 + 1.00071 * eta);
}

INLINE double ior_from_F0(double f0)
{
    double root = sqrt(f0 < 0.0 ? 0.0 : (f0 > 1.0 - 1e-7 ? 1.0 - 1e-7 : f0));
    return (1.0 + root) / (1.0 - root);
}

/* GlossyLobe.params: a microfacet closure's parameters, energy scale 1. */
INLINE void lobe_params(double *p, double roughness, int mode, double ior, const double *f0, const double *f90)
{
    for (int j = 0; j < STORAGE_STRIDE; j++) p[j] = 0.0;
    double r = clamp01(roughness);
    p[MF_ALPHA] = r * r;
    p[MF_FRESNEL] = (double)mode;
    p[MF_IOR] = ior;
    for (int j = 0; j < 3; j++) { p[MF_F0 + j] = f0[j]; p[MF_F90 + j] = f90[j]; }
    p[MF_ENERGY] = 1.0;
}

/* nodes.rotate_around_axis: v turned by angle about the unit axis (Rodrigues). */
INLINE void rotate_around_axis(const double *v, const double *axis, double angle, double *out)
{
    double c = cos(angle), s = sin(angle), d = dot3(axis, v), x[3];
    cross3(axis, v, x);
    for (int k = 0; k < 3; k++) out[k] = (v[k] * c + x[k] * s) + (d * axis[k]) * (1.0 - c);
}

/* nodes.anisotropic_lobe: alpha_x, alpha_y (clipped to 1) and the tangent T into a microfacet closure's parameters. */
INLINE void anisotropic_lobe(double *p, double alpha_x, double alpha_y, const double *T)
{
    p[MF_ALPHA] = at_most(alpha_x, 1.0);
    p[MF_ALPHA_Y] = at_most(alpha_y, 1.0);
    for (int k = 0; k < 3; k++) p[MF_TANGENT + k] = T[k];
}

/* nodes.table_roughness: sqrt(alpha), or sqrt(sqrt(alpha_x alpha_y)) for an anisotropic lobe. */
INLINE double table_roughness(const double *p)
{
    return mf_is_anisotropic(p) ? sqrt(sqrt(p[MF_ALPHA] * p[MF_ALPHA_Y])) : sqrt(p[MF_ALPHA]);
}

/* GlossyLobe.add: append the closure of BSDF `kind` (BSDF_MICROFACET: GGX, BSDF_BECKMANN, BSDF_ASHIKHMIN_SHIRLEY;
 * albedo: its Fresnel estimate or NULL; Fss: multiscatter's average Fresnel or NULL for none); `weight` becomes the
 * closure's weight after darkening. */
INLINE void lobe_add_as(ShaderResult *sd, double mu, double *weight, double *p, const double *albedo, const double *Fss,
                        int kind)
{
    double rough = table_roughness(p);
    double allocated[3] = {weight[0], weight[1], weight[2]};
    double factor = albedo != NULL ? (albedo[0] + albedo[1] + albedo[2]) / 3.0 : 1.0;
    if (Fss != NULL) {
        double E = at_least(lookup_2d(GGX_E, 32, 32, rough, mu), 1e-6);
        double E_avg = lookup_1d(GGX_EAVG, 32, rough);
        double missing = (1.0 - E) / E;
        p[MF_ENERGY] = 1.0 + missing;
        if (!(Fss[0] == 1.0 && Fss[1] == 1.0 && Fss[2] == 1.0)) {
            double darkening[3];
            for (int j = 0; j < 3; j++) {
                double Fms = Fss[j] * E_avg / (1.0 - Fss[j] * (1.0 - E_avg));
                darkening[j] = (1.0 + Fms * missing) / p[MF_ENERGY];
                weight[j] *= darkening[j];
            }
            factor *= (darkening[0] + darkening[1] + darkening[2]) / 3.0;
        }
    }
    double closure_weight[3] = {weight[0], weight[1], weight[2]};
    /* (with Filter Glossy's blur: ClosureBuilder.blurred; a blurred mirror is a rough lobe) */
    double q[STORAGE_STRIDE];
    const double *r = p;
    if (sd->blur > 0.0) {
        for (int j = 0; j < STORAGE_STRIDE; j++) q[j] = p[j];
        q[MF_ALPHA] = at_least(q[MF_ALPHA], sd->blur);
        q[MF_ALPHA_Y] = at_least(q[MF_ALPHA_Y], sd->blur);
        r = q;
    }
    double ax, ay;
    as_alphas(r, &ax, &ay);
    int singular = kind == BSDF_ASHIKHMIN_SHIRLEY ? at_least(ax, ay) <= AS_ALPHA_MIN
                 : (mf_is_anisotropic(r) ? r[MF_ALPHA] * r[MF_ALPHA_Y] : r[MF_ALPHA] * r[MF_ALPHA]) <= ROUGHNESS_SQ_THRESHOLD;
    if (singular) {
        double F[3];
        microfacet_fresnel(p, clamp01(mu), F);
        for (int j = 0; j < 3; j++) closure_weight[j] *= F[j] * p[MF_ENERGY];
        kind = BSDF_MIRROR;
    }
    if (sd->glossy != NULL) {                       /* the node's glossy normal (graph.valid_reflection) */
        double saved[3] = {sd->N[0], sd->N[1], sd->N[2]};
        for (int j = 0; j < 3; j++) sd->N[j] = sd->glossy[j];
        closure_add(sd, kind, closure_weight, allocated, factor, p);
        for (int j = 0; j < 3; j++) sd->N[j] = saved[j];
        return;
    }
    closure_add(sd, kind, closure_weight, allocated, factor, p);
}

INLINE void lobe_add(ShaderResult *sd, double mu, double *weight, double *p, const double *albedo, const double *Fss)
{
    lobe_add_as(sd, mu, weight, p, albedo, Fss, BSDF_MICROFACET);
}

/* nodes.dielectric_albedo: estimated albedo of a lobe with the dielectric curve remapped from f0 to 1. */
INLINE void dielectric_albedo(double rough, double mu, double eta, const double *f0, double *albedo)
{
    double z = sqrt(fabs((eta - 1.0) / (eta + 1.0)));
    double s = lookup_3d(GGX_SCHLICK_IOR_S, 16, rough, mu, z);
    for (int j = 0; j < 3; j++) albedo[j] = f0[j] + (1.0 - f0[j]) * s;
}

/* nodes.thin_film_slots: a closure's remapped dielectric Fresnel (or its metal's, mode FRESNEL_THIN_FILM_F82) made
 * a thin film's (film_ior relative to the medium light arrives from). */
INLINE void thin_film_slots(double *p, double thickness, double film_ior, int mode)
{
    p[MF_FRESNEL] = (double)mode;
    p[MF_THICKNESS] = thickness;
    p[MF_FILM_IOR] = film_ior;
}

/* nodes.glass_params: a Glass closure's parameters; the relative index is ior entering, 1 / ior leaving. */
INLINE void glass_params(double *g, int backfacing, double ior, int mode, const double *f0, const double *f90,
                         const double *reflect_tint, const double *transmit_tint)
{
    for (int j = 0; j < STORAGE_STRIDE; j++) g[j] = 0.0;
    g[MF_FRESNEL] = (double)mode;
    g[MF_IOR] = backfacing ? 1.0 / ior : ior;
    g[MF_ENERGY] = 1.0;
    for (int j = 0; j < 3; j++) {
        g[MF_F0 + j] = f0[j];
        g[MF_F90 + j] = f90[j];
        g[GLASS_REFLECT_TINT + j] = reflect_tint[j];
        g[GLASS_TRANSMIT_TINT + j] = transmit_tint[j];
    }
}

/* nodes.glass_share_mean: the mean of the reflected and transmitted shares at the view angle. */
INLINE double glass_share_mean(const double *g, double mu)
{
    double R[3], T[3];
    glass_shares(g, clamp01(mu), R, T);
    return (R[0] + T[0] + R[1] + T[1] + R[2] + T[2]) / 3.0;
}

/* ggx_tables.glass_E: E and Eavg of rough glass of relative index eta (the entering table for eta >= 1). */
INLINE double glass_E(double rough, double mu, double eta, double *E_avg)
{
    double ior = eta < 1.0 ? 1.0 / at_least(eta, 1e-300) : eta;
    double z = sqrt(fabs((ior - 1.0) / (ior + 1.0)));
    *E_avg = lookup_2d(eta < 1.0 ? GGX_GLASS_INV_EAVG : GGX_GLASS_EAVG, 16, 16, rough, z);
    return lookup_3d(eta < 1.0 ? GGX_GLASS_INV_E : GGX_GLASS_E, 16, rough, mu, z);
}

/* nodes.add_glass: smooth glass below the roughness threshold (or at index 1), else rough glass of BSDF
 * `rough_kind` (BSDF_ROUGH_GLASS: GGX, or BSDF_BECKMANN_GLASS); with Fss (Multiscatter GGX) its energy restored from
 * the glass tables and darkened by Fss. g: glass_params. */
INLINE void glass_add_as(ShaderResult *sd, double mu, const double *weight, double *g, double roughness,
                         const double *Fss, int rough_kind)
{
    double rough = clamp01(roughness), eta = g[MF_IOR];
    g[MF_ALPHA] = rough * rough;
    int smooth = g[MF_ALPHA] * g[MF_ALPHA] <= ROUGHNESS_SQ_THRESHOLD || fabs(eta - 1.0) < 1e-4;
    /* (Filter Glossy: smooth glass blurred is rough glass; its energy stays that of the glass set up) */
    double alpha = at_least(g[MF_ALPHA], sd->blur);
    int mirror_like = alpha * alpha <= ROUGHNESS_SQ_THRESHOLD || fabs(eta - 1.0) < 1e-4;
    double factor = glass_share_mean(g, mu), w[3] = {weight[0], weight[1], weight[2]};
    if (Fss != NULL) {
        double E_avg, E = glass_E(rough, mu, eta, &E_avg);
        double missing = smooth ? 0.0 : (1.0 - at_least(E, 1e-6)) / at_least(E, 1e-6);
        g[MF_ENERGY] = 1.0 + missing;
        if (!(Fss[0] == 1.0 && Fss[1] == 1.0 && Fss[2] == 1.0) && !smooth) {
            double darkening[3];
            for (int j = 0; j < 3; j++) {
                double Fms = Fss[j] * E_avg / (1.0 - Fss[j] * (1.0 - E_avg));
                darkening[j] = (1.0 + Fms * missing) / g[MF_ENERGY];
                w[j] *= darkening[j];
            }
            factor *= (darkening[0] + darkening[1] + darkening[2]) / 3.0;
        }
    }
    closure_add(sd, mirror_like ? BSDF_GLASS : rough_kind, w, weight, factor, g);
}

INLINE void glass_add(ShaderResult *sd, double mu, const double *weight, double *g, double roughness, const double *Fss)
{
    glass_add_as(sd, mu, weight, g, roughness, Fss, BSDF_ROUGH_GLASS);
}

/* nodes.add_diffuse: Lambert below the roughness cutoff, else Oren-Nayar with that roughness and colour. */
INLINE void diffuse_add(ShaderResult *sd, double mu, const double *weight, double roughness, const double *albedo,
                        double cutoff)
{
    if (!(roughness >= cutoff)) {
        closure_add(sd, BSDF_LAMBERT, weight, weight, 1.0, NULL);
        return;
    }
    double p[STORAGE_STRIDE] = {0.0};
    oren_nayar_params(roughness, albedo, mu, p);
    closure_add(sd, BSDF_OREN_NAYAR, weight, weight, 1.0, p);
}

/* nodes.add_sheen: a sheen closure with normal N seen from wo, weight x its albedo R (weight and sampling weight);
 * returns R. */
INLINE double sheen_add(ShaderResult *sd, const double *wo, const double *N, const double *weight, double roughness)
{
    double p[STORAGE_STRIDE] = {0.0};
    double R = sheen_params(roughness, dot3(N, wo), p);
    double w[3] = {weight[0] * R, weight[1] * R, weight[2] * R}, saved[3] = {sd->N[0], sd->N[1], sd->N[2]};
    for (int j = 0; j < 3; j++) sd->N[j] = N[j];
    closure_add(sd, BSDF_SHEEN, w, weight, R, p);
    for (int j = 0; j < 3; j++) sd->N[j] = saved[j];
    return R;
}

/* nodes.sheen_normal: the node's normal sd->N turned towards the coat's normal `hit` by coat in 0..1. */
INLINE void sheen_normal(const ShaderResult *sd, double coat, const double *hit, double *N)
{
    for (int j = 0; j < 3; j++) N[j] = sd->N[j] + coat * (hit[j] - sd->N[j]);
    double length = sqrt(dot3(N, N));
    for (int j = 0; j < 3; j++) N[j] = length > 0.0 ? N[j] / length : hit[j];
}

/* nodes.PrincipledNode.setup: p holds nodes.PRINCIPLED_INPUTS in order. */
INLINE void principled_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                            const double *p)
{
    double base[3], clamped[3], tint[3], coat_tint[3], W[3];
    for (int j = 0; j < 3; j++) {
        base[j] = at_least(p[j], 0.0);
        clamped[j] = at_most(base[j], 1.0);
        tint[j] = at_least(p[9 + j], 0.0);
        coat_tint[j] = at_least(p[15 + j], 0.0);
        W[j] = weight[j];
    }
    double metallic = clamp01(p[3]), roughness = clamp01(p[4]), ior = at_least(p[5], 1e-5), alpha = clamp01(p[6]);
    double subsurface = clamp01(p[7]), level = at_least(p[8], 0.0);
    double coat = at_least(p[12], 0.0), coat_roughness = clamp01(p[13]), coat_ior = at_least(p[14], 1.0);
    double transmission = clamp01(p[21]);
    int multiscatter = p[22] != 0.0;
    double thickness = p[38], film_ior = at_least(p[39], 1e-5);
    int film = thickness > THIN_FILM_THICKNESS_CUTOFF;
    double lobe[STORAGE_STRIDE], one[3] = {1.0, 1.0, 1.0};
    int reflective = !(sd->caustics & FILTER_REFLECTIVE), refractive = !(sd->caustics & FILTER_REFRACTIVE);
    /* nodes.principled_anisotropy: the metal's and the specular's alphas and tangent. */
    double anisotropic = clamp01(p[30]), T[3] = {p[32], p[33], p[34]}, alpha_x = 0.0, alpha_y = 0.0;
    int aniso = anisotropic > 0.0 && (T[0] != 0.0 || T[1] != 0.0 || T[2] != 0.0);
    if (aniso) {
        double aspect = sqrt(1.0 - clamp01(anisotropic) * 0.9), a = roughness * roughness;
        alpha_x = a / aspect;
        alpha_y = a * aspect;
        if (p[31] != 0.0) rotate_around_axis(p + 32, sd->N, p[31] * 2.0 * PI, T);
    }
    /* nodes.coat_normal: Coat Normal from the graph (p[35..37], unit and valid-reflection corrected; zero where
     * unlinked), else the node's own normal where it follows Normal (p[29]), else the hit's. */
    int follows = p[29] != 0.0, coat_linked = p[35] != 0.0 || p[36] != 0.0 || p[37] != 0.0;
    const double *coat_N = coat_linked ? p + 35 : (sd->hit_N != NULL && !follows ? sd->hit_N : sd->N);
    const double *coat_glossy = coat_linked || !follows ? NULL : sd->glossy;
    /* 1. Alpha. */
    if (alpha < 1.0)
        for (int j = 0; j < 3; j++) { sd->transparency[j] += W[j] * (1.0 - alpha); W[j] *= alpha; }
    /* 1b. Sheen, on top of everything else (a diffuse closure: no caustics filter). */
    double sheen = at_least(p[24], 0.0);
    if (sheen > WEIGHT_CUTOFF) {
        double Ns[3], sheen_weight[3];
        sheen_normal(sd, clamp01(coat), coat_N, Ns);
        for (int j = 0; j < 3; j++) sheen_weight[j] = W[j] * sheen * at_least(p[26 + j], 0.0);
        double R = sheen_add(sd, wo, Ns, sheen_weight, clamp01(p[25]));
        double albedo[3] = {sheen_weight[0] * R, sheen_weight[1] * R, sheen_weight[2] * R};
        layering_weight(albedo, W);
    }
    /* 2. Coat, with its own normal coat_N (nodes.py: a normal map at the node's Normal input alone turns the
     *    layers below it, not the coat); where reflective caustics are filtered out it reflects nothing, but
     *    still tints. */
    if (coat > WEIGHT_CUTOFF) {
        double node_N[3] = {sd->N[0], sd->N[1], sd->N[2]}, hit[3] = {coat_N[0], coat_N[1], coat_N[2]};
        const double *node_glossy = sd->glossy;
        double mu_c = mu;
        if (coat_linked || !follows) {
            for (int j = 0; j < 3; j++) sd->N[j] = hit[j];
            sd->glossy = coat_glossy;
            mu_c = dot3(hit, wo);
        }
        if (reflective) {
            double F0c = F0_from_ior(coat_ior), f0[3] = {F0c, F0c, F0c}, reflect[3], Fss[3];
            lobe_params(lobe, coat_roughness, FRESNEL_DIELECTRIC, coat_ior, f0, one);
            dielectric_albedo(coat_roughness, mu_c, coat_ior, f0, reflect);
            double coat_weight[3] = {W[0] * coat, W[1] * coat, W[2] * coat};
            Fss[0] = Fss[1] = Fss[2] = dielectric_Fss(coat_ior);
            lobe_add(sd, mu_c, coat_weight, lobe, reflect, Fss);
            double albedo[3] = {coat_weight[0] * reflect[0], coat_weight[1] * reflect[1], coat_weight[2] * reflect[2]};
            layering_weight(albedo, W);
        }
        if (!(coat_tint[0] == 1.0 && coat_tint[1] == 1.0 && coat_tint[2] == 1.0)) {
            double cos_t = sqrt(at_least(1.0 - (1.0 - mu_c * mu_c) / (coat_ior * coat_ior), 1e-12));
            for (int j = 0; j < 3; j++) W[j] *= 1.0 + coat * (pow(coat_tint[j], 1.0 / cos_t) - 1.0);
        }
        for (int j = 0; j < 3; j++) sd->N[j] = node_N[j];
        sd->glossy = node_glossy;
    }
    /* 3. Emission. */
    for (int j = 0; j < 3; j++) sd->emission[j] += W[j] * p[18 + j];
    /* 4. Metal. */
    if (metallic > WEIGHT_CUTOFF) {
        double B[3] = {0.0, 0.0, 0.0}, reflect[3], Fss[3], metal_weight[3];
        int tinted = 0;
        for (int j = 0; j < 3; j++) tinted |= at_most(tint[j], 1.0) != 1.0;
        if (tinted) {
            double f = 6.0 / 7.0, f5 = f * f * f * f * f;
            for (int j = 0; j < 3; j++)
                B[j] = (clamped[j] + (1.0 - clamped[j]) * f5) * (7.0 / (f5 * f)) * (1.0 - at_most(tint[j], 1.0));
        }
        lobe_params(lobe, roughness, FRESNEL_F82_TINT, 1.0, clamped, B);
        if (aniso) anisotropic_lobe(lobe, alpha_x, alpha_y, T);
        double s = lookup_2d(GGX_SCHLICK_S_HALF, 16, 16, aniso ? table_roughness(lobe) : roughness, mu);
        for (int j = 0; j < 3; j++) {
            reflect[j] = clamped[j] + (1.0 - clamped[j]) * s;
            Fss[j] = clamped[j] + (1.0 - clamped[j]) / 21.0 - B[j] / 126.0;
            metal_weight[j] = W[j] * metallic;
        }
        if (film) {     /* the film on the metal (Cycles 5.0): its Fresnel at mu is the albedo estimate */
            thin_film_slots(lobe, thickness, film_ior, FRESNEL_THIN_FILM_F82);
            microfacet_fresnel(lobe, clamp01(mu), reflect);
        }
        if (reflective)     /* p[47]: the metal's distribution (a Metallic BSDF's Beckmann) */
            lobe_add_as(sd, mu, metal_weight, lobe, reflect, multiscatter ? Fss : NULL,
                        p[47] == DISTRIBUTION_BECKMANN ? BSDF_BECKMANN : BSDF_MICROFACET);
        for (int j = 0; j < 3; j++) W[j] *= 1.0 - metallic;
    }
    /* 5. Transmission: glass, smooth or rough; a caustics filter takes away its reflection or refraction. */
    if (transmission > WEIGHT_CUTOFF) {
        double g[STORAGE_STRIDE], f0[3], root[3], glass_weight[3], Fss[3], reflect_tint[3];
        for (int j = 0; j < 3; j++) {
            f0[j] = clamp01(F0_from_ior(ior) * tint[j]);
            root[j] = refractive ? sqrt(clamped[j]) : 0.0;
            reflect_tint[j] = reflective ? 1.0 : 0.0;
            glass_weight[j] = W[j] * transmission;
        }
        glass_params(g, backfacing, ior, FRESNEL_SCHLICK_IOR, f0, one, reflect_tint, root);
        if (film) thin_film_slots(g, thickness, backfacing ? film_ior / ior : film_ior, FRESNEL_THIN_FILM);
        for (int j = 0; j < 3; j++) Fss[j] = root[j];   /* the transmission tint: Cycles' Fss for glass */
        if (reflective || refractive) glass_add(sd, mu, glass_weight, g, roughness, multiscatter ? Fss : NULL);
        for (int j = 0; j < 3; j++) W[j] *= 1.0 - transmission;
    }
    /* 6. Specular. */
    double eta = ior, f0 = F0_from_ior(ior);
    if (level != 0.5) {
        f0 *= 2.0 * level;
        eta = ior_from_F0(f0);
        if (ior < 1.0) eta = 1.0 / eta;
    }
    if ((eta != 1.0 || film) && reflective) {
        double f0_tinted[3], reflect[3], Fss[3];
        for (int j = 0; j < 3; j++) f0_tinted[j] = clamp01(f0 * tint[j]);
        lobe_params(lobe, roughness, FRESNEL_SCHLICK_IOR, eta, f0_tinted, one);
        if (aniso) anisotropic_lobe(lobe, alpha_x, alpha_y, T);
        dielectric_albedo(aniso ? table_roughness(lobe) : roughness, mu, eta, f0_tinted, reflect);
        if (film) {     /* no table for a film: its albedo estimate is its Fresnel at mu (Cycles) */
            thin_film_slots(lobe, thickness, film_ior, FRESNEL_THIN_FILM);
            microfacet_fresnel(lobe, clamp01(mu), reflect);
        }
        double F0_real = F0_from_ior(eta);
        double s = F0_real < 1.0 ? clamp01((dielectric_Fss(eta) - F0_real) / (1.0 - F0_real)) : 1.0;
        for (int j = 0; j < 3; j++) Fss[j] = f0_tinted[j] + (1.0 - f0_tinted[j]) * s;
        double specular_weight[3] = {W[0], W[1], W[2]};
        lobe_add(sd, mu, specular_weight, lobe, reflect, multiscatter ? Fss : NULL);
        double albedo[3];
        for (int j = 0; j < 3; j++) albedo[j] = specular_weight[j] * reflect[j];
        layering_weight(albedo, W);
    }
    /* 7. Subsurface (a BSSRDF of the clamped colour, subsurface_add), then the diffuse, Oren-Nayar's with Diffuse
     *    Roughness. */
    if (subsurface > WEIGHT_CUTOFF) {
        double walk_weight[3], radius[3];
        for (int j = 0; j < 3; j++) { walk_weight[j] = W[j] * clamped[j] * subsurface; radius[j] = p[40 + j] * p[43]; }
        subsurface_add(sd, walk_weight, radius, clamped, p[45], p[46] == RANDOM_WALK_SKIN ? p[44] : eta,
                       roughness * roughness, p[46]);
    }
    double diffuse[3];
    for (int j = 0; j < 3; j++) diffuse[j] = W[j] * base[j] * (1.0 - subsurface);
    diffuse_add(sd, mu, diffuse, clamp01(p[23]), base, WEIGHT_CUTOFF);
}

/* The other nodes' setups (nodes.py <Name>Node.setup), each with the normal sd->N and mu = N.wo. */
INLINE void diffuse_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                         const double *p)
{
    (void)wo; (void)backfacing;
    double albedo[3] = {clamp01(p[1]), clamp01(p[2]), clamp01(p[3])};
    diffuse_add(sd, mu, weight, p[0], albedo, 1e-5);            /* nodes.DIFFUSE_ROUGHNESS_CUTOFF */
}

INLINE void glossy_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                        const double *p)
{
    (void)wo; (void)backfacing;
    if (sd->caustics & FILTER_REFLECTIVE) return;
    double lobe[STORAGE_STRIDE], w[3] = {weight[0], weight[1], weight[2]}, one[3] = {1.0, 1.0, 1.0};
    double Fss[3] = {at_least(p[2], 0.0), at_least(p[3], 0.0), at_least(p[4], 0.0)};
    lobe_params(lobe, p[0], FRESNEL_NONE, 1.0, one, one);
    double a = p[5] < -0.99 ? -0.99 : (p[5] > 0.99 ? 0.99 : p[5]);
    int on = fabs(a) > 1e-4 && (p[7] != 0.0 || p[8] != 0.0 || p[9] != 0.0);
    if (on) {                                                                /* nodes.GlossyNode: anisotropic */
        double T[3] = {p[7], p[8], p[9]}, r = lobe[MF_ALPHA];
        if (p[6] != 0.0) rotate_around_axis(p + 7, sd->glossy != NULL ? sd->glossy : sd->N, p[6] * 2.0 * PI, T);
        anisotropic_lobe(lobe, a < 0.0 ? r / (1.0 + a) : r * (1.0 - a), a < 0.0 ? r * (1.0 + a) : r / (1.0 - a), T);
    }
    int distribution = (int)p[10];
    int kind = distribution == DISTRIBUTION_BECKMANN ? BSDF_BECKMANN
             : distribution == DISTRIBUTION_ASHIKHMIN_SHIRLEY ? BSDF_ASHIKHMIN_SHIRLEY : BSDF_MICROFACET;
    if (kind == BSDF_ASHIKHMIN_SHIRLEY) {                 /* alphas raised to the model's least */
        lobe[MF_ALPHA] = at_least(lobe[MF_ALPHA], AS_ALPHA_MIN);
        if (on) lobe[MF_ALPHA_Y] = at_least(lobe[MF_ALPHA_Y], AS_ALPHA_MIN);
    }
    lobe_add_as(sd, mu, w, lobe, NULL, p[1] != 0.0 && distribution == DISTRIBUTION_GGX ? Fss : NULL, kind);
}

INLINE void sheen_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                       const double *p)
{
    (void)mu; (void)backfacing;
    if (p[1] != 0.0) {                                          /* Ashikhmin velvet */
        double v[STORAGE_STRIDE] = {0.0};
        velvet_params(p[0], v);
        closure_add(sd, BSDF_VELVET, weight, weight, 1.0, v);
    } else {
        sheen_add(sd, wo, sd->N, weight, clamp01(p[0]));
    }
}

INLINE void glass_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                       const double *p)
{
    (void)wo;
    /* A caustics filter takes away the reflection or the refraction (tints of 0). */
    int reflective = !(sd->caustics & FILTER_REFLECTIVE), refractive = !(sd->caustics & FILTER_REFRACTIVE);
    double g[STORAGE_STRIDE], zero[3] = {0.0, 0.0, 0.0}, reflect_tint[3], transmit_tint[3];
    for (int j = 0; j < 3; j++) {
        double color = at_least(p[j], 0.0);
        reflect_tint[j] = reflective ? color : 0.0;
        transmit_tint[j] = refractive ? color : 0.0;
    }
    double ior = at_least(p[3], 1e-5);
    int refraction_only = p[4] != 0.0;
    if (refraction_only ? !refractive : !(reflective || refractive)) return;
    if (refraction_only) glass_params(g, backfacing, ior, FRESNEL_SCHLICK_IOR, zero, zero, zero, transmit_tint);
    else glass_params(g, backfacing, ior, FRESNEL_DIELECTRIC, zero, zero, reflect_tint, transmit_tint);
    int beckmann = (int)p[7] == DISTRIBUTION_BECKMANN;
    glass_add_as(sd, mu, weight, g, p[5], p[6] != 0.0 && !refraction_only && !beckmann ? transmit_tint : NULL,
                 beckmann ? BSDF_BECKMANN_GLASS : BSDF_ROUGH_GLASS);
}

INLINE void emission_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                          const double *p)
{
    (void)mu; (void)wo; (void)backfacing;
    for (int j = 0; j < 3; j++) sd->emission[j] += weight[j] * p[j];
}

INLINE void transparent_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                             const double *p)
{
    (void)mu; (void)wo; (void)backfacing; (void)p;
    for (int j = 0; j < 3; j++) sd->transparency[j] += weight[j];
}

/* portal.PortalNode.setup for one hit: one Portal closure of the node's weight (p: position_set, position, direction);
 * sd->portal adds its weight even where sd has no room for closures (a shadow ray's: portal.shadow_transparency). */
INLINE void ray_portal_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                            const double *p)
{
    (void)mu; (void)wo; (void)backfacing;
    double v[STORAGE_STRIDE] = {0.0};
    for (int j = 0; j < 7; j++) v[j] = p[j];
    if (fabs((weight[0] + weight[1] + weight[2]) / 3.0) >= WEIGHT_CUTOFF)
        for (int j = 0; j < 3; j++) sd->portal[j] += weight[j];
    closure_add(sd, BSDF_PORTAL, weight, weight, 1.0, v);
}

INLINE void holdout_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                         const double *p)
{
    (void)mu; (void)wo; (void)backfacing; (void)p;
    for (int j = 0; j < 3; j++) sd->holdout[j] += weight[j];
}

/* Node.setup of a node that adds one closure of BSDF kind `kind` (its `bsdf`), weighted by the node's weight, with
 * the hit's normal, unless the caustics switches take closures of that kind away. */
/* toon.ToonNode.setup for one hit: a Diffuse or Glossy Toon closure (p: size, smooth, glossy), its Size and Smooth
 * as angles (toon.params_of); the caustics switches take the Glossy one away as any glossy reflection. */
INLINE void toon_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                      const double *p)
{
    (void)mu; (void)wo; (void)backfacing;
    int kind = p[2] != 0.0 ? BSDF_GLOSSY_TOON : BSDF_DIFFUSE_TOON;
    if (caustics_take(kind, sd->caustics)) return;
    double v[STORAGE_STRIDE] = {0.0};
    v[TOON_MAX_ANGLE] = (p[0] < 1e-5 ? 1e-5 : (p[0] > 1.0 ? 1.0 : p[0])) * (PI / 2.0);
    v[TOON_SMOOTH] = clamp01(p[1]) * (PI / 2.0);
    closure_add(sd, kind, weight, weight, 1.0, v);
}

/* subsurface.SubsurfaceNode: one BSSRDF of weight x Color (subsurface_add), radius Radius x Scale, the entry's alpha
   its Roughness. */
INLINE void subsurface_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                            const double *p)
{
    (void)mu; (void)wo; (void)backfacing;
    double w[3], radius[3];
    for (int k = 0; k < 3; k++) { w[k] = weight[k] * p[k]; radius[k] = p[3 + k] * p[6]; }
    subsurface_add(sd, w, radius, p, p[9], p[7], clamp01(p[8]), p[10]);
}

/* hair.sigma_from_reflectance for one channel. */
INLINE double hair_sigma_from_reflectance(double color, double radial)
{
    double x = radial;
    double scale = (((((0.245 * x) + 5.574) * x - 10.73) * x + 2.532) * x - 0.215) * x + 5.969;
    double sigma = log(color > 1e-30 ? color : 1e-30) / scale;
    return sigma * sigma;
}

INLINE double hair_variance_of(double r)
{
    double a = 0.726 * r + 0.812 * r * r + 3.7 * pow(r, 20);
    return a * a;
}

INLINE double hair_clip(double x) { return x < 0.001 ? 0.001 : (x > 1.0 ? 1.0 : x); }

/* hair.hair_sigma: the absorption of the Principled Hair BSDF's inputs by its parametrisation, the colours' fit read
 * at the azimuthal roughness `radial` (Chiang's Radial Roughness, Huang's Roughness). */
static NOINLINE void hair_sigma(const double *p, double radial, double *sigma)
{
    static const double eumelanin[3] = {0.506, 0.841, 1.653}, pheomelanin[3] = {0.343, 0.733, 1.924};
    double random = p[16];
    int kind = (int)p[0];
    double melanin = p[4] * (1.0 + 2.0 * (random - 0.5) * clamp01(p[15]));
    melanin = -log(at_least(1.0 - melanin, 0.0001));
    double eu = melanin * (1.0 - p[5]), pheo = melanin * p[5];
    for (int k = 0; k < 3; k++) {
        double pigment = (eu * eumelanin[k] + pheo * pheomelanin[k]) + hair_sigma_from_reflectance(p[6 + k], radial);
        sigma[k] = kind == HAIR_PARAMETRIZATION_ABSORPTION ? p[17 + k]
                   : (kind == HAIR_PARAMETRIZATION_MELANIN ? pigment : hair_sigma_from_reflectance(p[1 + k], radial));
    }
}

/* hair.surface_tangent: a triangle's edge (p + at: the node's surface_tangent, zero on curves) turned to the viewer's
 * side where met from behind, into S; whether the hit is on a triangle (its back faces scatter as its front). */
static NOINLINE int hair_surface_tangent(const double *p, int at, int backfacing, double *S)
{
    for (int k = 0; k < 3; k++) S[k] = backfacing ? -p[at + k] : p[at + k];
    return S[0] != 0.0 || S[1] != 0.0 || S[2] != 0.0;
}

/* hair.fibre_normal for the closure closure_add set up in slot `slot` (if it did) on a triangle: its normal Cycles'
 * bsdf->N, the fibre frame's axis across the tangent and the view (unless degenerate). */
static NOINLINE void hair_fibre_normal(ShaderResult *sd, int slot, const double *axis)
{
    if (sd->n <= slot || (axis[0] == 0.0 && axis[1] == 0.0 && axis[2] == 0.0)) return;
    for (int k = 0; k < 3; k++) sd->c[slot].N[k] = axis[k];
}

/* hair.PrincipledHairNode.setup (hair.chiang_params) for one hit: a Chiang closure of the node's weight; h from the
 * hit's normal sd->N (Cycles' Ng of a thick curve), the curve's tangent and the view; on a triangle from its dPdu
 * and dPdv (p + 23, p + 26). */
INLINE void principled_hair_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                                 const double *p)
{
    (void)mu;
    double S[3];
    int mesh = hair_surface_tangent(p, 23, backfacing, S);
    if (backfacing && !mesh) {  /* hair.through_own_fibre: from inside its tube a ray goes on straight through */
        for (int k = 0; k < 3; k++) sd->transparency[k] += weight[k];
        return;
    }
    double v[STORAGE_STRIDE] = {0.0};
    double random = p[16];
    double factor = 1.0 + 2.0 * (random - 0.5) * p[14];
    double roughness = p[9] * factor, radial = p[10] * factor;
    hair_sigma(p, radial, v + HAIR_SIGMA);
    double rv = hair_clip(roughness), rs = hair_clip(radial);
    double m0 = hair_clip((1.0 - clamp01(p[11])) * rv);
    double X[3], Y[3], Z[3], c[3];
    hair_normalize(mesh ? S : p + 20, X);                 /* (a triangle: Cycles' dPdu) */
    if (X[0] == 0.0 && X[1] == 0.0 && X[2] == 0.0) {     /* (a degenerate triangle: a tangent across the normal) */
        double b[3];
        orthonormal_frame(sd->N, X, b);
    }
    cross3(X, wo, c);
    hair_normalize(c, Y);
    cross3(X, Y, c);
    hair_normalize(c, Z);
    v[HAIR_V] = hair_variance_of(rv);
    v[HAIR_S] = (0.265 * rs + 1.194 * rs * rs + 5.372 * pow(rs, 22)) * HAIR_SQRT_PI_8;
    v[HAIR_M0] = hair_variance_of(m0);
    v[HAIR_ALPHA] = -p[13];
    v[HAIR_ETA] = p[12];
    double Ng[3] = {sd->N[0], sd->N[1], sd->N[2]};
    if (mesh) {             /* (a triangle: h from its true normal dPdu x dPdv, towards the viewer) */
        double n[3];
        cross3(p + 23, p + 26, c);
        hair_normalize(c, n);
        double side = dot3(n, wo) < 0.0 ? -1.0 : 1.0;
        if (n[0] != 0.0 || n[1] != 0.0 || n[2] != 0.0)
            for (int k = 0; k < 3; k++) Ng[k] = side * n[k];
    }
    cross3(Ng, X, c);
    v[HAIR_H] = dot3(c, Z);
    for (int k = 0; k < 3; k++) v[HAIR_X + k] = X[k];
    int before = sd->n;
    closure_add(sd, BSDF_CHIANG_HAIR, weight, weight, 1.0, v);
    if (mesh) hair_fibre_normal(sd, before, Y);
}

/* huang.HuangHairNode.setup (huang.huang_params) for one hit: a Huang closure of the node's weight, none where its
 * three lobes are 0, transparent outside the elliptical fibre's projected width. */
INLINE void principled_hair_huang_node(ShaderResult *sd, double mu, const double *wo, int backfacing,
                                       const double *weight, const double *p)
{
    (void)mu;
    double S[3];
    int mesh = hair_surface_tangent(p, 31, backfacing, S);
    if (backfacing && !mesh) {  /* hair.through_own_fibre */
        for (int k = 0; k < 3; k++) sd->transparency[k] += weight[k];
        return;
    }
    if (!(p[24] > 0.0 || p[25] > 0.0 || p[26] > 0.0)) return;
    double v[STORAGE_STRIDE] = {0.0};
    double random = p[16];
    double roughness = p[9] * (1.0 + 2.0 * (random - 0.5) * p[14]);
    hair_sigma(p, roughness, v + HUANG_SIGMA);
    double Y[3], X[3], A[3], Z[3], c[3], d[3], tmp[3];
    hair_normalize(mesh ? S : p + 20, Y);                 /* (a triangle: Cycles' dPdu, a round fibre) */
    int none = (Y[0] == 0.0 && Y[1] == 0.0 && Y[2] == 0.0) || mesh;
    if (Y[0] == 0.0 && Y[1] == 0.0 && Y[2] == 0.0) orthonormal_frame(sd->N, Y, tmp);
    cross3(Y, wo, c);
    hair_normalize(c, X);
    double h = -dot3(X, sd->N);
    double b = p[23];
    int elliptic = b != 1.0 && !none;
    if (elliptic) {
        cross3(p + 27, Y, c);
        hair_normalize(c, d);
        cross3(Y, d, c);
        hair_normalize(c, A);
        if (b > 1.0) {
            b = 1.0 / (b == 0.0 ? 1.0 : b);
            double minor[3];
            cross3(Y, A, c);
            hair_normalize(c, minor);
            cross3(minor, Y, c);
            hair_normalize(c, A);
        }
    } else {
        for (int k = 0; k < 3; k++) A[k] = X[k];
    }
    if ((A[0] == 0.0 && A[1] == 0.0 && A[2] == 0.0) || !isfinite(A[0]) || !isfinite(A[1]) || !isfinite(A[2]))
        orthonormal_frame(Y, A, tmp);
    cross3(A, Y, c);
    hair_normalize(c, Z);
    double I[3] = {dot3(wo, A), dot3(wo, Y), dot3(wo, Z)};
    double radius = huang_radius(b, I);
    if (fabs(h) >= radius) {         /* outside the fibre: Cycles' transparent closure */
        for (int k = 0; k < 3; k++) sd->transparency[k] += weight[k];
        return;
    }
    v[HUANG_ROUGH] = roughness < 0.001 ? 0.001 : (roughness > 1.0 ? 1.0 : roughness);
    v[HUANG_TILT] = -p[13];
    v[HUANG_ETA] = p[12];
    v[HUANG_B] = b;
    v[HUANG_H] = h;
    for (int k = 0; k < 3; k++) {
        v[HUANG_R + k] = at_least(p[24 + k], 0.0);
        v[HUANG_X + k] = A[k]; v[HUANG_Y + k] = Y[k];
    }
    v[HUANG_COVERAGE] = p[30] > 0.0 ? p[30] : 1.0;
    int before = sd->n;
    closure_add(sd, BSDF_HUANG_HAIR, weight, weight, 1.0, v);
    if (mesh) hair_fibre_normal(sd, before, A);
}

/* hair.HairNode.setup for one hit: a Reflection or Transmission closure (p: offset, roughness_u, roughness_v,
 * tangent, transmission) of the node's weight. */
INLINE void hair_node(ShaderResult *sd, double mu, const double *wo, int backfacing, const double *weight,
                      const double *p)
{
    (void)mu; (void)wo;
    double S[3];
    int mesh = hair_surface_tangent(p, 10, backfacing, S);
    if (backfacing && !mesh) {  /* hair.through_own_fibre */
        for (int k = 0; k < 3; k++) sd->transparency[k] += weight[k];
        return;
    }
    double v[STORAGE_STRIDE] = {0.0}, T[3];
    hair_normalize(p + 3, T);
    int none = T[0] == 0.0 && T[1] == 0.0 && T[2] == 0.0;
    v[HAIR_RU] = hair_clip(p[1]);
    v[HAIR_RV] = hair_clip(p[2]);
    v[HAIR_OFFSET] = none ? 0.0 : -p[0];
    if (none) hair_normalize(S, T);                      /* (a triangle's dPdv, no offset) */
    if (T[0] == 0.0 && T[1] == 0.0 && T[2] == 0.0) {
        double b[3];
        orthonormal_frame(sd->N, T, b);
    }
    for (int k = 0; k < 3; k++) v[HAIR_T + k] = T[k];
    double w[3];
    for (int k = 0; k < 3; k++) w[k] = weight[k] * at_least(p[7 + k], 0.0);
    closure_add(sd, p[6] != 0.0 ? BSDF_HAIR_TRANSMISSION : BSDF_HAIR_REFLECTION, w, w, 1.0, v);
}

INLINE void closure_node(ShaderResult *sd, int kind, const double *weight)
{
    if (!caustics_take(kind, sd->caustics)) closure_add(sd, kind, weight, weight, 1.0, NULL);
}

/* setup_node: the switch on a node's kind (generated from core/materials/registry.py NODE_TYPES). */
#include "nodes.gen.c"

/* nodes.ClosureBuilder.result: the light let through, as a Transparent closure. */
INLINE void add_transparent(ShaderResult *sd)
{
    if (sd->transparency[0] != 0.0 || sd->transparency[1] != 0.0 || sd->transparency[2] != 0.0)
        closure_add(sd, BSDF_TRANSPARENT, sd->transparency, sd->transparency, 1.0, NULL);
}

/* nodes.shade_nodes for one hit: every node of the material sets up its closures. */
INLINE void shade_nodes(const MaterialRecord *m, const double *N, const double *wo, int backfacing, ShaderResult *sd)
{
    double mu = dot3(N, wo);
    sd->n = 0;
    sd->glossy = NULL;
    sd->hit_N = NULL;
    for (int j = 0; j < 3; j++) { sd->emission[j] = sd->transparency[j] = sd->holdout[j] = 0.0; sd->N[j] = N[j]; }
    sd->portal[0] = sd->portal[1] = sd->portal[2] = 0.0;
    for (int k = 0; k < (int)m->n; k++)
        setup_node(sd, (int)m->kind[k], mu, wo, backfacing, m->weight + 3 * k, m->p + (int64_t)NODE_PARAMS * k);
    add_transparent(sd);
}

/* graph.aov_values: a program's AOV Output rows (`outputs`, `count` of them, OUT_AOV ones written) read from its
 * registers `reg`, added into the shader AOVs `into` (a COLOR AOV its Color and 1 into its alpha, a VALUE AOV its
 * Value). */
INLINE void add_aovs(const double *outputs, int64_t count, const double *reg, double *into)
{
    for (int64_t o = 0; o < count; o++) {
        const double *out = outputs + 5 * o;
        if ((int)out[0] != OUT_AOV) continue;
        for (int j = 0; j < (int)out[3]; j++) into[(int64_t)out[1] + j] += reg[(int64_t)out[4] + j];
        if ((int)out[3] == 3) into[(int64_t)out[1] + 3] += 1.0;
    }
}

/* NodeShader.shade with a program: the node graph runs at the hit (graph.c), its outputs replace the
 * nodes' linked inputs, multiply their weights and give them their own normals (graph.apply_outputs);
 * then every node sets up its closures with its normal; sd->N stays the hit's (Cycles' sd->N: a Set Normal output
 * replaces it), which bump shadowing (bsdf.c) compares the closures' normals with. One node at a time (each output changes
 * only its own node), so that a material may have any number of nodes. emission_only: only sd->emission is wanted
 * (a light sample, a ray that lands on an emitter): only the ops and nodes it depends on run
 * (GraphTables.emission_ops and emission_nodes, graph.emission_live); the other closures are left out. */
NOINLINE static void shade_graph(const GraphTables *G, const MaterialRecord *m, const ShadingPoint *sp, const double *N,
                        const double *wo, int backfacing, int emission_only, ShaderResult *sd)
{
    double reg[MAX_REGISTERS], weight[3], p[NODE_PARAMS], normal[3], glossy[3], hit[3];
    int n = (int)m->n, program = (int)m->graph - 1;
    const double *info = G->programs + PROGRAM_INFO * program;
    const double *emits = emission_only ? G->emission_nodes + (int64_t)info[8] : NULL;   /* [Set Normal, nodes] */
    run_program(G, program, sp, emission_only ? G->emission_ops : NULL, reg);
    const double *outputs = G->outputs + 5 * (int64_t)info[5];
    /* Set Normal (a normal output to node -1): the hit's own normal from here on, where the graph gives one. */
    for (int64_t o = 0; o < (int64_t)info[6]; o++) {
        const double *out = outputs + 5 * o;
        if ((int)out[1] >= 0 || (emits != NULL && emits[0] == 0.0)) continue;
        for (int j = 0; j < 3; j++) hit[j] = reg[(int64_t)out[4] + j];
        safe_normalize3(hit);
        if (hit[0] != 0.0 || hit[1] != 0.0 || hit[2] != 0.0) N = hit;
    }
    sd->n = 0;
    sd->portal[0] = sd->portal[1] = sd->portal[2] = 0.0;
    for (int j = 0; j < 3; j++) sd->emission[j] = sd->transparency[j] = sd->holdout[j] = 0.0;
    /* The AOV Output nodes into the hit's shader AOVs, where it writes them. */
    if (sp->aov != NULL && emits == NULL) add_aovs(outputs, (int64_t)info[6], reg, sp->aov);
    for (int k = 0; k < n; k++) {
        int own = 0;
        if (emits != NULL && emits[1 + k] == 0.0) continue;
        for (int j = 0; j < 3; j++) weight[j] = m->weight[3 * k + j];
        for (int j = 0; j < NODE_PARAMS; j++) p[j] = m->p[(int64_t)NODE_PARAMS * k + j];
        for (int64_t o = 0; o < (int64_t)info[6]; o++) {
            const double *out = outputs + 5 * o;
            if ((int)out[1] != k || (int)out[0] == OUT_AOV) continue;
            int kind = (int)out[0], slot = (int)out[2], width = (int)out[3];
            const double *value = reg + (int64_t)out[4];
            if (kind == OUT_INPUT) {
                for (int j = 0; j < width; j++) p[slot + j] = value[j];
            } else if (kind == OUT_WEIGHT) {
                for (int j = 0; j < 3; j++) {
                    double v = value[width == 3 ? j : 0];
                    double f = slot == 0 ? clamp01(v) : (slot == 1 ? 1.0 - clamp01(v) : at_least(v, 0.0));
                    weight[j] *= f;
                }
            } else if (slot == 0) {
                own = 1;
                for (int j = 0; j < 3; j++) normal[j] = value[j];
                safe_normalize3(normal);
            } else {                                /* a normal input (Coat Normal) into the row, zero kept zero */
                double *into = p + slot;
                for (int j = 0; j < 3; j++) into[j] = value[j];
                safe_normalize3(into);
                if ((into[0] != 0.0 || into[1] != 0.0 || into[2] != 0.0) && !m->uncorrected)
                    valid_reflection(sp->Ng, wo, into);
            }
        }
        if (own) {
            for (int j = 0; j < 3; j++) glossy[j] = normal[j];
            if (!m->uncorrected) valid_reflection(sp->Ng, wo, glossy);
        }
        const double *Nk = own ? normal : N, *Gk = own ? glossy : N;
        for (int j = 0; j < 3; j++) sd->N[j] = Nk[j];
        sd->glossy = own ? glossy : NULL;
        sd->hit_N = N;
        setup_node(sd, (int)m->kind[k], dot3(Gk, wo), wo, backfacing, weight, p);
    }
    sd->glossy = NULL;
    sd->hit_N = NULL;
    for (int j = 0; j < 3; j++) sd->N[j] = N[j];
    add_transparent(sd);
}

/* A material at a hit: its constant closures, or its nodes set up for this view direction. */
INLINE void shade_material(const MaterialRecord *m, const double *N, const double *wo, int backfacing,
                           ShaderResult *sd)
{
    sd->uncorrected = m->uncorrected;
    if (m->program != 0.0) shade_nodes(m, N, wo, backfacing, sd);
    else shade_constant(m, N, sd);
}

/* The material at a hit as the chunk shades it: a material with a node graph reads the hit's
 * ShadingPoint (triangles.c), with `path` the path that reached it, and runs its program; any other material as
 * shade_material (it reads no path). keys: what its Ambient Occlusion and Bevel nodes trace with (triangles.c
 * ShaderKeys), or NULL where shaders trace nothing (shadow rays, light samples: as Cycles). emission_only: only
 * sd->emission is read afterwards (shade_graph). */
INLINE void shade_hit(const GraphTables *G, const GeometryTables *g, const MaterialRecord *m, const Triangle *tri,
                      const Surface *s, int64_t geometry, int64_t prim, int64_t instance, double u, double v,
                      const double *wo, const LightPath *path, const ShaderKeys *keys, int emission_only,
                      ShaderResult *sd)
{
    /* (the object's Shading Offset bends the cosine of every closure's light: closures.terminator_term) */
    sd->terminator = terminator_multiplier_of(g, geometry, prim, instance);
    sd->uncorrected = m->uncorrected;
    if (m->graph == 0.0 || G == NULL) {
        shade_material(m, s->N, wo, s->backfacing, sd);
        return;
    }
    ShadingPoint sp;
    shading_point_at(g, geometry, prim, instance, tri, s, u, v, &sp);
    sp.aov = keys != NULL ? keys->aov : NULL;
    sp.path = *path;
    for (int c = 0; c < 3; c++) sp.I[c] = wo[c];
    if (keys != NULL) {
        sp.rays = keys->rays;
        sp.pixel = keys->pixel;
        sp.sample = keys->sample;
        sp.dimension = keys->dimension;
        sp.blurry = keys->blurry;
    }
    shade_graph(G, m, &sp, s->N, wo, s->backfacing, emission_only, sd);
}
