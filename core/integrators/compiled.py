"""The integrators' compiled twin: a whole chunk of pixels x samples in one C call (chunk.c).

core/render.py renders every chunk through `Compiled.chunk` where it applies (`why_not`), else through
the Python reference (camera -> integrator -> film). Both give the same numbers, within the
tolerance tests/test_compiled.py states. This module packs what the C code reads, once per render:
the camera (core/camera), the triangles (core/geometry/tables.py), the lights (each light's `pack`),
the materials, the shadow settings, Embree's packet queries, and the film's background.
"""
from __future__ import annotations

import ctypes

import numpy as np

from ..camera import camera as camera_
from ..film import adaptive
from ..film.film import ChunkSums
from ..geometry.tables import GeometryTables
from ..lights import LightRecord
from ..materials import MAX_CLOSURES, NODE_PARAMS, PARAMS
from ..materials.graph import graph_tables
from ..native import library
from . import lightpasses
from .base import Context

# The integrators the C code knows (chunk.c INTEGRATOR_*).
COMPILED_INTEGRATORS = {"direct": 0, "path": 1}

ShadowSettings = library.record("ShadowSettings", ["robust", "epsilon", "terminator_fix", "terminator_offset", "seed"],
                                size_function="primer_shadow_settings_size")
MaterialRecord = library.record("MaterialRecord", [
    "n", "program", "graph", ("kind", MAX_CLOSURES), ("weight", 3 * MAX_CLOSURES), ("sample_weight", MAX_CLOSURES),
    ("p", NODE_PARAMS * MAX_CLOSURES), ("emission", 3), ("transparency", 3), "shadow_opaque", "may_pass",
    "graph_emits"],
    size_function="primer_material_record_size")


class LightContext(ctypes.Structure):
    """The emitters' and the world's tables (lights.h LightContext)."""

    _fields_ = [("emitters", ctypes.c_void_p), ("world", ctypes.c_void_p)]


class ChunkParams(ctypes.Structure):
    """Everything a chunk reads (chunk.c ChunkParams)."""

    _fields_ = ([(name, ctypes.c_void_p) for name in ("camera", "geometry", "lights", "materials", "shadows",
                                                      "intersect8", "occluded8", "scene", "light_context", "graphs")]
                + [(name, ctypes.c_double) for name in ("light_count", "integrator", "sampling", "bsdf_rays",
                                                        "emissive", "everywhere", "transparent", "width", "height", "seed")]
                + [("background", ctypes.c_double * 4), ("luminance", ctypes.c_double * 3),
                   ("want_squares", ctypes.c_double)]
                + [(name, ctypes.c_double) for name in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                                                        "transmission_bounces", "roulette_from",
                                                        "transparent_bounces", "see_through", "caustics",
                                                        "clamp_direct", "clamp_indirect", "light_passes")])
    _size_function = "primer_chunk_params_size"


class ChunkOut(ctypes.Structure):
    """What a chunk adds up (chunk.c ChunkOut)."""

    _fields_ = [("rgba", ctypes.c_void_p), ("squares", ctypes.c_void_p), ("hits", ctypes.c_void_p),
                ("counts", ctypes.c_int64 * 2), ("seconds", ctypes.c_double * 3), ("light", ctypes.c_void_p)]
    _size_function = "primer_chunk_out_size"


