"""Build the sample .blend files that a student opens first, from scratch, with bpy.

Usage (any Python with Blender's `bpy` module, or Blender itself):
    python sample_scenes/make_scenes.py                 # writes sample_scenes/<name>.blend, all scenes
    python sample_scenes/make_scenes.py --only light_spot camera_ortho --out /tmp/scenes
    blender -b --python sample_scenes/make_scenes.py -- --only light_spot

The committed files were written with Blender 4.2 LTS (`.venv42/bin/python`), the oldest Blender
Primer supports, so that every supported Blender opens them (Blender 5 files do not open in 4.x).
Settings that 4.2 lacks (light exposure, temperature) are skipped there.

The scenes, one idea each:
    light_point, light_point_soft, light_spot, light_sun     one light of each type, Cycles' units
    light_area, light_area_spread                             area lights: rectangle (mirrored), ellipse
    light_emissive                                            an emissive mesh (a ceiling lamp) lights a room
    world_light                                               a sky-blue world lights the stage, with a sun
    world_hdri                                                an HDRI (a sky with a small sun) lights the stage
    shading_flat_smooth                                       the shadow terminator of a 12-segment sphere
    shading_visibility                                        an open smooth sheet: light leaks, negative N.L
    modifiers_instances                                       modifiers, instancing, negative scale, curves
    materials_principled, materials_textures                  Principled BSDFs; materials from node graphs
    cornell_box, materials_glass                              path tracing: light that bounces; glass
    camera_ortho, camera_persp_shift,                         every camera type, with shift and sensor fit
    camera_fisheye_equidistant, camera_fisheye_equisolid      (disk, square and sphere lights light them)

Each renders the same in Primer and in Cycles set up as Primer's reference (direct light only:
max_bounces 0, a 1-pixel box filter, no denoising; tests/test_blender_scenes.py checks it), except
where the lecture chooses differently from Cycles on purpose (shading_visibility: Cycles lets light
leak through the open sheet, like Primer's Visibility Normal: Shading), because:
- materials are pure Lambert: a Diffuse BSDF with roughness 0, or a Principled BSDF with
  Specular IOR Level 0 (Cycles then adds no specular lobe);
- the world is a plain Background colour seen by camera rays only (its diffuse, glossy,
  transmission and scatter ray visibility are off), except in world_light, where it lights the stage;
- lights stay invisible to the camera (Blender's default for light objects);
- Cycles' per-object shadow-terminator geometry offset is 0, matching Primer's default
  (terminator fix off); see `shading_flat_smooth`;
- each scene has one light: Cycles samples one light per path, so several lights would need many
  more samples for a clean reference.
The images are small (160x120 or less) and the files saved compressed.
"""
from __future__ import annotations

import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# Sampling stored in each file: enough for a clean look when a student presses F12.
DEFAULT_PRIMER_SAMPLES = 64
DEFAULT_CYCLES_SAMPLES = 256


# ----------------------------------------------------------------------------
# Building blocks
# ----------------------------------------------------------------------------

def _bpy():
    import bpy
    return bpy


def new_file(name: str, width: int = 160, height: int = 120, light_samples: int = 4,
             world=(0.03, 0.035, 0.045)):
    """Start an empty file and give its scene Primer's and Cycles' reference settings."""
    bpy = _bpy()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.name = name
    render = scene.render
    render.resolution_x, render.resolution_y = width, height
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.film_transparent = False
    render.use_border = False
    # Cycles as Primer's reference, so that switching the engine compares like with like.
    from render import configure_cycles_reference      # tools/render.py (on sys.path, see main)
    configure_cycles_reference(scene, DEFAULT_CYCLES_SAMPLES)
    view = scene.view_settings
    view.view_transform = "Standard"
    view.look = "None"
    view.exposure = 0.0
    view.gamma = 1.0
    # Primer, when it is installed (tools/render.py's load_primer registers it from this checkout).
    if hasattr(scene, "primer"):
        scene.primer.samples = DEFAULT_PRIMER_SAMPLES
        scene.primer.light_samples = light_samples
        render.engine = "PRIMER"
    else:
        render.engine = "CYCLES"
    set_world(scene, world)
    return scene


def set_world(scene, color, strength: float = 1.0, lights: bool = False):
    """A plain Background colour; camera rays see it, and with `lights` it lights surfaces too (as Cycles'
    world does by default); without, only camera rays see it."""
    bpy = _bpy()
    world = bpy.data.worlds.new("World")
    scene.world = world
    if world.node_tree is None:             # Blender 4.x: node trees are opt-in
        world.use_nodes = True
    background = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    world.color = color
    visibility = world.cycles_visibility
    visibility.camera = True
    visibility.diffuse = visibility.glossy = visibility.transmission = visibility.scatter = lights
    return world


def bare_material(name: str, color=None):
    """A new material (viewport colour `color`, if given) whose node tree holds its Material Output alone:
    (material, tree, output)."""
    bpy = _bpy()
    material = bpy.data.materials.new(name)
    if color is not None:
        material.diffuse_color = (*color, 1.0)
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    for node in list(tree.nodes):
        if node.name != output.name:
            tree.nodes.remove(node)
    return material, tree, output


def emission(name: str, color, strength: float, sampling: str = "AUTO"):
    """A material that emits colour x strength (radiance, W / (m^2 sr)) from both sides, and reflects nothing."""
    material, tree, output = bare_material(name, color)
    node = tree.nodes.new("ShaderNodeEmission")
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Strength"].default_value = strength
    tree.links.new(node.outputs["Emission"], output.inputs["Surface"])
    if hasattr(material, "cycles"):
        material.cycles.emission_sampling = sampling
    return material


