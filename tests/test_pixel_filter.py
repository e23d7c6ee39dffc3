"""The pixel filter (core/camera/filter.py): Cycles' inverse-CDF table draws each camera sample's position from the
filter's density. Closed forms: the drawn positions' histogram is the normalised Blackman-Harris / Gaussian / box
density, the footprint scales with the width, a 1-pixel box leaves the uniform point where it is; and both
kernels give the same camera rays and renders with a filter."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.camera import camera as camera_
from core.camera.filter import FILTER_TABLE_SIZE, PixelFilter, filter_density, filter_table, offsets
from core.geometry import primitives
from core.sampling import sobol as sampling
from core.scene import PointLight, RenderSettings, Scene

# u on a fine regular grid: the drawn positions' histogram is then the table's own density, free of noise.
GRID = (np.arange(1 << 20) + 0.5) / (1 << 20)


def drawn_histogram(kind: str, width: float, bins: int):
    """Return (bin centres, histogram density) of the offsets from the pixel's centre the table draws on GRID."""
    half = 0.5 * width * {"BOX": 1.0, "GAUSSIAN": 3.0, "BLACKMAN_HARRIS": 2.0}[kind]
    x = offsets(PixelFilter(kind, width).table(), GRID) - 0.5
    histogram, edges = np.histogram(x, bins=bins, range=(-half, half), density=True)
    return 0.5 * (edges[1:] + edges[:-1]), histogram


@pytest.mark.parametrize("kind", ["BLACKMAN_HARRIS", "GAUSSIAN"])
def test_drawn_positions_have_the_filters_normalised_density(kind):
    """Histogram of the positions drawn through the table = the closed-form density, normalised over its footprint
    (within 1.5% of the peak per bin of a 30th of the footprint; the table is 1024 linear pieces)."""
    centres, histogram = drawn_histogram(kind, 1.5, 30)
    density = filter_density(kind, 1.5, centres)
    assert np.abs(histogram - density).max() < 0.015 * density.max()


def test_the_box_table_is_the_uniform_density_over_its_width():
    """A Box 2 pixels wide (Cycles' standalone box; Blender's is always 1 wide) draws uniformly over [-1, 1]."""
    centres, histogram = drawn_histogram("BOX", 2.0, 16)
    np.testing.assert_allclose(histogram, 0.5, rtol=5e-3)


@pytest.mark.parametrize("kind", ["BLACKMAN_HARRIS", "GAUSSIAN", "BOX"])
def test_the_footprint_scales_with_the_width(kind):
    """Offsets from the centre for width 2w are twice those for w (up to float32 rounding of the table; but the
    last 1/1023 of u, folded back towards the corner by the table's last entry, 0 at any width); every position
    lies within the footprint: |x| <= w/2 (box), w (Blackman-Harris), 1.5 w (Gaussian)."""
    narrow = offsets(filter_table(kind, 0.75).astype(np.float64), GRID) - 0.5
    wide = offsets(filter_table(kind, 1.5).astype(np.float64), GRID) - 0.5
    unfolded = GRID <= (FILTER_TABLE_SIZE - 2) / (FILTER_TABLE_SIZE - 1)
    np.testing.assert_allclose(wide[unfolded], 2.0 * narrow[unfolded], rtol=0, atol=2e-6)
    half = 0.5 * 1.5 * {"BOX": 1.0, "GAUSSIAN": 3.0, "BLACKMAN_HARRIS": 2.0}[kind]
    assert np.abs(wide).max() <= half * (1 + 1e-6)
    assert PixelFilter(kind, 1.5).reach == pytest.approx(max(0.0, half - 0.5))


def test_the_table_is_symmetric_with_its_last_entry_zero_as_cycles_leaves_it():
    """Entries half - j and half + j lie either side of the centre 0.5; entry 0 and entry 1022 are the footprint's
    edges; the last entry is never written by Cycles' inversion (an even table size) and stays 0."""
    table = filter_table("BLACKMAN_HARRIS", 1.5).astype(np.float64)
    assert len(table) == FILTER_TABLE_SIZE == 1024
    half = (FILTER_TABLE_SIZE - 1) // 2
    np.testing.assert_allclose(table[half:FILTER_TABLE_SIZE - 1] - 0.5, 0.5 - table[half::-1], atol=1e-6)
    assert table[0] == -1.0 and table[FILTER_TABLE_SIZE - 2] == 2.0 and table[-1] == 0.0


def test_a_one_pixel_box_leaves_the_uniform_point_where_it_is():
    """Blender's Box filter (always 1 pixel wide): the sample's uniform point in its pixel is its position, bit for
    bit, and the compiled camera gets no table."""
    box = PixelFilter("BOX", 1.0)
    u = sampling.sample_2d(3, np.arange(64), np.arange(64), 0)
    assert box.is_identity and box.positions(u) is u and box.reach == 0.0
    record = camera_.camera_record(Camera(), 8, 8, (1.0, 1.0), np.zeros(3), box)
    assert not record.filter_table


