"""Compile Primer's C code into the shared library core/native/library.py loads (`make kernels`).

Usage:
    python tools/build_kernels.py [--cc CC] [--force]

core/native/primer.c includes every part's C file (core/lights/*.c, core/materials/*.c, ...) into one
translation unit. The library is named after the platform it runs on (core/native/library.py
`library_path`), so an extension built on one machine carries the library for that machine only;
elsewhere Primer uses its Python reference path. Rebuilt only when a C file under core/ is newer than
the library (or with --force).

Flags: no fused multiply-add (-ffp-contract=off), so that the kernels round exactly as the numpy code
they mirror does, step by step. -O3 turns the loops over blocks of samples into SIMD instructions
(core/native/primer.h compiles those for AVX2 as well, where the compiler can); two flags let it, and
neither changes a result: -fno-math-errno (sqrt is one instruction, with no errno to set) and
-fno-trapping-math (a lane may compute a value it then throws away, such as a division by zero).
"""
from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

FLAGS = ["-O3", "-std=c99", "-Wall", "-Wextra", "-fPIC", "-shared", "-ffp-contract=off",
         "-fno-math-errno", "-fno-trapping-math", "-fvisibility=hidden"]


def sources() -> list:
    """Return every C source and header under core/ (the unity file includes them)."""
    found = []
    for folder, _, files in os.walk(os.path.join(ROOT, "core")):
        found += [os.path.join(folder, name) for name in files if name.endswith((".c", ".h"))]
    return sorted(found)


def build(cc: str, force: bool = False) -> str:
    """Compile core/native/primer.c if any C file changed; return the library's path."""
    from core.native import library
    source = os.path.join(ROOT, "core", "native", "primer.c")
    target = library.library_path()
    newest = max(os.path.getmtime(path) for path in sources())
    if not force and os.path.exists(target) and os.path.getmtime(target) >= newest:
        return target
    command = shlex.split(cc) + FLAGS + [source, "-o", target + ".tmp", "-lm"]
    print(" ".join(command), flush=True)
    subprocess.run(command, check=True)
    os.replace(target + ".tmp", target)
    return target


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cc", default=os.environ.get("CC", "cc"), help="C compiler (default: $CC or cc)")
    parser.add_argument("--force", action="store_true", help="rebuild even if the library is up to date")
    args = parser.parse_args()
    path = build(args.cc, args.force)
    print(f"kernels: {os.path.relpath(path, ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
