"""A world whose Environment Texture cannot be read, inside real Blender (the bpy module, no mocks), against Cycles:
Cycles shows and lights with its missing-image magenta (times the Background's Strength); Primer does the same and
says so once. The probe of issue 31 found a grey world (the viewport colour) and two contradicting warnings."""
from __future__ import annotations

import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy

pytestmark = [pytest.mark.blender, pytest.mark.slow]

SCRIPT = """
import os, sys
import bpy
import numpy as np
from blender_env import render_pixels, report
sys.path.insert(0, {tools!r})
from render import load_primer

primer = load_primer()
engine_module = sys.modules[primer.__name__ + ".addon.engine"]
corrupt = os.path.abspath("corrupt.hdr")
with open(corrupt, "wb") as handle:
    handle.write(b"#?RADIANCE\\nthis is not an image" * 10)
out = {{}}
for case, path in (("missing", os.path.abspath("no_such_sky.hdr")), ("corrupt", corrupt)):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 16, 12, 100
    world = bpy.data.worlds.new("World")
    scene.world = world
    if world.node_tree is None:
        world.use_nodes = True
    tree = world.node_tree
    background = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Strength"].default_value = 0.5
    texture = tree.nodes.new("ShaderNodeTexEnvironment")
    image = bpy.data.images.new("Sky", 4, 2)
    image.source, image.filepath = "FILE", path
    texture.image = image
    tree.links.new(texture.outputs["Color"], background.inputs["Color"])
    bpy.ops.mesh.primitive_plane_add(size=2.0)                # a grey plane lit by the world, seen from above
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -3.0, 2.0)
    camera.rotation_euler = (0.98, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    found = {{}}
    for engine, samples in (("PRIMER", 64), ("CYCLES", 256)):
        found[engine] = render_pixels(scene, engine, os.path.abspath(f"{{case}}_{{engine}}.exr"), samples,
                                      case)[..., :3].tolist()
    found["warnings"] = list(engine_module.last_render.warnings) if engine_module.last_render else []
    out[case] = found
primer.unregister()
report(**out)
"""


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    folder = tmp_path_factory.mktemp("missing_images")
    return run_bpy(SCRIPT.format(tools=os.path.join(ROOT, "tools")), str(folder))


@pytest.mark.parametrize("case", ["missing", "corrupt"])
def test_an_unreadable_environment_is_cycles_magenta_and_says_so_once(renders, case):
    """The sky is magenta x 0.5 where the camera sees it and lights the plane magenta, as in Cycles (block means), and
    one warning names the image."""
    from core.film.compare import relative_mse_of_blocks
    found = renders[case]
    mine, cycles = np.asarray(found["PRIMER"]), np.asarray(found["CYCLES"])
    error = relative_mse_of_blocks(mine, cycles)
    print(case, f"{error:.2e}", mine.mean(axis=(0, 1)), cycles.mean(axis=(0, 1)), found["warnings"])
    assert cycles[-1].mean(axis=0) == pytest.approx([0.5, 0.0, 0.5], abs=1e-3)      # the top row: sky
    assert error < 1e-3, error
    about_sky = [w for w in found["warnings"] if "Sky" in w or "world" in w.lower()]
    assert len(about_sky) == 1 and "magenta" in about_sky[0], found["warnings"]
