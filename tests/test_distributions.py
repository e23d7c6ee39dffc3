"""Beckmann and Ashikhmin-Shirley microfacet distributions (issue 32): their normalisation, masking and sampling
against quadrature that never calls the sampler, their closed forms, the nodes' setups and the C twins."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import materials
from core.materials import ashikhmin_shirley as ashikhmin
from core.materials import microfacet as mf
from core.materials import nodes, rough_glass
from core.materials.ashikhmin_shirley import AshikhminShirley
from core.materials.beckmann import Beckmann
from core.materials.beckmann_glass import BeckmannGlass

N_UP = np.array([0.0, 0.0, 1.0])
TANGENT = (0.6, 0.8, 0.0)


def sphere_grid(k: int, lower: bool = False):
    """Directions (m, 3) and solid-angle weights (m,) of a midpoint grid in (cos theta, phi) over the upper
    hemisphere (and the lower one too where `lower`), finer near the poles (cos theta = 1 - t^2), where narrow lobes
    live."""
    t = (np.arange(k) + 0.5) / k
    cos_t, dcos = 1.0 - t * t, 2.0 * t / k
    if lower:
        cos_t, dcos = np.concatenate([cos_t, -cos_t]), np.concatenate([dcos, dcos])
    phi = (np.arange(2 * k) + 0.5) / (2 * k) * 2.0 * math.pi
    c, p = np.meshgrid(cos_t, phi, indexing="ij")
    s = np.sqrt(1.0 - c * c)
    w = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1).reshape(-1, 3)
    return w, (dcos[:, None] * np.full(2 * k, math.pi / k)[None, :]).reshape(-1)


def view(mu: float, phi: float = 0.7) -> np.ndarray:
    """The unit direction at cosine mu to N, at azimuth phi."""
    s = math.sqrt(1.0 - mu * mu)
    return np.array([s * math.cos(phi), s * math.sin(phi), mu])


def rows(n: int, alpha_x: float, alpha_y=None) -> np.ndarray:
    """n rows (n, PARAMS) of a reflection lobe without Fresnel, anisotropic along TANGENT where alpha_y is given."""
    p = nodes.GlossyLobe.params(n, math.sqrt(alpha_x), mf.FRESNEL_NONE)
    if alpha_y is not None:
        nodes.anisotropic_lobe(p, np.full(n, alpha_x), np.full(n, alpha_y), np.tile(TANGENT, (n, 1)), np.ones(n, bool))
    return p


def glass_rows(n: int, alpha: float, eta: float) -> np.ndarray:
    """n rows of a rough Glass closure (dielectric Fresnel, white tints) of relative index eta."""
    p = nodes.glass_params(n, np.zeros(n, bool), eta, mf.FRESNEL_DIELECTRIC, np.zeros(3), np.zeros(3), np.ones(3),
                           np.ones(3))
    p[:, mf.ALPHA] = alpha
    return p


@pytest.mark.parametrize("alpha_x,alpha_y", [(0.2, None), (0.5, None), (0.9, None), (0.5, 0.2), (0.15, 0.7)])
def test_beckmann_D_integrates_to_one_over_the_projected_hemisphere(alpha_x, alpha_y):
    """The integral of D(h) (n.h) over the hemisphere of microfacet normals is 1 (projected area), isotropic and
    anisotropic."""
    h, dw = sphere_grid(800)
    m = len(h)
    if alpha_y is None:
        D = mf.D_beckmann(np.full(m, alpha_x * alpha_x), h[:, 2])
    else:
        D = mf.D_aniso_beckmann(np.full(m, alpha_x), np.full(m, alpha_y), h)
    assert (D * h[:, 2] * dw).sum() == pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("alpha_x,alpha_y,mu", [(0.3, None, 0.5), (0.8, None, 0.2), (0.6, 0.25, 0.4)])
def test_beckmann_masking_covers_the_projected_area_within_walters_fit(alpha_x, alpha_y, mu):
    """Smith's masking is the visible projected area: the integral of G1 D max(0, v.h) over h equals v.n. Cycles'
    Lambda is Walter et al.'s rational fit of Beckmann's exact erf form, which it meets within 0.5%."""
    h, dw = sphere_grid(800)
    m = len(h)
    v = view(mu)
    ay = alpha_x if alpha_y is None else alpha_y
    X, Y = mf.tangent_frame(N_UP[None, :], np.array([TANGENT]))
    local_h = mf.to_local(np.tile(X, (m, 1)), np.tile(Y, (m, 1)), np.tile(N_UP, (m, 1)), h)
    D = mf.D_aniso_beckmann(np.full(m, alpha_x), np.full(m, ay), local_h)
    local_v = mf.to_local(X, Y, N_UP[None, :], v[None, :])
    G1 = 1.0 / (1.0 + mf.lambda_aniso_beckmann(np.array([alpha_x]), np.array([ay]), local_v))[0]
    # Beckmann's exact Lambda, for the fit's error: (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2, a = 1 / (alpha tan).
    tan2 = ((alpha_x * local_v[0, 0]) ** 2 + (ay * local_v[0, 1]) ** 2) / local_v[0, 2] ** 2
    a = 1.0 / math.sqrt(tan2)
    exact = 0.5 * (math.exp(-a * a) / (a * math.sqrt(math.pi)) - math.erfc(a))
    assert 1.0 / (1.0 + exact) == pytest.approx(G1, rel=5e-3)
    assert (G1 * D * np.maximum(h @ v, 0.0) * dw).sum() == pytest.approx(v[2], rel=5e-3)


def test_error_function_and_its_inverse_meet_the_library_erf():
    """erf within 1.5e-7 of math.erf over the reals, and erf(erfinv(x)) within 1e-7 of x on (-1, 1): the
    approximations the Beckmann sampler inverts its CDF with."""
    x = np.linspace(-5.0, 5.0, 4001)
    assert np.abs(mf.erf(x) - np.array([math.erf(v) for v in x])).max() < 1.5e-7
    y = np.linspace(-0.999999, 0.999999, 4001)
    assert np.abs(np.array([math.erf(v) for v in mf.erfinv(y)]) - y).max() < 1e-7


def everywhere(N: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Every pair (m,) bool."""
    return np.ones(len(wi), bool)


