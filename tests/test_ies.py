"""IES light profiles (core/materials/ies.py, ies.c; lamps: core/lights/ies.py; the node:
core/materials/converters/ies_texture.py): Cycles' reading of an LM-63 file, its interpolation, lamps scaled by a
profile and the IES Texture node in a material, against closed forms and between the two kernels."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest

from core.lights import AreaLight, PointLight, SpotLight, SunLight
from core.lights.ies import IESLamp
from core.materials import ies
from core.lights.base import compiled_hit, compiled_sample

TEST_FILE = os.path.join(os.path.dirname(__file__), "data", "primer_test.ies")


def lm63(v_angles, h_angles, candela, multiplier=1.0, kind=1, ballast=1.0, tilt="TILT=NONE") -> str:
    """An LM-63 file's text: candela (h, v) on the angles (degrees), photometric type `kind` (1 C, 2 B, 3 A)."""
    rows = "\n".join(" ".join(f"{x:g}" for x in row) for row in np.asarray(candela, np.float64))
    return (f"IESNA:LM-63-2002\n[TEST] built by the test\n{tilt}\n1 1000 {multiplier:g} {len(v_angles)} {len(h_angles)} "
            f"{kind} 2 0.1 0.1 0\n{ballast:g} 1 40\n" + " ".join(f"{x:g}" for x in v_angles) + "\n"
            + " ".join(f"{x:g}" for x in h_angles) + "\n" + rows + "\n")


def directions(n: int = 500, seed: int = 3) -> np.ndarray:
    """Random unit directions (n, 3) float64."""
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


def test_parser_reads_the_hand_written_files_candela_in_cycles_units():
    """The committed file: multiplier 2 x ballast 1 x ballast-lamp 0.5 = 1, so each value is its candela x 4 pi /
    177.83; its quadrant (0, 45, 90 degrees) is mirrored to the full circle 0..360 in 45 degree steps."""
    profile = ies.parse_ies(open(TEST_FILE).read())
    assert np.allclose(np.degrees(profile.h_angles), np.arange(0, 361, 45), atol=1e-4)
    assert np.allclose(np.degrees(profile.v_angles), [0, 45, 90, 135, 180], atol=1e-4)
    candela = profile.intensity / ies.CANDELA_TO_WATT
    assert np.allclose(candela[0], [100, 80, 60, 40, 20], rtol=1e-6)       # 0 degrees
    assert np.allclose(candela[2], [120, 100, 80, 60, 40], rtol=1e-6)      # 90
    assert np.allclose(candela[4], candela[0]) and np.allclose(candela[3], candela[1])   # 180 mirrors 0, 135 mirrors 45
    assert np.allclose(candela[8], candela[0])                             # 360 closes the circle
    assert abs(ies.CANDELA_TO_WATT - 4.0 * math.pi / 177.83) < 1e-9


def test_symmetries_expand_to_the_full_circle_as_cycles_does():
    """Type C: one angle (rotationally symmetric) -> 0 and 360; a half (0..180) mirrored; 90..270 rotated to 0..180
    first; a file without its 360 column gets it where the spacing says so."""
    one = ies.parse_ies(lm63([0, 90, 180], [0], [[3, 2, 1]]))
    assert np.allclose(np.degrees(one.h_angles), [0, 360], atol=1e-4)
    half = ies.parse_ies(lm63([0, 90], [0, 90, 180], [[1, 1], [2, 2], [3, 3]]))
    assert np.allclose(np.degrees(half.h_angles), [0, 90, 180, 270, 360], atol=1e-4)
    assert np.allclose(half.intensity[:, 0] / ies.CANDELA_TO_WATT, [1, 2, 3, 2, 1], rtol=1e-6)
    rotated = ies.parse_ies(lm63([0, 90], [90, 180, 270], [[1, 1], [2, 2], [3, 3]]))
    assert np.allclose(np.degrees(rotated.h_angles), [0, 90, 180, 270, 360], atol=1e-4)
    open_circle = ies.parse_ies(lm63([0, 90], [0, 120, 240], [[1, 1], [2, 2], [3, 3]]))
    assert np.allclose(np.degrees(open_circle.h_angles), [0, 120, 240, 360], atol=1e-4)
    assert np.allclose(open_circle.intensity[-1], open_circle.intensity[0])


def test_unreadable_files_give_strength_times_100_as_cycles():
    """No TILT line, an unknown photometric type, too few numbers: Cycles keeps no table, and its IES Texture then
    gives Strength x 100."""
    assert ies.parse_ies("\n") is None
    assert ies.parse_ies(lm63([0, 90], [0], [[1, 1]], kind=4)) is None
    assert ies.parse_ies(lm63([0, 90], [0], [[1, 1]])[:-6]) is None
    assert np.allclose(ies.ies_fac(None, 0.5, directions(4)), 50.0)


