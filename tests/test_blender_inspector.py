"""The ray inspector inside real Blender (the bpy module): operator, stored record, panel rows, overlay, picking.

No mocks: each test builds a scene with bpy, runs `bpy.ops.primer.inspect_pixel` through Primer's
registration (tools/render.py's load_primer), and checks the record against closed forms and against
core's inspect_pixel. The gpu draw handler cannot run headless; what it draws comes from
addon/inspector_view.py, which is checked here.
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
from blender_env import lambert_everywhere  # noqa: E402

from core.film import image_io  # noqa: E402

pytestmark = pytest.mark.blender

CAMERA_HEIGHT = 3.0
CLIP_START = 0.01
ORTHO_SCALE = 4.0


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def module(primer, name):
    """Return one of the add-on's modules (primer.addon.<name>)."""
    return sys.modules[f"{primer.__name__}.addon.{name}"]


def add_light(scene, name, kind, location, energy, rotation=(0.0, 0.0, 0.0)):
    """Add a light without extent (radius 0 / angle 0) and return its object."""
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    if kind == "SUN":
        data.angle = 0.0
    else:
        data.shadow_soft_size = 0.0
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = rotation
    scene.collection.objects.link(obj)
    return obj


def add_plane(scene, name, size, center):
    """Add a horizontal square of side `size` centred at `center`, facing +Z."""
    h = 0.5 * size
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], [], [(0, 1, 2, 3)])
    obj = bpy.data.objects.new(name, mesh)
    obj.location = center
    scene.collection.objects.link(obj)
    return obj


def floor_scene(width=16, height=12):
    """An empty file: a 20 m floor at z = 0 seen straight down by an orthographic camera 3 m above it."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    lambert_everywhere(bpy.context.scene)       # the lecture's grey Lambert surface, for its closed forms
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.primer.samples = 1
    add_plane(scene, "Floor", 20.0, (0.0, 0.0, 0.0))
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = ORTHO_SCALE
    cam.data.clip_start = CLIP_START
    cam.location = (0.0, 0.0, CAMERA_HEIGHT)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return scene


def floor_point(x, y, width=16, height=12):
    """Where the centre of pixel (x, y) (row 0 at the top) of the orthographic view meets the floor."""
    pixel = ORTHO_SCALE / width                       # landscape: ortho_scale spans the width
    return np.array([(x + 0.5 - 0.5 * width) * pixel, (0.5 * height - y - 0.5) * pixel, 0.0])


def test_operator_record_matches_the_closed_forms_of_a_point_light_on_a_plane(primer):
    """Typed pixel -> record: t = height - clip start, N = +Z, N.L = h/r, 1/r^2, (0.8/pi) P/(4 pi r^2) N.L."""
    scene = floor_scene()
    P = np.array([1.0, -0.5, 2.0])
    add_light(scene, "Key", "POINT", P, 300.0)
    assert bpy.ops.primer.inspect_pixel(x=3, y=2) == {"FINISHED"}
    record = module(primer, "inspector").state.record
    I = floor_point(3, 2)
    r = np.linalg.norm(P - I)
    assert (record.x, record.y) == (3, 2) and record.hit and record.object_name == "Floor"
    assert record.t == pytest.approx(CAMERA_HEIGHT - CLIP_START, rel=1e-6)
    np.testing.assert_allclose(record.I, I, atol=1e-6)
    np.testing.assert_allclose(record.N, [0.0, 0.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(record.Ng, [0.0, 0.0, 1.0], atol=1e-9)
    (light,) = record.lights
    assert light.name == "Key" and light.cast and light.occluded is False
    assert light.n_dot_l == pytest.approx(P[2] / r, rel=1e-6)
    assert light.inverse_square == pytest.approx(1.0 / r ** 2, rel=1e-6)
    np.testing.assert_allclose(light.contribution, 0.8 / math.pi * 300.0 / (4 * math.pi * r * r) * P[2] / r,
                               rtol=1e-6)
    # The pixel typed into the operator is stored on the scene for the panel.
    settings = scene.primer_inspector
    assert (settings.x, settings.y) == (3, 2)


def test_operator_without_coordinates_uses_the_scene_pixel_and_equals_core(primer):
    """With x, y left out the operator reads scene.primer_inspector; its record is core's for the exported scene."""
    scene = floor_scene()
    add_light(scene, "Key", "POINT", (1.0, -0.5, 2.0), 300.0)
    add_light(scene, "Sun", "SUN", (0.0, 0.0, 5.0), 2.0, rotation=(math.radians(40), 0.0, math.radians(30)))
    scene.primer_inspector.x, scene.primer_inspector.y = 11, 7
    assert bpy.ops.primer.inspect_pixel() == {"FINISHED"}
    record = module(primer, "inspector").state.record
    export = module(primer, "export")
    core_inspector = sys.modules[f"{primer.__name__}.core.teaching.inspector"]
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    expected = core_inspector.inspect_pixel(exported.scene, exported.settings, 11, 7)
    assert (record.x, record.y) == (11, 7)
    assert record.t == expected.t and record.object_name == expected.object_name
    np.testing.assert_array_equal(record.I, expected.I)
    assert [light.name for light in record.lights] == ["Key", "Sun"]
    for got, want in zip(record.lights, expected.lights):
        assert got.n_dot_l == want.n_dot_l and got.inverse_square == want.inverse_square
        np.testing.assert_array_equal(got.contribution, want.contribution)
    # The sun: no distance attenuation, N.L = cos(40 degrees) for a sun tilted 40 degrees from straight down.
    sun = record.lights[1]
    assert sun.inverse_square is None and sun.n_dot_l == pytest.approx(math.cos(math.radians(40)), rel=1e-6)
    np.testing.assert_allclose(record.radiance, sum(light.contribution for light in record.lights), rtol=1e-12)


