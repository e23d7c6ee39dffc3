"""Point lights: the lecture's light, and with a radius a round light that casts soft shadows."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Optional

import numpy as np

from ..vectors import orthonormal_frame
from .base import (INV_4PI, Cone, Light, LightFlags, LightHit, LightSample, cone_pdf, delta_pdf, direction_to,
                   sample_cone)
from .ies import IESLamp
from .lamp_graph import LampEmission
from .linking import ALL_SETS


def sphere_radiance(power: float, radius: float) -> float:
    """Return the radiance P / (4 pi^2 R^2) of a point light of radius R > 0 (from afar: intensity P / (4 pi))."""
    return power / (4.0 * math.pi * math.pi * radius * radius)


class RoundLight(Light):
    """What point and spot lights share: a point of `power` watts, or with radius > 0 a round light.

    Radiant intensity of the radius-0 light: I = power / (4 pi) W/sr. soft_falloff (Blender's
    default): the radius-R light is a disk of radiance P / (4 pi^2 R^2) that always faces the
    shading point; without it, a sphere.
    """

    point_fields: ClassVar[tuple] = ("position",)

    @property
    def delta(self) -> bool:
        return self.radius <= 0.0

    def cone(self, points: np.ndarray) -> Optional[Cone]:
        """Return the cone the light of radius R > 0 covers from each point (None at radius 0).

        As in Cycles, with soft falloff (Blender's default) the light is a disk of radius R facing
        the shading point: sin^2 a = R^2 / (R^2 + d^2). Without it, it is a sphere:
        sin^2 a = R^2 / d^2, which gives exactly the point light's irradiance while above the horizon.
        """
        if self.delta:
            return None
        radius = self.radius
        to_center, d = direction_to(points, np.broadcast_to(np.asarray(self.position, np.float64), points.shape))
        if self.soft_falloff:
            sin2_max = radius * radius / (radius * radius + d * d)
        else:
            d = np.maximum(d, radius * (1.0 + 1e-9))        # a point inside the sphere sees it from its surface
            sin2_max = np.minimum(1.0, (radius / d) ** 2)
        t, b = orthonormal_frame(to_center)
        return Cone(to_center, t, b, np.sqrt(1.0 - sin2_max), d)

    def sample(self, points: np.ndarray, u: np.ndarray, cone: Optional[Cone] = None, N=None,
               paths=None) -> LightSample:
        """The lecture's point light I / r^2; with a radius, a direction uniform in the cone it covers."""
        center = np.asarray(self.position, np.float64)
        if self.delta:
            # I = P / (4 pi), attenuated by 1 / r^2.
            L, distance = direction_to(points, np.broadcast_to(center, points.shape))
            with np.errstate(divide="ignore"):
                falloff = np.where(distance > 0, 1.0 / (distance * distance), 0.0)
            position = np.broadcast_to(center, points.shape)
            return LightSample(L, distance, self.power * INV_4PI * falloff * self.ies_factor(-L)
                               * self.falloff_factor(distance), delta_pdf(len(points)),
                               self.emitted(position, -L, distance, paths), position)
        # Radiance L_e = P / (4 pi^2 R^2) over the cone, pdf = 1 / (2 pi (1 - cos a)): each sample
        # carries E_normal = L_e 2 pi (1 - cos a).
        cone = self.cone(points) if cone is None else cone
        L = sample_cone(cone, u)
        cos_to_center = np.einsum("ij,ij->i", L, cone.axis)
        d = cone.d
        if self.soft_falloff:
            distance = d / np.maximum(cos_to_center, 1e-300)  # to the disk through the centre, facing the point
        else:
            b = d * cos_to_center                              # to the near side of the sphere
            distance = b - np.sqrt(np.maximum(0.0, b * b - (d * d - self.radius * self.radius)))
        strength = (sphere_radiance(self.power, self.radius) * 2.0 * math.pi * (1.0 - cone.cos_max) * self.ies_factor(-L)
                    * self.falloff_factor(distance))
        position = points + L * distance[:, None]
        return LightSample(L, distance, strength, cone_pdf(cone.cos_max), self.emitted(position, -L, distance, paths),
                           position)

    @property
    def hittable(self) -> bool:
        return self.radius > 0.0

    def hit(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray, paths=None) -> LightHit:
        """Rays meet a round light of radius R: with soft falloff the disk through its centre facing the
        ray's origin, else the sphere; radiance P / (4 pi^2 R^2); pdf that of `sample`'s cone."""
        n = len(origins)
        if self.delta:
            return super().hit(origins, directions, t_max)
        cone = self.cone(origins)
        cos_to_center = np.einsum("ij,ij->i", directions, cone.axis)
        inside = cos_to_center >= cone.cos_max
        d = cone.d
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.soft_falloff:
                t = d / cos_to_center
            else:
                b = d * cos_to_center
                t = b - np.sqrt(np.maximum(0.0, b * b - (d * d - self.radius * self.radius)))
        hit = inside & (cos_to_center > 0.0) & (t > 0.0) & (t < t_max)
        radiance = np.where(hit, sphere_radiance(self.power, self.radius), 0.0)
        radiance = self.attenuate(radiance, -directions) * self.falloff_factor(np.where(hit, t, 1.0))
        reach = np.where(hit, t, 1.0)
        color = self.emitted(origins + directions * reach[:, None], -directions, reach, paths)
        return LightHit(hit, np.where(hit, t, np.inf), radiance[:, None] * color, np.where(hit, cone_pdf(cone.cos_max), 0.0))

    def attenuate(self, radiance: np.ndarray, leaving: np.ndarray) -> np.ndarray:
        """The radiance leaving along `leaving` (n, 3): times its IES Texture's factor, if any (a spot's cone masks it
        too)."""
        return radiance * self.ies_factor(leaving)

    def without_attenuation(self, sample: LightSample, points: np.ndarray) -> LightSample:
        """Undo 1/r^2 with r measured to the light's centre: E_normal = P / (4 pi) at any distance."""
        w = points - np.asarray(self.position, np.float64)
        return sample._replace(strength=sample.strength * np.einsum("ij,ij->i", w, w))

    def pack_fields(self, record) -> None:
        record.position[:] = np.asarray(self.position, np.float64).tolist()
        record.power, record.radius = float(self.power), float(self.radius)
        record.soft_falloff = self.soft_falloff
        if not self.delta:
            record.radiance = sphere_radiance(self.power, self.radius)


@dataclass
class PointLight(RoundLight):
    """A point light of `power` watts; with radius > 0 it has extent and casts soft shadows.

    position: (3,) float64 world point; color: (3,) float64 linear RGB.
    """

    position: np.ndarray
    power: float = 1000.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    radius: float = 0.0
    soft_falloff: bool = True
    name: str = "Point"
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

    flags: ClassVar[LightFlags] = LightFlags.POSITION
    blender_type: ClassVar[str] = "POINT"
