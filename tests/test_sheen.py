"""The microfiber sheen BSDF (Cycles' Sheen BSDF and Principled sheen, Zeltner et al.'s LTC lobe) against its
physical properties: the lobe reflects exactly the albedo the layers below lose, a white base under a sheen
keeps all the light, the lobe is isotropic and mirror-symmetric (but, like Cycles', not reciprocal), sampling
draws the distribution its pdf states, C equals Python, and a Principled BSDF without sheen is unchanged.
The Sheen BSDF's Ashikhmin velvet too: its facet distribution is normalized, it is reciprocal, its samples
weigh to what eval integrates, C equals Python. And the addon reads both from Blender without a warning."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.materials import Material, nodes
from core.materials import sheen as sh
from core.materials import velvet as vv
from core.materials.graph import GraphNode, Link
from core.scene import PointLight, RenderSettings, Scene, SunLight

UP = np.array([0.0, 0.0, 1.0])


def direction(mu: float, phi: float = 0.0) -> np.ndarray:
    """The unit direction at cos theta = mu and azimuth phi around +Z."""
    s = math.sqrt(max(0.0, 1.0 - mu * mu))
    return np.array([s * math.cos(phi), s * math.sin(phi), mu])


def hemisphere(n: int) -> tuple:
    """Midpoint directions (k, 3) of an n x 2n grid in (cos theta, phi) over the upper hemisphere, and the solid
    angle of one cell (d omega = d mu d phi)."""
    mu = (np.arange(n) + 0.5) / n
    phi = (np.arange(2 * n) + 0.5) * (math.pi / n)
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - M * M)
    return np.stack([s * np.cos(P), s * np.sin(P), M], axis=-1).reshape(-1, 3), (1.0 / n) * (math.pi / n)


def lobe(roughness: float, mu_o: float, phi_o: float = 0.0) -> tuple:
    """A sheen closure's parameter row and albedo R for a view at mu_o, and that view direction."""
    p, R = sh.params_of(np.array([roughness]), np.array([mu_o]))
    return p[0], float(R[0]), direction(mu_o, phi_o)


def integral_of_f_cos(row: np.ndarray, wo: np.ndarray, n: int = 800) -> float:
    """The integral of the lobe's f cos over the hemisphere (its weight left out), by the midpoint rule."""
    wi, cell = hemisphere(n)
    k = len(wi)
    f_cos, _ = sh.Sheen.eval(np.tile(row, (k, 1)), np.tile(UP, (k, 1)), np.tile(wo, (k, 1)), wi)
    return float(f_cos[:, 0].sum() * cell)


@pytest.mark.parametrize("roughness", [0.3, 0.5, 1.0])
@pytest.mark.parametrize("mu_o", [0.2, 0.6, 0.95])
def test_the_lobe_reflects_exactly_its_albedo(roughness, mu_o):
    """White furnace of the closure: f cos (weight R) integrates to R, the albedo the layers below lose. The LTC
    lobe is a distribution (M keeps every direction above the surface), so it integrates to 1 before R."""
    row, R, wo = lobe(roughness, mu_o)
    assert 0.0 < R < 1.0
    np.testing.assert_allclose(R * integral_of_f_cos(row, wo), R, rtol=3e-3)


def test_a_white_base_under_a_white_sheen_keeps_all_the_light():
    """Principled BSDF, white base, no specular (IOR level 0), sheen 1 and white tint: the sheen reflects R(mu)
    and the diffuse below keeps 1 - R(mu) of its weight, so together they reflect exactly all the light (the
    layering uses the same albedo the lobe integrates to)."""
    row = nodes.PrincipledNode.row({"base_color": (1.0, 1.0, 1.0), "specular_ior_level": 0.0, "sheen": 1.0,
                                    "sheen_roughness": 0.4})
    wi, cell = hemisphere(300)              # the sums are within 1e-5 of 1 on this grid (800: 1e-6, 5x the time)
    k = len(wi)
    for mu_o in (0.15, 0.5, 0.9):
        wo = direction(mu_o, 0.7)
        result = nodes.shade_nodes([(nodes.PrincipledNode, np.ones(3), row)], UP[None, :], wo[None, :])
        kinds = set(result.closures.kind[0]) - {-1}
        assert kinds == {materials.Sheen.kind, materials.Lambert.kind}
        closures = materials.Closures(*(None if array is None else np.repeat(array, k, axis=0)
                                        for array in result.closures))
        f_cos, _ = materials.eval_closures(closures, np.tile(wo, (k, 1)), wi)
        np.testing.assert_allclose(f_cos.sum(axis=0) * cell, 1.0, rtol=1e-4)


