"""Object > Visibility > Ray Visibility (Camera, Shadow, Diffuse, Glossy, Transmission) and Holdout, as Cycles
reads them, on both kernels: a hidden object is passed by the rays of that kind as if it were not there, and is
still seen by every other ray; a holdout is a hole in the film for camera rays only."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.lights import SunLight
from core.lights.world import World
from core.scene import RenderSettings, Scene

KERNELS = ["numpy", "compiled"]


def glow(name: str, radiance: float) -> materials.Material:
    """A surface that only emits `radiance` (no BSDF): what the camera sees of it is that number."""
    return materials.Material(name=name, nodes=[("EMISSION", (1, 1, 1), {"emission": (radiance,) * 3})])


def looking_down(distance: float = 4.0) -> Camera:
    """A camera `distance` above the origin, looking straight down -Z."""
    return Camera(lens=35.0, matrix_world=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, distance], [0, 0, 0, 1.0]]))


@pytest.mark.parametrize("kernels", KERNELS)
def test_camera_rays_pass_an_object_hidden_from_the_camera(kernels):
    """A quad glowing 5 in front of a wall glowing 2: seen, the quad's pixels are 5; hidden from the camera,
    every pixel shows the wall's 2, exactly, as if the quad were not there."""
    scene = Scene(camera=looking_down())
    scene.materials += [glow("wall", 2.0), glow("quad", 5.0)]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(0.8, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    settings = RenderSettings(width=24, height=24, samples=2, kernels=kernels)
    seen = render.render(scene, settings).image[..., :3]
    assert (seen == 5.0).any() and (seen == 2.0).any()
    scene.instances[1].visible_camera = False
    hidden = render.render(scene, settings).image[..., :3]
    np.testing.assert_array_equal(hidden, 2.0)


def lit_floor(hide_lamp: bool = False, albedo: float = 0.5) -> Scene:
    """A diffuse floor lit only by a glowing quad above it (which the camera sees unless `hide_lamp`)."""
    scene = Scene(camera=looking_down(6.0))
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (albedo,) * 3, {})]), glow("lamp", 8.0)]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    lamp = np.array([[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 1.5], [0, 0, 0, 1.0]])     # facing down, 1.5 up
    scene.add_mesh(primitives.plane(1.0), lamp, materials=np.array([1]))
    scene.instances[1].visible_camera = not hide_lamp
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_emitter_hidden_from_the_camera_still_lights_the_floor(kernels):
    """The glowing quad hidden from the camera: the floor it lights is the same, pixel for pixel (the same rays
    and samples), and where the quad was seen the floor below it shows, lit."""
    settings = RenderSettings(width=32, height=32, samples=4, kernels=kernels)
    seen = render.render(lit_floor(), settings).image[..., :3]
    hidden = render.render(lit_floor(hide_lamp=True), settings).image[..., :3]
    quad = (seen == 8.0).all(axis=-1)                  # pixels all of whose samples saw the quad
    touched = (seen > 1.0).any(axis=-1)                 # and those some of whose did (the floor is far dimmer)
    assert quad.sum() > 4
    np.testing.assert_allclose(hidden[~touched], seen[~touched], rtol=1e-6)
    assert (hidden[quad] > 0.001).all() and (hidden[quad] < 1.0).all()


