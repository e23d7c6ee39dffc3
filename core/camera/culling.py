"""Simplify > Culling, as Cycles' Blender sync culls objects (blender/object_cull.cpp): an object whose bounding box
lies outside the camera's view (Camera Culling, with a margin) or farther from the camera than a distance (Distance
Culling) is left out of the render entirely: its shadows and its light on other objects go with it.

The camera test projects the box's 8 corners into the frame's normalised coordinates (0..1 across the image, shift
included) as Cycles' worldtondc does: a corner in front of the near clip plane (depth below clip_start) counts as
behind and is mirrored, as Cycles mirrors it; the box is culled when every corner is behind (beyond the margin), or
when the corners' extent lies wholly past one side of the frame widened by the margin. The distance test takes the
box's point closest to the camera. With both on, an object is culled only when both tests cull it.
"""
from __future__ import annotations

import numpy as np

from .camera import Camera, viewplane, world_to_camera


def box_corners(local_box: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """The 8 corners of an object's local bounding box (8, 3) placed by its (4, 4) matrix: (8, 3) float64."""
    corners = np.asarray(local_box, np.float64).reshape(8, 3)
    return corners @ np.asarray(matrix, np.float64)[:3, :3].T + np.asarray(matrix, np.float64)[:3, 3]


def outside_view(camera: Camera, width: int, height: int, pixel_aspect: tuple, corners: np.ndarray,
                 margin: float) -> bool:
    """Whether the box of world corners (8, 3) is out of the view of `camera` (PERSP or ORTHO) rendering width x height
    pixels, by Cycles' test_camera with its Camera Cull margin (a fraction of the frame)."""
    P = corners @ world_to_camera(camera)[:, :3].T + world_to_camera(camera)[:, 3]   # (x, y, depth along the view)
    left, right, bottom, top = viewplane(camera, width, height, pixel_aspect)
    near, far = float(camera.clip_start), float(camera.clip_end)
    if camera.type == "PERSP":
        w = P[:, 2]
        clip_z = far / (far - near) * (P[:, 2] - near)          # Cycles' projection_perspective's z row
    else:
        w = np.ones(len(P))
        clip_z = (P[:, 2] - near) / (far - near)                # projection_orthographic's
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (P[:, 0] / w - left) / (right - left)
        y = (P[:, 1] / w - bottom) / (top - bottom)
    behind = clip_z < 0.0
    x, y = np.where(behind, 1.0 - x, x), np.where(behind, 1.0 - y, y)
    if (clip_z < -margin).all():
        return True
    return bool(x.min() >= 1.0 + margin or y.min() >= 1.0 + margin or x.max() <= -margin or y.max() <= -margin)


def beyond_distance(position: np.ndarray, corners: np.ndarray, distance: float) -> bool:
    """Whether the box of world corners (8, 3) lies farther than `distance` from the camera `position` (3,) (Cycles'
    test_distance: the box's closest point)."""
    closest = np.clip(np.asarray(position, np.float64), corners.min(axis=0), corners.max(axis=0))
    return float(np.sum((np.asarray(position, np.float64) - closest) ** 2)) > distance * distance


def culled(camera_cull: bool, distance_cull: bool, outside: bool, beyond: bool) -> bool:
    """Cycles' rule: with both tests on an object is culled only when both cull it, else by the one that is on."""
    if camera_cull and distance_cull:
        return outside and beyond
    return (camera_cull and outside) or (distance_cull and beyond)
