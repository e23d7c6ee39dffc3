"""Scene export: Blender's evaluated depsgraph to Primer's plain scene model.

Everything is read from the *evaluated* depsgraph, so modifiers, geometry
nodes, curves, text, metaballs and every kind of instance arrive as Blender
would render them. Mesh data is read in bulk with `foreach_get`, never with a
Python loop per vertex, and a mesh shared by many instances is exported once.
"""
from __future__ import annotations

import dataclasses
import math
import types
from dataclasses import dataclass, field

import numpy as np

from ..core import scene as core_scene
from ..core.camera import Camera
from ..core.camera import culling as culling_
from ..core.camera.camera import PANORAMA_TYPES
from ..core.geometry import curves as curves_
from ..core.geometry import islands as islands_
from ..core.geometry import pointiness as pointiness_
from ..core.geometry import points as points_
from ..core.lights import World, world_graph
from ..core.lights import world as lights_world
from ..core.lights import lamp_graph as lamp_graph_
from ..core.materials import ies as ies_
from ..core.lights.ies import IESLamp
from ..core.materials import DEFAULT_SURFACE
from ..core.materials import graph as graph_
from ..core.materials import textures as textures_
from ..core.visibility import (HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION,
                               HIDDEN_FROM_VOLUME_SCATTER, hidden_bits)
from . import cycles_settings, lightgroups, linking, motion, unmodelled, vdb
from . import materials as materials_

# Primer renders objects whose evaluated data is a mesh, as Cycles does (object_is_geometry in its
# Blender sync). Curves, text, surfaces and metaballs are skipped themselves: the depsgraph hands
# their evaluated meshes to render engines as separate instances of type MESH (Blender 4.2 and 5.0).
# Types Cycles renders that Primer does not (it traces triangles only): none left (Volume objects: addon/vdb.py,
# skipped with a warning where Blender ships no OpenVDB module, as 4.2's bpy module).
UNSUPPORTED_GEOMETRY: set = set()


class ExportError(Exception):
    """The scene cannot be rendered; the message says why, for Blender's report."""


@dataclass
class Export:
    """A Blender scene in Primer's terms, with the notes made on the way."""

    scene: core_scene.Scene
    settings: core_scene.RenderSettings
    full_size: tuple            # (width, height) of the whole frame in pixels
    border: tuple               # (x, y, width, height) of the rendered rectangle in the whole frame, y from
                                # the bottom; Blender's render result is exactly this rectangle, so write it
                                # with engine.begin_result(0, 0, width, height)
    warnings: list = field(default_factory=list)
    meshes_read: list = field(default_factory=list)     # objects whose meshes were read from Blender (not kept)
    # Each mesh instance's key among the depsgraph's object instances (index into scene.instances ->
    # motion.placement_key), by which addon/motion.py gives the ones that move their motion over the shutter.
    instance_keys: dict = field(default_factory=dict)
    culled: list = field(default_factory=list)          # objects Simplify > Culling left out (object_culling)


# ----------------------------------------------------------------------------
# Meshes
# ----------------------------------------------------------------------------

def _face_attribute(mesh, name: str, data_type: str, dtype, default) -> np.ndarray:
    """Return a face attribute's values, read in bulk: (faces,) `dtype`, `default` everywhere when absent."""
    values = np.full(len(mesh.polygons), default, dtype)
    attribute = mesh.attributes.get(name)
    if attribute is not None and attribute.domain == "FACE" and attribute.data_type == data_type and len(values):
        attribute.data.foreach_get("value", values)
    return values


def _all_triangles(mesh) -> bool:
    """Whether every face of `mesh` is a triangle (3 corners each, as glTF and most imported meshes are): then its
    loop triangles are its faces, in order, each of corners 3 f, 3 f + 1, 3 f + 2 (Blender's triangulation keeps a
    triangle's corners as they are)."""
    faces = len(mesh.polygons)
    return len(mesh.loops) == 3 * faces and len(mesh.loop_triangles) == faces


def _triangle_loops(mesh) -> np.ndarray:
    """Return the face corner (loop) of each loop triangle's corners: (3 t,) int32. RNA reads loop triangles one
    item at a time (0.1 s for 10^6 triangles); a mesh of triangles alone needs no read (_all_triangles)."""
    if _all_triangles(mesh):
        return np.arange(3 * len(mesh.polygons), dtype=np.int32)
    loops = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    return loops


def _positions(mesh) -> np.ndarray:
    """Return the mesh's vertex positions: (3 v,) float32, read from Blender's own `position` array where it has one
    (without RNA's per-item path), else through the vertices."""
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    attribute = mesh.attributes.get("position")
    if (attribute is not None and attribute.domain == "POINT" and attribute.data_type == "FLOAT_VECTOR"
            and len(attribute.data) * 3 == len(co)):
        attribute.data.foreach_get("vector", co)
    else:
        mesh.vertices.foreach_get("co", co)
    return co


def _triangle_faces(mesh) -> np.ndarray:
    """Return the face each loop triangle belongs to: (t,) int32."""
    if _all_triangles(mesh):
        return np.arange(len(mesh.polygons), dtype=np.int32)
    face = np.empty(len(mesh.loop_triangles), np.int32)
    if hasattr(mesh, "loop_triangle_polygons"):              # Blender's own array
        mesh.loop_triangle_polygons.foreach_get("value", face)
    else:
        mesh.loop_triangles.foreach_get("polygon_index", face)
    return face


def _corner_vertices(mesh) -> np.ndarray:
    """Return the vertex of each face corner (loop): (loops,) int32."""
    corners = np.empty(len(mesh.loops), np.int32)
    attribute = mesh.attributes.get(".corner_vert")          # Blender's own array, read without RNA's per-item path
    if attribute is not None and len(attribute.data) == len(corners):
        attribute.data.foreach_get("value", corners)
    else:
        mesh.loops.foreach_get("vertex_index", corners)
    return corners


# Cycles' radius of a curve point without a radius attribute (blender/curves.cpp).
CURVE_RADIUS = 0.005
# How finely curves become tubes: sides of each ring and rings per span of the spline; past CURVE_TRIANGLES triangles
# in one object, the coarse pair (a warning says so).
CURVE_TESSELLATION, CURVE_TESSELLATION_COARSE, CURVE_TRIANGLES = (12, 8), (6, 3), 4_000_000


def tube_resolution(spans: int, fine: tuple, coarse: tuple, what: str, unit: str, warnings: list) -> tuple:
    """The (sides, rings per `unit`) of tubes over `spans` spans: `fine`, or `coarse` with a warning about `what`
    where fine ones would pass CURVE_TRIANGLES triangles."""
    if 2 * fine[0] * fine[1] * spans <= CURVE_TRIANGLES:
        return fine
    warnings.append(f"{what} are made tubes of {coarse[0]} sides and {coarse[1]} rings per {unit}, coarser than "
                    f"Primer's usual {fine[0]} and {fine[1]}")
    return coarse


def curves_mesh(curves, scene, warnings: list) -> core_scene.Mesh:
    """A hair Curves datablock as a core Mesh of tubes around its Catmull-Rom splines (core/geometry/curves.py), read
    in bulk: its points' positions and radius attribute (Cycles' 0.005 without one), its curves' offsets and material
    index. Cycles' Thick Linear shape gives straight tubes between the points; its Ribbons (Blender 5's default) and
    Blender's Bezier, NURBS and poly curve types are rendered as round Catmull-Rom tubes, with a warning."""
    points, count = len(curves.points), len(curves.curves)
    positions = np.empty(points * 3, np.float32)
    curves.position_data.foreach_get("vector", positions)
    radius = np.full(points, CURVE_RADIUS, np.float32)
    attribute = curves.attributes.get("radius")
    if attribute is not None and attribute.domain == "POINT" and attribute.data_type == "FLOAT":
        attribute.data.foreach_get("value", radius)
    offsets = np.empty(count + 1, np.int32)
    curves.curve_offset_data.foreach_get("value", offsets)
    first, counts = offsets[:-1].astype(np.int64), np.diff(offsets).astype(np.int64)
    material = np.zeros(count, np.int32)
    attribute = curves.attributes.get("material_index")
    if attribute is not None and attribute.domain == "CURVE":
        attribute.data.foreach_get("value", material)
    kinds = curves.attributes.get("curve_type")
    if kinds is not None and attribute_values(kinds, np.int32).any():
        warnings.append(f"curves '{curves.name}' have Bezier, NURBS or poly curves: Primer renders each as Cycles "
                        "renders Catmull-Rom curves, through its control points")
    shape = curve_shape(scene, f"curves '{curves.name}'", warnings)
    linear = shape == "THICK_LINEAR"                    # (straight tubes between the points: one ring per point)
    sides, steps = tube_resolution(int(np.maximum(counts - 1, 0).sum()), CURVE_TESSELLATION,
                                   CURVE_TESSELLATION_COARSE, f"curves '{curves.name}': {count} curves", "span",
                                   warnings)
    tubes = curves_.tubes(positions.reshape(-1, 3), radius, first, counts, sides, 1 if linear else steps,
                          name=curves.name, linear=linear)
    tubes.mesh.material_indices = material[tubes.curve].astype(np.int64)
    return tubes.mesh


# Cycles' radius of a point without a radius attribute (blender/pointcloud.cpp), and the icosphere a point becomes:
# its subdivisions by how many points the object has (at most POINT_TRIANGLES triangles), the finest first.
POINT_RADIUS, POINT_TRIANGLES = 0.01, 4_000_000


def points_mesh(cloud, warnings: list) -> core_scene.Mesh:
    """A PointCloud datablock as a core Mesh of icospheres (core/geometry/points.py): its points' positions, radius
    attribute (Cycles' 0.01 without one) and material index, read in bulk."""
    count = len(cloud.points)
    positions = np.empty(count * 3, np.float32)
    radius = np.full(count, POINT_RADIUS, np.float32)
    material = np.zeros(count, np.int32)
    for name, values, kind in (("position", positions, "vector"), ("radius", radius, "value"),
                               ("material_index", material, "value")):
        attribute = cloud.attributes.get(name)
        if attribute is not None and attribute.domain == "POINT" and len(attribute.data) == count:
            attribute.data.foreach_get(kind, values)
    subdivisions = next((n for n in (2, 1) if 20 * 4 ** n * count <= POINT_TRIANGLES), 0)
    if subdivisions < 2:
        warnings.append(f"point cloud '{cloud.name}': its {count} points are spheres of {20 * 4 ** subdivisions} "
                        "triangles, coarser than Primer's usual 320")
    mesh, point = points_.spheres(positions.reshape(-1, 3), radius, subdivisions, name=cloud.name)
    mesh.material_indices = material[point].astype(np.int64)
    mesh.curve_info = points_.point_info(positions.reshape(-1, 3), radius, len(mesh.vertices))
    return mesh


def curve_shape(scene, what: str, warnings: list) -> str:
    """Cycles' curve shape for the scene's curves (Render > Curves > Shape), with the note for Ribbons (rendered as
    round tubes) about `what` (e.g. "curves 'Hair'")."""
    shape = getattr(getattr(scene, "cycles_curves", None), "shape", "RIBBONS")
    if shape == "RIBBONS":
        warnings.append(f"{what}: Cycles' Ribbons (flat strips facing each ray, shaded as round) are rendered as "
                        "round tubes (3D Curves): the same outline and shading to within a few pixels' noise")
    return shape


def rendered_hair(obj) -> list:
    """The particle systems of `obj` that Cycles renders as hair: Hair type, rendered as Path, their modifier on
    for renders."""
    on = {modifier.particle_system.name for modifier in obj.modifiers
          if modifier.type == "PARTICLE_SYSTEM" and modifier.show_render}
    return [system for system in obj.particle_systems
            if system.name in on and system.settings.type == "HAIR" and system.settings.render_type == "PATH"]


def hair_radius(settings, time: np.ndarray) -> np.ndarray:
    """A hair's radius at `time` (...,) float64, the share of its length from the root, as Cycles' particle sync
    shapes it: radius_scale / 2 x (the diameters at root and tip, blended by (1 - time) to the power 1 + shape
    below 0, 1 / (1 - shape) above)."""
    scale = 0.5 * float(settings.radius_scale)
    root, tip, shape = scale * float(settings.root_radius), scale * float(settings.tip_radius), float(settings.shape)
    fall = 1.0 - time
    if shape < 0.0:
        fall = fall ** (1.0 + shape)
    elif shape > 0.0:
        fall = fall ** (1.0 / (1.0 - shape))
    return fall * (root - tip) + tip


# Particle hair's tubes: sides and rings per span between the path cache's keys (the coarse pair past CURVE_TRIANGLES).
HAIR_TESSELLATION, HAIR_TESSELLATION_COARSE = (8, 2), (4, 1)


