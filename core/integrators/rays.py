"""Rays that leave surfaces and the camera: where a new ray starts, what it meets, which kind of ray it is.

Every integrator starts its rays the same ways, so they live here once: a ray off a surface starts a safe distance
off it, on the side it goes to (shadows.spawn_ray); a ray of one kind passes the objects hidden from that kind
(`nearest_seen`, Object > Visibility > Ray Visibility); a bounce's ray is a diffuse, glossy or transmission ray by
what the BSDF that sent it is (`ray_kind`), and carries on the path's flags and bounce counts (`path_after`, what
the Light Path node reads); camera rays see the world and the lamps they pass (`camera_hits`).
"""
from __future__ import annotations

import numpy as np

from .. import materials as materials_
from .. import vectors, volumes
from ..camera import camera as camera_
from ..materials import graph as graph_
from ..native import schema
from ..geometry.surface import surface_at_hits
from ..lights import LightFlags
from ..visibility import (HIDDEN_FROM_CAMERA, HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY,
                          HIDDEN_FROM_TRANSMISSION)
from . import clamp as clamp_
from . import lightgroups, shadows
from .base import Context, Recorder


def camera_hits(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, recorder: Recorder,
                limit=np.inf, groups=None, stretch=None, times=None) -> tuple:
    """What camera rays O, D (n, 3) up to t_max (n,) meet: (L (n, 3) the world where they escape, where the
    camera sees it, plus the lamps with extent they pass, each ray's capped at `limit` (sample clamping); the
    tracer's hits; the hit rows (m,) int64; the hits' Surface, or None when nothing was hit). groups: a
    lightgroups.GroupLight of the n rays that receives L split by source, or None. stretch: the media the rays start
    in (core/volumes Stretch), or None: the world and lamps they see keep exp(-sigma_t t) of their light over their
    distance t (inf for the world), and L includes the media's emission up to the hit. times: (n,) the rays' times
    in the shutter (object motion blur: where moving objects are; the Surface carries them on), or None."""
    sigma = stretch
    s = ctx.settings
    # 1. The nearest hit of each camera ray (t), past objects hidden from the camera.
    found = nearest_seen(ctx, O, D, t_max, times=times)
    hit = np.flatnonzero(found.hit)
    # 2. What rays that hit nothing see: the world, where it is visible to the camera.
    L_out = np.zeros((len(O), 3))
    world = ctx.extra.get("world_light")
    if world is not None and world.camera and not s.transparent_background:
        missed = np.flatnonzero(~found.hit)
        L_out[missed] = world.radiance_seen(D[missed])          # (camera rays: a world's graph per ray)
        if sigma is not None:
            L_out[missed] *= sigma.rows(missed).transmittance(np.full(len(missed), np.inf))
        if groups is not None:
            groups.add(missed, L_out[missed], groups.groups.world)
    # 3. Lamps seen by the camera in front of what it hits (area lights, round lights), suns where it escapes.
    L_out += lamps_seen(ctx, O, D, np.where(found.hit, found.t, t_max), groups, escaped=~found.hit, sigma=sigma)
    if stretch is not None:
        emitted = volumes.emitted(stretch, np.where(found.hit, found.t, t_max))
        L_out += emitted
        lightgroups.add_emitted(groups, np.arange(len(O)), emitted, stretch)
    # What the camera sees itself is a direct contribution (Clamp Direct).
    if np.isfinite(limit):
        f = clamp_.scale(L_out, None, limit)
        L_out = L_out * f[:, None]
        if groups is not None:
            groups.scale(f)
    if len(hit) == 0:
        recorder.hits(O, D, None, found.hit)
        return L_out, found, hit, None
    # The surface at each hit: I, Ng, N.
    surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit], vectors.gather(O, hit),
                              vectors.gather(D, hit), found.t[hit], flat_only=not s.smooth_normals,
                              times=None if times is None else times[hit])
    recorder.hits(O, D, surface, found.hit)
    return L_out, found, hit, surface


