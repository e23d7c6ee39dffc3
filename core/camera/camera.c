/* Camera rays: core/camera/camera.py generate_rays, for every camera type, a block of samples at a time. */

/* A block of camera samples: their pixels' keys and positions, their points, their rays. */
typedef struct {
    int64_t n;
    uint32_t pixel[BLOCK], index[BLOCK];
    double column[BLOCK], row[BLOCK];            /* the pixel's x and y on the image */
    double u[2][BLOCK];                          /* the sample's point in (or, filtered, around) its pixel */
    double lens[2][BLOCK];                       /* its point on the aperture (depth of field only), uniform */
    double time[BLOCK];                          /* its time in the shutter (motion blur only, else 1/2) */
    double O[3][BLOCK], D[3][BLOCK], t[BLOCK];
    uint8_t valid[BLOCK];                        /* 0 outside a fisheye's image circle: no ray */
} CameraBlock;

/* camera.aperture_points for one lane: the point (2) on the aperture of the uniform numbers u (2), scene units. */
INLINE void aperture_point(const CameraRecord *camera, double u0, double u1, double *out)
{
    double x, y;
    if (camera->aperture_blades < 3) {
        /* camera.uniform_disk: the concentric map of the square onto the disk */
        double a = 2.0 * u0 - 1.0, b = 2.0 * u1 - 1.0, r, phi;
        if (a == 0.0 && b == 0.0) { out[0] = out[1] = 0.0; return; }
        if (a * a > b * b) { r = a; phi = (PI / 4.0) * (b / a); }
        else { r = b; phi = PI / 2.0 - (PI / 4.0) * (a / b); }
        x = r * cos(phi);
        y = r * sin(phi);
    } else {
        /* camera.regular_polygon: a corner's triangle, uniform in its area, turned into place */
        double corners = (double)camera->aperture_blades, t = u0 * corners, corner = floor(t);
        double s = sqrt(t - corner), v = u1 * s;
        s = 1.0 - s;
        double half = PI / corners;
        double px = (s + v) * cos(half), py = (s - v) * sin(half);
        double turn = camera->aperture_rotation + corner * 2.0 * half, c = cos(turn), n = sin(turn);
        x = c * px - n * py;
        y = n * px + c * py;
    }
    out[0] = x / camera->aperture_ratio * camera->aperture_size;
    out[1] = y * camera->aperture_size;
}

/* motion.interpolate for one time: the linear part L (3 x 3, row-major) and translation eye (3) at `time` of the
 * `steps` decomposed transforms `motion` (MOTION_STRIDE numbers a step: quaternion, translation and the scale with
 * shear), a camera's or a moving object's. */
INLINE void decomposed_at(const double *motion, int64_t steps, double time, double *L, double *eye)
{
    int64_t last = steps - 1;
    int64_t step = (int64_t)(time * (double)last);
    if (step > last - 1) step = last - 1;
    double t = time * (double)last - (double)step;
    const double *a = motion + step * MOTION_STRIDE, *b = a + MOTION_STRIDE;
    /* 1. The rotation: spherical interpolation, or linear and renormalised where the two nearly agree. */
    double cos_ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3], q[4];
    if (cos_ab > 0.9995) {
        double length = 0.0;
        for (int c = 0; c < 4; c++) { q[c] = (1.0 - t) * a[c] + t * b[c]; length += q[c] * q[c]; }
        length = sqrt(length);
        for (int c = 0; c < 4; c++) q[c] /= length;
    } else {
        double theta = acos(cos_ab < -1.0 ? -1.0 : (cos_ab > 1.0 ? 1.0 : cos_ab)), across[4], length = 0.0;
        for (int c = 0; c < 4; c++) { across[c] = b[c] - a[c] * cos_ab; length += across[c] * across[c]; }
        length = length > 0.0 ? sqrt(length) : 1.0;
        double ca = cos(theta * t), sa = sin(theta * t);
        for (int c = 0; c < 4; c++) q[c] = a[c] * ca + across[c] / length * sa;
    }
    /* 2. The translation, scale and shear: linear. */
    double rest[12];
    for (int c = 0; c < 12; c++) rest[c] = (1.0 - t) * a[4 + c] + t * b[4 + c];
    /* 3. Composed: the quaternion's rotation times the upper-triangular scale with shear. */
    const double root2 = 1.4142135623730951;             /* (math.sqrt(2.0)) */
    double x = root2 * q[0], y = root2 * q[1], z = root2 * q[2], w = root2 * q[3];
    double R[9] = {1.0 - y * y - z * z, -w * z + x * y, w * y + x * z,
                   w * z + x * y, 1.0 - x * x - z * z, -w * x + y * z,
                   -w * y + x * z, w * x + y * z, 1.0 - x * x - y * y};
    double S[9] = {rest[3], rest[4], rest[5], 0.0, rest[7], rest[8], 0.0, 0.0, rest[11]};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            L[3 * r + c] = R[3 * r] * S[c] + R[3 * r + 1] * S[3 + c] + R[3 * r + 2] * S[6 + c];
    eye[0] = rest[0]; eye[1] = rest[1]; eye[2] = rest[2];
}

