"""The compiled kernel's media (core/volumes/media.c) held to the Python reference: the same scenes, seeds and samples
render to the same pixels (a few float32 ulps, as tests/test_compiled.py holds the twins) with both integrators:
absorbing and emitting media behind volume-only boundaries and inside Glass and Transparent surfaces, overlapping
media, a camera inside a medium, shadow rays and bounces through media, the world's medium, single scattering (free
flight, equi-angular points, light samples and phase rays) with every light-sampling mode; and where a render goes
(any number of media compiled, MAX_MEDIA at once along a ray, said where a scene has more)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import AreaLight, PointLight, SunLight, World
from core.materials import Material
from core.render import render
from core.scene import RenderSettings, Scene

COLOR = np.array([0.2, 0.5, 0.8])


def unexpected(warnings: list) -> list:
    """The warnings (a heterogeneous medium gives none: it renders without bias)."""
    return list(warnings)


def fog(name: str = "Fog", closure: str = "ABSORPTION", surface=None, **inputs) -> Material:
    """A material with a Volume of one closure and either no Surface (a volume-only boundary) or `surface` nodes."""
    volume = [(closure, 1.0, inputs)]
    if surface is None:
        return Material(np.zeros(3), name, nodes=[("TRANSPARENT", np.ones(3), {})], volume=volume, volume_only=True)
    return Material(np.zeros(3), name, nodes=surface, volume=volume)


def room(camera: Camera) -> Scene:
    """A grey floor (material 0) and a red wall (material 1), an area lamp above and a point lamp to the side."""
    scene = Scene(camera=camera)
    scene.materials.append(Material(np.full(3, 0.7), "Floor"))
    scene.materials.append(Material(np.array([0.8, 0.2, 0.1]), "Wall"))
    scene.add_mesh(primitives.plane(12.0), materials=np.array([0]))
    scene.add_mesh(primitives.box((0.2, 8.0, 4.0), center=(-2.5, 0.0, 2.0)), materials=np.array([1]))
    scene.lights.append(AreaLight(center=np.array([0.5, 0.0, 3.5]), axis_u=np.array([1.0, 0.0, 0.0]),
                                  axis_v=np.array([0.0, 1.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]),
                                  power=400.0))
    scene.lights.append(PointLight(position=np.array([2.0, -2.0, 2.0]), power=300.0))
    return scene


def looking() -> Camera:
    """A perspective camera looking down at the room's middle."""
    return Camera.look_at((4.0, -5.0, 3.0), (0.0, 0.0, 0.8))


def absorbing_box(scene: Scene) -> None:
    """A volume-only absorbing box standing on the floor."""
    scene.materials.append(fog("Box", color=COLOR, density=1.2))
    scene.add_mesh(primitives.box((1.6, 1.6, 1.6), center=(0.0, 0.0, 0.8)), materials=np.array([len(scene.materials) - 1]))


def glass_ball(scene: Scene) -> None:
    """A smooth Glass sphere holding an absorbing medium."""
    scene.materials.append(fog("Ball", surface=[("GLASS", np.ones(3), {"ior": 1.45})], color=np.array([0.9, 0.4, 0.2]),
                               density=2.0))
    scene.add_mesh(primitives.uv_sphere(0.7, 24, 12, center=(1.0, 1.0, 0.7)),
                   materials=np.array([len(scene.materials) - 1]))


def emitting_shell(scene: Scene) -> None:
    """A Transparent shell (0.8) around a medium that absorbs and emits (Volume Coefficients), overlapping the box."""
    scene.materials.append(fog("Glow", closure="COEFFICIENTS", surface=[("TRANSPARENT", np.full(3, 0.8), {})],
                               absorption=np.array([0.6, 0.3, 0.9]), scatter=np.zeros(3),
                               emission=np.array([0.4, 0.2, 0.8])))
    scene.add_mesh(primitives.box((1.0, 3.0, 1.0), center=(0.5, 0.0, 1.2)), materials=np.array([len(scene.materials) - 1]))


