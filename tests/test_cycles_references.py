"""The committed Cycles references (tests/references/, tests/cycles_references.py): a reference is used only while
its key matches; a missing or stale one is rendered again, with a warning, never compared against."""
from __future__ import annotations

import glob
import json
import os

import numpy as np
import pytest

import cycles_references
from bench.common import digest
from core.film import image_io


def test_a_committed_reference_is_used_only_while_every_part_of_its_key_matches(tmp_path):
    """staleness() accepts the entry of the same parts, and names the part that changed otherwise."""
    blend = tmp_path / "scene.blend"
    blend.write_bytes(b"one scene")
    exr = tmp_path / "scene.exr"
    exr.write_bytes(b"an image")
    parts = cycles_references.key_parts((str(blend),), 256, {"max_bounces": 0})
    entry = {"key": digest(parts), "parts": parts}
    assert cycles_references.staleness(entry, parts, str(exr)) == ""
    assert cycles_references.staleness(None, parts, str(exr)) == "is not committed"
    assert cycles_references.staleness(entry, parts, str(tmp_path / "gone.exr")) == "is not committed"
    changed = {
        "samples": cycles_references.key_parts((str(blend),), 512, {"max_bounces": 0}),
        "cycles": cycles_references.key_parts((str(blend),), 256, {"max_bounces": 4}),     # the add-on's settings
        "inputs": cycles_references.key_parts((str(blend), {"render.resolution_percentage": 50}), 256,
                                              {"max_bounces": 0}),
    }
    for part, other in changed.items():
        assert cycles_references.staleness(entry, other, str(exr)) == f"is stale ({part} changed)"
    blend.write_bytes(b"the scene edited")                  # the same path, other contents
    assert cycles_references.staleness(entry, cycles_references.key_parts((str(blend),), 256, {"max_bounces": 0}),
                                       str(exr)) == "is stale (inputs changed)"
    assert cycles_references.staleness({**entry, "key": "0" * 20}, parts, str(exr)) == "is stale (key changed)"


def test_a_stale_reference_is_rendered_again_with_a_warning_and_never_compared_against(tmp_path, monkeypatch):
    """reference() returns the committed image while its key matches; once the key differs it renders the image
    (saying so), caches it under the new key, and returns the fresh one, not the committed one."""
    monkeypatch.setattr(cycles_references, "REFERENCES", str(tmp_path / "references"))
    monkeypatch.setattr(cycles_references, "bpy_version", lambda: "9.9.9")
    monkeypatch.delenv(cycles_references.WRITE, raising=False)
    folder, cache = tmp_path / "work", tmp_path / "cache"
    folder.mkdir(), cache.mkdir()
    blend = tmp_path / "scene.blend"
    blend.write_bytes(b"scene")
    committed_image = np.full((4, 6, 4), 0.25, np.float32)
    fresh_image = np.full((4, 6, 4), 0.5, np.float32)
    renders = []

    def render(blend_path, out, engine, samples, render_folder):
        renders.append((engine, samples))
        image_io.write_image(out, fresh_image)

    parts = cycles_references.key_parts((str(blend),), 64, {"samples": 64})
    os.makedirs(tmp_path / "references" / "9.9.9")
    cycles_references.write_half_exr(str(tmp_path / "references" / "9.9.9" / "scene.exr"), committed_image)
    with open(cycles_references.manifest_path(), "w", encoding="utf-8") as fh:
        json.dump({"scene": {"key": digest(parts), "parts": parts}}, fh)

    def fetch(samples):
        return cycles_references.reference("scene", str(blend), (str(blend),), samples, {"samples": samples},
                                           str(cache), str(folder), render)

    np.testing.assert_array_equal(fetch(64), committed_image)
    assert renders == []
    with pytest.warns(UserWarning, match=r"9\.9\.9/scene is stale \(samples, cycles changed\): rendering it now"):
        stale = fetch(128)
    assert renders == [("CYCLES", 128)]
    np.testing.assert_array_equal(stale, fresh_image)
    with pytest.warns(UserWarning, match="is stale .* using the one rendered into the cache"):
        np.testing.assert_array_equal(fetch(128), fresh_image)
    assert renders == [("CYCLES", 128)]                     # rendered once, then cached under its key


def test_every_committed_reference_has_its_file_and_a_consistent_key():
    """Each manifest entry's key is the digest of its parts, for its folder's bpy version, with its half-float EXR
    beside it; every EXR there is in the manifest; the whole folder stays a few MB."""
    folders = sorted(glob.glob(os.path.join(cycles_references.REFERENCES, "*", "manifest.json")))
    assert folders, "no committed references"
    total = 0
    for manifest_file in folders:
        folder = os.path.dirname(manifest_file)
        version = os.path.basename(folder)
        manifest = cycles_references.read_manifest(version)
        exrs = {os.path.basename(p)[:-4] for p in glob.glob(os.path.join(folder, "*.exr"))}
        assert exrs == set(manifest), exrs ^ set(manifest)
        for name, entry in manifest.items():
            assert entry["key"] == digest(entry["parts"]), name
            assert entry["parts"]["bpy"] == version, name
            image = image_io.read_image(os.path.join(folder, f"{name}.exr"))
            assert image.ndim == 3 and image.shape[2] == 4 and np.isfinite(image).all(), name
        total += sum(os.path.getsize(os.path.join(folder, f)) for f in os.listdir(folder))
    assert total < 4e6, f"tests/references/ holds {total / 1e6:.1f} MB"


def test_a_scripted_reference_is_named_after_its_test_and_claimed_once(monkeypatch):
    """A label names the reference within the running test's file; True takes the test's name (with its parameters)
    and the output's stem; the same id asked for twice in one process is an error (two scenes would swap images)."""
    monkeypatch.setattr(cycles_references, "USED", set())
    monkeypatch.setenv("PYTEST_CURRENT_TEST", "tests/test_cycles_references.py::test_x[a-1] (call)")
    assert cycles_references.claim("sky", "/tmp/out.exr") == "test_cycles_references-sky"
    assert cycles_references.claim(True, "/tmp/cycles512.exr") == "test_cycles_references-test_x[a-1]-cycles512"
    with pytest.raises(RuntimeError, match="asked for twice"):
        cycles_references.claim("sky", "/tmp/other.exr")


def test_a_scripted_references_key_covers_the_test_modules_it_builds_scenes_with():
    """The test file's digest takes in the test modules it imports scene builders from (`from test_x import`)."""
    sources = cycles_references.builder_sources(os.path.join(cycles_references.TESTS, "test_blender_distributions.py"))
    names = [os.path.basename(path) for path in sources]
    assert names[0] == "test_blender_distributions.py"
    assert {"test_blender_anisotropy.py", "test_blender_denoise.py"} <= set(names[1:])
    assert all(os.path.isfile(path) for path in sources)
