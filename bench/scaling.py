"""Scaling runs with core alone: time and peak memory against triangles, pixels, lights and instances.

Each point runs in its own process, so its peak resident memory (ru_maxrss) is its own:

    .venv/bin/python bench/scaling.py KIND VALUE        prints one JSON line

KIND is "triangles" (a heightfield of VALUE triangles), "pixels" (VALUE pixels at 16:9), "lights"
(VALUE point lights), "instances" (VALUE copies of a 48-triangle sphere), "instances_fine" (VALUE
copies of a 4,800-triangle sphere: 100 times the triangles, in the same places) or "samples_4k" (a
3840 x 2160 render at VALUE samples, with adaptive sampling as Blender's default has it). Every
point renders with the robust shadow offset on all cores; see DEFAULTS for the fixed parameters.
All but samples_4k sample uniformly, so their times measure the cost per sample.
"""
from __future__ import annotations

import json
import math
import os
import resource
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from core.geometry import primitives
from core import render  # noqa: E402
from core.camera import Camera  # noqa: E402
from core.geometry.geometry import build_geometry  # noqa: E402
from core.geometry.intersect import Tracer  # noqa: E402
from core.scene import Mesh, PointLight, RenderSettings, Scene, SunLight  # noqa: E402

# What stays fixed while one quantity varies.
DEFAULTS = {"triangles": 10_000, "width": 320, "height": 180, "samples": 4, "lights": 2, "instances": 1}
KINDS = ("triangles", "pixels", "lights", "instances", "instances_fine", "samples_4k")
# The spheres of the two instance series: (segments, rings) of 48 and 4,800 triangles.
SPHERES = {"instances": (8, 4), "instances_fine": (80, 31)}


def heightfield(triangles: int, size: float = 10.0) -> Mesh:
    """Return a wavy square grid of about `triangles` flat triangles, `size` wide, centred at the origin.

    Built with array operations only, so 10^7 triangles take seconds. vertices (v, 3) float64.
    """
    k = max(1, int(round(math.sqrt(triangles / 2.0))))          # k x k quads, two triangles each
    s = np.linspace(-0.5 * size, 0.5 * size, k + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    z = 0.15 * np.sin(1.7 * x) * np.cos(1.3 * y) + 0.05 * np.sin(5.0 * x + 3.0 * y)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = (i * (k + 1) + j).ravel()
    b, c, d = a + (k + 1), a + (k + 2), a + 1
    tris = np.empty((2 * len(a), 3), np.int64)
    tris[0::2] = np.stack([a, b, c], axis=1)
    tris[1::2] = np.stack([a, c, d], axis=1)
    return Mesh(vertices, tris, name="Heightfield")


def build(kind: str, value: int) -> tuple:
    """Return (scene, settings, description dict) for one scaling point."""
    p = dict(DEFAULTS)
    if kind == "pixels":
        p["height"] = max(1, int(round(math.sqrt(value * 9.0 / 16.0))))
        p["width"] = max(1, int(round(value / p["height"])))
        p["samples"] = 1
    elif kind == "samples_4k":
        p["width"], p["height"], p["samples"] = 3840, 2160, int(value)
    elif kind in SPHERES:
        p["instances"] = int(value)
    elif kind in p:
        p[kind] = int(value)
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 5.0), (0.0, 0.0, 0.0), fov=math.radians(55)),
                  world_color=np.array([0.02, 0.02, 0.03]))
    scene.add_material((0.7, 0.7, 0.7))
    scene.add_material((0.8, 0.3, 0.2))
    if kind in SPHERES:
        scene.add_mesh(primitives.plane(12.0))
        sphere = primitives.uv_sphere(1.0, *SPHERES[kind], smooth=False)
        scene.meshes.append(sphere)
        n = p["instances"]
        side = int(math.ceil(math.sqrt(n)))
        spacing = 10.0 / side
        from core.scene import Instance
        for index in range(n):
            M = np.eye(4)
            M[:3, :3] *= 0.35 * spacing
            M[:3, 3] = (-5.0 + spacing * (index % side + 0.5), -5.0 + spacing * (index // side + 0.5), 0.35 * spacing)
            scene.instances.append(Instance(1, M, np.array([1]), f"Sphere {index}"))
    else:
        scene.add_mesh(heightfield(p["triangles"]))
    scene.lights.append(SunLight(np.array([-0.4, 0.5, -0.77]) / np.linalg.norm([-0.4, 0.5, -0.77]), strength=1.0))
    rng = np.random.default_rng(7)
    for index in range(p["lights"] - 1):
        position = np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(1.0, 4.0)])
        scene.lights.append(PointLight(position, power=300.0 / max(1, p["lights"] - 1), name=f"Point {index}"))
    settings = RenderSettings(width=p["width"], height=p["height"], samples=p["samples"], jitter=True,
                              adaptive=kind == "samples_4k")
    return scene, settings, p


def peak_mb() -> float:
    """Return this process's peak resident memory in MB (Linux reports ru_maxrss in kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def measure(kind: str, value: int) -> dict:
    """Build and render one scaling point and return its times, ray counts and memory."""
    baseline = peak_mb()
    start = time.perf_counter()
    scene, settings, p = build(kind, value)
    built = time.perf_counter() - start
    scene_peak = peak_mb()          # the core scene description alone (10^5 instance records are not free)
    result = render.render(scene, settings)
    stats = result.stats
    peak = peak_mb()
    # The Embree BVH build alone, on the same triangles (a second build, after the render, so
    # that it cannot change the render's time or peak memory).
    geometry = build_geometry(scene, np.asarray(scene.camera.matrix_world)[:3, 3])
    start = time.perf_counter()
    tracer = Tracer(geometry.vertices, geometry.triangles, instanced=geometry.instanced)
    embree_build = time.perf_counter() - start
    return {"kind": kind, "value": value, "triangles": stats.triangles, "pixels": settings.width * settings.height,
            "width": settings.width, "height": settings.height, "samples": settings.samples,
            "lights": len(scene.lights), "instances": len(scene.instances), "scene_seconds": built,
            "seconds": stats.seconds, "bvh_seconds": stats.geometry_seconds, "embree_build_seconds": embree_build,
            "embreex_upload_seconds": tracer.upload_seconds, "embree_shared": tracer.shared, "embree_commit_seconds": tracer.build_seconds,
            "trace_seconds": stats.trace_seconds, "shading_seconds": stats.shading_seconds,
            "rays": stats.rays, "peak_mb": peak, "baseline_mb": baseline,
            "scene_peak_mb": scene_peak}


def main(argv=None) -> int:
    """Measure the point named on the command line and print it as one JSON line."""
    argv = sys.argv[1:] if argv is None else argv
    kind, value = argv[0], int(float(argv[1]))
    if kind not in KINDS:
        raise SystemExit(f"KIND must be one of {KINDS}")
    print(json.dumps(measure(kind, value)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
