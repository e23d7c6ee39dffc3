"""First-hit render passes: what compositing setups made for Cycles read besides Combined.

The integrator writes them along each camera sample's own path, as Cycles does (kernel/film/data_passes.h,
light_passes.h, integrator/shade_surface.h), both kernels (the compiled twin is passes.c). A path's *camera
chain* is the camera ray and the rays it sends straight on through Transparent closures (a Transparent BSDF, a
Principled BSDF's Alpha): the vertices a path meets before its first real bounce, each seen with the path's
throughput there (the product of the transparent bounces' weights).

- The data passes come from the first vertex of the chain whose alpha (1 - the mean transparency) is at least
  RenderSettings.pass_alpha_threshold (Cycles' Alpha Threshold, 0.5 by default); until then each vertex overwrites the sample-0 ones:
    position        the world-space hit point, of sample 0 only (not anti-aliased, as in Cycles)
    object_index    the object's Pass Index, of sample 0 only
    material_index  the material's Pass Index, of sample 0 only
    z_depth         the hit's distance along the camera's forward axis (Blender's Depth pass), of sample 0 only;
                    MISS_DEPTH where sample 0 met no surface
    average_normal  the closures' normals weighed by their mean weight, normalised (the shading normal where
                    no closure says otherwise: normal maps and bump included), world space, the mean over
                    samples (Cycles' Normal pass, surface_shader_average_normal)
    uv              (u, v, 1) of the object's active render UV map, the mean over samples: the third channel
                    is the share of samples that found such a surface
    vector          the hit's motion on screen (Cycles' Vector pass, primitive_motion_vector): where it was at the
                    frame before minus where it is, and where it is minus where it will be at the frame after, each
                    in raster pixels (x right, y up), the hit carried by its object's transform (Instance.
                    vector_motion), or a deforming mesh's hit its own point on the mesh then (its vertices then,
                    Instance.vector_deformation, interpolated: with_vector_deformation), and seen by the camera then
                    (Scene.vector_cameras; a panoramic camera through the inverse of its projection, Cycles'
                    direction_to_panorama: graph.panorama_window); the mean over the samples that
                    found a surface (a fifth channel counts them); 0 with motion blur on, as Cycles writes it.
                    Where the chain escapes before its opaque-enough vertex, nothing (Cycles before Blender 5.2), or
                    with VectorTables.world (Blender 5.2's Cycles, camera_motion_vector_direction) the motion of the
                    ray's direction as the camera turns: world_vector_at, counted as a sample
  A chain that escapes before its opaque vertex leaves the sample-0 passes 0 (Cycles' background data passes).
- At every vertex of the chain:
    diffuse_color, glossy_color, transmission_color   throughput times the sum over the closures of their weight
                    times their albedo (Cycles' bsdf_albedo; each BSDF class's `albedo`): Lambert's albedo is 1;
                    a microfacet's is its Fresnel reflectance at the view angle (Cycles reads a roughness-averaged
                    table for some Fresnel models; Primer's closures do not keep it); glass splits into its
                    reflected share (glossy) and transmitted share (transmission); a smooth glossy lobe, stored as
                    a mirror whose weight already holds its Fresnel reflectance, counts with albedo 1
    emission        throughput times what the surface emits
    ambient_occlusion  throughput times its alpha times what a cosine-distributed ray about the shading normal
                    carries back through transparent surfaces within ao_distance (1 open, 0 occluded; Cycles'
                    AO pass)
    mist            the mean of throughput times alpha, times 1 - m, m = clamp((d - mist_start) / mist_depth, 0,
                    1) ^ mist_falloff of the hit's distance d from the camera (along its axis for an orthographic
                    one); the pass is 1 - its mean over samples, clamped to [0, 1] (Cycles' Mist: a ray that
                    escapes adds nothing, so the world is 1)
    crypto_object, crypto_material, crypto_asset  Cryptomatte (cryptomatte.py): mean(throughput) x alpha for the
                    surface's object, material or asset id, into the pixel's slots
- Along the chain's rays:
    emission        throughput times the lamps with extent the camera sees that the ray passes
    environment     throughput times the world where the ray escapes, also with a transparent film (Cycles
                    keeps it for compositing the background back in)

Shader AOVs (View Layer > Passes > Shader AOV; RenderSettings.aovs), as Cycles writes them (svm/aov.h,
film/aov_passes.h): at each vertex of the chain until and with its opaque-enough one (Cycles'
PATH_RAY_SINGLE_PASS_DONE), every AOV Output node of the surface's material that names one of the view layer's AOVs
adds to it, neither weighed by the throughput nor by the alpha: a COLOR AOV its Color and 1 into a fourth channel
(its alpha: the share of samples that wrote it, 2 where two surfaces of a chain did), a VALUE AOV its Value. A
sample that writes nothing adds 0. The graph's ops that feed only AOVs run only there (graph.py AOV_START). The
world's AOV Output nodes write the same way where a camera chain escapes before its opaque-enough vertex (Cycles'
integrator_eval_background_shader runs the world's nodes there with the same svm_node_aov_check): the world's
program (world_graph.compile_aovs) at the ray's direction, added to what the chain's surfaces in front wrote, where
the camera sees the world (Ray Visibility > Camera) and, on a transparent film, only where the Environment pass is
asked for (Cycles evaluates the background of a transparent film's camera rays only for that pass).

Each pass is the mean over all of a pixel's samples (the film's sums divided by its count), but for the
sample-0 ones (FIRST_SAMPLE_ONLY), with the render's pixel filter (Primer's 1-pixel box; Cycles' default is
1.5 pixels Blackman-Harris: anti-aliased edges differ).
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple, Optional

import numpy as np

from .. import materials as materials_
from .. import volumes
from ..camera import camera as camera_
from ..geometry.surface import hit_attributes, hit_owners
from ..lights import world_graph
from ..materials import graph as graph_
from ..materials.closures import each_kind
from ..materials.lambert import Lambert
from ..native import schema
from ..native.schema import F64, I32, I64, ptr
from ..sampling import sobol as sampling
from . import cryptomatte, shadows
from .rays import lamps_seen

# Channels of each pass (core/render.py RenderResult.aux), in the order the film keeps them (PASS_* in C).
PASS_CHANNELS = {
    "position": 3, "uv": 3, "object_index": 1, "material_index": 1, "z_depth": 1, "average_normal": 3,
    "diffuse_color": 3, "glossy_color": 3, "transmission_color": 3,
    "emission": 3, "environment": 3, "ambient_occlusion": 3, "mist": 1, "vector": 5,
}
PASS = schema.constants("PASS", tuple(PASS_CHANNELS), "the first-hit passes, in the film's order (passes.py)")
schema.constant("PASS_CHANNELS_MAX", sum(PASS_CHANNELS.values()), "the first-hit passes' channels in all")
# Cryptomatte's passes: core buffer -> matte kind (cryptomatte.KINDS); their channels follow the depth.
CRYPTO_PASSES = {"crypto_object": "object", "crypto_material": "material", "crypto_asset": "asset"}
# Passes Cycles takes from sample 0 alone (overwritten, not averaged).
FIRST_SAMPLE_ONLY = ("position", "object_index", "material_index", "z_depth")
# A Depth pixel whose sample 0 met no surface (Cycles' value for no depth).
MISS_DEPTH = 1e10
# Sampling dimension of the ambient occlusion ray's direction (before the vertex's shift).
AO_DIMENSION = schema.constant("AO_DIMENSION", 120, "the ambient occlusion ray's sampling dimension")
# The UV map the UV pass reads: the mesh's active render map (core/scene Mesh.attributes).
UV_ATTRIBUTE = "uv:"
# The shader AOVs' channels a render keeps at most (passes.c's lanes hold as many; an AOV past them is left out with a
# warning, aov_slots): COLOR takes 4 (RGB, the share of samples written), VALUE 1.
AOV_CHANNELS_MAX = schema.constant("AOV_CHANNELS_MAX", 64, "the shader AOVs' channels a render keeps at most")
AOV_CHANNELS = {"COLOR": 4, "VALUE": 1}
# The core buffer (RenderResult.aux) of the shader AOV named NAME: AOV_PREFIX + NAME.
AOV_PREFIX = "aov:"
# The film's buffers of the passes' per-pixel sums, and of the Cryptomatte slots.
FILM_BUFFER = "data_passes"
MATTE_BUFFER = "cryptomatte"


def pass_channels(name: str, depth: int) -> int:
    """Return the channels of the pass `name`: PASS_CHANNELS', or 4 per two Cryptomatte ranks of `depth`."""
    return 4 * cryptomatte.pass_count(depth) if name in CRYPTO_PASSES else PASS_CHANNELS[name]


