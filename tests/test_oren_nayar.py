"""The Oren-Nayar BSDF (rough diffuse, Cycles' Diffuse BSDF Roughness and Principled Diffuse Roughness) against
closed forms: energy, reciprocity, Lambert at roughness 0, sampling that matches eval, and C equal to Python."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import materials
from core.materials import nodes
from core.materials import oren_nayar as on
from core.materials.closures import PARAMS


def direction(mu: float, phi: float = 0.0) -> np.ndarray:
    """The unit direction at cos theta = mu and azimuth phi around +Z."""
    s = math.sqrt(max(0.0, 1.0 - mu * mu))
    return np.array([s * math.cos(phi), s * math.sin(phi), mu])


def hemisphere_integral(params_row: np.ndarray, wo: np.ndarray, n: int = 600) -> np.ndarray:
    """The integral of f cos over the hemisphere (RGB), by the midpoint rule in (cos theta, phi)."""
    mu = (np.arange(n) + 0.5) / n
    phi = (np.arange(2 * n) + 0.5) * (math.pi / n)
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - M * M)
    wi = np.stack([s * np.cos(P), s * np.sin(P), M], axis=-1).reshape(-1, 3)
    k = len(wi)
    N = np.tile([0.0, 0.0, 1.0], (k, 1))
    f_cos, _ = on.OrenNayar.eval(np.tile(params_row, (k, 1)), N, np.tile(wo, (k, 1)), wi)
    # d omega = d mu d phi; f_cos already holds the cosine, so the integral of f cos d omega is the sum x cell.
    return f_cos.sum(axis=0) * (1.0 / n) * (math.pi / n)


@pytest.mark.parametrize("sigma", [0.2, 0.6, 1.0])
@pytest.mark.parametrize("mu_o", [0.05, 0.4, 0.9, 1.0])
def test_a_white_rough_diffuse_surface_reflects_all_the_light_it_receives(sigma, mu_o):
    """Colour 1: single scattering (A + B t) loses light at rough, grazing angles; the multiple-scattering term
    puts exactly that back, so the directional albedo is 1 at every view angle and roughness."""
    wo = direction(mu_o)
    row = on.params_of(np.array([sigma]), np.ones((1, 3)), np.array([mu_o]))[0]
    np.testing.assert_allclose(hemisphere_integral(row, wo), 1.0, atol=2e-3)


def test_the_single_scattering_albedo_is_the_closed_form_E():
    """Without the multiple-scattering term the lobe reflects E(mu) = A pi + B G(mu) (the closed form the
    energy compensation is built on)."""
    for sigma, mu_o in ((0.5, 0.3), (1.0, 0.8), (1.0, 0.05)):
        row = on.params_of(np.array([sigma]), np.ones((1, 3)), np.array([mu_o]))[0]
        row[on.MULTI:on.MULTI + 3] = 0.0
        a, b = row[on.A], row[on.B]
        expected = a * math.pi + b * on.G(np.array([mu_o]))[0]
        np.testing.assert_allclose(hemisphere_integral(row, direction(mu_o)), expected, rtol=2e-3)


def test_rough_diffuse_reflection_is_reciprocal():
    """f(wo, wi) = f(wi, wo): the lobe and its multiple scattering are symmetric in the two directions."""
    rng = np.random.default_rng(4)
    albedo = rng.uniform(0.1, 1.0, (200, 3))
    sigma = rng.uniform(0.05, 1.0, 200)
    wo = np.array([direction(m, p) for m, p in rng.uniform((0.02, 0.0), (1.0, 2 * math.pi), (200, 2))])
    wi = np.array([direction(m, p) for m, p in rng.uniform((0.02, 0.0), (1.0, 2 * math.pi), (200, 2))])
    N = np.tile([0.0, 0.0, 1.0], (200, 1))
    f_oi, _ = on.OrenNayar.eval(on.params_of(sigma, albedo, wo[:, 2]), N, wo, wi)
    f_io, _ = on.OrenNayar.eval(on.params_of(sigma, albedo, wi[:, 2]), N, wi, wo)
    np.testing.assert_allclose(f_oi / wi[:, 2:3], f_io / wo[:, 2:3], rtol=1e-12)


def test_samples_weigh_to_what_eval_integrates():
    """Cosine-weighted samples with weight f cos / pdf average to the integral of f cos (colour 0.6, rough 0.7)."""
    n = 400_000
    rng = np.random.default_rng(9)
    wo = direction(0.35, 0.4)
    row = on.params_of(np.array([0.7]), np.full((1, 3), 0.6), np.array([0.35]))[0]
    s = on.OrenNayar.sample(np.tile(row, (n, 1)), np.tile([0.0, 0.0, 1.0], (n, 1)), np.tile(wo, (n, 1)),
                            rng.random((n, 2)))
    np.testing.assert_allclose(s.weight.mean(axis=0), hemisphere_integral(row, wo), rtol=3e-3)
    np.testing.assert_allclose(s.pdf, s.wi[:, 2] / math.pi, rtol=1e-12)


def test_compiled_oren_nayar_equals_the_reference():
    """bsdf.c's Oren-Nayar evaluates and samples as oren_nayar.py does."""
    n = 500
    rng = np.random.default_rng(5)
    wo = np.array([direction(m, p) for m, p in rng.uniform((0.01, 0.0), (1.0, 2 * math.pi), (n, 2))])
    wi = np.array([direction(m, p) for m, p in rng.uniform((-0.2, 0.0), (1.0, 2 * math.pi), (n, 2))])
    N = np.tile([0.0, 0.0, 1.0], (n, 1))
    params = on.params_of(rng.uniform(0.0, 1.0, n), rng.uniform(0.0, 1.0, (n, 3)), wo[:, 2])
    u = rng.random((n, 2))
    f_cos, pdf = on.OrenNayar.eval(params, N, wo, wi)
    s = on.OrenNayar.sample(params, N, wo, u)
    kind = np.full(n, on.OrenNayar.kind, np.int32)
    c_f, c_pdf, c_sample = materials.compiled_bsdf(kind, np.ones((n, 3)), N, params, wo, wi, u)
    np.testing.assert_allclose(c_f, f_cos, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c_pdf, pdf, rtol=1e-9, atol=1e-12)
    # (The sampled direction carries a float32 cosine in C, as for every BSDF: tests/test_compiled.py's tolerance.)
    np.testing.assert_allclose(c_sample.wi, s.wi, rtol=0, atol=1e-6)
    np.testing.assert_allclose(c_sample.weight, s.weight, rtol=1e-6, atol=1e-12)


