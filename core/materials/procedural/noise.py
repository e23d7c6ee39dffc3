"""Cycles' Noise Texture (kernel/svm/noisetex.h): fractal Perlin noise (perlin.py) in 1 to 4 dimensions."""
from __future__ import annotations

import numpy as np

from . import hash as hash_
from . import perlin
from .base import F32, TextureNode, as_f32

DIMENSIONS = ("1D", "2D", "3D", "4D")


def random_offset(seed: float, d: int) -> np.ndarray:
    """Cycles' random_float_offset .. random_float4_offset: a (d,) float32 seed offset in [100, 200] per axis (1D:
    hash_float_to_float(seed); else hash_float2_to_float(seed, k) for axis k)."""
    if d == 1:
        return np.array([F32(100.0) + hash_.hash_float(F32(seed)) * F32(100.0)], F32)
    return np.array([F32(100.0) + hash_.hash_float2(F32(seed), F32(k)) * F32(100.0) for k in range(d)], F32)


class NoiseTexture(TextureNode):
    """Fac: the fractal (`noise_type`) of the scaled point, distorted first by Distortion x snoise at seeded
    offsets; Color: Fac and the same fractal at two more seeded offsets (computed only when Color is read)."""

    kind = "TEX_NOISE"
    blender = "ShaderNodeTexNoise"
    c_name = "noise"
    inputs = (("Vector", 3, "generated"), ("W", 1, 0.0), ("Scale", 1, 5.0), ("Detail", 1, 2.0), ("Roughness", 1, 0.5),
              ("Lacunarity", 1, 2.0), ("Offset", 1, 0.0), ("Gain", 1, 1.0), ("Distortion", 1, 0.0))
    outputs = {"Fac": (1, "float"), "Color": (3, "color")}
    settings = {"dimensions": ("noise_dimensions", DIMENSIONS, "3D"),
                "noise_type": ("noise_type", perlin.NOISE_TYPES, "FBM"),
                "normalize": ("normalize", None, True)}

    @classmethod
    def numbers(cls, props: dict, output: str) -> list:
        """Dimensions, type, normalize, and 1 when the Color output is read."""
        return super().numbers(props, output) + [1 if output == "Color" else 0]

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Fac (n, 1) and Color (n, 3) side by side (Color 0 unless asked for)."""
        vector, w, scale, detail, roughness, lacunarity, offset, gain, distortion = (as_f32(x) for x in inputs)
        d, kind, normalize, color_needed = numbers[0] + 1, numbers[1], bool(numbers[2]), bool(numbers[3])
        scale = scale[:, 0]
        detail = np.clip(detail[:, 0], F32(0.0), F32(15.0))
        roughness = np.maximum(roughness[:, 0], F32(0.0))
        lacunarity, offset, gain, distortion = lacunarity[:, 0], offset[:, 0], gain[:, 0], distortion[:, 0]
        v = vector * scale[:, None]
        w = w[:, 0] * scale
        p = {1: w[:, None], 2: v[:, :2], 3: v, 4: np.concatenate([v, w[:, None]], axis=1)}[d].copy()
        distorted = distortion != F32(0.0)
        if distorted.any():
            shift = np.stack([perlin.snoise(p + random_offset(float(k), d)) * distortion for k in range(d)], axis=1)
            p = np.where(distorted[:, None], p + shift, p)
        args = (detail, roughness, lacunarity, offset, gain, normalize)
        value = perlin.fractal(kind, p, *args)
        out = np.zeros((len(p), 4))
        out[:, 0] = value
        if color_needed:
            out[:, 1] = value
            out[:, 2] = perlin.fractal(kind, p + random_offset(float(d), d), *args)
            out[:, 3] = perlin.fractal(kind, p + random_offset(float(d + 1), d), *args)
        return out
