"""A lamp's node tree evaluated per light sample and per ray that meets the lamp (core/lights/lamp_graph.py), as
Cycles' light_sample_shader_eval at shader_setup_from_sample's point: closed forms for a point lamp whose emission
follows Texture Coordinate > Normal (the direction leaving it in its object frame) and the ray's length, and a spot
whose checker gobo follows its UV projection; the two kernels agree sample by sample and hit by hit; light samples and
BSDF rays see the same textured light."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import render
from core.lights import AreaLight, PointLight, SpotLight, SunLight
from core.lights import base as lights_base
from core.lights.lamp_graph import UV_AREA, UV_SPHERE, UV_SPOT, UV_SUN, compile_lamp, map_to_sphere
from core.materials.graph import GraphNode, Link
from core.scene import RenderSettings

from test_lamp_falloff import H, P, RHO, floor_scene      # (a Lambert floor under one lamp, seen from above)


def pixel_centres(n: int = 8, scale: float = 4.0):
    """The floor points at the centres of an n x n image of the orthographic camera: x, y (n, n) each."""
    c = (np.arange(n) + 0.5) / n * scale - scale / 2
    return np.meshgrid(c, c[::-1])


def at(position) -> np.ndarray:
    """A lamp object's transform (4, 4): no rotation, at `position`."""
    matrix = np.eye(4)
    matrix[:3, 3] = position
    return matrix


def normal_abs() -> Link:
    """The absolute of Texture Coordinate > Normal: |the direction leaving the lamp| in its object frame."""
    normal = Link(GraphNode("TEXCOORD"), "Normal")
    return Link(GraphNode("VECTOR_MATH", {"operation": "ABSOLUTE"}, {"Vector": normal}), "Vector")


def checker() -> Link:
    """A Checker of scale 3 on the lamp's UV, colours (1, 0.5, 0.25) and (0.1, 0.2, 0.3)."""
    uv = Link(GraphNode("TEXCOORD"), "UV")
    return Link(GraphNode("TEX_CHECKER", {}, {"Vector": uv, "Color1": np.array([1.0, 0.5, 0.25]),
                                              "Color2": np.array([0.1, 0.2, 0.3]), "Scale": 3.0}), "Color")


