"""Anisotropic GGX (issue 20): the distribution, its visible-normal sampling, the Principled and Glossy setups and
the Tangent node, against closed forms, quadrature that does not use the sampler, the isotropic code and the C twin."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import materials
from core.materials import graph
from core.materials import microfacet as mf
from core.materials import nodes

N_UP = np.array([0.0, 0.0, 1.0])
ALPHA_PAIRS = [(0.5, 0.2), (0.2, 0.6), (0.8, 0.3), (1.0, 0.45)]


def hemisphere_grid(k: int):
    """Directions (m, 3) and solid-angle weights (m,) of a midpoint grid in (cos theta, phi) over the upper
    hemisphere, finer near the pole (cos theta = 1 - t^2), where narrow lobes live."""
    t = (np.arange(k) + 0.5) / k
    cos_t = 1.0 - t * t
    dcos = 2.0 * t / k
    phi = (np.arange(2 * k) + 0.5) / (2 * k) * 2.0 * math.pi
    c, p = np.meshgrid(cos_t, phi, indexing="ij")
    s = np.sqrt(1.0 - c * c)
    w = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1).reshape(-1, 3)
    return w, (dcos[:, None] * np.full(2 * k, math.pi / k)[None, :]).reshape(-1)


def aniso_rows(n: int, alpha_x: float, alpha_y: float, tangent=(1.0, 0.0, 0.0), mode: int = mf.FRESNEL_NONE,
               ior: float = 1.5) -> np.ndarray:
    """n rows (n, PARAMS) of an anisotropic microfacet closure."""
    p = nodes.GlossyLobe.params(n, 0.5, mode, ior)
    nodes.anisotropic_lobe(p, np.full(n, alpha_x), np.full(n, alpha_y), np.tile(tangent, (n, 1)), np.ones(n, bool))
    return p


def view(mu: float, phi: float = 0.7) -> np.ndarray:
    """The unit direction at cosine mu to N, at azimuth phi."""
    s = math.sqrt(1.0 - mu * mu)
    return np.array([s * math.cos(phi), s * math.sin(phi), mu])


@pytest.mark.parametrize("alpha_x,alpha_y", ALPHA_PAIRS)
def test_anisotropic_D_integrates_to_one_over_the_projected_hemisphere(alpha_x, alpha_y):
    """The integral of D(h) (n.h) over the hemisphere of microfacet normals is 1 (projected area)."""
    h, dw = hemisphere_grid(600)
    D = mf.D_aniso(np.full(len(h), alpha_x), np.full(len(h), alpha_y), h)
    assert (D * h[:, 2] * dw).sum() == pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("alpha_x,alpha_y", ALPHA_PAIRS)
def test_visible_normals_cover_the_projected_area_seen_from_any_view(alpha_x, alpha_y):
    """Smith's masking (1 / (1 + Lambda)) is the visible projected area: the integral of G1 D max(0, v.h) over h
    equals v.n, for a view off the tangent's axes."""
    h, dw = hemisphere_grid(600)
    v = view(0.4)
    m = len(h)
    D = mf.D_aniso(np.full(m, alpha_x), np.full(m, alpha_y), h)
    G1 = 1.0 / (1.0 + mf.lambda_aniso(np.array([alpha_x]), np.array([alpha_y]), v[None, :]))[0]
    assert (G1 * D * np.maximum(h @ v, 0.0) * dw).sum() == pytest.approx(v[2], rel=3e-3)


