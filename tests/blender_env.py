"""Run code under Blender's bpy module in a fresh process with empty user folders, for the Blender tests.

bpy keeps global state (registered classes, preferences, installed extensions, the open file), so a
test that installs or registers Primer runs a script in its own process through `run_bpy`. That
process gets an empty HOME and empty Blender user folders, so nothing from the machine's own Blender
setup leaks in and nothing the test installs leaks out.

The functions under "Inside Blender" are for those scripts (run_bpy puts this folder on their
sys.path): they render Blender's default scene (cube, light, camera) with Primer and summarise the
pixels, and hand results back to the test as one JSON line.
"""
from __future__ import annotations

import atexit
import json
import os
import subprocess
import sys
import textwrap
import warnings

TESTS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TESTS)
RESULT_TAG = "PRIMER_RESULT "
STALE_TAG = "PRIMER_STALE_REFERENCE "         # tests/cycles_references.py prints it


def keep_box_filter() -> None:
    """Give every scene Blender loads from now on (a file, the factory settings) Cycles' 1-pixel box filter.

    Primer follows the scene's pixel filter (core/camera/filter.py), and Blender's factory scene asks for Cycles'
    Blackman-Harris 1.5 px; the Blender tests hold Primer to closed forms written for a pixel's own samples and to
    Cycles rendered as Primer's reference (tools/render.py configure_cycles_reference: a 1-pixel box). The sample
    scenes carry the box themselves. A test of the filter sets its scene's filter after loading
    (tests/test_blender_pixel_filter.py). Installed by run_bpy's scripts and by conftest.py once bpy is imported.
    """
    import bpy
    from bpy.app.handlers import persistent

    if any(getattr(handler, "__name__", "") == "_box_filter" for handler in bpy.app.handlers.load_post):
        return

    @persistent
    def _box_filter(_file) -> None:
        """Set Cycles' pixel filter of every scene to a 1-pixel box."""
        for scene in bpy.data.scenes:
            cycles = getattr(scene, "cycles", None)
            if cycles is not None:
                cycles.pixel_filter_type = "BOX"
                cycles.filter_width = 1.0

    bpy.app.handlers.load_post.append(_box_filter)
    # bpy 4.2 crashes at exit with a Python handler still in place (as with a registered RenderEngine).
    atexit.register(lambda: _box_filter in bpy.app.handlers.load_post
                    and bpy.app.handlers.load_post.remove(_box_filter))


def require_bpy(test_file: str) -> None:
    """Skip the calling test module when bpy is missing and PRIMER_ALLOW_NO_BPY is set, else fail its import."""
    import importlib.util
    import pytest
    if importlib.util.find_spec("bpy") is None:
        if os.environ.get("PRIMER_ALLOW_NO_BPY"):
            pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
        raise ImportError(f"tests/{os.path.basename(test_file)} needs bpy (Blender as a Python module): "
                          "pip install bpy")


