"""Procedural texture nodes (Cycles' Noise, Voronoi, White Noise, Gradient, Checker, Wave, Magic, Brick and Gabor
textures, and the Radial Tiling node, a texture coordinate built the same way), one class and one C file each.

Adding a texture node is one class (a `base.TextureNode`: its Blender node, inputs, outputs, settings and numpy
`evaluate`), one C file beside it (`<c_name>.c` with `<c_name>_texture`, the op at one hit), and one entry in
`TEXTURE_TYPES` here. core/materials/graph.py makes each class's `kind` an op code and compiles it from the
description; tools/make_boundary.py writes the C side (core/materials/procedural/procedural.gen.c: the shared
headers, each texture's C file and `procedural_op`, the switch on the op code); addon/materials.py reads the node.
The textures share Cycles' hashes (hash.py, hash.h) and Perlin noise (perlin.py, perlin.h), computed in float32 and
uint32 as Cycles does, so that a texture's pattern is Cycles' own.
"""
from __future__ import annotations

from .base import TextureNode
from .brick import BrickTexture
from .checker import CheckerTexture
from .gabor import GaborTexture
from .gradient import GradientTexture
from .magic import MagicTexture
from .noise import NoiseTexture
from .radial_tiling import RadialTiling
from .voronoi import VoronoiTexture
from .wave import WaveTexture
from .white_noise import WhiteNoiseTexture

TEXTURE_TYPES = (CheckerTexture, GradientTexture, WhiteNoiseTexture, NoiseTexture, VoronoiTexture, WaveTexture,
                 MagicTexture, BrickTexture, GaborTexture, RadialTiling)
# The C headers every texture's C file may use, included first.
SHARED_C = ("hash.h", "perlin.h")

TEXTURE_BY_KIND = {cls.kind: cls for cls in TEXTURE_TYPES}
TEXTURE_BY_BLENDER = {cls.blender: cls for cls in TEXTURE_TYPES}
if len(TEXTURE_BY_KIND) != len(TEXTURE_TYPES) or len(TEXTURE_BY_BLENDER) != len(TEXTURE_TYPES):
    raise ValueError("two texture classes share a kind or a Blender node")

__all__ = ["TextureNode", "TEXTURE_TYPES", "TEXTURE_BY_KIND", "TEXTURE_BY_BLENDER", "SHARED_C", "BrickTexture",
           "CheckerTexture", "GaborTexture", "GradientTexture", "MagicTexture", "NoiseTexture", "RadialTiling", "VoronoiTexture", "WaveTexture",
           "WhiteNoiseTexture"]
