"""A lamp's IES Texture: the profile (core/materials/ies.py) seen from the lamp's own frame.

For a lamp, the node's Vector defaults to Cycles' Geometry > Incoming taken into the lamp object's frame by the
normal transform (transposed object matrix): the direction from the lamp towards the lit point, in the lamp's own
axes (`IESLamp`), so that a lamp pointing down (-Z) sends the profile's 0 degree value straight down. Profiles are
read and evaluated by core/materials/ies.py (and ies.c), which the material node compiler shares; the C twin of
`IESLamp.factor` is core/lights/ies.c.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..materials.ies import UNREAD_VALUE, IESProfile, ies_fac, table


@dataclass(frozen=True)
class IESLamp:
    """A lamp's IES Texture: its profile (None: unread, Strength x 100), the node's Strength, and the lamp's frame.

    to_local: (3, 3) float64 the transposed object matrix (Cycles' object_inverse_normal_transform): world
              directions leaving the lamp -> the node's Vector
    """

    profile: Optional[IESProfile]
    strength: float
    to_local: np.ndarray

    def factor(self, leaving: np.ndarray) -> np.ndarray:
        """The node's Fac for light leaving the lamp along world directions (n, 3) float64: (n,) float64."""
        return ies_fac(self.profile, self.strength, np.einsum("ij,kj->ki", self.to_local, leaving))

    def pack(self, record) -> None:
        """Fill a LightRecord's IES fields (its table kept alive by the record)."""
        record.has_ies = 1
        record.ies_frame[:] = np.asarray(self.to_local, np.float64).ravel().tolist()
        if self.profile is None:                        # (no table: C gives Strength x 100)
            record.ies_strength = float(self.strength) * UNREAD_VALUE
            return
        record.ies = table(self.profile)
        record.ies_h, record.ies_v = len(self.profile.h_angles), len(self.profile.v_angles)
        record.ies_strength = float(self.strength)
