"""Rays a shader traces while it is evaluated: Cycles' Ambient Occlusion and Bevel nodes (svm/ao.h, svm/bevel.h).

Most shader nodes read only the hit (core/materials/graph.py ShadingPoint). These two look around it in the scene, so
the integrator hands the materials a ShaderRays for the hits it shades (MaterialTable.shade(..., rays=...)): the
scene's intersector, the hits and the keys of their random numbers (pixel, sample, the vertex's dimension shift).
Only materials whose program holds one of graph.RAYTRACE_OPS read it; the integrators make one only where the scene
has such a material (MaterialTable.traces), so other scenes pay nothing. Shadow rays and light samples landing on an
emitter shade without it, as Cycles does (there Ambient Occlusion is 1 and Bevel the shading normal).

- **Ambient Occlusion**: `samples` rays cosine-distributed about N (or -N, Inside), each the index
  sample x samples + j of the pixel's pattern at AO_NODE_DIMENSION, up to Distance; the share that nothing blocks
  (any surface, opaque or not, as Cycles' opaque shadow query), or, Only Local, that no triangle of the hit's own
  object blocks.
- **Bevel**: `samples` probes, each a point on a disk of radius Radius about the hit in a plane picked among three
  (across Ng with probability 1/2, across either tangent 1/4), at a distance from the centre drawn from the cubic
  falloff 10 (R - r)^3 / (pi R^5), shot straight through the disk's plane from a height sqrt(R^2 - r^2) on either
  side; every triangle of the hit's object it meets (the nearest BEVEL_MAX_HITS) adds its smooth normal weighted by
  the three planes' multiple importance (power heuristic) and the falloff at its true distance over the falloff at
  the disk's. The normalised sum, turned to the side the hit was seen from, is the Bevel normal.
"""
from __future__ import annotations

import numpy as np

from ..geometry import normals as normals_
from ..materials.graph import AO_INSIDE, AO_ONLY_LOCAL
from ..materials.lambert import Lambert
from ..native import schema
from ..sampling import sobol as sampling
from . import shadows

AO_NODE_DIMENSION = schema.constant("AO_NODE_DIMENSION", 121, "the Ambient Occlusion node's rays' sampling dimension")
BEVEL_DIMENSION = schema.constant("BEVEL_DIMENSION", 122, "the Bevel node's probes' sampling dimension")
BEVEL_MAX_HITS = schema.constant("BEVEL_MAX_HITS", 4, "the hits of its object a Bevel probe counts (LOCAL_MAX_HITS)")
# How many surfaces of other objects (or beyond the hits counted) a local ray steps past before it gives up.
LOCAL_STEPS = schema.constant("LOCAL_STEPS", 16, "how many surfaces a ray looking for its own object's steps past")
# A path that bounced with a pdf below this somewhere (Cycles' min_ray_pdf: a diffuse or rough bounce) bevels nothing.
BEVEL_MIN_PDF = schema.constant("BEVEL_MIN_PDF", 8.0, "the smallest bounce pdf after which Bevel still traces")


def for_hits(ctx, surface, pixel: np.ndarray, sample: np.ndarray, dimension: int = 0, min_pdf=None):
    """The ShaderRays of the hits `surface` (pixel, sample (k,) int64, the vertex's dimension shift; min_pdf (k,) the
    smallest pdf of each path's real bounces so far, None: none, a camera ray's hits) where some material traces rays
    (MaterialTable.traces), else None."""
    if not getattr(ctx.materials, "traces", False) or surface is None:
        return None
    blurry = None if min_pdf is None else np.asarray(min_pdf) < BEVEL_MIN_PDF
    return ShaderRays(ctx, surface, pixel, sample, dimension, blurry=blurry)


