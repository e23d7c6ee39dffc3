"""Tests for core/lights (and the integrator that uses it) against closed-form radiometry.

Units follow Cycles: a diffuse surface of albedo rho reflects radiance (rho / pi) E for
an irradiance E.
- point light of power P: intensity P / (4 pi), E = P / (4 pi) cos(theta) / r^2
- sun of strength S: E = S cos(theta)
- area light of power P and area A: one-sided Lambertian emitter of radiance P / (pi A)
- sphere light of power P and radius R: radiance P / (4 pi^2 R^2), so E = P cos(theta) / (4 pi d^2)
  while the whole sphere is above the receiver's horizon.

Every expected value below is computed in the test from these formulas (the polygon
formula for rectangles, exact integrals for disks and ellipses), never from Primer.

Sampled lights are integrated with a jittered m x m grid of unit-square samples made
here with a fixed seed. For an integrand that is Lipschitz on the unit square with
constant K, a jittered grid of N = m^2 strata has a standard error of at most about
K / (sqrt(6) N) (each stratum contributes variance <= (K h)^2 / 6 with h = 1 / m).
With N = 384^2 ~ 1.5e5 and K / E of order 10 for the nearby lights used here, that is
below ~3e-5 of E, so the 1e-3 relative tolerances are > 30 standard errors while still
far below any modelling error (a wrong cosine, area or radiance changes E by > 1 %).
"""

import math

import numpy as np
import pytest

from conftest import rotation, unit

from core.camera import Camera, generate_rays
from core.render import render
from core.scene import AreaLight, Mesh, PointLight, RenderSettings, Scene, SpotLight, SunLight

GRID_SIDE = 384                    # jittered grid of 384 x 384 = 147456 light samples
SAMPLING_RTOL = 1e-3               # see the module docstring for why this is honest


# ----------------------------------------------------------------------------
# Helpers: geometry, closed forms, sampling
# ----------------------------------------------------------------------------

def perpendicular(axis):
    """Return a unit vector perpendicular to the unit `axis`."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    return unit(np.cross(axis, helper))


def light_sample(light, points, u, cone=None):
    """The light's sample at each point (Light.sample)."""
    return light.sample(points, u, cone)


def jittered_grid(side=GRID_SIDE, seed=1234):
    """Return (side^2, 2) jittered-grid points in [0, 1)^2: one uniform point per square stratum."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    cells = np.stack([i.ravel(), j.ravel()], axis=1).astype(np.float64)
    return (cells + rng.random(cells.shape)) / side


def sampled_irradiance(light, point, normal, u=None):
    """Return the (3,) average of irradiance * max(N.L, 0) over stratified light samples at one point."""
    u = jittered_grid() if u is None else u
    points = np.broadcast_to(np.asarray(point, np.float64), (len(u), 3)).copy()
    sample = light_sample(light, points, u)
    cosine = np.maximum(sample.L @ np.asarray(normal, np.float64), 0.0)
    return (sample.irradiance * cosine[:, None]).mean(axis=0)


def clip_to_upper_half_space(polygon, normal):
    """Return the part of a convex polygon ((k, 3) points relative to the receiver) with normal . p >= 0."""
    out = []
    k = len(polygon)
    for i in range(k):
        a, b = polygon[i], polygon[(i + 1) % k]
        da, db = normal @ a, normal @ b
        if da >= 0.0:
            out.append(a)
        if da * db < 0.0:
            out.append(a + (b - a) * (da / (da - db)))
    return np.array(out)


def polygon_irradiance(radiance, corners, point, normal):
    """Irradiance at `point` (unit `normal`) from a Lambertian polygon of constant radiance.

    Lambert's formula: E = L / 2 * |sum_i Theta_i (n . gamma_i)|, with Theta_i the angle
    subtended by edge i and gamma_i the unit normal of the plane through the point and
    that edge. The polygon is first clipped to the receiver's upper half space.
    """
    normal = np.asarray(normal, np.float64)
    polygon = clip_to_upper_half_space(np.asarray(corners, np.float64) - point, normal)
    if len(polygon) < 3:
        return 0.0
    total = 0.0
    for i in range(len(polygon)):
        a, b = polygon[i], polygon[(i + 1) % len(polygon)]
        cross = np.cross(a, b)
        angle = math.atan2(np.linalg.norm(cross), a @ b)
        total += angle * (normal @ cross) / np.linalg.norm(cross)
    return 0.5 * radiance * abs(total)


def parallelogram_corners(center, axis_u, axis_v):
    """Return the 4 corners of the parallelogram center +- axis_u / 2 +- axis_v / 2, in order."""
    c, hu, hv = np.asarray(center, float), 0.5 * np.asarray(axis_u, float), 0.5 * np.asarray(axis_v, float)
    return np.array([c - hu - hv, c + hu - hv, c + hu + hv, c - hu + hv])


def ortho_camera_looking_down(height, scale):
    """Return an orthographic camera at (0, 0, height) looking along -Z, seeing `scale` x `scale` units."""
    matrix = np.eye(4)
    matrix[2, 3] = height
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=scale, clip_start=0.1, clip_end=100.0)


def pixel_centre_points(camera, width, height, surface_z):
    """Return (H, W, 3) points where the rays through the pixel centres meet the surface z = surface_z(x, y).

    surface_z: callable on (n,) x, y arrays; the rays are vertical (orthographic camera looking down).
    """
    ys, xs = np.mgrid[0:height, 0:width]
    rays = generate_rays(camera, width, height, xs.ravel() + 0.5, ys.ravel() + 0.5)
    assert np.allclose(rays.directions, [0.0, 0.0, -1.0])
    x, y = rays.origins[:, 0], rays.origins[:, 1]
    points = np.stack([x, y, surface_z(x, y)], axis=1)
    return points.reshape(height, width, 3)


def ground_plane(size=40.0):
    """Return a flat square of side `size` at z = 0 facing +Z (two counter-clockwise triangles)."""
    h = 0.5 * size
    return Mesh(np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]]),
                np.array([[0, 1, 2], [0, 2, 3]]))


def plane_scene(camera, albedo, lights):
    """Return a scene with one diffuse ground plane of `albedo` and the given lights."""
    scene = Scene(camera=camera)
    scene.add_material(albedo)
    scene.add_mesh(ground_plane())
    scene.lights.extend(lights)
    return scene


def point_light_radiance(albedo, color, power, light_position, points, normal=(0.0, 0.0, 1.0)):
    """Return (..., 3) radiance (albedo / pi) * P / (4 pi) * max(cos theta, 0) / r^2 * color."""
    w = np.asarray(light_position, float) - points
    r = np.linalg.norm(w, axis=-1)
    cosine = np.maximum((w @ np.asarray(normal, float)) / r, 0.0)
    irradiance = power / (4.0 * math.pi) * cosine / (r * r)
    return (np.asarray(albedo, float) * np.asarray(color, float) / math.pi) * irradiance[..., None]


# ----------------------------------------------------------------------------
# Image level: exact lights through core.render.render, one sample per pixel centre
# ----------------------------------------------------------------------------

EXACT = RenderSettings(width=16, height=16, samples=1, jitter=False, seed=3)


def test_point_light_inverse_square_and_cosine_law_per_pixel():
    """Each pixel of a plane under a point light is (rho/pi) P/(4 pi) cos(theta)/r^2 (to 1e-4 relative)."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    albedo, power, position = (0.7, 0.7, 0.7), 500.0, np.array([0.3, -0.2, 1.5])
    scene = plane_scene(camera, albedo, [PointLight(position=position, power=power)])
    image = render(scene, EXACT).image
    points = pixel_centre_points(camera, 16, 16, lambda x, y: np.zeros_like(x))
    expected = point_light_radiance(albedo, (1.0, 1.0, 1.0), power, position, points)
    np.testing.assert_allclose(image[..., :3], expected, rtol=1e-4)
    # Non-trivial: the image spans a wide range of distances and angles.
    assert expected[..., 0].max() > 3.0 * expected[..., 0].min() > 0.0
    np.testing.assert_array_equal(image[..., 3], 1.0)


