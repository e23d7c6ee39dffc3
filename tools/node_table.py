"""Write docs/nodes.md: every shader node a material can hold, in each of its modes, rendered by Primer and by
Cycles, and the project's error measure between the two images.

    .venv/bin/python tools/node_table.py [--only NAME ...] [--modes MODE ...] [--out docs/nodes.md] [--json PATH]

Run it with the Python that has bpy (Blender as a Python module): it renders in this process. Each node, in
each setting of an enum property that changes its output (Math's operations, Mix's blend modes, Noise's types
and dimensions, ...), is one cell of a grid, one material per cell; each family of nodes is one scene, rendered
once by each renderer:

* textures, converters, colour and vector nodes: an emitting plane per cell under an orthographic camera,
  the node's output the Emission's colour. Its inputs read the Generated coordinate snapped to the pixel's
  centre (tests/blender_env.py snapped_generated), so each pixel holds one value whichever renderer samples it:
  one sample per pixel, 1-pixel box filter, as tests/test_blender_procedural.py renders.
* inputs that depend on geometry or camera (Geometry, Texture Coordinate, Light Path, Fresnel, ...): an
  emitting smooth UV sphere per cell under a perspective camera. The pixel filter is a Gaussian 0.01 pixel
  wide, so both renderers sample each pixel at its centre (within 0.015 pixel).
* shaders: a sphere per cell with the shader at its Surface (volume shaders at its Volume), lit by a sun
  (angle 0) in a black world, direct light only (max bounces 0), centre-sampled as above.

The measure (`block_measure`): B(I) are the means of 4 x 4 pixel blocks of image I (each channel); the relative
MSE is mean((B(P) - B(C))^2 / (B(C)^2 + 0.01)) over blocks and channels, and the ratio is mean(P) / mean(C).
A node Primer warns about in that material is listed as not evaluated, with the warning.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests"))
sys.path.insert(0, os.path.join(ROOT, "tools"))

EXACT, CLOSE = 1e-6, 1.5e-4
PIXELS = 16                 # pixels across a cell
COLUMNS = 16                # cells per row of a family's grid
BLOCK = 4                   # block side of the measure

# Nodes a material holds but this table leaves out: outputs (nothing to feed an Emission) and group plumbing.
SKIPPED = {"ShaderNodeOutputMaterial", "ShaderNodeOutputWorld", "ShaderNodeOutputLight", "ShaderNodeOutputAOV",
           "ShaderNodeOutputLineStyle", "ShaderNodeGroup", "ShaderNodeCustomGroup", "ShaderNodeTree"}

# Families by node type; a type not named falls into Converters (or Shaders when its first output is a shader).
GEOMETRY_NODES = {"ShaderNodeNewGeometry", "ShaderNodeTexCoord", "ShaderNodeLightPath", "ShaderNodeCameraData",
                  "ShaderNodeWireframe", "ShaderNodeLayerWeight", "ShaderNodeFresnel", "ShaderNodeObjectInfo",
                  "ShaderNodeAttribute", "ShaderNodeUVMap", "ShaderNodeTangent", "ShaderNodeVertexColor",
                  "ShaderNodeParticleInfo", "ShaderNodePointInfo", "ShaderNodeHairInfo", "ShaderNodeVolumeInfo",
                  "ShaderNodeAmbientOcclusion", "ShaderNodeBevel", "ShaderNodeNormalMap", "ShaderNodeBump",
                  "ShaderNodeVectorTransform", "ShaderNodeDisplacement", "ShaderNodeVectorDisplacement",
                  "ShaderNodeLightFalloff", "ShaderNodeUVAlongStroke", "ShaderNodeScript"}
COLOUR_NODES = {"ShaderNodeMix", "ShaderNodeMixRGB", "ShaderNodeInvert", "ShaderNodeHueSaturation",
                "ShaderNodeBrightContrast", "ShaderNodeGamma", "ShaderNodeRGBCurve", "ShaderNodeRGB",
                "ShaderNodeRGBToBW", "ShaderNodeBlackbody", "ShaderNodeWavelength", "ShaderNodeValToRGB",
                "ShaderNodeCombineColor", "ShaderNodeSeparateColor", "ShaderNodeCombineRGB", "ShaderNodeSeparateRGB",
                "ShaderNodeCombineHSV", "ShaderNodeSeparateHSV"}
VECTOR_NODES = {"ShaderNodeMapping", "ShaderNodeVectorMath", "ShaderNodeVectorRotate", "ShaderNodeVectorCurve",
                "ShaderNodeNormal", "ShaderNodeCombineXYZ", "ShaderNodeSeparateXYZ"}

FAMILIES = {
    "Textures": "an emitting plane per cell, orthographic camera from above; the texture's Vector (W when 1D) reads "
                "the Generated coordinate snapped to the pixel's centre and mapped to -2..2 (z = 0.375); its other "
                "inputs keep their defaults; 1 sample per pixel, 1-pixel box filter. (The Image Texture's image here is "
                "opaque; an image with straight alpha is held to Cycles per Alpha mode and colour space in "
                "tests/test_blender_unmodelled.py: Cycles multiplies the colours of an sRGB image with Alpha Straight or "
                "Premultiplied by their alpha when it loads it (bytes truncated: (c a) // 255), keeps them as stored "
                "for Non-Color and Channel Packed, reads alpha 1 for None, and divides the interpolated colour back by "
                "its alpha where the Alpha output is used; Primer does the same, both kernels)",
    "Converters": "an emitting plane per cell, orthographic camera from above; every float input reads the snapped "
                  "Generated x or y (-2..2; a Fac or Factor reads (x + 2) / 4), a vector input (x, y, 0.375), a "
                  "colour ((x + 2) / 4, (y + 2) / 4, 0.6) (a node's second vector or colour input (y, x, -0.625) or "
                  "((y + 2) / 4, (x + 2) / 4, 0.3)); a Wavelength reads 380..780 nm, a Temperature 800..12800 K "
                  "across x; 1 sample per pixel, 1-pixel box filter",
    "Colour": "as Converters",
    "Vector": "as Converters",
    "Geometry and camera inputs": "an emitting smooth UV sphere (radius 0.4, 32 x 16 segments, UV map, a colour attribute Col "
                                  "(the Attribute node reads it by name)) per cell under "
                                  "a perspective camera 24 units above the grid; inputs at their defaults; pixel "
                                  "filter Gaussian 0.01 px (each pixel sampled at its centre), 64 samples",
    "Shaders": "a smooth UV sphere per cell, the shader at its Surface output (volume shaders at its Volume output), "
               "lit by a sun (strength 3, angle 0) in a black world, direct light only (max bounces 0); the spheres are "
               "hidden from diffuse, glossy and transmission rays (no light from an emitting neighbour); perspective "
               "camera as for the geometry inputs; pixel filter Gaussian 0.01 px, 64 samples",
    "Shaders (subsurface)": "as Shaders, at 1024 samples (a random walk's noise at 64 samples is about 1e-3 of "
                            "this measure in both renderers)",
}
FAMILY_ORDER = list(FAMILIES)


def block_means(image: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """(h, w, c) -> (h // block, w // block, c) float64: the mean of each block x block square."""
    h, w, c = image.shape
    h, w = h - h % block, w - w % block
    return image[:h, :w].reshape(h // block, block, w // block, block, c).mean(axis=(1, 3))


def block_measure(primer: np.ndarray, cycles: np.ndarray) -> tuple:
    """(relative MSE of block means, mean ratio) of Primer's (h, w, c) image against Cycles'.

    relMSE = mean((B(P) - B(C))^2 / (B(C)^2 + 0.01)); ratio = mean(P) / mean(C) (nan when Cycles' mean is 0)."""
    ours, theirs = block_means(np.asarray(primer, np.float64)), block_means(np.asarray(cycles, np.float64))
    relmse = float(np.mean((ours - theirs) ** 2 / (theirs ** 2 + 0.01)))
    reference = float(np.mean(cycles))
    ratio = float(np.mean(primer)) / reference if abs(reference) > 1e-12 else float("nan")
    return relmse, ratio


def status_of(relmse: float, warnings: list, has_output: bool = True) -> str:
    """The table's status: no output (nothing to compare), not evaluated (Primer warned about the node), exact,
    close or differs."""
    if not has_output:
        return "no output"
    if warnings:
        return "not evaluated"
    if not math.isfinite(relmse):
        return "differs"
    return "exact" if relmse <= EXACT else "close" if relmse <= CLOSE else "differs"


# ----------------------------------------------------------------------------
# Inside Blender: the cases
# ----------------------------------------------------------------------------

def node_types() -> list:
    """The bl_idname of every shader node a material's tree accepts, sorted (outputs and groups left out)."""
    import bpy
    material = bpy.data.materials.new("probe")
    if material.node_tree is None:
        material.use_nodes = True
    tree, found = material.node_tree, []
    for name in sorted(dir(bpy.types)):
        if not name.startswith("ShaderNode") or name in SKIPPED:
            continue
        try:
            node = tree.nodes.new(name)
        except RuntimeError:                        # not a node, or one a material cannot hold
            continue
        found.append(name)
        tree.nodes.remove(node)
    bpy.data.materials.remove(material)
    return found


def family_of(idname: str, node) -> str:
    """The family a node type's table is in."""
    if idname in GEOMETRY_NODES:
        return "Geometry and camera inputs"
    if idname == "ShaderNodeSubsurfaceScattering":
        return "Shaders (subsurface)"
    if any(s.type == "SHADER" for s in node.outputs):
        return "Shaders"
    if idname.startswith("ShaderNodeTex"):
        return "Textures"
    if idname in COLOUR_NODES:
        return "Colour"
    if idname in VECTOR_NODES:
        return "Vector"
    return "Converters"


def enum_settings(node) -> list:
    """The node's own enum properties that may change its output: [(name, [item ids])]."""
    import bpy
    base = set(bpy.types.ShaderNode.bl_rna.properties.keys())
    found = []
    for prop in node.bl_rna.properties:
        if prop.type != "ENUM" or prop.is_readonly or prop.identifier in base or getattr(prop, "is_enum_flag", False):
            continue
        items = [item.identifier for item in prop.enum_items]
        if len(items) > 1:
            found.append((prop.identifier, items))
    return found


# Settings whose product is the interesting set (one enum varied at a time misses them).
def combined_variants(idname: str) -> list | None:
    """[(mode label, {setting: value})] for the nodes whose enums act together, or None for one-at-a-time."""
    if idname == "ShaderNodeTexNoise":
        return [(f"{d} {t}", {"noise_dimensions": d, "noise_type": t}) for d in ("1D", "2D", "3D", "4D")
                for t in ("FBM", "MULTIFRACTAL", "HYBRID_MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HETERO_TERRAIN")]
    if idname == "ShaderNodeTexVoronoi":
        features = ("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS")
        out = [(f"{d} {f}", {"voronoi_dimensions": d, "feature": f}) for d in ("1D", "2D", "3D", "4D")
               for f in features]
        out += [(f"3D F1 {m}", {"voronoi_dimensions": "3D", "feature": "F1", "distance": m})
                for m in ("MANHATTAN", "CHEBYCHEV", "MINKOWSKI")]
        return out
    if idname == "ShaderNodeMix":
        import bpy
        blends = [i.identifier for i in bpy.types.ShaderNodeMix.bl_rna.properties["blend_type"].enum_items]
        return ([("FLOAT", {"data_type": "FLOAT"}), ("VECTOR uniform", {"data_type": "VECTOR"}),
                 ("VECTOR non-uniform", {"data_type": "VECTOR", "factor_mode": "NON_UNIFORM"})]
                + [(f"RGBA {b}", {"data_type": "RGBA", "blend_type": b}) for b in blends])
    if idname == "ShaderNodeMapRange":
        return [(f"{d} {i}", {"data_type": d, "interpolation_type": i}) for d in ("FLOAT", "FLOAT_VECTOR")
                for i in ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP")]
    if idname == "ShaderNodeTexWave":
        return ([(f"BANDS {d}", {"wave_type": "BANDS", "bands_direction": d}) for d in ("X", "Y", "Z", "DIAGONAL")]
                + [(f"RINGS {d}", {"wave_type": "RINGS", "rings_direction": d}) for d in ("X", "Y", "Z", "SPHERICAL")]
                + [(f"BANDS X {p}", {"wave_profile": p}) for p in ("SAW", "TRI")])
    if idname == "ShaderNodeValToRGB":
        return ([(i, {"color_ramp.interpolation": i}) for i in ("EASE", "CARDINAL", "LINEAR", "B_SPLINE", "CONSTANT")]
                + [(f"{m} {h}", {"color_ramp.color_mode": m, "color_ramp.hue_interpolation": h})
                   for m in ("HSV", "HSL") for h in ("NEAR", "FAR", "CW", "CCW")])
    return None


def variants(idname: str, node) -> list:
    """[(mode label, {setting: value}, output identifier or None for the first)] of a node type."""
    combined = combined_variants(idname)
    outputs = [s.identifier for s in node.outputs if s.enabled]
    found = [(f"default, {o}" if len(outputs) > 1 else "default", {}, o) for o in outputs] or [("default", {}, None)]
    if not outputs:
        return found
    if idname == "ShaderNodeAttribute":             # a name no mesh holds
        found += [(f"no such attribute, {o}", {"attribute_name": "missing"}, o) for o in ("Color", "Alpha")]
    if combined is not None:
        return found[:1] + [(label, settings, None) for label, settings in combined]
    for prop, items in enum_settings(node):
        default = getattr(node, prop)
        many = len(enum_settings(node)) > 1
        found += [(f"{prop}={item}" if many else item, {prop: item}, None) for item in items if item != default]
    return found


def apply_settings(node, settings: dict) -> None:
    """Set `settings` ({"prop": value} or {"color_ramp.prop": value}) on `node`."""
    for name, value in settings.items():
        owner = node
        *path, last = name.split(".")
        for part in path:
            owner = getattr(owner, part)
        setattr(owner, last, value)


def prepare(node, idname: str) -> None:
    """Give nodes that show nothing at their defaults something to show (a colour ramp with 3 stops, an image)."""
    import bpy
    if idname == "ShaderNodeValToRGB":
        ramp = node.color_ramp
        ramp.elements[0].color = (0.9, 0.1, 0.2, 1.0)
        ramp.elements[1].color = (0.1, 0.4, 0.9, 1.0)
        middle = ramp.elements.new(0.4)
        middle.color = (0.2, 0.9, 0.3, 1.0)
    if idname in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment"):
        # 50 x 45 texels: no snapped coordinate falls on a texel's edge (where Closest may round either way)
        image = bpy.data.images.get("node table grid") or bpy.data.images.new("node table grid", 50, 45,
                                                                              float_buffer=True)
        image.generated_type = "COLOR_GRID"
        node.image = image
    if idname == "ShaderNodeTexSky":
        # With its sun disc on, Blender 5 makes the scattering models' Vector input unavailable: both renderers then
        # read the unsnapped Generated coordinate (Cycles at the pixel's centre with 1 sample, Primer anywhere in
        # it), which measured 2.3e-4 / 2.1e-3 of noise, not of the sky; the disc has its own tests
        # (tests/test_blender_sky_disc.py).
        node.sun_disc = False
    if idname == "ShaderNodeAttribute":
        node.attribute_name = "Col"                 # the spheres' colour attribute (colour_attribute)
    if idname == "ShaderNodeTexPointDensity":
        node.point_source = "OBJECT"
    roughness = node.inputs.get("Roughness")
    if roughness is not None and any(s.type == "SHADER" for s in node.outputs) and roughness.default_value == 0.0:
        roughness.default_value = 0.4               # a sharp lobe shows nothing of a sun
    if idname in ("ShaderNodeAddShader", "ShaderNodeMixShader"):
        tree = node.id_data
        diffuse, glossy = tree.nodes.new("ShaderNodeBsdfDiffuse"), tree.nodes.new("ShaderNodeBsdfAnisotropic")
        diffuse.inputs["Color"].default_value = (0.8, 0.3, 0.1, 1.0)
        glossy.distribution, glossy.inputs["Roughness"].default_value = "GGX", 0.4
        shaders = [s for s in node.inputs if s.type == "SHADER"]
        tree.links.new(diffuse.outputs[0], shaders[0])
        tree.links.new(glossy.outputs[0], shaders[1])
        if idname == "ShaderNodeMixShader":
            node.inputs["Fac"].default_value = 0.3


def feed_inputs(tree, node, family: str, sources: dict) -> None:
    """Link the node's inputs to the snapped coordinate: textures their Vector (W when 1D), other plane nodes every
    float, vector and colour input (a node's first and second input of a kind read different sources)."""
    available = [s for s in node.inputs if s.enabled and not s.is_linked]
    if family == "Textures":
        vector = next((s for s in available if s.name == "Vector"), None)
        if vector is not None:
            tree.links.new(sources["vector"], vector)
        else:
            w = next((s for s in available if s.name == "W"), None)
            if w is not None:
                tree.links.new(sources["x"], w)
        return
    counts = {"VALUE": 0, "VECTOR": 0, "RGBA": 0}
    for socket in available:
        if socket.type not in counts:
            continue
        if socket.type == "VALUE" and socket.name in ("Fac", "Factor"):
            tree.links.new(sources["u"], socket)
            continue
        if socket.name in ("Wavelength", "Temperature"):  # 380..780 nm; 800..12800 K
            tree.links.new(sources["nm" if socket.name == "Wavelength" else "kelvin"], socket)
            continue
        first = counts[socket.type] % 2 == 0
        counts[socket.type] += 1
        name = {"VALUE": ("x", "y"), "VECTOR": ("vector", "vector2"), "RGBA": ("colour", "colour2")}[socket.type]
        tree.links.new(sources[name[0] if first else name[1]], socket)


def plane_sources(tree) -> dict:
    """The snapped coordinate's sockets: vector (x, y, 0.375), vector2 (y, x, -0.625), x, y (-2..2),
    u = (x + 2) / 4, colour (u, v, 0.6), colour2 (v, u, 0.3)."""
    from blender_env import snapped_generated
    vector, x, y = snapped_generated(tree, PIXELS)
    sources = {"vector": vector, "x": x, "y": y}
    units = []
    for socket in (x, y):
        math_node = tree.nodes.new("ShaderNodeMath")
        math_node.operation = "MULTIPLY_ADD"
        math_node.inputs[1].default_value, math_node.inputs[2].default_value = 0.25, 0.5
        tree.links.new(socket, math_node.inputs[0])
        units.append(math_node.outputs[0])
    sources["u"] = units[0]
    colour = tree.nodes.new("ShaderNodeCombineColor")
    colour.inputs["Blue"].default_value = 0.6
    tree.links.new(units[0], colour.inputs["Red"])
    tree.links.new(units[1], colour.inputs["Green"])
    sources["colour"] = colour.outputs[0]
    colour2 = tree.nodes.new("ShaderNodeCombineColor")
    colour2.inputs["Blue"].default_value = 0.3
    tree.links.new(units[1], colour2.inputs["Red"])
    tree.links.new(units[0], colour2.inputs["Green"])
    sources["colour2"] = colour2.outputs[0]
    vector2 = tree.nodes.new("ShaderNodeCombineXYZ")
    vector2.inputs["Z"].default_value = -0.625
    tree.links.new(y, vector2.inputs["X"])
    tree.links.new(x, vector2.inputs["Y"])
    sources["vector2"] = vector2.outputs[0]
    for name, scale, offset in (("nm", 400.0, 380.0), ("kelvin", 12000.0, 800.0)):
        math_node = tree.nodes.new("ShaderNodeMath")
        math_node.operation = "MULTIPLY_ADD"
        math_node.inputs[1].default_value, math_node.inputs[2].default_value = scale, offset
        tree.links.new(units[0], math_node.inputs[0])
        sources[name] = math_node.outputs[0]
    return sources


def build_case(index: int, family: str, idname: str, settings: dict, output) -> tuple:
    """Add cell `index` of `family`'s grid: its object and a material named for it; return (the material's name,
    whether the node has an output to show)."""
    import bpy
    from blender_env import empty_material
    name = f"cell {index:03d}"
    material, tree, out = empty_material(name)
    node = tree.nodes.new(idname)
    prepare(node, idname)
    apply_settings(node, settings)
    plane = family in ("Textures", "Converters", "Colour", "Vector")
    if plane:
        feed_inputs(tree, node, family, plane_sources(tree))
    enabled = [s for s in node.outputs if s.enabled]
    socket = next((s for s in enabled if s.identifier == output), enabled[0] if enabled else None)
    if socket is not None and socket.type == "SHADER":
        volume = "Volume" in node.bl_label or idname == "ShaderNodeVolumeCoefficients"
        tree.links.new(socket, out.inputs["Volume" if volume else "Surface"])
    elif socket is not None:
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(socket, emission.inputs["Color"])
        tree.links.new(emission.outputs[0], out.inputs["Surface"])
    location = (index % COLUMNS + 0.5, -(index // COLUMNS) - 0.5, 0.0)
    if plane:
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=location)
    else:
        bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.4, location=location)
        bpy.ops.object.shade_smooth()
        colour_attribute(bpy.context.view_layer.objects.active.data)
        if family.startswith("Shaders"):            # no light from an emitting neighbour (Emission, Background)
            sphere = bpy.context.view_layer.objects.active
            sphere.visible_diffuse = sphere.visible_glossy = sphere.visible_transmission = False
    obj = bpy.context.view_layer.objects.active
    obj.name = obj.data.name = name
    obj.data.materials.append(material)
    return name, socket is not None


def colour_attribute(mesh) -> None:
    """Give `mesh` an active per-corner colour attribute "Col" varying over it: (|x|, |y|, |z|) / 0.4 of the
    corner's vertex, alpha 0.25 + |z| (for the Attribute and Color Attribute nodes)."""
    attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    mesh.color_attributes.active_color = attribute
    points = np.array([mesh.vertices[loop.vertex_index].co[:] for loop in mesh.loops])
    colours = np.concatenate([np.abs(points) / 0.4, 0.25 + np.abs(points[:, 2:])], axis=1)
    attribute.data.foreach_set("color", colours.astype(np.float32).ravel())


def setup_camera_and_light(scene, family: str, rows: int) -> int:
    """Camera (orthographic over planes, perspective over spheres), sun for the shaders, film; return samples."""
    import bpy
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = COLUMNS * PIXELS, rows * PIXELS
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.bl_idname == "ShaderNodeBackground":
                node.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    if family in ("Textures", "Converters", "Colour", "Vector"):
        camera.data.type = "ORTHO"
        camera.data.ortho_scale = float(COLUMNS)
        camera.location = (COLUMNS / 2, -rows / 2, 5.0)
        return 1
    height = 24.0
    camera.data.sensor_fit = "HORIZONTAL"
    camera.data.angle = 2.0 * math.atan(COLUMNS / 2 / height)
    camera.location = (COLUMNS / 2, -rows / 2, height)
    if family.startswith("Shaders"):
        sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
        sun.data.energy, sun.data.angle = 3.0, 0.0
        sun.rotation_euler = (0.6, 0.3, 0.2)
        scene.collection.objects.link(sun)
        return 1024 if family == "Shaders (subsurface)" else 64
    return 64


def render(scene, engine: str, path: str, samples: int, centre: bool) -> np.ndarray:
    """Render `scene` with `engine` at `samples` into the EXR `path`: (H, W, 3) float64, rows top first."""
    import bpy
    from render import configure_cycles_reference, configure_output
    scene.render.engine = engine
    if engine == "CYCLES":
        configure_cycles_reference(scene, samples)
        scene.cycles.seed = 0
    else:
        scene.primer.samples = samples
        scene.primer.terminator_fix = True          # Cycles' shadow terminator offset, as Cycles renders
    if centre:                                      # every sample within 0.015 px of the pixel's centre
        scene.cycles.pixel_filter_type, scene.cycles.filter_width = "GAUSSIAN", 0.01
    configure_output(scene, path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path)
    pixels = np.array(image.pixels[:], np.float64).reshape(image.size[1], image.size[0], image.channels)
    bpy.data.images.remove(image)
    return pixels[::-1, :, :3]


def run_family(family: str, cases: list, export, folder: str) -> list:
    """Render one family's grid with both renderers; return one row dict per case."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    built = [build_case(i, family, idname, settings, output) for i, (idname, _, _, settings, output) in
             enumerate(cases)]
    rows = -(-len(cases) // COLUMNS)
    samples = setup_camera_and_light(scene, family, rows)
    centre = family not in ("Textures", "Converters", "Colour", "Vector")
    started = time.time()
    primer = render(scene, "PRIMER", os.path.join(folder, "primer.exr"), samples, centre)
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    middle = time.time()
    cycles = render(scene, "CYCLES", os.path.join(folder, "cycles.exr"), samples, centre)
    print(f"{family}: {len(cases)} cells, Primer {middle - started:.1f} s, Cycles {time.time() - middle:.1f} s",
          flush=True)
    results = []
    for index, ((idname, label, mode, _, _), (name, has_output)) in enumerate(zip(cases, built)):
        row, column = divmod(index, COLUMNS)
        cell = (slice(row * PIXELS, (row + 1) * PIXELS), slice(column * PIXELS, (column + 1) * PIXELS))
        ours, theirs = primer[cell], cycles[cell]
        finite = bool(np.isfinite(ours).all() and np.isfinite(theirs).all())
        relmse, ratio = block_measure(np.nan_to_num(ours), np.nan_to_num(theirs))
        notes = [w.split(": ", 1)[-1] if w.startswith("material") else w for w in warnings
                 if f"material '{name}'" in w or f"mesh '{name}'" in w]
        results.append({"family": family, "idname": idname, "node": label, "mode": mode, "relmse": relmse,
                        "ratio": ratio, "finite": finite, "warnings": notes, "status": status_of(relmse, notes, has_output),
                        "cycles_mean": float(np.mean(theirs)), "cycles_uniform": bool(np.ptp(theirs) < 1e-6),
                        "cycles_black": bool(np.abs(theirs).max() < 1e-6)})
    return results


def collect_cases(only: list, modes: list = ()) -> dict:
    """{family: [(idname, node label, mode, settings, output)]} for every node type (those matching `only`), in every
    mode (those in `modes`)."""
    import bpy
    material = bpy.data.materials.new("probe cases")
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    families = {family: [] for family in FAMILY_ORDER}
    for idname in node_types():
        node = tree.nodes.new(idname)
        label = node.bl_label
        if only and not any(o.lower() in (idname.lower(), label.lower(), idname[len("ShaderNode"):].lower())
                            for o in only):
            tree.nodes.remove(node)
            continue
        family = family_of(idname, node)
        for mode, settings, output in variants(idname, node):
            if modes and mode not in modes:
                continue
            families[family].append((idname, label, mode, settings, output))
        tree.nodes.remove(node)
    bpy.data.materials.remove(material)
    return {family: cases for family, cases in families.items() if cases}


# ----------------------------------------------------------------------------
# The table
# ----------------------------------------------------------------------------

def markdown(results: list, version: str, seconds: float) -> str:
    """docs/nodes.md's text from the rows."""
    lines = ["# Shader nodes: Primer against Cycles, node by node", "",
             f"Written by `tools/node_table.py` (Blender {version}, {len(results)} node modes, {seconds / 60:.1f} "
             "minutes); regenerate it with", "",
             "    .venv/bin/python tools/node_table.py --out docs/nodes.md", "",
             "(`--only Math Noise ...` renders the named nodes alone, by bl_idname, its tail or its label). Each row "
             "is one node in one mode, the node's output seen through an Emission (shaders: lit directly) in a grid "
             "cell of 16 x 16 pixels, rendered by Cycles and by Primer in the same process. The measure is the "
             "project's: B(I) are the means of 4 x 4 pixel blocks, **relMSE** = mean((B(P) - B(C))² / (B(C)² + "
             "0.01)) over blocks and RGB, **ratio** = mean(P) / mean(C) (– where Cycles' cell is black). Status: "
             f"**exact** (relMSE <= {EXACT:g}), **close** (<= {CLOSE:g}), **differs**, or **not evaluated**: Primer "
             "warned about the node in that material (its warning quoted; the numbers are what it rendered "
             "instead). Modes are each enum setting of the node varied alone from its defaults (all outputs at the "
             "defaults), or for Noise, Voronoi, Mix, Map Range, Wave and Color Ramp the combinations listed. A match "
             "marked *(Cycles' cell is black)* or *(one colour)* shows nothing of the node in this scene. On the "
             "sphere scenes each pixel's samples spread over 0.015 pixel around its centre, differently in each "
             "renderer, which leaves up to about 1e-5 at the silhouettes: there *close* is as near as the scene "
             "can tell.", ""]
    counts = {}
    for row in results:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    lines += ["Totals: " + ", ".join(f"{status} {counts.get(status, 0)}"
                                     for status in ("exact", "close", "differs", "not evaluated")), ""]
    for family in FAMILY_ORDER:
        rows = [r for r in results if r["family"] == family]
        if not rows:
            continue
        lines += [f"## {family}", "", f"Scene: {FAMILIES[family]}.", "",
                  "| node | mode | relMSE | ratio | status |", "|---|---|---|---|---|"]
        for r in rows:
            ratio = "–" if not math.isfinite(r["ratio"]) else f"{r['ratio']:.4f}"
            status = r["status"]
            if r["warnings"]:
                status += ": " + "; ".join(w.replace("|", "\\|") for w in r["warnings"])
            if r["status"] in ("exact", "close") and r.get("cycles_uniform"):
                status += " (Cycles' cell is " + ("black" if r.get("cycles_black") else "one colour") + ")"
            if not r["finite"]:
                status += " (non-finite pixels, read as 0)"
            lines.append(f"| {r['node']} | {r['mode']} | {r['relmse']:.3g} | {ratio} | {status} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Render the table (the nodes named by --only, or all) and write it as markdown (and JSON when asked)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="*", default=[], help="node bl_idnames, their tails or labels")
    parser.add_argument("--modes", nargs="*", default=[], help="keep only these modes (e.g. default MULTIPLY)")
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "nodes.md"))
    parser.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = parser.parse_args(argv)
    import bpy
    import blender_env
    blender_env.keep_box_filter()
    primer, export = blender_env.primer_in_blender()
    started = time.time()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    families = collect_cases(args.only, args.modes)
    results = []
    with tempfile.TemporaryDirectory() as folder:
        for family, cases in families.items():
            results += run_family(family, cases, export, folder)
    seconds = time.time() - started
    version = bpy.app.version_string
    with open(args.out, "w", encoding="utf-8") as fh:
        fh.write(markdown(results, version, seconds))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({"version": version, "rows": results}, fh)
    primer.unregister()
    print(f"{len(results)} rows in {seconds:.0f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