def isolated_env(folder: str) -> dict:
    """Return an environment whose HOME and Blender user folders are empty folders inside `folder`."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("BLENDER_") and k != "PYTHONPATH"}
    home = os.path.join(folder, "home")
    resources = os.path.join(folder, "blender")
    env.update(HOME=home, XDG_CONFIG_HOME=os.path.join(home, ".config"), XDG_CACHE_HOME=os.path.join(home, ".cache"),
               BLENDER_USER_RESOURCES=resources,
               BLENDER_USER_CONFIG=os.path.join(resources, "config"),
               BLENDER_USER_SCRIPTS=os.path.join(resources, "scripts"),
               BLENDER_USER_EXTENSIONS=os.path.join(resources, "extensions"),
               BLENDER_USER_DATAFILES=os.path.join(resources, "datafiles"),
               PYTHONNOUSERSITE="1")
    for path in (home, resources):
        os.makedirs(path, exist_ok=True)
    return env


def run_bpy(script: str, folder: str, *args: str, python: str = sys.executable, timeout: float = 600) -> dict:
    """Run `script` with bpy's Python in a fresh isolated process; return the dict it passed to report().

    Fails the test, showing the process's output, when it exits non-zero, prints a Python traceback,
    or reports nothing. The dict also carries the whole output as "output".
    """
    import pytest

    path = os.path.join(folder, "script.py")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"import sys\nsys.path.append({TESTS!r})\nimport blender_env\nblender_env.keep_box_filter()\n"
                 + textwrap.dedent(script))
    completed = subprocess.run([python, path, *args], cwd=folder, env=isolated_env(folder),
                               capture_output=True, text=True, timeout=timeout)
    output = completed.stdout + completed.stderr
    shown = "\n".join(output.splitlines()[-60:])
    if completed.returncode != 0:
        pytest.fail(f"Blender script exited with {completed.returncode}:\n{shown}", pytrace=False)
    if "Traceback (most recent call last)" in output:
        pytest.fail(f"Blender script printed a traceback:\n{shown}", pytrace=False)
    for line in completed.stdout.splitlines():
        if line.startswith(STALE_TAG):                  # a Cycles reference the script had to render itself
            warnings.warn(line[len(STALE_TAG):])
    lines = [line for line in completed.stdout.splitlines() if line.startswith(RESULT_TAG)]
    if not lines:
        pytest.fail(f"Blender script reported nothing:\n{shown}", pytrace=False)
    result = json.loads(lines[-1][len(RESULT_TAG):])
    result["output"] = output
    return result


# ----------------------------------------------------------------------------
# Inside Blender
# ----------------------------------------------------------------------------

def report(**values) -> None:
    """Hand `values` back to run_bpy as one JSON line on stdout."""
    print(RESULT_TAG + json.dumps(values), flush=True)


def engine_ids() -> list:
    """Return the bl_idname of every registered render engine (Blender's own and add-ons').

    An unregistered class stays among Python's subclasses until it is garbage collected, so
    `is_registered` decides.
    """
    import bpy

    return sorted(cls.bl_idname for cls in bpy.types.RenderEngine.__subclasses__()
                  if getattr(cls, "bl_idname", "") and getattr(cls, "is_registered", False))


def primer_types() -> list:
    """Return the names in bpy.types that belong to Primer (engine, settings, panels)."""
    import bpy

    return sorted(name for name in dir(bpy.types) if "primer" in name.lower())


def can_select_primer() -> bool:
    """Return whether the scene accepts 'PRIMER' as its render engine (restoring the engine it had)."""
    import bpy

    render = bpy.context.scene.render
    before = render.engine
    try:
        render.engine = "PRIMER"
    except TypeError:               # "enum 'PRIMER' not found": no engine with that id is registered
        return False
    render.engine = before
    return True


def render_default_scene(out_path: str, package: str, width: int = 32, height: int = 24, samples: int = 2) -> dict:
    """Render the default scene with Primer through bpy.ops.render.render into `out_path` (EXR); summarise it."""
    import bpy
    import numpy as np

    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.primer.samples = samples
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = out_path
    scene.render.use_file_extension = False
    status = bpy.ops.render.render(write_still=True)
    record = sys.modules[package + ".addon.engine"].last_render
    image = bpy.data.images.load(out_path)
    pixels = np.array(image.pixels[:], np.float64).reshape(image.size[1], image.size[0], image.channels)
    bpy.data.images.remove(image)
    rgb = pixels[..., :3]
    return {
        "status": sorted(status),
        "error": record.error,
        "rays": record.rays,
        "kernels": record.stats.kernels if record.stats is not None else "",
        "shape": list(pixels.shape),
        "finite": bool(np.isfinite(pixels).all()),
        "max": float(np.nan_to_num(rgb).max()),
        "nonzero_fraction": float((rgb.sum(axis=2) > 1e-4).mean()),
    }


# A script for run_bpy (format it with tools= and scenes=): every mesh of the sample scenes and a
# few edge cases read by the export's fast path and by its RNA reference; check_mesh_reads judges it.
MESH_READS = """
import glob, os, sys
import bpy
import bmesh
import numpy as np
from blender_env import report
sys.path.insert(0, {tools!r})
from render import load_primer

primer = load_primer()
export = sys.modules[primer.__name__ + ".addon.export"]


