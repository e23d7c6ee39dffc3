"""Cycles' Brick Texture (kernel/svm/brick.h): rows of bricks, offset and squashed every so many rows, each brick
tinted between Color1 and Color2 by an integer hash of its row and column, in mortar lines."""
from __future__ import annotations

import numpy as np

from .base import F32, TextureNode, as_f32

FREQUENCIES = tuple(range(100))          # offset_frequency and squash_frequency (1 to 99 in Blender) as themselves
U32 = np.uint32


def brick_noise(n: np.ndarray) -> np.ndarray:
    """Cycles' brick_noise: a fast integer hash of n (uint32) to [0, 1) in float32."""
    n = (n + U32(1013)) & U32(0x7FFFFFFF)
    n = (n >> U32(13)) ^ n
    nn = (n * (n * n * U32(60493) + U32(19990303)) + U32(1376312589)) & U32(0x7FFFFFFF)
    return F32(0.5) * (nn.astype(F32) / F32(1073741824.0))


def smoothstep(f: np.ndarray) -> np.ndarray:
    """Cycles' smoothstepf: 3f^2 - 2f^3 on [0, 1], 0 below, 1 above (float32)."""
    ff = f * f
    return np.where(f <= F32(0.0), F32(0.0), np.where(f >= F32(1.0), F32(1.0), F32(3.0) * ff - F32(2.0) * ff * f))


def c_remainder(a: np.ndarray, b: int) -> np.ndarray:
    """C's a % b on int32 (the sign of a)."""
    return np.fmod(a, np.int32(b))


class BrickTexture(TextureNode):
    """Rows of Row Height, bricks of Brick Width (x Squash every Squash Frequency-th row, row 0 included), every
    Offset Frequency-th row shifted by Offset x the width, in the point x Scale. Fac: the mortar, 1 within Mortar
    Size of a brick's edge, smoothed over Mortar Smooth of it. Color: Color1 mixed towards Color2 by the brick's
    tint (brick_noise of (row << 16) + (column & 0xFFFF), + Bias, clamped to [0, 1]), then towards Mortar by Fac."""

    kind = "TEX_BRICK"
    blender = "ShaderNodeTexBrick"
    c_name = "brick"
    inputs = (("Vector", 3, "generated"), ("Color1", 3, (0.8, 0.8, 0.8)), ("Color2", 3, (0.2, 0.2, 0.2)),
              ("Mortar", 3, (0.0, 0.0, 0.0)), ("Scale", 1, 5.0), ("Mortar Size", 1, 0.02), ("Mortar Smooth", 1, 0.1),
              ("Bias", 1, 0.0), ("Brick Width", 1, 0.5), ("Row Height", 1, 0.25), ("Offset", 1, 0.5),
              ("Squash", 1, 1.0))
    properties = {"Offset": "offset", "Squash": "squash"}
    outputs = {"Color": (3, "color"), "Fac": (1, "float")}
    settings = {"offset_frequency": ("offset_frequency", FREQUENCIES, 2),
                "squash_frequency": ("squash_frequency", FREQUENCIES, 2)}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Colour (n, 3) and Fac (n, 1) side by side."""
        vector, color1, color2, mortar_color, *rest = (as_f32(x) for x in inputs)
        scale, mortar_size, mortar_smooth, bias, width, row_height, offset_amount, squash = (x[:, 0] for x in rest)
        offset_frequency, squash_frequency = numbers[0], numbers[1]
        p = vector * scale[:, None]
        px, py = p[:, 0], p[:, 1]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            row = np.floor(py / row_height).astype(np.int32)
            offset = np.zeros_like(px)
            if offset_frequency and squash_frequency:
                width = np.where(c_remainder(row, squash_frequency) != 0, width, width * squash)
                offset = np.where(c_remainder(row, offset_frequency) != 0, F32(0.0), width * offset_amount)
            column = np.floor((px + offset) / width).astype(np.int32)
            x = (px + offset) - width * column.astype(F32)
            y = py - row_height * row.astype(F32)
            cell = ((row.astype(np.int64) << 16) + (column.astype(np.int64) & 0xFFFF)) & 0xFFFFFFFF
            tint = np.clip(brick_noise(cell.astype(U32)) + bias, F32(0.0), F32(1.0))
            nearest = np.minimum(np.minimum(x, y), np.minimum(width - x, row_height - y))
            smoothed = smoothstep((F32(1.0) - nearest / mortar_size) / mortar_smooth)
        fac = np.where(nearest >= mortar_size, F32(0.0), np.where(mortar_smooth == F32(0.0), F32(1.0), smoothed))
        mixed = (F32(1.0) - tint)[:, None] * color1 + tint[:, None] * color2
        brick = np.where((fac != F32(1.0))[:, None], mixed, color1)
        color = brick * (F32(1.0) - fac)[:, None] + mortar_color * fac[:, None]
        return np.concatenate([color.astype(np.float64), fac[:, None].astype(np.float64)], axis=1)
