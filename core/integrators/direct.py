"""Shading: what a camera ray sees where it hits a diffuse surface.

For each hit: find the point I, the face normal and the shading normal N
(flipped towards the viewer), then sum the lights: for every light,

    E += E_normal * max(N.L, 0) * visibility          (core/lights.py, core/shadows.py)

and reflect L_out = (albedo / pi) * E. Work is done only where it matters:
interpolated normals only for smooth triangles, shadow rays only for lights
in front of both N and the face, and only where the light sends something.
The lecture switches of RenderSettings (README, "Lecture switches") undo these
choices one at a time, to show why the lecture makes them.
"""
from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple, Optional

import numpy as np

from ..lights import lights as lights_
from ..geometry import normals as normals_
from ..teaching import debug
from ..sampling import sobol as sampling
from . import shadows
from .. import vectors
from ..scene.scene import AreaLight, PointLight, SpotLight, SunLight

# Below this fraction of lit samples, shadow rays are built for the lit samples only (gathered);
# above it, for all samples, which skips the gather and the scatter.
GATHER_BELOW = 0.75


class Surface(NamedTuple):
    """Surface records of the hit samples, camera-relative.

    I:        (n, 3) float64 hit points
    N:        (n, 3) float64 unit shading normals, facing the viewer
    Ng:       (n, 3) float64 unit face normals, facing the viewer
    albedo:   (n, 3) float64 material base colour
    vertices: (n, 3, 3) float64 the hit triangles' corners
    corners:  (n, 3, 3) float64 corner normals, facing the viewer (zeros on flat triangles)
    smooth:   (n,) bool where N was interpolated
    u, v:     (n,) float64 barycentric coordinates
    Read-only: N may be the very array Ng is (no hit smooth), and corners a broadcast view of zeros.
    """

    I: np.ndarray
    N: np.ndarray
    Ng: np.ndarray
    albedo: np.ndarray
    vertices: np.ndarray
    corners: np.ndarray
    smooth: np.ndarray
    u: np.ndarray
    v: np.ndarray


class Shading(NamedTuple):
    """Light at the hit samples.

    radiance:   (n, 3) float64 outgoing radiance towards the camera
    n_dot_l:    (n, k) float64 max(N.L, 0) per light (N.L with the clamp off), averaged over light samples
    visibility: (n, k) float64 fraction of shadow rays that reached each light (0 if none was cast)
    shadow_rays: int number of shadow rays traced
    rays_per_hit: (n,) float64 shadow rays traced for each hit, or None when not asked for
    acne_per_hit: (n,) float64 of those, how many hit the surface they left, or None when not asked for
    """

    radiance: np.ndarray
    n_dot_l: np.ndarray
    visibility: np.ndarray
    shadow_rays: int
    rays_per_hit: Optional[np.ndarray] = None
    acne_per_hit: Optional[np.ndarray] = None


