"""The Vector pass (core/integrators/passes.py vector_at, passes.c): each hit's motion on screen between the frames
before and after, in raster pixels, as Cycles' primitive_motion_vector; closed forms on a floor, both kernels."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.camera.camera import world_to_raster
from core.camera.motion import Shutter
from core.geometry import primitives
from core.scene import RenderSettings, Scene

KERNELS = ["numpy", "compiled"]


def floor_under(camera: Camera) -> tuple:
    """A 20 x 20 floor (z = 0) seen by `camera` (filling its view), the Vector pass asked for: (scene, settings)."""
    scene = Scene(camera=camera)
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(20.0), materials=[0])
    return scene, RenderSettings(width=16, height=12, samples=2, passes=("vector",))


def shifted(matrix, offset) -> np.ndarray:
    """`matrix` (4, 4) moved by offset (3,) in the world."""
    out = np.array(matrix, np.float64)
    out[:3, 3] += offset
    return out


def ortho_camera() -> Camera:
    """An orthographic camera 3 above the origin looking down, 2 wide (x right, y up on screen)."""
    return Camera(matrix_world=np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 3.0], [0, 0, 0, 1.0]]),
                  type="ORTHO", ortho_scale=2.0)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_floor_moving_steadily_moves_by_its_speed_in_pixels_on_both_sides_of_the_frame(kernels):
    """The floor moves by d = (0.25, -0.125) a frame under an orthographic camera 2 wide over 16 pixels (8 pixels a
    unit): every pixel's vector is (before - now, now - after) = (-8 d, -8 d) = (-2, 1, -2, 1) (Cycles' raster: y up)."""
    scene, settings = floor_under(ortho_camera())
    d = np.array([0.25, -0.125, 0.0])
    floor = scene.instances[0]
    floor.vector_motion = (shifted(floor.matrix, -d), shifted(floor.matrix, d))
    vector = render.render(scene, dataclasses.replace(settings, kernels=kernels)).aux["vector"]
    np.testing.assert_allclose(vector, np.broadcast_to([-2.0, 1.0, -2.0, 1.0], vector.shape), atol=1e-9)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_camera_moving_over_a_still_floor_moves_it_the_other_way_on_screen(kernels):
    """A perspective camera 3 above the floor, 90 degrees across 16 pixels (the floor's plane 6 across at depth 3),
    moving 0.3 a frame towards -x: a frame earlier it was 0.3 further along x, so the floor stood 0.3 x 16 / 6 = 0.8
    pixel further left then (before - now = -0.8), and a frame later it stands 0.8 further right (now - after =
    -0.8); y does not move."""
    camera = Camera.look_at(np.array([0.0, 0.0, 3.0]), np.zeros(3), up=(0.0, 1.0, 0.0), fov=math.radians(90))
    scene, settings = floor_under(camera)
    scene.vector_cameras = (dataclasses.replace(camera, matrix_world=shifted(camera.matrix_world, (0.3, 0.0, 0.0))),
                            dataclasses.replace(camera, matrix_world=shifted(camera.matrix_world, (-0.3, 0.0, 0.0))))
    vector = render.render(scene, dataclasses.replace(settings, kernels=kernels)).aux["vector"]
    np.testing.assert_allclose(vector, np.broadcast_to([-0.8, 0.0, -0.8, 0.0], vector.shape), atol=1e-6)


def test_world_to_raster_sends_each_pixels_ray_back_to_that_pixel():
    """Cycles' worldtoraster inverts the camera's rays: a point along the ray through raster (x, y from the top) of a
    turned, shifted perspective camera and of an orthographic one lands on (x, height - y), Cycles' y from the
    bottom."""
    from core.camera.camera import _orthographic_rays, _perspective_rays
    turned = np.array([[1.0, 0, 0, 1], [0, 0, -1, -5], [0, 1, 0, 2], [0, 0, 0, 1]])
    for camera, rays in ((Camera(matrix_world=turned, lens=35.0, shift_x=0.1, shift_y=-0.05), _perspective_rays),
                         (Camera(matrix_world=turned, type="ORTHO", ortho_scale=3.0, sensor_fit="VERTICAL"),
                          _orthographic_rays)):
        x, y = np.array([0.5, 10.25, 63.0]), np.array([47.5, 5.0, 30.75])
        origins, directions, _, _ = rays(camera, 64, 48, x, y, (1.0, 1.0))
        local = origins + 4.0 * directions
        world = local @ camera.matrix_world[:3, :3].T + camera.matrix_world[:3, 3]
        h = np.c_[world, np.ones(3)] @ world_to_raster(camera, 64, 48).T
        np.testing.assert_allclose(h[:, :2] / h[:, 3:], np.c_[x, 48.0 - y], atol=1e-9)


@pytest.mark.parametrize("kernels", KERNELS)
def test_with_motion_blur_the_vector_pass_is_zero_as_cycles_writes_it(kernels):
    """Cycles writes a Vector pass of zeros when the render blurs motion; so does Primer, however the floor moves."""
    camera = dataclasses.replace(ortho_camera(), shutter=Shutter.box())
    scene, settings = floor_under(camera)
    floor = scene.instances[0]
    floor.vector_motion = (shifted(floor.matrix, (-0.5, 0.0, 0.0)), shifted(floor.matrix, (0.5, 0.0, 0.0)))
    vector = render.render(scene, dataclasses.replace(settings, kernels=kernels)).aux["vector"]
    assert vector.shape == (12, 16, 4) and not vector.any()
