"""A file made for Cycles renders in Primer with its own Cycles settings (addon/cycles_settings.py), in real Blender
(the bpy module). No mocks.

Render > Settings: Cycles (samples, seed, bounces, clamping, caustics read from scene.cycles, path tracing), Primer
(scene.primer's own), Automatic (Cycles' until one of Primer's own is set). The scene: a diffuse corner (floor and
two walls) under an area light, where the light after one bounce is a large share of the image.
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

from blender_env import diffuse_material  # noqa: E402
from test_blender_denoise import addon, render_image  # noqa: E402
from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def quad(name: str, corners, material) -> None:
    """Link a one-quad mesh object with `corners` (4 points) and `material` into the scene."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    bpy.context.scene.collection.objects.link(bpy.data.objects.new(name, mesh))


def new_cycles_file(width: int, height: int):
    """An empty scene as a file made for Cycles would set it: width x height pixels, Cycles on the CPU at 64 samples,
    no adaptive sampling, no denoising, no world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.world = None
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples, cycles.use_adaptive_sampling, cycles.use_denoising = 64, False, False
    return scene


def add_camera(scene, location, rotation, lens: float = 50.0) -> None:
    """Link a perspective camera at `location` turned by Euler `rotation` (radians) and make it the scene's."""
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = location, rotation
    camera.data.lens = lens
    scene.collection.objects.link(camera)
    scene.camera = camera


