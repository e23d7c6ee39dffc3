"""Hair (core/materials/hair.py, Cycles' bsdf_principled_hair_chiang.h and bsdf_hair.h): Chiang's fibre loses no
light when it absorbs none, its sampler draws the directions its pdf says and weighs them by f cos / pdf, its offset
h is Cycles' from the round normal; the Hair BSDF's samples have its eval's pdf; Huang's model (core/materials/huang.py)
returns all the light of a white fibre through its sampler, its samples carry its eval's integral, an elliptical
fibre is as wide as Cycles'; both kernels render curves with them alike."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import curves
from core.materials import Material
from core.materials import hair
from core.materials import huang
from core.materials.hair import ChiangHair, HairReflection, HairTransmission, PrincipledHairNode, chiang_params
from core.materials.huang import HuangHair, HuangHairNode, huang_params
from core.scene import PointLight, RenderSettings, Scene

from test_compiled import assert_same_render, compare_paths

Z = np.array([0.0, 0.0, 1.0])
VIEW = np.array([0.3, -0.8, 0.52]) / np.linalg.norm([0.3, -0.8, 0.52])


def rows(n, vector):
    """n copies of a (3,) vector."""
    return np.tile(np.asarray(vector, np.float64), (n, 1))


def sphere_grid(n_sin: int = 250, n_phi: int = 500):
    """Midpoint directions over the sphere (n_sin n_phi, 3), uniform in z and azimuth, and the solid angle of each
    (250 x 500 integrates this file's lobes, roughness 0.15 and up, to within 1e-5 of 400 x 800)."""
    z = -1.0 + (np.arange(n_sin) + 0.5) * (2.0 / n_sin)
    phi = (np.arange(n_phi) + 0.5) * (2.0 * math.pi / n_phi)
    Zs, P = np.meshgrid(z, phi, indexing="ij")
    s = np.sqrt(1.0 - Zs * Zs)
    return np.stack([s * np.cos(P), s * np.sin(P), Zs], axis=-1).reshape(-1, 3), (2.0 / n_sin) * (2.0 * math.pi / n_phi)


def fibre(n: int, h: float, **inputs) -> np.ndarray:
    """n Chiang closure rows seen from VIEW along a fibre with tangent along x, at offset h."""
    p = rows(n, PrincipledHairNode.row({"tangent": (1.0, 0.0, 0.0), **inputs}))
    params = chiang_params(p, rows(n, Z), rows(n, VIEW))
    params[:, hair.H] = h
    return params


WHITE = dict(parametrization=float(hair.PARAMETRIZATIONS["absorption"]), absorption=(0.0, 0.0, 0.0))
CASES = [dict(roughness=0.3, radial_roughness=0.3, h=0.2), dict(roughness=0.15, radial_roughness=0.2, h=-0.7),
         dict(roughness=0.7, radial_roughness=0.9, h=0.5, offset=0.1), dict(roughness=1.0, radial_roughness=1.0, h=0.0)]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"r{c['roughness']}_h{c['h']}")
def test_a_fibre_that_absorbs_nothing_and_has_no_coat_loses_no_light(case):
    """White furnace: with no absorption A_R + A_TT + A_TRT + A_TRRT+ = 1, and each lobe is a density over the
    sphere, so f cos integrates to 1 over the sphere of light directions, within 2 % (the tilted lobes and the
    trimmed logistic are normalised only nearly, as in Cycles)."""
    wi, dw = sphere_grid()
    case = dict(case)
    h = case.pop("h")
    params = fibre(len(wi), h, **WHITE, **case)
    f_cos, pdf = ChiangHair.eval(params, rows(len(wi), Z), rows(len(wi), VIEW), wi)
    assert f_cos.sum(axis=0) * dw == pytest.approx(np.ones(3), abs=0.02)
    assert pdf.sum() * dw == pytest.approx(1.0, abs=0.02)


MELANIN = dict(parametrization=float(hair.PARAMETRIZATIONS["melanin"]), melanin=0.5, melanin_redness=0.3,
               roughness=0.35, radial_roughness=0.4, coat=0.3, offset=math.radians(3.0))