class ShaderRays:
    """The rays the shaders of k hits may trace: the context's geometry and seed, the hits (camera-relative points I,
    face normals Ng facing the viewer, corners, triangles prim) and their random numbers' keys pixel, sample (k,)
    int64 and the vertex's dimension shift; blurry (k,) bool the hits a path reached after a bounce of pdf below
    BEVEL_MIN_PDF (a diffuse or rough one), where Bevel keeps the shading normal, as Cycles does.
    Indexing by rows gives the ShaderRays of those hits."""

    def __init__(self, ctx, surface, pixel: np.ndarray, sample: np.ndarray, dimension: int = 0, rows=None,
                 blurry=None):
        self.ctx, self.surface, self.dimension = ctx, surface, int(dimension)
        self.pixel, self.sample = np.asarray(pixel, np.int64), np.asarray(sample, np.int64)
        self.rows = np.arange(len(self.pixel)) if rows is None else rows
        self.blurry = np.zeros(len(self.pixel), bool) if blurry is None else blurry

    def __getitem__(self, rows) -> "ShaderRays":
        """The ShaderRays of hits `rows` of these."""
        return ShaderRays(self.ctx, self.surface, self.pixel, self.sample, self.dimension, self.rows[rows],
                          self.blurry)

    def __len__(self) -> int:
        return len(self.rows)

    def _hits(self):
        """(I, Ng, vertices, prim, pixel, sample) of these hits."""
        s, r = self.surface, self.rows
        return s.I[r], s.Ng[r], s.vertices[r], np.asarray(s.prim)[r], self.pixel[r], self.sample[r]

    def _times(self):
        """The hits' times in the shutter (their rays carry them: where moving objects are), or None."""
        return None if self.surface.time is None else self.surface.time[self.rows]

    def ambient_occlusion(self, N: np.ndarray, distance: np.ndarray, samples: int, flags: int) -> np.ndarray:
        """Cycles' svm_ao: the share (k,) float64 of `samples` cosine-distributed rays about the unit N (k, 3) (-N with
        AO_INSIDE) that nothing blocks within `distance` (k,) (only the hit's own object with AO_ONLY_LOCAL); 1 where
        distance <= 0 or samples < 1."""
        I, Ng, vertices, prim, pixel, sample = self._hits()
        k = len(I)
        distance = np.broadcast_to(np.asarray(distance, np.float64), (k,))
        if samples < 1 or k == 0:
            return np.ones(k)
        around = -N if flags & AO_INSIDE else N
        step = shadows.error_bound(I, vertices)
        geometry = self.ctx.geometry
        owner = geometry.owners(prim) if flags & AO_ONLY_LOCAL else None
        times = self._times()
        open_ = np.zeros(k)
        for j in range(samples):
            u = sampling.sample_2d(self.ctx.settings.seed, pixel, sample * samples + j,
                                   dimension=AO_NODE_DIMENSION + self.dimension)
            wi = Lambert.sample(None, around, None, u).wi
            origin = shadows.spawn_ray(I, Ng, wi, step)
            t = np.maximum(distance, 0.0)
            if owner is None:
                blocked = geometry.tracer.occluded(origin, wi, t, times)
            else:
                blocked = local_hits(geometry, origin, wi, t, owner, 1, times)[0] > 0
            open_ += ~blocked
        return np.where(distance > 0.0, open_ / samples, 1.0)

    def bevel(self, radius: np.ndarray, samples: int, N: np.ndarray, side: np.ndarray) -> np.ndarray:
        """Cycles' svm_bevel: the normal (k, 3) float64 averaged over the hit's object within `radius` (k,), turned
        towards the viewer (side (k,) -1 where the back was hit); the shading normal N (k, 3) where radius <= 0,
        samples < 1 or no probe met the object."""
        I, Ng, _, prim, pixel, sample = self._hits()
        k = len(I)
        radius = np.broadcast_to(np.asarray(radius, np.float64), (k,))
        if samples < 1 or k == 0:
            return N
        geometry = self.ctx.geometry
        owner = geometry.owners(prim)
        times = self._times()
        T0, B0 = orthonormals(Ng)
        total = np.zeros((k, 3))
        R = np.maximum(radius, 0.0)
        for j in range(samples):
            u = sampling.sample_2d(self.ctx.settings.seed, pixel, sample * samples + j,
                                   dimension=BEVEL_DIMENSION + self.dimension)
            # 1. The disk's plane: across Ng (1/2), across T or across B (1/4 each); u.x reused within its share.
            axis = np.where(u[:, 0] < 0.5, 0, np.where(u[:, 0] < 0.75, 1, 2))
            x = np.where(axis == 0, 2.0 * u[:, 0], np.where(axis == 1, (u[:, 0] - 0.5) * 4.0, (u[:, 0] - 0.75) * 4.0))
            disk_N = np.where((axis == 0)[:, None], Ng, np.where((axis == 1)[:, None], T0, B0))
            disk_T = np.where((axis == 1)[:, None], Ng, T0)
            disk_B = np.where((axis == 2)[:, None], Ng, B0)
            pick = np.stack([np.where(axis == 0, 0.5, 0.25), np.where(axis == 1, 0.5, 0.25),
                             np.where(axis == 2, 0.5, 0.25)], axis=1)
            # 2. The point on the disk, at the cubic falloff's distance, and the probe through it.
            r = cubic_root(u[:, 1]) * R
            h = np.sqrt(np.maximum(R * R - r * r, 0.0))
            phi = 2.0 * np.pi * x
            disk_P = (r * np.cos(phi))[:, None] * disk_T + (r * np.sin(phi))[:, None] * disk_B
            origin = I + disk_N * h[:, None] + disk_P
            count, hits = local_hits(geometry, origin, -disk_N, 2.0 * h, owner, BEVEL_MAX_HITS, times)
            # 3. Each hit's smooth normal, weighed by the planes' MIS and the falloff at its true distance.
            for prim_hit, uu, vv, t, found in hits:
                rows = np.flatnonzero(found & (R > 0.0))
                if len(rows) == 0:
                    continue
                data = geometry.triangle_data(prim_hit[rows], smooth=True, times=None if times is None else times[rows])
                hit_Ng, hit_N = data.Ng, data.Ng.copy()
                if data.smooth.any():
                    s = data.smooth
                    hit_N[s] = normals_.interpolate(data.corner_normals, uu[rows][s], vv[rows][s], hit_Ng[s])
                p = pick[rows] * np.abs(np.stack([np.einsum("ij,ij->i", d[rows], hit_Ng)
                                                  for d in (disk_N, disk_T, disk_B)], axis=1))
                w = p[:, 0] / np.maximum((p * p).sum(axis=1), 1e-300)
                w = np.where(p[:, 0] > 0.0, w, 0.0)
                w = w * np.maximum(count[rows], BEVEL_MAX_HITS) / BEVEL_MAX_HITS
                hit_P = origin[rows] + t[rows, None] * -disk_N[rows]
                distance = np.linalg.norm(hit_P - I[rows], axis=1)
                w = w * cubic(R[rows], distance) / np.maximum(cubic(R[rows], r[rows]), 1e-300)
                total[rows] += w[:, None] * hit_N
        length = np.linalg.norm(total, axis=1)
        out = np.divide(total, length[:, None], out=np.zeros_like(total), where=length[:, None] > 0.0)
        out = out * side[:, None]
        return np.where(((length > 0.0) & (R > 0.0) & ~self.blurry[self.rows])[:, None], out, N)


