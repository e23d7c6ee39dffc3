"""Path tracing: bounce limits, Russian roulette and MIS against closed forms, on both paths."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.scene import RenderSettings, Scene

ALBEDO = 0.6
EMISSION = 0.5


def furnace(albedo: float = ALBEDO, emission: float = EMISSION, samples: int = 64) -> tuple:
    """The camera at the centre of a closed sphere that emits `emission` and reflects `albedo` diffusely
    everywhere. Light bounced k times arrives as emission x albedo^k, from every direction alike, whatever
    the sphere's shape (flat-shaded, so that no shading normal leans past its face): so a path of at most
    B bounces sees emission x (1 + albedo + ... + albedo^(B+1)), exactly, with no noise at all."""
    scene = Scene(camera=Camera(lens=18.0))
    scene.materials.append(materials.Material(name="glowing wall", nodes=[
        ("DIFFUSE", (albedo, albedo, albedo), {}), ("EMISSION", (1.0, 1.0, 1.0), {"emission": (emission,) * 3})]))
    scene.add_mesh(primitives.uv_sphere(3.0, 16, 8, smooth=False), materials=np.array([0]))
    return scene, RenderSettings(width=8, height=8, samples=samples, integrator="path", min_light_bounces=1024)


def furnace_radiance(bounces: int, albedo: float = ALBEDO, emission: float = EMISSION) -> float:
    """emission x sum_{k=0}^{bounces+1} albedo^k (bounces = inf: emission / (1 - albedo))."""
    if math.isinf(bounces):
        return emission / (1.0 - albedo)
    return emission * sum(albedo ** k for k in range(bounces + 2))


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("bounces", [0, 1, 3])
def test_each_bounce_adds_one_more_albedo_factor_of_the_furnace(bounces, kernels):
    """Max Bounces B: the furnace shows emission x (1 + a + ... + a^(B+1)), the direct light (B = 0) being
    emission x (1 + a); Diffuse Bounces limits the same way. (Min Light Bounces keeps Russian roulette out.)"""
    scene, settings = furnace()
    settings = dataclasses.replace(settings, max_bounces=bounces, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, furnace_radiance(bounces), rtol=1e-4)
    limited = dataclasses.replace(settings, max_bounces=12, diffuse_bounces=bounces)
    image = render.render(scene, limited).image[..., :3]
    np.testing.assert_allclose(image, furnace_radiance(bounces), rtol=1e-4)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_russian_roulette_keeps_the_furnace_unbiased(kernels):
    """Many bounces with Russian roulette from the third vertex: emission / (1 - albedo) (the geometric
    series summed), although most paths end early: only the roulette is random here."""
    scene, settings = furnace(albedo=0.8, samples=256)
    settings = dataclasses.replace(settings, max_bounces=1024, diffuse_bounces=1024, min_light_bounces=0,
                                   kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    expected = furnace_radiance(math.inf, albedo=0.8)
    assert image.mean() == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_russian_roulette_keeps_every_path_that_carries_a_quarter_of_the_light(kernels):
    """Russian roulette's q = min(max(sqrt(t), 4 t), 1) (path.survival), t the path's throughput: in a furnace of
    albedo 1/2 lit by a point light at its centre (one shadow ray at every vertex), a path carries t = 1/4 at its
    first roulette (after 2 bounces: q = 1) and t = 1/8 at every later one (q = 1/2, the survivors' throughput back
    to 1/4), so with Max Bounces 8 a path has 2 + (1 + 1/2 + ... + 1/2^6) vertices on average (Cycles' sqrt(t)
    gives 2 + (1/2 + ... + 1/2^7), 1 fewer; no roulette 9), and the image is the one without roulette."""
    from core.lights import PointLight
    scene, settings = furnace(albedo=0.5, emission=0.0, samples=256)
    scene.lights.append(PointLight(np.zeros(3), power=100.0, radius=0.0))
    settings = dataclasses.replace(settings, max_bounces=8, diffuse_bounces=8, kernels=kernels)
    played = render.render(scene, dataclasses.replace(settings, min_light_bounces=0))
    unplayed = render.render(scene, settings)
    paths = settings.width * settings.height * settings.samples
    assert unplayed.stats.shadow_rays == 9 * paths
    expected = 2.0 + sum(0.5 ** k for k in range(7))
    assert played.stats.shadow_rays / paths == pytest.approx(expected, rel=0.015)
    assert played.image[..., :3].mean() == pytest.approx(unplayed.image[..., :3].mean(), rel=0.01)


def test_compiled_paths_follow_the_reference_paths():
    """A path-traced scene with every kind of light (point, sun disk, area, an emissive mesh, a world) and
    diffuse, metal, glossy and default surfaces, three bounces: the compiled path renders what the Python
    reference renders, within the stated tolerance, with the same rays."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.lights import World
    scene = lit_scene(LIGHTS["several"])
    # (a dark metal: paths that meet it carry less than a quarter of the light, where Russian roulette plays)
    scene.materials[1] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.3, 0.2, 0.1), "roughness": 0.3})])
    scene.materials.append(materials.Material(name="lamp", nodes=[
        ("EMISSION", (1, 1, 1), {"emission": (4.0, 3.0, 2.0)}), ("GLOSSY", (0.3, 0.3, 0.3), {"roughness": 0.4})]))
    scene.add_mesh(primitives.plane(0.6, center=(-1.2, 1.0, 1.5)), materials=np.array([2]))
    scene.world = World(color=np.array([0.1, 0.12, 0.15]), camera=True, lights=True)
    settings = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=3)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    unplayed = render.render(scene, dataclasses.replace(settings, min_light_bounces=3, kernels="compiled"))
    assert compiled.stats.shadow_rays < unplayed.stats.shadow_rays        # (the roulette ended some paths)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_path_of_no_bounces_is_the_direct_light(kernels):
    """Max Bounces 0: path tracing converges to the direct-lighting tracer's image (they differ only in
    where a BSDF ray is traced, which changes the noise, not the mean)."""
    from test_compiled import LIGHTS, lit_scene
    scene = lit_scene(LIGHTS["several"])
    settings = RenderSettings(width=24, height=18, samples=256, max_bounces=0, kernels=kernels)
    direct = render.render(scene, dataclasses.replace(settings, integrator="direct")).image[..., :3]
    path = render.render(scene, dataclasses.replace(settings, integrator="path")).image[..., :3]
    assert abs(path.mean() / direct.mean() - 1.0) < 0.01
    np.testing.assert_allclose(path, direct, atol=0.02 * direct.max())


