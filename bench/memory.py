"""Peak memory of one render of a million-triangle mesh in Blender, Primer against Cycles (issue 34's target).

    .venv/bin/python bench/memory.py ENGINE TRIANGLES

Runs in a fresh Blender (the bpy module) with empty user folders: a grid of about TRIANGLES smooth triangles, a sun
and a camera, rendered once at 320 x 180 with 4 samples by ENGINE (PRIMER or CYCLES, on the CPU). Prints one JSON
line: the process's peak resident memory (ru_maxrss) after Blender starts, after the mesh is built, and after the
render, in MB, and the render's wall time. What the render adds (peak after the render less after the mesh) is the
engine's own: the scene in its form, its BVH, its film and its buffers.
"""
from __future__ import annotations

import json
import math
import os
import resource
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))


def peak_mb() -> float:
    """This process's peak resident memory in MB (Linux reports ru_maxrss in kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv=None) -> int:
    """Build the grid, render it once with the engine named, print the JSON line."""
    engine, triangles = (argv or sys.argv[1:])[:2]
    import bpy
    if engine == "PRIMER":
        from render import load_primer
        load_primer()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    started = peak_mb()
    # 1. A grid of about `triangles` triangles (two per square), smooth-shaded, a sun and a camera above it.
    side = max(2, int(round(math.sqrt(float(triangles) / 2.0))) + 1)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=side, y_subdivisions=side, size=10.0)
    grid = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0.0, -12.0, 8.0), (0.9, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.collection.objects.link(bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN")))
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 320, 180, 100
    scene.render.engine = engine
    scene.cycles.device, scene.cycles.samples = "CPU", 4
    if engine == "PRIMER":
        scene.primer.samples = 4
    built = peak_mb()
    # 2. One render.
    start = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - start
    print(json.dumps({"engine": engine, "triangles": 2 * len(grid.data.polygons), "started_mb": started,
                      "built_mb": built, "peak_mb": peak_mb(), "seconds": seconds}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
