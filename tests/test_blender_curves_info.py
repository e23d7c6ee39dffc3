"""The Curves Info node on hair curves inside real Blender (the bpy module, no mocks), against Cycles' own render.

Two sets of five wavy, tapering hair curves, each an Emission of colours built from the node's outputs: (Intercept,
Random, Length / 10) and (Thickness x 4, Is Strand / 2, Tangent Normal's z), seen from above by an orthographic
camera (64 x 48 pixels, 16 samples each). Cycles renders round strands, Primer triangle tubes around the same splines (inscribed, 12
sides): the outputs are compared where both renders see a strand, on pixels whose neighbours Cycles also sees as strand.
"""
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
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
scene.cycles_curves.shape = "THICK"                     # (round strands: 3D Curves)


def info_material(name, outputs):
    material, tree, out = empty_material(name)
    info, combine = tree.nodes.new("ShaderNodeHairInfo"), tree.nodes.new("ShaderNodeCombineXYZ")
    for axis, (output, component, scale) in zip("XYZ", outputs):
        socket = info.outputs[output]
        if component is not None:                         # (a vector's component)
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


for side, outputs in ((-1, [("Intercept", None, 1.0), ("Random", None, 1.0), ("Length", None, 0.1)]),
                      (1, [("Thickness", None, 4.0), ("Is Strand", None, 0.5), ("Tangent Normal", "Z", 1.0)])):
    hair = bpy.data.hair_curves.new("Hair")
    hair.add_curves([6] * 5)
    positions = [(1.6 * side - 1.2 + 0.5 * x, -1.6 + 0.8 * k + 0.3 * math.sin(2.0 * x + k), 0.3 + 0.1 * math.cos(3.0 * x))
                 for k in range(5) for x in np.linspace(0.0, 5.0, 6)]
    hair.position_data.foreach_set("vector", np.array(positions, np.float32).ravel())
    radius = hair.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", np.tile(np.linspace(0.25, 0.12, 6), 5).astype(np.float32))
    hair.materials.append(info_material("Info %d" % side, outputs))
    scene.collection.objects.link(bpy.data.objects.new("Hair %d" % side, hair))
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.data.type, camera.data.ortho_scale = "ORTHO", 6.4
camera.location = (0.0, 0.0, 5.0)
scene.collection.objects.link(camera)
scene.camera = camera
warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
for engine in ("PRIMER", "CYCLES"):
    np.save(engine.lower() + ".npy", render_pixels(scene, engine, os.path.abspath(engine.lower() + ".exr"), 16)[..., :3])
primer.unregister()
report(warnings=warnings)
"""


def strand_inside(image: np.ndarray) -> np.ndarray:
    """Pixels (H, W) bool whose 3 x 3 neighbourhood is all strand (some channel above 0): away from the silhouettes."""
    covered = image.max(axis=2) > 0.0
    h, w = covered.shape
    padded = np.pad(covered, 1)
    return np.all([padded[i:i + h, j:j + w] for i in range(3) for j in range(3)], axis=0)


def test_curves_info_outputs_on_hair_strands_are_cycles(tmp_path):
    """Intercept (0 at the root, 1 at the tip, along the polyline through the points), Random (a hash of the curve's
    index), Length (the polyline's), Thickness (twice the interpolated radius) and Is Strand (1) are Cycles' on every
    strand pixel, within the sampling of values that vary along a pixel (Intercept, Thickness)."""
    report = run_bpy(SCRIPT, str(tmp_path))
    assert report["warnings"] == []
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    inside = strand_inside(cycles) & strand_inside(primer)
    assert inside[:, :32].sum() > 60 and inside[:, 32:].sum() > 60
    difference = np.abs(primer - cycles)[inside]                     # (k, 3)
    left = np.broadcast_to(np.arange(inside.shape[1]) < 32, inside.shape)[inside]   # (which set each pixel shows)
    print("mean |difference| left (intercept, random, length/10):", difference[left].mean(axis=0),
          "right (thickness x 4, is strand / 2):", difference[~left].mean(axis=0))
    print("largest:", difference[left].max(axis=0), difference[~left].max(axis=0))
    exact = [float((d < 1e-5).mean()) for d in (difference[left][:, 1], difference[left][:, 2], difference[~left][:, 1])]
    print("share of the pixels equal to float32 rounding (random, length, is strand):", exact)
    # Constant along a curve (Random, Length, Is Strand): Cycles' value to float32 rounding in nearly every pixel
    # (measured: 94-97%; the others are where strands pass over each other or end, their samples on another strand
    # or the background, the tubes' silhouette inscribed in Cycles' round one).
    assert min(exact) > 0.9
    # Varying along it (Intercept, Thickness, Tangent Normal): the mean difference is that and the samples' placement
    # in the pixels (measured 4.1e-3, 8.8e-3 and 6.0e-3 (median 2.2e-3) of values up to 1; the tangent normal's z, the
    # view across the strand seen from above, averages 0.9381 in Primer and 0.9375 in Cycles).
    assert difference[left][:, 0].mean() < 1e-2
    assert difference[~left][:, 0].mean() < 2e-2
    assert difference[~left][:, 2].mean() < 1e-2
    assert primer[inside][~left][:, 2].mean() == pytest.approx(cycles[inside][~left][:, 2].mean(), abs=2e-3)
    assert difference.mean() < 5e-3
