"""Run code under Blender's bpy module in a fresh process with empty user folders, for the Blender tests.

bpy keeps global state (registered classes, preferences, installed extensions, the open file), so a
test that installs or registers Primer runs a script in its own process through `run_bpy`. That
process gets an empty HOME and empty Blender user folders, so nothing from the machine's own Blender
setup leaks in and nothing the test installs leaks out.

The functions under "Inside Blender" are for those scripts (run_bpy puts this folder on their
sys.path): they render Blender's default scene (cube, light, camera) with Primer and summarise the
pixels, and hand results back to the test as one JSON line.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

TESTS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TESTS)
RESULT_TAG = "PRIMER_RESULT "


def isolated_env(folder: str) -> dict:
    """Return an environment whose HOME and Blender user folders are empty folders inside `folder`."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("BLENDER_") and k != "PYTHONPATH"}
    home = os.path.join(folder, "home")
    resources = os.path.join(folder, "blender")
    env.update(HOME=home, XDG_CONFIG_HOME=os.path.join(home, ".config"), XDG_CACHE_HOME=os.path.join(home, ".cache"),
               BLENDER_USER_RESOURCES=resources,
               BLENDER_USER_CONFIG=os.path.join(resources, "config"),
               BLENDER_USER_SCRIPTS=os.path.join(resources, "scripts"),
               BLENDER_USER_EXTENSIONS=os.path.join(resources, "extensions"),
               BLENDER_USER_DATAFILES=os.path.join(resources, "datafiles"),
               PYTHONNOUSERSITE="1")
    for path in (home, resources):
        os.makedirs(path, exist_ok=True)
    return env


def run_bpy(script: str, folder: str, *args: str, python: str = sys.executable, timeout: float = 600) -> dict:
    """Run `script` with bpy's Python in a fresh isolated process; return the dict it passed to report().

    Fails the test, showing the process's output, when it exits non-zero, prints a Python traceback,
    or reports nothing. The dict also carries the whole output as "output".
    """
    import pytest

    path = os.path.join(folder, "script.py")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"import sys\nsys.path.append({TESTS!r})\n" + textwrap.dedent(script))
    completed = subprocess.run([python, path, *args], cwd=folder, env=isolated_env(folder),
                               capture_output=True, text=True, timeout=timeout)
    output = completed.stdout + completed.stderr
    shown = "\n".join(output.splitlines()[-60:])
    if completed.returncode != 0:
        pytest.fail(f"Blender script exited with {completed.returncode}:\n{shown}", pytrace=False)
    if "Traceback (most recent call last)" in output:
        pytest.fail(f"Blender script printed a traceback:\n{shown}", pytrace=False)
    lines = [line for line in completed.stdout.splitlines() if line.startswith(RESULT_TAG)]
    if not lines:
        pytest.fail(f"Blender script reported nothing:\n{shown}", pytrace=False)
    result = json.loads(lines[-1][len(RESULT_TAG):])
    result["output"] = output
    return result


# ----------------------------------------------------------------------------
# Inside Blender
# ----------------------------------------------------------------------------

def report(**values) -> None:
    """Hand `values` back to run_bpy as one JSON line on stdout."""
    print(RESULT_TAG + json.dumps(values), flush=True)


def engine_ids() -> list:
    """Return the bl_idname of every registered render engine (Blender's own and add-ons').

    An unregistered class stays among Python's subclasses until it is garbage collected, so
    `is_registered` decides.
    """
    import bpy

    return sorted(cls.bl_idname for cls in bpy.types.RenderEngine.__subclasses__()
                  if getattr(cls, "bl_idname", "") and getattr(cls, "is_registered", False))


def primer_types() -> list:
    """Return the names in bpy.types that belong to Primer (engine, settings, panels)."""
    import bpy

    return sorted(name for name in dir(bpy.types) if "primer" in name.lower())


def can_select_primer() -> bool:
    """Return whether the scene accepts 'PRIMER' as its render engine (restoring the engine it had)."""
    import bpy

    render = bpy.context.scene.render
    before = render.engine
    try:
        render.engine = "PRIMER"
    except TypeError:               # "enum 'PRIMER' not found": no engine with that id is registered
        return False
    render.engine = before
    return True


def render_default_scene(out_path: str, package: str, width: int = 32, height: int = 24, samples: int = 2) -> dict:
    """Render the default scene with Primer through bpy.ops.render.render into `out_path` (EXR); summarise it."""
    import bpy
    import numpy as np

    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.primer.samples = samples
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = out_path
    scene.render.use_file_extension = False
    status = bpy.ops.render.render(write_still=True)
    record = sys.modules[package + ".addon.engine"].last_render
    image = bpy.data.images.load(out_path)
    pixels = np.array(image.pixels[:], np.float64).reshape(image.size[1], image.size[0], image.channels)
    bpy.data.images.remove(image)
    rgb = pixels[..., :3]
    return {
        "status": sorted(status),
        "error": record.error,
        "rays": record.rays,
        "kernels": record.stats.kernels if record.stats is not None else "",
        "shape": list(pixels.shape),
        "finite": bool(np.isfinite(pixels).all()),
        "max": float(np.nan_to_num(rgb).max()),
        "nonzero_fraction": float((rgb.sum(axis=2) > 1e-4).mean()),
    }
