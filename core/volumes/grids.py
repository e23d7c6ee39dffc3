"""Volume objects' voxel grids (OpenVDB), as Cycles samples them: dense arrays a heterogeneous medium's graph reads.

A Blender Volume object holds named grids ("density", "temperature", "flame", "color", ...). The add-on reads them
(addon/export.py with OpenVDB: core never reads files) into `Grid`s: the values over the box of the grid's active
voxels, float32 (X, Y, Z, C) indexed by the voxels' (i, j, k) from `lower`, and the map from object space to index
space (the inverse of the grid's transform: voxel (i, j, k)'s centre is index point (i, j, k)). A point's value is
the trilinear interpolation of the eight voxels around its index point (Cycles' kernel_tex_image_interp_3d with
Linear interpolation; Cycles 5.0 samples one of the eight at random with those weights, whose mean is the same),
the background 0 outside the box. A grid of C = 1 reads (v, v, v, 1) as Cycles' float grids do, of C = 3 (r, g, b, 1):
the four floats an Attribute node reads (its Fac the mean of the three).

Cycles bounds a Volume object's medium by a mesh: with its null-scattering integrator (5.0's default) the box of
the union of the loaded grids' active voxels, dilated by one voxel (Linear interpolation; two for Cubic), from index
min - pad to max + 1 + pad (scene/volume.cpp VolumeMeshBuilder). `bounding_box` gives those index corners.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..native import schema

# The floats a grid takes among a volume point's attributes (an Attribute node's RGBA).
GRID_WIDTH = schema.constant("GRID_WIDTH", 4,
                             "the floats a Volume object's grid takes among a volume point's attributes")
# The most values (float32: 4 bytes each) Primer keeps of one grid; a grid with more is averaged over blocks of voxels.
MAX_VOXELS = 1 << 23


class Grid(NamedTuple):
    """One grid of a Volume object: its name, values (X, Y, Z, C) float32 (C 1 or 3) over voxels lower + (i, j, k),
    lower (3,) int64, to_index (3, 4) float64 the affine map from object space to index space, and cubic: the
    material's Volume > Interpolation is Cubic (Cycles' uniform cubic B-spline over 4 x 4 x 4 voxels) rather than
    Linear (trilinear over 2 x 2 x 2)."""

    name: str
    values: np.ndarray
    lower: np.ndarray
    to_index: np.ndarray
    cubic: bool = False


def cubic_weights(t: np.ndarray) -> list:
    """The uniform cubic B-spline's four weights (each like t) of the voxels at floor - 1 .. floor + 2 for the
    fractions t (Cycles' fill_cubic_weights)."""
    return [(((-1.0 / 6.0) * t + 0.5) * t - 0.5) * t + (1.0 / 6.0), ((0.5 * t - 1.0) * t) * t + (2.0 / 3.0),
            ((-0.5 * t + 0.5) * t + 0.5) * t + (1.0 / 6.0), (1.0 / 6.0) * t * t * t]


def taps(grid: Grid, local: np.ndarray):
    """The voxels each object-space point of local (n, 3) is interpolated from, one at a time (8 trilinear, 64
    tricubic): yields (weight (n,) float64 (0 outside the grid's box), value (n, C) float64)."""
    P = local @ grid.to_index[:, :3].T + grid.to_index[:, 3] - grid.lower
    base = np.floor(P)
    t = P - base
    base = base.astype(np.int64)
    values = grid.values
    dims = np.array(values.shape[:3])
    count = 4 if grid.cubic else 2
    weights = cubic_weights(t) if grid.cubic else [1.0 - t, t]
    for corner in range(count ** 3):
        offset = np.array([corner // (count * count), (corner // count) % count, corner % count])
        index = base + offset - (1 if grid.cubic else 0)
        w = [weights[offset[axis]][:, axis] for axis in range(3)]
        inside = ((index >= 0) & (index < dims)).all(axis=1)
        clamped = np.clip(index, 0, dims - 1)
        value = values[clamped[:, 0], clamped[:, 1], clamped[:, 2]].astype(np.float64)
        yield np.where(inside, (w[0] * w[1]) * w[2], 0.0), np.where(inside[:, None], value, 0.0)


def sample(grid: Grid, local: np.ndarray) -> np.ndarray:
    """The grid's RGBA (n, 4) float64 at object-space points local (n, 3): trilinear over the voxels around each
    point's index point (tricubic B-spline over 4^3 where `grid.cubic`), 0 outside the grid's box, alpha 1."""
    C = grid.values.shape[3]
    out = np.zeros((len(local), C))
    for weight, value in taps(grid, local):
        out += weight[:, None] * value
    rgba = np.ones((len(local), GRID_WIDTH))
    rgba[:, :3] = out if C == 3 else out[:, :1]
    return rgba


def corners(grid: Grid, local: np.ndarray) -> tuple:
    """The voxels around object-space points local (n, 3) that Cycles' stochastic lookup picks from, and its odds:
    (values (n, K) float64 the first channel, odds (n, K) float64 the interpolation weights, 0 outside the box)."""
    found = list(taps(grid, local))
    return np.stack([v[:, 0] for _, v in found], axis=1), np.stack([w for w, _ in found], axis=1)


def active_box(values: np.ndarray, clipping: float) -> tuple:
    """The index box (low (3,), high (3,) int64, inclusive; None when empty) of the voxels of values (X, Y, Z, C)
    that stay active after Cycles' clipping (a voxel whose every channel lies within `clipping` of 0 is inactive)."""
    active = (np.abs(values) > clipping).any(axis=3)
    if not active.any():
        return None
    where = [np.flatnonzero(active.any(axis=tuple(a for a in range(3) if a != axis))) for axis in range(3)]
    return np.array([w[0] for w in where]), np.array([w[-1] for w in where])


def bounding_box(low: np.ndarray, high: np.ndarray, pad: int) -> np.ndarray:
    """The 8 index-space corners (8, 3) float64 of Cycles' bounding mesh of active voxels low..high (inclusive):
    dilated by `pad` voxels, from low - pad to high + 1 + pad, in primitives.box's corner order."""
    a = np.asarray(low, np.float64) - pad
    b = np.asarray(high, np.float64) + 1 + pad
    return np.array([[(a, b)[x][0], (a, b)[y][1], (a, b)[z][2]] for z in (0, 1) for y in (0, 1) for x in (0, 1)])


def downsample(values: np.ndarray, factor: int) -> np.ndarray:
    """values (X, Y, Z, C) averaged over blocks of factor^3 voxels (the edges padded with the background 0)."""
    X, Y, Z, C = values.shape
    pad = [(0, (-s) % factor) for s in (X, Y, Z)] + [(0, 0)]
    v = np.pad(values, pad)
    return v.reshape(v.shape[0] // factor, factor, v.shape[1] // factor, factor, v.shape[2] // factor, factor,
                     C).mean(axis=(1, 3, 5)).astype(np.float32)
