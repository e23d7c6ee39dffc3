"""The integrators' compiled twin: a whole chunk of pixels x samples in one C call (chunk.c).

core/render.py renders every chunk through `Compiled.chunk` where it applies (`why_not`), else through
the Python reference (camera -> integrator -> film). Both give the same numbers, within the
tolerance tests/test_compiled.py states. This module packs what the C code reads, once per render:
the camera (core/camera), the triangles (core/geometry/tables.py), the lights (each light's `pack`),
the materials, the shadow settings, Embree's packet queries, and the film's background.
"""
from __future__ import annotations

import numpy as np

from ..camera import camera as camera_
from ..film import adaptive
from ..film.film import ChunkSums
from ..geometry.tables import GeometryTables
from ..lights import LightRecord
from ..lights.base import LightContext
from ..materials import NODE_PARAMS, PARAMS
from ..materials.graph import graph_tables
from ..native import library, schema
from ..native.schema import F64, I32, I64, out, ptr
from . import features as features_
from . import catcher as catcher_, lightgroups, lightpasses
from . import mnee as mnee_
from . import passes as passes_
from .base import Cancelled, Context
from .shadows import ShadowSettings

# The integrators the C code knows (INTEGRATOR_*), and how it finds lights with extent (SAMPLE_*: light_sampling).
COMPILED_INTEGRATORS = schema.constants("INTEGRATOR", ("direct", "path"), "the integrators with a compiled twin")
schema.table("INTEGRATOR", lambda: list(COMPILED_INTEGRATORS))
SAMPLING = schema.constants("SAMPLE", ("mis", "light", "bsdf"), "RenderSettings.light_sampling")

MaterialRecord = schema.record("MaterialRecord", """One material of the scene's MaterialTable. program 0: a ConstantShader, n closures the same at
every hit but for their normal (kind: BSDF_*). program 1: a NodeShader, n shader nodes (kind: NODE_*, weight, p:
the node's inputs) set up per hit (nodes.c); graph: 0, or 1 + its node graph's program in the render's
GraphTables (graph.c), which overwrites inputs per hit. Its rows are arrays of n (as many as it has: no limit),
which the record keeps alive.""", [
    ("n", I32, "closures or nodes"),
    ("program", I32, "0: closures; 1: shader nodes"),
    ("graph", I32, "0, or 1 + its program in GraphTables"),
    ("kind", ptr(I32), "(n,) BSDF_* (program 0) or NODE_* (program 1)"),
    ("weight", ptr(F64), "(n, 3)"),
    ("sample_weight", ptr(F64), "(n,) a closure's (program 0)"),
    ("p", ptr(F64), "(n, NODE_PARAMS) a closure's CLOSURE_PARAMS, or a node's NODE_PARAMS inputs"),
    ("emission", F64, 3, ""),
    ("transparency", F64, 3, ""),
    ("shadow_opaque", I32, "1: opaque to shadow rays even where it lets light through (Transparent Shadows off)"),
    ("may_pass", I32, "1: it may let light through somewhere (a Transparent node, alpha)"),
    ("graph_emits", I32, "1: its node graph gives its emission (a texture): evaluated where light lands"),
    ("uncorrected", I32, "1: Bump Map Correction off (no valid_reflection of its nodes' normals; diffuse bump "
                         "shadowing only its side test)"),
], tables=("BSDF", "NODE"))

