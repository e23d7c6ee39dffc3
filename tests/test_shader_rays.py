"""The Ambient Occlusion and Bevel nodes (core/integrators/shader_rays.py and .c): rays traced while a shader runs.

Closed forms on both kernels: a floor's ambient occlusion is the cosine-weighted share of directions whose ray leaves
the Distance unblocked. Cosine-distributed directions project to points spread evenly over the unit disk, so the share
is an area of the disk: under a ceiling at height h a ray is blocked within d where cos(theta) > h / d, a disk of
radius sqrt(1 - (h/d)^2), leaving (h/d)^2 open; beside a wall at distance x it is blocked where it heads for the wall
faster than x / d, a segment of the disk, leaving 1 - (acos(c) - c sqrt(1 - c^2)) / pi open, c = x / d. A plane seen
from above renders the node's output as its Emission, a pixel for a point.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ortho_down, pixel_points_on_plane
from core import render
from core.geometry import primitives
from core.lights import PointLight
from core.materials import Material, MaterialTable
from core.materials.graph import GraphNode, Link
from core.scene import RenderSettings, Scene

KERNELS = ["compiled", "numpy"]


def ao(samples: int = 16, distance: float = 1.0, **props) -> Link:
    """An Ambient Occlusion node's AO output."""
    return Link(GraphNode("AO", {"samples": samples, **props}, {"Distance": distance}), "AO")


def bevel(radius: float, samples: int = 8) -> Link:
    """A Bevel node's Normal output."""
    return Link(GraphNode("BEVEL", {"samples": samples}, {"Radius": radius}), "Normal")


def floor_scene(link: Link, flipped: bool = False) -> Scene:
    """A 12 x 12 floor at z = 0 (its back up where `flipped`) emitting `link`, seen from 10 above (a 2 x 2 view)."""
    scene = Scene(camera=ortho_down(height=10.0, scale=2.0))
    scene.materials.append(Material(name="Shown", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
    scene.materials.append(Material(name="Dark", nodes=[("EMISSION", (0.0, 0.0, 0.0), {})]))
    floor = primitives.plane(12.0)
    if flipped:
        floor.triangles = floor.triangles[:, ::-1].copy()
    scene.add_mesh(floor, materials=np.array([0]), name="Floor")
    return scene


def add_hidden(scene: Scene, mesh, name: str) -> None:
    """Add `mesh` as an object the camera does not see (it still blocks the shader's rays)."""
    mesh.triangles = mesh.triangles.copy()
    scene.add_mesh(mesh, materials=np.array([1]), name=name)
    scene.instances[-1].visible_camera = False


def shoot(scene: Scene, kernels: str, size: int = 8, samples: int = 16) -> np.ndarray:
    """The rendered image (size, size, 3)."""
    result = render.render(scene, RenderSettings(width=size, height=size, samples=samples, kernels=kernels))
    assert result.stats.kernels.startswith(kernels)
    return result.image[..., :3]


@pytest.mark.parametrize("kernels", KERNELS)
def test_ambient_occlusion_of_an_open_plane_is_one(kernels):
    image = shoot(floor_scene(ao(distance=5.0)), kernels, size=4, samples=2)
    np.testing.assert_array_equal(image, 1.0)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("h, d", [(1.0, 3.0), (0.5, 0.8)])
def test_ambient_occlusion_under_a_ceiling_is_the_squared_height_over_distance(kernels, h, d):
    scene = floor_scene(ao(distance=d))
    ceiling = primitives.plane(100.0, center=(0.0, 0.0, h))
    ceiling.triangles = ceiling.triangles[:, ::-1]
    add_hidden(scene, ceiling, "Ceiling")
    image = shoot(scene, kernels)
    assert abs(image.mean() - (h / d) ** 2) < 0.01                   # 64 pixels x 16 samples x 16 rays
    assert np.abs(image - (h / d) ** 2).max() < 0.08


@pytest.mark.parametrize("kernels", KERNELS)
def test_ambient_occlusion_beside_a_wall_is_the_disk_outside_its_segment(kernels):
    # A wall y = -1 facing +y, across the whole floor; the view spans y in (-1, 1), 0 to 2 from the wall, d = 2.
    d = 2.0
    scene = floor_scene(ao(distance=d))
    wall = primitives.plane(100.0)
    wall.vertices = wall.vertices[:, [0, 2, 1]] * np.array([1.0, 1.0, 1.0]) + np.array([0.0, -1.0, 0.0])
    wall.triangles = wall.triangles[:, ::-1]                          # (the swap of y and z turned it to face -y)
    add_hidden(scene, wall, "Wall")
    image = shoot(scene, kernels)[..., 0]
    points = pixel_points_on_plane(scene.camera, 8, 8, 0.0)
    c = np.clip((points[..., 1] + 1.0) / d, 0.0, 1.0)
    expected = 1.0 - (np.arccos(c) - c * np.sqrt(1.0 - c * c)) / math.pi
    assert np.abs(image.mean(axis=1) - expected.mean(axis=1)).max() < 0.02      # each row: 8 points at one x
    assert np.abs(image - expected).max() < 0.08
    assert expected.min() < 0.6 and expected.max() > 0.9              # (the view spans the near and the open floor)


@pytest.mark.parametrize("kernels", KERNELS)
def test_only_local_ambient_occlusion_sees_no_other_object_and_inside_a_closed_box_is_dark(kernels):
    scene = floor_scene(ao(distance=3.0, only_local=True))
    add_hidden(scene, primitives.plane(100.0, center=(0.0, 0.0, 1.0)), "Ceiling")
    np.testing.assert_array_equal(shoot(scene, kernels, size=4, samples=2), 1.0)
    # The top of a closed box, its rays turned inwards (Inside) and long enough to reach every other face.
    box = Scene(camera=ortho_down(height=10.0, scale=1.0))
    box.materials.append(Material(name="Shown", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                        {"emission": ao(distance=10.0, inside=True)})]))
    box.add_mesh(primitives.box((2.0, 2.0, 2.0)), materials=np.array([0]))
    np.testing.assert_array_equal(shoot(box, kernels, size=4, samples=2), 0.0)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("flipped", [False, True])
