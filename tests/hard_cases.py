"""Hard cases for shadow rays and geometry, each with an expected image that Primer never produced.

Shared by tests/test_hard_cases.py (which asserts that the robust offset gets every judged pixel
right), tests/test_shadows.py (which reuses the builders) and `make bench` (which prints the table).

Every case renders a scene with one shadow-offset method and compares each pixel with an
expectation computed here, independently of Primer's tracer:
- a closed form per pixel (a plane lit by a sun or a point light, a facet of a convex mesh), or
- an analytic classification: the pixel's camera ray and its shadow rays are traced in float64
  against the exact shapes (axis-aligned boxes and rectangles in a local frame, which the scene
  then rotates, scales and moves), giving which surface is seen and which lights reach it.
Only the camera's pixel-to-ray mapping is taken from core.camera.camera (tested against Blender in
tests/test_camera.py). A pixel is *judged* unless the answer there is ambiguous at the scale of
the case's margin: a camera ray or shadow ray passing within the margin of an edge, where shrinking
or growing the shapes by the margin changes what is seen or whether the light is blocked.

A judged pixel is *wrong* when it differs from the expected value by more than rtol (relative)
plus a tiny absolute floor. Each case returns an Outcome: the wrong fraction of the judged pixels.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from conftest import ortho_down, rotation, sun_direction
from core.camera import camera as camera_
from core.geometry import primitives
from core import render
from core.integrators import debug
from core.integrators import shadows
from core.camera import Camera
from core.geometry.geometry import build_geometry
from core.scene import Instance, Mesh, PointLight, RenderSettings, Scene, SunLight

ALBEDO = 0.5
EPSILON = 1e-3          # the lecture's epsilon, RenderSettings' default
METHODS = ("robust", "epsilon")


@dataclass
class Outcome:
    """How one render compares with its expected image.

    wrong:  fraction of the judged pixels that are wrong (0..1)
    judged: number of pixels judged; total: number of pixels
    worst:  largest relative error among the judged pixels
    warnings: the render's warnings (bad input cases)
    """

    wrong: float
    judged: int
    total: int
    worst: float = 0.0
    warnings: list = field(default_factory=list)


def compare(image: np.ndarray, expected: np.ndarray, judged: np.ndarray, rtol: float = 1e-4,
            floor: float = 1e-7) -> Outcome:
    """Compare the red channel of a (H, W, 4) image with expected (H, W) values where judged (H, W) bool.

    Wrong: |image - expected| > rtol * expected + floor * max(expected) (1e-12 when all expected are 0).
    """
    value = image[..., 0].astype(np.float64)
    floor = floor * float(expected[judged].max()) if judged.any() and expected[judged].max() > 0 else 1e-12
    error = np.abs(value - expected)
    bad = ~np.isfinite(value) | (error > rtol * np.abs(expected) + floor)
    bad &= judged
    worst = float((error / np.maximum(np.abs(expected), floor))[judged].max()) if judged.any() else 0.0
    return Outcome(float(bad.sum() / max(1, judged.sum())), int(judged.sum()), int(judged.size), worst)


def pixel_rays(camera: Camera, width: int, height: int):
    """Return the camera rays through the pixel centres: origins (H*W, 3), directions (H*W, 3), t_max (H*W,)."""
    ys, xs = np.mgrid[0:height, 0:width]
    rays = camera_.generate_rays(camera, width, height, xs.ravel() + 0.5, ys.ravel() + 0.5)
    return rays.origins, rays.directions, rays.t_max


def settings_for(method: str, width: int, height: int, **kw) -> RenderSettings:
    """Return settings that sample each pixel once at its centre, with the given shadow method."""
    return RenderSettings(width=width, height=height, samples=1, jitter=False, shadow_method=method,
                          epsilon=EPSILON, **kw)


# ----------------------------------------------------------------------------
# Analytic scenes: boxes and rectangles in a local frame, then rotated, scaled and moved
# ----------------------------------------------------------------------------

@dataclass
class Shape:
    """An axis-aligned box (lo < hi on every axis) or rectangle (lo == hi on z), in the local frame.

    lo, hi: (3,) float64 corners; albedo: grey base colour.
    """

    lo: np.ndarray
    hi: np.ndarray
    albedo: float = ALBEDO

    def __post_init__(self):
        self.lo = np.asarray(self.lo, np.float64)
        self.hi = np.asarray(self.hi, np.float64)

    def grown(self, margin: float) -> "Shape":
        """Return the shape grown by `margin` (shrunk when negative) along each axis it extends on."""
        extends = self.hi > self.lo
        return Shape(self.lo - margin * extends, self.hi + margin * extends, self.albedo)

    def mesh(self) -> Mesh:
        """Return the shape as a closed box or a two-triangle rectangle facing +z."""
        size = self.hi - self.lo
        center = 0.5 * (self.lo + self.hi)
        if size[2] == 0.0:
            return primitives.plane(size[0], size[1], center)
        return primitives.box(size, center)


@dataclass
class Stage:
    """A scene of Shapes lit by suns and point lights, seen by a camera, all in the local frame.

    suns:   list of (travel direction (3,), strength W/m^2)
    points: list of (position (3,), power W)
    The world scene is the local one rotated by R, scaled by s and moved by T (`similarity`).
    """

    shapes: list
    camera: Camera
    suns: list = field(default_factory=list)
    points: list = field(default_factory=list)

    def world(self, R=np.eye(3), s: float = 1.0, T=np.zeros(3)) -> Scene:
        """Return the Primer scene of this stage placed by x -> s R x + T (point powers times s^2)."""
        M = similarity(R, s, T)
        cam = self.camera
        camera = dataclasses.replace(cam, matrix_world=M @ cam.matrix_world, clip_start=cam.clip_start * s,
                                     clip_end=cam.clip_end * s, ortho_scale=cam.ortho_scale * s)
        scene = Scene(camera=camera)
        for index, shape in enumerate(self.shapes):
            scene.add_material((shape.albedo,) * 3)
            scene.add_mesh(shape.mesh(), matrix=M, materials=[index], name=f"Shape {index}")
        for travel, strength in self.suns:
            scene.lights.append(SunLight(np.asarray(R, np.float64) @ np.asarray(travel, np.float64), strength=strength))
        for position, power in self.points:
            scene.lights.append(PointLight(M[:3, :3] @ np.asarray(position, np.float64) + M[:3, 3], power=power * s * s))
        return scene

    def expected(self, width: int, height: int, margin: float):
        """Return (expected red value (H, W), judged (H, W) bool), traced analytically in the local frame."""
        O, D, t_max = pixel_rays(self.camera, width, height)
        seen = [nearest(O, D, t_max, self.shapes, g) for g in (0.0, -margin, margin)]
        obj, face, t, inside = seen[0]
        judged = (seen[1][0] == obj) & (seen[2][0] == obj) & (seen[1][1] == face) & (seen[2][1] == face)
        value = np.zeros(len(O))
        hit = obj >= 0
        P = O + np.where(hit, t, 0.0)[:, None] * D
        normal = np.zeros_like(P)
        axis = np.abs(face)
        rows = np.flatnonzero(hit)
        normal[rows, axis[rows] - 1] = np.sign(face[rows])
        normal *= np.where(np.einsum("ij,ij->i", normal, D) > 0, -1.0, 1.0)[:, None]   # towards the camera
        albedo = np.array([s.albedo for s in self.shapes] + [0.0])[obj]
        lights = [(-np.asarray(d, np.float64) / np.linalg.norm(d), np.inf, strength, None) for d, strength in self.suns]
        lights += [(None, None, power, np.asarray(p, np.float64)) for p, power in self.points]
        for L, distance, amount, position in lights:
            if position is None:
                Ls = np.broadcast_to(L, P.shape)
                dist = np.full(len(P), np.inf)
                E = np.full(len(P), amount)
            else:
                w = position - P
                dist = np.linalg.norm(w, axis=1)
                Ls = w / np.maximum(dist, 1e-300)[:, None]
                E = amount / (4.0 * math.pi * dist ** 2)
            cos = np.einsum("ij,ij->i", normal, Ls)
            # Ambiguous: the verdict changes when the shapes grow or shrink by the margin, or when the
            # point moves off its surface by up to the margin (at grazing light that moves a shadow's
            # edge by margin / tan(elevation), as float32 rounding of the surface itself does; lifts
            # are sampled, since past a thin occluder the verdict can flip back).
            blocked = occluded(P, Ls, dist, self.shapes, obj, inside, position)
            lifts = [(0.0, lift) for lift in np.linspace(-margin, margin, 9) if lift != 0.0]
            for g, lift in [(-margin, 0.0), (margin, 0.0)] + lifts:
                Q = P + lift * normal
                Lq, dq = Ls, dist
                if position is not None:
                    w = position - Q
                    dq = np.linalg.norm(w, axis=1)
                    Lq = w / np.maximum(dq, 1e-300)[:, None]
                other = occluded(Q, Lq, dq, self.shapes, obj, inside, position, g)
                judged &= ~(hit & (cos > 0) & (other != blocked))
            value += np.where(hit & (cos > 0) & ~blocked, albedo / math.pi * E * np.maximum(cos, 0.0), 0.0)
        return value.reshape(height, width), judged.reshape(height, width)


def similarity(R, s: float, T) -> np.ndarray:
    """Return the (4, 4) float64 matrix of x -> s R x + T."""
    M = np.eye(4)
    M[:3, :3] = s * np.asarray(R, np.float64)
    M[:3, 3] = np.asarray(T, np.float64)
    return M


def _slabs(O: np.ndarray, D: np.ndarray, shape: Shape):
    """Return (t_enter, t_exit, enter_axis, exit_axis) of rays (n, 3) through an axis-aligned box (n,) each."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / D
        t1 = (shape.lo - O) * inv
        t2 = (shape.hi - O) * inv
    parallel = D == 0.0
    inside = (O >= shape.lo) & (O <= shape.hi)
    near = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    far = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    return near.max(axis=1), far.min(axis=1), near.argmax(axis=1), far.argmin(axis=1)


