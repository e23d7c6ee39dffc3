"""Converter and colour nodes (Cycles' Vector Math, Vector Rotate, Gamma, Brightness/Contrast, RGB to BW, Blackbody,
Wavelength, Separate and Combine Color in RGB, HSV and HSL, RGB Curves, Vector Curves, Float Curve, the vector Map
Range, the IES Texture), one class and one
C file each, described as the procedural textures are (core/materials/procedural).

Adding one is one class (a `base.ConverterNode`: its Blender node, inputs, outputs, settings, numpy `evaluate` in
float32 as Cycles computes it; `table` for a node whose Blender node bakes a table, `c_tables` for constant tables C
reads), one C file `<c_name>.c` beside it with `<c_name>_texture(a, reg)` (`(a, reg, tables)` with a table), and one
entry in `CONVERTER_TYPES` here. core/materials/graph.py compiles and runs them beside the textures; tools/
make_boundary.py writes core/materials/converters/converters.gen.c (the constant tables, the shared headers, each C
file and `converter_op`, the switch graph.c falls through to); addon/materials.py reads them by `blender`.
"""
from __future__ import annotations

from .base import ConverterNode
from .blackbody import Blackbody
from .bright_contrast import BrightContrast
from .combine_color import CombineColor
from .float_curve import FloatCurve
from .gamma import Gamma
from .ies_texture import IESTexture
from .map_range_vector import MapRangeVector
from .rgb_curves import RGBCurves
from .rgb_to_bw import RGBToBW
from .separate_color import SeparateColor
from .vector_curves import VectorCurves
from .vector_math import VectorMath
from .vector_rotate import VectorRotate
from .wavelength import Wavelength

CONVERTER_TYPES = (VectorMath, VectorRotate, Gamma, BrightContrast, RGBToBW, Blackbody, Wavelength, SeparateColor,
                   CombineColor, RGBCurves, VectorCurves, FloatCurve, MapRangeVector, IESTexture)
# The C headers the converters' C files share, included first.
SHARED_C = ("color.h", "curves.h")

CONVERTER_BY_KIND = {cls.kind: cls for cls in CONVERTER_TYPES}
CONVERTER_BY_BLENDER = {cls.blender: cls for cls in CONVERTER_TYPES}
if len(CONVERTER_BY_KIND) != len(CONVERTER_TYPES) or len(CONVERTER_BY_BLENDER) != len(CONVERTER_TYPES):
    raise ValueError("two converter classes share a kind or a Blender node")

__all__ = ["ConverterNode", "CONVERTER_TYPES", "CONVERTER_BY_KIND", "CONVERTER_BY_BLENDER", "SHARED_C"]
