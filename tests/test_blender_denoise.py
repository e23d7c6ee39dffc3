"""Render > Denoise inside real Blender (the bpy module): the passes, the compositor set-up, and that
Blender's Denoise node fed with them brings a noisy render closer to a converged one. No mocks."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from render import configure_output, load_primer  # noqa: E402

from blender_env import diffuse_material, render_still  # noqa: E402

from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def addon(primer, name: str):
    """Return the add-on's module `name` (engine, compositor)."""
    return sys.modules[primer.__name__ + ".addon." + name]


def plane_scene(width=32, height=24, color=(0.2, 0.5, 0.7)):
    """Start from an empty file: a plane of `color` (Lambert) under a sun, seen from straight above."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.primer.samples = 2
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(diffuse_material("Plane colour", color))
    scene.collection.objects.link(bpy.data.objects.new("Plane", mesh))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 2.0
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


def noisy_scene(width=64, height=48):
    """A sphere on a plane under a large area light, one light sample per camera sample: noisy at few samples."""
    scene = plane_scene(width, height, color=(0.8, 0.8, 0.8))
    scene.objects["Sun"].data.energy = 0.0
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0.0, 0.0, 1.0))
    light = bpy.data.objects.new("Area", bpy.data.lights.new("Area", "AREA"))
    light.data.energy, light.data.size = 300.0, 3.0
    light.location = (1.5, -1.0, 4.0)
    scene.collection.objects.link(light)
    camera = scene.camera
    camera.location, camera.rotation_euler = (0.0, -6.0, 4.0), (0.95, 0.0, 0.0)
    scene.primer.use_adaptive_sampling = False
    scene.primer.light_samples = 1
    return scene


def read_channels(path: str) -> dict:
    """Return the multilayer EXR's passes: pass name -> (channel names, (H, W, c) float32 rows top-down)."""
    import OpenImageIO as oiio
    passes: dict = {}
    inp = oiio.ImageInput.open(path)
    part = 0
    while inp.seek_subimage(part, 0):
        spec = inp.spec()
        pixels = inp.read_image(part, 0, 0, spec.nchannels, oiio.FLOAT).reshape(spec.height, spec.width, -1)
        for c, name in enumerate(spec.channelnames):
            *_, layer_pass, channel = name.split(".")
            names, planes = passes.setdefault(layer_pass, ([], []))
            names.append(channel)
            planes.append(pixels[..., c])
        part += 1
    inp.close()
    return {name: (channels, np.stack(planes, axis=-1)) for name, (channels, planes) in passes.items()}


def render_image(scene, path: str, multilayer: bool = False, reference: str | None = None) -> np.ndarray:
    """Render with write_still into a float EXR (multilayer: every pass) and return what was written; Cycles'
    image with a `reference` label is the committed one while its key matches (blender_env.render_pixels)."""
    from core.film import image_io
    scene.render.image_settings.media_type = "IMAGE"
    configure_output(scene, path)
    if multilayer:
        scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    render_still(scene, path, reference)
    return read_channels(path) if multilayer else image_io.read_image(path)


def links_of(tree) -> set:
    """Return the tree's links as (from node, from socket, to node, to socket) names."""
    return {(link.from_node.name, link.from_socket.name, link.to_node.name, link.to_socket.name) for link in tree.links}


def test_denoising_passes_hold_the_plane_albedo_and_normal_with_cycles_channels(primer, tmp_path):
    """Denoising Albedo (R, G, B) is the Lambert plane's base colour, Denoising Normal (X, Y, Z) its normal +Z."""
    scene = plane_scene()
    scene.primer.use_denoising = True
    passes = render_image(scene, str(tmp_path / "passes.exr"), multilayer=True)
    channels, albedo = passes["Denoising Albedo"]
    assert channels == ["R", "G", "B"]
    np.testing.assert_allclose(albedo, np.broadcast_to([0.2, 0.5, 0.7], albedo.shape), atol=1e-5)
    channels, normal = passes["Denoising Normal"]
    assert channels == ["X", "Y", "Z"]
    np.testing.assert_allclose(normal, np.broadcast_to([0.0, 0.0, 1.0], normal.shape), atol=1e-5)
    assert addon(primer, "engine").last_render.warnings == []


def test_denoising_passes_are_only_written_when_denoise_is_on(primer, tmp_path):
    """Without Denoise, no Denoising passes."""
    passes = render_image(plane_scene(), str(tmp_path / "plain.exr"), multilayer=True)
    assert "Denoising Albedo" not in passes and "Denoising Normal" not in passes


