"""Rough glass: GGX microfacets that reflect or refract, as Cycles' rough Glass and Refraction BSDF and the
Principled BSDF's rough transmission do.

Each microfacet (normal H, drawn from the GGX normals the viewer sees, as core/materials/microfacet.py
does) is a little smooth glass boundary (core/materials/glass.py): it reflects R(wo.H) and refracts
T(wo.H) of the light, and one of the two is chosen in proportion. For a pair of directions the
microfacet normal is the half vector: H = wo + wi for reflection, and for refraction, where Snell's law
bends wi into wo at H, H = -(eta wi + wo) (Walter et al. 2007, "Microfacet Models for Refraction
through Rough Surfaces"), both normalised and turned to N's side. Then, with D, Lambda and the lobe's
energy scale as in the reflection-only lobe,

    reflection:   f cos = R D / (4 N.wo) G2,   pdf = P(reflect | H) D / (4 N.wo) G1(wo)
    refraction:   f cos = T D eta^2 |wo.H| |wi.H| / (N.wo |eta wi + wo|^2) G2,
                  pdf = P(refract | H) D eta^2 |wo.H| |wi.H| / (N.wo |eta wi + wo|^2) G1(wo)

with G2 = 1 / (1 + Lambda(wo) + Lambda(wi)), G1(wo) = 1 / (1 + Lambda(wo)). As in Cycles the refracted
radiance is not scaled by 1 / eta^2 (smooth glass lets T through unscaled too). A lobe smoother than
ROUGHNESS_SQ_THRESHOLD is smooth glass, whose closure the node setups choose instead.

Choosing between reflection and refraction takes a third random number: u[:, 2], which
closures.sample_closures derives from the number that picked the closure.

Cycles parity, stated: for a pair of directions eval does not check that a microfacet can connect them
(that wo sees H, and that refraction crosses H while reflection does not: `connects`), as Cycles'
bsdf_microfacet_eval does not either. The sampler only ever produces pairs that connect, so light
samples find some light that BSDF samples cannot: in a test of a sphere of roughness 0.7 lit from
behind, 25% more than the physical model, which is what Cycles renders; at roughness 0.3, under 1%.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .. import vectors
from . import microfacet as mf
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F
from .glass import refract, shares


def half_vector(wo: np.ndarray, wi: np.ndarray, eta: np.ndarray, transmit: np.ndarray) -> tuple:
    """(H (n, 3) unit, |eta wi + wo| (n,)): the microfacet normal that reflects wo into wi, or refracts
    (where `transmit` (n,) bool) light from wi into wo; turned to N's side by the caller."""
    raw = np.where(transmit[:, None], -(eta[:, None] * wi + wo), wo + wi)
    length = np.maximum(np.linalg.norm(raw, axis=1), 1e-300)
    return raw / length[:, None], length


