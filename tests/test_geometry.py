"""Placing copies: every copied triangle lands where its own object's matrix puts it.

core/geometry/geometry.py places the copies of many meshes in one batch (_place_copies). Each test builds
a scene of many different small meshes and checks the placed triangles against the closed forms:
world point = M p + t, face normal along (b - a) x (c - a), corner normals turned by M^-T, the
instance's material table, and the bad triangles dropped and counted.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.geometry import primitives
from core.camera import Camera
from core.geometry.geometry import build_geometry
from core.scene import Instance, Mesh, Scene

COPY = 1 << 62      # instance_triangles that copies every mesh


def many_meshes(count: int = 40, seed: int = 11):
    """Return (scene, matrices): `count` different meshes, each placed once by a random matrix (some
    mirrored, unevenly scaled), half of them smooth, each with two material slots."""
    rng = np.random.default_rng(seed)
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 5.0), (0.0, 0.0, 0.0), fov=math.radians(55)))
    for colour in ((0.7, 0.7, 0.7), (0.8, 0.3, 0.2), (0.2, 0.3, 0.8)):
        scene.add_material(colour)
    matrices = []
    for index in range(count):
        mesh = primitives.uv_sphere(0.5, 4 + index % 5, 3 + index % 4, smooth=index % 2 == 0)
        mesh.material_indices[::2] = 1                                  # slot 1 on every other triangle
        scene.meshes.append(mesh)
        M = np.eye(4)
        M[:3, :3] = rng.normal(size=(3, 3)) + 2.0 * np.eye(3)
        if index % 3 == 0:
            M[:3, 0] *= -1.0                                           # a mirror
        M[:3, 3] = rng.uniform(-5.0, 5.0, 3)
        matrices.append(M)
        scene.instances.append(Instance(index, M, np.array([index % 3, (index + 1) % 3]), f"Object {index}"))
    return scene, matrices


def test_copies_land_where_their_own_matrices_put_them():
    scene, matrices = many_meshes()
    origin = np.array([0.5, -2.0, 1.0])
    geometry = build_geometry(scene, origin, COPY)
    assert not geometry.instanced and geometry.warnings == []
    assert len(geometry.triangles) == sum(len(mesh.triangles) for mesh in scene.meshes)
    start = 0
    for index, (mesh, M) in enumerate(zip(scene.meshes, matrices)):
        rows = slice(start, start + len(mesh.triangles))
        start += len(mesh.triangles)
        assert (geometry.instance[rows] == index).all()
        # World points: M p + t - origin (rounded to float32 once).
        expected = (mesh.vertices[mesh.triangles] @ M[:3, :3].T + M[:3, 3] - origin).astype(np.float32)
        np.testing.assert_array_equal(geometry.vertices[geometry.triangles[rows]], expected)
        # Face normals along (b - a) x (c - a) of the placed triangle: a mirror turns the winding, and
        # the normal is turned back, so it still points out of the sphere.
        placed = mesh.vertices[mesh.triangles] @ M[:3, :3].T
        n = np.cross(placed[:, 1] - placed[:, 0], placed[:, 2] - placed[:, 0]) * np.sign(np.linalg.det(M[:3, :3]))
        n /= np.linalg.norm(n, axis=1)[:, None]
        np.testing.assert_allclose(geometry.face_normals[rows], n, atol=1e-12)
        outward = placed.mean(axis=1)                                   # (placed about the origin, before t)
        assert (np.einsum("ij,ij->i", geometry.face_normals[rows], outward) > 0).all()
        # Materials: slot 0 -> table[0], slot 1 -> table[1].
        table = np.array([index % 3, (index + 1) % 3])
        np.testing.assert_array_equal(geometry.material[rows], table[mesh.material_indices])
        # Smooth corners: N' = normalize(M^-T n).
        smooth = geometry.smooth_index[rows]
        assert (smooth >= 0).all() == (index % 2 == 0) and ((smooth >= 0).any() == (index % 2 == 0))
        if index % 2 == 0:
            turned = mesh.corner_normals @ np.linalg.inv(M[:3, :3])
            turned /= np.linalg.norm(turned, axis=2)[..., None]
            np.testing.assert_allclose(geometry.corner_normals[smooth], turned, atol=1e-6)   # stored float32


def test_bad_triangles_and_placements_among_many_meshes_are_dropped_and_counted():
    scene, matrices = many_meshes(count=12)
    scene.meshes[3].triangles[0] = (0, 1, 10_000)                      # an index out of range
    scene.meshes[5].vertices[0] = np.nan                               # NaN corners
    scene.meshes[7].material_indices[:] = 5                            # a slot the table lacks
    scene.instances[8].matrix[:3, :3] = 0.0                            # zero scale
    nan_triangles = int((scene.meshes[5].triangles == 0).any(axis=1).sum())
    geometry = build_geometry(scene, np.zeros(3), COPY)
    text = " ".join(geometry.warnings)
    assert "1 triangle(s) with out-of-range vertex indices" in text
    assert f"{nan_triangles} triangle(s) with NaN or infinite vertices" in text
    assert f"{len(scene.meshes[7].triangles)} triangle(s) have no material" in text
    assert "1 object(s) of mesh" in text and 8 not in set(geometry.instance.tolist())
    expected = (sum(len(m.triangles) for m in scene.meshes) - 1 - nan_triangles - len(scene.meshes[8].triangles))
    assert len(geometry.triangles) == expected
    assert (geometry.material[geometry.instance == 7] == len(scene.materials)).all()    # the default grey
    assert np.isfinite(geometry.vertices).all()


def test_a_mesh_of_its_own_material_indices_uses_them_as_scene_materials():
    scene = Scene(camera=Camera.look_at((0.0, -5.0, 2.0), (0.0, 0.0, 0.0)))
    scene.add_material((0.1, 0.2, 0.3))
    scene.add_material((0.4, 0.5, 0.6))
    mesh = Mesh(primitives.plane(2.0).vertices, primitives.plane(2.0).triangles, material_indices=[1, 0])
    scene.meshes.append(mesh)
    scene.meshes.append(primitives.box((1.0, 1.0, 1.0)))
    scene.instances += [Instance(0, np.eye(4), None, "Plane"), Instance(1, np.eye(4), np.array([1]), "Box")]
    geometry = build_geometry(scene, np.zeros(3), COPY)
    np.testing.assert_array_equal(geometry.material[geometry.instance == 0], [1, 0])
    assert (geometry.material[geometry.instance == 1] == 1).all()


def test_a_lone_placement_is_placed_as_it_is_in_a_batch():
    """One mesh placed once takes a path with no gathered copies; it gives the batch's numbers."""
    scene, matrices = many_meshes(count=2)
    scene.meshes[0].triangles[1] = (0, 2, 99_999)                     # out of range: dropped
    alone = Scene(camera=scene.camera, materials=scene.materials, meshes=[scene.meshes[0]],
                  instances=[scene.instances[0]])
    origin = np.array([0.25, 1.0, -0.5])
    one, both = build_geometry(alone, origin, COPY), build_geometry(scene, origin, COPY)
    rows = both.instance == 0
    assert len(one.triangles) == rows.sum() == len(scene.meshes[0].triangles) - 1
    np.testing.assert_array_equal(one.vertices[one.triangles], both.vertices[both.triangles[rows]])
    for name in ("face_normals", "material"):
        np.testing.assert_array_equal(getattr(one, name), getattr(both, name)[rows])
    np.testing.assert_array_equal(one.corner_normals, both.corner_normals[both.smooth_index[rows]])
    assert "1 triangle(s) with out-of-range vertex indices" in " ".join(one.warnings)


