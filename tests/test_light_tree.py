"""The light tree that picks an emissive triangle for a shading point (core/lights/light_tree.py, emitters.c).

The pick probabilities of all triangles sum to one wherever the point is; a triangle that can light the
point is never left out (the estimate stays unbiased); sampling follows the probabilities; a BSDF ray's
MIS pdf (pdf_of_hits) is the probability the sample gave; C picks what Python picks; and the irradiance
many emitters give a point converges to Lambert's closed form for polygons.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.lights import MeshEmitters
from core.lights.light_tree import CENTRE, CYCLES, DIAGONAL, HALF, LEFT, POWER, RIGHT, UPPER, importance
from core.native import library


def scattered_emitters(count: int, seed: int, sides=None) -> MeshEmitters:
    """`count` small triangles of random power and orientation spread over a 4 m box."""
    rng = np.random.default_rng(seed)
    corners = rng.random((count, 1, 3)) * 4.0 + rng.normal(size=(count, 3, 3)) * 0.1
    emission = rng.random((count, 3)) ** 3 * 10.0
    sides = rng.integers(1, 4, count) if sides is None else np.full(count, sides)
    return MeshEmitters.of(corners, emission, sides.astype(np.int32), np.arange(count) * 3)


def random_receivers(n: int, seed: int, unknown: float = 0.25):
    """Points (n, 3) in and around the emitters' box, unit normals (n, 3), a share of them unknown (zero)."""
    rng = np.random.default_rng(seed)
    P = rng.random((n, 3)) * 6.0 - 1.0
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    N[rng.random(n) < unknown] = 0.0
    return P, N