def diffuse(name: str, color, principled: bool = False):
    """A pure Lambert material: Diffuse BSDF (roughness 0), or Principled BSDF with Specular IOR Level 0."""
    bpy = _bpy()
    material = bpy.data.materials.new(name)
    material.diffuse_color = (*color, 1.0)          # the viewport colour, too
    if material.node_tree is None:          # Blender 4.x: node trees are opt-in
        material.use_nodes = True
    tree = material.node_tree
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    for node in list(tree.nodes):
        if node.name != output.name:
            tree.nodes.remove(node)
    if principled:
        bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.inputs["Base Color"].default_value = (*color, 1.0)
        bsdf.inputs["Specular IOR Level"].default_value = 0.0
        bsdf.inputs["Roughness"].default_value = 0.5
    else:
        bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
        bsdf.inputs["Color"].default_value = (*color, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.0
    bsdf.location = (-300, 0)
    tree.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def principled(name: str, **inputs):
    """A Principled BSDF material with these inputs (socket names with spaces as underscores) and Blender's
    defaults for the rest; `distribution` picks GGX or Multiscatter GGX."""
    bpy = _bpy()
    material = bpy.data.materials.new(name)
    if material.node_tree is None:          # Blender 4.x: node trees are opt-in
        material.use_nodes = True
    tree = material.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    bsdf.distribution = inputs.pop("distribution", "MULTI_GGX")
    for key, value in inputs.items():
        socket = bsdf.inputs[key.replace("_", " ")]
        socket.default_value = (*value, 1.0) if isinstance(value, tuple) and len(value) == 3 else value
    base = bsdf.inputs["Base Color"].default_value
    material.diffuse_color = (base[0], base[1], base[2], 1.0)
    return material


def glossy_mix(name: str, color, roughness: float, glossy_color, factor: float):
    """A Mix Shader of a Diffuse BSDF (colour) and a Multiscatter GGX Glossy BSDF (glossy_color, roughness)."""
    bpy = _bpy()
    material = diffuse(name, color)
    tree = material.node_tree
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    diffuse_node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    glossy = tree.nodes.new("ShaderNodeBsdfAnisotropic" if bpy.app.version >= (4, 0, 0) else "ShaderNodeBsdfGlossy")
    glossy.distribution = "MULTI_GGX"
    glossy.inputs["Color"].default_value = (*glossy_color, 1.0)
    glossy.inputs["Roughness"].default_value = roughness
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = factor
    tree.links.new(diffuse_node.outputs["BSDF"], mix.inputs[1])
    tree.links.new(glossy.outputs["BSDF"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], output.inputs["Surface"])
    return material


def link(obj, collection=None):
    """Put `obj` in `collection` (default: the scene's collection) and return it."""
    bpy = _bpy()
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def _active():
    return _bpy().context.view_layer.objects.active


def finish_object(obj, material=None, smooth=None, name=None, terminator_offset: float = 0.0):
    """Name, material, shading and Cycles' terminator offset of a freshly added object."""
    if name:
        obj.name = name
        if obj.data is not None and obj.data.users == 1:
            obj.data.name = name
    if material is not None:
        obj.data.materials.clear()
        obj.data.materials.append(material)
    if smooth is not None and obj.type == "MESH":
        obj.data.shade_smooth() if smooth else obj.data.shade_flat()
    # Cycles' shadow-terminator geometry offset: on the object since Blender 4.3, in obj.cycles before.
    for owner in (obj, getattr(obj, "cycles", None)):
        if owner is not None and hasattr(owner, "shadow_terminator_geometry_offset"):
            owner.shadow_terminator_geometry_offset = terminator_offset
    return obj


def add_primitive(kind: str, material=None, smooth=None, name=None, location=(0, 0, 0),
                  rotation=(0, 0, 0), scale=(1, 1, 1), **kw):
    """Add a mesh primitive with bpy.ops (kind: 'plane', 'cube', 'uv_sphere', 'cylinder', 'cone', 'monkey', ...)."""
    bpy = _bpy()
    getattr(bpy.ops.mesh, f"primitive_{kind}_add")(location=location, rotation=rotation, **kw)
    obj = _active()
    obj.scale = scale
    return finish_object(obj, material, smooth, name)


def ground(material, size: float = 20.0):
    """A large flat floor at z = 0."""
    return add_primitive("plane", material, False, "Floor", size=size)


def add_camera(location, target, lens: float = 35.0, name: str = "Camera", **data):
    """A camera at `location` looking at `target` (up = +Z); extra keyword arguments set camera data."""
    bpy = _bpy()
    from mathutils import Vector

    camera = bpy.data.objects.new(name, bpy.data.cameras.new(name))
    camera.location = location
    camera.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    camera.data.lens = lens
    camera.data.clip_start = 0.05
    camera.data.clip_end = 200.0
    for key, value in data.items():
        setattr(camera.data, key, value)
    link(camera)
    bpy.context.scene.camera = camera
    return camera


def add_light(kind: str, name: str, location=(0, 0, 0), target=None, rotation=None, scale=(1, 1, 1), **data):
    """A light object of `kind` ('POINT', 'SPOT', 'SUN', 'AREA'); aim it at `target` or give `rotation`."""
    bpy = _bpy()
    from mathutils import Vector

    light = bpy.data.objects.new(name, bpy.data.lights.new(name, kind))
    light.location = location
    if target is not None:
        light.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    elif rotation is not None:
        light.rotation_euler = rotation
    light.scale = scale
    for key, value in data.items():
        if hasattr(light.data, key):        # exposure and temperature exist from Blender 4.3 / 4.4 on
            setattr(light.data, key, value)
    return link(light)


def sun_rotation(elevation_deg: float, azimuth_deg: float):
    """Euler rotation of a sun shining from this elevation and azimuth (its -Z travels towards the ground)."""
    from mathutils import Vector

    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    towards_sun = Vector((math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)))
    return towards_sun.to_track_quat("Z", "Y").to_euler()


def stage(principled_sphere: bool = False):
    """The common set: a grey floor, a smooth red sphere, a flat blue box and a green cylinder."""
    grey = diffuse("Grey", (0.8, 0.8, 0.8))
    red = diffuse("Red", (0.8, 0.15, 0.1), principled=principled_sphere)
    blue = diffuse("Blue", (0.15, 0.3, 0.8))
    green = diffuse("Green", (0.2, 0.7, 0.25), principled=True)
    ground(grey)
    add_primitive("uv_sphere", red, True, "Sphere", location=(0.9, 0.3, 0.8), radius=0.8, segments=32,
                  ring_count=16)
    add_primitive("cube", blue, False, "Box", location=(-1.1, 0.6, 0.5), rotation=(0, 0, math.radians(25)),
                  size=1.0)
    add_primitive("cylinder", green, None, "Cylinder", location=(-0.2, -1.0, 0.35), radius=0.35, depth=0.7,
                  vertices=24)
    return grey


def stage_camera(**data):
    """The camera that looks at the stage from the front and a little above."""
    return add_camera((0.0, -6.5, 3.6), (0.0, 0.2, 0.55), lens=32.0, **data)


# ----------------------------------------------------------------------------
# The scenes
# ----------------------------------------------------------------------------

def light_point():
    """A point light of radius 0: hard shadows, 1/r^2 falloff, colour and exposure in Cycles' units."""
    new_file("light_point")
    stage(principled_sphere=True)
    stage_camera()
    add_light("POINT", "Point", (2.2, -1.6, 3.2), energy=250.0, exposure=0.5, color=(1.0, 0.85, 0.7),
              shadow_soft_size=0.0)


def light_point_soft():
    """A point light of radius 0.5 with Blender's soft falloff: soft shadows, 1/(d^2 + R^2)."""
    new_file("light_point_soft")
    stage()
    stage_camera()
    add_light("POINT", "Soft Point", (2.0, -1.4, 2.6), energy=280.0, shadow_soft_size=0.5,
              use_soft_falloff=True, color=(1.0, 0.9, 0.8))