def sunlit_floor(kernels: str, hide_shadow: bool) -> tuple:
    """A floor of albedo 0.5 under a sun of 3 W/m^2 at 30 degrees from the zenith, a box standing on it."""
    scene = Scene(camera=looking_down(8.0))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(30.0), materials=np.array([0]))
    scene.add_mesh(primitives.box((1.0, 1.0, 2.0), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.instances[1].visible_shadow = not hide_shadow
    theta = math.radians(30.0)
    scene.lights.append(SunLight(np.array([math.sin(theta), 0.0, -math.cos(theta)]), strength=3.0))
    return scene, RenderSettings(width=32, height=32, samples=1, kernels=kernels)


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_object_hidden_from_shadow_rays_casts_no_shadow(kernels):
    """A box on a sunlit floor: its shadow is black; hidden from shadow rays, every floor pixel has the sunlit
    floor's radiance albedo x E cos(theta) / pi, exactly, and the box itself is still seen (and lit)."""
    expected = 0.5 * 3.0 * math.cos(math.radians(30.0)) / math.pi
    scene, settings = sunlit_floor(kernels, hide_shadow=False)
    casting = render.render(scene, settings).image[..., :3]
    scene, settings = sunlit_floor(kernels, hide_shadow=True)
    hidden = render.render(scene, settings).image[..., :3]
    floor = np.isclose(hidden, expected, rtol=1e-6).all(axis=-1)
    shadow = (casting == 0.0).all(axis=-1)
    assert shadow.sum() > 4 and floor[shadow].all()               # where the shadow was: sunlit floor
    box_top = np.isclose(hidden, 0.5 * 3.0 * math.cos(math.radians(30.0)) / math.pi, rtol=1e-6).all(axis=-1)
    assert box_top.sum() > 0.5 * hidden.shape[0] * hidden.shape[1]
    np.testing.assert_allclose(hidden[~shadow], casting[~shadow], rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("instancing", ["never", "always"])
def test_one_placement_of_a_shared_mesh_hides_and_the_other_does_not(kernels, instancing):
    """One quad mesh placed twice (traced as Embree instances with Instancing: Always), the second placement
    hidden from the camera: the first is seen glowing 5, where the second was the wall's 2 shows."""
    scene = Scene(camera=looking_down())
    scene.materials += [glow("wall", 2.0), glow("quad", 5.0)]
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    quad = scene.add_mesh(primitives.plane(0.5), np.array([[1, 0, 0, -0.5], [0, 1, 0, 0], [0, 0, 1, 1.0], [0, 0, 0, 1]]),
                          materials=np.array([1]))
    scene.instances.append(dataclasses.replace(scene.instances[-1], matrix=np.array(
        [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 1.0], [0, 0, 0, 1]], np.float64), visible_camera=False))
    assert scene.instances[-1].mesh == quad
    settings = RenderSettings(width=32, height=16, samples=1, kernels=kernels, instancing=instancing)
    image = render.render(scene, settings).image[..., :3]
    left, right = image[:, :16], image[:, 16:]
    assert (left == 5.0).any()
    np.testing.assert_array_equal(right, 2.0)


def sky_and_sun(hide_diffuse: bool, kernels: str) -> tuple:
    """A floor of albedo 0.5 under a white sky of radiance 1 and a sun of 3 W/m^2 at 45 degrees, a panel of
    albedo 0.8 floating 1 above it (its shadow offset by 1 from it), seen from above; one sample per pixel."""
    scene = Scene(camera=looking_down(6.0), world=World(color=np.ones(3)))
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (0.5,) * 3, {})]),
                        materials.Material(name="panel", nodes=[("DIFFUSE", (0.8,) * 3, {})])]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(1.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    scene.instances[1].visible_diffuse = not hide_diffuse
    scene.lights.append(SunLight(np.array([-1.0, 0.0, -1.0]) / math.sqrt(2.0), strength=3.0))
    return scene, RenderSettings(width=48, height=48, samples=1, integrator="path", kernels=kernels)


@pytest.mark.parametrize("kernels", KERNELS)
def test_diffuse_rays_pass_an_object_hidden_from_them_but_its_shadow_and_its_look_stay(kernels):
    """The panel hidden from diffuse rays: every floor ray that bounces diffusely sees the whole sky, so (one
    sample per pixel, a cosine-sampled bounce carries exactly the albedo) each floor pixel is exactly 0.5 x 1 in
    the panel's shadow (shadow rays still see it) and 0.5 (1 + 3 cos 45 / pi) in the sun; the camera still sees
    the panel, 0.8 (1 + 3 cos 45 / pi). Seen by diffuse rays, the panel darkens the floor's sky near it."""
    sun = 3.0 * math.cos(math.radians(45.0)) / math.pi
    scene, settings = sky_and_sun(True, kernels)
    image = render.render(scene, settings).image[..., 0]
    shadow, lit, panel = (np.isclose(image, value, rtol=1e-9) for value in (0.5, 0.5 * (1 + sun), 0.8 * (1 + sun)))
    assert (shadow | lit | panel).all()
    assert shadow.sum() > 20 and panel.sum() > 20 and lit.sum() > 1000
    scene, settings = sky_and_sun(False, kernels)
    seen = render.render(scene, settings).image[..., 0]
    assert seen[shadow].mean() < 0.495           # some diffuse rays from the shadow now meet the panel's dim underside
    np.testing.assert_allclose(seen[panel], image[panel], rtol=1e-9)


def mirror_under_a_lamp(hidden_from: str, kernels: str) -> tuple:
    """A mirror floor (Glossy BSDF, roughness 0, white) under a sky of radiance 1; a quad glowing 5 floats 1 above
    it, hidden from the camera (the camera sees the mirror) and from the rays named by `hidden_from`."""
    scene = Scene(camera=looking_down(6.0), world=World(color=np.ones(3)))
    scene.materials += [materials.Material(name="mirror", nodes=[("GLOSSY", (1.0,) * 3, {"roughness": 0.0})]),
                        glow("lamp", 5.0)]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(1.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    scene.instances[1].visible_camera = False
    if hidden_from:
        setattr(scene.instances[1], f"visible_{hidden_from}", False)
    return scene, RenderSettings(width=32, height=32, samples=2, integrator="path", kernels=kernels)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_mirror_does_not_reflect_an_object_hidden_from_glossy_rays(kernels):
    """The mirror shows the lamp (5) where it reflects it and the sky (1) elsewhere; with the lamp hidden from
    glossy rays every pixel is the sky's 1, exactly; hidden from diffuse rays instead, the mirror still shows it."""
    scene, settings = mirror_under_a_lamp("", kernels)
    seen = render.render(scene, settings).image[..., :3]
    assert (seen == 5.0).all(axis=-1).sum() > 4
    scene, settings = mirror_under_a_lamp("glossy", kernels)
    np.testing.assert_allclose(render.render(scene, settings).image[..., :3], 1.0, rtol=1e-12)
    scene, settings = mirror_under_a_lamp("diffuse", kernels)
    np.testing.assert_array_equal(render.render(scene, settings).image[..., :3], seen)


def behind_a_pane(pane: list, hidden_from: str, kernels: str) -> tuple:
    """Looking down through a pane of the shader nodes `pane` (2 up) at a quad glowing 5 (1 up) before a floor
    glowing 2; the quad hidden from the rays named by `hidden_from` (or none)."""
    scene = Scene(camera=looking_down(6.0))
    scene.materials += [glow("floor", 2.0), glow("quad", 5.0), materials.Material(name="pane", nodes=pane)]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(1.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 2.0)), materials=np.array([2]))
    if hidden_from:
        setattr(scene.instances[1], f"visible_{hidden_from}", False)
    return scene, RenderSettings(width=24, height=24, samples=2, integrator="path", kernels=kernels)