def nearest_seen(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, kind=HIDDEN_FROM_CAMERA, times=None):
    """The nearest hits (the tracer's Hits) of rays O, D (n, 3) up to t_max (n,) on the objects these rays see: a
    ray goes on past the triangles of objects hidden from its kind (Object > Visibility > Ray Visibility), as if
    they were not there; t stays the distance from O. kind: the rays' HIDDEN_FROM_* bit, one int or (n,) int
    (camera rays by default; ray_kind gives a bounce's). times: (n,) the rays' times in the shutter (where moving
    objects are), or None."""
    geometry = ctx.geometry
    found = geometry.tracer.intersect(O, D, t_max, times)
    kind = np.broadcast_to(np.asarray(kind, np.int64), (len(O),))
    if not geometry.hides(int(np.bitwise_or.reduce(kind)) if len(kind) else 0):
        return found if times is None else found._replace(time=np.asarray(times, np.float64))
    hit, t, prim, u, v = (np.array(array) for array in found[:5])
    rows = np.flatnonzero(hit & geometry.hidden(prim, kind))
    while len(rows):
        # On from just past the hidden triangle, for what is left of the ray.
        at = None if times is None else times[rows]
        surface = surface_at_hits(geometry, prim[rows], u[rows], v[rows], O[rows], D[rows], t[rows], times=at)
        P = shadows.spawn_ray(surface.I, surface.Ng, D[rows], shadows.error_bound(surface.I, surface.vertices))
        gone = np.einsum("ij,ij->i", P - O[rows], D[rows])
        again = geometry.tracer.intersect(P, D[rows], t_max[rows] - gone, at)
        hit[rows], t[rows], prim[rows] = again.hit, np.where(again.hit, gone + again.t, np.inf), again.prim
        u[rows], v[rows] = again.u, again.v
        rows = rows[again.hit & geometry.hidden(again.prim, kind[rows])]
    return type(found)(hit, t, prim, u, v, None if times is None else np.asarray(times, np.float64))


def goes_through(kind: np.ndarray, transmit: np.ndarray) -> np.ndarray:
    """Which sampled directions count as going through the surface (Cycles' LABEL_TRANSMIT): a diffuse closure's
    by its class (a Lambert reflects, a translucent surface transmits), any other's by the side of the face it
    leaves to, `transmit` (k,) bool. kind: (k,) int the sampled closures' BSDF kinds. Returns (k,) bool."""
    flags = materials_.flags_of(kind)
    F = materials_.BSDFFlags
    diffuse = (flags & F.DIFFUSE) != 0
    return np.where(diffuse, (flags & F.TRANSMISSION) != 0, transmit)


def ray_kind(kind: np.ndarray, transmit: np.ndarray, previous) -> np.ndarray:
    """The kind of the rays a bounce sends, as the HIDDEN_FROM_* bit (k,) int64 of the objects they pass (Cycles'
    path_state_ray_visibility): a ray through the surface (goes_through) is a transmission ray, a diffuse
    reflection's a diffuse ray, any other reflection's (glossy, mirror) a glossy ray; straight through a
    Transparent closure the ray keeps the kind of the ray that arrived, `previous` (int or (k,) int).

    kind: (k,) int the sampled closures' BSDF kinds; transmit: (k,) bool whether each ray went through the face.
    """
    F = materials_.BSDFFlags
    reflected = np.where(materials_.has(kind, F.DIFFUSE), HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY)
    bounced = np.where(goes_through(kind, transmit), HIDDEN_FROM_TRANSMISSION, reflected)
    return np.where(materials_.has(kind, F.STRAIGHT), previous, bounced).astype(np.int64)


def camera_cones(ctx: Context, O: np.ndarray, D: np.ndarray) -> tuple:
    """The ray cones camera rays O, D (k, 3) (camera-relative origins, unit directions) leave with: (cone (k,),
    spread (k,)). Perspective and orthographic cameras: graph.camera_cones of the origin in the camera's frame
    (MaterialTable.view and .window); panoramic ones: camera.panorama_cones at the panorama's (u, v) of the direction
    (graph.panorama_window; Cycles differences the pinhole's directions, so under depth of field this is the
    refracted ray's); graph.UNKNOWN_CONE and 0 with no camera frame."""
    view, frame = getattr(ctx.materials, "view", None), getattr(ctx.materials, "window", None)
    if view is None or frame is None:
        return np.full(len(O), graph_.UNKNOWN_CONE), np.zeros(len(O))
    view = np.asarray(view, np.float64).reshape(3, 4)
    if frame[4] >= 2.0:
        uv = graph_.panorama_window(np.asarray(D, np.float64) @ view[:, :3].T, np.asarray(frame, np.float64))
        s = ctx.settings
        cone, spread, known = camera_.panorama_cones(ctx.scene.camera, uv[:, 0], uv[:, 1], s.width, s.height,
                                                     tuple(s.pixel_aspect))
        return np.where(known, cone, graph_.UNKNOWN_CONE), spread
    P = (O + ctx.geometry.origin) @ view[:, :3].T + view[:, 3]
    return graph_.camera_cones(P, np.asarray(frame, np.float64))


