"""The compiled twin: the C code computes what the Python reference computes.

The Python in core/ is the reference. Each part's C file is checked against its Python on its own
(the sample pattern bit for bit; camera rays, light samples and BSDFs to float64 rounding), and
whole renders on both paths are compared: the same rays traced, the same samples per pixel, and
images that agree to float32 rounding. Stated tolerance: every pixel within 4e-7 absolute and
1e-6 relative (a few float32 ulps). The two are not bit-identical in general because numpy's float32
cosine (a sampled light's azimuth, vectors.cos_sin) may round one ulp away from the C library's;
lights without extent, whose samples take no cosine, render bit for bit the same. Closed forms are
checked on both paths by the other test files (which run compiled by default) and by
test_point_light_inverse_square_on_both_paths here.
"""
from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor

import zlib

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.camera import camera as camera_
from core.film import adaptive
from core.film.film import NoiseEstimates, add_pixels, resolve
from core.geometry import primitives
from core.lights.base import compiled_sample
from core.native import library
from core.sampling import sobol as sampling
from core.scene import AreaLight, Instance, PointLight, RenderSettings, Scene, SpotLight, SunLight

IMAGE_ATOL, IMAGE_RTOL = 4e-7, 1e-6


def test_the_library_is_built_for_this_machine():
    """`make kernels` ran: without the library every other test here would measure nothing."""
    assert library.available(), library.unavailable_reason()


def test_sample_2d_agrees_bit_for_bit(rng):
    n = 20000
    pixel = rng.integers(0, 1 << 40, n)
    index = rng.integers(0, 1 << 31, n)
    for seed, dimension in ((0, 0), (7, 16), (123456789, 20), (2 ** 40 + 3, 44)):
        expected = sampling.sample_2d(seed, pixel, index, dimension)
        assert np.array_equal(sampling.compiled_sample_2d(seed, pixel, index, dimension), expected)


CAMERAS = [
    Camera.look_at((1.0, -6.0, 2.5), (0.0, 0.0, 0.5), fov=math.radians(50)),
    dataclasses.replace(Camera.look_at((3.0, 2.0, 1.0), (0.0, 0.0, 0.0)), shift_x=0.3, shift_y=-0.2,
                        sensor_fit="VERTICAL", clip_start=0.5, clip_end=40.0),
    dataclasses.replace(Camera.look_at((0.0, 0.0, 9.0), (0.0, 0.1, 0.0)), type="ORTHO", ortho_scale=4.0,
                        shift_x=-0.1),
    dataclasses.replace(Camera.look_at((0.3, -4.0, 2.0), (0.0, 0.0, 0.5)), type="PANO",
                        panorama_type="FISHEYE_EQUIDISTANT", fisheye_fov=math.radians(160)),
    dataclasses.replace(Camera.look_at((0.3, -4.0, 2.0), (0.0, 0.0, 0.5)), type="PANO",
                        panorama_type="FISHEYE_EQUISOLID", fisheye_fov=math.radians(170), fisheye_lens=8.0,
                        shift_x=0.05),
]


CAMERAS += [dataclasses.replace(Camera.look_at((0.3, -4.0, 2.0), (0.0, 0.0, 0.5)), type="PANO", panorama_type=kind,
                                shift_y=0.03, fisheye_fov=math.radians(120), **settings)
            for kind, settings in (("EQUIRECTANGULAR", dict(longitude_min=-2.0, longitude_max=1.5, latitude_max=1.2)),
                                   ("EQUIANGULAR_CUBEMAP_FACE", {}), ("MIRRORBALL", {}),
                                   ("FISHEYE_LENS_POLYNOMIAL", dict(fisheye_polynomial=(0.0, -0.05, 0.0, 1e-5, 0.0))),
                                   ("CENTRAL_CYLINDRICAL", dict(cylinder_u_min=-1.2, cylinder_v_max=1.4,
                                                                cylinder_radius=1.3)))]


@pytest.mark.parametrize("camera", CAMERAS, ids=["persp", "persp_shift_vertical", "ortho_shift", "equidistant",
                                                 "equisolid", "equirectangular", "cubemap_face", "mirrorball",
                                                 "polynomial_fisheye", "central_cylindrical"])
def test_camera_rays_agree(camera):
    """camera.c's rays are generate_rays' for every camera type, camera-relative, the image circle included."""
    W, H, spp, seed = 37, 23, 5, 11
    pixels = np.arange(0, W * H, 3, dtype=np.int64)
    first = (pixels % 4).astype(np.int64)
    origin = np.array([0.5, -0.25, 2.0])
    record = camera_.camera_record(camera, W, H, (1.0, 1.2), origin)
    O, D, t, valid = camera_.compiled_rays(record, seed, W, H, pixels, first, spp)
    pixel, sample = render.sample_keys(pixels, spp, first)
    offset = sampling.sample_2d(seed, pixel, sample, 0)
    rays = camera_.generate_rays(camera.moved(origin), W, H, pixel % W + offset[:, 0], pixel // W + offset[:, 1],
                                 (1.0, 1.2))
    np.testing.assert_array_equal(valid, rays.valid)
    np.testing.assert_allclose(O[valid], rays.origins[valid], rtol=0, atol=1e-13)
    np.testing.assert_allclose(D[valid], rays.directions[valid], rtol=0, atol=1e-14)
    np.testing.assert_allclose(t, rays.t_max, rtol=1e-15, atol=0)


