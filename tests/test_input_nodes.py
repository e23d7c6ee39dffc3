"""Cycles' input nodes in the node-graph compiler (core/materials/graph.py, graph.c): Fresnel, Layer Weight, Geometry
(and Pointiness, core/geometry/pointiness.py), Texture Coordinate, Camera Data, Wireframe and Light Path's Ray Length,
each checked against a closed form on both kernels (the compiled C and the numpy reference), and the two kernels
against each other.

The scenes look straight down (an orthographic camera, so every ray has the same direction) at a large plane tilted
by an angle theta about x, its front towards the camera or, flipped, its back; the plane's Emission shows the node's
output, so a pixel is the output's value.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.geometry import pointiness, primitives
from core.materials import Material, graph
from core.materials.graph import GraphNode, Link
from core.camera import Camera
from core.scene import RenderSettings, Scene, SunLight

KERNELS = ["compiled", "numpy"]
SIZE = 4


def fresnel_closed_form(cos_i: float, eta: float) -> float:
    """The unpolarized reflectance of light meeting a dielectric of relative index eta at cos_i, from Snell's law
    and the s and p amplitudes written out; 1 under total internal reflection."""
    sin_t = math.sqrt(max(0.0, 1.0 - cos_i * cos_i)) / eta
    if sin_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin_t * sin_t)
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (r_s * r_s + r_p * r_p)


def tilted_scene(link: Link, degrees: float = 0.0, flipped: bool = False) -> Scene:
    """A 12 x 12 plane through the origin tilted `degrees` about x (its back to the camera where `flipped`),
    emitting the value of `link`, under an orthographic camera looking down -z."""
    scene = Scene(camera=ortho_down(height=10.0, scale=2.0))
    scene.materials.append(Material(name="Input", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
    mesh = primitives.plane(12.0)
    a = math.radians(degrees)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])
    mesh.vertices = mesh.vertices @ turn.T
    if flipped:
        mesh.triangles = mesh.triangles[:, ::-1].copy()
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    mesh.attributes = {"generated": ((mesh.vertices - lo) / np.where(hi > lo, hi - lo, 1.0))[mesh.triangles]}
    scene.add_mesh(mesh, materials=np.array([0]))
    return scene


def shoot(scene: Scene, kernels: str) -> np.ndarray:
    """The rendered red channel (SIZE, SIZE), two samples per pixel."""
    result = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=2, kernels=kernels))
    assert result.stats.kernels.startswith(kernels)
    return result.image[..., 0]


def fresnel(ior, normal=None) -> Link:
    """A Fresnel node's Fac."""
    return Link(GraphNode("FRESNEL", {}, {"IOR": ior, **({} if normal is None else {"Normal": normal})}), "Fac")


def layer_weight(blend, output: str) -> Link:
    """A Layer Weight node's Fresnel or Facing."""
    return Link(GraphNode("LAYER_WEIGHT", {}, {"Blend": blend}), output)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("ior", [1.5, 2.4])
