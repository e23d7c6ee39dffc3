"""The Ray Portal BSDF node inside real Blender (the bpy module, no mocks), against Cycles' own render: a sheet seen from
above, Mix(Fac 0.5, Diffuse, Ray Portal) whose Position is the hit's moved 30 along x (a Vector Math node), under a sun
and a grey world. Half the camera's rays are teleported 30 to the side, downwards as they were, through a second
portal (unlinked: straight on) to a diffuse floor under a ceiling glowing 2: the floor's light samples stop at that
portal, its bounce rays go through it to the ceiling, unweighed by MIS. Path tracing, 16 x 12 pixels, Primer 64
samples, Cycles 256; held to the project's measure (relative MSE of 4 x 4-pixel block means)."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from blender_env import ROOT, run_bpy
from one_process import RUNNER

pytestmark = pytest.mark.blender

PRIMER_SAMPLES, CYCLES_SAMPLES = 64, 256

SCRIPT = """
import math, os, sys
import bpy
import numpy as np
from blender_env import empty_material, fresh_scene, level_square, ortho_camera, render_pixels, report

primer, export, scene = fresh_scene(16, 12)
materials_ = sys.modules[primer.__name__ + ".addon.materials"]
scene.primer.integrator, scene.primer.max_bounces = "PATH", 2
world = bpy.data.worlds.new("World")
world.color = (0.3, 0.3, 0.3)
if world.node_tree is not None:
    background = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
scene.world = world


def quad(name, x, z, size, material):
    level_square(scene, name, x, z, size, material)


def diffuse(tree, color):
    node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (*color, 1.0)
    return node


sheet, tree, output = empty_material("Sheet")
mix, portal = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeBsdfRayPortal")
portal.inputs["Color"].default_value = (1.0, 0.8, 0.6, 1.0)
geometry, add = tree.nodes.new("ShaderNodeNewGeometry"), tree.nodes.new("ShaderNodeVectorMath")
add.operation = "ADD"
add.inputs[1].default_value = (30.0, 0.0, 0.0)
tree.links.new(geometry.outputs["Position"], add.inputs[0])
tree.links.new(add.outputs["Vector"], portal.inputs["Position"])
tree.links.new(diffuse(tree, (0.8, 0.8, 0.8)).outputs[0], mix.inputs[1])
tree.links.new(portal.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], output.inputs["Surface"])
quad("Sheet", 0.0, 0.0, 20.0, sheet)
clear, tree, output = empty_material("Clear portal")
tree.links.new(tree.nodes.new("ShaderNodeBsdfRayPortal").outputs[0], output.inputs["Surface"])
quad("Clear portal", 30.0, -0.5, 30.0, clear)
floor, tree, output = empty_material("Floor")
tree.links.new(diffuse(tree, (0.5, 0.6, 0.7)).outputs[0], output.inputs["Surface"])
quad("Floor", 30.0, -1.0, 20.0, floor)
glow, tree, output = empty_material("Ceiling")
emission = tree.nodes.new("ShaderNodeEmission")
emission.inputs["Strength"].default_value = 2.0
tree.links.new(emission.outputs[0], output.inputs["Surface"])
quad("Ceiling", 30.0, 2.0, 20.0, glow)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy, sun.data.angle = 3.0, 0.0
sun.rotation_euler = (0.3, 0.2, 0.0)
scene.collection.objects.link(sun)
ortho_camera(scene, 4.0)
warnings = []
nodes = [entry[0] for m in (sheet, clear) for entry in materials_.export_material(m, warnings).nodes]
primer_rgb = render_pixels(scene, "PRIMER", os.path.abspath("primer.exr"), {primer_samples})[..., :3]
cycles_rgb = render_pixels(scene, "CYCLES", os.path.abspath("cycles.exr"), {cycles_samples})[..., :3]
np.save("primer.npy", primer_rgb)
np.save("cycles.npy", cycles_rgb)
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(nodes=nodes, warnings=[str(w) for w in warnings])
"""


@pytest.mark.slow
def test_a_ray_portal_renders_as_in_cycles(results):
    """The nodes read as Diffuse + Ray Portal and one Ray Portal, with no warning; Primer's image against Cycles':
    block relative MSE below 2e-3 (measured: see docs/blender.md) and mean within 3%."""
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import node_table
    report, folder = results
    report = report["portal"]
    assert report["warnings"] == []
    assert report["nodes"] == ["DIFFUSE", "RAY_PORTAL", "RAY_PORTAL"]
    primer, cycles = np.load(folder / "portal" / "primer.npy"), np.load(folder / "portal" / "cycles.npy")
    relmse, ratio = node_table.block_measure(primer, cycles)
    print(f"relMSE {relmse:.3g}, mean ratio {ratio:.4f}, Cycles mean {cycles.mean(axis=(0, 1))}")
    assert relmse < 2e-3 and abs(ratio - 1.0) < 0.03


# A sunlit diffuse floor seen through a pane of Ray Portal (straight on) alone, or mixed half and half with a
# Transparent BSDF: the pixels' mean in Primer and in Cycles, for each pane. bpy's Python.
SHADOWS = """
import math, os, sys
import bpy
import numpy as np
from blender_env import empty_material, fresh_scene, ortho_camera, render_pixels, report

