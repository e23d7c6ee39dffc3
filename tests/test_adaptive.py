"""Adaptive sampling (core/film/adaptive.py): samples go where pixels need them, and pixels stay unbiased."""
from __future__ import annotations

import math

import numpy as np

from conftest import ortho_down, sun_direction
from core.film import adaptive
from core.geometry import primitives
from core import render
from core.scene import RenderSettings, Scene, SunLight

ALBEDO = 0.8
SUN = 3.0


def lit_plane_scene(edge_x: float | None = None) -> Scene:
    """A plane under a sun at 60 degrees, seen straight down; with edge_x, the plane ends at x = edge_x."""
    scene = Scene(camera=ortho_down(scale=2.0))
    scene.add_material((ALBEDO, ALBEDO, ALBEDO))
    if edge_x is None:
        scene.add_mesh(primitives.plane(10.0))
    else:
        # The plane covers x < edge_x: pixels straddling the edge are partly black.
        width = edge_x + 5.0
        scene.add_mesh(primitives.plane(width, 10.0, center=(edge_x - 0.5 * width, 0.0, 0.0)))
    scene.lights.append(SunLight(sun_direction(60.0), strength=SUN))
    return scene


LIT = ALBEDO / math.pi * SUN * math.sin(math.radians(60.0))     # radiance of the lit plane


def test_pass_sizes_double_the_count_and_sum_to_samples():
    """A pixel that never converges gets exactly `samples`, each pass doubling what it had."""
    for samples in (1, 3, 4, 16, 64, 100, 128, 1000):
        sizes = adaptive.pass_sizes(samples)
        assert sum(sizes) == samples
        done = sizes[0]
        for size in sizes[1:]:
            assert size <= done
            done += size
    assert adaptive.pass_sizes(64) == [4, 4, 8, 16, 32]
    assert adaptive.pass_sizes(64, min_samples=16) == [16, 16, 32]


