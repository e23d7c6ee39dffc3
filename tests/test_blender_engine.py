"""Primer inside real Blender (the bpy module): passes, debug views, reports, cancelling.

No mocks: each test builds a scene with bpy, renders it with bpy.ops.render.render()
through Primer's RenderEngine, and reads the written image back.
"""
from __future__ import annotations

import math
import os
import sys
import time

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from render import configure_output, load_primer  # noqa: E402

from blender_env import lambert_everywhere  # noqa: E402
from core.film import image_io  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def engine_module(primer):
    """Return the add-on's engine module."""
    return sys.modules[primer.__name__ + ".addon.engine"]


def new_scene(width=48, height=36, light=True, camera=True):
    """Start from an empty file: a plane under a sun, seen from above, rendered by Primer."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    lambert_everywhere(scene)                  # the lecture's grey Lambert surface, for its closed forms
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.primer.samples = 1
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], [], [(0, 1, 2, 3)])
    plane = bpy.data.objects.new("Plane", mesh)
    scene.collection.objects.link(plane)
    if light:
        sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
        sun.data.energy = 2.0
        sun.data.angle = 0.0                   # a point-like sun: exact N.L, no sampling
        scene.collection.objects.link(sun)
    if camera:
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        cam.location = (0.0, 0.0, 5.0)
        scene.collection.objects.link(cam)
        scene.camera = cam
    return scene


def write_float_exr(scene, path: str, multilayer: bool = False) -> None:
    """Render the scene with write_still into a 32-bit float EXR at `path` (tools/render.py's output
    settings), with every pass when multilayer."""
    scene.render.image_settings.media_type = "IMAGE"          # a scene rendered multilayer before stays so
    configure_output(scene, path)
    if multilayer:
        scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    bpy.ops.render.render(write_still=True)


def render_to(scene, path):
    """Render the scene with write_still into a float EXR and return it (H, W, C) top-down."""
    write_float_exr(scene, path)
    return image_io.read_image(path)


def render_passes(scene, path: str) -> dict:
    """Render into a multilayer float EXR and return pass name -> (H, W, c) float32, rows top-down.

    Channels are named ViewLayer.<pass>.<channel>; Blender may put several passes in one part.
    """
    import OpenImageIO as oiio
    write_float_exr(scene, path, multilayer=True)
    channels: dict = {}
    inp = oiio.ImageInput.open(path)
    part = 0
    while inp.seek_subimage(part, 0):
        spec = inp.spec()
        pixels = inp.read_image(part, 0, 0, spec.nchannels, oiio.FLOAT).reshape(spec.height, spec.width, -1)
        for c, name in enumerate(spec.channelnames):
            channels.setdefault(name.split(".")[-2], []).append(pixels[..., c])
        part += 1
    inp.close()
    return {name: np.stack(planes, axis=-1) for name, planes in channels.items()}


def test_sun_on_a_plane_renders_albedo_over_pi_times_strength(primer, tmp_path):
    """A default-grey plane under a 2 W/m^2 overhead sun shows 0.8/pi * 2 in every pixel."""
    scene = new_scene()
    image = render_to(scene, str(tmp_path / "sun.exr"))
    np.testing.assert_allclose(image[..., :3], 0.8 / math.pi * 2.0, rtol=1e-5)
    assert engine_module(primer).last_render.error == ""


def test_debug_view_shows_the_normal_as_colour(primer, tmp_path):
    """The 'Shading Normal' debug view paints the upward plane normal (0, 0, 1) as (0.5, 0.5, 1)."""
    scene = new_scene()
    scene.primer.debug_view = "NORMAL"
    image = render_to(scene, str(tmp_path / "normal.exr"))
    np.testing.assert_allclose(image[..., :3], np.broadcast_to([0.5, 0.5, 1.0], image[..., :3].shape), atol=1e-6)


def test_depth_normal_and_debug_passes_are_written(primer, tmp_path):
    """With Z and Normal enabled, the multilayer EXR holds Depth, Normal and Primer's debug passes with exact values."""
    scene = new_scene()
    scene.primer.debug_passes = True
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = True
    parts = render_passes(scene, str(tmp_path / "passes.exr"))
    assert {"Combined", "Depth", "Normal", "Primer Face Normal", "Primer NdotL", "Primer Shadow"} <= set(parts)
    np.testing.assert_allclose(parts["Depth"], 5.0, rtol=1e-6)            # camera 5 above, looking down
    np.testing.assert_allclose(parts["Normal"][..., 2], 1.0, rtol=1e-6)
    np.testing.assert_allclose(parts["Primer NdotL"], 1.0, rtol=1e-6)
    np.testing.assert_allclose(parts["Primer Shadow"], 1.0, rtol=1e-6)


def test_scene_without_lights_is_reported_and_renders_black(primer, tmp_path):
    """No lights: a warning in the report, and black surfaces (the world is black)."""
    scene = new_scene(light=False)
    image = render_to(scene, str(tmp_path / "dark.exr"))
    record = engine_module(primer).last_render
    assert any("no lights" in w for w in record.warnings)
    assert np.count_nonzero(image[..., :3]) == 0


