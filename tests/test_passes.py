"""First-hit render passes in core (core/integrators/passes.py), without Blender: what they hold on a
scene whose answers are known, and that nothing is computed for passes not asked for."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.integrators.passes import PASS_CHANNELS
from core.scene import RenderSettings, Scene


def floor_scene(pass_index: int = 5, material_index: int = 9) -> tuple:
    """A 4 x 4 floor (z = 0) at the origin under a camera 3 above it looking straight down, the world grey."""
    scene = Scene(camera=Camera.look_at(np.array([0.0, 0.0, 3.0]), np.zeros(3), up=(0.0, 1.0, 0.0),
                                        fov=math.radians(90)),
                  world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_material((0.5, 0.25, 0.125))
    scene.materials[0].pass_index = material_index
    mesh = primitives.plane(4.0)
    scene.add_mesh(mesh, materials=[0])
    scene.instances[0].pass_index = pass_index
    settings = RenderSettings(width=32, height=32, samples=4, passes=tuple(PASS_CHANNELS))
    return scene, settings


def test_floor_passes_hold_the_hit_point_indices_albedo_and_world():
    scene, settings = floor_scene()
    aux = render.render(scene, settings).aux
    hit = aux["object_index"][..., 0] > 0
    assert 0.2 < hit.mean() < 0.9                                   # the floor and the world around it
    assert np.all(aux["object_index"][hit] == 5) and np.all(aux["material_index"][hit] == 9)
    assert np.allclose(aux["position"][hit][:, 2], 0.0, atol=1e-5)  # on the floor
    assert np.abs(aux["position"][hit][:, :2]).max() <= 2.0 + 1e-5
    inside = aux["uv"][..., 2] == 1.0
    assert np.allclose(aux["diffuse_color"][inside], (0.5, 0.25, 0.125), atol=1e-6)
    assert np.all(aux["environment"][inside] == 0.0)
    missed = aux["uv"][..., 2] == 0.0
    assert missed.any() and np.allclose(aux["environment"][missed], (0.1, 0.2, 0.3), atol=1e-6)
    assert np.all(aux["ambient_occlusion"][inside] == 1.0)           # nothing above the floor
    assert np.all(aux["glossy_color"] == 0.0) and np.all(aux["emission"] == 0.0)


def test_the_position_pass_follows_the_scene_not_the_camera_relative_frame():
    scene, settings = floor_scene()
    moved = np.eye(4)
    moved[:3, 3] = (100.0, -50.0, 7.0)
    scene.instances[0].matrix = moved
    scene.camera = Camera.look_at(np.array([100.0, -50.0, 10.0]), np.array([100.0, -50.0, 7.0]), up=(0.0, 1.0, 0.0),
                                  fov=math.radians(90))
    aux = render.render(scene, settings).aux
    hit = aux["object_index"][..., 0] > 0
    assert np.allclose(aux["position"][hit][:, 2], 7.0, atol=1e-4)
    assert np.allclose(aux["position"][hit][:, 0].mean(), 100.0, atol=0.1)


def test_only_the_passes_asked_for_are_returned():
    scene, settings = floor_scene()
    result = render.render(scene, dataclasses.replace(settings, passes=("uv",)))
    assert "uv" in result.aux and not set(result.aux) & (set(PASS_CHANNELS) - {"uv"})
    none = dataclasses.replace(settings, passes=())
    result = render.render(scene, none)
    assert not set(result.aux) & set(PASS_CHANNELS)
    assert result.stats.first_hit == () and not render.prepare(scene, none).extra["pass_layout"]   # none written


def test_an_unknown_pass_name_is_refused():
    scene, settings = floor_scene()
    with pytest.raises(ValueError, match="unknown render passes"):
        render.render(scene, dataclasses.replace(settings, passes=("shadow",)))


def chain_scene() -> Scene:
    """The light passes' scene of many materials (tests/test_passes_light.py sum_scene) with a sheet in front that lets
    60 % through (a Transparent BSDF mixed with a Diffuse: camera chains through it) and an area lamp the camera sees."""
    from test_passes_light import sum_scene
    from core.lights import AreaLight
    scene = sum_scene()
    scene.materials.append(materials.Material(name="veil", nodes=[("TRANSPARENT", (0.6, 0.6, 0.6), {}),
                                                                  ("DIFFUSE", (0.4, 0.3, 0.2), {})]))
    scene.add_mesh(primitives.plane(1.5, center=(0.3, -2.5, 1.2)), materials=np.array([len(scene.materials) - 1]),
                   name="Veil")
    scene.instances[-1].pass_index = 3
    scene.materials[-1].pass_index = 7
    scene.lights.append(AreaLight(center=np.array([-0.8, 1.0, 2.2]), axis_u=np.array([0.6, 0.0, 0.0]),
                                  axis_v=np.array([0.0, 0.0, 0.4]), direction=np.array([0.0, -1.0, 0.0]), power=40.0))
    return scene


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_the_compiled_first_hit_passes_follow_the_reference(integrator):
    """The C kernels write every first-hit pass from the same samples as the Python reference (the images' tolerance
    of tests/test_compiled.py, relative to each pass's largest value; Cryptomatte's ids exactly)."""
    from test_compiled import IMAGE_ATOL, IMAGE_RTOL
    everything = tuple(PASS_CHANNELS) + ("crypto_object", "crypto_material", "crypto_asset")
    settings = RenderSettings(width=40, height=30, samples=4, integrator=integrator, max_bounces=2, passes=everything)
    def moving():                                   # (an instance that moves between frames: the Vector pass)
        scene = chain_scene()
        before, after = np.array(scene.instances[0].matrix, np.float64), np.array(scene.instances[0].matrix, np.float64)
        before[:3, 3] -= (0.05, 0.02, 0.0)
        after[:3, 3] += (0.04, 0.0, 0.03)
        scene.instances[0].vector_motion = (before, after)
        return scene
    compiled = render.render(moving(), dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(moving(), dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    for name in everything:
        a, b = compiled.aux[name], reference.aux[name]
        assert a.shape == b.shape and np.abs(b).max() > 0.0, name
        if name.startswith("crypto"):
            assert np.array_equal(a[..., 0::2], b[..., 0::2]), name
            a, b = a[..., 1::2], b[..., 1::2]
        np.testing.assert_allclose(a, b, rtol=IMAGE_RTOL, atol=IMAGE_ATOL * max(1.0, float(np.abs(b).max())),
                                   err_msg=name)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_the_alpha_threshold_picks_the_first_surface_that_opaque_for_the_data_passes(kernels):
    """The view layer's Alpha Threshold: a veil letting 60 % through (alpha 0.4) 1 above the floor holds the data
    passes under a threshold of 0.3 or 0 (Position z = 1 in every pixel); under Cycles' default 0.5 the camera paths
    that pass it (its Transparent share sampled) reach the floor behind it (z = 0) and the others end on it."""
    scene, settings = floor_scene()
    scene.materials.append(materials.Material(name="veil", nodes=[("TRANSPARENT", (0.6, 0.6, 0.6), {}),
                                                                  ("DIFFUSE", (0.4, 0.4, 0.4), {})]))
    scene.add_mesh(primitives.plane(4.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]), name="Veil")
    settings = dataclasses.replace(settings, width=8, height=8, kernels=kernels, passes=("position",))
    def heights(threshold):
        return render.render(scene, dataclasses.replace(settings, pass_alpha_threshold=threshold)).aux["position"][..., 2]
    for threshold in (0.3, 0.0):
        np.testing.assert_allclose(heights(threshold), 1.0, atol=1e-5, err_msg=str(threshold))
    z = heights(0.5)
    floor = np.abs(z) < 1e-5
    assert floor.any() and (floor | (np.abs(z - 1.0) < 1e-5)).all()
