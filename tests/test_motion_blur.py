"""Camera motion blur (core/camera/motion.py, camera.py, camera.c), without Blender: closed forms and both kernels.

Each camera ray gets a time in the shutter, drawn through Cycles' inverse-CDF table of the shutter curve; the camera
is placed where it is at that time (its transforms decomposed and interpolated as Cycles does). A camera sliding
sideways at constant speed over a small emitter smears it into a streak as long as the slide plus the emitter, of
uniform brightness (a box shutter) that adds up to the emitter's own; a rolling shutter reads row r of H at
(r + 1) / H; a turn about the view axis interpolates to the rotation by the angle's share of the shutter.

Objects that move (Instance.motion) are traced as Embree motion instances at each ray's time: a ray at time t meets a
sliding square where it is then, a turning one where Cycles' interpolation puts it; a small emitter sliding under a
still camera smears as the camera's slide smeared it; the shadow of a sliding blocker is its time-averaged shadow.
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
from core.geometry.geometry import build_geometry
from core.lights import PointLight
from core.lights import emitters as emitters_
from core.materials.graph import GraphNode, Link
from core.sampling import sobol as sampling
from core.scene import Material, RenderSettings, Scene, SunLight

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


def placed(x: float, angle: float = 0.0) -> np.ndarray:
    """An object-to-world matrix: turned by `angle` about z, then moved to (x, 0, 0)."""
    c, s = math.cos(angle), math.sin(angle)
    matrix = np.eye(4)
    matrix[:2, :2] = [[c, -s], [s, c]]
    matrix[0, 3] = x
    return matrix


def moving_square_geometry(steps) -> object:
    """The WorldGeometry of a unit square at z = 0 moving through the matrices `steps` over the shutter."""
    scene = Scene(camera=Camera())
    scene.materials.append(Material(np.ones(3), "White"))
    scene.add_mesh(primitives.plane(1.0, 1.0), materials=np.array([0]))
    scene.instances[0].motion = tuple(steps)
    return build_geometry(scene, np.zeros(3), motion_blur=True)


def test_a_ray_meets_a_sliding_square_where_it_is_at_the_rays_time():
    """A unit square sliding from x = -2 to 2 over the shutter (three steps): a ray straight down at x and time t hits
    it exactly where |x - (4 t - 2)| < 1/2, at distance 5; its surface is the square placed at that time."""
    geometry = moving_square_geometry([placed(-2.0), placed(0.0), placed(2.0)])
    assert geometry.tracer.moving and len(geometry.instanced) == 1
    rng = np.random.default_rng(5)
    n = 4000
    x, time = rng.uniform(-3.0, 3.0, n), rng.uniform(0.0, 1.0, n)
    inside = np.abs(x - (4.0 * time - 2.0))
    clear = np.abs(inside - 0.5) > 1e-5                       # (rays on an edge: rounding decides)
    O = np.stack([x, np.zeros(n), np.full(n, 5.0)], axis=1)
    D = np.tile([0.0, 0.0, -1.0], (n, 1))
    hits = geometry.tracer.intersect(O, D, np.full(n, np.inf), time)
    np.testing.assert_array_equal(hits.hit[clear], (inside < 0.5)[clear])
    np.testing.assert_allclose(hits.t[hits.hit], 5.0, rtol=1e-6)
    blocked = geometry.tracer.occluded(O, D, np.full(n, 10.0), time)
    np.testing.assert_array_equal(blocked[clear], (inside < 0.5)[clear])
    corners = geometry.triangle_data(hits.prim[hits.hit], times=time[hits.hit]).corners
    np.testing.assert_allclose(corners[..., 0].mean(axis=1) - (4.0 * time[hits.hit] - 2.0), 0.0, atol=0.34)
    assert not moving_square_geometry([placed(1.0)] * 3).tracer.moving    # (steps all alike: still, no instance)


def test_a_turning_square_is_met_where_cycles_interpolation_places_it():
    """A square turning by -0.6, 0, 0.6 rad over five steps (Embree's quaternion motion of Cycles' decomposition):
    every hit at time t lies on the square placed by motion.interpolate at t (the rotation's angle linear in t), and
    the hit's barycentrics give that very point."""
    angles = np.linspace(-0.6, 0.6, 5)
    geometry = moving_square_geometry([placed(0.3, a) for a in angles])
    rng = np.random.default_rng(8)
    n = 3000
    xy, time = rng.uniform(-0.8, 0.8, (n, 2)), rng.uniform(0.0, 1.0, n)
    O = np.concatenate([xy + [0.3, 0.0], np.full((n, 1), 5.0)], axis=1)
    D = np.tile([0.0, 0.0, -1.0], (n, 1))
    hits = geometry.tracer.intersect(O, D, np.full(n, np.inf), time)
    angle = -0.6 + 1.2 * time
    c, s = np.cos(-angle), np.sin(-angle)
    local = np.stack([c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]], axis=1)   # (in the square's frame)
    inside = np.abs(local).max(axis=1)
    clear = np.abs(inside - 0.5) > 1e-4
    np.testing.assert_array_equal(hits.hit[clear], (inside < 0.5)[clear])
    on = np.flatnonzero(hits.hit)
    corners = geometry.triangle_data(hits.prim[on], times=time[on]).corners
    u, v = hits.u[on, None], hits.v[on, None]
    point = (1.0 - u - v) * corners[:, 0] + u * corners[:, 1] + v * corners[:, 2]
    np.testing.assert_allclose(point[:, :2], O[on, :2], atol=2e-6)


