"""World geometry: every instance's triangles placed in the world, ready to trace.

Camera-relative rendering: all world points are stored relative to `origin`
(the camera position), subtracted in float64 *before* the float32 conversion
for Embree. Float32 has 24 bits of mantissa; near the camera, where the image
is made, coordinates are then small and precise, so a scene 100 km from the
world origin renders like one at the origin.

Bad input never reaches Embree: triangles with NaN or infinite vertices,
out-of-range indices and zero area are dropped here, each kind counted in
`warnings`.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from . import normals as normals_
from .intersect import Tracer
from .scene import DEFAULT_BASE_COLOR, Scene


# Scenes up to this many triangles keep a per-triangle table of corner coordinates (WorldGeometry.corner_points).
CORNER_TABLE_TRIANGLES = 1 << 21


@dataclass
class WorldGeometry:
    """The traced scene.

    origin:         (3,) float64 world point subtracted from every coordinate below
    vertices:       (v, 3) float32 camera-relative points (what Embree sees)
    triangles:      (t, 3) int32 indices into vertices
    face_normals:   (t, 3) float64 unit normals on each triangle's front side
    material:       (t,) int32 row of `albedo` per triangle
    albedo:         (m + 1, 3) float64 base colours; the last row is the default for missing materials
    smooth_index:   (t,) int32 row of `corner_normals` per smooth triangle, -1 for flat ones
    corner_normals: (s, 3, 3) float32 world-space unit normals of the smooth triangles' corners
    tracer:         the Embree BVH over vertices and triangles
    warnings:       human-readable notes about input that was dropped or replaced
    instance:       (t,) int32 index into Scene.instances per triangle (which object it belongs to)
    """

    origin: np.ndarray
    vertices: np.ndarray
    triangles: np.ndarray
    face_normals: np.ndarray
    material: np.ndarray
    albedo: np.ndarray
    smooth_index: np.ndarray
    corner_normals: np.ndarray
    tracer: Tracer
    warnings: list = field(default_factory=list)
    instance: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))

    @property
    def has_smooth(self) -> bool:
        """Whether any triangle needs interpolated normals."""
        return len(self.corner_normals) > 0

    @functools.cached_property
    def _corner_columns(self) -> np.ndarray:
        """(9, t) float32: coordinate c of corner k of every triangle in row 3 k + c (built on first use)."""
        return np.ascontiguousarray(self.vertices[self.triangles].reshape(-1, 9).T)

    def corner_points(self, prim: np.ndarray) -> np.ndarray:
        """Return the corners of the triangles `prim` in float64: (n,) int64 -> (n, 3, 3), [i, k] = corner k.

        The same numbers as vertices[triangles[prim]]. Up to CORNER_TABLE_TRIANGLES triangles they
        are gathered a coordinate at a time from one per-triangle table (36 bytes per triangle,
        several times faster than the nested fancy index) and come column-major: corner k of all
        triangles, points[:, k], is an (n, 3) array with contiguous columns. Larger scenes spend
        their time elsewhere and keep the memory.
        """
        if len(self.triangles) > CORNER_TABLE_TRIANGLES:
            return self.vertices[self.triangles[prim]].astype(np.float64)
        out = np.empty((9, len(prim)))
        for row in range(9):
            out[row] = self._corner_columns[row].take(prim)
        return out.T.reshape(len(prim), 3, 3)


def _object_corner_normals(mesh, keep: np.ndarray) -> np.ndarray:
    """Return the corner normals of the triangles `keep` in object space, deriving vertex normals if none were given.

    keep: (t,) bool -> (kept, 3, 3) float64
    """
    if mesh.corner_normals is not None:
        return mesh.corner_normals[keep]
    triangles = mesh.triangles[keep]
    with np.errstate(invalid="ignore", over="ignore"):
        per_vertex = normals_.vertex_normals(mesh.vertices, triangles, weighting="angle")
    return per_vertex[triangles]


def material_albedo(materials: list) -> np.ndarray:
    """Return the base colours as WorldGeometry stores them, the default grey last: (m + 1, 3) float64 in [0, 1]."""
    colors = [np.asarray(m.base_color, np.float64)[:3] for m in materials] + [DEFAULT_BASE_COLOR]
    return np.clip(np.nan_to_num(np.array(colors, np.float64)), 0.0, 1.0)


# Instances are placed in batches of about this many triangles (bounds the temporary arrays).
BATCH_TRIANGLES = 1 << 20


def _slot_materials(slots: np.ndarray, table, rows: dict) -> np.ndarray:
    """Return the scene material of each triangle for one instance: (t,) int64, -1 where it has none.

    slots: (t,) int64 material slot per triangle; table: the instance's slot -> material array, or None
    for the mesh's own indices. rows caches the answer per distinct table (instances share tables).
    """
    key = None if table is None else tuple(np.asarray(table).tolist())
    if key not in rows:
        if table is None:
            rows[key] = slots
        else:
            table = np.asarray(table, np.int64)
            filled = (slots >= 0) & (slots < len(table))
            rows[key] = (np.where(filled, table[np.where(filled, slots, 0)], -1) if len(table)
                         else np.full(len(slots), -1, np.int64))
    return rows[key]


def build_geometry(scene: Scene, origin: np.ndarray) -> WorldGeometry:
    """Place every instance in the world relative to `origin` and build the BVH.

    origin: (3,) float64 world point (the camera position for camera-relative rendering).
    """
    origin = np.asarray(origin, dtype=np.float64)
    warnings: list[str] = []
    parts_v, parts_t, parts_n, parts_m, parts_cn, parts_smooth = [], [], [], [], [], []
    parts_i = []
    instance_index = {id(instance): i for i, instance in enumerate(scene.instances)}
    vertex_offset = 0
    n_materials = len(scene.materials)
    missing_materials = dropped_nonfinite = dropped_degenerate = dropped_index = 0

    # Group instances by mesh: one batched transform per mesh, whatever the instance count.
    by_mesh: dict[int, list] = {}
    for instance in scene.instances:
        by_mesh.setdefault(instance.mesh, []).append(instance)

    for mesh_index, instances in by_mesh.items():
        mesh = scene.meshes[mesh_index]
        if len(mesh.triangles) == 0 or len(mesh.vertices) == 0:
            continue
        # Triangles whose indices point outside the vertex array are dropped.
        in_range = ((mesh.triangles >= 0) & (mesh.triangles < len(mesh.vertices))).all(axis=1)
        dropped_index += int((~in_range).sum()) * len(instances)
        triangles = mesh.triangles[in_range]
        smooth = mesh.smooth[in_range]
        slots = mesh.material_indices[in_range]
        corners = _object_corner_normals(mesh, in_range)[smooth] if smooth.any() else None
        table_rows: dict = {}

        matrices = np.stack([inst.matrix for inst in instances])            # (k, 4, 4)
        linear = matrices[:, :3, :3]
        det = np.linalg.det(linear)                                          # (k,)
        singular = ~(np.isfinite(det) & (det != 0.0))
        if singular.any():
            warnings.append(f"{int(singular.sum())} object(s) of mesh '{mesh.name}' have zero or invalid scale and were skipped")
        with np.errstate(invalid="ignore", over="ignore"):
            # World point = M p + t, minus the origin, in float64.
            world = (np.einsum("kij,vj->kvi", linear, mesh.vertices)
                     + (matrices[:, :3, 3] - origin)[:, None, :])           # (k, v, 3)

        # Instances in batches of about BATCH_TRIANGLES triangles: (k instances) x (t triangles) arrays,
        # no Python loop per triangle, and temporaries bounded whatever the instance count.
        placed_all = np.flatnonzero(~singular)
        t, v = len(triangles), len(mesh.vertices)
        per_batch = max(1, BATCH_TRIANGLES // t)
        for first in range(0, len(placed_all), per_batch):
            placed = placed_all[first:first + per_batch]
            k = len(placed)
            sign = np.sign(det[placed])
            # 1. Materials: slot -> scene material; missing ones fall back to the default grey.
            material = np.stack([_slot_materials(slots, instances[index].materials, table_rows)
                                 for index in placed])                          # (k, t)
            missing = (material < 0) | (material >= n_materials)
            missing_materials += int(missing.sum())
            material = np.where(missing, n_materials, material)
            # 2. Face normals from the world points; a mirror (det < 0) flips the winding back.
            all_triangles = (triangles[None, :, :] + (np.arange(k) * v)[:, None, None]).reshape(-1, 3)
            points = world[placed].reshape(-1, 3)
            with np.errstate(invalid="ignore", over="ignore"):     # NaN and huge vertices are dropped below
                faces = normals_.face_normals(points, all_triangles)
                points32 = points.astype(np.float32)
            face_n = faces.normals * np.repeat(sign, t)[:, None]
            finite = np.isfinite(points32).all(axis=1)[all_triangles].all(axis=1)
            nondegenerate = face_n.any(axis=1) & (faces.area > 0)
            keep = finite & nondegenerate                                   # (k t,)
            dropped_nonfinite += int((~finite).sum())
            dropped_degenerate += int((finite & ~nondegenerate).sum())
            # 3. Smooth corners transform with the inverse transpose: N' = M^-T N (row vectors: n @ M^-1).
            smooth_all = np.tile(smooth, k)
            if corners is not None:
                inverse = np.linalg.inv(linear[placed])                     # (k, 3, 3)
                world_corners = normals_.safe_normalize(np.einsum("sij,kjl->ksil", corners, inverse))
                parts_cn.append(world_corners.reshape(-1, 3, 3)[keep[smooth_all]].astype(np.float32))
            parts_smooth.append(smooth_all[keep])
            # 4. Keep the good triangles, their vertices offset past those placed so far.
            parts_v.append(points32)
            parts_t.append(all_triangles[keep] + vertex_offset)
            parts_n.append(face_n[keep])
            parts_m.append(material.reshape(-1)[keep])
            owners = np.array([instance_index[id(instances[index])] for index in placed], np.int32)
            parts_i.append(np.repeat(owners, t)[keep])
            vertex_offset += len(points32)

    if dropped_index:
        warnings.append(f"{dropped_index} triangle(s) with out-of-range vertex indices were skipped")
    if dropped_nonfinite:
        warnings.append(f"{dropped_nonfinite} triangle(s) with NaN or infinite vertices were skipped")
    if dropped_degenerate:
        warnings.append(f"{dropped_degenerate} zero-area triangle(s) were skipped")
    if missing_materials:
        warnings.append(f"{missing_materials} triangle(s) have no material and render in the default grey")

    vertices = np.concatenate(parts_v) if parts_v else np.zeros((0, 3), np.float32)
    # Non-finite vertices that no kept triangle uses must not reach Embree either.
    vertices = np.where(np.isfinite(vertices), vertices, np.float32(0.0))
    triangles = (np.concatenate(parts_t) if parts_t else np.zeros((0, 3), np.int64)).astype(np.int32)
    smooth_mask = np.concatenate(parts_smooth) if parts_smooth else np.zeros(0, bool)
    smooth_index = np.full(len(triangles), -1, np.int32)
    smooth_index[smooth_mask] = np.arange(int(smooth_mask.sum()), dtype=np.int32)
    return WorldGeometry(
        origin=origin,
        vertices=vertices,
        triangles=triangles,
        face_normals=np.concatenate(parts_n) if parts_n else np.zeros((0, 3)),
        material=(np.concatenate(parts_m) if parts_m else np.zeros(0, np.int64)).astype(np.int32),
        albedo=material_albedo(scene.materials),
        smooth_index=smooth_index,
        corner_normals=np.concatenate(parts_cn) if parts_cn else np.zeros((0, 3, 3), np.float32),
        tracer=Tracer(vertices, triangles),
        warnings=warnings,
        instance=np.concatenate(parts_i) if parts_i else np.zeros(0, np.int32),
    )
