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
random numbers (keyed by pixel and sample, as Cycles' split copies the path's state). A camera ray that goes
straight through purely clear surfaces (every closure a Transparent BSDF: clear_at) to a catcher is caught there, as
Cycles splits a camera path at its first catcher past transparent bounces: what those surfaces let through, T,
makes the matte's alpha 1 - mean(T) (Cycles adds the split path's mean throughput to the matte's transparency) and
multiplies K and B (the split path carries the throughput). Left out: a catcher behind a partly transparent surface
(a Transparent BSDF mixed with other closures, an alpha: rendered as an ordinary object there, said once).

Media, as Cycles 5.0: its volume kernel shades the camera ray's stretch before integrator_split_shadow_catcher, and
the split path goes on from the catcher with a volume stack re-made of the catchers' own media alone
(integrator_volume_stack_init with SHADOW_CATCHER_PATH_VISIBILITY; the world's volume "always assumed to be CG"). So
what the media in front of a caught sample's catcher emit and scatter towards the camera is the matte's (its light
groups and Volume Direct kept), and what they let through multiplies the split path as the clear surfaces' T does
(`front_media`; past a clear surface or a volume's boundary in front of the catcher, the media it leads into add
their emission, in their light groups too, and transmittance the same way, sample_rows); the catcher-only scene keeps
the catcher objects' own media alone (`catcher_media`: the world's left out, the other objects' never entered, for
they are hidden from every ray). Cycles re-makes that stack from the camera ray's origin, so a camera inside a
catcher's own medium starts its split path in it at the catcher, the camera's stretch of it already in the split
path's throughput: the catcher-only scene's camera rays (`catcher_split`, path.py; compiled: ChunkParams.split) cross
no medium to their catcher and go on from it in the catchers' media the camera is in (Whitted's tracer leaves such a
medium out, said once). Left out, said once
(`media_notes`): what media past the camera ray's first surface scatter, and with Volume Bounces what media in front
of a catcher scatter.
"""
from __future__ import annotations

import copy
import dataclasses
from typing import Optional

import numpy as np

from ..native import schema
from ..visibility import EVERY_RAY, SHADOW_CATCHER
from . import clamp as clamp_
from . import lightgroups, lightpasses
from . import passes as passes_
from .base import Context, Recorder
from .rays import lamps_seen, nearest_seen
from .shadows import spawn_ray
from . import shadows
from .. import materials as materials_
from ..geometry.surface import surface_at_hits
from ..materials import graph as graph_
from ..visibility import HOLDOUT
from .. import volumes
from .whitted import WhittedTracing

WHITTED = WhittedTracing.name

# The film's sums of the shadow catcher (render.Film aux): M rgba, K rgb, B rgb, S per pixel.
FILM_BUFFER = "shadow_catcher"
FILM_CHANNELS = schema.constant("CATCHER_CHANNELS", 11, "the shadow catcher's film sums: matte RGBA, catcher-only "
                                "RGB, background RGB, caught samples")
PASS_BUFFER = "shadow_catcher"     # the Shadow Catcher pass's image in RenderResult.aux


def catcher_context(ctx: Context, warnings: Optional[list] = None) -> Optional[Context]:
    """The Context of the catcher-only scene of `ctx` (module docstring), or None where no object is a catcher:
    its geometry hides every other object from every ray, the emitters of those objects light no closure, its
    integrator writes no passes, light groups or features nor Fast GI's added occlusion, its camera rays see no lamps,
    and its media are the catcher objects' own (`catcher_media`: Cycles leaves the world's volume and those of objects
    that are not catchers out). What
    it leaves out of Cycles' catchers is said once in `warnings` (where the scene has it)."""
    geometry = ctx.geometry
    if geometry is None or not geometry.hides(SHADOW_CATCHER):
        return None
    notes = []
    if any(may and not only_clear(shader) for may, shader in zip(ctx.materials.may_pass, ctx.materials.shaders)):
        notes.append("shadow catchers: a catcher seen through a surface that is partly transparent (a Transparent "
                     "BSDF mixed with other closures, an alpha) renders as an ordinary object there (Cycles shows "
                     "only its shadows where the camera path goes through); behind purely Transparent surfaces "
                     "it is caught")
    notes.extend(media_notes(ctx, geometry))
    media, note = catcher_media(ctx, geometry)
    if note:
        notes.append(note)
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
    # (and no Fast GI Add: Cycles' split path, PATH_RAY_SHADOW_CATCHER_PASS, traces no ambient occlusion)
    settings = dataclasses.replace(ctx.settings, passes=(), light_groups=(), denoising_features=False, aux=(),
                                   ao_additive_factor=0.0)
    # (catcher_split: its camera rays go to their catcher through no medium and on from it in the catchers' media
    #  the camera is in, as Cycles' split path, whose throughput already holds the media in front: path.py)
    extra = dict(ctx.extra, transparent=True, camera_lamps=[], media=media, emitters=emitters,
                 light_groups=None, pass_layout=passes_.PassLayout((), 1), catcher_split=True)
    if extra["media"] is None:
        extra.pop("media_bounds", None)     # (else the render's box of the media's triangles holds the catchers')
    extra.pop("catcher", None)
    return dataclasses.replace(ctx, settings=settings, geometry=view, lights=lights, extra=extra)


