"""Curves as tubes (core/geometry/curves.py): the spline through the control points, rings at the radius, faces
outward, and the tube's outline seen by a camera, against closed forms."""
from __future__ import annotations

import math

import numpy as np

from conftest import ortho_down
from core import render
from core.geometry import curves
from core.materials import Material
from core.scene import RenderSettings, Scene


def test_the_catmull_rom_spline_passes_through_its_middle_points_with_their_neighbours_chord_as_tangent():
    """At t = 0 and 1 the span is at p1 and p2; its tangent at t = 0 is (p2 - p0) / 2; at t = 1/2 it is
    (-p0 + 9 p1 + 9 p2 - p3) / 16."""
    p = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 1.0], [4.0, 4.0]])
    at = lambda t: curves.catmull_rom(p[0], p[1], p[2], p[3], np.array(t))  # noqa: E731
    np.testing.assert_allclose(at(0.0), p[1], atol=1e-15)
    np.testing.assert_allclose(at(1.0), p[2], atol=1e-15)
    np.testing.assert_allclose(at(0.5), (-p[0] + 9 * p[1] + 9 * p[2] - p[3]) / 16.0, atol=1e-15)
    h = 1e-6
    np.testing.assert_allclose((at(h) - at(0.0)) / h, (p[2] - p[0]) / 2.0, atol=1e-5)


def test_a_straight_curve_becomes_a_tube_of_its_radius_with_outward_faces_and_smooth_radial_normals():
    """Three points along x, radius 0.2: every ring vertex 0.2 from the axis, every fourth ring centred on a point
    (the spline passes through them and ends at both ends), the side normals radial and unit, each side triangle facing away from the axis, one cap at
    each end facing along -x and +x."""
    tubes = curves.tubes(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.full(3, 0.2), np.array([0]),
                         np.array([3]), sides=8, steps=4)
    mesh = tubes.mesh
    v = mesh.vertices
    ring = v[:-2]
    np.testing.assert_allclose(np.hypot(ring[:, 1], ring[:, 2]), 0.2, rtol=1e-12)
    along = np.unique(np.round(ring[:, 0], 12))          # 9 rings, through the points (between them, the spline's
    assert len(along) == 9 and (np.diff(along) > 0).all()  # pace: slower near the repeated end points)
    np.testing.assert_allclose(along[::4], [0.0, 1.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(v[-2:], [[0, 0, 0], [2, 0, 0]], atol=1e-15)
    a, b, c = (v[mesh.triangles[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    centroid = (a + b + c) / 3.0
    side = np.abs(centroid[:, 0] - np.clip(centroid[:, 0], 1e-9, 2 - 1e-9)) == 0.0
    side &= np.hypot(centroid[:, 1], centroid[:, 2]) > 0.15
    outward = centroid * [0.0, 1.0, 1.0]
    assert (np.einsum("ij,ij->i", normal[side], outward[side]) > 0).all()
    assert side.sum() == 2 * 8 * 8
    caps = ~side
    assert caps.sum() == 2 * 8
    np.testing.assert_allclose(np.sign(normal[caps, 0]), np.where(centroid[caps, 0] < 1.0, -1.0, 1.0))
    n = mesh.corner_normals[side]
    np.testing.assert_allclose(np.linalg.norm(n, axis=2), 1.0, rtol=1e-12)
    np.testing.assert_allclose(n[..., 0], 0.0, atol=1e-12)
    assert len(tubes.curve) == len(mesh.triangles) and (tubes.curve == 0).all()


def test_a_glowing_tube_seen_side_on_covers_its_diameter_times_its_length():
    """An emitting straight tube of radius r = 0.25 and length 4 seen from above by an orthographic camera: the
    pixels it covers sum to between 2 r cos(pi / sides) x 4 and 2 r x 4 (its inscribed polygon's width), plus its
    two caps' half-discs; its pixels shine at the emission."""
    r, sides = 0.25, 12
    scene = Scene(camera=ortho_down(height=5.0, scale=6.0))
    scene.materials.append(Material(np.zeros(3), emission=np.ones(3)))
    scene.add_mesh(curves.tubes(np.array([[-2.0, 0, 0], [0, 0, 0], [2, 0, 0]]), np.full(3, r), np.array([0]),
                                np.array([3]), sides=sides).mesh)
    settings = RenderSettings(width=120, height=120, samples=16, seed=2)
    image = render.render(scene, settings).image[..., 0]
    area = image.sum() * (6.0 / 120) ** 2
    low, high = 2 * r * math.cos(math.pi / sides) * 4.0, 2 * r * 4.0 + math.pi * r * r
    print(area, low, high)
    assert low * 0.99 < area < high * 1.01
    assert image.max() == 1.0


def test_a_point_becomes_a_closed_sphere_of_its_radius_with_outward_faces_and_radial_normals():
    """Two points of radius 0.5 and 0.25: 320 triangles each, every vertex on its sphere, every face turned away from
    its centre, the corner normals the unit directions from the centre; the faces enclose about the sphere's
    volume (4/3 pi r^3, inscribed: 3.4 % less)."""
    from core.geometry import points
    centres, radius = np.array([[0.0, 0.0, 0.0], [3.0, 1.0, 2.0]]), np.array([0.5, 0.25])
    mesh, point = points.spheres(centres, radius, subdivisions=2)
    assert len(mesh.triangles) == 640 and (np.bincount(point) == 320).all()
    v = mesh.vertices
    own = np.repeat(np.arange(2), len(v) // 2)
    np.testing.assert_allclose(np.linalg.norm(v - centres[own], axis=1), radius[own], rtol=1e-12)
    a, b, c = (v[mesh.triangles[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    assert (np.einsum("ij,ij->i", normal, (a + b + c) / 3.0 - centres[point]) > 0).all()
    corner = v[mesh.triangles] - centres[point][:, None, :]
    np.testing.assert_allclose(mesh.corner_normals, corner / np.linalg.norm(corner, axis=2, keepdims=True), atol=1e-12)
    volume = np.bincount(point, np.einsum("ij,ij->i", a - centres[point], np.cross(b - centres[point],
                                                                                   c - centres[point])) / 6.0)
    exact = 4.0 / 3.0 * math.pi * radius ** 3
    assert ((volume < exact) & (volume > 0.96 * exact)).all(), volume / exact
