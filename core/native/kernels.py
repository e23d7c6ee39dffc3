"""Compiled kernels: the render loop's arithmetic in C (core/kernels.c), beside the numpy that explains it.

numpy runs one operation at a time over whole arrays. Shading a point takes a few hundred such
operations, so the render loop spends most of its time making passes over memory: on the sample
scenes, four times as long as Embree spends tracing the rays. The kernels in core/kernels.c do the
same steps one sample at a time, with the values in registers. Each kernel is the twin of numpy
code in core/ and computes the same float64 numbers, step for step; tests/test_kernels.py checks
every kernel against its twin and whole renders against the numpy path.

What stays in Python: planning, Embree's queries (through core/intersect.py, as before) and
everything the kernels do not cover. The kernels cover the renders a user makes: every light and
camera type, both shadow methods, the terminator fix, adaptive sampling, instanced meshes. The
numpy path still renders what they do not: the lecture switches, the debug buffers and
unjittered sampling, since those exist to be read and changed. `RenderSettings.kernels = "numpy"`
renders everything on the numpy path, to compare.

The library is compiled for the machine that builds Primer (`make kernels`, tools/build_kernels.py);
where it is missing or does not load (another platform, no compiler), Primer says so in the log
once and renders on the numpy path: the same image, more slowly. ctypes releases Python's GIL
while a kernel runs, so the render's threads run kernels on every core at once.
"""
from __future__ import annotations

import ctypes
import logging
import math
import os
import platform
import sys
from typing import NamedTuple, Optional

import numpy as np

from ..scene.scene import AreaLight, PointLight, SpotLight, SunLight

log = logging.getLogger(__name__)

ABI = 8
KERNELS = ("compiled", "numpy")

# Shadow rays prepared per Embree query: lights are taken in groups of at most this many rays
# (44 bytes each), so the buffers stay near 10 MB however many lights a scene has.
RAY_BUDGET = 1 << 18


def library_path() -> str:
    """Return where this platform's compiled library lives: core/_kernels-<platform>-<machine>.<ext>."""
    extension = {"win32": ".dll", "darwin": ".dylib"}.get(sys.platform, ".so")
    tag = f"{sys.platform}-{platform.machine().lower()}"
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), f"_kernels-{tag}{extension}")


# ---------------------------------------------------------------------------
# The C records (all doubles, so the layout is the same on every compiler)
# ---------------------------------------------------------------------------

def _record(name: str, fields: list) -> type:
    """Return a ctypes Structure of doubles; a field given as (name, k) is an array of k doubles."""
    spec = [(field, ctypes.c_double) if isinstance(field, str) else (field[0], ctypes.c_double * field[1])
            for field in fields]
    return type(name, (ctypes.Structure,), {"_fields_": spec})


CameraRecord = _record("CameraRecord", [
    "orthographic", "left", "right", "bottom", "top", "clip_start", "clip_end", ("rotation", 9), ("eye", 3),
    "renormalize"])

LightRecord = _record("LightRecord", [
    "kind", "samples", "dimension", "delta", ("color", 3), ("position", 3), ("direction", 3),
    ("axis_u", 3), ("axis_v", 3), "ellipse", "area", "radiance", "power", "radius", "soft_falloff",
    "strength", ("sun_t", 3), ("sun_b", 3), "sun_cos_max", "spot_frame", ("spot_inverse", 9),
    "spot_cos_half", "spot_blend_width", "spread_narrow", "spread_tan_half", "spread_norm"])

ShadowSettings = _record("ShadowSettings", ["robust", "epsilon", "terminator_fix", "terminator_offset", "seed"])

LIGHT_POINT, LIGHT_SPOT, LIGHT_SUN, LIGHT_AREA = 0, 1, 2, 3


# ---------------------------------------------------------------------------
# Loading the library
# ---------------------------------------------------------------------------

_cache: dict = {}


def library() -> Optional[ctypes.CDLL]:
    """Return the loaded kernels, or None (the reason is logged once and kept in `unavailable_reason`)."""
    if "library" in _cache:
        return _cache["library"]
    path, lib, reason = library_path(), None, ""
    if not os.path.exists(path):
        reason = f"{os.path.basename(path)} is not built for this platform (make kernels)"
    else:
        try:
            lib = _declare(ctypes.CDLL(path))
            sizes = (lib.primer_light_record_size(), lib.primer_camera_record_size(),
                     lib.primer_shadow_settings_size())
            expected = (ctypes.sizeof(LightRecord), ctypes.sizeof(CameraRecord), ctypes.sizeof(ShadowSettings))
            if lib.primer_kernels_abi() != ABI or sizes != expected:
                reason, lib = f"{os.path.basename(path)} was built from another kernels.c (make kernels)", None
        except (OSError, AttributeError) as error:
            reason, lib = f"{os.path.basename(path)} does not load ({error})", None
    if lib is None:
        log.info("Compiled kernels unavailable: %s; rendering on the numpy path", reason)
    _cache["library"], _cache["reason"] = lib, reason
    return lib


def available() -> bool:
    """Whether the compiled kernels loaded."""
    return library() is not None


def unavailable_reason() -> str:
    """Why the kernels did not load ('' when they did)."""
    library()
    return _cache["reason"]


