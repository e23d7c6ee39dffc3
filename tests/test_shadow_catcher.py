"""Shadow catchers (Object > Visibility > Shadow Catcher, core/integrators/catcher.py), as Cycles shows them, on
both kernels: the Shadow Catcher pass is the catcher's light with the other objects over its light without them
(1 outside shadows, the unblocked lights' share inside), and Combined shows only what the objects do to the
catcher: nothing where nothing shadows it (transparent on a transparent film, the world on an opaque one), the
shadow in the alpha."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.lights import AreaLight, SunLight
from core.lights.world import World
from core.scene import RenderSettings, Scene

KERNELS = ["numpy", "compiled"]
SLANT = math.radians(45.0)
E_SLANT, E_DOWN = 3.0, 1.0               # the suns' irradiance at normal incidence, W/m^2


def looking_down(distance: float = 8.0, x: float = 0.0) -> Camera:
    """A camera `distance` above (x, 0, 0), looking straight down -Z."""
    return Camera(lens=35.0, matrix_world=np.array([[1, 0, 0, x], [0, 1, 0, 0], [0, 0, 1, distance], [0, 0, 0, 1.0]]))


def ball_over_catcher(world: float = 0.0, catcher: bool = True) -> Scene:
    """A grey catcher floor (albedo 0.5), a ball of radius 0.5 two metres above it, lit by a sun 45 degrees from the
    zenith (3 W/m^2, the ball's shadow 2 m along +x) and one straight down (1 W/m^2, its shadow under the ball). The
    camera, 3 m above the slanted sun's shadow, sees the floor alone."""
    scene = Scene(camera=looking_down(3.0, x=2.0), world=World(color=np.full(3, world)))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.5, center=(0.0, 0.0, 2.0)), materials=np.array([0]))
    scene.instances[0].is_shadow_catcher = catcher
    scene.lights.append(SunLight(np.array([math.sin(SLANT), 0.0, -math.cos(SLANT)]), strength=E_SLANT))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=E_DOWN))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_the_shadow_catcher_pass_is_one_in_light_and_the_other_suns_share_in_shadow(kernels, integrator):
    """Where the slanted sun's shadow falls on the catcher, the pass is the straight-down sun's share of the light,
    E_down / (E_slant cos 45 + E_down), to float rounding; wherever no shadow falls it is exactly 1; between the two
    only at the shadow's edge (pixels partly in it)."""
    share = E_DOWN / (E_SLANT * math.cos(SLANT) + E_DOWN)
    settings = RenderSettings(width=32, height=32, samples=4, kernels=kernels, integrator=integrator, max_bounces=0,
                              shadow_catcher_pass=True)
    result = render.render(ball_over_catcher(), settings)
    shadow = result.aux["shadow_catcher"]
    assert shadow.shape == (32, 32, 3)
    inside = np.isclose(shadow, share, rtol=1e-6).all(axis=-1)
    lit = (shadow == 1.0).all(axis=-1)
    assert inside.sum() >= 20 and lit.sum() >= 500
    assert (shadow >= share - 1e-6).all() and (shadow <= 1.0 + 1e-6).all()
    assert (inside | lit).sum() >= 0.9 * 32 * 32


