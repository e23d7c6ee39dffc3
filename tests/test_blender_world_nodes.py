"""A world made of shader nodes (core/lights/world_graph.py, addon/export.py `_baked_world`) against Cycles' render
and closed forms: a sky from the Generated direction through Map Range and Color Ramp with a Noise Texture for its
strength, an Environment Texture through Hue/Saturation multiplied by that sky, each seen by an equirectangular
camera and lighting a Lambert floor; a Mix Shader of Backgrounds; an RGB node into the Background is the constant world it
is.
"""
from __future__ import annotations

import importlib.util
import os

import pytest

from blender_env import run_bpy

from core.film.compare import relative_mse_of_blocks

pytestmark = pytest.mark.blender

if importlib.util.find_spec("bpy") is None:
    if os.environ.get("PRIMER_ALLOW_NO_BPY"):
        pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
    raise ImportError("tests/test_blender_world_nodes.py needs bpy (Blender as a Python module): pip install bpy")

SCRIPT = """
import sys, os
import bpy
import numpy as np
from blender_env import report, render_pixels, diffuse_material, primer_in_blender
primer, export = primer_in_blender()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
world = bpy.data.worlds.new("Sky")
scene.world = world
world.use_nodes = True
tree = world.node_tree
background = tree.nodes["Background"]
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
bpy.ops.mesh.primitive_plane_add(size=8.0)
floor = bpy.context.view_layer.objects.active
floor.data.materials.append(diffuse_material(albedo=(0.5, 0.5, 0.5)))


def sky():
    # Generated (in a world: the direction) -> Z -> Map Range from [-0.3, 1] -> an orange-to-blue Color Ramp.
    coords = tree.nodes.new("ShaderNodeTexCoord")
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(coords.outputs["Generated"], separate.inputs["Vector"])
    remap = tree.nodes.new("ShaderNodeMapRange")
    remap.inputs["From Min"].default_value = -0.3
    tree.links.new(separate.outputs["Z"], remap.inputs["Value"])
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (1.0, 0.5, 0.2, 1.0)
    ramp.color_ramp.elements[1].color = (0.2, 0.4, 1.0, 1.0)
    tree.links.new(remap.outputs[0], ramp.inputs["Fac"])
    return ramp.outputs["Color"]


def clear():
    for node in [n for n in tree.nodes if n.name not in (background.name, "World Output")]:
        tree.nodes.remove(node)
    background.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    background.inputs["Strength"].default_value = 1.0


def view(panorama):
    # An equirectangular camera sees the whole sky (the floor hidden from it); a perspective one the lit floor.
    floor.visible_camera = not panorama
    if panorama:
        camera.data.type, camera.data.panorama_type = "PANO", "EQUIRECTANGULAR"
        camera.location, camera.rotation_euler = (0.0, 0.0, 0.0), (np.pi / 2, 0.0, 0.0)
        scene.render.resolution_x, scene.render.resolution_y = 64, 32
    else:
        camera.data.type = "PERSP"
        camera.location, camera.rotation_euler = (0.0, -6.0, 1.0), (np.radians(80.0), 0.0, 0.0)
        scene.render.resolution_x, scene.render.resolution_y = 48, 32


def render(name, panorama):
    view(panorama)
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    for engine in ("PRIMER", "CYCLES"):
        np.save(f"{{name}}_{{engine.lower()}}.npy", render_pixels(scene, engine, os.path.abspath("out.exr"), 64, name)[..., :3])
    return warnings


results = {{}}
noise = tree.nodes.new("ShaderNodeTexNoise")
noise.inputs["Scale"].default_value = 3.0
tree.links.new(sky(), background.inputs["Color"])
tree.links.new(noise.outputs["Fac"], background.inputs["Strength"])
results["noise sky seen"] = render("noise_sky_seen", True)
results["noise sky lighting"] = render("noise_sky_lighting", False)

clear()
image = bpy.data.images.new("Grid", 64, 32, float_buffer=True)
image.generated_type = "COLOR_GRID"
environment = tree.nodes.new("ShaderNodeTexEnvironment")
environment.image = image
saturation = tree.nodes.new("ShaderNodeHueSaturation")
saturation.inputs["Saturation"].default_value = 0.5
tree.links.new(environment.outputs["Color"], saturation.inputs["Color"])
multiply = tree.nodes.new("ShaderNodeMix")
multiply.data_type, multiply.blend_type = "RGBA", "MULTIPLY"
multiply.inputs["Factor"].default_value = 1.0
tree.links.new(saturation.outputs["Color"], multiply.inputs["A"])
tree.links.new(sky(), multiply.inputs["B"])
tree.links.new(multiply.outputs["Result"], background.inputs["Color"])
results["graded environment seen"] = render("graded_environment_seen", True)

# Mix Shader (Fac from a Noise Texture) of the sky's Background and an Add Shader of a red Background and the
# environment's through a Mapping that scales the direction (which only a graph can evaluate).
clear()
tree.links.new(sky(), background.inputs["Color"])
mix, add = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeAddShader")
red, grid = tree.nodes.new("ShaderNodeBackground"), tree.nodes.new("ShaderNodeBackground")
red.inputs["Color"].default_value = (0.9, 0.1, 0.1, 1.0)
grid.inputs["Strength"].default_value = 0.5
environment = tree.nodes.new("ShaderNodeTexEnvironment")
environment.image = image
mapping = tree.nodes.new("ShaderNodeMapping")
mapping.inputs["Scale"].default_value = (2.0, 1.0, 1.0)
tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], mapping.inputs["Vector"])
tree.links.new(mapping.outputs["Vector"], environment.inputs["Vector"])
tree.links.new(environment.outputs["Color"], grid.inputs["Color"])
tree.links.new(red.outputs[0], add.inputs[0])
tree.links.new(grid.outputs[0], add.inputs[1])
noise = tree.nodes.new("ShaderNodeTexNoise")
tree.links.new(noise.outputs["Fac"], mix.inputs["Fac"])
tree.links.new(background.outputs[0], mix.inputs[1])
tree.links.new(add.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], tree.nodes["World Output"].inputs["Surface"])
results["mixed backgrounds seen"] = render("mixed_backgrounds_seen", True)
tree.links.new(background.outputs[0], tree.nodes["World Output"].inputs["Surface"])


def camera_or_lighting(lighting, seen):
    # A Mix Shader whose Fac is Is Camera Ray: the camera sees the Background of colour `seen`, the floor is lit by
    # the one of `lighting` (each a colour, or a function making the nodes and returning their output socket).
    clear()
    mix, shown = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeBackground")
    tree.links.new(tree.nodes.new("ShaderNodeLightPath").outputs["Is Camera Ray"], mix.inputs["Fac"])
    for target, value in ((background, lighting), (shown, seen)):
        if isinstance(value, tuple):
            target.inputs["Color"].default_value = value + (1.0,)
        else:
            tree.links.new(value(), target.inputs["Color"])
    tree.links.new(background.outputs[0], mix.inputs[1])
    tree.links.new(shown.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["World Output"].inputs["Surface"])


def grid():
    environment = tree.nodes.new("ShaderNodeTexEnvironment")
    environment.image = image
    return environment.outputs["Color"]


camera_or_lighting(grid, (0.3, 0.3, 0.3))
results["grey seen grid lighting"] = render("grey_seen_grid_lighting", False)
camera_or_lighting((0.8, 0.6, 0.4), sky)
results["sky seen colour lighting"] = render("sky_seen_colour_lighting", False)

# The sky's Strength Is Diffuse Ray: no light sample sees it (Cycles' importance map is black), the floor's diffuse
# BSDF rays do, the camera does not.
clear()
tree.links.new(background.outputs[0], tree.nodes["World Output"].inputs["Surface"])
tree.links.new(sky(), background.inputs["Color"])
tree.links.new(tree.nodes.new("ShaderNodeLightPath").outputs["Is Diffuse Ray"], background.inputs["Strength"])
results["sky on diffuse rays lighting"] = render("sky_on_diffuse_rays_lighting", False)
tree.links.new(background.outputs[0], tree.nodes["World Output"].inputs["Surface"])

# A Checker of the direction with squares of 0.23 degrees (Scale 250), about a bake texel (0.18 degrees), seen through a
# 5-degree lens at 64 x 64 (0.08 degrees a pixel): a pixel inside a square is that square's colour exactly.
clear()
checker = tree.nodes.new("ShaderNodeTexChecker")
checker.inputs["Scale"].default_value = 250.0
checker.inputs["Color1"].default_value = (0.9, 0.2, 0.1, 1.0)
checker.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], checker.inputs["Vector"])
tree.links.new(checker.outputs["Color"], background.inputs["Color"])
floor.visible_camera = False
camera.data.type, camera.data.lens, camera.data.sensor_width, camera.data.sensor_fit = "PERSP", 412.0, 36.0, "HORIZONTAL"
camera.location, camera.rotation_euler = (0.0, 0.0, 0.0), (np.radians(60.0), 0.0, np.radians(30.0))
scene.render.resolution_x, scene.render.resolution_y = 64, 64
results["fine checker seen"] = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
for engine in ("PRIMER", "CYCLES"):
    np.save(f"fine_checker_seen_{{engine.lower()}}.npy", render_pixels(scene, engine, os.path.abspath("out.exr"), 16, "fine_checker_seen")[..., :3])
floor.visible_camera = True

# Colours and values linked straight into closure inputs: Cycles turns each into an Emission (a colour at Strength
# 1, a value as the Strength of white): the sky's colour into the Surface; a Noise Fac into a Mix Shader's input.
clear()
tree.links.new(sky(), tree.nodes["World Output"].inputs["Surface"])
results["automatic emission seen"] = render("automatic_emission_seen", True)
clear()
mix = tree.nodes.new("ShaderNodeMixShader")
mix.inputs["Fac"].default_value = 0.4
noise = tree.nodes.new("ShaderNodeTexNoise")
tree.links.new(noise.outputs["Fac"], mix.inputs[1])
tree.links.new(sky(), background.inputs["Color"])
tree.links.new(background.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], tree.nodes["World Output"].inputs["Surface"])
results["automatic emission mixed lighting"] = render("automatic_emission_mixed_lighting", False)
tree.links.new(background.outputs[0], tree.nodes["World Output"].inputs["Surface"])

clear()
rgb = tree.nodes.new("ShaderNodeRGB")
rgb.outputs[0].default_value = (0.2, 0.6, 0.9, 1.0)
tree.links.new(rgb.outputs[0], background.inputs["Color"])
background.inputs["Strength"].default_value = 2.0
view(False)
exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
results["rgb"] = exported.warnings
rgb_world = exported.scene.world
np.save("rgb_primer.npy", render_pixels(scene, "PRIMER", os.path.abspath("out.exr"), 4)[..., :3])

light_path = tree.nodes.new("ShaderNodeLightPath")
tree.links.new(light_path.outputs["Ray Depth"], background.inputs["Strength"])
results["light path"] = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
primer.unregister()
report(warnings=results, rgb_color=list(map(float, rgb_world.color)), rgb_image=rgb_world.image is not None)
"""


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """The world variants rendered by Primer and Cycles (64 samples): (report, folder)."""
    folder = tmp_path_factory.mktemp("world_nodes")
    return run_bpy(SCRIPT.format(), str(folder)), folder


