"""Denoising features (core/integrators/features.py, features.c): each pixel's first non-specular albedo and normal,
written by the integrator along its own paths on both kernels, as Cycles 5.0 writes them."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ortho_down, sun_direction, unit
from core import render
from core.camera import Camera
from core.geometry import primitives
from core.integrators import features
from core.scene import RenderSettings, Scene, SunLight


def plane_scene(color=(0.2, 0.5, 0.7), bsdf="DIFFUSE", world=(0.0, 0.0, 0.0)) -> Scene:
    """A 20 x 20 plane in z = 0 with one material under a sun, an orthographic camera looking down."""
    scene = Scene(camera=ortho_down(scale=2.0), world_color=np.array(world, np.float64))
    scene.add_material(color, bsdf=bsdf)
    scene.add_mesh(primitives.plane(20.0), materials=[0])
    scene.lights.append(SunLight(sun_direction(60.0), strength=2.0))
    return scene


def features_of(scene: Scene, kernels: str = "compiled", width: int = 16, height: int = 12, **kw) -> dict:
    """Render `scene` small (width x height) with the denoising features and return the result's aux buffers."""
    settings = RenderSettings(width=width, height=height, samples=4, denoising_features=True, kernels=kernels, **kw)
    return render.render(scene, settings).aux


def test_a_diffuse_plane_gives_its_base_colour_as_albedo_and_its_normal():
    """Lambert's closure weight is the base colour; the shading normal of a plane facing the camera is +Z."""
    for kernels in ("compiled", "numpy"):
        aux = features_of(plane_scene(), kernels)
        assert aux["denoising_albedo"].shape == (12, 16, 3) and aux["denoising_albedo"].dtype == np.float32
        np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to([0.2, 0.5, 0.7], (12, 16, 3)), atol=1e-6)
        np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, 0.0, 1.0], (12, 16, 3)), atol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["direct", "path", "whitted"])
def test_the_features_leave_the_image_unchanged(kernels, integrator):
    """The integrator writes the features beside the image: the image is the same with or without them, bit for bit."""
    scene = mirror_scene()
    settings = RenderSettings(width=16, height=12, samples=4, integrator=integrator, kernels=kernels, max_bounces=2)
    a = render.render(scene, settings).image
    b = render.render(scene, dataclasses.replace(settings, denoising_features=True)).image
    assert np.array_equal(a, b)


def mirror_scene() -> Scene:
    """A tinted mirror tilted 45 degrees under a camera looking down, reflecting a red wall, under a sun."""
    camera = Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=math.radians(10))
    scene = Scene(camera=camera, world_color=np.zeros(3))
    scene.add_material((0.9, 0.8, 0.5), bsdf="MIRROR")
    scene.add_material((0.6, 0.1, 0.1))
    mirror = primitives.plane(4.0)
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(math.pi / 4), -math.sin(math.pi / 4)],
                     [0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]])
    mirror.vertices = mirror.vertices @ tilt.T                      # normal (0, -0.707, 0.707)
    scene.add_mesh(mirror, materials=[0])
    wall = primitives.plane(40.0)
    wall.vertices = wall.vertices @ np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]).T
    wall.vertices = wall.vertices + [0.0, -6.0, 0.0]              # the plane y = -6, normal +-Y
    scene.add_mesh(wall, materials=[1])
    scene.lights.append(SunLight(sun_direction(60.0), strength=2.0))
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_mirror_shows_the_albedo_and_normal_of_what_its_path_reaches(kernels):
    """Path traced, the mirror's pixels take the wall's albedo x the mirror's tint and the wall's normal; with Max
    Bounces 0 the path ends at the wall before its feature vertex: albedo and normal 0. Both as measured in Cycles
    5.0 on this scene (albedo (0.54, 0.08, 0.05), normal (0, 1, 0) at Max Bounces 1; 0 and 0 at Max Bounces 0)."""
    aux = features_of(mirror_scene(), kernels, integrator="path", max_bounces=1)
    centre = aux["denoising_albedo"][4:8, 6:10]
    np.testing.assert_allclose(centre, np.broadcast_to([0.54, 0.08, 0.05], centre.shape), atol=1e-5)
    normal = aux["denoising_normal"][4:8, 6:10]
    np.testing.assert_allclose(normal, np.broadcast_to([0.0, 1.0, 0.0], normal.shape), atol=1e-5)
    for integrator in ("direct", "path"):
        aux = features_of(mirror_scene(), kernels, integrator=integrator, max_bounces=0)
        assert not aux["denoising_albedo"][4:8, 6:10].any() and not aux["denoising_normal"][4:8, 6:10].any()


