"""The Lambert BSDF: a diffuse surface that reflects colour / pi of the irradiance, the same in every direction."""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from .base import BSDF, BsdfSample


class Lambert(BSDF):
    """f = colour / pi. The lecture's absorption: the surface keeps 1 - colour of the light it receives.

    f is the same for every pair of directions; the cosine N.L (clamped at 0 by the lecture) is the
    integrator's. Sampling is cosine-weighted over the hemisphere around N: pdf = max(N.wi, 0) / pi,
    so each sample's weight f cos / pdf is exactly the colour.
    """

    kind: ClassVar[int] = 0
    name: ClassVar[str] = "DIFFUSE"

    @staticmethod
    def f(color, N, wo, wi):
        return color * (1.0 / math.pi)

    @staticmethod
    def pdf(color, N, wo, wi):
        return np.maximum(np.einsum("ij,ij->i", N, wi), 0.0) * (1.0 / math.pi)

    @staticmethod
    def sample(color, N, wo, u):
        # A point uniform on the unit disk (polar map), lifted onto the hemisphere: cosine-weighted.
        r = np.sqrt(u[:, 0])
        cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
        x, y = r * cos_phi, r * sin_phi
        z = np.sqrt(np.maximum(0.0, 1.0 - u[:, 0]))
        t, b = vectors.orthonormal_frame(N)
        wi = t * x[:, None] + b * y[:, None] + N * z[:, None]
        pdf = z * (1.0 / math.pi)
        weight = np.where((pdf > 0.0)[:, None], color, 0.0)
        return BsdfSample(wi, weight, pdf)
