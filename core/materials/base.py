"""What every BSDF does: evaluate f cos, give the pdf of a direction, and sample a direction.

A BSDF f(wo, wi) says how much of the light arriving from direction wi leaves towards wo. The
lecture's "absorption by the material colour" is the simplest one, the Lambert BSDF colour / pi.

A surface's material becomes, at each hit, a list of closures (core/materials/closures.py): BSDFs
with an RGB weight, as in Cycles. The colour is a closure's weight; the BSDF itself gives, for a
batch of hits at once:

- eval(wo, wi): f cos, the cosine taken with the closure's own normal (0 below it), and the
  solid-angle pdf with which `sample` would choose wi; an integrator weighs light that a light
  sample found with it (next-event estimation) and weighs light sampling against BSDF sampling
  (multiple importance sampling);
- sample(wo, u): a direction wi with its weight f cos / pdf and its pdf, to continue a path.

Conventions: wo points towards the viewer, wi towards the light, both unit and world space; N is
the closure's unit normal, on the viewer's side. A perfectly specular BSDF (a mirror) is a delta:
eval is 0 for every pair of directions, and only `sample` finds its one direction (pdf inf).
A closure's parameters beyond its normal and weight are a row of PARAMS floats (closures.py), whose
meaning each BSDF class lists in `params`.

A BSDF is one class (core/materials/<name>.py), one C file (core/materials/<name>.c) and one entry
in the table of core/materials/__init__.py, whose position is its `kind` tag in C.
"""
from __future__ import annotations

from typing import ClassVar, NamedTuple

import numpy as np


class BsdfSample(NamedTuple):
    """Directions sampled from a BSDF, one per hit.

    wi:     (n, 3) float64 unit sampled direction
    weight: (n, 3) float64 f cos / pdf, the closure's weight not included (0 where nothing was sampled)
    pdf:    (n,) float64 solid-angle pdf of wi (inf for a delta BSDF, 0 where nothing was sampled)
    """

    wi: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray


class BSDF:
    """The interface every BSDF implements, vectorized over the m hits that have one.

    kind:   its tag, the position of its class in core/materials/__init__.py's BSDF_TYPES
    name:   the name a Material uses to choose it
    delta:  True for a perfectly specular BSDF (eval is 0; only `sample` finds its direction)
    params: the names of its parameters, in their slots of a closure's parameter row
    Arguments: params (m, PARAMS) float64; N, wo, wi (m, 3) float64 unit; u (m, 2) or (m, 3) float64 in
    [0, 1): two numbers for the direction, and a third for a BSDF that chooses between lobes (rough glass).
    """

    kind: ClassVar[int] = -1
    name: ClassVar[str] = ""
    delta: ClassVar[bool] = False
    params: ClassVar[tuple] = ()

    @staticmethod
    def eval(params: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray):
        """Return (f cos: (m, 3) float64, pdf: (m,) float64) for each pair of directions."""
        raise NotImplementedError

    @staticmethod
    def sample(params: np.ndarray, N: np.ndarray, wo: np.ndarray, u: np.ndarray) -> BsdfSample:
        """Return one sampled direction per hit."""
        raise NotImplementedError
