"""Tests for core/geometry/normals.py and the normals that core/geometry/geometry.py and core/integrators/direct.py derive from it.

Expected values are closed forms: face normals and areas of hand-picked triangles,
cube corner normals (+-1, +-1, +-1)/sqrt(3), normalised sums of corner normals at edge
midpoints, analytic sphere and ellipsoid normals. Float32 enters only where the
geometry is handed to Embree, hence the ~1e-6 tolerances on world-space normals.
"""

import math

import numpy as np
import pytest

from conftest import rotation, unit

from core.geometry import primitives
from core.camera import Camera, generate_rays
from core.geometry import geometry as geometry_module
from core.geometry.geometry import build_geometry
from core.geometry.normals import face_forward, face_normals, interpolate, safe_normalize, vertex_normals
from core.render import render
from core.scene import Instance, RenderSettings, Scene
from core.geometry.surface import surface_at_hits

FLOAT32_NORMAL_ATOL = 2e-6      # a few float32 ulps of a unit vector


def affine(linear=np.eye(3), translation=(0.0, 0.0, 0.0)):
    """Return the (4, 4) transform with the given (3, 3) linear part and translation."""
    matrix = np.eye(4)
    matrix[:3, :3] = linear
    matrix[:3, 3] = translation
    return matrix


def angle_between(a, b):
    """Return the angles (radians) between rows of a and b ((n, 3) each)."""
    a, b = unit(a), unit(b)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.einsum("...i,...i->...", a, b))


# ----------------------------------------------------------------------------
# Face normals and areas
# ----------------------------------------------------------------------------

def test_face_normals_and_areas_of_known_triangles():
    """Counter-clockwise triangles have the right-hand unit normal and area |e1 x e2| / 2."""
    vertices = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0],      # right triangle in z = 0
                         [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0],      # the x + y + z = 1 triangle
                         [1e6, 1e6, 1e6], [1e6, 1e6 + 4.0, 1e6], [1e6, 1e6, 1e6 + 1.0]])  # far away, in x = 1e6
    triangles = np.array([[0, 1, 2], [0, 2, 1], [3, 4, 5], [6, 7, 8]])
    result = face_normals(vertices, triangles)
    expected = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], unit([1.0, 1.0, 1.0]), [1.0, 0.0, 0.0]])
    np.testing.assert_allclose(result.normals, expected, atol=1e-15)
    np.testing.assert_allclose(result.area, [3.0, 3.0, math.sqrt(3.0) / 2.0, 2.0], rtol=1e-14)


def test_degenerate_triangles_have_zero_normal_and_zero_area():
    """Zero-area triangles (collinear or repeated corners) get a zero normal and area 0, not NaN."""
    vertices = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [5.0, -1.0, 2.0]])
    triangles = np.array([[0, 1, 2], [3, 3, 0], [3, 3, 3], [0, 1, 3]])
    result = face_normals(vertices, triangles)
    np.testing.assert_array_equal(result.normals[:3], 0.0)
    np.testing.assert_array_equal(result.area[:3], 0.0)
    # The regular triangle among them is unaffected.
    assert np.linalg.norm(result.normals[3]) == pytest.approx(1.0, abs=1e-15) and result.area[3] > 0.0


def test_non_finite_vertices_give_zero_normal_and_area_not_nan():
    """A triangle with a NaN or infinite corner gets a zero normal and area 0; its neighbours are unaffected."""
    vertices = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                         [np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0]])
    triangles = np.array([[0, 1, 3], [0, 4, 2], [0, 1, 2]])
    with np.errstate(invalid="ignore"):
        result = face_normals(vertices, triangles)
        per_vertex = vertex_normals(vertices, triangles)
    assert np.isfinite(result.normals).all() and np.isfinite(result.area).all()
    np.testing.assert_array_equal(result.normals[:2], 0.0)
    np.testing.assert_array_equal(result.area[:2], 0.0)
    np.testing.assert_array_equal(result.normals[2], [0.0, 0.0, 1.0])
    assert result.area[2] == 0.5
    # Vertex normals stay finite too: the bad triangles contribute nothing.
    assert np.isfinite(per_vertex).all()
    np.testing.assert_allclose(per_vertex[:3], [[0.0, 0.0, 1.0]] * 3, atol=1e-15)


