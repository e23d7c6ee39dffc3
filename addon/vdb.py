"""Volume objects (OpenVDB grids) as Cycles renders them: a heterogeneous medium reading the grids, in a box mesh.

The grids are read from the Volume's file (its current frame's, `grids.frame_filepath`) with the OpenVDB module that
ships inside Blender (`openvdb`, older Blenders' `pyopenvdb`; bpy-as-a-module keeps it under its own python folder,
which is put on sys.path), into core/volumes/grids.py `Grid`s: the values over the box of the active voxels (after
the Volume's Render > Clipping), rounded to half floats where Render > Precision is Half (Cycles' Fp16 grids). Only
the grids the material reads are loaded, as Cycles does (the Attribute nodes' names, Volume Info's outputs, the
Principled Volume's Density, Color and Temperature Attributes), and Cycles' bounding mesh is made of them
(grids.bounding_box), sampled as the material's Volume > Interpolation asks (Linear: trilinear; Cubic: Cycles'
tricubic B-spline). The Principled Volume's attributes multiply its Density, Color and Temperature (Cycles'
svm_node_principled_volume: density * grid, color * grid, temperature * max(grid, 0)); Render > Space Object scales
every closure's weight by 1 / |M (1, 1, 1) / sqrt 3| (Cycles' object_volume_density).
"""
from __future__ import annotations

import dataclasses
import glob
import math
import os
import sys

import numpy as np

from ..core.geometry import primitives
from ..core.materials import graph as graph_
from ..core.volumes import grids as grids_

_MODULE: list = []          # [the openvdb module, or None], found once
# The most grids of one Volume Primer reads (each takes 4 of the volume point's MAX_ATTRIBUTES floats).
MAX_GRIDS = 8


def _imported(names: tuple):
    """The first of the modules `names` that imports, or None."""
    for name in names:
        try:
            return __import__(name)
        except ImportError:
            pass
    return None


def openvdb_module():
    """The OpenVDB Python module Blender ships (openvdb or pyopenvdb), or None when this Blender has none."""
    if _MODULE:
        return _MODULE[0]
    found = _imported(("openvdb", "pyopenvdb"))
    if found is None:
        import bpy
        here = os.path.dirname(os.path.abspath(bpy.__file__))
        for _ in range(6):                       # (bpy-as-a-module: <bpy>/<version>/python/lib/python3.x/site-packages)
            for folder in sorted(glob.glob(os.path.join(here, "*", "python", "lib", "python3.*", "site-packages"))
                                 + glob.glob(os.path.join(here, "python", "lib", "python3.*", "site-packages"))):
                if glob.glob(os.path.join(folder, "*openvdb*")) and folder not in sys.path:
                    sys.path.append(folder)
            here = os.path.dirname(here)
        found = _imported(("openvdb", "pyopenvdb"))
    _MODULE.append(found)
    return found


def grid_names(entries: list) -> set:
    """The grid names a material's volume closures [(name, weight, inputs)] read: Attribute nodes' names, Volume
    Info's outputs, the Principled Volume's attributes."""
    nodes = [(name, weight, {k: v for k, v in inputs.items() if k != "factors"}, inputs.get("factors", ()))
             for name, weight, inputs in entries]
    names = {n.split(":", 1)[1] for n in graph_.attributes_of(nodes) if n.startswith("attr:")}
    names |= {link.output.lower() for link in graph_.links_under(nodes) if link.node.kind == "VOLUME_INFO"}
    for name, _, inputs in entries:
        if name == "PRINCIPLED_VOLUME":
            names |= {inputs.get(k, "") for k in ("density_attribute", "color_attribute", "temperature_attribute")}
    names.discard("")
    return names


def with_grids(entries: list, names: set, scale: float) -> list:
    """The closures [(name, weight, inputs)] of a Volume object: each weight times `scale` (Render > Space), and a
    Principled Volume's Density, Color and Temperature multiplied by its attributes' grids among `names`."""
    out = []
    for name, weight, inputs in entries:
        inputs = dict(inputs)
        if name == "PRINCIPLED_VOLUME":
            grid = inputs.get("density_attribute", "")
            if grid in names:
                fac = graph_.Link(graph_.GraphNode("ATTRIBUTE", {"attribute": "grid:" + grid}), "Fac")
                inputs["density"] = graph_.Link(graph_.GraphNode(
                    "MATH", {"operation": "MULTIPLY"}, {"0": inputs.get("density", 1.0), "1": fac}), "Value")
            grid = inputs.get("color_attribute", "")
            if grid in names:
                color = graph_.Link(graph_.GraphNode("ATTRIBUTE", {"attribute": "grid:" + grid}), "Color")
                inputs["color"] = graph_.Link(graph_.GraphNode(         # (a Mix Multiply of factor 1: A x B)
                    "MIX", {"data_type": "RGBA", "blend_type": "MULTIPLY"},
                    {"Factor": 1.0, "A": inputs.get("color", 0.5), "B": color}), "Result")
            grid = inputs.get("temperature_attribute", "")
            if grid in names:                   # (looked up stochastically by Cycles: field.closure_at's voxels)
                inputs["temperature_grid"] = grid
        out.append((name, float(weight) * scale, inputs))
    return out


