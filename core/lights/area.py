"""Area lights: a one-sided planar emitter (square, rectangle, disk or ellipse).

A square or rectangle is sampled uniformly in the solid angle it subtends (a spherical rectangle, Urena et al. 2013,
core/lights/emitters.py), as Cycles samples it, wherever it is large against its distance (the emitters' rule,
within NEAR of its diagonals); far from it, and on disks and ellipses, a point uniform in its area."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Optional

import numpy as np

from .. import vectors
from ..native import schema
from .emitters import rectangle_solid_angle, spherical_rectangle_sample
from .base import Cone, Light, LightFlags, LightHit, LightSample, direction_to
from .ies import IESLamp
from .lamp_graph import LampEmission
from .linking import ALL_SETS

NEAR = schema.constant("AREA_NEAR", 100.0, "the heights over an Area lamp (in its diagonals) within which its "
                       "spherical rectangle samples it")


def spread_constants(spread: float) -> tuple[float, float]:
    """Return (tan h, norm) of `spread_attenuation` for a spread below pi, h = spread / 2; norm = tan h - h."""
    half = 0.5 * max(spread, 1e-6)
    return math.tan(half), (math.tan(half) - half if half > 0.05 else half ** 3 / 3.0)


def spread_attenuation(spread: float, cos_light: np.ndarray) -> np.ndarray:
    """Return Blender's area-light spread factor for emission at angle theta to the light's normal.

    spread = pi (the default) is a Lambertian emitter: factor 1. A narrower spread, with
    h = spread / 2, weighs the radiance by max(0, tan h - tan theta) / (tan h - h), which keeps
    the emitted power unchanged. cos_light: (n,) float64 -> (n,) float64
    """
    if spread >= math.pi:
        return np.ones_like(cos_light)
    tan_half, norm = spread_constants(spread)
    with np.errstate(divide="ignore", invalid="ignore"):
        tan_theta = np.sqrt(np.maximum(0.0, 1.0 - cos_light * cos_light)) / cos_light
    return np.where(cos_light > 0, np.maximum(0.0, tan_half - tan_theta), 0.0) / norm


def concentric_disk(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map unit-square points onto the disk of radius 1/2 (Shirley-Chiu's concentric map): (n, 2) -> x, y (n,)."""
    a = 2.0 * u[:, 0] - 1.0
    b = 2.0 * u[:, 1] - 1.0
    use_a = np.abs(a) > np.abs(b)
    r = np.where(use_a, a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(use_a, b, a) / r
    ratio[r == 0.0] = 0.0
    phi = np.where(use_a, (math.pi / 4) * ratio, (math.pi / 2) - (math.pi / 4) * ratio)
    cos_phi, sin_phi = vectors.cos_sin(np.where(phi < 0.0, phi + 2.0 * math.pi, phi))
    return 0.5 * r * cos_phi, 0.5 * r * sin_phi


@dataclass
class AreaLight(Light):
    """A one-sided planar emitter of `power` watts with radiance P / (pi A).

    center:    (3,) float64 world point
    axis_u:    (3,) float64 world vector spanning the full size along the light's local X
    axis_v:    (3,) float64 world vector spanning the full size along the light's local Y
    direction: (3,) float64 unit normal on the emitting side (Blender's local -Z)
    shape:     "SQUARE" | "RECTANGLE" (a parallelogram from the two axes) or "DISK" | "ELLIPSE"
    spread:    radians; below pi, Blender narrows the emission towards the normal (power kept)
    """

    center: np.ndarray
    axis_u: np.ndarray
    axis_v: np.ndarray
    direction: np.ndarray
    power: float = 100.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    shape: str = "SQUARE"
    spread: float = math.pi
    name: str = "Area"
    camera: bool = True                   # seen by camera rays (Blender: Ray Visibility > Camera)
    cast_shadow: bool = True              # its light is stopped by what stands in the way (Blender: Cast Shadow)
    hidden_from: int = 0                  # HIDDEN_FROM_* bits of the bounces that do not see it (Ray Visibility)
    use_mis: bool = True                  # BSDF rays find it too, weighed by MIS (Blender: Multiple Importance)
    max_bounces: int = 1024               # its light samples stop after this many bounces (Blender: Max Bounces)
    light_membership: int = ALL_SETS        # the receiver light sets it lights (Light Linking, core/lights/linking.py)
    shadow_membership: int = ALL_SETS       # the blocker shadow sets that cast its shadows (Shadow Linking)
    ies: Optional[IESLamp] = None           # an IES Texture scaling the light by direction (core/lights/ies.py)
    falloff: tuple = (0, 0.0)               # a Light Falloff node: (power of the distance, Smooth) (Light.falloff_factor)
    lamp_nodes: Optional[LampEmission] = None  # a tree that varies over the lamp (core/lights/lamp_graph.py)

    flags: ClassVar[LightFlags] = LightFlags.AREA
    blender_type: ClassVar[str] = "AREA"
    point_fields: ClassVar[tuple] = ("center",)

    @property
    def round(self) -> bool:
        """Whether the light is a disk or an ellipse (else a parallelogram)."""
        return self.shape in ("DISK", "ELLIPSE")

    def area(self) -> float:
        """Return the emitting area in m^2."""
        parallelogram = float(np.linalg.norm(np.cross(np.asarray(self.axis_u, np.float64),
                                                      np.asarray(self.axis_v, np.float64))))
        return 0.25 * math.pi * parallelogram if self.round else parallelogram

    def radiance(self) -> float:
        """Return the radiance P / (pi A) (0 for a degenerate light)."""
        area = self.area()
        return self.power / (math.pi * area) if area > 0 else 0.0

    def points(self, u: np.ndarray) -> np.ndarray:
        """Map unit-square samples to points on the light, uniform in area: (n, 2) -> (n, 3) float64."""
        if self.round:
            x, y = concentric_disk(u)
        else:
            x, y = u[:, 0] - 0.5, u[:, 1] - 0.5
        return vectors.combine(np.asarray(self.center, np.float64), [x, y],
                               [np.asarray(self.axis_u, np.float64), np.asarray(self.axis_v, np.float64)])

    def rectangle(self) -> Optional[np.ndarray]:
        """The light as a rectangle [corner, edge u, edge v] (3, 3) float64 where it is one (a square or rectangle
        whose edges meet each other and its direction at right angles to 1e-9), else None (a disk, an ellipse, a
        sheared parallelogram)."""
        axis_u, axis_v = np.asarray(self.axis_u, np.float64), np.asarray(self.axis_v, np.float64)
        normal = np.asarray(self.direction, np.float64)
        lu, lv = float(np.linalg.norm(axis_u)), float(np.linalg.norm(axis_v))
        if (self.round or lu * lv <= 0.0 or abs(float(axis_u @ axis_v)) > 1e-9 * lu * lv
                or abs(float(axis_u @ normal)) > 1e-9 * lu or abs(float(axis_v @ normal)) > 1e-9 * lv):
            return None
        return np.stack([np.asarray(self.center, np.float64) - 0.5 * axis_u - 0.5 * axis_v, axis_u, axis_v])

    def spherical(self, points: np.ndarray) -> np.ndarray:
        """Whether the spherical rectangle serves each point (n, 3) rather than area sampling: (n,) bool; where the
        point's height h over the plane is below NEAR diagonals (there the solid angle is >= about 1e-4 of the
        lamp's, and its asin terms lose no digits that matter; a rule of ratios, so a scaled scene samples alike;
        C: area_spherical)."""
        R = self.rectangle()
        if R is None:
            return np.zeros(len(points), bool)
        height = (points - R[0]) @ np.asarray(self.direction, np.float64)
        diagonal = R[1] + R[2]
        return height * height < NEAR * NEAR * float(diagonal @ diagonal)

    def sample(self, points: np.ndarray, u: np.ndarray, cone: Optional[Cone] = None, N=None) -> LightSample:
        """A direction uniform in the spherical rectangle where `spherical` (pdf = 1 / Omega), else a point uniform
        in area (pdf = d^2 / (cos(theta_light) A)); E_normal = L_e / pdf on the emitting side."""
        targets = self.points(u)
        area = self.area()
        L, distance = direction_to(points, targets)
        spherical = self.spherical(points)
        if spherical.any():
            rows = np.flatnonzero(spherical)
            R = np.broadcast_to(self.rectangle(), (len(rows), 3, 3))
            L[rows], distance[rows], by_angle = spherical_rectangle_sample(points[rows], R, u[rows, :2])
            targets[rows] = points[rows] + distance[rows, None] * L[rows]
        normal = np.asarray(self.direction, np.float64)
        cos_light = -np.einsum("ij,j->i", L, normal)
        with np.errstate(divide="ignore", invalid="ignore"):
            facing = (cos_light > 0) & (distance > 0)
            pdf = np.where(facing, distance * distance / (cos_light * area), 0.0)
            if spherical.any():
                pdf[rows] = np.where(facing[rows], by_angle, 0.0)
            facing &= pdf > 0.0
            geometry = np.where(facing, 1.0 / pdf, 0.0)
        geometry *= spread_attenuation(self.spread, cos_light) * self.ies_factor(-L) * self.falloff_factor(distance)
        return LightSample(L, distance, self.radiance() * geometry, pdf, self.emitted(targets, -L, distance), targets)

    def hit(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray) -> LightHit:
        """Rays meet the light's plane from its emitting side, inside its shape: radiance L_e (spread
        applied) and the pdf `sample` gives that direction (1 / Omega or d^2 / (cos(theta_light) A))."""
        normal = np.asarray(self.direction, np.float64)
        center = np.asarray(self.center, np.float64)
        axis_u, axis_v = np.asarray(self.axis_u, np.float64), np.asarray(self.axis_v, np.float64)
        cos_light = -np.einsum("ij,j->i", directions, normal)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.einsum("ij,j->i", center - origins, normal) / -cos_light
            X = origins + t[:, None] * directions - center
            # The hit point in the light's own coordinates (x, y in [-1/2, 1/2] on the square): the 2 x 2
            # Gram system of its edges, by Cramer's rule.
            uu, uv, vv = axis_u @ axis_u, axis_u @ axis_v, axis_v @ axis_v
            xu, xv = np.einsum("ij,j->i", X, axis_u), np.einsum("ij,j->i", X, axis_v)
            det = uu * vv - uv * uv
            x, y = (vv * xu - uv * xv) / det, (uu * xv - uv * xu) / det
            inside = (x * x + y * y <= 0.25) if self.round else ((np.abs(x) <= 0.5) & (np.abs(y) <= 0.5))
            hit = (cos_light > 0) & (t > 0) & (t < t_max) & inside
            area = self.area()
            pdf = np.where(hit, t * t / (cos_light * area), 0.0)
            spherical = hit & self.spherical(origins)
            if spherical.any():
                rows = np.flatnonzero(spherical)
                omega = rectangle_solid_angle(origins[rows], np.broadcast_to(self.rectangle(), (len(rows), 3, 3)))
                pdf[rows] = np.where(omega > 0.0, 1.0 / omega, 0.0)
            radiance = np.where(hit, self.radiance() * spread_attenuation(self.spread, cos_light)
                                * self.ies_factor(-directions) * self.falloff_factor(np.where(hit, t, 1.0)), 0.0)
        reach = np.where(hit, t, 1.0)
        color = self.emitted(origins + directions * reach[:, None], -directions, reach)
        return LightHit(hit, np.where(hit, t, np.inf), radiance[:, None] * color, pdf)

    @property
    def hittable(self) -> bool:
        return self.area() > 0.0 and self.spread > 0.0

    def centre_numbers(self) -> np.ndarray:
        """u = (0.5, 0.5) is the middle of the square, and the middle of the disk."""
        return np.array([0.5, 0.5])

    def pack_fields(self, record) -> None:
        record.position[:] = np.asarray(self.center, np.float64).tolist()
        record.direction[:] = np.asarray(self.direction, np.float64).tolist()
        record.axis_u[:] = np.asarray(self.axis_u, np.float64).tolist()
        record.axis_v[:] = np.asarray(self.axis_v, np.float64).tolist()
        record.ellipse = self.round
        record.area = self.area()
        record.radiance = self.radiance()
        if self.spread < math.pi:
            record.spread_narrow = 1
            record.spread_tan_half, record.spread_norm = spread_constants(self.spread)