ChunkParams = schema.record("ChunkParams", "Everything a chunk reads, made once per render (core/integrators/compiled.py).", [
    ("camera", ptr("CameraRecord"), ""),
    ("geometry", ptr("GeometryTables"), ""),
    ("lights", ptr("LightRecord"), "(light_count,)"),
    ("materials", ptr("MaterialRecord"), "(m + 1,) the MaterialTable's rows"),
    ("closure_room", I64, "the most closures a hit of any of them sets up (closure_room): room made per hit"),
    ("shadows", ptr("ShadowSettings"), ""),
    ("intersect8", out(), "Embree's packet queries and the RTCScene"),
    ("occluded8", out(), ""),
    ("scene", out(), ""),
    ("light_context", ptr("LightContext"), "the emitters' and the world's tables"),
    ("graphs", ptr("GraphTables"), "the materials' node-graph programs, or NULL (graph.c)"),
    ("light_count", I64, ""),
    ("integrator", I32, "INTEGRATOR_*"),
    ("sampling", I32, "SAMPLE_*: how lights with extent are found"),
    ("bsdf_rays", I32, "1: one BSDF-sampled ray per hit finds lights with extent"),
    ("emissive", I32, "1: some material emits"),
    ("everywhere", I32, "1: every hit traces a BSDF ray, else glossy hits only"),
    ("transparent", I32, "1: the film is transparent (the world is not drawn)"),
    ("clear_glass", F64, "Film > Transparent Glass: the threshold^4 of alpha_x alpha_y under which a glass "
                         "transmission keeps a camera path clear (PATH_CLEAR_GLASS); -1: off"),
    ("width", I64, ""),
    ("height", I64, ""),
    ("seed", I64, "the sampling pattern's seed"),
    ("background", F64, 4, "RGBA of a camera ray that misses"),
    ("luminance", F64, 3, "adaptive sampling's luminance weights"),
    ("want_squares", I32, "1: sum squared luminance and alpha (adaptive sampling)"),
    ("max_bounces", I32, "path.c's bounce limits (RenderSettings)"),
    ("diffuse_bounces", I32, ""),
    ("glossy_bounces", I32, ""),
    ("transmission_bounces", I32, ""),
    ("roulette_from", I32, "the first vertex Russian roulette may end"),
    ("transparent_bounces", I32, "a path's limit of transparent bounces"),
    ("volume_bounces", I32, "how often a path goes on from where it scatters in media"),
    ("see_through", I32, "1: some material lets light through (Transparent, alpha)"),
    ("walks", I32, "1: some material walks subsurface scattering (direct: the path tracer with no bounces)"),
    ("caustics", I32, "FILTER_* bits after a diffuse bounce (path.caustics_bits)"),
    ("filter_glossy", F64, "Cycles' Filter Glossy, 0: off (path.filter_glossy_roughness)"),
    ("ao_bounces", I32, "Fast GI (Replace): a ray past these bounces is short and ends its path (vertex.fast_gi_ray); "
                        "0: off"),
    ("ao_factor", F64, "Fast GI: the world's light a short ray escapes to is scaled by this"),
    ("ao_distance", F64, "Fast GI: how far a short ray looks (and Add's ambient occlusion rays)"),
    ("ao_additive_factor", F64, "Fast GI (Add): every path vertex adds ambient occlusion times its diffuse closures' "
                                "weights times this (path.fast_gi_added); 0: off"),
    ("clamp_direct", F64, "sample clamping's caps (clamp.limits; inf: none)"),
    ("clamp_indirect", F64, ""),
    ("mnee", I32, "1: the path tracer walks Shadow Caustics for the lights whose LightRecord.caustics is set "
                  "(mnee.active; core/integrators/mnee.c)"),
    ("light_passes", I32, "1: sum the light passes (lightpasses.c) into ChunkOut.light"),
    ("light_groups", I32, "G: sum the light groups' light into ChunkOut.groups (lightgroups.py; 0: none)"),
    ("instance_groups", ptr(I32), "(n,) each Scene.instances entry's light group (-1: none), or NULL"),
    ("world_group", I32, "the world's light group (-1: none)"),
    ("stop", ptr(I32), "(1,) set to 1 when the render is cancelled: the chunk stops before its next block, or NULL"),
    ("features", I32, "1: sum the denoising features (features.c) into ChunkOut.features"),
    ("passes", ptr("PassTables"), "the first-hit passes asked for (passes.c), or NULL"),
    ("media", ptr("MediaTables"), "the render's homogeneous media (core/volumes/media.c), or NULL: none"),
    ("catcher", ptr(), "the ChunkParams of the shadow catchers' catcher-only scene (catcher.py), or NULL: no catcher"),
    ("split", I32, "1: the catcher-only scene's (catcher.py catcher_split): camera rays cross no medium to their "
                   "catcher and go on from it in the media the camera is in"),
    ("cones", I32, "1: some program reads a ray's cone (rays.cones_read: a Bump, Ray Footprint, Pixel Size), so camera "
                   "rays carry theirs; 0: they carry UNKNOWN_CONE, which nothing reads (chunk.c camera_ray_cone)"),
], tables=("INTEGRATOR",))