def sliding_emitter_scene(camera: Camera) -> Scene:
    """A 1 x 1 emitter of radiance 1 sliding by SLIDE along x over the shutter (three steps) under `camera`."""
    scene = emitter_scene(camera, 1.0, 1.0)
    scene.instances[0].motion = tuple(placed(x) for x in np.linspace(-0.5 * SLIDE, 0.5 * SLIDE, 3))
    return scene


def test_a_sliding_emitter_smears_into_a_uniform_streak():
    """The still camera over a 1-unit emitter sliding SLIDE = 4 over a box shutter: the streak of the sliding camera
    (test above) mirrored, exactly as long as the slide over the box table's span plus the emitter, uniform at
    1 / travel inside, each row adding up to the emitter's width in pixels; with the path tracer too. The render says
    nothing about motion blur."""
    first, last = box_span()
    travel = SLIDE * (last - first)
    camera = dataclasses.replace(sliding_camera(), motion=())
    for integrator in ("direct", "path"):
        result = render.render(sliding_emitter_scene(camera), RenderSettings(width=W, height=H, samples=1024,
                                                                              adaptive=False, integrator=integrator))
        assert not [w for w in result.stats.warnings if "motion blur" in w]
        image = result.image[..., 0]
        rows = image[2:6]
        left = -0.5 * SCALE + PIXEL * np.arange(W)
        outside = (left + PIXEL <= -0.5 * travel - 0.5) | (left >= 0.5 * travel + 0.5)
        assert np.all(rows[:, outside] == 0.0) and np.all(rows[:, ~outside] > 0.0)
        assert np.all(image[[0, 1, 6, 7]] == 0.0)
        interior = (left >= -0.5 * travel + 0.5) & (left + PIXEL <= 0.5 * travel - 0.5)
        assert rows[:, interior].mean() == pytest.approx(1.0 / travel, rel=0.02)
        np.testing.assert_allclose(rows.sum(axis=1), 1.0 / PIXEL, rtol=0.02)


def test_a_sliding_blocker_casts_its_time_averaged_shadow():
    """A white ground lit by a sun straight above, under a 1 x 8 blocker the camera does not see, sliding SLIDE = 4
    over the shutter: each ground point is lit the share of the shutter the blocker is not over it, so the shadow is
    a trapezoid in x whose deficit adds up, row by row, to the blocker's width (shadow rays carry their camera
    ray's time); no pixel far from the slide is shadowed."""
    first, last = box_span()
    travel = SLIDE * (last - first)
    camera = dataclasses.replace(sliding_camera(), motion=())
    scene = Scene(camera=camera)
    scene.materials.append(Material(np.ones(3), "White"))
    scene.add_mesh(primitives.plane(SCALE * 2, SCALE * 2), materials=np.array([0]))
    scene.add_mesh(primitives.plane(1.0, 8.0, center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    blocker = scene.instances[1]
    blocker.visible_camera = False
    blocker.motion = tuple(placed(x) for x in np.linspace(-0.5 * SLIDE, 0.5 * SLIDE, 3))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=math.pi))
    image = render.render(scene, RenderSettings(width=W, height=H, samples=256, adaptive=False)).image[..., 0]
    lit = 1.0                                          # albedo 1 / pi x irradiance pi
    left = -0.5 * SCALE + PIXEL * np.arange(W)
    far = (left + PIXEL <= -0.5 * travel - 0.5) | (left >= 0.5 * travel + 0.5)
    np.testing.assert_allclose(image[:, far], lit, rtol=1e-6)
    np.testing.assert_allclose(((lit - image) * PIXEL).sum(axis=1), 1.0, rtol=0.03)
    interior = (left >= -0.5 * travel + 0.5) & (left + PIXEL <= 0.5 * travel - 0.5)
    assert image[:, interior].mean() == pytest.approx(lit * (1.0 - 1.0 / travel), rel=0.01)


