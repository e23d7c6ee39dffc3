"""Curves (hair, fur, strands) as triangle tubes: Cycles' thick curves, approximated.

Cycles renders a curve as a round tube swept along a Catmull-Rom spline through its control points (Embree's round
Catmull-Rom curve; the first and last point repeated so that the spline passes through both ends), its radius
interpolated by the same spline, and shades it with the normal pointing from the spline out to the hit. Primer's
tracer meets triangles only, so each curve becomes a tube: `steps` points per span of the spline, a ring of
`sides` vertices around each (turned along the curve by a rotation-minimising frame, so the tube does not twist),
smooth normals pointing out of the spline, and a flat cap at each end. The tube is inscribed in Cycles' round one: its
silhouette lies within r (1 - cos(pi / sides)) of it (1.7 % of the radius with 12 sides), and its smooth normals are
Cycles' at the ring vertices. Ribbons (Cycles' other curve shape) are noted by the add-on.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..materials.procedural import hash as hash_
from ..scene import Mesh


class Tubes(NamedTuple):
    """Curves tessellated: the mesh and, per triangle, the curve it belongs to."""

    mesh: Mesh
    curve: np.ndarray          # (t,) int64 the curve of each triangle


def catmull_rom(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The uniform Catmull-Rom spline between p1 and p2 (its neighbours p0, p3: (..., k) arrays) at t (...,) in
    [0, 1]: 0.5 (2 p1 + (p2 - p0) t + (2 p0 - 5 p1 + 4 p2 - p3) t^2 + (3 p1 - p0 - 3 p2 + p3) t^3)."""
    t = t[..., None]
    return 0.5 * (2.0 * p1 + (p2 - p0) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t * t
                  + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t * t * t)


def spline_points(keys: np.ndarray, first: np.ndarray, counts: np.ndarray, steps: int,
                  linear_from: int = None) -> tuple:
    """Each curve's spline sampled `steps` times per span (its ends included): (samples (c, s, k) float64 position
    and radius, padded with each curve's last sample; valid (c, s) bool). keys (p, k) float64 the control points'
    position, radius and any more columns, those from `linear_from` on interpolated linearly between the span's two
    points instead of by the spline; first, counts (c,) int the curves' first key and number of keys (at least 2)."""
    spans = counts - 1
    s = int(spans.max()) * steps + 1
    j = np.minimum(np.arange(s)[None, :], spans[:, None] * steps)         # (c, s) the sample along each curve
    span = np.minimum(j // steps, spans[:, None] - 1)
    t = (j - span * steps) / steps
    index = lambda k: first[:, None] + np.clip(span + k, 0, counts[:, None] - 1)  # noqa: E731 (the 4 keys of a span)
    samples = catmull_rom(keys[index(-1)], keys[index(0)], keys[index(1)], keys[index(2)], t)
    if linear_from is not None:
        samples[..., linear_from:] = ((1.0 - t)[..., None] * keys[index(0)][..., linear_from:]
                                      + t[..., None] * keys[index(1)][..., linear_from:])
    return samples, np.arange(s)[None, :] <= spans[:, None] * steps


def frames(centres: np.ndarray) -> tuple:
    """A rotation-minimising frame along each sampled curve (Wang et al.'s double reflection): (tangent, normal,
    binormal), each (c, s, 3) float64 unit. centres (c, s, 3)."""
    c, s, _ = centres.shape
    tangent = np.gradient(centres, axis=1) if s > 1 else np.zeros_like(centres)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=2, keepdims=True), 1e-30)
    normal = np.empty_like(centres)
    start = np.cross(tangent[:, 0], np.where(np.abs(tangent[:, 0, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]]))
    normal[:, 0] = start / np.maximum(np.linalg.norm(start, axis=1, keepdims=True), 1e-30)
    for k in range(1, s):
        # Reflect the frame in the plane between the two centres, then in the one between the tangents.
        v1 = centres[:, k] - centres[:, k - 1]
        c1 = np.maximum(np.einsum("ij,ij->i", v1, v1), 1e-30)[:, None]
        r = normal[:, k - 1] - (2.0 / c1) * np.einsum("ij,ij->i", v1, normal[:, k - 1])[:, None] * v1
        tl = tangent[:, k - 1] - (2.0 / c1) * np.einsum("ij,ij->i", v1, tangent[:, k - 1])[:, None] * v1
        v2 = tangent[:, k] - tl
        c2 = np.maximum(np.einsum("ij,ij->i", v2, v2), 1e-30)[:, None]
        normal[:, k] = r - (2.0 / c2) * np.einsum("ij,ij->i", v2, r)[:, None] * v2
        normal[:, k] /= np.maximum(np.linalg.norm(normal[:, k], axis=1, keepdims=True), 1e-30)
    return tangent, normal, np.cross(tangent, normal)


