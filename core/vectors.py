"""Row-vector arithmetic that numpy would otherwise do slowly.

Primer keeps points, directions and normals as (n, 3) float64 rows. numpy is fast
at row-by-row work between two such arrays, but an expression that broadcasts an
(n,) array against a single (3,) vector, `s[:, None] * v`, runs an inner loop of
length 3 per row and is several times slower than the same work done column by
column (measured: 5.6 ms against 1.0 ms for 60,000 rows of c + x u + y v). These
helpers do it column by column. Trigonometry of sampled angles is done in float32,
whose vectorised sin and cos are about 30 times faster than float64's: the angles
are random anyway, and the resulting directions stay unit length to float64 precision.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np


def combine(origin: np.ndarray, weights: list, vectors: list) -> np.ndarray:
    """Return origin + sum_k weights[k] * vectors[k] for every row.

    origin: (3,) float64 point or direction; weights: list of (n,) float64; vectors: list of (3,) float64
    -> (n, 3) float64
    """
    out = np.empty((len(weights[0]), 3), order="F")
    for c in range(3):
        column = out[:, c]
        np.multiply(weights[0], vectors[0][c], out=column)
        for w, v in zip(weights[1:], vectors[1:]):
            column += w * v[c]
        column += origin[c]
    return out


def cos_sin(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (cos phi, sin phi) of angles phi in [0, 2 pi): (n,) float64 -> two (n,) float64.

    cos is taken in float32 (fast); sin follows from it as +-sqrt(1 - cos^2) in float64, so
    cos^2 + sin^2 = 1 holds to float64 precision. The angle these represent is off by at most
    about 5e-7 radians where |sin phi| > 0.1 (measured on 400,000 angles); near 0 and pi, where
    cos is flat, float32's rounding of cos (~3e-8) moves it by up to sqrt(2 * 3e-8), about 2.4e-4.
    """
    c = np.cos(phi.astype(np.float32)).astype(np.float64)
    np.clip(c, -1.0, 1.0, out=c)
    s = 1.0 - c * c
    np.sqrt(s, out=s)
    np.copysign(s, math.pi - phi, out=s)       # negative for phi in (pi, 2 pi)
    return c, s


# Column-major (n, 3) arrays: numpy runs element-wise work in memory order, so with the three
# coordinates stored as three contiguous columns, row-wise expressions such as P - c, P * s[:, None]
# and einsum("ij,ij->i") run over long contiguous loops: 3-4 times faster than on row-major
# (n, 3) arrays, whose inner loops have length 3 (measured on 60,000 rows). Results of
# element-wise work keep the layout of their operands, so it is set once, where arrays are made.

def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (n, 3) arrays, summed as C's dot3 sums them (x, then y, then z): the compiled twins
    then give the very same numbers where a BSDF amplifies a last-bit difference (velvet's exponent near its
    normal, Oren-Nayar at grazing). (n,) float64."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def rows(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Return the (n, 3) float64 array of rows (x, y, z), column-major. x, y, z: (n,) float64."""
    return np.stack([x, y, z]).T