def material_record(shader, shadow_opaque: bool = False) -> MaterialRecord:
    """Return the C record of a material: a ConstantShader's closures, or a NodeShader's nodes (program 1);
    shadow_opaque: it blocks shadow rays even where it lets light through (Transparent Shadows off)."""
    record = MaterialRecord()
    record.shadow_opaque = 1.0 if shadow_opaque else 0.0
    record.may_pass = 1.0 if shader.may_let_light_through else 0.0
    record.graph_emits = 1.0 if getattr(shader, "graph_emits", False) else 0.0
    if hasattr(shader, "nodes"):
        k = len(shader.nodes)
        record.n, record.program = float(k), 1.0
        record.kind[:k] = [float(node.kind) for node, _, _ in shader.nodes]
        if k:
            record.weight[:3 * k] = np.concatenate([w for _, w, _ in shader.nodes]).tolist()
            record.p[:NODE_PARAMS * k] = np.concatenate([p for _, _, p in shader.nodes]).tolist()
        record.emission[:] = np.asarray(shader.emission, np.float64).tolist()
        record.transparency[:] = np.asarray(shader.transparency, np.float64).tolist()
        return record
    k = len(shader.kinds)
    record.n = float(k)
    record.kind[:k] = [float(x) for x in shader.kinds]
    record.weight[:3 * k] = np.asarray(shader.weights, np.float64).ravel().tolist()
    record.sample_weight[:k] = np.asarray(shader.sample_weights, np.float64).tolist()
    rows = np.zeros((k, NODE_PARAMS))                    # a closure's PARAMS, in a record's row of NODE_PARAMS
    rows[:, :PARAMS] = np.asarray(shader.params, np.float64).reshape(k, PARAMS)
    record.p[:NODE_PARAMS * k] = rows.ravel().tolist()
    record.emission[:] = np.asarray(shader.emission, np.float64).tolist()
    record.transparency[:] = np.asarray(shader.transparency, np.float64).tolist()
    return record


def why_not(settings) -> str:
    """Return why a render with `settings` takes the Python reference path ('' when the C chunk applies)."""
    if settings.kernels != "compiled":
        return "kernels set to numpy"
    if not library.available():
        return library.unavailable_reason()
    if settings.integrator not in COMPILED_INTEGRATORS:
        return f"the {settings.integrator} integrator has no compiled twin yet"
    if not settings.is_lecture_default():
        return "a lecture switch is off its default"
    if settings.aux:
        return "debug buffers are requested"
    if not settings.jitter:
        return "jitter is off"
    if abs(settings.seed) >= 2 ** 53:
        return "the seed does not fit a double"
    return ""


