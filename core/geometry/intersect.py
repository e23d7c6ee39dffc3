"""Ray queries: the one place where Primer asks Embree (through embreex) about rays.

Two questions can be asked of the scene:
- `intersect`: where does each ray first hit a triangle (primary rays)?
- `occluded`: is there *any* hit before t_max (shadow rays)? Embree may stop at
  the first hit it finds, so this is cheaper: "the shadow ray is used to
  determine *if* there is an occluder, not *where*" (the lecture).

Everything above this module is float64; Embree works in float32. The
conversion happens here and only here. Callers pass camera-relative
coordinates (see `core/geometry/geometry.py`), so float32 keeps its precision where
the camera looks.
"""
from __future__ import annotations

import ctypes
import threading
import time
from typing import NamedTuple, Optional

import numpy as np

from . import embree_buffers
from ..camera import motion
from ..native import library, schema
from ..native.schema import F32, F64, I32, I64, U8, out, ptr

# Embree's "infinite" t_far: the largest distance embreex uses itself.
T_INFINITY = 1e37


class Hits(NamedTuple):
    """Nearest hits of a batch of rays.

    hit:  (n,) bool, True where the ray hit a triangle before t_max
    t:    (n,) float64 distance along the (unit) direction, inf where missed
    prim: (n,) int64 triangle index, -1 where missed
    u, v: (n,) float64 barycentric coordinates of the hit: I = (1-u-v) V0 + u V1 + v V2
    time: (n,) float64 the rays' times in the shutter, where moving objects were met (the integrators' nearest_seen
          keeps them with the hits), or None: no object moves
    """

    hit: np.ndarray
    t: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray
    time: Optional[np.ndarray] = None


def _f32_rays(origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray):
    """Convert a ray batch to the contiguous float32 arrays embreex expects."""
    o = np.ascontiguousarray(origins, dtype=np.float32)
    d = np.ascontiguousarray(directions, dtype=np.float32)
    t = np.ascontiguousarray(np.minimum(t_max, T_INFINITY), dtype=np.float32)
    return o, d, t


