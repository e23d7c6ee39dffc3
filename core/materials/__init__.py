"""Materials: what a surface does with the light that reaches it, as closures of BSDFs in one table.

core/materials/registry.py holds the tables: a BSDF's (a shader node's) `kind` tag is its class's position in
BSDF_TYPES (NODE_TYPES), and the C code, generated from them, dispatches on the same tag. To add a BSDF, write its
class (core/materials/base.py says what it implements and which flags say what it is), its C file, and one entry
in the registry. What a closure is (diffuse, glossy, transmission, singular) its BSDF's flags say (`has`).

A scene's materials become one MaterialTable per render: a row per material and a last row for
triangles without a material (Blender's default grey, diffuse). `MaterialTable.shade` turns hits
into ShaderResults (core/materials/closures.py): a constant material is the same closures at every
hit, with only the normal changing.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from ..native import schema
from .base import BSDF, BSDFFlags, BsdfSample, flags_of, has, specular_roughness_squared
from .finite import finite_color, finite_value
from .closures import (NODE_PARAMS, PARAMS, ClosureSample, Closures, ShaderResult, concatenate,
                       constant_result, eval_closures, sample_closures)
from .registry import (BSDF_BY_NAME, BSDF_TYPES, NODE_BY_NAME, NODE_TYPES, Glass, Lambert, Microfacet, Mirror,
                       OrenNayar, RoughGlass, Sheen, Transparent, Velvet)

# The colour used when a triangle's material is missing (Blender's default grey).
DEFAULT_BASE_COLOR = (0.8, 0.8, 0.8)


@dataclass
class Material:
    """A surface's material: one BSDF from the table (by name), its colour, and what it emits.

    base_color: (3,) float64 in 0..1, the BSDF closure's weight (the Lambert albedo, the mirror's tint)
    bsdf:       a name in BSDF_BY_NAME ("DIFFUSE" or "MIRROR")
    emission:   (3,) float64 emitted radiance L_e = colour x strength (W / (m^2 sr)), from both sides
    emission_sampling: from which sides light samples find its triangles (Blender's Material > Settings >
                Emission Sampling): "NONE", "FRONT", "BACK", "FRONT_BACK", or "AUTO" (both sides when the
                emission exceeds 0.5 in some channel, as Cycles decides; else none: BSDF rays still find it), or
                "AUTO_CONVERTED" (Auto for a surface Cycles made an Emission shader of: above 5)
    transparent_shadows: whether shadow rays pass it where it lets light through (Blender's Material >
                Settings > Transparent Shadows, which Cycles reads): False makes it opaque to shadow rays only
    nodes:      the shader nodes of its node tree, when it has more than one colour to say (a Principled,
                Glossy or Mix of them): (name in NODE_BY_NAME, weight (3,), inputs dict[, factors]) each.
                An input may be a graph.Link (a texture or colour node feeding it, evaluated per hit); factors,
                a list of (graph.Link, "fac" | "one_minus" | "color"), multiply the weight per hit (a Mix
                Shader's linked factor, a Diffuse BSDF's linked colour); inputs["normal"] may be a Link (Normal
                Map, Bump). When given, the nodes decide the surface and its emission; base_color, bsdf and
                emission are ignored.
    pass_index: Blender's Material > Settings > Pass Index, what the Material Index pass shows
    volume:     the closures of its Volume output, [(name in core/volumes VOLUME_BY_NAME, weight float, inputs
                dict)], the medium inside its closed meshes (core/volumes); empty: none
    normal:     a graph.Link or None: Cycles' Set Normal, the hit's shading normal (sd->N) from the graph, which every
                node's closures default to and bump shadowing compares with (a Displacement output rendered as bump,
                addon/materials.py displacement_bump); None: the hit's interpolated normal
    volume_only: a Volume and no Surface: its surface is a boundary rays pass through without counting a bounce
                (Cycles' SD_HAS_ONLY_VOLUME); `nodes` then holds one white Transparent node
    volume_space: for a heterogeneous medium (a volume input fed by a link), the space its graph reads at a point:
                (world-to-object (3, 4) float64, texture space location (3,), size (3,)) of the object that holds it
                (its Object and Generated coordinates), and for a Volume object a 4th item, its [grids.Grid] (the
                voxel grids its graph reads: core/volumes/grids.py); None: the world's (core/volumes/field.py)
    displacement: a graph.Link (or a constant (3,)) of its Displacement output, the world-space offset by which it
                moves its meshes' vertices (core/geometry/displacement.py), with Displacement Method `displacement_method`
                "DISPLACEMENT" (Displacement Only: normals from the moved faces) or "BOTH" (Displacement and Bump: the
                mesh's normals, the bump in `normal`); None: its surface stays where it is (Bump Only, or no output)
    aovs:       its AOV Output nodes, [(AOV name, Color: (3,) or a graph.Link, Value: float or a graph.Link)]: what
                camera paths write into the render's shader AOVs of that name (core/integrators/passes.py); `nodes`
                then decide the surface (a material with AOV Outputs is never the constant one)
    """

    base_color: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_BASE_COLOR))
    name: str = "Material"
    bsdf: str = "DIFFUSE"
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))
    emission_sampling: str = "AUTO"
    nodes: list = field(default_factory=list)
    transparent_shadows: bool = True
    pass_index: int = 0
    volume: list = field(default_factory=list)
    volume_only: bool = False
    normal: Optional[object] = None
    volume_space: Optional[tuple] = None
    displacement: Optional[object] = None
    displacement_method: str = "BUMP"
    bump_map_correction: bool = True
    aovs: list = field(default_factory=list)


# The sides a material's emitting triangles are sampled from (core/lights/emitters.py FRONT | BACK).
EMISSION_SIDES = {"NONE": 0, "FRONT": 1, "BACK": 2, "FRONT_BACK": 3}


def emission_sides(method: str, estimate: np.ndarray) -> int:
    """The sides of Emission Sampling `method` for an emission estimate (3,): AUTO is both sides when some
    channel exceeds 0.5 (Cycles' Shader::estimate_emission), else none; AUTO_CONVERTED (Auto, the surface an
    Emission shader that Cycles made of a colour or value linked into it) when some channel exceeds 5 (Cycles
    scales such an estimate by 0.1)."""
    if method in ("AUTO", "AUTO_CONVERTED"):
        limit = 5.0 if method == "AUTO_CONVERTED" else 0.5
        return 3 if float(np.max(np.abs(estimate))) > limit else 0
    return EMISSION_SIDES.get(method, 3)


# The surface of triangles without a material: Cycles' default surface, a Principled BSDF with its defaults.
DEFAULT_SURFACE = Material(name="(default)", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {})])


@dataclass
class ConstantShader:
    """A material whose closures are the same at every hit (only their normal follows the hit).

    kinds (K,) int32; weights (K, 3); sample_weights (K,); params (K, PARAMS); emission (3,);
    transparency (3,); emission_sides: FRONT 1 | BACK 2 from which light samples find its triangles
    """

    kinds: np.ndarray
    weights: np.ndarray
    sample_weights: np.ndarray
    params: np.ndarray
    emission: np.ndarray
    transparency: np.ndarray
    emission_sides: int = 3

    @classmethod
    def of(cls, material: Material, notes: Optional[list] = None) -> "ConstantShader":
        """One closure, the material's BSDF weighted by its colour (clipped to 0..1); a NaN or infinite channel of
        the colour or emission reads 0 (core/materials/finite.py), named in `notes`."""
        if material.bsdf not in BSDF_BY_NAME:
            raise ValueError(f"material '{material.name}' asks for BSDF {material.bsdf!r}; "
                             f"Primer knows {sorted(BSDF_BY_NAME)}")
        color, bad_color = finite_color(material.base_color)
        emission, bad_emission = finite_color(material.emission)
        color, emission = np.clip(color, 0.0, 1.0), np.maximum(emission, 0.0)
        if notes is not None:
            notes.extend(name for name, bad in (("base colour", bad_color), ("emission", bad_emission)) if bad)
        return cls(np.array([BSDF_BY_NAME[material.bsdf].kind], np.int32), color[None, :],
                   np.array([abs(color.mean())]), np.zeros((1, PARAMS)), emission, np.zeros(3),
                   emission_sides(material.emission_sampling, emission))

    @property
    def may_let_light_through(self) -> bool:
        """Whether its hits let light through (a constant transparency)."""
        return bool(np.asarray(self.transparency).any())

    @property
    def closures_at_most(self) -> int:
        """The most closures a hit of it has: its K."""
        return len(self.kinds)

    def shade(self, N: np.ndarray, wo: Optional[np.ndarray] = None, backfacing=None, caustics=None,
              blur=None) -> ShaderResult:
        """The ShaderResult at hits with shading normals N (n, 3) (the same from every direction wo); caustics:
        (n,) int filter bits (closures.FILTER_*) that take away its reflective or refractive closure, or None;
        blur: (n,) the roughness Filter Glossy gives its microfacet lobes (nodes.roughen), or None."""
        result = constant_result(len(N), N, self.kinds, self.weights, self.sample_weights, self.params,
                                 self.emission, self.transparency)
        if blur is not None and np.any(blur > 0.0):
            from .nodes import roughen
            params = np.array(result.closures.params)             # (the rows are shared: blur a copy)
            for k in range(params.shape[1]):
                roughen(result.closures.kind[:, k], params[:, k], np.broadcast_to(blur, (len(N),)))
            result = result._replace(closures=result.closures._replace(params=params))
        if caustics is not None and np.any(caustics):
            filtered = caustics_filtered(result.closures.kind, np.asarray(caustics))
            result.closures.kind[filtered] = -1
            result.closures.weight[filtered] = 0.0
            result.closures.sample_weight[filtered] = 0.0
        return result


@dataclass
class NodeShader:
    """A material made of shader nodes (core/materials/nodes.py), set up per hit for its view direction.

    nodes: (node class, weight (3,), inputs (NODE_PARAMS,)) each, linked inputs at their own values;
    emission, transparency (3,): what it emits and lets through seen head-on with the inputs' own values
    (the emitters' power and the `emissive` flag use it); emission_sides as ConstantShader's;
    graph: the nodes with their links [(node class, weight, inputs, factors)], None when nothing is linked
    (then the nodes are the same at every hit); programs: its compiled graph per attribute layout; normal: the
    Material's `normal` (a Link: the hit's shading normal from the graph) or None; bump_map_correction: the
    Material's.
    """

    nodes: list
    emission: np.ndarray
    transparency: np.ndarray
    emission_sides: int = 3
    graph: Optional[list] = None
    programs: dict = field(default_factory=dict)
    graph_emits: bool = False
    normal: Optional[object] = None
    bump_map_correction: bool = True
    aovs: list = field(default_factory=list)
    aov_channels: int = 0

    @classmethod
    def of(cls, material: Material, notes: Optional[list] = None, aovs: Optional[dict] = None) -> "NodeShader":
        """The material's nodes, their inputs read as Cycles reads a NaN or an infinity (core/materials/finite.py),
        each one changed named in `notes` ("Principled base_color"); aovs: the render's shader AOVs (passes.aov_slots:
        name -> (first channel, channels)) its AOV Output nodes write (with_aovs)."""
        return cls._of(material, notes).with_aovs(material, aovs or {})

    def with_aovs(self, material: Material, slots: dict) -> "NodeShader":
        """Itself with the AOV Output nodes of `material` that name one of the render's shader AOVs `slots` (name ->
        (first channel, channels: 4 COLOR, 1 VALUE)): `aovs` [(first channel, channels, its Color or Value)], in the
        program after its AOV_START op (graph.Compiler.compile); its graph then runs even without links. A node that
        names an AOV the view layer lacks writes nothing, as in Cycles (OutputAOVNode: offset -1, not compiled)."""
        wanted = [(slots[name][0], slots[name][1], color if slots[name][1] == 4 else value)
                  for name, color, value in material.aovs if name in slots]
        if not wanted:
            return self
        # (constant inputs: their rows hold them already)
        graph = self.graph if self.graph is not None else [(node, weight, {}, ()) for node, weight, _ in self.nodes]
        return replace(self, graph=graph, aovs=wanted, aov_channels=sum(channels for _, channels in slots.values()),
                       programs={})

    @classmethod
    def _of(cls, material: Material, notes: Optional[list] = None) -> "NodeShader":
        """NodeShader.of without the AOVs."""
        from . import graph as graph_
        from . import nodes as nodes_
        rows, linked = [], []
        for entry in material.nodes:
            name, weight, inputs = entry[:3]
            if name not in NODE_BY_NAME:
                raise ValueError(f"material '{material.name}' has shader node {name!r}; "
                                 f"Primer knows {sorted(NODE_BY_NAME)}")
            node = NODE_BY_NAME[name]
            clean = {}
            for key, value in inputs.items():
                if not isinstance(value, graph_.Link):
                    clean[key], changed = finite_value(key, value)
                    if changed and notes is not None:
                        notes.append(f"{node.name.title()} {key}")
            weight, changed = finite_color(weight)
            if changed and notes is not None:
                notes.append(f"{node.name.title()} weight")
            rows.append((node, weight, node.row(clean)))
            linked.append((node, weight, inputs, tuple(entry[3]) if len(entry) > 3 else ()))
        head_on = nodes_.shade_nodes(rows, np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]))
        # The emission light samples use is what other surfaces see: a shader mixed by Light Path's Is Camera
        # Ray shows the camera one part and every other ray the other (glTF's unlit materials emit nothing).
        emitted = head_on.emission[0]
        factors = [_bounce_factor(entry) for entry in linked]
        if any(factor != 1.0 for factor in factors):
            lit = [(node, weight * factor, p) for (node, weight, p), factor in zip(rows, factors)]
            emitted = nodes_.shade_nodes(lit, np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]])).emission[0]
        emission = np.maximum(emitted, 0.0)
        normal = material.normal if isinstance(material.normal, graph_.Link) else None
        graph = linked if graph_.has_links(material.nodes) or normal is not None else None
        estimate = graph_emission_estimate(linked, rows) if graph_.has_links(material.nodes) else None
        if estimate is None:
            return cls(rows, emission, head_on.transparency[0], emission_sides(material.emission_sampling, emission),
                       graph, normal=normal, bump_map_correction=material.bump_map_correction)
        # Its emission comes from the graph (a texture, a linked factor): light samples and BSDF rays evaluate it
        # where they land, and Emission Sampling Auto decides on Cycles' estimate of it.
        return cls(rows, emission, head_on.transparency[0], emission_sides(material.emission_sampling, estimate),
                   graph, graph_emits=True, normal=normal, bump_map_correction=material.bump_map_correction)

    @property
    def closures_at_most(self) -> int:
        """The most closures a hit of it sets up: its nodes' slots and the Transparent closure of the light let
        through (nodes.closures_at_most)."""
        from . import nodes as nodes_
        return nodes_.closures_at_most(self.nodes)

    @property
    def may_let_light_through(self) -> bool:
        """Whether some hit may let light through: a Transparent node, a node that passes light somewhere
        (Node.lets_light_through: hair, from inside its tube), or an alpha below 1 or fed by a link."""
        from . import graph as graph_
        if np.asarray(self.transparency).any():
            return True
        for node, _, inputs, _ in (self.graph or ()):
            if node.name == "TRANSPARENT" or node.lets_light_through or isinstance(inputs.get("alpha"), graph_.Link):
                return True
        return False

    def program(self, layout: dict, image_index, name: str = "", view=None, window=None):
        """Its graph compiled for an attribute layout, the camera's world-to-camera transform `view` ((3, 4) or
        None: the identity) and its frame `window` (MaterialTable.window) (core/materials/graph.py), once for each;
        None without links."""
        from . import graph as graph_
        if self.graph is None:
            return None
        key = (tuple(sorted(layout.items())), None if view is None else tuple(np.asarray(view).ravel()), window)
        if key not in self.programs:
            self.programs[key] = graph_.Compiler(layout, image_index, material=name, view=view,
                                                 window=window).compile(self.graph, self.normal, self.aovs)
        return self.programs[key]

    def shade(self, N: np.ndarray, wo: np.ndarray, point=None, program=None, textures=None,
              backfacing: Optional[np.ndarray] = None, caustics=None, blur=None) -> ShaderResult:
        """The ShaderResult at hits with shading normals N (n, 3) seen from wo (n, 3), hit from behind where
        `backfacing` (n,) bool (glass bends light leaving an object the other way), with the caustics filter
        bits (n,) int (closures.FILTER_*) or None; with a program, its outputs at the ShadingPoint `point`
        replace the linked inputs, weights and normals first; blur: (n,) Filter Glossy's roughness, or None."""
        from . import graph as graph_
        from . import nodes as nodes_
        if program is None:
            return nodes_.shade_nodes(self.nodes, N, wo, backfacing=backfacing, caustics=caustics, blur=blur)
        n = len(N)
        if point.I is None and wo is not None:
            point = point._replace(I=wo)                  # the view direction (the Fresnel and Layer Weight nodes)
        registers = graph_.run(program, point, textures)
        weights = [np.broadcast_to(weight, (n, 3)).astype(np.float64) for _, weight, _ in self.nodes]
        rows = [np.tile(p, (n, 1)) for _, _, p in self.nodes]
        normals = [None] * len(self.nodes)
        corrected = self.bump_map_correction          # (off: nodes' normals as the graph gives them)
        hit_normal = graph_.apply_outputs(program, registers, weights, rows, normals, point.Ng if corrected else None,
                                          wo)
        if hit_normal is not None:                    # (Set Normal: the hit's own normal, where the graph gives one)
            N = np.where(np.any(hit_normal != 0.0, axis=1)[:, None], hit_normal, N)
        glossy = [None if normal is None or not corrected else graph_.valid_reflection(point.Ng, wo, normal)
                  for normal in normals]
        result = nodes_.shade_nodes(self.nodes, N, wo, (weights, rows, normals), glossy, backfacing=backfacing,
                                    caustics=caustics, blur=blur)
        if self.aovs:                                 # (its AOV Output nodes' values: passes.at_vertex keeps them)
            result = result._replace(aov=graph_.aov_values(program, registers, self.aov_channels))
        if corrected:
            return result
        return result._replace(closures=result.closures._replace(uncorrected=np.ones(n, bool)))


