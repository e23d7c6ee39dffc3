"""Cycles' two biased path-tracing settings, caustics switches and sample clamping, against closed forms on
both paths, and the Principled BSDF's layers without the closures a caustics filter takes away."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.materials.closures import FILTER_REFLECTIVE, FILTER_REFRACTIVE
from core.scene import RenderSettings, Scene


def glowing_furnace(albedo: float, mirror: float, emission: float, samples: int = 64) -> tuple:
    """The camera inside a closed, flat-shaded sphere that emits `emission` and is a Diffuse BSDF of `albedo`
    mixed with a perfect mirror of `mirror` (tests/test_path.py's furnace with a glossy part). The radiance
    is the same everywhere and from every direction, so each bounce multiplies by what the closures reflect."""
    scene = Scene(camera=Camera(lens=18.0))
    scene.materials.append(materials.Material(name="glowing wall", nodes=[
        ("DIFFUSE", (albedo,) * 3, {}), ("MIRROR", (mirror,) * 3, {}),
        ("EMISSION", (1.0, 1.0, 1.0), {"emission": (emission,) * 3})]))
    scene.add_mesh(primitives.uv_sphere(3.0, 16, 8, smooth=False), materials=np.array([0]))
    settings = RenderSettings(width=8, height=8, samples=samples, integrator="path", max_bounces=48,
                              diffuse_bounces=48, glossy_bounces=48, min_light_bounces=1024)
    return scene, settings


def furnace_radiance(a: float, m: float, e: float, bounces: int, caustics: bool) -> float:
    """The glowing furnace's radiance seen by the camera with `bounces` bounces after the camera's hit: L(k) =
    e + a L_d(k - 1) + m L(k - 1), where a diffuse bounce's hit L_d sees the mirror only with reflective caustics
    (L_d(k) = e + a L_d(k - 1) without it); the last hit adds the light its diffuse part samples and the light its
    mirror's ray finds (both kernels trace that ray for the emission it hits, and no further): L(0) = e + a e
    + m e, and L_d(0) = e + a e without reflective caustics (the mirror is gone there), else L(0)."""
    L = e + a * e + m * e
    L_d = L if caustics else e + a * e
    for _ in range(bounces):
        L, L_d = e + a * (L if caustics else L_d) + m * L, e + a * L_d
    return L


@pytest.mark.parametrize("kernels, bounces, samples", [("numpy", 6, 32), ("compiled", 48, 32)])
def test_without_reflective_caustics_a_diffuse_bounce_sees_no_mirror(kernels, bounces, samples):
    """A furnace of diffuse albedo a and mirror m glowing with e: with caustics, L = e / (1 - a - m) (for endless
    bounces). Without reflective caustics the mirror is gone at hits a diffuse bounce's ray reaches, so those see
    L_d = e / (1 - a), and the camera (and mirror bounces) see L = (e + a L_d) / (1 - m) = e / ((1 - a)(1 - m)).
    With a bounce limit both are the sums furnace_radiance adds up (the reference kernel stops at 6 bounces to stay
    quick; at 32 samples, three seeds each, both kernels' means are within -0.4 % and +0.1 % of them: the
    reference's +0.4 % at 12 bounces, +1 % at 8 and +3.3 % at 4 were the last hit's mirror light, m e (a + m)^k,
    which the sums used to leave out)."""
    a, m, e = 0.5, 0.3, 1.0
    scene, settings = glowing_furnace(a, m, e, samples=samples)
    settings = dataclasses.replace(settings, kernels=kernels, max_bounces=bounces, diffuse_bounces=bounces,
                                   glossy_bounces=bounces)
    assert furnace_radiance(a, m, e, 10**4, True) == pytest.approx(e / (1.0 - a - m))
    assert furnace_radiance(a, m, e, 10**4, False) == pytest.approx(e / ((1.0 - a) * (1.0 - m)))
    with_caustics = render.render(scene, settings).image[..., :3]
    assert with_caustics.mean() == pytest.approx(furnace_radiance(a, m, e, bounces, True), rel=0.01)
    without = render.render(scene, dataclasses.replace(settings, caustics_reflective=False)).image[..., :3]
    assert without.mean() == pytest.approx(furnace_radiance(a, m, e, bounces, False), rel=0.01)
    # Refractive caustics concern glass alone: switched off here they change nothing (the compiled kernel's case;
    # the reference takes 4 s a render).
    if kernels == "numpy":
        return
    refractive_off = render.render(scene, dataclasses.replace(settings, caustics_refractive=False)).image[..., :3]
    np.testing.assert_array_equal(refractive_off, with_caustics)


def principled_closures(caustics: int, **inputs):
    """The closures of one head-on hit of a Principled BSDF with `inputs`, under the caustics filter bits."""
    node = materials.nodes.PrincipledNode
    row = node.row(inputs)
    N = np.array([[0.0, 0.0, 1.0]])
    result = materials.nodes.shade_nodes([(node, np.ones(3), row)], N, N, caustics=np.array([caustics]))
    c = result.closures
    kept = c.kind[0] >= 0
    return c.kind[0][kept], c.weight[0][kept], c.params[0][kept]


def test_a_principled_surface_without_reflective_caustics_is_its_diffuse_layer_alone():
    """Without reflective caustics the specular layer is left out together with the light it takes from the
    layers below (as Cycles sets it up): the diffuse closure then carries the whole base colour; a metallic
    share still takes its part of the weight, although its closure is gone; the coat still tints."""
    base = (0.8, 0.4, 0.2)
    kind, weight, _ = principled_closures(0, base_color=base)
    assert set(kind) == {materials.Lambert.kind, materials.Microfacet.kind}
    assert (weight[kind == materials.Lambert.kind][0] < base).all()        # the specular layer took its share
    kind, weight, _ = principled_closures(FILTER_REFLECTIVE, base_color=base)
    assert list(kind) == [materials.Lambert.kind]
    np.testing.assert_allclose(weight[0], base, rtol=1e-12)
    kind, weight, _ = principled_closures(FILTER_REFLECTIVE, base_color=base, metallic=0.25)
    assert list(kind) == [materials.Lambert.kind]
    np.testing.assert_allclose(weight[0], 0.75 * np.array(base), rtol=1e-12)
    kind, weight, _ = principled_closures(FILTER_REFLECTIVE, base_color=base, coat=1.0, coat_tint=(0.5, 1.0, 1.0))
    assert list(kind) == [materials.Lambert.kind]
    # Head-on the path through the coat is 1 / cos_t = 1 long: the tint itself.
    np.testing.assert_allclose(weight[0], np.array(base) * (0.5, 1.0, 1.0), rtol=1e-9)


def test_principled_transmission_without_a_caustic_keeps_the_other_half_of_its_glass():
    """Principled transmission is one glass closure; each caustics switch zeroes one of its two tints
    (reflection 1, transmission sqrt(base colour)), and with both off it is gone."""
    from core.materials.glass import REFLECT_TINT, TRANSMIT_TINT
    base = (0.64, 0.36, 1.0)
    kind, _, params = principled_closures(0, base_color=base, transmission=1.0, roughness=0.0)
    glass = params[kind == materials.Glass.kind][0]
    np.testing.assert_allclose(glass[REFLECT_TINT:REFLECT_TINT + 3], 1.0)
    np.testing.assert_allclose(glass[TRANSMIT_TINT:TRANSMIT_TINT + 3], np.sqrt(base))
    kind, _, params = principled_closures(FILTER_REFRACTIVE, base_color=base, transmission=1.0, roughness=0.0)
    glass = params[kind == materials.Glass.kind][0]
    np.testing.assert_allclose(glass[REFLECT_TINT:REFLECT_TINT + 3], 1.0)
    np.testing.assert_allclose(glass[TRANSMIT_TINT:TRANSMIT_TINT + 3], 0.0)
    kind, _, params = principled_closures(FILTER_REFLECTIVE, base_color=base, transmission=1.0, roughness=0.0)
    glass = params[kind == materials.Glass.kind][0]
    np.testing.assert_allclose(glass[REFLECT_TINT:REFLECT_TINT + 3], 0.0)
    np.testing.assert_allclose(glass[TRANSMIT_TINT:TRANSMIT_TINT + 3], np.sqrt(base))
    kind, _, _ = principled_closures(FILTER_REFLECTIVE | FILTER_REFRACTIVE, base_color=base, transmission=1.0)
    assert materials.Glass.kind not in kind and materials.RoughGlass.kind not in kind


def test_compiled_paths_filter_caustics_and_clamp_as_the_reference_does():
    """Glass, metal, coated and glossy surfaces under a lamp, an emitter and a world, path traced with both
    caustics switches off and both clamps on: the compiled path renders what the Python reference renders."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.lights import World
    scene = lit_scene(LIGHTS["several"])
    scene.materials[1] = materials.Material(name="glass", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"transmission": 1.0, "roughness": 0.2, "base_color": (0.9, 0.8, 0.7)})])
    scene.materials.append(materials.Material(name="coated metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 0.7, "coat": 0.5, "roughness": 0.3}),
        ("EMISSION", (1, 1, 1), {"emission": (4.0, 3.0, 2.0)})]))
    scene.materials.append(materials.Material(name="glass node", nodes=[("GLASS", (1, 1, 1), {"roughness": 0.3})]))
    scene.add_mesh(primitives.plane(0.6, center=(-1.2, 1.0, 1.5)), materials=np.array([2]))
    scene.add_mesh(primitives.box((0.5, 0.5, 0.5), center=(-1.0, -0.8, 0.25)), materials=np.array([3]))
    scene.world = World(color=np.array([0.1, 0.12, 0.15]), camera=True, lights=True)
    settings = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=4,
                              caustics_reflective=False, caustics_refractive=False,
                              sample_clamp_direct=0.5, sample_clamp_indirect=0.1)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    # The switches changed the picture (else this test could not fail).
    unbiased = render.render(scene, dataclasses.replace(settings, caustics_reflective=True, caustics_refractive=True,
                                                        sample_clamp_direct=0.0, sample_clamp_indirect=0.0))
    assert abs(unbiased.image[..., :3].mean() - compiled.image[..., :3].mean()) > 0.01