def connects(N: np.ndarray, wo: np.ndarray, wi: np.ndarray, eta: float) -> np.ndarray:
    """Where a microfacet connects wo and wi (rough_glass.connects): eval, like Cycles', also answers other pairs."""
    return rough_glass.connects(N, wo, wi, np.full(len(wi), eta))


def histogram_check(bsdf, p_row: np.ndarray, mu: float, u_dims: int, k: int, lower: bool, tolerance: float,
                    pdf_share_tolerance: float, support=everywhere, drawn=None):
    """Sample 200000 directions of `bsdf` with parameters p_row seen from mu: each sample's pdf is eval's there and
    its weight f cos / pdf; the pdf integrated by quadrature (which never calls the sampler) is the share of
    samples the BSDF keeps, within `pdf_share_tolerance` (what the lobe loses below the surface); the directions'
    histogram over (cos theta, phi) cells matches the pdf integrated over each cell, within 5 sigma + `tolerance`
    of each cell; and the mean weight is the albedo by quadrature. Samples and quadrature over the pairs
    `support` (N, wo, wi) (m,) bool says the model has, and samples where `drawn` (u (n, dims), N, wo) (n,) bool
    says the sampler meant them so."""
    rng = np.random.default_rng(32)
    n = 200_000
    p = np.tile(p_row, (n, 1))
    N, wo = np.tile(N_UP, (n, 1)), np.tile(view(mu), (n, 1))
    u = rng.random((n, u_dims))
    s = bsdf.sample(p, N, wo, u)
    kept = (s.pdf > 0.0) & support(N, wo, s.wi) & (True if drawn is None else drawn(p, u, N, wo))
    f_cos, pdf = bsdf.eval(p, N, wo, s.wi)
    np.testing.assert_allclose(s.pdf[kept], pdf[kept], rtol=1e-9)
    np.testing.assert_allclose(s.weight[kept], f_cos[kept] / pdf[kept][:, None], rtol=1e-9)
    wi, dw = sphere_grid(k, lower)
    m = len(wi)
    f_q, pdf_q = bsdf.eval(np.tile(p_row, (m, 1)), np.tile(N_UP, (m, 1)), np.tile(view(mu), (m, 1)), wi)
    inside = support(np.tile(N_UP, (m, 1)), np.tile(view(mu), (m, 1)), wi)
    f_q, pdf_q = f_q * inside[:, None], pdf_q * inside
    assert (pdf_q * dw).sum() == pytest.approx(kept.mean(), abs=pdf_share_tolerance)
    albedo = (f_q[:, 0] * dw).sum()
    weights = np.where(kept, s.weight[:, 0], 0.0)
    assert weights.mean() == pytest.approx(albedo, abs=4.0 * weights.std() / math.sqrt(n) + 2 * pdf_share_tolerance)
    bands = 12 if lower else 6

    def cell(w):
        c = np.clip(((w[:, 2] + (1.0 if lower else 0.0)) * 6).astype(int), 0, bands - 1)
        ph = np.clip(((np.arctan2(w[:, 1], w[:, 0]) % (2 * math.pi)) / (2 * math.pi) * 8).astype(int), 0, 7)
        return c * 8 + ph

    expected = np.bincount(cell(wi), weights=pdf_q * dw, minlength=bands * 8) * n
    found = np.bincount(cell(s.wi[kept]), minlength=bands * 8)
    big = expected > 200
    assert big.sum() >= 6
    assert np.all(np.abs(found[big] - expected[big]) <= 5.0 * np.sqrt(expected[big]) + tolerance * expected[big])
    return albedo


