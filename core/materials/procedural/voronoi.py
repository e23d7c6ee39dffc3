"""Cycles' Voronoi Texture (kernel/svm/voronoi.h): distances to random points, one per lattice cell, in 1 to 4
dimensions, in float32.

Each cell holds one point at cell + hash(cell) x Randomness (1D: lookup3 of the cell's float; 2D to 4D: PCG of the
integer cell, hash.py). F1 is the nearest point of the 3^d cells around the point's own, F2 the second nearest,
Smooth F1 a smooth minimum over 5^d cells (Inigo Quilez's), Distance to Edge the distance to the nearest bisector
of two points, N-Sphere Radius half the distance from the nearest point to its own nearest. Distances are Euclidean,
Manhattan, Chebychev or Minkowski (Exponent); sums of components add x + y, then z (4D: (x + y) + (z + w), as
Cycles' SSE dot and horizontal add do). Detail adds octaves at Lacunarity times the frequency and Roughness times
the weight, lerped in (`fractal`); Normalize divides by the largest distance possible. The cells are visited in
Cycles' order (x fastest), which decides ties.
"""
from __future__ import annotations

import itertools

import numpy as np

from . import hash as hash_
from .base import F32, TextureNode, as_f32

DIMENSIONS = ("1D", "2D", "3D", "4D")
FEATURES = ("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS")
METRICS = ("EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI")
BIG = F32(np.finfo(np.float32).max)


def offsets(d: int, reach: int) -> list:
    """The cell offsets -reach..reach in each of d axes, in Cycles' loop order: x fastest, the last axis slowest."""
    return [tuple(reversed(o)) for o in itertools.product(range(-reach, reach + 1), repeat=d)]


def total(values: np.ndarray) -> np.ndarray:
    """The sum of (n, d) components: x + y, then + z; in 4D (x + y) + (z + w)."""
    d = values.shape[1]
    if d == 4:
        return (values[:, 0] + values[:, 1]) + (values[:, 2] + values[:, 3])
    out = values[:, 0]
    for k in range(1, d):
        out = out + values[:, k]
    return out


def power(x, e) -> np.ndarray:
    """powf(x, e) in float32, computed in double and rounded (the same in numpy and C)."""
    return np.power(np.asarray(x, np.float64), np.asarray(e, np.float64)).astype(F32)


def distance(a: np.ndarray, b: np.ndarray, metric: int, exponent: np.ndarray, bound: bool = False) -> np.ndarray:
    """Cycles' voronoi_distance (bound: voronoi_distance_bound, which orders points alike and skips the root) of
    (n, d) points; 1D: |b - a| whatever the metric."""
    if a.shape[1] == 1:
        return np.abs(b[:, 0] - a[:, 0])
    diff = a - b
    name = METRICS[metric]
    if name == "EUCLIDEAN":
        squared = total(diff * diff)
        return squared if bound else np.sqrt(squared)
    if name == "MANHATTAN":
        return total(np.abs(diff))
    if name == "CHEBYCHEV":
        return np.abs(diff).max(axis=1)
    summed = total(power(np.abs(diff), exponent[:, None]))
    return summed if bound else power(summed, F32(1.0) / exponent)


def cell_point(cell: np.ndarray, cell_f: np.ndarray, offset: tuple, randomness: np.ndarray) -> np.ndarray:
    """The point of the cell at `offset` from the point's cell, relative to the point's cell: offset + hash x
    Randomness, (n, d) float32 (1D: lookup3 of the float cell; else PCG of the integer cell)."""
    o = np.array(offset, F32)
    if cell.shape[1] == 1:
        h = hash_.hash_float(cell_f[:, 0] + o[0])[:, None]
    else:
        h = hash_.hash_int_to_float(cell + np.array(offset, np.int64))
    return o + h * randomness[:, None]


def cell_color(cell: np.ndarray, cell_f: np.ndarray, offset) -> np.ndarray:
    """The colour of the cell at `offset` ((n, d) offsets or a tuple): (n, 3) float32."""
    if cell.shape[1] == 1:
        return hash_.hash_float_to_float3(cell_f[:, 0] + np.asarray(offset, F32).reshape(-1))
    return hash_.hash_int_to_float3(cell + np.asarray(offset, np.int64))