def noted(warnings):
    """The warnings about the world (the scene's other notes, the Cycles settings', left out)."""
    return [w for w in warnings if "world" in w]


@pytest.mark.parametrize("name", ["noise_sky_seen", "noise_sky_lighting", "graded_environment_seen",
                                  "mixed_backgrounds_seen", "grey_seen_grid_lighting", "sky_seen_colour_lighting",
                                  "sky_on_diffuse_rays_lighting", "automatic_emission_seen",
                                  "automatic_emission_mixed_lighting"])
def test_a_world_node_graph_renders_as_cycles_seen_and_lighting_a_floor(rendered, name):
    """The sky's colour and strength, the graded environment, and a Mix Shader of Backgrounds with a scaled Mapping,
    as the camera sees them and as they light a Lambert floor; a Mix Shader by Is Camera Ray that shows the camera a
    grey Background and lights the floor with the grid image, and one that shows the camera the sky and lights the
    floor with a colour; the sky shining on diffuse rays alone (Is Diffuse Ray as its Strength: the camera sees black,
    the floor is lit by its BSDF rays); a colour linked straight into the world's Surface, and a value into a Mix
    Shader's input, each an Emission as Cycles converts it. Cycles evaluates the world for each ray that escapes with its path, and for
    its light samples with EMISSION alone; so does Primer (the bake is a light sample's): Cycles' image within noise
    (64 samples each), with nothing noted about the world; the viewport colour Primer used before is far off."""
    import numpy as np
    result, folder = rendered
    primer, cycles = np.load(folder / f"{name}_primer.npy"), np.load(folder / f"{name}_cycles.npy")
    assert cycles.std() > 0.02                              # the world varies across the image
    error = relative_mse_of_blocks(primer, cycles)
    print(name, "block relMSE", error)
    assert error < 2e-4, error
    assert abs(primer.mean() / cycles.mean() - 1.0) < 0.01
    assert relative_mse_of_blocks(np.full_like(cycles, 0.05), cycles) > 0.1      # (what a grey viewport colour would score)
    label = name.replace("_", " ")
    assert noted(result["warnings"][label]) == [], result["warnings"][label]