def test_point_light_inverse_square():
    """Doubling the height of a point light above a pixel divides that pixel's radiance by exactly 4."""
    camera = ortho_camera_looking_down(10.0, 4.0)
    # Pixel centres of a 16 x 16 image over 4 units sit at -1.875 + 0.25 k; put the light over one.
    over = np.array([0.125, 0.125])
    row, col = 7, 8                 # raster row 7 (from the top) has y = +0.125; column 8 has x = +0.125
    values = []
    for height in (1.0, 2.0):
        position = np.array([over[0], over[1], height])
        scene = plane_scene(camera, (0.5, 0.5, 0.5), [PointLight(position=position, power=300.0)])
        values.append(float(render(scene, EXACT).image[row, col, 0]))
    expected_near = 0.5 / math.pi * 300.0 / (4.0 * math.pi) / 1.0 ** 2
    assert values[0] == pytest.approx(expected_near, rel=1e-5)
    assert values[0] / values[1] == pytest.approx(4.0, rel=1e-5)


def test_light_color_and_material_color_multiply_per_channel():
    """Absorption: each channel's radiance is albedo_c * color_c / pi times the irradiance."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    albedo, color = np.array([0.2, 0.6, 0.9]), np.array([1.0, 0.5, 0.25])
    position, power = np.array([-0.4, 0.5, 2.0]), 800.0
    scene = plane_scene(camera, albedo, [PointLight(position=position, power=power, color=color)])
    image = render(scene, EXACT).image
    points = pixel_centre_points(camera, 16, 16, lambda x, y: np.zeros_like(x))
    expected = point_light_radiance(albedo, color, power, position, points)
    np.testing.assert_allclose(image[..., :3], expected, rtol=1e-4)
    # The channel ratios are the products albedo * color, not either factor alone.
    ratios = image[..., :3] / image[..., :1]
    np.testing.assert_allclose(ratios, np.broadcast_to(albedo * color / (albedo[0] * color[0]), ratios.shape),
                               rtol=1e-5)


@pytest.mark.parametrize("elevation_deg", [10.0, 35.0, 60.0, 90.0])
def test_sun_irradiance_is_strength_times_cosine(elevation_deg):
    """A sun of strength S at elevation e lights a horizontal plane with E = S cos(90deg - e), no falloff."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    elevation, azimuth = math.radians(elevation_deg), math.radians(30.0)
    towards_sun = np.array([math.cos(elevation) * math.cos(azimuth),
                            math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
    albedo, strength = np.array([0.8, 0.5, 0.3]), 3.0
    scene = plane_scene(camera, albedo, [SunLight(direction=-towards_sun, strength=strength)])
    image = render(scene, RenderSettings(width=8, height=8, samples=1, jitter=False)).image
    expected = albedo / math.pi * strength * math.sin(elevation)
    assert expected.min() > 0.0
    np.testing.assert_allclose(image[..., :3], np.broadcast_to(expected, (8, 8, 3)), rtol=1e-5)


def roof_mesh():
    """Return a ridge roof z = 1 - |x| for x in [-1, 1], y in [-3, 3]; faces point up-left and up-right."""
    vertices = np.array([[-1.0, -3.0, 0.0], [0.0, -3.0, 1.0], [0.0, 3.0, 1.0], [-1.0, 3.0, 0.0],
                         [1.0, -3.0, 0.0], [1.0, 3.0, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3],      # left face, normal (-1, 0, 1) / sqrt(2)
                          [1, 4, 5], [1, 5, 2]])     # right face, normal (1, 0, 1) / sqrt(2)
    return Mesh(vertices, triangles)


@pytest.mark.parametrize("elevation_deg", [10.0, 30.0])
def test_sun_below_a_faces_horizon_gives_exactly_zero(elevation_deg):
    """N.L is clamped at 0: a roof face turned away from a low sun is exactly black, the other is S cos(theta)."""
    camera = ortho_camera_looking_down(5.0, 2.0)
    scene = Scene(camera=camera)
    albedo = np.array([0.6, 0.6, 0.6])
    scene.add_material(albedo)
    scene.add_mesh(roof_mesh())
    e = math.radians(elevation_deg)
    towards_sun = np.array([math.cos(e), 0.0, math.sin(e)])
    scene.lights.append(SunLight(direction=-towards_sun, strength=2.0))
    image = render(scene, RenderSettings(width=8, height=8, samples=1, jitter=False)).image
    points = pixel_centre_points(camera, 8, 8, lambda x, y: 1.0 - np.abs(x))
    left = points[..., 0] < 0.0
    # The left face's normal is (-1, 0, 1)/sqrt(2): cos = (sin e - cos e)/sqrt(2) < 0 for e < 45 deg.
    assert (math.sin(e) - math.cos(e)) / math.sqrt(2.0) < 0.0
    assert np.all(image[left][:, :3] == 0.0)
    np.testing.assert_array_equal(image[left][:, 3], 1.0)        # hit, but unlit
    lit = albedo / math.pi * 2.0 * (math.cos(e) + math.sin(e)) / math.sqrt(2.0)
    np.testing.assert_allclose(image[~left][:, :3], np.broadcast_to(lit, (int((~left).sum()), 3)), rtol=1e-5)


def test_point_light_below_the_plane_adds_exactly_zero():
    """A point light under the plane is below every pixel's horizon: it adds exactly 0, alone or with another light."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    albedo = (0.5, 0.5, 0.5)
    below = PointLight(position=np.array([0.1, 0.2, -0.5]), power=1000.0)
    alone = render(plane_scene(camera, albedo, [below]), EXACT).image
    assert np.all(alone[..., :3] == 0.0)
    above = PointLight(position=np.array([-0.3, 0.4, 1.0]), power=200.0)
    both = render(plane_scene(camera, albedo, [below, above]), EXACT).image
    points = pixel_centre_points(camera, 16, 16, lambda x, y: np.zeros_like(x))
    expected = point_light_radiance(albedo, (1.0, 1.0, 1.0), 200.0, above.position, points)
    assert expected.min() > 0.0
    np.testing.assert_allclose(both[..., :3], expected, rtol=1e-4)


# ----------------------------------------------------------------------------
# Light sampling: Light.sample (core/lights) against closed-form irradiance
# ----------------------------------------------------------------------------

def test_only_lights_without_extent_are_delta():
    """Lights without extent (point, spot of radius 0, sun of angle 0) are evaluated exactly, the rest sampled."""
    assert PointLight(position=np.zeros(3)).delta
    assert SpotLight(position=np.zeros(3), direction=np.array([0.0, 0.0, -1.0])).delta
    assert SunLight(direction=np.array([0.0, 0.0, -1.0])).delta
    assert not PointLight(position=np.zeros(3), radius=0.1).delta
    assert not SunLight(direction=np.array([0.0, 0.0, -1.0]), angle=0.01).delta
    assert not AreaLight(center=np.zeros(3), axis_u=np.array([1.0, 0, 0]),
                         axis_v=np.array([0, 1.0, 0]), direction=np.array([0, 0, -1.0])).delta


def test_point_light_sample_is_intensity_over_distance_squared():
    """A point light's single exact sample carries E_normal = P/(4 pi r^2) along the unit direction to the light."""
    position = np.array([1.0, -2.0, 3.0])
    points = np.array([[0.0, 0.0, 0.0], [1.0, -2.0, 0.0], [4.0, 2.0, 3.0]])
    sample = light_sample(PointLight(position=position, power=250.0, color=np.array([1.0, 0.5, 0.0])),
                          points, np.zeros((3, 2)))
    r = np.linalg.norm(position - points, axis=1)
    np.testing.assert_allclose(sample.distance, r, rtol=1e-15)
    np.testing.assert_allclose(sample.L, (position - points) / r[:, None], rtol=1e-15)
    expected = 250.0 / (4.0 * math.pi * r * r)
    np.testing.assert_allclose(sample.irradiance, expected[:, None] * [1.0, 0.5, 0.0], rtol=1e-14)
    assert expected.min() > 0.0


@pytest.mark.parametrize("height", [0.25, 1.0, 4.0])
def test_disk_area_light_on_axis_irradiance(height):
    """A disk light of radius R, radiance L, seen on its axis at distance h gives E = L pi R^2 / (R^2 + h^2)."""
    radius, power = 0.75, 60.0
    light = AreaLight(center=np.array([0.0, 0.0, height]), axis_u=np.array([2 * radius, 0.0, 0.0]),
                      axis_v=np.array([0.0, 2 * radius, 0.0]), direction=np.array([0.0, 0.0, -1.0]),
                      power=power, shape="DISK")
    radiance = power / (math.pi * math.pi * radius ** 2)
    expected = radiance * math.pi * radius ** 2 / (radius ** 2 + height ** 2)
    estimate = sampled_irradiance(light, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(estimate, expected, rtol=SAMPLING_RTOL)


def tilted_rectangle():
    """Return a 1.5 x 0.8 rectangle light tilted 25 deg about X, 2 units up, shining downwards."""
    frame = rotation([1.0, 0.0, 0.0], math.radians(25.0)) @ rotation([0.0, 0.0, 1.0], math.radians(10.0))
    axis_u, axis_v = frame @ [1.5, 0.0, 0.0], frame @ [0.0, 0.8, 0.0]
    direction = -unit(np.cross(axis_u, axis_v))
    assert direction[2] < 0.0
    return AreaLight(center=np.array([0.2, -0.1, 2.0]), axis_u=axis_u, axis_v=axis_v, direction=direction,
                     power=40.0, color=np.array([1.0, 0.8, 0.6]), shape="RECTANGLE")


# (receiver point, receiver normal): on the axis, off axis, tilted, and one whose horizon cuts the light.
RECEIVERS = [
    ((0.2, -0.1, 0.0), (0.0, 0.0, 1.0)),
    ((1.6, 0.9, 0.0), (0.0, 0.0, 1.0)),
    ((-0.5, 0.4, 0.6), tuple(unit([1.0, -0.5, 2.0]))),
    ((0.3, -0.3, 1.2), tuple(unit([1.0, 0.2, 0.1]))),
]


@pytest.mark.parametrize("point, normal", RECEIVERS)
def test_rectangle_area_light_matches_lambert_polygon_formula(point, normal):
    """A rectangle light's sampled irradiance equals Lambert's polygon formula (clipped at the receiver's horizon)."""
    light = tilted_rectangle()
    point, normal = np.array(point), np.array(normal)
    corners = parallelogram_corners(light.center, light.axis_u, light.axis_v)
    area = np.linalg.norm(np.cross(light.axis_u, light.axis_v))
    radiance = light.power / (math.pi * area)
    expected = polygon_irradiance(radiance, corners, point, normal) * light.color
    assert expected[0] > 0.0
    estimate = sampled_irradiance(light, point, normal)
    np.testing.assert_allclose(estimate, expected, rtol=SAMPLING_RTOL)


def test_rectangle_receiver_list_includes_a_light_cut_by_the_horizon():
    """Guard for the polygon test: one receiver sees the light straddle its horizon (exercises max(N.L, 0))."""
    light = tilted_rectangle()
    corners = parallelogram_corners(light.center, light.axis_u, light.axis_v)
    point, normal = np.array(RECEIVERS[3][0]), np.array(RECEIVERS[3][1])
    heights = (corners - point) @ normal
    assert heights.min() < 0.0 < heights.max()
    # And the clipped formula is then strictly below the unclipped one.
    radiance = 1.0
    clipped = polygon_irradiance(radiance, corners, point, normal)
    v = corners - point
    unclipped = 0.5 * abs(sum(math.atan2(np.linalg.norm(np.cross(v[i], v[(i + 1) % 4])), v[i] @ v[(i + 1) % 4])
                              * normal @ unit(np.cross(v[i], v[(i + 1) % 4])) for i in range(4)))
    assert 0.0 < clipped and clipped != pytest.approx(unclipped, rel=1e-2)


def test_parallelogram_area_light_matches_lambert_polygon_formula():
    """A light with non-orthogonal axes is the parallelogram they span: area |u x v|, polygon-formula irradiance."""
    axis_u, axis_v = np.array([1.2, 0.0, 0.0]), np.array([0.5, 0.9, 0.0])
    light = AreaLight(center=np.array([0.0, 0.0, 1.5]), axis_u=axis_u, axis_v=axis_v,
                      direction=np.array([0.0, 0.0, -1.0]), power=25.0, shape="RECTANGLE")
    area = 1.2 * 0.9
    assert light.area() == pytest.approx(area, rel=1e-14)
    point, normal = np.array([0.7, -0.4, 0.0]), np.array([0.0, 0.0, 1.0])
    corners = parallelogram_corners(light.center, axis_u, axis_v)
    expected = polygon_irradiance(25.0 / (math.pi * area), corners, point, normal)
    assert expected > 0.0
    np.testing.assert_allclose(sampled_irradiance(light, point, normal), expected, rtol=SAMPLING_RTOL)


def test_area_light_areas_of_all_shapes():
    """Emitting areas: square/rectangle a*b, disk/ellipse pi*a*b/4 of the full sizes a, b."""
    frame = rotation([1.0, 2.0, 3.0], 0.7)
    a, b = 1.3, 0.4
    for shape, area in (("SQUARE", a * b), ("RECTANGLE", a * b), ("DISK", math.pi * a * b / 4.0),
                        ("ELLIPSE", math.pi * a * b / 4.0)):
        light = AreaLight(center=np.array([5.0, 6.0, 7.0]), axis_u=frame @ [a, 0, 0], axis_v=frame @ [0, b, 0],
                          direction=frame @ [0, 0, -1.0], shape=shape)
        assert light.area() == pytest.approx(area, rel=1e-13), shape


@pytest.mark.parametrize("height", [0.3, 1.0, 3.0])
def test_ellipse_area_light_on_axis_irradiance(height):
    """An ellipse light (semi-axes A, B) on its axis at distance h gives E = L pi / sqrt((1 + h^2/A^2)(1 + h^2/B^2))."""
    # Derivation: E = L int h^2 / (rho^2 + h^2)^2 dA = L/2 int_0^{2pi} r(phi)^2 / (r(phi)^2 + h^2) dphi
    # with 1/r^2 = cos^2/A^2 + sin^2/B^2, and int_0^{2pi} dphi / (p cos^2 + q sin^2) = 2 pi / sqrt(p q).
    frame = rotation([0.3, -1.0, 0.5], 0.9)
    full_a, full_b, power = 1.6, 0.6, 30.0
    center = np.array([0.5, -0.2, 0.3])
    light = AreaLight(center=center, axis_u=frame @ [full_a, 0, 0], axis_v=frame @ [0, full_b, 0],
                      direction=frame @ [0, 0, -1.0], power=power, shape="ELLIPSE")
    A, B = full_a / 2.0, full_b / 2.0
    radiance = power / (math.pi * math.pi * A * B)
    expected = radiance * math.pi / math.sqrt((1.0 + height ** 2 / A ** 2) * (1.0 + height ** 2 / B ** 2))
    point = center + height * light.direction
    estimate = sampled_irradiance(light, point, -light.direction)
    np.testing.assert_allclose(estimate, expected, rtol=SAMPLING_RTOL)


@pytest.mark.parametrize("shape", ["SQUARE", "DISK"])
def test_area_light_is_one_sided(shape):
    """An area light emits only on the side of `direction`: a point behind it receives exactly nothing."""
    light = AreaLight(center=np.array([0.0, 0.0, 1.0]), axis_u=np.array([1.0, 0.0, 0.0]),
                      axis_v=np.array([0.0, 1.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]),
                      power=50.0, shape=shape)
    u = jittered_grid(64)
    behind = light_sample(light, np.broadcast_to([0.1, 0.2, 2.0], (len(u), 3)).copy(), u)
    assert np.all(behind.irradiance == 0.0)
    # The mirror image point in front, facing the light, receives light (so the zero is not trivial).
    front = sampled_irradiance(light, np.array([0.1, 0.2, 0.0]), np.array([0.0, 0.0, 1.0]), u)
    assert front[0] > 0.1


@pytest.mark.parametrize("theta_deg", [0.0, 35.0, 70.0, 79.0])
def test_sun_with_angle_gives_strength_times_cosine(theta_deg):
    """A sun disk of angular diameter 2a, fully above the horizon, gives E = S cos(theta) like a sharp sun."""
    angle = math.radians(20.0)                      # angular diameter; radius 10 deg, so 79 + 10 < 90
    normal = unit([0.2, -0.4, 1.0])
    tilt_axis = perpendicular(normal)
    towards_sun = rotation(tilt_axis, math.radians(theta_deg)) @ normal
    sun = SunLight(direction=-towards_sun, strength=4.0, color=np.array([1.0, 0.9, 0.5]), angle=angle)
    expected = 4.0 * math.cos(math.radians(theta_deg)) * sun.color
    u = jittered_grid()
    estimate = sampled_irradiance(sun, np.zeros(3), normal, u)
    np.testing.assert_allclose(estimate, expected, rtol=SAMPLING_RTOL)
    # Every sampled direction lies inside the sun's disk.
    sample = light_sample(sun, np.zeros((len(u), 3)), u)
    assert np.all(sample.L @ towards_sun >= math.cos(0.5 * angle) - 1e-12)
    assert np.all(np.isinf(sample.distance))


def test_sun_disk_on_the_horizon_still_lights_the_surface():
    """A sun disk centred on the horizon lights the surface with its upper half (a sharp sun would give 0)."""
    angle = math.radians(20.0)
    sun = SunLight(direction=np.array([-1.0, 0.0, 0.0]), strength=4.0, angle=angle)     # comes from +X
    estimate = sampled_irradiance(sun, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    # Upper half of a cone of half-angle a around the horizon, radiance L = S / (pi sin^2 a):
    # directions (cos b, sin b cos p, sin b sin p), z = sin b sin p, dw = sin b db dp, so
    # E = L int_0^a int_0^pi sin^2 b sin p dp db = L (a - sin a cos a).
    a = 0.5 * angle
    expected = 4.0 / (math.pi * math.sin(a) ** 2) * (a - math.sin(a) * math.cos(a))
    assert expected > 0.0
    np.testing.assert_allclose(estimate, expected, rtol=SAMPLING_RTOL)


def sphere_light(**kw):
    """Return a point light with radius as a uniform sphere (Blender's soft falloff off)."""
    return PointLight(soft_falloff=False, **kw)


@pytest.mark.parametrize("theta_deg", [0.0, 40.0, 75.0])
def test_sphere_light_fully_above_horizon_gives_point_light_irradiance(theta_deg):
    """A sphere light fully above the horizon gives exactly E = P cos(theta) / (4 pi d^2) (Nusselt)."""
    radius, distance, power = 0.5, 3.0, 120.0
    assert math.degrees(math.asin(radius / distance)) + theta_deg < 90.0
    normal = unit([0.3, 0.1, 1.0])
    point = np.array([0.4, -0.3, 0.2])
    towards = rotation(perpendicular(normal), math.radians(theta_deg)) @ normal
    center = point + distance * towards
    light = sphere_light(position=center, power=power, radius=radius, color=np.array([0.5, 1.0, 0.25]))
    expected = power * math.cos(math.radians(theta_deg)) / (4.0 * math.pi * distance ** 2) * light.color
    u = jittered_grid()
    np.testing.assert_allclose(sampled_irradiance(light, point, normal, u), expected, rtol=SAMPLING_RTOL)
    # The sampled points lie on the sphere, at the reported distance along L.
    sample = light_sample(light, np.broadcast_to(point, (len(u), 3)).copy(), u)
    np.testing.assert_allclose(np.linalg.norm(sample.position - center, axis=1), radius, rtol=1e-9)
    np.testing.assert_allclose(point + sample.L * sample.distance[:, None], sample.position, atol=1e-12)
    # The near side of the sphere is between d - R (straight at it) and sqrt(d^2 - R^2) (tangent) away.
    assert np.all(sample.distance >= distance - radius - 1e-12)
    assert np.all(sample.distance <= math.sqrt(distance ** 2 - radius ** 2) + 1e-9)


def test_sphere_light_converges_to_point_light_far_away():
    """Far away, every sample of a sphere light approaches the point light's exact value, with error O(R/d)."""
    radius, power = 0.2, 100.0
    normal = np.array([0.0, 0.0, 1.0])
    towards = unit([0.6, 0.0, 1.0])                                 # theta ~ 31 deg
    u = jittered_grid(32)
    errors = []
    for ratio in (10.0, 100.0, 1000.0):
        d = ratio * radius
        center = d * towards
        sphere = light_sample(sphere_light(position=center, power=power, radius=radius), np.zeros((len(u), 3)), u)
        point = light_sample(PointLight(position=center, power=power), np.zeros((1, 3)), u[:1])
        exact = power / (4.0 * math.pi * d * d) * (towards @ normal)
        assert float(point.irradiance[0, 0] * (point.L[0] @ normal)) == pytest.approx(exact, rel=1e-13)
        per_sample = sphere.irradiance[:, 0] * np.maximum(sphere.L @ normal, 0.0)
        error = np.abs(per_sample - exact).max() / exact
        # Bound: radiance * solid angle = P/(4 pi d^2) * 2/(1 + cos a) with sin a = R/d, and
        # |N.L - N.C| <= |L - C| <= 2 sin(a/2) for L within the cone of half-angle a.
        a = math.asin(radius / d)
        scale = 2.0 / (1.0 + math.cos(a))
        bound = (scale * (towards @ normal + 2.0 * math.sin(0.5 * a)) - towards @ normal) / (towards @ normal)
        assert error <= bound * (1 + 1e-9)
        errors.append(error)
    assert errors[0] > errors[1] > errors[2] > 0.0
    assert errors[2] < 5e-3


# --- spot lights ------------------------------------------------------------------

SPOT_AXIS = unit([1.0, -1.0, -2.0])


def spot(size_deg=60.0, blend=0.4, **kw):
    """Return a spot light at the origin shining along SPOT_AXIS."""
    return SpotLight(position=np.zeros(3), direction=SPOT_AXIS, power=kw.pop("power", 200.0),
                     spot_size=math.radians(size_deg), spot_blend=blend, **kw)


def directions_at_angles(axis, angles, around=0.3):
    """Return unit directions (n, 3) at the given angles (radians) from `axis`, rotated about it by `around`."""
    side = rotation(axis, around) @ perpendicular(axis)
    return np.cos(angles)[:, None] * axis + np.sin(angles)[:, None] * side


def blend_band(size_deg, blend):
    """Return (cos of the outer cone edge, cos of the inner cone edge) of the documented blend band."""
    cos_half = math.cos(0.5 * math.radians(size_deg))
    return cos_half, cos_half + blend * (1.0 - cos_half)


def test_spot_attenuation_is_one_inside_inner_cone_and_zero_outside_cone():
    """The spot factor is exactly 1 inside the inner cone and exactly 0 outside spot_size/2."""
    light = spot(60.0, 0.4)
    cos_outer, cos_inner = blend_band(60.0, 0.4)
    inner_angle, outer_angle = math.acos(cos_inner), math.acos(cos_outer)
    inside = np.linspace(0.0, inner_angle * (1 - 1e-6), 50)
    outside = np.linspace(outer_angle * (1 + 1e-6), math.pi, 50)
    np.testing.assert_array_equal(light.attenuation(directions_at_angles(SPOT_AXIS, inside)), 1.0)
    np.testing.assert_array_equal(light.attenuation(directions_at_angles(SPOT_AXIS, outside)), 0.0)


def test_spot_attenuation_blend_band_is_monotonic_smooth_and_half_at_middle():
    """In the blend band the factor decreases monotonically from 1 to 0 and is 0.5 at the middle (in cos space)."""
    light = spot(60.0, 0.4)
    cos_outer, cos_inner = blend_band(60.0, 0.4)
    cosines = np.linspace(cos_inner, cos_outer, 201)                  # from the inner edge outwards
    factor = light.attenuation(directions_at_angles(SPOT_AXIS, np.arccos(cosines)))
    assert np.all((factor >= 0.0) & (factor <= 1.0))
    assert np.all(np.diff(factor) <= 1e-15)                            # non-increasing outwards
    assert np.all((factor[1:-1] > 0.0) & (factor[1:-1] < 1.0))         # strictly inside the band: partial
    assert factor[0] == pytest.approx(1.0, abs=1e-9) and factor[-1] == pytest.approx(0.0, abs=1e-9)
    middle = directions_at_angles(SPOT_AXIS, np.array([math.acos(0.5 * (cos_inner + cos_outer))]))
    assert light.attenuation(middle)[0] == pytest.approx(0.5, abs=1e-9)


def test_spot_without_blend_has_a_hard_edge():
    """With spot_blend = 0 the cone edge is sharp: 1 just inside spot_size/2, 0 just outside."""
    light = spot(40.0, 0.0)
    half = math.radians(20.0)
    factor = light.attenuation(directions_at_angles(SPOT_AXIS, np.array([0.0, half - 1e-4, half + 1e-4])))
    np.testing.assert_array_equal(factor, [1.0, 1.0, 0.0])


def test_spot_inside_cone_equals_point_light_and_is_dark_outside():
    """Through sample_light a spot equals the point light P/(4 pi r^2) inside its inner cone, 0 outside, and between in the band."""
    light = spot(60.0, 0.4, power=200.0, color=np.array([1.0, 0.7, 0.2]))
    cos_outer, cos_inner = blend_band(60.0, 0.4)
    angles = np.array([0.0, 0.5 * math.acos(cos_inner), math.acos(0.5 * (cos_inner + cos_outer)),
                       math.acos(cos_outer) + 0.05, 2.5])
    distances = np.array([1.0, 2.0, 1.5, 3.0, 1.0])
    points = directions_at_angles(SPOT_AXIS, angles) * distances[:, None]
    sample = light_sample(light, points, np.zeros((5, 2)))
    point_light = 200.0 / (4.0 * math.pi * distances ** 2)
    np.testing.assert_allclose(sample.irradiance[:2], point_light[:2, None] * light.color, rtol=1e-14)
    assert 0.0 < sample.irradiance[2, 0] < point_light[2]
    assert sample.irradiance[2, 0] == pytest.approx(0.5 * point_light[2], rel=1e-9)
    np.testing.assert_array_equal(sample.irradiance[3:], 0.0)
    # The spot shines along `direction`: the point straight behind it is dark, the one ahead is lit.
    ahead_behind = light_sample(light, np.array([SPOT_AXIS, -SPOT_AXIS]), np.zeros((2, 2)))
    assert ahead_behind.irradiance[0, 0] > 0.0 and np.all(ahead_behind.irradiance[1] == 0.0)


# ----------------------------------------------------------------------------
# Through a full render: an area light over a plane, many light samples
# ----------------------------------------------------------------------------

def square_light_over_plane():
    """Return a 1 x 1 square light 1 unit above z = 0, shining down, of 100 W."""
    return AreaLight(center=np.array([0.1, -0.05, 1.0]), axis_u=np.array([1.0, 0.0, 0.0]),
                     axis_v=np.array([0.0, 1.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]),
                     power=100.0, shape="SQUARE")


def expected_area_light_image(camera, light, albedo, width, height, sub):
    """Return (H, W) mean of (rho/pi) E over the sub x sub stratum centres of each pixel (a non-jittered box filter)."""
    corners = parallelogram_corners(light.center, light.axis_u, light.axis_v)
    radiance = light.power / (math.pi * np.linalg.norm(np.cross(light.axis_u, light.axis_v)))
    ys, xs = np.mgrid[0:height, 0:width]
    total = np.zeros((height, width))
    for k in range(sub * sub):
        dx, dy = ((k % sub) + 0.5) / sub, ((k // sub) + 0.5) / sub
        rays = generate_rays(camera, width, height, xs.ravel() + dx, ys.ravel() + dy)
        e = [polygon_irradiance(radiance, corners, np.array([o[0], o[1], 0.0]), np.array([0.0, 0.0, 1.0]))
             for o in rays.origins]
        total += np.reshape(e, (height, width))
    return albedo / math.pi * total / (sub * sub)


def test_area_light_render_one_camera_sample_matches_closed_form():
    """Rendered pixels under a square light equal (rho/pi) times the polygon-formula irradiance at the pixel centre."""
    # samples=1 without jitter: the camera ray goes through the pixel centre, and the 32 x 32
    # stratified light samples of each pixel integrate a smooth integrand: the error is of order
    # K / (sqrt(6) N) ~ 1e-3 (measured max 2e-3 over the 64 pixels), so 1e-2 separates sampling
    # noise from any modelling error (a wrong radiance, area or cosine is off by far more).
    camera = ortho_camera_looking_down(5.0, 2.0)
    light = square_light_over_plane()
    scene = plane_scene(camera, (0.5, 0.5, 0.5), [light])
    settings = RenderSettings(width=8, height=8, samples=1, light_samples=1024, jitter=False, seed=7)
    image = render(scene, settings).image
    expected = expected_area_light_image(camera, light, 0.5, 8, 8, sub=1)
    assert expected.min() > 0.0
    np.testing.assert_allclose(image[..., 0], expected, rtol=1e-2)


def test_area_light_render_many_camera_samples_matches_pixel_average():
    """With samples > 1 each pixel is the box-filtered (rho/pi) E over its camera samples: light sampling stays unbiased."""
    # Without jitter the 16 camera samples sit at the centres of a 4 x 4 grid of sub-pixels
    # (core.sampling.sobol.stratum_centres), so the exact pixel value is the mean of the
    # closed form over those 16 points. 16 x 256 = 4096 stratified light samples per pixel give a
    # sampling error ~1e-4; the 1e-2 tolerance leaves room for that, not for a biased estimate.
    camera = ortho_camera_looking_down(5.0, 2.0)
    light = square_light_over_plane()
    scene = plane_scene(camera, (0.5, 0.5, 0.5), [light])
    settings = RenderSettings(width=8, height=8, samples=16, light_samples=256, jitter=False, seed=7)
    image = render(scene, settings).image
    expected = expected_area_light_image(camera, light, 0.5, 8, 8, sub=4)
    assert expected.min() > 0.0
    np.testing.assert_allclose(image[..., 0], expected, rtol=1e-2)


# ----------------------------------------------------------------------------
# Cycles' own conventions (measured against Cycles renders with bpy 5.0.1)
# ----------------------------------------------------------------------------

def cone_illuminance(cos_t, sin2_a):
    """Return the integral of max(cos, 0) over a cone of half-angle a around an axis at angle t to the normal.

    Closed form for a cone that may cross the horizon (Snyder 1996): pi sin^2 a cos t while
    the cone is fully above, otherwise the clipped expression below.
    """
    if cos_t * cos_t > sin2_a:
        return math.pi * sin2_a * max(cos_t, 0.0)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    x = math.sqrt(1.0 / sin2_a - 1.0)
    y = max(-1.0, min(1.0, -x * cos_t / sin_t))
    q = sin_t * math.sqrt(1.0 - y * y)
    return max(0.0, (cos_t * math.acos(y) - x * q) * sin2_a + math.atan2(q, x))


@pytest.mark.parametrize("theta_deg", [0.0, 50.0, 85.0, 100.0])
def test_soft_falloff_point_light_is_a_disk_facing_the_point(theta_deg):
    """Blender's default soft falloff: radiance P/(4 pi^2 R^2) over a disk facing the point, sin^2 a = R^2/(R^2+d^2)."""
    radius, distance, power = 0.6, 1.5, 80.0
    normal = np.array([0.0, 0.0, 1.0])
    towards = rotation([0.0, 1.0, 0.0], math.radians(theta_deg)) @ normal
    light = PointLight(position=distance * towards, power=power, radius=radius)     # soft_falloff defaults on
    radiance = power / (4 * math.pi ** 2 * radius ** 2)
    expected = radiance * cone_illuminance(math.cos(math.radians(theta_deg)), radius ** 2 / (radius ** 2 + distance ** 2))
    got = sampled_irradiance(light, np.zeros(3), normal)[0]
    assert expected > 0
    np.testing.assert_allclose(got, expected, rtol=SAMPLING_RTOL)
    if theta_deg == 0.0:
        # Above the horizon this is P cos(theta) / (4 pi (d^2 + R^2)): softer than 1/d^2 near the light.
        np.testing.assert_allclose(expected, power / (4 * math.pi * (distance ** 2 + radius ** 2)), rtol=1e-12)


def test_sphere_light_crossing_the_horizon_matches_the_clipped_cone():
    """A sphere light half below the receiver's horizon gives L times the clipped cone integral."""
    radius, distance, power = 0.8, 2.0, 50.0
    light = sphere_light(position=np.array([distance * math.cos(0.2), 0.0, distance * math.sin(0.2)]),
                         power=power, radius=radius)
    radiance = power / (4 * math.pi ** 2 * radius ** 2)
    expected = radiance * cone_illuminance(math.sin(0.2), (radius / distance) ** 2)
    got = sampled_irradiance(light, np.zeros(3), [0.0, 0.0, 1.0])[0]
    np.testing.assert_allclose(got, expected, rtol=SAMPLING_RTOL)


def test_spot_blend_is_a_smoothstep_in_cosine():
    """Inside the blend band the factor is 3t^2 - 2t^3 of t = (cos - cos_outer) / ((1 - cos_outer) blend)."""
    light = spot(size_deg=70.0, blend=0.5)
    outer, inner = blend_band(70.0, 0.5)
    cosines = np.linspace(outer, inner, 9)[1:-1]
    t = (cosines - outer) / (inner - outer)
    got = light.attenuation(directions_at_angles(SPOT_AXIS, np.arccos(cosines)))
    np.testing.assert_allclose(got, t * t * (3 - 2 * t), rtol=1e-9)


def test_non_uniformly_scaled_spot_has_an_elliptical_cone():
    """Scaling a spot's frame by (2, 1, 1) widens its cone along local X only: tan(edge) doubles there."""
    half = math.radians(20.0)
    frame = np.diag([2.0, 1.0, 1.0])                       # axis = -Z
    light = SpotLight(position=np.zeros(3), direction=np.array([0.0, 0.0, -1.0]), spot_size=2 * half,
                      spot_blend=0.0, frame=frame)
    def lit(angle, along_x):
        d = np.array([[math.sin(angle), 0.0, -math.cos(angle)] if along_x else [0.0, math.sin(angle), -math.cos(angle)]])
        return light.attenuation(d)[0]
    edge_x = math.atan(2.0 * math.tan(half))
    assert lit(edge_x - 1e-3, True) == 1.0 and lit(edge_x + 1e-3, True) == 0.0
    assert lit(half - 1e-3, False) == 1.0 and lit(half + 1e-3, False) == 0.0


def test_spot_with_radius_applies_the_cone_per_light_sample():
    """A spot of radius R lights a point at its cone edge by L times the integral of (cone factor x cos)
    over the directions to the disk, not by the centre's cone factor times the disk's irradiance."""
    radius, distance, power = 0.5, 2.0, 100.0
    light = SpotLight(position=np.array([0.0, 0.0, distance]), direction=unit([1.0, 0.0, -2.0]),
                      power=power, radius=radius, spot_size=math.radians(40.0), spot_blend=0.0)
    got = sampled_irradiance(light, np.zeros(3), [0.0, 0.0, 1.0])[0]
    # Quadrature of the same integral: directions from the receiver over the disk's cone,
    # each weighted by the hard cone test of the direction from the light to the receiver.
    u = jittered_grid(seed=99)
    sin2 = radius ** 2 / (radius ** 2 + distance ** 2)
    cos_t = 1.0 - u[:, 0] * (1.0 - math.sqrt(1.0 - sin2))
    sin_t = np.sqrt(1.0 - cos_t ** 2)
    phi = 2 * math.pi * u[:, 1]
    L = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)   # around +Z, towards the light
    inside = (-L) @ light.direction > math.cos(math.radians(20.0))
    radiance = power / (4 * math.pi ** 2 * radius ** 2)
    expected = radiance * 2 * math.pi * (1 - math.sqrt(1 - sin2)) * np.mean(inside * L[:, 2])
    centre_factor = light.attenuation(np.array([[0.0, 0.0, -1.0]]))[0]
    assert 0.05 < np.mean(inside) < 0.95                     # the receiver sits on the cone's edge
    np.testing.assert_allclose(got, expected, rtol=5e-3)
    assert abs(got - centre_factor * radiance * cone_illuminance(1.0, sin2)) > 0.05 * got


@pytest.mark.parametrize("spread_deg", [60.0, 120.0])
def test_area_light_spread_keeps_its_power(spread_deg):
    """A narrower spread redistributes the emission: the cosine-weighted average over the hemisphere stays 1."""
    from core.lights.area import spread_attenuation
    theta = (np.arange(200000) + 0.5) / 200000 * (math.pi / 2)
    weight = np.cos(theta) * np.sin(theta) * 2.0          # cos-weighted hemisphere density in theta, integrates to 1
    factor = spread_attenuation(math.radians(spread_deg), np.cos(theta))
    np.testing.assert_allclose(np.sum(factor * weight) * (math.pi / 2) / len(theta), 1.0, rtol=1e-4)
    assert factor[-1] == 0.0 and factor[0] > 1.0
