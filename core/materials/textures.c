/* Image textures: core/materials/textures.py. Every image of a render kept as stored (8-bit, 16-bit or float
 * texels, 1 to 4 channels) in one buffer per format, looked up with Cycles' conventions (texel centres at
 * i + 0.5, Closest, Linear, Cubic B-spline; Repeat, Extend, Clip, Mirror); sRGB images decoded after
 * interpolation. A UDIM image's lookup first picks its tile (texture_tile). */

/* One image as a lookup reads it. */
typedef struct {
    const void *data;
    int format, channels;
    int64_t w, h;
} TextureView;


/* textures.srgb_to_linear */
INLINE double srgb_to_linear(double c)
{
    if (c < 0.04045) return c < 0.0 ? 0.0 : c * (1.0 / 12.92);
    return pow((c + 0.055) * (1.0 / 1.055), 2.4);
}

/* textures.wrap: a texel index wrapped by the extension mode (Clip leaves it). */
INLINE int64_t texel_wrap(int64_t i, int64_t size, int extension)
{
    switch (extension) {
    case EXT_REPEAT: {
        if ((uint64_t)i < (uint64_t)size) return i;         /* (inside: no division, the same index) */
        int64_t m = i % size; return m < 0 ? m + size : m;
    }
    case EXT_EXTEND: return i < 0 ? 0 : (i > size - 1 ? size - 1 : i);
    case EXT_MIRROR: {
        if ((uint64_t)i < (uint64_t)size) return i;
        int64_t a = i + (i < 0);
        int64_t m = (a < 0 ? -a : a) % (2 * size);
        return m >= size ? 2 * size - m - 1 : m;
    }
    default: return i;
    }
}

/* textures.as_rgba of one texel: its stored values scaled to 0..1, grey to RGB, a missing alpha 1. */
INLINE void texel_rgba(const TextureView *image, int64_t at, double *rgba)
{
    double v[4] = {0.0, 0.0, 0.0, 1.0};
    int channels = image->channels;
    switch (image->format) {                /* (the format chosen once per texel, not per channel) */
    case TEX_BYTE: {
        const uint8_t *texel = (const uint8_t *)image->data + at;
        for (int c = 0; c < channels; c++) v[c] = (double)texel[c] * (1.0 / 255.0);
        break;
    }
    case TEX_SHORT: {
        const uint16_t *texel = (const uint16_t *)image->data + at;
        for (int c = 0; c < channels; c++) v[c] = (double)texel[c] * (1.0 / 65535.0);
        break;
    }
    default: {
        const float *texel = (const float *)image->data + at;
        for (int c = 0; c < channels; c++) v[c] = (double)texel[c];
        break;
    }
    }
    if (image->channels <= 2) {
        double alpha = image->channels == 2 ? v[1] : 1.0;
        rgba[0] = rgba[1] = rgba[2] = v[0];
        rgba[3] = alpha;
    } else {
        for (int c = 0; c < 3; c++) rgba[c] = v[c];
        rgba[3] = image->channels == 4 ? v[3] : 1.0;
    }
}

/* textures.read: out += weight x texel (ix, iy); nothing outside the image. */
INLINE void texel_add(const TextureView *image, int64_t ix, int64_t iy, double weight, double *out)
{
    if (ix < 0 || ix >= image->w || iy < 0 || iy >= image->h) return;
    double t[4];
    texel_rgba(image, (int64_t)image->channels * (iy * image->w + ix), t);
    for (int c = 0; c < 4; c++) out[c] += weight * t[c];
}

/* textures.tile_of and TextureSet.tiled_lookup's choice: the row of UDIM image `index`'s tile at (*x, *y), whose
 * integer parts (rounded toward zero, as Cycles' (int) cast) are taken off them; -1 (magenta) where no tile is. */
INLINE int texture_tile(const TextureTables *T, int index, double *x, double *y)
{
    if (!(*x > -1.0 && *x < 10.0 && *y > -1.0 && *y < 1e9)) return -1;
    int64_t tx = (int64_t)*x, ty = (int64_t)*y;
    int64_t number = 1001 + tx + 10 * ty, start = T->tile_start[index], end = start + T->tile_count[index];
    for (int64_t entry = start; entry < end; entry++) {
        if (T->tile_number[entry] == number) {
            *x -= (double)tx;
            *y -= (double)ty;
            return (int)T->tile_image[entry];
        }
    }
    return -1;
}

/* TextureSet.lookup for one point: image `index` (-1: missing, magenta) at (x, y) -> RGBA out[4]; `unassociate`
 * nonzero: the colour divided by an alpha neither 0 nor 1 before the sRGB decoding (textures.unassociated). */
