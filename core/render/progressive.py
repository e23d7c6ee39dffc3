"""Progressive rendering for the viewport: a coarse image at once, then ever more samples.

An interactive view must answer within a frame or two, long before a clean image is ready, so
the viewport renders in passes (the lecture's framerate slide: measure the time of a frame and
act on it):

1. a *coarse* pass: one sample per block of s x s pixels, one shadow ray per light, which takes
   tens of milliseconds; the block size s is chosen from the measured cost of earlier passes so
   that it fits `coarse_seconds`;
2. a full-resolution pass with one sample per pixel, which replaces the coarse picture;
3. more full-resolution passes, each with a fresh sample pattern (another seed), averaged with
   the earlier ones until `samples` per pixel are reached. Pass sizes double (1, 1, 2, 4, ...) so
   the picture updates often at first and the per-pass overhead stays small later.

Everything here is plain numpy and core; addon/viewport.py runs it on a worker thread.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, Iterator, NamedTuple, Optional

import numpy as np

from ..camera import view as view_
from ..camera.camera import Camera
from ..geometry.geometry import WorldGeometry
from . import render                      # the function: the render loop is core/render/__init__.py
from ..scene import RenderSettings, Scene

BLOCK_SIZES = (1, 2, 4, 8, 16, 32)
SEED_STRIDE = 7919      # seeds of successive passes, far apart so their patterns are unrelated


@dataclasses.dataclass(frozen=True, eq=False)
class View:
    """What the viewport shows: a camera image placed in a region of width x height pixels.

    film: (x, y, w, h) rectangle of the region, rows from the top, that the camera's w x h image
    covers; the whole region except for fisheye cameras in camera view. Outside it the region is black.
    """

    camera: Camera
    pixel_aspect: tuple
    width: int
    height: int
    film: tuple

    def signature(self) -> tuple:
        """Return a hashable summary; two views with equal signatures render the same image."""
        c = self.camera
        lens = tuple(getattr(c, f.name) for f in dataclasses.fields(c) if f.name != "matrix_world")   # (every other field)
        return (self.width, self.height, tuple(self.film), tuple(self.pixel_aspect),
                tuple(np.round(c.matrix_world, 12).ravel())) + lens


def region_view(view_matrix, window_matrix, width: int, height: int) -> View:
    """Return the View of a viewport region from Blender's view and window matrices."""
    camera, aspect = view_.camera_from_matrices(view_matrix, window_matrix, width, height)
    return View(camera, aspect, width, height, (0, 0, width, height))


class Pass(NamedTuple):
    """One progressive pass: block size (1 = full resolution), samples per pixel, shadow rays, seed."""

    block: int
    samples: int
    light_samples: Optional[int]    # None: the scene's own setting
    seed: int


def schedule(samples: int, block: int, seed: int = 0) -> Iterator[Pass]:
    """Yield the passes of one view: a coarse pass of `block` (if > 1), then full passes up to `samples` in all."""
    if block > 1:
        yield Pass(block, 1, 1, seed)
    done, size, index = 0, 1, 1
    while done < samples:
        n = min(size, samples - done)
        yield Pass(1, n, None, seed + SEED_STRIDE * index)
        done += n
        index += 1
        if index > 2:
            size *= 2


def coarse_block(seconds_per_sample: Optional[float], pixels: int, budget: float, default: int = 8) -> int:
    """Return the smallest block size whose coarse pass is predicted to take at most `budget` seconds.

    seconds_per_sample: measured cost of one camera sample with one shadow ray per light (None: unknown);
    pixels: pixels of the view.
    """
    if seconds_per_sample is None:
        return default
    for block in BLOCK_SIZES[1:]:
        if seconds_per_sample * pixels / (block * block) <= budget:
            return block
    return BLOCK_SIZES[-1]


def _upsample(image: np.ndarray, block: int, width: int, height: int) -> np.ndarray:
    """Repeat each pixel of a coarse (h, w, 4) image into block x block pixels, cropped to (height, width, 4)."""
    return np.repeat(np.repeat(image, block, axis=0), block, axis=1)[:height, :width]