def test_safe_normalize_gives_unit_or_zero_vectors():
    """safe_normalize scales finite non-zero vectors to unit length and maps zero/NaN/inf vectors to 0."""
    vectors = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], [np.inf, 0.0, 0.0], [0.0, -1e-9, 0.0]])
    with np.errstate(invalid="ignore", over="ignore"):
        out = safe_normalize(vectors)
    np.testing.assert_allclose(out[0], [0.6, 0.8, 0.0], rtol=1e-15)
    np.testing.assert_array_equal(out[1:4], 0.0)
    np.testing.assert_allclose(out[4], [0.0, -1.0, 0.0], rtol=1e-15)


# ----------------------------------------------------------------------------
# Barycentric interpolation of corner normals
# ----------------------------------------------------------------------------

CORNERS = np.array([unit([0.0, 0.0, 1.0]), unit([1.0, 0.0, 1.0]), unit([0.0, 1.0, 2.0])])
FACE = np.array([0.0, 0.0, 1.0])


def interpolate_at(corners, u, v, fallback=FACE):
    """Interpolate one triangle's corner normals at each (u, v): returns (n, 3)."""
    u, v = np.atleast_1d(np.asarray(u, float)), np.atleast_1d(np.asarray(v, float))
    return interpolate(np.broadcast_to(corners, (len(u), 3, 3)).copy(), u, v,
                       np.broadcast_to(fallback, (len(u), 3)).copy())


