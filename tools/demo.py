"""`make demo`: render every sample scene with Primer and print the time per image.

First the .blend files in sample_scenes/, each through tools/render.py (Blender as the
bpy module, Primer loaded from this checkout) in its own process, as a user would run
it; then the teaching scenes built with core alone (sample_scenes/scenes.py).

Usage: .venv/bin/python tools/demo.py [--out out] [--only NAME ...] [--samples N]
"""
from __future__ import annotations

import argparse
import glob
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def render_blend_scenes(out: str, names, samples) -> int:
    """Render sample_scenes/*.blend with Primer into out/NAME.exr; return how many failed."""
    failed = 0
    for blend in sorted(glob.glob(os.path.join(ROOT, "sample_scenes", "*.blend"))):
        name = os.path.splitext(os.path.basename(blend))[0]
        if names and name not in names:
            continue
        command = [sys.executable, os.path.join(ROOT, "tools", "render.py"), blend,
                   "-o", os.path.join(out, f"{name}.exr")]
        if samples:
            command += ["--samples", str(samples)]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if done.returncode != 0:
            failed += 1
            print(f"{name:30s} FAILED: {done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode}")
            continue
        # tools/render.py prints "<file>: PRIMER rendered <out> in <s> s" (the render alone).
        render_line = next((line for line in done.stdout.splitlines() if " rendered " in line), "")
        render_seconds = render_line.rsplit(" in ", 1)[-1] if render_line else "?"
        print(f"{name:30s} render {render_seconds:>8s}  (with Blender start-up {seconds:5.1f} s)  -> {out}/{name}.exr")
    return failed


def render_core_scenes(out: str, names) -> None:
    """Render the scenes of sample_scenes/scenes.py with core alone into out/core/."""
    from core.film import image_io
    from core import render
    from sample_scenes.scenes import SCENES

    folder = os.path.join(out, "core")
    os.makedirs(folder, exist_ok=True)
    for name, build in SCENES.items():
        if names and name not in names:
            continue
        scene, settings = build()
        start = time.perf_counter()
        result = render.render(scene, settings)
        seconds = time.perf_counter() - start
        for ext in ("png", "exr"):
            image_io.write_image(os.path.join(folder, f"{name}.{ext}"), result.image)
        print(f"{name:30s} render {seconds:6.2f} s  {settings.width}x{settings.height} {settings.samples} spp  "
              f"{result.stats.rays / seconds / 1e6:4.2f} Mrays/s  -> {folder}/{name}.png")


def main(argv=None) -> int:
    """Render the sample scenes; return a process exit code."""
    parser = argparse.ArgumentParser(description="Render Primer's sample scenes.")
    parser.add_argument("--out", default="out", help="folder for the images (default: out)")
    parser.add_argument("--only", nargs="*", default=None, help="render only these scenes")
    parser.add_argument("--samples", type=int, default=None, help="override the .blend scenes' samples")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    print("Blender sample scenes (sample_scenes/*.blend, through tools/render.py):")
    failed = render_blend_scenes(args.out, args.only, args.samples)
    print("Teaching scenes built with core alone (sample_scenes/scenes.py):")
    render_core_scenes(args.out, args.only)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
