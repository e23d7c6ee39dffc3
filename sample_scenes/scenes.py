"""Sample scenes built with core alone (no Blender): each shows one idea of the lecture.

Every builder returns (Scene, RenderSettings). `tools/demo.py` renders them all.
"""
from __future__ import annotations

import math

import numpy as np

from core.geometry import primitives
from core.camera import Camera
from core.scene import AreaLight, PointLight, RenderSettings, Scene, SpotLight, SunLight


def _sun_travel(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """Return the direction sunlight travels for a sun at this elevation and azimuth."""
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    return -np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def _stage(offset=np.zeros(3), camera_distance: float = 7.0) -> Scene:
    """A grey floor with a red smooth sphere and a white box, seen from the front."""
    eye = offset + np.array([0.0, -camera_distance, 0.45 * camera_distance])
    scene = Scene(camera=Camera.look_at(eye, offset + [0.0, 0.0, 0.6], fov=math.radians(45)),
                  world_color=np.array([0.02, 0.025, 0.03]))
    scene.add_material((0.8, 0.8, 0.8))
    scene.add_material((0.8, 0.2, 0.15))
    M = np.eye(4)
    M[:3, 3] = offset
    scene.add_mesh(primitives.plane(30.0), matrix=M)
    scene.add_mesh(primitives.uv_sphere(0.8, 32, 16, center=(0.9, 0.2, 0.8)), matrix=M, materials=[1])
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(-1.1, 0.5, 0.5)), matrix=M)
    return scene


def lights() -> tuple[Scene, RenderSettings]:
    """Point, spot, disk area and sun light on the same stage, in Cycles' units."""
    scene = _stage()
    scene.lights += [
        PointLight(np.array([2.5, -2.0, 3.0]), power=80.0, color=np.array([1.0, 0.9, 0.8])),
        SpotLight(np.array([-2.5, -2.5, 4.0]), np.array([0.45, 0.5, -0.74]) / np.linalg.norm([0.45, 0.5, -0.74]),
                  power=250.0, spot_size=math.radians(40), spot_blend=0.3, color=np.array([0.7, 0.8, 1.0])),
        AreaLight(np.array([0.0, 2.5, 3.0]), np.array([1.5, 0.0, 0.0]), np.array([0.0, 1.5, 0.0]),
                  np.array([0.0, 0.0, -1.0]), power=120.0, shape="DISK"),
        SunLight(_sun_travel(35.0, 150.0), strength=0.15, angle=math.radians(3.0)),
    ]
    return scene, RenderSettings(width=480, height=320, samples=16, light_samples=2)


def _grazing(method: str, epsilon: float = 1e-3) -> tuple[Scene, RenderSettings]:
    """The stage 100 km from the origin under a low sun, in world coordinates (no camera-relative help)."""
    scene = _stage(offset=np.array([1e5, 0.0, 0.0]))
    scene.lights.append(SunLight(_sun_travel(4.0, 120.0), strength=2.0))
    scene.lights.append(PointLight(np.array([1e5 + 1.0, -3.0, 4.0]), power=150.0))
    return scene, RenderSettings(width=480, height=320, samples=4, shadow_method=method, epsilon=epsilon,
                                 camera_relative=False)


def shadow_offset_epsilon() -> tuple[Scene, RenderSettings]:
    """The lecture's epsilon = 1e-3 far from the origin: shadow acne speckles every lit surface."""
    return _grazing("epsilon", 1e-3)


def shadow_offset_robust() -> tuple[Scene, RenderSettings]:
    """The robust error-bound offset in the same world coordinates: no acne, contact shadows kept."""
    return _grazing("robust")


def smooth_and_flat() -> tuple[Scene, RenderSettings]:
    """Two 12-segment spheres: flat (face normals) on the left, smooth (interpolated normals) on the right."""
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 3.0), (0.0, 0.0, 0.9), fov=math.radians(35)),
                  world_color=np.array([0.02, 0.025, 0.03]))
    scene.add_material((0.8, 0.8, 0.8))
    scene.add_mesh(primitives.plane(30.0))
    for x, smooth in ((-1.3, False), (1.3, True)):
        scene.add_mesh(primitives.uv_sphere(1.0, 12, 6, center=(x, 0.0, 1.0), smooth=smooth))
    scene.lights.append(SunLight(_sun_travel(20.0, -25.0), strength=2.0))
    return scene, RenderSettings(width=480, height=240, samples=16)


def smooth_terminator_fix() -> tuple[Scene, RenderSettings]:
    """The same spheres with the shadow-terminator fix switched on."""
    scene, settings = smooth_and_flat()
    settings.terminator_fix = True
    return scene, settings


def fisheye() -> tuple[Scene, RenderSettings]:
    """The stage through a 180-degree equidistant fisheye lens."""
    scene, settings = lights()
    scene.camera = Camera(matrix_world=Camera.look_at((0.0, -3.0, 1.5), (0.0, 0.0, 0.8)).matrix_world,
                          type="PANO", panorama_type="FISHEYE_EQUIDISTANT", fisheye_fov=math.pi)
    settings.width = settings.height = 320
    return scene, settings


SCENES = {
    "lights": lights,
    "shadow_offset_epsilon": shadow_offset_epsilon,
    "shadow_offset_robust": shadow_offset_robust,
    "smooth_and_flat": smooth_and_flat,
    "smooth_terminator_fix": smooth_terminator_fix,
    "fisheye": fisheye,
}
