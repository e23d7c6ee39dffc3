"""Light linking and shadow linking read from Blender and rendered as Cycles renders them (issue 33): a floor, a cube
and a sphere under two lamps and an emitting plane, with a receiver collection of Included objects, one of Excluded
objects, blocker collections of either kind and a child collection; against Cycles' image, block relMSE within
Cycles' own noise; and the sets read as Blender's depsgraph makes them."""
from __future__ import annotations

import importlib
import math
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

from blender_env import diffuse_material, empty_material, render_pixels  # noqa: E402
from test_blender_volumes import ortho_scene  # noqa: E402

pytestmark = [pytest.mark.blender]


@pytest.fixture(scope="module")
def primer():
    return load_primer()


def collection(name, members):
    """A collection holding `members`: (object or collection, "INCLUDE" or "EXCLUDE") each."""
    made = bpy.data.collections.new(name)
    for member, state in members:
        if isinstance(member, bpy.types.Collection):
            made.children.link(member)
            made.collection_children[len(made.children) - 1].light_linking.link_state = state
        else:
            made.objects.link(member)
            made.collection_objects[len(made.objects) - 1].light_linking.link_state = state
    return made


def linked_scene():
    """The scene: a floor, a cube and a sphere on it; lamp A lights only the floor (a receiver collection that
    Includes it) and only the sphere casts its shadows (a blocker collection Including a child collection that holds
    the sphere); lamp B lights everything but the sphere (a collection that Excludes it) and everything but the cube
    casts its shadows (one that Excludes the cube); an emitting plane out of frame lights only the cube."""
    scene = ortho_scene(32, 24, 4.0)
    scene.primer.integrator = "DIRECT"
    grey = diffuse_material("Grey", (0.6, 0.6, 0.6))
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    floor = bpy.context.object
    floor.name = "Floor"
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(-0.6, 0.3, 0.4))
    cube = bpy.context.object
    cube.name = "Cube"
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.35, location=(0.8, -0.3, 0.35), segments=16, ring_count=8)
    sphere = bpy.context.object
    sphere.name = "Sphere"
    for obj in (floor, cube, sphere):
        obj.data.materials.append(grey)
    a = bpy.data.objects.new("LampA", bpy.data.lights.new("LampA", "POINT"))
    a.location, a.data.energy, a.data.shadow_soft_size = (1.8, -1.2, 1.6), 400.0, 0.1
    b = bpy.data.objects.new("LampB", bpy.data.lights.new("LampB", "POINT"))
    b.location, b.data.energy, b.data.shadow_soft_size = (-1.5, -1.0, 1.2), 300.0, 0.1
    for lamp in (a, b):
        scene.collection.objects.link(lamp)
    a.light_linking.receiver_collection = collection("LitByA", [(floor, "INCLUDE")])
    a.light_linking.blocker_collection = collection("BlocksA", [(collection("Spheres", [(sphere, "EXCLUDE")]),
                                                                  "INCLUDE")])
    b.light_linking.receiver_collection = collection("NotLitByB", [(sphere, "EXCLUDE")])
    b.light_linking.blocker_collection = collection("NotBlockingB", [(cube, "EXCLUDE")])
    glow, tree, output = empty_material("Glow")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 30.0
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    bpy.ops.mesh.primitive_plane_add(size=0.6, location=(-0.6, 2.6, 1.2), rotation=(math.radians(-60.0), 0.0, 0.0))
    panel = bpy.context.object
    panel.name = "Panel"
    panel.data.materials.append(glow)
    panel.light_linking.receiver_collection = collection("LitByPanel", [(cube, "INCLUDE")])
    return scene