def aov_slots(aovs) -> dict:
    """Where the shader AOVs `aovs` ((name, "COLOR" or "VALUE") each, the view layer's order) sit among the AOV
    channels: name -> (first channel, channels: 4 or 1); a name given twice keeps its first, and the AOVs past
    AOV_CHANNELS_MAX channels are left out (aovs_left_out names them)."""
    slots, used = {}, 0
    for name, kind in aovs:
        channels = AOV_CHANNELS[kind]
        if name in slots or used + channels > AOV_CHANNELS_MAX:
            continue
        slots[name] = (used, channels)
        used += channels
    return slots


def aovs_left_out(aovs) -> list:
    """The names of the shader AOVs `aovs` that aov_slots leaves out for want of channels."""
    kept = aov_slots(aovs)
    return [name for name, _ in aovs if name not in kept]


class PassLayout:
    """Where the passes a render asks for sit in the film: names (in PASS_CHANNELS' order), offset name -> first
    channel, channels in all; the Cryptomatte kinds asked for (mattes: pass names, kinds: cryptomatte.KINDS
    indices) with `slots` (id, weight) slots each; the shader AOVs (aovs: aov_slots) from channel aov_base on,
    aov_channels of them, after the passes."""

    def __init__(self, wanted, depth: int, aovs=()):
        """The layout of the passes `wanted` (names of PASS_CHANNELS and CRYPTO_PASSES), Cryptomatte `depth`, shader
        AOVs `aovs` ((name, "COLOR" or "VALUE") each)."""
        self.names = [name for name in PASS_CHANNELS if name in wanted]
        self.offset, self.channels = {}, 0
        for name in self.names:
            self.offset[name] = self.channels
            self.channels += PASS_CHANNELS[name]
        self.mattes = [name for name in CRYPTO_PASSES if name in wanted]
        self.kinds = [cryptomatte.KINDS.index(CRYPTO_PASSES[name]) for name in self.mattes]
        self.slots = cryptomatte.slot_count(depth)
        self.aovs = aov_slots(aovs)
        self.aov_base = self.channels
        self.aov_channels = sum(channels for _, channels in self.aovs.values())
        self.channels += self.aov_channels

    def __bool__(self) -> bool:
        return bool(self.names or self.mattes or self.aovs)

    @property
    def sums(self) -> bool:
        """Whether the film keeps per-pixel sums of its passes (FILM_BUFFER): passes or shader AOVs asked for."""
        return bool(self.names or self.aovs)

    def has(self, name: str) -> bool:
        """Whether the pass `name` is asked for."""
        return name in self.offset

    def merge_mattes(self, film: np.ndarray, chunk: np.ndarray) -> np.ndarray:
        """A film's Cryptomatte slots (p, kinds slots 2) float64 after a chunk's of the same pixels went in, kind by
        kind (cryptomatte.merge_slots)."""
        p, kinds = len(film), len(self.mattes)
        film, chunk = film.reshape(p, kinds, self.slots, 2), chunk.reshape(p, kinds, self.slots, 2)
        return np.stack([cryptomatte.merge_slots(film[:, k], chunk[:, k]) for k in range(kinds)], axis=1).reshape(p, -1)

    def channels_of(self, name: str) -> slice:
        """The film channels of the pass `name`."""
        return slice(self.offset[name], self.offset[name] + PASS_CHANNELS[name])