def particle_hair_mesh(obj, system, render: bool, matrix: np.ndarray, warnings: list, shape: str = "THICK"):
    """The hair of particle system `system` of the evaluated object `obj` as a core Mesh of tubes in the object's
    space (core/geometry/curves.py), or None without strands. As Cycles' sync: the parents, or only the children
    where the system has some; 2^(render or display steps) + 1 keys each (co_hair, in world space), repeated keys
    left out; the radius by hair_radius along each strand's length, 0 at the tip with Close Tip; the material of
    the system's slot; straight between the keys for Cycles' Thick Linear `shape`."""
    settings = system.settings
    parents, children = len(system.particles), len(system.child_particles)
    if not render:
        children = int(children * settings.display_percentage / 100.0)
    start = parents if settings.child_type != "NONE" and children > 0 else 0
    steps = (1 << int(settings.render_step if render else settings.display_step)) + 1
    if settings.kink == "SPIRAL":
        steps += int(settings.kink_extra_steps)
    strands = np.arange(start, parents + children)
    if len(strands) == 0:
        return None
    keys = np.array([[system.co_hair(obj, particle_no=int(k), step=step)[:] for step in range(steps)]
                     for k in strands], np.float64)                                   # (c, steps, 3) world
    inverse = np.linalg.inv(matrix)
    keys = keys @ inverse[:3, :3].T + inverse[:3, 3]
    step = np.linalg.norm(np.diff(keys, axis=1), axis=2)                                # (c, steps - 1)
    kept = np.concatenate([np.ones((len(keys), 1), bool), step > 0.0], axis=1)
    length = np.concatenate([np.zeros((len(keys), 1)), np.cumsum(step, axis=1)], axis=1)
    total = length[:, -1:]
    time = np.divide(length, total, out=np.zeros_like(length), where=total > 0.0)
    radius = hair_radius(settings, time)
    if settings.use_close_tip:
        last = np.where(kept, np.arange(steps)[None, :], -1).max(axis=1)
        radius[np.arange(len(keys)), last] = 0.0
    counts = kept.sum(axis=1)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    sides, rings = tube_resolution(int((counts - 1).sum()), HAIR_TESSELLATION, HAIR_TESSELLATION_COARSE,
                                   f"object '{obj.name}': the {len(strands)} strands of particle system "
                                   f"'{system.name}'", "key", warnings)   # (keys: the path cache's, close together)
    tubes = curves_.tubes(keys[kept], radius[kept], first, counts, sides, rings, name=f"{obj.name} {system.name}",
                          linear=shape == "THICK_LINEAR")
    slot = max(int(settings.material) - 1, 0)
    tubes.mesh.material_indices[:] = min(slot, max(len(obj.material_slots) - 1, 0))
    return tubes.mesh


def curve_attributes(mesh: core_scene.Mesh, wanted: set) -> set:
    """Give the tubes `mesh` of curves the Curves Info attributes of `wanted`, or a point cloud's spheres the Point Info
    ones (its Mesh.curve_info, per vertex, as per-corner attributes); return the names of `wanted` it cannot carry (on
    other meshes the Curves Info and Point Info read 0, as in Cycles off strands and points)."""
    for name in wanted & set(mesh.curve_info):
        if name not in mesh.attributes:
            values = mesh.curve_info[name][mesh.triangles]                      # (t, 3) or (t, 3, 3)
            mesh.attributes[name] = values[:, :, None] if values.ndim == 2 else values
    return {name for name in wanted - set(mesh.curve_info) if not name.startswith(("curve", "point_", "triangle_"))}   # (0 off them)


def attribute_values(attribute, dtype) -> np.ndarray:
    """A Blender attribute's values (n,) of `dtype`, read in bulk."""
    values = np.empty(len(attribute.data), dtype)
    attribute.data.foreach_get("value", values)
    return values


def _mesh_arrays(mesh) -> core_scene.Mesh:
    """Return a core Mesh from a Blender mesh's loop triangles, read in bulk.

    Corner normals (Blender's own: smooth, flat, sharp edges, smooth by angle,
    custom normals) are read only when some face is smooth. Face values are read from the mesh's
    attributes (`sharp_face`, `material_index`, the triangles' faces) rather than from RNA's
    per-triangle properties, which Blender computes one item at a time: about 4 times faster on
    `modifiers_instances`, the same numbers (_mesh_arrays_by_rna, tests/test_blender_scenes.py). A mesh of
    triangles alone reads no loop triangles at all (_triangle_loops).
    """
    co = _positions(mesh)
    loops = _triangle_loops(mesh)                                       # the triangles' face corners
    triangles = _corner_vertices(mesh)[loops]
    face = _triangle_faces(mesh)
    smooth = ~_face_attribute(mesh, "sharp_face", "BOOLEAN", bool, False)[face]
    material_indices = _face_attribute(mesh, "material_index", "INT", np.int32, 0)[face]
    return _core_mesh(mesh, co, triangles, loops, smooth, material_indices)


