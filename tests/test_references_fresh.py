"""The committed Cycles references of the Blender tests' own scenes (tests/references/<bpy>/scripted/) match the test
files and helpers that made them: a test edited without `make references` makes every run of the suite render Cycles
again for it, in both Blender runs (24 images x 2 were so at stop 46, minutes of CI each time). This checks the parts
of each reference's key that need no Blender (its test file and the modules it imports scenes from, blender_env.py
and tools/render.py); the rest (Cycles' settings, the files read, the samples) the tests themselves check."""
from __future__ import annotations

import json
import os

import pytest

import cycles_references as refs

VERSIONS = sorted(name for name in os.listdir(refs.REFERENCES)
                  if os.path.isfile(os.path.join(refs.REFERENCES, name, refs.SCRIPTED, "manifest.json")))


@pytest.mark.parametrize("version", VERSIONS)
def test_every_scripted_reference_was_made_by_the_test_files_as_they_are(version):
    """Each manifest entry's test and helpers digests equal those of the files now; its test file exists."""
    with open(os.path.join(refs.REFERENCES, version, refs.SCRIPTED, "manifest.json"), encoding="utf-8") as fh:
        manifest = json.load(fh)
    helpers = refs.digest(os.path.join(refs.TESTS, "blender_env.py"), refs.RENDER_TOOL)
    stale = []
    for ref_id, entry in sorted(manifest.items()):
        test = os.path.join(refs.TESTS, ref_id.split("-")[0] + ".py")
        if not os.path.isfile(test):
            stale.append(f"{ref_id}: no test file {os.path.basename(test)} (remove the entry and its image)")
        elif entry["parts"]["test"] != refs.digest(*refs.builder_sources(test)):
            stale.append(f"{ref_id}: its test file changed (run it with PRIMER_WRITE_REFERENCES=1)")
        elif entry["parts"]["helpers"] != helpers:
            stale.append(f"{ref_id}: blender_env.py or tools/render.py changed (`make references`)")
    assert not stale, "\n".join(stale)
