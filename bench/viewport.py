"""Viewport timings: how long the coarse pass, a full pass and each kind of scene update take.

Usage:
    .venv/bin/python bench/viewport.py [--size 960x540] [--repeat 5] [SCENE ...]

For each sample scene (default: all of them) it syncs a ViewportSession with the scene, looks
through the scene camera at the given viewport size (as camera view at zoom 1), and prints in
milliseconds:
  sync      the first export (meshes, lights, BVH)
  coarse    the coarse pass (median of --repeat runs, each after a restart; block size in brackets)
  full      the first full-resolution pass of 1 sample per pixel
  move      a transform update of one mesh object (re-placed, BVH rebuilt)
  light     a light update (no BVH)
The issue's target: a coarse image within 100 ms of a change. Numbers depend on the machine and on
what else runs on it; the load average is printed with them.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))


def main() -> int:
    """Print the viewport timings of the sample scenes."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*", help="sample scene names (default: all)")
    parser.add_argument("--size", default="960x540", help="viewport size WxH in pixels")
    parser.add_argument("--repeat", type=int, default=5, help="coarse passes to time per scene")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))

    import bpy
    import numpy as np
    from render import load_primer

    primer = load_primer()
    viewport = sys.modules[primer.__name__ + ".addon.viewport"]
    progressive = sys.modules[primer.__name__ + ".core.render.progressive"]
    names = args.scenes or sorted(f[:-6] for f in os.listdir(os.path.join(ROOT, "sample_scenes"))
                                  if f.endswith(".blend"))
    print(f"viewport {width}x{height}, load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores")
    print(f"{'scene':30s} {'sync':>7s} {'coarse':>13s} {'full':>8s} {'move':>7s} {'light':>7s}")
    for name in names:
        bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", f"{name}.blend"))
        scene = bpy.context.scene
        session = viewport.ViewportSession()
        depsgraph = bpy.context.evaluated_depsgraph_get()
        start = time.perf_counter()
        session.update(depsgraph, start=False)
        sync_ms = 1e3 * (time.perf_counter() - start)
        camera = scene.camera.evaluated_get(depsgraph)
        if camera.data.type == "PANO":
            print(f"{name:30s} (fisheye: camera view renders inside the camera frame; skipped)")
            continue
        window = np.array(camera.calc_matrix_camera(depsgraph, x=width, y=height), np.float64)
        session.set_view(progressive.region_view(np.array(camera.matrix_world.inverted(), np.float64), window,
                                                 width, height), start=False)
        # Coarse passes, each after a restart, as after an edit; the first one also calibrates the block.
        coarse, blocks, full_ms = [], [], None
        for attempt in range(args.repeat + 1):
            session.restart(start=False)
            frames = session.run()
            frame = next(frames)
            if attempt > 0:
                coarse.append(1e3 * frame.pass_seconds)
                blocks.append(frame.block)
            if attempt == args.repeat:
                full_ms = 1e3 * next(frames).pass_seconds
            frames.close()
        # Updates, through depsgraph_update_post as view_update gets them.
        timings = {}

        def record(scene_, depsgraph_, key=None):
            began = time.perf_counter()
            session.update(depsgraph_, start=False)
            timings[record.key] = 1e3 * (time.perf_counter() - began)

        bpy.app.handlers.depsgraph_update_post.append(record)
        try:
            mesh_objects = [o for o in scene.objects if o.type == "MESH"]
            record.key = "move"
            mesh_objects[0].location.x += 0.01
            bpy.context.view_layer.update()
            lights = [o for o in scene.objects if o.type == "LIGHT"]
            record.key = "light"
            lights[0].data.energy *= 1.01
            bpy.context.view_layer.update()
        finally:
            bpy.app.handlers.depsgraph_update_post.remove(record)
        session.stop()
        print(f"{name:30s} {sync_ms:7.1f} {statistics.median(coarse):7.1f} (1/{max(set(blocks), key=blocks.count)})"
              f" {full_ms:8.1f} {timings.get('move', float('nan')):7.1f} {timings.get('light', float('nan')):7.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
