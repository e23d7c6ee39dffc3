"""The Toon BSDF: flat, cartoon-like shading, lit fully within a cone and not at all outside it (Cycles' Toon BSDF
node, `closure/bsdf_toon.h`).

Its intensity depends on one angle only: for the Diffuse component the angle between the normal N and the light
direction wi, for the Glossy component the angle between wi and the view direction mirrored about N,
R = 2 (N.wo) N - wo. With the node's Size s and Smooth m turned into angles (s clipped to 1e-5..1, m to 0..1, both
times pi / 2), the cone is lit fully up to max_angle = s pi / 2, then fades linearly to 0 over the next m pi / 2:

    I(angle) = 1 within max_angle,  1 - (angle - max_angle) / smooth  up to max_angle + smooth,  0 beyond
    f cos = I(angle) / (2 pi (1 - cos sample_angle)),  sample_angle = min(max_angle + smooth, pi / 2)

This "f cos" carries no cosine of its own: it is Cycles' eval, which is f cos, taken as it is. Sampling is uniform
over the cone of sample_angle around N (Diffuse) or R (Glossy), pdf = 1 / (2 pi (1 - cos sample_angle)), so a
sample's weight is I(angle) exactly; a Glossy direction that falls below the surface is no sample. With Size 1 and
Smooth 0 the Diffuse component lights the whole hemisphere alike: f cos = 1 / (2 pi) for every light direction, and
a sun of irradiance E at normal incidence gives radiance E / (2 pi) at any angle.

The two components are two BSDFs of one family because Cycles labels them differently (its closure types
CLOSURE_BSDF_DIFFUSE_TOON_ID and CLOSURE_BSDF_GLOSSY_TOON_ID): the Diffuse one's directions are diffuse bounces and
its light goes to the Diffuse passes; the Glossy one's are glossy bounces, go to the Glossy passes, and the caustics
switches take it away as they take any glossy reflection. Their C twin is core/materials/toon.c (diffuse_toon_* and
glossy_toon_*); the Toon BSDF node sets one of them up (ToonNode, nodes.c toon_node).
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import vectors
from .base import BSDF, BsdfSample, PARAMS
from .base import BSDFFlags as F
from .nodes import Node, per_hit_rows

# The slots of its parameter row: the fully lit cone's half-angle and the width of its fading rim, in radians.
MAX_ANGLE, SMOOTH = 0, 1


def params_of(size: np.ndarray, smooth: np.ndarray) -> np.ndarray:
    """(n, PARAMS) closure rows from the node's Size and Smooth (n,), as Cycles' bsdf_toon_setup_common turns them
    into angles."""
    p = np.zeros((len(size), PARAMS))
    p[:, MAX_ANGLE] = np.clip(size, 1e-5, 1.0) * (math.pi / 2.0)
    p[:, SMOOTH] = np.clip(smooth, 0.0, 1.0) * (math.pi / 2.0)
    return p


def intensity(params: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """I(angle) (n,): 1 within the cone, falling linearly to 0 across its rim of width `smooth`."""
    max_angle, smooth = params[:, MAX_ANGLE], params[:, SMOOTH]
    rim = (angle < max_angle + smooth) & (smooth != 0.0)
    fading = 1.0 - (angle - max_angle) / np.where(smooth != 0.0, smooth, 1.0)
    return np.where(angle < max_angle, 1.0, np.where(rim, fading, 0.0))


def cone(params: np.ndarray) -> tuple:
    """The sampled cone's half-angle sample_angle (n,) and its uniform pdf 1 / (2 pi (1 - cos sample_angle)) (n,)."""
    sample_angle = np.minimum(params[:, MAX_ANGLE] + params[:, SMOOTH], math.pi / 2.0)
    one_minus_cos = 2.0 * np.sin(0.5 * sample_angle) ** 2
    return sample_angle, 1.0 / (2.0 * math.pi * one_minus_cos)