def one_over_one_plus_length() -> Link:
    """1 / (1 + Light Path > Ray Length): a Light Falloff wired non-linearly, in closed form."""
    length = Link(GraphNode("LIGHT_PATH"), "Ray Length")
    plus = Link(GraphNode("MATH", {"operation": "ADD"}, {"0": length, "1": 1.0}), "Value")
    return Link(GraphNode("MATH", {"operation": "DIVIDE"}, {"0": 1.0, "1": plus}), "Value")


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_point_lamps_emission_follows_the_direction_leaving_it(kernels):
    """A point lamp of power P at height H whose Color is |Normal|: the floor at (x, y) shows rho / pi P / (4 pi) H / d^3
    x (|x|, |y|, H) / d, d the distance to the lamp (each channel its own direction cosine), at each pixel centre."""
    lamp = PointLight(position=np.array([0.0, 0.0, H]), power=P,
                      lamp_nodes=compile_lamp(normal_abs(), 1.0, at([0.0, 0.0, H])))
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    image = render.render(floor_scene(lamp), settings).image[..., :3]
    x, y = pixel_centres()
    d = np.sqrt(H * H + x * x + y * y)
    cosines = np.stack([np.abs(x), np.abs(y), np.full_like(x, H)], axis=-1) / d[..., None]
    expected = (RHO / math.pi * P / (4.0 * math.pi) * H / d ** 3)[..., None] * cosines
    np.testing.assert_allclose(image, expected, rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_falloff_wired_non_linearly_divides_by_one_plus_the_distance(kernels):
    """A point lamp whose Strength is 1 / (1 + Ray Length): the floor shows rho / pi P / (4 pi) H / d^3 / (1 + d)."""
    lamp = PointLight(position=np.array([0.0, 0.0, H]), power=P,
                      lamp_nodes=compile_lamp(np.ones(3), one_over_one_plus_length(), at([0.0, 0.0, H])))
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    image = render.render(floor_scene(lamp), settings).image[..., 0]
    x, y = pixel_centres()
    d = np.sqrt(H * H + x * x + y * y)
    np.testing.assert_allclose(image, RHO / math.pi * P / (4.0 * math.pi) * H / d ** 3 / (1.0 + d), rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_spots_checker_gobo_projects_its_uv_onto_the_floor(kernels):
    """A spot of 90 degrees (hard edge) at height H pointing down with a Checker of scale 3 on its UV: Cycles' spot UV
    is 0.5 + (x, y) cot(45 deg) / 2 / H on the floor, so the floor inside the cone shows rho / pi P / (4 pi) H / d^3
    times Color1 where floor(3 u) and floor(3 v) differ in parity, else Color2 (the pixel centres fall off the
    squares' edges); outside the cone black."""
    lamp = SpotLight(position=np.array([0.0, 0.0, H]), direction=np.array([0.0, 0.0, -1.0]), power=P,
                     spot_size=math.radians(90.0), spot_blend=0.0,
                     lamp_nodes=compile_lamp(checker(), 1.0, at([0.0, 0.0, H]), UV_SPOT, math.radians(90.0)))
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    image = render.render(floor_scene(lamp), settings).image[..., :3]
    x, y = pixel_centres()
    d = np.sqrt(H * H + x * x + y * y)
    u, v = 0.5 + 0.5 * x / H, 0.5 + 0.5 * y / H
    odd = (np.floor(3.0 * u).astype(int) % 2) != (np.floor(3.0 * v).astype(int) % 2)
    color = np.where(odd[..., None], [1.0, 0.5, 0.25], [0.1, 0.2, 0.3])
    inside = x * x + y * y < H * H
    expected = (RHO / math.pi * P / (4.0 * math.pi) * H / d ** 3 * inside)[..., None] * color
    np.testing.assert_allclose(image, expected, rtol=1e-5, atol=1e-12)
    assert odd[inside].any() and (~odd[inside]).any()


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_spots_image_gobo_with_its_vector_unlinked_reads_the_spots_uv(kernels):
    """A spot of 90 degrees (hard edge) at height H pointing down whose Color is a 2 x 2 image (Closest), its Vector
    unlinked (Cycles' default: UV, the spot's projection 0.5 + (x, y) / (2 H) on the floor): each quarter of the cone's
    floor shows the texel of its quadrant (bottom row first), times rho / pi P / (4 pi) H / d^3."""
    from core.materials import textures
    texels = np.array([[[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0]], [[0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 0.0, 1.0]]],
                      np.float32)
    image = Link(GraphNode("IMAGE", {"image": textures.Image(texels), "interpolation": "Closest",
                                     "extension": "EXTEND"}, {}), "Color")
    lamp = SpotLight(position=np.array([0.0, 0.0, H]), direction=np.array([0.0, 0.0, -1.0]), power=P,
                     spot_size=math.radians(90.0), spot_blend=0.0,
                     lamp_nodes=compile_lamp(image, 1.0, at([0.0, 0.0, H]), UV_SPOT, math.radians(90.0)))
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    result = render.render(floor_scene(lamp), settings)
    image_out = result.image[..., :3]
    x, y = pixel_centres()
    d = np.sqrt(H * H + x * x + y * y)
    texel = texels[(y > 0).astype(int), (x > 0).astype(int), :3]
    inside = x * x + y * y < H * H
    expected = (RHO / math.pi * P / (4.0 * math.pi) * H / d ** 3 * inside)[..., None] * texel
    np.testing.assert_allclose(image_out, expected, rtol=1e-5, atol=1e-12)


def lamps_with_programs():
    """A turned, scaled sun of 0.6 rad with a program of its UV and Object coordinates; a sphere, a disc-like round spot
    and a rotated, scaled area lamp, each with a program of Normal, UV, Object and the ray's length."""
    def program(uv_kind, matrix, spot_size=0.0):
        parts = [Link(GraphNode("TEXCOORD"), name) for name in ("Normal", "UV", "Object")]
        mixed = Link(GraphNode("VECTOR_MATH", {"operation": "ADD"}, {"Vector": parts[0], "Vector_001": parts[1]}),
                     "Vector")
        mixed = Link(GraphNode("VECTOR_MATH", {"operation": "ADD"}, {"Vector": mixed, "Vector_001": parts[2]}), "Vector")
        return compile_lamp(Link(GraphNode("VECTOR_MATH", {"operation": "ABSOLUTE"}, {"Vector": mixed}), "Vector"),
                            one_over_one_plus_length(), matrix, uv_kind, spot_size)

    turn = np.eye(4)
    c, s = math.cos(0.4), math.sin(0.4)
    turn[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag([1.5, 0.8, 1.0])
    turn[:3, 3] = [0.3, -0.2, H]
    sun = turn.copy()
    sun[:3, :3] = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(0.5), -math.sin(0.5)], [0.0, math.sin(0.5), math.cos(0.5)]]) \
        @ np.diag([1.0, 1.3, 1.0])
    sun_program = compile_lamp(Link(GraphNode("VECTOR_MATH", {"operation": "ABSOLUTE"}, {"Vector": Link(GraphNode(
        "VECTOR_MATH", {"operation": "ADD"}, {"Vector": Link(GraphNode("TEXCOORD"), "UV"), "Vector_001": Link(
            GraphNode("TEXCOORD"), "Object")}), "Vector")}), "Vector"), 1.0, sun, UV_SUN, 0.6)
    return [
        SunLight(direction=-sun[:3, 2] / np.linalg.norm(sun[:3, 2]), strength=3.0, angle=0.6, lamp_nodes=sun_program),
        PointLight(position=np.array([0.3, 0.0, H]), power=P, radius=0.5, soft_falloff=False,
                   lamp_nodes=program(UV_SPHERE, at([0.3, 0.0, H]))),
        SpotLight(position=np.array([0.3, 0.0, H]), direction=np.array([0.0, 0.0, -1.0]), power=P, radius=0.5,
                  spot_size=math.radians(120.0), lamp_nodes=program(UV_SPOT, at([0.3, 0.0, H]), math.radians(120.0))),
        AreaLight(center=turn[:3, 3].copy(), direction=np.array([0.0, 0.0, -1.0]), power=P,
                  axis_u=turn[:3, 0] * 1.0, axis_v=turn[:3, 1] * 0.7, lamp_nodes=program(UV_AREA, turn)),
    ]


