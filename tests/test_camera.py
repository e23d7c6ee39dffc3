"""Tests for core/camera/camera.py against hand-computed, closed-form rays.

Conventions: an identity matrix_world means the camera sits at the origin looking
along -Z, with +X to the right and +Y up.  Raster y counts rows from the top.
With lens 50 mm and sensor 36 mm the sensor spans 36/50 = 0.72 units on the
plane at distance 1, i.e. half a sensor is 0.36 units.
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from core.camera import camera as camera_module
from core.camera import Camera, CameraRays, fov_from_lens, generate_rays, lens_from_fov


def unit(vector):
    """Return `vector` ((3,) or (n, 3)) normalised along its last axis."""
    vector = np.asarray(vector, dtype=np.float64)
    return vector / np.linalg.norm(vector, axis=-1, keepdims=True)


def ray_directions(camera, width, height, raster_points, pixel_aspect=(1.0, 1.0)):
    """Return the (n, 3) ray directions through (n, 2) raster points."""
    raster_points = np.asarray(raster_points, dtype=np.float64)
    rays = generate_rays(camera, width, height, raster_points[:, 0], raster_points[:, 1], pixel_aspect)
    return rays.directions


def corner_rasters(width, height):
    """Return the raster positions of the image corners: top-left, top-right, bottom-left, bottom-right."""
    return [(0, 0), (width, 0), (0, height), (width, height)]


def expected_corner_directions(half_width, half_height):
    """Return unit directions (4, 3) through the corners of a centred image plane at distance 1."""
    return unit([[-half_width, half_height, -1.0],
                 [half_width, half_height, -1.0],
                 [-half_width, -half_height, -1.0],
                 [half_width, -half_height, -1.0]])


def rotation_matrix(axis, angle):
    """Return the (3, 3) rotation by `angle` radians about `axis` (Rodrigues)."""
    axis = unit(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


# --- perspective -------------------------------------------------------------

def test_centre_ray_points_along_minus_z():
    """The ray through the image centre looks straight down the camera's -Z axis."""
    camera = Camera(matrix_world=np.eye(4))
    directions = ray_directions(camera, 64, 48, [(32, 24)])
    np.testing.assert_allclose(directions[0], [0.0, 0.0, -1.0], atol=1e-15)


def test_corner_rays_auto_fit_landscape_sensor_width_spans_width():
    """AUTO, landscape: sensor_width spans the width, the height follows the aspect ratio."""
    camera = Camera(matrix_world=np.eye(4), lens=50.0, sensor_width=36.0)
    directions = ray_directions(camera, 200, 100, corner_rasters(200, 100))
    np.testing.assert_allclose(directions, expected_corner_directions(0.36, 0.18), atol=1e-12)


def test_corner_rays_auto_fit_portrait_sensor_width_spans_height():
    """AUTO, portrait: sensor_width (not sensor_height) spans the larger dimension, the height."""
    camera = Camera(matrix_world=np.eye(4), lens=50.0, sensor_width=36.0, sensor_height=24.0)
    directions = ray_directions(camera, 100, 200, corner_rasters(100, 200))
    np.testing.assert_allclose(directions, expected_corner_directions(0.18, 0.36), atol=1e-12)


def test_corner_rays_horizontal_fit_portrait_sensor_width_spans_width():
    """HORIZONTAL: sensor_width spans the width even for a portrait image."""
    camera = Camera(matrix_world=np.eye(4), sensor_fit="HORIZONTAL")
    directions = ray_directions(camera, 100, 200, corner_rasters(100, 200))
    np.testing.assert_allclose(directions, expected_corner_directions(0.36, 0.72), atol=1e-12)


def test_corner_rays_vertical_fit_landscape_sensor_height_spans_height():
    """VERTICAL: sensor_height spans the height even for a landscape image."""
    camera = Camera(matrix_world=np.eye(4), sensor_fit="VERTICAL", sensor_height=24.0)
    directions = ray_directions(camera, 200, 100, corner_rasters(200, 100))
    np.testing.assert_allclose(directions, expected_corner_directions(0.48, 0.24), atol=1e-12)


def test_corner_rays_horizontal_fov_matches_lens():
    """The angle between the left- and right-edge rays is the FOV the lens was made from."""
    fov = math.radians(70.0)
    camera = Camera(matrix_world=np.eye(4), lens=lens_from_fov(fov, 36.0))
    left_edge, right_edge = ray_directions(camera, 300, 200, [(0, 100), (300, 100)])
    angle = math.acos(np.clip(left_edge @ right_edge, -1, 1))
    assert angle == pytest.approx(fov, abs=1e-12)


