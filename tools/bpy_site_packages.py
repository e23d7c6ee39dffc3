"""Put the Python modules bundled inside the bpy wheel (OpenImageIO, ...) on this environment's path.

Usage (the Makefile runs it for .venv52):
    .venv52/bin/python tools/bpy_site_packages.py

Blender ships its own OpenImageIO Python module in bpy/<version>/python/lib/python3.X/site-packages,
which `import bpy` does not put on sys.path. This writes a .pth file into the environment's
site-packages naming that folder (relative to site-packages, as .pth lines may be), so
`import OpenImageIO` finds Blender's copy and no second OpenImageIO needs installing. Python appends
.pth folders after site-packages, so a package installed in the environment still comes first.
"""
from __future__ import annotations

import glob
import os
import sys
import sysconfig

PTH = "primer-bpy-bundled.pth"


def main() -> int:
    site = sysconfig.get_path("purelib")
    found = sorted(glob.glob(os.path.join(site, "bpy", "*", "python", "lib", "python3.*", "site-packages",
                                          "OpenImageIO")))
    if len(found) != 1:
        print(f"expected one OpenImageIO inside bpy under {site}, found {found}", file=sys.stderr)
        return 1
    folder = os.path.relpath(os.path.dirname(found[0]), site)
    with open(os.path.join(site, PTH), "w", encoding="utf-8") as fh:
        fh.write(folder + "\n")
    print(f"{PTH}: {folder}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
