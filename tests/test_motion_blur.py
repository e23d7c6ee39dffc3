"""Camera motion blur (core/camera/motion.py, camera.py, camera.c), without Blender: closed forms and both kernels.

Each camera ray gets a time in the shutter, drawn through Cycles' inverse-CDF table of the shutter curve; the camera
is placed where it is at that time (its transforms decomposed and interpolated as Cycles does). A camera sliding
sideways at constant speed over a small emitter smears it into a streak as long as the slide plus the emitter, of
uniform brightness (a box shutter) that adds up to the emitter's own; a rolling shutter reads row r of H at
(r + 1) / H; a turn about the view axis interpolates to the rotation by the angle's share of the shutter.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.camera import camera as camera_
from core.camera import motion
from core.geometry import primitives
from core.sampling import sobol as sampling
from core.scene import Material, RenderSettings, Scene

# u on a fine regular grid: what the table does to the uniform numbers, free of noise.
GRID = (np.arange(1 << 18) + 0.5) / (1 << 18)
# The image: 32 x 8 pixels over 8 x 2 scene units (pixels 0.25 wide), looking down at the plane z = 0.
W, H, SCALE = 32, 8, 8.0
PIXEL = SCALE / W
SLIDE = 4.0                                     # the camera slides from x = -2 to x = 2 over the shutter


def down_at(x: float, y: float = 0.0) -> np.ndarray:
    """An orthographic camera's matrix 5 units above (x, y, 0), looking down -Z (local axes the world's)."""
    matrix = np.eye(4)
    matrix[:3, 3] = (x, y, 5.0)
    return matrix


def sliding_camera(shutter=None, steps: int = 3) -> Camera:
    """The orthographic camera sliding along +x by SLIDE over the shutter, `steps` motion steps (evenly spaced)."""
    positions = np.linspace(-0.5 * SLIDE, 0.5 * SLIDE, steps)
    return Camera(matrix_world=down_at(0.0), type="ORTHO", ortho_scale=SCALE, clip_start=0.1, clip_end=100.0,
                  shutter=shutter or motion.Shutter.box(), motion=tuple(down_at(x) for x in positions))


def emitter_scene(camera: Camera, width: float, height: float) -> Scene:
    """A black scene with one rectangle of radiance 1 (width x height, centred at the origin, facing the camera)."""
    scene = Scene(camera=camera)
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.ones(3)))
    scene.add_mesh(primitives.plane(width, height), materials=np.array([0]))
    return scene


def box_span() -> tuple[float, float]:
    """The first and last time a box shutter's table gives (Cycles' table starts about 1/256 late, ends as early)."""
    table = motion.shutter_table(np.ones(motion.CURVE_POINTS))
    return float(table[0]), float(table[-1])


def test_a_box_shutter_spreads_times_uniformly_over_cycles_span():
    """A box curve's table is Cycles' line (1 + 254 x) / 256 at x = (k + 1/2) / 256 (its first curve point weighs
    nothing): times uniform between 0.0058 and 0.9942, symmetric about the middle."""
    table = motion.shutter_table(np.ones(motion.CURVE_POINTS))
    x = (np.arange(motion.SHUTTER_TABLE_SIZE) + 0.5) / motion.SHUTTER_TABLE_SIZE
    np.testing.assert_allclose(table, (1.0 + 254.0 * x) / 256.0, rtol=0, atol=3e-7)
    times = motion.ray_times(motion.Shutter(table), GRID, np.zeros(len(GRID), np.int64), 1)
    first, last = box_span()
    assert first + last == pytest.approx(1.0, abs=1e-6)
    histogram, _ = np.histogram(times, bins=16, range=(first, last))
    np.testing.assert_allclose(histogram / len(GRID), 1.0 / 16, rtol=2e-3)


def test_a_ramp_shutter_curve_draws_times_with_its_density():
    """A curve rising linearly from 0 to 1 opens the shutter gradually: times drawn with density 2t (a share of
    t^2 before t)."""
    curve = np.linspace(0.0, 1.0, motion.CURVE_POINTS)
    times = motion.ray_times(motion.Shutter(motion.shutter_table(curve)), GRID, np.zeros(len(GRID), np.int64), 1)
    for t in (0.25, 0.5, 0.75):
        assert np.mean(times < t) == pytest.approx(t * t, abs=6e-3)


def test_a_rolling_shutter_reads_row_r_at_its_share_of_the_frame():
    """Rolling shutter, top row first: with Duration 0 row r of H is read at (r + 1) / H whatever the number; with
    Duration d the time is (t - 1/2) d + (row time - 1/2)(1 - d) + 1/2; both kernels alike."""
    u = np.random.default_rng(3).random(64)
    rows = np.arange(64) % H
    rolling = motion.Shutter.box(rolling=True, rolling_duration=0.0)
    np.testing.assert_array_equal(motion.ray_times(rolling, u, rows, H), (rows + 1.0) / H)
    blended = motion.ray_times(dataclasses.replace(rolling, rolling_duration=0.25), u, rows, H)
    plain = motion.ray_times(motion.Shutter.box(), u, rows, H)
    np.testing.assert_allclose(blended, (plain - 0.5) * 0.25 + ((rows + 1.0) / H - 0.5) * 0.75 + 0.5, atol=1e-15)
    camera = sliding_camera(dataclasses.replace(rolling, rolling_duration=0.25))
    pixels, first = np.arange(W * H, dtype=np.int64), np.zeros(W * H, np.int64)
    record = camera_.camera_record(camera, W, H, (1.0, 1.0), np.zeros(3))
    *_, times = camera_.compiled_rays(record, 9, W, H, pixels, first, 4, times=True)
    pixel, sample = render.sample_keys(pixels, 4, None)
    numbers = sampling.sample_2d(9, pixel, sample, dimension=motion.TIME_DIMENSION)[:, 0]
    np.testing.assert_array_equal(times, motion.ray_times(camera.shutter, numbers, pixel // W, H))


def test_a_turn_about_the_view_axis_interpolates_to_the_angles_share():
    """Three steps turning by -a/2, 0, a/2 about the axis and sliding: at time t the camera is turned by a (t - 1/2)
    and slid by (t - 1/2), exactly (spherical interpolation keeps the angle linear in time)."""
    def turned(angle, x):
        c, s = math.cos(angle), math.sin(angle)
        m = down_at(x)
        m[:2, :2] = [[c, -s], [s, c]]
        return m
    a = 1.2
    steps = motion.decompose([turned(-a / 2, -0.5), turned(0.0, 0.0), turned(a / 2, 0.5)])
    time = np.linspace(0.0, 1.0, 11)
    linear, eye = motion.interpolate(steps, time)
    for k, t in enumerate(time):
        expected = turned(a * (t - 0.5), t - 0.5)
        np.testing.assert_allclose(linear[k], expected[:3, :3], atol=1e-12)
        np.testing.assert_allclose(eye[k], expected[:3, 3], atol=1e-12)


def test_a_mirrored_and_sheared_step_comes_back_as_it_was():
    """Decomposition and composition invert each other at the steps themselves, for a camera matrix with Blender's
    flipped axis (a negative determinant) and a sheared parent's matrix."""
    flipped = down_at(1.0) @ np.diag([1.0, 1.0, -1.0, 1.0])
    sheared = down_at(-1.0)
    sheared[:3, :3] = [[1.0, 0.3, 0.0], [0.0, 1.0, 0.2], [0.1, 0.0, 1.0]]
    for matrix in (flipped, sheared):
        linear, eye = motion.interpolate(motion.decompose([matrix, matrix]), np.array([0.0, 0.7]))
        np.testing.assert_allclose(linear, np.broadcast_to(matrix[:3, :3], (2, 3, 3)), atol=1e-12)
        np.testing.assert_allclose(eye, np.broadcast_to(matrix[:3, 3], (2, 3)), atol=1e-12)


