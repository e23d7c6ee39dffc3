"""Thin-film iridescence (the Principled BSDF's Thin Film): Belcour and Barla's series against the exact Airy sum
at one wavelength and integrated over the spectrum, its limits, the Principled's setup, the table's generator, and
the C twin."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

from core import materials
from core.materials import microfacet as mf
from core.materials import nodes
from core.materials import thin_film as tf

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
import thin_film_table  # noqa: E402

COSINES = np.linspace(0.02, 1.0, 25)


def exact_airy(cos_i: float, lam: np.ndarray, thickness: float, film: float, substrate: float) -> np.ndarray:
    """The film's unpolarised reflectance (len(lam),) at wavelengths lam nm, from the amplitudes (the closed form
    |(r12 + r23 e^(i phi)) / (1 + r12 r23 e^(i phi))|^2, written here independently of thin_film.py)."""
    sin_1 = math.sqrt(1.0 - cos_i * cos_i)
    cos_2 = math.sqrt(1.0 - (sin_1 / film) ** 2)
    cos_3 = math.sqrt(1.0 - (sin_1 / substrate) ** 2)
    phase = np.exp(1j * 2.0 * math.pi * 2.0 * film * thickness * cos_2 / lam)
    total = np.zeros(len(lam))
    for r12, r23 in (((cos_i - film * cos_2) / (cos_i + film * cos_2),
                      (film * cos_2 - substrate * cos_3) / (film * cos_2 + substrate * cos_3)),
                     ((film * cos_i - cos_2) / (film * cos_i + cos_2),
                      (substrate * cos_2 - film * cos_3) / (substrate * cos_2 + film * cos_3))):
        total += 0.5 * np.abs((r12 + r23 * phase) / (1.0 + r12 * r23 * phase)) ** 2
    return total


def film_rows(n: int, thickness: float, film: float, substrate: float = 1.5):
    """(eta, thickness, film_ior) arrays of n identical films."""
    return np.full(n, substrate), np.full(n, thickness), np.full(n, film)


@pytest.mark.parametrize("film,thickness,atol", [(1.33, 350.0, 5e-5), (1.8, 250.0, 1e-4), (2.4, 600.0, 2e-3)])
def test_series_at_one_wavelength_is_the_airy_sum(monkeypatch, film, thickness, atol):
    """With sensitivities that see one wavelength per channel, the series to m = 3 is the exact Airy reflectance
    to the truncation's error, about 2 (R12 R23)^2: 3e-5 for a soap film, 1.6e-3 for a film of index 2.4 over glass)."""
    lam = np.array([460.0, 540.0, 630.0])
    monkeypatch.setattr(tf, "sensitivity", lambda opd: np.cos(2.0 * math.pi * np.asarray(opd)[:, None] / lam))
    F = tf.iridescence(COSINES, *film_rows(len(COSINES), thickness, film))
    expected = np.array([exact_airy(c, lam, thickness, film, 1.5) for c in COSINES])
    np.testing.assert_allclose(F, expected, rtol=0, atol=atol)


@pytest.mark.parametrize("film,thickness", [(1.33, 120.0), (1.33, 400.0), (1.6, 700.0), (2.0, 300.0)])
def test_spectrally_integrated_airy_sum(film, thickness):
    """The film's RGB reflectance is the exact Airy reflectance averaged over the spectrum with each channel's
    Rec.709 matching function (integrated here, no table): within 2e-3 (the table's linear interpolation)."""
    lam, cbar = thin_film_table.matching_functions(0.5)
    F = tf.iridescence(COSINES, *film_rows(len(COSINES), thickness, film))
    expected = np.array([exact_airy(c, lam, thickness, film, 1.5) @ cbar / cbar.sum(axis=0) for c in COSINES])
    np.testing.assert_allclose(F, np.clip(expected, 0.0, 1.0), rtol=0, atol=2e-3)
    # The film colours: at normal incidence its channels differ by more than twice the tolerance.
    assert np.ptp(F[-1]) > 0.005


