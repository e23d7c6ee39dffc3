"""The Geometry node's Pointiness: a mesh's curvature per vertex, as Cycles' Blender sync defines it.

At each vertex, the angle between its normal and the mean direction of its edges, over pi: 0.5 on a flat
surface, more at a convex corner (the edges bend away from the normal), less in a hollow; then each vertex
averaged with its edge neighbours once (a blur over two rings). Vertices at one place count as one (their
normals summed), so that split edges do not change it. Computed once per mesh, at export, only when a
material reads it (addon/export.py mesh_attributes); read per corner like any attribute.
"""
from __future__ import annotations

import numpy as np


def pointiness(positions: np.ndarray, normals: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Cycles' pointiness (v,) float64 of a mesh's vertices positions (v, 3), their unit normals (v, 3) and its
    edges (e, 2) int (Blender's edges: a quad's triangulating diagonal is none). Vertices at exactly the same
    place are welded (Cycles also welds those closer than sqrt(FLT_EPSILON); Primer only equal ones)."""
    v = len(positions)
    if v == 0:
        return np.zeros(0)
    # 1. Weld: each vertex's representative, the first of its place.
    _, first, weld = np.unique(np.asarray(positions, np.float64), axis=0, return_index=True, return_inverse=True)
    weld = first[weld.reshape(-1)]
    # 2. The welded normals: summed over each place, normalised.
    normal = np.zeros((v, 3))
    np.add.at(normal, weld, normals)
    length = np.linalg.norm(normal, axis=1)
    normal = np.divide(normal, length[:, None], out=np.zeros_like(normal), where=length[:, None] > 0.0)
    # 3. Each welded edge once: its unit direction added at one end and subtracted at the other.
    pairs = np.sort(weld[np.asarray(edges, np.int64).reshape(-1, 2)], axis=1)
    pairs = np.unique(pairs, axis=0) if len(pairs) else pairs
    a, b = pairs[:, 0], pairs[:, 1]
    direction = positions[b] - positions[a]
    size = np.linalg.norm(direction, axis=1)
    direction = np.divide(direction, size[:, None], out=np.zeros_like(direction), where=size[:, None] > 0.0)
    accum, count = np.zeros((v, 3)), np.zeros(v)
    np.add.at(accum, a, direction)
    np.add.at(accum, b, -direction)
    np.add.at(count, a, 1.0)
    np.add.at(count, b, 1.0)
    # 4. The angle between the normal and the mean edge direction, over pi (0 for a vertex without edges).
    mean = np.divide(accum, count[:, None], out=np.zeros_like(accum), where=count[:, None] > 0.0)
    cosine = np.clip(np.einsum("ij,ij->i", normal, mean), -1.0, 1.0)
    raw = np.where(count > 0.0, np.arccos(cosine) / np.pi, 0.0)
    # 5. One blur: each vertex's value and its neighbours' averaged; duplicates take their place's value.
    blurred = raw.copy()
    np.add.at(blurred, a, raw[b])
    np.add.at(blurred, b, raw[a])
    blurred /= count + 1.0
    return blurred[weld]
