"""Render: a wavefront of camera rays, traced chunk by chunk on a thread pool.

There is no Python loop per pixel or per ray. A chunk holds every sample of a
run of pixels; for the whole chunk at once we
1. place the samples inside their pixels (core/sampling.py),
2. generate the camera rays (core/camera.py),
3. find the nearest hits (core/intersect.py),
4. shade the hits with every light and its shadow rays (core/shading.py),
5. sum each pixel's samples; the image is their mean (a 1-pixel box filter, like Cycles' "Box").
Chunks write to disjoint pixels, so threads need no locks; Embree and numpy
release the GIL, so large passes run on every core (small ones on fewer).
Memory stays bounded by the chunk size, whatever the image size, and the
temporaries come from the heap (core/memory.py).
With adaptive sampling (core/adaptive.py) this runs in passes: all pixels first,
then only the noisy ones, each pass continuing every pixel's sample pattern.
`_render_chunk` is the readable chunk; `_render_chunk_compiled` takes the same steps with their
arithmetic in C (core/kernels.py) and stands in for it wherever the kernels apply.
"""
from __future__ import annotations

import dataclasses
import math
import os
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Callable, NamedTuple, Optional

import numpy as np

from .film import adaptive
from .camera import camera as camera_
from .teaching import debug
from .geometry import instancing
from .native import kernels
from . import memory
from .sampling import sobol as sampling
from . import vectors
from .geometry.geometry import WorldGeometry, build_geometry
from .scene.scene import RenderSettings, Scene
from .integrators.direct import direct_light, surface_at_hits, translate_light

# Auxiliary buffers a render can return, with their channel counts ("lights": one per light).
AUX_BUFFERS = {
    "depth": 1,         # distance along the camera's view axis (Blender's Z); 1e10 where nothing was hit
    "normal": 3,        # shading normal N, world space, facing the camera
    "face_normal": 3,   # face normal, world space, facing the camera
    "n_dot_l": "lights",     # max(N.L, 0) per light (N.L itself with the clamp switched off)
    "visibility": "lights",  # fraction of shadow rays per light that reached it
    # Debug buffers (core/debug.py), computed only when asked for:
    "normal_angle": 1,  # angle between N and the face normal, degrees
    "barycentric": 3,   # (1 - u - v, u, v) of the hit
    "hit_distance": 1,  # t along the camera ray from the camera; 1e10 where nothing was hit
    "acne": 1,          # fraction of the pixel's shadow rays that hit the surface they left
    "rays": 1,          # camera rays plus shadow rays cast for the pixel
    "time": 1,          # seconds spent on the pixel (an estimate: debug.share_time)
}
MISS_DEPTH = 1e10
# With the "time" buffer, each chunk is rendered and timed in runs of this many pixels.
TIME_TILE = 64


@dataclass
class RenderStats:
    """What a render did: ray counts, time, and notes about the input."""

    primary_rays: int = 0
    shadow_rays: int = 0
    seconds: float = 0.0
    geometry_seconds: float = 0.0
    trace_seconds: float = 0.0      # inside Embree (nearest hits and shadow rays), summed over threads
    shading_seconds: float = 0.0    # shading the hits, less its shadow rays' Embree time, summed over threads
    triangles: int = 0
    passes: int = 0                 # sampling passes run (1 without adaptive sampling)
    samples_per_pixel: Optional[np.ndarray] = None   # (H, W) int32 camera samples each pixel received
    warnings: list = field(default_factory=list)
    kernels: str = ""               # "compiled", or "numpy" and why (core/kernels.py)

    @property
    def rays(self) -> int:
        """All rays traced."""
        return self.primary_rays + self.shadow_rays


@dataclass
class RenderResult:
    """A rendered image.

    image: (H, W, 4) float32 scene-linear RGBA, row 0 at the top
    aux:   name -> (H, W, c) float32 auxiliary buffer
    light_names: the name of the light behind each channel of the per-light buffers
    """

    image: np.ndarray
    aux: dict
    stats: RenderStats
    cancelled: bool = False
    light_names: list = field(default_factory=list)


