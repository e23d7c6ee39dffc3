"""What every BSDF does: evaluate f, give the pdf of a direction, and sample a direction.

A BSDF f(wo, wi) says how much of the light arriving from direction wi leaves towards wo. The
lecture's "absorption by the material colour" is the simplest one, the Lambert BSDF colour / pi.
An integrator needs three things of a BSDF, for a batch of hits at once:

- f(wo, wi): to weigh light that a light sample found (next-event estimation), without the cosine:
  the integrator multiplies by N.L itself, as the lecture does;
- pdf(wo, wi): the solid-angle density with which `sample` would choose wi, to weigh light
  sampling against BSDF sampling (multiple importance sampling);
- sample(wo, u): a direction wi with its weight f cos / pdf and pdf, to continue a path.

Conventions: wo points towards the viewer (-D), wi towards the light, both unit and world space; N
is the unit shading normal facing the viewer. A perfectly specular BSDF (a mirror) is a delta:
f and pdf are 0 for every pair of directions, and only `sample` finds its one direction (pdf inf).

A BSDF is one class (core/materials/<name>.py), one C file (core/materials/<name>.c) and one entry
in the table of core/materials/__init__.py, whose position is its `kind` tag in C.
"""
from __future__ import annotations

from typing import ClassVar, NamedTuple

import numpy as np


class BsdfSample(NamedTuple):
    """Directions sampled from a BSDF, one per hit.

    wi:     (n, 3) float64 unit sampled direction
    weight: (n, 3) float64 f(wo, wi) |N.wi| / pdf (0 where nothing was sampled)
    pdf:    (n,) float64 solid-angle pdf of wi (inf for a delta BSDF, 0 where nothing was sampled)
    """

    wi: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray


class BSDF:
    """The interface every BSDF implements. `color` is each hit's (n, 3) float64 colour parameter.

    kind:  its tag, the position of its class in core/materials/__init__.py's BSDF_TYPES
    name:  the name a Material uses to choose it
    delta: True for a perfectly specular BSDF (f and pdf are 0; only `sample` finds its direction)
    """

    kind: ClassVar[int] = -1
    name: ClassVar[str] = ""
    delta: ClassVar[bool] = False

    @staticmethod
    def f(color: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """Return f(wo, wi) without the cosine: (n, 3) float64."""
        raise NotImplementedError

    @staticmethod
    def pdf(color: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """Return the solid-angle pdf with which `sample` chooses wi: (n,) float64."""
        raise NotImplementedError

    @staticmethod
    def sample(color: np.ndarray, N: np.ndarray, wo: np.ndarray, u: np.ndarray) -> BsdfSample:
        """Return one sampled direction per hit; u: (n, 2) float64 uniform numbers in [0, 1)."""
        raise NotImplementedError
