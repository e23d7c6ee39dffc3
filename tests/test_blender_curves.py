"""Hair curves (Blender's Curves object) and point clouds inside real Blender (the bpy module, no mocks), against Cycles' own render.

Cycles renders each curve as a round tube along the Catmull-Rom spline through its points; Primer as a tube of
triangles around the same spline (core/geometry/curves.py). A few thick wavy curves of a red diffuse material, with a
radius that tapers, lie over a grey floor under a sun, seen from above by an orthographic camera: the strands, their
shading and their shadows on the floor, held to the project's measure (the relative MSE of 4 x 4-pixel block means);
the same with twelve points of growing radius made by geometry nodes (Cycles' spheres; Primer's icospheres), and
with thirty tapering particle hairs grown sideways from an upright emitter.
"""
from __future__ import annotations

import numpy as np
import pytest

from blender_env import run_bpy
from core.film.compare import relative_mse_of_blocks

pytestmark = pytest.mark.blender

PRIMER_SAMPLES, CYCLES_SAMPLES = 64, 256

SCRIPT = """
import math, os
import bpy
import numpy as np
from blender_env import diffuse_material, fresh_scene, ortho_camera, points_by_index, primer_in_blender, render_pixels
from blender_env import report
primer, export = primer_in_blender()


def render_case(case):
    # The case's scene built afresh, rendered by Primer and Cycles into <case>_primer.npy and <case>_cycles.npy;
    # returns the export's warnings.
    scene = fresh_scene(64, 48)[2]
    floor = bpy.data.meshes.new("Floor")
    floor.from_pydata([(-4, -3, 0), (4, -3, 0), (4, 3, 0), (-4, 3, 0)], [], [(0, 1, 2, 3)])
    floor.materials.append(diffuse_material("Grey", (0.5, 0.5, 0.5)))
    scene.collection.objects.link(bpy.data.objects.new("Floor", floor))
    # Five wavy strands of 6 points each across the view, 0.3 above the floor, their radius tapering 0.12 -> 0.04.
    hair = bpy.data.hair_curves.new("Hair")
    hair.add_curves([6] * 5)
    positions = [(-2.5 + x, -1.6 + 0.8 * k + 0.35 * math.sin(2.0 * x + k), 0.3 + 0.1 * math.cos(3.0 * x))
                 for k in range(5) for x in np.linspace(0.0, 5.0, 6)]
    hair.position_data.foreach_set("vector", np.array(positions, np.float32).ravel())
    radius = hair.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", np.tile(np.linspace(0.12, 0.04, 6), 5).astype(np.float32))
    red = diffuse_material("Red", (0.8, 0.1, 0.1))
    if case == "particle_hair":
        # Thirty particle hairs (Hair type, rendered as Path) 1.5 long, root diameter 0.08 tapering to 0, grown
        # sideways from an upright emitter plane in its second material slot (red).
        bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0.0, 1.6, 0.6), rotation=(math.pi / 2, 0.0, 0.0))
        emitter = bpy.context.view_layer.objects.active
        emitter.data.materials.append(diffuse_material("Grey Emitter", (0.5, 0.5, 0.5)))
        emitter.data.materials.append(red)
        emitter.modifiers.new("Hair", "PARTICLE_SYSTEM")
        settings = emitter.particle_systems[0].settings
        settings.type, settings.count, settings.hair_length = "HAIR", 30, 1.5
        settings.radius_scale, settings.root_radius, settings.tip_radius, settings.material = 0.08, 1.0, 0.0, 2
    elif case == "point_cloud":
        # Twelve points of radius 0.1 to 0.32 made by geometry nodes (Mesh to Points), red.
        cloud = bpy.data.meshes.new("Cloud")
        cloud.from_pydata([(-2.4 + 0.45 * k, 1.4 * math.sin(1.3 * k), 0.4) for k in range(12)], [], [])
        obj = bpy.data.objects.new("Cloud", cloud)
        points_by_index(obj, red, 0.1, 0.02)
        scene.collection.objects.link(obj)
    else:
        hair.materials.append(red)
        scene.collection.objects.link(bpy.data.objects.new("Hair", hair))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 3.0, (0.5, 0.3, 0.0)
    scene.collection.objects.link(sun)
    ortho_camera(scene, 6.0)
    warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    p = render_pixels(scene, "PRIMER", os.path.abspath(case + "_primer.exr"), {primer})[..., :3]
    c = render_pixels(scene, "CYCLES", os.path.abspath(case + "_cycles.exr"), {cycles}, case)[..., :3]
    np.save(case + "_primer.npy", p)
    np.save(case + "_cycles.npy", c)
    return warnings


warnings = {{case: render_case(case) for case in {cases!r}}}
primer.unregister()
report(warnings=warnings)
"""
# The three cases, each its own scene, rendered in one Blender process (one start and one registration of Primer).
CASES = ["hair_curves", "point_cloud", "particle_hair"]


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Every case rendered by Primer and Cycles (Cycles' the committed references while their keys match): (the
    export's warnings by case, the folder holding <case>_primer.npy and <case>_cycles.npy)."""
    folder = tmp_path_factory.mktemp("curves")
    report = run_bpy(SCRIPT.format(primer=PRIMER_SAMPLES, cycles=CYCLES_SAMPLES, cases=CASES), str(folder))
    return report["warnings"], folder


@pytest.mark.parametrize("case", CASES)
def test_curves_and_points_render_as_cycles_round_strands_and_spheres_with_their_shadows(case, rendered):
    """The strands (or a point cloud's spheres) cover the same pixels with the same shading and cast the same
    shadows as in Cycles: block relMSE within Cycles' own noise at these samples, red where they are, and no warning
    that they are not rendered."""
    warnings, folder = rendered
    print(warnings[case])
    assert not [w for w in warnings[case] if "of type" in w or "not render" in w], warnings[case]
    primer, cycles = np.load(folder / f"{case}_primer.npy"), np.load(folder / f"{case}_cycles.npy")
    strands = (cycles[..., 0] > 1.5 * cycles[..., 1]) & (cycles[..., 0] > 0.05)
    print("strand pixels", strands.mean(), "Primer", (primer[..., 0] > 1.5 * primer[..., 1]).mean())
    assert 0.03 < strands.mean() < 0.5
    error = relative_mse_of_blocks(primer, cycles)
    print("block relMSE", error, "means", primer.mean(axis=(0, 1)), cycles.mean(axis=(0, 1)))
    assert error < 1e-3
