"""Simple meshes to build scenes by hand: planes, boxes and UV spheres."""
from __future__ import annotations

import math

import numpy as np

from ..scene import Mesh


def plane(size_x: float = 2.0, size_y: float | None = None, center=(0.0, 0.0, 0.0),
          name: str = "Plane") -> Mesh:
    """Return a flat rectangle in the z = center_z plane, facing +Z, made of two triangles."""
    size_y = size_x if size_y is None else size_y
    hx, hy = 0.5 * size_x, 0.5 * size_y
    cx, cy, cz = center
    vertices = np.array([[cx - hx, cy - hy, cz], [cx + hx, cy - hy, cz],
                         [cx + hx, cy + hy, cz], [cx - hx, cy + hy, cz]])
    return Mesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]), name=name)


def box(size=(1.0, 1.0, 1.0), center=(0.0, 0.0, 0.0), name: str = "Box") -> Mesh:
    """Return a closed axis-aligned box of 12 triangles with outward (counter-clockwise) faces."""
    h = 0.5 * np.asarray(size, np.float64)
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float64)
    vertices = corners * h + np.asarray(center, np.float64)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6),   # bottom (-z), top (+z)
             (0, 1, 5, 4), (2, 6, 7, 3),   # front (-y), back (+y)
             (0, 4, 6, 2), (1, 3, 7, 5)]   # left (-x), right (+x)
    triangles = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return Mesh(vertices, np.array(triangles), name=name)


def uv_sphere(radius: float = 1.0, segments: int = 32, rings: int = 16, center=(0.0, 0.0, 0.0),
              smooth: bool = True, name: str = "Sphere") -> Mesh:
    """Return a closed UV sphere with outward faces; smooth ones get exact sphere normals at the corners."""
    center = np.asarray(center, np.float64)
    theta = np.linspace(0.0, math.pi, rings + 1)[1:-1]              # interior rings, from the north pole
    phi = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring_points = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    unit = np.vstack([[0.0, 0.0, 1.0], ring_points, [0.0, 0.0, -1.0]])
    north, south = 0, len(unit) - 1

    def ring(i, j):
        return 1 + i * segments + (j % segments)

    triangles = []
    for j in range(segments):
        triangles.append((north, ring(0, j), ring(0, j + 1)))
        triangles.append((south, ring(rings - 2, j + 1), ring(rings - 2, j)))
    for i in range(rings - 2):
        for j in range(segments):
            a, b, c, d = ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)
            triangles += [(a, b, c), (a, c, d)]
    triangles = np.array(triangles)
    return Mesh(unit * radius + center, triangles, smooth=np.full(len(triangles), smooth),
                corner_normals=unit[triangles] if smooth else None, name=name)
