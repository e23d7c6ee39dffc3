"""A perfect mirror: all light leaves in the one reflected direction (the closure's weight tints it)."""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .base import BSDF, BsdfSample
from .base import BSDFFlags as F


def reflect(wo: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Return the mirror direction of wo about N: 2 (N.wo) N - wo, (n, 3) float64."""
    return 2.0 * np.einsum("ij,ij->i", N, wo)[:, None] * N - wo


class Mirror(BSDF):
    """A delta BSDF: eval is 0 for any pair of directions a light sample could find; `sample` returns
    the reflection R = 2 (N.wo) N - wo with weight 1 (f cos / pdf of the delta) and pdf inf.

    Under direct light alone a mirror is black, as in Cycles with max_bounces = 0: only a ray that
    follows R (an integrator that recurses, the lecture's next part) sees what it reflects.
    """

    name: ClassVar[str] = "MIRROR"
    flags: ClassVar[F] = F.REFLECTION | F.SINGULAR | F.GLOSSY_TYPE

    @staticmethod
    def eval(params, N, wo, wi):
        return np.zeros((len(wi), 3)), np.zeros(len(wi))

    @staticmethod
    def sample(params, N, wo, u):
        wi = reflect(wo, N)
        above = np.einsum("ij,ij->i", N, wi) > 0.0
        return BsdfSample(wi, np.repeat(np.where(above, 1.0, 0.0)[:, None], 3, axis=1), np.where(above, np.inf, 0.0))
