"""The viewport's camera and progressive passes, without Blender (core/camera/view.py, core/render/progressive.py).

The projection matrices here are OpenGL's frustum and orthographic matrices written out from their
closed forms, the same ones Blender's viewport uses; tests/test_viewport.py checks against bpy's own.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.camera import camera as camera_
from core.render import progressive
from core.camera import view as view_
from core.scene import Mesh, RenderSettings, Scene, SunLight


def frustum(left, right, bottom, top, near, far) -> np.ndarray:
    """Return OpenGL's perspective matrix for edges at distance `near` (glFrustum): (4, 4) float64."""
    return np.array([
        [2 * near / (right - left), 0, (right + left) / (right - left), 0],
        [0, 2 * near / (top - bottom), (top + bottom) / (top - bottom), 0],
        [0, 0, -(far + near) / (far - near), -2 * far * near / (far - near)],
        [0, 0, -1, 0]])


def orthographic(left, right, bottom, top, near, far) -> np.ndarray:
    """Return OpenGL's orthographic matrix (glOrtho): (4, 4) float64."""
    return np.array([
        [2 / (right - left), 0, 0, -(right + left) / (right - left)],
        [0, 2 / (top - bottom), 0, -(top + bottom) / (top - bottom)],
        [0, 0, -2 / (far - near), -(far + near) / (far - near)],
        [0, 0, 0, 1]])


