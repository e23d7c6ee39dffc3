"""Materials from Blender's node trees, exported with real Blender (the bpy module, no mocks): images from
files and packed bytes, node groups and reroutes, warnings for what Primer cannot read, and the Object
Info node's Random per object and per instance against Cycles' own render.

The sample scene materials_textures (image textures, a normal map, vertex colours, Mix, Math, a group)
is matched against Cycles by tests/test_blender_scenes.py.
"""
from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy
from one_process import RUNNER

pytestmark = pytest.mark.blender

if importlib.util.find_spec("bpy") is None:
    if os.environ.get("PRIMER_ALLOW_NO_BPY"):
        pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
    raise ImportError("tests/test_blender_textures.py needs bpy (Blender as a Python module): pip install bpy")

PRELUDE = """
import sys, os
import bpy
import numpy as np
from blender_env import report
sys.path.insert(0, {tools!r})
from render import load_primer
primer = load_primer()
export = sys.modules[primer.__name__ + ".addon.export"]
graph = sys.modules[primer.__name__ + ".core.materials.graph"]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def material(name):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    tree = m.node_tree
    for node in list(tree.nodes):
        if node.bl_idname != "ShaderNodeOutputMaterial":
            tree.nodes.remove(node)
    return m, tree, next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")


def plane(name, mat, location=(0, 0, 0)):
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=location)
    obj = bpy.context.view_layer.objects.active
    obj.name = name
    obj.data.materials.append(mat)
    return obj
"""