@pytest.mark.parametrize("alpha_x,alpha_y,mu", [(0.5, 0.2, 0.8), (0.2, 0.6, 0.5), (0.9, 0.35, 0.3)])
def test_sampled_directions_have_the_eval_pdf_and_their_mean_weight_is_the_albedo(alpha_x, alpha_y, mu):
    """VNDF sampling of an anisotropic lobe: each sampled direction's pdf is eval's pdf there; the sampled
    directions' histogram over (cos theta, phi) cells matches the pdf integrated over each cell; and the mean
    of f cos / pdf is the directional albedo by quadrature (which never calls the sampler)."""
    rng = np.random.default_rng(20)
    n = 200_000
    p = aniso_rows(n, alpha_x, alpha_y, tangent=(0.6, 0.8, 0.0))
    N = np.tile(N_UP, (n, 1))
    wo = np.tile(view(mu), (n, 1))
    s = materials.Microfacet.sample(p, N, wo, rng.random((n, 2)))
    kept = s.pdf > 0.0
    f_cos, pdf = materials.Microfacet.eval(p, N, wo, s.wi)
    np.testing.assert_allclose(s.pdf[kept], pdf[kept], rtol=1e-9)
    # Quadrature of f cos and of the pdf per cell.
    k = 300
    wi, dw = hemisphere_grid(k)
    m = len(wi)
    f_q, pdf_q = materials.Microfacet.eval(aniso_rows(m, alpha_x, alpha_y, tangent=(0.6, 0.8, 0.0)),
                                           np.tile(N_UP, (m, 1)), np.tile(view(mu), (m, 1)), wi)
    albedo = (f_q[:, 0] * dw).sum()
    weights = np.where(kept, s.weight[:, 0], 0.0)
    assert weights.mean() == pytest.approx(albedo, abs=4.0 * weights.std() / math.sqrt(n) + 2e-3)
    # Histogram over 6 x 8 cells in (cos theta, phi).
    def cell(w):
        c = np.clip((w[:, 2] * 6).astype(int), 0, 5)
        ph = np.clip(((np.arctan2(w[:, 1], w[:, 0]) % (2 * math.pi)) / (2 * math.pi) * 8).astype(int), 0, 7)
        return c * 8 + ph
    expected = np.bincount(cell(wi), weights=pdf_q * dw, minlength=48) * n
    upper = kept & (s.wi[:, 2] > 0.0)
    found = np.bincount(cell(s.wi[upper]), minlength=48)
    big = expected > 200
    assert big.sum() >= 8
    assert np.all(np.abs(found[big] - expected[big]) <= 5.0 * np.sqrt(expected[big]) + 0.01 * expected[big])


def test_equal_alphas_give_the_isotropic_closure_bit_for_bit():
    """A tangent with alpha_y = alpha (or anisotropy 0 at the nodes) changes nothing: eval, sample and the Principled
    and Glossy setups give the very same numbers as without a tangent."""
    rng = np.random.default_rng(5)
    n = 500
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo *= np.sign(np.einsum("ij,ij->i", wo, N))[:, None]
    iso = nodes.GlossyLobe.params(n, 0.4, mf.FRESNEL_SCHLICK_IOR, 1.5, (0.04, 0.05, 0.06))
    tangent = iso.copy()
    tangent[:, mf.ALPHA_Y] = tangent[:, mf.ALPHA]
    tangent[:, mf.TANGENT:mf.TANGENT + 3] = rng.normal(size=(n, 3))
    for a, b in zip(materials.Microfacet.eval(iso, N, wo, wi), materials.Microfacet.eval(tangent, N, wo, wi)):
        np.testing.assert_array_equal(a, b)
    u = rng.random((n, 2))
    for a, b in zip(materials.Microfacet.sample(iso, N, wo, u), materials.Microfacet.sample(tangent, N, wo, u)):
        np.testing.assert_array_equal(a, b)
    for name, zero in (("PRINCIPLED", {"metallic": 0.5, "anisotropic": 0.0, "anisotropic_rotation": 0.3}),
                       ("GLOSSY", {"anisotropy": 0.0, "rotation": 0.3})):
        plain = nodes.shade_nodes([(materials.NODE_BY_NAME[name], np.ones(3), materials.NODE_BY_NAME[name].row(zero))], N, wo)
        row = materials.NODE_BY_NAME[name].row(dict(zero, tangent=(1.0, 0.0, 0.0)))
        same = nodes.shade_nodes([(materials.NODE_BY_NAME[name], np.ones(3), row)], N, wo)
        for a, b in zip(plain.closures, same.closures):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("alpha_x,alpha_y", ALPHA_PAIRS)