def validate(scene: Scene, settings: RenderSettings) -> None:
    """Raise ValueError with a clear message when the scene or settings cannot be rendered."""
    if scene.camera is None:
        raise ValueError("the scene has no camera")
    if settings.width < 1 or settings.height < 1:
        raise ValueError(f"resolution must be at least 1x1 pixels, got {settings.width}x{settings.height}")
    if settings.samples < 1:
        raise ValueError(f"samples must be at least 1, got {settings.samples}")
    if settings.chunk_size < 1:
        raise ValueError(f"chunk size must be at least 1 sample, got {settings.chunk_size}")
    if not (math.isfinite(settings.adaptive_threshold) and settings.adaptive_threshold >= 0):
        raise ValueError(f"the adaptive noise threshold must be a finite number >= 0, got {settings.adaptive_threshold}")
    if settings.adaptive_min_samples < 0:
        raise ValueError(f"adaptive min samples must be >= 0, got {settings.adaptive_min_samples}")
    if not all(math.isfinite(a) and a > 0 for a in settings.pixel_aspect):
        raise ValueError(f"pixel aspect must be two finite numbers > 0, got {settings.pixel_aspect}")
    if settings.shadow_method not in ("robust", "epsilon"):
        raise ValueError(f"shadow method must be 'robust' or 'epsilon', got {settings.shadow_method!r}")
    if settings.visibility_normal not in ("face", "shading"):
        raise ValueError(f"visibility normal must be 'face' or 'shading', got {settings.visibility_normal!r}")
    if settings.kernels not in kernels.KERNELS:
        raise ValueError(f"kernels must be one of {kernels.KERNELS}, got {settings.kernels!r}")
    if settings.instancing not in instancing.INSTANCING_MODES:
        raise ValueError(f"instancing must be one of {instancing.INSTANCING_MODES}, got {settings.instancing!r}")
    if settings.shadow_method == "epsilon" and not (settings.epsilon >= 0 and math.isfinite(settings.epsilon)):
        raise ValueError(f"epsilon must be a finite length >= 0, got {settings.epsilon}")
    if not np.isfinite(np.asarray(scene.camera.matrix_world)).all():
        raise ValueError("the camera's transform has NaN or infinite values")
    unknown = set(settings.aux) - set(AUX_BUFFERS)
    if unknown:
        raise ValueError(f"unknown auxiliary buffers {sorted(unknown)}; choose from {list(AUX_BUFFERS)}")


def _usable_lights(scene: Scene, warnings: list) -> list:
    """Return the lights with finite parameters and some power; note the rest in warnings."""
    usable = []
    for light in scene.lights:
        values = [np.asarray(getattr(light, f), np.float64) for f in light.__dataclass_fields__
                  if f not in ("name", "shape") and getattr(light, f) is not None]     # a spot's frame may be None
        if not all(np.isfinite(x).all() for x in values):
            warnings.append(f"light '{light.name}' has NaN or infinite parameters and was skipped")
            continue
        if np.max(np.asarray(light.color, np.float64)) <= 0 or getattr(light, "power", getattr(light, "strength", 0.0)) <= 0:
            continue    # sends no light: nothing to trace
        usable.append(light)
    return usable


def region_pixels(settings: RenderSettings) -> np.ndarray:
    """Return the flat indices (row-major, row 0 at the top) of the pixels to render: (p,) int64."""
    W, H = settings.width, settings.height
    x0, y0, x1, y1 = settings.region if settings.region is not None else (0, 0, W, H)
    x0, x1 = max(0, int(x0)), min(W, int(x1))
    y0, y1 = max(0, int(y0)), min(H, int(y1))
    if x1 <= x0 or y1 <= y0:
        return np.zeros(0, np.int64)
    return (np.arange(y0, y1, dtype=np.int64)[:, None] * W + np.arange(x0, x1, dtype=np.int64)).reshape(-1)


class _Context:
    """What every chunk reads: scene, settings, geometry and camera-relative lights."""

    def __init__(self, scene: Scene, settings: RenderSettings, geometry: WorldGeometry, lights: list):
        self.scene = scene
        self.settings = settings
        self.geometry = geometry
        self.lights = lights
        self.world_color = np.asarray(scene.world_color, np.float64)[:3]
        self.want_aux = bool(settings.aux)
        cam = scene.camera
        self.forward = -np.asarray(cam.matrix_world, np.float64)[:3, 2]
        self.forward = self.forward / np.linalg.norm(self.forward)
        self.camera_offset = geometry.origin - np.asarray(cam.matrix_world, np.float64)[:3, 3]
        # Acne debug view: how far a blocker may rise above the plane a shadow ray leaves and still
        # count as lying in it (core/debug.py, self_intersections).
        self.self_hit_distance = (debug.SELF_HIT_FRACTION * debug.scene_scale(geometry)
                                  if "acne" in settings.aux else 0.0)
        # The render's running sums (PixelNoise, hits per pixel, and kernels.NoiseEstimates or None)
        # when chunks add to them themselves.
        self.sums = None
        # The compiled kernels' records of the scene (core/kernels.py), when they apply.
        self.numpy_because = kernels.why_not(settings)
        if not self.numpy_because:
            self.camera_record = kernels.camera_record(cam, settings.width, settings.height,
                                                       tuple(settings.pixel_aspect), geometry.origin)
            self.light_records = (kernels.LightRecord * len(lights))(
                *[kernels.light_record(light, i, settings.light_samples) for i, light in enumerate(lights)])
            self.shadow_settings = kernels.shadow_settings(settings)
            self.copied = kernels.copied_arrays(geometry) if not geometry.instanced else None
            self.copied_tables = kernels.copied_tables(self.copied) if self.copied is not None else None
            self.smooth = geometry.has_smooth
            background = [0.0, 0.0, 0.0, 0.0] if settings.transparent_background else [*self.world_color, 1.0]
            self.background = np.array(background)


