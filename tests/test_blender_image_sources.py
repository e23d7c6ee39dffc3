"""UDIM tiles, image sequences and movies, inside real Blender (the bpy module, no mocks), against Cycles.

Issue 31: all three rendered magenta, with a warning that Cycles does the same; Cycles renders the tile or frame.
Now each renders as in Cycles.
Each scene is seen straight down by an orthographic camera: planes whose Emission colour is an Image Texture
(Closest, texels on whole pixels), so every pixel is one texel's colour, the same in both engines for few samples.
The images are written here: a 2-tile UDIM image (name.1001.png, name.1002.png) on a plane of three quads whose UVs
span u 0..3 (the third lies in no tile; each tile has UV corners in it, else Cycles' final render leaves it out,
ImageTextureNode::cull_tiles); a sequence of three files, numbered 11 to 13, read at scene frame 8 through
Image Users with Frames 3, Start 1, Cyclic, Offset 10 and 11 (frames 12 and 13: the 2nd and 3rd files); a movie
rendered by Blender to FFmpeg, shown at its frame 2 and past its end. And images Cycles reads from Blender's own buffers (packed
16-bit and 8-bit PNGs) or by the running Blender's alpha and half rules (a half EXR set to Straight, a 16-bit PNG set to
Premultiplied), each texel against Cycles and its closed form.
"""
from __future__ import annotations

import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy

pytestmark = [pytest.mark.blender, pytest.mark.slow]