def light_spot():
    """A spot light: cone size and blend, an elliptical cone from non-uniform scale, a radius."""
    new_file("light_spot")
    stage()
    stage_camera()
    add_light("SPOT", "Spot", (1.8, -2.4, 3.6), target=(0.0, 0.4, 0.4), scale=(1.6, 1.0, 1.0), energy=700.0,
              spot_size=math.radians(40.0), spot_blend=0.5, shadow_soft_size=0.1)


def light_sun():
    """A sun with a 6-degree disk: parallel light of `strength` W/m^2 and soft shadows."""
    new_file("light_sun")
    stage()
    stage_camera()
    add_light("SUN", "Sun", rotation=sun_rotation(40.0, -30.0), energy=3.0, angle=math.radians(6.0),
              color=(1.0, 0.95, 0.85))


def light_area():
    """A rectangular area light, stretched and mirrored by its object scale: one-sided, radiance P / (pi A)."""
    new_file("light_area", light_samples=8)
    stage()
    stage_camera()
    add_light("AREA", "Rectangle", (1.8, -2.0, 2.6), target=(0.0, 0.3, 0.5), scale=(-1.5, 0.8, 1.0),
              energy=60.0, shape="RECTANGLE", size=1.0, size_y=0.4, color=(1.0, 0.9, 0.75))


def light_area_spread():
    """An elliptical area light with a 90-degree spread: a soft-edged pool of light."""
    new_file("light_area_spread", light_samples=8)
    stage()
    stage_camera()
    add_light("AREA", "Ellipse", (-0.6, -1.5, 3.0), target=(-0.2, 0.3, 0.3), energy=60.0, shape="ELLIPSE",
              size=1.2, size_y=0.6, spread=math.radians(90.0), color=(0.8, 0.9, 1.0))


def shading_flat_smooth():
    """The shadow terminator: a 12-segment sphere flat and smooth, sharp edges, custom normals.

    Every object here has Cycles' Shadow Terminator > Geometry Offset at 0, like Primer with its
    terminator fix off (the default), so the faceted terminator shows in both. To compare the two
    fixes, set the offset to 0.1 (Cycles' default) and turn on Primer's Shadow Terminator Fix.
    """
    new_file("shading_flat_smooth")
    grey = diffuse("Grey", (0.8, 0.8, 0.8))
    white = diffuse("White", (0.75, 0.75, 0.7))
    orange = diffuse("Orange", (0.85, 0.4, 0.1), principled=True)
    ground(grey)
    add_primitive("uv_sphere", white, False, "Flat Sphere", location=(-1.3, 0.0, 1.0), radius=1.0, segments=12,
                  ring_count=6)
    add_primitive("uv_sphere", white, True, "Smooth Sphere", location=(1.3, 0.0, 1.0), radius=1.0, segments=12,
                  ring_count=6)
    # Smooth by angle: faces are smooth, but edges sharper than 30 degrees stay sharp (split normals).
    bpy = _bpy()
    cylinder = add_primitive("cylinder", orange, True, "Smooth By Angle", location=(-0.6, -1.9, 0.4),
                             radius=0.4, depth=0.8, vertices=10)
    bpy.ops.object.select_all(action="DESELECT")
    cylinder.select_set(True)
    bpy.context.view_layer.objects.active = cylinder
    bpy.ops.object.shade_smooth_by_angle(angle=math.radians(30.0))
    # Custom normals: a flat box whose normals point away from its centre, like a sphere's.
    box = add_primitive("cube", orange, True, "Custom Normals", location=(0.9, -1.9, 0.25), size=0.5)
    normals = [tuple(c / vertex.co.length for c in vertex.co) for vertex in box.data.vertices]
    box.data.normals_split_custom_set_from_vertices(normals)
    add_camera((0.0, -7.5, 3.2), (0.0, 0.2, 0.55), lens=32.0)
    add_light("SUN", "Low Sun", rotation=sun_rotation(20.0, -25.0), energy=3.0, angle=0.0)


# The sheet of `shading_visibility`: its profile in the XZ plane, one (slope, length) per face from
# left to right (slope in degrees, rising to the right > 0), extruded along Y.
SHEET_START = (-1.1, 0.0)          # the profile's first point (x, z): on the floor
SHEET_FACES = ((85.0, 0.55), (30.0, 1.0), (-30.0, 0.8), (50.0, 1.0))
SHEET_DEPTH = 2.0                  # along Y, centred on y = 0
SHEET_SUN_ELEVATION = 40.0         # the sun shines from +X (azimuth 0), across the profile


def sheet_profile(start=SHEET_START, faces=SHEET_FACES):
    """The points (x, z) of a polyline that starts at `start` and follows (slope in degrees, length) per face."""
    x, z = start
    points = [(x, z)]
    for slope, length in faces:
        x += length * math.cos(math.radians(slope))
        z += length * math.sin(math.radians(slope))
        points.append((x, z))
    return points


def add_profile_sheet(name: str, points, depth: float, material):
    """An open smooth sheet: the polyline `points` (x, z) extruded from y = -depth/2 to +depth/2, one quad per segment."""
    bpy = _bpy()
    vertices = [(x, y, z) for y in (-0.5 * depth, 0.5 * depth) for x, z in points]
    n = len(points)
    quads = [(i, i + 1, n + i + 1, n + i) for i in range(n - 1)]      # counter-clockwise seen from above: Ng up
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], quads)
    mesh.update()
    return finish_object(link(bpy.data.objects.new(name, mesh)), material, True, name)


def shading_visibility():
    """An open, smooth, low-poly sheet under a sun: where the interpolated normal N and the face normal Ng disagree.

    Each interior vertex normal is the mean of its two faces' normals, so N turns across a face from
    one vertex normal to the next. The sun (40 degrees high, from +X) meets the sheet's faces thus:
    - the 30-degree face still faces it (Ng.L > 0), but N leans away from it near the steep 85-degree
      face: N.L < 0 there. Clamp N.L off, and that light turns negative;
    - the last, 50-degree face turns away from it (Ng.L < 0), but N leans towards it near the valley:
      N.L > 0 there. Visibility Normal: Shading, and light leaks onto it through the sheet, because
      the sheet is open: nothing lies on its underside to block the shadow ray.
    With the lecture's defaults both show what Cycles shows: black.
    """
    new_file("shading_visibility")
    grey = diffuse("Grey", (0.8, 0.8, 0.8))
    sheet = diffuse("Sheet", (0.85, 0.6, 0.3))
    ground(grey)
    add_profile_sheet("Sheet", sheet_profile(), SHEET_DEPTH, sheet)
    add_camera((-2.0, -4.2, 3.0), (0.0, 0.0, 0.6), lens=32.0)
    add_light("SUN", "Sun", rotation=sun_rotation(SHEET_SUN_ELEVATION, 0.0), energy=3.0, angle=0.0)


