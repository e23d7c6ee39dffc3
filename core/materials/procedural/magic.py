"""Cycles' Magic Texture (kernel/svm/magic.h): sines and cosines of the point folded into each other Depth times."""
from __future__ import annotations

import numpy as np

from .base import F32, TextureNode, as_f32
from .wave import TWO_PI, cosine, sine

DEPTHS = tuple(range(11))
# Each level of depth after the first: (the component it sets, its function, the signs of x, y, z in the argument).
LEVELS = ((0, "cos", (1, -1, -1)), (2, "sin", (-1, -1, -1)), (0, "-cos", (-1, 1, -1)), (1, "-sin", (-1, 1, 1)),
          (1, "-cos", (-1, 1, 1)), (0, "cos", (1, 1, 1)), (2, "sin", (1, 1, -1)), (0, "-cos", (-1, -1, 1)),
          (1, "-sin", (1, -1, 1)))


def signed_sum(x: np.ndarray, y: np.ndarray, z: np.ndarray, signs: tuple) -> np.ndarray:
    """±x ± y ± z, left to right, in float32 (negating is exact, so this is Cycles' -x + y - z and the like)."""
    sx, sy, sz = signs
    first = x if sx > 0 else -x
    second = first + y if sy > 0 else first - y
    return second + z if sz > 0 else second - z


def apply(name: str, t: np.ndarray) -> np.ndarray:
    """sin, cos, -sin or -cos of t (float32)."""
    value = sine(t) if name.endswith("sin") else cosine(t)
    return -value if name.startswith("-") else value


class MagicTexture(TextureNode):
    """Color: 1/2 - (x, y, z) / (2 Distortion), where x, y, z start as sin, cos and -cos of 5 Scale times signed
    sums of the point (each coordinate taken mod 2pi first) and each level of Depth replaces one of them by a sine or
    cosine of a signed sum of all three, times Distortion (as Cycles' svm_magic, level for level; no division when
    Distortion is 0); Fac: the colour's average."""

    kind = "TEX_MAGIC"
    blender = "ShaderNodeTexMagic"
    c_name = "magic"
    inputs = (("Vector", 3, "generated"), ("Scale", 1, 5.0), ("Distortion", 1, 1.0))
    outputs = {"Color": (3, "color"), "Fac": (1, "float")}
    settings = {"depth": ("turbulence_depth", DEPTHS, 2)}

    @classmethod
    def differs_in(cls, props: dict, version: tuple):
        """From Blender 5.2 Cycles wraps the point x Scale every 2pi (as OSL and EEVEE), where 5.0 wraps the point
        and scales afterwards: another pattern wherever a coordinate or its product with Scale passes 2pi."""
        if tuple(version[:2]) >= (5, 2):
            return ("the Cycles of Blender 5.2 wraps the Magic Texture's point x Scale every 2pi, Cycles 5.0 the point "
                    "before scaling; Primer wraps as Cycles 5.0 does, so its pattern differs from this Blender's "
                    "where a coordinate or its product with Scale passes 2pi")
        return None

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Colour (n, 3) and Fac (n, 1) side by side."""
        vector, scale, distortion = (as_f32(v) for v in inputs)
        depth = numbers[0]
        scale, distortion = scale[:, 0], distortion[:, 0]
        px, py, pz = (np.fmod(vector[:, k], TWO_PI) for k in range(3))
        five = F32(5.0)
        x = sine((px + py + pz) * five * scale)
        y = cosine((-px + py - pz) * five * scale)
        z = -cosine((-px - py + pz) * five * scale)
        if depth > 0:
            x, y, z = x * distortion, y * distortion, z * distortion
            y = -cosine(x - y + z) * distortion
            xyz = [x, y, z]
            for target, name, signs in LEVELS[:depth - 1]:
                xyz[target] = apply(name, signed_sum(*xyz, signs)) * distortion
            x, y, z = xyz
        twice = distortion * F32(2.0)
        shown = distortion != F32(0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            x, y, z = (np.where(shown, c / twice, c) for c in (x, y, z))
        color = np.stack([F32(0.5) - x, F32(0.5) - y, F32(0.5) - z], axis=1)
        fac = (color[:, 0] + color[:, 1] + color[:, 2]) * F32(1.0 / 3.0)
        return np.concatenate([color.astype(np.float64), fac[:, None].astype(np.float64)], axis=1)
