"""The Translucent BSDF (core/materials/translucent.py), added with one class, one C file and one registry line:
its closed forms, and that the integrators, the passes and the path's bounce counting treat it as its flags say
(transmission, labelled diffuse, of the diffuse type) without naming it anywhere."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import materials
from core.camera import Camera
from core.geometry import primitives
from core.integrators import path, rays, vertex
from core.lights import SunLight
from core.materials import Material
from core.materials.translucent import Translucent
from core.render import render
from core.scene import RenderSettings, Scene
from core.visibility import HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION

UP = np.array([0.0, 0.0, 1.0])


def rows(n, vector):
    """n copies of a (3,) vector."""
    return np.tile(np.asarray(vector, np.float64), (n, 1))


def test_it_lets_light_through_as_a_lambert_surface_turned_round():
    """f cos = max(-N.wi, 0) / pi: nothing for light on the viewer's side, cos / pi from the far side; the pdf of
    its cosine-weighted sampling is the same, so a sample's weight is exactly 1."""
    rng = np.random.default_rng(7)
    wi = rng.normal(size=(500, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    f_cos, pdf = Translucent.eval(None, rows(500, UP), rows(500, UP), wi)
    expected = np.maximum(-wi[:, 2], 0.0) / math.pi
    np.testing.assert_allclose(f_cos, np.repeat(expected[:, None], 3, axis=1), rtol=1e-15)
    np.testing.assert_allclose(pdf, expected, rtol=1e-15)
    s = Translucent.sample(None, rows(500, UP), rows(500, UP), rng.random((500, 2)))
    assert (s.wi[:, 2] <= 0.0).all()                              # every sample goes through, to the far side
    np.testing.assert_allclose(s.pdf, -s.wi[:, 2] / math.pi, rtol=1e-12)
    np.testing.assert_array_equal(s.weight[s.pdf > 0], 1.0)


def test_a_white_sheet_lets_through_all_the_light_it_receives():
    """The white furnace, through the sheet: f cos integrates to 1 over the far hemisphere (midpoint rule)."""
    n = 400
    mu = (np.arange(n) + 0.5) / n
    phi = (np.arange(2 * n) + 0.5) * (math.pi / n)
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - M * M)
    wi = np.stack([s * np.cos(P), s * np.sin(P), -M], axis=-1).reshape(-1, 3)
    f_cos, _ = Translucent.eval(None, rows(len(wi), UP), rows(len(wi), UP), wi)
    np.testing.assert_allclose(f_cos.sum(axis=0) * (1.0 / n) * (math.pi / n), 1.0, rtol=1e-5)


def test_its_bounces_count_as_transmission_but_labelled_diffuse():
    """As Cycles' path_state_next counts a LABEL_TRANSMIT | LABEL_DIFFUSE direction: a transmission bounce (not a
    diffuse one), the caustics switches apply after it (labelled diffuse), and its ray is a transmission ray,
    even where the ray leaves on the viewer's side of the face; a Lambert's is a diffuse bounce and a diffuse ray."""
    kind = np.array([Translucent.kind, Translucent.kind, materials.Lambert.kind])
    transmit = np.array([True, False, False])
    diffuse, glossy, transmission, transparent, labelled = path.bounce_kind(kind, transmit)
    np.testing.assert_array_equal(diffuse, [False, False, True])
    np.testing.assert_array_equal(glossy, [False, False, False])
    np.testing.assert_array_equal(transmission, [True, True, False])
    np.testing.assert_array_equal(transparent, [False, False, False])
    np.testing.assert_array_equal(labelled, [True, True, True])
    np.testing.assert_array_equal(rays.ray_kind(kind, transmit, 0),
                                  [HIDDEN_FROM_TRANSMISSION, HIDDEN_FROM_TRANSMISSION, HIDDEN_FROM_DIFFUSE])


def test_a_light_hidden_from_diffuse_rays_leaves_it_out_as_cycles_does():
    """Its closure type is diffuse (CLOSURE_IS_BSDF_DIFFUSE): an emitter hidden from diffuse rays lights it not,
    one hidden from glossy or transmission rays does (Cycles' _surface_shader_exclude)."""
    kind = np.full((3, 1), Translucent.kind)
    hidden = np.array([HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION])
    np.testing.assert_array_equal(vertex.closures_left_out(kind, hidden)[:, 0], [True, False, False])


def sheet_lit_from_below(albedo, strength, elevation_deg, kernels):
    """A horizontal translucent sheet seen from above, a sun below it at `elevation_deg` under the horizon."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    camera = Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=10.0)
    scene = Scene(camera=camera)
    scene.materials.append(Material(name="Sheet", nodes=[("TRANSLUCENT", np.asarray(albedo, np.float64), {})]))
    scene.add_mesh(primitives.plane(20.0))
    e = math.radians(elevation_deg)
    towards_sun = np.array([math.cos(e), 0.0, -math.sin(e)])
    scene.lights.append(SunLight(direction=-towards_sun, strength=strength))
    settings = RenderSettings(width=6, height=4, samples=4, kernels=kernels,
                              passes=("diffuse_direct", "diffuse_color", "transmission_direct"))
    return render(scene, settings)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_a_sheet_lit_from_behind_glows_with_albedo_over_pi_times_the_irradiance(kernels):
    """Seen from above, a sheet lit by a sun below it sends albedo / pi x S x sin(e) towards the camera (the light
    sample from behind counts because the closure transmits and is no delta); that light is Diffuse Direct (its
    closure type), the Diffuse Color pass holds the albedo, and Transmission Direct holds none of it."""
    albedo, strength = np.array([0.7, 0.5, 0.2]), 3.0
    result = sheet_lit_from_below(albedo, strength, 40.0, kernels)
    expected = albedo / math.pi * strength * math.sin(math.radians(40.0))
    np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(expected, (4, 6, 3)), rtol=1e-6)
    np.testing.assert_allclose(result.aux["diffuse_color"], np.broadcast_to(albedo, (4, 6, 3)), rtol=1e-6)
    np.testing.assert_allclose(result.aux["diffuse_direct"] * result.aux["diffuse_color"], result.image[..., :3],
                               rtol=1e-5)
    np.testing.assert_array_equal(result.aux["transmission_direct"], 0.0)


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_light_behind_the_smooth_normal_but_in_front_of_the_face_is_blocked_by_the_surface_itself(kernels):
    """A smooth sheet whose corner normals lean 30 degrees off its face, a sun 75 degrees from the face on the other
    side: the light is in front of the face (Ng.L = cos 75) but behind the shading normal (N.L = cos 105), where the
    translucent closure takes it. Cycles' shadow_ray_offset (terminator fix, Geometry Offset 0.1) casts that ray from
    the surface's back without skipping its own triangle: the sheet itself blocks it, black. With Geometry Offset 0
    the ray leaves from the front and escapes: albedo / pi x S x |N.L|. (Issue 32's Hair BSDF Transmission row.)"""
    albedo, strength = np.array([0.7, 0.5, 0.2]), 3.0
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=10.0))
    scene.materials.append(Material(name="Sheet", nodes=[("TRANSLUCENT", albedo, {})]))
    a, b = math.radians(30.0), math.radians(75.0)
    sheet = primitives.plane(20.0)
    sheet.smooth[:] = True
    sheet.corner_normals = np.tile([math.sin(a), 0.0, math.cos(a)], (2, 3, 1))
    scene.add_mesh(sheet)
    scene.lights.append(SunLight(direction=-np.array([-math.sin(b), 0.0, math.cos(b)]), strength=strength))
    settings = RenderSettings(width=6, height=4, samples=4, kernels=kernels, terminator_fix=True)
    np.testing.assert_array_equal(render(scene, settings).image[..., :3], 0.0)
    settings.terminator_offset = 0.0
    expected = albedo / math.pi * strength * abs(math.cos(a + b))
    np.testing.assert_allclose(render(scene, settings).image[..., :3], np.broadcast_to(expected, (4, 6, 3)),
                               rtol=1e-6)