def _mesh_arrays_by_rna(mesh) -> core_scene.Mesh:
    """_mesh_arrays through RNA's per-triangle and per-face properties: the readable reference."""
    n_triangles = len(mesh.loop_triangles)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    triangles = np.empty(n_triangles * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    loops = np.empty(n_triangles * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    material_indices = np.empty(n_triangles, np.int32)
    mesh.loop_triangles.foreach_get("material_index", material_indices)
    polygon = np.empty(n_triangles, np.int32)
    mesh.loop_triangles.foreach_get("polygon_index", polygon)
    smooth_faces = np.empty(len(mesh.polygons), bool)
    mesh.polygons.foreach_get("use_smooth", smooth_faces)
    smooth = smooth_faces[polygon] if len(smooth_faces) else np.zeros(n_triangles, bool)
    return _core_mesh(mesh, co, triangles, loops, smooth, material_indices)


def _core_mesh(mesh, co: np.ndarray, triangles: np.ndarray, loops: np.ndarray, smooth: np.ndarray,
               material_indices: np.ndarray) -> core_scene.Mesh:
    """Return the core Mesh of flat arrays read from `mesh`, with its corner normals where some face is smooth.

    co: (3 v,) float32; triangles, loops: (3 t,) int32 vertex and face corner of each triangle corner;
    smooth: (t,) bool; material_indices: (t,) int32.
    """
    n_triangles = len(smooth)
    if mesh.has_custom_normals:
        smooth[:] = True
    corner_normals = None
    if smooth.any():
        normals = np.empty(len(mesh.loops) * 3, np.float32)
        mesh.corner_normals.foreach_get("vector", normals)
        corner_normals = np.take(normals.reshape(-1, 3), loops, axis=0).reshape(n_triangles, 3, 3)
    return core_scene.Mesh(co.reshape(-1, 3), triangles.reshape(-1, 3), smooth=smooth,
                           corner_normals=corner_normals, material_indices=material_indices, name=mesh.name)


# Mesh attributes a material graph may read (core/materials/graph.py attributes_of), read per triangle corner.

def _active_render(collection):
    """The layer of a UV map or colour attribute collection that renders (Cycles' default), or None."""
    for layer in collection:
        if getattr(layer, "active_render", False):
            return layer
    return getattr(collection, "active", None)


def _corner_loops(mesh) -> np.ndarray:
    """The face corner (loop) of each triangle corner: (t, 3) int64."""
    return _triangle_loops(mesh).reshape(-1, 3).astype(np.int64)


def mesh_attributes(mesh, core_mesh: core_scene.Mesh, names, warnings: list) -> None:
    """Add to `core_mesh` the per-corner attributes `names` it lacks (graph.attributes_of's names), read in
    bulk: UV maps, colour attributes, MikkTSpace tangents (mesh.calc_tangents), generated and object
    coordinates, Cycles' pointiness (core/geometry/pointiness.py) and Random Per Island (core/geometry/islands.py).
    A missing map or attribute stays zeros (as in Cycles), with a warning."""
    missing = [name for name in sorted(names) if name not in core_mesh.attributes]
    if not missing or len(core_mesh.triangles) == 0:
        return
    loops = _corner_loops(mesh)
    t = len(loops)
    co = _positions(mesh).reshape(-1, 3).astype(np.float64)
    corner_vertex = _corner_vertices(mesh)
    for name in missing:
        kind, _, layer = name.partition(":")
        values = np.zeros((t, 3, graph_.attribute_width(name)))
        if kind == "uv":
            uv = mesh.uv_layers.get(layer) if layer else _active_render(mesh.uv_layers)
            if uv is None:
                warnings.append(f"mesh '{mesh.name}' has no UV map '{layer or '(active)'}'; Primer reads (0, 0)")
            else:
                data = np.empty(len(mesh.loops) * 2, np.float32)
                uv.uv.foreach_get("vector", data)
                values[:, :, :2] = data.reshape(-1, 2)[loops]
        elif kind in ("color", "attr"):
            attribute = (mesh.color_attributes.get(layer) or mesh.attributes.get(layer)) if layer else None
            if not layer and kind == "color":
                index = getattr(mesh.color_attributes, "render_color_index", -1)
                attribute = mesh.color_attributes[index] if 0 <= index < len(mesh.color_attributes) else None
            if attribute is None and kind == "attr":           # Cycles' attribute_not_found: 0, Alpha 1
                values[:, :, 3] = 1.0
            elif attribute is None:
                warnings.append(f"mesh '{mesh.name}' has no colour attribute '{layer or '(active)'}'; Primer reads 0")
            else:
                width = {"FLOAT_COLOR": 4, "BYTE_COLOR": 4, "FLOAT_VECTOR": 3, "FLOAT2": 2, "FLOAT": 1}.get(
                    attribute.data_type, 0)
                field_name = "color" if width == 4 else ("vector" if width in (2, 3) else "value")
                if width == 0:
                    warnings.append(f"attribute '{layer}' of mesh '{mesh.name}' is {attribute.data_type}; Primer reads 0")
                    continue
                data = np.empty(len(attribute.data) * width, np.float32)
                attribute.data.foreach_get(field_name, data)
                data = data.reshape(-1, width)
                per_corner = {"CORNER": loops, "POINT": corner_vertex[loops]}.get(attribute.domain)
                if per_corner is None:
                    warnings.append(f"attribute '{layer}' of mesh '{mesh.name}' is on the {attribute.domain} domain; "
                                    "Primer reads 0")
                    continue
                values[:, :, :width] = data[per_corner]
                if width < 4:
                    values[:, :, 3] = 1.0
        elif kind == "tangent":
            uv = mesh.uv_layers.get(layer) if layer else _active_render(mesh.uv_layers)
            try:
                if uv is None:
                    raise ValueError("no such UV map")
                mesh.calc_tangents(uvmap=uv.name)
                tangent = np.empty(len(mesh.loops) * 3, np.float32)
                sign = np.empty(len(mesh.loops), np.float32)
                mesh.loops.foreach_get("tangent", tangent)
                mesh.loops.foreach_get("bitangent_sign", sign)
                values[:, :, :3] = tangent.reshape(-1, 3)[loops]
                values[:, :, 3] = sign[loops]
            except (RuntimeError, ValueError) as error:
                warnings.append(f"mesh '{mesh.name}': no tangents for UV map '{layer or '(active)'}' ({error}); "
                                "normal maps there keep the surface's normal, and a tangent-space Vector "
                                "Displacement takes the triangle's edge for its tangent, as Cycles does")
        elif kind == "pointiness":                                          # Cycles' curvature per vertex
            normals = np.empty(len(mesh.vertices) * 3, np.float32)
            mesh.vertices.foreach_get("normal", normals)
            edges = np.empty(len(mesh.edges) * 2, np.int32)
            mesh.edges.foreach_get("vertices", edges)
            per_vertex = pointiness_.pointiness(co, normals.reshape(-1, 3).astype(np.float64), edges.reshape(-1, 2))
            values[:, :, 0] = per_vertex[corner_vertex[loops]]
        elif kind == "island":                                              # Cycles' Random Per Island
            edges = np.empty(len(mesh.edges) * 2, np.int32)
            mesh.edges.foreach_get("vertices", edges)
            values[:, :, 0] = islands_.random_per_island(len(mesh.vertices), edges,
                                                         corner_vertex[loops][:, 0])[:, None]
        elif kind in ("triangle_dpdu", "triangle_dpdv"):      # Cycles' sd->dPdu, dPdv of a triangle (object space)
            points = co[corner_vertex[loops]]                                   # (t, 3, 3)
            edge = points[:, 1] - points[:, 0] if kind == "triangle_dpdu" else points[:, 2] - points[:, 0]
            values[:] = edge[:, None, :]
        elif kind in ("generated", "object"):
            points = co[corner_vertex[loops]]                                   # (t, 3, 3)
            if kind == "generated":
                location = np.array(mesh.texspace_location, np.float64)
                size = np.array(mesh.texspace_size, np.float64)
                points = np.divide(points - location, 2.0 * size, out=np.zeros_like(points), where=size != 0.0) + 0.5
            values[:] = points
        core_mesh.attributes[name] = values


class MaterialTable:
    """Scene materials, each exported once, with stable indices (the BVH stores them per triangle).

    Keyed by the original datablock's session uid: a pointer may be reused when Blender evaluates
    the scene again, which matters to the viewport's cache (addon/scene_cache.py), kept between updates.
    """

    def __init__(self):
        self.index: dict = {}
        self.materials: list = []          # core_scene.Material, in index order

    def index_of(self, material, warnings: list) -> int:
        """Return the scene index of `material`, exporting it the first time it is seen."""
        uid = material.original.session_uid
        if uid not in self.index:
            self.index[uid] = len(self.materials)
            exported = materials_.export_material(material, warnings)
            self.materials.append(dataclasses.replace(exported, pass_index=int(getattr(material, "pass_index", 0))))
        return self.index[uid]

    def slot_map(self, obj, warnings: list, override=None) -> np.ndarray:
        """Return the scene material index of each of the object's material slots (-1 for empty): (k,) int64.

        With the view layer's Material Override every slot, and an object without slots, gets it (as in Cycles)."""
        if override is not None:
            return np.full(max(1, len(obj.material_slots)), self.index_of(override, warnings), np.int64)
        return np.array([-1 if slot.material is None else self.index_of(slot.material, warnings)
                         for slot in obj.material_slots], np.int64)


# ----------------------------------------------------------------------------
# Lights, in Cycles' units
# ----------------------------------------------------------------------------

def _light_color(light) -> np.ndarray:
    """Return colour x 2^exposure (x blackbody colour when temperature is used), linear RGB."""
    color = materials_.blender_float(np.array(light.color[:3], np.float64)) * 2.0 ** getattr(light, "exposure", 0.0)
    if getattr(light, "use_temperature", False):
        color = color * np.array(light.temperature_color[:3], np.float64)
    return color


# The node kinds whose outputs depend on their inputs alone (no coordinates, no texture, no path): a lamp's Emission
# fed only by them is a constant, which Primer evaluates once (light_node_factor).
CONSTANT_KINDS = frozenset({"RGB", "VALUE", "MATH", "MIX", "RAMP", "INVERT", "HSV", "SEPARATE_COLOR", "SEPARATE_XYZ",
                            "COMBINE_COLOR", "COMBINE_XYZ", "CLAMP", "MAP_RANGE", "SCALE"}
                           | {cls.kind for cls in graph_.CONVERTER_TYPES if cls.kind != "IES_TEXTURE"})


def light_node_factor(obj, warnings: list, wiring, falloff=None) -> np.ndarray:
    """Return what the light's node tree multiplies its colour by: (3,) linear RGB.

    Cycles renders a light as its colour x power x the emission of its shader. Without a node tree that
    shader is an Emission node, white, strength 1; Blender 5.2 gives every light such a tree (4.2 and 5.0
    use one only with Use Nodes on). Primer reads an Emission node at the Light Output as Cycles does, its
    Color x Strength, so a default tree changes nothing; inputs fed by nodes that depend on nothing but constants
    (a Blackbody, a Math, a Mix of colours...: CONSTANT_KINDS) are evaluated once, by the node-graph program the
    materials use. Where the Emission's Color x Strength is the Fac of one IES Texture times a constant colour (the
    Fac straight into the Strength, or through Math, Mix ... nodes linear in it: lamp_ies_wiring), this returns that
    colour: the lamp's IESLamp (light_ies) scales its light by the Fac per direction. A tree that varies over the lamp
    otherwise is the lamp's program (lamp_program, evaluated per light sample), and never reaches here. Nothing at the
    output: Cycles' light sends no light (zeros, noted). Another shader there, or (beside an IES Texture not so wired,
    or in a sun's tree with a Light Falloff) an input fed by a node that varies over the lamp (a texture, texture
    coordinates, a Light Path, a Light Falloff) is warned about, naming the light and the node, and Primer uses the
    light's colour and power (or the input's own value).
    """
    tree = materials_.node_tree(obj.data)
    if tree is None:
        return np.ones(3)
    node = materials_.linked_node(materials_.output_node(tree, "ShaderNodeOutputLight"))
    if node is None:
        warnings.append(f"light '{obj.name}': nothing is linked to its Light Output, so it sends no light "
                        "(as in Cycles)")
        return np.zeros(3)
    reader = materials_.NodeReader(obj, warnings, kind="light")
    if node.bl_idname not in materials_.EMISSION_NODES:
        reader.warn(node, f"'{node.bl_label}' at the Light Output is not an Emission node; Primer uses the "
                          "light's colour and power")
        return np.ones(3)
    if wiring is not None:                  # (lamp_ies_wiring(obj), found once by _export_light)
        return wiring[1]
    if falloff is not None:                 # (lamp_falloff_wiring(obj): the rest is the lamp's falloff)
        return falloff[1]
    linked = [name for name in ("Color", "Strength") if node.inputs.get(name) is not None
              and node.inputs[name].is_linked]
    if linked:
        color = reader.input(node, "Color", np.ones(3))
        strength = reader.input(node, "Strength", 1.0)
        feeding = graph_.links_under([(None, 1.0, {"color": color, "strength": strength})])
        varying = [link.node for link in feeding if link.node.kind not in CONSTANT_KINDS or varies_with_distance(link.node)]
        if not varying:
            value = world_graph.radiance_along(world_graph.compile_world(color, strength), np.array([[0.0, 0.0, 1.0]]))
            return np.nan_to_num(value[0], nan=0.0, posinf=0.0, neginf=0.0)
        for name in linked:
            socket = node.inputs[name]
            reader.warn(node, f"input '{name}' is linked to '{socket.links[0].from_node.name}', which Primer does "
                              "not evaluate for lights (it varies over the lamp: "
                              f"'{varying[0].name or varying[0].kind}'); it uses the input's own value")
    return reader.value(node, "Color", np.ones(3)) * reader.value(node, "Strength", 1.0)


def varies_with_distance(node) -> bool:
    """Whether a graph node is a lamp's Light Falloff (addon/materials.py lamp_falloff) whose output depends on the
    distance to the lit point (Linear, Constant, or a Smooth above 0)."""
    power, smooth = node.props.get("light_falloff", (0, 0.0)) if node.kind == "VALUE" else (0, 0.0)
    return power != 0 or smooth > 0.0


def falloff_fed(tree) -> bool:
    """Whether a lamp's tree has a Light Falloff whose output is used and whose Strength or Smooth is linked (the
    warning-free reading of lamp_emission takes its own values; its program reads the links per sample)."""
    return any(node.bl_idname == "ShaderNodeLightFalloff" and not getattr(node, "mute", False)
               and any(out.is_linked for out in node.outputs)
               and any(node.inputs[name].is_linked for name in ("Strength", "Smooth")) for node in tree.nodes)


def lamp_emission(obj):
    """The Emission at a lamp's Light Output as node-graph inputs: (its tree, color, strength, the graph of the two),
    read without warnings (the caller's reading warns), or None where no Emission is there."""
    tree = materials_.node_tree(obj.data)
    emission = materials_.linked_node(materials_.output_node(tree, "ShaderNodeOutputLight")) if tree else None
    if emission is None or emission.bl_idname not in materials_.EMISSION_NODES:
        return None
    reader = materials_.NodeReader(obj, [], kind="light")
    color, strength = reader.input(emission, "Color", np.ones(3)), reader.input(emission, "Strength", 1.0)
    return tree, color, strength, [(None, 1.0, {"color": color, "strength": strength})]


def linear_factor(node, color, strength):
    """c (3,) float64 where the Emission of `color` x `strength` is c times the output of the graph node `node`, or None:
    the node's place is tried with the values 0, 1 and 2.5 (the node-graph program the materials use, once each),
    linear where they give 0, c and 2.5 c."""
    kind, props, inputs, values = node.kind, node.props, node.inputs, []
    try:
        for value in (0.0, 1.0, 2.5):
            node.kind, node.props, node.inputs = "VALUE", {"value": value}, {}
            values.append(np.asarray(world_graph.radiance_along(world_graph.compile_world(color, strength),
                                                                np.array([[0.0, 0.0, 1.0]]))[0], np.float64))
    finally:
        node.kind, node.props, node.inputs = kind, props, inputs
    zero, one, more = values
    if not (np.all(np.isfinite(values)) and np.allclose(zero, 0.0, atol=1e-12)
            and np.allclose(more, 2.5 * one, rtol=1e-6, atol=1e-12)):   # (float32 nodes)
        return None
    return one


def lamp_falloff_wiring(obj):
    """The arrangement of a Light Falloff in a lamp's tree Primer evaluates per light sample: the Emission at the Light
    Output whose Color x Strength is c x the output of one Light Falloff node (Strength S and Smooth unlinked), c a
    constant colour (the output straight into the Strength, or through nodes of constants alone linear in it:
    linear_factor), as lamp_ies_wiring finds an IES Texture's. Returns ((power, smooth), c S (3,) float64): the lamp
    sends c S t^power (t^2 / (smooth + t^2)) x its light (Light.falloff_factor), t the light sample's distance; or
    None."""
    emission = lamp_emission(obj)
    if emission is None:
        return None
    _, color, strength, graph = emission
    nodes = list(graph_.links_under(graph))      # (walked twice)
    found = {id(link.node): link.node for link in nodes if varies_with_distance(link.node)}
    if len(found) != 1 or any(link.node.kind not in CONSTANT_KINDS for link in nodes):
        return None
    node = next(iter(found.values()))
    falloff, S = tuple(node.props["light_falloff"]), float(node.props["value"])
    c = linear_factor(node, color, strength)
    return None if c is None else (falloff, c * S)


def lamp_ies_wiring(obj):
    """The one arrangement of IES Textures in a lamp's tree Primer evaluates per direction: the Emission at the Light
    Output whose Color x Strength is c x the Fac of one IES Texture, c a constant colour (the Fac straight into the
    Strength, or through nodes of constants alone that are linear in it: a Multiply, a Mix with black ...:
    linear_factor). Returns (the bpy IES Texture node, c (3,) float64), or None."""
    emission = lamp_emission(obj)
    if emission is None:
        return None
    tree, color, strength, graph = emission
    ies = {id(link.node): link.node for link in graph_.links_under(graph) if link.node.kind == "IES_TEXTURE"}
    if len(ies) != 1:
        return None
    found = next(iter(ies.values()))
    inputs = found.inputs
    try:
        found.inputs = {}                       # (what feeds its Vector or Strength is warned about, not evaluated)
        if any((link.node.kind not in CONSTANT_KINDS or varies_with_distance(link.node)) and link.node is not found
               for link in graph_.links_under(graph)):
            return None
    finally:
        found.inputs = inputs
    bpy_node = tree.nodes.get(found.name)
    if bpy_node is None or bpy_node.bl_idname != "ShaderNodeTexIES" or getattr(bpy_node, "mute", False):
        return None
    c = linear_factor(found, color, strength)
    return None if c is None else (bpy_node, c)


def light_ies(obj, matrix: np.ndarray, warnings: list, wiring):
    """Return the lamp's IES Texture as a core IESLamp (core/lights/ies.py), or None without one.

    Cycles evaluates the lamp's shader for each light sample; the IES Texture there gives Strength x the profile in
    the direction of its Vector, by default Geometry > Incoming taken into the lamp object's frame by the normal
    transform (the transposed object matrix): the direction from the lamp to the lit point in its own axes. Primer
    evaluates it so where the Emission is a constant colour times its Fac (lamp_ies_wiring: straight into the
    Strength, or through nodes linear in it); a linked Vector or Strength is warned about (Primer uses the default
    direction, the input's own value), as is an IES Texture wired otherwise (not evaluated: a lamp's tree is not run
    per direction; its node is read as the materials read it for the rest).
    """
    node = None if wiring is None else wiring[0]        # (lamp_ies_wiring(obj))
    tree = materials_.node_tree(obj.data)
    reader = materials_.NodeReader(obj, warnings, kind="light")
    for other in (tree.nodes if tree is not None else ()):
        if other.bl_idname == "ShaderNodeTexIES" and other != node and any(s.is_linked for s in other.outputs):
            reader.warn(other, "an IES Texture is evaluated per direction only where the lamp's Emission is a "
                               "constant colour times its Fac (straight into the Strength, or through nodes linear "
                               "in it); here Primer does not evaluate it")
    if node is None:
        return None
    for name, instead in (("Vector", "the direction from the lamp in its own frame (Cycles' default)"),
                          ("Strength", "the input's own value")):
        socket = node.inputs.get(name)
        if socket is not None and socket.is_linked:
            reader.warn(node, f"input '{name}' of the IES Texture is linked, which Primer does not evaluate; it uses "
                              f"{instead}")
    profile = ies_.parse_ies(materials_.ies_text(node))
    if profile is None:
        reader.warn(node, "its IES file could not be read (none given, missing or not LM-63); as in Cycles, the "
                          "IES Texture gives Strength x 100 in every direction")
    strength = float(materials_.own_value(node.inputs["Strength"]))
    return IESLamp(profile, strength, np.ascontiguousarray(np.asarray(matrix, np.float64)[:3, :3].T))


def ray_visibility(obj) -> dict:
    """An object's Object > Visibility settings Primer reads, as core Instance keywords (visible_camera, ...,
    is_holdout, is_shadow_catcher: bool)."""
    names = ("visible_camera", "visible_shadow", "visible_diffuse", "visible_glossy", "visible_transmission",
             "visible_volume_scatter")
    seen = {name: bool(getattr(obj, name, True)) for name in names}
    return dict(seen, is_holdout=bool(getattr(obj, "is_holdout", False)),
                is_shadow_catcher=bool(getattr(obj, "is_shadow_catcher", False)))


def terminator_keywords(obj) -> dict:
    """An object's Object > Shading > Shadow Terminator offsets, as core Instance keywords (terminator_offset,
    terminator_shading): Cycles lifts the shadow rays of each object's smooth triangles, and bends its closures'
    light, by the object's own."""
    geometry, shading = _terminator_offsets(obj)
    return {"terminator_offset": geometry, "terminator_shading": shading}


def instance_keywords(obj) -> dict:
    """What a core Instance reads of an object besides its mesh and materials: Ray Visibility, Holdout, the shadow
    terminator offsets (ray_visibility, terminator_keywords), its own Fast GI AO Distance (Object > Visibility) and
    its Shadow Caustics switches (Object > Shading > Caustics: core Instance.caustics_caster, caustics_receiver)."""
    cycles = getattr(obj, "cycles", None)
    own = float(getattr(cycles, "ao_distance", 0.0) or 0.0)
    caustics = {"caustics_caster": bool(getattr(cycles, "is_caustics_caster", False)),
                "caustics_receiver": bool(getattr(cycles, "is_caustics_receiver", False))}
    return {**ray_visibility(obj), **terminator_keywords(obj), **({"ao_distance": own} if own else {}), **caustics}


def indirect_only(instance, view_layer) -> bool:
    """Whether a depsgraph object instance lies in an Indirect Only collection of `view_layer` (an instance: its
    instancer does), which Cycles renders hidden from camera rays only; Blender keeps the flag on the original
    object's base (the evaluated copy reads False)."""
    owner = instance.parent if instance.is_instance and instance.parent is not None else instance.object
    try:
        return bool(owner.original.indirect_only_get(view_layer=view_layer))
    except (AttributeError, RuntimeError, TypeError):  # (an object outside the view layer: no base to ask)
        return False


# The Ray Visibility switches of a lamp object that hide it from bounces (camera visibility is read on its own).
LAMP_RAY_VISIBILITY = ("visible_diffuse", "visible_glossy", "visible_transmission", "visible_volume_scatter")


def lamp_hidden(obj) -> int:
    """The HIDDEN_FROM_* bits of the bounces a lamp object hides from (its Ray Visibility, as Cycles' light shader's
    SHADER_EXCLUDE_* flags): its light samples leave out the closures of those kinds, and such rays pass it."""
    return hidden_bits(obj, LAMP_RAY_VISIBILITY)


def export_light(obj, matrix: np.ndarray, warnings: list, instance=None):
    """Return the core light of a Blender light object placed by `matrix` (4, 4), or None if it sends no light.
    instance: the depsgraph object instance it comes from (an instanced lamp's random number and Instancer
    attributes, which its node tree's Object Info and Attribute nodes read), or None: the object itself.

    A light with size is seen by camera rays, as in Cycles, unless its Ray Visibility > Camera is off; its other
    Ray Visibility switches hide it from diffuse, glossy and transmission bounces (lamp_hidden).
    """
    core = _export_light(obj, matrix, warnings, instance)
    if core is not None:
        core.camera = bool(getattr(obj, "visible_camera", True))
        core.cast_shadow = bool(getattr(obj.data, "use_shadow", True))    # Cast Shadow (Cycles: no shadow rays)
        core.hidden_from = lamp_hidden(obj)
        cycles = getattr(getattr(getattr(obj, "original", obj), "data", obj.data), "cycles", None)   # (as the user set it)
        core.use_mis = bool(getattr(cycles, "use_multiple_importance_sampling", True))
        core.max_bounces = int(getattr(cycles, "max_bounces", 1024))
        core.caustics = bool(getattr(cycles, "is_caustics_light", False))   # Shadow Caustics (core/integrators/mnee.py)
    return core


def _export_light(obj, matrix: np.ndarray, warnings: list, instance=None):
    """export_light's work."""
    light = obj.data
    if light.type == "AREA" and getattr(getattr(light, "cycles", None), "is_portal", False):
        return None
    wiring = lamp_ies_wiring(obj)
    falloff = lamp_falloff_wiring(obj) if wiring is None else None
    program = lamp_program(obj, matrix, warnings, instance) if wiring is None and falloff is None else None
    if program is not None:             # (the tree's emission is the program's, per sample)
        core = _lamp(obj, matrix, warnings, _light_color(light))
        if core is not None:
            core.lamp_nodes = program
        return core
    emission = light_node_factor(obj, warnings, wiring, falloff)
    if not emission.any():
        return None                     # Cycles leaves out a light whose shader emits nothing
    ies = light_ies(obj, matrix, warnings, wiring)
    core = _lamp(obj, matrix, warnings, _light_color(light) * emission)
    if core is not None and ies is not None:
        core.ies = ies
    if core is not None and falloff is not None and hasattr(core, "falloff"):   # (a sun: Cycles skips the node)
        core.falloff = falloff[0]
    return core


# The lamps whose trees Primer evaluates per light sample (core/lights/lamp_graph.py), with how their UV is made.
PROGRAM_LAMPS = {"POINT": lamp_graph_.UV_SPHERE, "SPOT": lamp_graph_.UV_SPOT, "AREA": lamp_graph_.UV_AREA,
                 "SUN": lamp_graph_.UV_SUN}


def lamp_program(obj, matrix: np.ndarray, warnings: list, instance=None):
    """The program of a lamp's Emission that varies over the lamp (core/lights/lamp_graph.py LampEmission), or None: a
    constant tree (light_node_factor evaluates it once), an IES Texture or a Light Falloff wired linearly
    (lamp_ies_wiring, lamp_falloff_wiring: evaluated by the lamp's own factors), another shader at the Light Output, a
    tree with an IES Texture wired otherwise (light_ies warns, as before), or a sun's tree with a Light Falloff (its
    ray length FLT_MAX; light_node_factor warns).

    As Cycles' light_sample_shader_eval, the Emission's Color x Strength is evaluated for each light sample and each
    ray that meets the lamp, at the lamp's shading point (shader_setup_from_sample): textures, Texture Coordinate
    (Normal, Object, Generated, UV as Cycles defines them for lamps), Math, Mix, Color Ramp, Light Falloff in any wiring
    (with the sample's ray length, as the materials' Light Falloff) and the rest of the node-graph program; Light
    Path's depths those of the path the light reaches (lamp_graph.lamp_paths), Object Info and an Attribute node's
    Object and Instancer attributes the lamp object's (lamp_object_info; instance: its depsgraph instance, or None)."""
    light = obj.data
    emission = lamp_emission(obj)
    if light.type not in PROGRAM_LAMPS or emission is None:
        return None
    tree, _, _, graph = emission
    feeding = list(graph_.links_under(graph))
    if not any(link.node.kind not in CONSTANT_KINDS or varies_with_distance(link.node) for link in feeding) and \
            not falloff_fed(tree):
        return None
    if any(link.node.kind == "IES_TEXTURE" for link in feeding):
        return None                     # (an IES Texture wired otherwise than linearly: light_ies warns, as before)
    if light.type == "SUN" and any(n.bl_idname == "ShaderNodeLightFalloff" and any(o.is_linked for o in n.outputs)
                                   for n in tree.nodes):
        return None                     # (a sun's ray length is FLT_MAX, whose square Cycles skips: warned, as before)
    node = materials_.linked_node(materials_.output_node(tree, "ShaderNodeOutputLight"))
    reader = materials_.NodeReader(obj, warnings, kind="light")
    reader.per_sample = True            # (a Light Falloff reads the sample's ray length, as in a material)
    color, strength = reader.input(node, "Color", np.ones(3)), reader.input(node, "Strength", 1.0)
    spot_size = float(light.spot_size) if light.type == "SPOT" else float(light.angle) if light.type == "SUN" else 0.0
    info, random = lamp_object_info(obj, matrix, instance)     # (after reading: the attributes it reads have columns)
    return lamp_graph_.compile_lamp(color, strength, np.asarray(matrix, np.float64), PROGRAM_LAMPS[light.type],
                                    spot_size, info, random)


def lamp_object_info(obj, matrix: np.ndarray, instance=None) -> tuple:
    """A lamp object's Object Info row ((OBJECT_INFO_WIDTH + 4 k,) float64, geometry.instance_info's columns: its
    location, Color and Alpha, pass index, then the RGBA of the k Object and Instancer attributes read so far,
    materials.INSTANCE_ATTRIBUTES) and its random number, as Cycles' lamp shading point reads its object (ls->object:
    a light is an object of its own in Cycles 5): Object Info's Random hash_uint2(hash_string(name), 0), an
    instance's its random_id. instance: its depsgraph instance, or None (the object itself)."""
    shim = instance if instance is not None else types.SimpleNamespace(
        is_instance=False, object=obj, parent=None, particle_system=None, persistent_id=(0,))
    row = np.zeros(materials_.OBJECT_INFO_WIDTH + 4 * len(materials_.INSTANCE_ATTRIBUTES))
    row[0:3] = np.asarray(matrix, np.float64)[:3, 3]
    row[3:7] = np.asarray(tuple(obj.color), np.float64)[:4]
    row[7] = int(getattr(obj, "pass_index", 0))
    for key, rgba in (materials_.object_attributes(shim) or {}).items():
        start = materials_.OBJECT_INFO_WIDTH + 4 * materials_.INSTANCE_ATTRIBUTES.index(key)
        row[start:start + 4] = rgba
    instanced = instance is not None and getattr(instance, "is_instance", False)
    random = graph_.random_from_id(instance.random_id) if instanced else graph_.object_random(obj.name)
    return row, random


def _lamp(obj, matrix: np.ndarray, warnings: list, color: np.ndarray):
    """The core lamp of a Blender light object of colour `color` (its light's colour x what its nodes give)."""
    light = obj.data
    normalize = getattr(light, "normalize", True)
    position = matrix[:3, 3].copy()
    axes = matrix[:3, :3]
    minus_z = -axes[:, 2] / max(np.linalg.norm(axes[:, 2]), 1e-300)
    if light.type in {"POINT", "SPOT"}:
        radius = float(light.shadow_soft_size)
        power = materials_.blender_float(float(light.energy))
        if not normalize:
            # Unnormalised: radiance P / pi instead of P / (4 pi^2 R^2) (radius 0: intensity P / pi).
            power *= 4.0 * math.pi * radius * radius if radius > 0 else 4.0
        soft = bool(getattr(light, "use_soft_falloff", True))
        if light.type == "POINT":
            return core_scene.PointLight(position, power, color, radius, soft, name=obj.name)
        return core_scene.SpotLight(position, minus_z, power, color, radius, soft,
                                    spot_size=float(light.spot_size), spot_blend=float(light.spot_blend),
                                    frame=axes.copy(), name=obj.name)
    if light.type == "SUN":
        angle = float(light.angle)
        strength = materials_.blender_float(float(light.energy))
        if not normalize and angle > 0:
            strength *= math.pi * math.sin(0.5 * angle) ** 2
        return core_scene.SunLight(minus_z, strength, color, angle, name=obj.name)
    if light.type == "AREA":
        size_x = float(light.size)
        size_y = float(light.size_y) if light.shape in {"RECTANGLE", "ELLIPSE"} else size_x
        axis_u = axes[:, 0] * size_x
        axis_v = axes[:, 1] * size_y
        # Cycles emits along the object's -Z axis, whatever the handedness of X and Y (a light with
        # negative X scale still faces -Z), and ignores the Z scale.
        if not (np.linalg.norm(np.cross(axis_u, axis_v)) > 0 and np.linalg.norm(axes[:, 2]) > 0):
            warnings.append(f"area light '{obj.name}' has zero size and was skipped")
            return None
        power = materials_.blender_float(float(light.energy))
        area = core_scene.AreaLight(position, axis_u, axis_v, minus_z, power, color,
                                    light.shape, float(getattr(light, "spread", math.pi)), name=obj.name)
        if not normalize:
            area.power = power * area.area()
        return area
    warnings.append(f"light '{obj.name}' of type {light.type} is not supported and was skipped")
    return None


# ----------------------------------------------------------------------------
# Camera, world, settings
# ----------------------------------------------------------------------------

def export_camera(camera_object, warnings: list = None) -> Camera:
    """Return the core camera of a Blender camera object (scale is ignored, as in Cycles); another object (an
    Empty, a mesh, a light) as the scene camera is looked through as Cycles does, with a warning."""
    data = camera_object.data
    if getattr(camera_object, "type", "CAMERA") != "CAMERA" or data is None or not hasattr(data, "lens"):
        return _object_camera(camera_object, warnings)
    kind = data.type if data.type in {"PERSP", "ORTHO", "PANO"} else "PERSP"
    panorama = getattr(data, "panorama_type", "FISHEYE_EQUIDISTANT")
    if kind == "PANO" and panorama not in PANORAMA_TYPES:
        raise ExportError(f"camera '{camera_object.name}' is a {panorama} panorama, which Primer does not know")
    return Camera(
        matrix_world=np.array(camera_object.matrix_world, np.float64),
        type=kind, lens=float(data.lens), sensor_width=float(data.sensor_width),
        sensor_height=float(data.sensor_height), sensor_fit=data.sensor_fit,
        shift_x=float(data.shift_x), shift_y=float(data.shift_y),
        clip_start=float(data.clip_start), clip_end=float(data.clip_end),
        ortho_scale=float(data.ortho_scale),
        panorama_type=panorama if kind == "PANO" else "FISHEYE_EQUIDISTANT",
        fisheye_fov=float(getattr(data, "fisheye_fov", math.pi)),
        fisheye_lens=float(getattr(data, "fisheye_lens", 10.5)),
        **panorama_settings(data, panorama if kind == "PANO" else ""),
        **depth_of_field(camera_object, kind),
    )


def panorama_settings(data, panorama: str) -> dict:
    """The Camera fields of an equirectangular, polynomial-fisheye or central-cylindrical panorama (their spans and
    coefficients, as Blender names them); {} for the others."""
    if panorama == "EQUIRECTANGULAR":
        return dict(longitude_min=float(data.longitude_min), longitude_max=float(data.longitude_max),
                    latitude_min=float(data.latitude_min), latitude_max=float(data.latitude_max))
    if panorama == "FISHEYE_LENS_POLYNOMIAL":
        return dict(fisheye_polynomial=tuple(float(k) for k in (
            data.fisheye_polynomial_k0, data.fisheye_polynomial_k1, data.fisheye_polynomial_k2,
            data.fisheye_polynomial_k3, data.fisheye_polynomial_k4)))
    if panorama == "CENTRAL_CYLINDRICAL":
        return dict(cylinder_u_min=float(data.central_cylindrical_range_u_min),
                    cylinder_u_max=float(data.central_cylindrical_range_u_max),
                    cylinder_v_min=float(data.central_cylindrical_range_v_min),
                    cylinder_v_max=float(data.central_cylindrical_range_v_max),
                    cylinder_radius=max(float(data.central_cylindrical_radius), 1e-6))
    return {}


def depth_of_field(camera_object, kind: str) -> dict:
    """The Camera fields of a camera's Depth of Field, as Cycles reads them (intern/cycles/blender/camera.cpp): the
    aperture's radius is the focal length over twice the f-stop (1 / (2 f-stop) for an orthographic camera); the focus
    distance is the Focus Distance, or with a Focus Object (a bone of it with a Focus Bone) its distance from the camera
    along the view axis (a panorama's too, with its Lens's focal length). {} without depth of field (a pinhole)."""
    dof = getattr(camera_object.data, "dof", None)
    if dof is None or not dof.use_dof:
        return {}
    fstop = max(float(dof.aperture_fstop), 1e-5)
    size = 1.0 / (2.0 * fstop) if kind == "ORTHO" else float(camera_object.data.lens) * 1e-3 / (2.0 * fstop)
    distance = float(dof.focus_distance)
    target = dof.focus_object
    if target is not None:
        where = np.array(target.matrix_world, np.float64)
        bone = getattr(dof, "focus_subtarget", "")
        if bone and getattr(target, "pose", None) is not None and bone in target.pose.bones:
            where = where @ np.array(target.pose.bones[bone].matrix, np.float64)
        camera = np.array(camera_object.matrix_world, np.float64)
        axis = camera[:3, 2] / max(np.linalg.norm(camera[:3, 2]), 1e-300)
        distance = abs(float(axis @ (camera[:3, 3] - where[:3, 3])))
    return dict(aperture_size=size, focus_distance=max(distance, 1e-5), aperture_blades=int(dof.aperture_blades),
                aperture_rotation=float(dof.aperture_rotation), aperture_ratio=float(dof.aperture_ratio))


# Cycles' camera for a scene camera that is no camera object (intern/cycles/blender/camera.cpp, BlenderCamera's
# defaults): perspective, 50 mm lens on a 36 x 24 mm sensor fitted automatically, no shift, clipping 1e-5 .. 1e5.
OBJECT_CAMERA = dict(type="PERSP", lens=50.0, sensor_width=36.0, sensor_height=24.0, sensor_fit="AUTO",
                     shift_x=0.0, shift_y=0.0, clip_start=1e-5, clip_end=1e5)


def _object_camera(obj, warnings) -> Camera:
    """The camera Cycles looks through for an object that is not a camera: its transform (scale cleared) with
    OBJECT_CAMERA's settings; a spot lamp's cone sets the lens (16 mm / tan(spot size / 2)), as in Cycles."""
    settings = dict(OBJECT_CAMERA)
    data = obj.data
    if getattr(obj, "type", "") == "LIGHT" and getattr(data, "type", "") == "SPOT":
        lens = 16.0 / math.tan(float(data.spot_size) * 0.5)
        if lens > 0.0:
            settings["lens"] = lens
    if warnings is not None:
        warnings.append(f"the scene camera '{obj.name}' is not a camera object but {getattr(obj, 'type', '?')}: Primer "
                        f"looks through it as Cycles does, a perspective camera with a {settings['lens']:g} mm lens on a "
                        "36 x 24 mm sensor (Auto fit), clipping 1e-05 to 1e+05")
    return Camera(matrix_world=np.array(obj.matrix_world, np.float64), **settings)


def note_volume_space(obj, matrix: np.ndarray, slots: np.ndarray, materials: list, spaces: dict) -> "tuple | None":
    """Keep in `spaces` (material index -> Material.volume_space) the object space of each heterogeneous medium
    (a volume input fed by a link) among the materials `slots` (k,) of object `obj` placed by `matrix` (4, 4): its
    graph reads the points' Object and Generated coordinates there (the first object's; a medium on objects of other
    placements or texture spaces is kept per object, each in its own: core/volumes/media.py per_object). Returns
    the object's texture space (location (3,), size (3,)) for its Instance.texspace where it holds such a medium,
    else None."""
    from ..core.volumes import field as field_
    texspace = None
    for slot in sorted(set(slots[slots >= 0].tolist())):
        volume = materials[slot].volume
        if not volume or not field_.linked(volume):
            continue
        data = obj.data
        location = np.array(getattr(data, "texspace_location", (0.0, 0.0, 0.0)), np.float64)
        size = np.array(getattr(data, "texspace_size", (1.0, 1.0, 1.0)), np.float64)
        texspace = (location, size)
        if slot not in spaces:
            spaces[slot] = (np.linalg.inv(np.asarray(matrix, np.float64))[:3], location, size)
    return texspace


def media_of_layer(use_volumes: bool, materials: list, world: World) -> tuple:
    """(materials, world) as the view layer renders them: with View Layer > Filter > Volumes (`use_volumes`) off,
    Cycles renders no media, so their volumes are dropped (the boundaries of volume-only materials stay invisible)."""
    if use_volumes:
        return materials, world
    return [dataclasses.replace(m, volume=[]) for m in materials], dataclasses.replace(world, volume=[])


def export_world(world, warnings: list, kernels: str = "compiled") -> World:
    """The core World of a Blender world (_export_world), with its Ray Visibility for bounces read (world_hidden):
    rays of a kind it hides from find nothing where they escape, and its light samples light no closure of that
    kind (no scattering point for Volume Scatter), as Cycles' SHADER_EXCLUDE_* flags; and its AOV Output nodes
    (World.aovs: what camera rays that escape write into the shader AOVs, core/integrators/passes.py)."""
    if world is not None:
        materials_.forget_alpha_reads(world)
    core = _export_world(world, warnings, kernels)
    aovs = materials_.aov_outputs(world, warnings, kind="world", kernels=kernels) if world is not None else []
    if aovs:
        core = dataclasses.replace(core, aovs=aovs)
    hidden = world_hidden(world)
    if hidden and core.lights:
        core = dataclasses.replace(core, hidden=hidden)
        for sun in core.suns:           # (a Sky Texture's sun disc is the world's light too)
            sun.hidden_from |= hidden
    return core


# The world's Ray Visibility switches (World > Settings > Ray Visibility, Cycles' world.cycles_visibility) other than
# Camera, and the bits of the bounces each hides the world from when off.
WORLD_RAY_VISIBILITY = (("diffuse", HIDDEN_FROM_DIFFUSE), ("glossy", HIDDEN_FROM_GLOSSY),
                        ("transmission", HIDDEN_FROM_TRANSMISSION), ("scatter", HIDDEN_FROM_VOLUME_SCATTER))


def world_hidden(world) -> int:
    """The HIDDEN_FROM_* bits of the bounces a Blender world hides from (its Ray Visibility, as Cycles' background
    shader's SHADER_EXCLUDE_* flags); 0 for none or no world."""
    visibility = getattr(world, "cycles_visibility", None)
    if visibility is None:
        return 0
    return sum(bit for name, bit in WORLD_RAY_VISIBILITY if not bool(getattr(visibility, name, True)))


def _export_world(world, warnings: list, kernels: str = "compiled") -> World:
    """Return the world as Cycles shows and uses it: its surface (world_surface) and the homogeneous medium of its
    Volume output, everywhere no mesh's medium is (core/volumes)."""
    surface = world_surface(world, warnings, kernels)
    if world is None or materials_.node_tree(world) is None:
        return surface
    tree = materials_.node_tree(world)
    output = materials_.output_node(tree, "ShaderNodeOutputWorld")
    volume = materials_.volume_of(world, output, warnings, kind="world")
    return dataclasses.replace(surface, volume=volume) if volume else surface


def world_surface(world, warnings: list, kernels: str = "compiled") -> World:
    """Return the world's surface as Cycles shows and uses it: its Background colour x strength, seen by camera
    rays (Ray Visibility > Camera) and lighting the scene where any bounce sees it (Diffuse, Glossy, Transmission or
    Volume Scatter: which ones, export_world).

    A world without nodes is its viewport colour (Cycles makes a Background of it); other world shaders
    than a plain Background colour are noted, and their viewport colour used.
    """
    if world is None:
        return World(color=np.zeros(3), camera=True, lights=False)
    visibility = getattr(world, "cycles_visibility", None)
    camera = visibility is None or bool(visibility.camera)
    # (it lights the scene where some kind of bounce sees it; export_world reads which: world_hidden)
    lights = world_hidden(world) != sum(bit for _, bit in WORLD_RAY_VISIBILITY)
    color = materials_.blender_float(np.array(world.color[:3], np.float64))
    seen = None                 # (a graph world's program, which camera rays evaluate per ray)
    tree = materials_.node_tree(world)
    if tree is not None:
        output = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output
                       and n.target in {"ALL", "CYCLES"}), None)
        if output is None or not output.inputs["Surface"].is_linked:
            return World(color=np.zeros(3), camera=True, lights=False)
        node = materials_.linked_node(output)
        environment = _environment(world, node, warnings) if node is not None else None
        if environment is not None:
            image, strength, rotation = environment
            if strength < 0.0:
                warnings.append(NEGATIVE_WORLD.format(strength))
                strength = 0.0
            if image is None:               # missing or unreadable (load_image said so): Cycles' magenta everywhere
                return World(color=np.array(MISSING_RGB) * strength, camera=camera, lights=lights)
            return World(color=np.zeros(3), image=image, strength=strength, rotation=rotation, camera=camera,
                         lights=lights)
        if node is None:
            return World(color=np.zeros(3), camera=True, lights=False)
        if node.bl_idname == "ShaderNodeBackground" and not node.inputs["Color"].is_linked \
                and not node.inputs["Strength"].is_linked:
            # (a NaN or infinite strength or colour: core/lights/world.py finite_world reads it as Cycles renders it)
            color = materials_.own_value(node.inputs["Color"]) * materials_.own_value(node.inputs["Strength"])
        elif not (camera or lights):
            return World(color=np.zeros(3), camera=False, lights=False)     # seen by no ray: nothing to evaluate
        else:
            baked, suns, seen, depths = _baked_world(world, output.inputs["Surface"], warnings, kernels)
            if isinstance(baked, np.ndarray) and baked.ndim == 3:
                return World(color=np.zeros(3), image=baked, strength=1.0, camera=camera, lights=lights, suns=suns,
                             seen=seen, samples_seen=depths and seen is not None)
            color = color if baked is None else baked
    if (color < 0.0).any():
        warnings.append(NEGATIVE_WORLD.format(float(color.min())))
        color = np.maximum(color, 0.0)
    return World(color=color, camera=camera, lights=lights, seen=seen)


