"""Spot lights: a point light masked by Blender's spot cone."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Optional

import numpy as np

from .. import vectors
from .base import Cone, LightFlags, LightSample
from .ies import IESLamp
from .lamp_graph import LampEmission
from .linking import ALL_SETS
from .point import RoundLight


@dataclass
class SpotLight(RoundLight):
    """A point light masked by Blender's spot cone.

    position:  (3,) float64 world point; direction: (3,) float64 unit spot axis (where it shines).
    spot_size: full cone angle in radians; spot_blend: 0..1 softness of the cone edge.
    frame:     (3, 3) float64 object-to-world linear map of the light (rotation times scale),
               whose -Z column is the axis, or None for an unscaled frame around `direction`.
               A non-uniform scale makes the cone elliptical, as in Blender.
    """

    position: np.ndarray
    direction: np.ndarray
    power: float = 1000.0
    color: np.ndarray = field(default_factory=lambda: np.ones(3))
    radius: float = 0.0
    soft_falloff: bool = True
    spot_size: float = math.radians(45.0)
    spot_blend: float = 0.15
    frame: Optional[np.ndarray] = None
    name: str = "Spot"
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
    blender_type: ClassVar[str] = "SPOT"

    def cone_constants(self) -> tuple[float, float]:
        """Return (c0, blend width): the cosine of the spot cone's half-angle and its soft edge's width in cosine."""
        cos_half = math.cos(0.5 * self.spot_size)
        return cos_half, (1.0 - cos_half) * self.spot_blend

    def inverse_frame(self) -> np.ndarray:
        """Return the world-to-spot-local matrix of a spot with a (scaled) frame: (3, 3) float64."""
        return vectors.determinant_and_inverse(np.asarray(self.frame, np.float64)[None])[1][0]

    def attenuation(self, directions: np.ndarray) -> np.ndarray:
        """Return Blender's spot cone factor for light leaving along each direction.

        The direction is taken into the light's own frame (scale included, so a non-uniformly
        scaled spot has an elliptical cone) and c is its cosine to the local -Z axis. With
        c0 = cos(spot_size / 2), the factor is smoothstep((c - c0) / ((1 - c0) spot_blend)): 0
        outside the cone, 1 in its inner part, a smooth ramp over the outer `spot_blend` fraction.
        directions: (n, 3) float64 unit, from the light towards the point -> (n,) float64
        """
        if self.frame is None:
            cos_angle = np.einsum("ij,j->i", directions, np.asarray(self.direction, np.float64))
        else:
            local = np.einsum("ij,kj->ik", directions, self.inverse_frame())
            length = np.linalg.norm(local, axis=1)
            cos_angle = -local[:, 2] / np.where(length > 0, length, 1.0)
        cos_half, blend_width = self.cone_constants()
        if blend_width <= 0.0:
            return (cos_angle > cos_half).astype(np.float64)
        x = np.clip((cos_angle - cos_half) / blend_width, 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    def attenuate(self, radiance: np.ndarray, leaving: np.ndarray) -> np.ndarray:
        """The spot's cone masks what leaves along `leaving` (n, 3) unit (and its IES Texture scales it)."""
        return super().attenuate(radiance, leaving) * self.attenuation(leaving)

    def sample(self, points: np.ndarray, u: np.ndarray, cone: Optional[Cone] = None, N=None,
               paths=None) -> LightSample:
        """The point light's sample, times the cone factor for the direction from the (sampled) light point."""
        sample = super().sample(points, u, cone, paths=paths)
        return sample._replace(strength=sample.strength * self.attenuation(-sample.L))

    def pack_fields(self, record) -> None:
        super().pack_fields(record)
        if self.frame is None:
            record.direction[:] = np.asarray(self.direction, np.float64).tolist()
        else:
            record.spot_frame = 1
            record.spot_inverse[:] = self.inverse_frame().ravel().tolist()
        record.spot_cos_half, record.spot_blend_width = self.cone_constants()