def test_scene_without_camera_is_a_clear_error(primer):
    """No camera: rendering stops with an error that names the camera."""
    new_scene(camera=False)
    with pytest.raises(RuntimeError, match="(?i)camera"):
        bpy.ops.render.render()


def test_nan_vertices_and_empty_meshes_are_reported_not_fatal(primer, tmp_path):
    """A mesh with a NaN vertex and an empty mesh render without NaN pixels; the NaN triangle is reported."""
    scene = new_scene()
    bad = bpy.data.meshes.new("Bad")
    bad.from_pydata([(0, 0, 1), (1, 0, 1), (0, 1, 1), (2, 2, 1)], [], [(0, 1, 2), (1, 3, 2)])
    coords = np.array([0, 0, 1, 1, 0, 1, 0, 1, 1, np.nan, 2, 1], np.float32)
    bad.vertices.foreach_set("co", coords)
    scene.collection.objects.link(bpy.data.objects.new("Bad", bad))
    scene.collection.objects.link(bpy.data.objects.new("Empty", bpy.data.meshes.new("Empty")))
    image = render_to(scene, str(tmp_path / "nan.exr"))
    record = engine_module(primer).last_render
    assert np.isfinite(image).all()
    assert any("NaN or infinite" in w for w in record.warnings)
    assert record.error == ""


CTRL_C_SCRIPT = """
import os, signal, sys, threading, time
sys.path.insert(0, {tools!r})
import bpy
from render import load_primer
primer = load_primer()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "PRIMER"
scene.render.resolution_x, scene.render.resolution_y = 1280, 960
scene.primer.samples = 1024
scene.primer.use_adaptive_sampling = False
bpy.ops.mesh.primitive_uv_sphere_add()
bpy.ops.object.light_add(type="POINT", location=(2, -2, 3))
bpy.ops.object.camera_add(location=(0, -6, 0), rotation=(1.5708, 0, 0))
scene.camera = bpy.context.object
# Press Ctrl+C 0.3 s after the render loop has started (not earlier, while Blender itself is busy).
core_render = sys.modules[primer.__name__ + ".core.render"]
started = threading.Event()
original = core_render.render
def render_and_signal(*args, **kwargs):
    started.set()
    return original(*args, **kwargs)
core_render.render = render_and_signal
threading.Thread(target=lambda: started.wait(60) and (time.sleep(0.3), os.kill(os.getpid(), signal.SIGINT)),
                 daemon=True).start()
start = time.perf_counter()
bpy.ops.render.render()
record = sys.modules[primer.__name__ + ".addon.engine"].last_render
print("RESULT", record.cancelled, round(time.perf_counter() - start, 2), repr(record.error))
"""


def test_ctrl_c_stops_a_headless_render_promptly(tmp_path):
    """Ctrl+C (SIGINT) during a long headless render ends it within seconds, marked cancelled, without an error."""
    import subprocess
    tools = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools")
    script = tmp_path / "ctrl_c.py"
    script.write_text(CTRL_C_SCRIPT.format(tools=tools))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    elapsed = time.perf_counter() - start
    line = next((l for l in done.stdout.splitlines() if l.startswith("RESULT")), "")
    assert line.split()[1:2] == ["True"], done.stdout[-2000:] + done.stderr[-2000:]
    assert float(line.split()[2]) < 3.0          # the render itself stopped promptly
    assert line.split()[3] == "''"
    assert elapsed < 60.0


def test_blender_panels_are_shown_for_primer(primer):
    """Camera (its Depth of Field too), output and material panels list Primer; the light panels Primer replaces do
    not."""
    panels = {p.__name__: p for p in bpy.types.Panel.__subclasses__()}
    for name in ("DATA_PT_lens", "RENDER_PT_format", "EEVEE_MATERIAL_PT_surface",
                 "EEVEE_MATERIAL_PT_context_material", "OBJECT_PT_visibility", "DATA_PT_camera_dof",
                 "DATA_PT_camera_dof_aperture"):
        assert "PRIMER" in panels[name].COMPAT_ENGINES, name
    for name in ("DATA_PT_light", "DATA_PT_spot", "EEVEE_MATERIAL_PT_thickness"):
        assert "PRIMER" not in panels[name].COMPAT_ENGINES, name
    for name in ("RENDER_PT_primer_sampling", "RENDER_PT_primer_shadows", "DATA_PT_primer_light",
                 "RENDER_PT_primer_motion_blur", "OBJECT_PT_primer_motion_blur"):
        assert hasattr(bpy.types, name), name