def test_pixel_aspect_wide_pixels_make_the_image_wider():
    """Pixel aspect (2, 1) on a square raster gives the 2:1 image's rays."""
    # 100x100 pixels that are twice as wide as tall display as a 2:1 image.
    camera = Camera(matrix_world=np.eye(4))
    directions = ray_directions(camera, 100, 100, corner_rasters(100, 100), pixel_aspect=(2.0, 1.0))
    np.testing.assert_allclose(directions, expected_corner_directions(0.36, 0.18), atol=1e-12)


def test_pixel_aspect_tall_pixels_switch_auto_fit_to_vertical():
    """Pixel aspect (1, 2) makes the displayed image portrait, so AUTO fits the height."""
    camera = Camera(matrix_world=np.eye(4))
    directions = ray_directions(camera, 100, 100, corner_rasters(100, 100), pixel_aspect=(1.0, 2.0))
    np.testing.assert_allclose(directions, expected_corner_directions(0.18, 0.36), atol=1e-12)


def test_pixel_aspect_with_vertical_fit():
    """VERTICAL fit with wide pixels: sensor_height spans the height, width follows displayed aspect."""
    camera = Camera(matrix_world=np.eye(4), sensor_fit="VERTICAL", sensor_height=24.0)
    # displayed size 120 x 60 -> height spans 0.48, width 0.96
    directions = ray_directions(camera, 40, 60, corner_rasters(40, 60), pixel_aspect=(3.0, 1.0))
    np.testing.assert_allclose(directions, expected_corner_directions(0.48, 0.24), atol=1e-12)


def test_shift_x_half_moves_centre_to_former_right_edge_landscape():
    """shift_x = 0.5 moves the picture by half its (fitted) width."""
    plain = Camera(matrix_world=np.eye(4))
    shifted = Camera(matrix_world=np.eye(4), shift_x=0.5)
    right_edge = ray_directions(plain, 200, 100, [(200, 50)])
    shifted_centre = ray_directions(shifted, 200, 100, [(100, 50)])
    np.testing.assert_allclose(shifted_centre, right_edge, atol=1e-12)


def test_shift_is_in_units_of_the_fitted_dimension():
    """Both shifts are measured in units of the fitted (larger, for AUTO) dimension."""
    # Landscape: width is fitted (0.72 units); shift_y = 0.25 moves the centre up by 0.18.
    landscape = Camera(matrix_world=np.eye(4), shift_x=0.1, shift_y=0.25)
    np.testing.assert_allclose(ray_directions(landscape, 200, 100, [(100, 50)])[0],
                               unit([0.072, 0.18, -1.0]), atol=1e-12)
    # Portrait (AUTO): height is fitted (0.72 units); shift_x = 0.5 moves by 0.36 = twice the half width.
    portrait = Camera(matrix_world=np.eye(4), shift_x=0.5)
    np.testing.assert_allclose(ray_directions(portrait, 100, 200, [(50, 100)])[0],
                               unit([0.36, 0.0, -1.0]), atol=1e-12)


def test_raster_y_zero_is_the_top_row():
    """Raster row 0 is the top of the image (rays tilt up), the last row the bottom."""
    camera = Camera(matrix_world=np.eye(4))
    top, bottom = ray_directions(camera, 64, 64, [(32, 0.5), (32, 63.5)])
    assert top[1] > 0.0 and bottom[1] < 0.0


def test_raster_x_zero_is_the_left_column():
    """Raster column 0 is the left of the image (rays tilt towards -X)."""
    camera = Camera(matrix_world=np.eye(4))
    left, right = ray_directions(camera, 64, 64, [(0.5, 32), (63.5, 32)])
    assert left[0] < 0.0 and right[0] > 0.0


# --- the lecture's camera ----------------------------------------------------

def test_look_at_matches_lecture_construction():
    """look_at reproduces the lecture's V, right, up and screen corners p1, p2, p3."""
    position = np.array([1.0, 2.0, 3.0])
    target = np.array([4.0, -1.0, 5.0])
    up = np.array([0.0, 0.0, 1.0])
    fov = math.radians(60.0)
    width, height = 160, 90

    view = unit(target - position)
    right = unit(np.cross(view, up))
    true_up = np.cross(right, view)
    half_width = math.tan(fov / 2)
    half_height = half_width * height / width
    centre = position + view
    p1 = centre - half_width * right + half_height * true_up
    p2 = centre + half_width * right + half_height * true_up
    p3 = centre - half_width * right - half_height * true_up

    camera = Camera.look_at(position, target, up, fov=fov)
    np.testing.assert_allclose(camera.position, position)
    np.testing.assert_allclose(camera.forward, view, atol=1e-15)
    np.testing.assert_allclose(camera.right, right, atol=1e-15)
    np.testing.assert_allclose(camera.up, true_up, atol=1e-15)
    assert camera.type == "PERSP" and camera.sensor_fit == "AUTO"
    assert camera.lens == pytest.approx(18.0 / math.tan(fov / 2))
    for got, want in zip(camera.screen_corners(width, height), (p1, p2, p3)):
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_look_at_default_fov_is_blenders_50mm_lens():
    """The default FOV of 39.6 degrees is Blender's default 50 mm lens on a 36 mm sensor."""
    camera = Camera.look_at((0, 0, 0), (0, 1, 0))
    assert camera.lens == pytest.approx(50.0, rel=2e-4)
    assert fov_from_lens(50.0, 36.0) == pytest.approx(math.radians(39.6), rel=2e-4)