ChunkOut = schema.record("ChunkOut", "What a chunk adds up: per pixel, and for the render's statistics.", [
    ("rgba", out(F64), "(p, 4) sums of the samples' RGBA"),
    ("squares", out(F64), "(p, 2) sums of squared luminance and alpha, or NULL"),
    ("hits", out(I64), "(p,) samples that hit a surface"),
    ("counts", I64, 2, "camera rays traced, shadow rays traced"),
    ("seconds", F64, 3, "inside Embree's nearest-hit queries, its occlusion queries, shading"),
    ("light", out(F64), "(p, LIGHT_CHANNELS) sums of the light passes, or NULL"),
    ("groups", out(F64), "(p, 3 light_groups) sums of the light groups' light, or NULL"),
    ("features", out(F64), "(p, FEATURE_CHANNELS) sums of the denoising features, or NULL"),
    ("nonfinite", out(I64), "(p,) samples whose value was NaN or beyond the float32 film (replaced by 0), or NULL"),
    ("passes", out(F64), "(p, PassTables.channels) sums of the first-hit passes, or NULL"),
    ("mattes", out(F64), "(p, matte_count, slots, 2) each pixel's Cryptomatte slots (id, weight), or NULL"),
    ("catcher", out(F64), "(p, CATCHER_CHANNELS) sums of the shadow catchers' matte, catcher-only light, background "
                          "and caught samples (catcher.py), or NULL"),
])

ChunkArgs = schema.function("primer_render_chunk", "render_chunk", schema.record("ChunkArgs", "primer_render_chunk's arguments: spp samples in each of p pixels.", [
    ("params", ptr("ChunkParams"), ""),
    ("pixels", ptr(I64), "(p,) the pixels' flat indices"),
    ("first", ptr(I64), "(p,) each pixel's first sample of its pattern"),
    ("p", I64, ""),
    ("spp", I64, ""),
    ("out", out("ChunkOut"), "the sums (zeroed first), the counts and seconds (added to)"),
]))


GraphEmissionArgs = schema.function("primer_graph_emission", "graph_emission_rows", schema.record("GraphEmissionArgs", "primer_graph_emission's arguments: what n points on triangles emit by their materials' node graphs.", [
    ("geometry", ptr("GeometryTables"), ""),
    ("materials", ptr("MaterialRecord"), "every material's record"),
    ("graphs", ptr("GraphTables"), "their node-graph programs"),
    ("n", I64, ""),
    ("prim", ptr(I64), "(n,) the triangles (WorldGeometry's flat indices)"),
    ("O", ptr(F64), "(n, 3) the rays' origins"),
    ("D", ptr(F64), "(n, 3) their unit directions"),
    ("t", ptr(F64), "(n,) the distances to the points"),
    ("emission", out(F64), "(n, 3) what the points emit back along -D"),
]))


def graph_emission(geometry, materials, prim: np.ndarray, O: np.ndarray, D: np.ndarray, t: np.ndarray,
                   paths=None) -> np.ndarray:
    """vertex.graph_emission in C, for rays other than the camera's with no path (paths None) and the frame's
    geometry, as the emitters' estimates ask it (emitters.mean_graph_emission): (n, 3) float64. Falls back to the
    reference where the library is not loaded or paths are given."""
    from .vertex import graph_emission as reference
    graphs = graph_tables(materials, geometry.attribute_layout)
    if paths is not None or graphs is None or not library.available() or len(prim) == 0:
        return reference(geometry, materials, prim, O, D, t, paths)
    tables = GeometryTables(geometry)
    records, array = material_records(materials, graphs)
    n = len(prim)
    emission = np.empty((n, 3))
    arrays = dict(prim=library.contiguous(prim, np.int64), O=library.contiguous(O, np.float64),
                  D=library.contiguous(D, np.float64), t=library.contiguous(np.broadcast_to(t, (n,)), np.float64))
    library.call("primer_graph_emission", GraphEmissionArgs(geometry=tables.record, materials=array,
                                                            graphs=graphs.record, n=n, emission=emission, **arrays))
    return emission


