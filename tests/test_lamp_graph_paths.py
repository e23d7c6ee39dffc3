"""What a lamp's node tree reads of the path its light reaches and of the lamp's own object (core/lights/lamp_graph.py
lamp_paths, LampEmission.info), as Cycles' light_sample_shader_eval: EMISSION alone as the flags, the depths of the
vertex a light sample lights (Ray Depth one more) or of a BSDF ray after its bounce, and Object Info of the lamp object.
Closed forms per pixel on both kernels: a ceiling seen directly and in a mirror, a floor seen through a transparent
sheet, a lamp coloured by its Object Info; light samples against BSDF rays, each alone, sample by sample."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.geometry import primitives
from core.lights import AreaLight, PointLight
from core.lights.lamp_graph import INFO_COLUMNS, UV_AREA, compile_lamp
from core.materials import Material
from core.materials.graph import GraphNode, Link, object_random
from core.scene import RenderSettings, Scene, World

from test_emitters_world import ortho_down
from test_lamp_graph import at, pixel_centres

RHO, P = 0.5, 100.0                                        # the lit surface's albedo, the lamp's power
KERNELS = ["numpy", "compiled"]


def path_output(name: str) -> Link:
    """One output of a Light Path node."""
    return Link(GraphNode("LIGHT_PATH"), name)


def weighted_sum(terms: list, offset: float = 0.0) -> Link:
    """offset + the sum of weight x value over `terms` ((weight, Link) each) as Math nodes."""
    total = offset
    for weight, value in terms:
        scaled = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": value, "1": float(weight)}), "Value")
        total = Link(GraphNode("MATH", {"operation": "ADD"}, {"0": total, "1": scaled}), "Value")
    return total


# Strength = 1 + Ray Depth + 10 Diffuse + 100 Glossy + 1000 Transmission + 10^4 Transparent Depth + 10^5 x every
# "Is ... Ray" (a lamp's shading sees EMISSION alone: they read 0).
DEPTHS = [(1.0, "Ray Depth"), (10.0, "Diffuse Depth"), (100.0, "Glossy Depth"), (1000.0, "Transmission Depth"),
          (1e4, "Transparent Depth")] + [(1e5, name) for name in ("Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray",
                                                                   "Is Glossy Ray", "Is Singular Ray",
                                                                   "Is Reflection Ray", "Is Transmission Ray")]


def depth_strength() -> Link:
    """The Strength DEPTHS spells out."""
    return weighted_sum([(w, path_output(name)) for w, name in DEPTHS], 1.0)


def direct_light(h: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """What a Lambert surface of albedo RHO shows at (x, y) h below (or above) a point lamp of power P over it:
    rho / pi P / (4 pi) h / d^3."""
    d = np.sqrt(h * h + x * x + y * y)
    return RHO / math.pi * P / (4.0 * math.pi) * h / d ** 3


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_sees_the_depths_of_the_vertex_it_lights_directly_and_in_a_mirror(kernels):
    """A Lambert ceiling at z = 5 under a point lamp 1 below it whose Strength spells the Light Path depths (DEPTHS),
    seen by an orthographic camera looking down at a mirror floor (path tracer, one bounce): each pixel shows the
    ceiling's direct light at its (x, y) times 1 + 2 (Ray Depth: one bounce, one more for the lamp's shading) + 100
    (one glossy bounce), 103; the ceiling seen straight up (no mirror: the camera below it looking up) 1 + 1, 2."""
    lamp = PointLight(position=np.array([0.0, 0.0, 4.0]), power=P,
                      lamp_nodes=compile_lamp(np.ones(3), depth_strength(), at([0.0, 0.0, 4.0])))
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=World(color=np.zeros(3)))
    scene.materials.append(Material(name="mirror", bsdf="MIRROR", base_color=np.ones(3)))
    scene.materials.append(Material(np.full(3, RHO), "Ceiling"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]), name="Mirror")
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 5.0)), materials=np.array([1]), name="Ceiling")
    scene.lights.append(lamp)
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False, integrator="path",
                              max_bounces=1)
    image = render.render(scene, settings).image[..., :3]
    x, y = pixel_centres()
    np.testing.assert_allclose(image, (103.0 * direct_light(1.0, x, y))[..., None] * np.ones(3), rtol=1e-5)
    # The same ceiling seen directly: the camera 1 below it, looking up (its image's y the other way round).
    up = np.diag([1.0, -1.0, -1.0, 1.0])
    up[:3, 3] = [0.0, 0.0, 4.0]
    scene.camera = Camera(matrix_world=up, type="ORTHO", ortho_scale=4.0, clip_start=1e-3, clip_end=30.0)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, (2.0 * direct_light(1.0, x, y[::-1]))[..., None] * np.ones(3), rtol=1e-5)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_sees_the_transparent_surfaces_the_path_passed(kernels):
    """A Lambert floor under a point lamp at height 1.5 whose Strength spells the depths (DEPTHS), seen from above
    through a fully transparent sheet at height 2 (a Transparent BSDF of white: it passes the camera ray and the
    shadow rays whole): 1 + 1 (Ray Depth) + 10^4 (one Transparent Depth) times the floor's direct light."""
    h = 1.5
    lamp = PointLight(position=np.array([0.0, 0.0, h]), power=P,
                      lamp_nodes=compile_lamp(np.ones(3), depth_strength(), at([0.0, 0.0, h])))
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=World(color=np.zeros(3)))
    scene.materials.append(Material(np.full(3, RHO), "Floor"))
    scene.materials.append(Material(name="sheet", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})]))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]), name="Floor")
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]), name="Sheet")
    scene.lights.append(lamp)
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    image = render.render(scene, settings).image[..., :3]
    x, y = pixel_centres()
    np.testing.assert_allclose(image, ((2.0 + 1e4) * direct_light(h, x, y))[..., None] * np.ones(3), rtol=1e-5)


