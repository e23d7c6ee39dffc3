"""Cycles' Radial Tiling node (kernel/svm/radial_tiling.h, radial_tiling_shared.h): the plane around the origin cut
into Sides angular segments, each with its own coordinate system that follows a polygon of Sides sides whose
corners are rounded by Roundness.

Every point (x, y) of the input Vector (z unused) lies in segment k = floor(angle / (2 pi / Sides)), the angle
counter-clockwise from the x axis in [0, 2 pi). Its segment's coordinates are (u, v): v the distance from the origin
measured along the segment's angle bisector to the polygon's edge line through the point (the polygon of "radius" 1
has v = 1 on its edges; with Normalize off v - 1, so 0 on the edge), u the signed distance along that edge from the
bisector (in [-1, 1] mapped to [0, 1] with Normalize on). With Roundness > 0 the polygon's corners are circular arcs
and u, v follow the arcs; a fractional Sides leaves one last, narrower segment, whose corners Cycles joins to the
regular ones with a further arc. Segment Width is the largest u on a segment's unit edge (tan(pi / Sides) for a sharp
polygon), Segment Rotation the angle of the segment's bisector from the x axis.

Everything is in float32 as Cycles computes it; the transcendental functions are evaluated in double and rounded to
float32 (what a correctly rounded sinf, cosf, tanf, atanf and atan2f give).
"""
from __future__ import annotations

import numpy as np

from .base import F32, TextureNode, as_f32

PI = F32(3.1415926535897932)
TWO_PI = F32(6.2831853071795864)
HALF, ONE = F32(0.5), F32(1.0)


def _f32(function):
    """A float32 -> float32 numpy function computed in double and rounded once."""
    return lambda *args: function(*(np.asarray(a, np.float64) for a in args)).astype(F32)


sin, cos, tan, atan, atan2 = (_f32(f) for f in (np.sin, np.cos, np.tan, np.arctan, np.arctan2))


def _straight(lab: np.ndarray, bisector: np.ndarray, sdc: np.ndarray) -> np.ndarray:
    """u on a straight edge: lab tan(|bisector - angle in segment|), negative before the bisector."""
    u = lab * tan(np.abs(bisector - sdc))
    return np.where(sdc < bisector, -u, u)


def _rounded(l: np.ndarray, a: np.ndarray, cab: np.ndarray, spline: np.ndarray) -> np.ndarray:
    """u (unsigned) on a rounded corner: the edge's part l sin(a), then the arc's (a quadratic blend up to `spline`
    radians from the bevel's start, linear past it), cab the angle from the point to the bevel's start."""
    c = l * cos(a)
    near = c * cab + HALF * (ONE - c) * (cab * cab) / spline
    far = spline * (HALF * c - HALF) + cab
    return l * sin(a) + np.where(cab < spline, near, far)


def _norm_edge(lab, a, spline, roundness, bevel):
    """The normalising divisor of u measured from the bisector's length lab."""
    return lab * tan(a) + spline * (HALF * lab + HALF) + roundness * bevel


def _norm_arc(l, a, spline, roundness, bevel):
    """The normalising divisor of u measured from the point's distance l."""
    return l * sin(a) + spline * (HALF * l * cos(a) + HALF) + roundness * bevel


def _mix(a, b, t):
    """Cycles' mix: a + t (b - a)."""
    return a + t * (b - a)


def _regular_rounded(l, sab, snd, sdc, r, sdbs, bsab, normalize):
    """(lab, u, width) on the rounded corner of a regular segment."""
    ns = sdc - (sdc > sab).astype(F32) * snd
    center = (ONE - r) / cos(sab)
    cn = cos(ns) * center
    lab = l / (cn + np.sqrt(cn * cn + r * r - center * center))
    spline = (ONE - r) * sdbs
    cab = sdbs - np.abs(ns)
    u = _rounded(l, bsab, cab, spline)
    u = np.where(sdc < sab, -u, u)
    if normalize:
        u = u / _mix(_norm_edge(lab, bsab, spline, r, sdbs), _norm_arc(l, bsab, spline, r, sdbs), cab / sdbs)
    return lab, u, tan(bsab) + spline + r * sdbs


def _regular_straight(l, sab, sdc, r, sdbs, bsab, normalize):
    """(lab, u, width) on the straight edge of a regular segment with rounded corners."""
    lab = l * cos(sab - sdc)
    spline = (ONE - r) * sdbs
    u = _straight(lab, sab, sdc)
    if normalize:
        u = u / _norm_edge(lab, bsab, spline, r, sdbs)
    return lab, u, tan(bsab) + spline + r * sdbs


