"""The Ashikhmin-Shirley BSDF: Cycles' Glossy BSDF with the Ashikhmin-Shirley distribution (Ashikhmin and
Shirley 2000, "An Anisotropic Phong BRDF Model"), without its Fresnel factor (the colour is the closure's weight).

The half vector H = normalize(wo + wi) follows a Phong lobe around N whose exponents along the tangent and
across it come from alpha = roughness^2 (clamped to [1e-4, 1]): n = 2 / alpha^2 - 2. With Cycles' clamps (every
cosine at least 1e-6),

    isotropic:    p(H) = (n + 1) / (2 pi) (N.H)^n
    anisotropic:  p(H) = sqrt((nx + 1)(ny + 1)) / (2 pi) (N.H)^((nx (H.X)^2 + ny (H.Y)^2) / (1 - (N.H)^2))
    pdf(wi) = p(H) / (4 |H.wo|)                                       (from the half vector to wi)
    f cos = p(H) / (4 |H.wo| max(N.wo, N.wi)) N.wi                     (the paper's specular term, F = 1)

so f cos / pdf = N.wi / max(N.wo, N.wi): no masking term, and sampling the half vector from p(H) (phi uniform,
or per quadrant from the exponents' ratio; cos theta = u^(1 / (n + 1)) with n the exponent at phi) cancels most of
it. A half vector H facing away from wo is turned round, and the direction made from it as Cycles does:
2 (H.wo) (-H) - wo, not the mirror direction and longer than 1; its weight and pdf are eval's at that long vector
(so N.wi in them is longer too, and the half vector eval finds is H again), and the ray goes along it made unit,
as Cycles' does. That sampler's directions are not distributed as eval's pdf says (a few percent of the samples
at grazing views and broad lobes); matching it keeps Primer within Cycles' noise (tests/test_blender_distributions.py).
Roughness below 0.01 (both alphas at the clamp) is a perfect mirror, which the node's setup gives instead.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from . import microfacet as mf
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F

ALPHA_MIN = 1e-4        # the alphas' clamp (Cycles' bsdf_ashikhmin_shirley_setup); both at it: a mirror


def exponent(alpha: np.ndarray) -> np.ndarray:
    """The Phong exponent (m,) of a roughness alpha (m,): 2 / alpha^2 - 2."""
    return 2.0 / (alpha * alpha) - 2.0


def alphas(params: np.ndarray) -> tuple:
    """(alpha_x, alpha_y, anisotropic) (m,) of rows (m, PARAMS): alpha_y is alpha_x where isotropic."""
    aniso = mf.is_anisotropic(params)
    return params[:, mf.ALPHA], np.where(aniso, params[:, mf.ALPHA_Y], params[:, mf.ALPHA]), aniso


def first_quadrant(n_x: np.ndarray, n_y: np.ndarray, u0: np.ndarray, u1: np.ndarray) -> tuple:
    """(phi, cos theta) (m,) of a half vector in the first quadrant of the anisotropic lobe, from u0, u1 (m,)."""
    phi = np.arctan(np.sqrt((n_x + 1.0) / (n_y + 1.0)) * np.tan(0.5 * math.pi * u0))
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    return phi, u1 ** (1.0 / (n_x * cos_phi * cos_phi + n_y * sin_phi * sin_phi + 1.0))


class AshikhminShirley(BSDF):
    """Ashikhmin-Shirley reflection (module docstring); params: Microfacet's slots (alpha, alpha_y, tangent)."""

    name: ClassVar[str] = "ASHIKHMIN_SHIRLEY"
    flags: ClassVar[F] = F.REFLECTION | F.GLOSSY | F.GLOSSY_TYPE | F.OWN_WEIGHT | F.ROUGHENS      # (turned half vectors)
    params: ClassVar[tuple] = mf.Microfacet.params
    specular_alpha: ClassVar[tuple] = ("alpha", "alpha_y")

    @staticmethod
    def singular(params: np.ndarray) -> np.ndarray:
        """Where rows (m, PARAMS) are a mirror: both alphas at most ALPHA_MIN (m,) bool."""
        ax, ay, _ = alphas(params)
        return np.maximum(ax, ay) <= ALPHA_MIN

    @staticmethod
    def eval(params, N, wo, wi):
        ax, ay, aniso = alphas(params)
        cos_NI, cos_NO = mf.dot(N, wo), mf.dot(N, wi)
        valid = (np.maximum(ax, ay) > ALPHA_MIN) & (cos_NI >= 0.0) & (cos_NO >= 0.0)
        cos_NI, cos_NO = np.maximum(cos_NI, 1e-6), np.maximum(cos_NO, 1e-6)
        H = wo + wi
        H /= np.maximum(np.sqrt(mf.dot(H, H)), 1e-300)[:, None]
        cos_HI = np.maximum(np.abs(mf.dot(H, wo)), 1e-6)
        cos_NH = np.maximum(mf.dot(N, H), 1e-6)
        pump = 1.0 / np.maximum(1e-6, cos_HI * np.maximum(cos_NI, cos_NO))
        safe_x, safe_y = np.where(valid, ax, 1.0), np.where(valid, ay, 1.0)
        n_x, n_y = exponent(safe_x), exponent(safe_y)
        lobe = cos_NH ** n_x
        norm = (n_x + 1.0) / (8.0 * math.pi)
        if aniso.any():
            X, Y = mf.tangent_frame(N, np.where(aniso[:, None], params[:, mf.TANGENT:mf.TANGENT + 3], [1.0, 0.0, 0.0]))
            cos_HX, cos_HY = mf.dot(H, X), mf.dot(H, Y)
            tilted = cos_NH < 1.0
            e = (n_x * cos_HX * cos_HX + n_y * cos_HY * cos_HY) / np.where(tilted, 1.0 - cos_NH * cos_NH, 1.0)
            lobe = np.where(aniso, np.where(tilted, cos_NH ** e, 1.0), lobe)
            norm = np.where(aniso, np.sqrt((n_x + 1.0) * (n_y + 1.0)) / (8.0 * math.pi), norm)
        f_cos = np.where(valid, cos_NO * norm * lobe * pump, 0.0)
        pdf = np.where(valid, norm * lobe / cos_HI, 0.0)
        return np.repeat(f_cos[:, None], 3, axis=1), pdf

    @staticmethod
    def half_vectors(params: np.ndarray, N: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Half vectors H (m, 3) drawn from p(H) with u (m, 2), around N (m, 3) (before `sample` turns those facing
        away from the view)."""
        ax, ay, aniso = alphas(params)
        n_x, n_y = exponent(np.maximum(ax, 1e-300)), exponent(np.maximum(ay, 1e-300))
        # 1. The frame: the tangent's where anisotropic.
        t, b = vectors.orthonormal_frame(N)
        if aniso.any():
            X, Y = mf.tangent_frame(N, np.where(aniso[:, None], params[:, mf.TANGENT:mf.TANGENT + 3], [1.0, 0.0, 0.0]))
            t, b = np.where(aniso[:, None], X, t), np.where(aniso[:, None], Y, b)
        # 2. The angles: phi uniform and the isotropic exponent, or a quadrant's phi and its exponent.
        phi, cos_theta = 2.0 * math.pi * u[:, 0], u[:, 1] ** (1.0 / (n_x + 1.0))
        if aniso.any():
            quadrant = np.minimum((u[:, 0] * 4.0).astype(np.int64), 3)
            u0 = np.choose(quadrant, [4.0 * u[:, 0], 4.0 * (0.5 - u[:, 0]), 4.0 * (u[:, 0] - 0.5), 4.0 * (1.0 - u[:, 0])])
            q_phi, q_cos = first_quadrant(n_x, n_y, u0, u[:, 1])
            q_phi = np.choose(quadrant, [q_phi, math.pi - q_phi, math.pi + q_phi, 2.0 * math.pi - q_phi])
            phi, cos_theta = np.where(aniso, q_phi, phi), np.where(aniso, q_cos, cos_theta)
        sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
        cos_phi, sin_phi = np.cos(phi), np.sin(phi)
        return t * (sin_theta * cos_phi)[:, None] + b * (sin_theta * sin_phi)[:, None] + N * cos_theta[:, None]

    @staticmethod
    def sample(params, N, wo, u):
        # 1. A half vector, turned to face wo, and the direction made from it (Cycles' arithmetic).
        H = AshikhminShirley.half_vectors(params, N, u)
        cos_HI = mf.dot(H, wo)
        H = np.where((cos_HI < 0.0)[:, None], -H, H)
        raw = 2.0 * cos_HI[:, None] * H - wo
        # 2. Its value and pdf, from eval at that direction as it is (a turned one is longer than 1: Cycles
        #    evaluates it so), and the direction made unit for the ray.
        f_cos, pdf = AshikhminShirley.eval(params, N, wo, raw)
        wi = raw / np.maximum(np.sqrt(mf.dot(raw, raw)), 1e-300)[:, None]
        pdf = np.where(mf.dot(N, wo) > 0.0, pdf, 0.0)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=pdf[:, None] > 0.0)
        return BsdfSample(wi, weight, pdf)
