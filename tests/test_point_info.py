"""The Point Info node on a point cloud's spheres (core/geometry/points.py point_info, graph.Compiler.point_info): each
sphere reads its point's centre in world space, its radius scaled by the object's transform and Cycles' random number
of its index (hash_uint2_to_float(i, 0)), on both kernels; a plain mesh reads 0 (Cycles' point_position,
point_radius, point_random off points), and so does every Volume Info output (no volume grid on a mesh).
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.geometry import points, primitives
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.materials.procedural import hash as hash_
from core.scene import RenderSettings, Scene

CENTRES = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [-0.5, 0.5, 0.0], [0.5, 0.5, 0.0]])
RADIUS = np.array([0.3, 0.35, 0.4, 0.45])   # (x 1.5: each covers its centre pixel wholly)
SIZE = 8                  # (pixels half a unit wide: the centres, at +-0.75, are pixel centres)


def cloud_pixels(output: str, kernels: str, matrix: np.ndarray) -> np.ndarray:
    """The four points (CENTRES, RADIUS) placed by `matrix`, emitting Point Info `output`, seen from above: the
    pixels at the four centres (4, 3)."""
    mesh, _ = points.spheres(CENTRES, RADIUS, 2)
    mesh.curve_info = points.point_info(CENTRES, RADIUS, len(mesh.vertices))
    for name, values in mesh.curve_info.items():         # (as addon/export.py curve_attributes carries them)
        per_corner = values[mesh.triangles]
        mesh.attributes[name] = per_corner[:, :, None] if per_corner.ndim == 2 else per_corner
    link = Link(GraphNode("POINT_INFO", {}, {}), output)
    scene = Scene(camera=ortho_down(center=matrix[:3, 3], height=3.0, scale=4.0))
    scene.materials.append(Material(name="Info", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
    scene.add_mesh(mesh, matrix, materials=np.array([0]))
    image = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, kernels=kernels)).image
    world = CENTRES @ matrix[:3, :3].T + matrix[:3, 3]
    columns = np.floor((world[:, 0] - matrix[0, 3] + 2.0) / 4.0 * SIZE).astype(int)
    rows = np.floor((2.0 - (world[:, 1] - matrix[1, 3])) / 4.0 * SIZE).astype(int)
    return image[rows, columns, :3]


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_each_sphere_reads_its_points_world_centre_scaled_radius_and_random(kernels):
    """Object scaled 1.5 and moved to (2, 3, 0.5): Position the centres moved so, Radius 1.5 r, Random
    hash_uint2_to_float(i, 0)."""
    matrix = np.diag([1.5, 1.5, 1.5, 1.0])
    matrix[:3, 3] = (2.0, 3.0, 0.5)
    world = CENTRES * 1.5 + matrix[:3, 3]
    np.testing.assert_allclose(cloud_pixels("Position", kernels, matrix), world, atol=1e-6)
    np.testing.assert_allclose(cloud_pixels("Radius", kernels, matrix)[:, 0], 1.5 * RADIUS, rtol=1e-6)
    random = hash_.uint_to_float(hash_.hash_uint2(np.arange(4), 0))
    np.testing.assert_allclose(cloud_pixels("Random", kernels, matrix)[:, 0], random, rtol=1e-6)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_point_info_and_volume_info_read_zero_on_a_plain_mesh(kernels):
    """A plane emitting each Point Info and Volume Info output + 0.25 (Vector Math Add): 0.25 everywhere."""
    scene = Scene(camera=ortho_down(height=2.0, scale=2.0))
    outputs = [("POINT_INFO", o) for o in ("Position", "Radius", "Random")] + [
        ("VOLUME_INFO", o) for o in ("Color", "Density", "Flame", "Temperature")]
    for index, (kind, output) in enumerate(outputs):
        plus = Link(GraphNode("VECTOR_MATH", {"operation": "ADD"},
                              {"Vector": Link(GraphNode(kind, {}, {}), output), "Vector_001": (0.25, 0.25, 0.25)}),
                    "Vector")
        scene.materials.append(Material(name=f"{kind} {output}", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                                          {"emission": plus})]))
    scene.add_mesh(primitives.plane(2.0), materials=np.array([0]))
    for index in range(len(outputs)):
        scene.instances[0].materials = np.array([index])
        image = render.render(scene, RenderSettings(width=4, height=4, samples=1, kernels=kernels)).image
        np.testing.assert_allclose(image[..., :3], 0.25, atol=1e-7, err_msg=str(outputs[index]))
