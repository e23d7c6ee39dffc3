"""IES light profiles: an LM-63 photometric file read as Cycles reads it, and evaluated as Cycles' IES Texture does.

A luminaire's maker measures how much light it sends in each direction and writes the candela values on a grid of
angles: vertical angles (0 straight down, 180 straight up) and horizontal ones around the axis. Cycles
(intern/cycles/util/ies.cpp) reads the file's numbers, scales the candela by the file's multiplier, ballast factor and
ballast-lamp photometric factor and by 4 pi / 177.83 (candela to a lamp strength in watts, for a light of D65's
luminous efficacy 177.83 lm/W: no normalisation by the maximum), expands the photometric type's symmetries to a full
0-360 degree horizontal range, and stores angles in radians and values as 32-bit floats (`parse_ies`). Its kernel
(kernel/util/ies.h kernel_ies_interp) interpolates the grid with Catmull-Rom cubics, vertically then horizontally,
wrapping around the horizontal circle and mirroring at the poles; values outside the table are 0 (`evaluate`). The
IES Texture node (kernel/svm/ies.h) turns its Vector into the angles: v = acos(-z), h = atan2(x, y) + pi, and
gives Strength x the interpolated value (`ies_fac`); a file Cycles cannot read gives Strength x 100.

The node's Vector defaults to Cycles' Geometry > Incoming taken into the object's frame by the normal transform
(transposed object matrix; shader_graph.cpp's LINK_TEXTURE_INCOMING). Lamps (core/lights/ies.py IESLamp) and the
material node compiler (the IES_TEXTURE op, core/materials/converters/ies_texture.py) both evaluate profiles here.
The C twin is core/materials/ies.c; `table` lays a profile out for it (the lamp's record and a program's table floats).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..native import library, schema
from ..native.schema import F64, I32, I64, ptr

# Cycles' candela-to-watt factor: 4 pi / 177.83 (D65's luminous efficacy), as util/ies.cpp writes it.
CANDELA_TO_WATT = 0.0706650768394
# What Cycles' kernel gives for an IES it could not read (kernel_ies_interp's offset -1).
UNREAD_VALUE = schema.constant("IES_UNREAD_VALUE", 100.0, "what an IES Texture without a readable file gives per unit "
                                                         "Strength (Cycles' kernel_ies_interp without a table)")
_F32 = np.float32


@dataclass(frozen=True)
class IESProfile:
    """A profile as Cycles stores it after reading (float32 values held as float64).

    h_angles: (h,) float64 radians, ascending (a full circle ends at 2 pi)
    v_angles: (v,) float64 radians, ascending, within [0, pi]
    intensity: (h, v) float64 watts per steradian x 4 pi: candela x the file's factors x CANDELA_TO_WATT
    """

    h_angles: np.ndarray
    v_angles: np.ndarray
    intensity: np.ndarray


# The numbers C's strtod and strtol read after skipping white space (Cycles' IESTextParser).
_DOUBLE = re.compile(r"\s*([+-]?(?:\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?))")
_LONG = re.compile(r"\s*([+-]?\d+)")


class _Numbers:
    """The numbers of a text read one by one as strtod / strtol read them; a failed read marks an error."""

    def __init__(self, text: str, at: int):
        self.text, self.at, self.error = text, at, False

    def number(self, pattern, cast):
        """The next number `pattern` matches at the cursor (cast), or 0 and an error."""
        found = pattern.match(self.text, self.at) if self.at is not None else None
        if found is None:
            self.at, self.error = None, True
            return cast(0)
        self.at = found.end()
        return cast(found.group(1))

    def double(self) -> float:
        """strtod's number."""
        return self.number(_DOUBLE, float)

    def long(self) -> int:
        """strtol's number."""
        return self.number(_LONG, int)


