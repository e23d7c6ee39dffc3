"""Blender materials as Primer reads them: the node tree at the Material Output, as a list of shader nodes.

From the Surface socket down, Mix Shader and Add Shader nodes are multiplied out into one weight per
BSDF node (Principled, Diffuse, Glossy, Glass, Refraction, Sheen, Emission, Transparent), with each node's inputs
(core/materials/nodes.py sets them up per hit, as Cycles does). An anisotropic Principled or Glossy BSDF whose
Tangent is unlinked gets Cycles' default tangent: a Tangent node, Radial about Z of the Generated coordinates.
A plain Diffuse BSDF stays the lecture's constant Lambert material. An input fed by a link becomes a
core/materials/graph.py Link to the sub-graph that feeds it (image textures, texture coordinates, Math, Mix,
Color Ramp, Tangent ...; reroutes skipped, node groups flattened), evaluated per hit; a linked Mix Shader factor or BSDF colour becomes a
per-hit factor of the node's weight. Whatever Primer cannot read (a node it does not know, a missing image)
gets a warning that names the material and the node and says what Primer
used instead.
"""
from __future__ import annotations

import hashlib
import os
import tempfile

import bpy
import numpy as np

from ..core.materials import NODE_TYPES, Material
from ..core.materials import closures as closures_
from ..core.materials import graph as graph_
from ..core.materials import hair as hair_
from ..core.materials import huang as huang_
from ..core.materials import ies as ies_
from ..core.materials import nodes as nodes_
from ..core.materials import sky as sky_
from ..core.materials import subsurface as subsurface_
from ..core.materials import textures as textures_
from ..core.geometry.geometry import OBJECT_INFO_WIDTH
from ..core.materials.graph import GraphNode, Link
from ..core.materials.converters import CONVERTER_BY_BLENDER
from ..core.materials.converters.curves import CURVE_TABLE_SIZE, curve_table
from ..core.materials.converters.ies_texture import ies_props
from ..core.materials.procedural import TEXTURE_BY_BLENDER
from ..core.materials.procedural import hash as hash_
from ..core.volumes import VOLUME_BY_BLENDER
from . import movie as movie_
from . import unmodelled

# Principled BSDF sockets -> core/materials/nodes.py PRINCIPLED_INPUTS.
PRINCIPLED_SOCKETS = {"Base Color": "base_color", "Metallic": "metallic", "Roughness": "roughness", "IOR": "ior",
                      "Alpha": "alpha", "Subsurface Weight": "subsurface", "Specular IOR Level": "specular_ior_level",
                      "Specular Tint": "specular_tint", "Coat Weight": "coat", "Coat Roughness": "coat_roughness",
                      "Coat IOR": "coat_ior", "Coat Tint": "coat_tint", "Transmission Weight": "transmission",
                      "Diffuse Roughness": "diffuse_roughness", "Sheen Weight": "sheen",
                      "Sheen Roughness": "sheen_roughness", "Sheen Tint": "sheen_tint", "Anisotropic": "anisotropic",
                      "Anisotropic Rotation": "anisotropic_rotation", "Thin Film Thickness": "thin_film_thickness",
                      "Thin Film IOR": "thin_film_ior", "Subsurface Radius": "subsurface_radius",
                      "Subsurface Scale": "subsurface_scale", "Subsurface IOR": "subsurface_ior",
                      "Subsurface Anisotropy": "subsurface_anisotropy"}
# Principled inputs Primer leaves out: socket -> what Primer does instead (warned when above 0).
PRINCIPLED_LEFT_OUT = {"Dispersion": "refracts every wavelength alike (no dispersion)"}
GLOSSY_IDS = {"ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic"}
# A Glossy, Glass or Refraction node's distribution as the closure's `distribution` input (Multiscatter GGX is GGX
# with `multiscatter`); the Glass and Refraction nodes offer all but Ashikhmin-Shirley.
DISTRIBUTIONS = {"GGX": nodes_.GGX, "MULTI_GGX": nodes_.GGX, "BECKMANN": nodes_.BECKMANN,
                 "ASHIKHMIN_SHIRLEY": nodes_.ASHIKHMIN_SHIRLEY}
# Blender's nodes that add one closure of a BSDF, read alike: bl_idname -> core/materials node name (Node.blender).
ONE_CLOSURE_NODES = {cls.blender: cls.name for cls in NODE_TYPES if cls.blender is not None}


def node_tree(datablock):
    """Return the node tree Cycles uses for a material, world or light, or None where Use Nodes is off.

    Use Nodes is deprecated, and always on, once Blender gives every such datablock a node tree: materials
    and worlds from Blender 5.0, lights from 5.2 (whose default tree is an Emission node, white, strength 1).
    Before that the tree counts only with Use Nodes on, as in Cycles. RNA says which applies, so the
    deprecated property is never read.
    """
    prop = datablock.bl_rna.properties.get("use_nodes")
    if prop is not None and not getattr(prop, "is_deprecated", False) and not datablock.use_nodes:
        return None
    return datablock.node_tree


def output_node(tree, idname: str):
    """Return the active Cycles output node of type `idname` (ShaderNodeOutputMaterial, ...Light) in `tree`,
    else its first such node, or None."""
    outputs = [n for n in tree.nodes if n.bl_idname == idname and n.target in {"ALL", "CYCLES"}]
    return next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)


def linked_node(output, socket: str = "Surface"):
    """Return the node linked to `output`'s `socket` (through reroutes), or None where nothing is."""
    return None if output is None else linked_node_of(output.inputs[socket])


def linked_node_of(socket):
    """Return the node linked into an input `socket` (through reroutes), or None where nothing is."""
    return _follow(socket.links[0].from_node) if socket.is_linked and socket.links else None


def linked_output_of(socket):
    """Return the output socket linked into an input `socket` through reroutes, or None where nothing is."""
    while socket is not None and socket.is_linked and socket.links:
        link = socket.links[0]
        if link.from_node.bl_idname != "NodeReroute":
            return link.from_socket
        socket = link.from_node.inputs[0] if link.from_node.inputs else None
    return None


def auto_emission(socket) -> bool:
    """Whether a closure input `socket` is fed by a value, colour or vector output, which Cycles turns into an Emission
    shader (ShaderGraph::connect's automatic conversion) rather than a shader."""
    out = linked_output_of(socket)
    return out is not None and out.type not in ("SHADER", "CUSTOM")


def auto_emission_of(reader, socket):
    """The emission (colour x strength: a constant or a graph.Link) of the Emission shader Cycles makes of the value,
    colour or vector linked into the closure input `socket` (auto_emission): a colour or vector its Color at Strength
    1, a value its Strength of white."""
    value = reader.graph.socket(socket, reader.path)
    number = linked_output_of(socket).type in ("VALUE", "INT", "BOOLEAN")
    return _scaled(np.ones(3), value) if number else _scaled(value, 1.0)


def surface_node(material):
    """Return the node linked to the active Cycles material output's Surface socket, or None."""
    tree = node_tree(material)
    if tree is None:
        return None
    return linked_node(output_node(tree, "ShaderNodeOutputMaterial"))


def _follow(node):
    """Skip reroutes: the node a chain of Reroute nodes comes from (None where it ends unlinked)."""
    while node is not None and node.bl_idname == "NodeReroute":
        node = node.inputs[0].links[0].from_node if node.inputs[0].is_linked else None
    return node


# A Bump in a light-sampled emitter's tree: Cycles evaluates no bump nodes in a light's own shading (its Normal is the
# zero vector at light samples), Primer too. Where light samples and BSDF rays see different emission the image is
# their MIS weights' mix, and Primer's Light Samples n weigh BSDF rays less than Cycles' one light sample does
# (tests/test_blender_displacement.py: the floor under such an emitter 13x darker at 4, 9 % brighter at 1).
BUMP_AT_LIGHT_SAMPLES = ("a Bump in a light-sampled emitter: light samples see its Normal as zero and BSDF rays see "
                         "it bumped, as in Cycles; the image then depends on how MIS weighs the two, which matches "
                         "Cycles only at Light Samples 1 (within 9 %)")


# The Wireframe node's Pixel Size where light samples land on an emitter: Cycles sets up no ray differentials there
# (shader_setup_from_sample: a zero footprint, so no wire shows), Primer too (graph.pixel_width); BSDF rays see the
# wires, and the image is their MIS weights' mix, Cycles' at Light Samples 1 (as BUMP_AT_LIGHT_SAMPLES).
PIXEL_SIZE_AT_LIGHT_SAMPLES = ("Pixel Size on a light-sampled emitter: light samples see no wire (no ray footprint) "
                               "and BSDF rays see it, as in Cycles; the image then depends on how MIS weighs the "
                               "two, which matches Cycles only at Light Samples 1")


# The shader nodes whose closure is an emission on a surface (or lamp): Color x Strength, two-sided.
EMISSION_NODES = ("ShaderNodeEmission", "ShaderNodeBackground")


def _light_sampled_emitter(material) -> bool:
    """Whether `material` (a Blender material or light) may be an emitter that light samples land on: Cycles'
    Emission Sampling is not None and its node tree holds an Emission or Background node (Cycles' surface takes a
    Background as an Emission) or a Principled BSDF that emits (closures.principled_emits: its Emission Color and
    Emission Strength each linked or above Cycles' weight cutoff)."""
    material = getattr(material, "original", material)      # (as the user set it, not a depsgraph's copy)
    sampling = getattr(getattr(material, "cycles", None), "emission_sampling", "NONE")
    tree = getattr(material, "node_tree", None)
    if sampling == "NONE" or tree is None:
        return False
    for n in tree.nodes:
        if n.bl_idname in EMISSION_NODES:
            return True
        strength = n.inputs.get("Emission Strength") if n.bl_idname == "ShaderNodeBsdfPrincipled" else None
        color = n.inputs.get("Emission Color", n.inputs.get("Emission")) if strength is not None else None
        if strength is not None and closures_.principled_emits(
                color is None or color.is_linked, max(color.default_value[:3]) if color is not None else 1.0,
                strength.is_linked, strength.default_value):
            return True
    return False


class NodeReader:
    """Reads one material's (or light's) inputs, noting each input that a link feeds (Primer takes its own value)."""

    def __init__(self, material, warnings: list, kind: str = "material", kernels: str = "compiled"):
        self.material, self.warnings, self.kind = material, warnings, kind
        self.kernels = kernels         # where its Sky Textures' tables are computed ("compiled": C, "numpy")
        self.path: tuple = ()          # the group nodes the shader nodes being read sit inside

    def warn(self, node, text: str) -> None:
        """A warning naming the material (or light) and node."""
        note = f"{self.kind} '{self.material.name}', node '{node.name}': {text}"
        if note not in self.warnings:
            self.warnings.append(note)

    def value(self, node, name: str, default):
        """An input's own value (float or RGB), `default` where the node has no such input (a link into it
        is not followed: the callers that want links use `input`)."""
        socket = node.inputs.get(name)
        if socket is None:
            return default
        return own_value(socket)

    def input(self, node, name: str, default, path: tuple = None):
        """An input as the core reads it: its own value, or a graph.Link to the sub-graph feeding it
        (`path`: the group nodes it sits inside, default the ones being read)."""
        socket = node.inputs.get(name) or next((s for s in node.inputs if s.identifier == name), None)
        if socket is None:
            return default
        return self.graph.socket(socket, self.path if path is None else path)

    @property
    def graph(self) -> "GraphReader":
        """The reader that follows this material's links (made on first use)."""
        if not hasattr(self, "_graph"):
            self._graph = GraphReader(self)
        return self._graph


def own_value(socket):
    """A socket's own value: a float, or (3,) float64 for colours and vectors (infinities as blender_float reads them)."""
    value = getattr(socket, "default_value", 0.0)
    try:
        return blender_float(np.array(value[:3], np.float64))
    except TypeError:
        return float(blender_float(float(value)))


# Blender stores a typed-in infinity as the largest float32 (RNA clamps to the float range).
BLENDER_INFINITY = float(np.finfo(np.float32).max)


def blender_float(value):
    """A float or (k,) float64 array from Blender with +-FLT_MAX read back as the +-infinity it stands for, so that
    the core reads it as Cycles renders it (core/materials/finite.py)."""
    array = np.asarray(value, np.float64)
    out = np.where(np.abs(array) >= BLENDER_INFINITY, np.copysign(np.inf, array), array)
    return float(out) if out.ndim == 0 else out


# Texture and colour nodes Primer evaluates: Blender's node -> core/materials/graph.py kind.
GRAPH_KINDS = {**{idname: cls.kind for idname, cls in CONVERTER_BY_BLENDER.items()},   # (the Map Range's below)
               "ShaderNodeTexImage": "IMAGE", "ShaderNodeTexCoord": "TEXCOORD", "ShaderNodeUVMap": "UVMAP",
               "ShaderNodeAttribute": "ATTRIBUTE", "ShaderNodeVertexColor": "ATTRIBUTE",
               "ShaderNodeObjectInfo": "OBJECT_INFO", "ShaderNodeLightPath": "LIGHT_PATH", "ShaderNodeMapping": "MAPPING", "ShaderNodeNormalMap": "NORMAL_MAP",
               "ShaderNodeBump": "BUMP", "ShaderNodeMath": "MATH", "ShaderNodeMix": "MIX", "ShaderNodeMixRGB": "MIX",
               "ShaderNodeValToRGB": "RAMP", "ShaderNodeInvert": "INVERT", "ShaderNodeHueSaturation": "HSV",
               "ShaderNodeSeparateRGB": "SEPARATE_COLOR", "ShaderNodeSeparateXYZ": "SEPARATE_XYZ",
               "ShaderNodeCombineRGB": "COMBINE_COLOR", "ShaderNodeCombineXYZ": "COMBINE_XYZ", "ShaderNodeClamp": "CLAMP",
               "ShaderNodeMapRange": "MAP_RANGE", "ShaderNodeTangent": "TANGENT",
               "ShaderNodeTexEnvironment": "ENVIRONMENT", "ShaderNodeTexSky": "SKY",
               "ShaderNodeVectorTransform": "VECTOR_TRANSFORM",
               "ShaderNodeFresnel": "FRESNEL", "ShaderNodeLayerWeight": "LAYER_WEIGHT", "ShaderNodeNewGeometry": "GEOMETRY",
               "ShaderNodeCameraData": "CAMERA_DATA", "ShaderNodeWireframe": "WIREFRAME",
               "ShaderNodeAmbientOcclusion": "AO", "ShaderNodeBevel": "BEVEL",
               "ShaderNodeHairInfo": "CURVES_INFO",
               "ShaderNodeParticleInfo": "PARTICLE_INFO",
               "ShaderNodePointInfo": "POINT_INFO", "ShaderNodeVolumeInfo": "VOLUME_INFO",
               **{idname: cls.kind for idname, cls in TEXTURE_BY_BLENDER.items()}}
# Nodes bpy creates that Cycles has no node for (EEVEE's only): Cycles' sync drops them and what they feed keeps its
# own value, as in Primer. The legacy Squeeze Value has only a GPU function (node_shader_squeeze.cc).
EEVEE_ONLY = frozenset({"ShaderNodeSqueeze"})
# How many of a curve node's curves Cycles bakes (RGB Curves: R, G, B and the combined C applied first).
CURVES_BAKED = {"ShaderNodeRGBCurve": 4, "ShaderNodeVectorCurve": 3, "ShaderNodeFloatCurve": 1}
# Legacy socket names -> the core's.
RENAMED = {"R": "Red", "G": "Green", "B": "Blue", "Image": "Color", "Fac": "Fac", "Factor": "Fac"}
# Colour spaces whose numbers are used as they are (no decoding); sRGB is decoded after lookup.
LINEAR_SPACES = {"Non-Color", "Linear Rec.709", "Linear", "Raw", "Linear CIE-XYZ E", "Linear CIE-XYZ D65",
                 "Linear Rec.2020", "Linear FilmLight E-Gamut", "Generic Data", "Scene Linear"}


