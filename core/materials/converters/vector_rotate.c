/* core/materials/converters/vector_rotate.py VectorRotate.evaluate at one hit: a[0] the output Vector, a[1] Vector,
 * a[2] Center, a[3] Axis, a[4] Angle, a[5] Rotation, a[6] the type (ROTATION_TYPES), a[7] invert. */
INLINE void vector_rotate_texture(const int *a, double *reg)
{
    float v[3], c[3], p[3], r[3];
    for (int k = 0; k < 3; k++) { v[k] = (float)reg[a[1] + k]; c[k] = (float)reg[a[2] + k]; p[k] = v[k] - c[k]; }
    double *out = reg + a[0];
    if (a[6] == 4) {
        float e[3], co[3], si[3];
        for (int k = 0; k < 3; k++) {
            e[k] = (float)reg[a[5] + k];
            co[k] = (float)cos((double)e[k]);
            si[k] = (float)sin((double)e[k]);
        }
        float cx = co[0], cy = co[1], cz = co[2], sx = si[0], sy = si[1], sz = si[2];
        float M[3][3] = {{cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz},
                         {cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz},
                         {-sy, cy * sx, cy * cx}};
        for (int i = 0; i < 3; i++)
            r[i] = a[7] ? (M[0][i] * p[0] + M[1][i] * p[1]) + M[2][i] * p[2]
                        : (M[i][2] * p[2] + M[i][1] * p[1]) + M[i][0] * p[0];
        for (int k = 0; k < 3; k++) out[k] = r[k] + c[k];
        return;
    }
    float axis[3] = {0.0f, 0.0f, 0.0f}, norm = 1.0f;
    if (a[6] == 0) {
        for (int k = 0; k < 3; k++) axis[k] = (float)reg[a[3] + k];
        norm = sqrtf((axis[0] * axis[0] + axis[1] * axis[1]) + axis[2] * axis[2]);
    } else {
        axis[a[6] - 1] = 1.0f;
    }
    if (norm == 0.0f) { for (int k = 0; k < 3; k++) out[k] = v[k]; return; }
    for (int k = 0; k < 3; k++) axis[k] = axis[k] / norm;
    float angle = (float)reg[a[4]];
    if (a[7]) angle = -angle;
    float cs = (float)cos((double)angle), sn = (float)sin((double)angle), u = 1.0f - cs;
    float x = axis[0], y = axis[1], z = axis[2];
    r[0] = ((cs + u * x * x) * p[0] + (u * x * y - z * sn) * p[1]) + (u * x * z + y * sn) * p[2];
    r[1] = ((u * x * y + z * sn) * p[0] + (cs + u * y * y) * p[1]) + (u * y * z - x * sn) * p[2];
    r[2] = ((u * x * z - y * sn) * p[0] + (u * y * z + x * sn) * p[1]) + (cs + u * z * z) * p[2];
    for (int k = 0; k < 3; k++) out[k] = r[k] + c[k];
}