def closure_albedos(closures, wo: np.ndarray) -> tuple:
    """Return (diffuse, glossy, transmission) colours (m, 3) float64 of hits with `closures` seen from wo (m, 3):
    each the sum of its closures' weight x albedo (module docstring), by closure type (BSDFFlags.*_TYPE): the
    diffuse type's reflection to Diffuse, the glossy type's to Glossy, the transmission type's transmission to
    Transmission, and glass's reflection and transmission to Glossy and Transmission."""
    F = materials_.BSDFFlags
    m = len(closures.kind)
    diffuse, glossy, transmission = np.zeros((m, 3)), np.zeros((m, 3)), np.zeros((m, 3))
    for slot in range(closures.kind.shape[1]):
        for bsdf, rows in each_kind(closures, slot):
            if not bsdf.is_(F.DIFFUSE_TYPE | F.GLOSSY_TYPE | F.TRANSMISSION_TYPE | F.GLASS_TYPE):
                continue
            weight = closures.weight[rows, slot]
            R, T = bsdf.albedo(closures.params[rows, slot], closures.N[rows, slot], wo[rows])
            if bsdf.is_(F.DIFFUSE_TYPE):
                diffuse[rows] += weight * R
            if bsdf.is_(F.GLOSSY_TYPE | F.GLASS_TYPE):
                glossy[rows] += weight * R
            if bsdf.is_(F.TRANSMISSION_TYPE | F.GLASS_TYPE):
                transmission[rows] += weight * T
    return diffuse, glossy, transmission


def average_normal(closures, N: np.ndarray) -> np.ndarray:
    """Return the unit normals (k, 3) float64 of hits with `closures`: their closures' normals weighed by
    |mean(weight)| (the Transparent BSDF left out), or the shading normal N (k, 3) where they have none."""
    kind, weight, normals = closures.kind, closures.weight, closures.N
    w = np.where((kind >= 0) & ~materials_.has(kind, materials_.BSDFFlags.STRAIGHT), np.abs(weight.mean(axis=-1)), 0.0)
    total = np.einsum("nk,nkj->nj", w, normals)
    length = np.linalg.norm(total, axis=-1, keepdims=True)
    return np.where(length > 0.0, total / np.where(length > 0.0, length, 1.0), N)


PassTables = schema.record("PassTables", """What the compiled kernel writes the first-hit passes with (passes.py,
passes.c): where each sits in a pixel's channels, and the scene's tables they read.""", [
    ("offset", I32, len(PASS_CHANNELS), "each PASS_*'s first channel, -1: not asked for"),
    ("channels", I64, "the passes' channels in all"),
    ("object_index", ptr(F64), "(n,) each Scene.instances entry's Pass Index"),
    ("material_index", ptr(F64), "(m + 1,) each material's Pass Index, then the default material's"),
    ("object_ids", ptr(F64), "(n,) each Scene.instances entry's Cryptomatte object id (a float32's value)"),
    ("asset_ids", ptr(F64), "(n,) its asset id"),
    ("material_ids", ptr(F64), "(m + 1,) each material's id, then the default surface's"),
    ("matte_count", I32, "the Cryptomatte kinds asked for (0: none)"),
    ("matte_kind", I32, 3, "each one's kind: 0 object, 1 material, 2 asset (cryptomatte.KINDS)"),
    ("slots", I64, "(id, weight) slots per kind and pixel"),
    ("origin", F64, 3, "the geometry's origin: a camera-relative point + origin is in the world"),
    ("camera_offset", F64, 3, "a camera-relative point + camera_offset is relative to the camera"),
    ("forward", F64, 3, "the camera's unit forward axis"),
    ("ao_distance", F64, "the ambient occlusion ray's length"),
    ("mist_start", F64, "the Mist pass's start distance"),
    ("mist_inv_depth", F64, "1 / its depth (0 for a depth of 0)"),
    ("mist_falloff", F64, "its falloff exponent"),
    ("ortho", I32, "1: an orthographic camera (the Mist pass's distance along its axis)"),
    ("uv_offset", I32, "the UV map's first attribute float, -1: none"),
    ("world_camera", I32, "1: the camera sees the world (the environment pass)"),
    ("alpha_threshold", F64, "the data passes' opaque-enough alpha (RenderSettings.pass_alpha_threshold)"),
    ("vector_before", ptr(F64), "(n, 3, 4) VectorTables.before (the Vector pass; NULL: not asked for)"),
    ("vector_after", ptr(F64), "(n, 3, 4) VectorTables.after"),
    ("vector_raster", F64, 48, "(3, 4, 4) VectorTables.raster: before, at and after the frame"),
    ("vector_still", I32, "VectorTables.still: 1 writes 0 motion"),
    ("vector_rows", I64, "the rows of vector_before and vector_after"),
    ("vector_deformed", ptr(I32), "(n,) VectorTables.deformed (NULL: no mesh deforms)"),
    ("vector_objects", ptr(F64), "(n, 2, 3, 4) VectorTables.objects"),
    ("vector_offset_before", I32, "VectorTables.offsets[0]: the motion:before attribute's first float"),
    ("vector_offset_after", I32, "VectorTables.offsets[1]"),
    ("vector_panorama", I32, "1: a panoramic camera, whose Window (vector_window) maps each frame's camera-space "
                             "point (vector_raster's rows 0-2) to the raster; 0: vector_raster projects"),
    ("vector_window", F64, 8, "VectorTables.window: the panorama's numbers (graph.panorama_window)"),
    ("vector_size", F64, 2, "VectorTables.size: the image's width and height in pixels"),
    ("vector_world", I32, "VectorTables.world: 1 the rays that see the world write their direction's motion"),
    ("aov_base", I32, "the AOVs' first channel (PassLayout.aov_base), -1: none"),
    ("world_aovs", ptr("WorldGraph"), "the world's AOV Output nodes (world_graph.compile_aovs), NULL: none written"),
])