def gather(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Return values[index] as a column-major array: (t, 3) values, (n,) int index -> (n, 3)."""
    out = np.empty((len(index), values.shape[1]), values.dtype, order="F")
    for c in range(values.shape[1]):
        np.take(values[:, c], index, out=out[:, c])
    return out


# Rows picked out of (n, 3) and (n, 3, 3) arrays: numpy 1.x's fancy and boolean indexing on
# several axes runs a generic loop per row, 3 to 9 times slower here than np.take and np.compress
# (measured on 6,000 rows: a[i] 86-124 us against 36 us, a[mask] 97 against 26 us, M[i, :3, :3]
# of 30 matrices 292 against 33 us). Reductions over a short last axis are as slow
# (mask.all(axis=1) of (6000, 3): 113 us, against 13 us for the columns and-ed). The same values.

def pick_rows(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Return values[index] along the first axis: (n, ...) values, (m,) int index -> (m, ...)."""
    return np.take(values, index, axis=0)


def keep_rows(values: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Return values[keep] along the first axis: (n, ...) values, (n,) bool keep -> (kept, ...)."""
    return np.compress(keep, values, axis=0)


def all_columns(mask: np.ndarray) -> np.ndarray:
    """Return mask.all(axis=1): whether every column of each row is True. (n, k) bool -> (n,) bool."""
    out = mask[:, 0].copy()
    for c in range(1, mask.shape[1]):
        out &= mask[:, c]
    return out


def any_nonzero(values: np.ndarray) -> np.ndarray:
    """Return values.any(axis=1): whether some column of each row is nonzero (NaN is). (n, k) -> (n,) bool."""
    out = values[:, 0] != 0
    for c in range(1, values.shape[1]):
        out |= values[:, c] != 0
    return out


def selector(index: np.ndarray):
    """Return what selects rows `index` (sorted, distinct) of an array: a slice where they form one
    run, so that reading them is a view and adding to them is in place (no gather, no scatter);
    else `index` itself. index: (n,) int64."""
    if len(index) and index[-1] - index[0] + 1 == len(index):
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def transform(points: np.ndarray, linear: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Return linear @ p + offset for every row p, column-major: (n, 3), (3, 3), (3,) float64 -> (n, 3)."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    out = np.empty((len(points), 3), order="F")
    for c in range(3):
        column = out[:, c]
        np.multiply(x, linear[c, 0], out=column)
        column += linear[c, 1] * y
        column += linear[c, 2] * z
        column += offset[c]
    return out


def apply_each(L: np.ndarray, p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Return L_i p_i + t_i for every row i: L (n, 3, 3), p (n, 3), t (n, 3) float64 -> (n, 3).

    Written out (L[:, :, 0] p_x + L[:, :, 1] p_y + L[:, :, 2] p_z): numpy's einsum runs a generic
    loop for a small matrix per row, several times slower.
    """
    return L[:, :, 0] * p[:, 0, None] + L[:, :, 1] * p[:, 1, None] + L[:, :, 2] * p[:, 2, None] + t


def rows_times_each(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Return A_i B_i for every i: A (n, r, 3), B (n, 3, 3) float64 -> (n, r, 3), written out as apply_each is."""
    return (A[:, :, 0, None] * B[:, None, 0, :] + A[:, :, 1, None] * B[:, None, 1, :]
            + A[:, :, 2, None] * B[:, None, 2, :])


def cross(a: np.ndarray, b: np.ndarray, out: Optional[np.ndarray] = None) -> np.ndarray:
    """Return a x b of (n, 3) float64 vectors: (n, 3), into `out` when given.

    The same products and differences as np.cross, in the same order (so the same bits), without
    its axis juggling, which costs more than the arithmetic on the few vectors of a scene's
    placements (about 40 against 15 us on three vectors here).
    """
    if out is None:
        out = np.empty((len(a), 3), np.result_type(a, b))
    a0, a1, a2, b0, b1, b2 = a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2]
    np.subtract(a1 * b2, a2 * b1, out=out[:, 0])
    np.subtract(a2 * b0, a0 * b2, out=out[:, 1])
    np.subtract(a0 * b1, a1 * b0, out=out[:, 2])
    return out


def determinant(L: np.ndarray) -> np.ndarray:
    """Return det L of (k, 3, 3) float64 matrices, a . (b x c) with a, b, c the columns: (k,).

    Elementwise numpy: np.linalg.det runs through LAPACK (see determinant_and_inverse).
    """
    return np.einsum("ki,ki->k", L[:, :, 0], cross(L[:, :, 1], L[:, :, 2]))


def adjugate(L: np.ndarray) -> np.ndarray:
    """Return the adjugate of (k, 3, 3) float64 matrices: (k, 3, 3) with the rows b x c, c x a, a x b,
    a, b, c the columns of L. L^-1 = adj L / det L, and normals turn with its transpose, the
    cofactor matrix (core/geometry/instancing.py)."""
    a, b, c = L[:, :, 0], L[:, :, 1], L[:, :, 2]
    rows = np.empty((len(L), 3, 3), np.result_type(L))
    cross(b, c, rows[:, 0])
    cross(c, a, rows[:, 1])
    cross(a, b, rows[:, 2])
    return rows


def determinant_and_inverse(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return det L and L^-1 of (k, 3, 3) float64 matrices by their cofactors: (k,) and (k, 3, 3).

    With a, b, c the columns of L, det L = a . (b x c) and L^-1 = adj L / det L. Elementwise numpy:
    LAPACK's inverse (np.linalg) runs through OpenBLAS, whose threads fought Embree's right after a
    BVH build (3 ms a call instead of 20 us). Singular matrices give det 0 and an infinite or NaN
    inverse, which callers skip.
    """
    rows = adjugate(L)                                                             # (k, 3, 3)
    det = np.einsum("ki,ki->k", L[:, :, 0], rows[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        rows /= det[:, None, None]
    return det, rows


def orthonormal_frame(axis: np.ndarray):
    """Return two unit vectors (t, b) that complete each unit axis to a right-handed orthonormal frame.

    Duff et al., "Building an Orthonormal Basis, Revisited" (2017): no branches, no cross products.
    axis: (n, 3) float64 unit -> t, b: (n, 3) float64
    """
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    sign = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    c = x * y * a
    t = rows(1.0 + sign * x * x * a, sign * c, -sign * x)
    b = rows(c, sign + y * y * a, -y)
    return t, b