def lit_scene(lights: list, box: bool = True) -> Scene:
    """A smooth low-poly sphere on a flat floor with a box beside it (unless not `box`), seen from above, under
    `lights`."""
    scene = Scene(camera=Camera.look_at((0.5, -5.0, 3.0), (0.0, 0.0, 0.4), fov=math.radians(45)),
                  world_color=np.array([0.05, 0.06, 0.07]))
    scene.add_material((0.8, 0.7, 0.6))
    scene.add_material((0.3, 0.5, 0.9))
    scene.add_mesh(primitives.plane(8.0), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.8, 12, 6, center=(0.0, 0.0, 0.8), smooth=True), materials=np.array([1]))
    if box:
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


@pytest.mark.parametrize("name", [name for name in LIGHTS if name != "several"])
def test_each_lights_c_file_samples_what_its_class_samples(name):
    """Every light type's C sample (direction, distance, E_normal, pdf, point) is its Python class's: to
    float64 rounding, except where a sampled azimuth's float32 cosine rounds one ulp apart (vectors.cos_sin:
    the direction may then move by up to ~3e-7 near the cone's axis)."""
    (light,) = LIGHTS[name]
    rng = np.random.default_rng(3)
    points = rng.uniform(-2.0, 2.0, (4000, 3)) * [1.0, 1.0, 0.5]
    u = rng.random((4000, 2))
    expected = light.sample(points, u)
    found = compiled_sample(light, points, u)
    np.testing.assert_allclose(found.L, expected.L, rtol=0, atol=1e-6)
    for field in ("distance", "strength", "pdf"):
        # (A spot's cone edge: a direction one rounding apart may fall a hair inside or outside.)
        close = np.isclose(getattr(found, field), getattr(expected, field), rtol=1e-5, atol=0)
        assert close.mean() > 0.999, field
    if np.isfinite(expected.distance).all():
        np.testing.assert_allclose(found.position, expected.position, rtol=0, atol=1e-6)


@pytest.mark.parametrize("bsdf", materials.BSDF_TYPES, ids=lambda cls: cls.name)
def test_each_bsdfs_c_file_evaluates_and_samples_what_its_class_does(bsdf):
    """f cos, pdf and a sampled direction of every BSDF in C (as a one-closure ShaderResult), against its
    Python class, on random directions (each BSDF its own draw, seeded by its name: a BSDF added to the table
    changes no other's)."""
    rng = np.random.default_rng(zlib.crc32(bsdf.name.encode()))
    n = 1000
    kind = np.full(n, bsdf.kind, np.int32)
    weight = rng.random((n, 3))
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    wo, wi = (rng.normal(size=(n, 3)) for _ in range(2))
    wo, wi = wo / np.linalg.norm(wo, axis=1, keepdims=True), wi / np.linalg.norm(wi, axis=1, keepdims=True)
    wo *= np.where(np.einsum("ij,ij->i", wo, N) < 0, -1.0, 1.0)[:, None]          # the viewer's side
    u = rng.random((n, 2))
    params = rng.random((n, materials.PARAMS))
    f_cos, pdf, sampled = materials.compiled_bsdf(kind, weight, N, params, wo, wi, u)
    closures = materials.Closures(kind[:, None], weight[:, None, :], np.abs(weight.mean(axis=1))[:, None],
                                  N[:, None, :], params[:, None, :])
    expected_f, expected_pdf = materials.eval_closures(closures, wo, wi)
    expected = materials.sample_closures(closures, wo, u, np.full(n, 0.5))
    # (Huang's hair integrates by a quadrature seeded by the bits of the directions, whose steps follow from arccos
    # and arctan2: where numpy's AVX-512 versions and libm's part in the last bit, a few rows draw other numbers, each
    # another estimate of the same integral; those rows are left out, no more than 2 % of them)
    huang = bsdf.name == "HAIR_HUANG"
    evaluated = (np.isclose(f_cos, expected_f, rtol=1e-12, atol=0).all(axis=1) & np.isclose(pdf, expected_pdf, rtol=1e-12,
                                                                                          atol=0)
                 if huang else np.ones(n, bool))
    drawn = np.isclose(sampled.wi, expected.wi, rtol=0, atol=1e-6).all(axis=1) if huang else np.ones(n, bool)
    assert evaluated.mean() > 0.98 and drawn.mean() > 0.98
    np.testing.assert_allclose(f_cos[evaluated], expected_f[evaluated], rtol=1e-12, atol=0)
    np.testing.assert_allclose(pdf[evaluated], expected_pdf[evaluated], rtol=1e-12, atol=0)
    np.testing.assert_allclose(sampled.wi[drawn], expected.wi[drawn], rtol=0, atol=1e-6)   # (a float32 cosine, as for lights)
    # The sampled direction differs from Python's by the float32 cosine (checked above), which a BSDF's weight then
    # inherits (amplified near grazing): so the weight and pdf are checked at the very direction C sampled, where
    # they must be f cos / pdf of Python's closures to float64 rounding; a delta's (and an OWN_WEIGHT BSDF's, whose
    # sample is not eval at its direction: Ashikhmin-Shirley; a BSSRDF's, whose eval is 0) against Python's sample.
    delta = materials.has(kind, materials.BSDFFlags.SINGULAR | materials.BSDFFlags.OWN_WEIGHT
                          | materials.BSDFFlags.SUBSURFACE)
    at_f, at_pdf = materials.eval_closures(closures, wo, sampled.wi)
    at_weight = np.divide(at_f, at_pdf[:, None], out=np.zeros_like(at_f), where=at_pdf[:, None] > 0.0)
    rtol = 1e-8 if huang else 1e-9            # (Huang's: sums of its quadrature's steps, each a few ulps apart)
    weight_there, pdf_there = np.where(delta[:, None], expected.weight, at_weight), np.where(delta, expected.pdf, at_pdf)
    if huang:   # (numpy's AVX-512 loops and their scalar ends part in the last bit, so which rows draw other numbers
        # follows the arrays' alignment in memory: 0 to 1 of the 996 measured over 8 offsets, a weight of 1e56 once)
        drawn &= (np.isclose(sampled.weight, weight_there, rtol=rtol, atol=1e-12).all(axis=1)
                  & np.isclose(sampled.pdf, pdf_there, rtol=rtol, atol=1e-12))
        assert drawn.mean() > 0.98
    np.testing.assert_allclose(sampled.weight[drawn], weight_there[drawn], rtol=rtol, atol=1e-12)
    np.testing.assert_allclose(sampled.pdf[drawn], pdf_there[drawn], rtol=rtol, atol=1e-12)
    np.testing.assert_allclose(sampled.pdf[drawn], expected.pdf[drawn], rtol=1e-6, atol=1e-9)


