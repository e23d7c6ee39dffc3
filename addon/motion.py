"""Motion blur: the camera read over the shutter as Cycles' Blender sync reads it, and the objects that move noted.

With Render > Motion Blur on (and the view layer's Motion Blur), Cycles renders the camera where it is at each ray's
time in the shutter (core/camera/motion.py). Its Blender sync (intern/cycles/blender/sync.cpp `sync_motion`,
camera.cpp `sync_camera_motion`) reads the camera at the times of its motion steps: the shutter is Shutter frames
long, centred on the frame (Position Center), starting at it (Start) or ending at it (End); step k of n lies at the
relative time 2k / (n - 1) - 1 of the shutter's half-length around its centre, and n = 2^steps + 1 for the camera
object's Motion Steps (Object > Motion Blur; 0 when its Motion Blur is off: it stands still). For a Start or End
shutter the camera at the shutter's centre gives the render's camera its matrix (its position for the camera-relative
frame, the Camera texture coordinates) and field of view, its other settings staying the frame's, as in Cycles. A
perspective camera whose field of view differs at the shutter's open or close gets it too (Cycles' perspective
motion). The add-on moves the scene there with RenderEngine.frame_set(frame,
subframe), reads, and sets the frame back. Only a final render does this: Cycles' viewport renders no motion blur.

The objects are read the same way: each rendered object and instance with its Motion Blur on (and its instancer's)
whose transform differs over the shutter gets its matrices at its own motion steps (2^steps + 1 of its Motion Steps,
evenly spaced from open to close: Cycles' object motion), Instance.motion, and the render places it where it is at
each ray's time (core/geometry/geometry.py). A mesh object that deforms (Deformation on: modifiers or shape keys, up
to DEFORM_CHECK_VERTICES vertices) gets its vertex positions there too, Instance.deformation (Cycles' motion
vertices), as long as its vertex count stays the exported mesh's, and, where its normals are per vertex (smooth
faces, no sharp edges or custom normals: Mesh.normals_domain POINT, where Cycles reads its motion vertex normals), its
vertex normals there, Instance.deformation_normals, which the render interpolates at each ray's time as Cycles does;
a deforming mesh with smooth faces whose normals are per corner keeps them as they are at the frame (a note says so).
An object that moves or deforms and cannot be read so is named in a note and rendered
where it is at the frame.

The Vector pass (without motion blur: sample_vector_frames) reads the frames before and after the same way: the
objects' transforms there (Instance.vector_motion) and a deforming mesh's vertices (Instance.vector_deformation,
Cycles' motion vertex positions); a mesh object that may deform but has more than DEFORM_CHECK_VERTICES vertices is
not read, and named in a note (its pass carries its transform alone).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from ..core.camera import motion as core_motion

# Objects named in a note before "and N more".
NAMED = 3
# A mesh is compared vertex by vertex for deformation up to this many vertices (more: not checked, to stay cheap).
DEFORM_CHECK_VERTICES = 200_000


def blurs(scene, view_layer=None) -> bool:
    """Whether a Cycles render of `scene` has motion blur: Render > Motion Blur and the view layer's Motion Blur."""
    if not getattr(scene.render, "use_motion_blur", False):
        return False
    return view_layer is None or bool(getattr(view_layer, "use_motion_blur", True))


def shutter_curve(render) -> np.ndarray:
    """The shutter curve's values as Cycles' sync reads them (curvemapping_to_array): the first curve of
    motion_blur_shutter_curve evaluated by Blender at i / 256, i = 0 .. 256 -> (257,) float32."""
    mapping = render.motion_blur_shutter_curve
    mapping.update()
    mapping.initialize()
    curve = mapping.curves[0]
    size = core_motion.CURVE_POINTS - 1
    return np.array([mapping.evaluate(curve, float(np.float32(i) / np.float32(size))) for i in range(size + 1)],
                    np.float32)


