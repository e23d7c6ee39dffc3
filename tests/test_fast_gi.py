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


def test_compiled_fast_gi_in_media_follows_the_reference():
    """The lit scene of every kind of light with a glossy sphere, inside a scattering, absorbing and glowing fog box
    with Fast GI: AO Bounces 1 (and 2 with Volume Bounces 2), 3 bounces and an AO Distance that ends some rays in the
    fog and lets others out of it: the compiled path renders what the Python reference renders, with the same rays (the
    short rays' media absorbing and emitting alone, the phase rays of points on the camera rays and on later stretches
    short, escaping ones out of the meshes' media)."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    scene = lit_scene(LIGHTS["several"])
    scene.materials[1] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.3})])
    scene.world = World(color=np.array([0.3, 0.35, 0.4]), camera=True, lights=True)
    scene.materials.append(materials.Material(np.zeros(3), "fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                              volume=[("COEFFICIENTS", 1.0, {
                                                  "absorption": np.array([0.05, 0.1, 0.15]),
                                                  "scatter": np.array([0.3, 0.25, 0.2]),
                                                  "emission": np.array([0.02, 0.01, 0.03]), "anisotropy": 0.3})],
                                              volume_only=True))
    scene.add_mesh(primitives.box((6.0, 6.0, 3.0), center=(0.0, 0.0, 1.4)),
                   materials=np.array([len(scene.materials) - 1]))
    for ao_bounces, volume_bounces in ((1, 0), (2, 2)):      # (with Volume Bounces: chains cut where Fast GI's)
        fast = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=3, ao_bounces=ao_bounces,
                              ao_factor=0.5, ao_distance=1.5, volume_bounces=volume_bounces)
        compiled, reference = compare_paths(scene, fast)
        assert_same_render(compiled, reference)


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
    """Add with a short AO Distance on the scene with every kind of light and a metal sphere (dark enough that
    Russian roulette still ends its paths: on long bright paths the kernels part by about 1e-6), three bounces: the
    compiled path renders what the Python reference renders, with the same rays; brighter than without it."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    scene = lit_scene(LIGHTS["several"])
    scene.materials[1] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.45, 0.3, 0.15), "roughness": 0.3})])
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


FOG_TOP = 2.0          # the fog box's top, metres above the floor