def compare_paths(scene: Scene, settings: RenderSettings):
    """Render on both paths; return (compiled, reference) results."""
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    assert reference.stats.kernels.startswith("numpy")
    return compiled, reference


def assert_same_render(compiled, reference, exact: bool = False):
    """The same rays and samples per pixel; the images within the stated tolerance (or bit for bit)."""
    assert compiled.stats.primary_rays == reference.stats.primary_rays
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    np.testing.assert_array_equal(compiled.stats.samples_per_pixel, reference.stats.samples_per_pixel)
    if exact:
        np.testing.assert_array_equal(compiled.image, reference.image)
    else:
        np.testing.assert_allclose(compiled.image, reference.image, rtol=IMAGE_RTOL, atol=IMAGE_ATOL)


@pytest.mark.parametrize("method", ["robust", "epsilon"])
@pytest.mark.parametrize("name", list(LIGHTS))
def test_renders_agree_for_every_light(name, method):
    scene = lit_scene(LIGHTS[name])
    settings = RenderSettings(width=40, height=30, samples=4, light_samples=3, shadow_method=method, epsilon=1e-3)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference, exact=all(light.delta for light in scene.lights))


@pytest.mark.parametrize("transparent", [False, True])
@pytest.mark.parametrize("adaptive_sampling", [False, True])
def test_renders_agree(adaptive_sampling, transparent):
    scene = lit_scene(LIGHTS["several"])
    settings = RenderSettings(width=64, height=48, samples=8, light_samples=2, adaptive=adaptive_sampling,
                              transparent_background=transparent, terminator_fix=True, chunk_size=4096)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    assert (compiled.image[..., 3] < 1).any() == transparent


def with_a_row_of_spheres(scene: Scene) -> Scene:
    """Place lit_scene's sphere six more times in a row behind it (instancing="always" instances them)."""
    sphere = scene.instances[1]
    for k in range(6):
        matrix = np.eye(4)
        matrix[:3, 3] = (-2.5 + k, 1.8, 0.0)
        scene.instances.append(Instance(sphere.mesh, matrix, sphere.materials, f"Sphere {k}"))
    return scene


@pytest.mark.parametrize("instancing", ["never", "always"])
@pytest.mark.parametrize("camera_type", ["PERSP", "FISHEYE_EQUISOLID"])
def test_fisheye_and_instanced_renders_agree(camera_type, instancing):
    """Every camera and both kinds of triangles (copied, and placements of an instanced mesh) in C."""
    scene = with_a_row_of_spheres(lit_scene(LIGHTS["point"] + LIGHTS["spot"]))
    if camera_type != "PERSP":
        scene.camera = dataclasses.replace(scene.camera, type="PANO", panorama_type=camera_type,
                                           fisheye_fov=math.radians(170), fisheye_lens=8.0)
    settings = RenderSettings(width=48, height=32, samples=4, light_samples=2, instancing=instancing,
                              terminator_fix=True)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)


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


def test_lecture_switches_and_debug_views_take_the_reference_path():
    scene = lit_scene(LIGHTS["point"])
    base = RenderSettings(width=16, height=12, samples=2)
    assert render.render(scene, base).stats.kernels == "compiled"
    for change in ({"clamp_n_dot_l": False}, {"aux": ("normal",)}, {"jitter": False}, {"kernels": "numpy"}):
        stats = render.render(scene, dataclasses.replace(base, **change)).stats
        assert stats.kernels.startswith("numpy ("), change


