"""Ray queries against closed forms, and the shared-buffer upload against embreex's copying one."""
import gc
import os

import numpy as np
import pytest

from core.geometry import embree_buffers
from core.geometry.intersect import Tracer


def _unit_square(z: float = 0.0):
    """Two triangles covering [0, 1]^2 at height z: vertices (4, 3) float32, triangles (2, 3) int32."""
    vertices = np.array([[0, 0, z], [1, 0, z], [1, 1, z], [0, 1, z]], np.float32)
    return vertices, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def _random_mesh(rng, count: int = 2000):
    """A random triangle soup in the unit ball: vertices (3 count, 3) float32, triangles (count, 3) int32."""
    vertices = (rng.normal(size=(3 * count, 3)) * 0.6).astype(np.float32)
    return vertices, rng.permutation(3 * count).reshape(count, 3).astype(np.int32)


def _rays_at_origin(rng, count: int):
    """Rays from a sphere of radius 3 towards random points near the origin: (count, 3) float64 each."""
    origins = rng.normal(size=(count, 3))
    origins *= 3.0 / np.linalg.norm(origins, axis=1)[:, None]
    D = rng.normal(size=(count, 3)) * 0.3 - origins
    return origins, D / np.linalg.norm(D, axis=1)[:, None]


@pytest.mark.parametrize("share", [True, False])
def test_hit_distance_equals_plane_distance(share):
    """A ray straight down onto a plane at height z from height h hits it at t = h - z."""
    tracer = Tracer(*_unit_square(z=0.25), share=share)
    xy = np.random.default_rng(3).uniform(0.01, 0.99, (500, 2))
    origins = np.c_[xy, np.full(500, 2.0)]
    hits = tracer.intersect(origins, np.tile([0.0, 0.0, -1.0], (500, 1)), np.full(500, np.inf))
    assert hits.hit.all()
    np.testing.assert_allclose(hits.t, 1.75, rtol=1e-6)
    # Barycentrics reproduce the hit point: I = (1 - u - v) V0 + u V1 + v V2 for the triangle hit.
    vertices, triangles = _unit_square(z=0.25)
    corners = vertices[triangles[hits.prim]]
    I = (1 - hits.u - hits.v)[:, None] * corners[:, 0] + hits.u[:, None] * corners[:, 1] + hits.v[:, None] * corners[:, 2]
    np.testing.assert_allclose(I[:, :2], xy, atol=1e-6)


@pytest.mark.parametrize("share", [True, False])
def test_occlusion_only_before_t_max(share):
    """A plane at distance 1 occludes a shadow ray with t_max = 1.5 and not one with t_max = 0.5."""
    tracer = Tracer(*_unit_square(z=0.0), share=share)
    origins = np.tile([0.5, 0.5, 1.0], (2, 1))
    blocked = tracer.occluded(origins, np.tile([0.0, 0.0, -1.0], (2, 1)), np.array([1.5, 0.5]))
    assert blocked.tolist() == [True, False]


def test_shared_buffers_are_used_here():
    """On this platform (Linux, the embreex wheel) the arrays go to Embree without embreex's copy."""
    assert Tracer(*_unit_square()).shared
    assert not Tracer(*_unit_square(), share=False).shared


def test_shared_buffers_call_the_embree_inside_embreex_not_blenders():
    """Blender ships its own libembree4 for Cycles; the shared path must use the copy embreex links to."""
    import embreex.rtcore_scene
    path = embree_buffers._loaded_embree_path()
    wheel = os.path.dirname(os.path.dirname(embreex.rtcore_scene.__file__))
    assert path is not None and os.path.commonpath([path, wheel]) == wheel
    assert os.path.basename(os.path.dirname(path)) in ("embreex.libs", ".dylibs", "embreex")
    with open(embreex.rtcore_scene.__file__, "rb") as module:
        assert os.path.basename(path).encode() in module.read()


def test_shared_and_copied_meshes_give_identical_hits():
    """Sharing changes only how the arrays reach Embree: every hit field and occlusion answer is bit-equal."""
    rng = np.random.default_rng(11)
    vertices, triangles = _random_mesh(rng)
    shared, copied = Tracer(vertices, triangles), Tracer(vertices, triangles, share=False)
    origins, D = _rays_at_origin(rng, 20000)
    t_max = rng.uniform(0.5, 6.0, 20000)
    a, b = shared.intersect(origins, D, t_max), copied.intersect(origins, D, t_max)
    assert 1000 < a.hit.sum() < 19000
    for field in a._fields:
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    np.testing.assert_array_equal(shared.occluded(origins, D, t_max), copied.occluded(origins, D, t_max))