def test_ticking_denoise_puts_a_denoise_node_fed_by_the_passes_into_the_compositor_and_unticking_removes_it(primer):
    """Render Layers -> Denoise (Image, Albedo, Normal) -> the output; unticked, Render Layers -> the output again."""
    compositor = addon(primer, "compositor")
    scene = plane_scene()
    scene.primer.use_denoising = True
    tree = compositor.compositor_tree(scene)
    output = next(node.name for node in tree.nodes
                  if node.bl_idname in ("NodeGroupOutput", "CompositorNodeComposite"))
    denoise = compositor.DENOISE_NODE
    assert {("Render Layers", "Image", denoise, "Image"), ("Render Layers", "Denoising Albedo", denoise, "Albedo"),
            ("Render Layers", "Denoising Normal", denoise, "Normal"),
            (denoise, "Image", output, "Image")} <= links_of(tree)
    assert scene.render.use_compositing and compositor.problems(scene) == []
    scene.primer.use_denoising = False
    assert not any(node.bl_idname == "CompositorNodeDenoise" for node in tree.nodes)
    assert ("Render Layers", "Image", output, "Image") in links_of(tree)


def test_a_tree_with_two_render_layers_nodes_is_left_alone_with_a_warning(primer, tmp_path):
    """Primer cannot tell which Render Layers node to denoise: it changes nothing, and the render says so."""
    compositor = addon(primer, "compositor")
    scene = plane_scene()
    tree = compositor.compositor_tree(scene, create=True)
    tree.nodes.new("CompositorNodeRLayers")
    before = links_of(tree)
    assert "2 Render Layers nodes" in compositor.set_up(scene)
    assert links_of(tree) == before
    scene.primer.use_denoising = True
    render_image(scene, str(tmp_path / "two.exr"))
    warnings = addon(primer, "engine").last_render.warnings
    assert any("no Denoise node" in warning for warning in warnings)


def test_denoise_with_compositing_off_renders_the_frame_and_warns(primer, tmp_path):
    """Compositing switched off: the frame is still rendered, with a warning that the Denoise node does not run."""
    scene = plane_scene()
    scene.primer.use_denoising = True
    scene.render.use_compositing = False
    image = render_image(scene, str(tmp_path / "off.exr"))
    assert image[..., :3].max() > 0.0
    assert any("Compositing is off" in warning for warning in addon(primer, "engine").last_render.warnings)


def test_denoised_low_sample_render_is_closer_to_a_converged_one(primer, tmp_path):
    """4 samples of an area-lit sphere: Blender's Denoise node fed with Primer's passes cuts the error against a
    256-sample render, per pixel and in 4 x 4 block means, by a margin."""
    compositor = addon(primer, "compositor")
    if not compositor.has_denoiser():
        pytest.skip("this Blender has no Open Image Denoise")
    scene = noisy_scene()
    scene.primer.samples = 256
    reference = render_image(scene, str(tmp_path / "reference.exr"))
    scene.primer.samples = 4
    noisy = render_image(scene, str(tmp_path / "noisy.exr"))
    scene.primer.use_denoising = True
    denoised = render_image(scene, str(tmp_path / "denoised.exr"))
    assert addon(primer, "engine").last_render.warnings == []
    pixel_noisy, pixel_denoised = relative_mse_of_blocks(noisy, reference, 1), relative_mse_of_blocks(denoised, reference, 1)
    block_noisy, block_denoised = relative_mse_of_blocks(noisy, reference), relative_mse_of_blocks(denoised, reference)
    assert pixel_denoised < 0.3 * pixel_noisy, (pixel_noisy, pixel_denoised)
    assert block_denoised < 0.8 * block_noisy, (block_noisy, block_denoised)


def test_a_file_saved_with_denoise_renders_denoised_when_opened_again(primer, tmp_path):
    """As `blender -b scene.blend -f 1` does: the set-up is saved with the file, no tick needed after opening it."""
    scene = noisy_scene(48, 36)
    scene.primer.samples = 4
    noisy = render_image(scene, str(tmp_path / "noisy.exr"))
    scene.primer.use_denoising = True
    path = str(tmp_path / "denoise.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    reopened = bpy.context.scene
    assert reopened.primer.use_denoising
    denoised = render_image(reopened, str(tmp_path / "reopened.exr"))
    assert addon(primer, "engine").last_render.warnings == []
    # The Denoise node ran: the composited image is smoother than the raw one (less pixel-to-pixel change).
    def roughness(image):
        return float(np.abs(np.diff(image[..., :3], axis=1)).mean())
    assert roughness(denoised) < 0.7 * roughness(noisy), (roughness(noisy), roughness(denoised))


def test_a_blender_without_open_image_denoise_is_warned_about_and_the_frame_still_renders(primer, tmp_path,
                                                                                          monkeypatch):
    """Where Blender was built without OIDN (its Denoise node passes images through), the report says so."""
    compositor = addon(primer, "compositor")
    assert compositor.has_denoiser()                # this bpy ships it (bpy/lib/libOpenImageDenoise*)
    monkeypatch.setattr(compositor, "has_denoiser", lambda: False)
    scene = plane_scene()
    scene.primer.use_denoising = True
    image = render_image(scene, str(tmp_path / "no_oidn.exr"))
    assert image[..., :3].max() > 0.0
    warnings = addon(primer, "engine").last_render.warnings
    assert any("without Open Image Denoise" in warning for warning in warnings)