def test_limits_give_the_plain_fresnel_and_energy_stays_in_0_1():
    """No film (thickness 0) or a film of the ambient's index: the substrate's own Fresnel; a film under 1 nm
    fades to it; any film reflects 0..1 and everything under total internal reflection."""
    n = len(COSINES)
    plain = mf.fresnel_dielectric(COSINES, 1.5)[:, None]
    np.testing.assert_allclose(tf.iridescence(COSINES, *film_rows(n, 0.0, 1.33)), np.repeat(plain, 3, 1), atol=1e-15)
    np.testing.assert_allclose(tf.iridescence(COSINES, *film_rows(n, 500.0, 1.0)), np.repeat(plain, 3, 1), atol=1e-15)
    thin = tf.iridescence(COSINES, *film_rows(n, 0.5, 1.8))
    assert np.abs(thin - plain).max() < 0.02
    rng = np.random.default_rng(3)
    m = 20000
    F = tf.iridescence(rng.random(m), rng.uniform(0.3, 3.0, m), rng.uniform(0.0, 3000.0, m), rng.uniform(0.5, 3.0, m))
    assert np.isfinite(F).all() and F.min() >= 0.0 and F.max() <= 1.0
    # Leaving glass (eta 1 / 1.5) past the critical angle: everything is reflected.
    grazing = np.array([0.3])
    np.testing.assert_array_equal(tf.iridescence(grazing, *film_rows(1, 400.0, 1.33 / 1.5, 1.0 / 1.5)), 1.0)


def test_principled_fresnel_scales_towards_f0_as_specular_tint():
    """Untinted (f0 = F0(eta)) the Principled's Fresnel is the film's; a tint scales it near F0, not near 1."""
    n = len(COSINES)
    eta, thickness, film = film_rows(n, 400.0, 1.33)
    F0 = mf.F0_from_ior(1.5)
    plain = tf.iridescence(COSINES, eta, thickness, film)
    np.testing.assert_allclose(tf.fresnel(COSINES, eta, np.full((n, 3), F0), thickness, film), plain, atol=1e-15)
    tinted = tf.fresnel(COSINES, eta, np.tile([F0, F0 * 0.5, 0.0], (n, 1)), thickness, film)
    np.testing.assert_allclose(tinted[:, 0], plain[:, 0], atol=1e-15)
    assert (tinted[:, 1] <= plain[:, 1] + 1e-15).all() and (tinted[:, 2] <= plain[:, 2] + 1e-15).all()
    assert tinted[0, 2] > 0.5 * plain[0, 2]        # grazing: the film's reflectance near 1 keeps most of it


def gulbrandsen(f0: np.ndarray, f82: np.ndarray) -> tuple:
    """The metal's (n, k) (3,) from its reflectances at 0 and 82 degrees (Gulbrandsen 2014, written out here)."""
    r = np.minimum(f0, 0.999)
    n_max = (1.0 + np.sqrt(r)) / (1.0 - np.sqrt(r))
    n = f82 * (1.0 - r) / (1.0 + r) + (1.0 - f82) * n_max
    k = np.sqrt(np.maximum((r * (n + 1.0) ** 2 - (n - 1.0) ** 2) / (1.0 - r), 0.0))
    return n, k


