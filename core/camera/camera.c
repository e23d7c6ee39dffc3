/* Camera rays: core/camera/camera.py generate_rays, for every camera type, a block of samples at a time. */

/* A block of camera samples: their pixels' keys and positions, their points, their rays. */
typedef struct {
    int64_t n;
    uint32_t pixel[BLOCK], index[BLOCK];
    double column[BLOCK], row[BLOCK];            /* the pixel's x and y on the image */
    double u[2][BLOCK];                          /* the sample's point inside its pixel */
    double O[3][BLOCK], D[3][BLOCK], t[BLOCK];
    uint8_t valid[BLOCK];                        /* 0 outside a fisheye's image circle: no ray */
} CameraBlock;

/* One camera ray per lane (inlined once per camera kind, so that the loop has no branch). */
INLINE void camera_lanes(CameraBlock *restrict b, const CameraRecord *restrict record, int64_t width,
                         int64_t height, int kind, int renormalize)
{
    const CameraRecord camera = *record;   /* a local copy: every lane may read every field */
    const double *R = camera.rotation;
    for (int64_t k = 0; k < b->n; k++) {
        double raster_x = b->column[k] + b->u[0][k];
        double raster_y = b->row[k] + b->u[1][k];
        double o[3], d[3], t;
        int valid = 1;
        if (kind == CAMERA_PERSP || kind == CAMERA_ORTHO) {
            /* 1. The sample's position on the image plane (row 0 is the top of the image). */
            double plane_x = camera.left + (raster_x / (double)width) * (camera.right - camera.left);
            double plane_y = camera.top - (raster_y / (double)height) * (camera.top - camera.bottom);
            if (kind == CAMERA_PERSP) {
                /* 2. A pinhole: the point on the plane at distance 1 is the direction; planar clipping. */
                double length = sqrt(plane_x * plane_x + plane_y * plane_y + 1.0);
                d[0] = plane_x / length; d[1] = plane_y / length; d[2] = -1.0 / length;
                double cos_to_axis = -d[2];
                double start = camera.clip_start / cos_to_axis;
                o[0] = d[0] * start; o[1] = d[1] * start; o[2] = d[2] * start;
                t = (camera.clip_end - camera.clip_start) / cos_to_axis;
            } else {
                /* 2'. Parallel rays along -Z from the near clip plane. */
                o[0] = plane_x; o[1] = plane_y; o[2] = -camera.clip_start;
                d[0] = 0.0; d[1] = 0.0; d[2] = -1.0;
                t = camera.clip_end - camera.clip_start;
            }
        } else {
            /* 1. A fisheye: the panorama's (u, v), v from the bottom, onto its image plane. */
            double u = raster_x / (double)width + camera.shift_x;
            double v = ((double)height - raster_y) / (double)height + camera.shift_y;
            double plane_x = (u - 0.5) * camera.scale_x, plane_y = (v - 0.5) * camera.scale_y;
            double radius = sqrt(plane_x * plane_x + plane_y * plane_y);
            valid = radius <= camera.limit;
            /* 2. The angle from the axis: linear in the radius (equidistant) or r = 2 lens sin(theta / 2). */
            double sin_theta, cos_theta;
            if (kind == CAMERA_FISHEYE_EQUIDISTANT) {
                double theta = valid ? radius * (0.5 * camera.fisheye_fov) : 0.0;
                sin_theta = sin(theta);
                cos_theta = cos(theta);
            } else {
                double s = valid ? radius / (2.0 * camera.fisheye_lens) : 0.0;
                s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
                sin_theta = 2.0 * s * sqrt(1.0 - s * s);
                cos_theta = 1.0 - 2.0 * s * s;
            }
            double scale = radius > 0.0 ? sin_theta / radius : 0.0;
            d[0] = scale * plane_x; d[1] = scale * plane_y; d[2] = -cos_theta;
            /* Spherical clipping, as in Cycles: the clip distances are measured along the ray. */
            o[0] = d[0] * camera.clip_start; o[1] = d[1] * camera.clip_start; o[2] = d[2] * camera.clip_start;
            t = camera.clip_end - camera.clip_start;
        }
        /* 3. Into the camera-relative world frame. */
        double O[3], D[3];
        for (int c = 0; c < 3; c++) {
            O[c] = R[3 * c] * o[0] + R[3 * c + 1] * o[1] + R[3 * c + 2] * o[2] + camera.eye[c];
            D[c] = R[3 * c] * d[0] + R[3 * c + 1] * d[1] + R[3 * c + 2] * d[2];
        }
        if (renormalize) {
            double length = sqrt(dot3(D, D));
            D[0] /= length; D[1] /= length; D[2] /= length;
        }
        for (int c = 0; c < 3; c++) { b->O[c][k] = O[c]; b->D[c][k] = D[c]; }
        b->t[k] = t;
        b->valid[k] = (uint8_t)valid;
    }
}

