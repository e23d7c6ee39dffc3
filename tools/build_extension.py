"""Build Primer's Blender extension: dist/primer-<version>.zip, with embreex wheels and compiled kernels for every platform.

Usage:
    .venv/bin/python tools/build_extension.py [--dist dist] [--offline] [--blender-ext PATH] [--check-kernels]

Steps:
1. Download the embreex wheels (the version pinned in requirements.txt) for each Blender platform and
   Python version below with `pip download --no-deps --only-binary=:all:`, cached in dist/wheels/ so
   that later builds need no network.
2. Cross-compile the C kernels for every platform of tools/build_kernels.py's TARGETS with Zig (the
   ziglang package, requirements-platforms.txt) into dist/kernels/, rebuilt only when a C file changed.
3. Copy the add-on into dist/build/primer/ with a copy of blender_manifest.toml that lists the
   platforms and the wheels (the committed manifest stays platform-free), and the five libraries into
   its core/native/ in place of whatever `make kernels` built for this machine.
4. Build the zip with Blender's own extension builder (`blender_ext.py build`, shipped inside the bpy
   module), which applies the manifest's [build] paths_exclude_pattern, then check it with
   `blender_ext.py validate` and with a listing check of its own.

With --check-kernels the zip is the test suite's (tests/test_extension.py): its kernels are the unoptimised check
builds of dist/kernels-check/ (quick to compile, slow to render), and it is written to dist/check/<environment>/
(.venv, .venv42 or .venv52: each Blender's tests build their own), never where a release zip goes.

Only embreex is bundled: numpy comes with Blender, and OpenImageIO (used by core/film/image_io.py, never by
the add-on) is Blender's own copy when anything inside Blender needs it.
"""
from __future__ import annotations

import argparse
import fnmatch
import glob
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from tools import build_kernels  # noqa: E402  (after the path is set, when run as a script)
MANIFEST = "blender_manifest.toml"

# Blender platform -> the pip platform tag whose wheels it runs. embreex 4.4.0.post1 publishes
# manylinux_2_28, win_amd64 and macosx_13_0 (arm64 and x86_64) wheels, so macOS needs 13 or newer.
PLATFORMS = {
    "linux-x64": "manylinux_2_28_x86_64",
    "windows-x64": "win_amd64",
    "macos-arm64": "macosx_13_0_arm64",
    "macos-x64": "macosx_13_0_x86_64",
}
# Blender 4.2 LTS to 5.0 run Python 3.11; Blender 5.1 and later run Python 3.13.
PYTHONS = ("3.11", "3.13")

# Top-level entries never copied into the staging folder: version control, virtual environments and
# build output (large, or the staging folder itself). Everything else is filtered by the manifest.
STAGING_SKIP = (".git", ".venv*", "dist", "out", ".pytest_cache", ".hypothesis", "__pycache__")

# What the zip must never contain (development files) and must always contain.
FORBIDDEN_PREFIXES = ("tests/", "sample_scenes/", "tools/", "docs/", "bench/", ".ci/", ".git", ".venv",
                      "dist/", "out/", "Makefile", "pyproject.toml", "requirements", ".pytest_cache", ".hypothesis")
REQUIRED_FILES = ("blender_manifest.toml", "__init__.py", "addon/__init__.py", "addon/engine.py",
                  "core/render/__init__.py", "core/geometry/intersect.py")


class BuildError(Exception):
    """The extension could not be built; the message says why."""


def pinned_version(package: str, requirements: str = os.path.join(ROOT, "requirements.txt")) -> str:
    """Return the version pinned as `package==VERSION` in requirements.txt."""
    with open(requirements, encoding="utf-8") as fh:
        for line in fh:
            match = re.match(rf"\s*{re.escape(package)}\s*==\s*([^\s#;]+)", line, re.IGNORECASE)
            if match:
                return match.group(1)
    raise BuildError(f"{requirements} pins no version of {package}")


def read_manifest(path: str = os.path.join(ROOT, MANIFEST)) -> dict:
    """Return the parsed blender_manifest.toml."""
    with open(path, "rb") as fh:
        return tomllib.load(fh)


def cp_tag(python: str) -> str:
    """Return the CPython wheel tag of a Python version: '3.11' -> 'cp311'."""
    return "cp" + python.replace(".", "")


def cached_wheel(folder: str, package: str, version: str, python: str) -> str | None:
    """Return the cached wheel of package==version for one Python in `folder`, or None."""
    tag = cp_tag(python)
    pattern = os.path.join(folder, f"{package}-{version}-{tag}-{tag}-*.whl")
    found = sorted(glob.glob(pattern))
    return found[0] if found else None


def download_wheel(folder: str, package: str, version: str, platform: str, python: str, offline: bool) -> str | None:
    """Return the wheel of package==version for one platform tag and Python, downloading it once; None if PyPI has none."""
    wheel = cached_wheel(folder, package, version, python)
    if wheel or offline:
        return wheel
    os.makedirs(folder, exist_ok=True)
    command = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:",
               "--platform", platform, "--python-version", python, "--implementation", "cp",
               "--dest", folder, f"{package}=={version}"]
    completed = subprocess.run(command, capture_output=True, text=True)
    if completed.returncode != 0:
        print(f"  no {package} {version} wheel for {platform}, Python {python}:\n    "
              + completed.stderr.strip().replace("\n", "\n    "), file=sys.stderr)
        return None
    return cached_wheel(folder, package, version, python)


