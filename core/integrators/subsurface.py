"""The subsurface random walk: where light that entered a BSSRDF closure leaves the mesh, and what it keeps.

Cycles' Random Walk (kernel/integrator/subsurface_random_walk.h; Chiang, Kutz and Burley, "Practical and
Controllable Subsurface Scattering for Production Path Tracing", 2016) treats the inside of the mesh as a
homogeneous medium per colour channel:

1. coefficients: the single-scattering albedo alpha that makes a half-space's multiple-scattering albedo equal the
   surface colour (a fitted curve in the colour and the anisotropy g), and sigma_t = 1 / (radius (1 - g)); the
   path's weight loses the colour (the walk puts it back by scattering), and alpha below 0.2 is raised to 0.2 with
   the weight scaled down to match;
2. steps, at most MAX_STEPS: a colour channel chosen in proportion to weight x alpha, a free-flight distance in
   it, a direction from the Henyey-Greenstein phase function or, guided, from Dwivedi's zero-variance scheme
   (towards the entry plane, or away from it to a nearby opposite side found by the first step's ray), all
   weighed by the balance heuristic over channels and strategies; after 9 steps the walk turns isotropic with
   the similarity relation's reduced coefficients;
3. the exit: the first step whose ray meets the same object's surface (a local ray cast: other objects do not
   count) before its distance ends. A walk that runs out of steps, or of weight, ends the path.

The path then goes on from the exit as if a ray from outside had hit it there (vertex.bsdf_ray): a white Lambert
closure with the exit's shading normal (subsurface_shader), lit by light samples and bouncing diffusely.

Christensen-Burley (Cycles' disk projection, kernel/integrator/subsurface_disk.h; King, Kulla, Conty and Fajardo,
"BSSRDF Importance Sampling", 2013) walks nothing: `disk` probes the object along one chord through a disk about the
entry, as the Bevel node does (shader_rays.local_hits):

1. a plane through the entry: across its face normal Ng (probability 1/2) or across either tangent (1/4 each);
2. a distance r on it from Burley's profile of a colour channel picked uniformly (materials/subsurface.py
   burley_sample), at an angle phi, and the chord through that point across the plane, of half length
   h = sqrt((16 d)^2 - r^2) on either side;
3. the object's surfaces along the chord (up to DISK_MAX_HITS of them, Cycles' BSSRDF_MAX_HITS: where more, a
   window of that many consecutive ones from a random start, each then counting their number / DISK_MAX_HITS: every
   surface is in it with the same chance as in Cycles' random subset), each weighed by the three planes' multiple
   importance (power heuristic) and the profile at its true distance from the entry over the mean profile density at
   r (per channel: the colour shift of the scattering);
4. one of them chosen in proportion to its mean weight (resampling), the path keeping the sum.

The exit is then lit as a walk's (the white Lambert of subsurface_shader), seen from outside along its face normal.
After any diffuse bounce the closure is a Lambert one of its weight instead (burley_as_diffuse).

The path leaves at another point than it entered, so the media it is in may differ (its exit inside another object's
medium, or outside one it entered from): `media_across` updates its volume stack by the volume boundaries of other
objects on the segment from the entry to the exit (Cycles' integrator_volume_stack_update_for_subsurface; the walk's
own object is left out, as the walk itself enters and leaves it).

The compiled twin is core/integrators/subsurface.c (subsurface_walk and subsurface_disk, one path at a time, with the
same sampling dimensions: the two kernels agree to float32 rounding).
"""
from __future__ import annotations

import math

import numpy as np

from .. import vectors
from ..geometry.intersect import Hits
from ..materials import subsurface as bssrdf
from ..materials.base import BSDFFlags, has
from ..materials.closures import ShaderResult
from ..materials.lambert import Lambert
from ..native import schema
from ..sampling import sobol as sampling
from ..volumes.phase import HenyeyGreenstein, henyey_greenstein
from ..geometry.surface import surface_at_hits
from . import shadows
from .rays import CAMERA_MEDIA_HITS
from .shader_rays import LOCAL_STEPS, local_hits, orthonormals

