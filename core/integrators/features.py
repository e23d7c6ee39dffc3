"""Denoising features: what a denoiser needs besides the noisy image, as Cycles 5.0 writes them.

Intel Open Image Denoise (Blender's compositor Denoise node) is guided by two smooth images of the
same pixels: each pixel's albedo and normal at the first surface whose look is not a sharp
reflection. They are cheap and nearly noise-free, and the denoiser keeps the edges and textures
they show while it smooths the noise of the Combined pass.

The integrator writes them along each camera sample's own path, as Cycles does (kernel/film/denoising_passes.h,
film_write_emission_or_background_pass in light_passes.h), both kernels:

- A path looks for its feature vertex from the camera on, with a feature throughput of 1.
- At a hit, its closures split into diffuse-like ones (Lambert; glossy or rough glass with alpha >
  ROUGH_ALPHA, Cycles' 0.075) and specular-like ones (mirror, smooth glass, Transparent, and those
  with alpha at most ROUGH_ALPHA). If the diffuse-like closures carry more than a quarter of the sampling weight
  (or there are no closures), the hit is the feature vertex:
      albedo += feature throughput x the sum of the diffuse-like closures' weights,
      normal  = the closures' normals weighed by their sampling weights (0 where there are none),
  and the path stops looking. Otherwise the feature throughput is multiplied by the sum of the specular-like
  weights and the path goes on as it does anyway (its own sampled direction).
- While a path looks, what it sees emit adds feature throughput x its contribution to Combined (path throughput,
  MIS weight and cap included): the surface the camera sees emit, what its rays find (lamps, emitters, the world)
  and, for the camera, the world where it escapes (0 with a transparent film) and the lamps it passes.
- Scattering media the path crosses while it looks (in_media; Cycles' film_write_denoising_features_volume): in
  expectation over Cycles' choice to scatter there (its unguided odds), the integral of T(s) sigma_s(s) ds over
  the ray (sigma_s / sigma_t (1 - T) in a homogeneous medium; summed over the pieces of the march, core/volumes/
  field.py, in a heterogeneous one) times the path's throughputs; a path that scatters stops looking with the view
  direction back towards the camera as its normal, so later vertices count times the odds of getting past (the
  reach).
- A path that ends before a feature vertex (a bounce limit, Russian roulette) leaves the features as they are:
  with Max Bounces 0, a mirror's pixel keeps albedo 0 unless its ray finds a light or the world, as in Cycles
  (measured: a tinted mirror reflecting a red wall, albedo 0 in Cycles 5.0 at Max Bounces 0, tint x red at 1).

Each pixel's features are the mean over all its samples (the film's FILM_BUFFER sums).

What Primer approximates: a closure's albedo is its weight (Cycles multiplies a microfacet's weight by its
Fresnel-averaged reflectance); the normal is in world space, like Primer's Normal pass (Cycles writes its
Denoising Normal in camera space; Open Image Denoise accepts either, as long as it is one space). Whitted's
tracer writes the features of the camera's hit alone (its two specular branches are not one path), and those of the
media its camera rays cross (in_media) as the path tracer's camera rays do.
"""
from __future__ import annotations

import numpy as np

from .. import materials as materials_
from ..native import schema

# A glossy closure whose alpha (roughness^2) exceeds this counts as diffuse-like (Cycles' 0.075).
ROUGH_ALPHA = schema.constant("ROUGH_ALPHA", 0.075, "the denoising features' diffuse-like alpha (features.py)")
# The core buffers the features fill (core/render.py RenderResult.aux), 3 channels each.
FEATURE_BUFFERS = ("denoising_albedo", "denoising_normal")


def diffuse_like(closures: materials_.Closures) -> np.ndarray:
    """Return which closure slots count as diffuse for the features: (n, K) bool (empty slots False).

    From each BSDF's class (materials_.BSDF_TYPES): a singular BSDF (mirror, smooth glass, Transparent) is
    specular-like; one with an "alpha" parameter (GGX glossy, rough glass) is diffuse-like when its alpha
    exceeds ROUGH_ALPHA; any other (Lambert) is diffuse-like.
    """
    out = np.zeros(closures.kind.shape, bool)
    for bsdf in materials_.BSDF_TYPES:
        mine = closures.kind == bsdf.kind
        if bsdf.is_(materials_.BSDFFlags.SINGULAR) or not mine.any():
            continue
        if "alpha" in bsdf.params:
            mine &= closures.params[..., bsdf.params.index("alpha")] > ROUGH_ALPHA
        out |= mine
    return out


