"""Smoke test on Blender 4.2 LTS, the oldest Blender Primer supports (blender_version_min = "4.2.0").

Not collected by a plain `pytest` (the name does not start with test_): `make test` runs it in a second
environment, .venv42 (requirements-bpy42.txt, bpy 4.2.x), with
    .venv42/bin/python -m pytest tests/smoke_bpy42.py
Each test runs Blender in its own process with empty user folders (tests/blender_env.py).
"""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from blender_env import LIGHT_NODES, MESH_READS, ROOT, check_light_nodes, check_mesh_reads, run_bpy

pytestmark = pytest.mark.smoke42


def test_checkout_registers_and_renders_in_blender_4_2(tmp_path):
    """Primer loaded from this checkout (tools/render.py's load_primer) renders the default scene in bpy 4.2."""
    result = run_bpy(f"""
    import os
    sys.path.append({ROOT!r})
    import bpy
    from blender_env import engine_ids, render_default_scene, report
    from tools.render import load_primer

    primer = load_primer()
    engines = engine_ids()
    pixels = render_default_scene(os.path.abspath("primer.exr"), "primer")
    # Unregister before exit: bpy 4.2 crashes at exit while a Python RenderEngine or Panel is registered.
    primer.unregister()
    report(version=list(bpy.app.version), engines=engines, engines_after=engine_ids(), **pixels)
    """, str(tmp_path))
    assert result["version"][:2] == [4, 2], f"this smoke test is for bpy 4.2, found {result['version']}"
    assert "PRIMER" in result["engines"] and "PRIMER" not in result["engines_after"]
    assert result["status"] == ["FINISHED"] and result["error"] == ""
    assert result["shape"] == [24, 32, 4] and result["finite"]
    assert 0.1 < result["max"] < 1e3               # the lit cube, brighter than the grey world
    assert result["nonzero_fraction"] > 0.5


def test_ray_inspector_runs_in_blender_4_2(tmp_path):
    """The ray inspector's operator and panel rows work in bpy 4.2: the default cube's centre pixel is lit."""
    result = run_bpy(f"""
    import sys
    sys.path.append({ROOT!r})
    import bpy
    from blender_env import report
    from tools.render import load_primer

    primer = load_primer()
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y = 32, 24
    status = bpy.ops.primer.inspect_pixel(x=16, y=12)
    record = sys.modules["primer.addon.inspector"].state.record
    view = sys.modules["primer.addon.inspector_view"]
    rows = dict(view.panel_sections(record, 24)[0][1])
    values = dict(status=sorted(status), object=record.object_name, t=record.t,
                  lights=[view.shadow_state(light) for light in record.lights],
                  radiance=float(record.radiance.sum()), t_row=rows["t"],
                  segments=len(view.overlay_segments(record)))
    primer.unregister()
    report(version=list(bpy.app.version), **values)
    """, str(tmp_path))
    assert result["version"][:2] == [4, 2]
    assert result["status"] == ["FINISHED"] and result["object"] == "Cube"
    assert result["lights"] == ["unoccluded"] and result["radiance"] > 0
    assert result["t_row"] == f"{result['t']:.5g}" and result["segments"] == 4


def test_extension_zip_installs_and_renders_in_blender_4_2(tmp_path):
    """The zip (the tests' build: unoptimised kernels), built and validated with Blender 4.2's own extension tool,
    installs and renders in bpy 4.2."""
    completed = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"), "--check-kernels"],
                               capture_output=True, text=True, timeout=1800)
    assert completed.returncode == 0, completed.stdout + completed.stderr
    from tools import build_extension

    extension_zip = build_extension.output_zip(check_kernels=True)
    result = run_bpy("""
    import os
    import bpy
    from blender_env import engine_ids, render_default_scene, report

    status = bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default",
                                                      enable_on_install=True)
    report(version=list(bpy.app.version), installed=sorted(status), engines=engine_ids(),
           **render_default_scene(os.path.abspath("primer.exr"), "bl_ext.user_default.primer"))
    """, str(tmp_path), extension_zip)
    assert result["version"][:2] == [4, 2]
    assert result["installed"] == ["FINISHED"] and "PRIMER" in result["engines"]
    assert result["status"] == ["FINISHED"] and result["error"] == "" and result["finite"]
    assert 0.1 < result["max"] < 1e3 and result["nonzero_fraction"] > 0.5


