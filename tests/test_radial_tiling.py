"""The Radial Tiling node (core/materials/procedural/radial_tiling.py, radial_tiling.c) against its closed forms, and
the compiled kernel against the numpy reference.

Closed forms: a point at angle phi lies in segment floor(phi / (2 pi / Sides)); a sharp polygon's segment has width
tan(pi / Sides) and rotation (2 k + 1) pi / Sides, and its coordinates are the distance along the bisector
(l cos(pi / Sides - angle in segment)) and across it (that times tan of the angle from the bisector); with
Roundness 1 the polygon is a circle: v = l and u the angle from the bisector over pi / Sides. (Against Cycles' own
render: tests/test_blender_info_nodes.py.)
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core import render
from core.materials.graph import GraphNode, Link
from core.materials.procedural import RadialTiling
from core.scene import RenderSettings

from test_procedural import plane_scene

SIZE = 24


def tiling(points: np.ndarray, sides: float, roundness: float, normalize: bool) -> np.ndarray:
    """RadialTiling.evaluate at (n, 2) points: (n, 6) (u, v, 0, Segment ID, Segment Width, Segment Rotation)."""
    n = len(points)
    vector = np.concatenate([points, np.zeros((n, 1))], axis=1)
    return RadialTiling.evaluate([vector, np.full((n, 1), sides), np.full((n, 1), roundness)], [int(normalize)])


def ring(sides: int, radius: float, offset: float = 0.5) -> tuple:
    """Points at `radius`, one per segment at (k + offset) of its angle: (angles (sides,), points (sides, 2))."""
    angles = (np.arange(sides) + offset) * 2.0 * np.pi / sides
    return angles, radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)


@pytest.mark.parametrize("sides", [3, 5, 8])
def test_a_point_at_a_known_angle_lies_in_its_segment_with_its_width_and_rotation(sides):
    """Segment ID k for the angle (k + 0.3) 2 pi / n, at every roundness; a sharp polygon's width tan(pi / n),
    a round one's pi / n; rotation (2 k + 1) pi / n."""
    angles, points = ring(sides, 1.3, 0.3)
    for roundness in (0.0, 0.5, 1.0):
        out = tiling(points, sides, roundness, False)
        np.testing.assert_array_equal(out[:, 3], np.arange(sides))
        np.testing.assert_allclose(out[:, 5], (2 * np.arange(sides) + 1) * np.pi / sides, rtol=1e-6)
    np.testing.assert_allclose(tiling(points, sides, 0.0, False)[:, 4], np.tan(np.pi / sides), rtol=1e-6)
    np.testing.assert_allclose(tiling(points, sides, 1.0, False)[:, 4], np.pi / sides, rtol=1e-6)


def test_a_sharp_polygons_coordinates_are_the_distances_along_and_across_its_bisector():
    """Sides 6, Roundness 0: v = l cos(d) - 1 and u = -l cos(d) tan(d) (d the angle from the bisector, clockwise of it
    negative); Normalize: u / (l cos(d) tan(pi / 6)) mapped to [0, 1], v + 1."""
    angles, points = ring(6, 1.7, 0.2)
    d = 0.3 * 2.0 * np.pi / 6                                  # (0.5 - 0.2) of a segment before the bisector
    raw, unit = tiling(points, 6.0, 0.0, False), tiling(points, 6.0, 0.0, True)
    along = 1.7 * np.cos(d)
    np.testing.assert_allclose(raw[:, 1], along - 1.0, rtol=1e-6)
    np.testing.assert_allclose(raw[:, 0], -along * np.tan(d), rtol=1e-6)
    np.testing.assert_allclose(unit[:, 1], along, rtol=1e-6)
    np.testing.assert_allclose(unit[:, 0], 0.5 - 0.5 * np.tan(d) / np.tan(np.pi / 6), atol=1e-6)


