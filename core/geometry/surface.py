"""The surface where a ray hits: the point I, the face normal, the shading normal N, the material.

The lecture's normals: the face normal Ng decides which side of the triangle a point is on (and so
whether a light can be seen from it), the interpolated normal N shades smooth triangles; both are
turned to face the viewer when a triangle is hit from behind.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from . import normals as normals_


class Surface(NamedTuple):
    """Surface records of n hits, camera-relative.

    I:        (n, 3) float64 hit points
    N:        (n, 3) float64 unit shading normals, facing the viewer
    Ng:       (n, 3) float64 unit face normals, facing the viewer
    material: (n,) int32 row of the scene's material table (core/materials)
    vertices: (n, 3, 3) float64 the hit triangles' corners
    corners:  (n, 3, 3) float64 corner normals, facing the viewer (zeros on flat triangles)
    smooth:   (n,) bool where N was interpolated
    u, v:     (n,) float64 barycentric coordinates
    prim:     (n,) int64 the hit triangle (WorldGeometry's flat index)
    t:        (n,) float64 Embree's distance along the ray
    backfacing: (n,) bool where the ray hit the triangle from behind (it leaves a closed object: glass
              bends it with 1 / IOR)
    time:     (n,) float64 each hit's time in the shutter, where a moving object was met (object motion blur), or
              None: no object moves
    Read-only: N may be the very array Ng is (no hit smooth), and corners a broadcast view of zeros.
    """

    I: np.ndarray
    N: np.ndarray
    Ng: np.ndarray
    material: np.ndarray
    vertices: np.ndarray
    corners: np.ndarray
    smooth: np.ndarray
    u: np.ndarray
    v: np.ndarray
    prim: np.ndarray
    t: np.ndarray
    backfacing: np.ndarray = None
    time: np.ndarray = None


def hit_points(vertices: np.ndarray, Ng: np.ndarray, u: np.ndarray, v: np.ndarray,
               O: np.ndarray, D: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Return the hit points I, as precise as float64 allows.

    Embree's t and (u, v) are float32: good to ~1e-7 of the triangle's size. We intersect the
    float64 ray with the triangle's plane again, t = (V0 - O).Ng / D.Ng, and keep that refinement
    wherever it agrees with Embree's t to float32 precision (it does not at grazing angles, where
    the barycentric point is the better one).
    vertices: (n, 3, 3) float64; Ng: (n, 3) unit; u, v, t: (n,) float64; O, D: (n, 3) float64.
    """
    # 1. The float64 ray meets the triangle's plane at t_plane.
    DNg = np.einsum("ij,ij->i", D, Ng)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_plane = np.einsum("ij,ij->i", vertices[:, 0] - O, Ng) / DNg
    I = O + t_plane[:, None] * D
    # 2. Where that disagrees with Embree's t (grazing rays), the barycentric point instead.
    disagrees = np.flatnonzero(~(np.abs(t_plane - t) <= 1e-5 * np.abs(t) + 1e-30))
    if len(disagrees):
        w = 1.0 - u[disagrees] - v[disagrees]
        corners = vertices[disagrees]
        I[disagrees] = (w[:, None] * corners[:, 0] + u[disagrees, None] * corners[:, 1]
                        + v[disagrees, None] * corners[:, 2])
    return I


def surface_at_hits(geometry, prim: np.ndarray, u: np.ndarray, v: np.ndarray,
                    O: np.ndarray, D: np.ndarray, t: np.ndarray, flat_only: bool = False,
                    times: Optional[np.ndarray] = None) -> Surface:
    """Return the surface records of hits on `geometry` (core/geometry/geometry.py WorldGeometry).

    prim: (n,) int64 triangle index; u, v, t: (n,) float64 barycentrics and distance;
    O, D: (n, 3) float64 camera-relative ray origins and directions.
    flat_only: ignore smooth shading (the lecture's "flat normals" switch).
    times: (n,) float64 the rays' times in the shutter: a moving object is where it is then (None: still).
    """
    # 1. I on the float32 triangle Embree hit (a moving one where it is at the ray's time).
    triangle = geometry.triangle_data(prim, smooth=geometry.has_smooth and not flat_only, times=times)
    vertices, Ng = triangle.corners, triangle.Ng                                # (n, 3, 3), (n, 3)
    I = hit_points(vertices, Ng, u, v, O, D, t)
    # 2. The face normal, flipped when the triangle was hit from behind (N.D > 0).
    side = normals_.face_forward(Ng, D)
    Ng = Ng * side[:, None]
    N = Ng
    corners = np.broadcast_to(np.zeros((1, 3, 3)), vertices.shape)     # read-only zeros: no smooth work
    smooth = triangle.smooth
    if smooth.any():
        # 3. Interpolated normals only where the triangle is smooth.
        N, corners = Ng.copy(), np.zeros_like(vertices)
        corners[smooth] = triangle.corner_normals * side[smooth, None, None]
        N[smooth] = normals_.interpolate(corners[smooth], u[smooth], v[smooth], Ng[smooth])
    return Surface(I, N, Ng, triangle.material, vertices, corners, smooth, u, v, np.asarray(prim, np.int64),
                   np.asarray(t, np.float64), side < 0.0, None if times is None else np.asarray(times, np.float64))


def shading_point(geometry, surface: Surface):
    """What a material's node graph reads at each hit (core/materials/graph.py ShadingPoint): the mesh
    attributes interpolated with the barycentrics (w = 1 - u - v at corner 0, u at 1, v at 2) and their
    changes along u and v, the object's random number and linear transform, the side that was hit, the
    triangle's edges, the world point, the barycentrics and the distance along the ray."""
    from ..materials import graph as graph_
    prim = surface.prim
    n = len(prim)
    rows, owner, linear = hit_owners(geometry, prim, surface.time)
    random = geometry.instance_random[owner] if len(geometry.instance_random) else np.zeros(n)
    info = (geometry.instance_info[owner] if len(geometry.instance_info)
            else np.zeros((n, geometry.instance_info.shape[1])))
    attributes, d_du, d_dv = hit_attributes(geometry, rows, surface.u, surface.v)
    front = geometry.triangle_data(prim, smooth=False, times=surface.time).Ng
    side = np.where(np.einsum("ij,ij->i", front, surface.Ng) < 0.0, -1.0, 1.0)
    V = surface.vertices
    return graph_.ShadingPoint(attributes, d_du, d_dv, random, surface.N, side, linear, V[:, 1] - V[:, 0],
                               V[:, 2] - V[:, 0], surface.Ng, P=surface.I + geometry.origin,
                               uv=np.stack([surface.u, surface.v], axis=1), t=np.asarray(surface.t, np.float64),
                               info=info)


def hit_owners(geometry, prim: np.ndarray, times: Optional[np.ndarray] = None) -> tuple:
    """Return, for the hit triangles `prim` (n,) int64: (row of geometry.attributes (n,) int64, index into
    Scene.instances of the object hit (n,) int64, that object's linear transform (n, 3, 3) float64, a moving one's
    at the hits' `times` (n,))."""
    n = len(prim)
    rows, owner = np.zeros(n, np.int64), np.zeros(n, np.int64)
    linear = np.zeros((n, 3, 3))
    copied = np.flatnonzero(prim < len(geometry.triangles))
    if len(copied):
        if len(geometry.attribute_row):
            rows[copied] = geometry.attribute_row[prim[copied]]
        owner[copied] = geometry.instance[prim[copied]]
        linear[copied] = geometry.instance_linear[owner[copied]]
    for mesh in geometry.instanced:
        at = np.flatnonzero((prim >= mesh.first_prim) & (prim < mesh.first_prim + mesh.triangle_count))
        if len(at) == 0:
            continue
        j, local = mesh.split(prim[at])
        if mesh.attribute_row is not None:
            rows[at] = mesh.attribute_row[local]
        owner[at] = mesh.owner[j]
        linear[at] = mesh.placements(j, None if times is None else np.asarray(times)[at])[:, :, :3]
    return rows, owner, linear


def hit_attributes(geometry, rows: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple:
    """Return the mesh attributes at hits on attribute rows `rows` (n,) int64 with barycentrics u, v (n,):
    (values (n, A), their change along u (n, A), along v (n, A)) float64, A = 0 without attributes."""
    n = len(rows)
    if geometry.attributes is None:
        return np.zeros((n, 0)), np.zeros((n, 0)), np.zeros((n, 0))
    corners = geometry.attributes[rows].astype(np.float64)                      # (n, 3, A)
    w = (1.0 - u - v)[:, None]
    attributes = (w * corners[:, 0] + u[:, None] * corners[:, 1]) + v[:, None] * corners[:, 2]
    return attributes, corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
