"""Emissive meshes and the world as lights (core/lights/emitters.py, world.py) against closed forms.

Direct light only, as Cycles with max_bounces = 0: a Lambert surface of albedo rho shows rho / pi E,
where E is the irradiance the emitter or the world gives it. Every strategy (light samples alone,
BSDF-sampled rays alone, both weighed by MIS) must converge to the same closed form: the MIS weights
of the two strategies sum to one for every direction.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.camera import Camera
from core.camera import camera as camera_
from core.geometry import primitives
from core.lights import MeshEmitters, World, WorldLight
from core.lights.base import compiled_sample
from core.lights.emitters import solid_angle, spherical_triangle_sample
from core.lights.world import uv_to_direction
from core.scene import Material, Mesh, RenderSettings, Scene


def rectangle_factor(x: float, y: float) -> float:
    """View factor from a point to a parallel rectangle of sides x h, y h whose corner is straight above it."""
    a, b = math.sqrt(1 + x * x), math.sqrt(1 + y * y)
    return (x / a * math.atan(y / a) + y / b * math.atan(x / b)) / (2.0 * math.pi)


def emitter_over_floor(side: float, height: float, radiance: float, albedo: float) -> Scene:
    """A floor of albedo `albedo` and a square emitter of radiance L, side `side`, `height` above, facing down."""
    scene = Scene(camera=ortho_down(center=(0.0, 0.0, 0.0), height=0.5 * height, scale=0.02))
    floor = scene.add_material((albedo,) * 3)
    scene.materials.append(Material(np.zeros(3), "Lamp", emission=np.full(3, radiance)))
    lamp = len(scene.materials) - 1
    scene.add_mesh(primitives.plane(40.0), materials=np.array([floor]))
    flipped = np.diag([1.0, -1.0, -1.0, 1.0])                       # the plane turned to face -Z
    flipped[2, 3] = height
    scene.add_mesh(primitives.plane(side), matrix=flipped, materials=np.array([lamp]))
    return scene


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("strategy", ["mis", "light", "bsdf"])
def test_square_emitter_lights_a_floor_by_its_form_factor(strategy, kernels):
    """Under the centre of a square emitter of radiance L (side s, height h) a Lambert floor of albedo rho
    shows rho L F, F = 4 F_corner(s / 2h, s / 2h): the camera sees a tiny patch straight below it."""
    side, height, L, rho = 1.0, 0.7, 3.0, 0.6
    scene = emitter_over_floor(side, height, L, rho)
    size = 8 if strategy == "bsdf" else 2          # (BSDF rays alone are the noisiest: more samples)
    settings = RenderSettings(width=size, height=size, samples=512, light_samples=4, light_sampling=strategy,
                              kernels=kernels, adaptive=False)
    image = render.render(scene, settings).image
    expected = rho * L * 4.0 * rectangle_factor(side / (2 * height), side / (2 * height))
    assert image[..., :3].mean() == pytest.approx(expected, rel=0.01)


def projected_solid_angle(points: np.ndarray, normal: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Lambert's closed form: the cosine-weighted solid angle (irradiance over radiance) of a planar polygon
    (k, 3) seen from points (n, 3) with unit normal (3,), the polygon wholly above their horizon: (n,) float64."""
    v = polygon[None] - points[:, None]
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    total = np.zeros(len(points))
    for i in range(len(polygon)):
        a, b = v[:, i], v[:, (i + 1) % len(polygon)]
        c = np.cross(a, b)
        c /= np.linalg.norm(c, axis=-1, keepdims=True)
        total += np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0)) * (c @ normal)
    return np.abs(0.5 * total)


