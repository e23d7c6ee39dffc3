"""What Primer does not render is said, inside real Blender (the bpy module, no mocks): each setting of issue 31's list
("ignored without a word") gets its note in the render's warnings, once; and the two it now renders as Cycles do
(a Holdout collection, a material with a Volume and no Surface) match Cycles' image. (Homogeneous media are rendered:
tests/test_blender_volumes.py.)"""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

from blender_env import empty_material, render_pixels  # noqa: E402

pytestmark = [pytest.mark.blender]


@pytest.fixture(scope="module")
def primer():
    return load_primer()


def material(name: str, surface=None, volume=None, displacement=False):
    """A material whose output has the given Surface node type, Volume node type, and a Displacement."""
    m, tree, output = empty_material(name)
    for kind, socket in ((surface, "Surface"), (volume, "Volume")):
        if kind is not None:
            tree.links.new(tree.nodes.new(kind).outputs[0], output.inputs[socket])
    if displacement:                    # (true displacement: Primer moves the vertices, as Cycles; nothing said)
        tree.links.new(tree.nodes.new("ShaderNodeDisplacement").outputs[0], output.inputs["Displacement"])
        owner = m if hasattr(m, "displacement_method") else m.cycles
        owner.displacement_method = "DISPLACEMENT"
    return m


def scene_with_everything():
    """Blender's default scene with every setting of the list switched on."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    layer = scene.view_layers[0]
    scene.render.use_motion_blur = True
    cube, light = scene.objects["Cube"], scene.objects["Light"]
    cube.data.materials.clear()
    cube.data.materials.append(material("Smoke", volume="ShaderNodeVolumePrincipled"))
    bpy.ops.mesh.primitive_uv_sphere_add(location=(3, 0, 0))
    sphere = bpy.context.object
    principled = material("Displaced", surface="ShaderNodeBsdfPrincipled", displacement=True)
    dispersion = next(n for n in principled.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled").inputs.get(
        "Dispersion")                                   # (Blender 4.2 to 4.5 have it)
    if dispersion is not None:
        dispersion.default_value = 0.5
    sphere.data.materials.append(principled)
    receivers = bpy.data.collections.new("Receivers")
    light.light_linking.receiver_collection = receivers
    light.light_linking.blocker_collection = receivers
    world = scene.world
    tree = world.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    tree.links.new(tree.nodes.new("ShaderNodeVolumeScatter").outputs[0], out.inputs["Volume"])
    layer.use_pass_mist = layer.use_pass_vector = True
    layer.aovs.add().name = "Mask"
    tree.nodes.new("ShaderNodeOutputAOV").aov_name = "Mask"      # (the world's AOVs: rendered, no note)
    return scene


def test_every_unmodelled_setting_is_said_once(primer):
    """Principled Dispersion: named in one warning. (The world's AOV Output nodes are written since issue 33: no
    warning. A material's true Displacement
    moves its vertices as in Cycles, the Volumes of the material and the world are homogeneous media Primer renders,
    the Mist pass is written since stop 46 and the Vector pass since stop 48: no warning.)"""
    scene = scene_with_everything()
    export = sys.modules[primer.__name__ + ".addon.export"]
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    assert not [w for w in warnings if "Displacement" in w], warnings
    assert not [w for w in warnings if "Mist" in w or "Vector" in w], warnings
    assert not [w for w in warnings if "AOV" in w], warnings
    expected = []
    if any(node.inputs.get("Dispersion") is not None for node in bpy.data.materials["Displaced"].node_tree.nodes):
        expected.append("'Dispersion' is above 0")
    for phrase in expected:
        found = [w for w in warnings if phrase in w]
        assert len(found) == 1, (phrase, warnings)
    assert not [w for w in warnings if "Volume" in w and "Ray Visibility" not in w], warnings


def test_a_default_scene_says_nothing_of_these(primer):
    """Blender's default scene, Cycles' Blackman-Harris pixel filter included (Primer follows it), asks none of
    them: no note."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    export = sys.modules[primer.__name__ + ".addon.export"]
    bpy.context.scene.cycles.pixel_filter_type = "BLACKMAN_HARRIS"     # the factory's (the tests load a box)
    bpy.context.scene.cycles.filter_width = 1.5
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    assert not [w for w in warnings if "Primer" in w], warnings