def test_mesh_read_by_attributes_equals_rna_reading_in_blender_4_2(tmp_path):
    """Blender 4.2 has the attribute arrays the export reads meshes from, and they give RNA's numbers."""
    result = run_bpy(MESH_READS.format(tools=os.path.join(ROOT, "tools"), scenes=os.path.join(ROOT, "sample_scenes")),
                     str(tmp_path))
    assert result["version"][:2] == [4, 2]
    check_mesh_reads(result)


def test_light_node_tree_in_blender_4_2(tmp_path):
    """Blender 4.2: a light's tree counts only with Use Nodes on; its Emission scales the light as in Cycles,
    and a default light warns nothing (tests/test_blender_lights.py on 5.0 and 5.2)."""
    result = run_bpy(LIGHT_NODES.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    assert result["version"][:2] == [4, 2]
    check_light_nodes(result)


def test_denoise_sets_up_the_compositor_and_denoises_in_blender_4_2(tmp_path):
    """Render > Denoise in bpy 4.2: the Denoise node goes into scene.node_tree between Render Layers and Composite,
    and the composited 4-sample image is nearer a 128-sample one than without it."""
    result = run_bpy(f"""
    import sys
    sys.path.append({ROOT!r})
    import bpy
    import numpy as np
    from blender_env import report
    from tools.render import configure_output, load_primer

    primer = load_primer()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 36, 100
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(bpy.data.objects.new("Plane", mesh))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0.0, 0.0, 1.0))
    light = bpy.data.objects.new("Area", bpy.data.lights.new("Area", "AREA"))
    light.data.energy, light.data.size, light.location = 300.0, 3.0, (1.5, -1.0, 4.0)
    scene.collection.objects.link(light)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0.0, -6.0, 4.0), (0.95, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.primer.use_adaptive_sampling = False
    scene.primer.light_samples = 1

    def render(name, samples):
        scene.primer.samples = samples
        configure_output(scene, name)
        bpy.ops.render.render(write_still=True)
        image = bpy.data.images.load(name)
        pixels = np.array(image.pixels[:], np.float64).reshape(image.size[1], image.size[0], image.channels)
        bpy.data.images.remove(image)
        return pixels[..., :3]

    def error(image, reference):
        return float(np.mean((image - reference) ** 2 / (reference ** 2 + 1e-2)))

    reference = render("reference.exr", 128)
    noisy = render("noisy.exr", 4)
    scene.primer.use_denoising = True
    links = sorted((l.from_node.name, l.from_socket.name, l.to_node.name, l.to_socket.name)
                   for l in scene.node_tree.links)
    denoised = render("denoised.exr", 4)
    warnings = sys.modules["primer.addon.engine"].last_render.warnings
    primer.unregister()
    report(links=links, noisy=error(noisy, reference), denoised=error(denoised, reference), warnings=warnings)
    """, str(tmp_path))
    links = {tuple(link) for link in result["links"]}
    assert {("Render Layers", "Image", "Primer Denoise", "Image"),
            ("Render Layers", "Denoising Albedo", "Primer Denoise", "Albedo"),
            ("Render Layers", "Denoising Normal", "Primer Denoise", "Normal"),
            ("Primer Denoise", "Image", "Composite", "Image")} <= links
    assert result["warnings"] == []
    assert result["denoised"] < 0.3 * result["noisy"], (result["noisy"], result["denoised"])
