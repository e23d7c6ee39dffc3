"""Compiled kernels: each C kernel computes what its numpy twin computes (core/kernels.py).

The numpy code in core/ is the reference. Every kernel is checked against it on its own (random
inputs, every light and camera type), and whole renders on both paths are compared. The sampling
kernel must agree bit for bit; float64 arithmetic to rounding; images to float32 rounding, with
the same rays traced. Closed forms are checked on both paths by the other test files (which run
compiled by default) and by test_point_light_inverse_square_on_both_paths here.
"""
from __future__ import annotations

import contextlib
import dataclasses
from concurrent.futures import ThreadPoolExecutor
import math

import numpy as np
import pytest

from core.camera import camera as camera_
from core.film import adaptive
from core.geometry import intersect
from core.native import kernels
from core.geometry import primitives
from core import render
from core.sampling import sobol as sampling
from core.integrators import shadows
from core.camera.camera import Camera
from core.geometry.geometry import build_geometry
from core.scene.scene import AreaLight, Instance, PointLight, RenderSettings, Scene, SpotLight, SunLight
from core.integrators.direct import direct_light, surface_at_hits, translate_light


def test_the_library_is_built_for_this_machine():
    """`make kernels` ran: without the library every other test here would measure nothing."""
    assert kernels.available(), kernels.unavailable_reason()


def test_sample_2d_agrees_bit_for_bit(rng):
    n = 20000
    pixel = rng.integers(0, 1 << 40, n)
    index = rng.integers(0, 1 << 31, n)
    for seed, dimension in ((0, 0), (7, 16), (123456789, 20), (2 ** 40 + 3, 44)):
        expected = sampling.sample_2d(seed, pixel, index, dimension)
        assert np.array_equal(kernels.sample_2d(seed, pixel, index, dimension), expected)


CAMERAS = [
    Camera.look_at((1.0, -6.0, 2.5), (0.0, 0.0, 0.5), fov=math.radians(50)),
    dataclasses.replace(Camera.look_at((3.0, 2.0, 1.0), (0.0, 0.0, 0.0)), shift_x=0.3, shift_y=-0.2,
                        sensor_fit="VERTICAL", clip_start=0.5, clip_end=40.0),
    dataclasses.replace(Camera.look_at((0.0, 0.0, 9.0), (0.0, 0.1, 0.0)), type="ORTHO", ortho_scale=4.0,
                        shift_x=-0.1),
]


@pytest.mark.parametrize("camera", CAMERAS, ids=["persp", "persp_shift_vertical", "ortho_shift"])
def test_camera_rays_agree(camera):
    W, H, spp, seed = 37, 23, 5, 11
    pixels = np.arange(0, W * H, 3, dtype=np.int64)
    first = (pixels % 4).astype(np.int64)
    origin = np.array([0.5, -0.25, 2.0])
    record = kernels.camera_record(camera, W, H, (1.0, 1.2), origin)
    O, D, t = kernels.camera_rays(record, seed, W, H, pixels, first, spp)
    # The numpy steps of render._render_chunk.
    pixel = np.repeat(pixels, spp)
    sample = np.tile(np.arange(spp), len(pixels)) + np.repeat(first, spp)
    offset = sampling.sample_2d(seed, pixel, sample, 0)
    rays = camera_.generate_rays(camera, W, H, pixel % W + offset[:, 0], pixel // W + offset[:, 1], (1.0, 1.2))
    assert np.allclose(O, rays.origins - origin, rtol=0, atol=1e-13)
    assert np.allclose(D, rays.directions, rtol=0, atol=1e-15)
    assert np.allclose(t, rays.t_max, rtol=1e-15, atol=0)


def lit_scene(lights: list) -> Scene:
    """A smooth low-poly sphere on a flat floor with a box beside it, seen from above, under `lights`."""
    scene = Scene(camera=Camera.look_at((0.5, -5.0, 3.0), (0.0, 0.0, 0.4), fov=math.radians(45)),
                  world_color=np.array([0.05, 0.06, 0.07]))
    scene.add_material((0.8, 0.7, 0.6))
    scene.add_material((0.3, 0.5, 0.9))
    scene.add_mesh(primitives.plane(8.0), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.8, 12, 6, center=(0.0, 0.0, 0.8), smooth=True), materials=np.array([1]))
    scene.add_mesh(primitives.box((0.6, 0.6, 1.2), center=(1.3, 0.6, 0.6)), materials=np.array([0]))
    scene.lights = lights
    return scene


