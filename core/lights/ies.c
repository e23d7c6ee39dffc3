/* A lamp's IES Texture (core/lights/ies.py IESLamp): the profile (core/materials/ies.c) in the lamp's frame. */

/* Light.falloff_factor: what a lamp's Light Falloff node multiplies the light it sends over distance t by: t^power,
 * times t^2 / (Smooth + t^2) where Smooth > 0 (Cycles' svm_node_light_falloff with the sample's ray length); 1
 * without one or at an infinite t. */
static inline double lamp_falloff(const LightRecord *light, double t)
{
    if (light->has_falloff == 0 || !(t < INFINITY)) return 1.0;
    double factor = light->falloff_power == 0.0 ? 1.0 : light->falloff_power == 1.0 ? t : t * t;
    if (light->falloff_smooth > 0.0) factor *= t * t / (light->falloff_smooth + t * t);
    return factor;
}

/* IESLamp.factor: what a lamp's IES Texture multiplies the light it sends towards a point by, `towards` the world
 * direction from that point to the lamp (the light leaves along -towards): 1 without one; Strength x 100 for a file
 * Cycles could not read. */
static inline double ies_lamp_factor(const LightRecord *light, const double *towards)
{
    if (light->has_ies == 0) return 1.0;
    if (light->ies == NULL) return light->ies_strength;
    const double *M = light->ies_frame;
    double local[3];
    for (int c = 0; c < 3; c++) local[c] = -(M[3 * c] * towards[0] + M[3 * c + 1] * towards[1] + M[3 * c + 2] * towards[2]);
    return ies_fac(light->ies, light->ies_h, light->ies_v, light->ies_strength, local);
}