def both(scene: Scene, **settings) -> tuple:
    """The scene rendered by the Python reference and the compiled kernel: (numpy RGBA, compiled RGBA, compiled
    RenderResult's stats)."""
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": "path", "max_bounces": 4, **settings}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    return reference.image, compiled.image, compiled.stats


def assert_same_pixels(reference: np.ndarray, compiled: np.ndarray) -> None:
    """Every pixel within 4e-7 absolute and 1e-6 relative (a few float32 ulps), and something to see."""
    assert reference[..., :3].max() > 0.01
    np.testing.assert_allclose(compiled, reference, rtol=1e-6, atol=4e-7)


def assert_same_light_groups(reference, compiled) -> None:
    """The two light groups of both renders' aux passes, each lit and within assert_same_pixels' tolerance."""
    groups = [name for name in reference.aux if name.startswith("lightgroup")]
    assert len(groups) == 2
    for name in groups:
        assert reference.aux[name].max() > 0.01
        np.testing.assert_allclose(compiled.aux[name], reference.aux[name], rtol=1e-6, atol=4e-7, err_msg=name)


def assert_same_tracked_pixels(reference: np.ndarray, compiled: np.ndarray, rtol: float = 1e-4) -> None:
    """A heterogeneous medium's render (ratio tracking, its walks' numbers keyed by each ray on a 2^-20 grid,
    core/volumes/tracking.py ray_keys): nine in ten values within a few float32 ulps as assert_same_pixels, and the
    rest within the tracking's noise (rtol: 1e-4 here): a secondary ray whose hit point the kernels compute a
    float32 ulp apart now and then straddles a grid line and walks other tentative collisions (in a Volume Bounces
    chain its throughput may then pick another channel and the path goes elsewhere: rtol 0.05)."""
    assert reference[..., :3].max() > 0.01
    close = np.isclose(compiled, reference, rtol=1e-6, atol=4e-7)
    assert close.mean() >= 0.9, close.mean()
    np.testing.assert_allclose(compiled, reference, rtol=rtol, atol=4e-7)
    np.testing.assert_allclose(compiled.mean(axis=(0, 1)), reference.mean(axis=(0, 1)), rtol=min(rtol, 0.01))


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_both_kernels_render_absorbing_and_emitting_media_in_a_lit_room_to_the_same_pixels(integrator):
    """An absorbing box (a volume-only boundary), a Glass ball holding a medium, and a Transparent shell around an
    emitting medium overlapping the box, under an area and a point lamp: camera rays, light samples' shadow rays,
    BSDF rays and bounces all cross media, enter and leave them."""
    scene = room(looking())
    absorbing_box(scene)
    glass_ball(scene)
    emitting_shell(scene)
    reference, compiled, stats = both(scene, integrator=integrator)
    assert stats.kernels == "compiled"
    assert_same_pixels(reference, compiled)


def test_both_kernels_see_from_a_camera_inside_a_medium_to_the_same_pixels():
    """A perspective camera inside an absorbing volume-only box that holds the whole room: its rays start in the
    medium (the walk along the first ray), and every ray of every path stays in it."""
    scene = room(Camera.look_at((2.0, -3.0, 2.0), (0.0, 0.0, 0.8)))
    scene.materials.append(fog("Air", color=np.array([0.9, 0.8, 0.7]), density=0.3))
    scene.add_mesh(primitives.box((10.0, 10.0, 6.0), center=(0.0, 0.0, 2.5)), materials=np.array([2]))
    glass_ball(scene)
    reference, compiled, stats = both(scene)
    assert stats.kernels == "compiled"
    assert_same_pixels(reference, compiled)


def test_both_kernels_render_a_world_medium_that_absorbs_and_emits_to_the_same_pixels():
    """The world's medium absorbing and emitting everywhere, with a world colour that no escaping ray reaches, and a
    sun whose light it blocks: the lamps' light and the medium's glow through it."""
    scene = room(looking())
    absorbing_box(scene)
    scene.lights.append(SunLight(direction=np.array([0.3, 0.2, -1.0]) / math.sqrt(1.13), strength=2.0))
    scene.world = World(color=np.array([0.3, 0.4, 0.5]),
                        volume=[("COEFFICIENTS", 1.0, {"absorption": np.array([0.05, 0.08, 0.1]),
                                                       "emission": np.array([0.01, 0.02, 0.01])})])
    reference, compiled, stats = both(scene)
    assert stats.kernels == "compiled"
    assert_same_pixels(reference, compiled)


