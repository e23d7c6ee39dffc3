"""Cycles' White Noise Texture (kernel/svm/white_noise.h): a hash of the point's float bits, in 1 to 4 dimensions."""
from __future__ import annotations

import numpy as np

from . import hash as hash_
from .base import TextureNode, as_f32

DIMENSIONS = ("1D", "2D", "3D", "4D")


class WhiteNoiseTexture(TextureNode):
    """Value: hash_float_to_float of W (1D), of the vector's x, y (2D), of the vector (3D), of the vector and W (4D);
    Color: the hash_float*_to_float3 of the same. Any change of the point's float32 bits gives a new value."""

    kind = "TEX_WHITE_NOISE"
    blender = "ShaderNodeTexWhiteNoise"
    c_name = "white_noise"
    inputs = (("Vector", 3, "generated"), ("W", 1, 0.0))
    outputs = {"Value": (1, "float"), "Color": (3, "color")}
    settings = {"dimensions": ("noise_dimensions", DIMENSIONS, "3D")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Value (n, 1) and Color (n, 3) side by side."""
        v, w = as_f32(inputs[0]), as_f32(inputs[1])[:, 0]
        d = numbers[0] + 1
        x, y, z = v[:, 0], v[:, 1], v[:, 2]
        if d == 1:
            value, color = hash_.hash_float(w), hash_.hash_float_to_float3(w)
        elif d == 2:
            value, color = hash_.hash_float2(x, y), hash_.hash_float2_to_float3(x, y)
        elif d == 3:
            value, color = hash_.hash_float3(x, y, z), hash_.hash_float3_to_float3(x, y, z)
        else:
            value, color = hash_.hash_float4(x, y, z, w), hash_.hash_float4_to_float3(x, y, z, w)
        return np.concatenate([value[:, None], color], axis=1).astype(np.float64)
