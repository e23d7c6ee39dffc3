"""GGX albedo tables: how much light a GGX lobe reflects, looked up by roughness and view angle.

Multiscatter GGX and the Principled BSDF's layering need, per hit, the albedo of a lobe seen from
mu = N.wo (the fraction of light from a white sky that it reflects towards wo). They are integrals
over the hemisphere, so they are computed once, by tools/make_tables.py, into
core/materials/ggx_tables.h; the C code includes that file and this module reads the same numbers.

  E[mu][rough]          32 x 32   albedo of GGX without Fresnel (1 - E is what multiple scattering restores)
  Eavg[rough]           32        E averaged over the hemisphere (2 mu dmu): the albedo under uniform light
  schlick_ior_s[z][mu][rough]  16^3  where between F0 and F90 the albedo of a lobe with the dielectric curve
                                  lies (z = ((ior - 1) / (ior + 1))^(1/2))
  schlick_s_half[mu][rough]   16^2  the same for Schlick's curve (1 - cos)^5, used for metals
  glass_E[z][mu][rough]       16^3  albedo (reflected plus refracted) of rough glass with the dielectric
                                  curve, entering a medium of index ior = ior_from_F0(z^4); glass_inv_E
                                  leaving it (relative index 1 / ior); glass_Eavg[z][rough] and
                                  glass_inv_Eavg their cosine-weighted means over mu

Lookups interpolate linearly between grid points at i / (size - 1), clamping outside 0..1, in the same
order as Cycles' lookup_table_read_2D/3D (rough fastest, then mu, then z).
"""
from __future__ import annotations

import os
import re

import numpy as np

HEADER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ggx_tables.h")


def _read(name: str, header: str = HEADER) -> np.ndarray:
    """The C array `name` of a table header (ggx_tables.h, or another of this folder) as a flat float64 array."""
    with open(header) as handle:
        text = handle.read()
    body = re.search(r"\b%s\[\d+\] = \{(.*?)\};" % name, text, re.S)
    if body is None:
        raise RuntimeError(f"{header} has no table {name}: run tools/make_tables.py")
    return np.array([float(x) for x in body.group(1).split(",") if x.strip()])


E = _read("GGX_E").reshape(32, 32)
EAVG = _read("GGX_EAVG")
SCHLICK_IOR_S = _read("GGX_SCHLICK_IOR_S").reshape(16, 16, 16)
SCHLICK_S_HALF = _read("GGX_SCHLICK_S_HALF").reshape(16, 16)
GLASS_E = _read("GGX_GLASS_E").reshape(16, 16, 16)
GLASS_EAVG = _read("GGX_GLASS_EAVG").reshape(16, 16)
GLASS_INV_E = _read("GGX_GLASS_INV_E").reshape(16, 16, 16)
GLASS_INV_EAVG = _read("GGX_GLASS_INV_EAVG").reshape(16, 16)


def _position(x: np.ndarray, size: int):
    """Grid cell and fraction of coordinates x in 0..1 on an axis of `size` points: (index, next, t)."""
    x = np.clip(np.nan_to_num(np.asarray(x, np.float64)), 0.0, 1.0) * (size - 1)
    index = np.minimum(x.astype(np.int64), size - 1)
    return index, np.minimum(index + 1, size - 1), x - index


def lookup_1d(table: np.ndarray, x) -> np.ndarray:
    """table (size,) at x, linearly interpolated."""
    i, j, t = _position(x, table.shape[0])
    return (1.0 - t) * table[i] + t * table[j]


def lookup_2d(table: np.ndarray, x, y) -> np.ndarray:
    """table[y][x] at (x, y), bilinearly interpolated."""
    ny, nx = table.shape
    yi, yj, ty = _position(y, ny)
    xi, xj, tx = _position(x, nx)
    row = lambda r: (1.0 - tx) * table[r, xi] + tx * table[r, xj]   # noqa: E731
    return (1.0 - ty) * row(yi) + ty * row(yj)


def lookup_3d(table: np.ndarray, x, y, z) -> np.ndarray:
    """table[z][y][x] at (x, y, z), trilinearly interpolated."""
    zi, zj, tz = _position(z, table.shape[0])
    ny, nx = table.shape[1:]
    yi, yj, ty = _position(y, ny)
    xi, xj, tx = _position(x, nx)

    def plane(s):
        row = lambda r: (1.0 - tx) * table[s, r, xi] + tx * table[s, r, xj]   # noqa: E731
        return (1.0 - ty) * row(yi) + ty * row(yj)
    return (1.0 - tz) * plane(zi) + tz * plane(zj)


def glass_E(rough, mu, eta) -> tuple:
    """(E, Eavg) of rough glass of relative index eta (n,) at roughness and mu (n,): the entering table for
    eta >= 1, the leaving one for eta < 1, at z = ((ior - 1) / (ior + 1))^(1/2) of ior = max(eta, 1 / eta)."""
    eta = np.asarray(eta, np.float64)
    ior = np.where(eta < 1.0, 1.0 / np.maximum(eta, 1e-300), eta)
    z = np.sqrt(np.abs((ior - 1.0) / (ior + 1.0)))
    leaving = eta < 1.0
    E = np.where(leaving, lookup_3d(GLASS_INV_E, rough, mu, z), lookup_3d(GLASS_E, rough, mu, z))
    E_avg = np.where(leaving, lookup_2d(GLASS_INV_EAVG, rough, z), lookup_2d(GLASS_EAVG, rough, z))
    return E, E_avg