def _read(text: str):
    """Cycles' IESFile::parse: (photometric type, v angles (v,) float32 degrees, h angles (h,) float32 degrees,
    intensity list of h rows of (v,) float32), or None where Cycles refuses the file."""
    text = text.replace(",", " ")
    at = text.find("\nTILT=")
    if at < 0:
        return None
    if text.startswith("\nTILT=INCLUDE", at):
        numbers = _Numbers(text, at + 13)
        numbers.double()                                    # lamp to luminaire geometry
        for _ in range(2 * numbers.long()):                 # the tilt angles and factors, skipped
            numbers.double()
        at = numbers.at
    else:
        at = text.find("\n", at + 1)                         # the rest of the TILT line
        at = None if at < 0 else at
    if at is None or at >= len(text):
        return None
    numbers = _Numbers(text, at + 1)
    numbers.long()                                          # number of lamps
    numbers.double()                                        # lumens per lamp
    factor = numbers.double()                               # candela multiplier
    v_count, h_count = numbers.long(), numbers.long()
    kind = numbers.long()                                   # photometric type: 1 C, 2 B, 3 A
    if kind not in (1, 2, 3):
        return None
    numbers.long()                                          # units
    numbers.double(), numbers.double(), numbers.double()    # width, length, height
    factor *= numbers.double()                              # ballast factor
    factor *= numbers.double()                              # ballast-lamp photometric factor
    numbers.double()                                        # input watts
    factor *= CANDELA_TO_WATT
    v_angles = np.array([numbers.double() for _ in range(max(v_count, 0))], _F32)
    h_angles = np.array([numbers.double() for _ in range(max(h_count, 0))], _F32)
    rows = [np.array([factor * numbers.double() for _ in range(max(v_count, 0))], np.float64).astype(_F32)
            for _ in range(max(h_count, 0))]
    if numbers.error:
        return None
    return kind, v_angles, h_angles, rows


def _close(a, b) -> bool:
    """Cycles' angle_close: |a - b| < 1e-4 in float32."""
    return bool(abs(_F32(a) - _F32(b)) < _F32(1e-4))


def _type_c(h: list, rows: list):
    """Cycles' IESFile::process_type_c: rotate a 90-270 file, mirror one quadrant and a half to the full circle, add
    a missing 360 degree column. h: float32 degrees; rows: one (v,) per h (both lists, changed in place)."""
    if _close(h[0], 90.0):
        h[:] = [x - _F32(90.0) for x in h]
    if len(h) == 1:
        h[0] = _F32(0.0)
        h.append(_F32(360.0))
        rows.append(rows[0])
    if _close(h[-1], 90.0):
        for i in range(len(h) - 2, -1, -1):
            h.append(_F32(180.0) - h[i])
            rows.append(rows[i])
    if _close(h[-1], 180.0):
        for i in range(len(h) - 2, -1, -1):
            h.append(_F32(360.0) - h[i])
            rows.append(rows[i])
    if _close(h[0], 0.0) and not _close(h[-1], 360.0) and len(h) > 1:
        last, first, gap = h[-1] - h[-2], h[1] - h[0], _F32(360.0) - h[-1]
        if _close(last, gap) or _close(first, gap):
            h.append(_F32(360.0))
            rows.append(rows[0])
    return h, rows


def _type_b(v: list, h: list, rows: list):
    """Cycles' IESFile::process_type_b: transpose to type C's axes, mirror 0-90 ranges to -90-90, shift to 0-180."""
    rows = [np.array([rows[j][i] for j in range(len(h))], _F32) for i in range(len(v))]
    h, v = v, h
    if _close(h[0], 0.0):
        n = len(h)
        h = [_F32(90.0) - h[i] for i in range(n - 1, 0, -1)] + [_F32(90.0) + h[i] for i in range(n)]
        rows = [rows[i] for i in range(n - 1, 0, -1)] + [rows[i] for i in range(n)]
    else:
        h = [x + _F32(90.0) for x in h]
    if _close(v[0], 0.0):
        n = len(v)
        v = [_F32(90.0) - v[i] for i in range(n - 1, 0, -1)] + [_F32(90.0) + v[i] for i in range(n)]
        rows = [np.concatenate([row[n - 1:0:-1], row]) for row in rows]
    else:
        v = [x + _F32(90.0) for x in v]
    return v, h, rows


