"""Shadow catchers (Object > Visibility > Shadow Catcher): an object the camera sees only through what the other
objects do to its light, their shadows and reflections, for putting rendered objects into filmed footage.

As Cycles 5.0 does it (kernel/integrator/shadow_catcher.h, intersect_closest.h integrator_split_shadow_catcher,
film/light_passes.h, film/read.h): a camera sample whose ray meets a catcher first is followed twice from there,

- C: in the whole scene, the catcher an ordinary object (the render's own sample, Combined's sums);
- K: in the catcher-only scene, where every object that is not a catcher is hidden from every ray (Cycles'
  SHADOW_CATCHER_PATH_VISIBILITY) and lights no one (an emissive object's light samples leave every closure out,
  Cycles' SHADER_EXCLUDE_SHADOW_CATCHER); lamps and the world light it as before.

Each pixel sums, besides Combined (FILM_CHANNELS):

- M (rgba): the matte, each sample's C where its camera ray does not meet a catcher first, and where it does the
  lamps the camera sees in front of the catcher alone (alpha 0: a hole; Cycles' Shadow Catcher Matte);
- K (rgb): the caught samples' light in the catcher-only scene (Cycles' Shadow Catcher buffer);
- B (rgb): the world the camera looks at through the caught samples and where it escapes, where the film is not
  transparent (Cycles' Background pass behind the catcher);
- S: how many samples were caught.

The images (`images`): the Shadow Catcher pass is (C - M) / K per channel, the catcher's light with the objects
over its light without them (1 where K is 0 and in pixels no sample caught), laid over white by Combined's alpha:
1 where nothing shadows the catcher, below 1 in shadows, above where a reflection brightens it. Combined becomes the
matte: as it is where the view layer writes the Shadow Catcher pass (the artist multiplies the footage by the pass
and lays the matte over it); otherwise Cycles' approximation (use_approximate_shadow_catcher) puts the shadow in
the matte's alpha, 1 - mean(pass) where the matte is clear, and on an opaque film lays the matte over the
background times 1 - that alpha.

As in Cycles, a sample that met a catcher writes no light passes and no light groups (but for the lamps the camera
sees in front of it): the catcher's light is in the pass. Both kernels follow K's paths the same way: the render's integrator, run again on the caught samples' camera rays
with the catcher-only scene's Context (`catcher_context`; compiled: its ChunkParams, chunk.c), with the same
random numbers (keyed by pixel and sample, as Cycles' split copies the path's state). Left out: a catcher seen
through Transparent surfaces (only a camera ray's first hit splits; Cycles splits where the camera's path through
clear surfaces meets one) and media in the catcher-only scene and in front of a catcher.
"""
from __future__ import annotations

import copy
import dataclasses
from typing import Optional

import numpy as np

from ..native import schema
from ..visibility import EVERY_RAY, SHADOW_CATCHER
from . import clamp as clamp_
from . import lightgroups
from . import passes as passes_
from .base import Context, Recorder
from .rays import lamps_seen, nearest_seen

# The film's sums of the shadow catcher (render.Film aux): M rgba, K rgb, B rgb, S per pixel.
FILM_BUFFER = "shadow_catcher"
FILM_CHANNELS = schema.constant("CATCHER_CHANNELS", 11, "the shadow catcher's film sums: matte RGBA, catcher-only "
                                "RGB, background RGB, caught samples")
PASS_BUFFER = "shadow_catcher"     # the Shadow Catcher pass's image in RenderResult.aux


def catcher_context(ctx: Context, warnings: Optional[list] = None) -> Optional[Context]:
    """The Context of the catcher-only scene of `ctx` (module docstring), or None where no object is a catcher:
    its geometry hides every other object from every ray, the emitters of those objects light no closure, its
    integrator writes no passes, light groups or features, its camera rays see no lamps, and it has no media. What
    it leaves out of Cycles' catchers is said once in `warnings` (where the scene has it)."""
    geometry = ctx.geometry
    if geometry is None or not geometry.hides(SHADOW_CATCHER):
        return None
    notes = []
    if ctx.materials.may_pass.any():
        notes.append("shadow catchers: a catcher seen through a Transparent surface (or an alpha) renders as an "
                     "ordinary object there (Cycles shows only its shadows behind clear surfaces too)")
    if ctx.extra.get("media") is not None:
        notes.append("shadow catchers: the catcher-only light the Shadow Catcher pass divides by leaves the volumes "
                     "out (Cycles keeps the catchers' media), and volumes in front of a catcher go to it, not the matte")
    for note in notes:
        if warnings is not None and note not in warnings:
            warnings.append(note)
    hidden = geometry.instance_hidden
    view = copy.copy(geometry)
    view.instance_hidden = np.where(hidden & SHADOW_CATCHER, hidden, hidden | EVERY_RAY).astype(np.uint8)
    emitters = ctx.extra.get("emitters")
    lights = list(ctx.lights)
    if emitters is not None:
        alone = copy.copy(emitters)
        alone.hidden = emitters_hidden(view, emitters)
        lights = [alone if light is emitters else light for light in lights]
        emitters = alone
    settings = dataclasses.replace(ctx.settings, passes=(), light_groups=(), denoising_features=False, aux=())
    extra = dict(ctx.extra, transparent=True, camera_lamps=[], media=None, emitters=emitters, light_groups=None,
                 pass_layout=passes_.PassLayout((), 1))
    extra.pop("media_bounds", None)
    extra.pop("catcher", None)
    return dataclasses.replace(ctx, settings=settings, geometry=view, lights=lights, extra=extra)