IMAGES = PRELUDE + """
import OpenImageIO as oiio
# A 2 x 2 file, top row red, green; bottom row blue, white (as image files store rows: top first).
path = os.path.join(os.getcwd(), "corners.png")
pixels = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 1]]], np.float32)
out = oiio.ImageOutput.create(path)
out.open(path, oiio.ImageSpec(2, 2, 3, oiio.UINT8))
out.write_image(pixels)
out.close()
mat, tree, output = material("Textured")
image = tree.nodes.new("ShaderNodeTexImage")
image.image = bpy.data.images.load(path)
image.image.colorspace_settings.name = "Non-Color"
image.texture_mapping.scale = (2.0, 1.0, 1.0)           # its own Texture Mapping, on the default UV
packed = bpy.data.images.load(path)
packed.name = "Packed"
packed.pack()
packed.filepath = "//nowhere/corners.png"              # only its bytes are left
diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
mix = tree.nodes.new("ShaderNodeMix")
mix.data_type = "RGBA"
packed_node = tree.nodes.new("ShaderNodeTexImage")
packed_node.image = packed
# Through a group (Group Input -> Reroute -> Invert -> Group Output) and a reroute.
group = bpy.data.node_groups.new("Inverted", "ShaderNodeTree")
if hasattr(group, "interface"):
    group.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
else:
    group.inputs.new("NodeSocketColor", "Color")
    group.outputs.new("NodeSocketColor", "Color")
g_in, g_out = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
g_reroute, invert = group.nodes.new("NodeReroute"), group.nodes.new("ShaderNodeInvert")
group.links.new(g_in.outputs[0], g_reroute.inputs[0])
group.links.new(g_reroute.outputs[0], invert.inputs["Color"])
group.links.new(invert.outputs[0], g_out.inputs[0])
group_node = tree.nodes.new("ShaderNodeGroup")
group_node.node_tree = group
reroute = tree.nodes.new("NodeReroute")
tree.links.new(packed_node.outputs["Color"], reroute.inputs[0])
tree.links.new(reroute.outputs[0], group_node.inputs[0])
tree.links.new(image.outputs["Color"], mix.inputs[6])
tree.links.new(group_node.outputs[0], mix.inputs[7])
tree.links.new(mix.outputs[2], diffuse.inputs["Color"])
tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
# Missing and unknown: a material whose colour comes from a missing file, one fed by a Noise Texture.
missing, tree2, output2 = material("Missing")
node = tree2.nodes.new("ShaderNodeTexImage")
node.name = "Lost Image"
lost = bpy.data.images.new("Lost", 4, 4)
lost.source = "FILE"
lost.filepath = os.path.join(os.getcwd(), "no_such_file.png")
node.image = lost
emission = tree2.nodes.new("ShaderNodeEmission")
tree2.links.new(node.outputs["Color"], emission.inputs["Color"])
tree2.links.new(emission.outputs[0], output2.inputs["Surface"])
noisy, tree3, output3 = material("Noisy")
noise = tree3.nodes.new("ShaderNodeSqueeze")             # a node Primer does not evaluate (nor Cycles)
noise.name = "Some Noise"
principled = tree3.nodes.new("ShaderNodeBsdfPrincipled")
principled.inputs["Roughness"].default_value = 0.25
tree3.links.new(noise.outputs["Value"], principled.inputs["Roughness"])
tree3.links.new(principled.outputs[0], output3.inputs["Surface"])
plane("A", mat)
plane("B", missing, (2, 0, 0))
plane("C", noisy, (4, 0, 0))
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
camera.location = (2, 0, 8)
exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
table = {{m.name: m for m in exported.scene.materials}}
images = []
for name in ("Textured",):
    for entry in table[name].nodes:
        pass
def find(link, kind, found):
    if isinstance(link, graph.Link):
        if link.node.kind == kind:
            found.append(link.node)
        for value in link.node.inputs.values():
            find(value, kind, found)
    return found
factors = table["Textured"].nodes[0][3]
images = find(factors[0][0], "IMAGE", [])
inverts = find(factors[0][0], "INVERT", [])
missing_nodes = find(table["Missing"].nodes[0][2]["emission"], "IMAGE", [])
roughness = table["Noisy"].nodes[0][2]["roughness"]
report(warnings=exported.warnings,
       images=[None if n.props["image"] is None else n.props["image"].rgba()[:, :, :3].tolist() for n in images],
       dtypes=[None if n.props["image"] is None else n.props["image"].pixels.dtype.name for n in images],
       srgb=[None if n.props["image"] is None else n.props["image"].srgb for n in images],
       inverts=len(inverts), missing=[n.props["image"] is None for n in missing_nodes],
       roughness=float(roughness), uv=[sorted(m.attributes) for m in exported.scene.meshes],
       mapped=[[n.inputs["Vector"].node.kind, list(n.inputs["Vector"].node.inputs["Scale"]),
                n.inputs["Vector"].node.inputs["Vector"].output] for n in images if "Vector" in n.inputs])
"""


def test_images_from_files_and_packed_bytes_groups_and_warnings(results):
    result = results["images"]
    # Both images: bottom row first (blue, white), then red, green; the file's Non-Color, the packed one sRGB.
    expected = [[[0, 0, 1], [1, 1, 1]], [[1, 0, 0], [0, 1, 0]]]
    assert len(result["images"]) == 2
    for pixels in result["images"]:
        np.testing.assert_allclose(pixels, expected, atol=1e-6)
    assert sorted(result["srgb"]) == [False, True]
    assert result["dtypes"] == ["uint8", "uint8"]             # 8-bit files stay 8-bit
    assert result["inverts"] == 1                            # the group's Invert, reached through reroutes
    assert result["missing"] == [True]
    assert result["roughness"] == pytest.approx(0.25)      # the unknown node's input keeps its own value
    assert ["uv:"] in result["uv"]
    # The file's node's Texture Mapping (scale 2 along x) is a Point Mapping of the default UV before the lookup.
    assert result["mapped"] == [["MAPPING", [2.0, 1.0, 1.0], "UV"]]
    warnings = "\n".join(result["warnings"])
    assert "material 'Missing', node 'Lost Image'" in warnings and "magenta" in warnings
    assert "material 'Noisy', node 'Some Noise'" in warnings and "own value 0.25" in warnings