def test_the_sets_are_blenders(primer):
    """Lamp A lights set 1 alone (the floor's), B every set but the sphere's; A's shadows the sphere's set alone
    (its state is its child collection's Include), B's every set but the cube's; unlinked objects in set 0."""
    linked_scene()
    linking = sys.modules[primer.__name__ + ".addon.linking"]
    links = linking.LinkSets.of(bpy.context.evaluated_depsgraph_get())
    objects = {name: links.of_object(bpy.data.objects[name]) for name in ("Floor", "Cube", "Sphere", "LampA", "LampB")}
    floor, cube, sphere = objects["Floor"], objects["Cube"], objects["Sphere"]
    lamp_a, lamp_b = objects["LampA"], objects["LampB"]
    lights = lambda lamp, obj: bool(lamp["light_membership"] >> obj["light_set"] & 1)       # noqa: E731
    blocks = lambda lamp, obj: bool(lamp["shadow_membership"] >> obj["shadow_set"] & 1)     # noqa: E731
    assert [lights(lamp_a, o) for o in (floor, cube, sphere)] == [True, False, False]
    assert [lights(lamp_b, o) for o in (floor, cube, sphere)] == [True, True, False]
    assert [blocks(lamp_a, o) for o in (floor, cube, sphere)] == [False, False, True]
    assert [blocks(lamp_b, o) for o in (floor, cube, sphere)] == [True, False, True]


def assert_renders_as_cycles(scene, tmp_path, compare, label: str) -> tuple:
    """Primer at 256 samples against Cycles at 1024: block relMSE within three times Cycles 256's own against its
    1024, and the mean within 1%; returns (Cycles' 1024-sample pixels, its own 256-vs-1024 error)."""
    p = render_pixels(scene, "PRIMER", str(tmp_path / "primer.exr"), 256)[..., :3]
    c = render_pixels(scene, "CYCLES", str(tmp_path / "cycles.exr"), 1024, True)[..., :3]
    c_low = render_pixels(scene, "CYCLES", str(tmp_path / "cycles_low.exr"), 256, True)[..., :3]
    error = compare.relative_mse_of_blocks(p, c)
    own = compare.relative_mse_of_blocks(c_low, c)
    print(f"{label}: Primer 256 vs Cycles 1024 {error:.3g}; Cycles 256 vs 1024 {own:.3g}; means {p.mean():.5f} "
          f"{c.mean():.5f}")
    assert error < 3.0 * own + 1e-6
    assert abs(p.mean() / c.mean() - 1.0) < 0.01
    return c, own


def test_a_scene_with_light_and_shadow_links_renders_as_in_cycles(primer, tmp_path):
    """The linked scene: Primer 256 samples against Cycles 1024, block relMSE within three times Cycles 256's own
    against its 1024, and the mean within 1%; the same scene unlinked is far from it (the test can tell)."""
    scene = linked_scene()
    compare = importlib.import_module(primer.__name__ + ".core.film.compare")
    c, own = assert_renders_as_cycles(scene, tmp_path, compare, "linking")
    for obj in bpy.data.objects:
        if obj.light_linking is not None:
            obj.light_linking.receiver_collection = obj.light_linking.blocker_collection = None
    unlinked = render_pixels(scene, "PRIMER", str(tmp_path / "unlinked.exr"), 64)[..., :3]
    assert compare.relative_mse_of_blocks(unlinked, c) > 30.0 * own


def test_path_traced_links_with_an_area_lamp_and_a_glossy_floor_render_as_in_cycles(primer, tmp_path):
    """The linked scene path traced (2 bounces) with lamp A an area lamp over a rough Principled floor: Cycles finds a
    shadow-linked lamp's light along BSDF directions by a dedicated shadow ray, Primer by its light samples alone (the
    same mean, other noise); block relMSE within three times Cycles 256's own against its 1024, mean within 1%."""
    scene = linked_scene()
    scene.primer.integrator, scene.primer.max_bounces = "PATH", 2
    scene.primer.diffuse_bounces = scene.primer.glossy_bounces = 2
    a = bpy.data.objects["LampA"]
    a.data.type = "AREA"
    a.data.size, a.data.energy = 1.0, 300.0
    m, tree, output = empty_material("Satin")
    principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
    principled.inputs["Roughness"].default_value = 0.3
    principled.inputs["Metallic"].default_value = 0.5
    tree.links.new(principled.outputs[0], output.inputs["Surface"])
    bpy.data.objects["Floor"].data.materials[0] = m
    compare = importlib.import_module(primer.__name__ + ".core.film.compare")
    assert_renders_as_cycles(scene, tmp_path, compare, "linking, path traced")
