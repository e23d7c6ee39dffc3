"""Lights in Cycles' units: each light type is a class here and a C file beside it.

LIGHT_TYPES is the table: a light's `kind` tag is its class's position in it, and the C code, generated from
it (core/lights/lights.gen.c), dispatches on the same tag. To add a light type, write its class
(core/lights/base.py says what it implements and which flags say what it is), its C file, and one entry here.
"""
from __future__ import annotations

from . import linking  # noqa: F401 (Light and Shadow Linking's sets)
from .area import AreaLight
from .base import LAMP, Light, LightFlags, LightHit, LightRecord, LightSample
from . import ies  # noqa: F401 (IES profiles: their record for C)
from .emitters import MeshEmitters
from .point import PointLight
from .spot import SpotLight
from .sun import SunLight
from .world import World, WorldLight
from . import world_graph  # noqa: F401,E402 (the world's program: its records for C)
from . import lamp_graph  # noqa: F401,E402 (a lamp's node program: its record for C)

# Blender's lamps, then the lights a render makes of its scene: the emissive meshes, the world's image.
LIGHT_TYPES = (PointLight, SpotLight, SunLight, AreaLight, MeshEmitters, WorldLight)

for _kind, _cls in enumerate(LIGHT_TYPES):
    _cls.kind = _kind
Light.types = LIGHT_TYPES


def usable(lights: list, warnings: list) -> list:
    """Return the lights with finite parameters that send some light; note the rest in warnings."""
    kept = []
    for light in lights:
        if not light.finite():
            warnings.append(f"light '{light.name}' has NaN or infinite parameters and was skipped")
        elif light.emits():
            kept.append(light)
    return kept


__all__ = ["AreaLight", "LAMP", "LIGHT_TYPES", "Light", "LightFlags", "LightHit", "LightRecord", "LightSample", "MeshEmitters",
           "PointLight", "SpotLight", "SunLight", "World", "WorldLight", "usable"]
