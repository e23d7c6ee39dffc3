"""The scene model: plain records the tracer reads (meshes, instances, materials, lights, camera, world)
and the render settings. Nothing here knows about Blender; a student can build a scene by hand."""
from __future__ import annotations

from ..camera.camera import Camera
from ..lights import AreaLight, Light, PointLight, SpotLight, SunLight, World
from ..materials import DEFAULT_BASE_COLOR, Material
from .scene import Instance, Mesh, Scene
from .settings import LECTURE_SWITCHES, RenderSettings

__all__ = ["AreaLight", "Camera", "DEFAULT_BASE_COLOR", "Instance", "LECTURE_SWITCHES", "Light", "Material", "Mesh",
           "PointLight", "RenderSettings", "Scene", "SpotLight", "SunLight", "World"]
