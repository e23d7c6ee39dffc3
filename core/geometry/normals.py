"""Normals: the face normal of a triangle, vertex normals, and smooth shading.

The lecture's recipe for smooth surfaces:
1. a *vertex normal* is the normalised average of the normals of the triangles
   that share the vertex;
2. inside a triangle, the normal is interpolated from its corners with the
   barycentric coordinates of the hit, then normalised again.
Use the interpolated normal for N.L, but the face normal to decide whether a
light can be visible at all (`core/integrators/shadows.py`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..native import library, schema
from ..native.schema import F64, I64, out, ptr

from .. import vectors


class FaceNormals(NamedTuple):
    """Per-triangle geometry. normals: (t, 3) float64 unit (zero where degenerate); area: (t,) float64."""

    normals: np.ndarray
    area: np.ndarray


def safe_normalize(vectors: np.ndarray) -> np.ndarray:
    """Return vectors scaled to unit length; zero, infinite or NaN vectors become (0, 0, 0).

    vectors: (..., 3) float64 -> (..., 3) float64
    """
    length = np.sqrt(np.einsum("...i,...i->...", vectors, vectors))
    ok = np.isfinite(length) & (length > 0)
    out = np.zeros_like(vectors)
    np.divide(vectors, length[..., None], out=out, where=ok[..., None])
    return out


def face_normals(vertices: np.ndarray, triangles: np.ndarray) -> FaceNormals:
    """Return the unit normal and area of each triangle (counter-clockwise = front).

    vertices: (v, 3) float; triangles: (t, 3) int.
    """
    p0, p1, p2 = (vertices[triangles[:, k]].astype(np.float64) for k in range(3))
    cross = vectors.cross(p1 - p0, p2 - p0)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    return FaceNormals(safe_normalize(cross), np.where(np.isfinite(area), area, 0.0))


def corner_angles(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Return the interior angle at each corner of each triangle: (t, 3) float64 radians."""
    p = [vertices[triangles[:, k]].astype(np.float64) for k in range(3)]
    angles = np.zeros((len(triangles), 3))
    for k in range(3):
        a = safe_normalize(p[(k + 1) % 3] - p[k])
        b = safe_normalize(p[(k + 2) % 3] - p[k])
        angles[:, k] = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))
    return angles


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray, weighting: str = "angle") -> np.ndarray:
    """Return one unit normal per vertex: the weighted average of the adjacent face normals.

    weighting "angle" weighs each face by its corner angle at the vertex (as Blender
    does, so a vertex normal does not change when a face is split); "area" weighs
    by triangle area. vertices: (v, 3) float64; triangles: (t, 3) int -> (v, 3) float64.
    """
    faces = face_normals(vertices, triangles)
    if weighting == "angle":
        weights = corner_angles(vertices, triangles)
    elif weighting == "area":
        weights = np.repeat(faces.area[:, None], 3, axis=1)
    else:
        raise ValueError(f"unknown vertex-normal weighting {weighting!r}")
    summed = np.zeros((len(vertices), 3))
    for k in range(3):
        np.add.at(summed, triangles[:, k], faces.normals * weights[:, k:k + 1])
    return safe_normalize(summed)


def interpolate(corner_normals: np.ndarray, u: np.ndarray, v: np.ndarray,
                fallback: np.ndarray) -> np.ndarray:
    """Return the barycentric interpolation of corner normals, renormalised.

    N = normalize((1-u-v) N0 + u N1 + v N2). Where that sum vanishes (opposite
    corner normals) or is not finite, the fallback (the face normal) is used.
    corner_normals: (n, 3, 3) float; u, v: (n,) float64; fallback: (n, 3) float64 -> (n, 3) float64
    """
    w = 1.0 - u - v
    n = (w[:, None] * corner_normals[:, 0] + u[:, None] * corner_normals[:, 1]
         + v[:, None] * corner_normals[:, 2]).astype(np.float64)
    unit = safe_normalize(n)
    degenerate = ~unit.any(axis=1)
    unit[degenerate] = fallback[degenerate]
    return unit


def face_forward(normals: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Return the sign (+1/-1) that turns each normal against the incoming ray.

    The lecture: "if N . D > 0 then N = -N" (the surface was hit from behind or from inside).
    normals, directions: (n, 3) float64 -> (n,) float64
    """
    return np.where(np.einsum("ij,ij->i", normals, directions) > 0.0, -1.0, 1.0)


# ---------------------------------------------------------------------------
# The compiled twins (core/geometry/triangles.c)
# ---------------------------------------------------------------------------

FaceNormalsArgs = schema.function("primer_face_normals", "face_normals_rows", schema.record(
    "FaceNormalsArgs", "primer_face_normals' arguments: face_normals of t triangles.", [
        ("t", I64, ""),
        ("vertices", ptr(F64), "(v, 3)"),
        ("triangles", ptr(I64), "(t, 3)"),
        ("normals", out(F64), "(t, 3)"),
        ("area", out(F64), "(t,)"),
    ]))
TurnNormalsArgs = schema.function("primer_turn_normals", "turn_normals_rows", schema.record(
    "TurnNormalsArgs", "primer_turn_normals' arguments: corner normals turned by their placements' inverse.", [
        ("n", I64, ""),
        ("corners", ptr(F64), "(c, 3, 3)"),
        ("rows", ptr(I64), "(n,)"),
        ("inverse", ptr(F64), "(p, 3, 3)"),
        ("placement", ptr(I64), "(n,)"),
        ("out", out(F64), "(n, 3, 3)"),
    ]))


def compiled_face_normals(vertices: np.ndarray, triangles: np.ndarray) -> FaceNormals:
    """face_normals in one compiled pass: vertices (v, 3) float64, triangles (t, 3) int64 (in range)
    -> FaceNormals of (t, 3) unit normals and (t,) areas, the same numbers."""
    vertices, triangles = library.contiguous(vertices, np.float64), library.contiguous(triangles, np.int64)
    normals, area = np.empty((len(triangles), 3)), np.empty(len(triangles))
    library.call("primer_face_normals", FaceNormalsArgs(t=len(triangles), vertices=vertices, triangles=triangles,
                                                        normals=normals, area=area))
    return FaceNormals(normals, area)


def compiled_turn_normals(corners: np.ndarray, rows: np.ndarray, inverse: np.ndarray, placement: np.ndarray) -> np.ndarray:
    """safe_normalize(vectors.rows_times_each(corners[rows], inverse[placement])) in one compiled pass:
    corners (c, 3, 3), inverse (p, 3, 3) float64; rows (n,) and placement (n,) int64 -> (n, 3, 3)."""
    corners, inverse = library.contiguous(corners, np.float64), library.contiguous(inverse, np.float64)
    rows, placement = library.contiguous(rows, np.int64), library.contiguous(placement, np.int64)
    turned = np.empty((len(rows), 3, 3))
    library.call("primer_turn_normals", TurnNormalsArgs(n=len(rows), corners=corners, rows=rows, inverse=inverse,
                                                        placement=placement, out=turned))
    return turned
