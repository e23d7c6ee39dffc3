"""Square and rectangle Area lamps sampled over their spherical rectangle where they are near (core/lights/area.py
AreaLight.sample / hit, area.c), as Cycles samples them: closed-form solid angles and irradiance, the hit's pdf
equal to the sample's, and the C kernel's samples equal to Python's.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.lights import AreaLight
from core.lights.base import compiled_hit, compiled_sample


def square_lamp(side: float = 1.0, power: float = 100.0, shape: str = "SQUARE") -> AreaLight:
    """A lamp of side `side` at height 1 over the origin, facing down (Blender's -Z)."""
    return AreaLight(center=np.array([0.0, 0.0, 1.0]), axis_u=np.array([side, 0.0, 0.0]),
                     axis_v=np.array([0.0, side, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=power, shape=shape)


def corner_factor(x: float, y: float) -> float:
    """View factor from a point to a parallel rectangle of sides x h, y h whose corner is straight above it."""
    a, b = math.sqrt(1 + x * x), math.sqrt(1 + y * y)
    return (x / a * math.atan(y / a) + y / b * math.atan(x / b)) / (2.0 * math.pi)


def test_a_near_square_lamps_samples_have_the_pdf_of_its_solid_angle():
    """On the axis of a square of side a at height h, Omega = 4 asin(a^2 / (a^2 + 4 h^2)): every sample's pdf is
    1 / Omega, in both kernels, and every sampled direction meets the lamp."""
    lamp = square_lamp(side=2.0)
    n = 512
    points = np.zeros((n, 3))
    u = np.random.default_rng(1).random((n, 2))
    omega = 4.0 * math.asin(4.0 / (4.0 + 4.0))
    for sample in (lamp.sample(points, u), compiled_sample(lamp, points, u)):
        np.testing.assert_allclose(sample.pdf, 1.0 / omega, rtol=1e-12)
        landed = sample.distance[:, None] * sample.L
        np.testing.assert_allclose(landed[:, 2], 1.0, atol=1e-12)
        assert (np.abs(landed[:, :2]) <= 1.0 + 1e-12).all()


@pytest.mark.parametrize("where", [(0.0, 0.0), (0.7, -0.3), (1.4, 0.9)])
def test_a_rectangle_lamps_irradiance_is_its_view_factor_times_pi_L(where):
    """E = pi L F at points of a parallel floor 1 below a 1.2 x 0.8 lamp (F from the corner view factors, by
    superposition), estimated from the samples (strength x cos at the floor) in both kernels."""
    lamp = AreaLight(center=np.array([0.0, 0.0, 1.0]), axis_u=np.array([1.2, 0.0, 0.0]),
                     axis_v=np.array([0.0, 0.8, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=50.0,
                     shape="RECTANGLE")
    px, py = where
    factor = 0.0
    for x, sx in ((0.6 - px, 1.0), (-0.6 - px, -1.0)):
        for y, sy in ((0.4 - py, 1.0), (-0.4 - py, -1.0)):
            factor += sx * sy * math.copysign(1.0, x) * math.copysign(1.0, y) * corner_factor(abs(x), abs(y))
    expected = math.pi * lamp.radiance() * factor
    n = 1 << 16
    points = np.tile([px, py, 0.0], (n, 1))
    u = np.random.default_rng(2).random((n, 2))
    for sample in (lamp.sample(points, u), compiled_sample(lamp, points, u)):
        E = np.mean(sample.strength * np.maximum(sample.L[:, 2], 0.0))
        assert abs(E - expected) < 0.01 * expected, (E, expected)


def test_a_ray_meeting_a_near_lamp_gets_the_pdf_its_sample_had():
    """For MIS, hit(P, L) gives the pdf sample(P) gave L (1 / Omega where near, the area pdf far away), in both
    kernels; points near and far from the lamp, so both ways of sampling are checked."""
    lamp = square_lamp(side=1.0)
    rng = np.random.default_rng(3)
    n = 400
    points = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.choice([0.5, -0.5, -200.0], n)])
    u = rng.random((n, 2))
    sample = lamp.sample(points, u)
    lit = sample.pdf > 0
    assert lit.sum() > n // 2
    t_max = np.full(lit.sum(), np.inf)
    for hit in (lamp.hit(points[lit], sample.L[lit], t_max), compiled_hit(lamp, points[lit], sample.L[lit], t_max)):
        assert hit.hit.all()
        np.testing.assert_allclose(hit.pdf, sample.pdf[lit], rtol=1e-9)
    far = np.abs(points[:, 2] - 1.0) > 100.0
    assert not lamp.spherical(points[far]).any() and lamp.spherical(points[~far]).all()


def test_both_kernels_sample_a_rectangle_lamp_alike():
    """The C kernel's directions, distances, strengths and pdfs equal Python's, near and far."""
    lamp = AreaLight(center=np.array([0.3, -0.2, 2.0]), axis_u=np.array([0.8, 0.6, 0.0]),
                     axis_v=np.array([-0.3, 0.4, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=30.0,
                     shape="RECTANGLE")
    rng = np.random.default_rng(4)
    points = np.column_stack([rng.uniform(-2, 2, 300), rng.uniform(-2, 2, 300), rng.choice([0.0, 1.9, -300.0], 300)])
    u = rng.random((300, 2))
    python, c = lamp.sample(points, u), compiled_sample(lamp, points, u)
    for a, b in ((python.L, c.L), (python.distance, c.distance), (python.strength, c.strength),
                 (python.pdf, c.pdf)):
        np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12)


def test_disks_and_sheared_lamps_keep_area_sampling():
    """Only a rectangle whose edges meet each other and its direction at right angles takes the spherical way."""
    disk = square_lamp(shape="DISK")
    sheared = AreaLight(center=np.array([0.0, 0.0, 1.0]), axis_u=np.array([1.0, 0.0, 0.0]),
                        axis_v=np.array([0.3, 1.0, 0.0]), direction=np.array([0.0, 0.0, -1.0]), power=1.0,
                        shape="RECTANGLE")
    assert disk.rectangle() is None and sheared.rectangle() is None
    assert square_lamp().rectangle() is not None