def all_pick_probabilities(emitters: MeshEmitters, P: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Every triangle's pick probability from each point, by enumerating the tree's branches: (n, t)."""
    return emitters.tree.all_pick_probabilities(P, N)


def test_every_node_bounds_its_triangles_and_their_orientations():
    """Each node's box holds the corners of every triangle below it, its power is theirs summed, and its
    orientation cone holds each one's sampled-side normal (theta_o = pi above a two-sided triangle)."""
    emitters = scattered_emitters(400, 19)
    tree = emitters.tree
    assert len(tree.nodes) == 2 * 400 - 1
    power = emitters.area * emitters.emission.mean(axis=1)
    axis = np.where((emitters.sides == 2)[:, None], -emitters.normal, emitters.normal)
    energy = np.zeros(len(tree.nodes))
    for i in range(400):
        node = 0
        for level in range(tree.depth[i] + 1):
            row = tree.nodes[node]
            assert (emitters.corners[i] >= row[0:3]).all() and (emitters.corners[i] <= row[3:6]).all()
            angle = math.acos(min(max(float(row[6:9] @ axis[i]), -1.0), 1.0))
            assert angle <= row[9] + 1e-6 and (emitters.sides[i] != 3 or row[9] == math.pi)
            energy[node] += power[i]
            if level < tree.depth[i]:
                node = int(row[RIGHT] if (tree.path[i] >> level) & 1 else row[LEFT])
        assert row[RIGHT] == -1 and -1 - row[LEFT] == i
    np.testing.assert_allclose(tree.nodes[:, 11], energy, rtol=1e-12)


def test_every_nodes_centre_and_diagonal_are_its_boxs():
    """The centre, diagonal and half-diagonal length each node row carries for the importance (made once at the
    build) are its box's: (lo + hi) / 2, hi - lo and |hi - lo| / 2, bit for bit as the importance made them per step."""
    nodes = scattered_emitters(64, 23).tree.nodes
    lo, hi = nodes[:, 0:3], nodes[:, 3:6]
    assert (nodes[:, CENTRE:CENTRE + 3] == 0.5 * (lo + hi)).all()
    assert (nodes[:, DIAGONAL:DIAGONAL + 3] == hi - lo).all()
    np.testing.assert_allclose(nodes[:, HALF], 0.5 * np.linalg.norm(hi - lo, axis=1), rtol=1e-15)
    assert (nodes[:, HALF] > 0.0).all() and (nodes[:, HALF] >= 0.5 * np.abs(hi - lo).max(axis=1)).all()


@pytest.mark.parametrize("rule", [CYCLES, UPPER, POWER])
def test_pick_probabilities_of_all_triangles_sum_to_one(rule):
    """Whatever the point and normal (known or not, inside the emitters' boxes or far away), the
    probabilities of the tree's leaves sum to one, and the path walk gives each leaf's, whichever the rule."""
    emitters = scattered_emitters(300, 1)
    emitters.tree = emitters.tree.with_rule(rule)
    P, N = random_receivers(200, 2)
    probability = all_pick_probabilities(emitters, P, N)
    np.testing.assert_allclose(probability.sum(axis=1), 1.0, rtol=1e-12)
    rows = np.repeat(np.arange(len(P)), 5)
    index = np.random.default_rng(3).integers(0, 300, len(rows))
    np.testing.assert_allclose(emitters.pick_probability(P[rows], index, N[rows]), probability[rows, index],
                               rtol=1e-12)


def test_the_power_rule_picks_each_triangle_by_its_share_of_the_power():
    """LightTree.by_power (the bench's global power CDF): from any point, a triangle's probability is its power over
    the total."""
    emitters = scattered_emitters(200, 22)
    emitters.tree = emitters.tree.by_power()
    P, N = random_receivers(20, 23)
    probability = all_pick_probabilities(emitters, P, N)
    np.testing.assert_allclose(probability, np.tile(emitters.power / emitters.power.sum(), (20, 1)), rtol=1e-9)


def test_a_leafs_lower_importance_bound_never_exceeds_what_its_triangle_sends():
    """The lower bound of a leaf (one triangle, sampled from one side) is at most its mean radiance x Lambert's
    irradiance of it (the integral of cos_i cos_o / r^2 over its area), and never above the upper bound; it is > 0
    for many pairs (a triangle in front of the point, facing it, away from its horizon)."""
    emitters = scattered_emitters(150, 24, sides=1)
    tree = emitters.tree
    P, N = random_receivers(60, 25, unknown=0.0)
    leaf = np.flatnonzero(tree.nodes[:, RIGHT] < 0)
    triangle = (-1 - tree.nodes[leaf, LEFT]).astype(np.int64)
    rows, cols = np.repeat(np.arange(len(P)), len(leaf)), np.tile(np.arange(len(leaf)), len(P))
    upper, lower = importance(P[rows], N[rows], tree.nodes[leaf[cols]])
    assert (lower <= upper).all()
    found = lower > 0.0
    assert found.mean() > 0.05
    sent = np.array([emitters.emission[triangle[c]].mean() * lambert_irradiance(P[r], N[r], emitters.corners[
        triangle[c]][None])[0] for r, c in zip(rows[found], cols[found])])
    assert (lower[found] <= sent * (1.0 + 1e-9)).all()
    assert (lower[found] > 0.05 * sent).mean() > 0.5                  # (and not a vanishing bound)


def test_every_triangle_that_can_light_a_point_may_be_picked():
    """Unbiasedness: a triangle with some point above the receiver's horizon, seen from its sampled side,
    has a pick probability > 0 (the importance never rules out a node that could light the point)."""
    emitters = scattered_emitters(200, 4)
    P, N = random_receivers(150, 5)
    probability = all_pick_probabilities(emitters, P, N)
    rng = np.random.default_rng(6)
    ab = rng.random((64, 2))
    ab = np.where(ab.sum(axis=1, keepdims=True) > 1.0, 1.0 - ab, ab)
    V = emitters.corners
    X = (V[:, None, 0] + ab[None, :, :1] * (V[:, None, 1] - V[:, None, 0])
         + ab[None, :, 1:] * (V[:, None, 2] - V[:, None, 0]))
    X = np.concatenate([X, V], axis=1)                                    # (t, 67, 3) points on each triangle
    to_X = X[None] - P[:, None, None]                                     # (n, t, 67, 3)
    above = (np.einsum("nk,ntsk->nts", N, to_X) > 1e-9) | (np.einsum("nk,nk->n", N, N) == 0.0)[:, None, None]
    height = np.einsum("tk,ntk->nt", emitters.normal, V[None, :, 0] - P[:, None])
    side = np.where(height > 0.0, 2, 1)
    sampled_side = (emitters.sides[None] & side) != 0
    can_light = above.any(axis=2) & sampled_side & (np.abs(height) > 1e-9)
    assert can_light.sum() > 1000
    assert (probability[can_light] > 0.0).all()
    assert (probability[~can_light] == 0.0).mean() > 0.2          # and the tree does leave out what cannot


def test_sampling_follows_the_pick_probabilities():
    """From one point, 40,000 walks down the tree land on each triangle as often as its probability says
    (within 5 standard deviations of the binomial count)."""
    emitters = scattered_emitters(60, 7)
    n = 40_000
    P = np.tile([1.0, 2.0, 0.5], (n, 1))
    N = np.tile([0.0, 0.6, 0.8], (n, 1))
    index, probability, _ = emitters.tree.pick(P, N, np.random.default_rng(8).random(n))
    expected = all_pick_probabilities(emitters, P[:1], N[:1])[0]
    counts = np.bincount(index, minlength=60)
    sigma = np.sqrt(n * expected * (1.0 - expected))
    assert (np.abs(counts - n * expected) <= 5.0 * sigma + 1.0).all()
    np.testing.assert_allclose(probability, expected[index], rtol=1e-12)


def test_a_bsdf_ray_that_hits_an_emitter_gets_the_pdf_the_light_sample_gave():
    """pdf_of_hits (MIS of BSDF rays) equals the pdf `sample` gave the same direction: the same pick
    probability from the same point and normal, times the same direction pdf."""
    emitters = scattered_emitters(120, 9)
    P, N = random_receivers(4000, 10)
    u = np.random.default_rng(11).random((4000, 2))
    sample = emitters.sample(P, u, N=N)
    index, pick, _ = emitters.tree.pick(P, N, u[:, 0])
    np.testing.assert_array_equal(emitters.pick_probability(P, index, N), pick)
    found = sample.pdf > 0.0
    pdf = emitters.pdf_of_hits(P[found], index[found], sample.L[found], sample.distance[found], N=N[found])
    # (Two formulas of the solid angle: they part by up to ~5e-4 where a far triangle's pdf is in the hundreds.)
    assert np.isclose(pdf, sample.pdf[found], rtol=1e-5).mean() > 0.999
    np.testing.assert_allclose(pdf, sample.pdf[found], rtol=1e-3)


def test_one_emissive_triangle_is_a_single_leaf_picked_always():
    """With one triangle the tree is one leaf, picked with probability 1."""
    emitters = MeshEmitters.of(np.array([[[0.0, 0, 1], [1, 0, 1], [0, 1, 1]]]), np.ones((1, 3)),
                               np.array([1], np.int32), np.array([0]))
    assert len(emitters.tree.nodes) == 1
    P, N = random_receivers(10, 12)
    index, probability, _ = emitters.tree.pick(P, N, np.linspace(0.0, 0.99, 10))
    assert (index == 0).all() and (probability == 1.0).all()


def lambert_irradiance(P: np.ndarray, N: np.ndarray, V: np.ndarray) -> np.ndarray:
    """The irradiance per unit radiance a triangle V (t, 3, 3) wholly above the horizon gives point P (3,)
    with normal N (3,): Lambert's polygon formula |sum_k Theta_k (Gamma_k . N)| / 2. (t,) float64"""
    r = V - P
    r = r / np.linalg.norm(r, axis=2, keepdims=True)
    total = np.zeros(len(V))
    for k in range(3):
        a, b = r[:, k], r[:, (k + 1) % 3]
        theta = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))
        gamma = np.cross(a, b)
        gamma /= np.linalg.norm(gamma, axis=1, keepdims=True)
        total += theta * (gamma @ N)
    return 0.5 * np.abs(total)