def shutter(scene) -> core_motion.Shutter:
    """The scene's shutter for the camera's rays: its curve's table, and Cycles' rolling shutter (Top to Bottom with
    its Duration; scene.cycles' rolling_shutter_type and rolling_shutter_duration)."""
    cycles = getattr(scene, "cycles", None)
    rolling = str(getattr(cycles, "rolling_shutter_type", "NONE")) == "TOP"
    duration = float(getattr(cycles, "rolling_shutter_duration", 0.1))
    return core_motion.Shutter(table=core_motion.shutter_table(shutter_curve(scene.render)), rolling=rolling,
                               rolling_duration=duration)


def motion_steps(obj) -> int:
    """Cycles' object_motion_steps: 2^steps + 1 transforms over the shutter for an object's Motion Steps, 0 with its
    Motion Blur off (object.cycles' use_motion_blur and motion_steps)."""
    settings = getattr(obj, "cycles", None)
    if settings is None or not getattr(settings, "use_motion_blur", True):
        return 0
    return (2 << (max(1, int(getattr(settings, "motion_steps", 1))) - 1)) + 1


def centre_offset(render) -> float:
    """Frames from the frame to the shutter's centre: 0 for Center, +Shutter / 2 for Start, -Shutter / 2 for End
    (motion_blur_position, motion_blur_shutter)."""
    half = 0.5 * float(render.motion_blur_shutter)
    return {"START": half, "END": -half}.get(str(render.motion_blur_position), 0.0)


def frame_of(scene, relative: float) -> tuple[int, float]:
    """The (frame, subframe) of a relative time in [-1, 1] of the shutter, as Cycles' sync_motion computes it."""
    render = scene.render
    time = (scene.frame_current + scene.frame_subframe + centre_offset(render)
            + relative * float(render.motion_blur_shutter) * 0.5)
    frame = math.floor(time)
    return int(frame), float(time - frame)


def _fov_tangent(camera) -> float:
    """tan(fov / 2) of a core perspective camera up to the image's aspect, which does not change over the shutter."""
    sensor = camera.sensor_height if camera.sensor_fit == "VERTICAL" else camera.sensor_width
    return float(np.float32(0.5 * sensor / camera.lens))


# The object types Cycles renders (and so blurs): an Empty, an armature or a lattice moves nothing that is seen.
RENDERED_TYPES = ("MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD", "VOLUME")


def placement_key(instance) -> tuple:
    """A depsgraph object instance's key from one time of the shutter to the next: (its name in a note, quoted, an
    instance's with its instancer's; its persistent id)."""
    obj = instance.object
    parent = instance.parent if instance.is_instance else None
    name = f"'{obj.name}'" + ("" if parent is None else f" (instanced by '{parent.name}')")
    return name, tuple(instance.persistent_id)


def _object_state(depsgraph) -> dict:
    """Where each rendered object and instance is: its world matrix, its motion steps, and for a mesh object that may
    deform (modifiers or shape keys, Deformation on, not too large) its vertex positions and, where its normals are
    per vertex (normals_domain POINT), its vertex normals. -> placement_key -> (matrix (4, 4) float64, positions
    (3 v,) float32 or None, steps, normals (3 v,) float32 or None). An instance counts when its object's and its
    instancer's Motion Blur are on (Cycles' object_motion_steps)."""
    state = {}
    for instance in depsgraph.object_instances:
        obj = instance.object
        parent = instance.parent if instance.is_instance else None
        if obj.type not in RENDERED_TYPES or motion_steps(obj) == 0 or (parent is not None and not motion_steps(parent)):
            continue
        positions = None
        mesh = obj.data if obj.type == "MESH" and parent is None else None
        if mesh is not None and may_deform(obj) and len(mesh.vertices) <= DEFORM_CHECK_VERTICES:
            positions = np.empty(3 * len(mesh.vertices), np.float32)
            mesh.vertices.foreach_get("co", positions)
        normals = None
        if positions is not None and getattr(mesh, "normals_domain", "") == "POINT":
            normals = np.empty(3 * len(mesh.vertices), np.float32)          # (Cycles' motion vertex normals)
            mesh.vertex_normals.foreach_get("vector", normals)
        state[placement_key(instance)] = (np.array(instance.matrix_world, np.float64), positions, motion_steps(obj),
                                          normals)
    return state