def pass_tables(ctx, layout: PassLayout):
    """The PassTables record of a render's `layout` (the arrays it points at kept alive by the record; the world's
    AOV program, ctx.extra["world_aovs"], pointed at where the layout has AOVs)."""
    scene, geometry = ctx.scene, ctx.geometry
    offset = np.full(len(PASS_CHANNELS), -1, np.int32)
    for name in layout.names:
        offset[PASS[name]] = layout.offset[name]
    ids = ctx.extra.get("crypto_ids") or cryptomatte.id_tables(scene)
    kinds = np.zeros(3, np.int32)
    kinds[:len(layout.kinds)] = layout.kinds
    world = ctx.extra.get("world_light")
    uv = geometry.attribute_layout.get(UV_ATTRIBUTE)
    world_aovs = ctx.extra.get("world_aovs")
    tables = PassTables(
        offset=offset, channels=layout.channels,
        object_index=object_indices(scene), material_index=material_indices(scene),
        object_ids=ids["object"].astype(np.float64), asset_ids=ids["asset"].astype(np.float64),
        material_ids=ids["material"].astype(np.float64), matte_count=len(layout.kinds), matte_kind=kinds,
        slots=layout.slots, origin=np.asarray(geometry.origin, np.float64),
        camera_offset=np.asarray(ctx.extra["camera_offset"], np.float64),
        forward=np.asarray(ctx.extra["forward"], np.float64), ao_distance=float(ctx.settings.ao_distance),
        mist_start=float(ctx.settings.mist_start), mist_inv_depth=mist_inv_depth(ctx.settings),
        mist_falloff=float(ctx.settings.mist_falloff), ortho=is_ortho(ctx),
        uv_offset=-1 if uv is None else int(uv[0]), world_camera=world is not None and bool(world.camera),
        alpha_threshold=float(ctx.settings.pass_alpha_threshold), aov_base=layout.aov_base if layout.aovs else -1,
        **vector_fields(ctx.extra.get("vector_tables")))
    if world_aovs is not None and layout.aovs:
        tables.world_aovs = world_aovs.record()
    return tables


def vector_fields(tables) -> dict:
    """PassTables' Vector pass fields from VectorTables (or None: not asked for)."""
    if tables is None:
        return dict(vector_still=1)
    fields = dict(vector_before=np.ascontiguousarray(tables.before, np.float64),
                  vector_after=np.ascontiguousarray(tables.after, np.float64),
                  vector_raster=np.ascontiguousarray(tables.raster, np.float64).ravel(), vector_still=tables.still,
                  vector_rows=len(tables.before), vector_offset_before=int(tables.offsets[0]),
                  vector_offset_after=int(tables.offsets[1]), vector_world=int(tables.world))
    if tables.window:
        fields.update(vector_panorama=1, vector_window=np.asarray(tables.window, np.float64),
                      vector_size=np.asarray(tables.size, np.float64))
    if np.any(tables.deformed):
        fields.update(vector_deformed=np.ascontiguousarray(tables.deformed, np.int32),
                      vector_objects=np.ascontiguousarray(tables.objects, np.float64))
    return fields


def mist_inv_depth(settings) -> float:
    """1 / the Mist pass's depth, 0 for a depth of 0 or less (Cycles' mist_inv_depth: all mist from the start on)."""
    return 1.0 / float(settings.mist_depth) if settings.mist_depth > 0.0 else 0.0


def is_ortho(ctx) -> bool:
    """Whether the render's camera is orthographic (the Mist pass measures along its axis, as Cycles'
    camera_distance)."""
    return getattr(ctx.extra.get("camera"), "type", "PERSP") == "ORTHO"


def mist(ctx, I: np.ndarray) -> np.ndarray:
    """The Mist pass's m (k,) float64 at camera-relative hits I (k, 3): clamp((d - start) / depth, 0, 1) ^ falloff,
    d the distance from the camera (along its forward axis for an orthographic camera), as Cycles' data pass."""
    s = ctx.settings
    towards = I + ctx.extra["camera_offset"]
    d = np.abs(towards @ ctx.extra["forward"]) if is_ortho(ctx) else np.linalg.norm(towards, axis=1)
    m = np.clip((d - s.mist_start) * mist_inv_depth(s), 0.0, 1.0)
    return m if s.mist_falloff == 1.0 else m ** float(s.mist_falloff)


def object_indices(scene) -> np.ndarray:
    """Each Scene.instances entry's Pass Index: (n,) float64 (one 0 without instances)."""
    return np.array([float(getattr(i, "pass_index", 0)) for i in scene.instances] or [0.0])


def material_indices(scene) -> np.ndarray:
    """Each material's Pass Index, then the default material's: (m + 1,) float64."""
    return np.array([float(getattr(m, "pass_index", 0)) for m in scene.materials]
                    + [float(getattr(scene.default_material, "pass_index", 0))])


class DataPasses:
    """Each camera ray's first-hit passes as its path writes them (module docstring).

    values: (n, layout.channels) float64 its sums; done: (n,) bool its chain met its opaque-enough vertex; first:
    (n,) bool it is sample 0 of its pixel; object_index, material_index: the scene's Pass Indices (read once); mattes: its Cryptomatte entries as (owner (k,) int64, vertex int, ids
    (k, kinds) float64, weight (k,) float64) tuples, in the order the path met them.
    """

    def __init__(self, ctx, layout: PassLayout, sample: np.ndarray):
        """Nothing written yet for the camera rays of samples `sample` (n,) int64."""
        n = len(sample)
        self.layout = layout
        self.values = np.zeros((n, layout.channels))
        self.done = np.zeros(n, bool)
        self.first = np.asarray(sample) == 0
        self.mattes = []
        self.ids = (ctx.extra.get("crypto_ids") or cryptomatte.id_tables(ctx.scene)) if layout.mattes else None
        self.object_index, self.material_index = object_indices(ctx.scene), material_indices(ctx.scene)

    @classmethod
    def of(cls, ctx, sample: np.ndarray):
        """The DataPasses of a batch of camera rays, or None where the render asks for no first-hit pass."""
        layout = ctx.extra.get("pass_layout")
        return cls(ctx, layout, sample) if layout else None

    def add(self, name: str, owner: np.ndarray, value: np.ndarray) -> None:
        """Add value (k, c) to the pass `name` of the camera rays `owner` (k,) int64 (distinct), if it is asked for."""
        if self.layout.has(name) and len(owner):
            self.values[owner, self.layout.channels_of(name)] += value

    def set(self, name: str, owner: np.ndarray, value) -> None:
        """Overwrite the pass `name` of the camera rays `owner` (k,) int64 with value (k, c), if it is asked for."""
        if self.layout.has(name) and len(owner):
            self.values[owner, self.layout.channels_of(name)] = value