def test_fresnel_at_normal_incidence_is_the_squared_index_ratio(kernels, ior):
    image = shoot(tilted_scene(fresnel(ior)), kernels)
    np.testing.assert_allclose(image, ((ior - 1.0) / (ior + 1.0)) ** 2, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("degrees", [30.0, 60.0, 80.0])
def test_fresnel_follows_the_dielectric_reflectance_with_the_angle_of_view(kernels, degrees):
    image = shoot(tilted_scene(fresnel(1.5), degrees), kernels)
    np.testing.assert_allclose(image, fresnel_closed_form(math.cos(math.radians(degrees)), 1.5), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_fresnel_seen_from_behind_is_light_leaving_the_object_and_reflects_totally_past_the_critical_angle(kernels):
    # From behind, light goes from glass to air: relative index 1 / 1.5, critical angle asin(1 / 1.5) = 41.8 deg.
    below = shoot(tilted_scene(fresnel(1.5), 30.0, flipped=True), kernels)
    np.testing.assert_allclose(below, fresnel_closed_form(math.cos(math.radians(30.0)), 1.0 / 1.5), rtol=1e-6)
    past = shoot(tilted_scene(fresnel(1.5), 60.0, flipped=True), kernels)
    np.testing.assert_allclose(past, 1.0, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_fresnel_with_a_linked_normal_uses_that_normal_for_the_angle(kernels):
    # A normal straight up, towards the camera, on a plane tilted 60 degrees: normal incidence.
    up = Link(GraphNode("COMBINE_XYZ", {}, {"X": 0.0, "Y": 0.0, "Z": 1.0}), "Vector")
    image = shoot(tilted_scene(fresnel(1.5, up), 60.0), kernels)
    np.testing.assert_allclose(image, 0.04, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("degrees", [0.0, 60.0, 75.0])
def test_layer_weight_facing_with_blend_one_half_is_one_minus_the_view_cosine(kernels, degrees):
    image = shoot(tilted_scene(layer_weight(0.5, "Facing"), degrees), kernels)
    np.testing.assert_allclose(image, 1.0 - math.cos(math.radians(degrees)), atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("blend, power", [(0.25, 0.5), (0.8, 2.5), (0.0, 0.0)])
def test_layer_weight_facing_raises_the_view_cosine_to_a_power_set_by_the_blend(kernels, blend, power):
    # Blend below 1/2: power 2 Blend; above: 1 / (2 (1 - Blend)).
    image = shoot(tilted_scene(layer_weight(blend, "Facing"), 60.0), kernels)
    np.testing.assert_allclose(image, 1.0 - 0.5 ** power, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_layer_weight_fresnel_is_the_reflectance_of_index_one_over_one_minus_blend_inverted_from_behind(kernels):
    front = shoot(tilted_scene(layer_weight(0.3, "Fresnel"), 50.0), kernels)
    np.testing.assert_allclose(front, fresnel_closed_form(math.cos(math.radians(50.0)), 1.0 / 0.7), rtol=1e-6)
    back = shoot(tilted_scene(layer_weight(0.3, "Fresnel"), 20.0, flipped=True), kernels)
    np.testing.assert_allclose(back, fresnel_closed_form(math.cos(math.radians(20.0)), 0.7), rtol=1e-6)


def test_the_compiled_input_nodes_compute_what_the_reference_computes():
    # Indices, blends and linked normals varying across the plane (Generated x), every Geometry, Texture Coordinate
    # and Camera Data output, Wireframe, seen from both sides.
    uv = GraphNode("TEXCOORD", {}, {})
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "Generated")}), "X")
    tilted = Link(GraphNode("COMBINE_XYZ", {}, {"X": 0.2, "Y": 0.3, "Z": x}), "Vector")
    index = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": x, "1": 2.0, "2": 0.5}), "Value")
    links = [fresnel(index), fresnel(1.33, tilted), layer_weight(x, "Fresnel"), layer_weight(x, "Facing"),
             Link(GraphNode("LAYER_WEIGHT", {}, {"Blend": 0.7, "Normal": tilted}), "Facing")]
    links += [Link(GraphNode("GEOMETRY", {}, {}), output) for output in graph.NODE_OUTPUTS["GEOMETRY"]]
    turned = np.array([[0.0, -1.0, 0.0, 0.5], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 2.0, -1.0], [0.0, 0.0, 0.0, 1.0]])
    links += [Link(GraphNode("TEXCOORD", {}, {}), output) for output in ("Normal", "Camera", "Window", "Reflection")]
    links += [Link(GraphNode("TEXCOORD", {"object_matrix": turned}, {}), "Object")]
    links += [Link(GraphNode("CAMERA_DATA", {}, {}), output) for output in graph.NODE_OUTPUTS["CAMERA_DATA"]]
    links += [Link(GraphNode("WIREFRAME", {}, {"Size": index}), "Fac"),
              Link(GraphNode("LIGHT_PATH", {}, {}), "Ray Length")]
    for output in ("Position", "Parametric"):           # read at the bump's offset points too
        height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": component(geometry(output), "Y")}), "Value")
        links.append(Link(GraphNode("BUMP", {}, {"Height": height, "Distance": 3.0}), "Normal"))
    spread = []
    for link in links:
        for flipped in (False, True):
            scene = tilted_scene(link, 35.0, flipped)
            scene.camera = ortho_down(height=10.0, scale=10.0)
            settings = RenderSettings(width=16, height=16, samples=2)
            compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
            reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
            assert compiled.stats.kernels == "compiled"
            np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
            assert np.isfinite(reference.image).all()
            spread.append(reference.image[..., :3].std())
    assert min(spread[:5]) > 1e-3 and min(spread[-2:]) > 1e-3      # (some Geometry outputs are one value here)
    for link in links[-2:]:         # the bumps lighting a Diffuse, their steps the paths' ray cones after bounces too
        scene = tilted_scene(link, 35.0)
        scene.materials[0] = Material(name="Bumped", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"normal": link}),
                                                            ("EMISSION", (0.5, 0.5, 0.5), {})])
        scene.add_mesh(primitives.plane(12.0), materials=np.array([0]))
        scene.meshes[-1].vertices = scene.meshes[-1].vertices[:, [0, 2, 1]] + [0.0, 2.0, 0.0]
        scene.lights.append(SunLight(np.array([0.3, 0.2, -1.0]), strength=2.0))
        settings = RenderSettings(width=16, height=16, samples=2, integrator="path", max_bounces=2)
        compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
        reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
        assert compiled.stats.kernels == "compiled" and reference.image[..., :3].std() > 1e-3
        np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-5, atol=1e-6)