def test_missing_library_falls_back_to_the_reference(monkeypatch, tmp_path):
    """Without the library (another platform, no compiler) the render says so and runs the reference."""
    monkeypatch.setattr(library, "_cache", {})
    monkeypatch.setattr(library, "library_path", lambda: str(tmp_path / "_kernels-elsewhere.so"))
    scene = lit_scene(LIGHTS["point"])
    result = render.render(scene, RenderSettings(width=16, height=12, samples=2))
    assert result.stats.kernels.startswith("numpy (_kernels-elsewhere.so is not built")
    assert result.image[..., :3].max() > 0


def test_unknown_kernels_setting_is_refused():
    scene = lit_scene(LIGHTS["point"])
    with pytest.raises(ValueError, match="kernels must be one of"):
        render.render(scene, RenderSettings(width=8, height=8, kernels="fortran"))


@pytest.mark.parametrize("instancing", ["auto", "always"])
def test_time_in_embree_is_a_share_of_the_render_seconds(instancing):
    """On one thread, the seconds the C chunk counts inside Embree are a real part of the render's."""
    scene = with_a_row_of_spheres(lit_scene(LIGHTS["several"]))
    result = render.render(scene, RenderSettings(width=96, height=72, samples=16, threads=1, instancing=instancing))
    assert result.stats.kernels == "compiled"
    assert 0.05 * result.stats.seconds < result.stats.trace_seconds < result.stats.seconds


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
                np.testing.assert_array_equal(adaptive.unconverged_compiled(pixels, noise, threshold, W, H, first), expected)
                partial.append(0 < len(expected) < len(pixels))
                # Bands of rows decided apart (one per thread) give the same pixels: 1-row bands,
                # bands of uneven height, more bands than rows.
                for bands in (2, 3, 7, H, H + 5):
                    np.testing.assert_array_equal(
                        adaptive.unconverged_compiled(pixels, noise, threshold, W, H, first, pool=pool, bands=bands), expected)
    assert sum(partial) >= 6           # most cases keep some pixels and drop others


@pytest.mark.parametrize("whole", [False, True])
@pytest.mark.parametrize("first", [0, 4])
def test_noise_kept_by_the_chunks_decides_as_the_sums_do(first, whole):
    """Each pixel's noise and mean, renewed by the chunk that adds its samples (film.add_pixels),
    give the noise test exactly adaptive.unconverged's pixels: passes of random chunk sums over
    the region (a rectangle inside the image, or the whole image: one run of pixels, which the C
    takes by its own path), then over scattered ones, with a test after each."""
    rng = np.random.default_rng(7 + first)
    H, W = 29, 41
    noise = adaptive.PixelNoise(np.zeros((H * W, 4)), np.zeros((H * W, 2)), np.zeros(H * W, np.int64))
    hits = np.zeros(H * W, np.int64)
    kept = NoiseEstimates.empty(H * W)
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
            add_pixels(chunk, spp, rgba, squares, np.full(len(chunk), spp), noise, hits, kept)
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
                    adaptive.unconverged_compiled(region, noise, 0.05, W, H, first, pool=pool, bands=bands, estimates=kept),
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
        estimates = NoiseEstimates.empty(size)
        add_pixels(pixels, spp, rgba[order], squares[order], np.zeros(len(run), np.int64), noise,
                           np.zeros(size, np.int64), estimates)
        kept.append(estimates)
    assert np.isfinite(kept[0].error[run]).any() and np.isinf(kept[0].error[:37]).all()
    np.testing.assert_array_equal(kept[0].error, kept[1].error)
    np.testing.assert_array_equal(kept[0].mean, kept[1].mean)


def test_noise_test_refuses_pixels_that_are_not_ascending_indices_of_the_image():
    """adaptive.unconverged_compiled reads each pixel's neighbours by its flat index: pixels out of order,
    repeated, negative or past the image are refused (the C would read outside the sums)."""
    W, H = 8, 6
    noise = adaptive.PixelNoise(np.ones((W * H, 4)), np.ones((W * H, 2)), np.full(W * H, 4, np.int64))
    assert len(adaptive.unconverged_compiled(np.arange(W * H), noise, 0.05, W, H)) == W * H    # (every pixel is noisy)
    assert len(adaptive.unconverged_compiled(np.zeros(0, np.int64), noise, 0.05, W, H)) == 0
    for bad in ([3, 2, 5], [1, 4, 4], [-1, 2, 3], [0, 1, W * H]):
        with pytest.raises(ValueError, match="ascending"):
            adaptive.unconverged_compiled(np.array(bad, np.int64), noise, 0.05, W, H)


def test_compiled_box_filter_divides_as_numpy_does():
    """film.resolve gives numpy's float32 quotients bit for bit, a pixel without samples its sums."""
    rng = np.random.default_rng(3)
    total = rng.uniform(-1.0, 50.0, (1000, 4)) * rng.choice([1e-30, 1.0, 1e30], (1000, 1))
    count = rng.integers(0, 200, 1000).astype(np.int64)
    expected = (total / np.maximum(count, 1)[:, None]).astype(np.float32)
    np.testing.assert_array_equal(resolve(total, count), expected)




