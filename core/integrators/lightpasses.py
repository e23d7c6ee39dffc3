"""Light passes: Cycles' Diffuse, Glossy, Transmission and Volume Direct and Indirect, from the integrator's own samples.

Cycles' meaning (kernel/film/light_passes.h), which Primer follows: a path's light is classified by what the
path did at its first real bounce (its first surface interaction other than passing straight through a
Transparent closure, or its first scattering in a medium), split by the kind of closure that scattered it there:

- diffuse       closures of the diffuse type (BSDFFlags.DIFFUSE_TYPE, Cycles' CLOSURE_IS_BSDF_DIFFUSE: Lambert,
                Oren-Nayar, Sheen; the same closures as the Diffuse Color pass, core/integrators/passes.py)
- glossy        the glossy type (microfacet lobes, mirrors, the velvet), and glass reflecting (light on the
                viewer's side)
- transmission  the transmission type, and glass refracting (light from the other side)
- volume        a scattering event in a medium (core/integrators/volume.py): Cycles' PATH_RAY_VOLUME_PASS, set where
                a path's first real interaction is a volume scatter (integrator/path_state.h, and shade_volume.h for
                its light samples: "no diffuse/glossy distinction needed for volumes")

"Direct" is the light that arrives at the first hit: its light samples (next-event estimation) and what its
BSDF-sampled ray finds (lamps, emitters, the world), each weighed by MIS as in Combined. "Indirect" is
everything a path gathers from its second hit on. What the camera sees itself (emission, the world, lamps,
and what it sees through Transparent closures) goes to the Emission and Environment passes instead.

In media the same rule holds, a scattering point being a hit: on a stretch of a path before any real bounce (the
camera ray, or a ray through Transparent closures from it), the light gathered at its scattering point (its light
samples, each lamp's equi-angular point, and what its phase-sampled ray finds) is Volume Direct; everything the
path gathers after that scattering event (further scattering events, the surfaces its phase ray reaches) is Volume
Indirect (`stretch_shares`). On a stretch after a surface bounce, what the media scatter is indirect light of that
bounce's kind (the path's shares). What a medium emits along the camera ray is seen by the camera: Emission, as in
Cycles (film_write_volume_emission writes a path without a pass flag to the Emission pass).

The split by closure kind, as Cycles' BsdfEval keeps it: a light sample's contribution is shared out in
proportion to each kind's part of the closures' f cos at the light's direction (`kind_shares`); a BSDF-sampled
ray's, and with it the whole rest of its path, in proportion to each kind's part of f cos at the sampled
direction (one-hot for a delta closure: a mirror is glossy, smooth glass glossy or transmission by the side the
ray leaves to). The shares of one contribution add up to 1 wherever it is not 0, so, per sample,

    Combined = sum of the eight light passes' contributions + Emission + Environment.

Cycles stores each surface light pass divided by the matching colour pass (scene/pass.cpp: DiffDir's divide_type is
PASS_DIFFUSE_COLOR; kernel/film/read.h divides with safe_divide_even_color), so that DiffDir x DiffCol +
DiffInd x DiffCol + ... + VolumeDir + VolumeInd + Emission + Environment = Combined: `divide_by_color` does the same
with the colour passes Primer writes (core/integrators/passes.py). The volume passes have no colour pass and are
not divided (scene/pass.cpp: PASS_VOLUME_DIRECT has no divide_type).
"""
from __future__ import annotations

import numpy as np

from ..native import schema

from .. import materials as materials_
from ..materials.closures import Closures, eval_closures

# The light passes, in the order of the integrator's (n, 8, 3) buffer: the four kinds direct, then indirect.
LIGHT_PASSES = ("diffuse_direct", "glossy_direct", "transmission_direct", "volume_direct",
                "diffuse_indirect", "glossy_indirect", "transmission_indirect", "volume_indirect")
# The kinds the passes split light by (three of closure, and scattering in media); the indirect passes follow the
# direct ones.
DIFFUSE, GLOSSY, TRANSMISSION, VOLUME = schema.constants("PASS", ("diffuse", "glossy", "transmission", "volume"),
                                                         "the light passes' kinds of closure").values()
KINDS = schema.constant("PASS_KINDS", 4, "")
# The colour pass each surface light pass is divided by (Cycles' divide_type); the volume passes have none.
COLOR_OF = {name: f"{name.split('_')[0]}_color" for name in LIGHT_PASSES if not name.startswith("volume")}
# The film's buffer of the light passes' per-pixel sums: 8 passes x RGB.
FILM_BUFFER = "light_passes"
FILM_CHANNELS = schema.constant("LIGHT_CHANNELS", 3 * len(LIGHT_PASSES), "the light passes' channels: 8 passes x RGB")