def cones_read(ctx: Context) -> bool:
    """Whether anything in the render reads a ray's cone (graph.reads_cone of one of its programs: a Bump, a Ray
    Footprint, Wireframe's Pixel Size), so that camera rays must carry theirs (camera_cones; the compiled kernels
    skip them where not: ChunkParams.cones). Every program counts: the materials' (which also give textured
    emitters' and hair's), the world's (what escaping rays run with their path, its AOVs), the lamps' and the
    media's (those two run with a cone of 0 of their own, lamp_graph.c and field.c: counted all the same, so
    that a reader is never missed)."""
    materials, layout = ctx.materials, ctx.geometry.attribute_layout
    programs = [materials.program(row, layout) for row in range(len(materials.shaders))]
    world = ctx.extra.get("world_light")
    programs += [getattr(world, "seen", None), ctx.extra.get("world_aovs")]
    programs += [getattr(light, "lamp_nodes", None) for light in ctx.lights]
    media = ctx.extra.get("media")
    programs += list(media.fields) if media is not None else []
    return any(graph_.reads_cone(getattr(p, "program", p)) for p in programs)


def clear_glass_threshold(settings) -> float:
    """Film > Transparent Glass as Cycles' kernel compares it (transparent_roughness_squared_threshold): the roughness
    threshold to the fourth power, against a lobe's alpha_x alpha_y; -1 (off) without a transparent film."""
    threshold = float(settings.transparent_glass)
    if not settings.transparent_background or not threshold >= 0.0:
        return -1.0
    return threshold ** 4


def clears_glass(kind: np.ndarray, params: np.ndarray, transmit: np.ndarray, threshold: float) -> np.ndarray:
    """Which sampled closures (kind (n,), params (n, PARAMS)) whose rays went through the face (transmit (n,) bool)
    keep a camera path clear under Transparent Glass (threshold from clear_glass_threshold): not diffuse, and at most
    that rough (Cycles' LABEL_TRANSMIT_TRANSPARENT): (n,) bool."""
    if threshold < 0.0 or not len(kind):
        return np.zeros(len(kind), bool)
    glossy = ~materials_.has(kind, materials_.BSDFFlags.DIFFUSE) & (np.asarray(kind) >= 0)
    return transmit & glossy & (materials_.specular_roughness_squared(kind, params) <= threshold)


def path_after(paths, kind: np.ndarray, transmit: np.ndarray, singular: np.ndarray, t=None, clear=None):
    """The paths (graph.LightPaths of k rows) the rays of k bounces carry on from `paths` (Cycles' path_state_next).

    Straight through a Transparent closure: one more transparent surface, the flags kept (a camera ray stays one);
    through a Ray Portal the same, and one more portal (Cycles' portal_bounce, the Light Path node's Portal Depth).
    Any other closure: one more bounce, of its kind (diffuse or glossy reflection, or through the surface:
    goes_through), and the flags of its labels: REFLECT or TRANSMIT, and DIFFUSE (a diffuse closure), GLOSSY and
    SINGULAR (a delta: singular (k,) bool, or a SINGULAR closure) or GLOSSY. kind: (k,) int the sampled closures'
    BSDF kinds; transmit: (k,) bool whether each ray left through the face. Every new ray leaves with the path's ray
    cone as it was at the hit, t (k,) along the ray that reached it (None: kept as it was): Cycles' compact ray
    differentials, dP the hit's footprint and dD kept (0 into a subsurface walk). clear (k,) bool: the bounces
    through glass under Transparent Glass's threshold (path.clears_glass), after which a camera path (or one already
    clear) carries CLEAR_GLASS; None: none."""
    F = materials_.BSDFFlags
    P = graph_.PATH
    straight = materials_.has(kind, F.STRAIGHT)
    through = goes_through(kind, transmit) & ~straight
    diffuse = materials_.has(kind, F.DIFFUSE)
    reflected = ~through & ~straight
    singular = np.asarray(singular, bool) | materials_.has(kind, F.SINGULAR)
    labels = (np.where(through, P["transmit"], P["reflect"])
              | np.where(diffuse, P["diffuse"], np.where(singular, P["glossy"] | P["singular"], P["glossy"])))
    # Into a subsurface walk: no bounce counted, the flags kept but the camera's (Cycles' subsurface_bounce).
    walk = materials_.has(kind, F.SUBSURFACE)
    straight = straight | walk
    through, reflected = through & ~walk, reflected & ~walk
    if clear is not None:
        labels = labels | np.where(clear & ((paths.flags & graph_.PATH_CLEARS_FILM) != 0), P["clear_glass"], 0)
    flags = np.where(walk, paths.flags & ~graph_.PATH_CLEARS_FILM, np.where(straight, paths.flags, labels))
    return graph_.LightPaths(flags=flags, bounce=paths.bounce + ~straight,
                             diffuse=paths.diffuse + (reflected & diffuse),
                             glossy=paths.glossy + (reflected & ~diffuse),
                             transmission=paths.transmission + through,
                             transparent=paths.transparent + (straight & ~walk),
                             portal=paths.portal + materials_.has(kind, F.PORTAL),
                             cone=paths.cone if t is None else graph_.footprints(paths, t),
                             spread=np.where(walk, 0.0, paths.spread))


