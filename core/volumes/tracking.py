"""Null scattering: unbiased transmittance and free flight through a heterogeneous medium (Cycles 5.0's way).

The march (field.March) gives each piece of a ray its midpoint's coefficients: biased wherever the density varies
inside a piece. Null scattering instead fills the medium up to a **majorant** mu_bar >= sigma_t(s) on each piece with
fictitious "null" particles, so the total is homogeneous and its free flights are exponential with rate mu_bar;
at each tentative collision s the real medium holds sigma_t(s) of mu_bar and the null part mu_bar - sigma_t(s).

- Ratio tracking (transmittance, shadow rays): walk the tentative collisions and multiply
  T_hat = prod_k (1 - sigma_t(s_k) / mu_bar). Its mean is exactly T = exp(-integral sigma_t ds), for any
  mu_bar > 0, even where sigma_t > mu_bar (the factor turns negative: Cycles accepts such null weights).
- Delta tracking (free flight): at a tentative collision, it is real with probability sigma_t / mu_bar. Where a
  sampled sigma_t exceeds mu_bar the weighted variant (Kutz et al. 2017) picks real with q = sigma_t /
  (sigma_t + |mu_bar - sigma_t|) and carries the weight sigma_t / (mu_bar q) (real) or (mu_bar - sigma_t) /
  (mu_bar (1 - q)) (null); where mu_bar bounds sigma_t both weights are 1 and this is plain delta tracking.

The majorant grid is the march's pieces: each piece's mu_bar is the largest sigma_t at a few points in it times a
safety factor (Cycles' volume_estimate_extrema samples the same way and scales by 1.5).

`ratio_tracking` and `delta_tracking` take one grey sigma_t (the compiled twin is tracking.c, its density a table:
`table_density`). The integrators use ratio tracking on the march's pieces (field.March.transmittance): there the
walks' random numbers come from a stream keyed by the ray itself (`ray_keys`, `stream`), so that both kernels (and
every call along the same ray) draw the same tentative collisions.
"""
from __future__ import annotations

import numpy as np

from ..native import schema

# How many points of a piece its majorant is estimated from, and the factor it is scaled by (Cycles: 1.5).
MAJORANT_POINTS = 4
MAJORANT_SAFETY = 1.5


# splitmix64's constants (Steele et al. 2014): the stream's increment and its two mixing multipliers.
GOLDEN = np.uint64(0x9E3779B97F4A7C15)
MIX_1, MIX_2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
# The grid a ray's origin and direction are keyed on (cells per unit), and the most cells either way.
KEY_GRID = schema.constant("KEY_GRID", 1048576.0, "cells per unit of the grid a ray's stream is keyed on")
KEY_LIMIT = schema.constant("KEY_LIMIT", 1e15, "the most grid cells a ray's key counts either way")


