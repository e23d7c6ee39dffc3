"""Homogeneous media (core/volumes, core/integrators/volume.py) held to closed forms: Beer-Lambert through slabs on
camera, shadow and bounce rays, volume-only boundaries that are not there, the volume stack (entering, leaving,
overlapping media, a camera inside one), media emission, single scattering of a slab under a sun, and the samplers
(Henyey-Greenstein, free flight, equi-angular) against their own densities."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.integrators import volume
from core.lights import SunLight, World
from core.materials import Material
from core.render import render
from core.scene import RenderSettings, Scene
from core.volumes import HenyeyGreenstein, Media, Stretch, emitted, transmittance
from core.volumes.phase import henyey_greenstein

COLOR = np.array([0.2, 0.5, 0.8])                        # an absorption's colour: sigma_a = density (1 - colour)


def camera_above(height: float = 3.0, scale: float = 2.0, clip_start: float = 0.1) -> Camera:
    """An orthographic camera `height` above the origin, looking straight down."""
    matrix = np.eye(4)
    matrix[2, 3] = height
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=scale, clip_start=clip_start, clip_end=20.0)


def fog(name: str = "Fog", closure: str = "ABSORPTION", surface=None, **inputs) -> Material:
    """A material with a Volume of one closure and either no Surface (a volume-only boundary) or `surface` nodes."""
    volume = [(closure, 1.0, inputs)]
    if surface is None:
        return Material(np.zeros(3), name, nodes=[("TRANSPARENT", np.ones(3), {})], volume=volume, volume_only=True)
    return Material(np.zeros(3), name, nodes=surface, volume=volume)


def glowing_floor(scene: Scene, emission=(1.0, 2.0, 0.5)) -> None:
    """An emitting plane (black, emission `emission`) at z = 0, the scene's material 0."""
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.asarray(emission, np.float64)))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))