def geometry(output: str) -> Link:
    """A Geometry node's output."""
    return Link(GraphNode("GEOMETRY", {}, {}), output)


def component(link: Link, axis: str) -> Link:
    """One component (X, Y or Z) of a vector."""
    return Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": link}), axis)


@pytest.mark.parametrize("kernels", KERNELS)
def test_geometry_position_is_the_world_point_where_each_pixel_centre_ray_meets_the_plane(kernels):
    # A plane at z = 0.7 under a camera 10 above (3, 2, 0): Position is world space, not camera-relative.
    scene = tilted_scene(component(geometry("Position"), "Z"))
    scene.meshes[0].vertices = scene.meshes[0].vertices + [3.0, 2.0, 0.7]
    scene.camera = ortho_down(center=(3.0, 2.0, 0.0), height=10.0, scale=2.0)
    np.testing.assert_allclose(shoot(scene, kernels), 0.7, rtol=1e-6)
    scene.materials[0] = Material(name="X", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                    {"emission": component(geometry("Position"), "X")})])
    # Unjittered (the reference), each pixel's ray goes through its centre: x = 2 + (column + 0.5) / 2.
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels="numpy",
                                                jitter=False)).image[..., 0]
    np.testing.assert_allclose(image, np.tile(2.0 + (np.arange(SIZE) + 0.5) * 2.0 / SIZE, (SIZE, 1)), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("output", ["Normal", "True Normal"])
def test_geometry_normals_of_a_tilted_plane_are_its_turned_up_axis(kernels, output):
    for axis, expected in (("Z", math.cos(math.radians(40.0))), ("X", 0.0)):
        image = shoot(tilted_scene(component(geometry(output), axis), 40.0), kernels)
        np.testing.assert_allclose(image, expected, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_geometry_normals_seen_from_behind_turn_towards_the_viewer_and_backfacing_is_one(kernels):
    flipped = shoot(tilted_scene(component(geometry("Normal"), "Z"), 40.0, flipped=True), kernels)
    np.testing.assert_allclose(flipped, math.cos(math.radians(40.0)), rtol=1e-6)
    np.testing.assert_allclose(shoot(tilted_scene(geometry("Backfacing"), 40.0, flipped=True), kernels), 1.0)
    np.testing.assert_allclose(shoot(tilted_scene(geometry("Backfacing"), 40.0), kernels), 0.0)


@pytest.mark.parametrize("kernels", KERNELS)
def test_geometry_incoming_points_back_along_the_camera_rays(kernels):
    np.testing.assert_allclose(shoot(tilted_scene(component(geometry("Incoming"), "Z"), 40.0), kernels), 1.0,
                               rtol=1e-6)


def test_geometry_parametric_is_the_barycentric_weights_of_the_first_two_corners():
    # The 12 x 12 plane's triangles (V0, V1, V2) = ((-6, -6), (6, -6), (6, 6)) below its diagonal and
    # ((-6, -6), (6, 6), (-6, 6)) above: a point's weight of V1 is u = (x - y) / 12 below, (x + 6) / 12 above, and of
    # V0 1 - u - v. Unjittered (the reference) rays through pixel centres, the camera moved off the diagonal.
    scene = tilted_scene(component(geometry("Parametric"), "Y"))
    scene.camera = ortho_down(center=(0.1, 0.0, 0.0), height=10.0, scale=2.0)
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels="numpy",
                                                jitter=False)).image[..., 0]
    x, y = np.meshgrid(0.1 - 1.0 + (np.arange(SIZE) + 0.5) * 2.0 / SIZE, 1.0 - (np.arange(SIZE) + 0.5) * 2.0 / SIZE)
    # (float32 barycentrics: an ulp of values up to 1 is 6e-8, which small weights cannot hold to 1e-6 relative)
    np.testing.assert_allclose(image, np.where(y < x, (x - y) / 12.0, (x + 6.0) / 12.0), rtol=1e-6, atol=1.2e-7)
    scene.materials[0] = Material(name="Z", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                    {"emission": component(geometry("Parametric"), "Z")})])
    np.testing.assert_allclose(shoot(scene, "compiled"), 0.0)