def test_tilt_include_and_factors_scale_the_candela():
    """TILT=INCLUDE's angles and factors are skipped; the candela multiplier and ballast factor scale the values."""
    text = lm63([0, 90, 180], [0], [[10, 10, 10]], multiplier=3.0, ballast=0.5,
                tilt="TILT=INCLUDE\n1\n3\n0 45 90\n1 0.9 0.8")
    profile = ies.parse_ies(text)
    assert np.allclose(profile.intensity / ies.CANDELA_TO_WATT, 15.0, rtol=1e-6)


def test_an_isotropic_profile_is_a_constant_and_a_downlight_sends_nothing_upward():
    """A file of one candela value everywhere gives that value x 4 pi / 177.83 x Strength in every direction; a 0..90
    degree file (a downlight) gives 0 above the horizon."""
    profile = ies.parse_ies(lm63(np.arange(0, 181, 30), [0], [np.full(7, 500.0)]))
    d = directions()
    d = d[d[:, 2] < 0.999]
    assert np.allclose(ies.ies_fac(profile, 2.0, d), 2.0 * 500.0 * ies.CANDELA_TO_WATT, rtol=1e-6)
    down = ies.parse_ies(lm63([0, 30, 60, 90], [0], [[4, 3, 2, 1]]))
    up = directions()[directions()[:, 2] > 0.0]
    assert np.all(ies.ies_fac(down, 1.0, up) == 0.0)


def test_a_cosine_profile_is_interpolated_to_the_cosine():
    """Candela 1000 cos(v) on a 5 degree grid from 0 to 90 degrees: Catmull-Rom gives 1000 cos(v) to 2e-5 of the
    peak between the samples (measured 1.1e-5; across the pole at v = 0 by the mirrored value), exactly at them; in
    the last interval, whose missing neighbour repeats the last value (the table ends at 90 degrees), to 1%."""
    v = np.arange(0, 91, 5.0)
    profile = ies.parse_ies(lm63(v, [0], [1000.0 * np.cos(np.radians(v))]))
    angle = np.radians(np.linspace(0.0, 89.0, 200))
    vectors = np.stack([np.sin(angle) * 0.3, np.sin(angle) * 0.95393920141, -np.cos(angle)], axis=1)
    fac = ies.ies_fac(profile, 1.0, vectors) / ies.CANDELA_TO_WATT
    inner = angle < np.radians(85.0)
    assert np.allclose(fac[inner], 1000.0 * np.cos(angle[inner]), atol=0.02)
    assert np.allclose(fac[~inner], 1000.0 * np.cos(angle[~inner]), atol=10.0)
    at = np.radians(v[:-1])
    exact = ies.evaluate(profile, np.full(len(at), 1.0), at.astype(np.float32).astype(np.float64))
    assert np.allclose(exact / ies.CANDELA_TO_WATT, 1000.0 * np.cos(at), rtol=1e-5)


def test_cycles_does_not_wrap_a_full_circle_in_float32():
    """Cycles' wrap tests compare in 32-bit floats, where 2 pi - 1e-7 rounds to 2 pi: a table closing the circle at
    360 degrees is not wrapped (the end columns repeat), nor one reaching 180 degrees; v = 0 mirrors."""
    profile = ies.parse_ies(open(TEST_FILE).read())
    assert ies.wraps(profile) == (False, True, False)


@pytest.mark.parametrize("name", ["file", "type B", "type A"])
def test_python_and_c_give_the_same_fac(name):
    """ies_fac in Python and C agree to rounding over random directions, for each photometric type."""
    if name == "file":
        profile = ies.parse_ies(open(TEST_FILE).read())
    else:
        rng = np.random.default_rng(5)
        kind = 2 if name == "type B" else 3
        profile = ies.parse_ies(lm63([0, 30, 60, 90], [0, 45, 90], rng.uniform(1, 100, (3, 4)), kind=kind))
    d = directions(2000) * np.random.default_rng(2).uniform(0.5, 2.0, (2000, 1))
    assert np.allclose(ies.ies_fac(profile, 1.7, d), ies.compiled_fac(profile, 1.7, d), rtol=1e-12, atol=1e-12)


def lamps():
    """A point, a round spot, an area lamp and a sun with a disc, turned, each scaled by the test file's profile
    (Strength 1.3)."""
    frame = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(0.4), -math.sin(0.4)], [0.0, math.sin(0.4), math.cos(0.4)]])
    lamp = IESLamp(ies.parse_ies(open(TEST_FILE).read()), 1.3, frame.T.copy())
    at = np.array([0.2, -0.1, 2.0])
    return [PointLight(at, 200.0, ies=lamp),
            SpotLight(at, -frame[:, 2], 200.0, radius=0.3, spot_size=2.0, frame=frame, ies=lamp),
            AreaLight(at, frame[:, 0] * 0.5, frame[:, 1] * 0.8, -frame[:, 2], 200.0, ies=lamp),
            SunLight(-frame[:, 2], 3.0, angle=0.6, ies=lamp)]