RANDOM = PRELUDE + """
import math
mat, tree, output = material("Random")
info = tree.nodes.new("ShaderNodeObjectInfo")
emission = tree.nodes.new("ShaderNodeEmission")
tree.links.new(info.outputs["Random"], emission.inputs["Color"])
tree.links.new(emission.outputs[0], output.inputs["Surface"])
for i, name in enumerate(("Cube", "Plane.001", "Thing")):
    plane(name, mat, (i - 1.5, 0.7, 0))
# Instances of a collection: Blender gives each its own random id.
source = bpy.data.collections.new("Source")
bpy.ops.mesh.primitive_plane_add(size=1.0)
tile = bpy.context.view_layer.objects.active
tile.data.materials.append(mat)
for collection in list(tile.users_collection):
    collection.objects.unlink(tile)
source.objects.link(tile)
for i in range(3):
    empty = bpy.data.objects.new(f"Instance {{i}}", None)
    empty.instance_type = "COLLECTION"
    empty.instance_collection = source
    empty.location = (i - 1.5, -0.7, 0)
    scene.collection.objects.link(empty)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.data.type = "ORTHO"
camera.data.ortho_scale = 4.0
camera.location = (-0.5, 0, 5)
scene.collection.objects.link(camera)
scene.camera = camera
scene.render.resolution_x, scene.render.resolution_y = 64, 64
exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
randoms = [graph.object_random(i.name) if i.random is None else i.random for i in exported.scene.instances]
# Cycles' own render of the same scene.
from render import configure_cycles_reference
configure_cycles_reference(scene, 4)
scene.render.engine = "CYCLES"
scene.view_settings.view_transform = "Standard"
scene.render.filepath = os.path.join(os.getcwd(), "cycles.exr")
scene.render.image_settings.file_format = "OPEN_EXR"
bpy.ops.render.render(write_still=True)
import OpenImageIO as oiio
pixels = oiio.ImageBuf(scene.render.filepath).get_pixels(oiio.FLOAT)
# Pixel centres of the six planes: x = (X + 2.5) / 4 * 64, rows from the top.
points = [(x - 1.5, y) for y in (0.7, -0.7) for x in range(3)]
cycles = [float(pixels[int((2.0 - y) / 4.0 * 64), int((x + 2.5) / 4.0 * 64), 0]) for x, y in points]
report(randoms=randoms, cycles=cycles, names=[i.name for i in exported.scene.instances])
"""


def test_object_random_is_cycles_per_object_and_per_instance(results):
    result = results["random"]
    assert len(result["randoms"]) == 6
    assert len(set(result["randoms"])) == 6                # different for every object and instance
    np.testing.assert_allclose(result["randoms"], result["cycles"], rtol=1e-5, atol=1e-6)