@pytest.mark.parametrize("kernels", KERNELS)
def test_on_a_transparent_film_the_catcher_is_clear_but_for_its_shadow_in_the_alpha(kernels):
    """Film > Transparent, no Shadow Catcher pass (Cycles' approximate catcher): where nothing shadows the catcher the
    pixel is (0, 0, 0, 0); in the slanted sun's shadow it is black with alpha 1 - the pass, the blocked sun's share
    E_slant cos 45 / (E_slant cos 45 + E_down); with the pass written, Combined is the matte, clear everywhere."""
    blocked = E_SLANT * math.cos(SLANT) / (E_SLANT * math.cos(SLANT) + E_DOWN)
    settings = RenderSettings(width=32, height=32, samples=4, kernels=kernels, transparent_background=True)
    image = render.render(ball_over_catcher(), settings).image
    np.testing.assert_array_equal(image[..., :3], 0.0)
    clear = image[..., 3] == 0.0
    shade = np.isclose(image[..., 3], blocked, rtol=1e-6)
    assert clear.sum() >= 500 and shade.sum() >= 20
    matte = render.render(ball_over_catcher(), RenderSettings(width=32, height=32, samples=4, kernels=kernels,
                                                               transparent_background=True,
                                                               shadow_catcher_pass=True)).image
    np.testing.assert_array_equal(matte, 0.0)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_catcher_with_nothing_over_it_is_invisible(kernels):
    """A catcher floor alone under a sun and a grey world, path traced: on an opaque film every pixel is the world
    seen through it (0.3, alpha 1), as if the floor were not there; on a transparent film every pixel is clear."""
    scene = Scene(camera=looking_down(6.0), world=World(color=np.full(3, 0.3)))
    scene.add_material((0.8, 0.8, 0.8))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.instances[0].is_shadow_catcher = True
    scene.lights.append(SunLight(np.array([0.0, 0.6, -0.8]), strength=2.0))
    settings = RenderSettings(width=16, height=16, samples=4, kernels=kernels, integrator="path", max_bounces=2)
    opaque = render.render(scene, settings).image
    np.testing.assert_allclose(opaque[..., :3], 0.3, rtol=1e-6)
    np.testing.assert_array_equal(opaque[..., 3], 1.0)
    clear = render.render(scene, RenderSettings(width=16, height=16, samples=4, kernels=kernels, integrator="path",
                                                max_bounces=2, transparent_background=True)).image
    np.testing.assert_allclose(clear, 0.0, atol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_objects_other_than_the_catcher_render_as_without_it(kernels):
    """The ball's own pixels in Combined are those of the same scene with an ordinary floor (the catcher is only a
    hole where the camera sees it), exactly: the matte holds the ball's samples as the render made them."""
    settings = RenderSettings(width=32, height=32, samples=4, kernels=kernels, integrator="path", max_bounces=2,
                              shadow_catcher_pass=True)
    scene = ball_over_catcher(world=0.2)
    scene.camera = looking_down(6.0)
    caught = render.render(scene, settings).image
    scene.instances[0].is_shadow_catcher = False
    plain = render.render(scene, settings).image
    ball = caught[..., 3] == 1.0
    assert ball.sum() >= 20
    np.testing.assert_array_equal(caught[ball], plain[ball])


def glowing_quad_over_catcher() -> Scene:
    """A catcher floor lit only by a glowing quad above it that is no catcher."""
    scene = Scene(camera=looking_down(6.0))
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (0.5,) * 3, {})]),
                        materials.Material(name="lamp", nodes=[("EMISSION", (1, 1, 1), {"emission": (8.0,) * 3})])]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    lamp = np.array([[1, 0, 0, 2.5], [0, -1, 0, 0], [0, 0, -1, 1.5], [0, 0, 0, 1.0]])     # facing down, 1.5 up
    scene.add_mesh(primitives.plane(1.0), lamp, materials=np.array([1]))
    scene.instances[0].is_shadow_catcher = True
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_emitter_that_is_no_catcher_does_not_light_the_catcher_only_scene(kernels):
    """The floor lit by a glowing quad that is no catcher: in the catcher-only scene it has no light at all (Cycles
    leaves such emitters out of the catcher's paths), so the pass is 1 (Cycles' division by 0) everywhere."""
    settings = RenderSettings(width=16, height=16, samples=4, kernels=kernels, integrator="path", max_bounces=1,
                              shadow_catcher_pass=True)
    result = render.render(glowing_quad_over_catcher(), settings)
    np.testing.assert_array_equal(result.aux["shadow_catcher"], 1.0)


def test_without_a_catcher_the_pass_is_one_and_combined_unchanged():
    """No catcher in the scene: the Shadow Catcher pass is 1 everywhere and Combined is the ordinary render."""
    settings = RenderSettings(width=16, height=16, samples=2, kernels="numpy")
    plain = render.render(ball_over_catcher(catcher=False), settings)
    asked = render.render(ball_over_catcher(catcher=False), RenderSettings(width=16, height=16, samples=2,
                                                                           kernels="numpy", shadow_catcher_pass=True))
    np.testing.assert_array_equal(asked.aux["shadow_catcher"], 1.0)
    np.testing.assert_array_equal(asked.image, plain.image)


@pytest.mark.parametrize("transparent, with_pass, pane", [(False, False, False), (False, True, False),
                                                          (True, False, False), (True, True, False),
                                                          (False, False, True), (True, True, True)])
