"""The GGX microfacet BSDF, its albedo tables and the Principled BSDF's layers, against closed forms and
quadrature that does not use the BSDF's own sampling."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import materials
from core.materials import ggx_tables as tables
from core.materials import microfacet as mf
from core.materials import nodes

N_UP = np.array([0.0, 0.0, 1.0])


def hemisphere_grid(k: int = 400):
    """Directions and solid-angle weights of a midpoint grid in (cos theta, phi) over the upper hemisphere."""
    cos_t = (np.arange(k) + 0.5) / k
    phi = (np.arange(2 * k) + 0.5) / (2 * k) * 2.0 * math.pi
    c, p = np.meshgrid(cos_t, phi, indexing="ij")
    s = np.sqrt(1.0 - c * c)
    wi = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1).reshape(-1, 3)
    return wi, np.full(len(wi), (1.0 / k) * (2.0 * math.pi / (2 * k)))


def lobe(n: int, roughness: float, mode: int = mf.FRESNEL_NONE, ior: float = 1.5, f0=(1.0, 1.0, 1.0),
         f90=(1.0, 1.0, 1.0), energy: float = 1.0) -> np.ndarray:
    """n rows of a microfacet closure's parameters."""
    p = nodes.GlossyLobe.params(n, roughness, mode, ior, f0, f90)
    p[:, mf.ENERGY] = energy
    return p


def view(mu: float) -> np.ndarray:
    """The unit direction at cosine mu to N, in the xz plane."""
    return np.array([math.sqrt(1.0 - mu * mu), 0.0, mu])


def albedo_by_quadrature(params_row: np.ndarray, mu: float, k: int = 400):
    """(integral of f cos, integral of pdf) over the hemisphere, for one closure seen from mu."""
    wi, dw = hemisphere_grid(k)
    n = len(wi)
    f_cos, pdf = materials.Microfacet.eval(np.tile(params_row, (n, 1)), np.tile(N_UP, (n, 1)),
                                           np.tile(view(mu), (n, 1)), wi)
    return (f_cos * dw[:, None]).sum(axis=0), (pdf * dw).sum()


@pytest.mark.parametrize("roughness,mu", [(0.3, 0.9), (0.5, 0.5), (0.8, 0.2), (1.0, 1.0)])
def test_table_E_is_the_lobes_albedo_by_quadrature(roughness, mu):
    """E(mu, roughness) read from the table equals the integral of f cos over the hemisphere (F = 1),
    done by a grid in (cos theta, phi) that never calls the sampler; the table's own grid and its
    linear interpolation leave well under 1%."""
    albedo, _ = albedo_by_quadrature(lobe(1, roughness)[0], mu)
    assert tables.lookup_2d(tables.E, roughness, mu) == pytest.approx(albedo[0], rel=0.01)


@pytest.mark.parametrize("roughness,mu", [(0.3, 0.9), (0.6, 0.4), (1.0, 0.7)])
def test_multiscatter_ggx_reflects_all_light_of_a_white_furnace(roughness, mu):
    """With F = 1 and the energy scale 1 / E that Multiscatter GGX applies, a Glossy BSDF reflects all the
    light of a uniform white sky: its albedo is 1 (Kulla and Conty's energy compensation)."""
    b = nodes.ClosureBuilder(N_UP[None, :], view(mu)[None, :], 1)
    nodes.GlossyNode.setup(b, np.ones((1, 3)), nodes.GlossyNode.row({"roughness": roughness}))
    params_row = b.closures.params[0, 0]
    albedo, _ = albedo_by_quadrature(params_row, mu)
    np.testing.assert_allclose(albedo, 1.0, rtol=0.01)


@pytest.mark.parametrize("roughness,mu", [(0.2, 0.8), (0.5, 0.3), (0.9, 0.9)])
def test_sampled_directions_follow_the_pdf_eval_gives(roughness, mu):
    """Visible-normal sampling: the pdf integrates to the share of samples that stay above the surface,
    and every sample's weight is f cos / pdf of its direction."""
    n = 200_000
    rng = np.random.default_rng(1)
    params = lobe(n, roughness)
    s = materials.Microfacet.sample(params, np.tile(N_UP, (n, 1)), np.tile(view(mu), (n, 1)), rng.random((n, 2)))
    _, total_pdf = albedo_by_quadrature(params[0], mu)
    above = (s.pdf > 0).mean()
    assert total_pdf == pytest.approx(above, abs=0.005)
    f_cos, pdf = materials.Microfacet.eval(params, np.tile(N_UP, (n, 1)), np.tile(view(mu), (n, 1)), s.wi)
    np.testing.assert_allclose(s.pdf, pdf)
    seen = s.pdf > 0
    np.testing.assert_allclose(s.weight[seen], f_cos[seen] / pdf[seen][:, None])
    # The mean weight is the albedo, which quadrature gives without the sampler.
    albedo, _ = albedo_by_quadrature(params[0], mu)
    assert s.weight[:, 0].mean() == pytest.approx(albedo[0], rel=0.01)