def test_smooth_glass_splits_light_by_fresnel_and_bends_it_by_snells_law():
    """A Glass closure: reflection with probability R / (R + T) about N, refraction with sin_t = sin_i / eta,
    total internal reflection past the critical angle, and white glass keeps all the light (R + T = 1)."""
    n = 20000
    rng = np.random.default_rng(3)
    theta = math.radians(50.0)
    wo = np.tile([math.sin(theta), 0.0, math.cos(theta)], (n, 1))
    N = np.tile([0.0, 0.0, 1.0], (n, 1))
    glass = materials.nodes.glass_params(n, np.zeros(n, bool), 1.5, materials.microfacet.FRESNEL_DIELECTRIC,
                                         np.zeros(3), np.zeros(3), np.ones(3), np.ones(3))
    s = materials.Glass.sample(glass, N, wo, rng.random((n, 2)))
    F = materials.microfacet.fresnel_dielectric(np.array([math.cos(theta)]), 1.5)[0]
    reflected = s.wi[:, 2] > 0
    assert reflected.mean() == pytest.approx(F, abs=0.01)
    np.testing.assert_allclose(s.weight.mean(axis=0), 1.0, rtol=0.02)          # R + T = 1
    sin_t = np.hypot(s.wi[~reflected, 0], s.wi[~reflected, 1])
    np.testing.assert_allclose(sin_t, math.sin(theta) / 1.5, rtol=1e-12)
    # Leaving the glass (eta = 1 / 1.5) at 50 degrees, past the critical angle of 41.8: all reflected.
    inside = materials.nodes.glass_params(n, np.ones(n, bool), 1.5, materials.microfacet.FRESNEL_DIELECTRIC,
                                          np.zeros(3), np.zeros(3), np.ones(3), np.ones(3))
    s = materials.Glass.sample(inside, N, wo, rng.random((n, 2)))
    assert (s.wi[:, 2] > 0).all() and np.allclose(s.weight, 1.0)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_glass_slab_passes_the_fresnel_series_of_light(kernels):
    """Looking straight through a smooth glass slab at a glowing wall, in the dark: each face passes 1 - R
    and reflects R = ((n - 1) / (n + 1))^2, so light that bounces inside the slab 2k times adds up to
    L (1 - R)^2 (1 + R^2 + R^4 + ...) = L (1 - R) / (1 + R). (No roulette, ample bounces.)"""
    ior, glow = 1.5, 2.0
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.5, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, -3], [0, 1, 0, 0], [0, 0, 0, 1.0]])))
    scene.materials.append(materials.Material(name="glass", nodes=[("GLASS", (1, 1, 1), {"ior": ior})]))
    scene.materials.append(materials.Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (glow,) * 3})]))
    scene.add_mesh(primitives.box((4.0, 0.2, 4.0)), materials=np.array([0]))
    wall = primitives.plane(8.0)
    scene.add_mesh(wall, np.array([[1, 0, 0, 0], [0, 0, -1, 2.0], [0, 1, 0, 0], [0, 0, 0, 1.0]]),
                   materials=np.array([1]))
    settings = RenderSettings(width=6, height=6, samples=256, integrator="path", max_bounces=64,
                              glossy_bounces=64, transmission_bounces=64, min_light_bounces=64, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    R = ((ior - 1) / (ior + 1)) ** 2
    assert image.mean() == pytest.approx(glow * (1 - R) / (1 + R), rel=0.01)


def test_the_inspector_shows_each_vertex_of_a_path_and_they_add_up_to_the_pixel():
    """The ray inspector on a path-traced pixel: one record per vertex with its throughput and the light it
    gathered; the pixel's radiance is the sum of throughput x gathered over the vertices, and in the furnace
    every vertex gathers emission x albedo (the light samples and BSDF ray of a uniform glowing sphere)."""
    from core.teaching.inspector import inspect_pixel
    scene, settings = furnace()
    settings = dataclasses.replace(settings, max_bounces=3, diffuse_bounces=3)
    record = inspect_pixel(scene, settings, 4, 4)
    assert [v.vertex for v in record.path] == [0, 1, 2, 3]
    total = sum(v.throughput * v.gathered for v in record.path)
    np.testing.assert_allclose(total, record.radiance, rtol=1e-12)
    np.testing.assert_allclose(record.radiance, furnace_radiance(3), rtol=1e-9)
    for v in record.path:
        np.testing.assert_allclose(v.throughput, ALBEDO ** v.vertex, rtol=1e-9)
        assert v.bsdf_direction is not None and v.bsdf_pdf > 0


def slab_scene(ior: float = 1.5, glow: float = 2.0):
    """An orthographic camera looking through a smooth glass slab at a glowing wall, in the dark."""
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.5, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, -3], [0, 1, 0, 0], [0, 0, 0, 1.0]])))
    scene.materials.append(materials.Material(name="glass", nodes=[("GLASS", (1, 1, 1), {"ior": ior})]))
    scene.materials.append(materials.Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (glow,) * 3})]))
    scene.add_mesh(primitives.box((4.0, 0.2, 4.0)), materials=np.array([0]))
    scene.add_mesh(primitives.plane(8.0), np.array([[1, 0, 0, 0], [0, 0, -1, 2.0], [0, 1, 0, 0], [0, 0, 0, 1.0]]),
                   materials=np.array([1]))
    return scene


