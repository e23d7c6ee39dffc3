"""The table of BSDFs and shader nodes: a class's `kind` is its place in its table, here and in C.

Adding a BSDF or a shader node is one class (with its flags, core/materials/base.py), one C file beside it
(a BSDF's <name>_eval and <name>_sample; a node that only adds one closure of a BSDF needs none), and one
entry here. tools/make_boundary.py writes the C side of these tables (core/native/boundary.gen.h: the kinds
and flags; core/materials/bsdfs.gen.c and nodes.gen.c: each BSDF's C file and the switches on kind), and
`make kernels` runs it before compiling.
"""
from __future__ import annotations

import numpy as np

from ..native import schema
from .ashikhmin_shirley import AshikhminShirley
from .base import BSDF
from .beckmann import Beckmann
from .beckmann_glass import BeckmannGlass
from .glass import Glass
from .hair import ChiangHair, HairNode, HairReflection, HairTransmission, PrincipledHairNode
from .huang import HuangHair, HuangHairNode
from .lambert import Lambert
from .microfacet import Microfacet
from .mirror import Mirror
from .nodes import (DiffuseNode, EmissionNode, GlassNode, GlossyNode, HoldoutNode, MirrorNode, Node, PrincipledNode,
                    SheenNode, TransparentNode)
from .oren_nayar import OrenNayar
from .portal import Portal, PortalNode
from .rough_glass import RoughGlass
from .sheen import Sheen
from .subsurface import RandomWalk, SubsurfaceNode
from .toon import DiffuseToon, GlossyToon, ToonNode
from .translucent import Translucent, TranslucentNode
from .transparent import Transparent
from .velvet import Velvet

BSDF_TYPES = (Lambert, Mirror, Microfacet, Glass, Transparent, RoughGlass, OrenNayar, Sheen, Velvet, Translucent,
              Beckmann, BeckmannGlass, AshikhminShirley, DiffuseToon, GlossyToon, RandomWalk, ChiangHair,
              HairReflection, HairTransmission, Portal, HuangHair)
NODE_TYPES = (DiffuseNode, MirrorNode, GlossyNode, PrincipledNode, EmissionNode, TransparentNode, GlassNode,
              SheenNode, HoldoutNode, TranslucentNode, ToonNode, SubsurfaceNode,
              PrincipledHairNode, HairNode, PortalNode, HuangHairNode)


def _number(table: tuple, base: type) -> None:
    """Give each class of `table` its kind, its place there; refuse a name twice."""
    names = [cls.name for cls in table]
    if len(set(names)) != len(names):
        raise ValueError(f"two {base.__name__} classes share a name: {names}")
    for kind, cls in enumerate(table):
        cls.kind = kind
    base.types = table


_number(BSDF_TYPES, BSDF)
_number(NODE_TYPES, Node)
# The flags by kind, with a last 0 that kind -1 (an empty closure slot) picks.
BSDF.flag_table = np.array([int(cls.flags) for cls in BSDF_TYPES] + [0], np.int64)

schema.table("BSDF", lambda: [cls.c_name() for cls in BSDF_TYPES])
schema.table("NODE", lambda: [cls.name for cls in NODE_TYPES])

BSDF_BY_NAME = {cls.name: cls for cls in BSDF_TYPES}
NODE_BY_NAME = {cls.name: cls for cls in NODE_TYPES}
