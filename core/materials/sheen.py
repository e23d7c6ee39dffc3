"""The microfiber sheen BSDF: the soft glow of velvet and cloth at grazing angles, as Cycles renders the Sheen
BSDF (Microfiber) and the Principled BSDF's Sheen.

Cloth is covered in tiny fibres standing up from the surface. Seen head-on, light slips between them; seen at
a grazing angle, the fibres' sides catch it and scatter it back, many times over. Zeltner, Burley and Chiang
("Practical Multiple-Scattering Sheen Using Linearly Transformed Cosines", SIGGRAPH 2022) simulated that
fibre layer as a volume and fitted what it reflects with a *linearly transformed cosine* (LTC, Heitz et al.
2016): take the cosine distribution D_o(w) = max(w.z, 0) / pi, whose integral over the hemisphere is 1, and
stretch it by a 3 x 3 matrix. In the frame of the hit (x along the view direction's tangent part, z = N),
a direction wi is mapped back to the cosine's domain by

    M^-1 = [[a, 0, b],      w = M^-1 wi / |M^-1 wi|,     D(wi) = D_o(w) det(M^-1) / |M^-1 wi|^3
            [0, a, 0],                                         = (N.wi / pi) a^2 / |M^-1 wi|^4
            [0, 0, 1]]

D is again a distribution of directions (its integral is 1), and the lobe is

    f cos = R D(wi),    pdf = D(wi)

with R the directional albedo of the fibre layer, the fraction of light it reflects seen from wo. a, b and R
depend on the view angle (mu = N.wo) and the roughness (how far the fibres lean over). M leaves the z
coordinate alone, so the stretched lobe stays above the surface, and sampling is exact: a cosine-distributed
direction, mapped by M = M^-1's inverse, is distributed by D (its weight f cos / pdf is R).

The fibres that reflect take that light away from what lies below: the Principled BSDF puts the sheen on
top of its other layers, which keep 1 - (largest channel of) the sheen's weight x R (nodes.py).

a, b and R come from the authors' 32 x 32 tables of the volume fit, as Cycles ships and reads them
(core/materials/sheen_table.h, written by tools/sheen_table.py from Cycles' source): bilinear in mu and the
roughness between grid points i / 31, as Cycles' lookup_table_read_2D. Where the table has no valid lobe (a or R
under 1e-5: smooth fibres seen at grazing angles) there is no sheen at all, as in Cycles.

The lobe is not exactly reciprocal (the cosine is part of the fitted lobe), as in Cycles. Cycles counts sheen
as a diffuse closure (CLOSURE_IS_BSDF_DIFFUSE, LABEL_DIFFUSE): a diffuse bounce for the Light Paths limits and
the caustics filter; so does Primer (its flags: BSDFFlags.DIFFUSE and DIFFUSE_TYPE).

Parameters (computed per hit by the node that sets the closure up, `params_of`): a and b; R goes into the
closure's weight.
"""
from __future__ import annotations

import math
import os
from typing import ClassVar

import numpy as np

from .. import vectors
from . import ggx_tables
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F
from .base import PARAMS

# The slots of its parameter row: M^-1's diagonal a and corner b.
A, B = 0, 1
# Cycles clamps the sheen roughness to this range (a roughness of 0 would make the lobe a delta at grazing).
ROUGHNESS_MIN = 1e-3


SHEEN_LTC = ggx_tables._read("SHEEN_LTC", os.path.join(os.path.dirname(os.path.abspath(__file__)), "sheen_table.h"))
LTC_A, LTC_B, ALBEDO = SHEEN_LTC.reshape(3, 32, 32)          # [roughness row][mu column] each
INVALID = 1e-5              # a table entry of |a| or R below this is no lobe (Cycles skips the closure)