def test_relative_noise_is_the_standard_error_of_the_mean():
    """Samples 0 and 1 in equal parts: luminance mean 1/2, sample variance n/(4(n-1)), error sqrt(var/n)."""
    n = 8
    luminance = np.array([0.0, 1.0] * (n // 2))
    rgba = np.zeros((n, 4))
    rgba[:, :3] = luminance[:, None]            # grey: luminance equals each channel
    rgba[:, 3] = 1.0                            # opaque: alpha adds no noise
    noise = adaptive.PixelNoise(rgba.sum(axis=0)[None], np.array([[(luminance ** 2).sum(), float(n)]]), np.array([n]))
    variance = n / (4.0 * (n - 1))
    expected = math.sqrt(variance / n) / math.sqrt(0.25 + adaptive.DARK ** 2)
    assert math.isclose(adaptive.relative_noise(noise)[0], expected, rel_tol=1e-12)


def test_uniformly_lit_pixels_stop_after_the_first_pass():
    """A plane under a sun has the same radiance everywhere: no pixel is noisy, none gets a second pass."""
    settings = RenderSettings(width=24, height=24, samples=64, adaptive=True)
    result = render.render(lit_plane_scene(), settings)
    assert (result.stats.samples_per_pixel == adaptive.first_pass_size(64)).all()
    assert result.stats.passes == 1             # the first pass left nothing to do
    np.testing.assert_allclose(result.image[..., :3], LIT, rtol=1e-5)


def test_edge_pixels_get_all_samples_and_flat_ones_few():
    """Pixels that straddle the plane's edge are noisy and get every sample; far from it pixels stop early."""
    W = 32
    edge_x = 0.0 + 0.3 * (2.0 / W)              # inside pixel column W/2, 30% across it
    settings = RenderSettings(width=W, height=8, samples=64, adaptive=True)
    result = render.render(lit_plane_scene(edge_x), settings)
    counts = result.stats.samples_per_pixel
    edge_column = W // 2
    assert (counts[:, edge_column] == 64).all()
    # The edge column's neighbours contrast with it, so they go on, and so do theirs (grow): 3 columns each side.
    assert (counts[:, :edge_column - 3] == adaptive.first_pass_size(64)).all()
    assert (counts[:, edge_column + 3:] == adaptive.first_pass_size(64)).all()


def test_a_noiseless_pixel_beside_a_contrasting_one_gets_a_second_pass_only_after_the_first():
    """Two 4-sample pixels, black and lit, each with zero spread: by its noise neither needs more, but their
    contrast could hide a missed sliver of the edge, so after the first pass both go on (with their
    neighbours); once they have more than the first pass, only their noise decides."""
    W, H, first = 6, 1, 4
    noise = adaptive.PixelNoise(np.zeros((W * H, 4)), np.zeros((W * H, 2)), np.full(W * H, first))
    lit = np.arange(W) >= 3                                  # pixels 0-2 black, 3-5 lit
    noise.total[lit, :3] = first * LIT
    noise.total[:, 3] = first
    noise.squares[lit, 0] = first * LIT ** 2                 # luminance of a grey pixel = its value
    noise.squares[:, 1] = first
    pixels = np.arange(W)
    threshold = adaptive.automatic_threshold(64)
    assert len(adaptive.unconverged(pixels, noise, threshold, W, H)) == 0
    assert adaptive.unconverged(pixels, noise, threshold, W, H, first=first).tolist() == [1, 2, 3, 4]
    later = adaptive.PixelNoise(noise.total * 2, noise.squares * 2, noise.count * 2)
    assert len(adaptive.unconverged(pixels, later, threshold, W, H, first=first)) == 0
    # A small contrast, such as shading across a smooth surface, is no edge.
    smooth = adaptive.PixelNoise(noise.total.copy(), noise.squares.copy(), noise.count)
    smooth.total[~lit, :3] = first * LIT * 0.99
    smooth.squares[~lit, 0] = first * (LIT * 0.99) ** 2
    assert len(adaptive.unconverged(pixels, smooth, threshold, W, H, first=first)) == 0


def test_adaptive_edge_pixels_converge_to_the_covered_fraction():
    """The box-filtered value of an edge pixel is the lit radiance times the fraction the plane covers."""
    W = 32
    fraction = 0.3
    edge_x = fraction * (2.0 / W)               # the plane covers the left 30% of pixel column W/2
    settings = RenderSettings(width=W, height=16, samples=256, adaptive=True, seed=3)
    result = render.render(lit_plane_scene(edge_x), settings)
    edge = result.image[:, W // 2, 0]
    # 256 stratified samples (16 x 16 jittered) of a straight edge: error well below 1%.
    assert abs(edge.mean() - fraction * LIT) < 0.01 * LIT
    np.testing.assert_allclose(result.image[:, :W // 2 - 1, 0], LIT, rtol=1e-5)
    np.testing.assert_allclose(result.image[:, W // 2 + 1:, 0], 0.0, atol=1e-7)


def test_adaptive_render_spends_fewer_rays_than_uniform_at_the_same_maximum():
    """On an image with one edge, adaptive sampling traces a fraction of the uniform render's rays."""
    scene = lit_plane_scene(0.01)
    uniform = render.render(scene, RenderSettings(width=32, height=32, samples=64))
    adaptive_result = render.render(scene, RenderSettings(width=32, height=32, samples=64, adaptive=True))
    assert adaptive_result.stats.rays < 0.25 * uniform.stats.rays
    # They agree away from the edge exactly; at the edge each 8 x 8 jittered pattern of a straight edge
    # can be off by up to about one column of strata (1/8 of the pixel).
    assert np.abs(adaptive_result.image - uniform.image).max() < 0.125 * LIT


def speck_scene(fraction: float) -> Scene:
    """A 3 x 3 pixel view of a lit square speck covering `fraction` of the centre pixel, on black."""
    pixel = 0.25                                 # ortho scale 0.75 over 3 pixels
    scene = Scene(camera=ortho_down(scale=3 * pixel))
    scene.add_material((ALBEDO, ALBEDO, ALBEDO))
    scene.add_mesh(primitives.plane(math.sqrt(fraction) * pixel, center=(0.03, -0.02, 0.0)))
    scene.lights.append(SunLight(sun_direction(60.0), strength=SUN))
    return scene


def test_a_speck_smaller_than_a_first_pass_stratum_is_found_as_samples_grow():
    """A speck covering 5% of a pixel: a 4-sample first pass misses it most of the time (adaptive sampling's
    bias, documented), but the first pass grows with the budget, so at 1024 samples (a 64-sample first pass,
    strata of 1/64 pixel) every render finds it and the pixel converges to 5% of the lit radiance."""
    fraction = 0.05
    scene = speck_scene(fraction)
    values = [render.render(scene, RenderSettings(width=3, height=3, samples=1024, adaptive=True, seed=seed)).image[1, 1, 0]
              for seed in range(8)]
    assert all(v > 0 for v in values)            # found every time
    assert abs(np.mean(values) - fraction * LIT) < 0.05 * fraction * LIT


def test_a_black_edge_over_a_transparent_film_is_refined_by_its_alpha():
    """A black plane's edge over a transparent film: no brightness varies, only coverage (alpha), and
    that alone sends the edge pixels to the full budget, where alpha converges to the covered fraction."""
    W, fraction = 32, 0.3
    scene = lit_plane_scene(fraction * (2.0 / W))
    scene.materials[0].base_color = np.zeros(3)
    settings = RenderSettings(width=W, height=8, samples=256, adaptive=True, transparent_background=True, seed=5)
    result = render.render(scene, settings)
    assert (result.stats.samples_per_pixel[:, W // 2] == 256).all()
    assert abs(result.image[:, W // 2, 3].mean() - fraction) < 0.01
