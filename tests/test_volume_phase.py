"""The Phase menu's phase functions (core/volumes/phase.py, phase.c; issues 32 and 35): Henyey-Greenstein,
Fournier-Forand, Draine, Rayleigh and Mie (Jendersie and d'Eon's HG + Draine fit) each integrate to 1 over the
sphere, sample their own density (a chi-square test of sampled angles against the density's integral over bins, and
the pdf of each sample its density there), have the mean cosines of their closed forms, reduce to each other where
they should, agree between the Python reference and C for the same numbers, and travel with their medium through
both kernels to the same pixels (the Cycles comparison: tests/test_blender_volumes.py)."""
from __future__ import annotations

import numpy as np
import pytest

from core.volumes import phase as phase_
from core.volumes.media import Coefficients, Media, VolumeScatter, medium_of
from core.volumes.phase import Draine, FournierForand, HenyeyGreenstein, Mie, Phases, Rayleigh

# One of each, and the corners of their parameters: FF of the node's defaults and of a strong back-scatterer, Draine
# general, nearly isotropic (the cube-root form) and backwards, Mie in each of the fit's four ranges of diameter.
PHASES = {
    "hg": HenyeyGreenstein(0.6),
    "ff": FournierForand.of(0.1, 1.33),
    "ff_back": FournierForand.of(0.3, 1.1),
    "draine": Draine(0.4, 0.8),
    "draine_small_g": Draine(0.005, 2.0),
    "draine_back": Draine(-0.6, 0.3),
    "rayleigh": Rayleigh(),
    "mie_tiny": Mie.of(0.05),
    "mie_small": Mie.of(0.8),
    "mie_mid": Mie.of(3.0),
    "mie_large": Mie.of(20.0),
}


def sphere_integral(phase, f=lambda x: 1.0) -> float:
    """2 pi times the integral over cos theta in [-1, 1] of p f (phase.cos_quadrature: fine at a forward pole)."""
    x, w = phase_.cos_quadrature()
    return float(2.0 * np.pi * np.sum(w * phase.eval_cos(x) * f(x)))