class Tracer:
    """An Embree BVH over one triangle soup and any instanced meshes, answering nearest-hit and occlusion queries.

    vertices:  (v, 3) float32 camera-relative points
    triangles: (t, 3) int32 vertex indices
    The queries release the GIL, so several threads may query one Tracer at once.
    share: True lets Embree read the arrays in place (`core/geometry/embree_buffers.py`); False, or a share
    that fails its checks, copies them through embreex's `TriangleMesh`, the reference path.
    Both give the same BVH and the same hits.
    shared: whether the arrays were shared.
    intersect_seconds, occluded_seconds: time spent inside Embree's queries, summed over threads.
    upload_seconds: time taken to hand the arrays to Embree. Sharing costs one numpy copy (to add
    a padding row); embreex's copy goes one element at a time through Python indexing (about
    0.35 us per number, so 1.6 s for a mesh of 10^6 triangles and 5 x 10^5 vertices).
    build_seconds: time Embree took to build the BVH itself.
    instanced: InstancedMesh records (core/geometry/instancing.py), each traced as an Embree instance array
    of one prototype; `intersect` reports their hits by flat triangle index like the copied ones.
    packets: True asks Embree 8 rays at a time (rtcIntersect8 / rtcOccluded8, through the compiled
    compiled code in core/geometry/embree.c) where it can; False, or without the library, asks through embreex's
    `run`, one ray at a time: the reference path. Both give the same answers. Neighbouring rays of
    a batch (a pixel's samples, a hit's light samples) travel close together, so a packet shares
    much of its way down the BVH: on the sample scenes a shadow ray costs 2.4 times less.
    packed: whether the queries go in packets.
    """

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray, share: bool = True, instanced=(),
                 packets: bool = True):
        self.instanced = list(instanced)
        self.moving = any(mesh.motion is not None for mesh in self.instanced)
        self.triangle_count = int(len(triangles)) + sum(m.triangle_count for m in self.instanced)
        self._scene = None
        self.shared = False
        self.intersect_seconds = 0.0
        self.occluded_seconds = 0.0
        self.upload_seconds = 0.0
        self.build_seconds = 0.0
        self._clock = threading.Lock()
        self._packets = None
        if self.triangle_count == 0:
            return
        from embreex import rtcore, rtcore_scene
        start = time.perf_counter()
        self._device = rtcore.EmbreeDevice()
        self._scene = rtcore_scene.EmbreeScene(self._device, robust=True)
        self._buffers = []  # arrays Embree reads in place, kept alive as long as the scene
        if share and len(triangles):
            self.shared = self._share(vertices, triangles)
        if len(triangles) and not self.shared:
            from embreex.mesh_construction import TriangleMesh
            self._mesh = TriangleMesh(self._scene,
                                      np.ascontiguousarray(vertices, dtype=np.float32),
                                      np.ascontiguousarray(triangles, dtype=np.int32))
        # The copied triangles are geometry 0 of the top-level scene; instanced mesh m reports m + 1.
        for geometry_id, mesh in enumerate(self.instanced, start=1):
            self._instance(mesh, geometry_id)
        uploaded = time.perf_counter()
        # Build the BVH now (Embree commits on the first query), not inside a worker thread.
        self._scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), query="OCCLUDED")
        self.upload_seconds = uploaded - start
        self.build_seconds = time.perf_counter() - uploaded
        if packets or self.moving:
            self._packets = embree_packets(self._scene, self._device)
        if self.moving and self._packets is None:
            raise RuntimeError("moving meshes need Embree's packet queries (the compiled library): embreex's own "
                               "queries carry no time")

    @property
    def packed(self) -> bool:
        """Whether the queries go to Embree in packets of 8 rays."""
        return self._packets is not None

    @property
    def packets(self):
        """The packet queries' addresses (EmbreePackets), or None."""
        return self._packets

    def count_occluded(self, seconds: float) -> None:
        """Count `seconds` that a compiled kernel spent in Embree's occlusion queries (as `occluded` would)."""
        self._count("occluded_seconds", seconds)

    def count_intersect(self, seconds: float) -> None:
        """Count `seconds` that a compiled kernel spent in Embree's nearest-hit queries (as `intersect` would)."""
        self._count("intersect_seconds", seconds)

    def flatten_prims(self, geometry_id: np.ndarray, prim: np.ndarray, u: np.ndarray, v: np.ndarray,
                      origins: np.ndarray, directions: np.ndarray, t: np.ndarray, instance: np.ndarray) -> None:
        """Turn hits that a compiled kernel found on instances into flat triangle indices, in place
        in `prim`, as `intersect` does (all rays here hit). Arguments as `_flat_indices` takes them."""
        self._flat_indices(geometry_id, prim, u, v, origins, directions, t, instance)

    def _share(self, vertices: np.ndarray, triangles: np.ndarray) -> bool:
        """Attach the mesh as buffers Embree reads in place; return False (nothing attached) if it cannot be done."""
        points = embree_buffers.padded(vertices, np.float32)
        indices = embree_buffers.padded(triangles, np.uint32)
        if embree_buffers.attach_triangles(self._scene, self._device, points, indices) is None:
            return False
        self._buffers += [points, indices]
        return True

    def _instance(self, mesh, geometry_id: int) -> None:
        """Attach an instanced mesh (core/geometry/instancing.py): its prototype once, reported as geomID `geometry_id`;
        a moving one (mesh.motion) as one instance that Embree places at each ray's time."""
        points = embree_buffers.padded(mesh.vertices, np.float32)
        indices = embree_buffers.padded(mesh.triangles, np.uint32)
        if mesh.motion is not None:
            steps = motion.embree_steps(mesh.motion)
            shapes = ([] if mesh.vertex_steps is None
                      else [embree_buffers.padded(points_k, np.float32) for points_k in mesh.vertex_steps])
            if not embree_buffers.attach_motion_instance(self._scene, self._device, points, indices, steps, geometry_id,
                                                         shapes):
                raise RuntimeError(f"Embree refused the motion of mesh '{mesh.name}'")
            self._buffers += [points, indices, steps] + shapes
            return
        transforms = mesh.embree_transforms()
        if not embree_buffers.attach_instances(self._scene, self._device, points, indices, transforms, geometry_id):
            raise RuntimeError(f"Embree refused the instances of mesh '{mesh.name}'")
        self._buffers += [points, indices, transforms]

    def intersect(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray,
                  times: Optional[np.ndarray] = None) -> Hits:
        """Return the nearest hit in (0, t_max) of each ray.

        origins: (n, 3) float64 points; directions: (n, 3) float64 unit vectors; t_max: (n,) float64;
        times: (n,) float64 each ray's time in the shutter, where moving meshes are (None: a still scene's 0).
        """
        n = len(origins)
        if self._scene is None or n == 0:
            return Hits(np.zeros(n, bool), np.full(n, np.inf), np.full(n, -1, np.int64),
                        np.zeros(n), np.zeros(n))
        if self._packets is not None:
            # The packets take the float64 rays and round them to float32 as they are filled.
            o, d, t = (np.ascontiguousarray(a, np.float64) for a in (origins, directions, t_max))
            start = time.perf_counter()
            t_hit, prim, geometry_id, u, v, instance = packet_intersect(self._packets, o, d, t, times)
            self._count("intersect_seconds", time.perf_counter() - start)
            hit = geometry_id >= 0
        else:
            o, d, t = _f32_rays(origins, directions, t_max)
            start = time.perf_counter()
            out = self._scene.run(o, d, dists=t, output=1)
            self._count("intersect_seconds", time.perf_counter() - start)
            prim = out["primID"].astype(np.int64)
            geometry_id = out["geomID"]
            hit = geometry_id >= 0
            prim[~hit] = -1
            t_hit = np.where(hit, out["tfar"].astype(np.float64), np.inf)
            u, v = out["u"].astype(np.float64), out["v"].astype(np.float64)
            instance = None                      # embreex's record drops Embree's instance IDs
        if self.instanced:
            self._flat_indices(geometry_id, prim, u, v, origins, directions, t_hit, instance)
        return Hits(hit, t_hit, prim, u, v)

    def _flat_indices(self, geometry_id: np.ndarray, prim: np.ndarray, u: np.ndarray, v: np.ndarray,
                      origins: np.ndarray, directions: np.ndarray, t: np.ndarray,
                      instance: Optional[np.ndarray] = None) -> None:
        """Turn hits on instances into flat triangle indices, in place in `prim` (core/geometry/instancing.py).

        geometry_id: (n,) int32 Embree's geomID (0 copied triangles, m + 1 instanced mesh m);
        prim: (n,) int64 Embree's primID; instance: (n,) int64 Embree's instPrimID, the placement
        each hit was on (the packet queries have it; -1 or None where not known: the hit's point
        then finds it, mesh.identify); the rest as `intersect` has them.
        """
        for geometry, mesh in enumerate(self.instanced, start=1):
            on = np.flatnonzero(geometry_id == geometry)
            if len(on) == 0:
                continue
            local = prim[on]
            j = np.full(len(on), -1, np.int64) if instance is None else instance[on].copy()
            unknown = np.flatnonzero((j < 0) | (j >= len(mesh.transforms)))
            if len(unknown):
                rows = on[unknown]
                X = origins[rows] + t[rows, None] * directions[rows]
                j[unknown] = mesh.identify(local[unknown], u[rows], v[rows], X)
            prim[on] = mesh.first_prim + j * len(mesh.triangles) + local

    def occluded(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray,
                 times: Optional[np.ndarray] = None) -> np.ndarray:
        """Return whether anything lies on each ray within (0, t_max): (n,) bool.

        origins: (n, 3) float64 points; directions: (n, 3) float64 unit vectors; t_max: (n,) float64;
        times: (n,) float64 each ray's time in the shutter, where moving meshes are (None: a still scene's 0).
        """
        n = len(origins)
        if self._scene is None or n == 0:
            return np.zeros(n, bool)
        o, d, t = _f32_rays(origins, directions, t_max)
        start = time.perf_counter()
        if self._packets is not None:
            blocked = packet_occluded(self._packets, o, d, t, times)
        else:
            blocked = self._scene.run(o, d, dists=t, query="OCCLUDED") >= 0
        self._count("occluded_seconds", time.perf_counter() - start)
        return blocked

    def _count(self, name: str, seconds: float) -> None:
        """Add `seconds` to the query timer `name` (threads share it, hence the lock)."""
        with self._clock:
            setattr(self, name, getattr(self, name) + seconds)