def vertex_features(closures: materials_.Closures) -> tuple:
    """Return (diffuse albedo (m, 3), specular albedo (m, 3), normal (m, 3), is the feature vertex (m,) bool)
    of hits with the `closures` (module docstring: Cycles' rule)."""
    present = closures.kind >= 0
    weight = np.where(present[..., None], closures.weight, 0.0)
    sample_weight = np.where(present, closures.sample_weight, 0.0)
    diffuse = diffuse_like(closures) & present
    diffuse_albedo = np.where(diffuse[..., None], weight, 0.0).sum(axis=1)
    specular_albedo = np.where((present & ~diffuse)[..., None], weight, 0.0).sum(axis=1)
    total = sample_weight.sum(axis=1)
    nonspecular = np.where(diffuse, sample_weight, 0.0).sum(axis=1)
    normal = np.einsum("nk,nkj->nj", sample_weight, closures.N)
    normal = np.divide(normal, total[:, None], out=np.zeros_like(normal), where=total[:, None] > 0.0)
    stops = (total == 0.0) | (4.0 * nonspecular > total)
    return diffuse_albedo, specular_albedo, normal, stops


# The film's buffer of the features' per-pixel sums: albedo RGB, then normal XYZ.
FILM_BUFFER = "denoising_features"
FILM_CHANNELS = schema.constant("FEATURE_CHANNELS", 6, "the denoising features' channels: albedo RGB, normal XYZ")


class Features:
    """Each camera ray's denoising features as its path writes them: albedo and normal, (n, 3) float64 each; and
    reach (n,) float64, the odds that the path is still looking past the media in front of the camera (in_media)."""

    def __init__(self, n: int):
        """Nothing written yet for n camera rays."""
        self.albedo = np.zeros((n, 3))
        self.normal = np.zeros((n, 3))
        self.reach = np.ones(n)

    def stacked(self) -> np.ndarray:
        """(n, FILM_CHANNELS) albedo then normal, as the film sums them."""
        return np.concatenate([self.albedo, self.normal], axis=1)


def at_vertex(features: Features, owner: np.ndarray, looking: np.ndarray, throughput: np.ndarray,
              feature_throughput: np.ndarray, shader, emission: np.ndarray) -> tuple:
    """The rule at a path vertex (module docstring) for the hits of camera rays `owner` (m,) int64: where the path
    still looks (`looking` (m,) bool), the emission it sees there (m, 3) (its contribution: x throughput (m, 3)),
    then the feature vertex's albedo and normal; returns (looking, feature_throughput (m, 3)) after the vertex."""
    rows = np.flatnonzero(looking)
    if len(rows) == 0:
        return looking, feature_throughput
    features.albedo[owner[rows]] += feature_throughput[rows] * throughput[rows] * emission[rows]
    diffuse_albedo, specular_albedo, normal, stops = vertex_features(shader.closures.rows(rows))
    done = rows[stops]
    reach = features.reach[owner[done]]
    features.albedo[owner[done]] += reach[:, None] * feature_throughput[done] * diffuse_albedo[stops]
    features.normal[owner[done]] += reach[:, None] * normal[stops]
    looking, feature_throughput = looking.copy(), feature_throughput.copy()
    looking[done] = False
    feature_throughput[rows[~stops]] *= specular_albedo[~stops]
    return looking, feature_throughput


