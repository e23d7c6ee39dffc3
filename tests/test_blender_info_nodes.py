"""The Radial Tiling, Point Info and Volume Info nodes against Cycles' own render, in one Blender process.

Each case is the emission of a unit cell of a grid seen from above by an orthographic camera (blender_env's
render_plane_grid), exported by addon/materials.py with real Blender. Radial Tiling reads the Generated coordinate
snapped to its pixel's centre and mapped to -2..2 (snapped_generated: one value per pixel whatever the sample), for
whole and fractional Sides, sharp, rounded and circular corners, Normalize off and on, every output (through
|x|: its coordinates and ids may be negative or large); one case leaves the Vector unlinked (Cycles' (0, 0, 0)).
Point Info: three point clouds (geometry nodes' Mesh to Points, radius by index, the object moved and scaled
uniformly), their Position (|x|), Radius (x 4) and Random, each constant over a sphere, compared on the pixels deep
inside the spheres in both images. On a plain plane Point Info and Volume Info read 0 in Cycles (no point, no volume
grid): each output + 0.25 is 0.25 all over the cell in both.
"""
from __future__ import annotations


import numpy as np
import pytest

from blender_env import require_bpy, run_bpy
from core.film.compare import relative_mse_of_blocks

pytestmark = pytest.mark.blender

require_bpy(__file__)

PIXELS = 32
COLUMNS = 10
# (Sides, Roundness): whole and fractional Sides, sharp, rounded and circular corners, and the 2-gon.
POLYGONS = ((5.0, 0.0), (5.0, 0.4), (6.0, 1.0), (4.3, 0.0), (4.3, 0.5), (3.7, 1.0), (2.0, 0.0), (2.6, 0.8))

SCRIPT = """
import bpy
from blender_env import (report, empty_material, fresh_scene, grid_plane, points_by_index, snapped_generated,
                         render_plane_grid)
primer, export, scene = fresh_scene()
PIXELS, COLUMNS = {pixels}, {columns}
cases = []


def emit(tree, out, socket, add=None, absolute=True, scale=None):
    '''Emission of `socket` (|x|, x scale, + add as asked) into the tree's output.'''
    vector = socket.type in ("VECTOR", "RGBA")
    for operation, value in (("ABSOLUTE", absolute), ("SCALE" if vector else "MULTIPLY", scale), ("ADD", add)):
        if not value:
            continue
        math = tree.nodes.new("ShaderNodeVectorMath" if vector else "ShaderNodeMath")
        math.operation = operation
        if operation == "SCALE":
            math.inputs["Scale"].default_value = value
        elif operation != "ABSOLUTE":
            math.inputs[1].default_value = (value,) * 3 if vector else value
        tree.links.new(socket, math.inputs[0])
        socket = math.outputs["Vector" if vector else "Value"]
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(socket, emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])


def cell(label, idname, output, settings=(), inputs=(), snap=True, add=None, absolute=True):
    '''A unit plane in the next cell, emitting `output` of a new `idname` node.'''
    material, tree, out = empty_material(label)
    node = tree.nodes.new(idname)
    for name, value in settings:
        setattr(node, name, value)
    for name, value in inputs:
        node.inputs[name].default_value = value
    if snap:
        tree.links.new(snapped_generated(tree, PIXELS)[0], node.inputs["Vector"])
    emit(tree, out, node.outputs[output], add=add, absolute=absolute)
    grid_plane(cases, label, material, COLUMNS)


for sides, roundness in {polygons}:
    for normalize in (False, True):
        cell(f"Radial {{sides}} {{roundness}} {{normalize}} Segment Coordinates", "ShaderNodeRadialTiling",
             "Segment Coordinates", [("normalize", normalize)], [("Sides", sides), ("Roundness", roundness)])
    for output in ("Segment ID", "Segment Width", "Segment Rotation"):
        cell(f"Radial {{sides}} {{roundness}} False {{output}}", "ShaderNodeRadialTiling", output, [],
             [("Sides", sides), ("Roundness", roundness)])
cell("Radial default vector", "ShaderNodeRadialTiling", "Segment Coordinates", [("normalize", True)], snap=False)
for output in ("Position", "Radius", "Random"):
    cell(f"Point Info on a plane {{output}}", "ShaderNodePointInfo", output, snap=False, add=0.25, absolute=False)
for output in ("Color", "Density", "Flame", "Temperature"):
    cell(f"Volume Info on a plane {{output}}", "ShaderNodeVolumeInfo", output, snap=False, add=0.25, absolute=False)

# Point clouds: nine points in a cell (local -0.3..0.3), radius 0.04 + 0.012 index, the object scaled 1.5.
for output, scale in (("Position", None), ("Radius", 4.0), ("Random", None)):
    material, tree, out = empty_material(f"Points {{output}}")
    emit(tree, out, tree.nodes.new("ShaderNodePointInfo").outputs[output], absolute=output == "Position",
         scale=scale)
    mesh = bpy.data.meshes.new(f"Points {{output}}")
    mesh.from_pydata([(-0.2 + 0.2 * (k % 3), -0.2 + 0.2 * (k // 3), 0.0) for k in range(9)], [], [])
    obj = bpy.data.objects.new(f"Points {{output}}", mesh)
    points_by_index(obj, material, 0.03, 0.006)
    index = len(cases)
    obj.location = (index % COLUMNS + 0.5, -(index // COLUMNS) - 0.5, 0.0)
    obj.scale = (1.5, 1.5, 1.5)
    scene.collection.objects.link(obj)
    cases.append(f"Points {{output}}")

warnings = render_plane_grid(scene, export, COLUMNS, -(-len(cases) // COLUMNS), PIXELS)
report(cases=cases, warnings=warnings)
"""


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """The grid rendered by both engines: (case labels, warnings, Primer's pixels, Cycles' pixels, (rows, columns)
    of each case's cell)."""
    folder = tmp_path_factory.mktemp("info_nodes")
    result = run_bpy(SCRIPT.format(pixels=PIXELS, columns=COLUMNS, polygons=POLYGONS), str(folder))
    primer, cycles = np.load(folder / "primer.npy"), np.load(folder / "cycles.npy")
    cells = {}
    for index, label in enumerate(result["cases"]):
        row, column = divmod(index, COLUMNS)
        cells[label] = (slice(row * PIXELS, (row + 1) * PIXELS), slice(column * PIXELS, (column + 1) * PIXELS))
    return result["cases"], result["warnings"], primer, cycles, cells