SIMD_CLONES NOINLINE static void camera_block(CameraBlock *restrict b, const CameraRecord *restrict camera,
                                              int64_t width, int64_t height)
{
    int kind = (int)camera->kind, renormalize = camera->renormalize != 0.0;
    switch (kind) {
    case CAMERA_PERSP:
        if (renormalize) camera_lanes(b, camera, width, height, CAMERA_PERSP, 1);
        else camera_lanes(b, camera, width, height, CAMERA_PERSP, 0);
        break;
    case CAMERA_ORTHO:
        if (renormalize) camera_lanes(b, camera, width, height, CAMERA_ORTHO, 1);
        else camera_lanes(b, camera, width, height, CAMERA_ORTHO, 0);
        break;
    default:
        camera_lanes(b, camera, width, height, kind, renormalize);
    }
}

/* The camera rays of samples start .. start + BLOCK - 1 of p pixels' spp samples each (sample j of
 * pixel k is sample first[k] + j of its pattern): their keys, points and rays, into b. */
INLINE void camera_samples(CameraBlock *b, const CameraRecord *camera, uint32_t stream, int64_t width,
                           int64_t height, const int64_t *pixels, const int64_t *first, int64_t spp, int64_t start,
                           int64_t total)
{
    b->n = total - start < BLOCK ? total - start : BLOCK;
    int64_t k = start / spp, j = start % spp;
    int64_t pixel = pixels[k];
    double column = (double)(pixel % width), row = (double)(pixel / width);   /* (one division per pixel) */
    for (int64_t lane = 0; lane < b->n; lane++) {
        b->pixel[lane] = (uint32_t)pixel;
        b->index[lane] = (uint32_t)(first[k] + j);
        b->column[lane] = column;
        b->row[lane] = row;
        if (++j == spp && lane + 1 < b->n) {
            j = 0;
            pixel = pixels[++k];
            column = (double)(pixel % width);
            row = (double)(pixel / width);
        }
    }
    sample_lanes(b->n, stream, b->pixel, b->index, b->u[0], b->u[1]);
    camera_block(b, camera, width, height);
}

/* The camera rays of `spp` samples in each of `p` pixels, camera-relative (for the tests).
 * pixels, first: (p,) int64; out: origins, directions (p spp, 3), t_max (p spp,) float64, valid (p spp,) uint8. */
static void camera_rays(const CameraRaysArgs *a)
{
    uint32_t stream = stream_of(a->seed, 0);
    int64_t total = a->p * a->spp;
    CameraBlock b;
    for (int64_t start = 0; start < total; start += BLOCK) {
        camera_samples(&b, a->camera, stream, a->width, a->height, a->pixels, a->first, a->spp, start, total);
        for (int64_t lane = 0; lane < b.n; lane++) {
            int64_t i = start + lane;
            for (int c = 0; c < 3; c++) {
                a->origins[3 * i + c] = b.O[c][lane];
                a->directions[3 * i + c] = b.D[c][lane];
            }
            a->t_max[i] = b.t[lane];
            a->valid[i] = b.valid[lane];
        }
    }
}

