"""Blender materials as Primer reads them: the node tree at the Material Output, as a list of shader nodes.

From the Surface socket down, Mix Shader and Add Shader nodes are multiplied out into one weight per
BSDF node (Principled, Diffuse, Glossy, Emission, Transparent), with each node's constant inputs
(core/materials/nodes.py sets them up per hit, as Cycles does). A plain Diffuse BSDF stays the lecture's
constant Lambert material. Whatever Primer cannot read yet (a texture or another node linked into an
input, a shader node it does not know, sheen, transmission) gets a warning that names the material and
the node and says what Primer used instead.
"""
from __future__ import annotations

import bpy
import numpy as np

from ..core.materials import Material

# Principled BSDF sockets -> core/materials/nodes.py PRINCIPLED_INPUTS.
PRINCIPLED_SOCKETS = {"Base Color": "base_color", "Metallic": "metallic", "Roughness": "roughness", "IOR": "ior",
                      "Alpha": "alpha", "Subsurface Weight": "subsurface", "Specular IOR Level": "specular_ior_level",
                      "Specular Tint": "specular_tint", "Coat Weight": "coat", "Coat Roughness": "coat_roughness",
                      "Coat IOR": "coat_ior", "Coat Tint": "coat_tint", "Transmission Weight": "transmission"}
# Principled inputs Primer leaves out: socket -> what Primer does instead (warned when above 0).
PRINCIPLED_LEFT_OUT = {"Sheen Weight": "leaves the sheen out", "Anisotropic": "renders it isotropic",
                       "Transmission Weight": "does not render the transmitted light yet (its share is dark)",
                       "Subsurface Weight": "approximates subsurface scattering by diffuse reflection",
                       "Diffuse Roughness": "uses Lambert's diffuse (roughness 0)",
                       "Thin Film Thickness": "leaves the thin film out"}
GLOSSY_IDS = {"ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic"}


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
    if output is None or not output.inputs[socket].is_linked:
        return None
    return _follow(output.inputs[socket].links[0].from_node)


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


class NodeReader:
    """Reads one material's (or light's) inputs, noting each input that a link feeds (Primer takes its own value)."""

    def __init__(self, material, warnings: list, kind: str = "material"):
        self.material, self.warnings, self.kind = material, warnings, kind

    def warn(self, node, text: str) -> None:
        """A warning naming the material (or light) and node."""
        note = f"{self.kind} '{self.material.name}', node '{node.name}': {text}"
        if note not in self.warnings:
            self.warnings.append(note)

    def value(self, node, name: str, default):
        """An input's own value (float or RGB), `default` where the node has no such input."""
        socket = node.inputs.get(name)
        if socket is None:
            return default
        if socket.is_linked:
            self.warn(node, f"input '{name}' is linked to '{socket.links[0].from_node.name}', which Primer does "
                            "not evaluate yet; it uses the input's own value")
        value = socket.default_value
        try:
            return np.array(value[:3], np.float64)
        except TypeError:
            return float(value)


def shader_nodes(material, warnings: list) -> list:
    """The material's surface as [(node name in core/materials/nodes.py, weight (3,), inputs dict)]."""
    reader = NodeReader(material, warnings)
    out: list = []
    _collect(reader, surface_node(material), np.ones(3), out)
    return out