def _irregular_circular(l, x, y, xac, sab, snd, seg, sdc, sides, r, normalize):
    """(lab, u, width, rotation) for a fractional Sides and Roundness > 0 (Cycles'
    calculate_out_variables_irregular_circular)."""
    sdbs = sab - atan((ONE - r) * tan(sab))
    las = PI - np.floor(sides) * sab                        # the last (narrower) segment's half angle
    lsd = F32(2.0) * las
    ilbs = las - atan((ONE - r) * tan(las))
    radius = r * tan(las) / tan(HALF * (sab + las))
    d = cos(las - ilbs)
    cx = cos(ilbs) / d - radius * cos(las)
    cy = radius * sin(las) - sin(ilbs) / d
    ox, oy = cx + radius * cos(sab), cy + radius * sin(sab)
    xolbs = atan(oy / ox)
    olbs_ab = sab - xolbs
    bsab = sab - sdbs
    spline = (ONE - r) * sdbs
    width_regular = tan(bsab) + spline + r * sdbs
    rotation = seg * snd + sab
    rotation_last = seg * snd + las
    # Regular segments: straight edges and rounded corners.
    regular = (xac >= xolbs) & (xac < TWO_PI - lsd - xolbs)
    straight = ((sdc >= sdbs) & (sdc < snd - sdbs)) | (xac >= TWO_PI - lsd - sdbs) | (xac < sdbs)
    lab_s = l * cos(sab - sdc)
    u_s = _straight(lab_s, sab, sdc)
    effective = ONE - tan(sab - xolbs) / tan(sab)
    spline_outer = (ONE - effective) * xolbs
    if normalize:
        next_to_last = (xac >= TWO_PI - lsd - sab) | (xac < sab)
        u_s = u_s / np.where(next_to_last, _norm_edge(lab_s, olbs_ab, spline_outer, effective, xolbs),
                             _norm_edge(lab_s, bsab, spline, r, sdbs))
    lab_r, u_r, _ = _regular_rounded(l, sab, snd, sdc, r, sdbs, bsab, normalize)
    # The last segment's straight edge.
    ilbs_ab = las - ilbs
    ratio = cos(sab) / cos(las)
    last_straight = (xac >= TWO_PI - lsd + ilbs) & (xac < TWO_PI - ilbs)
    inner_spline = (ONE - r) * ilbs
    lla = l * cos(las - sdc)
    lab_is = ratio * lla
    u_is = _straight(lab_is, las, sdc)
    if normalize:
        u_is = u_is / (ratio * _norm_edge(lla, ilbs_ab, inner_spline, r, ilbs))
    width_last = tan(ilbs_ab) + ratio * (inner_spline * ((HALF / ratio) + HALF) + r * ilbs)
    # The arcs joining the last segment to its neighbours (mirrored about the last bisector).
    m = atan2(y, x)
    mirrored = (xac >= TWO_PI - lsd - xolbs) & (xac < TWO_PI - las)
    m = np.where(mirrored, -(m + lsd), m)
    t = sin(m) * cy + cos(m) * cx
    lla_r = l / (t + np.sqrt(t * t + radius * radius - cx * cx - cy * cy))
    lab_ir = ratio * lla_r
    inner = m < F32(0.0)
    cab_in = ilbs - np.abs(m)
    c_in = l * cos(ilbs_ab)
    u_in = ratio * l * sin(ilbs_ab) + np.where(
        cab_in < inner_spline, ratio * (c_in * cab_in + HALF * (ONE - c_in) * (cab_in * cab_in) / inner_spline),
        ratio * (inner_spline * (HALF * c_in - HALF) + cab_in))
    u_in = np.where(sdc < las, -u_in, u_in)
    cab_out = xolbs - np.abs(m)
    u_out = _rounded(l, olbs_ab, cab_out, spline_outer)
    u_out = np.where(sdc < sab, -u_out, u_out)
    if normalize:
        u_in = u_in / (ratio * _mix(_norm_edge(lla_r, ilbs_ab, inner_spline, r, ilbs),
                                    _norm_arc(l, ilbs_ab, inner_spline, r, ilbs), cab_in / ilbs))
        u_out = u_out / _mix(_norm_edge(lab_ir, olbs_ab, spline_outer, effective, xolbs),
                             _norm_arc(l, olbs_ab, spline_outer, effective, xolbs), cab_out / xolbs)
    choices = [regular & straight, regular, last_straight, inner]
    lab = np.select(choices, [lab_s, lab_r, lab_is, lab_ir], lab_ir)
    u = np.select(choices, [u_s, u_r, u_is, u_in], u_out)
    width = np.select(choices, [width_regular, width_regular, width_last, width_last], width_regular)
    rot = np.select(choices, [rotation, rotation, rotation_last, rotation_last], rotation)
    return lab, u, width, rot