def test_bevel_of_a_flat_plane_is_its_normal_exactly(kernels, flipped):
    # The normal facing the viewer, (0, 0, 1), from either side: every probe meets the plane and adds its normal.
    image = shoot(floor_scene(bevel(0.3), flipped), kernels, size=4, samples=4)
    np.testing.assert_array_equal(image, np.broadcast_to([0.0, 0.0, 1.0], image.shape))


@pytest.mark.parametrize("kernels", KERNELS)
def test_bevel_at_a_box_edge_leans_towards_the_other_face_and_stays_flat_beyond_the_radius(kernels):
    # A box whose top is the view's left half (x < 0), seen from above; its +x side face is x = 0. Near the edge the
    # bevelled normal leans towards +x (the side face's normal); farther than the radius it is the top's, (0, 0, 1).
    scene = Scene(camera=ortho_down(height=10.0, scale=2.0))
    scene.materials.append(Material(name="Shown", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": bevel(0.2, 16)})]))
    scene.add_mesh(primitives.box((4.0, 4.0, 4.0), center=(-2.0, 0.0, -2.0)), materials=np.array([0]))
    image = shoot(scene, kernels, samples=4)
    x = pixel_points_on_plane(scene.camera, 8, 8, 0.0)[..., 0]
    near, far = (x < 0.0) & (x > -0.1), x < -0.3
    assert (image[near][:, 0] > 0.05).all() and (image[near][:, 2] > 0.5).all()
    np.testing.assert_array_equal(image[far], np.broadcast_to([0.0, 0.0, 1.0], image[far].shape))
    np.testing.assert_array_equal(image[x < 0.0][:, 1], 0.0)          # (only the top and the +x side are near)


def test_both_kernels_trace_the_same_rays():
    # Ambient occlusion (plain, Only Local, Inside) times a bevelled normal's z on a box on a floor, with a path
    # tracer's bounces: the compiled kernel's image is the reference's.
    product = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {
        "0": ao(samples=4, distance=1.5),
        "1": Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": bevel(0.3, 4)}), "Z")}), "Value")
    for extra in ({}, {"only_local": True}, {"inside": True}):
        scene = Scene(camera=ortho_down(height=10.0, scale=4.0))
        link = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": product, "1": ao(4, 1.0, **extra)}), "Value")
        scene.materials.append(Material(name="Shown", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"color": (0.8, 0.8, 0.8)}),
                                                             ("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
        scene.add_mesh(primitives.plane(12.0), materials=np.array([0]))
        scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(0.3, 0.2, 0.5)), materials=np.array([0]))
        settings = RenderSettings(width=12, height=12, samples=4, integrator="path", max_bounces=2)
        compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
        reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
        assert compiled.stats.kernels == "compiled"
        np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-5, atol=1e-6)
        assert reference.image[..., 0].std() > 0.01


def test_a_bevelled_box_seen_in_a_mirror_is_bevelled_and_after_a_diffuse_bounce_is_not():
    # A lit white box whose Diffuse normal is its Bevel, over a floor that is a perfect mirror or a white diffuse
    # floor, the box hidden from the camera: the mirror's bounce has an infinite pdf, so the reflected box shows its
    # bevelled edges (unlike the sharp box); a diffuse bounce's pdf is below 8, so the light the diffuse floor gathers
    # from the box is the sharp box's, to the bit (Cycles' min_ray_pdf rule). Both kernels alike.
    images = {}
    for floor in ("MIRROR", "DIFFUSE"):
        for normal in ({"normal": bevel(0.3, 8)}, {}):
            scene = Scene(camera=ortho_down(height=10.0, scale=4.0))
            scene.materials.append(Material(name="Box", nodes=[("DIFFUSE", (1.0, 1.0, 1.0),
                                                                {"color": (1.0, 1.0, 1.0), **normal})]))
            scene.materials.append(Material(name="Floor", nodes=[(floor, (1.0, 1.0, 1.0), {"color": (1.0, 1.0, 1.0)}
                                                                 if floor == "DIFFUSE" else {})]))
            scene.add_mesh(primitives.plane(40.0), materials=np.array([1]))
            scene.add_mesh(primitives.box((2.0, 2.0, 0.2), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
            scene.instances[-1].visible_camera = False
            scene.lights = [PointLight(np.array([1.5, 0.4, 0.4]), power=100.0)]
            settings = RenderSettings(width=8, height=8, samples=4, integrator="path", max_bounces=1)
            compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
            reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
            np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-5, atol=1e-6)
            images[floor, bool(normal)] = reference.image[..., :3]
    assert np.abs(images["MIRROR", True] - images["MIRROR", False]).max() > 0.01
    np.testing.assert_array_equal(images["DIFFUSE", True], images["DIFFUSE", False])
    assert images["DIFFUSE", True].max() > 0.0


@pytest.mark.parametrize("kernels", KERNELS)
def test_ambient_occlusion_seen_in_a_mirror_is_the_emitters_own(kernels):
    # A plane at height 1 facing down onto a mirror floor, emitting its ambient occlusion (Distance 3), hidden from the
    # camera above: the camera sees it only in the mirror, where the BSDF ray's find is shaded as the surface it hits
    # (as Cycles shades the next vertex): the floor 1 below blocks all but (1/3)^2 of its rays.
    scene = Scene(camera=ortho_down(height=10.0, scale=2.0))
    scene.materials.append(Material(name="Glow", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                         {"emission": ao(samples=16, distance=3.0)})]))
    scene.materials.append(Material(name="Mirror", nodes=[("MIRROR", (1.0, 1.0, 1.0), {})]))
    scene.add_mesh(primitives.plane(100.0), materials=np.array([1]))
    glow = primitives.plane(100.0, center=(0.0, 0.0, 1.0))
    glow.triangles = glow.triangles[:, ::-1].copy()
    scene.add_mesh(glow, materials=np.array([0]))
    scene.instances[-1].visible_camera = False
    result = render.render(scene, RenderSettings(width=8, height=8, samples=16, kernels=kernels, integrator="path",
                                                 max_bounces=1))
    assert result.stats.kernels.startswith(kernels)
    assert abs(result.image[..., 0].mean() - 1.0 / 9.0) < 0.01


def test_materials_without_such_nodes_trace_nothing():
    plain = Material(name="Plain", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": Link(GraphNode(
        "GEOMETRY", {}, {}), "Normal")})])
    assert not MaterialTable.of([plain]).traces
    assert MaterialTable.of([plain, floor_scene(ao()).materials[0]]).traces
