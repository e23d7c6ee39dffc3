"""Whitted's tracer through participating media (core/integrators/whitted.py) held to closed forms: Beer-Lambert on
its camera and shadow rays, a medium's emission, single scattering against the direct tracer on the same scene, a
mirror seen through fog, and the warning for what it leaves out (Volume Bounces)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import SunLight, World
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.render import render
from core.scene import RenderSettings, Scene
from core.volumes.phase import henyey_greenstein

COLOR = np.array([0.2, 0.5, 0.8])                        # an absorption's colour: sigma_a = density (1 - colour)


def camera_above(height: float = 3.0, scale: float = 2.0) -> Camera:
    """An orthographic camera `height` above the origin, looking straight down."""
    matrix = np.eye(4)
    matrix[2, 3] = height
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=scale, clip_start=0.1, clip_end=20.0)


def fog(name: str = "Fog", closure: str = "ABSORPTION", **inputs) -> Material:
    """A volume-only material (a Volume of one closure, no Surface)."""
    return Material(np.zeros(3), name, nodes=[("TRANSPARENT", np.ones(3), {})], volume=[(closure, 1.0, inputs)],
                    volume_only=True)


def rendered(scene: Scene, **settings):
    """The scene's render at 4 x 4 by Whitted's tracer unless said otherwise (settings override RenderSettings)."""
    return render(scene, RenderSettings(**{"width": 4, "height": 4, "samples": 2, "integrator": "whitted",
                                           **settings}))


def lit_floor(scene: Scene, elevation: float, strength: float = 3.0) -> None:
    """A diffuse floor (albedo 0.8) at z = 0 under a sun `elevation` degrees above the horizon."""
    scene.materials.append(Material(np.full(3, 0.8), "Floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([len(scene.materials) - 1]))
    e = math.radians(elevation)
    scene.lights.append(SunLight(direction=-np.array([math.cos(e), 0.0, math.sin(e)]), strength=strength))


@pytest.mark.parametrize("shadowed", [False, True])
def test_whitted_sees_a_lit_floor_through_an_absorbing_slab_as_exp_of_minus_sigma_a_times_each_rays_path(shadowed):
    """A floor lit by a sun at 30 degrees, seen from above through an absorbing slab 0.4 deep (1.8 to 2.2 up): a slab
    just wider than the view keeps exp(-sigma_a d) of the camera ray's light and lets the sun's pass beside it; a wide
    one keeps exp(-sigma_a d / sin 30) of the shadow ray's as well: albedo / pi x E sin 30 x exp(-sigma_a d (1 [+ 1 /
    sin 30]))."""
    scene = Scene(camera=camera_above())
    lit_floor(scene, 30.0)
    scene.materials.append(fog(color=COLOR, density=1.5))
    width = 40.0 if shadowed else 2.2              # (the narrow one: the sun's rays pass it 3.1 to 3.8 aside)
    scene.add_mesh(primitives.box((width, width, 0.4), center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    e = math.radians(30.0)
    sigma = 1.5 * (1.0 - COLOR)
    expected = 0.8 / math.pi * 3.0 * math.sin(e) * np.exp(-sigma * 0.4 * (1.0 + (1.0 / math.sin(e) if shadowed
                                                                                else 0.0)))
    # (within 5e-5: each crossing moves the ray off the slab's face by its robust offset)
    np.testing.assert_allclose(rendered(scene).image[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=5e-5)


def test_whitted_adds_a_purely_emitting_fogs_emission_times_its_depth():
    """A slab 0.8 deep that emits e and neither absorbs nor scatters, over black: the camera sees e d."""
    scene = Scene(camera=camera_above())
    e = np.array([0.3, 0.2, 0.1])
    scene.materials.append(fog(closure="COEFFICIENTS", absorption=np.zeros(3), scatter=np.zeros(3), emission=e))
    scene.add_mesh(primitives.box((4.0, 4.0, 0.8), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    np.testing.assert_allclose(rendered(scene).image[..., :3], np.broadcast_to(e * 0.8, (4, 4, 3)), rtol=3e-6)


def scattering_scene() -> Scene:
    """A lit floor (sun at 50 degrees) under an isotropically scattering slab 0.6 deep (sigma_s per channel)."""
    scene = Scene(camera=camera_above())
    lit_floor(scene, 50.0)
    scene.materials.append(fog(closure="SCATTER", color=np.array([0.5, 1.0, 2.0]), density=1.0, anisotropy=0.0))
    scene.add_mesh(primitives.box((40.0, 40.0, 0.6), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    return scene


def test_whitted_single_scattering_under_a_sun_agrees_with_the_direct_tracer_and_the_closed_form():
    """The scattering slab over the lit floor: Whitted's tracer (at a diffuse floor, direct light) renders what the
    direct tracer does at Max Bounces 0, and both are the closed form: the floor's light through the slab both ways,
    plus sigma_s p E (1 - exp(-sigma d k)) / (sigma k), k = 1 + 1 / sin 50, p = 1 / 4 pi; within 0.3% (measured 0.04%)."""
    whitted = rendered(scattering_scene(), samples=128).image[..., :3].mean(axis=(0, 1))
    direct = rendered(scattering_scene(), samples=128, integrator="direct", max_bounces=0).image[..., :3].mean(axis=(0, 1))
    sigma, d, E, e = np.array([0.5, 1.0, 2.0]), 0.6, 3.0, math.radians(50.0)
    k = 1.0 + 1.0 / math.sin(e)
    floor = 0.8 / math.pi * E * math.sin(e) * np.exp(-sigma * d * k)
    slab = sigma * henyey_greenstein(-math.sin(e), 0.0) * E * (1.0 - np.exp(-sigma * d * k)) / (sigma * k)
    np.testing.assert_allclose(whitted, direct, rtol=3e-3)
    np.testing.assert_allclose(whitted, floor + slab, rtol=3e-3)


def test_whitted_sees_a_glowing_wall_in_a_mirror_through_fog_over_both_rays_ways():
    """A mirror tinted (0.9, 0.5, 0.2) at 45 degrees facing a glowing wall 3 up, all in an absorbing world: the camera
    ray's 3 less the clip start 0.1 to the mirror and the mirror ray's 3 to the wall (their sum the same for every
    pixel) keep 2 tint exp(-5.9 sigma_a)."""
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.5, clip_start=0.1, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, -3], [0, 1, 0, 0], [0, 0, 0, 1.0]])))
    scene.materials.append(Material((0.9, 0.5, 0.2), name="mirror", bsdf="MIRROR"))
    scene.materials.append(Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (2.0,) * 3})]))
    c = s_ = math.sqrt(0.5)
    scene.add_mesh(primitives.plane(4.0), np.array([[1, 0, 0, 0], [0, c, -s_, 0], [0, s_, c, 0], [0, 0, 0, 1.0]]),
                   materials=np.array([0]))
    scene.add_mesh(primitives.plane(8.0), np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3.0], [0, 0, 0, 1.0]]),
                   materials=np.array([1]))
    scene.world = World(color=np.zeros(3), volume=[("ABSORPTION", 1.0, {"color": COLOR, "density": 0.1})])
    image = rendered(scene, samples=1, max_bounces=2).image[..., :3]
    expected = 2.0 * np.array([0.9, 0.5, 0.2]) * np.exp(-0.1 * (1.0 - COLOR) * 5.9)
    np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), rtol=1e-5)


def test_whitted_warns_that_it_scatters_once_whatever_the_volume_bounces():
    """Volume Bounces 2 in a scattering medium: Whitted's tracer says it renders them as 0, and no longer that it
    leaves media out."""
    warnings = rendered(scattering_scene(), volume_bounces=2).stats.warnings
    assert any("Whitted's tracer scatters light in media once" in w and "Volume Bounces 2" in w for w in warnings)
    assert not any("renders no media" in w for w in warnings)


def test_whitted_refracts_into_a_glass_of_absorbing_medium_and_keeps_exp_of_each_crossing():
    """A glass slab (IOR 1.5, 0.2 deep) filled with an absorbing medium, in front of a glowing wall at normal
    incidence: each way across the glass keeps exp(-sigma_a 0.2), so through 2 refractions and 2k internal
    reflections L (1 - R)^2 R^(2k) exp(-(2k + 1) sigma_a 0.2), summed over what the depth 5 allows; no noise."""
    ior, depth = 1.5, 5
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.5, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, -3], [0, 1, 0, 0], [0, 0, 0, 1.0]])))
    scene.materials.append(Material(name="glass", nodes=[("GLASS", (1, 1, 1), {"ior": ior})],
                                    volume=[("ABSORPTION", 1.0, {"color": COLOR, "density": 2.0})]))
    scene.materials.append(Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (2.0,) * 3})]))
    scene.add_mesh(primitives.box((4.0, 0.2, 4.0)), materials=np.array([0]))
    scene.add_mesh(primitives.plane(8.0), np.array([[1, 0, 0, 0], [0, 0, -1, 2.0], [0, 1, 0, 0], [0, 0, 0, 1.0]]),
                   materials=np.array([1]))
    image = rendered(scene, samples=1, max_bounces=depth, glossy_bounces=depth, transmission_bounces=depth)
    R, sigma = ((ior - 1) / (ior + 1)) ** 2, 2.0 * (1.0 - COLOR)
    expected = 2.0 * (1 - R) ** 2 * sum(R ** (2 * k) * np.exp(-(2 * k + 1) * sigma * 0.2)
                                        for k in range((depth - 2) // 2 + 1))
    np.testing.assert_allclose(image.image[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_whitted_marches_a_slab_whose_density_grows_linearly_to_exp_of_minus_its_integral():
    """A heterogeneous slab (density 2 z + 0.5 from z = 0.5 to 1.5, its integral 2.5) over a glowing floor: each
    channel keeps exp(-2.5 (1 - colour)) of the floor's light (the march of the direct and path tracers)."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.array([1.0, 2.0, 0.5])))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    z = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("TEXCOORD"), "Object")}), "Z")
    density = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": z, "1": 2.0, "2": 0.5}), "Value")
    scene.materials.append(fog(color=COLOR, density=density))
    scene.add_mesh(primitives.box((4.0, 4.0, 1.0), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-2.5 * (1.0 - COLOR))
    np.testing.assert_allclose(rendered(scene).image[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_whitteds_denoising_albedo_and_normal_see_a_scattering_slab_as_the_path_tracers_camera_rays_do():
    """The scattering slab (sigma_s = sigma_t = (0.5, 1, 2), 0.6 deep) over the diffuse floor (0.8): Whitted's
    features are the path tracer's for its camera rays (features.in_media then the floor's vertex): the slab's albedo
    sigma_s / sigma_t (1 - T), T = exp(-sigma_t 0.6), plus the floor's 0.8 times the odds of passing it, Cycles'
    channel-weighed T (here the mean of T: each channel's share albedo + T is 1), and the normal up (the camera looks
    straight down: its back direction and the floor's normal agree). Whitted's albedo used to hold the light the
    slab scatters to the camera and the floor's 0.8 whole."""
    sigma = np.array([0.5, 1.0, 2.0])
    T = np.exp(-sigma * 0.6)
    whitted = rendered(scattering_scene(), denoising_features=True).aux
    direct = rendered(scattering_scene(), denoising_features=True, integrator="direct", max_bounces=0).aux
    expected = (1.0 - T) + 0.8 * T.mean()
    # (within 1e-5: the rays step off the slab's faces by their robust offset, shortening its depth a little)
    np.testing.assert_allclose(whitted["denoising_albedo"], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)
    np.testing.assert_allclose(whitted["denoising_normal"], np.broadcast_to([0.0, 0.0, 1.0], (4, 4, 3)), atol=1e-6)
    for name in ("denoising_albedo", "denoising_normal"):
        np.testing.assert_allclose(whitted[name], direct[name], rtol=1e-6, atol=1e-7, err_msg=name)


def test_whitteds_emission_and_environment_passes_see_through_media_as_the_path_tracers():
    """A glowing floor (GLOW) half covered by a slab 0.8 deep (x < 0) that absorbs sigma and emits e, under a world
    seen beside the floor: the Emission pass is e (1 - exp(-sigma d)) / sigma + GLOW exp(-sigma d) through the slab,
    GLOW beside it, and both passes are the path tracer's (Whitted's used to leave the media out: GLOW everywhere and
    no emission of the slab)."""
    glow, sigma, e = np.array([1.0, 2.0, 0.5]), np.array([0.5, 1.0, 2.0]), np.array([0.3, 0.2, 0.1])
    scene = Scene(camera=camera_above(scale=4.0))
    scene.world = World(color=np.array([0.3, 0.4, 0.5]))
    scene.materials.append(Material(np.zeros(3), "Glow", emission=glow))
    scene.add_mesh(primitives.plane(3.0), materials=np.array([0]))                  # (x, y in -1.5 .. 1.5)
    scene.materials.append(fog(closure="COEFFICIENTS", absorption=sigma, scatter=np.zeros(3), emission=e))
    scene.add_mesh(primitives.box((2.0, 4.0, 0.8), center=(-1.0, 0.0, 1.0)), materials=np.array([1]))
    settings = dict(width=8, height=8, passes=("emission", "environment"))
    whitted, path = rendered(scene, **settings).aux, rendered(scene, integrator="path", **settings).aux
    through = e * (1.0 - np.exp(-sigma * 0.8)) / sigma + glow * np.exp(-sigma * 0.8)
    np.testing.assert_allclose(whitted["emission"][2:6, 2:4], np.broadcast_to(through, (4, 2, 3)), rtol=1e-5)
    np.testing.assert_allclose(whitted["emission"][2:6, 4:6], np.broadcast_to(glow, (4, 2, 3)), rtol=1e-6)
    assert whitted["environment"][0, 0].max() > 0.1                 # (the world beside the floor)
    for name in ("emission", "environment"):
        np.testing.assert_allclose(whitted[name], path[name], rtol=1e-6, atol=1e-7, err_msg=name)
