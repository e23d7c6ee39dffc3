"""Viewport rendering in real Blender (the bpy module): scene reuse, the view's camera, progressive passes.

Background Blender has no 3D viewport and no GPU ("GPU functions for drawing are not available in
background mode"), so view_update and view_draw cannot be called by Blender here. The tests drive
their plain-Python halves instead: the ViewportSession gets the depsgraph inside Blender's
depsgraph_update_post handler, where `depsgraph.updates` holds the same records view_update sees,
and views are made from Blender's own camera projection (Object.calc_matrix_camera), the matrices
a viewport in camera view has at zoom 1.
"""
from __future__ import annotations

import math
import os
import sys
import time

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from render import load_primer  # noqa: E402
from blender_env import diffuse_material  # noqa: E402

from core.camera import camera as camera_  # noqa: E402
from core.render import progressive  # noqa: E402
from core.camera import view as view_  # noqa: E402

pytestmark = pytest.mark.blender
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def viewport_module(primer):
    """Return the add-on's viewport module."""
    return sys.modules[primer.__name__ + ".addon.viewport"]


def add_mesh(scene, name, vertices, faces, location=(0.0, 0.0, 0.0), mesh=None):
    """Link a new mesh object (a new mesh from vertices and faces, or `mesh` shared) and return it."""
    if mesh is None:
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(vertices, [], faces)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    scene.collection.objects.link(obj)
    if not mesh.materials:                     # the lecture's grey Lambert surface, for its closed forms
        mesh.materials.append(bpy.data.materials.get("Lecture Lambert") or diffuse_material("Lecture Lambert"))
    return obj


