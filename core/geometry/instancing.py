"""Instancing: a mesh stored once, placed k times, and which placement a ray hit.

A forest of 10^5 trees made of one tree mesh need not cost the memory of 10^5 trees. Embree
can trace a mesh stored once, in a scene of its own (the prototype), through k object-to-world
transforms (an instance array): the ray is moved into a candidate instance's object space and
tested against the one prototype BVH. Primer does this for a mesh whose copies would add more
than INSTANCE_TRIANGLES triangles; smaller scenes are copied into one triangle soup, which is
faster to trace and to shade (`core/geometry/geometry.py`).

Which instance did the ray hit? Embree's hit record names it (instID), but embreex hands back
only geomID, primID, u, v, Ng and t. The prototype's geomID tells the mesh; primID and (u, v)
give the point p on the prototype's triangle, in object space; t gives the world point
X = O + t D. The instance is the j whose transform takes one to the other: A_j p = X.
`InstanceLocator` keeps a sparse grid over the instances' world boxes, so only the few
instances whose box holds X are tried, and the one with the smallest |A_j p - X| wins. If
several instances take p exactly to X (two copies touching there), the triangle of each passes
through X at the same distance t: any of them is a true nearest hit.

Every instanced triangle gets a flat index, as if the instances had been copied out one after
the other: first_prim + j t + local. The rest of Primer keeps addressing a triangle by one
integer, and `WorldGeometry` answers for both kinds.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import normals as normals_
from .. import vectors
from ..camera import motion

# A mesh is instanced, not copied, when its copies would hold more than this many triangles.
INSTANCE_TRIANGLES = 1 << 18

# RenderSettings.instancing: "auto" instances a mesh when its copies would exceed INSTANCE_TRIANGLES,
# "always" every mesh placed twice or more, "never" none (every placement copied).
INSTANCING_MODES = ("auto", "always", "never")

# The locator's grid: cells per axis at most (so a cell's key fits in an int64), and boxes
# spanning more cells than this are tried for every point instead of being filed in each cell.
MAX_CELLS_PER_AXIS = 1 << 20
MAX_CELLS_PER_BOX = 64

# Pairs (point, candidate instance) tried at once: bounds identification's memory however crowded.
MAX_PAIRS = 1 << 22

# In "auto" mode a mesh whose instances pile up deeper than this in one grid cell (thousands of
# copies in one place) is copied instead: each hit would have to try that many instances.
CROWDED = 256


def instance_triangles(mode: str) -> int:
    """Return build_geometry's `instance_triangles` for a RenderSettings.instancing mode."""
    if mode == "auto":
        return INSTANCE_TRIANGLES
    if mode == "always":
        return 0
    if mode == "never":
        return 1 << 62
    raise ValueError(f"instancing must be one of {INSTANCING_MODES}, got {mode!r}")


