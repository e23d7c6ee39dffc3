"""Light linking and shadow linking (core/lights/linking.py) in both kernels, held to closed forms.

A floor of albedo rho under point lamps of power P at distance r and angle theta has radiance
(rho / pi) P / (4 pi r^2) cos theta per lamp. A lamp whose receiver sets leave out the floor's set adds nothing to it
(Light Linking); a lamp whose blocker sets leave out an occluder's set lights the floor behind the occluder fully
(Shadow Linking); the sets are tested bit by bit as Cycles tests them.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from test_lamp_settings import SHADOWED_COLUMNS, occluded_floor
from test_lights import EXACT, ortho_camera_looking_down, pixel_centre_points, plane_scene, point_light_radiance

from core.lights.linking import ALL_SETS, in_sets
from core.materials import Material
from core.render import render
from core.scene import AreaLight, Mesh, PointLight, RenderSettings

KERNELS = ["numpy", "compiled"]
FLOOR = 0.5


def kernel_settings(kernels, samples=4):
    """16 x 16 pixels on `kernels`: jittered (the compiled kernel renders jittered samples only), a few samples."""
    return RenderSettings(width=16, height=16, samples=samples, seed=3, kernels=kernels)


def rendered(scene, settings):
    """The image (H, W, 3) of `scene`, checking that the kernel asked for rendered it."""
    result = render(scene, settings)
    assert result.stats.kernels.startswith(settings.kernels)
    return result.image[..., :3]


def floor_points(camera):
    """The floor points (16, 16, 3) the pixel centres see."""
    return pixel_centre_points(camera, 16, 16, lambda x, y: np.zeros_like(x))


def test_a_set_is_in_a_membership_where_its_bit_is_set():
    """Bit s of the 64-bit membership: set 0 and set 63 at the ends, every set in ALL_SETS."""
    membership = np.array([1, 1 << 63, ALL_SETS, 0b1010], np.uint64)
    assert in_sets(membership, np.array([0, 63, 17, 1])).tolist() == [True, True, True, True]
    assert in_sets(membership, np.array([1, 62, 0, 2])).tolist() == [False, False, True, False]


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_linked_to_another_object_adds_nothing_to_the_floor(kernels):
    """Two lamps over a floor in receiver set 1; one lights set 1 (and the default set), the other only set 2 (a
    plane elsewhere): the floor is the first lamp's closed form alone (at the pixel centres, and every jittered sample
    as the first lamp alone renders it), and with both linked to it the sum."""
    settings = kernel_settings(kernels)
    camera = ortho_camera_looking_down(5.0, 4.0)
    a, b = np.array([1.0, 0.5, 1.5]), np.array([-1.0, -0.5, 1.0])
    lamps = [PointLight(position=a, power=300.0, light_membership=0b11),
             PointLight(position=b, power=500.0, light_membership=0b100)]
    scene = plane_scene(camera, (FLOOR,) * 3, lamps)
    scene.instances[0].light_set = 1
    points = floor_points(camera)
    only_a = point_light_radiance((FLOOR,) * 3, (1.0,) * 3, 300.0, a, points)
    np.testing.assert_allclose(render(scene, dataclasses.replace(EXACT, kernels="numpy")).image[..., :3], only_a,
                               rtol=1e-5)
    image = rendered(scene, settings)
    np.testing.assert_allclose(image, only_a, rtol=0.03)
    alone = plane_scene(camera, (FLOOR,) * 3, lamps[:1])
    np.testing.assert_allclose(image, rendered(alone, settings), rtol=1e-6)
    scene.lights[1] = dataclasses.replace(lamps[1], light_membership=0b110)
    both = rendered(scene, settings)
    np.testing.assert_allclose(both, only_a + point_light_radiance((FLOOR,) * 3, (1.0,) * 3, 500.0, b, points),
                               rtol=0.03)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_blocker_outside_a_lamps_blocker_sets_casts_none_of_its_shadow(kernels):
    """The occluder in blocker set 1; a lamp whose shadows only set 2 casts lights the floor behind it with the full
    (rho / pi) P / (4 pi r^2) cos theta (at the pixel centres, and every jittered sample as the lamp with Cast Shadow
    off renders it); one whose shadows set 1 casts leaves it dark."""
    position, power = np.array([2.0, 0.0, 1.0]), 400.0
    settings = kernel_settings(kernels)
    camera, scene = occluded_floor(PointLight(position=position, power=power, shadow_membership=0b101))
    scene.instances[1].shadow_set = 1
    expected = point_light_radiance((FLOOR,) * 3, (1.0,) * 3, power, position, floor_points(camera))
    exact = render(scene, dataclasses.replace(EXACT, kernels="numpy")).image[..., :3]
    np.testing.assert_allclose(exact[:, SHADOWED_COLUMNS], expected[:, SHADOWED_COLUMNS], rtol=1e-5)
    assert expected[:, SHADOWED_COLUMNS].min() > 0.1
    image = rendered(scene, settings)
    _, unshadowed = occluded_floor(PointLight(position=position, power=power, cast_shadow=False))
    np.testing.assert_allclose(image[:, SHADOWED_COLUMNS], rendered(unshadowed, settings)[:, SHADOWED_COLUMNS],
                               rtol=1e-6)
    scene.lights[0] = dataclasses.replace(scene.lights[0], shadow_membership=0b10)
    shadowed = rendered(scene, settings)
    np.testing.assert_array_equal(shadowed[:, SHADOWED_COLUMNS], 0.0)


def emitting_square(scene, z, size, strength):
    """Add a square emitter of `size` at height z facing down, emitting `strength` (white): its instance index."""
    h = 0.5 * size
    material = scene.add_material((0.0, 0.0, 0.0))
    scene.materials[material].emission = np.full(3, float(strength))
    scene.add_mesh(Mesh(np.array([[-h, -h, z], [-h, h, z], [h, h, z], [h, -h, z]]), np.array([[0, 1, 2], [0, 2, 3]])),
                   materials=np.array([material]))
    return len(scene.instances) - 1


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_emitting_mesh_linked_to_another_object_lights_the_floor_with_neither_strategy(kernels):
    """An emitting square over the floor, by light samples and BSDF rays (MIS): linked to another set it adds nothing
    to the floor (0 exactly), while the camera still sees it; linked to the floor's set it lights it."""
    settings = RenderSettings(width=8, height=8, samples=16, seed=5, kernels=kernels)
    camera = ortho_camera_looking_down(5.0, 3.0)
    scene = plane_scene(camera, (FLOOR,) * 3, [])
    emitter = emitting_square(scene, 1.0, 1.0, 4.0)
    scene.instances[0].light_set = 1
    scene.instances[emitter].light_membership = 0b100
    image = rendered(scene, settings)
    np.testing.assert_array_equal(image[0], 0.0)              # (the floor beside the square)
    assert np.allclose(image[3:5, 3:5], 4.0)                  # (the camera sees the square itself)
    scene.instances[emitter].light_membership = 0b10
    lit = rendered(scene, settings)
    assert lit[0].min() > 0.01