@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_lamps_scaled_by_a_profile_agree_between_kernels(index):
    """Light samples (and rays meeting a lamp with extent) of an IES lamp: Python and C give the same strength and
    radiance; the sample of a point lamp is the plain lamp's x the node's Fac in the direction leaving it."""
    light = lamps()[index]
    rng = np.random.default_rng(9)
    points = np.column_stack([rng.uniform(-3, 3, 300), rng.uniform(-3, 3, 300), np.zeros(300)])
    u = rng.uniform(0, 1, (300, 2))
    py, c = light.sample(points, u), compiled_sample(light, points, u)
    assert np.allclose(py.strength, c.strength, rtol=1e-6, atol=1e-12)     # (the cone samples differ by rounding)
    if index == 0:
        plain = PointLight(light.position, light.power).sample(points, u)
        assert np.allclose(py.strength, plain.strength * light.ies.factor(-plain.L), rtol=1e-12)
    if light.hittable:
        directions_ = -py.L
        origins = points
        hp = light.hit(origins, -directions_, np.full(300, np.inf))
        hc = compiled_hit(light, origins, -directions_, np.full(300, np.inf))
        assert np.array_equal(hp.hit, hc.hit)
        assert np.allclose(hp.radiance, hc.radiance, rtol=1e-6, atol=1e-12)
        assert hp.radiance[hp.hit].max() > 0.0


# ------------------------------------------------------------------------------------------------
# The IES Texture as a node of a material's graph (core/materials/converters/ies_texture.py)
# ------------------------------------------------------------------------------------------------

def ies_node(profile, strength=0.05, **inputs):
    """A Link to the Fac of an IES Texture node of `profile` (None: a file Cycles could not read)."""
    from core.materials.converters.ies_texture import ies_props
    from core.materials.graph import GraphNode, Link
    return Link(GraphNode("IES_TEXTURE", ies_props(profile), dict(inputs, Strength=strength)), "Fac")


def emitting_plane(link, matrix=None):
    """test_procedural's plane emitting `link` (SIZE x SIZE pixels seen from above), placed by `matrix`."""
    from test_procedural import plane_scene
    scene = plane_scene(link)
    if matrix is not None:
        scene.instances[0].matrix = matrix
    return scene


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_the_node_gives_strength_times_the_profile_along_its_vector(kernels):
    """An Emission of the IES Texture's Fac with its Vector the pixel's snapped point (x, y in -2..2, z 0.375): each
    pixel is Strength x ies_fac there (Python and C to rounding); a file Cycles cannot read gives Strength x 100."""
    from test_procedural import shoot, snapped_points, snapped_vector
    profile = ies.parse_ies(open(TEST_FILE).read())
    fac = shoot(ies_node(profile, Vector=snapped_vector()), kernels)
    expected = ies.ies_fac(profile, 0.05, snapped_points().reshape(-1, 3).astype(np.float64)).reshape(fac.shape[:2])
    np.testing.assert_allclose(fac, np.repeat(expected[..., None], 3, axis=2), rtol=1e-6, atol=1e-9)
    assert expected.std() > 0.01
    np.testing.assert_allclose(shoot(ies_node(None, Vector=snapped_vector()), kernels), 5.0, rtol=1e-12)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_the_default_vector_is_the_incoming_direction_in_the_objects_frame(kernels):
    """Unlinked, the Vector is Cycles' Geometry > Incoming taken to object space as a normal (the transposed object
    matrix): on a plane turned 50 degrees about x and 30 about z, seen straight down, every pixel is Strength x the
    profile along R^T (0, 0, 1)."""
    from core import render
    from core.scene import RenderSettings
    profile = ies.parse_ies(open(TEST_FILE).read())
    a, b = math.radians(50.0), math.radians(30.0)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])
    rz = np.array([[math.cos(b), -math.sin(b), 0.0], [math.sin(b), math.cos(b), 0.0], [0.0, 0.0, 1.0]])
    matrix = np.eye(4)
    matrix[:3, :3] = rz @ rx
    scene = emitting_plane(ies_node(profile), matrix)
    image = render.render(scene, RenderSettings(width=8, height=8, samples=1, kernels=kernels)).image[..., :3]
    expected = ies.ies_fac(profile, 0.05, (matrix[:3, :3].T @ [0.0, 0.0, 1.0])[None])[0]
    seen = image[image[..., 0] > 0.0]
    assert len(seen) > 8 and expected > 0.05
    np.testing.assert_allclose(seen, expected, rtol=1e-9)


def test_the_node_gives_the_same_fac_on_both_kernels():
    """The IES Texture op in C (converters/ies_texture.c) and numpy agree to rounding (1e-12) at every pixel, for the
    file and for a type B profile."""
    from test_procedural import shoot, snapped_vector
    rng = np.random.default_rng(5)
    for profile in (ies.parse_ies(open(TEST_FILE).read()),
                    ies.parse_ies(lm63([0, 30, 60, 90], [0, 45, 90], rng.uniform(1, 100, (3, 4)), kind=2))):
        link = ies_node(profile, Vector=snapped_vector(-0.6))
        compiled, reference = shoot(link, "compiled"), shoot(link, "numpy")
        np.testing.assert_allclose(compiled, reference, rtol=1e-12, atol=1e-15)
        assert reference.std() > 1e-3