def catcher_media(ctx: Context, geometry):
    """The media of the catcher-only scene of `ctx` (its `geometry`): the render's without the world's, as Cycles
    re-makes the split path's volume stack of the objects its shadow-catcher visibility sees (the objects that are
    not catchers hidden from every ray there: their media never enter a stack, rays.camera_media passes them), or
    None where no catcher object has a Volume; and a note, or None. A camera inside a catcher's medium is modelled by
    the path tracer (`catcher_split`: its camera rays there cross no medium to the catcher and go on from it in the
    catcher media the camera is in, as Cycles' split path); Whitted's tracer, which has no such start, keeps none of
    them where the camera may be inside one (within the box of their triangles; an orthographic camera's half width
    around it) and says so. Returns (Media or None, str or None)."""
    media = ctx.extra.get("media")
    if media is None or not media.has_medium.any():
        return None, None
    prims = np.flatnonzero(geometry.hidden(np.arange(geometry.triangle_count), SHADOW_CATCHER))
    if len(prims) == 0:
        return None, None
    triangles = geometry.triangle_data(prims, smooth=False)
    mine = media.has_medium[triangles.material]
    if not mine.any():
        return None, None
    if ctx.settings.integrator != WHITTED:
        return media.without_world(), None
    corners = triangles.corners[mine].reshape(-1, 3)
    camera = ctx.extra.get("camera")
    margin = 0.5 * float(camera.ortho_scale) if camera is not None and camera.type == "ORTHO" else 0.0
    eye = -np.asarray(ctx.extra.get("camera_offset", np.zeros(3)), np.float64)
    if ((eye >= corners.min(axis=0) - margin) & (eye <= corners.max(axis=0) + margin)).all():
        return None, ("shadow catchers: with Whitted's tracer, a catcher's own Volume the camera may be inside is "
                      "left out of the catcher-only light the Shadow Catcher pass divides by (Cycles keeps it there "
                      "from the catcher on; the path and direct tracers do); catchers' Volumes away from the camera "
                      "are kept")
    return media.without_world(), None


def media_notes(ctx: Context, geometry) -> list:
    """What Primer leaves out of Cycles' shadow catchers in media (module docstring), one note each: what media
    between a clear surface and the catcher behind it scatter (their emission and transmittance are kept:
    sample_rows), and with Volume Bounces what media in front of a catcher scatter (`chains`)."""
    media = ctx.extra.get("media")
    if media is None:
        return []
    notes = []
    if media.scatters and any(may and only_clear(shader)
                              for may, shader in zip(ctx.materials.may_pass, ctx.materials.shaders)):
        notes.append("shadow catchers: the light scattering volumes send to the camera past a Transparent surface or "
                     "a volume's boundary in front of a catcher goes to the Shadow Catcher pass, not the matte "
                     "(Cycles writes it to the matte; Primer does for the media before the camera ray's first "
                     "surface, and keeps the emission and transmittance of them all)")
    if media.scatters and chains(ctx):
        notes.append("shadow catchers: with Volume Bounces above 0, the light scattering volumes in front of a "
                     "catcher send to the camera goes to the Shadow Catcher pass, not the matte (Cycles writes it "
                     "to the matte; with Volume Bounces 0, or Fast GI's AO Bounces 1, whose paths scatter once in "
                     "front of it, Primer does too); their transmittance is kept")
    return notes


