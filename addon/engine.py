"""Primer's RenderEngine: Blender calls it, it forwards to plain functions.

F12 and `blender -b ... -E PRIMER -f 1` end up in `PrimerRenderEngine.render`,
which exports the evaluated depsgraph (`addon/export.py`), renders it with
`core.render.render` on worker threads, and writes the passes back, flipped to
Blender's bottom-up rows. Progress and Esc (`test_break`) are handled between
chunks of rays, so the render stops within a fraction of a second.
"""
from __future__ import annotations

import contextlib
import logging
import os
import signal
import tempfile
import threading
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..core.integrators import catcher, cryptomatte
from ..core.integrators import passes as passes_
from ..core.integrators import debug
from . import compositor, export, lightgroups, motion, viewport

log = logging.getLogger("primer")

# Passes that Primer writes besides Combined: Blender name -> (core buffer, channels, chan ids, type).
# Both come from the first-hit passes (core/integrators/passes.py: z_depth, average_normal), so the compiled
# kernels still render the image.
STANDARD_PASSES = {
    "Depth": ("z_depth", 1, "Z", "VALUE"),
    "Normal": ("average_normal", 3, "XYZ", "VECTOR"),
}
# The compositor's Denoise node reads these (Cycles' names and channels); written with Render > Denoise.
DENOISING_PASSES = {
    "Denoising Albedo": ("denoising_albedo", 3, "RGB", "COLOR"),
    "Denoising Normal": ("denoising_normal", 3, "XYZ", "VECTOR"),
}
# Cycles' Shadow Catcher pass (View Layer > Passes > Light > Shadow Catcher, core/integrators/catcher.py).
SHADOW_CATCHER_PASS = "Shadow Catcher"
# Cycles' first-hit passes (core/integrators/passes.py) and light passes: core buffer -> (view layer toggle (`toggled`),
# Blender 5 name, the name before Blender 5, channels, chan ids, type); written with the view layer's toggle, as
# Cycles does.
CYCLES_PASSES = {
    "position": ("use_pass_position", "Position", "Position", 3, "XYZ", "VECTOR"),
    "uv": ("use_pass_uv", "UV", "UV", 3, "UVA", "VECTOR"),
    "object_index": ("use_pass_object_index", "Object Index", "IndexOB", 1, "X", "VALUE"),
    "material_index": ("use_pass_material_index", "Material Index", "IndexMA", 1, "X", "VALUE"),
    "diffuse_color": ("use_pass_diffuse_color", "Diffuse Color", "DiffCol", 3, "RGB", "COLOR"),
    "glossy_color": ("use_pass_glossy_color", "Glossy Color", "GlossCol", 3, "RGB", "COLOR"),
    "transmission_color": ("use_pass_transmission_color", "Transmission Color", "TransCol", 3, "RGB", "COLOR"),
    "emission": ("use_pass_emit", "Emission", "Emit", 3, "RGB", "COLOR"),
    "environment": ("use_pass_environment", "Environment", "Env", 3, "RGB", "COLOR"),
    "ambient_occlusion": ("use_pass_ambient_occlusion", "Ambient Occlusion", "AO", 3, "RGB", "COLOR"),
    "mist": ("use_pass_mist", "Mist", "Mist", 1, "Z", "VALUE"),
    "vector": ("use_pass_vector", "Vector", "Vector", 4, "XYZW", "VECTOR"),
    # The light passes come from the integrator instead (core/integrators/lightpasses.py), each divided by its
    # colour pass as Cycles stores them.
    "diffuse_direct": ("use_pass_diffuse_direct", "Diffuse Direct", "DiffDir", 3, "RGB", "COLOR"),
    "diffuse_indirect": ("use_pass_diffuse_indirect", "Diffuse Indirect", "DiffInd", 3, "RGB", "COLOR"),
    "glossy_direct": ("use_pass_glossy_direct", "Glossy Direct", "GlossDir", 3, "RGB", "COLOR"),
    "glossy_indirect": ("use_pass_glossy_indirect", "Glossy Indirect", "GlossInd", 3, "RGB", "COLOR"),
    "transmission_direct": ("use_pass_transmission_direct", "Transmission Direct", "TransDir", 3, "RGB", "COLOR"),
    "transmission_indirect": ("use_pass_transmission_indirect", "Transmission Indirect", "TransInd", 3, "RGB",
                              "COLOR"),
    # (the volume ones, undivided as in Cycles, are toggled in Cycles' own settings of the view layer)
    "volume_direct": ("cycles.use_pass_volume_direct", "Volume Direct", "VolumeDir", 3, "RGB", "COLOR"),
    "volume_indirect": ("cycles.use_pass_volume_indirect", "Volume Indirect", "VolumeInd", 3, "RGB", "COLOR"),
}


