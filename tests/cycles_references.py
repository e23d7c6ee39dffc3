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
stale image. `make references` (tools/make_references.py) renders the stale and missing ones into
tests/references/ and updates the manifests.
"""
from __future__ import annotations

import importlib.metadata
import json
import os
import re
import shutil
import sys
import warnings

import numpy as np

from blender_env import ROOT, STALE_TAG, TESTS, run_bpy

if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
from bench.common import digest  # noqa: E402  (one cache-key function for the tests and the benchmark)
from core.film import image_io  # noqa: E402

REFERENCES = os.path.join(TESTS, "references")
RENDER_TOOL = os.path.join(ROOT, "tools", "render.py")
# Set by tools/make_references.py: write a missing or stale reference into tests/references/ (and its manifest).
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


def commit(folder: str, ref_id: str, entry: dict, committed: str, why: str) -> None:
    """Enter the reference `ref_id`, just written to `committed`, in the manifest of `folder` (a bpy version, or
    <version>/scripted) with its `entry` (key, parts, ...), and say so: one process at a time writes references
    (tools/make_references.py), so the manifest is re-read and rewritten whole for each."""
    manifest = read_manifest(folder)
    manifest[ref_id] = entry
    with open(manifest_path(folder) + ".part", "w", encoding="utf-8") as fh:
        json.dump(dict(sorted(manifest.items())), fh, indent=1, sort_keys=True)
        fh.write("\n")
    os.replace(manifest_path(folder) + ".part", manifest_path(folder))
    print(f"wrote {os.path.relpath(committed, ROOT)} ({why[3:] if why.startswith('is ') else why})", flush=True)


def keep_in_cache(rendered: str, cached: str) -> None:
    """Copy the image `rendered` to `cached` whole or not at all (pytest-xdist's workers may render one at once)."""
    os.makedirs(os.path.dirname(cached), exist_ok=True)
    part = f"{cached}.{os.getpid()}.part"
    shutil.copyfile(rendered, part)
    os.replace(part, cached)


def reference(ref_id: str, blend: str, inputs: tuple, samples: int, applied: dict, cache: str, folder: str,
              render) -> np.ndarray:
    """Return Cycles' image `ref_id` of `blend`: the committed one when its key matches, else rendered now with
    `render(blend, out, "CYCLES", samples, folder)` (and cached under its key, or written to tests/references/
    when tools/make_references.py asks)."""
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
        commit(version, ref_id, {"key": key, "parts": parts, "source": os.path.relpath(blend, ROOT)
                                 if blend.startswith(ROOT) else os.path.basename(blend)}, committed, why)
        return image_io.read_image(committed)
    cached = os.path.join(cache, f"{key}.exr")
    if not os.path.isfile(cached):
        message = (f"Cycles reference {version}/{ref_id} {why}: rendering it now ({samples} samples); "
                   f"`make references` renders and commits it")
        print(message, flush=True)
        warnings.warn(message)
        fresh = os.path.join(folder, "cycles.exr")
        render(blend, fresh, "CYCLES", samples, folder)
        keep_in_cache(fresh, cached)
    else:
        warnings.warn(f"Cycles reference {version}/{ref_id} {why}: using the one rendered into the cache "
                      f"({os.path.basename(cached)}); `make references` commits it")
    return image_io.read_image(cached)


# ----------------------------------------------------------------------------
# References of scenes the tests build in Blender (scripts and in-process tests)
# ----------------------------------------------------------------------------
# A test that builds its scene with bpy and holds Primer to Cycles' image of it names that image:
# blender_env.render_pixels(..., reference="label") keeps it as tests/references/<bpy>/scripted/<module>-<label>.exr,
# keyed by what makes the scene and Cycles' image of it: the test's file (its scene-building code), the helpers
# (tests/blender_env.py, tools/render.py), the files the scene reads (a .blend, images, libraries), Cycles' and the
# render's settings as they are when it renders, the samples and the bpy version.
SCRIPTED = "scripted"
SKIPPED_RENDER_SETTINGS = {"filepath"}           # where the image goes, a test's own folder
USED: set = set()                                # the scripted references this process has asked for


def rna_values(struct, skip=frozenset()) -> dict:
    """Return the plain (non-pointer, non-collection) properties of an RNA struct as JSON-able values."""
    values = {}
    for prop in struct.bl_rna.properties:
        if prop.identifier in skip or prop.identifier == "rna_type" or prop.type in ("POINTER", "COLLECTION"):
            continue
        value = getattr(struct, prop.identifier)
        values[prop.identifier] = sorted(value) if isinstance(value, set) else (
            list(value) if getattr(prop, "is_array", False) else value)
    return values


def current_test_file() -> str | None:
    """Return the path of the test file pytest is running (PYTEST_CURRENT_TEST, inherited by run_bpy's scripts)."""
    current = os.environ.get("PYTEST_CURRENT_TEST", "")
    path = os.path.join(ROOT, current.split("::")[0]) if "::" in current else ""
    return path if os.path.isfile(path) else None


def builder_sources(test: str | None) -> list:
    """Return the test file `test` and the test modules it imports its scene builders from (`from test_x import`)."""
    if test is None:
        return [""]
    with open(test, encoding="utf-8") as fh:
        imported = re.findall(r"^from (test_\w+) import", fh.read(), flags=re.MULTILINE)
    return [test] + [os.path.join(TESTS, f"{name}.py") for name in sorted(set(imported))]


def scripted_parts(ref_id: str, scene, samples: int) -> dict:
    """The parts of the key of the scripted reference `ref_id` of `scene` (set up for Cycles and its output) at
    `samples`. The id is a part: two renders of one test file under the same settings (a test's parameters change
    its scene, not its settings) have keys, and cached images, of their own."""
    import bpy
    read = [bpy.data.filepath] + [bpy.path.abspath(image.filepath, library=image.library) for image in
                                  bpy.data.images if image.source in {"FILE", "SEQUENCE", "TILED", "MOVIE"}]
    read += [bpy.path.abspath(library.filepath) for library in bpy.data.libraries]
    read += [bpy.path.abspath(volume.filepath, library=volume.library) for volume in bpy.data.volumes]  # (.vdb grids)
    settings = {"cycles": rna_values(scene.cycles),
                "render": rna_values(scene.render, SKIPPED_RENDER_SETTINGS),
                "view_layers": {layer.name: rna_values(layer) for layer in scene.view_layers}}
    return {"id": ref_id, "test": digest(*builder_sources(current_test_file())),
            "helpers": digest(os.path.join(TESTS, "blender_env.py"), RENDER_TOOL),
            "inputs": digest(*sorted(path for path in read if path and os.path.isfile(path))),
            "cycles": digest(settings), "samples": samples, "bpy": bpy_version()}


def claim(label: str | bool, path: str) -> str:
    """Return the id <test file>-<label> of a scripted reference (label True: the running test's name and the stem of
    `path`), and fail if this process asked for it before: two scenes under one id would replace each other."""
    test = current_test_file()
    if label is True:
        name = os.environ.get("PYTEST_CURRENT_TEST", "").split("::")[-1].rsplit(" ", 1)[0]
        label = f"{name}-{os.path.splitext(os.path.basename(path))[0]}"
    ref_id = f"{os.path.splitext(os.path.basename(test))[0] if test else 'untested'}-{label}"
    if ref_id in USED:
        raise RuntimeError(f"Cycles reference {ref_id} is asked for twice in one run: give each render its label")
    USED.add(ref_id)
    return ref_id


def scripted_reference(scene, label: str | bool, path: str) -> None:
    """Leave Cycles' image of `scene` (set up by configure_cycles_reference and configure_output to write the EXR
    `path`, at scene.cycles.samples) at `path`: the committed reference <module>-<label> (label True: the running test's name, with its
    parameters, and the stem of `path`; for a function-scoped test) when its key matches, else rendered now (and written
    to tests/references/ when tools/make_references.py asks, or else kept in pytest's cache under its key, with a
    warning: `make references` commits it)."""
    import bpy
    ref_id = claim(label, path)
    version, samples = bpy_version(), scene.cycles.samples
    parts = scripted_parts(ref_id, scene, samples)
    key = digest(parts)
    committed = os.path.join(REFERENCES, version, SCRIPTED, f"{ref_id}.exr")
    why = staleness(read_manifest(f"{version}/{SCRIPTED}").get(ref_id), parts, committed)
    if not why:
        shutil.copyfile(committed, path)
        return
    cached = os.path.join(ROOT, ".pytest_cache", "d", "primer-cycles-references", f"{key}.exr")
    if os.path.isfile(cached) and not os.environ.get(WRITE):
        warnings.warn(f"Cycles reference {version}/{SCRIPTED}/{ref_id} {why}: using the one rendered into the "
                      f"cache ({os.path.basename(cached)}); `make references` commits it")
        shutil.copyfile(cached, path)
        return
    bpy.ops.render.render(write_still=True)
    if os.environ.get(WRITE):
        os.makedirs(os.path.dirname(committed), exist_ok=True)
        shutil.copyfile(path, committed)          # Cycles' own float EXR: pixel-exact tests compare to 1e-6
        commit(f"{version}/{SCRIPTED}", ref_id, {"key": key, "parts": parts}, committed, why)
        return
    message = (f"Cycles reference {version}/{SCRIPTED}/{ref_id} {why}: rendered it now ({samples} samples); "
               f"`make references` renders and commits it")
    print(STALE_TAG + message, flush=True)
    warnings.warn(message)
    keep_in_cache(path, cached)