def edge_case_meshes():
    # Meshes the sample scenes may lack: ngons, mixed smooth and flat faces, material indices, no
    # sharp_face attribute at all (every face smooth), custom normals, and an empty mesh.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    made = []
    mesh = bpy.data.meshes.new("Ngons")
    bm = bmesh.new()
    bmesh.ops.create_circle(bm, cap_ends=True, segments=7, radius=1.0)
    bmesh.ops.create_cube(bm, size=0.5)
    bm.to_mesh(mesh)
    bm.free()
    mesh.polygons.foreach_set("use_smooth", [i % 2 == 0 for i in range(len(mesh.polygons))])
    mesh.polygons.foreach_set("material_index", [i % 3 for i in range(len(mesh.polygons))])
    made.append(mesh)
    smooth = bpy.data.meshes.new("All smooth")
    smooth.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0.3)], [], [(0, 1, 2, 3)])
    if smooth.attributes.get("sharp_face") is not None:
        smooth.attributes.remove(smooth.attributes["sharp_face"])      # no attribute: every face smooth
    made.append(smooth)
    custom = bpy.data.meshes.new("Custom normals")
    custom.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    custom.shade_flat()
    custom.normals_split_custom_set_from_vertices([(0.0, 0.6, 0.8)] * 3)
    made.append(custom)
    made.append(bpy.data.meshes.new("Empty"))
    for m in made:
        m.calc_loop_triangles()
    return [(m.name, m) for m in made]


def compare(label, mesh, results):
    fast, slow = export._mesh_arrays(mesh), export._mesh_arrays_by_rna(mesh)
    same = {{name: bool(np.array_equal(getattr(fast, name), getattr(slow, name)))
             for name in ("vertices", "triangles", "smooth", "material_indices")}}
    same["corner_normals"] = ((fast.corner_normals is None and slow.corner_normals is None)
                              or bool(np.array_equal(fast.corner_normals, slow.corner_normals)))
    results.append({{"mesh": label, "n_triangles": int(len(fast.triangles)), "n_smooth": int(fast.smooth.sum()),
                     "n_materials": int(len(np.unique(fast.material_indices))), **same}})


results = []
for blend in sorted(glob.glob(os.path.join({scenes!r}, "*.blend"))):
    bpy.ops.wm.open_mainfile(filepath=blend)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for instance in depsgraph.object_instances:
        if instance.object.type == "MESH" and instance.object.data is not None:
            compare(os.path.basename(blend) + ": " + instance.object.data.name, instance.object.data, results)
for label, mesh in edge_case_meshes():
    compare(label, mesh, results)
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(version=list(bpy.app.version), results=results)
"""


def check_mesh_reads(result) -> None:
    """Every mesh read through the attributes equals the same mesh read through RNA's per-item properties."""
    results = result["results"]
    differ = [r for r in results if not all(r[k] for k in ("vertices", "triangles", "smooth", "material_indices",
                                                              "corner_normals"))]
    assert differ == [], differ
    # The comparison covered what can differ: flat and smooth faces, several materials, an empty mesh.
    assert any(0 < r["n_smooth"] < r["n_triangles"] for r in results)
    assert any(r["n_materials"] >= 3 for r in results)
    assert any(r["mesh"] == "All smooth" and r["n_smooth"] == r["n_triangles"] == 2 for r in results)
    assert any(r["mesh"] == "Empty" and r["n_triangles"] == 0 for r in results)
    assert len(results) > 20