def test_the_kernels_agree_on_a_scene_with_every_kind_of_link():
    """A floor in receiver set 1 and an occluder in blocker set 1 under a point lamp that lights set 1 and whose shadows
    only set 2 casts, an area lamp whose shadows set 1 casts, an emitting square that lights only set 2 and one that
    lights set 1 with shadows set 2 casts, seen from the floor through a half-transparent pane (in set 2, which no
    emitter but the first square lights: rays straight on through it find emitters as the floor receives): the
    compiled kernel renders every pixel as the Python reference does (the same samples, to float rounding)."""
    position = np.array([2.0, 0.0, 1.0])
    camera, scene = occluded_floor(PointLight(position=position, power=400.0, light_membership=0b10,
                                              shadow_membership=0b100))
    scene.lights.append(AreaLight(center=np.array([-1.0, 0.0, 2.0]), axis_u=np.array([1.0, 0.0, 0.0]),
                                  axis_v=np.array([0.0, 1.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=200.0,
                                  shape="SQUARE", shadow_membership=0b10))
    scene.instances[0].light_set = 1
    scene.instances[1].shadow_set = 1
    emitter = emitting_square(scene, 3.0, 0.5, 8.0)
    scene.instances[emitter].light_membership = 0b100
    shadowed = emitting_square(scene, 2.0, 0.5, 8.0)
    scene.instances[-1].matrix = np.array([[1.0, 0, 0, 1.0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])
    scene.instances[shadowed].light_membership, scene.instances[shadowed].shadow_membership = 0b10, 0b100
    scene.materials.append(Material(np.zeros(3), "Pane", nodes=[("TRANSPARENT", np.full(3, 0.5), {})]))
    scene.add_mesh(Mesh(np.array([[-1.5, -3.0, 1.6], [1.5, -3.0, 1.6], [1.5, 3.0, 1.6], [-1.5, 3.0, 1.6]]),
                        np.array([[0, 1, 2], [0, 2, 3]])), materials=np.array([len(scene.materials) - 1]))
    scene.instances[-1].light_set = 2
    settings = RenderSettings(width=16, height=16, samples=8, seed=7, integrator="path", max_bounces=2)
    python = rendered(scene, dataclasses.replace(settings, kernels="numpy"))
    compiled = rendered(scene, dataclasses.replace(settings, kernels="compiled"))
    np.testing.assert_allclose(compiled, python, rtol=1e-6, atol=4e-7)
    assert python[:, SHADOWED_COLUMNS].mean() > 0.05


def test_a_medium_receives_as_the_default_set():
    """A scattering slab under a sun (the Python reference's media): a sun that lights the default set 0 scatters
    sigma_s p E (1 - exp(-sigma d k)) / (sigma k) towards the camera (within 2%), one that lights only set 1 nothing."""
    import math
    from test_volumes import camera_above, fog
    from core.geometry import primitives
    from core.scene import Scene, SunLight
    from core.volumes.phase import henyey_greenstein
    scene = Scene(camera=camera_above())
    sigma, g, d, E, e = np.array([0.5, 1.0, 2.0]), 0.4, 0.6, 3.0, math.radians(50.0)
    scene.materials.append(fog(closure="SCATTER", color=sigma, density=1.0, anisotropy=g))
    scene.add_mesh(primitives.box((40.0, 40.0, d), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.lights.append(SunLight(direction=-np.array([math.cos(e), 0.0, math.sin(e)]), strength=E,
                                 light_membership=0b11))
    settings = RenderSettings(width=4, height=4, samples=128, integrator="path")
    k = 1.0 + 1.0 / math.sin(e)
    expected = sigma * henyey_greenstein(-math.sin(e), g) * E * (1.0 - np.exp(-sigma * d * k)) / (sigma * k)
    np.testing.assert_allclose(render(scene, settings).image[..., :3].mean(axis=(0, 1)), expected, rtol=2e-2)
    scene.lights[0] = dataclasses.replace(scene.lights[0], light_membership=0b10)
    np.testing.assert_array_equal(render(scene, settings).image[..., :3], 0.0)


def pane_scene(pane_set):
    """A floor (set 1) under an emitting square that lights only set 2, seen through a half-transparent pane in set
    `pane_set` between them (and between the floor and the camera), path traced."""
    camera = ortho_camera_looking_down(5.0, 4.0)
    scene = plane_scene(camera, (FLOOR,) * 3, [])
    scene.instances[0].light_set = 1
    emitter = emitting_square(scene, 3.0, 1.0, 8.0)
    scene.instances[emitter].light_membership = 0b100
    scene.materials.append(Material(np.zeros(3), "Pane", nodes=[("TRANSPARENT", np.full(3, 0.5), {})]))
    scene.add_mesh(Mesh(np.array([[-1.5, -3.0, 1.6], [1.5, -3.0, 1.6], [1.5, 3.0, 1.6], [-1.5, 3.0, 1.6]]),
                        np.array([[0, 1, 2], [0, 2, 3]])), materials=np.array([len(scene.materials) - 1]))
    scene.instances[-1].light_set = pane_set
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_rays_on_through_a_transparent_pane_find_emitters_as_the_last_real_bounce_receives(kernels):
    """The floor's bounce rays that go on through the pane find the square as the floor receives (Cycles'
    mis_ray_object), whatever the pane's own set: the floor around the square's image is black with the pane in the
    square's set 2 too (the camera sees the square itself through the pane)."""
    settings = RenderSettings(width=16, height=16, samples=8, seed=7, integrator="path", max_bounces=2,
                              kernels=kernels)
    image = rendered(pane_scene(2), settings)
    np.testing.assert_array_equal(image[:, :3], 0.0)
    assert image[6:10, 6:10].min() > 1.0
