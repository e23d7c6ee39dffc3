"""Area lights: a one-sided planar emitter (square, rectangle, disk or ellipse).

A square or rectangle is sampled uniformly in the solid angle it subtends (a spherical rectangle, Urena et al. 2013,
core/lights/emitters.py), as Cycles samples it, wherever it is large against its distance (the emitters' rule,
within NEAR of its diagonals); far from it, and on disks and ellipses, a point uniform in its area.

A lamp of narrow Spread lights a point P only from the disk of radius r = h tan(spread / 2) around P's foot on
its plane (h: P's height over it); the rest of the lamp sends P nothing. As Cycles 5.0 does
(kernel/light/area.h area_light_spread_clamp_light), the samples are then drawn from the smallest of a few shapes
that hold the part of the lamp that can light P (`spread_region`): a square or rectangle's clamped rectangle (that
disk's bounding square cut to the lamp), sampled over its spherical rectangle as the whole lamp would be; for a
disk or an ellipse, that clamped rectangle, the spread disk itself or the whole lamp, whichever is smallest in area
(for a disk, the rectangle around the lens where the two disks overlap instead of the clamped one); a point of a
disk or an ellipse drawn outside the lamp is no sample (it sends nothing). The pdf is the clamped region's, so a
BSDF ray that meets the lamp (`hit`) gets the pdf of the region its origin would have sampled, and MIS stays
consistent. Same expectation, far fewer wasted samples (docs/lecture.md, Light units)."""
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
class SpreadRegion:
    """The part of an area lamp each of n points samples under a narrow spread (AreaLight.spread_region).

    center: (n, 3) float64 the region's centre on the lamp's plane
    U, V:   (n, 3) float64 its full edges (a rectangle's sides, an ellipse's diameters), at right angles
    round:  (n,) bool an ellipse (sampled uniformly in area) rather than a rectangle (over its spherical rectangle)
    empty:  (n,) bool no point of the lamp lights the point (behind it, or its spread disk misses the lamp)
    """

    center: np.ndarray
    U: np.ndarray
    V: np.ndarray
    round: np.ndarray
    empty: np.ndarray

    def area(self) -> np.ndarray:
        """Each region's area (n,) float64: |U x V|, times pi / 4 for an ellipse."""
        w = np.cross(self.U, self.V)
        return np.sqrt(np.einsum("ij,ij->i", w, w)) * np.where(self.round, 0.25 * math.pi, 1.0)

    def rectangles(self) -> np.ndarray:
        """Each region as a rectangle [corner, edge u, edge v] (n, 3, 3) float64 (meaningful where not round)."""
        return np.stack([self.center - 0.5 * self.U - 0.5 * self.V, self.U, self.V], axis=1)


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
    caustics: bool = False                # a Shadow Caustics light (Cycles' MNEE, core/integrators/mnee.py)
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

    def spread_clamps(self) -> bool:
        """Whether the lamp samples only the part of it its spread lets light a point (`spread_region`): a spread
        below pi on a lamp whose edges meet each other and its direction at right angles to 1e-9 (Cycles takes
        them to; a sheared parallelogram samples its whole shape)."""
        if self.spread >= math.pi:
            return False
        axis_u, axis_v = np.asarray(self.axis_u, np.float64), np.asarray(self.axis_v, np.float64)
        normal = np.asarray(self.direction, np.float64)
        lu, lv = float(np.linalg.norm(axis_u)), float(np.linalg.norm(axis_v))
        return (lu * lv > 0.0 and abs(float(axis_u @ axis_v)) <= 1e-9 * lu * lv
                and abs(float(axis_u @ normal)) <= 1e-9 * lu and abs(float(axis_v @ normal)) <= 1e-9 * lv)

    def spread_region(self, points: np.ndarray) -> SpreadRegion:
        """The region of the lamp's plane each point (n, 3) samples under its narrow spread (Cycles'
        area_light_spread_clamp_light; C: area_spread_region), holding every lamp point within r = h tan(spread / 2)
        of the point's foot F on the plane (h its height), the only ones that light it:

        - a square or rectangle: the square of side 2 r around F cut to the lamp;
        - an ellipse: that clamped rectangle, the spread disk (radius r around F) or the whole lamp, the smallest;
        - a disk (radius R, its centre at d from F): none where d >= R + r; where one disk holds the other, the
          smaller; where they cross, the rectangle around their lens (from the disk's near edge to the spread
          disk's far one along F -> centre, as wide as the lens), the spread disk or the whole lamp, the smallest.
        """
        points = np.asarray(points, np.float64)
        n = len(points)
        normal = np.asarray(self.direction, np.float64)
        center = np.asarray(self.center, np.float64)
        axis_u, axis_v = np.asarray(self.axis_u, np.float64), np.asarray(self.axis_v, np.float64)
        lu, lv = float(np.linalg.norm(axis_u)), float(np.linalg.norm(axis_v))
        eu, ev = axis_u / lu, axis_v / lv
        tan_half = spread_constants(self.spread)[0]
        h = (points - center) @ normal                              # the height over the plane (> 0 in front)
        r = h * tan_half                                            # the spread disk's radius
        foot = points - h[:, None] * normal
        su, sv = (foot - center) @ eu, (foot - center) @ ev         # the foot in the lamp's own frame
        lo_u, hi_u = np.maximum(su - r, -0.5 * lu), np.minimum(su + r, 0.5 * lu)
        lo_v, hi_v = np.maximum(sv - r, -0.5 * lv), np.minimum(sv + r, 0.5 * lv)
        empty = ~(h > 0.0) | (lo_u >= hi_u) | (lo_v >= hi_v)
        # The clamped rectangle (a square or rectangle's region).
        mid_u, mid_v = 0.5 * (lo_u + hi_u), 0.5 * (lo_v + hi_v)
        C = center + mid_u[:, None] * eu + mid_v[:, None] * ev
        U, V = (hi_u - lo_u)[:, None] * eu, (hi_v - lo_v)[:, None] * ev
        is_round = np.zeros(n, bool)
        if self.round:
            spread_area = math.pi * r * r
            lamp_area = 0.25 * math.pi * lu * lv
            if abs(lu - lv) <= 1e-9 * max(lu, lv):                  # a disk: how the two disks meet
                R = 0.5 * lu
                d = np.hypot(su, sv)
                empty = ~(h > 0.0) | (d >= R + r)
                inner = d <= np.abs(R - r)
                with np.errstate(divide="ignore", invalid="ignore"):
                    lens_u = R + r - d
                    lens_v = np.where(np.abs(R * R - r * r) >= d * d, 2.0 * np.minimum(R, r),
                                      np.sqrt(np.maximum((2.0 * r) ** 2 - (d + (r * r - R * R) / d) ** 2, 0.0)))
                    lens = ~inner & (lens_u * lens_v < np.minimum(lamp_area, spread_area))
                    to_center = np.where(d[:, None] > 0.0, (center - foot) / d[:, None], eu)
                across = np.cross(normal, to_center)
                C = 0.5 * (center + foot + (r - R)[:, None] * to_center)
                U, V = lens_u[:, None] * to_center, lens_v[:, None] * across
                use_spread = np.where(inner, r < R, ~lens & (spread_area < lamp_area))
                rectangle = lens
            else:                                                   # an ellipse
                rectangle = (hi_u - lo_u) * (hi_v - lo_v) < np.minimum(lamp_area, spread_area)
                use_spread = ~rectangle & (spread_area < lamp_area)
            whole = ~rectangle & ~use_spread
            spread_center = center + su[:, None] * eu + sv[:, None] * ev
            C = np.where(use_spread[:, None], spread_center, np.where(whole[:, None], center, C))
            U = np.where(use_spread[:, None], (2.0 * r)[:, None] * eu, np.where(whole[:, None], axis_u, U))
            V = np.where(use_spread[:, None], (2.0 * r)[:, None] * ev, np.where(whole[:, None], axis_v, V))
            is_round = ~rectangle
        return SpreadRegion(C, U, V, is_round, empty)

    def sample_spread_region(self, points: np.ndarray, u: np.ndarray) -> tuple:
        """Light samples drawn from each point's `spread_region`: a rectangle over its spherical rectangle within NEAR
        of its diagonals (pdf 1 / Omega), else a point uniform in the region's area (pdf d^2 / (cos A_region)); a
        point of a disk or an ellipse outside the lamp, and an empty region, give no sample (pdf 0).
        points (n, 3), u (n, 2) -> (L (n, 3), distance (n,), targets (n, 3), cos_light (n,), pdf (n,))."""
        g = self.spread_region(points)
        normal = np.asarray(self.direction, np.float64)
        x, y = concentric_disk(u)
        x, y = np.where(g.round, x, u[:, 0] - 0.5), np.where(g.round, y, u[:, 1] - 0.5)
        targets = x[:, None] * g.U + y[:, None] * g.V + g.center
        L, distance = direction_to(points, targets)
        R = g.rectangles()
        diagonal = g.U + g.V
        height = np.einsum("ij,j->i", points - R[:, 0], normal)
        spherical = ~g.round & ~g.empty & (height * height < NEAR * NEAR * np.einsum("ij,ij->i", diagonal, diagonal))
        rows = np.flatnonzero(spherical)
        if len(rows):
            L[rows], distance[rows], by_angle = spherical_rectangle_sample(points[rows], R[rows], u[rows, :2])
            targets[rows] = points[rows] + distance[rows, None] * L[rows]
        cos_light = -np.einsum("ij,j->i", L, normal)
        facing = (cos_light > 0) & (distance > 0) & ~g.empty
        if self.round:                                              # (the region may reach past the lamp)
            axis_u, axis_v = np.asarray(self.axis_u, np.float64), np.asarray(self.axis_v, np.float64)
            offset = targets - np.asarray(self.center, np.float64)
            lx, ly = offset @ axis_u / (axis_u @ axis_u), offset @ axis_v / (axis_v @ axis_v)
            facing &= lx * lx + ly * ly <= 0.25 * (1.0 + 1e-9)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.where(facing, distance * distance / (cos_light * g.area()), 0.0)
        if len(rows):
            pdf[rows] = np.where(facing[rows], by_angle, 0.0)
        return L, distance, targets, cos_light, pdf

    def spread_region_pdf(self, origins: np.ndarray, cos_light: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The pdf (n,) with which `sample_spread_region` from origins (n, 3) chooses the lamp point t (n,) away
        along a ray meeting the plane at cos(theta_light) cos_light (n,) > 0: 1 / Omega of the origin's region where
        it is a near rectangle, else t^2 / (cos A_region); 0 where the region is empty."""
        g = self.spread_region(origins)
        normal = np.asarray(self.direction, np.float64)
        R = g.rectangles()
        diagonal = g.U + g.V
        height = np.einsum("ij,j->i", origins - R[:, 0], normal)
        spherical = ~g.round & ~g.empty & (height * height < NEAR * NEAR * np.einsum("ij,ij->i", diagonal, diagonal))
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.where(g.empty, 0.0, t * t / (cos_light * g.area()))
        rows = np.flatnonzero(spherical)
        if len(rows):
            omega = rectangle_solid_angle(origins[rows], R[rows])
            pdf[rows] = np.where(omega > 0.0, 1.0 / omega, 0.0)
        return pdf

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

    def sample(self, points: np.ndarray, u: np.ndarray, cone: Optional[Cone] = None, N=None,
               paths=None) -> LightSample:
        """A direction uniform in the spherical rectangle where `spherical` (pdf = 1 / Omega), else a point uniform
        in area (pdf = d^2 / (cos(theta_light) A)); E_normal = L_e / pdf on the emitting side. Under a narrow
        spread (`spread_clamps`), from the part of the lamp that can light each point (`sample_spread_region`)."""
        if self.spread_clamps():
            L, distance, targets, cos_light, pdf = self.sample_spread_region(points, u)
            with np.errstate(divide="ignore", invalid="ignore"):
                geometry = np.where(pdf > 0.0, 1.0 / pdf, 0.0)
            geometry *= spread_attenuation(self.spread, cos_light) * self.ies_factor(-L) * self.falloff_factor(distance)
            return LightSample(L, distance, self.radiance() * geometry, pdf, self.emitted(targets, -L, distance, paths),
                               targets)
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
        return LightSample(L, distance, self.radiance() * geometry, pdf, self.emitted(targets, -L, distance, paths),
                           targets)

    def hit(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray, paths=None) -> LightHit:
        """Rays meet the light's plane from its emitting side, inside its shape: radiance L_e (spread
        applied) and the pdf `sample` gives that direction (1 / Omega or d^2 / (cos(theta_light) A); under a narrow
        spread, its origin's `spread_region_pdf`)."""
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
            if self.spread_clamps() and hit.any():
                rows = np.flatnonzero(hit)
                pdf[rows] = self.spread_region_pdf(origins[rows], cos_light[rows], t[rows])
            radiance = np.where(hit, self.radiance() * spread_attenuation(self.spread, cos_light)
                                * self.ies_factor(-directions) * self.falloff_factor(np.where(hit, t, 1.0)), 0.0)
        reach = np.where(hit, t, 1.0)
        color = self.emitted(origins + directions * reach[:, None], -directions, reach, paths)
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
