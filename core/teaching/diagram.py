"""The 2D ray diagram: the scene seen from above, cut at the camera's height, with the rays of one row of pixels.

The lecture's assignments ask for this debug output: a top-down view of the scene (its triangles cut
by the horizontal plane through the camera, in grey), the camera, the lights, and for one row of
pixels every ray the integrator traces, each kind in its own colour:

    camera rays    yellow          shadow rays    green where they reach the light, red where blocked
    reflected      blue            refracted      cyan
    where a medium scatters light towards a ray: a magenta cross

The rays are recorded from the integrator itself (a Recorder, core/integrators/base.py) while it renders
the row's pixel centres, so the diagram shows exactly what the renderer does: the direct tracer's
shadow rays and BSDF rays, Whitted's recursion through mirrors and glass, a path tracer's bounces.
Rays are drawn in 3D projected straight down (x to the right, y up the image); a ray that escapes is
drawn to the edge of the picture. `ray_diagram` returns the image; `write_diagram` writes a PNG.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from .. import render as render_
from ..camera import camera as camera_
from ..integrators import Recorder, for_render

# The colours of the diagram (linear RGB).
COLORS = {"scene": (0.55, 0.55, 0.55), "camera": (1.0, 0.85, 0.1), "shadow_free": (0.1, 0.8, 0.2),
          "shadow_blocked": (0.9, 0.1, 0.1), "reflect": (0.15, 0.35, 1.0), "refract": (0.1, 0.85, 0.9),
          "portal": (1.0, 0.5, 0.0), "portal_jump": (0.6, 0.3, 0.0),
          "light": (1.0, 1.0, 1.0), "background": (0.02, 0.02, 0.025), "scatter": (1.0, 0.2, 0.9)}


class Segment(NamedTuple):
    """Rays of one kind: start and end points (k, 3) float64, world space (an escaping ray ends far away)."""

    kind: str
    start: np.ndarray
    end: np.ndarray


class DiagramRecorder(Recorder):
    """Keeps every ray the integrator traces, as segments (camera-relative points, made world-space later)."""

    def __init__(self):
        self.segments: list = []

    def scatter(self, kind, P) -> None:
        self.segments.append(Segment("scatter", P.copy(), P.copy()))

    def rays(self, kind, O, D, t) -> None:
        far = np.where(np.isfinite(t), t, 1e4)
        self.segments.append(Segment(kind, O.copy(), O + D * far[:, None]))

    def shadow_rays(self, light, count, rows, rays, seen) -> None:
        t = np.where(np.isfinite(rays.t_max), rays.t_max, 1e4)
        end = rays.origins + rays.directions * t[:, None]
        for kind, mask in (("shadow_free", seen), ("shadow_blocked", ~seen)):
            if mask.any():
                self.segments.append(Segment(kind, rays.origins[mask], end[mask]))


class Diagram(NamedTuple):
    """A ray diagram: the image (H, W, 4) float32, row 0 at the top, and what it was drawn from."""

    image: np.ndarray
    segments: tuple
    scene_lines: np.ndarray          # (k, 2, 2) float64 the cut of the scene, world (x, y) pairs
    bounds: tuple                    # (x0, y0, x1, y1) world rectangle the image shows
    row: int


def scene_section(geometry, height: float) -> np.ndarray:
    """The triangles cut by the plane z = height (camera-relative): (k, 2, 2) float64 (x, y) segments."""
    n = geometry.triangle_count
    corners = geometry.triangle_data(np.arange(n), smooth=False).corners if n else np.zeros((0, 3, 3))
    z = corners[:, :, 2] - height
    lines = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        crosses = (z[:, a] > 0) != (z[:, b] > 0)
        t = np.divide(z[:, a], z[:, a] - z[:, b], out=np.zeros(len(z)), where=crosses)
        lines.append((corners[:, a, :2] + t[:, None] * (corners[:, b, :2] - corners[:, a, :2]), crosses))
    points, masks = zip(*lines)
    cut = (np.stack(masks, axis=1).sum(axis=1) == 2)
    ends = []
    for i in np.flatnonzero(cut):
        ends.append([points[k][i] for k in range(3) if masks[k][i]])
    return np.array(ends, np.float64).reshape(-1, 2, 2)


def ray_diagram(scene, settings, row: Optional[int] = None, every: int = 0, size: int = 512) -> Diagram:
    """Trace the centres of pixels of `row` (default: the middle row; every `every`-th pixel, default about 24
    of them) with the settings' integrator, recording its rays, and draw the top-down diagram (size x size)."""
    W, H = settings.width, settings.height
    row = H // 2 if row is None else int(row)
    if not 0 <= row < H:
        raise ValueError(f"row {row} is outside the image (0..{H - 1})")
    every = every or max(1, W // 24)
    ctx = render_.prepare(scene, settings)
    origin = ctx.geometry.origin
    xs = np.arange(every // 2, W, every)
    rays = camera_.generate_rays(ctx.extra["camera"], W, H, xs + 0.5, np.full(len(xs), row + 0.5),
                                 tuple(settings.pixel_aspect))
    recorder = DiagramRecorder()
    found = ctx.geometry.tracer.intersect(rays.origins, rays.directions, rays.t_max)
    recorder.rays("camera", rays.origins, rays.directions, np.where(found.hit, found.t, np.inf))
    for_render(ctx).radiance(ctx, rays.origins, rays.directions, rays.t_max, row * W + xs,
                                                np.zeros(len(xs), np.int64), recorder)
    eye = np.asarray(scene.camera.matrix_world, np.float64)[:3, 3]
    lines = scene_section(ctx.geometry, eye[2] - origin[2]) + origin[:2]
    segments = tuple(Segment(s.kind, s.start + origin, s.end + origin) for s in recorder.segments)
    lights = [np.asarray(getattr(light, "position", getattr(light, "center", None)), np.float64) + origin
              for light in ctx.lights if getattr(light, "position", getattr(light, "center", None)) is not None]
    bounds = _bounds(lines, segments, eye, lights)
    image = _draw(lines, segments, eye, lights, bounds, size)
    return Diagram(image, segments, lines, bounds, row)


def _bounds(lines, segments, eye, lights) -> tuple:
    """A square world rectangle around the scene's cut, the camera, the lights and the rays' finite ends."""
    points = [eye[:2][None, :]] + [p[:2][None, :] for p in lights]
    if len(lines):
        points.append(lines.reshape(-1, 2))
    for s in segments:
        near = np.linalg.norm(s.end - s.start, axis=1) < 1e3
        points.append(s.start[:, :2])
        points.append(s.end[near, :2])
    p = np.concatenate(points)
    lo, hi = p.min(axis=0), p.max(axis=0)
    centre, half = (lo + hi) / 2.0, max(float((hi - lo).max()) * 0.55, 1e-3)
    return (centre[0] - half, centre[1] - half, centre[0] + half, centre[1] + half)


def _draw(lines, segments, eye, lights, bounds, size) -> np.ndarray:
    """Rasterize the diagram: the scene's cut, then camera rays, shadow rays, reflected and refracted rays."""
    image = np.empty((size, size, 4), np.float32)
    image[..., :3] = COLORS["background"]
    image[..., 3] = 1.0
    x0, y0, x1, y1 = bounds
    scale = (size - 1) / (x1 - x0)

    def line(a: np.ndarray, b: np.ndarray, color) -> None:
        """Draw segments a -> b ((k, 2) world x, y) in `color`, clipped to the picture."""
        pa, pb = (a - (x0, y0)) * scale, (b - (x0, y0)) * scale
        steps = np.clip(np.ceil(np.abs(pb - pa).max(axis=1)), 1, 4 * size).astype(np.int64)
        for i in range(len(a)):
            t = np.linspace(0.0, 1.0, steps[i] + 1)
            p = pa[i] + t[:, None] * (pb[i] - pa[i])
            col, r = np.round(p[:, 0]).astype(np.int64), size - 1 - np.round(p[:, 1]).astype(np.int64)
            ok = (col >= 0) & (col < size) & (r >= 0) & (r < size)
            image[r[ok], col[ok], :3] = color

    if len(lines):
        line(lines[:, 0], lines[:, 1], COLORS["scene"])
    for kind in ("camera", "shadow_free", "shadow_blocked", "reflect", "refract", "portal", "portal_jump"):
        for s in segments:
            if s.kind == kind and len(s.start):
                line(s.start[:, :2], s.end[:, :2], COLORS[kind])
    for s in segments:                          # (scattering points: a cross 5 pixels wide)
        if s.kind == "scatter" and len(s.start):
            for offset in ((2.0, 0.0), (0.0, 2.0)):
                step = np.asarray(offset) / scale
                line(s.start[:, :2] - step, s.start[:, :2] + step, COLORS["scatter"])
    for p in [eye] + lights:
        c = (p[:2] - (x0, y0)) * scale
        col, r = int(round(c[0])), size - 1 - int(round(c[1]))
        image[max(r - 2, 0):r + 3, max(col - 2, 0):col + 3, :3] = COLORS["light"]
    return image


def write_diagram(path: str, scene, settings, row: Optional[int] = None, every: int = 0, size: int = 512) -> Diagram:
    """Draw the ray diagram of `row` and write it as an image file (PNG: sRGB)."""
    from ..film import image_io
    diagram = ray_diagram(scene, settings, row, every, size)
    image_io.write_image(path, diagram.image)
    return diagram