def test_pointiness_is_one_half_on_a_flat_grid_and_the_corner_angle_on_a_cube():
    # A 3 x 3 grid of vertices: every edge lies in the plane, at right angles to the normal.
    grid = np.array([[x, y, 0.0] for y in range(3) for x in range(3)], np.float64)
    edges = [(i, i + 1) for i in range(9) if i % 3 < 2] + [(i, i + 3) for i in range(6)]
    np.testing.assert_allclose(pointiness.pointiness(grid, np.tile([0.0, 0.0, 1.0], (9, 1)), edges), 0.5)
    # A cube's corner: normal (1, 1, 1) / sqrt 3, edges (-1, 0, 0), (0, -1, 0), (0, 0, -1): acos(-1 / sqrt 3) / pi at
    # every corner, so the blur keeps it; each corner given twice (split faces) is welded into one.
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float64)
    cube_edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.abs(corners[i] - corners[j]).sum() == 1]
    doubled = np.concatenate([corners, corners])
    normals = (doubled - 0.5) / np.linalg.norm(doubled - 0.5, axis=1)[:, None]
    split = [(i + 8 * (k % 2), j + 8 * (k % 2)) for k, (i, j) in enumerate(cube_edges)]
    np.testing.assert_allclose(pointiness.pointiness(doubled, normals, split),
                               math.acos(-1.0 / math.sqrt(3.0)) / math.pi)


@pytest.mark.parametrize("kernels", KERNELS)
def test_geometry_pointiness_reads_the_meshs_per_vertex_curvature(kernels):
    scene = tilted_scene(geometry("Pointiness"))
    mesh = scene.meshes[0]
    edges = [(0, 1), (1, 2), (2, 3), (3, 0)]            # the quad's own edges (the diagonal is none)
    values = pointiness.pointiness(mesh.vertices, np.tile([0.0, 0.0, 1.0], (4, 1)), edges)
    mesh.attributes["pointiness"] = values[mesh.triangles][..., None]
    np.testing.assert_allclose(shoot(scene, kernels), 0.5, rtol=1e-6)


def texcoord(output: str, props=None) -> Link:
    """A Texture Coordinate node's output."""
    return Link(GraphNode("TEXCOORD", props or {}, {}), output)


@pytest.mark.parametrize("kernels", KERNELS)
def test_camera_data_z_depth_and_distance_of_a_plane_at_a_known_distance(kernels):
    # The camera 10 above a plane at z = 0 looks straight down: every point is 10 deep along the view, and
    # (orthographic) sqrt(10^2 + x^2 + y^2) away from the camera's own point, its view vector z = 10 / that distance.
    depth = shoot(tilted_scene(Link(GraphNode("CAMERA_DATA", {}, {}), "View Z Depth")), kernels)
    np.testing.assert_allclose(depth, 10.0, rtol=1e-6)
    scene = tilted_scene(Link(GraphNode("CAMERA_DATA", {}, {}), "View Distance"))
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels="numpy",
                                                jitter=False)).image[..., 0]
    x, y = np.meshgrid(-1.0 + (np.arange(SIZE) + 0.5) * 2.0 / SIZE, 1.0 - (np.arange(SIZE) + 0.5) * 2.0 / SIZE)
    np.testing.assert_allclose(image, np.sqrt(100.0 + x * x + y * y), rtol=1e-6)
    vector = shoot(tilted_scene(component(Link(GraphNode("CAMERA_DATA", {}, {}), "View Vector"), "Z")), kernels)
    assert ((vector > 10.0 / math.sqrt(102.0)) & (vector <= 1.0)).all()


