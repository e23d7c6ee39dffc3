"""Cycles' pixel filter in real Blender (the bpy module): a sharp edge rendered by Cycles and by Primer with
Render > Film > Pixel Filter's Blackman-Harris and Gaussian, 1.5 px, blurs across the same pixels by the same
amounts. No mocks.

The scene: an emissive plane (strength 1) covering the right of an orthographic view, its edge 0.3 px into a pixel,
over a black world. A pixel's value is the share of its samples that land right of the edge; every sample weighs 1
and lands where the filter's density puts it, so the profile across the edge is, in closed form,
1 - F(edge - pixel centre) with F the filter's CDF (core/camera/filter.py filter_density).
"""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import configure_cycles_reference, load_primer  # noqa: E402

from test_blender_denoise import addon, render_image  # noqa: E402
from core.camera.filter import filter_density  # noqa: E402

pytestmark = pytest.mark.blender

WIDTH, HEIGHT = 24, 4
PIXEL = 0.1                     # scene units per pixel (ortho_scale / WIDTH)
EDGE = 12.3                     # the edge's raster x: 0.3 px into pixel 12
SAMPLES = 1024


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def edge_scene():
    """An emissive plane right of x = EDGE (raster), seen straight down by an orthographic camera; black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    edge = (EDGE - WIDTH / 2) * PIXEL
    mesh = bpy.data.meshes.new("Lit half")
    mesh.from_pydata([(edge, -5.0, 0.0), (10.0, -5.0, 0.0), (10.0, 5.0, 0.0), (edge, 5.0, 0.0)], [], [(0, 1, 2, 3)])
    material = bpy.data.materials.new("Glow")
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    mesh.materials.append(material)
    plane = bpy.data.objects.new("Lit half", mesh)
    scene.collection.objects.link(plane)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = WIDTH * PIXEL
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = None                                       # black, in both renderers
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False
    return scene


def profile(scene, engine: str, kind: str, path: str) -> np.ndarray:
    """The mean of each column's pixels (WIDTH,) rendered by `engine` with the pixel filter `kind`, 1.5 px."""
    if engine == "CYCLES":
        configure_cycles_reference(scene, SAMPLES)          # (sets a box: the filter is set again below)
    else:
        scene.render.engine = "PRIMER"
        scene.primer.samples = SAMPLES
    scene.cycles.pixel_filter_type = kind
    scene.cycles.filter_width = 1.5
    return render_image(scene, path, reference=True)[..., 0].mean(axis=0)


def closed_form(kind: str) -> np.ndarray:
    """1 - F(EDGE - centre) for each column: the share of the filter's density right of the edge, (WIDTH,)."""
    fine = np.linspace(-3.0, 3.0, 60001)
    cdf = np.cumsum(filter_density(kind, 1.5, fine)) * (fine[1] - fine[0])
    return 1.0 - np.interp(EDGE - (np.arange(WIDTH) + 0.5), fine, cdf)


@pytest.mark.parametrize("kind", ["BLACKMAN_HARRIS", "GAUSSIAN"])
def test_an_edge_blurs_across_the_pixels_as_in_cycles(primer, tmp_path, kind):
    """Primer's and Cycles' profiles across the edge (1024 samples, 4 rows) agree within 0.004 per pixel (measured:
    0.0010 Blackman-Harris, 0.0005 Gaussian), both follow the filter's closed form (within 0.0005 and 0.0010), no
    note is given, and the blur reaches the pixels a box would leave alone."""
    scene = edge_scene()
    mine = profile(scene, "PRIMER", kind, str(tmp_path / "primer.exr"))
    warnings = addon(primer, "engine").last_render.warnings
    cycles = profile(scene, "CYCLES", kind, str(tmp_path / "cycles.exr"))
    expected = closed_form(kind)
    print(f"{kind}: Primer {np.round(mine[9:16], 4)}\n Cycles {np.round(cycles[9:16], 4)}\n closed form "
          f"{np.round(expected[9:16], 4)}; max |Primer - Cycles| {np.abs(mine - cycles).max():.4f}, "
          f"|Primer - closed form| {np.abs(mine - expected).max():.4f}, |Cycles - closed form| "
          f"{np.abs(cycles - expected).max():.4f}")
    assert not [w for w in warnings if "filter" in w], warnings
    np.testing.assert_allclose(mine, cycles, rtol=0, atol=0.004)
    np.testing.assert_allclose(mine, expected, rtol=0, atol=0.004)
    assert 0.01 < mine[11] < 0.5                # a box leaves it 0: the edge is in pixel 12
