"""Debug output: the tracer's intermediate quantities, one number (or colour) per sample.

"Use that debug output" (the lecture). Each function here turns what the
tracer already knows about a batch of samples into a quantity a student can
look at; core/render/__init__.py averages them per pixel (`AUX_BUFFERS`) and the
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

from .base import Recorder

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

    The time is measured per batch of pixels (core/render/__init__.py: TIME_TILE pixels), not per
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


# ---------------------------------------------------------------------------
# Debug buffers: what the integrator decided, summed per pixel (a Recorder)
# ---------------------------------------------------------------------------

# Auxiliary buffers a render can return, with their channel counts ("lights": one per light).
AUX_BUFFERS = {
    "depth": 1,         # distance along the camera's view axis (Blender's Z); 1e10 where nothing was hit
    "normal": 3,        # shading normal N, world space, facing the camera
    "face_normal": 3,   # face normal, world space, facing the camera
    "n_dot_l": "lights",     # max(N.L, 0) per light (N.L itself with the clamp switched off)
    "visibility": "lights",  # fraction of shadow rays per light that reached it
    "normal_angle": 1,  # angle between N and the face normal, degrees
    "barycentric": 3,   # (1 - u - v, u, v) of the hit
    "hit_distance": 1,  # t along the camera ray from the camera; 1e10 where nothing was hit
    "acne": 1,          # fraction of the pixel's shadow rays that hit the surface they left
    "rays": 1,          # camera rays plus shadow rays cast for the pixel
    "time": 1,          # seconds spent on the pixel (an estimate: share_time)
    "shutter_time": 1,  # the mean time in the shutter of the pixel's camera rays (0 open, 1 closed; 1/2 without blur)
}
MISS_DEPTH = 1e10
# Buffers that are per-pixel totals, not means over the hit samples; and the hidden denominator of "acne".
TOTAL_BUFFERS = ("rays", "time")
ACNE_CAST = "acne cast"
# Buffers of the camera rays themselves (hit or not): the render loop sums them (camera_ray_sums), and each pixel shows
# their mean over its traced rays (the hidden denominator CAMERA_RAYS).
CAMERA_RAY_BUFFERS = ("shutter_time",)
CAMERA_RAYS = "camera rays"


def aux_channels(names, lights: int) -> dict:
    """Return the film's sums for the debug buffers `names`: name -> channels (with acne's denominator)."""
    channels = {name: (lights if AUX_BUFFERS[name] == "lights" else AUX_BUFFERS[name]) for name in names}
    if "acne" in channels:
        channels[ACNE_CAST] = 1
    if any(name in channels for name in CAMERA_RAY_BUFFERS):
        channels[CAMERA_RAYS] = 1
    return channels


def camera_ray_sums(names, rays, p: int, spp: int) -> dict:
    """The camera-ray buffers among `names` summed per pixel over its traced rays, with their count: name -> (p, 1)
    float64. rays: the chunk's CameraRays (p spp of them, pixel by pixel); a ray without a time is at 1/2."""
    wanted = [name for name in names if name in CAMERA_RAY_BUFFERS]
    if not wanted:
        return {}
    traced = rays.valid.reshape(p, spp)
    time = rays.time if rays.time is not None else np.full(len(rays.valid), 0.5)
    sums = {CAMERA_RAYS: traced.sum(axis=1).astype(np.float64)[:, None]}
    if "shutter_time" in wanted:
        sums["shutter_time"] = np.where(traced, time.reshape(p, spp), 0.0).sum(axis=1)[:, None]
    return sums


