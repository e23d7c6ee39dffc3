"""The film's alpha and background, as Cycles writes them: fisheye corners, world, transparent film."""
from __future__ import annotations

import numpy as np

from core.geometry import primitives
from core import render
from core.camera import Camera
from core.scene import RenderSettings, Scene, SunLight


def fisheye_scene() -> Scene:
    """A sunlit 2 x 2 plane seen from 3 above through a 180-degree equidistant fisheye on a wide image."""
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 3.0)
    scene = Scene(camera=Camera(matrix_world=matrix, type="PANO", panorama_type="FISHEYE_EQUIDISTANT"),
                  world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_mesh(primitives.plane(2.0))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=1.0))
    return scene


def test_fisheye_corners_are_opaque_black_and_misses_show_the_world():
    """Outside the image circle: (0, 0, 0, 1); a miss inside it: the world colour, alpha 1."""
    image = render.render(fisheye_scene(), RenderSettings(width=40, height=20, samples=4)).image
    np.testing.assert_array_equal(image[0, 0], [0.0, 0.0, 0.0, 1.0])          # corner, outside the circle
    np.testing.assert_allclose(image[10, 6], [0.1, 0.2, 0.3, 1.0], rtol=1e-6)  # inside the circle, the sky
    np.testing.assert_allclose(image[10, 20], [0.8 / np.pi] * 3 + [1.0], rtol=1e-6)   # the plane, straight down
    np.testing.assert_array_equal(image[..., 3], 1.0)


def test_transparent_film_clears_the_world_but_not_the_fisheye_corners():
    """With a transparent film a miss is (0, 0, 0, 0) (premultiplied); the corners stay opaque black."""
    image = render.render(fisheye_scene(), RenderSettings(width=40, height=20, samples=4,
                                                          transparent_background=True)).image
    np.testing.assert_array_equal(image[0, 0], [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(image[10, 6], [0.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(image[10, 20], [0.8 / np.pi] * 3 + [1.0], rtol=1e-6)
