"""Cycles' Brightness/Contrast node (kernel/svm/brightness.h, svm_brightness_contrast), in float32."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32


class BrightContrast(ConverterNode):
    """max((1 + contrast) c + (brightness - contrast / 2), 0) per channel."""

    kind = "BRIGHT_CONTRAST"
    blender = "ShaderNodeBrightContrast"
    c_name = "bright_contrast"
    inputs = (("Color", 3, 1.0), ("Bright", 1, 0.0), ("Contrast", 1, 0.0))
    outputs = {"Color": (3, "color")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The colour (n, 3)."""
        color, bright, contrast = (as_f32(x) for x in inputs)
        a = F32(1.0) + contrast
        b = bright - contrast * F32(0.5)
        return np.maximum(a * color + b, F32(0.0)).astype(np.float64)