def test_a_scene_where_nothing_moves_builds_no_motion_instance():
    """Without Instance.motion (or with motion blur off) the geometry is the still scene's: copied triangles, no
    instance, no time in the queries."""
    scene = emitter_scene(sliding_camera(), 1.0, 1.0)
    geometry = build_geometry(scene, np.zeros(3), motion_blur=True)
    assert not geometry.tracer.moving and not geometry.instanced and len(geometry.triangles) == 2
    moving = sliding_emitter_scene(dataclasses.replace(sliding_camera(), motion=()))
    assert not build_geometry(moving, np.zeros(3), motion_blur=False).instanced


@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_both_kernels_render_moving_objects_alike(integrator):
    """A diffuse box sliding and turning over five steps under a sun (its image and its shadow blurred) and an
    emitting strip sliding the other way, seen by a perspective camera: the compiled render is the reference's."""
    camera = Camera(matrix_world=down_at(0.0), lens=20.0, clip_start=0.1, clip_end=100.0, shutter=motion.Shutter.box())
    scene = Scene(camera=camera)
    scene.materials.append(Material(np.full(3, 0.8), "White"))
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.array([2.0, 1.0, 0.5])))
    scene.add_mesh(primitives.plane(16.0, 16.0), materials=np.array([0]))
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.add_mesh(primitives.plane(0.5, 3.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    turns = zip(np.linspace(-2.0, 2.0, 5), np.linspace(-0.5, 0.5, 5))
    scene.instances[1].motion = tuple(placed(x, a) for x, a in turns)
    scene.instances[2].motion = tuple(placed(x) for x in np.linspace(1.0, -1.0, 3))
    travel = np.array([0.3, 0.2, -1.0])
    scene.lights.append(SunLight(travel / np.linalg.norm(travel), strength=2.0))
    settings = RenderSettings(width=W, height=H, samples=16, adaptive=False, integrator=integrator)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled" and reference.stats.kernels.startswith("numpy")
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
    still = render.render(dataclasses.replace(scene, camera=dataclasses.replace(camera, shutter=None)), settings)
    assert np.abs(still.image - compiled.image).max() > 0.1          # (the motion is seen)


def test_both_kernels_trace_shader_rays_and_transparent_shadows_at_the_paths_time():
    """A floor whose emission is its Ambient Occlusion, a box with a Bevel normal sliding and turning over it and a
    half-transparent sheet sliding through a point light's rays: the AO and Bevel rays, the transparent shadows and
    the bounces meet the moving objects where they are at each path's time, the same in both kernels."""
    occlusion = Link(GraphNode("AO", {"samples": 4}, {"Distance": 1.5}), "AO")
    bevelled = Link(GraphNode("BEVEL", {"samples": 4}, {"Radius": 0.2}), "Normal")
    camera = Camera(matrix_world=down_at(0.0), lens=20.0, clip_start=0.1, clip_end=100.0, shutter=motion.Shutter.box())
    scene = Scene(camera=camera)
    scene.materials.append(Material(name="Floor", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"color": (0.8, 0.8, 0.8)}),
                                                         ("EMISSION", (1.0, 1.0, 1.0), {"emission": occlusion})]))
    scene.materials.append(Material(name="Box", nodes=[("DIFFUSE", (1.0, 1.0, 1.0),
                                                        {"color": (0.9, 0.9, 0.9), "normal": bevelled})]))
    scene.materials.append(Material(name="Sheet", nodes=[("TRANSPARENT", (0.5, 0.5, 0.5), {})]))
    scene.add_mesh(primitives.plane(16.0, 16.0), materials=np.array([0]))
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(0.0, 0.0, 0.5)), materials=np.array([1]))
    scene.add_mesh(primitives.plane(1.0, 4.0, center=(0.0, 0.0, 2.5)), materials=np.array([2]))
    scene.instances[1].motion = tuple(placed(x, a) for x, a in zip(np.linspace(-2.0, 2.0, 3), (-0.4, 0.0, 0.4)))
    scene.instances[2].motion = tuple(placed(x) for x in np.linspace(1.5, -1.5, 3))
    scene.lights = [PointLight(np.array([0.5, 0.3, 4.0]), power=300.0)]
    settings = RenderSettings(width=W, height=H, samples=8, adaptive=False, integrator="path", max_bounces=2)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled" and not compiled.stats.warnings
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-5, atol=1e-6)
    still = render.render(dataclasses.replace(scene, camera=dataclasses.replace(camera, shutter=None)), settings)
    assert np.abs(still.image - compiled.image).max() > 0.1


