"""Ray Visibility > Volume Scatter inside real Blender (the bpy module, no mocks), against Cycles' own render: a
Volume Scatter cube over a floor, lit by a point lamp, an emissive panel, a sun and a grey world, with the lamp, the
panel and the world hidden from Volume Scatter rays. In Cycles they then light the floor but not the fog (their light
samples at scattering points are dropped, SHADER_EXCLUDE_SCATTER, and phase rays pass them); Primer read none of it
until this stop (objects: a note that said nothing changes; the world: a note). Then the world hidden from glossy and
transmission rays, seen in a mirror and through a glass pane (Primer noted Transmission and lit every kind of bounce
where Diffuse was on)."""
from __future__ import annotations

import numpy as np
import pytest

from blender_env import run_bpy

pytestmark = [pytest.mark.blender, pytest.mark.slow]

SCRIPT = """
import os, sys
import bpy
from blender_env import empty_material, fresh_scene, render_pixels, report

primer, export, scene = fresh_scene(40, 30)
scene.primer.integrator = "PATH"
scene.primer.max_bounces = 2
scene.primer.use_adaptive_sampling = False


def material(name, kind, color, socket="Surface", **inputs):
    m, tree, output = empty_material(name)
    node = tree.nodes.new(kind)
    node.inputs["Color"].default_value = (*color, 1.0)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], output.inputs[socket])
    return m


bpy.ops.mesh.primitive_plane_add(size=20.0)
bpy.context.object.data.materials.append(material("Floor", "ShaderNodeBsdfDiffuse", (0.8, 0.8, 0.8)))
bpy.ops.mesh.primitive_cube_add(size=2.5, location=(0.0, 0.0, 1.5))
bpy.context.object.data.materials.append(material("Fog", "ShaderNodeVolumeScatter", (0.9, 0.7, 0.5), "Volume",
                                                  Density=0.6))
bpy.ops.mesh.primitive_plane_add(size=1.5, location=(2.4, -0.5, 1.5), rotation=(1.5707963, 0.0, 0.5))
panel = bpy.context.object
panel.data.materials.append(material("Panel", "ShaderNodeEmission", (0.3, 0.6, 1.0), Strength=8.0))
lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
lamp.data.energy, lamp.data.shadow_soft_size = 600.0, 0.2
lamp.location = (-2.5, -1.0, 4.0)
scene.collection.objects.link(lamp)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy = 1.5
sun.rotation_euler = (0.5, 0.3, 0.2)
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("World")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.35, 0.4, 1.0)
scene.world = world
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.location = (0.0, -9.0, 3.0)
camera.rotation_euler = (1.29, 0.0, 0.0)
scene.collection.objects.link(camera)
scene.camera = camera
out = {}
for hidden in (False, True):
    lamp.visible_volume_scatter = panel.visible_volume_scatter = world.cycles_visibility.scatter = not hidden
    name = "hidden" if hidden else "seen"
    # (the image seen by the lights needs only to differ: 32 samples; the hidden one is held to Cycles: 128)
    out[name] = render_pixels(scene, "PRIMER", os.path.abspath(f"{name}.exr"), 128 if hidden else 32)[..., :3].tolist()
    out[name + " warnings"] = list(sys.modules[primer.__name__ + ".addon.engine"].last_render.warnings)
out["cycles"] = render_pixels(scene, "CYCLES", os.path.abspath("cycles.exr"), 1024, reference="hidden")[..., :3].tolist()
# The world hidden from glossy and transmission rays: a tilted mirror and a glass pane over the floor, no fog.
bpy.data.objects.remove(bpy.data.objects["Cube"])
lamp.visible_volume_scatter = panel.visible_volume_scatter = world.cycles_visibility.scatter = True
bpy.ops.mesh.primitive_plane_add(size=2.0, location=(-1.3, 0.5, 1.2), rotation=(1.2, 0.0, 0.4))
bpy.context.object.data.materials.append(material("Mirror", "ShaderNodeBsdfGlossy", (0.9, 0.9, 0.9), Roughness=0.0))
bpy.ops.mesh.primitive_plane_add(size=2.0, location=(1.2, 0.0, 1.2), rotation=(1.3, 0.0, -0.3))
bpy.context.object.data.materials.append(material("Glass", "ShaderNodeBsdfGlass", (1.0, 1.0, 1.0), Roughness=0.0,
                                                  IOR=1.5))
world.cycles_visibility.glossy = world.cycles_visibility.transmission = False
scene.primer.caustics_reflective = scene.primer.caustics_refractive = False   # (no fireflies on the floor)
out["world hidden"] = render_pixels(scene, "PRIMER", os.path.abspath("world.exr"), 128)[..., :3].tolist()
out["world warnings"] = list(sys.modules[primer.__name__ + ".addon.engine"].last_render.warnings)
out["world cycles"] = render_pixels(scene, "CYCLES", os.path.abspath("world_cycles.exr"), 1024,
                                    reference="world hidden")[..., :3].tolist()
world.cycles_visibility.glossy = world.cycles_visibility.transmission = True
out["world seen"] = render_pixels(scene, "PRIMER", os.path.abspath("world_seen.exr"), 32)[..., :3].tolist()
report(images=out)
"""


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    return run_bpy(SCRIPT, str(tmp_path_factory.mktemp("volume_scatter_visibility")), timeout=900)["images"]


def test_what_is_hidden_from_volume_scatter_lights_the_floor_but_not_the_fog_as_in_cycles(images):
    """With the lamp, the panel and the world hidden from Volume Scatter, Primer's image is Cycles' within the noise
    (block relMSE), the same scene seen by Volume Scatter rays is not, and nothing is said about the setting."""
    from core.film.compare import relative_mse_of_blocks
    hidden, seen, cycles = (np.asarray(images[name]) for name in ("hidden", "seen", "cycles"))
    error, other = relative_mse_of_blocks(hidden, cycles), relative_mse_of_blocks(seen, cycles)
    print(f"hidden: {error:.2e}, seen: {other:.2e}, means {hidden.mean():.4f} {seen.mean():.4f} {cycles.mean():.4f}")
    assert not [w for w in images["hidden warnings"] + images["seen warnings"] if "Volume Scatter" in w]
    assert error < 5e-4 and other > 20 * error, (error, other)


def test_a_world_hidden_from_glossy_and_transmission_rays_is_dark_in_a_mirror_and_through_glass_as_in_cycles(images):
    """The world hidden from glossy and transmission rays: Primer's image is Cycles' within the noise, the world seen
    by them is not, and nothing is said about the world's visibility."""
    from core.film.compare import relative_mse_of_blocks
    hidden, seen, cycles = (np.asarray(images[name]) for name in ("world hidden", "world seen", "world cycles"))
    error, other = relative_mse_of_blocks(hidden, cycles), relative_mse_of_blocks(seen, cycles)
    print(f"world hidden: {error:.2e}, seen: {other:.2e}, means {hidden.mean():.4f} {seen.mean():.4f} "
          f"{cycles.mean():.4f}")
    assert not [w for w in images["world warnings"] if "world" in w and "rays" in w]
    assert error < 5e-4 and other > 20 * error, (error, other)