class InstanceLocator:
    """A sparse uniform grid over k axis-aligned boxes: which boxes may hold a point.

    lo, hi: (k, 3) float64 box corners. The cell is as wide as the median box, so a typical
    box is filed in at most 8 cells; a box spanning more than MAX_CELLS_PER_BOX cells is
    returned for every point (`everywhere`). Only the grid is kept, and `bounds`: (2, 3)
    float64, the box around all the boxes.
    """

    def __init__(self, lo: np.ndarray, hi: np.ndarray):
        self.bounds = np.stack([lo.min(axis=0), hi.max(axis=0)]) if len(lo) else np.zeros((2, 3))
        # 1. Cell size and grid dimensions.
        self.origin = lo.min(axis=0)
        span = hi.max(axis=0) - self.origin
        extent = (hi - lo).max(axis=1)
        cell = float(np.median(extent)) if len(extent) else 1.0
        self.cell = max(cell, float(span.max()) / (MAX_CELLS_PER_AXIS - 1), 1e-30)
        self.dims = (np.floor(span / self.cell).astype(np.int64) + 1)
        # 2. The cells each box covers; very large boxes go to `everywhere`.
        first, last = self._cells(lo), self._cells(hi)
        size = last - first + 1                                              # (k, 3) cells per axis
        count = size.prod(axis=1)
        filed = count <= MAX_CELLS_PER_BOX
        self.everywhere = np.flatnonzero(~filed)
        keys, boxes = self._file(np.flatnonzero(filed), first, size, count)
        # 3. Sorted by cell: the boxes of cell keys[i] are boxes[starts[i]:starts[i + 1]].
        order = np.argsort(keys, kind="stable")
        keys, self.boxes = keys[order], boxes[order]
        del order
        starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]]) if len(keys) else np.zeros(0, np.int64)
        self.keys = keys[starts]
        self.starts = np.append(starts, len(keys)).astype(np.int32 if len(keys) < 2**31 else np.int64)
        # The most boxes a point can be tested against.
        self.crowding = int(np.diff(self.starts).max(initial=0)) + len(self.everywhere)

    def _file(self, ids: np.ndarray, first: np.ndarray, size: np.ndarray, count: np.ndarray):
        """Return (cell key, box) for every cell of the boxes `ids`: (m,) int64 and (m,) int32.

        Built a bounded batch of boxes at a time, one axis at a time, so the temporaries stay
        small for 10^5 boxes and more.
        """
        parts_keys, parts_boxes = [], []
        batch = max(1, (1 << 20) // MAX_CELLS_PER_BOX)
        for start in range(0, len(ids), batch):
            chosen = ids[start:start + batch]
            c = count[chosen]
            boxes = np.repeat(chosen, c)
            rank = np.arange(len(boxes)) - np.repeat(np.cumsum(c) - c, c)    # which of its cells
            keys = np.zeros(len(boxes), np.int64)
            stride = np.ones(len(boxes), np.int64)
            for axis in (2, 1, 0):                     # z varies fastest, as in _keys
                extent = size[boxes, axis]
                along = (rank // stride) % extent
                keys += (first[boxes, axis] + along) * int(np.prod(self.dims[axis + 1:]))
                stride *= extent
            parts_keys.append(keys)
            parts_boxes.append(boxes.astype(np.int32))
        if not parts_keys:
            return np.zeros(0, np.int64), np.zeros(0, np.int32)
        return np.concatenate(parts_keys), np.concatenate(parts_boxes)

    def _cells(self, points: np.ndarray) -> np.ndarray:
        """Return the integer cell of each point, clamped to the grid: (n, 3) float64 -> (n, 3) int64."""
        cells = np.floor((points - self.origin) / self.cell)
        return np.clip(np.nan_to_num(cells), 0, self.dims - 1).astype(np.int64)

    def _keys(self, cells: np.ndarray) -> np.ndarray:
        """Return one int64 key per cell: (n, 3) int64 -> (n,) int64."""
        return (cells[:, 0] * self.dims[1] + cells[:, 1]) * self.dims[2] + cells[:, 2]

    def candidates(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the pairs (point, box) worth testing: two (p,) int64 arrays, grouped by point.

        points: (n, 3) float64. A point's boxes are those filed in its cell plus `everywhere`.
        """
        # 1. The range of filed boxes in each point's cell (empty where the cell holds none).
        keys = self._keys(self._cells(points))
        slot = np.minimum(np.searchsorted(self.keys, keys), max(len(self.keys) - 1, 0))
        found = (self.keys[slot] == keys) if len(self.keys) else np.zeros(len(points), bool)
        begin = np.where(found, self.starts[slot], 0)
        end = np.where(found, self.starts[np.minimum(slot + 1, len(self.starts) - 1)], 0)
        # 2. Expand to pairs: each point's filed boxes, then the `everywhere` boxes.
        filed = end - begin
        count = filed + len(self.everywhere)
        rows = np.repeat(np.arange(len(points)), count)
        rank = np.arange(len(rows)) - np.repeat(np.cumsum(count) - count, count)
        in_cell = rank < filed[rows]
        boxes = np.empty(len(rows), np.int64)
        boxes[in_cell] = self.boxes[begin[rows[in_cell]] + rank[in_cell]]
        if len(self.everywhere):
            boxes[~in_cell] = self.everywhere[rank[~in_cell] - filed[rows[~in_cell]]]
        return rows, boxes


@dataclass
class InstancedMesh:
    """One mesh, stored once, and its placements.

    name:           the mesh's name
    vertices:       (v, 3) float32 object-space points (what Embree traces)
    triangles:      (t, 3) int32 vertex indices (only the valid, finite, non-degenerate triangles)
    smooth_index:   (t,) int32 row of `corner_normals` per smooth triangle, -1 for flat ones
    corner_normals: (s, 3, 3) float64 object-space unit normals of the smooth triangles' corners
    transforms:     (k, 3, 4) float32 camera-relative object-to-world matrices [L | T], the very
                    numbers Embree traces with (it reads this array in place)
    flip:           (k,) float32 sign of det L: a mirror turns the winding, and the face normal with it
    material:       (r, t) int32 row of the scene's material table per triangle, one row per distinct slot table
    material_row:   (k,) int32 the row of `material` each instance uses
    owner:          (k,) int32 index into Scene.instances
    first_prim:     flat index of instance 0's triangle 0
    locator:        InstanceLocator over the instances' world boxes
    attribute_row:  (t,) int32 row of WorldGeometry.attributes per triangle (None without attributes)
    motion:         for one placement that moves over the shutter (object motion blur): (s, MOTION_STRIDE) float64
                    its camera-relative transforms at s evenly spaced times, decomposed (core/camera/motion.py
                    `decompose`), where Embree and shading place it at each ray's time; `transforms` then holds
                    it at the frame. None: still.
    vertex_steps:   for one placement whose mesh deforms over the shutter (deformation motion blur): (s, v, 3)
                    float32 its object-space points at s evenly spaced times, which Embree and shading interpolate
                    linearly at each ray's time (Cycles' motion vertices); `vertices` then holds them at the frame.
                    None: rigid.
    normal_steps:   with vertex_steps, (s, v, 3) float32 the object-space unit vertex normals at the same times
                    (Instance.deformation_normals), whose linear interpolation, normalised, gives the smooth triangles'
                    corner normals at each ray's time (Cycles' motion_triangle_normals); None: `corner_normals` (the
                    frame's) at every time.
    """

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    smooth_index: np.ndarray
    corner_normals: np.ndarray
    transforms: np.ndarray
    flip: np.ndarray
    material: np.ndarray
    material_row: np.ndarray
    owner: np.ndarray
    first_prim: int
    locator: InstanceLocator
    attribute_row: Optional[np.ndarray] = None
    motion: Optional[np.ndarray] = None
    vertex_steps: Optional[np.ndarray] = None
    normal_steps: Optional[np.ndarray] = None

    @property
    def triangle_count(self) -> int:
        """Triangles of all instances together (the flat indices this mesh takes)."""
        return len(self.transforms) * len(self.triangles)

    def split(self, prim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return (instance j, prototype triangle) of flat indices: (n,) int64 -> two (n,) int64."""
        return np.divmod(prim - self.first_prim, len(self.triangles))

    def object_points(self, local: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Return the object-space points at barycentrics (u, v) of prototype triangles: (n,) -> (n, 3) float64."""
        corners = self.vertices[self.triangles[local]].astype(np.float64)            # (n, 3, 3)
        w = 1.0 - u - v
        return w[:, None] * corners[:, 0] + u[:, None] * corners[:, 1] + v[:, None] * corners[:, 2]

    def placements(self, j: np.ndarray, times: Optional[np.ndarray] = None) -> np.ndarray:
        """Return the transforms [L | T] of instances `j` (n,) int64, a moving one's at each hit's time (times (n,)
        float64 in the shutter; None: its middle) -> (n, 3, 4) float64."""
        if self.motion is None or times is None:
            return self.transforms[j].astype(np.float64)
        linear, translation = motion.interpolate(self.motion, times)
        return np.concatenate([linear, translation[:, :, None]], axis=2)

    def object_corners(self, local: np.ndarray, times: Optional[np.ndarray] = None) -> np.ndarray:
        """Return the object-space corners of prototype triangles `local` (n,) -> (n, 3, 3) float64; a deforming
        mesh's at each hit's `times` (n,): linear between the two vertex steps around it, as Embree and Cycles."""
        if self.vertex_steps is None or times is None:
            return self.vertices[self.triangles[local]].astype(np.float64)
        last = len(self.vertex_steps) - 1
        times = np.asarray(times, np.float64)
        step = np.minimum((times * last).astype(np.int64), last - 1)
        t = (times * last - step)[:, None, None]
        a = self.vertex_steps[step[:, None], self.triangles[local]].astype(np.float64)
        b = self.vertex_steps[step[:, None] + 1, self.triangles[local]].astype(np.float64)
        return (1.0 - t) * a + t * b

    def object_normals(self, local: np.ndarray, times: np.ndarray) -> np.ndarray:
        """Return the object-space corner normals of prototype triangles `local` (n,) at `times` (n,) of a mesh with
        normal_steps: each vertex's normal linear between the two steps around the time, normalised (Cycles'
        motion_triangle_normals) -> (n, 3, 3) float64."""
        last = len(self.normal_steps) - 1
        times = np.asarray(times, np.float64)
        step = np.minimum((times * last).astype(np.int64), last - 1)
        t = (times * last - step)[:, None, None]
        a = self.normal_steps[step[:, None], self.triangles[local]].astype(np.float64)
        b = self.normal_steps[step[:, None] + 1, self.triangles[local]].astype(np.float64)
        return normals_.safe_normalize((1.0 - t) * a + t * b)

    def corner_points(self, j: np.ndarray, local: np.ndarray, times: Optional[np.ndarray] = None) -> np.ndarray:
        """Return the world corners of triangle `local` of instance `j`: (n,), (n,) -> (n, 3, 3) float64; a moving
        instance placed at each hit's `times` (n,), a deforming one's corners where they are then."""
        corners = self.object_corners(local, times)                                  # (n, 3, 3)
        A = self.placements(j, times)                                                # (n, 3, 4)
        return np.einsum("nij,nkj->nki", A[:, :, :3], corners) + A[:, None, :, 3]

    def face_normals(self, j: np.ndarray, corners: np.ndarray) -> np.ndarray:
        """Return unit front-side normals of placed triangles: j (n,), corners (n, 3, 3) -> (n, 3) float64."""
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        return normals_.safe_normalize(cross) * self.flip[j][:, None]

    def smooth_normals(self, j: np.ndarray, local: np.ndarray,
                       times: Optional[np.ndarray] = None) -> tuple[np.ndarray, np.ndarray]:
        """Return which triangles are smooth, (n,) bool, and their world corner normals, (s, 3, 3) float64 (a moving
        instance turned as it is at each hit's `times` (n,); a deforming one's normals, where it has normal_steps,
        as they are then: object_normals).

        A normal N transforms with L^-T, which is the cofactor matrix of L over det L. The
        cofactor matrix has the columns b x c, c x a, a x b (a, b, c the columns of L), so
        N' = N_x (b x c) + N_y (c x a) + N_z (a x b), times the sign of det L: no inverse needed.
        """
        row = self.smooth_index[local]
        smooth = row >= 0
        L = self.placements(j[smooth], None if times is None else times[smooth])[:, :, :3]    # (s, 3, 3)
        cofactor = np.ascontiguousarray(np.swapaxes(vectors.adjugate(L), 1, 2))      # (s, 3, 3) columns
        if self.normal_steps is None or times is None:
            corner = self.corner_normals[row[smooth]]
        else:
            corner = self.object_normals(local[smooth], np.asarray(times)[smooth])
        world = np.einsum("sij,skj->ski", cofactor, corner)
        world *= self.flip[j[smooth]][:, None, None]
        return smooth, normals_.safe_normalize(world)

    def materials(self, j: np.ndarray, local: np.ndarray) -> np.ndarray:
        """Return the material row of triangle `local` of instance `j`: (n,), (n,) -> (n,) int32."""
        return self.material[self.material_row[j], local]

    def identify(self, local: np.ndarray, u: np.ndarray, v: np.ndarray, X: np.ndarray) -> np.ndarray:
        """Return the instance each hit was on: the j with A_j p nearest X.

        local: (n,) int64 prototype triangle; u, v: (n,) float64 barycentrics; X: (n, 3) float64
        camera-relative world hit points -> (n,) int64.
        """
        p = self.object_points(local, u, v)
        j = np.full(len(X), -1, np.int64)
        # 1. The instances whose boxes hold X; the nearest image of p wins. A batch of points at a
        #    time, so that even crowded cells keep the pairs within MAX_PAIRS.
        step = max(1, MAX_PAIRS // max(self.locator.crowding, 1))
        for first in range(0, len(X), step):
            rows, boxes = self.locator.candidates(X[first:first + step])
            if len(rows):
                rows += first
                self._pick_nearest(p, X, rows, boxes, j)
        # 2. A point outside every box (it cannot be, but rounding is rounding): try them all.
        lost = np.flatnonzero(j < 0)
        k = len(self.transforms)
        step = max(1, MAX_PAIRS // max(k, 1))
        for first in range(0, len(lost), step):
            chunk = lost[first:first + step]
            rows = np.repeat(chunk, k)
            boxes = np.tile(np.arange(k), len(chunk))
            self._pick_nearest(p, X, rows, boxes, j)
        return j

    def _pick_nearest(self, p: np.ndarray, X: np.ndarray, rows: np.ndarray, boxes: np.ndarray,
                      out: np.ndarray) -> None:
        """Write into out[row] the box whose transform takes p[row] nearest X[row], over pairs grouped by row."""
        A = self.transforms[boxes].astype(np.float64)                                # (q, 3, 4)
        image = np.einsum("qij,qj->qi", A[:, :, :3], p[rows]) + A[:, :, 3]
        miss = image - X[rows]
        distance = np.einsum("qi,qi->q", miss, miss)
        order = np.lexsort((distance, rows))
        first = order[np.flatnonzero(np.r_[True, rows[order][1:] != rows[order][:-1]])]
        out[rows[first]] = boxes[first]

    def embree_transforms(self) -> np.ndarray:
        """Return the transforms as Embree reads them: (k, 12) float32, the rows of [L | T] one after another (a view)."""
        return np.ascontiguousarray(self.transforms, dtype=np.float32).reshape(len(self.transforms), 12)


def world_boxes(vertices: np.ndarray, transforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return each instance's world box, padded for rounding: vertices (v, 3), transforms (k, 3, 4) float -> two (k, 3) float64.

    The object-space box (centre c, half-size r) maps to the world box of centre L c + T and
    half-size |L| r (entrywise |L|): the smallest box around the transformed box.
    """
    lo, hi = vertices.min(axis=0).astype(np.float64), vertices.max(axis=0).astype(np.float64)
    L = transforms[:, :, :3].astype(np.float64)
    centre = L @ (0.5 * (lo + hi)) + transforms[:, :, 3]                             # (k, 3)
    half = np.abs(L, out=L) @ (0.5 * (hi - lo))                                      # (k, 3)
    # Embree's t is float32: X = O + t D may stray ~1e-7 of the coordinates from the surface.
    pad = 1e-5 * (half.max(axis=1) + np.abs(centre).max(axis=1))[:, None]
    half += pad
    return centre - half, centre + half