def nearest(O: np.ndarray, D: np.ndarray, t_max: np.ndarray, shapes: list, grow: float = 0.0):
    """Return (shape index or -1, signed face axis 1..3 of the outward normal or 0, t, camera inside) per ray."""
    n = len(O)
    best_t = np.array(t_max, np.float64, copy=True)
    best_obj = np.full(n, -1)
    best_face = np.zeros(n, np.int64)
    best_inside = np.zeros(n, bool)
    for index, shape in enumerate(shapes):
        t0, t1, a0, a1 = _slabs(O, D, shape.grown(grow))
        entering = (t0 <= t1) & (t0 > 0.0)
        leaving = (t0 <= t1) & (t0 <= 0.0) & (t1 > 0.0)          # the ray starts inside: it hits the inner wall
        t = np.where(entering, t0, np.where(leaving, t1, np.inf))
        axis = np.where(entering, a0, a1)
        outward = np.where(entering, -np.sign(D[np.arange(n), axis]), np.sign(D[np.arange(n), axis]))
        closer = t < best_t
        best_t[closer] = t[closer]
        best_obj[closer] = index
        best_face[closer] = ((axis + 1) * outward)[closer].astype(np.int64)
        best_inside[closer] = leaving[closer]
    return best_obj, best_face, best_t, best_inside