def test_the_kernels_agree_on_the_catchers_images(transparent, with_pass, pane):
    """A path-traced catcher under a ball, a sun, a grey world and a glowing quad that is no catcher (and seen through
    a clear pane): the compiled kernel's Combined, Shadow Catcher pass, light passes and light groups are the
    reference's, within a few float32 ulps."""
    scene = ball_over_catcher(world=0.2)
    lamp = np.array([[1, 0, 0, 3.0], [0, -1, 0, 1.0], [0, 0, -1, 1.0], [0, 0, 0, 1.0]])
    scene.materials.append(materials.Material(name="lamp", nodes=[("EMISSION", (1, 1, 1), {"emission": (4.0,) * 3})]))
    scene.add_mesh(primitives.plane(0.5), lamp, materials=np.array([1]))
    if pane:
        behind_a_pane(scene)
    scene.lightgroups = {"lights": ["S", ""], "instances": ["", "", "S"] + [""] * pane, "world": "W"}
    images = {}
    for kernels in KERNELS:
        settings = RenderSettings(width=24, height=24, samples=4, kernels=kernels, integrator="path", max_bounces=3,
                                  transparent_background=transparent, shadow_catcher_pass=with_pass,
                                  passes=("diffuse_direct", "diffuse_indirect"), light_groups=("S", "W"))
        result = render.render(scene, settings)
        assert result.stats.kernels.startswith(kernels)
        images[kernels] = result
    numpy, compiled = images["numpy"], images["compiled"]
    np.testing.assert_allclose(compiled.image, numpy.image, rtol=1e-5, atol=4e-6)
    names = ["diffuse_direct", "diffuse_indirect", "lightgroup:S", "lightgroup:W"] + (["shadow_catcher"] * with_pass)
    for name in names:
        np.testing.assert_allclose(compiled.aux[name], numpy.aux[name], rtol=1e-5, atol=4e-6, err_msg=name)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lamp_the_camera_sees_in_front_of_the_catcher_stays_in_combined(kernels):
    """An area lamp facing the camera above the sunlit catcher floor (it lights nothing below it): on a transparent
    film its pixels keep its radiance, alpha 0, exactly as where the floor is not seen at all (Cycles writes what the
    camera sees before a catcher to the matte), and the pass is the one without the lamp, pixel for pixel (within the
    float32 rounding of Combined, from which the lamp's light is taken away again)."""
    def scene(hide_floor: bool = False, lamp: bool = True) -> Scene:
        s = ball_over_catcher()
        s.instances[0].visible_camera = not hide_floor
        if lamp:
            s.lights.append(AreaLight(center=np.array([2.0, 0.3, 1.5]), axis_u=np.array([0.6, 0.0, 0.0]),
                                      axis_v=np.array([0.0, 0.6, 0.0]), direction=np.array([0.0, 0.0, 1.0]),
                                      power=20.0))
        return s
    settings = RenderSettings(width=24, height=24, samples=4, kernels=kernels, transparent_background=True,
                              shadow_catcher_pass=True)
    caught = render.render(scene(), settings)
    bare = render.render(scene(hide_floor=True), settings)
    lamp = (bare.image[..., :3] > 0.0).all(axis=-1)
    assert lamp.sum() >= 9
    np.testing.assert_allclose(caught.image[lamp], bare.image[lamp], rtol=1e-6)
    assert (caught.image[lamp][..., 3] == 0.0).all()
    unlit = render.render(scene(lamp=False), settings)
    np.testing.assert_allclose(caught.aux["shadow_catcher"], unlit.aux["shadow_catcher"], atol=1e-5)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_path_that_meets_a_catcher_writes_no_light_pass_and_no_light_group(kernels):
    """As Cycles (film_write_direct_light, film_write_emission_or_background_pass): where the camera sees the catcher,
    Diffuse Direct and the suns' light group are 0, while Combined's catcher light (the Shadow Catcher pass's
    numerator) is there; the ball, no catcher, keeps both, as without the catcher."""
    scene = ball_over_catcher()
    scene.camera = looking_down(6.0)
    scene.lightgroups = {"lights": ["S", "S"], "instances": ["", ""], "world": ""}
    settings = RenderSettings(width=24, height=24, samples=2, kernels=kernels, passes=("diffuse_direct",),
                              light_groups=("S",), shadow_catcher_pass=True)
    caught = render.render(scene, settings)
    scene.instances[0].is_shadow_catcher = False
    plain = render.render(scene, settings)
    floor = caught.image[..., 3] == 0.0                   # (the matte's hole: all samples on the catcher)
    ball = caught.image[..., 3] == 1.0
    assert floor.sum() >= 100 and ball.sum() >= 9
    assert (plain.aux["diffuse_direct"][floor] > 0.0).all()
    np.testing.assert_array_equal(caught.aux["diffuse_direct"][floor], 0.0)
    np.testing.assert_array_equal(caught.aux["lightgroup:S"][floor], 0.0)
    np.testing.assert_array_equal(caught.aux["diffuse_direct"][ball], plain.aux["diffuse_direct"][ball])
    np.testing.assert_array_equal(caught.aux["lightgroup:S"][ball], plain.aux["lightgroup:S"][ball])


PANE = np.array([0.3, 0.6, 0.9])         # a clear pane's colour (its Transparent BSDF)


def behind_a_pane(scene: Scene, x: float = 2.0, pane: tuple = ("TRANSPARENT", tuple(PANE), {})) -> Scene:
    """`scene` (ball_over_catcher) with a pane of the node `pane` filling the view of a camera 3 m above (x, 0, 0),
    0.25 m below it (above the ball), hidden from shadow rays (it changes no light on the floor)."""
    scene.materials.append(materials.Material(name="pane", nodes=[pane]))
    scene.add_mesh(primitives.plane(4.0, center=(x, 0.0, 2.75)), materials=np.array([len(scene.materials) - 1]))
    scene.instances[-1].visible_shadow = False
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_catcher_behind_a_clear_pane_keeps_its_pass_and_the_pane_dims_the_matte(kernels):
    """A clear Transparent pane of colour c between the camera and the catcher floor: the camera path passes it and
    splits at the catcher as at a first hit (Cycles' transparent bounces keep it a camera path). The pass is what it
    is without the pane, exactly (the share of the unblocked sun in the shadow, 1 elsewhere: both the whole scene's
    and the catcher-only light come through the pane times c); the matte is black with alpha 1 - mean(c) (the
    pane lets mean(c) of the footage through); on a transparent film without the pass, alpha (1 - a)(1 - pass) + a
    with a = 1 - mean(c); no warning."""
    share = E_DOWN / (E_SLANT * math.cos(SLANT) + E_DOWN)
    settings = RenderSettings(width=24, height=24, samples=2, kernels=kernels, max_bounces=0, shadow_catcher_pass=True,
                              transparent_background=True)
    bare = render.render(ball_over_catcher(), settings)
    paned = render.render(behind_a_pane(ball_over_catcher()), settings)
    assert not any("shadow catchers" in w for w in paned.stats.warnings)
    shadow = paned.aux["shadow_catcher"]
    np.testing.assert_allclose(shadow, bare.aux["shadow_catcher"], rtol=1e-6, atol=1e-7)
    assert np.isclose(shadow, share, rtol=1e-6).all(axis=-1).sum() >= 20
    np.testing.assert_allclose(paned.image[..., :3], 0.0, atol=1e-7)
    np.testing.assert_allclose(paned.image[..., 3], 1.0 - PANE.mean(), rtol=1e-6)
    approximate = render.render(behind_a_pane(ball_over_catcher()),
                                dataclasses.replace(settings, shadow_catcher_pass=False)).image
    a = 1.0 - PANE.mean()
    np.testing.assert_allclose(approximate[..., 3], (1.0 - a) * (1.0 - shadow.mean(axis=-1)) + a, rtol=1e-5)


