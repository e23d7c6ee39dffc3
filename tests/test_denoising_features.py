"""Denoising features (core/integrators/features.py): each pixel's first non-specular albedo and normal."""
from __future__ import annotations

import math

import numpy as np

from conftest import ortho_down, sun_direction, unit
from core import render
from core.camera import Camera
from core.geometry import primitives
from core.integrators import features
from core.scene import RenderSettings, Scene, SunLight


def plane_scene(color=(0.2, 0.5, 0.7), bsdf="DIFFUSE", world=(0.0, 0.0, 0.0)) -> Scene:
    """A 20 x 20 plane in z = 0 with one material under a sun, an orthographic camera looking down."""
    scene = Scene(camera=ortho_down(scale=2.0), world_color=np.array(world, np.float64))
    scene.add_material(color, bsdf=bsdf)
    scene.add_mesh(primitives.plane(20.0), materials=[0])
    scene.lights.append(SunLight(sun_direction(60.0), strength=2.0))
    return scene


def features_of(scene: Scene, kernels: str = "compiled", **kw) -> dict:
    """Render `scene` small with the denoising features and return the result's aux buffers."""
    settings = RenderSettings(width=16, height=12, samples=4, denoising_features=True, kernels=kernels, **kw)
    return render.render(scene, settings).aux


def test_a_diffuse_plane_gives_its_base_colour_as_albedo_and_its_normal():
    """Lambert's closure weight is the base colour; the shading normal of a plane facing the camera is +Z."""
    for kernels in ("compiled", "numpy"):
        aux = features_of(plane_scene(), kernels)
        assert aux["denoising_albedo"].shape == (12, 16, 3) and aux["denoising_albedo"].dtype == np.float32
        np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to([0.2, 0.5, 0.7], (12, 16, 3)), atol=1e-6)
        np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, 0.0, 1.0], (12, 16, 3)), atol=1e-6)


def test_the_features_leave_the_image_unchanged():
    """The features come from a pass of their own: the render's image is the same with or without them."""
    scene = plane_scene()
    a = render.render(scene, RenderSettings(width=16, height=12, samples=4)).image
    b = render.render(scene, RenderSettings(width=16, height=12, samples=4, denoising_features=True)).image
    assert np.array_equal(a, b)


def test_a_mirror_shows_the_albedo_and_normal_of_what_it_reflects():
    """A tinted mirror tilted 45 degrees under the camera reflects a red wall: albedo tint x red, the wall's normal."""
    camera = Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=math.radians(10))
    scene = Scene(camera=camera, world_color=np.zeros(3))
    scene.add_material((0.9, 0.8, 0.5), bsdf="MIRROR")
    scene.add_material((0.6, 0.1, 0.1))
    mirror = primitives.plane(4.0)
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(math.pi / 4), -math.sin(math.pi / 4)],
                     [0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]])
    mirror.vertices = mirror.vertices @ tilt.T                      # normal (0, -0.707, 0.707)
    scene.add_mesh(mirror, materials=[0])
    wall = primitives.plane(40.0)
    wall.vertices = wall.vertices @ np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]).T
    wall.vertices = wall.vertices + [0.0, -6.0, 0.0]              # the plane y = -6, normal +-Y
    scene.add_mesh(wall, materials=[1])
    scene.lights.append(SunLight(sun_direction(60.0), strength=2.0))
    aux = features_of(scene)
    centre = aux["denoising_albedo"][4:8, 6:10]
    np.testing.assert_allclose(centre, np.broadcast_to([0.54, 0.08, 0.05], centre.shape), atol=1e-5)
    normal = aux["denoising_normal"][4:8, 6:10]
    np.testing.assert_allclose(normal, np.broadcast_to([0.0, 1.0, 0.0], normal.shape), atol=1e-5)


def test_rays_that_escape_give_the_world_as_albedo_and_no_normal():
    """Where the camera sees the world: its colour as albedo (Cycles writes the background), normal 0."""
    scene = Scene(camera=ortho_down(scale=2.0), world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(20.0, center=(0.0, 0.0, 5.0)), materials=[0])   # behind the camera
    scene.lights.append(SunLight(sun_direction(60.0), strength=2.0))
    aux = features_of(scene)
    np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to([0.1, 0.2, 0.3], (12, 16, 3)), atol=1e-6)
    assert not aux["denoising_normal"].any()


def test_glossy_closures_count_as_diffuse_only_when_rough():
    """Cycles' split: a glossy closure with alpha > 0.075 is diffuse-like, a sharper one specular-like."""
    from core.materials import Closures, Lambert, Microfacet, Mirror, PARAMS
    kind = np.array([[Lambert.kind, Microfacet.kind, Microfacet.kind, Mirror.kind]], np.int32)
    params = np.zeros((1, 4, PARAMS))
    params[0, 1, 0], params[0, 2, 0] = 0.3, 0.01
    closures = Closures(kind, np.ones((1, 4, 3)), np.ones((1, 4)), np.tile(unit([0, 0, 1]), (1, 4, 1)), params)
    assert features.diffuse_like(closures).tolist() == [[True, True, False, False]]
    assert features.feature_samples(1) == 1 and features.feature_samples(1024) == features.FEATURE_SAMPLES