def occluded(P: np.ndarray, L: np.ndarray, distance: np.ndarray, shapes: list, own: np.ndarray,
             inside: np.ndarray, light: Optional[np.ndarray], grow: float = 0.0) -> np.ndarray:
    """Return whether the way from P (n, 3) along L (n, 3) to the light, `distance` (n,) away, is blocked.

    Shapes are convex, so the point's own shape cannot shadow the side of it that faces the light,
    unless the point is seen from inside (`inside`) and the light (a point (3,), or None for a sun)
    is outside the shape: then the ray must leave through another wall.
    """
    blocked = np.zeros(len(P), bool)
    for index, shape in enumerate(shapes):
        grown = shape.grown(grow)
        t0, t1, _, _ = _slabs(P, L, grown)
        crosses = (t0 <= t1) & (t1 > 0.0) & (t0 < distance)
        light_inside = light is not None and bool(np.all((light >= grown.lo) & (light <= grown.hi)))
        blocked |= np.where(own == index, inside & (not light_inside), crosses)
    return blocked


# Judging margin from float32: a pixel whose answer changes when the shapes move by this many
# float32 roundoffs of the camera-relative coordinates is beyond what float32 geometry can decide.
RESOLUTION_ULPS = 16.0


def float32_margin(stage: Stage) -> float:
    """Return RESOLUTION_ULPS float32 roundoffs of the largest camera-relative coordinate of the stage (local units)."""
    eye = stage.camera.position
    corners = np.array([[shape.lo, shape.hi][k >> 2 & 1][0:1].tolist() + [shape.lo, shape.hi][k >> 1 & 1][1:2].tolist()
                        + [shape.lo, shape.hi][k & 1][2:3].tolist() for shape in stage.shapes for k in range(8)])
    return RESOLUTION_ULPS * 2.0 ** -24 * float(np.abs(corners - eye).max())


def stage_outcome(stage: Stage, method: str, width: int, height: int, margin: float, R=np.eye(3),
                  s: float = 1.0, T=np.zeros(3), rtol: float = 1e-4, resolution_margin: bool = True,
                  **settings) -> Outcome:
    """Render the stage placed by (R, s, T) with `method` and compare it with its analytic image.

    The judging margin is `margin` or, with `resolution_margin`, the stage's float32 resolution
    (`float32_margin`) if that is larger.
    """
    result = render.render(stage.world(R, s, T), settings_for(method, width, height, **settings))
    if resolution_margin:
        margin = max(margin, float32_margin(stage))
    expected, judged = stage.expected(width, height, margin)
    return compare(result.image, expected, judged, rtol)


# ----------------------------------------------------------------------------
# The builders
# ----------------------------------------------------------------------------

TILT = rotation((0.3, 0.5, 0.8), 0.7)       # a rotation that float32 cannot store exactly


def showcase_stage(width_fov: float = 50.0) -> Stage:
    """A floor, a box floating above it and a box resting on it, under a sun and a point light."""
    shapes = [Shape((-10.0, -10.0, 0.0), (10.0, 10.0, 0.0)),                       # floor
              Shape((-1.6, -0.5, 0.8), (-0.6, 0.5, 1.4), 0.7),                     # floating box
              Shape((0.3, -0.6, 0.0), (1.3, 0.4, 1.0), 0.3)]                       # box resting on the floor
    camera = Camera.look_at((3.0, -7.0, 4.5), (0.0, 0.0, 0.5), fov=math.radians(width_fov), clip_start=0.05,
                            clip_end=100.0)
    return Stage(shapes, camera, suns=[(sun_direction(35.0, 200.0), 2.0)], points=[((2.0, -2.5, 3.0), 300.0)])


def translated(offset: float, method: str) -> Outcome:
    """The showcase stage, tilted and moved `offset` from the origin (camera-relative rendering, the default)."""
    T = TILT @ np.array([offset, 0.5 * offset, -0.3 * offset])
    return stage_outcome(showcase_stage(), method, 64, 48, margin=1e-4, R=TILT, T=T)


def scaled(s: float, method: str) -> Outcome:
    """The showcase stage, tilted and scaled by s (point powers by s^2, so every pixel keeps its value)."""
    return stage_outcome(showcase_stage(), method, 64, 48, margin=1e-4, R=TILT, s=s)


def grazing_sun_image(elevation_deg: float, offset: float, method: str = "robust",
                      camera_relative: bool = True, epsilon: float = EPSILON, size: int = 64):
    """Render a tilted plane lit by a sun `elevation_deg` above it, `offset` away from the origin.

    Returns (image (H, W, 4), hit mask (H, W), exact pixel value). The plane is rotated
    off the axes so that float32 cannot store it exactly: the honest case.
    """
    R = rotation((0.3, 0.5, 0.8), 0.7)
    origin = R @ np.array([offset, 0.5 * offset, 0.3 * offset])
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, origin
    scene = Scene(camera=Camera.look_at(origin + R @ [0.0, -4.0, 2.5], origin, R @ [0.0, 0.0, 1.0],
                                        fov=math.radians(60), clip_start=0.01, clip_end=1e3))
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(primitives.plane(100.0), matrix=M)
    scene.lights.append(SunLight(R @ sun_direction(elevation_deg, 30.0), strength=3.0))
    settings = RenderSettings(width=size, height=size, samples=1, jitter=False, shadow_method=method,
                              epsilon=epsilon, camera_relative=camera_relative, aux=("depth",))
    result = render.render(scene, settings)
    hit = result.aux["depth"][..., 0] < debug.MISS_DEPTH
    exact = ALBEDO / math.pi * 3.0 * math.sin(math.radians(elevation_deg))
    return result.image, hit, exact


def wrong_fraction(image: np.ndarray, hit: np.ndarray, exact) -> float:
    """Return the fraction of hit pixels whose red channel is off by more than 1e-4 relative."""
    wrong = np.abs(image[..., 0] - exact) > 1e-4 * np.maximum(exact, 1e-12)
    return float((wrong & hit).sum() / max(1, hit.sum()))


