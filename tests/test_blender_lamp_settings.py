"""Cycles' per-lamp settings read from Blender and rendered as Cycles renders them (the bpy module, no mocks).

One bpy process builds a small scene (a grey floor, an occluder over part of it, a lamp), changes one setting per
case, and renders each case with Primer and with Cycles (24 x 16 pixels, Primer 32 samples, Cycles 128); each case
reports the lamp's exported fields, the export's warnings and the relative MSE of 4 x 4-pixel block means,
mean((B(P) - B(C))^2 / (B(C)^2 + 0.01)), the project's measure (tests/test_blender_scenes.py).
"""
from __future__ import annotations

import pytest

from blender_env import run_bpy

pytestmark = pytest.mark.blender

PRIMER_SAMPLES, CYCLES_SAMPLES = 32, 128
BLOCK_TOLERANCE = 2e-3

SCRIPT = """
import math, os
import bpy
import numpy as np
from blender_env import diffuse_material, fresh_scene, ortho_camera, render_pixels, report
primer, export, scene = fresh_scene(24, 16)
material = diffuse_material("Floor", (0.8, 0.8, 0.8))
principled = bpy.data.materials.new("Principled")      # Blender's default surface: diffuse and a glossy layer
principled.use_nodes = True
principled.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.3
metal = bpy.data.materials.new("Metal")                 # a smooth metal: a mirror of the lamps
metal.use_nodes = True
metal.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
metal.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.0


def plane(name, corners):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


plane("Floor", [(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)])
plane("Occluder", [(0.5, -4, 0.6), (1.5, -4, 0.6), (1.5, 4, 0.6), (0.5, 4, 0.6)])
camera = ortho_camera(scene, 6.0)


def lamp(kind, location, energy, **settings):
    obj = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", kind))
    obj.location = location
    obj.data.energy = energy
    for name, value in settings.items():
        target = obj
        for part in name.split(".")[:-1]:
            target = getattr(target, part)
        setattr(target, name.split(".")[-1], value)
    scene.collection.objects.link(obj)
    return obj


def blocks(image):
    h, w = image.shape[0] // 4 * 4, image.shape[1] // 4 * 4
    return image[:h, :w].reshape(h // 4, 4, w // 4, 4, -1).mean(axis=(1, 3))


def case(name, kind, location, energy, surface=None, samples={primer_samples}, cycles_samples={cycles_samples},
         **settings):
    obj = lamp(kind, location, energy, **settings)
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = surface or material
    warnings = []
    core = export.export_light(bpy.context.evaluated_depsgraph_get().objects[obj.name],
                               np.array(obj.matrix_world, np.float64), warnings)
    fields = dict() if core is None else {{k: v for k, v in vars(core).items() if isinstance(v, (bool, int, float))}}
    p = render_pixels(scene, "PRIMER", os.path.abspath(name + "_primer.exr"), samples)[..., :3]
    c = render_pixels(scene, "CYCLES", os.path.abspath(name + "_cycles.exr"), cycles_samples, name)[..., :3]
    bp, bc = blocks(p), blocks(c)
    cases[name] = dict(fields=fields, warnings=warnings, rel_mse=float(np.mean((bp - bc) ** 2 / (bc ** 2 + 0.01))),
                       primer_mean=float(p.mean()), cycles_mean=float(c.mean()))
    bpy.data.objects.remove(obj)


def world_case(name, **settings):
    # Light the scene by an image world (a sky brighter overhead) with the world's Cycles settings, lamp-free.
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    tree = world.node_tree
    image = bpy.data.images.new(name, 32, 16, float_buffer=True)
    rows = np.linspace(0.05, 2.0, 16)[:, None, None] * np.ones((16, 32, 4))
    rows[..., 3] = 1.0
    image.pixels[:] = rows.ravel().tolist()
    texture = tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    tree.links.new(texture.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    if not all(hasattr(world.cycles, key) for key in settings):      # (Shadows: Blender 5.2's, not 5.0's)
        cases[name] = None
        return
    for key, value in settings.items():
        setattr(world.cycles, key, value)
    scene.world = world
    p = render_pixels(scene, "PRIMER", os.path.abspath(name + "_primer.exr"), {primer_samples})[..., :3]
    c = render_pixels(scene, "CYCLES", os.path.abspath(name + "_cycles.exr"), {cycles_samples}, name)[..., :3]
    core = export.world_light_settings(world, export.export_world(world, []))
    bp, bc = blocks(p), blocks(c)
    cases[name] = dict(fields=dict(max_bounces=core.max_bounces, cast_shadow=core.cast_shadow), warnings=[],
                       rel_mse=float(np.mean((bp - bc) ** 2 / (bc ** 2 + 0.01))), primer_mean=float(p.mean()),
                       cycles_mean=float(c.mean()))
    scene.world = None


cases = {{}}
for name in {cases!r}:
    if name == "cast shadow off":
        case(name, "POINT", (2.0, 0.0, 1.2), 300.0, **{{"data.use_shadow": False, "data.shadow_soft_size": 0.2}})
    elif name == "cast shadow on":
        case(name, "POINT", (2.0, 0.0, 1.2), 300.0, **{{"data.shadow_soft_size": 0.2}})
    elif name.startswith("hidden from "):
        kind = name.split()[-1]
        case(name, "AREA", (0.0, 0.0, 1.5), 200.0, surface=principled,
             **{{"data.size": 2.0, "rotation_euler": (0.3, 0.0, 0.0), "visible_" + kind: False}})
    elif name == "mis off":
        case(name, "AREA", (0.0, 0.0, 1.5), 200.0, surface=principled,
             **{{"data.size": 2.0, "rotation_euler": (0.3, 0.0, 0.0), "data.cycles.use_multiple_importance_sampling": False}})
    elif name.startswith("max bounces"):
        scene.primer.integrator, scene.primer.max_bounces, scene.primer.diffuse_bounces = "PATH", 2, 2
        case(name, "POINT", (2.0, 0.0, 0.4), 300.0, **{{"data.cycles.max_bounces": int(name.split()[-1])}})
        scene.primer.integrator = "DIRECT"
    elif name == "negative lamp":
        sun = lamp("SUN", (0.0, 0.0, 3.0), 3.0)
        case(name, "AREA", (0.0, 0.0, 1.5), -30.0, surface=principled, **{{"data.size": 2.0}})
        bpy.data.objects.remove(sun)
    elif name == "metal spot":
        case(name, "SPOT", (0.3, 0.0, 2.0), 500.0, surface=metal,
             **{{"data.shadow_soft_size": 0.6, "data.spot_size": 1.0, "rotation_euler": (0.0, 0.5, 0.0)}})
    elif name == "metal point":
        case(name, "POINT", (0.3, 0.0, 2.0), 500.0, surface=metal, **{{"data.shadow_soft_size": 0.6}})
    elif name == "metal sun":
        case(name, "SUN", (0.0, 0.0, 3.0), 3.0, surface=metal, **{{"data.angle": 0.3, "rotation_euler": (0.05, 0.0, 0.0)}})
    elif name.startswith("world max bounces"):
        scene.primer.integrator, scene.primer.max_bounces, scene.primer.diffuse_bounces = "PATH", 2, 2
        world_case(name, max_bounces=int(name.split()[-1]))
        scene.primer.integrator = "DIRECT"
    elif name == "sun seen by camera":
        # A perspective camera looking down past the floor and occluder (hidden from it) at a sun's disc below.
        camera.data.type = "PERSP"
        for obj in (bpy.data.objects["Floor"], bpy.data.objects["Occluder"]):
            obj.visible_camera = False
        case(name, "SUN", (0.0, 0.0, 3.0), 3.0, **{{"data.angle": 0.3, "rotation_euler": (math.pi + 0.08, 0.05, 0.0),
                                              "visible_camera": True}})
        for obj in (bpy.data.objects["Floor"], bpy.data.objects["Occluder"]):
            obj.visible_camera = True
        camera.data.type = "ORTHO"
    elif name.startswith("lamp nodes"):
        # The lamp's Emission fed by nodes: constant ones (a Blackbody colour, a Math strength), or a varying one.
        data = bpy.data.lights.new("Lamp with nodes", "POINT")
        data.energy, data.shadow_soft_size = 300.0, 0.2
        if hasattr(data, "use_nodes"):
            data.use_nodes = True
        tree = data.node_tree
        emission = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeEmission")
        if name.endswith("constant"):
            blackbody = tree.nodes.new("ShaderNodeBlackbody")
            blackbody.inputs["Temperature"].default_value = 3200.0
            math_node = tree.nodes.new("ShaderNodeMath")
            math_node.operation = "MULTIPLY"
            math_node.inputs[0].default_value, math_node.inputs[1].default_value = 2.0, 0.75
            tree.links.new(blackbody.outputs["Color"], emission.inputs["Color"])
            tree.links.new(math_node.outputs["Value"], emission.inputs["Strength"])
        else:
            coordinates = tree.nodes.new("ShaderNodeTexCoord")
            separate = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(coordinates.outputs["Normal"], separate.inputs["Vector"])
            tree.links.new(separate.outputs["Z"], emission.inputs["Strength"])
        case(name, "POINT", (2.0, 0.0, 1.2), 300.0, **{{"data": data}})
    elif name.startswith("narrow spread"):
        # A lamp of 15 degree Spread, tilted: both renderers sample only the part of it that can light each point.
        # (Cycles' square at 128 samples alone leaves a block relative MSE of 1.5e-3: more samples for both.)
        case(name, "AREA", (0.0, 0.0, 1.5), 200.0, samples=128, cycles_samples=1024, **{{"data.size": 2.0, "data.spread": math.radians(15.0),
                                                   "data.shape": name.split()[-1].upper(),
                                                   "rotation_euler": (0.3, 0.0, 0.0)}})
    elif name == "shadow caustics":
        # A smooth glass ball over the floor (a caustics caster and receiver), a point lamp with Shadow Caustics:
        # Cycles' MNEE, Primer's compiled kernels (core/integrators/mnee.c, the twin of mnee.py), path traced.
        import bmesh
        primer_settings = (scene.primer.integrator, scene.primer.max_bounces, scene.primer.diffuse_bounces,
                           scene.primer.glossy_bounces, scene.primer.transmission_bounces, scene.primer.kernels)
        scene.primer.integrator, scene.primer.max_bounces, scene.primer.diffuse_bounces = "PATH", 4, 1
        scene.primer.glossy_bounces, scene.primer.transmission_bounces, scene.primer.kernels = 1, 4, "COMPILED"
        mesh = bpy.data.meshes.new("Ball")
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=0.8)
        bm.to_mesh(mesh)
        bm.free()
        for polygon in mesh.polygons:
            polygon.use_smooth = True
        glass = bpy.data.materials.new("Glass")
        glass.use_nodes = True
        tree = glass.node_tree
        bsdf = tree.nodes.new("ShaderNodeBsdfGlass")
        bsdf.inputs["IOR"].default_value = 1.5
        bsdf.inputs["Roughness"].default_value = 0.0
        output = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeOutputMaterial")
        tree.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
        mesh.materials.append(glass)
        ball = bpy.data.objects.new("Ball", mesh)
        ball.location, ball.rotation_euler = (-2.0, 0.0, 1.2), (math.pi / 2, 0.0, 0.0)    # (its poles sideways)
        ball.cycles.is_caustics_caster = True
        scene.collection.objects.link(ball)
        floor = bpy.data.objects["Floor"]
        floor.cycles.is_caustics_receiver = True
        case(name, "POINT", (-2.0, 0.0, 4.0), 300.0, **{{"data.shadow_soft_size": 0.0,
                                                      "data.cycles.is_caustics_light": True}})
        floor.cycles.is_caustics_receiver = False
        bpy.data.objects.remove(ball)
        (scene.primer.integrator, scene.primer.max_bounces, scene.primer.diffuse_bounces, scene.primer.glossy_bounces,
         scene.primer.transmission_bounces, scene.primer.kernels) = primer_settings
    elif name == "seen by all":
        case(name, "AREA", (0.0, 0.0, 1.5), 200.0, surface=principled,
             **{{"data.size": 2.0, "rotation_euler": (0.3, 0.0, 0.0)}})
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(cases=cases)
"""