@pytest.mark.parametrize("kernels", KERNELS)
def test_objects_seen_through_a_clear_pane_keep_it_in_the_matte(kernels):
    """The ball, seen through the clear pane of colour c, is in the matte as the pane shows it: c times the ball of
    the render without the pane, opaque; the catcher around it a hole as opaque as the pane is not."""
    settings = RenderSettings(width=24, height=24, samples=2, kernels=kernels, max_bounces=0, shadow_catcher_pass=True)
    scene = ball_over_catcher()
    scene.camera = looking_down(3.0)
    bare = render.render(scene, settings).image
    scene = behind_a_pane(ball_over_catcher(), x=0.0)
    scene.camera = looking_down(3.0)
    paned = render.render(scene, settings).image
    ball = bare[..., 3] == 1.0
    assert ball.sum() >= 20
    np.testing.assert_allclose(paned[ball][:, :3], bare[ball][:, :3] * PANE, rtol=1e-4)
    np.testing.assert_allclose(paned[ball][:, 3], 1.0, rtol=1e-6)
    hole = bare[..., 3] == 0.0
    assert hole.sum() >= 40
    np.testing.assert_allclose(paned[hole][:, 3], 1.0 - PANE.mean(), rtol=1e-6)


@pytest.mark.parametrize("clamp", [0.0, 0.2])
def test_a_lamp_the_camera_sees_past_a_clear_pane_in_front_of_a_catcher_is_in_its_light_group(clamp):
    """An area lamp in light group L facing the camera between a clear pane of colour c and the catcher floor: as
    Cycles 5.0 writes a lamp a camera path hits before its split at the catcher to the lamp's light group
    (shade_light.h film_write_surface_emission; the split sets PATH_RAY_SHADOW_CATCHER_HIT only at the catcher), group
    L is c times the lamp's radiance there, as the matte is (on a transparent film, alpha 0 but for the pane), on both
    kernels, with and without Clamp Direct (the group capped as the matte's lamp light)."""
    scene = behind_a_pane(ball_over_catcher())
    scene.lights.append(AreaLight(center=np.array([2.0, 0.3, 1.5]), axis_u=np.array([0.6, 0.0, 0.0]),
                                  axis_v=np.array([0.0, 0.6, 0.0]), direction=np.array([0.0, 0.0, 1.0]), power=20.0))
    scene.lightgroups = {"lights": ["", "", "L"], "instances": ["", "", ""], "world": ""}
    results = {}
    for kernels in KERNELS:
        settings = RenderSettings(width=24, height=24, samples=2, kernels=kernels, max_bounces=0,
                                  transparent_background=True, shadow_catcher_pass=True, light_groups=("L",),
                                  sample_clamp_direct=clamp)
        results[kernels] = render.render(scene, settings)
        assert results[kernels].stats.kernels.startswith(kernels)
        group, matte = results[kernels].aux["lightgroup:L"], results[kernels].image[..., :3]
        lamp = (matte > 0.0).all(axis=-1)
        assert lamp.sum() >= 9, kernels
        np.testing.assert_allclose(group, matte, rtol=1e-6, atol=1e-7, err_msg=kernels)
    np.testing.assert_allclose(results["compiled"].aux["lightgroup:L"], results["numpy"].aux["lightgroup:L"],
                               rtol=1e-5, atol=4e-6)


def test_a_catcher_behind_a_partly_transparent_pane_is_said_to_render_as_an_ordinary_object():
    """A pane that is a Transparent BSDF mixed with a diffuse one (no clear surface: Primer does not split paths
    there): the floor renders as an ordinary object behind it (Combined the render without any catcher there),
    and the render says so once."""
    scene = ball_over_catcher()
    scene.materials.append(materials.Material(name="pane", nodes=[("TRANSPARENT", (0.5,) * 3, {}),
                                                                  ("DIFFUSE", (0.25,) * 3, {})]))
    scene.add_mesh(primitives.plane(8.0, center=(2.0, 0.0, 2.5)), materials=np.array([len(scene.materials) - 1]))
    settings = RenderSettings(width=16, height=16, samples=2, kernels="numpy")
    caught = render.render(scene, settings)
    assert sum("partly transparent" in w for w in caught.stats.warnings) == 1
    scene.instances[0].is_shadow_catcher = False
    np.testing.assert_allclose(caught.image, render.render(scene, settings).image, rtol=1e-6)


