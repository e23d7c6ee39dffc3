"""Null scattering's random numbers: a stream per ray, the same in both kernels.

Null scattering fills a heterogeneous medium up to a majorant mu_bar >= sigma_t with fictitious "null" particles, so
that the total is homogeneous and free flights through it are exponential with rate mu_bar; ratio tracking multiplies
T_hat = prod_k (1 - sigma_t(s_k) / mu_bar) over the tentative collisions s_k, whose mean is exactly exp(-integral
sigma_t ds). Primer's integrators track the residual against a control on each piece of the march
(core/volumes/field.py March.transmittance; C field.c march_track). Their tentative collisions draw from a stream
keyed by the ray itself (`ray_keys`, `stream`), so that both kernels, and every call along the same ray, draw the
same collisions.
"""
from __future__ import annotations

import numpy as np

from ..native import schema

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