def only_clear(shader) -> bool:
    """Whether a material's shader (MaterialTable.shaders) is nothing but Transparent BSDFs (their colours may be
    linked): no other closure, no emission (a camera path passes it straight through everywhere: clear_at)."""
    if np.asarray(shader.emission).any():
        return False
    nodes = getattr(shader, "nodes", None)
    if nodes is not None:
        return all(node.name == "TRANSPARENT" for node, *_ in nodes)
    kinds = np.asarray(shader.kinds)
    return bool(materials_.has(kinds, materials_.BSDFFlags.STRAIGHT).all())


def emitters_hidden(geometry, emitters) -> Optional[np.ndarray]:
    """(t,) uint8 the HIDDEN_FROM_* bits of each emissive triangle's object in `geometry` (emitters.hidden), or
    None where none is hidden."""
    from ..lights.emitters import hidden_bits_of
    return hidden_bits_of(geometry, emitters.prim)


def clear_at(ctx: Context, O: np.ndarray, D: np.ndarray, found, rows: np.ndarray, passed: np.ndarray) -> tuple:
    """Which hits `rows` (k,) of the camera rays O, D (n, 3) in `found` (their nearest hits) a camera path passes
    straight through, as Cycles' transparent bounces, and what each lets through: surfaces whose every closure is a
    Transparent BSDF (no emission, no holdout, no other closure), after `passed` (k,) such surfaces. Returns
    ((k,) bool, (k, 3) float64 the transparency)."""
    surface = surface_at_hits(ctx.geometry, found.prim[rows], found.u[rows], found.v[rows], O[rows], D[rows],
                              found.t[rows])
    path = graph_.light_paths(len(rows), transparent=passed)
    shader = ctx.materials.shade(surface.material, surface.N, -D[rows], surface, ctx.geometry, path)
    c = shader.closures
    other = (c.kind >= 0) & ~materials_.has(c.kind, materials_.BSDFFlags.STRAIGHT) & (c.weight != 0.0).any(axis=-1)
    clear = ~other.any(axis=1) & (shader.emission == 0.0).all(axis=1)
    if shader.holdout is not None:
        clear &= (shader.holdout == 0.0).all(axis=1)
    clear &= ctx.materials.may_pass[surface.material] & ~ctx.geometry.hidden(found.prim[rows], HOLDOUT)
    return clear, shader.transparency


def caught(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray) -> tuple:
    """Which camera rays O, D (n, 3) up to t_max (n,) meet a shadow catcher first, straight through the clear
    surfaces in front of it (clear_at: Cycles splits a camera path at its first catcher past transparent bounces, up
    to the transparent-bounce limit), which escape at once (past objects hidden from the camera), how far each went
    to its first hit, what the clear surfaces let through to the catcher, and the stretches along which it sees
    lamps: ((n,) bool, (n,) bool, (n,) float64, (n, 3) float64, [(rows (k,), O (k, 3), t (k,), T (k, 3), crossed),
    ...]), crossed None on the first stretch, else the clear surface it starts at (material (k,), backfacing (k,),
    prim (k,): where the media change, media_along)."""
    n = len(O)
    first = np.zeros(n, bool)
    T = np.ones((n, 3))
    found = nearest_seen(ctx, O, D, t_max)
    escaped, t0 = ~found.hit, np.where(found.hit, found.t, t_max)
    stretches = [(np.arange(n), O, t0, T.copy(), None)]
    rows, O_now, passed = np.arange(n), O, np.zeros(n, np.int64)
    # (Whitted's tracer sees no Transparent surface through: its camera rays end at the first hit)
    limit = ctx.settings.transparent_max_bounces if ctx.settings.integrator != WHITTED else 0
    while len(rows):
        hit = found.hit
        at_catcher = hit & ctx.geometry.hidden(np.where(hit, found.prim, 0), SHADOW_CATCHER)
        first[rows[at_catcher]] = True
        more = np.flatnonzero(hit & ~at_catcher & ctx.materials.may_pass[
            ctx.geometry.triangle_data(np.where(hit, found.prim, 0), smooth=False).material] & (passed + 1 < limit))
        if len(more) == 0:
            break
        clear, transparency = clear_at(ctx, O_now, D[rows], found, more, passed[more])
        more, transparency = more[clear], transparency[clear]
        T[rows[more]] *= transparency
        more = more[(T[rows[more]] > 0.0).any(axis=1)]
        if len(more) == 0:
            break
        surface = surface_at_hits(ctx.geometry, found.prim[more], found.u[more], found.v[more], O_now[more],
                                  D[rows[more]], found.t[more])
        O_now = spawn_ray(surface.I, surface.Ng, D[rows[more]], shadows.error_bound(surface.I, surface.vertices))
        rows, passed = rows[more], passed[more] + 1
        gone = np.einsum("ij,ij->i", O_now - O[rows], D[rows])        # (the camera's clipping end stays)
        found = nearest_seen(ctx, O_now, D[rows], t_max[rows] - gone)
        stretches.append((rows, O_now, np.where(found.hit, found.t, np.inf), T[rows].copy(),
                          (surface.material, surface.backfacing, surface.prim)))
    return first, escaped, t0, T, stretches


