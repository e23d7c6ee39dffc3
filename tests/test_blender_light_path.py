"""The Light Path node against Cycles' own renders: the tricks artists use, read from Blender by addon/materials.py and
rendered path traced by Primer and by Cycles (tiny images, one Blender process).

- An emitting wall seen in a mirror, its colour (Ray Depth, Is Glossy Ray, Glossy Depth) and (Is Singular Ray,
  Is Reflection Ray, Is Camera Ray): the mirror's reflected ray, one bounce deep. One value per pixel, so Cycles' pixels
  are the closed form and Primer's must match them to float32 rounding.
- An emitting floor under three clear Transparent planes, its colour (Transparent Depth / 4, Is Camera Ray, Ray Depth):
  still a camera ray, three transparent bounces. Exact as well.
- A pane that lets through 0.5 x Ray Depth of a sun's light (and all of the camera's, Is Camera Ray): the floor under it
  is lit through a shadow ray one bounce deeper than the floor (depth 1); two panes letting Ray Length / 4 through, the
  shadow ray's length measured from the floor at both; two clear panes under Transparent Max Bounces 3 and 4, the
  shadow rays passing only what the camera path left of the limit. Exact: a sun without extent.
- Lamps that Light Path shows otherwise to light samples and BSDF rays, over a floor: one shining 1 to light samples and
  5 to diffuse rays (strength 1 + 4 x Is Diffuse Ray) over a diffuse floor, the same shining 1 to all, and one hidden
  from glossy rays (a Mix Shader of Emission and Transparent by Is Glossy Ray) over a rough Glossy floor. Cycles shades
  a light sample's emitter with PATH_RAY_EMISSION alone (neither diffuse nor glossy), a BSDF ray's with that ray's flags,
  and weighs the two by MIS: so Primer takes one light sample per vertex here, as Cycles does, for the same weights.
  The floor's mean and block means against the mean of Cycles' renders at two seeds.
"""
from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

from blender_env import run_bpy

pytestmark = pytest.mark.blender

if importlib.util.find_spec("bpy") is None:
    if os.environ.get("PRIMER_ALLOW_NO_BPY"):
        pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
    raise ImportError("tests/test_blender_light_path.py needs bpy (Blender as a Python module): pip install bpy")

