"""Debug output: the tracer's intermediate quantities, one number (or colour) per sample.

"Use that debug output" (the lecture). Each function here turns what the
tracer already knows about a batch of samples into a quantity a student can
look at; core/render.py averages them per pixel (`AUX_BUFFERS`) and the
add-on shows them as debug views and passes. Nothing here runs unless a
debug buffer was asked for.

Closed forms (tests/test_debug_views.py):
- normal angle: the angle between the shading normal N and the face normal Ng,
  acos(N.Ng) in degrees; 0 on flat faces.
- barycentrics: (1 - u - v, u, v), the weights of the triangle's corners at I;
  they sum to 1 and I = (1-u-v) V0 + u V1 + v V2.
- hit distance: t in I = O + t D for the camera ray that starts at the camera
  (O = its position, or its point on the image plane for an orthographic camera).
- self-intersection (acne): a blocked shadow ray whose nearest hit lies in or below
  the plane of the triangle it left, which only rounding can reach (`self_intersections`).
- rays per pixel: camera rays plus shadow rays cast for the pixel.
- time per pixel: see `share_time`.
"""
from __future__ import annotations

import numpy as np

# How far above the plane a shadow ray leaves a blocker may rise and still count as lying in it
# (so that hitting it needs rounding: acne), as a fraction of the scene's bounding-box diagonal.
SELF_HIT_FRACTION = 1e-5

# Fixed full scale of the normal-angle heat map, in degrees (a 12-segment sphere peaks near 20).
NORMAL_ANGLE_FULL_SCALE = 30.0


def normal_angle(N: np.ndarray, Ng: np.ndarray) -> np.ndarray:
    """Return the angle between shading and face normals in degrees.

    N, Ng: (n, 3) float64 unit -> (n,) float64 in [0, 180]
    """
    cos = np.clip(np.einsum("ij,ij->i", N, Ng), -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def barycentrics(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Return the barycentric weights (1 - u - v, u, v) of each hit: u, v (n,) float64 -> (n, 3) float64."""
    return np.stack([1.0 - u - v, u, v], axis=1)


def hit_distance(I: np.ndarray, camera_point: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Return t of I = O + t D, with O the camera's point the ray starts from (not the clip start).

    I: (n, 3) float64 hit points; camera_point: (3,) float64 camera position in the same frame;
    D: (n, 3) float64 unit ray directions -> (n,) float64. For an orthographic camera, whose
    rays start on its image plane, (I - camera position).D is the distance from that plane.
    """
    return np.einsum("ij,ij->i", I - camera_point, D)


def scene_scale(geometry) -> float:
    """Return the diagonal of the bounding box of all of a WorldGeometry's triangles, copied and instanced (0 when empty)."""
    lo, hi = geometry.bounds()
    return float(np.linalg.norm(hi - lo))


def self_intersections(geometry, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray,
                       own_prim: np.ndarray, min_distance: float) -> np.ndarray:
    """Return which of these blocked shadow rays were blocked by the surface they left (acne).

    One extra nearest-hit query, run only for the acne debug view. A ray that leaves a
    triangle's plane on one side cannot meet anything that lies entirely on the other side
    of that plane, or in it: its own triangle, the other half of a quad, the neighbour over
    a convex edge. So a hit on such a blocker can only come from rounding: acne. Whatever
    rises above the plane (a wall standing on the floor, the neighbour in a concave crease)
    can cast a real shadow, however close, and does not count. "In the plane" allows
    `min_distance` for the blocker's own rounding.
    origins, directions: (n, 3) float64; t_max: (n,) float64; own_prim: (n,) int64 triangle the
    ray started on -> (n,) bool
    """
    hits = geometry.tracer.intersect(origins, directions, t_max)
    other = np.where(hits.hit, hits.prim, own_prim)
    # 1. The own triangle's plane, its normal turned to the side the ray leaves to.
    own = geometry.triangle_data(own_prim, smooth=False)
    N_own = own.Ng * np.where(np.einsum("ij,ij->i", own.Ng, directions) < 0.0, -1.0, 1.0)[:, None]
    V_own = own.corners[:, 0]
    # 2. How far the blocker's corners rise above that plane.
    corners = geometry.triangle_data(other, smooth=False).corners                  # (n, 3, 3)
    heights = np.einsum("ncj,nj->nc", corners - V_own[:, None, :], N_own)
    return hits.hit & (heights.max(axis=1) <= min_distance)


def share_time(seconds: float, rays: np.ndarray) -> np.ndarray:
    """Return each pixel's share of a batch's wall time, in proportion to the rays it cast.

    The time is measured per batch of pixels (core/render.py: TIME_TILE pixels), not per
    pixel: numpy works on whole batches. So this is an estimate: within a batch it follows
    the rays per pixel, between batches it follows the clock.
    seconds: wall time of the batch; rays: (p,) float64 rays per pixel -> (p,) float64 seconds
    """
    total = rays.sum()
    if total <= 0:
        return np.full(len(rays), seconds / max(1, len(rays)))
    return seconds * rays / total


# The heat map: black -> blue -> red -> yellow -> white at x = 0, 0.25, 0.5, 0.75, 1.
HEAT_STOPS = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
HEAT_COLOURS = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 1.0, 1.0]])


NEGATIVE_COLOUR = np.array([0.0, 0.0, 1.0], np.float32)     # signed_grey: the colour of -1


def signed_grey(x: np.ndarray) -> np.ndarray:
    """Return grey levels x for x >= 0 and blue levels -x (NEGATIVE_COLOUR scaled) for x < 0: x (...) float -> (..., 3) float32.

    The N.L view uses it: with Clamp N.L off, N.L < 0 must not look like the 0 of a clamped value.
    """
    x = np.nan_to_num(np.asarray(x, np.float64))
    grey = np.repeat(np.maximum(x, 0.0)[..., None], 3, axis=-1)
    return (grey + np.maximum(-x, 0.0)[..., None] * NEGATIVE_COLOUR).astype(np.float32)


def heat(x: np.ndarray) -> np.ndarray:
    """Return heat-map colours for values in 0..1 (clipped): x (...) float -> (..., 3) float32.

    Black (0), blue (0.25), red (0.5), yellow (0.75), white (1), linear in between.
    """
    x = np.clip(np.nan_to_num(np.asarray(x, np.float64)), 0.0, 1.0)
    return np.stack([np.interp(x, HEAT_STOPS, HEAT_COLOURS[:, c]) for c in range(3)], axis=-1).astype(np.float32)
