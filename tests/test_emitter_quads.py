"""Quad lamps sampled as one spherical rectangle (core/lights/emitters.py quad_partners, spherical_rectangle_sample;
emitters.c) against closed forms: the rectangle's solid angle, where its samples land, its pdf over the sphere, the
irradiance it gives, the BSDF hits' pdf on either triangle, and the C kernel's samples against Python's.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.lights import MeshEmitters
from core.lights.base import LightContext, compiled_sample
from core.lights.emitters import (compiled_pdf_of_hits, quad_partners, rectangle_solid_angle, solid_angle,
                                  spherical_rectangle_sample)


def rectangle_factor(x: float, y: float) -> float:
    """View factor from a point to a parallel rectangle of sides x h, y h whose corner is straight above it."""
    a, b = math.sqrt(1 + x * x), math.sqrt(1 + y * y)
    return (x / a * math.atan(y / a) + y / b * math.atan(x / b)) / (2.0 * math.pi)


def quad(a, u, v) -> np.ndarray:
    """The two triangles (2, 3, 3) of the rectangle with corner a and edges u, v, sharing the diagonal a + u, a + v,
    both counter-clockwise about u x v."""
    a, u, v = (np.asarray(x, np.float64) for x in (a, u, v))
    return np.array([[a, a + u, a + v], [a + u + v, a + v, a + u]])


def lamp(corners: np.ndarray, radiance: float = 1.0, sides: int = 3, quads: bool = True) -> MeshEmitters:
    """MeshEmitters of triangles (t, 3, 3) of one object and material (as quads if `quads`)."""
    t = len(corners)
    return MeshEmitters.of(corners, np.full((t, 3), radiance), np.full(t, sides, np.int32), np.arange(t),
                           quad_key=np.zeros(t, np.int64) if quads else None)


def random_rectangles(rng, n: int) -> tuple:
    """n rectangles R (n, 3, 3) of random orientation and sides, and points P (n, 3) around them."""
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(u, rng.normal(size=(n, 3)))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    R = np.stack([rng.normal(size=(n, 3)), u * rng.uniform(0.1, 2.0, (n, 1)), w * rng.uniform(0.1, 2.0, (n, 1))], 1)
    return R, rng.normal(size=(n, 3)) * 1.5


def test_a_rectangles_solid_angle_is_its_two_triangles_sum():
    """Urena et al.'s solid angle of a rectangle (the sum of its spherical quadrilateral's angles less 2 pi, as asin
    terms) equals Van Oosterom and Strackee's for its two triangles, added, from points all around it."""
    rng = np.random.default_rng(1)
    R, P = random_rectangles(rng, 2000)
    a, u, v = R[:, 0], R[:, 1], R[:, 2]
    halves = solid_angle(P, np.stack([a, a + u, a + v], 1)) + solid_angle(P, np.stack([a + u + v, a + v, a + u], 1))
    np.testing.assert_allclose(rectangle_solid_angle(P, R), halves, rtol=1e-9, atol=1e-12)


def test_spherical_rectangle_samples_land_on_it_uniformly_in_solid_angle():
    """Every sampled direction meets the rectangle at the returned distance, and the share of samples in each of
    4 x 4 sub-rectangles is its share of the solid angle (to 3 standard deviations of 40,000 samples)."""
    rng = np.random.default_rng(2)
    R = np.array([[0.0, 0.0, 1.0], [1.5, 0.0, 0.0], [0.0, 0.0, 0.8]])   # a wall from the point's side
    for P0 in ([0.4, -0.5, 1.3], [0.2, -3.0, 0.0], [2.5, -0.1, 1.9]):
        n = 40000
        P = np.tile(P0, (n, 1))
        L, t, pdf = spherical_rectangle_sample(P, np.tile(R, (n, 1, 1)), rng.random((n, 2)))
        omega = rectangle_solid_angle(P[:1], R[None])[0]
        np.testing.assert_allclose(pdf, 1.0 / omega)
        hit = P + L * t[:, None] - R[0]
        s = hit @ R[1] / (R[1] @ R[1])
        r = hit @ R[2] / (R[2] @ R[2])
        assert np.abs(hit @ np.cross(R[1], R[2])).max() < 1e-9
        assert s.min() > -1e-9 and s.max() < 1 + 1e-9 and r.min() > -1e-9 and r.max() < 1 + 1e-9
        cell = np.minimum((s * 4).astype(int), 3) * 4 + np.minimum((r * 4).astype(int), 3)
        share = np.bincount(cell, minlength=16) / n
        sub = np.array([[R[0] + i / 4 * R[1] + j / 4 * R[2], R[1] / 4, R[2] / 4] for i in range(4) for j in range(4)])
        expected = rectangle_solid_angle(np.tile(P0, (16, 1)), sub) / omega
        assert np.all(np.abs(share - expected) < 3 * np.sqrt(expected * (1 - expected) / n) + 1e-4)


