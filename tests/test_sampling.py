"""Sample patterns: stratified in every power-of-two block, unbiased, reproducible, decorrelated."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core.sampling import sobol as sampling
from core.render import render
from core.scene import PointLight, RenderSettings


def cells_hit(points: np.ndarray, columns_log2: int, rows_log2: int) -> np.ndarray:
    """Return how many points fall in each cell of a 2^a x 2^b grid: (2^a * 2^b,) int64."""
    columns, rows = 1 << columns_log2, 1 << rows_log2
    cell = (points[:, 0] * columns).astype(np.int64) * rows + (points[:, 1] * rows).astype(np.int64)
    return np.bincount(cell, minlength=columns * rows)


def test_reverse_bits_mirrors_all_32_bits():
    """reverse_bits(x) reads x's binary digits backwards."""
    x = np.random.default_rng(1).integers(0, 2 ** 32, 500, dtype=np.uint64).astype(np.uint32)
    expected = [int(f"{int(value):032b}"[::-1], 2) for value in x]
    assert sampling.reverse_bits(x).tolist() == expected


def test_sobol_y_xors_one_direction_number_per_set_bit():
    """Sobol's second dimension: v_0 = 1/2, v_(k+1) = v_k XOR (v_k >> 1), y(i) = XOR of v_k over i's set bits."""
    directions = [0x80000000]
    for _ in range(31):
        directions.append(directions[-1] ^ (directions[-1] >> 1))
    random = np.random.default_rng(5).integers(0, 2 ** 32, 2000, dtype=np.uint64)
    index = [1, 2, 3, 7, 255, 256, 1000, 65537, 2 ** 31 + 5, 2 ** 32 - 1] + [int(i) for i in random]
    expected = []
    for i in index:
        word = 0
        for bit in range(32):
            if i >> bit & 1:
                word ^= directions[bit]
        expected.append(word)
    assert sampling.sobol_y(np.array(index, np.uint32)).tolist() == expected