@pytest.mark.parametrize("known_normal,rule", [(True, UPPER), (False, UPPER), (True, CYCLES)])
def test_many_emitters_light_a_point_by_lamberts_formula(known_normal, rule):
    """300 emitters over a point whose horizon they are all above: the mean of the light samples'
    L_e cos / pdf converges to the sum of the triangles' L_e x Lambert's polygon irradiance (Cycles' rule too)."""
    emitters = scattered_emitters(300, 13, sides=3)
    emitters.tree = emitters.tree.with_rule(rule)
    point, normal = np.array([2.0, 2.0, -1.5]), np.array([0.0, 0.0, 1.0])
    assert (emitters.corners[..., 2] > point[2]).all()
    n = 40_000
    P = np.tile(point, (n, 1))
    N = np.tile(normal, (n, 1)) if known_normal else None
    sample = emitters.sample(P, np.random.default_rng(14).random((n, 3)), N=N)
    estimate = (sample.strength[:, None] * sample.color * np.maximum(sample.L @ normal, 0.0)[:, None]).mean(axis=0)
    exact = (emitters.emission * lambert_irradiance(point, normal, emitters.corners)[:, None]).sum(axis=0)
    np.testing.assert_allclose(estimate, exact, rtol=0.02)


@pytest.mark.skipif(not library.available(), reason="compiled kernels unavailable")
@pytest.mark.parametrize("rule", [CYCLES, UPPER, POWER])
def test_compiled_light_tree_picks_what_the_python_picks(rule):
    """emitters.c walks the same tree: the same triangle for the same number, the same probabilities,
    and the same pick probability along a triangle's path (pdf_of_hits), whichever the rule."""
    from core.lights.emitters import compiled_pick, compiled_pick_probability
    emitters = scattered_emitters(500, 15)
    emitters.tree = emitters.tree.with_rule(rule)
    P, N = random_receivers(5000, 16)
    u = np.random.default_rng(17).random(5000)
    index, probability, _ = emitters.tree.pick(P, N, u)
    found, found_probability = compiled_pick(emitters, P, N, u)
    same = found == index
    assert same.mean() > 0.999
    np.testing.assert_allclose(found_probability[same], probability[same], rtol=1e-9)
    np.testing.assert_allclose(compiled_pick_probability(emitters, P, N, index), probability, rtol=1e-9)