@pytest.mark.parametrize("alpha_x,alpha_y,mu", [(0.2, None, 0.8), (0.5, None, 0.3), (0.9, None, 0.95),
                                                (0.5, 0.15, 0.6), (0.1, 0.6, 0.35)])
def test_beckmann_samples_follow_the_pdf_eval_gives(alpha_x, alpha_y, mu):
    """Beckmann's visible normals (isotropic and anisotropic): the sampler draws the exact visible normals and the
    pdf has Walter's fitted G1, so they agree to the fit's error (a percent of each cell, of the pdf's integral)."""
    histogram_check(Beckmann, rows(1, alpha_x, alpha_y)[0], mu, 2, 300, False, 0.02, 0.01)


@pytest.mark.parametrize("alpha,mu,eta", [(0.16, 0.8, 1.5), (0.36, 0.5, 1 / 1.5), (0.8, 0.3, 1.33)])
def test_beckmann_glass_samples_follow_the_pdf_eval_gives(alpha, mu, eta):
    """Beckmann glass reflects and refracts: the samples on both sides of the surface follow eval's pdf (the
    quadrature over the pairs a microfacet connects) and their mean weight is its albedo."""
    histogram_check(BeckmannGlass, glass_rows(1, alpha, eta)[0], mu, 3, 300, True, 0.03, 0.02,
                    support=lambda N, wo, wi: connects(N, wo, wi, eta))


@pytest.mark.parametrize("alpha_x,alpha_y,mu", [(0.2, None, 0.8), (0.6, None, 0.3), (0.1, None, 0.5),
                                                (0.5, 0.1, 0.6), (0.1, 0.7, 0.35)])
def test_ashikhmin_shirley_samples_follow_the_pdf_eval_gives(alpha_x, alpha_y, mu):
    """Ashikhmin-Shirley's half vectors (phi uniform, or per quadrant for the anisotropic lobe): the pdf eval gives
    is the density of the directions they reflect into, exactly (no fitted term): every cell within 5 sigma + 1%.
    (Half vectors facing away from wo make other directions, as in Cycles: not counted.)"""
    histogram_check(AshikhminShirley, rows(1, alpha_x, alpha_y)[0], mu, 2, 400, False, 0.01, 0.003,
                    drawn=lambda p, u, N, wo: np.einsum("ij,ij->i", AshikhminShirley.half_vectors(p, N, u), wo) >= 0.0)