def info_row(location, color=(0.2, 0.5, 0.9, 0.7), index: float = 7.0) -> np.ndarray:
    """A lamp object's Object Info row (geometry.instance_info's columns): location, colour and alpha, pass index."""
    row = np.zeros(INFO_COLUMNS)
    row[0:3], row[3:7], row[7] = location, color, index
    return row


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_coloured_by_its_object_info(kernels):
    """A point lamp at (0.5, 0.25, 1.5) whose Color is Object Info's Location and whose Strength is its Alpha +
    Object Index + Random + Material Index (0.7 + 7 + the name's hash + 0 for a lamp): the floor shows the direct
    light times (0.5, 0.25, 1.5) x that sum."""
    location = np.array([0.5, 0.25, 1.5])
    random = object_random("Lamp")
    info = GraphNode("OBJECT_INFO", {"material_index": 0.0})
    strength = weighted_sum([(1.0, Link(info, name)) for name in ("Alpha", "Object Index", "Random",
                                                                   "Material Index")])
    lamp = PointLight(position=location, power=P,
                      lamp_nodes=compile_lamp(Link(info, "Location"), strength, at(location),
                                              info=info_row(location), random=random))
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=World(color=np.zeros(3)))
    scene.materials.append(Material(np.full(3, RHO), "Floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.lights.append(lamp)
    image = render.render(scene, RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)).image
    x, y = pixel_centres()
    expected = direct_light(location[2], x - location[0], y - location[1])[..., None] * location * (0.7 + 7.0 + random)
    np.testing.assert_allclose(image[..., :3], expected, rtol=1e-5)
    assert 0.0 < random < 1.0


def area_over_floor(strength, height: float = 1.5) -> Scene:
    """A Lambert floor under a 4 x 4 area lamp at `height` facing down whose Strength is `strength`."""
    matrix = at([0.0, 0.0, height])
    lamp = AreaLight(center=np.array([0.0, 0.0, height]), axis_u=np.array([4.0, 0.0, 0.0]),
                     axis_v=np.array([0.0, 4.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=P,
                     lamp_nodes=compile_lamp(np.ones(3), strength, matrix, UV_AREA))
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=World(color=np.zeros(3)))
    scene.materials.append(Material(np.full(3, RHO), "Floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.lights.append(lamp)
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("sampling, depth", [("light", 1.0), ("bsdf", 2.0)])
def test_light_samples_and_bsdf_rays_see_the_depths_cycles_gives_them(kernels, sampling, depth):
    """An area lamp over a floor seen directly, found by light samples alone or by BSDF rays alone: with Strength =
    Ray Depth each pixel is Ray Depth x the same render with Strength 1 (the same draws), 1 for light samples (the
    vertex's bounce 0, one more for the lamp's shading) and 2 for BSDF rays (Cycles counts their bounce before it
    shades the lamp they meet: path_state_next, then integrate_light)."""
    settings = RenderSettings(width=6, height=6, samples=4, kernels=kernels, light_sampling=sampling)
    one = render.render(area_over_floor(1.0), settings).image
    deep = render.render(area_over_floor(path_output("Ray Depth")), settings).image
    assert (one[..., 0] > 0.0).sum() >= 30            # (BSDF rays alone: a few miss the lamp)
    np.testing.assert_allclose(deep[..., :3], depth * one[..., :3], rtol=1e-6)


def world_through_a_sheet(strength, sheet: bool = True) -> Scene:
    """A Lambert floor under a world whose colour is |Generated| (brighter towards the axes) times `strength`, seen
    from above through a fully transparent sheet at height 2 (none where not `sheet`); the world's light samples run
    its program with their paths (World.samples_seen), its importance map the first bounce's bake (64 x 32)."""
    from core.lights import world_graph
    generated = Link(GraphNode("TEXCOORD"), "Generated")
    color = Link(GraphNode("VECTOR_MATH", {"operation": "ABSOLUTE"}, {"Vector": generated}), "Vector")
    world = World(color=np.zeros(3), image=world_graph.bake(color, strength, width=64, kernels="numpy"),
                  seen=world_graph.compile_world(color, strength), samples_seen=True)
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=world)
    scene.materials.append(Material(np.full(3, RHO), "Floor"))
    scene.materials.append(Material(name="sheet", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})]))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]), name="Floor")
    if sheet:
        scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]), name="Sheet")
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_worlds_light_samples_see_the_depths_of_the_vertex_they_light(kernels):
    """A world whose Strength is 1 + Transparent Depth lights a floor seen through a transparent sheet, by light
    samples alone: they see the one transparent surface the path passed, so each pixel is exactly twice the same
    render with Strength 1 (the same map, the same draws), where the bake (the first bounce's) alone said 1."""
    settings = RenderSettings(width=6, height=6, samples=2, kernels=kernels, light_sampling="light")
    one = render.render(world_through_a_sheet(1.0), settings).image[..., :3]
    more = weighted_sum([(1.0, path_output("Transparent Depth"))], 1.0)
    deeper = render.render(world_through_a_sheet(more), settings).image[..., :3]
    assert one.min() > 0.0
    np.testing.assert_allclose(deeper, 2.0 * one, rtol=1e-6)
    # (without the sheet: the same as Strength 1)
    alone = render.render(world_through_a_sheet(more, sheet=False), settings).image[..., :3]
    np.testing.assert_allclose(alone, render.render(world_through_a_sheet(1.0, sheet=False), settings).image[..., :3],
                               rtol=1e-6)