def toggled(view_layer, toggle: str) -> bool:
    """Whether the pass toggle `toggle` (a property of the view layer, or "cycles.<property>" of its Cycles
    settings) is on in `view_layer`."""
    owner, _, name = toggle.rpartition(".")
    return bool(getattr(getattr(view_layer, owner, None) if owner else view_layer, name, False))


def cycles_pass_name(buffer: str, version: tuple = None) -> str:
    """Return the name Cycles gives the pass of core buffer `buffer` in Blender `version` (default: this one)."""
    version = tuple(bpy.app.version) if version is None else tuple(version)
    return CYCLES_PASSES[buffer][1 if version >= (5, 0, 0) else 2]


# Shader AOVs (View Layer > Passes > Shader AOV; core/integrators/passes.py): type -> (channels, chan ids, type) of the
# pass named as the AOV, as Cycles registers it; its core buffer is passes.AOV_PREFIX + the name.
AOV_PASS_KINDS = {"COLOR": (4, "RGBA", "COLOR"), "VALUE": (1, "X", "VALUE")}

# Cryptomatte (core/integrators/cryptomatte.py): core buffer -> (view layer toggle, the passes' name prefix).
CRYPTO_PASSES = {
    "crypto_object": ("use_pass_cryptomatte_object", "CryptoObject"),
    "crypto_material": ("use_pass_cryptomatte_material", "CryptoMaterial"),
    "crypto_asset": ("use_pass_cryptomatte_asset", "CryptoAsset"),
}


def requested_passes(view_layer) -> tuple:
    """Return the render passes (core buffers: first-hit and light passes) whose toggles are on in the view layer,
    and no more."""
    if view_layer is None:
        return ()
    toggles = {"z_depth": "use_pass_z", "average_normal": "use_pass_normal"}
    toggles.update({buffer: toggle for buffer, (toggle, *_) in CYCLES_PASSES.items()})
    toggles.update({buffer: toggle for buffer, (toggle, _) in CRYPTO_PASSES.items()})
    return tuple(buffer for buffer, toggle in toggles.items() if toggled(view_layer, toggle))


def crypto_pass_names(buffer: str, depth: int) -> list:
    """Return the RGBA passes holding the Cryptomatte buffer `buffer` with `depth` ranks, as Cycles names them
    ("CryptoObject00", "CryptoObject01", ...)."""
    prefix = CRYPTO_PASSES[buffer][1]
    return [f"{prefix}{i:02d}" for i in range(cryptomatte.pass_count(depth))]


def add_crypto_metadata(result, exported: export.Export, view_layer: str) -> None:
    """Store each Cryptomatte's manifest in the render result's metadata, as Cycles does, so that the
    compositor's Cryptomatte node and other compositors find the names (core/integrators/cryptomatte.py)."""
    names = cryptomatte.names_of(exported.scene)
    for buffer in exported.settings.passes:
        if buffer in CRYPTO_PASSES:
            kind = buffer.split("_", 1)[1]
            for key, value in cryptomatte.metadata(view_layer, kind, names[kind]).items():
                result.stamp_data_add_field(key, value)