def render_pass(scene: Scene, settings: RenderSettings, geometry: WorldGeometry, view: View, p: Pass,
                cancel: Optional[Callable[[], bool]] = None, keep_memory: bool = False) -> Optional[np.ndarray]:
    """Render one pass of `view`: return its (height, width, 4) float32 region image, or None if cancelled.

    settings: the scene's render settings; size, samples, seed and pixel aspect come from the view
    and the pass. The coarse pass renders one ray per block and repeats it over the block.
    keep_memory: leave the heap warm for the next pass (core/memory.py, render.render).
    """
    fx, fy, fw, fh = view.film
    camera, aspect = view.camera, tuple(view.pixel_aspect)
    # 1. The pass's image size and camera: a block camera covers whole blocks of the film.
    if p.block > 1:
        w, h = math.ceil(fw / p.block), math.ceil(fh / p.block)
        if camera.type in ("PERSP", "ORTHO"):
            camera, aspect = view_.crop(view_.ViewCamera(camera, aspect), fw, fh, 0, 0, w * p.block, h * p.block)
    else:
        w, h = fw, fh
    # 2. Render only the film's part inside the region (full passes; a coarse pass is small anyway).
    region = None
    if p.block == 1:
        x0, y0 = max(0, -fx), max(0, -fy)
        x1, y1 = min(fw, view.width - fx), min(fh, view.height - fy)
        if x1 <= x0 or y1 <= y0:
            return np.zeros((view.height, view.width, 4), np.float32)
        region = (x0, y0, x1, y1)
    light_samples = settings.light_samples if p.light_samples is None else min(p.light_samples,
                                                                                settings.light_samples)
    pass_settings = dataclasses.replace(settings, width=w, height=h, samples=p.samples, seed=p.seed,
                                        light_samples=light_samples, region=region, pixel_aspect=aspect,
                                        aux=(), chunk_size=min(settings.chunk_size, 1 << 14))
    result = render(dataclasses.replace(scene, camera=camera), pass_settings, cancel=cancel, geometry=geometry,
                    keep_memory=keep_memory)
    if result.cancelled:
        return None
    # 3. Back to film pixels: repeat blocks (exact for block cameras, nearest pixel for fisheyes).
    image = result.image
    if p.block > 1:
        if camera is view.camera:           # a fisheye keeps its camera: map film pixels to coarse pixels
            rows = np.minimum((np.arange(fh) + 0.5) * h / fh, h - 1).astype(np.int64)
            cols = np.minimum((np.arange(fw) + 0.5) * w / fw, w - 1).astype(np.int64)
            image = image[rows][:, cols]
        else:
            image = _upsample(image, p.block, fw, fh)
    # 4. Place the film in the region; black outside it.
    if view.film == (0, 0, view.width, view.height):
        return np.ascontiguousarray(image, np.float32)
    out = np.zeros((view.height, view.width, 4), np.float32)
    out[..., 3] = 1.0
    x0, y0 = max(0, fx), max(0, fy)
    x1, y1 = min(view.width, fx + fw), min(view.height, fy + fh)
    if x1 > x0 and y1 > y0:
        out[y0:y1, x0:x1] = image[y0 - fy:y1 - fy, x0 - fx:x1 - fx]
    return out


class Accumulator:
    """The running mean of a view's full-resolution passes: image (H, W, 4) float32 and its sample count."""

    def __init__(self):
        self.image: Optional[np.ndarray] = None
        self.samples = 0

    def add(self, image: np.ndarray, samples: int) -> np.ndarray:
        """Average in a pass of `samples` per pixel; return the new mean (H, W, 4) float32."""
        if self.image is None or self.samples == 0:
            self.image = np.array(image, np.float32)
        else:
            weight = samples / (self.samples + samples)
            self.image = self.image + np.float32(weight) * (image - self.image)
        self.samples += samples
        return self.image


class PassTimer:
    """Keeps the measured cost of one coarse-pass sample, for choosing the next coarse block size."""

    def __init__(self):
        self.seconds_per_sample: Optional[float] = None

    def measure(self, seconds: float, samples: int) -> None:
        """Record a coarse pass that took `seconds` for `samples` camera samples (one shadow ray per light)."""
        if samples <= 0:
            return
        per_sample = seconds / samples
        if self.seconds_per_sample is None:
            self.seconds_per_sample = per_sample
        else:
            self.seconds_per_sample = 0.5 * (self.seconds_per_sample + per_sample)