def view_matrix_looking_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Return the world-to-eye matrix of an eye at `eye` looking at `target`: (4, 4) float64."""
    camera = camera_.Camera.look_at(eye, target, up)
    return np.linalg.inv(camera.matrix_world)


def distance_to_rays(rays, points) -> np.ndarray:
    """Return each point's distance from its ray's line: (n,) float64."""
    offset = points - rays.origins
    along = np.sum(offset * rays.directions, axis=1)
    return np.linalg.norm(offset - along[:, None] * rays.directions, axis=1)


WORLD_POINTS = np.array([[0.0, 0.0, 0.0], [1.0, -0.5, 0.3], [-0.7, 0.4, -0.2], [0.2, 0.9, 0.5]])


@pytest.mark.parametrize("edges", [(-0.4, 0.4, -0.225, 0.225), (-0.1, 0.5, -0.3, 0.1)])
def test_perspective_view_rays_pass_through_projected_points(edges):
    """The ray through the pixel where the frustum matrix puts a world point passes through that point."""
    width, height = 320, 180
    near = 0.1
    window = frustum(*(near * e for e in edges), near, 100.0)
    view = view_matrix_looking_at((4.0, -3.0, 2.0), (0.0, 0.0, 0.0))
    camera, aspect = view_.camera_from_matrices(view, window, width, height)
    raster = view_.project(view, window, width, height, WORLD_POINTS)
    rays = camera_.generate_rays(camera, width, height, raster[:, 0], raster[:, 1], aspect)
    np.testing.assert_allclose(distance_to_rays(rays, WORLD_POINTS), 0.0, atol=1e-9)
    assert camera.clip_start == pytest.approx(near) and camera.clip_end == pytest.approx(100.0)


def test_orthographic_view_rays_pass_through_projected_points():
    """Orthographic, off-centre and with a negative near plane (as Blender's ortho viewport has)."""
    width, height = 200, 260
    window = orthographic(-2.0, 3.0, -3.0, 3.5, -50.0, 50.0)
    view = view_matrix_looking_at((0.0, -10.0, 1.0), (0.0, 0.0, 1.0))
    camera, aspect = view_.camera_from_matrices(view, window, width, height)
    assert camera.type == "ORTHO"
    raster = view_.project(view, window, width, height, WORLD_POINTS)
    rays = camera_.generate_rays(camera, width, height, raster[:, 0], raster[:, 1], aspect)
    np.testing.assert_allclose(distance_to_rays(rays, WORLD_POINTS), 0.0, atol=1e-9)
    # The ray starts on the near plane, 50 units behind the eye, so points behind the eye are still seen.
    np.testing.assert_allclose(rays.origins[:, 1], -10.0 - 50.0, atol=1e-9)


def test_region_corners_map_to_the_frustum_edges():
    """Pixel corner (0, 0) looks along (L, T, -1) and (W, H) along (R, B, -1), in eye coordinates."""
    width, height = 64, 48
    left, right, bottom, top = -0.3, 0.5, -0.2, 0.4
    window = frustum(left, right, bottom, top, 1.0, 10.0)
    camera, aspect = view_.camera_from_matrices(np.eye(4), window, width, height)
    rays = camera_.generate_rays(camera, width, height, np.array([0.0, width]), np.array([0.0, height]), aspect)
    expected = np.array([[left, top, -1.0], [right, bottom, -1.0]])
    np.testing.assert_allclose(rays.directions, expected / np.linalg.norm(expected, axis=1, keepdims=True),
                               atol=1e-12)


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_crop_sees_the_same_rays_as_the_rectangle_it_crops(kind):
    """Pixel (i, j) of a crop of [x0, x1) x [y0, y1) looks where raster (x0 + i, y0 + j) of the whole view looks."""
    width, height = 90, 50
    window = (frustum(-0.4, 0.3, -0.2, 0.25, 1.0, 50.0) if kind == "PERSP"
              else orthographic(-2.0, 2.0, -1.0, 1.5, 0.1, 50.0))
    view = view_.camera_from_matrices(view_matrix_looking_at((1.0, 2.0, 3.0), (0.0, 0.0, 0.0)), window,
                                      width, height)
    x0, y0, x1, y1 = 8, 4, 96, 52          # reaches beyond the image, as the coarse pass does
    cropped = view_.crop(view, width, height, x0, y0, x1, y1)
    i, j = np.meshgrid(np.arange(0.5, x1 - x0, 7.0), np.arange(0.5, y1 - y0, 5.0))
    ours = camera_.generate_rays(cropped.camera, x1 - x0, y1 - y0, i.ravel(), j.ravel(), cropped.pixel_aspect)
    whole = camera_.generate_rays(view.camera, width, height, x0 + i.ravel(), y0 + j.ravel(), view.pixel_aspect)
    np.testing.assert_allclose(ours.directions, whole.directions, atol=1e-12)
    np.testing.assert_allclose(ours.origins, whole.origins, atol=1e-12)


def test_schedule_reaches_the_sample_count_in_growing_passes():
    """Coarse pass first, then full passes of 1, 1, 2, 4, ... samples summing to the target, each with its own seed."""
    passes = list(progressive.schedule(16, block=8, seed=3))
    assert passes[0] == progressive.Pass(8, 1, 1, 3)
    full = passes[1:]
    assert [p.samples for p in full] == [1, 1, 2, 4, 8]
    assert all(p.block == 1 for p in full) and len({p.seed for p in full}) == len(full)
    assert sum(p.samples for p in progressive.schedule(5, block=1)) == 5


def test_coarse_block_is_the_smallest_that_fits_the_budget():
    """With 1 us per sample, 1920 x 1080 pixels need blocks of 8 to fit 50 ms (32400 samples), 4 would not."""
    assert progressive.coarse_block(1e-6, 1920 * 1080, 0.05) == 8
    assert progressive.coarse_block(None, 1920 * 1080, 0.05) == 8
    assert progressive.coarse_block(1e-9, 100, 0.05) == 2
    assert progressive.coarse_block(1.0, 1920 * 1080, 0.05) == progressive.BLOCK_SIZES[-1]


def test_accumulator_is_the_sample_weighted_mean():
    """Passes of 1, 1 and 2 samples average to (a + b + 2c) / 4."""
    a, b, c = (np.full((2, 3, 4), v, np.float32) for v in (1.0, 2.0, 5.0))
    accumulator = progressive.Accumulator()
    for image, n in ((a, 1), (b, 1), (c, 2)):
        mean = accumulator.add(image, n)
    np.testing.assert_allclose(mean, (1.0 + 2.0 + 2 * 5.0) / 4, rtol=1e-6)
    assert accumulator.samples == 4


def plane_under_sun(elevation_deg: float = 60.0) -> Scene:
    """A 20 x 20 default-grey plane at z = 0 under a 3 W/m^2 sun, in front of a blue-grey world."""
    vertices = [(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)]
    scene = Scene(camera=camera_.Camera())
    scene.add_mesh(Mesh(vertices, [(0, 1, 2), (0, 2, 3)]))
    e = math.radians(elevation_deg)
    scene.lights.append(SunLight(np.array([0.0, -math.cos(e), -math.sin(e)]), strength=3.0))
    scene.world_color = np.array([0.05, 0.1, 0.2])
    return scene


def test_coarse_pass_shows_the_closed_form_radiance_in_its_blocks():
    """Seen from above, every block on the plane shows albedo / pi * E * sin(elevation), the sky the world colour."""
    from core.geometry.geometry import build_geometry

    scene = plane_under_sun(60.0)
    width, height = 101, 67                 # not multiples of the block: the last blocks are cut
    window = frustum(-0.6, 0.6, -0.4, 0.4, 1.0, 100.0)
    view = progressive.region_view(view_matrix_looking_at((0.0, -14.0, 6.0), (0.0, 0.0, 0.0)), window,
                                   width, height)
    geometry = build_geometry(scene, view.camera.position)
    settings = RenderSettings(samples=1, light_samples=1)
    coarse = progressive.render_pass(scene, settings, geometry, view, progressive.Pass(8, 1, 1, 0))
    full = progressive.render_pass(scene, settings, geometry, view, progressive.Pass(1, 1, None, 0))
    assert coarse.shape == full.shape == (height, width, 4)
    lit = 0.8 / math.pi * 3.0 * math.sin(math.radians(60.0))
    # Blocks entirely on the plane or entirely sky in the full render are exactly that in the coarse pass.
    for by in range(0, height, 8):
        for bx in range(0, width, 8):
            block_full = full[by:by + 8, bx:bx + 8, :3]
            block_coarse = coarse[by:by + 8, bx:bx + 8, :3]
            assert np.ptp(block_coarse.reshape(-1, 3), axis=0).max() == 0.0     # one ray per block
            for value in (lit, scene.world_color):
                if np.allclose(block_full, value, rtol=1e-5):
                    np.testing.assert_allclose(block_coarse, np.broadcast_to(value, block_coarse.shape), rtol=1e-5)
            assert (np.allclose(block_coarse, lit, rtol=1e-5) or np.allclose(block_coarse, scene.world_color))
    assert np.isclose(full[..., 0], lit, rtol=1e-5).mean() > 0.3      # the plane fills much of the view


def test_fisheye_film_sits_inside_its_frame_and_the_rest_is_black():
    """A fisheye's image fills its film rectangle of the region exactly as its own render; outside is black."""
    from core.geometry.geometry import build_geometry
    from core.render import render

    scene = plane_under_sun(60.0)
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 5.0)                 # looking straight down at the plane
    fisheye = camera_.Camera(matrix_world=matrix, type="PANO", panorama_type="FISHEYE_EQUIDISTANT",
                             fisheye_fov=math.radians(120.0))
    width, height, film = 50, 40, (-3, 6, 30, 24)     # the film sticks out of the region on the left
    view = progressive.View(fisheye, (1.0, 1.0), width, height, film)
    geometry = build_geometry(scene, fisheye.position)
    settings = RenderSettings(samples=1, light_samples=1, jitter=False)
    image = progressive.render_pass(scene, settings, geometry, view, progressive.Pass(1, 1, None, 0))
    scene.camera = fisheye
    own = render(scene, RenderSettings(width=30, height=24, samples=1, light_samples=1, jitter=False)).image
    np.testing.assert_allclose(image[6:30, 0:27], own[:, 3:30], rtol=1e-6)
    outside = np.ones((height, width), bool)
    outside[6:30, 0:27] = False
    assert np.all(image[outside][:, :3] == 0.0) and np.all(image[outside][:, 3] == 1.0)
    coarse = progressive.render_pass(scene, settings, geometry, view, progressive.Pass(4, 1, 1, 0))
    assert np.all(coarse[outside][:, :3] == 0.0)
    assert np.isclose(coarse[6:30, 0:27, 0], 0.8 / math.pi * 3.0 * math.sin(math.radians(60.0)), rtol=1e-5).mean() > 0.5
