"""The scene's triangles as the compiled code reads them (GeometryTables, core/geometry/triangles.c).

Made once per render from a WorldGeometry: the copied triangles' arrays and, for each instanced mesh,
its prototype, placements and material rows, in the dtypes C reads (no copy where they already are).
The records keep the arrays they point at alive for as long as they live.
"""
from __future__ import annotations

import numpy as np

from ..native import library, schema
from ..native.schema import F32, F64, I32, I64, U8, U64, ptr

InstancedRecord = schema.record("InstancedTables", "One instanced mesh (core/geometry/instancing.py InstancedMesh), as core/geometry/tables.py lays it out.", [
    ("vertices", ptr(F32), "(v, 3) object-space points"),
    ("triangles", ptr(I32), "(t, 3)"),
    ("smooth_index", ptr(I32), "(t,) row of corner_normals, -1 on flat triangles"),
    ("corner_normals", ptr(F64), "(s, 3, 3) object-space unit corner normals"),
    ("transforms", ptr(F32), "(k, 3, 4) camera-relative [L | T] per placement"),
    ("flip", ptr(F32), "(k,) sign of det L"),
    ("material", ptr(I32), "(r, t) material row per triangle, one row per slot table"),
    ("material_row", ptr(I32), "(k,) the row of `material` each placement uses"),
    ("triangle_count", I64, "t"),
    ("placements", I64, "k"),
    ("first_prim", I64, "WorldGeometry's flat index of placement 0's triangle 0"),
    ("owner", ptr(I32), "(k,) Scene.instances index per placement"),
    ("attribute_row", ptr(I32), "(t,) row of GeometryTables.attributes per triangle, or NULL"),
    ("motion", ptr(F64), "(s, MOTION_STRIDE) a moving placement's decomposed transforms over the shutter\n"
                         "(InstancedMesh.motion), or NULL: still"),
    ("motion_steps", I64, "s (0: still)"),
    ("vertex_steps", ptr(F32), "(r, v, 3) a deforming mesh's object-space points over the shutter\n"
                               "(InstancedMesh.vertex_steps), or NULL: rigid"),
    ("vertex_step_count", I64, "r (0: rigid)"),
    ("vertex_count", I64, "v"),
    ("normal_steps", ptr(F32), "(r, v, 3) a deforming mesh's object-space unit vertex normals at its vertex steps\n"
                               "(InstancedMesh.normal_steps), or NULL: the smooth normals are corner_normals at every time"),
])

GeometryRecord = schema.record("GeometryTables", "Every triangle of the scene (core/geometry/tables.py).", [
    ("vertices", ptr(F32), "(v, 3) camera-relative points of the copied triangles"),
    ("triangles", ptr(I32), "(t, 3)"),
    ("face_normals", ptr(F64), "(t, 3) unit front-side normals"),
    ("material", ptr(I32), "(t,) material row"),
    ("smooth_index", ptr(I32), "(t,) row of corner_normals, -1 flat; NULL when nothing is smooth"),
    ("corner_normals", ptr(F32), "(s, 3, 3) world unit corner normals"),
    ("meshes", ptr("InstancedTables"), "the instanced meshes, Embree geometry 1 .. instanced"),
    ("instanced", I64, ""),
    ("attributes", ptr(F32), "(r, 3, A) per-corner attributes the node graphs read, or NULL"),
    ("attribute_row", ptr(I32), "(t,) row of `attributes` per copied triangle"),
    ("instance", ptr(I32), "(t,) Scene.instances index per copied triangle"),
    ("instance_random", ptr(F64), "(n,) each instance's random number"),
    ("instance_info", ptr(F64), "(n, info_width) each instance's Object Info: location, colour, pass index, then\n"
                                "its Object and Instancer attributes (geometry.instance_info)"),
    ("info_width", I64, "columns of instance_info"),
    ("instance_linear", ptr(F64), "(n, 3, 3) each instance's linear transform"),
    ("attribute_width", I64, "A"),
    ("hidden", ptr(U8), "(n,) the rays each instance hides from (HIDDEN_FROM_*), NULL: none hides"),
    ("links", ptr(U64), "(n, 4) each instance's light set, shadow set, light and shadow membership\n"
                        "(WorldGeometry.instance_links), NULL: nothing is linked"),
    ("terminator", ptr(F64), "(n, 2) each instance's Shadow Terminator Geometry Offset (-1: the render's) and Shading\n"
                             "Offset multiplier (WorldGeometry.instance_terminator), NULL: none has its own"),
    ("ao_distance", ptr(F64), "(n,) each instance's own Fast GI AO Distance (WorldGeometry.instance_ao_distance, "
                              "0: the render's), NULL: none has its own"),
    ("caustics", ptr(U8), "(n,) each instance's shadow caustics bits (WorldGeometry.instance_caustics: 1 casts, 2\n"
                          "receives; core/integrators/mnee.c), NULL: no object has any"),
    ("origin", ptr(F64), "(3,) the world point the vertices are relative to (the Geometry node's Position adds it)"),
])