def test_compiled_face_and_corner_normals_are_numpys_bit_for_bit():
    """normals.compiled_face_normals and compiled_turn_normals (the placement's C passes) give the numbers
    of normals.face_normals and of safe_normalize(rows_times_each(...)): random, degenerate, tiny, huge
    and NaN triangles; mirrored and scaled placements."""
    from core.native import library
    from core.geometry import normals
    from core import vectors
    if not library.available():
        pytest.skip(library.unavailable_reason())
    rng = np.random.default_rng(5)
    vertices = rng.normal(size=(400, 3)) * rng.choice([1e-20, 1.0, 1e3, 1e160], (400, 1))
    vertices[7] = np.nan
    vertices[9] = vertices[8]                                           # a zero-length edge
    triangles = rng.integers(0, 400, (1000, 3))
    triangles[:5] = [7, 1, 2]                                          # NaN corners
    triangles[5:10] = [8, 9, 3]                                        # degenerate
    with np.errstate(invalid="ignore", over="ignore"):
        expected = normals.face_normals(vertices, triangles)
        found = normals.compiled_face_normals(vertices, triangles)
    np.testing.assert_array_equal(found.normals, expected.normals)
    np.testing.assert_array_equal(found.area, expected.area)
    corners = rng.normal(size=(300, 3, 3))
    corners[3] = 0.0                                                   # zero normals stay zero
    inverse = rng.normal(size=(6, 3, 3)) * rng.choice([-1.0, 1e-3, 1e3], (6, 1, 1))
    rows, placement = rng.integers(0, 300, 700), rng.integers(0, 6, 700)
    np.testing.assert_array_equal(normals.compiled_turn_normals(corners, rows, inverse, placement),
                                  normals.safe_normalize(vectors.rows_times_each(corners[rows], inverse[placement])))