def lamp_over_a_pane(pane_transparency: float | None, camera_height: float = 6.0) -> Scene:
    """Boxes on a floor under an emissive quad lamp (z 2.5, facing down) with a Transparent pane (z 1.9) between
    them and the lamp (None: no pane); camera_height: the camera looking straight down from there."""
    from core.lights.world import World
    from test_ray_visibility import glow, looking_down
    scene = Scene(camera=looking_down(camera_height), world=World(color=np.zeros(3)))
    scene.materials += [materials.Material(name="matte", nodes=[("DIFFUSE", (0.42,) * 3, {})]),
                        materials.Material(name="gloss", nodes=[("GLOSSY", (0.36,) * 3, {"roughness": 0.3})]),
                        materials.Material(name="pane", nodes=[("TRANSPARENT", (pane_transparency or 0.0,) * 3, {})]),
                        glow("lamp", 6.0)]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    for x, material in [(-1.5, 1), (0.0, 0), (1.5, 0)]:
        scene.add_mesh(primitives.box((0.8, 0.8, 0.8), center=(x, 0.0, 0.4)), materials=np.array([material]))
    if pane_transparency is not None:
        scene.add_mesh(primitives.plane(2.0, center=(0.6, 0.4, 1.9)), materials=np.array([2]))
    lamp = np.array([[1, 0, 0, 0], [0, -1, 0, 0.5], [0, 0, -1, 2.5], [0, 0, 0, 1.0]])
    scene.add_mesh(primitives.plane(1.0), lamp, materials=np.array([3]))
    return scene


def test_shadow_rays_through_a_transparent_pane_stay_short_of_the_light():
    """Transparent shadows: past a pane a shadow ray goes on towards its own end, short of the light point, as
    Cycles' one shadow ray does. Going on along its old direction for its old length less what it gained along
    it, the step off the pane (along the pane's normal) carried the end onto the lamp's own surface for slanted
    rays, which the lamp then shadowed; where that end lands within float32 rounding of the lamp, the two
    kernels (a few ulps apart on the path's later vertices) disagreed: a bounce-1 light sample through the pane
    at pixel (4, 29), sample 4."""
    scene = lamp_over_a_pane(0.5)
    settings = RenderSettings(width=40, height=40, samples=4, integrator="path", light_samples=2, max_bounces=1)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)


def test_a_clear_pane_casts_no_shadow():
    """Shadow rays from the floor to points of the lamp at every slant, through a Transparent pane of transparency
    1: each carries all of its light (shadows.transmittance 1) wherever nothing opaque is in the way, exactly where
    it reaches the lamp without the pane; none is stopped by the lamp it aims at."""
    from core.integrators import shadows
    ctx = render.prepare(lamp_over_a_pane(1.0), RenderSettings(width=8, height=8))
    bare = render.prepare(lamp_over_a_pane(None), RenderSettings(width=8, height=8))
    origin = ctx.geometry.origin
    grid = np.linspace(-0.45, 0.45, 7)
    lamp = np.array([(x, 0.5 + y, 2.5) for x in grid for y in grid]) - origin
    floor = np.array([(x, y, 0.0) for x in np.linspace(-3.0, 4.0, 15) for y in np.linspace(-3.0, 3.5, 14)]) - origin
    P, Q = np.repeat(floor, len(lamp), axis=0), np.tile(lamp, (len(floor), 1))
    L = Q - P
    distance = np.linalg.norm(L, axis=1)
    rays = shadows.robust_rays(P, np.tile([0.0, 0.0, 1.0], (len(P), 1)), shadows.error_bound(P, P[:, None, :]), Q,
                               L / distance[:, None], distance)
    seen = shadows.visible(bare.geometry.tracer, rays)
    pane = ctx.geometry.tracer.intersect(rays.origins, rays.directions, rays.t_max)
    assert (seen & pane.hit).sum() > 1000                    # (many rays pass the pane, at many slants)
    T = shadows.transmittance(ctx, rays, 8)
    np.testing.assert_array_equal(T, np.where(seen, 1.0, 0.0)[:, None] * np.ones(3))


@pytest.mark.parametrize("strategy", ["mis", "light", "bsdf"])
@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_light_found_through_a_pane_is_weighed_from_the_last_real_bounce_on_both_paths(integrator, strategy):
    """The boxes under the quad lamp and the pane, with an area lamp and a round point lamp above the pane too: BSDF
    rays that pass the pane (as a path's clear bounce, or looking on past the path's end) weigh the emitter and the
    lamps they find by the light pdfs measured from the last real bounce's point and normal (mis_origin; the round
    lamp's disk faces that point), and with light samples alone find nothing; the two kernels agree."""
    from core.lights.area import AreaLight
    from core.lights.point import PointLight
    scene = lamp_over_a_pane(0.5)
    scene.lights += [AreaLight(np.array([1.0, 0.6, 2.3]), np.array([0.6, 0.0, 0.0]), np.array([0.0, 0.5, 0.0]),
                               np.array([0.0, 0.0, -1.0]), power=60.0),
                     PointLight(np.array([0.2, 0.2, 2.2]), power=80.0, radius=0.2)]
    settings = RenderSettings(width=32, height=32, samples=4, integrator=integrator, light_samples=2, max_bounces=2,
                              light_sampling=strategy)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("offset", [0.25, 1.0])