# Every case, rendered in one Blender process (one start and one registration of Primer for the file's tests).
# The cases that path-trace (Max Bounces, the lamp's and the world's) come last: each sets the integrator itself.
CASES = ["cast shadow off", "cast shadow on", "seen by all", "hidden from diffuse", "hidden from glossy",
         "hidden from camera", "mis off", "negative lamp", "metal point", "metal spot", "metal sun",
         "sun seen by camera", "lamp nodes constant", "lamp nodes varying", "narrow spread square", "narrow spread disk",
         "shadow caustics", "max bounces 0", "max bounces 1024",
         "world max bounces 0", "world max bounces 1024"]


@pytest.fixture(scope="module")
def all_cases(tmp_path_factory):
    """Each of CASES rendered with Primer and Cycles (Cycles' the committed references while their keys match):
    {name: its report}."""
    return run_bpy(SCRIPT.format(primer_samples=PRIMER_SAMPLES, cycles_samples=CYCLES_SAMPLES, cases=CASES),
                   str(tmp_path_factory.mktemp("lamp_settings")))["cases"]


def run_cases(all_cases, names):
    """The named cases' reports of the file's one render of every case: {name: its report}."""
    return {name: all_cases[name] for name in names}


def test_cast_shadow_off_is_read_without_a_warning_and_renders_as_cycles(all_cases):
    """A point lamp with Cast Shadow off lights the floor under the occluder: Primer's image is Cycles' (block
    relMSE below the tolerance) and brighter than with the shadow cast; the export reads it with no warning."""
    cases = run_cases(all_cases, ["cast shadow off", "cast shadow on"])
    off, on = cases["cast shadow off"], cases["cast shadow on"]
    print({name: c["rel_mse"] for name, c in cases.items()})
    assert off["fields"]["cast_shadow"] is False and on["fields"]["cast_shadow"] is True
    assert off["warnings"] == [] and on["warnings"] == []
    assert off["rel_mse"] < BLOCK_TOLERANCE and on["rel_mse"] < BLOCK_TOLERANCE
    assert off["cycles_mean"] > 1.1 * on["cycles_mean"]