def curves_info(positions: np.ndarray, radius: np.ndarray, first: np.ndarray, counts: np.ndarray) -> tuple:
    """What the Curves Info node reads, as Cycles' Blender sync computes it for each curve (export_hair_curves): per
    control point (p,) Intercept (the length of the polyline through the points up to it over the whole, 0 at the
    root, 1 at the tip) and Thickness (twice the radius); per curve (c,) Length (that polyline's whole length),
    Random (hash_uint2_to_float(curve, 0)) and Is Strand (1). -> ({name: (p,)}, {name: (c,)}), names "curve:...".
    (Its Tangent Normal reads the tubes' spline tangent, "curve_tangent", which `tubes` adds.)"""
    positions = np.asarray(positions, np.float64)
    first, counts = np.asarray(first, np.int64), np.asarray(counts, np.int64)
    curve_of = np.repeat(np.arange(len(counts)), counts)
    step = np.zeros(len(positions))
    inner = np.ones(len(positions), bool)
    inner[first[counts > 0]] = False                                   # (each curve's first point starts at 0)
    step[1:] = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    step[~inner] = 0.0
    along = np.cumsum(step)
    along -= np.repeat(along[first] if len(first) else np.zeros(0), counts)
    length = np.zeros(len(counts))
    np.add.at(length, curve_of, step)
    total = length[curve_of]
    intercept = np.divide(along, total, out=along.copy(), where=total > 0.0)
    random = hash_.uint_to_float(hash_.hash_uint2(np.arange(len(counts)), 0)).astype(np.float64)
    per_point = {"curve:intercept": intercept, "curve:thickness": 2.0 * np.asarray(radius, np.float64)}
    per_curve = {"curve:length": length, "curve:random": random, "curve:strand": np.ones(len(counts))}
    return per_point, per_curve


