"""The Lambert BSDF: a diffuse surface that reflects colour / pi of the irradiance, the same in every direction."""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from .base import BSDF, BsdfSample
from .base import BSDFFlags as F


class Lambert(BSDF):
    """f = 1 / pi (the closure's weight is the colour): the lecture's absorption, the surface keeps
    1 - colour of the light it receives. f cos = max(N.wi, 0) / pi. Sampling is cosine-weighted over
    the hemisphere around N: pdf = max(N.wi, 0) / pi, so each sample's f cos / pdf is exactly 1."""

    name: ClassVar[str] = "DIFFUSE"
    flags: ClassVar[F] = F.REFLECTION | F.DIFFUSE | F.DIFFUSE_TYPE

    @staticmethod
    def eval(params, N, wo, wi, signed_cosine: bool = False):
        """f cos and pdf; signed_cosine keeps N.wi below the surface (the lecture switch "Clamp N.L" off)."""
        cosine = np.einsum("ij,ij->i", N, wi)
        pdf = np.maximum(cosine, 0.0) * (1.0 / math.pi)
        f_cos = (cosine if signed_cosine else np.maximum(cosine, 0.0)) * (1.0 / math.pi)
        return np.repeat(f_cos[:, None], 3, axis=1), pdf

    @staticmethod
    def sample(params, N, wo, u):
        # A point uniform on the unit disk (polar map), lifted onto the hemisphere: cosine-weighted.
        r = np.sqrt(u[:, 0])
        cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
        x, y = r * cos_phi, r * sin_phi
        z = np.sqrt(np.maximum(0.0, 1.0 - u[:, 0]))
        t, b = vectors.orthonormal_frame(N)
        wi = t * x[:, None] + b * y[:, None] + N * z[:, None]
        pdf = z * (1.0 / math.pi)
        weight = np.repeat(np.where(pdf > 0.0, 1.0, 0.0)[:, None], 3, axis=1)
        return BsdfSample(wi, weight, pdf)