def test_panel_lists_the_records_numbers(primer):
    """The panel's rows show t, I, N, and per light N.L, 1/r^2, the shadow-ray state and the contribution."""
    scene = floor_scene()
    add_light(scene, "Key", "POINT", (1.0, -0.5, 2.0), 300.0)
    bpy.ops.primer.inspect_pixel(x=3, y=2)
    view = module(primer, "inspector_view")
    record = module(primer, "inspector").state.record
    sections = dict(view.panel_sections(record, height=12))
    camera = dict(sections["Camera ray"])
    assert camera["t"] == f"{CAMERA_HEIGHT - CLIP_START:.5g}" == "2.99"
    assert camera["Blender Y"].startswith("9 ")
    assert camera["N"].startswith("(0.0000, 0.0000, 1.0000)")
    light = dict(sections["Point 'Key'"])
    r = np.linalg.norm(np.array([1.0, -0.5, 2.0]) - floor_point(3, 2))
    assert light["1/r²"] == f"{1.0 / r ** 2:.5g}" and light["N·L"] == f"{2.0 / r:.5g}"
    assert light["Shadow ray"] == "unoccluded"
    contribution = 0.8 / math.pi * 300.0 / (4 * math.pi * r * r) * 2.0 / r
    assert light["Contribution"] == "(" + ", ".join([f"{contribution:.5g}"] * 3) + ")"


