"""Cycles' Separate Color node in RGB, HSV and HSL (kernel/svm/sepcomb_color.h), in float32."""
from __future__ import annotations

import numpy as np

from .base import ConverterNode, as_f32
from .color import COLOR_MODES, rgb_to_hsl, rgb_to_hsv


class SeparateColor(ConverterNode):
    """The colour's three channels in the chosen mode: R, G, B; or H, S, V; or H, S, L (hue in 0..1)."""

    kind = "SEPARATE_COLOR_MODE"
    blender = "ShaderNodeSeparateColor"
    c_name = "separate_color"
    inputs = (("Color", 3, 0.8),)
    outputs = {"Red": (1, "float"), "Green": (1, "float"), "Blue": (1, "float")}
    settings = {"mode": ("mode", COLOR_MODES, "RGB")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The three channels (n, 3)."""
        c = as_f32(inputs[0])
        mode = COLOR_MODES[numbers[0]]
        out = rgb_to_hsv(c) if mode == "HSV" else rgb_to_hsl(c) if mode == "HSL" else c
        return out.astype(np.float64)
