"""Camera motion blur in real Blender (the bpy module): a camera sliding and turning over an emitting checker plane,
rendered by Cycles and by Primer with Render > Motion Blur on, blurs the same way. No mocks.

The scene: a plane whose emission is a Checker texture (strength 1, so no lamp and no lighting noise), a perspective
camera (or an equisolid fisheye) 4 above it whose location and rotation are keyframed linearly from frame 0 to 2 and
rendered at frame 1, a black world, Cycles' 1-pixel box filter in both. The error measure is the relative MSE of
4 x 4-pixel block means, mean((P - C)^2 / (C^2 + 0.01)); its threshold is set against Cycles' own noise: Cycles
rendered again with another seed differs from itself by about as much (measured below), while the still camera's
image is 30 to 600 times the tolerance away from the blurred one. Each part is needed: with a box curve in place of
the ramp Primer measures 4.5e-3, without the zoom 6.0e-3, with the shutter centred on the frame instead of starting
at it 0.11, without the rolling shutter 0.25 (all 9 times the tolerance or more).

Objects blur too (under a still camera, same measure): a cube flying and turning in the sun (its shadow smeared with
it), a bar spinning a quarter turn with Motion Steps 2, a sheet folding by a shape key (deformation motion) and a
floor lit only by a sliding, turning emitter (light-sampled where it is at each path's time) match Cycles within its
own noise (1.1e-5, 4.5e-5, 2.6e-5, 1.9e-5; the floor 3.1e-3 when the emitter was found by BSDF rays alone), the still
objects 1.1e-2 to 1.6e-2 away; a smooth sheet tilting into a low sun, its vertex normals interpolated at each ray's
time, 2.7e-5 (0.55 with the frame's normals; the still sheet 0.44).
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import configure_cycles_reference, load_primer  # noqa: E402

from core.film.compare import relative_mse_of_blocks  # noqa: E402
from test_blender_denoise import addon, render_image  # noqa: E402

pytestmark = pytest.mark.blender

WIDTH, HEIGHT = 32, 24
SAMPLES = 256
# Block relative MSE within which Primer matches Cycles: Cycles against itself with another seed measures 1.1e-4 to
# 2.7e-4 on these images (256 samples; the fisheye's the most), Primer against Cycles 6.9e-5 to 2.3e-4; the still
# camera 0.015 to 0.32.
BLOCK_TOLERANCE = 5e-4


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def emitting_checker(scene):
    """A 20 x 20 plane at z = 0 emitting a Checker texture (white and 0.1 grey squares 0.5 wide)."""
    mesh = bpy.data.meshes.new("Checker")
    mesh.from_pydata([(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], [], [(0, 1, 2, 3)])
    material = bpy.data.materials.new("Glow")
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    checker.inputs["Scale"].default_value = 40.0
    checker.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.1, 0.1, 1.0)
    tree.links.new(coordinates.outputs["Generated"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new("Checker", mesh))


def keyframe_linearly(obj, path: str, values: dict) -> None:
    """Keyframe obj.<path> at each frame of `values` (frame -> value) with linear interpolation."""
    for frame, value in values.items():
        setattr(obj, path, value)
        obj.keyframe_insert(path, frame=frame)
    action = obj.id_data.animation_data.action           # (a shape key's is its Key's)
    curves = action.fcurves if hasattr(action, "fcurves") else [
        c for layer in action.layers for strip in layer.strips for bag in strip.channelbags for c in bag.fcurves]
    for curve in curves:
        for point in curve.keyframe_points:
            point.interpolation = "LINEAR"


def moving_camera_scene(zoom: bool = False, kind: str = "PERSP"):
    """The checker plane under a camera that slides 1.2 along x, turns 0.5 rad about its axis and tilts 0.2 rad
    between frames 0 and 2 (rendered at frame 1); with zoom its lens also goes from 40 to 60 mm. Black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    emitting_checker(scene)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.data.type = kind
    if kind == "PANO":
        camera.data.panorama_type = "FISHEYE_EQUISOLID"
        camera.data.fisheye_fov = math.radians(150.0)
    keyframe_linearly(camera, "location", {0: (-0.6, 0.0, 4.0), 2: (0.6, 0.1, 4.0)})
    keyframe_linearly(camera, "rotation_euler", {0: (-0.1, 0.0, -0.25), 2: (0.1, 0.0, 0.25)})
    if zoom:
        keyframe_linearly(camera.data, "lens", {0: 40.0, 2: 60.0})
    scene.frame_set(1)
    scene.world = None
    scene.render.use_motion_blur = True
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False
    return scene


