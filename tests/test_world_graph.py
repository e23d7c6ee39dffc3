"""A world made of shader nodes, baked into the equirectangular image Primer renders (core/lights/world_graph.py):
closed forms of the bake's directions and of the Environment Texture's lookup."""
from __future__ import annotations

import numpy as np
import pytest

from core.lights import world_graph
from core.lights.world import World, bilinear_equirect, direction_to_uv, uv_to_direction
from core.materials import textures
from core.materials.graph import GraphNode, Link


def generated_axis(axis: str) -> Link:
    """A Link to one component of the Generated coordinate (in a world: of the ray's direction)."""
    coords = GraphNode("TEXCOORD", {}, {}, "Texture Coordinate")
    return Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Generated")}, "Separate XYZ"), axis)


def test_each_texel_holds_the_graph_at_its_centres_direction():
    """Colour (Z, Z, Z) x strength 2 baked at width 64: texel (i, j) holds 2 cos(theta) of the direction of
    u = (j + 1/2) / 64, v = (i + 1/2) / 32, the centre the world's lookup reads it at."""
    image = world_graph.bake(generated_axis("Z"), 2.0, width=64)
    assert image.shape == (32, 64, 3) and image.dtype == np.float32
    v = (np.arange(32) + 0.5) / 32
    expected = 2.0 * np.cos(np.pi * (1.0 - v))                     # z = cos(theta), theta = pi (1 - v)
    assert np.allclose(image[:, :, 0], expected[:, None], atol=1e-6)
    assert np.allclose(image[:, :, 0], image[:, :, 2])


def test_the_bake_reads_azimuth_as_the_worlds_lookup_does():
    """X and Y baked: each texel centre's (x, y) is the direction whose (u, v) the world maps to that texel."""
    x, y = world_graph.bake(generated_axis("X"), 1.0, width=32), world_graph.bake(generated_axis("Y"), 1.0, width=32)
    u, v = np.meshgrid((np.arange(32) + 0.5) / 32, (np.arange(16) + 0.5) / 16)
    D = uv_to_direction(u.ravel(), v.ravel())
    assert np.allclose(x[:, :, 0].ravel(), D[:, 0], atol=1e-6) and np.allclose(y[:, :, 0].ravel(), D[:, 1], atol=1e-6)


def test_an_environment_texture_baked_at_its_own_size_gives_back_its_texels():
    """An equirectangular image through the graph's Environment Texture (Cycles' u = 1/2 - atan2(y, x) / 2 pi,
    v = 1/2 + atan2(z, |(x, y)|) / pi), baked at the image's own width: texel centres meet, so the bake is the image,
    and the world renders it as the plain environment does."""
    rng = np.random.default_rng(7)
    pixels = rng.random((16, 32, 3)).astype(np.float32)
    environment = GraphNode("ENVIRONMENT", {"image": textures.Image(pixels), "interpolation": "Linear"}, {},
                            "Environment Texture")
    baked = world_graph.bake(Link(environment, "Color"), 1.5, width=32)
    assert np.allclose(baked, 1.5 * pixels, atol=2e-5)
    D = uv_to_direction(*(rng.random((2, 200))))
    plain, graph = World(image=pixels, strength=1.5), World(image=baked)
    assert np.allclose(plain.radiance(D), graph.radiance(D), atol=3e-5)
    u, v = direction_to_uv(D)
    assert np.allclose(graph.radiance(D), 1.5 * bilinear_equirect(pixels, u, v), atol=3e-5)


# --- The program run in C (world_graph.c) and per camera ray (World.seen) -------------------------------------------

KERNELS = ["compiled", "numpy"]
CAMERA_SEES, LIGHTS_WITH = (1.0, 0.5, 0.25), (0.2, 0.3, 0.4)


def noise_sky() -> tuple:
    """A fine Checker of the direction (Scale 40) as colour, a Noise Texture's Fac as strength."""
    coords = GraphNode("TEXCOORD", {}, {}, "Texture Coordinate")
    noise = GraphNode("TEX_NOISE", {"dimensions": "3D", "noise_type": "FBM"},
                      {"Vector": Link(coords, "Generated"), "Scale": 3.0}, "Noise Texture")
    checker = GraphNode("TEX_CHECKER", {}, {"Vector": Link(coords, "Generated"), "Scale": 40.0}, "Checker Texture")
    return Link(checker, "Color"), Link(noise, "Fac")


