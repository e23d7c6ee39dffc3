"""Procedural textures (core/materials/procedural): Cycles' hashes against lookup3 and PCG written out on Python
integers, and each texture against its closed form on both kernels: White Noise is the hash of the point's float32
bits, the Checker's squares alternate by the parity of floor(x) + floor(y) + floor(z), the Gradients are their
formulas, Perlin noise is 0 on the integer lattice and within [-1, 1], a fractional Detail blends two octave counts,
Voronoi without randomness measures to the integer lattice, Wave bands and rings are their profile of 20 x the
distance along or from the axis and Distortion adds the fBM, Magic is its folded sines and cosines, Bricks are tinted
by the hash of row and column, Gabor noise is the sum of its cells' windowed kernels.
The compiled twin renders every texture, dimension and fractal bit for bit as the numpy reference does.

The scenes look straight down at a 2 x 2 plane whose Generated coordinates run 0..1 across it (z = 0.3); a texture
reading the coordinate snapped to its pixel's centre ((floor(8 g) + 0.5) / 8, x 4 - 2: exact in float32) has one
value per pixel, whatever the sample.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.geometry import primitives
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.materials.procedural import hash as hash_
from core.materials.procedural import perlin
from core.scene import RenderSettings, Scene

from test_textures import plane_attributes

SIZE = 8
KERNELS = ["compiled", "numpy"]
M = 0xFFFFFFFF


# ------------------------------------------------------------------------------------------------
# lookup3 on Python integers, as Bob Jenkins writes it (http://burtleburtle.net/bob/c/lookup3.c)
# ------------------------------------------------------------------------------------------------

def rot(x: int, k: int) -> int:
    """x rotated left by k bits, 32-bit."""
    return ((x << k) | (x >> (32 - k))) & M


def final(a: int, b: int, c: int) -> int:
    """lookup3's final(a, b, c); returns c."""
    c ^= b; c = (c - rot(b, 14)) & M
    a ^= c; a = (a - rot(c, 11)) & M
    b ^= a; b = (b - rot(a, 25)) & M
    c ^= b; c = (c - rot(b, 16)) & M
    a ^= c; a = (a - rot(c, 4)) & M
    b ^= a; b = (b - rot(a, 14)) & M
    c ^= b; c = (c - rot(b, 24)) & M
    return c


def mix(a: int, b: int, c: int) -> tuple:
    """lookup3's mix(a, b, c)."""
    a = (a - c) & M; a ^= rot(c, 4); c = (c + b) & M
    b = (b - a) & M; b ^= rot(a, 6); a = (a + c) & M
    c = (c - b) & M; c ^= rot(b, 8); b = (b + a) & M
    a = (a - c) & M; a ^= rot(c, 16); c = (c + b) & M
    b = (b - a) & M; b ^= rot(a, 19); a = (a + c) & M
    c = (c - b) & M; c ^= rot(b, 4); b = (b + a) & M
    return a, b, c


def bits(x: float) -> int:
    """A float32's bits."""
    return int(np.array(x, np.float32).view(np.uint32))


def test_the_hashes_are_lookup3_of_the_words_with_cycles_initial_value():
    """Cycles' hash_uint .. hash_uint4 are lookup3's hashword with 0xdeadbeef + 4 x words + 13 (initval 13)."""
    rng = np.random.default_rng(7)
    words = rng.integers(0, 2**32, (50, 4), dtype=np.uint64)
    functions = (hash_.hash_uint, hash_.hash_uint2, hash_.hash_uint3, hash_.hash_uint4)
    for count, function in enumerate(functions, start=1):
        got = function(*(words[:, k] for k in range(count)))
        expected = [final_of(count, [int(w) for w in row[:count]]) for row in words]
        np.testing.assert_array_equal(got, np.array(expected, np.uint32))


def final_of(count: int, words: list) -> int:
    """lookup3's hashword of `count` words (1 to 4) with initval 13: Cycles' hash_uint .. hash_uint4."""
    a = b = c = (0xDEADBEEF + (count << 2) + 13) & M
    if count == 4:
        a, b, c = mix((a + words[0]) & M, (b + words[1]) & M, (c + words[2]) & M)
        return final((a + words[3]) & M, b, c)
    k = list(words) + [0] * (3 - count)
    return final((a + k[0]) & M, (b + k[1]) & M, (c + k[2]) & M)


def test_a_hash_becomes_a_float_in_0_1_with_0_and_the_largest_word_at_the_ends():
    """uint_to_float_incl: (float)h x 2^-32; 0 -> 0, 0xFFFFFFFF rounds to 2^32 in float32 -> exactly 1."""
    values = hash_.uint_to_float(np.array([0, 1 << 31, M], np.uint32))
    np.testing.assert_array_equal(values, np.array([0.0, 0.5, 1.0], np.float32))