def _baked_world(world, surface, warnings: list, kernels: str = "compiled"):
    """The world's shader with linked inputs, evaluated as Cycles does: (for its light samples, its colour (3,) where
    it does not vary with the direction, else its radiance baked into an equirectangular image (H, W, 3) float32
    (core/lights/world_graph.py bake, in C where `kernels` is "compiled"), or None, with a warning, for a world shader
    Primer does not read; the sun lamps of its Sky Textures' discs (sky_suns, left out of the bake and of the rays
    that escape); the program every ray that escapes evaluates with its path (World.seen), or None where they find
    the bake: a graph that varies or reads the Light Path node; whether the graph reads Light Path's depths, which
    the bake fixes at the first bounce: its light samples then run that program with their vertex's path
    (World.samples_seen), as Cycles evaluates the world's shader for each light sample)."""
    reader = materials_.NodeReader(world, warnings, kind="world", kernels=kernels)
    radiance = _socket_radiance(reader, surface)
    if radiance is None:
        return None, [], None, False
    if not isinstance(radiance, graph_.Link):
        return radiance, [], None, False
    suns, notes = world_graph.sky_suns(radiance, 1.0)
    warnings.extend(notes)
    program = world_graph.compile_world(radiance, 1.0)
    read = {link.output for link in graph_.links_under([(None, 1.0, {"radiance": radiance})])
            if link.node.kind == "LIGHT_PATH"}
    depths = bool(read - world_graph.EXACT_FOR_LIGHTING)   # (its light samples run `program` with their paths)
    baked = world_graph.bake(radiance, 1.0, kernels=kernels)
    flat = baked.reshape(-1, 3)
    constant = bool(np.isfinite(flat).all() and (flat == flat[0]).all() and not suns)
    seen = program if read or not constant else None
    if constant:                                      # the same everywhere: a constant world, not sampled as a light
        return flat[0].astype(np.float64), [], seen, depths
    if (flat < 0.0).any():
        warnings.append(NEGATIVE_WORLD.format(float(np.nanmin(flat))))
        baked = np.maximum(baked, np.float32(0.0))
    return baked, suns, seen, depths


