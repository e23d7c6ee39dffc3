"""The Vector Transform node between world and camera space (core/materials/graph.py `Compiler.vector_transform`)
against Cycles' render: points, vectors and normals, each the colour (its components' absolute values) of an
emitting plane seen from above; object space is noted."""
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
    bpy.context.view_layer.objects.active.data.materials.append(material)
    cases.append(label)


for kind in ("POINT", "VECTOR", "NORMAL"):
    case(kind, "WORLD", "CAMERA", (0.3, -0.5, 0.8))
    case(kind, "CAMERA", "WORLD", (0.2, 0.1, -0.6))
warnings = render_plane_grid(scene, export, {columns}, 1, {pixels}, 4)
case("VECTOR", "OBJECT", "WORLD", (0.2, 0.1, -0.6))
noted = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
primer.unregister()
report(cases=cases, warnings=warnings, noted=noted)
"""


def test_vector_transform_between_world_and_camera_is_cycles(tmp_path):
    """Points, vectors and normals taken from world to camera space and back: each plane's colour is Cycles' (its
    float32 transforms: within 1e-6), nothing noted; a transform from object space is noted."""
    result = run_bpy(SCRIPT.format(columns=COLUMNS, pixels=PIXELS), str(tmp_path))
    assert result["warnings"] == []
    assert any("Object space" in w for w in result["noted"]), result["noted"]
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    for index, label in enumerate(result["cases"][:COLUMNS]):
        block = (slice(0, PIXELS), slice(index * PIXELS, (index + 1) * PIXELS))
        assert cycles[block].max() > 0.05, label
        assert np.abs(primer[block] - cycles[block]).max() < 1e-6, (label, primer[block][0, 0], cycles[block][0, 0])