def test_lookup_matches_cycles_linear_interpolation():
    """lookup_table_read: u = k / (size - 1) gives entry k itself, a point between two entries their blend."""
    table = PixelFilter("GAUSSIAN", 1.5).table()
    k = np.arange(FILTER_TABLE_SIZE)
    np.testing.assert_array_equal(offsets(table, k / (FILTER_TABLE_SIZE - 1.0)), table)
    mid = offsets(table, (k[:-1] + 0.25) / (FILTER_TABLE_SIZE - 1.0))
    np.testing.assert_allclose(mid, 0.75 * table[:-1] + 0.25 * table[1:], rtol=0, atol=1e-12)
    assert offsets(table, np.array([-0.5, 1.5])).tolist() == [table[0], table[-1]]


@pytest.mark.parametrize("kind", ["BLACKMAN_HARRIS", "GAUSSIAN"])
@pytest.mark.parametrize("camera_type", ["PERSP", "FISHEYE_EQUISOLID"])
def test_both_kernels_give_the_same_filtered_camera_rays(kind, camera_type):
    """camera.c's table lookup and the Python reference's: the same rays to float64 rounding."""
    camera = Camera.look_at((0.0, -4.0, 1.0), (0.0, 0.0, 0.5))
    if camera_type != "PERSP":
        camera = dataclasses.replace(camera, type="PANO", panorama_type=camera_type, fisheye_fov=math.radians(170))
    W, H, seed, spp = 20, 14, 7, 5
    pixel_filter = PixelFilter(kind, 1.5)
    pixels = np.arange(0, W * H, 2, dtype=np.int64)
    first = (pixels % 3).astype(np.int64)
    origin = np.array([0.25, 0.5, -1.0])
    record = camera_.camera_record(camera, W, H, (1.0, 1.0), origin, pixel_filter)
    O, D, t, valid = camera_.compiled_rays(record, seed, W, H, pixels, first, spp)
    pixel, sample = render.sample_keys(pixels, spp, first)
    offset = pixel_filter.positions(sampling.sample_2d(seed, pixel, sample, 0))
    assert (offset < 0).any() and (offset > 1).any()                 # samples land in the neighbours
    rays = camera_.generate_rays(camera.moved(origin), W, H, pixel % W + offset[:, 0], pixel // W + offset[:, 1])
    np.testing.assert_array_equal(valid, rays.valid)
    np.testing.assert_allclose(O[valid], rays.origins[valid], rtol=0, atol=1e-13)
    np.testing.assert_allclose(D[valid], rays.directions[valid], rtol=0, atol=1e-14)


def test_both_kernels_render_a_filtered_image_alike():
    """A lit sphere on a floor with Blackman-Harris 1.5 px: the same samples and image on both kernels (lamps
    without extent: bit for bit), and a different image from the box's (the filter reaches the pixels)."""
    scene = Scene(camera=Camera.look_at((0.5, -5.0, 3.0), (0.0, 0.0, 0.4), fov=math.radians(45)))
    scene.add_material((0.8, 0.7, 0.6))
    scene.add_mesh(primitives.plane(8.0), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.8, 12, 6, center=(0.0, 0.0, 0.8), smooth=True), materials=np.array([0]))
    scene.lights = [PointLight(np.array([1.0, -1.5, 3.0]), power=400.0)]
    settings = RenderSettings(width=32, height=24, samples=4, pixel_filter="BLACKMAN_HARRIS", filter_width=1.5)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled" and reference.stats.kernels.startswith("numpy")
    np.testing.assert_array_equal(compiled.image, reference.image)
    box = render.render(scene, dataclasses.replace(settings, pixel_filter="BOX", filter_width=1.0))
    assert not np.array_equal(box.image, compiled.image)


def test_an_unknown_filter_is_refused():
    """A filter type outside Cycles' three, or a width of 0, is a ValueError naming it."""
    scene = Scene(camera=Camera())
    with pytest.raises(ValueError, match="pixel filter"):
        render.render(scene, RenderSettings(width=4, height=4, pixel_filter="MITCHELL"))
    with pytest.raises(ValueError, match="width"):
        render.render(scene, RenderSettings(width=4, height=4, pixel_filter="GAUSSIAN", filter_width=0.0))


def test_a_fisheye_skips_only_pixels_whose_filtered_samples_all_miss_the_image_circle():
    """With Blackman-Harris 1.5 px, samples of a pixel just outside the image circle land inside it: such a pixel is
    rendered (not taken as black), and every pixel taken as black has no sample inside the circle."""
    camera = Camera(type="PANO", panorama_type="FISHEYE_EQUIDISTANT", fisheye_fov=math.pi)
    W, H = 24, 16
    pixels = np.arange(W * H, dtype=np.int64)
    pixel_filter = PixelFilter("BLACKMAN_HARRIS", 1.5)
    skipped = camera_.outside_image_circle(camera, W, H, pixels, reach=pixel_filter.reach)
    unfiltered = camera_.outside_image_circle(camera, W, H, pixels)
    assert skipped.sum() < unfiltered.sum() and not (skipped & ~unfiltered).any()
    pixel, sample = render.sample_keys(pixels, 256, None)
    offset = pixel_filter.positions(sampling.sample_2d(1, pixel, sample, 0))
    rays = camera_.generate_rays(camera, W, H, pixel % W + offset[:, 0], pixel // W + offset[:, 1])
    any_inside = rays.valid.reshape(W * H, 256).any(axis=1)
    assert not (skipped & any_inside).any()
    assert (unfiltered & any_inside).any()                  # the pixels the box's test would wrongly leave black
