"""The ray inspector: every number the renderer computes for one pixel ("use that debug output").

`inspect_pixel` follows the ray through a pixel's centre exactly as core/render.py
and core/shading.py do, with the same functions, but for one ray, and keeps
every intermediate value:

1. the primary ray (core/camera.py) and its nearest hit (t, the point I,
   triangle, barycentrics u, v, object);
2. the face normal Ng and the shading normal N, both turned towards the viewer
   (core/shading.py `surface_at_hits`);
3. per light: the direction L and distance r to the light (core/lights.py),
   N.L and Ng.L, the distance attenuation 1/r^2, whether a shadow ray was cast
   (not when the light is behind N or behind the face), whether it was
   occluded (core/shadows.py, `Tracer.occluded`), and the light's share of the
   pixel: albedo / pi * E_normal * max(N.L, 0) * visibility.

Lights with extent (a point or spot with a radius, a sun with an angle, an
area light) are sampled by the renderer at many random points; the inspector
takes ONE sample, at the light's centre (`centre_numbers`), so its shadow ray
is the one a student would draw. Its contribution is then that one sample's
estimate, not the render's average over the light. Lights without extent are
exact, and for them the contributions sum to the rendered pixel of a 1-sample,
unjittered render.

All positions in a PixelRecord are world space (the camera-relative origin is
added back); never imports bpy.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Optional

import numpy as np

from ..camera import camera as camera_
from ..lights import lights as lights_
from ..geometry import instancing
from ..integrators import shadows
from ..geometry.geometry import WorldGeometry, build_geometry
from ..render import _usable_lights, validate
from ..scene.scene import AreaLight, PointLight, RenderSettings, Scene, SpotLight, SunLight
from ..integrators.direct import surface_at_hits, translate_light

# Why a shadow ray was or was not cast (LightRecord.reason).
CAST = "cast"
BEHIND_N = "light behind N (N.L <= 0)"
BEHIND_FACE = "light behind the face (Ng.L <= 0)"
NO_LIGHT = "the light sends nothing here"


class LightRecord(NamedTuple):
    """What one light does at the inspected hit point (one sample; world space).

    name:            the light's name
    kind:            "POINT" | "SPOT" | "SUN" | "AREA"
    sampled:         True for lights with extent, inspected at one sample at their centre
    L:               (3,) float64 unit direction from I towards the light (sample)
    distance:        r, the distance from I to the light point; inf for the sun
    light_point:     (3,) float64 the light point the shadow ray aims at; None for the sun
    n_dot_l:         N.L with the shading normal (not clamped)
    ng_dot_l:        Ng.L with the face normal (not clamped)
    inverse_square:  1 / r^2 for point, spot and area lights; None for the sun
    irradiance:      (3,) float64 E_normal, irradiance at normal incidence (W/m^2, RGB)
    cast:            whether a shadow ray was traced
    reason:          why it was or was not cast (CAST, BEHIND_N, BEHIND_FACE, NO_LIGHT)
    occluded:        whether the shadow ray was blocked; None when none was cast
    shadow_origin:   (3,) float64 the shadow ray's origin (offset off the surface); None when not cast
    shadow_end:      (3,) float64 where the shadow ray stops (origin + t_max D); None when not cast
                     (for the sun it is the origin + t_max D with t_max = inf, so it is not finite)
    shadow_t_max:    the shadow ray's t_max; None when not cast
    contribution:    (3,) float64 albedo / pi * E_normal * max(N.L, 0) * visibility (radiance, RGB)
    """

    name: str
    kind: str
    sampled: bool
    L: np.ndarray
    distance: float
    light_point: Optional[np.ndarray]
    n_dot_l: float
    ng_dot_l: float
    inverse_square: Optional[float]
    irradiance: np.ndarray
    cast: bool
    reason: str
    occluded: Optional[bool]
    shadow_origin: Optional[np.ndarray]
    shadow_end: Optional[np.ndarray]
    shadow_t_max: Optional[float]
    contribution: np.ndarray


class PixelRecord(NamedTuple):
    """Everything the renderer computes for the ray through one pixel's centre (world space).

    x, y:           the pixel, row 0 at the top (core/render.py's convention)
    camera_point:   (3,) float64 the camera's position (the eye)
    origin:         (3,) float64 the primary ray's origin (on the near clip plane)
    direction:      (3,) float64 its unit direction D
    valid:          False outside a fisheye's image circle (no ray is traced; the pixel is black)
    hit:            whether the ray hit a triangle
    t:              distance from origin to I along D; inf when missed
    I:              (3,) float64 the hit point; None when missed
    Ng:             (3,) float64 unit face normal, facing the viewer; None when missed
    N:              (3,) float64 unit shading normal (interpolated on smooth triangles); None when missed
    smooth:         whether N was interpolated from the vertex normals
    u, v:           barycentric coordinates: I = (1-u-v) V0 + u V1 + v V2
    triangle:       index of the hit triangle in the traced geometry; -1 when missed
    object_name:    name of the object (Scene.instances[...].name) the triangle belongs to; "" when missed
    albedo:         (3,) float64 the material's base colour; None when missed
    shadow_method:  "robust" or "epsilon", as in the settings
    lights:         tuple of LightRecord, one per light that sends light (as the renderer uses them)
    radiance:       (3,) float64 the pixel's colour from this one ray: sum of the contributions on a hit,
                    the world colour on a miss (black when the film is transparent or outside a fisheye)
    warnings:       notes about the scene (lights skipped, geometry dropped)
    """

    x: int
    y: int
    camera_point: np.ndarray
    origin: np.ndarray
    direction: np.ndarray
    valid: bool
    hit: bool
    t: float
    I: Optional[np.ndarray]
    Ng: Optional[np.ndarray]
    N: Optional[np.ndarray]
    smooth: bool
    u: float
    v: float
    triangle: int
    object_name: str
    albedo: Optional[np.ndarray]
    shadow_method: str
    lights: tuple
    radiance: np.ndarray
    warnings: tuple


def light_kind(light) -> str:
    """Return Blender's name for the light's type: "POINT", "SPOT", "SUN" or "AREA"."""
    if isinstance(light, SpotLight):
        return "SPOT"
    if isinstance(light, PointLight):
        return "POINT"
    if isinstance(light, SunLight):
        return "SUN"
    if isinstance(light, AreaLight):
        return "AREA"
    raise TypeError(f"unknown light type {type(light).__name__}")


def centre_numbers(light) -> np.ndarray:
    """Return the unit-square point (2,) float64 that `lights.sample_light` maps to the light's centre.

    Round lights and sun disks are sampled over a cone of directions: u = (0, 0) is the cone's
    axis, the direction to the centre. Area lights are sampled over their surface: u = (0.5, 0.5)
    is the middle of the square, and the middle of the disk. Lights without extent ignore u.
    """
    if isinstance(light, AreaLight):
        return np.array([0.5, 0.5])
    return np.zeros(2)


def _inspect_light(geometry: WorldGeometry, surface, light, settings: RenderSettings,
                   offset: Optional[float]) -> LightRecord:
    """Return what one camera-relative light does at the one-hit `surface` (camera-relative values in, world out)."""
    origin = geometry.origin
    I = surface.I                                   # (1, 3)
    N, Ng = surface.N[0], surface.Ng[0]
    # 1. Where does the light come from? One sample, at the centre for lights with extent.
    ls = lights_.sample_light(light, I, centre_numbers(light)[None, :])
    if not settings.distance_attenuation:
        ls = lights_.without_distance_attenuation(light, ls, I)
    L = ls.L[0]
    r = float(ls.distance[0])
    E_normal = ls.irradiance[0]
    is_sun = isinstance(light, SunLight)
    # 2. The lecture's two tests, as core/shading.py's direct_light makes them (lecture switches
    #    included): N.L > 0 (the clamp) and Ng.L > 0 (the face normal decides whether the light can
    #    be visible); with the terminator fix, smooth triangles leave the second test to the shadow ray.
    NL = float(N @ L)
    NgL = float(Ng @ L)
    facing = NgL > 0.0 if settings.visibility_normal == "face" else NL > 0.0
    face_allows = facing or (settings.terminator_fix and bool(surface.smooth[0]))
    cosine = max(NL, 0.0) if settings.clamp_n_dot_l else NL
    if settings.shadow_rays_for_backfacing and E_normal.max() > 0.0:
        reason = CAST
    elif cosine == 0.0:
        reason = BEHIND_N
    elif not face_allows:
        reason = BEHIND_FACE
    elif E_normal.max() <= 0.0:
        reason = NO_LIGHT
    else:
        reason = CAST
    occluded = shadow_origin = shadow_end = shadow_t_max = None
    visibility = 0.0
    if reason == CAST:
        # 3. One shadow ray, from a point safely off the surface (terminator fix first, if on).
        start = I
        face_normal = surface.Ng
        if settings.terminator_fix and surface.smooth[0] and settings.terminator_offset > 0.0:
            amount = shadows.terminator_amount(np.array([NL]), np.array([NgL]), settings.terminator_offset)
            lifted = shadows.terminator_points(I, surface.vertices, surface.corners, surface.u, surface.v)
            start = I + amount[:, None] * (lifted - I)
        elif settings.shadow_rays_for_backfacing or settings.visibility_normal != "face":
            face_normal = face_normal * (-1.0 if NgL < 0.0 else 1.0)     # offset to the light's side
        if settings.shadow_method == "robust":
            rays = shadows.robust_rays(start, face_normal, np.array([offset]), ls.position, ls.L, ls.distance,
                                       settings.reduce_t_max)
        else:
            rays = shadows.epsilon_rays(start, ls.L, ls.distance, settings.epsilon, settings.reduce_t_max)
        seen = bool(shadows.visible(geometry.tracer, rays)[0])
        occluded = not seen
        visibility = 1.0 if seen else 0.0
        shadow_origin = rays.origins[0] + origin
        shadow_t_max = float(rays.t_max[0])
        with np.errstate(invalid="ignore"):
            shadow_end = shadow_origin + shadow_t_max * rays.directions[0]
    # 4. The light's share of the pixel: albedo / pi * E_normal * max(N.L, 0) * V (N.L with the clamp off).
    contribution = surface.albedo[0] * (1.0 / math.pi) * E_normal * cosine * visibility
    return LightRecord(
        name=light.name, kind=light_kind(light), sampled=not lights_.is_delta(light),
        L=L.copy(), distance=r, light_point=None if is_sun else ls.position[0] + origin,
        n_dot_l=NL, ng_dot_l=NgL, inverse_square=None if is_sun else (1.0 / (r * r) if r > 0 else math.inf),
        irradiance=E_normal.copy(), cast=reason == CAST, reason=reason, occluded=occluded,
        shadow_origin=shadow_origin, shadow_end=shadow_end, shadow_t_max=shadow_t_max,
        contribution=contribution)


def inspect_pixel(scene: Scene, settings: RenderSettings, x: int, y: int,
                  geometry: Optional[WorldGeometry] = None) -> PixelRecord:
    """Trace the ray through the centre of pixel (x, y) (row 0 at the top) and return every value on the way.

    Raises ValueError for a scene that cannot be rendered or a pixel outside the image.
    A prebuilt `geometry` (same origin as the renderer's) skips the BVH build.
    """
    validate(scene, settings)
    W, H = settings.width, settings.height
    if int(x) != x or int(y) != y:
        raise ValueError(f"pixel coordinates must be whole numbers, got ({x}, {y})")
    if not (0 <= x < W and 0 <= y < H):
        raise ValueError(f"pixel ({x}, {y}) is outside the {W}x{H} image (x in 0..{W - 1}, y in 0..{H - 1}, "
                         f"row 0 at the top)")
    x, y = int(x), int(y)
    # 1. The scene as the renderer traces it: camera-relative geometry and lights.
    cam = scene.camera
    origin = (np.asarray(cam.matrix_world, np.float64)[:3, 3] if settings.camera_relative else np.zeros(3))
    if geometry is None:
        geometry = build_geometry(scene, origin, instancing.instance_triangles(settings.instancing))
    warnings = list(geometry.warnings)
    lights = [translate_light(light, geometry.origin) for light in _usable_lights(scene, warnings)]
    world = np.asarray(scene.world_color, np.float64)[:3]
    camera_point = np.asarray(cam.matrix_world, np.float64)[:3, 3].copy()
    # 2. The primary ray through the pixel centre.
    rays = camera_.generate_rays(cam, W, H, np.array([x + 0.5]), np.array([y + 0.5]), tuple(settings.pixel_aspect))
    O_world, D = rays.origins[0], rays.directions[0]
    miss = dict(x=x, y=y, camera_point=camera_point, origin=O_world.copy(), direction=D.copy(),
                valid=bool(rays.valid[0]), hit=False, t=math.inf, I=None, Ng=None, N=None, smooth=False,
                u=0.0, v=0.0, triangle=-1, object_name="", albedo=None, shadow_method=settings.shadow_method,
                lights=(), warnings=tuple(warnings))
    if not rays.valid[0]:
        return PixelRecord(radiance=np.zeros(3), **miss)
    # 3. The nearest hit, in the camera-relative frame.
    O = rays.origins - geometry.origin
    hits = geometry.tracer.intersect(O, rays.directions, rays.t_max)
    if not hits.hit[0]:
        return PixelRecord(radiance=np.zeros(3) if settings.transparent_background else world.copy(), **miss)
    # 4. The surface: I, Ng and N facing the viewer, barycentrics, material.
    surface = surface_at_hits(geometry, hits.prim, hits.u, hits.v, O, rays.directions, hits.t,
                              flat_only=not settings.smooth_normals)
    triangle = int(hits.prim[0])
    object_name = ""
    owner = geometry.instance_of(triangle)
    if owner >= 0:
        object_name = scene.instances[owner].name
    # 5. Every light, with its shadow ray (the robust offset is computed once, as in direct_light).
    offset = (float(shadows.error_bound(surface.I, surface.vertices)[0])
              if settings.shadow_method == "robust" else None)
    records = tuple(_inspect_light(geometry, surface, light, settings, offset) for light in lights)
    radiance = np.sum([r.contribution for r in records], axis=0) if records else np.zeros(3)
    miss.update(hit=True, t=float(hits.t[0]), I=surface.I[0] + geometry.origin, Ng=surface.Ng[0].copy(),
                N=surface.N[0].copy(), smooth=bool(surface.smooth[0]), u=float(hits.u[0]), v=float(hits.v[0]),
                triangle=triangle, object_name=object_name, albedo=surface.albedo[0].copy(), lights=records)
    return PixelRecord(radiance=radiance, **miss)


def light_numbers(scene: Scene) -> np.ndarray:
    """Return the inspector's unit-square sample per usable light, for `shading.direct_light`: (k, 2) float64.

    With these, direct_light evaluates exactly the samples the inspector shows.
    """
    usable = _usable_lights(scene, [])
    return np.array([centre_numbers(light) for light in usable]).reshape(len(usable), 2)