def look_at(eye, target) -> np.ndarray:
    """A camera's matrix_world (4, 4) at `eye` looking at `target`, its image's x axis horizontal."""
    eye, target = np.asarray(eye, np.float64), np.asarray(target, np.float64)
    Z = (eye - target) / np.linalg.norm(eye - target)
    X = np.cross([0.0, 0.0, 1.0], Z)
    X /= np.linalg.norm(X)
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1], matrix[:3, 2], matrix[:3, 3] = X, np.cross(Z, X), Z, eye
    return matrix


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_a_wall_just_below_a_ceiling_lamp_gets_the_lamps_form_factor(kernels):
    """The Cornell box's corner (its own numbers, in its units): a wall meets the ceiling 1 above a quad lamp that
    hangs 213 to 343 from the wall. A wall point h below the lamp's plane sees the lamp nearly edge-on, and a
    Lambert wall of albedo rho shows rho / pi L times Lambert's projected solid angle of the quad, to 0.5 %,
    for h from 0.3 to 14. (The shadow rays towards it graze the lamp's plane at h / 300 radians; with the
    camera 800 away, Embree's float32 hit on that plane fell short of the ray's end and the lamp shadowed itself:
    the pixels 1 to 10 below its plane lost 5 to 55 % of their light, the cornell_box scene's dark line.)"""
    wall_x, ceiling, lamp_z, L, rho = -556.0, 548.8, 547.8, 100.0, 0.5
    lamp = np.array([[-343.0, 227.0, lamp_z], [-213.0, 227.0, lamp_z], [-213.0, 332.0, lamp_z],
                     [-343.0, 332.0, lamp_z]])
    camera = Camera(matrix_world=look_at((-278.0, -800.0, 273.0), (wall_x, 250.0, lamp_z - 6.0)), lens=3000.0,
                    sensor_width=32.0, clip_start=1.0, clip_end=3000.0)
    scene = Scene(camera=camera)
    wall = scene.add_material((rho,) * 3)
    scene.materials.append(Material(np.zeros(3), "Lamp", emission=np.full(3, L)))
    quads = (np.array([[wall_x, 0.0, 0.0], [wall_x, 559.2, 0.0], [wall_x, 559.2, ceiling], [wall_x, 0.0, ceiling]]),
             np.array([[wall_x, 0.0, ceiling], [wall_x, 559.2, ceiling], [0.0, 559.2, ceiling], [0.0, 0.0, ceiling]]),
             lamp)
    for corners, material in zip(quads, (wall, wall, len(scene.materials) - 1)):
        scene.add_mesh(Mesh(corners, np.array([[0, 1, 2], [0, 2, 3]])), materials=np.array([material]))
    size, fine = 8, 16
    settings = RenderSettings(width=size, height=size, samples=64, light_sampling="light", kernels=kernels,
                              adaptive=False)
    image = render.render(scene, settings).image[..., 0]
    # The closed form over each pixel (a box filter): fine x fine rays to the wall's plane.
    ys, xs = np.mgrid[0:size * fine, 0:size * fine]
    rays = camera_.generate_rays(camera, size, size, (xs.ravel() + 0.5) / fine, (ys.ravel() + 0.5) / fine)
    points = rays.origins + ((wall_x - rays.origins[:, 0]) / rays.directions[:, 0])[:, None] * rays.directions
    exact = rho / math.pi * L * projected_solid_angle(points, np.array([1.0, 0.0, 0.0]), lamp)
    exact = exact.reshape(size, fine, size, fine).mean(axis=(1, 3))
    below = (lamp_z - points[:, 2]).reshape(size, fine, size, fine).min(axis=(1, 3))
    on_wall = below > 0.3                         # (every ray of the pixel meets the wall below the lamp's plane)
    assert on_wall.sum() >= 40 and below[on_wall].min() < 1.0 and below.max() > 14.0
    np.testing.assert_allclose(image[on_wall], exact[on_wall], rtol=5e-3)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_a_white_world_lights_a_lambert_plane_with_its_albedo(kernels):
    """A world of uniform radiance L over an infinite Lambert plane of albedo rho: E = pi L, so the plane
    shows rho L exactly (every cosine-weighted BSDF ray escapes; no noise)."""
    scene = Scene(camera=ortho_down(height=1.0, scale=2.0), world=World(color=np.array([0.5, 1.0, 2.0])))
    scene.add_material((0.25, 0.5, 0.75))
    scene.add_mesh(primitives.plane(1e4), materials=np.array([0]))
    image = render.render(scene, RenderSettings(width=4, height=4, samples=4, kernels=kernels)).image
    np.testing.assert_allclose(image[..., :3], np.broadcast_to([0.125, 0.5, 1.5], (4, 4, 3)), rtol=1e-6)


