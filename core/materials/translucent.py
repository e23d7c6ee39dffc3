"""The Translucent BSDF: a thin diffuse sheet that lets light through, scattering it evenly to the other side.

Leaves, paper, lampshades, curtains: light arriving on one side leaves the other side as if from a Lambert
surface turned round. For a closure with normal N (on the viewer's side) and light from wi:

    f cos = max(-N.wi, 0) / pi        (0 for light on the viewer's side)

Sampling is cosine-weighted over the hemisphere around -N, so each sample's f cos / pdf is exactly 1, as
Lambert's. Its directions go through the surface and are labelled diffuse (Cycles' LABEL_TRANSMIT |
LABEL_DIFFUSE): a path counts them as transmission bounces, the rays they send are transmission rays, and light
samples on the far side count for it (BSDFFlags.TRANSMISSION without SINGULAR). Its closure type is diffuse
(CLOSURE_IS_BSDF_DIFFUSE): its light goes to the Diffuse passes, and bump shadowing darkens it as it does
Lambert's. All of that follows from its flags; nothing else in Primer names it.

The Translucent BSDF node adds one such closure, weighted by its colour (TranslucentNode); its Normal input, when
linked, is the closure's normal. Its C twin is core/materials/translucent.c.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .base import BSDF, BsdfSample
from .base import BSDFFlags as F
from .lambert import Lambert
from .nodes import Node


class Translucent(BSDF):
    """f = 1 / pi towards the side opposite N (the closure's weight is the colour): f cos = max(-N.wi, 0) / pi;
    sampled cosine-weighted around -N, pdf = max(-N.wi, 0) / pi."""

    name: ClassVar[str] = "TRANSLUCENT"
    flags: ClassVar[F] = F.TRANSMISSION | F.DIFFUSE | F.DIFFUSE_TYPE

    @staticmethod
    def eval(params, N, wo, wi):
        cosine = np.maximum(-np.einsum("ij,ij->i", N, wi), 0.0) * (1.0 / math.pi)
        return np.repeat(cosine[:, None], 3, axis=1), cosine

    @staticmethod
    def sample(params, N, wo, u) -> BsdfSample:
        return Lambert.sample(params, -N, wo, u)       # Lambert's hemisphere, turned to the far side


class TranslucentNode(Node):
    """Translucent BSDF (Blender's ShaderNodeBsdfTranslucent): one Translucent closure of the node's weight (its
    colour), with the node's normal."""

    name, inputs, defaults = "TRANSLUCENT", (), ()
    bsdf = Translucent
    blender = "ShaderNodeBsdfTranslucent"