class Compiled:
    """A render's records for the C chunk, made once; `chunk` renders one chunk with them.

    Returns None from `prepare` when the geometry's queries cannot go in packets (then the reference path renders).
    """

    def __init__(self, ctx: Context, background: np.ndarray):
        s = ctx.settings
        for struct in (LightRecord, ShadowSettings, MaterialRecord, ChunkParams, ChunkOut):
            library.check_size(struct)
        geometry = ctx.geometry
        self.tracer = geometry.tracer
        packets = self.tracer.packets
        self.camera = camera_.camera_record(ctx.scene.camera, s.width, s.height, tuple(s.pixel_aspect), geometry.origin)
        self.tables = GeometryTables(geometry)
        self.lights = (LightRecord * max(1, len(ctx.lights)))(
            *[light.pack(index, s.light_samples) for index, light in enumerate(ctx.lights)])
        self.materials = (MaterialRecord * len(ctx.materials.shaders))(
            *[material_record(shader, opaque) for shader, opaque in zip(ctx.materials.shaders, ctx.materials.shadow_opaque)])
        # Materials with node graphs: their programs, and each record's program number (+ 1).
        self.graphs = graph_tables(ctx.materials, geometry.attribute_layout)
        for row, index in (self.graphs.rows.items() if self.graphs is not None else ()):
            self.materials[row].graph = float(index + 1)
        self.shadows = ShadowSettings(1.0 if s.shadow_method == "robust" else 0.0, float(s.epsilon),
                                      1.0 if s.terminator_fix else 0.0, float(s.terminator_offset), float(s.seed))
        params = ChunkParams()
        params.camera, params.geometry = ctypes.addressof(self.camera), ctypes.addressof(self.tables.record)
        params.lights, params.materials = ctypes.addressof(self.lights), ctypes.addressof(self.materials)
        params.shadows = ctypes.addressof(self.shadows)
        params.graphs = self.graphs.pointer if self.graphs is not None else None
        params.intersect8, params.occluded8, params.scene = packets.intersect8, packets.occluded8, packets.scene
        # The emissive meshes' and the world's tables (their records in self.lights say only how often).
        from ..lights.world import WorldTables
        emitters = ctx.extra.get("emitters")
        self.emitter_tables = emitters.tables() if emitters is not None else None
        self.world_tables = WorldTables(ctx.extra["world_light"], ctx.extra.get("world_sampler"))
        self.context = LightContext(ctypes.addressof(self.emitter_tables.record) if emitters is not None else None,
                                    ctypes.addressof(self.world_tables.record))
        params.light_context = ctypes.addressof(self.context)
        params.light_count = float(len(ctx.lights))
        params.integrator = float(COMPILED_INTEGRATORS[s.integrator])
        params.sampling = float(("mis", "light", "bsdf").index(s.light_sampling))
        params.bsdf_rays = 1.0 if ctx.extra.get("bsdf_rays") else 0.0
        params.emissive = 1.0 if ctx.extra.get("emissive") else 0.0
        params.everywhere = 1.0 if ctx.extra.get("bsdf_everywhere") else 0.0
        params.transparent = 1.0 if s.transparent_background else 0.0
        params.width, params.height = float(s.width), float(s.height)
        params.background[:] = [float(x) for x in background]
        params.luminance[:] = adaptive.LUMINANCE.tolist()
        params.want_squares = 1.0 if s.adaptive else 0.0
        params.max_bounces, params.diffuse_bounces = float(s.max_bounces), float(s.diffuse_bounces)
        params.glossy_bounces, params.transmission_bounces = float(s.glossy_bounces), float(s.transmission_bounces)
        from .path import roulette_from
        params.roulette_from = float(roulette_from(s))
        params.transparent_bounces = float(s.transparent_max_bounces)
        params.see_through = 1.0 if ctx.extra.get("transparent") else 0.0
        from .clamp import limits
        from .path import caustics_bits
        params.caustics = float(caustics_bits(s))
        params.clamp_direct, params.clamp_indirect = limits(s)
        self.light_passes = lightpasses.wanted(s.passes)
        params.light_passes = 1.0 if self.light_passes else 0.0
        self.params = params
        self.want_squares = bool(s.adaptive)
        self._render = library.function("primer_render_chunk", None,
                                        [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64,
                                         ctypes.c_int64, ctypes.c_void_p])

    @staticmethod
    def applies(ctx: Context) -> bool:
        """Whether the scene's queries can be asked in packets from C (a Tracer with packets, or no geometry)."""
        return ctx.geometry.tracer.packets is not None

    def chunk(self, pixels: np.ndarray, spp: int, seed: int, first: np.ndarray) -> ChunkSums:
        """Render spp samples in each of `pixels` (samples first .. first + spp - 1 of each pixel's pattern)."""
        p = len(pixels)
        pixels = library.contiguous(pixels, np.int64)
        first = library.contiguous(first, np.int64)
        rgba, squares, hits = np.empty((p, 4)), (np.empty((p, 2)) if self.want_squares else None), np.empty(p, np.int64)
        params = ChunkParams.from_buffer_copy(self.params)
        params.seed = float(seed)
        out = ChunkOut(rgba.ctypes.data, None if squares is None else squares.ctypes.data, hits.ctypes.data)
        aux = {}
        if self.light_passes:               # the light passes' sums (core/integrators/lightpasses.py)
            aux[lightpasses.FILM_BUFFER] = light = np.empty((p, lightpasses.FILM_CHANNELS))
            out.light = light.ctypes.data
        self._render(ctypes.addressof(params), pixels.ctypes.data, first.ctypes.data, p, int(spp), ctypes.addressof(out))
        self.tracer.count_intersect(out.seconds[0])
        self.tracer.count_occluded(out.seconds[1])
        return ChunkSums(rgba, squares if squares is not None else np.zeros((p, 2)), hits, aux, int(out.counts[0]),
                         int(out.counts[1]), spp, out.seconds[0], out.seconds[1], out.seconds[2])