class GeometryTables:
    """A WorldGeometry's arrays in C's dtypes, and the record that points at them (`record`)."""

    def __init__(self, geometry):
        c = library.contiguous
        smooth = len(geometry.corner_normals) > 0
        self.meshes = (InstancedRecord * max(1, len(geometry.instanced)))()
        # An element of a ctypes array is a new wrapper at each indexing, and the arrays a record points at are kept
        # alive by its wrapper (schema.Record): the wrappers are kept here, or a copy `c` made (a material table
        # in Fortran order, say) would be freed while C still reads it.
        self._records = []
        for index, mesh in enumerate(geometry.instanced):
            record = self.meshes[index]
            self._records.append(record)
            for name, array in (("vertices", c(mesh.vertices, np.float32)), ("triangles", c(mesh.triangles, np.int32)),
                                ("smooth_index", c(mesh.smooth_index, np.int32)),
                                ("corner_normals", c(mesh.corner_normals, np.float64).reshape(-1, 3, 3)),
                                ("transforms", c(mesh.transforms, np.float32)), ("flip", c(mesh.flip, np.float32)),
                                ("material", c(mesh.material, np.int32)),
                                ("material_row", c(mesh.material_row, np.int32)), ("owner", c(mesh.owner, np.int32)),
                                ("attribute_row", None if mesh.attribute_row is None
                                 else c(mesh.attribute_row, np.int32))):
                setattr(record, name, array)
            record.triangle_count, record.placements = len(mesh.triangles), len(mesh.transforms)
            record.vertex_count = len(mesh.vertices)
            record.first_prim = int(mesh.first_prim)
            if mesh.motion is not None:                # (a moving placement: where it is at each ray's time)
                record.motion, record.motion_steps = c(mesh.motion, np.float64), len(mesh.motion)
            if mesh.vertex_steps is not None:          # (a deforming mesh: its points at each ray's time)
                record.vertex_steps = c(mesh.vertex_steps, np.float32)
                record.vertex_step_count = len(mesh.vertex_steps)
                if mesh.normal_steps is not None:      # (and its smooth normals then)
                    record.normal_steps = c(mesh.normal_steps, np.float32)
        self.record = GeometryRecord(
            vertices=c(geometry.vertices, np.float32), triangles=c(geometry.triangles, np.int32),
            face_normals=c(geometry.face_normals, np.float64), material=c(geometry.material, np.int32),
            smooth_index=c(geometry.smooth_index, np.int32) if smooth else None,
            corner_normals=c(geometry.corner_normals, np.float32) if smooth else None,
            meshes=self.meshes, instanced=len(geometry.instanced),
            # What node graphs read: the attributes, each copied triangle's row and instance, the instances'
            # random numbers and transforms.
            attributes=None if geometry.attributes is None else c(geometry.attributes, np.float32),
            attribute_row=c(geometry.attribute_row, np.int32) if len(geometry.attribute_row) else None,
            instance=c(geometry.instance, np.int32) if len(geometry.instance) else None,
            instance_random=c(geometry.instance_random, np.float64) if len(geometry.instance_random) else None,
            instance_info=c(geometry.instance_info, np.float64) if len(geometry.instance_info) else None,
            info_width=geometry.instance_info.shape[1],
            instance_linear=c(geometry.instance_linear, np.float64) if len(geometry.instance_linear) else None,
            attribute_width=geometry.attributes.shape[2] if geometry.attributes is not None else 0,
            origin=c(np.asarray(geometry.origin, np.float64).reshape(3), np.float64))
        # Which rays each instance hides from, where some object hides (Ray Visibility); the copied triangles'
        # instances are needed to find a hit's object then.
        if len(geometry.instance_hidden):
            self.record.hidden = c(geometry.instance_hidden, np.uint8)
            self.record.instance = c(geometry.instance, np.int32) if len(geometry.instance) else None
        # Light and shadow linking: each instance's sets and memberships, where some object is linked.
        if len(geometry.instance_links):
            self.record.links = c(geometry.instance_links, np.uint64)
            self.record.instance = c(geometry.instance, np.int32) if len(geometry.instance) else None
        # The objects' own shadow terminator offsets, where some object has one (the terminator fix).
        if len(geometry.instance_terminator):
            self.record.terminator = c(geometry.instance_terminator, np.float64)
            self.record.instance = c(geometry.instance, np.int32) if len(geometry.instance) else None
        # The objects' shadow caustics switches, where some object has one (core/integrators/mnee.c).
        if len(geometry.instance_caustics) and geometry.instance_caustics.any():
            self.record.caustics = c(geometry.instance_caustics, np.uint8)
            self.record.instance = c(geometry.instance, np.int32) if len(geometry.instance) else None
        # The objects' own Fast GI AO Distance, where some object has one.
        if len(geometry.instance_ao_distance):
            self.record.ao_distance = c(geometry.instance_ao_distance, np.float64)
            self.record.instance = c(geometry.instance, np.int32) if len(geometry.instance) else None