def test_a_square_whose_vertices_slide_smears_as_a_sliding_square():
    """Deformation motion: a 1-unit emitter whose four vertices (not its transform) slide by SLIDE over the shutter
    (Instance.deformation, interpolated linearly as Cycles' motion vertices) smears into the sliding emitter's streak:
    uniform at 1 / travel inside, rows adding up to its width; both kernels alike, and a ray at time t meets it where
    the interpolated vertices put it."""
    first, last = box_span()
    travel = SLIDE * (last - first)
    scene = emitter_scene(dataclasses.replace(sliding_camera(), motion=()), 1.0, 1.0)
    square = np.asarray(scene.meshes[0].vertices, np.float64)
    scene.instances[0].deformation = tuple(square + [x, 0.0, 0.0] for x in np.linspace(-0.5 * SLIDE, 0.5 * SLIDE, 3))
    settings = RenderSettings(width=W, height=H, samples=1024, adaptive=False)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.warnings == []
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
    rows = compiled.image[2:6, :, 0]
    left = -0.5 * SCALE + PIXEL * np.arange(W)
    interior = (left >= -0.5 * travel + 0.5) & (left + PIXEL <= 0.5 * travel - 0.5)
    assert rows[:, interior].mean() == pytest.approx(1.0 / travel, rel=0.02)
    np.testing.assert_allclose(rows.sum(axis=1), 1.0 / PIXEL, rtol=0.02)
    geometry = build_geometry(scene, np.zeros(3), motion_blur=True)
    rng = np.random.default_rng(2)
    x, time = rng.uniform(-3.0, 3.0, 2000), rng.uniform(0.0, 1.0, 2000)
    O = np.stack([x, np.zeros(2000), np.full(2000, 5.0)], axis=1)
    hits = geometry.tracer.intersect(O, np.tile([0.0, 0.0, -1.0], (2000, 1)), np.full(2000, np.inf), time)
    inside = np.abs(x - (4.0 * time - 2.0))
    clear = np.abs(inside - 0.5) > 1e-5
    np.testing.assert_array_equal(hits.hit[clear], (inside < 0.5)[clear])


@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_both_kernels_render_a_moving_and_deforming_object_alike(integrator):
    """A box sliding over five steps while its top face is sheared by its vertices (transform and deformation motion
    together, the shear over three steps), under a sun over a white floor: the compiled render is the reference's."""
    camera = Camera(matrix_world=down_at(0.0), lens=20.0, clip_start=0.1, clip_end=100.0, shutter=motion.Shutter.box())
    scene = Scene(camera=camera)
    scene.materials.append(Material(np.full(3, 0.8), "White"))
    scene.add_mesh(primitives.plane(16.0, 16.0), materials=np.array([0]))
    box = primitives.box((1.0, 1.0, 1.0), center=(0.0, 0.0, 0.5))
    scene.add_mesh(box, materials=np.array([0]))
    points = np.asarray(box.vertices, np.float64)
    top = points[:, 2] > 0.75
    scene.instances[1].motion = tuple(placed(x) for x in np.linspace(-1.5, 1.5, 5))
    scene.instances[1].deformation = tuple(points + np.where(top[:, None], [s, 0.5 * s, 0.0], 0.0)
                                           for s in (-0.8, 0.0, 0.8))
    travel = np.array([0.3, 0.2, -1.0])
    scene.lights.append(SunLight(travel / np.linalg.norm(travel), strength=2.0))
    settings = RenderSettings(width=W, height=H, samples=16, adaptive=False, integrator=integrator)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
    rigid = dataclasses.replace(scene.instances[1], deformation=())
    unsheared = render.render(dataclasses.replace(scene, instances=[scene.instances[0], rigid]), settings)
    assert np.abs(unsheared.image - compiled.image).max() > 0.05        # (the deformation is seen)


