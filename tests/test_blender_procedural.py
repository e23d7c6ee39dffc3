"""Procedural textures against Cycles' own render, pixel for pixel: Noise (every fractal, 1D to 4D, fractional
detail, distortion, Color), Voronoi (every feature, every metric, 1D to 4D, fractal detail), White Noise (1D
to 4D), Gradient (all seven types), Checker, Wave (bands and rings in every direction, every profile, Distortion),
Magic (depth 0 to 10), Brick, Gabor (2D and 3D, every output) and a node's own Texture Mapping, each the colour of an
emitting plane seen by an orthographic camera, exported by addon/materials.py with real Blender.

A rendered pixel is the mean of its samples, and Primer's samples fall elsewhere in the pixel than Cycles'. So that
the two images can agree to float precision, each texture reads the Generated coordinate snapped to its pixel's
centre ((floor(32 x) + 0.5) / 32, then x 4 - 2: every step exact in float32 and float64), one value per pixel
whatever the sample; the Checker also reads the unlinked (default Generated) vector at a scale whose squares end on
pixel edges. Then a pixel differs only by float32 rounding: White Noise, Gradient and Checker render exactly
Cycles' values, Voronoi and Noise, Wave and Magic within a few float32 ulps (Cycles' x86 kernels fuse some
multiply-adds and order some sums differently; sinf and cosf round as they may).
"""
from __future__ import annotations


import numpy as np
import pytest

from blender_env import require_bpy, run_bpy
from core.materials.procedural import MagicTexture

pytestmark = pytest.mark.blender

require_bpy(__file__)

PIXELS = 32               # pixels across each plane
COLUMNS = 10              # planes per row of the grid (no more rows than columns: ortho_scale spans the wider side)