def render_with(scene, engine: str, path: str, seed: int = 0) -> np.ndarray:
    """The image (H, W, 3) rendered by `engine` at SAMPLES samples, 1-pixel box filter; Cycles with `seed`."""
    if engine == "CYCLES":
        configure_cycles_reference(scene, SAMPLES)
        scene.cycles.seed = seed
    else:
        scene.render.engine = "PRIMER"
        scene.primer.samples = SAMPLES
        scene.cycles.pixel_filter_type = "BOX"
        scene.cycles.filter_width = 1.0
    return render_image(scene, path, reference=True)[..., :3]


SHUTTERS = {
    "centre, shutter 0.5": dict(shutter=0.5),
    "centre, shutter 1.0": dict(shutter=1.0),
    "start, shutter 1.0, a ramp curve and a zoom": dict(shutter=1.0, position="START", ramp=True, zoom=True),
    "rolling shutter, duration 0.3": dict(shutter=1.0, rolling=0.3),
    "equisolid fisheye, end, shutter 1.0": dict(shutter=1.0, position="END", kind="PANO"),
}


@pytest.mark.parametrize("case", list(SHUTTERS))
def test_a_moving_camera_blurs_as_in_cycles(primer, tmp_path, case):
    """Primer's blurred image is Cycles' within Cycles' own noise (block relative MSE), far from the still camera's,
    and the render says nothing about motion blur (no object moves)."""
    options = SHUTTERS[case]
    scene = moving_camera_scene(zoom=options.get("zoom", False), kind=options.get("kind", "PERSP"))
    scene.render.motion_blur_shutter = options["shutter"]
    scene.render.motion_blur_position = options.get("position", "CENTER")
    if options.get("ramp"):
        curve = scene.render.motion_blur_shutter_curve.curves[0]
        curve.points[0].location = (0.0, 0.0)
        curve.points[-1].location = (1.0, 1.0)
        scene.render.motion_blur_shutter_curve.update()
    if "rolling" in options:
        scene.cycles.rolling_shutter_type = "TOP"
        scene.cycles.rolling_shutter_duration = options["rolling"]
    mine = render_with(scene, "PRIMER", str(tmp_path / "primer.exr"))
    warnings = addon(primer, "engine").last_render.warnings
    assert scene.frame_current == 1 and scene.frame_subframe == 0.0          # the frame is set back
    cycles = render_with(scene, "CYCLES", str(tmp_path / "cycles.exr"))
    again = render_with(scene, "CYCLES", str(tmp_path / "again.exr"), seed=7)
    scene.render.use_motion_blur = False
    still = render_with(scene, "CYCLES", str(tmp_path / "still.exr"))
    error, noise, unblurred = (relative_mse_of_blocks(mine, cycles), relative_mse_of_blocks(again, cycles),
                               relative_mse_of_blocks(still, cycles))
    print(f"{case}: Primer {error:.2e}, Cycles' own noise {noise:.2e}, the still camera {unblurred:.2e}")
    assert not [w for w in warnings if "motion blur" in w], warnings
    assert unblurred > 10 * BLOCK_TOLERANCE
    assert error < BLOCK_TOLERANCE


