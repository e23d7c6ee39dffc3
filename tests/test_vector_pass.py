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


def turned(scale: float, offset) -> np.ndarray:
    """An object-to-world transform: a quarter turn about z, scaled by `scale`, moved by offset (3,)."""
    out = np.eye(4)
    out[:3, :3] = scale * np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    out[:3, 3] = offset
    return out


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_mesh_whose_vertices_shift_between_frames_moves_by_that_shift_carried_by_its_transform(kernels):
    """Cycles' deformation motion: a floor whose vertices (object space) stand e = (0.1, 0.05, 0) back a frame earlier
    and as far on a frame later (Instance.vector_deformation), under a transform turning it a quarter about z and
    scaling it by 2, moves in the world by d = M e = (-0.1, 0.2, 0), and the object slides t = (0, 0.0625, 0) a frame
    besides (its transform then carries the vertices then): with the orthographic camera (8 pixels a unit) also
    moving c = 0.05 along +x a frame, the pass is 8 ((-d - t) - (-c)) on both sides of the frame, (1.2, -2.1, 1.2,
    -2.1), in every pixel (a shift interpolates to itself; within 5e-5 pixel: the positions are kept as float32
    attributes)."""
    scene, settings = floor_under(ortho_camera())
    floor = scene.instances[0]
    floor.matrix = turned(2.0, (0.0, 0.0, 0.0))
    scene.meshes[0] = primitives.plane(10.0)
    e = np.array([0.1, 0.05, 0.0])
    vertices = scene.meshes[0].vertices
    floor.vector_deformation = (vertices - e, vertices + e)
    t = np.array([0.0, 0.0625, 0.0])                  # (the object's own slide, M_before and M_after)
    floor.vector_motion = (shifted(floor.matrix, -t), shifted(floor.matrix, t))
    camera = scene.camera
    c = np.array([0.05, 0.0, 0.0])
    scene.vector_cameras = (dataclasses.replace(camera, matrix_world=shifted(camera.matrix_world, -c)),
                            dataclasses.replace(camera, matrix_world=shifted(camera.matrix_world, c)))
    vector = render.render(scene, dataclasses.replace(settings, kernels=kernels)).aux["vector"]
    d = floor.matrix[:3, :3] @ e
    expected = 8.0 * np.r_[(-d - t)[:2] - (-c)[:2], (-d - t)[:2] - (-c)[:2]]
    np.testing.assert_allclose(expected, [1.2, -2.1, 1.2, -2.1], atol=1e-12)
    np.testing.assert_allclose(vector, np.broadcast_to(expected, vector.shape), atol=5e-5)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_mesh_growing_between_frames_moves_each_hit_by_its_own_vertices_interpolated(kernels):
    """A floor whose vertices stand at 0.9 of where they are a frame earlier and 1.2 a frame later (a shape key
    growing it about its origin, placed at (0.3, -0.2)): the hit at p (object space) was at 0.9 p and will be at
    1.2 p, so with one sample a pixel (the Position pass its hit) the pass is 8 (-0.1 p, -0.2 p) in x and y (the
    barycentric interpolation of the corners is exact for a linear motion); where the frame after's vertices are of
    another count (the topology changed) that side takes the transform's motion alone (0 here), as Cycles copies the
    frame's vertices there."""
    scene, settings = floor_under(ortho_camera())
    floor = scene.instances[0]
    floor.matrix = shifted(np.eye(4), (0.3, -0.2, 0.0))
    scene.meshes[0] = primitives.plane(10.0)
    vertices = scene.meshes[0].vertices
    settings = dataclasses.replace(settings, samples=1, passes=("vector", "position"), kernels=kernels)
    for after, grows in ((1.2 * vertices, True), (np.zeros((5, 3)), False)):
        floor.vector_deformation = (0.9 * vertices, after)
        aux = render.render(scene, settings).aux
        p = aux["position"][..., :2] - [0.3, -0.2]
        np.testing.assert_allclose(aux["vector"][..., :2], 8.0 * (-0.1 * p), atol=5e-5)
        np.testing.assert_allclose(aux["vector"][..., 2:], 8.0 * (-0.2 * p) if grows else 0.0, atol=5e-5)
        assert np.ptp(p[..., 0]) > 1.5


def test_a_deforming_mesh_gets_its_vertices_then_as_attributes_and_a_rigid_one_none():
    """with_vector_deformation: the deforming mesh carries its vertices at both frames per corner (object space), a
    frame whose vertices did not change or changed count keeps the mesh's own, a mesh that does not deform gets
    nothing, and the scene given is left as it was."""
    from core.integrators import passes
    scene = Scene(camera=ortho_camera())
    scene.add_mesh(primitives.plane(2.0))
    scene.add_mesh(primitives.plane(2.0))
    vertices = scene.meshes[0].vertices
    scene.instances[0].vector_deformation = (vertices + 1.0, np.zeros((3, 3)))
    out = passes.with_vector_deformation(scene)
    assert out is not scene and "motion:before" not in (scene.meshes[0].attributes or {})
    attributes = out.meshes[0].attributes
    np.testing.assert_array_equal(attributes["motion:before"], (vertices + 1.0)[scene.meshes[0].triangles])
    np.testing.assert_array_equal(attributes["motion:after"], vertices[scene.meshes[0].triangles])
    assert not out.meshes[1].attributes
    scene.instances[0].vector_deformation = (vertices.copy(), None)
    assert passes.with_vector_deformation(scene) is scene


def test_the_compiled_deformation_motion_follows_the_reference():
    """Both kernels map a box whose every vertex moves its own way between frames (a perspective camera, the box
    turned and sliding too) to the same pass, pixel for pixel, from the same samples."""
    camera = Camera.look_at(np.array([2.0, -3.0, 2.5]), np.zeros(3), up=(0.0, 0.0, 1.0), fov=math.radians(50))
    scene = Scene(camera=camera)
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(20.0), materials=[0])
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(0.0, 0.0, 0.5)), turned(1.0, (0.2, 0.0, 0.0)),
                   materials=[0])
    box = scene.instances[1]
    vertices = scene.meshes[1].vertices
    wobble = np.random.default_rng(3).uniform(-0.2, 0.2, (2, *vertices.shape))
    box.vector_deformation = (vertices + wobble[0], vertices + wobble[1])
    box.vector_motion = (shifted(box.matrix, (-0.1, 0.0, 0.0)), shifted(box.matrix, (0.1, 0.05, 0.0)))
    settings = RenderSettings(width=24, height=18, samples=4, passes=("vector",))
    compiled, reference = (render.render(scene, dataclasses.replace(settings, kernels=k)) for k in ("compiled", "numpy"))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_allclose(compiled.aux["vector"], reference.aux["vector"], atol=1e-6)
    assert np.abs(reference.aux["vector"]).max() > 1.0


def test_a_deformation_without_room_among_the_attributes_is_noted_and_left_to_the_transform():
    """The materials' attributes take graph.MAX_ATTRIBUTES floats a corner at most: where the deforming meshes'
    vertices (6 more) do not fit, the scene is left as it is, with a note."""
    from core.integrators import passes
    from core.materials import graph
    scene = Scene(camera=ortho_camera())
    scene.add_mesh(primitives.plane(2.0))
    mesh = scene.meshes[0]
    mesh.attributes = {f"attr:a{k}": np.zeros((2, 3, 4)) for k in range(graph.MAX_ATTRIBUTES // 4 - 1)}
    scene.instances[0].vector_deformation = (mesh.vertices + 1.0, None)
    notes = []
    assert passes.with_vector_deformation(scene, notes) is scene and "no room" in notes[0]