class GraphReader:
    """Follows links from a shader node's inputs into the texture and colour nodes that feed them, as
    graph.GraphNode records (once per node and group path); groups flattened, reroutes skipped."""

    def __init__(self, reader: NodeReader):
        self.reader = reader
        self.nodes: dict = {}

    def socket(self, socket, path: tuple = ()):
        """An input socket's value: its own, or a Link; `path`: the group nodes it sits inside."""
        link = socket.links[0] if socket.is_linked and socket.links else None
        if link is not None and not getattr(link, "is_valid", True):
            # A link Blender marks invalid (one that closes a loop): Cycles leaves it out, and so does Primer.
            self.reader.warn(link.to_node, f"the link from '{link.from_node.name}' into '{socket.name}' is invalid (it "
                                           "closes a loop); it is ignored, as in Cycles")
            return own_value(socket)
        if link is None or getattr(link, "is_muted", False):
            return own_value(socket)
        return self.output(link.from_node, link.from_socket, path, socket)

    def output(self, node, out, path: tuple, consumer):
        """The value an output socket `out` of `node` gives `consumer` (an input socket)."""
        kind = node.bl_idname
        if kind == "NodeReroute":
            return self.socket(node.inputs[0], path) if node.inputs else own_value(consumer)
        if getattr(node, "mute", False):
            for internal in getattr(node, "internal_links", ()):
                if internal.to_socket.identifier == out.identifier:
                    return self.socket(internal.from_socket, path)
            return own_value(consumer)
        if kind == "ShaderNodeGroup" and node.node_tree is not None:
            outputs = [n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput"]
            inner = next((n for n in outputs if getattr(n, "is_active_output", False)), outputs[0] if outputs else None)
            socket = next((s for s in inner.inputs if s.identifier == out.identifier), None) if inner else None
            return self.socket(socket, path + (node,)) if socket is not None else own_value(consumer)
        if kind == "NodeGroupInput":
            if not path:
                return own_value(consumer)
            group = path[-1]
            socket = next((s for s in group.inputs if s.identifier == out.identifier), None)
            return self.socket(socket, path[:-1]) if socket is not None else own_value(consumer)
        if kind == "ShaderNodeDisplacement":
            return self.displacement(node, path)
        if kind == "ShaderNodeVectorDisplacement":
            return self.vector_displacement(node, path)
        if kind == "ShaderNodeRGB":
            return np.array(out.default_value[:3], np.float64)
        if kind == "ShaderNodeValue":
            return float(out.default_value)
        if kind == "ShaderNodeAttribute" and node.attribute_type == "VIEW_LAYER":     # one value for the whole render
            f32 = view_layer_attribute(node.attribute_name).astype(np.float32).astype(np.float64)
            name = RENAMED.get(out.name, out.name)
            if name in ("Color", "Vector"):
                return Link(GraphNode("RGB", {"value": f32[:3], "type": name.lower()}), "Color")
            return Link(GraphNode("VALUE", {"value": float(f32[3]) if name == "Alpha"
                                            else float((f32[0] + f32[1] + f32[2]) / 3.0)}), "Value")
        if kind == "ShaderNodeNormal":
            return self.normal_node(node, path, out.name)
        if kind == "ShaderNodeLightFalloff" and (self.reader.kind == "material"     # (worlds: warned)
                                                 or getattr(self.reader, "per_sample", False)):  # (a lamp's program)
            return self.light_falloff(node, path, out.name)
        if kind == "ShaderNodeLightFalloff" and self.reader.kind == "light" and not any(
                node.inputs[name].is_linked for name in ("Strength", "Smooth")):
            return self.lamp_falloff(node, out.name)
        if kind == "ShaderNodeNormalMap" and node.space != "TANGENT":
            return self.normal_map_space(node, path)
        name = RENAMED.get(out.name, out.name)
        if kind == "ShaderNodeMixRGB" and name == "Color":          # the legacy Mix's output is the Mix's Result
            name = "Result"
        if kind in EEVEE_ONLY:
            self.reader.warn(node, f"'{node.bl_label}' is EEVEE's only: Cycles drops it, and as Cycles, for "
                                   f"'{consumer.name}' of '{consumer.node.name}' Primer uses that input's own value "
                                   f"{_shown(consumer)}")
            return own_value(consumer)
        if kind not in GRAPH_KINDS:
            self.reader.warn(node, f"'{node.bl_label}' is not a node Primer evaluates; for '{consumer.name}' of "
                                   f"'{consumer.node.name}' it uses that input's own value {_shown(consumer)}")
            return own_value(consumer)
        graph_node = self.node(node, path)
        if graph_node is None:
            return own_value(consumer)
        if name not in graph_.NODE_OUTPUTS[graph_node.kind]:
            self.reader.warn(node, f"output '{out.name}' is not one Primer evaluates; for '{consumer.name}' of "
                                   f"'{consumer.node.name}' it uses that input's own value {_shown(consumer)}")
            return own_value(consumer)
        return Link(graph_node, name)

    def normal_node(self, node, path: tuple, output: str):
        """The Normal node as Cycles' svm_node_normal: Normal its direction (the output socket's value) normalised,
        Dot that direction dotted with its Normal input normalised (the input's own value where unlinked)."""
        direction = np.asarray(node.outputs["Normal"].default_value[:3], np.float32)
        length = np.sqrt(np.float32(direction @ direction))
        unit = (direction / length if length > 0.0 else np.zeros(3, np.float32)).astype(np.float64)
        constant = Link(GraphNode("RGB", {"value": unit, "type": "vector"}, {}, node.name), "Color")
        if output == "Normal":
            return constant
        normal = self.inputs(node, path, ["Normal"]).get("Normal", (0.0, 0.0, 1.0))
        normalised = Link(GraphNode("VECTOR_MATH", {"operation": "NORMALIZE"}, {"Vector": normal}, node.name), "Vector")
        return Link(GraphNode("VECTOR_MATH", {"operation": "DOT_PRODUCT"}, {"Vector": constant, "Vector_001": normalised},
                              node.name), "Value")

    def light_falloff(self, node, path: tuple, output: str):
        """The Light Falloff node as Cycles' svm_node_light_falloff at a surface: Strength times the ray's length L
        to the power 0 (Quadratic), 1 (Linear) or 2 (Constant), times L^2 / (Smooth + L^2) where Smooth > 0."""
        inputs = self.inputs(node, path, ["Strength", "Smooth"])
        strength, smooth = inputs.get("Strength", 100.0), inputs.get("Smooth", 0.0)
        length = Link(GraphNode("LIGHT_PATH", {}, {}, node.name), "Ray Length")
        squared = _math("MULTIPLY", length, length)
        powers = {"Quadratic": 1.0, "Linear": length, "Constant": squared}
        value = _math("MULTIPLY", strength, powers.get(output, 1.0))
        if _linked(smooth) or float(smooth) > 0.0:
            ratio = Link(GraphNode("MATH", {"operation": "DIVIDE"}, {"0": squared, "1": _math2("ADD", smooth, squared)}),
                         "Value")
            smoothing = _math("SUBTRACT", ratio, 1.0)
            if _linked(smooth):                                 # the smoothing only where Smooth > 0
                positive = Link(GraphNode("MATH", {"operation": "GREATER_THAN"}, {"0": smooth, "1": 0.0}), "Value")
                smoothing = _math("MULTIPLY", smoothing, positive)
            value = _math("MULTIPLY", value, _math2("ADD", smoothing, 1.0))
        return value if _linked(value) else Link(GraphNode("VALUE", {"value": float(value)}, {}, node.name), "Value")

    def lamp_falloff(self, node, output: str):
        """The Light Falloff node in a lamp's tree: its Strength as a value tagged with the output's power of the
        distance (Quadratic 0, Linear 1, Constant 2) and its Smooth, `light_falloff`, which export.lamp_falloff_wiring
        turns into the lamp's falloff where the Emission is linear in it (Cycles evaluates it per light sample, with
        the sample's ray length); a tree that uses it otherwise is warned about (export.light_node_factor)."""
        power = {"Quadratic": 0, "Linear": 1, "Constant": 2}.get(output, 0)
        strength, smooth = float(own_value(node.inputs["Strength"])), float(own_value(node.inputs["Smooth"]))
        return Link(GraphNode("VALUE", {"value": strength, "light_falloff": (power, max(smooth, 0.0))}, {}, node.name),
                    "Value")

    def normal_map_space(self, node, path: tuple):
        """A Normal Map in Object, World, Blender Object or Blender World space as Cycles' svm_node_normal_map: the
        colour's 2 (c - 0.5) (y and z negated in the Blender spaces) taken from object to world space as a normal
        (normalised; the World spaces only normalised), negated on back faces, then moved from the shading normal N
        by Strength (clamped at 0 below): normalize(N + (M - N) Strength) where Strength is not 1; N where that is
        zero (a colour of 0.5 grey)."""
        inputs = self.inputs(node, path, ["Strength", "Color"])
        color, strength = inputs.get("Color", (0.5, 0.5, 1.0)), inputs.get("Strength", 1.0)
        signs = (2.0, -2.0, -2.0) if node.space.startswith("BLENDER") else (2.0, 2.0, 2.0)
        centred = vector_op("SUBTRACT", node.name, Vector=color, Vector_001=(0.5, 0.5, 0.5))
        m = vector_op("MULTIPLY", node.name, Vector=centred, Vector_001=signs)
        if node.space.endswith("OBJECT"):
            m = _transformed(m, "NORMAL", "OBJECT", "WORLD", node.name)
        else:
            m = vector_op("NORMALIZE", node.name, Vector=m)
        geometry = GraphNode("GEOMETRY", {}, {}, node.name)
        facing = _math2("SUBTRACT", 1.0, _math2("MULTIPLY", Link(geometry, "Backfacing"), 2.0))
        m = vector_op("SCALE", node.name, Vector=m, Scale=facing)
        if _linked(strength) or float(strength) != 1.0:
            n = Link(geometry, "Normal")
            amount = strength if not _linked(strength) else _math2("MAXIMUM", strength, 0.0)
            amount = max(float(amount), 0.0) if not _linked(amount) else amount
            moved = vector_op("SCALE", node.name, Vector=vector_op("SUBTRACT", node.name, Vector=m, Vector_001=n),
                              Scale=amount)
            m = vector_op("NORMALIZE", node.name, Vector=vector_op("ADD", node.name, Vector=n, Vector_001=moved))
        length = Link(GraphNode("VECTOR_MATH", {"operation": "LENGTH"}, {"Vector": m}, node.name), "Value")
        zero = Link(GraphNode("MATH", {"operation": "COMPARE"}, {"0": length, "1": 0.0, "2": 0.0}), "Value")
        return Link(GraphNode("MIX", {"data_type": "VECTOR", "clamp_factor": True},      # a zero normal: N, as Cycles
                              {"Factor": zero, "A": m, "B": Link(geometry, "Normal")}, node.name), "Result")

    def displacement(self, node, path: tuple):
        """A Displacement node's offset, as Cycles' svm_node_displacement computes it, from nodes Primer evaluates:
        (Height - Midlevel) x Scale along its Normal (the shading normal where unlinked), in world space or (its
        default) in object space: the normal taken into the object's frame, scaled, and the offset brought back, so
        that the object's scale scales it."""
        inputs = self.inputs(node, path, ["Height", "Midlevel", "Scale", "Normal"])
        normal = inputs["Normal"] if _linked(inputs.get("Normal")) else Link(GraphNode("GEOMETRY", {}, {}, node.name),
                                                                             "Normal")
        amount = _math("MULTIPLY", _math("SUBTRACT", inputs.get("Height", 0.0), inputs.get("Midlevel", 0.5)),
                       inputs.get("Scale", 1.0))
        in_object = getattr(node, "space", "OBJECT") == "OBJECT"
        if in_object:
            normal = _transformed(normal, "NORMAL", "WORLD", "OBJECT", node.name)
        offset = Link(GraphNode("VECTOR_MATH", {"operation": "SCALE"}, {"Vector": normal, "Scale": amount}, node.name),
                      "Vector")
        return _transformed(offset, "VECTOR", "OBJECT", "WORLD", node.name) if in_object else offset

    def vector_displacement(self, node, path: tuple):
        """A Vector Displacement node's offset as Cycles' svm_node_vector_displacement computes it: (Vector -
        Midlevel) x Scale, in world space, or (brought into the world) object space, or tangent space (its default:
        x along the active UV map's tangent, y along the normal, z along the bitangent, graph.tangent_space, then
        as object space)."""
        space = getattr(node, "space", "TANGENT")
        inputs = self.inputs(node, path, ["Vector", "Midlevel", "Scale"])
        midlevel = inputs.get("Midlevel", 0.0)
        middle = (np.full(3, float(midlevel)) if not _linked(midlevel)
                  else Link(GraphNode("COMBINE_XYZ", {}, {"X": midlevel, "Y": midlevel, "Z": midlevel}, node.name),
                            "Vector"))
        offset = Link(GraphNode("VECTOR_MATH", {"operation": "SUBTRACT"},
                                {"Vector": inputs.get("Vector", np.zeros(3)), "Vector_001": middle}, node.name), "Vector")
        offset = Link(GraphNode("VECTOR_MATH", {"operation": "SCALE"}, {"Vector": offset,
                                                                       "Scale": inputs.get("Scale", 1.0)}, node.name),
                      "Vector")
        if space == "TANGENT":
            offset = Link(GraphNode("TANGENT_SPACE", {"map": ""}, {"Vector": offset}, node.name), "Vector")
        return offset if space == "WORLD" else _transformed(offset, "VECTOR", "OBJECT", "WORLD", node.name)

    def sky(self, node, warn):
        """A Sky Texture's props {"sky": core/materials/sky.py Sky}, precomputed as Cycles 5.0 does (Blender 4.x's
        NISHITA is Cycles 5.0's SINGLE_SCATTERING, its Dust its Aerosol), in a world or a surface material (which
        draws the sun's disc itself, as does a world's whose vector is linked or mapped; a world's other sky gives
        its disc to a sun lamp); None, with a warning, for a sky type Primer does not know."""
        kind = {"NISHITA": "SINGLE_SCATTERING"}.get(node.sky_type, node.sky_type)
        if kind not in sky_.SKY_TYPES:
            warn(f"sky type {node.sky_type} is not one Primer computes; Primer uses the input's own value")
            return None
        if node.sky_type == "NISHITA":
            warn("Blender 4.x's Nishita sky: Primer computes Cycles 5.0's Single Scattering sky, which this "
                 "Blender's Cycles draws slightly differently (its sun disc hides the sky behind it, and it reads its "
                 "table and fades the ground below the horizon its own way)")
        world = self.reader.kind == "world"
        mapping = getattr(node, "texture_mapping", None)
        moved = _vector_linked(node) or (mapping is not None and not identity_mapping(mapping))
        if world and moved and kind in ("MULTIPLE_SCATTERING", "SINGLE_SCATTERING") and node.sun_disc:
            warn("its Vector is linked or mapped: Primer draws its sun disc in the sky itself rather than as a sun "
                 "lamp; rays that escape see it exactly, but light samples read it from the world's bake, where its "
                 "half degree falls on a few texel centres (0.8 to 1.04 times its light, by where they fall)")
        aerosol = getattr(node, "aerosol_density", getattr(node, "dust_density", 1.0))
        return {"sky": sky_.precompute(
            kind, float(node.sun_elevation), float(node.sun_rotation), float(node.sun_size),
            float(node.sun_intensity), bool(node.sun_disc), float(node.altitude), float(node.air_density),
            float(aerosol), float(node.ozone_density), tuple(node.sun_direction), float(node.turbidity),
            float(node.ground_albedo), disc_drawn=not world or moved, kernels=self.reader.kernels)}

    def node(self, node, path: tuple):
        """The GraphNode of a Blender node (made once per group path), or None when Primer cannot read it."""
        key = (tuple(g.as_pointer() for g in path), node.as_pointer())
        if key not in self.nodes:
            self.nodes[key] = None
            self.nodes[key] = self.convert(node, path)
        return self.nodes[key]

    def inputs(self, node, path: tuple, names, legacy: dict = None) -> dict:
        """The enabled inputs called `names` (first of that name), each its value or a Link."""
        out = {}
        for name in names:
            socket = next((s for s in node.inputs if name in (s.name, s.identifier) and getattr(s, "enabled", True)),
                          None)
            if socket is None and legacy:
                socket = next((s for s in node.inputs if s.name == legacy.get(name)), None)
            if socket is not None:
                out[name] = self.socket(socket, path)
        return out

    def convert(self, node, path: tuple):
        """A Blender node as a GraphNode (warnings for what Primer leaves out)."""
        kind, warn = GRAPH_KINDS[node.bl_idname], lambda text: self.reader.warn(node, text)    # noqa: E731
        props: dict = {}
        inputs: dict = {}
        if kind == "IMAGE":
            props = {"image": load_image(node.image, self.reader, node),
                     "interpolation": node.interpolation, "extension": node.extension,
                     "projection": node.projection, "blend": float(node.projection_blend),
                     "unassociate": unassociates(node.image, node),
                     "alpha_read": alpha_read(self.reader.material, path, node)}
            inputs = self.inputs(node, path, ["Vector"])
            if not node.inputs["Vector"].is_linked:
                inputs = {}
            if not identity_mapping(node.texture_mapping):
                inputs["Vector"] = mapped_vector(node.texture_mapping, inputs.get("Vector"), "UV", warn)
        elif kind == "ENVIRONMENT":
            props = {"image": load_image(node.image, self.reader, node), "interpolation": node.interpolation,
                     "projection": node.projection}
            inputs = self.inputs(node, path, ["Vector"]) if node.inputs["Vector"].is_linked else {}
            if self.reader.kind != "world" and "Vector" not in inputs:   # Cycles' default: the shading point's P
                inputs["Vector"] = Link(GraphNode("GEOMETRY", {}, {}), "Position")
            if not identity_mapping(node.texture_mapping):
                inputs["Vector"] = mapped_vector(node.texture_mapping, inputs.get("Vector"), "Generated", warn)
        elif kind == "SKY":
            props = self.sky(node, warn)
            if props is None:
                return None
            inputs = self.inputs(node, path, ["Vector"]) if _vector_linked(node) else {}
            mapping = getattr(node, "texture_mapping", None)
            if mapping is not None and not identity_mapping(mapping):
                inputs["Vector"] = mapped_vector(mapping, inputs.get("Vector"), "Generated", warn)
        elif kind == "VECTOR_TRANSFORM":
            props = {"type": node.vector_type, "from": node.convert_from, "to": node.convert_to}
            inputs = self.inputs(node, path, ["Vector"])
        elif kind == "TEXCOORD":
            if node.object is not None:                   # Object: in that object's frame
                props = {"object_matrix": np.array(node.object.matrix_world, np.float64)}
            camera = bpy.context.scene.camera
            if (node.outputs["Window"].is_linked and camera is not None and getattr(camera.data, "type", "") == "PANO"
                    and panorama_type(camera.data) not in graph_.PANORAMA_WINDOWS):
                warn(f"Window for a {panorama_type(camera.data)} panoramic camera is not supported; Primer reads "
                     "(0, 0, 0)")
            props["from_instancer"] = bool(getattr(node, "from_instancer", False))  # (UV, Generated: the instance's)
        elif kind == "UVMAP":
            props = {"map": node.uv_map}
        elif kind == "ATTRIBUTE":
            if node.bl_idname == "ShaderNodeVertexColor":
                props = {"attribute": "color:" + node.layer_name}
            elif node.attribute_type in ("OBJECT", "INSTANCER"):   # the instance's columns of its Object Info
                key = f"{node.attribute_type}:{node.attribute_name}"
                if key not in INSTANCE_ATTRIBUTES:
                    INSTANCE_ATTRIBUTES.append(key)
                kind = "INSTANCE_ATTRIBUTE"
                props = {"column": OBJECT_INFO_WIDTH + 4 * INSTANCE_ATTRIBUTES.index(key)}
            else:
                name = node.attribute_name
                uv = any(name in mesh.uv_layers for mesh in bpy.data.meshes)
                props = {"attribute": ("uv:" if uv else "attr:") + name}    # (attr: Alpha 1 where missing)
        elif kind == "PARTICLE_INFO":           # 16 columns of the instances' Object Info (particle_columns)
            if "PARTICLE:0" not in INSTANCE_ATTRIBUTES:
                INSTANCE_ATTRIBUTES.extend(f"PARTICLE:{k}" for k in range(4))
            props = {"column": OBJECT_INFO_WIDTH + 4 * INSTANCE_ATTRIBUTES.index("PARTICLE:0")}
        elif kind == "OBJECT_INFO":             # (its Material Index: this material's pass index, a constant; a
            # lamp's tree has no material: Cycles' shader_pass_id of a light's shader is 0)
            owner = self.reader.material
            props = {"material_index": 0.0 if self.reader.kind == "light" else float(getattr(owner, "pass_index", 0))}
        elif kind == "MAPPING":
            props = {"type": node.vector_type}
            inputs = self.inputs(node, path, ["Vector", "Location", "Rotation", "Scale"])
        elif kind == "NORMAL_MAP":
            props = {"map": node.uv_map}
            inputs = self.inputs(node, path, ["Strength", "Color"])
        elif kind in ("FRESNEL", "LAYER_WEIGHT"):
            inputs = self.inputs(node, path, ["IOR" if kind == "FRESNEL" else "Blend", "Normal"])
            if not node.inputs["Normal"].is_linked:
                inputs.pop("Normal", None)                # unlinked: the shading normal, as in Cycles
        elif kind == "WIREFRAME":
            props = {"pixel_size": bool(node.use_pixel_size)}
            if node.use_pixel_size and _light_sampled_emitter(self.reader.material):
                warn(PIXEL_SIZE_AT_LIGHT_SAMPLES)
            inputs = self.inputs(node, path, ["Size"])
        elif kind == "TANGENT":
            props = {"direction": node.direction_type, "axis": node.axis, "map": node.uv_map}
        elif kind == "BUMP":
            if node.inputs["Height"].is_linked and _light_sampled_emitter(self.reader.material):
                warn(BUMP_AT_LIGHT_SAMPLES)
            # Filter Width (Blender 4.5 and later; Cycles reads its value when compiling, never a link)
            width = node.inputs.get("Filter Width")
            props = {"invert": bool(node.invert),
                     "filter_width": bump_filter_width() if width is None else float(width.default_value)}
            inputs = self.inputs(node, path, ["Strength", "Distance", "Height", "Normal"])
            if not node.inputs["Normal"].is_linked:
                inputs.pop("Normal", None)
        elif kind == "MATH":
            operation = node.operation
            if operation not in graph_.MATH_OPS:
                warn(f"operation {node.operation} is not supported; Primer uses Add")
                operation = "ADD"
            props = {"operation": operation, "clamp": bool(node.use_clamp)}
            inputs = {str(i): self.socket(socket, path) for i, socket in enumerate(node.inputs) if i < 3}
        elif kind == "MIX":
            if node.bl_idname == "ShaderNodeMixRGB":
                props = {"data_type": "RGBA", "blend_type": node.blend_type, "clamp_result": bool(node.use_clamp),
                         "clamp_factor": True}
                by_id = {s.identifier: s for s in node.inputs}
                inputs = {"Factor": self.socket(by_id["Fac"], path),
                          "A": self.socket(by_id["Color1"], path), "B": self.socket(by_id["Color2"], path)}
            else:
                data_type = node.data_type
                if data_type not in ("FLOAT", "VECTOR", "RGBA"):
                    warn(f"data type {data_type} is not supported; Primer mixes colours")
                    data_type = "RGBA"
                props = {"data_type": data_type, "blend_type": node.blend_type, "clamp_result": bool(node.clamp_result),
                         "clamp_factor": bool(node.clamp_factor), "factor_mode": getattr(node, "factor_mode", "UNIFORM")}
                suffix = {"FLOAT": "Float", "VECTOR": "Vector", "RGBA": "Color"}[data_type]
                factor = "Factor_Vector" if data_type == "VECTOR" and props["factor_mode"] == "NON_UNIFORM" else "Factor_Float"
                by_id = {s.identifier: s for s in node.inputs}
                for name, identifier in (("Factor", factor), ("A", "A_" + suffix), ("B", "B_" + suffix)):
                    if identifier in by_id:
                        inputs[name] = self.socket(by_id[identifier], path)
            if props["blend_type"] not in graph_.BLEND_TYPES:
                warn(f"blend mode {props['blend_type']} is not supported; Primer uses Mix")
                props["blend_type"] = "MIX"
        elif kind == "RAMP":
            ramp = node.color_ramp
            props = {"table": graph_.ramp_table(lambda position: ramp.evaluate(float(position))[:]),
                     "interpolate": ramp.interpolation != "CONSTANT"}
            inputs = self.inputs(node, path, ["Fac"])
        elif kind == "INVERT":
            inputs = self.inputs(node, path, ["Fac", "Color"])
        elif kind == "HSV":
            inputs = self.inputs(node, path, ["Hue", "Saturation", "Value", "Fac", "Color"])
        elif kind in ("SEPARATE_COLOR", "COMBINE_COLOR"):      # the legacy RGB nodes (Separate/Combine Color: converters)
            if kind == "SEPARATE_COLOR":
                inputs = self.inputs(node, path, ["Color"], legacy={"Color": "Image"})
            else:
                inputs = self.inputs(node, path, ["Red", "Green", "Blue"], legacy={"Red": "R", "Green": "G", "Blue": "B"})
        elif kind == "SEPARATE_XYZ":
            inputs = self.inputs(node, path, ["Vector"])
        elif kind == "COMBINE_XYZ":
            inputs = self.inputs(node, path, ["X", "Y", "Z"])
        elif kind == "AO":                                      # rays traced per hit: core/integrators/shader_rays.py
            props = {"samples": int(node.samples), "inside": bool(node.inside), "only_local": bool(node.only_local)}
            inputs = self.inputs(node, path, ["Color", "Distance", "Normal"])
        elif kind == "BEVEL":
            props = {"samples": int(node.samples)}
            inputs = self.inputs(node, path, ["Radius", "Normal"])
        elif kind == "CLAMP":
            props = {"clamp_type": node.clamp_type}
            inputs = self.inputs(node, path, ["Value", "Min", "Max"])
        elif kind in graph_.DESCRIBED_BY_KIND:
            props, inputs = self.texture(node, path, graph_.DESCRIBED_BY_KIND[kind], warn)
            if node.bl_idname in CURVES_BAKED:
                props["table"] = baked_curves(node.mapping, CURVES_BAKED[node.bl_idname])
            if node.bl_idname == "ShaderNodeTexIES":          # its profile, read as Cycles reads it
                profile = ies_.parse_ies(ies_text(node))
                if profile is None:
                    warn("its IES file could not be read (none given, missing or not LM-63); as in Cycles, the IES "
                         "Texture gives Strength x 100 in every direction")
                props.update(ies_props(profile))
        elif kind == "MAP_RANGE" and node.data_type == "FLOAT_VECTOR":
            kind = "MAP_RANGE_VECTOR"                               # core/materials/converters/map_range_vector.py
            props, inputs = self.texture(node, path, graph_.DESCRIBED_BY_KIND[kind], warn)
        elif kind == "MAP_RANGE":
            props = {"interpolation_type": node.interpolation_type, "clamp": bool(node.clamp)}
            inputs = self.inputs(node, path, ["Value", "From Min", "From Max", "To Min", "To Max", "Steps"])
        return GraphNode(kind, props, inputs, node.name)

    def texture(self, node, path: tuple, texture, warn) -> tuple:
        """A procedural texture's settings and inputs (core/materials/procedural): each setting from the bpy
        attribute its class names, the inputs by name (an unlinked Vector left out: the class's texture coordinate),
        the float properties its class reads as inputs (`properties`);
        the node's Texture Mapping applied to the vector (`mapped_vector`), and a warning where this Blender's Cycles
        computes the texture otherwise than Cycles 5.0 (`differs_in`)."""
        props = {name: getattr(node, attribute) for name, (attribute, _, _) in texture.settings.items()}
        for name, (attribute, choices, default) in texture.settings.items():
            if choices is not None and props[name] not in choices:
                warn(f"{attribute} {props[name]} is not supported; Primer uses {default}")
                props[name] = default
        inputs = self.inputs(node, path, [name for name, _, _ in texture.inputs if name not in texture.properties])
        inputs.update({name: float(getattr(node, attribute)) for name, attribute in texture.properties.items()})
        for name, _, default in texture.inputs:
            if isinstance(default, str) and name in inputs and not isinstance(inputs[name], Link):
                del inputs[name]
        note = texture.differs_in(props, tuple(bpy.app.version))
        if note is not None:
            warn(note)
        mapping = getattr(node, "texture_mapping", None)
        if mapping is not None and not identity_mapping(mapping):
            vector = inputs.get("Vector")
            inputs["Vector"] = mapped_vector(mapping, vector if isinstance(vector, Link) else None, "Generated", warn)
        return props, inputs


def ies_text(node) -> str:
    """The IES file's text an IES Texture names, as Cycles reads it: its Text datablock (Internal) or its file
    (External, relative to the .blend); "\n" (a file Cycles cannot read) where there is none."""
    if node.mode == "EXTERNAL":
        library = getattr(node.id_data, "library", None)
        path = bpy.path.abspath(node.filepath, library=library) if node.filepath else ""
        try:
            with open(path, encoding="latin-1") as handle:
                return handle.read() or "\n"
        except OSError:
            return "\n"
    text = node.ies
    content = text.as_string() if text is not None else ""
    return content or "\n"



def panorama_type(camera_data) -> str:
    """A panoramic camera's type: Blender 5's Camera.panorama_type, or 4.x's Cycles setting."""
    kind = getattr(camera_data, "panorama_type", None)
    return kind if kind is not None else getattr(getattr(camera_data, "cycles", None), "panorama_type", "")


def baked_curves(mapping, count: int) -> np.ndarray:
    """A curve mapping's table as Cycles' Blender sync bakes it (curvemapping_color_to_array, curvemapping_float_to_array):
    the first `count` curves evaluated by Blender at CURVE_TABLE_SIZE points from the smallest first point's x to the
    largest last point's x (in float32); with 4 (RGB Curves) each channel's curve of the combined curve's value; one
    column per channel (R, G, B or X, Y, Z; one for a Float Curve). -> converters.curves.curve_table."""
    f32 = np.float32
    mapping.update()
    mapping.initialize()
    curves = list(mapping.curves)[:count]
    min_x = min(f32(c.points[0].location[0]) for c in curves)
    max_x = max(f32(c.points[len(c.points) - 1].location[0]) for c in curves)
    size = CURVE_TABLE_SIZE - 1
    rows = []
    for i in range(CURVE_TABLE_SIZE):
        t = float(f32(min_x + (f32(i) / f32(size)) * f32(max_x - min_x)))
        if count == 4:
            c = mapping.evaluate(curves[3], t)
            rows.append([mapping.evaluate(curve, c) for curve in curves[:3]])
        else:
            rows.append([mapping.evaluate(curve, t) for curve in curves])
    return curve_table(float(min_x), float(max_x), mapping.extend == "EXTRAPOLATED", rows)


def mapped_vector(mapping, vector, coordinate: str, warn) -> Link:
    """A texture node's Texture Mapping (node properties) applied to its vector as Cycles does (TextureMapping): the
    axes mapping_x/y/z pick, then the Mapping of vector_type with its translation, rotation and scale (Texture and
    Normal keep each |scale| at least 1e-5). Its Min and Max clamps change nothing: Cycles' Blender sync does not read
    them. `vector` is the input's Link, or None for the node's default coordinate, the Texture Coordinate output
    `coordinate`; returns the mapped vector's Link."""
    if vector is None:
        vector = Link(GraphNode("TEXCOORD", {}, {}), coordinate)
    axes = (mapping.mapping_x, mapping.mapping_y, mapping.mapping_z)
    if axes != ("X", "Y", "Z"):
        separate = GraphNode("SEPARATE_XYZ", {}, {"Vector": vector})
        picked = {key: Link(separate, axis) if axis != "NONE" else 0.0 for key, axis in zip("XYZ", axes)}
        vector = Link(GraphNode("COMBINE_XYZ", {}, picked), "Vector")
    kind = mapping.vector_type
    scale = tuple(float(x) for x in mapping.scale)
    if kind in ("TEXTURE", "NORMAL"):
        scale = tuple((-1e-5 if x < 0.0 else 1e-5) if abs(x) < 1e-5 else x for x in scale)
    vector = Link(GraphNode("MAPPING", {"type": kind}, {
        "Vector": vector, "Location": tuple(float(x) for x in mapping.translation),
        "Rotation": tuple(float(x) for x in mapping.rotation), "Scale": scale}), "Vector")
    return vector


def _vector_linked(node) -> bool:
    """Whether a node's Vector input is there, enabled and linked (a Sky Texture's is hidden: unavailable in Blender)."""
    socket = next((s for s in node.inputs if s.identifier == "Vector"), None)
    return socket is not None and getattr(socket, "enabled", True) and socket.is_linked


def identity_mapping(mapping) -> bool:
    """Whether a texture node's TexMapping changes nothing (Cycles' TextureMapping::skip; Min and Max, which Cycles'
    Blender sync leaves unread, aside)."""
    return (tuple(mapping.translation) == (0.0, 0.0, 0.0) and tuple(mapping.rotation) == (0.0, 0.0, 0.0)
            and tuple(mapping.scale) == (1.0, 1.0, 1.0)
            and (mapping.mapping_x, mapping.mapping_y, mapping.mapping_z) == ("X", "Y", "Z"))


def _shown(socket) -> str:
    """A socket's own value, as the warnings show it."""
    value = own_value(socket)
    return f"{value:g}" if isinstance(value, float) else "(" + ", ".join(f"{x:g}" for x in value) + ")"


def load_image(image, reader: NodeReader, node):
    """A Blender image as Cycles reads it at the scene's frame (set_frame): a textures.Image (pixels as stored,
    bottom row first, the alpha as Cycles reads it: alpha_rule), a textures.TiledImage for a UDIM image (every tile
    of image.tiles), or None (Cycles' magenta) with a warning when it is missing or cannot be read. A sequence gives
    the file of the frame the node's Image User shows (sequence_frame); a movie, that frame decoded by Blender (addon/movie.py). Files are read with
    OpenImageIO (Blender's own module inside Blender, else the pip one), packed images from their bytes; without
    OpenImageIO Blender's pixel buffer is read in bulk. Read once per export and file."""
    if image is None:
        reader.warn(node, "has no image; Primer renders it magenta, as Cycles does")
        return None
    source = image.source
    frame = sequence_frame(node.image_user, _FRAME[0]) if source in ("SEQUENCE", "MOVIE") else 0
    key = (image.as_pointer(), frame)
    if key in _IMAGES:
        return _IMAGES[key]
    space = image.colorspace_settings.name
    if source == "MOVIE":                           # decoded by Blender into scene-linear values (addon/movie.py)
        _IMAGES[key] = _image_or_warning(image, reader, node, False, frame=frame)
        return _IMAGES[key]
    raw = from_float_buffer(image)                  # (Blender made it scene-linear: no decoding after lookup)
    if space != "sRGB" and space not in LINEAR_SPACES and not raw:
        reader.warn(node, f"image '{image.name}' is in colour space {space}; Primer uses its numbers as linear")
    srgb = space == "sRGB" and not raw
    if source == "TILED":
        tiles = {}
        for tile in image.tiles:
            if getattr(tile, "is_generated_tile", False):
                reader.warn(node, f"image '{image.name}' tile {tile.number} is generated (no file), which Primer does "
                                  "not read; Primer renders it magenta, where Cycles shows the generated tile")
                tiles[tile.number] = None
            else:
                tiles[tile.number] = _image_or_warning(image, reader, node, srgb, tile=tile.number)
        _IMAGES[key] = textures_.TiledImage(tiles, name=image.name) if tiles else None
        if not tiles:
            reader.warn(node, f"image '{image.name}' has no tiles; Primer renders it magenta, as Cycles does")
        return _IMAGES[key]
    if source not in ("FILE", "GENERATED", "SEQUENCE"):
        reader.warn(node, f"image '{image.name}' could not be read (source {source} is not supported); Primer "
                          "renders it magenta")
        _IMAGES[key] = None
        return None
    _IMAGES[key] = _image_or_warning(image, reader, node, srgb, frame=frame if source == "SEQUENCE" else None)
    return _IMAGES[key]


def from_float_buffer(image) -> bool:
    """Whether Cycles reads an image from Blender's float buffer (its BlenderImageLoader with a float ImBuf): a packed
    or generated single image (Cycles' sync calls such images builtin) that Blender holds in float (a 16-bit PNG, an
    EXR, ...; image.is_float, which loads it). Blender has made that buffer scene-linear and associated (its colour
    space and alpha mode applied), and Cycles copies it as float, with no decoding of its own."""
    if image.source not in ("FILE", "GENERATED") or (image.source == "FILE" and image.packed_file is None):
        return False
    try:
        return bool(image.is_float)
    except (AttributeError, RuntimeError, ReferenceError):
        return False


def load_alpha_rule(image) -> str:
    """How this Blender's Cycles associates an image's alpha when it loads it: alpha_rule's "ignore" and "straight"
    as they are; its "associate" in Blender 4.2 .. 5.0 too (associate what the file stores straight), but from 5.1
    on Cycles goes by the Alpha mode alone (ImageMetaData's is_unassociated_alpha, set from the alpha type Blender
    passes): "associate always" for Straight (an EXR's associated colours, and Blender's associated float buffer,
    times alpha once more) and "straight" for Premultiplied (a PNG's straight colours kept). Measured against Cycles
    5.2.3: a 16-bit PNG set to Premultiplied, an EXR set to Straight, a packed 16-bit PNG (Straight)."""
    rule = alpha_rule(image)
    if rule != "associate" or tuple(bpy.app.version)[:2] < (5, 1):
        return rule
    return "associate always" if image.alpha_mode == "STRAIGHT" else "straight"


def alpha_rule(image) -> str:
    """How Cycles reads an image's alpha (Blender passes the image's Alpha mode and colour space): "ignore" for Alpha
    None (IMAGE_ALPHA_IGNORE: alpha 1), "straight" for a data colour space (Non-Color) or Alpha Channel Packed (the
    colours as stored), else "associate" (Straight or Premultiplied: image_associate_alpha, the colours multiplied
    by the alpha where the file stores them straight)."""
    if image.alpha_mode == "NONE":
        return "ignore"
    settings = image.colorspace_settings
    data = getattr(settings, "is_data", settings.name == "Non-Color")
    return "straight" if data or image.alpha_mode == "CHANNEL_PACKED" else "associate"


def alpha_read(owner, path: tuple, node) -> list:
    """[whether a compiled program reads the Alpha output of Image Texture `node` (inside the groups `path`) of
    `owner` (a material, world or light)], one list shared by the GraphNodes each reader makes of that node (its
    surface's, AOVs', volume's, displacement's), set and read by graph.Compiler (mark_unassociate): Cycles compiles
    them as one graph, whose Image Texture divides back wherever its Alpha output has links."""
    key = (_pointer(owner), tuple(_pointer(g) for g in path), _pointer(node))
    return _ALPHA_READ.setdefault(key, [False])


def forget_alpha_reads(owner) -> None:
    """Drop what alpha_read knew of `owner`'s nodes: it is being read anew (a viewport update re-exports a material
    without begin_export), its programs compiled anew."""
    pointer = _pointer(owner)
    for key in [key for key in _ALPHA_READ if key[0] == pointer]:
        del _ALPHA_READ[key]


def _pointer(thing) -> int:
    """A Blender struct's address (as_pointer), else the Python object's id."""
    pointer = getattr(thing, "as_pointer", None)
    return pointer() if pointer is not None else id(thing)


def unassociates(image, node) -> bool:
    """Whether Cycles divides an Image Texture's colour back by its alpha where the node's Alpha output is read
    (ImageTextureNode::compile's NODE_IMAGE_ALPHA_UNASSOCIATE): for an image it associates (alpha_rule), whatever its
    file stores; core/materials/graph.py sets the flag where the compiled graph reads the Alpha output."""
    return image is not None and alpha_rule(image) == "associate"


def _image_or_warning(image, reader: NodeReader, node, srgb: bool, tile: int = None, frame: int = None):
    """One picture of an image (its file; a UDIM image's `tile`; a sequence's `frame`) as a textures.Image, or None
    with a warning that Primer, as Cycles, renders it magenta."""
    what = f"image '{image.name}'" + (f" tile {tile}" if tile is not None else "") + \
        (f" frame {frame}" if frame is not None else "")
    pixels, why = None, ""
    try:
        pixels = _read_pixels(image, tile=tile, frame=frame)
    except Exception as error:                      # noqa: BLE001 (a corrupt file must not stop the render)
        why = str(error) or type(error).__name__
    if pixels is None or pixels.size == 0:
        reader.warn(node, f"{what} could not be read ({why or 'no pixels'}); Primer renders it magenta, as Cycles "
                          "does")
        return None
    if tile is not None and pixels.dtype != np.uint8 and _tile_packed(image, tile):
        # Cycles reads a packed UDIM's tiles from Blender's float buffers (BlenderImageLoader), which Python cannot
        # see: a linear file stored associated is its values exactly (a half's too, in float32); others are warned.
        space = image.colorspace_settings.name
        if pixels.dtype.kind == "f" and space in LINEAR_SPACES and image.alpha_mode in ("PREMUL", "NONE",
                                                                                         "CHANNEL_PACKED"):
            pixels = pixels.astype(np.float32)
        else:
            reader.warn(node, f"{what} is packed and stored in more than 8 bits: Cycles reads Blender's float "
                              "buffer of it (decoded to scene-linear and associated by Blender), Primer the file's "
                              "values as for a tile on disk")
    rounding = _HALF_ROUNDING[0] or half_rounding_now()
    if pixels.dtype.kind == "f":
        pixels = _finite_texels(pixels, rounding, reader, node, what)
    # (Simplify's Texture Limit and Resolution, as Cycles; a half image's means made half as this Blender's Cycles)
    pixels = textures_.limited(pixels, *_TEXTURE_LIMIT, rounding)
    if pixels.dtype == np.float16 and image.source != "MOVIE":
        pixels = textures_.half_widened(pixels, rounding)   # (halves as this Blender's Cycles reads them in lookups)
    return textures_.Image(pixels, srgb=srgb, name=image.name if tile is None else f"{image.name} {tile}")


def _finite_texels(pixels: np.ndarray, rounding, reader: NodeReader, node, what: str) -> np.ndarray:
    """A float image's pixels (h, w, c), bottom row first, with its NaN and infinite texels as the running Blender's
    Cycles loads them, with a warning that says so. From Blender 5.1 on (`rounding` NEAREST_EVEN) a texel of several
    channels (Cycles makes it RGBA, an RGB one's alpha 1) with any channel not finite becomes 0 in every channel, alpha
    too (an RGB image gains an alpha channel for it), a grey texel 0; halves likewise. Blender 4.2 .. 5.0 (TRUNCATED)
    check floats only, and of several channels only the texels whose index (bottom row first) is a multiple of 4
    (their loop steps 4 texels at a time): those become 0 in every channel; the others reach the kernel, which renders
    a bad channel as 0 (measured on Emission), and Primer reads them so; halves stay as they are, read with the
    exponent's bias moved as 65536 (1 + m / 1024) (textures.half_widened), finite."""
    bad = ~np.isfinite(pixels)
    if not bad.any():
        return pixels
    texels = int(bad.any(axis=-1).sum())
    old = rounding is textures_.HalfRounding.TRUNCATED
    if pixels.dtype == np.float16 and old:
        reader.warn(node, f"{what} has {texels} NaN or infinite half texel(s); Primer reads them as Cycles 5.0 does, "
                          "as 65536 (1 + mantissa / 1024)")
        return pixels
    if pixels.shape[2] == 1:
        reader.warn(node, f"{what} has {texels} NaN or infinite texel(s); Primer reads them as 0, as Cycles does")
        return np.where(bad, pixels.dtype.type(0.0), pixels)
    whole = bad.any(axis=-1)
    if old:
        h, w = pixels.shape[:2]
        whole &= np.arange(h * w).reshape(h, w) % 4 == 0
        reader.warn(node, f"{what} has {texels} NaN or infinite texel(s); Primer reads them as Cycles 5.0 does: those "
                          "at an index that is a multiple of 4 as 0 in every channel, alpha too, the others' bad "
                          "channels as 0")
    else:
        reader.warn(node, f"{what} has {texels} NaN or infinite texel(s); Primer reads each as 0 in every channel, "
                          "alpha too, as Cycles does")
    pixels = np.where(bad, pixels.dtype.type(0.0), pixels)
    if whole.any() and pixels.shape[2] == 3:        # (Cycles' RGB to RGBA, alpha 1, before the texel's 0)
        pixels = np.concatenate([pixels, np.ones(pixels.shape[:2] + (1,), pixels.dtype)], axis=2)
    return np.where(whole[..., None], pixels.dtype.type(0.0), pixels)


def _tile_packed(image, tile: int) -> bool:
    """Whether UDIM `image`'s `tile` (its number) is packed into the .blend."""
    return any(getattr(p, "tile_number", 1001) == tile for p in image.packed_files)


def sequence_frame(user, scene_frame: int) -> int:
    """The frame (an int) of a sequence or movie that an Image User shows at `scene_frame`, as Blender's
    BKE_image_user_frame_get computes it; Cycles calls it with the scene's current frame for every render (the
    user's own frame_current is updated only with Auto Refresh on, or in a final render's depsgraph). Frames
    (frame_duration) counted from Start Frame, clamped to 0 .. Frames, or wrapped when Cyclic; then Offset added."""
    length = int(user.frame_duration)
    if length == 0:
        return 0
    cyclic = bool(user.use_cyclic)
    frame = int(scene_frame) - int(user.frame_start) + 1
    if cyclic:
        frame %= length                             # Python's modulo: 0 .. length - 1 for negative frames too
        if frame == 0:
            frame = length
    frame = min(max(frame, 0), length)
    return frame + int(user.frame_offset)


def sequence_path(path: str, frame: int) -> str:
    """The file of a sequence's `frame`: the last run of digits in the file name (before its extension) written
    as `frame` with as many digits, at least (frames below 0 as 0): Blender's BLI_path_sequence_decode and
    _encode, as BKE_image_user_file_path_ex names a sequence's frame for Cycles."""
    folder, name = os.path.split(path)
    stem, dot, extension = name.rpartition(".") if "." in name else (name, "", "")
    end = len(stem)
    while end > 0 and not stem[end - 1].isdigit():
        end -= 1
    begin = end
    while begin > 0 and stem[begin - 1].isdigit():
        begin -= 1
    digits = end - begin
    if digits == 0:                                 # no number: the frame goes before the extension ("%.0d" of 0 is "")
        begin = end = len(stem)
    number = "%.*d" % (digits, max(0, frame)) if digits or frame else ""
    return os.path.join(folder, stem[:begin] + number + stem[end:] + dot + extension)


def tile_path(path: str, tile: int) -> str:
    """A UDIM tile's file: the <UDIM> token replaced by the tile's number, <UVTILE> by u<column + 1>_v<row + 1>, as
    Cycles' ImageManager::add_image names each tile."""
    u, v = (tile - 1001) % 10, (tile - 1001) // 10
    return path.replace("<UDIM>", "%04d" % tile).replace("<UVTILE>", f"u{u + 1}_v{v + 1}")


# Images read in this export, by (image pointer, frame) (cleared by `begin_export`), and the scene's frame.
_IMAGES: dict = {}
_FRAME = [1]
# Which Image Textures' Alpha outputs this export reads (alpha_read), by (owner, group path, node).
_ALPHA_READ: dict = {}
# Decoded image files (_decoded): those of this export, and those of the export before it.
_DECODED_NOW: dict = {}
_DECODED_BEFORE: dict = {}


def begin_export(frame: int = 1, view_layer=None, texture_limit: int = 0, texture_resolution: float = 1.0,
                 half_rounding: textures_.HalfRounding = None) -> None:
    """Forget the images read by an earlier export (a render reads each image once) and the Object and Instancer
    attributes its materials read; read sequences and movies at the scene's `frame`, View Layer attributes from
    `view_layer` (None: the context's), and images under `texture_limit` (Simplify's, texture_limit_of; 0: none)
    and at `texture_resolution` (Blender 5.2's Simplify > Texture Resolution, texture_resolution_of; 1: full), half
    floats made as `half_rounding` says (textures.HalfRounding; None: this Blender's Cycles', half_rounding_now)."""
    global _DECODED_BEFORE, _DECODED_NOW
    _IMAGES.clear()
    _ALPHA_READ.clear()
    _DECODED_BEFORE, _DECODED_NOW = _DECODED_NOW, {}
    INSTANCE_ATTRIBUTES.clear()
    ATTRIBUTE_NOTES.clear()
    _VIEW_LAYER[0] = view_layer
    _TEXTURE_LIMIT[:] = [int(texture_limit), float(texture_resolution)]
    _HALF_ROUNDING[0] = half_rounding_now() if half_rounding is None else half_rounding
    set_frame(frame)


def half_rounding_now() -> textures_.HalfRounding:
    """How this Blender's Cycles makes half floats (textures.half_rounding_of bpy.app.version): truncated in 4.2 ..
    5.0, rounded to nearest even from 5.1 on."""
    return textures_.half_rounding_of(tuple(bpy.app.version))


# The texture size limit and resolution of this export's images (textures.limited), as Cycles' scene params
# texture_limit and texture_resolution.
_TEXTURE_LIMIT: list = [0, 1.0]
# How this export makes half floats (textures.HalfRounding): its images' Texture Limit means and associated alpha.
_HALF_ROUNDING: list = [None]


def texture_limit_of(scene, final: bool) -> int:
    """Simplify > Texture Limit as Cycles' sync reads it: with Simplify on, the Render limit for a final render
    (`final`), the Viewport one else; 0 (none) for "OFF", without Simplify or without Cycles' settings."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None or not scene.render.use_simplify:
        return 0
    value = str(getattr(cycles, "texture_limit_render" if final else "texture_limit", "OFF"))
    return int(value) if value.isdigit() else 0


def texture_resolution_of(scene, final: bool) -> float:
    """Simplify > Texture Resolution (Blender 5.2) as Cycles' sync reads it: with Simplify on, the Render factor for
    a final render (`final`), the Viewport one else; 1 (full resolution) without Simplify, in Blender 5.0 (which has
    none) or without Cycles' settings."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None or not scene.render.use_simplify:
        return 1.0
    return float(getattr(cycles, "texture_resolution_render" if final else "texture_resolution", 1.0))


# The Attribute node's Object and Instancer attributes this export's materials read, "OBJECT:name" or
# "INSTANCER:name", in the order of their columns (core/scene Scene.instance_attributes); the view layer whose View
# Layer attributes they read.
INSTANCE_ATTRIBUTES: list = []
_VIEW_LAYER: list = [None]
# What the lookups could not read as Cycles does (addon/export.py adds them to the export's warnings).
ATTRIBUTE_NOTES: list = []


def property_rgba(owner, name: str):
    """A custom property `name` of `owner` (an ID or a view layer), else the RNA property at path `name`, as RGBA
    (4,) float64 as Blender's find_property_rgba reads it: a number (float, int, boolean) as (v, v, v, 1), an array of
    up to 4 floats or ints over (0, 0, 0, 1); None where there is none or it is of another kind."""
    if owner is None:
        return None
    try:
        keys = owner.keys()
    except (AttributeError, TypeError):
        keys = ()
    if name in keys:
        value = owner[name]
    else:
        try:
            value = owner.path_resolve(name)
        except (ValueError, TypeError, AttributeError):
            return None
    if isinstance(value, (bool, int, float)) and not isinstance(value, str):
        v = float(value)
        return np.array([v, v, v, 1.0])
    try:
        items = list(value)
    except TypeError:
        return None
    if not 0 < len(items) <= 4 or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in items):
        return None
    rgba = np.array([0.0, 0.0, 0.0, 1.0])
    rgba[:len(items)] = [float(x) for x in items]
    return rgba


