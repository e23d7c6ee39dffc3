"""The hair BSDFs on a mesh inside real Blender (the bpy module, no mocks), against Cycles' own render.

On a triangle Cycles' hair closures take their fibre from the triangle's edges: the Principled Hair BSDF (Chiang's
and Huang's models) along dPdu = p1 - p0, the Hair BSDF along dPdv = p2 - p0 with no offset, both in world space
and turned with the normal where the ray meets the triangle from behind, whose back faces scatter as their front.
The Principled Hair BSDF's closure normal there is its fibre frame's axis across the tangent and the view, not the
surface's, so Cycles' bump shadowing zeroes its light samples behind the smooth surface (not its own samples).
A smooth-shaded UV sphere (rotated, stretched; Chiang's h from the triangle's true normal Ng, Huang's from
the smooth normal) and a sheet seen from behind, lit by a sun and a grey world, wear each
hair material in turn.
"""
from __future__ import annotations

import numpy as np
import pytest

from blender_env import run_bpy
from core.film.compare import relative_mse_of_blocks

pytestmark = pytest.mark.blender

PRIMER_SAMPLES, CYCLES_SAMPLES = 64, 256
CASES = ("hair_reflection", "hair_transmission", "chiang_melanin", "chiang_absorption", "huang")

SCRIPT = """
import math, os
import bpy
import numpy as np
from blender_env import empty_material, primer_in_blender, render_pixels, report
primer, export = primer_in_blender()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 24, 100
world = bpy.data.worlds.new("World")
if world.node_tree is None:
    world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.25, 0.25, 0.3, 1.0)
scene.world = world
bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=8, radius=1.0, location=(-0.9, 0.0, 0.0),
                                     rotation=(0.4, 0.2, 0.7), scale=(1.0, 0.8, 1.2))
sphere = bpy.context.active_object
bpy.ops.object.shade_smooth()                       # (Chiang's h reads the triangle's true normal, Huang's the smooth one)
scene.primer.terminator_fix = True                  # (Cycles' shadow terminator offset on smooth triangles)
sheet_mesh = bpy.data.meshes.new("Sheet")
sheet_mesh.from_pydata([(0, 0, 0), (1.6, 0.2, 0), (1.5, 1.7, 0.3), (0.1, 1.5, 0.2)], [], [(0, 1, 2, 3)])
sheet_mesh.flip_normals()
sheet = bpy.data.objects.new("Sheet", sheet_mesh)
sheet.location, sheet.rotation_euler = (0.4, -0.8, 0.0), (0.5, 0.3, 0.2)
scene.collection.objects.link(sheet)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy, sun.rotation_euler = 3.0, (0.6, 0.3, 0.4)
scene.collection.objects.link(sun)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.data.type, camera.data.ortho_scale = "ORTHO", 4.0
camera.location = (0.0, 0.0, 5.0)
scene.collection.objects.link(camera)
scene.camera = camera
results = {{}}
for name in {cases!r}:
    material, tree, output = empty_material(name)
    if name.startswith("hair_"):
        node = tree.nodes.new("ShaderNodeBsdfHair")
        node.component = "Transmission" if name == "hair_transmission" else "Reflection"
        node.inputs["Color"].default_value = (0.8, 0.55, 0.3, 1.0)
        node.inputs["Offset"].default_value = 0.05
        node.inputs["RoughnessU"].default_value = 0.2
        node.inputs["RoughnessV"].default_value = 0.4
    else:
        node = tree.nodes.new("ShaderNodeBsdfHairPrincipled")
        node.model = "HUANG" if name == "huang" else "CHIANG"
        node.inputs["Roughness"].default_value = 0.35
        if node.inputs.get("Radial Roughness") is not None:
            node.inputs["Radial Roughness"].default_value = 0.4
        if name == "chiang_absorption":
            node.parametrization = "ABSORPTION"
            node.inputs["Absorption Coefficient"].default_value = (0.2, 0.5, 1.2)
        else:
            node.parametrization = "MELANIN"
            node.inputs["Melanin"].default_value = 0.35
            node.inputs["Melanin Redness"].default_value = 0.6
            node.inputs["Offset"].default_value = math.radians(4.0)
            if node.inputs.get("Coat") is not None:
                node.inputs["Coat"].default_value = 0.3
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    for obj in (sphere, sheet):
        obj.data.materials.clear()
        obj.data.materials.append(material)
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    p = render_pixels(scene, "PRIMER", os.path.abspath(name + "_primer.exr"), {primer})[..., :3]
    c = render_pixels(scene, "CYCLES", os.path.abspath(name + "_cycles.exr"), {cycles}, "smooth_mesh_" + name)[..., :3]
    np.save(name + "_primer.npy", p)
    np.save(name + "_cycles.npy", c)
    results[name] = warnings
primer.unregister()
report(warnings=results)
"""


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """Every case rendered by Primer and Cycles in one Blender session: (folder, warnings by case)."""
    folder = tmp_path_factory.mktemp("hairmesh")
    report = run_bpy(SCRIPT.format(primer=PRIMER_SAMPLES, cycles=CYCLES_SAMPLES, cases=CASES), str(folder))
    return folder, report["warnings"]


# The block relMSE each case stays under (measured, with margin for the two renders' noise).
BOUNDS = {"hair_reflection": 1e-4, "hair_transmission": 1e-4, "chiang_melanin": 1.5e-4, "chiang_absorption": 1.5e-4,
          "huang": 3e-4}


@pytest.mark.parametrize("case", CASES)
def test_a_hair_bsdf_on_a_mesh_takes_its_fibre_from_the_triangles_edges_as_cycles(case, renders):
    """Each hair material on a smooth-shaded sphere and a sheet seen from behind: block relMSE against Cycles within
    BOUNDS (the Principled Hair BSDF's light samples shadowed by Cycles' bump shadowing against its fibre frame's
    normal, its own sampled directions not), and nothing said: Huang's note on curves' elliptical fibres is not drawn
    by a material on meshes alone."""
    folder, warnings = renders
    primer, cycles = np.load(folder / f"{case}_primer.npy"), np.load(folder / f"{case}_cycles.npy")
    error = relative_mse_of_blocks(primer, cycles)
    lit = np.abs(cycles - cycles[0, 0]).max(axis=2) > 0.005
    ratio = primer[lit].mean(axis=0) / cycles[lit].mean(axis=0)
    print(case, "block relMSE", error, "surface pixels", lit.mean(), "mean ratio", ratio, warnings[case])
    assert lit.mean() > 0.2
    # (Huang's default Aspect Ratio, 0.85, would draw the note on curves' elliptical fibres; a triangle's are round)
    assert not warnings[case], warnings[case]
    assert error < BOUNDS[case]