LIGHTS = {
    "point": [PointLight(np.array([1.0, -1.5, 3.0]), power=400.0, color=np.array([1.0, 0.9, 0.8]))],
    "point_sphere": [PointLight(np.array([-1.0, -1.0, 2.5]), power=300.0, radius=0.4, soft_falloff=False)],
    "point_soft": [PointLight(np.array([-1.0, -1.0, 2.5]), power=300.0, radius=0.4)],
    "spot": [SpotLight(np.array([0.0, -2.0, 3.0]), np.array([0.0, 0.55, -0.835]), power=800.0, radius=0.1,
                       spot_size=math.radians(50), spot_blend=0.3)],
    "spot_scaled": [SpotLight(np.array([0.0, -2.0, 3.0]), np.array([0.0, 0.55, -0.835]), power=800.0,
                              spot_size=math.radians(60), spot_blend=0.0,
                              frame=np.array([[1.0, 0.0, 0.0], [0.0, 0.835, -0.55], [0.0, 0.55, 0.835]])
                              @ np.diag([1.0, 0.5, 1.0]))],
    "sun": [SunLight(np.array([0.3, 0.4, -0.866]), strength=2.0)],
    "sun_disk": [SunLight(np.array([0.3, 0.4, -0.866]), strength=2.0, angle=math.radians(10))],
    "area_rect": [AreaLight(np.array([0.5, -1.0, 2.5]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.6, 0.3]),
                            np.array([0.0, 0.2, -0.98]), power=200.0, shape="RECTANGLE")],
    "area_ellipse_spread": [AreaLight(np.array([0.5, -1.0, 2.5]), np.array([1.0, 0.0, 0.0]),
                                      np.array([0.0, 0.6, 0.3]), np.array([0.0, 0.2, -0.98]), power=200.0,
                                      shape="ELLIPSE", spread=math.radians(60))],
    "several": [PointLight(np.array([1.0, -1.5, 3.0]), power=200.0),
                SunLight(np.array([-0.3, 0.2, -0.93]), strength=1.0, angle=math.radians(3)),
                AreaLight(np.array([-1.0, 1.0, 2.0]), np.array([0.5, 0.0, 0.0]), np.array([0.0, 0.5, 0.0]),
                          np.array([0.0, 0.0, -1.0]), power=100.0, shape="DISK")],
}


def hits_of(scene: Scene, settings: RenderSettings, geometry):
    """Return the camera rays (camera-relative) of a small render and the nearest hits of those that hit."""
    W, H, spp = settings.width, settings.height, settings.samples
    pixels = np.arange(W * H, dtype=np.int64)
    first = np.zeros(len(pixels), np.int64)
    record = kernels.camera_record(scene.camera, W, H, (1.0, 1.0), geometry.origin)
    O, D, t = kernels.camera_rays(record, settings.seed, W, H, pixels, first, spp)
    hits = geometry.tracer.intersect(O, D, t)
    hit = np.flatnonzero(hits.hit)
    return pixels, first, O, D, hits, hit


@pytest.mark.parametrize("terminator_fix", [False, True], ids=["plain", "terminator_fix"])
def test_surfaces_agree(terminator_fix):
    scene = lit_scene(LIGHTS["point"])
    settings = RenderSettings(width=48, height=36, samples=2, terminator_fix=terminator_fix)
    geometry = build_geometry(scene, scene.camera.position)
    _, _, O, D, hits, hit = hits_of(scene, settings, geometry)
    prim = hits.prim[hit]
    triangles = kernels.copied_triangles(kernels.copied_arrays(geometry), prim)
    surface = kernels.surfaces(triangles, hit, O, D, hits.t[hit], hits.u[hit], hits.v[hit], lift=terminator_fix)
    reference = surface_at_hits(geometry, prim, hits.u[hit], hits.v[hit], O[hit], D[hit], hits.t[hit])
    assert np.allclose(surface.I, reference.I, rtol=0, atol=1e-12)
    assert np.array_equal(surface.Ng, reference.Ng)
    assert np.allclose(surface.N, reference.N, rtol=0, atol=1e-14)
    assert np.array_equal(triangles.smooth.astype(bool), reference.smooth) and reference.smooth.any()
    assert np.array_equal(triangles.albedo, reference.albedo)
    assert np.allclose(surface.offset, shadows.error_bound(reference.I, reference.vertices), rtol=1e-15, atol=0)
    if terminator_fix:
        s = reference.smooth
        lifted = shadows.terminator_points(reference.I[s], reference.vertices[s], reference.corners[s],
                                           reference.u[s], reference.v[s])
        assert np.allclose(surface.lifted[s], lifted, rtol=0, atol=1e-12)