@pytest.mark.parametrize("kernels", KERNELS)
def test_glass_does_not_show_an_object_hidden_from_transmission_rays(kernels):
    """Through glass of index 1 (no reflection, no bending) the quad shows (5) before the floor (2); hidden from
    transmission rays it vanishes, every pixel the floor's 2, exactly. Through a Transparent BSDF the rays stay
    camera rays: the quad hidden from transmission still shows, hidden from the camera it vanishes."""
    glass = [("GLASS", (1.0,) * 3, {"ior": 1.0, "roughness": 0.0})]
    scene, settings = behind_a_pane(glass, "", kernels)
    seen = render.render(scene, settings).image[..., :3]
    assert (seen == 5.0).all(axis=-1).sum() > 4 and (seen == 2.0).all(axis=-1).sum() > 100
    scene, settings = behind_a_pane(glass, "transmission", kernels)
    np.testing.assert_allclose(render.render(scene, settings).image[..., :3], 2.0, rtol=1e-12)
    clear = [("TRANSPARENT", (1.0,) * 3, {})]
    scene, settings = behind_a_pane(clear, "transmission", kernels)
    np.testing.assert_array_equal(render.render(scene, settings).image[..., :3], seen)
    scene, settings = behind_a_pane(clear, "camera", kernels)
    np.testing.assert_allclose(render.render(scene, settings).image[..., :3], 2.0, rtol=1e-12)