def grazing_light(elevation_deg: float, method: str, offset: float = 0.0, camera_relative: bool = True) -> Outcome:
    """A tilted plane lit by a sun `elevation_deg` above its plane: every pixel it covers has the same value.

    The hit mask comes from the plane's analytic extent, not from the render.
    """
    image, _, exact = grazing_sun_image(elevation_deg, offset, method, camera_relative)
    R = rotation((0.3, 0.5, 0.8), 0.7)
    origin = R @ np.array([offset, 0.5 * offset, 0.3 * offset])
    camera = Camera.look_at(R @ [0.0, -4.0, 2.5], np.zeros(3), R @ [0.0, 0.0, 1.0], fov=math.radians(60),
                            clip_start=0.01, clip_end=1e3)
    O, D, t_max = pixel_rays(camera, 64, 64)
    O, D = O @ R, D @ R                             # into the plane's frame (rows times R = R^T x)
    t = -O[:, 2] / D[:, 2]
    x = O + t[:, None] * D
    inside = (t > 0) & (t < t_max) & (np.abs(x[:, :2]).max(axis=1) < 50.0 - 1e-3)
    del origin
    return compare(image, np.full((64, 64), exact), inside.reshape(64, 64))


def grazing_view(angle_deg: float, method: str) -> Outcome:
    """An orthographic camera whose parallel rays meet a large floor at `angle_deg`; a sun 30 degrees high.

    Every pixel whose ray reaches the floor sees (rho/pi) S sin(30 deg); the rays meet it up to
    1/sin(angle) units away, so at 0.01 degrees the floor's hits lie ~6000 units from the camera.
    """
    a = math.radians(angle_deg)
    view = np.array([math.cos(a), 0.0, -math.sin(a)])
    up = np.array([math.sin(a), 0.0, math.cos(a)])
    matrix = np.eye(4)
    matrix[:3, 0] = np.cross(view, up)
    matrix[:3, 1] = up
    matrix[:3, 2] = -view
    matrix[:3, 3] = (0.0, 0.0, 0.5)
    reach = 2.0 / math.sin(a)
    camera = Camera(matrix_world=matrix, type="ORTHO", ortho_scale=1.0, clip_start=1e-3, clip_end=2.0 * reach)
    size = 4.0 * reach
    stage = Stage([Shape((-0.25 * size, -0.5 * size, 0.0), (0.75 * size, 0.5 * size, 0.0))], camera,
                  suns=[(sun_direction(30.0, 150.0), 2.0)])
    return stage_outcome(stage, method, 48, 48, margin=1e-6 * reach, rtol=1e-4)


def light_near_surface(height: float, method: str, occluder: bool = False, offset: float = 0.0) -> Outcome:
    """A point light `height` above a floor, seen from straight above (view 20 heights wide).

    Without occluder: a 1x1 floor seen from 1 unit above; every pixel is (rho/pi) P/(4 pi) h/r^3.
    With `occluder`: a plate half-way between the floor and the light must cast its shadow, a
    contact shadow at the scale of `height`; floor and camera distance then shrink with the
    height (a 40h floor seen from 10h), since float32 cannot resolve a gap much smaller than
    2^-24 of the coordinates around it (see thin_plate).
    """
    center = np.array([offset, -offset, 0.0])
    size = 40.0 * height if occluder else 1.0
    camera = ortho_down(center, height=10.0 * height if occluder else 1.0, scale=20.0 * height)
    shapes = [Shape(center + [-0.5 * size, -0.5 * size, 0.0], center + [0.5 * size, 0.5 * size, 0.0])]
    if occluder:
        shapes.append(Shape(center + [-2.5 * height, -1.5 * height, 0.5 * height],
                            center + [1.0 * height, 2.5 * height, 0.5 * height]))
    light = center + [0.3 * height, 0.2 * height, height]
    stage = Stage(shapes, camera, points=[(light, 10.0)])
    return stage_outcome(stage, method, 48, 48, margin=1e-3 * height)


def thin_plate(gap: float, distance: float, method: str, offset: float = 0.0, beyond: bool = False) -> Outcome:
    """A strip `gap` above a floor (10 gaps wide) under a sun 3 degrees high, seen from `distance` straight
    above; the whole scene (camera included) `offset` from the origin.

    The strip's shadow is a band of its width, displaced by gap/tan(3 deg) = 19 gaps from under it:
    a contact shadow at the scale of the gap, fully visible from above.
    The physical limit: in camera-relative coordinates the floor lies `distance` from the camera, so
    the robust offset lifts its shadow rays by error_bound ~ 8 2^-24 distance; once that exceeds the
    gap, shadow rays start above the strip and the band is lost. float32 itself cannot place the
    strip within the gap there either (its spacing at `distance` is 2^-23 distance).
    `beyond`: judge every pixel away from edges by 1e-3 gaps, although the scene is then below
    float32's resolution, to show what is lost.
    """
    center = np.array([offset, 0.3 * offset, -0.2 * offset])
    camera = ortho_down(center + [-10.0 * gap, 0.0, 0.0], height=distance, scale=60.0 * gap,
                        clip_start=0.5 * distance, clip_end=2.0 * distance)
    shapes = [Shape(center + [-60.0 * gap, -60.0 * gap, 0.0], center + [60.0 * gap, 60.0 * gap, 0.0]),
              Shape(center + [-5.0 * gap, -30.0 * gap, gap], center + [5.0 * gap, 30.0 * gap, gap])]
    stage = Stage(shapes, camera, suns=[(sun_direction(3.0, 0.0), 2.0)])
    return stage_outcome(stage, method, 64, 32, margin=1e-3 * gap, resolution_margin=not beyond)


def robust_offset_at(distance: float) -> float:
    """Return the robust offset (core.integrators.shadows.error_bound) of a point `distance` from the camera."""
    return float(shadows.error_bound(np.array([[distance, 0.0, 0.0]]), np.full((1, 3, 3), distance))[0])


def thin_sheet_from_below(thickness: float, method: str) -> Outcome:
    """A box `thickness` thin lit from above and seen from below: its underside must stay black."""
    camera = Camera.look_at((0.3, -0.4, -1.5), (0.0, 0.0, 0.0), fov=math.radians(40), clip_start=1e-3)
    stage = Stage([Shape((-1.0, -1.0, 0.0), (1.0, 1.0, thickness))], camera,
                  suns=[(sun_direction(60.0, 30.0), 2.0)], points=[((0.2, 0.1, 0.5), 50.0)])
    return stage_outcome(stage, method, 48, 48, margin=1e-4)


