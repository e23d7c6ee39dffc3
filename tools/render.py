"""Render a .blend file headlessly with the bpy module, with Primer loaded from this checkout.

Usage:
    .venv/bin/python tools/render.py SCENE.blend -o OUT.exr [--samples N] [--engine PRIMER|CYCLES]
                                     [--percentage P] [--frame F] [--seed S]

Writes a linear float EXR (or an 8-bit sRGB PNG when OUT ends in .png), prints the
render's wall time, and exits non-zero with a clear message on failure. With
--engine CYCLES it renders the same scene as Primer's reference: direct light
only (max_bounces = 0), a 1-pixel box filter, no denoising.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load_primer(name: str = "primer"):
    """Import this checkout as the package `name` and register it with Blender; return the module.

    The package may already be imported without being registered: pytest imports a checkout
    folder named `primer` (it holds an `__init__.py`) as the package `primer` before any test
    runs. That module is this checkout, so it is registered here rather than replaced.
    """
    init = os.path.join(ROOT, "__init__.py")
    module = sys.modules.get(name)
    if module is not None and getattr(module, "_registered_by_load_primer", False):
        return module
    if module is not None and not os.path.samefile(getattr(module, "__file__", None) or init, init):
        raise RuntimeError(f"a different package named {name!r} is already imported from {module.__file__}")
    if module is None:
        spec = importlib.util.spec_from_file_location(name, init, submodule_search_locations=[ROOT])
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    module.register()
    module._registered_by_load_primer = True
    return module


def configure_cycles_reference(scene, samples: int) -> None:
    """Set Cycles up as Primer's reference: the light paths Primer's integrator follows (direct light only,
    or path tracing with Primer's bounce limits and caustics switches), Primer's sample clamping (none unless
    the file asks), 1-pixel box filter, no denoising, no Filter Glossy, CPU."""
    primer = getattr(scene, "primer", None)
    path = primer is not None and getattr(primer, "integrator", "DIRECT") == "PATH"
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    for bounce in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces"):
        setattr(cycles, bounce, 0)
    # Rays pass transparent surfaces with every Primer integrator, as in Cycles (apart from Max Bounces).
    cycles.transparent_max_bounces = getattr(primer, "transparent_bounces", 8) if primer is not None else 8
    if path:
        cycles.max_bounces = primer.max_bounces
        cycles.diffuse_bounces = primer.diffuse_bounces
        cycles.glossy_bounces = primer.glossy_bounces
        cycles.transmission_bounces = getattr(primer, "transmission_bounces", 12)
        cycles.volume_bounces = getattr(primer, "volume_bounces", 0)
        cycles.min_light_bounces = primer.min_light_bounces
        cycles.caustics_reflective = bool(getattr(primer, "caustics_reflective", True))
        cycles.caustics_refractive = bool(getattr(primer, "caustics_refractive", True))
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    # No bias: Filter Glossy is switched off, and so is sample clamping (on by default in Cycles) unless the
    # file asks Primer for it.
    cycles.blur_glossy = 0.0
    cycles.sample_clamp_direct = float(getattr(primer, "sample_clamp_direct", 0.0))
    cycles.sample_clamp_indirect = float(getattr(primer, "sample_clamp_indirect", 0.0))


def configure_output(scene, path: str) -> None:
    """Write `path` as a 32-bit float EXR, or an 8-bit PNG when it ends in .png."""
    settings = scene.render.image_settings
    if path.lower().endswith(".png"):
        settings.file_format = "PNG"
        settings.color_mode = "RGBA"
        settings.color_depth = "8"
    else:
        settings.file_format = "OPEN_EXR"
        settings.color_mode = "RGBA"
        settings.color_depth = "32"
        settings.exr_codec = "ZIP"
    scene.render.filepath = os.path.abspath(path)
    scene.render.use_file_extension = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0


def render_file(blend: str, out: str, engine: str = "PRIMER", samples: int | None = None,
                percentage: int | None = None, frame: int | None = None, seed: int | None = None) -> float:
    """Render `blend` to `out` and return the wall time of the render in seconds; raise RuntimeError on failure."""
    import bpy

    if not os.path.isfile(blend):
        raise RuntimeError(f"no such .blend file: {blend}")
    primer = load_primer()              # before loading, so the file's engine 'PRIMER' is known
    bpy.ops.wm.open_mainfile(filepath=os.path.abspath(blend))
    scene = bpy.context.scene
    if seed is not None:
        scene.primer.seed = seed
        scene.cycles.seed = seed
    if frame is not None:
        scene.frame_set(frame)
    if percentage is not None:
        scene.render.resolution_percentage = percentage
    if engine == "CYCLES":
        configure_cycles_reference(scene, samples or 256)
    else:
        scene.render.engine = "PRIMER"
        if samples is not None:
            scene.primer.samples = samples
    if scene.camera is None:
        raise RuntimeError(f"{blend} has no camera")
    configure_output(scene, out)
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - start
    if engine == "PRIMER":
        record = sys.modules[primer.__name__ + ".addon.engine"].last_render
        for warning in record.warnings:
            print(f"warning: {warning}", file=sys.stderr)
        if record.error:
            raise RuntimeError(record.error)
    if not os.path.isfile(out):
        raise RuntimeError(f"Blender wrote no image to {out}")
    return seconds


def main(argv=None) -> int:
    """Parse the command line, render, and return the exit code."""
    parser = argparse.ArgumentParser(description="Render a .blend file with Primer (or Cycles) through bpy.")
    parser.add_argument("blend")
    parser.add_argument("-o", "--output", required=True, help="output image (.exr linear float, or .png)")
    parser.add_argument("--samples", type=int, default=None)
    parser.add_argument("--engine", choices=("PRIMER", "CYCLES"), default="PRIMER")
    parser.add_argument("--percentage", type=int, default=None, help="resolution percentage")
    parser.add_argument("--frame", type=int, default=None)
    parser.add_argument("--seed", type=int, default=None, help="sampling seed (Primer and Cycles)")
    args = parser.parse_args(argv)
    try:
        seconds = render_file(args.blend, args.output, args.engine, args.samples, args.percentage, args.frame,
                              args.seed)
    except Exception as error:          # a clear message and a non-zero exit, never a traceback dump
        print(f"render failed: {error}", file=sys.stderr)
        return 1
    finally:
        # bpy 4.2 crashes at exit while a Python RenderEngine or Panel is still registered.
        if "primer" in sys.modules:
            sys.modules["primer"].unregister()
    print(f"{os.path.basename(args.blend)}: {args.engine} rendered {args.output} in {seconds:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