def test_a_lamps_ray_visibility_is_read_without_a_warning_and_renders_as_cycles(all_cases):
    """An area lamp over a Principled floor (diffuse under a glossy layer, roughness 0.3) hidden from diffuse,
    glossy or camera rays: the export reads the bits with no warning, and Primer's image is Cycles' in each case
    (diffuse and glossy differ from the lamp seen by all, so the test can tell)."""
    names = ["seen by all", "hidden from diffuse", "hidden from glossy", "hidden from camera"]
    cases = run_cases(all_cases, names)
    print({name: (c["rel_mse"], c["cycles_mean"]) for name, c in cases.items()})
    assert [cases[name]["fields"]["hidden_from"] for name in names] == [0, 4, 8, 0]
    assert cases["hidden from camera"]["fields"]["camera"] is False
    for name in names:
        assert cases[name]["warnings"] == []
        assert cases[name]["rel_mse"] < BLOCK_TOLERANCE, name
    for name in names[1:3]:
        assert cases[name]["cycles_mean"] < 0.97 * cases["seen by all"]["cycles_mean"]


def test_multiple_importance_off_is_read_without_a_warning_and_renders_as_cycles(all_cases):
    """An area lamp with Multiple Importance off over the Principled floor: read with no warning, and Primer's image
    (light samples alone) is Cycles'."""
    case = run_cases(all_cases, ["mis off"])["mis off"]
    print(case["rel_mse"])
    assert case["fields"]["use_mis"] is False and case["warnings"] == []
    assert case["rel_mse"] < BLOCK_TOLERANCE