def test_its_sampled_directions_follow_its_pdf():
    """Chi-square: 200,000 sampled directions of a brown fibre fall into 12 x 16 cells of (z, azimuth) as often as
    its pdf integrated over each cell says (cells expecting fewer than 20 pooled)."""
    rng = np.random.default_rng(5)
    n = 200000
    params = fibre(n, 0.3, **MELANIN)
    s = ChiangHair.sample(params, rows(n, Z), rows(n, VIEW), rng.random((n, 3)))
    assert (s.pdf > 0.0).all()
    bins = (12, 16)

    def cell(w):
        zi = np.minimum(((w[:, 2] + 1.0) * 0.5 * bins[0]).astype(int), bins[0] - 1)
        pi = np.minimum(((np.arctan2(w[:, 1], w[:, 0]) % (2 * math.pi)) / (2 * math.pi) * bins[1]).astype(int),
                        bins[1] - 1)
        return zi * bins[1] + pi

    observed = np.bincount(cell(s.wi), minlength=bins[0] * bins[1])
    # A 240 x 480 grid (20 x 30 points a cell): its cells' integrals differ from a 480 x 960 grid's by at most
    # 0.22 sigma of a cell's count, 0.2 of chi-square in all, against the bound's margin of 5 sigma (~76 for 115
    # cells): the same power at a fifth of the finer grid's eval time.
    wi, dw = sphere_grid(240, 480)
    _, pdf = ChiangHair.eval(fibre(len(wi), 0.3, **MELANIN), rows(len(wi), Z), rows(len(wi), VIEW), wi)
    expected = np.bincount(cell(wi), weights=pdf * dw, minlength=bins[0] * bins[1])
    expected *= n / expected.sum()
    big = expected >= 20
    obs = np.append(observed[big], observed[~big].sum())
    exp = np.append(expected[big], expected[~big].sum())
    chi2 = ((obs - exp) ** 2 / exp).sum()
    dof = len(obs) - 1
    assert chi2 < dof + 5.0 * math.sqrt(2.0 * dof), (chi2, dof)


def test_a_samples_weight_is_f_cos_over_pdf_and_their_mean_the_albedo():
    """Each sample's weight is eval's f cos / pdf at its direction, and their mean is f cos integrated over the
    sphere (the fibre's albedo, below 1 where it absorbs), within 1 %."""
    rng = np.random.default_rng(6)
    n = 100000
    params = fibre(n, -0.4, **MELANIN)
    s = ChiangHair.sample(params, rows(n, Z), rows(n, VIEW), rng.random((n, 3)))
    f_cos, pdf = ChiangHair.eval(params, rows(n, Z), rows(n, VIEW), s.wi)
    np.testing.assert_allclose(s.pdf, pdf, rtol=1e-9)
    np.testing.assert_allclose(s.weight, f_cos / pdf[:, None], rtol=1e-9)
    wi, dw = sphere_grid()
    f_grid, _ = ChiangHair.eval(fibre(len(wi), -0.4, **MELANIN), rows(len(wi), Z), rows(len(wi), VIEW), wi)
    albedo = f_grid.sum(axis=0) * dw
    assert (albedo < 0.9).all()
    np.testing.assert_allclose(s.weight.mean(axis=0), albedo, rtol=0.01)