@pytest.mark.parametrize("seed", [0, 1, 0xDEADBEEF])
def test_owen_scramble_is_a_bijection_that_keeps_dyadic_intervals_together(seed):
    """Owen scrambling permutes the 2^k aligned intervals of [0, 1) among themselves, at every k."""
    values = np.arange(1 << 12, dtype=np.uint32) << np.uint32(20)      # 4096 points, one per 1/4096 interval
    scrambled = sampling.owen_scramble(values, np.uint32(seed))
    for k in (1, 4, 12):
        # Points sharing their first k digits (one interval of length 2^-k) still share them.
        before = values >> np.uint32(32 - k)
        after = scrambled >> np.uint32(32 - k)
        assert len(np.unique(after)) == 1 << k
        for interval in range(0, 1 << k, max(1, (1 << k) // 8)):
            assert len(np.unique(after[before == interval])) == 1


@pytest.mark.parametrize("m", [2, 3, 4, 6, 8])
def test_every_power_of_two_prefix_is_stratified_in_every_grid(m):
    """The first 2^m points put exactly one point in each cell of every 2^a x 2^(m-a) grid (a (0,m,2)-net)."""
    n = 1 << m
    for pixel in (0, 17, 123456):
        points = sampling.sample_2d(3, np.full(n, pixel), np.arange(n), dimension=0)
        for a in range(m + 1):
            assert (cells_hit(points, a, m - a) == 1).all()


def test_adaptive_passes_continue_one_pattern_so_their_union_stays_stratified():
    """Samples 8..15, or 16..31, of a pixel form a net of their own, and 0..31 together one of 32."""
    pixel = np.full(32, 42)
    points = sampling.sample_2d(5, pixel, np.arange(32), dimension=16)
    for block in (points[8:16], points[16:32]):
        m = int(np.log2(len(block)))
        assert (cells_hit(block, m // 2, m - m // 2) == 1).all()
    assert (cells_hit(points, 2, 3) == 1).all() and (cells_hit(points, 5, 0) == 1).all()


def test_points_are_uniform_over_the_square():
    """Over many pixels the points have the mean 1/2 and variance 1/12 of a uniform variable, per coordinate."""
    n = 200_000
    points = sampling.sample_2d(9, np.arange(n) // 16, np.arange(n) % 16, dimension=4)
    assert ((points >= 0.0) & (points < 1.0)).all()
    np.testing.assert_allclose(points.mean(axis=0), 0.5, atol=3e-3)
    np.testing.assert_allclose(points.var(axis=0), 1.0 / 12.0, atol=2e-3)
    # Any one sample index, across pixels, is uniform too (each pixel scrambles its pattern its own way).
    first = points[::16]
    np.testing.assert_allclose(first.mean(axis=0), 0.5, atol=1e-2)


def test_camera_and_light_patterns_are_uncorrelated():
    """A camera sample's sub-pixel position says nothing about where its light samples land on the light."""
    pixels, spp, count = 4000, 16, 4
    pixel = np.repeat(np.arange(pixels), spp)
    sample = np.tile(np.arange(spp), pixels)
    camera = sampling.sample_2d(1, pixel, sample, dimension=0)
    for j in range(count):
        light = sampling.sample_2d(1, pixel, sample * count + j, dimension=16)
        for a in range(2):
            for b in range(2):
                assert abs(np.corrcoef(camera[:, a], light[:, b])[0, 1]) < 0.02


def test_fast_pattern_equals_the_readable_one_bit_for_bit():
    """sample_2d (mirrored Sobol y, cancelled reversals) computes exactly what sample_2d_reference spells out."""
    pixel = np.repeat(np.arange(300), 40)
    index = np.tile(np.arange(40), 300) * 7 + 3
    for seed, dimension in ((0, 0), (5, 16), (123456, 21)):
        fast = sampling.sample_2d(seed, pixel, index, dimension)
        np.testing.assert_array_equal(fast, sampling.sample_2d_reference(seed, pixel, index, dimension))


def test_same_seed_same_points_other_seed_or_dimension_other_points():
    """The points depend only on (seed, pixel, index, dimension)."""
    pixel, index = np.arange(100), np.arange(100) % 7
    a = sampling.sample_2d(1, pixel, index, 3)
    assert np.array_equal(a, sampling.sample_2d(1, pixel, index, 3))
    assert not np.array_equal(a, sampling.sample_2d(2, pixel, index, 3))
    assert not np.array_equal(a, sampling.sample_2d(1, pixel, index, 4))


@pytest.mark.parametrize("count", [16, 12])
def test_stratum_centres_fill_every_stratum_once(count):
    """Without jitter: a square count fills each cell of the m x m grid once; any count each row and column once."""
    points = sampling.stratum_centres(np.arange(count), count)
    m = int(np.sqrt(count))
    if m * m == count:
        cells = (points[:, 0] * m).astype(int) * m + (points[:, 1] * m).astype(int)
        assert sorted(cells.tolist()) == list(range(count))
    else:
        assert sorted((points[:, 0] * count).astype(int).tolist()) == list(range(count))
        assert sorted((points[:, 1] * count).astype(int).tolist()) == list(range(count))


def test_adaptive_render_where_every_pixel_takes_every_pass_equals_the_uniform_render():
    """Passes continue each pixel's pattern: with a threshold nothing meets, adaptive = uniform, sample for sample."""
    from test_adaptive import lit_plane_scene
    scene = lit_plane_scene(edge_x=0.3)
    scene.lights.append(PointLight(position=np.array([0.0, 0.5, 1.0]), power=50.0, radius=0.3))
    uniform = RenderSettings(width=24, height=16, samples=32, light_samples=2, seed=4)
    adaptive = dataclasses.replace(uniform, adaptive=True, adaptive_threshold=1e-12)
    a = render(scene, uniform)
    b = render(scene, adaptive)
    # Every pixel with any spread takes every pass (only the empty, black ones stop: they are exact).
    full = b.stats.samples_per_pixel == 32
    assert full.mean() > 0.5 and b.stats.passes > 1
    assert (a.image[~full] == 0.0).all() or np.ptp(a.image[~full][..., :3]) == 0.0
    np.testing.assert_allclose(b.image, a.image, rtol=1e-5, atol=1e-6)