def reflective(kind) -> np.ndarray:
    """Which closures of kind `kind` (int, any shape) are glossy or mirror reflections, what Cycles' Reflective
    Caustics switch takes away (labelled glossy or singular, reflection only): bool, kind's shape."""
    flags = flags_of(kind)
    lobe = (flags & (BSDFFlags.GLOSSY | BSDFFlags.SINGULAR)) != 0
    return lobe & ((flags & BSDFFlags.REFLECTION) != 0) & ((flags & BSDFFlags.TRANSMISSION) == 0)


def caustics_filtered(kind: np.ndarray, caustics: np.ndarray) -> np.ndarray:
    """Which of a constant material's closures kind (n, K) a caustics filter (n,) int takes away: reflective
    ones (a mirror, a glossy lobe) with FILTER_REFLECTIVE, glass with both bits: (n, K) bool."""
    from .closures import FILTER_REFLECTIVE, FILTER_REFRACTIVE
    bits = caustics[:, None]
    glass = has(kind, BSDFFlags.GLASS_TYPE)
    both = FILTER_REFLECTIVE | FILTER_REFRACTIVE
    return (reflective(kind) & ((bits & FILTER_REFLECTIVE) != 0)) | (glass & ((bits & both) == both))


def graph_emission_estimate(linked: list, rows: list) -> Optional[np.ndarray]:
    """Cycles' estimate (3,) of what a node material emits where its node graph decides it (Shader::
    estimate_emission: a linked colour or strength counts as 1, a node under a linked mix factor at full
    weight), or None where the graph changes no emission (then the head-on value is exact for other rays).

    linked: the NodeShader's (node class, weight, inputs, factors) entries; rows: its (node, weight, p) rows.
    """
    from . import graph as graph_
    estimate, varies = np.zeros(3), False
    for (node, _, inputs, factors), (_, weight, _) in zip(linked, rows):
        value = inputs.get("emission")
        if value is None:
            continue
        if isinstance(value, graph_.Link):
            own = np.ones(3)
            if value.node.kind == "SCALE":            # colour x strength (addon/materials.py _scaled)
                color, strength = value.node.inputs.get("Color"), value.node.inputs.get("Factor")
                own = (np.ones(3) if isinstance(color, graph_.Link) else np.asarray(color, np.float64)[:3]) * \
                      (1.0 if isinstance(strength, graph_.Link) else float(strength))
            varies = True
        else:
            own = np.asarray(value, np.float64)[:3]
        if not np.any(own > 0.0) or _bounce_factor((node, weight, inputs, factors)) == 0.0:
            continue                                  # emits nothing, or only towards the camera
        if any(isinstance(factor, graph_.Link) for factor, _ in factors):
            varies = True
            estimate += own                           # a linked mix factor: the node at full weight
        else:
            estimate += own * np.asarray(weight, np.float64)[:3]
    return np.maximum(estimate, 0.0) if varies else None


