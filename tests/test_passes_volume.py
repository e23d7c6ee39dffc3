"""Volume Direct and Volume Indirect (core/integrators/lightpasses.py stretch_shares, lightpasses.c), and a medium seen
by the camera in Emission and Environment (passes.py along_ray), without Blender:
Cycles' rule (kernel/film/light_passes.h, PATH_RAY_VOLUME_PASS) that a path whose first real interaction is a
scattering event in a medium writes the light gathered there to Volume Direct and all it gathers after to Volume
Indirect, on a slab whose single scattering has a closed form; the surface passes keep a surface's light seen through
a medium; the eight light passes (the surface ones times their colours) + Emission + Environment make Combined per
pixel with media that scatter and emit, with and without Volume Bounces, on both kernels; and the compiled passes
follow the reference's."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core.geometry import primitives
from core.integrators.lightpasses import COLOR_OF, LIGHT_PASSES
from core.lights import SunLight, World
from core.materials import Material
from core.render import render
from core.scene import RenderSettings
from core.scene import Scene
from core.volumes.phase import henyey_greenstein
from test_passes_light import sum_scene
from test_volumes import camera_above, fog

KERNELS = ["numpy", "compiled"]
SUM_PASSES = LIGHT_PASSES + ("diffuse_color", "glossy_color", "transmission_color", "emission", "environment")


def slab_under_a_sun(surface=None) -> tuple:
    """A scattering slab (sigma_s per channel, HG g 0.4, 0.6 deep) under a sun at 50 degrees, over black or over a
    floor of the material `surface` (nodes), seen from straight above; and the slab's single scattering towards
    the camera in closed form: sigma_s p(cos theta) E (1 - exp(-sigma d k)) / (sigma k), k = 1 + 1 / sin 50."""
    scene = Scene(camera=camera_above())
    sigma, g, d, E, e = np.array([0.5, 1.0, 2.0]), 0.4, 0.6, 3.0, math.radians(50.0)
    scene.materials.append(fog(closure="SCATTER", color=sigma, density=1.0, anisotropy=g))
    scene.add_mesh(primitives.box((40.0, 40.0, d), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    if surface is not None:
        scene.materials.append(Material(np.zeros(3), "Floor", nodes=surface))
        scene.add_mesh(primitives.plane(40.0), materials=np.array([1]))
    scene.lights.append(SunLight(direction=-np.array([math.cos(e), 0.0, math.sin(e)]), strength=E))
    k = 1.0 + 1.0 / math.sin(e)
    return scene, sigma * henyey_greenstein(-math.sin(e), g) * E * (1.0 - np.exp(-sigma * d * k)) / (sigma * k)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_single_scattering_of_a_slab_under_a_sun_is_all_volume_direct(integrator, kernels):
    """Max Bounces 0 (or the direct tracer) over black: Volume Direct is Combined, the closed form within 1%
    (free-flight noise), and every other light pass is 0."""
    scene, expected = slab_under_a_sun()
    settings = RenderSettings(width=4, height=4, samples=256, integrator=integrator, max_bounces=0,
                              passes=LIGHT_PASSES, kernels=kernels)
    result = render(scene, settings)
    assert result.stats.kernels.startswith(kernels)
    combined = result.image[..., :3].astype(np.float64)
    np.testing.assert_allclose(result.aux["volume_direct"], combined, rtol=1e-6)
    np.testing.assert_allclose(combined.mean(axis=(0, 1)), expected, rtol=1e-2)
    for name in LIGHT_PASSES:
        if name != "volume_direct":
            assert np.all(result.aux[name] == 0.0), name


@pytest.mark.parametrize("kernels", KERNELS)
def test_with_volume_bounces_the_first_scattering_is_volume_direct_and_the_rest_volume_indirect(kernels):
    """Volume Bounces 2 over black: Volume Direct is still the slab's single scattering (the light gathered at each
    path's first scattering event), the scattering after it is Volume Indirect (> 0), and the two make Combined."""
    scene, expected = slab_under_a_sun()
    settings = RenderSettings(width=4, height=4, samples=256, integrator="path", max_bounces=4, volume_bounces=2,
                              passes=LIGHT_PASSES, kernels=kernels)
    result = render(scene, settings)
    combined = result.image[..., :3].astype(np.float64)
    direct, indirect = result.aux["volume_direct"], result.aux["volume_indirect"]
    np.testing.assert_allclose(direct.mean(axis=(0, 1)), expected, rtol=2e-2)
    assert np.all(indirect.mean(axis=(0, 1)) > 0.1 * expected)
    np.testing.assert_allclose(direct + indirect, combined, rtol=1e-5, atol=1e-7)
    for name in LIGHT_PASSES:
        if not name.startswith("volume"):
            assert np.all(result.aux[name] == 0.0), name


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_floor_seen_through_an_absorbing_slab_keeps_its_light_in_diffuse_direct(kernels):
    """A white Lambert floor under an absorbing slab (no scattering), lit by a sun through it: all its light is
    Diffuse Direct (x Diffuse Color = Combined), the volume passes 0: a medium the path only crosses is no bounce."""
    scene, _ = slab_under_a_sun(surface=[("DIFFUSE", (0.8, 0.8, 0.8), {})])
    scene.materials[0] = fog(closure="ABSORPTION", color=np.array([0.2, 0.5, 0.8]), density=1.5)
    settings = RenderSettings(width=4, height=4, samples=4, integrator="path", max_bounces=0,
                              passes=LIGHT_PASSES + ("diffuse_color",), kernels=kernels)
    result = render(scene, settings)
    combined = result.image[..., :3].astype(np.float64)
    assert combined.min() > 0.0
    np.testing.assert_allclose(result.aux["diffuse_direct"] * result.aux["diffuse_color"], combined, rtol=1e-5)
    for name in LIGHT_PASSES:
        if name != "diffuse_direct":
            assert np.all(result.aux[name] == 0.0), name


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_floor_behind_a_scattering_slab_keeps_its_light_in_the_surface_passes(kernels):
    """A Lambert floor under the scattering slab, Max Bounces 0: Combined = DiffDir x DiffCol + Volume Direct, the
    slab's own light all Volume Direct (the closed form over black, within 1%), the floor's all Diffuse Direct."""
    scene, expected = slab_under_a_sun(surface=[("DIFFUSE", (0.8, 0.6, 0.4), {})])
    settings = RenderSettings(width=4, height=4, samples=256, integrator="path", max_bounces=0,
                              passes=LIGHT_PASSES + ("diffuse_color",), kernels=kernels)
    result = render(scene, settings)
    combined = result.image[..., :3].astype(np.float64)
    surface = result.aux["diffuse_direct"] * result.aux["diffuse_color"]
    np.testing.assert_allclose(surface + result.aux["volume_direct"], combined, rtol=1e-5)
    np.testing.assert_allclose(result.aux["volume_direct"].mean(axis=(0, 1)), expected, rtol=1e-2)
    assert surface.min() > 0.0
    for name in ("glossy_direct", "transmission_direct", *LIGHT_PASSES[4:]):
        assert np.all(result.aux[name] == 0.0), name


