"""The Ray Portal BSDF (core/materials/portal.py), as Cycles reads it, on both kernels and both integrators: a ray that
takes a portal closure of weight w goes on from the portal's Position (unlinked: the hit point) along its Direction
(zero: its own), carrying w, as a transparent bounce; shadow rays stop at a surface with a portal; what the teleported
ray finds is not weighed by MIS."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import materials, render
from core.geometry import primitives
from core.materials.graph import GraphNode, Link
from core.lights import SunLight
from core.scene import RenderSettings, Scene
from test_ray_visibility import KERNELS, behind_a_pane, glow, looking_down

INTEGRATORS = ["direct", "path"]


def pixels(scene, settings, integrator: str) -> np.ndarray:
    """The rendered image's distinct RGBA values (k, 4), rounded to 1e-9."""
    settings.integrator = integrator
    image = render.render(scene, settings).image
    return np.unique(np.round(image, 9).reshape(-1, 4), axis=0)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_a_portal_in_place_lets_the_ray_go_on_straight_tinted_by_its_colour(kernels, integrator):
    """A pane that is a Ray Portal of colour 0.5 with its Position and Direction unlinked: the quad glowing 5 and the
    floor glowing 2 behind it show at 2.5 and 1 (edge pixels between), exactly, alpha 1."""
    scene, settings = behind_a_pane([("RAY_PORTAL", (0.5,) * 3, {})], "", kernels)
    seen = pixels(scene, settings, integrator)
    assert {2.5, 1.0} <= set(seen[:, 0]) and seen[:, 0].min() == 1.0 and seen[:, 0].max() == 2.5
    np.testing.assert_array_equal(seen[:, 3], 1.0)


def far_away(kernels: str, inputs: dict) -> tuple:
    """behind_a_pane with a pane that is a white Ray Portal of `inputs`, a floor glowing 7 under x = 100 and a
    ceiling glowing 3 over it (z = 5; an emitter glows both ways). (The Position is a world point, the geometry
    camera-relative: a ray leaving from 6 too high, the camera's height, would meet the ceiling going down.)"""
    scene, settings = behind_a_pane([("RAY_PORTAL", (1.0,) * 3, inputs)], "", kernels)
    scene.materials += [glow("far floor", 7.0), glow("far ceiling", 3.0)]
    scene.add_mesh(primitives.plane(40.0, center=(100.0, 0.0, 0.0)), materials=np.array([3]))
    scene.add_mesh(primitives.plane(40.0, center=(100.0, 0.0, 5.0)), materials=np.array([4]))
    return scene, settings


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_a_portal_moves_every_ray_to_its_position_and_turns_it_to_its_direction(kernels, integrator):
    """The portal's Position (100, 0, 3): every camera ray goes on from there, downwards as it was, and meets the far
    floor (7) instead of the quad and floor behind the pane; with Direction (0, 0, 1) as well, every ray meets the
    far ceiling (3). Every pixel exactly so."""
    scene, settings = far_away(kernels, {"position_set": 1.0, "position": (100.0, 0.0, 3.0)})
    np.testing.assert_array_equal(pixels(scene, settings, integrator), [[7.0, 7.0, 7.0, 1.0]])
    scene, settings = far_away(kernels, {"position_set": 1.0, "position": (100.0, 0.0, 3.0),
                                         "direction": (0.0, 0.0, 2.0)})
    np.testing.assert_array_equal(pixels(scene, settings, integrator), [[3.0, 3.0, 3.0, 1.0]])


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_a_portal_mixed_half_and_half_with_an_emission_gives_the_average(kernels, integrator):
    """Mix(Fac 0.5, Emission 4, Ray Portal to the far floor glowing 7): every pixel 0.5 x 4 + 0.5 x 7 = 5.5."""
    portal = {"position_set": 1.0, "position": (100.0, 0.0, 3.0)}
    scene, settings = far_away(kernels, portal)
    scene.materials[2] = materials.Material(name="pane", nodes=[("EMISSION", (0.5,) * 3, {"emission": (4.0,) * 3}),
                                                                ("RAY_PORTAL", (0.5,) * 3, portal)])
    np.testing.assert_allclose(pixels(scene, settings, integrator), [[5.5, 5.5, 5.5, 1.0]], rtol=1e-6)  # (a float32 image)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_a_portal_stops_shadow_rays_unless_mixed_with_a_transparent_bsdf(kernels, integrator):
    """A diffuse floor (albedo 0.6) under a sun of 3 W/m^2 at 30 degrees, seen through a pane. The camera rays go on
    through a Ray Portal pane as through a Transparent one, but the sun's shadow rays stop there: the floor is 0,
    exactly. Mixed half and half with a Transparent BSDF, Cycles' shadow rays count the portal's weight as
    transparent too (they set up no portal closure, only its extinction): the floor is 0.6 x 3 cos 30 / pi, as under
    a Transparent pane."""
    theta = math.radians(30.0)
    lit = 0.6 * 3.0 * math.cos(theta) / math.pi
    for pane, expected in (([("TRANSPARENT", (1.0,) * 3, {})], lit), ([("RAY_PORTAL", (1.0,) * 3, {})], 0.0),
                           ([("TRANSPARENT", (0.5,) * 3, {}), ("RAY_PORTAL", (0.5,) * 3, {})], lit)):
        scene = Scene(camera=looking_down(6.0))
        scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (0.6,) * 3, {})]),
                            materials.Material(name="pane", nodes=pane)]
        scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
        scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
        scene.lights.append(SunLight(np.array([math.sin(theta), 0.0, -math.cos(theta)]), strength=3.0))
        settings = RenderSettings(width=16, height=16, samples=2, kernels=kernels)
        np.testing.assert_allclose(pixels(scene, settings, integrator)[:, :3], expected, rtol=1e-6, atol=1e-15)