def orthonormals(N: np.ndarray) -> tuple:
    """Two unit tangents (k, 3) T, B with N (k, 3) unit making a right-handed frame (Cycles' make_orthonormals)."""
    a = np.where((N[:, 0:1] != N[:, 1:2]) | (N[:, 0:1] != N[:, 2:3]),
                 np.stack([N[:, 2] - N[:, 1], N[:, 0] - N[:, 2], N[:, 1] - N[:, 0]], axis=1),
                 np.stack([N[:, 2] - N[:, 1], N[:, 0] + N[:, 2], -N[:, 1] - N[:, 0]], axis=1))
    T = a / np.linalg.norm(a, axis=1, keepdims=True)
    return T, np.cross(N, T)


def cubic(radius: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The Bevel's planar cubic falloff 10 (R - r)^3 / (pi R^5), 0 from r = R on: (k,) float64."""
    R = np.maximum(radius, 1e-300)
    f = np.maximum(R - r, 0.0)
    return np.where(r < radius, 10.0 * (f * f * f) / (np.pi * R ** 5.0), 0.0)


def cubic_root(xi: np.ndarray) -> np.ndarray:
    """The radius x in [0, 1] (k,) where the cubic falloff's cumulative 10x^2 - 20x^3 + 15x^4 - 4x^5 reaches xi (k,):
    Newton's method from 0.25, at most 10 steps, stopped within 1e-6 (Cycles' svm_bevel_cubic_quintic_root_find)."""
    x = np.full(len(xi), 0.25)
    going = np.ones(len(xi), bool)
    for _ in range(10):
        x2 = x * x
        f = 10.0 * x2 - 20.0 * x2 * x + 15.0 * x2 * x2 - 4.0 * x2 * x2 * x - xi
        slope = 20.0 * (x * (1.0 - x)) * ((1.0 - x) * (1.0 - x))
        going &= (np.abs(f) >= 1e-6) & (slope != 0.0)
        x = np.where(going, np.clip(x - f / np.where(slope != 0.0, slope, 1.0), 0.0, 1.0), x)
    return x


def local_hits(geometry, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, owner: np.ndarray, most: int,
               times=None) -> tuple:
    """The hits of rays O + t D, t in (0, t_max) (k,), on triangles of the objects `owner` (k,) int64 (Cycles'
    scene_intersect_local): (how many it met (k,) int64, capped at `most` + 1 past which it stops looking; a list of
    `most` (prim, u, v, t, found) the nearest first, each (k,) arrays). Other objects' triangles are stepped past,
    up to LOCAL_STEPS surfaces in all; each surface counts once (a triangle met again right after itself, as float32
    rays far from the origin do, is stepped past uncounted). times: (k,) the rays' times in the shutter (where moving
    objects are), or None."""
    k = len(O)
    count = np.zeros(k, np.int64)
    hits = [(np.zeros(k, np.int64), np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k, bool)) for _ in range(most)]
    start = np.zeros(k)                                 # how far along the ray the search has got
    last = np.full(k, -1, np.int64)                     # the triangle met last
    alive = np.flatnonzero(t_max > 0.0)
    for _ in range(LOCAL_STEPS):
        if len(alive) == 0:
            break
        here = O[alive] + start[alive, None] * D[alive]
        found = geometry.tracer.intersect(here, D[alive], t_max[alive] - start[alive],
                                          None if times is None else times[alive])
        met = found.hit
        t = start[alive] + found.t
        again = met & (found.prim == last[alive])
        last[alive] = np.where(met, found.prim, -1)
        mine = met & ~again & (geometry.owners(np.where(met, found.prim, 0)) == owner[alive])
        for slot in range(most):
            rows = alive[mine & (count[alive] == slot)]
            sel = mine & (count[alive] == slot)
            prim, u, v, tt, ok = hits[slot]
            prim[rows], u[rows], v[rows], tt[rows], ok[rows] = found.prim[sel], found.u[sel], found.v[sel], t[sel], True
        count[alive[mine]] += 1
        # On from just past the surface met: a step relative to the distance and at least the robust offset of the
        # point met (ROBUST_ULPS float32 ulps of its largest coordinate: Embree's float32 rays, far from the origin).
        at = np.where(met, t, 0.0)                      # (rays that met nothing stop here: no point to step from)
        robust = shadows.ROBUST_ULPS * shadows.FLOAT32_EPSILON * shadows.largest_coordinate(O[alive] + at[:, None] * D[alive])
        start[alive] = t + np.maximum(np.maximum(1e-5 * np.maximum(t, 1e-3), 1e-7), robust)
        keep = met & (count[alive] <= most) & (start[alive] < t_max[alive])
        alive = alive[keep]
    return count, hits
