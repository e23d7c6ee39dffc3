"""The Vector Transform node between world, camera and object space (core/materials/graph.py
`Compiler.vector_transform`) against Cycles' render: points, vectors and normals, each the colour (its components'
absolute values) of an emitting plane seen from above; the object-space cases on planes turned about z and scaled
unevenly (their own transforms)."""
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
    raise ImportError("tests/test_blender_vector_transform.py needs bpy (Blender as a Python module): pip install bpy")

PIXELS = 8
COLUMNS = 6

SCRIPT = """
import bpy
from blender_env import report, empty_material, primer_in_blender, render_plane_grid
primer, export = primer_in_blender()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
cases = []


def case(kind, source, target, vector):
    label = f"{{kind}} {{source}} to {{target}}"
    material, tree, out = empty_material(label)
    node = tree.nodes.new("ShaderNodeVectorTransform")
    node.vector_type, node.convert_from, node.convert_to = kind, source, target
    node.inputs["Vector"].default_value = vector
    absolute = tree.nodes.new("ShaderNodeVectorMath")
    absolute.operation = "ABSOLUTE"
    tree.links.new(node.outputs["Vector"], absolute.inputs[0])
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(absolute.outputs["Vector"], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    index = len(cases)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(index % {columns} + 0.5, -(index // {columns}) - 0.5, 0.0))
    plane = bpy.context.view_layer.objects.active
    if "OBJECT" in (source, target):            # (its own frame: turned about z, scaled unevenly)
        plane.rotation_euler = (0.0, 0.0, 0.4 + 0.1 * index)
        plane.scale = (0.9, 0.7, 1.3)
    plane.data.materials.append(material)
    cases.append(label)


for kind in ("POINT", "VECTOR", "NORMAL"):
    case(kind, "WORLD", "CAMERA", (0.3, -0.5, 0.8))
    case(kind, "CAMERA", "WORLD", (0.2, 0.1, -0.6))
for kind in ("POINT", "VECTOR", "NORMAL"):
    for source, target in (("OBJECT", "WORLD"), ("WORLD", "OBJECT"), ("OBJECT", "CAMERA"), ("CAMERA", "OBJECT")):
        case(kind, source, target, (0.3, -0.5, 0.8))
warnings = render_plane_grid(scene, export, {columns}, len(cases) // {columns}, {pixels}, 4)
noted = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
primer.unregister()
report(cases=cases, warnings=warnings, noted=noted)
"""


def test_vector_transform_between_world_camera_and_object_space_is_cycles(tmp_path):
    """Points, vectors and normals taken between world, camera and object space (each object's own transform, turned
    and scaled unevenly): each plane's colour is Cycles' (its float32 transforms: within 2e-6; measured 1.8e-7),
    nothing noted."""
    result = run_bpy(SCRIPT.format(columns=COLUMNS, pixels=PIXELS), str(tmp_path))
    assert result["warnings"] == [] and result["noted"] == [], (result["warnings"], result["noted"])
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    worst = {}
    for index, label in enumerate(result["cases"]):
        row, column = divmod(index, COLUMNS)
        # (the cell's middle 4 x 4 pixels: a turned, scaled plane covers them, not its corners)
        block = (slice(row * PIXELS + 2, (row + 1) * PIXELS - 2), slice(column * PIXELS + 2, (column + 1) * PIXELS - 2))
        assert cycles[block].min() > 0.0 and cycles[block].max() > 0.05, label
        worst[label] = float(np.abs(primer[block] - cycles[block]).max())
    print(worst)
    assert max(worst.values()) < 2e-6, worst
