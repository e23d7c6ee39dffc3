"""Sample patterns: every stratum used once, permutations are bijections, same seed same numbers."""
from __future__ import annotations

import numpy as np
import pytest

from core import sampling


@pytest.mark.parametrize("count", [1, 2, 3, 7, 16, 60, 64, 1000])
def test_permute_is_a_bijection_for_every_key(count):
    """permute(., count, key) maps 0..count-1 onto itself, for any key."""
    for key in (0, 1, 0xFFFFFFFF, 123456789):
        mapped = sampling.permute(np.arange(count), count, np.full(count, key))
        assert sorted(mapped.tolist()) == list(range(count))


def test_permute_differs_between_keys():
    """Different pixels (keys) deal the strata out in different orders, uniformly over the strata."""
    keys = np.arange(4000)
    first = sampling.permute(np.zeros(4000, np.int64), 16, keys)
    counts = np.bincount(first, minlength=16)
    assert counts.min() > 4000 / 16 * 0.7 and counts.max() < 4000 / 16 * 1.3


@pytest.mark.parametrize("count", [16, 12])
def test_stratified_points_fill_every_stratum_once(count):
    """A square count fills each cell of the m x m grid once; any count fills each row and column once."""
    pixel = np.full(count, 5)
    points = sampling.stratified_2d(3, pixel, np.arange(count), count, dimension=0)
    assert ((points >= 0) & (points < 1)).all()
    m = int(np.sqrt(count))
    if m * m == count:
        cells = (points[:, 0] * m).astype(int) * m + (points[:, 1] * m).astype(int)
        assert sorted(cells.tolist()) == list(range(count))
    else:
        assert sorted((points[:, 0] * count).astype(int).tolist()) == list(range(count))
        assert sorted((points[:, 1] * count).astype(int).tolist()) == list(range(count))


def test_same_seed_same_numbers_other_seed_other_numbers():
    """The numbers depend only on (seed, pixel, index, dimension)."""
    pixel, index = np.arange(100), np.arange(100) % 7
    a = sampling.uniform(1, pixel, index, 3)
    assert np.array_equal(a, sampling.uniform(1, pixel, index, 3))
    assert not np.array_equal(a, sampling.uniform(2, pixel, index, 3))
    assert not np.array_equal(a, sampling.uniform(1, pixel, index, 4))