def test_a_shading_offset_bends_lamberts_cosine_to_zero_before_the_terminator(kernels, offset):
    """Cycles' Shading Offset s: a Lambert plane of albedo rho under a sun of irradiance E at angle theta from its
    normal is L = rho / pi E max(cos(m theta), 0), m = 1 / (1 - s / 2), in both kernels (at theta = 50 degrees: 0.83
    of the unbent light for s = 0.25, none for s = 1)."""
    theta, rho, E = math.radians(50.0), 0.5, 3.0
    scene = Scene(camera=Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.001, 0.0), fov=math.radians(30)))
    scene.add_material((rho, rho, rho))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.instances[0].terminator_shading = offset
    scene.lights = [SunLight(np.array([-math.sin(theta), 0.0, -math.cos(theta)]), strength=E)]
    settings = RenderSettings(width=8, height=8, samples=1, terminator_fix=True, kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    m = 1.0 / (1.0 - 0.5 * offset)
    np.testing.assert_allclose(image, rho / math.pi * E * max(math.cos(m * theta), 0.0), rtol=1e-6, atol=1e-9)
    unbent = render.render(scene, dataclasses.replace(settings, terminator_fix=False)).image[..., :3]
    np.testing.assert_allclose(unbent, rho / math.pi * E * math.cos(theta), rtol=1e-6)


@pytest.mark.parametrize("instancing", ["never", "always"])
def test_each_objects_own_terminator_offsets_render_alike_in_both_kernels(instancing):
    """The spheres of a row, each with its own Geometry Offset (0: its shadow rays are not lifted) and Shading Offset,
    copied or instanced: the compiled kernel renders what the reference does."""
    scene = with_a_row_of_spheres(lit_scene(LIGHTS["several"]))
    for k, instance in enumerate(scene.instances[1:]):
        instance.terminator_offset = (0.0, 0.05, 0.3, 0.9)[k % 4]
        instance.terminator_shading = (0.0, 0.5, 0.2)[k % 3]
    settings = RenderSettings(width=48, height=32, samples=4, light_samples=2, instancing=instancing,
                              terminator_fix=True)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)


@pytest.mark.parametrize("camera_type", ["EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID", "MIRRORBALL"])
def test_bumps_and_pixel_size_wires_under_panoramic_cameras_render_alike_in_both_kernels(camera_type):
    """Under a panoramic camera each camera ray leaves with Cycles' panorama differentials (camera.panorama_cones:
    its pinhole's directions one pixel apart): the floor's Bump steps by that footprint and the sphere's emitted
    Pixel Size Wireframe measures it, the Python reference (from the ray's direction) and the compiled kernel (from
    its raster point) alike, both where the camera sees the sphere and where the floor's BSDF rays find it (each
    leaves with the footprint at its hit and the spread kept, as Cycles' ray differentials do: the direct
    integrator's bounce carries the camera ray's cone, not none)."""
    from core.materials import Material
    from core.materials.graph import GraphNode, Link
    scene = lit_scene(LIGHTS["sun"])
    scene.camera = dataclasses.replace(scene.camera, type="PANO", panorama_type=camera_type,
                                       fisheye_fov=math.radians(170), fisheye_lens=8.0)
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("GEOMETRY", {}, {}), "Position")}), "X")
    height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": Link(GraphNode(
        "MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 6.0}), "Value")}), "Value")
    normal = Link(GraphNode("BUMP", {"invert": False, "filter_width": 1.0},
                            {"Strength": 1.0, "Distance": 0.3, "Height": height}), "Normal")
    wire = Link(GraphNode("WIREFRAME", {"pixel_size": True}, {"Size": 1.5}), "Fac")
    scene.materials[0] = Material(name="Bumped", nodes=[("DIFFUSE", (0.8, 0.7, 0.6), {"color": np.array([0.8, 0.7, 0.6]),
                                                                                      "normal": normal})])
    scene.materials[1] = Material(name="Wire", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": wire})])
    settings = RenderSettings(width=48, height=32, samples=2, light_samples=1, terminator_fix=True)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)


@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_a_bumped_floor_under_a_perspective_camera_renders_alike_in_both_kernels(integrator):
    """A perspective camera ray's cone is measured in Cycles' camera frame (camera.world_to_camera: x right, y up, z
    along the view), where the window's pixel steps dx, dy are taken at d = P / P.z: the compiled kernel's camera
    cone (chunk.c camera_cone_of) is the Python reference's (rays.camera_cones), so a floor bumped by a sine of x
    (Filter Width 1: steps of the footprint, widened along the ray and after each bounce) renders to the same
    pixels, by direct light and path traced. (A frame with z behind the camera mirrors d and measures the spread
    at the mirrored pixel: 7.6e-4 apart by direct light.)"""
    scene = with_cone_readers(lit_scene(LIGHTS["sun"], box=False), bump=True, wire="")
    settings = RenderSettings(width=48, height=32, samples=2, light_samples=1, integrator=integrator)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)