/* motion.interpolate for one lane: the camera's linear part L and position eye at `time` (decomposed_at). */
INLINE void camera_at(const CameraRecord *camera, double time, double *L, double *eye)
{
    decomposed_at(camera->motion, (int64_t)camera->motion_steps, time, L, eye);
}

/* camera.panorama_directions for one (u, v) of the panoramas other than the two fisheyes: the direction (3) in Cycles'
 * panorama frame (x forward, y left, z up); returns 0 where none exists. */
INLINE int panorama_direction(const CameraRecord *camera, int kind, double u, double v, double *c)
{
    const double *range = camera->range;
    c[0] = c[1] = c[2] = 0.0;
    if (kind == CAMERA_EQUIRECTANGULAR) {
        double phi = (range[0] - range[1]) * u - range[0];
        double theta = (range[2] - range[3]) * v - range[2] + PI / 2.0;
        c[0] = sin(theta) * cos(phi); c[1] = sin(theta) * sin(phi); c[2] = cos(theta);
        return 1;
    }
    if (kind == CAMERA_EQUIANGULAR_CUBEMAP_FACE) {
        double y = tan((0.5 - u) * PI / 2.0), z = tan((v - 0.5) * PI / 2.0), length = sqrt(1.0 + y * y + z * z);
        c[0] = 1.0 / length; c[1] = y / length; c[2] = z / length;
        return 1;
    }
    if (kind == CAMERA_MIRRORBALL) {
        double x = 2.0 * u - 1.0, z = 2.0 * v - 1.0;
        if (!(x * x + z * z <= 1.0)) return 0;
        double y = -sqrt(at_least(1.0 - x * x - z * z, 0.0));
        c[0] = -2.0 * y * x; c[1] = 1.0 - 2.0 * y * y; c[2] = -2.0 * y * z;
        return 1;
    }
    if (kind == CAMERA_CENTRAL_CYLINDRICAL) {
        double theta = -range[0] + (range[0] - range[1]) * u;
        c[0] = cos(theta); c[1] = sin(theta); c[2] = range[2] + (range[3] - range[2]) * v;
        return 1;
    }
    /* FISHEYE_LENS_POLYNOMIAL: the angle from the axis a polynomial of the radius on the sensor. */
    double x = (u - 0.5) * camera->scale_x, y = (v - 0.5) * camera->scale_y, r = sqrt(x * x + y * y);
    const double *k = camera->polynomial;
    double theta = -(k[0] + k[1] * r + k[2] * r * r + k[3] * (r * r * r) + k[4] * (r * r * r * r));
    if (!(fabs(theta) <= 0.5 * camera->fisheye_fov)) return 0;
    double cos_phi = r != 0.0 ? x / r : 0.0;
    cos_phi = cos_phi < -1.0 ? -1.0 : (cos_phi > 1.0 ? 1.0 : cos_phi);
    double sin_phi = sqrt(1.0 - cos_phi * cos_phi) * (y < 0.0 ? -1.0 : 1.0);
    c[0] = cos(theta); c[1] = -cos_phi * sin(theta); c[2] = sin_phi * sin(theta);
    return 1;
}

/* camera.panorama_local: the pinhole's local unit direction d (Blender's camera frame, looking down -z) of a panoramic
 * camera of `kind` at its (u, v); returns 0 where none exists (d is then the forward direction). */
