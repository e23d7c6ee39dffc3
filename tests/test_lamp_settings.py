"""Cycles' per-lamp settings in both kernels, held to closed forms: Cast Shadow, Ray Visibility,
Multiple Importance.

A floor of albedo rho under a point lamp of power P lit at distance r and angle theta has radiance
(rho / pi) P / (4 pi r^2) cos theta; an occluder between them takes it all away unless the lamp casts no shadow
(Cycles' light.use_shadow off: no shadow ray is traced, so its light passes through everything).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from test_lights import (EXACT, expected_area_light_image, ground_plane, ortho_camera_looking_down,
                         pixel_centre_points, plane_scene, point_light_radiance, square_light_over_plane)

from core.render import render
from core.scene import AreaLight, Mesh, PointLight, RenderSettings, Scene, SunLight
from core.visibility import HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY

KERNELS = ["numpy", "compiled"]


def occluded_floor(light):
    """A floor (albedo 0.5) with a 1 x 6 occluder at z = 0.5 over x in [0.5, 1.5], and `light`; with the lamp at
    (2, 0, 1) the occluder's shadow covers the floor's x in [-1, 1], of which x < 0.5 is seen from above."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    scene = plane_scene(camera, (0.5, 0.5, 0.5), [light])
    scene.add_mesh(Mesh(np.array([[0.5, -3.0, 0.5], [1.5, -3.0, 0.5], [1.5, 3.0, 0.5], [0.5, 3.0, 0.5]]),
                        np.array([[0, 1, 2], [0, 2, 3]])))
    return camera, scene


# Columns of the 16 x 16 image over x in [-2, 2] whose floor is in the occluder's shadow and not under it.
SHADOWED_COLUMNS = slice(5, 10)          # pixel centres x = -0.625 .. 0.375


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_without_cast_shadow_lights_the_floor_behind_an_occluder_fully(kernels):
    """Cast Shadow off: the floor in the occluder's shadow gets the full (rho / pi) P / (4 pi r^2) cos theta; with
    it on, nothing (the same pixels: the test can tell the two apart)."""
    position, power = np.array([2.0, 0.0, 1.0]), 400.0
    settings = dataclasses.replace(EXACT, kernels=kernels)
    camera, scene = occluded_floor(PointLight(position=position, power=power, cast_shadow=False))
    image = render(scene, settings).image[..., :3]
    points = pixel_centre_points(camera, 16, 16, lambda x, y: np.zeros_like(x))
    expected = point_light_radiance((0.5, 0.5, 0.5), (1.0, 1.0, 1.0), power, position, points)
    np.testing.assert_allclose(image[:, SHADOWED_COLUMNS], expected[:, SHADOWED_COLUMNS], rtol=1e-5)
    assert expected[:, SHADOWED_COLUMNS].min() > 0.1
    camera, scene = occluded_floor(PointLight(position=position, power=power))
    shadowed = render(scene, settings).image[..., :3]
    np.testing.assert_array_equal(shadowed[:, SHADOWED_COLUMNS], 0.0)