def test_moving_and_deforming_meshes_are_blurred_and_not_named(primer, tmp_path):
    """A cube keyframed across the shutter, a collection instanced by a moving Empty and a flat mesh deformed by an
    animated shape key are all blurred, so no note names them, nor once it is smooth (its vertex normals interpolated
    over the shutter); with custom normals (per face corner) its note says they stay the frame's;
    the plane that stands still, an Empty and an object whose Motion Blur is off are never named; without motion blur
    nothing is said."""
    scene = moving_camera_scene()
    scene.render.motion_blur_shutter = 0.5
    bpy.ops.mesh.primitive_cube_add(size=0.2, location=(0.0, 0.0, 1.0))
    cube = bpy.context.active_object
    cube.name = "Flying cube"
    keyframe_linearly(cube, "location", {0: (-1.0, 0.0, 1.0), 2: (1.0, 0.0, 1.0)})
    bpy.ops.mesh.primitive_cube_add(size=0.2, location=(0.5, 0.5, 1.0))
    ignored = bpy.context.active_object
    ignored.name = "Unblurred cube"
    keyframe_linearly(ignored, "location", {0: (0.5, 0.0, 1.0), 2: (0.5, 1.0, 1.0)})
    ignored.cycles.use_motion_blur = False
    bpy.ops.mesh.primitive_plane_add(size=0.3, location=(-0.5, -0.5, 1.0))
    sheet = bpy.context.active_object
    sheet.name = "Waving sheet"
    sheet.shape_key_add(name="Basis")
    key = sheet.shape_key_add(name="Wave")
    key.data[0].co = (0.0, 0.0, 0.5)
    keyframe_linearly(key, "value", {0: 0.0, 2: 1.0})
    props = bpy.data.collections.new("Props")
    prop = bpy.data.objects.new("Prop", bpy.data.meshes.new("Prop"))
    prop.data.from_pydata([(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0)], [], [(0, 1, 2)])
    props.objects.link(prop)
    mover = bpy.data.objects.new("Mover", None)
    mover.instance_type, mover.instance_collection = "COLLECTION", props
    scene.collection.objects.link(mover)
    keyframe_linearly(mover, "location", {0: (0.0, -1.0, 1.0), 2: (0.0, -0.5, 1.0)})
    scene.collection.objects.link(bpy.data.objects.new("Still empty", None))
    scene.frame_set(1)
    render_with(scene, "PRIMER", str(tmp_path / "objects.exr"))
    notes = [w for w in addon(primer, "engine").last_render.warnings if "motion blur" in w]
    assert not notes, notes
    sheet.data.shade_smooth()
    render_with(scene, "PRIMER", str(tmp_path / "smooth.exr"))
    assert not [w for w in addon(primer, "engine").last_render.warnings if "motion blur" in w]   # (interpolated)
    sheet.data.normals_split_custom_set_from_vertices([(0.0, 0.0, 1.0)] * 4)
    render_with(scene, "PRIMER", str(tmp_path / "custom.exr"))
    notes = [w for w in addon(primer, "engine").last_render.warnings if "motion blur" in w]
    assert len(notes) == 1 and "'Waving sheet' deforms" in notes[0] and "smooth normals" in notes[0], notes
    scene.render.use_motion_blur = False
    render_with(scene, "PRIMER", str(tmp_path / "off.exr"))
    assert not [w for w in addon(primer, "engine").last_render.warnings if "motion blur" in w]


def emitting(name: str, color: tuple, strength: float = 1.0):
    """A material that only emits `color` at `strength`."""
    material = bpy.data.materials.new(name)
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (*color, 1.0)
    emission.inputs["Strength"].default_value = strength
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material