# One pass per debug view (README, "Debug views"); the shading normal and depth views match Normal and Depth.
DEBUG_PASSES = {
    "Primer Face Normal": ("face_normal", 3, "XYZ", "VECTOR"),
    "Primer Normal Angle": ("normal_angle", 1, "X", "VALUE"),        # degrees
    "Primer Barycentric": ("barycentric", 3, "RGB", "COLOR"),
    "Primer Hit Distance": ("hit_distance", 1, "X", "VALUE"),
    "Primer NdotL": ("n_dot_l", 1, "X", "VALUE"),
    "Primer Shadow": ("visibility", 1, "X", "VALUE"),
    "Primer Acne": ("acne", 1, "X", "VALUE"),                        # fraction of shadow rays
    "Primer Rays": ("rays", 1, "X", "VALUE"),                        # rays per pixel
    "Primer Time": ("time", 1, "X", "VALUE"),                        # seconds per pixel
    "Primer Shutter Time": ("shutter_time", 1, "X", "VALUE"),        # 0 the shutter opens, 1 it closes
}
# The core buffer each debug view shows (properties.DEBUG_VIEWS).
VIEW_BUFFERS = {
    "NORMAL": "normal", "FACE_NORMAL": "face_normal", "NORMAL_ANGLE": "normal_angle", "BARYCENTRIC": "barycentric",
    "HIT_DISTANCE": "hit_distance", "DEPTH": "depth", "N_DOT_L": "n_dot_l", "VISIBILITY": "visibility",
    "ACNE": "acne", "RAYS": "rays", "TIME": "time", "SHUTTER_TIME": "shutter_time",
}
# Buffers with one channel per light; their passes show the chosen light, or the mean over all lights.
PER_LIGHT = ("n_dot_l", "visibility")


def requested_buffers(props, view_layer) -> tuple:
    """Return the core buffers that the enabled passes and the debug view need, and no more."""
    wanted = set()
    if props.debug_passes:
        wanted.update(buffer for buffer, *_ in DEBUG_PASSES.values())
    if props.debug_view != "NONE":
        wanted.add(VIEW_BUFFERS[props.debug_view])
    return tuple(sorted(wanted))


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
    frame: int = 0                  # the scene frame rendered
    meshes_read: list = field(default_factory=list)    # objects whose meshes were read (the others kept)


last_render = RenderRecord()


def light_channels(light_names: list, chosen: str) -> list:
    """Return the per-light channels to show: those of the light named `chosen`, or all when it is ""."""
    if not chosen:
        return list(range(len(light_names)))
    return [i for i, name in enumerate(light_names) if name == chosen]


def _pass_values(buffers: dict, name: str, channels: list) -> np.ndarray:
    """Return the core buffer behind a pass, per-light buffers averaged over `channels`: (H, W, c) float32."""
    values = buffers[name]
    if name in PER_LIGHT:
        if not channels:
            return np.zeros(values.shape[:2] + (1,), np.float32)
        return values[..., channels].mean(axis=2, keepdims=True)
    return values


def _heat_of_maximum(values: np.ndarray) -> np.ndarray:
    """Return heat colours of values scaled by their maximum (0 stays black): (H, W) -> (H, W, 3)."""
    top = float(values.max()) if values.size else 0.0
    return debug.heat(values / top if top > 0 else np.zeros_like(values))


def _near_to_far(distance: np.ndarray) -> np.ndarray:
    """Return grey levels 1 at the nearest hit to 0 at the farthest, 0 where nothing was hit: (H, W)."""
    hit = distance < 1e9
    if not hit.any():
        return np.zeros_like(distance)
    near, far = distance[hit].min(), distance[hit].max()
    if far - near <= 1e-6 * far:                    # all hits equally near (to float precision): white
        return hit.astype(distance.dtype)
    return np.where(hit, 1.0 - (distance - near) / (far - near), 0.0)


def debug_image(view: str, image: np.ndarray, buffers: dict, channels: list) -> np.ndarray:
    """Return the RGBA picture of a debug view (see properties.DEBUG_VIEWS): (H, W, 4) float32.

    channels: the lights (channels of the per-light buffers) whose N.L and shadow rays are shown.
    """
    out = np.zeros_like(image)
    out[..., 3] = 1.0
    values = _pass_values(buffers, VIEW_BUFFERS[view], channels)
    if view in ("NORMAL", "FACE_NORMAL"):
        out[..., :3] = np.where(np.any(values != 0, axis=2, keepdims=True), 0.5 * (values + 1.0), 0.0)
    elif view == "BARYCENTRIC":
        out[..., :3] = values
    elif view in ("DEPTH", "HIT_DISTANCE"):
        out[..., :3] = _near_to_far(values[..., 0])[..., None]
    elif view == "NORMAL_ANGLE":
        out[..., :3] = debug.heat(values[..., 0] / debug.NORMAL_ANGLE_FULL_SCALE)
    elif view == "ACNE":
        out[..., :3] = debug.heat(values[..., 0])
    elif view in ("RAYS", "TIME"):
        out[..., :3] = _heat_of_maximum(values[..., 0])
    elif view == "N_DOT_L":             # grey levels; blue where N.L < 0 (Clamp N.L off)
        out[..., :3] = debug.signed_grey(values[..., 0])
    else:                               # VISIBILITY, SHUTTER_TIME: grey levels
        out[..., :3] = values
    return out


