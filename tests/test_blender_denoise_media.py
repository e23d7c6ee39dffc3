"""The Denoising Albedo through a scattering medium in real Blender (the bpy module), against Cycles 5.x: the medium's
albedo while the camera path looks, the surface behind by the odds of passing (core/integrators/features.py
in_media). No mocks."""
from __future__ import annotations

import os

import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")

from test_blender_denoise import plane_scene, primer, render_image  # noqa: E402,F401

pytestmark = pytest.mark.blender


def fog_world(scene, density: float) -> None:
    """A white world whose Volume is a white Volume Scatter of `density`."""
    world = bpy.data.worlds.new("Fog")
    world.use_nodes = True
    tree = world.node_tree
    tree.nodes["Background"].inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    scatter = tree.nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Density"].default_value = density
    tree.links.new(scatter.outputs[0], tree.nodes["World Output"].inputs["Volume"])
    scene.world = world


def test_denoising_albedo_through_fog_is_the_fogs_albedo_and_the_planes_by_the_odds_of_passing_as_cycles(primer,
                                                                                                        tmp_path):
    """A grey plane 5 below the camera in a white fog (density 0.15): Cycles writes the fog's albedo while the camera
    path looks and the plane's where it passes the fog; Primer's Denoising Albedo is Cycles' within 3 % (measured
    +1.2 % at base colour 0.2, +2.9 % at 0.7: Cycles 5.0 guides its camera paths' choice to scatter, Primer takes
    the unguided odds; until this stop Primer wrote the plane's colour alone, 64 % and 14 % off)."""
    found = {}
    for grey in (0.2, 0.7):
        scene = plane_scene(color=(grey, grey, grey))
        fog_world(scene, 0.15)
        scene.primer.use_denoising, scene.primer.integrator, scene.primer.samples = True, "PATH", 16
        scene.cycles.samples = 16
        scene.view_layers[0].cycles.denoising_store_passes = True
        for engine in ("PRIMER", "CYCLES"):
            scene.render.engine = engine
            passes = render_image(scene, str(tmp_path / f"{engine}{grey}.exr"), multilayer=True)
            found[engine, grey] = float(passes["Denoising Albedo"][1].mean())
    print(found)
    for grey in (0.2, 0.7):
        assert found["PRIMER", grey] == pytest.approx(found["CYCLES", grey], rel=0.03), found