def mix(z: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser of z (n,) uint64 -> (n,) uint64 (C: field.c tracking_mix)."""
    z = (z ^ (z >> np.uint64(30))) * MIX_1
    z = (z ^ (z >> np.uint64(27))) * MIX_2
    return z ^ (z >> np.uint64(31))


def ray_keys(O: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Each ray's stream key (n,) uint64: its origin's and direction's coordinates (O, D (n, 3) float64) on a grid
    of 1 / KEY_GRID (floor(x KEY_GRID), within +-KEY_LIMIT) mixed in turn (C: field.c tracking_key). On a grid so
    that rays the kernels compute a few ulps apart key alike (unless they straddle one of its lines: about 1e-10 of
    them), a point on a plane at 0 included (whose float bits would be noise)."""
    cells = np.clip(np.floor(np.concatenate([np.asarray(O, np.float64), np.asarray(D, np.float64)], axis=1)
                             * KEY_GRID), -KEY_LIMIT, KEY_LIMIT).astype(np.int64).view(np.uint64)
    h = np.full(len(cells), GOLDEN, np.uint64)
    for c in range(cells.shape[1]):
        h = mix(h ^ cells[:, c])
    return h


def stream(keys: np.ndarray, i: int) -> np.ndarray:
    """The i-th uniform number in [0, 1) (n,) float64 of the streams `keys` (n,) uint64 (C: field.c tracking_u)."""
    z = mix(keys + np.uint64((0x9E3779B97F4A7C15 * (i + 1)) & 0xFFFFFFFFFFFFFFFF))
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def majorants(sigma_t, edges: np.ndarray, points: int = MAJORANT_POINTS, safety: float = MAJORANT_SAFETY):
    """Each piece's majorant: the largest sigma_t(s) at `points` evenly spaced s in [edges[i], edges[i+1]] times
    `safety`. sigma_t: callable (n,) float64 distances -> (n,) float64; edges (p + 1,) float64 -> (p,) float64."""
    f = np.linspace(0.0, 1.0, points)
    s = edges[:-1, None] + (edges[1:] - edges[:-1])[:, None] * f[None, :]
    return safety * sigma_t(s.ravel()).reshape(s.shape).max(axis=1)


def tentative_collisions(edges: np.ndarray, mu_bar: np.ndarray, rng: np.random.Generator, walking: np.ndarray):
    """The tentative collisions of walks over the pieces of [edges[0], edges[-1]] drawn at rates mu_bar (p,): yields
    per round (walks (k,) int64, their distances s (k,), their pieces' majorants m (k,)) of those that collide; a walk
    that steps past its piece's end restarts at the next piece's start (the exponential's memorylessness) until it
    leaves the last. walking (n,) bool: the walks still going, which the caller may stop between rounds."""
    s = np.full(len(walking), float(edges[0]))
    piece = np.zeros(len(walking), dtype=np.int64)
    last = len(mu_bar)
    while walking.any():
        i = np.flatnonzero(walking)
        m = mu_bar[piece[i]]
        with np.errstate(divide="ignore"):
            step = np.where(m > 0.0, -np.log1p(-rng.random(i.size)) / np.where(m > 0.0, m, 1.0), np.inf)
        end = edges[piece[i] + 1]
        leaves_piece = s[i] + step >= end
        out = i[leaves_piece]
        s[out] = end[leaves_piece]
        piece[out] += 1
        walking[out[piece[out] >= last]] = False
        inside = i[~leaves_piece]
        s[inside] += step[~leaves_piece]
        yield inside, s[inside], m[~leaves_piece]


def ratio_tracking(sigma_t, edges: np.ndarray, mu_bar: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """n independent ratio-tracking estimates of T = exp(-integral over [edges[0], edges[-1]] of sigma_t): their mean
    is T exactly. sigma_t: callable (m,) -> (m,); edges (p + 1,), mu_bar (p,) float64 -> (n,) float64."""
    T_hat = np.ones(n)
    for inside, s, m in tentative_collisions(edges, mu_bar, rng, np.ones(n, dtype=bool)):
        T_hat[inside] *= 1.0 - sigma_t(s) / m
    return T_hat


def delta_tracking(sigma_t, edges: np.ndarray, mu_bar: np.ndarray, rng: np.random.Generator, n: int) -> tuple:
    """n (weighted) delta-tracking free flights over [edges[0], edges[-1]]: (s, w) (n,) float64 each, s the real
    collision's distance (inf where the flight leaves the stretch) and w its weight (1 where mu_bar bounds sigma_t),
    so that E[w; s <= x] = 1 - exp(-integral_0^x sigma_t)."""
    w = np.ones(n)
    hit = np.full(n, np.inf)
    walking = np.ones(n, dtype=bool)
    for inside, s, m in tentative_collisions(edges, mu_bar, rng, walking):
        sigma = sigma_t(s)
        bounded = sigma <= m
        q = np.where(bounded, sigma / m, sigma / (2.0 * sigma - m))  # sigma + |m - sigma| = 2 sigma - m where unbounded
        real = rng.random(inside.size) < q
        # Unbounded: real carries sigma / (m q) = (2 sigma - m) / m, null (m - sigma) / (m (1 - q)) = -(2 sigma - m) / m.
        w[inside] *= np.where(bounded, 1.0, np.where(real, 1.0, -1.0) * (2.0 * sigma - m) / m)
        hit[inside[real]] = s[real]
        walking[inside[real]] = False
    return hit, w


def table_density(values: np.ndarray, length: float, linear: bool):
    """sigma_t(s) over [0, length] from a table (C: TrackingRowsArgs): `linear` - values (m + 1,) at m + 1 evenly
    spaced nodes, interpolated linearly; else values (m,) constant in m equal cells."""
    values = np.asarray(values, np.float64)
    def sigma_t(s):
        if linear:
            x = np.clip(np.asarray(s) / length, 0.0, 1.0) * (len(values) - 1)
            k = np.minimum(x.astype(np.int64), len(values) - 2)
            return values[k] + (values[k + 1] - values[k]) * (x - k)
        return values[np.clip((np.asarray(s) / length * len(values)).astype(np.int64), 0, len(values) - 1)]
    return sigma_t


TrackingRowsArgs = schema.function("primer_tracking_rows", "tracking_rows", schema.record(
    "TrackingRowsArgs", "primer_tracking_rows' arguments: n ratio-tracking transmittances and n weighted "
    "delta-tracking free flights through a tabulated density (tracking.c).", [
        ("n", schema.I64, ""),
        ("seed", schema.I64, "the rows' random streams' seed"),
        ("values", schema.ptr(schema.F64), "(count,) the density table (table_density)"),
        ("count", schema.I64, ""),
        ("linear", schema.I64, "1: nodes interpolated linearly, 0: constant cells"),
        ("length", schema.F64, "the table's extent [0, length]"),
        ("edges", schema.ptr(schema.F64), "(pieces + 1,) the majorant grid"),
        ("mu_bar", schema.ptr(schema.F64), "(pieces,) each piece's majorant"),
        ("pieces", schema.I64, ""),
        ("transmittance", schema.out(schema.F64), "(n,) ratio tracking's estimates"),
        ("distance", schema.out(schema.F64), "(n,) delta tracking's real collisions (inf: none)"),
        ("weight", schema.out(schema.F64), "(n,) their weights"),
    ]))


def compiled_rows(values: np.ndarray, length: float, linear: bool, edges: np.ndarray, mu_bar: np.ndarray, n: int,
                  seed: int = 0) -> tuple:
    """tracking.c's ratio and delta tracking, n rows each, through table_density(values, length, linear):
    (T_hat, s, w) (n,) float64 each, to hold against ratio_tracking and delta_tracking in distribution."""
    from ..native import library
    T_hat, s, w = np.empty(n), np.empty(n), np.empty(n)
    values = library.contiguous(values, np.float64)
    library.call("primer_tracking_rows", TrackingRowsArgs(
        n=n, seed=seed, values=values, count=len(values), linear=int(linear), length=float(length),
        edges=library.contiguous(edges, np.float64), mu_bar=library.contiguous(mu_bar, np.float64),
        pieces=len(mu_bar), transmittance=T_hat, distance=s, weight=w))
    return T_hat, s, w