def hit_points(vertices: np.ndarray, Ng: np.ndarray, u: np.ndarray, v: np.ndarray,
               O: np.ndarray, D: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Return the hit points I, as precise as float64 allows.

    Embree's t and (u, v) are float32: good to ~1e-7 of the triangle's size. We
    intersect the float64 ray with the triangle's plane again, t = (V0 - O).Ng / D.Ng,
    and keep that refinement wherever it agrees with Embree's t to float32 precision
    (it does not at grazing angles, where the barycentric point is the better one).
    vertices: (n, 3, 3) float64; Ng: (n, 3) unit; u, v, t: (n,) float64; O, D: (n, 3) float64.
    """
    # 1. The float64 ray meets the triangle's plane at t_plane.
    DNg = np.einsum("ij,ij->i", D, Ng)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_plane = np.einsum("ij,ij->i", vertices[:, 0] - O, Ng) / DNg
    I = O + t_plane[:, None] * D
    # 2. Where that disagrees with Embree's t (grazing rays), the barycentric point instead.
    disagrees = np.flatnonzero(~(np.abs(t_plane - t) <= 1e-5 * np.abs(t) + 1e-30))
    if len(disagrees):
        w = 1.0 - u[disagrees] - v[disagrees]
        corners = vertices[disagrees]
        I[disagrees] = (w[:, None] * corners[:, 0] + u[disagrees, None] * corners[:, 1]
                        + v[disagrees, None] * corners[:, 2])
    return I


def surface_at_hits(geometry, prim: np.ndarray, u: np.ndarray, v: np.ndarray,
                    O: np.ndarray, D: np.ndarray, t: np.ndarray, flat_only: bool = False) -> Surface:
    """Return the surface records of hits on `geometry`.

    prim: (n,) int64 triangle index; u, v, t: (n,) float64 barycentrics and distance;
    O, D: (n, 3) float64 camera-relative ray origins and directions.
    flat_only: ignore smooth shading (the lecture's "flat normals" switch).
    """
    # I on the float32 triangle Embree hit.
    triangle = geometry.triangle_data(prim, smooth=geometry.has_smooth and not flat_only)
    vertices, Ng = triangle.corners, triangle.Ng                                # (n, 3, 3), (n, 3)
    I = hit_points(vertices, Ng, u, v, O, D, t)
    # Face normal, flipped when the triangle was hit from behind (N.D > 0).
    side = normals_.face_forward(Ng, D)
    Ng = Ng * side[:, None]
    N = Ng
    corners = np.broadcast_to(np.zeros((1, 3, 3)), vertices.shape)     # read-only zeros: no smooth work
    smooth = triangle.smooth
    if smooth.any():
        # Interpolated normals only where the triangle is smooth.
        N, corners = Ng.copy(), np.zeros_like(vertices)
        corners[smooth] = triangle.corner_normals * side[smooth, None, None]
        N[smooth] = normals_.interpolate(corners[smooth], u[smooth], v[smooth], Ng[smooth])
    albedo = geometry.albedo[triangle.material]
    return Surface(I, N, Ng, albedo, vertices, corners, smooth, u, v)


def translate_light(light, origin: np.ndarray):
    """Return the light moved into the camera-relative frame (points minus origin)."""
    if isinstance(light, (PointLight, SpotLight)):
        return dataclasses.replace(light, position=np.asarray(light.position, np.float64) - origin)
    if isinstance(light, AreaLight):
        return dataclasses.replace(light, center=np.asarray(light.center, np.float64) - origin)
    return light


def direct_light(geometry, surface: Surface, lights: list, settings, pixel: np.ndarray,
                 sample: np.ndarray, want_aux: bool = False, light_numbers=None,
                 prim: Optional[np.ndarray] = None, self_hit_distance: float = 0.0) -> Shading:
    """Return the radiance reflected towards the camera by direct light from every light.

    lights: already camera-relative (`translate_light`); pixel, sample: (n,) int64 keys
    of each hit for the random numbers. The lecture switches of `settings` apply here.
    light_numbers: None, or (k, 2) float64 one fixed unit-square point per light used for
    every hit instead of the stratified samples (the ray inspector's single sample,
    core/inspector.py). Debug counts (Shading.rays_per_hit, acne_per_hit) are kept only when
    settings.aux asks for "rays", "time" or "acne"; the acne check needs prim: (n,) int64
    triangle of each hit and self_hit_distance (core/debug.py).
    """
    n = len(surface.I)
    k = len(lights)
    E = np.zeros((n, 3))
    n_dot_l = np.zeros((n, k)) if want_aux else None
    visibility = np.zeros((n, k)) if want_aux else None
    aux = set(getattr(settings, "aux", ()))
    rays_per_hit = np.zeros(n) if aux & {"rays", "time", "acne"} else None
    acne_per_hit = np.zeros(n) if "acne" in aux and prim is not None else None
    shadow_ray_count = 0
    robust = settings.shadow_method == "robust"
    offsets = shadows.error_bound(surface.I, surface.vertices) if robust else None

    for index, light in enumerate(lights):
        # The light's colour is the same for all its samples: sum the scalar irradiance, colour it once.
        E_light = np.zeros(n)
        delta = lights_.is_delta(light)
        count = 1 if delta or light_numbers is not None else max(1, int(settings.light_samples))
        cone = lights_.light_cone(light, surface.I)        # shared by all the light's samples
        for j in range(count):
            # 1. Where does the light come from? (one stratified sample for extended lights)
            if delta:
                u2 = np.zeros((n, 2))
            elif light_numbers is not None:
                u2 = np.broadcast_to(np.asarray(light_numbers[index], np.float64), (n, 2))
            else:
                # The pixel's light points for this light are one progressive pattern over the light
                # (core/sampling.py): camera sample s takes its points s*count .. s*count+count-1,
                # so the points of any number of camera samples together cover the light evenly.
                u2 = sampling.sample_2d(settings.seed, pixel, sample * count + j, dimension=16 + 4 * index)
            ls = lights_.sample_light(light, surface.I, u2, cone)
            if not settings.distance_attenuation:
                ls = lights_.without_distance_attenuation(light, ls, surface.I)
            # 2. The lecture's two tests: N.L > 0 (shading normal, the clamp) and Ng.L > 0 (the face
            #    normal decides whether the light can be visible; `visibility_normal` switches it).
            #    The terminator fix lifts smooth points onto the curved surface, where the
            #    face normal no longer decides; its shadow ray does.
            NL = np.einsum("ij,ij->i", surface.N, ls.L)
            NgL = np.einsum("ij,ij->i", surface.Ng, ls.L)
            facing = NgL > 0.0 if settings.visibility_normal == "face" else NL > 0.0
            face_allows = facing | surface.smooth if settings.terminator_fix else facing
            cosine = np.maximum(NL, 0.0) if settings.clamp_n_dot_l else NL
            lit = (cosine != 0.0) & face_allows
            if settings.shadow_rays_for_backfacing:
                lit[:] = True                     # cast them anyway, to count what the lecture saves
            lit &= ls.strength > 0.0
            lit_count = int(np.count_nonzero(lit))
            if want_aux:
                n_dot_l[:, index] += cosine / count
            if lit_count == 0:
                continue
            # 3. One shadow ray per lit sample, from a point safely off the surface. Compact, compute,
            #    scatter: gather the lit samples first, unless nearly all are lit; gathering would
            #    then cost more than it saves, so every sample gets a ray and the unlit ones an
            #    empty interval (t_max < 0) that Embree does not trace.
            gather = settings.terminator_fix or acne_per_hit is not None or lit_count < GATHER_BELOW * n
            idx = np.flatnonzero(lit) if gather else slice(None)
            rows = (lambda values: vectors.gather(values, idx)) if gather else (lambda values: values)
            I = rows(surface.I)
            Ng = rows(surface.Ng)
            if settings.terminator_fix:
                I = _lift_terminator(surface, idx, NL[idx], NgL[idx], settings.terminator_offset)
            elif settings.shadow_rays_for_backfacing or settings.visibility_normal != "face":
                # Switches that cast rays towards lights behind the face: offset to the light's side.
                Ng = Ng * np.where(NgL[idx] < 0.0, -1.0, 1.0)[:, None]
            if robust:
                rays = shadows.robust_rays(I, Ng, offsets[idx], rows(ls.position),
                                           rows(ls.L), ls.distance[idx], settings.reduce_t_max)
            else:
                rays = shadows.epsilon_rays(I, rows(ls.L), ls.distance[idx], settings.epsilon,
                                            settings.reduce_t_max)
            if not gather:
                rays = rays._replace(t_max=np.where(lit, rays.t_max, -1.0))
            seen = shadows.visible(geometry.tracer, rays) & lit[idx]
            shadow_ray_count += lit_count
            # 4. Scatter the unoccluded light back: E += E_normal (N.L) V.
            E_light[idx] += ls.strength[idx] * cosine[idx] * seen * (1.0 / count)
            if want_aux:
                visibility[idx, index] += seen / count
            if rays_per_hit is not None:
                rays_per_hit[idx] += lit[idx]
            if acne_per_hit is not None:
                blocked = np.flatnonzero(~seen)
                acne_per_hit[idx[blocked]] += debug.self_intersections(
                    geometry, rays.origins[blocked], rays.directions[blocked], rays.t_max[blocked],
                    prim[idx[blocked]], self_hit_distance)
        E += vectors.combine(np.zeros(3), [E_light], [np.asarray(light.color, np.float64)[:3]])
    radiance = surface.albedo * (1.0 / math.pi) * E
    return Shading(radiance, n_dot_l, visibility, shadow_ray_count, rays_per_hit, acne_per_hit)


def _lift_terminator(surface: Surface, idx: np.ndarray, NL: np.ndarray, NgL: np.ndarray,
                     cutoff: float) -> np.ndarray:
    """Return shadow origins for the hits `idx`, lifted by the terminator fix on smooth triangles."""
    I = surface.I[idx].copy()
    smooth = surface.smooth[idx]
    if not smooth.any() or cutoff <= 0.0:
        return I
    amount = shadows.terminator_amount(NL[smooth], NgL[smooth], cutoff)
    sel = idx[smooth]
    lifted = shadows.terminator_points(surface.I[sel], surface.vertices[sel], surface.corners[sel],
                                       surface.u[sel], surface.v[sel])
    I[smooth] += amount[:, None] * (lifted - I[smooth])
    return I