@pytest.mark.parametrize("kernels", KERNELS)
def test_texture_coordinate_camera_is_the_point_in_the_cameras_frame_z_along_the_view(kernels):
    np.testing.assert_allclose(shoot(tilted_scene(component(texcoord("Camera"), "Z")), kernels), 10.0, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_texture_coordinate_reflection_mirrors_the_view_about_the_normal(kernels):
    # Looking straight down at a plane tilted 30 degrees about x: the view (0, 0, 1) mirrored about
    # (0, -sin 30, cos 30) is (0, -sin 60, cos 60).
    image = shoot(tilted_scene(component(texcoord("Reflection"), "Z"), 30.0), kernels)
    np.testing.assert_allclose(image, 0.5, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_texture_coordinate_normal_is_the_object_space_normal(kernels):
    # The plane flat in its object, placed by a matrix turning it 40 degrees: its object normal is +z.
    scene = tilted_scene(component(texcoord("Normal"), "Z"))
    a = math.radians(40.0)
    scene.instances[0].matrix = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a), 0.0],
                                          [0.0, math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 0.0, 1.0]])
    np.testing.assert_allclose(shoot(scene, kernels), 1.0, rtol=1e-6)
    scene.materials[0] = Material(name="World Z", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                          {"emission": component(geometry("Normal"), "Z")})])
    np.testing.assert_allclose(shoot(scene, kernels), math.cos(a), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_texture_coordinate_object_with_an_object_is_the_point_in_that_objects_frame(kernels):
    # An empty at z = -3 scaled by 2: a point of the plane z = 0 is at z = 3 / 2 in its frame.
    matrix = np.diag([2.0, 2.0, 2.0, 1.0])
    matrix[2, 3] = -3.0
    image = shoot(tilted_scene(component(texcoord("Object", {"object_matrix": matrix}), "Z")), kernels)
    np.testing.assert_allclose(image, 1.5, rtol=1e-6)


def test_wireframe_lights_the_points_within_half_its_size_of_a_triangle_edge():
    # The plane's two triangles meet on the diagonal y = x (its outer edges lie far outside the view): unjittered rays
    # through the pixel centres see 1 within 0.4 of it, |x - y| / sqrt 2 < 0.4, else 0.
    scene = tilted_scene(Link(GraphNode("WIREFRAME", {}, {"Size": 0.8}), "Fac"))
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels="numpy",
                                                jitter=False)).image[..., 0]
    x, y = np.meshgrid(-1.0 + (np.arange(SIZE) + 0.5) * 2.0 / SIZE, 1.0 - (np.arange(SIZE) + 0.5) * 2.0 / SIZE)
    np.testing.assert_array_equal(image, (np.abs(x - y) / math.sqrt(2.0) < 0.4).astype(np.float32))
    assert 0 < image.sum() < SIZE * SIZE


