"""Deterministic random numbers and sample patterns.

Every random number is a hash of (seed, pixel, sample, dimension), so an image
depends only on the seed: not on the chunk size, the thread count or the
order in which chunks finish. That makes renders reproducible and lets tests
compare images exactly.

Camera and light samples come from one progressive pattern per pixel (`sample_2d`):
a scrambled Sobol (0,2)-sequence. Its first 2^m points are stratified in every
way a set of 2^m points can be (one point in each of the 2^m cells of any grid
of 2^a x 2^b cells with a + b = m), and every later block of 2^m points is too. So
adaptive sampling (core/film/adaptive.py), which adds samples pass by pass, gets the
same well-spread pattern a uniform render of the same count gets: its passes
continue one sequence instead of starting new ones.
"""
from __future__ import annotations

import math

import numpy as np

from ..native import schema

_U32 = np.uint32


def hash_u32(x: np.ndarray) -> np.ndarray:
    """Return a well-mixed uint32 hash of each element (the PCG output permutation).

    x: (n,) uint32 -> (n,) uint32
    """
    with np.errstate(over="ignore"):
        state = x.astype(_U32) * _U32(747796405) + _U32(2891336453)
        word = ((state >> ((state >> _U32(28)) + _U32(4))) ^ state) * _U32(277803737)
        return (word >> _U32(22)) ^ word


def stratum_centres(index: np.ndarray, count: int) -> np.ndarray:
    """Return the centre of the index-th of `count` strata of the unit square (the unjittered pattern).

    A perfect-square count is an m x m grid, stratum (index mod m, index div m); any other
    count has one stratum per row and per column (a Latin square), paired by a golden-ratio lattice.
    index: (n,) int64 with 0 <= index < count -> (n, 2) float64 in (0, 1)
    """
    index = np.asarray(index, dtype=np.int64)
    m = math.isqrt(count)
    if m * m == count:
        x, y = index % m, index // m
        return np.stack([(x + 0.5) / m, (y + 0.5) / m], axis=-1)
    step = max(1, round(count * 0.6180339887498949))
    while math.gcd(step, count) != 1:
        step += 1
    row = (index * step) % count
    return np.stack([(index + 0.5) / count, (row + 0.5) / count], axis=-1)


# ---------------------------------------------------------------------------
# Progressive pattern: Owen-scrambled, shuffled Sobol (0,2)-sequence
# (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020).
# ---------------------------------------------------------------------------

# The five ways to cut a 32-bit word into groups of 2^k bits: (group width 2^k, mask of the
# groups in even position, i.e. of the bit positions whose bit k is 0).
_BIT_GROUPS = tuple((_U32(1 << k), _U32(mask)) for k, mask in
                    enumerate((0x55555555, 0x33333333, 0x0F0F0F0F, 0x00FF00FF, 0x0000FFFF)))


def reverse_bits(x: np.ndarray) -> np.ndarray:
    """Return each uint32 with its 32 bits in reverse order: (n,) uint32 -> (n,) uint32 (a new array)."""
    x = np.array(x, dtype=_U32)
    low = np.empty_like(x)
    for s, m in _BIT_GROUPS:
        # Swap neighbouring groups of s bits: x = ((x >> s) & m) | ((x & m) << s), in place.
        np.right_shift(x, s, out=low)
        low &= m
        x &= m
        x <<= s
        x |= low
    return x


