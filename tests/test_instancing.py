"""Instancing: a mesh stored once and traced through its placements gives what its copies give.

core/geometry/instancing.py stores a mesh placed many times once and finds, for every hit, the
instance it was on (embreex reports no instance ID). Each test compares the instanced scene
with the same scene copied triangle by triangle (the reference path), or with a closed form.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import sun_direction
from core.integrators import debug
from core.geometry import instancing
from core.geometry import primitives
from core import render
from core.camera import Camera
from core.geometry.geometry import build_geometry
from core.scene import Instance, PointLight, RenderSettings, Scene, SunLight
from hard_cases import ALBEDO, rotation, wrong_fraction

COPY = 1 << 62      # instance_triangles that copies every mesh
INSTANCE = 0        # instance_triangles that instances every mesh placed twice or more


def random_rotation(rng) -> np.ndarray:
    """Return a random proper rotation: (3, 3) float64."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.sign(np.linalg.det(q))


def scattered_scene(count: int = 60, seed: int = 3) -> Scene:
    """Return spheres (smooth) and cubes placed `count` times each, rotated, unevenly scaled, some mirrored,
    with per-object materials, over a copied ground plane and lit by a sun and a point light."""
    rng = np.random.default_rng(seed)
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 5.0), (0.0, 0.0, 0.0), fov=math.radians(55)),
                  world_color=np.array([0.02, 0.02, 0.03]))
    for colour in ((0.7, 0.7, 0.7), (0.8, 0.3, 0.2), (0.2, 0.3, 0.8)):
        scene.add_material(colour)
    scene.add_mesh(primitives.plane(12.0))
    sphere = len(scene.meshes)
    scene.meshes.append(primitives.uv_sphere(1.0, 12, 6, smooth=True))
    cube = len(scene.meshes)
    scene.meshes.append(primitives.box((1.0, 1.0, 1.0)))
    for index in range(2 * count):
        M = np.eye(4)
        scale = np.diag(rng.uniform(0.2, 0.6, 3))
        if index % 7 == 0:
            scale[0, 0] *= -1.0                       # a mirror: det < 0
        M[:3, :3] = random_rotation(rng) @ scale
        M[:3, 3] = (rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(0.2, 1.0))
        scene.instances.append(Instance(sphere if index % 2 else cube, M, np.array([1 + index % 2]), f"Object {index}"))
    scene.lights.append(SunLight(np.array([-0.4, 0.5, -0.77]) / np.linalg.norm([-0.4, 0.5, -0.77]), strength=1.0))
    scene.lights.append(PointLight(np.array([1.0, -2.0, 3.0]), power=300.0))
    return scene


def both_geometries(scene: Scene):
    """Return the scene's geometry copied and instanced (the same triangles, the same flat indices)."""
    origin = np.asarray(scene.camera.matrix_world, np.float64)[:3, 3]
    copied = build_geometry(scene, origin, instance_triangles=COPY)
    instanced = build_geometry(scene, origin, instance_triangles=INSTANCE)
    assert not copied.instanced and len(instanced.instanced) == 2
    return copied, instanced


def random_rays(n: int, seed: int = 5):
    """Return n rays from around the camera towards the scene: origins, unit directions (n, 3) float64, t_max (n,)."""
    rng = np.random.default_rng(seed)
    O = rng.uniform(-1.0, 1.0, (n, 3)) + [0.0, 0.0, 0.0]
    target = rng.uniform([-5, -5, -0.2], [5, 5, 1.5], (n, 3)) - [0.0, -9.0, 5.0]   # camera-relative
    D = target - O
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    return O, D, np.full(n, np.inf)


def test_instances_store_the_mesh_once():
    """The instanced mesh keeps one copy of its vertices and a few dozen bytes per placement."""
    scene = scattered_scene()
    _, geometry = both_geometries(scene)
    sphere = geometry.instanced[1]
    assert len(sphere.vertices) == len(scene.meshes[1].vertices)
    assert len(sphere.transforms) == 60
    placement_bytes = (sphere.transforms.nbytes + sphere.flip.nbytes + sphere.material_row.nbytes
                       + sphere.owner.nbytes + sphere.locator.boxes.nbytes + sphere.locator.keys.nbytes)
    assert placement_bytes / 60 < 256
    assert geometry.triangle_count == len(geometry.triangles) + sum(m.triangle_count for m in geometry.instanced)