def holdout_scene(pane: list, kernels: str, transparent_film: bool = False) -> tuple:
    """behind_a_pane with the glowing quad a holdout (and no pane when `pane` is empty)."""
    scene, settings = behind_a_pane(pane or [("TRANSPARENT", (1.0,) * 3, {})], "", kernels)
    if not pane:
        del scene.instances[2]
    scene.instances[1].is_holdout = True
    return scene, dataclasses.replace(settings, transparent_background=transparent_film)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("transparent_film", [False, True])
def test_a_holdout_is_a_hole_in_the_film(kernels, transparent_film):
    """Where the camera sees the holdout quad the pixel is (0, 0, 0, 0), whether the film is transparent or not;
    elsewhere the floor, (2, 2, 2, 1), untouched: every pixel one or the other, or a mix at the quad's edge."""
    scene, settings = holdout_scene([], kernels, transparent_film)
    image = render.render(scene, settings).image
    hole = (image == 0.0).all(axis=-1)
    floor = np.isclose(image, [2.0, 2.0, 2.0, 1.0], rtol=1e-12).all(axis=-1)
    edge = ~hole & ~floor
    assert hole.sum() > 4 and floor.sum() > 300 and edge.sum() < 30
    np.testing.assert_allclose(image[edge][:, 0] / 2.0, image[edge][:, 3], rtol=1e-6)    # coverage: colour / 2


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_holdout_seen_through_a_transparent_bsdf_takes_away_what_the_pane_lets_through(kernels):
    """Through a Transparent BSDF of 0.25 grey the holdout takes away 0.25 of the alpha: (0, 0, 0, 0.75) there,
    the floor seen through the pane (0.5, 0.5, 0.5, 1) elsewhere."""
    scene, settings = holdout_scene([("TRANSPARENT", (0.25,) * 3, {})], kernels)
    image = render.render(scene, settings).image
    hole = np.isclose(image, [0.0, 0.0, 0.0, 0.75], rtol=1e-12, atol=0).all(axis=-1)
    floor = np.isclose(image, [0.5, 0.5, 0.5, 1.0], rtol=1e-12).all(axis=-1)
    assert hole.sum() > 4 and floor.sum() > 300 and (hole | floor).sum() > image.shape[0] * image.shape[1] - 30


