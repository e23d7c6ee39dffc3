/* core/materials/converters/ies_texture.py IESTexture at one hit: a[0] the Fac, a[1] Strength, a[2] Vector, a[3] the
 * start of the profile's table in the program's table floats, a[4], a[5] its h and v angle counts (-1: no table,
 * Strength x IES_UNREAD_VALUE). The profile is evaluated by core/materials/ies.c. */
INLINE void ies_texture_texture(const int *a, double *reg, const double *tables)
{
    double strength = reg[a[1]];
    reg[a[0]] = a[4] < 0 ? strength * IES_UNREAD_VALUE : ies_fac(tables + a[3], a[4], a[5], strength, reg + a[2]);
}
