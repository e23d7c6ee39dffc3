"""True displacement (core/geometry/displacement.py) against closed forms: a material's Displacement output, a
world-space offset, moves each vertex of its mesh once, turned into the object's space; Displacement Only makes
the smooth normals again from the moved faces."""
from __future__ import annotations

import numpy as np

from core.geometry.displacement import displaced
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.scene import Instance, Mesh, Scene
from core.camera.camera import Camera


def grid_scene(displacement, method="DISPLACEMENT", scale=2.0):
    """A 3 x 3-vertex grid in the z = 0 plane, smooth, placed by one object scaled by `scale` and moved by (1, 0, 0),
    its material displacing by `displacement` (a constant (3,) or a graph Link) with `method`."""
    xs, ys = np.meshgrid(np.arange(3.0), np.arange(3.0))
    vertices = np.stack([xs.ravel(), ys.ravel(), np.zeros(9)], axis=1)
    triangles = []
    for i in range(2):
        for j in range(2):
            a = 3 * i + j
            triangles += [(a, a + 1, a + 4), (a, a + 4, a + 3)]
    mesh = Mesh(vertices, np.array(triangles), smooth=np.ones(8, bool))
    matrix = np.diag([scale, scale, scale, 1.0])
    matrix[0, 3] = 1.0
    material = Material(displacement=displacement, displacement_method=method)
    return Scene(camera=Camera(), meshes=[mesh], instances=[Instance(0, matrix, materials=np.array([0]))],
                 materials=[material])


def test_a_constant_world_offset_moves_every_vertex_by_it_in_object_space():
    """Displacement (0, 0, 1) in world space on an object scaled 2: each vertex rises 0.5 in object space (1 in the
    world), and the grid's normals stay +Z."""
    scene = grid_scene(np.array([0.0, 0.0, 1.0]))
    moved = displaced(scene, [])
    mesh = moved.meshes[0]
    assert np.allclose(mesh.vertices[:, 2], 0.5)
    assert np.allclose(mesh.vertices[:, :2], scene.meshes[0].vertices[:, :2])
    assert np.allclose(mesh.corner_normals, [0.0, 0.0, 1.0])
    assert scene.meshes[0].vertices[:, 2].max() == 0.0          # (the scene's own mesh is left as it was)


def test_an_offset_of_half_the_world_position_scales_the_placed_grid_by_one_and_a_half():
    """Displacement = 0.5 x the Geometry node's Position (the vertex in the world): every placed vertex P goes to
    1.5 P, so in object space v goes to 1.5 v + 0.5 t / s (t the object's location (1, 0, 0), s its scale 2)."""
    position = Link(GraphNode("GEOMETRY", {}, {}, "geometry"), "Position")
    half = Link(GraphNode("VECTOR_MATH", {"operation": "SCALE"}, {"Vector": position, "Scale": 0.5}, "half"), "Vector")
    scene = grid_scene(half)
    mesh = displaced(scene, []).meshes[0]
    expected = 1.5 * scene.meshes[0].vertices + 0.5 * np.array([1.0, 0.0, 0.0]) / 2.0
    assert np.allclose(mesh.vertices, expected, atol=1e-12)


def test_displacement_only_makes_the_normals_of_a_tilted_grid_from_its_faces():
    """An offset along z of 0.5 x the world x tilts the grid to the slope dz/dx = 0.5 (in the world, so the object's
    too): Displacement Only's normals are the tilted faces' (-0.5, 0, 1) / |.|; Displacement and Bump keeps +Z."""
    position = Link(GraphNode("GEOMETRY", {}, {}, "geometry"), "Position")
    separate = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": position}, "xyz"), "X")
    slope = Link(GraphNode("COMBINE_XYZ", {}, {"X": 0.0, "Y": 0.0, "Z": separate}, "dz"), "Vector")
    tilted = Link(GraphNode("VECTOR_MATH", {"operation": "SCALE"}, {"Vector": slope, "Scale": 0.5}, "tilt"), "Vector")
    normal = np.array([-0.5, 0.0, 1.0]) / np.sqrt(1.25)
    only = displaced(grid_scene(tilted, "DISPLACEMENT"), []).meshes[0]
    assert np.allclose(only.corner_normals, normal, atol=1e-12)
    both = displaced(grid_scene(tilted, "BOTH"), []).meshes[0]
    assert both.corner_normals is None or np.allclose(both.corner_normals, [0.0, 0.0, 1.0])
    assert np.allclose(only.vertices, both.vertices)
