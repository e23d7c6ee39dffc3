"""Point clouds as spheres of triangles: Cycles' points, approximated.

Cycles renders each point of a point cloud as a sphere of the point's radius. Primer's tracer meets triangles only, so
each point becomes an icosphere (an icosahedron whose faces are split `subdivisions` times, its vertices on the
sphere) with smooth normals pointing from the centre, Cycles' normal at those vertices. The icosphere is inscribed:
its outline lies within r (1 - cos(a / 2)) of the sphere's, a the angle one of its edges spans (3.1 % of the radius
at 2 subdivisions, 320 triangles a point).
"""
from __future__ import annotations

import numpy as np

from ..materials.procedural import hash as hash_
from ..scene import Mesh


def icosphere(subdivisions: int) -> tuple:
    """A unit icosphere: (vertices (v, 3) float64 on the unit sphere, triangles (t, 3) int64 counter-clockwise seen
    from outside)."""
    g = (1.0 + 5.0 ** 0.5) / 2.0
    vertices = [(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0), (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
                (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)]
    triangles = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
                 (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
                 (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    points = [np.array(v, np.float64) / np.linalg.norm(v) for v in vertices]
    for _ in range(subdivisions):
        middle: dict = {}

        def halfway(a: int, b: int) -> int:
            """The index of the vertex on the sphere between vertices a and b, made once."""
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = points[a] + points[b]
                points.append(m / np.linalg.norm(m))
                middle[key] = len(points) - 1
            return middle[key]

        split = []
        for a, b, c in triangles:
            ab, bc, ca = halfway(a, b), halfway(b, c), halfway(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        triangles = split
    return np.array(points), np.array(triangles, np.int64)


def spheres(positions: np.ndarray, radius: np.ndarray, subdivisions: int = 2, name: str = "Points") -> tuple:
    """The points (positions (p, 3), radius (p,)) as smooth icospheres: (the Mesh, the point of each triangle (t,)
    int64)."""
    unit, faces = icosphere(subdivisions)
    p = len(positions)
    vertices = (np.asarray(positions, np.float64)[:, None, :]
                + np.asarray(radius, np.float64)[:, None, None] * unit[None]).reshape(-1, 3)
    triangles = (faces[None] + len(unit) * np.arange(p)[:, None, None]).reshape(-1, 3)
    normals = np.broadcast_to(unit[faces][None], (p,) + faces.shape + (3,)).reshape(-1, 3, 3)
    mesh = Mesh(vertices, triangles, smooth=np.ones(len(triangles), bool), corner_normals=normals, name=name)
    return mesh, np.repeat(np.arange(p, dtype=np.int64), len(faces))


def point_info(positions: np.ndarray, radius: np.ndarray, vertex_count: int) -> dict:
    """The Point Info node's values per vertex of `spheres`' mesh (vertex_count vertices, the same number per point),
    as graph.POINT_INFO_ATTRIBUTES names them: "point_centre" (v, 4) the point's centre and 1, "point_radius" (v, 3)
    its radius / sqrt(3) thrice (its world radius is the length of that vector moved to world space, as Cycles'
    point_radius), "point_random" (v,) Cycles' hash_uint2_to_float(point index, 0)."""
    p = len(positions)
    of_vertex = np.arange(vertex_count) // max(vertex_count // max(p, 1), 1)
    centre = np.concatenate([np.asarray(positions, np.float64), np.ones((p, 1))], axis=1)
    third = np.float32(np.asarray(radius, np.float32) * np.float32(1.0 / np.sqrt(3.0))).astype(np.float64)
    random = hash_.uint_to_float(hash_.hash_uint2(np.arange(p), 0)).astype(np.float64)
    return {"point_centre": centre[of_vertex], "point_radius": np.repeat(third[:, None], 3, axis=1)[of_vertex],
            "point_random": random[of_vertex]}