# Shadow catchers in media (Cycles 5.0: the camera path's volume kernel runs before integrator_split_shadow_catcher,
# so what the media in front of a catcher emit and scatter is the matte's and the split path carries what they let
# through; the split path's volume stack is re-made of the catchers' own media, the world's left out).
FOG = np.array([0.2, 0.5, 0.8])          # an absorbing fog's colour: sigma_a = density (1 - colour)


def in_a_fog_box(volume: list, low: float, high: float, height: float = 3.0) -> Scene:
    """A grey catcher floor (albedo 0.5) at z = 0 seen straight down by an orthographic camera `height` above it,
    inside a volume-only box of the closures `volume` from z = low to z = high (10 m wide), no lamp."""
    scene = Scene(camera=Camera(matrix_world=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, height], [0, 0, 0, 1.0]]),
                                type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=20.0))
    scene.add_material((0.5, 0.5, 0.5))
    scene.materials.append(materials.Material(np.zeros(3), "Fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                              volume=volume, volume_only=True))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.instances[0].is_shadow_catcher = True
    scene.add_mesh(primitives.box((10.0, 10.0, high - low), center=(0.0, 0.0, (low + high) / 2.0)),
                   materials=np.array([1]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_absorbing_fog_dims_the_matte_by_its_transmittance_and_shadows_the_catcher_by_its_depth(kernels):
    """A catcher floor under a straight-down sun, camera and floor inside an absorbing fog that reaches 4 m up (the
    camera 3 m up): the camera path reaches the floor with T_d = exp(-sigma_a d), so the matte is black with alpha
    1 - mean(T_d) (Cycles adds the split path's mean throughput to the matte's transparency); the catcher-only scene
    has no fog (it is no catcher's), so the sun's light through 4 m of it over its light without it is the pass,
    exp(-sigma_a 4) per channel (within float32 rounding), the same on a transparent and an opaque film. (The
    camera's rays start at its clip start, 0.1 m: 2.9 m of fog in front of the floor.)"""
    density = 0.3
    sigma = density * (1.0 - FOG)
    scene = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": density})], -0.5, 4.0)
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=2.0))
    for transparent in (True, False):
        settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator="path", max_bounces=2,
                                  shadow_catcher_pass=True, transparent_background=transparent)
        result = render.render(scene, settings)
        np.testing.assert_allclose(result.aux["shadow_catcher"], np.broadcast_to(np.exp(-sigma * 4.0), (4, 4, 3)),
                                   rtol=1e-5)
        np.testing.assert_allclose(result.image[..., :3], 0.0, atol=1e-7)
        np.testing.assert_allclose(result.image[..., 3], 1.0 - np.exp(-sigma * 2.9).mean(), rtol=2e-6)
    assert not any("Volume is left out" in w for w in result.stats.warnings)


@pytest.mark.parametrize("kernels", KERNELS)
def test_what_a_fog_in_front_of_the_catcher_emits_is_the_matte(kernels):
    """A purely emitting fog (strength e, no extinction) from 1 m to 4 m up, the camera inside it 3 m up, the catcher
    floor below it, no lamp: the camera path gathers e x 1.9 m of the fog's light (from its clip start, 0.1 m, to
    the fog's bottom) before it meets the floor, which Cycles writes before its split, to the matte: Combined (the
    matte) is 1.9 e in each channel with alpha 0 (nothing in
    front absorbs), and the pass 1 (no catcher-only light: Cycles' division by 0). Without the pass on a transparent
    film the same (the approximation adds no shadow where the pass is 1)."""
    e = 0.7
    scene = in_a_fog_box([("EMISSION", 1.0, {"color": np.ones(3), "strength": e})], 1.0, 4.0)
    for with_pass in (True, False):
        settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator="path", max_bounces=2,
                                  shadow_catcher_pass=with_pass, transparent_background=True)
        result = render.render(scene, settings)
        np.testing.assert_allclose(result.image[..., :3], 1.9 * e, rtol=1e-6)
        np.testing.assert_allclose(result.image[..., 3], 0.0, atol=1e-7)
        if with_pass:
            np.testing.assert_array_equal(result.aux["shadow_catcher"], 1.0)


