"""The 2D ray diagram: the scene cut at the camera's height, seen from above, with one row's rays."""
from __future__ import annotations

import math

import numpy as np

from core import materials
from core.camera import Camera
from core.geometry import primitives
from core.scene import PointLight, RenderSettings, Scene
from core.teaching import diagram


def mirror_room() -> Scene:
    """A camera at height 1 looking along +y at a mirror standing at y = 3 turned 30 degrees about z, a grey
    floor and a glass box before it, and a point light at the camera's height."""
    scene = Scene(camera=Camera(lens=35.0, matrix_world=np.array(
        [[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 1.0], [0, 0, 0, 1.0]])))
    scene.materials.append(materials.Material((0.9, 0.9, 0.9), name="mirror", bsdf="MIRROR"))
    scene.materials.append(materials.Material((0.6, 0.6, 0.6), name="grey"))
    scene.materials.append(materials.Material(name="glass", nodes=[("GLASS", (1, 1, 1), {"ior": 1.5})]))
    a = math.radians(30)
    turn = np.array([[math.cos(a), 0, -math.sin(a), 0], [math.sin(a), 0, math.cos(a), 3.0], [0, 1, 0, 1.0],
                     [0, 0, 0, 1.0]])
    scene.add_mesh(primitives.plane(3.0), turn, materials=np.array([0]))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([1]))
    scene.add_mesh(primitives.box((0.6, 0.6, 2.0), center=(-0.8, 1.6, 1.0)), materials=np.array([2]))
    scene.lights.append(PointLight(np.array([1.5, 0.5, 1.0]), power=100.0))
    return scene


def test_the_diagram_draws_the_rays_the_tracer_traces_where_they_go():
    """Whitted on the middle row: camera rays start at the eye; rays reflected by the mirror leave from points
    on its cut and follow the law of reflection (in the plane of the cut); glass gives refracted rays; shadow
    rays end at the light; the scene's cut has the mirror's line at its angle; each kind is drawn in its colour."""
    settings = RenderSettings(width=48, height=32, integrator="whitted", max_bounces=4)
    d = diagram.ray_diagram(mirror_room(), settings, size=256)
    kinds = {s.kind for s in d.segments}
    assert {"camera", "reflect", "refract", "shadow_free"} <= kinds
    camera = [s for s in d.segments if s.kind == "camera"][0]
    np.testing.assert_allclose(camera.start[:, 1], 0.1, atol=1e-6)      # on the near clip plane ahead of the eye
    # The mirror's cut: a line through (0, 3) at 30 degrees; reflected rays leave from it by the law of reflection.
    normal = np.array([-math.sin(math.radians(30)), math.cos(math.radians(30)), 0.0])
    starts = np.concatenate([s.start for s in d.segments if s.kind == "reflect"])
    ends = np.concatenate([s.end for s in d.segments if s.kind == "reflect"])
    on_mirror = np.abs((starts - [0.0, 3.0, 1.0]) @ normal) < 1e-3
    assert on_mirror.sum() >= 5
    cameras = camera.end[np.abs((camera.end - [0.0, 3.0, 1.0]) @ normal) < 1e-3]
    D = (cameras - camera.start[np.abs((camera.end - [0.0, 3.0, 1.0]) @ normal) < 1e-3])
    D /= np.linalg.norm(D, axis=1)[:, None]
    expected = D - 2.0 * (D @ normal)[:, None] * normal
    R = ends[on_mirror] - starts[on_mirror]
    R /= np.linalg.norm(R, axis=1)[:, None]
    assert max(np.abs(R - e).max(axis=1).min() for e in expected) < 1e-3
    light = [s for s in d.segments if s.kind == "shadow_free"][0]
    np.testing.assert_allclose(np.linalg.norm(light.end - [1.5, 0.5, 1.0], axis=1), 0.0, atol=1e-3)
    angles = np.degrees(np.arctan2(*(d.scene_lines[:, 1] - d.scene_lines[:, 0]).T[::-1]))
    assert np.any(np.isclose(angles % 180.0, 30.0, atol=0.5))
    image = d.image[..., :3]
    for kind in ("scene", "camera", "reflect", "refract", "shadow_free"):
        assert np.all(np.isclose(image, diagram.COLORS[kind], atol=1e-6), axis=-1).any(), f"no {kind} pixel drawn"


def test_the_diagram_is_written_as_a_png(tmp_path):
    """write_diagram writes the picture; the path tracer's bounces are drawn too."""
    from core.film import image_io
    settings = RenderSettings(width=24, height=16, integrator="path", max_bounces=3)
    path = str(tmp_path / "diagram.png")
    d = diagram.write_diagram(path, mirror_room(), settings, size=128)
    assert image_io.read_image(path).shape[:2] == (128, 128)
    assert "reflect" in {s.kind for s in d.segments}