SCRIPT = """
import os, sys
import bpy
import numpy as np
import OpenImageIO as oiio
from blender_env import render_pixels, report
sys.path.insert(0, {tools!r})
from render import load_primer

primer = load_primer()
engine_module = sys.modules[primer.__name__ + ".addon.engine"]


def write_png(path, texels):
    # texels (h, w, 3) uint8, top row first (as files store them)
    spec = oiio.ImageSpec(texels.shape[1], texels.shape[0], 3, oiio.UINT8)
    out = oiio.ImageOutput.create(path)
    out.open(path, spec)
    out.write_image(np.ascontiguousarray(texels))
    out.close()


def emitting_plane(scene, name, image, x, width, u_scale, offset=None):
    # a plane `width` wide (2 high) centred at x, of one quad per unit of u (UVs 0..u_scale across it), emitting its
    # image texture's colour
    columns = max(1, int(round(u_scale)))
    xs = [x - width / 2.0 + width * i / columns for i in range(columns + 1)]
    vertices = [(px, py, 0.0) for py in (-1.0, 1.0) for px in xs]
    faces = [(i, i + 1, columns + 2 + i, columns + 1 + i) for i in range(columns)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    uv = mesh.uv_layers.new(name="UVMap")
    for loop in mesh.loops:
        px, py, _ = vertices[loop.vertex_index]
        uv.data[loop.index].uv = ((px - xs[0]) / width * u_scale, (py + 1.0) / 2.0)
    plane = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(plane)
    material = bpy.data.materials.new(name)
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    if image.source in ("SEQUENCE", "MOVIE"):
        user = texture.image_user
        user.frame_duration, user.frame_start, user.use_cyclic = 3, 1, True
        user.frame_offset = offset or 0
    tree.links.new(texture.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    plane.data.materials.append(material)


def empty_scene(width, height, frame=1):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    scene.frame_set(frame)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.0 * max(width, height) / height
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


def renders(scene, case):
    found = {{}}
    for engine, samples in (("PRIMER", 16), ("CYCLES", 16)):
        found[engine] = render_pixels(scene, engine, os.path.abspath(f"{{case}}_{{engine}}.exr"), samples)[..., :3].tolist()
    found["warnings"] = list(engine_module.last_render.warnings) if engine_module.last_render else []
    return found


out = {{}}
folder = os.path.abspath(".")
# 1. UDIM: tile 1001 a red/blue column pair, tile 1002 green/yellow; u 2..3 lies in no tile.
tiles = {{1001: [[200, 30, 30], [30, 30, 200]], 1002: [[30, 200, 30], [200, 200, 30]]}}
for number, colours in tiles.items():
    write_png(os.path.join(folder, f"udim.{{number}}.png"), np.array([colours, colours], np.uint8))
scene = empty_scene(24, 8)
udim = bpy.data.images.load(os.path.join(folder, "udim.1001.png"))
udim.source = "TILED"
emitting_plane(scene, "Tiles", udim, 0.0, 6.0, 3.0)
out["udim"] = renders(scene, "udim")
out["udim"]["tiles"] = [tile.number for tile in udim.tiles]

# 2. A sequence of three files, frames 11, 12, 13; two nodes at scene frame 8 show frames 12 and 13.
for frame, colour in ((11, [220, 40, 40]), (12, [40, 220, 40]), (13, [40, 40, 220])):
    write_png(os.path.join(folder, f"seq_{{frame:03d}}.png"), np.array([[colour, colour]] * 2, np.uint8))
scene = empty_scene(16, 8, frame=8)
sequence = bpy.data.images.load(os.path.join(folder, "seq_011.png"))
sequence.source = "SEQUENCE"
emitting_plane(scene, "Second", sequence, -1.0, 2.0, 1.0, offset=10)
emitting_plane(scene, "Third", sequence, 1.0, 2.0, 1.0, offset=11)
out["sequence"] = renders(scene, "sequence")
# ... and the same sequence as the world's Environment Texture, Offset 10: the sky is frame 12.
scene = empty_scene(8, 8, frame=8)
world = bpy.data.worlds.new("World")
scene.world = world
if world.node_tree is None:
    world.use_nodes = True
texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
texture.image = bpy.data.images.load(os.path.join(folder, "seq_011.png"))
texture.image.source = "SEQUENCE"
user = texture.image_user
user.frame_duration, user.frame_start, user.use_cyclic, user.frame_offset = 3, 1, True, 10
background = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
world.node_tree.links.new(texture.outputs["Color"], background.inputs["Color"])
out["world"] = renders(scene, "world")

# 3. A movie of three frames (red, green, blue), made by Blender's own FFmpeg output, shown at its frame 2.
out["movie"] = {{"ffmpeg": bool(bpy.app.ffmpeg.supported)}}
if bpy.app.ffmpeg.supported:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 16, 100
    scene.frame_start, scene.frame_end = 1, 3
    scene.view_settings.view_transform = "Standard"
    strips = scene.sequence_editor_create()
    strips = strips.strips if hasattr(strips, "strips") else strips.sequences
    for index, colour in enumerate(((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))):
        strip = strips.new_effect(name=f"c{{index}}", type="COLOR", channel=1, frame_start=index + 1, length=1)
        strip.color = colour
    scene.render.use_sequencer = True
    if hasattr(scene.render.image_settings, "media_type"):
        scene.render.image_settings.media_type = "VIDEO"
    scene.render.image_settings.file_format = "FFMPEG"
    scene.render.ffmpeg.format, scene.render.ffmpeg.codec = "QUICKTIME", "QTRLE"
    scene.render.filepath = os.path.join(folder, "movie_")
    bpy.ops.render.render(animation=True)
    movie_path = next(os.path.join(folder, f) for f in os.listdir(folder) if f.startswith("movie_"))
    scene = empty_scene(16, 8, frame=2)
    movie = bpy.data.images.load(movie_path)
    emitting_plane(scene, "Movie", movie, -1.0, 2.0, 1.0)
    emitting_plane(scene, "Past", movie, 1.0, 2.0, 1.0, offset=5)     # (frame 7 of 3: Blender shows the last)
    out["movie"].update(renders(scene, "movie"))
    out["movie"]["source"] = movie.source

# 4. Images Cycles reads from Blender's buffers, and alpha modes: a 16-bit PNG with straight alpha, packed (Blender's
# float buffer); a half EXR on disk with Alpha set to Straight (zero and subnormal halves, one texel at alpha 0.5);
# the 16-bit PNG on disk with Alpha set to Premultiplied; the same texels as an 8-bit PNG, packed, set to
# Premultiplied (Blender's byte buffer). One row of 4 texels each, a texel on 2 x 2 pixels.
texels = np.array([[[0.8, 0.3, 0.6, 1.0], [0.5, 0.9, 0.2, 0.5], [0.1, 0.7, 1.0, 0.25], [0.6, 0.6, 0.6, 1.0]]])
config = oiio.ImageSpec()
config.attribute("oiio:UnassociatedAlpha", 1)                     # (the colours written as given: straight)
for name, values, kind in (("deep.png", np.rint(texels * 65535).astype(np.uint16), oiio.UINT16),
                           ("bytes.png", np.rint(texels * 255).astype(np.uint8), oiio.UINT8),
                           ("halves.exr", np.array([[[0.0, 2.0 ** -20, 0.75, 1.0], [0.5, 0.25, 0.125, 0.5],
                                                     [1.5, 0.0, 2.0 ** -24, 1.0], [0.3, 0.3, 0.3, 1.0]]],
                                                   np.float16), oiio.HALF)):
    spec = oiio.ImageSpec(4, 1, 4, kind)
    spec.attribute("oiio:UnassociatedAlpha", 1)
    handle = oiio.ImageOutput.create(name)
    handle.open(os.path.join(folder, name), spec)
    handle.write_image(values)
    handle.close()
scene = empty_scene(8, 8)
deep = {{}}
for row, (name, packed, mode) in enumerate((("deep.png", True, "STRAIGHT"), ("halves.exr", False, "STRAIGHT"),
                                            ("deep.png", False, "PREMUL"), ("bytes.png", True, "PREMUL"))):
    image = bpy.data.images.load(os.path.join(folder, name), check_existing=False)
    image.alpha_mode = mode
    if packed and name == "deep.png":
        image.pack()
        deep["buffer"] = np.array(image.pixels[:], np.float64).reshape(4, 4).tolist()
        deep["is_float"] = bool(image.is_float)
    elif packed:
        image.pack()
    emitting_plane(scene, f"Deep{{row}}", image, 0.0, 2.0, 1.0)         # (the view: 2 x 2, a row 0.5 high)
    plane = bpy.data.objects[f"Deep{{row}}"]
    plane.scale.y, plane.location.y = 0.25, 0.75 - 0.5 * row
out["deep"] = renders(scene, "deep")
out["deep"].update(deep)
out["deep"]["version"] = list(bpy.app.version)
primer.unregister()
report(**out)
"""


