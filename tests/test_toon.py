"""The Toon BSDF (core/materials/toon.py, Cycles' bsdf_toon.h): its closed forms on both kernels, and that its two
components are labelled as Cycles labels them (diffuse and glossy) without being named anywhere else."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.integrators import path
from core.lights import SunLight
from core.materials import Material
from core.materials.toon import DiffuseToon, GlossyToon, params_of
from core.render import render
from core.scene import RenderSettings, Scene

UP = np.array([0.0, 0.0, 1.0])


def rows(n, vector):
    """n copies of a (3,) vector."""
    return np.tile(np.asarray(vector, np.float64), (n, 1))


def hemisphere(n: int = 20000, m: int = 8):
    """Midpoint directions over the upper hemisphere (n m, 3), n cosines by m azimuths, and their solid angle each."""
    mu = (np.arange(n) + 0.5) / n
    phi = (np.arange(m) + 0.5) * (2.0 * math.pi / m)
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - M * M)
    return np.stack([s * np.cos(P), s * np.sin(P), M], axis=-1).reshape(-1, 3), (1.0 / n) * (2.0 * math.pi / m)


@pytest.mark.parametrize("size", [0.3, 0.7, 1.0])
def test_with_smooth_0_it_reflects_all_the_light_it_receives(size):
    """Smooth 0: f cos is the uniform density over the lit cone, so it integrates to 1 over the hemisphere, for the
    Diffuse component and for the Glossy one seen along the normal (its cone around the mirror direction)."""
    wi, dw = hemisphere()
    p = np.repeat(params_of(np.array([size]), np.array([0.0])), len(wi), axis=0)
    for bsdf in (DiffuseToon, GlossyToon):
        f_cos, pdf = bsdf.eval(p, rows(len(wi), UP), rows(len(wi), UP), wi)
        assert f_cos[:, 0].sum() * dw == pytest.approx(1.0, abs=1e-3)
        np.testing.assert_array_equal(f_cos[:, 0], pdf)


def test_its_samples_weigh_the_rim_as_eval_over_pdf():
    """Sampling is uniform over the cone of size + smooth: every sample lies in it, its pdf is eval's, and its weight
    is the intensity, 1 inside Size and falling linearly across Smooth."""
    rng = np.random.default_rng(3)
    n = 2000
    p = np.repeat(params_of(np.array([0.4]), np.array([0.3])), n, axis=0)
    s = DiffuseToon.sample(p, rows(n, UP), rows(n, UP), rng.random((n, 2)))
    angle = np.arccos(np.clip(s.wi[:, 2], -1.0, 1.0))
    assert angle.max() < 0.7 * math.pi / 2 + 1e-9
    f_cos, pdf = DiffuseToon.eval(p, rows(n, UP), rows(n, UP), s.wi)
    np.testing.assert_allclose(s.pdf, pdf, rtol=1e-12)
    expected = np.clip(1.0 - (angle - 0.4 * math.pi / 2) / (0.3 * math.pi / 2), 0.0, 1.0)
    np.testing.assert_allclose(s.weight[:, 0], expected, atol=1e-9)


def plane_under_a_sun(nodes, elevation_deg, kernels, strength=3.0):
    """A horizontal plane of material `nodes` seen straight down by an orthographic camera, a sun at `elevation_deg`."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    camera = Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=10.0)
    scene = Scene(camera=camera)
    scene.materials.append(Material(name="Toon", nodes=nodes))
    scene.add_mesh(primitives.plane(20.0))
    e = math.radians(elevation_deg)
    scene.lights.append(SunLight(direction=-np.array([math.cos(e), 0.0, math.sin(e)]), strength=strength))
    settings = RenderSettings(width=4, height=3, samples=2, kernels=kernels, max_bounces=0,
                              passes=("diffuse_direct", "glossy_direct"))
    return render(scene, settings)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_toon_diffuse_of_size_1_lights_the_hemisphere_uniformly(kernels):
    """Size 1, Smooth 0: f cos = 1 / (2 pi) for any light above the surface, so a sun of strength S gives colour x
    S / (2 pi) whatever its elevation (a Lambert surface would give colour x S sin(e) / pi); all of it Diffuse
    Direct."""
    color = np.array([0.8, 0.5, 0.2])
    for elevation in (10.0, 45.0, 90.0):
        result = plane_under_a_sun([("TOON", color, {"size": 1.0, "smooth": 0.0})], elevation, kernels)
        np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(color * 3.0 / (2 * math.pi), (3, 4, 3)),
                                   rtol=1e-6)
        np.testing.assert_array_equal(result.aux["glossy_direct"], 0.0)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_a_sun_outside_the_toon_cone_lights_nothing_and_inside_it_lights_evenly(kernels):
    """Size 0.5, Smooth 0 (a cone of 45 degrees about the normal): a sun 60 degrees above the horizon (30 from the
    normal) gives S / (2 pi (1 - cos 45)); one 30 degrees above it (60 from the normal) gives nothing. The Glossy
    component, seen along the normal, is the same cone about the normal, its light Glossy Direct."""
    expected = 3.0 / (2 * math.pi * (1 - math.cos(math.pi / 4)))
    for glossy, pass_ in ((0.0, "diffuse_direct"), (1.0, "glossy_direct")):
        nodes = [("TOON", np.ones(3), {"size": 0.5, "smooth": 0.0, "glossy": glossy})]
        lit = plane_under_a_sun(nodes, 60.0, kernels)
        np.testing.assert_allclose(lit.image[..., :3], expected, rtol=1e-6)
        np.testing.assert_allclose(lit.aux[pass_], expected, rtol=1e-6)
        np.testing.assert_array_equal(plane_under_a_sun(nodes, 30.0, kernels).image[..., :3], 0.0)


def test_its_components_bounce_as_diffuse_and_glossy():
    """Cycles labels the Diffuse Toon's directions LABEL_DIFFUSE and the Glossy Toon's LABEL_GLOSSY: a path counts
    them as diffuse and glossy bounces."""
    kind = np.array([DiffuseToon.kind, GlossyToon.kind])
    diffuse, glossy, transmission, _, _ = path.bounce_kind(kind, np.array([False, False]))
    np.testing.assert_array_equal(diffuse, [True, False])
    np.testing.assert_array_equal(glossy, [False, True])
    np.testing.assert_array_equal(transmission, [False, False])