def test_the_colour_parametrisations_give_cycles_absorption():
    """Direct Coloring: sigma = (log c / scale(radial))^2 with Chiang's polynomial in the radial roughness; white is
    no absorption. Melanin m with Redness r: -log(1 - m) split into eumelanin (1 - r) and pheomelanin r times their
    spectra, plus the Tint's Direct Coloring absorption. Absorption Coefficient: itself."""
    c = np.array([0.2, 0.5, 1.0])
    radial = 0.4
    scale = (((((0.245 * radial) + 5.574) * radial - 10.73) * radial + 2.532) * radial - 0.215) * radial + 5.969
    p = fibre(1, 0.0, parametrization=float(hair.PARAMETRIZATIONS["direct_coloring"]), color=c,
              radial_roughness=radial)
    np.testing.assert_allclose(p[0, :3], (np.log(c) / scale) ** 2, rtol=1e-12)
    p = fibre(1, 0.0, parametrization=float(hair.PARAMETRIZATIONS["melanin"]), melanin=0.6, melanin_redness=0.25,
              tint=(1.0, 1.0, 1.0))
    m = -math.log(1.0 - 0.6)
    np.testing.assert_allclose(p[0, :3], m * 0.75 * np.array(hair.EUMELANIN) + m * 0.25 * np.array(hair.PHEOMELANIN),
                               rtol=1e-12)
    p = fibre(1, 0.0, parametrization=float(hair.PARAMETRIZATIONS["absorption"]), absorption=(0.1, 0.2, 0.3))
    np.testing.assert_allclose(p[0, :3], [0.1, 0.2, 0.3])


def test_its_colour_pass_albedo_is_cycles_estimate():
    """Cycles' albedo estimate: exp(-sqrt(sigma) x scale(v)) + Fresnel's f; with no absorption 1 + f."""
    params = fibre(1, 0.3, **WHITE)
    X = np.array([1.0, 0.0, 0.0])
    f = hair.fresnel_cos(np.array([math.sqrt(1.0 - VIEW.dot(X) ** 2) * math.sqrt(1.0 - 0.09)]), params[:, hair.ETA])
    R, T = ChiangHair.albedo(params, rows(1, Z), rows(1, VIEW))
    np.testing.assert_allclose(R[0], 1.0 + f[0], rtol=1e-12)
    assert not T.any()


def test_random_roughness_scales_both_roughnesses_by_one_plus_twice_the_randoms_offset_from_a_half():
    """Random Roughness k with Random x: roughness x (1 + 2 (x - 1/2) k), so Random 1/2 changes nothing."""
    base = fibre(1, 0.0, roughness=0.4, radial_roughness=0.5)
    same = fibre(1, 0.0, roughness=0.4, radial_roughness=0.5, random_roughness=1.0, random=0.5)
    np.testing.assert_array_equal(base, same)
    rougher = fibre(1, 0.0, roughness=0.4, radial_roughness=0.5, random_roughness=0.5, random=1.0)
    np.testing.assert_allclose(rougher[0, hair.V], hair.variance_of(np.array([0.6]))[0], rtol=1e-12)


def test_h_is_the_sine_of_the_hits_angle_across_the_fibre_as_cycles_computes_it():
    """h = (Ng x X) . Z: 0 where the normal faces the viewer (the fibre's middle), -+1 at its two grazing edges,
    sin(angle) between, for a fibre along x seen along -y."""
    wo = np.array([[0.0, -1.0, 0.0]])
    p = PrincipledHairNode.row({"tangent": (1.0, 0.0, 0.0)})[None, :]
    for angle in (0.0, 0.3, -1.1, math.pi / 2):
        N = np.array([[0.0, -math.cos(angle), math.sin(angle)]])
        h = chiang_params(p, N, wo)[0, hair.H]
        assert abs(h) == pytest.approx(abs(math.sin(angle)), abs=1e-12)
    up = chiang_params(p, np.array([[0.0, 0.0, 1.0]]), wo)[0, hair.H]
    down = chiang_params(p, np.array([[0.0, 0.0, -1.0]]), wo)[0, hair.H]
    assert up == pytest.approx(-down) and abs(up) == pytest.approx(1.0)