def test_turning_the_tangent_a_quarter_swaps_the_alphas(alpha_x, alpha_y):
    """alpha_x along T and alpha_y across it is alpha_y along N x T and alpha_x across it: f cos and pdf agree."""
    rng = np.random.default_rng(7)
    n = 2000
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo[:, 2], wi[:, 2] = np.abs(wo[:, 2]), np.abs(wi[:, 2])
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    N = np.tile(N_UP, (n, 1))
    T = np.array([math.cos(0.4), math.sin(0.4), 0.0])
    a = materials.Microfacet.eval(aniso_rows(n, alpha_x, alpha_y, T), N, wo, wi)
    b = materials.Microfacet.eval(aniso_rows(n, alpha_y, alpha_x, np.cross(N_UP, T)), N, wo, wi)
    np.testing.assert_allclose(a[0], b[0], rtol=1e-10, atol=1e-300)
    np.testing.assert_allclose(a[1], b[1], rtol=1e-10, atol=1e-300)
    # The Principled BSDF's Anisotropic Rotation of 0.25 turns it the same way.
    turned = nodes.rotate_around_axis(np.tile(T, (n, 1)), N, np.full(n, 0.25 * 2.0 * math.pi))
    np.testing.assert_allclose(turned, np.tile(np.cross(N_UP, T), (n, 1)), atol=1e-15)


def test_anisotropic_lobe_stretches_its_highlight_across_the_tangent():
    """alpha_x > alpha_y: the lobe is wider along the tangent: tilting wi away from the mirror direction along T
    loses less than tilting it across T."""
    wo = view(0.8, 0.0)
    mirror = np.array([-wo[0], -wo[1], wo[2]])
    along = mirror + np.array([0.15, 0.0, 0.0])
    across = mirror + np.array([0.0, 0.15, 0.0])
    wi = np.stack([along / np.linalg.norm(along), across / np.linalg.norm(across)])
    f, _ = materials.Microfacet.eval(aniso_rows(2, 0.4, 0.1), np.tile(N_UP, (2, 1)), np.tile(wo, (2, 1)), wi)
    assert f[0, 0] > 3.0 * f[1, 0]


def test_principled_maps_anisotropic_to_alphas_as_cycles_does():
    """Anisotropic 0.8 at roughness 0.5: aspect = sqrt(1 - 0.72), alpha_x = 0.25 / aspect, alpha_y = 0.25 aspect,
    on the metal and the specular layer; the tables read sqrt(sqrt(alpha_x alpha_y)) = roughness."""
    N, wo = np.array([N_UP]), np.array([view(0.7)])
    row = nodes.PrincipledNode.row({"metallic": 0.5, "roughness": 0.5, "anisotropic": 0.8, "tangent": (1.0, 0.0, 0.0)})
    result = nodes.shade_nodes([(nodes.PrincipledNode, np.ones(3), row)], N, wo)
    aspect = math.sqrt(1.0 - 0.8 * 0.9)
    glossy = result.closures.kind[0] == materials.Microfacet.kind
    assert glossy.sum() == 2
    for p in result.closures.params[0][glossy]:
        assert p[mf.ALPHA] == pytest.approx(0.25 / aspect) and p[mf.ALPHA_Y] == pytest.approx(0.25 * aspect)
        np.testing.assert_allclose(p[mf.TANGENT:mf.TANGENT + 3], (1.0, 0.0, 0.0))
    assert nodes.table_roughness(result.closures.params[0][glossy]) == pytest.approx([0.5, 0.5])


def test_glossy_maps_anisotropy_to_alphas_as_cycles_does():
    """Glossy Anisotropy a = 0.5, -0.5 at roughness 0.6 (r = 0.36): alpha_x = r (1 - a), alpha_y = r / (1 - a) for
    a >= 0, and r / (1 + a), r (1 + a) below."""
    N, wo = np.array([N_UP]), np.array([view(0.7)])
    for a, expected in ((0.5, (0.18, 0.72)), (-0.5, (0.72, 0.18))):
        row = nodes.GlossyNode.row({"roughness": 0.6, "anisotropy": a, "tangent": (0.0, 1.0, 0.0)})
        p = nodes.shade_nodes([(nodes.GlossyNode, np.ones(3), row)], N, wo).closures.params[0, 0]
        assert (p[mf.ALPHA], p[mf.ALPHA_Y]) == pytest.approx(expected)


def test_radial_tangent_circles_the_axis_and_lies_in_the_surface():
    """The Tangent node, Radial about Z of Generated: at a point of a sphere it is perpendicular to N and to the
    direction from the Z axis, as Cycles' svm_node_tangent gives (up to sign)."""
    rng = np.random.default_rng(9)
    n = 100
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    generated = 0.5 + 0.5 * N                        # a unit sphere's Generated coordinates
    point = graph.empty_point(n, 3)._replace(N=N)
    T = graph.tangent(generated, 0, 2, point)
    np.testing.assert_allclose(np.einsum("ij,ij->i", T, N), 0.0, atol=1e-12)
    radial = N * [1.0, 1.0, 0.0]
    np.testing.assert_allclose(np.einsum("ij,ij->i", T, radial), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(T, axis=1), 1.0, atol=1e-12)