INLINE void texture_lookup(const TextureTables *T, int index, double x, double y, int interpolation, int extension,
                           int unassociate, double *out)
{
    if (index >= 0 && T != NULL && index < (int)T->count && T->tile_count[index] > 0)
        index = texture_tile(T, index, &x, &y);
    if (index < 0 || T == NULL || index >= (int)T->count) {
        out[0] = 1.0; out[1] = 0.0; out[2] = 1.0; out[3] = 1.0;
        return;
    }
    int64_t w = (int64_t)T->width[index], h = (int64_t)T->height[index];
    TextureView view = {NULL, (int)T->format[index], (int)T->channels[index], w, h};
    int64_t start = (int64_t)T->offset[index];
    view.data = view.format == TEX_BYTE ? (const void *)(T->bytes + start)
              : view.format == TEX_SHORT ? (const void *)(T->shorts + start) : (const void *)(T->floats + start);
    const TextureView *data = &view;
    for (int c = 0; c < 4; c++) out[c] = 0.0;
    if (interpolation == TEX_CLOSEST) {
        int64_t ix = (int64_t)floor(x * (double)w), iy = (int64_t)floor(y * (double)h);
        texel_add(data, texel_wrap(ix, w, extension), texel_wrap(iy, h, extension), 1.0, out);
    } else {
        double fx = x * (double)w - 0.5, fy = y * (double)h - 0.5;
        double bx = floor(fx), by = floor(fy);
        double tx = fx - bx, ty = fy - by;
        int64_t ix = (int64_t)bx, iy = (int64_t)by;
        if (interpolation == TEX_CUBIC) {
            if (extension == EXT_CLIP && (ix < -2 || ix > w || iy < -2 || iy > h)) goto decode;
            double u[4] = {(((-1.0 / 6.0) * tx + 0.5) * tx - 0.5) * tx + 1.0 / 6.0, ((0.5 * tx - 1.0) * tx) * tx + 2.0 / 3.0,
                           ((-0.5 * tx + 0.5) * tx + 0.5) * tx + 1.0 / 6.0, (1.0 / 6.0) * tx * tx * tx};
            double v[4] = {(((-1.0 / 6.0) * ty + 0.5) * ty - 0.5) * ty + 1.0 / 6.0, ((0.5 * ty - 1.0) * ty) * ty + 2.0 / 3.0,
                           ((-0.5 * ty + 0.5) * ty + 0.5) * ty + 1.0 / 6.0, (1.0 / 6.0) * ty * ty * ty};
            for (int b = 0; b < 4; b++) {
                double row[4] = {0.0, 0.0, 0.0, 0.0};
                int64_t yb = texel_wrap(iy + b - 1, h, extension);
                for (int a = 0; a < 4; a++)
                    texel_add(data, texel_wrap(ix + a - 1, w, extension), yb, u[a], row);
                for (int c = 0; c < 4; c++) out[c] += v[b] * row[c];
            }
        } else {
            int64_t x0 = texel_wrap(ix, w, extension), x1 = texel_wrap(ix + 1, w, extension);
            int64_t y0 = texel_wrap(iy, h, extension), y1 = texel_wrap(iy + 1, h, extension);
            double r0[4] = {0.0, 0.0, 0.0, 0.0}, r1[4] = {0.0, 0.0, 0.0, 0.0};
            texel_add(data, x0, y0, 1.0 - tx, r0);
            texel_add(data, x1, y0, tx, r0);
            texel_add(data, x0, y1, 1.0 - tx, r1);
            texel_add(data, x1, y1, tx, r1);
            for (int c = 0; c < 4; c++) out[c] = (1.0 - ty) * r0[c] + ty * r1[c];
        }
    }
decode:
    if (unassociate && out[3] != 0.0 && out[3] != 1.0)
        for (int c = 0; c < 3; c++) out[c] /= out[3];
    if (T->srgb[index] != 0.0)
        for (int c = 0; c < 3; c++) out[c] = srgb_to_linear(out[c]);
}

/* textures.compiled_lookup: n lookups of image `index` at x, y (n,), for the tests -> rgba (n, 4). */
static void texture_lookup_rows(const TextureLookupArgs *a)
{
    for (int64_t i = 0; i < a->n; i++)
        texture_lookup(a->textures, (int)a->index, a->x[i], a->y[i], (int)a->interpolation, (int)a->extension,
                       (int)a->unassociate, a->rgba + 4 * i);
}