SCRIPT = """
import math, os
import bpy
import numpy as np
from blender_env import report, render_pixels, empty_material, primer_in_blender
primer, export = primer_in_blender()
folder = {folder!r}
warnings = []


def fresh(ortho_scale, height=6.0):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 16
    scene.render.resolution_percentage = 100
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = ortho_scale
    camera.location = (0.0, 0.0, height)
    scene.collection.objects.link(camera)
    scene.camera = camera
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.bl_idname == "ShaderNodeBackground":
                node.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    scene.primer.integrator = "PATH"
    scene.primer.max_bounces = 4
    return scene


def plane(scene, name, size, location, rotation, material):
    mesh = bpy.data.meshes.new(name)
    h = size / 2.0
    mesh.from_pydata([(-h, -h, 0.0), (h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    obj.rotation_euler = rotation
    scene.collection.objects.link(obj)


def light_path_colour(name, outputs, strength=1.0):
    material, tree, out = empty_material(name)
    path = tree.nodes.new("ShaderNodeLightPath")
    combine = tree.nodes.new("ShaderNodeCombineColor")
    for channel, (output, scale) in zip(("Red", "Green", "Blue"), outputs):
        node = tree.nodes.new("ShaderNodeMath")
        node.operation = "MULTIPLY"
        node.inputs[1].default_value = scale
        tree.links.new(path.outputs[output], node.inputs[0])
        tree.links.new(node.outputs[0], combine.inputs[channel])
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = strength
    tree.links.new(combine.outputs[0], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    return material


def shader_material(name, kind, **inputs):
    material, tree, out = empty_material(name)
    node = tree.nodes.new(kind)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    return material, tree, node


def both(scene, label, samples, seeds=(0,)):
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    warnings.extend(getattr(exported, "warnings", []) or [])
    primer_pixels = render_pixels(scene, "PRIMER", os.path.join(folder, label + "_primer.exr"), samples)
    np.save(os.path.join(folder, label + "_primer.npy"), primer_pixels)
    for seed in seeds:
        scene.cycles.seed = seed
        cycles_pixels = render_pixels(scene, "CYCLES", os.path.join(folder, label + "_cycles.exr"), samples,
                                      f"{{label}}_seed{{seed}}")
        np.save(os.path.join(folder, label + "_cycles%d.npy" % seed), cycles_pixels)


# 1. An emitting wall seen in a 45-degree mirror (a sharp Glossy BSDF).
for label, outputs in (("mirror_a", (("Ray Depth", 1.0), ("Is Glossy Ray", 1.0), ("Glossy Depth", 1.0))),
                       ("mirror_b", (("Is Singular Ray", 1.0), ("Is Reflection Ray", 1.0), ("Is Camera Ray", 1.0)))):
    scene = fresh(1.0)
    mirror, _, _ = shader_material("Mirror", "ShaderNodeBsdfGlossy", Roughness=0.0, Color=(1.0, 1.0, 1.0, 1.0))
    plane(scene, "Mirror", 4.0, (0.0, 0.0, 0.0), (math.radians(-45.0), 0.0, 0.0), mirror)
    plane(scene, "Wall", 20.0, (0.0, 3.0, 0.0), (math.radians(90.0), 0.0, 0.0), light_path_colour("Wall", outputs))
    both(scene, label, 4)

# 2. An emitting floor under three clear Transparent planes.
scene = fresh(1.0)
clear, _, _ = shader_material("Clear", "ShaderNodeBsdfTransparent", Color=(1.0, 1.0, 1.0, 1.0))
for k in range(3):
    plane(scene, "Pane %d" % k, 4.0, (0.0, 0.0, 1.0 + k), (0.0, 0.0, 0.0), clear)
plane(scene, "Floor", 4.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
      light_path_colour("Floor", (("Transparent Depth", 0.25), ("Is Camera Ray", 1.0), ("Ray Depth", 1.0))))
both(scene, "stack", 4)

# 3. A floor lit by a sun through a pane clear to the camera and letting 0.5 x Ray Depth through to shadow rays.
scene = fresh(1.0)
floor, _, _ = shader_material("White", "ShaderNodeBsdfDiffuse", Color=(1.0, 1.0, 1.0, 1.0), Roughness=0.0)
plane(scene, "Floor", 40.0, (10.0, 0.0, 0.0), (0.0, 0.0, 0.0), floor)
pane, tree, transparent = shader_material("Pane", "ShaderNodeBsdfTransparent")
path = tree.nodes.new("ShaderNodeLightPath")
half = tree.nodes.new("ShaderNodeMath")
half.operation = "MULTIPLY"
half.inputs[1].default_value = 0.5
tree.links.new(path.outputs["Ray Depth"], half.inputs[0])
larger = tree.nodes.new("ShaderNodeMath")
larger.operation = "MAXIMUM"
tree.links.new(path.outputs["Is Camera Ray"], larger.inputs[0])
tree.links.new(half.outputs[0], larger.inputs[1])
tree.links.new(larger.outputs[0], transparent.inputs["Color"])
plane(scene, "Pane", 40.0, (10.0, 0.0, 1.0), (0.0, 0.0, 0.0), pane)   # (its diagonal edge out of view: Cycles passes
#                                                                         a shadow ray through an edge's two triangles)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy = math.pi
sun.data.angle = 0.0
scene.collection.objects.link(sun)
both(scene, "shadow", 4)

# 3b. The same with two panes letting Ray Length / 4 through to shadow rays (Cycles measures both from the floor).
tree.links.new(path.outputs["Ray Length"], half.inputs[0])
half.inputs[1].default_value = 0.25
plane(scene, "Upper Pane", 40.0, (10.0, 0.0, 2.0), (0.0, 0.0, 0.0), pane)
scene.camera.location = (0.0, 0.0, 4.0)
both(scene, "shadow_length", 4)

# 3c. The floor seen and lit through two clear panes with Transparent Max Bounces 3 and 4: the camera ray passes both
#     panes either way, its shadow rays only what the path left of the limit (one, then two).
for limit in (3, 4):
    clear_pane, _, _ = shader_material("Clear Pane %d" % limit, "ShaderNodeBsdfTransparent", Color=(1.0, 1.0, 1.0, 1.0))
    for obj in (bpy.data.objects["Pane"], bpy.data.objects["Upper Pane"]):
        obj.data.materials[0] = clear_pane
    scene.primer.transparent_bounces = limit
    both(scene, "shadow_limit_%d" % limit, 4)

# 4. A lamp that shines 1 to light samples and 5 to diffuse rays over a diffuse floor (one light sample per vertex, as
#    Cycles takes: MIS weighs the two strategies as Cycles does).
scene = fresh(4.0, height=3.0)
scene.primer.light_samples = 1
floor, _, _ = shader_material("Grey", "ShaderNodeBsdfDiffuse", Color=(0.8, 0.8, 0.8, 1.0), Roughness=0.0)
plane(scene, "Floor", 40.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), floor)
lamp, tree, emission = shader_material("Lamp", "ShaderNodeEmission", Color=(1.0, 1.0, 1.0, 1.0))
path = tree.nodes.new("ShaderNodeLightPath")
boost = tree.nodes.new("ShaderNodeMath")
boost.operation = "MULTIPLY_ADD"
boost.inputs[1].default_value = 4.0
boost.inputs[2].default_value = 1.0
tree.links.new(path.outputs["Is Diffuse Ray"], boost.inputs[0])
tree.links.new(boost.outputs[0], emission.inputs["Strength"])
plane(scene, "Lamp", 1.0, (1.5, 0.0, 1.0), (math.radians(180.0), 0.0, 0.0), lamp)
both(scene, "lamp", 256, seeds=(0, 1))
boost.inputs[1].default_value = 0.0                 # the same lamp shining 1 to every ray
both(scene, "constant", 256, seeds=(0, 1))

# 5. A lamp invisible to glossy rays (Mix Shader: Emission, or Transparent where Is Glossy Ray) over a rough Glossy
#    floor.
scene = fresh(4.0, height=3.0)
scene.primer.light_samples = 1
glossy, _, _ = shader_material("Rough", "ShaderNodeBsdfGlossy", Color=(0.8, 0.8, 0.8, 1.0), Roughness=0.3)
plane(scene, "Floor", 40.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), glossy)
lamp, tree, mix = shader_material("Hidden Lamp", "ShaderNodeMixShader")
path = tree.nodes.new("ShaderNodeLightPath")
emission = tree.nodes.new("ShaderNodeEmission")
emission.inputs["Strength"].default_value = 2.0
clear = tree.nodes.new("ShaderNodeBsdfTransparent")
tree.links.new(path.outputs["Is Glossy Ray"], mix.inputs[0])
tree.links.new(emission.outputs[0], mix.inputs[1])
tree.links.new(clear.outputs[0], mix.inputs[2])
plane(scene, "Lamp", 1.0, (1.5, 0.0, 1.0), (math.radians(180.0), 0.0, 0.0), lamp)
both(scene, "hidden", 256, seeds=(0, 1))
report(warnings=[w for w in warnings if "Light Path" in w or "light path" in w])
"""


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Every scene rendered by Primer and Cycles: (the folder of their pixels, the script's report)."""
    folder = tmp_path_factory.mktemp("light_path")
    result = run_bpy(SCRIPT.format(folder=str(folder)), str(folder))
    return folder, result


def pixels(folder, label: str, engine: str) -> np.ndarray:
    """A render's RGB pixels (H, W, 3) float64."""
    return np.load(folder / f"{label}_{engine}.npy")[..., :3]


@pytest.mark.parametrize("label", ["mirror_a", "mirror_b", "stack", "shadow", "shadow_length"])
def test_light_path_outputs_seen_in_a_mirror_through_clear_planes_and_in_shadow_rays_are_cycles_values(rendered, label):
    """One value per pixel (the mirror's and panes' rays are singular, the sun has no extent): Cycles' pixels to
    float32 rounding."""
    folder, result = rendered
    assert result["warnings"] == []
    primer, cycles = pixels(folder, label, "primer"), pixels(folder, label, "cycles0")
    assert cycles.max() > 0.1, "the scene should show its outputs"
    # (Ray Length in a shadow ray: Primer's starts a robust offset off the floor (float32 ulps of the coordinates),
    # where Cycles' starts on it and skips its own triangle: measured 2.7e-6 darker)
    np.testing.assert_allclose(primer, cycles, atol=5e-6 if label == "shadow_length" else 2e-6, rtol=1e-6)


def test_a_shadow_ray_passes_what_its_path_left_of_the_transparent_bounce_limit_as_in_cycles(rendered):
    """Seen and lit through two clear panes: black with Transparent Max Bounces 3 (the shadow ray has one pass left),
    lit with 4 (1 / pi x pi = 1), in both renderers alike."""
    folder, _ = rendered
    for limit, lit in ((3, 0.0), (4, 1.0)):
        primer, cycles = (pixels(folder, f"shadow_limit_{limit}", engine) for engine in ("primer", "cycles0"))
        np.testing.assert_allclose(cycles, lit, atol=1e-5)
        np.testing.assert_allclose(primer, cycles, atol=2e-5)


# The largest relative difference of a 4 x 4 block mean allowed (measured 0.86%, 0.89% and 3.3%: the blocks by the
# lamp's edge, where Primer's samples fall elsewhere than Cycles'; Cycles' own noise 0.12%, 0.10% and 0.49%).
BLOCK_BOUND = {"lamp": 0.012, "constant": 0.012, "hidden": 0.045}


@pytest.mark.parametrize("label", list(BLOCK_BOUND))
def test_lamps_that_light_path_shows_otherwise_to_light_samples_and_bsdf_rays_light_a_floor_as_in_cycles(rendered,
                                                                                                        label):
    """The floor's mean within 0.3% of Cycles' (measured: 0.07% for the lamp brighter to diffuse rays, 0.009% for the
    same lamp shining 1 to every ray, 0.15% for the lamp hidden from glossy rays; a light sample shaded as a diffuse
    ray would be several times brighter, one shaded as a glossy ray would leave the glossy floor black), and its 4 x 4
    block means within BLOCK_BOUND; against the mean of Cycles' renders at two seeds."""
    folder, _ = rendered
    primer = pixels(folder, label, "primer").mean(axis=2)
    cycles = [pixels(folder, label, f"cycles{seed}").mean(axis=2) for seed in (0, 1)]
    ours, first, second = (image.reshape(4, 4, 4, 4).mean(axis=(1, 3)) for image in (primer, *cycles))
    reference = 0.5 * (first + second)
    noise = np.sqrt(np.mean((first / reference - second / reference) ** 2))
    difference = np.abs(ours / reference - 1.0)
    overall = ours.mean() / reference.mean() - 1.0
    print(label, "block means: largest relative difference", difference.max(), "image", overall, "Cycles' noise", noise)
    assert reference.mean() > 0.01
    assert abs(overall) <= 0.003
    assert difference.max() <= BLOCK_BOUND[label]