def mirrored(N: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """R = 2 (N.wo) N - wo (n, 3): the view direction mirrored about N."""
    return (2.0 * vectors.dot(N, wo))[:, None] * N - wo


def cone_eval(params: np.ndarray, axis: np.ndarray, wi: np.ndarray, valid: np.ndarray) -> tuple:
    """f cos (n, 3) and pdf (n,) of light from wi at the angle it makes with `axis`, where `valid` (n,) bool."""
    angle = np.arccos(np.clip(vectors.dot(axis, wi), 0.0, 1.0))
    sample_angle, pdf = cone(params)
    inside = valid & (angle < sample_angle)
    pdf = np.where(inside, pdf, 0.0)
    value = pdf * intensity(params, angle)
    return np.repeat(value[:, None], 3, axis=1), pdf


def cone_sample(params: np.ndarray, axis: np.ndarray, u: np.ndarray) -> tuple:
    """A direction uniform in the cone around `axis` (n, 3): (wi (n, 3), the angle (n,), pdf (n,))."""
    sample_angle, pdf = cone(params)
    one_minus_cos = 2.0 * np.sin(0.5 * sample_angle) ** 2
    cos_theta = 1.0 - u[:, 0] * one_minus_cos
    sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
    cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
    t, b = vectors.orthonormal_frame(axis)
    wi = t * (sin_theta * cos_phi)[:, None] + b * (sin_theta * sin_phi)[:, None] + axis * cos_theta[:, None]
    return wi, np.arccos(np.clip(cos_theta, -1.0, 1.0)), pdf


class DiffuseToon(BSDF):
    """The Toon BSDF's Diffuse component (module docstring): I of the angle between N and wi, over the cone's pdf."""

    name: ClassVar[str] = "DIFFUSE_TOON"
    flags: ClassVar[F] = F.REFLECTION | F.DIFFUSE | F.DIFFUSE_TYPE
    params: ClassVar[tuple] = ("max_angle", "smooth")

    @classmethod
    def c_name(cls) -> str:
        """Its C functions' prefix in toon.c."""
        return "diffuse_toon"

    @staticmethod
    def eval(params, N, wo, wi):
        return cone_eval(params, N, wi, vectors.dot(N, wi) >= 0.0)

    @staticmethod
    def sample(params, N, wo, u):
        wi, angle, pdf = cone_sample(params, N, u)
        weight = np.repeat(intensity(params, angle)[:, None], 3, axis=1)
        return BsdfSample(wi, weight, pdf)


class GlossyToon(BSDF):
    """The Toon BSDF's Glossy component (module docstring): I of the angle between R (the view mirrored about N)
    and wi, over the cone's pdf; nothing where the view or the light is below N."""

    name: ClassVar[str] = "GLOSSY_TOON"
    flags: ClassVar[F] = F.REFLECTION | F.GLOSSY | F.GLOSSY_TYPE
    params: ClassVar[tuple] = ("max_angle", "smooth")

    @classmethod
    def c_name(cls) -> str:
        """Its C functions' prefix in toon.c."""
        return "glossy_toon"

    @staticmethod
    def eval(params, N, wo, wi):
        above = (vectors.dot(N, wo) > 0.0) & (vectors.dot(N, wi) > 0.0)
        return cone_eval(params, mirrored(N, wo), wi, above)

    @staticmethod
    def sample(params, N, wo, u):
        wi, angle, pdf = cone_sample(params, mirrored(N, wo), u)
        sampled = (vectors.dot(N, wo) > 0.0) & (vectors.dot(N, wi) > 0.0)
        weight = np.where(sampled, intensity(params, angle), 0.0)
        return BsdfSample(wi, np.repeat(weight[:, None], 3, axis=1), np.where(sampled, pdf, 0.0))


class ToonNode(Node):
    """Toon BSDF (Blender's ShaderNodeBsdfToon): one DiffuseToon or GlossyToon closure (`glossy` 0 or 1, the node's
    Component) of the node's weight (its colour), with Size and Smooth; the caustics switches take the Glossy one
    away as any glossy reflection."""

    name, inputs, defaults = "TOON", ("size", "smooth", "glossy"), (0.5, 0.0, 0.0)
    slots = 1

    @staticmethod
    def setup(b, weight, p):
        """One closure of the component's class per hit, its Size and Smooth as angles (params_of)."""
        p = per_hit_rows(p, len(weight))
        kind = GlossyToon.kind if p[0, 2] != 0.0 else DiffuseToon.kind
        b.add(kind, weight, params_of(p[:, 0], p[:, 1]), keep=b.kept(kind))