def box_stage(light, camera: Camera, floor: float = -1.0) -> Stage:
    """A closed 2x2x2 box centred at the origin, a large floor at height `floor`, a point light at `light`."""
    return Stage([Shape((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0), 0.8), Shape((-20.0, -20.0, floor), (20.0, 20.0, floor))],
                 camera, points=[(light, 1000.0)])


def light_in_closed_box(wall_distance: float, method: str, margin: float = 1e-4) -> Outcome:
    """A point light inside a closed box, `wall_distance` from one wall: nothing outside may be lit."""
    camera = Camera.look_at((3.0, -5.0, 4.0), (0.0, 0.0, 0.0), fov=math.radians(60))
    stage = box_stage((1.0 - wall_distance, 0.2, -0.1), camera)
    return stage_outcome(stage, method, 64, 48, margin=margin, R=TILT)


def camera_in_closed_box(light_inside: bool, method: str) -> Outcome:
    """A camera inside a closed box sees its inner walls: lit by (rho/pi) P cos/(4 pi r^2) from a light
    inside, black with the light outside."""
    camera = Camera.look_at((0.3, -0.5, 0.2), (0.0, 1.0, 0.0), fov=math.radians(100), clip_start=1e-3)
    stage = box_stage((-0.2, 0.1, 0.3) if light_inside else (0.0, 0.0, 3.0), camera, floor=-1.5)
    return stage_outcome(stage, method, 48, 48, margin=1e-4, R=TILT)


def rays_through_edges(method: str, tilted: bool) -> Outcome:
    """Shadow rays from the inside of a closed 6x6x6 room to point lights inside a closed 2x2x2 box in it,
    aimed exactly at the box's vertices, edge midpoints and face-diagonal midpoints: all must be blocked.

    Each ray starts where the line from the light through the target meets the room's wall, and is
    built with the method's own construction (core.integrators.shadows) in camera-relative coordinates, then traced
    through the render's own BVH. Three light positions: the centre and two off-centre points.
    """
    R = TILT if tilted else np.eye(3)
    box = primitives.box((2.0, 2.0, 2.0))
    corners = box.vertices
    pairs = [(a, b) for a in range(8) for b in range(a + 1, 8)]
    targets = np.vstack([corners] + [0.5 * (corners[a] + corners[b]) for a, b in pairs])
    targets = targets[np.abs(targets).max(axis=1) > 0.999]              # on the surface, not the centre
    scene = Scene(camera=Camera.look_at(R @ [2.0, -2.5, 1.5], np.zeros(3), R @ [0.0, 0.0, 1.0]))
    scene.add_material((0.8,) * 3)
    M = similarity(R, 1.0, np.zeros(3))
    scene.add_mesh(box, matrix=M)
    scene.add_mesh(primitives.box((6.0, 6.0, 6.0)), matrix=M)
    origin = scene.camera.position
    geometry = build_geometry(scene, origin)
    room = Shape((-3.0, -3.0, -3.0), (3.0, 3.0, 3.0))
    leaked = []
    for light in ([0.0, 0.0, 0.0], [0.25, -0.5, 0.125], [0.5, 0.5, 0.9]):
        light = np.array(light)
        direction = targets - light
        direction /= np.linalg.norm(direction, axis=1)[:, None]
        _, t_exit, _, axis = _slabs(np.broadcast_to(light, direction.shape), direction, room)
        wall_points = light + t_exit[:, None] * direction
        inward = np.zeros_like(wall_points)
        inward[np.arange(len(axis)), axis] = -np.sign(direction[np.arange(len(axis)), axis])
        P = wall_points @ R.T - origin                     # camera-relative, as a render has them
        light_rel = np.broadcast_to(R @ light - origin, P.shape)
        w = light_rel - P
        distance = np.linalg.norm(w, axis=1)
        L = w / distance[:, None]
        if method == "robust":
            wall_corners = np.broadcast_to((3.0 * np.sign(wall_points))[:, None, :] @ R.T - origin, (len(P), 3, 3))
            rays = shadows.robust_rays(P, inward @ R.T, shadows.error_bound(P, wall_corners), light_rel, L, distance)
        else:
            rays = shadows.epsilon_rays(P, L, distance, EPSILON)
        leaked.append(shadows.visible(geometry.tracer, rays))
    leaked = np.concatenate(leaked)
    return Outcome(float(leaked.mean()), len(leaked), len(leaked))


def flat_sphere_facets(method: str, offset: float = 0.0) -> Outcome:
    """A convex 16x8 flat-shaded sphere under a sun 1 degree high, `offset` from the origin: each facet
    gets exactly (rho/pi) S max(Ng.L, 0), however grazing, and never shadows itself."""
    mesh = primitives.uv_sphere(1.0, 16, 8, smooth=False)
    return _sphere_outcome(mesh, method, sun_direction(1.0, -70.0), smooth=False, offset=offset)


def smooth_low_poly_sphere(method: str, travel=None) -> Outcome:
    """A 12x6 smooth sphere under a sun: shading and face normals disagree near the terminator.

    The lecture's rule, in closed form per pixel: (rho/pi) S max(N.L, 0) where the face normal
    also faces the light (Ng.L > 0), else 0, with N the renormalised barycentric interpolation of
    the corner normals. The sphere is convex, so nothing else shadows a facet facing the light.
    """
    travel = sun_direction(10.0, -60.0) if travel is None else travel
    mesh = primitives.uv_sphere(1.0, 12, 6, smooth=True)
    return _sphere_outcome(mesh, method, travel, smooth=True)


