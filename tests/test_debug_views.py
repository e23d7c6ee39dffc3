"""Debug buffers ("use that debug output"): each one against its closed form on a scene built by hand."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ortho_down, pixel_points_on_plane, rotation, sun_direction
from core.integrators import debug
from core.geometry import primitives
from core import render
from core.camera import Camera
from core.scene import AreaLight, Mesh, PointLight, RenderSettings, Scene, SunLight


def exact(width, height, aux, **kw) -> RenderSettings:
    """Settings for one unjittered sample per pixel at the pixel centre."""
    return RenderSettings(width=width, height=height, samples=1, jitter=False, aux=aux, **kw)


def tilted_quad(tilt_deg: float) -> Mesh:
    """The square [-1, 1]^2 at z = 0, two triangles, smooth, with corner normals leaning by -tilt at
    x = -1 and +tilt at x = +1 (about the y axis): the interpolated normal is normalize(x sin b, 0, cos b)."""
    b = math.radians(tilt_deg)
    vertices = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    lean = {-1.0: [-math.sin(b), 0.0, math.cos(b)], 1.0: [math.sin(b), 0.0, math.cos(b)]}
    corners = np.array([[lean[vertices[i, 0]] for i in tri] for tri in triangles])
    return Mesh(vertices, triangles, smooth=True, corner_normals=corners)


def test_hit_distance_of_an_orthographic_view_is_the_camera_height():
    """Looking straight down from height 3 at the plane z = 0, every camera ray hits at t = 3."""
    scene = Scene(camera=ortho_down(height=3.0, scale=2.0))
    scene.add_mesh(primitives.plane(10.0))
    result = render.render(scene, exact(16, 12, ("hit_distance",)))
    np.testing.assert_allclose(result.aux["hit_distance"], 3.0, rtol=1e-9)


def test_hit_distance_of_a_perspective_view_is_the_distance_from_the_eye():
    """A pinhole camera's t is |I - camera position|, not the depth along the view axis nor from the clip start."""
    camera = Camera.look_at((0.0, -4.0, 3.0), (0.0, 0.0, 0.0), fov=math.radians(50), clip_start=0.5)
    scene = Scene(camera=camera)
    scene.add_mesh(primitives.plane(100.0))
    result = render.render(scene, exact(24, 18, ("hit_distance", "depth")))
    points = pixel_points_on_plane(camera, 24, 18, 0.0)
    expected = np.linalg.norm(points - camera.position, axis=2)
    np.testing.assert_allclose(result.aux["hit_distance"][..., 0], expected, rtol=1e-6)
    assert np.all(result.aux["hit_distance"][..., 0] > result.aux["depth"][..., 0])   # off-axis rays are longer


def test_hit_distance_is_the_miss_value_where_nothing_is_hit():
    """Pixels that see only the world keep the documented miss value."""
    scene = Scene(camera=ortho_down(height=1.0, scale=4.0))
    scene.add_mesh(primitives.plane(1.0))
    result = render.render(scene, exact(8, 8, ("hit_distance", "barycentric", "normal_angle")))
    assert result.aux["hit_distance"][0, 0, 0] == debug.MISS_DEPTH
    assert result.aux["hit_distance"][4, 4, 0] == pytest.approx(1.0)
    assert not result.aux["barycentric"][0, 0].any()


def test_barycentrics_sum_to_one_and_locate_the_hit_point():
    """On one triangle seen from above, (1-u-v, u, v) sum to 1 and rebuild the pixel centre's point."""
    V = np.array([[-0.9, -0.8, 0.0], [0.95, -0.6, 0.0], [-0.2, 0.9, 0.0]])
    camera = ortho_down(height=1.0, scale=2.0)
    scene = Scene(camera=camera)
    scene.add_mesh(Mesh(V, np.array([[0, 1, 2]])))
    W = H = 20
    result = render.render(scene, exact(W, H, ("barycentric", "hit_distance")))
    hit = result.aux["hit_distance"][..., 0] < debug.MISS_DEPTH
    weights = result.aux["barycentric"][hit].astype(np.float64)
    assert hit.sum() > 100
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-6)
    # By hand: solve P = w0 V0 + w1 V1 + w2 V2 with w0 + w1 + w2 = 1 for every pixel centre P.
    P = pixel_points_on_plane(camera, W, H, 0.0)[hit][:, :2]
    A = np.vstack([V[:, :2].T, np.ones(3)])                                   # (3, 3)
    by_hand = np.linalg.solve(A, np.vstack([P.T, np.ones(len(P))])).T
    np.testing.assert_allclose(weights, by_hand, atol=1e-6)
    assert np.all(by_hand > -1e-9)                                             # hits lie inside the triangle