def sample_rows(ctx: Context, rgba: np.ndarray, traced: np.ndarray, O: np.ndarray, D: np.ndarray, t_max: np.ndarray,
                pixel: np.ndarray, sample: np.ndarray, light=None, groups=None) -> np.ndarray:
    """Each sample's row (n, FILM_CHANNELS) float64 of the film's shadow catcher sums: M, K, B, S (module
    docstring). rgba: (n, 4) the samples' values (C); traced: (k,) int64 the samples with a camera ray; O, D, t_max,
    pixel, sample: those rays' (k, 3), (k, 3), (k,), (k,), (k,). light, groups: those rays' light passes (k, 8, 3)
    and light groups (k, G, 3), or None: as Cycles writes neither from a path that met a catcher, the caught rays'
    are set to nothing, but for the lamps the camera sees in front of the catcher in their groups (changed here)."""
    from . import for_render
    alone = ctx.extra["catcher"]                     # (with this chunk's samples and seed)
    alone = dataclasses.replace(alone, settings=dataclasses.replace(alone.settings, samples=ctx.settings.samples,
                                                                    seed=ctx.settings.seed))
    rows = np.zeros((len(rgba), FILM_CHANNELS))
    rows[:, :4] = rgba
    first, escaped, t, through, stretches = caught(ctx, O, D, t_max)
    held = traced[first]
    rows[held, :4] = 0.0
    rows[held, 10] = 1.0
    if len(held):
        kept = np.flatnonzero(first)
        # (the lamps the camera sees in front of the catcher stay in the matte, as Cycles writes them before its
        #  split, each through the clear surfaces before it; capped by Clamp Direct as the render caps them)
        tally = lightgroups.tally(ctx, len(kept)) if groups is not None else None
        front = np.zeros((len(kept), 3))
        where = np.full(len(O), -1, np.int64)
        where[kept] = np.arange(len(kept))
        # (the media along the camera ray up to its first hit, as the render's own camera ray crosses them: their
        #  emission and scattering are written before Cycles' split, to the matte; what they let through is in the
        #  split path's throughput)
        media_front = front_media(ctx, O[kept], D[kept], t[kept], pixel[kept], sample[kept])
        # (and past each clear surface in front of the catcher, the media it leads into: what they emit, and what
        #  they let through, times what comes before)
        passed_media = np.ones((len(O), 3))
        inside = None
        if media_front is not None:
            inside = np.zeros((len(O),) + media_front.inside.shape[1:], media_front.inside.dtype)
            inside[kept] = media_front.inside
        for number, (stretch_rows, O_s, t_s, T_s, crossed) in enumerate(stretches):
            mine = where[stretch_rows] >= 0
            if not mine.any():
                continue
            index, mine_rows = where[stretch_rows[mine]], stretch_rows[mine]
            sigma = None
            if media_front is not None and number == 0:
                sigma = media_front.stretch
            elif media_front is not None:
                media = ctx.extra["media"]
                material, backfacing, prim = (x[mine] for x in crossed)
                inside[mine_rows] = media.crossed(inside[mine_rows], material, backfacing, np.ones(len(index), bool),
                                                  media.objects_of(ctx.geometry, prim))
                sigma = media.along(inside[mine_rows], O_s[mine], D[mine_rows])
            before = T_s[mine] * passed_media[mine_rows]
            part = lightgroups.tally(ctx, len(index)) if tally is not None else None
            front[index] += before * lamps_seen(ctx, O_s[mine], D[mine_rows], t_s[mine], part, sigma=sigma)
            if part is not None:
                tally.add_rows(index, part, before)
            if sigma is not None:
                if number > 0:                   # (in the group of the medium it glows in, as the first stretch's)
                    glow = before * volumes.emitted(sigma, t_s[mine])
                    front[index] += glow
                    lightgroups.add_emitted(tally, index, glow, sigma)
                passed_media[mine_rows] *= sigma.transmittance(t_s[mine])
        if media_front is not None:
            front += media_front.emitted
            lightgroups.add_emitted(tally, np.arange(len(kept)), media_front.emitted, media_front.stretch)
        cap = clamp_.limits(ctx.settings)[0]
        if np.isfinite(cap):
            f = clamp_.scale(front, None, cap)
            front = front * f[:, None]
            if tally is not None:
                tally.scale(f)
        if media_front is not None:              # (what they scatter: not clamped, as the render's)
            front += media_front.scattered
            if tally is not None and media_front.groups is not None:
                tally.L += media_front.groups.L
            through[kept] *= passed_media[kept]
        # the matte: a hole where the catcher is, as opaque as the clear surfaces and media in front of it are not
        # (Cycles adds the split path's mean throughput to the matte's transparency)
        rows[held, 3] = 1.0 - through[kept].mean(axis=1)
        rows[held, :3] = front
        if light is not None:
            light[kept] = 0.0
            if media_front is not None:          # (what the media in front scatter: Volume Direct, before the split)
                light[kept, lightpasses.VOLUME] += media_front.scattered
        if groups is not None:
            groups[kept] = tally.L
        # (the catcher-only light, through the clear surfaces in front of the catcher: Cycles' split path carries
        #  the camera path's throughput)
        rows[held, 4:7] = through[kept] * for_render(alone).radiance(alone, O[kept], D[kept], t_max[kept],
                                                                       pixel[kept], sample[kept], Recorder()).L
    world = ctx.extra.get("world_light")
    if world is not None and world.camera and not ctx.settings.transparent_background:
        behind = first | escaped
        seen = world.radiance_seen(D[behind])
        rows[traced[behind], 7:10] = seen * np.where(first[behind, None], through[behind], 1.0)
    return rows