def material_records(materials, graphs) -> tuple:
    """The C records of a MaterialTable's rows, each graph material's naming its program in `graphs` (GraphTables or
    None) by number + 1: (the records, which keep their rows' arrays alive; the C array of copies of them)."""
    records = [material_record(shader, opaque) for shader, opaque in zip(materials.shaders, materials.shadow_opaque)]
    array = (MaterialRecord * len(records))(*records)
    for row, index in (graphs.rows.items() if graphs is not None else ()):
        array[row].graph = index + 1
    return records, array


def material_record(shader, shadow_opaque: bool = False) -> MaterialRecord:
    """Return the C record of a material: a ConstantShader's closures, or a NodeShader's nodes (program 1), as many as
    it has; shadow_opaque: it blocks shadow rays even where it lets light through (Transparent Shadows off)."""
    record = MaterialRecord(shadow_opaque=shadow_opaque, may_pass=shader.may_let_light_through,
                            graph_emits=bool(getattr(shader, "graph_emits", False)),
                            uncorrected=not getattr(shader, "bump_map_correction", True))
    if hasattr(shader, "nodes"):
        k = len(shader.nodes)
        record.program = 1
        kind = np.array([node.kind for node, _, _ in shader.nodes], np.int32)
        weight = np.array([w for _, w, _ in shader.nodes], np.float64).reshape(k, 3)
        p = np.array([row for _, _, row in shader.nodes], np.float64).reshape(k, NODE_PARAMS)
        sample_weight = np.zeros(k)
    else:
        k = len(shader.kinds)
        kind = np.asarray(shader.kinds, np.int32).reshape(k)
        weight = np.asarray(shader.weights, np.float64).reshape(k, 3)
        sample_weight = np.asarray(shader.sample_weights, np.float64).reshape(k)
        p = np.zeros((k, NODE_PARAMS))
        p[:, :PARAMS] = np.asarray(shader.params, np.float64).reshape(k, PARAMS)   # a closure's PARAMS in its row
    record.n = k
    # (a zero row where there are none, so that no pointer is to an empty array)
    record.kind, record.weight, record.sample_weight, record.p = (
        np.ascontiguousarray(array if k else np.zeros((1,) + array.shape[1:], array.dtype))
        for array in (kind, weight, sample_weight, p))
    record.emission = np.asarray(shader.emission, np.float64)
    record.transparency = np.asarray(shader.transparency, np.float64)
    return record


def closure_room(shaders: list) -> int:
    """The room for closures the compiled kernel makes at each hit: the most any of the materials' `shaders` sets up
    (ConstantShader / NodeShader.closures_at_most), at least 1. Python's ClosureBuilder makes the same room per
    material, so both kernels keep every closure."""
    return max([1] + [int(shader.closures_at_most) for shader in shaders])


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
    if len(settings.light_groups) > lightgroups.MAX_GROUPS:
        return f"more than {lightgroups.MAX_GROUPS} light groups"
    return ""


