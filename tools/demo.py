"""Render every sample scene with Primer's core and write PNG and EXR files, printing the time per image.

Usage: .venv/bin/python tools/demo.py [--out out] [--only NAME ...]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from core import image_io, render  # noqa: E402
from sample_scenes.scenes import SCENES  # noqa: E402


def main(argv=None) -> int:
    """Render the sample scenes; return a process exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out", help="folder for the images (default: out)")
    parser.add_argument("--only", nargs="*", default=None, help="render only these scenes")
    args = parser.parse_args(argv)
    names = args.only or list(SCENES)
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        print(f"unknown scene(s) {unknown}; choose from {list(SCENES)}", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    for name in names:
        scene, settings = SCENES[name]()
        start = time.perf_counter()
        result = render.render(scene, settings)
        seconds = time.perf_counter() - start
        for ext in ("png", "exr"):
            image_io.write_image(os.path.join(args.out, f"{name}.{ext}"), result.image)
        rays = result.stats.rays
        print(f"{name:30s} {settings.width}x{settings.height} {settings.samples:3d} spp  "
              f"{seconds:6.2f} s  {rays / seconds / 1e6:5.2f} Mrays/s  -> {args.out}/{name}.png")
        for warning in result.stats.warnings:
            print(f"    warning: {warning}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