def _sphere_outcome(mesh: Mesh, method: str, travel, smooth: bool, size: int = 64, offset: float = 0.0) -> Outcome:
    """Render a convex mesh under a sun, moved `offset` from the origin (camera too), and compare it with
    the per-facet closed form (see the callers); the closed form is computed unmoved."""
    camera = Camera.look_at((0.3, -4.0, 0.7), (0.0, 0.0, 0.0), fov=math.radians(40))
    T = np.array([offset, 0.3 * offset, 0.1 * offset])
    M = similarity(np.eye(3), 1.0, T)
    scene = Scene(camera=dataclasses.replace(camera, matrix_world=M @ camera.matrix_world))
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(mesh, matrix=M)
    scene.lights.append(SunLight(np.asarray(travel, np.float64), strength=3.0))
    result = render.render(scene, settings_for(method, size, size))
    O, D, t_max = pixel_rays(camera, size, size)
    tri, u, v, edge = intersect_triangles(O, D, mesh.vertices, mesh.triangles)
    hit = tri >= 0
    V = mesh.vertices[mesh.triangles]
    Ng = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
    Ng /= np.linalg.norm(Ng, axis=1)[:, None]
    Ng = Ng[np.maximum(tri, 0)]
    side = np.where(np.einsum("ij,ij->i", Ng, D) > 0, -1.0, 1.0)
    Ng *= side[:, None]
    if smooth:
        corners = mesh.corner_normals[np.maximum(tri, 0)] * side[:, None, None]
        N = (1 - u - v)[:, None] * corners[:, 0] + u[:, None] * corners[:, 1] + v[:, None] * corners[:, 2]
        N /= np.linalg.norm(N, axis=1)[:, None]
    else:
        N = Ng
    L = -np.asarray(travel, np.float64)
    NL, NgL = N @ L, Ng @ L
    expected = np.where(hit & (NL > 0) & (NgL > 0), ALBEDO / math.pi * 3.0 * NL, 0.0)
    judged = (edge > 1e-4) & (np.abs(NgL) > 1e-9) | ~hit & (edge > 1e-4)
    # Smooth corner normals are stored as float32 (core/geometry/geometry.py): N.L is good to ~1e-7 absolute.
    return compare(result.image, expected.reshape(size, size), judged.reshape(size, size),
                   floor=1e-6 if smooth else 1e-7)


def intersect_triangles(O: np.ndarray, D: np.ndarray, vertices: np.ndarray, triangles: np.ndarray):
    """Return the nearest triangle hit by each ray in float64 (brute force, Moeller-Trumbore).

    O, D: (n, 3); vertices (v, 3); triangles (t, 3) -> (triangle (n,) or -1, u (n,), v (n,),
    margin (n,): the smallest barycentric coordinate of the hit, or for a miss the distance in
    barycentric units to the nearest triangle, so edges and silhouettes can be left unjudged).
    """
    V0, V1, V2 = (vertices[triangles[:, k]] for k in range(3))
    e1, e2 = V1 - V0, V2 - V0
    best_t = np.full(len(O), np.inf)
    best = np.full(len(O), -1)
    bu, bv = np.zeros(len(O)), np.zeros(len(O))
    margin = np.full(len(O), np.inf)
    for k in range(len(triangles)):
        p = np.cross(D, e2[k])
        det = p @ e1[k]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = O - V0[k]
            u = np.einsum("ij,ij->i", s, p) * inv
            q = np.cross(s, e1[k])
            v = np.einsum("ij,ij->i", D, q) * inv
            t = q @ e2[k] * inv
        bary = np.minimum(np.minimum(u, v), 1 - u - v)
        front = (t > 0) & np.isfinite(t)
        inside = front & (bary >= 0)
        closer = inside & (t < best_t)
        best_t[closer], best[closer], bu[closer], bv[closer] = t[closer], k, u[closer], v[closer]
        margin = np.where(front, np.minimum(margin, np.abs(bary)), margin)
    return best, bu, bv, margin


# ----------------------------------------------------------------------------
# Bad input
# ----------------------------------------------------------------------------

def _lit_floor_outcome(extra: Mesh, method: str, extra_matrix=None) -> Outcome:
    """A square floor under a point light, plus `extra` triangles that must change nothing.

    Every pixel is (rho/pi) P/(4 pi) h/r^3 of the floor's plane.
    """
    camera = ortho_down((0.0, 0.0, 0.0), height=1.0, scale=1.8)
    scene = Scene(camera=camera)
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(primitives.plane(2.0))
    scene.add_mesh(extra, matrix=extra_matrix)
    light = np.array([0.1, -0.2, 0.7])
    scene.lights.append(PointLight(light, power=50.0))
    result = render.render(scene, settings_for(method, 48, 48))
    stage = Stage([Shape((-1.0, -1.0, 0.0), (1.0, 1.0, 0.0))], camera, points=[(light, 50.0)])
    expected, judged = stage.expected(48, 48, 1e-4)
    outcome = compare(result.image, expected, judged)
    outcome.warnings = result.stats.warnings
    return outcome


def degenerate_triangles(method: str) -> Outcome:
    """Zero-area triangles (repeated and collinear vertices) and slivers 1e-9 wide lying in the floor."""
    rng = np.random.default_rng(5)
    a = rng.uniform(-0.9, 0.9, (200, 3))
    a[:, 2] = 0.0
    b = a + rng.uniform(-0.5, 0.5, (200, 3)) * [1, 1, 0]
    mid = 0.5 * (a + b)
    sliver = mid + np.cross(b - a, [0.0, 0.0, 1.0]) * 1e-9                      # 1e-9 off the line: area > 0
    vertices = np.vstack([a, b, mid, sliver])
    n = len(a)
    i = np.arange(n)
    triangles = np.vstack([np.stack([i, i, n + i], 1),                # repeated vertex
                           np.stack([i, n + i, 2 * n + i], 1),        # collinear
                           np.stack([i, n + i, 3 * n + i], 1)])       # sliver (kept; it lies in the floor)
    return _lit_floor_outcome(Mesh(vertices, triangles), method)


