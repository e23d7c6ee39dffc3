"""The Ambient Occlusion and Bevel nodes read from Blender and rendered as Cycles renders them: a dirt mask (a cube on
a floor emitting their ambient occlusion) and a bevelled cube's edges under a sun, each against Cycles' image, block
relMSE within Cycles' own noise at the same samples; without the nodes' rays the images are far from Cycles'."""
from __future__ import annotations

import importlib
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

from blender_env import empty_material, render_pixels  # noqa: E402
from test_blender_volumes import ortho_scene  # noqa: E402

pytestmark = [pytest.mark.blender]


@pytest.fixture(scope="module")
def primer():
    return load_primer()


def compared(scene, tmp_path, compare, label: str, samples: int = 64) -> tuple:
    """Primer and Cycles at `samples` against Cycles at 4 x `samples`: (Primer's block relMSE, Cycles' own, Primer's
    mean over Cycles' 4 x mean, Cycles' 4 x image)."""
    p = render_pixels(scene, "PRIMER", str(tmp_path / "primer.exr"), samples)[..., :3]
    c_high = render_pixels(scene, "CYCLES", str(tmp_path / "cycles_high.exr"), 4 * samples, True)[..., :3]
    c = render_pixels(scene, "CYCLES", str(tmp_path / "cycles.exr"), samples, True)[..., :3]
    error, own = compare.relative_mse_of_blocks(p, c_high), compare.relative_mse_of_blocks(c, c_high)
    print(f"{label}: Primer {samples} vs Cycles {4 * samples} {error:.3g}; Cycles {samples} vs {4 * samples} "
          f"{own:.3g}; means {p.mean():.5f} {c_high.mean():.5f}")
    return error, own, p.mean() / c_high.mean(), c_high


def test_an_ambient_occlusion_dirt_mask_renders_as_in_cycles(primer, tmp_path, caplog):
    """A cube on a floor emitting their Ambient Occlusion (8 samples, Distance 1; the floor its AO, the cube its
    Color output of an orange Color): dark in the corner where they meet, as in Cycles (block relMSE within 3 x Cycles'
    own noise at 64 samples, mean within 1%); the node's Only Local (the floor no longer sees the cube) is far from
    it."""
    scene = ortho_scene(32, 24, 4.0)
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False           # (every pixel its samples, as Cycles here)
    nodes = []
    for name, socket in (("Dirt", "AO"), ("Tinted dirt", "Color")):
        material, tree, output = empty_material(name)
        ao = tree.nodes.new("ShaderNodeAmbientOcclusion")
        ao.samples = 8
        ao.inputs["Distance"].default_value = 1.0
        ao.inputs["Color"].default_value = (1.0, 0.6, 0.2, 1.0)
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(ao.outputs[socket], emission.inputs["Color"])
        tree.links.new(emission.outputs[0], output.inputs["Surface"])
        bpy.ops.mesh.primitive_plane_add(size=8.0) if socket == "AO" else bpy.ops.mesh.primitive_cube_add(
            size=1.2, location=(-0.4, 0.2, 0.6), rotation=(0.0, 0.0, 0.5))
        bpy.context.object.data.materials.append(material)
        nodes.append(ao)
    ao = nodes[0]
    compare = importlib.import_module(primer.__name__ + ".core.film.compare")
    error, own, ratio, cycles = compared(scene, tmp_path, compare, "ambient occlusion")
    assert not [r.message for r in caplog.records if "Ambient Occlusion" in r.message]      # (read, not reported)
    assert error < 3.0 * own
    assert abs(ratio - 1.0) < 0.01
    ao.only_local = True
    local = render_pixels(scene, "PRIMER", str(tmp_path / "local.exr"), 16)[..., :3]
    wrong = compare.relative_mse_of_blocks(local, cycles)
    print(f"Only Local against the plain node's Cycles image: {wrong:.3g}")
    assert wrong > 20.0 * own


def test_a_bevelled_cube_under_a_sun_renders_as_in_cycles(primer, tmp_path, caplog):
    """A turned cube whose Diffuse BSDF reads its Normal from a Bevel node (radius 0.15, 8 samples), lit by a sun:
    its rounded edges shade as in Cycles (block relMSE within 3 x Cycles' own noise at 64 samples, mean within 1%);
    the sharp cube is far from it."""
    scene = ortho_scene(32, 32, 2.6)
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False           # (every pixel its samples, as Cycles here)
    material, tree, output = empty_material("Bevelled")
    bevel = tree.nodes.new("ShaderNodeBevel")
    bevel.samples = 8
    bevel.inputs["Radius"].default_value = 0.15
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    tree.links.new(bevel.outputs["Normal"], diffuse.inputs["Normal"])
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    bpy.ops.mesh.primitive_cube_add(size=1.4, rotation=(0.6, 0.4, 0.3))
    bpy.context.object.data.materials.append(material)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = (0.5, -0.4, 0.2)
    scene.collection.objects.link(sun)
    compare = importlib.import_module(primer.__name__ + ".core.film.compare")
    error, own, ratio, cycles = compared(scene, tmp_path, compare, "bevel")
    assert not [r.message for r in caplog.records if "Bevel" in r.message]
    assert error < 3.0 * own
    assert abs(ratio - 1.0) < 0.01
    tree.links.remove(diffuse.inputs["Normal"].links[0])
    sharp = render_pixels(scene, "PRIMER", str(tmp_path / "sharp.exr"), 16)[..., :3]
    wrong = compare.relative_mse_of_blocks(sharp, cycles)
    print(f"the sharp cube against the bevelled one's Cycles image: {wrong:.3g}")
    assert wrong > 5.0 * own