def test_look_at_rejects_up_parallel_to_view():
    """An up vector parallel to the view direction cannot define a camera."""
    with pytest.raises(ValueError):
        Camera.look_at((0, 0, 0), (0, 0, 5), up=(0, 0, 1))


def test_screen_corners_agree_with_generate_rays():
    """Rays pass through p1 + (x/W)(p2-p1) + (y/H)(p3-p1), with shift, fit and pixel aspect."""
    camera = Camera.look_at((0.5, -3.0, 1.0), (0.0, 0.0, 0.2), up=(0.1, 0.0, 1.0), fov=1.1,
                            sensor_fit="VERTICAL", sensor_height=20.0)
    camera = replace(camera, shift_x=0.13, shift_y=-0.07)
    width, height, pixel_aspect = 120, 70, (1.0, 1.5)
    p1, p2, p3 = camera.screen_corners(width, height, pixel_aspect)
    rng = np.random.default_rng(1)
    raster = rng.uniform([0, 0], [width, height], size=(50, 2))
    plane_points = (p1 + np.outer(raster[:, 0] / width, p2 - p1) + np.outer(raster[:, 1] / height, p3 - p1))
    expected = unit(plane_points - camera.position)
    np.testing.assert_allclose(ray_directions(camera, width, height, raster, pixel_aspect), expected, atol=1e-12)


def test_screen_corners_lie_at_distance_one_in_front():
    """The screen corners lie on the plane at distance 1 along the view direction."""
    camera = Camera.look_at((1, 1, 1), (0, 0, 0))
    for corner in camera.screen_corners(40, 30):
        assert (corner - camera.position) @ camera.forward == pytest.approx(1.0)


# --- clipping ------------------------------------------------------------------

def test_planar_clipping_offsets_origin_and_t_max_by_cosine():
    """Origins sit clip_start / cos from the eye and t_max is (clip_end - clip_start) / cos."""
    camera = Camera(matrix_world=np.eye(4), clip_start=0.5, clip_end=20.0)
    rays = generate_rays(camera, 200, 100, np.array([100.0, 0.0]), np.array([50.0, 0.0]))
    cos_corner = 1.0 / math.sqrt(0.36 ** 2 + 0.18 ** 2 + 1.0)
    np.testing.assert_allclose(rays.origins[0], [0.0, 0.0, -0.5], atol=1e-15)
    assert rays.t_max[0] == pytest.approx(19.5)
    assert np.linalg.norm(rays.origins[1]) == pytest.approx(0.5 / cos_corner)
    assert rays.t_max[1] == pytest.approx(19.5 / cos_corner)


def test_planar_clipping_start_and_end_points_lie_on_clip_planes():
    """Every ray starts on the near plane and ends on the far plane (depths along the axis)."""
    camera = Camera.look_at((2, -1, 3), (0, 0, 0), fov=1.6, clip_start=0.25, clip_end=7.0)
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, 64, 100), rng.uniform(0, 48, 100)
    rays = generate_rays(camera, 64, 48, x, y)
    start_depth = (rays.origins - camera.position) @ camera.forward
    end_points = rays.origins + rays.directions * rays.t_max[:, None]
    end_depth = (end_points - camera.position) @ camera.forward
    np.testing.assert_allclose(start_depth, 0.25, atol=1e-12)
    np.testing.assert_allclose(end_depth, 7.0, atol=1e-12)


# --- orthographic ----------------------------------------------------------------

def test_ortho_rays_are_parallel_with_origins_on_near_plane():
    """Orthographic rays all point along -Z and start on the near clip plane."""
    camera = Camera(matrix_world=np.eye(4), type="ORTHO", ortho_scale=4.0, clip_start=0.3, clip_end=9.0)
    rng = np.random.default_rng(3)
    rays = generate_rays(camera, 80, 40, rng.uniform(0, 80, 30), rng.uniform(0, 40, 30))
    np.testing.assert_allclose(rays.directions, np.tile([0.0, 0.0, -1.0], (30, 1)))
    np.testing.assert_allclose(rays.origins[:, 2], -0.3)
    np.testing.assert_allclose(rays.t_max, 8.7)