@pytest.mark.parametrize("film,thickness,atol", [(1.33, 400.0, 2e-4), (1.8, 250.0, 2e-3)])
def test_metal_series_at_normal_incidence_is_the_airy_sum(monkeypatch, film, thickness, atol):
    """A film on metal at normal incidence (where Cycles' F82 reflectance of the metal is the exact one): with
    one wavelength per channel the series is the Airy sum with the metal's complex amplitude (n + ik from F0 and
    F82), to its truncation (larger than a dielectric's: the metal reflects most of the light back into the film)."""
    lam = np.array([460.0, 540.0, 630.0])
    monkeypatch.setattr(tf, "sensitivity", lambda opd: np.cos(2.0 * math.pi * np.asarray(opd)[:, None] / lam))
    monkeypatch.setattr(tf, "sensitivity_imaginary",
                        lambda opd: -np.sin(2.0 * math.pi * np.asarray(opd)[:, None] / lam))
    f0, b = np.array([[0.9, 0.6, 0.3]]), np.array([[0.1, 0.2, 0.0]])
    F = tf.metal(np.array([1.0]), f0, b, np.array([thickness]), np.array([film]))[0]
    n, k = gulbrandsen(f0[0], mf.fresnel_f82(np.array([1.0 / 7.0]), f0, b)[0])
    r12, r23 = (1.0 - film) / (1.0 + film), (film - (n + 1j * k)) / (film + (n + 1j * k))
    phase = np.exp(1j * 2.0 * math.pi * 2.0 * film * thickness / lam)
    np.testing.assert_allclose(F, np.abs((r12 + r23 * phase) / (1.0 + r12 * r23 * phase)) ** 2, rtol=0, atol=atol)


def test_metal_limits_give_its_f82_curve_and_energy_stays_in_0_1():
    """No film, or a film of the ambient's index, on metal: the metal's own F82-tint curve; any film 0..1."""
    m = len(COSINES)
    f0, b = np.tile([0.9, 0.6, 0.3], (m, 1)), np.tile([0.1, 0.2, 0.0], (m, 1))
    plain = mf.fresnel_f82(COSINES, f0, b)
    np.testing.assert_allclose(tf.metal(COSINES, f0, b, np.zeros(m), np.full(m, 1.5)), plain, atol=1e-14)
    np.testing.assert_allclose(tf.metal(COSINES, f0, b, np.full(m, 400.0), np.ones(m)), plain, atol=1e-14)
    rng = np.random.default_rng(4)
    n = 20000
    F = tf.metal(rng.random(n), rng.random((n, 3)), rng.random((n, 3)) * 0.5, rng.uniform(0.0, 3000.0, n),
                 rng.uniform(0.5, 3.0, n))
    assert np.isfinite(F).all() and F.min() >= 0.0 and F.max() <= 1.0


def test_table_is_what_the_generator_computes():
    """core/materials/thin_film_table.h holds tools/thin_film_table.py's sensitivities (1 at OPD 0), real and
    imaginary parts."""
    opd = np.linspace(0.0, tf.OPD_MAX, tf.SENSITIVITY.shape[1])
    np.testing.assert_allclose(tf.SENSITIVITY.T, thin_film_table.sensitivity(opd), rtol=0, atol=1e-8)
    np.testing.assert_allclose(tf.SENSITIVITY_IM.T, thin_film_table.sensitivity_imaginary(opd), rtol=0, atol=1e-8)
    np.testing.assert_array_equal(tf.SENSITIVITY[:, 0], 1.0)


def principled_closures(inputs: dict, backfacing: bool = False):
    """The closures a Principled node with `inputs` sets up at 5 hits seen from different angles."""
    N = np.tile([0.0, 0.0, 1.0], (5, 1))
    wo = np.array([[math.sin(a), 0.0, math.cos(a)] for a in np.linspace(0.0, 1.4, 5)])
    node = nodes.PrincipledNode
    b = nodes.ClosureBuilder(N, wo, node.slots, backfacing=np.full(5, backfacing))
    node.setup(b, np.ones((5, 3)), node.row(inputs))
    return b.closures


def test_zero_thickness_sets_up_what_it_did_without_a_film():
    """Thickness 0 (or at the cutoff): the film's index changes nothing, no closure gets the thin-film Fresnel."""
    for extra in ({"transmission": 0.0}, {"transmission": 1.0, "roughness": 0.3}):
        base = principled_closures(dict(extra))
        for thickness, film in ((0.0, 2.0), (0.1, 1.7)):
            other = principled_closures(dict(extra, thin_film_thickness=thickness, thin_film_ior=film))
            for a, b in zip(base, other):
                np.testing.assert_array_equal(a, b)