def corner_scene():
    """A floor and two walls (diffuse, albedo 0.8) under an area light, 40 x 30; Cycles settings of a file made for
    Cycles: 64 samples, no adaptive sampling, one bounce, no denoising."""
    scene = new_cycles_file(40, 30)
    white = diffuse_material("White", (0.8, 0.8, 0.8))
    quad("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], white)
    quad("Back", [(-2, 2, 0), (2, 2, 0), (2, 2, 3), (-2, 2, 3)], white)
    quad("Side", [(-2, -2, 0), (-2, 2, 0), (-2, 2, 3), (-2, -2, 3)], white)
    light = bpy.data.objects.new("Area", bpy.data.lights.new("Area", "AREA"))
    light.data.energy, light.data.size = 300.0, 1.0
    light.location = (0.5, 0.0, 2.5)
    scene.collection.objects.link(light)
    add_camera(scene, (3.5, -5.0, 2.5), (math.radians(70), 0.0, math.radians(35)))
    scene.cycles.max_bounces, scene.cycles.diffuse_bounces = 1, 1
    scene.cycles.seed = 3
    return scene


def render(scene, engine: str, path: str) -> np.ndarray:
    """The scene rendered by `engine` with the settings it has: (H, W, 3)."""
    scene.render.engine = engine
    return render_image(scene, path, reference=True)[..., :3]


def test_the_automatic_choice_follows_cycles_until_a_primer_setting_is_set(primer, monkeypatch):
    """Automatic: a scene with none of Primer's own settings follows Cycles; once scene.primer.samples is set, Primer's
    own apply; an explicit Cycles or Primer wins either way."""
    monkeypatch.delenv("PRIMER_SETTINGS_SOURCE", raising=False)
    cycles_settings = addon(primer, "cycles_settings")
    scene = corner_scene()
    assert scene.primer.settings_source == "AUTOMATIC" and cycles_settings.follows_cycles(scene)
    settings = cycles_settings.effective(scene)
    assert (settings.samples, settings.max_bounces, settings.integrator, settings.seed) == (64, 1, "PATH", 3)
    assert settings.sample_clamp_indirect == scene.cycles.sample_clamp_indirect == 10.0     # Cycles' default
    scene.primer.samples = 5
    assert not cycles_settings.follows_cycles(scene)
    assert cycles_settings.effective(scene).samples == 5
    assert cycles_settings.effective(scene).integrator == scene.primer.integrator
    scene.primer.settings_source = "CYCLES"
    assert cycles_settings.effective(scene).samples == 64
    monkeypatch.setenv("PRIMER_SETTINGS_SOURCE", "PRIMER")                   # decides for Automatic only
    assert cycles_settings.follows_cycles(scene)
    scene.primer.settings_source = "AUTOMATIC"
    assert not cycles_settings.follows_cycles(scene)


def test_a_cycles_file_renders_with_its_cycles_settings(primer, tmp_path):
    """Following Cycles, Primer renders the file's 64 samples with path tracing and its one bounce: the image is
    Cycles' own render of the file (4x4 block relMSE within a few times Cycles' own 64-sample noise), where Primer's
    own settings (direct light, 16 samples) miss the bounced light; and with Cycles' Denoise on, a note says Primer
    does not denoise."""
    scene = corner_scene()
    scene.primer.settings_source = "CYCLES"
    mine = render(scene, "PRIMER", str(tmp_path / "primer.exr"))
    record = addon(primer, "engine").last_render
    assert not record.error, record.error
    assert (record.stats.samples_per_pixel == 64).all()
    assert not [w for w in record.warnings if "denoise" in w.lower()], record.warnings
    cycles = render(scene, "CYCLES", str(tmp_path / "cycles.exr"))
    scene.cycles.seed = 4
    cycles_again = render(scene, "CYCLES", str(tmp_path / "cycles_again.exr"))
    scene.primer.settings_source = "PRIMER"
    own = render(scene, "PRIMER", str(tmp_path / "own.exr"))
    noise = relative_mse_of_blocks(cycles_again, cycles)
    error = relative_mse_of_blocks(mine, cycles)
    wrong = relative_mse_of_blocks(own, cycles)
    print(f"block relMSE: Primer following Cycles {error:.2e}, Cycles seed 3 vs 4 {noise:.2e}, Primer's own "
          f"settings {wrong:.2e}; mean ratio {mine.mean() / cycles.mean():.4f}")
    assert error < max(4.0 * noise, 2e-4), (error, noise)
    assert wrong > 20.0 * error
    assert mine.mean() == pytest.approx(cycles.mean(), rel=0.02)
    scene.primer.settings_source = "CYCLES"
    scene.cycles.use_denoising = True
    scene.cycles.samples = 4
    render(scene, "PRIMER", str(tmp_path / "denoised.exr"))
    notes = [w for w in addon(primer, "engine").last_render.warnings if "Cycles denoises" in w]
    assert len(notes) == 1, addon(primer, "engine").last_render.warnings


class Layout:
    """A stand-in for a panel's layout (no window here): keeps each drawn property as (owner's RNA, name, text)."""

    def __init__(self, drawn: list):
        """Collect into `drawn`."""
        self.drawn, self.use_property_split, self.active = drawn, False, True

    def column(self, **_kw):
        """A sub-layout that collects into the same list."""
        return Layout(self.drawn)

    row = column

    def label(self, **_kw) -> None:
        """A label: nothing to check."""

    def prop(self, owner, name: str, **kw) -> None:
        """Check that `owner` has the property `name`, and keep it."""
        assert name in owner.bl_rna.properties.keys(), (owner.bl_rna.identifier, name)
        self.drawn.append((owner.bl_rna.identifier, name, kw.get("text")))


@pytest.mark.parametrize("source", ["CYCLES", "PRIMER"])
def test_the_panels_show_the_settings_the_render_reads(primer, source):
    """Sampling and Light Paths draw samples, bounces, clamping and caustics from scene.cycles when the scene follows
    Cycles and from scene.primer otherwise; Light Samples and Denoise are Primer's in both."""
    ui = addon(primer, "ui")
    scene = corner_scene()
    scene.primer.settings_source = source
    drawn = []
    for panel in (ui.RENDER_PT_primer_sampling, ui.RENDER_PT_primer_light_paths):
        panel.draw(type("Panel", (), {"layout": Layout(drawn)})(), type("Context", (), {"scene": scene})())
    owners = {name: owner for owner, name, _text in drawn}
    followed = addon(primer, "cycles_settings").FOLLOWED
    wanted = "CyclesRenderSettings" if source == "CYCLES" else "PrimerSettings"
    for name in followed:
        key = followed[name] if source == "CYCLES" else name
        assert owners.get(key) == wanted, (name, owners)
    assert owners["light_samples"] == owners["use_denoising"] == "PrimerSettings"


def terminator_scene():
    """Two 12-segment smooth spheres under a low sun, their terminators across the image: the left one with Cycles'
    default Shadow Terminator offsets (Geometry 0.1, Shading 0), the right one with its own (Geometry 0.5, Shading
    0.6: its shading bends towards 0 before the terminator); 64 x 32, direct light."""
    scene = new_cycles_file(64, 32)
    for x, geometry, shading in ((-1.1, 0.1, 0.0), (1.1, 0.5, 0.6)):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6, radius=1.0, location=(x, 0.0, 0.0))
        bpy.ops.object.shade_smooth()
        sphere = bpy.context.view_layer.objects.active
        sphere.data.materials.append(diffuse_material("White", (0.8, 0.8, 0.8)))
        sphere.shadow_terminator_geometry_offset, sphere.shadow_terminator_shading_offset = geometry, shading
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = (math.radians(75.0), 0.0, math.radians(90.0))
    scene.collection.objects.link(sun)
    add_camera(scene, (0.0, -6.0, 0.0), (math.radians(90.0), 0.0, 0.0), lens=40.0)
    scene.cycles.max_bounces = 0
    return scene