def bad_vertices(method: str) -> Outcome:
    """Triangles with NaN, infinite and float32-overflowing (1e39) vertices, sharing vertices with good ones."""
    vertices = np.array([[-0.5, -0.5, 0.3], [0.5, -0.5, 0.3], [0.0, 0.5, 0.3],
                         [np.nan, 0.0, 0.3], [np.inf, 0.0, 0.3], [0.0, -np.inf, 0.3], [1e39, 0.0, 0.3]])
    triangles = np.array([[0, 1, 3], [1, 2, 4], [2, 0, 5], [0, 1, 6], [3, 4, 5]])
    return _lit_floor_outcome(Mesh(vertices, triangles, smooth=np.ones(5, bool)), method)


def odd_corner_normals(method: str) -> Outcome:
    """A smooth floor whose corner normals are zero, opposite (pointing down) or tilted.

    The lecture's rule in closed form: N = normalize(sum w_i n_i) (zero-length corners add
    nothing; the face normal where the sum vanishes), flipped with the face towards the viewer;
    the pixel is (rho/pi) S max(N.L, 0) when the face normal faces the sun.
    """
    k = 6
    s = np.linspace(-1.0, 1.0, k + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    vertices = np.stack([x, y, np.zeros_like(x)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = (i * (k + 1) + j).ravel()
    triangles = np.vstack([np.stack([a, a + k + 1, a + k + 2], 1), np.stack([a, a + k + 2, a + 1], 1)])
    rng = np.random.default_rng(11)
    choices = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.6, 0.0, 0.8], [0.0, -0.8, 0.6]])
    corners = choices[rng.integers(0, len(choices), (len(triangles), 3))]
    mesh = Mesh(vertices, triangles, smooth=np.ones(len(triangles), bool), corner_normals=corners)
    camera = ortho_down((0.0, 0.0, 0.0), height=1.0, scale=2.0)
    travel = sun_direction(50.0, 30.0)
    scene = Scene(camera=camera)
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(mesh)
    scene.lights.append(SunLight(travel, strength=2.0))
    W = H = 48
    result = render.render(scene, settings_for(method, W, H))
    O, D, _ = pixel_rays(camera, W, H)
    tri, u, v, margin = intersect_triangles(O, D, vertices, triangles)
    c = corners[tri]                      # the camera sees the front (+z): no flip
    n = (1 - u - v)[:, None] * c[:, 0] + u[:, None] * c[:, 1] + v[:, None] * c[:, 2]
    length = np.linalg.norm(n, axis=1)
    N = np.where(length[:, None] > 0, n / np.maximum(length, 1e-300)[:, None], [0.0, 0.0, 1.0])
    L = -travel
    NL = N @ L
    expected = np.where(tri >= 0, ALBEDO / math.pi * 2.0 * np.maximum(NL, 0.0), 0.0)
    # Where opposite corners cancel, the sum's sign depends on the last bits of Embree's float32 barycentrics
    # (it differs between CPUs): only sums clearly away from zero are judged, and the face normal where every
    # corner is zero-length (the sum is then 0 for any barycentrics).
    zero_corners = (np.linalg.norm(c, axis=2) == 0.0).all(axis=1)
    judged = (tri >= 0) & (margin > 1e-4) & ((length > 1e-6) | zero_corners) & (np.abs(NL) > 1e-9)
    return compare(result.image, expected.reshape(H, W), judged.reshape(H, W))


def coplanar_faces(method: str, elevation: float = 20.0, offset: float = 1e3) -> Outcome:
    """Two overlapping rectangles in one plane (albedo 0.3 and 0.7), tilted and moved `offset` away.

    Wherever they overlap either may be seen (z-fighting is allowed), but the pixel must be one of
    the two lit values: a shadow ray from one face must not stop at the other.
    """
    travel = sun_direction(elevation, 40.0)
    camera = Camera.look_at((0.5, -3.0, 2.0), (0.0, 0.0, 0.0), fov=math.radians(50))
    stage_a = Stage([Shape((-2.0, -2.0, 0.0), (1.0, 2.0, 0.0), 0.3)], camera, suns=[(travel, 2.0)])
    stage_b = Stage([Shape((-1.0, -1.5, 0.0), (2.0, 2.5, 0.0), 0.7)], camera, suns=[(travel, 2.0)])
    T = TILT @ np.array([offset, -0.5 * offset, 0.2 * offset])
    world = stage_a.world(TILT, 1.0, T)
    other = stage_b.world(TILT, 1.0, T)
    world.add_material((0.7,) * 3)
    world.add_mesh(other.meshes[0], matrix=other.instances[0].matrix, materials=[1])
    result = render.render(world, settings_for(method, 64, 48))
    a, judged_a = stage_a.expected(64, 48, 1e-4)
    b, judged_b = stage_b.expected(64, 48, 1e-4)
    only_b = (a == 0) & judged_a
    expected = np.where(only_b, b, a)
    either = np.isclose(result.image[..., 0], b, rtol=1e-4, atol=1e-9) & (a > 0) & (b > 0)
    image = result.image.copy()
    image[either, 0] = a[either]          # a pixel showing the other face's value is right, too
    return compare(image, expected, judged_a & judged_b)


# ----------------------------------------------------------------------------
# The table of cases
# ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Case:
    """One row of the stability table.

    group: the property the case checks (tests/test_hard_cases.py has one test per group)
    run:   method -> Outcome
    note:  what goes wrong with the lecture's epsilon, shown when it does
    robust_exact: whether the robust offset must get every judged pixel right (False only for the
                  documented float32 limit)
    """

    group: str
    name: str
    run: Callable[[str], Outcome]
    note: str = ""
    robust_exact: bool = True


ACNE_WORLD = "acne: float32 rounding of world coordinates exceeds ε·sin(elevation)"
CONTACT = "lost contact shadow: ε = 10⁻³ carries the shadow ray past the occluder"


