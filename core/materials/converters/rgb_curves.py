"""Cycles' RGB Curves node (kernel/svm/ramp.h svm_node_curves), in float32 (curves.py)."""
from __future__ import annotations

from .curves import CurveNode


class RGBCurves(CurveNode):
    """Each channel through its own curve, of the combined (C) curve's value, as Blender bakes them; positions
    outside the baked range extrapolated from the end segments where the mapping extends so, held at the ends'
    values otherwise; then (1 - factor) value + factor curve."""

    kind = "RGB_CURVES"
    blender = "ShaderNodeRGBCurve"
    c_name = "rgb_curves"
    inputs = (("Fac", 1, 1.0), ("Color", 3, 1.0))
    outputs = {"Color": (3, "color")}
