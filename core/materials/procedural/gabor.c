/* core/materials/procedural/gabor.py GaborTexture.evaluate at one hit: a[0] the output block (Value, Phase,
 * Intensity), a[1] Vector, a[2] Scale, a[3] Frequency, a[4] Anisotropy, a[5] Orientation 2D, a[6] Orientation 3D;
 * a[7] the type (2D, 3D). */

#define GABOR_PI 3.14159265358979323846f

/* gabor.py kernel: the windowed Gaussian at squared distance d2 as a phasor of angle 2pi angle_dot. */
INLINE void gabor_kernel(float d2, float angle_dot, float *phasor)
{
    float hann = 0.5f + 0.5f * (float)cos((double)(GABOR_PI * d2));
    float envelope = (float)exp((double)(-GABOR_PI * d2)) * hann;
    float angle = 2.0f * GABOR_PI * angle_dot;
    phasor[0] = envelope * (float)cos((double)angle);
    phasor[1] = envelope * (float)sin((double)angle);
}

/* gabor.py noise_2d at one point. */
INLINE void gabor_noise_2d(const float *p, float frequency, float isotropy, float base, float *total)
{
    float cell[2] = {floorf(p[0]), floorf(p[1])}, local[2] = {p[0] - cell[0], p[1] - cell[1]};
    total[0] = total[1] = 0.0f;
    for (int j = -1; j <= 1; j++) {
        for (int i = -1; i <= 1; i++) {
            float cx = cell[0] + (float)i, cy = cell[1] + (float)j;
            float px = local[0] - (float)i, py = local[1] - (float)j, noise[2] = {0.0f, 0.0f}, phasor[2];
            for (int k = 0; k < 8; k++) {
                float seed = (float)(k * 3);
                float orientation = base + (hash_float3(cx, cy, seed) - 0.5f) * GABOR_PI * isotropy;
                float x = px - hash_float3(cx, cy, seed + 1.0f), y = py - hash_float3(seed + 1.0f, cx, cy);
                float d2 = x * x + y * y;
                if (!(d2 < 1.0f)) continue;
                float weight = hash_float3(cx, cy, seed + 2.0f) < 0.5f ? -1.0f : 1.0f;
                float fx = frequency * (float)cos((double)orientation), fy = frequency * (float)sin((double)orientation);
                gabor_kernel(d2, x * fx + y * fy, phasor);
                noise[0] += weight * phasor[0];
                noise[1] += weight * phasor[1];
            }
            total[0] += noise[0];
            total[1] += noise[1];
        }
    }
}

/* gabor.py orientation_3d. */
INLINE void gabor_orientation_3d(const float *base, float isotropy, const float *c, float seed, float *out)
{
    if (isotropy == 0.0f) { out[0] = base[0]; out[1] = base[1]; out[2] = base[2]; return; }
    float inclination = (float)acos((double)base[2]);
    float planar = sqrtf(base[0] * base[0] + base[1] * base[1]);
    float azimuth = (base[1] < 0.0f ? -1.0f : 1.0f) * (float)acos((double)(base[0] / planar));
    inclination = inclination + hash_float4(c[0], c[1], c[2], seed) * GABOR_PI * isotropy;
    azimuth = azimuth + hash_float4(c[2], c[0], seed, c[1]) * GABOR_PI * isotropy;
    float sine = (float)sin((double)inclination);
    out[0] = sine * (float)cos((double)azimuth);
    out[1] = sine * (float)sin((double)azimuth);
    out[2] = (float)cos((double)inclination);
}

/* gabor.py noise_3d at one point. */
INLINE void gabor_noise_3d(const float *p, float frequency, float isotropy, const float *base, float *total)
{
    float cell[3], local[3];
    for (int d = 0; d < 3; d++) { cell[d] = floorf(p[d]); local[d] = p[d] - cell[d]; }
    total[0] = total[1] = 0.0f;
    for (int k3 = -1; k3 <= 1; k3++) {
        for (int j = -1; j <= 1; j++) {
            for (int i = -1; i <= 1; i++) {
                float offset[3] = {(float)i, (float)j, (float)k3}, c[3], q[3], noise[2] = {0.0f, 0.0f}, phasor[2];
                for (int d = 0; d < 3; d++) { c[d] = cell[d] + offset[d]; q[d] = local[d] - offset[d]; }
                for (int k = 0; k < 8; k++) {
                    float seed = (float)(k * 3), orientation[3], x[3];
                    gabor_orientation_3d(base, isotropy, c, seed, orientation);
                    float s1 = seed + 1.0f;
                    x[0] = q[0] - hash_float4(c[0], c[1], c[2], s1);
                    x[1] = q[1] - hash_float4(c[2], c[0], s1, c[1]);
                    x[2] = q[2] - hash_float4(s1, c[2], c[1], c[0]);
                    float d2 = (x[0] * x[0] + x[1] * x[1]) + x[2] * x[2];
                    if (!(d2 < 1.0f)) continue;
                    float weight = hash_float4(c[0], c[1], c[2], seed + 2.0f) < 0.5f ? -1.0f : 1.0f;
                    float f[3] = {frequency * orientation[0], frequency * orientation[1], frequency * orientation[2]};
                    gabor_kernel(d2, (x[0] * f[0] + x[1] * f[1]) + x[2] * f[2], phasor);
                    noise[0] += weight * phasor[0];
                    noise[1] += weight * phasor[1];
                }
                total[0] += noise[0];
                total[1] += noise[1];
            }
        }
    }
}

NOINLINE static void gabor_texture(const int *a, double *reg)
{
    float scale = (float)reg[a[2]], frequency = (float)reg[a[3]], anisotropy = (float)reg[a[4]];
    float p[3], total[2], sigma;
    for (int k = 0; k < 3; k++) p[k] = (float)reg[a[1] + k] * scale;
    float isotropy = 1.0f - (anisotropy < 0.0f ? 0.0f : (anisotropy > 1.0f ? 1.0f : anisotropy));
    frequency = frequency > 0.001f ? frequency : 0.001f;
    if (a[7] == 0) {
        gabor_noise_2d(p, frequency, isotropy, (float)reg[a[5]], total);
        sigma = sqrtf(8.0f * 0.5f * 0.25f);
    } else {
        float d[3] = {(float)reg[a[6]], (float)reg[a[6] + 1], (float)reg[a[6] + 2]};
        float length = sqrtf((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]), base[3];
        for (int k = 0; k < 3; k++) base[k] = d[k] / length;
        gabor_noise_3d(p, frequency, isotropy, base, total);
        sigma = sqrtf(8.0f * 0.5f * (1.0f / (4.0f * 1.41421356237309504880f)));
    }
    float norm = 6.0f * sigma;
    double *out = reg + a[0];
    out[0] = (double)((total[1] / norm) * 0.5f + 0.5f);
    out[1] = (double)(((float)atan2((double)total[1], (double)total[0]) + GABOR_PI) / (2.0f * GABOR_PI));
    out[2] = (double)(sqrtf(total[0] * total[0] + total[1] * total[1]) / norm);
}