def test_ortho_scale_spans_the_fitted_dimension():
    """ortho_scale is the width (landscape), the height (portrait, or VERTICAL fit)."""
    landscape = Camera(matrix_world=np.eye(4), type="ORTHO", ortho_scale=4.0)
    rays = generate_rays(landscape, 80, 40, np.array([0.0, 80.0]), np.array([0.0, 40.0]))
    np.testing.assert_allclose(rays.origins[:, :2], [[-2.0, 1.0], [2.0, -1.0]], atol=1e-15)
    portrait = Camera(matrix_world=np.eye(4), type="ORTHO", ortho_scale=4.0)
    rays = generate_rays(portrait, 40, 80, np.array([0.0]), np.array([0.0]))
    np.testing.assert_allclose(rays.origins[0, :2], [-1.0, 2.0], atol=1e-15)
    vertical = Camera(matrix_world=np.eye(4), type="ORTHO", ortho_scale=4.0, sensor_fit="VERTICAL")
    rays = generate_rays(vertical, 80, 40, np.array([0.0]), np.array([0.0]))
    np.testing.assert_allclose(rays.origins[0, :2], [-4.0, 2.0], atol=1e-15)


def test_ortho_shift_is_in_units_of_ortho_scale():
    """Orthographic shift moves the image by shift * ortho_scale."""
    camera = Camera(matrix_world=np.eye(4), type="ORTHO", ortho_scale=4.0, shift_x=0.25, shift_y=-0.5)
    rays = generate_rays(camera, 80, 40, np.array([40.0]), np.array([20.0]))
    np.testing.assert_allclose(rays.origins[0, :2], [1.0, -2.0], atol=1e-15)


# --- fisheye ------------------------------------------------------------------------

def fisheye(panorama_type, **kw):
    """Return a PANO camera at the origin looking along -Z."""
    return Camera(matrix_world=np.eye(4), type="PANO", panorama_type=panorama_type, **kw)


@pytest.mark.parametrize("panorama_type", ["FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID"])
def test_fisheye_centre_ray_points_forward(panorama_type):
    """The fisheye's centre ray looks along -Z and is valid."""
    rays = generate_rays(fisheye(panorama_type), 60, 40, np.array([30.0]), np.array([20.0]))
    np.testing.assert_allclose(rays.directions[0], [0.0, 0.0, -1.0], atol=1e-15)
    assert rays.valid[0]


def test_fisheye_equidistant_circle_edge_is_at_half_fov():
    """Equidistant: the frame edges are at fov/2 from the axis and the angle grows linearly."""
    fov = math.radians(200.0)
    camera = fisheye("FISHEYE_EQUIDISTANT", fisheye_fov=fov)
    # right edge, top edge and a point half way to the left edge; non-square image
    rays = generate_rays(camera, 60, 40, np.array([60.0, 30.0, 15.0]), np.array([20.0, 0.0, 20.0]))
    half = fov / 2
    np.testing.assert_allclose(rays.directions[0], [math.sin(half), 0.0, -math.cos(half)], atol=1e-12)
    np.testing.assert_allclose(rays.directions[1], [0.0, math.sin(half), -math.cos(half)], atol=1e-12)
    # equidistant: angle grows linearly with the (normalised) radius
    np.testing.assert_allclose(rays.directions[2], [-math.sin(half / 2), 0.0, -math.cos(half / 2)], atol=1e-12)
    assert rays.valid.all()


def test_fisheye_equidistant_invalid_outside_image_circle():
    """Equidistant: rays outside the (elliptical) image circle are invalid but still unit length."""
    camera = fisheye("FISHEYE_EQUIDISTANT")
    # corners are outside; just inside and just outside the ellipse along the diagonal
    inside = 0.5 + 0.5 * 0.99 / math.sqrt(2)
    outside = 0.5 + 0.5 * 1.01 / math.sqrt(2)
    rays = generate_rays(camera, 60, 40, np.array([0.5, 60 * inside, 60 * outside]),
                         np.array([0.5, 40 * inside, 40 * outside]))
    assert rays.valid.tolist() == [False, True, False]
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0)