# ---------------------------------------------------------------------------
# Embree's queries in packets of 8 rays (core/geometry/embree.c)
# ---------------------------------------------------------------------------



class EmbreePackets(NamedTuple):
    """What the compiled code needs to ask one Embree scene about rays 8 at a time: addresses.

    scene: the RTCScene; occluded8, intersect8: Embree's rtcOccluded8 and rtcIntersect8.
    """

    scene: int
    occluded8: int
    intersect8: int


def embree_packets(scene, device) -> Optional[EmbreePackets]:
    """Return the packet queries of an embreex scene made on `device`, or None where they cannot be had.

    They need the compiled library and the very Embree library embreex loaded (embree_buffers.py finds
    it and reads the scene's handle); otherwise the Tracer asks embreex one ray at a time.
    """
    if not library.available():
        return None
    embree = embree_buffers.embree_library()
    handles = embree_buffers.scene_handles(scene, device) if embree is not None else None
    if handles is None:
        return None
    address = lambda function: ctypes.cast(function, ctypes.c_void_p).value
    return EmbreePackets(handles.scene, address(embree.rtcOccluded8), address(embree.rtcIntersect8))


OccludedArgs = schema.function("primer_occluded", "occluded_rays", schema.record(
    "OccludedArgs", "primer_occluded's arguments: whether anything lies on each of n rays (Embree's packets).", [
        ("function", out(), "Embree's rtcOccluded8"),
        ("scene", out(), "the RTCScene"),
        ("n", I64, ""),
        ("origins", ptr(F32), "(n, 3)"),
        ("directions", ptr(F32), "(n, 3)"),
        ("t_max", ptr(F32), "(n,)"),
        ("time", ptr(F64), "(n,) each ray's time in the shutter (object motion blur), or NULL: 0"),
        ("blocked", out(U8), "(n,)"),
    ]))
