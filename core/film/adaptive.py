"""Adaptive sampling: spend camera samples only where pixels need them.

Most pixels of a direct-lighting image are easy. On a surface lit by a point,
spot or sun light without extent, the light is exact and the pixel varies only
a little across its area, so a handful of samples already gives its average.
Noise lives at object edges, shadow boundaries and under lights with extent.
So instead of `samples` rays in every pixel, Primer renders in passes:

1. every pixel gets a first, small pass of stratified samples;
2. each pixel's noise is estimated from the spread of its samples: the standard
   error of the mean, sqrt(variance / n), relative to the pixel's brightness;
3. pixels whose noise is above the threshold, and their neighbours (an edge that
   a pixel's few samples all missed usually shows in the pixel next to it), get
   another pass, twice as large as the one before, until they either fall below
   the threshold or reach `samples`. After the first pass, a pixel that differs
   from a neighbour by more than threshold x (first pass size) also goes on: an
   edge runs there, and a sliver of it narrower than one first-pass stratum, which
   all its samples may have missed, could hide an error above the threshold.

The passes continue one progressive sample pattern per pixel (core/sampling/sobol.py):
a pixel that takes every pass gets exactly the samples a uniform render of `samples`
gets, stratified as well, and its passes so far always form a well-spread pattern.
The mean is not quite unbiased: whether a pixel goes on is decided from the very
samples that enter its mean. A feature smaller than
one stratum of the first pass (a thin wire, a far speck of light) is missed by all its
samples with some probability; the pixel then looks noiseless, stops, and lacks that
feature. The first pass grows with `samples` (a sixteenth of it), so such features
shrink with the budget and the image converges as samples grow; to be safe for tiny
features at any budget, raise the minimum samples or turn adaptive sampling off.
The threshold is in the units of the benchmark's error, the relative error
|x - r| / sqrt(r^2 + 0.01) per pixel; 0 chooses it from `samples`, so that more
samples still mean less noise.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .. import vectors
from ..native import library, schema
from ..native.schema import F64, I64, U8, out, ptr

# Brightness below which absolute rather than relative noise counts (as in the benchmark's relMSE,
# whose denominator is r^2 + 0.01): noise of 0.01 in a black pixel is as visible as 1% of a white one.
DARK = 0.1
# The automatic threshold: the noise a uniform render of `samples` samples leaves in a pixel whose
# samples spread by AUTO_SPREAD of its brightness (a pixel on an edge spreads by about 1/2).
AUTO_SPREAD = 0.25
# Rec. 709 luminance weights: noise is judged on brightness, not per channel.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


class PixelNoise(NamedTuple):
    """Running per-pixel sums over all passes, from which mean and noise follow.

    total:   (p, 4) float64 sum of the samples' RGBA
    squares: (p, 2) float64 sums of the samples' squared luminance and squared alpha
    count:   (p,) int64 samples taken
    """

    total: np.ndarray
    squares: np.ndarray
    count: np.ndarray


def automatic_threshold(samples: int) -> float:
    """Return the noise threshold that a render of at most `samples` samples aims for."""
    return AUTO_SPREAD / math.sqrt(max(1, samples))


def first_pass_size(samples: int, min_samples: int = 0) -> int:
    """Return the number of samples every pixel gets in the first pass (min_samples 0: automatic)."""
    if min_samples <= 0:
        # Enough for a 2x2 stratified pattern at least, and a sixteenth of the budget for larger ones:
        # growing with the budget, so that no feature, however small, is missed for ever.
        min_samples = max(4, samples // 16)
    return max(1, min(samples, int(min_samples)))


def pass_sizes(samples: int, min_samples: int = 0) -> list[int]:
    """Return the samples per pass for a pixel that never converges: they sum to `samples`.

    The first pass has first_pass_size samples, then each pass doubles the pixel's count so far.
    """
    sizes = [first_pass_size(samples, min_samples)]
    done = sizes[0]
    while done < samples:
        size = min(done, samples - done)
        sizes.append(size)
        done += size
    return sizes


def relative_noise(noise: PixelNoise) -> np.ndarray:
    """Return each pixel's estimated relative error of its mean: (p,) float64, inf with < 2 samples.

    The standard error sqrt(var / n) of the luminance, divided by sqrt(mean^2 + DARK^2); or of the
    alpha, where that is larger (the edge of an object over a transparent film), alpha's scale being 1.
    """
    n = noise.count.astype(np.float64)

    def standard_error(mean: np.ndarray, squares: np.ndarray) -> np.ndarray:
        variance = np.maximum(squares / n - mean * mean, 0.0) * n / (n - 1.0)
        return np.sqrt(variance / n)

    with np.errstate(divide="ignore", invalid="ignore"):
        luminance = np.einsum("ij,j->i", noise.total[:, :3], LUMINANCE) / n
        alpha = noise.total[:, 3] / n
        error = np.maximum(standard_error(luminance, noise.squares[:, 0]) / np.sqrt(luminance ** 2 + DARK ** 2),
                           standard_error(alpha, noise.squares[:, 1]))
    return np.where(n >= 2, error, np.inf)


def grow(mask: np.ndarray) -> np.ndarray:
    """Return the mask grown by one pixel in each of the 8 directions. mask: (H, W) bool -> (H, W) bool."""
    out = mask.copy()
    out[1:, :] |= mask[:-1, :]
    out[:-1, :] |= mask[1:, :]
    grown = out.copy()
    grown[:, 1:] |= out[:, :-1]
    grown[:, :-1] |= out[:, 1:]
    return grown


def edge_contrast(noise: PixelNoise, width: int, height: int) -> np.ndarray:
    """Return each pixel's largest relative luminance difference to its 4 neighbours: (H * W,) float64.

    |m_p - m_q| / sqrt(((m_p + m_q) / 2)^2 + DARK^2), in the units of `relative_noise`; pixels
    without samples count as equal to their neighbours.
    """
    n = np.maximum(noise.count, 1).astype(np.float64)
    mean = (np.einsum("ij,j->i", noise.total[:, :3], LUMINANCE) / n).reshape(height, width)
    sampled = (noise.count > 0).reshape(height, width)

    def difference(a, b, both):
        return np.where(both, np.abs(a - b) / np.sqrt((0.5 * (a + b)) ** 2 + DARK ** 2), 0.0)

    down = difference(mean[1:, :], mean[:-1, :], sampled[1:, :] & sampled[:-1, :])      # (H - 1, W)
    across = difference(mean[:, 1:], mean[:, :-1], sampled[:, 1:] & sampled[:, :-1])    # (H, W - 1)
    # Each difference counts for both pixels of its pair.
    contrast = np.zeros((height, width))
    np.maximum(contrast[1:, :], down, out=contrast[1:, :])
    np.maximum(contrast[:-1, :], down, out=contrast[:-1, :])
    np.maximum(contrast[:, 1:], across, out=contrast[:, 1:])
    np.maximum(contrast[:, :-1], across, out=contrast[:, :-1])
    return contrast.reshape(-1)


def unconverged(pixels: np.ndarray, noise: PixelNoise, threshold: float, width: int, height: int,
                first: int = 0) -> np.ndarray:
    """Return the pixels (flat indices, a subset of `pixels`) that need another pass.

    pixels: (p,) int64 sorted flat indices of the rendered region; noise: PixelNoise over the whole
    image (H * W rows); a pixel needs more when its noise, or a neighbour's, exceeds threshold.
    first: the first pass's size. A pixel that has only those samples also goes on when it
    differs from a neighbour by more than threshold * first: an edge runs nearby, and a sliver of
    it narrower than one of its first strata may be missed by all of them and look noiseless.
    """
    region = vectors.selector(pixels)       # the whole image, or rows of it, without a gather
    noisy = np.zeros(height * width, bool)
    noisy[region] = relative_noise(PixelNoise(noise.total[region], noise.squares[region],
                                              noise.count[region])) > threshold
    if first > 0:
        near_edge = edge_contrast(noise, width, height) > threshold * first
        noisy[region] |= near_edge[region] & (noise.count[region] <= first)
    wanted = grow(noisy.reshape(height, width)).reshape(-1)
    return pixels[wanted[region]]


AscendingArgs = schema.function("primer_ascending", "ascending", schema.record(
    "AscendingArgs", "primer_ascending's arguments: whether p pixels are distinct flat indices below size, ascending.", [
        ("pixels", ptr(I64), "(p,)"),
        ("p", I64, ""),
        ("size", I64, ""),
        ("result", I64, "1: they are"),
    ]), result="result")
UnconvergedArgs = schema.function("primer_unconverged", "unconverged", schema.record(
    "UnconvergedArgs", "primer_unconverged's arguments: the pixels of rows y0 .. y1 - 1 that need another pass (adaptive.c).", [
        ("width", I64, ""),
        ("height", I64, ""),
        ("y0", I64, ""),
        ("y1", I64, ""),
        ("total", ptr(F64), "(H W, 4) the film's sums"),
        ("squares", ptr(F64), "(H W, 2)"),
        ("count", ptr(I64), "(H W,)"),
        ("weights", ptr(F64), "(3,) luminance"),
        ("pixels", ptr(I64), "(p,) ascending"),
        ("p", I64, ""),
        ("threshold", F64, ""),
        ("first", I64, ""),
        ("known_error", ptr(F64), "(H W,) kept noise estimates, or NULL"),
        ("known_mean", ptr(F64), "(H W,) or NULL"),
        ("error", out(F64), "scratch: one value per pixel of the window"),
        ("mean", out(F64), "scratch"),
        ("noisy", out(U8), "scratch"),
        ("grown", out(U8), "scratch"),
        ("row", out(F64), "(W,) scratch"),
        ("wanted", out(I64), "the pixels that need another pass"),
        ("result", I64, "how many"),
    ]), result="result")


def unconverged_compiled(pixels: np.ndarray, noise: PixelNoise, threshold: float, width: int, height: int,
                         first: int = 0, pool=None, bands: int = 1, estimates=None) -> np.ndarray:
    """`unconverged` in C (core/film/adaptive.c): the pixels of `pixels` (sorted, (p,) int64) that need another pass.

    noise: adaptive.PixelNoise over the whole image. One pass over the image instead of numpy's
    twenty or so. It runs between passes, while the render's threads wait, so with a `pool` (a
    concurrent.futures executor) it is cut into `bands` bands of rows decided at once: the same
    answer, band after band. With `estimates` kept by add_pixels, it reads each pixel's noise and
    mean from them instead of working them out again.
    """
    size = width * height
    pixels = library.contiguous(pixels, np.int64)
    if not library.call("primer_ascending", AscendingArgs(pixels=pixels, p=len(pixels), size=size)).result:
        raise ValueError("unconverged: pixels must be distinct flat indices of the image, ascending")
    weights = library.contiguous(LUMINANCE, np.float64)
    known_error = estimates.error if estimates is not None else None
    known_mean = estimates.mean if estimates is not None else None
    bands = max(1, min(int(bands), height)) if pool is not None else 1
    edges = [height * b // bands for b in range(bands + 1)]
    wanted = np.empty(len(pixels), np.int64)      # each band writes into its own pixels' rows

    def band(rows: tuple) -> np.ndarray:
        """The wanted pixels of rows y0 .. y1 - 1, with scratch for their window (y1 - y0 + 4 rows)."""
        y0, y1 = rows
        k0, k1 = np.searchsorted(pixels, (y0 * width, y1 * width))
        window = (min(height, y1 + 2) - max(0, y0 - 2)) * width
        error, mean = np.empty(window), np.empty(window)
        noisy, grown, row = np.empty(window, np.uint8), np.empty(window, np.uint8), np.empty(width)
        mine = wanted[k0:k1]
        count = library.call("primer_unconverged", UnconvergedArgs(
            width=width, height=height, y0=y0, y1=y1, total=noise.total, squares=noise.squares, count=noise.count,
            weights=weights, pixels=pixels, p=len(pixels), threshold=float(threshold), first=int(first),
            known_error=known_error, known_mean=known_mean, error=error, mean=mean, noisy=noisy, grown=grown,
            row=row, wanted=mine)).result
        return mine[:count]

    rows = list(zip(edges[:-1], edges[1:]))
    if len(rows) == 1:
        return band(rows[0])
    return np.concatenate(list(pool.map(band, rows)))
