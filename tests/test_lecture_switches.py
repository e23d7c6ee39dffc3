"""The lecture switches: flip one and the image changes exactly as its closed form says.

Each switch defaults to the lecture's choice (core/scene/scene.py, LECTURE_SWITCHES). The scenes are
small and built so that every pixel has a closed form with the switch on and with it off.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ortho_down, pixel_points_on_plane
from core.geometry import primitives
from core import render
from core.integrators import debug
from core.scene import Mesh, PointLight, RenderSettings, Scene, SpotLight, SunLight
from test_debug_views import tilted_quad

ALBEDO = 0.5
W = H = 16


def exact(**kw) -> RenderSettings:
    """Settings for one unjittered sample per pixel at the pixel centre."""
    return RenderSettings(width=W, height=H, samples=1, jitter=False, **kw)


def quad_scene(travel, tilt: float = 40.0) -> tuple[Scene, np.ndarray]:
    """The smooth quad of test_debug_views (N = normalize(x sin b, 0, cos b), face normal +Z) under a sun
    travelling along `travel`, seen from above; return (scene, x of each pixel centre (H, W))."""
    camera = ortho_down(height=1.0, scale=2.0)
    scene = Scene(camera=camera)
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(tilted_quad(tilt))
    scene.lights.append(SunLight(np.asarray(travel, np.float64), strength=2.0))
    return scene, pixel_points_on_plane(camera, W, H, 0.0)[..., 0]


def quad_n_dot_l(x: np.ndarray, L, tilt: float = 40.0) -> np.ndarray:
    """Return N.L on the smooth quad: N = normalize(x sin b, 0, cos b). x: (H, W); L: (3,) -> (H, W)."""
    b = math.radians(tilt)
    return (x * math.sin(b) * L[0] + math.cos(b) * L[2]) / np.sqrt((x * math.sin(b)) ** 2 + math.cos(b) ** 2)


@pytest.mark.parametrize("light_type", ["point", "spot"])
def test_without_distance_attenuation_a_point_light_gives_P_over_4pi(light_type):
    """Point light of power P at height h over a plane: E = P/(4 pi) cos(theta) / r^2; with distance
    attenuation off, E = P/(4 pi) cos(theta) at every distance: brighter wherever r > 1."""
    P, h = 300.0, 2.0
    camera = ortho_down(height=1.0, scale=6.0)
    scene = Scene(camera=camera)
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(primitives.plane(20.0))
    position = np.array([0.3, -0.2, h])
    if light_type == "point":
        scene.lights.append(PointLight(position, power=P))
    else:
        scene.lights.append(SpotLight(position, np.array([0.0, 0.0, -1.0]), power=P, spot_size=math.radians(170),
                                      spot_blend=0.0))
    w = pixel_points_on_plane(camera, W, H, 0.0) - position
    r = np.linalg.norm(w, axis=2)
    cos_theta = h / r
    on = render.render(scene, exact()).image[..., 0]
    off = render.render(scene, exact(distance_attenuation=False)).image[..., 0]
    np.testing.assert_allclose(on, ALBEDO / math.pi * P / (4 * math.pi) * cos_theta / r ** 2, rtol=1e-5)
    np.testing.assert_allclose(off, ALBEDO / math.pi * P / (4 * math.pi) * cos_theta, rtol=1e-5)
    assert np.all(off > on)


def test_distance_attenuation_does_not_touch_the_sun():
    """A sun has no distance to attenuate by: the switch leaves its image unchanged."""
    scene, _ = quad_scene([0.3, 0.0, -1.0])
    a = render.render(scene, exact()).image
    b = render.render(scene, exact(distance_attenuation=False)).image
    np.testing.assert_array_equal(a, b)


def test_without_the_clamp_light_from_behind_the_shading_normal_is_negative():
    """On the smooth quad under a low sun from -x, N.L < 0 where x > tan(e)/tan(b) while the face still
    faces the sun. Clamped (lecture): max(N.L, 0); unclamped: N.L, negative radiance there."""
    e = math.radians(20.0)
    L = np.array([-math.cos(e), 0.0, math.sin(e)])             # towards the sun
    scene, x = quad_scene(-L)
    NL = quad_n_dot_l(x, L)
    assert (NL < 0).sum() > 20 and (NL > 0).sum() > 20
    clamped = render.render(scene, exact(aux=("n_dot_l",)))
    unclamped = render.render(scene, exact(clamp_n_dot_l=False, aux=("n_dot_l",)))
    np.testing.assert_allclose(clamped.image[..., 0], ALBEDO / math.pi * 2.0 * np.maximum(NL, 0.0), atol=1e-6)
    np.testing.assert_allclose(unclamped.image[..., 0], ALBEDO / math.pi * 2.0 * NL, atol=1e-6)
    np.testing.assert_allclose(unclamped.aux["n_dot_l"][..., 0], NL, atol=1e-6)
    assert unclamped.image[..., 0].min() < -0.05


def test_without_the_clamp_flat_faces_still_get_no_light_from_behind():
    """On a flat face N = Ng, so a light behind N is behind the face too: the visibility check already
    gives it 0, and switching the clamp off changes nothing."""
    scene = Scene(camera=ortho_down(height=1.0, scale=2.0))
    scene.add_mesh(primitives.plane(10.0))
    scene.lights += [SunLight(np.array([0.2, 0.0, 1.0]) / math.sqrt(1.04), strength=1.0),     # from below
                     SunLight(np.array([0.2, 0.0, -1.0]) / math.sqrt(1.04), strength=1.0)]    # from above
    a = render.render(scene, exact()).image
    b = render.render(scene, exact(clamp_n_dot_l=False)).image
    np.testing.assert_array_equal(a, b)


def test_flat_normals_light_the_smooth_quad_evenly():
    """Sun overhead: smooth normals give cos(b) / sqrt(x^2 sin^2 b + cos^2 b); flat normals give 1."""
    scene, x = quad_scene([0.0, 0.0, -1.0])
    NL = quad_n_dot_l(x, np.array([0.0, 0.0, 1.0]))
    smooth = render.render(scene, exact()).image[..., 0]
    flat = render.render(scene, exact(smooth_normals=False)).image[..., 0]
    np.testing.assert_allclose(smooth, ALBEDO / math.pi * 2.0 * NL, rtol=1e-6)
    np.testing.assert_allclose(flat, ALBEDO / math.pi * 2.0, rtol=1e-6)


def test_flat_normals_show_the_facets_of_a_sphere():
    """A smooth low-poly sphere shades continuously; with flat normals each triangle has one value
    (its face normal's N.L), so the image has no more distinct values than triangles."""
    scene = Scene(camera=ortho_down(height=3.0, scale=2.4))
    scene.add_material((ALBEDO,) * 3)
    sphere = primitives.uv_sphere(1.0, 12, 6)
    scene.add_mesh(sphere)
    scene.lights.append(SunLight(np.array([-0.4, -0.3, -1.0]) / math.sqrt(1.25), strength=2.0))
    settings = RenderSettings(width=48, height=48, samples=1, jitter=False, aux=("normal", "face_normal", "depth"))
    smooth = render.render(scene, settings)
    flat = render.render(scene, RenderSettings(**{**settings.__dict__, "smooth_normals": False}))
    hit = smooth.aux["depth"][..., 0] < debug.MISS_DEPTH
    lit = flat.image[..., 0][hit] > 0
    assert len(np.unique(flat.image[..., 0][hit][lit])) <= len(sphere.triangles)
    assert len(np.unique(smooth.image[..., 0][hit][lit])) > 4 * len(sphere.triangles)
    np.testing.assert_array_equal(flat.aux["normal"], flat.aux["face_normal"])


def test_visibility_with_the_shading_normal_leaks_light_from_behind_the_face():
    """A sun below the quad (Ng.L < 0) but where the leaning normals face it (N.L > 0 for x > tan(e)/tan(b)):
    the lecture's face-normal check keeps it dark; the shading-normal check lets the light leak through."""
    e = math.radians(10.0)
    L = np.array([math.cos(e), 0.0, -math.sin(e)])             # towards the sun, below the plane
    scene, x = quad_scene(-L)
    NL = quad_n_dot_l(x, L)
    assert (NL > 0).sum() > 20
    face = render.render(scene, exact()).image[..., 0]
    shading = render.render(scene, exact(visibility_normal="shading")).image[..., 0]
    assert not face.any()
    np.testing.assert_allclose(shading, ALBEDO / math.pi * 2.0 * np.maximum(NL, 0.0), atol=1e-6)


def wall_and_floor() -> tuple[Scene, np.ndarray, np.ndarray]:
    """A floor (z = 0, x in [0, 4]) and a wall (x = 0, facing +x) with a 100 W point light sitting on
    the wall, 1 above the floor; seen from above. Return (scene, pixel points on the floor, light point)."""
    camera = ortho_down(center=(2.0, 0.0, 0.0), height=1.0, scale=3.0)
    scene = Scene(camera=camera)
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(primitives.plane(4.0, 10.0, center=(2.0, 0.0, 0.0)))
    scene.add_mesh(Mesh(np.array([[0.0, -5.0, 0.0], [0.0, 5.0, 0.0], [0.0, 5.0, 5.0], [0.0, -5.0, 5.0]]),
                        np.array([[0, 1, 2], [0, 2, 3]])))
    light = np.array([0.0, 0.0, 1.0])
    scene.lights.append(PointLight(light, power=100.0))
    return scene, pixel_points_on_plane(camera, W, H, 0.0), light


def test_without_t_max_reduction_a_light_on_a_surface_is_shadowed_by_it():
    """The lecture's epsilon rays stop 2 epsilon short (t_max = |P - I| - 2 eps): the floor gets
    P/(4 pi) cos(theta)/r^2. Unreduced, each ray ends eps beyond the light, inside the wall: all dark."""
    scene, points, light = wall_and_floor()
    w = light - points
    r = np.linalg.norm(w, axis=2)
    expected = ALBEDO / math.pi * 100.0 / (4 * math.pi) * (w[..., 2] / r) / r ** 2
    reduced = render.render(scene, exact(shadow_method="epsilon")).image[..., 0]
    unreduced = render.render(scene, exact(shadow_method="epsilon", reduce_t_max=False)).image[..., 0]
    np.testing.assert_allclose(reduced, expected, rtol=1e-5)
    assert not unreduced.any()


def test_shadow_rays_for_backfacing_lights_change_nothing_but_the_ray_count():
    """Casting shadow rays for lights behind the surface: a closed sphere blocks them itself, and N.L
    clamps the rest to 0, so the image is the same while the ray count grows (the lecture skips them)."""
    scene = Scene(camera=ortho_down(height=3.0, scale=2.4))
    scene.add_material((ALBEDO,) * 3)
    scene.add_mesh(primitives.uv_sphere(1.0, 16, 8))
    scene.lights += [PointLight(np.array([3.0, -1.0, 0.5]), power=500.0),
                     SunLight(np.array([-1.0, 0.2, -0.3]) / math.sqrt(1.13), strength=1.0)]
    settings = RenderSettings(width=32, height=32, samples=2, aux=("rays",))
    skipped = render.render(scene, settings)
    cast = render.render(scene, RenderSettings(**{**settings.__dict__, "shadow_rays_for_backfacing": True}))
    np.testing.assert_array_equal(cast.image, skipped.image)
    assert cast.stats.shadow_rays > 1.3 * skipped.stats.shadow_rays
    # Every camera sample on the sphere now casts one shadow ray per light: the middle pixels cast 2 x (1 + 2).
    np.testing.assert_array_equal(cast.aux["rays"][12:20, 12:20], 2 * (1 + 2))