def test_radial_tiling_renders_cycles_segment_coordinates_ids_widths_and_rotations(rendered):
    """Every Radial Tiling case: Primer's pixels are Cycles' (block relMSE <= 1e-6 per cell, and per pixel within
    float32 rounding but for a few pixels on a segment's edge, where an ulp of the angle decides the segment)."""
    cases, warnings, primer, cycles, cells = rendered
    assert not [w for w in warnings if "Radial Tiling" in w], warnings
    errors, worst, flipped = {}, {}, {}
    for label in (c for c in cases if c.startswith("Radial")):
        ours, theirs = primer[cells[label]], cycles[cells[label]]
        if label != "Radial default vector" and not label.endswith("Width"):    # (Width: one per segment)
            assert theirs.std() > 0.01, f"{label}: Cycles' cell does not vary"
        errors[label] = relative_mse_of_blocks(ours, theirs)
        difference = np.abs(ours - theirs).max(axis=2)
        flipped[label] = int((difference > 1e-3).sum())
        worst[label] = float(np.where(difference > 1e-3, 0.0, difference).max())
    print("block relMSE", max(errors.values()), "largest difference", max(worst.values()),
          "pixels off by > 1e-3", sum(flipped.values()))
    assert {label: e for label, e in errors.items() if e > 1e-6} == {}
    assert {label: d for label, d in worst.items() if d > 2e-5} == {}
    assert sum(flipped.values()) <= 4, {label: n for label, n in flipped.items() if n}


def test_point_info_reads_each_points_world_centre_radius_and_random_and_zeros_off_points(rendered):
    """Point clouds: deep inside each sphere (pixels covered in both images, with all eight neighbours) Primer's
    Position, Radius and Random are Cycles' to float32 rounding; on a plain plane they and the Volume Info's outputs
    read 0 in both renderers (each + 0.25 fills its cell), with no warning about either node."""
    cases, warnings, primer, cycles, cells = rendered
    assert not [w for w in warnings if "Point Info" in w or "Volume Info" in w], warnings
    for label in (c for c in cases if c.startswith(("Point Info on", "Volume Info on"))):
        np.testing.assert_allclose(cycles[cells[label]], 0.25, atol=1e-6, err_msg=label)
        np.testing.assert_allclose(primer[cells[label]], 0.25, atol=1e-6, err_msg=label)
    for label in ("Points Position", "Points Radius", "Points Random"):
        ours, theirs = primer[cells[label]], cycles[cells[label]]
        covered = (ours.max(axis=2) > 0.0) & (theirs.max(axis=2) > 0.0)
        inner = covered.copy()
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                inner[1:-1, 1:-1] &= covered[1 + dy:PIXELS - 1 + dy, 1 + dx:PIXELS - 1 + dx]
        inner[[0, -1], :] = inner[:, [0, -1]] = False
        assert inner.sum() >= 9, label
        difference = np.abs(ours - theirs)[inner].max()
        print(label, "inner pixels", int(inner.sum()), "largest difference", difference,
              "values", len(np.unique(theirs[inner].round(4), axis=0)))
        assert difference < 1e-5, label
        assert len(np.unique(theirs[inner].round(4), axis=0)) >= 5, label     # (nine points, nine values)
