"""Render the Cycles references the Blender tests hold Primer to into tests/references/<bpy version>/ (`make references`).

Usage:
    .venv/bin/python tools/make_references.py [--no-variants] [--check]

Renders, with this Python's bpy, every reference of tests/test_blender_scenes.py (the sample scenes, and their
render-setting variants unless --no-variants) and tests/test_blender_holdout.py whose committed copy is missing
or stale (its key differs: tests/cycles_references.py), as half-float EXRs, and updates that version's
manifest.json; up-to-date ones are left alone. --check renders nothing and exits 1 if any is missing or stale.
Then, unless --check or --no-scripted, the references of scenes the tests build themselves (blender_env.render_pixels'
`reference` label: tests/references/<bpy version>/scripted/): it runs the test files that render Cycles (pytest, one
process) with PRIMER_WRITE_REFERENCES set, which writes each missing or stale one. `make references` runs it with
bpy 5.0 (.venv) and bpy 5.2 (.venv52, without the variants, which `make test` compares on 5.0 only).
"""
from __future__ import annotations

import argparse
import glob
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TESTS = os.path.join(ROOT, "tests")
for path in (ROOT, TESTS):
    if path not in sys.path:
        sys.path.insert(0, path)

import cycles_references  # noqa: E402
import test_blender_holdout as holdout  # noqa: E402
import test_blender_scenes as scenes  # noqa: E402


def references(folder: str, variants: bool) -> list:
    """Return every reference as (id, .blend path, inputs of its key, Cycles samples), writing the .blend files
    the tests make (variants, holdout) into `folder`."""
    found = []
    blends = scenes.scene_blends(folder)
    for name in sorted(scenes.SCENES):
        blend, inputs = blends[name]
        found.append((name, blend, inputs, scenes.SCENES[name][1]))
    if variants:
        paths = scenes.write_variants(folder)
        for v in scenes.VARIANTS:
            base = os.path.join(scenes.SCENES_DIR, f"{v.scene}.blend")
            found.append((f"variant-{v.id}", paths[v.id], (base, v.settings), v.cycles_samples))
    for transparent in (True, False):
        own = os.path.join(folder, f"holdout-{transparent}")
        os.makedirs(own)
        ref_id, blend, inputs = holdout.holdout_scene(transparent, own)
        found.append((ref_id, blend, inputs, holdout.CYCLES_SAMPLES))
    return found


def scripted_test_files() -> list:
    """Return the test files that may hold scripted references: those named in either version's scripted manifest,
    and every Blender test file that renders Cycles (through whichever module's render helper)."""
    named = set()
    for manifest in glob.glob(os.path.join(cycles_references.REFERENCES, "*", cycles_references.SCRIPTED,
                                           "manifest.json")):
        version = os.path.relpath(os.path.dirname(os.path.dirname(manifest)), cycles_references.REFERENCES)
        named |= {ref_id.split("-", 1)[0] for ref_id in cycles_references.read_manifest(
            f"{version}/{cycles_references.SCRIPTED}")}
    found = []
    for path in sorted(glob.glob(os.path.join(TESTS, "test_blender_*.py"))):
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
        name = os.path.splitext(os.path.basename(path))[0]
        if name in named or "CYCLES" in text:      # (scene builders and render helpers come from other modules too)
            found.append(path)
    return found


def write_scripted() -> int:
    """Run the test files of scripted references with PRIMER_WRITE_REFERENCES set; return pytest's exit code."""
    files = scripted_test_files()
    print(f"scripted references: running {len(files)} test files", flush=True)
    env = dict(os.environ, **{cycles_references.WRITE: "1"})
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", *files], cwd=ROOT,
                          env=env).returncode


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-variants", action="store_true", help="leave out test_blender_scenes.py's variants")
    parser.add_argument("--check", action="store_true", help="render nothing; exit 1 if a reference is stale")
    parser.add_argument("--no-scripted", action="store_true", help="leave out the references of scripted scenes")
    args = parser.parse_args()
    version = cycles_references.bpy_version()
    with tempfile.TemporaryDirectory(prefix="primer-references-") as folder:
        found = references(folder, not args.no_variants)
        applied = cycles_references.applied_settings([(blend, samples) for _, blend, _, samples in found], folder)
        manifest = cycles_references.read_manifest(version)
        stale = []
        for (ref_id, blend, inputs, samples), settings in zip(found, applied):
            path = os.path.join(cycles_references.REFERENCES, version, f"{ref_id}.exr")
            why = cycles_references.staleness(manifest.get(ref_id), cycles_references.key_parts(inputs, samples,
                                                                                               settings), path)
            if why:
                stale.append(ref_id)
                print(f"{version}/{ref_id} {why}", flush=True)
                if not args.check:
                    own = os.path.join(folder, ref_id)
                    os.makedirs(own, exist_ok=True)
                    os.environ[cycles_references.WRITE] = "1"
                    cycles_references.reference(ref_id, blend, inputs, samples, settings, own, own, scenes.render)
        extra = sorted(set(cycles_references.read_manifest(version)) - {r[0] for r in found})
        if extra and not args.no_variants:
            print(f"in the manifest but no longer used: {', '.join(extra)}")
    total = sum(os.path.getsize(os.path.join(dp, f)) for dp, _, fs in os.walk(cycles_references.REFERENCES)
                for f in fs)
    print(f"bpy {version}: {len(found)} references, {len(stale)} {'stale' if args.check else 'rendered'}; "
          f"tests/references/ holds {total / 1e6:.1f} MB")
    if args.check:
        return 1 if stale else 0
    return 0 if args.no_scripted else write_scripted()


if __name__ == "__main__":
    sys.exit(main())
