"""Compare Primer with Cycles on real scenes: Blender files made by other people, which no test of ours built.

The scenes are not committed (each one's source, commit and licence is listed in SOURCES); `fetch` copies
them from a local git mirror of their repository into the cache folder, `compare` renders each with
Primer and with Cycles under the same settings and writes a report:

    .venv/bin/python tools/real_scenes.py fetch --mirror PATH/TO/glTF-Blender-IO --mirror ...   # once
    .venv/bin/python tools/real_scenes.py compare [--integrator direct|path] [--only NAME ...]

A scene whose .blend reads linked libraries and textures by relative path (FOLDERS) is copied with its whole folder;
a file its mirror holds only as a Git LFS pointer, or without content, is named by `fetch` and not copied.
A material library (BOARDS: a file of materials and no scene) is shown as one sphere per material on a grid.
A scene without a camera gets one that frames its meshes from a three-quarter view above; a scene
without lights (lamps, an HDRI world or a mesh whose surface is an Emission shader) gets a sun and a dim world that lights it. Both renderers then run through
tools/render.py (Cycles as Primer's reference: the same bounces, a 1-pixel box filter, no denoising, no
clamping, no compositor). The error measure is the project's: the relative MSE of 4x4-pixel block means,
mean((B(P) - B(C))^2 / (B(C)^2 + 0.01)); for scale, Cycles at 256 samples against its own 512 scores
about 1e-4 or less. Cache: $PRIMER_REAL_SCENES, default ~/.cache/primer/real_scenes.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from core.film.compare import relative_mse_of_blocks  # noqa: E402  (the project's error measure)
CACHE = os.environ.get("PRIMER_REAL_SCENES", os.path.join(os.path.expanduser("~"), ".cache", "primer", "real_scenes"))
GLTF_IO = ("KhronosGroup/glTF-Blender-IO", "7551a35b146ab62ebc503ec661f88a74dc611392", "Apache-2.0")

# name -> (repository, commit, licence, path in the repository, what it exercises)
SOURCES = {
    "gltf_factors": GLTF_IO + ("tests/scenes/01_factors.blend", "Principled factors, a node group, Math and Mix"),
    "gltf_sheen": GLTF_IO + ("tests/scenes/19_sheen.blend", "the Sheen BSDF (Ashikhmin velvet), with textures"),
    "gltf_specular": GLTF_IO + ("tests/scenes/20_specular.blend", "Specular IOR Level and Specular Tint"),
    "gltf_node_groups": GLTF_IO + ("tests/scenes/22_node_groups.blend", "materials inside node groups"),
    "gltf_vertex_colors": GLTF_IO + ("tests/scenes/24_vertex_colors.blend", "vertex colours, transparency, emission"),
    "gltf_robot": GLTF_IO + ("tests/scenes/RobotExpressive.blend", "a rigged character, Principled materials"),
    "gltf_scene_export": GLTF_IO + ("tests/scenes/00_scene_export.blend", "diffuse and Principled meshes"),
    "cornell_box": ("wahn/render_comparison", "04527399aa828c72b46c80abda49d6718ae7af71",
                    "GPL-3.0 (the repository's licence), Jan Walter",
                    "cornell_box/blend/cornell_box.blend",
                    "a Cycles Cornell box saved by Blender 2.79: diffuse walls, a mesh-emitter ceiling light, "
                    "its own camera"),
    "bricabrac_color_ramp": ("Franck-Demongin/Bricabrac", "b6309181ab8da0bf30bf66afb0b2422a7226d118",
                             "GPL-3.0 (the repository's licence), Franck Demongin", "Nodes/nx_color-ramp.blend",
                             "procedural: Brick, Gradient and Noise textures through a 'dynamic Color Ramp' made of "
                             "node groups of Map Range, Math and Mix nodes, and a Color Ramp (Blender 3.4)"),
    "bmw27_studio": ("BabyYodaCoin/MinecraftServer", "5012308bbe128a6029f4fa9dd3a798ff0a0e4fe0",
                     "Mike Pan's BMW27, the Blender Foundation's Cycles benchmark and demo file (download.blender.org/"
                     "demo/test/BMW27.blend.zip), free to use as Blender's demo files are; this copy (saved by Blender "
                     "2.93, textures packed) is in a repository without a licence of its own",
                     "bmw27_gpu.blend",
                     "a car studio (Mike Pan's BMW27): a procedural flake car paint (a Noise texture of scale 1000 "
                     "into a Normal Map, Layer Weight mixing two Beckmann glossies), chrome, glass, a Sheen floor, "
                     "emission-panel lights, a world colour from an RGB node, depth of field, packed textures"),
    "gltf_volume": GLTF_IO + ("tests/scenes/16_volume.blend",
                              "glTF KHR_materials_volume as Blender makes it: a Volume Absorption inside a glass "
                              "(Principled transmission) mesh, beside one without and one of zero thickness"),
    "donut_tutorial": ("Cynnexis/b3d-donut", "63ff1abeeca44556cca61757789f08b5948d471d",
                       "licence unknown (the repository has no licence; a student's result of Blender Guru's donut "
                       "tutorial), Cynnexis", "donut.blend",
                       "a tutorial food scene (Blender Guru's donut, Blender 3.4): a Noise bump and an image texture "
                       "on the dough, icing by a Subdivision and a geometry-nodes modifier that scatters sprinkles "
                       "coloured by Object Info Random through a Constant Color Ramp, four point lamps (one hidden), "
                       "a world colour, depth of field, motion blur, its own camera, a compositor (the rig's is off)"),
}

# Scenes whose .blend reads other files by relative path (linked libraries, textures beside it): their whole folder
# is copied, keeping its layout, into the cache's folder of the scene's name. name -> (repository, commit, licence,
# folder in the repository, the .blend in that folder, what it exercises). A file the mirror holds only as a Git LFS
# pointer, or not at all (a snapshot may leave out large files), is not copied and `fetch` names it: a pointer
# written as a .blend would make Blender fail without saying why, and a missing image renders magenta in both
# Cycles and Primer (Primer warns).
FOLDERS = {
    "classroom": ("Start-Ten/Virtual-Reality", "b2eda5f2c7d2d967ab80f5b8daab1e44d6d6f048",
                  "CC0, Christophe Seux's *Classroom*, one of Blender's demo files (the licence the Blender demo-files "
                  "page gives, as cited by third parties; this copy's repository has no licence of its own and its "
                  "ReadMe.txt, the author's, states none)",
                  "classroom", "classroom.blend",
                  "an interior (Christophe Seux's Classroom, the Cycles benchmark scene, Blender 2.7x): sunlight "
                  "through windows and Venetian blinds, many lamps, linked asset libraries (assets/*/*.blend), "
                  "image textures beside the file"),
}
# Files a SOURCES scene reads by a relative path ("//..."), copied beside its .blend in the cache: name -> paths.
BESIDE = {"donut_tutorial": ("Donut Base.png",)}

# Material libraries: files that hold procedural materials but no scene to show them in. name -> (repository,
# commit, licence, path, the materials to show, what they exercise). `build` opens the file, removes its objects and
# lays a row-major grid of smooth UV spheres (and the rig adds a camera and a sun), one sphere per material, in the
# order given; the materials are the file's own, unchanged.
ADDONS_CONTRIB = ("blender/blender-addons-contrib", "GPL-2.0-or-later (the add-ons' licence)")
SHADER_LIB = ("wirehead/blender-shader-lib", "72eb89e80e2349f97163abadd6cdf41e172ff579",
              "CC0 (stated in the repository's README), wirehead")
BOARDS = {
    "crackit_materials": (ADDONS_CONTRIB[0], "0ed1a7e9724a932259552dd319f73171226f444b", ADDONS_CONTRIB[1],
                          "object_fracture_crack/process/materials/materials1.blend",
                          ("crackit_lava", "crackit_mud", "crackit_organic_mud", "crackit_rock", "crackit_tree_dry",
                           "crackit_tree_moss", "crackit_tree_red", "crackit_wet-paint", "crackit_soap"),
                          "procedural (Cell Fracture Crack It add-on's materials, Blender 2.79): many-octave Noise, "
                          "Voronoi, Wave, Color Ramps, RGB Curves, Bump, Bright/Contrast, Hue/Saturation, node groups"),
    "vx_cycles_materials": (ADDONS_CONTRIB[0], "db54088edea45ba9ffdbea4169665b5bb4d4a847", ADDONS_CONTRIB[1],
                            "materials_library_vx/cycles_materials.blend",
                            ("Floor Wood", "Ceramic_1970_tiles", "Marble", "rusty_g", "Carbon Fiber (Glossy)", "Denim",
                             "Mosaic", "Galvanized Steel", "Gob Stopper", "Polished Walnut", "Stone Red",
                             "Chocolate Swirl"),
                            "procedural (Material Library VX add-on's Cycles materials, Blender 2.78): Brick, Wave, "
                            "Noise, Voronoi, Magic, Checker, Color Ramps, Mix, Math, Bump, Fresnel, Layer Weight, "
                            "node groups"),
    "vx_sponge": (ADDONS_CONTRIB[0], "db54088edea45ba9ffdbea4169665b5bb4d4a847", ADDONS_CONTRIB[1],
                  "materials_library_vx/cycles_materials.blend", ("Sponge",),
                  "a heterogeneous volume (Material Library VX's *Sponge*, Blender 2.78): no surface, a node group "
                  "whose Voronoi distance, Math Less Than and Multiply make a density of 100 or 0 in open cells, "
                  "Volume Absorption plus Volume Scatter (anisotropy -0.3) at the Volume output"),
    "shaderlib_subsurface": (SHADER_LIB[0], SHADER_LIB[1], SHADER_LIB[2], "cycles-principled-dielectric-fabric.blend",
                             ("Blue Oxford", "Charocal Wool", "Checkered Cotton", "Gray Cotton T-shirt",
                              "Mustard Wool", "Satin", "Sheer Black Nylon Weave", "Striped Cotton",
                              "Two Tone Satin Principled"),
                             "subsurface scattering: Principled BSDFs of Subsurface Weight 1 (Christensen-Burley), "
                             "with sheen, procedural weaves (Wave, Checker, Noise, Bump, RGB Curves, node groups), "
                             "Transparent BSDF mixes, Blender 2.79"),
    "shaderlib_marble": (SHADER_LIB[0], SHADER_LIB[1], SHADER_LIB[2],
                         "cycles-principled-dielectric-construction.blend", ("Marble",),
                         "subsurface scattering close up: a Principled BSDF of Subsurface Weight 1 (Christensen-"
                         "Burley, Scale 0.1 on a sphere of radius 0.45) under procedural veins (Wave, Math, Mix, "
                         "Color Ramp), Blender 2.79"),
    "shaderlib_volumes": (SHADER_LIB[0], SHADER_LIB[1], SHADER_LIB[2],
                          "cycles-principled-dielectric-transparent.blend",
                          ("71% lead glass", "71% lead glass with fake dispersion", "Acrylic Plastic", "Crown Glass",
                           "Diamond with fake dispersion", "Ice", "PET (#1) Plastic", "Polycarbonate Plastic",
                           "Polystyrine (#6) Plastic", "Ruby", "White Saphire with fake dispersion"),
                          "volumes inside glass: Principled and Glass BSDF transmission over Volume Absorption and "
                          "Volume Scatter at the Volume output, 'fake dispersion' made of three glasses, Blender 2.79"),
}

HELMET = ("GDLynx/3d-models", "b56af89fbbe17fa6e8c0a49d886daae01efc1e9f",
          "CC-BY 4.0, 'Battle Damaged Sci-fi Helmet' by theblueturtle_ (Khronos glTF sample model)")
STUDIO = ("adityawaskel/PlutarchyHRDI", "59d64fda881538cea86e403c4545e3ec82447158", "CC0, Poly Haven 'Studio Small 08'")
# Copies of Khronos glTF sample models in small repositories (the Khronos sample repositories are too large to
# fetch here); each model's own licence is that of its Khronos README.
VCLIB, ASSIMP = "cnr-isti-vclab/vclib", "assimp/assimp"
VCLIB_AT = "d37c2830819731c9930bebdae7d72d88d9565059"
ASSIMP_AT = "21bea12f1278090c09a94c39ca090d9fb458ccd9"
SPHERES = (VCLIB, VCLIB_AT, "CC0, 'Metal-Rough Spheres (textureless)' by Krill Gavrilov (Khronos glTF sample model)")
MIRROR = (VCLIB, VCLIB_AT, "CC-BY 4.0, 'NormalTangentMirrorTest' by Ed Mackey, Analytical Graphics (Khronos glTF "
          "sample model)")
CLEARCOAT = (ASSIMP, ASSIMP_AT, "CC-BY 4.0, 'KHR_materials_clearcoat Test' by Ed Mackey, Analytical Graphics (Khronos "
             "glTF sample model)")
TRANSFORM = (ASSIMP, ASSIMP_AT, "CC0, 'Texture Transform Test' by Microsoft (Khronos glTF sample model)")
ATTENUATION = (GLTF_IO[0], GLTF_IO[1], "CC-BY 4.0, 'Attenuation Test' by Ed Mackey, Analytical Graphics (Khronos "
               "glTF sample model; glTF-Blender-IO's round-trip copy)")
TRUCK = (VCLIB, VCLIB_AT, "CC-BY 4.0, 'Cesium Milk Truck' donated by Cesium (Khronos glTF sample model)")

# Scenes built from files (a glTF model and an HDRI) by a bpy script: name -> (files [(repository, commit,
# licence, path)], the name of the HDRI among them or "", what it exercises). The script imports the model with
# Blender's own glTF importer and lights it by the HDRI alone (an Environment Texture in the world).
BUILT = {
    "gltf_damaged_helmet": ([HELMET + (path,) for path in (
        "DamagedHelmet.gltf", "DamagedHelmet.bin", "Default_albedo.jpg", "Default_metalRoughness.jpg",
        "Default_normal.jpg", "Default_emissive.jpg", "Default_AO.jpg")] + [STUDIO + ("studio_small_08_1k.hdr",)],
        "studio_small_08_1k.hdr", "glTF: textured metal-rough, normal map, emissive texture; an HDRI world"),
    "gltf_metal_rough_spheres": ([SPHERES + ("assets/example_meshes/gltf/MetalRoughSpheresNoTextures/" + path,)
                                  for path in ("MetalRoughSpheresNoTextures.gltf", "MetalRoughSpheresNoTextures.bin")]
                                 + [STUDIO + ("studio_small_08_1k.hdr",)], "studio_small_08_1k.hdr",
                                 "glTF: 98 spheres, metallic 0-1 against roughness 0-1 in gold and silver (no textures); "
                                 "an HDRI world"),
    "gltf_normal_tangent_mirror": ([MIRROR + ("assets/example_meshes/gltf/NormalTangentMirrorTest/" + path,)
                                    for path in ("NormalTangentMirrorTest.gltf", "NormalTangentMirrorTest.bin",
                                                 "NormalTangentMirrorTest_BaseColor.png",
                                                 "NormalTangentMirrorTest_Normal.png",
                                                 "NormalTangentMirrorTest_OcclusionRoughnessMetallic.png")]
                                   + [STUDIO + ("studio_small_08_1k.hdr",)], "studio_small_08_1k.hdr",
                                   "glTF: tangent-space normal maps on mirrored UVs, a packed ORM texture; an HDRI "
                                   "world"),
    "gltf_clearcoat": ([CLEARCOAT + ("test/models/glTF2/ClearCoat-glTF/" + path,)
                        for path in ("ClearCoatTest.gltf", "ClearCoatTest.bin", "PartialCoating.png",
                                     "PartialCoating_Alpha.png", "RoughnessStripes.png", "RibsNormal.png",
                                     "PlasticWrap_normals.jpg", "ClearCoatLabels.png")]
                       + [STUDIO + ("studio_small_08_1k.hdr",)], "studio_small_08_1k.hdr",
                       "glTF KHR_materials_clearcoat: coat weight, roughness and normal textures, alpha-blended "
                       "coats; an HDRI world"),
    "gltf_texture_transform": ([TRANSFORM + ("test/models/glTF2/textureTransform/" + path,)
                                for path in ("TextureTransformTest.gltf", "TextureTransformTest.bin", "UV.png",
                                             "Arrow.png", "Correct.png", "NotSupported.png", "Error.png")]
                               + [STUDIO + ("studio_small_08_1k.hdr",)], "studio_small_08_1k.hdr",
                               "glTF KHR_texture_transform (offset, rotation, scale: a Mapping node), clamped "
                               "textures; an HDRI world"),
    "gltf_milk_truck": ([TRUCK + ("assets/example_meshes/gltf/CesiumMilkTruck/" + path,)
                         for path in ("CesiumMilkTruck.gltf", "CesiumMilkTruck_data.bin", "CesiumMilkTruck.jpg")]
                        + [STUDIO + ("studio_small_08_1k.hdr",)], "studio_small_08_1k.hdr",
                        "glTF: a textured vehicle (rough dielectrics), a node hierarchy; an HDRI world"),
    "gltf_attenuation_test": ([ATTENUATION + ("tests/roundtrip/16_volume/" + path,)
                               for path in ("16_volume.gltf", "AttenuationTest.bin", "AttenuationLabels.png",
                                            "PlainGrid.png", "ThicknessTexture.png")]
                              + [STUDIO + ("studio_small_08_1k.hdr",)], "studio_small_08_1k.hdr",
                              "glTF KHR_materials_volume: attenuation colour and distance, thickness factors and a "
                              "thickness texture (the importer's Volume Absorption inside transmission); an HDRI "
                              "world"),
}

BOARD = r'''
import math
import bpy
bpy.ops.wm.open_mainfile(filepath={source!r})
scene = bpy.context.scene
for o in list(scene.objects):
    bpy.data.objects.remove(o, do_unlink=True)
names = {materials!r}
columns = math.ceil(math.sqrt(len(names) * 4 / 3))
rows = math.ceil(len(names) / columns)
for i, name in enumerate(names):
    row, column = divmod(i, columns)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.45,
                                         location=(column - (columns - 1) / 2, (rows - 1) / 2 - row, 0))
    sphere = bpy.context.object
    sphere.name = "Board " + name
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(bpy.data.materials[name])
bpy.ops.wm.save_as_mainfile(filepath={out!r})
print("BUILT")
'''

BUILD = r'''
import sys
import bpy
import addon_utils
addon_utils.enable("io_scene_gltf2", default_set=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath={model!r})
scene = bpy.context.scene
world = bpy.data.worlds.new("HDRI World")
scene.world = world
if bpy.app.version < (5, 0, 0):
    world.use_nodes = True
tree = world.node_tree
background = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBackground")
environment = tree.nodes.new("ShaderNodeTexEnvironment")
environment.image = bpy.data.images.load({hdri!r})
tree.links.new(environment.outputs["Color"], background.inputs["Color"])
background.inputs["Strength"].default_value = 1.0
bpy.ops.wm.save_as_mainfile(filepath={out!r})
print("BUILT")
'''

RIG = r'''
import sys, math
import bpy
from mathutils import Vector
sys.path.insert(0, {tools!r})
from render import load_primer
load_primer()
bpy.ops.wm.open_mainfile(filepath={source!r})
scene = bpy.context.scene
notes = []
meshes = [o for o in scene.objects if o.type == "MESH" and o.visible_get()]
if scene.camera is None:
    points = [o.matrix_world @ Vector(c) for o in meshes for c in o.bound_box]
    lo = Vector([min(p[i] for p in points) for i in range(3)])
    hi = Vector([max(p[i] for p in points) for i in range(3)])
    centre, radius = (lo + hi) / 2, max((hi - lo).length / 2, 1e-3)
    direction = Vector((1.0, -1.3, 0.9)).normalized()
    camera = bpy.data.objects.new("Rig Camera", bpy.data.cameras.new("Rig Camera"))
    camera.data.lens = 50.0
    camera.location = centre + direction * radius * 3.2
    camera.rotation_euler = (centre - camera.location).to_track_quat("-Z", "Y").to_euler()
    camera.data.clip_start, camera.data.clip_end = radius * 0.01, radius * 100
    scene.collection.objects.link(camera)
    scene.camera = camera
    notes.append("camera added")
lit_by_image = scene.world is not None and scene.world.node_tree is not None and any(
    n.bl_idname == "ShaderNodeTexEnvironment" for n in scene.world.node_tree.nodes)
def emitter(material):
    """Whether a material's active output takes its surface straight from an Emission shader (a mesh light)."""
    tree = material.node_tree if material is not None else None
    return tree is not None and any(
        n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output and n.inputs["Surface"].is_linked
        and n.inputs["Surface"].links[0].from_node.bl_idname == "ShaderNodeEmission" for n in tree.nodes)