static int panorama_local(const CameraRecord *camera, int kind, double u, double v, double *d)
{
    if (kind == CAMERA_FISHEYE_EQUIDISTANT || kind == CAMERA_FISHEYE_EQUISOLID) {
        /* The fisheyes: (u, v) onto the image plane, inside the image circle; the angle from the axis linear in the
         * radius (equidistant) or r = 2 lens sin(theta / 2) (equisolid). */
        double plane_x = (u - 0.5) * camera->scale_x, plane_y = (v - 0.5) * camera->scale_y;
        double radius = sqrt(plane_x * plane_x + plane_y * plane_y);
        int valid = radius <= camera->limit;
        double sin_theta, cos_theta;
        if (kind == CAMERA_FISHEYE_EQUIDISTANT) {
            double theta = valid ? radius * (0.5 * camera->fisheye_fov) : 0.0;
            sin_theta = sin(theta);
            cos_theta = cos(theta);
        } else {
            double s = valid ? radius / (2.0 * camera->fisheye_lens) : 0.0;
            s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
            sin_theta = 2.0 * s * sqrt(1.0 - s * s);
            cos_theta = 1.0 - 2.0 * s * s;
        }
        double scale = radius > 0.0 ? sin_theta / radius : 0.0;
        d[0] = scale * plane_x; d[1] = scale * plane_y; d[2] = -cos_theta;
        return valid;
    }
    /* The others: the direction in Cycles' panorama frame, turned into the camera's (a mirror ball looks down its y
     * axis, the others down x). */
    double c[3];
    int valid = panorama_direction(camera, kind, u, v, c);
    if (kind == CAMERA_MIRRORBALL) { d[0] = c[0]; d[1] = c[2]; d[2] = c[1]; }
    else { d[0] = -c[1]; d[1] = c[2]; d[2] = -c[0]; }
    double length = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (valid) { d[0] /= length; d[1] /= length; d[2] /= length; }
    else { d[0] = 0.0; d[1] = 0.0; d[2] = -1.0; }
    return valid;
}

/* camera.panorama_cones: a panoramic camera's ray cone at its (u, v) (Cycles' camera_sample_panorama differentials):
 * *spread the mean of |D(x + 1) - D| and |D(y + 1) - D| over one pixel step (u + 1 / width, v - 1 / height), *cone
 * clip_start times it; a neighbour with no direction counts as the other one; with neither, UNKNOWN_CONE and 0. */
static void panorama_cone(const CameraRecord *camera, int kind, double u, double v, int64_t width, int64_t height,
                          double *cone, double *spread)
{
    double d[3], dx[3], dy[3];
    panorama_local(camera, kind, u, v, d);
    int along_x = panorama_local(camera, kind, u + 1.0 / (double)width, v, dx);
    int along_y = panorama_local(camera, kind, u, v - 1.0 / (double)height, dy);
    double step_x = 0.0, step_y = 0.0;
    for (int c = 0; c < 3; c++) {
        step_x += (dx[c] - d[c]) * (dx[c] - d[c]);
        step_y += (dy[c] - d[c]) * (dy[c] - d[c]);
    }
    step_x = sqrt(step_x);
    step_y = sqrt(step_y);
    if (!along_x && !along_y) {
        *cone = UNKNOWN_CONE;
        *spread = 0.0;
        return;
    }
    if (!along_x) step_x = step_y;
    if (!along_y) step_y = step_x;
    *spread = 0.5 * (step_x + step_y);
    *cone = camera->clip_start * *spread;
}

/* One camera ray per lane (inlined once per camera kind, so that the loop has no branch). */
/* camera._panorama_lens for one ray: the local unit direction d through the thin lens of the uniform numbers u0, u1,
 * worked in Cycles' panorama frame (x forward; a mirror ball's own); o becomes the aperture's point past clip_start
 * along the new d. */