def test_max_bounces_is_read_without_a_warning_and_renders_as_cycles(all_cases):
    """A point lamp beside the occluder, path-traced with 2 bounces: with its Max Bounces 0 it lights the floor
    directly only (the occluder's underside sends nothing back), as in Cycles, and the image is darker than with
    Max Bounces 1024 (the test can tell)."""
    cases = run_cases(all_cases, ["max bounces 0", "max bounces 1024"])
    print({name: (c["rel_mse"], c["primer_mean"], c["cycles_mean"]) for name, c in cases.items()})
    limited, every = cases["max bounces 0"], cases["max bounces 1024"]
    assert limited["fields"]["max_bounces"] == 0 and limited["warnings"] == []
    assert limited["rel_mse"] < BLOCK_TOLERANCE
    # (With every bounce lit the 32-sample path-traced floor is noisy: its blocks within 1e-2, its mean within 2%.)
    assert every["rel_mse"] < 1e-2 and abs(every["primer_mean"] / every["cycles_mean"] - 1.0) < 0.02
    assert limited["cycles_mean"] < 0.97 * every["cycles_mean"]


def test_a_negative_lamp_is_read_without_a_warning_and_renders_as_cycles(all_cases):
    """An area lamp of power -30 W under a sun of strength 3 over the Principled floor: Cycles subtracts its light,
    and so does Primer (block relMSE below the tolerance), with no warning."""
    case = run_cases(all_cases, ["negative lamp"])["negative lamp"]
    print(case["rel_mse"], case["primer_mean"], case["cycles_mean"])
    assert case["fields"]["power"] == -30.0 and case["warnings"] == []
    assert case["rel_mse"] < BLOCK_TOLERANCE


