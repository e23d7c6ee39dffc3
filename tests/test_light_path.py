"""The Light Path node (core/materials/graph.py LightPath, graph.c light_path_output) on both kernels: what each output
reads, with Cycles' meaning (svm_node_light_path, path_state_next), wherever a shader is evaluated.

Each scene shows an output as light, so that a pixel is the output's value (or a closed form of it):
- an emitter seen in a mirror: the emitter is shaded for the mirror's reflected ray (a singular glossy reflection:
  Is Glossy, Is Singular, Is Reflection Ray 1, Ray Depth and Glossy Depth 1, Ray Length its distance);
- an emitter seen straight down through a stack of clear Transparent planes: still a camera ray (Is Camera Ray 1,
  Ray Depth 0) with Transparent Depth the planes passed; through glass of index 1, a singular transmission;
- a floor lit by a sun through a plane whose transparency is a Light Path output: the plane is shaded for the shadow
  ray (Is Shadow Ray 1, Ray Depth one more than the floor's, Transparent Depth the path's so far);
- an emitter seen through Ray Portals, one of them teleporting the rays: each counts in Portal Depth and, as a
  transparent bounce, in Transparent Depth; the path's shadow rays carry the count.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.geometry import primitives
from core.materials import Material
from core.materials.graph import LIGHT_PATH_OUTPUTS, GraphNode, Link
from core.scene import RenderSettings, Scene, SunLight

KERNELS = ["compiled", "numpy"]
SIZE = 4


def light_path(output: str) -> Link:
    """An output of a Light Path node."""
    return Link(GraphNode("LIGHT_PATH", {}, {}), output)


def math_node(operation: str, a, b) -> Link:
    """A Math node's Value of a and b (constants or links)."""
    return Link(GraphNode("MATH", {"operation": operation}, {"0": a, "1": b}), "Value")


def emitter(value: Link, name: str = "Shown") -> Material:
    """An Emission of strength 1 whose colour is `value` (a float read as grey)."""
    return Material(name=name, nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": value})])


def shoot(scene: Scene, kernels: str, integrator: str = "path", **settings) -> np.ndarray:
    """The rendered red channel (SIZE, SIZE), four samples per pixel."""
    result = render.render(scene, RenderSettings(width=SIZE, height=SIZE, samples=4, kernels=kernels,
                                                 integrator=integrator, **settings))
    assert result.stats.kernels.startswith(kernels)
    return result.image[..., 0]


def mirror_scene(output: str) -> Scene:
    """A mirror tilted 45 degrees about x under an orthographic camera looking down, turning every camera ray
    towards +y, and a wall at y = 3 facing it that emits the Light Path output `output`."""
    scene = Scene(camera=ortho_down(height=5.0, scale=1.0))
    scene.materials += [Material(name="Mirror", nodes=[("MIRROR", (1.0, 1.0, 1.0), {})]), emitter(light_path(output))]
    mirror = primitives.plane(4.0)
    a = math.radians(-45.0)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])
    mirror.vertices = mirror.vertices @ turn.T
    scene.add_mesh(mirror, materials=np.array([0]))
    wall = primitives.plane(20.0)
    wall.vertices = wall.vertices[:, [0, 2, 1]] + [0.0, 3.0, 0.0]      # the plane y = 3
    wall.triangles = wall.triangles[:, ::-1].copy()                       # facing -y, towards the mirror
    scene.add_mesh(wall, materials=np.array([1]))
    return scene


MIRRORED = {"Is Camera Ray": 0.0, "Is Shadow Ray": 0.0, "Is Diffuse Ray": 0.0, "Is Glossy Ray": 1.0,
            "Is Singular Ray": 1.0, "Is Reflection Ray": 1.0, "Is Transmission Ray": 0.0, "Is Volume Scatter Ray": 0.0,
            "Ray Depth": 1.0, "Diffuse Depth": 0.0, "Glossy Depth": 1.0, "Transparent Depth": 0.0,
            "Transmission Depth": 0.0, "Portal Depth": 0.0}


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("output", list(MIRRORED))
def test_an_emitter_seen_in_a_mirror_is_shaded_for_a_singular_glossy_reflection_one_bounce_deep(kernels, output):
    image = shoot(mirror_scene(output), kernels)
    np.testing.assert_array_equal(image, np.float32(MIRRORED[output]))


@pytest.mark.parametrize("output", ["Is Camera Ray", "Is Glossy Ray", "Is Singular Ray", "Ray Depth", "Glossy Depth"])
def test_whitteds_mirror_rays_are_singular_glossy_reflections_too(output):
    """The lecture's Whitted tracer (the reference kernel alone) hands the same path to what its mirror rays meet."""
    np.testing.assert_array_equal(shoot(mirror_scene(output), "numpy", "whitted"), np.float32(MIRRORED[output]))


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_emitter_seen_in_a_mirror_reads_the_reflected_rays_length(kernels):
    """Each pixel's ray meets the mirror at z = y (the 45-degree plane) and goes on along +y to the wall at y = 3: its
    length there is 3 - y of the pixel centre's row (ortho scale 1: rows at y = +-0.375, +-0.125)."""
    image = shoot(mirror_scene("Ray Length"), kernels)
    y = (np.arange(SIZE)[::-1] + 0.5) / SIZE - 0.5                  # image rows top first: y from +0.375 down
    expected = np.broadcast_to((3.0 - y)[:, None], (SIZE, SIZE))
    np.testing.assert_allclose(image, expected, atol=0.13)           # (a pixel's samples spread over its height)
    assert (np.diff(image[:, 0]) > 0.0).all()                        # farther down the image, farther to the wall


