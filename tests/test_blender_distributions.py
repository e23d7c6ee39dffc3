"""The Beckmann and Ashikhmin-Shirley distributions inside real Blender (the bpy module, no mocks), against Cycles' own
render: two rows of spheres (roughness 0.2 and 0.6) with a Glossy BSDF set to Beckmann, Beckmann anisotropic,
Ashikhmin-Shirley, Ashikhmin-Shirley anisotropic, and panes with a Glass BSDF and a Refraction BSDF set to Beckmann,
under point lamps (in front, and behind the panes) and under a uniform world, direct light only. Primer's error is the project's (relative MSE of 4x4-pixel block
means) against Cycles at 512 samples, compared with Cycles' own noise (256 against 512 samples)."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

from test_blender_anisotropy import node_material, render  # noqa: E402
from test_blender_denoise import addon  # noqa: E402
from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = pytest.mark.blender

# The columns: (name, node, distribution, its settings).
COLUMNS = [("Beckmann", "ShaderNodeBsdfGlossy", "BECKMANN", {}),
           ("Beckmann anisotropic", "ShaderNodeBsdfGlossy", "BECKMANN", {"Anisotropy": 0.6, "Rotation": 0.1}),
           ("Ashikhmin-Shirley", "ShaderNodeBsdfGlossy", "ASHIKHMIN_SHIRLEY", {}),
           ("Ashikhmin-Shirley anisotropic", "ShaderNodeBsdfGlossy", "ASHIKHMIN_SHIRLEY", {"Anisotropy": -0.6}),
           ("Beckmann glass", "ShaderNodeBsdfGlass", "BECKMANN", {"IOR": 1.45}),
           ("Beckmann refraction", "ShaderNodeBsdfRefraction", "BECKMANN", {"IOR": 1.45})]
ROUGHNESSES = (0.2, 0.6)
CELL = 20           # pixels per sphere


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def distribution_scene(lighting: str, distribution=None):
    """The two rows of spheres (module docstring), 120 x 40 pixels, orthographic, under `lighting` ("lamp": a point
    lamp and a dark world; "world": a uniform world of strength 1); `distribution` replaces every node's."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = CELL * len(COLUMNS), CELL * len(ROUGHNESSES)
    scene.render.resolution_percentage = 100
    for row, roughness in enumerate(ROUGHNESSES):
        for column, (name, kind, own, settings) in enumerate(COLUMNS):
            material = node_material(f"{name} {roughness}", kind, {"Roughness": roughness, **settings})
            node = next(n for n in material.node_tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial")
            node.distribution = distribution or own
            if "Color" in node.inputs:
                node.inputs["Color"].default_value = (0.9, 0.8, 0.7, 1.0)
            location = (column - 2.5, 0.0, 0.5 - row)
            if kind == "ShaderNodeBsdfGlossy":
                bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.48, location=location)
                bpy.ops.object.shade_smooth()
            else:                       # a pane facing the camera: what light behind it lets through is direct light
                bpy.ops.mesh.primitive_plane_add(size=0.9, location=location, rotation=(-math.pi / 2, 0.0, 0.0))
            obj = bpy.context.view_layer.objects.active
            obj.data.materials.append(material)
            owner = obj if hasattr(obj, "shadow_terminator_geometry_offset") else obj.cycles
            owner.shadow_terminator_geometry_offset = 0.0
    world = bpy.data.worlds.new("World")
    if world.node_tree is None:
        world.use_nodes = True
    background = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Color"].default_value = (0.6, 0.7, 0.8, 1.0) if lighting == "world" else (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    if lighting == "lamp":
        # One in front, and one behind and below for the light the glass and refraction let through.
        for name, location, energy in (("Front", (1.0, -4.0, 2.5), 600.0), ("Back", (2.0, 1.2, 0.0), 150.0)):
            light = bpy.data.objects.new(name, bpy.data.lights.new(name, "POINT"))
            light.data.energy, light.data.shadow_soft_size = energy, 0.5
            light.location = location
            scene.collection.objects.link(light)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", float(len(COLUMNS))
    camera.location, camera.rotation_euler = (0.0, -6.0, 0.0), (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.primer.integrator = "DIRECT"
    scene.primer.use_adaptive_sampling = False
    return scene


def per_sphere(mine: np.ndarray, cycles: np.ndarray) -> dict:
    """Each sphere's (or pane's) block relMSE and mean ratio, Primer over Cycles: name -> (relMSE, ratio)."""
    out = {}
    for row, roughness in enumerate(ROUGHNESSES):
        for column, (name, *_) in enumerate(COLUMNS):
            cell = np.s_[row * CELL:(row + 1) * CELL, column * CELL:(column + 1) * CELL]
            out[f"{name} {roughness}"] = (relative_mse_of_blocks(mine[cell], cycles[cell]),
                                          mine[cell].mean() / max(cycles[cell].mean(), 1e-12))
    return out


@pytest.mark.parametrize("lighting", ["lamp", "world"])
def test_beckmann_and_ashikhmin_shirley_match_cycles_within_its_noise(primer, tmp_path, lighting):
    """Primer (256 samples) against Cycles (512): the error is within a few times Cycles' own 256-vs-512 noise, with
    no distribution warning, and each sphere's mean within 3%; the same spheres rendered as GGX are far off (the
    test sees the distributions)."""
    scene = distribution_scene(lighting)
    cycles = render(scene, "CYCLES", 512, str(tmp_path / "cycles512.exr"))
    cycles_256 = render(scene, "CYCLES", 256, str(tmp_path / "cycles256.exr"))
    mine = render(scene, "PRIMER", 256, str(tmp_path / "primer.exr"))
    warnings = addon(primer, "engine").last_render.warnings
    assert not any("distribution" in w for w in warnings), warnings
    baseline = relative_mse_of_blocks(cycles_256, cycles)
    error = relative_mse_of_blocks(mine, cycles)
    ggx = render(distribution_scene(lighting, "GGX"), "PRIMER", 256, str(tmp_path / "ggx.exr"))
    wrong = relative_mse_of_blocks(ggx, cycles)
    spheres, noise = per_sphere(mine, cycles), per_sphere(cycles_256, cycles)
    print(f"{lighting}: relMSE Primer {error:.2e}, Cycles 256 vs 512 {baseline:.2e}, as GGX {wrong:.2e}")
    for name, (sphere_error, ratio) in spheres.items():
        print(f"  {name}: relMSE {sphere_error:.2e} (Cycles {noise[name][0]:.2e}), mean ratio {ratio:.4f} "
              f"(Cycles {noise[name][1]:.4f})")
    assert cycles.max() > 0.3
    assert error < max(3.0 * baseline, 1e-4), (error, baseline)
    assert wrong > 5.0 * error, (wrong, error)
    for name, (sphere_error, ratio) in spheres.items():
        if lighting == "lamp" and name == "Ashikhmin-Shirley anisotropic 0.6":
            # The known gap (docs/blender.md): lit at grazing from behind, 1.8 % darker than Cycles at 4,096 samples.
            assert sphere_error < 1e-3 and ratio == pytest.approx(0.982, abs=0.01), (name, sphere_error, ratio)
            continue
        if bpy.app.version >= (5, 1, 0) and name in ("Beckmann glass 0.2", "Beckmann refraction 0.2"):
            # Blender 5.2's Cycles draws these otherwise than 5.0's, which Primer follows: the same mean, block relMSE
            # 1.3e-4 and 5.2e-4 at 256 / 512 samples (Cycles' own noise 1.6e-5, 3.3e-5; docs/blender.md).
            assert sphere_error < 1e-3, name
        else:
            assert sphere_error < max(4.0 * noise[name][0], 1e-4), name
        assert ratio == pytest.approx(1.0, abs=max(0.03, 3.0 * abs(float(noise[name][1]) - 1.0))), name