def test_c_evaluates_and_samples_anisotropic_ggx_as_python_does():
    """f cos, pdf and a sampled direction of anisotropic microfacet closures in C, against the Python class."""
    rng = np.random.default_rng(11)
    n = 3000
    kind = np.full(n, materials.Microfacet.kind, np.int32)
    weight = rng.random((n, 3))
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo *= np.where(np.einsum("ij,ij->i", wo, N) < 0, -1.0, 1.0)[:, None]
    u = rng.random((n, 2))
    params = np.zeros((n, materials.PARAMS))
    params[:, :16] = aniso_rows(n, 0.5, 0.1, mode=mf.FRESNEL_SCHLICK_IOR)[:, :16]
    params[:, mf.ALPHA] = rng.uniform(0.05, 1.0, n)
    params[:, mf.ALPHA_Y] = rng.uniform(0.05, 1.0, n)
    params[:, mf.TANGENT:mf.TANGENT + 3] = rng.normal(size=(n, 3))
    params[:, mf.F0:mf.F0 + 3] = rng.random((n, 3)) * 0.2
    f_cos, pdf, sampled = materials.compiled_bsdf(kind, weight, N, params, wo, wi, u)
    closures = materials.Closures(kind[:, None], weight[:, None, :], np.abs(weight.mean(axis=1))[:, None],
                                  N[:, None, :], params[:, None, :])
    expected_f, expected_pdf = materials.eval_closures(closures, wo, wi)
    expected = materials.sample_closures(closures, wo, u, np.full(n, 0.5))
    assert (expected_pdf > 0.0).mean() > 0.3
    np.testing.assert_allclose(f_cos, expected_f, rtol=1e-12, atol=0)
    np.testing.assert_allclose(pdf, expected_pdf, rtol=1e-12, atol=0)
    np.testing.assert_allclose(sampled.wi, expected.wi, rtol=0, atol=1e-6)
    # The weight inherits the sampled direction's float32 azimuth cosine (as the isotropic lobe's does); narrow,
    # stretched lobes seen near grazing steepen it: 1e-5 relative.
    np.testing.assert_allclose(sampled.weight, expected.weight, rtol=1e-5, atol=1e-12)
    np.testing.assert_allclose(sampled.pdf, expected.pdf, rtol=1e-6, atol=1e-9)


def test_anisotropic_nodes_and_tangent_node_in_c_render_what_python_does():
    """A Principled metal and specular (Anisotropic 0.8, rotated) with Cycles' default Tangent (Radial Z of
    Generated, a graph link) on the sphere, and an anisotropic Glossy with a constant tangent on the floor: the
    compiled path renders what the reference path does, and the highlight differs from the isotropic one."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.scene import RenderSettings
    scene = lit_scene(LIGHTS["point"])
    sphere = scene.meshes[1]
    lo, hi = sphere.vertices.min(axis=0), sphere.vertices.max(axis=0)
    sphere.attributes["generated"] = ((sphere.vertices - lo) / (hi - lo))[sphere.triangles]
    radial = graph.Link(graph.GraphNode("TANGENT", {"direction": "RADIAL", "axis": "Z", "map": ""}), "Tangent")
    scene.materials[1] = materials.Material(name="brushed", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 0.6, "base_color": (0.9, 0.6, 0.3), "roughness": 0.35,
                                   "anisotropic": 0.8, "anisotropic_rotation": 0.1, "tangent": radial})])
    scene.materials[0] = materials.Material(name="floor", nodes=[
        ("GLOSSY", (0.5, 0.5, 0.5), {"roughness": 0.4, "anisotropy": 0.6, "rotation": 0.2, "tangent": (1.0, 0.0, 0.0)}),
        ("DIFFUSE", (0.3, 0.3, 0.3), {})])
    settings = RenderSettings(width=48, height=32, samples=4)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    scene.materials[1].nodes[0][2]["anisotropic"] = 0.0
    scene.materials[1] = materials.Material(name="round", nodes=scene.materials[1].nodes)
    isotropic = compare_paths(scene, settings)[0]
    assert np.abs(isotropic.image[..., :3] - compiled.image[..., :3]).max() > 0.02