@pytest.mark.parametrize("bsdf", [HairReflection, HairTransmission], ids=lambda c: c.name)
def test_the_hair_bsdfs_samples_have_its_evals_pdf_which_integrates_to_the_share_it_keeps(bsdf):
    """Hair BSDF: eval's pdf is the density its sampler draws with: integrated over the directions the sampler
    reaches it is the share of samples eval keeps (in front of N for Reflection, behind it for Transmission), and
    Transmission's samples carry it. (Transmission's sampler reaches azimuths within pi / 2 of the far side only,
    where its Cauchy lobe is normalised; its eval, as Cycles', goes on beyond, 7 % more here. Reflection's sampler,
    as Cycles', reports cos(phi / 2) / (4 RoughnessV) where its density, and its eval, is
    cos(phi / (2 RoughnessV)) / (4 RoughnessV): its samples keep their own weight, 1, so only MIS sees it.)"""
    rng = np.random.default_rng(7)
    n = 100000
    p = np.zeros((n, 32))
    p[:, hair.ROUGHNESS_U], p[:, hair.ROUGHNESS_V], p[:, hair.OFFSET] = 0.25, 0.3, -0.05
    p[:, hair.HAIR_TANGENT:hair.HAIR_TANGENT + 3] = (1.0, 0.0, 0.0)
    N = rows(n, (0.0, -0.6, 0.8))
    s = bsdf.sample(p, N, rows(n, VIEW), rng.random((n, 2)))
    f_cos, pdf = bsdf.eval(p, N, rows(n, VIEW), s.wi)
    kept = pdf > 0.0
    assert kept.mean() > 0.3
    if bsdf is HairTransmission:
        np.testing.assert_allclose(s.pdf[kept], pdf[kept], rtol=1e-9)
    np.testing.assert_array_equal(f_cos[:, 0], pdf)
    wi, dw = sphere_grid()
    m = len(wi)
    q = np.repeat(p[:1], m, axis=0)
    _, grid_pdf = bsdf.eval(q, rows(m, (0.0, -0.6, 0.8)), rows(m, VIEW), wi)
    if bsdf is HairTransmission:
        _, locy, _ = hair.hair_frame(q, rows(m, VIEW))
        grid_pdf = np.where(hair.light_angles(q, wi, locy)[1] <= 0.0, grid_pdf, 0.0)
    assert grid_pdf.sum() * dw == pytest.approx(kept.mean(), abs=0.01)


def huang_fibre(n: int, h: float, **inputs) -> np.ndarray:
    """n Huang closure rows seen from VIEW along a fibre with tangent along x, its major axis along z, at offset h
    (in the far field: no pixel coverage)."""
    p = rows(n, HuangHairNode.row({"tangent": (1.0, 0.0, 0.0), "major_axis": (0.0, 0.0, 1.0), **inputs}))
    params, _ = huang_params(p, rows(n, Z), rows(n, VIEW))
    params[:, huang.H] = h
    return params


HUANG_WHITE = dict(WHITE, roughness=0.3, offset=math.radians(2.0))
HUANG_BROWN = dict(parametrization=float(hair.PARAMETRIZATIONS["melanin"]), melanin=0.35, melanin_redness=0.6,
                   roughness=0.35, offset=math.radians(4.0), reflection=0.8, transmission=1.2,
                   secondary_reflection=0.7)


@pytest.mark.parametrize("aspect_ratio", [1.0, 0.5])
def test_a_huang_fibre_that_absorbs_nothing_returns_all_light_through_its_sampler(aspect_ratio):
    """White furnace, Huang's model: the sampler traces a path through the fibre and weighs it by the energy its
    lobes carry, so with no absorption the mean weight is 1, within the glass albedo tables' energy compensation (it
    scales each refraction by 1 / E, a little over 1: Cycles' too), 1.00 .. 1.04. (Cycles' eval is no density: its
    Simpson's rule over h weighs the fibre's edges by the Jacobian 1 / cos gamma, and its residual series carries
    T1 where a sampled normal reflects totally, so in a white furnace its integral exceeds 1; with absorption it
    agrees with the sampler: the test below.)"""
    rng = np.random.default_rng(8)
    n = 40000
    params = huang_fibre(n, 0.3, aspect_ratio=aspect_ratio, **HUANG_WHITE)
    s = HuangHair.sample(params, rows(n, Z), rows(n, VIEW), rng.random((n, 3)))
    assert (s.pdf[s.pdf > 0.0] == 1.0).all() and (s.pdf > 0.0).mean() > 0.95
    mean = s.weight.mean(axis=0)
    np.testing.assert_allclose(mean, mean[0], rtol=1e-12)
    assert 1.0 <= mean[0] <= 1.04, mean