STORED = PRELUDE + """
import OpenImageIO as oiio
render_ = sys.modules[primer.__name__ + ".core.render"]


def write(name, pixels, kind):
    path = os.path.join(os.getcwd(), name)
    out = oiio.ImageOutput.create(path)
    out.open(path, oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], kind))
    out.write_image(pixels)
    out.close()
    return path


# A 16384 x 4 8-bit RGB ramp (red grows along u), a 16-bit grey image, a float EXR with NaN and infinite texels and
# a half RGBA one, each the colour of an emitting plane; the float EXR is the world's HDRI too.
wide = np.zeros((4, 16384, 3), np.uint8)
wide[..., 0] = (np.arange(16384) * 255 // 16383).astype(np.uint8)
grey16 = np.full((2, 2, 1), 13107, np.uint16)                   # 0.2 exactly
broken = np.full((2, 2, 3), 0.5, np.float32)
broken[0, 0] = (np.nan, np.inf, -np.inf)                      # (texel 2, bottom row first)
broken[1, 0] = (0.25, np.nan, 0.75)                            # (texel 0)
halves = np.full((2, 2, 4), 0.5, np.float16)
halves[0, 0] = (np.inf, 0.25, np.nan, 1.0)                     # (numpy's NaN half: mantissa 512)
paths = [write("wide.png", wide, oiio.UINT8), write("grey16.png", grey16, oiio.UINT16),
         write("broken.exr", broken, oiio.FLOAT), write("halves.exr", halves, oiio.HALF)]
for i, path in enumerate(paths):
    mat, tree, output = material(f"Image {{i}}")
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images.load(path)
    node.image.colorspace_settings.name = "Non-Color"
    node.interpolation = "Closest"
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(node.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    plane(f"P{{i}}", mat, (2 * i, 0, 0))
world = bpy.data.worlds.new("HDRI")
scene.world = world
if bpy.app.version < (5, 0, 0):
    world.use_nodes = True
environment = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
environment.image = bpy.data.images.load(paths[2])
environment.texture_mapping.rotation = (0.0, 0.0, 0.5)   # not applied to the world's lookup: said
background = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
world.node_tree.links.new(environment.outputs["Color"], background.inputs["Color"])
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
camera.location = (2, 0, 6)
scene.render.resolution_x, scene.render.resolution_y = 96, 32
exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
images = {{}}
for material in exported.scene.materials:
    for entry in material.nodes:
        value = entry[2].get("emission")
        node = getattr(value, "node", None)
        while node is not None and node.kind != "IMAGE":
            node = next((v.node for v in node.inputs.values() if isinstance(v, graph.Link)), None)
        if node is not None:
            image = node.props["image"]
            images[material.name] = (image.pixels.dtype.name, list(image.pixels.shape), image.rgba()[..., :3].tolist()
                                     if image.pixels.shape[1] <= 2 else image.rgba()[0, [0, 8192, 16383], :3].tolist(),
                                     image.rgba()[..., 3].tolist() if image.pixels.shape[1] <= 2 else None)
settings = exported.settings
settings.samples = 4
result = render_.render(exported.scene, settings)
report(warnings=exported.warnings, images=images, version=list(bpy.app.version), finite=bool(np.isfinite(result.image).all()),
       world_finite=bool(np.isfinite(exported.scene.world.image).all()))
"""