def _laine_karras(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Return a permutation of uint32s in which each output bit depends only on the seed and the lower input bits."""
    with np.errstate(over="ignore"):
        x = x + np.asarray(seed, dtype=_U32)
        for constant in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
            x ^= x * _U32(constant)
    return x


def owen_scramble(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Return x with each bit flipped pseudo-randomly, depending only on the seed and the bits above it.

    Read as a binary fraction, that is Owen's nested scrambling: each half of [0, 1) is
    mirrored or not, then each quarter within it, and so on, so that points that were
    stratified stay stratified. The flips come from the Laine-Karras hash on the reversed
    bits (Burley's constants). x, seed: (n,) uint32 (broadcastable) -> (n,) uint32
    """
    return reverse_bits(_laine_karras(reverse_bits(x), seed))


def _sobol_y_mirrored(index: np.ndarray) -> np.ndarray:
    """Return reverse_bits(sobol_y(index)) in five shift-and-XOR steps: (n,) uint32 -> (n,) uint32.

    Sobol's second direction numbers are the rows of Pascal's triangle mod 2, and C(m, j) is odd
    exactly when the bits of j are a subset of the bits of m (Lucas' theorem). So bit j of the
    mirrored y is the XOR of the index's bits m over all m that contain j: a "superset sum",
    computed one bit of j at a time (step k adds bit m = j | 2^k into every j without bit k).
    """
    y = np.array(index, dtype=_U32)
    higher = np.empty_like(y)
    for shift, without_bit in _BIT_GROUPS:
        np.right_shift(y, shift, out=higher)
        higher &= without_bit
        y ^= higher
    return y


def sobol_y(index: np.ndarray) -> np.ndarray:
    """Return Sobol's second dimension of each index, a 32-bit binary fraction: (n,) uint32 -> (n,) uint32.

    It XORs together one direction number per set bit of the index; the direction numbers
    start at 1/2 and each is the one before XOR itself shifted right by one digit.
    """
    return reverse_bits(_sobol_y_mirrored(index))


def sobol_2d(index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the first two Sobol dimensions of each index, as 32-bit binary fractions.

    x is the van der Corput sequence (the index's bits mirrored behind the binary point), y is `sobol_y`.
    index: (n,) uint32 -> x, y: (n,) uint32
    """
    return reverse_bits(index), sobol_y(index)


def _combine(seed: np.ndarray, value: int) -> np.ndarray:
    """Return a seed derived from `seed` and a small constant (cheap, for seeds that are hashes already)."""
    with np.errstate(over="ignore"):
        return seed ^ (_U32(value) + (seed << _U32(6)) + (seed >> _U32(2)))


def _pixel_key(seed: int, pixel: np.ndarray, dimension: int) -> np.ndarray:
    """Return the scrambling key of each pixel's pattern for (seed, dimension): (n,) uint32."""
    stream = hash_u32(np.array([(seed * 0x9E3779B9 + dimension * 0x85EBCA6B) & 0xFFFFFFFF], dtype=_U32))
    return hash_u32(np.asarray(pixel).astype(_U32) ^ stream)


def sample_2d_reference(seed: int, pixel: np.ndarray, index: np.ndarray, dimension: int) -> np.ndarray:
    """The readable form of `sample_2d`, step by step (the tests check that both agree bit for bit)."""
    key = _pixel_key(seed, pixel, dimension)
    shuffled = owen_scramble(np.asarray(index).astype(_U32), key)       # 1. shuffle the order
    x, y = sobol_2d(shuffled)                                           # 2. the Sobol point
    x = owen_scramble(x, _combine(key, 1))                              # 3. scramble each coordinate
    y = owen_scramble(y, _combine(key, 2))
    return np.stack([x, y], axis=-1) / 2.0 ** 32


def sample_2d(seed: int, pixel: np.ndarray, index: np.ndarray, dimension: int) -> np.ndarray:
    """Return the index-th point of the pixel's own progressive pattern in the unit square.

    Each (seed, pixel, dimension) has its own scrambling of one Sobol (0,2)-sequence: the
    order of its points is shuffled (by an Owen scramble of the index, which keeps each
    aligned block of 2^m indices together, so every such block is still stratified) and
    each coordinate is Owen-scrambled. Points 0..2^m-1, and each aligned block after them,
    put one point in each of 2^m equal cells of any power-of-two grid.
    pixel, index: (n,) int64 (index >= 0) -> (n, 2) float64 in [0, 1)
    """
    key = _pixel_key(seed, pixel, dimension)
    shuffled = owen_scramble(np.asarray(index).astype(_U32), key)
    # Each coordinate c is owen_scramble(c) = reverse(laine_karras(reverse(c))). For x, the van der
    # Corput reversal cancels the first reverse; for y, _sobol_y_mirrored gives reverse(sobol_y) directly.
    x = reverse_bits(_laine_karras(shuffled, _combine(key, 1)))
    y = reverse_bits(_laine_karras(_sobol_y_mirrored(shuffled), _combine(key, 2)))
    # Column-major (n, 2), each coordinate a contiguous column (core/vectors.py).
    out = np.empty((2, len(x)))
    np.multiply(x, 1.0 / 2.0 ** 32, out=out[0])
    np.multiply(y, 1.0 / 2.0 ** 32, out=out[1])
    return out.T


Sample2dArgs = schema.function("primer_sample_2d", "sample_2d_rows", schema.record(
    "Sample2dArgs", "primer_sample_2d's arguments: sample_2d for n samples.", [
        ("seed", schema.I64, ""),
        ("pixel", schema.ptr(schema.I64), "(n,)"),
        ("index", schema.ptr(schema.I64), "(n,)"),
        ("dimension", schema.I64, ""),
        ("n", schema.I64, ""),
        ("out", schema.out(schema.F64), "(n, 2)"),
    ]))


def compiled_sample_2d(seed: int, pixel: np.ndarray, index: np.ndarray, dimension: int) -> np.ndarray:
    """sample_2d in C (core/sampling/sobol.c): pixel, index (n,) int64 -> (n, 2) float64, bit for bit the same."""
    from ..native import library
    pixel, index = library.contiguous(pixel, np.int64), library.contiguous(index, np.int64)
    out = np.empty((len(pixel), 2))
    library.call("primer_sample_2d", Sample2dArgs(seed=int(seed), pixel=pixel, index=index, dimension=int(dimension),
                                                  n=len(pixel), out=out))
    return out
