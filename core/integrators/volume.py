"""Light that a medium scatters towards a ray: single scattering, as Cycles renders it with Volume Bounces 0.

Along a ray that crosses a homogeneous medium (core/volumes) over a distance t, the light arriving at its start is

    L = T(t) L_surface  +  integral over 0 <= s < t of T(s) (sigma_s L_s(s) + emission) ds,   T(s) = exp(-sigma_t s)

where L_s(s) is the light scattered at the point s along the ray towards its start: the light arriving there from
every direction, weighed by the phase function p (core/volumes/phase.py). The first term is the surface behind
(the path goes on there, its throughput times T(t)); the emission's integral has a closed form (volumes.emitted,
added where the ray's light is gathered); and the scattering integral is estimated here by one point per ray:

1. **Free-flight sampling**: a distance s with a density proportional to exp(-sigma s) on [0, t), for one colour
   channel's sigma_t, picked with the probability of its share of throughput x albedo (sigma_s / sigma_t); the
   density of s is the mixture of the three channels' (spectral MIS, one-sample), so every channel is unbiased:
   weight = T(s) sigma_s / pdf(s).
2. **The light scattered at s** (`scattered_light`), as at a surface vertex (core/integrators/vertex.py) with the
   phase function in place of f cos: a light sample per light with its shadow ray through the media (their
   transmittance), weighed by MIS against the phase function's own sampling; and one direction sampled from the
   phase function, whose ray gathers the lamps, emitters, world and media emission it finds (and those behind the
   transparent surfaces it meets), weighed by MIS against the lights' samples.

With Cycles' default Volume Bounces 0 a path scatters at most once and ends there, its last (phase) ray still
finding light; so every stretch of a path (the camera ray, each bounce's ray the path goes on with) adds its one
scattering estimate here and the path goes on to the surface: the same mean as Cycles' paths, which choose between
the two, with less noise. Only stretches the path may still bounce on scatter (Cycles: a ray past its bounce
limits only absorbs and emits). Cycles also samples the distance towards each lamp (equi-angular sampling) and mixes
it with this one: the noise differs, not the mean.

Heterogeneous media (core/volumes/field.py) take the same estimate with their march as the proposal
(`marched_scattering`): ratio tracking's T and the true coefficients at the point over the march's pdf.
With Volume Bounces N > 0 a path goes on from where it scatters, N times (`multiple_scattering`): on a stretch of a path with volume bounces left, untruncated free flight decides whether it
collides (and goes on along its phase ray from there) or passes to the surface behind (`scatter_or_pass`).
"""
from __future__ import annotations

import numpy as np

from .. import volumes
from ..lights.base import LightFlags
from ..lights import linking
from ..materials import graph as graph_
from ..native import schema
from ..sampling import sobol as sampling
from ..volumes.phase import Phases
from ..visibility import HIDDEN_FROM_VOLUME_SCATTER
from . import lightgroups, shadows
from .base import Context, check_stop
from .rays import nearest_seen
from .vertex import (BsdfRay, fast_gi_scatter, gather_light, lamp_paths, light_count, light_numbers, mis_count,
                     power_heuristic, shadow_blockers, textured_samples, world_samples_seen)

# The sampling dimensions of a stretch's scattering point (distance, channel) and of its phase direction, and the
# shift of its light samples' dimensions from the vertex's own (core/sampling; a path's vertex k adds k x
# vertex.VERTEX_DIMENSIONS to each).
DISTANCE_DIMENSION = schema.constant("DISTANCE_DIMENSION", 8, "a stretch's free-flight distance and channel")
PHASE_DIMENSION = schema.constant("PHASE_DIMENSION", 9, "a scattering point's phase-sampled direction")
EQUIANGULAR_DIMENSION = schema.constant("EQUIANGULAR_DIMENSION", 1 << 14,
                                        "+ the light's index: the equi-angular distance towards each lamp")
LIGHT_SHIFT = schema.constant("LIGHT_SHIFT", 1 << 15, "a scattering point's light samples' shift of dimensions")


def channel_odds(stretch, throughput: np.ndarray) -> np.ndarray:
    """The probabilities (k, 3) float64 with which free-flight sampling picks each colour channel of stretches (k
    rows of volumes.Stretch) carrying `throughput` (k, 3): in proportion to |throughput| x albedo (sigma_s /
    sigma_t), as Cycles' volume_sample_channel; zero rows where nothing would scatter."""
    sigma = stretch.sigma_t
    positive = sigma > 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        albedo = np.where(positive, stretch.sigma_s / np.where(positive, sigma, 1.0), 0.0)
    share = np.abs(throughput) * albedo
    total = share.sum(axis=1)
    return np.where(total[:, None] > 0.0, share / np.where(total > 0.0, total, 1.0)[:, None], 0.0)


