"""The Oren-Nayar BSDF: rough diffuse reflection, as Cycles renders a Diffuse BSDF with Roughness above 0 and the
Principled BSDF's Diffuse Roughness.

A rough diffuse surface is made of tiny Lambertian facets that shadow and light each other: seen from near
the light it looks brighter than Lambert's law says (the facets facing both are lit), and it keeps less light
overall. Cycles uses Fujii's improved Oren-Nayar model, which adds to the Lambertian constant A a term B t
that grows where the view and light directions are on the same side (sigma is the roughness, 0..1):

    A = 1 / (pi + sigma (pi/2 - 2/3)),  B = sigma A,  t = wi.wo - (N.wi)(N.wo), divided by max(N.wi, N.wo) where > 0
    f_single = A + B t

and the light that facets pass to each other before it leaves, which the single-scattering model loses, is
put back as in the OpenPBR specification (the "energy-preserving Oren-Nayar"), from the directional albedo
E(mu) = A pi + B G(mu) of the single-scattering lobe (G in closed form) and its average E_avg:

    f_multi = E_ms (1 - E(N.wo)) (1 - E(N.wi)),  E_ms = rho^2 / pi  E_avg / (1 - E_avg) / (1 - rho (1 - E_avg))

with rho the surface colour. A white surface then reflects all the light it receives at every angle. Cycles
multiplies both terms by the closure's weight (the colour); so does Primer. Sampling is cosine-weighted, as
for Lambert (pdf = N.wi / pi).

Parameters (computed per hit by the node that sets the closure up, `params_of`): A, B, and the multiple
scattering term E_ms (1 - E(N.wo)) per channel.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F
from .base import PARAMS
from .lambert import Lambert

# The slots of its parameter row.
A, B, MULTI = 0, 1, 2


def G(mu: np.ndarray) -> np.ndarray:
    """The directional albedo's angular part: E(mu) = A pi + B G(mu) (mu = cos theta); near grazing its
    first-order expansion, where tan theta misbehaves."""
    mu = np.asarray(mu, np.float64)
    safe = np.clip(mu, 1e-6, 1.0)
    sin = np.sqrt(np.maximum(1.0 - safe * safe, 0.0))
    theta = np.arccos(safe)
    value = sin * (theta - 2.0 / 3.0 - sin * safe) + (2.0 / 3.0) * (sin / safe) * (1.0 - sin ** 3)
    return np.where(mu < 1e-6, (math.pi / 2.0 - 2.0 / 3.0) - mu, value)


def params_of(roughness: np.ndarray, albedo: np.ndarray, mu_o: np.ndarray) -> np.ndarray:
    """(n, PARAMS) closure rows for roughness (n,) in 0..1, colour (n, 3) and mu_o = N.wo (n,)."""
    sigma = np.clip(roughness, 0.0, 1.0)
    a = 1.0 / (math.pi + sigma * (math.pi / 2.0 - 2.0 / 3.0))
    b = sigma * a
    E_avg = a * math.pi + ((2.0 * math.pi - 5.6) / 3.0) * b
    rho = np.asarray(albedo, np.float64)
    E_ms = (1.0 / math.pi) * rho * rho * (E_avg / (1.0 - E_avg))[:, None] / (1.0 - rho * (1.0 - E_avg)[:, None])
    E_o = a * math.pi + b * G(np.maximum(mu_o, 0.0))
    p = np.zeros((len(sigma), PARAMS))
    p[:, A], p[:, B] = a, b
    p[:, MULTI:MULTI + 3] = E_ms * (1.0 - E_o)[:, None]
    return p


class OrenNayar(BSDF):
    """Rough diffuse reflection (module docstring): f cos = N.wi (A + B t + multi (1 - E(N.wi)))."""

    name: ClassVar[str] = "OREN_NAYAR"
    flags: ClassVar[F] = F.REFLECTION | F.DIFFUSE | F.DIFFUSE_TYPE
    params: ClassVar[tuple] = ("A", "B", "multi_r", "multi_g", "multi_b")

    @staticmethod
    def eval(params, N, wo, wi):
        nl = np.maximum(vectors.dot(N, wi), 0.0)
        nv = np.maximum(vectors.dot(N, wo), 0.0)
        t = vectors.dot(wi, wo) - nl * nv
        t = np.where(t > 0.0, t / (np.maximum(nl, nv) + np.finfo(np.float32).tiny), t)
        a, b = params[:, A], params[:, B]
        E_l = a * math.pi + b * G(nl)
        f = (a + b * t)[:, None] + params[:, MULTI:MULTI + 3] * (1.0 - E_l)[:, None]
        return f * nl[:, None], nl * (1.0 / math.pi)

    @staticmethod
    def sample(params, N, wo, u):
        s = Lambert.sample(params, N, wo, u)
        f_cos, pdf = OrenNayar.eval(params, N, wo, s.wi)
        weight = np.divide(f_cos, pdf[:, None], out=np.zeros_like(f_cos), where=pdf[:, None] > 0.0)
        return BsdfSample(s.wi, weight, pdf)