def test_a_cycles_file_lifts_and_bends_each_object_by_its_own_terminator_offsets(primer, tmp_path):
    """Following Cycles, Primer's Shadow Terminator Fix is on and each object takes its own Shadow Terminator
    Geometry Offset (how far its shadow rays are lifted) and Shading Offset (how its shading fades before the
    terminator): both spheres' terminators are Cycles' (block relMSE within Cycles' own noise), where the lecture's
    raw shadow rays (Primer's own settings, the fix off) darken whole facets and do not bend the shading."""
    scene = terminator_scene()
    export = sys.modules[primer.__name__ + ".addon.export"]
    scene.primer.settings_source = "CYCLES"
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    assert exported.settings.terminator_fix
    assert not [w for w in exported.warnings if "Terminator" in w], exported.warnings
    offsets = sorted((i.terminator_offset, i.terminator_shading) for i in exported.scene.instances)
    assert offsets == [(pytest.approx(0.1), 0.0), (pytest.approx(0.5), pytest.approx(0.6))], offsets
    mine = render(scene, "PRIMER", str(tmp_path / "primer.exr"))
    cycles = render(scene, "CYCLES", str(tmp_path / "cycles.exr"))
    scene.primer.settings_source = "PRIMER"
    scene.primer.samples = 64
    scene.update_tag()                                   # (the evaluated scene the export reads)
    bpy.context.view_layer.update()
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    notes = [w for w in exported.warnings if "Terminator" in w]
    assert len(notes) == 2 and "'Sphere.001'" in notes[1] and "Shading Offset" in notes[1], notes
    raw = render(scene, "PRIMER", str(tmp_path / "raw.exr"))
    right = (slice(None), slice(32, None))
    error, wrong = relative_mse_of_blocks(mine, cycles), relative_mse_of_blocks(raw, cycles)
    bent_error = relative_mse_of_blocks(mine[right], cycles[right])
    print(f"block relMSE: following Cycles {error:.2e} (the bent sphere {bent_error:.2e}), the fix off {wrong:.2e}")
    assert error < 5e-4 and bent_error < 5e-4 and wrong > 10.0 * error, (error, bent_error, wrong)


