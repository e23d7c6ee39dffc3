"""Shared builders for the tests: small scenes whose every pixel has a closed form."""
from __future__ import annotations

import ast
import functools
import math
import os
import sys

import numpy as np
import pytest

from core.camera import camera as camera_
from core.camera import Camera

# The Blender tests set Primer's settings piecemeal (samples here, the integrator there) and hold them to closed forms
# and to Cycles set up as Primer's reference: Render > Settings' Automatic takes Primer's own settings for them
# (addon/cycles_settings.py), in this process and in the Blender processes it starts. A test of following Cycles
# chooses CYCLES on its scene.
os.environ.setdefault("PRIMER_SETTINGS_SOURCE", "PRIMER")


def ortho_down(center=(0.0, 0.0, 0.0), height: float = 1.0, scale: float = 2.0, **kw) -> Camera:
    """Return an orthographic camera `height` above `center`, looking straight down (-Z), image +x = world +x."""
    matrix = np.eye(4)
    matrix[:3, 3] = np.asarray(center, np.float64) + [0.0, 0.0, height]
    kw.setdefault("clip_start", height * 1e-3)
    kw.setdefault("clip_end", height * 10.0)
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=scale, **kw)


def pixel_points_on_plane(camera: Camera, width: int, height: int, plane_z: float) -> np.ndarray:
    """Return where each pixel centre's camera ray meets the plane z = plane_z: (H, W, 3) float64."""
    ys, xs = np.mgrid[0:height, 0:width]
    rays = camera_.generate_rays(camera, width, height, xs.ravel() + 0.5, ys.ravel() + 0.5)
    t = (plane_z - rays.origins[:, 2]) / rays.directions[:, 2]
    return (rays.origins + t[:, None] * rays.directions).reshape(height, width, 3)


def sun_direction(elevation_deg: float, azimuth_deg: float = 0.0) -> np.ndarray:
    """Return the direction in which sunlight travels for a sun at the given elevation above the xy plane."""
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    towards_sun = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    return -towards_sun


def unit(vector):
    """Return `vector` ((3,) or (n, 3)) normalised along its last axis."""
    vector = np.asarray(vector, dtype=np.float64)
    return vector / np.linalg.norm(vector, axis=-1, keepdims=True)


def rotation(axis, angle):
    """Return the (3, 3) rotation by `angle` radians about `axis` (Rodrigues)."""
    x, y, z = unit(axis)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


@pytest.fixture
def rng():
    """A fixed-seed random generator."""
    return np.random.default_rng(12345)


# Test files whose tests pytest-xdist (`make test` runs `pytest -n 2`) gives to one worker, one after the other: they
# write into the checkout, which tools/build_extension.py copies while it builds the zip. test_extension.py builds
# dist/check/<environment>/primer-<version>.zip (once per worker that runs it), test_platforms.py dist/kernels-check/ (when older
# than a C file), and test_tour.py writes docs/images/tour/ (two of its tests the same picture).
ONE_WORKER = {"test_extension.py", "test_platforms.py", "test_tour.py"}
# Test files whose tests share one expensive module fixture (Primer's and Cycles' renders of every case, often in Blender
# processes of their own): each file's tests on one worker, so that the fixture renders once, not once per worker. A
# new file of that kind belongs here: split over both workers, its fixture's renders are paid twice (test_blender_animation's
# seven Blender processes, test_blender_hair's renders, ...: about a minute of CPU per make test run, measured).
SHARED_RENDERS = {"test_blender_world_nodes.py", "test_blender_sky.py", "test_blender_lightgroups.py",
                  "test_blender_animation.py", "test_blender_cryptomatte.py", "test_blender_finite.py",
                  "test_blender_glass_inputs.py", "test_blender_hair.py", "test_blender_image_sources.py",
                  "test_blender_light_passes.py", "test_blender_light_path.py", "test_blender_missing_images.py",
                  "test_blender_passes.py", "test_blender_shadow_catcher.py", "test_blender_subsurface.py"}
# Test files whose module fixtures start Blender only to write files the tests then render one by one: split.
SPLIT_ACROSS_WORKERS = {"test_blender_scenes.py"}


@functools.lru_cache(maxsize=None)
def shares_a_blender_fixture(path: str) -> bool:
    """Whether the test file at `path` is a SHARED_RENDERS file: listed there, or one of its module-scoped fixtures
    starts Blender (calls run_bpy) and it is not in SPLIT_ACROSS_WORKERS. (Seven files of the second kind had been
    left off the list, each paying its Blender process twice.)"""
    name = os.path.basename(path)
    if name in SHARED_RENDERS:
        return True
    if name in SPLIT_ACROSS_WORKERS or not name.startswith("test_blender_") or not os.path.exists(path):
        return False
    with open(path, encoding="utf-8") as handle:
        tree = ast.parse(handle.read())
    for node in ast.walk(tree):
        module_scoped = isinstance(node, ast.FunctionDef) and any(
            isinstance(d, ast.Call) and any(k.arg == "scope" and getattr(k.value, "value", None) == "module"
                                            for k in d.keywords) for d in node.decorator_list)
        if module_scoped and any(isinstance(c, ast.Call) and getattr(c.func, "id", None) == "run_bpy"
                                 for c in ast.walk(node)):
            return True
    return False


@pytest.hookimpl(optionalhook=True)         # a hook of pytest-xdist, which .venv42 does not install
def pytest_xdist_make_scheduler(config, log):
    """pytest-xdist's scheduling: every test on its own (as --dist load), but the tests of ONE_WORKER's files
    together on one worker, and each SHARED_RENDERS file's (shares_a_blender_fixture) on one worker. (xdist 3.8's --dist loadgroup groups nothing under pytest 9.2, which no longer reads
    the node id xdist changes to mark a group.)"""
    from xdist.scheduler import LoadScopeScheduling

    class OneWorkerForTheCheckoutsWriters(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            name = os.path.basename(path)
            return ("one worker" if name in ONE_WORKER else name
                    if shares_a_blender_fixture(os.path.join(str(config.rootpath), path)) else nodeid)

    return OneWorkerForTheCheckoutsWriters(config, log)


def pytest_runtest_setup(item) -> None:
    """Once a test module has imported bpy, give the scenes Blender loads the 1-pixel box filter
    (blender_env.keep_box_filter): the Blender tests' closed forms and Cycles references are a box's."""
    if "bpy" in sys.modules:
        from blender_env import keep_box_filter
        keep_box_filter()