def smoke(scene: Scene, closure: str = "SCATTER", **inputs) -> None:
    """A volume-only box of a scattering medium standing on the floor beside the absorbing one's place."""
    inputs = {"color": np.array([0.5, 0.6, 0.7]), "density": 0.8, "anisotropy": 0.3, **inputs}
    scene.materials.append(fog("Smoke", closure=closure, **inputs))
    scene.add_mesh(primitives.box((1.6, 1.6, 1.6), center=(0.0, 0.0, 0.8)), materials=np.array([len(scene.materials) - 1]))


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_both_kernels_scatter_light_in_a_smoke_box_to_the_same_pixels(integrator):
    """A Volume Scatter box (g 0.3) under an area and a point lamp: free-flight and equi-angular points on camera and
    bounce rays, light samples through the media weighed against phase-sampled rays, the balance heuristic between
    the two distances; the same shadow rays traced."""
    scene = room(looking())
    smoke(scene)
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": integrator, "max_bounces": 4}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    assert_same_pixels(reference.image, compiled.image)


@pytest.mark.parametrize("light_sampling", ["mis", "light", "bsdf"])
def test_both_kernels_render_a_world_fog_under_lamps_and_a_sun_to_the_same_pixels(light_sampling):
    """A world fog (scattering and absorbing everywhere) under an area lamp, a point lamp and a sun it blocks, with a
    back-scattering Principled Volume box and a Glass ball holding an absorbing medium: media inside media."""
    scene = room(looking())
    smoke(scene, "PRINCIPLED_VOLUME", anisotropy=-0.2, absorption_color=np.array([0.2, 0.3, 0.1]))
    glass_ball(scene)
    scene.lights.append(SunLight(direction=np.array([0.3, 0.2, -1.0]) / math.sqrt(1.13), strength=2.0))
    scene.world = World(color=np.array([0.3, 0.4, 0.5]),
                        volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": 0.05, "anisotropy": 0.5})])
    reference, compiled, stats = both(scene, light_sampling=light_sampling, light_samples=2)
    assert stats.kernels == "compiled"
    assert_same_pixels(reference, compiled)


@pytest.mark.parametrize("medium", ["absorbing", "scattering"])
def test_both_kernels_write_the_passes_light_groups_and_features_of_media_scenes_alike(medium):
    """With media, the light passes, the colour and first-hit passes, the denoising features and the light groups
    come out of both kernels alike (the media's own light in Combined alone, in both, with the same warning)."""
    from core.integrators.lightpasses import LIGHT_PASSES
    scene = room(looking())
    glass_ball(scene)
    absorbing_box(scene) if medium == "absorbing" else smoke(scene)
    scene.lightgroups = {"lights": ["Area", "Point"], "instances": [""] * len(scene.instances), "world": ""}
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": "path", "max_bounces": 4,
                "light_groups": ("Area", "Point"), "denoising_features": True,
                "passes": tuple(LIGHT_PASSES) + ("diffuse_color", "glossy_color", "transmission_color", "z_depth",
                                                 "average_normal", "emission", "environment", "ambient_occlusion")}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.warnings == reference.stats.warnings
    assert_same_pixels(reference.image, compiled.image)
    assert len(reference.aux) >= 18
    for name, buffer in reference.aux.items():
        np.testing.assert_allclose(compiled.aux[name], buffer, rtol=1e-6, atol=4e-7, err_msg=name)


