"""Heterogeneous media (core/volumes/field.py: a volume input fed by nodes, marched along each ray) held to closed
forms: an absorbing slab whose density grows linearly with height keeps exp(-its integral) on camera and shadow
rays; a graph that is constant renders the homogeneous medium's image; an emitting slab of linear emission sends
its integral; the march's free flight draws distances by its own density."""
from __future__ import annotations

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import SunLight
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.render import render
from core.scene import RenderSettings, Scene
from core.volumes import Media, field as field_

COLOR = np.array([0.2, 0.5, 0.8])


def camera_above(height: float = 3.0) -> Camera:
    """An orthographic camera `height` above the origin, looking straight down."""
    matrix = np.eye(4)
    matrix[2, 3] = height
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=20.0)


def height(scale: float = 1.0, offset: float = 0.0) -> Link:
    """A graph: scale x (the point's object z) + offset (Texture Coordinate > Object > Z, Multiply Add)."""
    coords = GraphNode("TEXCOORD")
    z = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Object")}), "Z")
    return Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": z, "1": scale, "2": offset}), "Value")


def slab(closure: str = "ABSORPTION", **inputs) -> Material:
    """A volume-only material of one closure."""
    return Material(np.zeros(3), "Slab", nodes=[("TRANSPARENT", np.ones(3), {})], volume=[(closure, 1.0, inputs)],
                    volume_only=True)


def scene_with(material: Material, emission=(1.0, 2.0, 0.5), low: float = 0.5, high: float = 1.5) -> Scene:
    """An emitting floor at z = 0 under a volume-only box from z = low to z = high holding `material`'s medium."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.asarray(emission, np.float64)))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(material)
    scene.add_mesh(primitives.box((4.0, 4.0, high - low), center=(0.0, 0.0, 0.5 * (low + high))),
                   materials=np.array([1]))
    return scene


def image(scene: Scene, **settings) -> np.ndarray:
    """The scene rendered at 4 x 4 (RGB (4, 4, 3)) by the path tracer."""
    settings = {"width": 4, "height": 4, "samples": 2, "integrator": "path", **settings}
    return render(scene, RenderSettings(**settings)).image[..., :3]


def test_a_slab_whose_density_grows_linearly_keeps_exp_of_minus_its_integral():
    """Density 2 z + 0.5 from z = 0.5 to 1.5 (its integral 2.5): each channel keeps exp(-2.5 (1 - colour)) of the
    floor's light (the march's midpoints integrate a linear density exactly)."""
    scene = scene_with(slab(color=COLOR, density=height(2.0, 0.5)))
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-2.5 * (1.0 - COLOR))
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_a_sun_through_a_linear_slab_at_an_angle_keeps_exp_of_the_integral_along_its_slanted_path():
    """A white floor lit by a sun 60 degrees up through density 2 z + 0.5 (integral 2.5 vertically): the camera sees
    albedo / pi x E exp(-2.5 (1 - colour) (1 + 1 / sin 60))."""
    scene = scene_with(slab(color=COLOR, density=height(2.0, 0.5)))
    scene.materials[0] = Material(np.full(3, 0.8), "Floor")
    elevation = np.radians(60.0)
    direction = np.array([np.cos(elevation), 0.0, np.sin(elevation)])
    scene.lights.append(SunLight(direction=-direction, strength=3.0))
    sigma = 2.5 * (1.0 - COLOR)
    expected = 0.8 / np.pi * 3.0 * np.sin(elevation) * np.exp(-sigma * (1.0 + 1.0 / np.sin(elevation)))
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_a_constant_graph_renders_the_homogeneous_medium():
    """A Scatter whose density is a graph of constant value 1.3 renders as the homogeneous Scatter of density 1.3
    under a sun (single scattering), within the noise of 64 samples."""
    sun = SunLight(direction=-np.array([0.3, 0.0, 1.0]) / np.linalg.norm([0.3, 0.0, 1.0]), strength=2.0)
    images = []
    for density in (height(0.0, 1.3), 1.3):
        scene = scene_with(slab("SCATTER", color=COLOR, density=density, anisotropy=0.3), emission=(0.0, 0.0, 0.0))
        scene.lights.append(sun)
        images.append(image(scene, samples=64))
    mean = [im.reshape(-1, 3).mean(axis=0) for im in images]
    np.testing.assert_allclose(mean[0], mean[1], rtol=0.03)


def test_an_emitting_slab_of_linear_emission_sends_its_integral():
    """An Emission volume of strength 2 z + 0.5 between z = 0.5 and 1.5 over a black floor: emission x 2.5."""
    scene = scene_with(slab("EMISSION", color=np.array([1.0, 0.5, 0.25]), strength=height(2.0, 0.5)),
                       emission=(0.0, 0.0, 0.0))
    expected = np.array([1.0, 0.5, 0.25]) * 2.5
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)