MAX_STEPS = 256                     # Cycles' BSSRDF_MAX_BOUNCES
SIMILARITY_STEPS = 9                # steps with the real anisotropy, before the isotropic similarity relation
MIN_ALPHA = 0.2                     # the smallest single-scattering albedo walked (the weight makes up the rest)
OWN_HITS = 4                        # the first step's hits looked at, to pass its own triangle's
THROUGHPUT_EPSILON = 1e-6           # a walk whose weight falls below this stops (Cycles' VOLUME_THROUGHPUT_EPSILON)
DISK_MAX_HITS = 4                   # the surfaces a disk probe weighs (Cycles' BSSRDF_MAX_HITS)
# Each step's sampling dimensions (three 2-d points: channel and distance, guiding choices, direction).
SUBSURFACE_DIMENSION = schema.constant("SUBSURFACE_DIMENSION", 1 << 12,
                                       "a subsurface walk's first sampling dimension at a vertex (3 a step)")


def remap(albedo: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The single-scattering albedo alpha (n, 3) whose walk reflects `albedo` (n, 3) with anisotropy g (n,)
    (Cycles' fit in powers of g, subsurface_random_walk_remap), clamped to 0..0.999999."""
    g = g[:, None]
    powers = [g ** i for i in range(8)]
    fit = lambda c: sum(ci * pi for ci, pi in zip(c, powers))         # noqa: E731
    A = fit((1.8260523782, -1.28451056436, -1.79904629312, 9.19393289202, -22.8215585862, 32.0234874259,
             -23.6264803333, 7.21067002658))
    B = 4.98511194385 + 0.127355959438 * np.exp(fit((0.0, 31.1491581433, -201.847017512, 841.576016723,
                                                     -2018.09288505, 2731.71560286, -1935.41424244,
                                                     559.009054474)))
    C = fit((1.09686102424, -0.394704063468, 1.05258115941, -8.83963712726, 28.8643230661, -46.8802913581,
             38.5402837518, -12.7181042538))
    D = fit((0.496310210422, 0.360146581622, -2.15139309747, 17.8896899217, -55.2984010333, 82.065982243,
             -58.5106008578, 15.8478295021))
    E = 4.23190299701 + 0.00310603949088 * np.exp(fit((0.0, 76.7316253952, -594.356773233, 2448.8834203,
                                                       -5576.68528998, 7116.60171912, -4763.54467887,
                                                       1303.5318055)))
    F = fit((2.40602999408, -2.51814844609, 9.18494908356, -79.2191708682, 259.082868209, -403.613804597,
             302.85712436, -87.4370473567))
    blend = albedo ** 0.25
    alpha = (1.0 - blend) * A * np.arctan(B * albedo) ** C + blend * D * np.arctan(E * albedo) ** F
    return np.clip(alpha, 0.0, 0.999999)


def coefficients(albedo: np.ndarray, radius: np.ndarray, g: np.ndarray, weight: np.ndarray) -> tuple:
    """(sigma_t, alpha, weight) (n, 3) each of walks for the colour `albedo` and mean free path `radius` (n, 3),
    anisotropy g (n,): the weight (n, 3) without the colour, and alpha raised to MIN_ALPHA at its cost."""
    alpha = remap(albedo, g)
    sigma_t = 1.0 / np.maximum(radius, 1e-16) / (1.0 - g)[:, None]
    weight = np.divide(weight, albedo, out=np.zeros_like(weight), where=albedo != 0.0)
    low = alpha < MIN_ALPHA
    weight = np.where(low, weight * alpha / MIN_ALPHA, weight)
    return sigma_t, np.where(low, MIN_ALPHA, alpha), weight


def diffusion_length(alpha: np.ndarray) -> np.ndarray:
    """Dwivedi's diffusion length (n,) for single-scattering albedo alpha (n,) (d'Eon and Krivanek 2020, eq. 67)."""
    return 1.0 / np.sqrt(1.0 - alpha ** (2.44294 - 0.0215813 * alpha + 0.578637 / alpha))


def flight_pdf(sigma: np.ndarray, t: np.ndarray, exits: np.ndarray) -> np.ndarray:
    """The pdf (n, 3) of a free flight of length t (n,) in sigma (n, 3): exp(-sigma t), times sigma unless it
    `exits` (n,) bool (the probability of flying that far)."""
    T = np.exp(-sigma * t[:, None])
    return np.where(exits[:, None], T, sigma * T)


def mix(a: np.ndarray, b: np.ndarray, t) -> np.ndarray:
    """a (1 - t) + b t, t broadcast over the channels."""
    t = np.asarray(t)
    t = t[:, None] if t.ndim == 1 else t
    return a * (1.0 - t) + b * t


def first_other(found: list, count: np.ndarray, own: np.ndarray) -> tuple:
    """The nearest of local_hits' `found` slots (count (k,) of them met) on a triangle other than `own` (k,): a ray
    leaving a triangle may meet it again within float32's reach (Cycles leaves it out by its ray.self). Returns
    ([that slot], how many such (k,), 0 or 1)."""
    prim, u, v, t = (np.zeros_like(found[0][i]) for i in range(4))
    chosen = np.zeros(len(own), bool)
    for slot, (p, uu, vv, tt, ok) in enumerate(found):
        take = ~chosen & ok & (slot < count) & (p != own)
        prim, u, v, t = (np.where(take, new, old) for new, old in zip((p, uu, vv, tt), (prim, u, v, t)))
        chosen |= take
    return [(prim, u, v, t, chosen)], chosen.astype(np.int64)


def walk(ctx, surface, rows: np.ndarray, params: np.ndarray, N: np.ndarray, D: np.ndarray, weight: np.ndarray,
         pixel: np.ndarray, sample: np.ndarray, dimension: int, carried=None) -> tuple:
    """Walk from the hits `rows` (k,) of `surface` into the mesh along D (k, 3) with the BSSRDF closures' params
    (k, PARAMS) and normals N (k, 3); weight (k, 3) the closure's weight into the walk; carried (k, 3) what the
    path carried to the entry (None: 1), which with the walk's weight chooses the colour channels. Returns (exits (k,) bool, the
    exit's (prim, u, v) (k,) each, the walk's last point (k, 3) (the exit), direction (k, 3) and step length (k,),
    the weight (k, 3) after the walk)."""
    k = len(rows)
    geometry, seed = ctx.geometry, ctx.settings.seed
    P0 = surface.I[rows]
    owner = geometry.owners(surface.prim[rows])
    albedo, radius = params[:, bssrdf.ALBEDO:bssrdf.ALBEDO + 3], params[:, bssrdf.RADIUS:bssrdf.RADIUS + 3]
    g0 = params[:, bssrdf.ANISOTROPY]
    # 1. The medium's coefficients per channel, and Dwivedi's guiding terms from the largest alpha.
    sigma_t0, alpha, throughput = coefficients(albedo, radius, g0, weight)
    sigma_s0 = sigma_t0 * alpha
    length = diffusion_length(alpha.max(axis=1))
    alive = np.flatnonzero(np.isfinite(length) & (length != 1.0) & (length > 1.0))
    phase_log = np.log((length + 1.0) / np.maximum(length - 1.0, 1e-300))
    guided0 = 1.0 - np.maximum(0.5, np.abs(g0) ** 0.125)
    sigma_s_star = sigma_s0 * (1.0 - g0)[:, None]
    sigma_t_star = sigma_t0 - sigma_s0 + sigma_s_star
    P = P0.copy()
    Dw = D.copy()
    exits = np.zeros(k, bool)
    prim, u, v, last_t = np.zeros(k, np.int64), np.zeros(k), np.zeros(k), np.zeros(k)
    opposite = np.zeros(k, bool)
    opposite_distance = np.zeros(k)
    for step in range(MAX_STEPS):
        if len(alive) == 0:
            break
        a = alive
        n = len(a)
        # 2a. This step's coefficients (isotropic with the similarity relation after SIMILARITY_STEPS).
        late = step > SIMILARITY_STEPS
        sigma_t = sigma_t_star[a] if late else sigma_t0[a]
        sigma_s = sigma_s_star[a] if late else sigma_s0[a]
        g = np.zeros(n) if late else g0[a]
        guided_fraction = np.full(n, 0.75) if late else guided0[a]
        dim = dimension + SUBSURFACE_DIMENSION + 3 * step
        r0 = sampling.sample_2d(seed, pixel[a], sample[a], dimension=dim)
        r1 = sampling.sample_2d(seed, pixel[a], sample[a], dimension=dim + 1)
        r2 = sampling.sample_2d(seed, pixel[a], sample[a], dimension=dim + 2)
        # 2b. The channel, in proportion to weight x alpha (uniform where that is all 0).
        w = np.abs(throughput[a] * alpha[a] * (1.0 if carried is None else carried[a]))
        total = w.sum(axis=1)
        channel_pdf = np.where((total > 0.0)[:, None], w / np.where(total > 0.0, total, 1.0)[:, None], 1.0 / 3.0)
        channel = np.minimum((np.cumsum(channel_pdf, axis=1) <= r0[:, 0:1]).sum(axis=1), 2)
        sample_sigma = sigma_t[np.arange(n), channel]
        forward_factor = backward_factor = np.zeros(n)
        forward_stretch = backward_stretch = np.ones(n)
        backward_fraction = np.zeros(n)
        if step > 0:
            # 2c. The direction: guided (Dwivedi, forward or backward) or from the phase function.
            guided = r1[:, 0] < guided_fraction
            d, plog, Nn = length[a], phase_log[a], N[a]
            x = np.clip(np.einsum("ij,ij->i", P[a] - P0[a], -Nn), 0.0, opposite_distance[a])
            with np.errstate(over="ignore"):
                backward_fraction = np.where(opposite[a], 1.0 / (1.0 + np.exp((opposite_distance[a] - 2.0 * x) / d)),
                                             0.0)
            backward = opposite[a] & (r1[:, 1] < backward_fraction)
            cos_guided = d - (d + 1.0) * np.exp(-r2[:, 0] * plog)
            cos_guided = np.where(backward, -cos_guided, cos_guided)
            sin_guided = np.sqrt(np.maximum(1.0 - cos_guided ** 2, 0.0))
            cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * r2[:, 1])
            T, B = vectors.orthonormal_frame(Nn)
            guided_D = ((sin_guided * cos_phi)[:, None] * T + (sin_guided * sin_phi)[:, None] * B
                        + cos_guided[:, None] * Nn)
            phase = HenyeyGreenstein(g).sample(-Dw[a], r2)
            new_D = np.where(guided[:, None], guided_D, phase.wi)
            hg_pdf = np.where(guided, henyey_greenstein(np.einsum("ij,ij->i", Dw[a], guided_D), g), phase.pdf)
            cos_theta = np.where(guided, cos_guided, np.einsum("ij,ij->i", phase.wi, Nn))
            Dw[a] = new_D
            forward_factor = (1.0 / (2.0 * math.pi)) / ((d - cos_theta) * plog) / hg_pdf
            backward_factor = (1.0 / (2.0 * math.pi)) / ((d + cos_theta) * plog) / hg_pdf
            forward_stretch = 1.0 - cos_theta / d
            backward_stretch = 1.0 + cos_theta / d
            sample_sigma = np.where(guided, sample_sigma * np.where(backward, backward_stretch, forward_stretch),
                                    sample_sigma)
        # 2d. The distance, and a local ray cast as far (the first step: at least 10 mean free paths, to find an
        #     opposite side for the backward guiding).
        t = -np.log(1.0 - r0[:, 1]) / sample_sigma
        reach = np.maximum(t, 10.0 / sigma_t.min(axis=1)) if step == 0 else t
        # (the first from the entry itself, its own triangle left out, as Cycles' ray.self)
        origin = P[a]
        count, found = local_hits(geometry, origin, Dw[a], reach, owner[a], OWN_HITS if step == 0 else 1)
        if step == 0:
            found, count = first_other(found, count, surface.prim[rows[a]])
        met = count > 0
        t_hit = np.where(met, found[0][3], np.inf)
        if step == 0:
            opposite[a] = met
            opposite_distance[a] = np.where(met, np.einsum("ij,ij->i", origin + t_hit[:, None] * Dw[a] - P0[a],
                                                           -N[a]), 0.0)
        leaves = met & (t_hit < t)
        t = np.where(leaves, t_hit, t)
        P[a] = origin + t[:, None] * Dw[a]
        # 2e. The weight: each channel's flight over the mixture of channels and strategies.
        pdf = flight_pdf(sigma_t, t, leaves)
        T = np.exp(-sigma_t * t[:, None])
        if step > 0:
            guided_pdf = flight_pdf(forward_stretch[:, None] * sigma_t, t, leaves)
            back_pdf = flight_pdf(backward_stretch[:, None] * sigma_t, t, leaves)
            guided_pdf = np.where(opposite[a][:, None],
                                  mix(guided_pdf * forward_factor[:, None], back_pdf * backward_factor[:, None],
                                      backward_fraction), guided_pdf * forward_factor[:, None])
            pdf = mix(pdf, guided_pdf, guided_fraction)
        denominator = (channel_pdf * pdf).sum(axis=1)
        gain = np.where(leaves[:, None], T, sigma_s * T)
        throughput[a] *= np.divide(gain, denominator[:, None], out=np.zeros_like(gain),
                                   where=denominator[:, None] > 0.0)
        # 2f. Those that left: their exit; those too faint: end.
        exits[a] = leaves
        prim[a] = np.where(leaves, found[0][0], 0)
        u[a], v[a], last_t[a] = np.where(leaves, found[0][1], 0.0), np.where(leaves, found[0][2], 0.0), t
        faint = np.abs(throughput[a]).max(axis=1) < THROUGHPUT_EPSILON
        alive = a[~leaves & ~faint & np.isfinite(throughput[a]).all(axis=1)]
    return exits, (prim, u, v), P, Dw, last_t, np.where(exits[:, None], throughput, 0.0)


def disk(ctx, surface, rows: np.ndarray, params: np.ndarray, weight: np.ndarray, pixel: np.ndarray,
         sample: np.ndarray, dimension: int) -> tuple:
    """Christensen-Burley's disk projection from the hits `rows` (k,) of `surface` with the BSSRDF closures' params
    (k, PARAMS) (DISK set; radius the per-channel d), weight (k, 3) the closure's weight: the same returns as `walk`
    (exits (k,) bool, the exit's (prim, u, v), the exit point (k, 3), its outward face normal (k, 3) (the side the
    entry was seen from), the probe's distance to it (k,), the weight (k, 3) after it)."""
    k = len(rows)
    geometry, seed = ctx.geometry, ctx.settings.seed
    P0, Ng = surface.I[rows], surface.Ng[rows]
    owner = geometry.owners(surface.prim[rows])
    times = None if surface.time is None else surface.time[rows]
    radius = params[:, bssrdf.RADIUS:bssrdf.RADIUS + 3]
    dim = dimension + SUBSURFACE_DIMENSION
    u = sampling.sample_2d(seed, pixel, sample, dimension=dim)
    u2 = sampling.sample_2d(seed, pixel, sample, dimension=dim + 1)
    # 1. The plane: across Ng (1/2), across T or across B (1/4 each); u.y reused within its share for phi.
    T0, B0 = orthonormals(Ng)
    axis = np.where(u[:, 1] < 0.5, 0, np.where(u[:, 1] < 0.75, 1, 2))
    y = np.where(axis == 0, 2.0 * u[:, 1], np.where(axis == 1, (u[:, 1] - 0.5) * 4.0, (u[:, 1] - 0.75) * 4.0))
    disk_N = np.where((axis == 0)[:, None], Ng, np.where((axis == 1)[:, None], T0, B0))
    disk_T = np.where((axis == 1)[:, None], Ng, T0)
    disk_B = np.where((axis == 2)[:, None], Ng, B0)
    pick = np.stack([np.where(axis == 0, 0.5, 0.25), np.where(axis == 1, 0.5, 0.25),
                     np.where(axis == 2, 0.5, 0.25)], axis=1)
    # 2. The point on the disk and the chord through it.
    r, h = bssrdf.burley_sample(radius, u[:, 0])
    phi = 2.0 * math.pi * y
    origin = P0 + disk_N * h[:, None] + (r * np.cos(phi))[:, None] * disk_T + (r * np.sin(phi))[:, None] * disk_B
    count, found = local_hits(geometry, origin, -disk_N, 2.0 * h, owner, LOCAL_STEPS, times)
    # 3. The surfaces weighed: DISK_MAX_HITS consecutive ones from a random start where there are more.
    n = np.minimum(count, LOCAL_STEPS)
    used = np.minimum(n, DISK_MAX_HITS)
    start = np.where(n > DISK_MAX_HITS, np.minimum(np.floor(u2[:, 1] * n), n - 1), 0).astype(np.int64)
    scale = np.where(n > DISK_MAX_HITS, n / DISK_MAX_HITS, 1.0)
    table = [np.stack([f[i] for f in found], axis=1) for i in range(4)]        # prim, u, v, t: (k, LOCAL_STEPS)
    live = radius > 0.0
    channels = np.maximum(live.sum(axis=1), 1)
    pdf = bssrdf.burley_pdf(radius, r[:, None]).sum(axis=1) / channels
    back = np.where(surface.backfacing[rows], -1.0, 1.0) if surface.backfacing is not None else np.ones(k)
    hit_prim, hit_u, hit_v, hit_t = (np.zeros((k, DISK_MAX_HITS), a.dtype) for a in table)
    hit_N = np.zeros((k, DISK_MAX_HITS, 3))
    weights = np.zeros((k, DISK_MAX_HITS, 3))
    at = np.arange(k)
    for i in range(DISK_MAX_HITS):
        ok = i < used
        slot = np.where(ok, (start + i) % np.maximum(n, 1), 0)
        for target, source in zip((hit_prim, hit_u, hit_v, hit_t), table):
            target[:, i] = source[at, slot]
        rows_i = np.flatnonzero(ok)
        if len(rows_i) == 0:
            continue
        data = geometry.triangle_data(hit_prim[rows_i, i], smooth=False, times=None if times is None else times[rows_i])
        N_i = data.Ng * back[rows_i, None]
        hit_N[rows_i, i] = N_i
        p = pick[rows_i] * np.abs(np.stack([np.einsum("ij,ij->i", d[rows_i], N_i) for d in (disk_N, disk_T, disk_B)],
                                           axis=1))
        w = np.where(p[:, 0] > 0.0, p[:, 0] / np.maximum((p * p).sum(axis=1), 1e-300), 0.0) * scale[rows_i]
        hit_P = origin[rows_i] - disk_N[rows_i] * hit_t[rows_i, i, None]
        distance = np.linalg.norm(hit_P - P0[rows_i], axis=1)
        ratio = np.divide(bssrdf.burley_pdf(radius[rows_i], distance[:, None]), pdf[rows_i, None],
                          out=np.zeros((len(rows_i), 3)), where=pdf[rows_i, None] > 0.0)
        weights[rows_i, i] = ratio * w[:, None]
    # 4. One surface in proportion to its mean weight; the path keeps the sum.
    mean = np.abs(weights).mean(axis=2)
    total = mean.sum(axis=1)
    partial = np.cumsum(mean, axis=1)
    chosen = np.minimum((partial <= (u2[:, 0] * total)[:, None]).sum(axis=1), DISK_MAX_HITS - 1)
    exits = (total > 0.0) & (mean[at, chosen] > 0.0)
    share = np.divide(total, mean[at, chosen], out=np.zeros(k), where=exits)
    kept = weight * weights[at, chosen] * share[:, None]
    t = hit_t[at, chosen]
    P = origin - disk_N * t[:, None]
    prim_uv = (np.where(exits, hit_prim[at, chosen], 0), np.where(exits, hit_u[at, chosen], 0.0),
               np.where(exits, hit_v[at, chosen], 0.0))
    return exits, prim_uv, P, hit_N[at, chosen], np.maximum(t, 1e-6), np.where(exits[:, None], kept, 0.0)


def media_across(ctx, inside: np.ndarray, P0: np.ndarray, P1: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """The volume stacks (k, V) int16 of paths that entered a BSSRDF's object `owner` (k,) at P0 (k, 3) in the media
    `inside` (k, V) and left it at P1 (k, 3): updated by every surface of another object with a medium on the segment
    from P0 to P1, entered through a front face and left through a back face as the segment meets them (Media.crossed;
    Cycles' integrator_volume_stack_update_for_subsurface), passing CAMERA_MEDIA_HITS surfaces at most; a copy."""
    media = ctx.extra["media"]
    inside = inside.copy()
    if inside.shape[1] == 0 or len(P0) == 0:
        return inside                               # (the world's medium alone: no mesh to go into or out of)
    gap = P1 - P0
    length = np.sqrt(np.einsum("ij,ij->i", gap, gap))
    D = np.divide(gap, length[:, None], out=np.zeros_like(gap), where=length[:, None] > 0.0)
    O = P0.copy()
    alive = np.flatnonzero(length > 0.0)
    for _ in range(CAMERA_MEDIA_HITS):
        reach = length[alive] - np.einsum("ij,ij->i", O[alive] - P0[alive], D[alive])
        alive = alive[reach > 0.0]
        if len(alive) == 0:
            break
        found = ctx.geometry.tracer.intersect(O[alive], D[alive], reach[reach > 0.0])
        hit = np.flatnonzero(found.hit)
        if len(hit) == 0:
            break
        rows = alive[hit]
        surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit], O[rows], D[rows],
                                  found.t[hit])
        objects = ctx.geometry.owners(found.prim[hit])
        inside[rows] = media.crossed(inside[rows], surface.material, surface.backfacing, objects != owner[rows],
                                     objects)
        O[rows] = shadows.spawn_ray(surface.I, surface.Ng, D[rows], shadows.error_bound(surface.I, surface.vertices))
        alive = rows
    return inside