@pytest.fixture(scope="module")
def found(tmp_path_factory):
    folder = tmp_path_factory.mktemp("image_sources")
    return run_bpy(SCRIPT.format(tools=os.path.join(ROOT, "tools")), str(folder))


def srgb_decoded(byte) -> np.ndarray:
    """An 8-bit sRGB value decoded to linear (the exact curve Cycles and Primer apply)."""
    from core.materials.textures import srgb_to_linear
    return srgb_to_linear(np.asarray(byte, np.float64) / 255.0)


def test_a_udim_plane_shows_each_tile_where_its_uvs_are_as_cycles(found):
    """u 0..1 shows tile 1001's two texel columns, u 1..2 tile 1002's, u 2..3 (no tile) Cycles' magenta: Primer's
    pixels are Cycles' (each pixel one texel's emission), and no warning claims magenta."""
    case = found["udim"]
    mine, cycles = np.asarray(case["PRIMER"]), np.asarray(case["CYCLES"])
    print(case["warnings"], case["tiles"])
    assert case["tiles"] == [1001, 1002]
    np.testing.assert_allclose(mine, cycles, atol=2e-3)
    row = cycles[4]                                  # 24 pixels: 8 per tile, 4 per texel column
    np.testing.assert_allclose(row[:4], np.broadcast_to(srgb_decoded([200, 30, 30]), (4, 3)), atol=2e-3)
    np.testing.assert_allclose(row[12:16], np.broadcast_to(srgb_decoded([200, 200, 30]), (4, 3)), atol=2e-3)
    np.testing.assert_allclose(row[16:], np.broadcast_to([1.0, 0.0, 1.0], (8, 3)), atol=2e-3)
    assert not [w for w in case["warnings"] if "magenta" in w], case["warnings"]


def test_a_sequence_shows_the_frame_its_image_user_picks_at_the_scene_frame_as_cycles(found):
    """At scene frame 8 an Image User of 3 frames from frame 1, cyclic, shows frame 8 mod 3 = 2, plus its Offset: 12
    (the 2nd file) for Offset 10 and 13 (the 3rd) for Offset 11; two nodes of one image show their own frames."""
    case = found["sequence"]
    mine, cycles = np.asarray(case["PRIMER"]), np.asarray(case["CYCLES"])
    print(case["warnings"])
    np.testing.assert_allclose(mine, cycles, atol=2e-3)
    np.testing.assert_allclose(cycles[:, :8], np.broadcast_to(srgb_decoded([40, 220, 40]), (8, 8, 3)), atol=2e-3)
    np.testing.assert_allclose(cycles[:, 8:], np.broadcast_to(srgb_decoded([40, 40, 220]), (8, 8, 3)), atol=2e-3)
    assert not [w for w in case["warnings"] if "magenta" in w], case["warnings"]


def test_a_world_environment_sequence_shows_the_frame_its_image_user_picks_as_cycles(found):
    """The sequence as the world's Environment Texture (Offset 10, scene frame 8): the sky is frame 12, the 2nd file,
    in both engines."""
    case = found["world"]
    mine, cycles = np.asarray(case["PRIMER"]), np.asarray(case["CYCLES"])
    print(case["warnings"])
    np.testing.assert_allclose(mine, cycles, atol=2e-3)
    np.testing.assert_allclose(cycles, np.broadcast_to(srgb_decoded([40, 220, 40]), cycles.shape), atol=2e-3)
    assert not [w for w in case["warnings"] if "magenta" in w], case["warnings"]