def at_vertex(ctx, dp: DataPasses, rows: np.ndarray, owner: np.ndarray, vertex: int, surface, shader,
              wo: np.ndarray, throughput: np.ndarray, pixel: np.ndarray, sample: np.ndarray, dimension: int = 0) -> None:
    """The passes at the hits `rows` (k,) int64 of a batch of m path vertices that lie on camera chains (module
    docstring): owner (m,) int64 each hit's camera ray (distinct), vertex their number along the path; surface,
    shader, wo (m, 3) and throughput (m, 3) of the m hits; pixel, sample (m,) int64 random-number keys; dimension:
    the vertex's shift of the sampling dimensions."""
    if len(rows) == 0:
        return
    geometry = ctx.geometry
    at = owner[rows]
    I, prim, material = surface.I[rows], surface.prim[rows], surface.material[rows]
    T = throughput[rows]
    transparency = np.clip(shader.transparency[rows], 0.0, None)
    alpha = 1.0 - transparency
    open_ = ~dp.done[at]
    # 0. The shader AOVs of the chain's vertices until its opaque-enough one (Cycles' svm_node_aov_check).
    aov = getattr(shader, "aov", None)
    if dp.layout.aovs and aov is not None:
        dp.values[at[open_], dp.layout.aov_base:dp.layout.aov_base + dp.layout.aov_channels] += aov[rows[open_]]
    # 1. Until the chain's opaque-enough vertex: sample 0's position, ids and depth, overwritten at each vertex.
    _, instance, _ = hit_owners(geometry, prim)
    first = np.flatnonzero(open_ & dp.first[at])
    if len(first):
        dp.set("position", at[first], I[first] + geometry.origin)
        indices = dp.object_index
        dp.set("object_index", at[first], indices[np.clip(instance[first], 0, len(indices) - 1)][:, None])
        indices = dp.material_index
        dp.set("material_index", at[first], indices[np.clip(material[first], 0, len(indices) - 1)][:, None])
        dp.set("z_depth", at[first], ((I[first] + ctx.extra["camera_offset"]) @ ctx.extra["forward"])[:, None])
    # 2. The opaque-enough vertex: the normal and UV, summed over samples; the chain's data passes are done.
    opaque = np.flatnonzero(open_ & (alpha.mean(axis=1) >= ctx.settings.pass_alpha_threshold))
    if len(opaque):
        if dp.layout.has("average_normal"):
            dp.add("average_normal", at[opaque], average_normal(shader.closures.rows(rows[opaque]),
                                                                shader.N[rows[opaque]]))
        if dp.layout.has("uv"):
            dp.add("uv", at[opaque], uv_at(geometry, surface, rows[opaque]))
        if dp.layout.has("vector"):
            tables = ctx.extra["vector_tables"]
            attributes = None
            if np.any(tables.deformed):                 # (a deforming mesh's vertices then: its attributes at the hit)
                attribute_rows, _, _ = hit_owners(geometry, prim[opaque])
                attributes, _, _ = hit_attributes(geometry, attribute_rows, surface.u[rows[opaque]],
                                                  surface.v[rows[opaque]])
            dp.add("vector", at[opaque], vector_at(tables, I[opaque] + geometry.origin, instance[opaque], attributes))
        dp.done[at[opaque]] = True
    # 3. Cryptomatte: this surface's share of the pixel, for its object, material and asset.
    if dp.layout.mattes:
        weight = T.mean(axis=1) * (1.0 - transparency.mean(axis=1))
        table = {"object": dp.ids["object"][np.clip(instance, 0, len(dp.ids["object"]) - 1)],
                 "asset": dp.ids["asset"][np.clip(instance, 0, len(dp.ids["asset"]) - 1)],
                 "material": dp.ids["material"][np.clip(material, 0, len(dp.ids["material"]) - 1)]}
        ids = np.stack([table[CRYPTO_PASSES[name]].astype(np.float64) for name in dp.layout.mattes], axis=1)
        dp.mattes.append((at, vertex, ids, weight))
    # 4. The closures' colours, the emission, and the ambient occlusion, seen through the chain.
    if any(dp.layout.has(name) for name in ("diffuse_color", "glossy_color", "transmission_color")):
        for name, albedo in zip(("diffuse_color", "glossy_color", "transmission_color"),
                                closure_albedos(shader.closures.rows(rows), wo[rows])):
            dp.add(name, at, T * albedo)
    dp.add("emission", at, T * shader.emission[rows])
    if dp.layout.has("ambient_occlusion"):
        dp.add("ambient_occlusion", at, T * alpha * ambient_occlusion(
            ctx, I, surface.Ng[rows], surface.vertices[rows], surface.N[rows], pixel[rows], sample[rows], dimension))
    if dp.layout.has("mist"):
        dp.add("mist", at, ((T * alpha).mean(axis=1) * (1.0 - mist(ctx, I)))[:, None])


