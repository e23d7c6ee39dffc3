"""Viewport rendering: Primer in the 3D viewport's Rendered shading mode.

Blender calls two methods of the RenderEngine for the viewport:

* `view_update(context, depsgraph)` after something changed in the scene: the session's
  SceneCache (addon/scene_cache.py) re-exports only what `depsgraph.updates` names, and the
  samples start again;
* `view_draw(context, depsgraph)` whenever the viewport is redrawn (also while the user flies
  around): the view's camera is taken from the region's matrices (core/camera/view.py); if it moved, the
  samples start again, and the newest image is drawn.

Rendering never happens in those calls. A worker thread renders progressive passes
(core/render/progressive.py): a coarse one of one ray per block of pixels within a frame or two, then
full-resolution passes that are averaged. A change cancels the pass in flight through core.render's
`cancel` callback. The frame time of each pass is shown in the viewport's corner, as in the
lecture's framerate slide: "measure the time it takes to render a frame".
"""
from __future__ import annotations

import dataclasses
import logging
import threading
import time
from dataclasses import dataclass
from typing import Iterator, Optional

import bpy
import numpy as np

from . import export
from .scene_cache import SceneCache, SyncReport
from ..core.render import progressive
from ..core.camera import view as view_
from ..core.scene import RenderSettings

log = logging.getLogger("primer")

COARSE_SECONDS = 0.05       # the coarse pass's time budget: well inside the 100 ms an edit may take


def viewport_settings(scene) -> RenderSettings:
    """Return the render settings the viewport uses: the scene's, with no border, no auxiliary buffers and no
    denoising features (the viewport does not composite).

    No adaptive sampling: progressive refinement is the viewport's own schedule (core/render/progressive.py),
    and it weighs every pass by its sample count, which holds only if every pixel got them all.
    """
    settings = export.render_settings(scene, 1, 1, (0, 0, 1, 1))
    return dataclasses.replace(settings, samples=int(scene.primer.viewport_samples), region=None,
                               pixel_aspect=(1.0, 1.0), aux=(), adaptive=False, denoising_features=False)


def view_from_region(region_data, width: int, height: int, depsgraph=None) -> progressive.View:
    """Return the View of a 3D viewport region (RegionView3D `region_data`, `width` x `height` pixels).

    Perspective, orthographic and camera views come from the region's matrices. In camera view a
    fisheye camera is rendered with its own projection inside the camera frame that Blender draws.
    """
    view_matrix = np.array(region_data.view_matrix, np.float64)
    window_matrix = np.array(region_data.window_matrix, np.float64)
    scene = depsgraph.scene_eval if depsgraph is not None else None
    camera_object = scene.camera if scene is not None else None
    if region_data.view_perspective == "CAMERA" and camera_object is not None and camera_object.type == "CAMERA" \
            and camera_object.data.type == "PANO":
        camera_eval = camera_object.evaluated_get(depsgraph)
        frame = [camera_eval.matrix_world @ corner for corner in camera_eval.data.view_frame(scene=scene)]
        film = view_.frame_rectangle(view_matrix, window_matrix, width, height, np.array(frame, np.float64))
        aspect = (float(scene.render.pixel_aspect_x), float(scene.render.pixel_aspect_y))
        return progressive.View(export.export_camera(camera_eval), aspect, width, height, film)
    return progressive.region_view(view_matrix, window_matrix, width, height)


@dataclass
class Frame:
    """The newest viewport image and how it was made (for drawing and the frame-time display).

    image: (H, W, 4) float32 scene-linear premultiplied RGBA, row 0 at the top
    """

    image: np.ndarray
    version: int                # grows with every published pass
    samples: int                # samples per pixel in the image (0 for the coarse pass)
    target: int                 # samples the view will reach
    block: int                  # block size of the pass (1: full resolution)
    pass_seconds: float         # wall time of the pass that made it
    since_change: float         # seconds from the change (or view move) to this image


@dataclass
class _Job:
    """Everything one view's passes read; immutable once made, so a new job never disturbs a running one."""

    generation: int
    scene: object
    geometry: object
    settings: RenderSettings
    view: progressive.View
    started: float


