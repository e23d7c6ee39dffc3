"""Heterogeneous media (core/volumes/field.py: a volume input fed by nodes, marched along each ray) held to closed
forms: an absorbing slab whose density grows linearly with height keeps exp(-its integral) on camera and shadow
rays; a graph that is constant renders the homogeneous medium's image; an emitting slab of linear emission sends
its integral; a Mix Shader's linked factor weighs its closures point by point."""
from __future__ import annotations

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import SunLight
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.render import render
from core.scene import RenderSettings, Scene
from core.volumes import Media, field as field_

COLOR = np.array([0.2, 0.5, 0.8])


def camera_above(height: float = 3.0) -> Camera:
    """An orthographic camera `height` above the origin, looking straight down."""
    matrix = np.eye(4)
    matrix[2, 3] = height
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=20.0)


def height(scale: float = 1.0, offset: float = 0.0) -> Link:
    """A graph: scale x (the point's object z) + offset (Texture Coordinate > Object > Z, Multiply Add)."""
    coords = GraphNode("TEXCOORD")
    z = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Object")}), "Z")
    return Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": z, "1": scale, "2": offset}), "Value")


def slab(closure: str = "ABSORPTION", **inputs) -> Material:
    """A volume-only material of one closure."""
    return Material(np.zeros(3), "Slab", nodes=[("TRANSPARENT", np.ones(3), {})], volume=[(closure, 1.0, inputs)],
                    volume_only=True)


