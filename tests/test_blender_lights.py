"""A light's node tree in Primer, as Cycles reads it, on the Blender of this environment (5.0 or 5.2).

Blender 5.2 gives every light a node tree (an Emission node, white, strength 1) and keeps Use Nodes on;
4.2 and 5.0 use a tree only with Use Nodes on. The script runs in its own bpy process (tests/blender_env.py
LIGHT_NODES); tests/smoke_bpy42.py runs it on Blender 4.2.
"""
from __future__ import annotations

import os

import pytest

from blender_env import LIGHT_NODES, ROOT, check_light_nodes, run_bpy

pytestmark = pytest.mark.blender

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")


def test_emission_node_scales_the_light_and_a_default_tree_warns_nothing(tmp_path):
    """Emission strength 2, colour (1, 0.5, 0.25): Primer's and Cycles' pixels are 2 x (1, 0.5, 0.25) those
    of the plain light; the default tree (and the default scene's light) warns nothing; a Light Falloff into the
    Strength gives a sun its Strength (as Cycles, no warning); another shader at the output is warned about, naming
    the light and the node."""
    result = run_bpy(LIGHT_NODES.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    assert result["version"][:2] == list(bpy.app.version[:2])
    check_light_nodes(result)


def test_a_lamp_tree_reading_path_depths_or_object_info_is_warned_about():
    """Cycles evaluates a lamp's tree with the depths of the path its light reaches and the lamp's own object
    (Object Info); Primer's lamps carry neither (they read 0), so a tree reading Light Path's Ray Depth or Object
    Info's Location is named in a warning, once; one reading Is Camera Ray (exact for lamps) is not."""
    import sys
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    from render import load_primer
    primer = load_primer()
    export = sys.modules[primer.__name__ + ".addon.export"]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(scene.camera)
    data = bpy.data.lights.new("Lamp", "POINT")
    if hasattr(data, "use_nodes"):
        data.use_nodes = True
    lamp = bpy.data.objects.new("Lamp", data)
    scene.collection.objects.link(lamp)
    tree = data.node_tree
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    path, info = tree.nodes.new("ShaderNodeLightPath"), tree.nodes.new("ShaderNodeObjectInfo")
    warned = {}
    for name, socket in (("depth", path.outputs["Ray Depth"]), ("info", info.outputs["Location"]),
                         ("camera", path.outputs["Is Camera Ray"])):
        for link in list(tree.links):
            if link.to_node == emission and link.to_socket.name == "Strength":
                tree.links.remove(link)
        tree.links.new(socket, emission.inputs["Strength"])
        warnings = export.export_scene(bpy.context.evaluated_depsgraph_get()).warnings
        warned[name] = [w for w in warnings if "light 'Lamp'" in w]
    assert len(warned["depth"]) == 1 and "Light Path's Ray Depth" in warned["depth"][0], warned
    assert len(warned["info"]) == 1 and "Object Info's Location" in warned["info"][0], warned
    assert warned["camera"] == [], warned