def test_a_zoom_over_the_shutter_scales_the_image_plane_as_the_focal_length_at_that_time():
    """A perspective camera at 50 mm whose lens is 62.5 mm when the shutter opens and 40 mm when it closes: a ray at
    time 0 or 1 is the ray of a still camera with that lens; at 1/2 the 50 mm one's."""
    still = Camera(lens=50.0)
    zooming = dataclasses.replace(still, shutter=motion.Shutter.box(), motion=(np.eye(4),) * 3,
                                  fov_motion=(50.0 / 62.5, 50.0 / 40.0))
    x, y = np.array([3.3, 20.1, 31.0]), np.array([1.2, 7.7, 5.0])
    for time, lens in ((0.0, 62.5), (0.5, 50.0), (1.0, 40.0)):
        moved = camera_.generate_rays(zooming, W, H, x, y, time=np.full(3, time))
        expected = camera_.generate_rays(dataclasses.replace(still, lens=lens), W, H, x, y)
        np.testing.assert_allclose(moved.directions, expected.directions, atol=1e-14)
        np.testing.assert_allclose(moved.t_max, expected.t_max, rtol=1e-13)


def test_a_sliding_camera_smears_a_small_emitter_into_a_uniform_streak():
    """The camera slides SLIDE = 4 over the shutter above a 1-unit-wide emitter of radiance 1: its image slides over
    D = 4 (t1 - t0) (the box table's span), so the streak covers exactly the pixels within D/2 + 1/2 of the centre,
    is uniform at 1 / D where every position of the emitter covers the pixel's whole width, and each row adds up
    to the emitter's width in pixels (4): motion blur moves light, it does not make or lose it."""
    first, last = box_span()
    travel = SLIDE * (last - first)
    scene = emitter_scene(sliding_camera(), 1.0, 1.0)
    image = render.render(scene, RenderSettings(width=W, height=H, samples=1024, adaptive=False)).image[..., 0]
    rows = image[2:6]                                   # rows fully covered by the emitter's height
    left = -0.5 * SCALE + PIXEL * np.arange(W)          # each column's left edge in the image, scene units
    outside = (left + PIXEL <= -0.5 * travel - 0.5) | (left >= 0.5 * travel + 0.5)
    assert np.all(rows[:, outside] == 0.0) and np.all(rows[:, ~outside] > 0.0)
    assert np.count_nonzero(~outside) == 20
    assert np.all(image[[0, 1, 6, 7]] == 0.0)
    interior = (left >= -0.5 * travel + 0.5) & (left + PIXEL <= 0.5 * travel - 0.5)
    assert np.count_nonzero(interior) == 10
    assert rows[:, interior].mean() == pytest.approx(1.0 / travel, rel=0.02)
    assert np.abs(rows[:, interior] / (1.0 / travel) - 1.0).max() < 0.2       # (1024 samples: 5% noise a pixel)
    np.testing.assert_allclose(rows.sum(axis=1), 1.0 / PIXEL, rtol=0.02)


