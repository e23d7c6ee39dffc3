"""The pictures of the guided tour (docs/tour.md), rendered through real Blender, each with the property
the tour claims for it.

Every test opens one of the sample scenes (sample_scenes/*.blend), changes what the tour tells the
student to change, renders it with Primer inside Blender (the bpy module, Primer registered from this
checkout by tools/render.py's load_primer), writes the picture as an sRGB PNG into docs/images/tour/,
and checks the picture against a closed form: the lecture's camera construction, the inverse-square
law, absorption by the material colour, the cosine law, and so on. The closed forms are computed here
from the scene's inputs (camera, lights, materials), never from Primer's earlier output.

The images are small (the scenes' own 160 x 120 or less) and sampled lightly with a fixed seed, so
the module runs in well under a minute and regenerates the same pictures every time.
"""
from __future__ import annotations

import importlib
import math
import os
import re
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402
from test_blender_engine import render_passes  # noqa: E402

from core.camera import motion  # noqa: E402
from core.integrators import debug
from core.film import image_io  # noqa: E402
from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = [pytest.mark.slow, pytest.mark.blender]

SCENES = os.path.join(ROOT, "sample_scenes")
PICTURES = os.path.join(ROOT, "docs", "images", "tour")
TOUR = os.path.join(ROOT, "docs", "tour.md")
MAX_PNG_BYTES = 60_000
SEED = 0
SAMPLES = 16                    # the tour's renders: adaptive sampling (the default) up to 16 samples
UP = np.array([0.0, 0.0, 1.0])  # Blender's world up; make_scenes.add_camera aims cameras with it
NO_HIT = 1e9                    # Depth and Hit Distance passes hold more than this where no surface was hit
# Where make_scenes.py aims each camera (its target; the position is read from the scene).
TARGETS = {
    "light_point": (0.0, 0.2, 0.55), "light_sun": (0.0, 0.2, 0.55),                 # stage_camera
    "shading_flat_smooth": (0.0, 0.2, 0.55), "camera_persp_shift": (0.0, 0.2, 0.9),
    "shading_visibility": (0.0, 0.0, 0.6),
}
FLOOR_HALF_SIZE = 10.0          # make_scenes.ground: a 20 m plane at z = 0


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def addon_module(primer, name):
    """Return one of the add-on's modules (primer.addon.<name>)."""
    return sys.modules[f"{primer.__name__}.addon.{name}"]


# ---------------------------------------------------------------------------
# Opening, rendering, saving
# ---------------------------------------------------------------------------

def open_scene(name: str, samples: int = SAMPLES):
    """Open sample_scenes/<name>.blend with the tour's sampling (fixed seed) and return its scene."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SCENES, f"{name}.blend"))
    scene = bpy.context.scene
    assert scene.render.engine == "PRIMER"
    scene.primer.samples = samples
    scene.primer.seed = SEED
    scene.primer.animate_seed = False
    return scene


def render(primer, scene, path: str, view: str = "NONE", passes: tuple = ()) -> dict:
    """Render through Blender into a multilayer float EXR; return pass name -> (H, W, c) float32, rows top-down.

    view: the Debug View (Combined then holds its picture); passes: "Depth", "Normal" and/or "Primer"
    (all debug passes).
    """
    layer = scene.view_layers[0]
    layer.use_pass_z = "Depth" in passes
    layer.use_pass_normal = "Normal" in passes
    scene.primer.debug_passes = "Primer" in passes
    scene.primer.debug_view = view
    result = render_passes(scene, path)
    record = addon_module(primer, "engine").last_render
    assert record.error == "" and not record.cancelled
    return result


def save(name: str, rgba: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Write docs/images/tour/<name>.png (sRGB, like Blender's Standard view at this exposure); return it.

    A PNG whose pixels are unchanged is left as it is: OpenImageIO versions write different metadata
    chunks (3.1, inside bpy 5.2, adds sRGB, gAMA and cHRM), which would otherwise change the file."""
    picture = np.array(rgba, np.float32)
    picture[..., :3] *= 2.0 ** exposure
    path = os.path.join(PICTURES, f"{name}.png")
    fresh = path + ".new.png"
    image_io.write_image(fresh, picture)
    if os.path.isfile(path) and np.array_equal(image_io.read_image(path), image_io.read_image(fresh)):
        os.remove(fresh)
    else:
        os.replace(fresh, path)
    assert os.path.getsize(path) < MAX_PNG_BYTES
    return picture


# ---------------------------------------------------------------------------
# Closed forms: the lecture's camera, the floor, a sphere
# ---------------------------------------------------------------------------

def lecture_camera(scene, target, sensor_fit="AUTO", raster_offset=(0.5, 0.5)):
    """The lecture's camera for each pixel: (position (3,), V (3,), D (H, W, 3), |P - position| (H, W)).

    V = normalize(target - position), right = normalize(V x up), up' = right x V, C = position + V; the
    screen corners p1 (top left), p2 (top right), p3 (bottom left) lie around C, half a tangent of the
    field of view wide, the other side scaled by the aspect ratio and moved by the lens shift. The pixel
    centre's point P = p1 + (x + 0.5)/W (p2 - p1) + (y + 0.5)/H (p3 - p1), and D = normalize(P - position).
    raster_offset: where in the pixel the ray passes, (0.5, 0.5) for its centre; y counts down.
    """
    cam = scene.camera
    position = np.array(cam.matrix_world.translation, np.float64)
    V = np.asarray(target, np.float64) - position
    V /= np.linalg.norm(V)
    np.testing.assert_allclose(-np.array(cam.matrix_world.col[2][:3]), V, atol=1e-6)   # the file aims at target
    right = np.cross(V, UP)
    right /= np.linalg.norm(right)
    up = np.cross(right, V)
    width, height = scene.render.resolution_x, scene.render.resolution_y
    data = cam.data
    if sensor_fit == "VERTICAL":
        half_h = 0.5 * data.sensor_height / data.lens                 # tan(vertical FOV / 2)
        half_w = half_h * width / height
        fitted = 2 * half_h
    else:                                                               # AUTO on a landscape image
        half_w = 0.5 * data.sensor_width / data.lens                  # tan(horizontal FOV / 2)
        half_h = half_w * height / width                              # the lecture's aspectRatio = height / width
        fitted = 2 * half_w
    cx, cy = data.shift_x * fitted, data.shift_y * fitted
    C = position + V
    p1 = C + (cx - half_w) * right + (cy + half_h) * up
    p2 = C + (cx + half_w) * right + (cy + half_h) * up
    p3 = C + (cx - half_w) * right + (cy - half_h) * up
    ys, xs = np.mgrid[0:height, 0:width]
    ox, oy = raster_offset
    P = (p1 + ((xs + ox) / width)[..., None] * (p2 - p1) + ((ys + oy) / height)[..., None] * (p3 - p1))
    to_P = P - position
    length = np.linalg.norm(to_P, axis=-1)
    return position, V, to_P / length[..., None], length


def floor_distance(position, D):
    """Closed-form t where each ray from `position` along D (H, W, 3) meets the 20 m floor (inf: misses it)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(D[..., 2] < 0.0, -position[2] / D[..., 2], np.inf)
    point = position + np.where(np.isfinite(t), t, 0.0)[..., None] * D
    inside = (np.abs(point[..., 0]) <= FLOOR_HALF_SIZE) & (np.abs(point[..., 1]) <= FLOOR_HALF_SIZE)
    return np.where(inside, t, np.inf)


def sphere_core(position, D, centre, radius, fraction=0.85):
    """Rays (H, W) that pass within `fraction` x radius of the sphere's centre: their whole pixel sees the sphere."""
    to_centre = np.asarray(centre, np.float64) - position
    along = D @ to_centre
    miss_distance = np.linalg.norm(to_centre - along[..., None] * D, axis=-1)
    return (along > 0) & (miss_distance < fraction * radius)


