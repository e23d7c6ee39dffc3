"""The viewport's view as a core Camera: from Blender's view and projection matrices to rays.

Blender's 3D viewport describes what it shows by two 4x4 matrices (RegionView3D):

* the *view matrix* takes world points into the eye's frame (the eye at the origin, looking
  down -Z, +Y up), so its inverse is the camera's matrix_world;
* the *window matrix* is an OpenGL projection: it maps the eye frame to normalised device
  coordinates (NDC, x and y in [-1, 1] across the region).

A perspective window matrix (last row 0 0 -1 0) is::

    [ 2/(R-L)    0      (R+L)/(R-L)   0 ]       L, R, B, T: the region's edges on the
    [   0      2/(T-B)  (T+B)/(T-B)   0 ]       plane at distance 1 in front of the eye
    [   0        0          a         b ]       (tangents of the edge angles)
    [   0        0         -1         0 ]

and an orthographic one (last row 0 0 0 1) has 2/(R-L) and -(R+L)/(R-L) in its first row, with
L, R, B, T in scene units. Either way the four edges are Blender's *viewplane*, which core/camera/camera.py
already turns into rays: `camera_from_viewplane` picks the lens, sensor, ortho scale, shift and pixel
aspect whose viewplane is exactly (L, R, B, T). Viewport and camera view both work this way, since
in camera view Blender's window matrix is the scene camera's projection, zoomed and panned.

`crop` gives the camera of a pixel rectangle of another camera's image: the coarse preview pass of
the viewport renders blocks of s x s pixels with it.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .camera import Camera, viewplane

SENSOR = 36.0    # mm; any sensor works, since only sensor / lens matters


class ViewCamera(NamedTuple):
    """A core camera and the pixel aspect that together give a W x H image exactly the wanted viewplane."""

    camera: Camera
    pixel_aspect: tuple      # (x, y) as core.camera.generate_rays takes it


def camera_from_viewplane(matrix_world, kind: str, left: float, right: float, bottom: float, top: float,
                          width: int, height: int, clip_start: float, clip_end: float) -> ViewCamera:
    """Return the PERSP or ORTHO camera whose W x H image spans the viewplane (left, right, bottom, top).

    matrix_world: (4, 4) float64 camera-to-world. PERSP edges are on the plane at distance 1;
    ORTHO edges are in scene units. The fit is horizontal: the width sets the lens (or ortho
    scale), both shifts are in units of the width, and the pixel aspect makes the height fit.
    """
    # 1. The fitted (horizontal) size, and the shift of the viewplane's centre in its units.
    fitted = right - left
    if not (fitted > 0 and top > bottom):
        raise ValueError(f"empty viewplane ({left}, {right}, {bottom}, {top})")
    shift_x = 0.5 * (left + right) / fitted
    shift_y = 0.5 * (bottom + top) / fitted
    # 2. half_height = half_width * (H * aspect_y) / (W * aspect_x): solve for aspect_y with aspect_x = 1.
    aspect_y = (top - bottom) / fitted * width / height
    common = dict(matrix_world=matrix_world, sensor_width=SENSOR, sensor_fit="HORIZONTAL",
                  shift_x=shift_x, shift_y=shift_y, clip_start=clip_start, clip_end=clip_end)
    if kind == "PERSP":
        camera = Camera(type="PERSP", lens=SENSOR / fitted, **common)
    elif kind == "ORTHO":
        camera = Camera(type="ORTHO", ortho_scale=fitted, **common)
    else:
        raise ValueError(f"a viewplane camera is PERSP or ORTHO, not {kind!r}")
    return ViewCamera(camera, (1.0, aspect_y))


def camera_from_matrices(view_matrix, window_matrix, width: int, height: int) -> ViewCamera:
    """Return the camera that sees what Blender's viewport shows with these matrices in a W x H region.

    view_matrix:   (4, 4) world -> eye (RegionView3D.view_matrix)
    window_matrix: (4, 4) eye -> clip space (RegionView3D.window_matrix), perspective or orthographic
    """
    view_matrix = np.asarray(view_matrix, np.float64).reshape(4, 4)
    P = np.asarray(window_matrix, np.float64).reshape(4, 4)
    matrix_world = np.linalg.inv(view_matrix)
    if abs(P[3, 3]) < 0.5:
        # 1. Perspective: x_ndc = (P00 x + P02 z) / -z; at z = -1 the edges x_ndc = -+1 give L and R.
        left, right = (P[0, 2] - 1.0) / P[0, 0], (P[0, 2] + 1.0) / P[0, 0]
        bottom, top = (P[1, 2] - 1.0) / P[1, 1], (P[1, 2] + 1.0) / P[1, 1]
        # 2. Depth row: z_ndc = -1 at -near and +1 at -far.
        near, far = P[2, 3] / (P[2, 2] - 1.0), P[2, 3] / (P[2, 2] + 1.0)
        return camera_from_viewplane(matrix_world, "PERSP", left, right, bottom, top, width, height, near, far)
    # 3. Orthographic: x_ndc = P00 x + P03, so x_ndc = -+1 at x = (-+1 - P03) / P00.
    left, right = (-1.0 - P[0, 3]) / P[0, 0], (1.0 - P[0, 3]) / P[0, 0]
    bottom, top = (-1.0 - P[1, 3]) / P[1, 1], (1.0 - P[1, 3]) / P[1, 1]
    # z_ndc = P22 z + P23 is -1 at z = -near and +1 at z = -far (near may be negative in the viewport).
    near, far = (P[2, 3] + 1.0) / P[2, 2], (P[2, 3] - 1.0) / P[2, 2]
    return camera_from_viewplane(matrix_world, "ORTHO", left, right, bottom, top, width, height, near, far)


def crop(view: ViewCamera, width: int, height: int, x0: float, y0: float, x1: float, y1: float) -> ViewCamera:
    """Return the camera whose whole image is the raster rectangle [x0, x1) x [y0, y1) of `view`'s W x H image.

    Rows count from the top. The rectangle may reach beyond the image (the coarse pass rounds up).
    The returned camera's pixel aspect is for an image of (x1 - x0) x (y1 - y0) pixels.
    """
    camera = view.camera
    left, right, bottom, top = viewplane(camera, width, height, view.pixel_aspect)
    sub_left = left + (right - left) * x0 / width
    sub_right = left + (right - left) * x1 / width
    sub_top = top - (top - bottom) * y0 / height
    sub_bottom = top - (top - bottom) * y1 / height
    return camera_from_viewplane(camera.matrix_world, camera.type, sub_left, sub_right, sub_bottom, sub_top,
                                 int(round(x1 - x0)), int(round(y1 - y0)), camera.clip_start, camera.clip_end)


def project(view_matrix, window_matrix, width: int, height: int, points) -> np.ndarray:
    """Return where Blender's projection puts world points in a W x H region: (n, 2) raster x, y from the top.

    points: (n, 3) float64 world points. This is the same arithmetic as
    bpy_extras.view3d_utils.location_3d_to_region_2d, with rows counted from the top.
    """
    points = np.atleast_2d(np.asarray(points, np.float64))
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    clip = homogeneous @ (np.asarray(window_matrix, np.float64) @ np.asarray(view_matrix, np.float64)).T
    ndc = clip[:, :2] / clip[:, 3:4]
    return np.stack([(ndc[:, 0] + 1.0) * 0.5 * width, (1.0 - ndc[:, 1]) * 0.5 * height], axis=1)


def frame_rectangle(view_matrix, window_matrix, width: int, height: int, frame_points) -> tuple:
    """Return the region rectangle (x, y, w, h), y from the top, that a camera frame's 4 corners cover.

    frame_points: (4, 3) float64 world points of the camera's frame (Camera.view_frame placed in the world).
    Used for fisheye cameras in camera view, whose image Blender shows inside that frame.
    """
    raster = project(view_matrix, window_matrix, width, height, frame_points)
    x0, y0 = raster.min(axis=0)
    x1, y1 = raster.max(axis=0)
    x, y = int(math.floor(x0 + 0.5)), int(math.floor(y0 + 0.5))
    return x, y, max(1, int(math.floor(x1 + 0.5)) - x), max(1, int(math.floor(y1 + 0.5)) - y)
