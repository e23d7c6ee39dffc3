"""Materials: what a surface does with the light that reaches it, as BSDFs in one table.

BSDF_TYPES is the table: a BSDF's `kind` tag is its class's position in it, and
core/materials/bsdf.c dispatches on the same tag. To add a BSDF, write its class
(core/materials/base.py says what it implements), its C file, and one entry here and in bsdf.c.

A scene's materials become one MaterialTable per render: a row per material (its BSDF and colour),
and a last row for triangles without a material (Blender's default grey, diffuse).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .base import BSDF, BsdfSample
from .lambert import Lambert
from .mirror import Mirror

BSDF_TYPES = (Lambert, Mirror)
BSDF_BY_NAME = {cls.name: cls for cls in BSDF_TYPES}

assert all(cls.kind == index for index, cls in enumerate(BSDF_TYPES)), "a BSDF's kind is its place in BSDF_TYPES"

# The colour used when a triangle's material is missing (Blender's default grey).
DEFAULT_BASE_COLOR = (0.8, 0.8, 0.8)


@dataclass
class Material:
    """A surface's material: one BSDF from the table (by name) and its colour.

    base_color: (3,) float64 in 0..1, the BSDF's colour (the Lambert albedo, the mirror's tint)
    bsdf:       a name in BSDF_BY_NAME ("DIFFUSE" or "MIRROR")
    """

    base_color: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_BASE_COLOR))
    name: str = "Material"
    bsdf: str = "DIFFUSE"


class MaterialTable(NamedTuple):
    """The scene's materials as the integrators read them, one row per material and a default row last.

    kind:  (m + 1,) int32 each material's BSDF tag
    color: (m + 1, 3) float64 each material's colour, clipped to 0..1
    """

    kind: np.ndarray
    color: np.ndarray

    @classmethod
    def of(cls, materials: list) -> "MaterialTable":
        """Build the table of `materials` (an unknown BSDF name is refused with a clear message)."""
        for material in materials:
            if material.bsdf not in BSDF_BY_NAME:
                raise ValueError(f"material '{material.name}' asks for BSDF {material.bsdf!r}; "
                                 f"Primer knows {sorted(BSDF_BY_NAME)}")
        kind = np.array([BSDF_BY_NAME[m.bsdf].kind for m in materials] + [Lambert.kind], np.int32)
        colors = [np.asarray(m.base_color, np.float64)[:3] for m in materials] + [DEFAULT_BASE_COLOR]
        return cls(kind, np.clip(np.nan_to_num(np.array(colors, np.float64)), 0.0, 1.0))


def _by_kind(kind: np.ndarray, method: str, width: int, *args) -> np.ndarray:
    """Call BSDF method `method` of each hit's BSDF on its rows of args; one call per kind present."""
    first = int(kind[0]) if len(kind) else Lambert.kind
    if len(kind) == 0 or (kind == first).all():
        return getattr(BSDF_TYPES[first], method)(*args)
    out = np.zeros((len(kind), width) if width else len(kind))
    for k in np.unique(kind):
        rows = np.flatnonzero(kind == k)
        out[rows] = getattr(BSDF_TYPES[int(k)], method)(*(a[rows] for a in args))
    return out


def f(kind: np.ndarray, color: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Return each hit's BSDF value f(wo, wi), without the cosine: kind (n,) int32 -> (n, 3) float64."""
    return _by_kind(kind, "f", 3, color, N, wo, wi)


def pdf(kind: np.ndarray, color: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Return each hit's BSDF sampling pdf of wi: (n,) float64."""
    return _by_kind(kind, "pdf", 0, color, N, wo, wi)


def sample(kind: np.ndarray, color: np.ndarray, N: np.ndarray, wo: np.ndarray, u: np.ndarray) -> BsdfSample:
    """Return one direction sampled from each hit's BSDF (u: (n, 2) float64)."""
    first = int(kind[0]) if len(kind) else Lambert.kind
    if len(kind) == 0 or (kind == first).all():
        return BSDF_TYPES[first].sample(color, N, wo, u)
    wi, weight, density = np.zeros((len(kind), 3)), np.zeros((len(kind), 3)), np.zeros(len(kind))
    for k in np.unique(kind):
        rows = np.flatnonzero(kind == k)
        s = BSDF_TYPES[int(k)].sample(color[rows], N[rows], wo[rows], u[rows])
        wi[rows], weight[rows], density[rows] = s.wi, s.weight, s.pdf
    return BsdfSample(wi, weight, density)


__all__ = ["BSDF", "BSDF_BY_NAME", "BSDF_TYPES", "BsdfSample", "DEFAULT_BASE_COLOR", "Lambert", "Material",
           "MaterialTable", "Mirror", "f", "pdf", "sample"]


def compiled_bsdf(kind: np.ndarray, color: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray,
                  u: np.ndarray) -> tuple:
    """f, pdf and sample of each hit's BSDF in C (core/materials/bsdf.c's table), for the tests:
    -> f (n, 3), pdf (n,), BsdfSample."""
    from ..native import library
    P, I64, ptr = library.P, library.I64, library.pointer
    n = len(kind)
    kind = library.contiguous(kind, np.int32)
    color, N, wo, wi, u = (library.contiguous(a, np.float64) for a in (color, N, wo, wi, u))
    f_out, pdf_out, sampled, weight, sampled_pdf = (np.empty((n, 3)), np.empty(n), np.empty((n, 3)),
                                                   np.empty((n, 3)), np.empty(n))
    library.function("primer_bsdf", None, [I64] + [P] * 11)(
        n, ptr(kind, np.int32), ptr(color, np.float64), ptr(N, np.float64), ptr(wo, np.float64),
        ptr(wi, np.float64), ptr(u, np.float64), ptr(f_out, np.float64), ptr(pdf_out, np.float64),
        ptr(sampled, np.float64), ptr(weight, np.float64), ptr(sampled_pdf, np.float64))
    return f_out, pdf_out, BsdfSample(sampled, weight, sampled_pdf)