def test_more_media_than_a_ray_is_in_at_once_render_compiled_to_the_references_pixels_and_say_so_once():
    """MAX_MEDIA volume materials render compiled with nothing to say; one more still renders compiled (its volume
    stack is sparse, as Cycles': any number of media, MAX_MEDIA of them at once along a ray) to the Python
    reference's pixels, with one warning of that limit."""
    from core.volumes import MAX_MEDIA
    scene = room(looking())
    settings = RenderSettings(width=4, height=4, samples=1, integrator="path")
    for index in range(int(MAX_MEDIA) + 1):
        if index == int(MAX_MEDIA):
            result = render(scene, settings)
            assert result.stats.kernels == "compiled" and not result.stats.warnings
        scene.materials.append(fog(f"Fog {index}", color=COLOR, density=0.1))
        scene.add_mesh(primitives.box((0.2, 0.2, 0.2), center=(0.3 * index - 2.0, 2.0, 0.1)),
                       materials=np.array([len(scene.materials) - 1]))
    reference, compiled, stats = both(scene, width=8, height=6, samples=2)
    assert stats.kernels == "compiled"
    assert_same_pixels(reference, compiled)
    notes = [w for w in stats.warnings if "volumes" in w]
    assert len(notes) == 1 and f"at most {int(MAX_MEDIA)} at once" in notes[0], notes


def noise_density(scale: float = 3.0):
    """A graph: `scale` x a Noise Texture (Scale 2) of the point's object coordinates (a heterogeneous density)."""
    from core.materials.graph import GraphNode, Link
    noise = Link(GraphNode("TEX_NOISE", {}, {"Vector": Link(GraphNode("TEXCOORD"), "Object"), "Scale": 2.0}), "Fac")
    return noise, Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": noise, "1": scale}), "Value")


def noise_box(scene: Scene, entries: list) -> None:
    """A volume-only box standing on the floor whose Volume is the closures `entries` (fed by nodes)."""
    scene.materials.append(Material(np.zeros(3), "Cloud", nodes=[("TRANSPARENT", np.ones(3), {})], volume=entries,
                                    volume_only=True))
    scene.add_mesh(primitives.box((1.6, 1.6, 1.6), center=(0.0, 0.0, 0.8)), materials=np.array([len(scene.materials) - 1]))


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_both_kernels_march_a_noise_fed_absorbing_and_glowing_box_to_the_same_pixels(integrator):
    """A box whose absorption density and emission strength a Noise Texture sets (core/volumes/field.c: its graph run
    at each piece's midpoint), beside a Glass ball holding a medium, under the room's lamps: camera rays, shadow rays,
    BSDF rays and bounces marched through it in both kernels."""
    noise, density = noise_density()
    scene = room(looking())
    noise_box(scene, [("ABSORPTION", 1.0, {"color": COLOR, "density": density}),
                      ("EMISSION", 1.0, {"strength": noise, "color": np.array([1.0, 0.4, 0.1])})])
    glass_ball(scene)
    reference, compiled, stats = both(scene, integrator=integrator)
    assert stats.kernels == "compiled" and not unexpected(stats.warnings)
    assert_same_tracked_pixels(reference, compiled)


@pytest.mark.parametrize("light_sampling", ["mis", "light", "bsdf"])
def test_both_kernels_scatter_light_in_a_noise_fed_smoke_to_the_same_pixels(light_sampling):
    """A Principled Volume smoke whose density (and glow) a Noise Texture sets, under an area lamp, a point lamp and
    a sun: free flight inverting the march's optical depth, equi-angular points weighed by the march's density, phase
    rays and shadow rays marched; the same shadow rays traced."""
    noise, density = noise_density()
    scene = room(looking())
    noise_box(scene, [("PRINCIPLED_VOLUME", 1.0, {"color": np.array([0.6, 0.7, 0.8]), "density": density,
                                                  "anisotropy": 0.3, "emission_strength": noise,
                                                  "emission_color": np.array([1.0, 0.4, 0.1])})])
    glass_ball(scene)
    scene.lights.append(SunLight(direction=np.array([0.3, 0.2, -1.0]) / math.sqrt(1.13), strength=2.0))
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": "path", "max_bounces": 4,
                "light_sampling": light_sampling}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    # (rtol 1e-3: paths that reach the fourth vertex, which Russian roulette keeps while they carry a quarter of the
    #  light, walk the smoke more often on hit points a float32 ulp apart; the same 3 values differ so with roulette off)
    assert_same_tracked_pixels(reference.image, compiled.image, rtol=1e-3)