def pcg(words: list) -> list:
    """Cycles' hash_pcg2d_i .. 4d_i on Python integers: signed 32-bit words, wrapping, an arithmetic shift by 16."""
    signed = lambda x: ((x & M) ^ 0x80000000) - 0x80000000          # noqa: E731
    v = [signed(w * 1664525 + 1013904223) for w in words]
    d = len(v)

    def rounds(v):
        if d == 2:
            v[0] = signed(v[0] + v[1] * 1664525); v[1] = signed(v[1] + v[0] * 1664525)
        else:
            pairs = ((1, 2), (2, 0), (0, 1)) if d == 3 else ((1, 3), (2, 0), (0, 1), (1, 2))
            for j, (a, b) in enumerate(pairs):
                v[j] = signed(v[j] + v[a] * v[b])
        return v

    v = rounds(v)
    v = [signed(x ^ (x >> 16)) for x in v]
    v = rounds(v)
    return [x & 0x7FFFFFFF for x in v]


def test_the_voronoi_hashes_are_pcg_of_the_signed_cell_words():
    """Cycles' hash_int2_to_float2 .. hash_int4_to_float4: PCG (Jarzynski and Olano) of the cell, (float)h x 2^-31."""
    rng = np.random.default_rng(11)
    for d in (2, 3, 4):
        cells = rng.integers(-2**31, 2**31, (40, d))
        expected = np.array([pcg([int(c) for c in row]) for row in cells], np.int64)
        np.testing.assert_array_equal(hash_.hash_pcg(cells), expected)
        np.testing.assert_array_equal(hash_.hash_int_to_float(cells),
                                      expected.astype(np.float32) * np.float32(2.0**-31))


# ------------------------------------------------------------------------------------------------
# Renders of a texture on the plane
# ------------------------------------------------------------------------------------------------