def object_attribute(instance, key: str) -> np.ndarray:
    """The RGBA (4,) of an Object or Instancer attribute `key` ("OBJECT:name", "INSTANCER:name") for a depsgraph
    object instance, found where Cycles looks (BKE_object_dupli_find_rgba_attribute): for Instancer, on an instance,
    its particle system's settings and then its instancer; then the object, then its data; 0 where none has it."""
    kind, name = key.split(":", 1)
    owners = []
    if kind == "INSTANCER" and instance.is_instance:
        system = getattr(instance, "particle_system", None)
        owners += [system.settings if system is not None else None, instance.parent]
        parent = instance.parent
        if system is None and any(m.type == "NODES" for m in getattr(parent, "modifiers", ())):
            note = (f"Instancer attribute '{name}' of the instances of '{parent.name}': Cycles reads an instance "
                    "attribute of that name made by geometry nodes first, which Blender's Python API does not show; "
                    "Primer reads the instancer's and the object's properties only")
            if note not in ATTRIBUTE_NOTES:
                ATTRIBUTE_NOTES.append(note)
    owners += [instance.object, getattr(instance.object, "data", None)]
    for owner in owners:
        value = property_rgba(owner, name)
        if value is not None:
            return value.astype(np.float32).astype(np.float64)       # (Cycles keeps it in float)
    return np.zeros(4)