def test_both_kernels_march_a_black_body_whose_temperature_a_noise_sets_to_the_same_pixels():
    """A Principled Volume glowing as a black body whose Temperature (800 to 2800 K, below and inside the fit's
    ranges) and density a Noise Texture sets: the fit's unclipped colour (negative outside Rec.709) and
    Stefan-Boltzmann's intensity per point, in both kernels alike."""
    from core.materials.graph import GraphNode, Link
    noise, density = noise_density()
    kelvin = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": noise, "1": 2000.0, "2": 800.0}), "Value")
    scene = room(looking())
    noise_box(scene, [("PRINCIPLED_VOLUME", 1.0, {"color": np.zeros(3), "density": density,
                                                  "blackbody_intensity": 1.0, "temperature": kelvin,
                                                  "blackbody_tint": np.array([1.0, 0.9, 0.8])})])
    reference, compiled, stats = both(scene)
    assert stats.kernels == "compiled" and not unexpected(stats.warnings)
    assert_same_tracked_pixels(reference, compiled)


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_both_kernels_walk_subsurface_spheres_in_a_smoke_box_and_a_world_fog_to_the_same_pixels(integrator):
    """Two subsurface spheres (Random Walk), one inside a Volume Scatter box, under a world fog: the walks' exit rays
    carry no medium's attenuation, gather nothing the media scatter along them and play no Russian roulette in either
    kernel, the exits take the media across from the entries (subsurface.media_across), and the media scatter along
    the other rays as before; the same pixels to a few float32 ulps, and no warning about the volume stack."""
    scene = room(looking())
    smoke(scene)
    scene.materials.append(Material(name="Wax", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {
        "base_color": (0.8, 0.5, 0.3), "subsurface": 1.0, "subsurface_scale": 0.5})]))
    wax = np.array([len(scene.materials) - 1])
    scene.add_mesh(primitives.uv_sphere(0.6, 24, 12, center=(0.0, 0.0, 0.8), smooth=True), materials=wax)
    scene.add_mesh(primitives.uv_sphere(0.5, 24, 12, center=(1.5, -1.0, 0.5), smooth=True), materials=wax)
    scene.world = World(color=np.array([0.3, 0.4, 0.5]),
                        volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": 0.05, "anisotropy": 0.5})])
    reference, compiled, stats = both(scene, integrator=integrator, samples=4)
    assert stats.kernels == "compiled"
    assert not any("volume stack" in w or "medium" in w for w in stats.warnings)
    assert reference[..., :3].max() > 0.01
    np.testing.assert_allclose(compiled, reference, rtol=5e-6, atol=4e-7)


@pytest.mark.parametrize("medium", ["smoke", "world fog", "noise"])
def test_both_kernels_follow_volume_bounces_chains_to_the_same_pixels(medium):
    """Volume Bounces 2 (paths go on from where they scatter: volume.py multiple_scattering, volume.c volume_chain):
    a smoke box under the room's lamps; a world fog the camera starts in around a back-scattering Principled Volume
    box and a Glass ball (the camera rays' own chains, their paths reaching the floor); a Noise-fed smoke (collisions
    inverting the march's optical depth). The same collisions, equi-angular points, phase rays, arrivals at surfaces
    and shadow rays in both kernels."""
    scene = room(looking())
    settings = {"volume_bounces": 2}
    if medium == "smoke":
        smoke(scene)
    elif medium == "world fog":
        smoke(scene, "PRINCIPLED_VOLUME", anisotropy=-0.2, absorption_color=np.array([0.2, 0.3, 0.1]))
        glass_ball(scene)
        scene.world = World(color=np.array([0.3, 0.4, 0.5]),
                            volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": 0.05, "anisotropy": 0.5})])
        settings = {"volume_bounces": 1, "light_samples": 2}
    else:
        noise, density = noise_density()
        noise_box(scene, [("PRINCIPLED_VOLUME", 1.0, {"color": np.array([0.6, 0.7, 0.8]), "density": density,
                                                      "anisotropy": 0.3, "emission_strength": noise,
                                                      "emission_color": np.array([1.0, 0.4, 0.1])})])
        settings = {"volume_bounces": 2, "width": 6, "height": 4}
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": "path", "max_bounces": 4, **settings}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled" and not unexpected(compiled.stats.warnings)
    if medium == "noise":           # (a path whose walks the kernels key apart may pick another channel)
        assert abs(compiled.stats.shadow_rays / reference.stats.shadow_rays - 1.0) < 0.03
    else:
        assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    if medium == "noise":
        assert_same_tracked_pixels(reference.image, compiled.image, rtol=0.05)
    else:
        assert_same_pixels(reference.image, compiled.image)


@pytest.mark.parametrize("bounces", [0, 2])
def test_both_kernels_write_the_light_groups_of_a_world_fog_around_the_camera_alike(bounces):
    """A world fog around the camera, Volume Bounces 0 and 2: the light groups of both kernels alike (what the camera's
    hits gather dimmed by the fog along the camera rays, as the image; with bounces, the paths that scatter along
    the camera rays and reach a surface writing theirs too)."""
    scene = room(looking())
    smoke(scene)
    scene.world = World(color=np.array([0.3, 0.4, 0.5]),
                        volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": 0.05, "anisotropy": 0.5})])
    scene.lightgroups = {"lights": ["Area", "Point"], "instances": [""] * len(scene.instances), "world": ""}
    settings = {"width": 8, "height": 6, "samples": 3, "integrator": "path", "max_bounces": 4,
                "volume_bounces": bounces, "light_groups": ("Area", "Point")}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert_same_pixels(reference.image, compiled.image)
    assert_same_light_groups(reference, compiled)


def bumped_floor_material() -> Material:
    """A grey Diffuse whose normal is a Bump (Distance 0.5, Filter Width 1) of the height sin(4 x) (x: world X)."""
    from core.materials.graph import GraphNode, Link
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("GEOMETRY", {}, {}), "Position")}), "X")
    height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": Link(GraphNode(
        "MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 4.0}), "Value")}), "Value")
    normal = Link(GraphNode("BUMP", {"invert": False, "filter_width": 1.0},
                            {"Strength": 1.0, "Distance": 0.5, "Height": height}), "Normal")
    return Material(name="Bumped floor", nodes=[("DIFFUSE", (0.7, 0.7, 0.7), {"color": np.full(3, 0.7),
                                                                               "normal": normal})])


