"""The camera: primary rays from Blender's camera model (camera.py), and the viewport's camera (view.py)."""
from __future__ import annotations

from .camera import Camera, CameraRays, fov_from_lens, generate_rays, lens_from_fov, outside_image_circle, viewplane

__all__ = ["Camera", "CameraRays", "fov_from_lens", "generate_rays", "lens_from_fov", "outside_image_circle",
           "viewplane"]