def lamps_seen(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, groups=None,
               escaped=None, sigma=None) -> np.ndarray:
    """The radiance (n, 3) of the lamps camera rays see: lamps with extent they meet before t_max (lamps never
    block), and the discs of suns where they escape (escaped (n,) bool: the rays that hit nothing; Cycles'
    shade_background adds distant lights there). groups: a lightgroups.GroupLight of the n rays that receives it by
    each lamp's group, or None; sigma: the media the rays cross (core/volumes Stretch), or None: each lamp's light
    keeps what they let through over its distance t."""
    seen = np.zeros((len(O), 3))
    escaped = np.zeros(len(O), bool) if escaped is None else escaped
    for index in ctx.extra.get("camera_lamps", ()):
        light = ctx.lights[index]
        reach = np.where(escaped, np.inf, -1.0) if light.is_(LightFlags.DISTANT) else t_max
        met = light.hit(O, D, reach)
        radiance = met.radiance
        if sigma is not None:
            radiance = radiance * sigma.transmittance(np.where(met.hit, met.t, 0.0))
        seen += radiance
        if groups is not None:
            groups.add(np.arange(len(O)), radiance, groups.groups.lights[index])
    return seen


# The most surfaces camera_media walks past along a ray (a bound on the walk through surfaces without a medium).
CAMERA_MEDIA_HITS = schema.constant("CAMERA_MEDIA_HITS", 256, "the most surfaces a camera ray's walk for its media passes")
# The most surfaces of media camera_media's walk counts: Cycles' integrator_volume_stack_init records at most twice
# its volume stack's size of them (2 x MAX_VOLUME_STACK_SIZE, 64, where the scene sizes the stack to the full 32).
VOLUME_WALK_HITS = schema.constant("VOLUME_WALK_HITS", 64, "the most surfaces with a medium the camera's walk counts")
# The way camera_media walks: world up, as Cycles ("any direction works, Z up is a guess to get the fewest hits").
WALK_UP = np.array([0.0, 0.0, 1.0])


def camera_back(ctx: Context) -> np.ndarray:
    """The unit direction (3,) back towards the camera along its view axis (its local +z in the world): Cycles'
    (0, 0, -1) in camera space, the normal its denoising features give a camera path that scatters in a medium."""
    axis = np.asarray(ctx.scene.camera.matrix_world, np.float64)[:3, 2]
    return axis / max(float(np.linalg.norm(axis)), 1e-300)


def camera_media(ctx: Context, O: np.ndarray) -> np.ndarray:
    """The media (n, V) int16 camera rays from O (n, 3) (on the near clip plane) start in (core/volumes Media.crossed),
    by Cycles' integrator_volume_stack_init (`_walk`): each walks from its own origin straight up, whatever way the
    ray looks; rays from one point walk once (a perspective camera with Clip Start 0 and no depth of field)."""
    media = ctx.extra["media"]
    if not may_start_inside(ctx, O):
        return media.start(len(O))                  # (no ray starts within a mesh medium's bounds: no walk)
    if len(O) and (O == O[0]).all():
        return np.repeat(camera_media(ctx, O[:1]), len(O), axis=0) if len(O) > 1 else _walk(ctx, media, O)
    return _walk(ctx, media, O)