def _cases() -> list:
    """Return every hard case, in the order of the table."""
    cases = []
    add = lambda group, name, run, note="", exact=True: cases.append(Case(group, name, run, note, exact))  # noqa: E731
    for offset in (1e3, 1e5, 1e7):
        add("translation", f"scene moved {offset:.0e} from the origin (camera-relative)",
            lambda m, o=offset: translated(o, m))
    for offset in (1e3, 1e5, 1e7):
        add("translation", f"tilted plane {offset:.0e} from the origin, sun 1° high, world coordinates",
            lambda m, o=offset: grazing_light(1.0, m, o, camera_relative=False), ACNE_WORLD)
    for s in (1e-4, 1e-2, 1e2, 1e4):
        add("scale", f"scene scaled by {s:.0e}", lambda m, s=s: scaled(s, m),
            "ε = 10⁻³ is larger than the scene: shadows lost" if s < 1 else
            "acne: ε = 10⁻³ is below the float32 rounding of the scene's coordinates")
    for e in (1.0, 0.1, 0.01):
        add("grazing light", f"sun {e:g}° above a tilted plane", lambda m, e=e: grazing_light(e, m),
            "acne: ε·sin(elevation) is below the float32 rounding of the plane")
        add("grazing light", f"sun {e:g}° above a tilted plane 1e5 from the origin, world coordinates",
            lambda m, e=e: grazing_light(e, m, 1e5, camera_relative=False), ACNE_WORLD)
    for a in (1.0, 0.1, 0.01):
        add("grazing view", f"view {a:g}° above a floor (hits up to {2 / math.sin(math.radians(a)):.0f} away)",
            lambda m, a=a: grazing_view(a, m), "acne where the hits lie far from the camera")
    for h in (1e-2, 1e-4, 1e-6):
        add("light near a surface", f"point light {h:.0e} above a floor", lambda m, h=h: light_near_surface(h, m))
        add("light near a surface", f"point light {h:.0e} above a floor, plate half-way",
            lambda m, h=h: light_near_surface(h, m, True), CONTACT)
    add("light near a surface", "point light 1e-04 above a floor 1e3 from the origin",
        lambda m: light_near_surface(1e-4, m, offset=1e3))
    add("convex mesh", "flat 16×8 sphere, sun 1° high", flat_sphere_facets, "acne on facets lit at grazing angles")
    add("convex mesh", "flat 16×8 sphere 1e5 from the origin, sun 1° high", lambda m: flat_sphere_facets(m, 1e5),
        "acne on facets lit at grazing angles")
    add("convex mesh", "smooth 12×6 sphere: N and face normal disagree", smooth_low_poly_sphere)
    add("closed mesh", "point light at the centre of a closed box", lambda m: light_in_closed_box(1.0, m))
    add("closed mesh", "point light 1e-4 inside a closed box's wall", lambda m: light_in_closed_box(1e-4, m, 1e-5),
        "leak: t_max = r − 2ε ends the shadow ray before the wall")
    add("closed mesh", "shadow rays exactly through a box's vertices and edges", lambda m: rays_through_edges(m, False))
    add("closed mesh", "the same, box tilted", lambda m: rays_through_edges(m, True))
    add("closed mesh", "camera inside a closed box, light inside", lambda m: camera_in_closed_box(True, m))
    add("closed mesh", "camera inside a closed box, light outside", lambda m: camera_in_closed_box(False, m),
        "leak in the room's corners: ε carries the origin through the adjacent wall")
    add("bad input", "zero-area triangles and 1e-9 slivers in a floor", degenerate_triangles)
    add("bad input", "NaN, infinite and 1e39 vertices", bad_vertices)
    add("bad input", "zero-length, opposite and tilted corner normals", odd_corner_normals)
    add("coplanar faces", "coplanar overlapping faces, 1e3 from the origin", coplanar_faces, "acne between the faces")
    add("coplanar faces", "coplanar overlapping faces, sun 1° high", lambda m: coplanar_faces(m, 1.0),
        "acne between the faces")
    add("thin geometry", "box 1e-6 thin, lit from above, seen from below", lambda m: thin_sheet_from_below(1e-6, m),
        "leak through the sheet")
    add("thin geometry", "strip 1e-6 above a floor, seen from 0.01", lambda m: thin_plate(1e-6, 1e-2, m), CONTACT)
    add("thin geometry", "strip 1e-6 above a floor 1e7 from the origin, seen from 0.01 (camera-relative)",
        lambda m: thin_plate(1e-6, 1e-2, m, offset=1e7), CONTACT)
    add("thin geometry", "strip 1e-6 above a floor, seen from 1 (only what float32 resolves is judged)",
        lambda m: thin_plate(1e-6, 1.0, m), CONTACT)
    add("float32 limit", "strip 1e-6 above a floor, seen from 100: beyond float32",
        lambda m: thin_plate(1e-6, 100.0, m, beyond=True),
        f"beyond float32: the robust offset 100 from the camera, {robust_offset_at(100.0):.1e}, exceeds the "
        "10⁻⁶ gap (float32 spacing there is 7.6e-06)", exact=False)
    return cases


CASES = _cases()


def row(case: Case, robust: Outcome, epsilon: Outcome) -> dict:
    """Return one table row: {group, case, judged, total, robust, epsilon, note}."""
    return {"group": case.group, "case": case.name, "judged": robust.judged, "total": robust.total,
            "robust": robust.wrong, "epsilon": epsilon.wrong,
            "note": case.note if (epsilon.wrong > 0 or robust.wrong > 0) else ""}


def table(cases: Optional[list] = None) -> list:
    """Run every case with both methods; return the table rows (see `row`)."""
    return [row(case, case.run("robust"), case.run("epsilon")) for case in (CASES if cases is None else cases)]


def markdown(rows: list) -> str:
    """Return the table rows as markdown."""
    lines = ["| case | judged pixels | robust offset: wrong | lecture's epsilon (10⁻³): wrong | what goes wrong |",
             "|---|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['judged']} / {r['total']} | {100 * r['robust']:.2f}% | "
                     f"{100 * r['epsilon']:.2f}% | {r['note']} |")
    return "\n".join(lines)