def floor_pixels(depth, scene, target, sensor_fit="AUTO", rtol=1e-3):
    """Pixels whose rendered depth is the floor's closed-form depth somewhere in the pixel (the Depth pass is sample
    0's, at its point of the pixel, as in Cycles: between the floor's depths at the pixel's corners) and whose whole
    pixel lies on the floor (its top edge too, where the floor ends towards the horizon): only the floor is seen
    there. (H, W) bool."""
    position, V, D, _ = lecture_camera(scene, target, sensor_fit)
    _, _, D_top, _ = lecture_camera(scene, target, sensor_fit, raster_offset=(0.5, 0.0))
    corners = []
    for corner in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)):
        _, _, D_corner, _ = lecture_camera(scene, target, sensor_fit, raster_offset=corner)
        corners.append(floor_distance(position, D_corner) * (D_corner @ V))
    low, high = np.min(corners, axis=0), np.max(corners, axis=0)
    inside = np.isfinite(high) & np.isfinite(floor_distance(position, D_top))
    floor = np.pad(inside & (depth >= low * (1.0 - rtol)) & (depth <= high * (1.0 + rtol)), 1)
    # One sample cannot tell a pixel half on an object from one on the floor: keep those whose neighbours are floor too.
    H, W = depth.shape
    return np.all([floor[1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)


def invert_heat(rgb: np.ndarray) -> np.ndarray:
    """Return x in 0..1 from heat-map colours (H, W, 3) (black, blue, red, yellow, white at 0, 1/4, ... 1)."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return np.select([(r == 0) & (g == 0), g == 0, b == 0], [b / 4, 0.25 + r / 4, 0.5 + g / 4], 0.75 + b / 4)


def light_object(scene):
    """The scene's one light object."""
    (light,) = [obj for obj in scene.objects if obj.type == "LIGHT"]
    return light


# ---------------------------------------------------------------------------
# 1. Primary rays from a camera
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("name, fit, floor_share", [("light_point", "AUTO", 0.4),
                                                     ("camera_persp_shift", "VERTICAL", 0.1)])
def test_primary_rays_follow_the_lectures_screen_corners(primer, tmp_path, name, fit, floor_share):
    """The floor's depth in every pixel is the one the lecture's rays (position, target, up, FOV, aspect
    ratio, three screen corners; plus sensor fit and shift) predict: nothing is ever behind the floor, and
    most pixels see the floor itself."""
    scene = open_scene(name)
    passes = render(primer, scene, str(tmp_path / f"{name}.exr"), passes=("Depth",))
    save(name, passes["Combined"])
    position, V, D, _ = lecture_camera(scene, TARGETS[name], fit)
    depth = passes["Depth"][..., 0]
    # The samples of a pixel spread over it: none can be farther than the floor at the pixel's top edge.
    _, _, D_top, _ = lecture_camera(scene, TARGETS[name], fit, raster_offset=(0.5, 0.0))
    farthest = floor_distance(position, D_top) * (D_top @ V)
    hit = depth < NO_HIT
    assert (depth[hit] <= farthest[hit] * (1 + 1e-5)).all()            # nothing lies behind the floor
    assert floor_pixels(depth, scene, TARGETS[name], fit).mean() > floor_share     # and the floor is where the rays say


# ---------------------------------------------------------------------------
# 2. The intersection: t
# ---------------------------------------------------------------------------

def test_hit_distance_is_t_along_the_unit_ray(primer, tmp_path):
    """I = O + tD: t over the depth along the view axis is |P - O| for the screen point P at distance 1,
    in every pixel that hits; the Hit Distance view shows t from white (nearest) to black (farthest)."""
    scene = open_scene("light_point")
    scene.primer.use_adaptive_sampling = False
    scene.primer.samples = 1                       # the Depth pass is sample 0's: the one the Hit Distance shows
    passes = render(primer, scene, str(tmp_path / "t.exr"), view="HIT_DISTANCE", passes=("Depth", "Primer"))
    save("hit_distance", passes["Combined"])
    position, V, D, length = lecture_camera(scene, TARGETS["light_point"])
    t, depth = passes["Primer Hit Distance"][..., 0], passes["Depth"][..., 0]
    hit = depth < NO_HIT
    assert hit.mean() > 0.7
    np.testing.assert_allclose(t[hit] / depth[hit], length[hit], rtol=3e-3)   # (the ray's point anywhere in its pixel)
    near, far = t[hit].min(), t[hit].max()
    np.testing.assert_allclose(passes["Combined"][..., 0][hit], 1.0 - (t[hit] - near) / (far - near), atol=1e-5)
    assert not passes["Combined"][..., :3][~hit].any()


# ---------------------------------------------------------------------------
# 3. Fisheye lenses
# ---------------------------------------------------------------------------

def test_fisheye_images_are_black_outside_their_circle(primer, tmp_path):
    """Equidistant: theta = r * fov/2 up to r = 1, where u, v in [-1, 1] span the frame (an ellipse touching
    its edges, moved by the shift). Equisolid: r = 2 f sin(theta/2) on the sensor, a circle of radius
    2 f sin(fov/4). Outside: no ray, black; inside: the scene (black only in shadows)."""
    for name in ("camera_fisheye_equidistant", "camera_fisheye_equisolid"):
        scene = open_scene(name)
        image = render(primer, scene, str(tmp_path / f"{name}.exr"))["Combined"][..., :3]
        save(name.replace("camera_", ""), np.dstack([image, np.ones(image.shape[:2])]))
        cam = scene.camera.data
        height, width = image.shape[:2]
        ys, xs = np.mgrid[0:height, 0:width]
        u = (xs + 0.5) / width + cam.shift_x - 0.5
        v = (height - ys - 0.5) / height + cam.shift_y - 0.5
        if cam.panorama_type == "FISHEYE_EQUIDISTANT":
            r = np.hypot(2 * u, 2 * v)                          # 1 on the ellipse
            pixel = 2.0 / min(width, height)                    # one pixel in these units (at most)
        else:
            sensor_h = cam.sensor_height                        # vertical fit: the sensor height spans the image
            r = np.hypot(u * sensor_h * width / height, v * sensor_h) / (2 * cam.fisheye_lens *
                                                                         math.sin(0.25 * cam.fisheye_fov))
            pixel = sensor_h / height / (2 * cam.fisheye_lens * math.sin(0.25 * cam.fisheye_fov))
        outside, inside = r > 1 + pixel, r < 1 - pixel
        assert outside.sum() > 0.1 * r.size and inside.sum() > 0.4 * r.size
        assert not image[outside].any()
        assert (image[inside].max(axis=-1) > 0).mean() > 0.9


# ---------------------------------------------------------------------------
# 4. Shadow rays
# ---------------------------------------------------------------------------

def test_shadow_rays_decide_lit_or_dark(primer, tmp_path):
    """One point light: where every shadow ray was blocked, the floor is black (direct light only); where
    none was, it is lit. The Shadow Rays view is 1 or 0 except at the shadows' edges."""
    scene = open_scene("light_point")
    shadow = render(primer, scene, str(tmp_path / "shadow.exr"), view="VISIBILITY", passes=("Depth",))
    save("shadow_rays", shadow["Combined"])
    combined = render(primer, scene, str(tmp_path / "lit.exr"), passes=("Depth",))["Combined"][..., :3]
    visibility = shadow["Combined"][..., 0]
    position, V, D, _ = lecture_camera(scene, TARGETS["light_point"])
    floor = floor_pixels(shadow["Depth"][..., 0], scene, TARGETS["light_point"])
    dark, lit = floor & (visibility == 0.0), floor & (visibility == 1.0)
    assert dark.sum() > 200 and lit.sum() > 5000
    assert not combined[dark].any()
    assert (combined[lit].min(axis=-1) > 0.0).all()
    assert np.isin(visibility[floor], (0.0, 1.0)).mean() > 0.95


# ---------------------------------------------------------------------------
# 5. Shadow acne, epsilon, t_max
# ---------------------------------------------------------------------------

def test_epsilon_zero_makes_acne_and_the_robust_offset_removes_it(primer, tmp_path):
    """The lecture's epsilon offset at epsilon = 0: most shadow rays hit the surface they leave, the acne view
    marks most of the image and the picture goes dark; the robust offset: (almost) no acne, light back."""
    scene = open_scene("light_point")
    scene.primer.shadow_method = "EPSILON"
    scene.primer.epsilon = 0.0
    acne = render(primer, scene, str(tmp_path / "acne.exr"), view="ACNE")["Combined"][..., :3]
    save("acne_epsilon_0_view", np.dstack([acne, np.ones(acne.shape[:2])]))
    speckled = save("acne_epsilon_0", render(primer, scene, str(tmp_path / "speckled.exr"))["Combined"])
    scene.primer.shadow_method = "ROBUST"
    clean = save("light_point", render(primer, scene, str(tmp_path / "clean.exr"))["Combined"])
    clean_acne = render(primer, scene, str(tmp_path / "clean_acne.exr"), view="ACNE")["Combined"][..., :3]
    assert (acne.max(axis=-1) > 0).mean() > 0.5
    assert not (clean_acne.max(axis=-1) > 0).any()
    assert speckled[..., :3].mean() < 0.5 * clean[..., :3].mean()


def test_reduced_t_max_lets_a_lamp_on_the_floor_light_the_scene(primer, tmp_path):
    """A point light lying on the floor, the lecture's epsilon offset: with t_max reduced by 2 epsilon the
    objects are lit from below; with t_max = |P_light - I| every shadow ray ends epsilon beyond the light,
    inside the floor, and the whole image goes black."""
    scene = open_scene("light_point")
    scene.primer.shadow_method = "EPSILON"
    light_object(scene).location = (0.4, -1.8, 0.0)
    reduced = save("t_max_reduced", render(primer, scene, str(tmp_path / "reduced.exr"))["Combined"])
    scene.primer.reduce_t_max = False
    full = save("t_max_not_reduced", render(primer, scene, str(tmp_path / "full.exr"))["Combined"])
    world = np.array(scene.world.color)
    assert (reduced[..., :3].max(axis=-1) > 0.2).sum() > 300
    assert (full[..., :3] <= world + 1e-6).all()              # nothing but the world colour (and black)


# ---------------------------------------------------------------------------
# 6. Distance attenuation 1/r^2
# ---------------------------------------------------------------------------

ATTENUATION_OFF_EXPOSURE = -3.5         # Color Management > Exposure for the picture without 1/r^2


def test_distance_attenuation_is_inverse_square(primer, tmp_path):
    """Switching Distance Attenuation off multiplies each lit floor pixel by exactly r^2, its squared
    distance to the light: far from the light the floor gets much brighter than near it."""
    scene = open_scene("light_point")
    on = render(primer, scene, str(tmp_path / "on.exr"), passes=("Depth", "Primer"))
    save("light_point", on["Combined"])
    scene.primer.distance_attenuation = False
    off = render(primer, scene, str(tmp_path / "off.exr"))["Combined"]
    save("attenuation_off", off, exposure=ATTENUATION_OFF_EXPOSURE)
    position, V, D, _ = lecture_camera(scene, TARGETS["light_point"])
    floor = floor_pixels(on["Depth"][..., 0], scene, TARGETS["light_point"])
    floor &= on["Primer Shadow"][..., 0] == 1.0                    # fully lit: every shadow ray got through
    P_light = np.array(light_object(scene).location)

    def squared_distance(D):
        t = floor_distance(position, D)
        I = position + np.where(np.isfinite(t), t, 0.0)[..., None] * D
        return ((I - P_light) ** 2).sum(axis=-1)

    r2 = squared_distance(D)
    # Towards the horizon one pixel spans metres of floor: keep pixels whose r^2 is nearly the same all over.
    floor &= np.abs(squared_distance(lecture_camera(scene, TARGETS["light_point"], raster_offset=(0.5, 0.0))[2])
                    / r2 - 1.0) < 0.01
    assert floor.sum() > 5000 and r2[floor].max() > 4 * r2[floor].min()
    np.testing.assert_allclose(off[..., 0][floor] / on["Combined"][..., 0][floor], r2[floor], rtol=0.01)


# ---------------------------------------------------------------------------
# 7. Absorption by the material colour
# ---------------------------------------------------------------------------

def test_material_colour_scales_the_light_channel_by_channel(primer, tmp_path):
    """Reflected = incoming x C_material: on the red sphere every pixel's RGB is proportional to
    albedo x light colour; on the unshadowed floor it is (0.8 / pi) S sin(40 deg) x light colour."""
    scene = open_scene("light_sun")
    passes = render(primer, scene, str(tmp_path / "sun.exr"), passes=("Depth",))
    image = save("absorption", passes["Combined"])[..., :3]
    light = light_object(scene).data
    colour = np.array(light.color)
    red = np.array(bpy.data.materials["Red"].diffuse_color[:3])
    grey = np.array(bpy.data.materials["Grey"].diffuse_color[:3])
    position, V, D, _ = lecture_camera(scene, TARGETS["light_sun"])
    sphere = sphere_core(position, D, bpy.data.objects["Sphere"].location, 0.8)
    lit_sphere = sphere & (image[..., 0] > 0.01)
    assert lit_sphere.sum() > 200
    expected = red * colour / (red * colour)[0]
    np.testing.assert_allclose(image[lit_sphere] / image[lit_sphere][:, :1], np.broadcast_to(expected, (
        lit_sphere.sum(), 3)), rtol=1e-4)
    floor = floor_pixels(passes["Depth"][..., 0], scene, TARGETS["light_sun"])
    sun_floor = grey / math.pi * light.energy * math.sin(math.radians(40.0)) * colour
    lit_floor = floor & (np.abs(image - sun_floor).max(axis=-1) < 0.01 * sun_floor.max())
    assert lit_floor.mean() > 0.3                       # most of the floor, all but the shadows
    np.testing.assert_allclose(np.median(image[lit_floor], axis=0), sun_floor, rtol=2e-3)


# ---------------------------------------------------------------------------
# 8. N.L, clamped; no shadow rays for lights behind the surface
# ---------------------------------------------------------------------------

def test_n_dot_l_view_is_the_cosine_law(primer, tmp_path):
    """Under the low sun (20 deg, no disk) the N.L view is sin(20 deg) = 0.342 on the whole floor, shadows
    included (N.L is not visibility), and clamped to 0 on the far sides of the spheres. Without the clamp
    the image has negative pixels."""
    scene = open_scene("shading_flat_smooth")
    passes = render(primer, scene, str(tmp_path / "ndotl.exr"), view="N_DOT_L", passes=("Depth",))
    n_dot_l = save("n_dot_l", passes["Combined"])[..., 0]
    position, V, D, _ = lecture_camera(scene, TARGETS["shading_flat_smooth"])
    floor = floor_pixels(passes["Depth"][..., 0], scene, TARGETS["shading_flat_smooth"])
    assert floor.mean() > 0.3
    # (A pixel half on an object and half on the floor can match the floor's depth by chance: allow a few.)
    assert np.isclose(n_dot_l[floor], math.sin(math.radians(20.0)), rtol=1e-5).mean() > 0.995
    hit = passes["Depth"][..., 0] < NO_HIT
    assert n_dot_l.min() >= 0.0 and (hit & (n_dot_l == 0.0)).sum() > 100
    # Without the clamp, smooth normals that lean away from the sun while the face still faces it give
    # negative light, which the Combined pass keeps (a PNG shows it as black).
    assert render(primer, scene, str(tmp_path / "clamped.exr"))["Combined"][..., :3].min() >= 0.0
    scene.primer.clamp_n_dot_l = False
    assert render(primer, scene, str(tmp_path / "unclamped.exr"))["Combined"][..., :3].min() < 0.0


def test_negative_light_only_without_the_clamp(primer, tmp_path):
    """shading_visibility: on the 30-degree face the face still faces the sun, but near the steep face N
    turns away from it. With the clamp those pixels are 0; without it they hold (rho/pi) E N.L < 0, the
    closed-form interpolated N.L, and nowhere else is the image negative. The N.L view shows them blue."""
    scene = open_scene("shading_visibility")
    sheet = Sheet(scene)
    clamped = render(primer, scene, str(tmp_path / "clamped.exr"), passes=("Depth", "Primer"))
    scene.primer.clamp_n_dot_l = False
    unclamped = render(primer, scene, str(tmp_path / "unclamped.exr"), passes=("Depth", "Primer"))
    view = render(primer, scene, str(tmp_path / "view.exr"), view="N_DOT_L", passes=("Primer",))
    save("n_dot_l_signed", view["Combined"])
    on_face, I = sheet_pixels(scene, unclamped, sheet, NEGATIVE_FACE)
    n_dot_l = sheet.n_dot_l(NEGATIVE_FACE, I)
    lit = on_face & (unclamped["Primer Shadow"][..., 0] == 1.0)
    away = lit & (n_dot_l < -0.02)                              # whole pixels where N turns away from the sun
    assert away.sum() > 100
    expected = sheet.albedo / math.pi * sheet.E * n_dot_l[away][:, None]
    np.testing.assert_allclose(unclamped["Combined"][..., :3][away], expected, atol=0.01 * sheet.E / math.pi)
    assert not clamped["Combined"][..., :3][away].any()
    negative = (unclamped["Combined"][..., :3] < 0).any(axis=-1)
    assert clamped["Combined"][..., :3].min() >= 0.0 and negative.sum() >= away.sum()
    assert near_face(on_face, 2)[negative].all()                # negative light only on that face (and its edges)
    blue = view["Combined"][..., :3]
    assert (blue[away][:, 2] > 0).all() and not blue[away][:, :2].any()


def test_no_shadow_rays_for_lights_behind_the_surface(primer, tmp_path):
    """Rays per Pixel, 4 samples everywhere: camera ray plus shadow ray (8 per pixel) where the sun is in front
    of the surface, the camera ray alone (4, red at half the scale) where it is behind. Casting the shadow
    rays there too (Back-Facing Lights) turns those pixels white and leaves the image unchanged."""
    scene = open_scene("shading_flat_smooth", samples=4)
    scene.primer.use_adaptive_sampling = False
    engine = addon_module(primer, "engine")
    skipped = save("rays_skip_backfacing", render(primer, scene, str(tmp_path / "skip.exr"), view="RAYS")["Combined"])
    image_skipped = render(primer, scene, str(tmp_path / "skip_image.exr"))["Combined"]
    rays_skipped = engine.last_render.rays
    scene.primer.shadow_rays_for_backfacing = True
    cast = save("rays_cast_backfacing", render(primer, scene, str(tmp_path / "cast.exr"), view="RAYS")["Combined"])
    image_cast = render(primer, scene, str(tmp_path / "cast_image.exr"))["Combined"]
    np.testing.assert_array_equal(image_cast, image_skipped)
    assert engine.last_render.rays > rays_skipped
    x_skipped, x_cast = invert_heat(skipped[..., :3]), invert_heat(cast[..., :3])
    np.testing.assert_allclose(x_skipped.max(), 1.0)            # 8 rays: the most any pixel casts
    backfacing = np.isclose(x_skipped, 0.5) & np.isclose(x_cast, 1.0)
    assert backfacing.sum() > 300                               # the spheres' far sides and the boxes' shaded faces
    assert (x_cast >= x_skipped - 1e-6).all()


# The open sheet of shading_visibility: face 1 (30 degrees) faces the sun but N turns away from it near the
# steep face 0; face 3 (50 degrees) faces away from the sun but N turns towards it near the valley.
NEGATIVE_FACE, LEAK_FACE = 1, 3


class Sheet:
    """shading_visibility's sheet in closed form, from its mesh: a polyline profile (x, z) extruded along y."""

    def __init__(self, scene):
        sheet = bpy.data.objects["Sheet"]
        assert np.allclose(np.array(sheet.matrix_world), np.eye(4))
        vertices = np.array([v.co[:] for v in sheet.data.vertices])
        self.profile = vertices[: len(vertices) // 2][:, [0, 2]]          # (n, 2) x, z at the front edge
        edges = np.diff(self.profile, axis=0)
        lengths = np.linalg.norm(edges, axis=1)
        self.face_normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1) / lengths[:, None]   # (n - 1, 2), up
        # Vertex normals: the mean of the adjacent faces' normals (each quad corner is 90 degrees), normalized.
        sums = np.zeros_like(self.profile)
        sums[:-1] += self.face_normals
        sums[1:] += self.face_normals
        self.vertex_normals = sums / np.linalg.norm(sums, axis=1, keepdims=True)
        sun = light_object(scene)
        self.L = np.array(sun.matrix_world.col[2][:3])[[0, 2]]             # towards the sun, in the XZ plane
        assert abs(sun.matrix_world.col[2][1]) < 1e-6                      # the sun shines across the profile
        self.E = sun.data.energy
        self.albedo = np.array(bpy.data.materials["Sheet"].diffuse_color[:3])

    def face_normal_3d(self, face: int) -> np.ndarray:
        """Ng of a face, (3,)."""
        nx, nz = self.face_normals[face]
        return np.array([nx, 0.0, nz])

    def n_dot_l(self, face: int, I: np.ndarray) -> np.ndarray:
        """Interpolated N.L at hit points I (..., 3) on `face`: N = normalize((1 - s) N_a + s N_b) along the profile."""
        a, b = self.profile[face], self.profile[face + 1]
        s = np.clip(((I[..., [0, 2]] - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        N = (1 - s)[..., None] * self.vertex_normals[face] + s[..., None] * self.vertex_normals[face + 1]
        return (N @ self.L) / np.linalg.norm(N, axis=-1)


def near_face(mask: np.ndarray, reach: int) -> np.ndarray:
    """The pixels within `reach` pixels (in x and y) of `mask` (H, W) bool."""
    grown = np.pad(mask, reach)
    height, width = mask.shape
    return np.logical_or.reduce([grown[reach + dy:reach + dy + height, reach + dx:reach + dx + width]
                                 for dy in range(-reach, reach + 1) for dx in range(-reach, reach + 1)])


def sheet_pixels(scene, passes, sheet: Sheet, face: int):
    """Pixels wholly on one face of the sheet (every sample's face normal is its Ng) and their hit points (H, W, 3)."""
    position, V, D, _ = lecture_camera(scene, TARGETS["shading_visibility"])
    I = position + (passes["Depth"][..., 0] / (D @ V))[..., None] * D
    on_face = np.abs(passes["Primer Face Normal"] - sheet.face_normal_3d(face)).max(axis=-1) < 1e-5
    return on_face, I


# ---------------------------------------------------------------------------
# 9. Normals flipped when a triangle is hit from behind
# ---------------------------------------------------------------------------

INSIDE_EXPOSURE = -2.0


def test_inside_the_sphere_normals_face_the_ray(primer, tmp_path):
    """The camera at the sphere's centre sees the inside of every triangle: N is turned to face the ray
    (N.D < 0), here N = -D up to the facets, and a light inside the sphere lights every pixel."""
    scene = open_scene("light_point")
    sphere = bpy.data.objects["Sphere"]
    centre = np.array(sphere.location)
    scene.camera.location = sphere.location
    light_object(scene).location = centre + (0.0, 0.0, 0.4)
    passes = render(primer, scene, str(tmp_path / "inside.exr"), passes=("Normal",))
    save("inside_sphere", passes["Combined"], exposure=INSIDE_EXPOSURE)
    normal_view = render(primer, scene, str(tmp_path / "inside_normal.exr"), view="NORMAL")["Combined"]
    save("inside_sphere_normal", normal_view)
    target = centre + (np.array(TARGETS["light_point"]) - np.array((0.0, -6.5, 3.6)))   # the stage camera's aim
    _, _, D, _ = lecture_camera(scene, target)
    N = passes["Normal"]
    assert ((N * D).sum(axis=-1) < -0.98).all()
    np.testing.assert_allclose(N, -D, atol=0.1)
    assert (passes["Combined"][..., 0] > 0.05).all()


# ---------------------------------------------------------------------------
# 10. Smooth shading: interpolated vertex normals; the face normal for visibility
# ---------------------------------------------------------------------------

def test_smooth_normals_change_only_smooth_meshes(primer, tmp_path):
    """Smooth Normals off gives every triangle its face normal: the image changes only where the Normal
    Disagreement view shows an angle between N and the face normal (the smooth sphere, the smooth-by-angle
    cylinder, the box with custom normals); the flat sphere and the floor stay the same to the bit."""
    scene = open_scene("shading_flat_smooth", samples=4)
    scene.primer.use_adaptive_sampling = False                  # the same samples in both pictures
    smooth = save("smooth_on", render(primer, scene, str(tmp_path / "smooth.exr"))["Combined"])
    angle = render(primer, scene, str(tmp_path / "angle.exr"), view="NORMAL_ANGLE", passes=("Primer",))
    save("normal_disagreement", angle["Combined"])
    scene.primer.smooth_normals = False
    flat = save("smooth_off", render(primer, scene, str(tmp_path / "flat.exr"))["Combined"])
    changed = np.abs(smooth - flat).max(axis=-1) > 0
    bent = angle["Primer Normal Angle"][..., 0] > 0
    assert changed.sum() > 300
    assert not (changed & ~bent).any()
    np.testing.assert_allclose(angle["Combined"][..., :3], debug.heat(angle["Primer Normal Angle"][..., 0] / 30.0),
                               atol=1e-6)


def test_face_normal_decides_visibility_on_an_open_sheet(primer, tmp_path):
    """shading_visibility: the 50-degree face turns away from the sun (Ng.L < 0), but near the valley its
    interpolated N faces it. The lecture's face rule leaves every pixel of that face exactly 0; the shading
    rule lets light through the open sheet: (rho/pi) E N.L with the closed-form interpolated N.L."""
    scene = open_scene("shading_visibility")
    sheet = Sheet(scene)
    assert sheet.face_normals[LEAK_FACE] @ sheet.L < 0 < sheet.vertex_normals[LEAK_FACE] @ sheet.L
    face = render(primer, scene, str(tmp_path / "face.exr"), passes=("Depth", "Primer"))
    save("visibility_face", face["Combined"])
    scene.primer.visibility_normal = "SHADING"
    shading = render(primer, scene, str(tmp_path / "shading.exr"), passes=("Depth", "Primer"))
    save("visibility_shading", shading["Combined"])
    on_face, I = sheet_pixels(scene, shading, sheet, LEAK_FACE)
    assert on_face.sum() > 500
    assert not face["Combined"][..., :3][on_face].any()
    n_dot_l = sheet.n_dot_l(LEAK_FACE, I)
    leak = on_face & (n_dot_l > 0.02)
    assert leak.sum() > 300 and (shading["Primer Shadow"][..., 0][leak] == 1.0).all()   # nothing blocks it
    expected = sheet.albedo / math.pi * sheet.E * n_dot_l[leak][:, None]
    np.testing.assert_allclose(shading["Combined"][..., :3][leak], expected, atol=0.01 * sheet.E / math.pi)


# ---------------------------------------------------------------------------
# 11. "Use that debug output": debug views and the ray inspector
# ---------------------------------------------------------------------------

def test_barycentrics_sum_to_one(primer, tmp_path):
    """The Barycentrics view paints (1 - u - v, u, v) as RGB: the channels sum to 1 wherever a surface was
    hit, so each triangle shows red, green and blue corners; the world stays black."""
    scene = open_scene("shading_flat_smooth")
    passes = render(primer, scene, str(tmp_path / "bary.exr"), view="BARYCENTRIC", passes=("Depth",))
    bary = save("barycentrics", passes["Combined"])[..., :3]
    # Pixels whose 3 x 3 neighbourhood all hit (or all missed) in sample 0's Depth: every sample did the same there.
    hit = np.pad(passes["Depth"][..., 0] < NO_HIT, 1, mode="edge")
    H, W = bary.shape[:2]
    near = [hit[1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    inside, outside = np.all(near, axis=0), ~np.any(near, axis=0)
    np.testing.assert_allclose(bary[inside].sum(axis=-1), 1.0, atol=1e-5)
    assert not bary[outside].any() and outside.sum() > 100


INSPECTED_PIXEL = (120, 100)        # x from the left, y from the top: on the floor, lit by the point light


def inspector_quotes() -> dict:
    """The inspector's numbers that docs/tour.md quotes, by name (its '| name | value |' rows)."""
    with open(TOUR, encoding="utf-8") as handle:
        text = handle.read()
    section = text.split("<!-- inspector:start -->")[1].split("<!-- inspector:end -->")[0]
    return dict(re.findall(r"^\| (.+?) \| `(.+?)` \|", section, re.M))


def test_ray_inspector_numbers_match_the_closed_form_and_the_tour(primer):
    """Inspect a floor pixel of light_point: t, I, N, N.L, 1/r^2 and the contribution are the closed forms of
    a lit floor point, and docs/tour.md quotes them as the inspector shows them."""
    scene = open_scene("light_point")
    x, y = INSPECTED_PIXEL
    assert bpy.ops.primer.inspect_pixel(x=x, y=y) == {"FINISHED"}
    record = addon_module(primer, "inspector").state.record
    position, V, D, _ = lecture_camera(scene, TARGETS["light_point"])
    t_floor = floor_distance(position, D)[y, x]
    I = position + t_floor * D[y, x]
    light = light_object(scene)
    L = np.array(light.location) - I
    r = np.linalg.norm(L)
    n_dot_l = L[2] / r
    power = light.data.energy * 2.0 ** light.data.exposure
    albedo = np.array(bpy.data.materials["Grey"].diffuse_color[:3])
    contribution = albedo / math.pi * power / (4 * math.pi * r * r) * np.array(light.data.color) * n_dot_l
    assert record.object_name == "Floor"
    clip = scene.camera.data.clip_start / (D[y, x] @ V)          # the ray starts on the near clip plane
    assert record.t == pytest.approx(t_floor - clip, rel=1e-5)
    np.testing.assert_allclose(record.I, I, atol=1e-4)
    np.testing.assert_allclose(record.N, UP, atol=1e-6)
    (numbers,) = record.lights
    assert numbers.occluded is False
    assert numbers.n_dot_l == pytest.approx(n_dot_l, rel=1e-5)
    assert numbers.inverse_square == pytest.approx(1.0 / r ** 2, rel=1e-5)
    np.testing.assert_allclose(numbers.contribution, contribution, rtol=1e-5)
    quotes = inspector_quotes()
    assert quotes["t"] == f"{record.t:.3f}"
    assert quotes["I"] == "({:.3f}, {:.3f}, {:.3f})".format(*record.I)
    assert quotes["N"] == "({:.0f}, {:.0f}, {:.0f})".format(*np.abs(record.N))
    assert quotes["r"] == f"{r:.3f}"
    assert quotes["N·L"] == f"{numbers.n_dot_l:.4f}"
    assert quotes["1/r²"] == f"{numbers.inverse_square:.4f}"
    assert quotes["Contribution"] == "({:.4f}, {:.4f}, {:.4f})".format(*numbers.contribution)


# ---------------------------------------------------------------------------
# 12. Framerate: adaptive sampling and the viewport's coarse first pass
# ---------------------------------------------------------------------------

def test_adaptive_sampling_spends_rays_on_edges(primer, tmp_path):
    """64 samples at most, adaptive: the first pass gives every pixel 4 samples, and only edges and shadow
    boundaries get more. Most of the picture stays at the first pass (1/8 or less of the brightest
    pixel's rays); the brightest pixels reach all 64 samples."""
    scene = open_scene("light_point", samples=64)
    rays = save("adaptive_rays", render(primer, scene, str(tmp_path / "rays.exr"), view="RAYS")["Combined"])
    x = invert_heat(rays[..., :3])
    most = 64 * 2                                                # 64 samples x (camera + shadow ray)
    assert np.isclose(x.max(), 1.0)
    assert (x <= 4 * 2 / most + 1e-6).mean() > 0.6
    total = addon_module(primer, "engine").last_render.rays
    assert total < 0.25 * most * x.size


def test_viewport_coarse_pass_is_one_ray_per_block(primer):
    """The viewport's first pass traces one ray per 8 x 8 block (1/64 of the pixels) and repeats it over
    the block, so it is ready at once; the following passes refine it to the full image."""
    scene = open_scene("light_point")
    viewport = addon_module(primer, "viewport")
    progressive = importlib.import_module(f"{primer.__name__}.core.render.progressive")
    cache = addon_module(primer, "scene_cache").SceneCache()
    cache.sync(bpy.context.evaluated_depsgraph_get())
    settings = viewport.viewport_settings(scene)
    width, height = scene.render.resolution_x, scene.render.resolution_y
    camera = addon_module(primer, "export").export_camera(scene.camera)      # camera view: the scene's camera
    view = progressive.View(camera, (1.0, 1.0), width, height, (0, 0, width, height))
    passes = list(progressive.schedule(settings.samples, block=8, seed=SEED))
    assert passes[0].block == 8
    coarse = progressive.render_pass(cache.scene, settings, cache.geometry, view, passes[0])
    save("viewport_coarse", coarse)
    accumulator = progressive.Accumulator()
    for p in passes[1:]:
        refined = accumulator.add(progressive.render_pass(cache.scene, settings, cache.geometry, view, p), p.samples)
    save("viewport_refined", refined)
    assert accumulator.samples == settings.samples
    blocks = coarse.reshape(height // 8, 8, width // 8, 8, 4)
    np.testing.assert_array_equal(blocks, np.broadcast_to(blocks[:, :1, :, :1], blocks.shape))
    assert len(np.unique(blocks[:, 0, :, 0].reshape(-1, 4), axis=0)) > 20
    refined_blocks = refined.reshape(height // 8, 8, width // 8, 8, 4)
    flat_blocks = (refined_blocks == refined_blocks[:, :1, :, :1]).all(axis=(1, 3, 4))
    assert flat_blocks.mean() < 0.5                     # the refined image has detail inside the blocks


# ---------------------------------------------------------------------------
# 13-17. Beyond direct light: recursion, Fresnel, the rendering equation, MIS, Russian roulette
# ---------------------------------------------------------------------------

def glass_sphere_pixels(scene, index: int = 0) -> np.ndarray:
    """The (H, W) bool pixels whose centre ray meets sphere `index` of materials_glass first (radius 0.6 at
    x = -2.1 + 1.4 index, z = 0.6), away from its rim (85% of its radius)."""
    position, _, D, _ = lecture_camera(scene, (0.0, 0.4, 0.6))
    return sphere_core(position, D, np.array([-2.1 + 1.4 * index, 0.0, 0.6]), 0.6)


def test_recursion_depth_lets_glass_show_what_is_behind_it(primer, tmp_path):
    """Whitted's tracer on the glass spheres: at depth 0 clear glass shows only what it emits (nothing) and
    what lamps light directly (nothing: a smooth boundary is a delta), so it is black; each level adds
    the light of one more reflection or refraction and takes none away, so depth 4 is brighter everywhere
    and the clear sphere shows the stripes behind it."""
    scene = open_scene("materials_glass")
    scene.primer.integrator = "WHITTED"
    scene.primer.use_adaptive_sampling = False
    pictures = {}
    for depth in (0, 1, 4):
        scene.primer.max_bounces = depth
        pictures[depth] = save(f"recursion_{depth}", render(primer, scene, str(tmp_path / f"d{depth}.exr"))["Combined"])
    clear = glass_sphere_pixels(scene)
    assert clear.sum() > 200
    assert pictures[0][..., :3][clear].max() < 1e-6
    for low, high in ((0, 1), (1, 4)):
        assert (pictures[high][..., :3] >= pictures[low][..., :3] - 1e-6).all()
    assert pictures[4][..., :3][clear].mean() > 0.05


def test_schlicks_fresnel_is_close_to_the_exact_one_and_differs_most_at_the_rim(primer, tmp_path):
    """The same Whitted picture with Schlick's approximation instead of the exact Fresnel equations: for IOR
    1.45 the reflected share differs by at most 4% of the light, near grazing incidence (the two curves,
    computed here), so the pictures differ little; what differs lies towards the spheres' rims."""
    n = 1.45
    cos = np.linspace(0.0, 1.0, 2001)
    sin_t = np.sqrt(1.0 - cos ** 2) / n
    cos_t = np.sqrt(1.0 - sin_t ** 2)
    exact = 0.5 * (((cos - n * cos_t) / (cos + n * cos_t)) ** 2 + ((n * cos - cos_t) / (n * cos + cos_t)) ** 2)
    r0 = ((n - 1.0) / (n + 1.0)) ** 2
    schlick = r0 + (1.0 - r0) * (1.0 - cos) ** 5
    assert 0.03 < np.abs(exact - schlick).max() < 0.05
    scene = open_scene("materials_glass")
    scene.primer.integrator = "WHITTED"
    scene.primer.use_adaptive_sampling = False
    scene.primer.max_bounces = 4
    exact_picture = render(primer, scene, str(tmp_path / "exact.exr"))["Combined"][..., :3]
    scene.primer.fresnel = "SCHLICK"
    schlick_picture = save("fresnel_schlick", render(primer, scene, str(tmp_path / "schlick.exr"))["Combined"])[..., :3]
    difference = np.abs(schlick_picture - exact_picture).mean(axis=-1)
    assert difference.max() > 0.0
    assert difference.mean() < 0.01 * exact_picture.mean()
    position, _, D, _ = lecture_camera(scene, (0.0, 0.4, 0.6))
    whole = sphere_core(position, D, np.array([-2.1, 0.0, 0.6]), 0.6, fraction=0.98)
    core = sphere_core(position, D, np.array([-2.1, 0.0, 0.6]), 0.6, fraction=0.5)
    rim = whole & ~sphere_core(position, D, np.array([-2.1, 0.0, 0.6]), 0.6, fraction=0.8)
    assert difference[rim].mean() > difference[core].mean()


def test_each_bounce_of_the_rendering_equation_adds_light_where_lamps_cannot_reach(primer, tmp_path):
    """The Cornell box with direct light (Max Bounces 0), one bounce and Cycles' twelve: each added bounce only
    adds light (the Monte Carlo estimate of one more term of the rendering equation), so the mean brightness
    grows; the ceiling, which the lamp just below it cannot light, is black with direct light and lit by
    the light the walls and floor send back up."""
    scene = open_scene("cornell_box")
    scene.primer.use_adaptive_sampling = False
    pictures = {}
    for bounces in (0, 1, 12):
        scene.primer.max_bounces = bounces
        pictures[bounces] = save(f"cornell_bounces_{bounces}",
                                 render(primer, scene, str(tmp_path / f"b{bounces}.exr"))["Combined"])[..., :3]
    lamp = (pictures[0] > 1.0).any(axis=-1)                      # the lamp itself, and its rim
    height = pictures[0].shape[0]
    ceiling = np.zeros(lamp.shape, bool)
    ceiling[: height // 12] = True                               # the top rows: the ceiling
    ceiling &= ~lamp
    means = [pictures[b][~lamp].mean() for b in (0, 1, 12)]
    assert means[0] < 0.8 * means[1] < 0.8 * means[2]
    assert pictures[0][ceiling].mean() < 0.02 * pictures[12][ceiling].mean()
    assert pictures[12][ceiling].mean() > 0.01


def test_mis_beats_light_sampling_and_bsdf_sampling_at_equal_samples(primer, tmp_path):
    """Glossy spheres under a softbox and a point light, 16 samples each way: light samples alone miss the
    sharp reflections of the softbox, BSDF samples alone miss the lamps on the rough surfaces; both are
    unbiased (their means agree with MIS's within 2%), and MIS, which weighs the two by the power
    heuristic, has the lowest error (each strategy's variance, from two renders at different seeds: noise_of).
    (The dim world is switched off as a light: a constant world has no light samples in Primer, so light samples
    alone would miss it.)"""
    scene = open_scene("materials_principled")
    scene.primer.use_adaptive_sampling = False
    visibility = scene.world.cycles_visibility
    visibility.diffuse = visibility.glossy = visibility.transmission = visibility.scatter = False
    errors, pictures = {}, {}
    for strategy in ("LIGHT", "BSDF", "MIS"):
        scene.primer.light_sampling = strategy
        scene.primer.seed = SEED
        pictures[strategy] = save(f"sampling_{strategy.lower()}",
                                  render(primer, scene, str(tmp_path / f"{strategy}.exr"))["Combined"])
        scene.primer.seed = SEED + 1
        again = render(primer, scene, str(tmp_path / f"{strategy}_again.exr"))["Combined"]
        errors[strategy] = noise_of(pictures[strategy], again)
    print("MIS, light and BSDF sampling: relative MSE of blocks", errors)
    for strategy in ("LIGHT", "BSDF"):
        assert pictures[strategy][..., :3].mean() == pytest.approx(pictures["MIS"][..., :3].mean(), rel=0.02)
    assert errors["MIS"] < errors["LIGHT"] and errors["MIS"] < errors["BSDF"]


def noise_of(first: np.ndarray, second: np.ndarray) -> float:
    """One render's error (relative MSE of 4x4 blocks, core/film/compare.py) against its expectation, estimated from
    two renders (H, W, c) of the same scene at different seeds: twice the first's against their mean (the
    expected square of their difference is twice a render's variance). It stands for the error against a
    many-sample render, which adds that render's own variance and costs 16 times the samples."""
    return 2.0 * relative_mse_of_blocks(first, 0.5 * (first + second))


def test_russian_roulette_is_unbiased_cheaper_and_noisier(primer, tmp_path):
    """The Cornell box by path tracing, 16 samples: with Russian roulette (paths may end from the third
    vertex on, survivors count 1/q) the mean is the same as without (within 2%), fewer shadow rays are
    traced (at least 5 %: its walls' albedo keeps most paths to the fourth vertex, path.survival), and the error (the render's variance, from two renders at different seeds: noise_of) is larger at
    equal samples."""
    scene = open_scene("cornell_box")
    scene.primer.use_adaptive_sampling = False
    engine = addon_module(primer, "engine")
    results = {}
    for name, min_light_bounces in (("roulette", 0), ("no_roulette", 64)):
        scene.primer.min_light_bounces = min_light_bounces
        scene.primer.seed = SEED
        picture = save(f"cornell_{name}", render(primer, scene, str(tmp_path / f"{name}.exr"))["Combined"])
        rays = engine.last_render.stats.shadow_rays
        scene.primer.seed = SEED + 1
        again = render(primer, scene, str(tmp_path / f"{name}_again.exr"))["Combined"]
        results[name] = (picture, rays, noise_of(picture, again))
    (with_rr, rays_rr, error_rr), (without, rays_all, error_all) = results["roulette"], results["no_roulette"]
    print(f"Russian roulette: relative MSE of blocks {error_rr:.3e} (without {error_all:.3e}), shadow rays "
          f"{rays_rr} ({rays_all})")
    assert with_rr[..., :3].mean() == pytest.approx(without[..., :3].mean(), rel=0.02)
    assert rays_rr < 0.95 * rays_all
    assert error_rr > error_all


# ---------------------------------------------------------------------------
# 18-21. What real scenes need: textures, normal maps, microfacets, emitters and the world
# ---------------------------------------------------------------------------

def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of linear RGB (..., 3)."""
    return rgb[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


def edges_along(row: np.ndarray, jump: float) -> int:
    """How many times the values (w,) of a row jump by more than `jump` (relative) from one pixel to the next."""
    ratio = np.abs(np.diff(np.log(np.maximum(row, 1e-6))))
    return int((ratio > np.log(1.0 + jump)).sum())


def test_a_texture_is_looked_up_at_the_uv_the_mapping_scales(primer, tmp_path):
    """The checker floor reads its image at UV x Mapping Scale (Closest: each texel a flat square): doubling
    the scale from 3 to 6 doubles the checker squares along a row of the floor; the UV pass shows the (u, v)
    each pixel looks the texture up at, inside 0..1 on the floor."""
    scene = open_scene("materials_textures")
    scene.primer.use_adaptive_sampling = False
    scene.view_layers[0].use_pass_uv = True
    mapping = bpy.data.materials["Checker Floor"].node_tree.nodes["Mapping"]
    pictures = {}
    for scale in (3.0, 6.0):
        mapping.inputs["Scale"].default_value = (scale, scale, 1.0)
        result = render(primer, scene, str(tmp_path / f"scale{scale:g}.exr"))
        pictures[scale] = save(f"texture_scale_{scale:g}", result["Combined"])
        uv = result["UV"]
    # The UV pass's channels come as A, U, V (Blender sorts them): show (u, v, 0).
    save("texture_uv", np.concatenate([uv[..., 1:3], np.zeros_like(uv[..., :1]), np.ones_like(uv[..., :1])], axis=-1))
    row = pictures[3.0].shape[0] - 4                              # near the bottom: the floor alone
    counts = {scale: edges_along(luminance(pictures[scale][row]), 0.3) for scale in pictures}
    assert counts[3.0] >= 4
    assert 1.6 <= counts[6.0] / counts[3.0] <= 2.4
    assert np.all(uv[row, :, 0] == 1.0) and np.all((uv[row, :, 1:] >= 0.0) & (uv[row, :, 1:] <= 1.0))


def test_a_normal_map_turns_the_shading_normal_only(primer, tmp_path):
    """With the Normal Map's Strength at 0 the sphere's Normal pass is its smooth normal, (P - centre) / r
    from the Position pass; at 1 the bumps of the tangent-space map turn it away by several degrees, while
    the sphere's silhouette (its coverage) stays the same: the normal map changes shading, not geometry."""
    scene = open_scene("materials_textures")
    scene.primer.use_adaptive_sampling = False
    scene.view_layers[0].use_pass_position = True
    scene.view_layers[0].use_pass_object_index = True
    sphere = scene.objects["Mapped Sphere"]
    sphere.pass_index = 7
    centre, radius = np.array(sphere.matrix_world.translation), sphere.dimensions[0] / 2.0
    node = bpy.data.materials["Normal Mapped"].node_tree.nodes["Normal Map"]
    angles, coverage = {}, {}
    for strength in (0.0, 1.0):
        node.inputs["Strength"].default_value = strength
        result = render(primer, scene, str(tmp_path / f"n{strength:g}.exr"), passes=("Normal",))
        save(f"normal_map_{strength:g}", result["Combined"])
        if strength == 1.0:
            save("normal_map_pass", np.concatenate([0.5 + 0.5 * result["Normal"], np.ones_like(result["Normal"][..., :1])], -1))
        on = result["Object Index"][..., 0] == 7
        coverage[strength] = on.sum()
        smooth = (result["Position"][on] - centre) / radius
        smooth /= np.linalg.norm(smooth, axis=-1, keepdims=True)
        N = result["Normal"][on]
        cosines = np.clip(np.einsum("ij,ij->i", N / np.linalg.norm(N, axis=-1, keepdims=True), smooth), -1, 1)
        angles[strength] = np.degrees(np.arccos(cosines))
    assert coverage[0.0] == coverage[1.0] > 100
    assert np.median(angles[0.0]) < 2.0                           # the smooth normal of a 48 x 24 sphere
    assert np.median(angles[1.0]) > 10.0                          # the bumps


def test_a_rougher_microfacet_highlight_is_wider_and_dimmer(primer, tmp_path):
    """The Plastic sphere's GGX highlight of the point lamp at Roughness 0.1, 0.3 and 0.6: the peak falls and
    the highlight spreads over more pixels as the microfacet normals spread; with Specular IOR Level 0
    (F0 = 0, no Fresnel reflection) the highlight is gone and only the diffuse base remains."""
    scene = open_scene("materials_principled")
    scene.primer.use_adaptive_sampling = False
    scene.view_layers[0].use_pass_object_index = True
    sphere = scene.objects["Sphere 0"]
    sphere.pass_index = 3
    principled = bpy.data.materials["Plastic"].node_tree.nodes["Principled BSDF"]
    stats = {}
    for name, roughness, level in (("0.1", 0.1, 0.5), ("0.3", 0.3, 0.5), ("0.6", 0.6, 0.5), ("no_specular", 0.3, 0.0)):
        principled.inputs["Roughness"].default_value = roughness
        principled.inputs["Specular IOR Level"].default_value = level
        result = render(primer, scene, str(tmp_path / f"r{name}.exr"))
        save(f"microfacet_{name}", result["Combined"])
        on = result["Object Index"][..., 0] == 3
        Y = luminance(result["Combined"][on])
        stats[name] = (Y.max(), np.median(Y), (Y > 2.0 * np.median(Y)).sum())
    assert stats["0.1"][0] > stats["0.3"][0] > stats["0.6"][0]
    assert stats["0.3"][2] > stats["0.1"][2]
    assert stats["no_specular"][0] < 0.5 * stats["0.3"][0]


def test_emitters_and_the_world_light_the_scene_and_light_adds_up(primer, tmp_path):
    """An emissive mesh is a light: the light_emissive stage at the ceiling lamp's strength s and 2s differs
    from the stage with the lamp at 0 by a factor of 2 (light is linear in its sources). The world is a light:
    with world_light's sun at 0, open floor far from the objects shows albedo x the world's radiance (a Lambert
    plane under a uniform sky: L = rho x L_world), and the ground under the objects is darker, shadowed by them."""
    scene = open_scene("light_emissive", samples=64)
    scene.primer.use_adaptive_sampling = False
    emission = bpy.data.materials["Ceiling Lamp"].node_tree.nodes["Emission"].inputs["Strength"]
    s = emission.default_value
    images = {}
    for factor in (0.0, 1.0, 2.0):
        emission.default_value = s * factor
        images[factor] = render(primer, scene, str(tmp_path / f"e{factor:g}.exr"))["Combined"][..., :3]
    save("emitter_lamp", np.concatenate([images[1.0], np.ones_like(images[1.0][..., :1])], -1))
    lit = luminance(images[1.0] - images[0.0]) > 0.02
    ratio = luminance(images[2.0] - images[0.0])[lit].mean() / luminance(images[1.0] - images[0.0])[lit].mean()
    assert lit.mean() > 0.3 and ratio == pytest.approx(2.0, rel=0.03)
    scene = open_scene("world_light", samples=64)
    scene.primer.use_adaptive_sampling = False
    scene.objects["Sun"].data.energy = 0.0
    picture = save("world_sky_only", render(primer, scene, str(tmp_path / "sky.exr"))["Combined"])
    background = scene.world.node_tree.nodes["Background"]
    sky = np.array(background.inputs["Color"].default_value[:3]) * background.inputs["Strength"].default_value
    rho = np.array(bpy.data.materials["Grey"].node_tree.nodes["Diffuse BSDF"].inputs["Color"].default_value[:3])
    corner = picture[-6:, :6, :3].reshape(-1, 3)                   # floor in the bottom-left corner
    np.testing.assert_allclose(corner.mean(axis=0), rho * sky, rtol=0.05)


def keyframe_sideways(obj, frames: dict) -> None:
    """Keyframe obj.location at frame -> x offset along world X (linear), keeping its y and z."""
    y, z = obj.location.y, obj.location.z
    for frame, x in frames.items():
        obj.location = (x, y, z)
        obj.keyframe_insert("location", frame=frame)
    action = obj.animation_data.action
    curves = action.fcurves if hasattr(action, "fcurves") else [
        c for layer in action.layers for strip in layer.strips for bag in strip.channelbags for c in bag.fcurves]
    for curve in curves:
        for point in curve.keyframe_points:
            point.interpolation = "LINEAR"


def frame_at(scene, time: float) -> None:
    """Set the scene to the frame and subframe of a time in frames."""
    frame = math.floor(time)
    scene.frame_set(frame, subframe=time - frame)


def test_motion_blur_is_the_mean_of_still_images_over_the_shutter(primer, tmp_path):
    """Each camera ray has its own time in the shutter: the blurred image of a camera sliding sideways is the mean
    of the still images at times spread over the shutter (a box shutter: uniform between Cycles' first and last
    time), within the noise; with a rolling shutter of Duration 0 row r of H is the still image's row r at time
    (r + 1) / H, for every row."""
    scene = open_scene("light_point", samples=64)
    scene.primer.use_adaptive_sampling = False
    keyframe_sideways(scene.camera, {0: -0.6, 2: 0.6})
    scene.frame_set(1)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 1.0
    blurred = save("motion_blur", render(primer, scene, str(tmp_path / "blur.exr"))["Combined"])
    scene.cycles.rolling_shutter_type = "TOP"
    scene.cycles.rolling_shutter_duration = 0.0
    rolling = save("motion_rolling", render(primer, scene, str(tmp_path / "rolling.exr"))["Combined"])
    scene.render.use_motion_blur = False
    table = motion.shutter_table(np.ones(motion.CURVE_POINTS))
    first, last = float(table[0]), float(table[-1])
    scene.primer.samples = 16
    stills = []
    for k in range(16):                                  # times spread evenly over the shutter's span
        time = first + (last - first) * (k + 0.5) / 16
        frame_at(scene, 0.5 + time)
        stills.append(render(primer, scene, str(tmp_path / f"still{k}.exr"))["Combined"])
    mean = np.mean(stills, axis=0)
    error = relative_mse_of_blocks(blurred, mean)
    height = blurred.shape[0]
    rows = {}
    for row in (29, 59, 89, 119):                        # read at 1/4, 1/2, 3/4 and the end of the shutter
        frame_at(scene, 0.5 + (row + 1) / height)
        still = render(primer, scene, str(tmp_path / f"row{row}.exr"))["Combined"]
        rows[row] = float(np.abs(rolling[row, :, :3] - still[row, :, :3]).mean())
    scene.frame_set(1)
    static = render(primer, scene, str(tmp_path / "static.exr"))["Combined"]
    print(f"blurred vs mean of stills {error:.2e}, vs the still frame {relative_mse_of_blocks(blurred, static):.2e}; "
          f"rolling rows vs stills {rows}")
    assert relative_mse_of_blocks(blurred, static) > 10 * error
    assert error < 5e-5                      # (measured 2.3e-6; the still frame 3.6e-3)
    assert max(rows.values()) < 0.003        # (measured 8e-4 at most, a row along an edge)


def test_a_thin_lens_image_is_the_mean_of_pinhole_images_over_its_aperture(primer, tmp_path):
    """A thin lens of aperture radius A focused at distance s: each camera ray starts at its own point of the lens and
    passes the point of the focal plane its pixel sees. So the image is the mean of pinhole images taken from the
    points of the lens, each shifted (by -f o / (s S) of the sensor S for a lens point o) so that the focal plane stays
    where it was: 32 pinholes spread evenly over the aperture (a sunflower spiral) agree with the lens within the
    noise, and the pinhole at the lens's centre does not."""
    scene = open_scene("light_point", samples=64)
    scene.primer.use_adaptive_sampling = False
    camera = scene.camera
    lens, sensor = camera.data.lens, camera.data.sensor_width
    target = np.array(TARGETS["light_point"])
    R = np.array(camera.matrix_world, np.float64)[:3, :3]
    origin = np.array(camera.matrix_world.translation, np.float64)
    s = float(-(R[:, 2] @ (target - origin)))            # the focal plane's distance along the view axis
    A = 1.0                                              # the aperture's radius, metres (a wide lens: a big blur)
    camera.data.dof.use_dof = True
    camera.data.dof.focus_distance = s
    camera.data.dof.aperture_fstop = lens * 1e-3 / (2.0 * A)
    camera.data.dof.aperture_blades = 0
    thin_lens = save("thin_lens", render(primer, scene, str(tmp_path / "lens.exr"))["Combined"])
    camera.data.dof.use_dof = False
    pinhole = save("thin_lens_pinhole", render(primer, scene, str(tmp_path / "pinhole.exr"))["Combined"])
    scene.primer.samples = 16
    images, count = [], 32
    for k in range(count):                               # lens points o on the aperture, a sunflower spiral
        r, phi = A * math.sqrt((k + 0.5) / count), k * math.pi * (3.0 - math.sqrt(5.0))
        o = np.array([r * math.cos(phi), r * math.sin(phi)])
        camera.location = origin + R[:, :2] @ o
        camera.data.shift_x, camera.data.shift_y = -lens * o[0] / (s * sensor), -lens * o[1] / (s * sensor)
        images.append(render(primer, scene, str(tmp_path / f"hole{k}.exr"))["Combined"])
    mean = np.mean(images, axis=0)
    error, centre = relative_mse_of_blocks(thin_lens, mean), relative_mse_of_blocks(thin_lens, pinhole)
    print(f"thin lens vs the mean of {count} pinholes {error:.2e}, vs the pinhole at its centre {centre:.2e}")
    assert centre > 10 * error
    assert error < 1e-4


def box_chords(position, D, lo, hi) -> np.ndarray:
    """The length of each ray from `position` along D (..., 3) inside the box [lo, hi] (0 where it misses)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (np.asarray(lo) - position) / D, (np.asarray(hi) - position) / D
    t_in = np.maximum(np.minimum(a, b).max(axis=-1), 0.0)
    t_out = np.maximum(a, b).min(axis=-1)
    return np.maximum(t_out - t_in, 0.0)


def test_a_medium_lets_through_exp_of_minus_its_absorption_along_the_chord(primer, tmp_path):
    """Beer-Lambert: a cube of Volume Absorption (density d, colour c: sigma_a = d (1 - c)) in front of the camera
    dims what is seen through it by T = exp(-sigma_a x), x the camera ray's chord through the cube, channel by
    channel (tinted by what c lets through), and changes nothing around it."""
    scene = open_scene("light_point", samples=16)
    scene.primer.use_adaptive_sampling = False
    position, V, D, _ = lecture_camera(scene, TARGETS["light_point"])
    clear = render(primer, scene, str(tmp_path / "clear.exr"))["Combined"][..., :3]
    centre, half = position + 3.0 * V, 0.6
    bpy.ops.mesh.primitive_cube_add(size=2 * half, location=tuple(centre))
    cube = bpy.context.view_layer.objects.active
    material = bpy.data.materials.new("Smoke")
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    absorption = tree.nodes.new("ShaderNodeVolumeAbsorption")
    density, colour = 1.5, np.array([0.2, 0.5, 0.8])
    absorption.inputs["Color"].default_value = (*colour, 1.0)
    absorption.inputs["Density"].default_value = density
    tree.links.new(absorption.outputs["Volume"], tree.nodes["Material Output"].inputs["Volume"])
    cube.data.materials.append(material)
    foggy = save("medium_absorption", render(primer, scene, str(tmp_path / "foggy.exr"))["Combined"])[..., :3]
    # Pixels wholly inside the cube's outline (all four corners' rays cross it), against the closed form.
    corners = [lecture_camera(scene, TARGETS["light_point"], raster_offset=o)[2] for o in ((0, 0), (1, 0), (0, 1), (1, 1))]
    inside = np.all([box_chords(position, d, centre - half, centre + half) > 0.0 for d in corners], axis=0)
    outside = ~np.any([box_chords(position, d, centre - half, centre + half) > 0.0 for d in corners], axis=0)
    x = box_chords(position, D, centre - half, centre + half)
    T = np.exp(-density * (1.0 - colour) * x[..., None])
    seen = inside & (luminance(clear) > 0.02)
    ratio = foggy[seen] / np.maximum(clear[seen], 1e-6)
    print(f"{seen.sum()} pixels through the cube: measured / closed-form transmittance "
          f"{np.median(ratio / T[seen], axis=0)}, chords {x[seen].min():.2f}..{x[seen].max():.2f}")
    assert seen.sum() > 300 and x[seen].max() > 1.0
    np.testing.assert_allclose(np.median(ratio / T[seen], axis=0), 1.0, atol=0.01)
    assert np.percentile(np.abs(ratio / T[seen] - 1.0), 90) < 0.03
    np.testing.assert_allclose(foggy[outside], clear[outside], atol=1e-6)


def noise_floor(scene, detail: float):
    """Give the stage's floor (its Diffuse BSDF) a 2D Noise Texture (Scale 20: a lattice cell a metre wide on the
    20 m floor's Generated coordinates; Detail `detail`, Roughness 0.5, Lacunarity 2) as its Color, as the tour's
    stop on procedural noise tells the student to."""
    tree = scene.objects["Floor"].active_material.node_tree
    noise = tree.nodes.get("Noise Texture") or tree.nodes.new("ShaderNodeTexNoise")
    noise.noise_dimensions = "2D"
    noise.inputs["Scale"].default_value, noise.inputs["Detail"].default_value = 20.0, detail
    tree.links.new(noise.outputs["Fac"], tree.nodes["Diffuse BSDF"].inputs["Color"])


def noise_panels(primer, tmp_path, panels: list) -> list:
    """Render flat emitting panels side by side, each showing a 2D Noise Texture's Fac of (scale, detail) at the
    points c = floor(32 g) / 8 of its Generated coordinate g (every sample of a pixel reads the same point, a
    multiple of 1/8); return each panel's 32 x 32 values (rows top-down)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.primer.samples, scene.primer.seed = 1, SEED
    for k, (scale, detail) in enumerate(panels):
        material = bpy.data.materials.new(f"Noise {k}")
        material.use_nodes = True
        tree = material.node_tree
        tree.nodes.remove(tree.nodes["Principled BSDF"])
        generated = tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"]
        snap = tree.nodes.new("ShaderNodeVectorMath")
        snap.operation = "SNAP"
        snap.inputs[1].default_value = (1.0 / 32.0, 1.0 / 32.0, 1.0)
        grow = tree.nodes.new("ShaderNodeVectorMath")
        grow.operation = "SCALE"
        grow.inputs["Scale"].default_value = 4.0
        noise = tree.nodes.new("ShaderNodeTexNoise")
        noise.noise_dimensions = "2D"
        noise.inputs["Scale"].default_value, noise.inputs["Detail"].default_value = scale, detail
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(generated, snap.inputs[0])
        tree.links.new(snap.outputs[0], grow.inputs[0])
        tree.links.new(grow.outputs[0], noise.inputs["Vector"])
        tree.links.new(noise.outputs["Fac"], emission.inputs["Color"])
        tree.links.new(emission.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(k + 0.5, 0.0, 0.0))
        bpy.context.view_layer.objects.active.data.materials.append(material)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", float(len(panels))
    camera.location = (len(panels) / 2.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32 * len(panels), 32, 100
    image = render(primer, scene, str(tmp_path / "panels.exr"))["Combined"][..., 0].astype(np.float64)
    return [image[:, 32 * k:32 * (k + 1)] for k in range(len(panels))]


def test_noise_is_a_hashed_lattice_whose_octaves_add_up(primer, tmp_path):
    """Perlin noise: each lattice corner gets a gradient from a hash of its coordinates, and the noise at a point
    blends the corners' ramps, so it is 0 at every corner: Fac = 0.5 + 0.5 noise is exactly 0.5 at integer points
    (every 8th pixel of the panels at Scale 1). fBM adds octaves: with Detail 2, Roughness r = 0.5 and Lacunarity 2,
    Fac = 0.5 + 0.5 (n(p) + r n(2p) + r^2 n(4p)) / (1 + r + r^2), n read off the Detail 0 panels at Scale 1, 2 and
    4 (float32 rounding); and the hash makes the same point give the same value in every render. The tour's
    pictures: the stage's floor at Detail 0 and 4."""
    for detail, name in ((0.0, "noise_detail0"), (4.0, "noise_detail4")):
        scene = open_scene("light_point", samples=16)
        noise_floor(scene, detail)
        save(name, render(primer, scene, str(tmp_path / f"{name}.exr"))["Combined"])
    one, two, four, fbm = noise_panels(primer, tmp_path, [(1.0, 0.0), (2.0, 0.0), (4.0, 0.0), (1.0, 2.0)])
    rows, cols = np.mgrid[0:32, 0:32]
    corners = ((31 - rows) % 8 == 0) & (cols % 8 == 0)   # (pixel (r, c), rows top-down, reads (c / 8, (31 - r) / 8))
    print("Fac at the lattice corners", np.unique(one[corners]), "elsewhere", one[~corners].min(), one[~corners].max())
    np.testing.assert_array_equal(one[corners], 0.5)
    assert np.abs(one[~corners] - 0.5).max() > 0.1
    n = [2.0 * panel - 1.0 for panel in (one, two, four)]
    r = 0.5
    expected = 0.5 + 0.5 * (n[0] + r * n[1] + r * r * n[2]) / (1.0 + r + r * r)
    print("fBM against its octaves: largest difference", np.abs(fbm - expected).max())
    np.testing.assert_allclose(fbm, expected, atol=2e-6)
    np.testing.assert_array_equal(noise_panels(primer, tmp_path, [(1.0, 0.0)])[0], one)


def scatter_material(name: str, density: float, anisotropy: float):
    """A material with only a Volume Scatter (white, `density`, `anisotropy`) at its Volume output."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    scatter = tree.nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    scatter.inputs["Density"].default_value, scatter.inputs["Anisotropy"].default_value = density, anisotropy
    tree.links.new(scatter.outputs["Volume"], tree.nodes["Material Output"].inputs["Volume"])
    return material


def slab_under_sun(material, width: float, depth: float, top: float, E: float = 3.0):
    """An empty scene (no world: black) holding a slab `width` x `width` x `depth` of the material `material()` makes
    (called once the scene is empty) whose top is at z =
    `top`, a sun of strength E shining straight down, and an orthographic camera 2 wide looking straight down at
    16 x 16 pixels; returns the scene."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.primer.seed, scene.primer.use_adaptive_sampling = SEED, False
    scene.world = None
    scene.cycles.max_bounces = 0
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, top - 0.5 * depth))
    slab = bpy.context.view_layer.objects.active
    slab.scale = (width, width, depth)
    slab.data.materials.append(material())
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = E, 0.0
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.0
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x = scene.render.resolution_y = 16
    scene.render.resolution_percentage = 100
    return scene


def slab_glow(primer, tmp_path, anisotropy: float, density: float, depth: float, E: float) -> float:
    """The mean of the pixels over a slab of Volume Scatter (`depth` deep, wider than the view) seen straight down
    under a sun shining straight down (strength E), 256 samples, max bounces 0."""
    scene = slab_under_sun(lambda: scatter_material("Slab", density, anisotropy), 10.0, depth, 1.0 + 0.5 * depth, E)
    scene.primer.samples = 256
    return float(render(primer, scene, str(tmp_path / "slab.exr"))["Combined"][..., :3].mean())


def test_a_medium_scatters_by_free_flight_and_its_phase_function(primer, tmp_path):
    """Single scattering: a slab d deep of a white Volume Scatter (sigma_s = sigma_t = density) under a sun straight
    above, seen straight down: the light turned back up at depth s crossed s going down and s coming up, so the view
    gathers E p(-1) sigma integral exp(-2 sigma s) ds = E p(-1) (1 - exp(-2 sigma d)) / 2, with p Henyey and
    Greenstein's phase function at cos theta = -1 (the light turns right round): 1 / 4 pi for g = 0, (1 - g^2) /
    (4 pi (1 + g)^3) for g = 0.5, 4.5 times less (forward-scattering fog sends little back). Within 0.2 %: free
    flight draws the depth in proportion to the transmittance, so every sample's weight T sigma_s / pdf is the
    same, and the sun's light there is exact. The tour's picture: the stage with a cube of fog around the lamp."""
    density, depth, E = 1.5, 0.8, 3.0
    for g in (0.0, 0.5):
        p = (1.0 - g * g) / (4.0 * math.pi * (1.0 + g) ** 3)
        expected = E * p * (1.0 - math.exp(-2.0 * density * depth)) / 2.0
        measured = slab_glow(primer, tmp_path, g, density, depth, E)
        print(f"g {g}: measured {measured:.5f}, closed form {expected:.5f}")
        assert measured == pytest.approx(expected, rel=2e-3)
    scene = open_scene("light_point", samples=16)
    lamp = light_object(scene)
    bpy.ops.mesh.primitive_cube_add(size=3.0, location=tuple(lamp.location))
    bpy.context.view_layer.objects.active.data.materials.append(scatter_material("Fog", 0.3, 0.0))
    save("medium_scatter", render(primer, scene, str(tmp_path / "fog.exr"))["Combined"])


def test_a_node_graph_becomes_weighted_closures_that_the_inspector_lists(primer, tmp_path):
    """The red sphere's material made a Mix Shader (Fac 0.3) of a Diffuse BSDF (its red) and a Glossy BSDF (GGX,
    roughness 0.3, white): at a sphere pixel the graph has become two closures, a diffuse one weighted 0.7 x red and
    a GGX one weighted 0.3 x white (alpha = roughness^2 = 0.09), each picked by one-sample MIS in proportion to its
    sampling weight (the mean of its weight); the inspector lists both, and no node values: a graph of constants is
    folded into the closures when the scene is exported, nothing of it runs per hit. The tour's picture: the stage
    with that sphere."""
    scene = open_scene("light_point", samples=16)
    tree = bpy.data.materials["Red"].node_tree
    principled = tree.nodes["Principled BSDF"]
    red = np.array(principled.inputs["Base Color"].default_value[:3])
    tree.nodes.remove(principled)
    diffuse, glossy, mix = (tree.nodes.new(kind) for kind in ("ShaderNodeBsdfDiffuse", "ShaderNodeBsdfAnisotropic",
                                                               "ShaderNodeMixShader"))
    diffuse.inputs["Color"].default_value = (*red, 1.0)
    glossy.distribution, glossy.inputs["Roughness"].default_value = "GGX", 0.3
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    mix.name, mix.inputs["Fac"].default_value = "Mix", 0.3
    tree.links.new(diffuse.outputs[0], mix.inputs[1])
    tree.links.new(glossy.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    picture = save("graph_closures", render(primer, scene, str(tmp_path / "mixed.exr"))["Combined"])
    reddish = picture[..., 0] - picture[..., 1:3].max(axis=-1)
    y, x = np.unravel_index(np.argmax(reddish), reddish.shape)
    assert bpy.ops.primer.inspect_pixel(x=int(x), y=int(y)) == {"FINISHED"}
    record = addon_module(primer, "inspector").state.record
    assert record.object_name == "Sphere"
    closures = {c.bsdf: c for c in record.material.closures}
    print({name: (c.weight, c.sample_weight, c.alpha) for name, c in closures.items()})
    np.testing.assert_allclose(closures["DIFFUSE"].weight, 0.7 * red, rtol=1e-6)
    (gloss,) = [c for name, c in closures.items() if name != "DIFFUSE"]
    np.testing.assert_allclose(gloss.weight, 0.3, rtol=1e-6)
    assert gloss.alpha == pytest.approx(0.09, rel=1e-6)
    assert closures["DIFFUSE"].sample_weight == pytest.approx(0.7 * red.mean(), rel=1e-6)
    assert gloss.sample_weight == pytest.approx(0.3, rel=1e-6)
    assert record.material.nodes == ()              # (a constant graph is folded when exported: nothing runs per hit)


def subsurface_material(name: str, color, radius: float):
    """A material whose Surface is a Subsurface Scattering node (Random Walk) of `color` and Scale `radius`."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new("ShaderNodeSubsurfaceScattering")
    node.falloff = "RANDOM_WALK"
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Scale"].default_value = radius
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return material


def wax_slab(colour, radius: float):
    """A slab 40 x 40 x 5 of Subsurface Scattering (Random Walk) whose top is z = 0 under a sun (3 W/m^2) straight
    above, seen straight down (slab_under_sun)."""
    return slab_under_sun(lambda: subsurface_material("Wax", colour, radius), 40.0, 5.0, 0.0)


def test_a_white_random_walk_loses_only_the_walks_its_step_cap_cuts_short(primer, tmp_path):
    """Subsurface scattering as a random walk: light enters, flies free inside (distances drawn from the medium's
    transmittance), scatters, and leaves where the walk crosses the surface again. A white medium absorbs nothing,
    so a slab wider and deeper than the walks would send back all that enters: E / pi, a white Lambert's. But a walk
    in a half-space can wander very long, and Cycles stops each at 256 steps (BSSRDF_MAX_BOUNCES), losing what has
    not come out by then: Primer and Cycles both show 0.90 E / pi (within 1 % of each other), the same at every radius
    (a half-space has no length of its own). A walk's chance of still being inside after n steps falls as 1 / sqrt(n),
    so with the cap raised four times, to 1024 (the Python reference), the slab loses about half as much (measured
    0.061 of E / pi against 0.103; less than 0.8 of it asserted), and a grey medium (0.5) is darker. The tour's picture: the stage's sphere as red wax."""
    from blender_env import render_pixels
    lambert = 3.0 / math.pi
    means = {}
    for radius in (0.05, 0.2):
        scene = wax_slab((1.0, 1.0, 1.0), radius)
        means[radius] = render_pixels(scene, "PRIMER", str(tmp_path / "p.exr"), 128)[..., :3].mean()
    cycles = render_pixels(scene, "CYCLES", str(tmp_path / "c.exr"), 128)[..., :3].mean()
    scene = wax_slab((1.0, 1.0, 1.0), 0.05)
    scene.primer.kernels = "NUMPY"
    scene.render.resolution_x = scene.render.resolution_y = 6
    walk = sys.modules[f"{primer.__name__}.core.integrators.subsurface"]
    cap = walk.MAX_STEPS
    try:
        walk.MAX_STEPS = 4 * cap
        longer = render_pixels(scene, "PRIMER", str(tmp_path / "long.exr"), 16)[..., :3].mean()
    finally:
        walk.MAX_STEPS = cap
    grey = render_pixels(wax_slab((0.5, 0.5, 0.5), 0.05), "PRIMER", str(tmp_path / "g.exr"), 16)[..., :3].mean()
    print(f"white walk / E/pi: radius 0.05 {means[0.05] / lambert:.4f}, 0.2 {means[0.2] / lambert:.4f}, Cycles "
          f"{cycles / lambert:.4f}, cap {4 * cap} {longer / lambert:.4f}; grey {grey / lambert:.4f}")
    assert means[0.05] == pytest.approx(cycles, rel=0.01) and means[0.2] == pytest.approx(cycles, rel=0.01)
    assert 0.85 < cycles / lambert < 0.95
    assert 1.0 - longer / lambert < 0.8 * (1.0 - means[0.05] / lambert)
    assert grey < 0.7 * means[0.05]
    scene = open_scene("light_point", samples=16)
    scene.objects["Sphere"].data.materials[0] = subsurface_material("Wax", (0.9, 0.25, 0.15), 0.3)
    save("subsurface_walk", render(primer, scene, str(tmp_path / "wax.exr"))["Combined"])


def test_every_picture_the_tour_shows_exists():
    """Each docs/images/tour/*.png that docs/tour.md links to is there (this module's tests write them)."""
    with open(TOUR, encoding="utf-8") as fh:
        shown = set(re.findall(r"images/tour/([\w.-]+)\.png", fh.read()))
    assert len(shown) > 40
    missing = sorted(name for name in shown if not os.path.isfile(os.path.join(PICTURES, f"{name}.png")))
    assert not missing, missing
