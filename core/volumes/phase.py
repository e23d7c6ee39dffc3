"""Phase functions: how a scattering medium sends the light it scatters on, the volume's BSDF.

A phase function p(wo, wi) is a density over the sphere of directions (it integrates to 1): the share of the light
arriving from wi that a scattering event sends towards wo. With a BSDF's conventions (wo towards the viewer, wi
towards the light) it depends only on the angle theta by which the light turns, between its direction of travel
before the event, -wi, and after it, wo. Henyey and Greenstein's one-parameter family is what Cycles' Volume Scatter
and Principled Volume use:

    p(cos theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5),    cos theta = dot(-wo, wi)

where theta is the angle by which the light turns: g > 0 scatters forward (light goes on roughly straight), g < 0
backward, g = 0 evenly (1 / 4 pi). `sample` inverts its cdf exactly, so eval / pdf = 1 (Cycles: "perfect importance
sampling").
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import vectors


class PhaseSample(NamedTuple):
    """Directions sampled from a phase function: wi (n, 3) unit, pdf (n,) (the weight p / pdf is 1)."""

    wi: np.ndarray
    pdf: np.ndarray


class HenyeyGreenstein:
    """The Henyey-Greenstein phase function of anisotropy g (n,) float64 or a float, |g| < 1."""

    def __init__(self, g):
        self.g = g

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """p(wo, wi) (n,) float64 for unit directions wo (towards the viewer) and wi (towards the light), (n, 3)."""
        return henyey_greenstein(np.einsum("ij,ij->i", -wo, wi), self.g)

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """The solid-angle pdf (n,) of `sample` choosing wi: p itself."""
        return self.eval(wo, wi)

    def sample(self, wo: np.ndarray, u: np.ndarray) -> PhaseSample:
        """Directions wi (n, 3) towards the light for viewers along wo (n, 3), from unit-square numbers u (n, 2):
        the angle from the cdf's inverse, the azimuth uniform around the light's direction of travel -wo."""
        g = np.broadcast_to(np.asarray(self.g, np.float64), (len(wo),))
        isotropic = np.abs(g) < 1e-3
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u[:, 0])
            cos_theta = np.where(isotropic, 1.0 - 2.0 * u[:, 0], (1.0 + g * g - s * s) / (2.0 * g))
        cos_theta = np.clip(cos_theta, -1.0, 1.0)
        sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
        phi = 2.0 * np.pi * u[:, 1]
        axis = -wo                                       # wi at theta = 0: light that goes on straight to the viewer
        T, B = vectors.orthonormal_frame(axis)
        wi = (sin_theta * np.cos(phi))[:, None] * T + (sin_theta * np.sin(phi))[:, None] * B + cos_theta[:, None] * axis
        return PhaseSample(wi, henyey_greenstein(cos_theta, g))


def henyey_greenstein(cos_theta: np.ndarray, g) -> np.ndarray:
    """(1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^1.5) (n,) float64."""
    denom = 1.0 + g * g - 2.0 * g * cos_theta
    return (1.0 - g * g) / (4.0 * np.pi * denom * np.sqrt(denom))