def in_media(features: Features, stretch, t: np.ndarray, back: np.ndarray, owner=None, throughput=None,
             feature_throughput=None) -> None:
    """The media a path crosses while it looks (stretch: the rays' core/volumes Stretch, out to t (k,), inf where a
    ray escapes), as Cycles 5.0 writes them (film_write_denoising_features_volume): a path that scatters there stops
    looking with the view direction as its normal; before it does, the media add their albedo. In expectation, with
    Cycles' odds of passing (no volume guiding): albedo += feature throughput x throughput x the integral of
    T(s) sigma_s(s) ds per channel (scattered: sigma_s / sigma_t (1 - T) in homogeneous media, summed over the pieces
    of the march in heterogeneous ones), the path's reach *= P, the odds it passes (T per channel weighed by Cycles'
    channel pdf, |throughput (albedo + T)|), normal += reach (1 - P) back (back (3,): towards the camera, Cycles'
    (0, 0, -1) in camera space); the surfaces after write their albedo and normal times the reach (at_vertex). Media
    that only absorb leave the features as they are (Cycles: attenuation only). owner (k,): the camera rays of the
    paths (None: the camera rays themselves); throughput, feature_throughput (k, 3): the paths' (None: 1)."""
    k = len(stretch.sigma_t)
    owner = np.arange(k) if owner is None else np.asarray(owner)
    throughput = np.ones((k, 3)) if throughput is None else throughput
    feature_throughput = np.ones((k, 3)) if feature_throughput is None else feature_throughput
    t = np.broadcast_to(np.asarray(t, np.float64), (k,))
    varying = stretch.varying
    rows = np.flatnonzero((stretch.sigma_s > 0.0).any(axis=1) & ~varying)
    sigma_t, sigma_s = stretch.sigma_t[rows], stretch.sigma_s[rows]
    positive = sigma_t > 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        T = np.where(positive, np.exp(-np.where(positive, sigma_t, 1.0) * t[rows, None]), 1.0)
    albedo = np.where(positive, sigma_s / np.where(positive, sigma_t, 1.0), 0.0) * (1.0 - T)
    marched = np.flatnonzero(varying & stretch.scatters)
    if len(marched):
        march = stretch.march(t[marched], marched)
        keep = (march.sigma_s > 0.0).any(axis=(1, 2))                   # (fields that scatter nowhere on the ray)
        T_m, albedo_m = march_scattered(march)
        rows = np.concatenate([rows, marched[keep]])
        T, albedo = np.concatenate([T, T_m[keep]]), np.concatenate([albedo, albedo_m[keep]])
    if len(rows) == 0:
        return
    tp = throughput[rows]
    share = np.abs(tp * (albedo * tp + T))
    total = share.sum(axis=1)
    P = np.where(total > 0.0, (share * T).sum(axis=1) / np.where(total > 0.0, total, 1.0), T.mean(axis=1))
    who = owner[rows]
    features.albedo[who] += feature_throughput[rows] * tp * albedo
    features.normal[who] += (features.reach[who] * (1.0 - P))[:, None] * np.asarray(back, np.float64)
    features.reach[who] *= P


def march_scattered(march) -> tuple:
    """(T, scattered) (n, 3) float64 of n marched rays (core/volumes/field.py March): what they let through to their
    ends, and the integral of T(s) sigma_s(s) ds over them, piece by piece in order: T(edge_i) sigma_s_i / sigma_t_i
    (1 - exp(-sigma_t_i len_i)) (0 where sigma_t_i is 0), as features.c features_in_march sums it."""
    width = np.diff(march.edges, axis=1)[:, :, None]                    # (n, K + 2, 1), the last may be inf
    sigma_t, sigma_s = march.sigma_t, march.sigma_s
    positive = sigma_t > 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        caught = -np.expm1(-np.where(positive, sigma_t, 1.0) * width)
        each = np.where(positive, np.exp(-march.tau[:, :-1]) * (sigma_s / np.where(positive, sigma_t, 1.0) * caught),
                        0.0)
        T = np.exp(-march.tau[:, -1])
    each = np.nan_to_num(each, nan=0.0)
    scattered = np.zeros_like(T)
    for j in range(each.shape[1]):                                      # (in order, as C sums them)
        scattered = scattered + each[:, j]
    return T, scattered


def found(features: Features, owner: np.ndarray, looking: np.ndarray, feature_throughput: np.ndarray,
          contribution: np.ndarray) -> None:
    """What paths' rays found (contribution (m, 3) to Combined, throughput included) adds feature throughput x
    contribution to the albedo of the camera rays `owner` (m,) whose paths still look (`looking` (m,) bool)."""
    rows = np.flatnonzero(looking)
    if len(rows):
        features.albedo[owner[rows]] += feature_throughput[rows] * contribution[rows]