def tubes(positions: np.ndarray, radius: np.ndarray, first: np.ndarray, counts: np.ndarray, sides: int = 12,
          steps: int = 8, name: str = "Curves", linear: bool = False, info: tuple = None) -> Tubes:
    """The curves (control points positions (p, 3), radius (p,); curve k has counts[k] points from first[k]) as
    smooth triangle tubes (module docstring); linear: straight between the points (Cycles' Thick Linear), one ring
    per point. Curves of fewer than 2 points are left out. info: the Curves Info values (curves_info, computed from
    these points when None), carried per vertex in Mesh.curve_info: a control point's interpolated linearly along
    each span (as Cycles interpolates a curve key attribute by the segment's u), a curve's the same all along it."""
    # 1. The spline of each curve, and a frame along it.
    keep = np.flatnonzero(counts >= 2)
    keys = np.concatenate([np.asarray(positions, np.float64), np.asarray(radius, np.float64)[:, None]], axis=1)
    if len(keep) == 0:
        return Tubes(Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), name=name), np.zeros(0, np.int64))
    per_point, per_curve = curves_info(positions, radius, first, counts) if info is None else info
    keys = np.concatenate([keys] + [np.asarray(v, np.float64)[:, None] for v in per_point.values()], axis=1)
    samples, valid = spline_points(keys, np.asarray(first)[keep], np.asarray(counts)[keep], 1 if linear else steps,
                                   linear_from=4)
    centres, r = samples[..., :3], np.maximum(samples[..., 3], 0.0)
    sampled = samples[..., 4:]                                                # (c, s, the per-point values)
    tangent, normal, binormal = frames(centres)
    c, s = valid.shape
    # 2. A ring of vertices around each sample, pointing out of the spline, and a centre at each end for its cap.
    angle = 2.0 * np.pi * np.arange(sides) / sides
    out = np.cos(angle)[None, None, :, None] * normal[:, :, None] + np.sin(angle)[None, None, :, None] * binormal[:, :, None]
    rings = centres[:, :, None] + r[:, :, None, None] * out                    # (c, s, sides, 3)
    last = valid.sum(axis=1) - 1                                              # each curve's last sample
    ends = np.stack([centres[:, 0], centres[np.arange(c), last]], axis=1)     # (c, 2, 3)
    vertices = np.concatenate([rings.reshape(-1, 3), ends.reshape(-1, 3)])
    ring_normals = out.reshape(-1, 3)
    end_normals = np.stack([-tangent[:, 0], tangent[np.arange(c), last]], axis=1).reshape(-1, 3)
    # 3. Two triangles between neighbouring samples for each side (counter-clockwise seen from outside), a fan
    #    for each cap.
    ring = lambda k, j, i: (k * s + j) * sides + i % sides                    # noqa: E731 (a ring vertex's index)
    k, j, i = np.meshgrid(np.arange(c), np.arange(s - 1), np.arange(sides), indexing="ij")
    along = valid[k, j + 1]
    k, j, i = k[along], j[along], i[along]
    a, b, cc, d = ring(k, j, i), ring(k, j, i + 1), ring(k, j + 1, i + 1), ring(k, j + 1, i)
    side_tris = np.concatenate([np.stack([a, b, cc], 1), np.stack([a, cc, d], 1)])
    side_curve = np.concatenate([k, k])
    centre = c * s * sides + 2 * np.arange(c)
    kk, ii = np.meshgrid(np.arange(c), np.arange(sides), indexing="ij")
    kk, ii = kk.ravel(), ii.ravel()
    start_caps = np.stack([centre[kk], ring(kk, 0, ii + 1), ring(kk, 0, ii)], 1)
    end_caps = np.stack([centre[kk] + 1, ring(kk, last[kk], ii), ring(kk, last[kk], ii + 1)], 1)
    triangles = np.concatenate([side_tris, start_caps, end_caps]).astype(np.int64)
    curve = keep[np.concatenate([side_curve, kk, kk])]
    # 4. Normals per corner: out of the spline on the sides, along the curve on the caps (flat).
    corner_normals = np.concatenate([ring_normals, end_normals])[triangles]
    caps = np.arange(len(triangles)) >= len(side_tris)
    corner_normals[caps] = np.concatenate([end_normals[2 * kk], end_normals[2 * kk + 1]])[:, None, :]
    mesh = Mesh(vertices, triangles, smooth=np.ones(len(triangles), bool), corner_normals=corner_normals, name=name)
    # 5. The Curves Info values per vertex: a ring's its sample's, a cap centre's its end sample's.
    ends_of = np.stack([sampled[:, 0], sampled[np.arange(c), last]], axis=1).reshape(2 * c, -1)
    point_rows = np.concatenate([np.repeat(sampled.reshape(c * s, -1), sides, axis=0), ends_of])
    mesh.curve_info = {name_: point_rows[:, k] for k, name_ in enumerate(per_point)}
    vertex_curve = np.concatenate([np.repeat(keep, s * sides), np.repeat(keep, 2)])
    mesh.curve_info.update({name_: np.asarray(v, np.float64)[vertex_curve] for name_, v in per_curve.items()})
    ends_tangent = np.stack([tangent[:, 0], tangent[np.arange(c), last]], axis=1).reshape(2 * c, 3)
    mesh.curve_info["curve_tangent"] = np.concatenate([np.repeat(tangent.reshape(c * s, 3), sides, axis=0),
                                                       ends_tangent])
    # The rotation-minimising normal (Blender's Minimum Twist normals start as it does, from tangent x Z): the major axis
    # of the Huang model's elliptical fibres (Cycles reads the curve's normal attribute).
    ends_normal = np.stack([normal[:, 0], normal[np.arange(c), last]], axis=1).reshape(2 * c, 3)
    mesh.curve_info["curve_normal"] = np.concatenate([np.repeat(normal.reshape(c * s, 3), sides, axis=0),
                                                      ends_normal])
    return Tubes(mesh, curve.astype(np.int64))