def may_deform(obj) -> bool:
    """Whether the mesh object `obj` may deform between times: its Deformation motion on (Cycles' use_deform_motion)
    and modifiers or shape keys that could move its vertices."""
    return (bool(getattr(getattr(obj, "cycles", None), "use_deform_motion", True))
            and bool(len(obj.modifiers) or getattr(obj.data, "shape_keys", None) is not None))


def named(names) -> str:
    """Up to NAMED of `names`, sorted, joined for a note ("'A', 'B' and 2 more")."""
    shown = ", ".join(sorted(names)[:NAMED])
    return shown + (f" and {len(names) - NAMED} more" if len(names) > NAMED else "")


def step_times(steps: int) -> list:
    """The relative times in [-1, 1] of the shutter of `steps` motion steps, evenly spaced from open to close."""
    return [2.0 * k / (steps - 1) - 1.0 for k in range(steps)]


def moving_objects_note(opened: dict, closed: dict, start: tuple, end: tuple, frame: float,
                        blurred=frozenset(), reshaped=frozenset(), smooth=frozenset()) -> Optional[str]:
    """The note naming the objects that move or deform between the shutter's open and close (_object_state at
    each) but are not blurred, and the deforming ones blurred whose smooth normals stay the frame's, or None; start,
    end: the shutter's (frame, subframe); frame: the frame rendered; blurred, reshaped: the keys of the objects the
    render blurs by their transform (Instance.motion) and by their deformation (Instance.deformation); smooth: those
    of reshaped whose faces are smooth and whose normals are not interpolated (per corner)."""
    moved, deformed = set(), set()
    for key, (matrix, positions, *_) in opened.items():
        if key not in closed:
            continue
        other_matrix, other_positions = closed[key][:2]
        if not np.array_equal(matrix, other_matrix) and key not in blurred:
            moved.add(key[0])
        elif key not in reshaped and positions is not None and (
                other_positions is None or positions.shape != other_positions.shape
                or not np.array_equal(positions, other_positions)):
            deformed.add(key[0])
    normals = sorted(key[0] for key in smooth)
    if not moved and not deformed:
        if not normals:
            return None
        shown = ", ".join(normals[:NAMED]) + (f" and {len(normals) - NAMED} more" if len(normals) > NAMED else "")
        its = "its" if len(normals) == 1 else "their"
        return (f"motion blur: {shown} deform{'s' if len(normals) == 1 else ''} during the shutter; Primer blurs "
                f"{its} vertices but keeps {its} smooth normals, which are per face corner (sharp edges or custom "
                f"normals), as they are at frame {frame:g} (per-vertex normals are interpolated over the shutter)")

    parts = ([f"{named(moved)} move{'s' if len(moved) == 1 else ''}"] if moved else []) + \
            ([f"{named(deformed)} deform{'s' if len(deformed) == 1 else ''}"] if deformed else [])
    them, they = ("it", "it is") if len(moved) + len(deformed) == 1 else ("them", "they are")
    moving = ("" if not moved else f"; Primer blurs the camera and the moving meshes, and renders "
              f"{named(moved)} still where {'it is' if len(moved) == 1 else 'they are'} at frame {frame:g}")
    shaped = ("" if not deformed else f"; Primer blurs no deformation of {named(deformed)}: "
              f"{'its' if len(deformed) == 1 else 'their'} vertices are where they are at frame {frame:g} (their "
              f"vertex count changes over the shutter, or they are too many to compare)")
    return (f"motion blur: {' and '.join(parts)} during the shutter (frames {start[0] + start[1]:g} to "
            f"{end[0] + end[1]:g}); Cycles blurs {them}{moving}{shaped}")