def test_a_rolling_shutter_shears_a_vertical_strip_by_the_rows_times():
    """With a rolling shutter of Duration 0 each row sees the still emitter where the camera is at its time: a
    vertical strip's image in row r is centred at -x(t_r) = 2 - 4 (r + 1) / H, the rows' centroids."""
    camera = sliding_camera(motion.Shutter.box(rolling=True, rolling_duration=0.0))
    scene = emitter_scene(camera, 0.5, 4.0)
    image = render.render(scene, RenderSettings(width=W, height=H, samples=64, adaptive=False)).image[..., 0]
    centres = -0.5 * SCALE + PIXEL * (np.arange(W) + 0.5)
    centroid = (image * centres).sum(axis=1) / image.sum(axis=1)
    expected = 0.5 * SLIDE - SLIDE * (np.arange(H) + 1.0) / H
    np.testing.assert_allclose(centroid, expected, atol=0.01)


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO", "PANO"])
def test_both_kernels_place_a_moving_camera_alike(kind):
    """Turning, sliding and zooming cameras of every kind, with a rolling shutter and a ramp curve: camera.c's rays
    and times are the reference's to float64 rounding."""
    def step(angle, x):
        c, s = math.cos(angle), math.sin(angle)
        m = down_at(x, 0.3)
        m[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
        return m
    shutter = motion.Shutter(motion.shutter_table(np.linspace(0.2, 1.0, motion.CURVE_POINTS)), rolling=True,
                             rolling_duration=0.4)
    camera = Camera(matrix_world=step(0.0, 0.0), type=kind, panorama_type="EQUIRECTANGULAR", shutter=shutter,
                    motion=tuple(step(a, x) for a, x in ((-0.4, -1.0), (-0.1, -0.2), (0.0, 0.0), (0.5, 0.3),
                                                         (0.9, 1.5))),
                    fov_motion=(0.9, 1.2), aperture_size=0.02 if kind != "PANO" else 0.0)
    origin = np.array([0.2, -0.1, 4.0])
    pixels, first = np.arange(W * H, dtype=np.int64), np.full(W * H, 3, np.int64)
    record = camera_.camera_record(camera, W, H, (1.0, 1.0), origin)
    O, D, t_max, valid, times = camera_.compiled_rays(record, 5, W, H, pixels, first, 4, times=True)
    pixel, sample = render.sample_keys(pixels, 4, first)
    numbers = sampling.sample_2d(5, pixel, sample, dimension=motion.TIME_DIMENSION)[:, 0]
    time = motion.ray_times(shutter, numbers, pixel // W, H)
    offset = sampling.sample_2d(5, pixel, sample, dimension=0)
    lens = sampling.sample_2d(5, pixel, sample, dimension=camera_.LENS_DIMENSION)
    rays = camera_.generate_rays(camera.moved(origin), W, H, pixel % W + offset[:, 0], pixel // W + offset[:, 1],
                                 lens=lens if kind != "PANO" else None, time=time)
    np.testing.assert_array_equal(times, time)
    np.testing.assert_allclose(O, rays.origins, rtol=0, atol=1e-13)
    np.testing.assert_allclose(D, rays.directions, rtol=0, atol=1e-14)
    np.testing.assert_allclose(t_max, rays.t_max, rtol=1e-14)


def test_both_kernels_render_a_moving_camera_alike():
    """The sliding camera over the emitter: the compiled render is the reference's."""
    scene = emitter_scene(sliding_camera(motion.Shutter.box(rolling=True, rolling_duration=0.5)), 1.0, 1.0)
    settings = RenderSettings(width=W, height=H, samples=16, adaptive=False)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled" and reference.stats.kernels.startswith("numpy")
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