def test_batches_number_their_triangles_past_the_ones_before_and_leave_the_scenes_arrays_as_they_were(monkeypatch):
    """A batch of one mesh placed once reads the scene's own arrays uncopied (_place_copies); the batches after the
    first offset their triangles past the vertices placed before, in a new array, never in the scene's."""
    import core.geometry.geometry as geometry_module
    monkeypatch.setattr(geometry_module, "BATCH_TRIANGLES", 1)          # one mesh a batch
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 5.0), (0.0, 0.0, 0.0)))
    scene.add_material((0.7, 0.7, 0.7))
    for index in range(3):
        scene.meshes.append(primitives.uv_sphere(0.5, 8, 5, smooth=True))
        M = np.eye(4)
        M[:3, 3] = (2.0 * index, 0.0, 0.0)
        scene.instances.append(Instance(index, M, None, f"Sphere {index}"))
    before = [(m.vertices.copy(), m.triangles.copy(), m.corner_normals.copy()) for m in scene.meshes]
    geometry = build_geometry(scene, np.zeros(3), COPY)
    for mesh, (vertices, triangles, corners) in zip(scene.meshes, before):
        np.testing.assert_array_equal(mesh.vertices, vertices)
        np.testing.assert_array_equal(mesh.triangles, triangles)
        np.testing.assert_array_equal(mesh.corner_normals, corners)
    start, first_vertex = 0, 0
    for index, mesh in enumerate(scene.meshes):
        rows = slice(start, start + len(mesh.triangles))
        np.testing.assert_array_equal(geometry.triangles[rows], mesh.triangles + first_vertex)
        np.testing.assert_array_equal(geometry.vertices[geometry.triangles[rows]],
                                      (mesh.vertices[mesh.triangles] + (2.0 * index, 0.0, 0.0)).astype(np.float32))
        start += len(mesh.triangles)
        first_vertex += len(mesh.vertices)


