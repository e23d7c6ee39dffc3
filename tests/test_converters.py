"""Converter and colour nodes (core/materials/converters) against closed forms on both kernels, and the compiled twin
against the numpy reference bit for bit on inputs that vary across the image.

Each closed form reads the Generated coordinate snapped to its pixel's centre (test_procedural.snapped_vector: x, y in
-2..2, z 0.375, exact in float32), so every pixel knows its input: Vector Math's identities (A x A = 0, A.A = |A|^2,
the projection of A on itself, a reflection twice, Refract at IOR 1 and Faceforward, Wrap and Snap), a quarter turn of
Vector Rotate, Gamma 2.2 of 0.5 as 0.5^2.2, Brightness/Contrast's line, RGB to BW of white as 1, Blackbody at 6500 K
near white, Wavelength at 550 nm green, HSV and HSL round trips, and curves through the identity points returning
their input inside and (extrapolated) outside the baked range.
"""
from __future__ import annotations

import numpy as np
import pytest

from core.materials.converters.curves import CURVE_TABLE_SIZE, curve_table
from core.materials.graph import GraphNode, Link

from test_procedural import assert_both_kernels_agree, shoot, snapped_points, snapped_vector

KERNELS = ["compiled", "numpy"]
F32_EPS = 1.2e-7


def node(kind: str, output: str, props: dict = None, **inputs) -> Link:
    """A Link to `output` of a new GraphNode (inputs by socket name; Vector_001 ... as Blender names them)."""
    return Link(GraphNode(kind, props or {}, dict(inputs)), output)


def vector_math(operation: str, output: str = "Vector", **inputs) -> Link:
    """A Vector Math node's output (inputs: Vector, Vector_001, Vector_002, Scale)."""
    return node("VECTOR_MATH", output, {"operation": operation}, **inputs)


@pytest.mark.parametrize("kernels", KERNELS)
def test_vector_math_identities_hold_at_every_pixel(kernels):
    """A x A = 0; A.A = |A|^2 (within float32 rounding); Distance(A, A) = 0; the projection of A on A is A; A reflected
    twice about B is A; Refract at IOR 1 through a normal facing A passes A on; Faceforward flips A where C.B >= 0;
    Wrap lands in [min, max); Snap lands on multiples of the increment; Multiply Add is A B + C; Round (Blender 5.1
    and later) is the nearest integer, halves up."""
    p = snapped_points().astype(np.float64)
    v = snapped_vector()
    b = (0.3, -0.5, 0.8)
    assert np.abs(shoot(vector_math("CROSS_PRODUCT", Vector=v, Vector_001=v), kernels)).max() == 0.0
    dot = shoot(vector_math("DOT_PRODUCT", "Value", Vector=v, Vector_001=v), kernels)[..., 0]
    length = shoot(vector_math("LENGTH", "Value", Vector=v), kernels)[..., 0]
    np.testing.assert_allclose(dot, (p * p).sum(axis=2), rtol=4 * F32_EPS)
    np.testing.assert_allclose(length ** 2, dot, rtol=8 * F32_EPS)
    assert np.abs(shoot(vector_math("DISTANCE", "Value", Vector=v, Vector_001=v), kernels)).max() == 0.0
    np.testing.assert_allclose(shoot(vector_math("PROJECT", Vector=v, Vector_001=v), kernels), p, atol=4e-7)
    twice = vector_math("REFLECT", Vector=vector_math("REFLECT", Vector=v, Vector_001=b), Vector_001=b)
    np.testing.assert_allclose(shoot(twice, kernels), p, atol=1e-6)
    facing = vector_math("FACEFORWARD", Vector=v, Vector_001=v, Vector_002=(0.0, 0.0, -1.0))   # C.B = -z < 0: A
    np.testing.assert_array_equal(shoot(facing, kernels), p)
    flipped = vector_math("FACEFORWARD", Vector=v, Vector_001=v, Vector_002=(0.0, 0.0, 1.0))    # C.B > 0: -A
    np.testing.assert_array_equal(shoot(flipped, kernels), -p)
    through = vector_math("REFRACT", Vector=vector_math("SCALE", Vector=v, Scale=-1.0), Vector_001=v, Scale=1.0)
    np.testing.assert_allclose(shoot(through, kernels), -p, atol=1e-6)
    wrapped = shoot(vector_math("WRAP", Vector=v, Vector_001=(0.7, 0.7, 0.7), Vector_002=(0.2, 0.2, 0.2)), kernels)
    assert wrapped.min() >= 0.2 and wrapped.max() < 0.7
    np.testing.assert_allclose(wrapped, 0.2 + np.mod(p - 0.2, 0.5), atol=1e-6)
    snapped = shoot(vector_math("SNAP", Vector=v, Vector_001=(0.3, 0.3, 0.3)), kernels)
    np.testing.assert_allclose(snapped, np.floor(p / 0.3) * 0.3, atol=1e-6)
    fused = vector_math("MULTIPLY_ADD", Vector=v, Vector_001=(2.0, 3.0, 4.0), Vector_002=(5.0, 5.0, 5.0))
    np.testing.assert_allclose(shoot(fused, kernels), p * (2.0, 3.0, 4.0) + 5.0, rtol=F32_EPS)
    rounded = shoot(vector_math("ROUND", Vector=vector_math("SCALE", Vector=v, Scale=2.5)), kernels)   # Blender 5.1+
    np.testing.assert_array_equal(rounded, np.floor(p.astype(np.float32) * np.float32(2.5) + np.float32(0.5)))