def _socket_radiance(reader, socket):
    """The radiance a world's closure input `socket` (its output's Surface, a Mix or Add Shader's input) receives: a
    value, colour or vector linked there is an Emission, as Cycles converts it (a colour or vector its Color at
    Strength 1, a value its Strength of white), else its shader node's (_world_radiance); black where nothing is
    linked; None (warned) for a shader Primer does not read."""
    if materials_.auto_emission(socket):
        emission = materials_.auto_emission_of(reader, socket)
        return emission if isinstance(emission, graph_.Link) else np.asarray(emission, np.float64)[:3]
    inner = materials_.linked_node_of(socket)
    return np.zeros(3) if inner is None else _world_radiance(reader, inner)


def _world_radiance(reader, node):
    """The radiance a world shader node gives, as Cycles adds its closures up: a Background's (or Emission's)
    Color x Strength, a Mix Shader's (1 - Fac) A + Fac B (Fac clamped to [0, 1]), an Add Shader's A + B; a constant
    (3,) float64 where every input is one, else a graph.Link into a node tree that computes it; None (warned) for
    any other shader."""
    kind = node.bl_idname
    if kind in ("ShaderNodeBackground", "ShaderNodeEmission"):
        color, strength = reader.input(node, "Color", np.ones(3)), reader.input(node, "Strength", 1.0)
        if isinstance(color, graph_.Link) or isinstance(strength, graph_.Link):
            return graph_.Link(graph_.GraphNode("SCALE", {}, {"Color": color, "Factor": strength}, node.name), "Color")
        return np.asarray(color, np.float64)[:3] * float(strength)
    if kind in ("ShaderNodeMixShader", "ShaderNodeAddShader"):
        shaders = [socket for socket in node.inputs if socket.type == "SHADER"]
        parts = []
        for socket in shaders[:2]:
            part = _socket_radiance(reader, socket)
            if part is None:
                return None
            parts.append(part)
        factor = reader.input(node, "Fac", 0.5) if kind == "ShaderNodeMixShader" else 1.0
        if not any(isinstance(value, graph_.Link) for value in (*parts, factor)):
            t = float(np.clip(factor, 0.0, 1.0)) if kind == "ShaderNodeMixShader" else 1.0
            return (1.0 - t) * parts[0] + t * parts[1] if kind == "ShaderNodeMixShader" else parts[0] + parts[1]
        blend = "MIX" if kind == "ShaderNodeMixShader" else "ADD"
        props = {"data_type": "RGBA", "blend_type": blend, "clamp_factor": True, "clamp_result": False}
        return graph_.Link(graph_.GraphNode("MIX", props, {"Factor": factor, "A": parts[0], "B": parts[1]},
                                            node.name), "Result")
    reader.warnings.append(f"the world shader is a '{node.bl_label}' node, not a Background or a mix of them; Primer "
                           "uses the world's viewport colour")
    return None