def test_renders_keep_the_heap_warm_until_blender_is_idle(primer, tmp_path):
    """An F12 render leaves the heap warm for the next one (core/memory.py); the engine's persistent
    timer, registered on the main thread, gives it back once no render has run for RELEASE_AFTER
    seconds (not before)."""
    engine = engine_module(primer)
    memory = sys.modules[primer.__name__ + ".core.memory"]
    assert bpy.app.timers.is_registered(engine.release_memory_when_idle)
    render_to(new_scene(), str(tmp_path / "warm.exr"))
    if memory._glibc() is None:
        pytest.skip("glibc only")
    assert memory.is_warm()
    assert engine.release_memory_when_idle() == engine.RELEASE_CHECK
    assert memory.is_warm()                                    # too soon after the render
    memory._idle_since -= engine.RELEASE_AFTER
    engine.release_memory_when_idle()
    assert not memory.is_warm() and memory._idle_since is None


def test_an_environment_texture_world_is_exported_and_lights_the_plane(primer, tmp_path):
    """A world made of an Environment Texture (a constant 16 x 8 image of (0.5, 0.25, 0.125)) through a Mapping
    node turned 30 degrees about Z, at Background Strength 2: Primer reads the image, its strength and the
    rotation, and the grey Lambert plane (albedo 0.8) under it shows 0.8 x 2 x the image's colour."""
    import math
    scene = new_scene(light=False)
    scene.primer.samples = 64
    world = bpy.data.worlds.new("Sky")
    scene.world = world
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    tree = world.node_tree
    background = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Strength"].default_value = 2.0
    image = bpy.data.images.new("Sky", 16, 8, float_buffer=True)
    image.pixels.foreach_set([0.5, 0.25, 0.125, 1.0] * (16 * 8))
    texture = tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(30.0))
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    tree.links.new(texture.outputs["Color"], background.inputs["Color"])
    export = sys.modules[primer.__name__ + ".addon.export"]
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    sky = exported.scene.world
    assert sky.image is not None and sky.image.shape == (8, 16, 3) and sky.strength == 2.0
    np.testing.assert_allclose(sky.rotation[:2, :2], [[math.cos(math.pi / 6), -0.5], [0.5, math.cos(math.pi / 6)]],
                               atol=1e-12)
    assert not [w for w in exported.warnings if "world" in w]
    pixels = render_to(scene, str(tmp_path / "sky.exr"))[..., :3]
    np.testing.assert_allclose(pixels.mean(axis=(0, 1)), 0.8 * 2.0 * np.array([0.5, 0.25, 0.125]), rtol=0.02)


def test_an_unlit_material_made_with_light_path_shows_its_colour_to_the_camera_only(primer, tmp_path):
    """glTF's unlit material (KHR_materials_unlit as Blender imports it): a Mix Shader of Transparent and
    Emission by Light Path > Is Camera Ray. The camera sees the emission colour exactly; to every other ray
    it is transparent, so it lights nothing (no emitter is made of it); no warning."""
    scene = new_scene(width=8, height=6)
    scene.view_layers[0].material_override = None
    unlit = bpy.data.materials.new("Unlit")
    if bpy.app.version < (5, 0, 0):
        unlit.use_nodes = True
    tree = unlit.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    mix, path = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeLightPath")
    transparent, emission = tree.nodes.new("ShaderNodeBsdfTransparent"), tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.6, 0.3, 0.1, 1.0)
    tree.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    tree.links.new(transparent.outputs["BSDF"], mix.inputs[1])
    tree.links.new(emission.outputs["Emission"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], output.inputs["Surface"])
    scene.objects["Plane"].data.materials.append(unlit)
    export = sys.modules[primer.__name__ + ".addon.export"]
    exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in exported.warnings if "Light Path" in w]
    # Other surfaces see it transparent, so it is no light (Cycles evaluates it per ray: no emission).
    render_module = sys.modules[primer.__name__ + ".core.render"]
    assert render_module.prepare(exported.scene, exported.settings).extra["emitters"] is None
    pixels = render_to(scene, str(tmp_path / "unlit.exr"))[..., :3]
    np.testing.assert_allclose(pixels, np.broadcast_to([0.6, 0.3, 0.1], pixels.shape), rtol=1e-5)


def test_transparent_shadows_off_in_a_material_makes_it_opaque_to_shadow_rays(primer):
    """Material > Settings > Transparent Shadows (Blender 4.2 and later), which Cycles reads: off, the material's
    alpha still shows the camera what is behind it, but shadow rays stop at it (its row is shadow-opaque)."""
    scene = new_scene(width=8, height=6)
    scene.view_layers[0].material_override = None
    export = sys.modules[primer.__name__ + ".addon.export"]
    render_module = sys.modules[primer.__name__ + ".core.render"]
    for setting in (True, False):
        material = bpy.data.materials.new(f"Alpha {setting}")
        if bpy.app.version < (5, 0, 0):
            material.use_nodes = True
        material.node_tree.nodes["Principled BSDF"].inputs["Alpha"].default_value = 0.3
        material.use_transparent_shadow = setting
        plane = scene.objects["Plane"]
        plane.data.materials.clear()
        plane.data.materials.append(material)
        exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
        (ours,) = [m for m in exported.scene.materials if m.name == material.name]
        assert ours.transparent_shadows is setting
        table = render_module.prepare(exported.scene, exported.settings).materials
        assert bool(table.shadow_opaque[table.names.index(material.name)]) is (not setting)