@pytest.mark.parametrize("elevation", [90.0, 60.0, 20.0])
def test_n_dot_l_is_the_cosine_of_the_sun_angle(elevation):
    """A sun `elevation` degrees above a plane gives N.L = cos(90 - elevation) = sin(elevation) everywhere."""
    scene = Scene(camera=ortho_down(height=1.0, scale=2.0))
    scene.add_mesh(primitives.plane(10.0))
    scene.lights.append(SunLight(sun_direction(elevation, 40.0), strength=1.0))
    result = render.render(scene, exact(8, 8, ("n_dot_l",)))
    # The debug buffers are float32: N.L is averaged in float64 and rounded once when stored, so the buffer
    # holds the closed form rounded to float32, within 1 unit in the last place of float32. Compared in
    # float32 on purpose: numpy 2 compares a float32 buffer with a float64 value in float64, where even the
    # correctly rounded float32 misses sin(elevation) by up to 6e-8 relative (numpy 1 rounded the value).
    n_dot_l = result.aux["n_dot_l"]
    assert n_dot_l.dtype == np.float32
    np.testing.assert_array_max_ulp(n_dot_l, np.full_like(n_dot_l, math.sin(math.radians(elevation))), maxulp=1)


def test_normal_angle_is_zero_on_flat_faces():
    """Where N is the face normal (flat shading), shading and face normals agree: angle 0."""
    scene = Scene(camera=ortho_down(height=1.0, scale=2.0))
    scene.add_mesh(primitives.plane(10.0))
    scene.add_mesh(primitives.uv_sphere(0.5, 8, 4, center=(0.0, 0.0, 0.2), smooth=False))
    result = render.render(scene, exact(16, 16, ("normal_angle",)))
    assert np.abs(result.aux["normal_angle"]).max() < 1e-4


@pytest.mark.parametrize("tilt", [10.0, 40.0])
def test_normal_angle_on_a_smooth_quad_is_atan_of_x_tan_tilt(tilt):
    """Corner normals leaning +-tilt across a flat quad interpolate to (x sin b, 0, cos b): angle atan(|x| tan b)."""
    camera = ortho_down(height=1.0, scale=2.0)
    scene = Scene(camera=camera)
    scene.add_mesh(tilted_quad(tilt))
    W = H = 16
    result = render.render(scene, exact(W, H, ("normal_angle",)))
    x = pixel_points_on_plane(camera, W, H, 0.0)[..., 0]
    expected = np.degrees(np.arctan(np.abs(x) * math.tan(math.radians(tilt))))
    np.testing.assert_allclose(result.aux["normal_angle"][..., 0], expected, atol=1e-4)
    # With smooth normals switched off, the disagreement is gone.
    flat = render.render(scene, exact(W, H, ("normal_angle",), smooth_normals=False))
    assert np.abs(flat.aux["normal_angle"]).max() < 1e-4


def test_rays_per_pixel_are_samples_times_one_plus_the_lit_lights():
    """Each camera sample casts one camera ray and one shadow ray per light in front (light_samples for
    a light with extent); a light below the plane costs nothing; pixels that miss cost their camera rays."""
    spp, light_samples = 4, 3
    scene = Scene(camera=ortho_down(height=1.0, scale=4.0))
    scene.add_mesh(primitives.plane(2.0))                                       # covers the middle half
    scene.lights += [
        PointLight(np.array([0.3, 0.2, 2.0]), power=100.0),
        SunLight(sun_direction(50.0), strength=1.0),
        PointLight(np.array([0.0, 0.0, -2.0]), power=100.0),                    # behind the plane: no rays
        AreaLight(np.array([0.0, 0.0, 3.0]), np.array([0.5, 0.0, 0.0]), np.array([0.0, 0.5, 0.0]),
                  np.array([0.0, 0.0, -1.0]), power=50.0),
    ]
    settings = RenderSettings(width=8, height=8, samples=spp, light_samples=light_samples, aux=("rays",))
    result = render.render(scene, settings)
    rays = result.aux["rays"][..., 0]
    np.testing.assert_array_equal(rays[2:6, 2:6], spp * (1 + 2 + light_samples))
    assert rays[0, 0] == spp and rays[7, 7] == spp
    assert rays.sum() == result.stats.rays
    # Back-facing shadow rays switched on: the light below the plane now costs one ray per sample too.
    more = render.render(scene, RenderSettings(**{**settings.__dict__, "shadow_rays_for_backfacing": True}))
    np.testing.assert_array_equal(more.aux["rays"][2:6, 2:6, 0], spp * (1 + 3 + light_samples))