def _kernels(scene) -> str:
    """The kernels `scene` renders with, "compiled" or "numpy" (Render > Kernels): its world's bake runs on them."""
    if getattr(scene, "primer", None) is None:
        return "compiled"
    return str(cycles_settings.effective(scene).kernels).lower()


def world_light_settings(world, core: World) -> World:
    """The core world with the Blender world's Cycles Max Bounces, Sampling (its importance map's size:
    core/lights/world.py map_size) and Shadows (Blender 5.2's: without them its light samples trace no shadow ray, as
    Cycles' background light without cast_shadow; its samples weighed as Cycles' one: vertex.mis_count)
    read into it."""
    cycles = getattr(world, "cycles", None)
    if cycles is None:
        return core
    environments, suns, guided = world_map_sources(world)
    size = lights_world.map_size(str(getattr(cycles, "sampling_method", "AUTOMATIC")),
                                 int(getattr(cycles, "sample_map_resolution", 1024)), environments, suns, guided)
    return dataclasses.replace(core, max_bounces=int(getattr(cycles, "max_bounces", 1024)), map_size=size,
                               cast_shadow=bool(getattr(cycles, "use_shadows", True)))


def world_map_sources(world) -> tuple:
    """What Cycles' Automatic world sampling sizes the map by, among the nodes that feed the world's Surface (inside
    node groups too): ([(width, height)] of its Environment Textures' images, the number of Sky Textures with a sun
    disc that read the plain direction, whether none reads another: its Vector unlinked or Texture Coordinate's
    Generated)."""
    tree = materials_.node_tree(world)
    output = None if tree is None else materials_.output_node(tree, "ShaderNodeOutputWorld")
    if output is None:
        return [], 0, True
    environments, suns, guided = [], 0, True
    for node in _feeding(output.inputs["Surface"]):
        if node.bl_idname == "ShaderNodeTexEnvironment" and node.image is not None:
            environments.append(tuple(int(n) for n in node.image.size[:2]))
        elif node.bl_idname == "ShaderNodeTexSky" and getattr(node, "sun_disc", False):
            vector = node.inputs.get("Vector")     # (Blender 5.0's Sky Texture has none: its mapping moves the sun)
            source = None if vector is None else materials_.linked_output_of(vector)
            if source is None or (source.node.bl_idname == "ShaderNodeTexCoord" and source.name == "Generated"):
                suns += 1
            else:
                guided = False
    return environments, suns, guided


