"""Cycles' Vector Curves node (kernel/svm/ramp.h svm_node_curves), in float32 (curves.py)."""
from __future__ import annotations

from .curves import CurveNode


class VectorCurves(CurveNode):
    """X, Y and Z each through its own curve; positions outside the baked range extrapolated from the end
    segments where the mapping extends so, held at the ends' values otherwise; then (1 - factor) value + factor
    curve."""

    kind = "VECTOR_CURVES"
    blender = "ShaderNodeVectorCurve"
    c_name = "vector_curves"
    inputs = (("Fac", 1, 1.0), ("Vector", 3, 0.0))
    outputs = {"Vector": (3, "vector")}