def give_motion(instances, instance_keys: dict, states: dict, meshes=()) -> tuple:
    """Give each exported instance that moves over the shutter its matrices at its motion steps (Instance.motion), and
    each whose mesh deforms its vertex positions there (Instance.deformation, where the vertices stay the exported
    mesh's: meshes, the core Scene.meshes), from the object states read at each relative time (time ->
    _object_state); with their vertex normals there where the mesh's normals are per vertex
    (Instance.deformation_normals); return the keys of those that move, of those that deform, and of the deforming
    ones with smooth faces whose normals stay the frame's (per corner): three sets."""
    moved, deformed, smooth = set(), set(), set()
    for index, key in instance_keys.items():
        if key not in states[-1.0] or index >= len(instances):
            continue
        times = step_times(states[-1.0][key][2])
        if not all(key in states.get(time, {}) for time in times):
            continue
        matrices = tuple(states[time][key][0] for time in times)
        if not all(np.isfinite(m).all() for m in matrices):
            continue
        if not all(np.array_equal(m, matrices[0]) for m in matrices[1:]):
            instances[index].motion = matrices
            moved.add(key)
        shapes = [states[time][key][1] for time in times]
        mesh = meshes[instances[index].mesh] if instances[index].mesh < len(meshes) else None
        unusable = mesh is None or any(p is None or p.size != np.size(mesh.vertices) or not np.isfinite(p).all()
                                       for p in shapes)
        if unusable or all(np.array_equal(p, shapes[0]) for p in shapes[1:]):
            continue
        instances[index].deformation = tuple(p.reshape(-1, 3).astype(np.float64) for p in shapes)
        deformed.add(key)
        normals = [states[time][key][3] if len(states[time][key]) > 3 else None for time in times]
        if all(n is not None and n.size == np.size(mesh.vertices) and np.isfinite(n).all() for n in normals):
            instances[index].deformation_normals = tuple(n.reshape(-1, 3).astype(np.float64) for n in normals)
        elif np.asarray(mesh.smooth).any():
            smooth.add(key)
    return moved, deformed, smooth


def sample_vector_frames(engine, depsgraph, camera_object, camera, export_camera, warnings: list, instances=(),
                         instance_keys=None) -> tuple:
    """The Vector pass's frames (Cycles' motion pass, which it writes only without motion blur): the camera at the
    frames before and after the one rendered (Scene.vector_cameras; `camera`, the frame's exported one, where its
    Motion Blur is off), read by moving the scene there with
    engine.frame_set and back; each exported instance (core Scene.instances, placement_key by index in
    `instance_keys`) whose transform differs there given Instance.vector_motion, and each whose mesh's vertices
    (read where it may deform: Deformation on, modifiers or shape keys, _object_state) differ between the frames
    given them as Instance.vector_deformation (core/integrators/passes.py with_vector_deformation maps them, a frame
    of another vertex count taking the mesh's own, as Cycles). A panoramic camera's frames give only their transforms
    (the core maps them through the frame's projection inverted, as Cycles' motion_pass_pre and post)."""
    scene = depsgraph.scene
    frame, subframe = scene.frame_current, scene.frame_subframe
    cameras, states = [], []
    try:
        for step in (-1, 1):                        # (Cycles: the shutter two frames long around the frame)
            engine.frame_set(frame + step, subframe)
            # (a camera whose Motion Blur is off stands still for the pass, as Cycles syncs no motion for it)
            cameras.append(export_camera(camera_object.evaluated_get(depsgraph), []) if motion_steps(camera_object)
                           else camera)
            states.append(_object_state(depsgraph))
    finally:
        engine.frame_set(frame, subframe)
    for index, key in (instance_keys or {}).items():
        if index >= len(instances) or not all(key in state for state in states):
            continue
        matrices = tuple(state[key][0] for state in states)
        if all(np.isfinite(m).all() for m in matrices) and not all(np.array_equal(m, instances[index].matrix)
                                                                    for m in matrices):
            instances[index].vector_motion = matrices
        shapes = [state[key][1] for state in states]
        if any(shape is not None for shape in shapes):      # (the vertices then: the core compares and maps them)
            instances[index].vector_deformation = tuple(None if shape is None else shape.reshape(-1, 3).astype(np.float64)
                                                        for shape in shapes)
    unread = unread_deforming(depsgraph)
    if unread:
        warnings.append(f"the Vector pass: {named(unread)} may deform between frames (modifiers or shape keys) but "
                        f"ha{'s' if len(unread) == 1 else 've'} more than {DEFORM_CHECK_VERTICES} vertices, which "
                        "Primer does not read: its pass carries only the objects' transforms there")
    return tuple(cameras)