def wall_of_wires(looking: str, kind: str) -> Scene:
    """A wall y = 3 facing -y whose Emission shows a Wireframe node 2 pixels wide (Pixel Size), its two triangles
    meeting on the diagonal through (0, 3, 0), seen by a camera of type `kind` ("ORTHO" 1 wide, or "PERSP") from above
    (5 up) in a mirror z = -y that turns every ray towards +y ("mirror"), or straight on from where the mirror shows
    that camera, 5 before the mirror's centre along -y ("direct"; upside down, which changes no area)."""
    if looking == "mirror":
        matrix = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 5.0], [0.0, 0.0, 0.0, 1.0]])
    else:
        matrix = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, -5.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    camera = Camera(matrix_world=matrix, type=kind, ortho_scale=1.0, clip_start=0.01, clip_end=100.0)
    wires = Link(GraphNode("WIREFRAME", {"pixel_size": True}, {"Size": 2.0}), "Fac")
    scene = Scene(camera=camera)
    scene.materials += [Material(name="Wires", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": wires})]),
                        Material(name="Mirror", nodes=[("MIRROR", (1.0, 1.0, 1.0), {})])]
    wall = primitives.plane(20.0)
    wall.vertices = wall.vertices[:, [0, 2, 1]] + [0.0, 3.0, 0.0]
    wall.triangles = wall.triangles[:, ::-1].copy()
    scene.add_mesh(wall, materials=np.array([0]))
    if looking == "mirror":
        mirror = primitives.plane(8.0)
        a = math.radians(-45.0)
        mirror.vertices = mirror.vertices @ np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), math.sin(a)],
                                                      [0.0, -math.sin(a), math.cos(a)]])
        scene.add_mesh(mirror, materials=np.array([1]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("kind", ["ORTHO", "PERSP"])
def test_wireframe_pixel_size_seen_in_a_mirror_is_as_wide_as_seen_straight_on_from_the_mirrored_camera(kernels, kind):
    """Cycles' ray cone (compact ray differentials): the camera ray's footprint where it bounces, widening on by the
    camera ray's spread (0 for an orthographic camera) over the path's length, so a mirror shows the wires as the
    camera it mirrors would see them straight on: the diagonal wire lights as much of the 16 x 16 image in the mirror
    as straight on, within the pixels' samples (an orthographic camera's: 2 pixels' width along the diagonal,
    2 x 16 x sqrt 2 pixels, within 10%)."""
    areas = [render.render(wall_of_wires(looking, kind), RenderSettings(width=16, height=16, samples=16,
                                                                        kernels=kernels, integrator="path",
                                                                        max_bounces=1)).image[..., 0].sum()
             for looking in ("direct", "mirror")]
    assert areas[1] == pytest.approx(areas[0], rel=0.03), areas
    if kind == "ORTHO":
        assert areas[0] == pytest.approx(2.0 * 16.0 * math.sqrt(2.0), rel=0.1), areas


@pytest.mark.parametrize("kernels", KERNELS)
def test_light_path_ray_length_of_camera_rays_is_the_distance_from_the_near_clipping_plane(kernels):
    # A perspective camera 10 above the plane, clipping at 2: each camera ray starts on the near plane (as Cycles'),
    # so it goes 8 / cos(angle off axis) to the hit: 0.8 of the eye's distance (the Camera Data node's View Distance).
    length = Link(GraphNode("LIGHT_PATH", {}, {}), "Ray Length")
    distance = Link(GraphNode("CAMERA_DATA", {}, {}), "View Distance")
    scaled = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": distance, "1": 0.8}), "Value")
    scene = tilted_scene(Link(GraphNode("MATH", {"operation": "SUBTRACT"}, {"0": length, "1": scaled}), "Value"))
    scene.camera = Camera.look_at((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=math.radians(20.0),
                                  clip_start=2.0)
    np.testing.assert_allclose(shoot(scene, kernels), 0.0, atol=2e-5)
    scene.materials[0] = Material(name="Length", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": length})])
    image = shoot(scene, kernels)
    assert (image >= 8.0 - 1e-5).all() and (image <= 8.0 / math.cos(math.radians(15.0))).all() and image.std() > 1e-3


@pytest.mark.parametrize("kernels", KERNELS)
def test_texture_coordinate_window_runs_from_zero_to_one_across_the_image(kernels):
    # An orthographic camera 2 wide: x = -1 .. 1 on the plane is Window x 0 .. 1; unjittered, pixel centres.
    scene = tilted_scene(texcoord("Window"))
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels="numpy",
                                                jitter=False)).image[..., :3]
    x, y = np.meshgrid((np.arange(SIZE) + 0.5) / SIZE, 1.0 - (np.arange(SIZE) + 0.5) / SIZE)
    np.testing.assert_allclose(image, np.stack([x, y, np.zeros_like(x)], axis=2), rtol=1e-6)
    # Perspective: the point straight ahead is the image's centre; the corners' rays end at the frame's corners.
    scene.camera = Camera.look_at((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=math.radians(20.0))
    scene.materials[0] = Material(name="W", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                    {"emission": component(texcoord("Window"), "X")})])
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels=kernels,
                                                jitter=False)).image[..., 0]
    np.testing.assert_allclose(image, np.tile((np.arange(SIZE) + 0.5) / SIZE, (SIZE, 1)), rtol=1e-5)


def test_random_per_island_is_one_hash_per_island_of_the_root_that_union_by_rank_elects():
    """Edges (0,1), (1,2), (3,4) and a lone vertex 5: joining 0 and 1 (equal ranks) makes 0 the root, 2 joins 0's
    higher-ranked set, 4 joins 3. Each triangle gets hash_uint_to_float of its island's root: 0, 3 and 5 (Cycles'
    attr_create_random_per_island), the same for every triangle of an island whichever vertex it names."""
    from core.geometry import islands
    from core.materials.procedural.hash import hash_uint, uint_to_float
    edges = np.array([[0, 1], [1, 2], [3, 4]])
    assert islands.island_roots(6, edges).tolist() == [0, 0, 0, 3, 3, 5]
    values = islands.random_per_island(6, edges, np.array([2, 1, 4, 3, 5]))
    expected = uint_to_float(hash_uint(np.array([0, 0, 3, 3, 5], np.uint32)))
    assert values.dtype == np.float32
    np.testing.assert_array_equal(values, expected)
    assert len(set(values.tolist())) == 3 and all(0.0 <= v <= 1.0 for v in values)


