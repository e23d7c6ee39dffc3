"""The pixel filter: where in and around its pixel a camera sample looks, as Cycles places it.

A renderer that *splats* adds each sample to every pixel its filter reaches, weighted by the filter. Cycles
does not: it draws each sample's position from the filter itself (importance sampling), adds it to its own
pixel only, and gives every sample the weight 1. A pixel's value is then the mean of its samples, and their
positions are spread around its centre with the filter's density, reaching into the neighbours for a filter
wider than a pixel. Primer does the same.

The filter is separable: x and y offsets are drawn independently from the same one-dimensional density f.
The draw goes through a table, Cycles' inverse CDF of f (`scene/film.cpp` filter_table and
`util/math_cdf.*`): FILTER_TABLE_SIZE entries, read by linear interpolation at the sample's uniform number u
(`kernel/util/lookup_table.h`), one table per filter type and width. The densities, over x measured from the
pixel's centre, for a Filter Width w (Render > Film > Pixel Filter):

* Box:             1 on |x| <= w / 2 (Blender always gives Cycles' box the width 1: the pixel itself)
* Gaussian:        exp(-8 x^2 / w^2) on |x| <= 1.5 w (a standard deviation of w / 4, cut at 6 of them)
* Blackman-Harris: the four-term Blackman-Harris window over |x| <= w (0.35875 - 0.48829 cos a + 0.14128 cos 2a
                   - 0.01168 cos 3a, a = 2 pi (x / (2 w) + 1 / 2))

The table is built the way Cycles builds it, in float32: the CDF of f sampled at FILTER_TABLE_SIZE - 1 points
of [0, half-width] (a left Riemann sum), inverted over one half and mirrored onto the other. Two of Cycles'
quirks are kept because they are what Cycles renders: the inversion interpolates with the slope of the CDF
interval *after* the one holding u, and the table's last entry is never written and stays 0, so the last
1/1023 of the u range maps to offsets between the far edge and 0 (about 0.1% of samples land at points
spread over the footprint rather than at its edge).

A Box 1 pixel wide is the identity: the sample's uniform point in its pixel is its position (Cycles' table
for it is that line up to float32 rounding, with its last 1/1023 folded back over the same pixel, which moves
no sample out of the uniform distribution). Primer reads no table then, so renders with it are those of a
renderer without a pixel filter, bit for bit.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..native import schema

__all__ = ["FILTER_TABLE_SIZE", "PIXEL_FILTERS", "PixelFilter", "filter_density", "filter_table", "offsets"]

FILTER_TABLE_SIZE = schema.constant("FILTER_TABLE_SIZE", 1024, "entries of the pixel filter's table (Cycles' size)")
PIXEL_FILTERS = ("BOX", "GAUSSIAN", "BLACKMAN_HARRIS")

_F32 = np.float32


def _box(x: np.ndarray, width: np.float32) -> np.ndarray:
    """Return the box filter's value 1 at each x ((n,) float32)."""
    return np.ones_like(x)


def _gaussian(x: np.ndarray, width: np.float32) -> np.ndarray:
    """Return Cycles' Gaussian exp(-2 (6 x / width)^2) at x ((n,) float32; width the table's, 3 Filter Widths)."""
    v = x * (_F32(6.0) / width)
    return np.exp(_F32(-2.0) * v * v)


def _blackman_harris(x: np.ndarray, width: np.float32) -> np.ndarray:
    """Return the Blackman-Harris window at x ((n,) float32; width the table's, 2 Filter Widths, the window's span)."""
    a = _F32(2.0 * math.pi) * (x / width + _F32(0.5))
    return (_F32(0.35875) - _F32(0.48829) * np.cos(a) + _F32(0.14128) * np.cos(_F32(2.0) * a)
            - _F32(0.01168) * np.cos(_F32(3.0) * a))


# Each filter: its function of (x, table width) and the table width in Filter Widths (Cycles' filter_table).
_FILTERS = {"BOX": (_box, 1.0), "GAUSSIAN": (_gaussian, 3.0), "BLACKMAN_HARRIS": (_blackman_harris, 2.0)}


def filter_density(kind: str, width: float, x: np.ndarray) -> np.ndarray:
    """Return the filter's normalised density (integral 1) at offsets x from the pixel's centre, in float64.

    The closed forms of the module docstring; 0 outside the footprint. x: (n,) float64 -> (n,) float64.
    """
    x = np.asarray(x, np.float64)
    half = 0.5 * width * _FILTERS[kind][1]
    inside = np.abs(x) <= half
    if kind == "BOX":
        return np.where(inside, 1.0 / width, 0.0)
    if kind == "GAUSSIAN":
        sigma = width / 4.0
        norm = sigma * math.sqrt(2.0 * math.pi) * math.erf(half / (sigma * math.sqrt(2.0)))
        return np.where(inside, np.exp(-0.5 * (x / sigma) ** 2) / norm, 0.0)
    a = 2.0 * math.pi * (x / (2.0 * width) + 0.5)
    window = 0.35875 - 0.48829 * np.cos(a) + 0.14128 * np.cos(2 * a) - 0.01168 * np.cos(3 * a)
    return np.where(inside, window / (0.35875 * 2.0 * width), 0.0)   # the cosines integrate to 0 over a period