def clamped_sum(terms: list, cap: float) -> float:
    """Sum of grey contributions, each clamped at `cap` per channel (Cycles' cap 3 x value on the channel sum)."""
    return sum(min(term, cap) for term in terms)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_clamping_caps_each_direct_and_indirect_contribution(kernels):
    """A glowing diffuse furnace found by BSDF rays alone (no light samples, no roulette), so each path
    is the same: the camera sees e, the camera's hit finds a e, vertex k finds a^(k+1) e. Clamp Direct caps
    the first two (the camera's and its hit's), Clamp Indirect each later one, at the value per grey channel.
    Every pixel's every sample is that path, so the reference kernel checks it on 2 x 2 pixels (the compiled on 8 x
    8): the same check at a sixteenth of the paths."""
    a, e, bounces = 0.6, 5.0, 24
    scene, settings = glowing_furnace(a, 0.0, e, samples=4)
    settings = dataclasses.replace(settings, max_bounces=bounces, light_sampling="bsdf", kernels=kernels)
    if kernels == "numpy":
        settings = dataclasses.replace(settings, width=2, height=2)
    direct = [e, a * e]
    indirect = [a ** (k + 1) * e for k in range(1, bounces + 1)]
    for clamp_direct, clamp_indirect in ((0.0, 0.0), (2.0, 0.0), (0.0, 1.0), (4.0, 0.5)):
        image = render.render(scene, dataclasses.replace(settings, sample_clamp_direct=clamp_direct,
                                                         sample_clamp_indirect=clamp_indirect)).image[..., :3]
        expected = (clamped_sum(direct, clamp_direct or np.inf) + clamped_sum(indirect, clamp_indirect or np.inf))
        np.testing.assert_allclose(image, expected, rtol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_clamp_direct_caps_what_the_camera_sees_by_its_channel_sum(kernels):
    """An emitter of (10, 5, 0) seen head-on, Clamp Direct 2: the channel sum 15 is capped at 3 x 2 = 6, so
    the colour keeps its hue at 0.4 of its value, (4, 2, 0); and the world where the camera sees it too."""
    from core.lights import World
    scene = Scene(camera=Camera(lens=18.0), world_color=np.array([3.0, 3.0, 3.0]))
    scene.world = World(color=np.array([3.0, 3.0, 3.0]), camera=True, lights=False)
    scene.materials.append(materials.Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (10.0, 5.0, 0.0)})]))
    scene.add_mesh(primitives.plane(0.5), np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -2.0], [0, 0, 0, 1.0]]),
                   materials=np.array([0]))
    settings = RenderSettings(width=16, height=16, samples=1, sample_clamp_direct=2.0, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    glowing = image[..., 0] > 3.5
    assert glowing.any() and (~glowing).any()
    np.testing.assert_allclose(image[glowing], np.broadcast_to([4.0, 2.0, 0.0], image[glowing].shape), rtol=1e-6)
    np.testing.assert_allclose(image[~glowing], 2.0, rtol=1e-6)


def test_clamping_values_must_be_finite_and_not_negative():
    """A negative or infinite clamp is refused with a message naming it."""
    scene, settings = glowing_furnace(0.5, 0.0, 1.0, samples=1)
    for bad in (-1.0, float("inf"), float("nan")):
        with pytest.raises(ValueError, match="sample clamp indirect"):
            render.render(scene, dataclasses.replace(settings, sample_clamp_indirect=bad))