def test_the_principled_sheen_is_tinted_scaled_and_darkens_the_layers_below_by_its_largest_channel():
    """Cycles' layout: sheen weight = sheen x tint x R; the layers below keep 1 - max(sheen x tint x R)."""
    tint = np.array([0.9, 0.5, 0.2])
    row = nodes.PrincipledNode.row({"base_color": (0.8, 0.8, 0.8), "specular_ior_level": 0.0, "sheen": 0.7,
                                    "sheen_tint": tint, "sheen_roughness": 0.6})
    wo = direction(0.3, 0.0)
    result = nodes.shade_nodes([(nodes.PrincipledNode, np.ones(3), row)], UP[None, :], wo[None, :])
    c = result.closures
    R = float(sh.params_of(np.array([0.6]), np.array([0.3]))[1][0])
    sheen_slot = list(c.kind[0]).index(materials.Sheen.kind)
    diffuse_slot = list(c.kind[0]).index(materials.Lambert.kind)
    np.testing.assert_allclose(c.weight[0, sheen_slot], 0.7 * tint * R, rtol=1e-12)
    np.testing.assert_allclose(c.sample_weight[0, sheen_slot], 0.7 * tint.mean() * R, rtol=1e-12)
    np.testing.assert_allclose(c.weight[0, diffuse_slot], 0.8 * (1.0 - 0.7 * 0.9 * R), rtol=1e-12)


def test_the_lobe_is_isotropic_and_symmetric_about_the_plane_of_incidence():
    """Turning both directions about N changes nothing, and neither does mirroring wi across the plane of wo and
    N (the lobe leans only towards or away from the viewer)."""
    rng = np.random.default_rng(3)
    n = 400
    wo = np.array([direction(m, p) for m, p in rng.uniform((0.02, 0.0), (1.0, 2 * math.pi), (n, 2))])
    wi = np.array([direction(m, p) for m, p in rng.uniform((0.02, 0.0), (1.0, 2 * math.pi), (n, 2))])
    N = np.tile(UP, (n, 1))
    params = sh.params_of(rng.uniform(0.05, 1.0, n), wo[:, 2])[0]
    f, _ = sh.Sheen.eval(params, N, wo, wi)
    angle = rng.uniform(0.0, 2 * math.pi, n)
    c, s = np.cos(angle), np.sin(angle)

    def turn(v):
        return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)

    f_turned, _ = sh.Sheen.eval(params, N, turn(wo), turn(wi))
    np.testing.assert_allclose(f_turned, f, rtol=1e-9, atol=1e-300)
    # Mirror wi across the plane through N and wo: reflect its part along wo's tangent-normal Bt.
    T, Bt = sh.frame(N, wo)
    mirrored = wi - 2.0 * np.einsum("ij,ij->i", wi, Bt)[:, None] * Bt
    f_mirrored, _ = sh.Sheen.eval(params, N, wo, mirrored)
    np.testing.assert_allclose(f_mirrored, f, rtol=1e-9, atol=1e-300)


