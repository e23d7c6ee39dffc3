"""Object > Visibility > Shadow Catcher inside real Blender (the bpy module, no mocks), against Cycles' own render:
a catcher floor under a ball that is out of the frame, lit by two suns, direct light only (tools/render.py's Cycles
reference). The Shadow Catcher pass, and Combined with and without it, on a transparent film and an opaque one, read
from each renderer's multilayer EXR."""
from __future__ import annotations

import math

import numpy as np
import pytest

from blender_env import run_bpy

pytestmark = pytest.mark.blender

SLANT = math.radians(45.0)
E_SLANT, E_DOWN = 3.0, 1.0
PRIMER_SAMPLES, CYCLES_SAMPLES = 4, 64

# Build the scene, render it with Primer and Cycles in three setups, report every pass. bpy's Python.
SCRIPT = """
import math, os, sys
import bpy
import numpy as np
import OpenImageIO as oiio
from blender_env import ROOT, diffuse_material, empty_material, report
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import configure_cycles_reference, load_primer
primer = load_primer()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = {size[0]!r}, {size[1]!r}, 100
world = bpy.data.worlds.new("World")
scene.world = world
mesh = bpy.data.meshes.new("Floor")
mesh.from_pydata([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)], [], [(0, 1, 2, 3)])
floor = bpy.data.objects.new("Floor", mesh)
floor.data.materials.append(diffuse_material("Floor", (0.8, 0.8, 0.8)))
floor.is_shadow_catcher = True
scene.collection.objects.link(floor)
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.0, 0.0, 2.0))
bpy.context.object.data.materials.append(diffuse_material("Ball", (0.5, 0.5, 0.5)))
for name, energy, tilt in (("Slant", {e_slant!r}, {slant!r}), ("Down", {e_down!r}, 0.0)):
    sun = bpy.data.objects.new(name, bpy.data.lights.new(name, "SUN"))
    sun.data.energy, sun.data.angle = energy, 0.0
    sun.rotation_euler = (0.0, -tilt, 0.0)          # (light travelling towards +x, down)
    scene.collection.objects.link(sun)
pane_color = {pane!r}
if pane_color is not None:                          # a clear pane under the camera, hidden from shadow rays
    material, tree, output = empty_material("Pane")
    clear = tree.nodes.new("ShaderNodeBsdfTransparent")
    clear.inputs["Color"].default_value = (*pane_color, 1.0)
    tree.links.new(clear.outputs["BSDF"], output.inputs["Surface"])
    mesh = bpy.data.meshes.new("Pane")
    mesh.from_pydata([(0, -2, 2.75), (4, -2, 2.75), (4, 2, 2.75), (0, 2, 2.75)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    pane = bpy.data.objects.new("Pane", mesh)
    pane.visible_shadow = False
    scene.collection.objects.link(pane)
fog = {fog!r}
if fog is not None:                                 # a volume-only box of absorbing, glowing fog around it all
    density, color, strength = fog
    material, tree, output = empty_material("Fog")
    absorb = tree.nodes.new("ShaderNodeVolumeAbsorption")
    absorb.inputs["Density"].default_value = density
    absorb.inputs["Color"].default_value = (*color, 1.0)
    glow = tree.nodes.new("ShaderNodeEmission")
    glow.inputs["Strength"].default_value = strength
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(absorb.outputs["Volume"], add.inputs[0])
    tree.links.new(glow.outputs["Emission"], add.inputs[1])
    tree.links.new(add.outputs["Shader"], output.inputs["Volume"])
    middle, height, catcher = {fog_box!r}
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, middle), scale=(40.0, 40.0, height))
    bpy.context.object.data.materials.append(material)
    bpy.context.object.is_shadow_catcher = catcher
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.location = (2.0, 0.0, 3.0)
scene.collection.objects.link(camera)
scene.camera = camera


def passes(path):
    inp = oiio.ImageInput.open(path)
    found, index = {{}}, 0
    while inp.seek_subimage(index, 0):
        spec = inp.spec()
        pixels = np.asarray(inp.read_image(index, 0, 0, spec.nchannels, "float")).reshape(spec.height, spec.width, -1)
        for k, name in enumerate(spec.channelnames):
            layer, _, channel = name.rpartition(".")
            found.setdefault(layer.split(".")[-1], {{}})[channel] = pixels[..., k].tolist()
        index += 1
    inp.close()
    return found


def render(engine, tag):
    path = os.path.abspath(tag + "_" + engine + ".exr")
    if engine == "CYCLES":
        configure_cycles_reference(scene, {cycles_samples!r})
    else:
        scene.render.engine = "PRIMER"
        scene.primer.samples = {primer_samples!r}
    scene.render.filepath, scene.render.use_file_extension = path, False
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    settings = scene.render.image_settings          # (every pass: Blender 5.0 a media type, 4.2 a file format)
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE"
    else:
        settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    bpy.ops.render.render(write_still=True)
    return passes(path)


setups = {{"pass": (True, True, 0.0), "transparent": (False, True, 0.0), "opaque": (False, False, 0.25)}}
out = {{}}
for tag, (with_pass, transparent, grey) in setups.items():
    if tag not in {tags!r}:
        continue
    scene.view_layers[0].cycles.use_pass_shadow_catcher = with_pass
    scene.render.film_transparent = transparent
    world.color = (grey, grey, grey)
    if world.node_tree is not None:
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (grey, grey, grey, 1.0)
    out[tag] = {{engine: render(engine, tag) for engine in ("PRIMER", "CYCLES")}}
primer.unregister()
report(out=out)
"""


