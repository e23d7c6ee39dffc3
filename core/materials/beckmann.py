"""The Beckmann microfacet BSDF: Cycles' Glossy BSDF with the Beckmann distribution (isotropic and anisotropic).

The same microfacet reflection as GGX (core/materials/microfacet.py: f cos = F D G2 / (4 N.wo), directions from
the visible normals, pdf = D G1(wo) / (4 N.wo)), with the older Beckmann distribution of normals: the slopes of
the microfacets are Gaussian, so with alpha = roughness^2,

    D(H) = exp(-tan^2(theta_H) / alpha^2) / (pi alpha^2 cos^4(theta_H)),
    anisotropic: D(h) = exp(-((hx/ax)^2 + (hy/ay)^2) / hz^2) / (pi ax ay hz^4),

a shorter tail than GGX's (its highlights have less glow around them). Smith's Lambda of a Gaussian surface has
no closed form; Cycles (and so Primer) uses Walter et al.'s rational fit in a = 1 / (alpha tan theta):

    Lambda = (1 - 1.259 a + 0.396 a^2) / (3.535 a + 2.181 a^2)  for a < 1.6, else 0.

The visible normals are sampled as Heitz and d'Eon (2014) do: stretch the view to unit roughness, draw the
slope along it from its distribution (its CDF involves erf, inverted by Newton steps as Jakob shows), the slope
across it from a Gaussian, turn and unstretch. Since the sampler draws the exact visible normals and pdf uses the
fitted G1, the two differ by the fit's error (under 1% of the pdf; tests/test_distributions.py).
Cycles keeps no energy compensation for Beckmann (no Multiscatter Beckmann): a white lobe loses what bounces
between microfacets, as a single-scattering GGX lobe does.
"""
from __future__ import annotations

from typing import ClassVar

from .microfacet import Microfacet


class Beckmann(Microfacet):
    """Beckmann reflection: Microfacet's model, parameters and anisotropy with Beckmann's D, Lambda and visible
    normals (module docstring)."""

    name: ClassVar[str] = "BECKMANN"
    beckmann: ClassVar[bool] = True