def out_variables(normalize: bool, sides: np.ndarray, roundness: np.ndarray, x: np.ndarray,
                  y: np.ndarray) -> tuple:
    """Cycles' calculate_out_variables at n points (float32 (n,) each; Sides >= 2, Roundness in [0, 1]):
    (v (the bisector's length, - 1 without Normalize), u (in [0, 1] with Normalize), Segment Width,
    Segment Rotation)."""
    l = np.sqrt(x * x + y * y)
    xac = atan2(y, x) + (y < F32(0.0)).astype(F32) * TWO_PI
    sab = PI / sides
    snd = F32(2.0) * sab
    seg = np.floor(xac / snd)
    sdc = xac - seg * snd
    rotation = seg * snd + sab
    whole = (sides - np.floor(sides)) == F32(0.0)
    sharp, full = roundness == F32(0.0), roundness == F32(1.0)
    # Whole Sides, Roundness 0: a sharp regular polygon (a 2-gon has no width).
    lab0 = l * cos(sab - sdc)
    u0 = _straight(lab0, sab, sdc)
    two = sides == F32(2.0)
    if normalize:
        u0 = np.where(two, u0, u0 / (lab0 * tan(sab)))
    width0 = np.where(two, F32(0.0), tan(sab))
    # Whole Sides, Roundness 1: circles, u the angle from the bisector.
    u1 = np.abs(sab - sdc)
    u1 = np.where(sdc < sab, -u1, u1)
    if normalize:
        u1 = u1 / sab
    # Whole Sides, Roundness between: straight edges and rounded corners.
    sdbs = sab - atan((ONE - roundness) * tan(sab))
    bsab = sab - sdbs
    corner = (sdc >= snd - sdbs) | (sdc < sdbs)
    lab_r, u_r, width_r = _regular_rounded(l, sab, snd, sdc, roundness, sdbs, bsab, normalize)
    lab_s, u_s, width_s = _regular_straight(l, sab, sdc, roundness, sdbs, bsab, normalize)
    # Fractional Sides, Roundness 0: the last segment's edge is straight too.
    las = PI - np.floor(sides) * sab
    last = xac >= TWO_PI - F32(2.0) * las
    ratio = cos(sab) / cos(las)
    lla = l * cos(las - sdc)
    lab_l = ratio * lla
    u_l = _straight(lab_l, las, sdc)
    u_f = _straight(lab0, sab, sdc)
    if normalize:
        u_l = u_l / (ratio * lla * tan(las))
        u_f = u_f / (lab0 * tan(sab))
    # Fractional Sides, rounded.
    lab_c, u_c, width_c, rot_c = _irregular_circular(l, x, y, xac, sab, snd, seg, sdc, sides, roundness, normalize)
    choices = [whole & sharp, whole & full, whole & corner, whole, sharp & last, sharp]
    lab = np.select(choices, [lab0, l, lab_r, lab_s, lab_l, lab0], lab_c)
    u = np.select(choices, [u0, u1, u_r, u_s, u_l, u_f], u_c)
    width = np.select(choices, [width0, sab, width_r, width_s, tan(las), tan(sab)], width_c)
    rot = np.select(choices, [rotation, rotation, rotation, rotation, seg * snd + las, rotation], rot_c)
    u = np.where((x == F32(0.0)) & (y == F32(0.0)), F32(0.0), u)
    if normalize:
        u = HALF * u + HALF
    else:
        lab = lab - ONE
    return lab, u, width, rot


def segment_id(sides: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cycles' calculate_out_segment_id: floor(Sides (angle / 2 pi)), the angle counter-clockwise in [0, 2 pi)."""
    return np.floor(sides * ((atan2(y, x) / TWO_PI) + (y < F32(0.0)).astype(F32)))


class RadialTiling(TextureNode):
    """Segment Coordinates (u, v, 0), Segment ID, Segment Width and Segment Rotation of the point's (x, y) about the
    origin (module docstring); Sides at least 2, Roundness clamped to [0, 1], as Cycles' svm_node_radial_tiling."""

    kind = "RADIAL_TILING"
    blender = "ShaderNodeRadialTiling"
    c_name = "radial_tiling"
    inputs = (("Vector", 3, (0.0, 0.0, 0.0)), ("Sides", 1, 5.0), ("Roundness", 1, 0.0))
    outputs = {"Segment Coordinates": (3, "vector"), "Segment ID": (1, "float"), "Segment Width": (1, "float"),
               "Segment Rotation": (1, "float")}
    settings = {"normalize": ("normalize", None, False)}

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Segment Coordinates (n, 3), Segment ID, Segment Width, Segment Rotation (n, 1 each) side by side."""
        vector = as_f32(inputs[0])
        sides = np.maximum(as_f32(inputs[1])[:, 0], F32(2.0))
        roundness = np.clip(as_f32(inputs[2])[:, 0], F32(0.0), ONE)
        x, y = vector[:, 0], vector[:, 1]
        with np.errstate(all="ignore"):                     # (every branch is computed at every point)
            v, u, width, rotation = out_variables(bool(numbers[0]), sides, roundness, x, y)
            ids = segment_id(sides, x, y)
        out = np.stack([u, v, np.zeros_like(u), ids, width, rotation], axis=1)
        return out.astype(np.float64)