class ViewportSession:
    """A viewport's scene cache, view, worker thread and newest image."""

    def __init__(self, coarse_seconds: float = COARSE_SECONDS):
        self.cache = SceneCache()
        self.settings: Optional[RenderSettings] = None
        self.view: Optional[progressive.View] = None
        self.coarse_seconds = coarse_seconds
        self.timer = progressive.PassTimer()
        self.error = ""
        self.last_sync: Optional[SyncReport] = None
        self._lock = threading.Condition()
        self._generation = 0
        self._job: Optional[_Job] = None
        self._finished = 0            # generation of the last job that ran to the end
        self._frame: Optional[Frame] = None
        self._version = 0
        self._thread: Optional[threading.Thread] = None
        self._stopping = False

    # --- from Blender's main thread ---------------------------------------------------------

    def update(self, depsgraph, start: bool = True) -> SyncReport:
        """Re-export what the depsgraph's updates name; restart the samples if the image may change."""
        origin = self.view.camera.position if self.view is not None else None
        try:
            report = self.cache.sync(depsgraph, origin)
            settings = viewport_settings(depsgraph.scene_eval)
            self.error = ""
        except export.ExportError as error:
            self.error = str(error)
            log.error("Primer viewport: %s", error)
            return SyncReport()
        except Exception as error:          # a half-updated cache cannot be trusted: export afresh next time
            log.exception("Primer viewport: the scene update failed")
            self.error = f"scene update failed: {error}"
            self.cache = SceneCache()
            return SyncReport()
        self.last_sync = report
        if report.changed or settings != self.settings:
            self.settings = settings
            self.restart(start)
        return report

    def set_view(self, view: progressive.View, start: bool = True) -> bool:
        """Use `view` from now on; restart the samples (not the export) when it differs. Return whether it did."""
        if self.view is not None and self.view.signature() == view.signature():
            return False
        self.view = view
        self.restart(start)
        return True

    def restart(self, start: bool = True) -> None:
        """Cancel the pass in flight and queue the current scene and view; `start` the worker thread if needed."""
        with self._lock:
            self._generation += 1
            if self.cache.scene is None or self.view is None or self.settings is None:
                self._job = None
                return
            self._job = _Job(self._generation, self.cache.scene, self.cache.geometry, self.settings, self.view,
                             time.perf_counter())
            self._lock.notify_all()
        if start and (self._thread is None or not self._thread.is_alive()):
            self._thread = threading.Thread(target=self._loop, name="primer-viewport", daemon=True)
            self._thread.start()

    def latest(self) -> Optional[Frame]:
        """Return the newest image, or None before the first pass finished."""
        with self._lock:
            return self._frame

    @property
    def refining(self) -> bool:
        """Whether passes are still to come for the current view."""
        with self._lock:
            return self._job is not None and self._finished != self._job.generation and not self.error

    def status_text(self) -> str:
        """Return the line shown in the viewport: samples, the frame time of the last pass, and notes."""
        if self.error:
            return f"Primer | {self.error}"
        frame = self.latest()
        if frame is None:
            return "Primer | exporting"
        ms = 1e3 * frame.pass_seconds
        fps = 1.0 / frame.pass_seconds if frame.pass_seconds > 0 else float("inf")
        kind = f"coarse 1/{frame.block}" if frame.block > 1 else f"{frame.samples}/{frame.target} samples"
        text = f"Primer | {kind} | frame time {ms:.0f} ms ({fps:.1f} fps)"
        if self.cache.warnings:
            text += f" | {len(self.cache.warnings)} warning(s), see the console"
        return text

    def stop(self) -> None:
        """Cancel the pass in flight and end the worker thread."""
        with self._lock:
            self._stopping = True
            self._generation += 1
            self._lock.notify_all()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)

    # --- the passes (the worker thread; tests call run() directly) -------------------------

    def run(self, job: Optional[_Job] = None) -> Iterator[Frame]:
        """Render the passes of `job` (default: the queued one) in this thread, yielding each new Frame.

        Stops early, yielding nothing more, once another change restarts the session.
        """
        job = job or self._job
        if job is None:
            return
        settings = job.settings
        block = progressive.coarse_block(self.timer.seconds_per_sample, job.view.film[2] * job.view.film[3],
                                         self.coarse_seconds)
        accumulator = progressive.Accumulator()

        def cancelled() -> bool:
            return self._generation != job.generation or self._stopping

        for p in progressive.schedule(settings.samples, block, settings.seed):
            start = time.perf_counter()
            # The heap stays warm between passes; the engine's idle timer gives it back.
            image = progressive.render_pass(job.scene, settings, job.geometry, job.view, p, cancel=cancelled,
                                            keep_memory=True)
            seconds = time.perf_counter() - start
            if image is None or cancelled():
                return
            if p.block > 1:
                self.timer.measure(seconds, -(-job.view.film[2] // p.block) * -(-job.view.film[3] // p.block))
                shown, samples = image, 0
            else:
                shown, samples = accumulator.add(image, p.samples), accumulator.samples
            with self._lock:
                if cancelled():
                    return
                self._version += 1
                self._frame = Frame(shown, self._version, samples, settings.samples, p.block, seconds,
                                    time.perf_counter() - job.started)
                frame = self._frame
            yield frame
        with self._lock:
            if job.generation == self._generation:
                self._finished = job.generation

    def _loop(self) -> None:
        """The worker: wait for a job, render its passes, repeat until stopped."""
        while True:
            with self._lock:
                while not self._stopping and (self._job is None or self._finished == self._job.generation):
                    self._lock.wait()
                if self._stopping:
                    return
                job = self._job
            try:
                for _ in self.run(job):
                    pass
            except Exception as error:          # never let the worker die silently
                log.exception("Primer viewport render failed")
                with self._lock:
                    self.error = f"render failed: {error}"
                    self._finished = job.generation
            with self._lock:
                if self._job is job:
                    self._finished = job.generation


# ------------------------------------------------------------------------------------------------
# The RenderEngine's side: kept here so engine.py only forwards
# ------------------------------------------------------------------------------------------------

def session_of(engine) -> ViewportSession:
    """Return the engine's viewport session, made on first use."""
    session = getattr(engine, "_primer_viewport", None)
    if session is None:
        session = ViewportSession()
        engine._primer_viewport = session
    return session


def view_update(engine, context, depsgraph) -> None:
    """RenderEngine.view_update: re-export what changed, then make sure the viewport redraws."""
    try:
        _view_update(engine, depsgraph)
    except Exception as error:          # never let an exception escape into Blender's drawing code
        _report_once(engine, f"viewport update failed: {error}")


def view_draw(engine, context, depsgraph) -> None:
    """RenderEngine.view_draw: follow the view, draw the newest image, show the frame time."""
    try:
        _view_draw(engine, context, depsgraph)
    except Exception as error:          # e.g. a camera type the viewport cannot show
        _report_once(engine, f"viewport drawing failed: {error}")


def _report_once(engine, message: str) -> None:
    """Log `message` with its traceback the first time, and show it in the viewport's status line."""
    if getattr(engine, "_primer_failed", None) != message:
        log.exception("Primer viewport: %s", message)
        engine._primer_failed = message
    engine.update_stats("", f"Primer | {message}")


def _view_update(engine, depsgraph) -> None:
    """view_update's work: sync the session with the depsgraph and pass its warnings on."""
    session = session_of(engine)
    session.update(depsgraph)
    for warning in session.cache.warnings:
        if warning not in getattr(engine, "_primer_warned", ()):
            log.warning(warning)
    engine._primer_warned = set(session.cache.warnings)
    if session.error:
        engine.update_stats("", session.status_text())


def _view_draw(engine, context, depsgraph) -> None:
    """view_draw's work: follow the view, draw the newest image, show the frame time."""
    session = session_of(engine)
    region = context.region
    session.set_view(view_from_region(context.region_data, region.width, region.height, depsgraph))
    frame = session.latest()
    if frame is not None:
        _draw_image(engine, depsgraph.scene, frame, region.width, region.height)
    engine.update_stats("", session.status_text())
    if session.refining:
        engine.tag_redraw()             # come back for the next pass


def free(engine) -> None:
    """Stop the engine's viewport session, if it has one (the engine is being freed)."""
    session = getattr(engine, "_primer_viewport", None)
    if session is not None:
        session.stop()


def _draw_image(engine, scene, frame: Frame, width: int, height: int) -> None:
    """Draw a frame stretched over the width x height region through Blender's view transform.

    Right after a resize the previous frame is stretched until the new coarse pass arrives.
    """
    if bpy.app.background:
        return
    import gpu
    from gpu_extras.presets import draw_texture_2d

    rows, columns = frame.image.shape[:2]
    cached = getattr(engine, "_primer_texture", None)
    if cached is None or cached[0] != frame.version:
        # Texture rows run bottom-up, like Blender's images.
        pixels = np.ascontiguousarray(frame.image[::-1], np.float32).ravel()
        buffer = gpu.types.Buffer("FLOAT", pixels.size, pixels)
        cached = (frame.version, gpu.types.GPUTexture((columns, rows), format="RGBA16F", data=buffer))
        engine._primer_texture = cached
    gpu.state.blend_set("ALPHA_PREMULT")
    engine.bind_display_space_shader(scene)
    draw_texture_2d(cached[1], (0, 0), width, height)
    engine.unbind_display_space_shader()
    gpu.state.blend_set("NONE")