def test_placing_a_smooth_mesh_holds_under_three_float64_copies_of_its_corner_normals_at_once():
    """build_geometry's arrays at their peak (numpy's allocations, tracemalloc), placing one smooth mesh: its corner
    normals are turned into one float64 array and rounded to float32 before the triangles are kept, and the batch's
    float64 arrays go before the tables are joined, so the peak stays under 3 x 72 bytes a triangle (the scene's own
    arrays not counted; it was about 4 x, 286 bytes, with a copy of the mesh's normals made before joining them and
    a float64 copy of the kept ones)."""
    import tracemalloc
    from core.native import library
    if not library.available():
        pytest.skip("the compiled kernels turn the normals in one pass; numpy's reference makes temporaries")
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 5.0), (0.0, 0.0, 0.0)))
    scene.add_material((0.7, 0.7, 0.7))
    mesh = primitives.uv_sphere(1.0, 200, 100, smooth=True)
    scene.meshes.append(mesh)
    M = np.diag([2.0, 1.0, 0.5, 1.0])
    scene.instances.append(Instance(0, M, None, "Sphere"))
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        geometry = build_geometry(scene, np.zeros(3), COPY)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    assert len(geometry.triangles) == len(mesh.triangles)
    assert peak < 3 * mesh.corner_normals.nbytes


def test_embree_reads_the_geometrys_own_points_and_triangles_in_place():
    """The placed points and triangles are the leading rows of the padded buffers Embree shares (with_spare_row):
    the tracer holds no second copy of them, and its buffers' spare rows are zero."""
    scene, _ = many_meshes(count=6)
    geometry = build_geometry(scene, np.zeros(3), COPY)
    if not geometry.tracer.shared:
        pytest.skip("Embree's buffers cannot be shared here (embree_buffers.scene_handles)")
    points, indices = geometry.tracer._buffers[:2]
    assert points.shape == (len(geometry.vertices) + 1, 3) and indices.shape == (len(geometry.triangles) + 1, 3)
    assert np.shares_memory(points, geometry.vertices) and np.shares_memory(indices, geometry.triangles)
    assert not points[-1].any() and not indices[-1].any()
    np.testing.assert_array_equal(indices[:-1], geometry.triangles)


def test_a_mesh_keeps_float32_corner_normals_and_places_them_as_their_float64_widening():
    """Blender's corner normals are float32: a Mesh keeps them so (half the memory of float64), and the placed
    geometry, copied or instanced, is bit for bit that of the same normals widened to float64."""
    from core.geometry.instancing import instance_triangles
    scene, matrices = many_meshes(count=6)
    for index, M in enumerate(matrices):                            # each mesh twice: instanced when asked
        moved = M.copy()
        moved[:3, 3] += (0.5, 0.25, -1.0)
        scene.instances.append(Instance(index, moved, np.array([index % 3, (index + 1) % 3]), f"Copy {index}"))
    wide = Scene(camera=scene.camera, materials=scene.materials, instances=scene.instances,
                 meshes=[Mesh(m.vertices, m.triangles, smooth=m.smooth, material_indices=m.material_indices,
                              corner_normals=None if m.corner_normals is None
                              else m.corner_normals.astype(np.float32).astype(np.float64)) for m in scene.meshes])
    narrow = Scene(camera=scene.camera, materials=scene.materials, instances=scene.instances,
                   meshes=[Mesh(m.vertices, m.triangles, smooth=m.smooth, material_indices=m.material_indices,
                                corner_normals=None if m.corner_normals is None
                                else m.corner_normals.astype(np.float32)) for m in scene.meshes])
    assert narrow.meshes[0].corner_normals.dtype == np.float32 and wide.meshes[0].corner_normals.dtype == np.float64
    for triangles in (COPY, instance_triangles("always")):
        a, b = build_geometry(wide, np.zeros(3), triangles), build_geometry(narrow, np.zeros(3), triangles)
        np.testing.assert_array_equal(a.corner_normals, b.corner_normals)
        np.testing.assert_array_equal(a.face_normals, b.face_normals)
        assert len(a.instanced) == len(b.instanced) == (6 if triangles == 0 else 0)
        for x, y in zip(a.instanced, b.instanced):
            np.testing.assert_array_equal(x.corner_normals, y.corner_normals)