def test_the_kernels_write_the_same_features():
    """Both kernels, the same samples: the same albedo and normal (a mirror, a wall, a diffuse floor, a sun)."""
    scene = mirror_scene()
    scene.add_material((0.3, 0.6, 0.2))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, -3.0)), materials=[2])
    for integrator in ("direct", "path"):
        a, b = (features_of(scene, kernels, integrator=integrator, max_bounces=3) for kernels in ("numpy", "compiled"))
        for name in ("denoising_albedo", "denoising_normal"):
            np.testing.assert_allclose(a[name], b[name], atol=1e-5, err_msg=(integrator, name))


def test_rays_that_escape_give_the_world_as_albedo_and_no_normal():
    """Where the camera sees the world: its colour as albedo (Cycles writes the background), normal 0."""
    scene = Scene(camera=ortho_down(scale=2.0), world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(20.0, center=(0.0, 0.0, 5.0)), materials=[0])   # behind the camera
    scene.lights.append(SunLight(sun_direction(60.0), strength=2.0))
    aux = features_of(scene)
    np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to([0.1, 0.2, 0.3], (12, 16, 3)), atol=1e-6)
    assert not aux["denoising_normal"].any()


def test_glossy_closures_count_as_diffuse_only_when_rough():
    """Cycles' split: a glossy closure with alpha > 0.075 is diffuse-like, a sharper one specular-like."""
    from core.materials import Closures, Lambert, Microfacet, Mirror, PARAMS
    kind = np.array([[Lambert.kind, Microfacet.kind, Microfacet.kind, Mirror.kind]], np.int32)
    params = np.zeros((1, 4, PARAMS))
    params[0, 1, 0], params[0, 2, 0] = 0.3, 0.01
    closures = Closures(kind, np.ones((1, 4, 3)), np.ones((1, 4)), np.tile(unit([0, 0, 1]), (1, 4, 1)), params)
    assert features.diffuse_like(closures).tolist() == [[True, True, False, False]]


def foggy(scene: Scene, scatter: float, absorb: float) -> Scene:
    """The scene in a grey world fog: Volume Scatter of density `scatter` (white) and Volume Absorption of density
    `absorb` (black: it absorbs every channel), so sigma_s = scatter and sigma_t = scatter + absorb."""
    from core.lights import World
    volume = [("ABSORPTION", 1.0, {"color": np.zeros(3), "density": absorb})]
    if scatter > 0.0:
        volume.append(("SCATTER", 1.0, {"color": np.ones(3), "density": scatter, "anisotropy": 0.0}))
    scene.world = World(color=np.zeros(3), volume=volume)
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_plane_seen_through_fog_gives_the_fogs_albedo_then_the_planes_by_the_odds_of_passing(kernels):
    """Cycles 5.0 writes a medium's albedo sigma_s / sigma_t (1 - T) (the integral of T sigma_s) while the camera
    path looks, and a path that scatters stops looking; in expectation (its unguided odds of passing, T for a grey
    medium) the plane behind adds T times its albedo: with sigma_s 0.8, sigma_t 1.2 over the 0.999 from the camera's
    near plane to the plane, albedo = 2/3 (1 - T) + T (0.2, 0.5, 0.7); the normal (1 - T) back towards the camera
    plus T the plane's, both +Z here."""
    aux = features_of(foggy(plane_scene(), 0.8, 0.4), kernels, integrator="path")
    T = math.exp(-1.2 * 0.999)
    expected = 2.0 / 3.0 * (1.0 - T) + T * np.array([0.2, 0.5, 0.7])
    np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to(expected, (12, 16, 3)), rtol=1e-5)
    np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, 0.0, 1.0], (12, 16, 3)), atol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_looking_into_endless_fog_gives_its_albedo_and_the_normal_back_towards_it(kernels):
    """A camera looking up into the fog (nothing in view, clip end 10 away): every path scatters before it ends but
    for T(9.999) = exp(-12.0), so the albedo is 2/3 (1 - T) and the normal is the view direction back towards the
    camera, -Z here (Cycles' (0, 0, -1) in camera space)."""
    scene = foggy(plane_scene(), 0.8, 0.4)
    scene.camera = dataclasses.replace(scene.camera, matrix_world=np.diag([1.0, -1.0, -1.0, 1.0]) @ np.eye(4)
                                       + np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1.0], [0, 0, 0, 0]]))
    aux = features_of(scene, kernels, integrator="path")
    T = math.exp(-1.2 * 9.999)
    np.testing.assert_allclose(aux["denoising_albedo"], np.full((12, 16, 3), 2.0 / 3.0 * (1.0 - T)), rtol=1e-5)
    np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, 0.0, -(1.0 - T)], (12, 16, 3)),
                               atol=1e-6)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_fog_that_only_absorbs_leaves_the_features_as_they_are(kernels):
    """A medium that scatters nothing only attenuates (Cycles writes no albedo for it and its paths never stop
    looking there): the plane's albedo and normal exactly."""
    aux = features_of(foggy(plane_scene(), 0.0, 0.7), kernels, integrator="path")
    np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to([0.2, 0.5, 0.7], (12, 16, 3)), atol=1e-6)
    np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, 0.0, 1.0], (12, 16, 3)), atol=1e-6)


