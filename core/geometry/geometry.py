"""World geometry: every instance's triangles placed in the world, ready to trace.

Most meshes are copied into the world, one triangle soup for all of them. A mesh whose copies
would hold more than `instancing.INSTANCE_TRIANGLES` triangles is stored once and traced as
Embree instances instead (`core/geometry/instancing.py`); `WorldGeometry.triangle_data` answers for both
kinds, by one flat triangle index.

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
from typing import NamedTuple, Optional

import numpy as np

from . import embree_buffers
from . import instancing
from ..camera import motion as motion_
from ..native import library
from ..native import schema
from . import displacement as displacement_
from . import normals as normals_
from . import surface as surface_
from .. import vectors
from .intersect import Tracer
from ..scene import Scene
from ..materials import graph as graph_
# The rays an object may hide from, and holdouts: WorldGeometry.instance_hidden's bits (core/visibility.py).
from ..visibility import HOLDOUT, SHADOW_CATCHER, hidden_bits
from ..lights.linking import ALL_SETS


# Scenes up to this many triangles keep a per-triangle table of corner coordinates (WorldGeometry.corner_points).
CORNER_TABLE_TRIANGLES = 1 << 21


@dataclass
class WorldGeometry:
    """The traced scene.

    origin:         (3,) float64 world point subtracted from every coordinate below
    vertices:       (v, 3) float32 camera-relative points (what Embree sees)
    triangles:      (t, 3) int32 indices into vertices
    face_normals:   (t, 3) float64 unit normals on each triangle's front side
    material:       (t,) int32 row of the scene's material table per triangle (core/materials
                    MaterialTable; its last row, m, is the default for triangles without a material)
    smooth_index:   (t,) int32 row of `corner_normals` per smooth triangle, -1 for flat ones
    corner_normals: (s, 3, 3) float32 world-space unit normals of the smooth triangles' corners
    tracer:         the Embree BVH over vertices and triangles
    warnings:       human-readable notes about input that was dropped or replaced
    instance:       (t,) int32 index into Scene.instances per triangle (which object it belongs to)
    instanced:      InstancedMesh records (core/geometry/instancing.py) of the meshes stored once; their
                    triangles have the flat indices len(triangles) and up
    attributes:     (r, 3, A) float32 the meshes' per-corner attributes (Mesh.attributes), each mesh's
                    triangles once, laid out by `attribute_layout` (name -> (offset, width)); None when no
                    mesh has any
    attribute_row:  (t,) int32 row of `attributes` per copied triangle (instanced meshes keep their own)
    instance_random: (n,) float64 the Object Info Random of each Scene.instances entry
    instance_info: (n, OBJECT_INFO_WIDTH) float64 each instance's other Object Info outputs (instance_info)
    instance_linear: (n, 3, 3) float64 each instance's linear transform (tangents turn with it)
    instance_texspace: (n, 6) float64 each instance's texture space location and size (Instance.texspace; NaN where
                    it gives none), or an empty array when none gives one
    instance_hidden: (n,) uint8 the rays each Scene.instances entry hides from (HIDDEN_FROM_* bits, Ray
                    Visibility), whether it is a holdout (HOLDOUT) and a shadow catcher (SHADOW_CATCHER), or an empty
                    array when no object has any of them
    instance_links: (n, 4) uint64 each Scene.instances entry's light set, shadow set, light membership and shadow
                    membership (core/lights/linking.py), or an empty array when nothing is linked
    instance_ao_distance: (n,) float64 each Scene.instances entry's own Fast GI AO Distance (0: the render's), or
        empty where none has one
    instance_terminator: (n, 2) float64 each Scene.instances entry's shadow terminator (terminator_table): its
                    Geometry Offset (-1: the render's) and its Shading Offset as Cycles' frequency multiplier, or an
                    empty array when every object takes the render's offset and bends no cosine
    instance_caustics: (n,) uint8 each Scene.instances entry's shadow caustics bits (core/integrators/mnee.py CASTER,
                    RECEIVER), or an empty array when no object casts or receives shadow caustics
    The arrays above hold the copied triangles only; ask `triangle_data` for any triangle.
    """

    origin: np.ndarray
    vertices: np.ndarray
    triangles: np.ndarray
    face_normals: np.ndarray
    material: np.ndarray
    smooth_index: np.ndarray
    corner_normals: np.ndarray
    tracer: Tracer
    warnings: list = field(default_factory=list)
    instance: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    instanced: list = field(default_factory=list)
    attributes: Optional[np.ndarray] = None
    attribute_layout: dict = field(default_factory=dict)
    attribute_row: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    instance_random: np.ndarray = field(default_factory=lambda: np.zeros(0))
    instance_info: np.ndarray = field(default_factory=lambda: np.zeros((0, OBJECT_INFO_WIDTH)))
    instance_linear: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    instance_texspace: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    instance_hidden: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    instance_links: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.uint64))
    instance_terminator: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    instance_ao_distance: np.ndarray = field(default_factory=lambda: np.zeros(0))
    instance_caustics: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))

    @property
    def has_smooth(self) -> bool:
        """Whether any triangle needs interpolated normals."""
        return len(self.corner_normals) > 0 or any(len(m.corner_normals) for m in self.instanced)

    @property
    def triangle_count(self) -> int:
        """Triangles in the scene, copied and instanced."""
        return len(self.triangles) + sum(m.triangle_count for m in self.instanced)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the camera-relative box around all the geometry: two (3,) float64, or zeros when empty."""
        lows = [m.locator.bounds[0] for m in self.instanced]
        highs = [m.locator.bounds[1] for m in self.instanced]
        if len(self.vertices):
            lows.append(self.vertices.min(axis=0).astype(np.float64))
            highs.append(self.vertices.max(axis=0).astype(np.float64))
        if not lows:
            return np.zeros(3), np.zeros(3)
        return np.min(lows, axis=0), np.max(highs, axis=0)

    def triangle_data(self, prim: np.ndarray, smooth: bool = True,
                      times: Optional[np.ndarray] = None) -> "TriangleData":
        """Return what shading needs of the triangles `prim` (flat indices, copied or instanced): (n,) int64.

        smooth: False skips the interpolated normals (all triangles then count as flat); times: (n,) float64 each
        hit's time in the shutter, where a moving instance is (None: its middle).
        """
        if not self.instanced:
            return self._copied_data(prim, smooth)
        # Compact each kind of triangle, compute, scatter back.
        n = len(prim)
        corners, Ng = np.empty((n, 3, 3)), np.empty((n, 3))
        material, is_smooth = np.empty(n, np.int32), np.zeros(n, bool)
        normals = np.zeros((n, 3, 3)) if smooth else None
        part = np.searchsorted([m.first_prim for m in self.instanced], prim, side="right")
        for index in np.unique(part):
            rows = np.flatnonzero(part == index)
            if index == 0:
                data = self._copied_data(prim[rows], smooth)
            else:
                data = self._instanced_data(self.instanced[index - 1], prim[rows], smooth,
                                            None if times is None else np.asarray(times)[rows])
            corners[rows], Ng[rows], material[rows] = data.corners, data.Ng, data.material
            if smooth and data.smooth.any():
                is_smooth[rows] = data.smooth
                normals[rows[data.smooth]] = data.corner_normals
        corner_normals = normals[is_smooth] if smooth else np.zeros((0, 3, 3))
        return TriangleData(corners, Ng, material, is_smooth, corner_normals)

    def _copied_data(self, prim: np.ndarray, smooth: bool) -> "TriangleData":
        """triangle_data for copied triangles (indices below len(triangles))."""
        corners = self.corner_points(prim)
        Ng = vectors.gather(self.face_normals, prim)
        is_smooth, normals = np.zeros(len(prim), bool), np.zeros((0, 3, 3))
        if smooth and len(self.corner_normals):
            row = self.smooth_index[prim]
            is_smooth = row >= 0
            normals = self.corner_normals[row[is_smooth]].astype(np.float64)
        return TriangleData(corners, Ng, self.material[prim], is_smooth, normals)

    @staticmethod
    def _instanced_data(mesh, prim: np.ndarray, smooth: bool, times: Optional[np.ndarray] = None) -> "TriangleData":
        """triangle_data for the triangles of one instanced mesh (a moving one at the hits' `times`)."""
        j, local = mesh.split(prim)
        corners = mesh.corner_points(j, local, times)
        Ng = mesh.face_normals(j, corners)
        is_smooth, normals = np.zeros(len(prim), bool), np.zeros((0, 3, 3))
        if smooth and len(mesh.corner_normals):
            is_smooth, normals = mesh.smooth_normals(j, local, times)
        return TriangleData(corners, Ng, mesh.materials(j, local), is_smooth, normals)

    def shading_point(self, surface):
        """What materials' node graphs read at the hits `surface` (a Surface): their ShadingPoint
        (core/materials/graph.py), made by core/geometry/surface.py shading_point. MaterialTable.shade asks the
        geometry it is given for it, so that the materials need not import the geometry."""
        return surface_.shading_point(self, surface)

    def hides(self, bit: int) -> bool:
        """Whether some object hides from the rays of `bit` (any of the HIDDEN_FROM_* or HOLDOUT bits it has)."""
        return bool(len(self.instance_hidden)) and bool((self.instance_hidden & bit).any())

    def hidden(self, prim: np.ndarray, bit) -> np.ndarray:
        """Which triangles `prim` (k,) int64 belong to objects hidden from the rays of `bit` (an int, or (k,) int
        each triangle's own ray kind: HIDDEN_FROM_* bits; HOLDOUT asks which are holdouts): (k,) bool."""
        prim = np.asarray(prim, np.int64)
        bits = np.asarray(bit, np.int64)
        if len(prim) == 0 or not self.hides(int(np.bitwise_or.reduce(bits.ravel())) if bits.size else 0):
            return np.zeros(len(prim), bool)
        owner = self.owners(prim)
        return (owner >= 0) & ((self.instance_hidden[np.maximum(owner, 0)] & bit) != 0)

    @property
    def linked(self) -> bool:
        """Whether some object is light- or shadow-linked (instance_links)."""
        return len(self.instance_links) > 0

    @property
    def shadow_linked(self) -> bool:
        """Whether some emitter object's shadows are cast by a blocker set only (its shadow membership is not all)."""
        return self.linked and bool((self.instance_links[:, 3] != np.uint64(ALL_SETS)).any())

    def links(self, prim: np.ndarray, column: int) -> np.ndarray:
        """Column `column` of instance_links (0 light set, 1 shadow set, 2 light membership, 3 shadow membership) of the
        object of each triangle `prim` (k,) int64: (k,) uint64 (the unlinked defaults for triangles of no object)."""
        default = np.array([0, 0, ALL_SETS, ALL_SETS], np.uint64)[column]
        if not self.linked:
            return np.full(len(prim), default, np.uint64)
        owner = self.owners(np.asarray(prim, np.int64))
        return np.where(owner >= 0, self.instance_links[np.maximum(owner, 0), column], default)

    def terminator_offsets(self, prim: np.ndarray, fallback: float) -> np.ndarray:
        """The Shadow Terminator Geometry Offset (k,) float64 of the object of each triangle `prim` (k,) int64:
        its own, or `fallback` (the render's) for objects without one and triangles of no object."""
        if not len(self.instance_terminator):
            return np.full(len(prim), float(fallback))
        owner = self.owners(np.asarray(prim, np.int64))
        own = np.where(owner >= 0, self.instance_terminator[np.maximum(owner, 0), 0], -1.0)
        return np.where(own >= 0.0, own, float(fallback))

    def ao_distances(self, prim: np.ndarray, fallback: float) -> np.ndarray:
        """How far Fast GI's rays leaving each triangle `prim` (k,) int64 look: (k,) float64 its object's own AO
        Distance where nonzero, else `fallback` (the render's; Cycles' intersect_closest)."""
        if not len(self.instance_ao_distance):
            return np.full(len(prim), float(fallback))
        owner = self.owners(np.asarray(prim, np.int64))
        own = np.where(owner >= 0, self.instance_ao_distance[np.maximum(owner, 0)], 0.0)
        return np.where(own != 0.0, own, float(fallback))

    def terminator_multipliers(self, prim: np.ndarray):
        """Cycles' frequency multiplier (k,) float64 of the Shading Offset of the object of each triangle `prim`
        (k,) int64 (1: none), or None where no object has one."""
        if not len(self.instance_terminator) or not (self.instance_terminator[:, 1] > 1.0).any():
            return None
        owner = self.owners(np.asarray(prim, np.int64))
        return np.where(owner >= 0, self.instance_terminator[np.maximum(owner, 0), 1], 1.0)

    def caustics_flags(self, prim: np.ndarray) -> np.ndarray:
        """The shadow caustics bits (k,) uint8 (mnee.CASTER, mnee.RECEIVER) of the object of each triangle `prim` (k,)
        int64 (0 for triangles of no object)."""
        if not len(self.instance_caustics):
            return np.zeros(len(prim), np.uint8)
        owner = self.owners(np.asarray(prim, np.int64))
        return np.where(owner >= 0, self.instance_caustics[np.maximum(owner, 0)], 0).astype(np.uint8)

    def owners(self, prim: np.ndarray) -> np.ndarray:
        """The index into Scene.instances of the object each triangle `prim` (k,) int64 belongs to, -1 for none."""
        owner = np.full(len(prim), -1, np.int64)
        copied = (prim >= 0) & (prim < len(self.instance))
        owner[copied] = self.instance[prim[copied]]
        for mesh in self.instanced:
            mine = (prim >= mesh.first_prim) & (prim < mesh.first_prim + mesh.triangle_count)
            if mine.any():
                j, _ = mesh.split(prim[mine])
                owner[mine] = mesh.owner[j]
        return owner

    def instance_of(self, prim: int) -> int:
        """Return the index into Scene.instances of the object triangle `prim` belongs to, or -1."""
        return int(self.owners(np.array([prim], np.int64))[0])

    @functools.cached_property
    def _corner_columns(self) -> np.ndarray:
        """(9, t) float32: coordinate c of corner k of every triangle in row 3 k + c (built on first use)."""
        return np.ascontiguousarray(self.vertices[self.triangles].reshape(-1, 9).T)

    def corner_points(self, prim: np.ndarray) -> np.ndarray:
        """Return the corners of the copied triangles `prim` in float64: (n,) int64 -> (n, 3, 3), [i, k] = corner k.

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


class TriangleData(NamedTuple):
    """What shading needs of n hit triangles.

    corners:        (n, 3, 3) float64 camera-relative corner points, [i, k] = corner k
    Ng:             (n, 3) float64 unit normals on the triangles' front sides
    material:       (n,) int32 row of the scene's material table
    smooth:         (n,) bool which triangles are shaded with interpolated normals
    corner_normals: (s, 3, 3) float64 world unit corner normals of the smooth ones, in order
    """

    corners: np.ndarray
    Ng: np.ndarray
    material: np.ndarray
    smooth: np.ndarray
    corner_normals: np.ndarray


def _object_corner_normals(mesh, keep: np.ndarray) -> np.ndarray:
    """Return the corner normals of the triangles `keep` in object space, deriving vertex normals if none were given.

    keep: (t,) bool -> (kept, 3, 3) float64 (a mesh's float32 normals widened: Mesh.corner_normals)
    """
    if mesh.corner_normals is not None:
        return vectors.keep_rows(mesh.corner_normals, keep).astype(np.float64, copy=False)
    triangles = vectors.keep_rows(mesh.triangles, keep)
    with np.errstate(invalid="ignore", over="ignore"):
        per_vertex = normals_.vertex_normals(mesh.vertices, triangles, weighting="angle")
    return per_vertex[triangles]


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


class _Batch(NamedTuple):
    """Placed copies of meshes, before the bad triangles are dropped (_place_copies, build_geometry).

    points: (v, 3) float64 world points minus the origin; triangles: (t, 3) int64 into points;
    sign: (t,) float64 the sign of each triangle's placement's determinant; material: (t,) int64;
    owner: (t,) int32 Scene.instances index; smooth: (t,) bool; corner_normals: (s, 3, 3) float64
    world corner normals of the smooth triangles, or None; source: (t,) int64 row of the attribute
    table (WorldGeometry.attributes) per triangle.
    """

    points: np.ndarray
    triangles: np.ndarray
    sign: np.ndarray
    material: np.ndarray
    owner: np.ndarray
    smooth: np.ndarray
    corner_normals: Optional[np.ndarray]
    source: np.ndarray


def _face_normals(points: np.ndarray, triangles: np.ndarray):
    """normals.face_normals, in one compiled pass where the kernels are loaded (the same numbers)."""
    if library.available():
        return normals_.compiled_face_normals(points, triangles)
    return normals_.face_normals(points, triangles)


def _triangle_checks(points32: np.ndarray, triangles: np.ndarray, face_normals: np.ndarray,
                     area: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (finite, nondegenerate): which triangles have only finite float32 corners, and which
    a nonzero face normal and area. points32 (v, 3) float32; triangles (t, 3) int64; face_normals
    (t, 3), area (t,) float64 -> two (t,) bool."""
    finite = vectors.all_columns(np.take(vectors.all_columns(np.isfinite(points32)), triangles))
    nondegenerate = vectors.any_nonzero(face_normals) & (area > 0)
    return finite, nondegenerate


def _finish_batch(batch: _Batch, vertex_offset: int, counts: dict, parts: dict) -> int:
    """Drop the batch's non-finite and zero-area triangles, append the rest to `parts` (as float32
    points and triangles offset past those placed so far) and return the new vertex offset.

    The batch's float64 arrays are let go as soon as their float32 copies are made (the caller keeps
    no reference to the batch): on a million triangles its corner normals alone are 72 MB."""
    # 1. Face normals from the world points, flipped back for mirrors; bad triangles found.
    smooth, triangles, corner_normals = batch.smooth, batch.triangles, batch.corner_normals
    with np.errstate(invalid="ignore", over="ignore"):       # NaN and huge vertices are dropped below
        faces = _face_normals(batch.points, triangles)
        points32 = batch.points.astype(np.float32)
    face_n = faces.normals
    face_n *= batch.sign[:, None]
    material, owner, source = batch.material, batch.owner, batch.source
    del batch
    finite, nondegenerate = _triangle_checks(points32, triangles, face_n, faces.area)
    keep = finite & nondegenerate
    every = bool(keep.all())
    counts["nonfinite"] += int((~finite).sum())
    counts["degenerate"] += int((finite & ~nondegenerate).sum())
    # 2. Keep the good triangles, and the smooth ones' corner normals (rounded to float32 first, then
    #    kept: the same numbers as keeping first, without a second float64 copy).
    if corner_normals is not None:
        corner_normals = corner_normals.astype(np.float32)
        parts["cn"].append(corner_normals if every else vectors.keep_rows(corner_normals, keep[smooth]))
        del corner_normals
    parts["smooth"].append(smooth if every else smooth[keep])
    parts["v"].append(points32)
    if every:                                  # (they may be the scene's own: not offset in place)
        parts["t"].append(triangles + vertex_offset)
    else:
        kept = vectors.keep_rows(triangles, keep)
        kept += vertex_offset
        parts["t"].append(kept)
    del triangles
    parts["n"].append(face_n if every else vectors.keep_rows(face_n, keep))
    material, owner, source = (material, owner, source) if every else (material[keep], owner[keep], source[keep])
    parts["m"].append(material)
    parts["i"].append(owner)
    parts["src"].append(source)
    return vertex_offset + len(points32)


def _joined(parts: dict, key: str, empty: np.ndarray) -> np.ndarray:
    """Take the list parts[key] out of `parts` and return its arrays joined along the first axis: the one array itself
    when there is one (the batches' parts are fresh arrays, not views of the scene's), `empty` when there is none."""
    arrays = parts.pop(key)
    if not arrays:
        return empty
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


def moves(instance) -> bool:
    """Whether a Scene instance moves over the shutter: two or more motion steps (Instance.motion), not all equal."""
    steps = instance.motion
    return len(steps) >= 2 and any(not np.array_equal(np.asarray(m), np.asarray(steps[0])) for m in steps[1:])


def deforms(instance, mesh) -> bool:
    """Whether a Scene instance's mesh deforms over the shutter: two or more vertex steps (Instance.deformation) of
    its mesh's vertex count, not all equal."""
    steps = instance.deformation
    return (len(steps) >= 2 and all(np.shape(p) == np.shape(mesh.vertices) for p in steps)
            and any(not np.array_equal(np.asarray(p), np.asarray(steps[0])) for p in steps[1:]))


def _normal_steps(instance, mesh, steps: int) -> Optional[np.ndarray]:
    """A deforming instance's vertex normals at its deformation's steps (Instance.deformation_normals) as
    InstancedMesh.normal_steps: (steps, v, 3) float32 unit (zero where not finite), or None where it has none of
    that shape (its smooth normals stay the frame's)."""
    normals = instance.deformation_normals
    if len(normals) != steps or not all(np.shape(n) == np.shape(mesh.vertices) for n in normals):
        return None
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        stacked = normals_.safe_normalize(np.stack([np.asarray(n, np.float64) for n in normals]).reshape(-1, 3))
    return stacked.reshape(steps, -1, 3).astype(np.float32)


def same_meshes(meshes: list) -> np.ndarray:
    """Each mesh's first mesh of the same content (its points, triangles, smooth flags, material slots, corner
    normals, attributes and curve info all equal): (m,) int64 indices into `meshes`. Identical meshes that are not
    one datablock (an importer's copies of one shape, one per material) are then placed as one mesh."""
    first = np.arange(len(meshes), dtype=np.int64)
    by_size: dict = {}               # (vertex count, triangle count) -> mesh indices: only these can be equal
    for index, mesh in enumerate(meshes):
        by_size.setdefault((len(mesh.vertices), len(mesh.triangles)), []).append(index)
    for indices in by_size.values():
        if len(indices) < 2:
            continue
        seen: dict = {}              # a digest of the points -> the distinct meshes with them
        for index in indices:
            mesh = meshes[index]
            candidates = seen.setdefault(hash(mesh.vertices.tobytes()), [])
            first[index] = next((other for other in candidates if _same_mesh(meshes[other], mesh)), index)
            if first[index] == index:
                candidates.append(index)
    return first


def _same_mesh(a, b) -> bool:
    """Whether two Scene meshes hold the same numbers (their names aside)."""
    def same(x, y) -> bool:
        return (x is None) == (y is None) and (x is None or np.array_equal(np.asarray(x), np.asarray(y)))
    def same_dict(x: dict, y: dict) -> bool:
        return x.keys() == y.keys() and all(same(x[k], y[k]) for k in x)
    return (same(a.vertices, b.vertices) and same(a.triangles, b.triangles) and same(a.smooth, b.smooth)
            and same(a.material_indices, b.material_indices) and same(a.corner_normals, b.corner_normals)
            and same_dict(a.attributes or {}, b.attributes or {}) and same_dict(a.curve_info or {}, b.curve_info or {}))


def _placed_meshes(scene: Scene, instance_triangles: int) -> np.ndarray:
    """Each Scene instance's mesh as build_geometry groups them: (n,) int64 indices into scene.meshes. Identical
    meshes (same_meshes) count as their first where their placements together are to be instanced (more than
    `instance_triangles` triangles, twice or more, where Embree instances); elsewhere each keeps its own, so copies
    stay in the order they had."""
    mesh_of = np.fromiter((instance.mesh for instance in scene.instances), np.int64, len(scene.instances))
    if len(mesh_of) < 2 or not embree_buffers.instancing_supported():
        return mesh_of
    first = same_meshes(scene.meshes)[mesh_of]
    placements = np.bincount(first, minlength=len(scene.meshes))[first]
    triangles = np.array([len(mesh.triangles) for mesh in scene.meshes], np.int64)[first]
    instanced = (placements >= 2) & (placements * triangles > instance_triangles)
    return np.where(instanced, first, mesh_of)


def build_geometry(scene: Scene, origin: np.ndarray,
                   instance_triangles: Optional[int] = None, motion_blur: bool = False) -> WorldGeometry:
    """Place every instance in the world relative to `origin` and build the BVH.

    origin: (3,) float64 world point (the camera position for camera-relative rendering).
    instance_triangles: a mesh placed more than once is stored once and instanced when its copies
    would hold more than this many triangles (None: instancing.INSTANCE_TRIANGLES; tests pass 0
    to instance every mesh placed twice or more). Without Embree instancing every mesh is copied,
    and so, unless instance_triangles is 0, is a mesh whose instances crowd one place
    (instancing.CROWDED): identifying a hit there would mean trying each of them.
    motion_blur: each instance that moves over the shutter (Instance.motion) becomes an Embree instance of its own,
    which the queries place at each ray's time (Tracer.intersect's `times`) and shading with it
    (WorldGeometry.triangle_data's `times`); False, or without Embree instancing, it is placed still at its matrix
    (with a warning when Embree's instancing is missing).
    """
    origin = np.asarray(origin, dtype=np.float64)
    if instance_triangles is None:
        instance_triangles = instancing.INSTANCE_TRIANGLES
    warnings: list[str] = []
    scene = displacement_.displaced(scene, warnings)          # (true displacement moves vertices before all else)
    parts = {"v": [], "t": [], "n": [], "m": [], "cn": [], "smooth": [], "i": [], "src": []}
    instanced: list = []
    vertex_offset = 0
    n_materials = len(scene.materials)
    counts = {"missing": 0, "nonfinite": 0, "degenerate": 0, "index": 0}

    # Every placement's matrix and determinant at once (numpy's cost is per call: one call, not one
    # per mesh).
    n_instances = len(scene.instances)
    all_matrices = (np.stack([instance.matrix for instance in scene.instances]) if n_instances
                    else np.zeros((0, 4, 4)))                                              # (n, 4, 4)
    all_det = vectors.determinant(all_matrices[:, :3, :3])                                 # (n,)

    # Group instances by mesh (their indices into scene.instances), meshes in order of first use:
    # one batched transform per mesh, whatever the instance count.
    mesh_of = _placed_meshes(scene, instance_triangles)
    order = np.argsort(mesh_of, kind="stable")
    by_mesh = np.split(order, np.flatnonzero(np.diff(mesh_of[order])) + 1) if n_instances else []
    by_mesh.sort(key=lambda owners: owners[0])

    singular_all = ~(np.isfinite(all_det) & (all_det != 0.0))                              # (n,)
    # The meshes' per-corner attributes, each mesh's triangles once (rows first_row[id(mesh)] ..).
    attributes, layout, first_row = attribute_table(scene.meshes)
    copies: list = []           # (mesh, its placements' indices into scene.instances): placed as copies
    moving_owners = [index for index, instance in enumerate(scene.instances)
                     if (instance.motion and moves(instance))
                     or (instance.deformation and deforms(instance, scene.meshes[instance.mesh]))]
    # (the queries carry times in the compiled library's packets: embreex's own carry none)
    blurred = motion_blur and embree_buffers.instancing_supported() and library.available()
    if moving_owners and motion_blur and not blurred:
        warnings.append(f"motion blur: {len(moving_owners)} moving object(s) rendered still where they are at the "
                        "frame (Embree's instances or packet queries are unavailable here)")
    for owners in by_mesh:
        mesh = scene.meshes[int(mesh_of[owners[0]])]
        if len(mesh.triangles) == 0 or len(mesh.vertices) == 0:
            continue
        if blurred and moving_owners:
            moving = np.isin(owners, moving_owners)
            for index in owners[moving & ~singular_all[owners]]:
                record, found = _instanced_placements(scene, mesh, np.array([index]), all_matrices, origin,
                                                      n_materials, first_row.get(id(mesh), 0))
                for key, value in found.items():
                    counts[key] += value
                if record is not None:
                    placement = scene.instances[index]
                    rigid = placement.motion if moves(placement) else (placement.matrix, placement.matrix)
                    record.motion = _motion_steps(rigid, origin)
                    if deforms(placement, mesh):
                        with np.errstate(invalid="ignore", over="ignore"):
                            steps = np.stack([np.asarray(p, np.float64) for p in placement.deformation])
                            steps = steps.astype(np.float32)
                        record.vertex_steps = np.where(np.isfinite(steps), steps, np.float32(0.0))
                        record.normal_steps = _normal_steps(placement, mesh, len(steps))
                    instanced.append(record)
            owners = owners[~moving]
            if len(owners) == 0:
                continue
        placed = owners[~singular_all[owners]]
        if len(placed) < len(owners):
            warnings.append(f"{len(owners) - len(placed)} object(s) of mesh '{mesh.name}' have zero or invalid scale "
                            "and were skipped")
        if (len(placed) >= 2 and len(placed) * len(mesh.triangles) > instance_triangles
                and embree_buffers.instancing_supported()):
            # Stored once, traced as Embree instances (core/geometry/instancing.py).
            record, found = _instanced_placements(scene, mesh, placed, all_matrices, origin, n_materials,
                                                  first_row.get(id(mesh), 0))
            # Unless asked to always instance, instances piled up in one place are copied instead:
            # every hit there would have to try each of them (instancing.CROWDED).
            crowded = (record is not None and instance_triangles > 0
                       and record.locator.crowding > instancing.CROWDED)
            if not crowded:
                for key, value in found.items():
                    counts[key] += value
                if record is not None:
                    instanced.append(record)
                continue
        copies.append((mesh, placed))

    # The copies, in batches of about BATCH_TRIANGLES triangles: a batch places all of its meshes
    # at once (numpy's cost is per call, so many small meshes cost what one large one does), and a
    # mesh whose copies exceed a batch is split between its placements (the temporaries stay bounded
    # whatever the instance count).
    batch: list = []
    batch_triangles = 0
    for mesh, placed in copies:
        per_batch = max(1, BATCH_TRIANGLES // len(mesh.triangles))
        for first in range(0, len(placed), per_batch):
            some = placed[first:first + per_batch]
            batch.append((mesh, some))
            batch_triangles += len(some) * len(mesh.triangles)
            if batch_triangles >= BATCH_TRIANGLES:
                vertex_offset = _finish_batch(_place_copies(batch, scene, all_matrices, all_det, origin,
                                                            n_materials, counts, first_row), vertex_offset, counts,
                                              parts)
                batch, batch_triangles = [], 0
    if batch:
        vertex_offset = _finish_batch(_place_copies(batch, scene, all_matrices, all_det, origin, n_materials,
                                                    counts, first_row), vertex_offset, counts, parts)

    if counts["index"]:
        warnings.append(f"{counts['index']} triangle(s) with out-of-range vertex indices were skipped")
    if counts["nonfinite"]:
        warnings.append(f"{counts['nonfinite']} triangle(s) with NaN or infinite vertices were skipped")
    if counts["degenerate"]:
        warnings.append(f"{counts['degenerate']} zero-area triangle(s) were skipped")
    # A scene from Blender gives them Cycles' own default surface: then nothing differs, nothing to warn.
    cycles_default = bool(getattr(getattr(scene, "default_material", None), "nodes", None))
    if counts["missing"] and not cycles_default:
        warnings.append(f"{counts['missing']} triangle(s) have no material and render in the default grey")

    # Each table joined from its batches' parts, which are let go at once (one batch's part is taken as
    # it is, not copied): they are not kept beside the tables while Embree builds its BVH.
    # The points and triangles are the leading rows of the buffers Embree reads in place (with_spare_row): the
    # tracer shares them instead of copying them.
    joined = _joined(parts, "v", np.zeros((0, 3), np.float32))
    vertices = embree_buffers.with_spare_row(len(joined), np.float32)
    vertices[...] = joined
    del joined
    # Non-finite vertices that no kept triangle uses must not reach Embree either.
    np.copyto(vertices, np.float32(0.0), where=~np.isfinite(vertices))
    joined = _joined(parts, "t", np.zeros((0, 3), np.int64))
    triangles = embree_buffers.with_spare_row(len(joined), np.int32)
    triangles[...] = joined
    del joined
    smooth_mask = _joined(parts, "smooth", np.zeros(0, bool))
    smooth_index = np.full(len(triangles), -1, np.int32)
    smooth_index[smooth_mask] = np.arange(int(smooth_mask.sum()), dtype=np.int32)
    del smooth_mask
    face_normals = _joined(parts, "n", np.zeros((0, 3)))
    material = _joined(parts, "m", np.zeros(0, np.int64)).astype(np.int32)
    corner_normals = _joined(parts, "cn", np.zeros((0, 3, 3), np.float32))
    instance = _joined(parts, "i", np.zeros(0, np.int32))
    attribute_row = _joined(parts, "src", np.zeros(0, np.int64)).astype(np.int32)
    # Instanced triangles are numbered after the copied ones.
    first_prim = len(triangles)
    for record in instanced:
        record.first_prim = first_prim
        first_prim += record.triangle_count
    return WorldGeometry(
        origin=origin,
        vertices=vertices,
        triangles=triangles,
        face_normals=face_normals,
        material=material,
        smooth_index=smooth_index,
        corner_normals=corner_normals,
        tracer=Tracer(vertices, triangles, instanced=instanced),
        warnings=warnings,
        instance=instance,
        instanced=instanced,
        attributes=attributes,
        attribute_layout=layout,
        attribute_row=attribute_row,
        instance_random=np.array([graph_.object_random(i.name) if i.random is None else float(i.random)
                                  for i in scene.instances], np.float64),
        instance_linear=all_matrices[:, :3, :3].copy(),
        instance_texspace=texspace_table(scene.instances),
        instance_info=instance_info(scene.instances, all_matrices, getattr(scene, "instance_attributes", ())),
        instance_hidden=hidden_flags(scene.instances),
        instance_links=link_table(scene.instances),
        instance_terminator=terminator_table(scene.instances),
        instance_ao_distance=ao_distance_table(scene.instances),
        instance_caustics=caustics_table(scene.instances),
    )


# The Object Info node's outputs an instance carries (graph.OBJECT_INFO_OUTPUTS, their columns): its world location,
# its colour and alpha, its pass index; the Texture Coordinate's Generated and UV From Instancer
# (Instance.dupli_generated, dupli_uv); then 4 columns (RGBA) per Object or Instancer attribute (Scene.instance_attributes).
OBJECT_INFO_WIDTH = schema.constant("OBJECT_INFO_WIDTH", 14, "an instance's Object Info columns before its attributes")


def instance_info(instances: list, matrices: np.ndarray, attributes=()) -> np.ndarray:
    """Each instance's Object Info (n, OBJECT_INFO_WIDTH + 4 k) float64: Location (the translation of its matrix in
    `matrices` (n, 4, 4), world space), Color and Alpha (Object > Viewport Display > Color), Object Index (its pass
    index), Generated and UV From Instancer (u, v, 0), then the RGBA of each of the k `attributes` (names;
    Instance.attributes, 0 where it has none); filled
    column by column (10^5 instances cost one array each, not one per instance)."""
    info = np.zeros((len(instances), OBJECT_INFO_WIDTH + 4 * len(attributes)))
    if len(instances):
        info[:, 0:3] = matrices[:, :3, 3]
        info[:, 3:7] = np.array([instance.color for instance in instances], np.float64).reshape(-1, 4)
        info[:, 7] = [instance.pass_index for instance in instances]
        info[:, 8:11] = [getattr(instance, "dupli_generated", None) or (0.0, 0.0, 0.0) for instance in instances]
        info[:, 11:13] = [getattr(instance, "dupli_uv", None) or (0.0, 0.0) for instance in instances]
    for k, name in enumerate(attributes):
        start = OBJECT_INFO_WIDTH + 4 * k
        info[:, start:start + 4] = [(instance.attributes or {}).get(name, (0.0, 0.0, 0.0, 0.0))
                                    for instance in instances]
    return info


def texspace_table(instances: list) -> np.ndarray:
    """(n, 6) float64 each instance's texture space location and size (Instance.texspace), NaN where it gives none;
    empty when none gives one."""
    if not any(getattr(i, "texspace", None) is not None for i in instances):
        return np.zeros((0, 6))
    return np.array([np.concatenate([np.asarray(i.texspace[0], np.float64).reshape(3),
                                     np.asarray(i.texspace[1], np.float64).reshape(3)])
                     if getattr(i, "texspace", None) is not None else np.full(6, np.nan) for i in instances],
                    np.float64).reshape(-1, 6)


def hidden_flags(instances: list) -> np.ndarray:
    """(n,) uint8 the rays each instance hides from (HIDDEN_FROM_* bits), whether it is a holdout (HOLDOUT) and a
    shadow catcher (SHADOW_CATCHER); empty when no instance has any of them."""
    flags = np.array([hidden_bits(i) | (HOLDOUT if i.is_holdout else 0)
                      | (SHADOW_CATCHER if getattr(i, "is_shadow_catcher", False) else 0) for i in instances], np.uint8)
    return flags if flags.any() else np.zeros(0, np.uint8)


def link_table(instances: list) -> np.ndarray:
    """(n, 4) uint64 each instance's light set, shadow set, light membership and shadow membership (Light and Shadow
    Linking, core/lights/linking.py); empty when no instance is linked."""
    table = np.array([(i.light_set, i.shadow_set, i.light_membership, i.shadow_membership) for i in instances],
                     np.uint64).reshape(-1, 4)
    unlinked = (table[:, 0] == 0) & (table[:, 1] == 0) & (table[:, 2] == ALL_SETS) & (table[:, 3] == ALL_SETS)
    return table if not unlinked.all() else np.zeros((0, 4), np.uint64)


def ao_distance_table(instances: list) -> np.ndarray:
    """(n,) float64 each instance's own Fast GI AO Distance (Instance.ao_distance, 0: the render's); empty where
    none has one."""
    table = np.array([float(getattr(i, "ao_distance", 0.0) or 0.0) for i in instances], np.float64)
    return table if (table != 0.0).any() else np.zeros(0)


def caustics_table(instances: list) -> np.ndarray:
    """(n,) uint8 each instance's shadow caustics bits (1: casts, 2: receives; core/integrators/mnee.py); empty where
    none has any."""
    table = np.array([(1 if getattr(i, "caustics_caster", False) else 0)
                      | (2 if getattr(i, "caustics_receiver", False) else 0) for i in instances], np.uint8)
    return table if table.any() else np.zeros(0, np.uint8)


def terminator_table(instances: list) -> np.ndarray:
    """(n, 2) float64 each instance's shadow terminator: its Geometry Offset (-1: the render's
    RenderSettings.terminator_offset) and its Shading Offset s as Cycles' frequency multiplier 1 / (1 - s / 2) (1:
    none); empty when every instance takes the render's offset and has no Shading Offset."""
    table = np.array([(-1.0 if i.terminator_offset is None else max(float(i.terminator_offset), 0.0),
                       1.0 / (1.0 - 0.5 * min(max(float(i.terminator_shading), 0.0), 1.0))) for i in instances],
                     np.float64).reshape(-1, 2)
    plain = (table[:, 0] < 0.0) & (table[:, 1] == 1.0)
    return table if not plain.all() else np.zeros((0, 2))


def attribute_table(meshes: list) -> tuple:
    """The meshes' per-corner attributes in one table: ((r, 3, A) float32 or None, layout name -> (offset,
    width), first row of each mesh by id). A mesh without one of the attributes has zeros there."""
    names = set()
    for mesh in meshes:
        names.update(getattr(mesh, "attributes", None) or {})
    if not names:
        return None, {}, {}
    layout = graph_.layout_of(names)
    width = sum(w for _, w in layout.values())
    if width > graph_.MAX_ATTRIBUTES:
        raise ValueError(f"the materials read {width} attribute floats per corner; Primer has {graph_.MAX_ATTRIBUTES}")
    first, rows = {}, 0
    for mesh in meshes:
        if id(mesh) not in first:
            first[id(mesh)] = rows
            rows += len(mesh.triangles)
    table = np.zeros((rows, 3, width), np.float32)
    for mesh in meshes:
        start = first[id(mesh)]
        for name, values in (getattr(mesh, "attributes", None) or {}).items():
            offset, w = layout[name]
            values = np.asarray(values, np.float64).reshape(len(mesh.triangles), 3, -1)
            table[start:start + len(mesh.triangles), :, offset:offset + min(w, values.shape[2])] = values[:, :, :w]
    return table, layout, first


def _in_range(mesh) -> np.ndarray:
    """Return which of the mesh's triangles index only its own vertices: (t,) bool."""
    return vectors.all_columns((mesh.triangles >= 0) & (mesh.triangles < len(mesh.vertices)))


def _motion_steps(matrices, origin: np.ndarray) -> np.ndarray:
    """A moving instance's motion steps (Instance.motion, (4, 4) each) camera-relative and decomposed as Cycles does
    (motion.decompose) -> (s, MOTION_STRIDE) float64."""
    relative = [np.array(m, np.float64) for m in matrices]
    for matrix in relative:
        matrix[:3, 3] -= origin
    return motion_.decompose(relative)


def _instanced_placements(scene: Scene, mesh, placed: np.ndarray, all_matrices: np.ndarray, origin: np.ndarray,
                          n_materials: int, first_row: int = 0):
    """Return (the InstancedMesh of `mesh` at the placements `placed`, or None; its counts of dropped
    and defaulted triangles). placed: (k,) int64 indices into scene.instances of non-singular
    placements, ascending (so when they are all of scene.instances, all_matrices is used uncopied)."""
    found = {"missing": 0, "nonfinite": 0, "degenerate": 0, "index": 0}
    every = len(placed) == len(scene.instances)
    in_range = _in_range(mesh)
    found["index"] += int((~in_range).sum()) * len(placed)
    triangles, smooth = mesh.triangles[in_range], mesh.smooth[in_range]
    corners = _object_corner_normals(mesh, in_range) if smooth.any() else None
    record = _instanced_mesh(mesh, triangles, smooth, mesh.material_indices[in_range], corners,
                             all_matrices if every else all_matrices[placed],
                             [scene.instances[index].materials for index in placed.tolist()],
                             placed.astype(np.int32), origin, n_materials, found,
                             np.flatnonzero(in_range) + first_row)
    return record, found


def _place_copies(batch: list, scene: Scene, all_matrices: np.ndarray, all_det: np.ndarray, origin: np.ndarray,
                  n_materials: int, counts: dict, first_row: Optional[dict] = None) -> _Batch:
    """Place meshes as copies, all at once: batch is a list of (mesh, placements (k,) int64 indices into
    scene.instances); a mesh with many placements may come more than once, a part of its placements
    each time. Returns the _Batch of their triangles in that order (a
    placement's triangles together, in the mesh's order); triangles with out-of-range vertex indices
    are dropped and counted, and triangles without a material get the default grey (counted)."""
    meshes = [mesh for mesh, _ in batch]
    # 1. Every mesh once, one after the other: its points, triangles (in its own numbering), smooth
    #    flags, material slots and object-space corner normals.
    V = np.array([len(mesh.vertices) for mesh in meshes], np.int64)                  # (d,)
    T = np.array([len(mesh.triangles) for mesh in meshes], np.int64)
    joined = lambda arrays: arrays[0] if len(arrays) == 1 else np.concatenate(arrays)    # (no copy of one)
    points = joined([mesh.vertices for mesh in meshes])                              # (sum V, 3)
    local = joined([mesh.triangles for mesh in meshes])                              # (sum T, 3)
    in_range = vectors.all_columns((local >= 0) & (local < np.repeat(V, T)[:, None]))
    smooth = joined([mesh.smooth for mesh in meshes]) & in_range
    slots = joined([mesh.material_indices for mesh in meshes])
    corners = None
    if smooth.any():
        has_smooth = np.array([mesh.smooth.any() for mesh in meshes])
        wanted_rows = np.repeat(has_smooth, T) & in_range
        # (A mesh whose given corner normals are all in range is joined as it is: no copy of it first; float32
        # ones are widened to float64 as they are joined, Mesh.corner_normals.)
        given = [mesh.corner_normals if mesh.corner_normals is not None and ok.all()
                 else _object_corner_normals(mesh, ok) for mesh, ok, wanted
                 in zip(meshes, np.split(in_range, np.cumsum(T)[:-1]), has_smooth) if wanted]
        values = (given[0].astype(np.float64, copy=False) if len(given) == 1
                  else np.concatenate(given, dtype=np.float64))
        del given
        if len(values) == len(local):               # every row (numpy's scatter costs 0.1 us a row)
            corners = values
        else:
            corners = np.zeros((len(local), 3, 3))
            corners[wanted_rows] = values
    # 2. The placements: which mesh, which instance, and where each one's rows start.
    k = np.array([len(placed) for _, placed in batch], np.int64)
    mesh_of = np.repeat(np.arange(len(meshes)), k)                                   # (p,)
    owner = np.concatenate([placed for _, placed in batch])                          # (p,) scene.instances
    Vp, Tp = V[mesh_of], T[mesh_of]

    def rows(counts_p: np.ndarray, starts_p: np.ndarray) -> np.ndarray:
        """Row starts_p[i] + j for j < counts_p[i], placement after placement: (sum counts_p,) int64."""
        ends = np.cumsum(counts_p)
        return np.arange(ends[-1]) - np.repeat(ends - counts_p - starts_p, counts_p)

    # 3. World point = M p + t, minus the origin, in float64, for every placement's points (one
    #    placement, such as a large mesh's, needs no gathered copies: the same numbers).
    with np.errstate(invalid="ignore", over="ignore"):
        if len(owner) == 1:
            M = all_matrices[owner[0]]
            world = vectors.transform(points, M[:3, :3], M[:3, 3] - origin)
        else:
            point_row = rows(Vp, (np.cumsum(V) - V)[mesh_of])                        # into `points`
            instance_of_point = np.repeat(owner, Vp)
            world = vectors.apply_each(vectors.pick_rows(all_matrices[:, :3, :3], instance_of_point),
                                       vectors.pick_rows(points, point_row),
                                       vectors.pick_rows(all_matrices[:, :3, 3] - origin, instance_of_point))
    # 4. Every placement's triangles, numbered into `world`; out-of-range ones dropped.
    if len(owner) == 1:
        counts["index"] += int((~in_range).sum())
        every = bool(in_range.all())
        triangle_row = np.arange(len(local)) if every else np.flatnonzero(in_range)      # into `local`
        placement_of_triangle = np.zeros(len(triangle_row), np.int64)
        triangles = local if every else vectors.pick_rows(local, triangle_row)
    else:
        triangle_row = rows(Tp, (np.cumsum(T) - T)[mesh_of])                         # into `local`
        keep = in_range[triangle_row]
        counts["index"] += int((~keep).sum())
        triangle_row = triangle_row[keep]
        placement_of_triangle = np.repeat(np.arange(len(owner)), Tp)[keep]
        triangles = vectors.pick_rows(local, triangle_row) + (np.cumsum(Vp) - Vp)[placement_of_triangle][:, None]
    instance = owner[placement_of_triangle]
    # 5. Materials: each instance's slot -> scene material (its own table, or the mesh's indices as
    #    they are); missing ones fall back to the default grey.
    slot = slots[triangle_row]
    tables = [scene.instances[index].materials for index in owner.tolist()]
    width = max([len(table) for table in tables if table is not None], default=0)
    table = np.full((len(owner), max(width, 1)), -1, np.int64)
    own = np.zeros(len(owner), bool)                   # the mesh's own indices are the materials
    for row, entries in enumerate(tables):
        if entries is None:
            own[row] = True
        else:
            table[row, :len(entries)] = entries
    filled = (slot >= 0) & (slot < table.shape[1])
    material = np.where(own[placement_of_triangle], slot,
                        table[placement_of_triangle, np.where(filled, slot, 0)])
    material = np.where(own[placement_of_triangle] | filled, material, -1)
    missing = (material < 0) | (material >= n_materials)
    counts["missing"] += int(missing.sum())
    # 6. Smooth corners turn with the inverse transpose: N' = M^-T N (row vectors: n @ M^-1).
    smooth = smooth[triangle_row]
    corner_normals = None
    if corners is not None and smooth.any():
        inverse = vectors.determinant_and_inverse(vectors.pick_rows(all_matrices[:, :3, :3], owner))[1]   # (p, 3, 3)
        if library.available():                     # the same numbers in one pass
            corner_normals = normals_.compiled_turn_normals(corners, triangle_row[smooth], inverse,
                                                  placement_of_triangle[smooth])
        else:
            corner_normals = normals_.safe_normalize(vectors.rows_times_each(corners[triangle_row[smooth]],
                                                                             inverse[placement_of_triangle[smooth]]))
    # 7. Each triangle's row of the attribute table: its mesh's first row plus its index in the mesh.
    source = np.zeros(len(triangle_row), np.int64)
    if first_row:
        starts = np.cumsum(T) - T
        mesh_of_row = np.repeat(np.arange(len(meshes)), T)[triangle_row]
        firsts = np.array([first_row.get(id(mesh), 0) for mesh in meshes], np.int64)
        source = firsts[mesh_of_row] + triangle_row - starts[mesh_of_row]
    return _Batch(points=world, triangles=triangles, sign=np.sign(all_det[instance]),
                  material=np.where(missing, n_materials, material), owner=instance.astype(np.int32),
                  smooth=smooth, corner_normals=corner_normals, source=source)


def _instanced_mesh(mesh, triangles: np.ndarray, smooth: np.ndarray, slots: np.ndarray,
                    corners: Optional[np.ndarray], matrices: np.ndarray, tables: list, owners: np.ndarray,
                    origin: np.ndarray, n_materials: int, counts: dict, attribute_rows: Optional[np.ndarray] = None):
    """Return the InstancedMesh of one mesh placed k times, or None when nothing of it can be traced.

    triangles: (t, 3) int64 in-range vertex indices; smooth: (t,) bool; slots: (t,) int64 material
    slots; corners: (t, 3, 3) float64 object-space corner normals or None; matrices: (k, 4, 4)
    float64 non-singular object-to-world matrices; tables: each instance's slot -> material table;
    owners: (k,) int32 Scene.instances indices; attribute_rows: (t,) int64 each triangle's row of the
    attribute table, or None. Dropped and defaulted triangles are added to `counts`.
    """
    # 1. The prototype: finite, non-degenerate triangles in object space (what Embree stores once).
    with np.errstate(invalid="ignore", over="ignore"):
        vertices32 = mesh.vertices.astype(np.float32)
        faces = _face_normals(mesh.vertices, triangles)
    finite, nondegenerate = _triangle_checks(vertices32, triangles, faces.normals, faces.area)
    keep = finite & nondegenerate
    # 2. Camera-relative transforms, rounded once to the float32 numbers Embree traces with;
    #    instances that overflow float32 or reach infinity are dropped.
    transforms = np.empty((len(matrices), 3, 4), np.float32)                        # (k, 3, 4)
    with np.errstate(invalid="ignore", over="ignore"):
        transforms[:, :, :3] = matrices[:, :3, :3]
        transforms[:, :, 3] = matrices[:, :3, 3] - origin
    prototype = np.where(np.isfinite(vertices32), vertices32, np.float32(0.0))
    used = np.unique(triangles[keep]) if keep.any() else np.zeros(0, np.int64)
    if len(used) == 0:
        counts["nonfinite"] += int((~finite).sum()) * len(matrices)
        counts["degenerate"] += int((finite & ~nondegenerate).sum()) * len(matrices)
        return None
    with np.errstate(invalid="ignore", over="ignore"):
        lo, hi = instancing.world_boxes(prototype[used], transforms)
        det = vectors.determinant(np.nan_to_num(transforms[:, :, :3].astype(np.float64)))
        placeable = (np.isfinite(transforms).all(axis=(1, 2)) & (det != 0.0) & np.isfinite(lo).all(axis=1)
                     & np.isfinite(hi).all(axis=1) & (np.abs(np.concatenate([lo, hi], axis=1)).max(axis=1)
                                                      < np.finfo(np.float32).max))
    counts["nonfinite"] += int((~finite).sum()) * len(matrices) + int(keep.sum()) * int((~placeable).sum())
    counts["degenerate"] += int((finite & ~nondegenerate).sum()) * len(matrices)
    if not placeable.any():
        return None
    if not placeable.all():
        transforms, lo, hi, owners = transforms[placeable], lo[placeable], hi[placeable], owners[placeable]
        tables = [table for table, ok in zip(tables, placeable) if ok]
        det = det[placeable]
    # 3. Materials: one row per distinct slot table, shared by the instances that use it.
    table_rows: dict = {}
    distinct: list = []
    row_of: dict = {}
    material_row = np.empty(len(transforms), np.int32)
    for index, table in enumerate(tables):
        row = _slot_materials(slots, table, table_rows)
        if id(row) not in row_of:
            row_of[id(row)] = len(distinct)
            distinct.append(row)
        material_row[index] = row_of[id(row)]
    material = np.stack(distinct)                                                  # (r, t)
    missing = (material < 0) | (material >= n_materials)
    counts["missing"] += int((missing.sum(axis=1) * np.bincount(material_row, minlength=len(distinct))).sum())
    material = np.where(missing, n_materials, material)[:, keep].astype(np.int32)
    # 4. Smooth triangles keep their object-space corner normals; shading turns them per hit.
    smooth_kept = smooth[keep]
    smooth_index = np.full(int(keep.sum()), -1, np.int32)
    smooth_index[smooth_kept] = np.arange(int(smooth_kept.sum()), dtype=np.int32)
    corner_normals = (corners[keep][smooth_kept] if corners is not None and smooth_kept.any()
                      else np.zeros((0, 3, 3)))
    return instancing.InstancedMesh(
        name=mesh.name, vertices=prototype, triangles=triangles[keep].astype(np.int32),
        smooth_index=smooth_index, corner_normals=corner_normals, transforms=transforms,
        flip=np.sign(det).astype(np.float32),
        material=material, material_row=material_row, owner=owners.astype(np.int32), first_prim=0,
        locator=instancing.InstanceLocator(lo, hi),
        attribute_row=None if attribute_rows is None else attribute_rows[keep].astype(np.int32))