def with_cone_readers(scene: Scene, bump: bool = True, wire: str = "pixel_size") -> Scene:
    """lit_scene `scene` with its floor's Diffuse bumped by a sine of x (Filter Width 1: steps of the ray's footprint,
    where `bump`) and its sphere an emitting Wireframe of Size 1.5 (wire "pixel_size": in pixels, which reads the
    footprint; "world": in scene units, which does not; "": no wire)."""
    from core.materials import Material
    from core.materials.graph import GraphNode, Link
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("GEOMETRY", {}, {}), "Position")}), "X")
    height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": Link(GraphNode(
        "MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 6.0}), "Value")}), "Value")
    inputs = {"color": np.array([0.8, 0.7, 0.6])}
    if bump:
        inputs["normal"] = Link(GraphNode("BUMP", {"invert": False, "filter_width": 1.0},
                                          {"Strength": 1.0, "Distance": 0.3, "Height": height}), "Normal")
    else:
        inputs["color"] = Link(GraphNode("COMBINE_XYZ", {}, {"X": height, "Y": 0.5, "Z": 0.5}), "Vector")
    scene.materials[0] = Material(name="Floor", nodes=[("DIFFUSE", (0.8, 0.7, 0.6), inputs)])
    if wire:
        fac = Link(GraphNode("WIREFRAME", {"pixel_size": wire == "pixel_size"}, {"Size": 1.5}), "Fac")
        color = Link(GraphNode("COMBINE_XYZ", {}, {"X": fac, "Y": 0.4, "Z": 0.9}), "Vector")
        scene.materials[1] = Material(name="Wire", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"color": color})])
    return scene


@pytest.mark.parametrize("bump, wire, reads", [(False, "", False), (False, "world", False), (True, "", True),
                                               (False, "pixel_size", True), (True, "pixel_size", True)])
def test_a_render_carries_camera_ray_cones_only_where_a_program_reads_them(bump, wire, reads):
    """rays.cones_read (the compiled kernel's ChunkParams.cones): a render needs its camera rays' cones where one of its
    programs holds a Bump (its step is the ray's footprint) or a Pixel Size Wireframe (its width is), not for plain
    Diffuse materials, a texture that reads no footprint (a sine of x into the colour) or a Wireframe in scene units."""
    from core.integrators.rays import cones_read
    scene = with_cone_readers(lit_scene(LIGHTS["sun"]), bump, wire)
    settings = RenderSettings(width=8, height=8, samples=1)
    assert cones_read(render.prepare(scene, settings)) == reads
    assert cones_read(render.prepare(lit_scene(LIGHTS["sun"]), settings)) is False


@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_skipping_the_camera_ray_cones_of_a_scene_that_reads_none_changes_no_pixel(integrator, monkeypatch):
    """A scene no program of which reads a ray's cone (Diffuse surfaces, a sine texture, a Wireframe in scene units)
    renders bit for bit the same in the compiled kernel whether its camera rays carry their cones or not
    (ChunkParams.cones forced on by rays.cones_read)."""
    from core.integrators import rays
    scene = with_cone_readers(lit_scene(LIGHTS["area_rect"]), bump=False, wire="world")
    settings = RenderSettings(width=24, height=16, samples=2, integrator=integrator, max_bounces=2, kernels="compiled")
    assert rays.cones_read(render.prepare(scene, settings)) is False
    skipped = render.render(scene, settings)
    monkeypatch.setattr(rays, "cones_read", lambda ctx: True)
    carried = render.render(scene, settings)
    assert skipped.stats.kernels == carried.stats.kernels == "compiled"
    np.testing.assert_array_equal(skipped.image, carried.image)


@pytest.mark.parametrize("integrator", ["direct", "path"])
@pytest.mark.parametrize("width", [1.0, 0.3])
def test_a_bump_in_the_compiled_kernel_differences_its_height_over_the_camera_rays_footprint(integrator, width,
                                                                                              monkeypatch):
    """The compiled kernel's camera rays carry their cones where a Bump reads them (rays.cones_read): a flat plane
    facing up under an orthographic camera 2 wide (8 pixels: each camera ray's footprint f = 1/4), a white Diffuse
    whose normal is a Bump (Distance D = 1/2, Filter Width w) of the height sin(4 x), lit by a sun of strength pi
    straight down, is the bumped normal's z: Cycles steps both x by s = f w / sqrt 2 (dPdx, dPdy = f a, f b along
    make_orthonormals of z), so z = w f / sqrt((w f)^2 + 2 D^2 (sin 4 (x + s) - sin 4 x)^2) (tests/test_input_nodes.py's
    closed form, for any footprint). A Gaussian filter 1/10000 of a pixel wide keeps each jittered sample within
    1.5e-4 pixels of its pixel's centre: the image is the closed form there within that times its slope. Without the
    cones (a Bump then steps along the triangle's edges) it would be off by far more."""
    from conftest import ortho_down
    from core.integrators import rays
    from core.materials import Material
    from core.materials.graph import GraphNode, Link
    size, f, D = 8, 0.25, 0.5
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("GEOMETRY", {}, {}), "Position")}), "X")
    height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": Link(GraphNode(
        "MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 4.0}), "Value")}), "Value")
    normal = Link(GraphNode("BUMP", {"invert": False, "filter_width": width},
                            {"Strength": 1.0, "Distance": D, "Height": height}), "Normal")
    scene = Scene(camera=ortho_down(height=10.0, scale=2.0))
    scene.materials.append(Material(name="Bumped", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {"color": np.ones(3),
                                                                                        "normal": normal})]))
    scene.add_mesh(primitives.plane(12.0), materials=np.array([0]))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=math.pi))
    settings = RenderSettings(width=size, height=size, samples=4, kernels="compiled", integrator=integrator,
                              max_bounces=0, pixel_filter="GAUSSIAN", filter_width=1e-4)
    result = render.render(scene, settings)
    assert result.stats.kernels == "compiled"
    s = f * width / math.sqrt(2.0)

    def z(x):
        """The bumped normal's z at x (the closed form)."""
        return width * f / np.sqrt((width * f) ** 2 + 2.0 * D * D * (np.sin(4.0 * (x + s)) - np.sin(4.0 * x)) ** 2)

    xs = -1.0 + (np.arange(size) + 0.5) * 2.0 / size
    fine = np.linspace(-1.5, 1.5, 300001)
    tolerance = np.abs(np.gradient(z(fine), fine)).max() * 1.5e-4 * 2.0 / size + 1e-6
    expected = np.tile(z(xs), (size, 1))
    np.testing.assert_allclose(result.image[..., 0], expected, rtol=0.0, atol=tolerance)
    monkeypatch.setattr(rays, "cones_read", lambda ctx: False)
    skipped = render.render(scene, settings).image[..., 0]
    assert np.abs(skipped - expected).max() > 100.0 * tolerance


