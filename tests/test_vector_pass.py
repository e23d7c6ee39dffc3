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


def wobbling_box(camera) -> Scene:
    """A floor and a turned box seen by `camera`, the box sliding between the frames and each of its vertices moving
    its own way (vector_motion, vector_deformation)."""
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
    return scene


def test_the_compiled_deformation_motion_follows_the_reference():
    """Both kernels map a box whose every vertex moves its own way between frames (a perspective camera, the box
    turned and sliding too) to the same pass, pixel for pixel, from the same samples."""
    camera = Camera.look_at(np.array([2.0, -3.0, 2.5]), np.zeros(3), up=(0.0, 0.0, 1.0), fov=math.radians(50))
    scene = wobbling_box(camera)
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


# Every panoramic camera Primer renders, with spans and lenses away from their defaults where they have them.
PANORAMAS = {
    "FISHEYE_EQUIDISTANT": dict(fisheye_fov=math.radians(170.0)),
    "FISHEYE_EQUISOLID": dict(fisheye_fov=math.radians(170.0), fisheye_lens=10.5),
    "EQUIRECTANGULAR": dict(longitude_min=-2.5, longitude_max=2.0, latitude_min=-1.2, latitude_max=1.0),
    "EQUIANGULAR_CUBEMAP_FACE": {},
    "MIRRORBALL": {},
    "FISHEYE_LENS_POLYNOMIAL": dict(fisheye_fov=math.radians(200.0)),
    "CENTRAL_CYLINDRICAL": dict(cylinder_u_min=-2.0, cylinder_u_max=2.5, cylinder_v_min=-0.7, cylinder_v_max=1.3,
                                cylinder_radius=1.5),
}
# A camera-to-world transform looking along +y from (1, -5, 2), turned a quarter about its view and moved.
TURNED = np.array([[1.0, 0, 0, 1], [0, 0, -1, -5], [0, 1, 0, 2], [0, 0, 0, 1]])


@pytest.mark.parametrize("kind", sorted(PANORAMAS))
def test_each_panoramas_inverse_projection_sends_its_rays_back_to_their_pixels(kind):
    """Cycles' direction_to_panorama (graph.panorama_window, with render.panorama_frame's numbers), which the Vector
    pass maps a panoramic camera's points with, inverts each panorama's ray generation: a point 3 along the ray
    through raster (x, y from the top) of a turned, shifted 64 x 48 panoramic camera (pixel aspect 1.25) maps to
    (u, v) = (x / 64 + shift_x, (48 - y) / 48 + shift_y) (Cycles' y from the bottom) within 1e-4 pixel (measured:
    6e-13 at most, the polynomial fisheye's Newton steps; the others 8e-14) for the 500 random raster points that
    have a ray (past a fisheye's circle or a mirror ball's rim none does)."""
    from core.camera import camera as camera_
    from core.materials import graph
    from core.render import panorama_frame
    camera = Camera(matrix_world=TURNED, type="PANO", panorama_type=kind, shift_x=0.05, shift_y=-0.1,
                    **PANORAMAS[kind])
    rng = np.random.default_rng(7)
    x, y = rng.uniform(0.0, 64.0, 500), rng.uniform(0.0, 48.0, 500)
    settings = RenderSettings(width=64, height=48, pixel_aspect=(1.25, 1.0))
    rays = camera_.generate_rays(camera, 64, 48, x, y, settings.pixel_aspect)
    points = rays.origins + 3.0 * rays.directions
    to_camera = camera_.world_to_camera(camera)
    seen = points @ to_camera[:, :3].T + to_camera[:, 3]          # (in the camera's space: x right, y up, z ahead)
    uv = graph.panorama_window(seen, np.array(panorama_frame(camera, settings)))
    raster = (uv[:, :2] - (camera.shift_x, camera.shift_y)) * (64.0, 48.0)
    assert rays.valid.sum() > 250
    np.testing.assert_allclose(raster[rays.valid], np.c_[x, 48.0 - y][rays.valid], atol=1e-4)


