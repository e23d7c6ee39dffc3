"""Area lamps of narrow Spread sample only the part of them that can light the point (core/lights/area.py
AreaLight.spread_region, area.c area_spread_region; Cycles 5.0's area_light_spread_clamp_light): the region holds
every lamp point that lights the point, its pdf integrates to 1 over it and is 1 / Omega of a near rectangle or the
area pdf of a disk or an ellipse, a ray meeting the lamp gets the pdf its sample had (MIS), both kernels agree, the
floor's irradiance keeps its closed form and its unclamped mean, and its variance drops.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.lights import AreaLight
from core.lights.area import spread_attenuation, spread_constants
from core.lights.base import compiled_hit, compiled_sample
from core.scene import RenderSettings

from test_lamp_falloff import floor_scene

DOWN = np.array([0.0, 0.0, -1.0])


class WholeLamp(AreaLight):
    """The same lamp sampled over its whole shape, as before the clamping (the reference the clamping must keep)."""

    def spread_clamps(self) -> bool:
        """Never clamp."""
        return False


def lamp(shape: str, size: tuple, spread_degrees: float, height: float = 2.0) -> AreaLight:
    """A lamp of `shape` and full sizes (x, y) at `height` over the origin facing down, of power 50 W."""
    return AreaLight(center=np.array([0.0, 0.0, height]), axis_u=np.array([size[0], 0.0, 0.0]),
                     axis_v=np.array([0.0, size[1], 0.0]), direction=DOWN, power=50.0, shape=shape,
                     spread=math.radians(spread_degrees))


def whole(light: AreaLight) -> WholeLamp:
    """`light` sampled over its whole shape."""
    return WholeLamp(**{f.name: getattr(light, f.name) for f in dataclasses.fields(light)})


# (lamp, point, the region's kind: "rectangle" or "round", and how it came): each of Cycles' choices once.
CASES = {
    "rectangle_clamped": (lamp("RECTANGLE", (2.0, 1.5), 30.0), (0.3, 0.2, 1.0), "rectangle"),
    "rectangle_at_its_edge": (lamp("RECTANGLE", (2.0, 1.5), 10.0), (1.05, -0.2, 0.5), "rectangle"),
    "ellipse_clamped_rectangle": (lamp("ELLIPSE", (3.0, 1.0), 30.0), (0.5, 0.45, 1.0), "rectangle"),
    "ellipse_spread_disk": (lamp("ELLIPSE", (3.0, 1.0), 30.0), (0.5, 0.0, 1.0), "round"),
    "disk_inside_spread_disk": (lamp("DISK", (2.0, 2.0), 30.0), (0.1, 0.0, 1.0), "round"),
    "disk_lens_rectangle": (lamp("DISK", (2.0, 2.0), 30.0), (0.95, 0.0, 1.0), "rectangle"),
    "disk_whole": (lamp("DISK", (2.0, 2.0), 90.0), (0.0, 0.0, 0.5), "round"),
}


def region_quadrature(light: AreaLight, P: np.ndarray, n: int = 600):
    """Midpoint quadrature nodes over P's spread region: (points on it (m, 3), their areas (m,)); polar for an
    ellipse (radius fraction s, angle phi: dA = |U||V| / 4 s ds dphi)."""
    g = light.spread_region(P[None])
    C, U, V = g.center[0], g.U[0], g.V[0]
    a, b = (np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n
    if g.round[0]:
        s, phi = np.meshgrid(a, 2.0 * math.pi * b)
        s, phi = s.ravel(), phi.ravel()
        points = C + 0.5 * s[:, None] * (np.cos(phi)[:, None] * U + np.sin(phi)[:, None] * V)
        dA = np.linalg.norm(U) * np.linalg.norm(V) / 4.0 * s * (1.0 / n) * (2.0 * math.pi / n)
    else:
        x, y = np.meshgrid(a - 0.5, b - 0.5)
        points = C + x.ravel()[:, None] * U + y.ravel()[:, None] * V
        dA = np.full(n * n, np.linalg.norm(np.cross(U, V)) / (n * n))
    return points, dA


@pytest.mark.parametrize("case", list(CASES))
def test_the_clamped_pdf_integrates_to_one_over_its_region(case):
    """sum pdf(P -> x) cos(theta_light) / d^2 dA over the region's quadrature nodes x is 1 (the pdf is a density over
    the directions into the region), and the pdf is 1 / Omega of a near rectangle (Omega by quadrature: the region's
    solid angle) or d^2 / (cos A_region) of an ellipse, as Cycles defines them; each case reaches its kind."""
    light, where, kind = CASES[case]
    P = np.array(where, np.float64)
    g = light.spread_region(P[None])
    assert not g.empty[0] and g.round[0] == (kind == "round")
    area = light.area()
    assert g.area()[0] < area or case == "disk_whole"          # (smaller than the lamp but where it is whole)
    points, dA = region_quadrature(light, P)
    w = points - P
    d = np.linalg.norm(w, axis=1)
    cos_light = -(w @ light.direction) / d
    pdf = light.spread_region_pdf(np.tile(P, (len(d), 1)), cos_light, d)
    solid_angle = np.sum(cos_light / d ** 2 * dA)
    assert np.sum(pdf * cos_light / d ** 2 * dA) == pytest.approx(1.0, rel=2e-5)
    if kind == "rectangle":
        np.testing.assert_allclose(pdf, 1.0 / solid_angle, rtol=2e-5)
    else:
        np.testing.assert_allclose(pdf, d * d / (cos_light * g.area()[0]), rtol=1e-12)


@pytest.mark.parametrize("shape, size", [("RECTANGLE", (2.0, 1.5)), ("DISK", (2.0, 2.0)), ("ELLIPSE", (3.0, 1.0))])
@pytest.mark.parametrize("spread_degrees", [10.0, 30.0, 90.0])
def test_every_lamp_point_that_lights_a_point_lies_in_its_region(shape, size, spread_degrees):
    """Lamp points of nonzero spread factor towards P lie inside P's region (so clamping loses no light), from points
    all around and under the lamp; points of zero factor are a region's only omissions."""
    light = lamp(shape, size, spread_degrees)
    rng = np.random.default_rng(7)
    n = 4000
    P = np.column_stack([rng.uniform(-2.5, 2.5, n), rng.uniform(-2.0, 2.0, n), rng.uniform(0.2, 1.95, n)])
    # a point of the plane near each one's spread disk (radius r = h tan a around its foot), kept where on the lamp
    h = 2.0 - P[:, 2]
    r = h * math.tan(0.5 * light.spread)
    rho, phi = 1.2 * r * np.sqrt(rng.random(n)), 2.0 * math.pi * rng.random(n)
    x = np.column_stack([P[:, 0] + rho * np.cos(phi), P[:, 1] + rho * np.sin(phi), np.full(n, 2.0)])
    lx, ly = x[:, 0] / size[0], x[:, 1] / size[1]
    on_lamp = lx * lx + ly * ly <= 0.25 if shape != "RECTANGLE" else (np.abs(lx) <= 0.5) & (np.abs(ly) <= 0.5)
    w = x - P
    d = np.linalg.norm(w, axis=1)
    lights = on_lamp & (spread_attenuation(light.spread, -(w @ light.direction) / d) > 0.0)
    assert lights.sum() > n // 20
    g = light.spread_region(P)
    assert not g.empty[lights].any()
    offset = x - g.center
    with np.errstate(divide="ignore", invalid="ignore"):         # (an empty region may have no width)
        lx = np.einsum("ij,ij->i", offset, g.U) / np.einsum("ij,ij->i", g.U, g.U)
        ly = np.einsum("ij,ij->i", offset, g.V) / np.einsum("ij,ij->i", g.V, g.V)
    in_box = (np.abs(lx) <= 0.5 + 1e-12) & (np.abs(ly) <= 0.5 + 1e-12)
    inside = np.where(g.round, lx * lx + ly * ly <= 0.25 + 1e-12, in_box)
    assert inside[lights].all()


