"""The Ashikhmin velvet BSDF: the older sheen, as Cycles renders the Sheen BSDF with its Ashikhmin distribution
(glTF's sheen materials, imported by Blender, use it).

Ashikhmin, Premoze and Shirley (2000) modelled velvet as a microfacet surface whose facets mostly stand
*sideways*: the "inverted Gaussian" distribution of half-vector angles theta_h (N.H = cos theta_h)

    D(H) = exp(-cot^2 theta_h / sigma^2) / (pi sigma^2 sin^4 theta_h)

is largest where H is far from N, so light is reflected most when the view and light directions are both
near grazing. With the microfacet form f = D G / (4 N.wo N.wi) and Cycles' shadowing term
G = min(1, 2 (N.H / |wo.H|) N.wo, 2 (N.H / |wo.H|) N.wi), the lobe is

    f cos = D G / (4 N.wo)                (N.wi and N.wo > 0; H = (wo + wi) / |wo + wi|)

sigma is the node's Roughness (at least 0.01, as Cycles clamps it). The model neither conserves energy nor is
normalized: it reflects what the formula says (at sigma 1, about 0.2 of the light seen head-on). It is
symmetric in wo and wi (reciprocal). Sampling is uniform over the hemisphere around N (pdf = 1 / (2 pi)), as
Cycles does.

Cycles' closure type is glossy (CLOSURE_IS_BSDF_GLOSSY: no bump shadowing term, the Glossy passes), but its
samples are labelled diffuse, so its bounces count as diffuse bounces; Primer follows both
(its flags: BSDFFlags.DIFFUSE for bounces, GLOSSY_TYPE for passes and bump shadowing).

Parameters (computed per hit by the node that sets the closure up, `params_of`): 1 / sigma^2.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F
from .base import PARAMS

# The slot of its parameter row.
INV_SIGMA2 = 0
# Cycles' smallest sigma.
SIGMA_MIN = 0.01


def params_of(roughness: np.ndarray) -> np.ndarray:
    """(n, PARAMS) closure rows for the Sheen BSDF's Roughness (n,) (sigma, clamped to 0.01..1)."""
    sigma = np.maximum(np.clip(np.asarray(roughness, np.float64), 0.0, 1.0), SIGMA_MIN)
    p = np.zeros((len(sigma), PARAMS))
    p[:, INV_SIGMA2] = 1.0 / (sigma * sigma)
    return p


class Velvet(BSDF):
    """Ashikhmin velvet (module docstring): f cos = D G / (4 N.wo); uniform hemisphere sampling."""

    name: ClassVar[str] = "VELVET"
    flags: ClassVar[F] = F.REFLECTION | F.DIFFUSE | F.GLOSSY_TYPE
    params: ClassVar[tuple] = ("inv_sigma2",)

    @staticmethod
    def eval(params, N, wo, wi):
        cos_v, cos_l = vectors.dot(N, wo), vectors.dot(N, wi)
        H = wo + wi
        H = H / np.maximum(np.sqrt(vectors.dot(H, H)), 1e-300)[:, None]
        cos_nh, cos_hv = vectors.dot(N, H), np.abs(vectors.dot(wo, H))
        lit = (cos_v > 0.0) & (cos_l > 0.0) & (np.abs(cos_nh) < 1.0 - 1e-5) & (cos_hv > 1e-5)
        ratio = np.maximum(cos_nh / np.where(lit, cos_hv, 1.0), 1e-5)
        G = np.minimum(1.0, np.minimum(2.0 * np.abs(ratio * cos_v), 2.0 * np.abs(ratio * cos_l)))
        sin2 = np.where(lit, 1.0 - cos_nh * cos_nh, 1.0)
        inv = params[:, INV_SIGMA2]
        D = np.exp(-(cos_nh * cos_nh / sin2) * inv) * inv / (math.pi * sin2 * sin2)
        f_cos = np.where(lit, 0.25 * D * G / np.where(lit, cos_v, 1.0), 0.0)
        pdf = np.where(cos_l > 0.0, 1.0 / (2.0 * math.pi), 0.0)
        return np.repeat(f_cos[:, None], 3, axis=1), pdf

    @staticmethod
    def sample(params, N, wo, u):
        # Uniform over the hemisphere: cos theta = u0, azimuth 2 pi u1.
        z = u[:, 0]
        radius = np.sqrt(np.maximum(1.0 - z * z, 0.0))
        cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
        t, b = vectors.orthonormal_frame(N)
        wi = t * (radius * cos_phi)[:, None] + b * (radius * sin_phi)[:, None] + N * z[:, None]
        f_cos, pdf = Velvet.eval(params, N, wo, wi)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=pdf[:, None] > 0.0)
        return BsdfSample(wi, weight, pdf)