def _declare(lib: ctypes.CDLL) -> ctypes.CDLL:
    """Give the kernels their C signatures: pointers as void *, counts as int64."""
    p, i64 = ctypes.c_void_p, ctypes.c_int64
    signatures = {
        "primer_kernels_abi": (i64, []),
        "primer_light_record_size": (i64, []),
        "primer_camera_record_size": (i64, []),
        "primer_shadow_settings_size": (i64, []),
        "primer_sample_2d": (None, [i64, p, p, i64, i64, p]),
        "primer_camera_rays": (None, [p, i64, i64, i64, p, p, i64, i64, p, p, p]),
        "primer_copied_triangles": (None, [p, i64, p, p, p, p, p, p, p, p, p, p, p, p]),
        "primer_surfaces": (None, [p, i64, p, p, p, p, p, p, p, p, p, p, p, p, p]),
        "primer_samples": (None, [p, i64, i64, i64, p, p, i64, i64, p, p, p, p, p, p, i64] + [p] * 7),
        "primer_shadow_rays": (i64, [p, p, i64, i64, p, p, p, p, p, p, p, p, i64, i64, p, p, p, p, p, p]),
        "primer_add_light": (None, [p, i64, p, p, p, p, p]),
        "primer_film": (i64, [i64, i64, p, p, p, i64, p, p, p, p, p, p]),
        "primer_occluded": (None, [p, p, i64, p, p, p, p]),
        "primer_add_pixels": (None, [i64, p, i64, p, p, p, p, p, p, p, p, p, p]),
        "primer_resolve": (None, [i64, p, p, p]),
        "primer_face_normals": (None, [i64, p, p, p, p]),
        "primer_turn_normals": (None, [i64, p, p, p, p, p]),
        "primer_shade": (i64, [p, p, i64, i64, p, p, p, p, p, p, p, p, i64, p, p, p, p]),
        "primer_primary": (i64, [p, i64, i64, i64, p, p, i64, i64, p, p, p, p, p, p, p, p, p, p, p, p]),
        "primer_unconverged": (i64, [i64, i64, i64, i64, p, p, p, p, p, i64, ctypes.c_double, i64] + [p] * 8),
        "primer_ascending": (i64, [p, i64, i64]),
        "primer_intersect": (None, [p, p, i64, p, p, p, p, p, p, p, p, p]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype, function.argtypes = restype, argtypes
    return lib


def _ptr(array: Optional[np.ndarray], dtype) -> Optional[int]:
    """Return the address of a C-contiguous array of `dtype` (None for None); refuse anything else."""
    if array is None:
        return None
    if array.dtype != dtype or not array.flags.c_contiguous:
        raise TypeError(f"kernel argument must be C-contiguous {np.dtype(dtype)}, got {array.dtype} "
                        f"{'contiguous' if array.flags.c_contiguous else 'strided'}")
    return array.ctypes.data


def _c(array: np.ndarray, dtype) -> np.ndarray:
    """Return `array` as a C-contiguous array of `dtype` (no copy when it already is one)."""
    return np.ascontiguousarray(array, dtype=dtype)


# ---------------------------------------------------------------------------
# Records of the scene, made once per render
# ---------------------------------------------------------------------------

def camera_record(camera, width: int, height: int, pixel_aspect: tuple, origin: np.ndarray):
    """Return the CameraRecord of a PERSP or ORTHO camera (None for others: their rays come from numpy).

    origin: (3,) float64 the geometry's origin, subtracted from the camera's position.
    """
    from ..camera import camera as camera_
    if camera.type not in ("PERSP", "ORTHO"):
        return None
    record = CameraRecord()
    record.orthographic = 1.0 if camera.type == "ORTHO" else 0.0
    record.left, record.right, record.bottom, record.top = camera_.viewplane(camera, width, height, pixel_aspect)
    record.clip_start, record.clip_end = camera.clip_start, camera.clip_end
    rotation = np.asarray(camera.matrix_world, np.float64)[:3, :3]
    record.rotation[:] = rotation.ravel().tolist()
    record.eye[:] = (np.asarray(camera.matrix_world, np.float64)[:3, 3] - origin).tolist()
    record.renormalize = 0.0 if camera_._is_rotation(rotation) else 1.0
    return record


def light_record(light, index: int, light_samples: int) -> LightRecord:
    """Return the LightRecord of a camera-relative light: all of core/lights.py's per-light constants."""
    from ..lights import lights as lights_
    record = LightRecord()
    delta = lights_.is_delta(light)
    record.delta = 1.0 if delta else 0.0
    record.samples = 1 if delta else max(1, int(light_samples))
    record.dimension = 16 + 4 * index
    record.color[:] = np.asarray(light.color, np.float64)[:3].tolist()
    if isinstance(light, SunLight):
        travel = np.asarray(light.direction, np.float64)
        axis = -travel / np.linalg.norm(travel)
        record.kind = LIGHT_SUN
        record.direction[:] = axis.tolist()
        if delta:
            record.strength = float(light.strength)
        else:
            record.strength = lights_.sun_disk_strength(light)
            t, b = lights_.orthonormal_frame(axis[None, :])
            record.sun_t[:], record.sun_b[:] = t[0].tolist(), b[0].tolist()
            record.sun_cos_max = math.cos(0.5 * light.angle)
    elif isinstance(light, (PointLight, SpotLight)):
        record.kind = LIGHT_SPOT if isinstance(light, SpotLight) else LIGHT_POINT
        record.position[:] = np.asarray(light.position, np.float64).tolist()
        record.power, record.radius = float(light.power), float(light.radius)
        record.soft_falloff = 1.0 if light.soft_falloff else 0.0
        if light.radius > 0.0:
            record.radiance = lights_.sphere_radiance(light.power, light.radius)
        if isinstance(light, SpotLight):
            if light.frame is None:
                record.direction[:] = np.asarray(light.direction, np.float64).tolist()
            else:
                record.spot_frame = 1.0
                record.spot_inverse[:] = lights_.spot_inverse_frame(light).ravel().tolist()
            record.spot_cos_half, record.spot_blend_width = lights_.spot_cone(light)
    elif isinstance(light, AreaLight):
        record.kind = LIGHT_AREA
        record.position[:] = np.asarray(light.center, np.float64).tolist()
        record.direction[:] = np.asarray(light.direction, np.float64).tolist()
        record.axis_u[:] = np.asarray(light.axis_u, np.float64).tolist()
        record.axis_v[:] = np.asarray(light.axis_v, np.float64).tolist()
        record.ellipse = 1.0 if light.shape in ("DISK", "ELLIPSE") else 0.0
        record.area = lights_.area_light_area(light)
        record.radiance = lights_.area_radiance(light, record.area)
        if light.spread < math.pi:
            record.spread_narrow = 1.0
            record.spread_tan_half, record.spread_norm = lights_.spread_constants(light.spread)
    else:
        raise TypeError(f"unknown light type {type(light).__name__}")
    return record


def shadow_settings(settings) -> ShadowSettings:
    """Return the ShadowSettings record of RenderSettings."""
    record = ShadowSettings()
    record.robust = 1.0 if settings.shadow_method == "robust" else 0.0
    record.epsilon = float(settings.epsilon)
    record.terminator_fix = 1.0 if settings.terminator_fix else 0.0
    record.terminator_offset = float(settings.terminator_offset)
    record.seed = float(settings.seed)
    return record


def why_not(settings) -> str:
    """Return why a render with `settings` takes the numpy path ('' when the kernels apply)."""
    if settings.kernels != "compiled":
        return "kernels set to numpy"
    if not available():
        return unavailable_reason()
    if not settings.is_lecture_default():
        return "a lecture switch is off its default"
    if settings.aux:
        return "debug buffers are requested"
    if not settings.jitter:
        return "jitter is off"
    if abs(settings.seed) >= 2 ** 53:
        return "the seed does not fit a double"
    return ""


# ---------------------------------------------------------------------------
# One wrapper per kernel: arrays checked, outputs allocated
# ---------------------------------------------------------------------------

def sample_2d(seed: int, pixel: np.ndarray, index: np.ndarray, dimension: int) -> np.ndarray:
    """sampling.sample_2d in C: pixel, index (n,) int64 -> (n, 2) float64, bit for bit the same."""
    pixel, index = _c(pixel, np.int64), _c(index, np.int64)
    out = np.empty((len(pixel), 2))
    library().primer_sample_2d(int(seed), _ptr(pixel, np.int64), _ptr(index, np.int64), int(dimension),
                               len(pixel), _ptr(out, np.float64))
    return out


def camera_rays(record, seed: int, width: int, height: int, pixels: np.ndarray, first: np.ndarray, spp: int):
    """Camera rays of spp samples in each pixel, camera-relative (render._render_chunk steps 1-2).

    pixels, first: (p,) int64 -> origins, directions (p spp, 3) float64, t_max (p spp,) float64
    """
    n = len(pixels) * spp
    origins, directions, t_max = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
    library().primer_camera_rays(ctypes.byref(record), int(seed), int(width), int(height),
                                 _ptr(pixels, np.int64), _ptr(first, np.int64), len(pixels), int(spp),
                                 _ptr(origins, np.float64), _ptr(directions, np.float64), _ptr(t_max, np.float64))
    return origins, directions, t_max


class PrimaryHits(NamedTuple):
    """The camera rays of a chunk that hit, with Embree's answers (kernels.primary).

    sample: (h,) int64 the hit's row among the chunk's samples; origins, directions (h, 3) float64
    its camera-relative ray; t (h,) float64; prim (h,) int64; geometry (h,) int32 Embree's geomID;
    u, v (h,) float64; instance (h,) int64 the placement of an instanced mesh hit (Embree's
    instPrimID; -1 on copied triangles); embree_seconds: the time inside Embree.
    """

    sample: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    t: np.ndarray
    prim: np.ndarray
    geometry: np.ndarray
    u: np.ndarray
    v: np.ndarray
    instance: np.ndarray
    embree_seconds: float


def primary(record, seed: int, width: int, height: int, pixels: np.ndarray, first: np.ndarray, spp: int,
            packets: "EmbreePackets") -> PrimaryHits:
    """camera_rays, Tracer.intersect and the gather of the hits in one C pass (no arrays of rays).

    pixels, first: (p,) int64, as camera_rays takes them.
    """
    if len(first) != len(pixels):
        raise ValueError("primary: one first-sample count per pixel")
    n = len(pixels) * spp
    sample, origins, directions = np.empty(n, np.int64), np.empty((n, 3)), np.empty((n, 3))
    t, prim, geometry, u, v = np.empty(n), np.empty(n, np.int64), np.empty(n, np.int32), np.empty(n), np.empty(n)
    instance = np.empty(n, np.int64)
    seconds = np.zeros(1)
    m = library().primer_primary(ctypes.byref(record), int(seed), int(width), int(height), _ptr(pixels, np.int64),
                                 _ptr(first, np.int64), len(pixels), int(spp), packets.intersect8, packets.scene,
                                 _ptr(sample, np.int64), _ptr(origins, np.float64), _ptr(directions, np.float64),
                                 _ptr(t, np.float64), _ptr(prim, np.int64), _ptr(geometry, np.int32),
                                 _ptr(u, np.float64), _ptr(v, np.float64), _ptr(instance, np.int64),
                                 _ptr(seconds, np.float64))
    return PrimaryHits(sample[:m], origins[:m], directions[:m], t[:m], prim[:m], geometry[:m], u[:m], v[:m],
                       instance[:m], float(seconds[0]))


class HitTriangles(NamedTuple):
    """What shading needs of the m hit triangles, one row per hit.

    corners: (m, 3, 3) float64; Ng: (m, 3) float64 unit front-side normals; albedo: (m, 3) float64;
    smooth: (m,) uint8; normals: (m, 3, 3) float64 world corner normals (rows of flat hits unused)
    """

    corners: np.ndarray
    Ng: np.ndarray
    albedo: np.ndarray
    smooth: np.ndarray
    normals: np.ndarray


class CopiedArrays(NamedTuple):
    """WorldGeometry's copied-triangle arrays as the kernels read them (made once per render)."""

    vertices: np.ndarray       # (v, 3) float32
    triangles: np.ndarray      # (t, 3) int32
    face_normals: np.ndarray   # (t, 3) float64
    material: np.ndarray       # (t,) int32
    albedo: np.ndarray         # (a, 3) float64
    smooth_index: Optional[np.ndarray]     # (t,) int32, None when nothing is smooth
    corner_normals: np.ndarray             # (s, 3, 3) float32


def copied_arrays(geometry) -> CopiedArrays:
    """Return the geometry's copied-triangle arrays in the kernels' dtypes (no copy where they already are)."""
    smooth = len(geometry.corner_normals) > 0
    return CopiedArrays(_c(geometry.vertices, np.float32), _c(geometry.triangles, np.int32),
                        _c(geometry.face_normals, np.float64), _c(geometry.material, np.int32),
                        _c(geometry.albedo, np.float64), _c(geometry.smooth_index, np.int32) if smooth else None,
                        _c(geometry.corner_normals, np.float32) if smooth else np.zeros((1, 3, 3), np.float32))


def copied_triangles(arrays: CopiedArrays, prim: np.ndarray) -> HitTriangles:
    """WorldGeometry.triangle_data for copied triangles, plus each hit's albedo: prim (m,) int64."""
    prim = _c(prim, np.int64)
    m = len(prim)
    out = HitTriangles(np.empty((m, 3, 3)), np.empty((m, 3)), np.empty((m, 3)), np.empty(m, np.uint8),
                       np.empty((m, 3, 3)))
    library().primer_copied_triangles(
        _ptr(prim, np.int64), m, _ptr(arrays.vertices, np.float32), _ptr(arrays.triangles, np.int32),
        _ptr(arrays.face_normals, np.float64), _ptr(arrays.material, np.int32), _ptr(arrays.albedo, np.float64),
        _ptr(arrays.smooth_index, np.int32), _ptr(arrays.corner_normals, np.float32),
        _ptr(out.corners, np.float64), _ptr(out.Ng, np.float64), _ptr(out.albedo, np.float64),
        _ptr(out.smooth, np.uint8), _ptr(out.normals, np.float64))
    return out


def any_triangles(geometry, prim: np.ndarray, smooth: bool) -> HitTriangles:
    """HitTriangles of any triangles, copied or instanced, from WorldGeometry.triangle_data (numpy)."""
    data = geometry.triangle_data(prim, smooth=smooth)
    normals = np.zeros((len(prim), 3, 3))
    normals[data.smooth] = data.corner_normals
    return HitTriangles(_c(data.corners, np.float64), _c(data.Ng, np.float64),
                        _c(geometry.albedo[data.material], np.float64), data.smooth.astype(np.uint8), normals)


class Surfaces(NamedTuple):
    """The kernels' surface records of m hits (shading.Surface, reduced to what shading reads).

    I, N, Ng: (m, 3) float64 (Ng facing the viewer); offset: (m,) float64 robust offsets;
    lifted: (m, 3) float64 terminator-fix points of smooth hits, or None
    """

    I: np.ndarray
    N: np.ndarray
    Ng: np.ndarray
    offset: np.ndarray
    lifted: Optional[np.ndarray]


def surfaces(triangles: HitTriangles, ray: np.ndarray, origins: np.ndarray, directions: np.ndarray,
             t: np.ndarray, u: np.ndarray, v: np.ndarray, lift: bool) -> Surfaces:
    """shading.surface_at_hits (and shadows.error_bound, terminator_points) in C.

    ray: (m,) int64 row of each hit in origins, directions (n, 3) float64; t, u, v: (m,) float64.
    The triangles' Ng is turned to face the viewer in place (and returned as Surfaces.Ng).
    """
    m = len(ray)
    ray, t, u, v = _c(ray, np.int64), _c(t, np.float64), _c(u, np.float64), _c(v, np.float64)
    I, N, offset = np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
    lifted = np.empty((m, 3)) if lift else None
    library().primer_surfaces(
        _ptr(ray, np.int64), m, _ptr(origins, np.float64), _ptr(directions, np.float64),
        _ptr(t, np.float64), _ptr(u, np.float64), _ptr(v, np.float64), _ptr(triangles.corners, np.float64),
        _ptr(triangles.Ng, np.float64), _ptr(triangles.smooth, np.uint8), _ptr(triangles.normals, np.float64),
        _ptr(I, np.float64), _ptr(N, np.float64), _ptr(offset, np.float64), _ptr(lifted, np.float64))
    return Surfaces(I, N, triangles.Ng, offset, lifted)


class CopiedTables(ctypes.Structure):
    """The addresses of CopiedArrays' tables, as core/kernels.c's CopiedTables reads them."""

    _fields_ = [(name, ctypes.c_void_p) for name in CopiedArrays._fields]


def copied_tables(arrays: CopiedArrays) -> CopiedTables:
    """Return the addresses of `arrays` (which must outlive every kernel call that reads them)."""
    dtypes = (np.float32, np.int32, np.float64, np.int32, np.float64, np.int32, np.float32)
    return CopiedTables(*[_ptr(array, dtype) for array, dtype in zip(arrays, dtypes)])


class ChunkSums(NamedTuple):
    """samples' answer: a chunk's per-pixel sums (as film makes them) and what it cost.

    rgba (p, 4), squares (p, 2) float64 (zeros unless asked for); hits (p,) int64; shadow_rays: traced;
    intersect_seconds, occluded_seconds: inside Embree's queries; shading_seconds: surfaces and shadow
    rays, the occlusion queries included
    """

    rgba: np.ndarray
    squares: np.ndarray
    hits: np.ndarray
    shadow_rays: int
    intersect_seconds: float
    occluded_seconds: float
    shading_seconds: float


def samples(camera, seed: int, width: int, height: int, pixels: np.ndarray, first: np.ndarray, spp: int,
            packets: "EmbreePackets", tables: CopiedTables, settings_record, records, background: np.ndarray,
            luminance: np.ndarray, want_squares: bool) -> ChunkSums:
    """primary, copied_triangles, surfaces, shade and film in one C pass, a block of camera samples at a time:
    a chunk's samples become its pixels' sums with no per-sample or per-hit arrays in between.

    pixels, first: (p,) int64 as primary takes them; tables: copied_tables of the scene's copied
    triangles; records: every light's LightRecord; background (4,), luminance (3,) float64 as film.
    """
    if len(first) != len(pixels):
        raise ValueError("samples: one first-sample count per pixel")
    p = len(pixels)
    pixels, first = _c(pixels, np.int64), _c(first, np.int64)
    background, luminance = _c(background, np.float64), _c(luminance, np.float64)
    rgba, squares, hits = np.empty((p, 4)), np.zeros((p, 2)), np.empty(p, np.int64)
    counts, seconds = np.zeros(1, np.int64), np.zeros(3)
    library().primer_samples(
        ctypes.byref(camera), int(seed), int(width), int(height), _ptr(pixels, np.int64), _ptr(first, np.int64), p,
        int(spp), packets.intersect8, packets.occluded8, packets.scene, ctypes.byref(tables),
        ctypes.byref(settings_record), records, len(records), _ptr(background, np.float64),
        _ptr(luminance, np.float64), _ptr(rgba, np.float64), _ptr(squares if want_squares else None, np.float64),
        _ptr(hits, np.int64), _ptr(counts, np.int64), _ptr(seconds, np.float64))
    return ChunkSums(rgba, squares, hits, int(counts[0]), float(seconds[0]), float(seconds[1]), float(seconds[2]))


class ShadowBatch(NamedTuple):
    """Shadow rays of a group of lights, compacted to those that can carry light.

    origins, directions: (r, 3) float32; t_max: (r,) float32; owner: (r,) int32 hit;
    light: (r,) int32 light index; weight: (r,) float64 what the ray adds to E when unoccluded
    """

    origins: np.ndarray
    directions: np.ndarray
    t_max: np.ndarray
    owner: np.ndarray
    light: np.ndarray
    weight: np.ndarray


def light_groups(records, hits: int) -> list:
    """Split lights into runs [l0, l1) whose shadow rays for `hits` hits fit RAY_BUDGET (at least one light each)."""
    groups, start, rays = [], 0, 0
    for index, record in enumerate(records):
        need = hits * int(record.samples)
        if index > start and rays + need > RAY_BUDGET:
            groups.append((start, index))
            start, rays = index, 0
        rays += need
    if start < len(records):
        groups.append((start, len(records)))
    return groups


def shadow_rays(settings_record, records, l0: int, l1: int, surface: Surfaces, smooth: np.ndarray,
                pixel: np.ndarray, sample: np.ndarray) -> ShadowBatch:
    """shading.direct_light's steps 1-3 for lights l0 .. l1 - 1 (core/lights.py, core/shadows.py) in C.

    smooth: (m,) uint8; pixel, sample: (m,) int64 each hit's random-number keys.
    """
    m = len(surface.I)
    capacity = m * sum(int(records[l].samples) for l in range(l0, l1))
    out = ShadowBatch(np.empty((capacity, 3), np.float32), np.empty((capacity, 3), np.float32),
                      np.empty(capacity, np.float32), np.empty(capacity, np.int32), np.empty(capacity, np.int32),
                      np.empty(capacity))
    pixel, sample = _c(pixel, np.int64), _c(sample, np.int64)
    count = library().primer_shadow_rays(
        ctypes.byref(settings_record), records, l0, l1, _ptr(surface.I, np.float64), _ptr(surface.N, np.float64),
        _ptr(surface.Ng, np.float64), _ptr(surface.offset, np.float64), _ptr(smooth, np.uint8),
        _ptr(surface.lifted, np.float64), _ptr(pixel, np.int64), _ptr(sample, np.int64), m, capacity,
        _ptr(out.origins, np.float32), _ptr(out.directions, np.float32), _ptr(out.t_max, np.float32),
        _ptr(out.owner, np.int32), _ptr(out.light, np.int32), _ptr(out.weight, np.float64))
    if count < 0:
        raise RuntimeError("shadow-ray buffer too small")     # cannot happen: capacity is the most rays possible
    return ShadowBatch(*(array[:count] for array in out))


def shade(settings_record, records, l0: int, l1: int, surface: Surfaces, smooth: np.ndarray, pixel: np.ndarray,
          sample: np.ndarray, packets: "EmbreePackets", E: np.ndarray) -> tuple[int, float]:
    """shadow_rays, Tracer.occluded and add_light in one C pass, block by block (no ray arrays):
    E (m, 3) float64 is added to; returns (shadow rays traced, seconds inside Embree).

    smooth: (m,) uint8; pixel, sample: (m,) int64 each hit's random-number keys.
    """
    m = len(surface.I)
    pixel, sample = _c(pixel, np.int64), _c(sample, np.int64)
    seconds = np.zeros(1)
    rays = library().primer_shade(
        ctypes.byref(settings_record), records, l0, l1, _ptr(surface.I, np.float64), _ptr(surface.N, np.float64),
        _ptr(surface.Ng, np.float64), _ptr(surface.offset, np.float64), _ptr(smooth, np.uint8),
        _ptr(surface.lifted, np.float64), _ptr(pixel, np.int64), _ptr(sample, np.int64), m,
        packets.occluded8, packets.scene, _ptr(E, np.float64), _ptr(seconds, np.float64))
    return int(rays), float(seconds[0])


def add_light(records, batch: ShadowBatch, blocked: np.ndarray, E: np.ndarray) -> None:
    """E[owner] += weight * colour for every unblocked ray (shading.direct_light step 4), in place.

    blocked: (r,) bool Embree's answers; E: (m, 3) float64.
    """
    blocked = _c(blocked, np.bool_).view(np.uint8)
    library().primer_add_light(records, len(batch.weight), _ptr(batch.owner, np.int32), _ptr(batch.light, np.int32),
                               _ptr(batch.weight, np.float64), _ptr(blocked, np.uint8), _ptr(E, np.float64))


def film(p: int, spp: int, valid: Optional[np.ndarray], background: np.ndarray, hit_sample: np.ndarray,
         albedo: np.ndarray, E: np.ndarray, luminance: np.ndarray, want_squares: bool):
    """The box filter's per-pixel sums of p pixels' spp samples (render._render_chunk step 5) in C.

    valid: (p spp,) bool camera rays traced, or None; background: (4,) RGBA of a traced miss;
    hit_sample: (m,) int64 the hits' sample rows, ascending; albedo, E: (m, 3) float64.
    -> rgba (p, 4) float64, squares (p, 2) float64 (zeros unless want_squares), hits (p,) int64
    """
    rgba, squares, hits = np.empty((p, 4)), np.zeros((p, 2)), np.empty(p, np.int64)
    valid_bytes = None if valid is None else _c(valid, np.bool_).view(np.uint8)
    if valid_bytes is not None and len(valid_bytes) != p * spp:
        raise ValueError("film: valid must have one entry per sample")
    # (Arrays the C code reads are held in names for the whole call: a converted copy must live.)
    hit_sample, background, luminance = _c(hit_sample, np.int64), _c(background, np.float64), _c(luminance, np.float64)
    status = library().primer_film(p, spp, _ptr(valid_bytes, np.uint8), _ptr(background, np.float64),
                                   _ptr(hit_sample, np.int64), len(hit_sample), _ptr(albedo, np.float64),
                                   _ptr(E, np.float64), _ptr(luminance, np.float64),
                                   _ptr(rgba, np.float64), _ptr(squares if want_squares else None, np.float64),
                                   _ptr(hits, np.int64))
    if status != 0:
        raise ValueError("film: the hits' sample rows must be ascending and within the chunk")
    return rgba, squares, hits


class NoiseEstimates(NamedTuple):
    """What the noise test between passes reads of each pixel, kept up to date as chunks add their
    samples (add_pixels), so that the test need not work it out for every pixel, alone, between passes.

    error: (H W,) float64 adaptive.relative_noise of each pixel (inf before it has 2 samples)
    mean:  (H W,) float64 its mean luminance (adaptive.edge_contrast's; 0 before its first sample)
    """

    error: np.ndarray
    mean: np.ndarray

    @classmethod
    def empty(cls, size: int) -> "NoiseEstimates":
        """The estimates of `size` pixels without samples."""
        return cls(np.full(size, np.inf), np.zeros(size))


def add_pixels(pixels: np.ndarray, spp: int, rgba: np.ndarray, squares: np.ndarray, hits: np.ndarray, noise,
               hits_sum: np.ndarray, estimates: Optional[NoiseEstimates] = None) -> None:
    """Add a chunk's per-pixel sums to the render's, in place: noise (adaptive.PixelNoise over the
    image) and hits_sum (H W,) int64, and renew the pixels' `estimates` where given. pixels (p,)
    int64 distinct; rgba (p, 4), squares (p, 2) float64; hits (p,) int64. Called by the thread that
    rendered the chunk (render.render's store)."""
    from ..film import adaptive
    pixels = _c(pixels, np.int64)
    weights = _c(adaptive.LUMINANCE, np.float64)
    kept = estimates if estimates is not None else NoiseEstimates(None, None)
    library().primer_add_pixels(len(pixels), _ptr(pixels, np.int64), int(spp), _ptr(rgba, np.float64),
                                _ptr(squares, np.float64), _ptr(hits, np.int64), _ptr(noise.total, np.float64),
                                _ptr(noise.squares, np.float64), _ptr(noise.count, np.int64),
                                _ptr(hits_sum, np.int64), _ptr(weights, np.float64), _ptr(kept.error, np.float64),
                                _ptr(kept.mean, np.float64))


def resolve(total: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Each pixel's mean over max(count, 1) samples, as render.render's numpy box filter divides:
    total (n, 4) float64, count (n,) int64 -> (n, 4) float32, in one pass."""
    total, count = _c(total, np.float64), _c(count, np.int64)
    out = np.empty((len(count), 4), np.float32)
    library().primer_resolve(len(count), _ptr(total, np.float64), _ptr(count, np.int64), _ptr(out, np.float32))
    return out


def unconverged(pixels: np.ndarray, noise, threshold: float, width: int, height: int, first: int = 0,
                pool=None, bands: int = 1, estimates: Optional[NoiseEstimates] = None) -> np.ndarray:
    """adaptive.unconverged in C: the pixels of `pixels` (sorted, (p,) int64) that need another pass.

    noise: adaptive.PixelNoise over the whole image. One pass over the image instead of numpy's
    twenty or so. It runs between passes, while the render's threads wait, so with a `pool` (a
    concurrent.futures executor) it is cut into `bands` bands of rows decided at once: the same
    answer, band after band. With `estimates` kept by add_pixels, it reads each pixel's noise and
    mean from them instead of working them out again.
    """
    from ..film import adaptive
    size = width * height
    pixels = _c(pixels, np.int64)
    if not library().primer_ascending(_ptr(pixels, np.int64), len(pixels), size):
        raise ValueError("unconverged: pixels must be distinct flat indices of the image, ascending")
    weights = _c(adaptive.LUMINANCE, np.float64)
    known = estimates if estimates is not None else NoiseEstimates(None, None)
    bands = max(1, min(int(bands), height)) if pool is not None else 1
    edges = [height * b // bands for b in range(bands + 1)]
    wanted = np.empty(len(pixels), np.int64)      # each band writes into its own pixels' rows

    def band(rows: tuple) -> np.ndarray:
        """The wanted pixels of rows y0 .. y1 - 1, with scratch for their window (y1 - y0 + 4 rows)."""
        y0, y1 = rows
        k0, k1 = np.searchsorted(pixels, (y0 * width, y1 * width))
        window = (min(height, y1 + 2) - max(0, y0 - 2)) * width
        error, mean = np.empty(window), np.empty(window)
        noisy, grown, row = np.empty(window, np.uint8), np.empty(window, np.uint8), np.empty(width)
        mine = wanted[k0:k1]
        count = library().primer_unconverged(
            width, height, y0, y1, _ptr(noise.total, np.float64), _ptr(noise.squares, np.float64),
            _ptr(noise.count, np.int64), _ptr(weights, np.float64), _ptr(pixels, np.int64), len(pixels),
            float(threshold), int(first), _ptr(known.error, np.float64), _ptr(known.mean, np.float64),
            _ptr(error, np.float64), _ptr(mean, np.float64), _ptr(noisy, np.uint8), _ptr(grown, np.uint8),
            _ptr(row, np.float64), _ptr(mine, np.int64))
        return mine[:count]

    rows = list(zip(edges[:-1], edges[1:]))
    if len(rows) == 1:
        return band(rows[0])
    return np.concatenate(list(pool.map(band, rows)))


# ---------------------------------------------------------------------------
# Embree's queries in packets of 8 rays (core/intersect.py's Tracer)
# ---------------------------------------------------------------------------

class EmbreePackets(NamedTuple):
    """What core/kernels.c needs to ask one Embree scene about rays 16 at a time: addresses.

    scene: the RTCScene; occluded8, intersect8: Embree's rtcOccluded8 and rtcIntersect8.
    """

    scene: int
    occluded8: int
    intersect8: int


def embree_packets(scene, device) -> Optional[EmbreePackets]:
    """Return the packet queries of an embreex scene made on `device`, or None where they cannot be had.

    They need the kernels and the very Embree library embreex loaded (core/embree_buffers.py finds it
    and reads the scene's handle); otherwise the Tracer asks embreex one ray at a time.
    """
    from ..geometry import embree_buffers
    if not available():
        return None
    embree = embree_buffers.embree_library()
    handles = embree_buffers.scene_handles(scene, device) if embree is not None else None
    if handles is None:
        return None
    address = lambda function: ctypes.cast(function, ctypes.c_void_p).value
    return EmbreePackets(handles.scene, address(embree.rtcOccluded8), address(embree.rtcIntersect8))


def _check_rays(origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray) -> None:
    """Refuse a ray batch whose arrays disagree in length (the C code would read past one of them)."""
    n = len(origins)
    if origins.shape != (n, 3) or directions.shape != (n, 3) or t_max.shape != (n,):
        raise ValueError(f"rays: origins {origins.shape}, directions {directions.shape}, t_max {t_max.shape}")


def occluded(packets: EmbreePackets, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray) -> np.ndarray:
    """Whether anything lies on each ray within (0, t_max), asked 8 rays at a time: (n,) bool.

    origins, directions: (n, 3) float32; t_max: (n,) float32.
    """
    n = len(origins)
    _check_rays(origins, directions, t_max)
    blocked = np.empty(n, np.bool_)
    library().primer_occluded(packets.occluded8, packets.scene, n, _ptr(origins, np.float32),
                              _ptr(directions, np.float32), _ptr(t_max, np.float32), blocked.ctypes.data)
    return blocked


def intersect(packets: EmbreePackets, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray):
    """The nearest hit in (0, t_max) of each ray, asked 8 rays at a time.

    origins, directions: (n, 3) float64; t_max: (n,) float64, rounded to Embree's float32 as the
    packets are filled (as intersect._f32_rays would) -> t (n,) float64 (inf where missed),
    prim (n,) int64 (-1 where missed), geometry (n,) int32 Embree's geomID (-1 where missed),
    u, v (n,) float64 (0 where missed), instance (n,) int64 the placement of an instanced mesh hit
    (Embree's instPrimID; -1 on copied triangles and misses)
    """
    n = len(origins)
    _check_rays(origins, directions, t_max)
    t, prim, geometry, u, v = (np.empty(n), np.empty(n, np.int64), np.empty(n, np.int32), np.empty(n),
                               np.empty(n))
    instance = np.empty(n, np.int64)
    library().primer_intersect(packets.intersect8, packets.scene, n, _ptr(origins, np.float64),
                               _ptr(directions, np.float64), _ptr(t_max, np.float64), _ptr(t, np.float64),
                               _ptr(prim, np.int64), _ptr(geometry, np.int32), _ptr(u, np.float64),
                               _ptr(v, np.float64), _ptr(instance, np.int64))
    return t, prim, geometry, u, v, instance


# ---------------------------------------------------------------------------
# Placing copies (core/geometry.py)
# ---------------------------------------------------------------------------

def face_normals(vertices: np.ndarray, triangles: np.ndarray):
    """normals.face_normals in one pass: vertices (v, 3) float64, triangles (t, 3) int64 (in range)
    -> normals.FaceNormals of (t, 3) unit normals and (t,) areas, the same numbers."""
    from ..geometry.normals import FaceNormals
    vertices, triangles = _c(vertices, np.float64), _c(triangles, np.int64)
    normals, area = np.empty((len(triangles), 3)), np.empty(len(triangles))
    library().primer_face_normals(len(triangles), _ptr(vertices, np.float64), _ptr(triangles, np.int64),
                                  _ptr(normals, np.float64), _ptr(area, np.float64))
    return FaceNormals(normals, area)


def turn_normals(corners: np.ndarray, rows: np.ndarray, inverse: np.ndarray, placement: np.ndarray) -> np.ndarray:
    """normals.safe_normalize(vectors.rows_times_each(corners[rows], inverse[placement])) in one pass:
    corners (c, 3, 3), inverse (p, 3, 3) float64; rows (n,) and placement (n,) int64 -> (n, 3, 3)."""
    corners, inverse = _c(corners, np.float64), _c(inverse, np.float64)
    rows, placement = _c(rows, np.int64), _c(placement, np.int64)
    out = np.empty((len(rows), 3, 3))
    library().primer_turn_normals(len(rows), _ptr(corners, np.float64), _ptr(rows, np.int64),
                                  _ptr(inverse, np.float64), _ptr(placement, np.int64), _ptr(out, np.float64))
    return out
