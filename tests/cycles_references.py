"""Cycles' reference images for the tests that hold Primer to Cycles (tests/test_blender_scenes.py,
tests/test_blender_holdout.py): rendered once, committed, and re-rendered only when stale.

A reference is committed as tests/references/<bpy version>/<id>.exr (half float RGBA, lossless ZIP) with its
key in that folder's manifest.json. The key covers everything that changes Cycles' image:

    inputs       the .blend file(s) and the setting changes (or the script) that make the scene
    samples      Cycles' sample count
    render_tool  tools/render.py, which sets Cycles up as Primer's reference
    cycles       every Cycles setting of the scene after tools/render.py's configure_cycles_reference, in
                 bpy's Python with Primer registered: the add-on's settings it applies (integrator, bounces,
                 caustics, clamping) included, whether the .blend sets them or the add-on's defaults do
    bpy          the bpy (Blender) version

A test whose committed reference is missing or stale (its key differs) renders the reference itself, says so (a
warning naming what changed), and keeps it in pytest's cache folder under its key; it never compares against a
stale image. `make references` (tools/cycles_references.py) renders the stale and missing ones into
tests/references/ and updates the manifests.
"""
from __future__ import annotations

import importlib.metadata
import json
import os
import shutil
import sys
import warnings

import numpy as np

from blender_env import ROOT, TESTS, run_bpy

if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
from bench.common import digest  # noqa: E402  (one cache-key function for the tests and the benchmark)
from core.film import image_io  # noqa: E402

REFERENCES = os.path.join(TESTS, "references")
RENDER_TOOL = os.path.join(ROOT, "tools", "render.py")
# Set by tools/cycles_references.py: write a missing or stale reference into tests/references/ (and its manifest).
WRITE = "PRIMER_WRITE_REFERENCES"

# The Cycles settings of each (blend, samples) as tools/render.py leaves them before rendering. Run in bpy's Python.
APPLIED = """
import json, sys
import bpy
from blender_env import report
sys.path.insert(0, {tools!r})
from render import configure_cycles_reference, load_primer

load_primer()               # as tools/render.py does: scene.primer (the add-on's settings) is read below
settings = []
for blend, samples in json.loads({jobs!r}):
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    configure_cycles_reference(scene, samples)
    values = {{}}
    for prop in scene.cycles.bl_rna.properties:
        if prop.identifier == "rna_type" or prop.type in ("POINTER", "COLLECTION"):
            continue
        value = getattr(scene.cycles, prop.identifier)
        values[prop.identifier] = sorted(value) if isinstance(value, set) else (
            list(value) if getattr(prop, "is_array", False) else value)
    settings.append(values)
report(settings=settings)
"""


def bpy_version() -> str:
    """The installed bpy's version, e.g. "5.0.1"."""
    return importlib.metadata.version("bpy")


def applied_settings(jobs: list, folder: str) -> list:
    """Return, for each (blend path, samples), Cycles' settings as tools/render.py applies them (one bpy process)."""
    if not jobs:
        return []
    script = APPLIED.format(tools=os.path.join(ROOT, "tools"), jobs=json.dumps([list(job) for job in jobs]))
    return run_bpy(script, folder)["settings"]


def key_parts(inputs: tuple, samples: int, applied: dict) -> dict:
    """The parts of a reference's key (see the module docstring), each a short digest or a plain value."""
    return {"inputs": digest(*inputs), "samples": samples, "render_tool": digest(RENDER_TOOL),
            "cycles": digest(applied), "bpy": bpy_version()}


def manifest_path(version: str | None = None) -> str:
    return os.path.join(REFERENCES, version or bpy_version(), "manifest.json")


def read_manifest(version: str | None = None) -> dict:
    path = manifest_path(version)
    if not os.path.isfile(path):
        return {}
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)


def write_half_exr(path: str, rgba: np.ndarray) -> None:
    """Write (H, W, 4) float pixels as a half-float RGBA EXR with lossless ZIP compression."""
    import OpenImageIO as oiio

    pixels = np.ascontiguousarray(rgba, dtype=np.float32)
    height, width, channels = pixels.shape
    spec = oiio.ImageSpec(width, height, channels, oiio.HALF)
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        raise OSError(f"cannot write {path}: {oiio.geterror()}")
    try:
        if not out.write_image(pixels):
            raise OSError(f"cannot write {path}: {out.geterror()}")
    finally:
        out.close()


def staleness(entry: dict | None, parts: dict, path: str) -> str:
    """Why the committed reference cannot be used ("" when it can)."""
    if entry is None or not os.path.isfile(path):
        return "is not committed"
    changed = [name for name in parts if entry.get("parts", {}).get(name) != parts[name]]
    if entry.get("key") != digest(parts) or changed:
        return f"is stale ({', '.join(changed) or 'key'} changed)"
    return ""


def reference(ref_id: str, blend: str, inputs: tuple, samples: int, applied: dict, cache: str, folder: str,
              render) -> np.ndarray:
    """Return Cycles' image `ref_id` of `blend`: the committed one when its key matches, else rendered now with
    `render(blend, out, "CYCLES", samples, folder)` (and cached under its key, or written to tests/references/
    when tools/cycles_references.py asks)."""
    version = bpy_version()
    parts = key_parts(inputs, samples, applied)
    key = digest(parts)
    committed = os.path.join(REFERENCES, version, f"{ref_id}.exr")
    why = staleness(read_manifest(version).get(ref_id), parts, committed)
    if not why:
        return image_io.read_image(committed)
    if os.environ.get(WRITE):
        fresh = os.path.join(folder, "cycles.exr")
        render(blend, fresh, "CYCLES", samples, folder)
        os.makedirs(os.path.dirname(committed), exist_ok=True)
        write_half_exr(committed, image_io.read_image(fresh))
        manifest = read_manifest(version)           # re-read: written one reference at a time
        manifest[ref_id] = {"key": key, "parts": parts, "source": os.path.relpath(blend, ROOT)
                            if blend.startswith(ROOT) else os.path.basename(blend)}
        with open(manifest_path(version) + ".part", "w", encoding="utf-8") as fh:
            json.dump(dict(sorted(manifest.items())), fh, indent=1, sort_keys=True)
            fh.write("\n")
        os.replace(manifest_path(version) + ".part", manifest_path(version))
        print(f"wrote {os.path.relpath(committed, ROOT)} ({why[3:] if why.startswith('is ') else why})", flush=True)
        return image_io.read_image(committed)
    cached = os.path.join(cache, f"{key}.exr")
    if not os.path.isfile(cached):
        message = (f"Cycles reference {version}/{ref_id} {why}: rendering it now ({samples} samples); "
                   f"`make references` renders and commits it")
        print(message, flush=True)
        warnings.warn(message)
        fresh = os.path.join(folder, "cycles.exr")
        render(blend, fresh, "CYCLES", samples, folder)
        part = f"{cached}.{os.getpid()}.part"      # pytest-xdist's workers may render the same one at once
        shutil.copyfile(fresh, part)
        os.replace(part, cached)                  # never leave a half-written reference behind
    else:
        warnings.warn(f"Cycles reference {version}/{ref_id} {why}: using the one rendered into the cache "
                      f"({os.path.basename(cached)}); `make references` commits it")
    return image_io.read_image(cached)