def compiled_radiance(settings, geometry, lights, O, D, hits, hit, pixel, sample):
    """The radiance of each hit from the kernels alone (render._render_chunk_compiled, steps 4)."""
    prim = hits.prim[hit]
    triangles = kernels.copied_triangles(kernels.copied_arrays(geometry), prim)
    lift = settings.terminator_fix and geometry.has_smooth
    surface = kernels.surfaces(triangles, hit, O, D, hits.t[hit], hits.u[hit], hits.v[hit], lift=lift)
    records = (kernels.LightRecord * len(lights))(*[kernels.light_record(light, i, settings.light_samples)
                                                    for i, light in enumerate(lights)])
    E = np.zeros((len(hit), 3))
    rays = 0
    for l0, l1 in kernels.light_groups(records, len(hit)):
        batch = kernels.shadow_rays(kernels.shadow_settings(settings), records, l0, l1, surface,
                                    triangles.smooth, pixel, sample)
        kernels.add_light(records, batch, geometry.tracer.occluded(batch.origins, batch.directions, batch.t_max), E)
        rays += len(batch.weight)
    return triangles.albedo / math.pi * E, rays


# Lights whose samples involve no cos: both paths compute every ray with the same float64 steps.
EXACT_LIGHTS = ("point", "spot_scaled", "sun", "area_rect")


@contextlib.contextmanager
def traced_rays(tracer):
    """Collect the shadow rays `tracer` is asked about, as Embree gets them (float32), rays with
    t_max < 0 (none cast) left out: yields a list that holds [origins, directions, t_max] once the
    block ends."""
    found, occluded = [], tracer.occluded

    def recording(origins, directions, t_max):
        o, d, t = intersect._f32_rays(origins, directions, t_max)
        cast = t >= 0.0
        found.append((o[cast], d[cast], t[cast]))
        return occluded(origins, directions, t_max)

    tracer.occluded = recording
    result = []
    try:
        yield result
    finally:
        del tracer.occluded
        result += [np.concatenate(part) for part in zip(*found)]


@pytest.mark.parametrize("method", ["robust", "epsilon"])
@pytest.mark.parametrize("name", list(LIGHTS))
def test_shading_agrees_for_every_light(name, method):
    scene = lit_scene(LIGHTS[name])
    # (One light sample for the lights whose rays are compared one by one: see the end.)
    settings = RenderSettings(width=40, height=30, samples=2, light_samples=1 if name in EXACT_LIGHTS else 3,
                              shadow_method=method,
                              terminator_fix=name in ("point_soft", "sun"), seed=5)
    geometry = build_geometry(scene, scene.camera.position)
    lights = [translate_light(light, geometry.origin) for light in scene.lights]
    pixels, first, O, D, hits, hit = hits_of(scene, settings, geometry)
    pixel, sample = np.repeat(pixels, settings.samples)[hit], np.tile(np.arange(settings.samples), len(pixels))[hit]
    with traced_rays(geometry.tracer) as compiled_rays:
        radiance, rays = compiled_radiance(settings, geometry, lights, O, D, hits, hit, pixel, sample)
    surface = surface_at_hits(geometry, hits.prim[hit], hits.u[hit], hits.v[hit], O[hit], D[hit], hits.t[hit])
    with traced_rays(geometry.tracer) as numpy_rays:
        reference = direct_light(geometry, surface, lights, settings, pixel, sample)
    assert rays == reference.shadow_rays > 0
    if name in EXACT_LIGHTS:
        # The very rays Embree gets, to the last bit or one (float64 steps in another order round
        # differently before float32). With one sample per light both paths cast them hit by hit.
        for x, y in zip(compiled_rays, numpy_rays):
            np.testing.assert_array_max_ulp(x, y, maxulp=1)
    assert reference.radiance.max() > 0.01
    # Equal to rounding (sampled lights take cos in float32 from two libraries, ~1 ulp apart), up to
    # a shadow ray that float32 rounding sends past an edge the other way.
    wrong = np.abs(radiance - reference.radiance).max(axis=1) > 1e-6 * (1.0 + reference.radiance.max())
    assert wrong.mean() < 0.002, f"{wrong.sum()} of {len(wrong)} hits differ"


