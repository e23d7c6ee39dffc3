"""A light's node tree in Primer, as Cycles reads it, on the Blender of this environment (5.0 or 5.2).

Blender 5.2 gives every light a node tree (an Emission node, white, strength 1) and keeps Use Nodes on;
4.2 and 5.0 use a tree only with Use Nodes on. The script runs in its own bpy process (tests/blender_env.py
LIGHT_NODES); tests/smoke_bpy42.py runs it on Blender 4.2.
"""
from __future__ import annotations

import math
import os

import numpy as np
import pytest

from blender_env import LIGHT_NODES, ROOT, check_light_nodes, run_bpy

pytestmark = pytest.mark.blender

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")


def test_emission_node_scales_the_light_and_a_default_tree_warns_nothing(tmp_path):
    """Emission strength 2, colour (1, 0.5, 0.25): Primer's and Cycles' pixels are 2 x (1, 0.5, 0.25) those
    of the plain light; the default tree (and the default scene's light) warns nothing; a Light Falloff into the
    Strength gives a sun its Strength (as Cycles, no warning); another shader at the output is warned about, naming
    the light and the node."""
    result = run_bpy(LIGHT_NODES.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    assert result["version"][:2] == list(bpy.app.version[:2])
    check_light_nodes(result)


DEPTHS_AND_INFO = """
import os, sys
import bpy
from blender_env import diffuse_material, fresh_scene, ortho_camera, render_pixels, report

primer, export, scene = fresh_scene(24, 16)
scene.primer.use_adaptive_sampling = False
scene.primer.integrator, scene.primer.max_bounces = "PATH", 1
scene.world = None
ortho_camera(scene, 4.0)
white = diffuse_material("White", (0.8, 0.8, 0.8))
bpy.ops.mesh.primitive_plane_add(size=6.0)
bpy.context.object.data.materials.append(white)
bpy.ops.mesh.primitive_plane_add(size=4.0, location=(1.2, 0.0, 1.0), rotation=(0.0, 1.5707963, 0.0))
bpy.context.object.data.materials.append(white)
data = bpy.data.lights.new("Lamp", "POINT")
data.energy, data.shadow_soft_size = 40.0, 0.1
if hasattr(data, "use_nodes"):
    data.use_nodes = True
lamp = bpy.data.objects.new("Lamp", data)
lamp.location, lamp.color, lamp.pass_index = (-0.3, 0.2, 1.2), (0.2, 0.5, 0.9, 0.7), 3
scene.collection.objects.link(lamp)
tree = data.node_tree
emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
path, info = tree.nodes.new("ShaderNodeLightPath"), tree.nodes.new("ShaderNodeObjectInfo")


def math(operation, a, b, c=None):
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = operation
    for k, value in enumerate((a, b, c)):
        if isinstance(value, bpy.types.NodeSocket):
            tree.links.new(value, node.inputs[k])
        elif value is not None:
            node.inputs[k].default_value = value
    return node.outputs[0]


depth = math("MULTIPLY_ADD", path.outputs["Diffuse Depth"], 3.0, path.outputs["Ray Depth"])
own = math("ADD", math("MULTIPLY_ADD", info.outputs["Object Index"], 0.2, info.outputs["Alpha"]),
           info.outputs["Random"])
tree.links.new(math("MULTIPLY", depth, own), emission.inputs["Strength"])
tree.links.new(info.outputs["Color"], emission.inputs["Color"])
out = {"primer": render_pixels(scene, "PRIMER", os.path.abspath("primer.exr"), 256)[..., :3].tolist()}
out["warnings"] = list(sys.modules[primer.__name__ + ".addon.engine"].last_render.warnings)
out["cycles"] = render_pixels(scene, "CYCLES", os.path.abspath("cycles.exr"), 1024,
                              reference="depths and object info")[..., :3].tolist()
report(images=out)
"""


def test_a_lamp_tree_reading_path_depths_and_object_info_lights_as_in_cycles(tmp_path):
    """Cycles evaluates a lamp's tree with the depths of the path its light reaches (a light sample its vertex's, Ray
    Depth one more; a BSDF ray meeting the lamp its own after the bounce) and the lamp's own object: a small point
    lamp whose Strength is (Ray Depth + 3 Diffuse Depth) x (Alpha + 0.2 Object Index + Random) and whose Color is
    its Object Info Color, over a floor beside a wall (path tracing, one bounce): Primer's image is Cycles' within
    the noise (block relMSE), and nothing is said about the tree."""
    from core.film.compare import relative_mse_of_blocks
    images = run_bpy(DEPTHS_AND_INFO, str(tmp_path))["images"]
    primer, cycles = np.asarray(images["primer"]), np.asarray(images["cycles"])
    error = relative_mse_of_blocks(primer, cycles)
    print(f"depths and object info: {error:.2e}, means {primer.mean():.4f} {cycles.mean():.4f}", images["warnings"])
    assert not [w for w in images["warnings"] if "light 'Lamp'" in w]
    assert error < 1e-4 and abs(primer.mean() / cycles.mean() - 1.0) < 0.01


def test_world_importance_map_is_sized_as_cycles_world_sampling(tmp_path):
    """The world's importance map has Cycles' World MIS resolution (scene/light.cpp): Automatic maps an HDRI of 64 x
    32 at 4096 x 2048 (Cycles' Automatic render is bit for bit its Manual 4096 one, not its Manual 1024 one), one
    Sky Texture's sun at 512 x 256, and the image's own size where larger; Manual its resolution; None makes no light
    of it (the rays that escape find it)."""
    import sys
    import numpy as np
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    from render import load_primer
    primer = load_primer()
    export = sys.modules[primer.__name__ + ".addon.export"]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera, camera.location, camera.rotation_euler = camera, (0.0, -4.0, 0.0), (math.pi / 2, 0.0, 0.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0)
    material = bpy.data.materials.new("Metal")
    material.use_nodes = True
    principled = material.node_tree.nodes["Principled BSDF"]
    principled.inputs["Metallic"].default_value, principled.inputs["Roughness"].default_value = 1.0, 0.3
    bpy.context.object.data.materials.append(material)
    # 1. An HDRI of 64 x 32 with a bright patch, saved and read back as a file.
    image = bpy.data.images.new("Sky", 64, 32, float_buffer=True)
    pixels = np.full((32, 64, 4), 0.2, np.float32)
    pixels[24:27, 10:13, :3] = 50.0
    image.pixels.foreach_set(pixels.ravel())
    image.filepath_raw, image.file_format = str(tmp_path / "sky.exr"), "OPEN_EXR"
    image.save()
    world = bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    tree = world.node_tree
    environment = tree.nodes.new("ShaderNodeTexEnvironment")
    environment.image = image
    tree.links.new(environment.outputs["Color"], tree.nodes["Background"].inputs["Color"])

    def size(sampling, resolution=1024):
        world.cycles.sampling_method, world.cycles.sample_map_resolution = sampling, resolution
        world.update_tag()
        core = export.export_scene(bpy.context.evaluated_depsgraph_get()).scene.world
        return core.map_size

    assert size("AUTOMATIC") == (4096, 2048)
    assert size("MANUAL", 300) == (300, 150)
    assert size("NONE") == (0, 0)
    # 2. Cycles: Automatic is its Manual 4096 map, noise for noise.
    scene.render.engine, scene.cycles.device, scene.cycles.samples = "CYCLES", "CPU", 2
    scene.cycles.use_denoising, scene.cycles.use_adaptive_sampling = False, False
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 24, 18, 100
    renders = {}
    for sampling, resolution in (("AUTOMATIC", 1024), ("MANUAL", 4096), ("MANUAL", 1024)):
        world.cycles.sampling_method, world.cycles.sample_map_resolution = sampling, resolution
        bpy.ops.render.render()
        result = bpy.data.images["Render Result"]
        path = str(tmp_path / f"{sampling}{resolution}.exr")
        scene.render.image_settings.file_format = "OPEN_EXR"
        result.save_render(path)
        renders[sampling, resolution] = np.array(bpy.data.images.load(path).pixels[:])
    assert np.array_equal(renders["AUTOMATIC", 1024], renders["MANUAL", 4096])
    assert not np.array_equal(renders["AUTOMATIC", 1024], renders["MANUAL", 1024])
    # 3. A Sky Texture's sun beside the image: the image's size, at least 512 x 256; its Vector mapped: 4096.
    sky = tree.nodes.new("ShaderNodeTexSky")
    mix = tree.nodes.new("ShaderNodeMixRGB")
    tree.links.new(environment.outputs["Color"], mix.inputs["Color1"])
    tree.links.new(sky.outputs["Color"], mix.inputs["Color2"])
    tree.links.new(mix.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    assert size("AUTOMATIC") == (512, 256)
    if "Vector" in sky.inputs:                 # (Blender 5.2's Sky Texture; 5.0's has no Vector input)
        mapping = tree.nodes.new("ShaderNodeMapping")
        tree.links.new(mapping.outputs["Vector"], sky.inputs["Vector"])
        assert size("AUTOMATIC") == (4096, 2048)