def _collect(reader: NodeReader, node, weight: np.ndarray, out: list) -> None:
    """Append the shader nodes under `node`, their weights multiplied by `weight`."""
    node = _follow(node)
    if node is None or not weight.any():
        return
    kind = node.bl_idname
    if kind == "ShaderNodeMixShader":
        fac = float(np.clip(np.mean(reader.value(node, "Fac", 0.5)), 0.0, 1.0))
        for socket, share in ((node.inputs[1], 1.0 - fac), (node.inputs[2], fac)):
            if socket.is_linked:
                _collect(reader, socket.links[0].from_node, weight * share, out)
    elif kind == "ShaderNodeAddShader":
        for socket in (node.inputs[0], node.inputs[1]):
            if socket.is_linked:
                _collect(reader, socket.links[0].from_node, weight, out)
    elif kind == "ShaderNodeBsdfPrincipled":
        inputs = {key: reader.value(node, socket, None) for socket, key in PRINCIPLED_SOCKETS.items()}
        inputs = {key: value for key, value in inputs.items() if value is not None}
        color = reader.value(node, "Emission Color", np.ones(3))
        inputs["emission"] = np.asarray(color, np.float64) * float(reader.value(node, "Emission Strength", 0.0))
        inputs["multiscatter"] = 1.0 if getattr(node, "distribution", "MULTI_GGX") == "MULTI_GGX" else 0.0
        for socket, instead in PRINCIPLED_LEFT_OUT.items():
            if node.inputs.get(socket) is not None and float(np.max(reader.value(node, socket, 0.0))) > 0.0:
                reader.warn(node, f"'{socket}' is above 0; Primer {instead}")
        out.append(("PRINCIPLED", weight, inputs))
    elif kind == "ShaderNodeBsdfDiffuse":
        if float(reader.value(node, "Roughness", 0.0)) > 0.0:
            reader.warn(node, "Roughness is above 0 (Oren-Nayar in Cycles); Primer uses Lambert's diffuse")
        out.append(("DIFFUSE", weight * np.maximum(reader.value(node, "Color", np.full(3, 0.8)), 0.0), {}))
    elif kind in GLOSSY_IDS:
        distribution = getattr(node, "distribution", "GGX")
        if distribution not in {"GGX", "MULTI_GGX"}:
            reader.warn(node, f"distribution {distribution} is not GGX; Primer uses GGX")
        if abs(float(reader.value(node, "Anisotropy", 0.0))) > 1e-4:
            reader.warn(node, "Anisotropy is not 0; Primer renders it isotropic")
        color = np.maximum(reader.value(node, "Color", np.full(3, 0.8)), 0.0)
        out.append(("GLOSSY", weight * color, {"roughness": float(reader.value(node, "Roughness", 0.5)),
                                               "multiscatter": 1.0 if distribution == "MULTI_GGX" else 0.0,
                                               "color": color}))
    elif kind == "ShaderNodeEmission":
        color = np.asarray(reader.value(node, "Color", np.ones(3)), np.float64)
        out.append(("EMISSION", weight, {"emission": color * float(reader.value(node, "Strength", 1.0))}))
    elif kind == "ShaderNodeBsdfTransparent":
        out.append(("TRANSPARENT", weight * np.maximum(reader.value(node, "Color", np.ones(3)), 0.0), {}))
    elif kind == "ShaderNodeHoldout":
        reader.warn(node, "Holdout is not supported yet; Primer leaves this part black")
    else:
        color = node.inputs.get("Color") or node.inputs.get("Base Color")
        reader.warn(node, f"'{node.bl_label}' is not a shader node Primer knows; "
                          + ("it uses a diffuse surface of the node's colour" if color is not None else "it leaves it black"))
        if color is not None:
            out.append(("DIFFUSE", weight * np.maximum(np.array(color.default_value[:3], np.float64), 0.0), {}))


def export_material(material, warnings: list) -> Material:
    """A Blender material as a core Material: a plain Diffuse BSDF (or no node tree: the viewport colour)
    stays the constant Lambert material; anything else becomes shader nodes."""
    sampling = str(getattr(getattr(material, "cycles", None), "emission_sampling", "AUTO"))
    if node_tree(material) is None:
        return Material(np.array(material.diffuse_color[:3], np.float64), material.name, emission_sampling=sampling)
    nodes = shader_nodes(material, warnings)
    if len(nodes) == 1 and nodes[0][0] == "DIFFUSE":
        return Material(np.clip(nodes[0][1], 0.0, None), material.name, emission_sampling=sampling)
    if not nodes:
        return Material(np.zeros(3), material.name, emission_sampling=sampling)
    return Material(np.zeros(3), material.name, nodes=nodes, emission_sampling=sampling)