def still_camera_scene():
    """A still perspective camera 4 above the origin looking down, a black world, Render > Motion Blur on (Center,
    Shutter 1), rendered at frame 1; the direct tracer."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.location = (0.0, 0.0, 4.0)
    scene.world = None
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 1.0
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False
    return scene


def moving_cube_in_the_sun(scene):
    """A grey cube 0.6 wide flying 1.6 along x and turning 0.8 rad between frames 0 and 2 over a white ground plane,
    both diffuse, lit by a sun from above and aside: its image and its shadow smear."""
    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, 0.0))
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(0.0, 0.0, 0.8))
    cube = bpy.context.active_object
    keyframe_linearly(cube, "location", {0: (-0.8, -0.1, 0.8), 2: (0.8, 0.1, 0.8)})
    keyframe_linearly(cube, "rotation_euler", {0: (0.0, 0.0, -0.4), 2: (0.0, 0.0, 0.4)})
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.data.angle = 0.0
    sun.rotation_euler = (0.5, 0.3, 0.0)
    scene.collection.objects.link(sun)


def spinning_bar(scene):
    """An emitting bar (2.4 x 0.3) turning a quarter turn about z between frames 0 and 2 with Motion Steps 2 (five
    steps: the turn is interpolated by its rotation, not its matrices), over a dim emitting ground."""
    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, 0.0))
    bpy.context.active_object.data.materials.append(emitting("Ground", (0.2, 0.2, 0.2)))
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.0, 0.0, 0.5))
    bar = bpy.context.active_object
    bar.scale = (2.4, 0.3, 1.0)
    bar.data.materials.append(emitting("Glow", (1.0, 0.6, 0.2), 2.0))
    keyframe_linearly(bar, "rotation_euler", {0: (0.0, 0.0, -math.pi / 4), 2: (0.0, 0.0, math.pi / 4)})
    bar.cycles.motion_steps = 2


def folding_sheet(scene):
    """An emitting 2 x 2 sheet whose shape key folds one corner over, 1.6 across and 0.6 up, between frames 0 and 2
    (deformation motion: its vertices interpolated at each ray's time), over a dim emitting ground."""
    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, 0.0))
    bpy.context.active_object.data.materials.append(emitting("Ground", (0.2, 0.2, 0.2)))
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, 0.0, 0.5))
    sheet = bpy.context.active_object
    sheet.data.materials.append(emitting("Glow", (0.3, 0.8, 1.0), 2.0))
    sheet.shape_key_add(name="Basis")
    fold = sheet.shape_key_add(name="Fold")
    fold.data[2].co = (-0.6, -0.6, 0.6)
    keyframe_linearly(fold, "value", {0: 0.0, 2: 1.0})


def floor_lit_by_a_sliding_lamp(scene):
    """A white diffuse ground lit only by an emitting 0.6 x 0.6 square 0.5 above it, facing down, hidden from the
    camera, sliding 1.6 along x and turning 0.5 rad between frames 0 and 2: the ground's direct light, smeared (the
    light samples reach the square where it is at each path's time)."""
    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, 0.0))
    bpy.ops.mesh.primitive_plane_add(size=0.6, location=(0.0, 0.0, 0.5), rotation=(math.pi, 0.0, 0.0))
    lamp = bpy.context.active_object
    lamp.data.materials.append(emitting("Glow", (1.0, 0.9, 0.7), 8.0))
    lamp.visible_camera = False
    keyframe_linearly(lamp, "location", {0: (-0.8, 0.0, 0.5), 2: (0.8, 0.0, 0.5)})
    keyframe_linearly(lamp, "rotation_euler", {0: (math.pi, 0.0, -0.25), 2: (math.pi, 0.0, 0.25)})


def smooth_sheet_tilting_into_a_low_sun(scene):
    """A smooth white 2 x 2 sheet whose shape key lifts its +x edge 1.5 between frames 0 and 2 (it tilts from 10 to 29
    degrees over the shutter), lit by a strong sun 20 degrees below the ground's horizon from the -x side: the sheet
    turns into the sun's light during the shutter, and its smooth normals, interpolated at each ray's time, shade it
    (with the frame's normals it would be about a quarter as bright)."""
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, 0.0, 0.0))
    sheet = bpy.context.active_object
    sheet.data.shade_smooth()
    sheet.shape_key_add(name="Basis")
    tilt = sheet.shape_key_add(name="Tilt")
    for point in tilt.data:
        if point.co.x > 0.0:
            point.co.z = 1.5
    keyframe_linearly(tilt, "value", {0: 0.0, 2: 1.0})
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 20.0
    sun.data.angle = 0.0
    sun.rotation_euler = (0.0, math.radians(-110.0), 0.0)
    scene.collection.objects.link(sun)