primer, export, scene = fresh_scene(8, 8)


def quad(name, z, material):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-10, -10, z), (10, -10, z), (10, 10, z), (-10, 10, z)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new(name, mesh))


floor, tree, output = empty_material("Floor")
diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
diffuse.inputs["Color"].default_value = (0.6, 0.6, 0.6, 1.0)
tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
quad("Floor", 0.0, floor)
pane, tree, output = empty_material("Pane")
mix = tree.nodes.new("ShaderNodeMixShader")
tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
tree.links.new(tree.nodes.new("ShaderNodeBsdfRayPortal").outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], output.inputs["Surface"])
quad("Pane", 2.0, pane)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy, sun.data.angle = 3.0, 0.0
sun.rotation_euler = (math.radians(30.0), 0.0, 0.0)
scene.collection.objects.link(sun)
ortho_camera(scene, 4.0)
means = {{}}
for fac in (1.0, 0.5):
    mix.inputs["Fac"].default_value = fac
    for engine in ("PRIMER", "CYCLES"):
        rgb = render_pixels(scene, engine, os.path.abspath(f"{{engine}}{{fac}}.exr"), 16)[..., :3]
        means[f"{{engine}} {{fac}}"] = float(rgb.mean())
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(means=means, version=list(bpy.app.version))
"""


def test_shadow_rays_stop_at_a_ray_portal_but_not_at_one_mixed_with_a_transparent_bsdf_as_in_cycles(results):
    """A floor (0.6) under a sun of 3 at 30 degrees, seen through a pane: a Ray Portal pane lets the camera through and
    stops the sun (0, in Primer and Cycles); Mix(Fac 0.5, Transparent, Ray Portal) lets the sun through whole, in
    both (Cycles' shadow rays set up no portal closure and count its weight as transparent): 0.6 x 3 cos 30 / pi."""
    report = results[0]["shadows"]
    means, bpy_version = report["means"], tuple(report["version"])
    lit = 0.6 * 3.0 * np.cos(np.radians(30.0)) / np.pi
    for engine in ("PRIMER", "CYCLES"):
        assert abs(means[f"{engine} 1.0"]) < 1e-6, means
    assert means["PRIMER 0.5"] == pytest.approx(lit, rel=1e-4), means
    # Cycles 5.0 gives the closed form to 1e-4; Cycles 5.2 0.1 % less (0.49571 against 0.49620, not explained yet),
    # still the whole sun and not the half an opaque portal would leave.
    assert means["CYCLES 0.5"] == pytest.approx(lit, rel=1e-4 if bpy_version < (5, 1) else 2e-3), means


# Portal Depth, as Cycles counts it: a Ray Portal pane over the origin sends the camera rays on from 30 along x and
# 1.5 lower, downwards, onto a floor emitting 2 x Portal Depth + Transparent Depth (Math nodes) and lit straight down
# by a sun of 3 through a screen high above it that lets 0.5 x Portal Depth through (a Transparent BSDF: what the
# floor's shadow rays read). The pixels' mean and spread in Primer and in Cycles. bpy's Python.
PORTAL_DEPTH = """
import math, os, sys
import bpy
import numpy as np
from blender_env import empty_material, fresh_scene, level_square, ortho_camera, render_pixels, report

primer, export, scene = fresh_scene(8, 8)
materials_ = sys.modules[primer.__name__ + ".addon.materials"]


def quad(name, x, z, size, material):
    level_square(scene, name, x, z, size, material)


def math_node(tree, operation, a, b, c=0.0):
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = operation
    for k, value in enumerate((a, b, c)):
        if isinstance(value, float):
            node.inputs[k].default_value = value
        else:
            tree.links.new(value, node.inputs[k])
    return node.outputs[0]


pane, tree, output = empty_material("Pane")
portal = tree.nodes.new("ShaderNodeBsdfRayPortal")
geometry, add = tree.nodes.new("ShaderNodeNewGeometry"), tree.nodes.new("ShaderNodeVectorMath")
add.operation = "ADD"
add.inputs[1].default_value = (30.0, 0.0, -1.5)
tree.links.new(geometry.outputs["Position"], add.inputs[0])
tree.links.new(add.outputs["Vector"], portal.inputs["Position"])
tree.links.new(portal.outputs[0], output.inputs["Surface"])
quad("Pane", 0.0, 2.0, 20.0, pane)
floor, tree, output = empty_material("Floor")
path = tree.nodes.new("ShaderNodeLightPath")
emission, diffuse, both = (tree.nodes.new(kind) for kind in ("ShaderNodeEmission", "ShaderNodeBsdfDiffuse",
                                                              "ShaderNodeAddShader"))
diffuse.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
tree.links.new(math_node(tree, "MULTIPLY_ADD", path.outputs["Portal Depth"], 2.0, path.outputs["Transparent Depth"]),
               emission.inputs["Strength"])
tree.links.new(emission.outputs[0], both.inputs[0])
tree.links.new(diffuse.outputs[0], both.inputs[1])
tree.links.new(both.outputs[0], output.inputs["Surface"])
floor.cycles.emission_sampling = "NONE"       # (not a light: the sun, alone, is sampled without noise)
quad("Floor", 30.0, 0.0, 20.0, floor)
screen, tree, output = empty_material("Screen")
path, clear = tree.nodes.new("ShaderNodeLightPath"), tree.nodes.new("ShaderNodeBsdfTransparent")
tree.links.new(math_node(tree, "MULTIPLY", path.outputs["Portal Depth"], 0.5), clear.inputs["Color"])
tree.links.new(clear.outputs[0], output.inputs["Surface"])
# (its diagonal off the pixel centres: Cycles' shadow ray straight up through a centre on the two triangles' shared
#  edge meets both, and passes the screen twice)
quad("Screen", 30.3, 3.0, 20.0, screen)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy, sun.data.angle = 3.0, 0.0
scene.collection.objects.link(sun)
ortho_camera(scene, 4.0)
warnings = []
for m in (pane, floor, screen):
    materials_.export_material(m, warnings)
pixels = {{}}
for engine in ("PRIMER", "CYCLES"):
    rgb = render_pixels(scene, engine, os.path.abspath(f"{{engine}}.exr"), 4)[..., :3]
    pixels[engine] = [float(rgb.mean()), float(rgb.min()), float(rgb.max())]
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(warnings=[str(w) for w in warnings], pixels=pixels)
"""


def test_the_light_path_nodes_portal_depth_counts_ray_portal_bounces_as_in_cycles(results):
    """Read with no warning; every pixel in Primer and in Cycles is the closed form: the floor's emission 2 x 1 + 1
    (one portal, which is one transparent bounce too) plus its diffuse 0.5 / pi under the sun of 3 that the screen
    lets 0.5 through for shadow rays of Portal Depth 1: 3 + 0.75 / pi."""
    report = results[0]["depth"]
    assert report["warnings"] == [], report["warnings"]
    expected = 3.0 + 0.75 / np.pi
    for engine, (mean, low, high) in report["pixels"].items():
        print(engine, mean, low, high)
        assert low == pytest.approx(expected, rel=1e-5) and high == pytest.approx(expected, rel=1e-5), report["pixels"]


# The three scripts above run one after the other in one Blender process (one start for the file's tests).
@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """The three scripts' reports, from one Blender process: ({"portal": ..., "shadows": ..., "depth": ...}, the folder
    holding each script's folder of files)."""
    folder = tmp_path_factory.mktemp("ray_portal")
    sources = {"portal": SCRIPT.format(primer_samples=PRIMER_SAMPLES, cycles_samples=CYCLES_SAMPLES),
               "shadows": SHADOWS.format(), "depth": PORTAL_DEPTH.format()}
    return run_bpy(RUNNER.format(sources=sources), str(folder))["results"], folder