@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_both_kernels_give_a_textured_lamp_the_same_light(index):
    """The Python and C lamps with a program agree sample by sample (colour x strength) and hit by hit (radiance),
    within 1e-5 relative (the nodes compute in float32, as Cycles', on inputs the kernels round alike but for the last
    double bits), and the program does vary over the lamp."""
    lamp = lamps_with_programs()[index]
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-2, 2, 200), rng.uniform(-2, 2, 200), np.zeros(200)])
    u = rng.random((200, 2))
    ours, theirs = lamp.sample(points, u), lights_base.compiled_sample(lamp, points, u)
    np.testing.assert_allclose(theirs.strength[:, None] * theirs.color, ours.strength[:, None] * ours.color,
                               rtol=1e-5, atol=1e-7)
    assert np.ptp(ours.color[ours.strength > 0], axis=0).max() > 0.05
    sun = isinstance(lamp, SunLight)
    directions = ours.L if sun else (ours.position - points) / ours.distance[:, None]
    t_max = np.full(200, np.inf if sun else 1e9)
    hit, hit_c = lamp.hit(points, directions, t_max), lights_base.compiled_hit(lamp, points, directions, t_max)
    np.testing.assert_array_equal(hit.hit, hit_c.hit)
    np.testing.assert_allclose(hit_c.radiance, hit.radiance, rtol=1e-5, atol=1e-7)
    assert hit.hit.sum() > 50


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_suns_emission_follows_the_direction_its_light_travels(kernels):
    """A sun (angle 0) of strength S travelling along w = (0.3, -0.4, -0.866) (normalised) whose Color is |Normal|:
    the floor shows rho / pi S cos(theta) |w| everywhere, channel by channel (Cycles' Ng for a sun: the direction its
    light travels, in its object frame; here unturned)."""
    w = np.array([0.3, -0.4, -0.866])
    w /= np.linalg.norm(w)
    lamp = SunLight(direction=w, strength=3.0, angle=0.0, lamp_nodes=compile_lamp(normal_abs(), 1.0, np.eye(4), UV_SUN))
    settings = RenderSettings(width=8, height=8, samples=1, kernels=kernels, jitter=False)
    image = render.render(floor_scene(lamp), settings).image[..., :3]
    np.testing.assert_allclose(image, np.broadcast_to(RHO / math.pi * 3.0 * -w[2] * np.abs(w), image.shape), rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_light_samples_and_bsdf_rays_see_the_same_textured_lamp(kernels, index):
    """The floor lit by light samples alone and by BSDF rays alone has the same mean (within 3 %: both unbiased, each
    weighing the lamp's program where it meets the lamp; the sun's disc, which BSDF rays seldom meet, 1024 samples)."""
    def mean(sampling):
        lamp = lamps_with_programs()[index]
        settings = RenderSettings(width=8, height=8, samples=1024 if index == 0 else 256, kernels=kernels,
                                  light_sampling=sampling)
        return render.render(floor_scene(lamp), settings).image[..., :3].mean()

    assert mean("bsdf") == pytest.approx(mean("light"), rel=0.03)


def test_map_to_sphere_is_cycles():
    """Cycles' map_to_sphere: u = 1/2 - atan2(x, y) / 2 pi, v = 1 - acos(z) / pi; the poles u 0; zero (0, 0)."""
    co = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(map_to_sphere(co), [[0.5, 0.5], [0.25, 0.5], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0]],
                               atol=1e-15)
