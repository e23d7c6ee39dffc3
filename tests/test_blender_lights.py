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