@pytest.mark.parametrize("panorama_type, kw", [
    ("FISHEYE_EQUIDISTANT", {}),
    ("FISHEYE_EQUISOLID", {"fisheye_lens": 8.0, "fisheye_fov": math.radians(170.0), "sensor_fit": "VERTICAL"}),
    ("FISHEYE_EQUISOLID", {"fisheye_lens": 10.0, "fisheye_fov": math.radians(180.0), "shift_x": 0.1, "shift_y": -0.05}),
])
def test_pixels_outside_the_image_circle_are_exactly_those_no_ray_of_reaches(panorama_type, kw):
    """Every pixel called outside has no valid ray at any of 32 x 32 points across it, and every pixel
    with no valid ray among them, except those the circle only grazes, is called outside."""
    camera = fisheye(panorama_type, **kw)
    W, H, k = 48, 36, 32
    pixels = np.arange(W * H)
    outside = camera_module.outside_image_circle(camera, W, H, pixels)
    offsets = (np.arange(k) + 0.5) / k
    ox, oy = np.meshgrid(np.append(offsets, [0.0, 1.0 - 1e-9]), np.append(offsets, [0.0, 1.0 - 1e-9]))
    raster_x = (pixels % W)[:, None] + ox.reshape(-1)[None, :]
    raster_y = (pixels // W)[:, None] + oy.reshape(-1)[None, :]
    valid = generate_rays(camera, W, H, raster_x.reshape(-1), raster_y.reshape(-1)).valid.reshape(len(pixels), -1)
    assert not valid[outside].any()                       # never skips a pixel the circle reaches
    unreached = ~valid.any(axis=1)
    assert outside.sum() > 0.1 * W * H                    # the corners of the frame are skipped
    assert (unreached & ~outside).sum() <= 0.01 * W * H   # and almost nothing else that could be
    inside = camera_module.outside_image_circle(Camera(matrix_world=np.eye(4)), W, H, pixels)
    assert not inside.any()                               # a perspective camera has no circle


def test_fisheye_render_skips_pixels_outside_the_circle_and_keeps_them_opaque_black():
    """The film outside a fisheye's image circle is opaque black without a single sample; inside, the image
    is what sampling every pixel gives."""
    from core import render as render_module
    from core.scene import RenderSettings, Scene, SunLight
    scene = Scene(camera=fisheye("FISHEYE_EQUISOLID", fisheye_lens=8.0, fisheye_fov=math.radians(170.0),
                                 sensor_fit="VERTICAL"))
    scene.world_color = np.array([0.2, 0.3, 0.4])
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=1.0))
    settings = RenderSettings(width=32, height=24, samples=4, seed=2)
    result = render_module.render(scene, settings)
    outside = camera_module.outside_image_circle(scene.camera, 32, 24, np.arange(32 * 24)).reshape(24, 32)
    assert outside.any() and not outside.all()
    assert (result.stats.samples_per_pixel[outside] == 0).all()
    assert (result.image[outside] == [0.0, 0.0, 0.0, 1.0]).all()
    # Inside, sampling every pixel as before gives the same values.
    original = camera_module.outside_image_circle
    try:
        camera_module.outside_image_circle = lambda *a, **k: np.zeros(len(a[3]), bool)
        full = render_module.render(scene, settings)
    finally:
        camera_module.outside_image_circle = original
    np.testing.assert_array_equal(full.image[~outside], result.image[~outside])
    assert (full.image[outside] == [0.0, 0.0, 0.0, 1.0]).all()


def test_fisheye_equisolid_angle_follows_equisolid_law():
    """Equisolid: a point r mm from the sensor centre looks at theta = 2 asin(r / (2 lens))."""
    lens = 10.5
    camera = fisheye("FISHEYE_EQUISOLID", fisheye_lens=lens, fisheye_fov=math.pi)
    # 100x100 image, AUTO fit: 36 mm across -> 0.36 mm per pixel; 12 mm right of centre is x = 50 + 12/0.36
    rays = generate_rays(camera, 100, 100, np.array([50 + 12 / 0.36, 50.0]), np.array([50.0, 50 - 9 / 0.36]))
    theta_right = 2 * math.asin(12 / (2 * lens))
    theta_up = 2 * math.asin(9 / (2 * lens))
    np.testing.assert_allclose(rays.directions[0], [math.sin(theta_right), 0, -math.cos(theta_right)], atol=1e-12)
    np.testing.assert_allclose(rays.directions[1], [0, math.sin(theta_up), -math.cos(theta_up)], atol=1e-12)


def test_fisheye_equisolid_image_circle_ends_at_half_fov():
    """Equisolid: the round image circle has radius 2 lens sin(fov / 4) on the sensor."""
    lens, fov = 8.0, math.radians(160.0)
    radius_mm = 2 * lens * math.sin(fov / 4)       # image circle radius on the sensor
    camera = fisheye("FISHEYE_EQUISOLID", fisheye_lens=lens, fisheye_fov=fov)
    # 200x100 landscape, AUTO fit: sensor 36 x 18 mm, 0.18 mm per pixel in both directions
    x = 100 + np.array([0.999, 1.001]) * radius_mm / 0.18
    rays = generate_rays(camera, 200, 100, x, np.array([50.0, 50.0]))
    assert rays.valid.tolist() == [True, False]
    angle = math.acos(-rays.directions[0, 2])
    assert angle == pytest.approx(2 * math.asin(0.999 * math.sin(fov / 4)), abs=1e-12)
    # the image circle is round: 0.18 mm per pixel vertically too
    rays = generate_rays(camera, 200, 100, np.array([100.0, 100.0]),
                         50 - np.array([0.999, 1.001]) * radius_mm / 0.18)
    assert rays.valid.tolist() == [True, False]