@pytest.mark.parametrize("aspect_ratio", [1.0, 0.5])
def test_huang_samples_carry_what_its_eval_integrates_over_the_sphere(aspect_ratio):
    """A brown fibre with lobe scales not 1: the mean sample weight (the sampler's estimate of the light the fibre
    returns, its pdf 1 as in Cycles) is eval integrated over the sphere of light directions, channel by channel,
    within 3 % (two estimates of one integral: eval's is itself a Monte Carlo-Simpson quadrature, as Cycles')."""
    rng = np.random.default_rng(9)
    n = 40000
    params = huang_fibre(n, 0.3, aspect_ratio=aspect_ratio, **HUANG_BROWN)
    s = HuangHair.sample(params, rows(n, Z), rows(n, VIEW), rng.random((n, 3)))
    wi, dw = sphere_grid(90, 180)
    f_grid, pdf = HuangHair.eval(huang_fibre(len(wi), 0.3, aspect_ratio=aspect_ratio, **HUANG_BROWN),
                                 rows(len(wi), Z), rows(len(wi), VIEW), wi)
    assert (pdf == 1.0).all()
    albedo = f_grid.sum(axis=0) * dw
    assert albedo[2] < albedo[1] < albedo[0] < 0.8
    np.testing.assert_allclose(s.weight.mean(axis=0), albedo, rtol=0.03)


def test_an_elliptical_fibre_is_transparent_outside_its_projected_width():
    """Aspect Ratio b: seen at an azimuth phi from its major axis, the fibre's projected half-width is
    sqrt(1 - (1 - b^2) cos^2 phi) (Cycles' radius); hits beyond it let the light through (Cycles' transparent
    closure), hits within it get the closure, its frame's X the major axis. An Aspect Ratio b over 1 is 1 / b about
    the same axis: Cycles' swap of the axes, (dPdu x N) x dPdu, gives back N itself."""
    view = np.array([0.0, -0.6, 0.8])
    major = np.array([0.0, 1.0, 0.0])
    p = rows(2, HuangHairNode.row({"tangent": (1.0, 0.0, 0.0), "major_axis": major, "aspect_ratio": 0.5}))
    across = np.cross([1.0, 0.0, 0.0], view)                  # Cycles' X: h = -X.N, the sine across the view
    normals = np.array([view, 0.95 * across + math.sqrt(1.0 - 0.95 ** 2) * view])       # h = 0 and h = -0.95
    params, outside = huang_params(p, normals, rows(2, view))
    radius = math.sqrt(1.0 - 0.75 * 0.6 ** 2)
    np.testing.assert_allclose(huang.radius_of(params[:, huang.B], huang.to_local(params, rows(2, view))), radius)
    np.testing.assert_allclose(params[:, huang.H], [0.0, -0.95], atol=1e-12)
    assert not outside[0] and outside[1]
    np.testing.assert_allclose(params[0, huang.AXIS_X:huang.AXIS_X + 3], major, atol=1e-12)
    p = rows(1, HuangHairNode.row({"tangent": (1.0, 0.0, 0.0), "major_axis": major, "aspect_ratio": 2.0}))
    params, _ = huang_params(p, normals[:1], rows(1, view))
    assert params[0, huang.B] == 0.5
    np.testing.assert_allclose(params[0, huang.AXIS_X:huang.AXIS_X + 3], major, atol=1e-12)