@functools.lru_cache(maxsize=8)
def filter_table(kind: str, width: float) -> np.ndarray:
    """Return Cycles' inverse-CDF table of the filter: (FILTER_TABLE_SIZE,) float32 positions in the pixel, read-only.

    Entry k is where the sample with u = k / (FILTER_TABLE_SIZE - 1) lands, in pixels from the pixel's corner
    (0.5 is its centre). Built as Cycles' filter_table -> util_cdf_inverted(make_symmetric) does, in float32.
    """
    function, scale = _FILTERS[kind]
    table_width = _F32(width) * _F32(scale)
    size = FILTER_TABLE_SIZE
    span = table_width * _F32(0.5)                               # the CDF covers [0, half the table width]
    # 1. The CDF: size - 1 samples of f, cdf[0] = 0, cdf[i + 1] = cdf[i] + |f(x_i)|, normalised, last entry 1.
    points = size - 1
    i = np.arange(points, dtype=_F32)
    x = _F32(0.0) + span * i / _F32(points - 1)
    cdf = np.zeros(points + 1, _F32)
    cdf[1:] = np.cumsum(np.abs(function(x, table_width)), dtype=_F32)
    total = cdf[points]
    cdf *= _F32(0.0) if total == 0 else _F32(1.0) / total
    cdf[points] = _F32(1.0)
    # 2. Its inverse over one half, mirrored: u = j / half at entries half +- j (the - side written last).
    half = (size - 1) // 2
    u = np.arange(half + 1, dtype=_F32) / _F32(half)
    index = np.searchsorted(cdf, u, side="right")                # the first CDF value above u
    last = index >= len(cdf) - 1
    inner = np.minimum(index, len(cdf) - 2)
    with np.errstate(divide="ignore", invalid="ignore"):          # (the last entries' t is not used)
        t = np.where(last, _F32(0.0), (u - cdf[inner]) / (cdf[inner + 1] - cdf[inner])).astype(_F32)
    index = np.where(last, len(cdf) - 1, index).astype(_F32)
    y = ((index + t) / _F32(size - 1)) * (_F32(2.0) * span)
    table = np.zeros(size, _F32)                                 # entry size - 1 stays 0, as in Cycles
    j = np.arange(half + 1)
    table[half + j] = _F32(0.5) * (_F32(1.0) + y)
    table[half - j] = _F32(0.5) * (_F32(1.0) - y)
    table.setflags(write=False)
    return table


def offsets(table: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Return the positions in the pixel (from its corner, in pixels) of samples with uniform numbers u.

    Cycles' lookup_table_read: u clamped to [0, 1] scaled to the table, linear between neighbouring entries
    (the entry itself where u falls on one). table: (FILTER_TABLE_SIZE,) float64; u: (n, ...) float64, same shape out.
    """
    size = len(table)
    x = np.clip(u, 0.0, 1.0) * (size - 1)
    index = np.minimum(x.astype(np.int64), size - 1)
    following = np.minimum(index + 1, size - 1)
    t = x - index
    return np.where(t == 0.0, table[index], (1.0 - t) * table[index] + t * table[following])


@dataclass(frozen=True)
class PixelFilter:
    """A pixel filter: its type (PIXEL_FILTERS) and width in pixels (Render > Film > Pixel Filter)."""

    kind: str = "BOX"
    width: float = 1.0

    def __post_init__(self) -> None:
        """Check the type and the width."""
        if self.kind not in PIXEL_FILTERS:
            raise ValueError(f"pixel filter must be one of {PIXEL_FILTERS}, got {self.kind!r}")
        if not (self.width > 0.0 and math.isfinite(self.width)):
            raise ValueError(f"pixel filter width must be positive, got {self.width!r}")

    @property
    def is_identity(self) -> bool:
        """Whether samples stay where they are drawn in their pixel: a Box 1 pixel wide (no table)."""
        return self.kind == "BOX" and self.width == 1.0

    @property
    def reach(self) -> float:
        """How far (pixels) beyond its pixel's edge a sample may land: half the footprint less half a pixel."""
        return max(0.0, 0.5 * self.width * _FILTERS[self.kind][1] - 0.5)

    def table(self) -> np.ndarray:
        """Return the filter's inverse-CDF table, (FILTER_TABLE_SIZE,) float64 (exact float32 values)."""
        return filter_table(self.kind, float(self.width)).astype(np.float64)

    def positions(self, u: np.ndarray) -> np.ndarray:
        """Return the samples' positions relative to their pixel's corner: u (n, 2) float64 -> (n, 2) float64."""
        return u if self.is_identity else offsets(self.table(), u)
