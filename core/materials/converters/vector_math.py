"""Cycles' Vector Math node (kernel/svm/vector_math.h, svm_vector_math in math_util.h), in float32."""
from __future__ import annotations

import numpy as np

from .base import F32, ConverterNode, as_f32, f32_call

# Blender's operation names in the op's numbering (the C switch follows it).
VECTOR_MATH_OPS = ("ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT", "REFLECT",
                   "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE", "NORMALIZE", "ABSOLUTE",
                   "POWER", "SIGN", "MINIMUM", "MAXIMUM", "FLOOR", "CEIL", "FRACTION", "MODULO", "WRAP", "SNAP", "SINE",
                   "COSINE", "TANGENT", "ROUND")          # (Round: Blender 5.1 and later)
# The operations whose result is the Value output (the Vector output is then 0), and Cycles leaves Value 0 otherwise.
VALUE_OPS = ("DOT_PRODUCT", "DISTANCE", "LENGTH")
ZERO = F32(0.0)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) float32 dot products of (n, 3) float32 rows, summed x, y, then z."""
    return (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]) + a[:, 2] * b[:, 2]


def length(a: np.ndarray) -> np.ndarray:
    """(n,) float32 |a|."""
    return np.sqrt(dot(a, a))


def safe_normalize(a: np.ndarray) -> np.ndarray:
    """a x (1 / |a|), a itself where |a| is 0 (Cycles' safe_normalize), (n, 3) float32."""
    t = length(a)
    with np.errstate(divide="ignore"):
        scale = np.where(t != ZERO, F32(1.0) / np.where(t != ZERO, t, F32(1.0)), F32(1.0)).astype(F32)
    return a * scale[:, None]


def safe_divide(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a / b per component, 0 where b is 0 (float32)."""
    return np.where(b != ZERO, a / np.where(b != ZERO, b, F32(1.0)), ZERO).astype(F32)


def safe_pow(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cycles' safe_powf per component: 0 for a negative base and a non-integer exponent, 1 for b = 0, 0 for a = 0."""
    integral = b == np.trunc(b)
    bad = (a < ZERO) & ~integral
    with np.errstate(all="ignore"):
        p = f32_call(np.power, np.where(bad, F32(1.0), a), b)
    return np.where(bad, ZERO, np.where(b == ZERO, F32(1.0), np.where(a == ZERO, ZERO, p))).astype(F32)


def vector_math(name: str, a: np.ndarray, b: np.ndarray, c: np.ndarray, scale: np.ndarray):
    """(vector (n, 3), value (n,)) float32 of operation `name` on float32 a, b, c (n, 3) and scale (n,)."""
    n = len(a)
    value = np.zeros(n, F32)
    with np.errstate(all="ignore"):
        if name == "ADD": v = a + b
        elif name == "SUBTRACT": v = a - b
        elif name == "MULTIPLY": v = a * b
        elif name == "DIVIDE": v = safe_divide(a, b)
        elif name == "MULTIPLY_ADD": v = a * b + c
        elif name == "CROSS_PRODUCT":
            v = np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                          a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)
        elif name == "PROJECT":
            l2 = dot(b, b)
            f = np.where(l2 != ZERO, dot(a, b) / np.where(l2 != ZERO, l2, F32(1.0)), ZERO).astype(F32)
            v = f[:, None] * b
        elif name == "REFLECT":
            nb = safe_normalize(b)
            v = a - (F32(2.0) * nb) * dot(a, nb)[:, None]
        elif name == "REFRACT":
            nb, eta = safe_normalize(b), scale
            d = dot(nb, a)
            k = F32(1.0) - eta * eta * (F32(1.0) - d * d)
            root = np.sqrt(np.maximum(k, ZERO))
            v = np.where((k < ZERO)[:, None], ZERO, eta[:, None] * a - (eta * d + root)[:, None] * nb)
        elif name == "FACEFORWARD": v = np.where((dot(c, b) < ZERO)[:, None], a, -a)
        elif name in VALUE_OPS:
            v = np.zeros_like(a)
            value = dot(a, b) if name == "DOT_PRODUCT" else length(a - b) if name == "DISTANCE" else length(a)
        elif name == "SCALE": v = a * scale[:, None]
        elif name == "NORMALIZE": v = safe_normalize(a)
        elif name == "ABSOLUTE": v = np.abs(a)
        elif name == "POWER": v = safe_pow(a, b)
        elif name == "SIGN": v = np.where(a == ZERO, ZERO, np.where(a < ZERO, F32(-1.0), F32(1.0)))
        elif name == "MINIMUM": v = np.minimum(a, b)
        elif name == "MAXIMUM": v = np.maximum(a, b)
        elif name == "FLOOR": v = np.floor(a)
        elif name == "CEIL": v = np.ceil(a)
        elif name == "FRACTION": v = a - np.floor(a)
        elif name == "MODULO": v = np.where(b != ZERO, np.fmod(a, np.where(b != ZERO, b, F32(1.0))), ZERO)
        elif name == "WRAP":
            x, span = a - c, b - c
            s = np.where(span != ZERO, span, F32(1.0))
            v = np.where(span != ZERO, x - np.floor(x / s) * s, ZERO) + c
        elif name == "SNAP": v = np.floor(safe_divide(a, b)) * b
        elif name == "SINE": v = f32_call(np.sin, a)
        elif name == "COSINE": v = f32_call(np.cos, a)
        elif name == "TANGENT": v = f32_call(np.tan, a)
        else: v = np.floor(a + F32(0.5))
    return v.astype(F32), value.astype(F32)


class VectorMath(ConverterNode):
    """Every operation of Blender's Vector Math on float32 vectors A, B, C and the Scale (Refract's IOR); Dot
    Product, Distance and Length write the Value output, the others the Vector output (the other output 0)."""

    kind = "VECTOR_MATH"
    blender = "ShaderNodeVectorMath"
    c_name = "vector_math"
    inputs = (("Vector", 3, 0.0), ("Vector_001", 3, 0.0), ("Vector_002", 3, 0.0), ("Scale", 1, 1.0))
    outputs = {"Vector": (3, "vector"), "Value": (1, "float")}
    settings = {"operation": ("operation", VECTOR_MATH_OPS, "ADD")}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Vector (n, 3) and Value (n, 1) side by side."""
        a, b, c, scale = (as_f32(x) for x in inputs)
        v, value = vector_math(VECTOR_MATH_OPS[numbers[0]], a, b, c, scale[:, 0])
        return np.concatenate([v, value[:, None]], axis=1).astype(np.float64)