def small_emitters_over_floor(count: int, height: float, albedo: float, seed: int):
    """A floor of albedo `albedo` under `count` small triangles in the plane z = height, some facing down,
    some up, of six radiances, the three dimmest sampled from their front only; the camera sees a tiny
    patch of the floor at the origin. (Scene, corners, radiance per triangle, whether light samples reach
    each from the floor)"""
    from conftest import ortho_down
    from core.geometry import primitives
    from core.scene import Material, Mesh, Scene
    rng = np.random.default_rng(seed)
    scene = Scene(camera=ortho_down(center=(0.0, 0.0, 0.0), height=0.5 * height, scale=0.02))
    floor = scene.add_material((albedo,) * 3)
    scene.add_mesh(primitives.plane(40.0), materials=np.array([floor]))
    radiances = np.geomspace(0.3, 30.0, 6)
    lamps = []
    for k, radiance in enumerate(radiances):
        scene.materials.append(Material(np.zeros(3), f"Lamp {k}", emission=np.full(3, radiance),
                                        emission_sampling="FRONT" if k < 3 else "FRONT_BACK"))
        lamps.append(len(scene.materials) - 1)
    centre = np.column_stack([rng.uniform(-2.0, 2.0, (count, 2)), np.full(count, height)])
    angle = rng.uniform(0.0, 2.0 * math.pi, count)[:, None] + np.array([0.0, 2.0, 4.0]) * math.pi / 3.0
    turn = np.where(rng.random(count) < 0.5, 1.0, -1.0)[:, None]            # counter-clockwise: facing up
    corners = np.stack([centre[:, None, 0] + 0.15 * np.cos(turn * angle),
                        centre[:, None, 1] + 0.15 * np.sin(turn * angle), np.repeat(centre[:, 2:], 3, axis=1)], axis=2)
    which = rng.integers(0, 6, count)
    scene.add_mesh(Mesh(corners.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3), material_indices=which),
                   materials=np.array(lamps))
    sampled_from_below = (which >= 3) | (turn[:, 0] < 0.0)
    return scene, corners, radiances[which], sampled_from_below


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("strategy", ["mis", "light"])
def test_a_floor_under_many_emitters_shows_the_sum_of_their_form_factors(strategy, kernels):
    """Under 60 small emitters in one plane (no one shadows another), a Lambert floor of albedo rho shows
    rho / pi x sum_i L_i E_i, E_i Lambert's polygon irradiance of triangle i: MIS, whose BSDF rays ask the
    tree for the pick probability the light samples gave, converges to it; light samples alone to the sum
    over the triangles sampled from below (the tree leaves out the front-only ones facing up, and only them)."""
    if kernels == "compiled" and not library.available():
        pytest.skip("compiled kernels unavailable")
    from core import render
    from core.scene import RenderSettings
    height, rho = 1.0, 0.5
    scene, corners, radiance, sampled = small_emitters_over_floor(60, height, rho, 18)
    settings = RenderSettings(width=2, height=2, samples=1024, light_samples=4, light_sampling=strategy,
                              kernels=kernels, adaptive=False)
    image = render.render(scene, settings).image
    E = lambert_irradiance(np.zeros(3), np.array([0.0, 0.0, 1.0]), corners)
    counted = np.ones(60, bool) if strategy == "mis" else sampled
    assert 0 < counted.sum() < 60 or strategy == "mis"
    expected = rho / math.pi * (radiance * E)[counted].sum()
    assert image[..., :3].mean() == pytest.approx(expected, rel=0.015)