def wanted(passes) -> bool:
    """Whether any light pass is among the render passes `passes` (names)."""
    return any(name in LIGHT_PASSES for name in passes)


def first_hit_passes(passes) -> tuple:
    """Return the first-hit passes (core/integrators/passes.py) a render of `passes` computes: those asked for
    but the light passes, and the colour passes the light passes asked for are divided by."""
    names = [name for name in passes if name not in LIGHT_PASSES]
    names += [COLOR_OF[name] for name in LIGHT_PASSES
              if name in passes and name in COLOR_OF and COLOR_OF[name] not in names]
    return tuple(dict.fromkeys(names))


def closure_kinds(kind: np.ndarray, N: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Return the pass kind (DIFFUSE, GLOSSY, TRANSMISSION; -1 for none: empty slots, Transparent) of each closure
    (n, K) int for light from wi (n, 3) towards wo (n, 3), by its BSDF's closure type (Cycles' bsdf_eval_accum):
    the diffuse, glossy and transmission types their own; glass glossy where wi is on wo's side of the closure's
    normal N (n, K, 3), else transmission."""
    F = materials_.BSDFFlags
    flags = materials_.flags_of(kind)
    same_side = (np.einsum("nkj,nj->nk", N, wo) * np.einsum("nkj,nj->nk", N, wi)) > 0.0
    glass = (flags & F.GLASS_TYPE) != 0
    out = np.full(kind.shape, -1, np.int64)
    out[(flags & F.DIFFUSE_TYPE) != 0] = DIFFUSE
    out[((flags & F.GLOSSY_TYPE) != 0) | (glass & same_side)] = GLOSSY
    out[((flags & F.TRANSMISSION_TYPE) != 0) | (glass & ~same_side)] = TRANSMISSION
    return out


def kind_shares(closures: Closures, wo: np.ndarray, wi: np.ndarray, signed_cosine: bool = False,
                left_out=None, sampled=None) -> np.ndarray:
    """Return each pass kind's share (n, KINDS, 3) float64 of the closures' f cos (eval_closures, same arguments)
    for light from wi (n, 3) towards wo (n, 3): its closures' f cos over all closures', per channel; 0 where the
    closures' f cos is 0."""
    kinds = closure_kinds(closures.kind, closures.N, wo, wi)
    left = np.zeros(kinds.shape, bool) if left_out is None else np.asarray(left_out, bool)
    parts = np.stack([eval_closures(closures, wo, wi, signed_cosine, left | (kinds != k), sampled)[0]
                      for k in range(KINDS)], axis=1)
    total = parts.sum(axis=1, keepdims=True)
    return np.divide(parts, total, out=np.zeros_like(parts), where=total != 0.0)


def sample_shares(closures: Closures, wo: np.ndarray, wi: np.ndarray, kind: np.ndarray, delta: np.ndarray,
                  transmit: np.ndarray, slot=None) -> np.ndarray:
    """Return the pass kinds' shares (k, KINDS, 3) of BSDF-sampled rays: kind_shares at the sampled direction wi
    (k, 3), or for a delta closure (delta (k,) bool) its own pass kind alone (closure_kinds; smooth glass glossy or
    transmission by the side the ray leaves to, transmit (k,) bool); none for a Transparent closure's ray.

    closures: the k hits' Closures; wo (k, 3); kind (k,) int the sampled closures' BSDF kinds; slot (k,) int their
    slots (eval_closures' sampled: the sampling closure's own direction as sample_closures shadows it), or None."""
    F = materials_.BSDFFlags
    shares = kind_shares(closures, wo, wi, sampled=slot)
    flags = materials_.flags_of(kind)
    glass = (flags & F.GLASS_TYPE) != 0
    one = np.zeros_like(shares)
    one[(flags & F.DIFFUSE_TYPE) != 0, DIFFUSE] = 1.0
    one[((flags & F.GLOSSY_TYPE) != 0) | (glass & ~transmit), GLOSSY] = 1.0
    one[((flags & F.TRANSMISSION_TYPE) != 0) | (glass & transmit), TRANSMISSION] = 1.0
    shares = np.where(delta[:, None, None], one, shares)
    return np.where(((flags & F.STRAIGHT) != 0)[:, None, None], 0.0, shares)