CUBE = ([(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (0.0, 1.0)],
        [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])


def build_scene():
    """An empty file with a 20 m grey plane, two cubes sharing a mesh, a third cube, a sun and a camera."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "PRIMER"
    scene.primer.viewport_samples = 2
    add_mesh(scene, "Plane", [(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], [(0, 1, 2, 3)])
    a = add_mesh(scene, "Cube A", *CUBE, location=(-2.0, 0.0, 0.0))
    add_mesh(scene, "Cube A Twin", None, None, location=(2.0, 0.0, 0.0), mesh=a.data)
    add_mesh(scene, "Cube B", *CUBE, location=(0.0, 3.0, 0.0))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 2.0
    sun.data.angle = 0.0
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, 0.0, 20.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


class Recorder:
    """Feeds the session from depsgraph_update_post, as Blender feeds view_update, and keeps the reports."""

    def __init__(self, session):
        self.session = session
        self.reports = []

    def __call__(self, scene, depsgraph):
        self.reports.append(self.session.update(depsgraph, start=False))

    def change(self, edit):
        """Apply `edit`, let Blender evaluate, and return the one report of that update."""
        self.reports.clear()
        edit()
        bpy.context.view_layer.update()
        assert len(self.reports) == 1, f"expected one depsgraph update, got {len(self.reports)}"
        return self.reports[0]


@pytest.fixture
def session_in_scene(primer):
    """A built scene, a ViewportSession synced with it, and a Recorder of later updates."""
    scene = build_scene()
    session = viewport_module(primer).ViewportSession()
    first = session.update(bpy.context.evaluated_depsgraph_get(), start=False)
    recorder = Recorder(session)
    bpy.app.handlers.depsgraph_update_post.append(recorder)
    try:
        yield scene, session, recorder, first
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(recorder)
        session.stop()


def camera_view(scene, width, height):
    """Return the progressive View of the scene camera as a viewport in camera view (zoom 1) shows it."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = scene.camera.evaluated_get(depsgraph)
    window = np.array(camera.calc_matrix_camera(depsgraph, x=width, y=height), np.float64)
    return progressive.region_view(np.array(camera.matrix_world.inverted(), np.float64), window, width, height)


def test_first_sync_exports_every_object_and_a_shared_mesh_once(session_in_scene):
    """Four objects are placed; the two cubes sharing a mesh read it once: three meshes in all."""
    _, session, _, first = session_in_scene
    assert sorted(first.objects) == ["Cube A", "Cube A Twin", "Cube B", "Plane"]
    assert sorted(first.meshes) == ["Cube A", "Cube B", "Plane"]
    assert first.bvh and first.lights == 1
    assert len(session.cache.geometry.triangles) == 2 + 3 * 12


def test_moving_one_object_reexports_only_that_object(session_in_scene):
    """A transform re-reads one placement and no mesh data; the BVH moves the cube's triangles."""
    scene, session, recorder, _ = session_in_scene
    report = recorder.change(lambda: setattr(bpy.data.objects["Cube B"], "location", (0.0, 5.0, 0.0)))
    # The scene's one light is read again too (lights are few; one in an instanced collection moves
    # with its instancer, and only the instancer is tagged), but no mesh data.
    assert report.objects == ["Cube B"] and report.meshes == [] and report.lights == 1
    assert report.bvh and report.changed
    # The moved cube's top face is now at y in [4.5, 5.5] (plus the camera-relative origin).
    geometry = session.cache.geometry
    world = geometry.vertices.astype(np.float64) + geometry.origin
    top = world[geometry.triangles].reshape(-1, 3)
    assert np.any(np.isclose(top[:, 1], 5.5) & np.isclose(top[:, 2], 1.0))
    assert not np.any(np.isclose(top[:, 1], 3.5) & np.isclose(top[:, 2], 1.0))


def test_editing_one_mesh_reexports_only_that_mesh(session_in_scene):
    """Editing the shared cube mesh reads it once, places its two users again, and leaves the rest cached."""
    _, session, recorder, _ = session_in_scene

    def edit():
        mesh = bpy.data.meshes["Cube A"]
        for vertex in mesh.vertices:
            vertex.co.z *= 2.0
        mesh.update()

    report = recorder.change(edit)
    assert report.meshes == ["Cube A"]
    assert sorted(report.objects) == ["Cube A", "Cube A Twin"]
    assert report.bvh and report.lights == 0
    heights = session.cache.geometry.vertices[:, 2] + session.cache.geometry.origin[2]
    assert np.isclose(heights, 2.0, atol=1e-5).sum() == 2 * 4        # both users' tops moved to z = 2


def test_changing_a_light_rebuilds_no_bvh(session_in_scene):
    """A light's strength re-exports the lights only; the BVH object is the same one."""
    scene, session, recorder, _ = session_in_scene
    geometry = session.cache.geometry
    report = recorder.change(lambda: setattr(bpy.data.lights["Sun"], "energy", 5.0))
    assert report.lights == 1 and not report.bvh and report.meshes == [] and report.objects == []
    assert session.cache.geometry is geometry
    assert session.cache.scene.lights[0].strength == 5.0
    report = recorder.change(lambda: setattr(bpy.data.objects["Sun"], "rotation_euler", (0.3, 0.0, 0.0)))
    assert report.lights == 1 and not report.bvh and session.cache.geometry is geometry


def test_changing_a_material_rebuilds_no_bvh_and_shows_the_new_colour(session_in_scene):
    """A new base colour reaches the traced albedo without a BVH build: the plane shows albedo / pi * E
    (a Principled BSDF without specular layer, Specular IOR Level 0, is Lambert's)."""
    scene, session, recorder, _ = session_in_scene
    material = bpy.data.materials.new("Red")
    if bpy.app.version < (5, 0, 0):
        material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    report = recorder.change(lambda: bpy.data.objects["Plane"].data.materials.__setitem__(0, material))
    assert report.meshes == ["Plane"] or report.objects == ["Plane"]
    geometry = session.cache.geometry
    report = recorder.change(lambda: setattr(bsdf.inputs["Base Color"], "default_value", (0.5, 0.25, 0.1, 1.0)))
    assert report.materials >= 1 and not report.bvh and report.meshes == []
    assert session.cache.geometry.tracer is geometry.tracer
    session.set_view(camera_view(scene, 24, 24), start=False)
    frame = list(session.run())[-1]
    np.testing.assert_allclose(frame.image[12, 12, :3], np.array([0.5, 0.25, 0.1]) / math.pi * 2.0, rtol=1e-5)


def test_a_medium_read_in_object_coordinates_is_read_in_its_objects_space_in_the_viewport(session_in_scene):
    """A volume whose density is linked to Object coordinates, on the moved "Cube B" alone: the viewport's scene reads
    it in that cube's space and texture space, as the final render's export does (Material.volume_space)."""
    scene, session, recorder, _ = session_in_scene
    material = bpy.data.materials.new("Fog")
    if bpy.app.version < (5, 0, 0):
        material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    coordinates, split = nodes.new("ShaderNodeTexCoord"), nodes.new("ShaderNodeSeparateXYZ")
    absorption = nodes.new("ShaderNodeVolumeAbsorption")
    links.new(coordinates.outputs["Object"], split.inputs[0])
    links.new(split.outputs["Z"], absorption.inputs["Density"])
    links.new(absorption.outputs[0], nodes["Material Output"].inputs["Volume"])
    recorder.change(lambda: bpy.data.objects["Cube B"].data.materials.append(material))
    cube = bpy.data.objects["Cube B"]
    materials = session.cache._core_scene().materials
    fog = next(m for m in materials if m.name == "Fog")
    inverse, location, size = fog.volume_space
    np.testing.assert_allclose(inverse, np.linalg.inv(np.array(cube.matrix_world))[:3], atol=1e-12)
    np.testing.assert_allclose(location, cube.data.texspace_location, atol=1e-7)
    np.testing.assert_allclose(size, cube.data.texspace_size, atol=1e-7)
    assert abs(inverse[1, 3] + 3.0) < 1e-12            # (world y = 3 is the cube's origin)


def test_moving_the_camera_reexports_nothing(session_in_scene):
    """A camera move changes no exported data and builds no BVH; only the view restarts the samples."""
    _, session, recorder, _ = session_in_scene
    report = recorder.change(lambda: setattr(bpy.data.objects["Camera"], "location", (1.0, 0.0, 20.0)))
    assert report.camera_changed and report.meshes == [] and report.objects == [] and not report.bvh


def test_instancing_setting_rebuilds_the_bvh_with_the_twins_stored_once(session_in_scene):
    """Instancing: Always stores the cubes once ("Cube A" placed twice, and "Cube B", another mesh of the same numbers:
    geometry.same_meshes); back on Automatic their three copies return."""
    scene, session, recorder, _ = session_in_scene
    # Blender's UI tags the scene when a setting changes; a script must tag it itself.
    report = recorder.change(lambda: (setattr(scene.primer, "instancing", "ALWAYS"), scene.update_tag()))
    geometry = session.cache.geometry
    assert report.bvh and [len(m.transforms) for m in geometry.instanced] == [3]
    assert len(geometry.triangles) == 2 and geometry.triangle_count == 2 + 3 * 12
    report = recorder.change(lambda: (setattr(scene.primer, "instancing", "AUTO"), scene.update_tag()))
    assert report.bvh and session.cache.geometry.instanced == []
    assert len(session.cache.geometry.triangles) == 2 + 3 * 12


def test_adding_and_removing_objects_updates_the_bvh(session_in_scene):
    """A new object is placed (Blender also re-evaluates the mesh it shares, so its other user is re-read);
    objects using other meshes stay cached; a removed object leaves the BVH."""
    scene, session, recorder, _ = session_in_scene
    report = recorder.change(lambda: add_mesh(scene, "Cube C", None, None, location=(0.0, -3.0, 0.0),
                                              mesh=bpy.data.meshes["Cube B"]))
    assert sorted(report.objects) == ["Cube B", "Cube C"] and report.meshes == ["Cube B"] and report.bvh
    assert len(session.cache.geometry.triangles) == 2 + 4 * 12
    report = recorder.change(lambda: bpy.data.objects.remove(bpy.data.objects["Cube A Twin"]))
    assert report.bvh and report.meshes == []
    assert len(session.cache.geometry.triangles) == 2 + 3 * 12


def test_plane_under_the_sun_renders_the_closed_form_in_every_pass(session_in_scene):
    """Seen from above, the coarse and the full passes show 0.8 / pi * E * cos(theta) over the whole plane."""
    scene, session, recorder, _ = session_in_scene
    for name in ("Cube A", "Cube A Twin", "Cube B"):
        bpy.data.objects[name].hide_render = True     # Blender's viewport depsgraph hides with hide_viewport
        bpy.data.objects[name].hide_viewport = True
    theta = 0.4
    recorder.change(lambda: setattr(bpy.data.objects["Sun"], "rotation_euler", (theta, 0.0, 0.0)))
    session.set_view(camera_view(scene, 64, 48), start=False)
    frames = list(session.run())
    assert frames[0].block > 1 and frames[-1].samples == 2
    expected = 0.8 / math.pi * 2.0 * math.cos(theta)
    for frame in frames:
        np.testing.assert_allclose(frame.image[..., :3], expected, rtol=1e-5)


def test_viewport_camera_agrees_with_blender_projection(primer):
    """For camera views of perspective (shifted, vertical fit) and orthographic cameras, the ray through the
    pixel where bpy_extras' world_to_camera_view puts a world point passes through that point."""
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    scene = build_scene()
    width, height = 120, 90
    scene.render.resolution_x, scene.render.resolution_y = width, height
    camera = scene.camera
    camera.location = (3.0, -6.0, 4.0)
    camera.rotation_euler = (1.1, 0.1, 0.4)
    points = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.5], [-1.5, 0.5, 1.0], [0.5, -1.0, 2.0]])
    for kind, fit, shift in (("PERSP", "AUTO", (0.0, 0.0)), ("PERSP", "VERTICAL", (0.2, -0.1)),
                             ("ORTHO", "AUTO", (-0.15, 0.05))):
        camera.data.type, camera.data.sensor_fit = kind, fit
        camera.data.shift_x, camera.data.shift_y = shift
        camera.data.ortho_scale = 9.0
        bpy.context.view_layer.update()
        view = camera_view(scene, width, height)
        normalised = np.array([world_to_camera_view(scene, camera, Vector(p))[:2] for p in points])
        raster = np.stack([normalised[:, 0] * width, (1.0 - normalised[:, 1]) * height], axis=1)
        rays = camera_.generate_rays(view.camera, width, height, raster[:, 0], raster[:, 1], view.pixel_aspect)
        offset = points - rays.origins
        along = np.sum(offset * rays.directions, axis=1)
        miss = np.linalg.norm(offset - along[:, None] * rays.directions, axis=1)
        np.testing.assert_allclose(miss, 0.0, atol=1e-5, err_msg=f"{kind} {fit} {shift}")
        # Our own projection of the viewport's matrices puts the points on the same pixels.
        depsgraph = bpy.context.evaluated_depsgraph_get()
        window = np.array(camera.calc_matrix_camera(depsgraph, x=width, y=height))
        ours = view_.project(np.array(camera.matrix_world.inverted()), window, width, height, points)
        np.testing.assert_allclose(ours, raster, atol=1e-4)


