"""The Holdout shader node inside real Blender (the bpy module, no mocks), against Cycles' own render: light_point's
sphere with its material mixed 50/50 with a Holdout (Mix Shader, Fac 0.5), on a transparent film and an opaque one,
direct light only as tools/render.py sets Cycles up. The sphere is half a hole (alpha 0.5, half its light), its
shadow stays whole; Primer's Combined RGBA is held to the project's measure (relative MSE of 4x4-pixel block means)
and to the alpha RMSE of tests/test_blender_scenes.py."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy
import cycles_references
from test_blender_scenes import SCENES_DIR, compare, reference_cache  # noqa: F401 (reference_cache: a fixture)

pytestmark = pytest.mark.blender

# Primer's error against Cycles' at these sample counts (light_point's own, tests/test_blender_scenes.py).
PRIMER_SAMPLES, CYCLES_SAMPLES = 64, 256
BLOCK_TOLERANCE = 1e-4

# Open light_point, put Mix(Fac, its shader, Holdout) at the sphere's Material Output, set the film, save. bpy's Python.
MAKE_SCENE = """
import bpy
from blender_env import report
source, target, fac, transparent = {source!r}, {target!r}, {fac!r}, {transparent!r}
bpy.ops.wm.open_mainfile(filepath=source)
material = bpy.data.objects["Sphere"].active_material
tree = material.node_tree
output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output)
shader = output.inputs["Surface"].links[0].from_socket
mix, holdout = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeHoldout")
mix.inputs["Fac"].default_value = fac
tree.links.new(shader, mix.inputs[1])
tree.links.new(holdout.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], output.inputs["Surface"])
bpy.context.scene.render.film_transparent = transparent
bpy.ops.wm.save_as_mainfile(filepath=target, compress=True)
report(shader=shader.node.bl_idname)
"""

# The addon's reading of Mix(Fac f, Diffuse, Holdout): its shader nodes and warnings. bpy's Python.
EXPORT = """
import sys
import bpy
from blender_env import empty_material, report
sys.path.insert(0, {tools!r})
from render import load_primer
primer = load_primer()
materials_ = sys.modules[primer.__name__ + ".addon.materials"]
bpy.ops.wm.read_factory_settings(use_empty=True)
m, tree, output = empty_material("Held")
mix, diffuse, holdout = (tree.nodes.new(kind) for kind in ("ShaderNodeMixShader", "ShaderNodeBsdfDiffuse",
                                                             "ShaderNodeHoldout"))
mix.inputs["Fac"].default_value = {fac!r}
diffuse.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
tree.links.new(diffuse.outputs[0], mix.inputs[1])
tree.links.new(holdout.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], output.inputs["Surface"])
warnings = []
nodes = materials_.export_material(m, warnings).nodes
report(nodes=[[entry[0], list(map(float, entry[1]))] for entry in nodes], warnings=[str(w) for w in warnings])
"""


def test_a_holdout_node_is_read_with_its_mix_weight_and_no_warning(tmp_path):
    """Mix(Fac 0.3, Diffuse of 0.5 grey, Holdout) reads as a Diffuse of weight 0.7 x 0.5 and a Holdout of weight
    0.3 (the Mix factor; the node's own Weight input is hidden), with no warning."""
    report = run_bpy(EXPORT.format(tools=os.path.join(ROOT, "tools"), fac=0.3), str(tmp_path))
    assert report["warnings"] == []
    names = [name for name, _ in report["nodes"]]
    assert names == ["DIFFUSE", "HOLDOUT"]
    np.testing.assert_allclose(report["nodes"][0][1], [0.35] * 3, rtol=1e-6)
    np.testing.assert_allclose(report["nodes"][1][1], [0.3] * 3, rtol=1e-6)


def holdout_scene(transparent_film: bool, folder: str) -> tuple:
    """Write light_point with its sphere half held out into `folder`; return (Cycles reference id, .blend path, the
    inputs that make it, for the reference's key). tools/make_references.py renders the same reference."""
    source = os.path.join(SCENES_DIR, "light_point.blend")
    blend = os.path.join(folder, "holdout_node.blend")
    run_bpy(MAKE_SCENE.format(source=source, target=blend, fac=0.5, transparent=transparent_film), folder)
    inputs = (source, json.dumps({"sphere": "Mix(0.5, shader, Holdout)", "film_transparent": transparent_film}),
              MAKE_SCENE)
    return f"holdout_node-{'transparent' if transparent_film else 'opaque'}_film", blend, inputs


@pytest.mark.slow
@pytest.mark.parametrize("transparent_film", [True, False], ids=["transparent_film", "opaque_film"])
def test_a_sphere_half_held_out_is_half_a_hole_as_in_cycles(transparent_film, reference_cache, tmp_path):
    """light_point's sphere as Mix(Fac 0.5, its Principled BSDF, Holdout): Primer's RGBA against Cycles'."""
    ref_id, blend, inputs = holdout_scene(transparent_film, str(tmp_path))
    applied, = cycles_references.applied_settings([(blend, CYCLES_SAMPLES)], str(tmp_path))
    compare(ref_id, blend, inputs, applied, PRIMER_SAMPLES, CYCLES_SAMPLES, reference_cache, str(tmp_path),
            block_tolerance=BLOCK_TOLERANCE)
