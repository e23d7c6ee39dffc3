"""Closures: what a material is at one hit, a list of weighted BSDFs plus emission, as in Cycles.

A shader (a material's node tree, or a constant material) turns each hit into a ShaderResult: as many
closures as its nodes set up, with no limit (a BSDF from the table, its RGB weight, its sampling weight, its
own normal and its parameters), the emitted radiance, the transparency, and the shading normal. The integrand is
the sum over closures of weight x (f cos); one-sample MIS over the closures picks one to sample in
proportion to its sampling weight, and the combined pdf is the sampling-weighted mean of theirs
(Cycles' surface_shader.h does the same). core/materials/closures.c is the compiled twin.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from ..native import schema
from .base import BSDF, NODE_PARAMS, PARAMS, BsdfSample  # noqa: F401 (PARAMS, NODE_PARAMS: the closures' rows)
from .base import BSDFFlags as F
from .lambert import Lambert

# A hit has as many closures as its material's nodes set up (Node.slots bounds each node's; the compiled kernel
# makes room for the scene's largest, compiled.closure_room); PARAMS floats of parameters per closure and
# NODE_PARAMS per shader node (core/materials/base.py).
# A closure whose sampling weight falls below this is dropped (Cycles' CLOSURE_WEIGHT_CUTOFF).
WEIGHT_CUTOFF = 1e-5


def principled_emits(color_linked: bool, color_max: float, strength_linked: bool, strength: float) -> bool:
    """Whether a Principled BSDF may emit, as Cycles decides it (PrincipledBsdfNode::has_surface_emission): its
    Emission Color linked or of a largest component above WEIGHT_CUTOFF, and its Emission Strength linked or above
    it. A black colour of strength 1 (Blender's default) emits nothing, whatever the strength."""
    return ((color_linked or color_max > WEIGHT_CUTOFF)
            and (strength_linked or strength > WEIGHT_CUTOFF))
# What a hit's shading may leave out (Cycles' caustics switches, Light Paths > Caustics): the bits of a hit's
# `caustics` filter. A hit reached by a ray that a diffuse bounce sent sets up no reflective (glossy, mirror,
# metal, coat, specular) closures with FILTER_REFLECTIVE, and lets no light through glass with
# FILTER_REFRACTIVE; core/integrators/path.py decides which hits get which bits.
FILTER_REFLECTIVE, FILTER_REFRACTIVE = schema.constants("FILTER", {"REFLECTIVE": 1, "REFRACTIVE": 2},
                                                       "what a hit's caustics filter takes away").values()


class Closures(NamedTuple):
    """The closures of n hits, K slots each (structure of arrays); kind -1 marks an empty slot.

    kind (n, K) int32; weight (n, K, 3) float64; sample_weight (n, K) float64; N (n, K, 3) float64
    unit normals on the viewer's side; params (n, K, PARAMS) float64; Ns (n, K, 3) float64 the hit's
    smooth shading normal (Cycles' sd->N) beside each closure, or None: where a closure's own normal differs
    (a Normal Map, a Bump), its light is shadowed by `bump_shadowing`; terminator (n,) float64 the Shading Offset
    multiplier of each hit's object (`terminator_term`; 1: none), or None: no object bends its light;
    uncorrected (n,) bool the hits whose material has Bump Map Correction off (their diffuse closures' bump shadowing
    keeps only its side test, Cycles without SD_USE_BUMP_MAP_CORRECTION), or None: every hit's material has it on
    """

    kind: np.ndarray
    weight: np.ndarray
    sample_weight: np.ndarray
    N: np.ndarray
    params: np.ndarray
    Ns: Optional[np.ndarray] = None
    terminator: Optional[np.ndarray] = None
    uncorrected: Optional[np.ndarray] = None

    @classmethod
    def empty(cls, n: int, slots: int = 1) -> "Closures":
        """n hits without closures (a black surface), with room for `slots` closures each."""
        return cls(np.full((n, slots), -1, np.int32), np.zeros((n, slots, 3)), np.zeros((n, slots)),
                   np.zeros((n, slots, 3)), np.zeros((n, slots, PARAMS)), np.zeros((n, slots, 3)))

    def rows(self, rows) -> "Closures":
        """The closures of the hits `rows` (an index array or a mask over the n hits)."""
        return Closures(*(None if array is None else array[rows] for array in self))


class ShaderResult(NamedTuple):
    """What a material is at n hits.

    closures:     the Closures
    emission:     (n, 3) float64 emitted radiance L_e (W / (m^2 sr)), the same from both sides
    transparency: (n, 3) float64 the weight of light passing straight through (Transparent BSDF, alpha)
    N:            (n, 3) float64 the shading normal after normal maps and bump (Cycles' sd->N)
    holdout:      (n, 3) float64 the weight of Holdout shader nodes (the Mix and Add Shaders above them), which
                  camera paths make a hole in the film of (path.hold_out); None: no Holdout node, all 0
    aov:          (n, c) float64 what its AOV Output nodes write into the render's c shader AOV channels
                  (graph.aov_values; core/integrators/passes.py keeps it on camera chains); None: nothing
    """

    closures: Closures
    emission: np.ndarray
    transparency: np.ndarray
    N: np.ndarray
    holdout: Optional[np.ndarray] = None
    aov: Optional[np.ndarray] = None


def each_kind(closures: Closures, slot: int):
    """Yield (BSDF class, rows) of the hits whose slot `slot` holds each kind present."""
    kinds = closures.kind[:, slot]
    first = int(kinds[0]) if len(kinds) else -1
    if len(kinds) and (kinds == first).all():
        if first >= 0:
            yield BSDF.types[first], slice(None)
        return
    for kind in np.unique(kinds):
        if kind >= 0:
            yield BSDF.types[int(kind)], np.flatnonzero(kinds == kind)


def eval_closures(closures: Closures, wo: np.ndarray, wi: np.ndarray, signed_cosine: bool = False,
                  left_out=None, sampled=None):
    """Return (f cos (n, 3), pdf (n,)): sum of weight x f cos, and the sampling-weighted mean pdf.

    wo, wi: (n, 3) float64 unit. signed_cosine: diffuse closures keep N.wi < 0 (a lecture switch). left_out:
    (n, K) bool closures that add neither f cos nor pdf (their sampling weight still counts in the mean, as in
    Cycles: a light sample of an object hidden from their kind of ray), or None. sampled: (n,) int the slot of the
    closure that sampled wi (sample_closures), or None: that closure's own direction is shadowed as Cycles'
    bsdf_sample shadows it (`bump_shadowing` with is_eval false: not at all unless diffuse).
    """
    n, slots = closures.kind.shape
    f_cos, numerator = np.zeros((n, 3)), np.zeros(n)
    for k in range(slots):
        for bsdf, rows in each_kind(closures, k):
            args = (closures.params[rows, k], closures.N[rows, k], wo[rows], wi[rows])
            value, pdf = bsdf.eval(*args, signed_cosine=True) if signed_cosine and bsdf is Lambert else bsdf.eval(*args)
            if closures.Ns is not None:
                term = bump_shadowing(closures.Ns[rows, k], closures.N[rows, k], wi[rows], bsdf.is_(F.DIFFUSE_TYPE),
                                      corrected(closures, rows),
                                      is_eval=None if sampled is None else sampled[rows] != k)
                if term is not None:
                    value = value * term[:, None]
                    pdf = np.where(term == 0.0, 0.0, pdf)
            if closures.terminator is not None:
                value = value * terminator_bend(closures.terminator[rows], closures.N[rows, k], wi[rows])[:, None]
            if left_out is not None:
                kept = ~left_out[rows, k]
                value, pdf = value * kept[:, None], pdf * kept
            f_cos[rows] += closures.weight[rows, k] * value
            numerator[rows] += closures.sample_weight[rows, k] * pdf
    total = closures.sample_weight.sum(axis=1)
    pdf = np.divide(numerator, total, out=np.zeros(n), where=total > 0)
    return f_cos, pdf


def terminator_term(cos_in: np.ndarray, multiplier: np.ndarray) -> np.ndarray:
    """Cycles' Shading Offset (kernel/closure/bsdf.h, after Appleseed): light arriving at cosine cos_in (m,) to a
    closure's normal is weighted by max(cos(theta x multiplier), 0) / cos(theta), so that it fades out before the
    terminator; multiplier (m,) = 1 / (1 - offset / 2), offset the object's Shading Offset (0..1)."""
    cos_in = np.minimum(cos_in, 1.0)
    bent = np.cos(np.arccos(np.clip(cos_in, -1.0, 1.0)) * multiplier)
    return np.divide(bent, cos_in, out=np.zeros_like(cos_in), where=(bent > 0.0) & (cos_in > 0.0))


def terminator_bend(multiplier: np.ndarray, N: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """The factor (m,) by which each closure of normal N (m, 3) passes light from wi (m, 3): terminator_term where
    the object bends (multiplier (m,) > 1) and the light arrives in front of N, 1 elsewhere (as Cycles' bsdf_eval)."""
    cos_in = np.einsum("ij,ij->i", N, wi)
    bends = (multiplier > 1.0) & (cos_in >= 0.0)
    return np.where(bends, terminator_term(cos_in, multiplier), 1.0)


def corrected(closures: Closures, rows) -> Optional[np.ndarray]:
    """Whether the materials of the hits `rows` have Bump Map Correction on: (m,) bool, or None (all of them)."""
    return None if closures.uncorrected is None else ~closures.uncorrected[rows]


def bump_shadowing(Ns: np.ndarray, N: np.ndarray, wi: np.ndarray, diffuse: bool, corrected=None, is_eval=None):
    """Cycles' bump shadowing term (kernel/closure/bsdf.h) for closures whose normal N (m, 3) differs from the
    smooth normal Ns (m, 3), light from wi (m, 3): 0 where wi and N lie on different sides of the smooth
    surface; for diffuse closures whose material has Bump Map Correction on (`corrected` (m,) bool, None: all), the
    GGX masking G1 of a roughness that grows with the angle between N and Ns at cos_i = |Ns.wi| ("A
    Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem", Conty Estevez et al.). is_eval: (m,)
    bool whether wi is a light's direction (bsdf_eval) rather than one the closure sampled itself (bsdf_sample: a
    non-diffuse closure is not shadowed there), or None: all are. Returns the term (m,), or None where every N is
    Ns (nothing to do)."""
    differs = ~np.all(N == Ns, axis=1) & np.any(Ns != 0.0, axis=1)      # (zeros: no smooth normal given)
    if not diffuse and is_eval is not None:
        differs &= is_eval
    if not differs.any():
        return None
    cos_si = np.einsum("ij,ij->i", Ns, wi)
    cos_sn = np.einsum("ij,ij->i", Ns, N)
    cos_ni = np.einsum("ij,ij->i", N, wi)
    term = np.where(cos_si * cos_sn * cos_ni < 0.0, 0.0, 1.0)
    if diffuse:
        cos_i, cos_d = np.abs(cos_si), np.abs(cos_sn)
        tan2_d = 1.0 / np.maximum(cos_d, 1e-300) ** 2 - 1.0
        alpha2 = np.clip(0.125 * tan2_d, 0.0, 1.0)
        safe = np.maximum(cos_i, 1e-300)
        tan2_i = (1.0 - safe * safe) / (safe * safe)
        g1 = 2.0 / (1.0 + np.sqrt(1.0 + alpha2 * tan2_i))
        smooth = np.where((cos_d >= 1.0) | (cos_i >= 1.0), 1.0, np.where(cos_i < 1e-6, 0.0, g1))
        term = term * (smooth if corrected is None else np.where(corrected, smooth, 1.0))
    return np.where(differs, term, 1.0)


class ClosureSample(NamedTuple):
    """A direction sampled from the closures of each hit.

    wi (n, 3); weight (n, 3) the path throughput factor f cos / pdf (closure weights included);
    pdf (n,) the combined pdf (inf when a delta closure was sampled, 0 when nothing was);
    delta (n,) bool whether the sampled closure was a delta (a mirror: no MIS);
    kind (n,) int32 the BSDF kind of the sampled closure (-1 where none): a path counts its bounces by it;
    slot (n,) int64 the sampled closure's slot (a BSSRDF's walk reads its parameters there), or None
    """

    wi: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray
    delta: np.ndarray
    kind: np.ndarray = None
    slot: np.ndarray = None


def own_weight(closures: Closures, wo: np.ndarray, wi: np.ndarray, total: np.ndarray, own: list, smooth: np.ndarray,
               f_cos: np.ndarray, pdf: np.ndarray) -> tuple:
    """The mixture's (f cos (m, 3), pdf (m,)) at the sampled directions of the rows `smooth` (m,), with each sampled
    OWN_WEIGHT closure's eval there (own: (bsdf, rows, slots, sample) per kind) replaced by its sample's f cos and pdf
    (BSDFFlags.OWN_WEIGHT), bump shadowing as eval_closures applies it to the closure that sampled the direction."""
    if not own:
        return f_cos, pdf
    f_cos, pdf = f_cos.copy(), pdf.copy()
    place = np.full(len(wo), -1)
    place[smooth] = np.arange(len(smooth))
    for bsdf, at, c, s in own:
        mine = place[at] >= 0
        at, c, s_weight, s_pdf = at[mine], c[mine], s.weight[mine], s.pdf[mine]
        f_e, pdf_e = bsdf.eval(closures.params[at, c], closures.N[at, c], wo[at], wi[at])
        f_s = s_weight * s_pdf[:, None]
        if closures.Ns is not None:
            term = bump_shadowing(closures.Ns[at, c], closures.N[at, c], wi[at], bsdf.is_(F.DIFFUSE_TYPE),
                                  corrected(closures, at), is_eval=np.zeros(len(at), bool))
            if term is not None:
                f_e, f_s = f_e * term[:, None], f_s * term[:, None]
                pdf_e, s_pdf = np.where(term == 0.0, 0.0, pdf_e), np.where(term == 0.0, 0.0, s_pdf)
        if closures.terminator is not None:
            bend = terminator_bend(closures.terminator[at], closures.N[at, c], wi[at])[:, None]
            f_e, f_s = f_e * bend, f_s * bend
        rows = place[at]
        f_cos[rows] += closures.weight[at, c] * (f_s - f_e)
        pdf[rows] += closures.sample_weight[at, c] * (s_pdf - pdf_e) / total[at]
    return f_cos, pdf


def sampled_across_face(flags: int, Ng: np.ndarray, N: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Whether directions wi (n, 3) sampled from closures of BSDFFlags `flags` with normals N (n, 3) leave on the
    other side of the face (Ng (n, 3), facing the viewer) than of N: (n,) bool, the samples Cycles' closures refuse
    (bsdf_diffuse_sample's `dot(Ng, wo) > 0`, the microfacet sampler's `(cos_NgO < 0) != do_refract || (cos_NO < 0)
    != do_refract`, the sheen, velvet, translucent, toon and Ashikhmin-Shirley samplers' tests); never for Transparent,
    Ray Portal, BSSRDF and hair closures (BSDFFlags.ANY_FACE)."""
    if flags & (F.STRAIGHT | F.SUBSURFACE | F.ANY_FACE):
        return np.zeros(len(wi), bool)
    return (np.einsum("ij,ij->i", Ng, wi) > 0.0) != (np.einsum("ij,ij->i", N, wi) > 0.0)


def sample_closures(closures: Closures, wo: np.ndarray, u: np.ndarray, pick: np.ndarray,
                    Ng: Optional[np.ndarray] = None) -> ClosureSample:
    """Sample a direction: choose a closure in proportion to its sampling weight (pick (n,) in [0, 1)),
    sample it with u (n, 2); then, unless it is a delta, weight and pdf from all closures at that
    direction (one-sample MIS with the balance heuristic); an OWN_WEIGHT closure its own sampled share of them.
    Ng (n, 3) the hits' face normals (facing the viewer), or None: a direction sampled across the face from the
    chosen closure's own normal is no sample (pdf 0; sampled_across_face), as in Cycles."""
    n, slots = closures.kind.shape
    total = closures.sample_weight.sum(axis=1)
    running = np.cumsum(closures.sample_weight, axis=1)
    chosen = np.minimum((running <= (pick * total)[:, None]).sum(axis=1), slots - 1)
    rows = np.arange(n)
    kind = np.where(total > 0.0, closures.kind[rows, chosen], -1)      # (no closure to sample: none chosen, as in C)
    # Where `pick` fell inside the chosen closure's share: a third number for a BSDF that chooses between
    # lobes (rough glass: reflect or refract), uniform and independent of the choice of closure.
    share = closures.sample_weight[rows, chosen]
    before = np.pad(running, ((0, 0), (1, 0)))[rows, chosen]
    within = np.divide(pick * total - before, share, out=np.full(n, 0.5), where=share > 0)
    u = np.column_stack([u[:, 0], u[:, 1], np.clip(within, 0.0, np.nextafter(1.0, 0.0))])
    wi, weight, pdf = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    delta = np.zeros(n, bool)
    own = []                                        # OWN_WEIGHT closures sampled: (bsdf, rows, slots, sample)
    for k in np.unique(kind):
        if k < 0:
            continue
        bsdf = BSDF.types[int(k)]
        at = np.flatnonzero(kind == k)
        c = chosen[at]
        s = bsdf.sample(closures.params[at, c], closures.N[at, c], wo[at], u[at])
        if Ng is not None:
            across = sampled_across_face(bsdf.flags, Ng[at], closures.N[at, c], s.wi)
            if across.any():
                s = BsdfSample(s.wi, np.where(across[:, None], 0.0, s.weight), np.where(across, 0.0, s.pdf))
        wi[at] = s.wi
        if bsdf.is_(F.SINGULAR | F.SUBSURFACE):
            # The closure's weight, over the probability of choosing it (a BSSRDF's: the walk's start,
            # core/integrators/subsurface.py).
            probability = closures.sample_weight[at, c] / total[at]
            weight[at] = closures.weight[at, c] * s.weight / np.maximum(probability, 1e-300)[:, None]
            pdf[at] = s.pdf
            delta[at] = True
        else:
            pdf[at] = s.pdf                         # (replaced by the combined pdf below)
            if bsdf.is_(F.OWN_WEIGHT):
                own.append((bsdf, at, c, s))
    smooth = np.flatnonzero(~delta & (pdf > 0))
    if len(smooth):
        part = closures.rows(smooth)
        f_cos, combined = eval_closures(part, wo[smooth], wi[smooth], sampled=chosen[smooth])
        f_cos, combined = own_weight(closures, wo, wi, total, own, smooth, f_cos, combined)
        weight[smooth] = np.divide(f_cos, combined[:, None], out=np.zeros_like(f_cos), where=combined[:, None] > 0)
        pdf[smooth] = combined
    return ClosureSample(wi, weight, pdf, delta, np.where(pdf > 0.0, kind, -1).astype(np.int32), chosen)


def constant_result(n: int, N: np.ndarray, kinds: np.ndarray, weights: np.ndarray, sample_weights: np.ndarray,
                    params: np.ndarray, emission: np.ndarray, transparency: Optional[np.ndarray] = None) -> ShaderResult:
    """A ShaderResult of closures that are the same at every hit but for the normal (a constant material).

    kinds (K,), weights (K, 3), sample_weights (K,), params (K, PARAMS), emission (3,); N (n, 3).
    """
    K = max(1, len(kinds))
    closures = Closures.empty(n, K)
    if len(kinds):
        closures.kind[:] = kinds
        closures.weight[:] = weights
        closures.sample_weight[:] = sample_weights
        closures.N[:] = N[:, None, :]
        closures.Ns[:] = N[:, None, :]
        closures.params[:] = params
    transparency = np.zeros(3) if transparency is None else transparency
    return ShaderResult(closures, np.broadcast_to(emission, (n, 3)).copy(), np.broadcast_to(transparency, (n, 3)).copy(),
                        N)


def concatenate(results: list, order: np.ndarray, n: int) -> ShaderResult:
    """Put ShaderResults of groups of hits back in hit order: results[i] covers the hits order[i] (m_i,) int64."""
    slots = max(r.closures.kind.shape[1] for r in results)
    holds = any(r.holdout is not None for r in results)
    aov = max((r.aov.shape[1] for r in results if r.aov is not None), default=0)
    closures = Closures.empty(n, slots)
    if any(r.closures.uncorrected is not None for r in results):
        closures = closures._replace(uncorrected=np.zeros(n, bool))
    out = ShaderResult(closures, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                       np.zeros((n, 3)) if holds else None, np.zeros((n, aov)) if aov else None)
    for result, rows in zip(results, order):
        k = result.closures.kind.shape[1]
        for mine, theirs in zip(out.closures, result.closures):
            if mine is not None and theirs is not None:
                if mine.ndim == 1:                      # (per hit: terminator, uncorrected)
                    mine[rows] = theirs
                else:
                    mine[rows, :k] = theirs
        out.emission[rows], out.transparency[rows], out.N[rows] = result.emission, result.transparency, result.N
        if result.holdout is not None:
            out.holdout[rows] = result.holdout
        if result.aov is not None:
            out.aov[rows] = result.aov
    return out