def test_a_bumped_floor_met_after_scattering_in_fog_is_shaded_alike_by_both_kernels():
    """Paths that scattered in a world fog and went on (Volume Bounces 1) reach a floor whose normal is a Bump: a
    scattering point has no footprint and its ray keeps the spread it had (Cycles: dP 0, dD kept); under an
    orthographic camera (spread 0) the bump is flat there. The Python reference and the compiled kernel alike, the
    same shadow rays traced."""
    camera = looking()
    camera = Camera(matrix_world=camera.matrix_world, type="ORTHO", ortho_scale=8.0, clip_start=0.1, clip_end=100.0)
    scene = room(camera)
    scene.materials[0] = bumped_floor_material()
    scene.world = World(color=np.zeros(3), volume=[("SCATTER", 1.0, {"color": np.full(3, 0.9), "density": 0.15,
                                                                      "anisotropy": 0.0})])
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": "path", "max_bounces": 3, "volume_bounces": 1}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    assert_same_pixels(reference.image, compiled.image)


def test_both_kernels_sample_a_volume_objects_grids_to_the_same_pixels():
    """A Volume object's grids (core/volumes/grids.py): a float grid "density" of uneven values and a vector grid
    "color" (tricubic), under turned and scaled index maps, read by a Principled Volume (its density x the grid, as the add-on
    writes it; its black body's temperature x each voxel's, their glows averaged) and an Attribute node's Color: trilinear lookups in both kernels (field.c grid_sample), marched along
    camera, scatter and shadow rays, to the same pixels."""
    from core.materials.graph import GraphNode, Link
    from core.volumes.grids import Grid
    rng = np.random.default_rng(7)
    density = rng.random((9, 7, 8, 1)).astype(np.float32) * 3.0
    color = (0.3 + 0.7 * rng.random((5, 6, 4, 3))).astype(np.float32)
    turn = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    grids = [Grid("density", density, np.zeros(3), np.hstack([turn * 4.0, [[4.0], [3.0], [0.5]]])),
             Grid("color", color, np.zeros(3), np.hstack([np.eye(3) * 2.5, [[2.0], [2.5], [-0.5]]]), cubic=True)]
    fac = Link(GraphNode("ATTRIBUTE", {"attribute": "grid:density"}), "Fac")
    entries = [("PRINCIPLED_VOLUME", 1.0, {
        "color": Link(GraphNode("ATTRIBUTE", {"attribute": "attr:color"}), "Color"), "anisotropy": 0.2,
        "density": Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": 1.5, "1": fac}), "Value"),
        "blackbody_intensity": 0.7, "temperature": 700.0, "temperature_grid": "density"})]
    scene = room(looking())
    scene.materials.append(Material(np.zeros(3), "Cloud", nodes=[("TRANSPARENT", np.ones(3), {})], volume=entries,
                                    volume_only=True,
                                    volume_space=(np.eye(4)[:3], np.zeros(3), np.ones(3), grids)))
    scene.add_mesh(primitives.box((1.6, 1.6, 1.6), center=(0.0, 0.0, 0.8)), materials=np.array([len(scene.materials) - 1]))
    reference, compiled, stats = both(scene)
    assert stats.kernels == "compiled" and not unexpected(stats.warnings)
    assert_same_tracked_pixels(reference, compiled)