def image(scene: Scene, **settings) -> np.ndarray:
    """The scene rendered at 4 x 4 (RGB (4, 4, 3)); settings override RenderSettings' defaults."""
    settings = {"width": 4, "height": 4, "samples": 2, "integrator": "path", **settings}
    return render(scene, RenderSettings(**settings)).image[..., :3]


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_light_through_an_absorbing_slab_keeps_exp_of_minus_sigma_a_times_its_depth(integrator):
    """An emitter seen through a volume-only slab 0.7 deep: each channel keeps exp(-density (1 - colour) 0.7)."""
    scene = Scene(camera=camera_above())
    glowing_floor(scene)
    scene.materials.append(fog(color=COLOR, density=1.5))
    scene.add_mesh(primitives.box((4.0, 4.0, 0.7), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-1.5 * (1.0 - COLOR) * 0.7)
    np.testing.assert_allclose(image(scene, integrator=integrator), np.broadcast_to(expected, (4, 4, 3)), rtol=3e-6)


def test_a_medium_inside_a_transparent_surface_is_entered_and_left_through_its_faces():
    """A Transparent surface of 0.9 around the same medium: exp(-sigma_a d) times 0.9 for each of its two faces."""
    scene = Scene(camera=camera_above())
    glowing_floor(scene)
    scene.materials.append(fog(surface=[("TRANSPARENT", np.full(3, 0.9), {})], color=COLOR, density=1.5))
    scene.add_mesh(primitives.box((4.0, 4.0, 0.7), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-1.5 * (1.0 - COLOR) * 0.7) * 0.81
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=3e-6)


def test_a_volume_only_boundary_counts_no_transparent_bounce_and_casts_no_shadow():
    """A volume-only box of density 0 is not there: with Transparent Max Bounces 0 the camera still sees the floor
    through it (Cycles counts volume boundaries apart), and a sun's shadow rays pass it: albedo / pi x E."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.full(3, 0.8), "Floor"))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(fog(color=COLOR, density=0.0))
    scene.add_mesh(primitives.box((4.0, 4.0, 0.7), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    scene.lights.append(SunLight(direction=np.array([0.0, 0.0, -1.0]), strength=3.0))
    np.testing.assert_allclose(image(scene, transparent_max_bounces=0), 0.8 / math.pi * 3.0, rtol=3e-6)


def test_shadow_rays_through_an_absorbing_slab_keep_exp_of_minus_sigma_a_times_their_path():
    """A floor under an absorbing slab, lit by a sun at 50 degrees and seen from straight above: the sun's light
    crosses the slab over d / sin(50), the camera's over d: albedo / pi x E sin(50) x exp(-sigma_a d (1 + 1 /
    sin 50)); path traced with bounces (nothing else to bounce from)."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.full(3, 0.8), "Floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.materials.append(fog(color=COLOR, density=1.5))
    scene.add_mesh(primitives.box((40.0, 40.0, 0.7), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    e = math.radians(50.0)
    scene.lights.append(SunLight(direction=-np.array([math.cos(e), 0.0, math.sin(e)]), strength=3.0))
    sigma = 1.5 * (1.0 - COLOR)
    expected = 0.8 / math.pi * 3.0 * math.sin(e) * np.exp(-sigma * 0.7 * (1.0 + 1.0 / math.sin(e)))
    # (within 5e-5: each crossing moves the ray off the slab's face by its robust offset, 8 float32 ulps of 20)
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=5e-5)


def test_overlapping_media_add_their_extinctions():
    """Two volume-only slabs overlapping over 0.2 of their depths: the camera crosses 0.5 of the first alone, 0.2 of
    both (sigma_1 + sigma_2, as Cycles' volume stack sums them) and 0.3 of the second alone."""
    scene = Scene(camera=camera_above())
    glowing_floor(scene, (1.0, 1.0, 1.0))
    scene.materials.append(fog("A", color=COLOR, density=1.0))
    scene.materials.append(fog("B", color=np.array([0.9, 0.3, 0.6]), density=2.0))
    scene.add_mesh(primitives.box((4.0, 4.0, 0.7), center=(0.0, 0.0, 1.65)), materials=np.array([1]))   # 1.3..2.0
    scene.add_mesh(primitives.box((4.0, 4.0, 0.5), center=(0.0, 0.0, 1.25)), materials=np.array([2]))   # 1.0..1.5
    a, b = 1.0 * (1.0 - COLOR), 2.0 * (1.0 - np.array([0.9, 0.3, 0.6]))
    expected = np.exp(-(a * 0.5 + (a + b) * 0.2 + b * 0.3))
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_a_camera_inside_a_medium_starts_in_it():
    """An orthographic camera inside an absorbing box, 1.0 above an emitter inside it: its rays (from its clip start
    on) cross 1.0 - clip start of the medium, and leave nothing behind them out of it."""
    scene = Scene(camera=camera_above(height=1.0, clip_start=0.01))
    glowing_floor(scene, (1.0, 1.0, 1.0))
    scene.materials.append(fog(color=COLOR, density=1.5))
    scene.add_mesh(primitives.box((6.0, 6.0, 3.0), center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    expected = np.exp(-1.5 * (1.0 - COLOR) * 0.99)
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=3e-6)


def test_an_emitting_medium_sends_its_emission_integrated_over_the_depth():
    """A slab of Volume Coefficients (absorption sigma_a, emission e, no scattering) over black: each channel is
    e (1 - exp(-sigma_a d)) / sigma_a."""
    scene = Scene(camera=camera_above())
    sigma, e = np.array([0.5, 1.0, 2.0]), np.array([0.3, 0.2, 0.1])
    scene.materials.append(fog(closure="COEFFICIENTS", absorption=sigma, scatter=np.zeros(3), emission=e))
    scene.add_mesh(primitives.box((4.0, 4.0, 0.8), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    expected = e * (1.0 - np.exp(-sigma * 0.8)) / sigma
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=3e-6)


def test_single_scattering_of_a_slab_under_a_sun_is_the_integral_along_the_view():
    """A scattering slab (sigma_s per channel, HG g 0.4, 0.6 deep) under a sun at 50 degrees, seen from straight
    above against black: L = sigma_s p(cos theta) E (1 - exp(-sigma d k)) / (sigma k), k = 1 + 1 / sin 50, cos theta =
    -sin 50 (the light turns from going down to going up); within 1% (free-flight noise at 256 samples)."""
    scene = Scene(camera=camera_above())
    sigma, g, d, E, e = np.array([0.5, 1.0, 2.0]), 0.4, 0.6, 3.0, math.radians(50.0)
    scene.materials.append(fog(closure="SCATTER", color=sigma, density=1.0, anisotropy=g))
    scene.add_mesh(primitives.box((40.0, 40.0, d), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.lights.append(SunLight(direction=-np.array([math.cos(e), 0.0, math.sin(e)]), strength=E))
    k = 1.0 + 1.0 / math.sin(e)
    p = henyey_greenstein(-math.sin(e), g)
    expected = sigma * p * E * (1.0 - np.exp(-sigma * d * k)) / (sigma * k)
    np.testing.assert_allclose(image(scene, samples=256).mean(axis=(0, 1)), expected, rtol=1e-2)


def test_a_world_medium_blocks_a_sun_whose_rays_never_leave_it():
    """A world absorbing everywhere: a sun's shadow rays cross infinitely much of it and bring nothing (as in
    Cycles); the world's own background, infinitely far, is hidden too."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.full(3, 0.8), "Floor"))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.lights.append(SunLight(direction=np.array([0.0, 0.0, -1.0]), strength=3.0))
    scene.world = World(color=np.ones(3), volume=[("ABSORPTION", 1.0, {"color": COLOR, "density": 0.01})])
    np.testing.assert_array_equal(image(scene), 0.0)


def test_henyey_greenstein_is_a_density_whose_mean_cosine_is_g_and_samples_itself():
    """p integrates to 1 over the sphere (midpoint rule in cos theta), its mean cosine is g, and `sample` draws
    directions whose pdf is p (the sample's weight p / pdf is 1) with mean cosine g."""
    for g in (-0.7, 0.0, 0.3, 0.9):
        mu = (np.arange(200000) + 0.5) / 200000 * 2.0 - 1.0
        p = henyey_greenstein(mu, g)
        assert abs(p.sum() * 2.0 / len(mu) * 2.0 * math.pi - 1.0) < 1e-4
        assert abs((mu * p).sum() * 2.0 / len(mu) * 2.0 * math.pi - g) < 1e-4
        rng = np.random.default_rng(5)
        wo = rng.normal(size=(100000, 3))
        wo /= np.linalg.norm(wo, axis=1, keepdims=True)
        phase = HenyeyGreenstein(g)
        s = phase.sample(wo, rng.random((100000, 2)))
        np.testing.assert_allclose(s.pdf, phase.eval(wo, s.wi), rtol=1e-9)
        assert abs(np.einsum("ij,ij->i", -wo, s.wi).mean() - g) < 0.01


def test_free_flight_sampling_is_unbiased_in_every_channel():
    """E[T(s) sigma_s / pdf(s)] over free-flight distances on [0, t) is the closed form sigma_s / sigma_t (1 -
    exp(-sigma_t t)) per channel, for a finite and an infinite stretch, whichever channel the throughput favours."""
    n = 400000
    rng = np.random.default_rng(3)
    sigma_t, sigma_s = np.array([0.5, 1.5, 3.0]), np.array([0.4, 0.3, 2.5])
    stretch = Stretch(np.tile(sigma_t, (n, 1)), np.tile(sigma_s, (n, 1)), np.zeros((n, 3)), np.zeros(n))
    for t in (0.8, np.inf):
        s, pdf, _ = volume.scatter_distance(stretch, np.tile([1.0, 0.2, 0.05], (n, 1)), np.full(n, t), rng.random((n, 2)))
        estimate = (transmittance(stretch.sigma_t, s) * sigma_s / pdf[:, None]).mean(axis=0)
        np.testing.assert_allclose(estimate, sigma_s / sigma_t * (1.0 - np.exp(-sigma_t * t)), rtol=1e-2)


def test_equiangular_sampling_draws_its_own_density_on_the_stretch():
    """Equi-angular distances towards a lamp stay on [0, t), and their pdf integrates to 1 there (trapezoids)."""
    O, D = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]])
    X = np.array([0.7, 0.3, 0.0])
    for t in (2.0, np.inf):
        s, pdf = volume.equiangular(np.repeat(O, 1000, axis=0), np.repeat(D, 1000, axis=0), np.full(1000, t), X,
                                    u=np.linspace(0.0, 0.999, 1000))
        assert (s >= 0.0).all() and (s <= t).all()
        grid = np.linspace(0.0, 2.0 if np.isfinite(t) else 2e4, 2000001)
        _, density = volume.equiangular(np.zeros((len(grid), 3)), np.tile(D, (len(grid), 1)), np.full(len(grid), t),
                                        X, s=grid)
        assert abs(np.trapz(density, grid) - 1.0) < 1e-3


def test_the_media_table_reads_each_closure_as_cycles_does():
    """Volume Absorption: sigma_a = density (1 - colour); Volume Scatter: sigma_s = density colour, g clamped to
    1 - 1e-3; Principled Volume: sigma_s = density colour, sigma_a = density max(1 - colour, 0) max(1 -
    sqrt(absorption colour), 0), emission = strength colour; a Mix weight scales each; overlapping closures add."""
    materials = [Material(volume=[("ABSORPTION", 0.5, {"color": COLOR, "density": 2.0}),
                                  ("SCATTER", 1.0, {"color": np.full(3, 0.5), "density": 1.0, "anisotropy": 1.0})]),
                 Material(volume=[("PRINCIPLED_VOLUME", 1.0, {"color": np.array([0.5, 0.2, 1.0]), "density": 2.0,
                                                              "absorption_color": np.array([0.25, 0.0, 1.0]),
                                                              "emission_strength": 3.0,
                                                              "emission_color": np.array([1.0, 0.5, 0.0])})]),
                 Material()]
    media = Media.of(materials)
    np.testing.assert_allclose(media.sigma_a[0], 1.0 - COLOR)
    np.testing.assert_allclose(media.sigma_s[0], 0.5)
    assert media.g[0] == pytest.approx(1.0 - 1e-3)
    np.testing.assert_allclose(media.sigma_s[1], [1.0, 0.4, 2.0])
    np.testing.assert_allclose(media.sigma_a[1], [2.0 * 0.5 * 0.5, 2.0 * 0.8 * 1.0, 0.0])
    np.testing.assert_allclose(media.emission[1], [3.0, 1.5, 0.0])
    np.testing.assert_array_equal(media.column, [0, 1, -1])
    assert Media.of([Material()]) is None
    np.testing.assert_allclose(emitted(media.along(np.array([[0, 1]], np.int16)), np.array([np.inf]))[0],
                               media.emission[1] / (media.sigma_a[1] + media.sigma_s[1]))


def test_a_principled_volumes_black_body_emits_stefan_boltzmanns_radiance_in_its_colour():
    """Blackbody Intensity 1 at 1500 K, tinted (1, 0.5, 0.25): emission = tint x 5.670373e-14 / pi x 1500^4 x the
    fit's colour of 1500 K, unclipped as Cycles uses it there; at intensity 0.5 the mix of 1 and T^4 halfway; at 0
    nothing."""
    from core.materials.converters.blackbody import blackbody
    tint, t = np.array([1.0, 0.5, 0.25]), 1500.0
    color = blackbody(np.array([t], np.float32), clip=False)[0].astype(np.float64)      # (its blue is below 0)
    for amount, factor in ((1.0, t ** 4), (0.5, 0.5 + 0.5 * t ** 4), (0.0, 0.0)):
        media = Media.of([Material(volume=[("PRINCIPLED_VOLUME", 1.0, {"density": 0.0, "blackbody_intensity": amount,
                                                                       "blackbody_tint": tint, "temperature": t})])])
        np.testing.assert_allclose(media.emission[0], tint * 5.670373e-14 / math.pi * factor * color, rtol=1e-12)