@pytest.mark.parametrize("fresnel", ["exact", "schlick"])
def test_whitted_splits_light_at_glass_by_fresnel_exactly(fresnel):
    """Whitted's tracer follows both branches at glass: through a slab at normal incidence it sees
    L (1 - R)^2 (1 + R^2 + ... + R^(2k)) for the internal reflections its depth allows, with no noise;
    Schlick's approximation equals the exact R0 at normal incidence."""
    ior, glow, depth = 1.5, 2.0, 5
    settings = RenderSettings(width=4, height=4, samples=1, integrator="whitted", max_bounces=depth,
                              glossy_bounces=depth, transmission_bounces=depth, fresnel=fresnel)
    image = render.render(slab_scene(ior, glow), settings).image[..., :3]
    R = ((ior - 1) / (ior + 1)) ** 2
    # Through 2 refractions and 2k internal reflections: 2 + 2k bounces <= depth.
    expected = glow * (1 - R) ** 2 * sum(R ** (2 * k) for k in range((depth - 2) // 2 + 1))
    np.testing.assert_allclose(image, expected, rtol=1e-6)          # (a float32 image)


def test_whitted_sees_a_glowing_wall_in_a_tinted_mirror():
    """A mirror tinted (0.9, 0.5, 0.2) facing a glowing wall: the camera sees the wall's radiance times the tint."""
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.5, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, -3], [0, 1, 0, 0], [0, 0, 0, 1.0]])))
    scene.materials.append(materials.Material((0.9, 0.5, 0.2), name="mirror", bsdf="MIRROR"))
    scene.materials.append(materials.Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (2.0,) * 3})]))
    tilt = math.radians(45)
    c, s_ = math.cos(tilt), math.sin(tilt)
    scene.add_mesh(primitives.plane(4.0), np.array([[1, 0, 0, 0], [0, c, -s_, 0], [0, s_, c, 0], [0, 0, 0, 1.0]]),
                   materials=np.array([0]))
    scene.add_mesh(primitives.plane(8.0), np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3.0], [0, 0, 0, 1.0]]),
                   materials=np.array([1]))
    settings = RenderSettings(width=4, height=4, samples=1, integrator="whitted", max_bounces=2)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, np.broadcast_to([1.8, 1.0, 0.4], image.shape), rtol=1e-6)