@pytest.mark.parametrize("shape, size", [("RECTANGLE", (2.0, 1.5)), ("DISK", (2.0, 2.0)), ("ELLIPSE", (3.0, 1.0))])
@pytest.mark.parametrize("spread_degrees", [10.0, 30.0, 90.0])
def test_a_ray_meeting_a_narrow_spread_lamp_gets_the_pdf_its_sample_had(shape, size, spread_degrees):
    """For MIS, hit(P, L) gives the pdf sample(P) gave L (its region's), in both kernels; and the C kernel's samples
    equal Python's (directions, distances, strengths, pdfs)."""
    light = lamp(shape, size, spread_degrees)
    rng = np.random.default_rng(8)
    n = 2000
    P = np.column_stack([rng.uniform(-2.5, 2.5, n), rng.uniform(-2.0, 2.0, n), rng.uniform(-0.5, 1.95, n)])
    u = rng.random((n, 2))
    python, c = light.sample(P, u), compiled_sample(light, P, u)
    for a, b in ((python.L, c.L), (python.distance, c.distance), (python.strength, c.strength), (python.pdf, c.pdf)):
        np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-7)     # (the disk map's float32 cos: 1e-8 apart)
    lit = python.strength > 0.0
    assert lit.sum() > n // 20
    t_max = np.full(lit.sum(), np.inf)
    for hit in (light.hit(P[lit], python.L[lit], t_max), compiled_hit(light, P[lit], python.L[lit], t_max)):
        assert hit.hit.all()
        np.testing.assert_allclose(hit.pdf, python.pdf[lit], rtol=1e-6)


