"""A world's Sky Texture sun disc as rays that meet it see it (core/lights/sun.py SunLight.limb, from
core/lights/world_graph.py sky_suns): the camera, a mirror and a glossy reflection see Cycles' limb-darkened disc,
its colour going from its bottom to its top, where its light samples keep the lamp of its mean radiance; against
Cycles 5.x (Single Scattering, a 4 degree disc 4 degrees up, a horizontal mirror below the camera)."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from render import load_primer  # noqa: E402

from test_blender_cycles_settings import add_camera, new_cycles_file, render  # noqa: E402
from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def sun_and_mirror(roughness: float):
    """A Single Scattering sky (Strength 0.5) whose sun, 4 degrees up, has a 4 degree disc; a camera at height 1 looks
    level at it (a 16 degree view, 48 x 48 pixels), over a horizontal Glossy plane of `roughness` (0: a mirror) that
    shows the disc below the horizon; one bounce, 64 samples."""
    scene = new_cycles_file(48, 48)
    world = bpy.data.worlds.new("Sky")
    scene.world = world
    world.use_nodes = True
    tree = world.node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "SINGLE_SCATTERING"
    sky.sun_elevation, sky.sun_rotation, sky.sun_size = math.radians(4.0), 0.0, math.radians(4.0)
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    tree.nodes["Background"].inputs["Strength"].default_value = 0.5
    bpy.ops.mesh.primitive_plane_add(size=400.0, location=(0.0, 0.0, 0.0))
    plane = bpy.context.view_layer.objects.active
    material = bpy.data.materials.new("Mirror")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    glossy = nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Roughness"].default_value = roughness
    glossy.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    material.node_tree.links.new(glossy.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
    plane.data.materials.append(material)
    sensor = 36.0
    add_camera(scene, (0.0, 0.0, 1.0), (math.radians(90.0), 0.0, 0.0), lens=0.5 * sensor / math.tan(math.radians(8.0)))
    scene.camera.data.sensor_fit, scene.camera.data.sensor_width = "HORIZONTAL", sensor
    scene.cycles.max_bounces = scene.cycles.glossy_bounces = 1
    scene.cycles.samples = 64
    scene.primer.settings_source = "CYCLES"
    return scene


@pytest.mark.parametrize("roughness, bound", [(0.0, 2e-3), (0.05, 1e-2)])
def test_the_camera_and_a_reflection_see_cycles_limb_darkened_disc(primer, tmp_path, roughness, bound):
    """Primer's image of the sky's disc and its reflection is Cycles' (block relMSE below `bound`: a mirror 3.6e-4,
    a glossy reflection of roughness 0.05 3.8e-3, where Cycles' own images of two seeds differ by 2.0e-3 there; the
    uniform disc of the lamp's mean radiance gave 0.24 and 0.18), nothing noted about the world."""
    scene = sun_and_mirror(roughness)
    export = sys.modules[primer.__name__ + ".addon.export"]
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in exported.warnings if "world" in w or "Sky" in w], exported.warnings
    mine = render(scene, "PRIMER", str(tmp_path / "primer.exr"))
    cycles = render(scene, "CYCLES", str(tmp_path / "cycles.exr"))
    error = relative_mse_of_blocks(mine, cycles)
    upper, lower = relative_mse_of_blocks(mine[:24], cycles[:24]), relative_mse_of_blocks(mine[24:], cycles[24:])
    print(f"roughness {roughness}: block relMSE {error:.2e} (rows 0-23 {upper:.2e}, 24-47 {lower:.2e}), "
          f"mean ratio {mine.mean() / cycles.mean():.4f}")
    assert error < bound, error
