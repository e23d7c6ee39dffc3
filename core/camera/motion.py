"""Motion blur of the camera: when in the shutter each camera ray looks, and where the camera is then.

A real shutter stays open for a while, and a camera that moves meanwhile smears the picture. Cycles renders this by
giving every camera ray its own *time* in the shutter, a number in [0, 1] (0 when it opens, 1 when it closes), and
placing the camera where it is at that time. Primer does the same, in both kernels (camera.py, camera.c):

* **The time** is a sampling dimension of its own (TIME_DIMENSION), drawn through the **shutter curve**: Render >
  Motion Blur > Shutter Curve says how open the shutter is over its time (a box: fully open throughout). Cycles turns
  the curve (257 values) into the table of its inverse CDF (`scene/camera.cpp` shutter_table, `util/math_cdf.*`,
  SHUTTER_TABLE_SIZE entries) and reads it at the uniform number by linear interpolation, as the pixel filter's table
  (core/camera/filter.py `offsets`). The table is built here the way Cycles builds it, in float32, with one of its
  quirks kept because it is what Cycles renders: its curve lookup reads the entry *before* the curve at time 0, which
  is the high half of Blender's allocation size, 0, so the curve's first point weighs nothing (the shutter opens
  about 1/256 late, and a box shutter spans the times 0.006 to 0.994).
* **Rolling shutter** (Cycles' Rolling Shutter, Top to Bottom): a sensor read row by row, the top row first. A row r
  of H (Primer's rows from the top) is read at 1 - y / H with Cycles' y = H - 1 - r from the bottom, that is
  (r + 1) / H; its Duration d blends the two: time = (t - 1/2) d + (row time - 1/2)(1 - d) + 1/2.
* **Where the camera is**: the add-on reads the camera's matrix at `steps` times evenly spread over the shutter
  (Cycles' motion steps of the camera object, 2^steps + 1 of them; three by default: open, middle, close). Cycles
  decomposes each into a translation, a rotation quaternion and a scale with shear (the upper-triangular factor of
  Gram-Schmidt on its columns, `util/transform.cpp` transform_decompose), turns each quaternion to lie on the same
  side as the one before (the shorter way round), and at a ray's time interpolates between the two steps around it:
  the translation, scale and shear linearly, the rotation by spherical interpolation (linear and renormalised when
  the two are within 0.9995 in cosine), then composes them again (`util/transform.h`
  transform_motion_array_interpolate). The decomposition is written here once per render (`decompose`), in the
  layout of Cycles' DecomposedTransform (MOTION_STRIDE numbers a step), which camera.c reads.
* **Field of view**: a perspective camera whose focal length or sensor changes over the shutter gets its image plane
  scaled (Cycles' perspective motion): the plane's point at time t is the one at the middle scaled by the
  interpolation of tan(fov / 2) between the shutter's open, middle and close, linear on each half.

Without motion blur a ray's time is 1/2 and the camera is where its matrix says.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..native import schema
from .filter import offsets

__all__ = ["SHUTTER_TABLE_SIZE", "TIME_DIMENSION", "MOTION_STRIDE", "Shutter", "shutter_table", "ray_times",
           "rolling_times", "decompose", "interpolate", "plane_scales"]

SHUTTER_TABLE_SIZE = schema.constant("SHUTTER_TABLE_SIZE", 256, "entries of the shutter curve's table (Cycles' size)")
TIME_DIMENSION = schema.constant("TIME_DIMENSION", 4, "the sampling dimension of a camera ray's time in the shutter")
MOTION_STRIDE = schema.constant("MOTION_STRIDE", 16, "numbers of one decomposed camera transform (motion.decompose)")
# The number of the curve's values Cycles reads (RAMP_TABLE_SIZE + 1: Blender's sync, curvemapping_to_array, evaluates
# the curve at i / RAMP_TABLE_SIZE for i = 0 .. RAMP_TABLE_SIZE), sampled at i / (CURVE_POINTS - 1).
CURVE_POINTS = 257

_F32 = np.float32


def _curve_at(curve: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cycles' shutter_curve_eval at x ((n,) float32 in [0, 1]): the curve (CURVE_POINTS,) float32 read at
    x * size - 1, linear between entries; index -1 (x = 0) reads the allocation's header before the array, 0."""
    size = len(curve)
    position = np.clip(x, _F32(0.0), _F32(1.0)) * _F32(size) - _F32(1.0)
    index = np.trunc(position).astype(np.int64)                  # (C's int conversion: towards zero)
    frac = position - index.astype(_F32)
    padded = np.concatenate([np.zeros(1, _F32), curve, curve[-1:]])   # padded[k + 1] = curve[k], curve[-1] = 0
    a, b = padded[index + 1], padded[np.minimum(index + 2, size + 1)]
    return np.where(index < size - 1, a + frac * (b - a), curve[-1]).astype(_F32)