def write_result(engine, exported: export.Export, image: np.ndarray, buffers: dict, channels: list,
                 debug_view: str):
    """Write Combined and the enabled passes for the rendered rectangle, rows flipped to bottom-up.

    channels: the lights whose per-light buffers (N.L, shadow rays) the passes and debug view show.
    """
    width, height = exported.full_size
    x, y, w, h = exported.border
    rows = slice(height - (y + h), height - y)
    cols = slice(x, x + w)
    if debug_view != "NONE":
        image = debug_image(debug_view, image, buffers, channels)

    def block(values: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(values[rows, cols][::-1], dtype=np.float32).reshape(w * h, -1)

    def fill(render_pass, values: np.ndarray) -> None:
        # foreach_set copies the buffer in one go; assigning an array converts it value by value.
        try:
            render_pass.rect.foreach_set(values.ravel())
        except (AttributeError, TypeError, RuntimeError):
            render_pass.rect = values

    # Blender's render result is the border rectangle itself: its coordinates start at the border's corner.
    crypto_names = {name: (buffer, 4 * i) for buffer in CRYPTO_PASSES if buffer in buffers
                    for i, name in enumerate(crypto_pass_names(buffer, exported.settings.cryptomatte_depth))}
    result = engine.begin_result(0, 0, w, h)
    layer_name = ""
    try:
        layer = result.layers[0]
        layer_name = layer.name
        written = set()
        cycles_names = {cycles_pass_name(buffer): buffer for buffer in CYCLES_PASSES}
        for render_pass in layer.passes:
            name = render_pass.name
            if name in written:
                continue
            if name == "Combined":
                fill(render_pass, block(image))
            elif name in cycles_names and cycles_names[name] in buffers:
                fill(render_pass, block(buffers[cycles_names[name]]))
            elif passes_.AOV_PREFIX + name in buffers:
                fill(render_pass, block(buffers[passes_.AOV_PREFIX + name]))
            elif name in crypto_names:
                buffer, first = crypto_names[name]
                fill(render_pass, block(buffers[buffer][..., first:first + 4]))
            elif name == SHADOW_CATCHER_PASS and catcher.PASS_BUFFER in buffers:
                fill(render_pass, block(buffers[catcher.PASS_BUFFER]))
            elif name.startswith(lightgroups.PASS_PREFIX):
                group = lightgroups.BUFFER_PREFIX + name[len(lightgroups.PASS_PREFIX):]
                fill(render_pass, block(buffers[group] if group in buffers else np.zeros((height, width, 3))))
            elif name in STANDARD_PASSES or name in DEBUG_PASSES or name in DENOISING_PASSES:
                buffer = (STANDARD_PASSES.get(name) or DEBUG_PASSES.get(name) or DENOISING_PASSES[name])[0]
                if buffer in buffers:
                    fill(render_pass, block(_pass_values(buffers, buffer, channels)))
            written.add(name)
    finally:
        engine.end_result(result)
    if crypto_names:
        # On the whole frame's result, as Cycles does: what a rectangle's result holds is not kept.
        add_crypto_metadata(engine.get_result(), exported, layer_name)


@contextlib.contextmanager
def _ctrl_c_cancels():
    """Within the block, Ctrl+C (SIGINT) sets the yielded event instead of raising KeyboardInterrupt.

    The render polls the event between chunks, as it polls Esc. A KeyboardInterrupt raised at an
    arbitrary point could leave a lock of the thread pool taken and hang the render. Only the main
    thread may set signal handlers; elsewhere (Blender's UI renders on a thread) nothing changes.
    """
    interrupted = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield interrupted
        return
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, lambda number, frame: interrupted.set())
    try:
        yield interrupted
    finally:
        signal.signal(signal.SIGINT, previous)