def units(n: int, rng) -> np.ndarray:
    """n uniformly random unit vectors (n, 3)."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


@pytest.mark.parametrize("name", list(PHASES))
def test_each_phase_function_integrates_to_one_over_the_sphere(name):
    """The integral of p over the sphere is 1 (to 1e-6; FF's pole at theta = 0, integrable, to 1e-4)."""
    assert sphere_integral(PHASES[name]) == pytest.approx(1.0, abs=1e-4 if name.startswith("ff") else 1e-6)


@pytest.mark.parametrize("name", list(PHASES))
def test_sampled_directions_follow_the_phase_function_and_their_pdf_is_its_value(name):
    """100000 directions sampled for random viewers (fixed seed): their angles to -wo fall in 40 bins of cos theta as
    the density's integral over each bin says (chi-square below its 99.9% point for 39 degrees of freedom, 72.1),
    they are unit, and each one's pdf is p(wo, wi) (eval / pdf = 1, to 1e-7: the cosine recomputed from the
    vectors loses digits at FF's pole)."""
    phase = PHASES[name]
    rng = np.random.default_rng(7)
    n = 100_000
    wo, u = units(n, rng), rng.random((n, 2))
    rows = Phases(np.full(n, phase.kind), phase.parameters(n))
    sample = rows.sample(wo, u)
    np.testing.assert_allclose(np.linalg.norm(sample.wi, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(sample.pdf, rows.eval(wo, sample.wi), rtol=1e-7)   # (cos theta from the vectors)
    cos_theta = np.einsum("ij,ij->i", -wo, sample.wi)
    edges = np.linspace(-1.0, 1.0, 41)
    t, w = np.polynomial.legendre.leggauss(64)             # (each bin its own rule; the last, at FF's pole, the rest)
    share = np.array([np.pi * (b - a) * np.sum(w * phase.eval_cos(a + (b - a) * (t + 1.0) / 2.0))
                      for a, b in zip(edges[:-2], edges[1:-1])])
    expected = n * np.append(share, sphere_integral(phase) - share.sum())
    observed = np.histogram(cos_theta, edges)[0]
    keep = expected > 5.0
    chi2 = float(np.sum((observed[keep] - expected[keep]) ** 2 / expected[keep]))
    assert chi2 < 72.1, chi2


@pytest.mark.parametrize("name", list(PHASES))
def test_mean_cosines_are_the_closed_forms(name):
    """<cos theta> by quadrature is Phase.mean_cosine: g for HG, 0 for Rayleigh, Draine's g (1 + alpha (3 + 2 g^2) /
    5) / (1 + alpha (1 + 2 g^2) / 3), Mie's (1 - w) g_HG + w <Draine>; FF's has none (its quadrature); and the
    mean of 100000 sampled cosines is within 4 standard errors of it."""
    phase = PHASES[name]
    mean = sphere_integral(phase, lambda x: x)
    assert float(phase.mean_cosine(1)[0]) == pytest.approx(mean, abs=1e-4 if name.startswith("ff") else 1e-8)
    if name == "rayleigh":
        assert mean == pytest.approx(0.0, abs=1e-10)
    if name == "hg":
        assert mean == pytest.approx(0.6, abs=1e-8)
    cos_theta = phase.sample_cos(np.random.default_rng(11).random(100_000))
    assert abs(cos_theta.mean() - mean) < 4.0 * cos_theta.std() / np.sqrt(len(cos_theta))


def test_draine_reduces_to_henyey_greenstein_and_rayleigh_and_mie_to_its_lobes():
    """Draine with alpha 0 is HG of its g, with g 0 and alpha 1 Rayleigh (Cycles' special cases, and the formula's
    own limits); Mie is (1 - w) HG + w Draine of its fitted numbers, which are Jendersie and d'Eon's at d = 20 um."""
    x = np.linspace(-0.99, 0.99, 101)
    np.testing.assert_allclose(Draine(0.5, 0.0).eval_cos(x), HenyeyGreenstein(0.5).eval_cos(x), rtol=1e-12)
    np.testing.assert_allclose(Draine(0.5, 2e-3).eval_cos(x), HenyeyGreenstein(0.5).eval_cos(x), rtol=2e-3)
    np.testing.assert_allclose(Draine(0.0, 1.0).eval_cos(x), Rayleigh().eval_cos(x), rtol=1e-12)
    np.testing.assert_allclose(Draine(2e-3, 1.0).eval_cos(x), Rayleigh().eval_cos(x), rtol=1e-2)
    g_hg, g_d, alpha, w = phase_.mie_parameters(20.0)
    np.testing.assert_allclose([g_hg, g_d, alpha, w], [0.99461, 0.593791, 27.1137, 0.498159], rtol=1e-5)
    mie = Mie.of(20.0)
    np.testing.assert_allclose(mie.eval_cos(x), (1.0 - w) * HenyeyGreenstein(g_hg).eval_cos(x)
                               + w * Draine(g_d, alpha).eval_cos(x), rtol=1e-12)
    # Rayleigh's sampler inverts its cdf P(cos theta < c) = (3 c + c^3 + 4) / 8 exactly.
    u = np.linspace(0.0, 1.0, 11)
    c = Rayleigh().sample_cos(u)
    np.testing.assert_allclose((3.0 * c + c ** 3 + 4.0) / 8.0, u, atol=1e-12)


@pytest.mark.parametrize("name", list(PHASES))
def test_python_and_c_agree_on_eval_and_sample_for_the_same_numbers(name):
    """phase.c's phase_eval and phase_sample (primer_phase_rows) give the Python reference's values at 2000 random
    (wo, wi, u): p to 1e-10 relative (FF's powers), sampled directions to 1e-8, their pdfs to 1e-8 relative
    (Draine's closed-form inverse loses digits to cancellation near its poles)."""
    phase = PHASES[name]
    rng = np.random.default_rng(5)
    n = 2000
    wo, wi, u = units(n, rng), units(n, rng), rng.random((n, 2))
    rows = Phases(np.full(n, phase.kind), phase.parameters(n))
    c_eval, c_sample = phase_.compiled_rows(rows, wo, wi, u)
    py_sample = rows.sample(wo, u)
    np.testing.assert_allclose(c_eval, rows.eval(wo, wi), rtol=1e-10)
    np.testing.assert_allclose(c_sample.wi, py_sample.wi, atol=1e-8)
    np.testing.assert_allclose(c_sample.pdf, py_sample.pdf, rtol=1e-8)


def test_a_node_sets_up_its_phase_menu_and_mixed_media_scatter_by_the_larger_share():
    """A Volume Scatter's Phase menu and inputs become its medium's phase (kind, numbers; g its mean cosine), clamped
    as Cycles clamps them; two HG closures mix into HG of the weighted g, HG and Rayleigh into the phase function of
    the one that scatters more; a ray in both an HG and a Rayleigh medium scatters with the larger one's."""
    c = VolumeScatter.coefficients(1.0, {"phase": "RAYLEIGH", "density": 2.0})
    assert c.phase == phase_.PHASE["RAYLEIGH"] and c.g == 0.0
    c = VolumeScatter.coefficients(1.0, {"phase": "DRAINE", "anisotropy": 1.5, "alpha": 0.7})
    assert c.phase == phase_.PHASE["DRAINE"] and c.parameters[:2] == (pytest.approx(0.999), 0.7)
    c = VolumeScatter.coefficients(1.0, {"phase": "FOURNIER_FORAND", "ior": 0.5, "backscatter": 0.9})
    assert c.parameters[0] == pytest.approx(1.001)        # (IOR at least 1 + 1e-3, B at most 1/2 - 1e-3)
    np.testing.assert_allclose(c.parameters[:3], FournierForand.of(0.499, 1.001).parameters(1)[0, :3])
    c = VolumeScatter.coefficients(1.0, {"phase": "MIE", "diameter": 20.0})
    assert c.g == pytest.approx(float(Mie.of(20.0).mean_cosine(1)[0]))
    hg = medium_of([("SCATTER", 1.0, {"anisotropy": 0.4, "density": 1.0}),
                    ("SCATTER", 1.0, {"anisotropy": -0.2, "density": 3.0})])
    assert hg.phase == phase_.PHASE["HENYEY_GREENSTEIN"] and hg.g == pytest.approx(-0.05)
    mixed = medium_of([("SCATTER", 1.0, {"anisotropy": 0.4, "density": 1.0}),
                       ("SCATTER", 1.0, {"phase": "RAYLEIGH", "density": 3.0})])
    assert mixed.phase == phase_.PHASE["RAYLEIGH"] and mixed.g == pytest.approx(0.1)
    media = Media([medium_of([("SCATTER", 1.0, {"anisotropy": 0.4, "density": 1.0})]),
                   medium_of([("SCATTER", 1.0, {"phase": "RAYLEIGH", "density": 0.5})])], [False, False])
    stretch = media.along(np.array([[1, 0], [1, 1], [0, 1], [2, 1]], np.int16))
    assert list(stretch.phase) == [0, 0, phase_.PHASE["RAYLEIGH"], 0]
    np.testing.assert_allclose(stretch.parameters[:, 0], [0.4, 0.4, 0.0, 0.4])
    assert isinstance(Coefficients(np.zeros(3), np.zeros(3), np.zeros(3)).parameters, tuple)


@pytest.mark.parametrize("phase", ["FOURNIER_FORAND", "DRAINE", "RAYLEIGH", "MIE"])
def test_both_kernels_scatter_with_a_media_phase_function_to_the_same_pixels(phase):
    """A Volume Scatter box of each phase function in a world fog (HG, or Mie around the FF and Rayleigh boxes: the
    world's own phase function), under an area and a point lamp: light samples weigh by its p, phase rays sample
    it, in the Python reference and the compiled kernel alike (a few float32 ulps per pixel, as
    tests/test_volumes_compiled.py holds the twins), the same shadow rays traced."""
    from core.lights import World
    from core.render import render
    from core.scene import RenderSettings
    from test_volumes_compiled import assert_same_pixels, looking, room, smoke
    scene = room(looking())
    smoke(scene, phase=phase, backscatter=0.2, ior=1.2, alpha=0.6, anisotropy=0.5, diameter=3.0, density=1.5)
    world_phase = "MIE" if phase in ("FOURNIER_FORAND", "RAYLEIGH") else "HENYEY_GREENSTEIN"
    scene.world = World(color=np.zeros(3), volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": 0.02,
                                                                      "anisotropy": 0.3, "phase": world_phase,
                                                                      "diameter": 8.0})])
    settings = {"width": 12, "height": 9, "samples": 3, "integrator": "path", "max_bounces": 4}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    assert_same_pixels(reference.image, compiled.image)