def grazing_plane(occluder: bool = False, offset: float = 0.0) -> Scene:
    """A tilted plane (float32 cannot store it exactly) `offset` from the origin under a sun 10 degrees
    above it; maybe a box on it."""
    R = rotation((0.3, 0.5, 0.8), 0.7)
    origin = np.array([offset, 0.5 * offset, 0.3 * offset])
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, origin
    scene = Scene(camera=Camera.look_at(origin + R @ [0.0, -4.0, 2.5], origin, R @ [0.0, 0.0, 1.0],
                                        fov=math.radians(60), clip_start=0.01, clip_end=1e3))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(100.0), matrix=M)
    if occluder:
        scene.add_mesh(primitives.box((0.6, 0.6, 0.6), center=(0.0, 0.0, 0.3)), matrix=M)
    scene.lights.append(SunLight(R @ sun_direction(10.0, 30.0), strength=3.0))
    return scene


def test_acne_map_marks_exactly_the_self_shadowed_pixels_with_zero_epsilon():
    """epsilon = 0 starts shadow rays on the surface (here in world coordinates): rounding puts many
    below it, and the acne map marks exactly the pixels that came out shadowed on a plane with nothing
    above it, where the closed form says every pixel is lit."""
    result = render.render(grazing_plane(), exact(48, 48, ("acne", "visibility", "depth"), shadow_method="epsilon",
                                                  epsilon=0.0, camera_relative=False))
    hit = result.aux["depth"][..., 0] < debug.MISS_DEPTH
    acne = result.aux["acne"][..., 0]
    shadowed = result.aux["visibility"][..., 0] == 0.0
    assert acne[hit].mean() > 0.3
    np.testing.assert_array_equal(acne[hit] == 1.0, shadowed[hit])


def test_acne_map_is_empty_with_the_robust_offset_even_beside_real_shadows():
    """The robust offset leaves no self-intersection; the box's real shadow is not counted as acne."""
    result = render.render(grazing_plane(occluder=True), exact(48, 48, ("acne", "visibility", "depth")))
    hit = result.aux["depth"][..., 0] < debug.MISS_DEPTH
    assert (result.aux["visibility"][..., 0][hit] == 0.0).sum() > 20      # the box casts a shadow
    assert not result.aux["acne"].any()


def test_time_per_pixel_adds_up_to_the_tracing_time_and_follows_the_rays():
    """The time buffer shares each timed run's clock time by rays: it sums to (nearly) the render's
    time outside the BVH build, and within a run, time per ray is the same for every pixel."""
    scene = grazing_plane(occluder=True)
    settings = RenderSettings(width=32, height=32, samples=2, threads=1, aux=("time", "rays"))
    result = render.render(scene, settings)
    seconds = result.aux["time"][..., 0].astype(np.float64)
    rays = result.aux["rays"][..., 0].astype(np.float64)
    assert seconds.min() > 0.0
    tracing = result.stats.seconds - result.stats.geometry_seconds
    assert 0.5 * tracing < seconds.sum() <= tracing
    first_run = (seconds / rays).reshape(-1)[:render.TIME_TILE]
    np.testing.assert_allclose(first_run, first_run[0], rtol=1e-5)


def test_every_lecture_switch_defaults_to_the_lecture_choice():
    """Default settings are the lecture's; any switch off its default is not."""
    assert RenderSettings().is_lecture_default()
    for change in ({"smooth_normals": False}, {"visibility_normal": "shading"}, {"reduce_t_max": False},
                   {"distance_attenuation": False}, {"clamp_n_dot_l": False},
                   {"shadow_rays_for_backfacing": True}):
        assert not RenderSettings(**change).is_lecture_default()


def test_debug_counts_are_kept_by_a_recorder_only_when_asked_for():
    """The integrator carries no debug code: without debug buffers a chunk keeps no counts; with them a
    recorder counts the centre pixel's camera ray and its one shadow ray (the plane is lit, no acne)."""
    scene = grazing_plane()
    centre = np.array([2 * 5 + 2])                       # pixel (2, 2) of a 5 x 5 image looks at the plane
    plain = render.prepare(scene, RenderSettings(width=5, height=5, samples=1, jitter=False))
    assert render.reference_chunk(plain, centre, 1, 0).aux == {}
    asked = render.prepare(scene, RenderSettings(width=5, height=5, samples=1, jitter=False, aux=("acne", "rays")))
    sums = render.reference_chunk(asked, centre, 1, 0).aux
    assert sums["rays"][0, 0] == 2.0 and sums["acne"][0, 0] == 0.0 and sums[debug.ACNE_CAST][0, 0] == 1.0


def test_heat_map_runs_black_blue_red_yellow_white():
    """The documented colour scale, clipped outside 0..1."""
    np.testing.assert_array_equal(debug.heat(np.array([-1.0, 0.0, 0.25, 0.5, 0.75, 1.0, 2.0])),
                                  [[0, 0, 0], [0, 0, 0], [0, 0, 1], [1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 1, 1]])
    np.testing.assert_allclose(debug.heat(np.array([0.125])), [[0.0, 0.0, 0.5]])