OBJECTS = {"a cube flying and turning in the sun": moving_cube_in_the_sun,
           "a bar spinning a quarter turn, Motion Steps 2": spinning_bar,
           "a sheet folding by a shape key": folding_sheet,
           "a floor lit by a sliding, turning emitter": floor_lit_by_a_sliding_lamp,
           "a smooth sheet tilting into a low sun": smooth_sheet_tilting_into_a_low_sun}


@pytest.mark.parametrize("case", list(OBJECTS))
def test_a_moving_object_blurs_as_in_cycles(primer, tmp_path, case):
    """Objects that move over the shutter blur as in Cycles (block relative MSE within Cycles' own noise), their
    shadows too (the shadow rays carry their camera ray's time), and the light of moving emitters (light-sampled
    where they are at each path's time), far from the still image; no note is made."""
    scene = still_camera_scene()
    OBJECTS[case](scene)
    scene.frame_set(1)
    mine = render_with(scene, "PRIMER", str(tmp_path / "primer.exr"))
    warnings = addon(primer, "engine").last_render.warnings
    cycles = render_with(scene, "CYCLES", str(tmp_path / "cycles.exr"))
    again = render_with(scene, "CYCLES", str(tmp_path / "again.exr"), seed=7)
    scene.render.use_motion_blur = False
    still = render_with(scene, "CYCLES", str(tmp_path / "still.exr"))
    error, noise, unblurred = (relative_mse_of_blocks(mine, cycles), relative_mse_of_blocks(again, cycles),
                               relative_mse_of_blocks(still, cycles))
    print(f"{case}: Primer {error:.2e}, Cycles' own noise {noise:.2e}, still objects {unblurred:.2e}")
    assert not [w for w in warnings if "motion blur" in w], warnings
    assert unblurred > 10 * BLOCK_TOLERANCE
    assert error < BLOCK_TOLERANCE


def test_the_shutter_time_view_shows_each_rows_time_with_a_rolling_shutter(primer, tmp_path):
    """Debug View > Shutter Time with a rolling shutter of Duration 0: row r of H (from the top) shows (r + 1) / H,
    as Cycles reads its rows."""
    scene = moving_camera_scene()
    scene.cycles.rolling_shutter_type = "TOP"
    scene.cycles.rolling_shutter_duration = 0.0
    scene.render.engine = "PRIMER"
    scene.primer.samples = 2
    scene.primer.debug_view = "SHUTTER_TIME"
    picture = render_image(scene, str(tmp_path / "time.exr"))[..., 0]
    expected = np.broadcast_to(((np.arange(HEIGHT) + 1.0) / HEIGHT)[:, None], (HEIGHT, WIDTH))
    np.testing.assert_allclose(picture, expected, atol=1e-6)


def passes_of_both(scene, tmp_path, reference: str):
    """Render `scene`'s passes with Primer, then Cycles (the Cycles reference `reference`), 16 samples each: yield
    (engine, {pass: (channels, pixels)}) as each finishes."""
    for engine in ("PRIMER", "CYCLES"):
        scene.render.engine = engine
        if engine == "CYCLES":
            configure_cycles_reference(scene, 16)
        else:
            scene.primer.samples = 16
        yield engine, render_image(scene, str(tmp_path / f"{engine}_{reference}.exr"), multilayer=True,
                                   reference=reference)