def _bounce_factor(entry: tuple) -> float:
    """The factor a node's Light Path Mix factors give it for rays other than the camera's: 0 where it is the
    camera's side of such a Mix, 1 otherwise (other factors keep their inputs' own values, as before)."""
    from . import graph as graph_
    for value, mode in entry[3]:
        if (isinstance(value, graph_.Link) and value.node.kind == "LIGHT_PATH" and value.output == "Is Camera Ray"
                and mode == "fac"):
            return 0.0
    return 1.0


def shader_of(material: Material, warnings: Optional[list] = None, aovs: Optional[dict] = None):
    """A material's shader: its nodes where it has them, else one constant closure; a NaN or infinite input read as
    Cycles reads it (core/materials/finite.py) is noted in `warnings`, naming the material; aovs: the render's shader
    AOVs (NodeShader.with_aovs)."""
    notes: list = []
    shader = NodeShader.of(material, notes, aovs) if material.nodes else ConstantShader.of(material, notes)
    if notes and warnings is not None:
        note = (f"material '{material.name}': {', '.join(notes)} NaN or infinite; Primer reads it as Cycles renders "
                "it: 0 (a clamped input such as roughness: its bound), so that the closure or emission drops out")
        if note not in warnings:
            warnings.append(note)
    return shader


def aov_sources(shader) -> list:
    """The AOV Output nodes a shader compiles (NodeShader.aovs) as Material.aovs entries, for with_normal."""
    return [("", source, source) for _, _, source in getattr(shader, "aovs", ())]