def test_viewport_camera_matches_the_render_camera_of_the_sample_scenes(primer):
    """The camera view of camera_persp_shift and camera_ortho traces the rays of the final render's camera."""
    export = sys.modules[primer.__name__ + ".addon.export"]
    for name in ("camera_persp_shift", "camera_ortho"):
        bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", f"{name}.blend"))
        scene = bpy.context.scene
        width, height = export.frame_size(scene.render)
        view = camera_view(scene, width, height)
        reference = export.export_camera(scene.camera.evaluated_get(bpy.context.evaluated_depsgraph_get()))
        aspect = (scene.render.pixel_aspect_x, scene.render.pixel_aspect_y)
        assert aspect == (1.0, 1.0)
        xs, ys = np.meshgrid(np.linspace(0.5, width - 0.5, 7), np.linspace(0.5, height - 0.5, 5))
        ours = camera_.generate_rays(view.camera, width, height, xs.ravel(), ys.ravel(), view.pixel_aspect)
        theirs = camera_.generate_rays(reference, width, height, xs.ravel(), ys.ravel(), aspect)
        np.testing.assert_allclose(ours.directions, theirs.directions, atol=1e-6, err_msg=name)
        # Blender's camera matrix uses the clip range; origins sit on the same near plane.
        np.testing.assert_allclose(ours.origins, theirs.origins, atol=1e-4, err_msg=name)