def sliding_square(scene) -> None:
    """A square (the checker's material) 0.5 above the floor sliding 0.8 a frame along y (frames 0 to 2), the scene
    set to frame 1 with the Vector pass asked for."""
    mesh = bpy.data.meshes.new("Square")
    mesh.from_pydata([(-0.5, -0.5, 0.5), (0.5, -0.5, 0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, 0.5)], [], [(0, 1, 2, 3)])
    mesh.materials.append(bpy.data.materials["Glow"])
    square = bpy.data.objects.new("Square", mesh)
    scene.collection.objects.link(square)
    keyframe_linearly(square, "location", {0: (0.3, -0.8, 0.0), 2: (0.3, 0.8, 0.0)})
    scene.frame_set(1)
    scene.view_layers[0].use_pass_vector = True


def inside_one_surface(vector: np.ndarray, within: float = 1.5) -> np.ndarray:
    """Which pixels (H, W) lie inside one surface: their 3 x 3 neighbours' motions in `vector` (H, W, 4) all within
    `within` pixels of theirs (the field varies by about 0.5 pixel a pixel; edges by a pixel or more)."""
    padded = np.pad(vector, ((1, 1), (1, 1), (0, 0)), mode="edge")
    spread = np.max([np.abs(padded[1 + dy:1 + dy + HEIGHT, 1 + dx:1 + dx + WIDTH] - vector).max(axis=-1)
                     for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    return spread < within


def test_the_vector_pass_holds_each_pixels_screen_motion_as_in_cycles(primer, tmp_path):
    """View Layer > Passes > Vector without motion blur (Cycles' motion pass): a square sliding 0.8 a frame along y
    over the checker floor, seen by the camera that slides, turns and zooms between frames 0 and 2 (rendered at 1).
    Where both engines see one surface in every sample (inside the square and the floor, away from its edges, whose
    pixels average two motions by the samples' coverage), Primer's four channels (before - now, now - after, in
    pixels, y up) are Cycles' within 0.05 pixel (of 2 to 8); the square's own motion differs from the floor's by
    pixels. With motion blur on, both write 0."""
    scene = moving_camera_scene(zoom=True)
    sliding_square(scene)
    vectors = {}
    for blur in (False, True):
        scene.render.use_motion_blur = blur
        for engine, passes in passes_of_both(scene, tmp_path, f"vector_{blur}"):
            channels, vectors[engine, blur] = passes["Vector"]
            assert channels == ["X", "Y", "Z", "W"], engine
    for engine in ("PRIMER", "CYCLES"):
        assert not vectors[engine, True].any(), engine
    primer_v, cycles_v = vectors["PRIMER", False], vectors["CYCLES", False]
    inside = inside_one_surface(cycles_v)       # (a pixel whose 3 x 3 neighbours all move alike in Cycles)
    assert inside.mean() > 0.5
    # (measured: within 0.02 pixel of motions of 2 to 8 pixels: each pixel's 16 samples see the field at other points)
    np.testing.assert_allclose(primer_v[inside], cycles_v[inside], atol=0.05)
    assert np.abs(cycles_v[inside] - np.median(cycles_v[inside], axis=0)).max() > 1.0    # (two motions seen)
    assert not [w for w in addon(primer, "engine").last_render.warnings if "Vector" in w]


def test_the_vector_pass_of_an_equirectangular_camera_maps_the_motion_through_its_projection_as_in_cycles(
        primer, tmp_path):
    """The Vector pass under a panoramic camera (issue 33): the sliding square over the checker floor seen by a full
    equirectangular camera that slides and turns between frames 0 and 2 (rendered at 1), without motion blur.
    Cycles maps where each hit was and will be through the inverse of the panorama's projection
    (direction_to_panorama with the camera's transform then); so does Primer: inside surfaces (3 x 3 neighbours
    seen and moving within 0.75 pixel alike in Cycles: 140 pixels), within 0.05 pixel of Cycles' (measured: a
    median 0.0033, at most 0.020 of motions up to 2.4 pixels; each engine's 16 samples see the field at other
    points of the pixel), and no note."""
    scene = moving_camera_scene(kind="PANO")
    scene.camera.data.panorama_type = "EQUIRECTANGULAR"
    sliding_square(scene)
    scene.render.use_motion_blur = False
    vectors = {}
    for engine, passes in passes_of_both(scene, tmp_path, "vector_equirectangular"):
        vectors[engine] = passes["Vector"][1]
        if engine == "PRIMER":
            warnings = addon(primer, "engine").last_render.warnings
    primer_v, cycles_v = vectors["PRIMER"], vectors["CYCLES"]
    seen = np.pad(np.abs(cycles_v).max(axis=-1) > 0.0, 1)          # (the black world moves by 0)
    all_seen = np.all([seen[1 + dy:1 + dy + HEIGHT, 1 + dx:1 + dx + WIDTH] for dy in (-1, 0, 1) for dx in (-1, 0, 1)],
                      axis=0)
    inside = inside_one_surface(cycles_v, 0.75) & all_seen
    error = np.abs(primer_v[inside] - cycles_v[inside])
    print("equirectangular: median", float(np.median(error)), "max", float(error.max()),
          "largest motion", float(np.abs(cycles_v[inside]).max()), "pixels", int(inside.sum()))
    assert inside.sum() > 100
    np.testing.assert_allclose(primer_v[inside], cycles_v[inside], atol=0.05)
    assert np.abs(cycles_v[inside]).max() > 1.0
    assert not [w for w in warnings if "Vector" in w], warnings


def test_the_vector_pass_of_a_deforming_sheet_follows_its_vertices_as_in_cycles(primer, tmp_path):
    """The Vector pass of a mesh that deforms (issue 33): folding_sheet's shape key folds one corner of the sheet
    1.6 across and 0.6 up between frames 0 and 2 under the still camera, without motion blur. Cycles exports the
    sheet's vertices at frames 0 and 2 (its Deformation on) and interpolates them at each hit; so does Primer:
    inside the sheet and the ground (Cycles' Object Index the same over a pixel's 3 x 3 neighbours), within 0.1 pixel
    of Cycles' (the sheet moves by up to 11 pixels, the ground not at all), and no note."""
    scene = still_camera_scene()
    folding_sheet(scene)
    scene.render.use_motion_blur = False
    scene.frame_set(1)
    scene.view_layers[0].use_pass_vector = scene.view_layers[0].use_pass_object_index = True
    for number, name in enumerate(("Plane.001", "Plane"), start=1):     # (the sheet 1, the ground 2)
        bpy.data.objects[name].pass_index = number
    vectors = {}
    for engine, passes in passes_of_both(scene, tmp_path, "vector_deform"):
        vectors[engine] = passes["Vector"][1]
        index = passes["Object Index"][1][..., 0]
        if engine == "PRIMER":
            warnings = addon(primer, "engine").last_render.warnings
    primer_v, cycles_v = vectors["PRIMER"], vectors["CYCLES"]
    # (a pixel whose 3 x 3 neighbours all show its object in Cycles' Object Index lies inside one surface)
    padded = np.pad(index, 1, mode="edge")
    inside = np.all([padded[1 + dy:1 + dy + HEIGHT, 1 + dx:1 + dx + WIDTH] == index
                     for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    assert inside.mean() > 0.5 and (inside & (index == 1)).sum() > 20
    error = np.abs(primer_v[inside] - cycles_v[inside])
    print("deforming sheet: median", float(np.median(error)), "max", float(error.max()),
          "largest motion", float(np.abs(cycles_v).max()))
    # (measured: a median 1.9e-7 pixel, at most 0.058 where the fold's motion changes by a pixel a pixel: each
    # engine's 16 samples see the field at other points of the pixel)
    np.testing.assert_allclose(primer_v[inside], cycles_v[inside], atol=0.1)
    assert np.abs(cycles_v[inside & (index == 1)]).max() > 2.0   # (the sheet moves by pixels, the ground not)
    assert not cycles_v[inside & (index == 2)].any()
    assert not [w for w in warnings if "Vector" in w or "deform" in w], warnings
