"""Cycles' Combine Color node in RGB, HSV and HSL (kernel/svm/sepcomb_color.h), in float32."""
from __future__ import annotations

import numpy as np

from .base import ConverterNode, as_f32
from .color import COLOR_MODES, hsl_to_rgb, hsv_to_rgb


class CombineColor(ConverterNode):
    """A colour from three channels in the chosen mode: R, G, B; or H, S, V; or H, S, L."""

    kind = "COMBINE_COLOR_MODE"
    blender = "ShaderNodeCombineColor"
    c_name = "combine_color"
    inputs = (("Red", 1, 0.0), ("Green", 1, 0.0), ("Blue", 1, 0.0))
    outputs = {"Color": (3, "color")}
    settings = {"mode": ("mode", COLOR_MODES, "RGB")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The colour (n, 3)."""
        c = np.concatenate([as_f32(x) for x in inputs], axis=1)
        mode = COLOR_MODES[numbers[0]]
        out = hsv_to_rgb(c) if mode == "HSV" else hsl_to_rgb(c) if mode == "HSL" else c
        return out.astype(np.float64)
