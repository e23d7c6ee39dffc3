"""Volume Bounces (core/integrators/volume.py multiple_scattering, its compiled twin volume.c volume_chain): paths go
on from where they scatter in media, held to closed forms in both kernels: an infinite emitting medium of albedo a
sends e / sigma_t (1 + a + ... + a^(N + 1)) with N Volume Bounces (each scattering event multiplies by a; the last
one's phase ray still finds the emission), grey exactly and per channel within the noise; a medium that absorbs
nothing, under a white world, stays white with enough bounces (energy is kept), homogeneous or heterogeneous."""
from __future__ import annotations

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import World
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.render import render
from core.scene import RenderSettings, Scene


def camera() -> Camera:
    """An orthographic camera 3 above the origin looking down, 1 wide."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=1.0, clip_start=0.1, clip_end=60.0)


def rendered(scene: Scene, bounces: int, samples: int = 16, kernels: str = "compiled") -> np.ndarray:
    """The mean colour (3,) of the scene path traced at 4 x 4 with Volume Bounces `bounces` by `kernels` ("compiled":
    the compiled kernel, checked; "numpy": the Python reference)."""
    settings = RenderSettings(width=4, height=4, samples=samples, integrator="path", volume_bounces=bounces,
                              max_bounces=256, **({"kernels": "numpy"} if kernels == "numpy" else {}))
    result = render(scene, settings)
    assert kernels == "numpy" or result.stats.kernels == "compiled"
    return result.image[..., :3].reshape(-1, 3).mean(axis=0)


def infinite_fog(color) -> Scene:
    """The camera in a world medium everywhere (glowing_fog of `color`), and a speck 1000 away that nothing reaches
    through it (exp(-1000)): the compiled kernel wants some geometry for Embree."""
    scene = Scene(camera=camera())
    scene.world = glowing_fog(color)
    scene.add_mesh(primitives.box((0.01, 0.01, 0.01), center=(0.0, 0.0, 1000.0)))
    return scene


def glowing_fog(color) -> World:
    """A world medium everywhere: scattering 0.8 colour, absorbing 0.2, emitting 1 per unit length."""
    return World(color=np.zeros(3), volume=[("SCATTER", 1.0, {"color": np.asarray(color, np.float64), "density": 0.8,
                                                              "anisotropy": 0.5}),
                                            ("ABSORPTION", 1.0, {"color": np.zeros(3), "density": 0.2}),
                                            ("EMISSION", 1.0, {"color": np.ones(3), "strength": 1.0})])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("bounces", [0, 1, 3])
def test_an_infinite_grey_emitting_medium_sends_the_sum_of_its_albedos_powers(bounces, kernels):
    """sigma_t 1, albedo 0.8, emission 1: 1 + 0.8 + ... + 0.8^(N + 1), to float32 rounding (a grey medium's
    collisions weigh exactly its albedo: no noise)."""
    scene = infinite_fog(np.ones(3))
    expected = sum(0.8 ** k for k in range(bounces + 2))
    np.testing.assert_allclose(rendered(scene, bounces, kernels=kernels), np.full(3, expected), rtol=1e-5)


def test_an_infinite_coloured_medium_sends_each_channels_sum_of_albedo_powers():
    """Scattering colour (0.9, 0.6, 0.3): sigma_t = 0.2 + 0.8 colour and albedo a = 0.8 colour / sigma_t per channel,
    e / sigma_t (1 + a + a^2 + a^3) with Volume Bounces 2, within 1% at 1024 samples (the channels share one free
    flight, spectral MIS)."""
    color = np.array([0.9, 0.6, 0.3])
    scene = infinite_fog(color)
    sigma_t = 0.2 + 0.8 * color
    albedo = 0.8 * color / sigma_t
    expected = sum(albedo ** k for k in range(4)) / sigma_t
    np.testing.assert_allclose(rendered(scene, 2, samples=1024), expected, rtol=1e-2)


def noise_density() -> Link:
    """A graph: 3 x Noise Texture (its object coordinates, scale 2), a density between about 0.5 and 2.5."""
    coords = GraphNode("TEXCOORD")
    noise = Link(GraphNode("TEX_NOISE", {}, {"Vector": Link(coords, "Object"), "Scale": 2.0}), "Fac")
    return Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": noise, "1": 3.0}), "Value")


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("density", [1.0, "noise"])
def test_a_medium_that_absorbs_nothing_stays_white_under_a_white_world_with_enough_bounces(density, kernels):
    """A white Volume Scatter cube (homogeneous, or of a Noise-driven density) under a white world: with Volume
    Bounces 64 every path leaves it carrying all its light (exactly 1), with none the light scattered more than
    twice is missing (the paths that scatter reach the cube's faces and go on from there). The Noise-driven cube
    within the noise of its estimates (white in the mean: ratio tracking's T and the true density at the points
    against the march's pdf no longer cancel exactly, as the march's own weights did)."""
    scene = Scene(camera=camera())
    scene.world = World(color=np.ones(3))
    scene.world_color = np.ones(3)
    medium = {"color": np.ones(3), "density": noise_density() if density == "noise" else density}
    scene.materials.append(Material(np.zeros(3), "Fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                    volume=[("SCATTER", 1.0, medium)], volume_only=True))
    scene.add_mesh(primitives.box((2.0, 2.0, 2.0)), materials=np.array([0]))
    if density == 1.0:
        np.testing.assert_allclose(rendered(scene, 64, kernels=kernels), np.ones(3), rtol=1e-5)
    else:                           # (32 samples: the mean's standard error about 1.5 %, and 4 of them allowed)
        np.testing.assert_allclose(rendered(scene, 64, samples=32, kernels=kernels), np.ones(3), rtol=0.06)
    assert (rendered(scene, 0, kernels=kernels) < 0.9).all()


@pytest.mark.parametrize("max_bounces", [0, 1, 2])
def test_each_scattering_event_is_a_bounce_that_max_bounces_caps(max_bounces):
    """Volume Bounces 3 under Max Bounces 0, 1, 2: a scattering event counts a bounce (Cycles' path_state_next), so
    the infinite medium sends 1 + a + ... + a^(min(3, Max Bounces) + 1)."""
    scene = infinite_fog(np.ones(3))
    settings = RenderSettings(width=4, height=4, samples=16, integrator="path", volume_bounces=3,
                              max_bounces=max_bounces)
    expected = sum(0.8 ** k for k in range(min(3, max_bounces) + 2))
    result = render(scene, settings)
    assert result.stats.kernels == "compiled"
    np.testing.assert_allclose(result.image[..., :3], expected, rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_white_fog_inside_a_glowing_shell_sends_the_shells_radiance_once(kernels):
    """A world fog that absorbs nothing (density 0.5, mean free path 2) filling a closed box 8 wide whose faces emit
    radiance 1 and reflect nothing, the camera inside: in equilibrium the radiance is 1 everywhere and in every
    direction, and Volume Bounces 64 leave out only paths of more scattering events than they ever make here. The
    paths that scatter along camera rays and reach a face had its emission found by their phase ray's MIS (the face
    adds none of its own there: counted twice, about 2); within 3 % at 256 samples (the mean's standard error about
    1 %). With no Volume Bounces the light scattered more than once is missing."""
    scene = Scene(camera=camera())
    scene.world = World(color=np.zeros(3), volume=[("SCATTER", 1.0, {"color": np.ones(3), "density": 0.5,
                                                                      "anisotropy": 0.0})])
    scene.materials.append(Material(name="Glow", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": (1.0, 1.0, 1.0)})]))
    scene.add_mesh(primitives.box((8.0, 8.0, 8.0)), materials=np.array([0]))
    np.testing.assert_allclose(rendered(scene, 64, samples=256, kernels=kernels), np.ones(3), rtol=0.03)
    assert (rendered(scene, 0, samples=256, kernels=kernels) < 0.9).all()