def fog_scene(closure: str) -> Scene:
    """sum_scene (test_passes_light.py) with a volume-only box over its left front: a medium that scatters, or one
    that absorbs, scatters and emits (Volume Coefficients). (The emissive panel stays outside it: an emitter in a
    medium seen through a transparent surface with Volume Bounces is in the Emission pass only in expectation,
    docs/passes.md.)"""
    scene = sum_scene()
    if closure == "SCATTER":
        medium = fog(closure="SCATTER", color=np.array([0.6, 0.8, 1.0]), density=0.4, anisotropy=0.3)
    else:
        medium = fog(closure="COEFFICIENTS", absorption=np.array([0.2, 0.3, 0.4]),
                     scatter=np.array([0.3, 0.5, 0.7]), emission=np.array([0.3, 0.2, 0.1]))
    scene.materials.append(medium)
    scene.add_mesh(primitives.box((3.0, 4.0, 3.0), center=(-0.8, -1.0, 1.2)),
                   materials=np.array([len(scene.materials) - 1]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("closure, volume_bounces", [("SCATTER", 0), ("COEFFICIENTS", 2)])
def test_eight_light_passes_plus_emission_and_environment_make_combined_in_media(closure, volume_bounces, kernels):
    """The sum rule, per pixel, with a medium over surfaces of every kind (the surface passes times their colours,
    the volume passes as they are): the passes are shares of the very samples Combined adds up."""
    settings = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=4,
                              volume_bounces=volume_bounces, passes=SUM_PASSES, kernels=kernels)
    result = render(fog_scene(closure), settings)
    assert result.stats.kernels.startswith(kernels)
    p = {name: result.aux[name].astype(np.float64) for name in SUM_PASSES}
    total = p["emission"] + p["environment"]
    for name in LIGHT_PASSES:
        total += p[name] * (p[COLOR_OF[name]] if name in COLOR_OF else 1.0)
    np.testing.assert_allclose(total, result.image[..., :3].astype(np.float64), rtol=1e-4, atol=1e-5)
    assert p["volume_direct"].max() > 0.0
    assert (p["volume_indirect"].max() > 0.0) == (volume_bounces > 0)


def test_the_compiled_volume_passes_follow_the_reference():
    """The C kernels split the same samples of a scattering, emitting medium with Volume Bounces the same way as
    the Python reference (the images' tolerance of tests/test_compiled.py, relative to each pass's largest value)."""
    from test_compiled import IMAGE_ATOL, IMAGE_RTOL
    from test_passes_light import assert_light_passes_agree
    settings = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=4, volume_bounces=2,
                              passes=LIGHT_PASSES)
    assert_light_passes_agree(fog_scene("COEFFICIENTS"), settings, IMAGE_RTOL, IMAGE_ATOL)


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_emitting_slab_seen_by_the_camera_is_emission_and_the_world_behind_it_keeps_its_transmittance(kernels):
    """A slab of Volume Coefficients (absorption sigma_a, emission e, no scattering, 0.8 deep) over the world: the
    camera sees the medium's emission, Cycles' Emission pass, e (1 - exp(-sigma_a d)) / sigma_a, and the world
    through it, Environment = world exp(-sigma_a d); no light pass; the two make Combined."""
    scene = Scene(camera=camera_above())
    sigma, e, d, world = np.array([0.5, 1.0, 2.0]), np.array([0.3, 0.2, 0.1]), 0.8, np.array([0.1, 0.12, 0.15])
    scene.materials.append(fog(closure="COEFFICIENTS", absorption=sigma, scatter=np.zeros(3), emission=e))
    scene.add_mesh(primitives.box((4.0, 4.0, d), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.world = World(color=world, camera=True, lights=True)
    settings = RenderSettings(width=4, height=4, samples=2, integrator="path",
                              passes=LIGHT_PASSES + ("emission", "environment"), kernels=kernels)
    result = render(scene, settings)
    emission = e * (1.0 - np.exp(-sigma * d)) / sigma
    np.testing.assert_allclose(result.aux["emission"], np.broadcast_to(emission, (4, 4, 3)), rtol=1e-5)
    np.testing.assert_allclose(result.aux["environment"], np.broadcast_to(world * np.exp(-sigma * d), (4, 4, 3)),
                               rtol=1e-5)
    np.testing.assert_allclose(result.aux["emission"] + result.aux["environment"], result.image[..., :3], rtol=1e-5)
    for name in LIGHT_PASSES:
        assert np.all(result.aux[name] == 0.0), name


# Every pass of light a render can ask for (the light passes, their colour passes, Emission, Environment, AO).
LIGHT_AND_COLOUR_PASSES = SUM_PASSES + ("ambient_occlusion",)


@pytest.mark.parametrize("kernels", KERNELS)
def test_each_pass_of_light_alone_is_the_same_as_beside_the_others(kernels):
    """Each pass of light asked alone (Blender's one tick, Volume Direct among them: its colour-less light passes
    once went unwritten without a first-hit pass beside them) equals the same pass asked beside all the others, bit
    for bit, on a medium that scatters and emits over surfaces of every kind, with Volume Bounces."""
    scene = fog_scene("COEFFICIENTS")
    settings = RenderSettings(width=16, height=12, samples=2, integrator="path", max_bounces=4, volume_bounces=2,
                              passes=LIGHT_AND_COLOUR_PASSES, kernels=kernels)
    among = render(scene, settings)
    assert among.stats.kernels.startswith(kernels)
    for name in LIGHT_AND_COLOUR_PASSES:
        alone = render(scene, dataclasses.replace(settings, passes=(name,))).aux
        assert set(alone) & set(LIGHT_AND_COLOUR_PASSES) == {name}, name
        assert among.aux[name].max() > 0.0, name
        np.testing.assert_array_equal(alone[name], among.aux[name], err_msg=name)