def _writable_folder(folder: str) -> str:
    """Return "" when a file can be made in `folder` (created if missing, as Blender does), else why not."""
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as error:
        return error.strerror or str(error)
    return ""


def empty_range_note(start: int, end: int) -> str:
    """Return the message for a frame range with End before Start (`blender -b -s 5 -e 2 -a`), else ""."""
    if end >= start:
        return ""
    return (f"no frame rendered: the frame range is empty (End {end} is before Start {start}); set -s/-e "
            "on the command line, or Output > Frame Start and End")


def animation_notes(scene, is_animation: bool) -> list:
    """Return warnings about an animation render's output path (none for a still render).

    Blender stops an animation at the first frame it cannot save; this is said before the frame is
    rendered, and the frame is rendered all the same (it stays in the Render Result).
    """
    if not is_animation:
        return []
    path = scene.render.frame_path(frame=scene.frame_current)
    why = _writable_folder(os.path.dirname(path) or ".")
    if not why:
        return []
    return [f"cannot write frame {scene.frame_current} to '{path}' ({why}): Blender will stop after this "
            "frame, which stays in the Render Result (Image > Save As); set Output > Path to a writable folder"]


# Frames Primer rendered since Blender's last render_init: an animation that ends with none had an
# empty frame range (Blender renders no frame then, and says nothing).
frames_since_init = 0


@bpy.app.handlers.persistent
def on_render_init(scene, *args):
    """bpy handler (render_init): start counting the frames of this render job."""
    global frames_since_init
    frames_since_init = 0


@bpy.app.handlers.persistent
def on_render_end(scene, *args):
    """bpy handler (render_complete, render_cancel): say why a Primer render job rendered no frame."""
    if frames_since_init == 0 and scene.render.engine == PrimerRenderEngine.bl_idname:
        note = empty_range_note(scene.frame_start, scene.frame_end)
        if note:
            log.error("Primer: %s", note)
            print(f"Primer: {note}", flush=True)


HANDLERS = (("render_init", on_render_init), ("render_complete", on_render_end), ("render_cancel", on_render_end))


def render_frame(engine, depsgraph) -> RenderRecord:
    """Export, render and write one frame; report problems in Blender instead of raising."""
    with _ctrl_c_cancels() as interrupted:
        return _render_frame(engine, depsgraph, lambda: interrupted.is_set() or engine.test_break())


# Seconds without a render before the renders' warm heap goes back to the system (core/memory.py),
# and how often the timer looks. Renders run on Blender's render thread and the viewport's worker,
# where bpy.app.timers must not be touched; one timer, registered with the engine on the main
# thread, does it. Blender runs timers only while its event loop runs; in background mode the
# process ends instead.
RELEASE_AFTER = 5.0
RELEASE_CHECK = 2.0


def release_memory_when_idle():
    """bpy timer (persistent): release the warm heap once no render has run for RELEASE_AFTER
    seconds (core/memory.py; never while a render runs); look again in RELEASE_CHECK seconds."""
    from ..core import memory

    memory.release_if_idle(RELEASE_AFTER)
    return RELEASE_CHECK