def test_worker_thread_restarts_on_a_change_and_converges(session_in_scene):
    """In the background thread: after a light change mid-render the final image shows the new light."""
    scene, session, recorder, _ = session_in_scene
    scene.primer.viewport_samples = 4
    for name in ("Cube A", "Cube A Twin", "Cube B"):
        bpy.data.objects[name].hide_viewport = True
    recorder.change(lambda: setattr(bpy.data.objects["Cube B"], "hide_render", True))
    session.set_view(camera_view(scene, 40, 30))           # starts the worker thread

    def wait_until_done(timeout=60.0):
        deadline = time.time() + timeout
        while session.refining and time.time() < deadline:
            time.sleep(0.01)
        assert not session.refining, "the viewport never finished"
        return session.latest()

    recorder.change(lambda: setattr(bpy.data.lights["Sun"], "energy", 3.0))
    session.restart()                                      # view_update's restart, now with the thread running
    frame = wait_until_done()
    assert frame.samples == 4 and session.error == ""
    np.testing.assert_allclose(frame.image[..., :3], 0.8 / math.pi * 3.0, rtol=1e-5)
    assert "frame time" in session.status_text()


def test_ray_visibility_and_holdout_reach_the_traced_scene(session_in_scene):
    """Object > Visibility > Ray Visibility > Diffuse off and Holdout on for one cube: the viewport's traced scene
    has an object hidden from diffuse rays and a holdout, and none hidden from glossy rays."""
    from core.visibility import HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HOLDOUT
    _, session, recorder, _ = session_in_scene
    assert not session.cache.geometry.hides(HIDDEN_FROM_DIFFUSE | HOLDOUT)

    def edit():
        cube = bpy.data.objects["Cube B"]
        cube.visible_diffuse = False
        cube.is_holdout = True

    recorder.change(edit)
    geometry = session.cache.geometry
    assert geometry.hides(HIDDEN_FROM_DIFFUSE) and geometry.hides(HOLDOUT) and not geometry.hides(HIDDEN_FROM_GLOSSY)