@pytest.mark.parametrize("kernels", KERNELS)
def test_what_a_portal_ray_finds_is_not_weighed_by_mis(kernels):
    """A diffuse floor (albedo 0.6) under a Ray Portal pane and, above it, a ceiling glowing 3, both 4 km wide and
    hidden from the camera: the floor's light samples of the ceiling all stop at the portal, and its BSDF rays go
    through to the ceiling with weight 1 (Cycles' PATH_RAY_MIS_SKIP): every pixel 0.6 x 3 = 1.8 but for the sliver
    of sky the ceiling leaves (< 1e-5), with no noise. (MIS weighing would lose a share of the light to the light
    samples that the portal stopped.)"""
    scene = Scene(camera=looking_down(6.0))
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (0.6,) * 3, {})]),
                        materials.Material(name="pane", nodes=[("RAY_PORTAL", (1.0,) * 3, {})]), glow("ceiling", 3.0)]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(4000.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    scene.add_mesh(primitives.plane(4000.0, center=(0.0, 0.0, 3.0)), materials=np.array([2]))
    scene.instances[1].visible_camera = scene.instances[2].visible_camera = False
    settings = RenderSettings(width=16, height=16, samples=4, kernels=kernels, integrator="path")
    np.testing.assert_allclose(render.render(scene, settings).image[..., :3], 1.8, rtol=1e-5)


def shifted(offset) -> Link:
    """The hit's position (Geometry > Position) + offset (3,): a Ray Portal's Position input read per hit."""
    return Link(GraphNode("VECTOR_MATH", {"operation": "ADD"},
                          {"Vector": Link(GraphNode("GEOMETRY", {}, {}), "Position"), "Vector_001": offset}), "Vector")


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_a_portal_with_a_linked_position_moves_each_ray_by_the_graphs_offset(kernels, integrator):
    """The portal's Position is the hit's own moved 30 along x (a node graph, per hit): each camera ray goes on 30 to
    the side, downwards as it was, and meets a floor glowing 7 laid there instead of the quad (5) and floor (2)
    behind the pane (nor a plane glowing 11 at 5 up, which rays from 6 too high would meet): every pixel exactly 7."""
    scene, settings = behind_a_pane([("RAY_PORTAL", (1.0,) * 3, {"position_set": 1.0,
                                                                 "position": shifted((30.0, 0.0, 0.0))})], "", kernels)
    scene.materials.append(glow("far floor", 7.0))
    scene.materials.append(glow("attic", 11.0))
    scene.add_mesh(primitives.plane(40.0, center=(30.0, 0.0, -1.0)), materials=np.array([3]))
    scene.add_mesh(primitives.plane(40.0, center=(30.0, 0.0, 5.0)), materials=np.array([4]))
    np.testing.assert_array_equal(pixels(scene, settings, integrator), [[7.0, 7.0, 7.0, 1.0]])


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_both_kernels_render_a_lit_scene_through_portals_alike(integrator):
    """A diffuse floor and box under a point lamp and a sky, seen through a pane Mix(Fac 0.5, Diffuse, Ray Portal moved
    30 along x by a node graph), a Glossy floor beyond: both kernels trace the same rays and agree to
    tests/test_compiled.py's tolerance (the portal's pick, teleport, MIS skip and shadow stop alike)."""
    from core.lights import PointLight
    from core.scene import World
    from test_compiled import assert_same_render, compare_paths
    scene = Scene(camera=looking_down(6.0), world=World(color=np.full(3, 0.3)))
    portal = {"position_set": 1.0, "position": shifted((30.0, 0.0, 0.0))}
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (0.6,) * 3, {})]),
                        materials.Material(name="pane", nodes=[("DIFFUSE", (0.4,) * 3, {}),
                                                               ("RAY_PORTAL", (0.5,) * 3, portal)]),
                        materials.Material(name="glossy", nodes=[("GLOSSY", (0.8,) * 3, {"roughness": 0.3})])]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.box((2.0, 2.0, 1.0), center=(30.0, 0.0, 0.5)), materials=np.array([0]))
    scene.add_mesh(primitives.plane(8.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    scene.add_mesh(primitives.plane(20.0, center=(30.0, 0.0, -0.5)), materials=np.array([2]))
    scene.lights.append(PointLight(np.array([0.0, 0.0, 4.0]), power=300.0, radius=0.5))
    scene.lights.append(PointLight(np.array([30.0, 0.0, 4.0]), power=300.0, radius=0.5))
    settings = RenderSettings(width=16, height=12, samples=4, integrator=integrator, max_bounces=3)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    assert np.isfinite(compiled.image).all() and compiled.image[..., :3].max() > 0.0


def test_the_ray_diagram_draws_each_portals_jump_and_the_ray_it_sends():
    """The 2D ray diagram of the far_away scene (Position (100, 0, 3)): each jump ("portal_jump") goes from a hit on
    the pane (z = 2) to the portal's Position, and the portal's rays ("portal") leave from there."""
    from core.teaching import diagram
    scene, settings = far_away("numpy", {"position_set": 1.0, "position": (100.0, 0.0, 3.0)})
    settings.integrator = "path"
    d = diagram.ray_diagram(scene, settings, size=64)
    jumps = [s for s in d.segments if s.kind == "portal_jump"]
    rays = [s for s in d.segments if s.kind == "portal"]
    assert jumps and rays
    np.testing.assert_allclose(np.concatenate([s.start for s in jumps])[:, 2], 2.0, atol=1e-5)
    P = np.array([100.0, 0.0, 3.0])
    assert np.abs(np.concatenate([s.end for s in jumps]) - P).max() < 1e-5
    assert np.abs(np.concatenate([s.start for s in rays]) - P).max() < 1e-5
