"""Christensen-Burley subsurface as Cycles' disk projection (core/materials/subsurface.py burley_*, core/integrators/
subsurface.py disk; the compiled twin subsurface.c subsurface_disk), held to closed forms: Burley's profile reflects
its albedo over the plane, the sampled distances follow the profile's density, a white object in a white world keeps
its light, the closure's set-up (Cycles' radius scale, no entry direction that fails, Lambert after a diffuse bounce);
and the two kernels render the same pixels, also where a probe meets more surfaces than Cycles weighs (BSSRDF_MAX_HITS).
The comparison with Cycles' own render is tests/test_blender_subsurface_disk.py."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.geometry import primitives
from core.lights.world import World
from core.materials import Material
from core.materials import subsurface as bssrdf
from core.materials.base import BSDFFlags, has
from core.materials.closures import Closures, ShaderResult
from core.materials.lambert import Lambert
from core.integrators import subsurface as disk_
from core.scene import Mesh, Scene, SunLight

from test_subsurface import SETTINGS, assert_same_pixels, both_kernels, principled_closures, sphere_scene

def trapezoid(y: np.ndarray, x: np.ndarray) -> float:
    """The trapezoid rule's integral of samples y at points x (numpy's own is named differently across versions)."""
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


BURLEY = {"base_color": (0.8, 0.5, 0.3), "subsurface": 1.0, "subsurface_scale": 0.3,
          "subsurface_method": bssrdf.BURLEY}


def test_burleys_profile_reflects_its_albedo_over_the_plane():
    """Burley's R(r) = A (e^(-r/d) + e^(-r/3d)) / (8 pi d r): the integral of 2 pi r R(r) dr over the plane is the
    albedo A; burley_radial is 2 pi r R(r) / A up to 16 d and 0 beyond, integrating to 1 - e^-16/4 - 3 e^(-16/3)/4
    (Cycles' BURLEY_TRUNCATE_CDF); the sampling density (its truncated form) integrates to 1."""
    A = 0.7
    for d in (0.01, 0.3, 2.0):
        r = np.linspace(0.0, 60.0 * d, 600001)[1:]
        R = A * (np.exp(-r / d) + np.exp(-r / (3.0 * d))) / (8.0 * math.pi * d * r)
        r0 = np.concatenate([[0.0], r])                     # (2 pi r R(r) -> A / (2 d) at r = 0)
        assert trapezoid(np.concatenate([[A / (2.0 * d)], 2.0 * math.pi * r * R]), r0) == pytest.approx(A, abs=1e-6)
        cut = bssrdf.burley_radial(d, r)
        inside = r < 16.0 * d
        np.testing.assert_allclose(cut[inside], (2.0 * math.pi * r * R / A)[inside], rtol=1e-12)
        assert not cut[~inside].any()
        assert trapezoid(bssrdf.burley_radial(d, r0), r0) == pytest.approx(bssrdf.BURLEY_TRUNCATE_CDF, abs=1e-6)
        assert bssrdf.BURLEY_TRUNCATE_CDF == pytest.approx(1.0 - math.exp(-16.0) / 4.0 - 0.75 * math.exp(-16.0 / 3.0),
                                                            abs=1e-12)
        pdf = np.concatenate([[1.0 / (2.0 * d * bssrdf.BURLEY_TRUNCATE_CDF)], bssrdf.burley_pdf(d, r)])
        assert trapezoid(pdf, r0) == pytest.approx(1.0, abs=1e-6)


def test_the_root_finder_inverts_the_profiles_cumulative():
    """burley_root(xi) is where the cumulative 1 - e^-x/4 - 3 e^(-x/3)/4 reaches xi, within Newton's 1e-6."""
    xi = np.linspace(0.0, bssrdf.BURLEY_TRUNCATE_CDF, 2001)
    x = bssrdf.burley_root(xi)
    np.testing.assert_allclose(1.0 - np.exp(-x) / 4.0 - 0.75 * np.exp(-x / 3.0), xi, atol=2e-6)


def test_sampled_distances_follow_the_mean_of_the_channels_profiles():
    """burley_sample with three channels (one of radius 0): a channel of the two picked uniformly, the distance from
    its truncated profile: the histogram of r is the mean of the two densities (Cycles' bssrdf_pdf), within 2% where
    it is not small; and the probe's half length h makes h^2 + r^2 = (16 d)^2 of the channel picked."""
    n = 400000
    xi = (np.arange(n) + 0.5) / n
    radius = np.tile([0.2, 0.0, 0.05], (n, 1))
    r, h = bssrdf.burley_sample(radius, xi)
    d = np.where(xi < 0.5, 0.2, 0.05)
    np.testing.assert_allclose(h * h + r * r, (16.0 * d) ** 2, rtol=1e-9)
    edges = np.linspace(0.0, 1.0, 201)
    counts, _ = np.histogram(r, edges)
    density = counts / (n * np.diff(edges))
    centres = 0.5 * (edges[1:] + edges[:-1])
    fine = np.linspace(0.0, 1.0, 20001)
    expected_mean = 0.5 * (bssrdf.burley_pdf(0.2, fine) + bssrdf.burley_pdf(0.05, fine))
    expected = np.array([trapezoid(expected_mean[(fine >= a) & (fine <= b)], fine[(fine >= a) & (fine <= b)])
                         for a, b in zip(edges[:-1], edges[1:])]) / np.diff(edges)
    big = expected > 0.2
    np.testing.assert_allclose(density[big], expected[big], rtol=0.02)
    assert centres[big].max() > 0.5


def test_the_principled_sets_up_burley_as_a_disk_with_cycles_radius_scale_in_every_blender():
    """Christensen-Burley: the BSSRDF closure with DISK set and radius x scale / (4 pi) (bssrdf_setup_radius, also in
    Blender 5.2, whose Random Walk drops that scale); its sample never fails, into the surface (-N)."""
    assert bssrdf.method_of("BURLEY", (5, 0, 1)) == bssrdf.BURLEY
    assert bssrdf.method_of("BURLEY", (5, 2, 0)) == bssrdf.BURLEY
    c = principled_closures(BURLEY)
    k = np.flatnonzero(has(c.kind[0], BSDFFlags.SUBSURFACE))[0]
    p = c.params[0, k]
    assert p[bssrdf.DISK] == 1.0
    np.testing.assert_allclose(p[bssrdf.RADIUS:bssrdf.RADIUS + 3], np.array([1.0, 0.2, 0.1]) * 0.3 / (4.0 * math.pi))
    N = np.array([[0.0, 0.0, 1.0]])
    grazing = np.array([[0.0, 0.6, -0.8]])                # (from below the shading normal: a walk's entry fails)
    s = bssrdf.RandomWalk.sample(c.params[0, k][None, :], N, grazing, np.array([[0.3, 0.6]]))
    assert s.pdf[0] == np.inf and (s.weight == 1.0).all()
    np.testing.assert_allclose(s.wi, -N)


def test_after_a_diffuse_bounce_burley_is_a_lambert_of_its_weight():
    """Cycles' PATH_RAY_DIFFUSE_ANCESTOR rule: at a hit reached after a diffuse bounce the Christensen-Burley closure
    is a Lambert closure of the same weight and normal, sampled by its mean weight; elsewhere (and Random Walk
    always) it stays."""
    burley = principled_closures(BURLEY)
    walk = principled_closures(dict(BURLEY, subsurface_method=bssrdf.RANDOM_WALK))
    both = Closures(*(np.concatenate([a, b]) for a, b in zip(burley[:5], walk[:5])))
    shader = ShaderResult(both, np.zeros((2, 3)), np.zeros((2, 3)), np.tile([[0.0, 0.0, 1.0]], (2, 1)))
    k = np.flatnonzero(has(both.kind[0], BSDFFlags.SUBSURFACE))[0]
    kept = disk_.burley_as_diffuse(shader, np.array([False, True])).closures
    assert has(kept.kind[0, k], BSDFFlags.SUBSURFACE) and has(kept.kind[1, k], BSDFFlags.SUBSURFACE)
    turned = disk_.burley_as_diffuse(shader, np.array([True, True])).closures
    assert turned.kind[0, k] == Lambert.kind and has(turned.kind[1, k], BSDFFlags.SUBSURFACE)
    np.testing.assert_allclose(turned.weight[0, k], both.weight[0, k])
    np.testing.assert_allclose(turned.sample_weight[0, k], both.weight[0, k].mean())


def test_a_white_burley_sphere_in_a_white_world_keeps_all_its_light():
    """White furnace: colour 1, no specular layer; the profile integrates to 1 and the three planes' MIS counts each
    exit once, so every pixel on the sphere sees the world's 1 (within the noise of 64 samples)."""
    scene = sphere_scene({"base_color": (1.0, 1.0, 1.0), "subsurface": 1.0, "subsurface_scale": 0.3,
                          "subsurface_method": bssrdf.BURLEY, "specular_ior_level": 0.0}, 1.0, sun=False)
    image = render.render(scene, dataclasses.replace(SETTINGS, samples=64)).image[..., :3]
    np.testing.assert_allclose(image[3:9, 3:9].mean(axis=(0, 1)), 1.0, atol=0.03)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_white_burley_sphere_keeps_all_its_light_seen_from_far_away(kernels):
    """The white furnace with the camera 24 away (framing the sphere as from near): Primer renders camera-relative,
    so the sphere is ~24 from the origin in Embree's float32 and a probe's step past a surface (tiny radii: Scale
    0.05) must not meet the same triangle again. Every pixel sees the world's 1 in both kernels, as from 2 away
    (counted twice, it read up to 1.75)."""
    for distance in (2.0, 24.0):
        scene = Scene(camera=Camera.look_at((0.0, -distance, 0.0), (0.0, 0.0, 0.0),
                                            fov=2.0 * math.atan(0.5 / distance)), world=World(color=np.ones(3)))
        scene.materials = [Material(name="White", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {
            "base_color": (1.0, 1.0, 1.0), "subsurface": 1.0, "subsurface_scale": 0.05,
            "subsurface_method": bssrdf.BURLEY, "specular_ior_level": 0.0})])]
        scene.add_mesh(primitives.uv_sphere(0.4, 32, 16, smooth=True), materials=np.array([0]))
        image = render.render(scene, dataclasses.replace(SETTINGS, samples=64, kernels=kernels)).image[..., :3]
        np.testing.assert_allclose(image[3:9, 3:9].mean(axis=(0, 1)), 1.0, atol=0.03)