def modifiers_instances():
    """Modifiers (subdivision, array, mirror), linked duplicates, a collection instance, geometry-nodes
    instances, a negatively scaled object, a text, a bevelled curve and a metaball."""
    bpy = _bpy()
    new_file("modifiers_instances")
    grey = diffuse("Grey", (0.8, 0.8, 0.8))
    red = diffuse("Red", (0.8, 0.15, 0.1))
    blue = diffuse("Blue", (0.15, 0.3, 0.8), principled=True)
    yellow = diffuse("Yellow", (0.85, 0.7, 0.15))
    ground(grey)
    # Back row. Subdivision surface on a cube: a smooth blob from 6 faces.
    blob = add_primitive("cube", red, True, "Subdivided Cube", location=(-2.1, 1.6, 0.5), size=0.9)
    subsurf = blob.modifiers.new("Subdivision", "SUBSURF")
    subsurf.levels = subsurf.render_levels = 2
    # An array of 4 small boxes along X, doubled by a mirror modifier across an empty's XZ plane.
    bar = add_primitive("cube", blue, False, "Array Mirror", location=(0.1, 2.7, 0.12), size=0.24)
    array = bar.modifiers.new("Array", "ARRAY")
    array.count = 4
    array.relative_offset_displace = (1.7, 0.0, 0.0)
    mirror_centre = link(bpy.data.objects.new("Mirror Centre", None))
    mirror_centre.location = (0.0, 2.35, 0.0)
    mirror = bar.modifiers.new("Mirror", "MIRROR")
    mirror.use_axis = (False, True, False)
    mirror.mirror_object = mirror_centre
    # Linked duplicates: three objects share one smooth cone mesh.
    cone = add_primitive("cone", yellow, True, "Cone", location=(1.5, 1.5, 0.4), radius1=0.3, depth=0.8,
                         vertices=16)
    for i, (x, y) in enumerate(((2.2, 1.2), (1.9, 0.6))):
        twin = cone.copy()                      # shares cone.data
        twin.name = f"Cone Twin {i + 1}"
        twin.location = (x, y, 0.4)
        twin.rotation_euler = (0.0, 0.0, 0.7 * (i + 1))
        link(twin)
    # Middle row. A collection instance: two empties instance one hidden collection (sphere and box).
    group = bpy.data.collections.new("Props")
    bpy.context.scene.collection.children.link(group)
    prop_sphere = add_primitive("uv_sphere", red, True, "Prop Sphere", location=(0, 0, 0.22), radius=0.22,
                                segments=16, ring_count=8)
    prop_box = add_primitive("cube", blue, False, "Prop Box", location=(0.4, 0, 0.13), size=0.26)
    for obj in (prop_sphere, prop_box):
        bpy.context.scene.collection.objects.unlink(obj)
        group.objects.link(obj)
    bpy.context.view_layer.layer_collection.children[group.name].exclude = True
    for i, (x, y, angle) in enumerate(((-2.6, 0.1, 0.3), (-2.0, -0.6, 1.4))):
        empty = link(bpy.data.objects.new(f"Props Instance {i + 1}", None))
        empty.instance_type = "COLLECTION"
        empty.instance_collection = group
        empty.location = (x, y, 0.0)
        empty.rotation_euler = (0.0, 0.0, angle)
    # Negative scale: a smooth monkey mirrored in X (its normals and winding must stay outward).
    add_primitive("monkey", blue, True, "Mirrored Monkey", location=(-0.2, 0.3, 0.55),
                  rotation=(0.0, 0.0, math.radians(-25.0)), scale=(-0.55, 0.55, 0.55))
    # Geometry-nodes instances: icospheres on the vertices of a grid, randomly turned and scaled.
    grid = add_primitive("grid", grey, False, "GN Instances", location=(1.5, -0.4, 0.1), x_subdivisions=3,
                         y_subdivisions=3, size=1.1)
    _instance_on_points(grid, yellow)
    # Front row. A text and a bevelled Bezier circle: curves reach renderers as meshes.
    text_data = bpy.data.curves.new("Text", "FONT")
    text_data.body = "Primer"
    text_data.size = 0.5
    text_data.extrude = 0.05
    text_data.align_x = "CENTER"
    text_data.materials.append(red)
    text = finish_object(link(bpy.data.objects.new("Text", text_data)))
    text.location = (-0.6, -1.5, 0.0)
    text.rotation_euler = (math.radians(60.0), 0.0, 0.0)
    bpy.ops.curve.primitive_bezier_circle_add(radius=0.3, location=(1.0, -1.6, 0.4),
                                              rotation=(math.radians(75.0), 0.0, math.radians(20.0)))
    ring = finish_object(_active(), yellow, None, "Bevelled Curve")
    ring.data.bevel_depth = 0.07
    ring.data.bevel_resolution = 3
    # A metaball of two balls: Blender meshes it for rendering.
    meta_data = bpy.data.metaballs.new("Metaball")
    meta_data.render_resolution = 0.05
    meta_data.resolution = 0.1
    for x in (-0.2, 0.2):
        element = meta_data.elements.new()
        element.co = (x, 0.0, 0.0)
        element.radius = 0.35
    meta_data.materials.append(grey)
    meta = finish_object(link(bpy.data.objects.new("Metaball", meta_data)))
    meta.location = (2.3, -1.2, 0.35)
    add_camera((0.0, -5.8, 2.6), (0.0, 0.3, 0.4), lens=30.0)
    add_light("SUN", "Sun", rotation=sun_rotation(50.0, -125.0), energy=2.5, angle=0.0)


