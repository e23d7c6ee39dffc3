"""Cycles' input nodes against Cycles' own render: each output the colour of an Emission shader, rendered by Cycles
and by Primer (exported by addon/materials.py with real Blender) and compared pixel for pixel.

An orthographic camera sends every ray in one direction, so a flat face shows one value of a view-dependent output
(Fresnel, Layer Weight) wherever it is hit: each case is a column of a flat-shaded icosphere (faces at every angle,
seen from the front) above two planes turned away from the camera, their backs seen at 30 and 60 degrees. Pixels
whose 3 x 3 neighbourhood Cycles renders as one value lie inside a face; there the two renders differ only by
float32 rounding (Cycles computes in float, Primer's graph in double).
"""
from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy

pytestmark = pytest.mark.blender

if importlib.util.find_spec("bpy") is None:
    if os.environ.get("PRIMER_ALLOW_NO_BPY"):
        pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
    raise ImportError("tests/test_blender_inputs.py needs bpy (Blender as a Python module): pip install bpy")

PIXELS = 32               # pixels across each cell
ROWS = 3                  # the icosphere, the back at 30 degrees, the back at 60 degrees

SCRIPT = """
import sys, os, math
import bpy
import numpy as np
from blender_env import report, render_pixels, empty_material
sys.path.insert(0, {tools!r})
from render import load_primer
primer = load_primer()
export = sys.modules[primer.__name__ + ".addon.export"]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
PIXELS, ROWS = {pixels}, {rows}
cases = []


def case(label, idname, output, inputs=()):
    material, tree, out = empty_material(label)
    node = tree.nodes.new(idname)
    for name, value in inputs:
        node.inputs[name].default_value = value
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(node.outputs[output], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    column = len(cases)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.45, location=(column + 0.5, -0.5, 0.0))
    bpy.context.view_layer.objects.active.data.materials.append(material)
    for row, degrees in ((1, 150.0), (2, 120.0)):      # backs to the camera, seen at 30 and 60 degrees
        bpy.ops.mesh.primitive_plane_add(size=0.9, location=(column + 0.5, -row - 0.5, 0.0),
                                         rotation=(math.radians(degrees), 0.0, 0.0))
        bpy.context.view_layer.objects.active.data.materials.append(material)
    cases.append(label)


case("Fresnel IOR 1.45", "ShaderNodeFresnel", "Fac", [("IOR", 1.45)])
case("Fresnel IOR 2.4", "ShaderNodeFresnel", "Fac", [("IOR", 2.4)])
case("Layer Weight Fresnel 0.3", "ShaderNodeLayerWeight", "Fresnel", [("Blend", 0.3)])
case("Layer Weight Facing 0.5", "ShaderNodeLayerWeight", "Facing", [("Blend", 0.5)])
case("Layer Weight Facing 0.2", "ShaderNodeLayerWeight", "Facing", [("Blend", 0.2)])
case("Layer Weight Facing 0.8", "ShaderNodeLayerWeight", "Facing", [("Blend", 0.8)])

columns = len(cases)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.data.type = "ORTHO"
camera.data.ortho_scale = float(columns)
camera.location = (columns / 2, -ROWS / 2, 5.0)
scene.collection.objects.link(camera)
scene.camera = camera
scene.render.resolution_x, scene.render.resolution_y = columns * PIXELS, ROWS * PIXELS
scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
images = {{engine: render_pixels(scene, engine, os.path.abspath(engine.lower() + ".exr"), 2)[::-1, :, :3]
          for engine in ("PRIMER", "CYCLES")}}
np.save("primer.npy", images["PRIMER"])
np.save("cycles.npy", images["CYCLES"])
primer.unregister()
report(cases=cases, warnings=warnings)
"""


def interior(image: np.ndarray) -> np.ndarray:
    """Pixels (H, W) bool whose 3 x 3 neighbourhood holds one value in every channel (inside a flat face)."""
    h, w = image.shape[:2]
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    windows = np.stack([padded[i:i + h, j:j + w] for i in range(3) for j in range(3)])
    return (np.ptp(windows, axis=0) == 0.0).all(axis=2)


def test_fresnel_and_layer_weight_render_cycles_values_inside_every_face_front_and_back(tmp_path):
    """Every face of a sphere seen from the front and two planes seen from behind (past the critical angle for
    Fresnel at 60 degrees): Primer's pixels are Cycles' values to float32 rounding, and nothing is warned of."""
    result = run_bpy(SCRIPT.format(tools=os.path.join(ROOT, "tools"), pixels=PIXELS, rows=ROWS), str(tmp_path))
    assert result["warnings"] == []
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    assert primer.shape == cycles.shape
    inside = interior(cycles)
    worst, counted = {}, {}
    for column, label in enumerate(result["cases"]):
        for row, view in enumerate(("front", "back 30", "back 60")):
            block = (slice(row * PIXELS, (row + 1) * PIXELS), slice(column * PIXELS, (column + 1) * PIXELS))
            face = inside[block] & (cycles[block].max(axis=2) > 0.0)
            counted[label, view] = int(face.sum())
            worst[label, view] = float(np.abs(primer[block] - cycles[block])[face].max())
    print("largest difference inside faces per output:", worst)
    assert min(counted.values()) >= 40, counted
    assert cycles[:PIXELS].std() > 0.01, "the spheres' faces should show many values"
    far = {key: d for key, d in worst.items() if d > 5e-7}      # measured <= 3.0e-7
    assert far == {}, far