def quad_irradiance_error(samples: int, receivers: int = 200) -> float:
    """The relative RMS error, over receivers on the floor under a unit emissive quad (two triangles, 1 above),
    of its irradiance per unit radiance estimated from each receiver's first `samples` points of the progressive
    pattern (core/sampling), against Lambert's polygon formula."""
    from core.sampling import sobol as sampling
    quad = np.array([[[-0.5, -0.5, 1.0], [0.5, -0.5, 1.0], [0.5, 0.5, 1.0]],
                     [[-0.5, -0.5, 1.0], [0.5, 0.5, 1.0], [-0.5, 0.5, 1.0]]])
    emitters = MeshEmitters.of(quad, np.ones((2, 3)), np.full(2, 3, np.int32), np.arange(2))
    rng = np.random.default_rng(21)
    P = np.column_stack([rng.uniform(-1.0, 1.0, (receivers, 2)), np.zeros(receivers)])
    N = np.tile([0.0, 0.0, 1.0], (receivers, 1))
    pixel, number = np.repeat(np.arange(receivers), samples), np.tile(np.arange(samples), receivers)
    u = sampling.sample_2d(0, pixel, number, dimension=16)
    s = emitters.sample(P[pixel], u, N=N[pixel])
    cos = np.maximum(s.L[:, 2], 0.0)
    estimate = (s.strength * cos).reshape(receivers, samples).mean(axis=1)
    exact = np.array([lambert_irradiance(p, n, quad).sum() for p, n in zip(P, N)])
    return float(np.sqrt(np.mean((estimate - exact) ** 2) / np.mean(exact ** 2)))


def test_the_triangles_of_an_emissive_quad_share_its_stratified_samples():
    """The number that picks one of a quad's two triangles is reused, rescaled, for the point on it: each
    triangle gets a stratified share of the pixel's pattern, and the irradiance error falls about as 1 / N from
    16 to 256 samples (a smooth integrand, stratified), not as 1 / sqrt(N) (a factor 4), as it does when a
    separate number picks and each triangle gets a random subset of the points."""
    coarse, fine = quad_irradiance_error(16), quad_irradiance_error(256)
    assert coarse < 0.05
    assert coarse / fine > 10.0, (coarse, fine)