def hair_scene(node: tuple) -> Scene:
    """Three curved strands (tubes) of one hair material, lit by a point lamp and a grey world."""
    scene = Scene(camera=Camera.look_at((0.0, -4.0, 0.6), (0.0, 0.0, 0.4), fov=math.radians(30)),
                  world_color=np.array([0.2, 0.2, 0.25]))
    keys = np.concatenate([np.array([[x + 0.05 * k, 0.05 * k * k, 0.3 * k] for k in range(4)])
                           for x in (-0.5, 0.0, 0.5)])
    tubes = curves.tubes(keys, np.full(len(keys), 0.08), np.array([0, 4, 8]), np.array([4, 4, 4]), sides=8, steps=4)
    mesh = tubes.mesh
    for name in ("curve_tangent", "curve:random", "curve_normal", "curve:thickness"):
        values = mesh.curve_info[name][mesh.triangles]
        mesh.attributes[name] = values[:, :, None] if values.ndim == 2 else values
    name, weight, inputs = node
    links = {**hair.curve_links(), **(huang.huang_links() if name == "PRINCIPLED_HAIR_HUANG" else {})}
    scene.materials.append(Material(np.ones(3), nodes=[(name, weight, {**links, **inputs})]))
    scene.add_mesh(mesh, materials=np.array([0]))
    scene.lights = [PointLight(np.array([1.5, -2.0, 2.0]), power=300.0)]
    return scene


NODES = {"chiang_melanin": ("PRINCIPLED_HAIR", np.ones(3), {k: v for k, v in MELANIN.items()}),
         "chiang_direct": ("PRINCIPLED_HAIR", np.ones(3), {"color": (0.6, 0.3, 0.1), "random_roughness": 0.5}),
         "hair_reflection": ("HAIR", np.ones(3), {"roughness_u": 0.2, "roughness_v": 0.3, "offset": 0.05,
                                                  "color": (0.8, 0.6, 0.4)}),
         "hair_transmission": ("HAIR", np.ones(3), {"transmission": 1.0, "color": (0.8, 0.6, 0.4)}),
         "huang": ("PRINCIPLED_HAIR_HUANG", np.ones(3), {**HUANG_BROWN, "aspect_ratio": 1.0}),
         "huang_elliptic": ("PRINCIPLED_HAIR_HUANG", np.ones(3), {**HUANG_BROWN, "aspect_ratio": 0.6})}


@pytest.mark.parametrize("name", list(NODES))
def test_both_kernels_render_hair_on_curves_alike(name):
    """Strands of each hair closure, path traced with 3 bounces: the compiled kernel's image is the reference's, and
    so is its Glossy Color pass (each closure's albedo, Chiang's and Huang's Cycles' estimates)."""
    settings = RenderSettings(width=32, height=24, samples=4, integrator="path", max_bounces=3,
                              passes=("glossy_color", "transmission_color"))
    compiled, reference = compare_paths(hair_scene(NODES[name]), settings)
    assert reference.image.max() > 0.01
    if name.startswith("huang"):
        # Huang's eval is a Monte Carlo-Simpson quadrature whose numbers are seeded by the directions' bits: where a
        # sampled direction's last bits differ between the kernels (the float32 cosine of the samplers), its
        # estimate is another draw of the same quadrature. The images agree but for those few pixels.
        same = np.isclose(compiled.image, reference.image, rtol=1e-6, atol=1e-9).all(axis=2)
        assert same.mean() > 0.98
        np.testing.assert_allclose(compiled.image, reference.image, atol=0.01)
    else:
        assert_same_render(compiled, reference)
    kind = "transmission_color" if name == "hair_transmission" else "glossy_color"
    assert reference.aux[kind].max() > 0.1
    for pass_ in ("glossy_color", "transmission_color"):
        np.testing.assert_allclose(compiled.aux[pass_], reference.aux[pass_], rtol=1e-5, atol=1e-6)


def hair_mesh_scene(node: tuple) -> Scene:
    """A flat-shaded sphere, seen from outside and, cut open by the camera's near side, from inside (its back faces),
    wearing one hair material on the triangles' edges (hair.mesh_links), lit by a point lamp and a grey world."""
    from core.geometry import primitives
    scene = Scene(camera=Camera.look_at((0.0, -3.0, 0.3), (0.0, 0.0, 0.0), fov=math.radians(40)),
                  world_color=np.array([0.2, 0.2, 0.25]))
    mesh = primitives.uv_sphere(1.0, segments=10, rings=6, smooth=False)
    corners = mesh.vertices[mesh.triangles]                                 # (t, 3, 3)
    for name, edge in (("triangle_dpdu", corners[:, 1] - corners[:, 0]), ("triangle_dpdv", corners[:, 2] - corners[:, 0])):
        mesh.attributes[name] = np.repeat(edge[:, None, :], 3, axis=1)
    name, weight, inputs = node
    links = hair.mesh_links("triangle_dpdv" if name == "HAIR" else "triangle_dpdu")
    if name != "PRINCIPLED_HAIR":
        links.pop("surface_bitangent")
    scene.materials.append(Material(np.ones(3), nodes=[(name, weight, {**links, **inputs})]))
    scene.add_mesh(mesh, materials=np.array([0]))
    scene.add_mesh(primitives.plane(1.5, center=(0.6, -1.2, -0.4)), materials=np.array([0]))
    scene.lights = [PointLight(np.array([1.5, -2.0, 2.0]), power=300.0)]
    return scene