def _feeding(socket, depth: int = 0) -> list:
    """The nodes whose outputs reach the input `socket`, each once: through reroutes, into node groups (from their
    Group Output) and out of them (a Group Input leads to the group node's inputs)."""
    found, seen, stack = [], set(), [(socket, ())]
    while stack:
        socket, groups = stack.pop()
        for link in socket.links if socket.is_linked else ():
            node = link.from_node
            key = (groups, node.name, getattr(node.id_data, "name", ""))
            if key in seen or link.is_muted:
                continue
            seen.add(key)
            found.append(node)
            if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and len(groups) < 32:
                outputs = [n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput"]
                inner = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
                stack.extend((s, groups + (node,)) for s in (inner.inputs if inner is not None else ()))
            elif node.bl_idname == "NodeGroupInput" and groups:
                stack.extend((s, groups[:-1]) for s in groups[-1].inputs)
            else:
                stack.extend((s, groups) for s in node.inputs)
    return found


# What Cycles shows for an image it cannot read (core/materials/textures.py MISSING): magenta.
MISSING_RGB = (1.0, 0.0, 1.0)

# Cycles shows a world of negative strength as black and lights nothing with it on its own (with lamps it
# takes some of their light away, and clamps); Primer reads it as 0.
NEGATIVE_WORLD = ("the world's Background is negative ({:g}); Primer reads it as 0: a black world that lights "
                  "nothing, as Cycles shows it (Cycles also subtracts it from the light of lamps)")


def _environment(world, background, warnings: list):
    """A Background of constant Strength showing an equirectangular Environment Texture at the direction (through
    nothing, a Texture Coordinate or a Mapping node's rotation alone), as (image (H, W, 3) float32 linear, or None
    where it is missing or cannot be read (a warning says so); strength, world-to-texture rotation (3, 3)): the
    image itself, rendered at its own resolution. None for any other world (`_baked_world` evaluates it)."""
    if background.bl_idname != "ShaderNodeBackground" or background.inputs["Strength"].is_linked:
        return None
    texture = materials_.linked_node_of(background.inputs["Color"])
    if texture is None or texture.bl_idname != "ShaderNodeTexEnvironment" or texture.outputs["Color"] not in \
            [link.from_socket for link in background.inputs["Color"].links]:
        return None
    if getattr(texture, "projection", "EQUIRECTANGULAR") != "EQUIRECTANGULAR":
        return None                                 # (a Mirror Ball: `_baked_world` evaluates it)
    mapping = getattr(texture, "texture_mapping", None)
    if mapping is not None and not materials_.identity_mapping(mapping):
        return None
    strength = materials_.own_value(background.inputs["Strength"])
    rotation = np.eye(3)
    source = materials_.linked_node_of(texture.inputs["Vector"])
    if source is not None:
        if source.bl_idname != "ShaderNodeMapping":
            return None
        angles = np.array(source.inputs["Rotation"].default_value[:3], np.float64)
        scale = np.array(source.inputs["Scale"].default_value[:3])
        coordinates = materials_.linked_node_of(source.inputs["Vector"])
        if any(source.inputs[name].is_linked for name in ("Location", "Rotation", "Scale")) \
                or not np.allclose(scale, 1.0) or getattr(source, "vector_type", "POINT") not in ("POINT", "VECTOR") \
                or coordinates is None or coordinates.bl_idname != "ShaderNodeTexCoord" \
                or not any(link.from_socket.name in ("Generated", "Object") for link in source.inputs["Vector"].links):
            return None
        rotation = _euler_xyz(angles)
    reader = materials_.NodeReader(world, warnings, kind="world")
    image = materials_.load_image(texture.image, reader, texture)
    if isinstance(image, textures_.TiledImage):
        # Cycles' Environment Texture has no tiles: it looks for the file named with the <UDIM> token itself.
        reader.warn(texture, f"image '{texture.image.name}' is a UDIM image, whose tiles an Environment Texture does "
                             "not read; Primer renders it magenta, as Cycles does")
        image = None
    if image is None:
        return None, strength, rotation
    pixels = image.rgba()[:, :, :3]
    if image.srgb:
        from ..core.film import image_io
        pixels = image_io.srgb_to_linear(pixels.astype(np.float64)).astype(np.float32)
    return np.ascontiguousarray(pixels), strength, rotation


def _euler_xyz(angles: np.ndarray) -> np.ndarray:
    """The rotation matrix of Blender's XYZ Euler angles (radians): Rz @ Ry @ Rx."""
    cx, cy, cz = np.cos(angles)
    sx, sy, sz = np.sin(angles)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def frame_size(render) -> tuple:
    """Return the (width, height) in pixels after the resolution percentage, as Blender computes it.

    Blender divides in integers: (resolution * percentage) // 100 (BKE_render_resolution).
    """
    percentage = int(render.resolution_percentage)
    return (max(1, int(render.resolution_x) * percentage // 100),
            max(1, int(render.resolution_y) * percentage // 100))


def border_rectangle(render, width: int, height: int) -> tuple:
    """Return the rendered rectangle (x, y, w, h) in pixels of the whole frame, y from the bottom.

    Blender truncates border * size, computed in float32, to whole pixels (render_init_from_main),
    with or without "crop to border". Its render result then covers exactly this rectangle, so an
    engine writes it with begin_result(0, 0, w, h): begin_result counts from the border's corner.
    """
    if not render.use_border:
        return 0, 0, width, height
    f = np.float32
    x0 = int(f(render.border_min_x) * f(width))
    x1 = int(f(render.border_max_x) * f(width))
    y0 = int(f(render.border_min_y) * f(height))
    y1 = int(f(render.border_max_y) * f(height))
    x0, x1 = max(0, min(x0, width)), max(0, min(x1, width))
    y0, y1 = max(0, min(y0, height)), max(0, min(y1, height))
    if x1 <= x0 or y1 <= y0:
        return 0, 0, width, height
    return x0, y0, x1 - x0, y1 - y0


def render_settings(scene, width: int, height: int, border: tuple, aux: tuple = (),
                    passes: tuple = ()) -> core_scene.RenderSettings:
    """Return core render settings from the scene's Primer settings and Blender's render settings.

    aux: the core buffers to compute (core.debug.AUX_BUFFERS), only those the passes and debug view need;
    passes: the render passes to compute (core/integrators/passes.py PASS_CHANNELS, lightpasses.py LIGHT_PASSES).
    """
    props = cycles_settings.effective(scene)        # a file made for Cycles: its Cycles settings
    render = scene.render
    x, y, w, h = border
    return core_scene.RenderSettings(
        width=width, height=height,
        samples=int(props.samples), seed=int(props.seed) + (scene.frame_current if props.animate_seed else 0),
        region=(x, height - (y + h), x + w, height - y),       # core counts rows from the top
        pixel_aspect=(float(render.pixel_aspect_x), float(render.pixel_aspect_y)),
        **pixel_filter(scene),
        exposure=film_exposure(scene),
        transparent_glass=transparent_glass(scene),
        light_samples=int(props.light_samples),
        shadow_method=props.shadow_method.lower(), epsilon=float(props.epsilon),
        terminator_fix=bool(props.terminator_fix),
        transparent_background=bool(render.film_transparent),
        threads=int(props.threads),
        instancing=props.instancing.lower(),
        kernels=props.kernels.lower(),
        aux=tuple(aux),
        smooth_normals=bool(props.smooth_normals),
        visibility_normal=props.visibility_normal.lower(),
        reduce_t_max=bool(props.reduce_t_max),
        distance_attenuation=bool(props.distance_attenuation),
        clamp_n_dot_l=bool(props.clamp_n_dot_l),
        shadow_rays_for_backfacing=bool(props.shadow_rays_for_backfacing),
        light_sampling=props.light_sampling.lower(),
        integrator=props.integrator.lower(),
        max_bounces=int(props.max_bounces), diffuse_bounces=int(props.diffuse_bounces),
        glossy_bounces=int(props.glossy_bounces), transmission_bounces=int(props.transmission_bounces),
        min_light_bounces=int(props.min_light_bounces), fresnel=props.fresnel.lower(),
        caustics_reflective=bool(props.caustics_reflective), caustics_refractive=bool(props.caustics_refractive),
        filter_glossy=float(props.filter_glossy),
        sample_clamp_direct=float(props.sample_clamp_direct), sample_clamp_indirect=float(props.sample_clamp_indirect),
        transparent_max_bounces=int(props.transparent_bounces), volume_bounces=int(props.volume_bounces),
        adaptive=bool(props.use_adaptive_sampling),
        adaptive_threshold=float(props.adaptive_threshold),
        adaptive_min_samples=int(props.adaptive_min_samples),
        denoising_features=bool(props.use_denoising),
        passes=tuple(passes),
        ao_distance=_ao_distance(scene),
        **_fast_gi(scene, props),
        **_mist(scene),
    )


def shadow_catcher_pass(view_layer) -> bool:
    """Whether `view_layer` writes Cycles' Shadow Catcher pass (view_layer.cycles.use_pass_shadow_catcher; Cycles then
    shows the shadow catchers' matte as Combined, not its approximation: core/integrators/catcher.py)."""
    return bool(getattr(getattr(view_layer, "cycles", None), "use_pass_shadow_catcher", False))


def pixel_filter(scene) -> dict:
    """Return the pixel filter Cycles renders `scene` with, as RenderSettings' pixel_filter and filter_width.

    Render > Film > Pixel Filter (scene.cycles.pixel_filter_type, filter_width), read as Cycles' Blender sync
    reads it: a Box is always 1 pixel wide, whatever the width says. (scene.render.filter_size is EEVEE's and
    Workbench's.) Without Cycles' settings, Cycles' defaults: Blackman-Harris, 1.5 pixels.
    """
    cycles = getattr(scene, "cycles", None)
    kind = str(getattr(cycles, "pixel_filter_type", "BLACKMAN_HARRIS"))
    width = 1.0 if kind == "BOX" else float(getattr(cycles, "filter_width", 1.5))
    return {"pixel_filter": kind, "filter_width": width}


def transparent_glass(scene) -> float:
    """Film > Transparent > Transparent Glass's Roughness Threshold (Cycles' film_transparent_glass,
    film_transparent_roughness) with a transparent film: core RenderSettings.transparent_glass; -1 where it is off."""
    cycles = getattr(scene, "cycles", None)
    if not scene.render.film_transparent or not getattr(cycles, "film_transparent_glass", False):
        return -1.0
    return min(max(float(getattr(cycles, "film_transparent_roughness", 0.1)), 0.0), 1.0)


def film_exposure(scene) -> float:
    """Render > Film > Exposure (scene.cycles.film_exposure), as the pixel filter always Cycles' film setting: the
    factor Cycles puts on Combined and the passes of light (core RenderSettings.exposure); 1 without Cycles."""
    exposure = float(getattr(getattr(scene, "cycles", None), "film_exposure", 1.0))
    return exposure if math.isfinite(exposure) and exposure >= 0.0 else 1.0


# World > Mist Pass > Falloff as Cycles' exponent (its sync: Quadratic 2, Linear 1, Inverse Quadratic 0.5).
MIST_FALLOFF = {"QUADRATIC": 2.0, "LINEAR": 1.0, "INVERSE_QUADRATIC": 0.5}


def _mist(scene) -> dict:
    """The Mist pass's settings (core RenderSettings mist_start, mist_depth, mist_falloff): the world's Mist Pass
    Start, Depth and Falloff, as Cycles syncs them; Cycles' own defaults (0, 100, linear) without a world."""
    settings = getattr(scene.world, "mist_settings", None) if scene.world is not None else None
    if settings is None:
        return {}
    return {"mist_start": float(settings.start), "mist_depth": float(settings.depth),
            "mist_falloff": MIST_FALLOFF.get(settings.falloff, 1.0)}


def object_culling(scene, camera):
    """Simplify > Culling as Cycles' sync reads it (blender/object_cull.cpp): a function (object, its (4, 4) world
    matrix) -> whether Cycles leaves that geometry object out (core/camera/culling.py), or None where nothing is
    culled: Simplify off, a panoramic camera, Stereoscopy on, or neither Camera nor Distance Culling on (a Distance
    Culling distance of 0 turns it off). Each object culls by the tests its own Culling flags ask for."""
    cycles = getattr(scene, "cycles", None)
    render = scene.render
    if (cycles is None or not render.use_simplify or camera.type not in ("PERSP", "ORTHO")
            or getattr(render, "use_multiview", False)):
        return None
    camera_cull = bool(getattr(cycles, "use_camera_cull", False))
    margin = float(getattr(cycles, "camera_cull_margin", 0.0))
    distance = float(getattr(cycles, "distance_cull_margin", 0.0))
    distance_cull = bool(getattr(cycles, "use_distance_cull", False)) and distance != 0.0
    if not camera_cull and not distance_cull:
        return None
    width, height = frame_size(render)
    aspect = (float(render.pixel_aspect_x), float(render.pixel_aspect_y))
    position = np.asarray(camera.matrix_world, np.float64)[:3, 3]

    def culled(obj, matrix) -> bool:
        flags = getattr(obj, "cycles", None)
        by_camera = camera_cull and bool(getattr(flags, "use_camera_cull", False))
        by_distance = distance_cull and bool(getattr(flags, "use_distance_cull", False))
        if not by_camera and not by_distance:
            return False
        corners = culling_.box_corners(np.array(obj.bound_box, np.float64), matrix)
        return culling_.culled(by_camera, by_distance,
                               by_camera and culling_.outside_view(camera, width, height, aspect, corners, margin),
                               by_distance and culling_.beyond_distance(position, corners, distance))
    return culled


def rendered_world(scene, view_layer, depsgraph=None):
    """The world `view_layer` renders, as Cycles picks it: its World Override (evaluated in `depsgraph`) where it has
    one, else the scene's; None (no light, no volume, black behind everything) where its Filter > Environment is off,
    as Cycles then gives the background its empty shader (measured: a world-lit scene black, alpha 1 on an opaque
    film). The Mist Pass and AO Distance are read from the scene's world."""
    if not getattr(view_layer, "use_sky", True):
        return None
    override = getattr(view_layer, "world_override", None)
    if override is None:
        return scene.world
    return override.evaluated_get(depsgraph) if depsgraph is not None else override


def _ao_distance(scene) -> float:
    """Return how far the Ambient Occlusion pass looks: the world's AO Distance (Cycles' ao_distance), else 10."""
    world = scene.world
    settings = getattr(world, "light_settings", None) if world is not None else None
    return float(getattr(settings, "distance", 10.0)) if settings is not None else 10.0


def _fast_gi(scene, props) -> dict:
    """Cycles' Fast GI Approximation (RenderSettings ao_bounces, ao_factor, ao_additive_factor), where the render
    follows the scene's Cycles settings (props: cycles_settings.Effective; Primer's own settings have no Fast GI, and
    unmodelled.fast_gi_notes says so): Replace, AO Bounces and the world's AO Factor; Add (RenderSettings
    ao_additive_factor), the world's AO Factor as the ambient occlusion each vertex adds. No world: factor 0, off, as
    Cycles' sync."""
    cycles = getattr(scene, "cycles", None)
    if not (getattr(props, "follows_cycles", False) and getattr(cycles, "use_fast_gi", False)):
        return {}
    settings = getattr(scene.world, "light_settings", None) if scene.world is not None else None
    factor = float(getattr(settings, "ao_factor", 0.0)) if settings is not None else 0.0
    if getattr(cycles, "fast_gi_method", "REPLACE") != "REPLACE":
        return dict(ao_additive_factor=factor)
    return dict(ao_bounces=int(getattr(cycles, "ao_bounces_render", 1)), ao_factor=factor)


# ----------------------------------------------------------------------------
# Meshes kept between frames
# ----------------------------------------------------------------------------

class MeshCache:
    """Exported meshes kept from one frame to the next by a render engine whose depsgraph Blender keeps
    (Render > Performance > Persistent Data).

    Blender keeps the evaluated mesh of an object whose geometry did not change between frames: the
    same datablock, same session_uid. An object whose geometry changed (deformed, new topology, a
    modifier or shape key animated) gets a new evaluated mesh, and the depsgraph's updates name it;
    either one is enough for the mesh to be read again. Every frame's scene is assembled afresh from
    these meshes in the order of the depsgraph's instances, so it is the scene a full export makes.
    """

    def __init__(self):
        self.meshes: dict = {}          # (session_uid, pointer) of an evaluated mesh -> (core Mesh, owner uids)
        self.used: set = set()          # keys used by the current export

    def begin(self, updates) -> None:
        """Start an export: forget the meshes of objects whose geometry the depsgraph's `updates` say changed."""
        changed = {update.id.original.session_uid for update in updates
                   if update.is_updated_geometry and update.id.id_type == "OBJECT"}
        self.meshes = {key: entry for key, entry in self.meshes.items() if not entry[1] & changed}
        self.used = set()

    def mesh(self, obj, read: list) -> core_scene.Mesh:
        """Return the core mesh of evaluated object `obj`, reading it (and naming the object in `read`)
        unless it is kept."""
        data, owner = obj.data, obj.original.session_uid
        key = (data.session_uid, data.as_pointer())
        entry = self.meshes.get(key)
        if entry is None:
            entry = self.meshes[key] = (_mesh_arrays(data), set())
            read.append(obj.name)
        entry[1].add(owner)
        self.used.add(key)
        return entry[0]

    def end(self) -> None:
        """End an export: drop the meshes it did not use (gone, or replaced by a new evaluation)."""
        self.meshes = {key: entry for key, entry in self.meshes.items() if key in self.used}


# ----------------------------------------------------------------------------
# The whole scene
# ----------------------------------------------------------------------------

def _terminator_offsets(obj) -> tuple:
    """Return Cycles' (geometry, shading) shadow-terminator offsets of an object (on obj.cycles before 4.3)."""
    for owner in (obj, getattr(obj, "cycles", None)):
        if owner is not None and hasattr(owner, "shadow_terminator_geometry_offset"):
            return (float(owner.shadow_terminator_geometry_offset),
                    float(getattr(owner, "shadow_terminator_shading_offset",
                                  getattr(owner, "shadow_terminator_offset", 0.0))))      # (4.2: its old name)
    return 0.1, 0.0


def _cycles_terminator(offsets: dict) -> bool:
    """Cycles' shadow terminator as Primer's switch: on where some smooth object has a Geometry Offset or some object a
    Shading Offset (each object then takes its own, core Instance.terminator_offset and terminator_shading), off where
    none has (the lecture's raw shadow rays are then Cycles'). offsets: object name -> (geometry, shading, smooth)."""
    return any((geometry > 0.0 and smooth) or shading > 0.0 for geometry, shading, smooth in offsets.values())


def _terminator_notes(offsets: dict, fix: bool) -> list:
    """Return warnings where Cycles' shadow terminator changes objects that Primer, with its Shadow Terminator Fix off,
    leaves raw (with the fix on every object takes its own offsets, as in Cycles).

    offsets: object name -> (geometry, shading, smooth) of each mesh object.
    """
    if fix:
        return []
    notes = []
    lifted = sorted(name for name, (geometry, _, smooth) in offsets.items() if geometry > 0.0 and smooth)
    bent = sorted(name for name, (_, shading, _) in offsets.items() if shading > 0.0)
    for names, what in ((lifted, "lifts shadow rays on smooth {} by a Shadow Terminator Geometry Offset"),
                        (bent, "bends the shading of {} by a Shadow Terminator Shading Offset")):
        if names:
            shown = ", ".join(f"'{name}'" for name in names[:3]) + (" and others" if len(names) > 3 else "")
            notes.append(f"Cycles {what.format(shown)}; Primer's Shadow Terminator Fix is off (the lecture's raw "
                         "shadow rays): turn it on to render as Cycles")
    return notes


def from_instancer(instance) -> dict:
    """An instance's Texture Coordinate From Instancer (core/scene Instance dupli_generated, dupli_uv): the point of
    its instancer it was placed at, as Cycles reads it (0.5 orco - 0.5, and the UV there); none for an object that is
    no instance."""
    if not instance.is_instance:
        return {}
    orco = np.array(instance.orco, np.float32)
    return {"dupli_generated": tuple((np.float32(0.5) * orco - np.float32(0.5)).astype(np.float64)),
            "dupli_uv": tuple(float(x) for x in instance.uv)}


def topmost_parent(obj):
    """Return the object at the top of `obj`'s parent chain (`obj` itself without a parent): Cryptomatte's asset."""
    seen = {obj.name}
    while obj.parent is not None and obj.parent.name not in seen:
        obj = obj.parent
        seen.add(obj.name)
    return obj


def shader_aovs(view_layer) -> tuple:
    """The view layer's shader AOVs Cycles writes: (name, "COLOR" or "VALUE") of each valid one, in order (Blender
    marks an AOV whose name another AOV or pass holds invalid; Cycles' sync skips it)."""
    return tuple((aov.name, aov.type) for aov in getattr(view_layer, "aovs", ())
                 if getattr(aov, "is_valid", True) and aov.name)


def export_scene(depsgraph, camera_override=None, is_cancelled=lambda: False, aux: tuple = (),
                 passes: tuple = (), mesh_cache: MeshCache = None) -> Export:
    """Return the evaluated depsgraph as a core scene plus render settings (computing the buffers `aux` and
    the first-hit render passes `passes`; the UV pass reads each mesh's active render UV map).

    mesh_cache: meshes kept from the engine's previous frame (MeshCache); only changed ones are read.
    Raises ExportError with a readable message when the scene cannot be rendered.
    """
    scene = depsgraph.scene_eval
    warnings: list[str] = []
    aov_names = {name for name, _ in shader_aovs(depsgraph.view_layer)}   # (what AOV Outputs read: only for these)
    camera_object = camera_override or scene.camera
    if camera_object is None:
        raise ExportError("the scene has no camera: add one, or set Scene > Camera")
    camera_eval = camera_object.evaluated_get(depsgraph)
    camera = export_camera(camera_eval, warnings)
    if not np.isfinite(np.asarray(camera.matrix_world)).all():
        raise ExportError(f"camera '{camera_object.name}' has an invalid (NaN or infinite) transform")
    final = depsgraph.mode == "RENDER"
    materials_.begin_export(scene.frame_current, depsgraph.view_layer, materials_.texture_limit_of(scene, final),
                            materials_.texture_resolution_of(scene, final), materials_.half_rounding_now())
    # What the scene asks of Cycles that Primer does not render, said once (addon/unmodelled.py).
    warnings += unmodelled.camera_notes(camera_object) + unmodelled.render_notes(scene)
    world_object = rendered_world(scene, depsgraph.view_layer, depsgraph)
    warnings += unmodelled.view_layer_notes(depsgraph.view_layer) + unmodelled.world_notes(world_object)
    holdouts = unmodelled.holdout_objects(depsgraph.view_layer)
    world = world_light_settings(world_object, export_world(world_object, warnings, _kernels(scene)))
    core = core_scene.Scene(camera=camera, world_color=world.color if world.camera else np.zeros(3), world=world,
                            default_material=DEFAULT_SURFACE)
    materials = MaterialTable()
    override = getattr(depsgraph.view_layer_eval, "material_override", None)
    mesh_index: dict = {}
    volume_spaces: dict = {}                   # material index -> its heterogeneous medium's space (note_volume_space)
    strands = bool(getattr(depsgraph.view_layer, "use_strand", True))   # (Filter > Strands: curves and hair)
    groups = {"lights": [], "instances": [], "world": lightgroups.source_group(world_object)}
    ray_visibility_noted: set = set()
    unsupported_noted: set = set()
    terminator_offsets: dict = {}
    meshes_read: list = []
    instance_keys: dict = {}
    if mesh_cache is not None:
        mesh_cache.begin(depsgraph.updates)

    links = linking.LinkSets.of(depsgraph)          # Light and Shadow Linking's sets (addon/linking.py)
    warnings.extend(links.notes)
    culled = object_culling(scene, camera)
    culled_names: list = []
    for instance in depsgraph.object_instances:
        if is_cancelled():
            break
        obj = instance.object
        matrix = np.array(instance.matrix_world, np.float64)
        if obj.name not in ray_visibility_noted:
            ray_visibility_noted.add(obj.name)
            warnings.extend(note for note in unmodelled.object_notes(obj)
                            + (unmodelled.light_notes(obj) if obj.type == "LIGHT" else []) if note not in warnings)
        if obj.type == "LIGHT":
            light = export_light(obj, matrix, warnings, instance)
            if light is not None:
                core.lights.append(links.lamp(light, obj))
                groups["lights"].append(lightgroups.source_group(obj))
            continue
        if culled is not None and culled(obj, matrix):      # Simplify > Culling: left out, as Cycles does
            culled_names.append(obj.name)
            continue
        if obj.type == "MESH" and not instance.is_instance and instance.show_particles and strands:
            for system in rendered_hair(obj):       # particle hair: tubes placed with their emitter
                hair = particle_hair_mesh(obj, system, depsgraph.mode == "RENDER", matrix, warnings,
                                          curve_shape(scene, f"object '{obj.name}' hair '{system.name}'", warnings))
                if hair is not None:
                    slots = materials.slot_map(obj, warnings, override)
                    curve_attributes(hair, set().union(*(graph_.attributes_of(materials.materials[slot].nodes)
                                                         for slot in slots[slots >= 0].tolist())))
                    core.meshes.append(hair)
                    instance_keys[len(core.instances)] = motion.placement_key(instance)   # (it moves with its emitter)
                    core.instances.append(core_scene.Instance(
                        len(core.meshes) - 1, matrix, materials.slot_map(obj, warnings, override), obj.name,
                        None, int(getattr(obj, "pass_index", 0)), **instance_keywords(obj),
                        asset=topmost_parent(obj).name, **links.of_object(obj),
                        attributes=materials_.object_attributes(instance)))
                    groups["instances"].append(lightgroups.source_group(obj))
        if not instance.show_self:
            continue                    # e.g. a particle emitter that is not rendered itself
        if obj.type == "VOLUME":                    # OpenVDB grids: a medium in Cycles' box of them (addon/vdb.py)
            slots = materials.slot_map(obj, warnings, override)
            made = vdb.volume_object(obj, matrix, slots, materials.materials, warnings)
            if made is not None:
                core.meshes.append(made[0])
                instance_keys[len(core.instances)] = motion.placement_key(instance)
                random = graph_.random_from_id(instance.random_id) if instance.is_instance else None
                core.instances.append(core_scene.Instance(len(core.meshes) - 1, matrix, made[1], obj.name, random,
                                                          int(getattr(obj, "pass_index", 0)), **instance_keywords(obj),
                                                          asset=topmost_parent(obj).name, color=tuple(obj.color),
                                                          **links.of_object(obj)))
                groups["instances"].append(lightgroups.source_group(obj))
            continue
        if obj.type in UNSUPPORTED_GEOMETRY:
            if obj.name not in unsupported_noted:
                unsupported_noted.add(obj.name)
                warnings.append(f"object '{obj.name}' is of type {obj.type}, which Primer does not render")
            continue
        if obj.type not in ("MESH", "CURVES", "POINTCLOUD") or obj.data is None or obj.type == "CURVES" and not strands:
            continue
        # A mesh shared by several instances is exported once (keyed by its evaluated data): linked
        # duplicates, collection and geometry-nodes instances share it; modifiers make a mesh of its own.
        key = obj.data.as_pointer()
        if key not in mesh_index:
            if obj.type == "CURVES":                # hair curves: tubes (core/geometry/curves.py)
                mesh = curves_mesh(obj.data, scene, warnings)
            elif obj.type == "POINTCLOUD":          # points: spheres (core/geometry/points.py)
                mesh = points_mesh(obj.data, warnings)
            elif mesh_cache is not None:
                mesh = mesh_cache.mesh(obj, meshes_read)
            else:
                mesh = _mesh_arrays(obj.data)
                meshes_read.append(obj.name)
            if len(mesh.triangles) == 0:
                mesh_index[key] = None
                continue
            core.meshes.append(mesh)
            mesh_index[key] = len(core.meshes) - 1
        if mesh_index[key] is None:
            continue
        if obj.name not in terminator_offsets and obj.type == "MESH":
            terminator_offsets[obj.name] = (*_terminator_offsets(obj), bool(core.meshes[mesh_index[key]].smooth.any()))
        slots = materials.slot_map(obj, warnings, override)
        texspace = note_volume_space(obj, matrix, slots, materials.materials, volume_spaces)
        # The attributes its materials' node graphs read, and Cycles' random number of an instance.
        wanted = set()
        for slot in slots[slots >= 0].tolist():
            material = materials.materials[slot]
            wanted |= graph_.attributes_of(graph_.with_normal(material.nodes, material.normal, material.displacement,
                                                              [a for a in material.aovs if a[0] in aov_names]))
        if "uv" in passes and len(obj.data.uv_layers):
            wanted.add("uv:")
        if wanted and obj.type != "MESH":
            wanted = curve_attributes(core.meshes[mesh_index[key]], wanted)
            if wanted:
                warnings.append(f"object '{obj.name}': its materials read {', '.join(sorted(wanted))}, which Primer "
                                f"does not carry on {obj.type.lower()} objects; they read 0")
        elif wanted:
            mesh_attributes(obj.data, core.meshes[mesh_index[key]], wanted, warnings)
        random = graph_.random_from_id(instance.random_id) if instance.is_instance else None
        visibility = instance_keywords(obj)       # (a Holdout collection makes its objects holdouts, as in Cycles)
        visibility["is_holdout"] |= obj.name in holdouts
        if instance.is_instance and instance.parent is not None:     # (Cycles: the object's or its instancer's)
            visibility["is_shadow_catcher"] |= bool(getattr(instance.parent, "is_shadow_catcher", False))
        if not visibility["is_holdout"] and indirect_only(instance, depsgraph.view_layer):
            visibility["visible_camera"] = False  # (an Indirect Only collection: Cycles clears camera visibility)
        instance_keys[len(core.instances)] = motion.placement_key(instance)
        core.instances.append(core_scene.Instance(mesh_index[key], matrix, slots, obj.name, random,
                                                  int(getattr(obj, "pass_index", 0)), **visibility,
                                                  asset=topmost_parent(obj).name, color=tuple(obj.color),
                                                  **links.of_object(obj),
                                                  attributes=materials_.object_attributes(instance),
                                                  texspace=texspace, **from_instancer(instance)))
        groups["instances"].append(lightgroups.source_group(obj))

    if mesh_cache is not None:
        mesh_cache.end()
    core.instance_attributes = list(materials_.INSTANCE_ATTRIBUTES)   # (the columns of Instance.attributes)
    warnings.extend(note for note in materials_.ATTRIBUTE_NOTES if note not in warnings)
    core.materials, core.world = media_of_layer(bool(getattr(depsgraph.view_layer, "use_volumes", True)),
                                                [dataclasses.replace(m, volume_space=volume_spaces[i])
                                                 if i in volume_spaces else m
                                                 for i, m in enumerate(materials.materials)], core.world)
    lamps = len(core.lights)
    if world.lights:                    # a Sky Texture's sun disc, a lamp of the world's (in the world's light group)
        for sun in world.suns:          # (seen where the world is: not on a transparent film, unlike a sun lamp)
            sun.camera = world.camera and not scene.render.film_transparent
            sun.cast_shadow = world.cast_shadow         # (Cycles' sun is its background light's: the world's Shadows)
            core.lights.append(sun)
            groups["lights"].append(groups["world"])
    world_lights = world.lights and (world.image is not None or float(np.max(world.color)) > 0.0
                                     or world.seen is not None)     # (a graph: the rays that escape evaluate it)
    emits = any(float(np.max(m.emission)) > 0.0 or m.nodes for m in core.materials)
    if not core.lights and not world_lights and not emits:
        warnings.append("the scene has no lights: only the world colour will be visible")
    warnings += unmodelled.shadowless_world_notes(world.cast_shadow, world.lights and world.image is not None,
                                                  lamps > 0 or emits)
    width, height = frame_size(scene.render)
    border = border_rectangle(scene.render, width, height)
    settings = render_settings(scene, width, height, border, aux, passes)
    settings.cryptomatte_depth = int(getattr(depsgraph.view_layer, "pass_cryptomatte_depth", 6))
    # (View Layer > Passes > Data > Alpha Threshold: the first surface that opaque holds the data passes)
    settings.pass_alpha_threshold = float(getattr(depsgraph.view_layer, "pass_alpha_threshold", 0.5))
    settings.light_groups = tuple(lightgroups.group_names(depsgraph.view_layer))
    # (View Layer > Passes > Shader AOV: what the materials' AOV Output nodes write, core/integrators/passes.py)
    settings.aovs = shader_aovs(depsgraph.view_layer)
    # (View Layer > Passes > Light > Shadow Catcher: the pass, and Combined as the catchers' matte itself)
    settings.shadow_catcher_pass = shadow_catcher_pass(depsgraph.view_layer)
    core.lightgroups = groups
    follows = cycles_settings.effective(scene).follows_cycles
    if follows:                                     # a file made for Cycles: Cycles' terminator, as its objects ask
        settings.terminator_fix = _cycles_terminator(terminator_offsets)
    warnings += _terminator_notes(terminator_offsets, settings.terminator_fix)
    for group in lightgroups.empty_groups(settings.light_groups, groups):
        warnings.append(f"light group '{group}' has no light, emissive object or world in it: its pass is black")
    return Export(core, settings, (width, height), border, warnings, meshes_read, instance_keys, culled_names)