def object_attributes(instance) -> dict:
    """Every Object and Instancer attribute read so far (INSTANCE_ATTRIBUTES) for a depsgraph object instance,
    key -> RGBA (core/scene Instance.attributes), or None when the materials read none; the Particle Info's four."""
    if not INSTANCE_ATTRIBUTES:
        return None
    values = {key: object_attribute(instance, key) for key in INSTANCE_ATTRIBUTES if not key.startswith("PARTICLE:")}
    if "PARTICLE:0" in INSTANCE_ATTRIBUTES:
        columns = particle_columns(instance)
        values.update({f"PARTICLE:{k}": columns[4 * k:4 * k + 4] for k in range(4)})
    return values


def particle_columns(instance) -> np.ndarray:
    """The Particle Info of a depsgraph object instance (16,) float64, as Cycles' sync_dupli_particle reads it for an
    object a particle system instanced (core/materials/graph.py PARTICLE_INFO_COLUMNS): its particle's index, age
    (the scene's frame less its birth time), lifetime, size, location, Random (hash_uint2_to_float(index, 0)),
    velocity and angular velocity; Cycles' particle 0 (all 0, Random of index 0) for any other object or a child
    particle."""
    columns = np.zeros(16)
    system = getattr(instance, "particle_system", None) if instance.is_instance else None
    index = int(instance.persistent_id[0]) if system is not None else -1
    if system is not None and 0 <= index < len(system.particles):
        particle = system.particles[index]
        layer = _VIEW_LAYER[0] or bpy.context.view_layer
        scene = getattr(getattr(layer, "id_data", None), "original", None) or bpy.context.scene
        frame = float(scene.frame_current) + float(scene.frame_subframe)
        columns[0:4] = (index, frame - particle.birth_time, particle.lifetime, particle.size)
        columns[4:7] = particle.location[:]
        columns[8:11], columns[12:15] = particle.velocity[:], particle.angular_velocity[:]
    else:
        index = 0
    columns[7] = float(hash_.uint_to_float(hash_.hash_uint2(index, 0)))
    return columns.astype(np.float32).astype(np.float64)