@pytest.mark.parametrize("top", [5.0, 2.5])
def test_the_kernels_agree_on_a_catcher_in_a_scattering_fog(top):
    """The ball over the catcher floor under the two suns, inside a scattering, absorbing and emitting fog box up to
    `top` (the camera, 3 m up, inside it or outside, looking in through its boundary): the compiled kernel's
    Combined, Shadow Catcher pass, Volume Direct and light groups are the reference's (what the fog in front of the
    floor scatters and emits in the matte, its light passes and groups; the split path through its
    transmittance)."""
    fog = [("PRINCIPLED_VOLUME", 1.0, {"color": np.array([0.9, 0.8, 0.7]), "density": 0.15,
                                       "absorption_color": np.array([0.9, 0.9, 0.9]),
                                       "emission_strength": 0.05, "emission_color": np.ones(3)})]
    images = {}
    for kernels in KERNELS:
        scene = ball_over_catcher(world=0.2)
        scene.materials.append(materials.Material(np.zeros(3), "Fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                                  volume=fog, volume_only=True))
        scene.add_mesh(primitives.box((12.0, 12.0, top + 1.0), center=(1.0, 0.0, (top - 1.0) / 2.0)),
                       materials=np.array([1]))
        scene.lightgroups = {"lights": ["S", ""], "instances": ["", "", "F"], "world": "W"}
        settings = RenderSettings(width=16, height=16, samples=4, kernels=kernels, integrator="path", max_bounces=2,
                                  shadow_catcher_pass=True, passes=("diffuse_direct", "volume_direct"),
                                  light_groups=("S", "W", "F"))
        result = render.render(scene, settings)
        assert result.stats.kernels.startswith(kernels)
        images[kernels] = result
    numpy, compiled = images["numpy"], images["compiled"]
    assert (numpy.image[..., 3] > 0.0).all() and (numpy.aux["volume_direct"] > 0.0).all() == (top > 3.0)
    np.testing.assert_allclose(compiled.image, numpy.image, rtol=1e-5, atol=4e-6)
    for name in ["shadow_catcher", "volume_direct", "lightgroup:S", "lightgroup:W", "lightgroup:F"]:
        np.testing.assert_allclose(compiled.aux[name], numpy.aux[name], rtol=1e-5, atol=4e-6, err_msg=name)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_fog_box_between_the_camera_and_the_catcher_glows_in_the_matte_and_shadows_in_the_pass(kernels):
    """The camera 3 m up outside a fog box from 0.5 m to 2 m that absorbs (sigma_a) and glows (e), the catcher floor
    below it under a straight-down sun: the camera path crosses the box's boundary (a clear surface, Cycles' volume
    stack entering the fog) and 1.5 m of fog before the floor, so the matte is the fog's glow e (1 - T) / sigma_a
    with alpha 1 - mean(T), T = exp(-sigma_a 1.5); without the glow (which lights the floor too) the pass is the
    sun's light through the box over its light without it, T per channel (within float32 rounding)."""
    density, e = 0.4, 0.3
    sigma = density * (1.0 - FOG)
    T = np.exp(-sigma * 1.5)
    absorbing = ("ABSORPTION", 1.0, {"color": FOG, "density": density})
    settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator="path", max_bounces=2,
                              shadow_catcher_pass=True, transparent_background=True)
    for glow in (0.0, e):
        scene = in_a_fog_box([absorbing, ("EMISSION", 1.0, {"color": np.ones(3), "strength": glow})], 0.5, 2.0)
        scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=2.0))
        result = render.render(scene, settings)
        np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(glow * (1.0 - T) / sigma, (4, 4, 3)),
                                   rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(result.image[..., 3], 1.0 - T.mean(), rtol=1e-5)
        if glow == 0.0:
            np.testing.assert_allclose(result.aux["shadow_catcher"], np.broadcast_to(T, (4, 4, 3)), rtol=1e-5)


@pytest.mark.parametrize("clamp", [0.0, 0.1])
def test_what_a_fog_past_a_clear_pane_emits_in_front_of_the_catcher_is_in_its_light_group(clamp):
    """The camera 3 m up over a clear pane of colour c (2.5 m), then a fog box from 0.5 m to 2 m that absorbs
    (sigma_a) and glows (e), in light group F, the catcher floor below, no lamp: as Cycles 5.0 writes the fog's
    emission before its split at the catcher (shade_volume.h film_write_volume_emission, in the fog object's group),
    group F is the matte, c e (1 - T) / sigma_a with T = exp(-sigma_a 1.5), alpha 1 - mean(c T), on both kernels, with
    and without Clamp Direct (the group capped as the matte's glow)."""
    density, e = 0.4, 0.3
    sigma = density * (1.0 - FOG)
    T = np.exp(-sigma * 1.5)
    scene = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": density}),
                          ("EMISSION", 1.0, {"color": np.ones(3), "strength": e})], 0.5, 2.0)
    scene.materials.append(materials.Material(name="pane", nodes=[("TRANSPARENT", tuple(PANE), {})]))
    scene.add_mesh(primitives.plane(4.0, center=(0.0, 0.0, 2.5)), materials=np.array([2]))
    scene.lightgroups = {"lights": [], "instances": ["", "F", ""], "world": ""}
    glow = PANE * e * (1.0 - T) / sigma
    if clamp:
        glow = glow * min(1.0, 3.0 * clamp / glow.sum())      # (the cap: 3 x Clamp Direct on the channel sum)
    results = {}
    for kernels in KERNELS:
        settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator="path", max_bounces=2,
                                  shadow_catcher_pass=True, transparent_background=True, light_groups=("F",),
                                  sample_clamp_direct=clamp)
        results[kernels] = result = render.render(scene, settings)
        assert result.stats.kernels.startswith(kernels)
        np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(glow, (4, 4, 3)), rtol=1e-5, err_msg=kernels)
        np.testing.assert_allclose(result.image[..., 3], 1.0 - (PANE * T).mean(), rtol=1e-5, err_msg=kernels)
        np.testing.assert_allclose(result.aux["lightgroup:F"], result.image[..., :3], rtol=1e-5, err_msg=kernels)
    np.testing.assert_allclose(results["compiled"].aux["lightgroup:F"], results["numpy"].aux["lightgroup:F"],
                               rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("density", [0.0, 0.2])
def test_a_catchers_own_fog_is_in_the_catcher_only_light_and_only_the_other_fogs_shadow_the_pass(kernels, density):
    """A catcher-flagged absorbing fog box (sigma_c) from -0.5 m to 1 m over the catcher floor, inside a fog box that
    is no catcher (sigma_n = density (1 - colour)) from -0.5 m to 4 m, the camera 3 m up in the latter, a straight-down
    sun: the camera path splits at the catcher fog's top (1.9 m of the other fog in front: the matte's alpha
    1 - mean(exp(-1.9 sigma_n))). As Cycles 5.0 re-makes the split path's volume stack of the catchers' media alone,
    the catcher-only light crosses the catcher fog as the whole scene's does (twice 1 m) and never the other fog: the
    pass is exp(-5 sigma_n), the other fog along the sun's 4 m and the view's last metre, the catcher fog's
    cancelling (1 where there is no other fog); no warning of the catcher's Volume."""
    sigma_n = density * (1.0 - FOG)
    scene = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": density})], -0.5, 4.0)
    scene.materials.append(materials.Material(np.zeros(3), "Catcher fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                              volume=[("ABSORPTION", 1.0, {"color": PANE, "density": 0.5})],
                                              volume_only=True))
    scene.add_mesh(primitives.box((10.0, 10.0, 1.5), center=(0.0, 0.0, 0.25)), materials=np.array([2]))
    scene.instances[-1].is_shadow_catcher = True
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=2.0))
    settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator="path", max_bounces=2,
                              shadow_catcher_pass=True, transparent_background=True)
    result = render.render(scene, settings)
    assert result.stats.kernels.startswith(kernels)
    np.testing.assert_allclose(result.aux["shadow_catcher"], np.broadcast_to(np.exp(-5.0 * sigma_n), (4, 4, 3)),
                               rtol=1e-5)
    np.testing.assert_allclose(result.image[..., :3], 0.0, atol=1e-7)
    np.testing.assert_allclose(result.image[..., 3], 1.0 - np.exp(-1.9 * sigma_n).mean(), rtol=1e-5, atol=1e-7)
    assert not any("shadow catchers" in w for w in result.stats.warnings), result.stats.warnings