def test_interpolation_is_exact_at_the_vertices():
    """(u, v) = (0,0), (1,0), (0,1) give exactly the corner normals N0, N1, N2."""
    result = interpolate_at(CORNERS, [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(result, CORNERS, atol=1e-15)


def test_interpolation_at_edge_midpoints_is_normalized_sum_of_the_edge_corners():
    """At an edge midpoint the normal is normalize(N_i + N_j) of that edge's two corners."""
    result = interpolate_at(CORNERS, [0.5, 0.5, 0.0], [0.0, 0.5, 0.5])
    expected = unit([CORNERS[0] + CORNERS[1], CORNERS[1] + CORNERS[2], CORNERS[0] + CORNERS[2]])
    np.testing.assert_allclose(result, expected, atol=1e-15)
    # Not just the face normal or a corner: the midpoints differ from every corner.
    assert angle_between(result[:, None, :], CORNERS[None, :, :]).min() > 0.1


def test_interpolated_normals_are_unit_inside_the_triangle():
    """Inside the triangle the interpolated normal is renormalised (unit) and parallel to sum w_i N_i."""
    rng = np.random.default_rng(5)
    u, v = rng.random(2000), rng.random(2000)
    outside = u + v > 1.0
    u[outside], v[outside] = 1.0 - u[outside], 1.0 - v[outside]
    result = interpolate_at(CORNERS, u, v)
    np.testing.assert_allclose(np.linalg.norm(result, axis=1), 1.0, atol=1e-14)
    blend = (1.0 - u - v)[:, None] * CORNERS[0] + u[:, None] * CORNERS[1] + v[:, None] * CORNERS[2]
    np.testing.assert_allclose(np.cross(result, blend), 0.0, atol=1e-14)
    assert np.linalg.norm(blend, axis=1).min() < 0.99      # the blend itself is shorter: renormalising matters


@pytest.mark.parametrize("case", ["opposite", "zero", "nan", "inf"])
def test_interpolation_falls_back_to_face_normal_when_corners_cancel_or_are_invalid(case):
    """Where the interpolated sum vanishes or is not finite, the face normal is used instead."""
    corners = CORNERS.copy()
    u, v = np.array([0.5, 0.2]), np.array([0.0, 0.2])
    if case == "opposite":
        corners[1] = -corners[0]          # the edge midpoint (u, v) = (0.5, 0) sums to exactly 0
    elif case == "zero":
        corners[:] = 0.0
    elif case == "nan":
        corners[2] = np.nan
    else:
        corners[1] = np.inf
    fallback = unit([0.1, -0.2, 1.0])
    with np.errstate(invalid="ignore"):
        result = interpolate_at(corners, u, v, fallback)
    np.testing.assert_array_equal(result[0], fallback)
    assert np.isfinite(result).all()
    if case == "opposite":
        # Away from the cancelling point the corners are used, not the fallback.
        assert np.linalg.norm(result[1]) == pytest.approx(1.0) and angle_between(result[1], fallback) > 0.05


# ----------------------------------------------------------------------------
# Vertex normals: angle weighting
# ----------------------------------------------------------------------------

def my_unit_cube():
    """Return (vertices, triangles) of a unit cube whose quads are split so corner 0 is shared unevenly.

    Vertex i is at (+-0.5, +-0.5, +-0.5) with bit 0 -> x, bit 1 -> y, bit 2 -> z. Each quad (a, b, c, d)
    is counter-clockwise seen from outside and split into (a, b, c), (a, c, d). Corner 0 lies in both
    triangles of the bottom face but in only one triangle of the front (-y) and left (-x) faces.
    """
    vertices = np.array([[x, y, z] for z in (-0.5, 0.5) for y in (-0.5, 0.5) for x in (-0.5, 0.5)])
    quads = [(0, 2, 3, 1), (4, 5, 7, 6),      # bottom (-z), top (+z)
             (1, 5, 4, 0), (2, 6, 7, 3),      # front (-y), back (+y)
             (4, 6, 2, 0), (1, 3, 7, 5)]      # left (-x), right (+x)
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    return vertices, triangles


def test_my_cube_faces_point_outward():
    """Guard for the cube tests: every triangle of the hand-made cube faces away from its centre."""
    vertices, triangles = my_unit_cube()
    faces = face_normals(vertices, triangles)
    centroids = vertices[triangles].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", faces.normals, centroids) > 0.0)
    np.testing.assert_allclose(faces.area, 0.5, rtol=1e-15)


@pytest.mark.parametrize("make", ["primitives.box", "hand-made"])
def test_angle_weighted_cube_corner_normals_are_diagonals(make):
    """With angle weighting every corner of a triangulated cube gets exactly (+-1, +-1, +-1)/sqrt(3)."""
    if make == "primitives.box":
        mesh = primitives.box((1.0, 1.0, 1.0))
        vertices, triangles = mesh.vertices, mesh.triangles
    else:
        vertices, triangles = my_unit_cube()
    normals = vertex_normals(vertices, triangles, weighting="angle")
    np.testing.assert_allclose(normals, np.sign(vertices) / math.sqrt(3.0), atol=1e-12)


def test_area_weighted_cube_corner_normal_depends_on_triangulation():
    """Area weighting counts a face twice where two of its triangles meet at the corner; angle weighting does not."""
    vertices, triangles = my_unit_cube()
    area = vertex_normals(vertices, triangles, weighting="area")
    angle = vertex_normals(vertices, triangles, weighting="angle")
    # Corner 0: bottom face (0, 0, -1) twice, front (0, -1, 0) and left (-1, 0, 0) once, each of area 1/2.
    np.testing.assert_allclose(area[0], unit([-1.0, -1.0, -2.0]), atol=1e-15)
    np.testing.assert_allclose(angle[0], unit([-1.0, -1.0, -1.0]), atol=1e-12)
    assert angle_between(area[0], angle[0]) > 0.1
    # Every corner's area-weighted normal is still unit and in the corner's octant.
    np.testing.assert_allclose(np.linalg.norm(area, axis=1), 1.0, atol=1e-15)
    assert np.all(np.sign(area) == np.sign(vertices))


def test_unknown_vertex_normal_weighting_is_rejected():
    """Only "angle" and "area" weightings exist."""
    vertices, triangles = my_unit_cube()
    with pytest.raises(ValueError):
        vertex_normals(vertices, triangles, weighting="uniform")


# ----------------------------------------------------------------------------
# Facing the viewer: the lecture's "if N . D > 0 then N = -N"
# ----------------------------------------------------------------------------

def test_face_forward_flips_normals_hit_from_behind():
    """face_forward returns -1 where N . D > 0 (hit from behind or inside) and +1 otherwise."""
    normals = np.array([[0.0, 0.0, 1.0]] * 4)
    directions = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], unit([1.0, 0.0, 0.1]), [1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(face_forward(normals, directions), [1.0, -1.0, -1.0, 1.0])
    flipped = normals * face_forward(normals, directions)[:, None]
    assert np.all(np.einsum("ij,ij->i", flipped, directions) <= 0.0)


def rays_from_inside(count=400, seed=11):
    """Return (origins, directions) of rays from the origin in random directions."""
    rng = np.random.default_rng(seed)
    directions = unit(rng.normal(size=(count, 3)))
    return np.zeros((count, 3)), directions


def trace_surface(scene, origin, origins, directions, flat_only=False):
    """Build the scene's geometry relative to `origin`, trace the rays, return (geometry, hit mask, Surface)."""
    geometry = build_geometry(scene, np.asarray(origin, float))
    relative = origins - origin
    hits = geometry.tracer.intersect(relative, directions, np.full(len(origins), 1e30))
    hit = hits.hit
    surface = surface_at_hits(geometry, hits.prim[hit], hits.u[hit], hits.v[hit],
                              relative[hit], directions[hit], hits.t[hit], flat_only=flat_only)
    return geometry, hits.hit, surface


@pytest.mark.parametrize("table", [True, False])
def test_surface_corners_are_the_hit_triangles_vertices(table, monkeypatch):
    """Surface.vertices, from the per-triangle corner table or without it (large scenes), are exactly
    vertices[triangles[prim]]; and the hit point lies in the plane of those corners."""
    if not table:
        monkeypatch.setattr(geometry_module, "CORNER_TABLE_TRIANGLES", 0)
    scene = Scene(camera=Camera())
    scene.add_mesh(primitives.uv_sphere(1.0, 12, 8))
    origins, directions = rays_from_inside()
    geometry, hit, surface = trace_surface(scene, np.zeros(3), origins, directions)
    prim = geometry.tracer.intersect(origins, directions, np.full(len(origins), 1e30)).prim[hit]
    np.testing.assert_array_equal(surface.vertices, geometry.vertices[geometry.triangles[prim]].astype(np.float64))
    in_plane = np.einsum("ij,ij->i", surface.I - surface.vertices[:, 0], surface.Ng)
    np.testing.assert_allclose(in_plane, 0.0, atol=1e-7)


def test_box_seen_from_inside_has_face_normals_turned_towards_the_viewer():
    """Hitting a closed box from inside flips its outward face normals: Ng = -outward, so Ng . D < 0."""
    scene = Scene(camera=Camera())
    scene.add_mesh(primitives.box((2.0, 2.0, 2.0)))
    origins, directions = rays_from_inside()
    _, hit, surface = trace_surface(scene, np.zeros(3), origins, directions)
    assert hit.all()
    outward = np.zeros_like(surface.I)
    axis = np.argmax(np.abs(surface.I), axis=1)
    outward[np.arange(len(axis)), axis] = np.sign(surface.I[np.arange(len(axis)), axis])
    np.testing.assert_array_equal(surface.Ng, -outward)
    np.testing.assert_array_equal(surface.N, surface.Ng)             # flat: the shading normal is Ng
    assert np.all(np.einsum("ij,ij->i", surface.Ng, directions[hit]) < 0.0)


def test_smooth_sphere_seen_from_inside_has_shading_normals_towards_the_centre():
    """From inside a smooth sphere both Ng and the interpolated N face the viewer: N = -(I - c)/|I - c|."""
    scene = Scene(camera=Camera())
    scene.add_mesh(primitives.uv_sphere(2.0, 32, 16))
    origins, directions = rays_from_inside()
    _, hit, surface = trace_surface(scene, np.zeros(3), origins, directions)
    assert hit.all() and surface.smooth.all()
    np.testing.assert_allclose(surface.N, -unit(surface.I), atol=FLOAT32_NORMAL_ATOL)
    assert np.all(np.einsum("ij,ij->i", surface.Ng, directions) < 0.0)


# ----------------------------------------------------------------------------
# World-space normals from core.geometry.geometry.build_geometry
# ----------------------------------------------------------------------------

def world_corner_normals(geometry):
    """Return (t, 3, 3) float64 corner normals of each world triangle (requires every triangle smooth)."""
    assert np.all(geometry.smooth_index >= 0)
    return geometry.corner_normals[geometry.smooth_index].astype(np.float64)


def test_mirrored_instances_keep_outward_face_normals_and_agreeing_corner_normals():
    """Negative-scale instances of a sphere: face normals point away from the centre, corner normals agree (dot > 0)."""
    mesh = primitives.uv_sphere(1.0, 16, 8)
    centers = np.array([[-4.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, -5.0, 1.0]])
    linears = [np.eye(3), np.diag([-1.0, 1.0, 1.0]), np.diag([1.5, -0.7, 1.0]),
               rotation([1.0, 1.0, 0.0], 0.4) @ np.diag([-1.0, -1.0, -1.0])]
    scene = Scene(camera=Camera())
    index = scene.add_mesh(mesh, affine(linears[0], centers[0]))
    for linear, center in zip(linears[1:], centers[1:]):
        scene.instances.append(Instance(index, affine(linear, center)))
    assert sum(np.linalg.det(m) < 0 for m in linears) == 3
    geometry = build_geometry(scene, np.zeros(3))
    assert len(geometry.triangles) == 4 * len(mesh.triangles)
    corners = geometry.vertices[geometry.triangles].astype(np.float64)
    centroids = corners.mean(axis=1)
    owner = np.argmin(np.linalg.norm(centroids[:, None, :] - centers[None], axis=2), axis=1)
    np.testing.assert_array_equal(np.bincount(owner), [len(mesh.triangles)] * 4)
    outward = np.einsum("ij,ij->i", geometry.face_normals, centroids - centers[owner])
    assert np.all(outward > 0.0)
    smooth = world_corner_normals(geometry)
    assert np.all(np.einsum("tij,tj->ti", smooth, geometry.face_normals) > 0.0)
    # For the pure mirror and the mirrored rotation the object is still a unit sphere: N = (p - c).
    for k in (1, 3):
        mine = owner == k
        np.testing.assert_allclose(smooth[mine], corners[mine] - centers[k], atol=FLOAT32_NORMAL_ATOL)


def test_non_uniformly_scaled_smooth_sphere_has_ellipsoid_corner_normals():
    """World corner normals of a scaled, rotated sphere equal the ellipsoid normals grad((q-t)^T (M M^T)^-1 (q-t))."""
    mesh = primitives.uv_sphere(1.0, 24, 12)
    linear = rotation([1.0, -2.0, 0.5], 0.8) @ np.diag([2.0, 1.0, 0.5])
    translation = np.array([1.0, 2.0, 3.0])
    scene = Scene(camera=Camera())
    scene.add_mesh(mesh, affine(linear, translation))
    geometry = build_geometry(scene, origin=np.array([0.5, 0.5, 0.5]))
    assert len(geometry.triangles) == len(mesh.triangles)
    world_points = mesh.vertices[mesh.triangles] @ linear.T                # (t, 3, 3) q - t, float64
    # The ellipsoid {q : (q - t)^T A (q - t) = 1} with A = (M M^T)^-1 has normal A (q - t).
    analytic = unit(world_points @ np.linalg.inv(linear @ linear.T).T)
    np.testing.assert_allclose(world_corner_normals(geometry), analytic, atol=FLOAT32_NORMAL_ATOL)
    # Transforming normals like points (M n) would be visibly wrong here.
    naive = unit(mesh.corner_normals @ linear.T)
    assert angle_between(naive, analytic).max() > 0.3


def test_flat_meshes_store_no_corner_normals():
    """Model only what a scene needs: flat meshes get smooth_index -1 and no corner-normal rows at all."""
    scene = Scene(camera=Camera())
    scene.add_mesh(primitives.plane(4.0))
    scene.add_mesh(primitives.box((1.0, 2.0, 3.0), center=(0.0, 0.0, 3.0)))
    scene.add_mesh(primitives.uv_sphere(1.0, 12, 6, center=(5.0, 0.0, 0.0), smooth=False))
    geometry = build_geometry(scene, np.zeros(3))
    assert len(geometry.triangles) == 2 + 12 + 12 * 6 * 2 - 2 * 12
    np.testing.assert_array_equal(geometry.smooth_index, -1)
    assert geometry.corner_normals.shape == (0, 3, 3)
    assert not geometry.has_smooth


def test_only_smooth_triangles_get_corner_normal_rows():
    """In a mixed scene exactly the smooth triangles get corner-normal rows, one each, numbered 0..s-1."""
    scene = Scene(camera=Camera())
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0)))
    sphere = primitives.uv_sphere(1.0, 12, 6, center=(4.0, 0.0, 0.0))
    scene.add_mesh(sphere)
    half = primitives.plane(2.0, center=(0.0, 4.0, 0.0))
    half.smooth = np.array([True, False])
    scene.add_mesh(half)
    geometry = build_geometry(scene, np.zeros(3))
    smooth = geometry.smooth_index >= 0
    assert smooth.sum() == len(sphere.triangles) + 1
    assert len(geometry.corner_normals) == smooth.sum()
    np.testing.assert_array_equal(np.sort(geometry.smooth_index[smooth]), np.arange(smooth.sum()))
    # The box (the first 12 triangles) stays flat.
    np.testing.assert_array_equal(geometry.smooth_index[:12], -1)


