"""Cycles' Random Per Island: one random number per connected part of a mesh (the Geometry node's output).

Blender's sync joins the two vertices of every edge in a disjoint set (union by rank, path compression, the edges in
the mesh's stored order) and gives each triangle the hash of the set's root, the vertex that stands for its island:
hash_uint_to_float(root). The root depends on the order of the joins, so this follows them one by one."""
from __future__ import annotations

import numpy as np

from ..materials.procedural.hash import hash_uint, uint_to_float


def island_roots(vertex_count: int, edges: np.ndarray) -> np.ndarray:
    """The root vertex (v,) int64 of each vertex's island, as Cycles' DisjointSet finds it after joining the vertices
    of `edges` (e, 2) int in order."""
    parent = list(range(vertex_count))
    rank = [0] * vertex_count

    def find(x: int) -> int:
        """The root of x's set, every vertex on the way pointed at it."""
        root = x
        while parent[root] != root:
            root = parent[root]
        while parent[x] != root:
            parent[x], x = root, parent[x]
        return root

    for a, b in edges.tolist():
        root_a, root_b = find(a), find(b)
        if root_a == root_b:
            continue
        if rank[root_a] < rank[root_b]:
            root_a, root_b = root_b, root_a
        parent[root_b] = root_a
        if rank[root_a] == rank[root_b]:
            rank[root_a] += 1
    return np.array([find(x) for x in range(vertex_count)], np.int64)


def random_per_island(vertex_count: int, edges: np.ndarray, triangle_vertex: np.ndarray) -> np.ndarray:
    """Each triangle's Random Per Island (t,) float32: hash_uint_to_float of its island's root. triangle_vertex (t,)
    int: any vertex of each triangle (Cycles takes its first corner's)."""
    if vertex_count == 0 or len(triangle_vertex) == 0:
        return np.zeros(len(triangle_vertex), np.float32)
    roots = island_roots(vertex_count, np.asarray(edges, np.int64).reshape(-1, 2))
    return uint_to_float(hash_uint(roots[np.asarray(triangle_vertex, np.int64)].astype(np.uint32)))