def test_a_movie_shows_the_frame_cycles_shows_decoded_by_blender(found):
    """Cycles reads the movie through Blender (frame 2 of red, green, blue: green); Primer has a second Blender decode
    that frame (addon/movie.py) and shows the same pixels, with no warning. A frame past the movie's end (Offset 5:
    frame 7) shows its last frame, blue, as Blender clamps it (Primer showed black)."""
    case = found["movie"]
    if not case["ffmpeg"]:
        pytest.skip("this Blender has no FFmpeg: no movie can be made to test with")
    mine, cycles = np.asarray(case["PRIMER"]), np.asarray(case["CYCLES"])
    print(case["warnings"], cycles.mean(axis=(0, 1)), mine.mean(axis=(0, 1)))
    assert case["source"] == "MOVIE"
    np.testing.assert_allclose(cycles[:, :8], np.broadcast_to([0.0, 1.0, 0.0], (8, 8, 3)), atol=2e-3)
    np.testing.assert_allclose(cycles[:, 8:], np.broadcast_to([0.0, 0.0, 1.0], (8, 8, 3)), atol=2e-3)
    np.testing.assert_allclose(mine, cycles, atol=2e-3)
    assert not [w for w in case["warnings"] if "movie" in w], case["warnings"]


def test_packed_and_deep_images_and_alpha_modes_read_as_the_running_blenders_cycles_reads_them(found):
    """Four rows of 4 texels, each texel the Emission of its 2 x 2 pixels, Primer's pixels Cycles' to 1e-6.
    A packed 16-bit PNG (Straight): Cycles copies Blender's float buffer, sRGB decoded then associated by Blender
    (srgb(c) a), and from Blender 5.1 on multiplies it by alpha once more (Alpha Straight: explicitly unassociated).
    A half EXR on disk set to Straight: Cycles 5.0 keeps the associated halves as stored and reads a zero or subnormal
    half (m 2^-24) as 2^-15 (1 + m / 1024); 5.1 on reads halves exactly and associates (0.5 x alpha 0.5 = 0.25).
    A 16-bit PNG on disk set to Premultiplied: 5.0 associates its straight shorts ((c a) // 65535, then decoded),
    5.1 on goes by the Alpha mode and keeps them (decoded c). The 8-bit PNG packed and set to Premultiplied: Cycles
    reads Blender's byte buffer, the bytes divided by alpha (c / a, at most 255), associated again in 5.0 ((255 a) //
    255 where c / a passes 255) and kept in 5.1 on (255: 1.0)."""
    case = found["deep"]
    mine, cycles = np.asarray(case["PRIMER"]), np.asarray(case["CYCLES"])
    print(case["warnings"], case["version"])
    np.testing.assert_allclose(mine, cycles, rtol=1e-6, atol=1e-7)
    later = tuple(case["version"][:2]) >= (5, 1)
    rows = [cycles[7 - 2 * row, ::2] for row in range(4)]                 # (4, 3) each, rows bottom first
    straight = np.array([[0.8, 0.3, 0.6, 1.0], [0.5, 0.9, 0.2, 0.5], [0.1, 0.7, 1.0, 0.25], [0.6, 0.6, 0.6, 1.0]])
    shorts = np.rint(straight * 65535.0)
    from core.materials.textures import srgb_to_linear
    buffer = np.asarray(case["buffer"])
    assert case["is_float"]
    np.testing.assert_allclose(buffer[:, :3], srgb_to_linear(shorts[:, :3] / 65535.0) * buffer[:, 3:], atol=5e-5)
    again = buffer[:, 3:] if later else 1.0
    np.testing.assert_allclose(rows[0], buffer[:, :3] * again, rtol=1e-6, atol=1e-7)
    low = 2.0 ** -15
    halves = np.array([[low, low * (1 + 16 / 1024), 0.75], [0.5, 0.25, 0.125], [1.5, low, low * (1 + 1 / 1024)],
                       [0.3, 0.3, 0.3]], np.float64)
    if later:
        halves = np.array([[0.0, 2.0 ** -20, 0.75], [0.25, 0.125, 0.0625], [1.5, 0.0, 2.0 ** -24], [0.3, 0.3, 0.3]])
    halves[3] = float(np.float16(0.3))
    np.testing.assert_allclose(rows[1], halves, rtol=1e-7, atol=0.0)
    kept = shorts[:, :3] if later else np.floor(shorts[:, :3] * shorts[:, 3:] / 65535.0)
    np.testing.assert_allclose(rows[2], srgb_to_linear(kept / 65535.0), rtol=1e-5, atol=1e-7)
    bytes_ = np.rint(straight * 255.0)
    opaque = [0, 3]                                                       # alpha 255: the bytes as stored
    np.testing.assert_allclose(rows[3][opaque], srgb_to_linear(bytes_[opaque, :3] / 255.0), rtol=1e-5, atol=1e-7)
    for texel, channels in ((1, [0, 1]), (2, [1, 2])):                    # c / a at least 255
        top = 255.0 if later else np.floor(255.0 * bytes_[texel, 3] / 255.0)
        np.testing.assert_allclose(rows[3][texel, channels], srgb_to_linear(top / 255.0), rtol=1e-5, atol=1e-7)