def corner_form_factor(a: np.ndarray, b: np.ndarray, h: float) -> np.ndarray:
    """The form factor from a point to the rectangle [0, a] x [0, b] parallel to its plane, h above it, the point under
    the corner (0, 0) (a, b signed: the rectangle on that side)."""
    A, B = np.sqrt(a * a + h * h), np.sqrt(b * b + h * h)
    return (a / A * np.arctan(b / A) + b / B * np.arctan(a / B)) / (2.0 * math.pi)


def floor_under_a_sliding_emitter():
    """A white (albedo 0.8) floor under the still orthographic camera, lit only by a 1 x 1 emitter of radiance 4
    facing it from 1 above, hidden from the camera, sliding SLIDE along x over a box shutter (three steps)."""
    camera = dataclasses.replace(sliding_camera(), motion=())
    scene = Scene(camera=camera)
    scene.materials.append(Material(np.full(3, 0.8), "White"))
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.full(3, 4.0)))
    scene.add_mesh(primitives.plane(16.0, 16.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(1.0, 1.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    scene.instances[1].visible_camera = False
    scene.instances[1].motion = tuple(placed(x) for x in np.linspace(-0.5 * SLIDE, 0.5 * SLIDE, 3))
    return scene


def test_a_sliding_emitter_is_light_sampled_where_it_is_at_each_paths_time():
    """The floor's light from the sliding emitter is its time average: albedo x L x the mean over the box table's
    times of the form factor of the square where it is then (a closed form per time). Light-sampled where the emitter
    is at each path's time (and weighed by MIS against BSDF rays, whose pdf is taken at the ray's time), 64 samples
    land within 3% of it per column and 10 times nearer per pixel than BSDF rays alone, which have the same mean."""
    first, last = box_span()
    centres = -0.5 * SLIDE + SLIDE * ((np.arange(1000) + 0.5) / 1000 * (last - first) + first)
    X, Y = np.meshgrid(-0.5 * SCALE + PIXEL * (np.arange(W) + 0.5), 0.5 * H * PIXEL - PIXEL * (np.arange(H) + 0.5))
    factor = np.zeros((H, W))
    for c in centres:
        for x0, y0, sign in ((c + 0.5, 0.5, 1.0), (c - 0.5, 0.5, -1.0), (c + 0.5, -0.5, -1.0), (c - 0.5, -0.5, 1.0)):
            factor += sign * corner_form_factor(x0 - X, y0 - Y, 1.0)
    exact = 0.8 * 4.0 * factor / len(centres)
    settings = RenderSettings(width=W, height=H, samples=64, adaptive=False, integrator="direct")
    sampled = render.render(floor_under_a_sliding_emitter(), settings)
    assert not sampled.stats.warnings
    image = sampled.image[..., 0]
    np.testing.assert_allclose(image.mean(axis=0), exact.mean(axis=0), rtol=0.03)
    bsdf = render.render(floor_under_a_sliding_emitter(), dataclasses.replace(settings, light_sampling="bsdf"))
    assert bsdf.image[..., 0].mean() == pytest.approx(exact.mean(), rel=0.05)
    error, bsdf_error = (np.sqrt(np.mean((picture - exact) ** 2)) for picture in (image, bsdf.image[..., 0]))
    assert error < 0.1 * bsdf_error


def test_both_kernels_sample_a_moving_and_deforming_emitter_alike():
    """The emitter of the floor above also turns (five steps) and its vertices shear (three steps): the compiled light
    samples and MIS pdfs are the reference's (direct and path tracers), and the light tree's leaf holds the emitter at
    every time of the shutter."""
    scene = floor_under_a_sliding_emitter()
    scene.add_mesh(primitives.plane(0.5, 2.0, center=(1.0, 0.5, 1.5)), materials=np.array([1]))   # (a still one)
    square = np.asarray(scene.meshes[1].vertices, np.float64)
    scene.instances[1].motion = tuple(placed(x, a) for x, a in zip(np.linspace(-2.0, 2.0, 5), np.linspace(-0.6, 0.6, 5)))
    scene.instances[1].deformation = tuple(square + np.where(square[:, :1] > 0.0, [0.0, s, 0.0], 0.0)
                                           for s in (-0.4, 0.0, 0.4))
    for integrator in ("direct", "path"):
        settings = RenderSettings(width=W, height=H, samples=8, adaptive=False, integrator=integrator, max_bounces=2)
        compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
        reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
        assert compiled.stats.kernels == "compiled" and not compiled.stats.warnings
        np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-5, atol=1e-6)
    geometry = build_geometry(scene, np.zeros(3), motion_blur=True)
    mesh = next(m for m in geometry.instanced if m.vertex_steps is not None)
    local = np.arange(len(mesh.triangles))
    corners = mesh.corner_points(np.zeros_like(local), local)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    sides = np.full(len(local), emitters_.FRONT, np.int32)
    lo, hi, axis, theta, _ = emitters_.shutter_bounds(corners, normal, sides, mesh.first_prim + local,
                                                      np.zeros(len(local), np.int32), [mesh])
    for time in np.random.default_rng(3).uniform(0.0, 1.0, 200):
        V = mesh.corner_points(np.zeros_like(local), local, np.full(len(local), time))
        assert np.all(V >= lo[:, None]) and np.all(V <= hi[:, None])
        n = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
        n /= np.linalg.norm(n, axis=1)[:, None]
        assert np.all(np.einsum("ij,ij->i", n, axis) >= np.cos(theta) - 1e-12)


TILT = 0.6                                          # the smooth sheet's normals turn from -TILT to TILT about y


def tilting_sheet(normals: bool = True) -> Scene:
    """A smooth, white (albedo 0.8) 6 x 1.5 sheet at z = 0 under the still orthographic camera and a sun straight above
    (irradiance pi): it deforms a little (its vertices slide 0.02 along x over three steps) and its vertex normals turn
    from -TILT to 0 to TILT about y over the same steps (Instance.deformation_normals; without `normals`, none)."""
    scene = Scene(camera=dataclasses.replace(sliding_camera(), motion=()))
    scene.materials.append(Material(np.full(3, 0.8), "White"))
    sheet = primitives.plane(6.0, 1.5)
    sheet.smooth[:] = True
    sheet.corner_normals = np.tile([0.0, 0.0, 1.0], (2, 3, 1))
    scene.add_mesh(sheet, materials=np.array([0]))
    square = np.asarray(sheet.vertices, np.float64)
    scene.instances[0].deformation = tuple(square + [0.01 * k, 0.0, 0.0] for k in range(3))
    if normals:
        scene.instances[0].deformation_normals = tuple(np.tile([math.sin(a), 0.0, math.cos(a)], (4, 1))
                                                       for a in (-TILT, 0.0, TILT))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=math.pi))
    return scene


