"""Shader nodes: how a material's BSDF nodes become closures at a hit, as Cycles' closure nodes do.

A material's node tree is exported (addon/export.py) as a short list of shader nodes, each with a
weight (the product of the Mix Shader factors and Add Shaders above it) and its constant inputs. At
each hit every node *sets up* its closures: the Diffuse BSDF one Lambert closure, the Glossy BSDF one
microfacet closure, the Principled BSDF a stack of layers (sheen over coat over emission over metal over
specular over diffuse) where each layer takes the light it reflects away from the layers below, as
Cycles' svm_node_closure_bsdf does. The setup depends on the view direction (how much a glossy layer
reflects, and so leaves for the layers below, depends on mu = N.wo), so it runs per hit.

core/materials/registry.py's NODE_TYPES is the table: a node's `kind` is its position, and the C side
(core/materials/nodes.gen.c, generated) dispatches on the same tag to each node's setup in nodes.c. Each class
lists its `inputs` (the slots of its row of NODE_PARAMS floats) and `defaults`.
"""
from __future__ import annotations

from typing import ClassVar, Optional

import numpy as np

from . import ggx_tables as tables
from . import microfacet as mf
from . import thin_film
from ..native import schema
from .ashikhmin_shirley import ALPHA_MIN as AS_ALPHA_MIN
from .ashikhmin_shirley import AshikhminShirley
from .base import NODE_PARAMS, PARAMS
from .beckmann import Beckmann
from .beckmann_glass import BeckmannGlass
from .closures import FILTER_REFLECTIVE, FILTER_REFRACTIVE, WEIGHT_CUTOFF, Closures, ShaderResult
from .glass import REFLECT_TINT, TRANSMIT_TINT, Glass
from .glass import shares as glass_shares
from .lambert import Lambert
from .microfacet import Microfacet
from .mirror import Mirror
from .oren_nayar import OrenNayar
from .oren_nayar import params_of as oren_nayar_params
from .rough_glass import RoughGlass
from .sheen import Sheen
from .sheen import params_of as sheen_params
from .velvet import Velvet
from .velvet import params_of as velvet_params
from .transparent import Transparent


class ClosureBuilder:
    """Closures of n hits, appended one slot at a time by the nodes' setups (Cycles' bsdf_alloc).

    N, wo: (n, 3) float64 unit shading normals and directions towards the viewer; mu = N.wo (n,);
    backfacing: (n,) bool where the ray hit from behind (leaving an object: glass bends by 1 / IOR);
    caustics: (n,) int the hits' filter bits (closures.FILTER_*), or None: `reflective` and `refractive`,
    (n,) bool, say where reflective and refractive closures may be set up (Cycles' caustics switches).
    blur: (n,) float64 the roughness Filter Glossy raises microfacet lobes to (0: none), or None
    (core/integrators/path.py filter_glossy_roughness; Cycles' bsdf_blur).
    """

    def __init__(self, N: np.ndarray, wo: np.ndarray, slots: int, backfacing=None, caustics=None, blur=None):
        n = len(N)
        self.N, self.wo = N, wo
        self.blur = None if blur is None or not np.any(np.asarray(blur) > 0.0) else \
            np.broadcast_to(np.asarray(blur, np.float64), (n,))
        self.backfacing = np.zeros(n, bool) if backfacing is None else np.asarray(backfacing, bool)
        bits = np.zeros(n, np.int64) if caustics is None else np.broadcast_to(np.asarray(caustics, np.int64), (n,))
        self.reflective = (bits & FILTER_REFLECTIVE) == 0
        self.refractive = (bits & FILTER_REFRACTIVE) == 0
        self.mu = np.einsum("ij,ij->i", N, wo)
        self.glossy_N = N
        self.closures = Closures.empty(n, max(1, slots))
        self.count = 0
        self.emission = np.zeros((n, 3))
        self.transparency = np.zeros((n, 3))
        self.holdout = None        # (n, 3) the Holdout nodes' weight, once one sets up
        self.shading_N = N
        self.smooth_N = N          # the hit's own normal (Cycles' sd->N), whatever normal a node's closures get

    def use_normal(self, N: np.ndarray, glossy: Optional[np.ndarray] = None) -> None:
        """The normal (n, 3) the next node's closures get (its Normal input, or the hit's), and the one its
        glossy lobes get (`glossy`, default N: Cycles turns a node's own normal for them so that their
        mirror direction stays above the face), with mu = glossy.wo."""
        glossy = N if glossy is None else glossy
        if glossy is not self.glossy_N:
            self.mu = np.einsum("ij,ij->i", glossy, self.wo)
        self.N, self.glossy_N = N, glossy

    def kept(self, kind: int) -> np.ndarray:
        """Where the caustics switches keep a closure of BSDF kind `kind` (n,) bool: a reflective one (a mirror,
        a glossy lobe) where reflective closures may be set up, glass where reflection or refraction may be."""
        from . import base
        if base.has(kind, base.BSDFFlags.GLASS_TYPE):
            return self.reflective | self.refractive
        reflective = base.has(kind, base.BSDFFlags.GLOSSY | base.BSDFFlags.SINGULAR) \
            and base.has(kind, base.BSDFFlags.REFLECTION) and not base.has(kind, base.BSDFFlags.TRANSMISSION)
        return self.reflective if reflective else np.ones(len(self.N), bool)

    def add(self, kind, weight: np.ndarray, params=None, allocated=None, factor=None, keep=None, N=None) -> int:
        """Append a closure: kind (n,) or int, weight (n, 3). Its sampling weight is |mean of the weight it
        was allocated with| (`allocated` (n, 3), default `weight`) times `factor` (n,) (Cycles' Fresnel
        estimate and darkening); hits where that mean is below the cutoff, or where `keep` (n,) bool is
        False, get none. Returns its slot."""
        k = self.count
        self.count += 1
        n = len(weight)
        sample_weight = np.abs((weight if allocated is None else allocated).mean(axis=1))
        kept = sample_weight >= WEIGHT_CUTOFF
        if keep is not None:
            kept &= keep
        if factor is not None:
            sample_weight = sample_weight * factor
        c = self.closures
        c.kind[:, k] = np.where(kept, np.broadcast_to(np.asarray(kind, np.int32), (n,)), -1)
        c.weight[:, k] = np.where(kept[:, None], weight, 0.0)
        c.sample_weight[:, k] = np.where(kept, sample_weight, 0.0)
        c.N[:, k] = self.N if N is None else N
        c.Ns[:, k] = self.smooth_N
        if params is not None:
            c.params[:, k] = params
            if self.blur is not None:
                roughen(c.kind[:, k], c.params[:, k], self.blur)
        return k

    def blurred(self, p: np.ndarray) -> np.ndarray:
        """A lobe's parameters (n, PARAMS) as Filter Glossy leaves them (alpha and alpha_y at least the blur): what
        decides whether it is a mirror (the closure itself keeps its own roughness for what was set up from it)."""
        if self.blur is None:
            return p
        p = p.copy()
        p[:, mf.ALPHA] = np.maximum(p[:, mf.ALPHA], self.blur)
        p[:, mf.ALPHA_Y] = np.maximum(p[:, mf.ALPHA_Y], self.blur)
        return p

    def result(self) -> ShaderResult:
        """The ShaderResult of what the setups added; the light let through becomes a Transparent closure."""
        if self.transparency.any():
            self.add(Transparent.kind, self.transparency)
        k = max(1, self.count)
        closures = Closures(*(None if array is None else array[:, :k] for array in self.closures))
        return ShaderResult(closures, self.emission, self.transparency, self.shading_N, self.holdout)


