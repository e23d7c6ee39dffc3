"""The Transparent BSDF: light passes straight through the surface, tinted by the closure's weight.

A delta BSDF like the mirror: eval is 0, and `sample` continues the ray in its own direction,
wi = -wo, with weight 1 and pdf inf. A path that takes it makes a *transparent* bounce, which Cycles
counts apart (Light Paths > Max Bounces > Transparent) and not as a bounce: alpha-mapped leaves and
glass-like cut-outs cost no light bounce. The Principled BSDF's Alpha gives such a closure of weight
1 - alpha.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .base import BSDF, BsdfSample
from .base import BSDFFlags as F


class Transparent(BSDF):
    """Straight through: wi = -wo, weight 1, pdf inf (module docstring)."""

    name: ClassVar[str] = "TRANSPARENT"
    flags: ClassVar[F] = F.TRANSMISSION | F.SINGULAR | F.STRAIGHT

    @staticmethod
    def eval(params, N, wo, wi):
        return np.zeros((len(wi), 3)), np.zeros(len(wi))

    @staticmethod
    def sample(params, N, wo, u):
        return BsdfSample(-wo, np.ones((len(wo), 3)), np.full(len(wo), np.inf))