def test_lamps_as_many_as_the_transparent_bounces_are_noted(primer):
    """Cycles ends a ray at its Transparent Max Bounces-th lamp with a size (shade_light.h): the default scene's
    point lamp with a radius and Transparent Max Bounces 1 is noted once; with the default 8 nothing is said."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    export = sys.modules[primer.__name__ + ".addon.export"]
    bpy.context.scene.objects["Light"].data.shadow_soft_size = 0.5
    phrase = "as a transparent bounce"
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    assert not [w for w in warnings if phrase in w]
    bpy.context.scene.cycles.transparent_max_bounces = 1
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    assert len([w for w in warnings if phrase in w]) == 1


@pytest.mark.slow
def test_a_holdout_collection_and_a_volume_only_box_render_as_in_cycles(primer, tmp_path):
    """A sphere in a Holdout collection cuts a hole in the film (alpha 0), and a cube whose material has only a
    Volume (an absorption of density 0) lets the camera see through it, as Cycles renders both."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 24, 100
    scene.render.film_transparent = True
    cube = scene.objects["Cube"]
    cube.data.materials.clear()
    thin = material("Thin", volume="ShaderNodeVolumeAbsorption")
    thin.node_tree.nodes["Volume Absorption"].inputs["Density"].default_value = 0.0
    cube.data.materials.append(thin)
    bpy.ops.mesh.primitive_plane_add(size=20.0, location=(0, 0, -1.2))
    holes = bpy.data.collections.new("Holes")
    scene.collection.children.link(holes)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(1.5, -1.5, 0.0))
    sphere = bpy.context.object
    for collection in sphere.users_collection:
        collection.objects.unlink(sphere)
    holes.objects.link(sphere)
    scene.view_layers[0].layer_collection.children["Holes"].holdout = True
    mine = render_pixels(scene, "PRIMER", str(tmp_path / "primer.exr"), 16)
    cycles = render_pixels(scene, "CYCLES", str(tmp_path / "cycles.exr"), 64, True)
    holes_primer, holes_cycles = mine[..., 3] < 0.5, cycles[..., 3] < 0.5
    assert holes_cycles.sum() > 10
    assert (holes_primer != holes_cycles).sum() <= 4, ((holes_primer != holes_cycles).sum(), holes_cycles.sum())
    rgb = (mine[..., :3] * mine[..., 3:]).mean(axis=(0, 1)), (cycles[..., :3] * cycles[..., 3:]).mean(axis=(0, 1))
    np.testing.assert_allclose(rgb[0], rgb[1], rtol=0.05, atol=0.005)


# The cases of an image's alpha (issue 33): (colour space, Alpha mode, Alpha output used), each on a plane of its own.
ALPHA_CASES = [("Non-Color", "STRAIGHT", True), ("sRGB", "STRAIGHT", False), ("sRGB", "STRAIGHT", True),
               ("sRGB", "CHANNEL_PACKED", True), ("sRGB", "NONE", True)]


def straight_alpha_png(path: str) -> np.ndarray:
    """Write a 4 x 4 RGBA PNG with straight alpha (Blender saves a byte image's values as they are) of bytes from a
    fixed generator, alpha 0 and 255 among them; return them (4, 4, 4) uint8, bottom row first."""
    rng = np.random.default_rng(33)
    texels = rng.integers(0, 256, (4, 4, 4)).astype(np.uint8)
    texels[0, 0, 3], texels[0, 1, 3], texels[1, 0, 3] = 0, 255, 1
    image = bpy.data.images.new("Straight", 4, 4, alpha=True)
    image.pixels.foreach_set((texels.astype(np.float32) / 255.0).reshape(-1))
    image.filepath_raw = path
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)
    return texels