def plates(count: int = 6) -> Mesh:
    """`count` thin parallel plates (1.6 x 0.02 x 1.6, 0.05 apart along y) as one mesh: a chord across them meets
    2 x count faces."""
    boxes = [primitives.box((1.6, 0.02, 1.6), center=(0.0, 0.05 * i, 0.0)) for i in range(count)]
    vertices = np.concatenate([b.vertices for b in boxes])
    triangles = np.concatenate([b.triangles + 8 * i for i, b in enumerate(boxes)])
    return Mesh(vertices, triangles, name="Plates")


@pytest.mark.parametrize("integrator", ["path", "direct"])
@pytest.mark.parametrize("inputs", [BURLEY, dict(BURLEY, subsurface_radius=(1.0, 0.0, 0.3))],
                         ids=["burley", "one-channel-diffuse"])
def test_both_kernels_project_a_burley_sphere_to_the_same_pixels(inputs, integrator):
    """The compiled disk projection (subsurface.c subsurface_disk) draws the reference's numbers: the same pixels on a
    sphere lit by a sun and the world, also with a channel of radius 0 (a Lambert beside the BSSRDF); no warning."""
    reference, compiled = both_kernels(sphere_scene(inputs, 0.2, sun=True), integrator=integrator)
    assert_same_pixels(reference, compiled)
    assert not compiled.stats.warnings


def test_both_kernels_agree_where_a_probe_meets_more_surfaces_than_cycles_weighs():
    """Six thin plates as one object (a chord across meets 12 faces, more than BSSRDF_MAX_HITS 4: a window of 4 from
    a random start, each counting 12 / 4), a radius of several plates, lit from behind; path traced, so exits bounce
    onto the neighbouring plates, where Christensen-Burley is a Lambert (a diffuse ancestor). Both kernels agree,
    and light comes through."""
    scene = Scene(camera=Camera.look_at((0.0, -4.0, 0.0), (0.0, 0.0, 0.0), fov=math.radians(30)),
                  world=World(color=np.full(3, 0.05)))
    scene.materials = [Material(name="Leaves", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0),
                                                        dict(BURLEY, subsurface_scale=2.0, base_color=(0.4, 0.8, 0.2)))])]
    scene.add_mesh(plates(), materials=np.array([0]))
    scene.lights = [SunLight(np.array([0.0, -1.0, 0.2]), strength=3.0)]
    reference, compiled = both_kernels(scene, samples=8)
    assert_same_pixels(reference, compiled)
    assert compiled.image[4:6, 4:6, 1].mean() > 0.01