# ----------------------------------------------------------------------------
# Shading normals of a smooth sphere seen head-on
# ----------------------------------------------------------------------------

SPHERE_RADIUS = 1.0
SPHERE_CENTER = np.array([0.2, -0.1, 0.0])


def sphere_scene():
    """Return (scene, camera) of a smooth UV sphere under an orthographic camera looking straight down at it."""
    matrix = np.eye(4)
    matrix[:3, 3] = [SPHERE_CENTER[0], SPHERE_CENTER[1], 5.0]
    camera = Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.2, clip_start=0.1, clip_end=100.0)
    scene = Scene(camera=camera)
    scene.add_material((0.8, 0.8, 0.8))
    mesh = primitives.uv_sphere(SPHERE_RADIUS, 48, 24)
    scene.add_mesh(mesh, affine(np.eye(3), SPHERE_CENTER))
    return scene, camera, mesh


def test_smooth_sphere_shading_normal_is_radial_at_every_hit():
    """On a sphere whose corner normals are radial, the interpolated normal at a hit I is exactly (I - c)/|I - c|."""
    # Corners p_i = c + R n_i, so sum w_i n_i = (I - c) / R: interpolation reproduces the radial direction.
    scene, camera, _ = sphere_scene()
    ys, xs = np.mgrid[0:32, 0:32]
    rays = generate_rays(camera, 32, 32, xs.ravel() + 0.5, ys.ravel() + 0.5)
    origin = camera.position
    _, hit, surface = trace_surface(scene, origin, rays.origins, rays.directions)
    assert hit.sum() > 500 and surface.smooth.all()
    radial = unit(surface.I - (SPHERE_CENTER - origin))
    np.testing.assert_allclose(surface.N, radial, atol=1e-5)
    assert np.all(surface.N[:, 2] > 0.0)                   # faces the camera above
    # The face normal differs from it (up to the triangles' angular size): interpolation matters.
    assert angle_between(surface.Ng, radial).max() > 0.02


