"""Sun lights: a distant light, and with an angle a disk of directions that casts soft shadows."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Optional

import numpy as np

from ..vectors import orthonormal_frame
from .base import Cone, Light, LightFlags, LightHit, LightSample, cone_pdf, delta_pdf, sample_cone
from .ies import IESLamp
from .lamp_graph import LampEmission
from .linking import ALL_SETS


@dataclass
class SunLight(Light):
    """A distant light: `strength` W/m^2 of irradiance on a surface facing it.

    direction: (3,) float64 unit direction in which the light travels (Blender's -Z of the sun object).
    angle: angular diameter of the sun disk in radians (0: hard shadows).
    """

    direction: np.ndarray
    strength: float = 1.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    angle: float = 0.0
    name: str = "Sun"
    camera: bool = True                   # seen by camera rays (Blender: Ray Visibility > Camera)
    cast_shadow: bool = True              # its light is stopped by what stands in the way (Blender: Cast Shadow)
    hidden_from: int = 0                  # HIDDEN_FROM_* bits of the bounces that do not see it (Ray Visibility)
    use_mis: bool = True                  # BSDF rays find it too, weighed by MIS (Blender: Multiple Importance)
    max_bounces: int = 1024               # its light samples stop after this many bounces (Blender: Max Bounces)
    caustics: bool = False                # a Shadow Caustics light (Cycles' MNEE, core/integrators/mnee.py)
    light_membership: int = ALL_SETS        # the receiver light sets it lights (Light Linking, core/lights/linking.py)
    shadow_membership: int = ALL_SETS       # the blocker shadow sets that cast its shadows (Shadow Linking)
    ies: Optional[IESLamp] = None           # an IES Texture scaling the light by direction (core/lights/ies.py)
    # A Sky Texture's disc (core/lights/world_graph.py sky_suns): (9,) float64 the sky's sun elevation, rotation and
    # earth's edge, then the RGB radiance at the disc's bottom and at its top, as core/materials/sky.py disc_xyz takes
    # them (the disc's size is `angle`). Rays that meet the lamp see that limb-darkened, bottom-to-top radiance,
    # Cycles' disc; its light samples carry its mean (strength, color).
    limb: Optional[np.ndarray] = None
    lamp_nodes: Optional[LampEmission] = None  # a tree that varies over the lamp (core/lights/lamp_graph.py)

    flags: ClassVar[LightFlags] = LightFlags.DISTANT
    blender_type: ClassVar[str] = "SUN"
    output_field: ClassVar[str] = "strength"

    @property
    def delta(self) -> bool:
        return self.angle <= 0.0

    def towards(self) -> np.ndarray:
        """Return the unit direction (3,) float64 from any point towards the sun."""
        travel = np.asarray(self.direction, np.float64)
        return -travel / np.linalg.norm(travel)

    def disk_strength(self) -> float:
        """Return the irradiance each sample of a disk of angle > 0 carries: radiance S / (pi sin^2 a), times 2 pi (1 - cos a)."""
        half = 0.5 * self.angle
        radiance = self.strength / (math.pi * math.sin(half) ** 2)
        return radiance * 2.0 * math.pi * (1.0 - math.cos(half))

    def cone(self, points: np.ndarray) -> Optional[Cone]:
        """The same cone everywhere (one frame, broadcast to all points), or None without an angle."""
        if self.delta:
            return None
        axis = self.towards()
        t, b = orthonormal_frame(axis[None, :])
        n = len(points)
        return Cone(np.broadcast_to(axis, (n, 3)), np.broadcast_to(t, (n, 3)), np.broadcast_to(b, (n, 3)),
                    np.full(n, math.cos(0.5 * self.angle)), np.full(n, np.inf))

    def sample(self, points: np.ndarray, u: np.ndarray, cone: Optional[Cone] = None, N=None,
               paths=None) -> LightSample:
        """One direction with irradiance = strength, no distance attenuation; or a direction in the disk."""
        n = len(points)
        if self.delta:
            L = np.broadcast_to(self.towards(), (n, 3)).copy()
            return LightSample(L, np.full(n, np.inf), float(self.strength) * self.ies_factor(-L), delta_pdf(n),
                               self.emitted(np.zeros((n, 3)), -L, np.full(n, np.inf), paths), np.zeros((n, 3)))
        cone = self.cone(points) if cone is None else cone
        L = sample_cone(cone, u)
        return LightSample(L, np.full(n, np.inf), self.disk_strength() * self.ies_factor(-L), cone_pdf(cone.cos_max),
                           self.emitted(np.zeros((n, 3)), -L, np.full(n, np.inf), paths), np.zeros((n, 3)))

    @property
    def hittable(self) -> bool:
        return not self.delta

    def hit(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray, paths=None) -> LightHit:
        """A ray that escapes the scene (t_max inf) inside the sun's disk sees radiance S / (pi sin^2 a)."""
        n = len(origins)
        if self.delta:
            return super().hit(origins, directions, t_max)
        half = 0.5 * self.angle
        inside = (np.einsum("ij,j->i", directions, self.towards()) >= math.cos(half)) & np.isinf(t_max)
        radiance = np.where(inside, self.strength / (math.pi * math.sin(half) ** 2) * self.ies_factor(-directions), 0.0)
        pdf = np.where(inside, cone_pdf(np.full(n, math.cos(half))), 0.0)
        seen = radiance[:, None] * self.emitted(np.zeros((n, 3)), -directions, np.full(n, np.inf), paths)
        if self.limb is not None:                   # (a Sky Texture's disc: Cycles' limb darkening, bottom to top)
            from ..materials.sky import disc_xyz
            limb = np.asarray(self.limb, np.float64)
            seen = np.where(inside[:, None], disc_xyz(directions, limb[0], limb[1], self.angle, 1.0, limb[3:6],
                                                      limb[6:9], limb[2]), 0.0)
        return LightHit(inside, np.where(inside, np.inf, np.inf), seen, pdf)

    def without_attenuation(self, sample: LightSample, points: np.ndarray) -> LightSample:
        """A sun has no falloff to undo."""
        return sample

    def pack_fields(self, record) -> None:
        axis = self.towards()
        record.direction[:] = axis.tolist()
        if self.delta:
            record.strength = float(self.strength)
        else:
            record.strength = self.disk_strength()
            t, b = orthonormal_frame(axis[None, :])
            record.sun_t[:], record.sun_b[:] = t[0].tolist(), b[0].tolist()
            record.sun_cos_max = math.cos(0.5 * self.angle)
            record.radiance = self.strength / (math.pi * math.sin(0.5 * self.angle) ** 2)
        if self.limb is not None and not self.delta:
            limb = np.asarray(self.limb, np.float64)
            record.limb = 1
            record.limb_bottom[:], record.limb_top[:] = limb[3:6].tolist(), limb[6:9].tolist()
            record.limb_sun[:] = [float(limb[0]), float(limb[1]), float(self.angle), float(limb[2]), 0.0]
