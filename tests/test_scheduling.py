"""How `make test` shares the test files between its two pytest-xdist workers (tests/conftest.py)."""
from __future__ import annotations

import glob
import os

from conftest import SHARED_RENDERS, SPLIT_ACROSS_WORKERS, shares_a_blender_fixture

HERE = os.path.dirname(os.path.abspath(__file__))


def test_a_module_fixture_that_starts_blender_keeps_its_file_on_one_worker():
    """A file whose module fixture starts Blender is scheduled whole on one worker (its Blender process runs once,
    not once per worker); files of tests that render one by one, and files without Blender, are split."""
    for name in ("test_blender_filter_glossy.py", "test_blender_subsurface_disk.py", "test_blender_lamp_falloff.py",
                 "test_blender_volume_scatter_visibility.py", "test_blender_hair_mesh.py"):
        assert shares_a_blender_fixture(os.path.join(HERE, name)), name
    for name in ("test_blender_scenes.py", "test_blender_volumes.py", "test_path.py"):
        assert not shares_a_blender_fixture(os.path.join(HERE, name)), name
    listed = SHARED_RENDERS | SPLIT_ACROSS_WORKERS
    assert all(os.path.exists(os.path.join(HERE, name)) for name in listed), listed - set(
        os.path.basename(p) for p in glob.glob(os.path.join(HERE, "test_*.py")))
