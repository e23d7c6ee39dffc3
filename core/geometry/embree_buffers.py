"""Shared buffers: hand the triangle arrays to Embree without copying them.

embreex builds a mesh by copying each vertex coordinate and each index into Embree's own buffers
one number at a time through Python indexing (`TriangleMesh` in its `mesh_construction.pyx`):
about 0.35 us per number, 1.6 s for a mesh of 10^6 triangles. Embree itself can read the
application's arrays in place (`rtcSetSharedGeometryBuffer`), so this module does that: it
creates the triangle geometry through Embree's C API (ctypes, against the very library embreex
loaded) and attaches it to an embreex scene, whose queries then run as before.

embreex keeps its scene handle in a C field that Python cannot read, so `scene_handles` reads it
from the object's memory, and only after checking the object's layout three ways (its size, a
value we write through a public field, and the device pointer beside it) and asking Embree
whether the scene belongs to the device. If anything is unexpected (another embreex, another
platform, a missing library), `attach_triangles` returns None and the caller copies the
arrays the ordinary way (`core/geometry/intersect.py` keeps that path and tests both against each other).

The same C API places a mesh many times while storing it once (`attach_instances`): the mesh
goes into a scene of its own, and one instance array reads every placement's 3 x 4 transform in
place (core/geometry/instancing.py explains how a hit's instance is found, since embreex drops instID).

Embree reads shared arrays until the scene is freed, so the caller must keep them alive.
"""
from __future__ import annotations

import ctypes
import glob
import logging
import os
from typing import NamedTuple, Optional

import numpy as np

log = logging.getLogger(__name__)

# Embree 4's C constants (rtcore_common.h, rtcore_buffer.h, rtcore_geometry.h).
RTC_GEOMETRY_TYPE_TRIANGLE = 0
RTC_GEOMETRY_TYPE_INSTANCE = 121
RTC_GEOMETRY_TYPE_INSTANCE_ARRAY = 122
RTC_BUFFER_TYPE_INDEX = 0
RTC_BUFFER_TYPE_VERTEX = 1
RTC_BUFFER_TYPE_TRANSFORM = 23
RTC_FORMAT_UINT3 = 0x5003
RTC_FORMAT_FLOAT3 = 0x9003
RTC_FORMAT_FLOAT3X4_ROW_MAJOR = 0x9134
RTC_SCENE_FLAG_ROBUST = 1 << 2
RTC_ERROR_NONE = 0

# The C layout of embreex 4's extension types (see rtcore_scene.pxd and rtcore.pxd): after
# CPython's 16-byte object header, EmbreeScene holds {RTCScene scene_i; int is_committed;
# EmbreeDevice device} and EmbreeDevice holds {RTCDevice device}.
_HEADER = 16
_SCENE_SIZE = _HEADER + 8 + 8 + 8
_DEVICE_SIZE = _HEADER + 8
_SCENE_HANDLE = _HEADER
_SCENE_COMMITTED = _HEADER + 8
_SCENE_DEVICE_OBJECT = _HEADER + 16
_DEVICE_HANDLE = _HEADER


class Handles(NamedTuple):
    """Embree's C handles behind an embreex scene: RTCScene and RTCDevice, as integers."""

    scene: int
    device: int


_library_cache: list = []


def embree_library() -> Optional[ctypes.CDLL]:
    """Return the Embree 4 library that embreex loaded, with the few signatures used here, or None."""
    if _library_cache:
        return _library_cache[0]
    library = None
    path = _loaded_embree_path()
    if path is not None:
        try:
            library = _declare(ctypes.CDLL(path))
        except (OSError, AttributeError) as error:
            log.info("Embree's library at %s cannot be used directly (%s); arrays will be copied", path, error)
            library = None
    _library_cache.append(library)
    return library


def _loaded_embree_path() -> Optional[str]:
    """Return the file of the Embree library embreex's own modules link to, or None.

    Only a library shipped inside the embreex wheel counts, and only if embreex's compiled scene
    module names it: Blender ships an Embree of its own (for Cycles), and a call into that copy
    with embreex's scene would mix two libraries' objects.
    """
    import embreex.rtcore_scene as scene_module
    package = os.path.dirname(scene_module.__file__)
    try:
        with open(scene_module.__file__, "rb") as module:
            linked = module.read()
    except OSError:
        return None
    for pattern in ("../embreex.libs/*embree4*", ".dylibs/*embree4*", "*embree4*"):
        for path in sorted(glob.glob(os.path.join(package, pattern))):
            if os.path.basename(path).encode() in linked:
                return os.path.normpath(path)
    return None