def test_the_surface_after_the_last_transparent_bounce_ends_the_camera_path_as_in_cycles(primer, tmp_path):
    """Four clear sheets (Transparent BSDF of 0.5) before an orange world, seen straight through: with Transparent Max
    Bounces 3 the fourth sheet ends the path (black), with 4 the camera sees the world through all four
    (1/16 of it), in Cycles (its mean: it plays Russian roulette on transparent bounces) and in Primer alike."""
    scene = new_cycles_file(8, 8)
    world = bpy.data.worlds.new("Orange")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    scene.world = world
    material = bpy.data.materials.new("Clear")
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    clear = tree.nodes.new("ShaderNodeBsdfTransparent")
    clear.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    tree.links.new(clear.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    for k in range(4):
        bpy.ops.mesh.primitive_plane_add(size=40.0, location=(0.0, 0.0, -float(k)))
        bpy.context.view_layer.objects.active.data.materials.append(material)
    add_camera(scene, (0.0, 0.0, 3.0), (0.0, 0.0, 0.0))
    scene.cycles.samples = 64
    scene.primer.settings_source = "CYCLES"
    for limit, expected in ((3, np.zeros(3)), (4, np.array([1.0, 0.5, 0.25]) / 16.0)):
        scene.cycles.transparent_max_bounces = limit
        mine = render(scene, "PRIMER", str(tmp_path / f"primer{limit}.exr"))
        np.testing.assert_allclose(mine, np.broadcast_to(expected, mine.shape), atol=1e-6)
        # (Cycles plays Russian roulette on transparent bounces past Min Transparent Bounces, 0: noisy, unbiased)
        cycles = render(scene, "CYCLES", str(tmp_path / f"cycles{limit}.exr"))
        np.testing.assert_allclose(cycles.mean(axis=(0, 1)), expected, rtol=0.05, atol=1e-9)


def test_film_exposure_scales_the_image_as_in_cycles(primer, tmp_path):
    """Render > Film > Exposure 2 (always read from the file's Cycles settings, as its pixel filter): Primer's image
    with the same samples is twice as bright, as Cycles' is (both measured here: Cycles multiplies Combined when it
    reads its film), and no note says it is not modelled."""
    scene = corner_scene()
    scene.primer.settings_source = "CYCLES"
    scene.cycles.samples = 4
    ratios = {}
    for engine in ("PRIMER", "CYCLES"):
        scene.cycles.film_exposure = 1.0
        plain = render(scene, engine, str(tmp_path / f"{engine}_1.exr"))
        scene.cycles.film_exposure = 2.0
        exposed = render(scene, engine, str(tmp_path / f"{engine}_2.exr"))
        lit = plain > 1e-3
        ratios[engine] = exposed[lit] / plain[lit]
    warnings = addon(primer, "engine").last_render.warnings
    assert not [w for w in warnings if "Exposure" in w], warnings
    np.testing.assert_allclose(ratios["CYCLES"], 2.0, rtol=1e-4)
    np.testing.assert_allclose(ratios["PRIMER"], 2.0, rtol=1e-6)


def plain_world(name: str, color):
    """A new world of one background colour (its Background node's, where a new world has one: since Blender 5.0)."""
    world = bpy.data.worlds.new(name)
    world.color = color
    background = world.node_tree.nodes.get("Background") if world.node_tree is not None else None
    if background is not None:
        background.inputs["Color"].default_value = (*color, 1.0)
    return world


def shader_material(name: str, kind: str, **inputs):
    """A new material whose Surface is one shader node of type `kind` with `inputs` (socket name -> value):
    (material, the node)."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    node = nodes.new(kind)
    for socket, value in inputs.items():
        node.inputs[socket].default_value = value
    material.node_tree.links.new(node.outputs[0], nodes["Material Output"].inputs["Surface"])
    return material, node


def plane_under_an_orthographic_camera(scene, size: float, material) -> None:
    """A plane of `size` with `material` at the origin, seen straight down by an orthographic camera 1 wide from 3
    above (the scene's camera)."""
    bpy.ops.mesh.primitive_plane_add(size=size)
    bpy.context.object.data.materials.append(material)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale, camera.location = "ORTHO", 1.0, (0.0, 0.0, 3.0)
    scene.collection.objects.link(camera)
    scene.camera = camera


def test_a_view_layer_renders_its_world_override_and_no_world_without_its_environment_as_in_cycles(primer,
                                                                                                  tmp_path):
    """View Layer > Filter > Environment off: Cycles gives the background its empty shader, so a bright world neither
    shows nor lights; each engine's image is then the same numbers as with no world at all. A World Override: each
    engine's image is the same numbers as with that world as the scene's (both measured here, Cycles' too), and
    Primer says nothing about either."""
    scene = corner_scene()
    scene.primer.settings_source = "CYCLES"
    scene.cycles.samples = 4
    bright, green = plain_world("Bright", (2.0, 1.5, 1.0)), plain_world("Green", (0.1, 0.9, 0.2))
    layer = scene.view_layers[0]
    warnings = []
    for engine in ("PRIMER", "CYCLES"):
        scene.world = None
        without = render(scene, engine, str(tmp_path / f"{engine}_none.exr"))
        scene.world = bright
        layer.use_sky = False
        filtered = render(scene, engine, str(tmp_path / f"{engine}_filtered.exr"))
        layer.use_sky = True
        lit = render(scene, engine, str(tmp_path / f"{engine}_lit.exr"))
        np.testing.assert_array_equal(filtered, without, err_msg=engine)
        assert lit.mean() > 1.5 * without.mean(), engine
        layer.world_override = green
        overridden = render(scene, engine, str(tmp_path / f"{engine}_overridden.exr"))
        warnings += addon(primer, "engine").last_render.warnings if engine == "PRIMER" else []
        layer.world_override, scene.world = None, green
        green_scene = render(scene, engine, str(tmp_path / f"{engine}_green.exr"))
        np.testing.assert_array_equal(overridden, green_scene, err_msg=engine)
        assert np.abs(green_scene - lit).max() > 0.1, engine
    layer.use_sky = False
    render(scene, "PRIMER", str(tmp_path / "again.exr"))
    warnings += addon(primer, "engine").last_render.warnings
    assert not [w for w in warnings if "Environment" in w or "Override" in w], warnings


def test_simplify_culling_leaves_out_what_cycles_leaves_out(primer, tmp_path):
    """Simplify > Camera Culling: a glowing panel behind the camera (it lights the corner) with its Camera Cull flag
    is left out by both engines, each image the same numbers as with the panel hidden from the render (Cycles'
    measured here); with Distance Culling on too, and the panel nearer than its distance, it stays (Cycles culls
    only what both tests cull)."""
    scene = corner_scene()
    scene.primer.settings_source = "CYCLES"
    scene.cycles.samples = 4
    glow, _ = shader_material("Glow", "ShaderNodeEmission", Strength=20.0)
    quad("Panel", [(5.5, -8.0, 0.5), (2.5, -10.0, 0.5), (2.5, -10.0, 4.5), (5.5, -8.0, 4.5)], glow)
    panel = bpy.data.objects["Panel"]
    panel.cycles.use_camera_cull = True
    scene.render.use_simplify = True
    scene.cycles.use_camera_cull = True
    export = addon(primer, "export")
    assert export.export_scene(bpy.context.evaluated_depsgraph_get()).culled == ["Panel"]
    for engine in ("PRIMER", "CYCLES"):
        culled = render(scene, engine, str(tmp_path / f"{engine}_culled.exr"))
        scene.cycles.use_distance_cull, scene.cycles.distance_cull_margin = True, 50.0
        panel.cycles.use_distance_cull = True
        kept = render(scene, engine, str(tmp_path / f"{engine}_kept.exr"))
        scene.cycles.use_distance_cull = panel.cycles.use_distance_cull = False
        panel.hide_render = True
        hidden = render(scene, engine, str(tmp_path / f"{engine}_hidden.exr"))
        panel.hide_render = False
        np.testing.assert_array_equal(culled, hidden, err_msg=engine)
        assert kept.mean() > 1.1 * hidden.mean(), engine
    assert not [w for w in addon(primer, "engine").last_render.warnings if "cull" in w.lower()]


def test_a_texture_limit_averages_a_fine_checker_to_grey_as_in_cycles(primer, tmp_path):
    """Simplify > Texture Limit 128 on a 256 x 256 PNG checker of single black and white texels, seen through an
    Emission of its colour (Closest) on a plane filling an orthographic view: Cycles keeps 2 x 2 means, byte 128 (sRGB
    0.2158 linear), everywhere, and so does Primer, pixel for pixel; without the limit each sample of both sees one
    texel, black or white."""
    scene = new_cycles_file(16, 16)
    scene.cycles.samples = 1
    scene.primer.settings_source = "CYCLES"
    image = bpy.data.images.new("Checker", 256, 256)
    texels = (np.indices((256, 256)).sum(axis=0) % 2).astype(np.float32)
    image.pixels[:] = np.repeat(texels[:, :, None], 4, axis=2).clip(0, 1).ravel().tolist()
    image.filepath_raw = str(tmp_path / "checker.png")
    image.file_format = "PNG"
    image.save()
    image = bpy.data.images.load(str(tmp_path / "checker.png"))
    material, emission = shader_material("Checker", "ShaderNodeEmission")
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    material.node_tree.links.new(texture.outputs["Color"], emission.inputs["Color"])
    plane_under_an_orthographic_camera(scene, 2.0, material)
    scene.render.use_simplify = True
    grey = 128.0 / 255.0
    grey = ((grey + 0.055) / 1.055) ** 2.4
    for limit, uniform in (("128", True), ("OFF", False)):
        scene.cycles.texture_limit_render = limit
        images = {engine: render(scene, engine, str(tmp_path / f"{engine}_{limit}.exr"))
                  for engine in ("PRIMER", "CYCLES")}
        if uniform:
            np.testing.assert_allclose(images["CYCLES"], grey, rtol=1e-4)
            np.testing.assert_allclose(images["PRIMER"], images["CYCLES"], rtol=1e-5)
        else:                                       # (each sample sees one texel, black or white)
            for pixels in images.values():
                assert np.isin(np.round(pixels, 4), (0.0, 1.0)).all()
    assert not [w for w in addon(primer, "engine").last_render.warnings if "texture" in w.lower()]


def test_texture_resolution_keeps_the_means_of_2_by_2_blocks_as_in_cycles(primer, tmp_path):
    """Blender 5.2's Simplify > Texture Resolution 0.75 on a 63 x 63 PNG of random bytes (Non-Color, Closest, an
    Emission of its colour filling an orthographic view of 62 x 62 pixels): Cycles shrinks it by 0.5, the power of 2
    below, into 31 x 31 means of 2 x 2 blocks from the bottom-left corner (the top row and the right column dropped),
    each seen by 2 x 2 pixels, and so does Primer (textures.limited), pixel for pixel; Primer says nothing of it."""
    if "texture_resolution_render" not in bpy.context.scene.cycles.bl_rna.properties:
        pytest.skip(f"Simplify > Texture Resolution is not in Blender {bpy.app.version_string}")
    textures = sys.modules[primer.__name__ + ".core.materials.textures"]
    scene = new_cycles_file(62, 62)
    scene.cycles.samples, scene.cycles.filter_width = 4, 0.01
    scene.primer.settings_source = "CYCLES"
    texels = np.random.default_rng(33).integers(0, 256, (63, 63, 3)).astype(np.uint8)      # (bottom row first)
    image = bpy.data.images.new("Random", 63, 63)
    image.pixels[:] = np.concatenate([texels, np.full((63, 63, 1), 255, np.uint8)], axis=2).ravel() / 255.0
    image.filepath_raw, image.file_format = str(tmp_path / "random.png"), "PNG"
    image.save()
    image = bpy.data.images.load(str(tmp_path / "random.png"))
    image.colorspace_settings.name = "Non-Color"
    material, emission = shader_material("Random", "ShaderNodeEmission")
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    material.node_tree.links.new(texture.outputs["Color"], emission.inputs["Color"])
    plane_under_an_orthographic_camera(scene, 1.0, material)
    scene.render.use_simplify = True
    scene.cycles.texture_resolution_render = 0.75
    images = {engine: render(scene, engine, str(tmp_path / f"{engine}.exr")) for engine in ("PRIMER", "CYCLES")}
    means = textures.limited(texels, 0, 0.75)
    assert means.shape == (31, 31, 3)
    expected = np.repeat(np.repeat(means[::-1], 2, axis=0), 2, axis=1) / np.float32(255.0)     # (top row first)
    np.testing.assert_allclose(images["CYCLES"], expected, atol=1e-6)
    np.testing.assert_allclose(images["PRIMER"], images["CYCLES"], atol=1e-6)
    assert not [w for w in addon(primer, "engine").last_render.warnings if "texture" in w.lower()]


def test_transparent_glass_clears_the_film_behind_smooth_glass_as_in_cycles(primer, tmp_path):
    """Film > Transparent with Transparent Glass: a smooth glass sheet (IOR 1.5) filling an orthographic view of a
    white world leaves the film clear by the light it lets through, alpha = R = 0.04 and colour R, in Cycles (measured
    here) and in Primer; without Transparent Glass the glass is opaque (alpha 1) in both."""
    scene = new_cycles_file(8, 8)
    scene.primer.settings_source = "CYCLES"
    scene.cycles.samples, scene.cycles.max_bounces = 256, 4
    scene.render.film_transparent = True
    scene.world = plain_world("White", (1.0, 1.0, 1.0))
    glass, _ = shader_material("Glass", "ShaderNodeBsdfGlass", Roughness=0.0, IOR=1.5)
    plane_under_an_orthographic_camera(scene, 4.0, glass)
    for engine in ("PRIMER", "CYCLES"):
        scene.render.engine = engine
        scene.cycles.film_transparent_glass = True
        clear = render_image(scene, str(tmp_path / f"{engine}_clear.exr"), reference=True)
        scene.cycles.film_transparent_glass = False
        opaque = render_image(scene, str(tmp_path / f"{engine}_opaque.exr"), reference=True)
        assert clear[..., 3].mean() == pytest.approx(0.04, abs=0.006), engine
        assert clear[..., :3].mean() == pytest.approx(clear[..., 3].mean(), abs=2e-3), engine
        assert opaque[..., 3].min() > 0.999 and opaque[..., :3].mean() == pytest.approx(1.0, abs=0.01), engine
    assert not [w for w in addon(primer, "engine").last_render.warnings if "Glass" in w]


def test_bump_map_correction_off_renders_as_in_cycles(primer, tmp_path):
    """Material > Settings > Bump Map Correction: a Principled plane (rough specular and diffuse) bumped steeply by
    wave bands under a low sun, seen straight down. On (Cycles' default), Cycles softens the diffuse closure's light
    where its bumped normal leans from the smooth one and turns the glossy normals whose mirror would dip below the
    face; off, it does neither. Primer's image is Cycles' within noise both ways, and the two differ in both
    engines; Primer says nothing about the setting."""
    scene = new_cycles_file(32, 32)
    scene.primer.settings_source = "CYCLES"
    scene.cycles.samples, scene.cycles.max_bounces = 256, 0
    material, principled = shader_material("Bumped", "ShaderNodeBsdfPrincipled", Roughness=0.35)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    wave, bump = nodes.new("ShaderNodeTexWave"), nodes.new("ShaderNodeBump")
    wave.inputs["Scale"].default_value = 2.0
    bump.inputs["Distance"].default_value = 0.6
    links.new(wave.outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], principled.inputs["Normal"])
    plane_under_an_orthographic_camera(scene, 2.0, material)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = (math.radians(68.0), 0.0, math.radians(30.0))
    scene.collection.objects.link(sun)
    images = {}
    for corrected in (True, False):
        material.cycles.use_bump_map_correction = corrected
        for engine in ("PRIMER", "CYCLES"):
            images[engine, corrected] = render(scene, engine, str(tmp_path / f"{engine}_{corrected}.exr"))
    for corrected in (True, False):                 # (measured: 2.3e-7 on, 2.0e-7 off)
        assert relative_mse_of_blocks(images["PRIMER", corrected], images["CYCLES", corrected], 4) < 3e-6, corrected
    for engine in ("PRIMER", "CYCLES"):             # (measured: 0.091 in both)
        assert relative_mse_of_blocks(images[engine, False], images[engine, True], 4) > 0.03, engine
    assert not [w for w in addon(primer, "engine").last_render.warnings if "Bump" in w]


def test_fast_gi_replace_renders_as_in_cycles(primer, tmp_path):
    """Render > Light Paths > Fast GI Approximation (Replace, AO Bounces 1) with the world's AO Factor 0.4 and Distance
    1.5: a floor and a wall under a grey world and a sun, seen from the side. Past its first diffuse bounce a path's
    ray looks 1.5 m (0.2 from the floor, its own Object > Visibility > AO Distance), ends at what it meets and brings
    0.4 of the world where it escapes: Primer's image is Cycles' within noise, darker than without Fast GI, and no note
    speaks of Fast GI."""
    scene = new_cycles_file(64, 48)
    scene.primer.settings_source = "CYCLES"
    scene.cycles.samples, scene.cycles.max_bounces = 128, 4
    scene.world = plain_world("Grey", (0.6, 0.6, 0.6))
    white = diffuse_material("White", (0.8, 0.8, 0.8))
    quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], white)
    quad("Wall", [(-3, 1, 0), (3, 1, 0), (3, 1, 3), (-3, 1, 3)], white)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 2.0, math.radians(5.0)
    sun.rotation_euler = (math.radians(50.0), 0.0, math.radians(-30.0))
    scene.collection.objects.link(sun)
    add_camera(scene, (2.5, -5.5, 2.2), (math.radians(72), 0.0, math.radians(25)))
    scene.cycles.use_fast_gi, scene.cycles.fast_gi_method, scene.cycles.ao_bounces_render = True, "REPLACE", 1
    scene.world.light_settings.ao_factor, scene.world.light_settings.distance = 0.4, 1.5
    bpy.data.objects["Floor"].cycles.ao_distance = 0.2
    images = {engine: render(scene, engine, str(tmp_path / f"{engine}.exr")) for engine in ("PRIMER", "CYCLES")}
    assert not [w for w in addon(primer, "engine").last_render.warnings if "Fast GI" in w]
    # (measured: 1.0e-6; 6.1e-4 with the world's distance from the floor too, 1.6e-6 against Cycles then)
    assert relative_mse_of_blocks(images["PRIMER"], images["CYCLES"], 4) < 3e-5
    scene.cycles.use_fast_gi = False
    full = render(scene, "PRIMER", str(tmp_path / "full.exr"))
    assert full.mean() > 1.4 * images["PRIMER"].mean()          # (measured: 0.854 against 0.514; relMSE 0.50)
    assert images["CYCLES"].mean() == pytest.approx(images["PRIMER"].mean(), rel=0.01)