@pytest.mark.parametrize("clamp", [0.0, 0.5])
def test_both_kernels_see_a_glowing_floor_in_a_world_fog_with_volume_bounces_to_the_same_pixels(clamp):
    """An Emission floor (radiance 1, reflecting nothing) under a scattering world fog around the camera, Volume
    Bounces 2, with and without Clamp Direct (0.5): the camera sees the floor's emission through what a path that
    passes to it carries on (0 where it scattered: volume.multiple_scattering's through, clamped through it), and a
    path that scattered and reached the floor adds no emission of its own there (its phase ray found it). Both
    kernels to the same pixels and light groups, the same shadow rays, and the same Denoising Albedo (the fog's, then
    the glow its passing paths carry, features.found; before the fix the compiled kernel's lacked the glow, 0.5 less
    per pixel near the camera)."""
    scene = Scene(camera=Camera.look_at((0.0, -4.0, 2.0), (0.0, 0.0, 0.0)))
    scene.materials.append(Material(name="Glow", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": np.ones(3)})]))
    scene.add_mesh(primitives.plane(12.0), materials=np.array([0]))
    scene.lights.append(PointLight(position=np.array([1.0, -1.0, 2.5]), power=100.0))
    scene.world = World(color=np.zeros(3), volume=[("SCATTER", 1.0, {"color": np.full(3, 0.9), "density": 0.3,
                                                                      "anisotropy": 0.0})])
    scene.lightgroups = {"lights": ["Point"], "instances": ["Floor"], "world": ""}
    settings = {"width": 16, "height": 12, "samples": 4, "integrator": "path", "max_bounces": 4,
                "volume_bounces": 2, "sample_clamp_direct": clamp, "light_groups": ("Floor", "Point"),
                "denoising_features": True}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    assert_same_pixels(reference.image, compiled.image)
    assert_same_light_groups(reference, compiled)
    np.testing.assert_allclose(compiled.aux["denoising_albedo"], reference.aux["denoising_albedo"], rtol=1e-5,
                               atol=1e-6)