def compare_paths(scene: Scene, settings: RenderSettings):
    """Render on both paths; return (compiled, numpy) results after checking which path each took."""
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    numpy_ = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    assert numpy_.stats.kernels.startswith("numpy")
    return compiled, numpy_


@pytest.mark.parametrize("transparent", [False, True])
@pytest.mark.parametrize("adaptive", [False, True])
def test_renders_agree(adaptive, transparent):
    scene = lit_scene(LIGHTS["several"])
    settings = RenderSettings(width=64, height=48, samples=8, light_samples=2, adaptive=adaptive,
                              transparent_background=transparent, terminator_fix=True, chunk_size=4096)
    compiled, numpy_ = compare_paths(scene, settings)
    assert compiled.stats.primary_rays == numpy_.stats.primary_rays
    assert abs(compiled.stats.shadow_rays - numpy_.stats.shadow_rays) <= 1e-4 * numpy_.stats.shadow_rays
    assert np.array_equal(compiled.stats.samples_per_pixel, numpy_.stats.samples_per_pixel)
    difference = np.abs(compiled.image - numpy_.image)
    assert difference.max() < 1e-5 and difference.mean() < 1e-8
    assert (compiled.image[..., 3] < 1).any() == transparent


def with_a_row_of_spheres(scene: Scene) -> Scene:
    """Place lit_scene's sphere six more times in a row behind it (instancing="always" instances them)."""
    sphere = scene.instances[1]
    for k in range(6):
        matrix = np.eye(4)
        matrix[:3, 3] = (-2.5 + k, 1.8, 0.0)
        scene.instances.append(Instance(sphere.mesh, matrix, sphere.materials, f"Sphere {k}"))
    return scene


def test_fisheye_and_instanced_renders_agree():
    """The two cases whose rays or triangles come from numpy into the kernels."""
    scene = with_a_row_of_spheres(lit_scene(LIGHTS["point_soft"]))
    scene.camera = dataclasses.replace(scene.camera, type="PANO", panorama_type="FISHEYE_EQUISOLID",
                                       fisheye_fov=math.radians(170), fisheye_lens=8.0)
    settings = RenderSettings(width=48, height=32, samples=4, light_samples=2, instancing="always")
    compiled, numpy_ = compare_paths(scene, settings)
    assert compiled.stats.rays == numpy_.stats.rays
    assert np.abs(compiled.image - numpy_.image).max() < 1e-5


def test_point_light_inverse_square_on_both_paths():
    """E = P / (4 pi r^2) cos(theta) on a floor of albedo rho: L = rho / pi E, at every pixel centre."""
    scene = Scene(camera=Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.001, 0.0), fov=math.radians(30)))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    light = np.array([0.7, -0.4, 2.0])
    scene.lights = [PointLight(light, power=500.0)]
    settings = RenderSettings(width=24, height=24, samples=1, jitter=True)
    for path in ("compiled", "numpy"):
        result = render.render(scene, dataclasses.replace(settings, kernels=path, samples=16))
        # Closed form at each sample, averaged over the pixel: compare against the pixel-centre value
        # within the variation of E across one pixel.
        W = H = 24
        ys, xs = np.mgrid[0:H, 0:W] + 0.5
        rays = camera_.generate_rays(scene.camera, W, H, xs.ravel(), ys.ravel())
        t = -rays.origins[:, 2] / rays.directions[:, 2]
        points = rays.origins + t[:, None] * rays.directions
        to_light = light - points
        r2 = np.einsum("ij,ij->i", to_light, to_light)
        E = 500.0 / (4 * math.pi * r2) * to_light[:, 2] / np.sqrt(r2)
        expected = (0.5 / math.pi * E).reshape(H, W)
        assert np.allclose(result.image[..., 0], expected, rtol=0.02), path
        assert result.stats.kernels.startswith(path)


def test_lecture_switches_and_debug_views_take_the_numpy_path():
    scene = lit_scene(LIGHTS["point"])
    base = RenderSettings(width=16, height=12, samples=2)
    assert render.render(scene, base).stats.kernels == "compiled"
    for change in ({"clamp_n_dot_l": False}, {"aux": ("normal",)}, {"jitter": False}, {"kernels": "numpy"}):
        stats = render.render(scene, dataclasses.replace(base, **change)).stats
        assert stats.kernels.startswith("numpy ("), change