SCRIPT = """
import sys, os
import bpy
import numpy as np
from blender_env import report, empty_material, fresh_scene, grid_plane, snapped_generated, render_plane_grid
primer, export, scene = fresh_scene()
PIXELS, COLUMNS = {pixels}, {columns}


cases = []


def case(label, idname, output, settings=(), inputs=(), snap=True, absolute=False, mapping=()):
    material, tree, out = empty_material(label)
    node = tree.nodes.new(idname)
    for name, value in settings:
        setattr(node, name, value)
    for name, value in mapping:                             # the node's own Texture Mapping
        setattr(node.texture_mapping, name, value)
    for name, value in inputs:
        next(s for s in node.inputs if name in (s.identifier, s.name)).default_value = value  # (unavailable too)
    if snap:
        vector, x, _ = snapped_generated(tree, PIXELS)
        available = {{s.name: s for s in node.inputs if s.enabled}}
        if "Vector" in available:
            tree.links.new(vector, available["Vector"])
        else:                                               # 1D: W is the snapped x
            tree.links.new(x, available["W"])
    emission = tree.nodes.new("ShaderNodeEmission")
    socket = next(s for s in node.outputs if s.identifier == output)
    if absolute:                                            # |x| of a vector or float that may be negative
        if socket.type == "VECTOR":
            separate = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(socket, separate.inputs["Vector"])
            socket = separate.outputs["X"]
        math = tree.nodes.new("ShaderNodeMath")
        math.operation = "ABSOLUTE"
        tree.links.new(socket, math.inputs[0])
        socket = math.outputs[0]
    tree.links.new(socket, emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    grid_plane(cases, label, material, COLUMNS)


for dimensions in ("1D", "2D", "3D", "4D"):
    for kind in ("FBM", "MULTIFRACTAL", "HYBRID_MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HETERO_TERRAIN"):
        case(f"Noise {{dimensions}} {{kind}}", "ShaderNodeTexNoise", "Color",
             [("noise_dimensions", dimensions), ("noise_type", kind)],
             [("W", 0.7), ("Scale", 1.5), ("Detail", 2.5), ("Roughness", 0.6), ("Lacunarity", 2.1), ("Offset", 0.3),
              ("Gain", 1.2), ("Distortion", 0.4 if kind == "FBM" else 0.0)])
case("Noise 3D fBM raw", "ShaderNodeTexNoise", "Fac", [("normalize", False)], [("Detail", 4.0)])
for dimensions in ("1D", "2D", "3D", "4D"):
    case(f"White Noise {{dimensions}}", "ShaderNodeTexWhiteNoise", "Color", [("noise_dimensions", dimensions)],
         [("W", 0.25)])
for kind in ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL", "QUADRATIC_SPHERE", "RADIAL"):
    case(f"Gradient {{kind}}", "ShaderNodeTexGradient", "Fac", [("gradient_type", kind)])
for dimensions in ("1D", "2D", "3D", "4D"):
    for feature, metric, output, normalize, inputs in (
            ("F1", "EUCLIDEAN", "Color", False, [("Detail", 1.5), ("Randomness", 0.8)]),
            ("F2", "MANHATTAN", "Distance", True, [("Detail", 0.0)]),
            ("SMOOTH_F1", "CHEBYCHEV", "Distance", False, [("Smoothness", 0.6), ("Detail", 1.0)]),
            ("F1", "MINKOWSKI", "Distance", True, [("Exponent", 1.5)]),
            ("DISTANCE_TO_EDGE", "EUCLIDEAN", "Distance", True, [("Detail", 2.3)]),
            ("N_SPHERE_RADIUS", "EUCLIDEAN", "Radius", False, [])):
        case(f"Voronoi {{dimensions}} {{feature}} {{metric}}", "ShaderNodeTexVoronoi", output,
             [("voronoi_dimensions", dimensions), ("feature", feature), ("distance", metric),
              ("normalize", normalize)], [("W", 0.7), ("Scale", 1.5)] + inputs)
for dimensions, feature, output in (("1D", "F1", "W"), ("3D", "F1", "Position"), ("4D", "F2", "Position"),
                                    ("4D", "SMOOTH_F1", "W")):
    case(f"Voronoi {{dimensions}} {{feature}} {{output}}", "ShaderNodeTexVoronoi", output,
         [("voronoi_dimensions", dimensions), ("feature", feature)], [("W", 0.7), ("Scale", 1.5), ("Detail", 1.5)],
         absolute=True)
for wave_type, direction, profile, distortion in (
        ("BANDS", "X", "SIN", 0.0), ("BANDS", "Y", "SAW", 2.0), ("BANDS", "Z", "TRI", 2.0),
        ("BANDS", "DIAGONAL", "SIN", 2.0), ("RINGS", "X", "TRI", 0.0), ("RINGS", "Y", "SIN", 2.0),
        ("RINGS", "Z", "SAW", 0.0), ("RINGS", "SPHERICAL", "SIN", 2.0)):
    attribute = "bands_direction" if wave_type == "BANDS" else "rings_direction"
    case(f"Wave {{wave_type}} {{direction}} {{profile}}", "ShaderNodeTexWave", "Fac",
         [("wave_type", wave_type), (attribute, direction), ("wave_profile", profile)],
         [("Scale", 0.3), ("Distortion", distortion), ("Detail", 2.5), ("Detail Scale", 1.5),
          ("Detail Roughness", 0.6), ("Phase Offset", 0.4)])
for depth, distortion in ((0, 0.0), (1, 1.7), (2, 1.7), (5, 1.7), (10, 1.7)):
    case(f"Magic {{depth}} {{distortion}}", "ShaderNodeTexMagic", "Color", [("turbulence_depth", depth)],
         [("Scale", 0.6), ("Distortion", distortion)])
for output, smooth, frequencies in (("Color", 0.3, (2, 3)), ("Fac", 0.0, (3, 1)), ("Fac", 0.6, (1, 2))):
    case(f"Brick {{output}} {{smooth}}", "ShaderNodeTexBrick", output,
         [("offset", 0.3), ("offset_frequency", frequencies[0]), ("squash", 1.4),
          ("squash_frequency", frequencies[1])],
         [("Color1", (0.9, 0.5, 0.1, 1.0)), ("Color2", (0.1, 0.3, 0.8, 1.0)), ("Mortar", (0.0, 0.05, 0.1, 1.0)),
          ("Scale", 1.0), ("Mortar Size", 0.07), ("Mortar Smooth", smooth), ("Bias", 0.1), ("Brick Width", 0.45),
          ("Row Height", 0.3)])
for dimensions, output, anisotropy in (("2D", "Value", 0.3), ("2D", "Phase", 1.0), ("2D", "Intensity", 0.0),
                                      ("3D", "Value", 0.5), ("3D", "Intensity", 1.0)):
    case(f"Gabor {{dimensions}} {{output}}", "ShaderNodeTexGabor", output, [("gabor_type", dimensions)],
         [("Scale", 1.5), ("Frequency", 2.5), ("Anisotropy", anisotropy), ("Orientation 2D", 0.4),
          ("Orientation 3D", (0.3, -0.5, 0.8))])
case("Checker", "ShaderNodeTexChecker", "Color", inputs=[("Scale", 1.7), ("Color1", (1.0, 0.5, 0.25, 1.0))])
case("Checker default vector", "ShaderNodeTexChecker", "Fac", inputs=[("Scale", 4.0)], snap=False)
case("Mapped Checker default vector", "ShaderNodeTexChecker", "Fac", inputs=[("Scale", 4.0)], snap=False,
     mapping=[("scale", (2.0, 1.0, 1.0))])
case("Mapped Gradient point", "ShaderNodeTexGradient", "Fac", [("gradient_type", "DIAGONAL")],
     mapping=[("translation", (0.3, -0.2, 0.1)), ("rotation", (0.2, -0.3, 0.5)), ("scale", (0.5, 0.7, 1.2))])
case("Mapped Noise texture axes min", "ShaderNodeTexNoise", "Fac", inputs=[("Scale", 1.5), ("Detail", 1.0)],
     mapping=[("vector_type", "TEXTURE"), ("mapping_x", "Y"), ("mapping_y", "X"), ("mapping_z", "NONE"),
              ("translation", (0.3, -0.2, 0.1)), ("rotation", (0.0, 0.0, 0.4)), ("scale", (1.5, 0.8, 1.0)),
              ("use_min", True), ("min", (-1.0, -0.5, -1.0))])
case("Mapped Wave vector max", "ShaderNodeTexWave", "Fac", [("wave_type", "RINGS"), ("rings_direction", "SPHERICAL")],
     inputs=[("Scale", 0.3)],
     mapping=[("vector_type", "VECTOR"), ("translation", (5.0, 5.0, 5.0)), ("rotation", (0.3, 0.0, 0.0)),
              ("scale", (1.0, 2.0, 1.0)), ("use_max", True), ("max", (1.0, 1.5, 1.0))])

warnings = render_plane_grid(scene, export, COLUMNS, -(-len(cases) // COLUMNS), PIXELS)
primer.unregister()
report(cases=cases, warnings=warnings, version=list(bpy.app.version))
"""