def view_layer_attribute(name: str) -> np.ndarray:
    """A View Layer attribute's RGBA (4,): from the view layer, else the scene, else its world (Blender's
    BKE_view_layer_find_rgba_attribute); 0 where none has it."""
    layer = _VIEW_LAYER[0] or bpy.context.view_layer
    scene = getattr(layer, "id_data", None) or bpy.context.scene
    scene = getattr(scene, "original", scene)          # (an evaluated scene shows no custom properties to Python)
    for owner in (layer, scene, getattr(scene, "world", None)):
        value = property_rgba(owner, name)
        if value is not None:
            return value
    return np.zeros(4)


def set_frame(frame: int) -> None:
    """The scene's current frame (int), at which sequences and movies are read (Cycles' b_scene.r.cfra)."""
    _FRAME[0] = int(frame)


def _oiio():
    """OpenImageIO's Python module, or None."""
    try:
        import OpenImageIO
        return OpenImageIO
    except ImportError:
        return None


def _read_pixels(image, tile: int = None, frame: int = None) -> np.ndarray:
    """An image's pixels (h, w, c) as Cycles loads them (uint8, uint16, float16 or float32) bottom row first, its
    channels as stored (sRGB values of an sRGB image are left encoded; a movie's are scene-linear), its alpha as
    load_alpha_rule says (with_alpha_rule): its file, a UDIM image's `tile`, a sequence's or a movie's `frame`; a
    packed or generated image Blender holds in float, its float buffer (from_float_buffer, _float_buffer)."""
    oiio = _oiio()
    rule = load_alpha_rule(image)
    if image.source == "TILED":
        packed = next((p for p in image.packed_files if getattr(p, "tile_number", 1001) == tile), None)
        if packed is not None and oiio is not None:
            return _oiio_read_bytes(oiio, packed.packed_file.data, os.path.splitext(packed.filepath)[1], rule)
        return _oiio_read_file(oiio, tile_path(bpy.path.abspath(image.filepath, library=image.library), tile), rule)
    if image.source == "SEQUENCE":
        return _oiio_read_file(oiio, sequence_path(bpy.path.abspath(image.filepath, library=image.library), frame),
                               rule)
    if image.source == "MOVIE":
        width, height = image.size
        if width * height == 0:
            raise ValueError("Blender cannot open the movie")
        # (a frame before the first or past the last shows that one, as Blender's load_movie_single clamps it)
        frame = min(max(int(frame), 1), max(int(image.frame_duration), 1))
        return _oiio_read_file(oiio, movie_.frame_file(bpy.path.abspath(image.filepath, library=image.library), frame,
                                                       width, height, image.colorspace_settings.name,
                                                       bpy.app.binary_path))
    packed = image.packed_file
    if from_float_buffer(image):                    # (Cycles' BlenderImageLoader: Blender's float buffer, copied)
        if packed is None:                          # (a generated image: its pixels may change with no file)
            return _float_buffer(image, rule)
        data = packed.data
        return _decoded(("blender floats", len(data), hashlib.blake2b(data, digest_size=16).digest(), rule,
                         image.alpha_mode, image.colorspace_settings.name), lambda: _float_buffer(image, rule))
    if image.source == "FILE" and packed is not None and image.alpha_mode != "STRAIGHT":
        # (a packed byte image: Cycles reads Blender's byte buffer, which for Premultiplied is the file's bytes divided
        # by alpha; for Straight it is the file's bytes, read below and decoded once)
        data = packed.data
        return _decoded(("blender bytes", len(data), hashlib.blake2b(data, digest_size=16).digest(), rule,
                         image.alpha_mode, image.colorspace_settings.name), lambda: _byte_buffer(image, rule))
    if oiio is not None and image.source == "FILE":
        if packed is not None:
            data = packed.data
            suffix = os.path.splitext(image.filepath)[1] or "." + image.file_format.lower()
            return _decoded(("packed", suffix, len(data), hashlib.blake2b(data, digest_size=16).digest(), rule,
                             _HALF_ROUNDING[0]),
                            lambda: _oiio_read_bytes(oiio, data, suffix, rule))
        path = bpy.path.abspath(image.filepath, library=image.library)
        try:
            stat = os.stat(path)
        except OSError:
            return _oiio_read_file(oiio, path, rule)    # (no such file: its error)
        return _decoded(("file", os.path.abspath(path), stat.st_mtime_ns, stat.st_size, rule, _HALF_ROUNDING[0]),
                        lambda: _oiio_read_file(oiio, path, rule))
    if image.source == "FILE" and packed is None:
        path = bpy.path.abspath(image.filepath, library=image.library)
        if not os.path.isfile(path):
            raise FileNotFoundError(f"no file {path}")
    # Blender's own buffer, in bulk (OpenImageIO missing, or a generated image): rows bottom first.
    return _buffer_alpha(_pixels(image), rule, bool(image.is_float))


def _pixels(image) -> np.ndarray:
    """Blender's buffer of an image as Image.pixels gives it, in bulk: (h, w, c) float32, bottom row first."""
    width, height = image.size
    if width * height == 0:
        raise ValueError("the image is empty")
    flat = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(flat)
    return flat.reshape(height, width, image.channels)


def _float_buffer(image, rule: str) -> np.ndarray:
    """Blender's float buffer of an image (from_float_buffer) as Cycles reads it (h, w, c) float32, bottom row first:
    its values as Blender made them (scene-linear, associated), alpha 1 for `rule` "ignore" (load_alpha_rule), and
    the colours times alpha once more for "associate always" (Cycles 5.1 on, Alpha Straight; textures.associated:
    float32 products)."""
    pixels = _pixels(image)
    if rule == "ignore":
        return textures_.alpha_ignored(pixels)
    if rule == "associate always":
        return textures_.associated(pixels)
    return pixels


BYTES_CHUNK = 1 << 18     # floats per step of bytes_of_unit_floats (1 MB: stays in the cache between its passes)