def stack_scene(output: str, planes: int) -> Scene:
    """`planes` white Transparent planes at z = 1, 2, ... above a floor at z = 0 that emits the Light Path output
    `output`, under an orthographic camera looking down."""
    scene = Scene(camera=ortho_down(height=planes + 2.0, scale=1.0))
    clear = Material(name="Clear", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})])
    scene.materials += [clear, emitter(light_path(output))]
    for k in range(planes):
        scene.add_mesh(primitives.plane(4.0, center=(0.0, 0.0, 1.0 + k)), materials=np.array([0]))
    scene.add_mesh(primitives.plane(4.0), materials=np.array([1]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["path", "direct"])
@pytest.mark.parametrize("output, expected", [("Transparent Depth", 3.0), ("Is Camera Ray", 1.0), ("Ray Depth", 0.0),
                                              ("Is Reflection Ray", 0.0)])
def test_a_camera_ray_through_clear_planes_stays_a_camera_ray_and_counts_them_as_transparent_depth(
        kernels, integrator, output, expected):
    image = shoot(stack_scene(output, 3), kernels, integrator)
    np.testing.assert_array_equal(image, np.float32(expected))


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("output, expected", [("Is Transmission Ray", 1.0), ("Transmission Depth", 1.0),
                                              ("Is Singular Ray", 1.0), ("Is Glossy Ray", 1.0), ("Ray Depth", 1.0),
                                              ("Is Reflection Ray", 0.0), ("Is Camera Ray", 0.0),
                                              ("Glossy Depth", 0.0)])
def test_an_emitter_seen_through_glass_of_index_one_is_shaded_for_a_singular_transmission(kernels, output, expected):
    """A smooth Glass of IOR 1 lets the camera ray straight through (Fresnel 0): a refraction, one bounce deep."""
    scene = stack_scene(output, 1)
    scene.materials[0] = Material(name="Glass", nodes=[("GLASS", (1.0, 1.0, 1.0), {"ior": 1.0, "roughness": 0.0})])
    np.testing.assert_array_equal(shoot(scene, kernels), np.float32(expected))


PORTAL_AWAY = {"position_set": 1.0, "position": (100.0, 0.0, 3.0)}   # (a world point: rays leave from there)


def portal_scene(output: str) -> Scene:
    """A Ray Portal pane at z = 1 under an orthographic camera looking down sends every camera ray on from
    (100, 0, 3), downwards as it was; there the ray passes a Ray Portal in place (z = 2: straight on) and a clear
    Transparent plane (z = 1) to a floor at z = 0 that emits the Light Path output `output`."""
    scene = Scene(camera=ortho_down(height=3.0, scale=1.0))
    scene.materials += [Material(name="Away", nodes=[("RAY_PORTAL", (1.0, 1.0, 1.0), PORTAL_AWAY)]),
                        Material(name="In place", nodes=[("RAY_PORTAL", (1.0, 1.0, 1.0), {})]),
                        Material(name="Clear", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})]),
                        emitter(light_path(output))]
    scene.add_mesh(primitives.plane(4.0, center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    for k in (1, 2):
        scene.add_mesh(primitives.plane(4.0, center=(100.0, 0.0, 3.0 - k)), materials=np.array([k]))
    scene.add_mesh(primitives.plane(4.0, center=(100.0, 0.0, 0.0)), materials=np.array([3]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["path", "direct"])
@pytest.mark.parametrize("output, expected", [("Portal Depth", 2.0), ("Transparent Depth", 3.0),
                                              ("Is Camera Ray", 1.0), ("Ray Depth", 0.0)])
def test_a_camera_ray_through_ray_portals_counts_them_as_portal_depth_and_as_transparent_depth(
        kernels, integrator, output, expected):
    """Cycles' path_state_next: a Ray Portal's ray is a transparent bounce (the flags kept, Transparent Depth one
    more) that adds one to Portal Depth too, wherever the portal sends it; a Transparent BSDF adds to Transparent
    Depth alone. Two portals and one clear plane: Portal Depth 2, Transparent Depth 3, still a camera ray, exactly."""
    np.testing.assert_array_equal(shoot(portal_scene(output), kernels, integrator), np.float32(expected))


def shadow_scene(transparency) -> Scene:
    """A white diffuse floor at z = 0 under a plane at z = 1 that lets `transparency` through (a Transparent BSDF's
    colour, a Link; None: all), lit straight down by a sun of strength pi; the camera looks down through the plane."""
    scene = Scene(camera=ortho_down(height=3.0, scale=1.0))
    scene.materials += [Material(name="Floor", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"roughness": 0.0})]),
                        Material(name="Pane", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {},
                                                      [] if transparency is None else [(transparency, "color")])])]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    scene.lights = [SunLight(np.array([0.0, 0.0, -1.0]), strength=math.pi)]
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("output, scale, expected", [
    ("Is Shadow Ray", 0.5, 0.5),        # the pane is shaded for the shadow ray
    ("Ray Depth", 0.5, 0.5),            # the floor's depth 0, one more for its shadow ray
    ("Transparent Depth", 0.25, 0.25),  # the camera ray passed the pane once before: the shadow ray's count goes on
    ("Is Diffuse Ray", 1.0, 0.0)])      # a shadow ray carries SHADOW alone
