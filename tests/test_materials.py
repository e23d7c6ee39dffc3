"""BSDFs (core/materials) against closed forms: each one's f, pdf and sampling, and their table."""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ortho_down
from core import materials, render
from core.geometry import primitives
from core.lights import AreaLight, SunLight
from core.materials import BSDFFlags, Lambert, MaterialTable, Mirror
from core.scene import RenderSettings, Scene


def random_frames(n: int, seed: int = 0):
    """n random unit normals and viewer directions on the normal's side: N, wo (n, 3) float64."""
    rng = np.random.default_rng(seed)
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    wo = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wo *= np.where(np.einsum("ij,ij->i", wo, N) < 0, -1.0, 1.0)[:, None]
    return N, wo


def no_params(n: int) -> np.ndarray:
    return np.zeros((n, materials.PARAMS))


def test_lambert_is_one_over_pi_and_reflects_its_albedo():
    """f cos = max(N.wi, 0) / pi for every pair of directions (the colour is the closure's weight), so the
    directional albedo, the integral of f cos over the hemisphere, is 1: with cosine-weighted samples each
    sample's f cos / pdf is 1, and pdf = N.wi / pi."""
    n = 20000
    N, wo = random_frames(n)
    wi = np.random.default_rng(1).normal(size=(n, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    f_cos, pdf = Lambert.eval(no_params(n), N, wo, wi)
    cos = np.einsum("ij,ij->i", N, wi)
    np.testing.assert_allclose(f_cos, np.repeat(np.maximum(cos, 0.0)[:, None] / math.pi, 3, axis=1), rtol=1e-15)
    np.testing.assert_allclose(pdf, np.maximum(cos, 0.0) / math.pi, rtol=1e-15)
    sample = Lambert.sample(no_params(n), N, wo, np.random.default_rng(2).random((n, 2)))
    np.testing.assert_allclose(np.linalg.norm(sample.wi, axis=1), 1.0, rtol=1e-12)
    cos = np.einsum("ij,ij->i", N, sample.wi)
    assert (cos >= 0).all()
    np.testing.assert_allclose(sample.pdf, cos / math.pi, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(sample.weight, 1.0)
    # Cosine-weighted: E[cos] = 2/3 and E[cos^2] = 1/2 (their closed forms under pdf = cos / pi).
    assert cos.mean() == pytest.approx(2.0 / 3.0, abs=5e-3)
    assert (cos ** 2).mean() == pytest.approx(0.5, abs=5e-3)


def test_lambert_is_zero_below_the_surface_unless_the_lecture_switch_keeps_the_sign():
    N = np.array([[0.0, 0.0, 1.0]])
    below = np.array([[0.0, 0.6, -0.8]])
    f_cos, pdf = Lambert.eval(no_params(1), N, N, below)
    assert (f_cos == 0.0).all() and pdf[0] == 0.0
    signed, _ = Lambert.eval(no_params(1), N, N, below, signed_cosine=True)
    np.testing.assert_allclose(signed, -0.8 / math.pi)


def test_mirror_reflects_about_the_normal_and_is_a_delta():
    """R = 2 (N.wo) N - wo: the angle of incidence equals the angle of reflection, in the plane of N and
    wo; weight 1 (the closure's weight tints it); pdf = inf; eval is 0 for any pair of directions."""
    n = 1000
    N, wo = random_frames(n, 3)
    sample = Mirror.sample(no_params(n), N, wo, np.zeros((n, 2)))
    np.testing.assert_allclose(np.einsum("ij,ij->i", N, sample.wi), np.einsum("ij,ij->i", N, wo), atol=1e-12)
    np.testing.assert_allclose(sample.wi + wo, 2.0 * np.einsum("ij,ij->i", N, wo)[:, None] * N, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(sample.wi, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_array_equal(sample.weight, 1.0)
    assert np.isinf(sample.pdf).all()
    f_cos, pdf = Mirror.eval(no_params(n), N, wo, sample.wi)
    assert (f_cos == 0).all() and (pdf == 0).all()
    assert Mirror.is_(BSDFFlags.SINGULAR) and not Lambert.is_(BSDFFlags.SINGULAR)


def closures_of(kinds, weights, N):
    """Closures of n hits with the given per-slot kinds (K,) and weights (K, 3), all at normals N (n, 3)."""
    n, K = len(N), len(kinds)
    c = materials.Closures.empty(n, K)
    c.kind[:] = kinds
    c.weight[:] = weights
    c.sample_weight[:] = np.abs(np.asarray(weights, np.float64).mean(axis=1))
    c.N[:] = N[:, None, :]
    return c


def test_closures_sum_their_values_and_average_their_pdfs_by_sampling_weight():
    """Two closures (a diffuse of weight a, a mirror of weight b): f cos = a cos / pi (the mirror adds 0);
    pdf = (w_a cos/pi + w_b 0) / (w_a + w_b); sampling picks each in proportion to its weight, and a
    picked mirror carries b / P(mirror)."""
    n = 4000
    N, wo = random_frames(n, 5)
    a, b = np.array([0.6, 0.3, 0.1]), np.array([0.2, 0.2, 0.5])
    closures = closures_of([Lambert.kind, Mirror.kind], [a, b], N)
    wi = np.random.default_rng(6).normal(size=(n, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    f_cos, pdf = materials.eval_closures(closures, wo, wi)
    cos = np.maximum(np.einsum("ij,ij->i", N, wi), 0.0)
    np.testing.assert_allclose(f_cos, a * (cos / math.pi)[:, None], rtol=1e-13)
    wa, wb = a.mean(), b.mean()
    np.testing.assert_allclose(pdf, wa * cos / math.pi / (wa + wb), rtol=1e-13)
    pick = np.random.default_rng(7).random(n)
    s = materials.sample_closures(closures, wo, np.random.default_rng(8).random((n, 2)), pick)
    assert s.delta.mean() == pytest.approx(wb / (wa + wb), abs=0.03)
    np.testing.assert_allclose(s.weight[s.delta], np.tile(b * (wa + wb) / wb, (s.delta.sum(), 1)), rtol=1e-12)
    # A diffuse pick carries f cos / pdf of the pair: a / P(diffuse).
    np.testing.assert_allclose(s.weight[~s.delta], np.tile(a * (wa + wb) / wa, ((~s.delta).sum(), 1)), rtol=1e-9)


def test_material_table_has_a_default_grey_diffuse_row_and_refuses_unknown_bsdfs():
    table = MaterialTable.of([materials.Material((0.1, 0.2, 0.3), "Red", "DIFFUSE"),
                              materials.Material((1.5, -1.0, np.nan), "Odd", "MIRROR", emission=(2.0, 0.0, 1.0))])
    N = np.tile([0.0, 0.0, 1.0], (3, 1))
    result = table.shade(np.array([0, 1, 2], np.int32), N, N)
    np.testing.assert_array_equal(result.closures.kind[:, 0], [Lambert.kind, Mirror.kind, Lambert.kind])
    np.testing.assert_allclose(result.closures.weight[:, 0], [[0.1, 0.2, 0.3], [1.0, 0.0, 0.0], [0.8, 0.8, 0.8]])
    np.testing.assert_allclose(result.emission, [[0, 0, 0], [2.0, 0.0, 1.0], [0, 0, 0]])
    with pytest.raises(ValueError, match="asks for BSDF 'HAIR'"):
        MaterialTable.of([materials.Material((0.5, 0.5, 0.5), "Fur", "HAIR")])


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_a_mirror_floor_is_black_in_direct_light_beside_a_diffuse_one(kernels):
    """Direct light only (Cycles' max_bounces = 0): a diffuse floor shows rho / pi S cos, a mirror floor
    nothing, since no light sample can find a delta direction."""
    scene = Scene(camera=ortho_down(height=2.0, scale=4.0))
    diffuse = scene.add_material((0.5, 0.5, 0.5))
    mirror = scene.add_material((0.9, 0.9, 0.9), bsdf="MIRROR")
    scene.add_mesh(primitives.plane(2.0, center=(-1.0, 0.0, 0.0)), materials=np.array([diffuse]))
    scene.add_mesh(primitives.plane(2.0, center=(1.0, 0.0, 0.0)), materials=np.array([mirror]))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=2.0))
    image = render.render(scene, RenderSettings(width=8, height=4, samples=4, kernels=kernels)).image
    np.testing.assert_allclose(image[1:3, 1:3, :3], 0.5 / math.pi * 2.0, rtol=1e-6)
    np.testing.assert_array_equal(image[1:3, 5:7, :3], 0.0)


def test_light_sampling_and_bsdf_sampling_estimate_the_same_light_from_an_area_light():
    """The light and BSDF interfaces agree on what arrives: the irradiance an area light gives a point,
    estimated by sampling the light (strength = L_e / pdf) and by sampling the Lambert BSDF's
    cosine-weighted directions that hit it (E = pi E[L_e], Light.hit), and the pdf that hit reports for
    a direction is the pdf sample gave it. With MIS weights w_l = p_l^2 / (p_l^2 + p_b^2) and
    w_b = p_b^2 / (p_l^2 + p_b^2), which sum to one, the combination estimates it too."""
    axis_u, axis_v = np.array([1.2, 0.0, 0.0]), np.array([0.0, 0.8, 0.3])
    down = -np.cross(axis_u, axis_v) / np.linalg.norm(np.cross(axis_u, axis_v))       # emitting downwards
    light = AreaLight(np.array([0.3, -0.2, 1.5]), axis_u, axis_v, down, power=50.0)
    n = 400_000
    rng = np.random.default_rng(8)
    P = np.zeros((n, 3))
    N = np.tile([0.0, 0.0, 1.0], (n, 1))
    # 1. Light sampling: E = mean(strength cos).
    ls = light.sample(P, rng.random((n, 2)))
    cos_l = np.maximum(ls.L[:, 2], 0.0)
    E_light = np.mean(ls.strength * cos_l)
    # 2. BSDF sampling: cosine-weighted directions, pdf cos / pi: E = mean(L_e cos / pdf) = pi mean(L_e).
    bs = Lambert.sample(no_params(n), N, N, rng.random((n, 2)))
    found = light.hit(P, bs.wi, np.full(n, np.inf))
    E_bsdf = np.mean(np.where(found.hit, found.radiance[:, 0] * math.pi, 0.0))
    assert E_bsdf == pytest.approx(E_light, rel=0.01)
    # 3. hit's pdf of a direction is the pdf sample gave it (the same solid-angle density).
    back = light.hit(P[:1000], ls.L[:1000], np.full(1000, np.inf))
    facing = ls.pdf[:1000] > 0
    assert back.hit[facing].all()
    np.testing.assert_allclose(back.pdf[facing], ls.pdf[:1000][facing], rtol=1e-9)
    # 4. MIS with the power heuristic: both estimators weighted, summed.
    p_b_of_light = np.maximum(ls.L[:, 2], 0.0) / math.pi
    w_light = ls.pdf ** 2 / (ls.pdf ** 2 + p_b_of_light ** 2)
    p_l_of_bsdf = found.pdf
    w_bsdf = np.where(found.hit, bs.pdf ** 2 / (bs.pdf ** 2 + p_l_of_bsdf ** 2), 0.0)
    E_mis = np.mean(w_light * ls.strength * cos_l) + np.mean(w_bsdf * np.where(found.hit, found.radiance[:, 0] * math.pi, 0.0))
    assert E_mis == pytest.approx(E_light, rel=0.01)


def test_a_principled_bsdf_emits_only_with_both_a_colour_and_a_strength_as_cycles_decides():
    """Cycles' PrincipledBsdfNode::has_surface_emission: a black Emission Color of Strength 1 (Blender's default, the
    donut tutorial's dough) is no emitter, so no light-sampled-emitter warning names its Bump."""
    from core.materials.closures import WEIGHT_CUTOFF, principled_emits
    assert not principled_emits(False, 0.0, False, 1.0)              # black, strength 1: Blender's default
    assert not principled_emits(False, 1.0, False, 0.0)              # white, strength 0
    assert not principled_emits(False, WEIGHT_CUTOFF, False, 1.0)    # at the cutoff: dropped, as Cycles drops it
    assert principled_emits(False, 2 * WEIGHT_CUTOFF, False, 1.0)
    assert principled_emits(True, 0.0, False, 1.0)                   # a linked colour may emit
    assert principled_emits(False, 0.5, True, 0.0)                   # so may a linked strength
    assert not principled_emits(True, 0.0, False, 0.0)               # but not at strength 0
