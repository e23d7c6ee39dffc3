"""First-hit render passes in core (core/integrators/passes.py), without Blender: what they hold on a
scene whose answers are known, and that nothing is computed for passes not asked for."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
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
    assert not render.prepare(scene, none).extra["pass_layout"]        # the integrator writes none


def test_an_unknown_pass_name_is_refused():
    scene, settings = floor_scene()
    with pytest.raises(ValueError, match="unknown render passes"):
        render.render(scene, dataclasses.replace(settings, passes=("shadow",)))