def test_a_pane_in_a_shadow_ray_is_shaded_for_that_shadow_ray(kernels, output, scale, expected):
    """The pane is clear to camera rays (its colour max(Is Camera Ray, scale x output)); the floor's radiance is
    albedo / pi x sun x cos = 1 times what the pane lets the shadow ray through."""
    pane = math_node("MAXIMUM", light_path("Is Camera Ray"), math_node("MULTIPLY", light_path(output), scale))
    image = shoot(shadow_scene(pane), kernels, max_bounces=0)
    np.testing.assert_allclose(image, expected, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_shadow_ray_carries_the_portal_depth_of_its_path(kernels):
    """shadow_scene moved to x = 100 and seen through a Ray Portal pane (z = 2 over the origin) that sends the camera
    rays on from (100, 0, 0.5) below its pane: the pane lets max(Is Camera Ray, 0.5 x Portal Depth) through, and the
    floor's shadow rays carry its path's Portal Depth 1 (Cycles copies portal_bounce into the shadow path): 0.5."""
    pane = math_node("MAXIMUM", light_path("Is Camera Ray"), math_node("MULTIPLY", light_path("Portal Depth"), 0.5))
    scene = shadow_scene(pane)
    scene.meshes.clear()
    scene.instances.clear()
    scene.materials.append(Material(name="Away", nodes=[("RAY_PORTAL", (1.0, 1.0, 1.0),
                                                          {"position_set": 1.0, "position": (100.0, 0.0, 0.5)})]))
    scene.add_mesh(primitives.plane(40.0, center=(100.0, 0.0, 0.0)), materials=np.array([0]))
    scene.add_mesh(primitives.plane(40.0, center=(100.0, 0.0, 1.0)), materials=np.array([1]))
    scene.add_mesh(primitives.plane(4.0, center=(0.0, 0.0, 2.0)), materials=np.array([2]))
    image = shoot(scene, kernels, max_bounces=0)
    np.testing.assert_allclose(image, 0.5, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_shadow_rays_length_at_each_pane_is_measured_from_where_it_left_the_floor(kernels):
    """Two panes at heights 1 and 2, each letting Ray Length / 4 of the shadow ray through (and all of the camera's):
    Cycles measures every hit of its one shadow ray from its start, so the floor gets 1/4 x 2/4 of the sun's light."""
    pane = math_node("MAXIMUM", light_path("Is Camera Ray"), math_node("MULTIPLY", light_path("Ray Length"), 0.25))
    scene = shadow_scene(pane)
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    scene.camera = ortho_down(height=4.0, scale=1.0)
    image = shoot(scene, kernels, max_bounces=0)
    np.testing.assert_allclose(image, 0.25 * 0.5, atol=1e-5)      # (the ray starts a robust offset off the floor)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("limit, lit", [(3, 0.0), (4, 1.0)])
def test_a_shadow_ray_passes_only_what_its_path_left_of_the_transparent_bounce_limit(kernels, limit, lit):
    """The camera sees the floor through two clear panes, and the sun lights it through the same two: with
    Transparent Max Bounces 3 the camera ray passes both (2 < 3) but its shadow rays have one pass left, and the
    floor is black, as in Cycles (integrate_shadow_max_transparent_hits); with 4 both get through (albedo 1 / pi x pi)."""
    scene = shadow_scene(None)
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    scene.camera = ortho_down(height=4.0, scale=1.0)
    image = shoot(scene, kernels, max_bounces=0, transparent_max_bounces=limit)
    np.testing.assert_allclose(image, lit, atol=1e-5)


def test_every_output_of_cycles_light_path_node_is_evaluated():
    """The node's outputs in Blender 5.0 and 5.2, all compiled (addon/materials.py warns of none)."""
    assert set(LIGHT_PATH_OUTPUTS) == {
        "Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray", "Is Glossy Ray", "Is Singular Ray", "Is Reflection Ray",
        "Is Transmission Ray", "Is Volume Scatter Ray", "Ray Length", "Ray Depth", "Diffuse Depth", "Glossy Depth",
        "Transparent Depth", "Transmission Depth", "Portal Depth"}