# Heterogeneous media (core/volumes/field.py): each phase function with its inputs fed by links, set up per point.
# (Mie in each of its fit's four ranges of diameter: phase.c's mie_fit against the Python's closed form)
VARYING_INPUTS = {"FOURNIER_FORAND": {"ior": 1.2, "backscatter": 0.2}, "DRAINE": {"anisotropy": 0.4, "alpha": 0.8},
                  "RAYLEIGH": {}, "MIE": {"diameter": 3.0}, "MIE_TINY": {"diameter": 0.05},
                  "MIE_SMALL": {"diameter": 0.8}, "MIE_LARGE": {"diameter": 20.0}}


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("case", list(VARYING_INPUTS))
def test_a_heterogeneous_slab_under_a_sun_scatters_by_its_phase_functions_value(case, kernels):
    """A scattering slab (sigma_s per channel, 0.6 deep) whose density and phase inputs are graphs of constant value
    (so it is marched as a heterogeneous medium, its phase set up at each scattering point) under a sun at 50
    degrees, seen from straight above: sigma_s p(-sin 50) E (1 - exp(-sigma d k)) / (sigma k), k = 1 + 1 / sin 50,
    p the phase function's closed form (phase.of_node of the constants); within 1e-3 at 64 samples (2e-5 at 256)."""
    from test_volumes_heterogeneous import camera_above, height, slab
    from core.geometry import primitives
    from core.lights import SunLight
    from core.render import render
    from core.scene import RenderSettings, Scene
    scene = Scene(camera=camera_above())
    sigma, d, E, e = np.array([0.5, 1.0, 2.0]), 0.6, 3.0, np.radians(50.0)
    phase = case.split("_")[0] if case.startswith("MIE") else case
    linked = {key: height(0.0, value) for key, value in VARYING_INPUTS[case].items()}
    scene.materials.append(slab("SCATTER", color=sigma, density=height(0.0, 1.0), phase=phase, **linked))
    scene.add_mesh(primitives.box((40.0, 40.0, d), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.lights.append(SunLight(direction=-np.array([np.cos(e), 0.0, np.sin(e)]), strength=E))
    k = 1.0 + 1.0 / np.sin(e)
    p = phase_.of_node(phase, VARYING_INPUTS[case]).eval_cos(np.array([-np.sin(e)]))[0]
    expected = sigma * p * E * (1.0 - np.exp(-sigma * d * k)) / (sigma * k)
    result = render(scene, RenderSettings(width=4, height=4, samples=64, integrator="path", kernels=kernels))
    assert (result.stats.kernels == "compiled") == (kernels == "compiled")
    np.testing.assert_allclose(result.image[..., :3].mean(axis=(0, 1)), expected, rtol=1e-3)


def test_phase_inputs_fed_by_links_are_set_up_at_each_point_and_closures_mix_by_their_scattering():
    """Field.phase_at: a Draine closure whose anisotropy and alpha follow the point's height and an FF one whose IOR
    does, under a Mix Shader's factor of height: each closure's phase function at each point, its numbers
    phase.parameters_at of its inputs there (clamped as Cycles), its weight its sigma_s there. Stretch.phases_at
    mixes them as Cycles keeps its closures (phase.PhaseMix): p the weight-averaged sum, its samples picking each
    lobe in proportion to its weight (each lobe's pdf returned); Mie's diameter set up per point too."""
    from test_volumes_heterogeneous import height
    from core.materials import Material
    from core.volumes.field import Field
    z = np.array([-0.3, 0.1, 0.45, 0.8, 1.6])
    P = np.stack([np.zeros(5), np.zeros(5), z], axis=1)
    fac = height(1.0, 0.0)
    entries = [("SCATTER", 1.0, {"phase": "DRAINE", "density": 1.0, "anisotropy": height(1.0, 0.0),
                                 "alpha": height(2.0, 1.0), "factors": [(fac, "one_minus")]}),
               ("SCATTER", 1.0, {"phase": "FOURNIER_FORAND", "density": 1.0, "ior": height(0.5, 1.1),
                                 "backscatter": 0.2, "factors": [(fac, "fac")]})]
    kinds, parameters, weights = Field(entries).phase_at(P)
    f = np.clip(z, 0.0, 1.0)
    assert (kinds == [phase_.PHASE["DRAINE"], phase_.PHASE["FOURNIER_FORAND"]]).all()
    np.testing.assert_allclose(weights, np.stack([1.0 - f, f], axis=1) * 2.4)     # (colour 0.8 in each channel)
    np.testing.assert_allclose(parameters[:, 0], Draine(phase_.clamp_g(z), 2.0 * z + 1.0).parameters(5))
    np.testing.assert_allclose(parameters[:, 1], FournierForand.of(0.2, 0.5 * z + 1.1).parameters(5))
    mie = Field([("SCATTER", 1.0, {"phase": "MIE", "density": 1.0, "diameter": height(10.0, 0.5)})])
    np.testing.assert_allclose(mie.phase_at(P)[1][:, 0], Mie.of(10.0 * z + 0.5).parameters(5))
    # The mixture at a point a quarter up: Draine 3/4 of the scattering, FF 1/4.
    media = Media.of([Material(np.zeros(3), "Mixed", volume=entries, volume_only=True)])
    n = 20000
    inside = np.ones((n, 1), np.int16)
    stretch = media.along(inside, np.zeros((n, 3)), np.tile([0.0, 0.0, 1.0], (n, 1)))
    mix = stretch.phases_at(np.arange(n), np.tile([0.0, 0.0, 0.25], (n, 1)), np.zeros(n))
    draine, ff = Draine(0.25, 1.5), FournierForand.of(0.2, 1.225)
    rng = np.random.default_rng(3)
    wo, wi = units(n, rng), units(n, rng)
    cos = phase_.cosines(wo, wi)
    np.testing.assert_allclose(mix.eval(wo, wi), 0.75 * draine.eval_cos(cos) + 0.25 * ff.eval_cos(cos), rtol=1e-12)
    ps = mix.sample(wo, rng.random((n, 2)))
    c = phase_.cosines(wo, ps.wi)
    from_draine = np.isclose(ps.pdf, draine.eval_cos(c), rtol=1e-9)
    assert (from_draine | np.isclose(ps.pdf, ff.eval_cos(c), rtol=1e-9)).all()
    assert abs(from_draine.mean() - 0.75) < 0.015


def test_both_kernels_scatter_in_a_medium_whose_phase_inputs_vary_to_the_same_pixels():
    """A smoke box whose Mix Shader's factor (a Gradient of height) mixes a Draine closure of varying anisotropy and
    an FF one of varying IOR, overlapping a Rayleigh world fog, under an area and a point lamp, Volume Bounces 1: the
    mixture of the three set up at each free-flight, equi-angular and collision point alike in the Python reference
    and the compiled kernel (phase_at: eval, the lobe picked, its pdf), the same pixels and shadow rays."""
    from core.lights import World
    from core.materials import Material
    from core.render import render
    from core.scene import RenderSettings
    from test_volumes_compiled import assert_same_pixels, looking, room
    from test_volumes_heterogeneous import height
    from core.geometry import primitives
    scene = room(looking())
    fac = height(0.6, 0.0)
    entries = [("SCATTER", 1.0, {"phase": "DRAINE", "color": np.array([0.5, 0.6, 0.7]), "density": 1.2,
                                 "anisotropy": height(0.5, -0.2), "alpha": height(1.0, 0.2),
                                 "factors": [(fac, "one_minus")]}),
               ("SCATTER", 1.0, {"phase": "FOURNIER_FORAND", "color": np.full(3, 0.7), "density": 1.5,
                                 "ior": height(0.2, 1.05), "backscatter": 0.3, "factors": [(fac, "fac")]})]
    scene.materials.append(Material(np.zeros(3), "Smoke", nodes=[("TRANSPARENT", np.ones(3), {})], volume=entries,
                                    volume_only=True))
    scene.add_mesh(primitives.box((1.6, 1.6, 1.6), center=(0.0, 0.0, 0.8)),
                   materials=np.array([len(scene.materials) - 1]))
    scene.world = World(color=np.zeros(3), volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": 0.02,
                                                                      "phase": "RAYLEIGH"})])
    settings = {"width": 12, "height": 9, "samples": 2, "integrator": "path", "max_bounces": 4,
                "volume_bounces": 1}
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    compiled = render(scene, RenderSettings(**settings))
    assert compiled.stats.kernels == "compiled"
    assert compiled.stats.shadow_rays == reference.stats.shadow_rays
    assert_same_pixels(reference.image, compiled.image)
