"""Cycles' Gamma node (kernel/svm/gamma.h, svm_math_gamma_color), in float32."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32, f32_call


class Gamma(ConverterNode):
    """Each positive channel raised to the Gamma (powf); channels <= 0 kept; white for a Gamma of 0."""

    kind = "GAMMA"
    blender = "ShaderNodeGamma"
    c_name = "gamma"
    inputs = (("Color", 3, 1.0), ("Gamma", 1, 1.0))
    outputs = {"Color": (3, "color")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The colour (n, 3)."""
        color, gamma = as_f32(inputs[0]), as_f32(inputs[1])
        with np.errstate(all="ignore"):
            raised = f32_call(np.power, np.maximum(color, F32(0.0)), np.broadcast_to(gamma, color.shape))
        out = np.where(color > 0.0, raised, color)
        return np.where(gamma == 0.0, F32(1.0), out).astype(np.float64)