def environment(width: int = 64) -> np.ndarray:
    """An equirectangular image: dim blue sky, a bright patch, dark ground: (w/2, w, 3) float32, row 0 at the bottom."""
    h = width // 2
    image = np.zeros((h, width, 3), np.float32)
    image[h // 2:] = (0.2, 0.3, 0.6)                     # the upper half: sky
    image[int(0.8 * h):int(0.9 * h), width // 8:width // 4] = (40.0, 35.0, 30.0)   # a sun-like patch
    image[:h // 2] = (0.05, 0.04, 0.03)                  # the lower half: ground
    return image


def test_world_map_pdf_integrates_to_one_and_sampling_follows_it():
    """The importance map's pdf over the sphere integrates to 1, and sampled directions are distributed by it."""
    sampler = WorldLight.of(World(image=environment(), strength=1.0))
    n = 400_000
    rng = np.random.default_rng(3)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert np.mean(sampler.pdf(d) * 4.0 * math.pi) == pytest.approx(1.0, rel=0.01)
    sample = sampler.sample(np.zeros((50_000, 3)), rng.random((50_000, 2)))
    np.testing.assert_allclose(sample.pdf, sampler.pdf(sample.L), rtol=1e-6)
    bright = sample.L[:, 2] > 0.8                          # the patch's band of elevation
    expected = np.mean(sampler.pdf(d) * (d[:, 2] > 0.8)) * 4.0 * math.pi
    assert bright.mean() == pytest.approx(expected, rel=0.02)


def test_compensated_world_map_samples_only_where_the_world_outshines_its_mean():
    """MIS compensation (world.compensated_map): the map less its solid-angle mean radiance is a pdf over the
    sphere (it integrates to 1), 0 wherever the world is at or below its mean, and > 0 wherever it is brighter; a
    world as bright everywhere has nothing left to sample."""
    world = World(image=environment(), strength=1.0)
    sampler = WorldLight.of(world, compensate=True)
    # Quadrature over the sphere: a grid of (u, v) at the map's cells' centres (1024 x 512), dw = 2 pi^2 sin du dv.
    u, v = np.meshgrid((np.arange(1024) + 0.5) / 1024, (np.arange(512) + 0.5) / 512)
    d = uv_to_direction(u.ravel(), v.ravel())
    dw = 2.0 * math.pi ** 2 * np.sin(math.pi * v.ravel()) / (1024 * 512)
    pdf = sampler.pdf(d)
    assert np.sum(pdf * dw) == pytest.approx(1.0, rel=1e-6)
    L = world.radiance(d).mean(axis=1)
    mean = np.sum(L * dw) / (4.0 * math.pi)
    clear = np.abs(L - mean) > 0.05 * mean             # (away from the cells that straddle the mean)
    assert np.all((pdf[clear] > 0.0) == (L[clear] > mean))
    sample = sampler.sample(np.zeros((20_000, 3)), np.random.default_rng(5).random((20_000, 2)))
    assert np.all(world.radiance(sample.L).mean(axis=1) > 0.5 * mean)
    flat = np.full((16, 32, 3), 0.7, np.float32)
    assert WorldLight.of(World(image=flat), compensate=True) is None


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_compensated_world_map_is_the_map_less_its_mean_made_in_the_maps_own_arrays(kernels):
    """The compensated map (world.compensated_map) is max(f - (pi / 2) mean(f) sin(theta), 0) of the map f, with each
    row's running sums and total, bit for bit as made anew; it is made in f's and f's sums' place, so making it holds
    two map-sized arrays at its peak (numpy's allocations, tracemalloc) and not the five of a new map and sums beside
    the old ones (a 4096 x 2048 map is 64 MiB an array)."""
    import tracemalloc
    from core.lights import world as world_
    world = World(image=environment(), strength=1.0)
    w, h = 1024, 512
    pixels = np.abs(world.image[..., :3].astype(np.float64))
    sines = np.sin(math.pi * ((np.arange(h) + 0.5) / h))
    f, columns, _ = world_.reference_map((pixels[..., 0] + pixels[..., 1] + pixels[..., 2]) * (1.0 / 3.0), sines, w, h)
    expected = np.maximum(f - 0.5 * math.pi * float(f.mean()) * sines[:, None], 0.0)
    made, made_columns, made_totals = world_.compensated_map(f.copy(), sines, columns.copy())
    np.testing.assert_array_equal(made, expected)
    np.testing.assert_array_equal(made_columns, world_.running_sums(expected)[0])
    np.testing.assert_array_equal(made_totals, world_.running_sums(expected)[1])
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        sampler = WorldLight.of(world, width=w, kernels=kernels, compensate=True)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(sampler.map, expected)
    image = world.image.shape[0] * world.image.shape[1] * 8 * 4          # the image's float64 channels and their mean
    assert peak < 2 * expected.nbytes + image + (1 << 20)


def glossy_plane_under_the_environment() -> Scene:
    """A rough metal plane (Glossy BSDF, roughness 0.3) under environment(), seen straight down."""
    scene = Scene(camera=ortho_down(height=1.0, scale=0.5), world=World(image=environment(), strength=1.0))
    scene.materials.append(Material(name="metal", nodes=[("GLOSSY", (0.9, 0.8, 0.7), {"roughness": 0.3})]))
    scene.add_mesh(primitives.plane(1e5), materials=np.array([0]))
    return scene


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_mis_compensation_keeps_a_glossy_planes_light_and_lowers_its_noise(kernels, monkeypatch):
    """A glossy plane under an environment: the light its pixels get is the same whether the world's light samples
    go by the plain map or by the compensated one (each estimator is unbiased, so they differ by noise alone: within
    4 standard errors over 8 seeds; measured at 256 samples x 16 seeds: 0.67582 and 0.67572, 1.3 standard errors), and the compensated map's pixels are less noisy."""
    scene = glossy_plane_under_the_environment()

    def pixels(compensate: bool) -> np.ndarray:
        monkeypatch.setattr(render, "compensates_world", lambda settings, world: compensate)
        return np.array([render.render(scene, RenderSettings(width=8, height=8, samples=4 if kernels == "numpy" else 16,
                                                             kernels=kernels, adaptive=False, seed=seed)).image[..., :3]
                         for seed in range(8)])

    plain, compensated = pixels(False), pixels(True)
    # (the standard error from the seeds' image means: a seed's pixels share its sample pattern's structure)
    means = plain.mean(axis=(1, 2, 3)), compensated.mean(axis=(1, 2, 3))
    error = np.sqrt((means[0].var(ddof=1) + means[1].var(ddof=1)) / 8)
    assert abs(means[0].mean() - means[1].mean()) < 4.0 * error
    assert compensated.var(axis=0).mean() < 0.9 * plain.var(axis=0).mean()


@pytest.mark.parametrize("size", [(64, 32), (1024, 512), (100, 37)])
def test_world_map_made_row_by_row_is_the_radiance_at_each_cells_centre(size):
    """The importance map's values, interpolated along rows then columns (bilinear_grid), are the same numbers as
    bilinear_equirect gives point by point at the cell centres, with a map finer, as fine as and coarser than the
    image, NaN and infinite texels included."""
    from core.lights.world import bilinear_equirect, bilinear_grid
    image = environment(96) * np.random.default_rng(5).random((48, 96, 1)).astype(np.float32)
    image[3, 7] = (np.nan, np.inf, -np.inf)
    w, h = size
    uu, vv = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    expected = bilinear_equirect(image, uu.ravel(), vv.ravel()).reshape(h, w, 3)
    for c in range(3):
        np.testing.assert_array_equal(bilinear_grid(image[..., c].astype(np.float64), w, h), expected[..., c])


@pytest.mark.parametrize("size", [(64, 32), (1024, 512), (100, 37)])
def test_world_map_in_c_is_the_reference_maps_numbers(size):
    """The importance map made in C (world.c world_map_rows, in bands of rows) is the numpy reference's, bit for bit:
    values, each row's normalised running sums and its total, a zero row included."""
    from core.lights.world import compiled_map, reference_map
    values = np.random.default_rng(7).random((48, 96)) * (np.arange(96) % 5 == 0)
    values[20:30] = 0.0
    w, h = size
    sines = np.sin(np.pi * ((np.arange(h) + 0.5) / h))
    for made, expected in zip(compiled_map(values, sines, w, h), reference_map(values, sines, w, h)):
        np.testing.assert_array_equal(made, expected)


@pytest.mark.parametrize("size", [(64, 32), (1024, 512), (100, 37)])
def test_compensated_world_map_in_c_is_the_reference_maps_numbers(size):
    """The map less its mean made in C (world.c compensated_rows, in bands of rows, after world_map_rows) is the numpy
    reference's compensated_map, bit for bit: values floored at 0, each row's normalised running sums and its total,
    rows left all 0 included."""
    from core.lights.world import compensated_map, compiled_map, reference_map
    values = np.random.default_rng(7).random((48, 96)) * (np.arange(96) % 5 == 0)
    values[20:30] = 0.0
    w, h = size
    sines = np.sin(np.pi * ((np.arange(h) + 0.5) / h))
    expected = compensated_map(reference_map(values, sines, w, h)[0], sines)
    assert (expected[2] == 0.0).any() and (expected[2] > 0.0).any()
    for made, wanted in zip(compiled_map(values, sines, w, h, compensate=True), expected):
        np.testing.assert_array_equal(made, wanted)


@pytest.mark.parametrize("sampling, resolution, environments, suns, guided, size", [
    ("AUTOMATIC", 1024, [(1024, 512)], 0, True, (4096, 2048)),      # an HDRI of 1k: Cycles maps it at 4k
    ("AUTOMATIC", 1024, [(8192, 4096)], 0, True, (8192, 4096)),
    ("AUTOMATIC", 1024, [], 1, True, (512, 256)),                    # one Sky Texture's sun: sun guiding
    ("AUTOMATIC", 1024, [(1024, 512)], 1, True, (1024, 512)),
    ("AUTOMATIC", 1024, [], 1, False, (4096, 2048)),                 # its Vector mapped: no guiding
    ("AUTOMATIC", 1024, [], 2, True, (4096, 2048)),
    ("MANUAL", 300, [(8192, 4096)], 0, True, (300, 150)),
    ("NONE", 1024, [(1024, 512)], 0, True, (0, 0)),
])
def test_world_map_size_follows_cycles_world_sampling(sampling, resolution, environments, suns, guided, size):
    """The importance map's size is Cycles' World MIS resolution for each world Sampling setting (checked against
    Cycles 5.0: its Automatic render of a 1k HDRI is bit for bit its Manual 4096 one); None makes no light of it."""
    from core.lights.world import map_size
    assert map_size(sampling, resolution, environments, suns, guided) == size
    sampler = WorldLight.of(World(image=environment(16), map_size=(size[0] // 64, size[1] // 64)))
    assert (sampler is None) == (size == (0, 0))
    if sampler is not None:
        assert sampler.map.shape == (size[1] // 64, size[0] // 64)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("strategy", ["mis", "light", "bsdf"])
def test_an_environment_lights_a_plane_by_its_cosine_weighted_mean(strategy, kernels):
    """A Lambert plane of albedo rho under an environment L(w) shows rho / pi * integral of L cos over the
    upper hemisphere: computed here by quadrature of the image, and reached by every strategy."""
    image = environment()
    world = World(image=image, strength=1.0)
    scene = Scene(camera=ortho_down(height=1.0, scale=0.01), world=world)
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(1e5), materials=np.array([0]))
    settings = RenderSettings(width=2, height=2, samples=1024, light_samples=4, light_sampling=strategy,
                              kernels=kernels, adaptive=False)
    result = render.render(scene, settings).image[..., :3].mean(axis=(0, 1))
    # Quadrature: a grid of directions over the upper hemisphere (500 x 1000: the same E to 5 digits as 2000 x 4000).
    k = 500
    theta = (np.arange(k) + 0.5) / k * (math.pi / 2)
    phi = (np.arange(2 * k) + 0.5) / (2 * k) * (2 * math.pi)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    weight = (np.cos(T) * np.sin(T)).reshape(-1) * (math.pi / 2 / k) * (2 * math.pi / (2 * k))
    E = (world.radiance(d) * weight[:, None]).sum(axis=0)
    np.testing.assert_allclose(result, 0.5 / math.pi * E, rtol=0.02)


def test_spherical_triangle_sampling_is_uniform_over_the_solid_angle():
    """Arvo's map: directions hit the triangle, pdf 1 / Omega, and the mean of 1 / pdf is Omega."""
    rng = np.random.default_rng(5)
    V = np.array([[[0.3, -0.2, 1.0], [1.5, 0.4, 1.2], [-0.4, 1.1, 0.8]]])
    P = np.zeros((1, 3))
    n = 20_000
    L, t, pdf = spherical_triangle_sample(np.repeat(P, n, 0), np.repeat(V, n, 0), rng.random((n, 2)))
    omega = solid_angle(P, V)[0]
    np.testing.assert_allclose(pdf, 1.0 / omega, rtol=1e-12)
    X = L * t[:, None]                                       # on the triangle's plane, inside the triangle
    e1, e2 = V[0, 1] - V[0, 0], V[0, 2] - V[0, 0]
    normal = np.cross(e1, e2)
    np.testing.assert_allclose((X - V[0, 0]) @ normal, 0.0, atol=1e-9)
    # Uniform in solid angle: split the triangle in halves by a median; each gets half the directions
    # in proportion to its solid angle.
    mid = 0.5 * (V[0, 1] + V[0, 2])
    half = np.array([[V[0, 0], V[0, 1], mid]])
    a = np.cross(V[0, 0], V[0, 1]), np.cross(V[0, 1], mid), np.cross(mid, V[0, 0])
    inside_half = (L @ a[0] > 0) & (L @ a[1] > 0) & (L @ a[2] > 0)
    if not inside_half.any():
        inside_half = (L @ -a[0] > 0) & (L @ -a[1] > 0) & (L @ -a[2] > 0)
    assert inside_half.mean() == pytest.approx(solid_angle(P, half)[0] / omega, abs=0.01)


def test_compiled_emitter_and_world_samples_are_the_pythons():
    """emitters.c and world.c sample what their Python classes sample (same directions, pdfs, radiance)."""
    from core.lights.base import LightContext
    import ctypes
    rng = np.random.default_rng(6)
    corners = rng.normal(size=(40, 3, 3)) + [0.0, 0.0, 3.0]
    emission = rng.random((40, 3)) * 5
    emitters = MeshEmitters.of(corners, emission, np.full(40, 3, np.int32), np.arange(40) * 2)
    sampler = WorldLight.of(World(image=environment(), strength=2.0, rotation=np.array(
        [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])))
    from core.lights.world import WorldTables
    tables, world_tables = emitters.tables(), WorldTables(sampler.world, sampler)
    context = LightContext(emitters=tables.record, world=world_tables.record)
    points = rng.normal(size=(3000, 3))
    u = rng.random((3000, 3))
    for light, numbers in ((emitters, u), (sampler, u[:, :2])):
        expected = light.sample(points, numbers)
        found = compiled_sample(light, points, numbers, context)
        np.testing.assert_allclose(found.pdf, expected.pdf, rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(found.L, expected.L, atol=1e-6)
        np.testing.assert_allclose(found.color, np.broadcast_to(expected.color, found.color.shape), rtol=1e-6)
        np.testing.assert_allclose(found.strength, expected.strength, rtol=1e-6)


def half_textured_emitter_over_floor(a: float, b: float, side: float, height: float, albedo: float,
                                     sampling: str = "AUTO") -> Scene:
    """emitter_over_floor's square lamp with its emission from a 2 x 1 image: radiance a where x < 0 (u < 0.5),
    b where x > 0 (Closest interpolation), seen from a camera over the floor below the left half's centre."""
    from test_textures import plane_attributes
    from core.materials import textures
    from core.materials.graph import GraphNode, Link
    image = textures.Image(np.array([[[a, a, a, 1.0], [b, b, b, 1.0]]], np.float32), srgb=False)
    node = GraphNode("IMAGE", {"image": image, "interpolation": "Closest", "extension": "EXTEND"}, {})
    scene = Scene(camera=ortho_down(center=(-0.25 * side, 0.0, 0.0), height=0.5 * height, scale=0.02))
    floor = scene.add_material((albedo,) * 3)
    scene.materials.append(Material(name="Screen", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": Link(node, "Color")})],
                                    emission_sampling=sampling))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([floor]))
    flipped = np.diag([1.0, -1.0, -1.0, 1.0])                       # the plane turned to face -Z
    flipped[2, 3] = height
    lamp = primitives.plane(side)
    lamp.attributes = plane_attributes(lamp)
    scene.add_mesh(lamp, matrix=flipped, materials=np.array([len(scene.materials) - 1]))
    return scene


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("strategy", ["mis", "light", "bsdf"])
def test_a_textured_emitter_lights_a_floor_by_each_texels_form_factor(strategy, kernels):
    """A square emitter whose left half emits a and right half b (an image texture on its Emission colour), seen
    from the floor below the left half's centre: rho (a F_left + b F_right), each half's view factor from corner
    rectangles. Each triangle of the square covers both halves: the texture is read where each sample lands."""
    side, height, a, b, rho = 1.0, 0.7, 4.0, 1.0, 0.6
    scene = half_textured_emitter_over_floor(a, b, side, height, rho)
    size = 8 if strategy == "bsdf" else 2
    settings = RenderSettings(width=size, height=size, samples=512, light_samples=4, light_sampling=strategy,
                              kernels=kernels, adaptive=False)
    image = render.render(scene, settings).image
    q, y = 0.25 * side / height, 0.5 * side / height
    left = 4.0 * rectangle_factor(q, y)
    right = 2.0 * (rectangle_factor(3.0 * q, y) - rectangle_factor(q, y))
    assert image[..., :3].mean() == pytest.approx(rho * (a * left + b * right), rel=0.01)


def turned_about_x(angle: float) -> np.ndarray:
    """The 4 x 4 rotation by `angle` (radians) about +X."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0, 0.0], [0.0, c, -s, 0.0], [0.0, s, c, 0.0], [0.0, 0.0, 0.0, 1.0]])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["direct", "path"])
@pytest.mark.parametrize("tilt", [1e-3, 0.3, math.pi + 1e-3, math.pi + 0.3])
def test_a_glowing_diffuse_sheet_alone_in_the_dark_reflects_none_of_its_own_light(tilt, integrator, kernels):
    """A flat emitter of radiance 1 that also reflects (albedo 0.5), alone in the dark, tilted and seen from the
    front or from behind: each of its points sees the sheet edge-on, so nothing lights it and it shows L_e = 1
    exactly, whatever the bounces. A hit on a tilted sheet lies a rounding error off its plane, from where its own
    triangle fills a hemisphere: Cycles skips a light sample on the triangle it lights, and Primer once lit the
    sheet by its own emission (up to 1.35 here; the OBJ Cornell box's lamp lit its back so, issue 34)."""
    scene = Scene(camera=ortho_down(center=(0.0, 0.0, 0.0), height=1.0, scale=0.8))
    scene.materials.append(Material(np.full(3, 0.5), "Glowing sheet", emission=np.ones(3)))
    scene.add_mesh(primitives.plane(2.0), matrix=turned_about_x(tilt), materials=np.array([0]))
    settings = RenderSettings(width=8, height=8, samples=16, integrator=integrator, max_bounces=3, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(image, 1.0, rtol=1e-9)


def test_a_textured_emitters_estimate_is_the_mean_of_its_texels_at_the_estimate_points_in_both_kernels():
    """The light tree weighs a textured emitter by the mean of what it emits at emitters.ESTIMATE_POINTS: for the
    half-textured square, a where a point lies at x < 0 and b where x > 0. The compiled estimate (the graphs run
    in C, compiled.graph_emission) is the reference's (vertex.graph_emission) to rounding, for an image and for
    a Noise texture's emission."""
    from core.integrators import compiled, vertex
    from core.lights import emitters as emitters_
    from core.materials.graph import GraphNode, Link
    side, a, b = 1.0, 4.0, 1.0
    scene = half_textured_emitter_over_floor(a, b, side, 0.7, 0.6)
    noise = Link(GraphNode("TEX_NOISE", {}, {"Vector": Link(GraphNode("TEXCOORD"), "Object"), "Scale": 3.0}), "Color")
    scene.materials.append(Material(name="Noisy", nodes=[("EMISSION", (2.0, 2.0, 2.0), {"emission": noise})],
                                    emission_sampling="FRONT_BACK"))
    beside = np.diag([1.0, -1.0, -1.0, 1.0])                        # (a second square, 2 along x, facing -Z)
    beside[:3, 3] = (2.0, 0.0, 0.7)
    scene.add_mesh(primitives.plane(side), matrix=beside, materials=np.array([len(scene.materials) - 1]))
    ctx = render.prepare(scene, RenderSettings(width=2, height=2))
    found = ctx.extra["emitters"]
    prim = found.prim[found.textured]
    assert len(prim) == 4
    in_c = emitters_.mean_graph_emission(ctx.geometry, ctx.materials, prim, compiled.graph_emission)
    in_python = emitters_.mean_graph_emission(ctx.geometry, ctx.materials, prim, vertex.graph_emission)
    np.testing.assert_allclose(in_c, in_python, rtol=1e-6, atol=1e-9)
    # The image's square: each point's texel by the side of x = 0 it lies on (the geometry is camera-relative).
    screen = ctx.geometry.material[prim] == 1
    V = ctx.geometry.corner_points(prim[screen]) + ctx.geometry.origin
    u, v = emitters_.ESTIMATE_POINTS[:, 0], emitters_.ESTIMATE_POINTS[:, 1]
    x = (1.0 - u - v) * V[:, 0, None, 0] + u * V[:, 1, None, 0] + v * V[:, 2, None, 0]
    expected = np.where(x < 0.0, a, b).mean(axis=1)
    np.testing.assert_allclose(in_c[screen], expected[:, None] * np.ones(3), rtol=1e-12)
    assert np.ptp(in_c[~screen]) > 0.0        # (the noise varies over the second square)


def test_a_light_sample_running_only_the_ops_its_emission_reads_sees_the_whole_graphs_emission():
    """A light sample wants only a material's emission, so the compiled kernel runs only the ops and shader nodes
    the emission depends on (graph.emission_live): a bumped, noise-textured Principled beside a textured Emission
    drops the bump's three evaluations of its height and the BSDF's colour, while an emitting Principled whose coat
    follows its bumped normal (the coat tints the emission at that normal's angle) keeps its normal's ops. The emission the C kernel
    finds at 64 random points on each material's square is the Python reference's, which runs every op."""
    from core.integrators import compiled, vertex
    from core.lights import emitters as emitters_
    from core.materials import graph as graph_
    from core.materials.graph import GraphNode, Link
    from test_textures import plane_attributes
    where = Link(GraphNode("TEXCOORD"), "UV")

    def noise(scale, detail, distortion=0.0):
        return Link(GraphNode("TEX_NOISE", {}, {"Vector": where, "Scale": scale, "Detail": detail,
                                                "Distortion": distortion}), "Fac")

    height = Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": noise(40.0, 15.5, 0.5), "1": noise(7.0, 3.0)}),
                  "Value")
    bumped = Link(GraphNode("BUMP", {"invert": False}, {"Height": height, "Distance": 0.1}), "Normal")
    glow = Link(GraphNode("TEX_VORONOI", {}, {"Vector": where, "Scale": 5.0}), "Distance")
    table = np.linspace((0.1, 0.0, 0.0, 1.0), (4.0, 2.0, 0.5, 1.0), 256)           # (a ramp from red to yellow)
    ramp = Link(GraphNode("RAMP", {"table": table, "interpolate": True}, {"Fac": glow}), "Color")
    wave = Link(GraphNode("TEX_WAVE", {}, {"Vector": where, "Scale": 3.0}), "Fac")
    lava = Material(name="Lava", emission_sampling="FRONT_BACK", nodes=[
        ("PRINCIPLED", (1.0, 1.0, 1.0), {"base_color": Link(GraphNode("TEX_NOISE", {}, {"Vector": where}), "Color"),
                                         "normal": bumped}, [(wave, "one_minus")]),
        ("EMISSION", (3.0, 3.0, 3.0), {"emission": ramp}, [(wave, "fac")])])
    coated = Material(name="Coated", emission_sampling="FRONT_BACK", nodes=[
        ("PRINCIPLED", (1.0, 1.0, 1.0), {"coat": 0.8, "coat_tint": (0.9, 0.3, 0.2), "coat_follows_normal": 1.0,
                                         "emission": ramp,
                                         "normal": bumped})])
    scene = Scene(camera=ortho_down(center=(0.0, 0.0, 0.0), height=1.0, scale=0.02))
    for k, material in enumerate((lava, coated)):
        scene.materials.append(material)
        square = primitives.plane(1.0)
        square.attributes = plane_attributes(square)
        place = np.diag([1.0, -1.0, -1.0, 1.0])
        place[:3, 3] = (2.0 * k, 0.0, 1.0)
        scene.add_mesh(square, matrix=place, materials=np.array([len(scene.materials) - 1]))
    ctx = render.prepare(scene, RenderSettings(width=2, height=2))
    layout = ctx.geometry.attribute_layout
    live = {}
    for row, name in enumerate(ctx.materials.names):
        program = ctx.materials.program(row, layout)
        if program is not None:
            ops, nodes = graph_.emission_live(program, ctx.materials.shaders[row].nodes)
            names = [graph_.OPS[int(o[0])] for o in program.ops]
            live[name] = (sum(n == "TEX_NOISE" for n, x in zip(names, ops) if x), names.count("TEX_NOISE"), nodes)
    assert live["Lava"][0] == 0 and live["Lava"][1] == 7 and list(live["Lava"][2]) == [False, False, True]
    assert live["Coated"][0] == live["Coated"][1] == 6 and list(live["Coated"][2]) == [True, True]
    prim = np.repeat(np.arange(4), 16)                              # (the squares' triangles)
    assert sorted(set(ctx.materials.names[m] for m in ctx.geometry.material[prim])) == ["Coated", "Lava"]
    rng = np.random.default_rng(34)
    uv = rng.random((len(prim), 2))
    uv = np.where(uv.sum(axis=1, keepdims=True) > 1.0, 1.0 - uv, uv)
    triangle = ctx.geometry.triangle_data(prim, smooth=False)
    V = triangle.corners
    P = (1.0 - uv[:, :1] - uv[:, 1:]) * V[:, 0] + uv[:, :1] * V[:, 1] + uv[:, 1:] * V[:, 2]
    D = rng.normal(size=(len(prim), 3)) * 0.3 - triangle.Ng                   # (towards the front, at angles)
    D /= np.linalg.norm(D, axis=1)[:, None]
    t = rng.uniform(0.5, 3.0, len(prim))
    O = P - t[:, None] * D
    in_c = compiled.graph_emission(ctx.geometry, ctx.materials, prim, O, D, t)
    in_python = vertex.graph_emission(ctx.geometry, ctx.materials, prim, O, D, t)
    assert np.all(np.isfinite(in_c)) and np.ptp(in_c[:32]) > 0.0 and np.ptp(in_c[32:]) > 0.0
    np.testing.assert_allclose(in_c, in_python, rtol=1e-6, atol=1e-9)