def test_the_lobe_is_not_reciprocal_as_in_cycles():
    """f(wo, wi) / cos(wi) and f(wi, wo) / cos(wo) differ: the cosine is part of the fitted lobe (Zeltner et al.
    say so; Cycles uses it as is). The swap changes the BRDF by tens of percent at some pairs: a known
    property of the model, not a bug of Primer's."""
    wo, wi = direction(0.8, 0.0), direction(0.2, math.pi)
    N = UP[None, :]
    row_o = sh.params_of(np.array([0.5]), np.array([0.8]))[0]
    row_i = sh.params_of(np.array([0.5]), np.array([0.2]))[0]
    R_o, R_i = (float(sh.params_of(np.array([0.5]), np.array([m]))[1][0]) for m in (0.8, 0.2))
    f_oi = R_o * sh.Sheen.eval(row_o, N, wo[None, :], wi[None, :])[0][0, 0] / wi[2]
    f_io = R_i * sh.Sheen.eval(row_i, N, wi[None, :], wo[None, :])[0][0, 0] / wo[2]
    assert abs(f_oi / f_io - 1.0) > 0.1


@pytest.mark.parametrize("roughness, mu_o", [(0.5, 0.4), (0.2, 0.8), (1.0, 0.1)])
def test_sampling_draws_the_distribution_its_pdf_states(roughness, mu_o):
    """Sampled directions binned in (cos theta, phi) match the pdf integrated over each bin (chi-square), every
    sample's pdf is eval's pdf at its direction, and its weight f cos / pdf is 1 (R is in the closure weight)."""
    n = 200_000
    rng = np.random.default_rng(11)
    row, _, wo = lobe(roughness, mu_o, 0.3)
    N, W = np.tile(UP, (n, 1)), np.tile(wo, (n, 1))
    params = np.tile(row, (n, 1))
    s = sh.Sheen.sample(params, N, W, rng.random((n, 2)))
    _, pdf = sh.Sheen.eval(params, N, W, s.wi)
    np.testing.assert_allclose(s.pdf, pdf, rtol=1e-9)
    np.testing.assert_allclose(s.weight, 1.0)
    assert (s.wi[:, 2] > 0.0).all()
    bins_mu, bins_phi = 10, 16
    phi = np.mod(np.arctan2(s.wi[:, 1], s.wi[:, 0]), 2 * math.pi)
    observed, _, _ = np.histogram2d(s.wi[:, 2], phi, bins=(bins_mu, bins_phi), range=((0, 1), (0, 2 * math.pi)))
    grid, cell = hemisphere(800)
    _, density = sh.Sheen.eval(np.tile(row, (len(grid), 1)), np.tile(UP, (len(grid), 1)),
                               np.tile(wo, (len(grid), 1)), grid)
    g_phi = np.mod(np.arctan2(grid[:, 1], grid[:, 0]), 2 * math.pi)
    expected, _, _ = np.histogram2d(grid[:, 2], g_phi, bins=(bins_mu, bins_phi), range=((0, 1), (0, 2 * math.pi)),
                                    weights=density * cell)
    np.testing.assert_allclose(expected.sum(), 1.0, rtol=3e-3)           # the pdf integrates to 1
    expected *= n / expected.sum()
    kept = expected > 20
    chi2 = float((((observed - expected) ** 2)[kept] / expected[kept]).sum())
    dof = int(kept.sum()) - 1
    assert chi2 < dof + 5.0 * math.sqrt(2.0 * dof), (chi2, dof)


def test_compiled_sheen_equals_the_reference():
    """bsdf.c's sheen evaluates and samples as sheen.py does, on random normals, views and roughnesses."""
    n = 1000
    rng = np.random.default_rng(5)
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    wo, wi = (rng.normal(size=(n, 3)) for _ in range(2))
    wo, wi = wo / np.linalg.norm(wo, axis=1, keepdims=True), wi / np.linalg.norm(wi, axis=1, keepdims=True)
    wo *= np.where(np.einsum("ij,ij->i", wo, N) < 0, -1.0, 1.0)[:, None]
    params = sh.params_of(rng.uniform(0.0, 1.0, n), np.einsum("ij,ij->i", N, wo))[0]
    u = rng.random((n, 2))
    f_cos, pdf = sh.Sheen.eval(params, N, wo, wi)
    s = sh.Sheen.sample(params, N, wo, u)
    kind = np.full(n, sh.Sheen.kind, np.int32)
    c_f, c_pdf, c_sample = materials.compiled_bsdf(kind, np.ones((n, 3)), N, params, wo, wi, u)
    np.testing.assert_allclose(c_f, f_cos, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c_pdf, pdf, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c_sample.wi, s.wi, rtol=0, atol=1e-6)       # (float32 cosine, as for every BSDF)
    np.testing.assert_allclose(c_sample.weight, s.weight, rtol=1e-9)