def along_ray(ctx, dp: DataPasses, owner: np.ndarray, throughput: np.ndarray, O: np.ndarray, D: np.ndarray,
              hit: np.ndarray, t: np.ndarray, stretch=None) -> None:
    """What rays of camera chains meet before their end: owner (k,) int64 the camera rays (distinct), throughput
    (k, 3) the chains' there, rays O, D (k, 3) that end at t (k,) (their hit where hit (k,) bool, else where they
    escape): the lamps with extent they pass and what the media along them emit (emission: a medium the camera
    sees is Cycles' Emission, film_write_volume_emission on a path with no pass yet), the world where they escape
    (environment), and where they escape with the data passes not done, the world's shader AOVs (world_aovs) and
    sample 0's position, ids and depth back to 0 (and with VectorTables.world the direction's motion:
    world_vector_at). stretch: the media the rays cross (core/volumes Stretch, k rows), or None: the lamps and the world keep what
    they let through over their distance, as in Combined."""
    if len(owner) == 0:
        return
    if dp.layout.has("emission"):
        seen = lamps_seen(ctx, O, D, t, escaped=~hit, sigma=stretch)
        if stretch is not None:
            seen = seen + volumes.emitted(stretch, t)
        dp.add("emission", owner, throughput * seen)
    missed = np.flatnonzero(~hit)
    world = ctx.extra.get("world_light")
    if dp.layout.has("environment") and world is not None and world.camera and len(missed):
        seen = world.radiance_seen(D[missed])
        if stretch is not None:
            seen = seen * stretch.rows(missed).transmittance(np.full(len(missed), np.inf))
        dp.add("environment", owner[missed], throughput[missed] * seen)
    open_ = missed[~dp.done[owner[missed]]]            # (escaping before their opaque-enough vertex)
    program = ctx.extra.get("world_aovs")
    if program is not None and dp.layout.aovs and len(open_):
        # (Cycles' svm_node_aov_check: a camera path before its opaque-enough vertex; not weighed by the throughput)
        dp.values[owner[open_], dp.layout.aov_base:dp.layout.aov_base + dp.layout.aov_channels] += \
            world_graph.aovs_along(program, D[open_], dp.layout.aov_channels)
    tables = ctx.extra.get("vector_tables")
    if dp.layout.has("vector") and len(open_) and tables is not None and tables.world and not tables.still:
        # (Blender 5.2's Cycles: film_write_data_passes_background writes the direction's motion, with weight 1)
        dp.add("vector", owner[open_], world_vector_at(tables, D[open_]))
    gone = owner[open_][dp.first[owner[open_]]]
    for name in ("position", "object_index", "material_index", "z_depth"):
        dp.set(name, gone, 0.0)


class VectorTables(NamedTuple):
    """What the Vector pass projects with: before, after (n, 3, 4) float64 each instance's transform from where it
    is to where it was at the frame before and will be at the frame after (M_before M^-1, the identity where it
    stands still); raster (3, 4, 4) float64 the camera's world-to-raster transform (camera.world_to_raster) at the
    frame before, at the frame and at the frame after; still: 1 with motion blur on (Cycles writes 0 then).
    Deformation (Cycles' motion vertex positions): deformed (n,) int32 1 where the instance's mesh carries its
    vertices at the neighbouring frames as the attributes VECTOR_ATTRIBUTES (with_vector_deformation), whose
    first floats sit at offsets (before, after: two ints; -1: the geometry has none); objects (n, 2, 3, 4) float64
    each instance's object-to-world transform at the frame before and after (M_before, M_after: M where still),
    which carries those object-space positions into the world (no rows where the geometry has none). A panoramic
    camera (Cycles' inverse mappings): window, the frame's camera's Window numbers (render.panorama_frame), whose
    graph.panorama_window maps a point in the camera's space (x right, y up, z forward) to its (u, v) at all three
    frames, then (u, v) times size (width, height) is the raster; raster's rows 0-2 then hold each frame's world to
    camera space (camera.world_to_camera, Cycles' motion_pass_pre and post). () for a perspective or orthographic
    camera. world: 1 where the camera rays that see the world write the motion of their direction
    (world_vector_at: Blender 5.2's Cycles), 0 where they write nothing (Cycles before)."""

    before: np.ndarray
    after: np.ndarray
    raster: np.ndarray
    still: int
    deformed: np.ndarray = np.zeros(0, np.int32)
    objects: np.ndarray = np.zeros((0, 2, 3, 4))
    offsets: tuple = (-1, -1)
    window: tuple = ()
    size: tuple = (0, 0)
    world: int = 0


# The mesh attributes (object-space positions per corner) of a deforming mesh's vertices at the frames before and
# after the one rendered, for the Vector pass (Cycles' ATTR_STD_MOTION_VERTEX_POSITION).
VECTOR_ATTRIBUTES = ("motion:before", "motion:after")


def with_vector_deformation(scene, warnings: Optional[list] = None):
    """The scene with each mesh that deforms between the neighbouring frames (Instance.vector_deformation) carrying
    its vertices there as the per-corner attributes VECTOR_ATTRIBUTES (object space, (t, 3, 3)), as Cycles exports
    its motion vertex positions; `scene` itself where none deforms. A frame whose vertices are missing, of another
    count (the topology changed) or not finite takes the mesh's own vertices, as Cycles' sync_mesh_motion copies the
    frame's there ("Topology differs, discarding motion blur"): that frame's motion is the transform's alone. The
    meshes are replaced, not changed (an exported scene may be cached). Where the materials' attributes leave no
    room for them (graph.MAX_ATTRIBUTES floats a corner), `scene` itself, noted in `warnings`."""
    if not any(instance.vector_deformation for instance in scene.instances):
        return scene
    names = set().union(*[(getattr(mesh, "attributes", None) or {}).keys() for mesh in scene.meshes])
    if sum(graph_.attribute_width(name) for name in names | set(VECTOR_ATTRIBUTES)) > graph_.MAX_ATTRIBUTES:
        if warnings is not None:
            warnings.append("the Vector pass: the materials' mesh attributes leave no room for the deforming meshes' "
                            "vertices at the neighbouring frames; their pass carries only the objects' transforms")
        return scene
    meshes = list(scene.meshes)
    changed = False
    for instance in scene.instances:
        if not instance.vector_deformation or instance.mesh >= len(meshes):
            continue
        mesh = meshes[instance.mesh]
        own = np.asarray(mesh.vertices, np.float64)
        frames = [own if p is None or np.shape(p) != own.shape or not np.isfinite(p).all() else np.asarray(p, np.float64)
                  for p in instance.vector_deformation]
        if all(np.array_equal(p, own) for p in frames) or VECTOR_ATTRIBUTES[0] in (mesh.attributes or {}):
            continue
        triangles = np.asarray(mesh.triangles, np.int64)
        attributes = dict(mesh.attributes or {})
        for name, positions in zip(VECTOR_ATTRIBUTES, frames):
            attributes[name] = positions[triangles]
        meshes[instance.mesh] = dataclasses.replace(mesh, attributes=attributes)
        changed = True
    return dataclasses.replace(scene, meshes=meshes) if changed else scene