def test_a_smooth_metal_shows_point_spot_and_sun_lamps_as_cycles(all_cases):
    """A smooth metal floor (Principled, Metallic 1, Roughness 0) mirrors a round point lamp, a round spot lamp whose
    cone cuts its disk, and a sun disk of 0.3 rad seen straight up: Primer's images are Cycles' (direct light)."""
    cases = run_cases(all_cases, ["metal point", "metal spot", "metal sun"])
    print({name: (c["rel_mse"], c["primer_mean"], c["cycles_mean"]) for name, c in cases.items()})
    for name, case in cases.items():
        assert case["warnings"] == [] and case["cycles_mean"] > 0.0, name
        assert case["rel_mse"] < BLOCK_TOLERANCE, name


def test_the_worlds_max_bounces_is_read_and_renders_near_cycles(all_cases):
    """An image world (brighter overhead) lights the floor and occluder, path traced with 2 bounces: with the world's
    Max Bounces 0 its light samples stop after the camera's hits, darker than with 1024, in Primer as in Cycles.
    Measured (128 / 512 samples): 1024 within 0.16 % of Cycles' mean (block relMSE 1.1e-5); 0 darker than Cycles by
    1.2 % (3.0e-4): Primer loses 2.1 % to the limit where Cycles loses 0.8 %, a gap left open (docs/blender.md)."""
    cases = run_cases(all_cases, ["world max bounces 0", "world max bounces 1024"])
    print({name: (c["rel_mse"], c["primer_mean"], c["cycles_mean"]) for name, c in cases.items()})
    limited, every = cases["world max bounces 0"], cases["world max bounces 1024"]
    assert limited["fields"]["max_bounces"] == 0
    assert limited["rel_mse"] < BLOCK_TOLERANCE and every["rel_mse"] < BLOCK_TOLERANCE
    assert abs(limited["primer_mean"] / limited["cycles_mean"] - 1.0) < 0.02
    assert limited["cycles_mean"] < every["cycles_mean"] and limited["primer_mean"] < every["primer_mean"]