@pytest.mark.parametrize("P0", [[0.3, 0.2, 0.0], [0.9, 0.4, 0.95], [5.0, -3.0, -20.0]])
def test_a_quads_pdf_of_hits_on_either_triangle_integrates_to_one_and_is_the_sampling_pdf(P0):
    """A quad lamp is one emitter: BSDF rays that hit either of its triangles get one pdf (the tree's pick x 1 /
    Omega of the rectangle, or the area measure's where it is far: the last point), which integrates to 1 over the
    sphere of directions (Monte Carlo, uniform directions), and is the pdf its light samples carry."""
    rng = np.random.default_rng(3)
    corners = quad([0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [2.0, 0.0, 0.0])        # faces -z
    other = quad([3.0, 3.0, 2.0], [0.5, 0.0, 0.0], [0.0, 0.0, 0.5])          # a second lamp: a pick < 1
    emitters = lamp(np.concatenate([corners, other]))
    assert list(emitters.partner) == [1, 0, 3, 2]
    n = 400000
    D = rng.normal(size=(n, 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    P = np.tile(P0, (n, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (1.0 - P[:, 2]) / D[:, 2]
    X = P + D * t[:, None]
    inside = (t > 0) & (X[:, 0] >= 0) & (X[:, 0] <= 2) & (X[:, 1] >= 0) & (X[:, 1] <= 1)
    rows = np.flatnonzero(inside)
    triangle = np.where(X[rows, 0] / 2 + X[rows, 1] < 1.0, 0, 1)           # which half the ray hit
    pdf = emitters.pdf_of_hits(P[rows], triangle, D[rows], t[rows])
    pick = emitters.pick_probability(P[:1], np.array([0]))[0]
    assert len(rows) > 100
    assert pdf.sum() * 4 * math.pi / n / pick == pytest.approx(1.0, abs=4 / math.sqrt(len(rows)))
    np.testing.assert_allclose(compiled_pdf_of_hits(emitters, P[rows], triangle, D[rows], t[rows]), pdf, rtol=1e-9)
    # The light samples' pdf is the BSDF hits' (on whichever triangle the sample lands), and lands on the quad.
    m = 2000
    sample = emitters.sample(P[:m], rng.random((m, 2)))
    on_quad = sample.emitter == 0
    assert on_quad.any() and set(sample.emitter) <= {0, 2}
    Y = sample.position[on_quad]
    half = np.where(Y[:, 0] / 2 + Y[:, 1] < 1.0, 0, 1)
    np.testing.assert_allclose(emitters.pdf_of_hits(P[:m][on_quad], half, sample.L[on_quad],
                                                    sample.distance[on_quad]), sample.pdf[on_quad], rtol=1e-9)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_quad_lamps_irradiance_is_the_form_factor(kernels):
    """A Lambert emitter of radiance L gives a point the irradiance pi L F, F the view factor: to a parallel
    rectangle whose corner is straight above the point (the closed form of rectangle_factor), and to a perpendicular
    wall (Lambert's polygon formula), both as the light samples' estimate over stratified numbers."""
    rng = np.random.default_rng(4)
    n = 4096
    u = (np.stack(np.meshgrid(np.arange(64), np.arange(64)), -1).reshape(-1, 2) + rng.random((n, 2))) / 64
    radiance, h = 2.5, 0.8
    cases = [
        # parallel, corner straight above: sides x h, y h
        (quad([0.0, 0.0, h], [0.0, 1.2 * h, 0.0], [0.7 * h, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]),
         rectangle_factor(0.7, 1.2)),
        # perpendicular: a wall x = 0.5 from y 0..1, z 0..0.6 (normal +z at the origin); Lambert's polygon formula
        (quad([0.5, 0.0, 0.0], [0.0, 0.0, 0.6], [0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]),
         polygon_factor(np.array([[0.5, 0.0, 0.0], [0.5, 0.0, 0.6], [0.5, 1.0, 0.6], [0.5, 1.0, 0.0]]),
                        np.array([0.0, 0.0, 1.0]))),
    ]
    for corners, N, F in cases:
        emitters = lamp(corners, radiance)
        assert emitters.partner is not None
        P = np.zeros((n, 3))
        if kernels == "numpy":
            s = emitters.sample(P, u)
        else:
            tables = emitters.tables()
            s = compiled_sample(emitters, P, u, LightContext(emitters=tables.record))
        E = (radiance * np.maximum(s.L @ N, 0.0) * s.strength).mean()
        assert E == pytest.approx(math.pi * radiance * F, rel=2e-3)


def polygon_factor(polygon: np.ndarray, normal: np.ndarray) -> float:
    """Lambert's closed form: the view factor from a differential area at the origin with unit normal `normal` to a
    planar polygon (k, 3) wholly above its horizon."""
    v = polygon / np.linalg.norm(polygon, axis=1, keepdims=True)
    total = 0.0
    for i in range(len(v)):
        a, b = v[i], v[(i + 1) % len(v)]
        c = np.cross(a, b)
        total += math.acos(np.clip(a @ b, -1, 1)) * (c / np.linalg.norm(c)) @ normal
    return abs(total) / (2.0 * math.pi)


def test_compiled_quad_samples_are_the_pythons():
    """emitters.c samples quads as Python does: the same directions, distances, pdfs and strengths, near the lamps
    (spherical rectangles) and far from them (area sampling); and its pdf for a BSDF ray that hits either triangle of
    a quad along a sample's direction is the sample's."""
    rng = np.random.default_rng(5)
    R, _ = random_rectangles(rng, 30)
    corners = np.concatenate([quad(*r) for r in R] + [rng.normal(size=(5, 3, 3))])   # 30 quads, 5 triangles
    emitters = lamp(corners, sides=3)
    assert (emitters.partner[:60] >= 0).all() and (emitters.partner[60:] < 0).all()
    tables = emitters.tables()
    points = np.concatenate([rng.normal(size=(3000, 3)), rng.normal(size=(1000, 3)) * 300])
    u = rng.random((len(points), 2))
    expected = emitters.sample(points, u)
    found = compiled_sample(emitters, points, u, LightContext(emitters=tables.record))
    assert (emitters.partner[expected.emitter] >= 0).mean() > 0.5
    np.testing.assert_allclose(found.pdf, expected.pdf, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(found.L, expected.L, atol=1e-6)
    np.testing.assert_allclose(found.distance, expected.distance, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(found.strength, expected.strength, rtol=1e-6)
    # A BSDF ray along a sample's direction that hits either triangle of its quad gets the sample's pdf in C too.
    quads = np.flatnonzero((emitters.partner[expected.emitter] >= 0) & (expected.pdf > 0))
    for index in (expected.emitter[quads], emitters.partner[expected.emitter[quads]]):
        np.testing.assert_allclose(compiled_pdf_of_hits(emitters, points[quads], index, expected.L[quads],
                                                        expected.distance[quads]), expected.pdf[quads], rtol=1e-6)


def test_a_quads_constants_made_once_are_the_ones_made_per_sample():
    """The rectangle constants EmitterTables keeps for each quad (rect_frame: unit edges, their normal, lengths and
    area, made once at set-up by emitters.rectangle_constants) are the numbers emitters.c makes per sample without
    them: the C's samples with and without them are bitwise equal, near the lamps and far from them."""
    rng = np.random.default_rng(11)
    R, _ = random_rectangles(rng, 20)
    emitters = lamp(np.concatenate([quad(*r) for r in R]))
    points = np.concatenate([rng.normal(size=(2000, 3)), rng.normal(size=(500, 3)) * 300])
    u = rng.random((len(points), 2))
    kept, made = emitters.tables(), emitters.tables()
    made.record.rect_frame = None
    once = compiled_sample(emitters, points, u, LightContext(emitters=kept.record))
    each = compiled_sample(emitters, points, u, LightContext(emitters=made.record))
    assert (once.pdf > 0).mean() > 0.5
    for a, b in ((once.L, each.L), (once.distance, each.distance), (once.pdf, each.pdf),
                 (once.strength, each.strength)):
        np.testing.assert_array_equal(a, b)


def test_only_exact_rectangles_of_one_key_pair_into_quads():
    """quad_partners pairs a rectangle's two triangles (either diagonal, any winding of the pair's order), and none of:
    a parallelogram that is not a rectangle, two triangles of different keys (objects or materials), of different
    emission, facing opposite ways, or a rectangle whose fourth corner is off by more than the tolerance (by float32's
    rounding: still a quad)."""
    ones, sides = np.ones((2, 3)), np.full(2, 3, np.int32)

    def pairs(corners, key=(0, 0), emission=ones):
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        normal = cross / np.linalg.norm(cross, axis=1, keepdims=True)
        partner, _ = quad_partners(corners, normal, emission, sides, np.array(key, np.int64))
        return partner is not None

    rect = quad([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    assert pairs(rect) and pairs(rect[::-1])
    assert pairs(quad([1.0, 2.0, 3.0], [0.3, 0.4, 0.0], [-0.8, 0.6, 0.5]))
    assert not pairs(quad([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.5, 1.0, 0.0]))       # a parallelogram
    assert not pairs(rect, key=(0, 1))
    assert not pairs(rect, emission=np.array([[1.0, 1, 1], [1.0, 1, 2]]))
    flipped = rect.copy()
    flipped[1] = flipped[1, [0, 2, 1]]                                               # the second faces the other way
    assert not pairs(flipped)
    off = rect.copy()
    off[1, 0] += [0.0, 0.0, 1e-4]                                                    # its corner off the plane
    assert not pairs(off)
    near = rect.copy()
    near[1, 0] += [1e-7, 0.0, 0.0]                                   # float32's rounding of a rectangle: still a quad
    near[0, 0] += [0.0, 0.0, 1e-7]
    assert pairs(near)


def test_a_plane_lamp_is_exported_as_one_quad_and_a_textured_one_as_triangles(monkeypatch):
    """The export (emitters.from_geometry) makes a plane lamp's two triangles one quad, one leaf of the light tree; a
    textured plane lamp (its emission varies over it) stays two triangles, and so does every lamp with
    emitters.QUADS off (PRIMER_QUADS=0)."""
    from test_emitters_world import emitter_over_floor, half_textured_emitter_over_floor
    from core import render
    from core.lights import emitters as emitters_
    from core.scene import RenderSettings
    settings = RenderSettings(width=2, height=2, samples=1)
    plain = render.prepare(emitter_over_floor(1.0, 0.7, 3.0, 0.6), settings).extra["emitters"]
    assert list(plain.partner) == [1, 0] and len(plain.tree.nodes) == 1
    textured = render.prepare(half_textured_emitter_over_floor(1.0, 3.0, 1.0, 0.7, 0.5), settings).extra["emitters"]
    assert textured.partner is None and len(textured.tree.nodes) == 3
    monkeypatch.setattr(emitters_, "QUADS", False)
    off = render.prepare(emitter_over_floor(1.0, 0.7, 3.0, 0.6), settings).extra["emitters"]
    assert off.partner is None and len(off.tree.nodes) == 3
