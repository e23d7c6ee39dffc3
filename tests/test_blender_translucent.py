"""The Translucent BSDF node inside real Blender (the bpy module, no mocks), against Cycles' own render and the closed
form: a horizontal sheet with a Translucent BSDF, lit by a sun from below, seen from above (16 x 12 pixels, Primer 4
samples, Cycles 256). The node is read with
no code of its own (core/materials Node.blender) and renders with no integrator code of its own (its flags)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from blender_env import run_bpy

pytestmark = pytest.mark.blender

ALBEDO, STRENGTH, BELOW_DEG = (0.7, 0.5, 0.2), 3.0, 40.0

SCRIPT = """
import math, os, sys
import bpy
import numpy as np
from blender_env import empty_material, fresh_scene, ortho_camera, render_pixels, report

primer, export, scene = fresh_scene(16, 12)
materials_ = sys.modules[primer.__name__ + ".addon.materials"]
material, tree, output = empty_material("Sheet")
sheet_bsdf = tree.nodes.new("ShaderNodeBsdfTranslucent")
sheet_bsdf.inputs["Color"].default_value = (*{albedo!r}, 1.0)
tree.links.new(sheet_bsdf.outputs[0], output.inputs["Surface"])
mesh = bpy.data.meshes.new("Sheet")
mesh.from_pydata([(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], [], [(0, 1, 2, 3)])
mesh.materials.append(material)
scene.collection.objects.link(bpy.data.objects.new("Sheet", mesh))
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy, sun.data.angle = {strength!r}, 0.0
sun.rotation_euler = (0.0, math.radians(90.0 + {below!r}), 0.0)     # light travels up, {below!r} deg from level
scene.collection.objects.link(sun)
ortho_camera(scene, 4.0)
warnings = []
nodes = materials_.export_material(material, warnings).nodes


def render(engine, path):
    rgb = render_pixels(scene, engine, path, 256 if engine == "CYCLES" else 4)[..., :3].reshape(-1, 3)
    return rgb.mean(axis=0).tolist(), np.median(rgb, axis=0).tolist(), float(np.ptp(rgb, axis=0).max())


primer_mean, primer_median, primer_spread = render("PRIMER", os.path.abspath("primer.exr"))
cycles_mean, cycles_median, cycles_spread = render("CYCLES", os.path.abspath("cycles.exr"))
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(nodes=[[entry[0], list(map(float, entry[1]))] for entry in nodes], warnings=warnings, primer=primer_mean,
       primer_spread=primer_spread, cycles=cycles_mean, cycles_median=cycles_median)
"""


@pytest.mark.slow
def test_a_translucent_sheet_lit_from_behind_renders_as_in_cycles(tmp_path):
    """The node reads as one Translucent closure of its colour, with no warning; seen from above, the sheet glows
    with albedo / pi x S x sin(e) for a sun e below its plane, in Primer as in Cycles (both noiseless here: a delta
    sun, a flat sheet)."""
    report = run_bpy(SCRIPT.format(albedo=ALBEDO, strength=STRENGTH,
                                   below=BELOW_DEG), str(tmp_path))
    assert report["warnings"] == []
    assert [name for name, _ in report["nodes"]] == ["TRANSLUCENT"]
    np.testing.assert_allclose(report["nodes"][0][1], ALBEDO, rtol=1e-6)
    expected = np.array(ALBEDO) / math.pi * STRENGTH * math.sin(math.radians(BELOW_DEG))
    np.testing.assert_allclose(report["primer"], expected, rtol=1e-5)
    assert report["primer_spread"] < 1e-5
    # Cycles' pixels are the closed form but for one of their 256 samples, black, in a few pixels (measured: 12 of 192
    # pixels lose exactly 1/N of their light, at N = 16 as at 256: one degenerate sample, not a different model).
    np.testing.assert_allclose(report["cycles_median"], expected, rtol=1e-5)
    np.testing.assert_allclose(report["cycles"], expected, rtol=5e-4)