def test_a_displacement_and_bump_bumps_over_the_unmoved_surface_alike_in_both_kernels():
    """Displacement and Bump: the floor and box move along z by a sine of the world x and their bump (the same offset
    as a height) is evaluated over the surface before it moved and in object space (graph.undisplaced_point: the
    corners and normals kept by core/geometry/displacement.py), the Python reference and the compiled kernel alike."""
    from core.materials import Material
    from core.materials.graph import GraphNode, Link
    scene = lit_scene(LIGHTS["sun"])
    position = Link(GraphNode("GEOMETRY", {}, {}), "Position")
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": position}), "X")
    wave = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": Link(GraphNode(
        "MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 5.0}), "Value")}), "Value")
    offset = Link(GraphNode("COMBINE_XYZ", {}, {"X": 0.0, "Y": 0.0, "Z": wave}), "Vector")
    offset = Link(GraphNode("VECTOR_MATH", {"operation": "SCALE"}, {"Vector": offset, "Scale": 0.2}), "Vector")
    height = Link(GraphNode("VECTOR_MATH", {"operation": "DOT_PRODUCT"},
                            {"Vector": offset, "Vector_001": Link(GraphNode("GEOMETRY", {}, {}), "Normal")}), "Value")
    normal = Link(GraphNode("BUMP", {"invert": False, "filter_width": 0.1, "undisplaced": True},
                            {"Strength": 1.0, "Distance": 1.0, "Height": height}), "Normal")
    scene.materials[0] = Material(name="Waves", nodes=[("DIFFUSE", (0.8, 0.7, 0.6),
                                                        {"color": np.array([0.8, 0.7, 0.6])})], normal=normal,
                                  displacement=offset, displacement_method="BOTH")
    settings = RenderSettings(width=48, height=32, samples=2, light_samples=1)
    compiled, reference = compare_paths(scene, settings)
    # (within 1e-4: the kernels' bumped waves differ by 4.4e-5 at most with the bump over the moved surface too)
    np.testing.assert_allclose(compiled.image, reference.image, rtol=0.0, atol=1e-4)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("tilt", [30.0, 60.0])
def test_bsdf_samples_below_the_face_are_refused_as_cycles_refuses_them(kernels, tilt):
    """A Lambert quad of albedo rho whose shading normal leans theta from its face, alone under a world of radiance L,
    seen from above by BSDF samples alone: a direction of N's cosine lobe below the face is no sample (Cycles'
    bsdf_diffuse_sample, closures.sampled_across_face), so the quad is rho L (1 + cos theta) / 2, the share of the lobe
    above the face (the projected area outside the ellipse the face's plane cuts from the disk), in both kernels;
    those directions used to go down through the quad to the world: rho L."""
    from core.lights.world import World
    from core.scene import Mesh
    theta, rho, L = math.radians(tilt), 0.5, 2.0
    scene = Scene(camera=Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.001, 0.0), fov=math.radians(30)))
    scene.add_material((rho, rho, rho))
    quad = primitives.plane(20.0)
    N = np.array([math.sin(theta), 0.0, math.cos(theta)])
    scene.add_mesh(Mesh(quad.vertices, quad.triangles, smooth=np.ones(2, bool),
                        corner_normals=np.broadcast_to(N, (2, 3, 3)).copy()), materials=np.array([0]))
    scene.world = World(color=np.full(3, L), camera=True, lights=True)
    settings = RenderSettings(width=8, height=8, samples=256, light_sampling="bsdf", kernels=kernels)
    image = render.render(scene, settings).image[..., :3]
    share = (1.0 + math.cos(theta)) / 2.0
    # (each sample brings rho L or nothing: the mean of 16384 Bernoulli draws, within 4 standard deviations)
    sigma = math.sqrt(share * (1.0 - share) / image[..., 0].size / settings.samples)
    assert abs(image.mean() / (rho * L) - share) < 4.0 * sigma + 1e-9
