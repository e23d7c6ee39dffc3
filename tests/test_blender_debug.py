"""Debug views, debug passes and lecture switches inside real Blender (the bpy module).

Each test builds a tiny scene with bpy, renders it through Primer's RenderEngine and reads the
written passes (a multilayer EXR) or the Combined image back. Closed forms as in
tests/test_debug_views.py and tests/test_lecture_switches.py, here through Blender's own settings.
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from render import load_primer  # noqa: E402

from test_blender_engine import engine_module, new_scene, render_passes, render_to  # noqa: E402

pytestmark = pytest.mark.blender
ALBEDO = 0.8                     # Blender's default material grey


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def aim(obj, travel) -> None:
    """Turn a light so that it shines along `travel` (its -Z axis)."""
    from mathutils import Vector
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = Vector(travel).normalized().to_track_quat("-Z", "Y")


def ortho_scene(width=12, height=9, elevation=90.0, camera_height=5.0):
    """new_scene's plane under one sun `elevation` degrees above it, seen from above by an orthographic camera."""
    scene = new_scene(width, height)
    scene.camera.data.type = "ORTHO"
    scene.camera.data.ortho_scale = 4.0
    scene.camera.location = (0.0, 0.0, camera_height)
    e = math.radians(elevation)
    aim(scene.objects["Sun"], (-math.cos(e), 0.0, -math.sin(e)))
    return scene


def smooth_quad(scene, tilt_deg: float = 40.0):
    """Replace the plane by a 2 x 2 smooth quad whose custom normals lean -tilt at x = -1 and +tilt at x = +1:
    the interpolated normal is normalize(x sin b, 0, cos b), the face normal +Z."""
    bpy.data.objects.remove(scene.objects["Plane"])
    b = math.radians(tilt_deg)
    mesh = bpy.data.meshes.new("Quad")
    vertices = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    mesh.from_pydata(vertices, [], [(0, 1, 2, 3)])
    mesh.polygons.foreach_set("use_smooth", [True])
    mesh.normals_split_custom_set([(math.copysign(math.sin(b), vertices[loop.vertex_index][0]), 0.0, math.cos(b))
                                   for loop in mesh.loops])
    scene.collection.objects.link(bpy.data.objects.new("Quad", mesh))
    scene.camera.data.ortho_scale = 2.0


def test_every_debug_pass_matches_its_closed_form(primer, tmp_path):
    """A flat plane under a sun 30 degrees high, seen from 5 above, orthographic: t = 5, barycentrics sum
    to 1, normal angle 0, N.L = sin 30, shadow 1, no acne, 2 x samples rays per pixel, some time."""
    scene = ortho_scene(elevation=30.0)
    scene.primer.samples = 2
    scene.primer.debug_passes = True
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = True
    passes = render_passes(scene, str(tmp_path / "passes.exr"))
    record = engine_module(primer).last_render
    assert record.error == ""
    assert set(engine_module(primer).DEBUG_PASSES) <= set(passes)
    np.testing.assert_allclose(passes["Depth"], 5.0, rtol=1e-6)
    np.testing.assert_allclose(passes["Primer Hit Distance"], 5.0, rtol=1e-6)
    np.testing.assert_allclose(passes["Primer Face Normal"][..., 2], 1.0, rtol=1e-6)
    np.testing.assert_allclose(passes["Primer Barycentric"].sum(axis=2), 1.0, atol=1e-6)
    assert passes["Primer Barycentric"].min() >= -1e-6
    np.testing.assert_allclose(passes["Primer Normal Angle"], 0.0, atol=1e-3)
    np.testing.assert_allclose(passes["Primer NdotL"], 0.5, rtol=1e-6)
    np.testing.assert_allclose(passes["Primer Shadow"], 1.0)
    np.testing.assert_array_equal(passes["Primer Acne"], 0.0)
    np.testing.assert_array_equal(passes["Primer Rays"], 2 * (1 + 1))
    time = passes["Primer Time"].astype(np.float64)
    assert time.min() > 0.0 and time.sum() < record.seconds


def test_debug_passes_cost_nothing_when_off(primer, tmp_path):
    """With debug passes and the debug view off, the render computes no debug buffer at all."""
    scene = ortho_scene()
    engine = engine_module(primer)
    assert engine.requested_buffers(scene.primer, scene.view_layers[0]) == ()
    passes = render_passes(scene, str(tmp_path / "plain.exr"))
    assert set(passes) == {"Combined"}
    assert engine.last_render.stats is not None