def _instance_on_points(obj, material):
    """Give `obj` a geometry-nodes modifier: an icosphere instanced on each of its vertices, randomly turned."""
    bpy = _bpy()
    tree = bpy.data.node_groups.new("Instance On Points", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    group_in = nodes.new("NodeGroupInput")
    group_out = nodes.new("NodeGroupOutput")
    ico = nodes.new("GeometryNodeMeshIcoSphere")
    ico.inputs["Radius"].default_value = 0.13
    ico.inputs["Subdivisions"].default_value = 1
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = material
    instance = nodes.new("GeometryNodeInstanceOnPoints")
    rotation = nodes.new("FunctionNodeRandomValue")
    rotation.data_type = "FLOAT_VECTOR"
    rotation.inputs["Max"].default_value = (3.0, 3.0, 3.0)
    scale = nodes.new("FunctionNodeRandomValue")
    scale.data_type = "FLOAT"
    scale.inputs[2].default_value = 0.7        # Min (float)
    scale.inputs[3].default_value = 1.3        # Max (float)
    links.new(group_in.outputs["Geometry"], instance.inputs["Points"])
    links.new(ico.outputs["Mesh"], set_material.inputs["Geometry"])
    links.new(set_material.outputs["Geometry"], instance.inputs["Instance"])
    links.new(rotation.outputs["Value"], instance.inputs["Rotation"])
    links.new(scale.outputs[1], instance.inputs["Scale"])
    links.new(instance.outputs["Instances"], group_out.inputs["Geometry"])
    modifier = obj.modifiers.new("Instances", "NODES")
    modifier.node_group = tree
    return modifier


def light_emissive():
    """A room lit by its ceiling: an emissive quad (a mesh, not a lamp) over a floor, walls and the stage.

    Emissive meshes are lights: sampled by power, found by BSDF rays too, the two weighed by MIS."""
    new_file("light_emissive", light_samples=4, world=(0.0, 0.0, 0.0))
    grey = stage()
    white = diffuse("White Wall", (0.75, 0.75, 0.72))
    add_primitive("plane", white, False, "Back Wall", location=(0.0, 2.2, 2.0),
                  rotation=(math.radians(90), 0, 0), size=6.0)
    add_primitive("plane", diffuse("Red Wall", (0.7, 0.12, 0.1)), False, "Left Wall", location=(-2.8, 0.0, 2.0),
                  rotation=(0, math.radians(90), 0), size=6.0)
    lamp = emission("Ceiling Lamp", (1.0, 0.92, 0.8), 12.0, sampling="FRONT")
    add_primitive("plane", lamp, False, "Ceiling Lamp", location=(0.0, 0.2, 3.4), rotation=(math.radians(180), 0, 0),
                  size=1.4)
    del grey
    stage_camera()


def world_light():
    """The stage under a sky-blue world that lights it (Ray Visibility > Diffuse on), plus a low sun.

    A constant world is found by BSDF-sampled rays, as in Cycles: a Lambert plane of albedo rho under a
    world of radiance L shows rho L."""
    new_file("world_light", light_samples=2)
    set_world(bpy_scene(), (0.35, 0.45, 0.6), lights=True)
    stage()
    stage_camera()
    add_light("SUN", "Sun", rotation=sun_rotation(25.0, -40.0), energy=1.5, angle=math.radians(3.0),
              color=(1.0, 0.9, 0.75))


def sky_pixels(width: int = 128, height: int = 64) -> list:
    """An equirectangular sky made here, RGBA rows bottom first (radiance, W / (m^2 sr)): a blue gradient over a
    brown ground and a sun 12 degrees wide, 40 degrees up, about 100 times brighter than the sky (the soft
    shadows that light sampling by the image's brightness must find)."""
    rows = []
    for j in range(height):
        elevation = (j + 0.5) / height * math.pi - math.pi / 2.0
        row = []
        for i in range(width):
            azimuth = (i + 0.5) / width * 2.0 * math.pi
            if elevation > 0.0:
                k = 0.35 + 0.65 * (1.0 - math.sin(elevation))
                color = (0.25 * k, 0.35 * k, 0.6 * k)
            else:
                color = (0.12, 0.1, 0.08)
            if abs(elevation - math.radians(40.0)) < math.radians(6.0) and abs(azimuth - math.radians(110.0)) < math.radians(6.0):
                color = (40.0, 35.0, 28.0)
            row.append((*color, 1.0))
        rows.append(row)
    return rows


def world_hdri():
    """The stage lit by an HDRI alone: an Environment Texture of a sky made here (packed, float), turned by a
    Mapping node, strength 1.5. The world is a light with a varying image: importance-sampled by brightness
    x sin(theta) and found by BSDF rays, the two weighed by MIS, as in Cycles."""
    bpy = _bpy()
    new_file("world_hdri", light_samples=4)
    world = set_world(bpy_scene(), (0.3, 0.4, 0.6), lights=True)
    pixels = sky_pixels()
    image = bpy.data.images.new("Sky", len(pixels[0]), len(pixels), alpha=True, float_buffer=True)
    image.pixels.foreach_set([channel for row in pixels for texel in row for channel in texel])
    image.filepath_raw = "//Sky.exr"
    image.file_format = "OPEN_EXR"
    image.pack()
    tree = world.node_tree
    background = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Strength"].default_value = 1.5
    texture = tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(30.0))
    tree.links.new(coordinates.outputs["Generated"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    tree.links.new(texture.outputs["Color"], background.inputs["Color"])
    stage()
    stage_camera()


def materials_principled():
    """Principled BSDFs as Cycles lays them out: a rough dielectric, a gold metal with a specular tint, a
    polished clear-coated red, a tinted translucent (alpha) blue, Glossy mixed with Diffuse, and a sphere
    without material (Cycles' default surface), under a soft area light, a point light and a dim world."""
    new_file("materials_principled", 192, 96, light_samples=4)
    set_world(bpy_scene(), (0.05, 0.06, 0.08), lights=True)
    ground(diffuse("Grey", (0.6, 0.6, 0.6)))
    looks = [principled("Plastic", Base_Color=(0.1, 0.35, 0.8), Roughness=0.4),
             principled("Gold", Base_Color=(1.0, 0.77, 0.34), Metallic=1.0, Roughness=0.3,
                        Specular_Tint=(1.0, 0.85, 0.7)),
             principled("Coated", Base_Color=(0.7, 0.06, 0.05), Roughness=0.6, Coat_Weight=1.0,
                        Coat_Roughness=0.05, Specular_IOR_Level=0.7),
             principled("Glassy Alpha", Base_Color=(0.2, 0.6, 0.9), Roughness=0.2, Alpha=0.6),
             glossy_mix("Glossy Mix", (0.7, 0.65, 0.5), 0.25, (0.9, 0.9, 0.9), 0.4),
             None]
    for i, material in enumerate(looks):
        add_primitive("uv_sphere", material, True, f"Sphere {i}", location=(-2.75 + 1.1 * i, 0.0, 0.5), radius=0.5,
                      segments=32, ring_count=16)
    add_camera((0.0, -5.2, 1.9), (0.0, 0.0, 0.45), lens=35.0)
    add_light("AREA", "Softbox", (-1.5, -2.5, 3.0), target=(0.0, 0.0, 0.5), energy=350.0, shape="RECTANGLE",
              size=1.5, size_y=0.8)
    add_light("POINT", "Point", (2.5, -1.0, 2.5), energy=150.0, shadow_soft_size=0.0, color=(1.0, 0.9, 0.8))


def cornell_box():
    """The Cornell box, the standard test of light that bounces: white, red and green walls, two white
    boxes, lit only by an emissive quad under the ceiling (dimensions after the Cornell data, in dm).
    Rendered by path tracing with Cycles' default bounce limits (12 in all, 4 diffuse, 4 glossy)."""
    bpy = _bpy()
    new_file("cornell_box", 128, 128, light_samples=1, world=(0.0, 0.0, 0.0))
    scene = bpy_scene()
    if hasattr(scene, "primer"):
        scene.primer.integrator = "PATH"
        scene.primer.max_bounces, scene.primer.diffuse_bounces, scene.primer.glossy_bounces = 12, 4, 4
    configure = __import__("render").configure_cycles_reference
    configure(scene, DEFAULT_CYCLES_SAMPLES)               # Cycles follows Primer's bounce limits
    scene.render.engine = "PRIMER" if hasattr(scene, "primer") else "CYCLES"
    white = diffuse("Cornell White", (0.725, 0.71, 0.68))
    red = diffuse("Cornell Red", (0.63, 0.065, 0.05))
    green = diffuse("Cornell Green", (0.14, 0.45, 0.091))
    w, d, h = 5.56, 5.59, 5.48
    walls = [("Floor", white, (w / 2, d / 2, 0.0), (0, 0, 0), (w, d)),
             ("Ceiling", white, (w / 2, d / 2, h), (math.pi, 0, 0), (w, d)),
             ("Back Wall", white, (w / 2, d, h / 2), (math.radians(90), 0, 0), (w, h)),
             ("Red Wall", red, (0.0, d / 2, h / 2), (0, math.radians(90), 0), (h, d)),
             ("Green Wall", green, (w, d / 2, h / 2), (0, math.radians(-90), 0), (h, d))]
    for name, material, location, rotation, (sx, sy) in walls:
        obj = add_primitive("plane", material, False, name, location=location, rotation=rotation, size=1.0)
        obj.scale = (sx, sy, 1.0)
    add_primitive("cube", white, False, "Short Box", location=(1.855, 1.69, 0.825),
                  rotation=(0, 0, math.radians(-17)), size=1.65)
    tall = add_primitive("cube", white, False, "Tall Box", location=(3.685, 3.515, 1.65),
                         rotation=(0, 0, math.radians(17)), size=1.65)
    tall.scale = (1.0, 1.0, 2.0)
    lamp = emission("Cornell Lamp", (1.0, 0.706, 0.235), 17.0, sampling="FRONT")
    add_primitive("plane", lamp, False, "Lamp", location=(w / 2, d / 2, h - 0.01), rotation=(math.pi, 0, 0),
                  size=1.0).scale = (1.3, 1.05, 1.0)
    add_camera((w / 2, -8.0, h / 2), (w / 2, 0.0, h / 2), lens=33.6, sensor_fit="VERTICAL", sensor_height=24.0)


def glass_node(name: str, kind: str, color, roughness: float, ior: float, distribution: str):
    """A material of one Glass BSDF or Refraction BSDF (kind "Glass" or "Refraction") with these inputs."""
    bpy = _bpy()
    material = bpy.data.materials.new(name)
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new(f"ShaderNodeBsdf{kind}")
    bsdf.distribution = distribution
    bsdf.inputs["Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["IOR"].default_value = ior
    tree.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def materials_glass():
    """Glass in front of coloured stripes, by path tracing: a smooth Glass BSDF, a frosted one (roughness
    0.35, Multiscatter GGX), a rough Principled transmission and a rough tinted Refraction BSDF, under a
    softbox and a dim world. Light reaches the stripes through the glass and the floor in the glass's
    caustics, as Cycles renders them with its default bounce limits."""
    new_file("materials_glass", 160, 96, light_samples=1)
    scene = bpy_scene()
    if hasattr(scene, "primer"):
        scene.primer.integrator = "PATH"
        scene.primer.max_bounces, scene.primer.diffuse_bounces, scene.primer.glossy_bounces = 12, 4, 4
    __import__("render").configure_cycles_reference(scene, DEFAULT_CYCLES_SAMPLES)   # Cycles follows the limits
    scene.render.engine = "PRIMER" if hasattr(scene, "primer") else "CYCLES"
    set_world(scene, (0.08, 0.09, 0.1), lights=True)
    ground(diffuse("Grey", (0.6, 0.6, 0.6)))
    for i, color in enumerate([(0.8, 0.15, 0.1), (0.9, 0.8, 0.2), (0.15, 0.5, 0.2), (0.1, 0.25, 0.7)]):
        add_primitive("cube", diffuse(f"Stripe {i}", color), False, f"Stripe {i}", location=(-2.1 + 1.4 * i, 1.6, 0.9),
                      size=1.0).scale = (1.4, 0.2, 1.8)
    looks = [glass_node("Clear Glass", "Glass", (1.0, 1.0, 1.0), 0.0, 1.45, "MULTI_GGX"),
             glass_node("Frosted Glass", "Glass", (0.95, 0.97, 1.0), 0.35, 1.45, "MULTI_GGX"),
             principled("Principled Glass", Base_Color=(0.9, 0.95, 1.0), Roughness=0.2, Transmission_Weight=1.0,
                        IOR=1.5),
             glass_node("Rough Refraction", "Refraction", (0.8, 0.9, 1.0), 0.15, 1.33, "GGX")]
    for i, material in enumerate(looks):
        add_primitive("uv_sphere", material, True, f"Sphere {i}", location=(-2.1 + 1.4 * i, 0.0, 0.6), radius=0.6,
                      segments=48, ring_count=24)
    add_camera((0.0, -5.6, 1.7), (0.0, 0.4, 0.6), lens=35.0)
    add_light("AREA", "Softbox", (-1.0, -2.0, 3.5), target=(0.0, 0.3, 0.5), energy=150.0, shape="RECTANGLE",
              size=2.5, size_y=1.5)


def packed_image(name: str, pixels, color_space: str):
    """An image made here from RGBA rows (h, w, 4) floats in 0..1, bottom row first, saved as PNG bytes
    inside the .blend (packed), in the colour space `color_space` ("sRGB" or "Non-Color")."""
    bpy = _bpy()
    height, width = len(pixels), len(pixels[0])
    image = bpy.data.images.new(name, width, height, alpha=True)
    image.colorspace_settings.name = color_space
    image.pixels.foreach_set([channel for row in pixels for texel in row for channel in texel])
    image.filepath_raw = f"//{name}.png"
    image.file_format = "PNG"
    image.pack()
    return image


def _texture_nodes(material):
    """The material's node tree, its output and its BSDF (Principled or Diffuse)."""
    tree = material.node_tree
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    bsdf = next(n for n in tree.nodes if n.bl_idname in ("ShaderNodeBsdfPrincipled", "ShaderNodeBsdfDiffuse"))
    return tree, output, bsdf


def materials_textures():
    """Materials fed by node graphs: a floor whose Principled base colour is a packed sRGB checker image
    repeated by a Mapping node, its roughness from a Math node; a sphere with a packed tangent-space normal
    map (Non-Color); a sphere coloured by its vertex colours through a Multiply Mix; a sphere mixing Diffuse
    and Glossy by a Color Ramp of its generated height, hue shifted; under one sun."""
    new_file("materials_textures", 160, 96, light_samples=4)
    n = 64
    checker = [[(0.9, 0.75, 0.2, 1.0) if ((i // 8) + (j // 8)) % 2 else (0.15, 0.3, 0.6, 1.0) for j in range(n)]
               for i in range(n)]
    bumps = []
    for i in range(n):
        row = []
        for j in range(n):
            # A field of round bumps: the normal of h = 0.08 (cos 2 pi 4x + cos 2 pi 4y).
            x, y = (j + 0.5) / n, (i + 0.5) / n
            dx = -0.08 * 2 * math.pi * 4 * math.sin(2 * math.pi * 4 * x)
            dy = -0.08 * 2 * math.pi * 4 * math.sin(2 * math.pi * 4 * y)
            length = math.sqrt(dx * dx + dy * dy + 1.0)
            row.append((0.5 - 0.5 * dx / length, 0.5 - 0.5 * dy / length, 0.5 + 0.5 / length, 1.0))
        bumps.append(row)
    checker_image = packed_image("Checker", checker, "sRGB")
    normal_image = packed_image("Bumps", bumps, "Non-Color")
    # The floor: base colour = checker(mapping(UV) x 3), roughness = 0.3 + 0.4 x checker's red.
    floor = principled("Checker Floor", Roughness=0.5)
    tree, _, bsdf = _texture_nodes(floor)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (3.0, 3.0, 1.0)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(15.0))
    image = tree.nodes.new("ShaderNodeTexImage")
    image.image = checker_image
    image.interpolation = "Closest"
    roughness = tree.nodes.new("ShaderNodeMath")
    roughness.operation = "MULTIPLY_ADD"
    roughness.inputs[1].default_value, roughness.inputs[2].default_value = 0.4, 0.3
    separate = tree.nodes.new("ShaderNodeSeparateColor")
    tree.links.new(coords.outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], image.inputs["Vector"])
    tree.links.new(image.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(image.outputs["Color"], separate.inputs["Color"])
    tree.links.new(separate.outputs["Red"], roughness.inputs[0])
    tree.links.new(roughness.outputs["Value"], bsdf.inputs["Roughness"])
    add_primitive("plane", floor, False, "Floor", size=6.0)
    # Normal-mapped sphere.
    mapped = principled("Normal Mapped", Base_Color=(0.8, 0.8, 0.8), Roughness=0.45)
    tree, _, bsdf = _texture_nodes(mapped)
    image = tree.nodes.new("ShaderNodeTexImage")
    image.image = normal_image
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(image.outputs["Color"], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    add_primitive("uv_sphere", mapped, True, "Mapped Sphere", location=(-1.6, 0.3, 0.6), radius=0.6, segments=48,
                  ring_count=24)
    # Vertex-coloured sphere: Diffuse colour = vertex colours x a warm tint (Mix, Multiply).
    painted = diffuse("Vertex Colours", (0.8, 0.8, 0.8))
    tree, _, bsdf = _texture_nodes(painted)
    attribute = tree.nodes.new("ShaderNodeVertexColor")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    mix.inputs["Factor"].default_value = 0.8
    mix.inputs[7].default_value = (1.0, 0.85, 0.7, 1.0)
    tree.links.new(attribute.outputs["Color"], mix.inputs[6])
    tree.links.new(mix.outputs[2], bsdf.inputs["Color"])
    sphere = add_primitive("uv_sphere", painted, True, "Painted Sphere", location=(0.0, 0.6, 0.6), radius=0.6,
                           segments=32, ring_count=16)
    colors = sphere.data.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    values = []
    for vertex in sphere.data.vertices:
        x, y, z = vertex.co
        values += [0.5 + 0.5 * x / 0.6, 0.5 + 0.5 * y / 0.6, 0.5 + 0.5 * z / 0.6, 1.0]
    colors.data.foreach_set("color", values)
    sphere.data.color_attributes.active_color = colors
    # Diffuse and Glossy mixed by a Color Ramp of the generated height, through a group; hue shifted.
    mixed = glossy_mix("Ramp Mix", (0.2, 0.5, 0.3), 0.3, (0.9, 0.9, 0.9), 0.5)
    tree = mixed.node_tree
    mix_shader = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeMixShader")
    diffuse_node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    group = bpy_data().node_groups.new("Height Ramp", "ShaderNodeTree")
    if hasattr(group, "interface"):
        group.interface.new_socket("Vector", in_out="INPUT", socket_type="NodeSocketVector")
        group.interface.new_socket("Fac", in_out="OUTPUT", socket_type="NodeSocketFloat")
    else:                                   # (before Blender 4.0)
        group.inputs.new("NodeSocketVector", "Vector")
        group.outputs.new("NodeSocketFloat", "Fac")
    group_in, group_out = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    split = group.nodes.new("ShaderNodeSeparateXYZ")
    ramp = group.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position, ramp.color_ramp.elements[1].position = 0.3, 0.7
    group.links.new(group_in.outputs[0], split.inputs["Vector"])
    group.links.new(split.outputs["Z"], ramp.inputs["Fac"])
    group.links.new(ramp.outputs["Color"], group_out.inputs[0])
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Generated"], node.inputs[0])
    tree.links.new(node.outputs[0], mix_shader.inputs["Fac"])
    hue = tree.nodes.new("ShaderNodeHueSaturation")
    hue.inputs["Hue"].default_value, hue.inputs["Color"].default_value = 0.6, (0.2, 0.5, 0.3, 1.0)
    tree.links.new(hue.outputs["Color"], diffuse_node.inputs["Color"])
    add_primitive("uv_sphere", mixed, True, "Ramp Sphere", location=(1.6, 0.3, 0.6), radius=0.6, segments=32,
                  ring_count=16)
    add_camera((0.0, -5.0, 2.6), (0.0, 0.3, 0.4), lens=35.0)
    add_light("SUN", "Sun", rotation=sun_rotation(50.0, -120.0), energy=3.0, angle=0.0)


def bpy_data():
    """Blender's data."""
    return _bpy().data


def bpy_scene():
    """The current scene."""
    return _bpy().context.scene


def camera_ortho():
    """An orthographic camera with shift and a vertical sensor fit on a wide image, under a disk light."""
    new_file("camera_ortho", 160, 96, light_samples=8)
    stage()
    add_camera((4.5, -6.0, 5.0), (0.0, 0.2, 0.4), type="ORTHO", ortho_scale=3.6, sensor_fit="VERTICAL",
               shift_x=0.12, shift_y=-0.06)
    add_light("AREA", "Disk", (-1.5, -2.0, 3.0), target=(0.0, 0.2, 0.3), energy=80.0, shape="DISK", size=1.2,
              size_y=0.1)      # size_y is ignored by disks


def camera_persp_shift():
    """A perspective camera with lens shift and a vertical sensor fit on a portrait image, under a square light."""
    new_file("camera_persp_shift", 96, 128, light_samples=8)
    stage()
    add_camera((0.5, -6.0, 2.2), (0.0, 0.2, 0.9), lens=40.0, sensor_fit="VERTICAL", sensor_height=30.0,
               shift_x=-0.08, shift_y=0.15)
    add_light("AREA", "Square", (2.0, -2.5, 2.5), target=(0.3, 0.2, 0.5), energy=70.0, shape="SQUARE", size=0.8,
              size_y=3.0)      # size_y is ignored by squares


def camera_fisheye_equidistant():
    """A 180-degree equidistant fisheye (the lens circle touches the frame), slightly shifted."""
    new_file("camera_fisheye_equidistant", 128, 96)
    stage()
    add_camera((0.0, -3.2, 1.4), (0.0, 0.2, 0.6), type="PANO", panorama_type="FISHEYE_EQUIDISTANT",
               fisheye_fov=math.radians(180.0), shift_x=0.05)
    add_light("SUN", "Sun", rotation=sun_rotation(45.0, -60.0), energy=2.5, angle=0.0)


def camera_fisheye_equisolid():
    """An equisolid fisheye (8 mm lens, 24 mm-high sensor, vertical fit, shifted) on a wide image, under a sphere light."""
    new_file("camera_fisheye_equisolid", 128, 96)
    stage()
    add_camera((0.0, -3.2, 1.4), (0.0, 0.2, 0.6), type="PANO", panorama_type="FISHEYE_EQUISOLID",
               fisheye_lens=8.0, fisheye_fov=math.radians(170.0), sensor_fit="VERTICAL", sensor_height=24.0,
               shift_y=0.04)
    add_light("POINT", "Sphere Light", (-1.8, -2.0, 2.4), energy=250.0, shadow_soft_size=0.3,
              use_soft_falloff=False, use_temperature=True, temperature=4500.0)


def volume_material(name: str, build):
    """A material with no surface whose Volume output is what `build(tree)` returns (an output socket)."""
    material, tree, output = bare_material(name)
    tree.links.new(build(tree), output.inputs["Volume"])
    return material


def fog(tree):
    """Homogeneous fog: a Volume Scatter of density 0.15, forward-scattering (anisotropy 0.4)."""
    node = tree.nodes.new("ShaderNodeVolumeScatter")
    node.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    node.inputs["Density"].default_value = 0.15
    node.inputs["Anisotropy"].default_value = 0.4
    return node.outputs["Volume"]


def smoke(tree):
    """A heterogeneous smoke: a Principled Volume whose density is 4 x (a Noise texture's Fac - 0.45), clamped."""
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.5
    noise.inputs["Detail"].default_value = 3.0
    density = tree.nodes.new("ShaderNodeMath")
    density.operation, density.use_clamp = "MULTIPLY_ADD", False
    density.inputs[1].default_value, density.inputs[2].default_value = 6.0, -2.7
    tree.links.new(noise.outputs["Fac"], density.inputs[0])
    positive = tree.nodes.new("ShaderNodeMath")
    positive.operation = "MAXIMUM"
    positive.inputs[1].default_value = 0.0
    tree.links.new(density.outputs["Value"], positive.inputs[0])
    node = tree.nodes.new("ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.7, 0.75, 0.8, 1.0)
    tree.links.new(positive.outputs["Value"], node.inputs["Density"])
    return node.outputs["Volume"]


def volume_fog():
    """Media: the stage inside a box of homogeneous fog, lit by a spot whose cone shows as a shaft of light, and a
    ball of heterogeneous smoke (a Noise texture's density) beside the sphere, under a dim world that lights
    nothing; single scattering in direct light (the phase function and transmittance along shadow rays)."""
    new_file("volume_fog", light_samples=4)
    stage()
    stage_camera()
    add_primitive("cube", volume_material("Fog", fog), False, "Fog Box", location=(0.0, 0.2, 1.2),
                  scale=(5.0, 4.0, 2.6), size=1.0)         # (its floor 0.1 under the stage's: no coplanar faces)
    add_primitive("ico_sphere", volume_material("Smoke", smoke), False, "Smoke", location=(-1.3, -0.6, 0.9),
                  radius=0.55, subdivisions=3)
    add_light("SPOT", "Spot", (1.2, -0.8, 2.4), target=(0.3, 0.4, 0.0), energy=400.0, spot_size=math.radians(35.0),
              spot_blend=0.3, shadow_soft_size=0.05)
    add_light("POINT", "Fill", (-2.0, -1.5, 1.9), energy=60.0, shadow_soft_size=0.1, color=(0.8, 0.9, 1.0))


SCENES = {
    "light_point": light_point,
    "light_point_soft": light_point_soft,
    "light_spot": light_spot,
    "light_sun": light_sun,
    "light_area": light_area,
    "light_area_spread": light_area_spread,
    "shading_flat_smooth": shading_flat_smooth,
    "shading_visibility": shading_visibility,
    "modifiers_instances": modifiers_instances,
    "light_emissive": light_emissive,
    "world_light": world_light,
    "world_hdri": world_hdri,
    "materials_principled": materials_principled,
    "cornell_box": cornell_box,
    "materials_glass": materials_glass,
    "materials_textures": materials_textures,
    "camera_ortho": camera_ortho,
    "camera_persp_shift": camera_persp_shift,
    "camera_fisheye_equidistant": camera_fisheye_equidistant,
    "camera_fisheye_equisolid": camera_fisheye_equisolid,
    "volume_fog": volume_fog,
}


def build(name: str, out_dir: str = HERE) -> str:
    """Build scene `name` from scratch and save it compressed; return the .blend path."""
    bpy = _bpy()
    SCENES[name]()
    path = os.path.join(out_dir, f"{name}.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True, check_existing=False)
    return path


def main(argv=None) -> int:
    """Build the requested scenes; return a process exit code."""
    parser = argparse.ArgumentParser(description="Build Primer's sample .blend files with bpy.")
    parser.add_argument("--only", nargs="*", default=None, help="build only these scenes")
    parser.add_argument("--out", default=HERE, help="folder for the .blend files (default: beside this script)")
    if argv is None:
        # Inside Blender (`blender -b --python make_scenes.py -- --only NAME`) the script's own
        # arguments follow "--"; with the bpy module they are the whole command line.
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    args = parser.parse_args(argv)
    names = args.only or list(SCENES)
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        print(f"unknown scene(s) {unknown}; choose from {list(SCENES)}", file=sys.stderr)
        return 2
    try:
        import bpy  # noqa: F401
    except ImportError:
        print("make_scenes.py needs the bpy module (Blender as a Python module)", file=sys.stderr)
        return 1
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    from render import load_primer      # registers Primer, so the files can select it as their engine

    load_primer()
    os.makedirs(args.out, exist_ok=True)
    for name in names:
        path = build(name, args.out)
        print(f"{name:28s} -> {os.path.relpath(path)} ({os.path.getsize(path) / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