def split(coord: np.ndarray) -> tuple:
    """(integer cell (n, d) int64, float cell, position within the cell) of points (n, d) float32."""
    cell_f = np.floor(coord)
    return cell_f.astype(np.int32).astype(np.int64), cell_f, coord - cell_f


def f1(coord, metric, exponent, randomness) -> tuple:
    """Cycles' voronoi_f1: (distance (n,), colour (n, 3), position (n, d)) of the nearest point."""
    cell, cell_f, local = split(coord)
    n, d = coord.shape
    best = np.full(n, BIG)
    target = np.zeros((n, d), np.int64)
    position = np.zeros((n, d), F32)
    for offset in offsets(d, 1):
        point = cell_point(cell, cell_f, offset, randomness)
        dist = distance(point, local, metric, exponent, bound=True)
        nearer = dist < best
        best = np.where(nearer, dist, best)
        target[nearer] = offset
        position = np.where(nearer[:, None], point, position)
    return (distance(position, local, metric, exponent), cell_color(cell, cell_f, target), position + cell_f)


def f2(coord, metric, exponent, randomness) -> tuple:
    """Cycles' voronoi_f2: the second nearest point's (distance, colour, position)."""
    cell, cell_f, local = split(coord)
    n, d = coord.shape
    d1, d2 = np.full(n, BIG), np.full(n, BIG)
    o1, o2 = np.zeros((n, d), np.int64), np.zeros((n, d), np.int64)
    p1, p2 = np.zeros((n, d), F32), np.zeros((n, d), F32)
    for offset in offsets(d, 1):
        point = cell_point(cell, cell_f, offset, randomness)
        dist = distance(point, local, metric, exponent)
        first = dist < d1
        second = ~first & (dist < d2)
        d2 = np.where(first, d1, np.where(second, dist, d2))
        o2 = np.where(first[:, None], o1, np.where(second[:, None], np.array(offset), o2))
        p2 = np.where(first[:, None], p1, np.where(second[:, None], point, p2))
        d1 = np.where(first, dist, d1)
        o1 = np.where(first[:, None], np.array(offset), o1)
        p1 = np.where(first[:, None], point, p1)
    return d2, cell_color(cell, cell_f, o2), p2 + cell_f


def lerp(a, b, t):
    """Cycles' mix: a + t (b - a)."""
    return a + t * (b - a)


def smoothstep(x: np.ndarray) -> np.ndarray:
    """Cycles' smoothstep(0, 1, x): 0 below 0, 1 from 1 on, (3 - 2t) t^2 between."""
    return np.where(x < F32(0.0), F32(0.0), np.where(x >= F32(1.0), F32(1.0), (F32(3.0) - F32(2.0) * x) * (x * x)))


def smooth_f1(coord, metric, exponent, randomness, smoothness) -> tuple:
    """Cycles' voronoi_smooth_f1: a smooth minimum of the distances, colours and points of the 5^d cells around."""
    cell, cell_f, local = split(coord)
    n, d = coord.shape
    smooth_distance, smooth_color, smooth_position = np.zeros(n, F32), np.zeros((n, 3), F32), np.zeros((n, d), F32)
    h = None
    for offset in offsets(d, 2):
        point = cell_point(cell, cell_f, offset, randomness)
        dist = distance(point, local, metric, exponent)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = np.ones(n, F32) if h is None else smoothstep(
                F32(0.5) + F32(0.5) * (smooth_distance - dist) / smoothness)
        correction = smoothness * h * (F32(1.0) - h)
        smooth_distance = lerp(smooth_distance, dist, h) - correction
        correction = correction / (F32(1.0) + F32(3.0) * smoothness)
        color = cell_color(cell, cell_f, offset)
        smooth_color = lerp(smooth_color, color, h[:, None]) - correction[:, None]
        smooth_position = lerp(smooth_position, point, h[:, None]) - correction[:, None]
    return smooth_distance, smooth_color, cell_f + smooth_position


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cycles' dot of (n, d) vectors, summed as `total`."""
    return total(a * b)