def scene_with(material: Material, emission=(1.0, 2.0, 0.5), low: float = 0.5, high: float = 1.5) -> Scene:
    """An emitting floor at z = 0 under a volume-only box from z = low to z = high holding `material`'s medium."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.asarray(emission, np.float64)))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(material)
    scene.add_mesh(primitives.box((4.0, 4.0, high - low), center=(0.0, 0.0, 0.5 * (low + high))),
                   materials=np.array([1]))
    return scene


def image(scene: Scene, **settings) -> np.ndarray:
    """The scene rendered at 4 x 4 (RGB (4, 4, 3)) by the path tracer."""
    settings = {"width": 4, "height": 4, "samples": 2, "integrator": "path", **settings}
    return render(scene, RenderSettings(**settings)).image[..., :3]


def test_a_slab_whose_density_grows_linearly_keeps_exp_of_minus_its_integral():
    """Density 2 z + 0.5 from z = 0.5 to 1.5 (its integral 2.5): each channel keeps exp(-2.5 (1 - colour)) of the
    floor's light (the march's midpoints integrate a linear density exactly)."""
    scene = scene_with(slab(color=COLOR, density=height(2.0, 0.5)))
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-2.5 * (1.0 - COLOR))
    result = render(scene, RenderSettings(width=4, height=4, samples=2, integrator="path"))
    np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)
    # (nothing to say: its transmittance is unbiased, ratio tracking)
    assert not any("'Slab'" in w for w in result.stats.warnings), result.stats.warnings


def test_a_sun_through_a_linear_slab_at_an_angle_keeps_exp_of_the_integral_along_its_slanted_path():
    """A white floor lit by a sun 60 degrees up through density 2 z + 0.5 (integral 2.5 vertically): the camera sees
    albedo / pi x E exp(-2.5 (1 - colour) (1 + 1 / sin 60))."""
    scene = scene_with(slab(color=COLOR, density=height(2.0, 0.5)))
    scene.materials[0] = Material(np.full(3, 0.8), "Floor")
    elevation = np.radians(60.0)
    direction = np.array([np.cos(elevation), 0.0, np.sin(elevation)])
    scene.lights.append(SunLight(direction=-direction, strength=3.0))
    sigma = 2.5 * (1.0 - COLOR)
    expected = 0.8 / np.pi * 3.0 * np.sin(elevation) * np.exp(-sigma * (1.0 + 1.0 / np.sin(elevation)))
    np.testing.assert_allclose(image(scene), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_a_constant_graph_renders_the_homogeneous_medium():
    """A Scatter whose density is a graph of constant value 1.3 renders as the homogeneous Scatter of density 1.3
    under a sun (single scattering), within the noise of 64 samples."""
    sun = SunLight(direction=-np.array([0.3, 0.0, 1.0]) / np.linalg.norm([0.3, 0.0, 1.0]), strength=2.0)
    images = []
    for density in (height(0.0, 1.3), 1.3):
        scene = scene_with(slab("SCATTER", color=COLOR, density=density, anisotropy=0.3), emission=(0.0, 0.0, 0.0))
        scene.lights.append(sun)
        images.append(image(scene, samples=64))
    mean = [im.reshape(-1, 3).mean(axis=0) for im in images]
    np.testing.assert_allclose(mean[0], mean[1], rtol=0.03)


def test_an_emitting_slab_of_linear_emission_sends_its_integral():
    """An Emission volume of strength 2 z + 0.5 between z = 0.5 and 1.5 over a black floor: emission x 2.5 (its
    control variate, linear on each piece, is exact: no noise); nothing to say (no part of it is marched)."""
    scene = scene_with(slab("EMISSION", color=np.array([1.0, 0.5, 0.25]), strength=height(2.0, 0.5)),
                       emission=(0.0, 0.0, 0.0))
    expected = np.array([1.0, 0.5, 0.25]) * 2.5
    result = render(scene, RenderSettings(width=4, height=4, samples=2, integrator="path"))
    np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)
    assert not any("'Slab'" in w for w in result.stats.warnings), result.stats.warnings


def test_a_mix_shaders_linked_factor_weighs_its_closures_point_by_point():
    """Two absorptions under a Mix Shader whose factor is the point's height - 0.5 (0 to 1 across the slab from
    z = 0.5 to 1.5): density 2 of colour COLOR weighed by the factor, density 4 of grey 0.5 by 1 - factor; each
    integrates to half its density across the slab: exp(-(2 (1 - colour) + 4 x 0.5) x 0.5) per channel."""
    factor = height(1.0, -0.5)
    entries = [("ABSORPTION", 1.0, {"color": COLOR, "density": 2.0, "factors": [(factor, "fac")]}),
               ("ABSORPTION", 1.0, {"color": np.full(3, 0.5), "density": 4.0, "factors": [(factor, "one_minus")]})]
    material = Material(np.zeros(3), "Mixed", nodes=[("TRANSPARENT", np.ones(3), {})], volume=entries,
                        volume_only=True)
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-(2.0 * (1.0 - COLOR) + 4.0 * 0.5) * 0.5)
    np.testing.assert_allclose(image(scene_with(material)), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_the_marchs_free_flight_and_collisions_draw_distances_by_their_densities():
    """On a ray up through a slab of density 2 z + 0.5 (z from 0.5 to 1.5, scattering): free flight truncated at the
    ray's end draws distances whose histogram is its pdf's integral per bin (within 4 standard deviations), and
    untruncated collisions pass the slab as often as exp(-optical depth 2.5) says (no piece is a hole: no uniform
    share, field.March.uniform_share)."""
    from core.volumes.field import Field, March
    field = Field([("SCATTER", 1.0, {"color": np.ones(3), "density": height(2.0, 0.5)})],
                  bounds=(np.array([-1.0, -1.0, 0.5]), np.array([1.0, 1.0, 1.5])))
    n = 10000
    O, D = np.zeros((n, 3)), np.tile([0.0, 0.0, 1.0], (n, 1))
    zero = np.zeros((n, 3))
    march = March([field], np.ones((n, 1)), (zero, zero, zero, np.zeros(n)), O, D, np.full(n, 2.0))
    odds = np.tile([1.0, 0.0, 0.0], (n, 1))
    rng = np.random.default_rng(7)
    u = rng.random((n, 2))
    s, pdf = march.free_flight(odds, u)
    bins = np.linspace(0.5, 1.5, 11)
    counts, _ = np.histogram(s, bins)
    grid = np.linspace(0.5, 1.5, 2001)
    mids = 0.5 * (grid[1:] + grid[:-1])
    small = March([field], np.ones((len(mids), 1)), (np.zeros((len(mids), 3)),) * 3 + (np.zeros(len(mids)),),
                  np.zeros((len(mids), 3)), np.tile([0.0, 0.0, 1.0], (len(mids), 1)), np.full(len(mids), 2.0))
    f = small.pdf(np.tile([1.0, 0.0, 0.0], (len(mids), 1)), mids) * np.diff(grid)
    expected = np.array([f[(mids >= a) & (mids < b)].sum() for a, b in zip(bins[:-1], bins[1:])])
    np.testing.assert_allclose(counts / n, expected, atol=4.0 * np.sqrt(0.25 / n))
    s, pdf, passed, p_pass = march.collision(odds, u)
    assert (march.uniform_share()[0] == 0.0).all()
    np.testing.assert_allclose(passed.mean(), np.exp(-2.5), atol=4.0 * np.sqrt(np.exp(-2.5) / n))
    np.testing.assert_allclose(p_pass[0], np.exp(-2.5), rtol=1e-6)


def test_an_image_texture_sets_the_density_texel_by_texel():
    """Density read from a 2 x 1 grey image (texels 1 and 3, Closest, repeated) at the points' object x: pixel
    columns alternate between exp(-(1 - colour)) and exp(-3 (1 - colour)) through the slab 1 deep."""
    from core.materials.textures import Image
    picture = Image(np.array([[[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]]], np.float32))
    coords = GraphNode("TEXCOORD")
    texel = Link(GraphNode("IMAGE", {"image": picture, "interpolation": "Closest", "extension": "REPEAT"},
                           {"Vector": Link(coords, "Object")}), "Color")
    scene = scene_with(slab(color=COLOR, density=texel))
    columns = np.exp(-np.array([1.0, 3.0, 1.0, 3.0])[:, None] * (1.0 - COLOR))
    expected = np.array([1.0, 2.0, 0.5]) * np.broadcast_to(columns, (4, 4, 3))
    np.testing.assert_allclose(image(scene), expected, rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_both_kernels_march_a_linear_slab_to_exp_of_minus_its_integral_on_camera_and_shadow_rays(kernels):
    """The slanted sun through density 2 z + 0.5 (as above) in the Python reference and in the compiled kernel
    (core/volumes/field.c, which renders it: no fallback): each keeps the closed form's exp(-integral)."""
    scene = scene_with(slab(color=COLOR, density=height(2.0, 0.5)))
    scene.materials[0] = Material(np.full(3, 0.8), "Floor")
    elevation = np.radians(60.0)
    direction = np.array([np.cos(elevation), 0.0, np.sin(elevation)])
    scene.lights.append(SunLight(direction=-direction, strength=3.0))
    result = render(scene, RenderSettings(width=4, height=4, samples=2, integrator="path", kernels=kernels))
    assert (result.stats.kernels == "compiled") == (kernels == "compiled")
    sigma = 2.5 * (1.0 - COLOR)
    expected = 0.8 / np.pi * 3.0 * np.sin(elevation) * np.exp(-sigma * (1.0 + 1.0 / np.sin(elevation)))
    np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def cells(scale: float = 3.0, frequency: float = 9.3) -> Link:
    """A graph: `scale` where fract(frequency x the point's object z) < 0.5, else 0: cells of density about as thick
    as the march's pieces, so that its midpoints miss their edges (Math > Fract, Less Than, Multiply)."""
    z = height(frequency, 0.0)
    fract = Link(GraphNode("MATH", {"operation": "FRACT"}, {"0": z}), "Value")
    inside = Link(GraphNode("MATH", {"operation": "LESS_THAN"}, {"0": fract, "1": 0.5}), "Value")
    return Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": inside, "1": scale}), "Value")


