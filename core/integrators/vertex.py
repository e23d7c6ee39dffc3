"""What one vertex of a path gathers: the light its hits send back, by light samples and a BSDF-sampled ray.

Every integrator lights the surfaces its rays meet the same way, the lecture's way: for every light, and every
sample of a light with extent,

    L_out += f(wo, L) max(N.L, 0) * E_normal * V * w_light    (core/materials, core/lights, shadows.py)

where E_normal = L_e / pdf is the light sample's irradiance at normal incidence and V the shadow ray's verdict;
and lights with extent (area lights, round lights, sun disks, emissive meshes, an environment) also the other way
round: one direction sampled from the BSDF, traced, adds the light it meets, L_out += (f cos / pdf_bsdf) L_e
w_bsdf, the two weighed by multiple importance sampling (Veach's power heuristic, as Cycles weighs them). The
direct-lighting tracer does this at the camera's hits (core/integrators/direct.py), Whitted's tracer at the hits of
its mirror and glass rays by light samples alone (whitted.py), the path tracer at every vertex, whose BSDF ray is
also where the path goes on (path.py). What a path brings to the hits it reached (how far it is, what it carries,
which kind of ray it is) is one record, PathState.

The compiled twin is core/integrators/direct.c (direct_light, bsdf_rays, gather_light).
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from .. import materials as materials_
from ..materials import portal as portal_
from ..materials import subsurface as bssrdf_
from ..geometry.intersect import Hits
from ..geometry.surface import surface_at_hits
from ..lights import linking
from ..lights.base import LAMP, LightFlags, light_dimension
from ..native import schema
from ..materials import graph as graph_
from ..sampling import sobol as sampling
from .. import volumes
from ..visibility import (HIDDEN_FROM_CAMERA, HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION,
                          HOLDOUT)
from . import clamp as clamp_
from . import lightgroups, lightpasses
from . import mnee as mnee_
from . import shader_rays, shadows
from .base import Context, Recorder, check_stop
from . import subsurface as subsurface_
from .rays import clear_glass_threshold, clears_glass, goes_through, nearest_seen, path_after, ray_kind
from .shadows import spawn_ray


class PathState(NamedTuple):
    """What a path brings to the hits it reached (one row per hit, or one value for all).

    dimension: the shift of every sampling dimension at this vertex (VERTEX_DIMENSIONS per vertex)
    vertex:    0 at the camera's hits, which add their own emission (not the surfaces that paths which scattered
               along camera rays reach, flagged volume_scatter: their phase rays found it); later hits leave it to the
               ray that found them
    light_path: the paths that reached the hits (graph.LightPaths of m rows: the flags of the rays that found them
               and the bounces so far), for the Light Path node; None: camera rays
    throughput: (m, 3) what the path carries so far, or None (1)
    limit:     the cap on each contribution seen through the throughput (sample clamping, clamp.py; inf: none),
               scalar or (m,)
    caustics:  (m,) int the closures a caustics filter takes away (closures.FILTER_*), or None
    seen_by:   the kind of ray that reached each hit (HIDDEN_FROM_* bit, int or (m,)): a Transparent closure's ray
               goes on as that kind (rays.ray_kind)
    carried_pdf, carried_origin, carried_N: (m,), (m, 3), (m, 3) the pdf, ray origin and light-tree normal of each
               path's last real bounce (bsdf_ray), or None: a camera ray's
    bounce:    the real bounces each path made before the hits (0: the camera's hits; int or (m,)): a light takes no
               light samples at hits past its max_bounces
    carried_receiver: (m,) int64 the triangle of each path's last real bounce (-1: the camera's), or None: a ray
               straight on through a transparent surface finds the emitters that light its object (Light Linking,
               Cycles' mis_ray_object)
    inside:    (m, V) int16 the media the rays that reached the hits were in (core/volumes Media.crossed), or None:
               no media. Rays leaving a hit to the other side of its surface enter or leave its material's medium.
    caustics_cull: (m,) bool the hits whose BSDF rays find no caustics lamp (Cycles' PATH_MNEE_CULL_LIGHT_CONNECTION:
               a caster's hit on a path that left a receiver before; that light is MNEE's, core/integrators/mnee.py),
               or None: none
    min_pdf:   (m,) the smallest pdf of each path's real bounces so far (Cycles' min_ray_pdf, which the Bevel node
               reads), or None: none (a camera ray's)
    """

    dimension: int = 0
    vertex: int = 0
    light_path: object = None
    throughput: Optional[np.ndarray] = None
    limit: object = np.inf
    caustics: Optional[np.ndarray] = None
    seen_by: object = HIDDEN_FROM_CAMERA
    carried_pdf: Optional[np.ndarray] = None
    carried_origin: Optional[np.ndarray] = None
    carried_N: Optional[np.ndarray] = None
    bounce: object = 0
    inside: Optional[np.ndarray] = None
    carried_receiver: Optional[np.ndarray] = None
    min_pdf: Optional[np.ndarray] = None
    caustics_cull: Optional[np.ndarray] = None


def power_heuristic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Veach's power heuristic a^2 / (a^2 + b^2), with a = inf (a delta strategy) giving 1 and a = 0 giving 0.

    a, b: (n,) float64 the two strategies' pdfs, each times its number of samples.
    """
    with np.errstate(invalid="ignore", over="ignore"):
        w = a * a / (a * a + b * b)
    return np.where(np.isinf(a), 1.0, np.where(a > 0.0, np.nan_to_num(w), 0.0))


def shade_vertex(ctx: Context, surface, wo: np.ndarray, pixel: np.ndarray, sample: np.ndarray, recorder: Recorder,
                 path: Optional["PathState"] = None, trace_all: bool = False, light_samples_only: bool = False,
                 shader=None, parts=None, groups=None, emitted=None, found=None):
    """Return (the radiance (m, 3) float64 each hit sends towards wo, shadow rays traced, the BsdfRay
    each traced hit sent out, or None).

    wo: (m, 3) float64 unit directions towards the viewer; pixel, sample: (m,) int64 each hit's
    keys for its random numbers; path: what the path that reached the hits brings (PathState; default: camera
    rays, whose fields are named below). Every integrator lights its hits with this. A path
    (core/integrators/path.py) calls it at every vertex:
    `dimension` shifts its random numbers, vertices after the first leave their emission to the
    ray that found them (vertex > 0), and every hit traces its BSDF ray (trace_all). Whitted's tracer
    lights every hit by light samples alone (light_samples_only: no BSDF ray, no MIS). light_path: the paths
    that reached the hits (graph.LightPaths; default: camera rays), which their shaders read (the Light Path node)
    as do the shadow rays' transparent surfaces, the textured emitters their light samples land on and the
    surfaces their BSDF rays hit.
    caustics: (m,) int the closures a caustics filter takes away (closures.FILTER_*), or None. throughput
    (m, 3) or None (1) and limit (scalar or (m,), inf: none): each contribution the hits gather is capped at
    `limit` seen through its path's throughput (sample clamping, core/integrators/clamp.py). shader: the
    hits' ShaderResult when the caller has it already (a path's holdouts change it), else evaluated here.
    seen_by: the kind of ray that reached each hit (HIDDEN_FROM_* bit, int or (m,)): a Transparent closure's
    ray goes on as that kind (ray_kind). parts: a lightpasses.FirstHitParts that receives the light samples'
    and the BSDF ray's contributions split by closure kind, and the BSDF rays' shares (the light passes), or None.
    carried_pdf, carried_origin, carried_N: (m,), (m, 3), (m, 3) the pdf, ray origin and light-tree normal of each
    path's last real bounce (bsdf_ray), or None. groups: a lightgroups.GroupLight of the m hits that receives
    everything L_out does, by the group of its source (core/integrators/lightgroups.py), or None. emitted, found:
    (m, 3) arrays that receive the hits' own emission (vertex 0) and what their BSDF rays find, as L_out receives
    them (the denoising features, core/integrators/features.py), or None.
    """
    s = ctx.settings
    m = len(surface.I)
    path = PathState() if path is None else path
    dimension, vertex, throughput, limit = path.dimension, path.vertex, path.throughput, path.limit
    caustics, seen_by = path.caustics, path.seen_by
    carried_pdf, carried_origin, carried_N = path.carried_pdf, path.carried_origin, path.carried_N
    # 1. The material at each hit: its closures (BSDFs with weights) and the light it emits itself.
    light_path = graph_.light_paths(m) if path.light_path is None else path.light_path
    if shader is None:
        shader = ctx.materials.shade(surface.material, surface.N, wo, surface, ctx.geometry, light_path, caustics,
                                     shader_rays.for_hits(ctx, surface, pixel, sample, dimension))
    shader = terminator_bent(ctx, surface, shader)
    recorder.shader(shader)
    clamping = np.any(np.isfinite(limit))
    # A vertex 0 reached by a phase ray adds no emission of its own: a path that scattered in media along a camera
    # ray and reached a surface (volume.multiple_scattering's arrivals, which join the camera's hits) had its phase
    # ray find that emission, weighed by MIS.
    phase_found = (np.broadcast_to(np.asarray(light_path.flags), (m,)) & graph_.PATH["volume_scatter"]) != 0
    own = (vertex == 0) & ~phase_found
    L_out = np.where(own[:, None], shader.emission, 0.0)
    if clamping and vertex == 0:
        L_out = clamp_.clamped(L_out, throughput, limit)
    if groups is not None and vertex == 0:
        groups.add(np.arange(m), L_out, groups.groups.of_prims(ctx.geometry, surface.prim))
    if emitted is not None and vertex == 0:
        emitted += L_out
    shadow_rays = 0
    offsets = shadows.error_bound(surface.I, surface.vertices) if s.shadow_method == "robust" else None
    # Which hits trace a BSDF ray (every hit where emitters or the world light the scene, glossy hits
    # where only lamps with extent do) and so weigh their light samples by MIS.
    traced = np.ones(m, bool) if trace_all else wants_bsdf_ray(ctx, shader)
    if light_samples_only:
        traced = np.zeros(m, bool)
    mis = (traced & (s.light_sampling == "mis")) if ctx.extra.get("bsdf_rays", False) else np.zeros(m, bool)
    # Hits whose closures let light through from behind (rough glass) sample lights on both sides.
    refracts = lets_light_through(shader)
    tree_N = tree_normals(s, surface, refracts)
    for index, light in enumerate(ctx.lights):
        check_stop(ctx)
        if (s.light_sampling == "bsdf" and not light_samples_only and not light.delta and light.use_mis
                and index in ctx.extra.get("hittable", ())):
            continue                      # found by BSDF rays alone
        count = light_count(ctx, light)
        cone = light.cone(surface.I)                   # shared by all the light's samples
        for j in range(count):
            # a. Where does the light come from? One sample of the light's progressive pattern:
            #    camera sample s takes its points s*count .. s*count+count-1 (core/sampling), so
            #    the points of any number of camera samples together cover the light evenly.
            u = light_numbers(ctx, light, index, pixel, sample * count + j, m, dimension)
            # (a moving emitter where it is at the path's time)
            moving = {} if getattr(light, "mesh", None) is None else {"times": surface.time}
            ls = light.sample(surface.I, u, cone, N=tree_N, **moving, **lamp_paths(light, light_path))
            ls = world_samples_seen(light, ls, light_path)
            if getattr(light, "textured", None) is not None:
                ls = textured_samples(ctx, light, surface.I, ls, graph_.with_flags(light_path, graph_.PATH_EMISSION),
                                      surface.time)
            if not s.distance_attenuation:
                ls = light.without_attenuation(ls, surface.I)
            if light.hidden_from and ls.hidden is None:
                ls = ls._replace(hidden=np.full(m, light.unseen_by, np.int64))   # a lamp's Ray Visibility
            # b. The lecture's two tests: N.L > 0 (shading normal, the clamp) and Ng.L > 0 (the
            #    face normal decides whether the light can be visible; `visibility_normal`
            #    switches it). The terminator fix lifts smooth points onto the curved surface,
            #    where the face normal no longer decides; its shadow ray does.
            NL = np.einsum("ij,ij->i", surface.N, ls.L)
            NgL = np.einsum("ij,ij->i", surface.Ng, ls.L)
            facing = NgL > 0.0 if s.visibility_normal == "face" else NL > 0.0
            face_allows = (facing | surface.smooth if s.terminator_fix else facing) | refracts
            cosine = np.maximum(NL, 0.0) if s.clamp_n_dot_l else NL
            cosine = np.where(refracts, np.abs(NL), cosine)
            lit = (cosine != 0.0) & face_allows
            if s.shadow_rays_for_backfacing:
                lit[:] = True                     # cast them anyway, to count what the lecture saves
            lit &= (ls.strength > 0.0) | (ls.strength < 0.0)      # (a negative lamp takes light away, as in Cycles)
            if light.max_bounces < 1024:
                lit &= np.asarray(path.bounce) <= light.max_bounces    # a light's Max Bounces (Cycles: per light)
            if ls.emitter is not None:
                lit &= ~lights_itself(surface, light, ls, NL, NgL)
            if ctx.geometry.linked or light.light_membership != linking.ALL_SETS:
                lit &= linking.lights_receivers(ctx.geometry, light, ls, surface.prim)    # Light Linking
            recorder.light_sample(index, count, ls, NL, NgL, cosine, face_allows, lit)
            rows = np.flatnonzero(lit)
            if len(rows) and mnee_.walks(light) and len(ctx.geometry.instance_caustics):
                # Shadow caustics (Cycles' MNEE): a receiver's samples that the walk through the casters lights
                # are lit that way; a caster's samples from behind it (through its glass) are dropped.
                rows = shadow_caustics(ctx, surface, shader, wo, rows, index, light, ls, NL, pixel, sample, count, j,
                                       dimension, path, light_path, L_out, recorder, groups, parts, clamping,
                                       throughput, limit)
            if len(rows) == 0:
                continue
            # c. One shadow ray per lit sample, from a point safely off the surface.
            rays = aim_shadow_rays(s, surface, rows, ls, NL, NgL, offsets, refracts[rows], ctx.geometry)
            blockers = shadow_blockers(ctx, light, ls, rows)
            if not light.cast_shadow:
                # A lamp with Cast Shadow off (Cycles' light.use_shadow): no shadow ray, nothing blocks it.
                seen = np.ones(len(rows), bool)
                through = np.ones((len(rows), 1))
            elif ctx.extra.get("transparent", False):
                # (a light behind the surface, N.L < 0, is reached through it: into or out of its medium)
                start = None if path.inside is None else media_beyond(ctx, surface, rows, path.inside[rows],
                                                                      NL[rows] < 0.0)
                # (Cycles' shadow ray: the hit's footprint, not widening: dP = sd->dP, dD = 0)
                shadow_paths = graph_.paths_at(graph_.with_flags(light_path, graph_.PATH_SHADOW)._replace(
                    cone=graph_.footprints(light_path, surface.t), spread=np.zeros(m)), rows)
                through = shadows.transmittance(ctx, rays, s.transparent_max_bounces, start, shadow_paths, blockers)
                seen = through.any(axis=1)
            else:
                seen = shadows.visible(ctx.geometry.tracer, rays)
                through = seen[:, None].astype(np.float64)
            if light.cast_shadow:                 # (no shadow ray to show where none was traced)
                recorder.shadow_rays(index, count, rows, rays, seen)
                shadow_rays += len(rows)
            # d. What gets through: f cos (the closures at L) E_normal / count, coloured by the
            #    light, weighed against BSDF sampling where a BSDF ray could find this light.
            part = shader.closures.rows(rows)
            left_out = None if ls.hidden is None else closures_left_out(part.kind, ls.hidden[rows])
            f_cos, pdf_bsdf = materials_.eval_closures(part, wo[rows], ls.L[rows],
                                                       signed_cosine=not s.clamp_n_dot_l, left_out=left_out)
            weight = ls.strength[rows] * (1.0 / count)
            mis_weight = np.ones(len(rows))
            if not light.delta and light.use_mis and index in ctx.extra["hittable"] and mis[rows].any():
                weighed = mis[rows] if blockers is None else mis[rows] & (blockers == np.uint64(linking.ALL_SETS))
                mis_weight = np.where(weighed, power_heuristic(mis_count(ctx, light) * ls.pdf[rows], pdf_bsdf), 1.0)
                weight = weight * mis_weight
            color = ls.color if ls.color.ndim == 1 else ls.color[rows]
            value = (weight[:, None] * color) * f_cos * through
            if clamping:
                value = clamp_.clamped(value, None if throughput is None else throughput[rows],
                                       limit if np.ndim(limit) == 0 else limit[rows], count)
            recorder.contribution(index, rows, value, mis_weight)
            L_out[rows] += value
            if groups is not None:
                group = groups.groups.of_sample(ctx.geometry, index, light, ls)
                groups.add(rows, value, group if np.ndim(group) == 0 else group[rows])
            if parts is not None:
                parts.gathered[rows] += lightpasses.split(value, lightpasses.kind_shares(
                    part, wo[rows], ls.L[rows], signed_cosine=not s.clamp_n_dot_l, left_out=left_out))
    # 2. The light one BSDF-sampled direction finds (lamps with extent, emitters, the world).
    check_stop(ctx)
    ray = None
    if not light_samples_only and (trace_all or (ctx.extra.get("bsdf_rays", False) and s.light_sampling != "light"
                                                 and traced.any())):
        gather = s.light_sampling != "light" and ctx.extra.get("bsdf_rays", False)
        ray_groups = None if groups is None else lightgroups.GroupLight(groups.groups, m)
        finds, ray = bsdf_ray(ctx, surface, shader, wo, pixel, sample, offsets, mis, traced, recorder,
                              dimension, gather, carried_pdf, seen_by, tree_N=tree_N, light_path=light_path,
                              carried_origin=carried_origin, carried_N=carried_N, groups=ray_groups,
                              inside=path.inside, carried_receiver=path.carried_receiver, min_pdf=path.min_pdf,
                              throughput=throughput, cull=path.caustics_cull)
        if clamping:
            f = clamp_.scale(finds, throughput, limit)
            finds = finds * f[:, None]
            if ray_groups is not None:
                ray_groups.scale(f)
        L_out += finds
        if groups is not None:
            groups.L += ray_groups.L
        if found is not None:
            found += finds
        if parts is not None and ray is not None:
            c = shader.closures.rows(ray.rows)
            parts.ray_shares = lightpasses.sample_shares(c, wo[ray.rows], ray.D, ray.kind, ray.delta, ray.transmit,
                                                         ray.slot)
            parts.gathered[ray.rows] += lightpasses.split(finds[ray.rows], parts.ray_shares)
    return L_out, shadow_rays, ray


def shadow_caustics(ctx: Context, surface, shader, wo, rows: np.ndarray, index: int, light, ls, NL: np.ndarray,
                    pixel, sample, count: int, j: int, dimension: int, path: PathState, light_path, L_out, recorder,
                    groups, parts, clamping: bool, throughput, limit) -> np.ndarray:
    """Light the samples `rows` of caustics light `light` (its index, sample j of count) that MNEE walks
    (core/integrators/mnee.py) into L_out (and the recorder, light groups and light passes), as Cycles'
    integrate_surface_direct_light does: the rows (r,) int64 left for the ordinary light sample."""
    flags = ctx.geometry.caustics_flags(surface.prim[rows])
    behind = NL[rows] < 0.0                       # (Cycles: the light behind the shading normal, a transmission)
    rows = rows[~(((flags & mnee_.CASTER) != 0) & behind)]
    flags = ctx.geometry.caustics_flags(surface.prim[rows])
    walk = rows[((flags & mnee_.RECEIVER) != 0) & ~(NL[rows] < 0.0)]
    if not len(walk):
        return rows
    # (the numbers that sample rough interfaces: two dimensions of the light's own four)
    u_h = sampling.sample_2d(ctx.settings.seed, pixel[walk], sample[walk] * count + j,
                             dimension=light_dimension(index) + dimension + 2)
    found = mnee_.sample(ctx, surface, shader, wo, walk, light, ls, u_h,
                         None if path.light_path is None else light_path)
    if not found.done.any():
        return rows
    done = walk[found.done]
    rays = found.rays
    s = ctx.settings
    if not light.cast_shadow:
        through = np.ones((len(done), 1))
    elif ctx.extra.get("transparent", False):
        shadow_paths = graph_.paths_at(graph_.with_flags(light_path, graph_.PATH_SHADOW), done)
        through = shadows.transmittance(ctx, rays, s.transparent_max_bounces, None, shadow_paths,
                                        shadow_blockers(ctx, light, ls, done))
    else:
        through = shadows.visible(ctx.geometry.tracer, rays)[:, None].astype(np.float64)
    color = ls.color if ls.color.ndim == 1 else ls.color[done]
    value = (1.0 / count) * color * found.value[found.done] * through
    if clamping:
        value = clamp_.clamped(value, None if throughput is None else throughput[done],
                               limit if np.ndim(limit) == 0 else limit[done], count)
    recorder.contribution(index, done, value, np.ones(len(done)))
    L_out[done] += value
    if groups is not None:
        group = groups.groups.of_sample(ctx.geometry, index, light, ls)
        groups.add(done, value, group if np.ndim(group) == 0 else group[done])
    if parts is not None:
        part = shader.closures.rows(done)
        parts.gathered[done] += lightpasses.split(value, lightpasses.kind_shares(part, wo[done],
                                                                                 found.first[found.done]))
    return np.setdiff1d(rows, done)


def bsdf_ray(ctx: Context, surface, shader, wo, pixel, sample, offsets, mis: np.ndarray, traced: np.ndarray,
             recorder: Recorder, dimension: int = 0, gather: bool = True, carried_pdf=None, seen_by=HIDDEN_FROM_CAMERA,
             *, tree_N: np.ndarray, carried_origin=None, carried_N=None, groups=None, light_path=None, inside=None,
             carried_receiver=None, min_pdf=None, throughput=None, cull=None):
    """Return (the light (m, 3) one direction sampled from each hit's closures finds, the BsdfRay).
    cull: (m,) bool the hits whose rays find no caustics lamp (PathState.caustics_cull), or None.

    The light: a lamp with extent in front of what the ray hits, an emissive surface it hits, or the
    world it escapes to, each weighed by MIS against that light's own samples (weight 1 for a constant
    world); nothing unless `gather`. mis, traced: (m,) bool which hits weigh by MIS, which trace a ray.
    carried_pdf: (m,) the pdf of the path's last real bounce (inf: the camera's), for rays that go on
    through a transparent surface. seen_by: the kind of ray that reached each hit (HIDDEN_FROM_* bit, int or
    (m,)); each ray passes the objects hidden from its own kind (ray_kind). tree_N: (m, 3) the normals the hits'
    light samples gave the light tree (tree_normals), for the emitters' MIS pdf. carried_origin, carried_N: (m, 3)
    the ray origin and light-tree normal of the path's last real bounce (with carried_pdf): a ray straight through
    a transparent surface weighs what it finds with the pdfs the light samples at that bounce would have given
    its direction, measured from there (Cycles' mis_origin), not from the transparent surface. groups: a
    lightgroups.GroupLight of the m hits that receives the light found by the group of its source, or None.
    light_path: the graph.LightPaths of the m hits (None: camera rays); each ray carries on its own (path_after).
    inside: (m, V) the media the rays that reached the hits were in, or None (no media): a ray through the surface
    enters or leaves its medium, and what it finds, and its weight for the path beyond, keep exp(-sigma_t t).
    throughput: (m, 3) what the paths carry to the hits, or None (1): a subsurface walk chooses its colour channels
    by it, as Cycles does."""
    s = ctx.settings
    m = len(surface.I)
    light_path = graph_.light_paths(m) if light_path is None else light_path
    u = sampling.sample_2d(s.seed, pixel, sample, dimension=BSDF_DIMENSION + dimension)
    pick = sampling.sample_2d(s.seed, pixel, sample, dimension=BSDF_DIMENSION + 1 + dimension)[:, 0]
    bs = materials_.sample_closures(shader.closures, wo, u, pick, surface.Ng)
    found = np.zeros((m, 3))
    go = np.flatnonzero((bs.pdf > 0.0) & traced)
    if len(go) == 0:
        recorder.bsdf_sample(bs.wi, bs.pdf, found)
        return found, None
    # The ray leaves from a point safely off the surface, on the side it goes to.
    D = bs.wi[go]
    O = spawn_ray(surface.I[go], surface.Ng[go], D, offsets[go] if offsets is not None else np.full(len(go), s.epsilon))
    # Through a Ray Portal: the ray leaves from the portal's Position where it is elsewhere (portal.origins).
    portal = materials_.has(bs.kind[go], materials_.BSDFFlags.PORTAL)
    moved = np.zeros(len(go), bool)
    if portal.any():
        at = go[portal]
        P, moved[portal] = portal_.origins(shader.closures.params[at, bs.slot[at]], surface.I[at], ctx.geometry.origin)
        O[moved] = P[moved[portal]]
    transmit = np.einsum("ij,ij->i", surface.Ng[go], D) < 0.0
    seen_as = ray_kind(bs.kind[go], transmit, np.broadcast_to(np.asarray(seen_by, np.int64), (m,))[go])
    threshold = clear_glass_threshold(s)
    through_clear_glass = (clears_glass(bs.kind[go], shader.closures.params[go, bs.slot[go]], transmit, threshold)
                           if threshold >= 0.0 else None)
    after = path_after(graph_.paths_at(light_path, go), bs.kind[go], transmit, bs.delta[go], surface.t[go],
                       through_clear_glass)
    # Fast GI (Replace): a ray past AO Bounces looks AO Distance far (and its path ends where it meets a surface).
    ao = fast_gi_ray(s, after) & ~materials_.has(bs.kind[go], materials_.BSDFFlags.SUBSURFACE)
    t_max = short_ray_lengths(ctx, surface.prim[go], ao)
    hits = nearest_seen(ctx, O, D, t_max, seen_as, None if surface.time is None else surface.time[go])
    pdf_b = np.where(bs.delta[go], np.inf, bs.pdf[go])
    # A ray that went straight through a transparent surface is still the last real bounce's ray: its MIS
    # weighs with that bounce's pdf (inf for the camera's), as Cycles keeps it across transparent bounces.
    # (a portal's ray is no longer that ray: what it finds is not weighed, pdf inf, as Cycles' PATH_RAY_MIS_SKIP)
    straight = materials_.has(bs.kind[go], materials_.BSDFFlags.STRAIGHT)
    clear = straight & ~portal
    mis_O, mis_N = O, tree_N[go]
    receiver = surface.prim[go]                   # (Light Linking: the object the ray left, or the last real bounce's)
    if carried_receiver is not None and straight.any():
        receiver = np.where(straight, carried_receiver[go], receiver)
    if carried_pdf is not None and clear.any():
        pdf_b = np.where(clear, carried_pdf[go], pdf_b)
        if carried_origin is not None:
            mis_O = np.where(clear[:, None], carried_origin[go], O)
            mis_N = np.where(clear[:, None], carried_N[go], mis_N)
    # Into a BSSRDF: a walk inside the mesh, and a ray that reaches its exit from outside instead of the one traced.
    walks = np.flatnonzero(materials_.has(bs.kind[go], materials_.BSDFFlags.SUBSURFACE))
    weight = bs.weight[go]
    if len(walks):
        at = go[walks]
        weight = weight.copy()
        closure_params = shader.closures.params[at, bs.slot[at]]
        disk = closure_params[:, bssrdf_.DISK] != 0.0               # (Christensen-Burley: the disk, no walk)
        below = np.einsum("ij,ij->i", surface.Ng[at], bs.wi[at]) < 0.0       # (an entry above Ng fails, as Cycles')
        j = len(at)
        exits, P, last_D, last_t, walked = np.zeros(j, bool), np.zeros((j, 3)), np.zeros((j, 3)), np.zeros(j), \
            np.zeros((j, 3))
        prim_uv = (np.zeros(j, np.int64), np.zeros(j), np.zeros(j))
        carried = None if throughput is None else np.broadcast_to(throughput, (m, 3))[at]
        for part, method in ((np.flatnonzero(~disk), "walk"), (np.flatnonzero(disk), "disk")):
            if len(part) == 0:
                continue
            a = at[part]
            if method == "walk":
                found_exit = subsurface_.walk(
                    ctx, surface, a, closure_params[part], shader.closures.N[a, bs.slot[a]], bs.wi[a],
                    np.where(below[part, None], bs.weight[a], 0.0), pixel[a], sample[a], dimension,
                    None if carried is None else carried[part])
                found_exit = (found_exit[0] & below[part],) + found_exit[1:]
            else:
                found_exit = subsurface_.disk(ctx, surface, a, closure_params[part], bs.weight[a], pixel[a],
                                              sample[a], dimension)
            exits[part] = found_exit[0]
            for target, value in zip(prim_uv, found_exit[1]):
                target[part] = value
            for target, value in zip((P, last_D, last_t, walked), found_exit[2:]):
                target[part] = value
        O[walks], D[walks], exit_hits = subsurface_.exit_ray(exits, prim_uv, P, last_D, last_t)
        hits = Hits(*(None if field is None else np.array(field) for field in hits))
        for field, value in zip(hits[:5], exit_hits[:5]):        # (hit, t, prim, u, v: a walk carries no time)
            field[walks] = value
        weight[walks] = walked
        transmit[walks] = False
        seen_as[walks] = np.broadcast_to(np.asarray(seen_by, np.int64), (m,))[at]
    ray_inside = stretch = attenuation = None
    t_hit = np.where(hits.hit, hits.t, np.inf)
    if inside is not None:
        # The ray's media (the hit's own where it went through the surface), and what they let through to its hit.
        ray_inside = media_beyond(ctx, surface, go, inside[go], goes_through(bs.kind[go], transmit))
        # (Fast GI's short ray that meets nothing within its reach leaves every mesh's medium, the world's alone kept:
        #  Cycles cleans the volume stack of a ray that hit nothing, volume_stack_clean, as if it had left the meshes)
        ray_inside[ao & ~hits.hit] = 0
        stretch = ctx.extra["media"].along(ray_inside, O, D)
        attenuation = stretch.transmittance(t_hit)
        if len(walks):
            attenuation[walks] = 1.0                     # (the walk's ray is no ray through the medium outside)
            # A walk's exit in the media it is in there: its stack across the segment from the entry to the exit.
            left = np.flatnonzero(exits)
            if len(left):
                ray_inside[walks[left]] = subsurface_.media_across(
                    ctx, ray_inside[walks[left]], surface.I[at[left]], P[left], ctx.geometry.owners(surface.prim[at[left]]))
    ray = BsdfRay(go, O, D, hits, weight, bs.kind[go], bs.delta[go], transmit, pdf_b, seen_as, mis_O, mis_N,
                  after, ray_inside, attenuation, receiver, bs.slot[go], ao)
    for kind, mask in (("reflect", ~ray.transmit & ~portal), ("refract", ray.transmit & ~portal), ("portal", portal)):
        if mask.any():
            recorder.rays(kind, O[mask], D[mask], t_hit[mask])
    if moved.any():                                 # (a portal's jump, from the hit to where its ray leaves)
        jump = O[moved] - surface.I[go[moved]]
        length = np.sqrt(np.einsum("ij,ij->i", jump, jump))
        recorder.rays("portal_jump", surface.I[go[moved]], jump / length[:, None], length)
    if not gather:
        recorder.bsdf_sample(bs.wi, bs.pdf, found)
        return found, ray
    use_mis = mis[go] & (~bs.delta[go] | (clear & np.isfinite(pdf_b)))
    holdouts = ctx.geometry.hides(HOLDOUT)
    ray_groups = None if groups is None else lightgroups.GroupLight(groups.groups, len(go))
    # (the surface it hits is the next vertex, whose Ambient Occlusion and Bevel nodes trace with its keys)
    keys = None
    if getattr(ctx.materials, "traces", False):
        below = np.full(len(go), np.inf) if min_pdf is None else min_pdf[go]
        keys = (pixel[go], sample[go], dimension + VERTEX_DIMENSIONS, np.where(straight, below, np.minimum(below, pdf_b)))
    if len(walks):
        # A walk's exit gathers nothing on the way (its light samples and bounce come at the next vertex).
        traced_rays = np.setdiff1d(np.arange(len(go)), walks)
        found[go[walks]] = 0.0
        if ray_groups is not None:
            ray_groups = lightgroups.GroupLight(groups.groups, len(traced_rays))
        pick = lambda x: None if x is None else x[traced_rays]          # noqa: E731
        keys = None if keys is None else (pick(keys[0]), pick(keys[1]), keys[2], pick(keys[3]))
        found[go[traced_rays]] = bs.weight[go[traced_rays]] * gather_light(
            ctx, O[traced_rays], D[traced_rays], Hits(*(None if field is None else field[traced_rays] for field in hits)),
            pdf_b[traced_rays], use_mis[traced_rays], pick(seen_as == HIDDEN_FROM_CAMERA) if holdouts else None,
            N=pick(mis_N),
            mis_O=pick(mis_O), groups=ray_groups, seen_as=pick(seen_as),
            stretch=None if stretch is None else stretch.rows(traced_rays),
            paths=graph_.paths_at(after, traced_rays), receiver=pick(receiver), keys=keys, t_max=pick(t_max),
            ao=pick(ao), cull=None if cull is None else cull[go][traced_rays])
        if groups is not None:
            groups.add_rows(go[traced_rays], ray_groups, bs.weight[go[traced_rays]])
        recorder.bsdf_sample(bs.wi, bs.pdf, found)
        return found, ray
    found[go] = bs.weight[go] * gather_light(ctx, O, D, hits, pdf_b, use_mis,
                                             seen_as == HIDDEN_FROM_CAMERA if holdouts else None, N=mis_N,
                                             mis_O=mis_O, groups=ray_groups, seen_as=seen_as, stretch=stretch,
                                             paths=after, receiver=receiver, keys=keys, t_max=t_max, ao=ao,
                                             cull=None if cull is None else cull[go])
    if groups is not None:
        groups.add_rows(go, ray_groups, bs.weight[go])
    recorder.bsdf_sample(bs.wi, bs.pdf, found)
    return found, ray


def media_beyond(ctx: Context, surface, rows: np.ndarray, inside: np.ndarray, through: np.ndarray) -> np.ndarray:
    """The media (k, V) of rays leaving the hits `rows` (k,) of `surface` from the media `inside` (k, V) they were
    reached in: where a ray goes `through` (k,) bool the surface, it enters the hit material's medium through a front
    face or leaves it through a back face (Cycles' volume_stack_enter_exit, for a transmission's label)."""
    media = ctx.extra["media"]
    return media.crossed(inside, surface.material[rows], surface.backfacing[rows], through,
                         media.objects_of(ctx.geometry, surface.prim[rows]))


def lights_itself(surface, emitters, ls, NL: np.ndarray, NgL: np.ndarray) -> np.ndarray:
    """(m,) bool: the emitters' light samples on the very triangle they light, towards the side they are lit from."""
    # Cycles skips them (shade_surface.h, integrate_surface_direct_light): a point on its own triangle sees it
    # edge-on, yet the triangle's sample from there covers a hemisphere, so that a reflective emitter's back
    # (or front) would reflect its own emission. Ng.L > 0 for reflection, Ng.L < 0 for light through it from behind.
    own = emitters.same_emitter(ls.emitter, surface.prim)       # (a quad: either of its triangles)
    return own & (np.where(NL < 0.0, -NgL, NgL) > 0.0)


def terminator_bent(ctx: Context, surface, shader):
    """The shader with each hit's object's Shading Offset multiplier on its closures (closures.terminator_term),
    where the terminator fix is on and some object has one."""
    if not ctx.settings.terminator_fix or ctx.geometry is None:
        return shader
    multipliers = ctx.geometry.terminator_multipliers(surface.prim)
    if multipliers is None:
        return shader
    return shader._replace(closures=shader.closures._replace(terminator=multipliers))


def aim_shadow_rays(s, surface, rows: np.ndarray, ls, NL: np.ndarray, NgL: np.ndarray, offsets,
                through=None, geometry=None) -> shadows.ShadowRays:
    """Return the shadow rays of the hits `rows` towards their light samples (robust or epsilon offsets);
    through (r,) bool: the hits whose closures let light through from behind (lets_light_through), which reach the
    lights behind them by a ray from their back (reaching_from_behind)."""
    I = surface.I[rows]
    Ng = surface.Ng[rows]
    behind = None if through is None else through & (NgL[rows] < 0.0)
    if s.terminator_fix:
        cutoff = (np.full(len(rows), s.terminator_offset) if geometry is None
                  else geometry.terminator_offsets(surface.prim[rows], s.terminator_offset))
        if through is not None:
            behind = reaching_from_behind(through, surface.smooth[rows] & (cutoff > 0.0), NL[rows], NgL[rows])
        I = shadows.lift_terminator(surface, rows, NL[rows], NgL[rows], cutoff)
    elif s.shadow_rays_for_backfacing or s.visibility_normal != "face":
        # Switches that cast rays towards lights behind the face: offset to the light's side.
        Ng = Ng * np.where(NgL[rows] < 0.0, -1.0, 1.0)[:, None]
    if behind is not None and behind.any():
        I = np.where(behind[:, None], surface.I[rows], I)
        Ng = np.where(behind[:, None], -surface.Ng[rows], Ng)
    if s.shadow_method == "robust":
        rays = shadows.robust_rays(I, Ng, offsets[rows], ls.position[rows], ls.L[rows], ls.distance[rows],
                                   s.reduce_t_max, None if ls.normal is None else ls.normal[rows])
    else:
        rays = shadows.epsilon_rays(I, ls.L[rows], ls.distance[rows], s.epsilon, s.reduce_t_max)
    # (a shadow ray carries its path's time: where moving objects block it)
    return rays if surface.time is None else rays._replace(time=surface.time[rows])



def reaching_from_behind(through: np.ndarray, lifts: np.ndarray, NL: np.ndarray, NgL: np.ndarray) -> np.ndarray:
    """Which light samples (r,) bool a surface that lets light through (`through` (r,) bool) reaches by a shadow ray
    from its back (from I, offset along -Ng, its own face not skipped). Where the terminator fix moves its shadow rays
    (`lifts` (r,) bool: a smooth triangle with a Geometry Offset above 0), the shading normal decides, as Cycles'
    shadow_ray_offset: a light behind N (N.L < 0, `NL`) is reached from the back, and one in front of the face
    (Ng.L > 0, `NgL`) is then behind the surface itself, whose own face blocks the ray (Cycles keeps such a ray from
    skipping its own triangle); elsewhere the face decides (Ng.L < 0)."""
    return through & np.where(lifts, NL < 0.0, NgL < 0.0)


def gather_light(ctx: Context, O: np.ndarray, D: np.ndarray, hits, pdf_b: np.ndarray, use_mis: np.ndarray,
                 camera=None, N=None, mis_O=None, groups=None, seen_as=None, stretch=None,
                 paths=None, receiver=None, keys=None, t_max=None, ao=None, cull=None) -> np.ndarray:
    """The light (k, 3) that rays O + t D (k, 3) bring back, ending at `hits` (the tracer's Hits): lamps with
    extent in front of the hit, the emission of the surface hit, or the world where the ray escapes, each
    weighed by MIS (where `use_mis` (k,) bool) with pdf_b (k,), the pdf of the bounce that sent the ray.
    camera: (k,) bool which rays are still a camera path's (through Transparent closures), or None: a holdout
    object such a ray hits emits nothing (it is a hole in the film, path.hold_out). N: (k, 3) the normals the light
    tree weighed the emitters by at the rays' origins (tree_normals), or None (unknown): the emitters' MIS pdf
    picks each triangle with the probability their light samples gave it. mis_O: (k, 3) where the light samples that
    MIS weighs against were taken (the last real bounce's ray origin, N its normal there), or None (O): a ray that
    went straight on through transparent surfaces from there still has the direction D, and a light it finds at
    distance t from O is at |O + t D - mis_O| from there (Cycles' mis_origin); an emitter's radiance is the actual
    hit's; a lamp is met where the line from mis_O meets it past O (the same point, but for a round lamp with soft
    falloff: the disk facing mis_O, the one its light samples there saw), with the radiance it sends along D.
    groups: a lightgroups.GroupLight of the k rays that receives each find by the group of its source, or None.
    seen_as: (k,) int each ray's kind (HIDDEN_FROM_* bit, ray_kind), or None: a lamp hidden from a kind of ray
    (its Ray Visibility) is passed by rays of that kind. stretch: the media the rays cross (core/volumes Stretch),
    or None (none): each find keeps exp(-sigma_t t) of its light over its distance t from O (inf for the world), and
    the media's emission along the ray up to its hit is found too (not weighed: no light sample finds it).
    paths: the graph.LightPaths the k rays carry, which a textured emitter they hit is shaded for (None: a ray other
    than the camera's, with no bounces counted).
    receiver: (k,) int64 the triangle each ray left, or None (no linking): a ray other than the camera's finds no
    emitter that does not light the receiver's object (Light Linking), and no emitter object whose shadows a blocker
    set casts (Shadow Linking: its light samples alone find it, linking.found_by_bounces).
    keys: (pixel, sample (k,) int64, the dimension shift of the vertex the rays reach, min_pdf (k,)) with which a
    textured emitter's Ambient Occlusion and Bevel nodes trace (shader_rays.for_hits), or None: they trace nothing.
    t_max: (k,) how far the rays looked (None: inf): one that escapes finds no lamp beyond. ao: (k,) bool the rays of
    Fast GI (fast_gi_ray), or None: the world's light they escape to is scaled by the settings' ao_factor (its MIS
    weight kept, as Cycles' integrate_background). cull: (k,) bool the rays that find no caustics lamp (a caster's ray
    on a path that left a receiver: Cycles' PATH_MNEE_CULL_LIGHT_CONNECTION, that light is MNEE's), or None."""
    light_L = np.zeros((len(O), 3))
    sigma = stretch
    if stretch is not None:
        light_L += volumes.emitted(stretch, np.where(hits.hit, hits.t, np.inf))
        lightgroups.add_emitted(groups, np.arange(len(O)), light_L, stretch)   # (by the medium's object's group)
    t_limit = np.where(hits.hit, hits.t, np.inf if t_max is None else t_max)
    away = np.zeros(len(O), bool) if mis_O is None else (mis_O != O).any(axis=1)
    # From mis_O: how far each ray's end (inf: none) and its start O are.
    t_mis = t_limit
    moved = np.flatnonzero(away)
    if len(moved):
        t_mis = np.where(away & hits.hit, np.linalg.norm(O + np.where(hits.hit, hits.t, 0.0)[:, None] * D - mis_O,
                                                         axis=1), t_limit)
        t_start = np.linalg.norm(O[moved] - mis_O[moved], axis=1)
    # a. Lamps with extent in front of the hit (they never block, as in Cycles).
    for index in ctx.extra["hittable"]:
        light = ctx.lights[index]
        if not light.is_(LAMP):                   # emitters and the world are found below
            continue
        lh = light.hit(O, D, t_limit, **lamp_paths(light, paths))
        found, radiance, pdf_l = lh.hit, lh.radiance, lh.pdf
        kind = np.zeros(len(O), np.int64) if seen_as is None else np.asarray(seen_as, np.int64)
        sees = (kind & light.unseen_by) == 0
        if not light.use_mis:             # Multiple Importance off: light samples alone find it, the camera sees it
            sees &= (kind == HIDDEN_FROM_CAMERA) & (not light.is_(LightFlags.DISTANT))
        if len(moved):
            # The lamp as the light samples at mis_O see it (a round lamp with soft falloff is a disk facing that
            # point), met on this stretch of the line, past O: its pdf from there, the radiance it sends along D.
            seen = light.hit(mis_O[moved], D[moved], t_mis[moved],
                             **lamp_paths(light, None if paths is None else graph_.paths_at(paths, moved)))
            past = seen.hit & (seen.t > t_start)
            found, radiance, pdf_l = found.copy(), radiance.copy(), pdf_l.copy()
            found[moved] = past
            radiance[moved] = np.where(past[:, None], seen.radiance, 0.0)
            pdf_l[moved] = np.where(past, seen.pdf, 0.0)
        if receiver is not None and (ctx.geometry.linked or light.light_membership != linking.ALL_SETS):
            sees &= (kind == HIDDEN_FROM_CAMERA) | linking.in_sets(light.light_membership,
                                                                   ctx.geometry.links(receiver, 0))
        if cull is not None and light.caustics:
            sees &= ~cull
        found = found & sees
        radiance = np.where(sees[:, None], radiance, 0.0)
        if sigma is not None:
            t_lamp = lh.t.copy()
            if len(moved):
                t_lamp[moved] = np.where(past, seen.t - t_start, np.inf)
            radiance = radiance * sigma.transmittance(np.where(found, t_lamp, 0.0))
        if not found.any():
            continue
        w = np.where(use_mis, power_heuristic(pdf_b, mis_count(ctx, light) * pdf_l), 1.0)
        light_L += radiance * w[:, None]
        if groups is not None:
            groups.add(np.arange(len(O)), radiance * w[:, None], groups.groups.lights[index])
    # b. An emissive surface the ray hits: its emission, weighed against the emitters' own samples.
    struck = np.flatnonzero(hits.hit)
    emitters = ctx.extra.get("emitters")
    if len(struck) and ctx.extra.get("emissive", False):
        where = surface_at_hits(ctx.geometry, hits.prim[struck], hits.u[struck], hits.v[struck], O[struck],
                                D[struck], hits.t[struck], times=None if hits.time is None else hits.time[struck])
        # (Each material's emission as its light samples see it: head-on, so that both strategies of
        #  MIS weigh the same radiance; a coat tint's change with angle is seen by the camera only.)
        emitted = ctx.materials.emission[where.material]
        textured = ctx.materials.graph_emits[where.material]
        if textured.any():                        # a texture's emission, evaluated where the ray landed
            rows = np.flatnonzero(textured)
            emitted = emitted.copy()
            emitted[rows] = graph_emission(ctx.geometry, ctx.materials, hits.prim[struck][rows], O[struck][rows],
                                           D[struck][rows], hits.t[struck][rows],
                                           None if paths is None else graph_.paths_at(paths, struck[rows]),
                                           ctx, None if keys is None else tuple(
                                               key if np.ndim(key) == 0 else key[struck[rows]] for key in keys),
                                           None if hits.time is None else hits.time[struck][rows])
        if camera is not None and camera[struck].any():
            emitted = np.where((camera[struck] & ctx.geometry.hidden(hits.prim[struck], HOLDOUT))[:, None], 0.0,
                               emitted)
        if receiver is not None and ctx.geometry.linked:
            emitted = np.where(unlinked_finds(ctx, hits.prim[struck], receiver[struck],
                                              None if seen_as is None else np.asarray(seen_as)[struck])[:, None],
                               0.0, emitted)
        pdf_l, n_l = np.zeros(len(struck)), 1
        if emitters is not None:
            index = emitters.index_of_prim(hits.prim[struck])
            known = index >= 0
            if known.any():
                origin = O if mis_O is None else mis_O
                pdf_l[known] = emitters.pdf_of_hits(origin[struck][known], index[known], D[struck][known],
                                                    t_mis[struck][known],
                                                    N=None if N is None else N[struck][known],
                                                    times=None if hits.time is None else hits.time[struck][known])
            n_l = mis_count(ctx, emitters)
        w = np.where(use_mis[struck], power_heuristic(pdf_b[struck], n_l * pdf_l), 1.0)
        if sigma is not None:
            emitted = emitted * sigma.rows(struck).transmittance(hits.t[struck])
        light_L[struck] += emitted * w[:, None]
        if groups is not None:
            groups.add(struck, emitted * w[:, None], groups.groups.of_prims(ctx.geometry, hits.prim[struck]))
    # c. The world, where the ray escapes and its kind sees it (a camera path's ray, straight on through clear
    #    surfaces, where the camera does and the film is opaque; any other where the world lights: Cycles' visibility
    #    by the ray's flags): a constant world with weight 1, an image by MIS.
    world = ctx.extra.get("world_light")
    missed = np.flatnonzero(~hits.hit)
    if world is not None and len(missed):
        flags = np.zeros(len(missed), np.int64) if paths is None else np.asarray(paths.flags)[missed]
        still_camera = (flags & graph_.PATH_CAMERA) != 0
        sees = np.where(still_camera, bool(world.camera) and not ctx.settings.transparent_background,
                        bool(world.lights))
        if ctx.settings.transparent_background:     # (through clear glass: the film's alpha, Transparent Glass)
            sees &= (flags & graph_.PATH["clear_glass"]) == 0
        if getattr(world, "hidden", 0) and seen_as is not None:     # (its Ray Visibility: hidden from these kinds)
            sees &= still_camera | ((np.asarray(seen_as)[missed] & world.hidden) == 0)
        missed = missed[sees]
    if world is not None and len(missed):
        L_world = (world.radiance(D[missed]) if paths is None     # (a graph world: evaluated for each ray's path)
                   else world.radiance_seen(D[missed], graph_.paths_at(paths, missed)))
        if sigma is not None:
            L_world = L_world * sigma.rows(missed).transmittance(np.full(len(missed), np.inf))
        w = np.ones(len(missed))
        sampler = ctx.extra.get("world_sampler")
        if sampler is not None:
            w = np.where(use_mis[missed], power_heuristic(pdf_b[missed],
                         mis_count(ctx, sampler) * sampler.pdf(D[missed])), 1.0)
        if ao is not None:
            L_world = L_world * np.where(ao[missed], ctx.settings.ao_factor, 1.0)[:, None]
        light_L[missed] += L_world * w[:, None]
        if groups is not None:
            groups.add(missed, L_world * w[:, None], groups.groups.world)
    return light_L


def fast_gi_ray(settings, paths) -> np.ndarray:
    """Which rays (k,) bool, carrying `paths` (graph.LightPaths of k rays, their counters past the bounce that sent
    them: rays.path_after), are Fast GI's short rays (Cycles' path_state_ao_bounce, Replace): with ao_bounces and
    ao_factor set, those past ao_bounces bounces, counted as bounce - transmission - (1 if glossy > 0) + 1."""
    bounces = getattr(settings, "ao_bounces", 0)
    if not bounces or not getattr(settings, "ao_factor", 0.0) or settings.integrator != "path":
        return np.zeros(len(paths.bounce), bool)
    depth = np.asarray(paths.bounce) - np.asarray(paths.transmission) - (np.asarray(paths.glossy) > 0) + 1
    return depth > bounces


def fast_gi_scatter(settings, n: int, bounce=0, transmission=0, glossy=0) -> np.ndarray:
    """Which of n stretches' scattering points (k,) bool send Fast GI's short rays along their phase direction: those
    whose paths, `bounce`, `transmission`, `glossy` (scalars or (n,)) the counters of the ray the stretch is on, are
    past AO Bounces once the scattering event counts as one more bounce (Cycles' path_state_next for a volume scatter,
    then path_state_ao_bounce: fast_gi_ray)."""
    paths = graph_.light_paths(n, flags=graph_.PATH["volume_scatter"], bounce=np.asarray(bounce) + 1,
                               transmission=transmission, glossy=glossy)
    return fast_gi_ray(settings, paths)


def short_ray_lengths(ctx: Context, prim: np.ndarray, ao: np.ndarray) -> np.ndarray:
    """How far rays leaving the triangles `prim` (k,) int64 look: (k,) float64 inf, and where `ao` (k,) bool (Fast
    GI's short rays, fast_gi_ray) their object's own AO Distance or the render's (geometry.ao_distances)."""
    t_max = np.full(len(prim), np.inf)
    if ao.any():
        t_max[ao] = ctx.geometry.ao_distances(prim[ao], ctx.settings.ao_distance)
    return t_max


def shadow_blockers(ctx: Context, light, ls, rows: np.ndarray):
    """The shadow membership (r,) uint64 of the samples `rows` of `light` (the blocker sets that cast its shadows,
    Shadow Linking), or None where nothing in the render is shadow-linked."""
    if not (ctx.geometry.shadow_linked or linking.shadow_linked(light)):
        return None
    return linking.memberships(ctx.geometry, light, ls, 3)[rows]


def unlinked_finds(ctx: Context, prim: np.ndarray, receiver: np.ndarray, seen_as) -> np.ndarray:
    """Which emissive triangles `prim` (k,) that rays from triangles `receiver` (k,) hit send them nothing: (k,)
    bool. For rays other than the camera's (seen_as (k,) int, None: a bounce's): an emitter object that does not
    light the receiver's object (Light Linking), or whose shadows a blocker set casts (its light samples alone find
    it, as linking.found_by_bounces)."""
    geometry = ctx.geometry
    unlinked = ~linking.in_sets(geometry.links(prim, 2), geometry.links(receiver, 0))
    unlinked |= geometry.links(prim, 3) != np.uint64(linking.ALL_SETS)
    if seen_as is not None:
        unlinked &= seen_as != HIDDEN_FROM_CAMERA
    return unlinked


def lamp_paths(light, paths) -> dict:
    """The keyword a lamp's sample or hit takes for the paths its light reaches (graph.LightPaths, or None): {"paths":
    paths} for a lamp whose node tree is a program (core/lights/lamp_graph.py: it reads their depths), else {}."""
    return {"paths": paths} if getattr(light, "lamp_nodes", None) is not None else {}


def world_samples_seen(light, ls, paths):
    """The world's light samples `ls` with the colour its program gives each with the path at the vertex it lights
    (graph.LightPaths, or None: no bounces), EMISSION alone as the flags (World.samples_seen: a graph reading Light
    Path's depths, which the bake fixes at the first bounce); any other light's as they are."""
    world = getattr(light, "world", None)
    if world is None or not getattr(world, "samples_seen", False) or world.seen is None:
        return ls
    n = len(ls.L)
    paths = graph_.light_paths(n, flags=0) if paths is None else graph_.as_light_paths(paths, n)._replace(
        flags=np.zeros(n, np.int64), cone=np.zeros(n), spread=np.zeros(n))
    return ls._replace(color=world.seen.along(ls.L, paths))


def textured_samples(ctx: Context, emitters, points: np.ndarray, ls, paths=None, times=None):
    """The emitters' samples `ls` of points (n, 3), with what each textured triangle emits where its sample
    landed (its node graph evaluated there) in place of the triangle's estimate: a LightSample with (n, 3) colour.
    paths: the graph.LightPaths the light is shaded for (Cycles' light_sample_shader_eval: EMISSION alone, the
    counts of the path at each point, and no ray footprint: a Bump there is flat, as in Cycles), or None. times: (n,)
    the points' times in the shutter (a moving emitter where it was sampled then), or None."""
    color = np.array(np.broadcast_to(ls.color, (len(points), 3)))
    rows = np.flatnonzero(emitters.textured[ls.emitter] & (ls.strength > 0.0))
    if len(rows):
        shaded = None if paths is None else graph_.paths_at(paths, rows)._replace(cone=np.zeros(len(rows)),
                                                                                  spread=np.zeros(len(rows)))
        color[rows] = graph_emission(ctx.geometry, ctx.materials, emitters.prim[ls.emitter[rows]], points[rows],
                                     ls.L[rows], ls.distance[rows], shaded,
                                     times=None if times is None else np.asarray(times)[rows])
    return ls._replace(color=color)


def graph_emission(geometry, materials, prim: np.ndarray, O: np.ndarray, D: np.ndarray, t: np.ndarray,
                   paths=None, ctx=None, keys=None, times=None) -> np.ndarray:
    """What the surfaces at O + t D on triangles prim (n,) int64 emit back along -D (n, 3) float64, by their
    materials' node graphs (a texture's emission), to rays carrying the paths `paths` (graph.LightPaths of n rows;
    None: a ray other than the camera's with no bounces counted, as the emitters' estimates take it).

    The barycentrics come from the point itself (a light sample's point has no ray hit of its own), as in the
    C twin (direct.c graph_emission). ctx, keys: the context and the (pixel, sample, dimension, min_pdf) of a BSDF
    ray's next vertex, with which its Ambient Occlusion and Bevel nodes trace (Cycles shades the surface a bounce
    hits in full), or None: they trace nothing (a light sample's emitter, as Cycles). times: (n,) the rays' times
    in the shutter, where a moving emitter is met, or None."""
    if len(prim) == 0:
        return np.zeros((0, 3))
    V = geometry.triangle_data(prim, smooth=False, times=times).corners
    u, v = barycentrics(V, O + t[:, None] * D)
    where = surface_at_hits(geometry, prim, u, v, O, D, t, times=times)
    paths = graph_.light_paths(len(prim), flags=0) if paths is None else paths
    rays = None if keys is None else shader_rays.for_hits(ctx, where, *keys)
    return materials.shade(where.material, where.N, -D, where, geometry, paths, rays=rays).emission


def barycentrics(V: np.ndarray, P: np.ndarray) -> tuple:
    """The barycentrics (u, v) (n,) float64 of points P (n, 3) in the planes of triangles V (n, 3, 3): P = (1 - u
    - v) V0 + u V1 + v V2 for points on them (the nearest such point otherwise)."""
    e1, e2, d = V[:, 1] - V[:, 0], V[:, 2] - V[:, 0], P - V[:, 0]
    d11, d12, d22 = (np.einsum("ij,ij->i", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    p1, p2 = np.einsum("ij,ij->i", d, e1), np.einsum("ij,ij->i", d, e2)
    det = d11 * d22 - d12 * d12
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(det > 0.0, (d22 * p1 - d12 * p2) / det, 1.0 / 3.0)
        v = np.where(det > 0.0, (d11 * p2 - d12 * p1) / det, 1.0 / 3.0)
    return u, v


# The sampling dimensions of the BSDF-sampled direction (2D) and of the closure it picks (core/sampling).
BSDF_DIMENSION = 2
# Each vertex's random numbers are its own: vertex k of a path shifts every sampling dimension by k x this.
VERTEX_DIMENSIONS = schema.constant("VERTEX_DIMENSIONS", 1 << 16, "each path vertex's shift of the sampling dimensions")


class BsdfRay(NamedTuple):
    """The BSDF-sampled rays of the hits that traced one, and what they hit (a path continues from there).

    rows (k,) int64 the hits that traced a ray; O, D (k, 3) their origins and unit directions; hits: the
    tracer's Hits of them; weight (k, 3) f cos / pdf; kind (k,) int32 the sampled closure's BSDF kind;
    delta (k,) bool whether it was a delta closure; transmit (k,) bool whether it went through the surface;
    pdf (k,) the pdf MIS weighs what the ray finds with (inf: none); seen_as (k,) int64 the ray's kind, the
    HIDDEN_FROM_* bit of the objects it passes (ray_kind); mis_O, mis_N (k, 3) the origin and light-tree normal
    that MIS measures the light pdfs from (those of the path's last real bounce: O and its tree normal, unless the
    ray went straight through a transparent surface); path: the graph.LightPaths each ray carries on (path_after);
    inside (k, V) the media the ray is in (None: no media), and attenuation (k, 3) what they let through to the hit
    (None: 1); receiver (k,) int64 the triangle each ray left, whose object decides which emitters its finds may
    light (Light Linking); slot (k,) int64 the sampled closure's slot (None: unknown), its own direction's bump
    shadowing as sampled (lightpasses.sample_shares); ao (k,) bool Fast GI's short rays (fast_gi_ray; None: none),
    whose paths end at their hit
    """

    rows: np.ndarray
    O: np.ndarray
    D: np.ndarray
    hits: object
    weight: np.ndarray
    kind: np.ndarray
    delta: np.ndarray
    transmit: np.ndarray
    pdf: np.ndarray = None
    seen_as: np.ndarray = None
    mis_O: np.ndarray = None
    mis_N: np.ndarray = None
    path: object = None
    inside: np.ndarray = None
    attenuation: np.ndarray = None
    receiver: np.ndarray = None
    slot: np.ndarray = None
    ao: np.ndarray = None


def closures_left_out(kind: np.ndarray, hidden: np.ndarray) -> np.ndarray:
    """Which closures (n, K) bool a light sample leaves out when it is on an object hidden from some kinds of ray
    (Cycles' rule for an emitter's Ray Visibility, by closure type): closures of the diffuse type if it is hidden
    from diffuse rays, of the glossy type if from glossy rays, of the transmission type if from transmission rays,
    glass only if from both glossy and transmission rays (a BSDF ray of such a closure could never find the
    object, so its light samples do not count for it either).

    kind: (n, K) int the closures' BSDF kinds; hidden: (n,) int each sample's object's HIDDEN_FROM_* bits.
    """
    bits = np.asarray(hidden, np.int64)[:, None]
    flags = materials_.flags_of(kind)
    F = materials_.BSDFFlags
    both = HIDDEN_FROM_GLOSSY | HIDDEN_FROM_TRANSMISSION
    return ((((flags & F.DIFFUSE_TYPE) != 0) & ((bits & HIDDEN_FROM_DIFFUSE) != 0))
            | (((flags & F.GLOSSY_TYPE) != 0) & ((bits & HIDDEN_FROM_GLOSSY) != 0))
            | (((flags & F.TRANSMISSION_TYPE) != 0) & ((bits & HIDDEN_FROM_TRANSMISSION) != 0))
            | (((flags & F.GLASS_TYPE) != 0) & ((bits & both) == both)))


def lets_light_through(shader) -> np.ndarray:
    """Which hits have a closure that takes light from behind the surface by light samples (a transmission that
    is not a delta: rough glass): (m,) bool. Their light samples come from both sides (smooth glass is a delta:
    only its BSDF rays find light)."""
    flags = materials_.flags_of(shader.closures.kind)
    F = materials_.BSDFFlags
    return (((flags & F.TRANSMISSION) != 0) & ((flags & F.SINGULAR) == 0)).any(axis=1)


def tree_normals(settings, surface, refracts: np.ndarray) -> np.ndarray:
    """The normals (m, 3) float64 the light tree weighs the emitters by at the hits: the shading normal N, below
    whose horizon no light sample counts (N.L clamped at 0); zero (unknown: light from every side) where a
    closure lets light through from behind, or where N.L is not clamped."""
    if not settings.clamp_n_dot_l:
        return np.zeros_like(surface.N)
    return np.where(refracts[:, None], 0.0, surface.N)


def wants_bsdf_ray(ctx: Context, shader) -> np.ndarray:
    """Which hits trace a BSDF-sampled ray: all where emitters or the world light the scene, else those
    with a closure other than Lambert (a glossy lobe that light samples of a large lamp find poorly)."""
    kind = shader.closures.kind
    glossy = ((kind >= 0) & ~materials_.has(kind, materials_.BSDFFlags.DIFFUSE)).any(axis=1)
    return glossy | bool(ctx.extra.get("bsdf_everywhere", False))


def light_count(ctx: Context, light) -> int:
    """Samples per hit of `light`: 1 for a light without extent or for the inspector's one sample, else
    the settings' light samples."""
    return 1 if light.delta or ctx.light_numbers is not None else max(1, int(ctx.settings.light_samples))


def mis_count(ctx: Context, light) -> int:
    """The count MIS weighs `light`'s samples as (the power heuristic of count x pdf against a BSDF ray's pdf, on both
    sides): its light_count, or 1 for a light that casts no shadow (a lamp's Cast Shadow, the world's Shadows off) or
    has a Max Bounces, as Cycles weighs its one sample per hit. Its unshadowed light samples and shadowed BSDF rays,
    or its BSDF rays at bounces where its samples stop, then no longer make one unbiased estimate, and what they give
    depends on these weights (measured, a floor under a black ceiling lit by an image world without shadows: Cycles
    0.328, one sample's power heuristic 0.329, four samples' 1.029; an image world's Max Bounces 0: 1.1 % darker than
    Cycles with four, 0.25 % brighter with one, as at 1024); elsewhere the weights still sum to one and the image is
    the same. (C: direct.c mis_samples.)"""
    return light_count(ctx, light) if light.cast_shadow and light.max_bounces >= 1024 else 1


def light_numbers(ctx: Context, light, index: int, pixel: np.ndarray, number: np.ndarray, m: int,
                  offset: int = 0) -> np.ndarray:
    """The light's unit-square numbers (m, 2) float64 for m samples: zeros for a light without extent, the
    inspector's fixed point, or the light's progressive pattern (its dimensions shifted by `offset` at a path's
    later vertices)."""
    if light.delta:
        return np.zeros((m, 2))
    if ctx.light_numbers is not None:
        return np.broadcast_to(np.asarray(ctx.light_numbers[index], np.float64), (m, 2))
    return sampling.sample_2d(ctx.settings.seed, pixel, number, dimension=light_dimension(index) + offset)