def test_overlay_colours_tell_unoccluded_occluded_and_not_cast_shadow_rays_apart(primer):
    """Three lights: one lit (green), one behind a blocker (red), one under the floor (grey dashes to the light)."""
    scene = floor_scene()
    I = floor_point(8, 6)
    add_light(scene, "Lit", "POINT", I + np.array([0.0, 2.0, 2.0]), 100.0)
    add_light(scene, "Blocked", "POINT", I + np.array([2.0, 0.0, 1.0]), 100.0)
    add_plane(scene, "Blocker", 0.2, I + np.array([1.0, 0.0, 0.5]))
    add_light(scene, "Below", "POINT", I + np.array([0.0, -1.0, -1.0]), 100.0)
    bpy.ops.primer.inspect_pixel(x=8, y=6)
    view = module(primer, "inspector_view")
    record = module(primer, "inspector").state.record
    lit, blocked, below = record.lights
    assert (lit.occluded, blocked.occluded, below.cast) == (False, True, False)
    segments = view.overlay_segments(record)
    parts = [s.part for s in segments]
    assert parts.count("primary") == 1 and parts.count("N") == 1 and parts.count("Ng") == 1
    assert parts.count("unoccluded") == 1 and parts.count("occluded") == 1
    assert parts.count("not cast") == view.DASHES
    by_part = {s.part: s for s in segments}
    assert by_part["unoccluded"].color == view.UNOCCLUDED
    assert by_part["occluded"].color == view.OCCLUDED
    assert all(s.color == view.NOT_CAST for s in segments if s.part == "not cast")
    assert len({view.UNOCCLUDED, view.OCCLUDED, view.NOT_CAST}) == 3
    # Geometry: the camera ray ends at I, shadow rays run from their origin to the light.
    np.testing.assert_allclose(by_part["primary"].end, I, atol=1e-6)
    np.testing.assert_allclose(by_part["unoccluded"].start, lit.shadow_origin)
    np.testing.assert_allclose(by_part["unoccluded"].end, I + [0.0, 2.0, 2.0], atol=1e-5)
    np.testing.assert_allclose(by_part["occluded"].end, I + [2.0, 0.0, 1.0], atol=1e-5)
    dashes = [s for s in segments if s.part == "not cast"]
    np.testing.assert_allclose(dashes[0].start, I, atol=1e-6)
    np.testing.assert_allclose(dashes[-1].end, I + [0.0, -1.0, -1.0], atol=1e-5)
    # Normals: a fifth of the camera ray's length, straight up.
    np.testing.assert_allclose(by_part["N"].end - by_part["N"].start, [0.0, 0.0, 0.2 * (CAMERA_HEIGHT - CLIP_START)],
                               atol=1e-6)
    # Turning shadow rays off leaves only the camera ray and the normals.
    assert {s.part for s in view.overlay_segments(record, shadow_rays=False)} == {"primary", "N", "Ng"}
    markers = view.overlay_markers(record)
    assert [m.color for m in markers] == [view.HIT_POINT, view.UNOCCLUDED, view.OCCLUDED, view.NOT_CAST]
    # Markers are drawn as 3D crosses centred on their point, in their colour.
    crosses = view.marker_segments(markers, 0.1)
    assert len(crosses) == 3 * len(markers)
    for k, marker in enumerate(markers):
        for segment in crosses[3 * k:3 * k + 3]:
            np.testing.assert_allclose(0.5 * (segment.start + segment.end), marker.point, atol=1e-12)
            assert np.linalg.norm(segment.end - segment.start) == pytest.approx(0.1)
            assert segment.color == marker.color


def test_pixel_outside_the_image_is_reported_not_raised_inside_blender(primer):
    """A pixel beyond the (percentage-scaled) image is an error report naming the range; the record stays."""
    scene = floor_scene(width=32, height=24)
    scene.render.resolution_percentage = 50
    add_light(scene, "Key", "POINT", (0.0, 0.0, 2.0), 100.0)
    assert bpy.ops.primer.inspect_pixel(x=15, y=11) == {"FINISHED"}
    kept = module(primer, "inspector").state.record
    with pytest.raises(RuntimeError, match=r"outside the 16x12 image"):
        bpy.ops.primer.inspect_pixel(x=16, y=0)
    state = module(primer, "inspector").state
    assert "outside" in state.error and state.record is kept


def test_scene_without_camera_is_reported(primer):
    """No camera: the export's clear message reaches Blender's report."""
    scene = floor_scene()
    scene.camera = None
    with pytest.raises(RuntimeError, match="no camera"):
        bpy.ops.primer.inspect_pixel(x=0, y=0)