class DebugRecorder(Recorder):
    """Keeps, for a batch of camera rays, the values the debug buffers show (core/integrators/base.py Recorder).

    Made per chunk by core/render/__init__.py; `pixel_sums` then sums them per pixel, over the samples that hit
    (except the per-pixel totals "rays" and "time", and "acne", a ratio of two sums).
    geometry: the WorldGeometry (acne asks it once more about blocked shadow rays).
    """

    def __init__(self, wanted, lights: int, geometry, camera_offset: np.ndarray, forward: np.ndarray,
                 self_hit_distance: float):
        self.wanted = set(wanted) | ({"rays"} if "time" in wanted else set())
        self.k = lights
        self.geometry = geometry
        self.camera_offset, self.forward = camera_offset, forward
        self.self_hit_distance = self_hit_distance
        self.surface = None

    def hits(self, O, D, surface, hit) -> None:
        self.surface, self.hit = surface, hit
        m = 0 if surface is None else len(surface.I)
        self.D_hit = D[hit]
        self.n_dot_l, self.visibility = np.zeros((m, self.k)), np.zeros((m, self.k))
        self.shadow_ray_count, self.acne = np.zeros(m), np.zeros(m)
        self.vertex = 0                      # a path's later vertices are not the camera's hits: not kept

    def path_vertex(self, vertex, owner, surface, throughput, L) -> None:
        self.vertex = vertex + 1

    def light_sample(self, light, count, sample, NL, NgL, cosine, face_allows, lit) -> None:
        if self.vertex > 0:
            return
        self.n_dot_l[:, light] += cosine / count

    def shadow_rays(self, light, count, rows, rays, seen) -> None:
        if self.vertex > 0:
            return
        self.visibility[rows, light] += seen / count
        self.shadow_ray_count[rows] += 1.0
        if "acne" in self.wanted:
            blocked = np.flatnonzero(~seen)
            self.acne[rows[blocked]] += self_intersections(
                self.geometry, rays.origins[blocked], rays.directions[blocked], rays.t_max[blocked],
                self.surface.prim[rows[blocked]], self.self_hit_distance)

    def shader(self, result) -> None:
        pass

    def contribution(self, light, rows, value, mis_weight) -> None:
        pass

    def bsdf_sample(self, wi, pdf, found) -> None:
        pass

    def per_hit(self, name: str) -> np.ndarray:
        """Return one debug buffer's value at each hit: (m, c) float64."""
        s = self.surface
        if name == "depth":
            return np.einsum("ij,j->i", s.I + self.camera_offset, self.forward)[:, None]
        if name == "normal":
            return s.N
        if name == "face_normal":
            return s.Ng
        if name == "n_dot_l":
            return self.n_dot_l
        if name == "visibility":
            return self.visibility
        if name == "normal_angle":
            return normal_angle(s.N, s.Ng)[:, None]
        if name == "barycentric":
            return barycentrics(s.u, s.v)
        if name == "hit_distance":
            return hit_distance(s.I, -self.camera_offset, self.D_hit)[:, None]
        raise KeyError(name)

    def pixel_sums(self, owner: np.ndarray, traced_per_pixel: np.ndarray) -> dict:
        """Sum the values per pixel: owner (m,) int64 each hit's pixel in the chunk; traced_per_pixel (p,)
        float64 camera rays traced per pixel -> name -> (p, c) float64 (sums, so that passes add up)."""
        p = len(traced_per_pixel)

        def total(values: np.ndarray) -> np.ndarray:
            values = values.reshape(len(owner), -1)
            out = np.zeros((p, values.shape[1]))
            for c in range(values.shape[1]):
                out[:, c] = np.bincount(owner, weights=values[:, c], minlength=p)
            return out

        hit = self.surface is not None
        sums = {}
        for name in self.wanted - {"time", *CAMERA_RAY_BUFFERS}:   # ("time" is measured around the chunk, the
            # camera rays' own buffers summed by the render loop: camera_ray_sums)
            if name == "rays":
                sums[name] = (traced_per_pixel + (total(self.shadow_ray_count)[:, 0] if hit else 0.0))[:, None]
            elif name == "acne":
                sums[name] = total(self.acne) if hit else np.zeros((p, 1))
                sums[ACNE_CAST] = total(self.shadow_ray_count) if hit else np.zeros((p, 1))
            elif not hit:
                sums[name] = np.zeros((p, self.k if AUX_BUFFERS[name] == "lights" else AUX_BUFFERS[name]))
            else:
                sums[name] = total(self.per_hit(name))
        return sums


def aux_images(sums: dict, hits: np.ndarray, names, height: int, width: int) -> dict:
    """Turn the film's debug sums into images: name -> (H, W, c) float32.

    Means over each pixel's samples that hit, except per-pixel totals (TOTAL_BUFFERS), and acne: shadow
    rays that hit their own surface per shadow ray cast. Pixels no sample hit: 0, or MISS_DEPTH for
    the distance buffers.
    """
    images = {}
    covered = hits > 0
    for name in names:
        values = sums[name]
        if name in TOTAL_BUFFERS:
            image = values.astype(np.float32)
        elif name == "acne":
            cast = sums[ACNE_CAST]
            image = np.where(cast > 0, values / np.maximum(cast, 1.0), 0.0).astype(np.float32)
        elif name in CAMERA_RAY_BUFFERS:
            rays = sums[CAMERA_RAYS]
            image = np.where(rays > 0, values / np.maximum(rays, 1.0), 0.0).astype(np.float32)
        else:
            image = np.full(values.shape, MISS_DEPTH if name in ("depth", "hit_distance") else 0.0, np.float32)
            image[covered] = values[covered] / hits[covered, None]
        images[name] = image.reshape(height, width, -1)
    return images