def one_more_transparent_depth() -> Link:
    """Strength = 1 + Light Path's Transparent Depth."""
    return weighted_sum([(1.0, path_output("Transparent Depth"))], 1.0)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_the_world_met_by_bsdf_rays_through_a_sheet_sees_both_crossings(kernels, integrator):
    """The world of 1 + Transparent Depth over a floor seen through a transparent sheet, found by BSDF rays alone:
    each ray crossed the sheet twice, once on the camera's side and once on its way up (Cycles' path_state_next counts
    every transparent crossing), so each pixel is exactly 3 x the same render with Strength 1. The direct tracer
    (no bounces: the ray past its limits looks on through the sheet, path.through_transparent) and the path tracer
    (the sheet a vertex of the path) alike."""
    settings = RenderSettings(width=6, height=6, samples=2, kernels=kernels, light_sampling="bsdf",
                              integrator=integrator)
    one = render.render(world_through_a_sheet(1.0), settings).image[..., :3]
    deeper = render.render(world_through_a_sheet(one_more_transparent_depth()), settings).image[..., :3]
    assert one.min() > 0.0
    np.testing.assert_allclose(deeper, 3.0 * one, rtol=1e-6)


def lamp_above_a_sheet(strength) -> Scene:
    """A Lambert floor seen from above (the camera at height 3) through a transparent sheet at height 2, under a
    4 x 4 area lamp at height 2.5 facing down whose Strength is `strength` (its back to the camera)."""
    scene = area_over_floor(strength, height=2.5)
    scene.materials.append(Material(name="sheet", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]), name="Sheet")
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
@pytest.mark.parametrize("sampling, factor", [("light", 2.0), ("bsdf", 3.0)])
def test_a_lamp_met_by_bsdf_rays_through_a_sheet_sees_both_crossings(kernels, integrator, sampling, factor):
    """An area lamp of Strength 1 + Transparent Depth above a transparent sheet over a floor seen through it: BSDF
    rays alone meet it after crossing the sheet twice (3 x the Strength-1 render), light samples light a vertex that
    the camera ray reached through the sheet once (2 x); by both tracers (direct: path.through_transparent)."""
    settings = RenderSettings(width=6, height=6, samples=4, kernels=kernels, light_sampling=sampling,
                              integrator=integrator)
    one = render.render(lamp_above_a_sheet(1.0), settings).image[..., :3]
    deeper = render.render(lamp_above_a_sheet(one_more_transparent_depth()), settings).image[..., :3]
    assert (one[..., 0] > 0.0).sum() >= 30            # (BSDF rays alone: a few miss the lamp)
    np.testing.assert_allclose(deeper, factor * one, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("limit, seen", [(3, False), (4, True)])
def test_a_bsdf_ray_past_its_bounces_counts_its_crossings_against_the_transparent_limit(kernels, limit, seen):
    """A Lambert floor (albedo RHO) under a white world of 1 seen through two transparent sheets, by BSDF rays alone
    and no bounces (the direct tracer): the camera ray crosses both (2), the floor's ray both again (3, 4). With
    Transparent Max Bounces 4 it escapes, RHO exactly; with 3 it is stopped at the second sheet (Cycles' terminate on
    the next surface after the last crossing allowed): black."""
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=World(color=np.ones(3)))
    scene.materials.append(Material(np.full(3, RHO), "Floor"))
    scene.materials.append(Material(name="sheet", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})]))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]), name="Floor")
    for z in (1.0, 2.0):
        scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, z)), materials=np.array([1]), name=f"Sheet {z}")
    settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, light_sampling="bsdf",
                              transparent_max_bounces=limit)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, np.full(image.shape, RHO if seen else 0.0), rtol=1e-6, atol=1e-12)