def test_a_real_shadow_in_a_concave_crease_is_not_acne_however_close():
    """A floor and a wall of one mesh meet in a concave crease; a low sun behind the wall shadows the floor.
    A floor point 1e-5 from the wall is really shadowed, its blocker only ~1e-5 away, yet the wall rises
    above the floor's plane, so no rounding is needed to hit it: the acne map stays empty."""
    gap = 1e-5                                   # the first pixel column's centre, this far from the wall
    c = 0.025 - gap                              # pixel centres sit at x = +-0.025, +-0.075, ... (40 px, 2 wide)
    vertices = np.array([[c, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [c, 1.0, 0.0],     # floor, x >= c
                         [c, -1.0, 1.0], [c, 1.0, 1.0]])                                       # wall, x = c
    triangles = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 5], [0, 5, 4]])
    scene = Scene(camera=ortho_down(height=2.0, scale=2.0))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(Mesh(vertices, triangles, name="Crease"))
    scene.lights.append(SunLight(sun_direction(20.0, 180.0), strength=3.0))     # low, from -x: behind the wall
    result = render.render(scene, exact(40, 8, ("acne", "visibility", "depth", "n_dot_l"), camera_relative=False))
    column = result.aux["visibility"][:, 20, 0]
    assert (result.aux["depth"][:, 20, 0] < debug.MISS_DEPTH).all()
    np.testing.assert_allclose(result.aux["n_dot_l"][:, 20, 0], math.sin(math.radians(20.0)))   # rays were cast
    assert (column == 0.0).all()                 # the sun sets behind the wall: really shadowed
    assert not result.aux["acne"].any()


def test_debug_buffers_render_where_bsdf_rays_find_lights():
    """Debug buffers (the reference path with the debug recorder) on a scene whose area light BSDF rays find:
    every buffer comes back, finite, and the image equals the render without them."""
    import dataclasses
    from test_compiled import LIGHTS, lit_scene
    from core import render
    from core.scene import RenderSettings
    from core.integrators.debug import AUX_BUFFERS
    from core.lights import World
    scene = lit_scene(LIGHTS["area_rect"])
    scene.world = World(color=np.array([0.1, 0.1, 0.1]), camera=True, lights=True)    # BSDF rays at every hit
    settings = RenderSettings(width=16, height=12, samples=2, kernels="numpy")
    plain = render.render(scene, settings)
    with_aux = render.render(scene, dataclasses.replace(settings, aux=tuple(AUX_BUFFERS)))
    np.testing.assert_allclose(with_aux.image, plain.image, rtol=1e-6, atol=1e-7)
    assert all(np.isfinite(np.asarray(v)).all() for v in with_aux.aux.values())
    # And on a path (the debug buffers keep the camera's hits; later vertices are not theirs).
    path = dataclasses.replace(settings, integrator="path", max_bounces=2)
    traced = render.render(scene, dataclasses.replace(path, aux=tuple(AUX_BUFFERS)))
    np.testing.assert_allclose(traced.image, render.render(scene, path).image, rtol=1e-6, atol=1e-7)


def test_shutter_time_is_each_rows_share_with_a_rolling_shutter_and_one_half_without_blur():
    """The Shutter Time view is the mean time of a pixel's camera rays: with a rolling shutter of Duration 0 row r of
    H is read at (r + 1) / H, hit or not; over a box shutter the mean of many rays is 1/2; without motion blur 1/2."""
    from core.camera import motion
    still = ortho_down(height=3.0, scale=2.0)
    scene = Scene(camera=dataclasses.replace(still, shutter=motion.Shutter.box(rolling=True, rolling_duration=0.0),
                                             motion=(still.matrix_world,) * 3))
    scene.add_mesh(primitives.plane(1.0))                       # (half the pixels see nothing)
    rows = render.render(scene, exact(8, 6, ("shutter_time",))).aux["shutter_time"][..., 0]
    np.testing.assert_allclose(rows, np.broadcast_to(((np.arange(6) + 1.0) / 6)[:, None], (6, 8)), atol=1e-15)
    scene.camera = dataclasses.replace(scene.camera, shutter=motion.Shutter.box())
    box = render.render(scene, RenderSettings(width=8, height=6, samples=256, aux=("shutter_time",), adaptive=False))
    assert box.aux["shutter_time"].mean() == pytest.approx(0.5, abs=2e-3)
    scene.camera = still
    plain = render.render(scene, exact(8, 6, ("shutter_time",))).aux["shutter_time"]
    np.testing.assert_array_equal(plain, 0.5)
