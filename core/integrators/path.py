"""Path tracing: light that reaches the camera after any number of bounces, as the lecture's next part
("Ray Tracing (3)") and Cycles compute it.

The rendering equation says the light leaving a point is what it emits plus what it reflects of the
light arriving from every direction, and that arriving light is itself light leaving another point:

    L(x, wo) = L_e(x, wo) + integral of f(wo, wi) L(x', -wi) cos(N, wi) dwi

A path estimates it with one direction per bounce. At every vertex (every hit along the path) it does
what the lecture's direct-lighting tracer does at the camera's hit (core/integrators/direct.py): light
samples with shadow rays, and one direction sampled from the BSDF that finds lamps, emitters and the
world, the two weighed by multiple importance sampling (the lecture's `Mis2`). That BSDF direction
is also where the path goes on: the surface it hits is the next vertex, seen through the path's
throughput, the product of f cos / pdf of every bounce so far.

    L += throughput x (what the vertex gathers);   throughput *= f cos / pdf of the sampled direction

Bounces are counted as in Cycles: after `max_bounces` bounces (and `diffuse_bounces` after diffuse
ones, `glossy_bounces` after glossy or mirror reflections, `transmission_bounces` after refractions) the
last BSDF ray still brings back the light it finds, but the
surface it hits does no more. From the third vertex on, Russian roulette ends a path with probability
1 - q and divides the throughput of those that go on by q: unbiased, cheaper, noisier (from where Cycles starts
it: after Min Light Bounces + 1 bounces, min_light_bounces in RenderSettings). Cycles' q is min(sqrt(t), 1), t the
largest channel of the throughput; Primer's is min(max(sqrt(t), 4 t), 1) (`survival`): never below Cycles', and 1
while the path carries a quarter of the camera's light or more, where a path ended would cost more noise than its
rest of the path costs time (measured in docs/performance.md).

Two of Cycles' Light Paths settings trade correctness for less noise, with Cycles' meaning: the caustics
switches (caustics_reflective, caustics_refractive) leave glossy reflection and refraction out of the
closures of a hit that a diffuse bounce's ray reached (the light of caustics, focused by a mirror or a
glass, then never reaches a diffuse surface), and sample clamping (core/integrators/clamp.py) caps
each contribution.

Cycles' Fast GI Approximation (Replace; RenderSettings ao_bounces, ao_factor, ao_distance) shortens the rest: past
ao_bounces bounces (vertex.fast_gi_ray) a path's ray looks ao_distance far, the world it escapes to counts ao_factor
times, and the surface it meets ends the path (its emission gathered, its transparent surfaces looked through, as past
the bounce limits): ambient occlusion in place of the light of later bounces. In media, as Cycles: the media along a
short ray only absorb and emit, one that meets nothing leaves the meshes' media (the world's kept), and a scattering
event counts as a bounce, so the phase rays of scattering points past AO Bounces are short too (volume.py).

Object > Visibility as Cycles reads it: every ray has a kind (camera; after a bounce diffuse, glossy or
transmission, rays.ray_kind; straight through a Transparent closure the kind it had) and passes the objects
hidden from that kind (Ray Visibility). A holdout object met by a camera path is a hole in the film
(hold_out): its colour is not added and the pixel's alpha loses the share the object covers; a Holdout shader
node is such a hole in proportion to its weight, the rest of the material shading as usual.

Through participating media (core/volumes) every stretch of a path keeps exp(-sigma_t t) of its light (Beer-Lambert),
each ray carrying its volume stack (the media it is in, changed where it goes through a surface with a medium), and
the media's scattering adds, on each stretch the path may still bounce on, one single-scattering estimate
(core/integrators/volume.py: free-flight and equi-angular points, light samples and a phase-sampled ray), as Cycles
renders with Volume Bounces 0; volume-only boundaries are crossed without counting a transparent bounce.

With max_bounces = 0 a path is the direct-lighting tracer at the camera's hit, except that every hit
traces its BSDF ray (the direct tracer skips it where light samples alone do well).
Its compiled twin is the same loop in core/integrators/chunk.c (INTEGRATOR_PATH).
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .. import materials as materials_
from ..native import schema
from ..materials import graph as graph_
from ..materials.closures import FILTER_REFLECTIVE, FILTER_REFRACTIVE
from .. import vectors, volumes
from ..geometry.surface import surface_at_hits
from ..sampling import sobol as sampling
from .base import Context, Integrator, Radiance, Recorder, check_stop
from . import clamp as clamp_
from . import mnee as mnee_
from . import features as features_
from . import lightgroups, lightpasses, shader_rays
from . import passes as passes_
from . import shadows
from . import subsurface as subsurface_
from . import volume as volume_
from .rays import camera_back, camera_cones, camera_hits, camera_media, goes_through, nearest_seen
from .shadows import spawn_ray
from .vertex import VERTEX_DIMENSIONS, PathState, fast_gi_scatter, gather_light, shade_vertex, short_ray_lengths
from ..visibility import HIDDEN_FROM_CAMERA, HIDDEN_FROM_VOLUME_SCATTER, HOLDOUT

# The most volume-only boundaries a path or a shadow ray crosses (Cycles' VOLUME_BOUNDS_MAX: a guard against a ray
# caught crossing the same boundary, as those crossings count as no transparent bounce).
VOLUME_BOUNDS_MAX = shadows.VOLUME_BOUNDS_MAX
# The dimension of Russian roulette's number at a vertex (before the shift).
ROULETTE_DIMENSION = schema.constant("ROULETTE_DIMENSION", 6, "Russian roulette's dimension at a vertex")
# Russian roulette keeps a path with at least ROULETTE_KEEP x its throughput (at most 1; never less than Cycles' sqrt).
ROULETTE_KEEP = schema.constant("ROULETTE_KEEP", 4.0, "Russian roulette's q is at least this times the throughput")


def survival(carried: np.ndarray) -> np.ndarray:
    """Russian roulette's probability q (k,) float64 that a path carrying `carried` (k, 3) float64 goes on:
    min(max(sqrt(t), ROULETTE_KEEP t), 1), t = max |carried| over the channels. Cycles' q is min(sqrt(t), 1); this
    one is never below it and keeps every path that carries 1 / ROULETTE_KEEP of the light or more."""
    t = np.abs(carried).max(axis=1)
    return np.minimum(np.maximum(np.sqrt(t), ROULETTE_KEEP * t), 1.0)


def roulette_from(settings) -> int:
    """The first vertex where Russian roulette may end a path (Cycles: bounce > Min Light Bounces + 1)."""
    return settings.min_light_bounces + 2


# A path's counters that volume.multiple_scattering carries along the chains of scattering events it follows.
COUNTERS = ("bounce", "volume", "diffuse", "glossy", "transmission", "transparent", "portal", "bounds")


def with_arrivals(ctx: Context, state: dict, where: tuple, arrivals: dict, owner_of: np.ndarray,
                  cone_of: np.ndarray, spread_of: np.ndarray) -> tuple:
    """The next vertices' path state `state` (name -> (k, ...) array: owner, throughput, the counters, flags, the
    MIS origin...) with the paths that scattered in media and reached a surface (volume.multiple_scattering's
    `arrivals`, whose origin rows owner_of (r,) maps to camera rays) appended, and the Surface of them all.
    where: (prim, u, v, O, D, t) of the k hits the state has. cone_of, spread_of (r,): the ray cones of the origin
    rows' rays; a scattering point has no footprint and its ray keeps the spread (Cycles: dP 0, dD kept), an unknown
    cone stays unknown."""
    a = len(arrivals["origin"])
    unknown = cone_of[arrivals["origin"]] < 0.0
    extra = dict(owner=owner_of[arrivals["origin"]], throughput=arrivals["throughput"],
                 flags=np.full(a, graph_.PATH["volume_scatter"], np.int64), mis_pdf=arrivals["pdf"],
                 mis_origin=arrivals["O"], mis_normal=np.zeros((a, 3)), mis_receiver=np.full(a, -1, np.int64),
                 after_diffuse=np.zeros(a, bool), seen_by=np.full(a, HIDDEN_FROM_VOLUME_SCATTER, np.int64),
                 inside=arrivals["inside"],
                 looking=np.zeros(a, bool), feature_throughput=np.ones((a, 3)), wo=-arrivals["D"],
                 cone=np.where(unknown, graph_.UNKNOWN_CONE, 0.0),
                 spread=np.where(unknown, 0.0, spread_of[arrivals["origin"]]),
                 min_pdf=arrivals.get("min_pdf", arrivals["pdf"]), **{name: arrivals[name] for name in COUNTERS})
    out = {}
    for name, value in state.items():
        if value is None:
            out[name] = None
        elif name == "shares":
            # (the light passes' shares of the paths that scattered: lightpasses.stretch_shares, or none)
            out[name] = np.concatenate([value, arrivals.get("shares", np.zeros((a,) + value.shape[1:]))])
        else:
            out[name] = np.concatenate([np.asarray(value), np.asarray(extra[name]).astype(np.asarray(value).dtype)])
    hits = arrivals["hits"]
    prim, u, v, O, D, t = (np.concatenate([x, y]) for x, y in zip(where, (hits.prim, hits.u, hits.v, arrivals["O"],
                                                                          arrivals["D"], hits.t)))
    surface = surface_at_hits(ctx.geometry, prim, u, v, O, D, t, flat_only=not ctx.settings.smooth_normals)
    return out, surface


def bounce_kind(kind: np.ndarray, transmit: np.ndarray) -> tuple:
    """Which bounces are diffuse, glossy (a rough or mirror reflection), transmission (through the surface:
    rays.goes_through) and transparent (straight through a Transparent closure, not counted as a bounce), as
    Cycles' path_state_next counts them by the sampled closure's flags; and which were labelled diffuse (the
    caustics switches apply after those): five (k,) bool arrays. kind (k,) int the sampled closures' BSDF
    kinds (-1: none); transmit (k,) bool whether each ray went through the face."""
    F = materials_.BSDFFlags
    flags = materials_.flags_of(kind)
    transparent = (flags & F.STRAIGHT) != 0
    labelled_diffuse = (flags & F.DIFFUSE) != 0
    through = goes_through(kind, transmit) & ~transparent & (kind >= 0)
    reflected = ~through & ~transparent & (kind >= 0)
    return reflected & labelled_diffuse, reflected & ~labelled_diffuse, through, transparent, labelled_diffuse


def caustics_bits(settings) -> int:
    """The closures.FILTER_* bits Cycles' caustics switches set at hits a diffuse bounce's ray reaches:
    reflective closures away with Reflective Caustics off, light through glass with Refractive Caustics off."""
    return ((0 if settings.caustics_reflective else FILTER_REFLECTIVE)
            | (0 if settings.caustics_refractive else FILTER_REFRACTIVE))


def filter_glossy_roughness(filter_glossy: float, min_pdf: np.ndarray):
    """Cycles' Filter Glossy at hits that paths reached after bounces of smallest pdf min_pdf (m,) float64 (inf: none
    yet): the roughness alpha (m,) float64 their microfacet lobes are raised to, 0.5 sqrt(1 - min_pdf / filter_glossy)
    where min_pdf < filter_glossy, else 0; None where the setting is off (0). A path that bounced off a diffuse
    surface (pdf cos / pi, at most 1 / pi) sees every glossy lobe after it at least that rough: less noise from
    the light of small bright things seen in them, and a blurred image of them (Cycles' surface_shader_prepare_closures,
    shader_bsdf_blur)."""
    if not filter_glossy > 0.0:
        return None
    with np.errstate(invalid="ignore"):
        ratio = np.asarray(min_pdf, np.float64) / filter_glossy
        return np.where(ratio < 1.0, 0.5 * np.sqrt(np.clip(1.0 - ratio, 0.0, 1.0)), 0.0)


def caustics_filter(settings, after_diffuse: np.ndarray):
    """The caustics filter bits (k,) int of hits that rays reached, or None: caustics_bits where the path's
    last real bounce was diffuse (after_diffuse (k,) bool), 0 elsewhere."""
    bits = caustics_bits(settings)
    if bits == 0 or not after_diffuse.any():
        return None
    return np.where(after_diffuse, bits, 0)


def is_ao_closure(kind: np.ndarray) -> np.ndarray:
    """Whether closures of kind `kind` (int, any shape) take Fast GI's Add term: bool, kind's shape. Cycles'
    surface_shader_ao takes the closures whose type is CLOSURE_IS_BSDF_DIFFUSE (Diffuse, Oren-Nayar, Burley, Sheen,
    Diffuse Toon, Translucent): BSDFFlags.DIFFUSE_TYPE, less the BSSRDFs (which carry it for the light passes); the
    diffuse *label* does not decide (the Ashikhmin velvet is labelled diffuse but of the glossy type: no AO)."""
    F = materials_.BSDFFlags
    return materials_.has(kind, F.DIFFUSE_TYPE) & ~materials_.has(kind, F.SUBSURFACE)


def fast_gi_added(ctx: Context, surface, shader, pixel: np.ndarray, sample: np.ndarray, dimension: int) -> np.ndarray:
    """Fast GI's Add method at the m hits of `surface` with `shader` (pixel, sample (m,) int64 their keys): the light
    (m, 3) float64 each adds to Combined, alpha x the sum of its diffuse-type closures' weights (is_ao_closure) x
    ao_additive_factor where
    one cosine-distributed ray about their weighted normal (sum of N |mean weight|, the shading normal where none)
    escapes within ao_distance (times the transparency of the surfaces it passes: passes.ambient_occlusion), as
    Cycles' integrate_surface_ao and surface_shader_ao; zero with the setting off (0) or an integrator other than
    path."""
    s = ctx.settings
    m = len(surface.I)
    added = np.zeros((m, 3))
    factor = getattr(s, "ao_additive_factor", 0.0)
    if not factor or s.integrator != "path" or m == 0:
        return added
    closures = shader.closures
    weight, normal = np.zeros((m, 3)), np.zeros((m, 3))
    for slot in range(closures.kind.shape[1]):
        diffuse = is_ao_closure(closures.kind[:, slot])
        w = np.where(diffuse[:, None], closures.weight[:, slot], 0.0)
        weight += w
        normal += np.abs(w.mean(axis=1))[:, None] * closures.N[:, slot]
    rows = np.flatnonzero((weight != 0.0).any(axis=1))
    if len(rows) == 0:
        return added
    length = np.linalg.norm(normal[rows], axis=1, keepdims=True)
    N = np.where(length > 0.0, normal[rows] / np.where(length > 0.0, length, 1.0), surface.N[rows])
    T = passes_.ambient_occlusion(ctx, surface.I[rows], surface.Ng[rows], surface.vertices[rows], N, pixel[rows],
                                  sample[rows], dimension)
    alpha = np.clip(1.0 - shader.transparency[rows], 0.0, 1.0)
    added[rows] = alpha * T * (weight[rows] * factor)
    return added


def hit_materials(ctx: Context, ray, rows: np.ndarray) -> np.ndarray:
    """The material rows (k,) int of the surfaces the BSDF rays `rows` of `ray` hit."""
    return ctx.geometry.triangle_data(ray.hits.prim[rows], smooth=False).material


def through_transparent(ctx: Context, ray, rows: np.ndarray, weight: np.ndarray, passed: np.ndarray,
                        limit=np.inf, groups=None, ao=None) -> np.ndarray:
    """The light (k, 3) behind the transparent surfaces that the ended paths' last rays (`rows` of the BsdfRay
    `ray`, carrying `weight` (k, 3), after `passed` (k,) clear surfaces) meet: each surface multiplies by its
    transparency and the ray goes straight on, finding lamps, emission and the world as a BSDF ray does, weighed
    by MIS with the pdf of the path's last real bounce and the light pdfs measured from that bounce (ray.mis_O,
    ray.mis_N: Cycles' mis_origin); up to the transparent-bounce limit. Each find is capped at `limit` (scalar or
    (k,), sample clamping). Nothing where BSDF rays gather nothing (light_sampling "light", as bsdf_ray). groups: a
    lightgroups.GroupLight of the k rows that receives the light found by the group of its source, or None. ao: (k,)
    bool the rows that are Fast GI's short rays (vertex.fast_gi_ray), or None: past each surface such a ray looks
    ao_distance far again, and the world it escapes to is scaled by ao_factor (Cycles' tmax at every intersect)."""
    s = ctx.settings
    found = np.zeros((len(rows), 3))
    if s.light_sampling == "light" or not ctx.extra.get("bsdf_rays", False):
        return found                             # light samples alone: the BSDF ray found nothing either
    O, D, pdf = ray.O[rows], ray.D[rows], ray.pdf[rows]
    mis_O, mis_N = ray.mis_O[rows], ray.mis_N[rows]
    prim, u, v, t = ray.hits.prim[rows], ray.hits.u[rows], ray.hits.v[rows], ray.hits.t[rows]
    times = None if ray.hits.time is None else ray.hits.time[rows]     # (object motion blur: the paths' times)
    T, passed = weight.copy(), passed.copy()
    mis = (s.light_sampling == "mis") and bool(ctx.extra.get("bsdf_rays", False))
    media = ctx.extra.get("media") if ray.inside is not None else None
    inside = None if media is None else ray.inside[rows]
    paths = graph_.paths_at(ray.path, rows)       # (each surface passed: one more transparent one)
    alive = np.arange(len(rows))
    while len(alive):
        # 1. The surface met: what it lets through, seen along the ray.
        surface = surface_at_hits(ctx.geometry, prim, u, v, O, D, t, times=times)
        path = graph_.paths_at(paths, alive)._replace(transparent=passed[alive])
        shader = ctx.materials.shade(surface.material, surface.N, -D, surface, ctx.geometry, path)
        T[alive] *= shader.transparency
        # (a volume-only boundary is no transparent bounce; an array, as ~False is -1)
        boundary = np.zeros(len(alive), bool) if media is None else media.boundary[surface.material]
        passed[alive] += ~boundary
        if media is not None:                    # (straight through the surface: into or out of its medium)
            inside[alive] = media.crossed(inside[alive], surface.material, surface.backfacing,
                                          np.ones(len(alive), bool), media.objects_of(ctx.geometry, surface.prim))
        go = ((T[alive] > 0.0).any(axis=1) & (passed[alive] <= s.transparent_max_bounces)
              & ctx.materials.may_pass[surface.material])
        alive, I, Ng, D = alive[go], surface.I[go], surface.Ng[go], D[go]
        times = None if times is None else times[go]
        if len(alive) == 0:
            break
        # 2. On from just past it, straight ahead, gathering what the ray finds.
        O = spawn_ray(I, Ng, D, shadows.error_bound(I, surface.vertices[go]))
        short = None if ao is None else ao[alive]
        t_max = (np.full(len(alive), np.inf) if ao is None     # (from the surface passed: its object's own)
                 else short_ray_lengths(ctx, surface.prim[go], short))
        hits = nearest_seen(ctx, O, D, t_max, ray.seen_as[rows][alive], times)
        found_groups = lightgroups.GroupLight(groups.groups, len(alive)) if groups is not None else None
        stretch = None
        if media is not None:                    # (a short ray that meets nothing keeps the world's medium alone)
            stretch = media.along(inside[alive] if short is None
                                  else np.where((short & ~hits.hit)[:, None], 0, inside[alive]), O, D)
        light = T[alive] * gather_light(ctx, O, D, hits, pdf[alive], mis & np.isfinite(pdf[alive]),
                                        N=mis_N[alive], mis_O=mis_O[alive], groups=found_groups,
                                        seen_as=ray.seen_as[rows][alive], stretch=stretch,
                                        paths=graph_.paths_at(paths, alive)._replace(transparent=passed[alive]),
                                        receiver=None if ray.receiver is None else ray.receiver[rows][alive],
                                        t_max=t_max, ao=short)
        f = clamp_.scale(light, None, limit if np.ndim(limit) == 0 else limit[alive])
        found[alive] += light * f[:, None]
        if groups is not None:                   # (the same weight: T up to this stretch's start)
            groups.add_rows(alive, found_groups, T[alive] * f[:, None])
        if media is not None:                    # (and what reaches the next surface)
            T[alive] *= stretch.transmittance(np.where(hits.hit, hits.t, np.inf))
        # 3. The rays that met another surface go on.
        more = hits.hit
        alive, O, D = alive[more], O[more], D[more]
        prim, u, v, t = hits.prim[more], hits.u[more], hits.v[more], hits.t[more]
        times = None if times is None else times[more]
    return found


def hold_out(ctx: Context, surface, shader, camera_path: np.ndarray) -> tuple:
    """Holdouts at a path's vertices, as Cycles: where a camera path (the camera ray, and its ray on through
    Transparent closures: `camera_path` (m,) bool) meets a holdout, that part of the surface is a hole in the film.

    A holdout object (Object > Visibility > Holdout) takes away the share 1 - transparency of the pixel's alpha
    (times the path's throughput, which the caller applies) and leaves the shader nothing but its Transparent
    closures: no emission, no light, and the path goes on only through what the object lets through. A Holdout
    shader node takes away its own weight w (shader.holdout, after the Mix and Add Shaders above it) and the other
    closures keep theirs (a Diffuse mixed 50/50 with a Holdout still shades with 0.5); where w is exactly 1 the
    path stops there (no closures, no emission). Every other ray sees neither: an ordinary object, and a Holdout
    node that reflects and emits nothing.

    Returns (the shader with the holdouts' closures taken away, the holdout weight (m, 3) float64: 1 - transparency
    at holdout objects', the Holdout nodes' weight at other hits of camera paths, 0 elsewhere)."""
    obj = camera_path & ctx.geometry.hidden(surface.prim, HOLDOUT)
    node = np.zeros((len(camera_path), 3)) if shader.holdout is None else shader.holdout
    node = np.where((camera_path & ~obj)[:, None], node, 0.0)
    weight = np.where(obj[:, None], 1.0 - shader.transparency, node)
    stop = (node == 1.0).all(axis=1)                 # a whole Holdout (Cycles: the holdout weight equals one)
    if not (obj.any() or stop.any()):
        return shader, weight
    c = shader.closures
    gone = (obj[:, None] & ~materials_.has(c.kind, materials_.BSDFFlags.STRAIGHT)) | stop[:, None]
    closures = c._replace(kind=np.where(gone, -1, c.kind).astype(c.kind.dtype),
                          weight=np.where(gone[..., None], 0.0, c.weight),
                          sample_weight=np.where(gone, 0.0, c.sample_weight))
    return shader._replace(closures=closures, emission=np.where((obj | stop)[:, None], 0.0, shader.emission)), weight


class PathTracing(Integrator):
    """Unidirectional path tracing with next-event estimation, MIS and Russian roulette (module docstring)."""

    name: ClassVar[str] = "path"

    def __init__(self, direct_only: bool = False):
        """direct_only: no bounces at all, only transparent ones (the direct tracer through transparent surfaces)."""
        self.direct_only = direct_only

    def radiance(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                 sample: np.ndarray, recorder: Recorder, times=None) -> Radiance:
        """Integrator.radiance; times: (n,) the camera rays' times in the shutter when objects move (object motion
        blur: every ray of a path, bounces and shadow rays, meets them where they are at its camera ray's time, as
        in Cycles; the surfaces carry it on), or None."""
        s = ctx.settings
        # 1. The camera rays: what they hit, the world where they escape, the lamps they pass.
        direct_cap, indirect_cap = clamp_.limits(s)
        groups = lightgroups.tally(ctx, len(O))
        # The media the camera rays start in (core/volumes): the world's, and those of the meshes around the camera.
        media = ctx.extra.get("media")
        inside = None if media is None else camera_media(ctx, O)
        at_hit = inside
        if media is not None and ctx.extra.get("catcher_split", False):
            # (the shadow catchers' catcher-only scene, catcher.py: the render's camera path brought these rays to
            #  their catcher through the media in front of it, and Cycles' split path goes on from there with the
            #  stack of the catchers' media the camera is in; so its camera rays cross no medium on the way)
            inside = media.start(len(O))
        stretch = None if media is None else media.along(inside, O, D)
        L_out, found, hit, surface = camera_hits(ctx, O, D, t_max, recorder, direct_cap, groups, stretch, times)
        # The denoising features (features.py): what the camera sees itself (not what the media scatter towards it),
        # the media in front of it, then along each path.
        feats = features_.Features(len(O)) if s.denoising_features else None
        if feats is not None:
            feats.albedo += L_out
            if stretch is not None:
                features_.in_media(feats, stretch, np.where(found.hit, found.t, t_max), camera_back(ctx))
        shadow_rays = 0
        scatters = media is not None and media.scatters
        # With Volume Bounces, paths go on from where they scatter (volume.multiple_scattering).
        onward = scatters and s.volume_bounces > 0 and not self.direct_only
        camera_through = arrivals = None
        # The light passes (core/integrators/lightpasses.py): each camera ray's contributions by pass. What the media
        # scatter along the camera rays is Volume Direct at their first scattering event, Volume Indirect after it.
        light = np.zeros((len(O), len(lightpasses.LIGHT_PASSES), 3)) if lightpasses.wanted(s.passes) else None
        if onward and volume_.volume_bounces_left(ctx, 0, 0):
            zero = np.zeros(len(O), np.int64)
            counters = {name: zero for name in COUNTERS}
            events = {} if light is not None else None
            scattered, shadow_rays, camera_through, arrivals = volume_.multiple_scattering(
                ctx, O, D, np.where(found.hit, found.t, t_max), inside, np.ones((len(O), 3)), pixel, sample, 0,
                counters, through_transparent, events, groups)
            L_out += scattered
            if light is not None:
                everyone, volume_only = np.arange(len(O)), lightpasses.volume_shares(len(O))
                lightpasses.add_scattered(light, everyone, events["first"], zero, volume_only, True)
                lightpasses.add_scattered(light, everyone, events["later"], zero, volume_only, False)
                if arrivals is not None:
                    arrivals["shares"] = lightpasses.volume_shares(len(arrivals["origin"]))
        elif scatters:
            # The light the media scatter towards the camera along its rays (core/integrators/volume.py).
            scattered, shadow_rays = volume_.in_scattering(ctx, O, D, np.where(found.hit, found.t, t_max), inside,
                                                           np.ones((len(O), 3)), pixel, sample, 0, 0,
                                                           through_transparent, recorder, groups,
                                                           fast_gi_scatter(s, len(O)))
            L_out += scattered
            if light is not None:
                light[:, lightpasses.VOLUME] += scattered
        # The first-hit passes (passes.py): what the camera rays pass and escape to, then along their camera chains.
        data = passes_.DataPasses.of(ctx, sample)
        if data is not None:
            passes_.along_ray(ctx, data, np.arange(len(O)), np.ones((len(O), 3)), O, D, found.hit,
                              np.where(found.hit, found.t, t_max), stretch)
        if surface is None and arrivals is None:
            return Radiance(L_out, found.hit, 0, light=light, groups=None if groups is None else groups.L,
                            features=None if feats is None else feats.stacked(), passes=data)
        D_hit = vectors.gather(D, hit)
        held = np.zeros(len(O))                      # each camera ray's alpha that holdouts take away
        holdouts = ctx.geometry.hides(HOLDOUT) or bool(ctx.materials.holds_out.any())
        film_clear = bool(s.transparent_background)  # (escaping camera paths clear the film: below)
        # 2. The path's vertices, one batch per bounce: the camera's hits first.
        owner = hit                                  # the camera ray each path belongs to
        throughput = np.ones((len(hit), 3))
        if media is not None:                        # (what the media let through to the camera's hits)
            inside = at_hit[hit]
            throughput = (stretch.rows(hit).transmittance(surface.t) if camera_through is None
                          else camera_through[hit])
        diffuse = np.zeros(len(hit), np.int64)
        glossy = np.zeros(len(hit), np.int64)
        transmission = np.zeros(len(hit), np.int64)
        transparent = np.zeros(len(hit), np.int64)
        portal = np.zeros(len(hit), np.int64)        # of those, Ray Portals (the Light Path node's Portal Depth)
        camera_cone, camera_spread = camera_cones(ctx, O, D)   # each camera ray's cone (graph.LightPath cone, spread)
        cone, spread = camera_cone[hit], camera_spread[hit]
        bounds = np.zeros(len(hit), np.int64)         # volume-only boundaries crossed (Cycles' volume_bounds_bounce)
        bounce = np.zeros(len(hit), np.int64)
        flags = np.full(len(hit), graph_.PATH_CAMERA, np.int64)   # the Light Path flags of the ray that got there
        mis_pdf = np.full(len(hit), np.inf)          # the pdf of each path's last real bounce (inf: the camera)
        min_pdf = np.full(len(hit), np.inf)          # the smallest pdf of its real bounces (Cycles' min_ray_pdf)
        mis_origin = vectors.gather(O, hit)          # its ray origin and light-tree normal (vertex.BsdfRay.mis_O):
        #                                              the camera's, from where a camera path sees lamps past clear panes
        mis_normal = np.zeros((len(hit), 3))
        mis_receiver = np.full(len(hit), -1, np.int64)   # and its triangle (-1: the camera's), for Light Linking
        after_diffuse = np.zeros(len(hit), bool)     # whether that bounce was diffuse (the caustics switches)
        seen_by = np.full(len(hit), HIDDEN_FROM_CAMERA)   # the kind of ray that reached each vertex (ray_kind)
        max_bounces = 0 if self.direct_only else s.max_bounces
        wo = -D_hit
        vertex = 0
        # The light passes: each path's shares by kind, set at its first real bounce or scattering event.
        shares = np.zeros((len(hit), lightpasses.KINDS, 3))
        looking = np.ones(len(hit), bool)            # which paths still look for their feature vertex
        feature_throughput = np.ones((len(hit), 3))
        volume = np.zeros(len(hit), np.int64)      # each path's scattering events in media so far (Volume Bounces)
        if arrivals is not None:
            # Paths that scattered along the camera rays and went on: their next vertices join the camera's hits.
            state = dict(owner=owner, throughput=throughput, diffuse=diffuse, glossy=glossy, transmission=transmission,
                         transparent=transparent, portal=portal, cone=cone, spread=spread, bounds=bounds, bounce=bounce,
                         flags=flags, mis_pdf=mis_pdf, mis_origin=mis_origin, mis_normal=mis_normal,
                         mis_receiver=mis_receiver, after_diffuse=after_diffuse, seen_by=seen_by, inside=inside,
                         looking=looking, feature_throughput=feature_throughput, shares=shares, volume=volume, wo=wo,
                         min_pdf=min_pdf)
            where = (found.prim[hit], found.u[hit], found.v[hit], vectors.gather(O, hit), D_hit, found.t[hit])
            state, surface = with_arrivals(ctx, state, where, arrivals, np.arange(len(O)), camera_cone, camera_spread)
            (owner, throughput, diffuse, glossy, transmission, transparent, portal, cone, spread, bounds, bounce, flags,
             mis_pdf, mis_origin, mis_normal, mis_receiver, after_diffuse, seen_by, inside, looking, feature_throughput,
             shares, volume, wo, min_pdf) = state.values()
        exiting = np.zeros(len(owner), bool)         # which vertices are subsurface walks' exits (subsurface.py)
        # Shadow caustics (core/integrators/mnee.py): which paths left a receiver (Cycles' PATH_MNEE_RECEIVER_ANCESTOR);
        # a caster's BSDF ray on such a path finds no caustics lamp, whose light MNEE brings.
        walking = mnee_.active(ctx)
        ancestor = np.zeros(len(O), bool)
        while len(owner):
            check_stop(ctx)
            # a. What the vertex gathers: its emission (camera hits only; later ones were found by the ray
            #    that led there), light samples, and the light its BSDF ray finds; then where that ray goes.
            #    Light the camera's hit gathers is direct, later light indirect (sample clamping).
            dimension = vertex * VERTEX_DIMENSIONS
            cap = np.where(bounce == 0, direct_cap, indirect_cap)
            light_path = graph_.LightPaths(flags, bounce, diffuse, glossy, transmission, transparent, portal, cone,
                                           spread)
            shader = ctx.materials.shade(surface.material, surface.N, wo, surface, ctx.geometry, light_path,
                                         caustics_filter(s, after_diffuse),
                                         shader_rays.for_hits(ctx, surface, pixel[owner], sample[owner], dimension,
                                                              min_pdf),
                                         blur=filter_glossy_roughness(s.filter_glossy, min_pdf))
            # A walk's exit is lit as a white Lambert surface (Cycles' subsurface_shader_data_setup).
            shader = subsurface_.subsurface_shader(shader, exiting)
            # After a diffuse bounce Christensen-Burley is a Lambert closure (Cycles' PATH_RAY_DIFFUSE_ANCESTOR).
            shader = subsurface_.burley_as_diffuse(shader, (diffuse > 0) | after_diffuse)
            if holdouts:
                # A camera path (no real bounce yet) that meets a holdout object or node: a hole in the film.
                shader, weight = hold_out(ctx, surface, shader, bounce == 0)
                np.add.at(held, owner, (throughput * weight).mean(axis=1))
            first = bounce == 0
            if data is not None:                     # (the vertices of camera chains: no real bounce yet)
                passes_.at_vertex(ctx, data, np.flatnonzero(first & ~exiting), owner, vertex, surface, shader, wo, throughput,
                                  pixel[owner], sample[owner], dimension)
            parts = lightpasses.FirstHitParts(len(owner)) if light is not None and first.any() else None
            cull = None
            if walking:
                caustic_flags = ctx.geometry.caustics_flags(surface.prim)
                cull = ((caustic_flags & mnee_.CASTER) != 0) & ancestor[owner]
                ancestor[owner[(caustic_flags & mnee_.RECEIVER) != 0]] = True
            state = PathState(dimension, vertex, light_path, throughput, cap, seen_by=seen_by, carried_pdf=mis_pdf,
                              carried_origin=mis_origin, carried_N=mis_normal, bounce=bounce, inside=inside,
                              carried_receiver=mis_receiver, min_pdf=min_pdf, caustics_cull=cull)
            vertex_groups = lightgroups.tally(ctx, len(owner))
            emitted, finds = (np.zeros((len(owner), 3)), np.zeros((len(owner), 3))) if feats is not None else (None, None)
            L_vertex, rays, ray = shade_vertex(ctx, surface, wo, pixel[owner], sample[owner], recorder, state,
                                               trace_all=True, shader=shader, parts=parts, groups=vertex_groups,
                                               emitted=emitted, found=finds)
            shadow_rays += rays
            L_out[owner] += throughput * L_vertex
            # (Fast GI's Add method: ambient occlusion at every vertex, to Combined alone, unclamped, as Cycles')
            if getattr(s, "ao_additive_factor", 0.0):
                np.add.at(L_out, owner, throughput * fast_gi_added(ctx, surface, shader, pixel[owner], sample[owner],
                                                                   dimension))
            if groups is not None:
                groups.add_rows(owner, vertex_groups, throughput)
            if feats is not None:
                # The emission seen here, the feature vertex; then what this vertex's BSDF ray found.
                looking, feature_throughput = features_.at_vertex(feats, owner, looking, throughput, feature_throughput,
                                                                  shader, emitted)
                features_.found(feats, owner, looking, feature_throughput, throughput * finds)
            if light is not None:
                # Direct: what the first hits gather (not their emission); indirect: all later vertices gather.
                if parts is not None:
                    np.add.at(light, (owner[first], slice(None, lightpasses.KINDS)),
                              throughput[first, None, :] * parts.gathered[first])
                later = ~first
                np.add.at(light, (owner[later], slice(lightpasses.KINDS, None)),
                          lightpasses.split(throughput[later] * L_vertex[later], shares[later]))
            recorder.path_vertex(vertex, owner, surface, throughput, L_vertex)
            if ray is None:
                break
            # b. The bounce: the paths whose ray hit a surface and may still bounce there go on.
            #    (each ray's path past the bounce counts it: vertex.bsdf_ray, rays.path_after)
            *_, is_transparent, labelled_diffuse = bounce_kind(ray.kind, ray.transmit)
            # (a walk into a BSSRDF counts no bounce and plays no roulette; the path keeps its kind of bounce)
            walked = materials_.has(ray.kind, materials_.BSDFFlags.SUBSURFACE)
            # Each ray's weight f cos / pdf, times what the media it crosses let through to its hit.
            weight = ray.weight if ray.attenuation is None else ray.weight * ray.attenuation
            # (a volume-only boundary is no transparent bounce: Cycles counts those crossings apart, up to 1024)
            boundary = False if media is None else media.boundary[surface.material[ray.rows]]
            bounces, d, g, tr = ray.path.bounce, ray.path.diffuse, ray.path.glossy, ray.path.transmission
            tp = ray.path.transparent - (is_transparent & boundary)
            vb = bounds[ray.rows] + (is_transparent & boundary)
            within = ((bounces <= max_bounces) & (d <= s.diffuse_bounces) & (g <= s.glossy_bounces)
                      & (tr <= s.transmission_bounces))
            # (Fast GI's short rays end their paths where they meet a surface, as past the bounce limits: Cycles'
            #  integrator_intersect_terminate, its emission gathered, its transparent surfaces looked through)
            short = np.zeros(len(bounces), bool) if ray.ao is None else ray.ao
            bouncing = within & ~short
            # (the surface after the last transparent bounce allowed ends the path, Cycles' terminate-on-next-surface:
            #  the ray gathered its emission, nothing more)
            last_clear = is_transparent & np.logical_not(boundary) & (tp >= s.transparent_max_bounces)
            going = (ray.hits.hit & bouncing & (tp <= s.transparent_max_bounces) & ~last_clear
                     & (vb <= VOLUME_BOUNDS_MAX))
            if data is not None:
                # A camera chain's ray straight on through a transparent surface: what it passes and escapes to.
                chain = np.flatnonzero((bounce[ray.rows] == 0) & is_transparent & (tp <= s.transparent_max_bounces))
                passes_.along_ray(ctx, data, owner[ray.rows[chain]], throughput[ray.rows[chain]] * ray.weight[chain],
                                  ray.O[chain], ray.D[chain], ray.hits.hit[chain],
                                  np.where(ray.hits.hit[chain], ray.hits.t[chain], np.inf),
                                  None if media is None else media.along(ray.inside[chain], ray.O[chain], ray.D[chain]))
            # A path past its bounce limits still looks through the transparent surfaces its last ray meets, to
            # the light behind them (Cycles' terminate-after-transparent): no more bounces, only clear ones.
            ended = np.flatnonzero(ray.hits.hit & ~bouncing & (tp <= s.transparent_max_bounces))
            ended = ended[ctx.materials.may_pass[hit_materials(ctx, ray, ended)]] if len(ended) else ended
            if len(ended):
                behind_groups = lightgroups.tally(ctx, len(ended))
                behind = through_transparent(ctx, ray, ended, throughput[ray.rows[ended]] * weight[ended],
                                             tp[ended], cap[ray.rows[ended]], behind_groups, short[ended])
                L_out[owner[ray.rows[ended]]] += behind
                if groups is not None:
                    groups.add_rows(owner[ray.rows[ended]], behind_groups)
                if feats is not None:
                    features_.found(feats, owner[ray.rows[ended]], looking[ray.rows[ended]],
                                    feature_throughput[ray.rows[ended]], behind)
                if light is not None:
                    self.light_behind(light, owner[ray.rows[ended]], behind, bounce[ray.rows[ended]] == 0,
                                      parts.ray_shares[ended] if parts is not None else None, shares[ray.rows[ended]])
            next_throughput = throughput[ray.rows] * weight
            if film_clear:
                # A camera path (through clear surfaces and clear glass alone) that escapes with a transparent film: the
                # film is as clear as what it brings through, and no world (Cycles' PATH_RAY_TRANSPARENT_BACKGROUND).
                escaped = np.flatnonzero(~ray.hits.hit & ((ray.path.flags & graph_.PATH_CLEARS_FILM) != 0))
                np.add.at(held, owner[ray.rows[escaped]], next_throughput[escaped].mean(axis=1))
            # c. Russian roulette from the third vertex: go on with probability q, and count for 1 / q.
            played = (bounces >= roulette_from(s)) & ~is_transparent & ~walked
            survived, q = np.ones(len(bounces), bool), np.ones(len(bounces))
            if played.any():
                # (q from the throughput before the media along the ray: a ray into fog that lets nothing through to
                #  its end still gathers the light scattered along it, as Cycles decides before the volume)
                carried = next_throughput if ray.attenuation is None else throughput[ray.rows] * ray.weight
                q = np.where(played, survival(carried), 1.0)
                u = sampling.sample_2d(s.seed, pixel[owner[ray.rows]], sample[owner[ray.rows]],
                                       dimension=ROULETTE_DIMENSION + (vertex + 1) * VERTEX_DIMENSIONS)[:, 0]
                survived = ~played | (u < q)
                recorder.roulette(vertex + 1, owner[ray.rows], q, survived & going)
                going &= survived
                next_throughput = next_throughput / np.where(going, q, 1.0)[:, None]
            vertex_arrivals = None
            path_shares = None
            if light is not None:
                # A path's shares are those of its first real bounce's ray, kept from then on.
                sets = (bounce[ray.rows] == 0) & ~is_transparent
                path_shares = shares[ray.rows]
                if parts is not None:
                    path_shares = np.where(sets[:, None, None], parts.ray_shares, path_shares)
            if feats is not None and media is not None:
                # (the media along this bounce's rays, where their paths still look: features.in_media)
                rows = np.flatnonzero(within & (tp <= s.transparent_max_bounces) & survived & looking[ray.rows]
                                      & ~walked)
                if len(rows):
                    features_.in_media(feats, media.along(ray.inside[rows], ray.O[rows], ray.D[rows]),
                                       np.where(ray.hits.hit[rows], ray.hits.t[rows], np.inf), camera_back(ctx),
                                       owner[ray.rows[rows]], throughput[ray.rows[rows]] * ray.weight[rows]
                                       / q[rows, None], feature_throughput[ray.rows[rows]])
            if scatters:
                # The light the media scatter towards this bounce's rays, where the path may still bounce on them.
                # (not along a walk's exit ray: no ray through the media, the exit is shaded at once, as in Cycles)
                # (nor along Fast GI's short rays, whose media only absorb and emit: Cycles ends such a path after
                #  the volume, PATH_RAY_TERMINATE_AFTER_VOLUME, and scatters nowhere on a path it terminates)
                live = np.flatnonzero(within & (tp <= s.transparent_max_bounces) & survived & ~walked & ~short)
                if onward and len(live):
                    # Paths with Volume Bounces left scatter or go on (volume.multiple_scattering).
                    multi = live[volume_.volume_bounces_left(ctx, volume[ray.rows[live]], bounces[live], tr[live],
                                                             g[live])]
                    live = np.setdiff1d(live, multi)
                    if len(multi):
                        carried = throughput[ray.rows[multi]] * ray.weight[multi] / q[multi, None]
                        counters = dict(bounce=bounces[multi], volume=volume[ray.rows[multi]], diffuse=d[multi],
                                        glossy=g[multi], transmission=tr[multi], transparent=tp[multi],
                                        portal=ray.path.portal[multi], bounds=vb[multi])
                        path_rows = owner[ray.rows[multi]]
                        events = {} if light is not None else None
                        stretch_groups = lightgroups.tally(ctx, len(multi))
                        scattered, count, passing, vertex_arrivals = volume_.multiple_scattering(
                            ctx, ray.O[multi], ray.D[multi], np.where(ray.hits.hit[multi], ray.hits.t[multi], np.inf),
                            ray.inside[multi], carried, pixel[path_rows], sample[path_rows],
                            (vertex + 1) * VERTEX_DIMENSIONS, counters, through_transparent, events, stretch_groups)
                        L_out[path_rows] += scattered
                        if groups is not None:
                            groups.add_rows(path_rows, stretch_groups)
                        if light is not None:
                            # (the light passes: lightpasses.stretch_shares, for the arrivals too)
                            here = lightpasses.stretch_shares(bounces[multi], path_shares[multi])
                            lightpasses.add_scattered(light, path_rows, events["first"], bounces[multi], here, True)
                            lightpasses.add_scattered(light, path_rows, events["later"], bounces[multi], here, False)
                            if vertex_arrivals is not None:
                                vertex_arrivals["shares"] = here[vertex_arrivals["origin"]]
                        shadow_rays += count
                        next_throughput[multi] = carried * passing
                        going[multi] &= (passing != 0.0).any(axis=1)
                        arrival_owners = path_rows
                if len(live):
                    path_rows = owner[ray.rows[live]]
                    carried = throughput[ray.rows[live]] * ray.weight[live] / q[live, None]
                    stretch_groups = lightgroups.tally(ctx, len(live))
                    scattered, count = volume_.in_scattering(
                        ctx, ray.O[live], ray.D[live], np.where(ray.hits.hit[live], ray.hits.t[live], np.inf),
                        ray.inside[live], carried, pixel[path_rows], sample[path_rows],
                        (vertex + 1) * VERTEX_DIMENSIONS, bounces[live], through_transparent, recorder, stretch_groups,
                        fast_gi_scatter(s, len(live), bounces[live], tr[live], g[live]))
                    L_out[path_rows] += carried * scattered
                    if groups is not None:
                        groups.add_rows(path_rows, stretch_groups, carried)
                    shadow_rays += count
                    if light is not None:
                        lightpasses.add_scattered(light, path_rows, carried * scattered, bounces[live],
                                                  lightpasses.stretch_shares(bounces[live], path_shares[live]), True)
            keep = np.flatnonzero(going & np.isfinite(next_throughput).all(axis=1))
            if len(keep) == 0 and vertex_arrivals is None:
                break
            seen_by = ray.seen_as[keep]
            looking, feature_throughput = looking[ray.rows][keep], feature_throughput[ray.rows][keep]
            if light is not None:
                shares = path_shares[keep]
            # d. The next vertex: the surfaces the kept rays hit.
            hits = ray.hits
            rows = ray.rows[keep]
            D_next = ray.D[keep]
            surface = surface_at_hits(ctx.geometry, hits.prim[keep], hits.u[keep], hits.v[keep], ray.O[keep],
                                      D_next, hits.t[keep], flat_only=not s.smooth_normals,
                                      times=None if hits.time is None else hits.time[keep])
            owner = owner[rows]
            throughput = next_throughput[keep]
            diffuse, glossy, transmission, transparent, bounds = d[keep], g[keep], tr[keep], tp[keep], vb[keep]
            portal, cone, spread = ray.path.portal[keep], ray.path.cone[keep], ray.path.spread[keep]
            flags = ray.path.flags[keep]
            # A transparent bounce keeps the kind of the last real one (Cycles' path flags).
            after_diffuse = np.where(is_transparent | walked, after_diffuse[ray.rows], labelled_diffuse)[keep]
            exiting = walked[keep]
            bounce = bounces[keep]
            mis_pdf = ray.pdf[keep]
            ray_min_pdf = np.where(is_transparent, min_pdf[ray.rows], np.minimum(min_pdf[ray.rows], ray.pdf))
            min_pdf = ray_min_pdf[keep]
            mis_origin, mis_normal = ray.mis_O[keep], ray.mis_N[keep]
            mis_receiver = ray.receiver[keep]
            inside = None if media is None else ray.inside[keep]
            wo = -D_next
            volume = volume[ray.rows][keep]
            if vertex_arrivals is not None:
                # Paths that scattered along this bounce's rays and went on: their next vertices join the others.
                exiting = np.concatenate([exiting, np.zeros(len(vertex_arrivals["origin"]), bool)])
                state = dict(owner=owner, throughput=throughput, diffuse=diffuse, glossy=glossy,
                             transmission=transmission, transparent=transparent, portal=portal, cone=cone,
                             spread=spread, bounds=bounds, bounce=bounce, flags=flags, mis_pdf=mis_pdf,
                             mis_origin=mis_origin, mis_normal=mis_normal, mis_receiver=mis_receiver,
                             after_diffuse=after_diffuse, seen_by=seen_by, inside=inside, looking=looking,
                             feature_throughput=feature_throughput, shares=shares, volume=volume, wo=wo,
                             min_pdf=min_pdf)
                # (a scattering path's smallest pdf so far: its bounce's and its phase function's, Cycles' min_ray_pdf)
                vertex_arrivals["min_pdf"] = np.minimum(ray_min_pdf[multi][vertex_arrivals["origin"]],
                                                        vertex_arrivals["pdf"])
                where = (hits.prim[keep], hits.u[keep], hits.v[keep], ray.O[keep], D_next, hits.t[keep])
                state, surface = with_arrivals(ctx, state, where, vertex_arrivals, arrival_owners,
                                               ray.path.cone[multi], ray.path.spread[multi])
                (owner, throughput, diffuse, glossy, transmission, transparent, portal, cone, spread, bounds, bounce,
                 flags, mis_pdf, mis_origin, mis_normal, mis_receiver, after_diffuse, seen_by, inside, looking,
                 feature_throughput, shares, volume, wo, min_pdf) = state.values()
            vertex += 1
        return Radiance(L_out, found.hit, shadow_rays, held if holdouts or film_clear else None, light,
                        None if groups is None else groups.L, None if feats is None else feats.stacked(), data)

    @staticmethod
    def light_behind(light: np.ndarray, owner: np.ndarray, value: np.ndarray, first: np.ndarray, ray_shares,
                     shares: np.ndarray) -> None:
        """Add to the light passes `light` (n, 8, 3) what ended paths' last rays found behind transparent surfaces,
        value (k, 3) of the camera rays `owner` (k,): direct, by their ray's shares ray_shares (k, KINDS, 3), where
        the ray left a first hit (first (k,) bool), else indirect by the path's shares (k, KINDS, 3)."""
        kinds = lightpasses.KINDS
        if first.any():
            np.add.at(light, (owner[first], slice(None, kinds)), lightpasses.split(value[first], ray_shares[first]))
        np.add.at(light, (owner[~first], slice(kinds, None)), lightpasses.split(value[~first], shares[~first]))
