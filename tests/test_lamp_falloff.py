"""A Light Falloff node in a lamp's tree (Light.falloff), as Cycles' svm_node_light_falloff with the light sample's
ray length t: the lamp's light times t^power (Quadratic 0, Linear 1, Constant 2), times t^2 / (Smooth + t^2) where
Smooth > 0. Closed forms on both kernels for a point lamp; a sphere, a spot and an area lamp found by light samples
alone and by BSDF rays alone agree (the two ways weigh the falloff at the same distances)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import render
from core.geometry import primitives
from core.lights import AreaLight, PointLight, SpotLight
from core.materials import Material
from core.scene import RenderSettings, Scene, World

from test_emitters_world import ortho_down

RHO, P, H = 0.5, 100.0, 1.5                               # the floor's albedo, the lamp's power, its height


def floor_scene(lamp) -> Scene:
    """A Lambert floor of albedo RHO seen straight down by an orthographic camera 4 wide, lit by `lamp` alone."""
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=World(color=np.zeros(3)))
    scene.materials.append(Material(np.full(3, RHO), "Floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.lights.append(lamp)
    return scene


def pixel_centres(n: int = 8, scale: float = 4.0) -> np.ndarray:
    """The floor points (n, n) at the centres of an n x n image of the orthographic camera: x, y (n, n) each."""
    c = (np.arange(n) + 0.5) / n * scale - scale / 2
    return np.meshgrid(c, c[::-1])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("falloff", [(1, 0.0), (2, 0.0), (2, 3.0), (0, 0.5)])
def test_a_point_lamps_falloff_scales_its_light_by_the_distance_to_the_power(kernels, falloff):
    """A point lamp of power P at height H: the floor at horizontal distance r shows rho / pi P / (4 pi) H / d^3 g(d),
    d = sqrt(H^2 + r^2), g(d) = d^power (d^2 / (Smooth + d^2) where Smooth > 0), at each pixel centre (no jitter)."""
    lamp = PointLight(position=np.array([0.0, 0.0, H]), power=P, falloff=falloff)
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    image = render.render(floor_scene(lamp), settings).image[..., 0]
    x, y = pixel_centres()
    d = np.sqrt(H * H + x * x + y * y)
    power, smooth = falloff
    g = d ** power * (d * d / (smooth + d * d) if smooth > 0 else 1.0)
    np.testing.assert_allclose(image, RHO / math.pi * P / (4.0 * math.pi) * H / d ** 3 * g, rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("lamp", ["sphere", "spot", "area"])
def test_light_samples_and_bsdf_rays_see_the_same_falloff(kernels, lamp):
    """A lamp with extent (a sphere of radius 0.5, a round spot, a 1 x 1 area lamp) and a Constant falloff with Smooth 1:
    the floor lit by light samples alone and by BSDF rays alone has the same mean (within 3 %, both unbiased), and
    differs from the floor without the falloff by more than that."""
    def make(falloff):
        if lamp == "sphere":
            return PointLight(position=np.array([0.3, 0.0, H]), power=P, radius=0.5, falloff=falloff)
        if lamp == "spot":
            return SpotLight(position=np.array([0.3, 0.0, H]), power=P, radius=0.5, direction=np.array([0.0, 0.0, -1.0]),
                             spot_size=math.radians(120.0), falloff=falloff)
        return AreaLight(center=np.array([0.3, 0.0, H]), direction=np.array([0.0, 0.0, -1.0]), power=P,
                         axis_u=np.array([1.0, 0.0, 0.0]), axis_v=np.array([0.0, 1.0, 0.0]), falloff=falloff)

    def mean(falloff, sampling):
        settings = RenderSettings(width=8, height=8, samples=256, kernels=kernels, light_sampling=sampling)
        return render.render(floor_scene(make(falloff)), settings).image[..., :3].mean()

    by_light, by_bsdf = mean((2, 1.0), "light"), mean((2, 1.0), "bsdf")
    assert by_bsdf == pytest.approx(by_light, rel=0.03)
    assert abs(mean((0, 0.0), "light") / by_light - 1.0) > 0.1