def shutter_table(curve) -> np.ndarray:
    """Cycles' inverse-CDF table of the shutter curve: (SHUTTER_TABLE_SIZE,) float64 times (exact float32 values).

    curve: (CURVE_POINTS,) the curve's values at i / (CURVE_POINTS - 1), as Blender's CurveMapping gives them
    (curvemapping_to_array); entry k of the table is the time of the uniform number k / (SHUTTER_TABLE_SIZE - 1).
    Built as Cycles' util_cdf_inverted (not symmetric) does, in float32.
    """
    curve = np.asarray(curve, _F32).reshape(-1)
    size = SHUTTER_TABLE_SIZE
    # 1. The CDF: the curve at size - 1 points of [0, 1], a running sum of their magnitudes, normalised, last 1.
    points = size - 1
    x = np.arange(points, dtype=_F32) / _F32(points - 1)
    cdf = np.zeros(points + 1, _F32)
    cdf[1:] = np.cumsum(np.abs(_curve_at(curve, x)), dtype=_F32)
    total = cdf[points]
    cdf *= _F32(0.0) if total == 0 else _F32(1.0) / total
    cdf[points] = _F32(1.0)
    # 2. Its inverse at the middles of size cells: the CDF interval holding u, linear within it.
    u = (np.arange(size, dtype=_F32) + _F32(0.5)) * (_F32(1.0) / _F32(size))
    index = np.searchsorted(cdf, u, side="right") - 1                # the last CDF value at or below u
    inside = index < len(cdf) - 1
    inner = np.minimum(index, len(cdf) - 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(inside, (u - cdf[inner]) / (cdf[inner + 1] - cdf[inner]), _F32(0.0)).astype(_F32)
    index = np.where(inside, index, size).astype(_F32)
    return ((index + t) * (_F32(1.0) / _F32(size))).astype(_F32).astype(np.float64)


def rolling_times(time: np.ndarray, row: np.ndarray, height: int, duration: float) -> np.ndarray:
    """Cycles' rolling shutter, the top row first: each ray's time (n,) float64 moved towards its row's, row (n,)
    int64 the pixel's row from the top of an image `height` rows high; duration 0: the row's time alone."""
    row_time = (np.asarray(row, np.float64) + 1.0) / float(height)
    if duration == 0.0:
        return row_time
    return (time - 0.5) * duration + (row_time - 0.5) * (1.0 - duration) + 0.5


@dataclass(frozen=True, eq=False)
class Shutter:
    """Render > Motion Blur as the camera's rays see it: the shutter curve's table (shutter_table) and the rolling
    shutter (Cycles' Rolling Shutter type Top to Bottom and its Duration)."""

    table: np.ndarray                  # (SHUTTER_TABLE_SIZE,) float64, shutter_table
    rolling: bool = False
    rolling_duration: float = 0.1

    @classmethod
    def box(cls, **kw) -> "Shutter":
        """The shutter fully open throughout (Blender's default curve)."""
        return cls(table=shutter_table(np.ones(CURVE_POINTS, _F32)), **kw)


def ray_times(shutter: Shutter, u: np.ndarray, row: np.ndarray, height: int) -> np.ndarray:
    """The times in the shutter (n,) float64 in [0, 1] of rays with uniform numbers u (n,) float64 in pixels of rows
    `row` (n,) int64 (from the top): the shutter curve's table read at u, then the rolling shutter."""
    time = offsets(shutter.table, np.asarray(u, np.float64))
    if shutter.rolling:
        time = rolling_times(time, row, height, float(shutter.rolling_duration))
    return time


# ---------------------------------------------------------------------------
# The camera's transform over the shutter
# ---------------------------------------------------------------------------

def _quaternion(rotation: np.ndarray) -> np.ndarray:
    """The unit quaternion (x, y, z, w) of a (3, 3) rotation (Cycles' transform_to_quat: the largest of w, x, y, z
    taken from the trace or the diagonal, the others from the off-diagonal sums and differences)."""
    m = rotation
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = math.sqrt(trace + 1.0)
        w, s = s / 2.0, 0.5 / s
        return np.array([(m[2, 1] - m[1, 2]) * s, (m[0, 2] - m[2, 0]) * s, (m[1, 0] - m[0, 1]) * s, w])
    i = 0
    if m[1, 1] > m[i, i]:
        i = 1
    if m[2, 2] > m[i, i]:
        i = 2
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(m[i, i] - (m[j, j] + m[k, k]) + 1.0)
    q = np.zeros(4)
    q[i] = 0.5 * s
    s = 0.5 / s if s != 0.0 else s
    q[3] = (m[k, j] - m[j, k]) * s
    q[j] = (m[j, i] + m[i, j]) * s
    q[k] = (m[k, i] + m[i, k]) * s
    return q


def _decompose_one(matrix: np.ndarray) -> np.ndarray:
    """One (4, 4) float64 transform as Cycles' DecomposedTransform: (MOTION_STRIDE,) float64 = quaternion (x, y, z,
    w), translation and scale x, shear xy, shear xz, 0, scale y, shear yz, 0, 0, scale z."""
    columns = [np.array(matrix[:3, c], np.float64) for c in range(3)]
    x, y, z = columns
    scale_x = float(np.linalg.norm(x))
    x = x / scale_x if scale_x != 0.0 else x * 0.0
    shear_xy = float(x @ y)
    y = y - shear_xy * x
    scale_y = float(np.linalg.norm(y))
    y = y / scale_y if scale_y != 0.0 else y * 0.0
    shear_xz = float(x @ z)
    z = z - shear_xz * x
    shear_yz = float(y @ z)
    z = z - shear_yz * y
    scale_z = float(np.linalg.norm(z))
    z = z / scale_z if scale_z != 0.0 else z * 0.0
    rotation = np.stack([x, y, z], axis=1)
    sign = 1.0
    if np.linalg.det(rotation) < 0.0:                  # a mirror: negate the scale and the axes (a rotation again)
        sign, rotation = -1.0, -rotation
    out = np.zeros(MOTION_STRIDE)
    out[0:4] = _quaternion(rotation)
    out[4:7] = matrix[:3, 3]
    out[7] = sign * scale_x
    out[8], out[9], out[11] = shear_xy, shear_xz, sign * scale_y
    out[12], out[15] = shear_yz, sign * scale_z
    return out


def decompose(matrices) -> np.ndarray:
    """Cycles' transform_motion_decompose: the camera's (4, 4) matrices at its motion steps -> (steps, MOTION_STRIDE)
    float64, each quaternion on the side of the one before, and a step of zero scale given its neighbour's rotation."""
    steps = np.stack([_decompose_one(np.asarray(m, np.float64)) for m in matrices])
    for i in range(1, len(steps)):
        if steps[i - 1, :4] @ steps[i, :4] < 0.0:
            steps[i, :4] = -steps[i, :4]
    for i in range(len(steps)):
        if steps[i, 7] == 0.0 and steps[i, 11] == 0.0 and steps[i, 15] == 0.0 and len(steps) > 1:
            steps[i, :4] = steps[i - 1, :4] if i > 0 else steps[i + 1, :4]
    return steps


def _slerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Cycles' quat_interpolate, row by row: a, b (n, 4) unit quaternions, t (n,) -> (n, 4)."""
    cos = np.einsum("ij,ij->i", a, b)
    near = cos > 0.9995
    mixed = (1.0 - t)[:, None] * a + t[:, None] * b
    mixed = mixed / np.linalg.norm(mixed, axis=1)[:, None]
    theta = np.arccos(np.clip(cos, -1.0, 1.0))
    across = b - a * cos[:, None]
    length = np.linalg.norm(across, axis=1)
    across = across / np.where(length > 0.0, length, 1.0)[:, None]
    turned = a * np.cos(theta * t)[:, None] + across * np.sin(theta * t)[:, None]
    return np.where(near[:, None], mixed, turned)


def interpolate(steps: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The camera's transform at each ray's time: steps (s, MOTION_STRIDE) from `decompose` (s >= 2), time (n,)
    float64 in [0, 1] -> linear part (n, 3, 3) and translation (n, 3) float64 (transform_motion_array_interpolate)."""
    last = len(steps) - 1
    time = np.asarray(time, np.float64)
    step = np.minimum((time * last).astype(np.int64), last - 1)
    t = time * last - step
    a, b = steps[step], steps[step + 1]
    q = _slerp(a[:, :4], b[:, :4], t)
    rest = (1.0 - t)[:, None] * a[:, 4:] + t[:, None] * b[:, 4:]
    # The rotation of the quaternion (x, y, z, w), written out as Cycles composes it.
    qx, qy, qz, qw = (math.sqrt(2.0) * q[:, c] for c in range(4))
    rotation = np.empty((len(time), 3, 3))
    rotation[:, 0] = np.stack([1.0 - qy * qy - qz * qz, -qw * qz + qx * qy, qw * qy + qx * qz], axis=1)
    rotation[:, 1] = np.stack([qw * qz + qx * qy, 1.0 - qx * qx - qz * qz, -qw * qx + qy * qz], axis=1)
    rotation[:, 2] = np.stack([-qw * qy + qx * qz, qw * qx + qy * qz, 1.0 - qx * qx - qy * qy], axis=1)
    # The scale with shear: the upper-triangular factor, columns (sx, 0, 0), (xy, sy, 0), (xz, yz, sz).
    scale = np.zeros((len(time), 3, 3))
    scale[:, 0, 0], scale[:, 0, 1], scale[:, 0, 2] = rest[:, 3], rest[:, 4], rest[:, 5]
    scale[:, 1, 1], scale[:, 1, 2], scale[:, 2, 2] = rest[:, 7], rest[:, 8], rest[:, 11]
    linear = np.einsum("nij,njk->nik", rotation, scale)
    return linear, rest[:, :3].copy()


def embree_steps(steps: np.ndarray) -> np.ndarray:
    """The motion steps of `decompose` as Embree's RTCQuaternionDecomposition (its instances' quaternion motion: the
    transform T R S, the same factors as Cycles', S upper-triangular with no shift): (s, MOTION_STRIDE) float64 ->
    (s, 16) float32 = scale x, y, z, skew xy, xz, yz, shift x, y, z, quaternion r (w), i, j, k, translation."""
    out = np.zeros((len(steps), 16), np.float32)
    out[:, 0], out[:, 1], out[:, 2] = steps[:, 7], steps[:, 11], steps[:, 15]
    out[:, 3], out[:, 4], out[:, 5] = steps[:, 8], steps[:, 9], steps[:, 12]
    out[:, 9] = steps[:, 3]
    out[:, 10:13] = steps[:, 0:3]
    out[:, 13:16] = steps[:, 4:7]
    return out


def plane_scales(fov_motion: tuple, time: np.ndarray) -> np.ndarray:
    """How much each ray's point on a perspective camera's image plane is scaled at its time (n,) float64: fov_motion
    (pre, post) the ratios tan(fov / 2) at the shutter's open and close over at its middle; linear on each half."""
    pre, post = fov_motion
    time = np.asarray(time, np.float64)
    return np.where(time < 0.5, pre + (1.0 - pre) * (time * 2.0), 1.0 + (post - 1.0) * ((time - 0.5) * 2.0))