def test_film_iridesces_metal_specular_and_glass():
    """Thickness 400 nm: the metal, the specular layer and the glass get the thin-film Fresnel (their indices: the
    film's, over the glass's when leaving it); at IOR 1 the specular layer is set up for the film."""
    c = principled_closures({"thin_film_thickness": 400.0, "thin_film_ior": 1.33, "metallic": 0.5})
    modes = c.params[:, :, mf.FRESNEL][c.kind >= 0]
    assert mf.FRESNEL_THIN_FILM in modes and mf.FRESNEL_THIN_FILM_F82 in modes and mf.FRESNEL_F82_TINT not in modes
    c = principled_closures({"thin_film_thickness": 400.0, "thin_film_ior": 1.33, "transmission": 1.0,
                             "roughness": 0.2}, backfacing=True)
    glass = c.params[c.kind == materials.RoughGlass.kind]
    np.testing.assert_allclose(glass[:, mf.FILM_IOR], 1.33 / 1.5)
    np.testing.assert_allclose(glass[:, mf.IOR], 1.0 / 1.5)
    assert (glass[:, mf.FRESNEL] == mf.FRESNEL_THIN_FILM).all()
    plain = principled_closures({"ior": 1.0})
    assert not (plain.params[:, :, mf.FRESNEL][plain.kind >= 0] == mf.FRESNEL_SCHLICK_IOR).any()
    with_film = principled_closures({"ior": 1.0, "thin_film_thickness": 300.0})
    assert (with_film.params[:, :, mf.FRESNEL][with_film.kind >= 0] == mf.FRESNEL_THIN_FILM).any()


def random_closures(kind: int, n: int, rng):
    """n closures of `kind` with the thin-film Fresnel and random films, normals and directions."""
    weight = rng.random((n, 3))
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo *= np.where(np.einsum("ij,ij->i", wo, N) < 0, -1.0, 1.0)[:, None]
    params = np.zeros((n, materials.PARAMS))
    params[:, mf.ALPHA] = rng.uniform(0.05, 1.0, n)
    params[:, mf.FRESNEL] = mf.FRESNEL_THIN_FILM
    if kind == materials.Microfacet.kind:       # half of them metal (F0 the colour, F90's slots its F82 b)
        params[:, mf.FRESNEL] = np.where(rng.random(n) < 0.5, mf.FRESNEL_THIN_FILM_F82, mf.FRESNEL_THIN_FILM)
    ior = rng.uniform(1.1, 2.2, n)
    leaving = rng.random(n) < 0.3
    params[:, mf.IOR] = np.where(leaving, 1.0 / ior, ior)
    params[:, mf.F0:mf.F0 + 3] = mf.F0_from_ior(ior)[:, None] * rng.uniform(0.3, 1.0, (n, 3))
    params[:, mf.F90:mf.F90 + 3] = 1.0
    metal = params[:, mf.FRESNEL] == mf.FRESNEL_THIN_FILM_F82
    params[metal, mf.IOR] = 1.0
    params[metal, mf.F0:mf.F0 + 3] = rng.random((metal.sum(), 3))
    params[metal, mf.F90:mf.F90 + 3] = rng.random((metal.sum(), 3)) * 0.4
    params[:, mf.ENERGY] = 1.0
    params[:, 10:16] = rng.random((n, 6)) if kind != materials.Microfacet.kind else 0.0
    params[:, mf.THICKNESS] = rng.choice([0.5, 150.0, 400.0, 900.0, 4000.0], n)
    film = rng.uniform(1.0, 2.0, n)
    params[:, mf.FILM_IOR] = np.where(leaving, film / ior, film)
    return weight, N, params, wo, wi, rng.random((n, 2))