def glow_behind(planes: list) -> Scene:
    """The slab scene's camera looking at a glowing wall (radiance 2) through planes of the given materials
    (each a list of shader nodes), one behind the other, in the dark."""
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=0.5, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, -3], [0, 1, 0, 0], [0, 0, 0, 1.0]])))
    scene.materials.append(materials.Material(name="glow", nodes=[("EMISSION", (1, 1, 1), {"emission": (2.0,) * 3})]))
    scene.add_mesh(primitives.plane(8.0), np.array([[1, 0, 0, 0], [0, 0, -1, 2.0], [0, 1, 0, 0], [0, 0, 0, 1.0]]),
                   materials=np.array([0]))
    for i, nodes in enumerate(planes):
        scene.materials.append(materials.Material(name=f"sheet {i}", nodes=nodes))
        scene.add_mesh(primitives.plane(4.0), np.array([[1, 0, 0, 0], [0, 0, -1, -1.0 + 0.5 * i], [0, 1, 0, 0],
                                                        [0, 0, 0, 1.0]]), materials=np.array([i + 1]))
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_light_passes_transparent_surfaces_tinted_and_alpha_lets_one_minus_alpha_through(integrator, kernels):
    """A Transparent BSDF tinted (0.5, 0.25, 1) shows the wall behind times the tint; a Principled BSDF of
    Alpha 0.3 in the dark lets 0.7 of it through; both with Max Bounces 0 too (transparent bounces are not
    bounces, as in Cycles)."""
    settings = RenderSettings(width=4, height=4, samples=16, integrator=integrator, max_bounces=0, kernels=kernels)
    tinted = render.render(glow_behind([[("TRANSPARENT", (0.5, 0.25, 1.0), {})]]), settings).image[..., :3]
    np.testing.assert_allclose(tinted, np.broadcast_to([1.0, 0.5, 2.0], tinted.shape), rtol=1e-6)
    alpha = render.render(glow_behind([[("PRINCIPLED", (1, 1, 1), {"alpha": 0.3})]]), settings).image[..., :3]
    assert alpha.mean() == pytest.approx(0.7 * 2.0, rel=0.05)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_transparent_bounces_stop_at_their_limit(kernels):
    """Three clear sheets before the glowing wall: with Transparent Max Bounces 3 the camera sees the wall (the ray
    leaving the last surface a path may pass still brings back the emission it finds), with 2 it sees black: the
    surface after the last transparent bounce allowed ends the path (Cycles' terminate-on-next-surface; measured
    in Cycles 5.0 with four sheets: black at 3, the world at 4)."""
    sheets = glow_behind([[("TRANSPARENT", (1, 1, 1), {})]] * 3)
    settings = RenderSettings(width=4, height=4, samples=1, integrator="path", kernels=kernels)
    seen = render.render(sheets, dataclasses.replace(settings, transparent_max_bounces=3)).image[..., :3]
    np.testing.assert_allclose(seen, 2.0, rtol=1e-6)
    stopped = render.render(sheets, dataclasses.replace(settings, transparent_max_bounces=2)).image[..., :3]
    assert not stopped.any()


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_shadows_pass_transparent_surfaces_as_in_cycles(integrator, kernels):
    """A sun 45 degrees high over a grey floor, seen straight from above; a sheet outside the view, 2 above
    the floor, shadows the viewed floor: a clear tinted sheet (0.5, 0.25, 1) lets that share of the sunlight
    through (the floor shows albedo/pi x E x tint), a sheet of Principled Alpha 0.3 lets 0.7 through, an
    opaque one nothing (Cycles' transparent shadows)."""
    from core.scene import SunLight

    def floor(sheet, transparent_shadows=True):
        scene = Scene(camera=Camera(type="ORTHO", ortho_scale=1.0, matrix_world=np.array(
            [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 5.0], [0, 0, 0, 1.0]])))
        scene.materials.append(materials.Material((0.5, 0.5, 0.5), name="floor"))
        scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
        if sheet is not None:
            scene.materials.append(materials.Material(name="sheet", nodes=sheet,
                                                      transparent_shadows=transparent_shadows))
            scene.add_mesh(primitives.plane(2.0, center=(2.5, 0.0, 2.0)), materials=np.array([1]))
        scene.lights.append(SunLight(np.array([-1.0, 0.0, -1.0]) / math.sqrt(2.0), strength=3.0))
        return scene

    settings = RenderSettings(width=4, height=4, samples=4, integrator=integrator, max_bounces=0, kernels=kernels)
    lit = 0.5 / math.pi * 3.0 * math.cos(math.radians(45))
    np.testing.assert_allclose(render.render(floor(None), settings).image[..., :3], lit, rtol=1e-5)
    tinted = render.render(floor([("TRANSPARENT", (0.5, 0.25, 1.0), {})]), settings).image[..., :3]
    np.testing.assert_allclose(tinted, np.broadcast_to(lit * np.array([0.5, 0.25, 1.0]), tinted.shape), rtol=1e-5)
    alpha = render.render(floor([("PRINCIPLED", (1, 1, 1), {"alpha": 0.3})]), settings).image[..., :3]
    np.testing.assert_allclose(alpha, 0.7 * lit, rtol=1e-5)
    opaque = render.render(floor([("DIFFUSE", (0.5, 0.5, 0.5), {})]), settings).image[..., :3]
    assert not opaque.any()
    # Transparent Shadows off (the material's setting, which Cycles reads): the same alpha sheet shadows fully.
    blocked = render.render(floor([("PRINCIPLED", (1, 1, 1), {"alpha": 0.3})], transparent_shadows=False),
                            settings).image[..., :3]
    assert not blocked.any()


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_light_found_through_a_transparent_surface_is_weighed_as_before_it(kernels):
    """A sun with a 10-degree disk over a grey floor, a clear sheet of Alpha 0.5 between them (outside the
    view, wide enough to cover the sun's whole disk): the floor shows albedo/pi x E x 0.5 in expectation. The sun is found both by light
    samples (their shadow rays pass the sheet at half strength) and by BSDF rays that go on through it; the
    latter must be weighed by MIS with the floor's own BSDF pdf (as Cycles does: a transparent bounce keeps
    the last real bounce's pdf), or the light through the sheet is counted twice."""
    from core.scene import SunLight
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=1.0, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 5.0], [0, 0, 0, 1.0]])))
    scene.materials.append(materials.Material((0.5, 0.5, 0.5), name="floor"))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(materials.Material(name="sheet", nodes=[("PRINCIPLED", (1, 1, 1), {"alpha": 0.5,
                                                                                          "base_color": (0, 0, 0)})]))
    scene.add_mesh(primitives.plane(3.0, center=(2.5, 0.0, 2.0)), materials=np.array([1]))
    scene.lights.append(SunLight(np.array([-1.0, 0.0, -1.0]) / math.sqrt(2.0), strength=3.0, angle=math.radians(10)))
    lit = 0.5 / math.pi * 3.0 * math.cos(math.radians(45))
    for integrator in ("direct", "path"):         # (the sheet is black: no light bounces off it)
        settings = RenderSettings(width=4, height=4, samples=512, integrator=integrator, kernels=kernels)
        image = render.render(scene, settings).image[..., :3]
        assert image.mean() == pytest.approx(0.5 * lit, rel=0.03), integrator


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_a_path_past_its_bounce_limit_still_sees_the_world_through_a_clear_roof(integrator, kernels):
    """A grey floor (albedo 0.5) under a wide clear roof (a Transparent BSDF of colour 0.6), lit only by a
    constant world L = 2, with no bounces: the floor's BSDF rays end their path, yet go on through the roof
    to the world, as Cycles' paths do past their limits (terminate after transparent): the floor shows
    exactly albedo x 0.6 x L, without noise (each ray brings 0.6 L, weighed by the albedo)."""
    from core.lights.world import World
    scene = Scene(camera=Camera(type="ORTHO", ortho_scale=1.0, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.0], [0, 0, 0, 1.0]])), world=World(color=np.full(3, 2.0)))
    scene.materials.append(materials.Material((0.5, 0.5, 0.5), name="floor"))
    scene.materials.append(materials.Material(name="roof", nodes=[("TRANSPARENT", (0.6, 0.6, 0.6), {})]))
    scene.add_mesh(primitives.plane(4000.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(4000.0, center=(0.0, 0.0, 2.0)), materials=np.array([1]))
    settings = RenderSettings(width=4, height=4, samples=8, integrator=integrator, max_bounces=0, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, 0.5 * 0.6 * 2.0, rtol=1e-4)


def lamp_over_a_clear_pane(lamp: str, transparency: float, side: float = 1.0, height: float = 0.7,
                           radiance: float = 3.0, albedo: float = 0.6) -> tuple:
    """A floor of albedo rho under a square lamp of radiance L (side s, `height` above, facing down): an emissive
    quad ("emitter") or an area lamp ("area"), with a wide Transparent pane of the given transparency halfway
    between them; the camera looks straight down at a tiny patch of floor from below the pane. Returns (the scene,
    what the patch shows without the pane: rho L F, F = 4 F_corner(s / 2h, s / 2h) the square's form factor)."""
    from conftest import ortho_down
    from core.lights.area import AreaLight
    from test_emitters_world import rectangle_factor
    scene = Scene(camera=ortho_down(height=0.1, scale=0.02))
    scene.materials.append(materials.Material((albedo,) * 3, name="floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    if lamp == "emitter":
        scene.materials.append(materials.Material(np.zeros(3), "lamp", emission=np.full(3, radiance)))
        flipped = np.diag([1.0, -1.0, -1.0, 1.0])                   # the plane turned to face -Z
        flipped[2, 3] = height
        scene.add_mesh(primitives.plane(side), matrix=flipped, materials=np.array([1]))
    else:
        scene.lights.append(AreaLight(np.array([0.0, 0.0, height]), np.array([side, 0.0, 0.0]),
                                      np.array([0.0, side, 0.0]), np.array([0.0, 0.0, -1.0]),
                                      power=radiance * math.pi * side * side))     # (radiance P / (pi A))
    scene.materials.append(materials.Material(name="pane", nodes=[("TRANSPARENT", (transparency,) * 3, {})]))
    scene.add_mesh(primitives.plane(8.0, center=(0.0, 0.0, 0.5 * height)),
                   materials=np.array([len(scene.materials) - 1]))
    half = side / (2.0 * height)
    return scene, albedo * radiance * 4.0 * rectangle_factor(half, half)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("strategy", ["mis", "light", "bsdf"])
@pytest.mark.parametrize("transparency", [0.5, 1.0])
@pytest.mark.parametrize("lamp", ["emitter", "area"])
def test_a_clear_pane_passes_its_transparency_times_a_lamps_light(lamp, transparency, strategy, kernels):
    """A floor under a square lamp (an emissive quad, an area lamp) with a Transparent pane of transparency T
    between them shows T x the lamp's form-factor light, rho L F T, by every strategy (MIS, light samples alone,
    BSDF rays alone) and integrator: the direct tracer, a path with no bounces (its BSDF ray ends and looks on
    through the pane, through_transparent) and with bounces (it goes on through the pane as a clear bounce). The
    BSDF ray that finds the lamp beyond the pane must be weighed by MIS against the pdf the floor's light samples
    gave its direction, measured from the floor (Cycles' mis_origin), not from the pane (closer: a smaller light
    pdf, too much weight: +4.7 % for the quad, +15 % for the area lamp at T = 0.5); with light samples alone the
    ray through the pane must find nothing (it doubled the light)."""
    scene, bare = lamp_over_a_clear_pane(lamp, transparency)
    size = 8 if strategy == "bsdf" else 4          # (BSDF rays alone are the noisiest: more samples)
    for integrator, bounces in (("direct", 0), ("path", 0), ("path", 4)):
        settings = RenderSettings(width=size, height=size, samples=256, light_samples=4, light_sampling=strategy,
                                  integrator=integrator, max_bounces=bounces, kernels=kernels, adaptive=False)
        image = render.render(scene, settings).image[..., :3]
        assert image.mean() == pytest.approx(transparency * bare, rel=0.01), (integrator, bounces)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("strategy", ["mis", "light", "bsdf"])
def test_a_clear_pane_passes_its_transparency_times_a_round_lamps_light(strategy, kernels):
    """A floor under a round point lamp (radius R, d above, soft falloff: a disk of radiance P / (4 pi^2 R^2) facing
    the shading point, covering the cone sin^2 a = R^2 / (R^2 + d^2) around the floor's normal) shows rho/pi x
    L pi sin^2 a; with a Transparent pane of transparency 0.5 between them, half that, by every strategy and
    integrator. The BSDF ray past the pane must meet the disk that faces the floor point its light samples saw (not
    one facing the pane: -13 % with BSDF rays alone), weighed by the cone's pdf from there."""
    from conftest import ortho_down
    from core.lights.point import PointLight, sphere_radiance
    power, radius, height, albedo, T = 40.0, 0.5, 0.6, 0.6, 0.5
    scene = Scene(camera=ortho_down(height=0.1, scale=0.02))
    scene.materials.append(materials.Material((albedo,) * 3, name="floor"))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.lights.append(PointLight(np.array([0.0, 0.0, height]), power=power, radius=radius))
    scene.materials.append(materials.Material(name="pane", nodes=[("TRANSPARENT", (T,) * 3, {})]))
    scene.add_mesh(primitives.plane(8.0, center=(0.0, 0.0, 0.5 * height)), materials=np.array([1]))
    bare = albedo * sphere_radiance(power, radius) * radius ** 2 / (radius ** 2 + height ** 2)
    for integrator, bounces in (("direct", 0), ("path", 0), ("path", 4)):
        settings = RenderSettings(width=8, height=8, samples=256, light_samples=4, light_sampling=strategy,
                                  integrator=integrator, max_bounces=bounces, kernels=kernels, adaptive=False)
        image = render.render(scene, settings).image[..., :3]
        assert image.mean() == pytest.approx(T * bare, rel=0.01), (integrator, bounces)


def glass(name: str, ior: float, roughness: float = 0.0) -> materials.Material:
    """A clear Glass BSDF of index `ior` (any number: 1, 0 and below are bad input) and roughness."""
    return materials.Material(name=name, nodes=[("GLASS", (1, 1, 1), {"ior": ior, "roughness": roughness})])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_bad_glass_never_makes_a_nan_pixel_nor_hangs(kernels):
    """Path tracing at every bounce limit 1024 with roulette off: the camera inside a closed glass sphere (light
    trapped by total internal reflection), ten nested dielectric spheres of alternating index, and glass of
    index 1, 0, -1, 1e-9 and 1e9 next to an emitter of 1e30: the render ends, and every pixel is finite and
    non-negative."""
    scene = Scene(camera=Camera(lens=18.0))
    scene.materials += [glass("inside", 1.5), glass("index 1", 1.0), glass("index 0", 0.0), glass("negative", -1.0),
                        glass("tiny", 1e-9), glass("huge", 1e9, 0.3),
                        materials.Material(name="sun", nodes=[("EMISSION", (1, 1, 1), {"emission": (1e30,) * 3})])]
    scene.add_mesh(primitives.uv_sphere(1.0, 12, 6, smooth=True), materials=np.array([0]))      # around the camera
    for k in range(10):                                                                           # nested, ahead
        scene.add_mesh(primitives.uv_sphere(1.5 - 0.1 * k, 12, 6, center=(0.0, 0.0, -4.0), smooth=k % 2 == 0),
                       materials=np.array([1 + k % 5]))
    scene.add_mesh(primitives.plane(6.0, center=(0.0, 0.0, -8.0)), materials=np.array([6]))      # behind them
    settings = RenderSettings(width=12, height=12, samples=2, integrator="path", max_bounces=1024,
                              diffuse_bounces=1024, glossy_bounces=1024, transmission_bounces=1024,
                              transparent_max_bounces=1024, min_light_bounces=1024, kernels=kernels)
    image = render.render(scene, settings).image
    assert np.isfinite(image).all() and (image >= 0.0).all()
    assert image[..., :3].max() > 1e20                   # the emitter is seen, through the glass