def _type_a(v: list, h: list, rows: list):
    """Cycles' IESFile::process_type_a: vertical angles shifted by 90, horizontal -90..90 mapped to 270..90."""
    v = [x + _F32(90.0) for x in v]
    new_h = [_F32(180.0) - h[i] for i in range(len(h) - 1, -1, -1)]
    new_rows = [rows[i] for i in range(len(h) - 1, -1, -1)]
    if _close(h[0], 0.0):
        new_h += [_F32(180.0) + h[i] for i in range(1, len(h))]
        new_rows += [rows[i] for i in range(1, len(h))]
    return v, new_h, new_rows


def parse_ies(text: str) -> Optional[IESProfile]:
    """Read an IES (LM-63) file's text as Cycles' IESFile::load does; None where Cycles cannot read it."""
    read = _read(text)
    if read is None:
        return None
    kind, v_angles, h_angles, rows = read
    if len(h_angles) == 0 or len(v_angles) == 0:
        return None
    v, h = list(v_angles), list(h_angles)
    if kind == 1:
        h, rows = _type_c(h, rows)
    elif kind == 2:
        v, h, rows = _type_b(v, h, rows)
    else:
        v, h, rows = _type_a(v, h, rows)
    to_radians = _F32(_F32(math.pi) / _F32(180.0))
    return IESProfile(h_angles=(np.array(h, _F32) * to_radians).astype(np.float64),
                      v_angles=(np.array(v, _F32) * to_radians).astype(np.float64),
                      intensity=np.array(rows, _F32).reshape(len(h), len(v)).astype(np.float64))


def cubic(a, b, c, d, x):
    """Cycles' cubic_interp: the Catmull-Rom cubic through b (x = 0) and c (x = 1), with neighbours a and d."""
    return 0.5 * (((d + 3.0 * (b - c) - a) * x + (2.0 * a - 5.0 * b + 4.0 * c - d)) * x + (c - a)) * x + b


def wraps(profile: IESProfile) -> tuple:
    """Cycles' wrap flags (wrap_h, wrap_vlow, wrap_vhigh), in its 32-bit floats: whether the table closes the circle
    (h from below 1e-7 to above 2 pi - 1e-7) and reaches each pole (v below 1e-7, v above pi - 1e-7). In float32,
    2 pi - 1e-7 and pi - 1e-7 round back to 2 pi and pi, which a table's 360 and 180 degrees equal: Cycles' lookups
    of a full circle do not wrap, nor at v = 180 degrees; only v = 0 mirrors."""
    tiny = _F32(1e-7)
    return (bool(_F32(profile.h_angles[0]) < tiny and _F32(profile.h_angles[-1]) > _F32(2.0 * math.pi) - tiny),
            bool(_F32(profile.v_angles[0]) < tiny), bool(_F32(profile.v_angles[-1]) > _F32(math.pi) - tiny))


def evaluate(profile: IESProfile, h_angle: np.ndarray, v_angle: np.ndarray) -> np.ndarray:
    """Cycles' kernel_ies_interp: the profile at angles (n,) float64 radians -> (n,) float64, 0 outside its table.

    Catmull-Rom along v in four columns around h, then along h; a missing neighbour is the one across the pole or
    across 0 = 360 degrees where Cycles wraps (`wraps`), else it repeats a value inside as Cycles does: along v the
    nearest, along h the near inner column at both ends.
    """
    H, V, I = profile.h_angles, profile.v_angles, profile.intensity
    h_num, v_num = len(H), len(V)
    h_angle, v_angle = np.asarray(h_angle, np.float64), np.asarray(v_angle, np.float64)
    if h_num < 2 or v_num < 2:                          # (no angle lies inside a table of one row)
        return np.zeros(np.broadcast(h_angle, v_angle).shape)
    inside = (v_angle >= V[0]) & (v_angle < V[-1]) & (h_angle >= H[0]) & (h_angle < H[-1])
    h_c = np.where(inside, h_angle, H[0])
    v_c = np.where(inside, v_angle, V[0])
    wrap_h, wrap_vlow, wrap_vhigh = wraps(profile)
    h_i = np.minimum(np.searchsorted(H[1:], h_c, side="left"), h_num - 2)
    v_i = np.minimum(np.searchsorted(V[1:], v_c, side="left"), v_num - 2)
    h_frac = (h_c - H[h_i]) / (H[h_i + 1] - H[h_i])
    v_frac = (v_c - V[v_i]) / (V[v_i + 1] - V[v_i])

    def column(h):
        """interpolate_ies_vertical at column h (n,) int."""
        b, c = I[h, v_i], I[h, v_i + 1]
        a = np.where(v_i > 0, I[h, np.maximum(v_i - 1, 0)], I[h, 1] if wrap_vlow else b)
        d = np.where(v_i + 2 < v_num, I[h, np.minimum(v_i + 2, v_num - 1)], I[h, v_num - 2] if wrap_vhigh else c)
        return cubic(a, b, c, d, v_frac)

    b, c = column(h_i), column(h_i + 1)
    a = np.where(h_i > 0, column(np.maximum(h_i - 1, 0)), column(np.full_like(h_i, h_num - 2)) if wrap_h else b)
    d = np.where(h_i + 2 < h_num, column(np.minimum(h_i + 2, h_num - 1)), column(np.ones_like(h_i)) if wrap_h else b)
    return np.where(inside, np.maximum(cubic(a, b, c, d, h_frac), 0.0), 0.0)


