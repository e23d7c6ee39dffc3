"""Lights in Cycles' units, and how much light each one sends to a point.

The lecture's transport: emitted energy, distance attenuation 1/r^2,
absorption by the material colour, and N.L. For a diffuse surface of albedo
rho lit by irradiance E, the reflected radiance is (rho / pi) E.

Every light answers one question for a batch of shading points: "from which
direction L, over which distance, and with what irradiance at normal incidence
does light arrive?" The caller multiplies by max(N.L, 0) and by the shadow
ray's verdict. So for a point light of power P at distance r:

    E_normal = P / (4 pi) / r^2      (intensity I = P / (4 pi) W/sr, then 1/r^2)

Every formula here was checked against Cycles 4.x/5.0 renders (bpy 5.0.1).

Lights without extent (point and spot of radius 0, sun of angle 0) are exact:
one direction, no noise. Lights with extent (sphere, sun disk, area) are
sampled: each sample returns an unbiased estimate E_normal = L_e G / pdf whose
average over samples converges to the true irradiance.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .. import vectors
from ..scene.scene import AreaLight, PointLight, SpotLight, SunLight

INV_4PI = 1.0 / (4.0 * math.pi)


class LightSample(NamedTuple):
    """Light arriving at a batch of points.

    L:          (n, 3) float64 unit direction from the point towards the light
    distance:   (n,) float64 distance to the sampled light point (inf for the sun)
    strength:   (n,) float64 irradiance at normal incidence carried by this sample per unit of
                the light's colour (W/m^2); zero where the light sends nothing
    color:      (3,) float64 the light's RGB colour
    position:   (n, 3) float64 the sampled light point (undefined for the sun)
    """

    L: np.ndarray
    distance: np.ndarray
    strength: np.ndarray
    color: np.ndarray
    position: np.ndarray

    @property
    def irradiance(self) -> np.ndarray:
        """The RGB irradiance at normal incidence: (n, 3) float64 W/m^2."""
        return self.strength[:, None] * self.color


def is_delta(light) -> bool:
    """Whether the light has no extent, so one exact evaluation replaces sampling."""
    if isinstance(light, (PointLight, SpotLight)):
        return light.radius <= 0.0
    if isinstance(light, SunLight):
        return light.angle <= 0.0
    return False


def _direction_to(points: np.ndarray, targets: np.ndarray):
    """Return (unit direction, distance) from each point to its target (a zero vector where they coincide).

    points, targets: (n, 3) float64 -> (n, 3) float64, (n,) float64
    """
    w = targets - points
    distance = np.sqrt(np.einsum("ij,ij->i", w, w))
    inverse = np.divide(1.0, distance, out=np.zeros_like(distance), where=distance > 0.0)
    w *= inverse[:, None]
    return w, distance


class Cone(NamedTuple):
    """The cone of directions a light with extent covers from each shading point.

    It depends on the points only, not on the sample, so it is built once per light and
    shared by all that light's samples (`light_cone`).
    axis:    (n, 3) float64 unit direction to the light's centre (may be a broadcast row)
    t, b:    (n, 3) float64 unit vectors completing axis to an orthonormal frame
    cos_max: (n,) float64 cosine of the cone's half-angle
    d:       (n,) float64 distance to the light's centre (inf for the sun)
    """

    axis: np.ndarray
    t: np.ndarray
    b: np.ndarray
    cos_max: np.ndarray
    d: np.ndarray


def _sample_cone(cone: Cone, u: np.ndarray):
    """Return unit directions uniform in solid angle within each cone: u (n, 2) float64 -> (n, 3) float64."""
    cos_theta = 1.0 - u[:, 0] * (1.0 - cone.cos_max)
    sin_theta = np.sqrt(np.maximum(0.0, 1.0 - cos_theta * cos_theta))
    cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
    return (cone.t * (sin_theta * cos_phi)[:, None] + cone.b * (sin_theta * sin_phi)[:, None]
            + cone.axis * cos_theta[:, None])


def orthonormal_frame(axis: np.ndarray):
    """Return two unit vectors (t, b) that complete each unit axis to a right-handed orthonormal frame.

    Duff et al., "Building an Orthonormal Basis, Revisited" (2017): no branches, no cross products.
    axis: (n, 3) float64 unit -> t, b: (n, 3) float64
    """
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    sign = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    c = x * y * a
    t = vectors.rows(1.0 + sign * x * x * a, sign * c, -sign * x)
    b = vectors.rows(c, sign + y * y * a, -y)
    return t, b


# ---------------------------------------------------------------------------
# Per-light constants: what does not depend on the shading point (core/kernels.py reads them too)
# ---------------------------------------------------------------------------

def spot_cone(light: SpotLight) -> tuple[float, float]:
    """Return (c0, blend width): the cosine of the spot cone's half-angle and its soft edge's width in cosine."""
    cos_half = math.cos(0.5 * light.spot_size)
    return cos_half, (1.0 - cos_half) * light.spot_blend


def sphere_radiance(power: float, radius: float) -> float:
    """Return the radiance P / (4 pi^2 R^2) of a point light of radius R > 0 (from afar: intensity P / (4 pi))."""
    return power / (4.0 * math.pi * math.pi * radius * radius)


def sun_disk_strength(light: SunLight) -> float:
    """Return the irradiance each sample of a sun disk of angle > 0 carries: radiance S / (pi sin^2 a), times 2 pi (1 - cos a)."""
    half = 0.5 * light.angle
    radiance = light.strength / (math.pi * math.sin(half) ** 2)
    return radiance * 2.0 * math.pi * (1.0 - math.cos(half))


def area_radiance(light: AreaLight, area: float) -> float:
    """Return the radiance P / (pi A) of a one-sided area light of area A (0 for a degenerate light)."""
    return light.power / (math.pi * area) if area > 0 else 0.0


def spread_constants(spread: float) -> tuple[float, float]:
    """Return (tan h, norm) of `spread_attenuation` for a spread below pi, h = spread / 2; norm = tan h - h."""
    half = 0.5 * max(spread, 1e-6)
    return math.tan(half), (math.tan(half) - half if half > 0.05 else half ** 3 / 3.0)


def spot_inverse_frame(light: SpotLight) -> np.ndarray:
    """Return the world-to-spot-local matrix of a spot with a (scaled) frame: (3, 3) float64."""
    return vectors.determinant_and_inverse(np.asarray(light.frame, np.float64)[None])[1][0]


def spot_attenuation(light: SpotLight, directions: np.ndarray) -> np.ndarray:
    """Return Blender's spot cone factor for light leaving along each direction.

    The direction is taken into the light's own frame (scale included, so a
    non-uniformly scaled spot has an elliptical cone) and c is its cosine to
    the local -Z axis. With c0 = cos(spot_size / 2), the factor is
    smoothstep((c - c0) / ((1 - c0) spot_blend)): 0 outside the cone, 1 in its
    inner part, a smooth ramp over the outer `spot_blend` fraction in cosine.
    directions: (n, 3) float64 unit, from the light towards the point -> (n,) float64
    """
    if light.frame is None:
        cos_angle = np.einsum("ij,j->i", directions, np.asarray(light.direction, np.float64))
    else:
        local = np.einsum("ij,kj->ik", directions, spot_inverse_frame(light))
        length = np.linalg.norm(local, axis=1)
        cos_angle = -local[:, 2] / np.where(length > 0, length, 1.0)
    cos_half, blend_width = spot_cone(light)
    if blend_width <= 0.0:
        return (cos_angle > cos_half).astype(np.float64)
    x = np.clip((cos_angle - cos_half) / blend_width, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _round_light_cone(center: np.ndarray, radius: float, soft_falloff: bool, points: np.ndarray) -> Cone:
    """Return the cone a point light of radius R > 0 covers from each point.

    As in Cycles, with soft falloff (Blender's default) the light is a disk of radius R facing
    the shading point: sin^2 a = R^2 / (R^2 + d^2). Without it, it is a sphere:
    sin^2 a = R^2 / d^2, which gives exactly the point light's irradiance while above the horizon.
    points: (n, 3) float64
    """
    to_center, d = _direction_to(points, np.broadcast_to(center, points.shape))
    if soft_falloff:
        sin2_max = radius * radius / (radius * radius + d * d)
    else:
        d = np.maximum(d, radius * (1.0 + 1e-9))        # a point inside the sphere sees it from its surface
        sin2_max = np.minimum(1.0, (radius / d) ** 2)
    t, b = orthonormal_frame(to_center)
    return Cone(to_center, t, b, np.sqrt(1.0 - sin2_max), d)


def _sample_round_light(cone: Cone, radius: float, soft_falloff: bool, power: float,
                        color: np.ndarray, points: np.ndarray, u: np.ndarray) -> LightSample:
    """Sample a point light of radius R > 0, uniformly over the cone of directions it covers.

    Its radiance is L_e = P / (4 pi^2 R^2), so that from afar it is a point light
    of intensity P / (4 pi). pdf = 1 / (2 pi (1 - cos a)), so each sample carries
    E_normal = L_e 2 pi (1 - cos a). cone: from `_round_light_cone` for these points.
    """
    L = _sample_cone(cone, u)
    cos_to_center = np.einsum("ij,ij->i", L, cone.axis)
    d = cone.d
    if soft_falloff:
        distance = d / np.maximum(cos_to_center, 1e-300)  # to the disk through the centre, facing the point
    else:
        b = d * cos_to_center                              # to the near side of the sphere
        distance = b - np.sqrt(np.maximum(0.0, b * b - (d * d - radius * radius)))
    strength = sphere_radiance(power, radius) * 2.0 * math.pi * (1.0 - cone.cos_max)
    return LightSample(L, distance, strength, color, points + L * distance[:, None])


def spread_attenuation(spread: float, cos_light: np.ndarray) -> np.ndarray:
    """Return Blender's area-light spread factor for emission at angle theta to the light's normal.

    spread = pi (the default) is a Lambertian emitter: factor 1. A narrower spread,
    with h = spread / 2, weighs the radiance by max(0, tan h - tan theta) / (tan h - h),
    which keeps the emitted power unchanged. cos_light: (n,) float64 -> (n,) float64
    """
    if spread >= math.pi:
        return np.ones_like(cos_light)
    tan_half, norm = spread_constants(spread)
    with np.errstate(divide="ignore", invalid="ignore"):
        tan_theta = np.sqrt(np.maximum(0.0, 1.0 - cos_light * cos_light)) / cos_light
    return np.where(cos_light > 0, np.maximum(0.0, tan_half - tan_theta), 0.0) / norm


def _area_points(light: AreaLight, u: np.ndarray) -> tuple[np.ndarray, float]:
    """Map unit-square samples to points on the area light, uniform in area; return (points, area)."""
    axis_u = np.asarray(light.axis_u, np.float64)
    axis_v = np.asarray(light.axis_v, np.float64)
    parallelogram = float(np.linalg.norm(np.cross(axis_u, axis_v)))
    if light.shape in ("DISK", "ELLIPSE"):
        # Concentric map of the square onto the unit disk (Shirley-Chiu), then scale to the ellipse.
        a = 2.0 * u[:, 0] - 1.0
        b = 2.0 * u[:, 1] - 1.0
        use_a = np.abs(a) > np.abs(b)
        r = np.where(use_a, a, b)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(use_a, b, a) / r
        ratio[r == 0.0] = 0.0
        phi = np.where(use_a, (math.pi / 4) * ratio, (math.pi / 2) - (math.pi / 4) * ratio)
        cos_phi, sin_phi = vectors.cos_sin(np.where(phi < 0.0, phi + 2.0 * math.pi, phi))
        x, y = 0.5 * r * cos_phi, 0.5 * r * sin_phi
        area = 0.25 * math.pi * parallelogram
    else:
        x, y = u[:, 0] - 0.5, u[:, 1] - 0.5
        area = parallelogram
    points = vectors.combine(np.asarray(light.center, np.float64), [x, y], [axis_u, axis_v])
    return points, area


def area_light_area(light: AreaLight) -> float:
    """Return the emitting area of an area light in m^2."""
    return _area_points(light, np.zeros((1, 2)))[1]


def light_cone(light, points: np.ndarray):
    """Return the Cone a sphere light or sun disk covers from each point, or None for other lights.

    It is the part of sampling that depends on the points only: compute it once per light and
    pass it to every `sample_light` call for the same points. points: (n, 3) float64
    """
    if isinstance(light, SunLight) and light.angle > 0.0:
        # The same cone everywhere: one frame, broadcast to all points.
        travel = np.asarray(light.direction, np.float64)
        axis = -travel / np.linalg.norm(travel)
        t, b = orthonormal_frame(axis[None, :])
        n = len(points)
        return Cone(np.broadcast_to(axis, (n, 3)), np.broadcast_to(t, (n, 3)), np.broadcast_to(b, (n, 3)),
                    np.full(n, math.cos(0.5 * light.angle)), np.full(n, np.inf))
    if isinstance(light, (PointLight, SpotLight)) and light.radius > 0.0:
        return _round_light_cone(np.asarray(light.position, np.float64), light.radius, light.soft_falloff, points)
    return None


def sample_light(light, points: np.ndarray, u: np.ndarray, cone=None) -> LightSample:
    """Return the light arriving at each point from `light`, one sample per point.

    points: (n, 3) float64 shading points in the same space as the light;
    u: (n, 2) float64 uniform numbers in [0, 1) (ignored by lights without extent);
    cone: `light_cone(light, points)`, if the caller already has it.
    """
    n = len(points)
    color = np.asarray(light.color, np.float64)[:3]
    if cone is None:
        cone = light_cone(light, points)

    if isinstance(light, SunLight):
        if light.angle <= 0.0:
            # A distant light: one direction, irradiance = strength, no distance attenuation.
            travel = np.asarray(light.direction, np.float64)
            L = np.broadcast_to(-travel / np.linalg.norm(travel), (n, 3)).copy()
            strength = np.full(n, float(light.strength))
        else:
            # A disk of directions of angular radius a with uniform radiance S / (pi sin^2 a).
            L = _sample_cone(cone, u)
            strength = np.full(n, sun_disk_strength(light))
        return LightSample(L, np.full(n, np.inf), strength, color, np.zeros((n, 3)))

    if isinstance(light, (PointLight, SpotLight)):
        center = np.asarray(light.position, np.float64)
        if light.radius <= 0.0:
            # The lecture's point light: I = P / (4 pi), attenuated by 1 / r^2.
            L, distance = _direction_to(points, np.broadcast_to(center, points.shape))
            with np.errstate(divide="ignore"):
                falloff = np.where(distance > 0, 1.0 / (distance * distance), 0.0)
            sample = LightSample(L, distance, light.power * INV_4PI * falloff, color,
                                 np.broadcast_to(center, points.shape))
        else:
            sample = _sample_round_light(cone, light.radius, light.soft_falloff, light.power, color, points, u)
        if isinstance(light, SpotLight):
            # The cone is evaluated for the direction from the (sampled) light point to the surface.
            sample = sample._replace(strength=sample.strength * spot_attenuation(light, -sample.L))
        return sample

    if isinstance(light, AreaLight):
        # A one-sided emitter of radiance P / (pi A), sampled uniformly in area:
        # E_normal = L_e cos(theta_light) A / d^2.
        targets, area = _area_points(light, u)
        L, distance = _direction_to(points, targets)
        normal = np.asarray(light.direction, np.float64)
        cos_light = -np.einsum("ij,j->i", L, normal)
        radiance = area_radiance(light, area)
        with np.errstate(divide="ignore", invalid="ignore"):
            geometry = np.where((cos_light > 0) & (distance > 0), cos_light * area / (distance * distance), 0.0)
        geometry *= spread_attenuation(light.spread, cos_light)
        return LightSample(L, distance, radiance * geometry, color, targets)

    raise TypeError(f"unknown light type {type(light).__name__}")


def without_distance_attenuation(light, sample: LightSample, points: np.ndarray) -> LightSample:
    """Return the sample with its 1/r^2 falloff undone (the lecture switch "distance attenuation" off).

    A point or spot light then gives E_normal = P / (4 pi) at any distance (r: to its centre); an
    area light sample is multiplied by r^2 to its sampled point; a sun has no falloff to undo.
    points: (n, 3) float64 shading points in the light's space.
    """
    if isinstance(light, SunLight):
        return sample
    if isinstance(light, (PointLight, SpotLight)):
        w = points - np.asarray(light.position, np.float64)
        r2 = np.einsum("ij,ij->i", w, w)
    else:
        r2 = sample.distance * sample.distance
    return sample._replace(strength=sample.strength * r2)