@pytest.mark.parametrize("view, expected", [
    ("BARYCENTRIC", "sum_one"),
    ("NORMAL_ANGLE", (0.0, 0.0, 0.0)),        # flat: angle 0 -> black
    ("HIT_DISTANCE", (1.0, 1.0, 1.0)),        # all hits equally near -> white
    ("N_DOT_L", (0.5, 0.5, 0.5)),             # sin 30
    ("VISIBILITY", (1.0, 1.0, 1.0)),
    ("ACNE", (0.0, 0.0, 0.0)),                # robust offset: none
    ("RAYS", (1.0, 1.0, 1.0)),                # every pixel casts the maximum -> white
    ("TIME", "heat"),
])
def test_debug_view_pictures(primer, tmp_path, view, expected):
    """Each debug view replaces Combined by its picture, with the documented colour scale."""
    scene = ortho_scene(elevation=30.0)
    scene.primer.debug_view = view
    image = render_to(scene, str(tmp_path / f"{view}.exr"))[..., :3]
    if expected == "sum_one":
        np.testing.assert_allclose(image.sum(axis=2), 1.0, atol=1e-5)
    elif expected == "heat":
        assert np.isclose(image, 1.0, atol=1e-6).all(axis=2).any()        # the slowest pixel is white
        assert image.min() >= 0.0
    else:
        np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), atol=1e-5)


def test_light_chooser_shows_one_lights_n_dot_l(primer, tmp_path):
    """Two suns, overhead (N.L = 1) and 30 degrees high (N.L = 0.5): the NdotL pass shows the chosen one,
    or their mean."""
    scene = ortho_scene(elevation=90.0)
    scene.primer.debug_passes = True
    low = bpy.data.objects.new("Low Sun", bpy.data.lights.new("Low Sun", "SUN"))
    low.data.angle = 0.0
    aim(low, (-math.cos(math.radians(30)), 0.0, -0.5))
    scene.collection.objects.link(low)
    for chosen, expected in ((None, 0.75), (scene.objects["Sun"], 1.0), (low, 0.5)):
        scene.primer.debug_light = chosen
        passes = render_passes(scene, str(tmp_path / "chooser.exr"))
        np.testing.assert_allclose(passes["Primer NdotL"], expected, rtol=1e-6)


def test_n_dot_l_view_shows_negative_cosines_in_blue(primer, tmp_path):
    """On the smooth quad under a sun 20 degrees high from -x, N.L = (-x sin b cos e + cos b sin e) /
    sqrt(x^2 sin^2 b + cos^2 b), negative for x > tan(e)/tan(b) = 0.43. With Clamp N.L off the N.L view
    keeps the sign: grey N.L where it is positive, blue (0, 0, -N.L) where it is negative; with the clamp
    those pixels are 0, black."""
    scene = ortho_scene(16, 16)
    smooth_quad(scene)
    e, b = math.radians(20.0), math.radians(40.0)
    aim(scene.objects["Sun"], (math.cos(e), 0.0, -math.sin(e)))
    scene.primer.debug_passes = True
    scene.primer.debug_view = "N_DOT_L"
    scene.primer.clamp_n_dot_l = False
    scene.primer.samples = 64                                    # the pixel's mean N.L close to its centre's
    scene.primer.use_adaptive_sampling = False
    passes = render_passes(scene, str(tmp_path / "signed.exr"))
    n_dot_l, picture = passes["Primer NdotL"][..., 0], passes["Combined"][..., :3]
    x = (np.arange(16) + 0.5) / 8.0 - 1.0                        # pixel centres across the quad
    expected = (-x * math.sin(b) * math.cos(e) + math.cos(b) * math.sin(e)) / np.sqrt(
        (x * math.sin(b)) ** 2 + math.cos(b) ** 2)
    np.testing.assert_allclose(n_dot_l, np.broadcast_to(expected, n_dot_l.shape), atol=0.02)
    negative = n_dot_l < 0.0
    assert negative[:, 12:].all() and not negative[:, :6].any()
    np.testing.assert_allclose(picture[negative], np.stack([0 * n_dot_l, 0 * n_dot_l, -n_dot_l], -1)[negative],
                               atol=1e-6)
    np.testing.assert_allclose(picture[~negative], np.repeat(n_dot_l[~negative][:, None], 3, axis=1), atol=1e-6)
    scene.primer.clamp_n_dot_l = True
    clamped = render_passes(scene, str(tmp_path / "clamped.exr"))["Combined"][..., :3]
    below, above = n_dot_l < -0.05, n_dot_l > 0.05                # whole pixels on one side of N.L = 0
    assert not clamped[below].any()
    np.testing.assert_allclose(clamped[above], picture[above], atol=1e-6)


def test_smooth_normals_off_renders_like_flat_shading(primer, tmp_path):
    """Switching smooth normals off gives the image Blender's own flat shading gives."""
    scene = new_scene(24, 24)
    bpy.data.objects.remove(scene.objects["Plane"])
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6, location=(0, 0, 0))
    sphere = bpy.context.object
    sphere.data.polygons.foreach_set("use_smooth", [True] * len(sphere.data.polygons))
    sphere.data.update()
    aim(scene.objects["Sun"], (0.5, 0.3, -1.0))
    scene.camera.location = (0.0, 0.0, 6.0)
    smooth = render_to(scene, str(tmp_path / "smooth.exr"))
    scene.primer.smooth_normals = False
    switched = render_to(scene, str(tmp_path / "switched.exr"))
    scene.primer.smooth_normals = True
    sphere.data.polygons.foreach_set("use_smooth", [False] * len(sphere.data.polygons))
    sphere.data.update()
    flat = render_to(scene, str(tmp_path / "flat.exr"))
    np.testing.assert_array_equal(switched, flat)
    assert np.abs(smooth - flat).max() > 0.01