def test_procedural_textures_render_cycles_values_pixel_for_pixel(tmp_path):
    """Every texture, setting and dimension, and a node's own Texture Mapping of each type: Primer's pixels are
    Cycles' (White Noise, Gradient, Checker exactly; Noise, Voronoi, Wave, Magic, Brick and the mapped ones within
    float32 rounding), and the export warns of nothing (but Blender 5.2's Magic)."""
    result = run_bpy(SCRIPT.format(pixels=PIXELS, columns=COLUMNS), str(tmp_path))
    # Blender 5.2's Cycles wraps the Magic Texture's point otherwise (the same pattern here, where no coordinate
    # nor its product with Scale passes 2pi): said once per Magic node there, nothing else anywhere.
    magics = [label for label in result["cases"] if label.startswith("Magic")]
    notes = [] if result["version"][:2] < [5, 2] else [
        f"material '{label}', node 'Magic Texture': {MagicTexture.differs_in({}, (5, 2, 0))}" for label in magics]
    assert result["warnings"] == notes
    primer, cycles = np.load(tmp_path / "primer.npy"), np.load(tmp_path / "cycles.npy")
    assert primer.shape == cycles.shape
    worst, fac, edges = {}, {}, {}
    for index, label in enumerate(result["cases"]):
        row, column = divmod(index, COLUMNS)
        block = (slice(row * PIXELS, (row + 1) * PIXELS), slice(column * PIXELS, (column + 1) * PIXELS))
        ours, theirs = primer[block], cycles[block]
        assert theirs.std() > 0.01, f"{label}: Cycles' texture does not vary across the plane"
        on_edge = edge_samples(ours, theirs)
        edges[label] = int(on_edge.sum())
        difference = np.where(on_edge[..., None], 0.0, np.abs(ours - theirs))
        worst[label] = float(difference.max())
        if label.startswith("Noise"):                   # Fac alone (the Color's red), and the Color's green, blue
            fac[label] = float(difference[..., 0].max())
    # A sample within float rounding of its pixel's edge snaps to the neighbouring pixel's centre in one renderer
    # and not the other: a pixel or two in the whole image (where the neighbour's value is Primer's exactly).
    assert sum(edges.values()) <= 2, {label: n for label, n in edges.items() if n}
    print("largest difference per texture:", worst)
    print("largest per family:", {family: max(d for label, d in worst.items() if label.startswith(family))
                                  for family in ("Noise", "Voronoi", "White", "Gradient", "Checker", "Wave", "Magic",
                                                 "Brick", "Mapped", "Gabor")})
    # White Noise, Checker, the Gradients but Radial and the hard-mortared Brick: Cycles' float32 values exactly.
    # Radial: atan2 rounded in double here, atan2f in Cycles, an ulp apart at most. Voronoi: its colours exactly, its
    # distances within a few ulps (measured <= 5.7e-7: Distance to Edge's normalized bisectors, Smooth F1's sums,
    # Minkowski's powf). Brick's smoothed mortar: Blender 5.2's build fuses more of it, and the smoothstep's argument
    # (1 - d / Mortar Size) / Mortar Smooth magnifies an ulp of d by 1 / (0.07 x 0.3) here (measured <= 2.9e-6).
    tolerance = dict(TOLERANCE)
    if result["version"][:2] >= [5, 2]:
        tolerance.update({label: 5e-6 for label in ("Brick Color 0.3", "Brick Fac 0.6")})
    exact = {label: d for label, d in worst.items()
             if not label.startswith(("Noise", "Voronoi", "Wave", "Magic", "Mapped", "Gabor"))
             and d > tolerance.get(label, 0.0)}
    assert exact == {}, exact
    cells = {label: d for label, d in worst.items() if label.startswith("Voronoi") and d > 1e-6}
    assert cells == {}, cells
    # Noise's Fac: a few float32 ulps of the sum of octaves (measured <= 1.6e-6); with Distortion, which moves the
    # point by a noise value, the ulps grow with the noise's slope (measured <= 1.7e-5).
    noisy = {label: d for label, d in fac.items() if d > (5e-5 if label.endswith("FBM") else 4e-6)}
    assert noisy == {}, noisy
    # Its Color's green and blue: the noise at the point + a seeded offset in [100, 200], where a float32 ulp is
    # 1.5e-5: an offset an ulp apart moves the value by that times the slope. Blender 5.0: <= 3.2e-5; Blender 5.2's
    # build rounds the 2D and 3D green offset an ulp away (its multiply-add fused): <= 1.7e-4.
    offset = {label: d for label, d in worst.items() if label.startswith("Noise") and d > 2.5e-4}
    assert offset == {}, offset
    # Wave: float32 ulps of n (20 x a coordinate, up to about 12 here) through the profile, and of the fBM with
    # Distortion (measured <= 1.4e-6; 4.8e-7 on 5.2). Magic: sines of sines, each level carrying the last one's
    # ulps times Distortion (1.7 here; measured <= 2.1e-7 at depth 1, 1.1e-6 at depth 5, 7.4e-6 at depth 10, as
    # Blender 4.2 does; Blender 5.2, which multiplies by Scale before 5 rather than after: 1.0e-6, 7.5e-6, 7.2e-5).
    magic = 3e-5 if result["version"][:2] < [5, 2] else 2e-4
    # A node's own Texture Mapping: Primer maps in float64 (the Mapping node's op), Cycles by its float32 matrix,
    # so the point is a float32 ulp or so away (Checker exactly; measured <= 1.9e-6 through the Wave's rings, whose
    # Min and Max are set: Cycles does not read them, nor does Primer).
    mapped = {label: d for label, d in worst.items() if label.startswith("Mapped") and d > 5e-6}
    assert mapped == {}, mapped
    # Gabor: sums of 72 (2D) or 216 (3D) kernels, each an ulp or so from Cycles' expf, cosf and sinf: Value and
    # Intensity measured <= 1.3e-7; Phase, atan2 of the sum, <= 1.4e-6.
    gabor = {label: d for label, d in worst.items() if label.startswith("Gabor") and d > 5e-6}
    assert gabor == {}, gabor
    waves = {label: d for label, d in worst.items() if label.startswith(("Wave", "Magic"))
             and d > (5e-6 if label.startswith("Wave") else magic)}
    assert waves == {}, waves


# Radial: atan2 an ulp apart. Brick: its smoothed mortar (3 ff - 2 ff f) and colour mixes an ulp apart where Cycles'
# build fuses a multiply-add (measured 6.0e-8); the hard mortar's Fac exactly.
TOLERANCE = {"Gradient RADIAL": 1.2e-7, "Brick Color 0.3": 1.2e-7, "Brick Fac 0.6": 1.2e-7}


def edge_samples(ours: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """(h, w) bool: pixels whose colour is not Cycles' there but, within 2.5e-4, Cycles' at a pixel beside it (the
    one sample landed on the pixels' common edge and snapped across it; 2.5e-4: a Noise Color's green and blue, an
    offset's ulp apart on Blender 5.2, the bound the test holds them to anyway)."""
    own = np.abs(ours - theirs).max(axis=2)
    padded = np.pad(theirs, ((1, 1), (1, 1), (0, 0)), constant_values=np.inf)
    h, w = own.shape
    beside = np.min([np.abs(ours - padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]).max(axis=2)
                     for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1))], axis=0)
    return (own > 1e-4) & (beside <= 2.5e-4)