@pytest.mark.parametrize("alpha_x,alpha_y", [(0.3, None), (0.05, None), (0.4, 0.1), (0.02, 0.3)])
def test_ashikhmin_shirley_half_vector_density_integrates_to_one(alpha_x, alpha_y):
    """p(H) = 4 |H.wo| pdf integrates to 1 over the hemisphere of half vectors (the lobe's normalisation
    sqrt((nx + 1)(ny + 1)) / 2 pi); each H read with wo = wi = H, where |H.wo| = 1. (The 600-grid's own error
    is at most 1.9e-4 over these lobes, under a tenth of the bound: as strict as a 1200-grid, at a sixth of the
    time.)"""
    h, dw = sphere_grid(600)
    m = len(h)
    _, pdf = AshikhminShirley.eval(rows(m, alpha_x, alpha_y), np.tile(N_UP, (m, 1)), h, h)
    assert (pdf * 4.0 * dw).sum() == pytest.approx(1.0, abs=3e-3)


@pytest.mark.parametrize("alpha_x,alpha_y,mu", [(0.3, None, 0.7), (0.5, 0.1, 0.4)])
def test_ashikhmin_shirley_weight_is_the_cosine_ratio_and_keeps_at_most_the_light(alpha_x, alpha_y, mu):
    """f cos / pdf = N.wi / max(N.wo, N.wi) (the paper's pump over the half vector's pdf): at most 1, so a white
    lobe keeps at most the light of a white furnace (no masking term: it loses only what reflects below). (Half
    vectors turned to face wo weigh a longer vector, as in Cycles: the ratio of its cosine, not counted here.)"""
    n = 50_000
    rng = np.random.default_rng(2)
    N, wo = np.tile(N_UP, (n, 1)), np.tile(view(mu), (n, 1))
    u = rng.random((n, 2))
    p = rows(n, alpha_x, alpha_y)
    s = AshikhminShirley.sample(p, N, wo, u)
    kept = (s.pdf > 0.0) & (np.einsum("ij,ij->i", AshikhminShirley.half_vectors(p, N, u), wo) >= 0.0)
    cos_i = s.wi[kept, 2]
    np.testing.assert_allclose(s.weight[kept, 0], cos_i / np.maximum(cos_i, mu), rtol=1e-9)
    assert 0.5 < s.weight[:, 0].mean() <= 1.0


def test_beckmann_lobes_approach_a_mirror_as_they_smooth():
    """A nearly smooth Beckmann lobe reflects all the light (albedo -> 1 as alpha -> 0), by quadrature: the closed
    form of the mirror it tends to. (The grid puts ~8 points across the lobe: its sum is 1 within 1e-14 at
    k = 500 as at 1500, at a fifteenth of the evals.)"""
    wi, dw = sphere_grid(500)
    m = len(wi)
    f_cos, _ = Beckmann.eval(rows(m, 0.02), np.tile(N_UP, (m, 1)), np.tile(view(0.7), (m, 1)), wi)
    assert (f_cos[:, 0] * dw).sum() == pytest.approx(1.0, abs=0.01)


def setup(node, inputs: dict, mu: float = 0.7):
    """One hit's closures of `node` (a node class) with `inputs`: (kinds (slots,), params (slots, PARAMS))."""
    b = nodes.ClosureBuilder(N_UP[None, :], view(mu)[None, :], 2)
    node.setup(b, np.ones((1, 3)), node.row(inputs))
    return b.closures.kind[0, :b.count], b.closures.params[0, :b.count]