def test_smooth_sphere_rendered_normals_match_analytic_sphere_within_tessellation_error():
    """The rendered normal buffer of a smooth sphere equals the true sphere's normal within the tessellation bound."""
    width = 32
    scene, camera, mesh = sphere_scene()
    result = render(scene, RenderSettings(width=width, height=width, samples=1, jitter=False, aux=("normal", "face_normal")))
    normal, face = result.aux["normal"].astype(np.float64), result.aux["face_normal"].astype(np.float64)
    ys, xs = np.mgrid[0:width, 0:width]
    rays = generate_rays(camera, width, width, xs.ravel() + 0.5, ys.ravel() + 0.5)
    x = (rays.origins[:, 0] - SPHERE_CENTER[0]).reshape(width, width)
    y = (rays.origins[:, 1] - SPHERE_CENTER[1]).reshape(width, width)
    rho2 = x * x + y * y
    # The mesh lies between the sphere of radius R and the one of radius r_min (the smallest distance
    # from the centre to a triangle's plane), so the hit on a vertical ray has height between
    # sqrt(r_min^2 - rho^2) and sqrt(R^2 - rho^2). Since N = normalize(I - c) (test above), its angle to
    # the true normal is at most the angle between (x, y, z_true) and (x, y, z_low).
    faces = face_normals(mesh.vertices, mesh.triangles)
    r_min = np.min(np.abs(np.einsum("ij,ij->i", faces.normals, mesh.vertices[mesh.triangles[:, 0]])))
    inside = rho2 < r_min ** 2
    assert inside.sum() > 500
    z_true = np.sqrt(SPHERE_RADIUS ** 2 - rho2[inside])
    z_low = np.sqrt(r_min ** 2 - rho2[inside])
    true = np.stack([x[inside], y[inside], z_true], axis=1) / SPHERE_RADIUS
    bound = angle_between(true, np.stack([x[inside], y[inside], z_low], axis=1))
    error = angle_between(normal[inside], true)
    assert np.all(error <= bound + 1e-5)
    # Flat face normals break the same bound somewhere: the test tells smooth from flat shading.
    assert np.any(angle_between(face[inside], true) > bound + 1e-3)
    # Outside the sphere's silhouette nothing is hit and the normal buffer stays zero.
    np.testing.assert_array_equal(normal[rho2 > SPHERE_RADIUS ** 2 * 1.01], 0.0)