def emitters_hidden(geometry, emitters) -> Optional[np.ndarray]:
    """(t,) uint8 the HIDDEN_FROM_* bits of each emissive triangle's object in `geometry` (emitters.hidden), or
    None where none is hidden."""
    from ..lights.emitters import hidden_bits_of
    return hidden_bits_of(geometry, emitters.prim)


def caught(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray) -> tuple:
    """Which camera rays O, D (n, 3) up to t_max (n,) meet a shadow catcher first, which escape (past objects
    hidden from the camera), and how far each went: (n,) bool, (n,) bool, (n,) float64."""
    found = nearest_seen(ctx, O, D, t_max)
    first = found.hit & ctx.geometry.hidden(np.where(found.hit, found.prim, 0), SHADOW_CATCHER)
    return first, ~found.hit, np.where(found.hit, found.t, t_max)


def sample_rows(ctx: Context, rgba: np.ndarray, traced: np.ndarray, O: np.ndarray, D: np.ndarray, t_max: np.ndarray,
                pixel: np.ndarray, sample: np.ndarray, light=None, groups=None) -> np.ndarray:
    """Each sample's row (n, FILM_CHANNELS) float64 of the film's shadow catcher sums: M, K, B, S (module
    docstring). rgba: (n, 4) the samples' values (C); traced: (k,) int64 the samples with a camera ray; O, D, t_max,
    pixel, sample: those rays' (k, 3), (k, 3), (k,), (k,), (k,). light, groups: those rays' light passes (k, 6, 3)
    and light groups (k, G, 3), or None: as Cycles writes neither from a path that met a catcher, the caught rays'
    are set to nothing, but for the lamps the camera sees in front of the catcher in their groups (changed here)."""
    from . import for_render
    alone = ctx.extra["catcher"]                     # (with this chunk's samples and seed)
    alone = dataclasses.replace(alone, settings=dataclasses.replace(alone.settings, samples=ctx.settings.samples,
                                                                    seed=ctx.settings.seed))
    rows = np.zeros((len(rgba), FILM_CHANNELS))
    rows[:, :4] = rgba
    first, escaped, t = caught(ctx, O, D, t_max)
    held = traced[first]
    rows[held, :4] = 0.0                             # the matte: a hole where the catcher is
    rows[held, 10] = 1.0
    if len(held):
        kept = np.flatnonzero(first)
        # (the lamps the camera sees in front of the catcher stay in the matte, as Cycles writes them before its
        #  split; capped by Clamp Direct as the render caps them)
        tally = lightgroups.tally(ctx, len(kept)) if groups is not None else None
        front = lamps_seen(ctx, O[kept], D[kept], t[kept], tally)
        cap = clamp_.limits(ctx.settings)[0]
        if np.isfinite(cap):
            f = clamp_.scale(front, None, cap)
            front = front * f[:, None]
            if tally is not None:
                tally.scale(f)
        rows[held, :3] = front
        if light is not None:
            light[kept] = 0.0
        if groups is not None:
            groups[kept] = tally.L
        rows[held, 4:7] = for_render(alone).radiance(alone, O[kept], D[kept], t_max[kept], pixel[kept], sample[kept],
                                                     Recorder()).L
    world = ctx.extra.get("world_light")
    if world is not None and world.camera and not ctx.settings.transparent_background:
        behind = first | escaped
        rows[traced[behind], 7:10] = world.radiance_seen(D[behind])
    return rows


def images(sums: np.ndarray, combined: np.ndarray, count: np.ndarray, transparent: bool,
           with_pass: bool) -> tuple:
    """Return (Combined (H, W, 4), the Shadow Catcher pass (H, W, 3)) float32 from the film's shadow catcher sums
    (H, W, FILM_CHANNELS), the render's Combined (H, W, 4: each pixel's mean of C) and its samples per pixel
    count (H, W); transparent: the film is; with_pass: the view layer writes the Shadow Catcher pass (Combined is
    then the matte itself, else Cycles' approximation). Module docstring."""
    n = count.astype(np.float64)[..., None]
    mean = np.divide(sums, n, out=np.zeros_like(sums), where=n > 0)
    matte, K, B, S = mean[..., :4], mean[..., 4:7], mean[..., 7:10], sums[..., 10]
    empty = count == 0                                       # (pixels not rendered keep what the film says)
    C = combined[..., :3].astype(np.float64)
    ratio = np.divide(C - matte[..., :3], K, out=np.ones_like(K), where=K != 0.0)
    ratio = np.where((S > 0)[..., None], ratio, 1.0)
    alpha = combined[..., 3:4].astype(np.float64)
    shadow = (1.0 - alpha) + alpha * ratio                   # laid over white by Combined's alpha
    if with_pass:
        out = matte
    else:
        a = np.clip(matte[..., 3:4], 0.0, 1.0)
        alpha_matte = (1.0 - a) * (1.0 - np.clip(shadow.mean(axis=-1, keepdims=True), 0.0, 1.0)) + a
        if transparent:
            out = np.concatenate([matte[..., :3], alpha_matte], axis=-1)
        else:
            out = np.concatenate([matte[..., :3] + B * (1.0 - alpha_matte), np.ones_like(alpha_matte)], axis=-1)
    out = np.where(empty[..., None], combined, out)
    return np.ascontiguousarray(out, np.float32), np.ascontiguousarray(shadow, np.float32)