def vector_tables(scene, width: int, height: int, pixel_aspect, blurred: bool, layout=None,
                  window: tuple = (), world: bool = False) -> VectorTables:
    """The VectorTables of a scene rendered width x height with `pixel_aspect`; blurred: motion blur is on (the pass
    is 0, as Cycles writes it); layout: the geometry's attribute layout (WorldGeometry.attribute_layout), where
    the deforming meshes' VECTOR_ATTRIBUTES sit (None: no deformation mapped); window: a panoramic camera's Window
    numbers (render.panorama_frame); world: the rays that see the world write their direction's motion
    (RenderSettings.world_vector, VectorTables.world). A panoramic camera's frames are mapped by its projection's inverse (Cycles'
    direction_to_panorama), only their transforms read from the cameras then (as Cycles' motion_pass_pre and post);
    a perspective or orthographic camera's frames each by that frame's camera (its lens and sensor), a panoramic one
    among them by the frame's camera moved there."""
    cameras = scene.vector_cameras or (scene.camera, scene.camera)
    if blurred:
        return VectorTables(np.zeros((0, 3, 4)), np.zeros((0, 3, 4)), np.zeros((3, 4, 4)), 1)
    frames = (cameras[0], scene.camera, cameras[1])
    panoramic = scene.camera.type == "PANO"
    if panoramic:
        if len(window) != 8:
            raise ValueError("a panoramic camera's Vector pass needs its Window numbers (render.panorama_frame)")
        raster = np.tile(np.eye(4), (3, 1, 1))
        for k, camera in enumerate(frames):
            raster[k, :3] = camera_.world_to_camera(camera)
    else:
        frames = [camera if camera.type != "PANO"
                  else dataclasses.replace(scene.camera, matrix_world=camera.matrix_world) for camera in frames]
        raster = np.stack([camera_.world_to_raster(camera, width, height, tuple(pixel_aspect)) for camera in frames])
    n = len(scene.instances)
    layout = layout or {}
    offsets = tuple(int(layout[name][0]) if name in layout else -1 for name in VECTOR_ATTRIBUTES)
    mapped = min(offsets) >= 0                          # (some mesh carries its vertices then: with_vector_deformation)
    moves = [np.tile(np.eye(4)[:3], (n, 1, 1)) for _ in range(2)]
    deformed = np.zeros(n, np.int32)
    objects = np.zeros((n if mapped else 0, 2, 3, 4))
    for i, instance in enumerate(scene.instances):
        if instance.vector_motion:
            inverse = np.linalg.inv(np.asarray(instance.matrix, np.float64))
            for k in range(2):
                moves[k][i] = (np.asarray(instance.vector_motion[k], np.float64) @ inverse)[:3]
        if mapped:
            mesh = scene.meshes[instance.mesh] if instance.mesh < len(scene.meshes) else None
            attributes = getattr(mesh, "attributes", None) or {}
            deformed[i] = all(name in attributes for name in VECTOR_ATTRIBUTES)
            for k in range(2):
                objects[i, k] = np.asarray(instance.vector_motion[k] if instance.vector_motion else instance.matrix,
                                           np.float64)[:3]
    return VectorTables(moves[0], moves[1], raster, 0, deformed, objects, offsets,
                        tuple(float(x) for x in window) if panoramic else (), (float(width), float(height)),
                        int(bool(world)))