def volume_shares(k: int) -> np.ndarray:
    """Return the shares (k, KINDS, 3) of k paths whose first real interaction is a scattering event: all volume."""
    out = np.zeros((k, KINDS, 3))
    out[:, VOLUME] = 1.0
    return out


def stretch_shares(bounces: np.ndarray, shares: np.ndarray) -> np.ndarray:
    """Return the shares (k, KINDS, 3) of the light media scatter along k stretches of paths and of what those paths
    gather after scattering there: volume where the path made no real bounce before the stretch (bounces (k,) int 0),
    else the path's own shares (k, KINDS, 3) (those of its first real bounce)."""
    return np.where((np.asarray(bounces) == 0)[:, None, None], volume_shares(len(shares)), shares)


def add_scattered(light: np.ndarray, owner: np.ndarray, value: np.ndarray, bounces: np.ndarray, shares: np.ndarray,
                  at_first_event: bool) -> None:
    """Add to the light passes `light` (n, 8, 3) the light value (k, 3) (throughput included) media scattered along
    k stretches of the camera rays `owner` (k,): Volume Direct where the path made no real bounce before the stretch
    (bounces (k,) int 0) and the light was gathered at its first scattering event (at_first_event), else indirect,
    split by the stretches' shares (k, KINDS, 3) (stretch_shares)."""
    direct = (np.asarray(bounces) == 0) & bool(at_first_event)
    np.add.at(light, (owner[direct], slice(None, KINDS)), split(value[direct], shares[direct]))
    np.add.at(light, (owner[~direct], slice(KINDS, None)), split(value[~direct], shares[~direct]))


def split(value: np.ndarray, shares: np.ndarray) -> np.ndarray:
    """Return contributions value (k, 3) shared out by `shares` (k, KINDS, 3): (k, KINDS, 3)."""
    return value[:, None, :] * shares


class FirstHitParts:
    """Where DirectLighting.shade puts the light a batch of m first hits gathers, split by pass kind.

    gathered: (m, KINDS, 3) float64 their light samples' and BSDF rays' contributions (not their emission);
    ray_shares: (k, KINDS, 3) float64 the shares of the BSDF rays they sent (rows: the BsdfRay's), or None.
    """

    def __init__(self, m: int):
        """Start with nothing gathered by m hits."""
        self.gathered = np.zeros((m, KINDS, 3))
        self.ray_shares = None


def safe_divide_even_color(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return a / b per channel (..., 3), as Cycles' safe_divide_even_color: 0 where b is 0, except that a channel
    whose divisor is 0 takes the mean of the other channels' quotients (one of them where two divisors are 0)."""
    q = np.divide(a, b, out=np.zeros(np.broadcast_shapes(a.shape, b.shape)), where=b != 0.0)
    zx, zy, zz = b[..., 0] == 0.0, b[..., 1] == 0.0, b[..., 2] == 0.0
    x0, y0, z0 = q[..., 0], q[..., 1], q[..., 2]
    x = np.where(zx, np.where(zy, z0, np.where(zz, y0, 0.5 * (y0 + z0))), x0)
    y = np.where(zx, np.where(zy, z0, y0), np.where(zy, np.where(zz, x0, 0.5 * (x0 + z0)), y0))
    z = np.where(zx, np.where(zy | ~zz, z0, y0), np.where(zy, np.where(zz, x0, z0), np.where(zz, 0.5 * (x0 + y0), z0)))
    return np.stack([x, y, z], axis=-1)


def divide_by_color(sums: np.ndarray, count: np.ndarray, colors: dict, wanted) -> dict:
    """Return the light passes `wanted` (names; others are ignored): name -> (H, W, 3) float32, each pixel's mean
    contribution divided by the matching colour pass where it has one (safe_divide_even_color; 0 where the pixel has no samples).

    sums: (H, W, 24) float64 the film's per-pixel sums (FILM_BUFFER); count: (H, W) samples per pixel;
    colors: colour pass name -> (H, W, 3) image (core/integrators/passes.py), at least those of `wanted`. The
    volume passes have no colour pass: their mean, undivided."""
    mean = np.divide(sums, count[..., None], out=np.zeros_like(sums), where=count[..., None] > 0)
    out = {}
    for index, name in enumerate(LIGHT_PASSES):
        if name not in wanted:
            continue
        value = mean[..., 3 * index:3 * index + 3]
        if name not in COLOR_OF:
            out[name] = value.astype(np.float32)
            continue
        color = np.asarray(colors[COLOR_OF[name]], np.float64)
        out[name] = safe_divide_even_color(value, color).astype(np.float32)
    return out