@pytest.mark.parametrize("name", ["chiang_melanin", "hair_reflection", "hair_transmission", "huang"])
def test_both_kernels_render_hair_on_triangles_alike(name):
    """A hair closure on a mesh, its fibre the triangles' dPdu (dPdv), path traced with 3 bounces: the compiled
    kernel's image is the reference's."""
    settings = RenderSettings(width=24, height=18, samples=4, integrator="path", max_bounces=3)
    compiled, reference = compare_paths(hair_mesh_scene(NODES[name]), settings)
    assert reference.image.max() > 0.01
    if name.startswith("huang"):      # (the quadrature's seeds: test_both_kernels_render_hair_on_curves_alike;
        # seen directly the images are the same: the bounces' few pixels differ, each another draw of its estimate;
        # more of them where numpy's AVX-512 arccos and arctan2 part from libm's in the last bit: 73 % alike there)
        same = np.isclose(compiled.image, reference.image, rtol=1e-6, atol=1e-9).all(axis=2)
        assert same.mean() > 0.6
        assert abs(compiled.image.mean() / reference.image.mean() - 1.0) < 0.01
    else:
        assert_same_render(compiled, reference)


def test_on_a_triangle_its_light_samples_behind_the_surface_are_shadowed_but_not_its_own_samples():
    """Cycles' bump shadowing (bsdf.h) with Chiang's closure normal on a triangle, its frame's Y = X x wo: a light's
    direction wi is zeroed where (Ns.wi)(Ns.Y)(Y.wi) < 0 (bsdf_eval), a direction the closure sampled itself is not
    (bsdf_sample shadows only diffuse closures there), its weight f cos / pdf of the bare fibre; a diffuse closure
    tilted off the smooth normal is shadowed at its own samples too. Both kernels."""
    from core.materials import Closures, compiled_bsdf, eval_closures, sample_closures
    from core.materials.lambert import Lambert
    n = 4000
    rng = np.random.default_rng(11)
    params = fibre(n, 0.3, **MELANIN)
    Y = np.cross([1.0, 0.0, 0.0], VIEW)
    Y /= np.linalg.norm(Y)
    u = rng.random((n, 2))
    for kind, N, bare in ((ChiangHair.kind, Y, ChiangHair), (Lambert.kind, np.array([0.6, 0.0, 0.8]), Lambert)):
        weight = rows(n, (0.9, 0.7, 0.5))
        closures = Closures(np.full((n, 1), kind, np.int32), weight[:, None, :], np.full((n, 1), 0.7),
                            rows(n, N)[:, None, :], params[:, None, :], rows(n, Z)[:, None, :])
        s = sample_closures(closures, rows(n, VIEW), u, np.full(n, 0.5))
        behind = (s.wi @ Z) * (Z @ N) * (s.wi @ N) < 0.0
        assert 0.05 < behind.mean() < 0.95
        light_f, light_pdf = eval_closures(closures, rows(n, VIEW), s.wi)
        assert not light_f[behind].any() and not light_pdf[behind].any()
        own = bare.sample(params, rows(n, N), rows(n, VIEW), np.column_stack([u, np.full(n, 0.5)]))
        kept = own.pdf > 0.0
        if bare is ChiangHair:
            np.testing.assert_allclose(s.weight[kept], weight[kept] * own.weight[kept], rtol=1e-6)
            np.testing.assert_allclose(s.pdf[kept], own.pdf[kept], rtol=1e-9)
            assert s.weight[behind].min() > 0.0
        else:
            assert not s.weight[behind].any() and s.weight[~behind & kept].min() > 0.0
        f_cos, pdf, sampled = compiled_bsdf(np.full(n, kind, np.int32), weight, rows(n, N), params, rows(n, VIEW),
                                            s.wi, u, Ns=rows(n, Z))
        np.testing.assert_allclose(f_cos, light_f, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(pdf, light_pdf, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(sampled.wi, s.wi, rtol=0, atol=1e-6)
        behind_c = (sampled.wi @ Z) * (Z @ N) * (sampled.wi @ N) < 0.0
        if bare is ChiangHair:
            assert sampled.weight[behind_c & kept].min() > 0.0
            np.testing.assert_allclose(sampled.pdf, s.pdf, rtol=1e-5, atol=1e-9)
        else:
            assert not sampled.weight[behind_c].any()


def test_a_ribbons_rounded_normal_is_the_tubes_so_its_offset_is_minus_v():
    """Cycles' Ribbons (curve_shader_setup) shade a flat strip with the round normal N = v B - sqrt(1 - v^2)
    (T x B) / |T x B|, B = T x wo / |T x wo|, v across the strip (-1..1), and give Chiang's and Huang's h = -v there:
    the h that Primer's round tube (chiang_params, huang_params from its normal) takes at the same point, for any
    tangent and view (the Hair BSDF reads only N.wi and the tangent: a ribbon shades as the tube)."""
    rng = np.random.default_rng(21)
    n = 500
    T = rng.normal(size=(n, 3))
    T /= np.linalg.norm(T, axis=1, keepdims=True)
    wo = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    v = rng.uniform(-1.0, 1.0, n)
    B = np.cross(T, wo)
    B /= np.linalg.norm(B, axis=1, keepdims=True)
    across = np.cross(T, B)
    N = v[:, None] * B - np.sqrt(1.0 - v * v)[:, None] * across / np.linalg.norm(across, axis=1, keepdims=True)
    p = np.array([PrincipledHairNode.row({"tangent": tuple(t)}) for t in T])
    params = chiang_params(p, N, wo)
    np.testing.assert_allclose(params[:, hair.H], -v, rtol=0, atol=1e-9)
    p = np.array([HuangHairNode.row({"tangent": tuple(t), "aspect_ratio": 1.0}) for t in T])
    np.testing.assert_allclose(huang_params(p, N, wo)[0][:, huang.H], -v, rtol=0, atol=1e-9)     # (Huang's too)
    assert (np.einsum("ij,ij->i", N, wo) >= -1e-12).all()          # (facing the viewer, as a tube's seen side)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_on_triangles_its_light_passes_times_colours_make_combined(kernels):
    """Cycles' sum rule (tests/test_passes_light.py) with Chiang's closure on triangles, whose own sampled directions
    escape the bump shadowing against its fibre frame's normal that its light samples get: a BSDF ray sent behind the
    smooth surface carries its light into the passes too (lightpasses.sample_shares with the sampled slot)."""
    from core import render
    from core.integrators.lightpasses import COLOR_OF, LIGHT_PASSES
    wanted = LIGHT_PASSES + ("diffuse_color", "glossy_color", "transmission_color", "emission", "environment")
    settings = RenderSettings(width=24, height=18, samples=4, integrator="path", max_bounces=3, passes=wanted,
                              kernels=kernels)
    result = render.render(hair_mesh_scene(NODES["chiang_melanin"]), settings)
    p = {name: result.aux[name].astype(np.float64) for name in wanted}
    total = p["emission"] + p["environment"]
    for name in LIGHT_PASSES:
        total += p[name] * (p[COLOR_OF[name]] if name in COLOR_OF else 1.0)
    combined = result.image[..., :3].astype(np.float64)
    assert combined.max() > 0.01
    np.testing.assert_allclose(total, combined, rtol=1e-4, atol=1e-5)