class MaterialTable:
    """The scene's materials as the integrators read them: a shader per material, the default last.

    shaders: one ConstantShader per material, then the default (diffuse grey)
    """

    def __init__(self, shaders: list, names: list, shadow_opaque=None):
        from . import graph as graph_
        from .textures import TextureSet
        self.shaders = shaders
        self.names = names
        # Which rows block shadow rays even where they let light through (Transparent Shadows off): (m + 1,) bool.
        self.shadow_opaque = np.zeros(len(shaders), bool) if shadow_opaque is None else np.asarray(shadow_opaque, bool)
        # Which rows may let light through somewhere (a Transparent node, alpha): (m + 1,) bool.
        self.may_pass = np.array([bool(shader.may_let_light_through) for shader in shaders], bool)
        # Which rows have a Holdout shader node (a hole in the film where camera paths meet it): (m + 1,) bool.
        self.holds_out = np.array([any(node.name == "HOLDOUT" for node, *_ in getattr(shader, "nodes", ()))
                                   for shader in shaders], bool)
        # The images the node graphs read, in one TextureSet (core/materials/textures.py); None is missing.
        self.images: list = []
        self._image_rows: dict = {}
        for shader in shaders:
            graph = getattr(shader, "graph", None)
            linked = graph_.with_normal(graph, shader.normal, aovs=aov_sources(shader)) if graph else ()
            for image in graph_.images_of(linked) if graph else ():
                self.image_index(image)
        self.textures = TextureSet.of(self.images)
        # The camera's world-to-camera transform (3, 4) the graphs' Camera coordinates read (set by render.prepare;
        # None: the identity).
        self.view: Optional[np.ndarray] = None
        # The camera's frame on screen (left, right, bottom, top, 1 perspective / 0 orthographic) the Window
        # coordinates read (set by render.prepare; None: a panoramic camera, whose Window Primer does not compute).
        self.window: Optional[tuple] = None
        self._has_graphs = any(getattr(shader, "graph", None) is not None for shader in shaders)
        # Whether some material's graph traces rays (an Ambient Occlusion or Bevel node, graph.RAYTRACE_OPS): then the
        # integrators hand shade the hits' ShaderRays (core/integrators/shader_rays.py); otherwise they make none.
        self.traces = any(graph_.traces(graph_.with_normal(shader.graph, shader.normal, aovs=aov_sources(shader)))
                          for shader in shaders if getattr(shader, "graph", None))
        # Which rows' emission their node graph gives (a texture, a linked factor), evaluated where a light sample
        # or a BSDF ray lands rather than taken from `emission`: (m + 1,) bool.
        self.graph_emits = np.array([bool(getattr(shader, "graph_emits", False)) for shader in shaders], bool)

    def image_index(self, image) -> int:
        """The row of a textures.Image in the table's TextureSet; -1 for a missing image (None)."""
        if image is None:
            return -1
        if id(image) not in self._image_rows:
            self._image_rows[id(image)] = len(self.images)
            self.images.append(image)
        return self._image_rows[id(image)]

    @property
    def has_graphs(self) -> bool:
        """Whether some material has inputs fed by a node graph (then shading reads the hits' attributes)."""
        return self._has_graphs

    def program(self, row: int, layout: dict):
        """The compiled graph of material `row` for an attribute layout, or None (no links)."""
        shader = self.shaders[row]
        return (shader.program(layout, self.image_index, self.names[row], self.view, self.window)
                if hasattr(shader, "program") else None)

    @classmethod
    def of(cls, materials: list, default: Optional[Material] = None, warnings: Optional[list] = None,
           aovs: Optional[dict] = None) -> "MaterialTable":
        """Build the table of `materials` and the `default` surface (the grey Lambert surface unless given);
        an unknown BSDF or node name is refused with a clear message; NaN or infinite inputs go to `warnings`;
        aovs: the render's shader AOVs (core/integrators/passes.py aov_slots; None: none) the materials' AOV Output
        nodes write."""
        default = default if default is not None else Material()
        shaders = [shader_of(m, warnings, aovs) for m in materials] + [shader_of(default, warnings, aovs)]
        opaque = [not getattr(m, "transparent_shadows", True) for m in list(materials) + [default]]
        return cls(shaders, [m.name for m in materials] + ["(default)"], opaque)

    @property
    def emission(self) -> np.ndarray:
        """Each row's emitted radiance as light samples see it (a node material's head-on value): (m + 1, 3)."""
        return np.array([np.asarray(shader.emission, np.float64) for shader in self.shaders])

    @property
    def emissive(self) -> np.ndarray:
        """Which rows emit: (m + 1,) bool."""
        return np.array([shader.emission.max() > 0.0 for shader in self.shaders])


    def shade(self, material: np.ndarray, N: np.ndarray, wo: np.ndarray, surface=None,
              geometry=None, path=None, caustics=None, rays=None, blur=None) -> ShaderResult:
        """Return the ShaderResult of n hits: material (n,) int32 rows, N (n, 3) shading normals, wo (n, 3).

        surface, geometry: the hits' Surface and the WorldGeometry (core/geometry), which materials with node
        graphs read their attributes from (without them, every attribute reads 0). path: the paths that reached
        the hits (a graph.LightPaths of n rows or of scalars, for the Light Path node; None: camera rays); caustics:
        (n,) int the closures a caustics filter takes away at each hit (closures.FILTER_*), or None. rays: the hits'
        ShaderRays (core/integrators/shader_rays.py) that Ambient Occlusion and Bevel nodes trace, or None (then they
        trace nothing: AO 1, Bevel the shading normal, as Cycles' shadow and light-sample shaders). blur: (n,)
        float64 the roughness Cycles' Filter Glossy raises microfacet lobes to at each hit (0: none), or None.
        """
        from . import graph as graph_
        n = len(material)
        backfacing = getattr(surface, "backfacing", None)
        if caustics is not None:
            caustics = np.broadcast_to(np.asarray(caustics, np.int64), (n,))
            if not caustics.any():
                caustics = None
        if blur is not None:
            blur = np.broadcast_to(np.asarray(blur, np.float64), (n,))
            if not (blur > 0.0).any():
                blur = None
        first = int(material[0]) if n else len(self.shaders) - 1
        if n == 0 or (not self.has_graphs and (material == first).all()):
            return self.shaders[first].shade(N, wo, backfacing=backfacing, caustics=caustics, blur=blur)
        point = None
        results, order = [], []
        for row in np.unique(material):
            rows = np.flatnonzero(material == row)
            shader = self.shaders[int(row)]
            if getattr(shader, "graph", None) is None:
                results.append(shader.shade(N[rows], None if wo is None else wo[rows],
                                            backfacing=None if backfacing is None else backfacing[rows],
                                            caustics=None if caustics is None else caustics[rows],
                                            blur=None if blur is None else blur[rows]))
            else:
                layout = geometry.attribute_layout if geometry is not None else {}
                if point is None:
                    point = self.shading_point(surface, geometry, N)
                    if path is not None:                      # the paths that reached the hits (the Light Path node)
                        point = point._replace(path=graph_.as_light_paths(path, n))
                    if wo is not None:                        # the view direction (Fresnel, Layer Weight)
                        point = point._replace(I=np.asarray(wo, np.float64))
                    if rays is not None:                      # the scene, for Ambient Occlusion and Bevel
                        point = point._replace(rays=rays)
                part = type(point)(*(None if array is None else graph_.paths_at(array, rows)
                                     if isinstance(array, graph_.LightPaths) else array[rows] for array in point))
                results.append(shader.shade(N[rows], wo[rows], part, self.program(int(row), layout), self.textures,
                                            backfacing=None if backfacing is None else backfacing[rows],
                                            caustics=None if caustics is None else caustics[rows],
                                            blur=None if blur is None else blur[rows]))
            order.append(rows)
        if len(results) == 1:
            return results[0]
        return concatenate(results, order, n)

    @staticmethod
    def shading_point(surface, geometry, N: np.ndarray):
        """The hits' ShadingPoint (core/geometry/surface.py), or one without attributes."""
        from . import graph as graph_
        if surface is None or geometry is None:
            return graph_.empty_point(len(N), 0)._replace(N=N, Ng=N)
        return geometry.shading_point(surface)