def test_the_compiled_bake_is_the_reference_bake():
    """The bake run by graph.c (primer_world_bake, in bands of rows on threads) and by the numpy reference: the same
    program at the same texel centres, so the same floats to rounding (measured: bit for bit)."""
    color, strength = noise_sky()
    assert world_graph.compile_world(color, strength).compiled
    compiled = world_graph.bake(color, strength, width=128, kernels="compiled")
    reference = world_graph.bake(color, strength, width=128, kernels="numpy")
    assert compiled.shape == reference.shape == (64, 128, 3) and compiled.dtype == np.float32
    np.testing.assert_allclose(compiled, reference, rtol=1e-6, atol=1e-7)
    assert reference.std() > 0.05


def camera_or_lighting() -> Link:
    """A world shader Mix(Is Camera Ray) showing camera rays CAMERA_SEES and lighting the scene with LIGHTS_WITH."""
    is_camera = Link(GraphNode("LIGHT_PATH", {}, {}, "Light Path"), "Is Camera Ray")
    props = {"data_type": "RGBA", "blend_type": "MIX", "clamp_factor": True, "clamp_result": False}
    return Link(GraphNode("MIX", props, {"Factor": is_camera, "A": LIGHTS_WITH, "B": CAMERA_SEES}, "Mix"), "Result")


