/* core/materials/procedural/brick.py BrickTexture.evaluate at one hit: a[0] the output block (Colour, Fac), a[1]
 * Vector, a[2] Color1, a[3] Color2, a[4] Mortar, a[5] Scale, a[6] Mortar Size, a[7] Mortar Smooth, a[8] Bias,
 * a[9] Brick Width, a[10] Row Height, a[11] Offset, a[12] Squash; a[13] the offset frequency, a[14] the squash
 * frequency. */

/* brick.py brick_noise: a fast integer hash to [0, 1). */
INLINE float brick_noise(uint32_t n)
{
    n = (n + 1013u) & 0x7FFFFFFFu;
    n = (n >> 13) ^ n;
    uint32_t nn = (n * (n * n * 60493u + 19990303u) + 1376312589u) & 0x7FFFFFFFu;
    return 0.5f * ((float)nn / 1073741824.0f);
}

/* brick.py smoothstep. */
INLINE float brick_smoothstep(float f)
{
    if (f <= 0.0f) return 0.0f;
    if (f >= 1.0f) return 1.0f;
    float ff = f * f;
    return 3.0f * ff - 2.0f * ff * f;
}

NOINLINE static void brick_texture(const int *a, double *reg)
{
    int offset_frequency = a[13], squash_frequency = a[14];
    float scale = (float)reg[a[5]], mortar_size = (float)reg[a[6]], mortar_smooth = (float)reg[a[7]];
    float bias = (float)reg[a[8]], width = (float)reg[a[9]], row_height = (float)reg[a[10]];
    float offset_amount = (float)reg[a[11]], squash = (float)reg[a[12]];
    float px = (float)reg[a[1]] * scale, py = (float)reg[a[1] + 1] * scale, offset = 0.0f;
    int row = (int)floorf(py / row_height);
    if (offset_frequency && squash_frequency) {
        width *= (row % squash_frequency) ? 1.0f : squash;
        offset = (row % offset_frequency) ? 0.0f : width * offset_amount;
    }
    int column = (int)floorf((px + offset) / width);
    float x = (px + offset) - width * (float)column, y = py - row_height * (float)row;
    float tint = brick_noise(((uint32_t)row << 16) + (uint32_t)(column & 0xFFFF)) + bias;
    tint = tint < 0.0f ? 0.0f : (tint > 1.0f ? 1.0f : tint);
    float near_xy = x < y ? x : y, far_x = width - x, far_y = row_height - y;
    float near_far = far_x < far_y ? far_x : far_y;
    float nearest = near_xy < near_far ? near_xy : near_far;
    float fac;
    if (nearest >= mortar_size) fac = 0.0f;
    else if (mortar_smooth == 0.0f) fac = 1.0f;
    else fac = brick_smoothstep((1.0f - nearest / mortar_size) / mortar_smooth);
    double *out = reg + a[0];
    for (int k = 0; k < 3; k++) {
        float c1 = (float)reg[a[2] + k], c2 = (float)reg[a[3] + k], mortar = (float)reg[a[4] + k];
        if (fac != 1.0f) c1 = (1.0f - tint) * c1 + tint * c2;
        out[k] = (double)(c1 * (1.0f - fac) + mortar * fac);
    }
    out[3] = (double)fac;
}