__all__ = ["BSDF", "BSDFFlags", "BSDF_BY_NAME", "BSDF_TYPES", "BsdfSample", "ClosureSample", "Closures",
           "ConstantShader", "DEFAULT_BASE_COLOR", "DEFAULT_SURFACE", "Glass", "Lambert", "Material",
           "MaterialTable", "Microfacet", "Mirror", "NODE_BY_NAME", "NODE_PARAMS", "NODE_TYPES", "NodeShader",
           "OrenNayar", "PARAMS", "RoughGlass", "ShaderResult", "Sheen", "Transparent", "Velvet", "eval_closures",
           "flags_of", "has", "reflective", "sample_closures", "specular_roughness_squared"]


BsdfArgs = schema.function("primer_bsdf", "bsdf_rows", schema.record(
    "BsdfArgs", "primer_bsdf's arguments: eval and a sample of one closure per row (bsdf.c), for the tests.", [
        ("n", schema.I64, ""),
        ("kind", schema.ptr(schema.I32), "(n,) BSDF_*"),
        ("weight", schema.ptr(schema.F64), "(n, 3)"),
        ("N", schema.ptr(schema.F64), "(n, 3)"),
        ("Ns", schema.ptr(schema.F64), "(n, 3) the hit's smooth normal (sd->N: bump shadowing where it is not N)"),
        ("params", schema.ptr(schema.F64), "(n, CLOSURE_PARAMS)"),
        ("wo", schema.ptr(schema.F64), "(n, 3)"),
        ("wi", schema.ptr(schema.F64), "(n, 3)"),
        ("u", schema.ptr(schema.F64), "(n, 2)"),
        ("f_cos", schema.out(schema.F64), "(n, 3)"),
        ("pdf", schema.out(schema.F64), "(n,)"),
        ("sampled", schema.out(schema.F64), "(n, 3)"),
        ("sampled_weight", schema.out(schema.F64), "(n, 3)"),
        ("sampled_pdf", schema.out(schema.F64), "(n,)"),
    ], tables=("BSDF",)))