@pytest.mark.parametrize("kernels", KERNELS)
def test_vector_rotate_turns_a_quarter_about_z_and_the_euler_inverse_undoes_it(kernels):
    """A quarter turn about Z maps (x, y, z) to (-y, x, z); an Euler rotation then its inverse is the identity; a zero
    axis leaves the vector as it is."""
    p = snapped_points().astype(np.float64)
    v = snapped_vector()
    turned = node("VECTOR_ROTATE", "Vector", {"rotation_type": "Z_AXIS"}, Vector=v, Angle=np.pi / 2)
    back = node("VECTOR_ROTATE", "Vector", {"rotation_type": "AXIS_ANGLE"}, Vector=turned, Axis=(0.0, 0.0, 1.0),
                Angle=-np.pi / 2)
    np.testing.assert_allclose(shoot(turned, kernels), np.stack([-p[..., 1], p[..., 0], p[..., 2]], axis=2), atol=3e-7)
    np.testing.assert_allclose(shoot(back, kernels), p, atol=5e-7)
    euler = node("VECTOR_ROTATE", "Vector", {"rotation_type": "EULER_XYZ"}, Vector=v, Rotation=(0.3, -0.7, 1.1),
                 Center=(0.1, 0.2, 0.3))
    undone = node("VECTOR_ROTATE", "Vector", {"rotation_type": "EULER_XYZ", "invert": True}, Vector=euler,
                  Rotation=(0.3, -0.7, 1.1), Center=(0.1, 0.2, 0.3))
    np.testing.assert_allclose(shoot(undone, kernels), p, atol=1e-6)
    still = node("VECTOR_ROTATE", "Vector", {"rotation_type": "AXIS_ANGLE"}, Vector=v, Axis=(0.0, 0.0, 0.0), Angle=1.0)
    np.testing.assert_array_equal(shoot(still, kernels), p)