@pytest.mark.parametrize("kind", ["Microfacet", "RoughGlass", "Glass"])
def test_c_evaluates_and_samples_thin_film_closures_as_python_does(kind):
    """f cos, pdf and samples of microfacet (dielectric and metal), rough and smooth glass closures with the
    thin-film Fresnel, in C and in Python."""
    from core.native import library
    if not library.available():
        pytest.skip(library.unavailable_reason())
    rng = np.random.default_rng(5)
    n = 3000
    k = getattr(materials, kind).kind
    weight, N, params, wo, wi, u = random_closures(k, n, rng)
    kinds = np.full(n, k, np.int32)
    f_cos, pdf, sampled = materials.compiled_bsdf(kinds, weight, N, params, wo, wi, u)
    closures = materials.Closures(kinds[:, None], weight[:, None, :], np.abs(weight.mean(axis=1))[:, None],
                                  N[:, None, :], params[:, None, :])
    expected_f, expected_pdf = materials.eval_closures(closures, wo, wi)
    expected = materials.sample_closures(closures, wo, u, np.full(n, 0.5))
    # float64 rounding: the series' cancelling terms leave 1e-12 relative where the film reflects little
    np.testing.assert_allclose(f_cos, expected_f, rtol=1e-10, atol=1e-300)
    np.testing.assert_allclose(pdf, expected_pdf, rtol=1e-10, atol=1e-300)
    assert (sampled.pdf > 0).mean() > 0.3
    np.testing.assert_allclose(sampled.wi, expected.wi, rtol=0, atol=1e-6)
    # The sampled direction carries a float32 azimuth cosine (as test_compiled.py's); the film's Fresnel turns
    # faster with the angle than the plain curve, so the weight follows to 1e-5 relative, not 1e-6.
    np.testing.assert_allclose(sampled.weight, expected.weight, rtol=5e-5, atol=1e-12)


def test_thin_film_principled_renders_the_same_compiled_and_in_python():
    """A thin-film Principled sphere (half metal, half specular; the film's thickness 200 to 800 nm and its index
    from node graphs of the object's coordinates) and a thin-film rough glass floor and box, path traced: the
    compiled path renders what the reference does, and the film changes the image."""
    from test_compiled import LIGHTS, assert_same_render, compare_paths, lit_scene
    from core.materials.graph import GraphNode, Link
    from core.native import library
    from core.scene import RenderSettings
    if not library.available():
        pytest.skip(library.unavailable_reason())
    scene = lit_scene(LIGHTS["point"])
    coords = GraphNode("TEXCOORD", {}, {})
    x = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Object")}), "X")
    z = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "Object")}), "Z")
    thickness = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": z, "1": 375.0, "2": 200.0}), "Value")
    film_ior = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": x, "1": 0.3, "2": 1.5}), "Value")
    scene.materials[1] = materials.Material(name="film", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"base_color": (0.8, 0.5, 0.2), "metallic": 0.5, "roughness": 0.15,
                                   "thin_film_thickness": thickness, "thin_film_ior": film_ior})])
    scene.materials[0] = materials.Material(name="coated glass", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"transmission": 1.0, "roughness": 0.3, "thin_film_thickness": 300.0,
                                   "thin_film_ior": 1.8})])
    settings = RenderSettings(width=40, height=30, samples=4, integrator="path", max_bounces=4)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    for m in (0, 1):
        scene.materials[m].nodes[0][2]["thin_film_thickness"] = 0.0
        scene.materials[m].nodes[0][2]["thin_film_ior"] = 1.33
        scene.materials[m] = materials.Material(name=f"plain{m}", nodes=scene.materials[m].nodes)
    plain = compare_paths(scene, settings)[0]
    assert np.abs(plain.image[..., :3] - compiled.image[..., :3]).max() > 0.02