def test_the_catcher_only_scene_keeps_the_catchers_media_and_leaves_the_worlds_out():
    """Cycles' split path re-makes its volume stack of the catchers' media, the world's volume "always assumed to be
    CG" (left out): with an absorbing world volume and a catcher-flagged fog box, the catcher-only scene's media are
    the render's columns with the world's extinction 0; without a catcher's medium it has none."""
    scene = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": 0.3})], -0.5, 1.0)
    scene.world = World(color=np.zeros(3), volume=[("ABSORPTION", 1.0, {"color": PANE, "density": 0.1})])
    settings = RenderSettings(width=4, height=4, samples=1, kernels="numpy", integrator="path", max_bounces=2,
                              shadow_catcher_pass=True)
    assert render.prepare(scene, settings).extra["catcher"].extra["media"] is None
    scene.instances[1].is_shadow_catcher = True
    ctx = render.prepare(scene, settings)
    media, alone = ctx.extra["media"], ctx.extra["catcher"].extra["media"]
    assert (media.world.sigma_t > 0.0).all()
    np.testing.assert_array_equal(alone.world.sigma_t, 0.0)
    np.testing.assert_array_equal(alone.sigma_t, media.sigma_t)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_a_camera_inside_a_catchers_own_fog_starts_the_catcher_only_light_in_it_at_the_catcher(kernels, integrator):
    """A catcher-flagged absorbing fog box (sigma_c) from -0.5 m to 4 m around the orthographic camera (3 m up, its
    rays from the clip start, 0.1 m) and the catcher floor, and an absorbing fog that is no catcher (sigma_n) from
    -0.5 m to 1 m, a straight-down sun. The camera path reaches the floor through 2.9 m of the catcher fog and 1 m of
    the other: the matte black with alpha 1 - mean(T), T = exp(-2.9 sigma_c - sigma_n). Cycles' split path goes on
    from the floor with the volume stack of the catchers' media the camera (its ray's origin) is in, the catcher fog,
    its throughput T: the catcher-only light is T E exp(-4 sigma_c) rho / pi and the whole scene's T E exp(-4 sigma_c -
    sigma_n) rho / pi, so the pass is exp(-sigma_n) per channel (within float32 rounding), not exp(-4 sigma_c -
    sigma_n) (the catcher fog left out, as before) nor exp(2.9 sigma_c - sigma_n) (crossed again); nothing said."""
    sigma_c, sigma_n = 0.3 * (1.0 - FOG), 0.2 * (1.0 - PANE)
    scene = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": 0.3})], -0.5, 4.0)
    scene.instances[1].is_shadow_catcher = True
    scene.materials.append(materials.Material(np.zeros(3), "Other fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                              volume=[("ABSORPTION", 1.0, {"color": PANE, "density": 0.2})],
                                              volume_only=True))
    scene.add_mesh(primitives.box((10.0, 10.0, 1.5), center=(0.0, 0.0, 0.25)), materials=np.array([2]))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=2.0))
    settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator=integrator, max_bounces=2,
                              shadow_catcher_pass=True, transparent_background=True)
    result = render.render(scene, settings)
    assert result.stats.kernels.startswith(kernels)
    np.testing.assert_allclose(result.aux["shadow_catcher"], np.broadcast_to(np.exp(-sigma_n), (4, 4, 3)), rtol=1e-5)
    np.testing.assert_allclose(result.image[..., :3], 0.0, atol=1e-7)
    np.testing.assert_allclose(result.image[..., 3], 1.0 - np.exp(-2.9 * sigma_c - sigma_n).mean(), rtol=1e-5)
    assert not any("shadow catchers" in w for w in result.stats.warnings), result.stats.warnings