def test_dielectric_fresnel_meets_its_closed_forms():
    """F(normal incidence) = ((n - 1) / (n + 1))^2, F(grazing) = 1, total internal reflection inside glass
    beyond the critical angle, and Brewster's angle (tan = n) reflects no p-polarized light (F = r_s^2 / 2)."""
    assert mf.fresnel_dielectric(np.array([1.0]), 1.5)[0] == pytest.approx(0.04)
    assert mf.fresnel_dielectric(np.array([0.0]), 1.5)[0] == pytest.approx(1.0)
    critical = math.sqrt(1.0 - (1.0 / 1.5) ** 2)
    assert mf.fresnel_dielectric(np.array([critical * 0.99]), 1.0 / 1.5)[0] == 1.0
    brewster = math.atan(1.5)
    ci, ct = math.cos(brewster), math.cos(math.asin(math.sin(brewster) / 1.5))
    r_s = (ci - 1.5 * ct) / (ci + 1.5 * ct)
    assert mf.fresnel_dielectric(np.array([ci]), 1.5)[0] == pytest.approx(0.5 * r_s * r_s, rel=1e-12)


def test_f82_tint_is_schlick_without_tint_and_dips_by_the_tint_at_82_degrees():
    """F82-tint with tint 1 is Schlick's F0 + (1 - F0)(1 - cos)^5; with tint t it is Schlick's times t at cos = 1/7."""
    f0 = np.array([[0.9, 0.6, 0.3]])
    cos = np.array([0.3])
    schlick = f0 + (1.0 - f0) * (1.0 - cos[:, None]) ** 5
    np.testing.assert_allclose(mf.fresnel_f82(cos, f0, np.zeros((1, 3))), schlick)
    tint = np.array([0.5, 0.8, 1.0])
    at82 = np.array([1.0 / 7.0])
    schlick82 = f0 + (1.0 - f0) * (6.0 / 7.0) ** 5
    np.testing.assert_allclose(mf.fresnel_f82(at82, f0, nodes.f82_tint_B(f0, tint)), schlick82 * tint, rtol=1e-12)


@pytest.mark.parametrize("mu", [0.2, 0.6, 1.0])
def test_a_smooth_principled_surface_reflects_fresnels_share_as_a_mirror(mu):
    """Roughness 0, IOR 1.5, Specular IOR Level 0.5: the specular layer is a mirror reflecting exactly the
    dielectric Fresnel reflectance F(mu), and the diffuse below gets the base colour times what is left
    (1 - the largest channel of the layer's albedo)."""
    b = nodes.ClosureBuilder(N_UP[None, :], view(mu)[None, :], 4)
    nodes.PrincipledNode.setup(b, np.ones((1, 3)), nodes.PrincipledNode.row({"roughness": 0.0}))
    kinds = list(b.closures.kind[0, :b.count])
    assert kinds == [materials.Mirror.kind, materials.Lambert.kind]
    F = mf.fresnel_dielectric(np.array([mu]), 1.5)[0]
    np.testing.assert_allclose(b.closures.weight[0, 0], F, rtol=2e-3)         # energy scale of a mirror: ~1
    s = tables.lookup_3d(tables.SCHLICK_IOR_S, 0.0, mu, math.sqrt(0.5 / 2.5))
    reflect = 0.04 + 0.96 * s
    np.testing.assert_allclose(b.closures.weight[0, 1], 0.8 * (1.0 - reflect), rtol=1e-6)


def test_a_white_metal_reflects_all_light_of_a_white_furnace():
    """Metallic 1, base colour 1, specular tint 1: F82 is 1 everywhere, and Multiscatter GGX keeps all the
    light: albedo 1 at every view angle and roughness."""
    for roughness, mu in ((0.4, 0.7), (0.9, 0.3)):
        b = nodes.ClosureBuilder(N_UP[None, :], view(mu)[None, :], 4)
        nodes.PrincipledNode.setup(b, np.ones((1, 3)),
                                   nodes.PrincipledNode.row({"metallic": 1.0, "base_color": (1, 1, 1),
                                                             "roughness": roughness}))
        assert b.count == 3 and (b.closures.weight[0, 1:] == 0).all()       # metal only: nothing below
        albedo, _ = albedo_by_quadrature(b.closures.params[0, 0], mu)
        np.testing.assert_allclose(b.closures.weight[0, 0] * albedo, 1.0, rtol=0.01)


@pytest.mark.parametrize("roughness", [0.2, 0.5, 1.0])
def test_a_white_dielectric_principled_keeps_nearly_all_light_and_creates_none(roughness):
    """Base colour 1, metallic 0: specular layer plus the diffuse below reflect at most all the light of a
    white furnace and lose little (Cycles' layering is an estimate: within 5%)."""
    mu = 0.6
    b = nodes.ClosureBuilder(N_UP[None, :], view(mu)[None, :], 4)
    nodes.PrincipledNode.setup(b, np.ones((1, 3)), nodes.PrincipledNode.row({"base_color": (1, 1, 1),
                                                                            "roughness": roughness}))
    specular, _ = albedo_by_quadrature(b.closures.params[0, 0], mu)
    total = b.closures.weight[0, 0] * specular + b.closures.weight[0, 1]      # Lambert's albedo is its weight
    assert (total <= 1.0 + 0.01).all() and (total >= 0.95).all()