def test_a_glowing_floor_in_fog_with_volume_bounces_gives_the_fogs_albedo_and_the_glow_by_the_odds_of_passing():
    """An Emission floor (radiance 0.5, no closures: the path's feature vertex, albedo 0 of its own) 4 below an
    orthographic camera in a grey world fog of albedo a = 0.9 (Scatter 0.27, Absorption 0.03: sigma_t 0.3), Volume
    Bounces 2. Cycles writes the fog's a (1 - T) while the camera path looks (T = exp(-0.3 x 3.996) from the near
    plane), then the floor's emission times what a path that passed carries (T / P = 1 here, P = T for a grey fog)
    and nothing where the path scattered (it stopped looking: its phase ray's glow is no feature). So each sample
    writes a (1 - T) or a (1 - T) + 0.5: each pixel of 16 samples is a (1 - T) + 0.5 k / 16 (k whole, 0..16), the
    mean over the image a (1 - T) + 0.5 T within its noise (0.5 sqrt(T (1 - T) / 3072) per sample drawn), never
    above a (1 - T) + 0.5 (an emission counted twice) nor missing the glow (the compiled kernel's before its fix:
    a (1 - T), 0.629, everywhere). Both kernels to the same pixels."""
    from core.lights import World
    from core.materials import Material
    scene = Scene(camera=ortho_down(height=4.0, scale=2.0))
    scene.materials.append(Material(name="Glow", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                         {"emission": np.full(3, 0.5)})]))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.world = World(color=np.zeros(3), volume=[
        ("SCATTER", 1.0, {"color": np.ones(3), "density": 0.27, "anisotropy": 0.0}),
        ("ABSORPTION", 1.0, {"color": np.zeros(3), "density": 0.03})])
    settings = RenderSettings(width=16, height=12, samples=16, integrator="path", max_bounces=4, volume_bounces=2,
                              denoising_features=True)
    reference, compiled = (render.render(scene, dataclasses.replace(settings, kernels=kernels))
                           for kernels in ("numpy", "compiled"))
    assert compiled.stats.kernels == "compiled"
    a, b = reference.aux["denoising_albedo"], compiled.aux["denoising_albedo"]
    np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-6)
    T, fog, glow = math.exp(-0.3 * (4.0 - 4e-3)), 0.9, 0.5
    k = (a - fog * (1.0 - T)) / glow * 16.0
    np.testing.assert_allclose(k, np.round(k), atol=1e-3)
    assert k.min() >= -1e-3 and k.max() <= 16.0 + 1e-3
    assert abs(a.mean() - (fog * (1.0 - T) + glow * T)) < 4.0 * glow * math.sqrt(T * (1.0 - T) / a[..., 0].size / 16)


def linear_slab(scene: Scene, axis: str, scale: float, offset: float, low, high) -> Scene:
    """Add to `scene` a volume-only box from `low` to `high` (3 each, world = object coordinates) holding a
    heterogeneous medium of density scale x (the point's object `axis`) + offset: a Volume Scatter of colour
    FOG_COLOUR and a Volume Absorption of the same colour and density, so sigma_s = density x colour and
    sigma_t = density in every channel (T grey, sigma_s / sigma_t = the colour all along)."""
    from core.materials import Material
    from core.materials.graph import GraphNode, Link
    coords = GraphNode("TEXCOORD")
    value = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Object")}), axis.upper())
    density = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": value, "1": scale, "2": offset}), "Value")
    volume = [("SCATTER", 1.0, {"color": FOG_COLOUR, "density": density, "anisotropy": 0.0}),
              ("ABSORPTION", 1.0, {"color": FOG_COLOUR, "density": density})]
    scene.materials.append(Material(np.zeros(3), "Slab", nodes=[("TRANSPARENT", np.ones(3), {})], volume=volume,
                                    volume_only=True))
    low, high = np.asarray(low, np.float64), np.asarray(high, np.float64)
    scene.add_mesh(primitives.box(tuple(high - low), center=tuple(0.5 * (low + high))),
                   materials=np.array([len(scene.materials) - 1]))
    return scene


