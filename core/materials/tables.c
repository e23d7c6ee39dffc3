/* The precomputed tables the BSDFs and nodes read (ggx_tables.h: GGX albedos; the sheen's in sheen.c) and their
 * lookups, core/materials/ggx_tables.py's lookup_*d. */

#include "ggx_tables.h"

/* ggx_tables.lookup_*: linear interpolation between grid points i / (size - 1), clamped to 0..1. */
INLINE void table_position(double x, int size, int *i, int *j, double *t)
{
    x = (x != x) ? 0.0 : clamp01(x) * (size - 1);
    *i = (int)x < size - 1 ? (int)x : size - 1;
    *j = *i + 1 < size - 1 ? *i + 1 : size - 1;
    *t = x - *i;
}

INLINE double lookup_1d(const double *table, int size, double x)
{
    int i, j; double t;
    table_position(x, size, &i, &j, &t);
    return (1.0 - t) * table[i] + t * table[j];
}

INLINE double lookup_2d(const double *table, int nx, int ny, double x, double y)
{
    int yi, yj, xi, xj; double ty, tx;
    table_position(y, ny, &yi, &yj, &ty);
    table_position(x, nx, &xi, &xj, &tx);
    double a = (1.0 - tx) * table[yi * nx + xi] + tx * table[yi * nx + xj];
    double b = (1.0 - tx) * table[yj * nx + xi] + tx * table[yj * nx + xj];
    return (1.0 - ty) * a + ty * b;
}

INLINE double lookup_3d(const double *table, int n, double x, double y, double z)
{
    int zi, zj; double tz;
    table_position(z, n, &zi, &zj, &tz);
    return (1.0 - tz) * lookup_2d(table + zi * n * n, n, n, x, y) + tz * lookup_2d(table + zj * n * n, n, n, x, y);
}