def turned_about_z(angle: float) -> np.ndarray:
    """A camera-to-world transform at (0, 0, 0.5) looking along +x (up +z), turned by `angle` about z."""
    c, s = math.cos(angle), math.sin(angle)
    out = np.eye(4)
    out[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array([[0.0, 0.0, -1.0],
                                                                                     [-1.0, 0.0, 0.0],
                                                                                     [0.0, 1.0, 0.0]])
    out[:3, 3] = (0.0, 0.0, 0.5)
    return out


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_equirectangular_camera_turning_about_its_up_axis_moves_everything_sideways_by_its_turn(kernels):
    """A full equirectangular camera 32 pixels around, inside a room, turning by a = 2 (2 pi / 32) a frame about
    its up axis (z): every point's longitude in its view changes by a a frame, u by a / (2 pi) the other way, so
    every pixel's vector is (-2, 0, -2, 0) pixels on both sides of the frame, wherever the hit lies, within 1e-9;
    but in the two columns each side where the point crosses the panorama's seam then (Cycles does not wrap it:
    a jump of 32 pixels)."""
    a = 2.0 * 2.0 * math.pi / 32.0
    camera = Camera(matrix_world=turned_about_z(0.0), type="PANO", panorama_type="EQUIRECTANGULAR")
    scene = Scene(camera=camera)
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.box((8.0, 6.0, 4.0), center=(0.5, -0.3, 1.0)), materials=[0])
    scene.vector_cameras = tuple(dataclasses.replace(camera, matrix_world=turned_about_z(t)) for t in (-a, a))
    settings = RenderSettings(width=32, height=16, samples=2, passes=("vector",), kernels=kernels)
    vector = render.render(scene, settings).aux["vector"]
    np.testing.assert_allclose(vector[:, 2:30], np.broadcast_to([-2.0, 0.0, -2.0, 0.0], (16, 28, 4)), atol=1e-9)
    np.testing.assert_allclose(vector[:, :2, 0], 30.0, atol=2.0 + 1e-9)      # (before: across the seam)
    np.testing.assert_allclose(vector[:, 30:, 2], 30.0, atol=2.0 + 1e-9)     # (after: across it the other way)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_floor_sliding_under_an_equirectangular_camera_moves_by_where_it_is_seen_then(kernels):
    """A floor (z = 0) sliding by d = (0.3, 0.2, 0) a frame under a full equirectangular camera 1.5 above it
    (looking along +x, up +z; 48 x 24 pixels): a hit at p seen from the eye e along q = p - e lies at raster
    x = (pi - atan2(q_y, q_x)) / (2 pi) 48, y = (1 - acos(q_z / |q|) / pi) 24 (Cycles' equirectangular
    mapping, y up), and was at p - d and will be at p + d: with one sample a pixel (the Position pass its hit) the
    pass is that closed form's (x(p - d) - x(p), x(p) - x(p + d)) wherever the floor is seen (the hit maps into
    its own pixel) and the point does not cross the seam behind the camera: within 2e-5 pixel (measured 1.0e-6,
    float32 images) of motions up to 23 pixels."""
    eye = np.array([0.0, 0.0, 1.5])
    camera = Camera(matrix_world=shifted(turned_about_z(0.0), (0.0, 0.0, 1.0)), type="PANO",
                    panorama_type="EQUIRECTANGULAR")
    scene, _ = floor_under(camera)
    d = np.array([0.3, 0.2, 0.0])
    floor = scene.instances[0]
    floor.vector_motion = (shifted(floor.matrix, -d), shifted(floor.matrix, d))
    settings = RenderSettings(width=48, height=24, samples=1, passes=("vector", "position"), kernels=kernels)
    aux = render.render(scene, settings).aux

    def raster(p):
        q = p - eye
        return np.stack([(math.pi - np.arctan2(q[..., 1], q[..., 0])) / (2.0 * math.pi) * 48.0,
                         (1.0 - np.arccos(q[..., 2] / np.linalg.norm(q, axis=-1)) / math.pi) * 24.0], axis=-1)

    p = aux["position"][..., :3].astype(np.float64)
    expected = np.concatenate([raster(p - d) - raster(p), raster(p) - raster(p + d)], axis=-1)
    pixel = np.stack(np.meshgrid(np.arange(48) + 0.5, 24.0 - (np.arange(24) + 0.5)), axis=-1)
    seen = np.abs(raster(p) - pixel).max(axis=-1) <= 0.5 + 1e-9             # (the floor's hit, in its own pixel)
    seen &= np.abs(expected[..., 0::2]).max(axis=-1) < 24.0                 # (not across the seam)
    assert seen.sum() > 300 and np.abs(expected[seen]).max() > 10.0
    np.testing.assert_allclose(aux["vector"][seen], expected[seen], atol=2e-5)