def collect_wheels(cache: str, offline: bool) -> tuple[dict, list]:
    """Return ({blender platform: [wheel paths]}, [(platform, python) without a wheel]) for embreex."""
    version = pinned_version("embreex")
    found, missing = {}, []
    for blender_platform, tag in PLATFORMS.items():
        for python in PYTHONS:
            folder = os.path.join(cache, f"embreex-{version}", blender_platform)
            wheel = download_wheel(folder, "embreex", version, tag, python, offline)
            if wheel is None:
                missing.append((blender_platform, python))
            else:
                found.setdefault(blender_platform, []).append(wheel)
    return found, missing


def toml_list(key: str, values: list) -> str:
    """Return a TOML array assignment, one value per line."""
    return f"{key} = [\n" + "".join(f'  "{value}",\n' for value in values) + "]\n"


def manifest_with_wheels(text: str, platforms: list, wheels: list) -> str:
    """Return the manifest text with `platforms` and `wheels` added before its first [table]."""
    data = tomllib.loads(text)
    for key in ("platforms", "wheels"):
        if key in data:
            raise BuildError(f"{MANIFEST} already sets `{key}`; leave it to tools/build_extension.py")
    generated = ("# Written by tools/build_extension.py.\n" + toml_list("platforms", platforms)
                 + toml_list("wheels", wheels) + "\n")
    match = re.search(r"^\[", text, re.MULTILINE)
    at = match.start() if match else len(text)
    result = text[:at] + generated + text[at:]
    parsed = tomllib.loads(result)
    assert parsed["platforms"] == platforms and parsed["wheels"] == wheels
    return result


def stage(stage_dir: str, wheels_by_platform: dict, kernels: list) -> None:
    """Copy the add-on, the wheels and the `kernels` libraries into `stage_dir`, with the manifest that lists the wheels."""
    if os.path.exists(stage_dir):
        shutil.rmtree(stage_dir)
    shutil.copytree(ROOT, stage_dir, ignore=_skipped)
    native = os.path.join(stage_dir, "core", "native")
    for name in os.listdir(native):
        if name.startswith("_kernels-"):            # this machine's `make kernels` build: the zip takes the cross-built one
            os.remove(os.path.join(native, name))
    for library in kernels:
        shutil.copy2(library, native)
    wheel_dir = os.path.join(stage_dir, "wheels")
    os.makedirs(wheel_dir, exist_ok=True)
    wheel_paths = []
    for platform in PLATFORMS:
        for wheel in wheels_by_platform.get(platform, ()):
            shutil.copy2(wheel, wheel_dir)
            wheel_paths.append("./wheels/" + os.path.basename(wheel))
    with open(os.path.join(ROOT, MANIFEST), encoding="utf-8") as fh:
        text = fh.read()
    with open(os.path.join(stage_dir, MANIFEST), "w", encoding="utf-8") as fh:
        fh.write(manifest_with_wheels(text, [p for p in PLATFORMS if p in wheels_by_platform], wheel_paths))


def _skipped(folder: str, names: list) -> list:
    """Return the names in `folder` that copytree must not copy (see STAGING_SKIP)."""
    top = os.path.abspath(folder) == ROOT
    return [name for name in names
            if name == "__pycache__" or (top and any(fnmatch.fnmatch(name, p) for p in STAGING_SKIP))]


def find_blender_ext(explicit: str | None = None) -> str:
    """Return the path of Blender's extension tool blender_ext.py, found inside the installed bpy module."""
    if explicit:
        if not os.path.isfile(explicit):
            raise BuildError(f"no such file: {explicit}")
        return explicit
    spec = importlib.util.find_spec("bpy")          # locates bpy without importing (and starting) Blender
    if spec is None or not spec.submodule_search_locations:
        raise BuildError("the bpy module is not installed in this Python (run `make venv`), "
                         "or pass --blender-ext PATH/TO/blender_ext.py")
    found = []
    for location in spec.submodule_search_locations:
        found += glob.glob(os.path.join(location, "*", "scripts", "addons_core", "bl_pkg", "cli", "blender_ext.py"))
    if not found:
        raise BuildError(f"blender_ext.py not found inside bpy at {list(spec.submodule_search_locations)}")
    return sorted(found)[-1]


def run_blender_ext(blender_ext: str, *args: str) -> str:
    """Run blender_ext.py with `args`; return its output, or raise BuildError with it."""
    completed = subprocess.run([sys.executable, blender_ext, *args], capture_output=True, text=True)
    output = (completed.stdout + completed.stderr).strip()
    if completed.returncode != 0:
        raise BuildError(f"blender_ext.py {args[0]} failed:\n{output}")
    return output


