"""What a converter or colour node is: a described graph node (procedural.base.TextureNode) that may carry a table.

A `ConverterNode` is described exactly as a procedural texture is (kind, blender, c_name, inputs, outputs, settings,
numbers, evaluate; the C file `<c_name>.c` with `<c_name>_texture`, the op at one hit). A node that bakes a table
(the curves: Blender evaluates the curve at 257 points and Cycles interpolates them) sets `table = True`: the add-on
puts the baked floats in its props["table"], the compiler appends them to the program's table floats and gives the op
their start as its first number, and `evaluate` and the C function receive the program's table floats too.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..procedural.base import F32, TextureNode, as_f32

__all__ = ["ConverterNode", "F32", "as_f32", "f32_call"]


class ConverterNode(TextureNode):
    """A converter or colour node (a subclass per node; everything is on the class)."""

    # Whether the op reads a baked table (props["table"], flat float64) from the program's table floats.
    table: ClassVar[bool] = False
    # C constant tables the C file reads: name -> array, written as `static const float NAME[]` (float32) by
    # tools/make_boundary.py from the class, so that C and Python hold one copy.
    c_tables: ClassVar[dict] = {}


def f32_call(function, *arrays) -> np.ndarray:
    """A libm function of float32 arrays computed in double and rounded to float32 (as the C twin does: both
    kernels then agree bit for bit; Cycles' sinf, powf ... are within an ulp of it)."""
    return function(*(np.asarray(a, F32).astype(np.float64) for a in arrays)).astype(F32)
