"""Cycles' IES Texture node (kernel/svm/ies.h svm_node_ies) in a node graph: Strength x an IES profile in the
direction of its Vector, profiles read and evaluated by core/materials/ies.py.

The add-on reads the node's file (Internal: its Text datablock; External: its path) as Cycles does and puts the
profile's `ies.table` in props["table"] with its counts in props["h_num"], props["v_num"] (-1, -1 and an empty table
for a file Cycles cannot read: Strength x 100 everywhere). An unlinked Vector is Cycles' default for the node
(LINK_TEXTURE_INCOMING): Geometry > Incoming taken from world to object space as a normal (graph.INCOMING_OBJECT).
"""
from __future__ import annotations

import numpy as np

from .. import ies as ies_
from .base import ConverterNode


class IESTexture(ConverterNode):
    """Fac = Strength x the profile at v = acos(-z), h = atan2(x, y) + pi of the normalised Vector (0 outside the
    profile's table), in float64 as the lamps evaluate it."""

    kind = "IES_TEXTURE"
    blender = "ShaderNodeTexIES"
    c_name = "ies_texture"
    inputs = (("Strength", 1, 1.0), ("Vector", 3, "incoming_object"))
    outputs = {"Fac": (1, "float")}
    table = True

    @classmethod
    def numbers(cls, props: dict, output: str) -> list:
        """The profile's h and v angle counts (the compiler puts the table's start first); -1, -1 without one."""
        return [int(props.get("h_num", -1)), int(props.get("v_num", -1))]

    @classmethod
    def evaluate(cls, inputs: list, numbers: list, tables: np.ndarray = None) -> np.ndarray:
        """Fac (n, 1): inputs Strength (n, 1), Vector (n, 3); numbers the table's start in `tables`, h_num, v_num."""
        start, h_num, v_num = (int(x) for x in numbers[:3])
        profile = ies_.from_table(tables[start:] if tables is not None else np.zeros(0), h_num, v_num)
        return ies_.ies_fac(profile, inputs[0][:, 0], inputs[1])[:, None]


def ies_props(profile) -> dict:
    """The props of an IES_TEXTURE graph node for a profile (ies.IESProfile, or None for a file Cycles cannot read)."""
    if profile is None:
        return {"table": np.zeros(0), "h_num": -1, "v_num": -1}
    return {"table": ies_.table(profile), "h_num": len(profile.h_angles), "v_num": len(profile.v_angles)}
