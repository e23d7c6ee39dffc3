"""Primary-ray generation: from the lecture's pinhole camera to Blender's camera.

The lecture describes a camera by four things:

* a *position* (the eye),
* a *target* it looks at and an *up* vector, which together fix its orientation,
* a horizontal *field of view* (FOV) and the image's *aspect ratio*.

From these it builds an image plane at distance 1 in front of the eye and three
screen corners ``p1`` (top-left), ``p2`` (top-right) and ``p3`` (bottom-left).
The ray through raster point (x, y) of a W x H image passes through::

    p1 + (x / W) * (p2 - p1) + (y / H) * (p3 - p1)

Blender describes the same pinhole camera differently, and this module
translates between the two:

* Orientation and position come from the object's ``matrix_world``.  The
  camera looks along its local -Z axis, local +Y is up and +X is right.  Object
  scale is ignored (Cycles normalises the axes away).
* The FOV comes from a focal length ``lens`` and a ``sensor_width`` (mm): on
  the plane at distance 1 the sensor spans ``sensor / lens`` units.
* ``sensor_fit`` says which image dimension the sensor spans: AUTO (the larger
  one, always measured with ``sensor_width``), HORIZONTAL (the width, with
  ``sensor_width``) or VERTICAL (the height, with ``sensor_height``).  The other
  dimension follows from the aspect ratio, which includes the pixel aspect.
* ``shift_x`` / ``shift_y`` slide the image plane sideways, in units of the
  fitted dimension (a shift of 1 moves the picture by one full image width for
  a horizontal fit).
* Clipping is planar: ``clip_start`` and ``clip_end`` are distances along the
  view axis, so a ray at angle a to the axis starts ``clip_start / cos(a)``
  from the eye and ends ``clip_end / cos(a)`` from it.  (Cycles' panoramic
  cameras measure both distances along the ray instead.)
* Orthographic cameras send parallel rays; ``ortho_scale`` is the size of the
  fitted image dimension in scene units.
* Panoramic fisheye cameras (equidistant and equisolid) map the image to
  directions the way Cycles does; pixels outside the lens' image circle are
  black.
* Depth of field replaces the pinhole by a thin lens, as Cycles' camera does: a
  ray leaves a random point of the aperture (radius ``aperture_size``: the
  focal length over twice the f-stop; a disk, or a polygon of blades, narrowed
  by the anamorphic ratio) towards the point the pinhole ray meets at
  ``focus_distance`` along the axis, so that what lies at that depth is sharp
  and the rest blurs in proportion to its distance from it.
* Motion blur gives each ray a time in the shutter and places the camera
  where it is then (core/camera/motion.py: its transforms at its motion
  steps, interpolated as Cycles does; a perspective camera's field of view
  too).

Conventions used below: *points* are positions (names ending in ``_point(s)``
or ``origins``), *directions* are vectors (``_direction(s)``, ``forward``,
``right``, ``up``).  Raster coordinates have x growing to the right and y
growing **downwards** from the top row; pixel centres sit at +0.5.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import NamedTuple, Optional

import numpy as np

from .. import vectors
from ..native import schema
from ..native.schema import F64, I32, I64, U8, out, ptr
from . import motion as motion_
from .filter import PixelFilter

__all__ = [
    "Camera",
    "CameraRays",
    "generate_rays",
    "outside_image_circle",
    "viewplane",
    "lens_from_fov",
    "fov_from_lens",
]

CAMERA_TYPES = ("PERSP", "ORTHO", "PANO")
SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")
PANORAMA_TYPES = ("FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID", "EQUIRECTANGULAR", "EQUIANGULAR_CUBEMAP_FACE",
                  "MIRRORBALL", "FISHEYE_LENS_POLYNOMIAL", "CENTRAL_CYLINDRICAL")
# Blender's default polynomial fisheye (k0 .. k4: the angle from the axis as a polynomial of the radius on the sensor).
POLYNOMIAL_DEFAULT = (-1.1735143712967577e-05, -0.019988736, -3.3525322e-06, 3.0994753e-06, -2.6165266e-08)


# ---------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------

def _normalize_rows(vectors: np.ndarray) -> np.ndarray:
    """Return `vectors` ((n, 3) float64) scaled to unit length row by row."""
    return vectors / np.sqrt(np.einsum("ij,ij->i", vectors, vectors))[:, None]


def _clear_scale(matrix: np.ndarray) -> np.ndarray:
    """Return a copy of a (4, 4) float64 transform with its three axis columns normalised.

    This is what Cycles does to the camera's object matrix (transform_clear_scale):
    the object's scale must not change the picture.
    """
    result = np.array(matrix, dtype=np.float64, copy=True)
    lengths = np.linalg.norm(result[:3, :3], axis=0)
    if np.any(lengths == 0.0):
        raise ValueError("matrix_world has a zero-length axis (zero scale)")
    result[:3, :3] /= lengths
    return result


def world_to_camera(camera: "Camera") -> np.ndarray:
    """Cycles' worldtocamera (3, 4) float64: world points to the camera's frame, x right, y up and z forward along the
    view (the inverse of its scale-cleared matrix with z flipped)."""
    to_world = _clear_scale(np.asarray(camera.matrix_world, np.float64)) @ np.diag([1.0, 1.0, -1.0, 1.0])
    return np.linalg.inv(to_world)[:3]


def world_to_raster(camera: "Camera", width: int, height: int,
                    pixel_aspect: tuple[float, float] = (1.0, 1.0)) -> np.ndarray:
    """Cycles' worldtoraster (4, 4) float64 of a perspective or orthographic camera: a world point p maps to raster
    (x, y) = (R p)[:2] / (R p)[3], x in pixels from the image's left edge, y from its bottom (Cycles' raster)."""
    left, right, bottom, top = viewplane(camera, width, height, pixel_aspect)
    sx, sy = width / (right - left), height / (top - bottom)
    to_local = np.linalg.inv(_clear_scale(np.asarray(camera.matrix_world, np.float64)))   # (x right, y up, -z ahead)
    if camera.type == "PERSP":                      # x / depth and y / depth on the plane at depth 1 (depth = -z)
        plane = np.array([[sx, 0.0, sx * left, 0.0], [0.0, sy, sy * bottom, 0.0], [0.0, 0.0, 0.0, 0.0],
                          [0.0, 0.0, -1.0, 0.0]])
    else:
        plane = np.array([[sx, 0.0, 0.0, -sx * left], [0.0, sy, 0.0, -sy * bottom], [0.0, 0.0, 0.0, 0.0],
                          [0.0, 0.0, 0.0, 1.0]])
    return plane @ to_local


def lens_from_fov(fov: float, sensor_size: float = 36.0) -> float:
    """Return the focal length (mm) whose sensor of `sensor_size` mm spans the angle `fov` (radians)."""
    return 0.5 * sensor_size / math.tan(0.5 * fov)


def fov_from_lens(lens: float, sensor_size: float = 36.0) -> float:
    """Return the angle (radians) spanned by a sensor of `sensor_size` mm behind a `lens` mm lens."""
    return 2.0 * math.atan(0.5 * sensor_size / lens)


# ---------------------------------------------------------------------------
# The camera
# ---------------------------------------------------------------------------

# eq=False: a generated __eq__ would compare the ndarray field element-wise and fail.
@dataclass(frozen=True, eq=False)
class Camera:
    """A Blender camera: where it is (matrix_world) and how it projects (the remaining fields)."""

    matrix_world: np.ndarray = field(default_factory=lambda: np.eye(4))  # (4, 4) float64 camera-to-world
    type: str = "PERSP"                          # "PERSP" | "ORTHO" | "PANO"
    lens: float = 50.0                           # focal length, mm (PERSP)
    sensor_width: float = 36.0                   # mm
    sensor_height: float = 24.0                  # mm
    sensor_fit: str = "AUTO"                     # "AUTO" | "HORIZONTAL" | "VERTICAL"
    shift_x: float = 0.0                         # in units of the fitted image dimension
    shift_y: float = 0.0
    clip_start: float = 0.1                      # planar, along the view axis
    clip_end: float = 100.0
    ortho_scale: float = 7.0                     # fitted image dimension in scene units (ORTHO)
    panorama_type: str = "FISHEYE_EQUIDISTANT"   # | "FISHEYE_EQUISOLID" (PANO)
    fisheye_fov: float = math.pi                 # radians: full angle of the image circle
    fisheye_lens: float = 10.5                   # mm (equisolid)
    longitude_min: float = -math.pi              # radians (EQUIRECTANGULAR): the image's span of longitude,
    longitude_max: float = math.pi               # and of latitude
    latitude_min: float = -math.pi / 2.0
    latitude_max: float = math.pi / 2.0
    fisheye_polynomial: tuple = POLYNOMIAL_DEFAULT   # k0 .. k4 (FISHEYE_LENS_POLYNOMIAL)
    cylinder_u_min: float = -math.pi             # radians (CENTRAL_CYLINDRICAL): the span around the axis,
    cylinder_u_max: float = math.pi
    cylinder_v_min: float = -1.0                 # and the height on the cylinder of `cylinder_radius`
    cylinder_v_max: float = 1.0
    cylinder_radius: float = 1.0
    # Depth of field (a thin lens, as Cycles'): the aperture's radius in scene units (0: a pinhole, all in focus),
    # the distance in focus along the view axis, the aperture's blades (fewer than 3: round), their rotation
    # (radians) and the anamorphic ratio (the aperture's height over its width).
    aperture_size: float = 0.0
    focus_distance: float = 10.0
    aperture_blades: int = 0
    aperture_rotation: float = 0.0
    aperture_ratio: float = 1.0
    # Motion blur (core/camera/motion.py): the shutter (None: no motion blur, every ray at time 1/2), the camera's
    # matrices at its motion steps evenly over the shutter (fewer than 2: it stands still), and for a perspective
    # camera whose field of view changes, tan(fov / 2) at the shutter's open and close over at its middle.
    shutter: Optional[motion_.Shutter] = None
    motion: tuple = ()
    fov_motion: tuple = ()

    def __post_init__(self) -> None:
        """Check the enums and store matrix_world (and the motion steps' matrices) as read-only, scale-free (4, 4)
        float64 arrays."""
        matrix = np.asarray(self.matrix_world, dtype=np.float64)
        if matrix.shape != (4, 4):
            raise ValueError(f"matrix_world must be (4, 4), got {matrix.shape}")
        matrix = _clear_scale(matrix)
        matrix.setflags(write=False)
        object.__setattr__(self, "matrix_world", matrix)
        steps = []
        for step in self.motion:
            step = np.asarray(step, dtype=np.float64)
            if step.shape != (4, 4):
                raise ValueError(f"each motion step must be (4, 4), got {step.shape}")
            step = _clear_scale(step)
            step.setflags(write=False)
            steps.append(step)
        object.__setattr__(self, "motion", tuple(steps))
        if self.type not in CAMERA_TYPES:
            raise ValueError(f"type must be one of {CAMERA_TYPES}, got {self.type!r}")
        if self.sensor_fit not in SENSOR_FITS:
            raise ValueError(f"sensor_fit must be one of {SENSOR_FITS}, got {self.sensor_fit!r}")
        if self.panorama_type not in PANORAMA_TYPES:
            raise ValueError(f"panorama_type must be one of {PANORAMA_TYPES}, got {self.panorama_type!r}")

    # --- where the camera is and where it looks ----------------------------

    @property
    def position(self) -> np.ndarray:
        """The eye point: (3,) float64 world position (translation column of matrix_world)."""
        return self.matrix_world[:3, 3].copy()

    @property
    def right(self) -> np.ndarray:
        """Unit (3,) float64 world direction of the image's +x (local +X)."""
        return self.matrix_world[:3, 0].copy()

    @property
    def up(self) -> np.ndarray:
        """Unit (3,) float64 world direction of the image's up (local +Y)."""
        return self.matrix_world[:3, 1].copy()

    @property
    def forward(self) -> np.ndarray:
        """Unit (3,) float64 world viewing direction (local -Z)."""
        return -self.matrix_world[:3, 2]

    def moved(self, origin: np.ndarray) -> "Camera":
        """Return the camera with `origin` subtracted from its position (camera-relative rendering)."""
        origin = np.asarray(origin, np.float64)
        matrix = np.array(self.matrix_world)
        matrix[:3, 3] = matrix[:3, 3] - origin
        steps = [np.array(step) for step in self.motion]
        for step in steps:
            step[:3, 3] = step[:3, 3] - origin
        return dataclasses.replace(self, matrix_world=matrix, motion=tuple(steps))

    @property
    def moves(self) -> bool:
        """Whether its rays see it move over the shutter (motion blur on and matrices that differ, or a perspective
        camera's field of view that changes)."""
        if self.shutter is None:
            return False
        turns = any(np.any(step != self.motion[0]) for step in self.motion[1:])
        zooms = self.type == "PERSP" and bool(self.fov_motion) and tuple(self.fov_motion) != (1.0, 1.0)
        return turns or zooms

    # --- the lecture's camera model ---------------------------------------

    @classmethod
    def look_at(cls, position, target, up=(0.0, 0.0, 1.0), fov: float = math.radians(39.6), **kw) -> "Camera":
        """Build a PERSP camera from the lecture's (position, target, up, horizontal fov in radians).

        The lecture's construction, with V the viewing direction::

            V     = normalize(target - position)
            right = normalize(V x up)          (perpendicular to V and up)
            up'   = right x V                  (the true up, perpendicular to V)

        The camera's local axes are X = right, Y = up', Z = -V.  The FOV becomes a
        focal length for `sensor_width` (default 36 mm): lens = (sensor_width / 2) / tan(fov / 2).
        With Blender's AUTO sensor fit the angle spans the *larger* image dimension,
        i.e. it is the horizontal FOV of landscape images.  The default, 39.6 deg,
        is Blender's default 50 mm lens.  Other Camera fields may be passed in `kw`.
        """
        for name in ("matrix_world", "type", "lens"):
            if name in kw:
                raise TypeError(f"look_at() computes {name!r} itself")
        eye_point = np.asarray(position, dtype=np.float64).reshape(3)
        target_point = np.asarray(target, dtype=np.float64).reshape(3)
        up_direction = np.asarray(up, dtype=np.float64).reshape(3)

        view_direction = target_point - eye_point
        if np.linalg.norm(view_direction) == 0.0:
            raise ValueError("position and target coincide")
        view_direction /= np.linalg.norm(view_direction)
        right_direction = np.cross(view_direction, up_direction)
        if np.linalg.norm(right_direction) < 1e-12:
            raise ValueError("up is parallel to the viewing direction")
        right_direction /= np.linalg.norm(right_direction)
        true_up_direction = np.cross(right_direction, view_direction)

        matrix = np.eye(4)
        matrix[:3, 0] = right_direction
        matrix[:3, 1] = true_up_direction
        matrix[:3, 2] = -view_direction
        matrix[:3, 3] = eye_point
        sensor_width = kw.get("sensor_width", 36.0)
        return cls(matrix_world=matrix, type="PERSP", lens=lens_from_fov(fov, sensor_width), **kw)

    def screen_corners(self, width: int, height: int,
                       pixel_aspect: tuple[float, float] = (1.0, 1.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the lecture's corners p1 (top-left), p2 (top-right), p3 (bottom-left): (3,) float64 world points.

        They lie on the image plane at distance 1 in front of the eye (PERSP only) and
        include sensor fit, pixel aspect and shift, so that the ray through raster point
        (x, y) passes through p1 + (x/W)(p2 - p1) + (y/H)(p3 - p1).
        """
        if self.type != "PERSP":
            raise ValueError("screen_corners() is defined for PERSP cameras only")
        left, right, bottom, top = viewplane(self, width, height, pixel_aspect)
        corners_local = np.array([[left, top, -1.0],      # p1, top-left
                                  [right, top, -1.0],     # p2, top-right
                                  [left, bottom, -1.0]])  # p3, bottom-left
        corners_world = corners_local @ self.matrix_world[:3, :3].T + self.matrix_world[:3, 3]
        return corners_world[0], corners_world[1], corners_world[2]


class CameraRays(NamedTuple):
    """Primary rays for n raster samples, in world space."""

    origins: np.ndarray     # (n, 3) float64 points, already moved to the near clip plane
    directions: np.ndarray  # (n, 3) float64 unit directions
    t_max: np.ndarray       # (n,) float64 distance from origin to the far clip plane along the ray
    valid: np.ndarray       # (n,) bool, False outside a fisheye's image circle (black pixels)
    time: Optional[np.ndarray] = None   # (n,) float64 each ray's time in the shutter (motion blur), or None


# ---------------------------------------------------------------------------
# Blender's image plane (perspective and orthographic)
# ---------------------------------------------------------------------------

def _is_horizontal_fit(sensor_fit: str, x_ratio: float, y_ratio: float) -> bool:
    """Return True when the sensor spans the image width (x_ratio, y_ratio: width, height times pixel aspect)."""
    if sensor_fit == "HORIZONTAL":
        return True
    if sensor_fit == "VERTICAL":
        return False
    return x_ratio >= y_ratio  # AUTO: the larger dimension


def _fit_sensor_size(camera: Camera) -> float:
    """Return the sensor size (mm) that spans the fitted dimension: sensor_height for VERTICAL, else sensor_width."""
    return camera.sensor_height if camera.sensor_fit == "VERTICAL" else camera.sensor_width


def _image_ratios(width: int, height: int, pixel_aspect: tuple[float, float]) -> tuple[float, float]:
    """Return the displayed image width and height (pixels times pixel aspect), as floats."""
    if width <= 0 or height <= 0:
        raise ValueError("width and height must be positive")
    aspect_x, aspect_y = pixel_aspect
    return float(width) * float(aspect_x), float(height) * float(aspect_y)


def viewplane(camera: Camera, width: int, height: int,
              pixel_aspect: tuple[float, float] = (1.0, 1.0)) -> tuple[float, float, float, float]:
    """Return the image rectangle (left, right, bottom, top) in camera-local x/y (PERSP, ORTHO).

    PERSP: on the plane at distance 1 (local z = -1), so the values are tangents of angles.
    ORTHO: in scene units.  Follows Blender's viewplane: the fitted dimension spans
    `sensor / lens` (PERSP) or `ortho_scale` (ORTHO); the other one follows from the
    aspect ratio; both shifts are in units of the fitted dimension.
    """
    x_ratio, y_ratio = _image_ratios(width, height, pixel_aspect)
    if camera.type == "PERSP":
        fitted_size = _fit_sensor_size(camera) / camera.lens
    elif camera.type == "ORTHO":
        fitted_size = camera.ortho_scale
    else:
        raise ValueError("viewplane() is defined for PERSP and ORTHO cameras only")

    if _is_horizontal_fit(camera.sensor_fit, x_ratio, y_ratio):
        half_width = 0.5 * fitted_size
        half_height = half_width * y_ratio / x_ratio
    else:
        half_height = 0.5 * fitted_size
        half_width = half_height * x_ratio / y_ratio

    center_x = camera.shift_x * fitted_size
    center_y = camera.shift_y * fitted_size
    return (center_x - half_width, center_x + half_width,
            center_y - half_height, center_y + half_height)


def _raster_to_plane(camera: Camera, width: int, height: int, raster_x: np.ndarray, raster_y: np.ndarray,
                     pixel_aspect: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Map raster positions ((n,) float64, y from the top) to camera-local plane x, y ((n,) float64 each)."""
    left, right, bottom, top = viewplane(camera, width, height, pixel_aspect)
    plane_x = left + (raster_x / width) * (right - left)
    plane_y = top - (raster_y / height) * (top - bottom)   # row 0 is the top of the image
    return plane_x, plane_y


# ---------------------------------------------------------------------------
# Ray generation, one function per camera type (all in camera-local space)
# ---------------------------------------------------------------------------

def has_depth_of_field(camera: Camera) -> bool:
    """Whether the camera's rays leave from a lens of some size."""
    return camera.aperture_size > 0.0


def uniform_disk(u: np.ndarray) -> np.ndarray:
    """Points (n, 2) of the unit disk from uniform numbers u (n, 2), by Shirley and Chiu's concentric map (the
    square's rings to the disk's, as Cycles' sample_uniform_disk)."""
    a, b = 2.0 * u[:, 0] - 1.0, 2.0 * u[:, 1] - 1.0
    wide = a * a > b * b
    r = np.where(wide, a, b)
    safe_a, safe_b = np.where(a == 0.0, 1.0, a), np.where(b == 0.0, 1.0, b)
    phi = np.where(wide, (math.pi / 4.0) * (b / safe_a), math.pi / 2.0 - (math.pi / 4.0) * (a / safe_b))
    centre = (a == 0.0) & (b == 0.0)
    return np.where(centre[:, None], 0.0, np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1))


def regular_polygon(u: np.ndarray, corners: int, rotation: float) -> np.ndarray:
    """Points (n, 2) of the regular polygon with `corners` corners inscribed in the unit circle, turned by `rotation`,
    uniform in its area, from uniform numbers u (n, 2): a corner's triangle (the first number picks it, the rest of it
    and the second are the point's triangle coordinates), as Cycles' regular_polygon_sample."""
    x = u[:, 0] * corners
    corner = np.floor(x)
    s = np.sqrt(x - corner)
    t = u[:, 1] * s
    s = 1.0 - s
    half = math.pi / corners
    px, py = (s + t) * math.cos(half), (s - t) * math.sin(half)
    turn = rotation + corner * 2.0 * half
    c, n = np.cos(turn), np.sin(turn)
    return np.stack([c * px - n * py, n * px + c * py], axis=1)


def aperture_points(camera: Camera, u: np.ndarray) -> np.ndarray:
    """Points (n, 2) on the camera's aperture (camera-local x right, y up, scene units) from uniform numbers u (n, 2):
    its disk or polygon of blades, narrowed across by the anamorphic ratio, times the aperture's radius."""
    blades = int(camera.aperture_blades)
    bokeh = uniform_disk(u) if blades < 3 else regular_polygon(u, blades, camera.aperture_rotation)
    bokeh[:, 0] /= camera.aperture_ratio
    return bokeh * camera.aperture_size


def _perspective_rays(camera: Camera, width, height, raster_x, raster_y, pixel_aspect, lens=None, scale=None):
    """Return local (origins (n,3), directions (n,3), t_max (n,), valid (n,)) for a pinhole camera, or with
    lens (n, 2) uniform numbers a thin lens: each ray leaves its point of the aperture towards the point the
    pinhole ray meets at the focus distance (the plane in focus), clipped where the pinhole ray would be.
    scale: (n,) float64 each ray's image plane scaled by its field of view at its time (motion.plane_scales), or None."""
    plane_x, plane_y = _raster_to_plane(camera, width, height, raster_x, raster_y, pixel_aspect)
    if scale is not None:
        plane_x, plane_y = plane_x * scale, plane_y * scale
    if lens is not None and has_depth_of_field(camera):
        pinhole = vectors.rows(plane_x, plane_y, -np.ones_like(plane_x))          # depth 1 along the axis
        cos_to_axis = 1.0 / np.linalg.norm(pinhole, axis=1)
        at = aperture_points(camera, lens)
        start = vectors.rows(at[:, 0], at[:, 1], np.zeros(len(at)))
        directions = _normalize_rows(pinhole * camera.focus_distance - start)
        origins = start + directions * (camera.clip_start / cos_to_axis)[:, None]
        t_max = (camera.clip_end - camera.clip_start) / cos_to_axis
        return origins, directions, t_max, np.ones(len(plane_x), dtype=bool)
    # The point on the image plane at distance 1 is also the (unnormalised) direction.
    directions = _normalize_rows(vectors.rows(plane_x, plane_y, -np.ones_like(plane_x)))
    # Planar clipping: a ray at angle a to the axis reaches depth d after d / cos(a).
    cos_to_axis = -directions[:, 2]
    origins = directions * (camera.clip_start / cos_to_axis)[:, None]
    t_max = (camera.clip_end - camera.clip_start) / cos_to_axis
    valid = np.ones(len(plane_x), dtype=bool)
    return origins, directions, t_max, valid


def _orthographic_rays(camera: Camera, width, height, raster_x, raster_y, pixel_aspect, lens=None):
    """Return local (origins (n,3), directions (n,3), t_max (n,), valid (n,)) for parallel rays along -Z, or with
    lens (n, 2) uniform numbers rays from the aperture's point (around the pixel's) that meet the pixel's parallel
    ray at the focus distance, started where they cross the near clip plane."""
    plane_x, plane_y = _raster_to_plane(camera, width, height, raster_x, raster_y, pixel_aspect)
    n = len(plane_x)
    if lens is not None and has_depth_of_field(camera):
        at = aperture_points(camera, lens)
        offset = vectors.rows(at[:, 0], at[:, 1], np.zeros(n))
        directions = _normalize_rows(np.array([0.0, 0.0, -camera.focus_distance]) - offset)
        origins = (vectors.rows(plane_x, plane_y, np.zeros(n)) + offset
                   + directions * (camera.clip_start / -directions[:, 2])[:, None])
        return origins, directions, np.full(n, camera.clip_end - camera.clip_start), np.ones(n, dtype=bool)
    origins = vectors.rows(plane_x, plane_y, np.full(n, -camera.clip_start))
    directions = vectors.rows(np.zeros(n), np.zeros(n), np.full(n, -1.0))
    t_max = np.full(n, camera.clip_end - camera.clip_start)
    valid = np.ones(n, dtype=bool)
    return origins, directions, t_max, valid


def _panorama_uv(camera: Camera, width, height, raster_x, raster_y) -> tuple[np.ndarray, np.ndarray]:
    """Map raster positions to Cycles' panorama (u, v) in [0, 1]^2 ((n,) float64 each), v growing upwards.

    For panoramic cameras Cycles uses the unit square as the viewplane and adds the
    shift directly (as a fraction of the image width / height).
    """
    u = raster_x / width + camera.shift_x
    v = (height - raster_y) / height + camera.shift_y   # Cycles counts rows from the bottom
    return u, v


def _panorama_sensor(camera: Camera, width, height, pixel_aspect) -> tuple[float, float]:
    """Return the (sensor width, sensor height) in mm that Cycles gives an equisolid fisheye.

    The sensor size (sensor_width, or sensor_height for VERTICAL) spans the fitted
    dimension; the other side follows the image's aspect ratio.
    """
    x_ratio, y_ratio = _image_ratios(width, height, pixel_aspect)
    sensor_size = _fit_sensor_size(camera)
    if _is_horizontal_fit(camera.sensor_fit, x_ratio, y_ratio):
        return sensor_size, sensor_size * y_ratio / x_ratio
    return sensor_size * x_ratio / y_ratio, sensor_size


def _fisheye_directions(sin_theta: np.ndarray, cos_theta: np.ndarray, plane_x: np.ndarray,
                        plane_y: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Return local unit directions (n, 3) at angle theta from -Z (given by its sine and cosine,
    (n,) each), with the azimuth of (plane_x, plane_y) at distance `radius` from the centre."""
    scale = np.divide(sin_theta, radius, out=np.zeros_like(radius), where=radius > 0.0)
    return vectors.rows(scale * plane_x, scale * plane_y, -cos_theta)


def _fisheye_plane(camera: Camera, width, height, pixel_aspect) -> tuple[float, float, float]:
    """Return (scale_x, scale_y, limit): the image plane is ((u - 0.5) scale_x, (v - 0.5) scale_y), and
    the image circle is where its distance from the centre is at most `limit` (see panorama_local)."""
    if camera.panorama_type == "FISHEYE_EQUIDISTANT":
        return 2.0, 2.0, 1.0
    sensor_width, sensor_height = _panorama_sensor(camera, width, height, pixel_aspect)
    return sensor_width, sensor_height, 2.0 * camera.fisheye_lens * math.sin(0.25 * camera.fisheye_fov)


def panorama_directions(camera: Camera, u: np.ndarray, v: np.ndarray, sensor: tuple) -> tuple:
    """Directions (n, 3) in Cycles' panorama frame (x forward, y left, z up; not unit for the central cylindrical
    one) of the panorama (u, v) (n,) of the camera's panorama_type, as Cycles' panorama_to_direction, and which
    exist (n,) bool (outside a mirror ball's circle or a polynomial fisheye's field of view none does). sensor: the
    (width, height) in mm the polynomial fisheye measures its radius on."""
    kind = camera.panorama_type
    n = len(u)
    valid = np.ones(n, bool)
    if kind == "EQUIRECTANGULAR":
        phi = (camera.longitude_min - camera.longitude_max) * u - camera.longitude_min
        theta = (camera.latitude_min - camera.latitude_max) * v - camera.latitude_min + math.pi / 2.0
        return vectors.rows(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)), valid
    if kind == "EQUIANGULAR_CUBEMAP_FACE":
        return _normalize_rows(vectors.rows(np.ones(n), np.tan((0.5 - u) * math.pi / 2.0),
                                            np.tan((v - 0.5) * math.pi / 2.0))), valid
    if kind == "MIRRORBALL":
        # The ball's point seen straight along -y (the camera looks down the ball's y axis), and the view reflected.
        x, z = 2.0 * u - 1.0, 2.0 * v - 1.0
        valid = x * x + z * z <= 1.0
        y = -np.sqrt(np.maximum(1.0 - x * x - z * z, 0.0))
        return np.where(valid[:, None], vectors.rows(-2.0 * y * x, 1.0 - 2.0 * y * y, -2.0 * y * z), 0.0), valid
    if kind == "CENTRAL_CYLINDRICAL":
        theta = -camera.cylinder_u_min + (camera.cylinder_u_min - camera.cylinder_u_max) * u
        z_min, z_max = camera.cylinder_v_min / camera.cylinder_radius, camera.cylinder_v_max / camera.cylinder_radius
        return vectors.rows(np.cos(theta), np.sin(theta), z_min + (z_max - z_min) * v), valid
    # FISHEYE_LENS_POLYNOMIAL: the angle from the axis a polynomial of the radius on the sensor.
    x, y = (u - 0.5) * sensor[0], (v - 0.5) * sensor[1]
    r = np.sqrt(x * x + y * y)
    k = camera.fisheye_polynomial
    theta = -(k[0] + k[1] * r + k[2] * r * r + k[3] * r ** 3 + k[4] * r ** 4)
    valid = np.abs(theta) <= 0.5 * camera.fisheye_fov
    cos_phi = np.clip(np.divide(x, r, out=np.zeros(n), where=r != 0.0), -1.0, 1.0)
    sin_phi = np.sqrt(1.0 - cos_phi * cos_phi) * np.where(y < 0.0, -1.0, 1.0)
    c = vectors.rows(np.cos(theta), -cos_phi * np.sin(theta), sin_phi * np.sin(theta))
    return np.where(valid[:, None], c, 0.0), valid


def local_to_panorama(camera: Camera, d: np.ndarray) -> np.ndarray:
    """The camera's local frame to Cycles' panorama frame (panorama_to_local undone). d (n, 3)."""
    if camera.panorama_type == "MIRRORBALL":
        return vectors.rows(d[:, 0], d[:, 2], d[:, 1])
    return vectors.rows(-d[:, 2], -d[:, 0], d[:, 1])


def _panorama_lens(camera: Camera, directions: np.ndarray, valid: np.ndarray, lens: np.ndarray) -> tuple:
    """A panorama's rays (local unit directions (n, 3)) through a thin lens, as Cycles' camera_sample_panorama: in
    the panorama frame (x forward) each ray leaves its aperture point (lens (n, 2) uniform numbers, aperture_points)
    on the plane across the pinhole ray made by U = (x - D_x D) normalised and V = D x U, towards where the pinhole
    ray is at the focus distance. Returns local (origins (n, 3) past clip_start along the ray, directions (n, 3));
    invalid rays keep theirs."""
    # 1. The pinhole ray in the panorama frame, and the frame across it.
    D = local_to_panorama(camera, directions)
    U = np.array([1.0, 0.0, 0.0]) - D[:, :1] * D
    length = np.linalg.norm(U, axis=1, keepdims=True)
    U = np.where(length > 1e-12, U / np.maximum(length, 1e-300), [[0.0, 1.0, 0.0]])  # (straight ahead: any across)
    V = _normalize_rows(np.cross(D, U))
    # 2. From the aperture's point towards the pinhole ray's point in focus.
    at = aperture_points(camera, lens)
    P = U * at[:, :1] + V * at[:, 1:]
    focused = _normalize_rows(D * camera.focus_distance - P)
    origins, new = panorama_to_local(camera, P), panorama_to_local(camera, focused)
    new = np.where(valid[:, None], new, directions)
    origins = np.where(valid[:, None], origins, 0.0) + new * camera.clip_start
    return origins, new


def panorama_to_local(camera: Camera, c: np.ndarray) -> np.ndarray:
    """Cycles' panorama frame to the camera's local one (Blender's: x right, y up, looking down -z): the frame
    its blender_camera_matrix turns panoramas by (a mirror ball looks down its y axis, the others down x). c (n, 3)."""
    if camera.panorama_type == "MIRRORBALL":
        return vectors.rows(c[:, 0], c[:, 2], c[:, 1])
    return vectors.rows(-c[:, 1], c[:, 2], -c[:, 0])


def panorama_local(camera: Camera, u: np.ndarray, v: np.ndarray, width: int, height: int,
                   pixel_aspect=(1.0, 1.0)) -> tuple:
    """The pinhole directions of a panoramic camera at its (u, v) (n,) (_panorama_uv): local unit directions (n, 3)
    (Blender's camera frame, looking down -z), and which exist (n,) bool; where none does, the forward direction.

    The fisheyes: (u, v) onto the image plane ((u - 0.5) scale_x, (v - 0.5) scale_y), inside the image circle;
    equidistant, the angle from the axis linear in the radius, theta = r fisheye_fov / 2 up to r = 1; equisolid,
    r = 2 lens sin(theta / 2) up to theta = fisheye_fov / 2. The others: panorama_directions turned into the local
    frame (panorama_to_local)."""
    if camera.panorama_type in ("FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID"):
        scale_x, scale_y, limit = _fisheye_plane(camera, width, height, pixel_aspect)
        plane_x, plane_y = (u - 0.5) * scale_x, (v - 0.5) * scale_y
        radius = np.sqrt(plane_x * plane_x + plane_y * plane_y)
        valid = radius <= limit
        if camera.panorama_type == "FISHEYE_EQUIDISTANT":
            theta = np.where(valid, radius * (0.5 * camera.fisheye_fov), 0.0)
            sin_theta, cos_theta = np.sin(theta), np.cos(theta)
        else:
            # r = 2 lens sin(theta / 2); with s = sin(theta / 2): sin theta = 2 s sqrt(1 - s^2), cos theta = 1 - 2 s^2.
            s = np.where(valid, np.clip(radius / (2.0 * camera.fisheye_lens), 0.0, 1.0), 0.0)
            sin_theta, cos_theta = 2.0 * s * np.sqrt(1.0 - s * s), 1.0 - 2.0 * s * s
        # (outside the image circle, theta = 0: the forward direction)
        return _fisheye_directions(sin_theta, cos_theta, plane_x, plane_y, radius), valid
    c, valid = panorama_directions(camera, u, v, _panorama_sensor(camera, width, height, pixel_aspect))
    local = panorama_to_local(camera, c)
    local[~valid] = (0.0, 0.0, -1.0)
    return _normalize_rows(local), valid


def panorama_cones(camera: Camera, u: np.ndarray, v: np.ndarray, width: int, height: int,
                   pixel_aspect=(1.0, 1.0)) -> tuple:
    """The ray cones of a panoramic camera's rays at its (u, v) (n,), as Cycles' camera_sample_panorama makes their
    differentials: the spread (n,) is the mean of |D(x + 1) - D| and |D(y + 1) - D| over one pixel step in raster x
    and y (u + 1 / width, v - 1 / height), the cone (n,) clip_start times it (the ray starts there). A neighbour
    with no direction (past a fisheye's circle or a mirror ball's rim) counts as the other one; with neither, the
    cone is unknown (0 and 0 there). Returns (cone, spread, known (n,) bool)."""
    d, _ = panorama_local(camera, u, v, width, height, pixel_aspect)
    dx, along_x = panorama_local(camera, u + 1.0 / width, v, width, height, pixel_aspect)
    dy, along_y = panorama_local(camera, u, v - 1.0 / height, width, height, pixel_aspect)
    step_x, step_y = np.linalg.norm(dx - d, axis=1), np.linalg.norm(dy - d, axis=1)
    step_x, step_y = np.where(along_x, step_x, step_y), np.where(along_y, step_y, step_x)
    known = along_x | along_y
    spread = np.where(known, 0.5 * (step_x + step_y), 0.0)
    return camera.clip_start * spread, spread, known


def _panorama_rays(camera: Camera, width, height, raster_x, raster_y, pixel_aspect):
    """Return local (origins (n,3), directions (n,3), t_max (n,), valid (n,)) for any panoramic camera
    (panorama_local); spherical clipping, as in Cycles: clip distances are measured along the ray. Where no
    direction exists the ray looks forward and is not valid (opaque black, as Cycles)."""
    u, v = _panorama_uv(camera, width, height, raster_x, raster_y)
    directions, valid = panorama_local(camera, u, v, width, height, pixel_aspect)
    origins = directions * camera.clip_start
    return origins, directions, np.full(len(u), camera.clip_end - camera.clip_start), valid


def outside_image_circle(camera: Camera, width: int, height: int, pixels: np.ndarray,
                         pixel_aspect: tuple[float, float] = (1.0, 1.0), reach: float = 0.0) -> np.ndarray:
    """Return which pixels lie wholly outside a fisheye's image circle: (p,) bool, all False for other cameras.

    Such pixels are opaque black whatever is sampled in them, so a render need not sample them.
    A pixel's samples land in an axis-aligned rectangle on the fisheye's image plane (u and v are
    affine in the raster position, see panorama_local): the pixel grown by `reach` pixels on every
    side (how far its pixel filter sends them, core/camera/filter.py); the pixel lies outside when the
    rectangle's point nearest the circle's centre does. pixels: (p,) int64 flat indices, row 0 at the top.
    """
    pixels = np.asarray(pixels, dtype=np.int64)
    if camera.type != "PANO" or camera.panorama_type not in ("FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID") or not len(pixels):
        return np.zeros(len(pixels), bool)      # (other panoramas: their rays say where no direction exists)
    x, y = (pixels % width).astype(np.float64), (pixels // width).astype(np.float64)
    u0, v0 = _panorama_uv(camera, width, height, x - reach, y + 1.0 + reach)
    u1, v1 = _panorama_uv(camera, width, height, x + 1.0 + reach, y - reach)
    scale_x, scale_y, limit = _fisheye_plane(camera, width, height, pixel_aspect)
    # The rectangle's point nearest the centre (0, 0) of the image plane.
    nearest_x = np.clip(0.0, (u0 - 0.5) * scale_x, (u1 - 0.5) * scale_x)
    nearest_y = np.clip(0.0, (v0 - 0.5) * scale_y, (v1 - 0.5) * scale_y)
    # A relative margin: a pixel whose nearest point lies on the circle up to rounding is still sampled.
    return nearest_x * nearest_x + nearest_y * nearest_y > (limit * (1.0 + 1e-9)) ** 2


def generate_rays(camera: Camera, width: int, height: int, raster_x: np.ndarray, raster_y: np.ndarray,
                  pixel_aspect: tuple[float, float] = (1.0, 1.0), lens: Optional[np.ndarray] = None,
                  time: Optional[np.ndarray] = None) -> CameraRays:
    """Return the world-space primary rays (CameraRays of n rays) through the given raster positions.

    raster_x, raster_y: (n,) float64 raster positions, x in [0, width) from the left,
    y in [0, height) from the TOP row (row 0 is the top of the image); pixel centres at +0.5.
    pixel_aspect: (x, y) as Blender's render pixel aspect; it changes the image's shape.
    lens: (n, 2) float64 uniform numbers picking each ray's point on the aperture (depth of field), or None:
    through the pinhole.
    time: (n,) float64 each ray's time in the shutter (motion.ray_times), or None: the camera where matrix_world says.
    """
    raster_x = np.atleast_1d(np.asarray(raster_x, dtype=np.float64))
    raster_y = np.atleast_1d(np.asarray(raster_y, dtype=np.float64))
    raster_x, raster_y = np.broadcast_arrays(raster_x, raster_y)
    raster_x, raster_y = raster_x.ravel(), raster_y.ravel()
    moving = time is not None and camera.moves
    if moving:
        time = np.broadcast_to(np.asarray(time, np.float64), raster_x.shape)

    if camera.type == "PERSP":
        scale = (motion_.plane_scales(camera.fov_motion, time) if moving and camera.fov_motion else None)
        local = _perspective_rays(camera, width, height, raster_x, raster_y, pixel_aspect, lens, scale)
    elif camera.type == "ORTHO":
        local = _orthographic_rays(camera, width, height, raster_x, raster_y, pixel_aspect, lens)
    else:
        local = _panorama_rays(camera, width, height, raster_x, raster_y, pixel_aspect)
    local_origins, local_directions, t_max, valid = local
    if camera.type == "PANO" and lens is not None and has_depth_of_field(camera):
        local_origins, local_directions = _panorama_lens(camera, local_directions, valid, lens)

    if moving and len(camera.motion) >= 2:
        # The camera where it is at each ray's time (motion.interpolate); its linear part may shear: renormalise.
        linear, eye_points = motion_.interpolate(motion_.decompose(camera.motion), time)
        origins = vectors.apply_each(linear, local_origins, eye_points)
        directions = _normalize_rows(vectors.apply_each(linear, local_directions, np.zeros_like(eye_points)))
        return CameraRays(origins=origins, directions=directions, t_max=t_max, valid=valid, time=time)
    # Camera-local to world: points get rotation and translation, directions rotation only.
    rotation = camera.matrix_world[:3, :3]
    eye_point = camera.matrix_world[:3, 3]
    # Column by column (core/vectors.py), not @: a matrix product of this size would start BLAS
    # threads that fight the render's own.
    origins = vectors.transform(local_origins, rotation, eye_point)
    directions = vectors.transform(local_directions, rotation, np.zeros(3))
    if not _is_rotation(rotation):
        # A sheared parent leaves the axes unit but not orthogonal: directions lose unit length.
        directions = _normalize_rows(directions)
    if time is not None:
        time = np.broadcast_to(np.asarray(time, np.float64), raster_x.shape)
    return CameraRays(origins=origins, directions=directions, t_max=t_max, valid=valid, time=time)


def _is_rotation(matrix: np.ndarray) -> bool:
    """Return whether a (3, 3) float64 matrix is orthonormal (it then keeps unit vectors unit).

    M^T M by einsum, not `@`: numpy hands `@` to OpenBLAS, whose threads, woken right after Embree's
    BVH build, took 0.5 ms for these nine products (core/vectors.py, determinant_and_inverse).
    """
    gram = np.einsum("ki,kj->ij", matrix, matrix)
    return bool(np.abs(gram - np.eye(3)).max() <= 1e-12)            # (False for NaN, as allclose)


# ---------------------------------------------------------------------------
# The compiled twin (core/camera/camera.c)
# ---------------------------------------------------------------------------

CameraRecord = schema.record("CameraRecord", "The camera, prepared by core/camera/camera.py (`camera_record`).", [
    ("kind", I32, "CAMERA_*"),
    ("renormalize", I32, "1 when the rotation is not orthonormal (a sheared parent)"),
    ("left", F64, "camera.viewplane (PERSP, ORTHO)"),
    ("right", F64, ""),
    ("bottom", F64, ""),
    ("top", F64, ""),
    ("clip_start", F64, ""),
    ("clip_end", F64, ""),
    ("rotation", F64, 9, "camera-to-world rotation, row-major"),
    ("eye", F64, 3, "the camera's position minus the geometry's origin"),
    ("shift_x", F64, "fisheye: the panorama shift"),
    ("shift_y", F64, ""),
    ("scale_x", F64, "fisheye: the image plane is ((u - 0.5) scale_x, (v - 0.5) scale_y)"),
    ("scale_y", F64, ""),
    ("limit", F64, "fisheye: the image circle's radius on that plane"),
    ("fisheye_fov", F64, ""),
    ("fisheye_lens", F64, ""),
    ("filter_table", ptr(F64), "(FILTER_TABLE_SIZE,) the pixel filter's inverse CDF (core/camera/filter.py); "
                               "NULL for a 1-pixel box: the sample's point stays where it is drawn"),
    ("range", F64, 4, "panorama_directions' spans: EQUIRECTANGULAR longitude min, max, latitude min, max; "
                      "CENTRAL_CYLINDRICAL u min, max, v min / radius, v max / radius"),
    ("polynomial", F64, 5, "FISHEYE_LENS_POLYNOMIAL: k0 .. k4"),
    ("aperture_size", F64, "depth of field (PERSP, ORTHO): the aperture's radius, 0 for a pinhole"),
    ("focus_distance", F64, ""),
    ("aperture_blades", I32, "fewer than 3: a round aperture"),
    ("aperture_rotation", F64, ""),
    ("aperture_ratio", F64, ""),
    ("shutter_table", ptr(F64), "(SHUTTER_TABLE_SIZE,) motion.shutter_table; NULL without motion blur (time 1/2)"),
    ("rolling", I32, "1: a rolling shutter, the top row first (motion.rolling_times)"),
    ("rolling_duration", F64, ""),
    ("motion_steps", I32, "the camera's transforms over the shutter; 0: it stands still"),
    ("motion", ptr(F64), "(motion_steps, MOTION_STRIDE) motion.decompose, translations minus the geometry's origin"),
    ("fov_motion", I32, "1: a perspective camera's image plane scales over the shutter (motion.plane_scales)"),
    ("fov_pre", F64, "tan(fov / 2) at the shutter's open over at its middle"),
    ("fov_post", F64, "... at its close"),
])
# The sampling dimension of a camera ray's point on the aperture (depth of field).
LENS_DIMENSION = schema.constant("LENS_DIMENSION", 1, "the sampling dimension of a camera ray's point on the lens")
# The camera types camera.c knows: CAMERA_PERSP, ...
_KINDS = schema.constants("CAMERA", ("PERSP", "ORTHO") + PANORAMA_TYPES, "camera.c's camera types")

CameraRaysArgs = schema.function("primer_camera_rays", "camera_rays", schema.record("CameraRaysArgs", "primer_camera_rays' arguments: the camera rays of spp samples in each of p pixels.", [
    ("camera", ptr("CameraRecord"), ""),
    ("seed", I64, ""),
    ("width", I64, ""),
    ("height", I64, ""),
    ("pixels", ptr(I64), "(p,)"),
    ("first", ptr(I64), "(p,) each pixel's first sample"),
    ("p", I64, ""),
    ("spp", I64, ""),
    ("origins", out(F64), "(p spp, 3)"),
    ("directions", out(F64), "(p spp, 3)"),
    ("t_max", out(F64), "(p spp,)"),
    ("valid", out(U8), "(p spp,)"),
    ("time", out(F64), "(p spp,) each ray's time in the shutter"),
]))


def camera_record(camera: Camera, width: int, height: int, pixel_aspect: tuple, origin: np.ndarray,
                  pixel_filter: Optional[PixelFilter] = None):
    """Return the camera's C record: everything generate_rays needs that does not depend on the sample.

    origin: (3,) float64 the geometry's origin, subtracted from the camera's position (camera-relative);
    pixel_filter: where samples land around their pixel (None: a 1-pixel box).
    """
    record = CameraRecord(kind=_KINDS[camera.type if camera.type != "PANO" else camera.panorama_type])
    if camera.type in ("PERSP", "ORTHO"):
        record.left, record.right, record.bottom, record.top = viewplane(camera, width, height, pixel_aspect)
    else:
        record.shift_x, record.shift_y = camera.shift_x, camera.shift_y
        record.scale_x, record.scale_y, record.limit = _fisheye_plane(camera, width, height, pixel_aspect)
        record.fisheye_fov, record.fisheye_lens = camera.fisheye_fov, camera.fisheye_lens
        if camera.panorama_type == "EQUIRECTANGULAR":
            record.range = np.array([camera.longitude_min, camera.longitude_max, camera.latitude_min,
                                     camera.latitude_max], np.float64)
        elif camera.panorama_type == "CENTRAL_CYLINDRICAL":
            record.range = np.array([camera.cylinder_u_min, camera.cylinder_u_max,
                                     camera.cylinder_v_min / camera.cylinder_radius,
                                     camera.cylinder_v_max / camera.cylinder_radius], np.float64)
        record.polynomial = np.asarray(camera.fisheye_polynomial, np.float64)
    record.clip_start, record.clip_end = camera.clip_start, camera.clip_end
    if has_depth_of_field(camera):
        record.aperture_size, record.focus_distance = camera.aperture_size, camera.focus_distance
        record.aperture_blades, record.aperture_rotation = int(camera.aperture_blades), camera.aperture_rotation
        record.aperture_ratio = camera.aperture_ratio
    rotation = np.asarray(camera.matrix_world, np.float64)[:3, :3]
    record.rotation = rotation.ravel()
    record.eye = np.asarray(camera.matrix_world, np.float64)[:3, 3] - origin
    record.renormalize = not _is_rotation(rotation)
    if pixel_filter is not None and not pixel_filter.is_identity:
        record.filter_table = pixel_filter.table()
    if camera.shutter is not None:                  # motion blur: each ray's time, and the camera then
        record.shutter_table = np.ascontiguousarray(camera.shutter.table, np.float64)
        record.rolling, record.rolling_duration = int(camera.shutter.rolling), float(camera.shutter.rolling_duration)
        if camera.moves and len(camera.motion) >= 2:
            steps = motion_.decompose([np.asarray(m) for m in camera.motion])
            steps[:, 4:7] -= origin
            record.motion_steps, record.motion = len(steps), np.ascontiguousarray(steps.ravel())
        if camera.moves and camera.type == "PERSP" and camera.fov_motion:
            record.fov_motion = 1
            record.fov_pre, record.fov_post = (float(v) for v in camera.fov_motion)
    return record


def compiled_rays(record, seed: int, width: int, height: int, pixels: np.ndarray, first: np.ndarray, spp: int,
                  times: bool = False):
    """The camera rays of spp samples in each pixel, camera-relative, from camera.c (for the tests).

    pixels, first: (p,) int64 -> origins, directions (p spp, 3) float64, t_max (p spp,) float64, valid (p spp,) bool,
    and with times=True each ray's time (p spp,) float64 after them
    """
    from ..native import library
    pixels, first = library.contiguous(pixels, np.int64), library.contiguous(first, np.int64)
    n = len(pixels) * spp
    origins, directions, t_max, valid = np.empty((n, 3)), np.empty((n, 3)), np.empty(n), np.empty(n, np.uint8)
    time = np.empty(n)
    library.call("primer_camera_rays", CameraRaysArgs(
        camera=record, seed=int(seed), width=int(width), height=int(height), pixels=pixels, first=first,
        p=len(pixels), spp=int(spp), origins=origins, directions=directions, t_max=t_max, valid=valid, time=time))
    if times:
        return origins, directions, t_max, valid.astype(bool), time
    return origins, directions, t_max, valid.astype(bool)