def test_the_lobe_is_cycles_table_at_its_grid_points_and_bilinear_between_them():
    """a, b and R are Cycles' table entries at mu = j / 31, roughness = i / 31 (row i, column j of each plane), the
    mean of the four around the middle of a cell, and no lobe (R = 0) where the table has none (smooth fibres seen
    at grazing angles: |a| or R under 1e-5, which Cycles skips); the compiled kernel reads the same numbers
    (test_the_compiled_lobe_equals_the_reference renders through it)."""
    i, j = np.array([5, 17, 31, 31]), np.array([9, 30, 0, 31])
    p, R = sh.params_of(i / 31.0, j / 31.0)
    np.testing.assert_allclose(p[:, sh.A], sh.LTC_A[i, j], rtol=1e-12)
    np.testing.assert_allclose(p[:, sh.B], sh.LTC_B[i, j], rtol=1e-12)
    np.testing.assert_allclose(R, sh.ALBEDO[i, j], rtol=1e-12)
    p, R = sh.params_of(np.array([17.5 / 31.0]), np.array([9.5 / 31.0]))
    np.testing.assert_allclose(R, sh.ALBEDO[17:19, 9:11].mean(), rtol=1e-12)
    np.testing.assert_allclose(p[:, sh.A], sh.LTC_A[17:19, 9:11].mean(), rtol=1e-12)
    p, R = sh.params_of(np.array([0.0]), np.array([0.5]))     # roughness 1e-3 (clamped), mu 0.5: no valid lobe
    assert sh.ALBEDO[0, 15] < sh.INVALID and R[0] == 0.0 and np.isfinite(p).all()
    assert 0.0 <= sh.ALBEDO.min() and sh.ALBEDO.max() <= 1.0


def test_a_principled_bsdf_without_sheen_is_unchanged():
    """Sheen Weight 0 (whatever its roughness and tint) sets up exactly the closures of a Principled BSDF with no
    sheen inputs at all, on a spread of inputs and views."""
    rng = np.random.default_rng(8)
    n = 64
    N = np.tile(UP, (n, 1))
    wo = np.array([direction(m, p) for m, p in rng.uniform((0.01, 0.0), (1.0, 2 * math.pi), (n, 2))])
    inputs = {"base_color": (0.6, 0.3, 0.2), "metallic": 0.3, "roughness": 0.4, "coat": 0.5, "transmission": 0.2,
              "diffuse_roughness": 0.3}
    plain = nodes.shade_nodes([(nodes.PrincipledNode, np.ones(3), nodes.PrincipledNode.row(inputs))], N, wo)
    zero = nodes.PrincipledNode.row({**inputs, "sheen": 0.0, "sheen_roughness": 0.9, "sheen_tint": (0.1, 0.2, 0.3)})
    with_zero = nodes.shade_nodes([(nodes.PrincipledNode, np.ones(3), zero)], N, wo)
    for a, b in zip(plain.closures, with_zero.closures):
        np.testing.assert_array_equal(a, b)
    assert materials.Sheen.kind not in plain.closures.kind