def test_instanced_hits_are_the_copied_hits():
    """20,000 random rays hit the same triangles at the same distances, copied or instanced."""
    copied, instanced = both_geometries(scattered_scene())
    O, D, t_max = random_rays(20_000)
    a = copied.tracer.intersect(O, D, t_max)
    b = instanced.tracer.intersect(O, D, t_max)
    assert a.hit.mean() > 0.5
    # Rays may part ways only where they graze an edge (float32 transforms differ in the last bit).
    assert (a.hit != b.hit).mean() < 1e-3
    both = a.hit & b.hit
    assert (a.prim[both] == b.prim[both]).mean() > 0.999
    np.testing.assert_allclose(b.t[both], a.t[both], rtol=1e-5, atol=1e-6)
    # The barycentric points agree too (in world units: Embree solves instances in object space).
    same = np.flatnonzero(both & (a.prim == b.prim))
    corners = copied.triangle_data(a.prim[same], smooth=False).corners
    def point(h):
        return ((1.0 - h.u[same] - h.v[same])[:, None] * corners[:, 0] + h.u[same, None] * corners[:, 1]
                + h.v[same, None] * corners[:, 2])
    assert np.linalg.norm(point(b) - point(a), axis=1).max() < 1e-5 * 20.0     # 20: the scene's size


def test_instanced_triangle_data_is_the_copied_data():
    """Corners, face normals (mirrors included), smooth corner normals and materials agree for every triangle."""
    copied, instanced = both_geometries(scattered_scene())
    prim = np.arange(copied.triangle_count)
    a, b = copied.triangle_data(prim), instanced.triangle_data(prim)
    np.testing.assert_allclose(b.corners, a.corners, atol=1e-6)
    np.testing.assert_allclose(b.Ng, a.Ng, atol=1e-5)
    np.testing.assert_array_equal(b.material, a.material)
    np.testing.assert_array_equal(b.smooth, a.smooth)
    np.testing.assert_allclose(b.corner_normals, a.corner_normals, atol=1e-5)
    # Every face normal is the front side of its corners' winding, mirrored objects too.
    assert b.smooth.sum() > 1000
    owners = [instanced.instance_of(int(p)) for p in prim[::97]]
    assert owners == [int(copied.instance[p]) for p in prim[::97]]


def test_instanced_render_is_the_copied_render():
    """The whole render (shading, shadow rays, smooth normals, mirrored objects) agrees to float32 rounding."""
    scene = scattered_scene()
    settings = RenderSettings(width=96, height=54, samples=4, jitter=True, instancing="never")
    copied = render.render(scene, settings)
    instanced = render.render(scene, dataclasses.replace(settings, instancing="always"))
    assert instanced.stats.triangles == copied.stats.triangles
    # A sample may part ways where a ray grazes an edge (a silhouette, a shadow's edge): the
    # float32 transform and the float32 copy round differently. Anything more would show up here.
    differs = np.abs(instanced.image - copied.image).max(axis=-1) > 1e-4
    assert differs.mean() < 2e-3
    assert np.abs(instanced.image - copied.image).mean() < 1e-5
    assert copied.image[..., :3].mean() > 0.05


def test_identification_picks_the_stacked_instance_the_ray_met():
    """Two copies of a quad stacked 1 apart: a ray from above meets the upper at t = 2, from below the lower at t = 1."""
    scene = Scene(camera=Camera.look_at((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)))
    scene.add_material((0.5, 0.5, 0.5))
    scene.meshes.append(primitives.plane(2.0))
    for z in (0.0, 1.0):
        M = np.eye(4)
        M[2, 3] = z
        scene.instances.append(Instance(0, M, None, f"Quad {z}"))
    geometry = build_geometry(scene, np.zeros(3), instance_triangles=INSTANCE)
    O = np.array([[0.3, 0.2, 3.0], [0.3, 0.2, -1.0], [-0.4, -0.6, 3.0]])
    D = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    hits = geometry.tracer.intersect(O, D, np.full(3, np.inf))
    np.testing.assert_allclose(hits.t, [2.0, 1.0, 2.0], rtol=1e-6)
    names = [scene.instances[geometry.instance_of(int(p))].name for p in hits.prim]
    assert names == ["Quad 1.0", "Quad 0.0", "Quad 1.0"]