def plane_scene(link: Link) -> Scene:
    """The plane emitting `link` (Generated 0..1 across it, z 0.3)."""
    scene = Scene(camera=ortho_down(height=2.0, scale=2.0))
    scene.materials.append(Material(name="Texture", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
    mesh = primitives.plane(2.0)
    mesh.attributes = plane_attributes(mesh)
    uv = mesh.attributes["uv:"]
    mesh.attributes["generated"] = np.concatenate([uv[..., :2], np.full(uv.shape[:2] + (1,), 0.3)], axis=2)
    scene.add_mesh(mesh, materials=np.array([0]))
    return scene


def shoot(link: Link, kernels: str) -> np.ndarray:
    """The plane's pixels (SIZE, SIZE, 3), image row 0 at the top."""
    settings = RenderSettings(width=SIZE, height=SIZE, samples=1, kernels=kernels)
    return render.render(plane_scene(link), settings).image[..., :3]


def snapped_vector(z: float = 0.375) -> Link:
    """The Generated coordinate snapped to the pixel centre and mapped to -2..2 (x, y), z given."""
    generated = Link(GraphNode("TEXCOORD", {}, {}), "Generated")
    separate = GraphNode("SEPARATE_XYZ", {}, {"Vector": generated})
    ends = []
    for axis in ("X", "Y"):
        value = Link(separate, axis)
        steps = (("MULTIPLY", SIZE), ("FLOOR", 0.0), ("ADD", 0.5), ("MULTIPLY", 4.0 / SIZE), ("SUBTRACT", 2.0))
        for operation, b in steps:
            value = Link(GraphNode("MATH", {"operation": operation}, {"0": value, "1": b}), "Value")
        ends.append(value)
    return Link(GraphNode("COMBINE_XYZ", {}, {"X": ends[0], "Y": ends[1], "Z": z}), "Vector")


def snapped_points(z: float = 0.375) -> np.ndarray:
    """What snapped_vector gives at each pixel: (SIZE, SIZE, 3) float32, row 0 at the top."""
    centres = (np.arange(SIZE) + 0.5) / SIZE * 4.0 - 2.0
    x, y = np.meshgrid(centres, centres[::-1])
    return np.stack([x, y, np.full_like(x, z)], axis=2).astype(np.float32)


@pytest.mark.parametrize("kernels", KERNELS)
def test_white_noise_is_the_lookup3_hash_of_the_points_float32_bits(kernels):
    """3D Value: hashword(bits x, y, z) x 2^-32; 1D Color: hash of W, then of (W, 1.0) and (W, 2.0)."""
    points = snapped_points()
    value = shoot(Link(GraphNode("TEX_WHITE_NOISE", {"dimensions": "3D"}, {"Vector": snapped_vector()}), "Value"),
                  kernels)[..., 0]
    expected = np.array([[final_of(3, [bits(c) for c in p]) for p in row] for row in points], np.float64)
    np.testing.assert_array_equal(value, (expected.astype(np.float32) * np.float32(2.0**-32)).astype(np.float32))
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": snapped_vector()}), "X")
    color = shoot(Link(GraphNode("TEX_WHITE_NOISE", {"dimensions": "1D"}, {"W": x}), "Color"), kernels)
    w = points[..., 0]
    words = [lambda v: [bits(v)], lambda v: [bits(v), bits(1.0)], lambda v: [bits(v), bits(2.0)]]
    for channel, make in enumerate(words):
        h = np.array([[final_of(len(make(v)), make(v)) for v in row] for row in w], np.float64)
        np.testing.assert_array_equal(color[..., channel], (h.astype(np.float32) * np.float32(2.0**-32)))


@pytest.mark.parametrize("kernels", KERNELS)
def test_checker_squares_are_color1_where_the_floors_sum_to_an_odd_number(kernels):
    """Cycles' checker of the (default Generated) point x Scale 2: Color1 where floor(2x) + floor(2y) + floor(0.6)
    is odd, Color2 where even; four pixels per square, so every sample of a pixel falls in one square."""
    link = Link(GraphNode("TEX_CHECKER", {}, {"Color1": (1.0, 0.5, 0.25), "Color2": (0.0, 0.1, 0.2), "Scale": 2.0}),
                "Color")
    image = shoot(link, kernels)
    centres = (np.arange(SIZE) + 0.5) / SIZE
    x, y = np.meshgrid(centres, centres[::-1])
    odd = (np.floor(2 * x) + np.floor(2 * y)) % 2 == 1
    np.testing.assert_allclose(image, np.where(odd[..., None], [1.0, 0.5, 0.25], [0.0, 0.1, 0.2]), atol=1e-7)


GRADIENTS = {
    "LINEAR": lambda x, y, z: x,
    "QUADRATIC": lambda x, y, z: np.maximum(x, 0.0) ** 2,
    "EASING": lambda x, y, z: 3 * np.clip(x, 0, 1) ** 2 - 2 * np.clip(x, 0, 1) ** 3,
    "DIAGONAL": lambda x, y, z: (x + y) / 2,
    "RADIAL": lambda x, y, z: np.arctan2(y, x) / (2 * np.pi) + 0.5,
    "QUADRATIC_SPHERE": lambda x, y, z: np.maximum(0.999999 - np.sqrt(x * x + y * y + z * z), 0.0) ** 2,
    "SPHERICAL": lambda x, y, z: np.maximum(0.999999 - np.sqrt(x * x + y * y + z * z), 0.0),
}


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("kind", list(GRADIENTS))
def test_each_gradient_is_its_formula_clamped_to_0_1(kind, kernels):
    """Linear x, quadratic max(x, 0)^2, easing 3r^2 - 2r^3, diagonal (x + y) / 2, radial atan2(y, x) / 2pi + 1/2,
    spherical 0.999999 - |p| and its square, clamped to [0, 1], at points of -2..2 scaled by 1/2 (z 0.1)."""
    half = Link(GraphNode("MAPPING", {"type": "POINT"}, {"Vector": snapped_vector(0.2), "Scale": (0.5, 0.5, 0.5)}),
                "Vector")
    image = shoot(Link(GraphNode("TEX_GRADIENT", {"gradient_type": kind}, {"Vector": half}), "Fac"), kernels)
    p = snapped_points(0.2).astype(np.float64) * 0.5
    expected = np.clip(GRADIENTS[kind](p[..., 0], p[..., 1], p[..., 2]), 0.0, 1.0)
    assert expected.std() > 0.05
    np.testing.assert_allclose(image[..., 0], expected, atol=3e-7)


WAVES = {   # (wave type, bands direction, rings direction) -> the wave's argument n of the nudged point
    ("BANDS", "X", "X"): lambda x, y, z: 20 * x,
    ("BANDS", "Y", "X"): lambda x, y, z: 20 * y,
    ("BANDS", "Z", "X"): lambda x, y, z: 20 * z,
    ("BANDS", "DIAGONAL", "X"): lambda x, y, z: 10 * (x + y + z),
    ("RINGS", "X", "X"): lambda x, y, z: 20 * np.sqrt(y * y + z * z),
    ("RINGS", "X", "Y"): lambda x, y, z: 20 * np.sqrt(x * x + z * z),
    ("RINGS", "X", "Z"): lambda x, y, z: 20 * np.sqrt(x * x + y * y),
    ("RINGS", "X", "SPHERICAL"): lambda x, y, z: 20 * np.sqrt(x * x + y * y + z * z),
}
PROFILES = {
    "SIN": lambda n: 0.5 - 0.5 * np.cos(n),
    "SAW": lambda n: n / (2 * np.pi) - np.floor(n / (2 * np.pi)),
    "TRI": lambda n: 2 * np.abs(n / (2 * np.pi) - np.floor(n / (2 * np.pi) + 0.5)),
}


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("profile", list(PROFILES))
@pytest.mark.parametrize("waves", list(WAVES))
def test_wave_bands_and_rings_are_their_profile_of_20_times_the_distance_along_or_from_the_axis(waves, profile,
                                                                                                kernels):
    """Without distortion the wave is the profile (sine 1/2 - cos(n)/2, saw n/2pi mod 1, triangle twice the distance
    of n/2pi to the nearest integer) of n + Phase Offset: n 20 x the coordinate (10 x (x + y + z) diagonally) or 20
    x the distance from the rings' axis (or the origin), at the point x Scale nudged to (p + 1e-6) x 0.999999."""
    wave_type, bands, rings = waves
    link = Link(GraphNode("TEX_WAVE", {"wave_type": wave_type, "bands_direction": bands, "rings_direction": rings,
                                       "wave_profile": profile},
                          {"Vector": snapped_vector(0.2), "Scale": 0.125, "Phase Offset": 0.3}), "Fac")
    image = shoot(link, kernels)[..., 0]
    p = (snapped_points(0.2).astype(np.float64) * 0.125 + 1e-6) * 0.999999
    expected = PROFILES[profile](WAVES[waves](p[..., 0], p[..., 1], p[..., 2]) + 0.3)
    assert expected.std() > 0.05 or (wave_type, bands) == ("BANDS", "Z")     # (Z bands: one value at z = 0.2)
    # (a saw's or triangle's seam is not on a pixel centre: the nearest lies 2e-3 away in n / 2pi)
    np.testing.assert_allclose(image, expected, atol=2e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_wave_distortion_adds_distortion_times_twice_the_normalized_fbm_less_one(kernels):
    """Distortion d moves n by d (2 fBM(p x Detail Scale) - 1), fBM at lacunarity 2 normalized to [0, 1]: with a
    saw profile (n / 2pi mod 1) and no Detail, the bands shift by d (2 (snoise / 2 + 1/2) - 1) / 2pi = d snoise /
    2pi, snoise 0 on the integer lattice of p x Detail Scale, so integer points are not moved."""
    settings = {"wave_type": "BANDS", "bands_direction": "X", "wave_profile": "SAW"}
    plain = shoot(Link(GraphNode("TEX_WAVE", settings, {"Vector": snapped_vector(0.2), "Scale": 0.125}), "Fac"),
                  kernels)[..., 0]
    moved = shoot(Link(GraphNode("TEX_WAVE", settings, {"Vector": snapped_vector(0.2), "Scale": 0.125,
                                                        "Distortion": 0.5, "Detail": 0.0, "Detail Scale": 3.0}),
                       "Fac"), kernels)[..., 0]
    p = (snapped_points(0.2) * np.float32(0.125) + np.float32(1e-6)) * np.float32(0.999999)
    shift = 0.5 * perlin.snoise(p.reshape(-1, 3) * np.float32(3.0)).reshape(SIZE, SIZE) / (2 * np.pi)
    assert np.abs(shift).max() > 0.01
    np.testing.assert_allclose((moved - plain + 0.5) % 1.0 - 0.5, shift, atol=1e-5)


def magic(p: np.ndarray, scale: float, depth: int, distortion: float) -> np.ndarray:
    """Cycles' svm_magic written out in float64: (n, 3) points -> (n, 3) colours."""
    px, py, pz = (np.fmod(p[:, k], 2 * np.pi) for k in range(3))
    x = np.sin((px + py + pz) * 5 * scale)
    y = np.cos((-px + py - pz) * 5 * scale)
    z = -np.cos((-px - py + pz) * 5 * scale)
    if depth > 0:
        x, y, z = x * distortion, y * distortion, z * distortion
        y = -np.cos(x - y + z) * distortion
    steps = [lambda x, y, z: (np.cos(x - y - z) * distortion, y, z),
             lambda x, y, z: (x, y, np.sin(-x - y - z) * distortion),
             lambda x, y, z: (-np.cos(-x + y - z) * distortion, y, z),
             lambda x, y, z: (x, -np.sin(-x + y + z) * distortion, z),
             lambda x, y, z: (x, -np.cos(-x + y + z) * distortion, z),
             lambda x, y, z: (np.cos(x + y + z) * distortion, y, z),
             lambda x, y, z: (x, y, np.sin(x + y - z) * distortion),
             lambda x, y, z: (-np.cos(-x - y + z) * distortion, y, z),
             lambda x, y, z: (x, -np.sin(x - y + z) * distortion, z)]
    for step in steps[:max(depth - 1, 0)]:
        x, y, z = step(x, y, z)
    if distortion != 0:
        x, y, z = x / (2 * distortion), y / (2 * distortion), z / (2 * distortion)
    return np.stack([0.5 - x, 0.5 - y, 0.5 - z], axis=1)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("depth", [0, 1, 2, 5, 10])
def test_magic_is_its_folded_sines_and_cosines_and_fac_their_average(depth, kernels):
    """Depth 0: (1/2 - sin(5s(x + y + z)), 1/2 - cos(5s(-x + y - z)), 1/2 + cos(5s(-x - y + z))) / (2 Distortion)
    about 1/2; each further level replaces one component by a sine or cosine of a signed sum of all three; Fac is
    the average of the colour."""
    inputs = {"Vector": snapped_vector(0.2), "Scale": 0.4, "Distortion": 1.3}
    color = shoot(Link(GraphNode("TEX_MAGIC", {"depth": depth}, inputs), "Color"), kernels)
    fac = shoot(Link(GraphNode("TEX_MAGIC", {"depth": depth}, inputs), "Fac"), kernels)[..., 0]
    expected = magic(snapped_points(0.2).reshape(-1, 3).astype(np.float64), 0.4, depth, 1.3).reshape(SIZE, SIZE, 3)
    assert expected.std() > 0.05
    np.testing.assert_allclose(color, expected, atol=2e-5)
    np.testing.assert_allclose(fac, expected.mean(axis=2), atol=2e-5)


def brick_noise(n: int) -> float:
    """Cycles' brick_noise on Python integers: the low 31 bits of n + 1013, xor-shifted by 13, through
    n (60493 n^2 + 19990303) + 1376312589, over 2^31."""
    n = (n + 1013) & 0x7FFFFFFF
    n = (n >> 13) ^ n
    return 0.5 * (((n * (n * n * 60493 + 19990303) + 1376312589) & 0x7FFFFFFF) / 2.0**30)


@pytest.mark.parametrize("kernels", KERNELS)
def test_bricks_are_tinted_by_the_hash_of_row_and_column_within_mortar_lines(kernels):
    """Rows of 0.7, bricks of 0.9 (x 1.3 on rows divisible by 3), rows divisible by 2 shifted by 0.4 x the width:
    a point in brick (column, row) has Color1 mixed to Color2 by brick_noise((row << 16) + (column & 0xFFFF)) + Bias,
    or the Mortar colour within Mortar Size of the brick's edge (Mortar Smooth 0: a hard line)."""
    color1, color2, mortar = np.array([0.9, 0.5, 0.1]), np.array([0.1, 0.3, 0.8]), np.array([0.0, 0.05, 0.1])
    link = Link(GraphNode("TEX_BRICK", {"offset_frequency": 2, "squash_frequency": 3}, {
        "Vector": snapped_vector(0.2), "Color1": tuple(color1), "Color2": tuple(color2), "Mortar": tuple(mortar),
        "Scale": 1.0, "Mortar Size": 0.09, "Mortar Smooth": 0.0, "Bias": 0.1, "Brick Width": 0.9,
        "Row Height": 0.7, "Offset": 0.4, "Squash": 1.3}), "Color")
    image = shoot(link, kernels)
    expected = np.zeros((SIZE, SIZE, 3))
    points = snapped_points(0.2).astype(np.float64)
    for i in range(SIZE):
        for j in range(SIZE):
            x, y = points[i, j, 0], points[i, j, 1]
            row = int(np.floor(y / 0.7))
            width = 0.9 * (1.3 if row % 3 == 0 else 1.0)
            shift = 0.4 * width if row % 2 == 0 else 0.0
            column = int(np.floor((x + shift) / width))
            u, v = x + shift - width * column, y - 0.7 * row
            tint = min(max(brick_noise(((row << 16) + (column & 0xFFFF)) & 0xFFFFFFFF) + 0.1, 0.0), 1.0)
            inside = min(u, v, width - u, 0.7 - v) >= 0.09
            expected[i, j] = (1 - tint) * color1 + tint * color2 if inside else mortar
    assert (expected == mortar).all(axis=2).any() and expected.std() > 0.05
    np.testing.assert_allclose(image, expected, atol=1e-6)


def gabor_2d(x: float, y: float, frequency: float, angle: float) -> complex:
    """Cycles' 2D Gabor noise without anisotropy's randomness, in float64: over the 3 x 3 cells about (x, y), 8
    kernels each at the centre (h(cx, cy, 3k + 1), h(3k + 1, cx, cy)) with sign -1 where h(cx, cy, 3k + 2) < 1/2,
    each e^(-pi d^2) (1/2 + cos(pi d^2) / 2) e^(2 pi i f (cos a, sin a) . offset) within distance 1."""
    h = lambda *words: float(hash_.hash_float3(*(np.float32(w) for w in words)))     # noqa: E731
    total = 0j
    for j in (-1, 0, 1):
        for i in (-1, 0, 1):
            cx, cy = np.floor(x) + i, np.floor(y) + j
            for k in range(8):
                ox, oy = x - cx - h(cx, cy, 3 * k + 1), y - cy - h(3 * k + 1, cx, cy)
                d2 = ox * ox + oy * oy
                if d2 < 1.0:
                    sign = -1.0 if h(cx, cy, 3 * k + 2) < 0.5 else 1.0
                    window = np.exp(-np.pi * d2) * (0.5 + 0.5 * np.cos(np.pi * d2))
                    total += sign * window * np.exp(2j * np.pi * frequency * (ox * np.cos(angle) + oy * np.sin(angle)))
    return total


@pytest.mark.parametrize("kernels", KERNELS)
def test_gabor_noise_is_the_sum_of_its_cells_windowed_kernels_and_its_outputs_one_phasor(kernels):
    """Anisotropy 1 (every kernel along Orientation): Value is Im / 6 / 2 + 1/2 and Intensity |sum| / 6 of the
    kernels written out in float64 (2D: sigma 1); Phase is (arg + pi) / 2pi, so 2 Value - 1 = -Intensity x
    sin(2pi Phase) on both dimensions."""
    inputs = {"Vector": snapped_vector(0.2), "Scale": 1.3, "Frequency": 1.7, "Anisotropy": 1.0,
              "Orientation 2D": 0.6, "Orientation 3D": (0.2, 0.4, 0.9)}
    points = snapped_points(0.2).astype(np.float64) * np.float64(np.float32(1.3))
    expected = np.array([[gabor_2d(np.float32(p[0]), np.float32(p[1]), 1.7, 0.6) for p in row] for row in points])
    outputs = {}
    for dimensions in ("2D", "3D"):
        for output in ("Value", "Phase", "Intensity"):
            link = Link(GraphNode("TEX_GABOR", {"gabor_type": dimensions}, inputs), output)
            outputs[dimensions, output] = shoot(link, kernels)[..., 0]
        value, phase, intensity = (outputs[dimensions, name] for name in ("Value", "Phase", "Intensity"))
        assert intensity.std() > 0.01
        np.testing.assert_allclose(2 * value - 1, -intensity * np.sin(2 * np.pi * phase), atol=1e-5)
    np.testing.assert_allclose(outputs["2D", "Value"], expected.imag / 6 / 2 + 0.5, atol=1e-5)
    np.testing.assert_allclose(outputs["2D", "Intensity"], np.abs(expected) / 6, atol=1e-5)


def test_perlin_noise_is_zero_on_the_integer_lattice_and_within_minus_one_one():
    """At integer points every corner's offset is 0 or the fade is 0: snoise is exactly 0, in 1 to 4 dimensions;
    at 10^5 random points it stays within [-1, 1] (the OSL scales' purpose)."""
    rng = np.random.default_rng(3)
    for d in (1, 2, 3, 4):
        lattice = rng.integers(-5000, 5000, (1000, d)).astype(np.float32)
        np.testing.assert_array_equal(perlin.snoise(lattice), 0.0)
        values = perlin.snoise(rng.uniform(-100.0, 100.0, (100000, d)).astype(np.float32))
        assert np.abs(values).max() <= 1.0 and values.std() > 0.1


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_fractional_detail_blends_the_normalized_fbm_of_the_octave_counts_either_side(kernels):
    """fBM at Detail 1.25 = 0.75 fBM(Detail 1) + 0.25 fBM(Detail 2), each normalized by its amplitudes."""
    def fac(detail):
        node = GraphNode("TEX_NOISE", {"dimensions": "3D", "noise_type": "FBM"},
                         {"Vector": snapped_vector(), "Detail": detail, "Roughness": 0.7, "Scale": 1.3})
        return shoot(Link(node, "Fac"), kernels)[..., 0]
    low, high, between = fac(1.0), fac(2.0), fac(1.25)
    np.testing.assert_allclose(between, 0.75 * low + 0.25 * high, atol=2e-7)
    assert np.abs(high - low).max() > 0.01


def voronoi(feature: str, metric: str, output: str, **inputs) -> np.ndarray:
    """A 2D Voronoi's `output` at the snapped points x 1.3, Randomness 0 (each cell's point at its lower corner)."""
    node = GraphNode("TEX_VORONOI", {"dimensions": "2D", "feature": feature, "metric": metric},
                     {"Vector": snapped_vector(), "Scale": 1.3, "Randomness": 0.0, **inputs})
    return Link(node, output)


@pytest.mark.parametrize("kernels", KERNELS)
def test_voronoi_without_randomness_measures_to_the_integer_lattice(kernels):
    """Randomness 0 puts the points on the integer lattice: F1 is the distance to the rounded point (Euclidean,
    Manhattan, Chebychev; Minkowski with exponent 1 and 2 is Manhattan and Euclidean), F2 the next lattice point's
    (sqrt(a^2 + (1 - b)^2) for offsets a <= b from the nearest), Distance to Edge 1/2 - the larger offset, the
    N-Sphere Radius 1/2."""
    p = snapped_points()[..., :2].astype(np.float64) * np.float32(1.3).astype(np.float64)
    offset = np.abs(p - np.round(p))
    small, large = offset.min(axis=2), offset.max(axis=2)
    expected = {
        ("F1", "EUCLIDEAN", "Distance", 1.0): np.hypot(offset[..., 0], offset[..., 1]),
        ("F1", "MANHATTAN", "Distance", 1.0): offset.sum(axis=2),
        ("F1", "CHEBYCHEV", "Distance", 1.0): large,
        ("F1", "MINKOWSKI", "Distance", 1.0): offset.sum(axis=2),
        ("F1", "MINKOWSKI", "Distance", 2.0): np.hypot(offset[..., 0], offset[..., 1]),
        ("F2", "EUCLIDEAN", "Distance", 1.0): np.hypot(small, 1.0 - large),
        ("DISTANCE_TO_EDGE", "EUCLIDEAN", "Distance", 1.0): 0.5 - large,
        ("N_SPHERE_RADIUS", "EUCLIDEAN", "Radius", 1.0): np.full(small.shape, 0.5),
    }
    assert (np.abs(offset - 0.5) > 1e-3).all()          # no point halfway between two lattice points
    for (feature, metric, output, exponent), value in expected.items():
        image = shoot(voronoi(feature, metric, output, Exponent=exponent), kernels)[..., 0]
        np.testing.assert_allclose(image, value, atol=1e-6, err_msg=f"{feature} {metric} {exponent}")


def all_textures() -> list:
    """A link of every texture, dimension, fractal and gradient type, fed by UV-dependent inputs."""
    uv = Link(GraphNode("TEXCOORD", {}, {}), "UV")
    separate = GraphNode("SEPARATE_XYZ", {}, {"Vector": uv})
    x, y = Link(separate, "X"), Link(separate, "Y")
    stretched = Link(GraphNode("MAPPING", {"type": "POINT"}, {"Vector": uv, "Location": (-3.0, -1.0, 0.4),
                                                              "Scale": (7.0, 5.0, 1.0)}), "Vector")
    links = []
    for dimensions in ("1D", "2D", "3D", "4D"):
        for kind in perlin.NOISE_TYPES:
            for output in ("Fac", "Color"):
                links.append(Link(GraphNode("TEX_NOISE", {"dimensions": dimensions, "noise_type": kind,
                                                          "normalize": output == "Fac"},
                                            {"Vector": stretched, "W": x, "Detail": Link(GraphNode(
                                                "MATH", {"operation": "MULTIPLY"}, {"0": y, "1": 6.0}), "Value"),
                                             "Roughness": 0.55, "Lacunarity": 2.3, "Offset": 0.8, "Gain": 1.5,
                                             "Distortion": y}), output))
        links.append(Link(GraphNode("TEX_WHITE_NOISE", {"dimensions": dimensions}, {"Vector": stretched, "W": y}),
                          "Color"))
    for kind in GRADIENTS:
        links.append(Link(GraphNode("TEX_GRADIENT", {"gradient_type": kind},
                                    {"Vector": Link(GraphNode("MAPPING", {"type": "POINT"}, {
                                        "Vector": uv, "Location": (-0.5, -0.5, 0.0), "Scale": (3.0, 3.0, 1.0)}),
                                                    "Vector")}), "Color"))
    links.append(Link(GraphNode("TEX_CHECKER", {}, {"Vector": stretched, "Scale": y, "Color1": (0.9, 0.1, 0.4)}),
                      "Color"))
    outputs = {"F1": "Color", "F2": "Position", "SMOOTH_F1": "W", "DISTANCE_TO_EDGE": "Distance",
               "N_SPHERE_RADIUS": "Radius"}
    for dimensions in ("1D", "2D", "3D", "4D"):
        for feature, output in outputs.items():
            metrics = ("EUCLIDEAN",) if dimensions == "1D" else ("EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI")
            if feature == "SMOOTH_F1" and dimensions == "4D":
                metrics = ("MINKOWSKI",)            # (5^4 cells an octave: slow in numpy)
            for metric in metrics:
                links.append(Link(GraphNode("TEX_VORONOI", {"dimensions": dimensions, "feature": feature,
                                                            "metric": metric, "normalize": metric != "MANHATTAN"},
                                            {"Vector": stretched, "W": x, "Detail": Link(GraphNode(
                                                "MATH", {"operation": "MULTIPLY"}, {"0": y, "1": 3.0}), "Value"),
                                             "Smoothness": y, "Exponent": 1.7, "Randomness": 0.9, "Scale": 0.7}),
                                  output))
    wide = Link(GraphNode("MAPPING", {"type": "POINT"}, {"Vector": uv, "Location": (-0.5, -0.5, 0.3),
                                                         "Scale": (0.6, 0.6, 1.0)}), "Vector")
    for wave_type, direction in (("BANDS", "X"), ("BANDS", "Y"), ("BANDS", "Z"), ("BANDS", "DIAGONAL"),
                                 ("RINGS", "X"), ("RINGS", "Y"), ("RINGS", "Z"), ("RINGS", "SPHERICAL")):
        for profile in ("SIN", "SAW", "TRI"):
            settings = {"wave_type": wave_type, "wave_profile": profile,
                        ("bands_direction" if wave_type == "BANDS" else "rings_direction"): direction}
            links.append(Link(GraphNode("TEX_WAVE", settings, {
                "Vector": wide, "Distortion": Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": y, "1": 4.0}),
                                                   "Value"),
                "Detail": Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": x, "1": 5.0}), "Value"),
                "Detail Scale": 1.7, "Detail Roughness": 0.6, "Phase Offset": x}), "Fac"))
    for depth in range(11):
        links.append(Link(GraphNode("TEX_MAGIC", {"depth": depth}, {
            "Vector": stretched, "Scale": 0.3, "Distortion": Link(GraphNode(
                "MATH", {"operation": "MULTIPLY"}, {"0": y, "1": 3.0}), "Value")}), "Color"))
    for offset_frequency, squash_frequency, smooth in ((2, 2, 0.3), (1, 3, 0.0), (3, 1, 1.0)):
        links.append(Link(GraphNode("TEX_BRICK", {"offset_frequency": offset_frequency,
                                                  "squash_frequency": squash_frequency}, {
            "Vector": stretched, "Color1": (0.9, 0.5, 0.1), "Color2": (0.1, 0.3, 0.8), "Mortar": (0.0, 0.05, 0.1),
            "Scale": 0.6, "Mortar Size": Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": y, "1": 0.2}),
                                              "Value"),
            "Mortar Smooth": smooth, "Bias": Link(GraphNode("MATH", {"operation": "SUBTRACT"}, {"0": x, "1": 0.5}),
                                                  "Value"),
            "Brick Width": 0.7, "Row Height": 0.3, "Offset": 0.35, "Squash": 1.6}), "Color"))
    for dimensions in ("2D", "3D"):
        for output in ("Value", "Phase", "Intensity"):
            links.append(Link(GraphNode("TEX_GABOR", {"gabor_type": dimensions}, {
                "Vector": stretched, "Scale": 0.4, "Frequency": Link(GraphNode(
                    "MATH", {"operation": "MULTIPLY"}, {"0": y, "1": 4.0}), "Value"),
                "Anisotropy": x, "Orientation 2D": 0.3, "Orientation 3D": (0.3, -0.5, 0.8)}), output))
    links.append(Link(GraphNode("TEX_CHECKER", {}, {}), "Fac"))
    return links


def assert_both_kernels_agree(links: list, generated: bool = False) -> None:
    """Each link as the emission of its own unit plane in a grid of 8 columns seen from above, rendered at one sample
    on both kernels: the same values to the bit, finite and varying (`generated`: each plane's Generated coordinates
    its UV, at z = 0.3)."""
    columns = 8
    rows = -(-len(links) // columns)
    scene = Scene(camera=ortho_down(center=(columns / 2, rows / 2, 0.0), height=2.0, scale=float(max(columns, rows))))
    for index, link in enumerate(links):
        scene.materials.append(Material(name=f"P{index}", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})]))
        mesh = primitives.plane(1.0, center=(index % columns + 0.5, index // columns + 0.5, 0.0))
        mesh.attributes = plane_attributes(mesh)
        if generated:
            uv = mesh.attributes["uv:"]
            mesh.attributes["generated"] = np.concatenate([uv[..., :2], np.full(uv.shape[:2] + (1,), 0.3)], axis=2)
        scene.add_mesh(mesh, materials=np.array([index]), name=f"P{index}")
    settings = RenderSettings(width=80, height=80, samples=1)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_array_equal(compiled.image, reference.image)
    assert np.isfinite(reference.image).all() and reference.image[..., :3].std() > 0.1


def test_the_compiled_textures_compute_what_the_reference_computes_bit_for_bit():
    """Every texture on both kernels, the same rays and samples: the same float32 values, to the bit."""
    assert_both_kernels_agree(all_textures(), generated=True)


def test_voronoi_warns_on_blenders_whose_cycles_hashed_its_cells_otherwise():
    """Cycles before Blender 5.0 placed 2D to 4D Voronoi points by lookup3 of float cells: the add-on says so there
    (1D, and Blender 5.0 on, need no note); the other textures are Cycles 4.2's too."""
    from core.materials.procedural import TEXTURE_TYPES, VoronoiTexture
    assert "before 5.0" in VoronoiTexture.differs_in({"dimensions": "2D"}, (4, 2, 0))
    assert VoronoiTexture.differs_in({"dimensions": "1D"}, (4, 2, 0)) is None
    assert VoronoiTexture.differs_in({"dimensions": "4D"}, (5, 0, 0)) is None
    assert [cls for cls in TEXTURE_TYPES if cls.differs_in({}, (4, 2, 0))] == [VoronoiTexture]


def test_magic_warns_on_blenders_whose_cycles_wraps_the_scaled_point():
    """Cycles of Blender 5.2 wraps the point x Scale every 2pi where 5.0 (and 4.2) wrap the point: said there; no
    other texture differs between 5.0 and 5.2."""
    from core.materials.procedural import TEXTURE_TYPES, MagicTexture
    assert "5.2" in MagicTexture.differs_in({"depth": 2}, (5, 2, 0))
    assert MagicTexture.differs_in({"depth": 2}, (5, 0, 1)) is None
    assert MagicTexture.differs_in({"depth": 2}, (4, 2, 0)) is None
    assert [cls for cls in TEXTURE_TYPES if cls.differs_in({}, (5, 2, 0))] == [MagicTexture]