def connects(N: np.ndarray, wo: np.ndarray, wi: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Which pairs (n,) bool a microfacet can connect: wo sees H, and the light from wi crosses H where it
    is refracted (wi below N) and does not where it is reflected (the physical model's support)."""
    transmit = np.einsum("ij,ij->i", N, wi) < 0.0
    H, _ = half_vector(wo, wi, eta, transmit)
    H = H * np.where(np.einsum("ij,ij->i", N, H) < 0.0, -1.0, 1.0)[:, None]
    cos_HO, cos_HI = np.einsum("ij,ij->i", H, wo), np.einsum("ij,ij->i", H, wi)
    return (cos_HO > 0.0) & np.where(transmit, cos_HI < 0.0, cos_HI > 0.0)


class RoughGlass(BSDF):
    """GGX reflection and refraction at a dielectric boundary (module docstring); params as Glass's."""

    name: ClassVar[str] = "ROUGH_GLASS"
    flags: ClassVar[F] = F.REFLECTION | F.TRANSMISSION | F.GLOSSY | F.GLASS_TYPE | F.ROUGHENS
    params: ClassVar[tuple] = ("alpha", "fresnel", "ior", "f0_r", "f0_g", "f0_b", "f90_r", "f90_g", "f90_b",
                               "energy_scale", "reflect_r", "reflect_g", "reflect_b",
                               "transmit_r", "transmit_g", "transmit_b")
    specular_alpha: ClassVar[tuple] = ("alpha", "alpha")
    beckmann: ClassVar[bool] = False          # Beckmann's D, Lambda and visible normals (beckmann_glass.py)

    @classmethod
    def distribution(cls) -> tuple:
        """Its (D, Lambda, visible-normal sampler): GGX's, or Beckmann's."""
        if cls.beckmann:
            return mf.D_beckmann, mf.lambda_beckmann, mf.sample_visible_normal_beckmann
        return mf.D_ggx, mf.lambda_ggx, mf.sample_visible_normal

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo: its reflected and transmitted shares of light arriving at N.wo."""
        return shares(params, np.clip(np.einsum("ij,ij->i", N, wo), 0.0, 1.0))

    @classmethod
    def eval(cls, params, N, wo, wi):
        D, lambda_, _ = cls.distribution()
        alpha2 = params[:, mf.ALPHA] ** 2
        eta = params[:, mf.IOR]
        cos_NO, cos_NI = np.einsum("ij,ij->i", N, wo), np.einsum("ij,ij->i", N, wi)
        transmit = cos_NI < 0.0
        # 1. The microfacet normal that sends wi to wo, on N's side.
        H, length = half_vector(wo, wi, eta, transmit)
        H = H * np.where(np.einsum("ij,ij->i", N, H) < 0.0, -1.0, 1.0)[:, None]
        cos_HO, cos_HI = np.einsum("ij,ij->i", H, wo), np.einsum("ij,ij->i", H, wi)
        # 2. Pairs with the viewer above the surface (every such pair, as Cycles: see `connects`).
        valid = (cos_NO > 0.0) & (cos_NI != 0.0) & (alpha2 > mf.ROUGHNESS_SQ_THRESHOLD)
        # 3. What the microfacet reflects and refracts, and how often the sampler picks each.
        R, T = shares(params, np.clip(np.abs(cos_HO), 0.0, 1.0))
        total = R.mean(axis=1) + T.mean(axis=1)
        p_reflect = np.divide(R.mean(axis=1), total, out=np.ones(len(total)), where=total > 0.0)
        lobe = np.where(transmit, 1.0 - p_reflect, p_reflect)
        # 4. D times the Jacobian from H to wi, over N.wo; then masking and shadowing.
        safe_NO = np.where(valid, cos_NO, 1.0)
        jacobian = np.where(transmit, eta * eta * np.abs(cos_HO * cos_HI) / (length * length), 0.25)
        safe_alpha2 = np.where(valid, alpha2, 1.0)
        common = D(safe_alpha2, mf.dot(N, H)) / safe_NO * jacobian
        lambda_O = lambda_(safe_alpha2, safe_NO)
        lambda_I = lambda_(safe_alpha2, np.where(valid, np.abs(cos_NI), 1.0))
        pdf = np.where(valid, common * lobe / (1.0 + lambda_O), 0.0)
        scale = np.where(valid, common / (1.0 + lambda_O + lambda_I) * params[:, mf.ENERGY], 0.0)
        return np.where(transmit[:, None], T, R) * scale[:, None], pdf

    @classmethod
    def sample(cls, params, N, wo, u):
        # 1. A microfacet normal the viewer sees.
        t, b = vectors.orthonormal_frame(N)
        local = np.stack([np.einsum("ij,ij->i", t, wo), np.einsum("ij,ij->i", b, wo), np.einsum("ij,ij->i", N, wo)],
                         axis=1)
        h = cls.distribution()[2](np.where(local[:, 2:] > 0.0, local, [0.0, 0.0, 1.0]), params[:, mf.ALPHA], u)
        H = t * h[:, 0:1] + b * h[:, 1:2] + N * h[:, 2:3]
        # 2. Reflect or refract at it, in proportion to what it reflects and refracts.
        cos_HO = np.einsum("ij,ij->i", H, wo)
        R, T = shares(params, np.clip(cos_HO, 0.0, 1.0))
        total = R.mean(axis=1) + T.mean(axis=1)
        p_reflect = np.divide(R.mean(axis=1), total, out=np.ones(len(total)), where=total > 0.0)
        lobe_u = u[:, 2] if u.shape[1] > 2 else np.full(len(u), 0.5)
        reflect = lobe_u < p_reflect
        refracted, _ = refract(wo, H, params[:, mf.IOR])
        wi = np.where(reflect[:, None], 2.0 * cos_HO[:, None] * H - wo, refracted)
        # 3. Its value and pdf, from eval (a direction on the wrong side of N is no sample).
        f_cos, pdf = cls.eval(params, N, wo, wi)
        cos_NI = np.einsum("ij,ij->i", N, wi)
        ok = (pdf > 0.0) & np.where(reflect, cos_NI > 0.0, cos_NI < 0.0) & (total > 0.0)
        pdf = np.where(ok, pdf, 0.0)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=pdf[:, None] > 0.0)
        return BsdfSample(wi, weight, pdf)