def _declare(library: ctypes.CDLL) -> ctypes.CDLL:
    """Give the Embree functions used here their C signatures (ctypes would guess int otherwise)."""
    handle, uint, size = ctypes.c_void_p, ctypes.c_uint, ctypes.c_size_t
    signatures = {
        "rtcGetSceneDevice": (handle, [handle]),
        "rtcReleaseDevice": (None, [handle]),
        "rtcGetDeviceError": (ctypes.c_int, [handle]),
        "rtcNewGeometry": (handle, [handle, ctypes.c_int]),
        "rtcSetSharedGeometryBuffer": (None, [handle, ctypes.c_int, uint, ctypes.c_int, handle, size, size, size]),
        "rtcCommitGeometry": (None, [handle]),
        "rtcAttachGeometry": (uint, [handle, handle]),
        "rtcAttachGeometryByID": (None, [handle, handle, uint]),
        "rtcReleaseGeometry": (None, [handle]),
        "rtcNewScene": (handle, [handle]),
        "rtcSetSceneFlags": (None, [handle, ctypes.c_int]),
        "rtcCommitScene": (None, [handle]),
        "rtcReleaseScene": (None, [handle]),
        "rtcSetGeometryInstancedScene": (None, [handle, handle]),
        "rtcSetGeometryTimeStepCount": (None, [handle, uint]),
        "rtcSetGeometryTransformQuaternion": (None, [handle, uint, handle]),
    }
    for name, (result, arguments) in signatures.items():
        function = getattr(library, name)
        function.restype, function.argtypes = result, arguments
    return library


def scene_handles(scene, device) -> Optional[Handles]:
    """Return the C handles of an embreex scene created on `device`, or None if its layout is not the one known.

    scene: embreex.rtcore_scene.EmbreeScene built as EmbreeScene(device); device: embreex.rtcore.EmbreeDevice.
    """
    library = embree_library()
    if library is None or ctypes.sizeof(ctypes.c_void_p) != 8:
        return None
    # 1. Both objects have the size the known layout gives.
    if type(scene).__basicsize__ != _SCENE_SIZE or type(device).__basicsize__ != _DEVICE_SIZE:
        return None
    base = id(scene)
    # 2. The public `is_committed` field sits where the layout says: write two values and read them back.
    committed = scene.is_committed
    try:
        for sentinel in (0x5EED1234, 0x0BADF00D):
            scene.is_committed = sentinel
            if ctypes.c_int.from_address(base + _SCENE_COMMITTED).value != sentinel:
                return None
    finally:
        scene.is_committed = committed
    # 3. The scene's device field points at the device object we gave it.
    if ctypes.c_void_p.from_address(base + _SCENE_DEVICE_OBJECT).value != id(device):
        return None
    handles = Handles(scene=ctypes.c_void_p.from_address(base + _SCENE_HANDLE).value or 0,
                      device=ctypes.c_void_p.from_address(id(device) + _DEVICE_HANDLE).value or 0)
    if not handles.scene or not handles.device:
        return None
    # 4. Embree agrees that this scene was made on this device (rtcGetSceneDevice adds a reference).
    owner = library.rtcGetSceneDevice(handles.scene)
    if owner:
        library.rtcReleaseDevice(owner)
    return handles if owner == handles.device else None


def with_spare_row(n: int, dtype) -> np.ndarray:
    """Return zeros (n, 3) of `dtype` that are the leading rows of an (n + 1, 3) buffer whose last row stays zero:
    `padded` hands that buffer to Embree as it is instead of copying the array (one table, not two)."""
    return np.zeros((n + 1, 3), dtype)[:-1]


