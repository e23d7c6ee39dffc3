"""Cycles' Map Range node on vectors (kernel/svm/map_range.h svm_node_vector_map_range), in float32; the float Map
Range stays graph.py's MAP_RANGE op."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32
from .vector_math import safe_divide

MAP_RANGE_TYPES = ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP")
ZERO, ONE = F32(0.0), F32(1.0)


class MapRangeVector(ConverterNode):
    """Per component: the factor (v - from_min) / (from_max - from_min) (0 where the range is empty), stepped,
    smoothstepped or smootherstepped (both on the factor clamped to 0..1), then to_min + factor (to_max - to_min),
    clamped to the target range (either way round) for Linear and Stepped when Clamp is on."""

    kind = "MAP_RANGE_VECTOR"
    blender = "ShaderNodeMapRange"        # (data_type FLOAT_VECTOR; addon/materials.py picks it)
    c_name = "map_range_vector"
    inputs = (("Vector", 3, 0.0), ("From_Min_FLOAT3", 3, 0.0), ("From_Max_FLOAT3", 3, 1.0), ("To_Min_FLOAT3", 3, 0.0),
              ("To_Max_FLOAT3", 3, 1.0), ("Steps_FLOAT3", 3, 4.0))
    outputs = {"Vector": (3, "vector")}
    settings = {"interpolation_type": ("interpolation_type", MAP_RANGE_TYPES, "LINEAR"), "clamp": ("clamp", None, True)}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The mapped vector (n, 3)."""
        value, from_min, from_max, to_min, to_max, steps = (as_f32(x) for x in inputs)
        kind, clamp = MAP_RANGE_TYPES[numbers[0]], numbers[1]
        factor = safe_divide(value - from_min, from_max - from_min)
        if kind == "STEPPED":
            positive = steps > ZERO
            factor = np.where(positive, np.floor(factor * (steps + ONE)) / np.where(positive, steps, ONE), ZERO)
        elif kind == "SMOOTHSTEP":
            f = np.minimum(np.maximum(factor, ZERO), ONE)
            factor = (F32(3.0) - F32(2.0) * f) * (f * f)
        elif kind == "SMOOTHERSTEP":
            f = np.minimum(np.maximum(factor, ZERO), ONE)
            factor = f * f * f * (f * (f * F32(6.0) - F32(15.0)) + F32(10.0))
        result = to_min + factor.astype(F32) * (to_max - to_min)
        if clamp and kind in ("LINEAR", "STEPPED"):
            lo, hi = np.minimum(to_min, to_max), np.maximum(to_min, to_max)
            result = np.minimum(np.maximum(result, lo), hi)
        return result.astype(np.float64)