def burley_as_diffuse(shader: ShaderResult, ancestor: np.ndarray) -> ShaderResult:
    """The shader with its Christensen-Burley closures turned Lambert ones of their weight (sampling weight their mean
    weight) at the hits `ancestor` (n,) bool a path reached after some diffuse bounce (Cycles' bssrdf_setup with
    PATH_RAY_DIFFUSE_ANCESTOR); the others as they are."""
    c = shader.closures
    if not ancestor.any() or c.params.shape[2] <= bssrdf.DISK:
        return shader
    turn = ancestor[:, None] & has(c.kind, BSDFFlags.SUBSURFACE) & (c.params[:, :, bssrdf.DISK] != 0.0)
    if not turn.any():
        return shader
    kind = np.where(turn, Lambert.kind, c.kind).astype(np.int32)
    sample_weight = np.where(turn, np.abs(c.weight.mean(axis=2)), c.sample_weight)
    closures = c._replace(kind=kind, sample_weight=sample_weight)
    return ShaderResult(closures, shader.emission, shader.transparency, shader.N, shader.holdout, shader.aov)


def exit_ray(exits: np.ndarray, prim_uv: tuple, P: np.ndarray, D: np.ndarray, t: np.ndarray) -> tuple:
    """(O (k, 3), D (k, 3), Hits) of rays that reach the walks' exits P (k, 3) from outside, as Cycles pretends:
    from beyond the exit along the walk's last direction D, back towards it (so the exit faces them); no hit where
    the walk found no exit."""
    prim, u, v = prim_uv
    back = np.maximum(t, 1e-6)
    return P + D * back[:, None], -D, Hits(exits, np.where(exits, back, np.inf), np.where(exits, prim, -1), u, v)


