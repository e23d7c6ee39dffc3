"""Cycles' Vector Rotate node (kernel/svm/vector_rotate.h), in float32."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32, f32_call
from .vector_math import dot

ROTATION_TYPES = ("AXIS_ANGLE", "X_AXIS", "Y_AXIS", "Z_AXIS", "EULER_XYZ")


def euler_columns(rotation: np.ndarray) -> tuple:
    """Cycles' euler_to_transform of XYZ angles (n, 3) float32: its rows (x, y, z), each (n, 3) float32."""
    c, s = f32_call(np.cos, rotation), f32_call(np.sin, rotation)
    cx, cy, cz, sx, sy, sz = c[:, 0], c[:, 1], c[:, 2], s[:, 0], s[:, 1], s[:, 2]
    x = np.stack([cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz], axis=1)
    y = np.stack([cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz], axis=1)
    z = np.stack([-sy, cy * sx, cy * cx], axis=1)
    return x, y, z


def rotate_around_axis(p: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Cycles' rotate_around_axis: p (n, 3) about the unit axis (n, 3) by angle (n,), float32, Rodrigues' matrix
    applied row by row in Cycles' order."""
    c, s = f32_call(np.cos, angle), f32_call(np.sin, angle)
    u = F32(1.0) - c
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    px, py, pz = p[:, 0], p[:, 1], p[:, 2]
    rx = ((c + u * x * x) * px + (u * x * y - z * s) * py) + (u * x * z + y * s) * pz
    ry = ((u * x * y + z * s) * px + (c + u * y * y) * py) + (u * y * z - x * s) * pz
    rz = ((u * x * z - y * s) * px + (u * y * z + x * s) * py) + (c + u * z * z) * pz
    return np.stack([rx, ry, rz], axis=1)


class VectorRotate(ConverterNode):
    """The Vector turned about the Center: about the Axis (normalised; the vector unchanged where the axis is 0) or
    X, Y, Z by the Angle, or by the XYZ Euler Rotation; Invert turns the other way (the Euler matrix transposed)."""

    kind = "VECTOR_ROTATE"
    blender = "ShaderNodeVectorRotate"
    c_name = "vector_rotate"
    inputs = (("Vector", 3, 0.0), ("Center", 3, 0.0), ("Axis", 3, (0.0, 0.0, 1.0)), ("Angle", 1, 0.0),
              ("Rotation", 3, 0.0))
    outputs = {"Vector": (3, "vector")}
    settings = {"rotation_type": ("rotation_type", ROTATION_TYPES, "AXIS_ANGLE"), "invert": ("invert", None, False)}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The turned vector (n, 3)."""
        vector, center, axis, angle, rotation = (as_f32(x) for x in inputs)
        kind, invert = ROTATION_TYPES[numbers[0]], numbers[1]
        p = vector - center
        if kind == "EULER_XYZ":
            x, y, z = euler_columns(rotation)
            if invert:
                out = np.stack([(x[:, 0] * p[:, 0] + y[:, 0] * p[:, 1]) + z[:, 0] * p[:, 2],
                                (x[:, 1] * p[:, 0] + y[:, 1] * p[:, 1]) + z[:, 1] * p[:, 2],
                                (x[:, 2] * p[:, 0] + y[:, 2] * p[:, 1]) + z[:, 2] * p[:, 2]], axis=1)
            else:
                out = np.stack([(x[:, 2] * p[:, 2] + x[:, 1] * p[:, 1]) + x[:, 0] * p[:, 0],
                                (y[:, 2] * p[:, 2] + y[:, 1] * p[:, 1]) + y[:, 0] * p[:, 0],
                                (z[:, 2] * p[:, 2] + z[:, 1] * p[:, 1]) + z[:, 0] * p[:, 0]], axis=1)
            return (out + center).astype(np.float64)
        if kind == "AXIS_ANGLE":
            norm = np.sqrt(dot(axis, axis))
        else:
            axis = np.zeros_like(axis)
            axis[:, ROTATION_TYPES.index(kind) - 1] = F32(1.0)
            norm = np.ones(len(axis), F32)
        with np.errstate(all="ignore"):
            unit = axis / np.where(norm != 0.0, norm, F32(1.0))[:, None]
        theta = -angle[:, 0] if invert else angle[:, 0]
        out = rotate_around_axis(p, unit, theta) + center
        return np.where((norm != 0.0)[:, None], out, vector).astype(np.float64)
