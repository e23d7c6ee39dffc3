"""Rough glass with the Beckmann distribution: Cycles' Glass and Refraction BSDFs set to Beckmann.

core/materials/rough_glass.py's model (each microfacet a little smooth glass boundary; reflect or refract in
proportion to its shares; Walter et al. 2007's Jacobians) with Beckmann's D, Lambda and visible normals
(core/materials/beckmann.py). Cycles' Beckmann glass is isotropic and has no energy compensation.
"""
from __future__ import annotations

from typing import ClassVar

from .rough_glass import RoughGlass


class BeckmannGlass(RoughGlass):
    """Beckmann reflection and refraction at a dielectric boundary; params as Glass's (module docstring)."""

    name: ClassVar[str] = "BECKMANN_GLASS"
    beckmann: ClassVar[bool] = True