def may_start_inside(ctx: Context, O: np.ndarray) -> bool:
    """Whether some of the points O (n, 3) lie within the bounding box of the triangles whose material has a medium
    (as Cycles walks camera rays only where the camera may be inside a volume): render.prepare finds the box once
    (media_bounds)."""
    low, high = ctx.extra["media_bounds"] if "media_bounds" in ctx.extra else media_bounds(ctx.geometry,
                                                                                             ctx.extra["media"])
    return bool(len(O)) and bool(((O >= low) & (O <= high)).all(axis=1).any())


def media_bounds(geometry, media) -> tuple:
    """The bounding box (low (3,), high (3,) float64, camera-relative) of the triangles whose material has a medium
    (core/volumes Media.column); an empty box (inf, -inf) where none has."""
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for start in range(0, geometry.triangle_count, 1 << 20):
        triangles = geometry.triangle_data(np.arange(start, min(start + (1 << 20), geometry.triangle_count)),
                                           smooth=False)
        inside = media.has_medium[triangles.material]
        if inside.any():
            corners = triangles.corners[inside].reshape(-1, 3)
            low, high = np.minimum(low, corners.min(axis=0)), np.maximum(high, corners.max(axis=0))
    return low, high


def _walk(ctx: Context, media, O: np.ndarray) -> np.ndarray:
    """camera_media's walk, Cycles' integrator_volume_stack_init, for rays from O (n, 3): the stacks (n, V) int16 they
    start in. From each origin straight up (WALK_UP) to the end of the scene, past every surface, meeting only the
    objects camera rays see (an object hidden from them is not there, as for the camera rays themselves): a front
    face of a medium's surface marks its object as entered on the way, and a back face of an object the walk has not
    entered, nor taken already, puts its medium on the stack, last (nearest first; each object once, its first back
    face's medium); past VOLUME_WALK_HITS surfaces with a medium the walk stops, as Cycles' does."""
    n = len(O)
    inside = media.start(n)
    if inside.shape[1] == 0:
        return inside                               # (the world's medium alone: no mesh to be inside)
    entered = np.full((n, int(VOLUME_WALK_HITS)), -2, np.int32)       # the objects of front faces met (-2: none)
    taken = np.full((n, int(VOLUME_WALK_HITS)), -2, np.int32)         # the objects of the media stacked
    counted = np.zeros(n, np.int64)                 # the surfaces with a medium met
    O = O.copy()
    D = np.broadcast_to(WALK_UP, O.shape)
    alive = np.arange(n)
    for _ in range(CAMERA_MEDIA_HITS):
        found = ctx.geometry.tracer.intersect(O[alive], D[alive], np.full(len(alive), np.inf))
        hit = np.flatnonzero(found.hit)
        if len(hit) == 0:
            break
        rows = alive[hit]
        surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit], O[rows], D[rows],
                                  found.t[hit])
        objects = ctx.geometry.owners(np.asarray(surface.prim, np.int64))
        column = media.column_of(surface.material, objects if media.objects_of(ctx.geometry, surface.prim) is not None
                                 else None)
        has = (column >= 0) & ~ctx.geometry.hidden(surface.prim, HIDDEN_FROM_CAMERA)
        front = np.flatnonzero(has & ~surface.backfacing)
        entered[rows[front], counted[rows[front]]] = objects[front]
        back = np.flatnonzero(has & surface.backfacing)
        new = back[~(entered[rows[back]] == objects[back, None]).any(axis=1)
                   & ~(taken[rows[back]] == objects[back, None]).any(axis=1)]
        media.enter(inside, rows[new], column[new])         # (last, unless the stack is full: Media.room)
        new = new[inside[rows[new], column[new]] > 0]
        taken[rows[new], counted[rows[new]]] = objects[new]
        counted[rows[has]] += 1
        O[rows] = shadows.spawn_ray(surface.I, surface.Ng, D[rows], shadows.error_bound(surface.I, surface.vertices))
        alive = rows[counted[rows] < VOLUME_WALK_HITS]
    return inside