FOG_COLOUR = np.array([0.9, 0.6, 0.3])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_plane_seen_through_a_slab_of_linear_density_gives_its_albedo_by_the_integral(kernels):
    """A heterogeneous slab (z from 0.5 to 1.5, density z + 0.25: optical depth 1.25) between the camera and the
    plane: the integral of T sigma_s over the march is colour (1 - T) with T = exp(-1.25) (sigma_s / sigma_t is the
    colour all along; the march's midpoints integrate a linear density exactly), and the plane behind counts T times
    its albedo: albedo = colour (1 - T) + T (0.2, 0.5, 0.7); the normal +Z both ways. The same from a camera inside
    the slab (z = 1.25, its near plane 1.25e-3 below: the camera rays' own media), over the depth from there down."""
    for height, top in ((3.0, 1.5), (1.25, 1.25 - 1.25e-3)):
        scene = plane_scene()
        scene.camera = ortho_down(height=height, scale=2.0)
        linear_slab(scene, "z", 1.0, 0.25, (-3.0, -3.0, 0.5), (3.0, 3.0, 1.5))
        aux = features_of(scene, kernels, integrator="path")
        T = math.exp(-(0.5 * (top ** 2 - 0.5 ** 2) + 0.25 * (top - 0.5)))
        expected = FOG_COLOUR * (1.0 - T) + T * np.array([0.2, 0.5, 0.7])
        np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to(expected, (12, 16, 3)), rtol=1e-6,
                                   err_msg=str(height))
        np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, 0.0, 1.0], (12, 16, 3)), atol=1e-6,
                                   err_msg=str(height))


def mirror_into_slab() -> Scene:
    """mirror_scene seen by an orthographic camera looking straight down (its rays leave the mirror along -Y exactly)
    with a heterogeneous slab between the mirror and the wall: y from -4 to -2, density 1.5 - 0.5 (y + 4) (from 1.5
    to 0.5 along the rays: optical depth 2)."""
    scene = mirror_scene()
    scene.camera = ortho_down(height=3.0, scale=1.0)
    return linear_slab(scene, "y", -0.5, -0.5, (-2.0, -4.0, -1.5), (2.0, -2.0, 1.5))


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_mirror_bounce_through_a_slab_of_linear_density_gives_its_albedo_by_the_integral(kernels):
    """The mirror's rays cross the slab while their paths look (feature throughput and path throughput: the tint):
    albedo = tint^2 colour (1 - T) + T tint (0.6, 0.1, 0.1) with T = exp(-2), the wall's normal +Y times T plus the
    view direction back towards the camera (+Z) times 1 - T."""
    aux = features_of(mirror_into_slab(), kernels, integrator="path", max_bounces=2)
    tint, T = np.array([0.9, 0.8, 0.5]), math.exp(-2.0)
    expected = tint * tint * FOG_COLOUR * (1.0 - T) + T * tint * np.array([0.6, 0.1, 0.1])
    np.testing.assert_allclose(aux["denoising_albedo"], np.broadcast_to(expected, (12, 16, 3)), rtol=1e-6)
    np.testing.assert_allclose(aux["denoising_normal"], np.broadcast_to([0.0, T, 1.0 - T], (12, 16, 3)), atol=1e-6)


def test_the_kernels_write_the_same_features_through_a_varying_medium():
    """A Noise Texture's density in the slab the mirror's rays cross, and in a slab around the camera: both
    kernels march the same pieces and sum them alike (and the slabs do change the features). On 8 x 6 pixels (every
    pixel's rays take the same mirror-slab-wall route, 4 samples each still averaged): the reference's render was
    most of the test's time at 16 x 12."""
    from core.materials import Material
    from core.materials.graph import GraphNode, Link
    scene = mirror_into_slab()
    noise = Link(GraphNode("TEX_NOISE", {}, {"Scale": 3.0}), "Fac")
    volume = [("PRINCIPLED_VOLUME", 1.0, {"color": FOG_COLOUR, "density": noise, "anisotropy": 0.2})]
    scene.materials[2] = dataclasses.replace(scene.materials[2], volume=volume)
    scene.materials.append(Material(np.zeros(3), "Haze", nodes=[("TRANSPARENT", np.ones(3), {})], volume=volume,
                                    volume_only=True))
    scene.add_mesh(primitives.box((4.0, 4.0, 2.0), center=(0.0, 0.0, 2.5)), materials=np.array([3]))
    a, b = (features_of(scene, kernels, 8, 6, integrator="path", max_bounces=2) for kernels in ("numpy", "compiled"))
    for name in ("denoising_albedo", "denoising_normal"):
        np.testing.assert_allclose(a[name], b[name], atol=1e-9, rtol=1e-9, err_msg=name)
    assert np.abs(a["denoising_albedo"] - np.array([0.54, 0.08, 0.05])).min() > 1e-3
