"""Path tracing: bounce limits, Russian roulette and MIS against closed forms, on both paths."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.scene import RenderSettings, Scene

ALBEDO = 0.6
EMISSION = 0.5


def furnace(albedo: float = ALBEDO, emission: float = EMISSION, samples: int = 64) -> tuple:
    """The camera at the centre of a closed sphere that emits `emission` and reflects `albedo` diffusely
    everywhere. Light bounced k times arrives as emission x albedo^k, from every direction alike, whatever
    the sphere's shape (flat-shaded, so that no shading normal leans past its face): so a path of at most
    B bounces sees emission x (1 + albedo + ... + albedo^(B+1)), exactly, with no noise at all."""
    scene = Scene(camera=Camera(lens=18.0))
    scene.materials.append(materials.Material(name="glowing wall", nodes=[
        ("DIFFUSE", (albedo, albedo, albedo), {}), ("EMISSION", (1.0, 1.0, 1.0), {"emission": (emission,) * 3})]))
    scene.add_mesh(primitives.uv_sphere(3.0, 16, 8, smooth=False), materials=np.array([0]))
    return scene, RenderSettings(width=8, height=8, samples=samples, integrator="path", min_light_bounces=1024)


def furnace_radiance(bounces: int, albedo: float = ALBEDO, emission: float = EMISSION) -> float:
    """emission x sum_{k=0}^{bounces+1} albedo^k (bounces = inf: emission / (1 - albedo))."""
    if math.isinf(bounces):
        return emission / (1.0 - albedo)
    return emission * sum(albedo ** k for k in range(bounces + 2))


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("bounces", [0, 1, 3])
def test_each_bounce_adds_one_more_albedo_factor_of_the_furnace(bounces, kernels):
    """Max Bounces B: the furnace shows emission x (1 + a + ... + a^(B+1)), the direct light (B = 0) being
    emission x (1 + a); Diffuse Bounces limits the same way. (Min Light Bounces keeps Russian roulette out.)"""
    scene, settings = furnace()
    settings = dataclasses.replace(settings, max_bounces=bounces, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, furnace_radiance(bounces), rtol=1e-4)
    limited = dataclasses.replace(settings, max_bounces=12, diffuse_bounces=bounces)
    image = render.render(scene, limited).image[..., :3]
    np.testing.assert_allclose(image, furnace_radiance(bounces), rtol=1e-4)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_russian_roulette_keeps_the_furnace_unbiased(kernels):
    """Many bounces with Russian roulette from the third vertex: emission / (1 - albedo) (the geometric
    series summed), although most paths end early: only the roulette is random here."""
    scene, settings = furnace(albedo=0.8, samples=256)
    settings = dataclasses.replace(settings, max_bounces=1024, diffuse_bounces=1024, min_light_bounces=0,
                                   kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    expected = furnace_radiance(math.inf, albedo=0.8)
    assert image.mean() == pytest.approx(expected, rel=0.02)
