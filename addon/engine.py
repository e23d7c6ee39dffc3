"""Primer's RenderEngine: Blender calls it, it forwards to plain functions.

F12 and `blender -b ... -E PRIMER -f 1` end up in `PrimerRenderEngine.render`,
which exports the evaluated depsgraph (`addon/export.py`), renders it with
`core.render.render` on worker threads, and writes the passes back, flipped to
Blender's bottom-up rows. Progress and Esc (`test_break`) are handled between
chunks of rays, so the render stops within a fraction of a second.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import export, viewport

log = logging.getLogger("primer")

# Passes that Primer writes besides Combined: Blender name -> (core buffer, channels, chan ids, type).
STANDARD_PASSES = {
    "Depth": ("depth", 1, "Z", "VALUE"),
    "Normal": ("normal", 3, "XYZ", "VECTOR"),
}
DEBUG_PASSES = {
    "Primer Face Normal": ("face_normal", 3, "XYZ", "VECTOR"),
    "Primer NdotL": ("n_dot_l", 1, "X", "VALUE"),
    "Primer Shadow": ("visibility", 1, "X", "VALUE"),
}


@dataclass
class RenderRecord:
    """What the last render did, for scripts (tools/render.py) and tests."""

    error: str = ""
    warnings: list = field(default_factory=list)
    seconds: float = 0.0
    rays: int = 0
    cancelled: bool = False
    export_seconds: float = 0.0     # reading the depsgraph (addon/export.py)
    write_seconds: float = 0.0      # writing the passes into Blender's render result
    stats: object = None            # core.render.RenderStats of the render (BVH, Embree and shading times)


last_render = RenderRecord()


def _pass_values(buffers: dict, name: str, lights: int, size: tuple = (1, 1)) -> np.ndarray:
    """Return the core buffer behind a pass, per-light buffers averaged over the lights: (H, W, c) float32.

    A buffer that was not computed (its pass was switched on after the export) reads as empty: size (H, W).
    """
    values = buffers.get(name)
    if values is None:
        return np.full(tuple(size) + (1 if name in ("depth", "n_dot_l", "visibility") else 3,),
                       1e10 if name == "depth" else 0.0, np.float32)
    if name in ("n_dot_l", "visibility"):
        if lights == 0:
            return np.zeros(values.shape[:2] + (1,), np.float32)
        return values.mean(axis=2, keepdims=True)
    return values


def debug_image(view: str, image: np.ndarray, buffers: dict, lights: int) -> np.ndarray:
    """Return the RGBA picture of a debug view (see properties.DEBUG_VIEWS): (H, W, 4) float32."""
    out = np.zeros_like(image)
    out[..., 3] = 1.0
    if view in ("NORMAL", "FACE_NORMAL"):
        normals = buffers["normal" if view == "NORMAL" else "face_normal"]
        out[..., :3] = np.where(np.any(normals != 0, axis=2, keepdims=True), 0.5 * (normals + 1.0), 0.0)
    elif view == "DEPTH":
        depth = buffers["depth"][..., 0]
        hit = depth < 1e9
        if hit.any():
            near, far = depth[hit].min(), depth[hit].max()
            shade = np.where(hit, 1.0 - (depth - near) / max(far - near, 1e-30), 0.0)
            out[..., :3] = shade[..., None]
    else:
        out[..., :3] = _pass_values(buffers, "n_dot_l" if view == "N_DOT_L" else "visibility", lights,
                                    image.shape[:2])
    return out


def write_result(engine, exported: export.Export, image: np.ndarray, buffers: dict, lights: int, debug_view: str):
    """Write Combined and the enabled passes for the rendered rectangle, rows flipped to bottom-up."""
    width, height = exported.full_size
    x, y, w, h = exported.border
    rows = slice(height - (y + h), height - y)
    cols = slice(x, x + w)
    if debug_view != "NONE":
        image = debug_image(debug_view, image, buffers, lights)

    def block(values: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(values[rows, cols][::-1], dtype=np.float32).reshape(w * h, -1)

    def fill(render_pass, values: np.ndarray) -> None:
        # foreach_set copies the buffer in one go; assigning an array converts it value by value.
        try:
            render_pass.rect.foreach_set(values.ravel())
        except (AttributeError, TypeError, RuntimeError):
            render_pass.rect = values

    # Blender's render result is the border rectangle itself: its coordinates start at the border's corner.
    result = engine.begin_result(0, 0, w, h)
    try:
        layer = result.layers[0]
        written = set()
        for render_pass in layer.passes:
            name = render_pass.name
            if name in written:
                continue
            if name == "Combined":
                fill(render_pass, block(image))
            elif name in STANDARD_PASSES or name in DEBUG_PASSES:
                buffer = (STANDARD_PASSES.get(name) or DEBUG_PASSES[name])[0]
                fill(render_pass, block(_pass_values(buffers, buffer, lights, image.shape[:2])))
            written.add(name)
    finally:
        engine.end_result(result)


def render_frame(engine, depsgraph) -> RenderRecord:
    """Export, render and write one frame; report problems in Blender instead of raising."""
    from ..core import render as core_render

    record = RenderRecord()
    start = time.perf_counter()
    scene = depsgraph.scene
    try:
        engine.update_stats("", "Primer | exporting scene")
        exported = export.export_scene(depsgraph, engine.camera_override, engine.test_break)
        record.export_seconds = time.perf_counter() - start
        record.warnings = list(exported.warnings)
        if engine.test_break():
            record.cancelled = True
            return record

        def progress(fraction, stats):
            engine.update_progress(fraction)
            engine.update_stats("", f"Primer | {stats.rays / 1e6:.2f} M rays | {stats.seconds:.1f} s "
                                    f"| {100 * fraction:.0f}%")

        engine.update_stats("", "Primer | building BVH")
        result = core_render.render(exported.scene, exported.settings, progress=progress, cancel=engine.test_break)
        record.warnings += [w for w in result.stats.warnings if w not in record.warnings]
        record.rays = result.stats.rays
        record.cancelled = result.cancelled
        record.stats = result.stats
        written = time.perf_counter()
        write_result(engine, exported, result.image, result.aux, result.lights, scene.primer.debug_view)
        record.write_seconds = time.perf_counter() - written
    except KeyboardInterrupt:            # Ctrl+C in a terminal: stop like Esc
        record.cancelled = True
    except export.ExportError as error:
        record.error = str(error)
    except ImportError as error:
        record.error = f"a library Primer needs is missing ({error}); reinstall the Primer extension"
    except Exception as error:          # never let an exception escape into Blender's render thread
        log.exception("Primer render failed")
        record.error = f"render failed: {error}"
    finally:
        record.seconds = time.perf_counter() - start
    for warning in record.warnings:
        log.warning(warning)
        engine.report({"WARNING"}, f"Primer: {warning}")
    if record.error:
        log.error(record.error)
        engine.report({"ERROR"}, f"Primer: {record.error}")
    else:
        engine.update_stats("", f"Primer | {record.rays / 1e6:.2f} M rays | {record.seconds:.2f} s"
                                + (" | cancelled" if record.cancelled else ""))
    return record


class PrimerRenderEngine(bpy.types.RenderEngine):
    """Primer: an educational direct-lighting ray tracer."""

    bl_idname = "PRIMER"
    bl_label = "Primer"
    bl_use_preview = False
    bl_use_shading_nodes_custom = False     # keep Blender's material nodes
    bl_use_postprocess = True

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)

    def __del__(self):
        """Stop the viewport's worker thread, if this engine drew a viewport."""
        try:
            viewport.free(self)
        except ReferenceError:          # the Blender side is already gone
            pass
        parent = getattr(super(), "__del__", None)
        if parent is not None:
            parent()

    def render(self, depsgraph):
        """Render the frame (F12, animation, or `blender -b -f`)."""
        global last_render
        last_render = render_frame(self, depsgraph)

    def view_update(self, context, depsgraph):
        """Viewport: re-export only what the depsgraph's updates name (addon/viewport.py)."""
        viewport.view_update(self, context, depsgraph)

    def view_draw(self, context, depsgraph):
        """Viewport: follow the view, draw the newest progressive pass, show the frame time."""
        viewport.view_draw(self, context, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        """Declare the passes Primer writes, so the compositor and the image editor list them."""
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if renderlayer.use_pass_z:
            self.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")
        if renderlayer.use_pass_normal:
            self.register_pass(scene, renderlayer, "Normal", 3, "XYZ", "VECTOR")
        if scene.primer.debug_passes:
            for name, (_, channels, chan_id, kind) in DEBUG_PASSES.items():
                self.register_pass(scene, renderlayer, name, channels, chan_id, kind)


classes = (PrimerRenderEngine,)