def test_images_keep_their_stored_precision_and_bad_texels_are_read_as_cycles_reads_them(results):
    """An 8-bit 16384-texel-wide image stays bytes (a quarter of floats' memory), a 16-bit grey one 16-bit and
    one channel, read as value / maximum; a float image's texel with a NaN or infinite channel (a texture and the
    world's HDRI) is 0 in every channel, alpha too (an RGB image gains alpha 1 elsewhere), as Cycles' loader sets it,
    with a warning, and the render has no NaN pixel; in Blender 5.0 only texels whose index is a multiple of 4 (the
    loader's loop), the others' bad channels 0. A half image's such texel is 0 from Blender 5.1 on, while Cycles 4.2 ..
    5.0 keep it and read inf as 65536 and NaN (mantissa 512) as 65536 x 1.5 (its exponent's bias moved); the HDRI's
    own Texture Mapping is applied (the world baked from its node graph), not warned about."""
    result = results["stored"]
    wide, grey, broken, halves = (result["images"][f"Image {i}"] for i in range(4))
    assert wide[:2] == ["uint8", [4, 16384, 3]]
    np.testing.assert_allclose(np.array(wide[2])[:, 0], [0.0, 8192 * 255 // 16383 / 255.0, 1.0], atol=1e-9)
    assert grey[:2] == ["uint16", [2, 2, 1]]
    np.testing.assert_allclose(grey[2], 0.2, atol=1e-12)            # grey to RGB: 13107 / 65535
    assert broken[:2] == ["float32", [2, 2, 4]] and np.isfinite(broken[2]).all()        # (alpha for texel 0)
    later = tuple(result["version"][:2]) >= (5, 1)
    assert broken[2][0][0] == [0.0, 0.0, 0.0] and broken[3][0][0] == 0.0     # texel 0: the file's bottom-left
    assert broken[2][1][0] == [0.0, 0.0, 0.0] and broken[3][1][0] == (0.0 if later else 1.0)    # texel 2
    assert broken[2][0][1] == [0.5, 0.5, 0.5] and broken[3][0][1] == 1.0
    if later:
        assert halves[2][1][0] == [0.0, 0.0, 0.0] and halves[3][1][0] == 0.0
    else:
        assert halves[2][1][0] == [65536.0, 0.25, 98304.0] and halves[3][1][0] == 1.0
    assert halves[2][0][0] == [0.5, 0.5, 0.5] and halves[3][0][0] == 0.5
    warnings = "\n".join(result["warnings"])
    assert "NaN or infinite" in warnings and "broken.exr" in warnings and "halves.exr" in warnings
    assert "Texture Mapping" not in warnings
    assert result["finite"] and result["world_finite"]


ODD = PRELUDE + """
import bmesh
render_ = sys.modules[primer.__name__ + ".core.render"]
# An image texture on a mesh without UV maps, an emitter of strength 1e9 whose triangles have no area,
# and a world of negative strength.
img = bpy.data.images.new("Checker", 8, 8)
img.generated_type = "COLOR_GRID"
mat, tree, output = material("No UV")
node = tree.nodes.new("ShaderNodeTexImage")
node.image = img
diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
tree.links.new(node.outputs["Color"], diffuse.inputs["Color"])
tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
floor = plane("Floor", mat)
floor.scale = (4, 4, 1)
floor.data.uv_layers.remove(floor.data.uv_layers[0])
glow, tree2, output2 = material("Glow")
emission = tree2.nodes.new("ShaderNodeEmission")
emission.inputs["Strength"].default_value = 1e9
tree2.links.new(emission.outputs[0], output2.inputs["Surface"])
flat = plane("Flat", glow, (0, 0, 1))
for vertex in flat.data.vertices:                            # every triangle has zero area
    vertex.co.y = 0.0
world = bpy.data.worlds.new("Negative")
scene.world = world
if bpy.app.version < (5, 0, 0):
    world.use_nodes = True
background = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
background.inputs["Strength"].default_value = -2.0
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
camera.location = (0, 0, 6)
scene.render.resolution_x, scene.render.resolution_y = 32, 32
exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
settings = exported.settings
settings.samples = 4
result = render_.render(exported.scene, settings)
report(warnings=exported.warnings + list(result.stats.warnings),
       finite=bool(np.isfinite(result.image).all()), low=float(result.image[..., :3].min()),
       mean=result.image[..., :3].mean(axis=(0, 1)).tolist())
"""


def test_a_texture_without_uvs_a_zero_area_emitter_of_1e9_and_a_negative_world_render_finite(results):
    """Bad input of issue 20: each is reported, and the render has no NaN, no infinite and no negative pixel."""
    result = results["odd"]
    warnings = "\n".join(result["warnings"])
    assert "has no UV map" in warnings and "reads (0, 0)" in warnings
    assert "world's Background is negative (-0.1" in warnings
    assert "zero-area triangle(s) were skipped" in warnings          # the emitter of 1e9: dropped, reported
    assert result["finite"] and result["low"] >= 0.0


def test_two_normal_map_nodes_reading_one_map_count_as_the_same_normal():
    """glTF's importer feeds Normal and Coat Normal from a Normal Map node each, reading one image: the coat then
    follows the node's normal (addon/materials.py same_graph); another image or strength is another normal."""
    import sys
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    from render import load_primer
    primer = load_primer()
    same_graph = sys.modules[f"{primer.__name__}.addon.materials"].same_graph
    graph = sys.modules[f"{primer.__name__}.core.materials.graph"]
    textures = sys.modules[f"{primer.__name__}.core.materials.textures"]
    image = textures.Image(np.zeros((2, 2, 3), np.uint8))

    def normal_map(picture, strength):
        texture = graph.GraphNode("IMAGE", {"image": picture, "interpolation": "Linear", "extension": "REPEAT"}, {})
        return graph.Link(graph.GraphNode("NORMAL_MAP", {"map": ""}, {"Color": graph.Link(texture, "Color"),
                                                                       "Strength": strength}), "Normal")

    assert same_graph(normal_map(image, 1.0), normal_map(image, 1.0))
    assert not same_graph(normal_map(image, 1.0), normal_map(image, 0.5))
    assert not same_graph(normal_map(image, 1.0), normal_map(textures.Image(np.zeros((2, 2, 3), np.uint8)), 1.0))


HALF = PRELUDE + """
import OpenImageIO as oiio
# A 256 x 256 half EXR of 2 x 2 blocks (1, 1 + 2^-10 three times) on an emitting plane, under Simplify > Texture
# Limit 128: exported, the image is its means, 1 + 3 x 2^-12 made half.
step = 2.0 ** -10
texels = np.tile(np.array([[1.0, 1.0 + step], [1.0 + step, 1.0 + step]]), (128, 128))
path = os.path.join(os.getcwd(), "blocks.exr")
out = oiio.ImageOutput.create(path)
out.open(path, oiio.ImageSpec(256, 256, 3, oiio.HALF))
out.write_image(np.repeat(texels[:, :, None], 3, axis=2).astype(np.float16))
out.close()
mat, tree, output = material("Blocks")
node = tree.nodes.new("ShaderNodeTexImage")
node.image = bpy.data.images.load(path)
node.image.colorspace_settings.name = "Linear Rec.709"
emission = tree.nodes.new("ShaderNodeEmission")
tree.links.new(node.outputs["Color"], emission.inputs["Color"])
tree.links.new(emission.outputs[0], output.inputs["Surface"])
plane("Blocks", mat)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
scene.render.use_simplify = True
scene.cycles.texture_limit = scene.cycles.texture_limit_render = "128"    # (a viewport depsgraph reads the first)
exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
values = []
for material in exported.scene.materials:
    for entry in material.nodes:
        node = getattr(entry[2].get("emission"), "node", None)
        while node is not None and node.kind != "IMAGE":
            node = next((v.node for v in node.inputs.values() if isinstance(v, graph.Link)), None)
        if node is not None:
            values.append((list(node.props["image"].pixels.shape), sorted(set(node.props["image"].rgba()[..., :3]
                                                                               .astype(float).ravel().tolist()))))
report(version=list(bpy.app.version), values=values)
"""


def test_a_half_image_under_a_texture_limit_keeps_the_half_this_blenders_cycles_makes(results):
    """The means 1 + 3 x 2^-12 of a half EXR's 2 x 2 blocks under Texture Limit 128 are made half as the running
    Blender's Cycles makes them (the add-on's rule from bpy.app.version): truncated to 1 in 4.2 .. 5.0, rounded to
    1 + 2^-10 from 5.1 (measured: Cycles 5.0.1 renders such an image 1.0, Cycles 5.2.3 1.0009766)."""
    result = results["half"]
    expected = 1.0 + 2.0 ** -10 if tuple(result["version"][:2]) >= (5, 1) else 1.0
    assert result["values"] == [[[128, 128, 3], [expected]]]


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """The five scripts' reports, from one Blender process (tests/one_process.py; one start for the file's tests, not
    five): {"images", "random", "stored", "odd", "half": its report}."""
    tools = os.path.join(ROOT, "tools")
    sources = {"images": IMAGES.format(tools=tools), "random": RANDOM.format(tools=tools),
               "stored": STORED.format(tools=tools), "odd": ODD.format(tools=tools), "half": HALF.format(tools=tools)}
    return run_bpy(RUNNER.format(sources=sources), str(tmp_path_factory.mktemp("textures")))["results"]