@pytest.mark.parametrize("kernels", KERNELS)
def test_reflected_rays_see_a_holdout_as_an_ordinary_object(kernels):
    """The mirror under the lamp quad (hidden from the camera) with the quad a holdout: the mirror still shows
    it glowing 5 at alpha 1, pixel for pixel as without the holdout (only camera paths make holes)."""
    scene, settings = mirror_under_a_lamp("", kernels)
    seen = render.render(scene, settings).image
    scene.instances[1].is_holdout = True
    np.testing.assert_array_equal(render.render(scene, settings).image, seen)
    assert (seen[..., 3] == 1.0).all()


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_an_emitter_hidden_from_diffuse_rays_lights_no_diffuse_surface(kernels, integrator):
    """The glowing quad over the floor hidden from the camera and from diffuse rays: as in Cycles its light
    samples leave diffuse closures out too (a diffuse BSDF ray could never find it), so the diffuse floor is black,
    exactly; a rough glossy floor is lit by it as if it were not hidden from diffuse rays, pixel for pixel."""
    settings = RenderSettings(width=24, height=24, samples=4, integrator=integrator, kernels=kernels)
    scene = lit_floor(hide_lamp=True)
    scene.instances[1].visible_diffuse = False
    np.testing.assert_array_equal(render.render(scene, settings).image[..., :3], 0.0)
    glossy = materials.Material(name="floor", nodes=[("GLOSSY", (0.8,) * 3, {"roughness": 0.4})])
    scene.materials[0] = glossy
    hidden = render.render(scene, settings).image[..., :3]
    scene.instances[1].visible_diffuse = True
    seen = render.render(scene, settings).image[..., :3]
    assert hidden.max() > 0.01
    np.testing.assert_array_equal(hidden, seen)


def test_whitted_rays_pass_the_objects_hidden_from_their_kind():
    """Whitted's tracer (reference only) reads Camera, Glossy and Transmission visibility too: the mirror shows
    the sky's 1 everywhere with the lamp hidden from glossy rays, the glass the floor's 2 with the quad hidden
    from transmission rays."""
    scene, settings = mirror_under_a_lamp("glossy", "numpy")
    image = render.render(scene, dataclasses.replace(settings, integrator="whitted")).image[..., :3]
    np.testing.assert_allclose(image, 1.0, rtol=1e-12)
    scene, settings = behind_a_pane([("GLASS", (1.0,) * 3, {"ior": 1.0, "roughness": 0.0})], "transmission", "numpy")
    image = render.render(scene, dataclasses.replace(settings, integrator="whitted")).image[..., :3]
    np.testing.assert_allclose(image, 2.0, rtol=1e-12)



@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_both_kernels_render_every_visibility_and_holdout_alike(integrator):
    """A glossy, glass and transparent scene where objects hide from each kind of ray, an emitter hides from
    glossy rays and one object is a holdout: the compiled kernels and the Python reference trace the same rays
    and agree pixel for pixel, alpha included (tests/test_compiled.py's comparison)."""
    from test_compiled import assert_same_render, compare_paths
    scene = Scene(camera=looking_down(6.0), world=World(color=np.full(3, 0.3)))
    scene.materials += [materials.Material(name="floor", nodes=[("DIFFUSE", (0.6,) * 3, {})]),
                        materials.Material(name="glossy", nodes=[("GLOSSY", (0.9,) * 3, {"roughness": 0.3})]),
                        materials.Material(name="glass", nodes=[("GLASS", (1.0,) * 3, {"ior": 1.45, "roughness": 0.1})]),
                        materials.Material(name="clear", nodes=[("TRANSPARENT", (0.5,) * 3, {})]), glow("lamp", 6.0)]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    for i, (x, material) in enumerate([(-1.5, 1), (0.0, 2), (1.5, 3), (0.0, 0)]):
        scene.add_mesh(primitives.box((0.8, 0.8, 0.8), center=(x, 0.7 * (i == 3), 0.4 + 1.2 * (i == 3))),
                       materials=np.array([material]))
    lamp = np.array([[1, 0, 0, 0], [0, -1, 0, 0.5], [0, 0, -1, 2.5], [0, 0, 0, 1.0]])
    scene.add_mesh(primitives.plane(1.0), lamp, materials=np.array([4]))
    scene.instances[1].visible_diffuse = False
    scene.instances[2].visible_transmission = False
    scene.instances[3].visible_glossy = False
    scene.instances[4].is_holdout = True
    scene.instances[5].visible_glossy = False
    scene.instances[5].visible_camera = False
    settings = RenderSettings(width=40, height=40, samples=4, integrator=integrator, light_samples=2)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    assert (reference.image[..., 3] < 1.0).any()
