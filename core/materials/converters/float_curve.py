"""Cycles' Float Curve node (kernel/svm/ramp.h svm_node_curve), in float32 (curves.py)."""
from __future__ import annotations

from .curves import CurveNode


class FloatCurve(CurveNode):
    """The value through the curve; positions outside the baked range extrapolated from the end segments where
    the mapping extends so, held at the ends' values otherwise; then (1 - factor) value + factor curve."""

    kind = "FLOAT_CURVE"
    blender = "ShaderNodeFloatCurve"
    c_name = "float_curve"
    inputs = (("Factor", 1, 1.0), ("Value", 1, 1.0))
    outputs = {"Value": (1, "float")}