def test_an_rgb_node_into_the_background_is_a_constant_world_of_colour_times_strength(rendered):
    """An RGB node (0.2, 0.6, 0.9) x Strength 2 is a constant world, not an image: a Lambert floor of albedo 0.5
    under it, seeing nothing but sky, shows 0.5 L = (0.2, 0.6, 0.9) exactly."""
    import numpy as np
    result, folder = rendered
    assert result["rgb_image"] is False
    assert np.allclose(result["rgb_color"], [0.4, 1.2, 1.8])
    assert noted(result["warnings"]["rgb"]) == []
    floor = np.load(folder / "rgb_primer.npy")[:8]          # the floor's pixels (rows bottom first), below the horizon
    assert np.allclose(floor, [0.2, 0.6, 0.9], rtol=2e-3), floor.reshape(-1, 3)[:3]


def test_a_pattern_about_a_texel_wide_is_seen_per_ray_as_cycles_sees_it(rendered):
    """A Checker of the direction with squares of 0.23 degrees, about a bake texel, seen at 0.08 degrees a pixel: of
    the pixels Cycles shows as one square's colour (all its samples in that square), Primer shows nearly all as one
    square's colour too (it evaluates the world for each camera ray; the bake, interpolated between texel centres 0.18
    degrees apart, would blend them), the same square's to float rounding; the rest within noise (16 samples; the
    samples of an edge pixel fall otherwise)."""
    import numpy as np
    result, folder = rendered
    primer, cycles = np.load(folder / "fine_checker_seen_primer.npy"), np.load(folder / "fine_checker_seen_cycles.npy")
    colours = np.array([[0.9, 0.2, 0.1], [0.1, 0.3, 0.8]], np.float32)
    square = {name: np.abs(image[:, :, None, :] - colours).max(axis=-1) < 1e-6 for name, image in
              (("primer", primer), ("cycles", cycles))}
    pure = {name: which.any(axis=-1) for name, which in square.items()}
    both = pure["primer"] & pure["cycles"]
    print("pure pixels: Cycles", pure["cycles"].mean(), "Primer", pure["primer"].mean(), "both", both.mean(),
          "block relMSE", relative_mse_of_blocks(primer, cycles))
    assert pure["cycles"].mean() > 0.3 and both.sum() > 0.9 * pure["cycles"].sum()
    assert (square["primer"][both] == square["cycles"][both]).all()
    np.testing.assert_allclose(primer[both], cycles[both], atol=1e-6)
    assert relative_mse_of_blocks(primer, cycles) < 4e-3
    assert noted(result["warnings"]["fine checker seen"]) == []


def test_a_world_reading_light_path_depths_is_not_reported(rendered):
    """Every ray that escapes evaluates the world with its path, and (issue 33) a world whose graph reads Light Path's
    depths runs it for each light sample with the path at the vertex it lights (World.samples_seen), as Cycles
    evaluates the world's shader per light sample: a world whose Strength is Ray Depth is not reported."""
    result, _ = rendered
    assert not [w for w in noted(result["warnings"]["light path"]) if "Light Path" in w], \
        result["warnings"]["light path"]
