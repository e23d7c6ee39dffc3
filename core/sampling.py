"""Deterministic random numbers and stratified sample patterns.

Every random number is a hash of (seed, pixel, sample, dimension), so an image
depends only on the seed: not on the chunk size, the thread count or the
order in which chunks finish. That makes renders reproducible and lets tests
compare images exactly.
"""
from __future__ import annotations

import math

import numpy as np

_U32 = np.uint32


def hash_u32(x: np.ndarray) -> np.ndarray:
    """Return a well-mixed uint32 hash of each element (the PCG output permutation).

    x: (n,) uint32 -> (n,) uint32
    """
    with np.errstate(over="ignore"):
        state = x.astype(_U32) * _U32(747796405) + _U32(2891336453)
        word = ((state >> ((state >> _U32(28)) + _U32(4))) ^ state) * _U32(277803737)
        return (word >> _U32(22)) ^ word


def uniform(seed: int, pixel: np.ndarray, index: np.ndarray, dimension: int) -> np.ndarray:
    """Return one uniform number in [0, 1) per element, fixed by (seed, pixel, index, dimension).

    pixel, index: (n,) integer arrays (broadcastable); returns (n,) float64.
    """
    stream = hash_u32(np.array([(seed * 0x9E3779B9 + dimension * 0x85EBCA6B) & 0xFFFFFFFF], dtype=_U32))
    key = hash_u32(np.asarray(pixel).astype(_U32) ^ stream)
    key = hash_u32(key ^ np.asarray(index).astype(_U32))
    return (key >> _U32(8)).astype(np.float64) * (1.0 / (1 << 24))


def stratified_2d(seed: int, pixel: np.ndarray, index: np.ndarray, count: int, dimension: int,
                  jitter: bool = True) -> np.ndarray:
    """Return the index-th of `count` stratified points in the unit square, per pixel.

    A perfect-square count uses a jittered m x m grid; any other count uses
    Latin-hypercube strata (one per row and one per column, paired by a golden-ratio
    lattice with a random offset per pixel). Without jitter, points sit at stratum centres.
    pixel, index: (n,) int64 with 0 <= index < count; returns (n, 2) float64 in [0, 1).
    """
    index = np.asarray(index, dtype=np.int64)
    u = uniform(seed, pixel, index, dimension) if jitter else np.full(index.shape, 0.5)
    v = uniform(seed, pixel, index, dimension + 1) if jitter else np.full(index.shape, 0.5)
    m = math.isqrt(count)
    if m * m == count:
        # Jittered grid: stratum (index mod m, index div m).
        x = (index % m + u) / m
        y = (index // m + v) / m
    else:
        # Latin hypercube: column `index`, row from a shifted rank-1 lattice.
        step = max(1, round(count * 0.6180339887498949))
        while math.gcd(step, count) != 1:
            step += 1
        shift = (uniform(seed, pixel, np.zeros_like(index), dimension + 2) * count).astype(np.int64) if jitter else 0
        row = (index * step + shift) % count
        x = (index + u) / count
        y = (row + v) / count
    return np.stack([x, y], axis=-1)


def permute(index: np.ndarray, count: int, key: np.ndarray) -> np.ndarray:
    """Return index mapped through a pseudo-random permutation of [0, count), a different one per key.

    An invertible mix of w-bit integers (xor with the key, odd multiplications and
    xor-shifts, each a bijection modulo 2^w), applied again while the result is
    still >= count ("cycle walking"), so that [0, count) maps onto itself.
    index: (n,) int64 in [0, count); key: (n,) integer -> (n,) int64
    """
    bits = max(1, int(count - 1).bit_length())
    mask = _U32((1 << bits) - 1)
    shift = _U32(max(1, bits // 2))
    key = hash_u32(np.asarray(key).astype(_U32))

    def mix(x: np.ndarray, k: np.ndarray) -> np.ndarray:
        with np.errstate(over="ignore"):
            x = (x ^ k) & mask
            x = (x * _U32(0x2C1B3C6D)) & mask
            x ^= x >> shift
            x = (x * _U32(0x297A2D39)) & mask
            x ^= x >> shift
            return (x + (k >> _U32(16))) & mask

    x = mix(np.asarray(index).astype(_U32), key)
    outside = np.flatnonzero(x >= count)
    while len(outside):
        x[outside] = mix(x[outside], key[outside])
        outside = outside[x[outside] >= count]
    return x.astype(np.int64)