def test_locator_finds_every_box_that_holds_a_point():
    """The grid's candidates include every box containing the point, with boxes of very different sizes."""
    rng = np.random.default_rng(11)
    centre = rng.uniform(-10, 10, (500, 3))
    half = rng.uniform(0.05, 0.5, (500, 3))
    half[:5] *= 80.0                                  # a few huge boxes: tried for every point
    lo, hi = centre - half, centre + half
    locator = instancing.InstanceLocator(lo, hi)
    assert len(locator.everywhere) >= 1
    points = rng.uniform(-12, 12, (3000, 3))
    rows, boxes = locator.candidates(points)
    found = set(zip(rows.tolist(), boxes.tolist()))
    inside = np.flatnonzero(((points[:, None] >= lo) & (points[:, None] <= hi)).all(axis=2).ravel())
    expected = set(zip((inside // 500).tolist(), (inside % 500).tolist()))
    assert expected and expected <= found
    assert len(found) < 0.05 * len(points) * len(lo)     # and far fewer pairs than trying every box


@pytest.mark.parametrize("offset", [0.0, 1e5])
@pytest.mark.parametrize("elevation", [1.0, 0.05])
def test_no_shadow_acne_on_instanced_tiles_at_grazing_sun(elevation, offset):
    """A floor of 100 instanced tiles, tilted off the axes, lit by a grazing sun: every pixel takes the closed form."""
    R = rotation((0.3, 0.5, 0.8), 0.7)
    origin = R @ np.array([offset, 0.5 * offset, 0.3 * offset])
    scene = Scene(camera=Camera.look_at(origin + R @ [0.0, -4.0, 2.5], origin, R @ [0.0, 0.0, 1.0],
                                        fov=math.radians(60), clip_start=0.01, clip_end=1e3))
    scene.add_material((ALBEDO,) * 3)
    scene.meshes.append(primitives.plane(10.0))
    for i in range(10):
        for j in range(10):
            M = np.eye(4)
            M[:3, :3], M[:3, 3] = R, origin + R @ [10.0 * i - 45.0, 10.0 * j - 45.0, 0.0]
            scene.instances.append(Instance(0, M, None, f"Tile {i} {j}"))
    scene.lights.append(SunLight(R @ sun_direction(elevation, 30.0), strength=3.0))
    settings = RenderSettings(width=64, height=64, samples=1, jitter=False, aux=("depth",), instancing="always")
    geometry = build_geometry(scene, np.asarray(scene.camera.matrix_world)[:3, 3], instance_triangles=INSTANCE)
    assert len(geometry.instanced) == 1
    result = render.render(scene, settings)
    hit = result.aux["depth"][..., 0] < debug.MISS_DEPTH
    exact = ALBEDO / math.pi * 3.0 * math.sin(math.radians(elevation))
    assert hit.mean() > 0.5
    assert wrong_fraction(result.image, hit, exact) == 0.0


def test_bad_instances_are_reported_like_bad_copies():
    """NaN vertices, zero-area triangles, missing materials and an unplaceable object give the copies' warnings."""
    scene = Scene(camera=Camera.look_at((0.0, -6.0, 3.0), (0.0, 0.0, 0.0)))
    scene.add_material((0.5, 0.5, 0.5))
    mesh = primitives.uv_sphere(1.0, 8, 4, smooth=True)
    mesh.vertices = np.vstack([mesh.vertices, [[np.nan, 0.0, 0.0], [1.0, 1.0, 1.0]]])
    mesh.corner_normals = None                        # derived from the vertices
    v = len(mesh.vertices)
    mesh.triangles = np.vstack([mesh.triangles, [[0, 1, v - 2], [v - 1, v - 1, 0]]])
    mesh.smooth = np.append(mesh.smooth, [True, True])
    mesh.material_indices = np.append(mesh.material_indices, [0, 0])
    mesh.material_indices[:3] = 5                    # no such slot: default grey
    scene.meshes.append(mesh)
    for index in range(6):
        M = np.eye(4)
        M[:3, 3] = (index - 2.5, 0.0, 0.0)
        scene.instances.append(Instance(0, M, np.array([0]), f"Ball {index}"))
    M = np.eye(4)
    M[0, 0] = 0.0
    scene.instances.append(Instance(0, M, np.array([0]), "Flat"))
    copied = build_geometry(scene, np.zeros(3), instance_triangles=COPY)
    instanced = build_geometry(scene, np.zeros(3), instance_triangles=INSTANCE)
    assert instanced.instanced and sorted(instanced.warnings) == sorted(copied.warnings)
    assert any("NaN" in w for w in copied.warnings) and any("zero-area" in w for w in copied.warnings)
    assert instanced.triangle_count == copied.triangle_count


def test_acne_debug_view_reads_instanced_triangles():
    """The acne debug view (an extra nearest-hit query per blocked shadow ray) works on instances as on copies."""
    scene = scattered_scene(count=20)
    settings = RenderSettings(width=48, height=27, samples=2, jitter=True, aux=("acne",), instancing="never")
    copied = render.render(scene, settings).aux["acne"]
    instanced = render.render(scene, dataclasses.replace(settings, instancing="always")).aux["acne"]
    np.testing.assert_allclose(instanced, copied, atol=1e-6)
    assert debug.scene_scale(build_geometry(scene, np.zeros(3), instance_triangles=INSTANCE)) > 5.0


def test_instancing_setting_chooses_what_is_stored_once():
    """"auto" instances only above INSTANCE_TRIANGLES, "always" every repeated mesh, "never" none; others are refused."""
    scene = scattered_scene(count=10)
    origin = np.zeros(3)
    counts = {mode: len(build_geometry(scene, origin, instancing.instance_triangles(mode)).instanced)
              for mode in instancing.INSTANCING_MODES}
    assert counts == {"auto": 0, "always": 2, "never": 0}      # 10 x 72 triangles is far below 2^18
    with pytest.raises(ValueError, match="instancing"):
        render.render(scene, RenderSettings(width=8, height=8, samples=1, instancing="sometimes"))


def test_crowded_instances_are_copied_unless_always(monkeypatch):
    """600 spheres piled up in one place: copied in "auto"; with "always" still identified, a bounded batch at a time."""
    rng = np.random.default_rng(17)
    scene = Scene(camera=Camera.look_at((0.0, -6.0, 2.0), (0.0, 0.0, 0.0)))
    scene.add_material((0.5, 0.5, 0.5))
    scene.meshes.append(primitives.uv_sphere(1.0, 8, 4, smooth=False))
    for index in range(600):
        M = np.eye(4)
        M[:3, 3] = rng.uniform(-0.05, 0.05, 3)
        scene.instances.append(Instance(0, M, None, f"Ball {index}"))
    assert build_geometry(scene, np.zeros(3), instance_triangles=1).instanced == []
    crowded = build_geometry(scene, np.zeros(3), instance_triangles=INSTANCE)
    assert crowded.instanced[0].locator.crowding > instancing.CROWDED
    copied = build_geometry(scene, np.zeros(3), instance_triangles=COPY)
    monkeypatch.setattr(instancing, "MAX_PAIRS", 5000)          # many small batches
    O = np.tile([0.0, -6.0, 2.0], (3000, 1))
    target = np.random.default_rng(2).uniform(-1.0, 1.0, (3000, 3))
    D = (target - O) / np.linalg.norm(target - O, axis=1, keepdims=True)
    a = copied.tracer.intersect(O, D, np.full(3000, np.inf))
    b = crowded.tracer.intersect(O, D, np.full(3000, np.inf))
    both = a.hit & b.hit
    assert both.sum() > 1000 and (a.hit != b.hit).mean() < 1e-3
    np.testing.assert_allclose(b.t[both], a.t[both], rtol=1e-5)
    assert (a.prim[both] == b.prim[both]).mean() > 0.99


def test_packets_find_the_instanced_triangles_single_rays_find():
    """Embree's packet queries walk instance arrays as its single-ray ones do: the same flat triangle,
    distance and barycentrics for every ray, and the same occlusion answers."""
    from core.geometry.intersect import Tracer
    _, instanced = both_geometries(scattered_scene())
    packed = instanced.tracer
    single = Tracer(instanced.vertices, instanced.triangles, instanced=instanced.instanced, packets=False)
    assert packed.packed and not single.packed
    O, D, t_max = random_rays(20_003, seed=9)
    a, b = packed.intersect(O, D, t_max), single.intersect(O, D, t_max)
    assert a.hit.mean() > 0.5
    for field in ("hit", "t", "prim"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    np.testing.assert_array_equal(a.u[a.hit], b.u[b.hit])
    np.testing.assert_array_equal(a.v[a.hit], b.v[b.hit])
    short = np.where(a.hit, a.t * 0.5, 3.0)
    np.testing.assert_array_equal(packed.occluded(O, D, short), single.occluded(O, D, short))
    np.testing.assert_array_equal(packed.occluded(O, D, t_max), a.hit)


def test_embree_names_the_placement_the_point_search_finds():
    """Embree's packet queries report each instanced hit's placement (instPrimID); it is the one
    the hit's own point finds among the boxes (mesh.identify), for every hit but edge grazes."""
    from core.geometry.intersect import packet_intersect
    _, instanced = both_geometries(scattered_scene())
    tracer = instanced.tracer
    O, D, t_max = random_rays(20_000, seed=13)
    t, prim, geometry, u, v, instance = packet_intersect(tracer.packets, O, D, t_max)
    checked = 0
    for number, mesh in enumerate(instanced.instanced, start=1):
        on = np.flatnonzero(geometry == number)
        X = O[on] + t[on, None] * D[on]
        found = mesh.identify(prim[on], u[on], v[on], X)
        assert (instance[on] >= 0).all() and (instance[on] < len(mesh.transforms)).all()
        assert (instance[on] == found).mean() > 0.999
        checked += len(on)
    assert checked > 5000
    assert (instance[geometry == 0] == -1).all() and (instance[geometry < 0] == -1).all()


def twin_spheres_scene(count: int = 6) -> Scene:
    """Return `count` spheres that are separate Scene meshes of the same numbers (an importer's copies of one shape,
    one per material), each placed once with a material of its own, and one sphere that differs in one vertex."""
    scene = Scene(camera=Camera.look_at((0.0, -9.0, 5.0), (0.0, 0.0, 0.0), fov=math.radians(55)),
                  world_color=np.array([0.02, 0.02, 0.03]))
    for index in range(count + 1):
        scene.add_material((0.1 + 0.1 * index, 0.5, 0.5))
    sphere = primitives.uv_sphere(1.0, 12, 6, smooth=True)
    for index in range(count + 1):
        twin = dataclasses.replace(sphere, vertices=sphere.vertices.copy(), triangles=sphere.triangles.copy(),
                                   corner_normals=sphere.corner_normals.copy(), name=f"Sphere {index}")
        if index == count:
            twin.vertices[0, 2] += 1e-3                       # one number differs: a mesh of its own
        scene.meshes.append(twin)
        M = np.eye(4)
        M[:3, 3] = (2.5 * index - 7.0, 0.0, 0.5)
        scene.instances.append(Instance(index, M, np.array([index]), f"Object {index}"))
    scene.lights.append(SunLight(np.array([-0.4, 0.5, -0.77]) / np.linalg.norm([-0.4, 0.5, -0.77]), strength=1.0))
    return scene


def test_identical_meshes_are_placed_as_one_mesh():
    """Meshes of the same numbers are stored once and instanced, each placement with its own materials, as their
    copies are; a mesh that differs in one number is not among them."""
    from core.geometry.geometry import same_meshes
    scene = twin_spheres_scene()
    assert same_meshes(scene.meshes).tolist() == [0, 0, 0, 0, 0, 0, 6]
    origin = np.asarray(scene.camera.matrix_world, np.float64)[:3, 3]
    copied = build_geometry(scene, origin, instance_triangles=COPY)
    instanced = build_geometry(scene, origin, instance_triangles=INSTANCE)
    assert [len(m.transforms) for m in instanced.instanced] == [6]
    assert len(instanced.triangles) == len(scene.meshes[6].triangles)          # the odd one out, copied
    assert instanced.triangle_count == copied.triangle_count
    prim = np.arange(copied.triangle_count)
    a, b = copied.triangle_data(prim), instanced.triangle_data(prim)
    # The copies number the six twins first, then the odd one; instanced, the copied odd one comes first.
    odd = len(instanced.triangles)
    same = np.concatenate([prim[odd:], prim[:odd]])
    np.testing.assert_allclose(b.corners[same], a.corners, atol=1e-6)
    np.testing.assert_array_equal(b.material[same], a.material)
    np.testing.assert_allclose(b.corner_normals[same], a.corner_normals, atol=1e-6)
    assert len(np.unique(b.material)) == 7


def test_compiled_tables_keep_an_instanced_meshs_copied_arrays():
    """The compiled kernels' tables of an instanced mesh read its material rows after Python made C-ordered copies
    of them: a mesh that drops a zero-area triangle and whose placements use different materials has its material
    table in Fortran order, copied for C, and that copy must live as long as the tables."""
    import ctypes
    import gc
    from core.geometry.tables import GeometryTables
    scene = twin_spheres_scene()
    for mesh in scene.meshes:
        mesh.triangles[0] = (0, 0, 1)                         # zero area: dropped from the prototype
    origin = np.asarray(scene.camera.matrix_world, np.float64)[:3, 3]
    geometry = build_geometry(scene, origin, instance_triangles=INSTANCE)
    mesh = geometry.instanced[0]
    assert not mesh.material.flags.c_contiguous               # (what made the copy)
    tables = GeometryTables(geometry)
    gc.collect()
    litter = [np.full(mesh.material.size, -7, np.int32) for _ in range(64)]   # (memory a freed copy would give)
    record = tables.meshes[0]
    read = np.ctypeslib.as_array((ctypes.c_int32 * mesh.material.size).from_address(record.material))
    np.testing.assert_array_equal(read.reshape(mesh.material.shape), mesh.material)
    del litter