def distance_pdf(stretch, odds: np.ndarray, t: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The density (k,) float64 of free-flight sampling choosing the distances s (k,) on stretches of length t (k,):
    the mixture over channels (odds (k, 3)) of each channel's exponential sigma exp(-sigma s), truncated at t."""
    sigma = stretch.sigma_t
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        reach = -np.expm1(-sigma * np.asarray(t, np.float64)[:, None])   # (k, 3) each channel's chance before t
        each = np.where(odds > 0.0, odds * sigma * np.exp(-sigma * s[:, None]) / np.where(reach > 0.0, reach, 1.0),
                        0.0)
    return each.sum(axis=1)


def scatter_distance(stretch, throughput: np.ndarray, t: np.ndarray, u: np.ndarray) -> tuple:
    """Free-flight sampling on [0, t): (the distances s (k,) float64, their pdf (k,) float64, the channel odds (k,
    3)) for stretches (k rows of volumes.Stretch) carrying `throughput` (k, 3), from numbers u (k, 2): u[:, 1] picks
    a channel by channel_odds, u[:, 0] the distance from that channel's exponential truncated at t (t may be inf).
    The pdf is the channels' mixture, so T(s) sigma_s / pdf is unbiased in every channel. pdf 0: nothing sampled."""
    sigma = stretch.sigma_t
    odds = channel_odds(stretch, throughput)
    channel = np.minimum((u[:, 1:2] >= np.cumsum(odds, axis=1)).sum(axis=1), 2)
    rows = np.arange(len(t))
    sigma_c = np.where(sigma[rows, channel] > 0.0, sigma[rows, channel], 1.0)
    with np.errstate(over="ignore", invalid="ignore"):
        reach = -np.expm1(-sigma_c * np.asarray(t, np.float64))
    s = -np.log1p(-u[:, 0] * reach) / sigma_c
    pdf = np.where(odds.sum(axis=1) > 0.0, distance_pdf(stretch, odds, t, s), 0.0)
    return np.where(pdf > 0.0, s, 0.0), pdf, odds


def equiangular(O: np.ndarray, D: np.ndarray, t: np.ndarray, X: np.ndarray, u=None, s=None) -> tuple:
    """Equi-angular sampling (Kulla and Fajardo 2012) of a distance on rays O + s D (k, 3), 0 <= s < t (k,), towards
    a light at X (3,): the density of s is proportional to 1 / |O + s D - X|^2, the light's own falloff, so points
    near the lamp, where free flight rarely lands, are found. With numbers u (k,): (s (k,), its pdf (k,)); with
    distances s (k,): (s, the pdf of choosing them)."""
    delta = np.einsum("ij,ij->i", X[None, :] - O, D)       # how far along each ray the lamp is passed closest
    h = np.linalg.norm(X[None, :] - O - delta[:, None] * D, axis=1)
    h = np.maximum(h, 1e-9 * np.maximum(np.abs(delta), 1.0))
    a = np.arctan2(-delta, h)
    b = np.where(np.isfinite(t), np.arctan2(np.where(np.isfinite(t), t, 0.0) - delta, h), 0.5 * np.pi)
    if s is None:
        s = np.clip(delta + h * np.tan(a + u * (b - a)), 0.0, np.where(np.isfinite(t), t, np.inf))
    with np.errstate(divide="ignore", invalid="ignore"):
        pdf = np.where(b > a, h / ((b - a) * (h * h + (s - delta) ** 2)), 0.0)
    return s, pdf


def in_scattering(ctx: Context, O: np.ndarray, D: np.ndarray, t: np.ndarray, inside: np.ndarray,
                  throughput: np.ndarray, pixel: np.ndarray, sample: np.ndarray, dimension: int, bounce,
                  behind, recorder=None, groups=None, ao=None) -> tuple:
    """The light (k, 3) float64 that the media scatter towards the starts of rays O, D (k, 3) over distances t (k,)
    (inf: to the world), seen through each path's `throughput` (k, 3) (not included), and the shadow rays traced.

    inside: (k, V) the rays' media (core/volumes Media.crossed); pixel, sample: (k,) the keys of their random
    numbers; dimension: the vertex's shift of the sampling dimensions; bounce: (k,) or int the real bounces the paths
    made before the stretch (a light's Max Bounces); behind: path.through_transparent, for the phase rays;
    recorder: a Recorder told each scattering point (Recorder.scatter), or None; groups: a lightgroups.GroupLight of
    the k rays that receives L by the group of each light scattered (scattered_light), or None; ao: (k,) bool the rays
    whose scattering points' phase rays are Fast GI's short rays (fast_gi_scatter), or None: none."""
    media = ctx.extra["media"]
    stretch = media.along(inside, O, D)
    L = np.zeros((len(O), 3))
    rows = np.flatnonzero(stretch.scatters)
    bounces = np.broadcast_to(np.asarray(bounce), (len(O),))
    # (Rays in a heterogeneous medium: the same on the pieces of its march.)
    marched = rows[stretch.varying[rows]]
    rows = rows[~stretch.varying[rows]]
    shadow_rays = 0
    if len(marched):
        part_groups = part_tally(groups, len(marched))
        L[marched], shadow_rays = marched_scattering(ctx, stretch.rows(marched), O[marched], D[marched],
                                                     np.asarray(t, np.float64)[marched], inside[marched],
                                                     throughput[marched], pixel[marched], sample[marched], dimension,
                                                     bounces[marched], behind, recorder, part_groups,
                                                     None if ao is None else ao[marched])
        if groups is not None:
            groups.add_rows(marched, part_groups)
    if len(rows) == 0:
        return L, shadow_rays
    part = stretch.rows(rows)
    # 1. Where each ray scatters, and its weight T(s) sigma_s / pdf(s).
    u = sampling.sample_2d(ctx.settings.seed, pixel[rows], sample[rows], dimension=DISTANCE_DIMENSION + dimension)
    s, pdf, odds = scatter_distance(part, throughput[rows], t[rows], u)
    sampled = pdf > 0.0
    rows, s, pdf, odds, part = rows[sampled], s[sampled], pdf[sampled], odds[sampled], part.rows(sampled)
    if len(rows) == 0:
        return L, shadow_rays
    weight = volumes.transmittance(part.sigma_t, s) * part.sigma_s / pdf[:, None]
    # 2. The light scattered there towards the ray's start; each lamp's light samples weighed against the same
    #    lamp's equi-angular points (3.), by the balance heuristic on the two densities of s.
    o, d, length = O[rows], D[rows], np.asarray(t, np.float64)[rows]
    P = o + s[:, None] * d
    if recorder is not None:
        recorder.scatter("free flight", P)
    bounces = bounces[rows]
    lamps = equiangular_lamps(ctx)
    share = {index: pdf / (pdf + equiangular(o, d, length, X, s=s)[1]) for index, X in lamps.items()}
    point_groups = part_tally(groups, len(rows))
    scattered, count = scattered_light(ctx, P, -d, part.phases(), inside[rows], pixel[rows], sample[rows],
                                       dimension, bounces, behind, share, groups=point_groups,
                                       ao=None if ao is None else ao[rows])
    L[rows] = weight * scattered
    if groups is not None:
        groups.add_rows(rows, point_groups, weight)
    shadow_rays += count
    # 3. Each lamp with a position: a point chosen by equi-angular sampling, lit by that lamp alone.
    for index, X in lamps.items():
        u = sampling.sample_2d(ctx.settings.seed, pixel[rows], sample[rows],
                               dimension=EQUIANGULAR_DIMENSION + index + dimension)[:, 0]
        s_e, pdf_e = equiangular(o, d, length, X, u=u)
        chosen = pdf_e > 0.0
        if not chosen.any():
            continue
        at = rows[chosen]
        w = pdf_e[chosen] / (pdf_e[chosen] + distance_pdf(part.rows(chosen), odds[chosen], length[chosen],
                                                              s_e[chosen]))
        T = volumes.transmittance(part.sigma_t[chosen], s_e[chosen]) * part.sigma_s[chosen]
        if recorder is not None:
            recorder.scatter("equi-angular", o[chosen] + s_e[chosen, None] * d[chosen])
        point_groups = part_tally(groups, len(at))
        lit, count = scattered_light(ctx, o[chosen] + s_e[chosen, None] * d[chosen], -d[chosen],
                                     part.phases().rows(chosen),
                                     inside[at], pixel[at], sample[at], dimension, bounces[chosen], behind,
                                     only=index, groups=point_groups)
        L[at] += T * (w / pdf_e[chosen])[:, None] * lit
        if groups is not None:
            groups.add_rows(at, point_groups, T * (w / pdf_e[chosen])[:, None])
        shadow_rays += count
    return L, shadow_rays


def marched_scattering(ctx: Context, stretch, O: np.ndarray, D: np.ndarray, t: np.ndarray, inside: np.ndarray,
                       throughput: np.ndarray, pixel: np.ndarray, sample: np.ndarray, dimension: int,
                       bounce: np.ndarray, behind, recorder=None, groups=None, ao=None) -> tuple:
    """in_scattering for k rays in a heterogeneous medium (stretch: their volumes.Stretch): the same estimate on the
    pieces of their march (core/volumes/field.py): free flight inverting the optical depth of a channel picked by
    throughput x the rays' albedo (their optical depths' ratio), weight T(s) sigma_s(s) / pdf(s), and each lamp's
    equi-angular point weighed against it by the balance heuristic (recorder: told the free-flight points, or None;
    groups: a lightgroups.GroupLight of the k rays that receives L by group, or None; ao: (k,) bool Fast GI's phase
    rays, in_scattering's, or None). Returns (L (k, 3), shadow rays)."""
    k = len(O)
    L = np.zeros((k, 3))
    march = stretch.march(t, np.arange(k))
    tau_t, tau_s = march.totals()
    odds = channel_odds(volumes.Stretch(tau_t, tau_s, np.zeros((k, 3)), np.zeros(k)), throughput)
    # 1. The free-flight point, its weight T(s) sigma_s(s) / pdf(s).
    u = sampling.sample_2d(ctx.settings.seed, pixel, sample, dimension=DISTANCE_DIMENSION + dimension)
    s, pdf = march.free_flight(odds, u)
    _, sigma_s, g = march.true_at(s)
    ok = np.flatnonzero(pdf > 0.0)
    shadow_rays = 0
    lamps = equiangular_lamps(ctx)
    if len(ok):
        weight = march.transmittance(s)[ok] * sigma_s[ok] / pdf[ok, None]
        if recorder is not None:
            recorder.scatter("free flight", O[ok] + s[ok, None] * D[ok])
        share = {index: pdf[ok] / (pdf[ok] + equiangular(O[ok], D[ok], t[ok], X, s=s[ok])[1])
                 for index, X in lamps.items()}
        X = O[ok] + s[ok, None] * D[ok]
        point_groups = part_tally(groups, len(ok))
        scattered, shadow_rays = scattered_light(ctx, X, -D[ok], stretch.phases_at(ok, X, g[ok]), inside[ok],
                                                 pixel[ok], sample[ok], dimension, bounce[ok], behind, share,
                                                 groups=point_groups, ao=None if ao is None else ao[ok])
        L[ok] = weight * scattered
        if groups is not None:
            groups.add_rows(ok, point_groups, weight)
    # 2. Each lamp with a position: a point chosen by equi-angular sampling, lit by that lamp alone.
    shadow_rays += equiangular_light(ctx, march, lambda at: march.pdf(odds, at), O, D, t, inside, pixel, sample,
                                     dimension, bounce, behind, L, np.arange(k), stretch.phases_at, groups)
    return L, shadow_rays


def equiangular_light(ctx: Context, march, distance_pdf, O: np.ndarray, D: np.ndarray, t: np.ndarray,
                      inside: np.ndarray, pixel: np.ndarray, sample: np.ndarray, dimension: int, bounce: np.ndarray,
                      behind, L: np.ndarray, rows: np.ndarray, phases: Phases = None, groups=None) -> int:
    """Add to L[rows] (rows (r,)) the light r rays O, D (r, 3) over [0, t) (r,) through a marched medium (march:
    their core/volumes/field.py March) scatter back from each lamp with a position: a point by equi-angular sampling,
    lit by that lamp alone, weight T(s) sigma_s(s) / pdf, weighed against the distance sampling of density
    distance_pdf(s) (r,) by the balance heuristic; phases: the rays' phase functions (phase.Phases, r rows) where
    their media are homogeneous, or in a heterogeneous medium phases(chosen, X, g) -> phase.Phases of the points X
    (c, 3) of the rays chosen (c,) (of the r) with the march's g (c,) there (media.Stretch.phases_at), or None: HG
    of the march's g there; groups: a lightgroups.GroupLight of L's rows that receives what is added to L by group,
    or None. Returns the shadow rays cast."""
    shadow_rays = 0
    for index, X in equiangular_lamps(ctx).items():
        u = sampling.sample_2d(ctx.settings.seed, pixel, sample, dimension=EQUIANGULAR_DIMENSION + index + dimension)
        s_e, pdf_e = equiangular(O, D, t, X, u=u[:, 0])
        chosen = np.flatnonzero(pdf_e > 0.0)
        if len(chosen) == 0:
            continue
        at = np.where(pdf_e > 0.0, s_e, 0.0)
        w = pdf_e / (pdf_e + distance_pdf(at))
        _, sigma_e, g_e = march.true_at(at)
        T = march.transmittance(at) * sigma_e
        X = O[chosen] + s_e[chosen, None] * D[chosen]
        phase = (Phases.henyey_greenstein(g_e[chosen]) if phases is None else
                 phases.rows(chosen) if isinstance(phases, Phases) else phases(chosen, X, g_e[chosen]))
        point_groups = part_tally(groups, len(chosen))
        lit, count = scattered_light(ctx, X, -D[chosen], phase,
                                     inside[chosen], pixel[chosen], sample[chosen], dimension, bounce[chosen], behind,
                                     only=index, groups=point_groups)
        L[rows[chosen]] += T[chosen] * (w[chosen] / pdf_e[chosen])[:, None] * lit
        if groups is not None:
            groups.add_rows(rows[chosen], point_groups, T[chosen] * (w[chosen] / pdf_e[chosen])[:, None])
        shadow_rays += count
    return shadow_rays


def part_tally(groups, m: int):
    """A lightgroups.GroupLight of m rows with the groups of `groups` (a GroupLight), or None where it is None."""
    return None if groups is None else lightgroups.GroupLight(groups.groups, m)


def equiangular_lamps(ctx: Context) -> dict:
    """The lights that equi-angular sampling aims at, by their index: the lamps with a position (point, spot:
    their position; area: their centre), as Cycles aims at a light's position; not those hidden from Volume
    Scatter rays (Cycles drops their equi-angular sample)."""
    out = {}
    for index, light in enumerate(ctx.lights):
        if light.unseen_by & HIDDEN_FROM_VOLUME_SCATTER:
            continue                                     # (Ray Visibility: no light of it at scattering points)
        if light.is_(LightFlags.POSITION):
            out[index] = np.asarray(light.position, np.float64)
        elif light.is_(LightFlags.AREA):
            out[index] = np.asarray(light.center, np.float64)
    return out


def scatter_paths(m: int, bounce) -> "graph_.LightPaths":
    """The Light Path of m phase-sampled rays from scattering points after `bounce` (m,) or int real bounces: a volume
    scatter ray, one bounce deeper (Cycles' path_state_next for LABEL_VOLUME_SCATTER; the paths' diffuse, glossy,
    transmission and transparent counts are not carried into media: 0)."""
    return graph_.light_paths(m, flags=graph_.PATH["volume_scatter"], bounce=np.asarray(bounce) + 1)


def scattered_light(ctx: Context, P: np.ndarray, wo: np.ndarray, phase, inside: np.ndarray,
                    pixel: np.ndarray, sample: np.ndarray, dimension: int, bounce: np.ndarray, behind,
                    share: dict = None, only: int = None, phase_out: dict = None, groups=None, ao=None) -> tuple:
    """The light (m, 3) float64 that scattering points P (m, 3) with phase functions `phase` (phase.Phases, m rows;
    or Henyey-Greenstein anisotropies (m,)) send
    towards wo (m, 3) per unit sigma_s (the integral of p L over the sphere), and the shadow rays traced: light
    samples with shadow rays through the media `inside` (m, V), and one phase-sampled ray, weighed by MIS.
    share: light index -> (m,) the weight of its light samples here (their point's share against equi-angular
    points), or None; only: a light's index: its light samples alone (an equi-angular point), no phase ray.
    phase_out: a dict that receives the phase ray ("wi" (m, 3), "pdf" (m,), "hits") where the path goes on along it
    (Volume Bounces left: the light behind the transparent surfaces it meets is then the path's to find), or None.
    groups: a lightgroups.GroupLight of the m points that receives L by the group of its source (a light sample:
    its light's, the phase ray's finds: what they find, the media's emission: lightgroups.add_emitted), or None.
    ao: (m,) bool the points whose phase ray is Fast GI's short ray (fast_gi_scatter; not with phase_out), or None:
    it looks the render's AO Distance far, its media only absorb and emit, leaving every mesh's where it meets
    nothing, and the world it escapes to counts AO Factor times (path.py's short rays)."""
    s = ctx.settings
    m = len(P)
    phase = phase if isinstance(phase, Phases) else Phases.henyey_greenstein(phase)
    L = np.zeros((m, 3))
    shadow_rays = 0
    unknown = np.zeros((m, 3))                           # no normal: light from every side
    nowhere = np.full(m, -1, np.int64)                   # no object: a medium receives as the default set (linking)
    bsdf_rays = bool(ctx.extra.get("bsdf_rays", False))
    mis = s.light_sampling == "mis" and bsdf_rays
    # 1. Light samples, each with its shadow ray through the media.
    for index, light in enumerate(ctx.lights):
        check_stop(ctx)
        if only is not None and index != only:
            continue
        hittable = index in ctx.extra.get("hittable", ())
        if s.light_sampling == "bsdf" and not light.delta and light.use_mis and hittable:
            continue                                     # found by phase rays alone
        if light.unseen_by & HIDDEN_FROM_VOLUME_SCATTER:
            continue                                     # (Ray Visibility: Cycles' SHADER_EXCLUDE_SCATTER)
        count = light_count(ctx, light)
        cone = light.cone(P)
        for j in range(count):
            u = light_numbers(ctx, light, index, pixel, sample * count + j, m, dimension + LIGHT_SHIFT)
            # (a light's own shading: EMISSION, the medium's path's bounces; its other counts are not carried)
            shaded = graph_.light_paths(m, flags=graph_.PATH_EMISSION, bounce=np.broadcast_to(np.asarray(bounce), (m,)))
            ls = world_samples_seen(light, light.sample(P, u, cone, N=unknown, **lamp_paths(light, shaded)), shaded)
            if getattr(light, "textured", None) is not None:
                ls = textured_samples(ctx, light, P, ls, shaded)
            if not s.distance_attenuation:
                ls = light.without_attenuation(ls, P)
            lit = (ls.strength > 0.0) | (ls.strength < 0.0)
            if ls.hidden is not None:                    # (an emitter's object hidden from Volume Scatter)
                lit &= (np.asarray(ls.hidden) & HIDDEN_FROM_VOLUME_SCATTER) == 0
            if light.max_bounces < 1024:
                lit &= bounce <= light.max_bounces
            if ctx.geometry.linked or light.light_membership != linking.ALL_SETS:
                lit &= linking.lights_receivers(ctx.geometry, light, ls, nowhere)    # (a medium: the default set)
            rows = np.flatnonzero(lit)
            if len(rows) == 0:
                continue
            rays = shadows.robust_rays(P[rows], unknown[rows], np.zeros(len(rows)), ls.position[rows], ls.L[rows],
                                       ls.distance[rows], s.reduce_t_max,
                                       None if ls.normal is None else ls.normal[rows])
            blockers = shadow_blockers(ctx, light, ls, rows)
            if light.cast_shadow:
                shadow_paths = graph_.light_paths(len(rows), flags=graph_.PATH_SHADOW,
                                                  bounce=np.broadcast_to(np.asarray(bounce), (m,))[rows])
                through = shadows.transmittance(ctx, rays, s.transparent_max_bounces, inside[rows], shadow_paths,
                                                blockers)
                shadow_rays += len(rows)
            else:
                through = np.ones((len(rows), 3))
            p = phase.rows(rows).eval(wo[rows], ls.L[rows])
            w = ls.strength[rows] * (1.0 / count)
            if share is not None and index in share:
                w = w * share[index][rows]
            if not light.delta and light.use_mis and hittable and mis:
                weighed = True if blockers is None else blockers == np.uint64(linking.ALL_SETS)
                w = w * np.where(weighed, power_heuristic(mis_count(ctx, light) * ls.pdf[rows], p), 1.0)
            color = ls.color if ls.color.ndim == 1 else ls.color[rows]
            L[rows] += (w * p)[:, None] * color * through
            if groups is not None:
                group = groups.groups.of_sample(ctx.geometry, index, light, ls)
                groups.add(rows, (w * p)[:, None] * color * through, group if np.ndim(group) == 0 else group[rows])
    # 2. One phase-sampled direction: the light its ray finds (its weight p / pdf is 1).
    if only is None and (bsdf_rays or ctx.extra["media"].emits or phase_out is not None):
        u = sampling.sample_2d(s.seed, pixel, sample, dimension=PHASE_DIMENSION + dimension)
        ps = phase.sample(wo, u)
        kind = np.full(m, HIDDEN_FROM_VOLUME_SCATTER, np.int64)   # (it passes objects hidden from Volume Scatter)
        # (Fast GI's: AO Distance far, Cycles' intersect_closest past path_state_ao_bounce, a scattering event a bounce)
        short = np.zeros(m, bool) if ao is None else np.asarray(ao, bool)
        t_max = np.where(short, s.ao_distance, np.inf)
        hits = nearest_seen(ctx, P, ps.wi, t_max, kind)
        # (one that meets nothing leaves every mesh's medium: Cycles' volume_stack_clean)
        phase_inside = np.where((short & ~hits.hit)[:, None], 0, inside) if short.any() else inside
        stretch = ctx.extra["media"].along(phase_inside, P, ps.wi)
        gather = bsdf_rays and s.light_sampling != "light"
        if phase_out is not None:                        # (the path goes on along this ray: multiple scattering)
            phase_out.update(wi=ps.wi, pdf=ps.pdf, hits=hits)
        if gather:
            L += gather_light(ctx, P, ps.wi, hits, ps.pdf, np.full(m, mis), N=unknown, seen_as=kind, stretch=stretch,
                              paths=scatter_paths(m, bounce), receiver=nowhere, groups=groups,
                              t_max=t_max if ao is not None else None, ao=ao)
        if gather and phase_out is None:
            # Straight on through the transparent surfaces it meets, to the light behind them.
            T = stretch.transmittance(np.where(hits.hit, hits.t, np.inf))
            ray = BsdfRay(np.arange(m), P, ps.wi, hits, np.ones((m, 3)), np.full(m, -1), np.zeros(m, bool),
                          np.zeros(m, bool), ps.pdf, kind, P, unknown, inside=phase_inside, attenuation=T,
                          path=scatter_paths(m, bounce), receiver=nowhere)
            rows = np.flatnonzero(hits.hit)
            if len(rows):
                rows = rows[ctx.materials.may_pass[ctx.geometry.triangle_data(hits.prim[rows], smooth=False).material]]
            if len(rows):
                behind_groups = part_tally(groups, len(rows))
                L[rows] += behind(ctx, ray, rows, T[rows], np.zeros(len(rows), np.int64), np.inf, behind_groups,
                                  None if ao is None else short[rows])
                if groups is not None:
                    groups.add_rows(rows, behind_groups)
        elif not gather:
            emitted = volumes.emitted(stretch, np.where(hits.hit, hits.t, np.inf))
            L += emitted
            lightgroups.add_emitted(groups, np.arange(m), emitted, stretch)
    return L, shadow_rays



# The shift of the sampling dimensions of each further scattering event along one stretch's chain (Volume Bounces):
# the k-th event after the stretch's own draws its numbers k x CHAIN_SHIFT past them.
CHAIN_SHIFT = schema.constant("CHAIN_SHIFT", 1 << 17,
                              "a chain's k-th scattering event: k x this past its stretch's dimensions")


def volume_bounces_left(ctx: Context, volume: np.ndarray, bounce: np.ndarray, transmission=0,
                        glossy=0) -> np.ndarray:
    """Which paths (k,) bool, having scattered `volume` (k,) times in media and bounced `bounce` (k,) times
    (`transmission`, `glossy`: scalars or (k,), of those), go on from their next scattering event (Cycles'
    path_state_next: a volume scatter counts a bounce and a volume bounce; past Volume Bounces or Max Bounces the path
    ends after it, its phase ray still finding light; and where that phase ray is Fast GI's, fast_gi_scatter, the path
    ends at what it meets, only absorbing on the way: its single scattering with a short phase ray, in_scattering)."""
    s = ctx.settings
    shape = np.broadcast_shapes(np.shape(volume), np.shape(bounce), np.shape(transmission), np.shape(glossy))
    short = fast_gi_scatter(s, int(np.prod(shape)), np.ravel(np.broadcast_to(bounce, shape)),
                            np.ravel(np.broadcast_to(transmission, shape)), np.ravel(np.broadcast_to(glossy, shape)))
    left = (np.asarray(volume) < s.volume_bounces) & (np.asarray(bounce) + 1 <= s.max_bounces) & ~short.reshape(shape)
    return left if shape else bool(left)


def scatter_or_pass(ctx: Context, O: np.ndarray, D: np.ndarray, t: np.ndarray, inside: np.ndarray,
                    throughput: np.ndarray, pixel: np.ndarray, sample: np.ndarray, dimension: int,
                    bounce: np.ndarray, groups=None) -> tuple:
    """A stretch of rays O, D (k, 3) over [0, t) (k,) whose paths go on from where they scatter: free flight decides
    whether each scatters in its media (a distance drawn without truncation, by a channel picked by throughput (k, 3)
    x albedo) or goes on to its end. Returns (L (k, 3) the light gathered at the scattering points per unit
    throughput (light samples and the phase ray's finds, weighed by MIS), shadow rays, through (k, 3) what a path
    that goes on to the end carries on: T(t) / P(no collision), 0 where it scattered, and the onward rays: None or
    a dict of rows (c,) (the rays that scattered), O (c, 3) their scattering points, D (c, 3) their phase
    directions, hits, pdf (c,) the phase pdf, weight (c, 3) T(s) sigma_s(s) / pdf(s)). groups: a
    lightgroups.GroupLight of the k rays that receives L by group, or None."""
    from ..volumes.field import March
    media = ctx.extra["media"]
    k = len(O)
    t = np.asarray(t, np.float64)
    stretch = media.along(inside, O, D)
    through = stretch.transmittance(t)
    L = np.zeros((k, 3))
    shadow_rays = 0
    onward = []
    rows = np.flatnonzero(stretch.scatters)
    varying = stretch.varying[rows]
    for group, is_varying in ((rows[~varying], False), (rows[varying], True)):
        if len(group) == 0:
            continue
        part = stretch.rows(group)
        if is_varying:
            march = stretch.march(t[group], group)
            tau_t, tau_s = march.totals()
            odds = channel_odds(volumes.Stretch(tau_t, tau_s, part.emission, part.g), throughput[group])
        else:
            march = March.uniform(part.sigma_t, part.sigma_s, part.emission, part.g, t[group])
            odds = channel_odds(part, throughput[group])
        u = sampling.sample_2d(ctx.settings.seed, pixel[group], sample[group],
                               dimension=DISTANCE_DIMENSION + dimension)
        s, pdf, passed, p_pass = march.collision(odds, u)
        none = odds.sum(axis=1) <= 0.0
        passed, p_pass = passed | none | ~(pdf > 0.0), np.where(none, 1.0, p_pass)
        with np.errstate(invalid="ignore", divide="ignore"):
            through[group] = np.where(passed[:, None], through[group] / np.where(p_pass > 0.0, p_pass, 1.0)[:, None],
                                      0.0)
        # Each lamp with a position: a point by equi-angular sampling, lit by that lamp alone, weighed against the
        # collisions by the balance heuristic (as in_scattering weighs it against its free flight).
        shadow_rays += equiangular_light(ctx, march, lambda at: march.collision_pdf(odds, at), O[group], D[group],
                                         t[group], inside[group], pixel[group], sample[group], dimension,
                                         np.asarray(bounce)[group], None, L, group,
                                         (lambda chosen, X, g: stretch.phases_at(group[chosen], X, g))
                                         if is_varying else part.phases(), groups)
        hit = np.flatnonzero(~passed)
        if len(hit) == 0:
            continue
        at = np.where(passed, 0.0, s)
        _, sigma_s, g = march.true_at(at)
        weight = (march.transmittance(at) * sigma_s)[hit] / pdf[hit, None]
        here = group[hit]
        P = O[here] + s[hit, None] * D[here]
        share = {index: pdf[hit] / (pdf[hit] + equiangular(O[here], D[here], t[here], X, s=s[hit])[1])
                 for index, X in equiangular_lamps(ctx).items()}
        phase = {}
        phases = stretch.phases_at(here, P, g[hit]) if is_varying else part.phases().rows(hit)
        point_groups = part_tally(groups, len(here))
        light, count = scattered_light(ctx, P, -D[here], phases, inside[here], pixel[here], sample[here], dimension,
                                       np.asarray(bounce)[here], None, share, phase_out=phase, groups=point_groups)
        L[here] += weight * light
        if groups is not None:
            groups.add_rows(here, point_groups, weight)
        shadow_rays += count
        onward.append(dict(rows=here, O=P, D=phase["wi"], hits=phase["hits"], pdf=phase["pdf"], weight=weight))
    return L, shadow_rays, through, joined(onward)


def joined(parts: list):
    """The dicts of arrays `parts` (each the same keys; "hits" a Hits) joined row-wise into one; None for none."""
    if not parts:
        return None
    if len(parts) == 1:
        return parts[0]
    out = {}
    for key in parts[0]:
        if key == "hits":
            out[key] = type(parts[0][key])(*(None if any(c is None for c in columns) else np.concatenate(columns)
                                             for columns in zip(*(p[key] for p in parts))))
        else:
            out[key] = np.concatenate([p[key] for p in parts])
    return out


def multiple_scattering(ctx: Context, O: np.ndarray, D: np.ndarray, t: np.ndarray, inside: np.ndarray,
                        throughput: np.ndarray, pixel: np.ndarray, sample: np.ndarray, dimension: int,
                        counts: dict, behind, events: dict = None, groups=None) -> tuple:
    """The stretches of rays O, D (k, 3) over [0, t) whose paths have Volume Bounces left (volume_bounces_left),
    carrying `throughput` (k, 3): each scatters or goes on (scatter_or_pass); a path that scattered goes on along
    its phase ray, whose own stretch scatters or goes on again while it has bounces left, and otherwise gathers its
    single scattering (in_scattering, `behind`: path.through_transparent) and goes on to its hit.

    counts: the paths' counters, each (k,) int64: "bounce", "volume" (scattering events so far), "transmission" and
    "glossy" (Fast GI's count, volume_bounces_left), and any others (diffuse...) carried unchanged. Returns (L (k, 3)
    the light found, throughput included; shadow rays; through (k, 3) what a path going on to its own ray's end
    carries on (0 where it scattered); arrivals: None or a dict of the scattered paths that reach a surface: origin
    (a,) the ray each came from, throughput (a, 3), O, D (a, 3) their last ray, hits, pdf (a,) its phase pdf, inside
    (a, V), and each counter of `counts`).
    events: a dict that receives L's two parts (the light passes, lightpasses.add_scattered): "first" (k, 3) the
    light gathered at the stretches' own scattering events, "later" (k, 3) at the events after them; or None.
    groups: a lightgroups.GroupLight of the k rays that receives L (throughput included) by group, or None."""
    k = len(O)
    L = np.zeros((k, 3))
    first_groups = part_tally(groups, k)
    light, shadow_rays, through, onward = scatter_or_pass(ctx, O, D, t, inside, throughput, pixel, sample, dimension,
                                                          counts["bounce"], first_groups)
    L += throughput * light
    if groups is not None:
        groups.add_rows(np.arange(k), first_groups, throughput)
    if events is not None:
        events["first"] = L.copy()
    arrivals = []
    step = 1
    while onward is not None and len(onward["weight"]):
        check_stop(ctx)
        origin = onward["rows"] if step == 1 else onward["origin"]
        carried = (throughput[origin] if step == 1 else onward["throughput"]) * onward["weight"]
        state = ({name: np.asarray(value)[origin] for name, value in counts.items()} if step == 1
                 else onward["counts"])
        state = {**state, "bounce": state["bounce"] + 1, "volume": state["volume"] + 1}
        P, wi, hits = onward["O"], onward["D"], onward["hits"]
        reach = np.where(hits.hit, hits.t, np.inf)
        dim = dimension + step * CHAIN_SHIFT
        stack = inside[origin]
        going = volume_bounces_left(ctx, state["volume"], state["bounce"], state["transmission"], state["glossy"])
        carry = np.zeros((len(origin), 3))
        # a. Paths that end at their next scattering event: their single scattering, and on to the hit with T.
        last = np.flatnonzero(~going)
        if len(last):
            last_groups = part_tally(groups, len(last))
            found, count = in_scattering(ctx, P[last], wi[last], reach[last], stack[last], carried[last],
                                         pixel[origin[last]], sample[origin[last]], dim, state["bounce"][last],
                                         behind, groups=last_groups,
                                         ao=fast_gi_scatter(ctx.settings, len(last), state["bounce"][last],
                                                            state["transmission"][last], state["glossy"][last]))
            np.add.at(L, origin[last], carried[last] * found)
            if groups is not None:
                groups.add_rows(origin[last], last_groups, carried[last])
            shadow_rays += count
            stretch = ctx.extra["media"].along(stack[last], P[last], wi[last])
            carry[last] = carried[last] * stretch.transmittance(reach[last])
        # b. The others scatter again or go on.
        more = np.flatnonzero(going)
        after = None
        if len(more):
            more_groups = part_tally(groups, len(more))
            light, count, passing, after = scatter_or_pass(ctx, P[more], wi[more], reach[more], stack[more],
                                                           carried[more], pixel[origin[more]], sample[origin[more]],
                                                           dim, state["bounce"][more], more_groups)
            np.add.at(L, origin[more], carried[more] * light)
            if groups is not None:
                groups.add_rows(origin[more], more_groups, carried[more])
            shadow_rays += count
            carry[more] = carried[more] * passing
        # c. Those that reach a surface arrive there, the next vertex of their paths.
        arrive = np.flatnonzero(hits.hit & (carry != 0.0).any(axis=1))
        if len(arrive):
            arrivals.append(dict(origin=origin[arrive], throughput=carry[arrive], O=P[arrive], D=wi[arrive],
                                 hits=type(hits)(*(None if x is None else np.asarray(x)[arrive] for x in hits)),
                                 pdf=onward["pdf"][arrive],
                                 inside=stack[arrive], **{name: value[arrive] for name, value in state.items()}))
        if after is None:
            break
        rows = more[after["rows"]]
        onward = dict(origin=origin[rows], throughput=carried[rows], weight=after["weight"], O=after["O"],
                      D=after["D"], hits=after["hits"], pdf=after["pdf"],
                      counts={name: value[rows] for name, value in state.items()})
        step += 1
    if events is not None:
        events["later"] = L - events["first"]
    return L, shadow_rays, through, joined(arrivals)