# A script for run_bpy (format it with tools=): a plane under a sun, rendered by Primer and by Cycles with
# the light plain and with a node tree; check_light_nodes judges it. Every Blender version runs it: 4.2 and
# 5.0 give a light a node tree only with Use Nodes on, 5.2 gives every light one (Emission, white, strength 1).
LIGHT_NODES = """
import os, sys
import bpy
import numpy as np
from blender_env import lambert_everywhere, render_pixels, report
sys.path.insert(0, {tools!r})
from render import load_primer

primer = load_primer()
export = sys.modules[primer.__name__ + ".addon.export"]


def sun_over_a_plane():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    lambert_everywhere(scene)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 16, 12, 100
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(bpy.data.objects.new("Plane", mesh))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 2.0, 0.0
    sun.rotation_euler = (0.5, 0.2, 0.0)
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene, sun.data


def deprecated_use_nodes(light):
    return getattr(light.bl_rna.properties["use_nodes"], "is_deprecated", False)


def emission_node(light):
    if not deprecated_use_nodes(light):
        light.use_nodes = True                      # Blender 4.2 and 5.0 make the default tree here
    return light.node_tree, next(n for n in light.node_tree.nodes if n.bl_idname == "ShaderNodeEmission")


def exported(scene):
    result = export.export_scene(bpy.context.evaluated_depsgraph_get())
    return {{"warnings": result.warnings, "colors": [light.color.tolist() for light in result.scene.lights]}}


def render(scene, engine, path):
    return render_pixels(scene, engine, path, 1 if engine == "PRIMER" else 4)[..., :3].tolist()


cases = {{}}
bpy.ops.wm.read_factory_settings(use_empty=False)            # the default scene: cube, point light, camera
cases["default scene"] = exported(bpy.context.scene)

scene, light = sun_over_a_plane()
cases["plain"] = exported(scene)
cases["plain"].update(primer=render(scene, "PRIMER", os.path.abspath("plain_primer.exr")),
                      cycles=render(scene, "CYCLES", os.path.abspath("plain_cycles.exr")))

tree, emission = emission_node(light)
emission.inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
emission.inputs["Strength"].default_value = 2.0
cases["emission"] = exported(scene)
cases["emission"].update(primer=render(scene, "PRIMER", os.path.abspath("emission_primer.exr")),
                         cycles=render(scene, "CYCLES", os.path.abspath("emission_cycles.exr")))

if not deprecated_use_nodes(light):                       # 4.2, 5.0: the tree counts only with Use Nodes
    light.use_nodes = False
    cases["use nodes off"] = exported(scene)
    light.use_nodes = True

falloff = tree.nodes.new("ShaderNodeLightFalloff")
tree.links.new(falloff.outputs["Quadratic"], emission.inputs["Strength"])
cases["linked strength"] = exported(scene)

output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputLight")
add = tree.nodes.new("ShaderNodeAddShader")
tree.links.new(emission.outputs["Emission"], add.inputs[0])
tree.links.new(add.outputs["Shader"], output.inputs["Surface"])
cases["other shader"] = exported(scene)

tree.links.remove(output.inputs["Surface"].links[0])
cases["nothing at the output"] = exported(scene)

primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(version=list(bpy.app.version), cases=cases)
"""


def check_light_nodes(result) -> None:
    """A light's node tree, as Cycles reads it: an Emission node at the Light Output multiplies the light's
    colour by its Color x Strength (2 x (1, 0.5, 0.25) here, exactly, in Primer's pixels and in Cycles');
    a default tree changes nothing and warns nothing; a Light Falloff into the Strength gives a sun its Strength; another
    shader at the output is warned about, naming light and node."""
    import numpy as np

    cases = result["cases"]
    factor = 2.0 * np.array([1.0, 0.5, 0.25])
    light_notes = [w for w in cases["default scene"]["warnings"] if "light" in w.lower()]
    assert light_notes == [], light_notes
    assert cases["plain"]["warnings"] == [] and cases["emission"]["warnings"] == []
    np.testing.assert_allclose(cases["plain"]["colors"], [[1.0, 1.0, 1.0]], rtol=1e-12)
    np.testing.assert_allclose(cases["emission"]["colors"], [factor], rtol=1e-7)
    for renderer in ("primer", "cycles"):
        plain, lit = np.array(cases["plain"][renderer]), np.array(cases["emission"][renderer])
        assert plain.min() > 0.1, f"{renderer}: the plane is not lit everywhere"
        # Float32 pixels scaled by powers of two (2, 1, 0.5): the same samples give exactly factor x plain.
        np.testing.assert_allclose(lit, plain * factor, rtol=1e-6, err_msg=renderer)
    if result["version"][:2] < [5, 2]:
        np.testing.assert_allclose(cases["use nodes off"]["colors"], [[1.0, 1.0, 1.0]], rtol=1e-12)
        assert cases["use nodes off"]["warnings"] == []
    else:
        assert "use nodes off" not in cases
    # A Light Falloff into the Strength: a sun's light samples see its Strength (100) whatever the output (Cycles'
    # svm_node_light_falloff skips a distant light's infinite ray length); evaluated since stop 46, no warning.
    linked = cases["linked strength"]
    assert linked["warnings"] == [], linked["warnings"]
    np.testing.assert_allclose(linked["colors"], [100.0 * factor / 2.0], rtol=1e-7)
    other = cases["other shader"]
    assert len(other["warnings"]) == 1 and "light 'Sun', node 'Add Shader'" in other["warnings"][0]
    assert "colour and power" in other["warnings"][0]
    np.testing.assert_allclose(other["colors"], [[1.0, 1.0, 1.0]], rtol=1e-12)
    nothing = cases["nothing at the output"]
    assert nothing["colors"] == []                              # Cycles leaves such a light out too
    assert any("light 'Sun': nothing is linked to its Light Output" in w for w in nothing["warnings"])


