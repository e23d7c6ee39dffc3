"""Film > Transparent through clear surfaces inside real Blender (the bpy module), against Cycles' own render: a
plane of a Transparent BSDF (and of Mix(Fac 0.3, Transparent, Diffuse)) filling the view before a world the camera
sees. Where the camera's ray goes on through it and escapes, the film is clear by what the plane lets through
(alpha 1 - mean(transparency)) and shows no world. No mocks."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from render import configure_cycles_reference, load_primer  # noqa: E402

from blender_env import empty_material  # noqa: E402
from test_blender_denoise import addon, plane_scene, render_image  # noqa: E402

from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = pytest.mark.blender

CLEAR = (0.3, 0.6, 0.9)                 # the Transparent BSDF's colour
ALBEDO = (0.8, 0.5, 0.2)                # the Diffuse BSDF's, in the mix
PRIMER_SAMPLES, CYCLES_SAMPLES = 16, 64


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def pane_scene(mix: bool):
    """plane_scene (24 x 18) with a Transparent BSDF of CLEAR (mix: Mix(Fac 0.3, Transparent, Diffuse of ALBEDO))
    under its sun, a grey-blue world seen by the camera, a transparent film, Primer's path tracer."""
    scene = plane_scene(24, 18)
    material, tree, output = empty_material("Pane")
    clear = tree.nodes.new("ShaderNodeBsdfTransparent")
    clear.inputs["Color"].default_value = (*CLEAR, 1.0)
    shader = clear.outputs[0]
    if mix:
        node, diffuse = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*ALBEDO, 1.0)
        node.inputs["Fac"].default_value = 0.3
        tree.links.new(clear.outputs[0], node.inputs[1])
        tree.links.new(diffuse.outputs[0], node.inputs[2])
        shader = node.outputs[0]
    tree.links.new(shader, output.inputs["Surface"])
    plane = scene.objects["Plane"].data
    plane.materials.clear()
    plane.materials.append(material)
    world = bpy.data.worlds.new("World")
    world.color = (0.1, 0.2, 0.3)
    if world.node_tree is None:
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    scene.world = world
    scene.render.film_transparent = True
    scene.primer.integrator = "PATH"
    scene.primer.use_adaptive_sampling = False
    return scene


def render_both(mix: bool, folder) -> dict:
    """engine -> (H, W, 4) RGBA of pane_scene(mix)."""
    out = {}
    for engine, samples in (("PRIMER", PRIMER_SAMPLES), ("CYCLES", CYCLES_SAMPLES)):
        scene = pane_scene(mix)
        scene.primer.samples = samples
        if engine == "CYCLES":
            configure_cycles_reference(scene, samples)
        out[engine] = np.asarray(render_image(scene, str(folder / f"pane_{mix}_{engine}.exr")), np.float64)
    return out


@pytest.mark.parametrize("mix", [False, True], ids=["transparent", "mix_transparent_diffuse"])
def test_a_clear_pane_before_the_world_leaves_the_film_as_clear_as_it_lets_light_through(primer, mix, tmp_path):
    """Alpha 1 - mean(weight of the Transparent BSDF): 0.4 for the pane, 1 - 0.7 x 0.6 = 0.58 for the mix, as in
    Cycles; the colour: none of the world (the pane: black), and the Diffuse's share lit by the sun and world."""
    images = render_both(mix, tmp_path)
    mine, cycles = images["PRIMER"], images["CYCLES"]
    expected = 1.0 - (0.7 if mix else 1.0) * np.mean(CLEAR)
    print("alpha", mine[..., 3].mean(), cycles[..., 3].mean(), "expected", expected)
    assert cycles[..., 3].mean() == pytest.approx(expected, abs=0.01)
    assert mine[..., 3].mean() == pytest.approx(expected, abs=0.01)
    alpha_error = relative_mse_of_blocks(np.repeat(mine[..., 3:], 3, axis=-1), np.repeat(cycles[..., 3:], 3, axis=-1))
    print("alpha block relMSE", alpha_error)
    assert alpha_error < 2e-3
    if mix:
        error = relative_mse_of_blocks(mine[..., :3], cycles[..., :3])
        print("colour block relMSE", error, mine[..., :3].mean(axis=(0, 1)), cycles[..., :3].mean(axis=(0, 1)))
        assert error < 2e-3
    else:
        np.testing.assert_allclose(mine[..., :3], 0.0, atol=1e-6)
        np.testing.assert_allclose(cycles[..., :3], 0.0, atol=1e-6)
    assert not any("Film > Transparent" in w for w in addon(primer, "engine").last_render.warnings)
