"""Cycles' Fast GI Approximation. Replace: past AO Bounces a path's ray looks AO Distance far, ends its path at the
surface it meets, and brings the world's light times the AO Factor where it escapes. Add: every vertex adds ambient
occlusion times its diffuse-type closures' weights times the factor. Closed forms on both kernels."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.lights.world import World
from core.scene import RenderSettings, Scene

ALBEDO = 0.5
SKY = 2.0


def floor_under_sky(ceiling: float = 0.0, roof: float = 0.0, ceiling_albedo: float = 0.5) -> Scene:
    """A grey Lambert floor (ALBEDO) under a constant world SKY, seen straight down by an orthographic camera at
    z = 0.5 whose 4 x 4 pixels cover 1 cm of it; a square ceiling (albedo ceiling_albedo) of half-width `ceiling` at
    z = 1 above the camera (0: none); a wide clear roof (a Transparent BSDF of colour `roof`) at z = 0.75 (0: none)."""
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.01, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.5], [0, 0, 0, 1.0]])), world=World(color=np.full(3, SKY)))
    scene.materials.append(materials.Material((ALBEDO,) * 3, name="floor"))
    scene.add_mesh(primitives.plane(4000.0), materials=np.array([0]))
    if ceiling:
        scene.materials.append(materials.Material((ceiling_albedo,) * 3, name="ceiling"))
        scene.add_mesh(primitives.plane(2.0 * ceiling, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    if roof:
        scene.materials.append(materials.Material(name="roof", nodes=[("TRANSPARENT", (roof,) * 3, {})]))
        scene.add_mesh(primitives.plane(4000.0, center=(0.0, 0.0, 0.75)),
                       materials=np.array([len(scene.materials) - 1]))
    return scene


def settings(kernels: str, **fast_gi) -> RenderSettings:
    """Path tracing, 4 x 4 pixels, with the Fast GI settings given."""
    return RenderSettings(width=4, height=4, samples=64, integrator="path", kernels=kernels, **fast_gi)


def square_form_factor(half_width: float, height: float) -> float:
    """The share of a Lambert point's cosine-weighted directions that meet a square of half-width a straight above
    it at `height` h (the point-to-parallel-rectangle form factor, four corner rectangles of sides a, a):
    4 / (2 pi) x 2 A / sqrt(1 + A^2) atan(A / sqrt(1 + A^2)), A = a / h."""
    A = half_width / height
    root = math.sqrt(1.0 + A * A)
    return 4.0 / (2.0 * math.pi) * 2.0 * A / root * math.atan(A / root)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_scales_the_world_found_past_ao_bounces_by_the_ao_factor(kernels):
    """The floor's light is the world found by its BSDF rays (a constant world has no light samples): with AO
    Bounces 1 the camera hit's ray is already Fast GI's, so the floor shows albedo x factor x L exactly; with AO
    Bounces 2 it is not (albedo x L); an AO Factor of 0 turns Fast GI off (Cycles' sync), as does 0 AO Bounces."""
    scene = floor_under_sky()
    for fast_gi, expected in (({"ao_bounces": 1, "ao_factor": 0.3}, ALBEDO * 0.3 * SKY),
                              ({"ao_bounces": 2, "ao_factor": 0.3}, ALBEDO * SKY),
                              ({"ao_bounces": 1, "ao_factor": 0.0}, ALBEDO * SKY),
                              ({"ao_bounces": 0, "ao_factor": 0.3}, ALBEDO * SKY)):
        image = render.render(scene, settings(kernels, **fast_gi)).image[..., :3]
        np.testing.assert_allclose(image, expected, rtol=1e-4, err_msg=str(fast_gi))


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_surface_within_ao_distance_ends_the_path_and_one_beyond_it_is_not_seen(kernels):
    """A grey square ceiling (half-width 1, 1 m above the floor, lit by nothing but the world): Fast GI's rays that
    meet it end there, so the floor keeps albedo x factor x L times the share of its directions that miss the ceiling,
    1 - the form factor (0.554); with AO Distance 0.5 the ceiling lies beyond the rays' reach and the floor shows
    albedo x factor x L, as under the open sky."""
    scene = floor_under_sky(ceiling=1.0)
    fast_gi = {"ao_bounces": 1, "ao_factor": 0.8}
    near = render.render(scene, dataclasses.replace(settings(kernels, **fast_gi), samples=256, ao_distance=10.0))
    blocked = square_form_factor(1.0, 1.0)
    assert blocked == pytest.approx(0.5541, abs=1e-4)
    assert near.image[..., :3].mean() == pytest.approx(ALBEDO * 0.8 * SKY * (1.0 - blocked), rel=0.03)
    far = render.render(scene, settings(kernels, ao_distance=0.5, **fast_gi)).image[..., :3]
    np.testing.assert_allclose(far, ALBEDO * 0.8 * SKY, rtol=1e-4)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_rays_still_look_through_clear_surfaces_to_the_scaled_world(kernels):
    """A clear roof (Transparent colour 0.6) 0.75 m above the floor, AO Distance 1000: the Fast GI ray ends its path at
    the roof but looks through it, as Cycles' terminate-after-transparent, to the world scaled by the factor: the floor
    shows albedo x 0.6 x factor x L (all but the rays within 0.04 degrees of the horizon, which escape short of the
    roof). With AO Distance 0.7 the roof is out of reach: albedo x factor x L."""
    scene = floor_under_sky(roof=0.6)
    fast_gi = {"ao_bounces": 1, "ao_factor": 0.5}
    image = render.render(scene, settings(kernels, ao_distance=1000.0, **fast_gi)).image[..., :3]
    np.testing.assert_allclose(image, ALBEDO * 0.6 * 0.5 * SKY, rtol=1e-4)
    image = render.render(scene, settings(kernels, ao_distance=0.7, **fast_gi)).image[..., :3]
    np.testing.assert_allclose(image, ALBEDO * 0.5 * SKY, rtol=1e-4)


def test_compiled_fast_gi_follows_the_reference():
    """A scene with every kind of light, an image-free world and a glossy sphere, Fast GI with AO Bounces 1 and a
    short AO Distance: the compiled path renders what the Python reference renders, with the same rays."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    scene = lit_scene(LIGHTS["several"])
    scene.materials[1] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.3})])
    scene.world = World(color=np.array([0.3, 0.35, 0.4]), camera=True, lights=True)
    fast = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=3, ao_bounces=1,
                          ao_factor=0.5, ao_distance=0.7)
    compiled, reference = compare_paths(scene, fast)
    assert_same_render(compiled, reference)
    full = render.render(scene, dataclasses.replace(fast, ao_factor=0.0, kernels="compiled"))
    assert compiled.image[..., :3].mean() < full.image[..., :3].mean()     # (the world's light past a bounce, halved)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_add_adds_the_diffuse_weight_times_the_factor_where_the_sky_is_open(kernels):
    """Add, factor a: the floor under the open sky shows its whole-path light albedo x L plus, from its ambient
    occlusion ray that always escapes, albedo x a: exactly (rtol 1e-4)."""
    scene = floor_under_sky()
    image = render.render(scene, settings(kernels, ao_additive_factor=0.7)).image[..., :3]
    np.testing.assert_allclose(image, ALBEDO * (SKY + 0.7), rtol=1e-4)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_add_is_occluded_by_a_surface_within_ao_distance(kernels):
    """Add under a black square ceiling (half-width 1, 1 m up; black: it reflects and adds nothing): the floor's paths
    and its ambient occlusion both miss the ceiling's share F = 0.554 of directions, albedo (L + a)(1 - F); with AO
    Distance 0.5 the occlusion is open again: albedo (L (1 - F) + a)."""
    scene = floor_under_sky(ceiling=1.0, ceiling_albedo=0.0)
    F = square_form_factor(1.0, 1.0)
    near = render.render(scene, dataclasses.replace(settings(kernels, ao_additive_factor=0.7), samples=256))
    assert near.image[..., :3].mean() == pytest.approx(ALBEDO * (SKY + 0.7) * (1.0 - F), rel=0.03)
    far = render.render(scene, dataclasses.replace(settings(kernels, ao_additive_factor=0.7, ao_distance=0.5),
                                                   samples=256))
    assert far.image[..., :3].mean() == pytest.approx(ALBEDO * (SKY * (1.0 - F) + 0.7), rel=0.03)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_add_takes_closures_of_the_diffuse_type_not_the_diffuse_label(kernels):
    """Cycles' surface_shader_ao takes the closures whose *type* is diffuse (CLOSURE_IS_BSDF_DIFFUSE): on the
    open-sky floor seen straight down, a Microfiber Sheen of colour c (the diffuse type) adds its closure's weight
    c x R(mu 1, roughness 1) = 0.34 c x a (exactly: the same paths with and without Add); the Ashikhmin velvet, labelled diffuse
    but of the glossy type (CLOSURE_BSDF_ASHIKHMIN_VELVET_ID), adds nothing."""
    from core.materials.sheen import params_of
    color = (0.9, 0.6, 0.3)
    for velvet in (0.0, 1.0):
        scene = floor_under_sky()
        scene.materials[0] = materials.Material(name="cloth", nodes=[
            ("SHEEN", color, {"roughness": 1.0, "velvet": velvet})])
        plain = render.render(scene, settings(kernels)).image[..., :3]
        added = render.render(scene, settings(kernels, ao_additive_factor=0.7)).image[..., :3]
        R = 0.0 if velvet else float(params_of(np.array([1.0]), np.array([1.0]))[1][0])
        assert velvet or R == pytest.approx(0.3419, abs=1e-4)
        np.testing.assert_allclose(added - plain, np.broadcast_to(np.multiply(color, R * 0.7), plain.shape),
                                   rtol=1e-4, atol=1e-7, err_msg=f"velvet {velvet}")


def test_compiled_fast_gi_add_follows_the_reference():
    """Add with a short AO Distance on the scene with every kind of light and a metal sphere, three bounces: the
    compiled path renders what the Python reference renders, with the same rays; brighter than without it."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    scene = lit_scene(LIGHTS["several"])
    scene.materials[1] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.3})])
    added = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=3, ao_additive_factor=0.5,
                           ao_distance=0.7)
    compiled, reference = compare_paths(scene, added)
    assert_same_render(compiled, reference)
    plain = render.render(scene, dataclasses.replace(added, ao_additive_factor=0.0, kernels="compiled"))
    assert compiled.image[..., :3].mean() > plain.image[..., :3].mean()


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_an_objects_own_ao_distance_sets_how_far_the_rays_leaving_it_look(kernels):
    """Replace under the grey square ceiling (1 m up), the world's AO Distance 10: the floor's own AO Distance 0.5
    (Object > Visibility) makes its rays too short to meet the ceiling (albedo x factor x L exactly); the ceiling's
    own 0.5 changes nothing, as the rays leave the floor (1 - the form factor of it), as Cycles' intersect_closest
    takes the distance of the object a ray leaves."""
    scene = floor_under_sky(ceiling=1.0)
    fast_gi = dict(ao_bounces=1, ao_factor=0.8, ao_distance=10.0)
    scene.instances[0].ao_distance = 0.5
    image = render.render(scene, settings(kernels, **fast_gi)).image[..., :3]
    np.testing.assert_allclose(image, ALBEDO * 0.8 * SKY, rtol=1e-4)
    scene.instances[0].ao_distance, scene.instances[1].ao_distance = 0.0, 0.5
    near = render.render(scene, dataclasses.replace(settings(kernels, **fast_gi), samples=256)).image[..., :3]
    assert near.mean() == pytest.approx(ALBEDO * 0.8 * SKY * (1.0 - square_form_factor(1.0, 1.0)), rel=0.03)


@pytest.mark.parametrize("bad", [{"ao_bounces": -1}, {"ao_bounces": 1.5}, {"ao_factor": float("nan")},
                                 {"ao_additive_factor": float("inf")}])
def test_fast_gi_settings_out_of_range_are_refused(bad):
    """A negative or fractional AO Bounces, a factor that is not a finite number: a ValueError naming the setting."""
    with pytest.raises(ValueError, match=list(bad)[0].replace("_", " ")):
        render.render(floor_under_sky(), settings("numpy", **bad))


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_shadow_catcher_pass_divides_the_added_occlusion_by_catcher_only_light_without_it(kernels):
    """Add on a catcher floor under the open sky: the whole scene's path brings albedo (L + a), the catcher-only one
    albedo L (Cycles' split path, PATH_RAY_SHADOW_CATCHER_PASS, adds no ambient occlusion), so the Shadow Catcher
    pass is (L + a) / L exactly."""
    scene = floor_under_sky()
    scene.instances[0].is_shadow_catcher = True
    result = render.render(scene, settings(kernels, ao_additive_factor=0.7, shadow_catcher_pass=True))
    np.testing.assert_allclose(result.aux["shadow_catcher"][..., :3], (SKY + 0.7) / SKY, rtol=1e-4)