def vector_at(tables: VectorTables, P: np.ndarray, instance: np.ndarray, attributes=None) -> np.ndarray:
    """The Vector pass's value at world points P (k, 3) float64 of the instances `instance` (k,) int64: (before -
    now, now - after) on the raster, then 1 (its weight): (k, 5) float64 (0 but the weight where still). Where it
    was and will be: a deforming instance's (tables.deformed) the hit's own point on its mesh then, the
    VECTOR_ATTRIBUTES interpolated at the hit (attributes: (k, A) float64 the hits' mesh attributes,
    surface.hit_attributes) carried by its object's transform then (Cycles' primitive_motion_vector with vertex
    motion); any other's P carried by its transform's change (M_before M^-1). Seen by the camera then: its
    world-to-raster transform, or a panoramic camera's projection inverted (its Window, graph.panorama_window, times
    the image's size: Cycles' primitive_motion_vector)."""
    out = np.zeros((len(P), 5))
    out[:, 4] = 1.0
    if tables.still or len(P) == 0:
        return out
    row = np.clip(instance, 0, max(len(tables.before) - 1, 0))
    deformed = (np.flatnonzero(tables.deformed[row] != 0) if attributes is not None and len(tables.deformed)
                else np.zeros(0, np.int64))
    at = []
    for k, move in ((0, tables.before), (1, None), (2, tables.after)):
        Q = P if move is None else np.einsum("kij,kj->ki", move[row], np.c_[P, np.ones(len(P))])
        if move is not None and len(deformed):
            start = tables.offsets[k // 2]
            local = np.asarray(attributes, np.float64)[deformed, start:start + 3]
            Q = Q.copy()
            Q[deformed] = np.einsum("kij,kj->ki", tables.objects[row[deformed], k // 2], np.c_[local, np.ones(len(local))])
        h = np.c_[Q, np.ones(len(P))] @ tables.raster[k].T
        at.append(raster_of(tables, h, divide=True))    # (h: the point in the camera's space then)
    out[:, 0:4] = differences(at)
    return out


def raster_of(tables: VectorTables, h: np.ndarray, divide: bool) -> np.ndarray:
    """Points h (k, 4) in a frame's camera space (or directions, h[:, 3] 1) on the raster: (k, 2), through a
    panoramic camera's projection inverted (its Window, graph.panorama_window) times the image's size, else h's x
    and y, divided by h[:, 3] where `divide` (points through the world-to-raster transform), as they are where not
    (directions). passes.c vector_raster."""
    if tables.window:
        return graph_.panorama_window(h[:, :3], np.asarray(tables.window, np.float64))[:, :2] * np.asarray(tables.size)
    return h[:, :2] / h[:, 3:4] if divide else h[:, :2]


def differences(at: list) -> np.ndarray:
    """The Vector pass's (before - now, now - after) of the three frames' raster places at (3 of (k, 2)): (k, 4).
    passes.c vector_differences."""
    return np.concatenate([at[0] - at[1], at[1] - at[2]], axis=1)


def world_vector_at(tables: VectorTables, D: np.ndarray) -> np.ndarray:
    """The Vector pass's value where camera rays of directions D (k, 3) float64 see the world (Blender 5.2's Cycles,
    camera_motion_vector_direction): (before - now, now - after) of the direction's place at infinity, then 1 (its
    weight): (k, 5) float64. Only the camera's turn moves it: each frame's world-to-camera rotation (tables.raster's
    3 x 3), a panoramic camera's through its projection inverted (times the image's size, as vector_at); a
    perspective or orthographic camera's the x and y rows of its world-to-raster's 3 x 3 times D, not divided by the
    depth (so Cycles writes it: transform_perspective_direction)."""
    out = np.zeros((len(D), 5))
    out[:, 4] = 1.0
    if tables.still or len(D) == 0:
        return out
    D = np.asarray(D, np.float64)
    D = D / np.maximum(np.linalg.norm(D, axis=1, keepdims=True), 1e-300)
    at = []
    for k in range(3):
        h = np.c_[D @ np.asarray(tables.raster[k], np.float64)[:3, :3].T, np.ones(len(D))]
        at.append(raster_of(tables, h, divide=False))   # (h: the direction in the camera's space then)
    out[:, 0:4] = differences(at)
    return out


def uv_at(geometry, surface, rows: np.ndarray) -> np.ndarray:
    """(u, v, 1) of the active render UV map at the hits `rows` of `surface`: (k, 3) float64 ((0, 0, 1) without one)."""
    uv = np.zeros((len(rows), 3))
    uv[:, 2] = 1.0
    layout = geometry.attribute_layout.get(UV_ATTRIBUTE)
    if layout is not None:
        attribute_rows, _, _ = hit_owners(geometry, surface.prim[rows])
        values, _, _ = hit_attributes(geometry, attribute_rows, surface.u[rows], surface.v[rows])
        uv[:, :2] = values[:, layout[0]:layout[0] + 2]
    return uv


def ambient_occlusion(ctx, I: np.ndarray, Ng: np.ndarray, vertices: np.ndarray, N: np.ndarray, pixel: np.ndarray,
                      sample: np.ndarray, dimension: int = 0) -> np.ndarray:
    """What a cosine-distributed ray about N (k, 3) from the hit points I (k, 3) float64 carries back within
    ctx.settings.ao_distance: (k, 3) float64, 1 where it escapes, the transparency of the surfaces it passes
    (shadows.transmittance), 0 where it meets an opaque one or leaves below the face. Ng: (k, 3) face normals;
    vertices (k, 3, 3); dimension: the vertex's shift of the sampling dimensions."""
    u = sampling.sample_2d(ctx.settings.seed, pixel, sample, dimension=AO_DIMENSION + dimension)
    wi = Lambert.sample(None, N, None, u).wi
    above = np.einsum("ij,ij->i", Ng, wi) > 0.0      # a direction under the surface sees nothing: occluded
    origin = shadows.spawn_ray(I, Ng, wi, shadows.error_bound(I, vertices))
    rays = shadows.ShadowRays(origin, wi, np.full(len(I), float(ctx.settings.ao_distance)))
    T = shadows.transmittance(ctx, rays, ctx.settings.transparent_max_bounces)
    return np.where(above[:, None], T, 0.0)


def images(sums: dict, count: np.ndarray, layout: PassLayout, depth: int, height: int, width: int) -> dict:
    """The pass images from the film's sums (FILM_BUFFER (H W, channels), MATTE_BUFFER (H W, kinds slots 2)) and
    the samples per pixel count (H W,): name -> (H, W, c) float32. Each pass is its sum over the count, the sample-0
    ones their sum (a Depth of 0, no surface, is MISS_DEPTH); Cryptomatte's slots ranked by coverage."""
    out = {}
    values = sums.get(FILM_BUFFER)
    n = count.astype(np.float64)[:, None]
    for name in layout.names:
        v = values[:, layout.channels_of(name)]
        if name == "vector":                        # (the mean over the samples that found a surface)
            v = np.divide(v[:, :4], v[:, 4:], out=np.zeros_like(v[:, :4]), where=v[:, 4:] > 0)
        elif name not in FIRST_SAMPLE_ONLY:
            v = np.divide(v, n, out=np.zeros_like(v), where=n > 0)
            if name == "mist":                   # (the film holds 1 - mist, as Cycles' buffer)
                v = np.clip(1.0 - v, 0.0, 1.0)
        elif name == "z_depth":
            v = np.where(v == 0.0, MISS_DEPTH, v)
        out[name] = v.astype(np.float32).reshape(height, width, -1)
    for name, (first, channels) in layout.aovs.items():
        v = values[:, layout.aov_base + first:layout.aov_base + first + channels]
        v = np.divide(v, n, out=np.zeros_like(v), where=n > 0)
        out[AOV_PREFIX + name] = v.astype(np.float32).reshape(height, width, -1)
    if layout.mattes:
        slots = sums[MATTE_BUFFER].reshape(len(count), len(layout.mattes), layout.slots, 2)
        for k, name in enumerate(layout.mattes):
            out[name] = cryptomatte.ranked(slots[:, k], count, depth).reshape(height, width, -1)
    return out
