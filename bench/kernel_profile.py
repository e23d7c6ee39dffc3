"""Profile the compiled kernels alone on a real scene (issue 34): export it once to a pickle, then render the pickle
with core.render outside Blender, so that callgrind counts the kernels and not Blender.

    .venv/bin/python bench/kernel_profile.py dump cornell_box path /tmp/cb_path.pkl        (rigs at 64 x 48)
    valgrind --tool=callgrind --toggle-collect='*render_chunk*' \\
        .venv/bin/python bench/kernel_profile.py render /tmp/cb_path.pkl 8 path [OUT.npy [THREADS]]

`dump` rigs the cached scene as tools/real_scenes.py does (into the pickle's folder), renders it once in Primer
with one thread and keeps the (Scene, RenderSettings) that the add-on hands core.render. `render` renders them with
SAMPLES samples, one thread (or THREADS), the integrator given (the passes as rigged), prints the times and the mean, and saves the
image and every pass flattened into OUT.npy (to compare builds bit for bit). The pickle holds Primer's classes: it is
stale once their fields change; dump it again then.
"""
from __future__ import annotations

import dataclasses
import importlib
import os
import pickle
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def dump(name: str, integrator: str, out: str, width: int = 64, height: int = 48) -> None:
    """Rig the cached real scene `name` for `integrator` at width x height and pickle what Primer's render exports."""
    sys.path.insert(0, os.path.join(ROOT, "bench"))
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import real_scenes
    rigged, notes = real_scenes.rig(name, integrator, width, height,
                                    out=os.path.join(os.path.dirname(os.path.abspath(out)), f"{name}_{integrator}.blend"))
    if not rigged:
        raise SystemExit(f"rigging failed: {notes}")
    import bpy
    import scenes
    scenes.load_primer()
    bpy.ops.wm.open_mainfile(filepath=rigged)
    scenes.use_primer(bpy.context.scene, 1, threads=1)
    module = sys.modules["primer.core.render"]
    original = module.render

    def keep(scene, settings, *args, **kwargs):
        """core.render.render, pickling its scene and settings first."""
        with open(out, "wb") as handle:
            pickle.dump((scene, settings), handle)
        return original(scene, settings, *args, **kwargs)

    module.render = keep
    bpy.ops.render.render()
    print(f"dumped {out} ({os.path.getsize(out)} bytes)")


class _Unpickler(pickle.Unpickler):
    """Reads the add-on's classes (module primer.core...) as this checkout's (core...)."""

    def find_class(self, module, name):
        if module.startswith("primer."):
            module = module[len("primer."):]
        return getattr(importlib.import_module(module), name)


def render(path: str, samples: int, integrator: str, out: str = "", threads: int = 1) -> None:
    """Render the pickled scene with `samples` samples on `threads` threads; print the times; save image and passes
    to out (a .npy, to compare runs bit for bit)."""
    from core import render as core_render
    with open(path, "rb") as handle:
        scene, settings = _Unpickler(handle).load()
    settings = dataclasses.replace(settings, samples=samples, integrator=integrator, threads=threads)
    start = time.perf_counter()
    result = core_render.render(scene, settings)
    s = result.stats
    print(f"wall {time.perf_counter() - start:.3f} s, shading {s.shading_seconds:.3f} s, trace {s.trace_seconds:.3f} s,"
          f" rays {s.rays}, mean {result.image[..., :3].mean():.6f}, {settings.width} x {settings.height}")
    if out:
        import numpy as np
        parts = [result.image.ravel()] + [np.asarray(result.aux[k], np.float32).ravel() for k in sorted(result.aux)]
        np.save(out, np.concatenate(parts))


if __name__ == "__main__":
    if len(sys.argv) >= 5 and sys.argv[1] == "dump":
        dump(sys.argv[2], sys.argv[3], sys.argv[4])
    elif len(sys.argv) >= 5 and sys.argv[1] == "render":
        render(sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5] if len(sys.argv) > 5 else "",
               int(sys.argv[6]) if len(sys.argv) > 6 else 1)
    else:
        raise SystemExit(__doc__)