def test_fast_gi_replace_in_a_fog_renders_as_in_cycles(primer, tmp_path):
    """Fast GI (Replace, AO Bounces 1, AO Factor 0.4, Distance 1) with the floor and the wall inside a fog box
    (Principled Volume, density 0.25, scattering and absorbing) and Volume Bounces 2, the camera outside the box:
    Fast GI's short rays in the fog only absorb and emit, leave the box's medium where they meet nothing within 1 m,
    and the phase rays of the camera rays' scattering points are already Fast GI's (a scattering event counts as a
    bounce), so those paths scatter no more. Primer 64 samples against Cycles 1024: block relMSE within 5e-5 (measured
    9.9e-6; 1.5e-2 before 2026-11-30, Primer's image then 10 % too bright), each channel's mean within 0.5 %, no note
    speaks of Fast GI."""
    scene = new_cycles_file(64, 48)
    scene.primer.settings_source = "CYCLES"
    scene.cycles.max_bounces, scene.cycles.volume_bounces = 4, 2
    scene.world = plain_world("Grey", (0.6, 0.6, 0.6))
    white = diffuse_material("White", (0.8, 0.8, 0.8))
    quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], white)
    quad("Wall", [(-3, 1, 0), (3, 1, 0), (3, 1, 3), (-3, 1, 3)], white)
    fog = bpy.data.materials.new("Fog")
    fog.use_nodes = True
    nodes = fog.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    volume = nodes.new("ShaderNodeVolumePrincipled")
    volume.inputs["Color"].default_value = (0.7, 0.8, 0.9, 1.0)
    volume.inputs["Density"].default_value = 0.25
    volume.inputs["Absorption Color"].default_value = (0.5, 0.4, 0.3, 1.0)
    fog.node_tree.links.new(volume.outputs[0], nodes["Material Output"].inputs["Volume"])
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 1.6))
    bpy.context.object.scale = (6.4, 6.4, 3.4)
    bpy.context.object.data.materials.append(fog)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 2.0, math.radians(5.0)
    sun.rotation_euler = (math.radians(50.0), 0.0, math.radians(-30.0))
    scene.collection.objects.link(sun)
    add_camera(scene, (2.5, -5.5, 2.2), (math.radians(72), 0.0, math.radians(25)))
    scene.cycles.use_fast_gi, scene.cycles.fast_gi_method, scene.cycles.ao_bounces_render = True, "REPLACE", 1
    scene.world.light_settings.ao_factor, scene.world.light_settings.distance = 0.4, 1.0
    images = {}
    for engine, samples in (("PRIMER", 64), ("CYCLES", 1024)):
        scene.cycles.samples = samples
        images[engine] = render(scene, engine, str(tmp_path / f"{engine}.exr"))
    assert not [w for w in addon(primer, "engine").last_render.warnings if "Fast GI" in w]
    assert relative_mse_of_blocks(images["PRIMER"], images["CYCLES"], 4) < 5e-5
    np.testing.assert_allclose(images["PRIMER"].reshape(-1, 3).mean(axis=0),
                               images["CYCLES"].reshape(-1, 3).mean(axis=0), rtol=5e-3)
