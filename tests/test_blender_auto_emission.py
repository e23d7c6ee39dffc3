"""A colour, vector or value linked into a shader socket, which Cycles turns into an Emission shader (ShaderGraph::connect's
automatic conversion: a colour its Color at Strength 1, a value its Strength of white), and a shader handed into a node
group through the group's input, against Cycles' own render pixel for pixel: emitting planes seen from above by an
orthographic camera, exported by addon/materials.py with real Blender. Found by Bricabrac's 'dynamic Color Ramp' file
(tools/real_scenes.py: its Surface is a group's Color output; Primer rendered it black, 26% dark) and the Crack It
materials (shaders passed into groups; Primer left them black). A Background node at a Surface emits as an Emission does.
"""
from __future__ import annotations

import numpy as np
import pytest

from blender_env import require_bpy, run_bpy

pytestmark = pytest.mark.blender

require_bpy(__file__)

PIXELS = 8                # pixels across each plane
COLUMNS = 6

SCRIPT = """
import bpy
import numpy as np
from blender_env import report, empty_material, fresh_scene, grid_plane, snapped_generated, render_plane_grid
primer, export, scene = fresh_scene()
PIXELS, COLUMNS = {pixels}, {columns}
cases = []


def checker(tree):
    # A Checker Texture of the pixel-snapped Generated coordinate: one colour per pixel whatever the sample.
    v, _, _ = snapped_generated(tree, PIXELS)
    node = tree.nodes.new("ShaderNodeTexChecker")
    node.inputs["Color1"].default_value = (0.9, 0.3, 0.1, 1.0)
    node.inputs["Color2"].default_value = (0.1, 0.4, 0.7, 1.0)
    tree.links.new(v, node.inputs["Vector"])
    return node


material, tree, out = empty_material("Colour into Surface")
tree.links.new(checker(tree).outputs["Color"], out.inputs["Surface"])
grid_plane(cases, "Colour into Surface", material, COLUMNS)

material, tree, out = empty_material("Value into Surface")
tree.links.new(checker(tree).outputs["Fac"], out.inputs["Surface"])
grid_plane(cases, "Value into Surface", material, COLUMNS)

# A group whose output is a colour (Bricabrac's case), into one slot of a Mix Shader through a reroute.
group = bpy.data.node_groups.new("Colour Group", "ShaderNodeTree")
group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
inner_out = group.nodes.new("NodeGroupOutput")
tree_node = checker(group)
tree_node.inputs["Scale"].default_value = 3.0
group.links.new(tree_node.outputs["Color"], inner_out.inputs[0])
material, tree, out = empty_material("Group colour in a Mix Shader")
node = tree.nodes.new("ShaderNodeGroup")
node.node_tree = group
reroute = tree.nodes.new("NodeReroute")
tree.links.new(node.outputs[0], reroute.inputs[0])
mix = tree.nodes.new("ShaderNodeMixShader")
mix.inputs["Fac"].default_value = 0.3
emission = tree.nodes.new("ShaderNodeEmission")
emission.inputs["Color"].default_value = (0.2, 0.9, 0.4, 1.0)
tree.links.new(reroute.outputs[0], mix.inputs[1])
tree.links.new(emission.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], out.inputs["Surface"])
grid_plane(cases, "Group colour in a Mix Shader", material, COLUMNS)

# A group that mixes the shader handed in through its input with one of its own (Crack It's case), twice nested.
inner = bpy.data.node_groups.new("Shader Through", "ShaderNodeTree")
inner.interface.new_socket("Shader", in_out="INPUT", socket_type="NodeSocketShader")
inner.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
group_in, group_out = inner.nodes.new("NodeGroupInput"), inner.nodes.new("NodeGroupOutput")
mix = inner.nodes.new("ShaderNodeMixShader")
mix.inputs["Fac"].default_value = 0.25
own = inner.nodes.new("ShaderNodeEmission")
own.inputs["Color"].default_value = (0.1, 0.2, 0.9, 1.0)
inner.links.new(group_in.outputs[0], mix.inputs[1])
inner.links.new(own.outputs[0], mix.inputs[2])
inner.links.new(mix.outputs[0], group_out.inputs[0])
outer = bpy.data.node_groups.new("Shader Through Twice", "ShaderNodeTree")
outer.interface.new_socket("Shader", in_out="INPUT", socket_type="NodeSocketShader")
outer.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
group_in, group_out = outer.nodes.new("NodeGroupInput"), outer.nodes.new("NodeGroupOutput")
nested = outer.nodes.new("ShaderNodeGroup")
nested.node_tree = inner
outer.links.new(group_in.outputs[0], nested.inputs[0])
outer.links.new(nested.outputs[0], group_out.inputs[0])
material, tree, out = empty_material("Shader into a group")
node = tree.nodes.new("ShaderNodeGroup")
node.node_tree = outer
emission = tree.nodes.new("ShaderNodeEmission")
tree.links.new(checker(tree).outputs["Color"], emission.inputs["Color"])
tree.links.new(emission.outputs[0], node.inputs[0])
tree.links.new(node.outputs[0], out.inputs["Surface"])
grid_plane(cases, "Shader into a group", material, COLUMNS)

# A colour into a group's shader output socket (inside the group): an emission too.
group = bpy.data.node_groups.new("Colour To Shader Socket", "ShaderNodeTree")
group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
inner_out = group.nodes.new("NodeGroupOutput")
group.links.new(checker(group).outputs["Color"], inner_out.inputs[0])
material, tree, out = empty_material("Colour into a group's shader output")
node = tree.nodes.new("ShaderNodeGroup")
node.node_tree = group
tree.links.new(node.outputs[0], out.inputs["Surface"])
grid_plane(cases, "Colour into a group's shader output", material, COLUMNS)

# A Background node at a Surface: Cycles' surface takes it as an Emission (background_setup adds to the same emission).
material, tree, out = empty_material("Background at a Surface")
background = tree.nodes.new("ShaderNodeBackground")
background.inputs["Strength"].default_value = 1.7
tree.links.new(checker(tree).outputs["Color"], background.inputs["Color"])
tree.links.new(background.outputs[0], out.inputs["Surface"])
grid_plane(cases, "Background at a Surface", material, COLUMNS)

world = bpy.data.worlds.new("Black")
scene.world = world
if bpy.app.version < (5, 0, 0):
    world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
warnings = render_plane_grid(scene, export, COLUMNS, 1, PIXELS)
report(cases=cases, warnings=warnings)
"""