def test_diffuse_and_principled_nodes_choose_lambert_or_oren_nayar_by_roughness():
    """Cycles' rule: a Diffuse BSDF of roughness below 1e-5, and a Principled BSDF of Diffuse Roughness below its
    weight cutoff, are Lambert's; above, Oren-Nayar's with the node's colour."""
    N = np.array([[0.0, 0.0, 1.0]])
    for node, inputs in ((nodes.DiffuseNode, {"roughness": 0.5, "color": (0.2, 0.4, 0.6)}),
                         (nodes.PrincipledNode, {"diffuse_roughness": 0.5, "base_color": (0.2, 0.4, 0.6)})):
        for value, expected in ((0.0, materials.Lambert.kind), (0.5, materials.OrenNayar.kind)):
            key = "roughness" if node is nodes.DiffuseNode else "diffuse_roughness"
            row = node.row({**inputs, key: value})
            result = nodes.shade_nodes([(node, np.ones(3), row)], N, N)
            kinds = result.closures.kind[0]
            assert expected in kinds and ({materials.Lambert.kind, materials.OrenNayar.kind} - {expected}).isdisjoint(kinds)
    row = nodes.DiffuseNode.row({"roughness": 1.0, "color": (0.2, 0.4, 0.6)})
    result = nodes.shade_nodes([(nodes.DiffuseNode, np.ones(3), row)], N, N)
    expected = on.params_of(np.array([1.0]), np.array([[0.2, 0.4, 0.6]]), np.array([1.0]))[0]
    np.testing.assert_allclose(result.closures.params[0, 0, :PARAMS], expected)
