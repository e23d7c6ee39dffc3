"""Simplify > Culling's tests (core/camera/culling.py), as Cycles' sync culls objects: closed forms on a camera
looking along -z from the origin (90 degrees across a square image: the frame spans x/depth in [-1, 1])."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from core.camera import Camera
from core.camera.culling import beyond_distance, box_corners, culled, outside_view

UNIT_BOX = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])


def camera(kind: str = "PERSP") -> Camera:
    """A camera at the origin looking down -z, 90 degrees wide (ortho: 4 units wide), clip 0.1 to 100."""
    looking = Camera.look_at(np.zeros(3), np.array([0.0, 0.0, -1.0]), up=(0.0, 1.0, 0.0), fov=math.radians(90.0),
                             ortho_scale=4.0, clip_start=0.1, clip_end=100.0)
    return dataclasses.replace(looking, type=kind)


def placed(x: float, y: float, z: float, scale: float = 1.0) -> np.ndarray:
    """The unit box scaled by `scale` and centred at (x, y, z): its 8 world corners."""
    matrix = np.diag([scale, scale, scale, 1.0])
    matrix[:3, 3] = (x, y, z)
    return box_corners(UNIT_BOX, matrix)


def test_a_box_in_view_stays_and_one_past_a_side_of_the_frame_is_culled():
    """The frame spans x / depth in [-1, 1]: a unit box at depth 10 and x = 0 or x = 10 (half inside) stays, one at
    x = 11 (its nearest corner 10.5 at depth 10.5: on the edge) is culled, as are ones above, below, to the left."""
    cam = camera()
    assert not outside_view(cam, 64, 64, (1.0, 1.0), placed(0.0, 0.0, -10.0), 0.0)
    assert not outside_view(cam, 64, 64, (1.0, 1.0), placed(10.0, 0.0, -10.0), 0.0)
    for x, y in ((11.0, 0.0), (-11.0, 0.0), (0.0, 11.0), (0.0, -11.0)):
        assert outside_view(cam, 64, 64, (1.0, 1.0), placed(x, y, -10.0), 0.0), (x, y)


def test_the_margin_widens_the_frame_by_its_fraction():
    """Margin 0.1 widens the normalised frame [0, 1] to [-0.1, 1.1], x / depth in [-1.2, 1.2]: the box at x = 11
    (its nearest corner 10.5 at depth 10.5: 1.0) stays, at x = 14 (13.5 / 10.5 = 1.29) it goes."""
    cam = camera()
    assert not outside_view(cam, 64, 64, (1.0, 1.0), placed(11.0, 0.0, -10.0), 0.1)
    assert outside_view(cam, 64, 64, (1.0, 1.0), placed(14.0, 0.0, -10.0), 0.1)


def test_a_box_behind_the_camera_is_culled_and_one_across_its_plane_is_not():
    """Every corner behind the near clip plane: culled. A large box around the camera: its mirrored corners span
    the frame, so it stays (Cycles' rule)."""
    cam = camera()
    assert outside_view(cam, 64, 64, (1.0, 1.0), placed(0.0, 0.0, 10.0), 0.0)
    assert not outside_view(cam, 64, 64, (1.0, 1.0), placed(0.0, 0.0, 0.0, scale=4.0), 0.0)


def test_an_orthographic_frame_is_its_scale_wide_at_any_depth():
    """Ortho scale 4: the frame spans x in [-2, 2] at every depth; a unit box at x = 2.4 (nearest corner 1.9) stays,
    at x = 2.6 (2.1) it is culled, near or far."""
    cam = camera("ORTHO")
    for depth in (-1.0, -50.0):
        assert not outside_view(cam, 64, 64, (1.0, 1.0), placed(2.4, 0.0, depth), 0.0)
        assert outside_view(cam, 64, 64, (1.0, 1.0), placed(2.6, 0.0, depth), 0.0)


def test_the_distance_is_to_the_boxs_closest_point():
    """A unit box centred 10 away along x: its closest point is 9.5 away; culled beyond 9, kept within 10."""
    corners = placed(10.0, 0.0, 0.0)
    assert beyond_distance(np.zeros(3), corners, 9.0)
    assert not beyond_distance(np.zeros(3), corners, 10.0)


def test_with_both_tests_on_an_object_is_culled_only_when_both_cull_it():
    """Cycles' rule: both flags on: culled = outside and beyond; one flag on: that test alone."""
    assert culled(True, True, True, True) and not culled(True, True, True, False)
    assert not culled(True, True, False, True)
    assert culled(True, False, True, False) and culled(False, True, False, True)
    assert not culled(False, False, True, True)