def check_contents(zip_path: str, wheel_paths: list, kernels: list = ()) -> list:
    """Check that the zip holds the add-on, the wheels, the `kernels` libraries and no development file; return its names."""
    with zipfile.ZipFile(zip_path) as archive:
        names = archive.namelist()
        manifest = tomllib.loads(archive.read(MANIFEST).decode("utf-8"))
    leaked = [n for n in names if n.startswith(FORBIDDEN_PREFIXES) or "__pycache__" in n or n.endswith(".pyc")]
    if leaked:
        raise BuildError(f"development files in {zip_path}: {leaked[:10]}")
    missing = [n for n in REQUIRED_FILES if n not in names]
    missing += [w for w in manifest.get("wheels", []) if w.removeprefix("./") not in names]
    missing += [f"core/native/{name}" for name in kernels if f"core/native/{name}" not in names]
    if missing:
        raise BuildError(f"{zip_path} lacks {missing}")
    if sorted(manifest.get("wheels", [])) != sorted(wheel_paths):
        raise BuildError(f"the manifest in {zip_path} lists other wheels than the ones staged")
    return names


def output_zip(dist: str = os.path.join(ROOT, "dist"), check_kernels: bool = False) -> str:
    """Return where `build` writes the zip: dist/<id>-<version>.zip, or, for the tests' zip, dist/check/<environment>/...
    (the folder of this Python's environment, .venv, .venv42 or .venv52: `make test` runs the Blender 4.2 and 5.2
    tests at the same time, each building and validating the zip with its own Blender)."""
    manifest = read_manifest()
    folder = os.path.join("check", os.path.basename(sys.prefix.rstrip(os.sep)) or "python") if check_kernels else ""
    return os.path.join(dist, folder, f"{manifest['id']}-{manifest['version']}.zip")


def build(dist: str = os.path.join(ROOT, "dist"), offline: bool = False, blender_ext: str | None = None,
          check_kernels: bool = False) -> str:
    """Build and validate the zip (with the tests' unoptimised kernels if `check_kernels`); return its path."""
    manifest = read_manifest()
    zip_path = output_zip(dist, check_kernels)
    os.makedirs(os.path.dirname(zip_path), exist_ok=True)
    tool = find_blender_ext(blender_ext)
    print(f"embreex wheels (cache {os.path.relpath(os.path.join(dist, 'wheels'), ROOT)}):")
    wheels_by_platform, missing = collect_wheels(os.path.join(dist, "wheels"), offline)
    for platform, wheels in wheels_by_platform.items():
        print(f"  {platform:12s} " + ", ".join(os.path.basename(w) for w in wheels))
    if not wheels_by_platform:
        raise BuildError("no embreex wheel at all" + (" in the cache (--offline)" if offline else ""))
    try:
        kernels = build_kernels.cross_build(os.path.join(dist, "kernels-check" if check_kernels else "kernels"),
                                            check=check_kernels)
    except build_kernels.ToolchainError as error:
        raise BuildError(str(error)) from error
    for platform, library in kernels.items():
        print(f"  kernels {platform:12s} {os.path.basename(library)} ({os.path.getsize(library) / 1e3:.0f} kB)")
    stage_dir = os.path.join(os.path.dirname(zip_path) if check_kernels else dist, "build", manifest["id"])
    stage(stage_dir, wheels_by_platform, list(kernels.values()))
    print(run_blender_ext(tool, "build", "--source-dir", stage_dir, "--output-filepath", zip_path))
    print(run_blender_ext(tool, "validate", zip_path))
    staged = read_manifest(os.path.join(stage_dir, MANIFEST))["wheels"]
    names = check_contents(zip_path, staged, [os.path.basename(path) for path in kernels.values()])
    size = os.path.getsize(zip_path) / 1e6
    print(f"{os.path.relpath(zip_path, ROOT)}: {len(names)} files, {size:.1f} MB, "
          f"platforms {', '.join(wheels_by_platform)}, Python {', '.join(PYTHONS)}, kernels {', '.join(kernels)}")
    for platform, python in missing:
        print(f"warning: PyPI has no embreex wheel for {platform}, Python {python}: not bundled", file=sys.stderr)
    return zip_path


def main(argv=None) -> int:
    """Parse the command line, build the extension, and return the exit code."""
    parser = argparse.ArgumentParser(description="Build Primer's Blender extension zip with embreex wheels and kernels.")
    parser.add_argument("--dist", default=os.path.join(ROOT, "dist"), help="output folder (default: dist/)")
    parser.add_argument("--offline", action="store_true", help="use cached wheels only, never download")
    parser.add_argument("--blender-ext", default=os.environ.get("BLENDER_EXT"),
                        help="path of Blender's blender_ext.py (default: the one inside the installed bpy)")
    parser.add_argument("--check-kernels", action="store_true",
                        help="the tests' zip: unoptimised kernels (quick to build), written to dist/check/")
    args = parser.parse_args(argv)
    try:
        build(os.path.abspath(args.dist), args.offline, args.blender_ext, args.check_kernels)
    except BuildError as error:
        print(f"build failed: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