INLINE void panorama_lens(const CameraRecord *camera, int kind, double u0, double u1, double *o, double *d)
{
    /* 1. The pinhole ray in the panorama frame, and the frame across it. */
    double D[3], U[3], V[3], at[2], P[3], F[3];
    if (kind == CAMERA_MIRRORBALL) { D[0] = d[0]; D[1] = d[2]; D[2] = d[1]; }
    else { D[0] = -d[2]; D[1] = -d[0]; D[2] = d[1]; }
    for (int c = 0; c < 3; c++) U[c] = (c == 0 ? 1.0 : 0.0) - D[0] * D[c];
    double length = sqrt(dot3(U, U));
    if (length > 1e-12) for (int c = 0; c < 3; c++) U[c] /= length;
    else { U[0] = 0.0; U[1] = 1.0; U[2] = 0.0; }             /* (straight ahead: any direction across) */
    V[0] = D[1] * U[2] - D[2] * U[1]; V[1] = D[2] * U[0] - D[0] * U[2]; V[2] = D[0] * U[1] - D[1] * U[0];
    length = sqrt(dot3(V, V));
    for (int c = 0; c < 3; c++) V[c] /= length;
    /* 2. From the aperture's point towards the pinhole ray's point in focus. */
    aperture_point(camera, u0, u1, at);
    for (int c = 0; c < 3; c++) {
        P[c] = U[c] * at[0] + V[c] * at[1];
        F[c] = D[c] * camera->focus_distance - P[c];
    }
    length = sqrt(dot3(F, F));
    for (int c = 0; c < 3; c++) F[c] /= length;
    double Pl[3];
    if (kind == CAMERA_MIRRORBALL) { Pl[0] = P[0]; Pl[1] = P[2]; Pl[2] = P[1]; d[0] = F[0]; d[1] = F[2]; d[2] = F[1]; }
    else { Pl[0] = -P[1]; Pl[1] = P[2]; Pl[2] = -P[0]; d[0] = -F[1]; d[1] = F[2]; d[2] = -F[0]; }
    for (int c = 0; c < 3; c++) o[c] = Pl[c] + d[c] * camera->clip_start;
}

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
            if (kind == CAMERA_PERSP && camera.fov_motion) {
                /* 1'. The field of view at the ray's time (motion.plane_scales). */
                double time = b->time[k];
                double scale = time < 0.5 ? camera.fov_pre + (1.0 - camera.fov_pre) * (time * 2.0)
                                          : 1.0 + (camera.fov_post - 1.0) * ((time - 0.5) * 2.0);
                plane_x *= scale;
                plane_y *= scale;
            }
            if (camera.aperture_size > 0.0) {
                /* 2''. A thin lens (camera._perspective_rays, _orthographic_rays with a lens): from the aperture's
                 * point towards where the pinhole's (or the parallel) ray meets the plane in focus. */
                double at[2], towards[3];
                aperture_point(&camera, b->lens[0][k], b->lens[1][k], at);
                if (kind == CAMERA_PERSP) {
                    double length = sqrt(plane_x * plane_x + plane_y * plane_y + 1.0), cos_to_axis = 1.0 / length;
                    towards[0] = plane_x * camera.focus_distance - at[0];
                    towards[1] = plane_y * camera.focus_distance - at[1];
                    towards[2] = -camera.focus_distance;
                    double norm = sqrt(dot3(towards, towards));
                    for (int c = 0; c < 3; c++) d[c] = towards[c] / norm;
                    double start = camera.clip_start / cos_to_axis;
                    o[0] = at[0] + d[0] * start; o[1] = at[1] + d[1] * start; o[2] = d[2] * start;
                    t = (camera.clip_end - camera.clip_start) / cos_to_axis;
                } else {
                    towards[0] = -at[0]; towards[1] = -at[1]; towards[2] = -camera.focus_distance;
                    double norm = sqrt(dot3(towards, towards));
                    for (int c = 0; c < 3; c++) d[c] = towards[c] / norm;
                    double start = camera.clip_start / -d[2];
                    o[0] = plane_x + at[0] + d[0] * start; o[1] = plane_y + at[1] + d[1] * start; o[2] = d[2] * start;
                    t = camera.clip_end - camera.clip_start;
                }
            } else if (kind == CAMERA_PERSP) {
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
            /* 1. A panorama (camera.panorama_local): the pinhole's direction at its (u, v); spherical clipping. */
            double u = raster_x / (double)width + camera.shift_x;
            double v = ((double)height - raster_y) / (double)height + camera.shift_y;
            valid = panorama_local(&camera, kind, u, v, d);
            o[0] = d[0] * camera.clip_start; o[1] = d[1] * camera.clip_start; o[2] = d[2] * camera.clip_start;
            t = camera.clip_end - camera.clip_start;
        }
        if (kind != CAMERA_PERSP && kind != CAMERA_ORTHO && camera.aperture_size > 0.0 && valid)
            panorama_lens(&camera, kind, b->lens[0][k], b->lens[1][k], o, d);
        /* 3. Into the camera-relative world frame (where the camera is at the ray's time, when it moves). */
        double O[3], D[3], moved[9], moved_eye[3];
        const double *M = R, *eye = camera.eye;
        if (camera.motion_steps >= 2) {
            camera_at(&camera, b->time[k], moved, moved_eye);
            M = moved;
            eye = moved_eye;
        }
        for (int c = 0; c < 3; c++) {
            O[c] = M[3 * c] * o[0] + M[3 * c + 1] * o[1] + M[3 * c + 2] * o[2] + eye[c];
            D[c] = M[3 * c] * d[0] + M[3 * c + 1] * d[1] + M[3 * c + 2] * d[2];
        }
        if (renormalize || camera.motion_steps >= 2) {
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

/* Cycles' lookup_table_read: the entry at u in [0, 1] of a table of `size`, linear between neighbouring entries
 * (core/camera/filter.py offsets, the same arithmetic; the pixel filter's and the shutter's inverse CDFs). */
static double table_lookup(const double *table, int64_t size, double u)
{
    double x = (u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u)) * (double)(size - 1);
    int64_t index = (int64_t)x;
    if (index > size - 1) index = size - 1;
    int64_t following = index + 1 < size ? index + 1 : size - 1;
    double t = x - (double)index;
    return t == 0.0 ? table[index] : (1.0 - t) * table[index] + t * table[following];
}

