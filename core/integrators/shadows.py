"""Shadow rays: is the light visible from the shading point?

The lecture's shadow ray starts at the hit point I and heads for the light:
O = I, D = normalize(P_light - I), 0 < t < ||P_light - I||. It only asks
*whether* something is in the way (`Tracer.occluded`), never *where*.

"In theory, theory and practice are the same. In practice, they are not."
Computed in floating point, I lies a tiny distance above or below the surface
it came from, and the shadow ray may hit that very surface at t ~ 0: shadow
acne. Two cures are offered here:

- "epsilon" (the lecture): move the origin by epsilon along the shadow ray and
  reduce t_max by 2 epsilon (once for the moved origin, once so the ray stops
  short of a surface the light sits on). Simple, but epsilon is a length in
  scene units: too small and it fails at grazing angles or far from the
  origin; too large and contact shadows and thin occluders are lost.

- "robust" (default): move the origin along the *face normal*, to the light's
  side, by a distance proportional to the float32 rounding error of the
  coordinates involved. This follows Waechter & Binder ("A Fast and Robust
  Method for Avoiding Self-Intersection", Ray Tracing Gems, 2019), who offset
  along the geometric normal by a fixed number of float ulps of the hit point,
  and pbrt-v4, which bounds the error of a hit point by the magnitudes of the
  triangle's vertices. We use the larger of the hit point's and the triangle
  vertices' magnitudes because Embree's own triangle test loses precision in
  proportion to |V - O|, which for a large triangle is set by its far vertices.
  We drop Waechter & Binder's absolute offset near the origin: our coordinates
  are camera-relative, so an absolute length would break scale invariance.
  Nothing is left for the user to tune, and the offset shrinks and grows with
  the scene.

Visibility also uses the face normal (the lecture): a light on the back side of
the triangle's plane cannot be seen, whatever the interpolated normal says,
so no shadow ray is cast for it.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from ..materials import portal as portal_
from .. import volumes
from ..lights.linking import in_sets
from ..native import schema
from ..native.schema import F64, I32

# float32 unit roundoff, and how many of them the robust offset spans. Measured
# (tests/test_shadows.py scenes, grazing suns down to 0.01 degrees, 1e5 from the
# origin): acne vanishes from 0.5 units of roundoff on; 8 leaves a 16x margin while
# keeping the offset ~1e-6 of the coordinates, far below any modelled thickness.
FLOAT32_EPSILON = 2.0 ** -24
ROBUST_ULPS = 8.0

# The most volume-only boundaries a shadow ray (or a path, path.py) crosses, as Cycles' VOLUME_BOUNDS_MAX: those
# crossings count as no transparent bounce, so this guards against a ray caught crossing the same boundary.
VOLUME_BOUNDS_MAX = schema.constant("VOLUME_BOUNDS_MAX", 1024, "the most volume-only boundaries a ray crosses")

# How shadow rays leave the surface, for the compiled kernels (shadows.c).
ShadowSettings = schema.record("ShadowSettings", "How shadow rays leave the surface (RenderSettings' shadow settings).", [
    ("robust", I32, "1: robust offsets (robust_rays); 0: the lecture's epsilon"),
    ("epsilon", F64, ""),
    ("terminator_fix", I32, "1: lift smooth points (Surface.lifted)"),
    ("terminator_offset", F64, ""),
])


def spawn_ray(I: np.ndarray, Ng: np.ndarray, D: np.ndarray, step: np.ndarray) -> np.ndarray:
    """The origins (k, 3) of rays leaving points I (k, 3) along D (k, 3): `step` (k,) off the surface along its face
    normal Ng (k, 3), on the side D goes to (the robust offset, shadows.error_bound, or the lecture's epsilon)."""
    side = np.where(np.einsum("ij,ij->i", Ng, D) < 0.0, -1.0, 1.0)
    return I + (step * side)[:, None] * Ng


class ShadowRays(NamedTuple):
    """Rays from shading points to light points.

    origins: (n, 3) float64; directions: (n, 3) float64 unit; t_max: (n,) float64; time: (n,) float64 their times
    in the shutter (the times of the paths they light: where moving objects are), or None.
    """

    origins: np.ndarray
    directions: np.ndarray
    t_max: np.ndarray
    time: Optional[np.ndarray] = None


def largest_coordinate(values: np.ndarray) -> np.ndarray:
    """Return the largest |coordinate| of each row: (n, ...) float64 -> (n,) float64.

    Column by column: a reduction along a short last axis is several times slower in numpy.
    """
    columns = np.abs(values.reshape(len(values), -1))
    largest = columns[:, 0].copy()
    for c in range(1, columns.shape[1]):
        np.maximum(largest, columns[:, c], out=largest)
    return largest


def error_bound(points: np.ndarray, triangle_vertices: np.ndarray) -> np.ndarray:
    """Return the robust offset distance for each hit: ROBUST_ULPS float32 ulps of its largest coordinate.

    points: (n, 3) float64 hit points; triangle_vertices: (n, 3, 3) float64 -> (n,) float64
    """
    magnitude = np.maximum(largest_coordinate(points), largest_coordinate(triangle_vertices))
    return ROBUST_ULPS * FLOAT32_EPSILON * magnitude


def robust_rays(points: np.ndarray, face_normals: np.ndarray, offsets: np.ndarray,
                light_points: np.ndarray, L: np.ndarray, distance: np.ndarray,
                reduce_t_max: bool = True, light_normals: Optional[np.ndarray] = None) -> ShadowRays:
    """Build shadow rays with the origin pushed off the surface by its error bound.

    points: (n, 3) float64 hit points; face_normals: (n, 3) float64 unit, on the light's side;
    offsets: (n,) float64 from `error_bound`; light_points: (n, 3) float64; L: (n, 3) unit
    direction to the light; distance: (n,) float64, inf for a distant light.
    light_normals: (n, 3) float64 the unit face normal of the surface each light point lies on (an emissive
    triangle, LightSample.normal; zero rows: none), or None where no light point lies on a surface.
    reduce_t_max=False (a lecture switch) keeps the unreduced t_max = ||P_light - I|| (and the end on the light).
    """
    origins = points + offsets[:, None] * face_normals
    finite = np.isfinite(distance)
    if finite.all():
        w = light_points - origins
        length = np.sqrt(np.einsum("ij,ij->i", w, w))
        if not reduce_t_max:
            return ShadowRays(origins, w / np.maximum(length, 1e-300)[:, None], distance)
        # The rounding error of the float32 ray that reaches the light point: ulps of the largest of its
        # coordinates, the origin's and the ray's length.
        magnitude = np.maximum(np.maximum(largest_coordinate(light_points), largest_coordinate(origins)), length)
        end_offset = ROBUST_ULPS * FLOAT32_EPSILON * magnitude
        if light_normals is not None:
            # A light point on an emissive triangle: the ray ends that far off its surface, along its face normal
            # on the origin's side (as the origin leaves its own surface). Stopping short along the ray alone is
            # not enough where the ray grazes the emitter: Embree's float32 hit on its plane moves along the ray
            # by the rounding error over the sine of the angle (1 / sin times the end offset), so a point a few
            # units below a ceiling lamp, hundreds of units from it, met the lamp it aims at and lost up to half
            # its light (the cornell_box scene). Cycles instead skips the sampled triangle on the shadow ray.
            side = np.where(np.einsum("ij,ij->i", light_normals, origins - light_points) < 0.0, -1.0, 1.0)
            w = w + (side * end_offset)[:, None] * light_normals
            length = np.sqrt(np.einsum("ij,ij->i", w, w))
        directions = w / np.maximum(length, 1e-300)[:, None]
        # Stop short of the (lifted) light point by that rounding error too (a long ray that grazes an emitter
        # would otherwise meet the emitter it aims at, a few ulps past the end).
        return ShadowRays(origins, directions, np.maximum(length - end_offset, 0.0))
    return ShadowRays(origins, L, distance)


def epsilon_rays(points: np.ndarray, L: np.ndarray, distance: np.ndarray, epsilon: float,
                 reduce_t_max: bool = True) -> ShadowRays:
    """Build the lecture's shadow rays: origin I + epsilon L, t_max = distance - 2 epsilon.

    points: (n, 3) float64; L: (n, 3) float64 unit; distance: (n,) float64 (inf for the sun).
    reduce_t_max=False (a lecture switch) keeps t_max = distance: the ray then ends epsilon
    beyond the light, and a surface the light sits on blocks it.
    """
    t_max = np.maximum(distance - 2.0 * epsilon, 0.0) if reduce_t_max else distance
    return ShadowRays(points + epsilon * L, L, t_max)


def terminator_points(points: np.ndarray, triangle_vertices: np.ndarray, corner_normals: np.ndarray,
                      u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Return shadow-ray origins lifted onto the smooth surface the normals describe.

    Hanika's "Hacking the Shadow Terminator" (Ray Tracing Gems II, 2021): a
    low-poly smooth mesh is flatter than the surface its vertex normals imply,
    so points near the terminator self-shadow. Project the hit point onto the
    tangent plane of each corner (only when it lies below that plane) and
    interpolate those projections with the barycentric coordinates.
    points: (n, 3) float64; triangle_vertices: (n, 3, 3) float64; corner_normals: (n, 3, 3) float64 unit;
    u, v: (n,) float64 -> (n, 3) float64
    """
    weights = np.stack([1.0 - u - v, u, v], axis=1)                     # (n, 3)
    to_point = points[:, None, :] - triangle_vertices                    # (n, 3 corners, 3)
    below = np.minimum(np.einsum("ncj,ncj->nc", to_point, corner_normals), 0.0)
    projected = to_point - below[:, :, None] * corner_normals
    return np.einsum("nc,ncj->nj", weights, triangle_vertices + projected)


def terminator_amount(NL: np.ndarray, NgL: np.ndarray, cutoff) -> np.ndarray:
    """Return how much of the terminator lift to apply, 0..1, as Cycles blends it.

    Only points where the light is near grazing (N.L or Ng.L below `cutoff`, (n,) or one for all) move,
    with a smooth transition to zero above it. NL, NgL: (n,) float64 -> (n,) float64
    """
    return np.where(NL < cutoff,
                    np.clip(2.0 - (NgL + NL) / cutoff, 0.0, 1.0),
                    np.clip(1.0 - NgL / cutoff, 0.0, 1.0))


def visible(tracer, rays: ShadowRays) -> np.ndarray:
    """Return True where nothing blocks the shadow ray: (n,) bool."""
    return ~tracer.occluded(rays.origins, rays.directions, rays.t_max, rays.time)


def transmittance(ctx, rays: ShadowRays, limit: int, inside=None, paths=None, blockers=None) -> np.ndarray:
    """The share of light (n, 3) float64 a shadow ray carries through transparent surfaces (Cycles'
    transparent shadows): the product of the transparency of each surface it passes, 0 where an opaque
    surface blocks it or where it would pass more than what is left of `limit` (less the transparent surfaces its
    path passed before, `paths.transparent`, as Cycles' integrate_shadow_max_transparent_hits). Objects hidden from
    shadow rays (Ray Visibility > Shadow off) are passed as if they were not there, and so are objects outside a
    shadow-linked light's blocker sets: blockers (n,) uint64 each ray's light's shadow membership
    (core/lights/linking.py), or None.

    Past each surface the ray goes on from just off it towards its own end point, origin + t_max direction
    (short of the light by robust_rays' margin), which stays where it was: Cycles moves only the start of its
    one shadow ray. (Going on along the old direction for the old length less the distance gained along it
    would move the end by the step off the surface across the ray, onto the light's own surface when the
    surface faces the light; a sun's ray, with no end, keeps its direction.)

    paths: the graph.LightPaths the n rays carry (SHADOW, and the counts of the path at their origins), which the
    surfaces' shaders read (the Light Path node), each surface passed one more transparent one; None: a shadow ray
    from a camera ray's hit. inside: (n, V) the media (core/volumes Media) the rays start in, or None: without media;
    each stretch keeps what its media let through, volume-only boundaries pass (not counted against `limit`, at most
    VOLUME_BOUNDS_MAX)."""
    from ..visibility import HIDDEN_FROM_SHADOW
    from ..geometry.surface import surface_at_hits
    from ..materials import graph as graph_
    n = len(rays.origins)
    T = np.ones((n, 3))
    O, D, t = rays.origins.copy(), rays.directions.copy(), rays.t_max.copy()
    finite = np.isfinite(rays.t_max)
    ends = rays.origins + np.where(finite, rays.t_max, 0.0)[:, None] * rays.directions
    passed = np.zeros(n, np.int64)
    crossed = np.zeros(n, np.int64)                 # volume-only boundaries passed
    media = ctx.extra.get("media") if inside is not None else None
    inside = None if media is None else inside.copy()
    if inside is not None and media.shadowless.any():   # (media of objects hidden from shadow rays: not there)
        inside[:, media.shadowless] = 0
    paths = graph_.light_paths(n, flags=graph_.PATH_SHADOW) if paths is None else paths
    alive = np.arange(n)
    while len(alive):
        found = ctx.geometry.tracer.intersect(O[alive], D[alive], t[alive],
                                              None if rays.time is None else rays.time[alive])
        if media is not None:
            # The stretch up to the surface met (or to the light): what its media let through.
            T[alive] *= media.along(inside[alive], O[alive], D[alive]).transmittance(np.where(found.hit, found.t,
                                                                                                t[alive]))
        hit = np.flatnonzero(found.hit)
        if len(hit) == 0:
            break
        rows = alive[hit]
        hidden = ctx.geometry.hidden(found.prim[hit], HIDDEN_FROM_SHADOW)
        if blockers is not None:              # (Shadow Linking: only the light's blocker sets stop its rays)
            hidden |= ~in_sets(blockers[rows], ctx.geometry.links(found.prim[hit], 1))
        boundary = (np.zeros(len(hit), bool) if media is None
                    else media.boundary[ctx.geometry.triangle_data(found.prim[hit], smooth=False).material])
        over = ~hidden & ~boundary & (passed[rows] >= limit - paths.transparent[rows])   # (what the path left)
        T[rows[over]] = 0.0
        passed[rows] += ~hidden & ~boundary
        crossed[rows] += boundary
        T[rows[crossed[rows] > VOLUME_BOUNDS_MAX]] = 0.0
        # The surface the ray passes: what its material lets through, seen along the ray.
        surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit], O[rows], D[rows],
                                  found.t[hit], times=None if rays.time is None else rays.time[rows])
        path = graph_.paths_at(paths, rows)
        path = path._replace(transparent=path.transparent + passed[rows] - 1)
        # (Ray Length: the distance from the shadow ray's start, as Cycles measures every hit of its one ray)
        gone = surface.I - rays.origins[rows]
        length = np.sqrt((gone[:, 0] * gone[:, 0] + gone[:, 1] * gone[:, 1]) + gone[:, 2] * gone[:, 2])
        surface = surface._replace(t=length)
        shader = ctx.materials.shade(surface.material, surface.N, -D[rows], surface, ctx.geometry, path)
        # (a Ray Portal's weight: as Cycles' shadow rays count it, portal.shadow_transparency)
        through = np.where(ctx.materials.shadow_opaque[surface.material][:, None], 0.0,
                           portal_.shadow_transparency(shader))
        T[rows] *= np.where(hidden[:, None], 1.0, through)
        if media is not None:
            inside[rows] = media.crossed(inside[rows], surface.material, surface.backfacing, ~hidden,
                                         media.objects_of(ctx.geometry, surface.prim))
        # On from just past that surface, for what is left of the way to the light: towards the ray's end.
        O[rows] = spawn_ray(surface.I, surface.Ng, D[rows], error_bound(surface.I, surface.vertices))
        w = ends[rows] - O[rows]
        length = np.sqrt(np.einsum("ij,ij->i", w, w))
        ahead = finite[rows] & (np.einsum("ij,ij->i", w, rays.directions[rows]) > 0.0)
        D[rows] = np.where(ahead[:, None], w / np.maximum(length, 1e-300)[:, None], D[rows])
        t[rows] = np.where(finite[rows], np.where(ahead, length, 0.0), rays.t_max[rows])
        alive = rows[(T[rows] > 0.0).any(axis=1)]
        if len(alive) == 0:
            break
    return T


def lift_terminator(surface, rows: np.ndarray, NL: np.ndarray, NgL: np.ndarray, cutoff) -> np.ndarray:
    """Return shadow-ray origins for the hits `rows`, lifted by the terminator fix on smooth triangles.

    surface: core/geometry/surface.py Surface; NL, NgL: (r,) float64 N.L and Ng.L of those hits; cutoff: the
    Geometry Offset (r,) float64 of each hit's object (or one for all); 0 lifts nothing.
    """
    I = surface.I[rows].copy()
    cutoff = np.broadcast_to(np.asarray(cutoff, np.float64), (len(rows),))
    smooth = surface.smooth[rows] & (cutoff > 0.0)
    if not smooth.any():
        return I
    amount = terminator_amount(NL[smooth], NgL[smooth], cutoff[smooth])
    chosen = rows[smooth]
    lifted = terminator_points(surface.I[chosen], surface.vertices[chosen], surface.corners[chosen],
                               surface.u[chosen], surface.v[chosen])
    I[smooth] += amount[:, None] * (lifted - I[smooth])
    return I
