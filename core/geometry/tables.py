"""The scene's triangles as the compiled code reads them (core/geometry/triangles.c GeometryTables).

Made once per render from a WorldGeometry: the copied triangles' arrays and, for each instanced mesh,
its prototype, placements and material rows, in the dtypes C reads (no copy where they already are).
The arrays must outlive every C call that reads them: GeometryTables keeps them.
"""
from __future__ import annotations

import ctypes

import numpy as np

from ..native import library


class InstancedRecord(ctypes.Structure):
    """One instanced mesh (triangles.c InstancedTables)."""

    _fields_ = [(name, ctypes.c_void_p) for name in ("vertices", "triangles", "smooth_index", "corner_normals",
                                                    "transforms", "flip", "material", "material_row")] + \
               [("triangle_count", ctypes.c_double), ("placements", ctypes.c_double), ("first_prim", ctypes.c_double),
                ("owner", ctypes.c_void_p), ("attribute_row", ctypes.c_void_p)]


class GeometryRecord(ctypes.Structure):
    """Every triangle of the scene (triangles.c GeometryTables)."""

    _fields_ = [(name, ctypes.c_void_p) for name in ("vertices", "triangles", "face_normals", "material",
                                                    "smooth_index", "corner_normals", "meshes")] + \
               [("instanced", ctypes.c_double)] + \
               [(name, ctypes.c_void_p) for name in ("attributes", "attribute_row", "instance", "instance_random",
                                                    "instance_linear")] + [("attribute_width", ctypes.c_double),
                                                                           ("hidden", ctypes.c_void_p)]


class GeometryTables:
    """A WorldGeometry's arrays in C's dtypes, and the record that points at them (`record`)."""

    def __init__(self, geometry):
        c = library.contiguous
        smooth = len(geometry.corner_normals) > 0
        self.arrays = [c(geometry.vertices, np.float32), c(geometry.triangles, np.int32),
                       c(geometry.face_normals, np.float64), c(geometry.material, np.int32),
                       c(geometry.smooth_index, np.int32) if smooth else None,
                       c(geometry.corner_normals, np.float32) if smooth else None]
        self.meshes = (InstancedRecord * max(1, len(geometry.instanced)))()
        for index, mesh in enumerate(geometry.instanced):
            arrays = [c(mesh.vertices, np.float32), c(mesh.triangles, np.int32), c(mesh.smooth_index, np.int32),
                      c(mesh.corner_normals, np.float64).reshape(-1, 3, 3), c(mesh.transforms, np.float32),
                      c(mesh.flip, np.float32), c(mesh.material, np.int32), c(mesh.material_row, np.int32)]
            self.arrays += arrays
            record = self.meshes[index]
            for (name, _), array in zip(InstancedRecord._fields_, arrays):
                setattr(record, name, array.ctypes.data)
            record.triangle_count, record.placements = float(len(mesh.triangles)), float(len(mesh.transforms))
            record.first_prim = float(mesh.first_prim)
            own = [c(mesh.owner, np.int32)] + ([c(mesh.attribute_row, np.int32)] if mesh.attribute_row is not None else [])
            self.arrays += own
            record.owner = own[0].ctypes.data
            record.attribute_row = own[1].ctypes.data if len(own) > 1 else None
        self.record = GeometryRecord(*[None if a is None else a.ctypes.data for a in self.arrays[:6]],
                                     ctypes.addressof(self.meshes), float(len(geometry.instanced)))
        # What node graphs read: the attributes, each copied triangle's row and instance, the instances'
        # random numbers and transforms.
        shading = [None if geometry.attributes is None else c(geometry.attributes, np.float32),
                   c(geometry.attribute_row, np.int32) if len(geometry.attribute_row) else None,
                   c(geometry.instance, np.int32) if len(geometry.instance) else None,
                   c(geometry.instance_random, np.float64) if len(geometry.instance_random) else None,
                   c(geometry.instance_linear, np.float64) if len(geometry.instance_linear) else None]
        self.arrays += shading
        for name, array in zip(("attributes", "attribute_row", "instance", "instance_random", "instance_linear"), shading):
            setattr(self.record, name, None if array is None else array.ctypes.data)
        self.record.attribute_width = float(geometry.attributes.shape[2]) if geometry.attributes is not None else 0.0
        # Which rays each instance hides from, where some object hides (Ray Visibility); the copied triangles'
        # instances are needed to find a hit's object then.
        if len(geometry.instance_hidden):
            hidden = [c(geometry.instance_hidden, np.uint8),
                      c(geometry.instance, np.int32) if len(geometry.instance) else None]
            self.arrays += hidden
            self.record.hidden = hidden[0].ctypes.data
            self.record.instance = None if hidden[1] is None else hidden[1].ctypes.data