def turned_quad_lamp(sides: int) -> MeshEmitters:
    """A 1.3 x 1.05 quad lamp 2.7 above the origin, facing down, turned by 1.5e-7 rad about x and y (as Blender's
    rotations leave a Cornell box's lamp), so that its two triangles' boxes and powers differ in the last bits."""
    a = 1.5e-7
    turn = np.array([[1.0, 0.0, a], [0.0, 1.0, -a], [-a, a, 1.0]])
    square = np.array([[-0.65, -0.5, 2.7], [0.65, -0.5, 2.7], [0.65, 0.55, 2.7], [-0.65, 0.55, 2.7]]) @ turn.T
    quad = square[np.array([[0, 2, 1], [0, 3, 2]])]                    # (clockwise from above: facing down)
    return MeshEmitters.of(quad, np.full((2, 3), 17.0), np.full(2, sides, np.int32), np.arange(2))


@pytest.mark.parametrize("sides", [1, 3])
def test_a_quad_lamps_two_triangles_are_picked_half_and_half_everywhere(sides):
    """The two triangles of a quad lamp are twins to the tree (light_tree.twins): each is picked with probability
    exactly 1/2 from every point, by both kernels, in the walk and in the MIS pdf, and the pick probabilities still
    sum to one (the estimate stays unbiased); triangles that differ are not twins."""
    from core.lights.emitters import compiled_pick, compiled_pick_probability
    from core.lights.light_tree import twins
    emitters = turned_quad_lamp(sides)
    nodes = emitters.tree.nodes
    assert len(nodes) == 3 and twins(nodes[1:2], nodes[2:3]).all()
    assert not (nodes[1, :6] == nodes[2, :6]).all() or nodes[1, 11] != nodes[2, 11]     # (not equal bit for bit)
    P, N = random_receivers(2000, 31)
    probabilities = all_pick_probabilities(emitters, P, N)
    assert (probabilities == 0.5).all()
    u = np.random.default_rng(32).random(2000)
    index, probability, _ = emitters.tree.pick(P, N, u)
    left_triangle = -1 - int(nodes[int(nodes[0, LEFT]), LEFT])
    assert ((index == left_triangle) == (u < 0.5)).all() and (probability == 0.5).all()
    if library.available():
        found, found_probability = compiled_pick(emitters, P, N, u)
        assert (found == index).all() and (found_probability == 0.5).all()
        assert (compiled_pick_probability(emitters, P, N, index) == 0.5).all()
    other = scattered_emitters(2, 33).tree.nodes
    assert not twins(other[1:2], other[2:3]).any()
    # (the build decides it once per inner node, into the TWINS field both kernels' walks read)
    from core.lights.light_tree import TWINS
    assert nodes[0, TWINS] == 1.0 and other[0, TWINS] == 0.0
    many = scattered_emitters(64, 34).tree.nodes
    inner = np.flatnonzero(many[:, RIGHT] >= 0)
    left, right = many[inner, LEFT].astype(np.int64), many[inner, RIGHT].astype(np.int64)
    assert (many[inner, TWINS] == twins(many[left], many[right])).all() and (many[many[:, RIGHT] < 0, TWINS] == 0).all()


def test_a_turned_quad_lamps_irradiance_is_lamberts():
    """Picked half and half, the turned quad lamp's estimate of the irradiance at floor points (each triangle's
    solid-angle sample, 1024 stratified points) converges to Lambert's polygon formula: the estimator's mean."""
    from core.sampling import sobol as sampling
    emitters = turned_quad_lamp(1)
    rng = np.random.default_rng(34)
    receivers, samples = 24, 1024
    P = np.column_stack([rng.uniform(-2.0, 2.0, (receivers, 2)), np.zeros(receivers)])
    N = np.tile([0.0, 0.0, 1.0], (receivers, 1))
    pixel, number = np.repeat(np.arange(receivers), samples), np.tile(np.arange(samples), receivers)
    s = emitters.sample(P[pixel], sampling.sample_2d(0, pixel, number, dimension=16), N=N[pixel])
    estimate = (s.strength * np.maximum(s.L[:, 2], 0.0)).reshape(receivers, samples).mean(axis=1)
    exact = np.array([lambert_irradiance(p, n, emitters.corners).sum() for p, n in zip(P, N)])
    np.testing.assert_allclose(estimate, exact, rtol=2e-3)