def tilted_normal(time: np.ndarray) -> np.ndarray:
    """The sheet's normal at `time` (n,): its step normals mixed linearly in the step around it, normalised."""
    steps = np.array([[math.sin(a), 0.0, math.cos(a)] for a in (-TILT, 0.0, TILT)])
    step = np.minimum((time * 2).astype(int), 1)
    s = (time * 2 - step)[:, None]
    mixed = (1.0 - s) * steps[step] + s * steps[step + 1]
    return mixed / np.linalg.norm(mixed, axis=1)[:, None]


def test_a_deforming_meshs_smooth_normals_are_interpolated_at_the_rays_time():
    """Cycles' motion vertex normals: a ray at time t meets the deforming sheet with the normal of its vertex normals
    mixed linearly between the two steps around t, normalised (both kernels); lit by a sun straight above it shades
    to 0.8 x the mean over the box table's times of that normal's cosine (0.8 at the frame's normals); both kernels'
    images agree."""
    scene = tilting_sheet()
    geometry = build_geometry(scene, np.zeros(3), motion_blur=True)
    time = np.random.default_rng(4).uniform(0.0, 1.0, 500)
    prim = np.full(500, geometry.instanced[0].first_prim)
    np.testing.assert_allclose(geometry.triangle_data(prim, times=time).corner_normals[:, 0], tilted_normal(time),
                               atol=1e-6)
    first, last = box_span()
    expected = 0.8 * tilted_normal(first + (last - first) * (np.arange(4096) + 0.5) / 4096)[:, 2].mean()
    settings = RenderSettings(width=W, height=H, samples=64, adaptive=False, integrator="direct")
    compiled = render.render(scene, settings)
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled" and not compiled.stats.warnings
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
    sheet = compiled.image[2:6, 6:26, 0]                         # pixels inside the sheet at every time
    assert sheet.mean() == pytest.approx(expected, rel=2e-3)
    assert np.abs(sheet - expected).max() < 0.01
    frames = render.render(tilting_sheet(normals=False), settings).image[2:6, 6:26, 0]
    np.testing.assert_allclose(frames, 0.8, rtol=1e-5)