def placed_plane(link: Link, matrix: np.ndarray, color=(1.0, 1.0, 1.0, 1.0), pass_index: int = 0) -> Scene:
    """A 4 x 4 plane placed by `matrix` (its own transform: turned about z, scaled, moved), emitting `link`, under an
    orthographic camera looking down -z at its middle."""
    scene = Scene(camera=ortho_down(center=matrix[:3, 3], height=10.0, scale=1.0))
    scene.materials.append(Material(name="Input", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
    scene.add_mesh(primitives.plane(4.0), matrix=matrix, materials=np.array([0]))
    scene.instances[-1].color, scene.instances[-1].pass_index = color, pass_index
    return scene


def turned_scaled_moved() -> np.ndarray:
    """An object transform (4, 4): turned 0.7 rad about z, scaled (0.9, 0.6, 1.4), moved to (2, -1, 0.5)."""
    c, s = math.cos(0.7), math.sin(0.7)
    matrix = np.diag([0.9, 0.6, 1.4, 1.0]) @ np.eye(4)
    matrix[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag([0.9, 0.6, 1.4])
    matrix[:3, 3] = [2.0, -1.0, 0.5]
    return matrix


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("kind, source, target", [("VECTOR", "OBJECT", "WORLD"), ("POINT", "OBJECT", "WORLD"),
                                                  ("POINT", "WORLD", "OBJECT"), ("NORMAL", "OBJECT", "WORLD"),
                                                  ("NORMAL", "WORLD", "OBJECT")])
def test_vector_transform_in_object_space_is_the_objects_affine_map(kernels, kind, source, target):
    """Object to world: a point goes by M p, a vector by its linear part L v, a normal by L^-T n normalised; world to
    object the inverses (a normal by L^T n normalised): the emitted red is that vector's x."""
    M = turned_scaled_moved()
    L, t = M[:3, :3], M[:3, 3]
    v = np.array([0.3, 0.2, 0.8])
    node = GraphNode("VECTOR_TRANSFORM", {"type": kind, "from": source, "to": target}, {"Vector": tuple(v)})
    inverse = np.linalg.inv(L)
    expected = {("VECTOR", "OBJECT"): L @ v, ("POINT", "OBJECT"): L @ v + t, ("POINT", "WORLD"): inverse @ (v - t),
                ("NORMAL", "OBJECT"): inverse.T @ v, ("NORMAL", "WORLD"): L.T @ v}[kind, source]
    if kind == "NORMAL":
        expected = expected / np.linalg.norm(expected)
    red = shoot(placed_plane(Link(node, "Vector"), M), kernels)
    np.testing.assert_allclose(red, expected[0], rtol=1e-6, atol=1e-7)
    assert np.abs(expected - v).max() > 0.05               # (the transform changed the vector)


@pytest.mark.parametrize("kernels", KERNELS)
def test_object_info_gives_the_objects_location_colour_alpha_and_index(kernels):
    """Object Info of a placed object: Location its matrix's translation, Color and Alpha its colour, Object Index
    its pass index, Material Index the material's: each output's first channel emitted."""
    M = turned_scaled_moved()
    values = {"Location": 2.0, "Color": 0.35, "Alpha": 0.6, "Object Index": 7.0, "Material Index": 4.0}
    for output, expected in values.items():
        node = GraphNode("OBJECT_INFO", {"material_index": 4.0}, {})
        red = shoot(placed_plane(Link(node, output), M, color=(0.35, 0.5, 0.25, 0.6), pass_index=7), kernels)
        np.testing.assert_allclose(red, expected, rtol=1e-6, err_msg=output)


@pytest.mark.parametrize("panorama", graph.PANORAMA_WINDOWS)
def test_window_under_a_panoramic_camera_is_where_each_point_shows_on_both_kernels(panorama):
    """Under a panoramic camera the Window coordinates of a point are the (u, v) its direction maps to
    (graph.panorama_window, Cycles' direction_to_panorama): a point seen at a pixel shows that pixel's place on the
    frame, within the pixel (1 / 8 across here; the middle pixels, inside a fisheye's or mirror ball's circle), and both
    kernels give the same values to float32 rounding."""
    camera = Camera(matrix_world=np.eye(4), type="PANO", panorama_type=panorama, clip_start=0.01, clip_end=100.0)
    scene = Scene(camera=camera)
    window = Link(GraphNode("TEXCOORD", {}, {}), "Window")
    scene.materials.append(Material(name="Window", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": window})]))
    scene.add_mesh(primitives.box((40.0, 40.0, 40.0)), materials=np.array([0]))       # all round the camera
    images = {}
    for kernels in KERNELS:
        result = render.render(scene, RenderSettings(width=8, height=8, samples=4, kernels=kernels))
        images[kernels] = result.image
    np.testing.assert_allclose(images["compiled"], images["numpy"], atol=1e-5)
    seen = np.zeros((8, 8), bool)
    seen[2:6, 2:6] = True                                  # (pixels whose every sample is inside a fisheye's circle)
    u = (np.arange(8) + 0.5) / 8.0
    v = 1.0 - (np.arange(8) + 0.5) / 8.0
    U, V = np.meshgrid(u, v)
    assert np.abs(images["numpy"][..., 0] - U)[seen].max() < 1.0 / 8.0 + 1e-6
    assert np.abs(images["numpy"][..., 1] - V)[seen].max() < 1.0 / 8.0 + 1e-6


def test_the_polynomial_fisheyes_window_radius_is_the_root_of_its_angle_polynomial():
    """graph.polynomial_radius inverts k0 + k1 r + ... + k4 r^4 = theta: exactly (r = (theta - k0) / k1) for a linear
    polynomial, and for Blender's default lens its r (growing with the angle) gives theta back to 1e-6 across a 180
    degree field of view."""
    from core.camera.camera import POLYNOMIAL_DEFAULT
    theta = -np.linspace(0.0, 0.5 * math.pi, 50)
    linear = (0.01, -0.05, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(graph.polynomial_radius(theta, linear), (theta - 0.01) / -0.05, rtol=1e-12)
    k = POLYNOMIAL_DEFAULT
    r = graph.polynomial_radius(theta, k)
    assert np.all(np.diff(r) > 0.0) and np.abs(np.polynomial.polynomial.polyval(r, k) - theta).max() < 1e-6



@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("width", [1.0, 0.3])
def test_a_bump_differences_its_height_over_the_pixel_footprint_times_its_filter_width(kernels, width):
    # The flat plane facing up under the orthographic camera (pixels 0.5 wide: every camera ray's footprint, Cycles'
    # compact differential), a white Diffuse BSDF whose normal is a Bump (Distance 0.5, Filter Width w) of the height
    # sin(4 x), lit by a sun of strength pi straight down: each pixel is the bumped normal's z. Cycles steps dPdx,
    # dPdy = 0.5 a, 0.5 b (make_orthonormals of N = z: a = (1, -1, 0) / sqrt 2, b = (1, 1, 0) / sqrt 2) times w: both
    # move x by s = 0.5 w / sqrt 2, and the normal is normalize(w 0.5 z - 0.5 (sin 4 (x + s) - sin 4 x) (sqrt 2, 0, 0))
    # (a fixed step along the triangle's edges would give the height's derivative instead).
    x = component(geometry("Position"), "X")
    angle = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 4.0}), "Value")
    height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": angle}), "Value")
    normal = Link(GraphNode("BUMP", {"invert": False, "filter_width": width},
                            {"Strength": 1.0, "Distance": 0.5, "Height": height}), "Normal")
    scene = tilted_scene(normal)
    scene.materials[0] = Material(name="Bumped", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"color": np.ones(3),
                                                                                      "normal": normal})])
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=math.pi))
    settings = RenderSettings(width=SIZE, height=SIZE, samples=1, kernels=kernels, integrator="path", max_bounces=0,
                              jitter=False)
    image = render.render(scene, settings).image[..., 0]
    xs = -1.0 + (np.arange(SIZE) + 0.5) * 2.0 / SIZE
    s = 0.5 * width / math.sqrt(2.0)
    across = -0.5 * (np.sin(4.0 * (xs + s)) - np.sin(4.0 * xs)) * math.sqrt(2.0)
    expected = (0.5 * width) / np.sqrt(across * across + (0.5 * width) ** 2)
    np.testing.assert_allclose(image, np.tile(expected, (SIZE, 1)), rtol=1e-5, atol=1e-6)
