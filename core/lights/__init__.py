"""Lights in Cycles' units: each light type is a class here and a C file beside it.

LIGHT_TYPES is the table: a light's `kind` tag is its class's position in it, and core/lights/lights.c
dispatches on the same tag. To add a light type, write its class (core/lights/base.py says what it
implements), its C file, and one entry here and in lights.c.
"""
from __future__ import annotations

from .area import AreaLight
from .base import Light, LightHit, LightRecord, LightSample
from .emitters import MeshEmitters
from .point import PointLight
from .spot import SpotLight
from .sun import SunLight
from .world import World, WorldLight

# Blender's lamps, then the lights a render makes of its scene: the emissive meshes, the world's image.
LIGHT_TYPES = (PointLight, SpotLight, SunLight, AreaLight, MeshEmitters, WorldLight)

assert all(cls.kind == index for index, cls in enumerate(LIGHT_TYPES)), "a light's kind is its place in LIGHT_TYPES"


def usable(lights: list, warnings: list) -> list:
    """Return the lights with finite parameters that send some light; note the rest in warnings."""
    kept = []
    for light in lights:
        if not light.finite():
            warnings.append(f"light '{light.name}' has NaN or infinite parameters and was skipped")
        elif light.emits():
            kept.append(light)
    return kept


__all__ = ["AreaLight", "LIGHT_TYPES", "Light", "LightHit", "LightRecord", "LightSample", "MeshEmitters",
           "PointLight", "SpotLight", "SunLight", "World", "WorldLight", "usable"]