def under_middle_irradiance(light: AreaLight, h: float) -> float:
    """E at a point h under a parallel lamp whose spread disk (radius h tan a, a = spread / 2) lies inside it:
    2 pi L / norm int_0^a (tan a - tan theta) cos theta sin theta dtheta
    = 2 pi L / norm (tan a sin^2 a / 2 - a / 2 + sin 2a / 4), norm = tan a - a."""
    a = 0.5 * light.spread
    tan_half, norm = spread_constants(light.spread)
    return 2.0 * math.pi * light.radiance() / norm * (tan_half * math.sin(a) ** 2 / 2 - a / 2 + math.sin(2 * a) / 4)


def irradiance_samples(light: AreaLight, P: np.ndarray, n: int, seed: int, kernel: str = "python") -> np.ndarray:
    """n one-sample estimates of the irradiance of an upward floor at P: strength x cos (n,)."""
    u = np.random.default_rng(seed).random((n, 2))
    points = np.tile(P, (n, 1))
    s = light.sample(points, u) if kernel == "python" else compiled_sample(light, points, u)
    return s.strength * np.maximum(s.L[:, 2], 0.0)


@pytest.mark.parametrize("spread_degrees", [10.0, 30.0])
@pytest.mark.parametrize("shape, size", [("RECTANGLE", (2.0, 1.5)), ("DISK", (2.0, 2.0)), ("ELLIPSE", (3.0, 1.0))])
def test_a_floor_under_a_narrow_spread_lamp_keeps_its_irradiance_and_loses_variance(shape, size, spread_degrees):
    """Under the middle of the lamp (spread disk inside it) the mean of the clamped samples is the closed form, in
    both kernels; near the lamp's edges, inside and outside, it is the whole lamp's mean (within 4 standard errors of
    both);
    and the one-sample variance under the middle is at least 10 (10 degrees) / 4 (30 degrees) times smaller than the
    whole lamp's (measured: 122 / 382 / 295 times at 10 degrees, 13 / 38 / 28 at 30, rectangle / disk /
    ellipse)."""
    light = lamp(shape, size, spread_degrees, height=1.0)
    reference = whole(light)
    n = 1 << 17
    middle = np.array([0.05, -0.03, 0.0])
    expected = under_middle_irradiance(light, 1.0)
    clamped = {k: irradiance_samples(light, middle, n, 1, k) for k in ("python", "compiled")}
    for k, e in clamped.items():
        assert abs(e.mean() - expected) < 4.0 * e.std() / math.sqrt(n) + 1e-12 * expected, (k, e.mean(), expected)
    before = irradiance_samples(reference, middle, n, 2)
    assert abs(before.mean() - expected) < 4.0 * before.std() / math.sqrt(n)
    assert before.var() > (10.0 if spread_degrees < 20 else 4.0) * clamped["python"].var()
    r = math.tan(0.5 * light.spread)                            # the spread disk's radius at height 1
    for where in ((0.5 * size[0] - 0.5 * r, 0.1 * r, 0.0), (0.5 * size[0] + 0.5 * r, 0.0, 0.0),
                  (0.3 * r, 0.5 * size[1] - 0.2 * r, 0.0)):
        P = np.array(where)
        after, before = irradiance_samples(light, P, n, 3, "compiled"), irradiance_samples(reference, P, n, 4)
        assert before.mean() > 0.0
        assert abs(after.mean() - before.mean()) < 4.0 * math.hypot(after.std(), before.std()) / math.sqrt(n)


def test_light_samples_and_bsdf_rays_see_the_same_narrow_spread_lamp():
    """A floor under a 20 degree spread disk lamp rendered by light samples alone (both kernels: the same image) and
    by BSDF rays alone (which never sample the lamp): the same mean, within 4 % (3 of the BSDF rays' standard errors
    over seeds, measured 1.3 %; the light samples' 0.04 %)."""
    light = AreaLight(center=np.array([0.3, 0.0, 1.5]), axis_u=np.array([1.5, 0.0, 0.0]),
                      axis_v=np.array([0.0, 1.5, 0.0]), direction=DOWN, power=100.0, shape="DISK",
                      spread=math.radians(20.0))

    def image(sampling, samples, kernels="compiled"):
        settings = RenderSettings(width=8, height=8, samples=samples, kernels=kernels, light_sampling=sampling)
        return render.render(floor_scene(light), settings).image[..., :3]

    by_light = image("light", 256)
    np.testing.assert_allclose(image("light", 256, "numpy"), by_light, rtol=1e-4, atol=1e-6)
    assert image("bsdf", 16384).mean() == pytest.approx(by_light.mean(), rel=0.04)