class Compiled:
    """A render's records for the C chunk, made once; `chunk` renders one chunk with them.

    Returns None from `prepare` when the geometry's queries cannot go in packets (then the reference path renders).
    """

    def __init__(self, ctx: Context, background: np.ndarray):
        from ..lights.world import WorldTables
        from .clamp import limits
        from .path import caustics_bits, roulette_from
        from .rays import clear_glass_threshold, cones_read
        s = ctx.settings
        geometry = ctx.geometry
        self.tracer = geometry.tracer
        packets = self.tracer.packets
        self.camera = camera_.camera_record(ctx.scene.camera, s.width, s.height, tuple(s.pixel_aspect), geometry.origin,
                                            s.filter)
        self.tables = GeometryTables(geometry)
        if not s.terminator_fix:                   # (the lecture's raw rays: no object's terminator offsets)
            self.tables.record.terminator = None
        # (the records keep their IES tables alive; the C array holds copies of their pointers)
        self.light_records = [light.pack(index, s.light_samples) for index, light in enumerate(ctx.lights)]
        self.lights = (LightRecord * max(1, len(ctx.lights)))(*self.light_records)
        # The materials' records, those with node graphs naming their programs.
        self.graphs = graph_tables(ctx.materials, geometry.attribute_layout)
        self.material_records, self.materials = material_records(ctx.materials, self.graphs)
        self.shadows = ShadowSettings(robust=s.shadow_method == "robust", epsilon=s.epsilon,
                                      terminator_fix=s.terminator_fix, terminator_offset=s.terminator_offset)
        # The emissive meshes' and the world's tables (their records in self.lights say only how often).
        emitters = ctx.extra.get("emitters")
        self.emitter_tables = emitters.tables() if emitters is not None else None
        if emitters is not None and emitters.mesh is not None:      # (moving emitters: placed at each path's time)
            self.emitter_tables.record.geometry = self.tables.record
        self.world_tables = WorldTables(ctx.extra["world_light"], ctx.extra.get("world_sampler"))
        self.context = LightContext(emitters=self.emitter_tables.record if emitters is not None else None,
                                    world=self.world_tables.record)
        direct_cap, indirect_cap = limits(s)
        self.light_passes = lightpasses.wanted(s.passes)
        self.params = ChunkParams(
            camera=self.camera, geometry=self.tables.record, lights=self.lights, materials=self.materials,
            closure_room=closure_room(ctx.materials.shaders),
            shadows=self.shadows, graphs=self.graphs.record if self.graphs is not None else None,
            intersect8=packets.intersect8, occluded8=packets.occluded8, scene=packets.scene,
            light_context=self.context, light_count=len(ctx.lights), integrator=COMPILED_INTEGRATORS[s.integrator],
            sampling=SAMPLING[s.light_sampling], bsdf_rays=bool(ctx.extra.get("bsdf_rays")),
            emissive=bool(ctx.extra.get("emissive")), everywhere=bool(ctx.extra.get("bsdf_everywhere")),
            transparent=s.transparent_background, clear_glass=clear_glass_threshold(s), width=s.width, height=s.height,
            background=np.asarray(background, np.float64), luminance=adaptive.LUMINANCE, want_squares=s.adaptive,
            max_bounces=s.max_bounces, diffuse_bounces=s.diffuse_bounces, glossy_bounces=s.glossy_bounces,
            transmission_bounces=s.transmission_bounces, roulette_from=roulette_from(s),
            transparent_bounces=s.transparent_max_bounces, volume_bounces=s.volume_bounces,
            see_through=bool(ctx.extra.get("transparent")),
            walks=bool(ctx.extra.get("subsurface")),
            caustics=caustics_bits(s), filter_glossy=max(float(s.filter_glossy), 0.0), clamp_direct=direct_cap, clamp_indirect=indirect_cap,
            ao_bounces=s.ao_bounces if s.ao_factor != 0.0 and s.integrator == "path" else 0,
            ao_factor=float(s.ao_factor), ao_distance=float(s.ao_distance),
            ao_additive_factor=float(s.ao_additive_factor) if s.integrator == "path" else 0.0,
            light_passes=self.light_passes, split=bool(ctx.extra.get("catcher_split", False)),
            mnee=s.integrator == "path" and mnee_.active(ctx), cones=cones_read(ctx))
        self.want_squares = bool(s.adaptive)
        self.features = bool(s.denoising_features)
        self.params.features = self.features
        # The first-hit passes (core/integrators/passes.py): their layout and the scene's tables they read.
        self.layout = ctx.extra.get("pass_layout") or passes_.PassLayout((), 1)
        if self.layout:
            self.pass_tables = passes_.pass_tables(ctx, self.layout)
            self.params.passes = self.pass_tables
        # The media (core/volumes): their coefficients, and which materials hold or bound them.
        media = ctx.extra.get("media")
        if media is not None:
            self.media_tables = media.tables(ctx.extra["media_bounds"])
            self.params.media = self.media_tables
        # Shadow catchers (catcher.py): the catcher-only scene's records, for the caught samples' second paths.
        alone = ctx.extra.get("catcher")
        self.catcher = Compiled(alone, background) if alone is not None else None
        self.stop = stop = ctx.extra.get("stop")      # (base.StopFlag: read before each block of samples, chunk.c)
        if stop is not None:
            self.params.stop = stop.flag
        # The light groups (core/integrators/lightgroups.py): each light's, each object's, each emitter's.
        groups = ctx.extra.get("light_groups")
        self.group_count = groups.count if groups is not None else 0
        if groups is not None:
            for index in range(len(ctx.lights)):
                self.lights[index].group = int(groups.lights[index])
            self.instance_groups = library.contiguous(groups.instances, np.int32)
            self.params.light_groups = groups.count
            self.params.instance_groups = self.instance_groups if len(self.instance_groups) else None
            self.params.world_group = groups.world
            if emitters is not None:
                self.emitter_groups = groups.emitter_groups(geometry, emitters)
                self.emitter_tables.record.group = self.emitter_groups
            if media is not None and groups.media is not None and len(groups.media):
                # (each medium's object's group: its emission's, LightGroups.emission_groups)
                self.media_groups = library.contiguous(groups.media, np.int32)
                self.media_tables.groups = self.media_groups

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
        params = self.params.copy()
        params.seed = int(seed)
        nonfinite = np.zeros(p, np.int64)
        out = ChunkOut(rgba=rgba, squares=squares, hits=hits, nonfinite=nonfinite)
        aux = {}
        if self.light_passes:               # the light passes' sums (core/integrators/lightpasses.py)
            aux[lightpasses.FILM_BUFFER] = light = np.empty((p, lightpasses.FILM_CHANNELS))
            out.light = light
        if self.features:                   # the denoising features' sums (core/integrators/features.py)
            aux[features_.FILM_BUFFER] = feature = np.empty((p, features_.FILM_CHANNELS))
            out.features = feature
        if self.group_count:                # the light groups' sums (core/integrators/lightgroups.py)
            aux[lightgroups.FILM_BUFFER] = groups = np.empty((p, 3 * self.group_count))
            out.groups = groups
        if self.layout.sums:                # first-hit passes' and AOVs' sums, Cryptomatte's slots (passes.py)
            aux[passes_.FILM_BUFFER] = values = np.empty((p, self.layout.channels))
            out.passes = values
        if self.layout.mattes:
            aux[passes_.MATTE_BUFFER] = mattes = np.empty((p, len(self.layout.mattes) * self.layout.slots * 2))
            out.mattes = mattes
        if self.catcher is not None:        # the shadow catchers' sums, and their catcher-only scene (catcher.py)
            aux[catcher_.FILM_BUFFER] = caught = np.empty((p, catcher_.FILM_CHANNELS))
            out.catcher = caught
            alone = self.catcher.params.copy()
            alone.seed = int(seed)
            params.catcher = alone
        library.call("primer_render_chunk", ChunkArgs(params=params, pixels=pixels, first=first, p=p, spp=int(spp),
                                                      out=out))
        if self.stop is not None and self.stop.flag[0]:
            raise Cancelled()                   # (stopped part way: its sums are incomplete)
        self.tracer.count_intersect(out.seconds[0])
        self.tracer.count_occluded(out.seconds[1])
        return ChunkSums(rgba, squares if squares is not None else np.zeros((p, 2)), hits, aux, int(out.counts[0]),
                         int(out.counts[1]), spp, out.seconds[0], out.seconds[1], out.seconds[2],
                         nonfinite=nonfinite)
