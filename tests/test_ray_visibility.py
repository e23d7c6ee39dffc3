"""Object > Visibility > Ray Visibility, Camera and Shadow, as Cycles reads them, on both paths: a hidden
object is passed by those rays as if it were not there, and is still seen by every other ray."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.lights import SunLight
from core.scene import RenderSettings, Scene

KERNELS = ["numpy", "compiled"]


def glow(name: str, radiance: float) -> materials.Material:
    """A surface that only emits `radiance` (no BSDF): what the camera sees of it is that number."""
    return materials.Material(name=name, nodes=[("EMISSION", (1, 1, 1), {"emission": (radiance,) * 3})])


def looking_down(distance: float = 4.0) -> Camera:
    """A camera `distance` above the origin, looking straight down -Z."""
    return Camera(lens=35.0, matrix_world=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, distance], [0, 0, 0, 1.0]]))


@pytest.mark.parametrize("kernels", KERNELS)
def test_camera_rays_pass_an_object_hidden_from_the_camera(kernels):
    """A quad glowing 5 in front of a wall glowing 2: seen, the quad's pixels are 5; hidden from the camera,
    every pixel shows the wall's 2, exactly, as if the quad were not there."""
    scene = Scene(camera=looking_down())
    scene.materials += [glow("wall", 2.0), glow("quad", 5.0)]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(0.8, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    settings = RenderSettings(width=24, height=24, samples=2, kernels=kernels)
    seen = render.render(scene, settings).image[..., :3]
    assert (seen == 5.0).any() and (seen == 2.0).any()
    scene.instances[1].visible_camera = False
    hidden = render.render(scene, settings).image[..., :3]
    np.testing.assert_array_equal(hidden, 2.0)


def lit_floor(hide_lamp: bool = False, albedo: float = 0.5) -> Scene:
    """A diffuse floor lit only by a glowing quad above it (which the camera sees unless `hide_lamp`)."""
    scene = Scene(camera=looking_down(6.0))
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (albedo,) * 3, {})]), glow("lamp", 8.0)]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    lamp = np.array([[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 1.5], [0, 0, 0, 1.0]])     # facing down, 1.5 up
    scene.add_mesh(primitives.plane(1.0), lamp, materials=np.array([1]))
    scene.instances[1].visible_camera = not hide_lamp
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_emitter_hidden_from_the_camera_still_lights_the_floor(kernels):
    """The glowing quad hidden from the camera: the floor it lights is the same, pixel for pixel (the same rays
    and samples), and where the quad was seen the floor below it shows, lit."""
    settings = RenderSettings(width=32, height=32, samples=4, kernels=kernels)
    seen = render.render(lit_floor(), settings).image[..., :3]
    hidden = render.render(lit_floor(hide_lamp=True), settings).image[..., :3]
    quad = (seen == 8.0).all(axis=-1)                  # pixels all of whose samples saw the quad
    touched = (seen > 1.0).any(axis=-1)                 # and those some of whose did (the floor is far dimmer)
    assert quad.sum() > 4
    np.testing.assert_allclose(hidden[~touched], seen[~touched], rtol=1e-6)
    assert (hidden[quad] > 0.001).all() and (hidden[quad] < 1.0).all()


def sunlit_floor(kernels: str, hide_shadow: bool) -> tuple:
    """A floor of albedo 0.5 under a sun of 3 W/m^2 at 30 degrees from the zenith, a box standing on it."""
    scene = Scene(camera=looking_down(8.0))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(30.0), materials=np.array([0]))
    scene.add_mesh(primitives.box((1.0, 1.0, 2.0), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.instances[1].visible_shadow = not hide_shadow
    theta = math.radians(30.0)
    scene.lights.append(SunLight(np.array([math.sin(theta), 0.0, -math.cos(theta)]), strength=3.0))
    return scene, RenderSettings(width=32, height=32, samples=1, kernels=kernels)


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_object_hidden_from_shadow_rays_casts_no_shadow(kernels):
    """A box on a sunlit floor: its shadow is black; hidden from shadow rays, every floor pixel has the sunlit
    floor's radiance albedo x E cos(theta) / pi, exactly, and the box itself is still seen (and lit)."""
    expected = 0.5 * 3.0 * math.cos(math.radians(30.0)) / math.pi
    scene, settings = sunlit_floor(kernels, hide_shadow=False)
    casting = render.render(scene, settings).image[..., :3]
    scene, settings = sunlit_floor(kernels, hide_shadow=True)
    hidden = render.render(scene, settings).image[..., :3]
    floor = np.isclose(hidden, expected, rtol=1e-6).all(axis=-1)
    shadow = (casting == 0.0).all(axis=-1)
    assert shadow.sum() > 4 and floor[shadow].all()               # where the shadow was: sunlit floor
    box_top = np.isclose(hidden, 0.5 * 3.0 * math.cos(math.radians(30.0)) / math.pi, rtol=1e-6).all(axis=-1)
    assert box_top.sum() > 0.5 * hidden.shape[0] * hidden.shape[1]
    np.testing.assert_allclose(hidden[~shadow], casting[~shadow], rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("instancing", ["never", "always"])
def test_one_placement_of_a_shared_mesh_hides_and_the_other_does_not(kernels, instancing):
    """One quad mesh placed twice (traced as Embree instances with Instancing: Always), the second placement
    hidden from the camera: the first is seen glowing 5, where the second was the wall's 2 shows."""
    scene = Scene(camera=looking_down())
    scene.materials += [glow("wall", 2.0), glow("quad", 5.0)]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    quad = scene.add_mesh(primitives.plane(0.5), np.array([[1, 0, 0, -0.5], [0, 1, 0, 0], [0, 0, 1, 1.0], [0, 0, 0, 1]]),
                          materials=np.array([1]))
    scene.instances.append(dataclasses.replace(scene.instances[-1], matrix=np.array(
        [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 1.0], [0, 0, 0, 1]], np.float64), visible_camera=False))
    assert scene.instances[-1].mesh == quad
    settings = RenderSettings(width=32, height=16, samples=1, kernels=kernels, instancing=instancing)
    image = render.render(scene, settings).image[..., :3]
    left, right = image[:, :16], image[:, 16:]
    assert (left == 5.0).any()
    np.testing.assert_array_equal(right, 2.0)