def test_a_colour_or_value_linked_into_a_shader_socket_or_a_background_at_a_surface_emits_it(tmp_path):
    """Every plane is Cycles' pixel for pixel (emission only, constant per pixel: float32 rounding apart), none is
    black, and the export warns of nothing."""
    result = run_bpy(SCRIPT.format(pixels=PIXELS, columns=COLUMNS), str(tmp_path))
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    assert result["warnings"] == []
    for k, label in enumerate(result["cases"]):
        ours, theirs = primer[:, k * PIXELS:(k + 1) * PIXELS], cycles[:, k * PIXELS:(k + 1) * PIXELS]
        assert theirs.mean() > 0.05, label
        assert np.abs(ours - theirs).max() < 1e-5, (label, float(np.abs(ours - theirs).max()))


def test_cycles_samples_an_automatic_emission_as_a_light_only_above_five():
    """Cycles weighs the estimate of an Emission it made of a colour a tenth (Shader::estimate_emission): Auto samples it
    as a light where some channel exceeds 5, where a real Emission shader's limit is 0.5."""
    from core.materials import emission_sides
    assert emission_sides("AUTO", np.array([0.6, 0.0, 0.0])) == 3
    assert emission_sides("AUTO_CONVERTED", np.array([0.6, 0.0, 0.0])) == 0
    assert emission_sides("AUTO_CONVERTED", np.array([0.0, 5.5, 0.0])) == 3