def _read_grid(grid, clipping: float, half: bool, warnings: list, where: str):
    """One OpenVDB grid as (a grids.Grid over the box of its active voxels, the box (low, high) of its voxels left
    active by `clipping` in the Grid's index, its downsampling factor), downsampled when its box holds more than
    grids.MAX_VOXELS values; None when empty or of a type Cycles does not read."""
    kind = grid.valueTypeName
    channels = {"float": 1, "double": 1, "int32": 1, "int64": 1, "bool": 1,
                "vec3s": 3, "vec3d": 3, "vec3i": 3}.get(kind)
    if channels is None:
        warnings.append(f"{where}: grid '{grid.name}' of type {kind} is not read (Cycles reads float and vector grids)")
        return None
    low, high = (np.array(c, np.int64) for c in grid.evalActiveVoxelBoundingBox())
    if (high < low).any() or grid.activeVoxelCount() == 0:
        return None
    dims = high - low + 1
    factor = max(1, math.ceil((float(np.prod(dims)) * channels / grids_.MAX_VOXELS) ** (1.0 / 3.0)))
    if factor > 1:
        warnings.append(f"{where}: grid '{grid.name}' has {int(np.prod(dims))} voxels in its box; Primer keeps at "
                        f"most {grids_.MAX_VOXELS} values of a grid and renders it averaged over {factor}^3 voxels")
    slabs, step = [], factor * max(1, (1 << 22) // int(dims[1] * dims[2] * channels * factor))
    dtype = np.float32 if kind in ("float", "vec3s") else (np.float64 if kind.startswith(("double", "vec3d"))
                                                           else np.int64 if "64" in kind else np.int32)
    for x in range(0, int(dims[0]), step):                  # (slab by slab: the whole box is never in memory)
        width = min(step, int(dims[0]) - x)
        slab = np.zeros((width, int(dims[1]), int(dims[2])) + ((3,) if channels == 3 else ()),
                        bool if kind == "bool" else dtype)
        grid.copyToArray(slab, ijk=(int(low[0]) + x, int(low[1]), int(low[2])))
        slab = slab.astype(np.float32).reshape(width, int(dims[1]), int(dims[2]), channels)
        slabs.append(grids_.downsample(slab, factor) if factor > 1 else slab)
    values = np.concatenate(slabs, axis=0)
    if half and channels == 1:
        values = values.astype(np.float16).astype(np.float32)
    box = grids_.active_box(values, clipping) if clipping > 0.0 else (np.zeros(3, np.int64),
                                                                      np.array(values.shape[:3]) - 1)
    if box is None:
        return None
    # Index to object: the grid's transform, an affine map (its images of the index origin and axes).
    origin = np.array(grid.transform.indexToWorld((0.0, 0.0, 0.0)), np.float64)
    axes = np.array([np.array(grid.transform.indexToWorld(tuple(e)), np.float64) - origin for e in np.eye(3)]).T
    to_index = np.linalg.inv(np.vstack([np.hstack([axes, origin[:, None]]), [0.0, 0.0, 0.0, 1.0]]))[:3]
    # Object space to the array's index: fine index i = low + factor J + (factor - 1) / 2 at coarse voxel J's centre.
    to_index[:, 3] -= low + (factor - 1) / 2.0
    return grids_.Grid(grid.name, values, np.zeros(3), to_index / factor), box, factor


def volume_object(obj, matrix: np.ndarray, slots: np.ndarray, materials: list, warnings: list):
    """A Volume object as Cycles renders it: (the bounding core Mesh in object space, its slots (k,) int64: all the
    new row of `materials` appended for it, its first volume material with the grids), or
    None (said in `warnings`) when Primer cannot render it."""
    import bpy
    where = f"Volume object '{obj.name}'"
    vdb = openvdb_module()
    if vdb is None:
        warnings.append(f"{where}: this Blender ships no OpenVDB Python module (openvdb), so Primer cannot read its "
                        "grids; it is not rendered")
        return None
    volume = obj.data
    rows = [int(s) for s in slots.tolist() if s >= 0 and materials[int(s)].volume]
    if not rows:
        return None                             # (Cycles: no volume shader, no mesh)
    row = rows[0]
    material = materials[row]
    try:
        path = volume.grids.frame_filepath if volume.grids.frame_filepath else volume.filepath
    except AttributeError:
        path = volume.filepath
    path = bpy.path.abspath(path) if path else ""
    if not path or not os.path.isfile(path):
        warnings.append(f"{where}: its grids are not in a file Primer can read ({path or 'none'}: generated or "
                        "missing); it is not rendered")
        return None
    if any(m.show_render for m in getattr(obj, "modifiers", ())):
        warnings.append(f"{where}: its modifiers are not applied; Primer reads the grids of its file")
    names = grid_names(material.volume)
    render = volume.render
    clipping, half = float(render.clipping), render.precision == "HALF"
    if render.precision == "VARIABLE":
        warnings.append(f"{where}: Render > Precision Variable is read at full precision (Cycles quantizes)")
    source = bpy.data.materials.get(material.name)
    interpolation = getattr(getattr(source, "cycles", None), "volume_interpolation", "LINEAR")
    pad = 2 if interpolation == "CUBIC" else 1
    try:                                        # (the grids' names first: only the wanted grids are read whole)
        found = [grid.name for grid in vdb.readAllGridMetadata(path)]
    except Exception as error:                  # (a file OpenVDB refuses)
        warnings.append(f"{where}: OpenVDB cannot read {path} ({error}); it is not rendered")
        return None
    velocity = {getattr(volume, key, "") for key in ("velocity_grid", "velocity_x_grid", "velocity_y_grid",
                                                      "velocity_z_grid")} - {""}
    if bpy.context.scene.render.use_motion_blur and velocity & set(found):
        warnings.append(f"{where}: its velocity grid's motion blur is not modelled; Primer renders it still")
    read, first, boxes = [], None, []
    if len(names & set(found)) > MAX_GRIDS:
        warnings.append(f"{where}: its material reads {len(names & set(found))} grids; Primer reads the first "
                        f"{MAX_GRIDS} of its file, the others read 0")
    for name in found:
        if name not in names or len(read) >= MAX_GRIDS:
            continue
        got = _read_grid(vdb.read(path, name), clipping, half, warnings, where)
        if got is None:
            continue
        grid_, (low, high), factor = got
        grid_ = grid_._replace(cubic=interpolation == "CUBIC")      # (the material's Volume > Interpolation)
        read.append(grid_)
        corners = grids_.bounding_box(low, high, max(1, math.ceil(pad / factor)) if pad else 0)
        # (the box's corners in object space: index (coarse) -> object)
        fine = np.linalg.inv(np.vstack([grid_.to_index, [0.0, 0.0, 0.0, 1.0]]))[:3]
        boxes.append(corners @ fine[:, :3].T + fine[:, 3])
        first = fine if first is None else first
    asked = grid_names([(n, w, {k: v for k, v in i.items() if not k.endswith("_attribute")})
                        for n, w, i in material.volume])       # (the Principled Volume's own: unsaid when absent)
    missing = sorted(asked - {g.name for g in read})
    if missing:
        warnings.append(f"{where}: its material reads grid{'s' if len(missing) > 1 else ''} "
                        f"{', '.join(missing)}, which {'are' if len(missing) > 1 else 'is'} not in its file or empty "
                        "(read as 0, as Cycles does)")
    if not read:
        return None
    # Cycles' bounding mesh: the box of the grids' active voxels (padded) in the first grid's index space.
    back = np.linalg.inv(np.vstack([first, [0.0, 0.0, 0.0, 1.0]]))[:3]
    index = np.concatenate([b @ back[:, :3].T + back[:, 3] for b in boxes])
    low, high = index.min(axis=0), index.max(axis=0)
    corners = np.array([[(low, high)[x][0], (low, high)[y][1], (low, high)[z][2]]
                        for z in (0, 1) for y in (0, 1) for x in (0, 1)])
    mesh = primitives.box(name=obj.name)
    mesh.vertices = corners @ first[:, :3].T + first[:, 3]
    if np.linalg.det(first[:, :3]) < 0.0:
        mesh.triangles = mesh.triangles[:, ::-1].copy()
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    scale = 1.0
    if render.space == "OBJECT":                # (Cycles' object_volume_density)
        scale = 1.0 / float(np.linalg.norm(np.asarray(matrix, np.float64)[:3, :3] @ (np.ones(3) / math.sqrt(3.0))))
    space = (np.linalg.inv(np.asarray(matrix, np.float64))[:3], 0.5 * (lo + hi), 0.5 * (hi - lo), read)
    # Cycles keeps the first material with a Volume on the mesh it builds, its Surface too (drawn on the box; none:
    # a volume-only boundary rays pass).
    materials.append(dataclasses.replace(material, volume=with_grids(material.volume, {g.name for g in read}, scale),
                                         volume_space=space))
    return mesh, np.full(max(len(slots), 1), len(materials) - 1, np.int64)