def test_lecture_switches_change_the_image_as_the_lecture_says(primer, tmp_path):
    """Through Blender's properties: a leak through the face with the shading-normal check, negative light
    without the clamp, a light on a wall shadowed without t_max reduction, 1/r^2 undone, acne at epsilon 0,
    and back-facing shadow rays that only cost rays."""
    # Visibility normal: a sun below the smooth quad, which the leaning normals face on the +x side.
    scene = ortho_scene(16, 16)
    smooth_quad(scene)
    e = math.radians(10.0)
    aim(scene.objects["Sun"], (-math.cos(e), 0.0, math.sin(e)))
    assert not render_to(scene, str(tmp_path / "face.exr"))[..., :3].any()
    scene.primer.visibility_normal = "SHADING"
    leak = render_to(scene, str(tmp_path / "shading.exr"))[..., 0]
    assert (leak[:, 12:] > 0.05).all() and not leak[:, :4].any()        # lit only where x > tan(e)/tan(b)
    # N.L clamp: a low sun from -x; N.L < 0 for x > tan(20)/tan(40) = 0.43.
    scene.primer.visibility_normal = "FACE"
    e = math.radians(20.0)
    aim(scene.objects["Sun"], (math.cos(e), 0.0, -math.sin(e)))
    assert render_to(scene, str(tmp_path / "clamped.exr"))[..., 0].min() >= 0.0
    scene.primer.clamp_n_dot_l = False
    unclamped = render_to(scene, str(tmp_path / "unclamped.exr"))[..., 0]
    assert (unclamped[:, 14:] < 0.0).all() and (unclamped[:, :4] > 0.0).all()

    # Distance attenuation: a 100 W point light 2 above the plane; without 1/r^2 each pixel is r^2 brighter.
    scene = ortho_scene(8, 8)
    scene.camera.data.ortho_scale = 1.0
    bpy.data.objects.remove(scene.objects["Sun"])
    point = bpy.data.objects.new("Point", bpy.data.lights.new("Point", "POINT"))
    point.data.energy, point.data.shadow_soft_size = 100.0, 0.0
    point.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(point)
    attenuated = render_to(scene, str(tmp_path / "attenuated.exr"))[..., 0]
    scene.primer.distance_attenuation = False
    plain = render_to(scene, str(tmp_path / "plain.exr"))[..., 0]
    ys, xs = np.mgrid[0:8, 0:8]
    r2 = 4.0 + ((xs + 0.5) / 8 - 0.5) ** 2 + ((ys + 0.5) / 8 - 0.5) ** 2
    np.testing.assert_allclose(plain / attenuated, r2, rtol=0.03)
    # Reduced t_max: the same light moved onto a wall (x = 0, facing +x), the lecture's epsilon rays.
    scene.primer.distance_attenuation = True
    scene.primer.shadow_method = "EPSILON"
    wall = bpy.data.meshes.new("Wall")
    wall.from_pydata([(0, -5, 0), (0, 5, 0), (0, 5, 5), (0, -5, 5)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(bpy.data.objects.new("Wall", wall))
    point.location = (0.0, 0.0, 1.0)
    scene.camera.location = (1.0, 0.0, 5.0)                   # looking at the floor x in [0.5, 1.5]
    assert render_to(scene, str(tmp_path / "reduced.exr"))[..., 0].min() > 0.01
    scene.primer.reduce_t_max = False
    assert not render_to(scene, str(tmp_path / "unreduced.exr"))[..., :3].any()

    # Shadow offset: epsilon 0 under a low sun is all acne; the robust offset has none.
    scene = ortho_scene(8, 8, elevation=10.0)
    scene.primer.debug_passes = True
    scene.primer.shadow_method = "EPSILON"
    scene.primer.epsilon = 0.0
    passes = render_passes(scene, str(tmp_path / "acne.exr"))
    lit = ALBEDO / math.pi * 2 * math.sin(math.radians(10))
    assert passes["Primer Acne"].mean() > 0.5 and passes["Combined"][..., 0].mean() < 0.5 * lit
    scene.primer.shadow_method = "ROBUST"
    passes = render_passes(scene, str(tmp_path / "robust.exr"))
    assert not passes["Primer Acne"].any()
    np.testing.assert_allclose(passes["Combined"][..., 0], lit, rtol=1e-5)

    # Back-facing shadow rays: a sphere lit from the side, same image, more rays.
    scene = new_scene(16, 16)
    bpy.data.objects.remove(scene.objects["Plane"])
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8)
    aim(scene.objects["Sun"], (1.0, 0.0, -0.2))
    skipped = render_to(scene, str(tmp_path / "skipped.exr"))
    rays_skipped = engine_module(primer).last_render.rays
    scene.primer.shadow_rays_for_backfacing = True
    cast = render_to(scene, str(tmp_path / "cast.exr"))
    np.testing.assert_array_equal(cast, skipped)
    assert engine_module(primer).last_render.rays > rays_skipped