@pytest.mark.slow
def test_an_images_straight_alpha_renders_as_in_cycles(primer, tmp_path):
    """A straight-alpha PNG on five planes, one per case of ALPHA_CASES, each an Emission of the image's Color (Closest)
    with Strength its Alpha where that is used: Cycles associates the colours (in bytes) of an sRGB image with Alpha
    Straight and divides them back where the Alpha output is used, keeps them straight for Non-Color and Channel
    Packed, and reads alpha 1 for None. Primer renders each texel (4 x 4 pixels, box filter) as Cycles does, where
    reading OpenImageIO's premultiplied colours it was off by up to 0.6 (the Non-Color plane)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 16 * len(ALPHA_CASES), 16, 100
    scene.world = bpy.data.worlds.new("Black")
    scene.world.color = (0.0, 0.0, 0.0)
    path = str(tmp_path / "straight.png")
    texels = straight_alpha_png(path)
    for k, (space, mode, alpha_used) in enumerate(ALPHA_CASES):
        image = bpy.data.images.load(path, check_existing=False)
        image.colorspace_settings.name = space
        image.alpha_mode = mode
        m, tree, output = empty_material(f"Alpha {k}")
        texture = tree.nodes.new("ShaderNodeTexImage")
        texture.image, texture.interpolation = image, "Closest"
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(texture.outputs["Color"], emission.inputs["Color"])
        if alpha_used:
            tree.links.new(texture.outputs["Alpha"], emission.inputs["Strength"])
        tree.links.new(emission.outputs[0], output.inputs["Surface"])
        bpy.ops.mesh.primitive_plane_add(size=2.0, location=(2.0 * k, 0.0, 0.0))
        bpy.context.object.data.materials.append(m)
    bpy.ops.object.camera_add(location=(len(ALPHA_CASES) - 1.0, 0.0, 5.0))
    camera = bpy.context.object
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.0 * len(ALPHA_CASES)
    scene.camera = camera
    mine = render_pixels(scene, "PRIMER", str(tmp_path / "primer.exr"), 4)
    cycles = render_pixels(scene, "CYCLES", str(tmp_path / "cycles.exr"), 4, True)
    worst = []
    for k in range(len(ALPHA_CASES)):
        here = (slice(None), slice(16 * k, 16 * (k + 1)), slice(0, 3))
        worst.append(float(np.abs(mine[here] - cycles[here]).max()))
    assert max(worst) < 1e-5, dict(zip([str(case) for case in ALPHA_CASES], worst))
    textures = sys.modules[primer.__name__ + ".core.materials.textures"]
    c = np.repeat(np.repeat(texels.astype(np.float64) / 255.0, 4, 0), 4, 1)     # each texel on 4 x 4 pixels
    np.testing.assert_allclose(mine[:, 0:16, :3], c[..., :3] * c[..., 3:], atol=1e-6)      # Non-Color: straight x a
    np.testing.assert_allclose(mine[:, 64:80, :3], textures.srgb_to_linear(c[..., :3]), atol=1e-6)   # None: a = 1


def test_udim_tiles_and_sequence_frames_read_alpha_by_the_same_rule(primer, tmp_path):
    """A UDIM image's tiles and a sequence's frames are read as a plain file is (no render): sRGB with Alpha Straight
    associated in bytes (textures.associated), Non-Color straight as stored, Alpha None with alpha 255; and a
    generated byte image (Blender's buffer, which Cycles' BlenderImageLoader associates in bytes too) likewise."""
    materials_ = sys.modules[primer.__name__ + ".addon.materials"]
    textures = sys.modules[primer.__name__ + ".core.materials.textures"]
    texels = straight_alpha_png(str(tmp_path / "tiles.1001.png"))
    straight_alpha_png(str(tmp_path / "frames_001.png"))
    ignored = texels.copy()
    ignored[..., 3] = 255
    for space, mode, expected in (("sRGB", "STRAIGHT", textures.associated(texels)), ("Non-Color", "STRAIGHT", texels),
                                  ("sRGB", "NONE", ignored)):
        tiled = bpy.data.images.load(str(tmp_path / "tiles.1001.png"), check_existing=False)
        tiled.source = "TILED"
        frames = bpy.data.images.load(str(tmp_path / "frames_001.png"), check_existing=False)
        frames.source = "SEQUENCE"
        for image in (tiled, frames):
            image.colorspace_settings.name = space
            image.alpha_mode = mode
        materials_.begin_export()
        np.testing.assert_array_equal(materials_._read_pixels(tiled, tile=1001), expected)
        np.testing.assert_array_equal(materials_._read_pixels(frames, frame=1), expected)
        generated = bpy.data.images.new("Generated", 4, 4, alpha=True)
        generated.colorspace_settings.name = space        # (before its pixels: a new colour space regenerates them)
        generated.alpha_mode = mode
        generated.pixels.foreach_set((texels.astype(np.float32) / 255.0).reshape(-1))
        np.testing.assert_allclose(materials_._read_pixels(generated), expected / 255.0, atol=1e-7)
    assert (textures.associated(texels) != texels).any()
