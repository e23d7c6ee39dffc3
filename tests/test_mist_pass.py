"""The Mist pass (core/integrators/passes.py), as Cycles' data pass: 1 - the mean over samples of (1 - m)
throughput alpha at each vertex of the camera chain, m = clamp((d - start) / depth, 0, 1) ^ falloff of the distance d
from the camera (along its axis for an orthographic camera); a ray that escapes leaves 1. Closed forms, both
kernels."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.geometry import primitives
from core.materials import Material
from core.scene import RenderSettings, Scene

from test_volumes import camera_above


def mist_image(scene: Scene, kernels: str, **settings) -> np.ndarray:
    """The scene's Mist pass at 8 x 8, pixel centres (no jitter): (8, 8) float64."""
    options = dict(width=8, height=8, samples=1, jitter=False, kernels=kernels, passes=("mist",))
    options.update(settings)
    return render.render(scene, RenderSettings(**options)).aux["mist"][..., 0].astype(np.float64)


def floor(scene: Scene, size: float = 40.0) -> None:
    """A grey Lambert floor at z = 0."""
    scene.materials.append(Material(np.full(3, 0.5), "Floor"))
    scene.add_mesh(primitives.plane(size), materials=np.array([len(scene.materials) - 1]))


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("falloff", [1.0, 2.0, 0.5])
def test_an_orthographic_camera_measures_the_mist_along_its_axis(kernels, falloff):
    """A floor 3 below an orthographic camera, mist from 1 over 4: m = (3 - 1) / 4 = 0.5, the pass 0.5 ^ falloff."""
    scene = Scene(camera=camera_above(height=3.0))
    floor(scene)
    image = mist_image(scene, kernels, mist_start=1.0, mist_depth=4.0, mist_falloff=falloff)
    np.testing.assert_allclose(image, 0.5 ** falloff, rtol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_perspective_camera_measures_the_mist_by_the_distance_and_the_sky_is_all_mist(kernels):
    """A 90-degree camera 3 above a 4 x 4 floor: each pixel centre that meets the floor at distance d = 3 / cos theta
    holds clamp((d - 2) / 3, 0, 1) (linear); the pixels that see past the floor hold 1."""
    scene = Scene(camera=Camera.look_at(np.array([0.0, 0.0, 3.0]), np.zeros(3), up=(0.0, 1.0, 0.0),
                                        fov=math.radians(90.0)))
    floor(scene, 4.0)
    image = mist_image(scene, kernels, mist_start=2.0, mist_depth=3.0)
    c = (np.arange(8) + 0.5) / 8 * 2.0 - 1.0                  # tan of each pixel centre's angle (x, y)
    x, y = np.meshgrid(c * 3.0, c * 3.0)                       # where its ray meets the plane z = 0
    on_floor = (np.abs(x) < 2.0) & (np.abs(y) < 2.0)
    d = np.sqrt(9.0 + x * x + y * y)
    expected = np.where(on_floor, np.clip((d - 2.0) / 3.0, 0.0, 1.0), 1.0)
    np.testing.assert_allclose(image, expected, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_half_transparent_pane_adds_its_own_mist_by_its_alpha(kernels):
    """A pane 1.5 below an orthographic camera, Transparent 0.5 + Diffuse 0.25 (transparency 0.5, alpha 0.5), over the
    floor 3 below, mist from 0 over 4: the pane keeps 0.5 (1 - 0.375), the floor behind it, seen with throughput 0.5
    on average, keeps 0.5 (1 - 0.75); the pass is 1 - 0.3125 - 0.125 = 0.5625 on average (the camera chain goes
    through the pane by the transparent closure's share: each sample's is 0.5 or 0.6875; 4096 samples, within 5
    standard errors), and the two kernels agree sample for sample."""
    scene = Scene(camera=camera_above(height=3.0))
    floor(scene)
    scene.materials.append(Material(np.zeros(3), "Pane", nodes=[("TRANSPARENT", np.full(3, 0.5), {}),
                                                               ("DIFFUSE", np.full(3, 0.25), {})]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 1.5)), materials=np.array([1]))
    image = mist_image(scene, kernels, mist_start=0.0, mist_depth=4.0, samples=64)
    assert image.mean() == pytest.approx(0.5625, abs=5 * 0.0014)
    other = mist_image(scene, "numpy" if kernels == "compiled" else "compiled", mist_start=0.0, mist_depth=4.0,
                       samples=64)
    np.testing.assert_allclose(image, other, rtol=1e-6)