def exit_normal(shader: ShaderResult) -> np.ndarray:
    """The normal (n, 3) the walks' exits are lit with: the shading normal, or where a BSSRDF closure there has a
    linked Normal (its BUMP), the mean of the BSSRDF closures' normals weighed by their mean weight (Cycles'
    surface_shader_bssrdf_normal)."""
    c = shader.closures
    walks = has(c.kind, BSDFFlags.SUBSURFACE)
    bumped = (walks & (c.params[:, :, bssrdf.BUMP] != 0.0)).any(axis=1)
    if not bumped.any():
        return shader.N
    weights = np.where(walks, np.abs(c.weight.mean(axis=2)), 0.0)
    total = np.einsum("nk,nkj->nj", weights, c.N)
    length = np.linalg.norm(total, axis=1)
    mean = np.divide(total, length[:, None], out=np.zeros_like(total), where=length[:, None] > 0.0)
    return np.where((bumped & (length > 0.0))[:, None], mean, shader.N)


def subsurface_shader(shader: ShaderResult, exiting: np.ndarray) -> ShaderResult:
    """The shader at walks' exits (`exiting` (n,) bool) replaced by one white Lambert closure on the shading normal
    (exit_normal), with no emission, transparency or holdout (Cycles' subsurface_shader_data_setup); the others as
    they are."""
    if not exiting.any():
        return shader
    c = shader.closures
    n, slots = c.kind.shape
    exit_N = exit_normal(shader)
    kind = np.where(exiting[:, None], -1, c.kind)
    kind[exiting, 0] = Lambert.kind
    weight = np.where(exiting[:, None, None], 0.0, c.weight)
    weight[exiting, 0] = 1.0
    sample_weight = np.where(exiting[:, None], 0.0, c.sample_weight)
    sample_weight[exiting, 0] = 1.0
    N = c.N.copy()
    N[exiting, 0] = exit_N[exiting]
    # (beside it the hit's own normal, sd->N: a bumped exit normal's light is shadowed as Cycles' bump term does)
    Ns = None if c.Ns is None else np.where(exiting[:, None, None], shader.N[:, None, :], c.Ns)
    closures = c._replace(kind=kind.astype(np.int32), weight=weight, sample_weight=sample_weight, N=N, Ns=Ns)
    keep = ~exiting[:, None]
    holdout = None if shader.holdout is None else shader.holdout * keep
    return ShaderResult(closures, shader.emission * keep, shader.transparency * keep, shader.N, holdout, shader.aov)
