"""The film: each pixel's running sums over all passes, and the image they make (a 1-pixel box filter).

A chunk of a render gives each of its pixels the sum of its samples' RGBA (sums, not means, so that
passes add up), the sums of their squared luminance and alpha (adaptive sampling's noise estimate),
and how many of its samples hit a surface. The film adds them up; the image is each pixel's mean
over all its samples, as Cycles' "Box" filter of width 1 makes it.

The compiled twin (core/film/film.c) adds a chunk's sums and resolves the image in one pass each,
with the same numbers; with adaptive sampling, the chunk that adds a pixel's samples also renews its
noise estimate, so that the noise test between passes need not work it out again.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from ..native import library, schema
from ..native.schema import F32, F64, I64, out, ptr
from . import adaptive



class ChunkSums(NamedTuple):
    """What a chunk of p pixels adds to the film, and what it cost.

    rgba:     (p, 4) float64 sum of the samples' RGBA
    squares:  (p, 2) float64 sums of the samples' squared luminance and alpha (zeros unless adaptive)
    hits:     (p,) int64 samples that hit a surface
    aux:      name -> (p, c) float64 sums of debug values (core/integrators/debug.py)
    primary:  camera rays traced (a fisheye's samples outside its image circle trace none)
    shadow:   shadow rays traced
    samples:  camera samples per pixel in this chunk
    intersect_seconds, occluded_seconds: time inside Embree's queries (compiled chunks count them)
    shading_seconds: time spent shading, Embree's shadow queries included
    added:    True when the chunk already added its sums to the film itself (rgba, squares, hits None)
    nonfinite: (p,) int64 samples whose value was NaN or infinite, replaced by 0 (finite_samples), or None
    """

    rgba: Optional[np.ndarray]
    squares: Optional[np.ndarray]
    hits: Optional[np.ndarray]
    aux: dict
    primary: int
    shadow: int
    samples: int
    intersect_seconds: float = 0.0
    occluded_seconds: float = 0.0
    shading_seconds: float = 0.0
    added: bool = False
    nonfinite: Optional[np.ndarray] = None


# The largest float32: the film's image is float32, as Cycles' render buffer is, so a sample beyond it is infinite
# there (film.c's FILM_MAX).
FILM_MAX = float(np.finfo(np.float32).max)


def finite_samples(rgba: np.ndarray, p: int, spp: int) -> np.ndarray:
    """Replace, in place, each channel of a sample that is NaN or beyond the float32 film's range by 0, as Cycles'
    film does with each contribution (ensure_finite): rgba (p spp, c) float64, pixel by pixel; return (p,) int64
    how many of each pixel's samples had one."""
    bad = ~(np.abs(rgba) <= FILM_MAX)
    if not bad.any():
        return np.zeros(p, np.int64)
    rgba[bad] = 0.0
    return bad.any(axis=1).reshape(p, spp).sum(axis=1).astype(np.int64)


def pixel_sums(rgba: np.ndarray, p: int, spp: int, want_squares: bool) -> tuple[np.ndarray, np.ndarray]:
    """Sum each pixel's spp samples: rgba (p spp, 4) float64, pixel by pixel -> rgba (p, 4), squares (p, 2).

    squares: each pixel's sums of squared luminance and squared alpha (zeros unless want_squares).
    """
    per_pixel = rgba.reshape(p, spp, 4).sum(axis=1)
    if not want_squares:
        return per_pixel, np.zeros((p, 2))
    luminance = np.einsum("ij,j->i", rgba[:, :3], adaptive.LUMINANCE)
    squares = np.stack([luminance * luminance, rgba[:, 3] * rgba[:, 3]], axis=1).reshape(p, spp, 2).sum(axis=1)
    return per_pixel, squares


class NoiseEstimates(NamedTuple):
    """What the noise test between passes reads of each pixel, kept up to date as chunks add their
    samples (Film.add, compiled), so that the test need not work it out for every pixel, alone.

    error: (H W,) float64 adaptive.relative_noise of each pixel (inf before it has 2 samples)
    mean:  (H W,) float64 its mean luminance (adaptive.edge_contrast's; 0 before its first sample)
    """

    error: np.ndarray
    mean: np.ndarray

    @classmethod
    def empty(cls, size: int) -> "NoiseEstimates":
        """The estimates of `size` pixels without samples."""
        return cls(np.full(size, np.inf), np.zeros(size))


class Film:
    """The running sums of a render's W x H pixels (row 0 at the top, flat index y W + x).

    noise:  adaptive.PixelNoise over the image: RGBA totals, squared luminance and alpha, sample counts
    hits:   (H W,) int64 samples that hit a surface
    aux:    name -> (H W, c) float64 sums of debug values
    compiled: add chunks and resolve the image in C (film.c), with noise `estimates` kept when given
    merge:  name -> function(film's rows, chunk's rows) -> new rows, for the aux buffers a chunk does not add to
            but merges into (Cryptomatte's slots)
    """

    def __init__(self, width: int, height: int, aux_channels: dict, compiled: bool = False,
                 keep_estimates: bool = False, merge: Optional[dict] = None):
        size = width * height
        self.width, self.height = width, height
        self.noise = adaptive.PixelNoise(np.zeros((size, 4)), np.zeros((size, 2)), np.zeros(size, np.int64))
        self.hits = np.zeros(size, np.int64)
        self.aux = {name: np.zeros((size, channels)) for name, channels in aux_channels.items()}
        self.compiled = compiled
        self.estimates = NoiseEstimates.empty(size) if compiled and keep_estimates else None
        self.nonfinite = np.zeros(size, np.int64)     # samples whose NaN or infinite value became 0, per pixel
        self.merge = merge or {}

    def add(self, pixels: np.ndarray, sums: ChunkSums, estimates: bool = True) -> None:
        """Add a chunk's per-pixel sums: pixels (p,) int64 distinct flat indices.

        Chunks of one pass have pixels of their own, so the threads rendering them may add at once.
        estimates: False skips renewing the noise estimates (no noise test follows).
        """
        if sums.added:
            return
        if sums.nonfinite is not None and sums.nonfinite.any():
            self.nonfinite[_selector(pixels)] += sums.nonfinite
        if self.compiled:
            add_pixels(pixels, sums.samples, sums.rgba, sums.squares, sums.hits, self.noise, self.hits,
                       self.estimates if estimates else None)
        else:
            chosen = _selector(pixels)
            self.noise.total[chosen] += sums.rgba
            self.noise.squares[chosen] += sums.squares
            self.noise.count[chosen] += sums.samples
            self.hits[chosen] += sums.hits
        for name, values in sums.aux.items():
            if name in self.merge:
                chosen = _selector(pixels)
                self.aux[name][chosen] = self.merge[name](self.aux[name][chosen], values)
            else:
                self.aux[name][_selector(pixels)] += values

    def nonfinite_note(self) -> Optional[str]:
        """The warning that some samples were NaN or infinite and went in as 0 (the first pixel named), or None."""
        if not self.nonfinite.any():
            return None
        pixels = np.flatnonzero(self.nonfinite)
        y, x = divmod(int(pixels[0]), self.width)
        return (f"{int(self.nonfinite.sum())} samples in {len(pixels)} pixels were NaN or infinite and went into the "
                f"image as 0, as Cycles' film does (the first at pixel x {x}, y {y} from the top); an input the "
                "add-on and core did not catch made them")

    def image(self) -> np.ndarray:
        """Return each pixel's mean over all its samples (a 1-pixel box filter): (H, W, 4) float32."""
        if self.compiled:
            image = resolve(self.noise.total, self.noise.count)
        else:
            image = (self.noise.total / np.maximum(self.noise.count, 1)[:, None]).astype(np.float32)
        return image.reshape(self.height, self.width, 4)


def _selector(pixels: np.ndarray):
    """Index rows `pixels` of a film array: a slice when they are one run (a first pass's chunk)."""
    from .. import vectors
    return vectors.selector(pixels)


# ---------------------------------------------------------------------------
# The compiled twin (core/film/film.c)
# ---------------------------------------------------------------------------

AddPixelsArgs = schema.function("primer_add_pixels", "add_pixels", schema.record(
    "AddPixelsArgs", "primer_add_pixels' arguments: a chunk's per-pixel sums into the film's (film.c).", [
        ("p", I64, ""),
        ("pixels", ptr(I64), "(p,) distinct"),
        ("spp", I64, ""),
        ("rgba", ptr(F64), "(p, 4)"),
        ("squares", ptr(F64), "(p, 2)"),
        ("hits", ptr(I64), "(p,)"),
        ("total", out(F64), "(H W, 4) the film's sums"),
        ("squares_sum", out(F64), "(H W, 2)"),
        ("count", out(I64), "(H W,)"),
        ("hits_sum", out(I64), "(H W,)"),
        ("weights", ptr(F64), "(3,) luminance"),
        ("error", out(F64), "(H W,) noise estimates renewed, or NULL"),
        ("mean", out(F64), "(H W,) or NULL"),
    ]))
ResolveArgs = schema.function("primer_resolve", "resolve_rows", schema.record(
    "ResolveArgs", "primer_resolve's arguments: each pixel's mean.", [
        ("n", I64, ""),
        ("total", ptr(F64), "(n, 4)"),
        ("count", ptr(I64), "(n,)"),
        ("out", out(F32), "(n, 4)"),
    ]))


def add_pixels(pixels: np.ndarray, spp: int, rgba: np.ndarray, squares: np.ndarray, hits: np.ndarray, noise,
               hits_sum: np.ndarray, estimates: Optional[NoiseEstimates] = None) -> None:
    """Add a chunk's per-pixel sums to the film's, in place, and renew the pixels' `estimates` where given.

    pixels (p,) int64 distinct; rgba (p, 4), squares (p, 2) float64; hits (p,) int64; noise:
    adaptive.PixelNoise over the image; hits_sum (H W,) int64.
    """
    pixels = library.contiguous(pixels, np.int64)
    weights = library.contiguous(adaptive.LUMINANCE, np.float64)
    kept = estimates if estimates is not None else NoiseEstimates(None, None)
    library.call("primer_add_pixels", AddPixelsArgs(
        p=len(pixels), pixels=pixels, spp=int(spp), rgba=rgba, squares=squares, hits=hits, total=noise.total,
        squares_sum=noise.squares, count=noise.count, hits_sum=hits_sum, weights=weights, error=kept.error,
        mean=kept.mean))


def resolve(total: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Each pixel's mean over max(count, 1) samples, as Film.image's numpy divides:
    total (n, 4) float64, count (n,) int64 -> (n, 4) float32, in one pass."""
    total, count = library.contiguous(total, np.float64), library.contiguous(count, np.int64)
    means = np.empty((len(count), 4), np.float32)
    library.call("primer_resolve", ResolveArgs(n=len(count), total=total, count=count, out=means))
    return means


def sums_buffer(p: int, want_squares: bool) -> tuple:
    """Fresh per-pixel sums for a compiled chunk of p pixels: rgba (p, 4), squares (p, 2) or None, hits (p,)."""
    return np.zeros((p, 4)), (np.zeros((p, 2)) if want_squares else None), np.zeros(p, np.int64)

