"""Cycles' Checker Texture (kernel/svm/checker.h): cubes of Color1 and Color2 alternating along x, y and z."""
from __future__ import annotations

import numpy as np

from .base import F32, TextureNode, as_f32


class CheckerTexture(TextureNode):
    """Fac 1 (Color1) where floor(x) + floor(y) + floor(z) of the scaled point is odd, 0 (Color2) where even; the
    point nudged by (p + 1e-6) x 0.999999 first, as Cycles does, so that unit coordinates fall one way."""

    kind = "TEX_CHECKER"
    blender = "ShaderNodeTexChecker"
    c_name = "checker"
    inputs = (("Vector", 3, "generated"), ("Color1", 3, (0.8, 0.8, 0.8)), ("Color2", 3, (0.2, 0.2, 0.2)),
              ("Scale", 1, 5.0))
    outputs = {"Color": (3, "color"), "Fac": (1, "float")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Colour (n, 3) and Fac (n, 1) side by side."""
        vector, color1, color2, scale = inputs
        p = as_f32(vector) * as_f32(scale)
        p = (p + F32(0.000001)) * F32(0.999999)
        cell = np.abs(np.floor(p).astype(np.int32)) % 2
        fac = ((cell[:, 0] == cell[:, 1]).astype(np.int32) == cell[:, 2]).astype(np.float64)
        color = np.where(fac[:, None] == 1.0, color1, color2)
        return np.concatenate([color, fac[:, None]], axis=1)
