"""Depth of field (core/camera/camera.py, camera.c), without Blender: the thin lens's closed forms and both kernels.

A thin lens of aperture radius A focused at distance f sends the rays of one image point from every point L of its
aperture towards the point the pinhole ray meets at depth f. At depth z they spread over the aperture's shape scaled
by |1 - z / f| around the pinhole ray's point: a point in the plane in focus is sharp, any other is a disk (or the
blades' polygon) of radius A |1 - z / f|, the circle of confusion.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.camera import camera as camera_
from core.camera import Camera
from core.sampling import sobol as sampling

FOCUS, APERTURE = 4.0, 0.05


def lens_camera(kind: str = "PERSP", **dof) -> Camera:
    """A camera at the origin looking down -Z (its local frame is the world's), with a thin lens."""
    settings = dict(aperture_size=APERTURE, focus_distance=FOCUS)
    settings.update(dof)
    return Camera(type=kind, ortho_scale=2.0, clip_start=0.1, clip_end=100.0, **settings)


def rays_of_one_point(camera: Camera, n: int = 4096, raster=(13.3, 7.6)):
    """The camera rays through one raster point of a 32 x 16 image from n points of the aperture (uniform numbers)."""
    u = np.random.default_rng(5).random((n, 2))
    return camera_.generate_rays(camera, 32, 16, np.full(n, raster[0]), np.full(n, raster[1]), lens=u)


def at_depth(rays, z: float) -> np.ndarray:
    """Where the rays cross the plane at depth z in front of the camera (z = -depth in its frame): (n, 2) x, y."""
    t = (-z - rays.origins[:, 2]) / rays.directions[:, 2]
    return (rays.origins + t[:, None] * rays.directions)[:, :2]


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_the_plane_in_focus_is_sharp_and_others_blur_by_the_circle_of_confusion(kind):
    """All rays of a point meet at the focus distance; at depth z they fill a disk of radius A |1 - z / f| (a
    perspective camera) around the pinhole's point; the near clip plane is where they start, as Cycles clips."""
    camera = lens_camera(kind)
    rays = rays_of_one_point(camera)
    focus = at_depth(rays, FOCUS)
    assert np.abs(focus - focus.mean(axis=0)).max() < 1e-12
    pinhole = camera_.generate_rays(dataclasses.replace(camera, aperture_size=0.0), 32, 16, [13.3], [7.6])
    for z in (1.0, 2.5, 9.0):
        spread = at_depth(rays, z) - at_depth(pinhole, z)[0]
        radius = np.linalg.norm(spread, axis=1)
        expected = APERTURE * abs(1.0 - z / FOCUS)
        assert radius.max() <= expected * (1 + 1e-9) and radius.max() > 0.98 * expected, (z, radius.max(), expected)
        assert np.abs(spread.mean(axis=0)).max() < 0.03 * expected       # centred on the pinhole ray's point
    if kind == "PERSP":                 # each ray starts where it has come clip_start / cos(pinhole's angle) from the lens
        cos_to_axis = -pinhole.directions[0, 2]
        lens = camera_.aperture_points(camera, np.random.default_rng(5).random((4096, 2)))
        travelled = np.linalg.norm(rays.origins - np.c_[lens, np.zeros(4096)], axis=1)
        np.testing.assert_allclose(travelled, 0.1 / cos_to_axis, rtol=1e-12)


def test_the_aperture_is_uniform_over_its_disk_and_the_ratio_narrows_it():
    """The concentric map covers the disk of radius A uniformly: mean 0, mean squared radius A^2 / 2; an anamorphic
    ratio of 2 halves its width."""
    u = np.random.default_rng(2).random((200000, 2))
    points = camera_.aperture_points(lens_camera(), u)
    assert np.linalg.norm(points, axis=1).max() <= APERTURE * (1 + 1e-12)
    assert np.abs(points.mean(axis=0)).max() < 1e-3 * APERTURE
    assert (np.einsum("ij,ij->i", points, points).mean() / APERTURE ** 2) == pytest.approx(0.5, rel=5e-3)
    narrow = camera_.aperture_points(lens_camera(aperture_ratio=2.0), u)
    assert np.abs(narrow[:, 0]).max() == pytest.approx(APERTURE / 2.0, rel=1e-3)
    assert np.abs(narrow[:, 1]).max() == pytest.approx(APERTURE, rel=1e-3)


@pytest.mark.parametrize("blades", [3, 5, 6])
def test_blades_make_a_regular_polygon_filled_uniformly(blades):
    """With b blades the aperture is the regular b-gon inscribed in the circle of radius A, turned by the rotation:
    every point inside it (within each edge's half-plane), its area filled evenly (each corner's triangle a 1 / b
    share; the mean squared radius of the triangle (0, a, b) with |a| = |b| = 1 is (2 + cos(2 pi / b)) / 6)."""
    rotation = 0.3
    u = np.random.default_rng(3).random((200000, 2))
    points = camera_.aperture_points(lens_camera(aperture_blades=blades, aperture_rotation=rotation), u) / APERTURE
    # (As Cycles' regular_polygon_sample: the edges' middles at rotation + 2 pi k / b, the corners between them.)
    # Inside: on the inner side of every edge.
    for k in range(blades):
        middle = rotation + 2.0 * math.pi * k / blades
        normal = np.array([math.cos(middle), math.sin(middle)])
        assert (points @ normal).max() <= math.cos(math.pi / blades) + 1e-12
        assert (points @ normal).max() > 0.99 * math.cos(math.pi / blades)
    # Uniform: each of the b triangles (centre, corner k, corner k + 1) gets 1 / b of the points; the mean squared
    # radius of a triangle (0, a, b) is (|a|^2 + |b|^2 + a.b) / 6.
    angle = np.mod(np.arctan2(points[:, 1], points[:, 0]) - rotation + math.pi / blades, 2.0 * math.pi)
    share = np.bincount((angle // (2.0 * math.pi / blades)).astype(int), minlength=blades) / len(points)
    assert np.abs(share - 1.0 / blades).max() < 0.01
    r2 = (2.0 + math.cos(2.0 * math.pi / blades)) / 6.0
    assert np.einsum("ij,ij->i", points, points).mean() == pytest.approx(r2, rel=5e-3)


@pytest.mark.parametrize("kind, panorama, blades", [("PERSP", "", 0), ("PERSP", "", 6), ("ORTHO", "", 0),
                                                    ("PANO", "EQUIRECTANGULAR", 5), ("PANO", "FISHEYE_EQUISOLID", 5),
                                                    ("PANO", "MIRRORBALL", 5)])
def test_compiled_lens_rays_follow_the_reference(kind, panorama, blades):
    """camera.c's rays with depth of field are generate_rays' with the same lens numbers (LENS_DIMENSION), for every
    kind of camera (a panorama's where it has a direction)."""
    from core.camera import Camera as C
    camera = dataclasses.replace(C.look_at((0.3, -4.0, 2.0), (0.0, 0.0, 0.5)), type=kind, ortho_scale=3.0,
                                 aperture_size=0.08, focus_distance=3.5, aperture_blades=blades, aperture_rotation=0.4,
                                 aperture_ratio=1.3, **({"panorama_type": panorama} if panorama else {}))
    W, H, spp, seed = 37, 23, 5, 11
    pixels = np.arange(0, W * H, 3, dtype=np.int64)
    first = (pixels % 4).astype(np.int64)
    origin = np.array([0.5, -0.25, 2.0])
    record = camera_.camera_record(camera, W, H, (1.0, 1.2), origin)
    O, D, t, valid = camera_.compiled_rays(record, seed, W, H, pixels, first, spp)
    pixel, sample = render.sample_keys(pixels, spp, first)
    offset = sampling.sample_2d(seed, pixel, sample, 0)
    lens = sampling.sample_2d(seed, pixel, sample, camera_.LENS_DIMENSION)
    rays = camera_.generate_rays(camera.moved(origin), W, H, pixel % W + offset[:, 0], pixel // W + offset[:, 1],
                                 (1.0, 1.2), lens)
    pinhole = camera_.generate_rays(dataclasses.replace(camera, aperture_size=0.0).moved(origin), W, H,
                                    pixel % W + offset[:, 0], pixel // W + offset[:, 1], (1.0, 1.2))
    seen = rays.valid.astype(bool)
    assert seen.sum() > 100
    np.testing.assert_array_equal(valid.astype(bool), seen)
    assert np.abs(rays.directions[seen] - pinhole.directions[seen]).max() > 1e-3        # the lens moved them
    np.testing.assert_allclose(O[seen], rays.origins[seen], rtol=0, atol=1e-13)
    np.testing.assert_allclose(D[seen], rays.directions[seen], rtol=0, atol=1e-14)
    np.testing.assert_allclose(t[seen], rays.t_max[seen], rtol=1e-15, atol=0)


def along(rays, pinhole, z: float) -> np.ndarray:
    """Where the rays cross the plane at distance z along the pinhole ray, across it (n, 3) from its point there."""
    D = pinhole.directions[0]
    t = (z - rays.origins @ D) / (rays.directions @ D)
    return rays.origins + t[:, None] * rays.directions - z * D


@pytest.mark.parametrize("panorama", ["EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "MIRRORBALL"])
def test_a_panoramas_rays_meet_at_the_focus_distance_along_the_pinhole_ray_and_blur_by_the_circle_of_confusion(
        panorama):
    """Cycles' panorama lens: each ray leaves its aperture point on the plane across the pinhole ray through the
    camera, towards the pinhole ray's point at the focus distance; on the plane across that ray at distance z they
    fill a disk of radius A |1 - z / f| about its point, and they start clip_start along themselves."""
    camera = dataclasses.replace(lens_camera("PANO"), panorama_type=panorama, fisheye_fov=math.radians(170.0))
    rays = rays_of_one_point(camera, raster=(12.3, 6.6))
    pinhole = camera_.generate_rays(dataclasses.replace(camera, aperture_size=0.0), 32, 16, [12.3], [6.6])
    assert rays.valid.all() and pinhole.valid.all()
    assert np.abs(along(rays, pinhole, FOCUS)).max() < 1e-12
    for z in (1.0, 2.5, 9.0):
        radius = np.linalg.norm(along(rays, pinhole, z), axis=1)
        expected = APERTURE * abs(1.0 - z / FOCUS)
        assert expected * 0.98 < radius.max() <= expected * (1 + 1e-9), (z, radius.max(), expected)
    start = rays.origins - 0.1 * rays.directions                       # the aperture's points
    np.testing.assert_allclose(start @ pinhole.directions[0], 0.0, atol=1e-15)
    assert np.linalg.norm(start, axis=1).max() <= APERTURE * (1 + 1e-12)