def channels(layers: dict, name: str, keys: str) -> np.ndarray:
    """The pass `name`'s channels `keys` (e.g. "RGBA") from an EXR's layers: (H, W, len(keys)) float64."""
    layer = layers[name]
    return np.stack([np.array(layer[key], np.float64) for key in keys], axis=-1)


def inner(mask: np.ndarray) -> np.ndarray:
    """The pixels of `mask` (H, W) bool whose eight neighbours are in it too (away from a shadow's edge, where the
    renderers' samples land apart)."""
    padded = np.pad(mask, 1, constant_values=True)
    H, W = mask.shape
    return np.all([padded[1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)


def render_setups(folder: str, pane=None, size=(24, 16), fog=None, tags=("pass", "transparent", "opaque"),
                  fog_box=(1.75, 4.5, False)) -> dict:
    """Primer's and Cycles' EXR passes of the setups `tags` (of the three), the catcher seen through a clear pane of
    colour `pane` (3,) or without one (None), in a fog (density, colour (3,), emission strength) or none, filling a
    box 40 m wide (its middle's height, its height, whether it is a shadow catcher: `fog_box`; by default from
    -0.5 m to 4 m, no catcher), at `size` (width, height) pixels."""
    return run_bpy(SCRIPT.format(e_slant=E_SLANT, e_down=E_DOWN, slant=SLANT, cycles_samples=CYCLES_SAMPLES,
                                 primer_samples=PRIMER_SAMPLES, pane=pane, size=size, fog=fog, tags=tags,
                                 fog_box=fog_box),
                   folder)["out"]


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """Primer's and Cycles' EXR passes of the three setups."""
    return render_setups(str(tmp_path_factory.mktemp("shadow_catcher")))


PANE = (0.3, 0.6, 0.9)


@pytest.fixture(scope="module")
def pane_renders(tmp_path_factory):
    """The three setups seen through a clear Transparent pane of colour PANE (32 x 24 pixels)."""
    return render_setups(str(tmp_path_factory.mktemp("shadow_catcher_pane")), pane=PANE, size=(32, 24))


def assert_pass_is_the_unblocked_share(renders) -> None:
    """Outside the shadow both renderers' Shadow Catcher pass is exactly 1; in the slanted sun's shadow Primer's is
    the other sun's share E_down / (E_slant cos 45 + E_down) and Cycles' mean there within 6% of it (its light tree
    picks one sun per sample, so its ratio is noisy)."""
    share = E_DOWN / (E_SLANT * math.cos(SLANT) + E_DOWN)
    primer = channels(renders["pass"]["PRIMER"], "Shadow Catcher", "RGB")
    cycles = channels(renders["pass"]["CYCLES"], "Shadow Catcher", "RGB")
    lit = inner((primer == 1.0).all(axis=-1))
    inside = inner(np.isclose(primer, share, rtol=1e-5).all(axis=-1))
    assert lit.sum() >= 100 and inside.sum() >= 20
    np.testing.assert_allclose(cycles[lit], 1.0, atol=1e-4)
    assert abs(cycles[inside].mean() / share - 1.0) < 0.06, (cycles[inside].mean(), share)


def test_the_shadow_catcher_pass_matches_cycles(renders):
    """Outside the shadow both renderers write exactly 1 (the catcher's light equals its light with the ball); in the
    slanted sun's shadow Primer writes the other sun's share E_down / (E_slant cos 45 + E_down), and Cycles' mean
    there (its light tree picks one sun per sample, so its ratio is noisy) is within 6% of it. Combined is the
    matte, clear everywhere, in both."""
    assert_pass_is_the_unblocked_share(renders)
    for engine in ("PRIMER", "CYCLES"):
        np.testing.assert_allclose(channels(renders["pass"][engine], "Combined", "RGBA"), 0.0, atol=1e-6)


def test_a_transparent_film_carries_the_shadow_in_its_alpha_as_in_cycles(renders):
    """No Shadow Catcher pass, Film > Transparent (Cycles' approximate catcher): black everywhere, alpha 0 where no
    shadow falls and the blocked sun's share in the shadow, in both; their mean alphas agree within 4%."""
    blocked = E_SLANT * math.cos(SLANT) / (E_SLANT * math.cos(SLANT) + E_DOWN)
    primer = channels(renders["transparent"]["PRIMER"], "Combined", "RGBA")
    cycles = channels(renders["transparent"]["CYCLES"], "Combined", "RGBA")
    np.testing.assert_allclose(primer[..., :3], 0.0, atol=1e-6)
    np.testing.assert_allclose(cycles[..., :3], 0.0, atol=1e-6)
    clear = inner(primer[..., 3] == 0.0)
    shade = np.isclose(primer[..., 3], blocked, rtol=1e-5)
    assert clear.sum() >= 100 and shade.sum() >= 20
    np.testing.assert_allclose(cycles[clear][..., 3], 0.0, atol=1e-4)
    assert abs(cycles[..., 3].mean() / primer[..., 3].mean() - 1.0) < 0.04


def test_on_an_opaque_film_the_catcher_shows_the_world_darkened_by_the_shadow_as_in_cycles(renders):
    """No pass, an opaque film and a grey world of 0.25 (which lights the floor too): Combined is the world seen
    through the catcher times the pass's mean, alpha 1; Primer's and Cycles' agree within 3% in mean and in the
    shadow, and the world shows unchanged (0.25) far from it."""
    primer = channels(renders["opaque"]["PRIMER"], "Combined", "RGBA")
    cycles = channels(renders["opaque"]["CYCLES"], "Combined", "RGBA")
    np.testing.assert_allclose(primer[..., 3], 1.0)
    np.testing.assert_allclose(cycles[..., 3], 1.0)
    assert abs(cycles[..., :3].mean() / primer[..., :3].mean() - 1.0) < 0.03
    dark = inner(primer[..., 0] < 0.2)
    assert dark.sum() >= 20
    assert abs(cycles[dark][..., :3].mean() / primer[dark][..., :3].mean() - 1.0) < 0.05
    assert primer[..., :3].max() <= 0.25 + 1e-6 and (np.abs(primer[..., :3] - 0.25) < 0.01).any()


def test_behind_a_clear_pane_the_pass_and_the_matte_match_cycles(pane_renders):
    """The catcher floor seen through a clear Transparent pane of colour c (Cycles splits the camera path at the
    catcher past it): the pass as without the pane (exactly 1 outside the shadow in both, the other sun's share in
    it), Combined with the pass the matte, black with alpha 1 - mean(c) in both; on a transparent film without the
    pass the shadow's alpha over it; on an opaque film the world behind through the pane."""
    a = 1.0 - np.mean(PANE)
    assert_pass_is_the_unblocked_share(pane_renders)
    for engine in ("PRIMER", "CYCLES"):
        matte = channels(pane_renders["pass"][engine], "Combined", "RGBA")
        np.testing.assert_allclose(matte[..., :3], 0.0, atol=1e-6)
        np.testing.assert_allclose(matte[..., 3], a, atol=1e-5, err_msg=engine)
    primer = channels(pane_renders["transparent"]["PRIMER"], "Combined", "RGBA")
    cycles = channels(pane_renders["transparent"]["CYCLES"], "Combined", "RGBA")
    np.testing.assert_allclose(cycles[inner(np.isclose(primer[..., 3], a, rtol=1e-5))][..., 3], a, atol=1e-4)
    assert abs(cycles[..., 3].mean() / primer[..., 3].mean() - 1.0) < 0.02
    primer = channels(pane_renders["opaque"]["PRIMER"], "Combined", "RGBA")
    cycles = channels(pane_renders["opaque"]["CYCLES"], "Combined", "RGBA")
    assert abs(cycles[..., :3].mean() / primer[..., :3].mean() - 1.0) < 0.03


FOG = (0.2, (0.4, 0.6, 0.8), 0.05)        # density, colour (sigma_a = density (1 - colour)), emission strength


def test_in_a_glowing_absorbing_fog_the_matte_and_the_pass_match_cycles(tmp_path):
    """Camera, ball and catcher floor inside a homogeneous fog that absorbs and glows, 4 m up (the camera 3 m up),
    Shadow Catcher pass on a transparent film. Cycles shades the fog in front of the floor before it splits the
    path: the matte (Combined) is the fog's glow in front of the floor, e (1 - T) / sigma_a, with alpha 1 - mean(T)
    of its transmittance T; Primer's matches Cycles' pixel for pixel within 1% (both have it in closed form). The
    catcher-only scene has no fog (it is no catcher's), so the pass is the floor's light in the fog (the suns through
    it, its glow) over its light without it: Primer's and Cycles' means agree within 2% where no shadow falls and in
    the slanted sun's shadow (Cycles' light tree picks one sun per sample: noisy per pixel). Before this change
    Primer's matte was clear (0, alpha 0) and its pass T times lower."""
    out = render_setups(str(tmp_path), fog=FOG, tags=("pass",))["pass"]
    primer = channels(out["PRIMER"], "Combined", "RGBA")
    cycles = channels(out["CYCLES"], "Combined", "RGBA")
    assert (primer[..., :3] > 0.1).all() and (primer[..., 3] > 0.15).all()
    np.testing.assert_allclose(cycles, primer, rtol=0.01)
    primer = channels(out["PRIMER"], "Shadow Catcher", "RGB")
    cycles = channels(out["CYCLES"], "Shadow Catcher", "RGB")
    lit, shade = inner(primer[..., 0] > 0.7), inner(primer[..., 0] < 0.45)
    assert lit.sum() >= 100 and shade.sum() >= 20
    for where in (lit, shade):
        np.testing.assert_allclose(cycles[where].mean(axis=0), primer[where].mean(axis=0), rtol=0.02)


def test_a_catcher_flagged_fog_over_the_floor_is_in_the_catcher_only_light_as_in_cycles(tmp_path):
    """An absorbing fog box from -0.5 m to 1 m over the catcher floor, itself a shadow catcher, the camera 3 m up
    outside it: both renderers split the camera path at the box's top and keep the catchers' fog in the catcher-only
    light, so it darkens the whole scene's light and the catcher-only light alike. The pass's means agree within 2%
    where no shadow falls (about 1: before, Primer's was exp(-2 sigma_a) there, the fog left out of the catcher-only
    light) and in the slanted sun's shadow; the matte is clear (nothing in front of the box)."""
    density, color = FOG[0], FOG[1]
    out = render_setups(str(tmp_path), fog=(density, color, 0.0), tags=("pass",), fog_box=(0.25, 1.5, True))["pass"]
    primer = channels(out["PRIMER"], "Shadow Catcher", "RGB")
    cycles = channels(out["CYCLES"], "Shadow Catcher", "RGB")
    lit, shade = inner(primer[..., 0] > 0.8), inner(primer[..., 0] < 0.45)
    assert lit.sum() >= 100 and shade.sum() >= 20, (lit.sum(), shade.sum())
    for where in (lit, shade):
        np.testing.assert_allclose(cycles[where].mean(axis=0), primer[where].mean(axis=0), rtol=0.02)
    for engine in ("PRIMER", "CYCLES"):
        np.testing.assert_allclose(channels(out[engine], "Combined", "RGBA"), 0.0, atol=1e-4, err_msg=engine)


def test_a_camera_inside_a_catcher_flagged_fog_keeps_it_in_the_catcher_only_light_as_in_cycles(tmp_path):
    """The absorbing fog box from -0.5 m to 4 m around camera, ball and floor, itself a shadow catcher: both
    renderers split the camera path at the floor, the fog in front in its throughput (the matte black, alpha
    1 - mean(T) per pixel, Cycles' within 1% of Primer's closed form), and go on from the floor in the catcher fog
    the camera is in (Cycles re-makes the split path's volume stack from the camera ray's origin), so the fog darkens
    the whole scene's light and the catcher-only light alike: the pass is 1 where no shadow falls in both (before,
    Primer left that fog out of the catcher-only light and its pass was exp(-4 sigma_a) there) and the means in the
    slanted sun's shadow agree within 2%."""
    density, color = FOG[0], FOG[1]
    out = render_setups(str(tmp_path), fog=(density, color, 0.0), tags=("pass",), fog_box=(1.75, 4.5, True))["pass"]
    primer = channels(out["PRIMER"], "Combined", "RGBA")
    cycles = channels(out["CYCLES"], "Combined", "RGBA")
    assert (primer[..., 3] > 0.15).all()
    for matte in (primer, cycles):
        np.testing.assert_allclose(matte[..., :3], 0.0, atol=1e-4)
    np.testing.assert_allclose(cycles[..., 3], primer[..., 3], rtol=0.01)
    primer = channels(out["PRIMER"], "Shadow Catcher", "RGB")
    cycles = channels(out["CYCLES"], "Shadow Catcher", "RGB")
    lit, shade = inner((np.abs(primer - 1.0) < 1e-5).all(axis=-1)), inner(primer[..., 0] < 0.45)
    assert lit.sum() >= 100 and shade.sum() >= 20, (lit.sum(), shade.sum())
    np.testing.assert_allclose(cycles[lit], 1.0, atol=1e-3)
    np.testing.assert_allclose(cycles[shade].mean(axis=0), primer[shade].mean(axis=0), rtol=0.02)
