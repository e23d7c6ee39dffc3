"""The media a camera ray starts in (issue 35), as Cycles 5.0's integrator_volume_stack_init finds them
(src/kernel/integrator/intersect_volume_stack.h): each path walks from its camera ray's origin, on the near clip
plane, straight up (world +z, whatever way the camera looks) through the objects camera rays see, marks an object
entered at a front face, and stacks, nearest first, the medium of the first back face of each object it has not
entered on the way. Both kernels (core/integrators/rays.py _walk, core/volumes/media.c camera_media) held to
Beer-Lambert's exp(-sigma_t d) through the known media over a glowing floor: a camera inside nested media, inside one
object's overlapping shells (where the walk up enters a shell first, Cycles starts the ray outside the object's
medium), inside one object of two volume materials (its first back face's medium alone), inside an object hidden
from camera rays (no medium), and an orthographic camera whose rays start half in a medium."""
from __future__ import annotations

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.integrators.rays import camera_media
from core.materials import Material
from core.render import prepare
from core.scene import RenderSettings, Scene
from core.scene.scene import Mesh

from test_volumes_per_object import COLOR, GLOW, absorbing, halves, rendered, shared


def looking_down(origin: float, clip_start: float = 0.01) -> Camera:
    """An orthographic camera looking straight down at x, y in [-1, 1], its rays starting at z = `origin` (its near
    clip plane, clip_start below it)."""
    matrix = np.eye(4)
    matrix[2, 3] = origin + clip_start
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=clip_start, clip_end=20.0)


def tau(*stretches) -> np.ndarray:
    """The optical depth (3,) of the stretches (density, depth) of media of colour COLOR (sigma_t = density (1 -
    COLOR))."""
    return sum(density * depth for density, depth in stretches) * (1.0 - COLOR)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_inside_nested_media_starts_in_both_and_leaves_the_inner_at_its_bottom(kernels):
    """Rays from z = 2 inside an inner box (density 3, z 1 .. 2.5) inside an outer one (density 1, z 0.5 .. 3), two
    objects of one material read per object: the walk up meets the inner box's top, then the outer's, both back
    faces: in both, exp(-(3 + 1) 1 - 1 x 0.5) down to the floor."""
    scene = absorbing([((4.0, 4.0, 2.5), (0.0, 0.0, 1.75))], looking_down(2.0))
    scene.materials.append(shared(3.0))
    scene.add_mesh(primitives.box((3.9, 3.9, 1.5), center=(0.0, 0.0, 1.75)), materials=np.array([2]), name="Inner")
    image, _ = rendered(scene, kernels)
    expected = GLOW * np.exp(-tau((4.0, 1.0), (1.0, 0.5)))
    np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), rtol=1e-5)


def test_the_walk_stacks_the_media_nearest_first_going_up():
    """The stack of a ray from inside two nested boxes of two materials lists them in the order the walk up meets
    their back faces (the inner first: Cycles' stack init adds them so), whatever way the ray would look."""
    scene = absorbing([((4.0, 4.0, 2.5), (0.0, 0.0, 1.75))], looking_down(2.0))
    scene.materials.append(shared(3.0))
    scene.add_mesh(primitives.box((3.9, 3.9, 1.5), center=(0.0, 0.0, 1.75)), materials=np.array([2]), name="Inner")
    ctx = prepare(scene, RenderSettings(width=4, height=4))
    media = ctx.extra["media"]
    origin = np.array([[0.0, 0.0, 2.0]]) - np.asarray(scene.camera.matrix_world)[:3, 3]     # (camera-relative)
    stack = camera_media(ctx, origin)[0]
    outer, inner = media.column_of(np.array([1, 2]))
    assert stack[inner] == 1 and stack[outer] == 2, stack


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_in_one_objects_shell_whose_overlapping_shell_the_walk_up_enters_first_starts_outside_it(kernels):
    """One object of two overlapping shells, z 0.5 .. 1.5 and 1.3 .. 2.3, rays from z = 1.2 in the lower alone:
    walking up, Cycles meets the upper shell's front face first, marks the object entered and so takes none of its
    back faces: the rays start outside its medium, and going down leave nothing at the lower shell's bottom: the
    floor's light whole (a walk down the view would have started them in it: exp(-0.7 sigma_t))."""
    scene = absorbing([((4.0, 4.0, 1.0), (0.0, 0.0, 1.0)), ((4.0, 4.0, 1.0), (0.0, 0.0, 1.8))], looking_down(1.2))
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, np.broadcast_to(GLOW, image.shape), rtol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_inside_one_object_of_two_nested_volume_materials_starts_in_its_first_back_faces_medium(kernels):
    """One object whose outer shell (z 0.5 .. 3) holds density 1 and inner shell (z 1 .. 2.5) density 3, rays from
    z = 2: the walk up meets the inner shell's back face, then the outer's of the same object, which Cycles' stack
    init adds once (by object): the rays start in the inner medium alone, exp(-3 x 1) down to the floor (the outer
    shell's bottom takes off nothing)."""
    outer, inner = primitives.box((4.0, 4.0, 2.5), center=(0.0, 0.0, 1.75)), primitives.box(
        (3.9, 3.9, 1.5), center=(0.0, 0.0, 1.75))
    mesh = Mesh(np.concatenate([outer.vertices, inner.vertices]),
                np.concatenate([outer.triangles, inner.triangles + len(outer.vertices)]),
                material_indices=np.repeat([0, 1], [len(outer.triangles), len(inner.triangles)]), name="Shells")
    scene = Scene(camera=looking_down(2.0))
    scene.materials.append(Material(np.zeros(3), "Glow", emission=GLOW))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials += [shared(1.0), shared(3.0)]
    scene.add_mesh(mesh, materials=np.array([1, 2]), name="Shells")
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, np.broadcast_to(GLOW * np.exp(-tau((3.0, 1.0))), image.shape), rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_inside_a_medium_hidden_from_camera_rays_starts_outside_it(kernels):
    """An absorbing box around the camera (z 0.5 .. 3) whose object camera rays do not see (Ray Visibility >
    Camera off): Cycles' walk meets only what camera rays see, and the camera rays pass its faces: the floor's light
    whole (Primer's walk used to count it: exp(-1.5 sigma_t) for the whole way)."""
    scene = absorbing([((4.0, 4.0, 2.5), (0.0, 0.0, 1.75))], looking_down(2.0))
    scene.instances[-1].visible_camera = False
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, np.broadcast_to(GLOW, image.shape), rtol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_an_orthographic_camera_whose_rays_start_half_in_a_medium_walks_each_ray(kernels):
    """An absorbing box (density 1) over x < 0 (x -3 .. 0, z 0.5 .. 3) and rays from z = 2 over x in [-1, 1]: each
    ray walks from its own origin, the left half in the box (exp(-1.5 sigma_t) to the floor), the right half not
    (the floor's light whole)."""
    scene = absorbing([((3.0, 4.0, 2.5), (-1.5, 0.0, 1.75))], looking_down(2.0))
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, halves(GLOW * np.exp(-tau((1.0, 1.5))), GLOW), rtol=1e-5)
