"""The Particle Info node on objects instanced by a particle system inside real Blender (the bpy module, no mocks),
against Cycles' own render: icospheres placed by an emitter's 16 particles, an Emission of (Index / 16, Random,
Age / 10), and a second system's of (Lifetime / 100, Size, Location's z); beside them an object no particle placed,
which reads Cycles' particle 0 (all 0, the Random of index 0). Seen from above, 48 x 32 pixels, 4 samples each."""
from __future__ import annotations

import numpy as np
import pytest

from blender_env import run_bpy

pytestmark = pytest.mark.blender

SCRIPT = """
import math, os
import bpy
import numpy as np
from blender_env import empty_material, primer_in_blender, render_pixels, report
primer, export = primer_in_blender()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 32, 100


def info_material(name, outputs):
    material, tree, out = empty_material(name)
    info, combine = tree.nodes.new("ShaderNodeParticleInfo"), tree.nodes.new("ShaderNodeCombineXYZ")
    for axis, (output, component, scale) in zip("XYZ", outputs):
        socket = info.outputs[output]
        if component is not None:
            separate = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(socket, separate.inputs[0])
            socket = separate.outputs[component]
        multiply = tree.nodes.new("ShaderNodeMath")
        multiply.operation, multiply.inputs[1].default_value = "MULTIPLY", scale
        tree.links.new(socket, multiply.inputs[0])
        tree.links.new(multiply.outputs[0], combine.inputs[axis])
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(combine.outputs[0], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    return material


FIRST = [("Index", None, 1.0 / 16.0), ("Random", None, 1.0), ("Age", None, 0.1)]
SECOND = [("Lifetime", None, 0.01), ("Size", None, 1.0), ("Location", "Z", 1.0)]
for x, outputs in ((-1.2, FIRST), (1.2, SECOND)):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=1.0, location=(100.0 + x, 0.0, 0.0))   # (out of view)
    ball = bpy.context.view_layer.objects.active
    ball.data.materials.append(info_material("Info %.1f" % x, outputs))
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(x, 0.0, 0.0))
    emitter = bpy.context.view_layer.objects.active
    emitter.show_instancer_for_render = False
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.count, settings.frame_start, settings.frame_end, settings.lifetime = 16, 1, 3, 40
    settings.physics_type, settings.render_type, settings.instance_object = "NO", "OBJECT", ball
    settings.particle_size, settings.size_random = 0.3, 0.4
    settings.emit_from, settings.use_emit_random = "FACE", True
bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.3, location=(0.0, 1.2, 0.0))
bpy.context.view_layer.objects.active.data.materials.append(info_material("Not a particle", FIRST))
scene.frame_set(6)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.data.type, camera.data.ortho_scale = "ORTHO", 4.8
camera.location = (0.0, 0.0, 5.0)
scene.collection.objects.link(camera)
scene.camera = camera
warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
for engine in ("PRIMER", "CYCLES"):
    np.save(engine.lower() + ".npy", render_pixels(scene, engine, os.path.abspath(engine.lower() + ".exr"), 4)[..., :3])
primer.unregister()
report(warnings=warnings)
"""


def inside(image: np.ndarray) -> np.ndarray:
    """Pixels (H, W) bool whose 3 x 3 neighbourhood holds one value in every channel, and something there."""
    h, w = image.shape[:2]
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    windows = np.stack([padded[i:i + h, j:j + w] for i in range(3) for j in range(3)])
    return (np.ptp(windows, axis=0) == 0.0).all(axis=2) & (image.max(axis=2) > 0.0)


def test_particle_info_of_instanced_objects_is_cycles(tmp_path):
    """Each instance's Index, Random, Age, Lifetime, Size and Location, and particle 0's for an object no particle
    placed, are Cycles' to float32 rounding inside every sphere."""
    report = run_bpy(SCRIPT, str(tmp_path))
    assert report["warnings"] == []
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    flat = inside(cycles) & inside(primer)
    assert flat.sum() > 20, flat.sum()
    assert len(np.unique(cycles[flat].round(4), axis=0)) > 8          # (many particles, each its own values)
    difference = np.abs(primer - cycles)[flat]
    print("pixels compared:", int(flat.sum()), "largest difference:", difference.max(axis=0))
    assert difference.max() < 1e-5