def test_light_linking_reaches_the_traced_scene_and_follows_a_link_state_change(session_in_scene):
    """A lamp whose receiver collection Includes one cube: the viewport's traced scene has that cube in a set of its
    own that the lamp lights and the default set it does not; switching the cube to Exclude makes the lamp light the
    default set and not the cube's."""
    from core.lights.linking import in_sets
    _, session, recorder, _ = session_in_scene
    lamp = next(obj for obj in bpy.data.objects if obj.type == "LIGHT")
    cube = bpy.data.objects["Cube B"]
    receivers = bpy.data.collections.new("Receivers")
    receivers.objects.link(cube)
    recorder.change(lambda: setattr(lamp.light_linking, "receiver_collection", receivers))
    cube_set = session.cache.links["Cube B"]["light_set"]
    membership = next(light for light in session.cache.scene.lights if light.name == lamp.name).light_membership
    assert cube_set != 0 and in_sets(membership, cube_set) and not in_sets(membership, 0)
    assert (session.cache.geometry.instance_links[:, 0] == cube_set).sum() >= 1

    def exclude():
        receivers.collection_objects[0].light_linking.link_state = "EXCLUDE"

    recorder.change(exclude)
    cube_set = session.cache.links["Cube B"]["light_set"]
    membership = next(light for light in session.cache.scene.lights if light.name == lamp.name).light_membership
    assert in_sets(membership, 0) and not in_sets(membership, cube_set)
