"""Primer as a user gets it: the extension zip of `make extension`, installed into real Blender (bpy).

The zip is built once per session by tools/build_extension.py (its embreex wheels are cached in
dist/wheels/, so only the first build downloads), with the unoptimised kernels the tests build quickly
(`--check-kernels`, into dist/check/<environment>/): the same sources and files as `make extension`'s zip, compiled at -O0. Each Blender test runs in its own process with
empty user folders (tests/blender_env.py): it installs the zip the way Blender's "Install from Disk"
does, with bpy.ops.extensions.package_install_files, and never imports Primer from this checkout.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tomllib
import zipfile

import pytest

from blender_env import ROOT, run_bpy

from tools import build_extension

MODULE = "bl_ext.user_default.primer"      # where Blender imports an extension of the user_default repository


@pytest.fixture(scope="session")
def extension_zip() -> str:
    """Build the tests' zip, dist/check/<environment>/primer-<version>.zip, with tools/build_extension.py (wheels from the cache,
    the unoptimised check kernels) and return its path."""
    completed = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"), "--check-kernels"],
                               capture_output=True, text=True, timeout=1800)
    assert completed.returncode == 0, completed.stdout + completed.stderr
    path = build_extension.output_zip(check_kernels=True)
    assert os.path.isfile(path)
    return path


def test_zip_holds_the_addon_the_wheels_the_kernels_and_no_development_files(extension_zip):
    """The zip has the add-on, the manifest with platforms and wheels, the five platforms' kernels, and nothing from tests, tools or docs."""
    with zipfile.ZipFile(extension_zip) as archive:
        names = set(archive.namelist())
        manifest = tomllib.loads(archive.read("blender_manifest.toml").decode("utf-8"))
    source = tomllib.loads(open(os.path.join(ROOT, "blender_manifest.toml"), encoding="utf-8").read())
    assert manifest["version"] == source["version"] and manifest["id"] == "primer"

    for folder in ("addon", "core"):
        expected = {f"{folder}/{name}" for name in os.listdir(os.path.join(ROOT, folder)) if name.endswith(".py")}
        assert expected <= names, expected - names
    assert {"__init__.py", "blender_manifest.toml"} <= names
    for name in names:
        assert not name.startswith(("tests/", "sample_scenes/", "tools/", "docs/", "bench/", ".", "dist/", "out/")), name
        assert name not in ("Makefile", "pyproject.toml") and not name.startswith("requirements"), name
        assert "__pycache__" not in name and not name.endswith(".pyc"), name

    assert manifest["platforms"] == ["linux-x64", "windows-x64", "macos-arm64", "macos-x64"]
    kernels = {n for n in names if n.startswith("core/native/_kernels-")}
    assert kernels == {"core/native/_kernels-linux-x86_64.so", "core/native/_kernels-linux-aarch64.so",
                       "core/native/_kernels-win32-amd64.dll", "core/native/_kernels-darwin-arm64.dylib",
                       "core/native/_kernels-darwin-x86_64.dylib"}
    wheels = [w.removeprefix("./") for w in manifest["wheels"]]
    assert set(wheels) == {n for n in names if n.endswith(".whl")}
    for tag in ("manylinux_2_28_x86_64", "win_amd64", "macosx_13_0_arm64", "macosx_13_0_x86_64"):
        for python in ("cp311", "cp313"):
            assert any(w.startswith("wheels/embreex-") and f"-{python}-{python}-" in w and w.endswith(tag + ".whl")
                       for w in wheels), (tag, python)


def test_zip_passes_blenders_validator(extension_zip):
    """Blender's own `blender_ext.py validate` accepts the zip."""
    tool = build_extension.find_blender_ext()
    completed = subprocess.run([sys.executable, tool, "validate", extension_zip], capture_output=True, text=True)
    assert completed.returncode == 0, completed.stdout + completed.stderr
    assert "Success" in completed.stdout


