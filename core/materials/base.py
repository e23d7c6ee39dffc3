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

What a BSDF *is* is declared once, on its class, as BSDFFlags (pbrt's BxDFFlags, Mitsuba's BSDF flags,
Cycles' closure labels and closure types): the integrators and the passes ask the flags, never which BSDF it is.

A BSDF is one class (core/materials/<name>.py), one C file beside it (core/materials/<name>.c, functions
<name>_eval and <name>_sample) and one entry in the table of core/materials/registry.py, whose position is its
`kind` tag; tools/make_boundary.py writes the C side of the table (the kinds, the flags, the dispatch).
"""
from __future__ import annotations

import enum
from typing import ClassVar, NamedTuple

import numpy as np

from ..native import schema

# A closure's parameters beyond its normal and weight: a row of PARAMS floats, whose slots each BSDF class names
# in `params`; a shader node's inputs: a row of NODE_PARAMS floats (core/materials/nodes.py).
PARAMS = schema.constant("CLOSURE_PARAMS", 32, "a closure's parameters (core/materials/base.py PARAMS)")
NODE_PARAMS = schema.constant("NODE_PARAMS", 48, "a shader node's inputs, a MaterialRecord's rows")


class BSDFFlags(enum.IntFlag):
    """What a BSDF is. The first six say how the directions it samples count (Cycles' closure labels):

    REFLECTION    it sends light back to the side it came from
    TRANSMISSION  it lets light through to the other side
    DIFFUSE       its directions are diffuse bounces: the Diffuse bounce limit, diffuse rays (Ray Visibility),
                  and the caustics switches for what those rays meet
    GLOSSY        its directions are glossy (or transmission) bounces
    SINGULAR      a delta distribution: eval is 0 for every pair of directions, only `sample` finds its
                  directions (pdf inf): a mirror, smooth glass
    STRAIGHT      light goes on straight through, unchanged in direction (Transparent): no bounce, no pass, the
                  ray keeps the kind it had

    The last four say which family of Cycles' closure types it belongs to (CLOSURE_IS_BSDF_DIFFUSE, _GLOSSY,
    _TRANSMISSION, CLOSURE_IS_GLASS): which light passes and colour passes its light goes to, whether bump shadowing
    darkens it, and which closures a light hidden from some kinds of ray leaves out (core/integrators/direct.py).
    A closure may be labelled diffuse but be of the glossy family (the Ashikhmin velvet), as in Cycles.

    OWN_WEIGHT    its `sample` weighs some directions otherwise than `eval` does at them (Ashikhmin-Shirley's half
                  vectors turned to face the view, as Cycles' sampler does): where it is the sampled closure, the
                  closure mixture keeps its own sampled f cos and pdf and adds the others' eval, as Cycles does
                  for every sampled closure (closures.sample_closures)
    SUBSURFACE    a BSSRDF, not a BSDF (Cycles' CLOSURE_IS_BSSRDF): eval is 0 (light samples skip it, its sampling
                  weight still counts in the mixture's pdf), and where it is the sampled closure the ray it gives
                  goes into the surface and walks inside the mesh (core/integrators/subsurface.py); the path goes
                  on from where the walk leaves, with no bounce counted for the walk itself
    PORTAL        a Ray Portal (with STRAIGHT: a transparent bounce that keeps the ray's kind): the ray it gives leaves
                  from the closure's Position along its Direction (core/materials/portal.py), what it finds is not
                  weighed by MIS, and shadow rays stop at a surface with one
    ROUGHENS      a lobe whose roughness params (the class's `blurred`: alpha and alpha_y for the microfacet lobes)
                  Cycles' Filter Glossy may raise at hits after rough bounces (Cycles' bsdf_blur: GGX, Beckmann,
                  Ashikhmin-Shirley, rough glass, Chiang's and Huang's hair; core/integrators/path.py
                  filter_glossy_roughness)
    ANY_FACE      the directions it samples are not held to the face's side (hair: Cycles gives its hair closures no
                  face normal to test). Every other closure but STRAIGHT and SUBSURFACE ones has a sampled direction
                  refused where it leaves on the other side of the face (the geometric normal Ng) than of its own
                  normal, as Cycles' samplers refuse it (`dot(Ng, wo)` in bsdf_diffuse_sample, the microfacet, sheen
                  and velvet samplers...; not in eval, where the shadow ray decides): closures.sampled_across_face
"""

    REFLECTION = 1 << 0
    TRANSMISSION = 1 << 1
    DIFFUSE = 1 << 2
    GLOSSY = 1 << 3
    SINGULAR = 1 << 4
    STRAIGHT = 1 << 5
    DIFFUSE_TYPE = 1 << 6
    GLOSSY_TYPE = 1 << 7
    TRANSMISSION_TYPE = 1 << 8
    GLASS_TYPE = 1 << 9
    OWN_WEIGHT = 1 << 10
    SUBSURFACE = 1 << 11
    PORTAL = 1 << 12
    ROUGHENS = 1 << 13
    ANY_FACE = 1 << 14


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

    kind:   its tag, the position of its class in core/materials/registry.py's BSDF_TYPES (set there)
    name:   the name a Material uses to choose it
    flags:  what it is (BSDFFlags)
    params: the names of its parameters, in their slots of a closure's parameter row
    Arguments: params (m, PARAMS) float64; N, wo, wi (m, 3) float64 unit; u (m, 2) or (m, 3) float64 in
    [0, 1): two numbers for the direction, and a third for a BSDF that chooses between lobes (rough glass).
    """

    kind: ClassVar[int] = -1
    name: ClassVar[str] = ""
    flags: ClassVar[BSDFFlags] = BSDFFlags(0)
    params: ClassVar[tuple] = ()
    # The params Filter Glossy raises to its roughness where the class ROUGHENS (those it has; Cycles' bsdf_blur).
    blurred: ClassVar[tuple] = ("alpha", "alpha_y")
    # A microfacet lobe's two params whose product is Cycles' specular roughness squared (alpha_x alpha_y,
    # bsdf_get_specular_roughness_squared; specular_roughness_squared); () for any other BSDF.
    specular_alpha: ClassVar[tuple] = ()
    # The table (core/materials/registry.py fills it): every BSDF class by kind, and their flags by kind.
    types: ClassVar[tuple] = ()
    flag_table: ClassVar[np.ndarray] = np.zeros(1, np.int64)

    @classmethod
    def is_(cls, flags: BSDFFlags) -> bool:
        """Whether the BSDF has any of `flags`."""
        return bool(cls.flags & flags)

    @classmethod
    def c_name(cls) -> str:
        """The name of its C file and functions: its module's (lambert for core/materials/lambert.py)."""
        return cls.__module__.rsplit(".", 1)[-1]

    @classmethod
    def c_file(cls) -> str:
        """The name of its C file (core/materials/<c_file>.c): its module's, which may hold more than one BSDF
        (toon.py's two components, each with its own c_name)."""
        return cls.__module__.rsplit(".", 1)[-1]

    @staticmethod
    def eval(params: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray):
        """Return (f cos: (m, 3) float64, pdf: (m,) float64) for each pair of directions."""
        raise NotImplementedError

    @staticmethod
    def albedo(params: np.ndarray, N: np.ndarray, wo: np.ndarray) -> tuple:
        """Return what the closure reflects and lets through of light seen from wo, (R (m, 3), T (m, 3)) per unit
        of its weight, as Cycles estimates it for the colour passes (bsdf_albedo): 1 and 0 unless the BSDF says."""
        m = len(wo)
        return np.ones((m, 3)), np.zeros((m, 3))

    @staticmethod
    def sample(params: np.ndarray, N: np.ndarray, wo: np.ndarray, u: np.ndarray) -> BsdfSample:
        """Return one sampled direction per hit."""
        raise NotImplementedError


def flags_of(kind) -> np.ndarray:
    """The BSDFFlags (int64, kind's shape) of closures of BSDF kind `kind` (int, any shape); 0 for -1 (an empty
    slot). A kind outside the table raises IndexError: an unknown kind is an error, never a Lambert."""
    kind = np.asarray(kind)
    if kind.size and int(kind.max()) >= len(BSDF.types):
        raise IndexError(f"BSDF kind {int(kind.max())} is not in the table of {len(BSDF.types)} BSDFs")
    return BSDF.flag_table[kind]


def has(kind, flags: BSDFFlags) -> np.ndarray:
    """Whether closures of kind `kind` (int, any shape) have any of `flags`: bool, kind's shape (False for -1)."""
    return (flags_of(kind) & int(flags)) != 0


def specular_roughness_squared(kind: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Cycles' bsdf_get_specular_roughness_squared of closures of kind (n,) int with params (n, PARAMS) float64: 0
    for a SINGULAR BSDF, alpha_x alpha_y for a microfacet lobe (its class's specular_alpha), 1 for any other:
    (n,) float64."""
    kind = np.asarray(kind)
    out = np.where(has(kind, BSDFFlags.SINGULAR), 0.0, 1.0)
    for cls in BSDF.types:
        if cls.specular_alpha:
            rows = kind == cls.kind
            a, b = (cls.params.index(name) for name in cls.specular_alpha)
            out[rows] = params[rows, a] * params[rows, b]
    return out