@pytest.mark.parametrize("kind", sorted(PANORAMAS))
def test_the_compiled_panorama_motion_follows_the_reference(kind):
    """Both kernels map a box sliding and deforming over a floor, seen by each panoramic camera that moves and turns
    between the frames (a quarter turn to the frame before), to the same pass, pixel for pixel, from the same
    samples: within 1e-5 pixel of motions of 15 to 73 pixels (measured: equal in the float32 images; past a
    fisheye's circle both write 0)."""
    look = Camera.look_at(np.array([2.0, -3.0, 2.5]), np.zeros(3), up=(0.0, 0.0, 1.0)).matrix_world
    camera = Camera(matrix_world=look, type="PANO", panorama_type=kind, **PANORAMAS[kind])
    scene = wobbling_box(camera)
    scene.vector_cameras = (dataclasses.replace(camera, matrix_world=shifted(turned(1.0, (0, 0, 0)) @ look,
                                                                             (0.1, 0.0, 0.0))),
                            dataclasses.replace(camera, matrix_world=shifted(look, (0.0, -0.2, 0.1))))
    settings = RenderSettings(width=24, height=18, samples=2, passes=("vector",))
    compiled, reference = (render.render(scene, dataclasses.replace(settings, kernels=k)) for k in ("compiled", "numpy"))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_allclose(compiled.aux["vector"], reference.aux["vector"], atol=1e-5)
    assert np.abs(reference.aux["vector"]).max() > 1.0


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_camera_that_is_panoramic_only_at_a_neighbouring_frame_projects_as_the_frames_camera_moved_there(kernels):
    """Cycles keeps the frame's projection and reads only the transforms of the camera at the neighbouring frames: an
    orthographic camera (8 pixels a unit) that is an equirectangular one at the frames before and after, standing
    0.25 further along -x and +x then, moves the still floor by (2, 0, 2, 0) pixels, as the orthographic camera moved
    there would."""
    scene, settings = floor_under(ortho_camera())
    camera = scene.camera
    scene.vector_cameras = tuple(Camera(matrix_world=shifted(camera.matrix_world, (s, 0.0, 0.0)), type="PANO",
                                        panorama_type="EQUIRECTANGULAR") for s in (-0.25, 0.25))
    vector = render.render(scene, dataclasses.replace(settings, kernels=kernels)).aux["vector"]
    np.testing.assert_allclose(vector, np.broadcast_to([2.0, 0.0, 2.0, 0.0], vector.shape), atol=1e-9)