def test_full_roundness_makes_circles_whose_coordinates_are_distance_and_angle():
    """Sides 5, Roundness 1: v = l - 1 and u = the angle from the bisector (over pi / 5 with Normalize); at the
    origin u is 0 (0.5 normalized) and v -1."""
    angles, points = ring(5, 0.8, 0.9)
    raw, unit = tiling(points, 5.0, 1.0, False), tiling(points, 5.0, 1.0, True)
    d = 0.4 * 2.0 * np.pi / 5
    np.testing.assert_allclose(raw[:, 1], 0.8 - 1.0, rtol=1e-6)
    np.testing.assert_allclose(raw[:, 0], d, rtol=1e-5)
    np.testing.assert_allclose(unit[:, 0], 0.5 + 0.5 * d / (np.pi / 5), rtol=1e-6)
    origin = tiling(np.zeros((1, 2)), 5.0, 0.4, True)[0]
    assert origin[0] == 0.5 and origin[1] == 0.0 and origin[3] == 0.0
    assert tiling(np.zeros((1, 2)), 5.0, 0.4, False)[0, 1] == -1.0


def test_sides_below_two_read_two_and_roundness_is_clamped_to_0_1():
    """Sides 1 is Sides 2; Roundness -1 is 0 and 3 is 1 (Cycles' fmaxf and clamp)."""
    _, points = ring(7, 1.1, 0.35)
    np.testing.assert_array_equal(tiling(points, 1.0, 0.3, True), tiling(points, 2.0, 0.3, True))
    np.testing.assert_array_equal(tiling(points, 4.5, -1.0, True), tiling(points, 4.5, 0.0, True))
    np.testing.assert_array_equal(tiling(points, 4.5, 3.0, True), tiling(points, 4.5, 1.0, True))


def snapped() -> Link:
    """The plane's Generated coordinate snapped to its pixel's centre, x 4 - 2 (one point per pixel)."""
    generated = Link(GraphNode("TEXCOORD", {}, {}), "Generated")
    separate = GraphNode("SEPARATE_XYZ", {}, {"Vector": generated})
    ends = []
    for axis in ("X", "Y"):
        value = Link(separate, axis)
        for operation, b in (("MULTIPLY", SIZE), ("FLOOR", 0.0), ("ADD", 0.5), ("MULTIPLY", 4.0 / SIZE),
                             ("SUBTRACT", 2.0)):
            value = Link(GraphNode("MATH", {"operation": operation}, {"0": value, "1": b}), "Value")
        ends.append(value)
    return Link(GraphNode("COMBINE_XYZ", {}, {"X": ends[0], "Y": ends[1], "Z": 0.0}), "Vector")


@pytest.mark.parametrize("sides, roundness", [(5.0, 0.0), (5.0, 0.35), (4.0, 1.0), (4.3, 0.0), (4.3, 0.6),
                                              (2.5, 1.0), (2.0, 0.0)])
def test_the_compiled_radial_tiling_computes_what_the_reference_computes(sides, roundness):
    """Every output (the coordinates with Normalize off and on) on both kernels: the same values within float32
    rounding of the sines and tangents (libm's float functions in C, double rounded once in numpy; measured
    <= 9.3e-7)."""
    settings = RenderSettings(width=SIZE, height=SIZE, samples=1)
    for normalize, output in ((False, "Segment Coordinates"), (True, "Segment Coordinates"), (False, "Segment ID"),
                              (False, "Segment Width"), (True, "Segment Rotation")):
        link = Link(GraphNode("RADIAL_TILING", {"normalize": normalize},
                              {"Vector": snapped(), "Sides": sides, "Roundness": roundness}), output)
        scene = plane_scene(link)
        compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
        reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
        assert compiled.stats.kernels == "compiled"
        assert np.isfinite(reference.image).all()
        print(output, normalize, "largest difference", np.abs(compiled.image - reference.image).max())
        np.testing.assert_allclose(compiled.image, reference.image, atol=1e-6, rtol=1e-6,
                                   err_msg=f"{output} normalize={normalize}")
