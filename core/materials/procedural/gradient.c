/* core/materials/procedural/gradient.py GradientTexture.evaluate at one hit: a[0] the output block (Colour, Fac),
 * a[1] Vector, a[2] the type (GRADIENT_TYPES). */
INLINE void gradient_texture(const int *a, double *reg)
{
    float x = (float)reg[a[1]], y = (float)reg[a[1] + 1], z = (float)reg[a[1] + 2], f;
    switch (a[2]) {
    case 0: f = x; break;
    case 1: { float r = x > 0.0f ? x : 0.0f; f = r * r; break; }
    case 2: {
        float r = x > 0.0f ? x : 0.0f;
        r = r < 1.0f ? r : 1.0f;
        float t = r * r;
        f = 3.0f * t - 2.0f * t * r;
        break;
    }
    case 3: f = (x + y) * 0.5f; break;
    case 4: f = (float)atan2((double)y, (double)x) / (float)(2.0 * PI) + 0.5f; break;
    default: {
        float r = 0.999999f - sqrtf(x * x + y * y + z * z);
        r = r > 0.0f ? r : 0.0f;
        f = a[2] == 5 ? r * r : r;
        break;
    }
    }
    f = f > 0.0f ? f : 0.0f;
    f = f < 1.0f ? f : 1.0f;
    double *out = reg + a[0];
    out[0] = out[1] = out[2] = out[3] = (double)f;
}