@pytest.mark.parametrize("kernels", KERNELS)
def test_where_an_equirectangular_camera_sees_the_world_it_moves_by_the_cameras_turn_alone_from_blender_5_2(kernels):
    """Blender 5.2's Cycles writes the Vector pass where a camera ray sees the world too (camera_motion_vector_direction:
    the direction's place at infinity, RenderSettings.world_vector): a full equirectangular camera 32 pixels around
    with nothing around it, turning by a = 2 (2 pi / 32) a frame about its up axis and sliding 5 a frame (which moves
    nothing at infinity), moves every pixel by (-2, 0, -2, 0) within 1e-9 but in the two columns each side of the
    seam; Cycles before 5.2 (world_vector off) writes 0 there."""
    a = 2.0 * 2.0 * math.pi / 32.0
    camera = Camera(matrix_world=turned_about_z(0.0), type="PANO", panorama_type="EQUIRECTANGULAR")
    scene = Scene(camera=camera)
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.box((0.1, 0.1, 0.1), center=(0.0, 0.0, -1000.0)), materials=[0])   # (out of sight)
    scene.vector_cameras = tuple(dataclasses.replace(camera, matrix_world=shifted(turned_about_z(t), (5 * t, 0, 0)))
                                 for t in (-a, a))
    settings = RenderSettings(width=32, height=16, samples=2, passes=("vector",), kernels=kernels, world_vector=True)
    vector = render.render(scene, settings).aux["vector"]
    np.testing.assert_allclose(vector[:, 2:30], np.broadcast_to([-2.0, 0.0, -2.0, 0.0], (16, 28, 4)), atol=1e-9)
    np.testing.assert_allclose(vector[:, :2, 0], 30.0, atol=2.0 + 1e-9)      # (before: across the seam)
    before = render.render(scene, dataclasses.replace(settings, world_vector=False)).aux["vector"]
    assert not before.any()


@pytest.mark.parametrize("kernels", KERNELS)
def test_where_a_perspective_camera_sees_the_world_its_roll_turns_each_pixel_scaled_by_its_rays_depth(kernels):
    """Blender 5.2's Cycles maps a perspective camera's world direction through the 3 x 3 of its world-to-raster
    transform without dividing by the depth (transform_perspective_direction): a camera (90 degrees across 16 x 16
    pixels, f = 8 pixels) rolling by b = 0.1 rad a frame about its axis writes, at the pixel p from the centre (the
    ray's direction d = (p, f) / |(p, f)|, its depth f / |(p, f)|), (R(b) p - p, p - R(-b) p) f / |(p, f)| within
    1e-9 (R(b) p: where that direction stood a frame earlier), and the still part is the same at every frame."""
    b = 0.1
    camera = Camera.look_at(np.array([0.0, 0.0, 3.0]), np.array([0.0, 0.0, 10.0]), up=(0.0, 1.0, 0.0),
                            fov=math.radians(90))

    def rolled(angle):
        c, s = math.cos(angle), math.sin(angle)
        out = np.array(camera.matrix_world, np.float64)
        out[:3, :3] = out[:3, :3] @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return out

    scene = Scene(camera=camera)
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.box((0.1, 0.1, 0.1), center=(0.0, 0.0, -1000.0)), materials=[0])   # (behind it)
    scene.vector_cameras = tuple(dataclasses.replace(camera, matrix_world=rolled(t)) for t in (-b, b))
    settings = RenderSettings(width=16, height=16, samples=1, passes=("vector",), kernels=kernels, world_vector=True,
                              jitter=False)
    vector = render.render(scene, settings).aux["vector"]
    f = 8.0
    x, y = np.meshgrid(np.arange(16) + 0.5 - 8.0, 8.0 - (np.arange(16) + 0.5))     # (raster y up, row 0 on top)
    depth = f / np.sqrt(x * x + y * y + f * f)

    def turn(angle):
        c, s = math.cos(angle), math.sin(angle)
        return np.stack([c * x - s * y, s * x + c * y], axis=-1)

    p = np.stack([x, y], axis=-1)
    expected = np.concatenate([turn(b) - p, p - turn(-b)], axis=-1) * depth[..., None]
    assert np.abs(expected).max() > 0.5
    np.testing.assert_allclose(vector, expected, atol=1e-9)