def angles(vectors: np.ndarray):
    """svm_node_ies's angles of directions (n, 3) float64 (any length): (h, v) each (n,) float64 radians."""
    length = np.linalg.norm(vectors, axis=1)
    unit = vectors / np.where(length > 0.0, length, 1.0)[:, None]
    v = np.arccos(np.clip(-unit[:, 2], -1.0, 1.0))
    h = np.arctan2(unit[:, 0], unit[:, 1]) + math.pi
    return h, v


def ies_fac(profile: Optional[IESProfile], strength, vectors: np.ndarray) -> np.ndarray:
    """The IES Texture node's Fac for Vectors (n, 3) float64: Strength (a float or (n,) float64) x the profile there;
    (n,) float64. profile None (a file Cycles could not read): Strength x 100 everywhere."""
    if profile is None:
        return np.broadcast_to(np.asarray(strength, np.float64) * UNREAD_VALUE, (len(vectors),)).copy()
    h, v = angles(vectors)
    return strength * evaluate(profile, h, v)


def table(profile: IESProfile) -> np.ndarray:
    """The profile laid out for C (core/materials/ies.c): h angles, v angles, then intensity by h then v; (h + v + h v,)."""
    return np.concatenate([profile.h_angles, profile.v_angles, profile.intensity.ravel()]).astype(np.float64)


def from_table(floats: np.ndarray, h_num: int, v_num: int) -> Optional[IESProfile]:
    """The profile `table` laid out in floats (h_num + v_num + h_num v_num, ...) float64; None for h_num < 0 (no
    table: a file Cycles could not read)."""
    if h_num < 0:
        return None
    floats = np.asarray(floats, np.float64)
    return IESProfile(h_angles=floats[:h_num], v_angles=floats[h_num:h_num + v_num],
                      intensity=floats[h_num + v_num:h_num + v_num + h_num * v_num].reshape(h_num, v_num))


# The evaluation in C over arrays (core/materials/ies.c), for the tests.
IESFacArgs = schema.function("primer_ies_fac", "ies_fac_rows", schema.record("IESFacArgs", "primer_ies_fac's arguments: ies_fac for n vectors.", [
    ("table", ptr(F64), "the profile's table (ies.table)"),
    ("h_num", I32, ""),
    ("v_num", I32, ""),
    ("strength", F64, "the node's Strength"),
    ("n", I64, ""),
    ("vectors", ptr(F64), "(n, 3) the node's Vector"),
    ("fac", schema.out(F64), "(n,)"),
]))


def compiled_fac(profile: IESProfile, strength: float, vectors: np.ndarray) -> np.ndarray:
    """ies_fac in C (core/materials/ies.c), for the tests: (n,) float64."""
    n = len(vectors)
    fac = np.empty(n)
    library.call("primer_ies_fac", IESFacArgs(
        table=table(profile), h_num=len(profile.h_angles), v_num=len(profile.v_angles), strength=float(strength),
        n=n, vectors=library.contiguous(vectors, np.float64), fac=fac))
    return fac
