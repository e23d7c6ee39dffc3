"""Cycles' RGB to BW node (svm_node_convert, colour to float: linear_rgb_to_gray), in float32."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32
from .colorspace import RGB_TO_Y


class RGBToBW(ConverterNode):
    """The colour's luminance: its dot product with Cycles' rgb_to_y (colorspace.RGB_TO_Y) in float32."""

    kind = "RGB_TO_BW"
    blender = "ShaderNodeRGBToBW"
    c_name = "rgb_to_bw"
    inputs = (("Color", 3, 0.5),)
    outputs = {"Val": (1, "float")}
    c_tables = {"RGB_TO_Y": RGB_TO_Y}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The luminance (n, 1)."""
        c, y = as_f32(inputs[0]), RGB_TO_Y.astype(F32)
        return ((c[:, 0] * y[0] + c[:, 1] * y[1]) + c[:, 2] * y[2]).astype(np.float64)[:, None]