def _render_frame(engine, depsgraph, cancelled) -> RenderRecord:
    """render_frame's work; cancelled() says whether Esc or Ctrl+C asked to stop."""
    from ..core import render as core_render

    record = RenderRecord()
    start = time.perf_counter()
    scene = depsgraph.scene
    record.frame = scene.frame_current
    try:
        # Persistent Data: Blender keeps this engine and its depsgraph from frame to frame, and the meshes
        # are kept with them; otherwise every frame starts from a new depsgraph and reads every mesh.
        mesh_cache = getattr(engine, "mesh_cache", None) if scene.render.use_persistent_data else None
        engine.update_stats("", "Primer | exporting scene")
        exported = export.export_scene(depsgraph, engine.camera_override, cancelled,
                                       requested_buffers(scene.primer, depsgraph.view_layer),
                                       requested_passes(depsgraph.view_layer), mesh_cache)
        # Motion blur: the camera and the moving objects read over the shutter (the scene moved there and back).
        camera_object = engine.camera_override or scene.camera
        exported.scene.camera = motion.sample_shutter(engine, depsgraph, camera_object, exported.scene.camera,
                                                      export.export_camera, exported.warnings,
                                                      exported.scene.instances, exported.instance_keys,
                                                      exported.scene.meshes)
        if "vector" in exported.settings.passes and not motion.blurs(scene, depsgraph.view_layer):
            # The Vector pass: the camera and the objects at the frames before and after (Cycles' motion pass).
            exported.scene.vector_cameras = motion.sample_vector_frames(
                engine, depsgraph, camera_object, exported.scene.camera, export.export_camera, exported.warnings,
                exported.scene.instances, exported.instance_keys)
            # (where the camera sees the world: its direction's motion from Blender 5.2's Cycles, before it nothing)
            exported.settings.world_vector = tuple(bpy.app.version[:2]) >= (5, 2)
        record.export_seconds = time.perf_counter() - start
        record.meshes_read = exported.meshes_read
        record.warnings = animation_notes(scene, bool(getattr(engine, "is_animation", False)))
        record.warnings += exported.warnings
        if scene.primer.use_denoising:
            record.warnings += compositor.problems(getattr(scene, "original", scene))
        if cancelled():
            record.cancelled = True
            return record

        def progress(fraction, stats):
            engine.update_progress(fraction)
            engine.update_stats("", f"Primer | {stats.rays / 1e6:.2f} M rays | {stats.seconds:.1f} s "
                                    f"| {100 * fraction:.0f}%")

        engine.update_stats("", "Primer | building BVH")
        # The heap stays warm for a render that follows (an animation's next frame, F12 again), and
        # goes back to the system a few seconds after the last one (release_memory_when_idle).
        result = core_render.render(exported.scene, exported.settings, progress=progress, cancel=cancelled,
                                    keep_memory=True)
        record.warnings += [w for w in result.stats.warnings if w not in record.warnings]
        record.rays = result.stats.rays
        log.info("Primer rendered %.2f M rays in %.2f s, %s kernels", result.stats.rays / 1e6,
                 result.stats.seconds, result.stats.kernels)
        record.cancelled = result.cancelled
        record.stats = result.stats
        buffers = result.aux
        written = time.perf_counter()
        chosen = scene.primer.debug_light
        channels = light_channels(result.light_names, chosen.name if chosen is not None else "")
        write_result(engine, exported, result.image, buffers, channels, scene.primer.debug_view)
        record.write_seconds = time.perf_counter() - written
    except KeyboardInterrupt:            # Ctrl+C before the handler was set: stop like Esc
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
        self.mesh_cache = export.MeshCache()    # used with Persistent Data, when Blender keeps this engine

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
        global last_render, frames_since_init
        frames_since_init += 1
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
        for buffer, (toggle, _, _, channels, chan_id, kind) in CYCLES_PASSES.items():
            if toggled(renderlayer, toggle):
                self.register_pass(scene, renderlayer, cycles_pass_name(buffer), channels, chan_id, kind)
        for name, kind in export.shader_aovs(renderlayer):     # (Cycles' names and channels: the AOV's own name)
            self.register_pass(scene, renderlayer, name, *AOV_PASS_KINDS[kind])
        for group in lightgroups.group_names(renderlayer):
            self.register_pass(scene, renderlayer, lightgroups.PASS_PREFIX + group, 3, "RGB", "COLOR")
        if export.shadow_catcher_pass(renderlayer):
            self.register_pass(scene, renderlayer, SHADOW_CATCHER_PASS, 3, "RGB", "COLOR")
        for buffer, (toggle, _) in CRYPTO_PASSES.items():
            if getattr(renderlayer, toggle, False):
                for name in crypto_pass_names(buffer, renderlayer.pass_cryptomatte_depth):
                    self.register_pass(scene, renderlayer, name, 4, "rgba", "COLOR")   # lower case, as Cycles
        if scene.primer.use_denoising:
            for name, (_, channels, chan_id, kind) in DENOISING_PASSES.items():
                self.register_pass(scene, renderlayer, name, channels, chan_id, kind)
        if scene.primer.debug_passes:
            for name, (_, channels, chan_id, kind) in DEBUG_PASSES.items():
                self.register_pass(scene, renderlayer, name, channels, chan_id, kind)


classes = (PrimerRenderEngine,)
