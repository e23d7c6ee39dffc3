"""Subsurface scattering as Cycles' Random Walk (core/materials/subsurface.py, core/integrators/subsurface.py), held to
closed forms: Cycles' closure set-up (bssrdf_setup), a white object in a white world that keeps all its light where the
walk is short, radius 0 as the diffuse look, and the compiled kernel's fallback to the reference with a warning. The
comparison with Cycles' own render is tests/test_blender_subsurface.py."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.integrators import subsurface
from core.camera import Camera
from core.geometry import primitives
from core.lights.world import World
from core.materials import Material, nodes
from core.materials import subsurface as bssrdf
from core.materials.base import BSDFFlags, has
from core.materials.lambert import Lambert
from core.scene import RenderSettings, Scene, SunLight


def sphere_scene(inputs: dict, world: float, sun: bool) -> Scene:
    """A smooth sphere of a Principled BSDF with `inputs` in front of the camera, in a world of radiance `world`,
    with a sun or without."""
    scene = Scene(camera=Camera.look_at((0.0, -4.0, 0.0), (0.0, 0.0, 0.0), fov=math.radians(30)),
                  world=World(color=np.full(3, world)))
    scene.materials = [Material(name="Wax", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), inputs)])]
    scene.add_mesh(primitives.uv_sphere(0.8, 32, 16, smooth=True), materials=np.array([0]))
    if sun:
        scene.lights = [SunLight(np.array([0.5, 0.6, -0.4]), strength=3.0)]
    return scene


SETTINGS = RenderSettings(width=12, height=12, samples=32, integrator="path", max_bounces=64, diffuse_bounces=64,
                          kernels="numpy")


def principled_closures(inputs: dict):
    """The closures one Principled BSDF node of `inputs` sets up at a hit seen head-on (normal +z)."""
    N = np.array([[0.0, 0.0, 1.0]])
    b = nodes.ClosureBuilder(N, N.copy(), nodes.PrincipledNode.slots)
    nodes.PrincipledNode.setup(b, np.ones((1, 3)), nodes.PrincipledNode.row(inputs)[None, :])
    return b.result().closures


def test_the_principled_sets_up_cycles_bssrdf_with_its_radius_scaled_and_three_channels_of_sampling_weight():
    """Subsurface Weight 1: one BSSRDF closure of the clamped colour (under the specular layer), sampling weight 3 x its mean (one per channel
    it walks), radius x scale / (4 pi), the colour as albedo, the specular index (IOR at Specular IOR Level 0.5; at
    level 0 it is remapped to 1, clamped to 1.01, as Cycles passes it); no diffuse closure."""
    colour, radius, scale = np.array([0.8, 0.5, 0.3]), np.array([1.0, 0.2, 0.1]), 0.05
    inputs = {"base_color": colour, "subsurface": 1.0, "subsurface_radius": radius, "subsurface_scale": scale,
              "ior": 1.45}
    c = principled_closures(inputs)
    walks = np.flatnonzero(has(c.kind[0], BSDFFlags.SUBSURFACE))
    assert len(walks) == 1 and not (c.kind[0] == Lambert.kind).any()
    k = walks[0]
    # (the colour below what the specular layer reflects: one factor for all channels)
    np.testing.assert_allclose(c.weight[0, k] / colour, (c.weight[0, k] / colour)[0])
    np.testing.assert_allclose(c.sample_weight[0, k], 3.0 * c.weight[0, k].mean())
    p = c.params[0, k]
    np.testing.assert_allclose(p[bssrdf.RADIUS:bssrdf.RADIUS + 3], radius * scale / (4.0 * math.pi))
    np.testing.assert_allclose(p[bssrdf.ALBEDO:bssrdf.ALBEDO + 3], colour)
    assert p[bssrdf.IOR] == 1.45 and p[bssrdf.SKIN] == 0.0
    level_0 = principled_closures(dict(inputs, specular_ior_level=0.0))
    assert level_0.params[0, np.flatnonzero(has(level_0.kind[0], BSDFFlags.SUBSURFACE))[0], bssrdf.IOR] == 1.01


def test_a_channel_without_radius_scatters_as_a_lambert_of_its_share():
    """bssrdf_setup: a channel whose radius is 0 goes to a Lambert closure of that channel's weight; the BSSRDF keeps
    the other two, with a sampling weight of 2 x its mean."""
    colour = np.array([0.8, 0.5, 0.3])
    c = principled_closures({"base_color": colour, "subsurface": 1.0, "subsurface_radius": (1.0, 0.0, 0.1),
                             "specular_ior_level": 0.0})
    walk = np.flatnonzero(has(c.kind[0], BSDFFlags.SUBSURFACE))[0]
    lambert = np.flatnonzero(c.kind[0] == Lambert.kind)[0]
    np.testing.assert_allclose(c.weight[0, lambert], [0.0, 0.5, 0.0])
    np.testing.assert_allclose(c.weight[0, walk], [0.8, 0.0, 0.3])
    np.testing.assert_allclose(c.sample_weight[0, walk], 2.0 * (0.8 + 0.3) / 3.0)


def test_skin_shrinks_the_radius_by_the_dipole_of_its_colour_and_index():
    """Random Walk (Skin): radius x sqrt(3 (1 - alpha')), alpha' the single-scattering albedo whose dipole (index
    Subsurface IOR) reflects the colour: the dipole of the alpha' found reflects the colour again."""
    colour = np.array([[0.8, 0.5, 0.3]])
    ior = np.array([1.4])
    scaled = bssrdf.scaled_radius(np.ones((1, 3)), colour, ior, np.array([True]))
    alpha_prime = 1.0 - scaled ** 2 / 3.0
    inv = 1.0 / ior
    F_dr = inv * (-1.440 * inv + 0.710) + 0.668 + 0.0636 * ior
    np.testing.assert_allclose(bssrdf.dipole_Rd(alpha_prime, (4.0 / 3.0) * (1.0 + F_dr) / (1.0 - F_dr)), colour,
                               rtol=1e-2)          # (Cycles bisects 12 times: alpha' to 2^-12)


def test_a_white_subsurface_sphere_in_a_white_world_keeps_all_its_light_where_the_walk_is_short():
    """White furnace: colour 1 (alpha -> 1, nothing absorbed), no specular layer, a radius as large as the sphere
    (the walks leave within far fewer than Cycles' 256 steps): every pixel on the sphere sees the world's 1."""
    scene = sphere_scene({"base_color": (1.0, 1.0, 1.0), "subsurface": 1.0, "subsurface_scale": 10.0,
                          "specular_ior_level": 0.0}, 1.0, sun=False)
    image = render.render(scene, dataclasses.replace(SETTINGS, samples=64)).image[..., :3]
    centre = image[3:9, 3:9]                        # all on the sphere
    np.testing.assert_allclose(centre.mean(axis=(0, 1)), 1.0, atol=0.03)


def test_radius_zero_is_exactly_the_diffuse_look():
    """Radius 0 in every channel: bssrdf_setup makes the whole weight a Lambert closure of the clamped colour, the
    image of Subsurface Weight 0 (lit by a sun and the world, the same samples)."""
    inputs = {"base_color": (0.8, 0.5, 0.3), "subsurface_radius": (0.0, 0.0, 0.0)}
    settings = dataclasses.replace(SETTINGS, samples=4, max_bounces=4)
    walked = render.render(sphere_scene(dict(inputs, subsurface=1.0), 0.2, sun=True), settings).image
    diffuse = render.render(sphere_scene(dict(inputs, subsurface=0.0), 0.2, sun=True), settings).image
    np.testing.assert_allclose(walked, diffuse, rtol=1e-12, atol=1e-12)


def both_kernels(scene: Scene, **settings) -> tuple:
    """`scene` rendered by the Python reference and the compiled kernel (10 x 10, 4 samples, path traced with 4
    bounces unless `settings` say otherwise): (reference RenderResult, compiled RenderResult)."""
    settings = dataclasses.replace(SETTINGS, **{"width": 10, "height": 10, "samples": 4, "max_bounces": 4, **settings})
    return (render.render(scene, settings), render.render(scene, dataclasses.replace(settings, kernels="compiled")))


def assert_same_pixels(reference: render.RenderResult, compiled: render.RenderResult) -> None:
    """The compiled kernel rendered (not the reference) every pixel within a few float32 ulps of the reference's, and
    something to see."""
    assert compiled.stats.kernels == "compiled"
    assert reference.image[..., :3].max() > 0.01
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)


@pytest.mark.parametrize("inputs", [
    {"base_color": (0.8, 0.5, 0.3), "subsurface": 1.0, "subsurface_scale": 0.3},
    {"base_color": (0.8, 0.5, 0.3), "subsurface": 0.7, "subsurface_method": bssrdf.RANDOM_WALK_SKIN,
     "subsurface_anisotropy": 0.5},
    {"base_color": (0.9, 0.6, 0.2), "subsurface": 1.0, "subsurface_scale": 0.5, "roughness": 0.2,
     "subsurface_method": bssrdf.RANDOM_WALK_MFP, "subsurface_anisotropy": 0.8},
    {"base_color": (0.8, 0.5, 0.3), "subsurface": 1.0, "subsurface_radius": (1.0, 0.0, 0.3)}],
    ids=["random-walk", "skin-anisotropic", "mfp-guided-anisotropic", "one-channel-diffuse"])
@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_both_kernels_walk_a_subsurface_sphere_to_the_same_pixels(inputs, integrator):
    """The compiled walk (core/integrators/subsurface.c) takes the reference's steps with the same sampling
    dimensions: Random Walk, Skin with anisotropy (Henyey-Greenstein steps, the similarity relation after 9), Blender
    5.2's mean free path with g 0.8, and a channel of radius 0 (a Lambert beside the BSSRDF), lit by a sun and the
    world; the direct tracer as the path tracer with no bounces. No warning about kernels."""
    scene = sphere_scene(inputs, 0.2, sun=True)
    reference, compiled = both_kernels(scene, integrator=integrator)
    assert_same_pixels(reference, compiled)
    assert not any("compiled" in w for w in compiled.stats.warnings)


def test_both_kernels_walk_a_thin_slab_guided_back_towards_its_far_side_to_the_same_pixels():
    """A thin box (0.1 thick, a radius of several times that) lit from behind: the first step finds the far side, so
    Dwivedi's backward guiding is on; the exits on the far side carry the sun's light through. Both kernels agree, and
    the light through is there."""
    scene = Scene(camera=Camera.look_at((0.0, -4.0, 0.0), (0.0, 0.0, 0.0), fov=math.radians(30)),
                  world=World(color=np.full(3, 0.05)))
    scene.materials = [Material(name="Leaf", nodes=[("SUBSURFACE", (1.0, 1.0, 1.0),
                                                     {"color": (0.4, 0.8, 0.2), "radius": (1.0, 1.0, 0.5),
                                                      "scale": 0.5, "roughness": 0.3})])]
    slab = primitives.box((1.6, 0.1, 1.6))
    scene.add_mesh(slab, materials=np.array([0]))
    scene.lights = [SunLight(np.array([0.0, -1.0, 0.2]), strength=3.0)]
    reference, compiled = both_kernels(scene, samples=8)
    assert_same_pixels(reference, compiled)
    assert compiled.image[4:6, 4:6, 1].mean() > 0.02


def test_both_kernels_write_the_light_passes_and_first_hit_passes_of_a_walk_alike():
    """A walk's exit at the camera's path (no bounce counted) lights the Diffuse Direct pass, later light Diffuse
    Indirect; the exit is no camera hit for the first-hit passes (its normal, depth): both kernels agree on each."""
    scene = sphere_scene({"base_color": (0.8, 0.5, 0.3), "subsurface": 1.0, "subsurface_scale": 0.3}, 0.2, sun=True)
    passes = ("diffuse_direct", "diffuse_indirect", "diffuse_color", "average_normal", "z_depth")
    reference, compiled = both_kernels(scene, passes=passes)
    assert_same_pixels(reference, compiled)
    for name in passes:
        if name in reference.aux:
            np.testing.assert_allclose(compiled.aux[name], reference.aux[name], rtol=1e-5, atol=1e-6, err_msg=name)
    assert reference.aux["diffuse_direct"].max() > 0.01


def test_the_subsurface_scattering_node_sets_up_one_bssrdf_of_its_colour():
    """Blender's Subsurface Scattering node (Cycles' BSSRDF closure node): weight x Color, the colour as albedo,
    Radius x Scale / (4 pi) (Random Walk), its own IOR, its Roughness as the entry's alpha (not squared), Anisotropy."""
    colour = np.array([0.7, 0.4, 0.2])
    N = np.array([[0.0, 0.0, 1.0]])
    b = nodes.ClosureBuilder(N, N.copy(), bssrdf.SubsurfaceNode.slots)
    row = bssrdf.SubsurfaceNode.row({"color": colour, "radius": (2.0, 1.0, 0.5), "scale": 0.1, "ior": 1.3,
                                     "roughness": 0.4, "anisotropy": 0.3})
    bssrdf.SubsurfaceNode.setup(b, np.full((1, 3), 0.5), row[None, :])
    c = b.result().closures
    assert list(c.kind[0]) == [bssrdf.RandomWalk.kind]
    np.testing.assert_allclose(c.weight[0, 0], 0.5 * colour)
    p = c.params[0, 0]
    np.testing.assert_allclose(p[bssrdf.RADIUS:bssrdf.RADIUS + 3], np.array([2.0, 1.0, 0.5]) * 0.1 / (4.0 * math.pi))
    np.testing.assert_allclose(p[bssrdf.ALBEDO:bssrdf.ALBEDO + 3], colour)
    assert (p[bssrdf.IOR], p[bssrdf.ALPHA], p[bssrdf.ANISOTROPY]) == (1.3, 0.4, 0.3)


def test_the_direct_tracer_walks_as_the_path_tracer_with_no_bounces():
    """Cycles counts no bounce for the walk: the direct-light tracer renders a subsurface sphere as the path tracer at
    Max Bounces 0 (the walk, then the exit's light samples), the same image; Whitted's tracer warns it gives the
    BSSRDF no light."""
    scene = sphere_scene({"base_color": (0.8, 0.5, 0.3), "subsurface": 1.0}, 0.2, sun=True)
    settings = dataclasses.replace(SETTINGS, width=4, height=4, samples=2)
    direct = render.render(scene, dataclasses.replace(settings, integrator="direct"))
    path = render.render(scene, dataclasses.replace(settings, max_bounces=0))
    np.testing.assert_array_equal(direct.image, path.image)
    assert direct.image[..., :3].max() > 0.05
    whitted = render.render(scene, dataclasses.replace(settings, integrator="whitted")).stats.warnings
    assert any(w.startswith("subsurface: Whitted's tracer does not walk") for w in whitted)



def test_the_exit_is_lit_with_the_bssrdfs_own_normal_only_where_its_normal_is_linked():
    """Cycles' subsurface_shader_data_setup: a white Lambert at the exit, on sd->N, or on the BSSRDFs' normals
    weighed by their mean weight where one of them has a linked Normal (SD_HAS_BSSRDF_BUMP)."""
    from core.integrators import subsurface as walk
    N = np.array([[0.0, 0.0, 1.0]])
    tilted = np.array([[0.6, 0.0, 0.8]])
    for bumped in (False, True):
        b = nodes.ClosureBuilder(N, N.copy(), 2)
        if bumped:
            b.use_normal(tilted)
        bssrdf.SubsurfaceNode.setup(b, np.ones((1, 3)), bssrdf.SubsurfaceNode.row({})[None, :])
        exit_shader = walk.subsurface_shader(b.result(), np.array([True]))
        assert list(exit_shader.closures.kind[0]) == [Lambert.kind]
        np.testing.assert_allclose(exit_shader.closures.weight[0, 0], 1.0)
        np.testing.assert_allclose(exit_shader.closures.N[0, 0], tilted[0] if bumped else N[0])
        np.testing.assert_allclose(exit_shader.emission, 0.0)


def test_blender_5_2_walks_random_walk_with_the_radius_itself_as_the_mean_free_path():
    """Blender 5.0's and 5.1's Cycles scale Random Walk's radius by 1 / (4 pi); 5.2's does not (measured against
    its render, tests/test_blender_subsurface.py): method_of asks for RANDOM_WALK_MFP there, Skin and Christensen-Burley
    stay."""
    assert bssrdf.method_of("RANDOM_WALK", (5, 0, 1)) == bssrdf.RANDOM_WALK
    assert bssrdf.method_of("RANDOM_WALK", (5, 2, 0)) == bssrdf.RANDOM_WALK_MFP
    assert bssrdf.method_of("BURLEY", (5, 2, 0)) == bssrdf.BURLEY          # (the disk keeps its scale there)
    assert bssrdf.method_of("RANDOM_WALK_SKIN", (5, 2, 0)) == bssrdf.RANDOM_WALK_SKIN
    c = principled_closures({"subsurface": 1.0, "subsurface_radius": (1.0, 0.2, 0.1), "subsurface_scale": 0.5,
                             "subsurface_method": bssrdf.RANDOM_WALK_MFP})
    k = np.flatnonzero(has(c.kind[0], BSDFFlags.SUBSURFACE))[0]
    np.testing.assert_allclose(c.params[0, k, bssrdf.RADIUS:bssrdf.RADIUS + 3], [0.5, 0.1, 0.05])


def slab_over_ink(walk: dict, density: float, ink: str = "below") -> Scene:
    """A wide subsurface slab (0.2 thick, `walk` its closure: a Subsurface Scattering node's inputs, or a Principled's
    with "principled" set) seen from above (z = 4) in a black world, 0.5 above a wide plane emitting 1, with half of it
    inside a volume-only box of an absorbing medium (Volume Absorption, colour 0.5 and `density`: sigma_a = density /
    2): its lower half, the box going down past the plane (ink "below"), or its upper half, the box 0.4 above the slab
    (ink "above")."""
    scene = Scene(camera=Camera.look_at((0.0, 0.0, 4.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=math.radians(20)),
                  world=World(color=np.zeros(3)))
    inputs = {k: v for k, v in walk.items() if k != "principled"}
    closure = ("PRINCIPLED", (1.0, 1.0, 1.0), inputs) if walk.get("principled") else ("SUBSURFACE", (1.0, 1.0, 1.0),
                                                                                         inputs)
    scene.materials = [Material(name="Wax", nodes=[closure]),
                       Material(np.zeros(3), "Ink", nodes=[("TRANSPARENT", np.ones(3), {})],
                                volume=[("ABSORPTION", 1.0, {"color": np.full(3, 0.5), "density": density})],
                                volume_only=True),
                       Material(name="Glow", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": (1.0, 1.0, 1.0)})])]
    scene.add_mesh(primitives.box((44.0, 44.0, 0.2)), materials=np.array([0]))
    box = ((42.0, 42.0, 2.0), (0.0, 0.0, -1.0)) if ink == "below" else ((42.0, 42.0, 0.5), (0.0, 0.0, 0.25))
    scene.add_mesh(primitives.box(box[0], center=box[1]), materials=np.array([1]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, -0.6)), materials=np.array([2]))
    return scene


def twice_e3(x: float) -> float:
    """2 E3(x): the share of a uniform plane's light a Lambert surface at optical depth x above it receives through an
    absorbing medium, the cosine-weighted mean of exp(-x / mu) over the hemisphere (midpoint rule, 1e-9 close)."""
    mu = (np.arange(400000) + 0.5) / 400000
    return float(2.0 * np.mean(mu * np.exp(-x / mu)))


@pytest.mark.parametrize("walk", [
    {"color": (0.9, 0.9, 0.9), "radius": (1.0, 1.0, 1.0), "scale": 0.3},
    {"principled": True, "base_color": (0.9, 0.9, 0.9), "subsurface": 1.0, "subsurface_radius": (1.0, 1.0, 1.0),
     "subsurface_scale": 3.0, "subsurface_method": bssrdf.BURLEY, "specular_ior_level": 0.0}],
    ids=["random-walk", "christensen-burley"])
def test_light_leaving_a_walk_inside_an_absorbing_medium_keeps_twice_e3_of_its_optical_depth(walk):
    """The slab's top is outside the medium, its bottom inside: a walk from the top that leaves through the bottom
    crosses the box's top face on its way (Cycles' volume stack update for subsurface, subsurface.media_across), so
    the exit's light from the plane 0.5 below keeps 2 E3(sigma_a 0.5) of what it has without the medium (the walks
    themselves the same: absorption alone changes no sample). Keeping the entry's media instead would give 1. Both
    kernels render the same pixels."""
    settings = dataclasses.replace(SETTINGS, width=8, height=8, samples=16, max_bounces=8)
    inked, clear = (render.render(slab_over_ink(walk, density), settings) for density in (2.0, 0.0))
    ratio = inked.image[..., :3].mean() / clear.image[..., :3].mean()
    assert clear.image[..., :3].mean() > 0.01
    assert ratio == pytest.approx(twice_e3(1.0 * 0.5), rel=0.03)          # (0.4432; 1 without the update)
    assert not any("volume stack" in w for w in inked.stats.warnings)
    assert_same_pixels(inked, render.render(slab_over_ink(walk, 2.0), dataclasses.replace(settings, kernels="compiled")))


def test_light_leaving_a_walk_out_of_an_absorbing_medium_it_entered_from_keeps_all_of_it():
    """The slab's top inside the medium, its bottom outside, the plane below: the camera's rays keep exp(-sigma_a 0.4
    / cos) through the 0.4 of ink above the slab, and a walk that leaves through the bottom crosses the box's bottom
    face on its way out, so the plane's light reaches that exit in full (keeping the entry's media instead would take
    2 E3(0.5) = 0.44 more of it). Both kernels render the same pixels."""
    walk = {"color": (0.9, 0.9, 0.9), "radius": (1.0, 1.0, 1.0), "scale": 0.3}
    settings = dataclasses.replace(SETTINGS, width=8, height=8, samples=16, max_bounces=8)
    inked, clear = (render.render(slab_over_ink(walk, density, "above"), settings) for density in (2.0, 0.0))
    ratio = inked.image[..., :3].mean() / clear.image[..., :3].mean()
    # (the camera's rays over the image: directions (x, y, -1) with |x|, |y| up to tan(fov / 2))
    x = (np.arange(400) + 0.5) / 400 * 2.0 - 1.0
    x = x * math.tan(math.radians(10.0))
    camera = float(np.exp(-0.4 * np.sqrt(1.0 + x[:, None] ** 2 + x[None, :] ** 2)).mean())
    assert ratio == pytest.approx(camera, rel=0.03)                          # (0.667; 0.30 without the update)
    assert_same_pixels(inked, render.render(slab_over_ink(walk, 2.0, "above"),
                                            dataclasses.replace(settings, kernels="compiled")))


def test_the_walks_media_change_at_other_objects_media_boundaries_between_entry_and_exit_and_not_at_its_own():
    """subsurface.media_across on segments about the ink box's top face (z = 0): down through it enters the ink, up
    through it leaves it, along it (both ends above) changes nothing, nor does a walk in the box's own object; a
    stack at 0 stays there leaving a medium it is not in (Cycles' volume_stack_enter_exit)."""
    scene = slab_over_ink({"color": (0.9, 0.9, 0.9), "radius": (1.0, 1.0, 1.0), "scale": 0.3}, 2.0)
    ctx = render.prepare(scene, dataclasses.replace(SETTINGS, width=8, height=8))
    media, geometry = ctx.extra["media"], ctx.geometry
    at = lambda *points: np.array(points, np.float64) - geometry.origin          # noqa: E731 (camera-relative)
    material = geometry.triangle_data(np.arange(geometry.triangle_count), smooth=False).material
    owners = geometry.owners(np.arange(geometry.triangle_count))
    slab, ink = owners[material == 0][0], owners[material == 1][0]
    column = media.column[1]
    P0 = at((0.0, 0.0, 0.1), (0.3, 0.2, -0.1), (0.0, 0.0, 0.1), (0.0, 0.0, 0.1), (0.3, 0.2, -0.1))
    P1 = at((0.1, 0.0, -0.1), (0.0, 0.0, 0.1), (2.0, 0.0, 0.1), (0.0, 0.0, -0.1), (0.0, 0.0, 0.1))
    inside = media.start(5)
    inside[[1, 3], column] = 1
    owner = np.array([slab, slab, slab, ink, slab])
    after = subsurface.media_across(ctx, inside, P0, P1, owner)[:, column]
    np.testing.assert_array_equal(after, [1, 0, 0, 1, 0])