def distance_to_edge(coord, randomness) -> np.ndarray:
    """Cycles' voronoi_distance_to_edge: the distance to the nearest bisector between the nearest point and another."""
    cell, cell_f, local = split(coord)
    n, d = coord.shape
    if d == 1:
        x = local[:, 0]
        mid = hash_.hash_float(cell_f[:, 0]) * randomness
        left = F32(-1.0) + hash_.hash_float(cell_f[:, 0] - F32(1.0)) * randomness
        right = F32(1.0) + hash_.hash_float(cell_f[:, 0] + F32(1.0)) * randomness
        return np.minimum(np.abs((mid + left) / F32(2.0) - x), np.abs((mid + right) / F32(2.0) - x))
    best = np.full(n, BIG)
    closest = np.zeros((n, d), F32)
    for offset in offsets(d, 1):
        to_point = cell_point(cell, cell_f, offset, randomness) - local
        dist = dot(to_point, to_point)
        nearer = dist < best
        best = np.where(nearer, dist, best)
        closest = np.where(nearer[:, None], to_point, closest)
    best = np.full(n, BIG)
    for offset in offsets(d, 1):
        to_point = cell_point(cell, cell_f, offset, randomness) - local
        across = to_point - closest
        apart = dot(across, across) > F32(0.0001)
        with np.errstate(divide="ignore", invalid="ignore"):
            length = np.sqrt(dot(across, across))[:, None]
            # normalize: a 3D vector divided by its length (SSE), a 2D or 4D one times the reciprocal.
            unit = across / length if d == 3 else across * (F32(1.0) / length)
            edge = dot((closest + to_point) / F32(2.0), unit)
        best = np.where(apart, np.minimum(best, edge), best)
    return best


def n_sphere_radius(coord, randomness) -> np.ndarray:
    """Cycles' voronoi_n_sphere_radius: half the (Euclidean) distance from the nearest point to its nearest."""
    cell, cell_f, local = split(coord)
    n, d = coord.shape
    best = np.full(n, BIG)
    closest = np.zeros((n, d), F32)
    closest_offset = np.zeros((n, d), np.int64)
    for offset in offsets(d, 1):
        point = cell_point(cell, cell_f, offset, randomness)
        gap = point - local
        dist = np.abs(gap[:, 0]) if d == 1 else dot(gap, gap)
        nearer = dist < best
        best = np.where(nearer, dist, best)
        closest = np.where(nearer[:, None], point, closest)
        closest_offset[nearer] = offset
    best = np.full(n, BIG)
    other = np.zeros((n, d), F32)
    for offset in offsets(d, 1):
        if not any(offset):
            continue
        moved = closest_offset + np.array(offset)
        o = moved.astype(F32)
        if d == 1:
            point = o + hash_.hash_float(cell_f[:, 0] + o[:, 0])[:, None] * randomness[:, None]
        else:
            point = o + hash_.hash_int_to_float(cell + moved) * randomness[:, None]
        gap = closest - point
        dist = np.abs(gap[:, 0]) if d == 1 else dot(gap, gap)
        nearer = dist < best
        best = np.where(nearer, dist, best)
        other = np.where(nearer[:, None], point, other)
    gap = other - closest
    length = np.abs(gap[:, 0]) if d == 1 else np.sqrt(dot(gap, gap))
    return length / F32(2.0)