def bytes_of_unit_floats(flat: np.ndarray) -> np.ndarray:
    """Bytes k = rint(255 clip(x, 0, 1)) of float32 values (n,) float32, as uint8 (n,): the same numbers as
    np.rint(np.clip(x, 0, 1) * float32(255)).astype(uint8), made a cache-sized step at a time in place in `flat`
    (which it overwrites) rather than through three whole-image float temporaries: a 4000 x 4000 RGBA texture's
    64 M floats are 256 MB per temporary, and their allocation and passes through memory cost seconds."""
    out = np.empty(len(flat), np.uint8)
    for start in range(0, len(flat), BYTES_CHUNK):
        part = flat[start:start + BYTES_CHUNK]
        np.clip(part, 0.0, 1.0, out=part)
        np.multiply(part, np.float32(255.0), out=part)
        np.rint(part, out=part)
        np.copyto(out[start:start + BYTES_CHUNK], part, casting="unsafe")
    return out


def _byte_buffer(image, rule: str) -> np.ndarray:
    """Blender's byte buffer of a packed byte image as Cycles' BlenderImageLoader reads it (h, w, 4) uint8, bottom row
    first (Image.pixels gives bytes as k x (1 / 255)): straight, as Blender keeps bytes, associated in bytes where
    `rule` (load_alpha_rule) associates, alpha 255 for "ignore"."""
    pixels = _pixels(image)
    stored = bytes_of_unit_floats(pixels.reshape(-1)).reshape(pixels.shape)
    if rule == "ignore":
        return textures_.alpha_ignored(stored)
    if rule in ("associate", "associate always"):
        return textures_.associated(stored)
    return stored


def _buffer_alpha(pixels: np.ndarray, rule: str, is_float: bool) -> np.ndarray:
    """Blender's pixel buffer (h, w, c) float32 of an image with its alpha as Cycles' BlenderImageLoader reads it: a
    byte image's (Blender keeps bytes straight, Image.pixels gives them as k x (1 / 255)) associated in bytes as
    textures.associated does, where `rule` (load_alpha_rule) associates; a float image's as it is (Blender keeps float
    buffers associated); alpha 1 for "ignore"."""
    if rule == "ignore":
        return textures_.alpha_ignored(pixels)
    if rule not in ("associate", "associate always") or is_float or not textures_.has_alpha_below_one(pixels):
        return pixels
    stored = np.rint(np.clip(pixels, 0.0, 1.0) * np.float32(255.0)).astype(np.uint8)
    return textures_.associated(stored).astype(np.float32) * np.float32(1.0 / 255.0)


def _decoded(key: tuple, read) -> np.ndarray:
    """The pixels of an image file as `read()` decodes them, decoded once for the renders that follow one another:
    key names the file's contents (a packed file's bytes by their hash; a file on disk by its path, modification time
    and size) and how its alpha is read, and the pixels an export used are kept (read-only) for the next export, the
    others dropped (begin_export), as Blender keeps a decoded image in memory for Cycles' renders after the first."""
    pixels = _DECODED_NOW.get(key)
    if pixels is None:
        pixels = _DECODED_BEFORE.get(key)
    if pixels is None:
        pixels = read()
        pixels.flags.writeable = False
    _DECODED_NOW[key] = pixels
    return pixels


def _oiio_read_file(oiio, path: str, rule: str = None) -> np.ndarray:
    """An image file's pixels with OpenImageIO (_oiio_read, `rule` as there); FileNotFoundError where there is no
    such file, OSError without OpenImageIO (tiles and sequences are read from their files only)."""
    if not os.path.isfile(path):
        raise FileNotFoundError(f"no file {path}")
    if oiio is None:
        raise OSError("OpenImageIO is not available to read it")
    return _oiio_read(oiio, path, rule)


def _oiio_read_bytes(oiio, data: bytes, suffix: str, rule: str = None) -> np.ndarray:
    """A packed file's pixels (its bytes, its file name's `suffix` such as ".png"), read with OpenImageIO from a
    temporary file (`rule` as _oiio_read)."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "packed" + suffix)
        with open(path, "wb") as handle:
            handle.write(data)
        return _oiio_read(oiio, path, rule)


def _oiio_read(oiio, path: str, rule: str = None) -> np.ndarray:
    """An image file's pixels with OpenImageIO at their stored precision (uint8 for 8-bit files, uint16 for
    16-bit ones, float16 for half-float ones, which Cycles keeps as half (textures.limited rounds its means to half;
    textures.Image reads them as float32, exactly), else float32), flipped to bottom row first. With a `rule`
    (load_alpha_rule) the file is opened as Cycles' OIIOImageLoader opens it, its colours as stored
    (oiio:UnassociatedAlpha 1), and its alpha read by with_alpha_rule; without one (a movie's frame, scene-linear
    floats from Blender), OpenImageIO's own reading."""
    if rule is None:
        buf = oiio.ImageBuf(path)
    else:
        config = oiio.ImageSpec()
        config.attribute("oiio:UnassociatedAlpha", 1)
        buf = oiio.ImageBuf(path, 0, 0, config)
    if buf.has_error:
        raise OSError(buf.geterror())
    spec = buf.spec()
    stored = spec.format.basetype
    kind, dtype = ((oiio.UINT8, np.uint8) if stored == oiio.UINT8 else
                   (oiio.UINT16, np.uint16) if stored == oiio.UINT16 else
                   (oiio.HALF, np.float16) if stored == oiio.HALF else (oiio.FLOAT, np.float32))
    pixels = buf.get_pixels(kind)
    if pixels is None or buf.has_error:
        raise OSError(buf.geterror() or "unreadable")
    pixels = np.asarray(pixels, dtype)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    pixels = np.ascontiguousarray(pixels[::-1])
    if rule is None:
        return pixels
    return with_alpha_rule(pixels, rule, stored_straight(spec, str(buf.file_format_name)))


def stored_straight(spec, format_name: str) -> bool:
    """Whether a file (its OpenImageIO ImageSpec, opened with oiio:UnassociatedAlpha 1, and its format's name) stores
    colours with straight alpha, as Cycles' OIIOImageLoader::load_pixels decides: OpenImageIO says so
    (oiio:UnassociatedAlpha: PNG, TIFF with unassociated alpha ...; not EXR, which stores them associated); or, for
    a file with an alpha channel, a Targa whose alpha type is not 4 (premultiplied), and every DDS and PSD file."""
    if spec.get_int_attribute("oiio:UnassociatedAlpha", 0):
        return True
    if spec.alpha_channel == -1:
        return False
    if format_name == "targa":
        return spec.get_int_attribute("targa:alpha_type", -1) != 4
    return format_name in ("dds", "psd")


def with_alpha_rule(pixels: np.ndarray, rule: str, straight: bool) -> np.ndarray:
    """An image file's pixels (h, w, c) as stored, `straight` when the file keeps its colours unassociated
    (stored_straight), as Cycles keeps them for `rule` (load_alpha_rule): "associate always" multiplies the colours
    by their alpha whatever the file stores (Cycles 5.1 on, Alpha Straight), "associate" multiplies a straight file's
    colours by their alpha (textures.associated: 4 channels only; half floats made half as this export's
    _HALF_ROUNDING says), "ignore" sets the alpha to 1 (textures.alpha_ignored), "straight" leaves them. Pixels with
    no alpha below 1 are given back untouched."""
    if rule == "ignore":
        return textures_.alpha_ignored(pixels)
    if rule == "associate always" or (rule == "associate" and straight):
        return textures_.associated(pixels, _HALF_ROUNDING[0] or half_rounding_now())
    return pixels


def shader_nodes(material, warnings: list) -> list:
    """The material's surface as [(node name in core/materials/nodes.py, weight (3,), inputs dict, factors)]:
    inputs are values or graph.Links; factors [(graph.Link, mode)] multiply the weight per hit."""
    reader = NodeReader(material, warnings)
    out: list = []
    tree = node_tree(material)
    output = output_node(tree, "ShaderNodeOutputMaterial") if tree is not None else None
    if output is not None:
        _collect_socket(reader, output.inputs["Surface"], np.ones(3), out, ())
    return out


def aov_outputs(material, warnings: list, kind: str = "material", kernels: str = "compiled") -> list:
    """The material's (or with kind "world" the world's) AOV Output nodes as core Material.aovs (World.aovs) [(AOV
    name, Color: (3,) or a graph.Link, Value: float or a graph.Link)], those inside node groups too (Cycles' sync adds a
    group's nodes with the rest); a node with no name writes nothing (Cycles finds no AOV of that name)."""
    tree = node_tree(material)
    if tree is None:
        return []
    reader = NodeReader(material, warnings, kind=kind, kernels=kernels)
    out: list = []

    def walk(nodes, path: tuple, depth: int = 0) -> None:
        for node in nodes:
            if node.bl_idname == "ShaderNodeOutputAOV" and getattr(node, "aov_name", ""):
                out.append((node.aov_name, reader.input(node, "Color", np.zeros(3), path),
                            reader.input(node, "Value", 0.0, path)))
            elif node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and depth < 32:
                walk(node.node_tree.nodes, path + (node,), depth + 1)

    walk(tree.nodes, ())
    return out


def _collect_socket(reader: NodeReader, socket, weight: np.ndarray, out: list, factors: tuple) -> None:
    """Append the shaders linked into the closure input `socket` (see _collect); a value, colour or vector linked
    there is an Emission shader, as Cycles converts it: a colour or vector its Color (Strength 1), a value its
    Strength (Color white)."""
    if auto_emission(socket):
        out.append(("EMISSION", weight, {"emission": auto_emission_of(reader, socket)}, list(factors)))
        return
    source = linked_output_of(socket)
    if source is not None and source.node.bl_idname == "NodeGroupInput" and reader.path:
        # A shader handed into the group: the one linked into the group node's input of that socket.
        group = reader.path[-1]
        outer = next((s for s in group.inputs if s.identifier == source.identifier), None)
        if outer is not None:
            reader.path = reader.path[:-1]
            try:
                _collect_socket(reader, outer, weight, out, factors)
            finally:
                reader.path += (group,)
        return
    _collect(reader, linked_node_of(socket), weight, out, factors)


def _transformed(vector, kind: str, source: str, target: str, name: str) -> Link:
    """A Vector Transform node's Link of `vector` (a value or a Link) of type `kind` from space `source` to `target`."""
    return Link(GraphNode("VECTOR_TRANSFORM", {"type": kind, "from": source, "to": target}, {"Vector": vector}, name),
                "Vector")


def _math(operation: str, a, b):
    """A Math node's result of a and b (constants or Links): a number when both are, else a MATH node's Link."""
    if not _linked(a) and not _linked(b):
        a, b = float(np.asarray(a).reshape(-1)[0]), float(np.asarray(b).reshape(-1)[0])
        return a - b if operation == "SUBTRACT" else a * b
    return Link(GraphNode("MATH", {"operation": operation, "clamp": False}, {"0": a, "1": b}), "Value")


def bump_filter_width() -> float:
    """The Filter Width of a Bump node without the input, and of a Displacement's bump: Cycles' BumpNode default
    (graph.BUMP_FILTER_WIDTH) from Blender 4.5; before it, Cycles stepped a whole ray differential (1)."""
    return graph_.BUMP_FILTER_WIDTH if bpy.app.version >= (4, 5, 0) else 1.0


def displacement_bump(offset, output, undisplaced=False):
    """A material's Displacement output `offset` (as NodeReader.input reads it from `output`) as Cycles renders it
    with Displacement Method Bump Only (its default; also the bump part of Displacement and Bump): the offset's
    height along the shading normal fed to a Bump node of Strength 1 and Distance 1, whose normal becomes the
    material's (ShaderGraph::bump_from_displacement). `undisplaced`: the surface moved (Displacement and Bump), the
    bump evaluated over it as it was before and in object space (Cycles' ENTER_BUMP_EVAL, bump_in_object_space;
    graph.undisplaced_point, graph.bump). Returns the Bump's
    Link, or None where the output does not vary per hit."""
    if not _linked(offset):
        return None
    normal = Link(GraphNode("GEOMETRY", {}, {}, output.name), "Normal")
    height = Link(GraphNode("VECTOR_MATH", {"operation": "DOT_PRODUCT"}, {"Vector": offset, "Vector_001": normal},
                            output.name), "Value")
    return Link(GraphNode("BUMP", {"invert": False, "filter_width": bump_filter_width(), "undisplaced": undisplaced},
                          {"Strength": 1.0, "Distance": 1.0, "Height": height},
                          output.name), "Normal")


def _math2(operation: str, a, b):
    """A Math node's Link of a and b (constants or Links) for any operation."""
    return Link(GraphNode("MATH", {"operation": operation, "clamp": False}, {"0": a, "1": b}), "Value")


def vector_op(operation: str, name: str, **inputs) -> Link:
    """A Vector Math node's Vector output of `inputs` (Vector, Vector_001, Scale: constants or Links)."""
    return Link(GraphNode("VECTOR_MATH", {"operation": operation}, dict(inputs), name), "Vector")


def _linked(value) -> bool:
    """Whether an input's value is a graph.Link (fed per hit) rather than a constant."""
    return isinstance(value, Link)


def _scaled(color, strength):
    """Colour x strength: a number when both are, else a SCALE node's Link."""
    if not _linked(color) and not _linked(strength):
        return np.asarray(color, np.float64) * float(strength)
    return Link(GraphNode("SCALE", {}, {"Color": color, "Factor": strength}), "Color")


def same_graph(a, b, depth: int = 0) -> bool:
    """Whether two values (constants or graph.Links) compute the same thing: the same node kinds, settings
    (the same image) and inputs, all the way down (glTF's importer gives Normal and Coat Normal a Normal Map
    node each for one shared map)."""
    if depth > 64:
        return False
    if _linked(a) != _linked(b):
        return False
    if not _linked(a):
        return np.array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object))
    if a.node is b.node:
        return a.output == b.output
    na, nb = a.node, b.node
    if a.output != b.output or na.kind != nb.kind or set(na.props) != set(nb.props) or set(na.inputs) != set(nb.inputs):
        return False
    for key in na.props:
        x, y = na.props[key], nb.props[key]
        if x is not y and not (isinstance(x, (str, int, float, bool, tuple)) and x == y) \
                and not (isinstance(x, np.ndarray) and isinstance(y, np.ndarray) and np.array_equal(x, y)):
            return False
    return all(same_graph(na.inputs[key], nb.inputs[key], depth + 1) for key in na.inputs)


def _normal(reader: NodeReader, node, inputs: dict) -> None:
    """A BSDF's Normal input, when linked (a Normal Map, a Bump), into inputs["normal"]."""
    socket = node.inputs.get("Normal")
    if socket is not None and socket.is_linked:
        value = reader.input(node, "Normal", None)
        if _linked(value):
            inputs["normal"] = value


def _tangent(reader: NodeReader, node, inputs: dict, amount: str) -> None:
    """A BSDF's Tangent input into inputs["tangent"] where its anisotropy (input `amount`) is linked or not 0: the
    link, or Cycles' default for an unlinked Tangent (a Tangent node, Radial about Z of Generated)."""
    socket = node.inputs.get("Tangent")
    value = inputs.get(amount)
    if socket is None or value is None or (not _linked(value) and abs(float(np.max(value))) <= 1e-4
                                           and abs(float(np.min(value))) <= 1e-4):
        return
    if socket.is_linked:
        inputs["tangent"] = reader.input(node, "Tangent", np.zeros(3))
    else:
        inputs["tangent"] = Link(GraphNode("TANGENT", {"direction": "RADIAL", "axis": "Z", "map": ""}), "Tangent")


