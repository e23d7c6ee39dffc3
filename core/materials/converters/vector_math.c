/* core/materials/converters/vector_math.py VectorMath.evaluate at one hit: a[0] the output block (Vector, Value),
 * a[1] A, a[2] B, a[3] C, a[4] Scale, a[5] the operation (VECTOR_MATH_OPS). */

/* vector_math.dot: x, y, then z, in float32. */
INLINE float dot3f(const float *a, const float *b) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }

/* vector_math.safe_normalize: v x (1 / |v|) in place, v left as it is where |v| is 0. */
INLINE void safe_normalize3f(float *v)
{
    float t = sqrtf(dot3f(v, v));
    if (t != 0.0f) { float s = 1.0f / t; v[0] *= s; v[1] *= s; v[2] *= s; }
}

/* vector_math.safe_pow for one component. */
INLINE float safe_powf_(float a, float b)
{
    if (a < 0.0f && b != truncf(b)) return 0.0f;
    if (b == 0.0f) return 1.0f;
    if (a == 0.0f) return 0.0f;
    return (float)pow((double)a, (double)b);
}

INLINE void vector_math_texture(const int *a, double *reg)
{
    float A[3], B[3], C[3], v[3] = {0.0f, 0.0f, 0.0f}, value = 0.0f, scale = (float)reg[a[4]];
    for (int k = 0; k < 3; k++) { A[k] = (float)reg[a[1] + k]; B[k] = (float)reg[a[2] + k]; C[k] = (float)reg[a[3] + k]; }
    switch (a[5]) {
    case 0: for (int k = 0; k < 3; k++) v[k] = A[k] + B[k]; break;
    case 1: for (int k = 0; k < 3; k++) v[k] = A[k] - B[k]; break;
    case 2: for (int k = 0; k < 3; k++) v[k] = A[k] * B[k]; break;
    case 3: for (int k = 0; k < 3; k++) v[k] = B[k] != 0.0f ? A[k] / B[k] : 0.0f; break;
    case 4: for (int k = 0; k < 3; k++) v[k] = A[k] * B[k] + C[k]; break;
    case 5:
        v[0] = A[1] * B[2] - A[2] * B[1]; v[1] = A[2] * B[0] - A[0] * B[2]; v[2] = A[0] * B[1] - A[1] * B[0];
        break;
    case 6: {
        float l2 = dot3f(B, B), f = l2 != 0.0f ? dot3f(A, B) / l2 : 0.0f;
        for (int k = 0; k < 3; k++) v[k] = f * B[k];
        break;
    }
    case 7: {
        safe_normalize3f(B);
        float d = dot3f(A, B);
        for (int k = 0; k < 3; k++) v[k] = A[k] - (2.0f * B[k]) * d;
        break;
    }
    case 8: {
        safe_normalize3f(B);
        float d = dot3f(B, A), k2 = 1.0f - scale * scale * (1.0f - d * d);
        if (k2 >= 0.0f) {
            float m = scale * d + sqrtf(k2);
            for (int k = 0; k < 3; k++) v[k] = scale * A[k] - m * B[k];
        }
        break;
    }
    case 9: { float s = dot3f(C, B) < 0.0f ? 1.0f : -1.0f; for (int k = 0; k < 3; k++) v[k] = s * A[k]; break; }
    case 10: value = dot3f(A, B); break;
    case 11: { float d[3] = {A[0] - B[0], A[1] - B[1], A[2] - B[2]}; value = sqrtf(dot3f(d, d)); break; }
    case 12: value = sqrtf(dot3f(A, A)); break;
    case 13: for (int k = 0; k < 3; k++) v[k] = A[k] * scale; break;
    case 14: for (int k = 0; k < 3; k++) v[k] = A[k]; safe_normalize3f(v); break;
    case 15: for (int k = 0; k < 3; k++) v[k] = fabsf(A[k]); break;
    case 16: for (int k = 0; k < 3; k++) v[k] = safe_powf_(A[k], B[k]); break;
    case 17: for (int k = 0; k < 3; k++) v[k] = A[k] == 0.0f ? 0.0f : (A[k] < 0.0f ? -1.0f : 1.0f); break;
    case 18: for (int k = 0; k < 3; k++) v[k] = A[k] < B[k] ? A[k] : B[k]; break;
    case 19: for (int k = 0; k < 3; k++) v[k] = A[k] > B[k] ? A[k] : B[k]; break;
    case 20: for (int k = 0; k < 3; k++) v[k] = floorf(A[k]); break;
    case 21: for (int k = 0; k < 3; k++) v[k] = ceilf(A[k]); break;
    case 22: for (int k = 0; k < 3; k++) v[k] = A[k] - floorf(A[k]); break;
    case 23: for (int k = 0; k < 3; k++) v[k] = B[k] != 0.0f ? fmodf(A[k], B[k]) : 0.0f; break;
    case 24:
        for (int k = 0; k < 3; k++) {
            float x = A[k] - C[k], span = B[k] - C[k];
            v[k] = (span != 0.0f ? x - floorf(x / span) * span : 0.0f) + C[k];
        }
        break;
    case 25: for (int k = 0; k < 3; k++) v[k] = floorf(B[k] != 0.0f ? A[k] / B[k] : 0.0f) * B[k]; break;
    case 26: for (int k = 0; k < 3; k++) v[k] = (float)sin((double)A[k]); break;
    case 27: for (int k = 0; k < 3; k++) v[k] = (float)cos((double)A[k]); break;
    case 28: for (int k = 0; k < 3; k++) v[k] = (float)tan((double)A[k]); break;
    default: for (int k = 0; k < 3; k++) v[k] = floorf(A[k] + 0.5f); break;     /* Round */
    }
    double *out = reg + a[0];
    out[0] = v[0]; out[1] = v[1]; out[2] = v[2]; out[3] = value;
}
