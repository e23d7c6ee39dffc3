"""True displacement: a material's Displacement output moves its mesh's vertices, as Cycles does it.

Cycles' Displacement Method *Displacement Only* (and *Displacement and Bump*) runs the material's displacement
graph once per vertex before the BVH is built (Cycles' `GeometryManager::displace`): each vertex is shaded at the
corner of the first triangle that uses it (in triangle order), and the world-space offset the Displacement output
gives there is turned into object space and added to the vertex. There is no subdivision: the mesh moves only at
its own vertices. Displacement Only then recomputes the smooth normals of its triangles from the moved faces (the
unweighted sum of their unit normals); Displacement and Bump keeps the mesh's normals, for its bump already bends
them, and keeps the corners and normals from before the move (attributes undisplaced_position and
undisplaced_normal, object space) for its bump, which Cycles evaluates over the surface before it moved. A mesh
placed by several objects is displaced once, with the first object's transform, as in Cycles.

The graph runs in the numpy reference (`graph.run`): once per mesh and material at scene set-up, not per sample.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .. import vectors
from ..materials import graph as graph_
from ..materials import textures as textures_
from ..lights.world_graph import register_number
from ..scene import Mesh, Scene
from . import normals as normals_


def displaced(scene: Scene, warnings: list) -> Scene:
    """The scene with each mesh whose materials displace moved as Cycles moves it (a copy of the scene and of the
    meshes it changes; the scene itself if none displaces)."""
    if not any(getattr(material, "displacement", None) is not None for material in scene.materials):
        return scene
    first_user = {}
    for instance in scene.instances:
        first_user.setdefault(instance.mesh, instance)
    meshes = list(scene.meshes)
    for index, instance in first_user.items():
        if 0 <= index < len(meshes):
            meshes[index] = displace_mesh(meshes[index], instance, scene.materials, warnings)
    return dataclasses.replace(scene, meshes=meshes)


def displace_mesh(mesh: Mesh, instance, materials: list, warnings: list) -> Mesh:
    """`mesh` moved by the displacement of its triangles' materials (as placed by `instance`), or `mesh` itself.

    1. Which triangles displace, and by which material's graph.
    2. Each vertex once, at the corner of the first displacing triangle that uses it.
    3. The offsets from the graphs, world space to object space, NaN and infinities as 0 (Cycles' ensure_finite).
    4. Displacement Only: the smooth normals of its triangles again, from the moved faces.
    5. Displacement and Bump: the corners and normals before the move kept as attributes, for the bump.
    """
    # 1. The scene material of each triangle.
    slots = mesh.material_indices
    if instance.materials is not None:
        table = np.asarray(instance.materials, np.int64)
        scene_index = np.where((slots >= 0) & (slots < len(table)), table[np.clip(slots, 0, max(len(table) - 1, 0))],
                               -1) if len(table) else np.full(len(slots), -1)
    else:
        scene_index = slots
    valid = (scene_index >= 0) & (scene_index < len(materials))
    graphs = {k: materials[k] for k in np.unique(scene_index[valid])
              if getattr(materials[k], "displacement", None) is not None}
    if not graphs or len(mesh.triangles) == 0:
        return mesh
    moves = valid & np.isin(scene_index, list(graphs))
    # 2. Each vertex at its first displacing corner.
    rows = np.flatnonzero(moves)
    corners = mesh.triangles[rows].reshape(-1)
    vertex, first = np.unique(corners, return_index=True)
    triangle, corner = rows[first // 3], first % 3
    # 3. Offsets per material.
    offsets = np.zeros((len(vertex), 3))
    matrix = np.asarray(instance.matrix, np.float64)
    from .geometry import attribute_table                        # (geometry imports this module)
    table, layout, _ = attribute_table([mesh])
    for k, material in graphs.items():
        mine = scene_index[triangle] == k
        if mine.any():
            offsets[mine] = world_offsets(mesh, instance, material, (table, layout), triangle[mine], corner[mine],
                                          warnings)
    linear = matrix[:3, :3]
    try:
        to_object = np.linalg.inv(linear)
    except np.linalg.LinAlgError:
        return mesh
    offsets = np.nan_to_num(offsets @ to_object.T, nan=0.0, posinf=0.0, neginf=0.0)
    vertices = mesh.vertices.copy()
    vertices[vertex] += offsets
    # 4. Displacement Only: normals from the moved faces (Displacement and Bump keeps the mesh's).
    corner_normals = mesh.corner_normals
    renormal = moves & np.isin(scene_index, [k for k, m in graphs.items() if m.displacement_method == "DISPLACEMENT"])
    if renormal.any():
        corner_normals = (object_corner_normals(mesh) if corner_normals is None
                          else np.array(corner_normals, np.float64))        # (a copy, float32 ones widened)
        triangles = mesh.triangles[renormal]
        faces = normals_.face_normals(vertices, triangles).normals
        summed = np.zeros((len(vertices), 3))
        for j in range(3):
            np.add.at(summed, triangles[:, j], faces)
        unit = normals_.safe_normalize(summed)
        smooth = renormal & mesh.smooth
        corner_normals[smooth] = unit[mesh.triangles[smooth]]
    # 5. Displacement and Bump: the corners before they moved, and their normals, for the bump (Cycles'
    # ATTR_STD_POSITION_UNDISPLACED and ATTR_STD_NORMAL_UNDISPLACED; graph.undisplaced_point).
    attributes = mesh.attributes
    if any(m.displacement_method == "BOTH" for m in graphs.values()):
        before = (np.asarray(mesh.corner_normals, np.float64) if mesh.corner_normals is not None
                  else object_corner_normals(mesh))
        attributes = {**(mesh.attributes or {}), "undisplaced_position": mesh.vertices[mesh.triangles],
                      "undisplaced_normal": before}
    return dataclasses.replace(mesh, vertices=vertices, corner_normals=corner_normals, attributes=attributes)


def object_corner_normals(mesh: Mesh) -> np.ndarray:
    """The mesh's corner normals (t, 3, 3) float64 in object space as rendered where it gives none: angle-weighted
    vertex normals (as geometry.build_geometry derives them)."""
    with np.errstate(invalid="ignore", over="ignore"):
        per_vertex = normals_.vertex_normals(mesh.vertices, mesh.triangles, weighting="angle")
    return per_vertex[mesh.triangles]


def world_offsets(mesh: Mesh, instance, material, attributes: tuple, triangle: np.ndarray, corner: np.ndarray,
                  warnings: list) -> np.ndarray:
    """The material's Displacement output (n, 3) float64 in world space at corners `corner` (n,) of triangles
    `triangle` (n,) of `mesh` placed by `instance`, whose attributes are `attributes` (geometry.attribute_table's
    table and layout): the graph run at each, as Cycles shades a vertex to displace it (shader_setup_from_displace:
    no ray, the view along the normal, no footprint)."""
    from .geometry import instance_info                          # (geometry imports this module)
    table, layout = attributes
    nodes = [(None, 1.0, {"displacement": material.displacement})]
    images = graph_.images_of(nodes)
    index = {id(image): k for k, image in enumerate(images) if image is not None}
    compiler = graph_.Compiler(layout, lambda image: index.get(id(image), -1), warnings, material.name)
    register = compiler.value(material.displacement, 3, 0.0)
    program = compiler.compile([])
    register = register_number(compiler, register)
    textures = textures_.TextureSet.of([image for image in images if image is not None])
    sp = corner_point(mesh, instance, table, triangle, corner, instance_info)
    values = graph_.run(program, sp, textures)
    return np.asarray(values[:, register:register + 3], np.float64)


def corner_point(mesh: Mesh, instance, table, triangle: np.ndarray, corner: np.ndarray, instance_info):
    """The graph.ShadingPoint of n triangle corners in world space (Cycles' displacement shading point: P the
    vertex, N its smooth normal on a smooth triangle else the face's, the view along N, barycentrics of the corner,
    no differentials)."""
    n = len(triangle)
    matrix = np.asarray(instance.matrix, np.float64)
    linear = matrix[:3, :3]
    normal_matrix = np.linalg.inv(linear).T
    corners = mesh.vertices[mesh.triangles[triangle]]                          # (n, 3, 3) object space
    P = corners[np.arange(n), corner] @ linear.T + matrix[:3, 3]
    dPdu = (corners[:, 1] - corners[:, 0]) @ linear.T
    dPdv = (corners[:, 2] - corners[:, 0]) @ linear.T
    Ng = normals_.safe_normalize(np.cross(dPdu, dPdv))
    if vectors.determinant(linear[None])[0] < 0.0:
        Ng = -Ng
    smooth_normals = np.asarray((mesh.corner_normals if mesh.corner_normals is not None
                                 else object_corner_normals(mesh))[triangle, corner], np.float64)
    N = np.where(mesh.smooth[triangle][:, None], normals_.safe_normalize(smooth_normals @ normal_matrix.T), Ng)
    uv = np.zeros((n, 2))
    uv[corner == 1, 0] = 1.0
    uv[corner == 2, 1] = 1.0
    width = 0 if table is None else table.shape[2]
    attributes = (np.zeros((n, 0)) if table is None
                  else np.asarray(table[triangle, corner], np.float64))
    random = instance.random if instance.random is not None else graph_.object_random(instance.name)
    info = instance_info([instance], matrix[None])
    return graph_.ShadingPoint(
        attributes=attributes, d_du=np.zeros((n, width)), d_dv=np.zeros((n, width)),
        random=np.full(n, float(random)), N=N, side=np.ones(n), linear=np.broadcast_to(linear, (n, 3, 3)).copy(),
        dPdu=dPdu, dPdv=dPdv, Ng=Ng, path=graph_.light_paths(n, flags=0), I=N.copy(), P=P, uv=uv,
        t=np.zeros(n), info=np.repeat(info, n, axis=0))
