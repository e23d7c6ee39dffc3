"""Cycles' Sky Texture in a world (core/materials/sky.py, core/lights/world_graph.py sky_suns) against Cycles 5.0's
render: each model (Multiple Scattering, Single Scattering, Preetham) seen by a small equirectangular camera (the sun
disc off: Primer's sun lamp is not seen by camera rays) and lighting a Lambert floor with its sun (direct light, 64
samples), the sun at 15 and 60 degrees.
"""
from __future__ import annotations

import importlib.util
import os

import pytest

from blender_env import run_bpy

from core.film.compare import relative_mse_of_blocks

pytestmark = pytest.mark.blender

if importlib.util.find_spec("bpy") is None:
    if os.environ.get("PRIMER_ALLOW_NO_BPY"):
        pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
    raise ImportError("tests/test_blender_sky.py needs bpy (Blender as a Python module): pip install bpy")

SCRIPT = """
import sys, os, math
import bpy
import numpy as np
from blender_env import report, render_pixels, diffuse_material, primer_in_blender
primer, export = primer_in_blender()
exports = []
export_scene = export.export_scene


def recording(*args, **kwargs):
    # Keep what Primer's render exported (its warnings and lights), rather than export the scene a second time.
    exported = export_scene(*args, **kwargs)
    exports.append(exported)
    return exported


export.export_scene = recording
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
world = bpy.data.worlds.new("Sky")
scene.world = world
world.use_nodes = True
tree = world.node_tree
background = tree.nodes["Background"]
sky = tree.nodes.new("ShaderNodeTexSky")
tree.links.new(sky.outputs["Color"], background.inputs["Color"])
background.inputs["Strength"].default_value = 0.5
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
bpy.ops.mesh.primitive_plane_add(size=8.0)
floor = bpy.context.view_layer.objects.active
floor.data.materials.append(diffuse_material(albedo=(0.5, 0.5, 0.5)))


def view(panorama):
    floor.visible_camera = not panorama
    if panorama:
        camera.data.type, camera.data.panorama_type = "PANO", "EQUIRECTANGULAR"
        camera.location, camera.rotation_euler = (0.0, 0.0, 0.0), (np.pi / 2, 0.0, 0.0)
        scene.render.resolution_x, scene.render.resolution_y = 64, 32
    else:
        camera.data.type = "PERSP"
        camera.location, camera.rotation_euler = (0.0, -6.0, 1.0), (np.radians(80.0), 0.0, 0.0)
        scene.render.resolution_x, scene.render.resolution_y = 48, 32


def render(name, kind, elevation, disc, panorama):
    sky.sky_type = kind
    sky.sun_elevation, sky.sun_rotation, sky.sun_disc = math.radians(elevation), math.radians(-130.0), disc
    sky.sun_direction = (0.5, -0.4, math.sin(math.radians(elevation)))
    view(panorama)
    for engine in ("PRIMER", "CYCLES"):
        np.save(f"{{name}}_{{engine.lower()}}.npy", render_pixels(scene, engine, os.path.abspath("out.exr"), 64)[..., :3])
    exported = exports[-1]
    return {{"warnings": exported.warnings, "lights": [light.name for light in exported.scene.lights]}}


results = {{}}
for name, kind, elevation, disc, panorama in {cases!r}:
    results[name] = render(name, kind, elevation, disc, panorama)
# Hosek / Wilkie (no dataset in Primer), and a Sky Texture in a surface material: exported only, for their notes.
sky.sky_type = "HOSEK_WILKIE"
results["hosek"] = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
material = floor.data.materials[0]
surface = material.node_tree.nodes.new("ShaderNodeTexSky")
diffuse = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
material.node_tree.links.new(surface.outputs["Color"], diffuse.inputs["Color"])
results["surface"] = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
primer.unregister()
report(results=results)
"""

# (name, sky type, sun elevation in degrees, sun disc, seen by the equirectangular camera (else: lighting the floor))
CASES = [
    ("multiple_15_seen", "MULTIPLE_SCATTERING", 15.0, False, True),
    ("multiple_15_lit", "MULTIPLE_SCATTERING", 15.0, True, False),
    ("multiple_60_lit", "MULTIPLE_SCATTERING", 60.0, True, False),
    ("single_15_seen", "SINGLE_SCATTERING", 15.0, False, True),
    ("single_60_lit", "SINGLE_SCATTERING", 60.0, True, False),
    ("preetham_60_seen", "PREETHAM", 60.0, False, True),
    ("preetham_15_lit", "PREETHAM", 15.0, False, False),
]


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Every case rendered by Primer and Cycles (64 samples): (report, folder)."""
    folder = tmp_path_factory.mktemp("sky")
    return run_bpy(SCRIPT.format(cases=CASES), str(folder)), folder


@pytest.mark.parametrize("name", [case[0] for case in CASES])
def test_a_sky_texture_renders_as_cycles_seen_and_lighting_a_floor_with_its_sun(rendered, name):
    """The sky's radiance (seen) and its light on a Lambert floor, sky and sun disc (lit), within noise of Cycles'
    image, with nothing noted about the world; the sun's lamp there exactly where the disc is on."""
    import numpy as np
    result, folder = rendered
    case = next(c for c in CASES if c[0] == name)
    primer, cycles = np.load(folder / f"{name}_primer.npy"), np.load(folder / f"{name}_cycles.npy")
    error = relative_mse_of_blocks(primer, cycles)
    print(name, "block relMSE", error, "mean ratio", primer.mean() / cycles.mean())
    assert cycles.mean() > 0.01
    assert error < 2e-4, error
    assert abs(primer.mean() / cycles.mean() - 1.0) < 0.01
    warnings = [w for w in result["results"][name]["warnings"] if "world" in w or "Sky" in w]
    assert warnings == [], warnings
    suns = [light for light in result["results"][name]["lights"] if "Sky Texture" in light]
    assert len(suns) == (1 if case[3] and case[1] != "PREETHAM" else 0), suns


def test_a_sky_primer_cannot_evaluate_is_noted(rendered):
    """Hosek / Wilkie (its fitted dataset is not in Primer) and a Sky Texture in a surface material (evaluated in
    world shaders only) are each noted, naming the node."""
    result, _ = rendered
    assert any("HOSEK_WILKIE" in w and "Sky Texture" in w for w in result["results"]["hosek"]), result["results"]["hosek"]
    assert any("world shaders only" in w and "Sky Texture" in w for w in result["results"]["surface"]), \
        result["results"]["surface"]