@dataclasses.dataclass
class FrontMedia:
    """What the media along caught camera rays send to the camera in front of their first hit (k rows):
    stretch: the rays' core/volumes Stretch; emitted, scattered: (k, 3) float64 their emission (as the render's camera
    ray gathers it) and their scattering (the render's estimate, same random numbers); T: (k, 3) float64 what they
    let through to the hit (the render's throughput there); groups: the scattered light by light group
    (lightgroups.GroupLight) or None; inside: (k, V) the media the rays start in (rays.camera_media)."""
    stretch: object
    emitted: np.ndarray
    scattered: np.ndarray
    T: np.ndarray
    groups: object = None
    inside: Optional[np.ndarray] = None


def front_media(ctx: Context, O: np.ndarray, D: np.ndarray, t: np.ndarray, pixel: np.ndarray,
                sample: np.ndarray) -> Optional[FrontMedia]:
    """The media in front of the first hits, at distances t (k,), of caught camera rays O, D (k, 3) of samples
    `sample` of pixels `pixel` (k,): a FrontMedia, as path.PathTracing.radiance computes them for those rays (so the
    same values), or None without media. Cycles shades them before it splits the path at the catcher (its volume
    kernel runs before integrator_split_shadow_catcher), so they belong to the matte. With Volume Bounces
    (volume.multiple_scattering: `chains`) their scattering is left out (said once: catcher_context)."""
    media = ctx.extra.get("media")
    if media is None:
        return None
    from . import volume as volume_
    from .path import through_transparent
    from .rays import camera_media
    from .vertex import fast_gi_scatter
    from .. import volumes
    k = len(O)
    inside = camera_media(ctx, O)
    stretch = media.along(inside, O, D)
    scattered = np.zeros((k, 3))
    groups = lightgroups.tally(ctx, k)
    if media.scatters and not chains(ctx):
        scattered, _ = volume_.in_scattering(ctx, O, D, t, inside, np.ones((k, 3)), pixel, sample, 0, 0,
                                             through_transparent, None, groups, fast_gi_scatter(ctx.settings, k))
    return FrontMedia(stretch, volumes.emitted(stretch, t), scattered, stretch.transmittance(t), groups, inside)


def chains(ctx: Context) -> bool:
    """Whether the render's camera paths go on from where they scatter in media (Volume Bounces: path.py's
    `onward`, chunk.c's `chains`)."""
    from . import for_render
    integrator = for_render(ctx)
    from . import volume as volume_
    # (not where a camera ray's scattering event sends Fast GI's short phase ray: volume.volume_bounces_left)
    return (ctx.settings.integrator == "path" and not getattr(integrator, "direct_only", False)
            and volume_.volume_bounces_left(ctx, 0, 0))


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