def test_glossy_and_glass_nodes_set_up_the_distribution_cycles_does():
    """Glossy: Beckmann and Ashikhmin-Shirley closures with alpha = roughness^2 (no multiscatter energy scale),
    anisotropic alphas as GGX's; Ashikhmin-Shirley's alphas raised to 1e-4, and a mirror below roughness 0.01;
    Glass and Refraction: Beckmann glass, smooth glass at roughness 0 still."""
    kind, p = setup(nodes.GlossyNode, {"roughness": 0.5, "distribution": nodes.BECKMANN, "multiscatter": 1.0})
    assert kind.tolist() == [Beckmann.kind] and p[0, mf.ALPHA] == 0.25 and p[0, mf.ENERGY] == 1.0
    kind, p = setup(nodes.GlossyNode, {"roughness": 0.5, "distribution": nodes.ASHIKHMIN_SHIRLEY,
                                       "anisotropy": 0.5, "tangent": (1.0, 0.0, 0.0)})
    assert kind.tolist() == [AshikhminShirley.kind]
    assert (p[0, mf.ALPHA], p[0, mf.ALPHA_Y]) == pytest.approx((0.125, 0.5))
    kind, p = setup(nodes.GlossyNode, {"roughness": 0.005, "distribution": nodes.ASHIKHMIN_SHIRLEY})
    assert kind.tolist() == [materials.Mirror.kind]
    kind, p = setup(nodes.GlossyNode, {"roughness": 0.02, "distribution": nodes.ASHIKHMIN_SHIRLEY})
    assert kind.tolist() == [AshikhminShirley.kind] and p[0, mf.ALPHA] == pytest.approx(4e-4)
    for refraction_only in (0.0, 1.0):
        kind, p = setup(nodes.GlassNode, {"roughness": 0.3, "distribution": nodes.BECKMANN,
                                          "refraction_only": refraction_only, "multiscatter": 1.0})
        assert kind.tolist() == [BeckmannGlass.kind] and p[0, mf.ENERGY] == 1.0
        kind, _ = setup(nodes.GlassNode, {"roughness": 0.0, "distribution": nodes.BECKMANN,
                                          "refraction_only": refraction_only})
        assert kind.tolist() == [materials.Glass.kind]
    assert ashikhmin.exponent(np.array([1.0]))[0] == 0.0


def test_distribution_nodes_in_c_render_what_python_does():
    """Glossy Beckmann (isotropic and anisotropic), Ashikhmin-Shirley (both), Beckmann Glass and Refraction under
    a lamp and an area light: the compiled path renders what the reference path does."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.scene import RenderSettings
    scene = lit_scene(LIGHTS["several"])
    aniso = {"anisotropy": 0.6, "rotation": 0.1, "tangent": (1.0, 0.0, 0.0)}
    scene.materials[0] = materials.Material(name="beckmann", nodes=[
        ("GLOSSY", (0.4, 0.3, 0.2), {"roughness": 0.3, "distribution": nodes.BECKMANN}),
        ("GLOSSY", (0.2, 0.3, 0.4), {"roughness": 0.5, "distribution": nodes.BECKMANN, **aniso}),
        ("GLASS", (0.3, 0.3, 0.3), {"roughness": 0.2, "ior": 1.3, "refraction_only": 1.0,
                                    "distribution": nodes.BECKMANN})])
    scene.materials[1] = materials.Material(name="ashikhmin", nodes=[
        ("GLOSSY", (0.4, 0.3, 0.2), {"roughness": 0.4, "distribution": nodes.ASHIKHMIN_SHIRLEY}),
        ("GLOSSY", (0.2, 0.3, 0.4), {"roughness": 0.3, "distribution": nodes.ASHIKHMIN_SHIRLEY, **aniso}),
        ("GLASS", (0.3, 0.3, 0.3), {"roughness": 0.4, "ior": 1.45, "distribution": nodes.BECKMANN})])
    compiled, reference = compare_paths(scene, RenderSettings(width=48, height=32, samples=4))
    assert_same_render(compiled, reference)
    assert compiled.image[..., :3].max() > 0.05
