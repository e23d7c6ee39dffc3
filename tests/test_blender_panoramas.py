"""Every panoramic camera of Cycles in real Blender (the bpy module): equirectangular (with a narrowed range), the
equiangular cube-map face, the mirror ball, the polynomial fisheye and the central cylinder look in the same
directions in Primer as in Cycles. No mocks.

The scene is only a world: an Environment Texture of a smooth, direction-coding image (red grows with the
longitude, green with the latitude, blue is a band), so each pixel's colour says where its camera rays looked. A
camera turned off the axes renders it with both engines (32 x 16 pixels, 32 samples, box filter); pixels agree
within 2 % of the image's range except where a colour jumps (the image's seam) and at the edge of a mirror ball or a
fisheye's field of view, where a pixel is part inside and part black.
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
from render import configure_cycles_reference, load_primer  # noqa: E402

from test_blender_denoise import addon, render_image  # noqa: E402

pytestmark = pytest.mark.blender

WIDTH, HEIGHT, SAMPLES = 32, 16, 32
CASES = {
    "EQUIRECTANGULAR": {"longitude_min": -2.0, "longitude_max": 1.5, "latitude_min": -1.0, "latitude_max": 1.2},
    "EQUIANGULAR_CUBEMAP_FACE": {},
    "MIRRORBALL": {},
    "FISHEYE_LENS_POLYNOMIAL": {"fisheye_fov": math.radians(200.0)},
    "CENTRAL_CYLINDRICAL": {"central_cylindrical_range_u_min": -1.2, "central_cylindrical_range_u_max": 2.0,
                            "central_cylindrical_range_v_min": -0.8, "central_cylindrical_range_v_max": 1.1,
                            "central_cylindrical_radius": 1.3},
}


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def world_scene(panorama: str, settings: dict):
    """A world of a direction-coding image seen by a panoramic camera of type `panorama` with `settings`."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    w, h = 128, 64
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    pixels = np.ones((h, w, 4), np.float32)
    pixels[..., 0] = 0.5 + 0.5 * np.sin(2.0 * math.pi * u)[None, :]        # no seam in red
    pixels[..., 1] = v[:, None]
    pixels[..., 2] = 0.5 + 0.5 * np.cos(2.0 * math.pi * u)[None, :] * np.sin(math.pi * v)[:, None]
    image = bpy.data.images.new("Directions", w, h, float_buffer=True)
    image.pixels.foreach_set(pixels.ravel())
    image.pack()
    world = bpy.data.worlds.new("Directions")
    scene.world = world
    if world.node_tree is None:
        world.use_nodes = True
    tree = world.node_tree
    background = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBackground")
    environment = tree.nodes.new("ShaderNodeTexEnvironment")
    environment.image = image
    tree.links.new(environment.outputs["Color"], background.inputs["Color"])
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = "PANO"
    camera.data.panorama_type = panorama
    for name, value in settings.items():
        setattr(camera.data, name, value)
    camera.rotation_euler = (1.2, 0.3, 0.7)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False
    return scene


@pytest.mark.parametrize("panorama", list(CASES))
def test_a_panorama_looks_where_cycles_looks(primer, tmp_path, panorama):
    scene = world_scene(panorama, CASES[panorama])
    configure_cycles_reference(scene, SAMPLES)
    cycles = render_image(scene, str(tmp_path / "cycles.exr"))
    scene.render.engine = "PRIMER"
    scene.primer.samples = SAMPLES
    mine = render_image(scene, str(tmp_path / "primer.exr"))
    warnings = addon(primer, "engine").last_render.warnings
    assert not [w for w in warnings if "panorama" in w.lower()], warnings
    a, b = mine[..., :3], cycles[..., :3]
    # Pixels whose neighbourhood is smooth in Cycles' image: no seam, no edge of the image circle.
    padded = np.pad(b, ((1, 1), (1, 1), (0, 0)), mode="edge")
    step = np.max([np.abs(padded[1 + dy:1 + dy + HEIGHT, 1 + dx:1 + dx + WIDTH] - b).max(axis=-1)
                   for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    smooth = step < 0.25
    difference = np.abs(a - b).max(axis=-1)
    print(panorama, f"smooth pixels {smooth.mean():.2f}, max difference there {difference[smooth].max():.4f}, "
          f"median {np.median(difference[smooth]):.4f}")
    assert smooth.mean() > 0.5
    assert np.percentile(difference[smooth], 95) < 0.02 and np.median(difference[smooth]) < 0.01
    np.testing.assert_allclose(mine[..., 3], cycles[..., 3], atol=0.1)