def sheen_scene() -> Scene:
    """Spheres, a box and a floor under a point light and a sun, in five sheen materials: a tinted Principled sheen
    with a coat, one whose normal a bump turns (the sheen normal mixed towards the hit's by the coat), a Sheen
    BSDF, a Sheen BSDF mixed with a diffuse, and an Ashikhmin (velvet) Sheen BSDF with a bumped normal."""
    scene = Scene(camera=Camera.look_at((0.5, -5.0, 3.0), (0.0, 0.0, 0.4), fov=math.radians(45)),
                  world_color=np.array([0.05, 0.06, 0.07]))
    uv = GraphNode("TEXCOORD", {}, {})
    height = Link(GraphNode("MATH", {"operation": "SINE"}, {"0": Link(GraphNode("SEPARATE_XYZ", {}, {
        "Vector": Link(uv, "Object")}), "X")}), "Value")
    bumped = Link(GraphNode("BUMP", {"invert": False}, {"Height": height, "Distance": 0.5, "Strength": 1.0}), "Normal")
    scene.materials = [
        Material(name="Velvet", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {
            "base_color": (0.3, 0.05, 0.1), "sheen": 1.0, "sheen_tint": (1.0, 0.6, 0.8), "sheen_roughness": 0.5,
            "coat": 0.4})]),
        Material(name="Bumped", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {
            "base_color": (0.2, 0.3, 0.5), "sheen": 0.8, "sheen_roughness": 0.3, "coat": 0.6, "normal": bumped})]),
        Material(name="Sheen", nodes=[("SHEEN", (0.9, 0.8, 0.7), {"roughness": 0.7})]),
        Material(name="Cloth", nodes=[("SHEEN", (0.5, 0.5, 0.9), {"roughness": 0.2, "normal": bumped}),
                                      ("DIFFUSE", (0.4, 0.2, 0.1), {})]),
        Material(name="Velvet BSDF", nodes=[("SHEEN", (0.8, 0.8, 0.8), {"roughness": 0.8, "velvet": 1.0,
                                                                        "normal": bumped})]),
    ]
    scene.add_mesh(primitives.plane(8.0), materials=np.array([2]))
    scene.add_mesh(primitives.uv_sphere(0.8, 24, 12, center=(-0.9, 0.0, 0.8), smooth=True), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.6, 24, 12, center=(0.8, 0.2, 0.6), smooth=True), materials=np.array([1]))
    scene.add_mesh(primitives.box((0.6, 0.6, 0.6), center=(1.6, 1.4, 0.3)), materials=np.array([3]))
    scene.add_mesh(primitives.uv_sphere(0.5, 24, 12, center=(-0.3, 1.5, 0.5), smooth=True), materials=np.array([4]))
    scene.lights = [PointLight(np.array([1.0, -1.5, 3.0]), power=400.0),
                    SunLight(np.array([0.6, 0.4, -0.3]), strength=2.0, angle=math.radians(5))]
    return scene


@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_sheen_renders_agree_on_both_paths(integrator):
    """The compiled node setup (nodes.c: Principled sheen layer, Sheen node, the coat-mixed normal) renders what
    the Python reference renders, to the compiled path's stated tolerance."""
    scene = sheen_scene()
    settings = RenderSettings(width=48, height=36, samples=4, light_samples=2, integrator=integrator,
                              max_bounces=3)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    # Path tracing carries the velvet's sampled weights (D over the uniform pdf, up to ~100) through a bounce, and
    # with them its direction's float32 cosine: a pixel or two reach 5e-7 there.
    atol = 4e-7 if integrator == "direct" else 1e-6
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=atol)
    assert reference.image[..., :3].mean() > 0.01


@pytest.mark.parametrize("sigma", [0.1, 0.4, 1.0])
def test_the_velvet_facet_distribution_is_normalized(sigma):
    """The inverted Gaussian D(theta_h) = exp(-cot^2 / sigma^2) / (pi sigma^2 sin^4) projects to 1:
    the integral of D cos theta_h over the hemisphere of half-vectors is 1 (substitute u = cot^2 theta_h)."""
    n = 200_000
    theta = (np.arange(n) + 0.5) * (math.pi / 2.0) / n
    inv = 1.0 / (sigma * sigma)
    s, c = np.sin(theta), np.cos(theta)
    D = np.exp(-(c * c / (s * s)) * inv) * inv / (math.pi * s ** 4)
    np.testing.assert_allclose((D * c * s).sum() * (math.pi / 2.0) / n * 2.0 * math.pi, 1.0, rtol=1e-4)