def test_shared_mesh_survives_the_callers_arrays():
    """The Tracer keeps its own copies alive: overwriting and dropping the caller's arrays changes no hit."""
    vertices, triangles = _unit_square(z=0.5)
    tracer = Tracer(vertices, triangles)
    vertices[:] = 1e6
    triangles[:] = 0
    del vertices, triangles
    gc.collect()
    junk = [np.full((64, 3), 7.0, np.float32) for _ in range(100)]  # reuse any freed memory
    hits = tracer.intersect(np.array([[0.3, 0.6, 2.0]]), np.array([[0.0, 0.0, -1.0]]), np.array([np.inf]))
    assert hits.hit[0] and hits.t[0] == pytest.approx(1.5)
    del junk


def test_unknown_embreex_layout_falls_back_to_copying(monkeypatch):
    """If embreex's objects do not have the layout the shared path relies on, nothing is read from them: it copies."""
    monkeypatch.setattr(embree_buffers, "_SCENE_SIZE", embree_buffers._SCENE_SIZE + 8)
    tracer = Tracer(*_unit_square(z=0.0))
    assert not tracer.shared
    hits = tracer.intersect(np.array([[0.5, 0.5, 1.0]]), np.array([[0.0, 0.0, -1.0]]), np.array([np.inf]))
    assert hits.hit[0] and hits.t[0] == pytest.approx(1.0)


def test_scene_handles_refuse_a_scene_made_on_another_device():
    """The handles are read only for a scene whose device field points at the device we name."""
    from embreex import rtcore, rtcore_scene
    device, other = rtcore.EmbreeDevice(), rtcore.EmbreeDevice()
    scene = rtcore_scene.EmbreeScene(device)
    assert embree_buffers.scene_handles(scene, device) is not None
    assert embree_buffers.scene_handles(scene, other) is None
    assert scene.is_committed == 0  # the layout check restores the field it probes


def test_empty_mesh_hits_nothing():
    """With no triangles there is no BVH: every ray misses and nothing is occluded."""
    tracer = Tracer(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32))
    hits = tracer.intersect(np.zeros((3, 3)), np.tile([0.0, 0.0, 1.0], (3, 1)), np.full(3, np.inf))
    assert not hits.hit.any() and np.isinf(hits.t).all()
    assert not tracer.occluded(np.zeros((3, 3)), np.tile([0.0, 0.0, 1.0], (3, 1)), np.ones(3)).any()


def _packed_and_single(vertices, triangles, **kwargs):
    """The same mesh asked in packets of 8 and one ray at a time through embreex (the reference)."""
    packed, single = Tracer(vertices, triangles, **kwargs), Tracer(vertices, triangles, packets=False, **kwargs)
    assert packed.packed and not single.packed
    return packed, single


@pytest.mark.parametrize("count", [1, 15, 16, 17, 20003])
def test_packets_give_the_single_ray_answers(count):
    """rtcIntersect8 / rtcOccluded8 give every ray the answer rtcIntersect1 / rtcOccluded1 gives:
    whatever the batch's length (a last, partial packet included), hit, triangle, t and (u, v) agree
    bit for bit, and so do the occlusion answers; rays with t_max 0 or below find nothing."""
    rng = np.random.default_rng(17)
    packed, single = _packed_and_single(*_random_mesh(rng))
    origins, D = _rays_at_origin(rng, count)
    t_max = rng.uniform(-0.5, 6.0, count)
    t_max[::5] = np.inf
    a, b = packed.intersect(origins, D, t_max), single.intersect(origins, D, t_max)
    if count > 1000:
        assert 1000 < a.hit.sum() < count - 1000
    for field in ("hit", "t", "prim"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    np.testing.assert_array_equal(a.u[a.hit], b.u[b.hit])
    np.testing.assert_array_equal(a.v[a.hit], b.v[b.hit])
    assert not a.hit[t_max <= 0].any()
    blocked = packed.occluded(origins, D, t_max)
    np.testing.assert_array_equal(blocked, single.occluded(origins, D, t_max))
    if count > 1000:
        assert 1000 < blocked.sum() < count - 1000

