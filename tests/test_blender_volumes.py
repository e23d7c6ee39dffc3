"""Homogeneous media read from Blender and rendered as Cycles renders them (issue 35's first slice): an absorbing
cube in front of an emitter, a scattering cube under a lamp, a world's fog under a sun, each against Cycles' image;
and the volume closures read from the node tree with what Primer does not model said."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

from blender_env import empty_material, render_pixels  # noqa: E402

pytestmark = [pytest.mark.blender]


@pytest.fixture(scope="module")
def primer():
    return load_primer()


def volume_material(name: str, kind: str, surface: str = None, **inputs):
    """A material whose Volume output is a `kind` node with `inputs` (socket name with spaces as underscores ->
    value) and whose Surface is a `surface` node, or nothing."""
    m, tree, output = empty_material(name)
    node = tree.nodes.new(kind)
    for key, value in inputs.items():
        socket = node.inputs[key.replace("_", " ")]
        socket.default_value = (*value, 1.0) if isinstance(value, tuple) and len(value) == 3 else value
    tree.links.new(node.outputs[0], output.inputs["Volume"])
    if surface is not None:
        tree.links.new(tree.nodes.new(surface).outputs[0], output.inputs["Surface"])
    return m, node


def emitting_material(name: str, color, strength: float = 1.0):
    """A material that only emits color x strength."""
    m, tree, output = empty_material(name)
    node = tree.nodes.new("ShaderNodeEmission")
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Strength"].default_value = strength
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    return m


def box(name: str, location, size, material):
    """A cube object of edge lengths `size` at `location` with `material`."""
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
    obj = bpy.context.object
    obj.name = name
    obj.scale = size
    obj.data.materials.append(material)
    return obj


def ortho_scene(width: int, height: int, scale: float):
    """An empty scene with a black world and an orthographic camera 6 above the origin looking down."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.0, 0.0, 0.0)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", scale
    camera.location = (0.0, 0.0, 6.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


def test_absorbing_cubes_in_front_of_an_emitter_let_through_exp_of_minus_sigma_d_as_in_cycles(primer, tmp_path):
    """An emitting plane seen from above through two absorbing cubes 0.8 thick: one whose material has only a Volume
    (its surface is no surface), one with a Transparent surface of 0.9 around the same medium. Each pixel behind
    them is the plane's emission x exp(-density (1 - colour) 0.8) (x 0.9^2 through the two transparent faces), per
    channel, in Primer and in Cycles (both to float32 rounding: no noise without scattering)."""
    scene = ortho_scene(16, 8, 4.0)
    glow = np.array([1.0, 0.8, 0.5])
    bpy.ops.mesh.primitive_plane_add(size=12.0, location=(0.0, 0.0, 0.0))
    bpy.context.object.data.materials.append(emitting_material("Glow", glow))
    color, density, depth = (0.3, 0.6, 0.9), 1.2, 0.8
    fog, _ = volume_material("Fog", "ShaderNodeVolumeAbsorption", Color=color, Density=density)
    glass, _ = volume_material("Clear", "ShaderNodeVolumeAbsorption", "ShaderNodeBsdfTransparent", Color=color,
                               Density=density)
    glass.node_tree.nodes["Transparent BSDF"].inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    box("Fog", (-1.0, 0.0, 1.5), (1.0, 1.0, depth), fog)           # (edges on pixel edges: every pixel one value)
    box("Clear", (1.0, 0.0, 1.5), (1.0, 1.0, depth), glass)
    mine = render_pixels(scene, "PRIMER", str(tmp_path / "primer.exr"), 4)[..., :3]
    cycles = render_pixels(scene, "CYCLES", str(tmp_path / "cycles.exr"), 16)[..., :3]
    through = glow * np.exp(-density * (1.0 - np.array(color)) * depth)
    # (rows bottom first; pixel (row, column) centres: x = -2 + (c + 0.5) / 4, y = -1 + (r + 0.5) / 4)
    expected = np.broadcast_to(glow, mine.shape).copy()
    expected[2:6, 2:6] = through
    expected[2:6, 10:14] = through * 0.81
    np.testing.assert_allclose(mine, expected, rtol=1e-5)
    np.testing.assert_allclose(cycles, expected, rtol=1e-5)