def padded(array: np.ndarray, dtype) -> np.ndarray:
    """Return a C-contiguous copy of (n, 3) `array` with one spare row, so Embree may read 16 bytes at the last element;
    or, when `array` is already the leading rows of such a buffer (with_spare_row) of dtype's size, that buffer itself
    (as dtype: the same bits, as the copy's would be for int32 indices >= 0 read as uint32).

    array: (n, 3); returns (n + 1, 3) of dtype, the last row zero.
    """
    owner = array.base
    if (isinstance(owner, np.ndarray) and owner.ndim == 2 and owner.shape == (len(array) + 1, 3)
            and array.shape == (len(array), 3) and owner.flags.c_contiguous and array.flags.c_contiguous
            and owner.dtype.itemsize == array.dtype.itemsize == np.dtype(dtype).itemsize
            and owner.dtype.kind == array.dtype.kind
            and owner.__array_interface__["data"][0] == array.__array_interface__["data"][0]
            and not owner[-1].any()
            and (array.dtype == np.dtype(dtype) or (array.dtype.kind == "i" and np.dtype(dtype).kind == "u"
                                                     and (len(array) == 0 or array.min() >= 0)))):
        return owner.view(dtype)
    out = np.zeros((len(array) + 1, 3), dtype)
    out[:-1] = array
    return out


def _check_buffer(array: np.ndarray, dtype, columns: int) -> None:
    """Refuse an array Embree could not read in place: it must be C-contiguous (n, columns) of `dtype`."""
    if array.dtype != dtype or not array.flags.c_contiguous or array.ndim != 2 or array.shape[1] != columns:
        raise ValueError(f"shared buffers must be C-contiguous (n, {columns}) {np.dtype(dtype).name} arrays")


def _triangle_geometry(library, device: int, vertices: np.ndarray, triangles: np.ndarray, steps=()) -> int:
    """Return a committed triangle geometry reading `vertices` and `triangles` in place (0 if Embree refused them).

    vertices: (v + 1, 3) float32 and triangles: (t + 1, 3) uint32, both from `padded`; steps: for a mesh that
    deforms over the shutter, its vertices at each of its s >= 2 time steps (each like `vertices`), which Embree
    interpolates linearly at each ray's time, in place of `vertices`.
    """
    _check_buffer(vertices, np.float32, 3)
    _check_buffer(triangles, np.uint32, 3)
    library.rtcGetDeviceError(device)  # clears any earlier error
    geometry = library.rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE)
    if not geometry:
        return 0
    # 12-byte rows; the padding row is not an item.
    if len(steps):
        library.rtcSetGeometryTimeStepCount(geometry, len(steps))
    for slot, points in enumerate(steps if len(steps) else [vertices]):
        _check_buffer(points, np.float32, 3)
        library.rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, slot, RTC_FORMAT_FLOAT3,
                                           points.ctypes.data, 0, 12, len(points) - 1)
    library.rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                       triangles.ctypes.data, 0, 12, len(triangles) - 1)
    library.rtcCommitGeometry(geometry)
    if library.rtcGetDeviceError(device) != RTC_ERROR_NONE:
        library.rtcReleaseGeometry(geometry)
        return 0
    return geometry


def attach_triangles(scene, device, vertices: np.ndarray, triangles: np.ndarray) -> Optional[int]:
    """Attach a triangle mesh that reads `vertices` and `triangles` in place; return its geometry ID, or None.

    vertices: (v + 1, 3) float32 C-contiguous, from `padded` (the last row is padding);
    triangles: (t + 1, 3) uint32 C-contiguous, from `padded`.
    Both arrays must outlive the scene. None means nothing was attached: copy the arrays instead.
    """
    handles = scene_handles(scene, device)
    if handles is None:
        return None
    library = embree_library()
    geometry = _triangle_geometry(library, handles.device, vertices, triangles)
    if not geometry:
        return None
    geometry_id = library.rtcAttachGeometry(handles.scene, geometry)
    library.rtcReleaseGeometry(geometry)
    scene.is_committed = 0
    return int(geometry_id)


def _prototype(library, device, vertices: np.ndarray, triangles: np.ndarray, geometry_id: int, vertex_steps=()):
    """A committed Embree scene holding the mesh once as geometry `geometry_id` (an instance's prototype; with
    vertex_steps, a deforming mesh's vertices at its time steps), or None where Embree refused the mesh."""
    geometry = _triangle_geometry(library, device, vertices, triangles, vertex_steps)
    if not geometry:
        return None
    prototype = library.rtcNewScene(device)
    library.rtcSetSceneFlags(prototype, RTC_SCENE_FLAG_ROBUST)
    library.rtcAttachGeometryByID(prototype, geometry, geometry_id)
    library.rtcReleaseGeometry(geometry)
    library.rtcCommitScene(prototype)
    return prototype