INSTALL = f"""
    import os
    import bpy
    from blender_env import engine_ids, primer_types, can_select_primer, render_default_scene, report

    assert "PRIMER" not in engine_ids()
    status = bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default",
                                                      enable_on_install=True)
    assert status == {{"FINISHED"}}, status
    module = sys.modules["{MODULE}"]
"""


@pytest.mark.slow
def test_installed_extension_renders_with_its_bundled_embree(extension_zip, tmp_path):
    """Installed from the zip, Primer is a render engine, renders through bpy.ops.render.render, with the wheel's embreex."""
    result = run_bpy(INSTALL + f"""
    enabled = "{MODULE}" in bpy.context.preferences.addons
    # A real Blender has no embreex of its own: import the one unpacked from the zip's wheel.
    assert "embreex" not in sys.modules
    wheel_site = [p for p in sys.path if p.startswith(os.environ["BLENDER_USER_RESOURCES"]) and "site-packages" in p]
    sys.path[:] = wheel_site + [p for p in sys.path if p not in wheel_site]
    pixels = render_default_scene(os.path.abspath("primer.exr"), "{MODULE}")
    import embreex
    report(enabled=enabled, engines=engine_ids(), selectable=can_select_primer(), module_file=module.__file__,
           embreex_file=embreex.__file__, **pixels)
    """, str(tmp_path), extension_zip)

    user_folder = str(tmp_path / "blender")
    assert result["enabled"]
    assert "PRIMER" in result["engines"] and result["selectable"]
    assert result["module_file"].startswith(user_folder), result["module_file"]
    assert result["embreex_file"].startswith(user_folder), result["embreex_file"]
    assert result["status"] == ["FINISHED"] and result["error"] == ""
    assert result["shape"] == [24, 32, 4]
    assert result["finite"]
    assert result["rays"] > 0
    assert result["kernels"] == "compiled"          # the zip carries this machine's compiled kernels
    assert 0.1 < result["max"] < 1e3               # the lit cube, brighter than the grey world
    assert result["nonzero_fraction"] > 0.5


@pytest.mark.slow
def test_register_unregister_and_register_again(extension_zip, tmp_path):
    """Disabling the add-on removes the engine and every Primer type; enabling it again brings them back, twice."""
    result = run_bpy(INSTALL + f"""
    states = [dict(engines=engine_ids(), types=primer_types(), selectable=can_select_primer(),
                   settings=hasattr(bpy.types.Scene, "primer"))]
    renders = []
    for cycle in range(2):
        assert bpy.ops.preferences.addon_disable(module="{MODULE}") == {{"FINISHED"}}
        states.append(dict(engines=engine_ids(), types=primer_types(), selectable=can_select_primer(),
                           settings=hasattr(bpy.types.Scene, "primer")))
        assert bpy.ops.preferences.addon_enable(module="{MODULE}") == {{"FINISHED"}}
        states.append(dict(engines=engine_ids(), types=primer_types(), selectable=can_select_primer(),
                           settings=hasattr(bpy.types.Scene, "primer")))
        renders.append(render_default_scene(os.path.abspath(f"primer{{cycle}}.exr"), "{MODULE}"))
    report(states=states, renders=renders)
    """, str(tmp_path), extension_zip)

    registered, unregistered = result["states"][0], result["states"][1]
    assert "PRIMER" in registered["engines"] and registered["selectable"] and registered["settings"]
    assert registered["types"], "no Primer class registered"
    assert unregistered == dict(engines=[e for e in registered["engines"] if e != "PRIMER"], types=[],
                                selectable=False, settings=False)
    assert result["states"][2::2] == [registered, registered]        # back, the same, after each re-enable
    assert result["states"][1::2] == [unregistered, unregistered]
    for pixels in result["renders"]:
        assert pixels["status"] == ["FINISHED"] and pixels["error"] == "" and pixels["finite"]
        assert 0.1 < pixels["max"] < 1e3
    assert result["renders"][0] == result["renders"][1]             # same scene, same seed, same image