def fractal(feature: int, coord, params: dict) -> tuple:
    """Cycles' fractal_voronoi_x_fx: F1, F2 or Smooth F1 summed over the octaves, (distance, colour, position)."""
    detail, roughness, lacunarity = params["detail"], params["roughness"], params["lacunarity"]
    n, d = coord.shape
    amplitude, max_amplitude, scale = np.ones(n, F32), np.zeros(n, F32), np.ones(n, F32)
    out_distance, out_color, out_position = np.zeros(n, F32), np.zeros((n, 3), F32), np.zeros((n, d), F32)
    zero_input = (detail == F32(0.0)) | (roughness == F32(0.0))
    done = np.zeros(n, bool)
    remainder = detail - np.floor(detail)
    for i in range(int(np.ceil(detail.max(initial=0.0))) + 1):
        active = ~done & (i <= np.ceil(detail))
        if not active.any():
            break
        p = coord * scale[:, None]
        name = FEATURES[feature]
        smooth = name == "SMOOTH_F1"
        use = (params["smoothness"] != F32(0.0)) if smooth else np.zeros(n, bool)
        if name == "F2":
            dist, color, position = f2(p, params["metric"], params["exponent"], params["randomness"])
        elif not use.any():
            dist, color, position = f1(p, params["metric"], params["exponent"], params["randomness"])
        else:
            dist, color, position = smooth_f1(p, params["metric"], params["exponent"], params["randomness"],
                                              params["smoothness"])
            if not use.all():                   # Smooth F1 with Smoothness 0 is F1
                hard = f1(p, params["metric"], params["exponent"], params["randomness"])
                dist, color, position = (np.where(use, dist, hard[0]), np.where(use[:, None], color, hard[1]),
                                         np.where(use[:, None], position, hard[2]))
        first = active & zero_input
        whole = active & ~zero_input & (F32(i) <= detail)
        part = active & ~zero_input & ~(F32(i) <= detail) & (remainder != F32(0.0))
        a = amplitude
        moved = position * (F32(1.0) / scale)[:, None]          # float4 / float: times the reciprocal
        # An octave in full.
        new_max = np.where(first, F32(1.0), np.where(whole, max_amplitude + a, max_amplitude))
        new_distance = np.where(first, dist, np.where(whole, out_distance + dist * a, out_distance))
        new_color = np.where(first[:, None], color, np.where(whole[:, None], out_color + color * a[:, None],
                                                                out_color))
        new_position = np.where(first[:, None], position,
                                np.where(whole[:, None], lerp(out_position, moved, a[:, None]), out_position))
        # The fractional last octave.
        r = remainder
        new_max = np.where(part, lerp(max_amplitude, max_amplitude + a, r), new_max)
        new_distance = np.where(part, lerp(out_distance, out_distance + dist * a, r), new_distance)
        new_color = np.where(part[:, None], lerp(out_color, out_color + color * a[:, None], r[:, None]), new_color)
        new_position = np.where(part[:, None], lerp(out_position, lerp(out_position, moved, a[:, None]), r[:, None]),
                                new_position)
        max_amplitude, out_distance, out_color, out_position = new_max, new_distance, new_color, new_position
        scale = np.where(whole, scale * lacunarity, scale)
        amplitude = np.where(whole, amplitude * roughness, amplitude)
        done = done | first
    with np.errstate(divide="ignore", invalid="ignore"):
        if params["normalize"]:
            out_distance = out_distance / (max_amplitude * params["max_distance"])
            out_color = out_color / max_amplitude[:, None]      # float3 / float: divided (SSE)
        s = params["scale"]
        out_position = np.where((s != F32(0.0))[:, None], out_position * (F32(1.0) / s)[:, None], F32(0.0))
    return out_distance, out_color, out_position


def fractal_distance_to_edge(coord, params: dict) -> np.ndarray:
    """Cycles' fractal_voronoi_distance_to_edge: the octaves' smallest distances to an edge, lerped in."""
    detail, roughness, lacunarity = params["detail"], params["roughness"], params["lacunarity"]
    max_distance = params["max_distance"]
    n = len(coord)
    amplitude, max_amplitude, scale = np.ones(n, F32), max_distance.copy(), np.ones(n, F32)
    out = np.full(n, F32(8.0))
    zero_input = (detail == F32(0.0)) | (roughness == F32(0.0))
    done = np.zeros(n, bool)
    remainder = detail - np.floor(detail)
    for i in range(int(np.ceil(detail.max(initial=0.0))) + 1):
        active = ~done & (i <= np.ceil(detail))
        if not active.any():
            break
        octave = distance_to_edge(coord * scale[:, None], params["randomness"])
        first = active & zero_input
        whole = active & ~zero_input & (F32(i) <= detail)
        part = active & ~zero_input & ~(F32(i) <= detail) & (remainder != F32(0.0))
        a = amplitude
        full_max = lerp(max_amplitude, max_distance / scale, a)
        full_out = lerp(out, np.minimum(out, octave / scale), a)
        new_max = np.where(whole, full_max, np.where(part, lerp(max_amplitude, full_max, remainder), max_amplitude))
        new_out = np.where(first, octave, np.where(whole, full_out, np.where(
            part, lerp(out, np.minimum(out, full_out), remainder), out)))
        max_amplitude, out = new_max, new_out
        scale = np.where(whole, scale * lacunarity, scale)
        amplitude = np.where(whole, amplitude * roughness, amplitude)
        done = done | first
    if params["normalize"]:
        with np.errstate(divide="ignore", invalid="ignore"):
            out = out / max_amplitude
    return out