def test_missing_library_falls_back_to_numpy(monkeypatch, tmp_path):
    """Without the library (another platform, no compiler) the render says so and runs on numpy."""
    monkeypatch.setattr(kernels, "_cache", {})
    monkeypatch.setattr(kernels, "library_path", lambda: str(tmp_path / "_kernels-elsewhere.so"))
    scene = lit_scene(LIGHTS["point"])
    result = render.render(scene, RenderSettings(width=16, height=12, samples=2))
    assert result.stats.kernels.startswith("numpy (_kernels-elsewhere.so is not built")
    assert result.image[..., :3].max() > 0


def test_unknown_kernels_setting_is_refused():
    scene = lit_scene(LIGHTS["point"])
    with pytest.raises(ValueError, match="kernels must be one of"):
        render.render(scene, RenderSettings(width=8, height=8, kernels="fortran"))


def test_many_lights_are_split_into_bounded_groups():
    records = (kernels.LightRecord * 5)(*[kernels.light_record(
        AreaLight(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, -1.0])), i, 16)
        for i in range(5)])
    groups = kernels.light_groups(records, kernels.RAY_BUDGET // 32)
    assert groups == [(0, 2), (2, 4), (4, 5)]
    assert kernels.light_groups(records, 10 * kernels.RAY_BUDGET) == [(i, i + 1) for i in range(5)]


@pytest.mark.parametrize("first", [0, 4])
def test_unconverged_pixels_agree(first):
    """The noise test between passes picks exactly adaptive.unconverged's pixels: random sums with
    unsampled pixels, pixels of one sample, dark and bright ones, over the whole image and a region."""
    rng = np.random.default_rng(first)
    H, W = 37, 53
    count = rng.choice([0, 1, 4, 8, 16], H * W, p=[0.01, 0.01, 0.5, 0.3, 0.18]).astype(np.int64)
    mean = np.repeat(rng.choice([0.0, 0.02, 0.5, 3.0], (H, 1, 4)), W, axis=1).reshape(H * W, 4)   # bands
    mean *= np.tile(rng.choice([1.0, 1.0, 1.0, 20.0], W), H)[:, None]      # and columns: edges both ways
    mean *= rng.uniform(0.95, 1.05, (H * W, 4))
    mean[:, 3] = rng.choice([1.0, 0.7], H * W, p=[0.95, 0.05])
    spread = rng.choice([0.0, 1e-4, 0.3], (H * W, 2), p=[0.9, 0.07, 0.03])
    total = mean * count[:, None]
    luminance = mean[:, :3] @ adaptive.LUMINANCE
    squares = np.stack([luminance ** 2, mean[:, 3] ** 2], axis=1) * (1.0 + spread) * count[:, None]
    noise = adaptive.PixelNoise(total, squares, count)
    everything = np.arange(H * W, dtype=np.int64)
    region = (np.arange(5, 30)[:, None] * W + np.arange(10, 41)).reshape(-1)
    scattered = np.flatnonzero(rng.random(H * W) < 0.3)            # a later pass: pixels here and there
    partial = []
    with ThreadPoolExecutor(max_workers=3) as pool:
        for pixels in (everything, region, scattered):
            for threshold in (0.02, 0.1, 0.3):
                expected = adaptive.unconverged(pixels, noise, threshold, W, H, first)
                np.testing.assert_array_equal(kernels.unconverged(pixels, noise, threshold, W, H, first), expected)
                partial.append(0 < len(expected) < len(pixels))
                # Bands of rows decided apart (one per thread) give the same pixels: 1-row bands,
                # bands of uneven height, more bands than rows.
                for bands in (2, 3, 7, H, H + 5):
                    np.testing.assert_array_equal(
                        kernels.unconverged(pixels, noise, threshold, W, H, first, pool=pool, bands=bands), expected)
    assert sum(partial) >= 6           # most cases keep some pixels and drop others


@pytest.mark.parametrize("whole", [False, True])
@pytest.mark.parametrize("first", [0, 4])
def test_noise_kept_by_the_chunks_decides_as_the_sums_do(first, whole):
    """Each pixel's noise and mean, renewed by the chunk that adds its samples (kernels.add_pixels),
    give the noise test exactly adaptive.unconverged's pixels: passes of random chunk sums over
    the region (a rectangle inside the image, or the whole image: one run of pixels, which the C
    takes by its own path), then over scattered ones, with a test after each."""
    rng = np.random.default_rng(7 + first)
    H, W = 29, 41
    noise = adaptive.PixelNoise(np.zeros((H * W, 4)), np.zeros((H * W, 2)), np.zeros(H * W, np.int64))
    hits = np.zeros(H * W, np.int64)
    kept = kernels.NoiseEstimates.empty(H * W)
    region = np.arange(H * W) if whole else (np.arange(2, 27)[:, None] * W + np.arange(3, 40)).reshape(-1)
    rows = rng.choice([0.0, 0.03, 0.6, 4.0], H)                       # bands of one brightness each
    pixels, decided = region, []
    for spp in (4, 4, 8, 8):
        for chunk in np.array_split(pixels, 5):                      # the chunks of one pass
            level = rows[chunk // W, None] * rng.uniform(0.97, 1.03, (len(chunk), 4))
            level *= rng.choice([1.0, 0.5], (len(chunk), 1), p=[0.9, 0.1])   # a pass unlike the last
            rgba = level * spp
            rgba[:, 3] = spp * rng.choice([1.0, 0.75], len(chunk), p=[0.9, 0.1])
            luminance = level[:, :3] @ adaptive.LUMINANCE
            squares = np.stack([luminance ** 2, (rgba[:, 3] / spp) ** 2], axis=1) * spp
            squares *= 1.0 + rng.choice([0.0, 1e-3, 0.5], (len(chunk), 1), p=[0.9, 0.07, 0.03])
            kernels.add_pixels(chunk, spp, rgba, squares, np.full(len(chunk), spp), noise, hits, kept)
        # What the chunks kept is what adaptive.py works out from the sums now (to rounding: a
        # variance near 0 is a difference of nearly equal sums).
        sampled = noise.count > 0
        np.testing.assert_allclose(kept.error[sampled], adaptive.relative_noise(adaptive.PixelNoise(
            noise.total[sampled], noise.squares[sampled], noise.count[sampled])), rtol=1e-9, atol=1e-6)
        mean = np.einsum("ij,j->i", noise.total[:, :3], adaptive.LUMINANCE) / np.maximum(noise.count, 1)
        np.testing.assert_allclose(kept.mean[sampled], mean[sampled], rtol=1e-12, atol=0)
        expected = adaptive.unconverged(region, noise, 0.05, W, H, first)
        with ThreadPoolExecutor(max_workers=2) as pool:
            for bands in (1, 3):
                np.testing.assert_array_equal(
                    kernels.unconverged(region, noise, 0.05, W, H, first, pool=pool, bands=bands, estimates=kept),
                    expected)
        decided.append(0 < len(expected) < len(region))
        pixels = expected if len(expected) else region
    assert sum(decided) >= 2            # the tests keep some pixels and drop others


def test_noise_kept_for_a_run_of_pixels_is_the_noise_kept_pixel_by_pixel():
    """add_pixels works a run of neighbouring pixels' noise and mean out in SIMD lanes, and
    scattered pixels one by one: the same numbers, bit for bit (a chunk of a first pass against the
    same chunk in another order), with pixels of 0, 1 and many samples, dark and bright."""
    rng = np.random.default_rng(11)
    size, spp = 500, 4
    run = np.arange(37, 437)
    shuffled = rng.permutation(run)
    rgba = rng.uniform(0.0, 3.0, (len(run), 4)) * spp * rng.choice([0.0, 1e-4, 1.0], (len(run), 1))
    squares = rng.uniform(0.0, 9.0, (len(run), 2)) * spp
    kept = []
    for pixels in (run, shuffled):
        order = np.argsort(np.argsort(pixels))                  # row of each pixel in `run` order
        noise = adaptive.PixelNoise(np.zeros((size, 4)), np.zeros((size, 2)), np.zeros(size, np.int64))
        noise.count[::7] = 1                                    # some pixels had a sample before
        estimates = kernels.NoiseEstimates.empty(size)
        kernels.add_pixels(pixels, spp, rgba[order], squares[order], np.zeros(len(run), np.int64), noise,
                           np.zeros(size, np.int64), estimates)
        kept.append(estimates)
    assert np.isfinite(kept[0].error[run]).any() and np.isinf(kept[0].error[:37]).all()
    np.testing.assert_array_equal(kept[0].error, kept[1].error)
    np.testing.assert_array_equal(kept[0].mean, kept[1].mean)


def test_noise_test_refuses_pixels_that_are_not_ascending_indices_of_the_image():
    """kernels.unconverged reads each pixel's neighbours by its flat index: pixels out of order,
    repeated, negative or past the image are refused (the C would read outside the sums)."""
    W, H = 8, 6
    noise = adaptive.PixelNoise(np.ones((W * H, 4)), np.ones((W * H, 2)), np.full(W * H, 4, np.int64))
    assert len(kernels.unconverged(np.arange(W * H), noise, 0.05, W, H)) == W * H    # (every pixel is noisy)
    assert len(kernels.unconverged(np.zeros(0, np.int64), noise, 0.05, W, H)) == 0
    for bad in ([3, 2, 5], [1, 4, 4], [-1, 2, 3], [0, 1, W * H]):
        with pytest.raises(ValueError, match="ascending"):
            kernels.unconverged(np.array(bad, np.int64), noise, 0.05, W, H)


def test_compiled_box_filter_divides_as_numpy_does():
    """kernels.resolve gives numpy's float32 quotients bit for bit, a pixel without samples its sums."""
    rng = np.random.default_rng(3)
    total = rng.uniform(-1.0, 50.0, (1000, 4)) * rng.choice([1e-30, 1.0, 1e30], (1000, 1))
    count = rng.integers(0, 200, 1000).astype(np.int64)
    expected = (total / np.maximum(count, 1)[:, None]).astype(np.float32)
    np.testing.assert_array_equal(kernels.resolve(total, count), expected)


@pytest.mark.parametrize("method", ["robust", "epsilon"])
@pytest.mark.parametrize("name", ["point", "spot", "sun_disk", "area_rect", "area_ellipse_spread", "several"])
def test_streamed_shading_adds_the_light_of_the_three_steps(name, method):
    """kernels.shade (rays made, traced 8 at a time and added up in one pass) casts the very rays of
    shadow_rays -> Tracer.occluded -> add_light and sums their light in the same order: E is equal."""
    scene = lit_scene(LIGHTS[name])
    settings = RenderSettings(width=40, height=30, samples=2, light_samples=3, shadow_method=method,
                              terminator_fix=True, seed=3)
    geometry = build_geometry(scene, scene.camera.position)
    lights = [translate_light(light, geometry.origin) for light in scene.lights]
    pixels, first, O, D, hits, hit = hits_of(scene, settings, geometry)
    pixel, sample = np.repeat(pixels, settings.samples)[hit], np.tile(np.arange(settings.samples), len(pixels))[hit]
    triangles = kernels.copied_triangles(kernels.copied_arrays(geometry), hits.prim[hit])
    surface = kernels.surfaces(triangles, hit, O, D, hits.t[hit], hits.u[hit], hits.v[hit], lift=True)
    records = (kernels.LightRecord * len(lights))(*[kernels.light_record(light, i, settings.light_samples)
                                                    for i, light in enumerate(lights)])
    shadow = kernels.shadow_settings(settings)
    steps, streamed = np.zeros((len(hit), 3)), np.zeros((len(hit), 3))
    batch = kernels.shadow_rays(shadow, records, 0, len(lights), surface, triangles.smooth, pixel, sample)
    kernels.add_light(records, batch, geometry.tracer.occluded(batch.origins, batch.directions, batch.t_max), steps)
    rays, seconds = kernels.shade(shadow, records, 0, len(lights), surface, triangles.smooth, pixel, sample,
                                  geometry.tracer.packets, streamed)
    assert rays == len(batch.weight) > 0 and seconds > 0.0
    assert steps.max() > 0.0 and (steps == 0.0).any()        # some light, some shadow
    np.testing.assert_array_equal(streamed, steps)


@pytest.mark.parametrize("instancing", ["auto", "always"])
def test_streamed_queries_render_the_very_image_of_the_separate_steps(instancing, monkeypatch):
    """A chunk's samples made, traced, shaded and summed in one pass (kernels.samples), and camera rays
    and shadow rays traced inside their kernels (kernels.primary, kernels.shade) for instanced
    spheres, give the image of camera_rays -> Tracer.intersect and shadow_rays -> Tracer.occluded
    -> add_light -> film, bit for bit, with the same rays."""
    scene = with_a_row_of_spheres(lit_scene(LIGHTS["several"]))
    settings = RenderSettings(width=48, height=36, samples=8, light_samples=2, instancing=instancing,
                              terminator_fix=True, chunk_size=2048)
    fused_chunks = []
    fused = kernels.samples
    monkeypatch.setattr(kernels, "samples", lambda *args: fused_chunks.append(1) or fused(*args))
    streamed = render.render(scene, settings)
    # Copied triangles take the whole chunk in one pass (kernels.samples); instances need the
    # placements named between the passes, so they stream camera rays and shadow rays apart.
    assert bool(fused_chunks) == (instancing == "auto")
    monkeypatch.setattr(intersect.Tracer, "stream_queries", False)
    steps = render.render(scene, settings)
    assert streamed.stats.kernels == steps.stats.kernels == "compiled"
    assert (streamed.stats.primary_rays, streamed.stats.shadow_rays) == (steps.stats.primary_rays,
                                                                         steps.stats.shadow_rays)
    assert streamed.stats.trace_seconds > 0.0
    np.testing.assert_array_equal(streamed.stats.samples_per_pixel, steps.stats.samples_per_pixel)
    np.testing.assert_array_equal(streamed.image, steps.image)
    assert streamed.image[..., :3].max() > 0.05


@pytest.mark.parametrize("instancing", ["auto", "always"])
def test_time_in_embree_counted_in_ticks_is_a_share_of_the_render_seconds(instancing):
    """The kernels count Embree's time in time-stamp ticks and turn them into seconds with the clock
    read at both ends of each call: on one thread, the queries' seconds are a real part of the
    render's, neither zero nor more than the whole (a tick taken for a nanosecond would be 2-4 times
    too much on a 2-4 GHz processor, a nanosecond for a tick as much too little)."""
    scene = with_a_row_of_spheres(lit_scene(LIGHTS["several"]))
    settings = RenderSettings(width=64, height=48, samples=16, light_samples=2, instancing=instancing,
                              threads=1, adaptive=False)
    result = render.render(scene, settings)
    stats = result.stats
    assert stats.kernels == "compiled"
    assert 0.05 * stats.seconds < stats.trace_seconds < stats.seconds
    assert 0.0 < stats.trace_seconds + stats.shading_seconds < stats.seconds


@pytest.mark.parametrize("lights, camera_type, samples, adaptive, transparent, fix", [
    ("several", "PERSP", 6, True, False, True),         # pixels split across blocks of 64 samples
    ("area_ellipse_spread", "ORTHO", 5, False, True, False),
    ("sun_disk", "PERSP", 16, True, True, True),
    ("spot_scaled", "ORTHO", 3, True, False, False),
])
def test_one_pass_chunks_render_the_image_of_the_separate_steps(lights, camera_type, samples, adaptive,
                                                                transparent, fix, monkeypatch):
    """kernels.samples gives the separate kernels' image, sample counts and ray counts bit for bit:
    both cameras it makes rays for, pixels whose samples straddle two blocks, adaptive sampling's
    sums of squares, a transparent film, the terminator fix on and off, a cropped region."""
    scene = lit_scene(LIGHTS[lights])
    scene.camera = dataclasses.replace(scene.camera, type=camera_type, ortho_scale=6.0)
    settings = RenderSettings(width=40, height=30, samples=samples, light_samples=3, adaptive=adaptive,
                              transparent_background=transparent, terminator_fix=fix, chunk_size=1500,
                              region=(2, 3, 37, 28))
    fused_chunks = []
    fused = kernels.samples
    monkeypatch.setattr(kernels, "samples", lambda *args: fused_chunks.append(1) or fused(*args))
    one_pass = render.render(scene, settings)
    assert fused_chunks
    monkeypatch.setattr(intersect.Tracer, "stream_queries", False)
    steps = render.render(scene, settings)
    assert (one_pass.stats.primary_rays, one_pass.stats.shadow_rays) == (steps.stats.primary_rays,
                                                                         steps.stats.shadow_rays)
    np.testing.assert_array_equal(one_pass.stats.samples_per_pixel, steps.stats.samples_per_pixel)
    np.testing.assert_array_equal(one_pass.image, steps.image)
    assert one_pass.image[..., :3].max() > 0.02 and one_pass.stats.shadow_rays > 0