IntersectArgs = schema.function("primer_intersect", "intersect_rays", schema.record(
    "IntersectArgs", "primer_intersect's arguments: the nearest hit of each of n rays (Embree's packets).", [
        ("function", out(), "Embree's rtcIntersect8"),
        ("scene", out(), "the RTCScene"),
        ("n", I64, ""),
        ("origins", ptr(F64), "(n, 3)"),
        ("directions", ptr(F64), "(n, 3)"),
        ("t_max", ptr(F64), "(n,)"),
        ("time", ptr(F64), "(n,) each ray's time in the shutter (object motion blur), or NULL: 0"),
        ("t", out(F64), "(n,) inf where missed"),
        ("prim", out(I64), "(n,) -1 where missed"),
        ("geometry", out(I32), "(n,) Embree's geomID, -1 where missed"),
        ("u", out(F64), "(n,)"),
        ("v", out(F64), "(n,)"),
        ("instance", out(I64), "(n,) the placement hit in an instance array, -1: a copied triangle"),
    ]))


def _check_rays(origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray) -> None:
    """Refuse a ray batch whose arrays disagree in length (the C code would read past one of them)."""
    n = len(origins)
    if origins.shape != (n, 3) or directions.shape != (n, 3) or t_max.shape != (n,):
        raise ValueError(f"rays: origins {origins.shape}, directions {directions.shape}, t_max {t_max.shape}")


def packet_occluded(packets: EmbreePackets, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray,
                    time: Optional[np.ndarray] = None) -> np.ndarray:
    """Whether anything lies on each ray within (0, t_max), asked 8 rays at a time: (n,) bool.

    origins, directions: (n, 3) float32; t_max: (n,) float32; time: (n,) float64 each ray's time in the shutter
    (where moving instances are), or None.
    """
    n = len(origins)
    _check_rays(origins, directions, t_max)
    blocked = np.empty(n, np.bool_)
    library.call("primer_occluded", OccludedArgs(function=packets.occluded8, scene=packets.scene, n=n, origins=origins,
                                                 directions=directions, t_max=t_max, time=_times(time, n),
                                                 blocked=blocked.view(np.uint8)))
    return blocked


def _times(time: Optional[np.ndarray], n: int) -> Optional[np.ndarray]:
    """The rays' times as the packets read them: (n,) float64 C-contiguous, or None."""
    if time is None:
        return None
    time = np.ascontiguousarray(time, np.float64)
    if time.shape != (n,):
        raise ValueError(f"rays: {n} rays, times {time.shape}")
    return time


def packet_intersect(packets: EmbreePackets, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray,
                     time: Optional[np.ndarray] = None):
    """The nearest hit in (0, t_max) of each ray, asked 8 rays at a time.

    origins, directions: (n, 3) float64; t_max: (n,) float64, rounded to Embree's float32 as the
    packets are filled (as _f32_rays would) -> t (n,) float64 (inf where missed),
    prim (n,) int64 (-1 where missed), geometry (n,) int32 Embree's geomID (-1 where missed),
    u, v (n,) float64 (0 where missed), instance (n,) int64 the placement of an instanced mesh hit
    (Embree's instPrimID; -1 on copied triangles and misses); time: (n,) float64 each ray's time in the shutter
    (where moving instances are), or None
    """
    n = len(origins)
    _check_rays(origins, directions, t_max)
    t, prim, geometry, u, v = (np.empty(n), np.empty(n, np.int64), np.empty(n, np.int32), np.empty(n),
                               np.empty(n))
    instance = np.empty(n, np.int64)
    library.call("primer_intersect", IntersectArgs(
        function=packets.intersect8, scene=packets.scene, n=n, origins=origins, directions=directions, t_max=t_max,
        time=_times(time, n), t=t, prim=prim, geometry=geometry, u=u, v=v, instance=instance))
    return t, prim, geometry, u, v, instance
