"""Cycles' curve lookups (kernel/svm/ramp.h svm_node_curves, svm_node_curve): a curve mapping baked by Blender into
CURVE_TABLE_SIZE points over [min_x, max_x], interpolated linearly, extrapolated from the end segments or clamped,
then blended with the input by the Factor. curves.h is the C twin."""
from __future__ import annotations

import numpy as np

from ...native import schema
from .base import F32, ConverterNode, as_f32

# Cycles' RAMP_TABLE_SIZE (256) + 1: Blender's sync bakes a curve at x = min_x + i / 256 (max_x - min_x).
CURVE_TABLE_SIZE = schema.constant("CURVE_TABLE_SIZE", 257, "the points of a baked curve mapping")


def curve_table(min_x: float, max_x: float, extrapolate: bool, values) -> np.ndarray:
    """The flat float64 table a curve op reads: min_x, max_x, extrapolate (0 or 1), then CURVE_TABLE_SIZE rows of
    `values` ((CURVE_TABLE_SIZE, k) baked curve values), all rounded to float32 as Cycles stores them."""
    rows = np.asarray(values, np.float64).reshape(CURVE_TABLE_SIZE, -1)
    head = [float(F32(min_x)), float(F32(max_x)), 1.0 if extrapolate else 0.0]
    return np.concatenate([head, rows.astype(F32).astype(np.float64).reshape(-1)])


def lookup(column: np.ndarray, f: np.ndarray, extrapolate: bool) -> np.ndarray:
    """Cycles' float_ramp_lookup (interpolating) of one column (CURVE_TABLE_SIZE,) float32 at positions f (n,)
    float32."""
    last = CURVE_TABLE_SIZE - 1
    with np.errstate(invalid="ignore"):
        x = np.minimum(np.maximum(f, F32(0.0)), F32(1.0)) * F32(last)
        i = np.clip(np.nan_to_num(x).astype(np.int64), 0, last)
    t = x - i.astype(F32)
    a = column[i]
    inner = np.where(t > F32(0.0), (F32(1.0) - t) * a + t * column[np.minimum(i + 1, last)], a)
    if not extrapolate:
        return inner
    low = column[0] + (column[0] - column[1]) * -f * F32(last)
    high = column[last] + (column[last] - column[last - 1]) * (f - F32(1.0)) * F32(last)
    return np.where(f < F32(0.0), low, np.where(f > F32(1.0), high, inner)).astype(F32)


def curves(table: np.ndarray, fac: np.ndarray, values: np.ndarray) -> np.ndarray:
    """(n, k) float32: values (n, k) float32 mapped through the table's k curves (column j for channel j) and blended
    with themselves by fac (n,) float32."""
    min_x, max_x, extrapolate = F32(table[0]), F32(table[1]), bool(table[2])
    k = values.shape[1]
    rows = table[3:3 + CURVE_TABLE_SIZE * k].astype(F32).reshape(CURVE_TABLE_SIZE, k)
    with np.errstate(all="ignore"):
        relpos = (values - min_x) / (max_x - min_x)
    mapped = np.stack([lookup(rows[:, j], relpos[:, j], extrapolate) for j in range(k)], axis=1)
    return (F32(1.0) - fac)[:, None] * values + fac[:, None] * mapped


class CurveNode(ConverterNode):
    """A node that maps its value or colour through a baked curve mapping (props["table"]: `curve_table`)."""

    table = True

    @classmethod
    def numbers(cls, props: dict, output: str) -> list:
        """None: the compiler puts the table's start first."""
        return []

    @classmethod
    def evaluate(cls, inputs: list, numbers: list, tables: np.ndarray = None) -> np.ndarray:
        """The mapped value or colour (n, k): inputs Factor (n, 1) and the value (n, k); numbers[0] the table's start
        in `tables`."""
        fac, values = as_f32(inputs[0])[:, 0], as_f32(inputs[1])
        return curves(tables[numbers[0]:], fac, values).astype(np.float64)
