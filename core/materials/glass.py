"""Smooth glass: light is reflected or refracted at a dielectric boundary, in the shares Fresnel gives.

A ray arriving at cos_i = N.wo on a boundary with relative index eta (the index behind the surface over
the index in front: IOR entering glass, 1 / IOR leaving it) is reflected about N with probability
R / (R + T) and bent by Snell's law, sin_t = sin_i / eta, otherwise:

    wt = -wo / eta + (cos_i / eta - cos_t) N,   cos_t = sqrt(1 - (1 - cos_i^2) / eta^2)

Past the critical angle (sin_i > eta) nothing is transmitted: total internal reflection. R is the
Fresnel reflectance (exact, or the dielectric curve remapped from F0 to F90 as the Principled BSDF's
transmission does) times the reflection tint, T = (1 - F) times the transmission tint. Both lobes are
deltas: eval is 0, and only `sample` finds the directions (weight R / P(reflect) or T / P(refract)). The choice
takes u[:, 2], where the closure pick fell in this closure's share (closures.sample_closures), as Cycles'
bsdf_microfacet_sample takes rand.z: one stratified number then chooses among a mixture's closures and between
the two lobes, and a pane mixed with others (windows of Glass and Transparent) is no noisier than glass alone.
Cycles' Glass and Refraction BSDF at roughness 0, and the Principled BSDF's transmission, use it.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from . import microfacet as mf
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F

# Parameter slots beyond the microfacet's (fresnel, ior, f0, f90): the two tints.
REFLECT_TINT, TRANSMIT_TINT = 10, 13


def refract(wo: np.ndarray, N: np.ndarray, eta: np.ndarray) -> tuple:
    """Snell's law: (the refracted directions (n, 3), which exist (n,) bool) of wo about N (both unit, N on
    wo's side) into a medium of relative index eta (n,)."""
    cos_i = np.einsum("ij,ij->i", N, wo)
    cos_t2 = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta)
    cos_t = np.sqrt(np.maximum(cos_t2, 0.0))
    wt = -wo / eta[:, None] + (cos_i / eta - cos_t)[:, None] * N
    return wt, cos_t2 > 0.0


def shares(params: np.ndarray, cos_i: np.ndarray) -> tuple:
    """(R (n, 3), T (n, 3)): the reflected and transmitted shares of light arriving at cos_i (n,)."""
    F = mf.fresnel(params, cos_i)
    inside = 1.0 - (1.0 - cos_i * cos_i) / (params[:, mf.IOR] ** 2) <= 0.0       # total internal reflection
    R = np.where(inside[:, None], 1.0, F) * params[:, REFLECT_TINT:REFLECT_TINT + 3]
    T = np.where(inside[:, None], 0.0, 1.0 - F) * params[:, TRANSMIT_TINT:TRANSMIT_TINT + 3]
    return R, T


class Glass(BSDF):
    """A smooth dielectric boundary (module docstring): a delta BSDF that reflects or refracts."""

    name: ClassVar[str] = "GLASS"
    flags: ClassVar[F] = F.REFLECTION | F.TRANSMISSION | F.SINGULAR | F.GLASS_TYPE
    params: ClassVar[tuple] = ("alpha", "fresnel", "ior", "f0_r", "f0_g", "f0_b", "f90_r", "f90_g", "f90_b",
                               "energy_scale", "reflect_r", "reflect_g", "reflect_b",
                               "transmit_r", "transmit_g", "transmit_b")

    @staticmethod
    def albedo(params, N, wo):
        """The colour passes' albedo: its reflected and transmitted shares of light arriving at N.wo."""
        return shares(params, np.clip(np.einsum("ij,ij->i", N, wo), 0.0, 1.0))

    @staticmethod
    def eval(params, N, wo, wi):
        return np.zeros((len(wi), 3)), np.zeros(len(wi))

    @staticmethod
    def sample(params, N, wo, u):
        cos_i = np.einsum("ij,ij->i", N, wo)
        R, T = shares(params, np.clip(cos_i, 0.0, 1.0))
        total = R.mean(axis=1) + T.mean(axis=1)
        p_reflect = np.divide(R.mean(axis=1), total, out=np.ones(len(total)), where=total > 0.0)
        wt, _ = refract(wo, N, params[:, mf.IOR])
        # (the third number: where the closure pick fell in this closure's share, so that the choice among the
        #  mixture's closures and this lobe choice are one stratified number, as Cycles' rand_bsdf.z)
        lobe_u = u[:, 2] if u.shape[1] > 2 else u[:, 0]
        reflect = lobe_u < p_reflect
        wi = np.where(reflect[:, None], 2.0 * cos_i[:, None] * N - wo, wt)
        weight = np.where(reflect[:, None], R / np.maximum(p_reflect, 1e-300)[:, None],
                          T / np.maximum(1.0 - p_reflect, 1e-300)[:, None])
        ok = (cos_i > 0.0) & (total > 0.0)
        return BsdfSample(wi, np.where(ok[:, None], weight, 0.0), np.where(ok, np.inf, 0.0))