def attach_instances(scene, device, vertices: np.ndarray, triangles: np.ndarray, transforms: np.ndarray,
                     geometry_id: int) -> bool:
    """Place one triangle mesh len(transforms) times in an embreex scene, storing the mesh once; return success.

    The mesh goes into a scene of its own (the prototype) as geometry `geometry_id`, which is what
    a hit on any of its instances reports as geomID; one instance array holds all the placements.
    vertices: (v + 1, 3) float32 and triangles: (t + 1, 3) uint32 object-space arrays from `padded`;
    transforms: (k, 12) float32 C-contiguous object-to-world matrices, rows of the 3 x 4 matrix
    [L | t] one after another. All three arrays must outlive the scene. False: nothing was attached.
    """
    handles = scene_handles(scene, device)
    if handles is None:
        return False
    library = embree_library()
    _check_buffer(transforms, np.float32, 12)
    # 1. The prototype: a scene holding the mesh once, built now (Embree wants it committed first).
    prototype = _prototype(library, handles.device, vertices, triangles, geometry_id)
    if not prototype:
        return False
    # 2. One instance array over the shared transforms, attached to the top-level scene.
    placements = library.rtcNewGeometry(handles.device, RTC_GEOMETRY_TYPE_INSTANCE_ARRAY)
    if placements:
        library.rtcSetGeometryInstancedScene(placements, prototype)
        library.rtcSetSharedGeometryBuffer(placements, RTC_BUFFER_TYPE_TRANSFORM, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR,
                                           transforms.ctypes.data, 0, 48, len(transforms))
        library.rtcCommitGeometry(placements)
    # The instance array holds its own reference to the prototype (Embree counts references).
    library.rtcReleaseScene(prototype)
    if not placements or library.rtcGetDeviceError(handles.device) != RTC_ERROR_NONE:
        if placements:
            library.rtcReleaseGeometry(placements)
        return False
    library.rtcAttachGeometry(handles.scene, placements)
    library.rtcReleaseGeometry(placements)
    scene.is_committed = 0
    return True


def attach_motion_instance(scene, device, vertices: np.ndarray, triangles: np.ndarray, steps: np.ndarray,
                           geometry_id: int, vertex_steps=()) -> bool:
    """Place one triangle mesh once in an embreex scene, moving over the shutter; return success.

    As attach_instances, but one instance whose transform Embree interpolates at each ray's time (the packets' time
    field, 0 at the shutter's open, 1 at its close) between len(steps) evenly spaced motion steps: steps (s, 16)
    float32 C-contiguous, each Embree's RTCQuaternionDecomposition (motion.embree_steps). All arrays must outlive
    the scene (Embree copies the steps, but the prototype reads the mesh in place). vertex_steps: a deforming mesh's
    vertices at its own time steps (_triangle_geometry's `steps`), or (). False: nothing was attached.
    """
    handles = scene_handles(scene, device)
    if handles is None:
        return False
    library = embree_library()
    _check_buffer(steps, np.float32, 16)
    prototype = _prototype(library, handles.device, vertices, triangles, geometry_id, vertex_steps)
    if not prototype:
        return False
    instance = library.rtcNewGeometry(handles.device, RTC_GEOMETRY_TYPE_INSTANCE)
    if instance:
        library.rtcSetGeometryInstancedScene(instance, prototype)
        library.rtcSetGeometryTimeStepCount(instance, len(steps))
        for k in range(len(steps)):
            library.rtcSetGeometryTransformQuaternion(instance, k, steps[k].ctypes.data)
        library.rtcCommitGeometry(instance)
    library.rtcReleaseScene(prototype)
    if not instance or library.rtcGetDeviceError(handles.device) != RTC_ERROR_NONE:
        if instance:
            library.rtcReleaseGeometry(instance)
        return False
    library.rtcAttachGeometry(handles.scene, instance)
    library.rtcReleaseGeometry(instance)
    scene.is_committed = 0
    return True


_instancing_cache: list = []


def instancing_supported() -> bool:
    """Whether `attach_instances` can work here: embreex's library is usable and its scene layout the known one."""
    if not _instancing_cache:
        supported = False
        if embree_library() is not None:
            try:
                from embreex import rtcore, rtcore_scene
                device = rtcore.EmbreeDevice()
                supported = scene_handles(rtcore_scene.EmbreeScene(device), device) is not None
            except Exception as error:  # an embreex we do not know: trace copies instead
                log.info("Embree instancing unavailable (%s); instanced meshes will be copied", error)
        _instancing_cache.append(supported)
    return _instancing_cache[0]