def test_velvet_is_reciprocal():
    """f(wo, wi) = f(wi, wo): D and Cycles' G are symmetric in the two directions (|wo.H| = |wi.H|)."""
    rng = np.random.default_rng(4)
    n = 300
    wo = np.array([direction(m, p) for m, p in rng.uniform((0.02, 0.0), (1.0, 2 * math.pi), (n, 2))])
    wi = np.array([direction(m, p) for m, p in rng.uniform((0.02, 0.0), (1.0, 2 * math.pi), (n, 2))])
    N = np.tile(UP, (n, 1))
    params = vv.params_of(rng.uniform(0.05, 1.0, n))
    f_oi, _ = vv.Velvet.eval(params, N, wo, wi)
    f_io, _ = vv.Velvet.eval(params, N, wi, wo)
    assert (f_oi > 0).mean() > 0.9
    np.testing.assert_allclose(f_oi / wi[:, 2:3], f_io / wo[:, 2:3], rtol=1e-9)


def test_velvet_samples_weigh_to_what_eval_integrates():
    """Uniform hemisphere samples (pdf 1 / 2 pi) with weight f cos / pdf average to the integral of f cos."""
    n = 400_000
    rng = np.random.default_rng(9)
    wo = direction(0.3, 0.4)
    row = vv.params_of(np.array([0.6]))[0]
    s = vv.Velvet.sample(np.tile(row, (n, 1)), np.tile(UP, (n, 1)), np.tile(wo, (n, 1)), rng.random((n, 2)))
    np.testing.assert_allclose(s.pdf, 1.0 / (2.0 * math.pi))
    wi, cell = hemisphere(800)
    k = len(wi)
    f_cos, _ = vv.Velvet.eval(np.tile(row, (k, 1)), np.tile(UP, (k, 1)), np.tile(wo, (k, 1)), wi)
    np.testing.assert_allclose(s.weight.mean(axis=0), f_cos.sum(axis=0) * cell, rtol=5e-3)


def test_compiled_velvet_equals_the_reference():
    """bsdf.c's velvet evaluates and samples as velvet.py does."""
    n = 1000
    rng = np.random.default_rng(6)
    wo = np.array([direction(m, p) for m, p in rng.uniform((0.01, 0.0), (1.0, 2 * math.pi), (n, 2))])
    wi = np.array([direction(m, p) for m, p in rng.uniform((-0.2, 0.0), (1.0, 2 * math.pi), (n, 2))])
    N = np.tile(UP, (n, 1))
    params = vv.params_of(rng.uniform(0.0, 1.0, n))
    u = rng.random((n, 2))
    f_cos, pdf = vv.Velvet.eval(params, N, wo, wi)
    s = vv.Velvet.sample(params, N, wo, u)
    kind = np.full(n, vv.Velvet.kind, np.int32)
    c_f, c_pdf, c_sample = materials.compiled_bsdf(kind, np.ones((n, 3)), N, params, wo, wi, u)
    np.testing.assert_allclose(c_f, f_cos, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c_pdf, pdf, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c_sample.wi, s.wi, rtol=0, atol=1e-6)
    np.testing.assert_allclose(c_sample.weight, s.weight, rtol=1e-5, atol=1e-9)   # (its direction's float32 cosine)