def floor_in_fog(closure: str, camera_height: float, **inputs) -> Scene:
    """floor_under_sky with the orthographic camera `camera_height` above the floor (its rays starting there: Clip
    Start 0), both inside a volume-only box
    (a Transparent surface) of one medium (`closure` with `inputs`) from 0.1 below the floor to FOG_TOP above it,
    2000 m wide."""
    scene = floor_under_sky()
    scene.camera = dataclasses.replace(scene.camera, clip_start=0.0, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, camera_height], [0, 0, 0, 1.0]]))
    scene.materials.append(materials.Material(np.zeros(3), "fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                              volume=[(closure, 1.0, inputs)], volume_only=True))
    scene.add_mesh(primitives.box((2000.0, 2000.0, FOG_TOP + 0.1), center=(0.0, 0.0, (FOG_TOP - 0.1) / 2.0)),
                   materials=np.array([len(scene.materials) - 1]))
    return scene


def twice_e3(x) -> np.ndarray:
    """2 E3(x) per channel of x (3,): the cosine-weighted mean of exp(-x / mu) over the hemisphere, the share of a
    Lambert point's directions' light that crosses a slab of optical depth x above it (midpoint rule, 1e-9 close)."""
    mu = (np.arange(400000) + 0.5) / 400000
    return np.array([2.0 * np.mean(mu * np.exp(-v / mu)) for v in np.asarray(x, np.float64)])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_rays_in_a_glowing_absorbing_fog_only_absorb_and_emit_and_escaping_leave_it(kernels):
    """Replace (AO Bounces 1, factor f) on the floor inside an absorbing fog that glows (sigma_a = (0.3, 0.2, 0.1),
    emission e), the camera 0.5 above the floor (T_c = exp(-0.5 sigma_a)), the fog's top 2 m up. With AO Distance 1
    every short ray escapes within the fog: Cycles cleans the volume stack of a ray that hits nothing (the meshes' media
    gone, volume_stack_clean), so it brings the world times f with nothing absorbed nor emitted on the way: the floor
    shows T_c albedo f L + e (1 - T_c) / sigma_a (the camera ray's own glow) exactly (until 2026-11-30 Primer absorbed
    the ray over an infinite fog: T_c x 0 plus the ray's glow e / sigma_a). With AO Distance 1000 the rays cross the
    fog's top (a volume boundary: on, short again) to the world: T_c albedo (f L 2 E3(2 sigma_a) + e / sigma_a
    (1 - 2 E3(2 sigma_a))) + the camera ray's glow."""
    sigma, glow, f = np.array([0.3, 0.2, 0.1]), np.array([0.05, 0.1, 0.15]), 0.6
    scene = floor_in_fog("COEFFICIENTS", 0.5, absorption=sigma, emission=glow)
    T_c = np.exp(-0.5 * sigma)
    camera_glow = glow * (1.0 - T_c) / sigma
    escaping = render.render(scene, settings(kernels, ao_bounces=1, ao_factor=f, ao_distance=1.0)).image[..., :3]
    np.testing.assert_allclose(escaping, np.broadcast_to(T_c * ALBEDO * f * SKY + camera_glow, escaping.shape),
                               rtol=1e-4)
    share = twice_e3(FOG_TOP * sigma)
    crossing = render.render(scene, dataclasses.replace(settings(kernels, ao_bounces=1, ao_factor=f,
                                                                 ao_distance=1000.0), samples=256)).image[..., :3]
    expected = T_c * ALBEDO * (f * SKY * share + glow / sigma * (1.0 - share)) + camera_glow
    np.testing.assert_allclose(crossing.reshape(-1, 3).mean(axis=0), expected, rtol=0.02)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_fast_gi_rays_do_not_scatter_in_a_scattering_fog(kernels):
    """Replace on the floor inside a scattering fog (sigma_s = 0.5 x (0.4, 0.6, 0.8), no absorption), the camera 0.1
    mm above the floor (what the fog scatters along its ray, about sigma_s 1e-4 L, is below 1e-4 of the floor's
    light): Fast GI's short rays only absorb (out-scatter) and emit, as Cycles' terminated paths (attenuation only, no
    scattering event). AO Distance 1: they escape within the fog and bring the world times f, nothing taken: albedo f L
    (until 2026-11-30 Primer scattered the world's light towards them along an infinite fog and let nothing through).
    AO Distance 1000: through the fog's top, albedo f L 2 E3(2 sigma_s)."""
    sigma, f = 0.5 * np.array([0.4, 0.6, 0.8]), 0.6
    scene = floor_in_fog("SCATTER", 1e-4, color=np.array([0.4, 0.6, 0.8]), density=0.5, anisotropy=0.0)
    escaping = render.render(scene, settings(kernels, ao_bounces=1, ao_factor=f, ao_distance=1.0)).image[..., :3]
    np.testing.assert_allclose(escaping, ALBEDO * f * SKY, rtol=2e-4)
    crossing = render.render(scene, dataclasses.replace(settings(kernels, ao_bounces=1, ao_factor=f,
                                                                 ao_distance=1000.0), samples=256)).image[..., :3]
    np.testing.assert_allclose(crossing.reshape(-1, 3).mean(axis=0), ALBEDO * f * SKY * twice_e3(FOG_TOP * sigma),
                               rtol=0.03)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_phase_ray_past_ao_bounces_is_short_and_sees_the_world_times_the_factor(kernels):
    """Replace with AO Bounces 1: a scattering event counts as a bounce (Cycles' path_state_next), so the phase ray of
    a point where the camera ray scatters is already Fast GI's. A grey scattering fog (sigma_s 0.3, no absorption), a
    black floor 1 m below the camera, AO Distance 1 mm: every phase ray escapes within the fog (but those of points
    within 1 mm of the floor) and brings the world times f, nothing absorbed (the meshes' media left): the pixel is
    the camera ray's scattering f L (1 - exp(-sigma_s 1)) (within 1e-3; until 2026-11-30 Primer's phase rays looked as
    far as any other, to the fog's top, through its transmittance to the world unscaled). With Volume Bounces 2 the
    same: a path whose phase ray is Fast GI's scatters no more (Cycles ends it after the volume), so its single
    scattering with that short ray is all it brings. With AO Bounces 2 they are
    not Fast GI's: each looks to the black floor or through the fog above it to the whole world, the pixel the
    integral over the camera ray of sigma_s exp(-sigma_s s) L E2(sigma_s (1 + s)) / 2 (its point at height 1 - s below
    the fog's top 2 m up; E2 the isotropic upper half's mean transmittance), within 3 %."""
    sigma, f = 0.3, 0.4
    scene = floor_in_fog("SCATTER", 1.0, color=np.ones(3), density=sigma, anisotropy=0.0)
    scene.materials[0] = materials.Material(np.zeros(3), name="floor")
    for volume_bounces in (0, 2):
        image = render.render(scene, dataclasses.replace(settings(kernels, ao_bounces=1, ao_factor=f, ao_distance=1e-3),
                                                         volume_bounces=volume_bounces)).image[..., :3]
        np.testing.assert_allclose(image, f * SKY * (1.0 - math.exp(-sigma)), rtol=1e-3, err_msg=str(volume_bounces))
    whole = render.render(scene, settings(kernels, ao_bounces=2, ao_factor=f, ao_distance=1e-3)).image[..., :3]
    mu = (np.arange(20000) + 0.5) / 20000                # (E2(x) = the mean of exp(-x / mu) over mu in (0, 1))
    along = (np.arange(2000) + 0.5) / 2000
    expected = np.mean([sigma * math.exp(-sigma * t) * SKY * 0.5 * np.mean(np.exp(-sigma * (1.0 + t) / mu))
                        for t in along])
    assert whole.mean() == pytest.approx(expected, rel=0.03)


def test_a_medium_objects_own_ao_distance_is_said_once_for_phase_rays():
    """The phase rays of scattering points look the render's AO Distance far, where Cycles takes that of the object
    whose medium is first in the ray's stack: said once where an object has its own; nothing said where none has."""
    scene = floor_in_fog("SCATTER", 1.0, color=np.ones(3), density=0.3, anisotropy=0.0)
    fast_gi = dict(ao_bounces=1, ao_factor=0.4, ao_distance=1e-3)
    quiet = render.render(scene, dataclasses.replace(settings("numpy", **fast_gi), samples=1))
    assert not any("Fast GI" in note for note in quiet.stats.warnings)
    scene.instances[1].ao_distance = 0.5
    said = render.render(scene, dataclasses.replace(settings("numpy", **fast_gi), samples=1))
    assert sum("own AO Distance" in note for note in said.stats.warnings) == 1


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