@pytest.mark.parametrize("kernels", KERNELS)
def test_colour_nodes_match_their_closed_forms(kernels):
    """Gamma 2.2 of 0.5 is 0.5^2.2; Brightness/Contrast is max((1 + c) x + b - c / 2, 0); RGB to BW of white is 1;
    Blackbody at 6500 K is near white (luminance 1 within 2%); Wavelength at 550 nm is green above red and blue."""
    gamma = shoot(node("GAMMA", "Color", Color=(0.5, 0.5, 0.5), Gamma=2.2), kernels)
    np.testing.assert_allclose(gamma, np.float32(0.5) ** np.float32(2.2), rtol=F32_EPS)
    x = node("SEPARATE_XYZ", "X", Vector=snapped_vector())
    gray = node("COMBINE_XYZ", "Vector", X=x, Y=x, Z=x)
    bc = shoot(node("BRIGHT_CONTRAST", "Color", Color=gray, Bright=0.1, Contrast=0.4), kernels)
    px = snapped_points()[..., 0].astype(np.float64)
    np.testing.assert_allclose(bc[..., 0], np.maximum(1.4 * px + 0.1 - 0.2, 0.0), atol=3e-7)
    white = shoot(node("RGB_TO_BW", "Val", Color=(1.0, 1.0, 1.0)), kernels)
    np.testing.assert_allclose(white, 1.0, atol=2e-6)          # (the configuration's matrices: white is Y 1 to 1e-6)
    body = shoot(node("BLACKBODY", "Color", Temperature=6500.0), kernels)[0, 0]
    assert abs(body @ np.array([0.2126, 0.7152, 0.0722]) - 1.0) < 0.02 and np.abs(body - 1.0).max() < 0.1
    green = shoot(node("WAVELENGTH", "Color", Wavelength=550.0), kernels)[0, 0]
    assert green[1] > 2 * green[0] and green[1] > 10 * green[2]
    assert shoot(node("WAVELENGTH", "Color", Wavelength=300.0), kernels).max() == 0.0


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("mode", ["RGB", "HSV", "HSL"])
def test_separating_and_combining_a_colour_in_one_mode_returns_it(mode, kernels):
    """Separate Color then Combine Color in the same mode gives the colour back (within float32 rounding); the
    channels of RGB are the colour's own."""
    p = snapped_points().astype(np.float64)
    colour = node("VECTOR_MATH", "Vector", {"operation": "MULTIPLY_ADD"}, Vector=snapped_vector(),
                  Vector_001=(0.2, 0.15, 1.0), Vector_002=(0.5, 0.4, 0.2))
    expected = p * (0.2, 0.15, 1.0) + (0.5, 0.4, 0.2)
    separate = GraphNode("SEPARATE_COLOR_MODE", {"mode": mode}, {"Color": colour})
    combined = node("COMBINE_COLOR_MODE", "Color", {"mode": mode}, Red=Link(separate, "Red"),
                    Green=Link(separate, "Green"), Blue=Link(separate, "Blue"))
    np.testing.assert_allclose(shoot(combined, kernels), expected, atol=1e-6)
    hue = shoot(Link(separate, "Red"), kernels)
    assert (hue >= 0.0).all() and (hue <= 1.0).all()
    if mode == "RGB":
        np.testing.assert_allclose(shoot(Link(separate, "Green"), kernels)[..., 0], expected[..., 1], atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_vector_map_range_maps_ranges_linearly_and_clamps_to_the_target(kernels):
    """Linear: from [-2, 2] to [0, 1] is (p + 2) / 4 per component; clamped to [0, 1] from a narrower source range;
    Smoothstep is 3 f^2 - 2 f^3 of the clamped factor."""
    p = snapped_points().astype(np.float64)
    v = snapped_vector()
    wide = node("MAP_RANGE_VECTOR", "Vector", {"clamp": False}, Vector=v, From_Min_FLOAT3=(-2.0, -2.0, -2.0),
                From_Max_FLOAT3=(2.0, 2.0, 2.0))
    np.testing.assert_allclose(shoot(wide, kernels), (p + 2.0) / 4.0, atol=1e-7)
    narrow = node("MAP_RANGE_VECTOR", "Vector", {"clamp": True}, Vector=v, From_Min_FLOAT3=(-1.0, -1.0, -1.0))
    np.testing.assert_allclose(shoot(narrow, kernels), np.clip((p + 1.0) / 2.0, 0.0, 1.0), atol=1e-7)
    smooth = node("MAP_RANGE_VECTOR", "Vector", {"interpolation_type": "SMOOTHSTEP"}, Vector=v,
                  From_Min_FLOAT3=(-1.0, -1.0, -1.0))
    f = np.clip((p + 1.0) / 2.0, 0.0, 1.0)
    np.testing.assert_allclose(shoot(smooth, kernels), 3 * f ** 2 - 2 * f ** 3, atol=3e-7)


def identity_table(columns: int, extrapolate: bool, lo: float = 0.0, hi: float = 1.0) -> np.ndarray:
    """A curve op's table of `columns` identity curves baked over [lo, hi]."""
    x = lo + np.arange(CURVE_TABLE_SIZE) / (CURVE_TABLE_SIZE - 1) * (hi - lo)
    return curve_table(lo, hi, extrapolate, np.repeat(x[:, None], columns, axis=1))


@pytest.mark.parametrize("kernels", KERNELS)
def test_curves_through_the_identity_points_return_their_input(kernels):
    """Identity curves give the input back: inside the baked range, and outside it when extrapolated (the end segments
    continue the line); clamped to the range's ends otherwise; a Factor of 0.5 with a constant curve blends half way."""
    p = snapped_points().astype(np.float64)                  # x, y in -2..2: outside [-1, 1] at the edges
    v = snapped_vector()
    straight = node("VECTOR_CURVES", "Vector", {"table": identity_table(3, True, -1.0, 1.0)}, Fac=1.0, Vector=v)
    np.testing.assert_allclose(shoot(straight, kernels), p, atol=1e-6)
    clamped = node("VECTOR_CURVES", "Vector", {"table": identity_table(3, False, -1.0, 1.0)}, Fac=1.0, Vector=v)
    np.testing.assert_allclose(shoot(clamped, kernels), np.clip(p, -1.0, 1.0), atol=1e-6)
    x = node("SEPARATE_XYZ", "X", Vector=v)
    value = node("FLOAT_CURVE", "Value", {"table": identity_table(1, True)}, Factor=1.0, Value=x)
    np.testing.assert_allclose(shoot(value, kernels)[..., 0], p[..., 0], atol=1e-6)
    flat = curve_table(0.0, 1.0, False, np.full((CURVE_TABLE_SIZE, 3), 0.25))
    half = shoot(node("RGB_CURVES", "Color", {"table": flat}, Fac=0.5, Color=(0.75, 0.5, 0.25)), kernels)
    np.testing.assert_allclose(half[0, 0], [0.5, 0.375, 0.25], atol=1e-7)


def all_converters() -> list:
    """A link of every converter, operation and mode, fed by UV-dependent inputs."""
    from core.materials.converters.color import COLOR_MODES
    from core.materials.converters.vector_math import VECTOR_MATH_OPS
    from core.materials.converters.vector_rotate import ROTATION_TYPES
    uv = Link(GraphNode("TEXCOORD", {}, {}), "UV")
    a = node("MAPPING", "Vector", {"type": "POINT"}, Vector=uv, Location=(-3.0, -1.0, 0.4), Scale=(7.0, 5.0, 1.0))
    b = node("MAPPING", "Vector", {"type": "POINT"}, Vector=uv, Location=(1.0, -2.0, 0.7), Scale=(-4.0, 3.0, 2.0),
             Rotation=(0.3, 0.2, 0.1))
    x = node("SEPARATE_XYZ", "X", Vector=uv)
    y = node("SEPARATE_XYZ", "Y", Vector=uv)
    links = []
    for operation in VECTOR_MATH_OPS:
        output = "Value" if operation in ("DOT_PRODUCT", "DISTANCE", "LENGTH") else "Vector"
        links.append(vector_math(operation, output, Vector=a, Vector_001=b, Vector_002=(0.3, -0.2, 0.5), Scale=y))
    for kind in ROTATION_TYPES:
        for invert in (False, True):
            links.append(node("VECTOR_ROTATE", "Vector", {"rotation_type": kind, "invert": invert}, Vector=a, Center=b,
                              Axis=b, Angle=x, Rotation=b))
    links.append(node("GAMMA", "Color", Color=a, Gamma=y))
    links.append(node("BRIGHT_CONTRAST", "Color", Color=a, Bright=x, Contrast=y))
    links.append(node("RGB_TO_BW", "Val", Color=b))
    links.append(node("BLACKBODY", "Color", Temperature=node("MATH", "Value", {"operation": "MULTIPLY"},
                                                             **{"0": x, "1": 14000.0})))
    links.append(node("WAVELENGTH", "Color", Wavelength=node("MATH", "Value", {"operation": "MULTIPLY_ADD"},
                                                             **{"0": x, "1": 450.0, "2": 360.0})))
    for mode in COLOR_MODES:
        for channel in ("Red", "Green", "Blue"):
            links.append(node("SEPARATE_COLOR_MODE", channel, {"mode": mode}, Color=b))
        links.append(node("COMBINE_COLOR_MODE", "Color", {"mode": mode}, Red=x, Green=y, Blue=0.7))
    for kind in ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP"):
        links.append(node("MAP_RANGE_VECTOR", "Vector", {"interpolation_type": kind, "clamp": kind == "LINEAR"}, Vector=a,
                          From_Min_FLOAT3=(-1.0, 0.5, 0.0), From_Max_FLOAT3=b, To_Max_FLOAT3=(2.0, -1.0, 0.5),
                          Steps_FLOAT3=(3.0, 0.0, 2.5)))
    rng = np.random.default_rng(3)
    for kind, columns, fac, value in (("RGB_CURVES", 3, "Fac", "Color"), ("VECTOR_CURVES", 3, "Fac", "Vector"),
                                      ("FLOAT_CURVE", 1, "Factor", "Value")):
        for extrapolate in (False, True):
            table = curve_table(-0.5, 1.5, extrapolate, np.cumsum(rng.random((CURVE_TABLE_SIZE, columns)), axis=0) / 50)
            links.append(node(kind, value, {"table": table}, **{fac: y, value: x if columns == 1 else a}))
    return links


def test_the_compiled_converters_compute_what_the_reference_computes_bit_for_bit():
    """Every converter, operation and mode on both kernels, the same rays and samples: the same values, to the bit."""
    assert_both_kernels_agree(all_converters())


@pytest.mark.parametrize("kernels", KERNELS)
def test_smooth_minimum_and_maximum_bend_by_a_cubic_within_the_distance_and_truncate_rounds_towards_zero(kernels):
    """Smooth Minimum of a, b at distance k is min(a, b) - k h^3 / 6, h = max(k - |a - b|, 0) / k (Cycles'
    smoothminf), Smooth Maximum its mirror max(a, b) + k h^3 / 6; at distance 0 they are min and max; Truncate is
    floor |a| with a's sign."""
    p = snapped_points().astype(np.float64)
    x, y = node("SEPARATE_XYZ", "X", Vector=snapped_vector()), node("SEPARATE_XYZ", "Y", Vector=snapped_vector())
    a, b = p[..., 0], p[..., 1]
    for k in (1.5, 0.0):
        h = np.maximum(k - np.abs(a - b), 0.0) / k if k else 0.0
        low = shoot(node("MATH", "Value", {"operation": "SMOOTH_MIN"}, **{"0": x, "1": y, "2": k}), kernels)
        high = shoot(node("MATH", "Value", {"operation": "SMOOTH_MAX"}, **{"0": x, "1": y, "2": k}), kernels)
        np.testing.assert_allclose(low[..., 0], np.minimum(a, b) - k * h ** 3 / 6.0, atol=1e-7)
        np.testing.assert_allclose(high[..., 0], np.maximum(a, b) + k * h ** 3 / 6.0, atol=1e-7)
    trunc = shoot(node("MATH", "Value", {"operation": "TRUNC"}, **{"0": node("MATH", "Value", {"operation": "MULTIPLY"},
                                                                          **{"0": x, "1": 1.7})}), kernels)
    np.testing.assert_array_equal(trunc[..., 0], np.sign(a) * np.floor(np.abs(a.astype(np.float32) * 1.7)))


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_hsv_blend_modes_move_hue_saturation_value_or_colour_of_a_towards_b(kernels):
    """Hue gives A B's hue, Color B's hue and saturation (both blended by the factor; a grey B leaves A), Saturation
    A's saturation moved towards B's (a grey A stays), Value A's value moved towards B's: red-ish A (0.8, 0.2, 0.2)
    with a blue B (0.2, 0.2, 0.8) at factor 1 is B (same saturation and value), at 0.25 a quarter of the way."""
    red, blue, grey = (0.8, 0.2, 0.2), (0.2, 0.2, 0.8), (0.5, 0.5, 0.5)

    def mixed(blend, factor, a, b):
        """The Mix (Color) node's result at every pixel, one colour."""
        link = node("MIX", "Result", {"data_type": "RGBA", "blend_type": blend}, Factor=factor, A=a, B=b)
        return shoot(link, kernels)[0, 0]

    for blend in ("HUE", "COLOR"):
        np.testing.assert_allclose(mixed(blend, 1.0, red, blue), blue, atol=1e-6)
        np.testing.assert_allclose(mixed(blend, 0.25, red, blue), np.add(red, 0.25 * np.subtract(blue, red)), atol=1e-6)
        np.testing.assert_allclose(mixed(blend, 1.0, red, grey), red, atol=1e-7)
    np.testing.assert_allclose(mixed("SATURATION", 1.0, red, grey), (0.8, 0.8, 0.8), atol=1e-6)
    np.testing.assert_allclose(mixed("SATURATION", 0.5, red, (0.1, 0.1, 0.4)), (0.8, 0.2, 0.2), atol=1e-6)
    np.testing.assert_allclose(mixed("SATURATION", 1.0, grey, blue), grey, atol=1e-7)
    np.testing.assert_allclose(mixed("VALUE", 1.0, red, (0.1, 0.1, 0.4)), (0.4, 0.1, 0.1), atol=1e-6)
    np.testing.assert_allclose(mixed("VALUE", 0.5, red, (0.1, 0.1, 0.4)), (0.6, 0.15, 0.15), atol=1e-6)
