"""The classic OBJ Cornell box's lamp inside real Blender (the bpy module, no mocks): its MTL gives it a diffuse
colour (Kd 0.78) besides its emission (Ke), so the OBJ importer makes it a Principled BSDF that both reflects and
emits. Seen from behind, nothing lights it but itself, which it cannot: Primer and Cycles show its emission alone,
path traced (issue 34: Primer lit its back by its own light samples, and the box was 3-5 % too bright)."""
from __future__ import annotations

import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy

pytestmark = pytest.mark.blender

# The lamp of Morgan McGuire's CornellBox-Original.obj / .mtl (public domain, Williams College 2011), facing down.
OBJ = """mtllib lamp.mtl
v -0.24 1.98 0.16
v -0.24 1.98 -0.22
v 0.23 1.98 -0.22
v 0.23 1.98 0.16
g light
usemtl light
f -4 -3 -2 -1
"""
MTL = """newmtl light
  Ns 10.0000
  Ni 1.0000
  illum 2
  Ka 0.78 0.78 0.78
  Kd 0.78 0.78 0.78
  Ks 0 0 0
  Ke 17 12 4
"""

SCRIPT = """
import os, sys
import bpy
import numpy as np
from blender_env import render_pixels, report
sys.path.insert(0, {tools!r})
from render import load_primer

primer = load_primer()
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.obj_import(filepath=os.path.abspath("lamp.obj"))
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 8, 8, 100
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.data.type, camera.data.ortho_scale = "ORTHO", 0.3
camera.location = (0.0, 0.03, 3.0)                 # above the lamp, looking down at its back
scene.collection.objects.link(camera)
scene.camera = camera
scene.primer.integrator, scene.primer.max_bounces = "PATH", 1
bsdf = next(n for m in bpy.data.materials for n in m.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
colour = list(bsdf.inputs["Base Color"].default_value)[:3]
emission = [c * bsdf.inputs["Emission Strength"].default_value for c in bsdf.inputs["Emission Color"].default_value[:3]]
pixels = {{engine: render_pixels(scene, engine, os.path.abspath(engine + ".exr"), 16)[..., :3].reshape(-1, 3).tolist()
          for engine in ("PRIMER", "CYCLES")}}
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(colour=colour, emission=emission, primer=pixels["PRIMER"], cycles=pixels["CYCLES"])
"""


def test_the_obj_cornell_lamp_seen_from_behind_shows_its_emission_alone_as_in_cycles(tmp_path):
    """The importer's Principled BSDF reflects (base colour 0.78) and emits (17, 12, 4); seen from behind with Max
    Bounces 1, every pixel is the emission alone, in Cycles and in Primer (whose pixels were up to 1.64 x it)."""
    (tmp_path / "lamp.obj").write_text(OBJ)
    (tmp_path / "lamp.mtl").write_text(MTL)
    result = run_bpy(SCRIPT.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    np.testing.assert_allclose(result["colour"], 0.78, rtol=1e-6)
    emission = np.array(result["emission"])
    np.testing.assert_allclose(emission, [17.0, 12.0, 4.0], rtol=1e-6)
    np.testing.assert_allclose(result["cycles"], np.broadcast_to(emission, (64, 3)), rtol=1e-5)
    np.testing.assert_allclose(result["primer"], result["cycles"], rtol=1e-5)