def compiled_bsdf(kind: np.ndarray, weight: np.ndarray, N: np.ndarray, params: np.ndarray, wo: np.ndarray,
                  wi: np.ndarray, u: np.ndarray, Ns=None) -> tuple:
    """One closure per row in C (the generated BSDF table), for the tests: eval and a sample of a ShaderResult
    holding only that closure -> f cos (n, 3), pdf (n,), ClosureSample (pick 0.5). Ns: (n, 3) the hits' smooth
    normal (closures.bump_shadowing where it is not the closure's N), or None: N."""
    from ..native import library
    n = len(kind)
    c = library.contiguous
    f_cos, pdf, sampled, sampled_weight, sampled_pdf = (np.empty((n, 3)), np.empty(n), np.empty((n, 3)),
                                                       np.empty((n, 3)), np.empty(n))
    library.call("primer_bsdf", BsdfArgs(
        n=n, kind=c(kind, np.int32), weight=c(weight, np.float64), N=c(N, np.float64),
        Ns=c(N if Ns is None else Ns, np.float64), params=c(params, np.float64),
        wo=c(wo, np.float64), wi=c(wi, np.float64), u=c(u, np.float64), f_cos=f_cos, pdf=pdf, sampled=sampled,
        sampled_weight=sampled_weight, sampled_pdf=sampled_pdf))
    return f_cos, pdf, ClosureSample(sampled, sampled_weight, sampled_pdf, np.isinf(sampled_pdf))
