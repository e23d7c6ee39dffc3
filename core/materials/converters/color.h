/* core/materials/converters/color.py: Cycles' colour models in float32, for Separate and Combine Color. */

INLINE void rgb_to_hsv_f(const float *c, float *out)
{
    float cmax = c[0] > c[1] ? c[0] : c[1], cmin = c[0] < c[1] ? c[0] : c[1];
    cmax = c[2] > cmax ? c[2] : cmax;
    cmin = c[2] < cmin ? c[2] : cmin;
    float delta = cmax - cmin, s = cmax != 0.0f ? delta / cmax : 0.0f, h = 0.0f;
    if (s != 0.0f) {
        float k[3];
        for (int j = 0; j < 3; j++) k[j] = (cmax - c[j]) / delta;
        if (c[0] == cmax) h = k[2] - k[1];
        else if (c[1] == cmax) h = 2.0f + k[0] - k[2];
        else h = 4.0f + k[1] - k[0];
        h /= 6.0f;
        if (h < 0.0f) h += 1.0f;
    }
    out[0] = h; out[1] = s; out[2] = cmax;
}

INLINE void hsv_to_rgb_f(const float *hsv, float *out)
{
    float h = hsv[0], s = hsv[1], v = hsv[2];
    if (s == 0.0f) { out[0] = out[1] = out[2] = v; return; }
    h = (h == 1.0f ? 0.0f : h) * 6.0f;
    float i = floorf(h), f = h - i;
    float p = v * (1.0f - s), q = v * (1.0f - s * f), t = v * (1.0f - s * (1.0f - f));
    float rows[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
    int k = i == 0.0f ? 0 : i == 1.0f ? 1 : i == 2.0f ? 2 : i == 3.0f ? 3 : i == 4.0f ? 4 : 5;
    for (int j = 0; j < 3; j++) out[j] = rows[k][j];
}

INLINE void rgb_to_hsl_f(const float *c, float *out)
{
    float cmax = c[0] > c[1] ? c[0] : c[1], cmin = c[0] < c[1] ? c[0] : c[1];
    cmax = c[2] > cmax ? c[2] : cmax;
    cmin = c[2] < cmin ? c[2] : cmin;
    float l = (cmax + cmin) / 2.0f, h = 0.0f, s = 0.0f;
    l = l < 1.0f ? l : 1.0f;
    if (cmax != cmin) {
        float delta = cmax - cmin;
        s = l > 0.5f ? delta / (2.0f - cmax - cmin) : delta / (cmax + cmin);
        if (cmax == c[0]) h = (c[1] - c[2]) / delta + (c[1] < c[2] ? 6.0f : 0.0f);
        else if (cmax == c[1]) h = (c[2] - c[0]) / delta + 2.0f;
        else h = (c[0] - c[1]) / delta + 4.0f;
    }
    out[0] = h / 6.0f; out[1] = s; out[2] = l;
}

INLINE float clamp01f(float x) { return x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x); }

INLINE void hsl_to_rgb_f(const float *hsl, float *out)
{
    float h6 = hsl[0] * 6.0f, s = hsl[1], l = hsl[2];
    float nr = clamp01f(fabsf(h6 - 3.0f) - 1.0f), ng = clamp01f(2.0f - fabsf(h6 - 2.0f));
    float nb = clamp01f(2.0f - fabsf(h6 - 4.0f)), chroma = (1.0f - fabsf(2.0f * l - 1.0f)) * s;
    out[0] = (nr - 0.5f) * chroma + l; out[1] = (ng - 0.5f) * chroma + l; out[2] = (nb - 0.5f) * chroma + l;
}