def unread_deforming(depsgraph) -> set:
    """The names of the rendered mesh objects that may deform (Deformation and Motion Blur on, modifiers or shape
    keys) but whose vertices _object_state does not read (more than DEFORM_CHECK_VERTICES)."""
    names = set()
    for instance in depsgraph.object_instances:
        obj = instance.object
        if instance.is_instance or obj.type != "MESH" or motion_steps(obj) == 0:
            continue
        if may_deform(obj) and len(obj.data.vertices) > DEFORM_CHECK_VERTICES:
            names.add(obj.name)
    return names


def sample_shutter(engine, depsgraph, camera_object, camera, export_camera, warnings: list, instances=(),
                   instance_keys=None, meshes=()):
    """The exported core camera with its motion over the shutter (Camera.shutter, motion, fov_motion), read by moving
    the scene with engine.frame_set to each time Cycles reads; the exported instances (core Scene.instances, with
    their placement_key by index in `instance_keys`; meshes: the core Scene.meshes) that move given their
    Instance.motion, those that deform their Instance.deformation (give_motion); the note about the objects that
    move or deform but are not blurred so, added to `warnings`. export_camera: the exporter's function
    from an evaluated camera object to a core Camera. The scene is set back to its frame before returning. Without
    motion blur the camera is returned as it is."""
    scene = depsgraph.scene
    if not blurs(scene, depsgraph.view_layer):
        return camera
    steps = motion_steps(camera_object)
    object_steps = {motion_steps(obj) for obj in scene.objects if obj.type in RENDERED_TYPES} - {0}
    relative = sorted({time for count in object_steps | {steps} - {0} for time in step_times(count)} | {-1.0, 1.0}
                      | ({0.0} if centre_offset(scene.render) != 0.0 else set()))
    frame, subframe = scene.frame_current, scene.frame_subframe
    frames = {time: frame_of(scene, time) for time in relative}     # (before frame_set moves the scene's frame)
    note_frames = frame_of(scene, -1.0), frame_of(scene, 1.0), frame + subframe
    cameras, states = {}, {}
    try:
        for time in relative:
            engine.frame_set(*frames[time])
            evaluated = camera_object.evaluated_get(depsgraph)
            cameras[time] = export_camera(evaluated, [])
            states[time] = _object_state(depsgraph)
    finally:
        engine.frame_set(frame, subframe)
    moved, deformed, smooth = give_motion(instances, instance_keys or {}, states, meshes)
    note = moving_objects_note(states[-1.0], states[1.0], *note_frames, blurred=moved, reshaped=deformed,
                               smooth=smooth)
    if note:
        warnings.append(note)
    centre = camera
    if centre_offset(scene.render) != 0.0:
        # Cycles keeps the frame's camera but for its matrix and field of view, which it takes at the shutter's centre.
        middle = cameras[0.0]
        view = dict(lens=middle.lens, sensor_width=middle.sensor_width, sensor_height=middle.sensor_height)
        centre = dataclasses.replace(camera, matrix_world=middle.matrix_world, **(view if camera.type == "PERSP" else {}))
    matrices = tuple(np.asarray(cameras[2.0 * k / (steps - 1) - 1.0].matrix_world) for k in range(steps))
    if not all(np.isfinite(m).all() for m in matrices):
        warnings.append(f"motion blur: camera '{camera_object.name}' has an invalid (NaN or infinite) transform during "
                        "the shutter; Primer renders it still")
        matrices = ()
    fov = ()
    if centre.type == "PERSP" and steps:
        middle_tangent = _fov_tangent(centre)
        fov = (_fov_tangent(cameras[-1.0]) / middle_tangent, _fov_tangent(cameras[1.0]) / middle_tangent)
    return dataclasses.replace(centre, shutter=shutter(scene), motion=matrices, fov_motion=fov)