def test_the_kernels_agree_on_a_glowing_catchers_light_in_a_scattering_catcher_fog_with_volume_bounces(monkeypatch):
    """A glowing catcher floor (emission (0.3, 0.2, 0.1)) under the ball and the two suns, in a catcher-flagged
    scattering fog around the camera, Volume Bounces 2: the catcher-only light of the caught samples (the film's K
    sums, catcher.py) is the same on both kernels within float rounding, the floor's own glow in it (the compiled
    kernel's volume chains move a camera hit's emission into its lane's scattered light, which its catcher-only
    light dropped before), and positive everywhere."""
    from core.integrators import catcher as catcher_
    seen, images = {}, catcher_.images

    def spy(sums, *args, **kwargs):
        seen["K"] = np.array(sums[..., 4:7])
        return images(sums, *args, **kwargs)

    monkeypatch.setattr(catcher_, "images", spy)
    light = {}
    for kernels in KERNELS:
        scene = ball_over_catcher(world=0.2)
        scene.materials[0] = materials.Material(np.full(3, 0.5), "Floor", emission=np.array([0.3, 0.2, 0.1]))
        scene.materials.append(materials.Material(np.zeros(3), "Fog", nodes=[("TRANSPARENT", np.ones(3), {})],
                                                  volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8),
                                                                            "density": 0.1})], volume_only=True))
        scene.add_mesh(primitives.box((12.0, 12.0, 6.0), center=(1.0, 0.0, 2.0)), materials=np.array([1]))
        scene.instances[-1].is_shadow_catcher = True
        settings = RenderSettings(width=8, height=8, samples=2, kernels=kernels, integrator="path", max_bounces=2,
                                  volume_bounces=2, shadow_catcher_pass=True)
        assert render.render(scene, settings).stats.kernels.startswith(kernels)
        light[kernels] = seen["K"]
    assert (light["numpy"] > 0.3).all()
    np.testing.assert_allclose(light["compiled"], light["numpy"], rtol=1e-5, atol=1e-7)


def test_with_whitteds_tracer_a_catchers_own_fog_around_the_camera_is_said_once_and_left_out():
    """Whitted's tracer has no split start: a catcher-flagged absorbing fog box around the camera and the catcher
    floor is left out of its catcher-only scene, said once, and the pass is what it is with the fog flagged no
    catcher, exp(-sigma_a 4) under a straight-down sun."""
    sigma = 0.3 * (1.0 - FOG)
    scene = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": 0.3})], -0.5, 4.0)
    scene.instances[1].is_shadow_catcher = True
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=2.0))
    settings = RenderSettings(width=4, height=4, samples=2, kernels="numpy", integrator="whitted",
                              shadow_catcher_pass=True, transparent_background=True)
    result = render.render(scene, settings)
    assert sum("Volume the camera may be inside" in w for w in result.stats.warnings) == 1, result.stats.warnings
    np.testing.assert_allclose(result.aux["shadow_catcher"], np.broadcast_to(np.exp(-sigma * 4.0), (4, 4, 3)),
                               rtol=1e-5)


def test_what_primer_leaves_out_of_catchers_in_media_is_said_once():
    """A scattering fog box seen from outside (its scattering past the boundary), Volume Bounces 2 (what the fog in
    front scatters): each said once, and not the catcher's own Volume (kept); an absorbing fog around everything,
    Volume Bounces 0, says none of them."""
    scene = in_a_fog_box([("SCATTER", 1.0, {"color": np.full(3, 0.5), "density": 0.3})], 0.5, 2.0)
    scene.materials[0] = materials.Material((0.5, 0.5, 0.5), "Floor", nodes=[("DIFFUSE", (0.5,) * 3, {})],
                                            volume=[("ABSORPTION", 1.0, {"color": FOG, "density": 0.1})])
    settings = RenderSettings(width=4, height=4, samples=1, kernels="numpy", integrator="path", max_bounces=2,
                              volume_bounces=2, shadow_catcher_pass=True)
    warnings = render.render(scene, settings).stats.warnings
    for words in ("past a Transparent surface", "Volume Bounces above 0"):
        assert sum(words in w for w in warnings) == 1, (words, warnings)
    assert not any("own Volume" in w for w in warnings), warnings
    quiet = in_a_fog_box([("ABSORPTION", 1.0, {"color": FOG, "density": 0.3})], -0.5, 4.0)
    warnings = render.render(quiet, dataclasses.replace(settings, volume_bounces=0)).stats.warnings
    assert not any("shadow catchers" in w for w in warnings), warnings