mesh_lights = any(emitter(slot.material) for o in meshes for slot in o.material_slots)
if not any(o.type == "LIGHT" for o in scene.objects) and not lit_by_image and not mesh_lights:
    sun = bpy.data.objects.new("Rig Sun", bpy.data.lights.new("Rig Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, math.radians(3.0)
    sun.rotation_euler = (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(sun)
    notes.append("sun added")
    world = scene.world or bpy.data.worlds.new("Rig World")
    scene.world = world
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    background = next((n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground"), None)
    if background is not None:
        background.inputs["Color"].default_value = (0.05, 0.055, 0.06, 1.0)
        background.inputs["Strength"].default_value = 1.0
render = scene.render
render.resolution_x, render.resolution_y, render.resolution_percentage = {width}, {height}, 100
render.film_transparent = False
render.use_stamp = False                    # a file may burn its date and render time into the image
# The compositor is post-processing on both renderers' images, and a nonlinear one (a Glare's threshold, a Blur, a Lens
# Distortion): the raw render result is what is compared (the donut's Glare made 3 % a 4x larger block error).
compositor = getattr(scene, "compositing_node_group", None) or (getattr(scene, "node_tree", None)
                                                                  if getattr(scene, "use_nodes", False) else None)
if render.use_compositing and compositor is not None and len(compositor.nodes) > 0:
    notes.append("compositor off")
render.use_compositing = render.use_sequencer = False
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
scene.primer.integrator = {integrator!r}
scene.primer.light_samples = 1
scene.primer.terminator_fix = True          # Cycles lifts smooth shadow rays by each object's offset (0.1)
scene.primer.use_adaptive_sampling = False
scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0   # Primer reads it; Cycles' reference has it
render.engine = "PRIMER"
bpy.ops.wm.save_as_mainfile(filepath={out!r}, copy=True)
print("RIG " + ", ".join(notes or ["as saved"]))
'''


def git_file(mirrors: list, commit: str, path: str):
    """The bytes of `path` at `commit` (or HEAD) in the first of the git directories `mirrors` that has it."""
    for mirror in mirrors:
        for revision in (commit, "HEAD"):
            data = subprocess.run(["git", "--git-dir", mirror, "show", f"{revision}:{path}"], capture_output=True)
            if data.returncode == 0:
                return data.stdout
    return None


def lfs_pointer(data: bytes):
    """The (sha256 oid, size in bytes) a Git LFS pointer file names, or None when `data` is not one (the spec's
    first line is `version https://git-lfs.github.com/spec/v1`)."""
    if not data.startswith(b"version https://git-lfs.github.com/spec/") or len(data) > 1024:
        return None
    fields = dict(line.split(" ", 1) for line in data.decode("ascii", "replace").splitlines() if " " in line)
    oid = fields.get("oid", "").split(":", 1)[-1]
    size = fields.get("size", "")
    return (oid, int(size)) if size.isdigit() else (oid, -1)


def git_folder(mirrors: list, commit: str, folder: str) -> tuple:
    """(the first of `mirrors` holding `commit` (else HEAD) with `folder`, the revision, the folder's file paths
    under it, repository-relative); (None, None, []) when none has it."""
    for mirror in mirrors:
        for revision in (commit, "HEAD"):
            listed = subprocess.run(["git", "--git-dir", mirror, "ls-tree", "-r", "--name-only", "-z", revision,
                                     "--", folder], capture_output=True)
            paths = [p.decode() for p in listed.stdout.split(b"\0") if p] if listed.returncode == 0 else []
            if paths:
                return mirror, revision, paths
    return None, None, []


def fetch_folder(name: str, mirrors: list) -> dict:
    """Copy a FOLDERS scene's folder from the first mirror holding it into CACHE/name, keeping its layout; return
    {"copied": [relative paths], "lfs": {relative path: size}, "absent": [relative paths]}: files the mirror holds
    only as Git LFS pointers, or whose content it lacks, are not written."""
    repo, commit, _, folder, blend, _ = FOLDERS[name]
    mirror, revision, paths = git_folder(mirrors, commit, folder)
    out = {"copied": [], "lfs": {}, "absent": []}
    if mirror is None:
        print(f"{name}: {folder}/ is in none of {mirrors}")
        return out
    for path in paths:
        relative = os.path.relpath(path, folder)
        done = subprocess.run(["git", "--git-dir", mirror, "show", f"{revision}:{path}"], capture_output=True)
        if done.returncode != 0:
            out["absent"].append(relative)
            continue
        pointer = lfs_pointer(done.stdout)
        if pointer is not None:
            out["lfs"][relative] = pointer[1]
            continue
        target = os.path.join(CACHE, name, relative)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        with open(target, "wb") as handle:
            handle.write(done.stdout)
        out["copied"].append(relative)
    print(f"{name}: {len(out['copied'])} of {len(paths)} files from {repo} ({folder}/)"
          + (f"; Git LFS pointers only (content not in the mirror): "
             + ", ".join(f"{p} ({s / 1e6:.1f} MB)" for p, s in sorted(out["lfs"].items())) if out["lfs"] else "")
          + (f"; absent from the mirror: {', '.join(sorted(out['absent']))}" if out["absent"] else ""))
    if blend in out["lfs"] or blend in out["absent"]:
        print(f"{name}: {blend} itself is not in the mirror, so the scene cannot be rendered; put the file (with its "
              f"linked libraries) in {os.path.join(CACHE, name)} by other means, e.g. a clone with Git LFS content")
    return out


def fetch(mirrors: list) -> None:
    """Copy every source that one of the git directories `mirrors` holds into the cache."""
    os.makedirs(CACHE, exist_ok=True)
    for name, (repo, commit, _, path, _) in SOURCES.items():
        data = git_file(mirrors, commit, path)
        if data is None:
            print(f"{name}: {path} is in none of {mirrors}")
            continue
        with open(os.path.join(CACHE, name + os.path.splitext(path)[1]), "wb") as handle:
            handle.write(data)
        print(f"{name}: {len(data) / 1e6:.1f} MB from {repo} ({path})")
        for extra in BESIDE.get(name, ()):
            data = git_file(mirrors, commit, extra)
            if data is not None:
                with open(os.path.join(CACHE, os.path.basename(extra)), "wb") as handle:
                    handle.write(data)
            print(f"{name}: {extra} " + ("copied beside it" if data is not None else "missing"))
    for name, (repo, commit, _, path, _, _) in BOARDS.items():
        data = git_file(mirrors, commit, path)
        if data is None:
            print(f"{name}: {path} is in none of {mirrors}")
            continue
        with open(os.path.join(CACHE, name + "_library.blend"), "wb") as handle:
            handle.write(data)
        print(f"{name}: {len(data) / 1e6:.1f} MB from {repo} ({path})")
    for name in FOLDERS:
        fetch_folder(name, mirrors)
    for name, (files, _, _) in BUILT.items():
        folder = os.path.join(CACHE, name)
        os.makedirs(folder, exist_ok=True)
        missing = []
        for repo, commit, _, path in files:
            data = git_file(mirrors, commit, path)
            if data is None:
                missing.append(f"{repo}:{path}")
                continue
            with open(os.path.join(folder, os.path.basename(path)), "wb") as handle:
                handle.write(data)
        print(f"{name}: {len(files) - len(missing)} of {len(files)} files" + (f"; missing {missing}" if missing else ""))


def build_board(name: str) -> str:
    """Make the .blend of a BOARDS scene in the cache from its fetched library (once); return its path, or ""."""
    library = os.path.join(CACHE, name + "_library.blend")
    out = os.path.join(CACHE, name + ".blend")
    if os.path.exists(out):
        return out
    if not os.path.exists(library):
        print(f"{name}: {library} is not in the cache; run `fetch` first")
        return ""
    done = run(["-c", BOARD.format(source=library, materials=BOARDS[name][4], out=out)])
    if done.returncode != 0 or not os.path.exists(out):
        print(f"{name}: building failed\n{done.stderr[-2000:]}")
        return ""
    return out


def build(name: str) -> str:
    """Make the .blend of a BUILT scene in the cache from its fetched files (once); return its path, or ""."""
    files, hdri, _ = BUILT[name]
    folder = os.path.join(CACHE, name)
    out = os.path.join(CACHE, name + ".blend")
    if os.path.exists(out):
        return out
    model = os.path.join(folder, os.path.basename(files[0][3]))
    if not all(os.path.exists(os.path.join(folder, os.path.basename(f[3]))) for f in files):
        print(f"{name}: its files are not all in {folder}; run `fetch` first")
        return ""
    done = run(["-c", BUILD.format(model=model, hdri=os.path.join(folder, hdri), out=out)])
    if done.returncode != 0 or not os.path.exists(out):
        print(f"{name}: building failed\n{done.stderr[-2000:]}")
        return ""
    return out


def rig(name: str, integrator: str, width: int, height: int, out: str = "") -> tuple:
    """Rig a cached scene for `integrator` ("direct" or "path") at width x height into `out` (default: the cache's
    work folder): a camera and a sun where it has none, Cycles' look, the renderers' shared settings. Return (the
    rigged .blend's path, the rig's notes), or ("", [why]) when the scene is not in the cache or rigging failed."""
    source = (build(name) if name in BUILT else build_board(name) if name in BOARDS
              else os.path.join(CACHE, name, FOLDERS[name][4]) if name in FOLDERS
              else os.path.join(CACHE, name + ".blend"))
    if not source or not os.path.exists(source):
        print(f"{name}: not in the cache ({source}); run `fetch` first"
              + (" (it names what the mirror lacks)" if name in FOLDERS else ""))
        return "", [f"{name} is not in the cache {CACHE}"]
    with open(source, "rb") as handle:
        if lfs_pointer(handle.read(1024)) is not None:
            print(f"{name}: {source} is a Git LFS pointer, not a .blend; its content is not in the cache")
            return "", [f"{name} is a Git LFS pointer"]
    rigged = out or os.path.join(CACHE, "work", f"{name}_{integrator}.blend")
    os.makedirs(os.path.dirname(rigged), exist_ok=True)
    script = RIG.format(tools=os.path.join(ROOT, "tools"), source=source, out=rigged, width=width, height=height,
                        integrator=integrator.upper())
    done = run(["-c", script])
    if done.returncode != 0:
        print(f"{name}: rigging failed\n{done.stderr[-2000:]}")
        return "", ["rigging failed"]
    return rigged, [line[4:] for line in done.stdout.splitlines() if line.startswith("RIG ")]


def run(args: list, timeout: float = 1800) -> subprocess.CompletedProcess:
    """Run a Python command of this checkout's venv, returning the finished process."""
    return subprocess.run([sys.executable] + args, capture_output=True, text=True, timeout=timeout, cwd=ROOT)


def compare(names: list, integrator: str, samples: int, reference: int, width: int, height: int,
            report: str) -> list:
    """Rig, render with both engines and measure each cached scene; write the report; return the rows."""
    from core.film import image_io
    rows = []
    work = os.path.join(CACHE, "work")
    for name in names:
        rigged, notes = rig(name, integrator, width, height)
        if not rigged:
            continue
        images, seconds, warnings = {}, {}, []
        for engine, count in (("PRIMER", samples), ("CYCLES", reference)):
            out = os.path.join(work, f"{name}_{integrator}_{engine.lower()}.exr")
            start = time.time()
            done = run([os.path.join(ROOT, "tools", "render.py"), rigged, "-o", out, "--engine", engine,
                        "--samples", str(count)])
            seconds[engine] = time.time() - start
            if done.returncode != 0:
                print(f"{name}: {engine} failed\n{done.stderr[-2000:]}")
                break
            if engine == "PRIMER":
                warnings = sorted({line.split("Primer: ", 1)[1] for line in (done.stdout + done.stderr).splitlines()
                                   if "Warning: Primer: " in line})
            images[engine] = image_io.read_image(out)
        if len(images) < 2:
            continue
        P, C = images["PRIMER"], images["CYCLES"]
        row = dict(name=name, integrator=integrator, error=relative_mse_of_blocks(P, C),
                   ratio=float(P[..., :3].mean() / max(C[..., :3].mean(), 1e-12)), primer_s=seconds["PRIMER"],
                   cycles_s=seconds["CYCLES"], notes=notes, warnings=warnings,
                   what=(SOURCES[name][4] if name in SOURCES else BOARDS[name][5] if name in BOARDS
                         else FOLDERS[name][5] if name in FOLDERS else BUILT[name][2]),
                   source=describe(name))
        rows.append(row)
        print(f"{name:22s} relMSE {row['error']:.2e}  mean P/C {row['ratio']:.4f}  "
              f"Primer {row['primer_s']:.1f} s  Cycles {row['cycles_s']:.1f} s  {len(warnings)} warning(s)")
    write_report(rows, report, samples, reference)
    return rows


def describe(name: str) -> str:
    """Where a scene's files come from, with their licences."""
    if name in SOURCES:
        return f"{SOURCES[name][0]} {SOURCES[name][3]} ({SOURCES[name][2]})"
    if name in BOARDS:
        return f"{BOARDS[name][0]} {BOARDS[name][3]} ({BOARDS[name][2]})"
    if name in FOLDERS:
        return f"{FOLDERS[name][0]} {FOLDERS[name][3]}/{FOLDERS[name][4]} ({FOLDERS[name][2]})"
    return "; ".join(sorted({f"{repo} ({licence})" for repo, _, licence, _ in BUILT[name][0]}))


def write_report(rows: list, path: str, samples: int, reference: int) -> None:
    """A markdown table of the measurements, and the JSON beside it."""
    lines = [f"| scene | what it exercises | relMSE (4x4 blocks) | mean P/C | Primer {samples} spp (s) | "
             f"Cycles {reference} spp (s) | Primer's warnings |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['name']} ({r['integrator']}) | {r['what']} | {r['error']:.2e} | {r['ratio']:.3f} | "
                     f"{r['primer_s']:.1f} | {r['cycles_s']:.1f} | {'; '.join(r['warnings'])[:300]} |")
    with open(path, "w") as handle:
        handle.write("\n".join(lines) + "\n")
    with open(os.path.splitext(path)[0] + ".json", "w") as handle:
        json.dump(rows, handle, indent=1)
    print(f"report: {path}")


def main(argv=None) -> int:
    """Parse the command line and run it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fetch", help="copy the sources from a local git mirror into the cache")
    f.add_argument("--mirror", required=True, action="append", help="a repository's git directory (repeatable)")
    c = sub.add_parser("compare", help="render every cached scene with Primer and Cycles and measure")
    c.add_argument("--only", nargs="*", default=None)
    c.add_argument("--integrator", choices=("direct", "path"), default="direct")
    c.add_argument("--samples", type=int, default=1024)
    c.add_argument("--reference", type=int, default=2048)
    c.add_argument("--size", type=int, nargs=2, default=(320, 240))
    c.add_argument("--report", default=os.path.join(CACHE, "report.md"))
    args = parser.parse_args(argv)
    if args.command == "fetch":
        fetch(args.mirror)
        return 0
    compare(args.only or list(SOURCES) + list(BOARDS) + list(BUILT) + list(FOLDERS), args.integrator, args.samples,
            args.reference, *args.size, args.report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