def camera_or_lighting_scene(clear_pane: bool):
    """A white-ish Lambert square (albedo 0.5, 2 x 2) at z = 0 filling the middle of an orthographic view 4 wide looking
    down, under the world camera_or_lighting (its bake: the constant LIGHTS_WITH); with clear_pane, a clear Transparent
    pane over everything at z = 1."""
    from conftest import ortho_down
    from core.geometry import primitives
    from core.materials import Material
    from core.scene import Scene
    radiance = camera_or_lighting()
    baked = world_graph.bake(radiance, 1.0, width=8)
    assert np.allclose(baked, LIGHTS_WITH)                      # (the bake: a ray that is not the camera's)
    world = World(color=np.asarray(LIGHTS_WITH, np.float64), seen=world_graph.compile_world(radiance, 1.0))
    scene = Scene(camera=ortho_down(height=3.0, scale=4.0), world=world)
    scene.materials += [Material(name="Floor", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {})]),
                        Material(name="Clear", nodes=[("TRANSPARENT", (1.0, 1.0, 1.0), {})])]
    scene.add_mesh(primitives.plane(2.0), materials=np.array([0]))
    if clear_pane:
        scene.add_mesh(primitives.plane(8.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
@pytest.mark.parametrize("clear_pane", [False, True])
def test_camera_rays_see_the_world_as_a_camera_ray_and_the_floor_is_lit_by_it_as_by_any_other(kernels, integrator,
                                                                                                 clear_pane):
    """Cycles evaluates the world for each escaping ray with its path: the camera, straight or through a clear pane
    (a transparent bounce keeps PATH_RAY_CAMERA), sees CAMERA_SEES; a Lambert floor of albedo 0.5 under the world is
    lit by LIGHTS_WITH from its whole hemisphere and shows 0.5 LIGHTS_WITH (cosine-sampled rays: no noise)."""
    from core import render
    from core.scene import RenderSettings
    result = render.render(camera_or_lighting_scene(clear_pane),
                           RenderSettings(width=8, height=8, samples=4, kernels=kernels, integrator=integrator))
    assert result.stats.kernels.startswith(kernels)
    image = result.image[..., :3]
    np.testing.assert_allclose(image[0, 0], CAMERA_SEES, rtol=1e-6)          # (a corner: past the floor)
    np.testing.assert_allclose(image[:2].reshape(-1, 3), np.tile(CAMERA_SEES, (16, 1)), rtol=1e-6)
    np.testing.assert_allclose(image[3:5, 3:5].reshape(-1, 3), np.tile(0.5 * np.asarray(LIGHTS_WITH), (4, 1)),
                               rtol=1e-5)


def test_a_pattern_finer_than_a_texel_is_seen_per_ray():
    """A Checker of Scale 2000 on the direction (squares some 0.03 degrees wide, a sixth of a bake texel): with one
    sample a pixel, each pixel is one camera ray's square, exactly one of its two colours (the bake's interpolation
    would blend them); the compiled twin evaluates the same rays to the same colours."""
    from core import render
    from core.camera.camera import Camera
    from core.geometry import primitives
    from core.scene import RenderSettings, Scene
    coords = GraphNode("TEXCOORD", {}, {}, "Texture Coordinate")
    checker = Link(GraphNode("TEX_CHECKER", {}, {"Vector": Link(coords, "Generated"), "Scale": 2000.0,
                                                 "Color1": (0.9, 0.2, 0.1), "Color2": (0.1, 0.3, 0.8)}, "Checker"),
                   "Color")
    world = World(image=world_graph.bake(checker, 1.0, width=64), seen=world_graph.compile_world(checker, 1.0))
    scene = Scene(camera=Camera(matrix_world=np.eye(4)), world=world)
    scene.add_mesh(primitives.plane(1.0, center=(0.0, 0.0, 5.0)))      # (behind the camera: Embree has a scene)
    images = {}
    for k in KERNELS:
        result = render.render(scene,
                               RenderSettings(width=16, height=16, samples=1, kernels=k, integrator="path"))
        assert result.stats.kernels.startswith(k)
        images[k] = result.image[..., :3].reshape(-1, 3)
    for image in images.values():
        first = np.isclose(image, (0.9, 0.2, 0.1), rtol=1e-6).all(axis=1)
        second = np.isclose(image, (0.1, 0.3, 0.8), rtol=1e-6).all(axis=1)
        assert (first | second).all() and first.any() and second.any()
    scene.world = World(image=world.image)                                     # the bake alone blends the squares
    baked = render.render(scene, RenderSettings(width=16, height=16, samples=1, integrator="path")).image[..., :3]
    pure = [np.isclose(baked.reshape(-1, 3), c, rtol=1e-3).all(axis=1) for c in ((0.9, 0.2, 0.1), (0.1, 0.3, 0.8))]
    assert (pure[0] | pure[1]).mean() < 0.5, (pure[0] | pure[1]).mean()   # (measured 0.28)
    np.testing.assert_allclose(images["compiled"], images["numpy"], rtol=1e-6)


def mix_by(output: str, a, b) -> Link:
    """A world shader colour: a where the Light Path output `output` is 0, b where it is 1."""
    factor = Link(GraphNode("LIGHT_PATH", {}, {}, "Light Path"), output)
    props = {"data_type": "RGBA", "blend_type": "MIX", "clamp_factor": True, "clamp_result": False}
    return Link(GraphNode("MIX", props, {"Factor": factor, "A": a, "B": b}, "Mix"), "Result")


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_mirrors_rays_find_the_world_as_singular_glossy_reflections(kernels):
    """A mirror turning every camera ray of an orthographic view towards +y, under Mix(Is Glossy Ray) of LIGHTS_WITH
    and CAMERA_SEES: the reflected rays escape as glossy rays (Cycles evaluates the world for each with its path) and
    bring back CAMERA_SEES; the bake (a light sample's view, Is Glossy Ray 0) is LIGHTS_WITH."""
    import math
    from conftest import ortho_down
    from core import render
    from core.geometry import primitives
    from core.materials import Material
    from core.scene import RenderSettings, Scene
    radiance = mix_by("Is Glossy Ray", LIGHTS_WITH, CAMERA_SEES)
    assert np.allclose(world_graph.bake(radiance, 1.0, width=8), LIGHTS_WITH)
    world = World(color=np.asarray(LIGHTS_WITH, np.float64), seen=world_graph.compile_world(radiance, 1.0))
    scene = Scene(camera=ortho_down(height=5.0, scale=1.0), world=world)
    scene.materials += [Material(name="Mirror", nodes=[("MIRROR", (1.0, 1.0, 1.0), {})])]
    mirror = primitives.plane(4.0)
    a = math.radians(-45.0)
    mirror.vertices = mirror.vertices @ np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)],
                                                  [0.0, math.sin(a), math.cos(a)]]).T
    scene.add_mesh(mirror, materials=np.array([0]))
    result = render.render(scene, RenderSettings(width=4, height=4, samples=4, kernels=kernels, integrator="path"))
    assert result.stats.kernels.startswith(kernels)
    np.testing.assert_allclose(result.image[..., :3].reshape(-1, 3), np.tile(CAMERA_SEES, (16, 1)), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_a_world_that_shines_on_diffuse_rays_alone_lights_a_floor_by_its_bsdf_rays(kernels, integrator):
    """A world of white x Is Diffuse Ray: its bake (light samples see EMISSION alone) is black, so, as in Cycles, it
    has no light samples, but the floor's diffuse BSDF rays find 1 where they escape: a Lambert floor of albedo 0.5
    shows 0.5, and the camera, whose rays are no diffuse rays, sees black beside it."""
    from core import render
    from core.scene import RenderSettings
    strength = Link(GraphNode("LIGHT_PATH", {}, {}, "Light Path"), "Is Diffuse Ray")
    assert np.allclose(world_graph.bake((1.0, 1.0, 1.0), strength, width=8), 0.0)
    scene = camera_or_lighting_scene(False)
    scene.world = World(color=np.zeros(3), seen=world_graph.compile_world((1.0, 1.0, 1.0), strength))
    result = render.render(scene, RenderSettings(width=8, height=8, samples=4, kernels=kernels, integrator=integrator))
    assert result.stats.kernels.startswith(kernels)
    image = result.image[..., :3]
    np.testing.assert_array_equal(image[:2], 0.0)
    np.testing.assert_allclose(image[3:5, 3:5], 0.5, rtol=1e-6)