def roughen(kind: np.ndarray, params: np.ndarray, blur: np.ndarray) -> None:
    """Cycles' bsdf_blur, in place: the closures (kind (n,) int, params (n, PARAMS)) that roughen (BSDFFlags.ROUGHENS)
    get their class's `blurred` params (alpha and alpha_y for microfacet lobes) of at least blur (n,) float64."""
    from . import base, registry
    for cls in registry.BSDF_TYPES:
        if not cls.flags & base.BSDFFlags.ROUGHENS:
            continue
        rows = (kind == cls.kind) & (blur > 0.0)
        if rows.any():
            for name in cls.blurred:
                if name in cls.params:
                    j = cls.params.index(name)
                    params[rows, j] = np.maximum(params[rows, j], blur[rows])


def layering_weight(albedo: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """What a layer leaves for the layers below it: weight x (1 - the largest channel of albedo / weight),
    clipped to 0..1 (Cycles' closure_layering_weight). albedo, weight: (n, 3)."""
    ratio = np.divide(albedo, weight, out=np.zeros_like(albedo), where=weight != 0.0)
    return weight * np.clip(1.0 - ratio.max(axis=1), 0.0, 1.0)[:, None]


def dielectric_Fss(eta):
    """Fresnel reflectance of a dielectric averaged over the hemisphere (2 cos dcos), Kulla and Conty's fit;
    eta a float or (n,)."""
    eta = np.asarray(eta, np.float64)
    return np.where(eta < 1.0, 0.997118 + eta * (0.1014 - eta * (0.965241 + eta * 0.130607)),
                    (eta - 1.0) / (4.08567 + 1.00071 * eta))


def f82_tint_B(f0: np.ndarray, tint: np.ndarray) -> np.ndarray:
    """The b of F82-tint that makes the curve at cos = 1/7 equal Schlick's times `tint` (Kutz et al.)."""
    f = 6.0 / 7.0
    f5 = f ** 5
    return (f0 + (1.0 - f0) * f5) * (7.0 / (f5 * f)) * (1.0 - tint)


def fresnel_conductor(cos_i: float, n: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The unpolarised reflectance (3,) of a conductor of complex index n + i k (each (3,)) at incidence cosine cos_i,
    from air (Cycles' fresnel_conductor); at normal incidence ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)."""
    cos2 = cos_i * cos_i
    sin2 = 1.0 - cos2
    n2, k2 = n * n, k * k
    t0 = n2 - k2 - sin2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * n2 * k2)
    t1 = a2b2 + cos2
    t2 = 2.0 * cos_i * np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    rs = (t1 - t2) / (t1 + t2)
    t3, t4 = cos2 * a2b2 + sin2 * sin2, t2 * sin2
    rp = rs * (t3 - t4) / (t3 + t4)
    return 0.5 * (rp + rs)


def conductor_as_f82(n: np.ndarray, k: np.ndarray) -> tuple:
    """The F82-tint curve (f0, tint), each (3,), through a conductor's reflectance at normal incidence and at
    cos = 1/7 (about 82 degrees), where that curve is fitted: tint = F(1/7) / Schlick(f0, 1/7), at most 1."""
    n, k = np.maximum(np.asarray(n, np.float64), 0.0), np.maximum(np.asarray(k, np.float64), 0.0)
    f0 = fresnel_conductor(1.0, n, k)
    schlick = f0 + (1.0 - f0) * (1.0 - 1.0 / 7.0) ** 5
    tint = np.clip(fresnel_conductor(1.0 / 7.0, n, k) / np.maximum(schlick, 1e-12), 0.0, 1.0)
    return f0, tint


def rotate_around_axis(v: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """v (n, 3) turned by angle (n,) radians about the unit axis (n, 3) (Rodrigues; Cycles' rotate_around_axis)."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    along = np.einsum("ij,ij->i", axis, v)[:, None] * axis
    return v * c + np.cross(axis, v) * s + along * (1.0 - c)


def anisotropic_lobe(p: np.ndarray, alpha_x: np.ndarray, alpha_y: np.ndarray, T: np.ndarray, on: np.ndarray) -> None:
    """Make the microfacet rows p (n, PARAMS) anisotropic where `on` (n,) bool: alpha_x, alpha_y (n,) clipped to 1
    as Cycles' bsdf_microfacet_ggx_setup does, tangent T (n, 3); changed in place."""
    p[:, mf.ALPHA] = np.where(on, np.minimum(alpha_x, 1.0), p[:, mf.ALPHA])
    p[:, mf.ALPHA_Y] = np.where(on, np.minimum(alpha_y, 1.0), 0.0)
    p[:, mf.TANGENT:mf.TANGENT + 3] = np.where(on[:, None], T, 0.0)


def table_roughness(p: np.ndarray) -> np.ndarray:
    """The roughness (n,) the albedo tables read for microfacet rows p (n, PARAMS): sqrt(alpha), or for anisotropic
    rows sqrt(sqrt(alpha_x alpha_y)), as Cycles' energy compensation and albedo estimates do."""
    rough = np.sqrt(p[:, mf.ALPHA])
    aniso = mf.is_anisotropic(p)
    if aniso.any():
        rough = np.where(aniso, np.sqrt(np.sqrt(p[:, mf.ALPHA] * p[:, mf.ALPHA_Y])), rough)
    return rough


def principled_anisotropy(b: "ClosureBuilder", roughness: np.ndarray, anisotropic: np.ndarray, rotation: np.ndarray,
                          T: np.ndarray):
    """The Principled BSDF's (alpha_x, alpha_y, tangent, on) for its metal and specular layers (Cycles'
    svm_node_closure_bsdf): aspect = sqrt(1 - 0.9 anisotropic), alpha_x = r^2 / aspect, alpha_y = r^2 aspect, the
    tangent T (n, 3) turned by rotation x 2 pi about the node's normal; on (n,) bool where anisotropic > 0 and T
    is not zero."""
    on = (anisotropic > 0.0) & np.any(T != 0.0, axis=1)
    if not on.any():
        return None, None, None, on
    aspect = np.sqrt(1.0 - np.clip(anisotropic, 0.0, 1.0) * 0.9)
    alpha = roughness * roughness
    turned = np.where((rotation != 0.0)[:, None], rotate_around_axis(T, b.N, rotation * 2.0 * np.pi), T)
    return alpha / aspect, alpha * aspect, turned, on


class GlossyLobe:
    """The microfacet closures' shared setup: parameters, Fresnel estimate and energy compensation."""

    @staticmethod
    def params(n: int, roughness, mode: int, ior=1.0, f0=(1.0, 1.0, 1.0), f90=(1.0, 1.0, 1.0)):
        """(n, PARAMS) rows of a microfacet closure (roughness, ior: float or (n,); f0, f90: (3,) or (n, 3));
        the energy scale starts at 1."""
        p = np.zeros((n, PARAMS))
        p[:, mf.ALPHA] = np.clip(roughness, 0.0, 1.0) ** 2
        p[:, mf.FRESNEL] = mode
        p[:, mf.IOR] = ior
        p[:, mf.F0:mf.F0 + 3] = f0
        p[:, mf.F90:mf.F90 + 3] = f90
        p[:, mf.ENERGY] = 1.0
        return p

    @staticmethod
    def add(b: ClosureBuilder, weight: np.ndarray, p: np.ndarray, albedo=None, Fss=None, keep=None,
            kind=None) -> np.ndarray:
        """Append the closure (only at the hits `keep` (n,) bool, default all); with Fss (3,) or (n, 3)
        restore the energy of multiple scattering (Multiscatter GGX, Cycles' microfacet_ggx_preserve_energy).
        Returns the closure's weight after darkening (n, 3). kind: the lobe's BSDF kind (n,) int (default
        Microfacet's: GGX; Beckmann's, Ashikhmin-Shirley's), each with its own rule for a mirror (`singular`).

        A lobe smoother than the threshold is a mirror reflecting F(mu) of the light. An anisotropic lobe reads
        the tables at sqrt(sqrt(alpha_x alpha_y)) (table_roughness)."""
        rough = table_roughness(p)
        allocated = weight
        factor = None if albedo is None else albedo.mean(axis=1)
        if Fss is not None:
            E = np.maximum(tables.lookup_2d(tables.E, rough, b.mu), 1e-6)
            E_avg = tables.lookup_1d(tables.EAVG, rough)
            missing = (1.0 - E) / E
            p[:, mf.ENERGY] = 1.0 + missing
            Fss = np.broadcast_to(np.asarray(Fss, np.float64), weight.shape)
            dark = ~np.all(Fss == 1.0, axis=1)
            if dark.any():
                Fms = Fss * E_avg[:, None] / (1.0 - Fss * (1.0 - E_avg[:, None]))
                darkening = (1.0 + Fms * missing[:, None]) / p[:, mf.ENERGY][:, None]
                darkening = np.where(dark[:, None], darkening, 1.0)
                weight = weight * darkening
                factor = darkening.mean(axis=1) if factor is None else factor * darkening.mean(axis=1)
        kind = np.full(len(p), Microfacet.kind) if kind is None else np.broadcast_to(kind, (len(p),))
        q = b.blurred(p)                                    # (Filter Glossy: a blurred mirror is a rough lobe)
        singular = np.where(kind == AshikhminShirley.kind, AshikhminShirley.singular(q), Microfacet.singular(q))
        kind = np.where(singular, Mirror.kind, kind)
        closure_weight = weight
        if singular.any():
            at_mu = mf.fresnel(p, np.clip(b.mu, 0.0, 1.0)) * p[:, mf.ENERGY][:, None]
            closure_weight = np.where(singular[:, None], weight * at_mu, weight)
        b.add(kind, closure_weight, p, allocated, factor, keep, b.glossy_N)
        return weight


def dielectric_albedo(rough: np.ndarray, mu: np.ndarray, eta: float, f0: np.ndarray, f90: np.ndarray) -> np.ndarray:
    """Estimated albedo (n, 3) of a lobe with the dielectric curve remapped from f0 to f90 (Cycles'
    bsdf_microfacet_estimate_albedo with the schlick_ior table)."""
    z = np.sqrt(np.abs((eta - 1.0) / (eta + 1.0)))
    s = tables.lookup_3d(tables.SCHLICK_IOR_S, rough, mu, np.broadcast_to(z, mu.shape))
    return f0 + (f90 - f0) * s[:, None]


def per_hit_rows(p: np.ndarray, n: int) -> np.ndarray:
    """A node's inputs as (n, NODE_PARAMS) rows: one row (NODE_PARAMS,) shared by all hits, or a row per hit."""
    return np.broadcast_to(np.asarray(p, np.float64).reshape(-1, NODE_PARAMS), (n, NODE_PARAMS))


class Node:
    """A shader node of the table: its inputs (names of the slots of its row) and their defaults.

    kind: its place in core/materials/registry.py's NODE_TYPES (set there); name: what a Material's nodes call it;
    its C setup is nodes.c's <name>_node (lower case). bsdf: a BSDF class for a node that adds just one closure of
    it, weighted by the node's weight (its colour), with the hit's normal: its setup is written for it, in Python
    and in C (closure_node), and the caustics switches take it away as they take its kind. blender: the Blender node
    (bl_idname) such a node reads, whose Color weighs the closure (a link into it, per hit) and whose linked Normal
    is the closure's normal (addon/materials.py reads it with no code of its own).
    """

    kind: ClassVar[int] = -1
    types: ClassVar[tuple] = ()     # every node class by kind (core/materials/registry.py fills it)
    name: ClassVar[str] = ""
    bsdf: ClassVar[Optional[type]] = None
    blender: ClassVar[Optional[str]] = None
    inputs: ClassVar[tuple] = ()
    defaults: ClassVar[tuple] = ()
    slots: ClassVar[int] = 1            # at most this many closures (closures_at_most)
    normal_inputs: ClassVar[tuple] = ()  # inputs a linked normal feeds (unit, valid for reflection; 0: unlinked)
    lets_light_through: ClassVar[bool] = False  # it may let light straight through at some hits (hair.through_own_fibre)
    # The slots [first, last) of its row its setup adds to the emission, or None (it emits nothing); and whether
    # that emission reads the node's normal and the view (graph.emission_live: what a light sample must run).
    emission_slots: ClassVar[Optional[tuple]] = None
    emission_reads_normal: ClassVar[bool] = False

    @classmethod
    def row(cls, values: dict) -> np.ndarray:
        """The node's inputs as a row (NODE_PARAMS,) float64, defaults where `values` has none."""
        p = np.zeros(NODE_PARAMS)
        i = 0
        for name, default in zip(cls.inputs, cls.defaults):
            value = np.asarray(values.get(name, default), np.float64).reshape(-1)
            p[i:i + len(value)] = value
            i += len(value)
        return p

    @classmethod
    def setup(cls, b: ClosureBuilder, weight: np.ndarray, p: np.ndarray) -> None:
        """Append the node's closures for n hits: weight (n, 3), its inputs p (n, NODE_PARAMS)."""
        if cls.bsdf is None:
            raise NotImplementedError(f"{cls.__name__} sets up no closures")
        b.add(cls.bsdf.kind, weight, keep=b.kept(cls.bsdf.kind))


# A Glossy, Glass or Refraction node's microfacet distribution (its `distribution` input; Multiscatter GGX is GGX
# with `multiscatter` 1): Cycles' closure types MICROFACET_GGX, MICROFACET_BECKMANN and ASHIKHMIN_SHIRLEY.
DISTRIBUTIONS = schema.constants("DISTRIBUTION", ("ggx", "beckmann", "ashikhmin_shirley"),
                                 "a Glossy, Glass or Refraction node's microfacet distribution (nodes.DISTRIBUTIONS)")
GGX, BECKMANN, ASHIKHMIN_SHIRLEY = (DISTRIBUTIONS[name] for name in ("ggx", "beckmann", "ashikhmin_shirley"))

# Below this roughness Cycles sets a Diffuse BSDF up as Lambert's, and Oren-Nayar's above it.
DIFFUSE_ROUGHNESS_CUTOFF = 1e-5


def add_diffuse(b: ClosureBuilder, weight: np.ndarray, roughness: np.ndarray, albedo: np.ndarray,
                cutoff: float = DIFFUSE_ROUGHNESS_CUTOFF) -> None:
    """Append a diffuse closure of `weight` (n, 3): Lambert where roughness (n,) is below `cutoff`, else
    Oren-Nayar with that roughness and colour `albedo` (n, 3) (its multiple scattering depends on it)."""
    rough = roughness >= cutoff
    if not rough.any():
        b.add(Lambert.kind, weight)
        return
    b.add(np.where(rough, OrenNayar.kind, Lambert.kind), weight, oren_nayar_params(roughness, albedo, b.mu))


def coat_normal(b: ClosureBuilder, linked: np.ndarray, follows: np.ndarray) -> tuple:
    """The Principled coat's normal and glossy normal ((n, 3) each, Cycles' coat_normal): the graph's Coat Normal
    `linked` (n, 3) (unit, valid-reflection corrected; zero where unlinked), else the node's own where `follows`
    (n,) bool (Coat Normal fed by what feeds Normal), else the hit's own normal (Cycles' sd->N)."""
    has = np.any(linked != 0.0, axis=1)
    if not has.any() and follows.all():
        return b.N, b.glossy_N
    if not has.any() and not follows.any():
        return b.smooth_N, b.smooth_N
    N = np.where(has[:, None], linked, np.where(follows[:, None], b.N, b.smooth_N))
    return N, np.where(has[:, None], linked, np.where(follows[:, None], b.glossy_N, b.smooth_N))


def sheen_normal(b: ClosureBuilder, coat: np.ndarray, coat_N: np.ndarray) -> np.ndarray:
    """The Principled sheen's normal (n, 3): the node's normal turned towards the coat's `coat_N` (n, 3) by the
    coat weight `coat` (n,) in 0..1, as Cycles mixes them."""
    N = b.N + coat[:, None] * (coat_N - b.N)
    length = np.linalg.norm(N, axis=1)
    return np.where(length[:, None] > 0.0, N / np.where(length > 0.0, length, 1.0)[:, None], coat_N)


def add_sheen(b: ClosureBuilder, weight: np.ndarray, roughness: np.ndarray, N: np.ndarray, keep=None) -> np.ndarray:
    """Append a microfiber sheen closure with normal N (n, 3): its weight is `weight` (n, 3) x its albedo R, its
    sampling weight too (Cycles' bsdf_sheen_setup). Returns R (n,), what the layers below lose."""
    p, R = sheen_params(roughness, np.einsum("ij,ij->i", N, b.wo))
    b.add(Sheen.kind, weight * R[:, None], p, allocated=weight, factor=R, keep=keep, N=N)
    return R


class DiffuseNode(Node):
    """Diffuse BSDF: a Lambert closure weighted by its colour (the node's weight carries the colour), or with
    Roughness above 0 an Oren-Nayar closure, whose multiple scattering needs the colour itself."""

    name, inputs, defaults = "DIFFUSE", ("roughness", "color"), (0.0, (0.8, 0.8, 0.8))

    @staticmethod
    def setup(b, weight, p):
        p = per_hit_rows(p, len(weight))
        add_diffuse(b, weight, p[:, 0], np.clip(p[:, 1:4], 0.0, 1.0))


class MirrorNode(Node):
    """The lecture's perfect mirror (no Blender node: Primer's own sample scenes)."""

    name, inputs, defaults = "MIRROR", (), ()
    bsdf = Mirror


class GlossyNode(Node):
    """Glossy BSDF (GGX, Multiscatter GGX, Beckmann or Ashikhmin-Shirley: `distribution`, nodes.DISTRIBUTIONS):
    one microfacet closure without Fresnel, weighted by its colour; anisotropic (Cycles' svm_node_closure_bsdf)
    where |Anisotropy| > 1e-4 and the Tangent is not zero: with r = roughness^2 and a = Anisotropy clipped to
    +-0.99, alpha_x = r (1 - a), alpha_y = r / (1 - a) for a >= 0, alpha_x = r / (1 + a), alpha_y = r (1 + a)
    below; the tangent turned by Rotation x 2 pi about the normal. Alphas are clipped to 1, and for
    Ashikhmin-Shirley raised to 1e-4 (both there: a mirror)."""

    name = "GLOSSY"
    inputs = ("roughness", "multiscatter", "color", "anisotropy", "rotation", "tangent", "distribution")
    defaults = (0.5, 1.0, (1.0, 1.0, 1.0), 0.0, 0.0, (0.0, 0.0, 0.0), GGX)

    @staticmethod
    def setup(b, weight, p):
        n = len(weight)
        p = per_hit_rows(p, n)
        lobe = GlossyLobe.params(n, p[:, 0], mf.FRESNEL_NONE)
        a, T = np.clip(p[:, 5], -0.99, 0.99), p[:, 7:10]
        on = (np.abs(a) > 1e-4) & np.any(T != 0.0, axis=1)
        if on.any():
            r = lobe[:, mf.ALPHA]
            turned = np.where((p[:, 6] != 0.0)[:, None], rotate_around_axis(T, b.glossy_N, p[:, 6] * 2.0 * np.pi), T)
            alpha_x = np.where(a < 0.0, r / (1.0 + a), r * (1.0 - a))
            alpha_y = np.where(a < 0.0, r * (1.0 + a), r / (1.0 - a))
            anisotropic_lobe(lobe, alpha_x, alpha_y, turned, on)
        distribution = p[:, 10]
        kind = np.select([distribution == BECKMANN, distribution == ASHIKHMIN_SHIRLEY],
                         [Beckmann.kind, AshikhminShirley.kind], Microfacet.kind)
        phong = distribution == ASHIKHMIN_SHIRLEY
        if phong.any():
            lobe[:, mf.ALPHA] = np.where(phong, np.maximum(lobe[:, mf.ALPHA], AS_ALPHA_MIN), lobe[:, mf.ALPHA])
            lobe[:, mf.ALPHA_Y] = np.where(phong & on, np.maximum(lobe[:, mf.ALPHA_Y], AS_ALPHA_MIN), lobe[:, mf.ALPHA_Y])
        multiscatter = p[0, 1] != 0.0 and distribution[0] == GGX
        GlossyLobe.add(b, weight, lobe, Fss=np.maximum(p[:, 2:5], 0.0) if multiscatter else None, keep=b.reflective,
                       kind=kind)


class EmissionNode(Node):
    """Emission: radiance colour x strength, no BSDF (the node's weight scales it)."""

    name, inputs, defaults = "EMISSION", ("emission",), ((0.0, 0.0, 0.0),)
    slots = 0
    emission_slots = (0, 3)

    @staticmethod
    def setup(b, weight, p):
        b.emission += weight * per_hit_rows(p, len(weight))[:, 0:3]


class TransparentNode(Node):
    """Transparent BSDF: light passes straight through, coloured by the node's weight."""

    name, inputs, defaults = "TRANSPARENT", (), ()
    slots = 0

    @staticmethod
    def setup(b, weight, p):
        b.transparency += weight


class HoldoutNode(Node):
    """Holdout: no BSDF and no light; its weight (the Mix and Add Shaders above it) is the share of the surface that
    camera paths see as a hole in the film (path.hold_out, Cycles' holdout closure). Its Weight input is hidden."""

    name, inputs, defaults = "HOLDOUT", (), ()
    slots = 0

    @staticmethod
    def setup(b, weight, p):
        b.holdout = weight.copy() if b.holdout is None else b.holdout + weight


# The Principled BSDF's inputs, in their slots.
PRINCIPLED_INPUTS = ("base_color", "metallic", "roughness", "ior", "alpha", "subsurface", "specular_ior_level",
                     "specular_tint", "coat", "coat_roughness", "coat_ior", "coat_tint", "emission",
                     "transmission", "multiscatter", "diffuse_roughness", "sheen", "sheen_roughness", "sheen_tint",
                     "coat_follows_normal", "anisotropic", "anisotropic_rotation", "tangent", "coat_normal",
                     "thin_film_thickness", "thin_film_ior", "subsurface_radius", "subsurface_scale",
                     "subsurface_ior", "subsurface_anisotropy", "subsurface_method", "metal_distribution")
PRINCIPLED_DEFAULTS = ((0.8, 0.8, 0.8), 0.0, 0.5, 1.5, 1.0, 0.0, 0.5, (1.0, 1.0, 1.0), 0.0, 0.03, 1.5,
                       (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), 0.0, 1.0, 0.0, 0.0, 0.5, (1.0, 1.0, 1.0), 0.0, 0.0, 0.0,
                       (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 1.33, (1.0, 0.2, 0.1), 0.05, 1.4, 0.0,
                       1.0,      # (subsurface.RANDOM_WALK)
                       GGX)      # the metal's (GGX; BECKMANN: a Metallic BSDF's Beckmann, no multiscatter)


class PrincipledNode(Node):
    """Principled BSDF, as Cycles lays it out (svm_node_closure_bsdf, CLOSURE_BSDF_PRINCIPLED_ID):

    1. alpha: 1 - alpha of the light passes through (a transparent closure), the rest meets the layers;
    1b. sheen (the outermost layer): microfiber sheen (core/materials/sheen.py) of weight sheen x sheen tint x
       its albedo R, its normal turned towards the coat's (the hit's) by the coat weight; below it, what it
       does not reflect (layering_weight);
    2. coat: a dielectric GGX layer (index coat_ior) with its own normal (Coat Normal: the graph's unit,
       valid-reflection normal in slots 35-37, zero where unlinked; else the node's own with
       coat_follows_normal, else the hit's); below it, light is tinted by coat_tint along the
       refracted path and reduced by what the coat reflects;
    3. emission, seen through the coat;
    4. metal (metallic): GGX with the F82-tint curve from the base colour, tinted near 82 degrees by
       the specular tint; the rest (1 - metallic) goes on;
    5. transmission: glass, smooth or rough (GGX), Fresnel's curve remapped from F0 x specular tint to 1,
       the transmitted light tinted by the square root of the base colour; it takes its share away from
       what follows;
    6. specular: a dielectric GGX layer whose F0 the Specular IOR Level scales and the Specular Tint
       colours; below it, what it does not reflect;
    7. subsurface and diffuse: Subsurface Weight of the clamped base colour goes to a BSSRDF closure
       (core/materials/subsurface.py: radius x scale, the colour as albedo, the specular index (Skin: Subsurface
       IOR), roughness^2, Subsurface Anisotropy), the rest to Lambert with the base colour, or Oren-Nayar's with
       Diffuse Roughness.
    A thin film (Thin Film Thickness > 0.1 nm, of Thin Film IOR) makes the metal's, the specular layer's and
    the glass's Fresnel iridescent (core/materials/thin_film.py; the specular layer is then set up even at
    index 1; the metal's and specular's albedo estimates are the film's reflectance at mu, as Cycles').
    The metal and specular layers are anisotropic where Anisotropic > 0 and the Tangent is not zero
    (principled_anisotropy); their albedo estimates and energy compensation read the tables at
    sqrt(sqrt(alpha_x alpha_y)), as Cycles' do. The coat, sheen and transmission stay isotropic, as in Cycles.
    """

    name = "PRINCIPLED"
    inputs, defaults = PRINCIPLED_INPUTS, PRINCIPLED_DEFAULTS
    normal_inputs = ("coat_normal",)
    slots = 8
    emission_slots, emission_reads_normal = (18, 21), True    # (seen through the coat: its tint, at its angle)

    @staticmethod
    def setup(b, weight, p):
        n = len(weight)
        p = per_hit_rows(p, n)
        ones = np.ones((n, 3))
        base = np.maximum(p[:, 0:3], 0.0)
        clamped = np.minimum(base, 1.0)
        metallic, roughness = np.clip(p[:, 3], 0.0, 1.0), np.clip(p[:, 4], 0.0, 1.0)
        ior, alpha, subsurface = np.maximum(p[:, 5], 1e-5), np.clip(p[:, 6], 0.0, 1.0), np.clip(p[:, 7], 0.0, 1.0)
        level, tint = np.maximum(p[:, 8], 0.0), np.maximum(p[:, 9:12], 0.0)
        coat, coat_roughness, coat_ior = np.maximum(p[:, 12], 0.0), np.clip(p[:, 13], 0.0, 1.0), np.maximum(p[:, 14], 1.0)
        coat_tint, emission = np.maximum(p[:, 15:18], 0.0), p[:, 18:21]
        transmission, multiscatter = np.clip(p[:, 21], 0.0, 1.0), p[0, 22] != 0.0
        W = np.broadcast_to(weight, (n, 3)).astype(np.float64)
        alpha_x, alpha_y, T, anisotropic = principled_anisotropy(b, roughness, np.clip(p[:, 30], 0.0, 1.0), p[:, 31],
                                                                 p[:, 32:35])
        aniso_on = anisotropic.any()
        coat_N, coat_glossy = coat_normal(b, p[:, 35:38], p[:, 29] != 0.0)
        thickness = p[:, 38]
        film = thickness > thin_film.THICKNESS_CUTOFF
        film_on = film.any()
        film_ior = np.maximum(p[:, 39], 1e-5)
        # 1. Alpha (nothing changes where alpha is 1).
        if (alpha < 1.0).any():
            b.transparency += W * (1.0 - alpha)[:, None]
            W = W * alpha[:, None]
        # 1b. Sheen, on top of everything else.
        sheen = np.maximum(p[:, 24], 0.0)
        on = sheen > WEIGHT_CUTOFF
        if on.any():
            sheen_weight = W * sheen[:, None] * np.maximum(p[:, 26:29], 0.0)
            R = add_sheen(b, sheen_weight, np.clip(p[:, 25], 0.0, 1.0),
                          sheen_normal(b, np.clip(coat, 0.0, 1.0), coat_N), on)
            W = np.where(on[:, None], layering_weight(sheen_weight * R[:, None], W), W)
        # 2. Coat, with its own normal (coat_N, coat_glossy above); a normal map at the node's Normal input alone
        #    turns the layers below it, not the coat.
        on = coat > WEIGHT_CUTOFF
        if on.any():
            node_normals = (b.N, b.glossy_N, b.mu)
            if coat_N is not b.N or coat_glossy is not b.glossy_N:
                b.use_normal(coat_N, glossy=coat_glossy)
            # (Where reflective caustics are filtered out the coat reflects nothing, but still tints.)
            lobe_on = on & b.reflective
            lobe = GlossyLobe.params(n, coat_roughness, mf.FRESNEL_DIELECTRIC, coat_ior)
            reflect = dielectric_albedo(coat_roughness, b.mu, coat_ior, mf.F0_from_ior(coat_ior)[:, None] * ones, ones)
            coat_weight = GlossyLobe.add(b, W * coat[:, None], lobe, reflect,
                                         Fss=dielectric_Fss(coat_ior)[:, None] * ones, keep=lobe_on)
            layered = np.where(lobe_on[:, None], layering_weight(coat_weight * reflect, W), W)
            tinted = on & ~np.all(coat_tint == 1.0, axis=1)
            if tinted.any():
                cos_t = np.sqrt(np.maximum(1.0 - (1.0 - b.mu ** 2) / coat_ior ** 2, 1e-12))
                tinted_weight = layered * (1.0 + coat[:, None] * (coat_tint ** (1.0 / cos_t)[:, None] - 1.0))
                layered = np.where(tinted[:, None], tinted_weight, layered)
            W = np.where(on[:, None], layered, W)
            b.N, b.glossy_N, b.mu = node_normals
        # 3. Emission.
        b.emission += W * emission
        # 4. Metal.
        on = metallic > WEIGHT_CUTOFF
        if on.any():
            f82 = np.minimum(tint, 1.0)
            B = np.where(np.all(f82 == 1.0, axis=1)[:, None], 0.0, f82_tint_B(clamped, f82))
            lobe = GlossyLobe.params(n, roughness, mf.FRESNEL_F82_TINT, 1.0, clamped, B)
            if aniso_on:
                anisotropic_lobe(lobe, alpha_x, alpha_y, T, anisotropic)
            s = tables.lookup_2d(tables.SCHLICK_S_HALF, table_roughness(lobe) if aniso_on else roughness, b.mu)
            reflect = clamped + (1.0 - clamped) * s[:, None]
            if film_on:     # the film on the metal (Cycles 5.0): its Fresnel at mu is the albedo estimate
                thin_film_slots(lobe, film, thickness, film_ior, mf.FRESNEL_THIN_FILM_F82)
                reflect = np.where(film[:, None], mf.fresnel(lobe, np.clip(b.mu, 0.0, 1.0)), reflect)
            Fss = clamped + (1.0 - clamped) / 21.0 - B / 126.0
            beckmann = p[:, 47] == BECKMANN
            GlossyLobe.add(b, W * metallic[:, None], lobe, reflect, Fss=Fss if multiscatter else None,
                           keep=on & b.reflective, kind=np.where(beckmann, Beckmann.kind, Microfacet.kind))
            W = np.where(on[:, None], W * (1.0 - metallic)[:, None], W)
        # 5. Transmission: glass, Fresnel's curve remapped from F0 x specular tint to 1, the transmitted
        #    light tinted by the square root of the base colour (it passes the surface twice); a caustics
        #    filter takes away its reflection or its refraction.
        on = transmission > WEIGHT_CUTOFF
        if on.any():
            f0 = np.clip(mf.F0_from_ior(ior)[:, None] * tint, 0.0, 1.0)
            reflect_tint = np.where(b.reflective[:, None], 1.0, 0.0) * ones
            transmit_tint = np.where(b.refractive[:, None], np.sqrt(clamped), 0.0)
            glass = glass_params(n, b.backfacing, ior, mf.FRESNEL_SCHLICK_IOR, f0, ones, reflect_tint, transmit_tint)
            if film_on:     # the film's index relative to the medium the light comes from (glass when leaving)
                thin_film_slots(glass, film, thickness, np.where(b.backfacing, film_ior / ior, film_ior))
            # Multiscatter GGX darkens by the transmission tint, which Cycles takes to make most of the colour.
            add_glass(b, W * transmission[:, None], glass, roughness, transmit_tint if multiscatter else None,
                      keep=on & (b.reflective | b.refractive))
            W = np.where(on[:, None], W * (1.0 - transmission)[:, None], W)
        # 6. Specular: the index whose F0 the Specular IOR Level scales.
        f0 = mf.F0_from_ior(ior)
        scaled = level != 0.5
        f0 = np.where(scaled, f0 * 2.0 * level, f0)
        remapped = mf.ior_from_F0(f0)
        eta = np.where(scaled, np.where(ior < 1.0, 1.0 / remapped, remapped), ior)
        on = ((eta != 1.0) | film) & b.reflective
        if on.any():
            f0_tinted = np.clip(f0[:, None] * tint, 0.0, 1.0)
            lobe = GlossyLobe.params(n, roughness, mf.FRESNEL_SCHLICK_IOR, eta, f0_tinted, (1.0, 1.0, 1.0))
            if aniso_on:
                anisotropic_lobe(lobe, alpha_x, alpha_y, T, anisotropic)
            reflect = dielectric_albedo(table_roughness(lobe) if aniso_on else roughness, b.mu, eta, f0_tinted, ones)
            if film_on:     # no table for a film: its albedo estimate is its Fresnel at mu (Cycles)
                thin_film_slots(lobe, film, thickness, film_ior)
                reflect = np.where(film[:, None], mf.fresnel(lobe, np.clip(b.mu, 0.0, 1.0)), reflect)
            F0_real = mf.F0_from_ior(eta)
            below = F0_real < 1.0
            s = np.where(below, np.clip((dielectric_Fss(eta) - F0_real) / np.where(below, 1.0 - F0_real, 1.0), 0.0, 1.0),
                         1.0)
            Fss = f0_tinted + (1.0 - f0_tinted) * s[:, None]
            specular_weight = GlossyLobe.add(b, W, lobe, reflect, Fss=Fss if multiscatter else None, keep=on)
            W = np.where(on[:, None], layering_weight(specular_weight * reflect, W), W)
        # 7. Subsurface (a BSSRDF of the clamped colour, Cycles' bssrdf_setup), then the diffuse, Oren-Nayar's with
        #    Diffuse Roughness.
        on = subsurface > WEIGHT_CUTOFF
        if on.any():
            from . import subsurface as subsurface_      # (it imports this module for Node)
            skin = p[:, 46] == subsurface_.RANDOM_WALK_SKIN
            subsurface_.add_subsurface(b, np.where(on[:, None], W * clamped * subsurface[:, None], 0.0),
                                       p[:, 40:43] * p[:, 43:44], clamped, p[:, 45], np.where(skin, p[:, 44], eta),
                                       roughness * roughness, p[:, 46], WEIGHT_CUTOFF)
        add_diffuse(b, W * base * (1.0 - subsurface)[:, None], np.clip(p[:, 23], 0.0, 1.0), base, WEIGHT_CUTOFF)


def thin_film_slots(p: np.ndarray, film: np.ndarray, thickness: np.ndarray, film_ior: np.ndarray,
                    mode: int = mf.FRESNEL_THIN_FILM) -> None:
    """Turn the closures' rows p (n, PARAMS) with the Principled's remapped dielectric Fresnel (or, mode
    THIN_FILM_F82, its metal's) into thin-film ones where `film` (n,) bool: thickness (n,) nm, film_ior (n,)
    relative to the medium light arrives from."""
    p[:, mf.FRESNEL] = np.where(film, mode, p[:, mf.FRESNEL])
    p[:, mf.THICKNESS] = np.where(film, thickness, 0.0)
    p[:, mf.FILM_IOR] = np.where(film, film_ior, 0.0)


def glass_params(n: int, backfacing: np.ndarray, ior: float, mode: int, f0, f90, reflect_tint, transmit_tint):
    """(n, PARAMS) rows of a Glass closure: the relative index is ior entering, 1 / ior leaving."""
    p = np.zeros((n, PARAMS))
    p[:, mf.FRESNEL] = mode
    p[:, mf.IOR] = np.where(backfacing, 1.0 / ior, ior)
    p[:, mf.F0:mf.F0 + 3] = f0
    p[:, mf.F90:mf.F90 + 3] = f90
    p[:, mf.ENERGY] = 1.0
    p[:, REFLECT_TINT:REFLECT_TINT + 3] = reflect_tint
    p[:, TRANSMIT_TINT:TRANSMIT_TINT + 3] = transmit_tint
    return p


def glass_share_mean(p: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """The mean of reflected plus transmitted shares at the view angle (the closure's sampling weight factor)."""
    R, T = glass_shares(p, np.clip(mu, 0.0, 1.0))
    return (R + T).mean(axis=1)


def add_glass(b: ClosureBuilder, weight: np.ndarray, glass: np.ndarray, roughness, Fss=None, keep=None,
              rough_kind=None) -> None:
    """Append a glass closure with the parameters `glass` (n, PARAMS): smooth glass where roughness (n,) is
    below the threshold (or the index is 1: light goes straight through), else rough glass (GGX's, or
    `rough_kind` (n,) int: Beckmann's); with Fss (n, 3)
    (Multiscatter GGX) its energy restored from the glass albedo tables and darkened by Fss, as Cycles'
    microfacet_ggx_preserve_energy does for glass."""
    rough = np.clip(roughness, 0.0, 1.0)
    glass[:, mf.ALPHA] = rough * rough
    eta = glass[:, mf.IOR]
    smooth = (glass[:, mf.ALPHA] ** 2 <= mf.ROUGHNESS_SQ_THRESHOLD) | (np.abs(eta - 1.0) < 1e-4)
    # (Filter Glossy: smooth glass blurred is rough glass; its energy stays that of the glass set up)
    alpha = glass[:, mf.ALPHA] if b.blur is None else np.maximum(glass[:, mf.ALPHA], b.blur)
    mirror_like = (alpha ** 2 <= mf.ROUGHNESS_SQ_THRESHOLD) | (np.abs(eta - 1.0) < 1e-4)
    factor = glass_share_mean(glass, b.mu)
    allocated = weight
    if Fss is not None:
        E, E_avg = tables.glass_E(rough, b.mu, eta)
        missing = np.where(smooth, 0.0, (1.0 - np.maximum(E, 1e-6)) / np.maximum(E, 1e-6))
        glass[:, mf.ENERGY] = 1.0 + missing
        Fss = np.broadcast_to(np.asarray(Fss, np.float64), weight.shape)
        dark = ~np.all(Fss == 1.0, axis=1) & ~smooth
        if dark.any():
            Fms = Fss * E_avg[:, None] / (1.0 - Fss * (1.0 - E_avg[:, None]))
            darkening = np.where(dark[:, None], (1.0 + Fms * missing[:, None]) / glass[:, mf.ENERGY][:, None], 1.0)
            weight = weight * darkening
            factor = factor * darkening.mean(axis=1)
    rough_kind = RoughGlass.kind if rough_kind is None else rough_kind
    b.add(np.where(mirror_like, Glass.kind, rough_kind), weight, glass, allocated, factor=factor, keep=keep)


class GlassNode(Node):
    """Glass BSDF (reflection and refraction, tinted by its colour) and Refraction BSDF (refraction only,
    no Fresnel loss), smooth or rough (GGX or Beckmann: `distribution`; Multiscatter GGX restores the energy of
    the Glass BSDF's GGX microfacets, its darkening by the colour, as Cycles assumes the transmission makes most
    of it)."""

    name = "GLASS"
    inputs = ("color", "ior", "refraction_only", "roughness", "multiscatter", "distribution")
    defaults = ((1.0, 1.0, 1.0), 1.5, 0.0, 0.0, 0.0, GGX)

    @staticmethod
    def setup(b, weight, p):
        n = len(weight)
        p = per_hit_rows(p, n)
        color, ior, refraction_only = np.maximum(p[:, 0:3], 0.0), np.maximum(p[:, 3], 1e-5), p[:, 4] != 0.0
        zero = np.zeros((n, 3))
        # A caustics filter takes away the reflection or the refraction (Cycles' tints of 0).
        reflect_tint = np.where(b.reflective[:, None], color, 0.0)
        transmit_tint = np.where(b.refractive[:, None], color, 0.0)
        glass = np.where(refraction_only[:, None],
                         glass_params(n, b.backfacing, ior, mf.FRESNEL_SCHLICK_IOR, zero, zero, zero, transmit_tint),
                         glass_params(n, b.backfacing, ior, mf.FRESNEL_DIELECTRIC, zero, zero, reflect_tint,
                                      transmit_tint))
        beckmann = p[:, 7] == BECKMANN
        multiscatter = (p[0, 6] != 0.0) and not refraction_only.all() and not beckmann.all()
        keep = np.where(refraction_only, b.refractive, b.reflective | b.refractive)
        add_glass(b, weight, glass, p[:, 5], transmit_tint if multiscatter else None, keep=keep,
                  rough_kind=np.where(beckmann, BeckmannGlass.kind, RoughGlass.kind))


class SheenNode(Node):
    """Sheen BSDF: Microfiber, one sheen closure of the node's weight (its colour) x the albedo R; or Ashikhmin
    (`velvet` 1), one velvet closure of the node's weight with sigma = Roughness (core/materials/velvet.py)."""

    name, inputs, defaults = "SHEEN", ("roughness", "velvet"), (0.5, 0.0)

    @staticmethod
    def setup(b, weight, p):
        p = per_hit_rows(p, len(weight))
        roughness = np.clip(p[:, 0], 0.0, 1.0)
        if p[0, 1] != 0.0:
            b.add(Velvet.kind, weight, velvet_params(roughness))
        else:
            add_sheen(b, weight, roughness, b.N)


def closures_at_most(nodes: list) -> int:
    """The most closures a hit of a material made of `nodes` ((node class, ...) each) sets up: the nodes' slots and
    the Transparent closure of the light let through. shade_nodes makes room for as many, and the compiled kernel
    for the largest of the scene (compiled.closure_room): neither has a limit of its own."""
    return sum(entry[0].slots for entry in nodes) + 1


def shade_nodes(nodes: list, N: np.ndarray, wo: np.ndarray, per_hit=None, glossy=None, backfacing=None,
                caustics=None, blur=None) -> ShaderResult:
    """The ShaderResult at n hits of a material made of `nodes`: (node class, weight (3,), inputs (NODE_PARAMS,)).

    per_hit: what a node graph computed at each hit (graph.apply_outputs), or None: (weights, rows,
    normals) lists by node of (n, 3), (n, NODE_PARAMS) and (n, 3) or None arrays. A node's own normal goes to its
    closures only: the result's N stays the hit's normal (Cycles' sd->N), which bump shadowing compares with.
    glossy: by node, the normal its glossy lobes get instead ((n, 3) or None). backfacing: (n,) bool where
    the ray hit from behind (glass bends light leaving an object by 1 / IOR). caustics: (n,) int filter bits
    (closures.FILTER_*) or None: the closures left out at hits that a diffuse bounce's ray reached. blur: (n,)
    the roughness Filter Glossy gives microfacet lobes (ClosureBuilder), or None.
    """
    n = len(N)
    b = ClosureBuilder(N, wo, closures_at_most(nodes), backfacing, caustics, blur)
    for k, entry in enumerate(nodes):
        cls, weight, p = entry[0], entry[1], entry[2]
        normal = None
        if per_hit is not None:
            weight, p, normal = per_hit[0][k], per_hit[1][k], per_hit[2][k]
        b.use_normal(N if normal is None else normal, None if glossy is None else glossy[k])
        cls.setup(b, np.broadcast_to(np.asarray(weight, np.float64), (n, 3)),
                  np.broadcast_to(np.asarray(p, np.float64), (n, NODE_PARAMS)))
    return b.result()