/* Where the pixel filter puts a sample with the uniform number u (table_lookup in its table). */
static double filter_position(const double *table, double u)
{
    return table_lookup(table, FILTER_TABLE_SIZE, u);
}

/* The camera rays of samples start .. start + BLOCK - 1 of p pixels' spp samples each (sample j of
 * pixel k is sample first[k] + j of its pattern): their keys, points and rays, into b. stream, lens_stream: the
 * patterns of their points in the pixel and on the lens (LENS_DIMENSION). */
INLINE void camera_samples(CameraBlock *b, const CameraRecord *camera, uint32_t stream, uint32_t lens_stream,
                           uint32_t time_stream, int64_t width, int64_t height, const int64_t *pixels,
                           const int64_t *first, int64_t spp, int64_t start, int64_t total)
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
    if (camera->filter_table)                  /* NULL for a 1-pixel box: the points stay where they are drawn */
        for (int64_t lane = 0; lane < b->n; lane++) {
            b->u[0][lane] = filter_position(camera->filter_table, b->u[0][lane]);
            b->u[1][lane] = filter_position(camera->filter_table, b->u[1][lane]);
        }
    if (camera->aperture_size > 0.0)           /* depth of field: each ray's point on the lens */
        sample_lanes(b->n, lens_stream, b->pixel, b->index, b->lens[0], b->lens[1]);
    if (camera->shutter_table) {               /* motion blur: each ray's time (motion.ray_times) */
        double unused[BLOCK];
        sample_lanes(b->n, time_stream, b->pixel, b->index, b->time, unused);
        for (int64_t lane = 0; lane < b->n; lane++) {
            double time = table_lookup(camera->shutter_table, SHUTTER_TABLE_SIZE, b->time[lane]);
            if (camera->rolling) {
                double row_time = (b->row[lane] + 1.0) / (double)height;
                time = camera->rolling_duration == 0.0 ? row_time
                       : (time - 0.5) * camera->rolling_duration + (row_time - 0.5) * (1.0 - camera->rolling_duration) + 0.5;
            }
            b->time[lane] = time;
        }
    } else
        for (int64_t lane = 0; lane < b->n; lane++) b->time[lane] = 0.5;
    camera_block(b, camera, width, height);
}

/* The camera rays of `spp` samples in each of `p` pixels, camera-relative (for the tests).
 * pixels, first: (p,) int64; out: origins, directions (p spp, 3), t_max, time (p spp,) float64, valid (p spp,) uint8. */
static void camera_rays(const CameraRaysArgs *a)
{
    uint32_t stream = stream_of(a->seed, 0), lens_stream = stream_of(a->seed, LENS_DIMENSION);
    uint32_t time_stream = stream_of(a->seed, TIME_DIMENSION);
    int64_t total = a->p * a->spp;
    CameraBlock b;
    for (int64_t start = 0; start < total; start += BLOCK) {
        camera_samples(&b, a->camera, stream, lens_stream, time_stream, a->width, a->height, a->pixels, a->first,
                       a->spp, start, total);
        for (int64_t lane = 0; lane < b.n; lane++) {
            int64_t i = start + lane;
            for (int c = 0; c < 3; c++) {
                a->origins[3 * i + c] = b.O[c][lane];
                a->directions[3 * i + c] = b.D[c][lane];
            }
            a->t_max[i] = b.t[lane];
            a->valid[i] = b.valid[lane];
            a->time[i] = b.time[lane];
        }
    }
}