def test_shader_nodes_in_c_set_up_what_python_does():
    """Principled (with coat, metal, alpha, tint, emission), Glossy, Diffuse and Transparent nodes under a
    lamp and an area light: the compiled path renders what the reference path does, within the stated
    tolerance, and the default surface (Cycles' Principled) too."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.scene import RenderSettings
    scene = lit_scene(LIGHTS["several"])
    scene.materials[0] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.3,
                                   "specular_tint": (0.7, 0.9, 1.0)})])
    scene.materials[1] = materials.Material(name="coated", nodes=[
        ("PRINCIPLED", (0.6, 0.6, 0.6), {"coat": 1.0, "coat_roughness": 0.1, "coat_tint": (0.9, 0.7, 0.6),
                                         "alpha": 0.7, "specular_ior_level": 0.8, "emission": (0.2, 0.1, 0.0),
                                         "base_color": (0.8, 0.3, 0.2), "roughness": 0.35}),
        ("GLOSSY", (0.2, 0.2, 0.36), {"roughness": 0.2, "color": (1.0, 1.0, 1.8)}),
        ("DIFFUSE", (0.1, 0.05, 0.02), {}), ("TRANSPARENT", (0.1, 0.1, 0.1), {})])
    scene.default_material = materials.DEFAULT_SURFACE
    scene.meshes[2].material_indices[:] = 5                  # the box: no material, the default surface
    compiled, reference = compare_paths(scene, RenderSettings(width=48, height=32, samples=4))
    assert_same_render(compiled, reference)
    assert compiled.image[..., :3].max() > 0.05


@pytest.mark.parametrize("n, k", [((2.757, 2.513, 2.231), (3.867, 3.404, 3.009)), ((0.2, 0.9, 1.1), (3.9, 2.4, 2.2)),
                                  ((1.5, 1.5, 1.5), (0.0, 0.0, 0.0))])
def test_conductor_fresnel_is_the_normal_incidence_closed_form_and_the_dielectric_one_without_extinction(n, k):
    n, k = np.array(n), np.array(k)
    np.testing.assert_allclose(nodes.fresnel_conductor(1.0, n, k), ((n - 1) ** 2 + k ** 2) / ((n + 1) ** 2 + k ** 2),
                               rtol=1e-12)
    if not k.any():                         # k = 0: Fresnel's dielectric equations at 60 degrees
        cos_i = 0.5
        cos_t = math.sqrt(1.0 - (1.0 - cos_i ** 2) / 1.5 ** 2)
        rs = ((cos_i - 1.5 * cos_t) / (cos_i + 1.5 * cos_t)) ** 2
        rp = ((1.5 * cos_i - cos_t) / (1.5 * cos_i + cos_t)) ** 2
        np.testing.assert_allclose(nodes.fresnel_conductor(cos_i, n, k), 0.5 * (rs + rp), rtol=1e-12)
    assert (nodes.fresnel_conductor(0.0, n, k) == pytest.approx(1.0))    # grazing: all reflected


def test_a_physical_conductor_as_f82_matches_its_fresnel_at_0_and_82_degrees():
    """The Metallic BSDF's Physical Conductor read as an F82-tint curve: that curve passes through the complex
    Fresnel at normal incidence and at cos = 1/7 (gold-like n, k)."""
    n, k = np.array([0.18, 0.42, 1.37]), np.array([3.42, 2.35, 1.77])
    f0, tint = nodes.conductor_as_f82(n, k)
    B = nodes.f82_tint_B(f0[None, :], tint[None, :])
    for cos_i in (1.0, 1.0 / 7.0):
        curve = mf.fresnel_f82(np.array([cos_i]), f0[None, :], B)
        np.testing.assert_allclose(curve[0], nodes.fresnel_conductor(cos_i, n, k), rtol=1e-9)


def test_a_metallic_bsdf_with_beckmann_sets_up_a_beckmann_metal_that_renders_alike_on_both_kernels():
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.scene import RenderSettings
    row = nodes.PrincipledNode.row({"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.4,
                                    "multiscatter": 0.0, "metal_distribution": nodes.BECKMANN})
    b = nodes.ClosureBuilder(N_UP[None, :], view(0.7)[None, :], 4)
    nodes.PrincipledNode.setup(b, np.ones((1, 3)), row)
    assert b.closures.kind[0, 0] == nodes.Beckmann.kind
    scene = lit_scene(LIGHTS["several"])
    scene.materials[0] = materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.3,
                                   "specular_tint": (0.7, 0.9, 1.0), "multiscatter": 0.0,
                                   "metal_distribution": nodes.BECKMANN})])
    compiled, reference = compare_paths(scene, RenderSettings(width=24, height=16, samples=4))
    assert_same_render(compiled, reference)
    assert compiled.image[..., :3].max() > 0.05
