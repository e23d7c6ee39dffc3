"""A pane of smooth Glass mixed with Transparent (issue 34, the BMW27's windows): one stratified number chooses the
closure and the glass's lobe, as Cycles' rand_bsdf.z does, so the mix is no noisier than its expectation needs."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.geometry import primitives
from core.materials import Glass, Material, MaterialTable, Transparent
from core.materials import sample_closures
from core.scene import RenderSettings, Scene, World

IOR = 3.0
R_NORMAL = ((IOR - 1.0) / (IOR + 1.0)) ** 2          # Fresnel reflectance at normal incidence: 0.25


def pane_nodes(glass: float) -> list:
    """The windows' material: `glass` Glass (IOR 3, roughness 0) + 1 - glass Transparent, white."""
    nodes = [("GLASS", glass * np.ones(3), {"ior": IOR, "roughness": 0.0})]
    return nodes + ([("TRANSPARENT", (1.0 - glass) * np.ones(3), {})] if glass < 1.0 else [])


def pane_under_the_sky(glass: float) -> Scene:
    """The pane filling an orthographic camera's view from 3 above, under a white world, a black floor 1 below it:
    only the glass's reflection brings light back, 0.2 R at normal incidence for glass = 0.2."""
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 3.0)
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=1.0), world=World(color=np.ones(3)))
    scene.materials.append(Material(np.zeros(3), "Pane", nodes=pane_nodes(glass)))
    scene.materials.append(Material(np.zeros(3), "Black"))
    scene.add_mesh(primitives.plane(4.0), materials=np.array([0]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, -1.0)), materials=np.array([1]))
    return scene


def test_a_glass_mixed_with_transparent_reflects_exactly_where_the_closure_pick_falls_in_its_reflected_share():
    """Glass 0.2 + Transparent 0.8 seen head-on: a pick p below 0.2 R reflects (weight 0.2 R / (0.2 R) = 1: the
    glass's share over the probability of choosing it, 0.2, and its reflection, R / (R + T) = R), between 0.2 R and 0.2
    refracts, above 0.2 passes straight through (weight 1), whatever the direction numbers u: of n stratified picks,
    exactly n 0.2 R reflect, and the estimate of the reflected light is 0.2 R with no error."""
    n = 1000
    N = np.tile([0.0, 0.0, 1.0], (n, 1))
    shaded = MaterialTable.of([Material(np.zeros(3), "Pane", nodes=pane_nodes(0.2))]).shade(np.zeros(n, np.int32), N, N)
    pick = (np.arange(n) + 0.5) / n
    u = np.random.default_rng(34).random((n, 2))
    s = sample_closures(shaded.closures, N, u, pick)
    reflected = s.wi[:, 2] > 0.0
    np.testing.assert_array_equal(reflected, pick < 0.2 * R_NORMAL)
    np.testing.assert_array_equal(s.kind == Transparent.kind, pick >= 0.2)
    np.testing.assert_array_equal(s.kind[pick < 0.2], Glass.kind)
    np.testing.assert_allclose(s.weight[reflected], 1.0, rtol=1e-12)
    assert reflected.sum() == round(n * 0.2 * R_NORMAL)
    assert s.weight[reflected].sum() / n / 3 == pytest.approx(0.2 * R_NORMAL, rel=1e-12)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_pane_of_glass_and_transparent_is_as_bright_as_its_glass_share_and_no_noisier_than_stratified(kernels):
    """The pane under the sky at 64 samples: every pixel's mean 0.2 R = 0.05 (the closed form), and the pixels' spread
    well below the 0.025 that an independent choice of the glass's lobe gave (the binomial sqrt(0.05 x 0.95 / 64) =
    0.027; now 0.0062; glass alone: 0, its 16 reflections of 64 stratified)."""
    image = render.render(pane_under_the_sky(0.2), RenderSettings(width=32, height=32, samples=64, kernels=kernels,
                                                                  integrator="path")).image[..., :3]
    value = image.mean(axis=2)
    assert value.mean() == pytest.approx(0.2 * R_NORMAL, rel=0.01)
    assert value.std() < 0.012
    alone = render.render(pane_under_the_sky(1.0), RenderSettings(width=8, height=8, samples=64, kernels=kernels,
                                                                  integrator="path")).image[..., :3]
    np.testing.assert_allclose(alone, R_NORMAL, rtol=1e-6)


def test_both_kernels_render_the_mixed_pane_alike():
    """Python and C sample the same closures with the same numbers: the same image."""
    settings = RenderSettings(width=16, height=16, samples=16, integrator="path")
    images = [render.render(pane_under_the_sky(0.2), dataclasses.replace(settings, kernels=k)).image
              for k in ("numpy", "compiled")]
    np.testing.assert_allclose(images[0], images[1], atol=1e-9)