def cells_depth(low: float, high: float, scale: float = 3.0, frequency: float = 9.3) -> float:
    """The exact integral of `cells` over z in [low, high] (a fine midpoint sum: exact to 1e-7 here)."""
    z = low + (np.arange(2_000_000) + 0.5) * (high - low) / 2_000_000
    return float(np.mean(np.where(np.mod(frequency * z, 1.0) < 0.5, scale, 0.0)) * (high - low))


def marched_depth(low: float = 0.5, high: float = 1.5, box=(4.0, 4.0, 1.0)) -> float:
    """What the midpoint march (field.March: pieces of 1/STEPS_ACROSS of the box's diagonal) makes of `cells` along
    a vertical ray through the slab."""
    step = float(np.linalg.norm(box)) / field_.STEPS_ACROSS
    pieces = int(np.ceil((high - low) / step))
    mid = low + (np.arange(pieces) + 0.5) * (high - low) / pieces
    return float(np.sum(np.where(np.mod(9.3 * mid, 1.0) < 0.5, 3.0, 0.0)) * (high - low) / pieces)


def agrees(values: np.ndarray, expected: np.ndarray, sigmas: float = 4.0) -> bool:
    """Whether the per-pixel values (k, 3) average to expected (3,) within `sigmas` standard errors per channel."""
    error = sigmas * values.std(axis=0) / np.sqrt(len(values)) + 1e-6 * np.abs(expected)
    return bool((np.abs(values.mean(axis=0) - expected) <= error).all())


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_slab_of_density_cells_lets_through_exp_of_its_integral_where_the_march_lets_less(kernels):
    """Cells of density 3 and 0 (about a march piece thick) between z = 0.5 and 1.5 over a glowing floor (camera
    rays) and over a white floor a sun lights at 60 degrees (shadow rays): both kernels average to the exact
    exp(-integral) (ratio tracking, core/volumes/field.py March.transmittance), where the march's midpoints alone
    let 4.7 % less through."""
    tau = cells_depth(0.5, 1.5)
    assert abs(np.exp(-marched_depth()) / np.exp(-tau) - 1.0) > 0.04           # (the march alone: biased)
    settings = dict(width=8, height=8, samples=16, integrator="path", kernels=kernels)
    result = render(scene_with(slab(color=COLOR, density=cells())), RenderSettings(**settings))
    assert (result.stats.kernels == "compiled") == (kernels == "compiled")
    values = result.image[..., :3].reshape(-1, 3).astype(np.float64)
    assert agrees(values, np.array([1.0, 2.0, 0.5]) * np.exp(-tau * (1.0 - COLOR)))
    # Shadow rays: the sun's slanted path crosses the same cells, tau / sin 60 of them.
    scene = scene_with(slab(color=COLOR, density=cells()))
    scene.materials[0] = Material(np.full(3, 0.8), "Floor")
    elevation = np.radians(60.0)
    scene.lights.append(SunLight(direction=-np.array([np.cos(elevation), 0.0, np.sin(elevation)]), strength=3.0))
    values = render(scene, RenderSettings(**settings)).image[..., :3].reshape(-1, 3).astype(np.float64)
    expected = 0.8 / np.pi * 3.0 * np.sin(elevation) * np.exp(-tau * (1.0 - COLOR) * (1.0 + 1.0 / np.sin(elevation)))
    assert agrees(values, expected)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_single_scattering_of_a_sun_in_density_cells_is_the_exact_integral(kernels):
    """A white Volume Scatter slab of density cells (3 or 0, z = 0.5..1.5) over a black floor, lit by a sun 60
    degrees up, seen from straight above: single scattering L = E / (4 pi) integral of sigma_s(z) exp(-tau(z)
    (1 + 1 / sin 60)) dz (tau(z) the depth above z), which both kernels reach in the mean with the free flight drawn
    on the march and weighed by ratio tracking's T and the density at the point itself (March.true_at)."""
    scene = scene_with(slab("SCATTER", color=np.ones(3), density=cells()), emission=(0.0, 0.0, 0.0))
    elevation = np.radians(60.0)
    scene.lights.append(SunLight(direction=-np.array([np.cos(elevation), 0.0, np.sin(elevation)]), strength=3.0))
    result = render(scene, RenderSettings(width=8, height=8, samples=16, integrator="path", kernels=kernels,
                                          max_bounces=0))
    assert (result.stats.kernels == "compiled") == (kernels == "compiled")
    z = 0.5 + (np.arange(200_000) + 0.5) / 200_000
    density = np.where(np.mod(9.3 * z, 1.0) < 0.5, 3.0, 0.0)
    above = np.cumsum(density[::-1])[::-1] / 200_000 - density / 400_000     # (the depth from z to the top)
    expected = 3.0 / (4.0 * np.pi) * np.mean(density * np.exp(-above * (1.0 + 1.0 / np.sin(elevation))))
    values = result.image[..., :3].reshape(-1, 3).astype(np.float64)
    assert agrees(values, np.full(3, expected)), (values.mean(axis=0), expected)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_glowing_slab_of_density_cells_sends_the_exact_integral_of_its_emission(kernels):
    """Cells of density 3 and 0 (z = 0.5..1.5) that absorb (Volume Absorption, black) and glow (an Emission of the
    same cells as its strength) over a black floor, seen from straight above: L = integral of e(z) exp(-tau(z)) dz
    (tau(z) the depth above z), which both kernels reach in the mean (March.emitted: the pieces' sum, a control
    variate linear on each piece, corrected at one point by the true emission and ratio tracking's T), where the
    pieces' midpoints alone are 1.4 % off."""
    material = Material(np.zeros(3), "Slab", nodes=[("TRANSPARENT", np.ones(3), {})], volume_only=True,
                        volume=[("ABSORPTION", 1.0, {"color": np.zeros(3), "density": cells()}),
                                ("EMISSION", 1.0, {"color": np.ones(3), "strength": cells()})])
    result = render(scene_with(material, emission=(0.0, 0.0, 0.0)),
                    RenderSettings(width=8, height=8, samples=16, integrator="path", kernels=kernels))
    assert (result.stats.kernels == "compiled") == (kernels == "compiled")
    z = 0.5 + (np.arange(200_000) + 0.5) / 200_000
    density = np.where(np.mod(9.3 * z, 1.0) < 0.5, 3.0, 0.0)
    above = np.cumsum(density[::-1])[::-1] / 200_000 - density / 400_000
    expected = np.mean(density * np.exp(-above))
    pieces = int(np.ceil(1.0 / (np.linalg.norm((4.0, 4.0, 1.0)) / field_.STEPS_ACROSS)))
    mid = 0.5 + (np.arange(pieces) + 0.5) / pieces
    d = np.where(np.mod(9.3 * mid, 1.0) < 0.5, 3.0, 0.0)
    marched = np.sum(np.where(d > 0.0, -np.expm1(-d / pieces), 0.0) * np.exp(-(np.cumsum(d[::-1])[::-1] - d) / pieces))
    assert abs(marched / expected - 1.0) > 0.01
    values = result.image[..., :3].reshape(-1, 3).astype(np.float64)
    assert agrees(values, np.full(3, expected)), (values.mean(axis=0), expected, marched)