def _metallic(reader: NodeReader, node, weight: np.ndarray, out: list, factors: tuple) -> None:
    """Append a Metallic BSDF as the metal of a Principled BSDF of Metallic 1 (the same closure in Cycles: GGX,
    Multiscatter GGX or Beckmann with the F82-tint Fresnel from Base Color to its Edge Tint, anisotropic by sqrt(1 - 0.9 a),
    thin film); a Physical Conductor's IOR and Extinction become the F82 curve through the conductor's reflectance at
    0 and 82 degrees (nodes.conductor_as_f82; Cycles evaluates the complex Fresnel at every angle)."""
    distribution = getattr(node, "distribution", "MULTI_GGX")
    inputs = {"metallic": 1.0, "roughness": reader.input(node, "Roughness", 0.5),
              "multiscatter": 1.0 if distribution == "MULTI_GGX" else 0.0,
              "metal_distribution": float(DISTRIBUTIONS.get(distribution, 0))}
    if getattr(node, "fresnel_type", "F82") == "PHYSICAL_CONDUCTOR":
        n, k = reader.input(node, "IOR", np.ones(3)), reader.input(node, "Extinction", np.zeros(3))
        if _linked(n) or _linked(k):
            reader.warn(node, "a linked IOR or Extinction is read at its own value (Primer fits the F82 curve once)")
            n, k = own_value(node.inputs["IOR"]), own_value(node.inputs["Extinction"])
        f0, tint = nodes_.conductor_as_f82(np.asarray(n, np.float64)[:3], np.asarray(k, np.float64)[:3])
        inputs["base_color"], inputs["specular_tint"] = f0, tint
    else:
        for socket, key in (("Base Color", "base_color"), ("Edge Tint", "specular_tint")):
            value = reader.input(node, socket, np.ones(3))
            inputs[key] = value if _linked(value) else np.clip(np.asarray(value, np.float64), 0.0, 1.0)
    for socket, key in (("Anisotropy", "anisotropic"), ("Rotation", "anisotropic_rotation"),
                        ("Thin Film Thickness", "thin_film_thickness"), ("Thin Film IOR", "thin_film_ior")):
        if node.inputs.get(socket) is not None:
            inputs[key] = reader.input(node, socket, 0.0)
    _normal(reader, node, inputs)
    _tangent(reader, node, inputs, "anisotropic")
    out.append(("PRINCIPLED", weight, inputs, list(factors)))