def params_of(roughness: np.ndarray, mu_o: np.ndarray) -> tuple:
    """(n, PARAMS) closure rows and R (n,) for roughness (n,) and mu_o = N.wo (n,), both clamped as Cycles does
    (roughness to 1e-3..1, mu to 0..1)."""
    r = np.clip(np.asarray(roughness, np.float64), ROUGHNESS_MIN, 1.0)
    mu = np.clip(np.asarray(mu_o, np.float64), 0.0, 1.0)
    p = np.zeros((len(r), PARAMS))
    p[:, A], p[:, B] = ggx_tables.lookup_2d(LTC_A, mu, r), ggx_tables.lookup_2d(LTC_B, mu, r)
    R = ggx_tables.lookup_2d(ALBEDO, mu, r)
    valid = (np.abs(p[:, A]) >= INVALID) & (R >= INVALID)
    p[~valid, A] = 1.0                  # (any finite lobe: its weight R is 0)
    return p, np.where(valid, R, 0.0)


def frame(N: np.ndarray, wo: np.ndarray) -> tuple:
    """The lobe's frame (T, Bt), (m, 3) each: T along wo's part tangent to N, Bt = N x T (any frame where wo
    is N itself: there b = 0 and the lobe is symmetric about N)."""
    T = wo - np.einsum("ij,ij->i", N, wo)[:, None] * N
    length = np.linalg.norm(T, axis=1)
    head_on = length < 1e-12
    if head_on.any():                   # a vector not along N, made tangent
        other = np.where(np.abs(N[:, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        fallback = other - np.einsum("ij,ij->i", N, other)[:, None] * N
        T = np.where(head_on[:, None], fallback, T)
        length = np.linalg.norm(T, axis=1)
    T = T / length[:, None]
    return T, np.cross(N, T)


def ltc_density(a: np.ndarray, b: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """D at a direction with local coordinates x, y, z (m,) each: (z / pi) a^2 / |M^-1 w|^4, 0 where z <= 0."""
    length_sq = (a * x + b * z) ** 2 + (a * y) ** 2 + z * z
    above = z > 0.0
    safe = np.where(above, length_sq, 1.0)
    return np.where(above, z * a * a / (math.pi * safe * safe), 0.0)


class Sheen(BSDF):
    """Microfiber sheen (module docstring): f cos = pdf = D(wi), the LTC lobe (R is in the closure's weight)."""

    name: ClassVar[str] = "SHEEN"
    flags: ClassVar[F] = F.REFLECTION | F.DIFFUSE | F.DIFFUSE_TYPE
    params: ClassVar[tuple] = ("a", "b")

    @staticmethod
    def eval(params, N, wo, wi):
        T, Bt = frame(N, wo)
        x, y = np.einsum("ij,ij->i", T, wi), np.einsum("ij,ij->i", Bt, wi)
        z = np.einsum("ij,ij->i", N, wi)
        D = ltc_density(params[:, A], params[:, B], x, y, z)
        return np.repeat(D[:, None], 3, axis=1), D

    @staticmethod
    def sample(params, N, wo, u):
        a, b = params[:, A], params[:, B]
        # A cosine-distributed direction (a uniform point on the disk, lifted to the hemisphere) ...
        radius = np.sqrt(u[:, 0])
        cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
        x, y = radius * cos_phi, radius * sin_phi
        z = np.sqrt(np.maximum(1.0 - u[:, 0], 0.0))
        # ... mapped by M: x' = (x - b z) / a, y' = y / a, z' = z, then normalized.
        local = np.stack([(x - b * z) / a, y / a, z], axis=1)
        local /= np.linalg.norm(local, axis=1)[:, None]
        T, Bt = frame(N, wo)
        wi = local[:, 0:1] * T + local[:, 1:2] * Bt + local[:, 2:3] * N
        wi /= np.linalg.norm(wi, axis=1)[:, None]
        pdf = ltc_density(a, b, local[:, 0], local[:, 1], local[:, 2])
        weight = np.where(pdf[:, None] > 0.0, 1.0, 0.0) * np.ones((len(a), 3))
        return BsdfSample(wi, weight, pdf)