def render_pixels(scene, engine: str, path: str, samples: int, reference: str | None = None):
    """Render `scene` with `engine` ("PRIMER", or "CYCLES" set up as Primer's reference by tools/render.py) at
    `samples` samples into the EXR `path`, and return its pixels (H, W, channels) float64, rows bottom first.
    With a `reference` label (unique within the test file), Cycles' image is the committed reference of it while
    its key matches (tests/cycles_references.py scripted_reference), rendered only when missing or stale."""
    import bpy
    import numpy as np
    from render import configure_cycles_reference, configure_output
    scene.render.engine = engine
    if engine == "CYCLES":
        configure_cycles_reference(scene, samples)
    else:
        scene.primer.samples = samples
    configure_output(scene, path)
    render_still(scene, path, reference)
    image = bpy.data.images.load(path)
    pixels = np.array(image.pixels[:], np.float64).reshape(image.size[1], image.size[0], image.channels)
    bpy.data.images.remove(image)
    return pixels


def render_still(scene, path: str, reference: str | bool | None = None) -> None:
    """Write `scene`'s image to `path`, its output set up (configure_output): rendered, or for Cycles with a
    `reference` label the committed reference of it while its key matches (tests/cycles_references.py)."""
    import bpy
    if reference and scene.render.engine == "CYCLES":
        import cycles_references
        cycles_references.scripted_reference(scene, reference, path)
    else:
        bpy.ops.render.render(write_still=True)


def empty_material(name: str):
    """A new material whose node tree holds its Material Output alone: (material, tree, output node)."""
    import bpy
    material = bpy.data.materials.new(name)
    if material.node_tree is None:                  # Blender 4.x: node trees are opt-in
        material.use_nodes = True
    tree = material.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    return material, tree, next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")


def diffuse_material(name: str = "Diffuse", albedo=(0.8, 0.8, 0.8)):
    """A material that Cycles and Primer both render as a Lambert surface of `albedo`: a Diffuse BSDF
    (Blender 4.x without nodes: its viewport colour, which Cycles renders the same way)."""
    import bpy
    material = bpy.data.materials.new(name)
    material.diffuse_color = (*albedo, 1.0)
    tree = material.node_tree
    if tree is not None and (bpy.app.version >= (5, 0, 0) or material.use_nodes):
        tree.nodes.clear()
        output = tree.nodes.new("ShaderNodeOutputMaterial")
        diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*albedo, 1.0)
        tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    return material


def lambert_everywhere(scene, albedo=(0.8, 0.8, 0.8)):
    """Render every surface of `scene` as the lecture's grey Lambert surface: the view layer's Material
    Override (Cycles' default surface is a Principled BSDF, whose specular layer the lecture's closed forms
    leave out)."""
    scene.view_layers[0].material_override = diffuse_material("Lecture Lambert", albedo)


def primer_in_blender():
    """Inside Blender: Primer registered from this checkout as tools/render.py loads it, and its add-on's export
    module: (the primer package, addon.export)."""
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    from render import load_primer
    primer = load_primer()
    return primer, sys.modules[primer.__name__ + ".addon.export"]


def fresh_scene(width: int = 0, height: int = 0):
    """Inside Blender: Primer loaded, the empty factory scene, width x height px if given: (primer, export, scene)."""
    import bpy
    primer, export = primer_in_blender()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    if width and height:
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    return primer, export, scene


def ortho_camera(scene, ortho_scale: float, location=(0.0, 0.0, 5.0)):
    """Inside Blender: the scene's camera, orthographic, `ortho_scale` wide, at `location` looking down -Z."""
    import bpy
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", float(ortho_scale)
    camera.location = location
    scene.collection.objects.link(camera)
    scene.camera = camera
    return camera