def test_image_coordinates_map_to_render_pixels_with_rows_flipped(primer):
    """Image Editor (u, v) counts rows from the bottom; render pixels from the top; crop-to-border is offset."""
    view = module(primer, "inspector_view")
    full, whole = (16, 12), (0, 0, 16, 12)
    assert view.image_uv_to_pixel(0.0, 0.0, (16, 12), full, whole) == (0, 11)          # bottom-left
    assert view.image_uv_to_pixel(0.999, 0.999, (16, 12), full, whole) == (15, 0)      # top-right
    assert view.image_uv_to_pixel(0.5, 0.5, (0, 0), full, whole) == (8, 5)             # size unknown: the frame
    border = (4, 2, 8, 6)                                                              # x, y from the bottom, w, h
    assert view.image_uv_to_pixel(0.0, 0.0, (8, 6), full, border) == (4, 9)
    assert view.image_uv_to_pixel(0.999, 0.999, (8, 6), full, border) == (11, 4)
    with pytest.raises(ValueError, match="outside the image"):
        view.image_uv_to_pixel(1.2, 0.5, (16, 12), full, whole)
    with pytest.raises(ValueError, match="render again"):
        view.image_uv_to_pixel(0.5, 0.5, (20, 10), full, whole)


def test_picked_pixel_shows_the_rendered_value_of_that_pixel(primer, tmp_path):
    """Render, then pick by image coordinates: the shadow is where the image shows it (v counts rows upwards)."""
    scene = floor_scene()
    # The sun comes from -y, 60 degrees from straight down: the blocker's shadow falls 0.87 m towards +y,
    # the top of the image, at x in [-1.5, -0.5], y in [0.57, 1.57] (the blocker hides y < 0.7 from the camera).
    add_light(scene, "Sun", "SUN", (0.0, 0.0, 5.0), 2.0, rotation=(math.radians(60), 0.0, 0.0))
    add_plane(scene, "Blocker", 1.0, (-1.0, 0.2, 0.5))
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth = "OPEN_EXR", "32"
    scene.render.filepath = str(tmp_path / "pick.exr")
    scene.render.use_file_extension = False
    scene.view_settings.view_transform = "Standard"
    bpy.ops.render.render(write_still=True)
    image = image_io.read_image(str(tmp_path / "pick.exr"))      # (H, W, 4), row 0 at the top
    view = module(primer, "inspector_view")
    export = module(primer, "export")
    full = export.frame_size(scene.render)
    # (u, v) across the image from its bottom-left corner -> world (-2 + 4u, -1.5 + 3v) on the floor.
    for u, v, shadowed in [(0.2, 0.85, True), (0.2, 0.15, False), (0.8, 0.85, False), (0.05, 0.95, False)]:
        x, y = view.image_uv_to_pixel(u, v, full, full, export.border_rectangle(scene.render, *full))
        bpy.ops.primer.inspect_pixel(x=x, y=y)
        record = module(primer, "inspector").state.record
        assert record.object_name == "Floor"
        np.testing.assert_allclose(record.I[:2], [-2.0 + 4.0 * u, -1.5 + 3.0 * v], atol=0.5 * 4.0 / 16)
        assert record.lights[0].occluded is shadowed
        np.testing.assert_allclose(record.radiance, image[y, x, :3], rtol=1e-5, atol=1e-7)
        expected = 0.0 if shadowed else 0.8 / math.pi * 2.0 * 0.5          # N.L = cos 60 degrees
        np.testing.assert_allclose(image[y, x, :3], expected, rtol=1e-5, atol=1e-7)


def test_viewport_drawing_is_not_installed_in_background_mode(primer):
    """Headless Blender has no GPU context: no draw handler is added, and registering still succeeds."""
    assert bpy.app.background
    assert module(primer, "inspector")._draw_handle is None
    assert hasattr(bpy.types, "PRIMER_OT_inspect_pixel") or hasattr(bpy.ops.primer, "inspect_pixel")


def test_ray_diagram_operator_draws_the_rays_into_an_image(primer):
    """Primer > Ray Diagram: the row of the inspector's Y is drawn from above into image 'Primer Ray Diagram',
    with the camera's rays in their colour (bottom-up rows, as Blender stores images)."""
    scene = floor_scene()
    scene.primer_inspector.y = 6
    assert bpy.ops.primer.ray_diagram() == {"FINISHED"}
    image = bpy.data.images["Primer Ray Diagram"]
    pixels = np.array(image.pixels[:]).reshape(image.size[1], image.size[0], 4)
    yellow = np.all(np.isclose(pixels[..., :3], (1.0, 0.85, 0.1), atol=1e-6), axis=-1)
    assert yellow.any()