def test_the_sheen_node_sets_up_microfiber_or_velvet():
    """Sheen BSDF: Microfiber gives a sheen closure of colour x R, Ashikhmin a velvet closure of the colour."""
    N = UP[None, :]
    wo = direction(0.5)[None, :]
    color = np.array([0.2, 0.4, 0.6])
    micro = nodes.shade_nodes([(nodes.SheenNode, color, nodes.SheenNode.row({"roughness": 0.3}))], N, wo)
    R = float(sh.params_of(np.array([0.3]), np.array([0.5]))[1][0])
    assert micro.closures.kind[0, 0] == materials.Sheen.kind
    np.testing.assert_allclose(micro.closures.weight[0, 0], color * R)
    velvet = nodes.shade_nodes([(nodes.SheenNode, color, nodes.SheenNode.row({"roughness": 0.3, "velvet": 1.0}))],
                               N, wo)
    assert velvet.closures.kind[0, 0] == materials.Velvet.kind
    np.testing.assert_allclose(velvet.closures.weight[0, 0], color)
    np.testing.assert_allclose(velvet.closures.params[0, 0, vv.INV_SIGMA2], 1.0 / 0.09)


EXPORT = """
import sys
import bpy
from blender_env import report
sys.path.insert(0, {tools!r})
from render import load_primer
primer = load_primer()
materials_ = sys.modules[primer.__name__ + ".addon.materials"]
graph = sys.modules[primer.__name__ + ".core.materials.graph"]
bpy.ops.wm.read_factory_settings(use_empty=True)


def material(name, kind):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    tree = m.node_tree
    for node in list(tree.nodes):
        if node.bl_idname != "ShaderNodeOutputMaterial":
            tree.nodes.remove(node)
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    node = tree.nodes.new(kind)
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    return m, tree, node


result = {{}}
m, tree, principled = material("Velvety", "ShaderNodeBsdfPrincipled")
principled.inputs["Sheen Weight"].default_value = 0.7
principled.inputs["Sheen Roughness"].default_value = 0.3
tint = tree.nodes.new("ShaderNodeRGB")
tint.outputs[0].default_value = (0.9, 0.5, 0.2, 1.0)
tree.links.new(tint.outputs[0], principled.inputs["Sheen Tint"])
warnings = []
nodes = materials_.export_material(m, warnings).nodes
result["principled"] = [nodes[0][0], float(nodes[0][2]["sheen"]), float(nodes[0][2]["sheen_roughness"]),
                        "link" if isinstance(nodes[0][2]["sheen_tint"], graph.Link)
                        else list(map(float, nodes[0][2]["sheen_tint"]))[:3]]
for distribution in ("MICROFIBER", "ASHIKHMIN"):
    m, tree, sheen = material(distribution.title(), "ShaderNodeBsdfSheen")
    sheen.distribution = distribution
    sheen.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    sheen.inputs["Roughness"].default_value = 0.25
    nodes = materials_.export_material(m, warnings).nodes
    result[distribution] = [nodes[0][0], list(map(float, nodes[0][1])), float(nodes[0][2]["roughness"]),
                            float(nodes[0][2]["velvet"])]
report(result=result, warnings=warnings)
"""


@pytest.mark.blender
def test_blender_sheen_inputs_and_sheen_bsdfs_are_read_without_warnings(tmp_path):
    """The addon reads the Principled BSDF's Sheen Weight, Roughness and (linked) Tint, and the Sheen BSDF's
    colour, roughness and distribution (Microfiber or Ashikhmin), with no warning."""
    import importlib.util
    import os
    if importlib.util.find_spec("bpy") is None:
        pytest.skip("bpy (Blender as a Python module) is not installed")
    from blender_env import ROOT, run_bpy
    report = run_bpy(EXPORT.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    result = report["result"]
    assert result["principled"][0] == "PRINCIPLED"
    # The RGB node feeding the tint: a link, or its colour where the reader folds a constant node.
    assert result["principled"][3] == "link" or np.allclose(result["principled"][3], [0.9, 0.5, 0.2], rtol=1e-6)
    np.testing.assert_allclose(result["principled"][1:3], [0.7, 0.3], rtol=1e-6)
    for distribution, velvet in (("MICROFIBER", 0.0), ("ASHIKHMIN", 1.0)):
        name, weight, roughness, flag = result[distribution]
        assert name == "SHEEN" and flag == velvet
        np.testing.assert_allclose(weight, [0.2, 0.4, 0.6], rtol=1e-6)
        assert roughness == pytest.approx(0.25)
    assert report["warnings"] == []