class VoronoiTexture(TextureNode):
    """Distance, Color, Position, W of the F1, F2 or Smooth F1 point (fractal over Detail), or the Distance to
    Edge, or the N-Sphere Radius, of the scaled point."""

    kind = "TEX_VORONOI"
    blender = "ShaderNodeTexVoronoi"
    c_name = "voronoi"
    inputs = (("Vector", 3, "generated"), ("W", 1, 0.0), ("Scale", 1, 5.0), ("Detail", 1, 0.0), ("Roughness", 1, 0.5),
              ("Lacunarity", 1, 2.0), ("Smoothness", 1, 1.0), ("Exponent", 1, 0.5), ("Randomness", 1, 1.0))
    outputs = {"Distance": (1, "float"), "Color": (3, "color"), "Position": (3, "vector"), "W": (1, "float"),
               "Radius": (1, "float")}
    settings = {"dimensions": ("voronoi_dimensions", DIMENSIONS, "3D"), "feature": ("feature", FEATURES, "F1"),
                "metric": ("distance", METRICS, "EUCLIDEAN"), "normalize": ("normalize", None, False)}

    @classmethod
    def differs_in(cls, props: dict, version: tuple):
        """Before Blender 5.0, Cycles placed the 2D to 4D points by lookup3 of the float cell (and F1 measured every
        point in full): other cells than 5.0's PCG ones."""
        if tuple(version[:2]) < (5, 0) and props.get("dimensions", "3D") != "1D":
            return ("the Cycles of Blender before 5.0 places 2D to 4D Voronoi points with other hashes; Primer "
                    "places them as Cycles 5.0 does, so its cells differ from this Blender's")
        return None

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """Distance, Color, Position, W, Radius side by side (n, 9)."""
        vector, w, scale, detail, roughness, lacunarity, smoothness, exponent, randomness = (as_f32(x) for x in inputs)
        d, feature, metric, normalize = numbers[0] + 1, numbers[1], numbers[2], bool(numbers[3])
        clamp = lambda x, lo, hi: np.minimum(np.maximum(x[:, 0], F32(lo)), F32(hi))       # noqa: E731
        params = {"scale": scale[:, 0], "detail": clamp(detail, 0.0, 15.0), "roughness": clamp(roughness, 0.0, 1.0),
                  "lacunarity": lacunarity[:, 0], "smoothness": clamp(smoothness / F32(2.0), 0.0, 0.5),
                  "exponent": exponent[:, 0], "randomness": clamp(randomness, 0.0, 1.0), "metric": metric,
                  "normalize": normalize}
        v = vector * params["scale"][:, None]
        w = w[:, 0] * params["scale"]
        coord = {1: w[:, None], 2: v[:, :2], 3: v, 4: np.concatenate([v, w[:, None]], axis=1)}[d]
        n = len(coord)
        out = np.zeros((n, 9))
        half = F32(0.5) + F32(0.5) * params["randomness"]
        name = FEATURES[feature]
        if name == "DISTANCE_TO_EDGE":
            params["max_distance"] = half
            out[:, 0] = fractal_distance_to_edge(coord, params)
        elif name == "N_SPHERE_RADIUS":
            out[:, 8] = n_sphere_radius(coord, params["randomness"])
        else:
            if d == 1:
                reach = half
            else:
                corner = np.repeat(half[:, None], d, axis=1)
                reach = distance(np.zeros((n, d), F32), corner, metric, params["exponent"])
            params["max_distance"] = reach * (F32(2.0) if name == "F2" else F32(1.0))
            dist, color, position = fractal(feature, coord, params)
            out[:, 0] = dist
            out[:, 1:4] = color
            if d == 1:
                out[:, 7] = position[:, 0]
            else:
                out[:, 4:4 + min(d, 3)] = position[:, :3]
                if d == 4:
                    out[:, 7] = position[:, 3]
        return out
