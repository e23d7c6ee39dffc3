"""Cycles' Gradient Texture (kernel/svm/gradient.h): a ramp from 0 to 1 of the point, of seven shapes."""
from __future__ import annotations

import numpy as np

from .base import F32, TextureNode, as_f32

# Blender's gradient_type names in Cycles' NodeGradientType order.
GRADIENT_TYPES = ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "RADIAL", "QUADRATIC_SPHERE", "SPHERICAL")
TWO_PI = F32(2.0 * np.pi)


class GradientTexture(TextureNode):
    """Linear x, quadratic max(x, 0)^2, easing 3t - 2t r (r = x clamped, t = r^2), diagonal (x + y) / 2, radial
    atan2(y, x) / 2pi + 1/2, spherical max(0.999999 - |p|, 0) and its square; clamped to [0, 1], in float32."""

    kind = "TEX_GRADIENT"
    blender = "ShaderNodeTexGradient"
    c_name = "gradient"
    inputs = (("Vector", 3, "generated"),)
    outputs = {"Color": (3, "color"), "Fac": (1, "float")}
    settings = {"gradient_type": ("gradient_type", GRADIENT_TYPES, "LINEAR")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Colour (f, f, f) and Fac f side by side."""
        p = as_f32(inputs[0])
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        name = GRADIENT_TYPES[numbers[0]]
        if name == "LINEAR":
            f = x
        elif name == "QUADRATIC":
            r = np.maximum(x, F32(0.0))
            f = r * r
        elif name == "EASING":
            r = np.minimum(np.maximum(x, F32(0.0)), F32(1.0))
            t = r * r
            f = F32(3.0) * t - F32(2.0) * t * r
        elif name == "DIAGONAL":
            f = (x + y) * F32(0.5)
        elif name == "RADIAL":
            # atan2 in double, rounded to float: the same in numpy and C (Cycles' atan2f may differ by an ulp).
            f = np.arctan2(y.astype(np.float64), x.astype(np.float64)).astype(F32) / TWO_PI + F32(0.5)
        else:
            r = np.maximum(F32(0.999999) - np.sqrt(x * x + y * y + z * z), F32(0.0))
            f = r * r if name == "QUADRATIC_SPHERE" else r
        f = np.minimum(np.maximum(f, F32(0.0)), F32(1.0)).astype(np.float64)
        return np.stack([f, f, f, f], axis=1)