def points_by_index(obj, material, radius: float, step: float) -> None:
    """Inside Blender: a geometry-nodes modifier making `obj`'s vertices points of `material`, radius + step x index."""
    import bpy
    tree = bpy.data.node_groups.new("To Points", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    given, result = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    to_points, paint = tree.nodes.new("GeometryNodeMeshToPoints"), tree.nodes.new("GeometryNodeSetMaterial")
    index, size = tree.nodes.new("GeometryNodeInputIndex"), tree.nodes.new("ShaderNodeMath")
    size.operation, size.inputs[1].default_value, size.inputs[2].default_value = "MULTIPLY_ADD", step, radius
    tree.links.new(index.outputs[0], size.inputs[0])
    tree.links.new(size.outputs[0], to_points.inputs["Radius"])
    paint.inputs["Material"].default_value = material
    tree.links.new(given.outputs[0], to_points.inputs[0])
    tree.links.new(to_points.outputs[0], paint.inputs[0])
    tree.links.new(paint.outputs[0], result.inputs[0])
    obj.modifiers.new("Points", "NODES").node_group = tree


def pixel_size_wires(size: float, strength: float = 1.0):
    """A material "Wire" emitting a Wireframe node's Fac (Pixel Size on, `size` pixels wide) at `strength`."""
    material, tree, out = empty_material("Wire")
    wire, emission = tree.nodes.new("ShaderNodeWireframe"), tree.nodes.new("ShaderNodeEmission")
    wire.use_pixel_size = True
    wire.inputs["Size"].default_value = size
    emission.inputs["Strength"].default_value = strength
    tree.links.new(wire.outputs["Fac"], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    return material


def level_square(scene, name: str, x: float, z: float, size: float, material):
    """Link a horizontal square mesh object `name` of side `size`, centred at (x, 0, z), facing +Z, with `material`."""
    import bpy

    mesh = bpy.data.meshes.new(name)
    h = size / 2
    mesh.from_pydata([(x - h, -h, z), (x + h, -h, z), (x + h, h, z), (x - h, h, z)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new(name, mesh))


def grid_plane(cases: list, label: str, material, columns: int):
    """Inside Blender: a unit plane `label` of `material` in render_plane_grid's cell len(cases); appends label."""
    import bpy
    index = len(cases)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(index % columns + 0.5, -(index // columns) - 0.5, 0.0))
    plane = bpy.context.view_layer.objects.active
    plane.name = label
    plane.data.materials.append(material)
    cases.append(label)
    return plane


def snapped_generated(tree, pixels: int):
    """Inside Blender: Math nodes in `tree` giving the Generated coordinate snapped to its pixel's centre and mapped
    to -2..2, (floor(pixels g) + 0.5) / pixels x 4 - 2 (every step exact in float32 and float64), so that every sample
    of a pixel reads the same value whichever renderer places it: (the Vector socket (x, y, 0.375), the x socket, the
    y socket)."""
    coords = tree.nodes.new("ShaderNodeTexCoord")
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(coords.outputs["Generated"], separate.inputs["Vector"])
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    combine.inputs["Z"].default_value = 0.375
    ends = []
    for axis in ("X", "Y"):
        steps = [("MULTIPLY", pixels), ("FLOOR", 0.0), ("ADD", 0.5), ("MULTIPLY", 4.0 / pixels), ("SUBTRACT", 2.0)]
        socket = separate.outputs[axis]
        for operation, value in steps:
            math = tree.nodes.new("ShaderNodeMath")
            math.operation = operation
            math.inputs[1].default_value = value
            tree.links.new(socket, math.inputs[0])
            socket = math.outputs[0]
        tree.links.new(socket, combine.inputs[axis])
        ends.append(socket)
    return combine.outputs["Vector"], ends[0], ends[1]


def render_plane_grid(scene, export, columns: int, rows: int, pixels: int, samples: int = 1,
                      reference: str | None = None) -> list:
    """Inside Blender: a grid of `columns` x `rows` unit cells (cell k centred at (k % columns + 1/2,
    -(k // columns) - 1/2, 0)) seen from above by an orthographic camera, `pixels` pixels across each, rendered at
    `samples` samples by Primer and by Cycles (the committed `reference`, if named: render_pixels) into primer.npy
    and cycles.npy (rows top first, RGB); returns the export's warnings."""
    import bpy
    import numpy as np
    ortho_camera(scene, columns, (columns / 2, -rows / 2, 5.0))
    scene.render.resolution_x, scene.render.resolution_y = columns * pixels, rows * pixels
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    for engine in ("PRIMER", "CYCLES"):
        image = render_pixels(scene, engine, os.path.abspath(engine.lower() + ".exr"), samples, reference)[::-1, :, :3]
        np.save(engine.lower() + ".npy", image)
    return warnings