def test_fisheye_equisolid_sensor_follows_vertical_fit_and_pixel_aspect():
    """Equisolid: the sensor is fitted like Blender's (VERTICAL fit, pixel aspect)."""
    lens = 10.0
    camera = fisheye("FISHEYE_EQUISOLID", fisheye_lens=lens, sensor_fit="VERTICAL", sensor_height=20.0)
    # 50x50 pixels of aspect 2:1 display as 100x50: sensor 40 x 20 mm
    rays = generate_rays(camera, 50, 50, np.array([25 + 5.0 / 40 * 50]), np.array([25.0]), pixel_aspect=(2.0, 1.0))
    theta = 2 * math.asin(5.0 / (2 * lens))
    np.testing.assert_allclose(rays.directions[0], [math.sin(theta), 0, -math.cos(theta)], atol=1e-12)


def test_fisheye_clipping_is_along_the_ray():
    """Fisheye clipping is spherical: clip distances are measured along each ray."""
    camera = fisheye("FISHEYE_EQUIDISTANT", clip_start=0.2, clip_end=5.0)
    rays = generate_rays(camera, 40, 40, np.array([20.0, 35.0]), np.array([20.0, 10.0]))
    np.testing.assert_allclose(np.linalg.norm(rays.origins, axis=1), 0.2)
    np.testing.assert_allclose(rays.t_max, 4.8)


# --- general properties ----------------------------------------------------------

@pytest.mark.parametrize("kw", [
    dict(type="PERSP", lens=18.0, shift_x=0.2),
    dict(type="ORTHO"),
    dict(type="PANO", panorama_type="FISHEYE_EQUIDISTANT", fisheye_fov=4.0),
    dict(type="PANO", panorama_type="FISHEYE_EQUISOLID"),
])
def test_directions_are_unit_length_and_shapes_are_right(kw):
    """All camera types return unit directions and arrays of the documented shapes and dtypes."""
    camera = Camera(matrix_world=np.eye(4), **kw)
    ys, xs = np.mgrid[0:24, 0:32]
    rays = generate_rays(camera, 32, 24, xs.ravel() + 0.5, ys.ravel() + 0.5)
    assert isinstance(rays, CameraRays)
    assert rays.origins.shape == (768, 3) and rays.origins.dtype == np.float64
    assert rays.directions.shape == (768, 3) and rays.t_max.shape == (768,)
    assert rays.valid.dtype == bool
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0, atol=1e-14)
    assert np.all(np.isfinite(rays.origins)) and np.all(np.isfinite(rays.t_max))


@pytest.mark.parametrize("kw", [
    dict(type="PERSP", shift_y=0.1),
    dict(type="ORTHO", ortho_scale=3.0),
    dict(type="PANO", panorama_type="FISHEYE_EQUISOLID"),
])
def test_matrix_world_rotates_and_translates_rays(kw):
    """matrix_world rotates directions and rotates and translates origins."""
    rotation = rotation_matrix([0.3, -1.0, 0.5], 1.3)
    translation = np.array([3.0, -2.0, 0.5])
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    matrix[:3, 3] = translation
    local = generate_rays(Camera(matrix_world=np.eye(4), **kw), 30, 20, np.array([0.0, 7.5, 29.0]),
                          np.array([0.0, 13.0, 20.0]))
    world = generate_rays(Camera(matrix_world=matrix, **kw), 30, 20, np.array([0.0, 7.5, 29.0]),
                          np.array([0.0, 13.0, 20.0]))
    np.testing.assert_allclose(world.directions, local.directions @ rotation.T, atol=1e-14)
    np.testing.assert_allclose(world.origins, local.origins @ rotation.T + translation, atol=1e-14)
    np.testing.assert_allclose(world.t_max, local.t_max)


def test_object_scale_is_ignored():
    """A scaled matrix_world gives the same rays as the unscaled one (Cycles clears scale)."""
    rotation = rotation_matrix([1.0, 2.0, 3.0], 0.7)
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    matrix[:3, 3] = [1.0, 2.0, 3.0]
    scaled = matrix.copy()
    scaled[:3, :3] = rotation @ np.diag([2.0, 0.5, 3.0])
    x, y = np.array([0.0, 10.0, 40.0]), np.array([30.0, 5.0, 0.0])
    plain = generate_rays(Camera(matrix_world=matrix), 40, 30, x, y)
    with_scale = generate_rays(Camera(matrix_world=scaled), 40, 30, x, y)
    np.testing.assert_allclose(with_scale.directions, plain.directions, atol=1e-14)
    np.testing.assert_allclose(with_scale.origins, plain.origins, atol=1e-14)
    np.testing.assert_allclose(Camera(matrix_world=scaled).forward, -rotation[:, 2], atol=1e-15)