def test_a_sun_disc_is_seen_by_camera_rays_that_escape_as_in_cycles(all_cases):
    """A sun of angle 0.3 below a camera whose view passes the floor (hidden from the camera): its disc fills part of
    the image with radiance S / (pi sin^2(angle / 2)), as Cycles adds distant lights to escaping camera rays."""
    sun = run_cases(all_cases, ["sun seen by camera"])["sun seen by camera"]
    print(sun)
    assert sun["warnings"] == []
    assert sun["cycles_mean"] > 1.0
    assert sun["rel_mse"] < BLOCK_TOLERANCE
    assert abs(sun["primer_mean"] / sun["cycles_mean"] - 1.0) < 0.03


def test_a_lamps_emission_fed_by_constant_nodes_renders_as_cycles(all_cases):
    """A point lamp whose Emission takes a Blackbody colour (3200 K) and a Math strength (2 x 0.75): Primer evaluates
    the nodes once, as the materials' node-graph program does, and lights the floor as Cycles does (no warning); a
    strength fed by the lamp's texture coordinates, which vary over it (Normal's Z: the direction leaving the lamp),
    is evaluated per light sample and per ray that meets the lamp (issue 33, core/lights/lamp_graph.py), as Cycles."""
    cases = run_cases(all_cases, ["lamp nodes constant", "lamp nodes varying"])
    for name in ("lamp nodes constant", "lamp nodes varying"):
        case = cases[name]
        print(name, case["rel_mse"], case["primer_mean"], case["cycles_mean"])
        assert case["warnings"] == [] and case["rel_mse"] < BLOCK_TOLERANCE, (name, case)


def test_a_narrow_spread_lamp_renders_as_cycles(all_cases):
    """A square and a disk lamp of 15 degree Spread, tilted 0.3 rad, over the floor and occluder: Primer's light samples
    come from the clamped region (core/lights/area.py spread_region) as Cycles' do, and the floor is Cycles' (block
    relative MSE, and the mean within 2 %), no warning. (Primer 128 samples, Cycles 1024; measured with Primer at 1024
    and Cycles at 2048: block relative MSE 8.5e-5 and 1.9e-5, means 0.10 % and 0.04 % apart.)"""
    cases = run_cases(all_cases, ["narrow spread square", "narrow spread disk"])
    for name, case in cases.items():
        print(name, case["rel_mse"], case["primer_mean"], case["cycles_mean"])
    for name, case in cases.items():
        assert case["fields"]["spread"] < 0.3 and case["warnings"] == [], (name, case)
        assert case["rel_mse"] < BLOCK_TOLERANCE, (name, case)
        assert abs(case["primer_mean"] / case["cycles_mean"] - 1.0) < 0.02, (name, case)


def test_shadow_caustics_through_a_glass_ball_render_as_cycles(all_cases):
    """A smooth glass ball (radius 0.8, 64 x 32 faces) over the floor, a point lamp with Shadow Caustics, path traced
    (4 bounces, 1 diffuse): Cycles finds the lamp's light focused through the ball by manifold next-event estimation,
    and so do Primer's compiled kernels (core/integrators/mnee.c; its Python reference mnee.py is held to them in
    tests/test_mnee.py), with no warning; the lamp's, ball's and floor's
    switches are read."""
    case = run_cases(all_cases, ["shadow caustics"])["shadow caustics"]
    print(case["rel_mse"], case["primer_mean"], case["cycles_mean"])
    assert case["fields"]["caustics"] is True and case["warnings"] == []
    assert case["rel_mse"] < BLOCK_TOLERANCE
    assert abs(case["primer_mean"] / case["cycles_mean"] - 1.0) < 0.02