def _collect(reader: NodeReader, node, weight: np.ndarray, out: list, factors: tuple) -> None:
    """Append the shader nodes under `node`, their weights multiplied by `weight` and the per-hit `factors`."""
    node = _follow(node)
    if node is None or not weight.any():
        return
    kind = node.bl_idname
    if kind == "ShaderNodeMixShader":
        fac = reader.input(node, "Fac", 0.5)
        if _linked(fac):
            for socket, mode in ((node.inputs[1], "one_minus"), (node.inputs[2], "fac")):
                if socket.is_linked:
                    _collect_socket(reader, socket, weight, out, factors + ((fac, mode),))
            return
        fac = float(np.clip(np.mean(fac), 0.0, 1.0))
        for socket, share in ((node.inputs[1], 1.0 - fac), (node.inputs[2], fac)):
            if socket.is_linked:
                _collect_socket(reader, socket, weight * share, out, factors)
    elif kind == "ShaderNodeGroup" and node.node_tree is not None:
        # A node group whose output is a shader: the shader nodes inside it, their inputs read in the group.
        outputs = [n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput"]
        inner = next((n for n in outputs if getattr(n, "is_active_output", False)), outputs[0] if outputs else None)
        socket = next((s for s in inner.inputs if s.type == "SHADER" and s.is_linked), None) if inner else None
        if socket is None:
            reader.warn(node, "the group gives no shader; Primer leaves this part black")
            return
        reader.path += (node,)
        try:
            _collect_socket(reader, socket, weight, out, factors)
        finally:
            reader.path = reader.path[:-1]
    elif kind == "ShaderNodeBsdfSheen":
        # Cycles' microfiber sheen (core/materials/sheen.py), or the older Ashikhmin velvet (velvet.py).
        velvet = getattr(node, "distribution", "MICROFIBER") == "ASHIKHMIN"
        color = reader.input(node, "Color", np.full(3, 0.8))
        inputs = {"roughness": reader.input(node, "Roughness", 0.5), "velvet": 1.0 if velvet else 0.0}
        _normal(reader, node, inputs)
        if _linked(color):
            out.append(("SHEEN", weight, inputs, list(factors) + [(color, "color")]))
        else:
            out.append(("SHEEN", weight * np.maximum(color, 0.0), inputs, list(factors)))
    elif kind == "ShaderNodeAddShader":
        for socket in (node.inputs[0], node.inputs[1]):
            if socket.is_linked:
                _collect_socket(reader, socket, weight, out, factors)
    elif kind == "ShaderNodeBsdfPrincipled":
        inputs = {key: reader.input(node, socket, None) for socket, key in PRINCIPLED_SOCKETS.items()}
        inputs = {key: value for key, value in inputs.items() if value is not None}
        inputs["emission"] = _scaled(reader.input(node, "Emission Color", np.ones(3)),
                                     reader.input(node, "Emission Strength", 0.0))
        inputs["multiscatter"] = 1.0 if getattr(node, "distribution", "MULTI_GGX") == "MULTI_GGX" else 0.0
        method = getattr(node, "subsurface_method", "RANDOM_WALK")
        inputs["subsurface_method"] = subsurface_.method_of(method, tuple(bpy.app.version))
        _normal(reader, node, inputs)
        _tangent(reader, node, inputs, "anisotropic")
        for socket, instead in PRINCIPLED_LEFT_OUT.items():
            own = node.inputs.get(socket)
            if own is None:
                continue
            if own.is_linked:
                reader.warn(node, f"'{socket}' is linked; where it is above 0 Primer {instead}")
            elif not own.is_linked and float(np.max(reader.value(node, socket, 0.0))) > 0.0:
                reader.warn(node, f"'{socket}' is above 0; Primer {instead}")
        # The coat's normal: Coat Normal, or the hit's own normal where it is unlinked (Cycles); fed by the very
        # node that feeds Normal (glTF's usual shared map) the coat takes the node's own normal, no second copy.
        coat_normal = node.inputs.get("Coat Normal")
        if coat_normal is not None and coat_normal.is_linked:
            coat_value = reader.input(node, "Coat Normal", None)
            normal = inputs.get("normal")
            if _linked(coat_value) and _linked(normal) and same_graph(coat_value, normal):
                inputs["coat_follows_normal"] = 1.0
            elif _linked(coat_value):
                inputs["coat_normal"] = coat_value
        out.append(("PRINCIPLED", weight, inputs, list(factors)))
    elif kind == "ShaderNodeBsdfMetallic":
        _metallic(reader, node, weight, out, factors)
    elif kind == "ShaderNodeBsdfDiffuse":
        # Roughness above 0: Oren-Nayar's rough diffuse, which also needs the colour itself.
        color = reader.input(node, "Color", np.full(3, 0.8))
        inputs: dict = {}
        roughness = reader.input(node, "Roughness", 0.0)
        if _linked(roughness) or float(np.max(roughness)) > 0.0:
            inputs["roughness"] = roughness
            inputs["color"] = color if _linked(color) else np.clip(np.asarray(color, np.float64), 0.0, 1.0)
        _normal(reader, node, inputs)
        if _linked(color):
            out.append(("DIFFUSE", weight, inputs, list(factors) + [(color, "color")]))
        else:
            out.append(("DIFFUSE", weight * np.maximum(color, 0.0), inputs, list(factors)))
    elif kind in GLOSSY_IDS:
        distribution = getattr(node, "distribution", "GGX")
        if distribution not in DISTRIBUTIONS:
            reader.warn(node, f"distribution {distribution} is not modelled; Primer uses GGX")
        color = reader.input(node, "Color", np.full(3, 0.8))
        inputs = {"roughness": reader.input(node, "Roughness", 0.5),
                  "multiscatter": 1.0 if distribution == "MULTI_GGX" else 0.0,
                  "distribution": float(DISTRIBUTIONS.get(distribution, 0))}
        for socket, key in (("Anisotropy", "anisotropy"), ("Rotation", "rotation")):
            if node.inputs.get(socket) is not None:
                inputs[key] = reader.input(node, socket, 0.0)
        _normal(reader, node, inputs)
        _tangent(reader, node, inputs, "anisotropy")
        if _linked(color):
            inputs["color"] = color
            out.append(("GLOSSY", weight, inputs, list(factors) + [(color, "color")]))
        else:
            color = np.maximum(color, 0.0)
            inputs["color"] = color
            out.append(("GLOSSY", weight * color, inputs, list(factors)))
    elif kind in ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"):
        roughness = reader.input(node, "Roughness", 0.0)
        distribution = getattr(node, "distribution", "GGX")
        if distribution not in DISTRIBUTIONS.keys() - {"ASHIKHMIN_SHIRLEY"}:
            reader.warn(node, f"distribution {distribution} is not modelled; Primer uses GGX")
        # Colour and IOR as Cycles reads them, per hit where linked (the node clamps: colour >= 0, IOR >= 1e-5).
        color, ior = reader.input(node, "Color", np.ones(3)), reader.input(node, "IOR", 1.5)
        inputs = {"color": color if _linked(color) else np.maximum(color, 0.0),
                  "ior": ior if _linked(ior) else float(np.asarray(ior, np.float64).reshape(-1)[0]),
                  "refraction_only": 1.0 if kind == "ShaderNodeBsdfRefraction" else 0.0,
                  "roughness": roughness, "multiscatter": 1.0 if distribution == "MULTI_GGX" else 0.0,
                  "distribution": float(DISTRIBUTIONS.get(distribution, 0))}
        _normal(reader, node, inputs)
        out.append(("GLASS", weight, inputs, list(factors)))
    elif kind == "ShaderNodeBsdfToon":
        # core/materials/toon.py: the Diffuse or Glossy component, its Size and Smooth per hit where linked.
        color = reader.input(node, "Color", np.full(3, 0.8))
        inputs = {"size": reader.input(node, "Size", 0.5), "smooth": reader.input(node, "Smooth", 0.0),
                  "glossy": 1.0 if getattr(node, "component", "DIFFUSE") == "GLOSSY" else 0.0}
        _normal(reader, node, inputs)
        if _linked(color):
            out.append(("TOON", weight, inputs, list(factors) + [(color, "color")]))
        else:
            out.append(("TOON", weight * np.maximum(color, 0.0), inputs, list(factors)))
    elif kind == "ShaderNodeBsdfHairPrincipled":
        # core/materials/hair.py: Chiang's model (its closure weight is the Mix weights alone: the colour is absorption).
        _principled_hair(reader, node, weight, out, factors)
    elif kind == "ShaderNodeBsdfHair":
        # core/materials/hair.py HairNode: the Reflection or Transmission component, the colour an input (it tints
        # the closure, not the light passing the strand's own tube); an unlinked Tangent is the curve's (Cycles' dPdu).
        color = reader.input(node, "Color", np.full(3, 0.8))
        inputs = {"offset": reader.input(node, "Offset", 0.0), "roughness_u": reader.input(node, "RoughnessU", 0.1),
                  "roughness_v": reader.input(node, "RoughnessV", 1.0),
                  "transmission": 1.0 if getattr(node, "component", "Reflection") == "Transmission" else 0.0}
        tangent = node.inputs.get("Tangent")
        inputs["tangent"] = reader.input(node, "Tangent", np.zeros(3)) if tangent is not None and tangent.is_linked \
            else hair_.curve_links()["tangent"]
        inputs["surface_tangent"] = hair_.mesh_links("triangle_dpdv")["surface_tangent"]   # (meshes: dPdv, no offset)
        inputs["color"] = color if _linked(color) else np.maximum(np.asarray(color, np.float64)[:3], 0.0)
        out.append(("HAIR", weight, inputs, list(factors)))
    elif kind == "ShaderNodeSubsurfaceScattering":
        # core/materials/subsurface.py SubsurfaceNode: the colour is the walk's albedo too, so it stays an input.
        method = getattr(node, "falloff", "RANDOM_WALK")
        inputs = {"color": reader.input(node, "Color", np.full(3, 0.8)),
                  "radius": reader.input(node, "Radius", np.array([1.0, 0.2, 0.1])),
                  "scale": reader.input(node, "Scale", 0.05), "ior": reader.input(node, "IOR", 1.4),
                  "roughness": reader.input(node, "Roughness", 1.0),
                  "anisotropy": reader.input(node, "Anisotropy", 0.0),
                  "method": subsurface_.method_of(method, tuple(bpy.app.version))}
        _normal(reader, node, inputs)
        out.append(("SUBSURFACE", weight, inputs, list(factors)))
    elif kind in EMISSION_NODES:
        # (A Background node at a Surface emits as an Emission does: Cycles' background_setup and emission_setup
        # add to the same emission, and its emission estimate reads both alike.)
        emission = _scaled(reader.input(node, "Color", np.ones(3)), reader.input(node, "Strength", 1.0))
        out.append(("EMISSION", weight, {"emission": emission}, list(factors)))
    elif kind == "ShaderNodeBsdfTransparent":
        color = reader.input(node, "Color", np.ones(3))
        if _linked(color):
            out.append(("TRANSPARENT", weight, {}, list(factors) + [(color, "color")]))
        else:
            out.append(("TRANSPARENT", weight * np.maximum(color, 0.0), {}, list(factors)))
    elif kind == "ShaderNodeBsdfRayPortal":
        # core/materials/portal.py: the ray goes on from Position (unlinked: the hit point) along Direction (zero:
        # its own), per hit where linked.
        color = reader.input(node, "Color", np.ones(3))
        inputs = {"direction": reader.input(node, "Direction", np.zeros(3))}
        socket = node.inputs.get("Position")
        if socket is not None and socket.is_linked:
            inputs["position"], inputs["position_set"] = reader.input(node, "Position", np.zeros(3)), 1.0
        if _linked(color):
            out.append(("RAY_PORTAL", weight, inputs, list(factors) + [(color, "color")]))
        else:
            out.append(("RAY_PORTAL", weight * np.maximum(color, 0.0), inputs, list(factors)))
    elif kind == "ShaderNodeHoldout":
        # A hole in the film for camera paths, as much as its weight (the Mix and Add Shaders above it).
        out.append(("HOLDOUT", weight, {}, list(factors)))
    elif kind in ONE_CLOSURE_NODES:
        # A node that adds one closure of a BSDF (core/materials Node.bsdf): its colour weighs it, a linked colour per
        # hit, and a linked Normal is the closure's own.
        color = reader.input(node, "Color", np.full(3, 0.8))
        inputs = {}
        _normal(reader, node, inputs)
        if _linked(color):
            out.append((ONE_CLOSURE_NODES[kind], weight, inputs, list(factors) + [(color, "color")]))
        else:
            out.append((ONE_CLOSURE_NODES[kind], weight * np.maximum(color, 0.0), inputs, list(factors)))
    elif kind.startswith("ShaderNodeVolume"):
        # A volume closure at a Surface socket: Cycles renders nothing of it on the surface.
        reader.warn(node, f"'{node.bl_label}' is a volume shader at a Surface output; it adds nothing there (as in "
                          "Cycles)")
    elif kind == "ShaderNodeEeveeSpecular":
        # EEVEE's own node: Cycles' sync makes nothing of it, so the surface it feeds is black.
        reader.warn(node, "the Specular BSDF is EEVEE's only; Cycles renders nothing of it (black), and so does Primer")
    else:
        color = node.inputs.get("Color") or node.inputs.get("Base Color")
        reader.warn(node, f"'{node.bl_label}' is not a shader node Primer knows; "
                          + ("it uses a diffuse surface of the node's colour" if color is not None else "it leaves it black"))
        if color is not None:
            out.append(("DIFFUSE", weight * np.maximum(np.array(color.default_value[:3], np.float64), 0.0), {},
                        list(factors)))


# The Principled Hair BSDF's sockets, as core/materials/hair.py's PrincipledHairNode names its inputs.
HAIR_SOCKETS = {"Color": "color", "Melanin": "melanin", "Melanin Redness": "melanin_redness", "Tint": "tint",
                "Absorption Coefficient": "absorption", "Roughness": "roughness", "Radial Roughness": "radial_roughness",
                "Coat": "coat", "IOR": "ior", "Offset": "offset", "Random Color": "random_color",
                "Random Roughness": "random_roughness"}
HAIR_PARAMETRIZATIONS = {"COLOR": "direct_coloring", "MELANIN": "melanin", "ABSORPTION": "absorption"}


def slot_materials(obj) -> list:
    """The original materials (bpy Material or None) of an object's slots, in order: the export reads evaluated
    copies, whose `original` is the data the file holds."""
    return [getattr(slot.material, "original", slot.material) for slot in obj.material_slots]


def shades_curves(material) -> bool:
    """Whether `material` (a bpy Material) is in a slot of a hair Curves object or is the one a rendered hair
    particle system takes (export.rendered_hair; its Material slot, 1-based): where it may shade curves."""
    import bpy
    from . import export
    target = getattr(material, "original", material)
    for obj in bpy.data.objects:
        slots = slot_materials(obj)
        if obj.type == "CURVES" and target in slots:
            return True
        if obj.type == "MESH" and slots:
            for system in export.rendered_hair(obj):
                if slots[min(max(int(system.settings.material) - 1, 0), len(slots) - 1)] == target:
                    return True
    return False


def _principled_hair(reader: NodeReader, node, weight: np.ndarray, out: list, factors: tuple) -> None:
    """Append the Principled Hair BSDF (Chiang's model, hair.PrincipledHairNode; Huang's, huang.HuangHairNode): its
    sockets per hit where linked, the curve's tangent (and for Huang's its normal, the major axis), Random from Curves
    Info's Random unless linked (as Cycles)."""
    inputs = {key: reader.input(node, socket, None) for socket, key in HAIR_SOCKETS.items()}
    inputs = {key: value for key, value in inputs.items() if value is not None}
    parametrization = HAIR_PARAMETRIZATIONS.get(getattr(node, "parametrization", "COLOR"), "direct_coloring")
    inputs["parametrization"] = float(hair_.PARAMETRIZATIONS[parametrization])
    random = node.inputs.get("Random")
    inputs.update(hair_.curve_links())
    inputs.update(hair_.mesh_links("triangle_dpdu"))              # (on meshes: Cycles' dPdu, Chiang's Ng)
    if random is not None and random.is_linked:
        inputs["random"] = reader.input(node, "Random", 0.0)
    if getattr(node, "model", "CHIANG") == "HUANG":
        # Cycles' Huang model has no Coat and no Radial Roughness (its Roughness serves the colour's fit too).
        inputs.pop("coat", None)
        inputs.pop("surface_bitangent", None)                    # (Huang's h reads the shading normal)
        inputs.pop("radial_roughness", None)
        for socket, key in HUANG_SOCKETS.items():
            value = reader.input(node, socket, None)
            if value is not None:
                inputs[key] = value
        inputs.update(huang_.huang_links())
        aspect = node.inputs.get("Aspect Ratio")
        if aspect is not None and (aspect.is_linked or aspect.default_value != 1.0) and shades_curves(reader.material):
            reader.warn(node, "where it shades curves, the Huang model's elliptical fibres take their major axis from "
                              "Primer's rotation-minimising curve normal (started from tangent x Z, as Blender's Minimum "
                              "Twist normal); Cycles reads the curve's own normal attribute (its Normal Mode); on "
                              "meshes the fibres are round in both")
        out.append(("PRINCIPLED_HAIR_HUANG", weight, inputs, list(factors)))
        return
    out.append(("PRINCIPLED_HAIR", weight, inputs, list(factors)))


# The Huang model's own sockets (huang.HuangHairNode's inputs).
HUANG_SOCKETS = {"Aspect Ratio": "aspect_ratio", "Reflection": "reflection", "Transmission": "transmission",
                 "Secondary Reflection": "secondary_reflection"}


# A volume node's inputs, by socket name, as core/volumes' closures read them (`inputs` keys).
VOLUME_SOCKETS = {"Color": "color", "Density": "density", "Anisotropy": "anisotropy",
                  "Absorption Color": "absorption_color", "Emission Strength": "emission_strength",
                  "Emission Color": "emission_color", "Absorption Coefficients": "absorption",
                  "Scatter Coefficients": "scatter", "Emission Coefficients": "emission", "Strength": "strength",
                  "Blackbody Intensity": "blackbody_intensity", "Blackbody Tint": "blackbody_tint",
                  "Temperature": "temperature"}
# The Phase menu's inputs (Volume Scatter, Volume Coefficients; core/volumes/phase.py of_node; a material's may be
# fed by links: set up point by point, core/volumes/field.py).
PHASE_SOCKETS = {"IOR": "ior", "Backscatter": "backscatter", "Alpha": "alpha", "Diameter": "diameter"}


def volume_closures(reader: "NodeReader", node, weight: float = 1.0, out: list = None, factors: tuple = ()) -> list:
    """The volume closures under `node` (a Volume output's link) as core/volumes reads them: [(name in
    VOLUME_BY_NAME, weight float, inputs dict)], the Mix and Add Shaders' constant factors multiplied out.
    A material's or the world's closure may have inputs fed by links (graph.Link: a heterogeneous medium,
    core/volumes/field.py; the world's: media.world_field_of), and a Mix Shader's linked factor weighs the closures
    under it per point (inputs["factors"]: [(Link, "fac" | "one_minus")], as a surface's). Volume nodes and phase
    functions Primer does not know are warned of."""
    out = [] if out is None else out
    node = _follow(node)
    if node is None or weight == 0.0:
        return out
    kind = node.bl_idname
    if kind == "ShaderNodeMixShader":
        fac = reader.input(node, "Fac", 0.5)
        if _linked(fac):
            for socket, mode in ((node.inputs[1], "one_minus"), (node.inputs[2], "fac")):
                if socket.is_linked:
                    volume_closures(reader, socket.links[0].from_node, weight, out, factors + ((fac, mode),))
            return out
        fac = float(np.clip(np.mean(fac), 0.0, 1.0))
        for socket, share in ((node.inputs[1], 1.0 - fac), (node.inputs[2], fac)):
            if socket.is_linked:
                volume_closures(reader, socket.links[0].from_node, weight * share, out, factors)
    elif kind == "ShaderNodeAddShader":
        for socket in (node.inputs[0], node.inputs[1]):
            if socket.is_linked:
                volume_closures(reader, socket.links[0].from_node, weight, out, factors)
    elif kind == "ShaderNodeGroup" and node.node_tree is not None:
        outputs = [n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput"]
        inner = next((n for n in outputs if getattr(n, "is_active_output", False)), outputs[0] if outputs else None)
        socket = next((s for s in inner.inputs if s.type == "SHADER" and s.is_linked), None) if inner else None
        if socket is not None:
            reader.path += (node,)
            try:
                volume_closures(reader, socket.links[0].from_node, weight, out, factors)
            finally:
                reader.path = reader.path[:-1]
    elif kind in VOLUME_BY_BLENDER:
        name = VOLUME_BY_BLENDER[kind].name
        phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
        inputs = {}
        if phase != "HENYEY_GREENSTEIN":                 # (core/volumes/phase.py; a heterogeneous medium: volume_of)
            inputs["phase"] = phase
            for socket, key in PHASE_SOCKETS.items():
                if socket in node.inputs:
                    value = reader.input(node, socket, None)
                    if _linked(value):                      # (set up point by point: field.py Field.phase_at)
                        inputs[key] = value
                        continue
                    inputs[key] = float(np.mean(value))
        for socket, key in VOLUME_SOCKETS.items():
            if socket in node.inputs:
                inputs[key] = reader.input(node, socket, None)
        if kind == "ShaderNodeVolumePrincipled":       # (the grids a Volume object's medium multiplies in: vdb.py)
            for key in ("density_attribute", "color_attribute", "temperature_attribute"):
                socket = node.inputs.get(key.replace("_", " ").title())     # (string sockets)
                inputs[key] = str(getattr(socket, "default_value", "") or "") if socket is not None else ""
        if factors:
            inputs["factors"] = list(factors)
        out.append((name, float(weight), inputs))
    else:
        reader.warn(node, f"'{node.bl_label}' at a Volume output is not a volume shader Primer renders; it is left out")
    return out


def note_unlike_phases(datablock, kind: str, entries: list, warnings: list) -> None:
    """Warn where a homogeneous medium (no input fed by a link) mixes scattering closures of unlike phase functions:
    Primer scatters such a medium by one (HG of the mean g, or the closure that scatters most: core/volumes/media.py),
    Cycles by each closure's (a heterogeneous medium mixes them as Cycles does: core/volumes/phase.py PhaseMix)."""
    if any(_linked(value) for _, _, inputs in entries for value in inputs.values()) or entries and \
            any(inputs.get("factors") for _, _, inputs in entries):
        return
    phases = {(inputs.get("phase", "HENYEY_GREENSTEIN"),
               tuple(round(float(np.mean(inputs[key])), 6) for key in ("anisotropy", *PHASE_SOCKETS.values())
                     if key in inputs and inputs[key] is not None))
              for name, weight, inputs in entries if name in ("SCATTER", "PRINCIPLED_VOLUME", "COEFFICIENTS")}
    if len(phases) > 1:
        warnings.append(f"{kind} '{datablock.name}': its homogeneous medium mixes unlike phase functions; Primer "
                        "scatters it by one (Henyey-Greenstein of their mean anisotropy, or the closure that scatters "
                        "most), Cycles by each closure's")


def volume_of(datablock, output, warnings: list, kind: str = "material") -> list:
    """The closures of `output`'s Volume socket (a material's or world's): [] where nothing is linked."""
    node = linked_node(output, "Volume") if output is not None and "Volume" in output.inputs else None
    if node is None:
        return []
    entries = volume_closures(NodeReader(datablock, warnings, kind), node)
    note_unlike_phases(datablock, kind, entries, warnings)
    # A heterogeneous medium's graph runs at points inside it: no image, no mesh attribute there.
    nodes = [(name, weight, {k: v for k, v in inputs.items() if k != "factors"}, inputs.get("factors", ()))
             for name, weight, inputs in entries]
    # (Point Info reads 0 inside a medium in Cycles too: no point is hit there.)
    # (An Attribute node's name reads a Volume object's grid; in a mesh's medium it reads 0 as in Cycles, unsaid.)
    # (A material's Object Info: each object that holds it keeps a medium of its own, core/volumes/media.py
    # per_object, as Cycles' volume stack holds (object, shader) pairs; Material Index is the material's constant. A
    # world's medium has no object: its Object Info reads 0 in Cycles too.)
    unread = sorted(({n for n in graph_.attributes_of(nodes) if not n.startswith(("point_", "attr:"))}
                     - {"generated", "object"})
                    | {f"Object Info's {link.output}" for link in graph_.links_under(nodes)
                       if link.node.kind == "OBJECT_INFO" and link.output not in ("Location", "Material Index")
                       and kind != "material"})
    if unread:
        warnings.append(f"{kind} '{datablock.name}': its volume reads {', '.join(unread)}, which points inside a "
                        "medium do not carry in Primer (they read 0)")
    return entries


def export_material(material, warnings: list) -> Material:
    """A Blender material as a core Material: a plain Diffuse BSDF (or no node tree: the viewport colour)
    stays the constant Lambert material; anything else becomes shader nodes."""
    forget_alpha_reads(material)
    sampling = str(getattr(getattr(material, "cycles", None), "emission_sampling", "AUTO"))
    # Settings > Transparent Shadows (Blender 4.2 and later; Cycles reads it too): off, shadow rays stop at it.
    shadows = bool(getattr(material, "use_transparent_shadow", True))
    if node_tree(material) is None:
        return Material(np.array(material.diffuse_color[:3], np.float64), material.name, emission_sampling=sampling,
                        transparent_shadows=shadows)
    output = output_node(node_tree(material), "ShaderNodeOutputMaterial")
    if sampling == "AUTO" and output is not None and auto_emission(output.inputs["Surface"]):
        sampling = "AUTO_CONVERTED"     # Cycles weighs an automatic conversion's emission a tenth in its estimate
    volume = linked_node(output, "Volume") if output is not None and "Volume" in output.inputs else None
    medium = volume_of(material, output, warnings) if volume is not None else []
    warnings.extend(unmodelled.material_notes(material))
    nodes = shader_nodes(material, warnings)
    aovs = aov_outputs(material, warnings)
    if aovs and not nodes:                  # (no surface: black, as Cycles' empty surface, its AOVs still written)
        nodes = [("DIFFUSE", np.zeros(3), {}, [])]
    normal, moved = None, {}
    if output is not None and "Displacement" in output.inputs and linked_node(output, "Displacement") is not None:
        method = str(getattr(material, "displacement_method", getattr(getattr(material, "cycles", None),
                                                                      "displacement_method", "BUMP")))
        offset = NodeReader(material, warnings).input(output, "Displacement", np.zeros(3))
        if method in ("DISPLACEMENT", "BOTH") and (_linked(offset) or np.any(np.asarray(offset, np.float64) != 0.0)):
            # The surface moved at its vertices (core/geometry/displacement.py), as Cycles without subdivision.
            moved = {"displacement": offset, "displacement_method": method}
        if method != "DISPLACEMENT" and nodes and surface_node(material) is not None:
            # (Bump nodes in the surface graph step over the moved surface, as Cycles': only its bump shader,
            # this one, runs over the surface before it moved.)
            normal = displacement_bump(offset, output, undisplaced=bool(moved))
    if volume is not None and surface_node(material) is None:
        # Cycles: a volume's boundary with no surface shader is not there for rays (they enter the volume, and a
        # crossing counts as no transparent bounce).
        return Material(np.zeros(3), material.name, nodes=[("TRANSPARENT", np.ones(3), {}, [])],
                        emission_sampling=sampling, transparent_shadows=True, volume=medium, volume_only=True,
                        aovs=aovs, **moved)
    if len(nodes) == 1 and nodes[0][0] == "DIFFUSE" and not graph_.has_links(nodes) and "roughness" not in nodes[0][2] \
            and normal is None and not aovs:
        return Material(np.clip(nodes[0][1], 0.0, None), material.name, emission_sampling=sampling,
                        transparent_shadows=shadows, volume=medium, **moved)
    if not nodes:
        return Material(np.zeros(3), material.name, emission_sampling=sampling, transparent_shadows=shadows,
                        volume=medium, **moved)
    # Settings > Bump Map Correction (Cycles' default on; off: the nodes' normals kept as they are, closures.py).
    corrected = bool(getattr(getattr(material, "cycles", None), "use_bump_map_correction", True))
    return Material(np.zeros(3), material.name, nodes=nodes, emission_sampling=sampling, transparent_shadows=shadows,
                    volume=medium, normal=normal, bump_map_correction=corrected, aovs=aovs, **moved)