@pytest.mark.parametrize("kw", [
    dict(type="PERSP", lens=18.0),
    dict(type="PANO", panorama_type="FISHEYE_EQUISOLID"),
])
def test_sheared_camera_still_gives_unit_directions(kw):
    """A parent's non-uniform scale can shear the camera: its axes stay unit, not orthogonal; rays stay unit."""
    sheared = np.eye(4)
    sheared[:3, :3] = rotation_matrix([0.0, 0.0, 1.0], 0.4) @ np.diag([1.0, 3.0, 1.0]) @ rotation_matrix(
        [1.0, 1.0, 0.0], 0.9)
    camera = Camera(matrix_world=sheared, **kw)
    axes = camera.matrix_world[:3, :3]
    assert abs(np.dot(axes[:, 0], axes[:, 1])) > 0.1              # really sheared
    ys, xs = np.mgrid[0:12, 0:16]
    rays = generate_rays(camera, 16, 12, xs.ravel() + 0.5, ys.ravel() + 0.5)
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0, atol=1e-14)
    # Each direction is the sheared image of the local one, rescaled.
    local = generate_rays(Camera(matrix_world=np.eye(4), **kw), 16, 12, xs.ravel() + 0.5, ys.ravel() + 0.5)
    mapped = local.directions @ axes.T
    np.testing.assert_allclose(rays.directions, mapped / np.linalg.norm(mapped, axis=1)[:, None], atol=1e-14)


def test_perspective_and_ortho_rays_are_always_valid():
    """Only fisheye rays can be invalid."""
    for kw in (dict(type="PERSP"), dict(type="ORTHO")):
        rays = generate_rays(Camera(matrix_world=np.eye(4), **kw), 8, 8, np.arange(8.0), np.arange(8.0))
        assert rays.valid.all()


def test_unknown_settings_are_rejected():
    """Unsupported camera types, fits and panorama types raise ValueError."""
    with pytest.raises(ValueError):
        Camera(matrix_world=np.eye(4), type="CUSTOM")
    with pytest.raises(ValueError):
        Camera(matrix_world=np.eye(4), sensor_fit="DIAGONAL")
    with pytest.raises(ValueError):
        Camera(matrix_world=np.eye(4), type="PANO", panorama_type="STEREOGRAPHIC")
    with pytest.raises(ValueError):
        Camera(matrix_world=np.eye(4), type="ORTHO").screen_corners(10, 10)


def test_only_an_orthonormal_camera_frame_keeps_ray_directions_unit():
    """camera._is_rotation decides whether camera rays need renormalising: a rotation (mirrored or
    not) keeps unit vectors unit; a scale, a shear, a drift past 1e-12 or a NaN do not."""
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0.0], [np.sin(angle), np.cos(angle), 0.0], [0.0, 0.0, 1.0]])
    assert camera_module._is_rotation(rotation)
    assert camera_module._is_rotation(rotation @ np.diag([1.0, 1.0, -1.0]))
    assert camera_module._is_rotation(rotation * (1.0 + 1e-14))
    assert not camera_module._is_rotation(rotation * (1.0 + 1e-10))
    assert not camera_module._is_rotation(rotation @ np.diag([1.0, 2.0, 1.0]))
    sheared = rotation.copy()
    sheared[0, 1] += 1e-3
    assert not camera_module._is_rotation(sheared)
    broken = rotation.copy()
    broken[2, 2] = np.nan
    assert not camera_module._is_rotation(broken)


