"""Cycles' Sky Texture (core/materials/sky.py, core/materials/sky.c, core/lights/world_graph.py sky_suns) against
Cycles 5.0's render: in a world, each model (Multiple Scattering, Single Scattering, Preetham, Hosek / Wilkie) seen by
a small equirectangular camera (the sun disc off; tests/test_blender_sky_disc.py looks at the disc) and lighting a
Lambert floor with its sun (direct light, 64 samples), the sun at 15 and 60 degrees; on surfaces, each model as an
emitting plane's colour at the plane's Generated coordinates (the Vector socket is unavailable in Blender 5.0), with and
without the sun disc, which a surface's Sky Texture draws itself.
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
    sky.turbidity, sky.ground_albedo = 3.3, 0.45
    sky.sun_elevation, sky.sun_rotation, sky.sun_disc = math.radians(elevation), math.radians(-130.0), disc
    sky.sun_direction = (0.5, -0.4, math.sin(math.radians(elevation)))
    view(panorama)
    for engine in ("PRIMER", "CYCLES"):
        np.save(f"{{name}}_{{engine.lower()}}.npy", render_pixels(scene, engine, os.path.abspath("out.exr"), 64, name)[..., :3])
    exported = exports[-1]
    return {{"warnings": exported.warnings, "lights": [light.name for light in exported.scene.lights]}}


results = {{}}
for name, kind, elevation, disc, panorama in {cases!r}:
    results[name] = render(name, kind, elevation, disc, panorama)
# A Sky Texture on surfaces: each model as an emitting plane's colour at its Generated coordinates (u, v, 0.5 on a
# flat plane: directions not normalised, as Cycles reads them), the sun at 30 degrees and rotation 45 (towards
# (0.61, 0.61, 0.5), a point of the plane) with a 10 degree disc, and without it.
from blender_env import empty_material, render_plane_grid
scene.world = None
floor.hide_render = True
surfaces = []
for kind, disc, mapped in (("MULTIPLE_SCATTERING", True, False), ("MULTIPLE_SCATTERING", False, False),
                           ("SINGLE_SCATTERING", True, False), ("SINGLE_SCATTERING", False, False),
                           ("PREETHAM", False, False), ("HOSEK_WILKIE", False, False), ("HOSEK_WILKIE", False, True)):
    label = f"{{kind}} {{'mapped ' if mapped else ''}}{{'disc' if disc else 'sky'}}"
    material, tree, out = empty_material(label)
    node = tree.nodes.new("ShaderNodeTexSky")
    node.sky_type, node.sun_disc, node.sun_size = kind, disc, math.radians(10.0)
    node.sun_elevation, node.sun_rotation = math.radians(30.0), math.radians(45.0)
    node.sun_direction, node.turbidity, node.ground_albedo = (0.6, 0.6, 0.5), 4.5, 0.7
    if mapped:                                      # the node's own Texture Mapping turns the direction
        node.texture_mapping.rotation, node.texture_mapping.scale = (0.2, -0.3, 0.5), (1.0, 0.8, 1.2)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 0.5
    tree.links.new(node.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    index = len(surfaces)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(index % 3 + 0.5, -(index // 3) - 0.5, 0.0))
    plane = bpy.context.view_layer.objects.active
    plane.name = label
    plane.data.materials.append(material)
    surfaces.append(label)
results["surface"] = render_plane_grid(scene, export, 3, 3, {pixels}, {surface_samples}, "surfaces")
results["surfaces"] = surfaces
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
    ("hosek_60_seen", "HOSEK_WILKIE", 60.0, False, True),
    ("hosek_15_lit", "HOSEK_WILKIE", 15.0, False, False),
]
PIXELS = 32                 # pixels across each surface's plane
SURFACE_SAMPLES = 16


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Every case rendered by Primer and Cycles (64 samples): (report, folder)."""
    folder = tmp_path_factory.mktemp("sky")
    return run_bpy(SCRIPT.format(cases=CASES, pixels=PIXELS, surface_samples=SURFACE_SAMPLES), str(folder)), folder


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
    assert len(suns) == (1 if case[3] and case[1].endswith("SCATTERING") else 0), suns


def test_a_sky_texture_on_a_surface_renders_as_cycles_with_its_sun_disc(rendered):
    """Each model as an emitting plane's colour (16 samples a pixel, a colour that varies across each pixel), nothing
    noted: the sky within the noise of where the two renderers put a pixel's samples (block relMSE, its mean within
    1%); with the sun's disc (some 6 pixels across, several hundred times as bright as the sky), the sky off the
    disc and its rim as well, the disc's pixels inside its rim within 2% of Cycles' (its limb darkening varies
    across a pixel as steeply as the sky does at the zenith) and its centre within 0.2% (a rim pixel's value is the
    share of its samples that fall on the disc, which differs with the renderers' sample positions)."""
    import numpy as np
    result, folder = rendered
    assert result["results"]["surface"] == [], result["results"]["surface"]
    primer, cycles = np.load(folder / "primer.npy"), np.load(folder / "cycles.npy")
    for index, label in enumerate(result["results"]["surfaces"]):
        row, column = divmod(index, 3)
        block = (slice(row * PIXELS, (row + 1) * PIXELS), slice(column * PIXELS, (column + 1) * PIXELS))
        ours, theirs = primer[block], cycles[block]
        assert theirs.mean() > 0.01 and theirs.std() > 0.0
        disc = theirs[..., 1] > 50.0 * np.median(theirs[..., 1])
        padded = np.pad(disc, 1, mode="edge")
        around = [padded[1 + dy:1 + dy + PIXELS, 1 + dx:1 + dx + PIXELS] for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
        rim = np.any(around, axis=0) & ~np.all(around, axis=0)
        error = relative_mse_of_blocks(np.where((disc | rim)[..., None], theirs, ours), theirs)
        relative = np.abs(ours - theirs).max(axis=2) / theirs.max(axis=2)
        print(label, "sky block relMSE", error, "mean ratio", ours.mean() / theirs.mean(), "disc pixels",
              int(disc.sum()), "rim", int(rim.sum()), "largest difference inside the rim",
              relative[disc & ~rim].max(initial=0.0), "at the centre", relative.ravel()[theirs[..., 1].argmax()])
        assert error < 2e-4, (label, error)
        if label.endswith("sky"):
            assert not disc.any() and abs(ours.mean() / theirs.mean() - 1.0) < 0.01, label
        else:
            assert (disc & ~rim).sum() >= 9 and relative[disc & ~rim].max() < 0.02, label
            assert relative.ravel()[theirs[..., 1].argmax()] < 2e-3, label