def lamp_over_floor(bsdf, light):
    """A 4 x 4 view from z = 5 of a floor (albedo 0.5, `bsdf`: "DIFFUSE" or "MIRROR") under `light`."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    scene = Scene(camera=camera)
    scene.add_material((0.5, 0.5, 0.5), bsdf=bsdf)
    scene.add_mesh(ground_plane())
    scene.lights.append(light)
    return scene


def large_square_lamp(**settings):
    """A 3 x 3 square lamp 1 unit above the floor, facing down, of 100 W."""
    return AreaLight(center=np.array([0.0, 0.0, 1.0]), axis_u=np.array([3.0, 0.0, 0.0]),
                     axis_v=np.array([0.0, 3.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=100.0,
                     shape="SQUARE", **settings)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_hidden_from_a_kind_of_bounce_lights_no_closure_of_that_kind(kernels):
    """Ray Visibility of a lamp (Cycles' SHADER_EXCLUDE_*): hidden from diffuse rays, it lights no Lambert floor
    (exactly 0) yet a mirror still shows it; hidden from glossy rays, a mirror shows nothing (the BSDF ray passes
    it) and the Lambert floor gets exactly what it gets from a lamp seen by all."""
    settings = dataclasses.replace(EXACT, samples=4, light_samples=4, kernels=kernels, jitter=True)
    images = {(bsdf, hidden): render(lamp_over_floor(bsdf, large_square_lamp(hidden_from=hidden, camera=False)),
                                     settings).image[..., :3]
              for bsdf in ("DIFFUSE", "MIRROR") for hidden in (0, HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY)}
    for bsdf in ("DIFFUSE", "MIRROR"):
        assert images[bsdf, 0].mean() > 0.05
    np.testing.assert_array_equal(images["DIFFUSE", HIDDEN_FROM_DIFFUSE], 0.0)
    np.testing.assert_array_equal(images["DIFFUSE", HIDDEN_FROM_GLOSSY], images["DIFFUSE", 0])
    np.testing.assert_array_equal(images["MIRROR", HIDDEN_FROM_GLOSSY], 0.0)
    np.testing.assert_array_equal(images["MIRROR", HIDDEN_FROM_DIFFUSE], images["MIRROR", 0])


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_area_lamp_without_multiple_importance_converges_to_the_same_irradiance(kernels):
    """Multiple Importance off (Cycles: the lamp is found by its light samples alone, at weight 1; bounces pass it):
    a path-traced Lambert floor under a square lamp still shows (rho / pi) E from the polygon formula at every
    pixel, as with MIS (where BSDF rays find the lamp too); the two differ in their noise only."""
    camera = ortho_camera_looking_down(5.0, 2.0)
    settings = RenderSettings(width=8, height=8, samples=16, light_samples=64, jitter=False, seed=7,
                              integrator="path", max_bounces=0, kernels=kernels)
    expected = expected_area_light_image(camera, square_light_over_plane(), 0.5, 8, 8, sub=4)
    for use_mis in (True, False):
        light = dataclasses.replace(square_light_over_plane(), use_mis=use_mis)
        image = render(plane_scene(camera, (0.5, 0.5, 0.5), [light]), settings).image
        np.testing.assert_allclose(image[..., 0], expected, rtol=1e-2)


def floor_and_wall(light):
    """The floor (albedo 0.5) of `occluded_floor` with its occluder, whose underside sends light back down (a second
    bounce): a path tracer sees more than the direct light."""
    return occluded_floor(light)[1]


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_point_lamp_with_max_bounces_0_lights_only_directly(kernels):
    """A point lamp with Max Bounces 0 (Cycles: no light samples past the camera's hits; a point is never met by a
    bounce) path-traced with 3 bounces gives exactly the direct light: the render with Max Bounces 0 for the whole
    path; the same lamp with Max Bounces 1024 adds the light from the occluder's underside."""
    position, power = np.array([2.0, 0.0, 0.3]), 400.0
    path = dataclasses.replace(EXACT, integrator="path", samples=4, max_bounces=3, diffuse_bounces=3,
                               min_light_bounces=3, kernels=kernels)
    direct = dataclasses.replace(path, max_bounces=0)
    limited = render(floor_and_wall(PointLight(position=position, power=power, max_bounces=0)), path).image
    only_direct = render(floor_and_wall(PointLight(position=position, power=power)), direct).image
    every = render(floor_and_wall(PointLight(position=position, power=power)), path).image
    np.testing.assert_allclose(limited, only_direct, rtol=1e-12, atol=1e-15)
    assert every[..., :3].mean() > 1.01 * limited[..., :3].mean()


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_negative_point_lamp_takes_away_what_its_positive_twin_adds(kernels):
    """A point lamp of power -P (Cycles renders it: its light is subtracted) beside one of power 2P at the same
    place gives exactly (rho / pi) P / (4 pi r^2) cos theta, the closed form of one lamp of power P."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    position, power = np.array([0.3, -0.2, 1.5]), 300.0
    scene = plane_scene(camera, (0.5, 0.5, 0.5), [PointLight(position=position, power=2.0 * power),
                                                   PointLight(position=position, power=-power)])
    image = render(scene, dataclasses.replace(EXACT, kernels=kernels)).image[..., :3]
    points = pixel_centre_points(camera, 16, 16, lambda x, y: np.zeros_like(x))
    expected = point_light_radiance((0.5, 0.5, 0.5), (1.0, 1.0, 1.0), power, position, points)
    np.testing.assert_allclose(image, expected, rtol=1e-6)
    alone = plane_scene(camera, (0.5, 0.5, 0.5), [PointLight(position=position, power=-power)])
    np.testing.assert_allclose(render(alone, dataclasses.replace(EXACT, kernels=kernels)).image[..., :3], -expected,
                               rtol=1e-6)


def sun_below_half_a_floor(**settings):
    """An orthographic camera looking down on a black floor over x < 0 only, and a 10-degree sun straight below
    (direction +Z, as seen from everywhere: down), tilted by `tilt` degrees about Y: the rays over x > 0 escape
    towards it."""
    tilt = math.radians(settings.pop("tilt", 0.0))
    camera = ortho_camera_looking_down(5.0, 4.0)
    scene = Scene(camera=camera)
    scene.add_material((0.0, 0.0, 0.0))
    scene.add_mesh(Mesh(np.array([[-3.0, -3.0, 0.0], [0.0, -3.0, 0.0], [0.0, 3.0, 0.0], [-3.0, 3.0, 0.0]]),
                        np.array([[0, 1, 2], [0, 2, 3]])))
    scene.lights.append(SunLight(direction=np.array([math.sin(tilt), 0.0, math.cos(tilt)]), strength=3.0,
                                 color=np.array([1.0, 0.5, 0.25]), angle=math.radians(10.0), **settings))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_camera_ray_that_escapes_into_a_suns_disc_sees_its_radiance(kernels):
    """Rays that escape inside the disc see S / (pi sin^2(angle / 2)) x colour (Cycles' shade_background adds distant
    lights to escaping camera rays); rays that hit the floor see none of it; a disc tilted past its half angle, a sun
    hidden from the camera, or one with Multiple Importance off (Cycles' distant_light_sample_from_intersection), is
    not seen."""
    settings = dataclasses.replace(EXACT, kernels=kernels)
    image = render(sun_below_half_a_floor(tilt=4.0), settings).image[..., :3]
    radiance = 3.0 / (math.pi * math.sin(math.radians(5.0)) ** 2) * np.array([1.0, 0.5, 0.25])
    np.testing.assert_allclose(image[:, 8:], np.broadcast_to(radiance, (16, 8, 3)), rtol=1e-6)
    np.testing.assert_array_equal(image[:, :8], 0.0)
    for hidden in ({"tilt": 6.0}, {"camera": False}, {"use_mis": False}):
        np.testing.assert_array_equal(render(sun_below_half_a_floor(**hidden), settings).image[..., :3], 0.0)


def sky_under_a_ceiling(cast_shadow: bool) -> Scene:
    """A floor (albedo 0.8) under a black ceiling 1 above it (both 1e4 wide), lit by an image world (a sky 0.05 at
    the nadir to 2.0 at the zenith, row by row) with or without its Shadows, seen from 0.5 above the floor."""
    from conftest import ortho_down
    from core.geometry import primitives
    from core.scene import World
    rows = np.linspace(0.05, 2.0, 16, dtype=np.float32)[:, None, None]       # (row 0 at the bottom)
    world = World(image=np.broadcast_to(rows, (16, 32, 3)).copy(), cast_shadow=cast_shadow)
    scene = Scene(camera=ortho_down(height=0.5, scale=0.2), world=world)
    scene.add_material((0.8, 0.8, 0.8))
    scene.add_material((0.0, 0.0, 0.0), name="Ceiling")
    scene.add_mesh(primitives.plane(1e4), materials=np.array([0]))
    scene.add_mesh(primitives.plane(1e4, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_world_without_shadows_lights_a_covered_floor_by_the_mis_weight_of_one_light_sample(kernels):
    """The world's Shadows off (Blender 5.2, Cycles' background light without cast_shadow): its light samples pass
    the ceiling, its BSDF rays do not, so the covered floor gets (rho / pi) integral of L cos w dw over the upper
    hemisphere with w the power heuristic of ONE light sample, p_l^2 / (p_l^2 + p_b^2) (p_l the world map's pdf, p_b
    cos / pi), as Cycles weighs its one sample per hit (measured in Cycles 5.2.3: 0.328 against this 0.329), whatever
    Primer's Light Samples (4 weighed as 4 samples gave 1.03); with the Shadows on, the floor is dark."""
    from core.lights.world import WorldLight
    scene = sky_under_a_ceiling(False)
    light = WorldLight.of(scene.world, kernels="numpy")
    n_theta, n_phi = 4000, 64                       # (the midpoint rule over the upper hemisphere)
    theta = (np.arange(n_theta) + 0.5) / n_theta * (0.5 * math.pi)
    phi = (np.arange(n_phi) + 0.5) / n_phi * (2.0 * math.pi)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    D = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    L = scene.world.radiance(D)[:, 0]
    p_l, p_b = light.pdf(D), np.cos(t).ravel() / math.pi
    weight = p_l ** 2 / (p_l ** 2 + p_b ** 2)
    dw = (np.sin(t) * (0.5 * math.pi / n_theta) * (2.0 * math.pi / n_phi)).ravel()
    expected = 0.8 / math.pi * np.sum(L * np.cos(t).ravel() * weight * dw)
    settings = RenderSettings(width=8, height=8, samples=64, integrator="path", max_bounces=1, light_samples=4,
                              kernels=kernels, seed=5)
    image = render(scene, settings).image[..., :3]
    assert 0.3 < expected < 0.36                    # (four samples' weights would give about 1.03)
    assert abs(image.mean() / expected - 1.0) < 0.02, (image.mean(), expected)
    assert render(sky_under_a_ceiling(True), settings).image[..., :3].max() < 1e-3


def test_mis_weighs_a_shadowless_or_bounce_limited_lights_samples_as_one_like_cycles():
    """vertex.mis_count: a light that casts no shadow or has a Max Bounces is weighed by MIS as one sample per hit
    (Cycles' count), whatever Light Samples; any other keeps its light_count (the weights sum to one either way)."""
    from types import SimpleNamespace
    from core.integrators.vertex import light_count, mis_count
    ctx = SimpleNamespace(settings=SimpleNamespace(light_samples=4), light_numbers=None)
    lamp = AreaLight(center=np.zeros(3), axis_u=np.array([1.0, 0.0, 0.0]), axis_v=np.array([0.0, 1.0, 0.0]),
                     direction=np.array([0.0, 0.0, -1.0]), power=10.0)
    assert light_count(ctx, lamp) == mis_count(ctx, lamp) == 4
    assert mis_count(ctx, dataclasses.replace(lamp, cast_shadow=False)) == 1
    assert mis_count(ctx, dataclasses.replace(lamp, max_bounces=0)) == 1
    assert light_count(ctx, dataclasses.replace(lamp, cast_shadow=False)) == 4