def test_panoramas_map_the_image_to_their_directions_in_closed_form():
    """Cycles' panoramas, in the camera's frame (looking down -Z, +Y up, +X right): the equirectangular image spans
    its longitudes (angles to the right) left to right and its latitudes bottom to top; a mirror ball's centre
    looks forward and its rim backward, nothing outside the ball; a cube-map face spans 90 degrees; the central
    cylinder puts height v on a cylinder of its radius; a polynomial fisheye's angle from the axis is its polynomial
    of the radius on the sensor."""
    def look(camera, u, v, width=64, height=32):
        x, y = np.asarray(u, float) * width, (1.0 - np.asarray(v, float)) * height
        return generate_rays(camera, width, height, x, y)

    pano = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="EQUIRECTANGULAR", longitude_min=-1.0,
                  longitude_max=0.5, latitude_min=-0.4, latitude_max=0.8)
    rays = look(pano, [0.0, 1.0, 0.5, 0.5], [0.5, 0.5, 1.0, 0.0])
    D = rays.directions
    longitude = np.arctan2(D[:, 0], -D[:, 2])           # 0 straight ahead, positive to the right
    latitude = np.arcsin(D[:, 1])
    np.testing.assert_allclose(longitude[:2], [-1.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(latitude[2:], [0.8, -0.4], atol=1e-12)
    ball = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="MIRRORBALL")
    rays = look(ball, [0.5, 0.5, 0.999, 0.9], [0.5, 0.9999999, 0.5, 0.9], width=32, height=32)
    np.testing.assert_allclose(rays.directions[0], [0.0, 0.0, -1.0], atol=1e-12)
    assert rays.directions[1, 2] > 0.999 and rays.directions[2, 2] > 0.99      # the rim sees behind
    assert list(rays.valid) == [True, True, True, False]                          # (0.9, 0.9) is off the ball
    face = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="EQUIANGULAR_CUBEMAP_FACE")
    rays = look(face, [0.0, 1.0], [0.5, 0.5])
    np.testing.assert_allclose(rays.directions, [[-math.sqrt(0.5), 0.0, -math.sqrt(0.5)],
                                                 [math.sqrt(0.5), 0.0, -math.sqrt(0.5)]], atol=1e-12)
    cylinder = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="CENTRAL_CYLINDRICAL", cylinder_u_min=-1.0,
                      cylinder_u_max=1.0, cylinder_v_min=-0.5, cylinder_v_max=1.5, cylinder_radius=2.0)
    rays = look(cylinder, [0.5, 0.5, 0.0], [1.0, 0.0, 0.5])
    D = rays.directions
    np.testing.assert_allclose(D[0] / -D[0, 2], [0.0, 0.75, -1.0], atol=1e-12)       # height 1.5 / radius 2
    np.testing.assert_allclose(D[1] / -D[1, 2], [0.0, -0.25, -1.0], atol=1e-12)
    np.testing.assert_allclose(np.arctan2(D[2, 0], -D[2, 2]), -1.0, atol=1e-12)      # u 0: u_min to the right
    k = (0.0, -0.03, 0.0, 0.0, 0.0)
    poly = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="FISHEYE_LENS_POLYNOMIAL", fisheye_polynomial=k,
                  fisheye_fov=math.radians(100), sensor_width=36.0)
    rays = look(poly, [0.75], [0.5])                   # 9 mm right of the centre on a 36 mm wide sensor
    np.testing.assert_allclose(math.acos(-rays.directions[0, 2]), 0.27, atol=1e-12)
    assert rays.directions[0, 0] > 0.0 and abs(rays.directions[0, 1]) < 1e-12


def test_an_equirectangular_rays_spread_is_the_chord_of_one_pixels_longitude_and_latitude():
    """Cycles differences a panorama's pinhole directions one pixel apart in x and y: on the equator of an
    equirectangular image, |D(x + 1) - D| = 2 sin(dphi / 2) and |D(y + 1) - D| = 2 sin(dtheta / 2), with dphi and
    dtheta the longitudes and latitudes of one pixel; the spread is their mean, the cone clip_start times it. Along a
    parallel at latitude l the longitude's chord shrinks by cos l."""
    pano = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="EQUIRECTANGULAR", longitude_min=-2.0,
                  longitude_max=1.0, latitude_min=-0.6, latitude_max=0.9, clip_start=0.25)
    width, height = 96, 40
    dphi, dtheta = 3.0 / width, 1.5 / height
    latitude = np.array([0.0, 0.3, -0.5])
    v = (latitude + 0.6) / 1.5                          # (v from the bottom: the latitude's place in the range)
    cone, spread, known = camera_module.panorama_cones(pano, np.full(3, 0.4), v, width, height)
    assert known.all()
    # (the y neighbour lies one pixel down, at latitude l - dtheta; its chord is 2 sin(dtheta / 2) all the same)
    expected = 0.5 * (2.0 * np.sin(0.5 * dphi) * np.cos(latitude) + 2.0 * math.sin(0.5 * dtheta))
    np.testing.assert_allclose(spread, expected, rtol=1e-12)
    np.testing.assert_allclose(cone, 0.25 * expected, rtol=1e-12)


def test_a_mirror_balls_rim_takes_the_neighbour_that_exists():
    """Past a mirror ball's rim there is no direction: a ray whose x neighbour falls off the ball takes its y
    neighbour's step for both (Cycles' would be undefined there); a ray with neither has an unknown cone."""
    ball = Camera(matrix_world=np.eye(4), type="PANO", panorama_type="MIRRORBALL")
    cone, spread, known = camera_module.panorama_cones(ball, np.array([0.5, 0.99, 0.9999]), np.array([0.5, 0.5, 0.0001]),
                                                32, 32)
    d, _ = camera_module.panorama_local(ball, np.array([0.99, 0.99]), np.array([0.5, 0.5 - 1.0 / 32]), 32, 32)
    assert spread[0] > 0.0
    np.testing.assert_allclose(spread[1], np.linalg.norm(d[1] - d[0]), rtol=1e-12)
    assert list(known) == [True, True, False] and spread[2] == 0.0
