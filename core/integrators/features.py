"""Denoising features: what a denoiser needs besides the noisy image, as Cycles writes them.

Intel Open Image Denoise (Blender's compositor Denoise node) is guided by two smooth images of the
same pixels: each pixel's albedo and normal at the first surface whose look is not a sharp
reflection. They are cheap and nearly noise-free, and the denoiser keeps the edges and textures
they show while it smooths the noise of the Combined pass.

Cycles' meaning (kernel/film/denoising_passes.h), followed here along each camera sample's path:

- At a hit, its closures split into diffuse-like ones (Lambert; glossy or rough glass with alpha >
  ROUGH_ALPHA, Cycles' 0.075) and specular-like ones (mirror, smooth glass, Transparent, and those
  with alpha at most ROUGH_ALPHA). If the diffuse-like closures carry more than a quarter of the sampling weight
  (or there are no closures), the hit is the feature vertex:
      albedo = throughput * (sum of the diffuse-like closures' weights + the emission seen there),
      normal = sum of every closure's normal times its sampling weight / the sum of those weights
               (the shading normal, where it has one closure; 0 where it has none).
- Otherwise the path goes on in a direction sampled from the closures (a mirror reflects, glass
  reflects or refracts at random), with throughput *= the sum of the specular-like weights: a
  mirror shows the albedo and normal of what it reflects, tinted by its colour. After
  MAX_SPECULAR_VERTICES such vertices the last one is taken as it is.
- A ray that escapes adds throughput * the world it sees (0 with a transparent film), as Cycles
  writes the background's colour into the albedo; its normal stays 0.

Each pixel's features are the mean over FEATURE_SAMPLES camera samples (fewer when the render takes
fewer), at the same jittered positions as the render's first samples; pixels without samples (outside
the region, outside a fisheye's image circle) are 0.

What Primer approximates: a closure's albedo is its weight (Cycles multiplies a microfacet's weight
by its Fresnel-averaged reflectance); the normal is in world space, like Primer's Normal pass
(Cycles writes its Denoising Normal in camera space; Open Image Denoise accepts either, as long as it
is one space); and the features come from a separate first-hit pass of a few samples per pixel, in
Python for both kernels (the compiled chunk does not fill them), instead of from every render sample.
"""
from __future__ import annotations

import numpy as np

from .. import materials as materials_
from .. import vectors
from ..materials import graph as graph_
from ..sampling import sobol as sampling
from . import shadows
from .base import Context, Recorder, check_stop
from .rays import camera_hits

# Camera samples per pixel the features average (at most the render's samples).
FEATURE_SAMPLES = 2
# A glossy closure whose alpha (roughness^2) exceeds this counts as diffuse-like (Cycles' 0.075).
ROUGH_ALPHA = 0.075
# Specular vertices followed before the last one is taken as the feature vertex.
MAX_SPECULAR_VERTICES = 8
# Sampling dimensions of the direction sampled at specular vertex k: FEATURE_DIMENSION + 2 k, + 1.
FEATURE_DIMENSION = 96
# The core buffers the features fill (core/render.py RenderResult.aux), 3 channels each.
FEATURE_BUFFERS = ("denoising_albedo", "denoising_normal")


def feature_samples(samples: int) -> int:
    """Return the camera samples per pixel the features average for a render of `samples` samples."""
    return max(1, min(int(samples), FEATURE_SAMPLES))


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


def vertex_features(shader) -> tuple:
    """Return (diffuse albedo (m, 3), specular albedo (m, 3), normal (m, 3), is the feature vertex (m,) bool)
    of hits with the ShaderResult `shader` (module docstring: Cycles' rule)."""
    closures = shader.closures
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


def trace_features(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                   sample: np.ndarray) -> tuple:
    """Return (albedo (n, 3), normal (n, 3)) float64 of camera rays O, D (n, 3) float64 up to t_max (n,):
    each ray's feature vertex, as the module docstring says. pixel, sample: (n,) int64 random-number keys."""
    s = ctx.settings
    n = len(O)
    albedo, normal = np.zeros((n, 3)), np.zeros((n, 3))
    owner = np.arange(n)
    throughput = np.ones((n, 3))
    recorder = Recorder()
    for vertex in range(MAX_SPECULAR_VERTICES + 1):
        check_stop(ctx)
        # 1. What the rays meet: the world (and lamps with extent) where they escape, else a surface.
        seen, found, hit, surface = camera_hits(ctx, O, D, t_max, recorder)
        missed = np.flatnonzero(~found.hit)
        albedo[owner[missed]] += throughput[missed] * seen[missed]
        if surface is None:
            break
        owner, throughput = owner[hit], throughput[hit]
        wo = -vectors.gather(D, hit)
        ray = graph_.RAY_CAMERA if vertex == 0 else graph_.RAY_BOUNCE
        shader = ctx.materials.shade(surface.material, surface.N, wo, surface, ctx.geometry, ray)
        diffuse_albedo, specular_albedo, closure_normal, stops = vertex_features(shader)
        if vertex == MAX_SPECULAR_VERTICES:
            stops[:] = True
        # 2. Feature vertices: their albedo (plus what they emit) and normal.
        done = np.flatnonzero(stops)
        albedo[owner[done]] += throughput[done] * (diffuse_albedo[done] + shader.emission[done])
        normal[owner[done]] = closure_normal[done]
        # 3. Specular vertices: on along a direction sampled from their closures.
        on = np.flatnonzero(~stops)
        if len(on) == 0:
            break
        part = materials_.Closures(*(None if array is None else array[on] for array in shader.closures))
        keys = pixel[owner[on]], sample[owner[on]]
        u = sampling.sample_2d(s.seed, *keys, dimension=FEATURE_DIMENSION + 2 * vertex)
        pick = sampling.sample_2d(s.seed, *keys, dimension=FEATURE_DIMENSION + 2 * vertex + 1)[:, 0]
        bs = materials_.sample_closures(part, wo[on], u, pick)
        going = np.flatnonzero(bs.pdf > 0.0)
        rows = on[going]
        wi = bs.wi[going]
        O = shadows.spawn_ray(surface.I[rows], surface.Ng[rows], wi, shadows.error_bound(surface.I[rows],
                                                                                         surface.vertices[rows]))
        D = wi
        t_max = np.full(len(rows), np.inf)
        owner = owner[rows]
        throughput = throughput[rows] * specular_albedo[rows]
        if len(rows) == 0:
            break
    return albedo, normal