class ChunkResult(NamedTuple):
    """Per-pixel sums of one chunk's samples (sums, not means, so passes add up).

    rgba:      (p, 4) float64 sum of the samples' RGBA
    squares:   (p, 2) float64 sums of the samples' squared luminance and alpha (adaptive sampling's
               noise estimate; zeros without adaptive sampling)
    aux:       name -> (p, c) float64 sum of the auxiliary values over the samples that hit
    hits:      (p,) int64 samples that hit a surface
               (rgba, squares and hits are None where the chunk added them to the render's sums
               itself: the compiled path, render._Context.sums)
    primary:   camera rays traced (a fisheye's samples outside its image circle trace none)
    shadow:    shadow rays traced
    shading_seconds: time spent shading (Embree's shadow queries included)
    samples:   camera samples per pixel in this chunk
    """

    rgba: np.ndarray
    squares: np.ndarray
    aux: dict
    hits: np.ndarray
    primary: int
    shadow: int
    shading_seconds: float
    samples: int


def _render_chunk(ctx: _Context, pixels: np.ndarray, spp: int, seed: int,
                  first: Optional[np.ndarray] = None) -> ChunkResult:
    """Render `spp` samples in each of `pixels`: samples first .. first + spp - 1 of each pixel's pattern.

    pixels: (p,) int64 flat pixel indices; first: (p,) int64 samples each pixel already has (None: 0).
    """
    s = dataclasses.replace(ctx.settings, samples=spp, seed=seed)
    W, H = s.width, s.height
    # 1. Sample positions inside each pixel: the next spp points of its progressive pattern
    #    (core/sampling.py), or without jitter the centres of a grid of spp cells.
    pixel, sample = _sample_keys(pixels, spp, first)
    if s.jitter:
        offset = sampling.sample_2d(s.seed, pixel, sample, dimension=0)
    else:
        offset = sampling.stratum_centres(sample, spp)
    raster_x = (pixel % W) + offset[:, 0]
    raster_y = (pixel // W) + offset[:, 1]
    # 2. Camera rays, moved into the camera-relative frame.
    rays = camera_.generate_rays(ctx.scene.camera, W, H, raster_x, raster_y, tuple(s.pixel_aspect))
    n = len(pixel)
    # As in Cycles: outside a fisheye's image circle the film is opaque black; camera rays that
    # miss show the world, or leave the film clear (alpha 0, and premultiplied RGB 0) when transparent.
    rgba = np.zeros((n, 4))
    rgba[:, 3] = 1.0
    if s.transparent_background:
        rgba[rays.valid, 3] = 0.0
    else:
        rgba[rays.valid, :3] = ctx.world_color
    traced = np.flatnonzero(rays.valid)
    if len(traced) == n:
        origins, directions, t_max = rays.origins - ctx.geometry.origin, rays.directions, rays.t_max
    else:
        origins = vectors.gather(rays.origins, traced) - ctx.geometry.origin
        directions, t_max = vectors.gather(rays.directions, traced), rays.t_max[traced]
    # 3. Nearest hits.
    hits = ctx.geometry.tracer.intersect(origins, directions, t_max)
    hit = np.flatnonzero(hits.hit)            # (m,) into the traced rays
    h = traced[hit]                            # (m,) into the chunk's samples
    D_hit = vectors.gather(directions, hit)    # (m, 3) the hit samples' camera-ray directions
    shadow_rays = 0
    shading_start = time.perf_counter()
    surface = shading = None
    if len(h):
        # 4. Shade the hits.
        surface = surface_at_hits(ctx.geometry, hits.prim[hit], hits.u[hit], hits.v[hit],
                                  vectors.gather(origins, hit), D_hit, hits.t[hit],
                                  flat_only=not s.smooth_normals)
        shading = direct_light(ctx.geometry, surface, ctx.lights, s, pixel[h], sample[h], ctx.want_aux,
                               prim=hits.prim[hit], self_hit_distance=ctx.self_hit_distance)
        rgba[h, :3] = shading.radiance
        rgba[h, 3] = 1.0
        shadow_rays = shading.shadow_rays
    shading_seconds = time.perf_counter() - shading_start
    # 5. Box filter: sum each pixel's samples (the caller divides by the count).
    per_pixel = rgba.reshape(len(pixels), spp, 4).sum(axis=1)
    squares = _squares(rgba, len(pixels), spp) if s.adaptive else np.zeros((len(pixels), 2))
    hits_per_pixel = np.bincount(h // spp, minlength=len(pixels))
    aux = (_sum_aux(ctx, len(pixels), spp, h, surface, shading, rays.valid, D_hit)
           if ctx.want_aux else {})
    return ChunkResult(per_pixel, squares, aux, hits_per_pixel, len(traced), shadow_rays, shading_seconds, spp)


def _sample_keys(pixels: np.ndarray, spp: int, first: Optional[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Return (pixel, sample) of a chunk's spp samples per pixel, pixel by pixel: two (p spp,) int64.

    Sample j of pixel k is number first[k] + j of that pixel's pattern (first None: 0).
    """
    pixel = np.repeat(pixels, spp)
    sample = np.tile(np.arange(spp, dtype=np.int64), len(pixels))
    if first is not None:
        sample += np.repeat(first, spp)
    return pixel, sample


def _squares(rgba: np.ndarray, n_pixels: int, spp: int) -> np.ndarray:
    """Return each pixel's sums of squared luminance and squared alpha, for adaptive sampling's noise estimate.

    rgba: (n_pixels * spp, 4) float64 samples, pixel by pixel -> (n_pixels, 2) float64
    """
    luminance = np.einsum("ij,j->i", rgba[:, :3], adaptive.LUMINANCE)
    return np.stack([luminance * luminance, rgba[:, 3] * rgba[:, 3]], axis=1).reshape(n_pixels, spp, 2).sum(axis=1)


def _render_chunk_compiled(ctx: _Context, pixels: np.ndarray, spp: int, seed: int,
                           first: Optional[np.ndarray] = None) -> ChunkResult:
    """`_render_chunk` with its arithmetic in the compiled kernels (core/kernels.py): the same steps,
    the same numbers, and the same Embree queries, through the same Tracer."""
    s = ctx.settings
    W, H = s.width, s.height
    p = len(pixels)
    first = np.zeros(p, np.int64) if first is None else np.ascontiguousarray(first, np.int64)
    pixels = np.ascontiguousarray(pixels, np.int64)
    valid = None
    tracer = ctx.geometry.tracer
    streamed = tracer.packed and tracer.stream_queries     # rays traced inside the kernels
    if ctx.camera_record is not None and streamed and ctx.copied is not None:
        # 1-5 in one pass (kernels.samples): the steps below, fused, a block of samples at a time.
        sums = kernels.samples(ctx.camera_record, seed, W, H, pixels, first, spp, tracer.packets,
                               ctx.copied_tables, ctx.shadow_settings, ctx.light_records, ctx.background,
                               adaptive.LUMINANCE, s.adaptive)
        tracer.count_intersect(sums.intersect_seconds)
        tracer.count_occluded(sums.occluded_seconds)
        return _chunk_sums(ctx, pixels, spp, sums.rgba, sums.squares, sums.hits, p * spp, sums.shadow_rays,
                           sums.shading_seconds)
    # 1-3. Sample positions, camera rays (camera-relative) and their nearest hits.
    if ctx.camera_record is not None and streamed:
        # Made, traced and gathered in one pass (kernels.primary): the steps below, fused. (Only
        # scenes with instances come here: the placement Embree hit becomes a triangle in between.)
        found = kernels.primary(ctx.camera_record, seed, W, H, pixels, first, spp, tracer.packets)
        tracer.count_intersect(found.embree_seconds)
        tracer.flatten_prims(found.geometry, found.prim, found.u, found.v, found.origins, found.directions,
                             found.t, found.instance)
        h = found.sample                                   # (m,) into the chunk's samples
        origins, directions = found.origins, found.directions
        hit = np.arange(len(h))                            # (m,) into origins / directions
        prim, t_hit, u_hit, v_hit = found.prim, found.t, found.u, found.v
        traced = None
    else:
        if ctx.camera_record is not None:
            origins, directions, t_max = kernels.camera_rays(ctx.camera_record, seed, W, H, pixels, first, spp)
            traced = None
        else:
            # A fisheye's rays come from numpy.
            pixel, sample = _sample_keys(pixels, spp, first)
            offset = kernels.sample_2d(seed, pixel, sample, dimension=0)
            rays = camera_.generate_rays(ctx.scene.camera, W, H, (pixel % W) + offset[:, 0],
                                         (pixel // W) + offset[:, 1], tuple(s.pixel_aspect))
            valid = rays.valid
            traced = np.flatnonzero(valid)
            origins = np.ascontiguousarray(vectors.gather(rays.origins, traced) - ctx.geometry.origin)
            directions = np.ascontiguousarray(vectors.gather(rays.directions, traced))
            t_max = rays.t_max[traced]
        hits = tracer.intersect(origins, directions, t_max)
        hit = np.flatnonzero(hits.hit)                     # (m,) into the traced rays
        h = hit if traced is None else traced[hit]         # (m,) into the chunk's samples
        prim, t_hit, u_hit, v_hit = hits.prim[hit], hits.t[hit], hits.u[hit], hits.v[hit]
    shading_start = time.perf_counter()
    m = len(h)
    E = np.zeros((m, 3))
    shadow_rays = 0
    albedo = np.zeros((m, 3))
    if m:
        # 4. The surface at each hit, then the lights in groups: shadow rays, Embree's answers, the light.
        lift = bool(s.terminator_fix and ctx.smooth)
        if ctx.copied is not None:
            triangles = kernels.copied_triangles(ctx.copied, prim)
        else:
            triangles = kernels.any_triangles(ctx.geometry, prim, ctx.smooth)
        albedo, smooth = triangles.albedo, triangles.smooth
        surface = kernels.surfaces(triangles, hit, origins, directions, t_hit, u_hit, v_hit, lift)
        row = h // spp                                     # (m,) each hit's pixel in the chunk
        pixel_of_hit = pixels[row]
        sample_of_hit = first[row] + h % spp
        if streamed:
            # Made, traced and added up in one pass (kernels.shade): the steps below, fused.
            shadow_rays, seconds = kernels.shade(ctx.shadow_settings, ctx.light_records, 0, len(ctx.light_records),
                                                 surface, smooth, pixel_of_hit, sample_of_hit,
                                                 tracer.packets, E)
            tracer.count_occluded(seconds)
        else:
            for l0, l1 in kernels.light_groups(ctx.light_records, m):
                batch = kernels.shadow_rays(ctx.shadow_settings, ctx.light_records, l0, l1, surface,
                                            smooth, pixel_of_hit, sample_of_hit)
                if len(batch.weight):
                    blocked = tracer.occluded(batch.origins, batch.directions, batch.t_max)
                    kernels.add_light(ctx.light_records, batch, blocked, E)
                shadow_rays += len(batch.weight)
    shading_seconds = time.perf_counter() - shading_start
    # 5. Box filter: sum each pixel's samples (the caller divides by the count).
    per_pixel, squares, hits_per_pixel = kernels.film(p, spp, valid, ctx.background, h, albedo, E,
                                                      adaptive.LUMINANCE, s.adaptive)
    primary = p * spp if traced is None else len(traced)
    return _chunk_sums(ctx, pixels, spp, per_pixel, squares, hits_per_pixel, primary, shadow_rays, shading_seconds)


def _chunk_sums(ctx: _Context, pixels: np.ndarray, spp: int, rgba: np.ndarray, squares: np.ndarray,
                hits: np.ndarray, primary: int, shadow: int, shading_seconds: float) -> ChunkResult:
    """A compiled chunk's result, its sums added to the render's here, in the worker (step 6), when
    the render asked for that (ctx.sums) rather than in the waiting thread."""
    if ctx.sums is not None:
        kernels.add_pixels(pixels, spp, rgba, squares, hits, *ctx.sums)
        return ChunkResult(None, None, {}, None, primary, shadow, shading_seconds, spp)
    return ChunkResult(rgba, squares, {}, hits, primary, shadow, shading_seconds, spp)


def _render_chunk_timed(ctx: _Context, pixels: np.ndarray, spp: int, seed: int,
                        first: Optional[np.ndarray] = None) -> ChunkResult:
    """Render `pixels` in runs of TIME_TILE pixels, timing each run: `_render_chunk`'s result plus the
    "time" buffer, each run's wall time shared out to its pixels by their rays (debug.share_time)."""
    parts = []
    for i in range(0, len(pixels), TIME_TILE):
        start = time.perf_counter()
        part = _render_chunk(ctx, pixels[i:i + TIME_TILE], spp, seed,
                             None if first is None else first[i:i + TIME_TILE])
        seconds = time.perf_counter() - start
        part.aux["time"] = debug.share_time(seconds, part.aux["rays"][:, 0])[:, None]
        if "rays" not in ctx.settings.aux:
            del part.aux["rays"]
        parts.append(part)
    aux = {name: np.concatenate([part.aux[name] for part in parts]) for name in parts[0].aux}
    return ChunkResult(np.concatenate([part.rgba for part in parts]),
                       np.concatenate([part.squares for part in parts]), aux,
                       np.concatenate([part.hits for part in parts]), sum(part.primary for part in parts),
                       sum(part.shadow for part in parts), sum(part.shading_seconds for part in parts), spp)


# Buffers that are per-pixel totals, not means over the hit samples; and the hidden denominator of "acne".
TOTAL_BUFFERS = ("rays", "time")
ACNE_CAST = "acne cast"


def _sum_aux(ctx: _Context, n_pixels: int, spp: int, h: np.ndarray, surface, shading,
             valid: np.ndarray, D: np.ndarray) -> dict:
    """Sum the auxiliary values of each pixel's hit samples: name -> (p, c) float64.

    Sums, so that passes add up: render() divides by the hit count, except for the per-pixel
    totals (TOTAL_BUFFERS) and "acne", a ratio of two sums (ACNE_CAST holds its denominator).
    h: (m,) int64 indices of the hit samples; valid: (n,) bool camera rays traced (n = p * spp);
    D: (m, 3) float64 the hit samples' camera-ray directions.
    """
    k = len(ctx.lights)
    owner = h // spp

    def total(values: np.ndarray) -> np.ndarray:
        values = values.reshape(len(h), -1)
        out = np.zeros((n_pixels, values.shape[1]))
        for c in range(values.shape[1]):
            out[:, c] = np.bincount(owner, weights=values[:, c], minlength=n_pixels)
        return out

    def summed(values: np.ndarray) -> np.ndarray:
        return total(values)[:, 0]

    aux = {}
    wanted = set(ctx.settings.aux) | ({"rays"} if "time" in ctx.settings.aux else set())
    for name in wanted - {"time"}:          # "time" is measured around the chunk (_render_chunk_timed)
        if name == "rays":
            # Every valid camera ray, plus the shadow rays of the hit samples.
            camera_rays = valid.reshape(n_pixels, spp).sum(axis=1).astype(np.float64)
            shadow = summed(shading.rays_per_hit) if surface is not None else 0.0
            aux[name] = (camera_rays + shadow)[:, None]
        elif name == "acne":
            cast = summed(shading.rays_per_hit) if surface is not None else np.zeros(n_pixels)
            acne = summed(shading.acne_per_hit) if surface is not None else np.zeros(n_pixels)
            aux[name], aux[ACNE_CAST] = acne[:, None], cast[:, None]
        elif surface is None:
            aux[name] = np.zeros((n_pixels, k if AUX_BUFFERS[name] == "lights" else AUX_BUFFERS[name]))
        elif name == "depth":
            aux[name] = total(np.einsum("ij,j->i", surface.I + ctx.camera_offset, ctx.forward))
        elif name == "normal":
            aux[name] = total(surface.N)
        elif name == "face_normal":
            aux[name] = total(surface.Ng)
        elif name == "n_dot_l":
            aux[name] = total(shading.n_dot_l) if k else np.zeros((n_pixels, 0))
        elif name == "visibility":
            aux[name] = total(shading.visibility) if k else np.zeros((n_pixels, 0))
        elif name == "normal_angle":
            aux[name] = total(debug.normal_angle(surface.N, surface.Ng))
        elif name == "barycentric":
            aux[name] = total(debug.barycentrics(surface.u, surface.v))
        elif name == "hit_distance":
            aux[name] = total(debug.hit_distance(surface.I, -ctx.camera_offset, D))
    return aux


def _run_chunks(pool, in_flight: int, chunks: list, work: Callable, store: Callable,
                cancel: Optional[Callable[[], bool]], progress: Callable[[float], None],
                stats: RenderStats, start: float) -> bool:
    """Run work(chunk) for every chunk on the pool and store(chunk, result) each; return whether cancelled.

    At most `in_flight` chunks are submitted at once: more than the pool's workers keeps them busy
    while results are stored, fewer runs a pass on fewer threads; and cancelling never waits for a
    long queue. store, progress and cancel are called from this (the calling) thread only.
    """
    queue = iter(chunks)
    running = {}

    def refill():
        for chunk in queue:
            running[pool.submit(work, chunk)] = chunk
            if len(running) >= in_flight:
                break

    refill()
    done = 0
    while running:
        finished, _ = wait(running, return_when=FIRST_COMPLETED)
        for future in finished:
            store(running.pop(future), future.result())
            done += 1
        if cancel is not None and cancel():
            for future in running:
                future.cancel()
            return True
        refill()
        stats.seconds = time.perf_counter() - start
        progress(done / max(1, len(chunks)))
    return False


# Below this many samples per thread, another thread costs more than it brings. Embree releases the
# GIL for whole batches and numpy inside each operation, but the Python between operations holds it,
# and on short arrays the handovers dominate. Measured on this 2-core machine (adaptive renders at 128
# samples, median of 7): light_area took 0.73 s with 2^14, 0.80 s with 2^15 and 0.90 s with 2^17,
# against 0.87 s for splitting every pass into two chunks per thread, which also burnt 25% more CPU.
PARALLEL_MIN_SAMPLES = 1 << 14

# From this many pixels on, the noise test between adaptive passes is shared out between the threads
# (kernels.unconverged's bands). Measured on this 2-core machine: 3840 x 2160 took 250-310 ms a pass
# instead of 330-360, 1920 x 1080 58-71 ms instead of 70-75; at 320 x 240 the bands cost more than
# they bring (4.5 ms against 3), as waking a worker thread takes up to a few ms here.
BANDED_PIXELS = 1 << 21


def _plan_chunks(pixels: int, spp: int, chunk_size: int, threads: int) -> tuple[int, int]:
    """Return (pixels per chunk, threads to use) for a pass over `pixels` pixels of `spp` samples.

    A chunk holds at most chunk_size samples (memory stays bounded). A pass too small to give every
    thread PARALLEL_MIN_SAMPLES runs on fewer threads (adaptive sampling's later passes often on one);
    otherwise it is cut into one chunk per thread at least, so that every core works.
    """
    if pixels <= 0:
        return 1, 1                       # nothing to render (an empty region): no chunks at all
    workers = max(1, min(threads, (pixels * spp) // PARALLEL_MIN_SAMPLES))
    # As few chunks as chunk_size allows, rounded up to a multiple of the workers, all of one size:
    # so that every worker gets the same share (5 chunks on 2 threads would leave one idle a fifth
    # of the pass).
    chunks = -(-pixels * spp // max(1, chunk_size))
    chunks = workers * -(-chunks // workers)
    return max(1, -(-pixels // chunks)), workers


def _usable_cores() -> int:
    """Return the number of cores this process may run on (its CPU affinity, where the OS tells)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:              # macOS and Windows have no sched_getaffinity
        return os.cpu_count() or 1


def render(scene: Scene, settings: RenderSettings,
           progress: Optional[Callable[[float, RenderStats], None]] = None,
           cancel: Optional[Callable[[], bool]] = None,
           geometry: Optional[WorldGeometry] = None, keep_memory: bool = False) -> RenderResult:
    """Render `scene` and return a float32 (H, W, 4) scene-linear RGBA image.

    progress(fraction, stats) is called after each chunk; cancel() is polled
    between chunks, and a True answer stops the render promptly (the result then
    holds the chunks finished so far and cancelled=True). Both are called from
    the calling thread. A prebuilt `geometry` (same camera origin) skips the BVH build.
    keep_memory: leave the freed buffers with the process for the next render (core/memory.py);
    the caller then calls memory.release() when no render follows.
    """
    start = time.perf_counter()
    validate(scene, settings)
    stats = RenderStats()
    W, H = settings.width, settings.height
    # Camera-relative rendering: subtract the camera position in float64 before float32.
    origin = (np.asarray(scene.camera.matrix_world, np.float64)[:3, 3] if settings.camera_relative
              else np.zeros(3))
    if geometry is None:
        geometry = build_geometry(scene, origin, instancing.instance_triangles(settings.instancing))
    stats.geometry_seconds = time.perf_counter() - start
    stats.triangles = geometry.triangle_count
    stats.warnings.extend(geometry.warnings)
    lights = [translate_light(light, geometry.origin) for light in _usable_lights(scene, stats.warnings)]
    ctx = _Context(scene, settings, geometry, lights)

    # Running sums per pixel over all passes (core/adaptive.py): colour, noise, aux values, hits.
    noise = adaptive.PixelNoise(np.zeros((H * W, 4)), np.zeros((H * W, 2)), np.zeros(H * W, np.int64))
    aux_total = {}
    for name in settings.aux:
        channels = len(lights) if AUX_BUFFERS[name] == "lights" else AUX_BUFFERS[name]
        aux_total[name] = np.zeros((H * W, channels))
    if "acne" in settings.aux:
        aux_total[ACNE_CAST] = np.zeros((H * W, 1))
    aux_hits = np.zeros(H * W, np.int64)

    region = region_pixels(settings)
    # Pixels wholly outside a fisheye's image circle are opaque black film: no samples needed.
    outside = camera_.outside_image_circle(scene.camera, W, H, region, tuple(settings.pixel_aspect))
    if outside.any():
        noise.total[region[outside], 3] = 1.0
        region = region[~outside]
    if settings.adaptive:
        passes = adaptive.pass_sizes(settings.samples, settings.adaptive_min_samples)
        threshold = settings.adaptive_threshold or adaptive.automatic_threshold(settings.samples)
    else:
        passes = [settings.samples]
    threads = settings.threads if settings.threads > 0 else _usable_cores()
    cancelled = False
    tracer = geometry.tracer
    queried = (tracer.intersect_seconds, tracer.occluded_seconds)

    def store(chunk: tuple, result: ChunkResult) -> None:
        chunk_pixels = vectors.selector(chunk[0])         # a chunk of the first pass: a run of rows
        if result.rgba is not None:                       # (else the chunk added its sums itself)
            noise.total[chunk_pixels] += result.rgba
            noise.squares[chunk_pixels] += result.squares
            noise.count[chunk_pixels] += result.samples
            aux_hits[chunk_pixels] += result.hits
        for name, values in result.aux.items():
            aux_total[name][chunk_pixels] += values
        stats.primary_rays += result.primary
        stats.shadow_rays += result.shadow
        stats.shading_seconds += result.shading_seconds

    if not ctx.numpy_because:
        # (The noise test between passes runs in bands of rows, one per thread, on large images.)
        bands = threads if W * H >= BANDED_PIXELS else 1
        render_chunk = _render_chunk_compiled
        # Each pixel's noise and mean are renewed by the chunk that adds its samples, on the render's
        # threads; the noise test between passes then reads them.
        estimates = kernels.NoiseEstimates.empty(H * W) if len(passes) > 1 else None
        unconverged = lambda *args: kernels.unconverged(*args, pool=pool, bands=bands, estimates=estimates)
        ctx.sums = (noise, aux_hits, estimates)
        stats.kernels = "compiled"
    else:
        render_chunk = _render_chunk_timed if "time" in settings.aux else _render_chunk
        unconverged = adaptive.unconverged
        stats.kernels = f"numpy ({ctx.numpy_because})"
    with memory.temporaries_from_the_heap(keep_memory), ThreadPoolExecutor(max_workers=threads) as pool:
        pixels = region
        for index, spp in enumerate(passes):
            # 1. Which pixels still need samples: all of them at first, then the noisy ones.
            if index > 0:
                pixels = unconverged(region, noise, threshold, W, H, passes[0])
                if len(pixels) == 0:
                    break
            # 2. A pass of `spp` more samples over them, chunk by chunk: each pixel continues its own
            #    progressive pattern where it left off, so all its passes together stay stratified.
            if ctx.sums is not None and index == len(passes) - 1:
                ctx.sums = ctx.sums[:2] + (None,)         # no noise test follows the last pass
            per_chunk, workers = _plan_chunks(len(pixels), spp, settings.chunk_size, threads)
            done_before = noise.count[pixels]                   # samples each pixel has, before this pass
            chunks = [(pixels[i:i + per_chunk], done_before[i:i + per_chunk])
                      for i in range(0, len(pixels), per_chunk)]
            in_flight = 2 * threads if workers == threads else workers
            cancelled = _run_chunks(pool, in_flight, chunks,
                                    lambda c: render_chunk(ctx, c[0], spp, settings.seed, c[1]), store,
                                    cancel, lambda f: progress((index + f) / len(passes), stats) if progress else None,
                                    stats, start)
            stats.passes += 1
            if cancelled:
                break

    if progress is not None and not cancelled:
        progress(1.0, stats)

    # 3. Box filter: each pixel's mean over all its samples; aux values over the samples that hit,
    #    except per-pixel totals, and acne: shadow rays that hit their own surface per ray cast.
    if ctx.numpy_because:
        image = (noise.total / np.maximum(noise.count, 1)[:, None]).astype(np.float32)
    else:
        image = kernels.resolve(noise.total, noise.count)       # the same quotients, in one pass
    aux = {}
    covered = aux_hits > 0
    for name in settings.aux:
        values = aux_total[name]
        if name in TOTAL_BUFFERS:
            aux[name] = values.astype(np.float32)
        elif name == "acne":
            cast = aux_total[ACNE_CAST]
            aux[name] = np.where(cast > 0, values / np.maximum(cast, 1.0), 0.0).astype(np.float32)
        else:
            out = np.full(values.shape, MISS_DEPTH if name in ("depth", "hit_distance") else 0.0, np.float32)
            out[covered] = values[covered] / aux_hits[covered, None]
            aux[name] = out
    stats.samples_per_pixel = noise.count.reshape(H, W).astype(np.int32)

    stats.seconds = time.perf_counter() - start
    # Embree's share: the shadow rays' queries ran inside shading, so they move from there to trace.
    shadow_query = tracer.occluded_seconds - queried[1]
    stats.trace_seconds = tracer.intersect_seconds - queried[0] + shadow_query
    stats.shading_seconds -= shadow_query
    return RenderResult(image.reshape(H, W, 4),
                        {name: values.reshape(H, W, -1) for name, values in aux.items()},
                        stats, cancelled, [light.name for light in lights])
