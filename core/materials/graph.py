"""Node graphs: the texture and colour nodes that feed a material's shader nodes, as a flat program.

A shader node's input can be a constant or a `Link` to an output of a `GraphNode` (an image texture, a
Math node, a Mix ...), whose own inputs can be links again: the sub-graph Blender's node tree feeds
into it (addon/materials.py exports it, groups flattened and reroutes skipped). Per render, each
material's sub-graphs are compiled once into a `Program`, as Cycles' SVM compiles node trees: a list
of ops on numbered registers. Registers 0 .. c - 1 hold the program's constants; every op reads
registers and writes new ones. Its `outputs` say which registers overwrite which shader node's
inputs (a slot of its row of NODE_PARAMS floats, core/materials/nodes.py), which multiply its weight (a
Mix Shader's factor, a Diffuse BSDF's colour) and which replace its normal (Normal Map, Bump).

At a hit the program reads a `ShadingPoint`: the mesh attributes the materials use (UV maps, colour
attributes, tangents, generated and object coordinates) interpolated with the hit's barycentrics, the
object's random number, the normals and the triangle's edges. `run` evaluates a program for n hits at
once with numpy; core/materials/graph.c is the compiled twin, one hit at a time. Materials whose inputs
are all constants have no program and cost nothing more.

The Bump node needs the height's derivative. As Cycles, Primer evaluates the height at the hit and at
two points a step away, re-interpolating the attributes there (OFFSET ops): the ray's footprint at the
hit (the path's ray cone, LightPaths cone + t spread: Cycles' compact differential) along two
directions across the face (make_orthonormals of Ng), times the Bump's Filter Width (bump_step,
bump_differentials). A footprint of 0 leaves the normal as it is, as in Cycles: a path that scattered
in media under an orthographic camera (a scattering point has no footprint; its ray keeps the spread it
had). In a light's own shading (PATH_EMISSION) the Bump's Normal is the zero vector (lit_by_bump: Cycles
evaluates no bump nodes there). Where Primer does not know the cone (UNKNOWN_CONE: a shading point without a
path, a panoramic ray with no neighbouring direction) the step is BUMP_STEP of the triangle's edges V1 - V0
and V2 - V0, a derivative where Cycles' difference averages over the footprint. A material of Displacement Method
Displacement and Bump bumps over its surface as it was before the vertices moved (UNDISPLACED ops around the
bump: undisplaced_point, undisplaced_differentials), in object space, as Cycles' ENTER_BUMP_EVAL.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, field
from typing import NamedTuple, Optional

import numpy as np

from ..native import library, schema
from ..native.schema import F64, I32, I64, ptr
from . import sky as sky_
from . import textures as textures_
from .converters import CONVERTER_BY_KIND, CONVERTER_TYPES
from .converters import color as color_
from .converters.colorspace import RGB_TO_Y
from .procedural import TEXTURE_BY_KIND, TEXTURE_TYPES
from .procedural import hash as hash_
from .procedural.base import F32

# The described nodes (one class each: core/materials/procedural's textures, core/materials/converters' converter and
# colour nodes): compiled from their description (Compiler.texture), one op each.
DESCRIBED = TEXTURE_TYPES + CONVERTER_TYPES
DESCRIBED_BY_KIND = {**TEXTURE_BY_KIND, **CONVERTER_BY_KIND}

# Op codes (graph.c's OP_*), and the width of one op's record: the code and up to OP_ARGS arguments. The
# described nodes' ops (DESCRIBED: the procedural textures, then the converters; one per class) follow graph.c's own.
OPS = ("ATTR", "RANDOM", "IMAGE", "MAPPING", "MATH", "MIX_COLOR", "MIX_FLOAT", "RAMP", "INVERT", "HSV",
       "COPY", "CLAMP", "MAP_RANGE", "NORMAL_MAP", "BUMP", "OFFSET", "CONVERT", "SCALE", "LIGHT_PATH",
       "TANGENT") + tuple(cls.kind for cls in DESCRIBED) + ("FRESNEL", "LAYER_WEIGHT", "GEOMETRY", "TRANSFORM",
                                                               "CAMERA_DATA", "WIREFRAME", "WINDOW", "SKY",
                                                               "OBJECT_INFO", "OBJECT_MATRIX", "AO", "BEVEL",
                                                               "PIXEL_SIZE", "CURVE_NORMAL", "SET_NORMAL",
                                                               "TANGENT_SPACE", "FOOTPRINT", "UNDISPLACED",
                                                               "AOV_START")
# Ops that trace rays into the scene while the shader runs (Cycles' __SHADER_RAYTRACE__ nodes: Ambient Occlusion,
# Bevel). A program holding one reads ShadingPoint.rays, the integrator's ShaderRays (core/integrators/shader_rays.py)
# for the hits' pixel samples; where there is none (shadow rays, light samples landing on an emitter: Cycles
# evaluates those shaders without ray tracing too) Ambient Occlusion gives 1 and Bevel the shading normal.
RAYTRACE_OPS = ("AO", "BEVEL")
# The Ambient Occlusion node's options (the AO op's flags; Cycles' NODE_AO_*).
AO_INSIDE, AO_ONLY_LOCAL = schema.constants("AO", {"INSIDE": 1, "ONLY_LOCAL": 2},
                                            "the Ambient Occlusion node's option bits").values()
OP = schema.constants("OP", OPS, "a node-graph program's op codes")
schema.table("OP", lambda: list(OPS))
# What a shader knows of the path that reached a hit (Cycles' path_flag and bounce counters; the Light Path node
# reads it): which kind of ray found the hit, as bits, and the path's bounces so far. A camera ray, and one that
# went on from it straight through transparent surfaces, carries CAMERA; after a real bounce the ray carries that
# bounce's labels (REFLECT or TRANSMIT; DIFFUSE, GLOSSY, or GLOSSY and SINGULAR), and a transparent bounce keeps
# them (path_state_next; a Ray Portal's is a transparent bounce, counted in `portal` as well). A shadow ray through
# a transparent surface carries SHADOW alone (and the path's counts), a light sample landing
# on an emitter EMISSION alone (both are one bounce further: Ray Depth adds one). VOLUME_SCATTER is for volumes.
# CLEAR_GLASS (no Light Path output reads it): a camera path that went on through glass under Film > Transparent
# Glass's roughness threshold alone (rays.path_after), which a transparent film sees through as a camera path
# (Cycles keeps PATH_RAY_TRANSPARENT_BACKGROUND there: the world it escapes to is the film's alpha, not its colour).
PATH_FLAGS = ("camera", "shadow", "diffuse", "glossy", "singular", "reflect", "transmit", "volume_scatter", "emission",
              "clear_glass")
PATH = schema.constants("PATH", {name: 1 << index for index, name in enumerate(PATH_FLAGS)},
                        "the bits of a LightPath's flags (Cycles' PATH_RAY_*)")
PATH_CAMERA, PATH_SHADOW, PATH_EMISSION = PATH["camera"], PATH["shadow"], PATH["emission"]
# The paths a transparent film sees through to the world (Cycles' PATH_RAY_TRANSPARENT_BACKGROUND).
PATH_CLEARS_FILM = PATH_CAMERA | PATH["clear_glass"]
schema.constant("PATH_CLEARS_FILM", PATH_CLEARS_FILM, "the paths a transparent film sees the world through")
LightPath = schema.record("LightPath", "What a shader knows of the path that reached a hit (the Light Path node).", [
    ("flags", I32, "PATH_* bits: the kind of ray that found the hit"),
    ("bounce", I32, "the path's real bounces so far (Cycles' bounce)"),
    ("diffuse", I32, "of those, diffuse reflections"),
    ("glossy", I32, "glossy and mirror reflections"),
    ("transmission", I32, "bounces through the surface"),
    ("transparent", I32, "transparent surfaces passed straight through, the whole path's"),
    ("portal", I32, "of those, Ray Portals passed (Cycles' portal_bounce: they count as transparent ones too)"),
    ("cone", F64, "the ray's footprint where it left (Cycles' compact ray differential dP; UNKNOWN_CONE: unknown)"),
    ("spread", F64, "how fast the footprint widens along it: the camera ray's (dD, kept through bounces)"),
])
# Which of them are floats (the others are counts and bits).
LIGHT_PATH_FLOATS = ("cone", "spread")
# The same fields, one (n,) array each (int64, float64 for LIGHT_PATH_FLOATS), for n hits at once (ShadingPoint.path).
LightPaths = namedtuple("LightPaths", [f.name for f in LightPath._description])
LightPaths.__doc__ = "A LightPath per hit: each field (n,) int64, cone and spread float64 (or a scalar for all)."
# The Light Path node's outputs, in the LIGHT_PATH op's numbering (LP_*): Cycles' svm_node_light_path.
LIGHT_PATH_OUTPUTS = ("Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray", "Is Glossy Ray", "Is Singular Ray",
                      "Is Reflection Ray", "Is Transmission Ray", "Is Volume Scatter Ray", "Ray Length", "Ray Depth",
                      "Diffuse Depth", "Glossy Depth", "Transparent Depth", "Transmission Depth", "Portal Depth")
schema.constants("LP", [name.replace(" ", "_") for name in LIGHT_PATH_OUTPUTS], "the Light Path node's outputs")
# Which flag each "Is ... Ray" output reads (its flag's bit), in output order.
LIGHT_PATH_FLAG_OF = {"Is Camera Ray": "camera", "Is Shadow Ray": "shadow", "Is Diffuse Ray": "diffuse",
                      "Is Glossy Ray": "glossy", "Is Singular Ray": "singular", "Is Reflection Ray": "reflect",
                      "Is Transmission Ray": "transmit", "Is Volume Scatter Ray": "volume_scatter"}


def light_paths(n: int, flags=PATH_CAMERA, bounce=0, diffuse=0, glossy=0, transmission=0,
                transparent=0, portal=0, cone=0.0, spread=0.0) -> "LightPaths":
    """n hits' LightPaths, each field (n,) int64 (cone, spread float64) from a scalar or an (n,) array (the
    default: camera rays with no footprint, as a light's sample is shaded)."""
    values = (flags, bounce, diffuse, glossy, transmission, transparent, portal, cone, spread)
    return as_light_paths(values, n)


def as_light_paths(values, n: int) -> "LightPaths":
    """LightPaths of n hits from its fields' values in order, each a scalar or (n,): int64 arrays, float64 for
    LIGHT_PATH_FLOATS."""
    return LightPaths(*(np.broadcast_to(np.asarray(v, np.float64 if name in LIGHT_PATH_FLOATS else np.int64),
                                        (n,)).copy() for name, v in zip(LightPaths._fields, values)))


def footprints(paths: "LightPaths", t) -> np.ndarray:
    """The rays' footprints (n,) at hits t (n,) along them (Cycles' differential_transfer_compact: dP + t dD);
    UNKNOWN_CONE where the cone is unknown (its spread is 0)."""
    return paths.cone + np.asarray(t, np.float64) * paths.spread


def paths_at(paths: "LightPaths", rows) -> "LightPaths":
    """The LightPaths of the hits `rows` (an index array or a mask) of `paths`."""
    return LightPaths(*(np.asarray(f)[rows] for f in paths))


def with_flags(paths: "LightPaths", flags: int) -> "LightPaths":
    """The same paths' counts with every ray's flags `flags` (a shadow ray's SHADOW, a light's EMISSION)."""
    return paths._replace(flags=np.full(len(paths.flags), flags, np.int64))


def light_path_output(output: int, path: "LightPaths", t: np.ndarray) -> np.ndarray:
    """The Light Path node's output number `output` (LIGHT_PATH_OUTPUTS) at n hits: (n,) float64. path: their
    LightPaths; t: (n,) the ray lengths."""
    name = LIGHT_PATH_OUTPUTS[output]
    if name in LIGHT_PATH_FLAG_OF:
        return ((path.flags & PATH[LIGHT_PATH_FLAG_OF[name]]) != 0).astype(np.float64)
    if name == "Ray Length":
        return np.asarray(t, np.float64)
    if name == "Ray Depth":                       # a shadow ray and a light's own shading: one bounce further
        return (path.bounce + ((path.flags & (PATH_SHADOW | PATH_EMISSION)) != 0)).astype(np.float64)
    field = {"Diffuse Depth": "diffuse", "Glossy Depth": "glossy", "Transparent Depth": "transparent",
             "Transmission Depth": "transmission", "Portal Depth": "portal"}[name]
    return getattr(path, field).astype(np.float64)


OP_ARGS = 15
schema.constant("OP_WIDTH", 1 + OP_ARGS, "one op's record: the code and its arguments")
# At most this many registers per program, attribute floats per hit.
MAX_REGISTERS = schema.constant("MAX_REGISTERS", 1024, "a program's registers at most")
PROGRAM_INFO = schema.constant("PROGRAM_INFO", 9, "one program's row of GraphTables.programs")
MAX_ATTRIBUTES = schema.constant("MAX_ATTRIBUTES", 64, "attribute floats per hit at most")
# The bump's finite-difference step, as a fraction of the triangle's edges.
BUMP_STEP = schema.constant("BUMP_STEP", 1e-3, "the bump's finite-difference step, a fraction of the edges")
# A ray cone Primer does not know (a panoramic ray with no direction a pixel away, and the path it starts), with
# spread 0: Bump steps by BUMP_STEP there. A cone of 0 and spread 0 is a footprint of 0 (Cycles' zero differential).
UNKNOWN_CONE = schema.constant("UNKNOWN_CONE", -1.0, "a ray cone Primer does not know (graph.py)")
# A Bump node's Filter Width where Blender has none (Cycles' BumpNode default; also its Displacement's bump).
BUMP_FILTER_WIDTH = 0.1
# Luminance of scene linear (Cycles' rgb_to_y with Blender's colour configuration, as float32: colour to float
# conversions; graph.c reads the same table, RGB_TO_Y).
LUMINANCE = tuple(float(np.float32(v)) for v in RGB_TO_Y)

MATH_OPS = ("ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT", "INVERSE_SQRT",
            "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN", "SIGN", "COMPARE", "ROUND",
            "FLOOR", "CEIL", "TRUNC", "FRACT", "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SINE",
            "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS",
            "DEGREES", "SMOOTH_MIN", "SMOOTH_MAX")
BLEND_TYPES = ("MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD", "OVERLAY", "SUBTRACT",
               "DIVIDE", "DIFFERENCE", "EXCLUSION", "SOFT_LIGHT", "LINEAR_LIGHT", "HUE", "SATURATION", "VALUE", "COLOR")
# The blend modes that mix in HSV (Cycles' svm_mix_hue, _sat, _val, _color), in float32 as Cycles' colour model.
HSV_BLENDS = ("HUE", "SATURATION", "VALUE", "COLOR")
MAPPING_TYPES = ("POINT", "TEXTURE", "VECTOR", "NORMAL")
MAP_RANGE_TYPES = ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP")
# Program outputs: what a register does to a shader node (OUT_*).
OUT_INPUT, OUT_WEIGHT, OUT_NORMAL, OUT_AOV = schema.constants(
    "OUT", ("input", "weight", "normal", "aov"), "what a program's output does to a shader node (AOV: to a shader "
    "AOV's channels instead)").values()
# An AOV Output node (Material.aovs) compiles after an AOV_START op, as Cycles' NODE_AOV_START: the ops after it feed
# only shader AOVs, and run only where the hit writes them (a camera chain's vertex before its opaque-enough one: the
# compiled kernel's ShadingPoint.aov). Its output row is [OUT_AOV, first channel of its AOV (core/integrators/passes.py
# aov_slots), 0, 3 (COLOR: its Color, and 1 into the alpha channel after it) or 1 (VALUE: its Value), register].
# How a weight factor multiplies a node's weight: by the value, by 1 - the value, by a colour.
WEIGHT_MODES = {"fac": 0, "one_minus": 1, "color": 2}


@dataclass(eq=False)
class GraphNode:
    """A texture or colour node: its kind (a key of NODE_OUTPUTS), properties and inputs.

    inputs: socket name -> a constant (float or (3,)) or a Link; props: the node's settings (for
    IMAGE: "image" a textures.Image or None when missing, "interpolation", "extension", "unassociate" (Cycles divides the
    colour back by the alpha where the Alpha output is read: Compiler.mark_unassociate); for RAMP:
    "table" (256, 4) float64 and "interpolate").
    """

    kind: str
    props: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    name: str = ""


@dataclass(frozen=True, eq=False)
class Link:
    """An output of a GraphNode, feeding an input."""

    node: GraphNode
    output: str


# The Particle Info outputs in an instance's 16 Particle Info columns (its Object Info's, from props["column"], filled
# at export: addon/materials.py particle_columns): name -> (offset, width).
PARTICLE_INFO_COLUMNS = {"Index": (0, 1), "Age": (1, 1), "Lifetime": (2, 1), "Size": (3, 1), "Location": (4, 3),
                         "Random": (7, 1), "Velocity": (8, 3), "Angular Velocity": (12, 3)}
# Each kind's outputs: name -> (width, type); type decides how a colour or vector becomes a float.
NODE_OUTPUTS = {
    "RGB": {"Color": (3, "color")}, "VALUE": {"Value": (1, "float")},
    "TEXCOORD": {"UV": (3, "vector"), "Generated": (3, "vector"), "Object": (3, "vector"), "Normal": (3, "vector"),
                 "Camera": (3, "vector"), "Window": (3, "vector"), "Reflection": (3, "vector")},
    "CAMERA_DATA": {"View Vector": (3, "vector"), "View Z Depth": (1, "float"), "View Distance": (1, "float")},
    "WIREFRAME": {"Fac": (1, "float")},
    "AO": {"Color": (3, "color"), "AO": (1, "float")}, "BEVEL": {"Normal": (3, "vector")},
    "UVMAP": {"UV": (3, "vector")},
    "ATTRIBUTE": {"Color": (3, "color"), "Vector": (3, "vector"), "Fac": (1, "float"), "Alpha": (1, "float")},
    "INSTANCE_ATTRIBUTE": {"Color": (3, "color"), "Vector": (3, "vector"), "Fac": (1, "float"), "Alpha": (1, "float")},
    "PARTICLE_INFO": {name: (width, "vector" if width == 3 else "float")
                      for name, (_, width) in PARTICLE_INFO_COLUMNS.items()},
    "POINT_INFO": {"Position": (3, "vector"), "Radius": (1, "float"), "Random": (1, "float")},
    "VOLUME_INFO": {"Color": (3, "color"), "Density": (1, "float"), "Flame": (1, "float"), "Temperature": (1, "float")},
    "CURVES_INFO": {"Is Strand": (1, "float"), "Intercept": (1, "float"), "Length": (1, "float"),
                    "Thickness": (1, "float"), "Random": (1, "float"), "Tangent Normal": (3, "vector")},
    "OBJECT_INFO": {"Location": (3, "vector"), "Color": (3, "color"), "Alpha": (1, "float"),
                    "Object Index": (1, "float"), "Material Index": (1, "float"), "Random": (1, "float")},
    "LIGHT_PATH": {name: (1, "float") for name in LIGHT_PATH_OUTPUTS},
    "IMAGE": {"Color": (3, "color"), "Alpha": (1, "float")}, "ENVIRONMENT": {"Color": (3, "color"), "Alpha": (1, "float")},
    "SKY": {"Color": (3, "color")},
    "MAPPING": {"Vector": (3, "vector")}, "NORMAL_MAP": {"Normal": (3, "vector")}, "BUMP": {"Normal": (3, "vector")},
    "MATH": {"Value": (1, "float")}, "MIX": {"Result": (3, "color")},
    "RAMP": {"Color": (3, "color"), "Alpha": (1, "float")}, "INVERT": {"Color": (3, "color")},
    "HSV": {"Color": (3, "color")},
    "SEPARATE_COLOR": {"Red": (1, "float"), "Green": (1, "float"), "Blue": (1, "float")},
    "SEPARATE_XYZ": {"X": (1, "float"), "Y": (1, "float"), "Z": (1, "float")},
    "COMBINE_COLOR": {"Color": (3, "color")}, "COMBINE_XYZ": {"Vector": (3, "vector")},
    "CLAMP": {"Result": (1, "float")}, "MAP_RANGE": {"Result": (1, "float")}, "SCALE": {"Color": (3, "color")},
    "TANGENT": {"Tangent": (3, "vector")}, "TANGENT_SPACE": {"Vector": (3, "vector")},
    "FRESNEL": {"Fac": (1, "float")}, "LAYER_WEIGHT": {"Fresnel": (1, "float"), "Facing": (1, "float")},
    "VECTOR_TRANSFORM": {"Vector": (3, "vector")},
    "GEOMETRY": {"Position": (3, "vector"), "Normal": (3, "vector"), "Tangent": (3, "vector"),
                 "True Normal": (3, "vector"), "Incoming": (3, "vector"), "Parametric": (3, "vector"),
                 "Backfacing": (1, "float"), "Pointiness": (1, "float"), "Random Per Island": (1, "float")},
    **{cls.kind: dict(cls.outputs) for cls in DESCRIBED},
}
# The Object Info outputs an OBJECT_INFO op copies from the instance's info (geometry.instance_info): (start, width).
OBJECT_INFO_COLUMNS = {"Location": (0, 3), "Color": (3, 3), "Alpha": (6, 1), "Object Index": (7, 1),
                       "From Instancer Generated": (8, 3), "From Instancer UV": (11, 3)}
# The Curves Info outputs, each a mesh attribute of the tubes curves become (0 on other meshes, as Cycles' off strands).
CURVES_INFO_ATTRIBUTES = {"Is Strand": "curve:strand", "Intercept": "curve:intercept", "Length": "curve:length",
                          "Thickness": "curve:thickness", "Random": "curve:random", "Tangent Normal": "curve_tangent"}
# The Point Info outputs, each a mesh attribute of the spheres a point cloud becomes (core/geometry/points.py
# point_info; zeros on other meshes, as Cycles' point_position, point_radius and point_random off points):
# the point's centre in object space and 1 (4 floats), its radius / sqrt(3) thrice (3), its random number (1).
POINT_INFO_ATTRIBUTES = {"Position": "point_centre", "Radius": "point_radius", "Random": "point_random"}
# The Geometry node's outputs the GEOMETRY op reads from the ShadingPoint, in its numbering (Tangent is a TANGENT op).
GEOMETRY_OUTPUTS = ("Position", "Normal", "True Normal", "Incoming", "Parametric", "Backfacing", "Object Normal",
                    "Reflection")
SCALAR_OUTPUTS = ("Backfacing",)                        # one float; the others three
schema.constants("GEOM", [name.replace(" ", "_") for name in GEOMETRY_OUTPUTS], "the Geometry node's outputs")
# The Tangent node's directions and axes (props "direction", "axis"), as Blender names them.
TANGENT_DIRECTIONS = ("RADIAL", "UV_MAP")
TANGENT_AXES = ("X", "Y", "Z")


def object_random(name: str) -> float:
    """An object's random number as Cycles gives one not made by instancing: hash_uint2(hash_string(name), 0)
    as a float in 0..1 (Cycles' util/hash.h, scene/object.cpp)."""
    h = 0
    for byte in name.encode("utf-8"):
        c = byte - 256 if byte > 127 else byte           # C's signed char, widened to uint
        h = (h * 37 + c) & 0xFFFFFFFF
    return random_from_id(int(hash_.hash_uint2(h, 0)))


# Cycles' RAMP_TABLE_SIZE. Blender's sync bakes a Color Ramp at i / 256 for i = 0 .. 256 (colorramp_to_array's
# full_size, size + 1 entries) and the kernel reads entry floor(f x 256) (svm/ramp.h, table_size - 1 = 256): a
# Constant ramp changes colour at the first of those points at or past each stop.
RAMP_TABLE_SIZE = 256


def ramp_table(evaluate) -> np.ndarray:
    """A Color Ramp's table as Cycles bakes it: `evaluate(position)` -> RGBA at position = i / RAMP_TABLE_SIZE for
    i = 0 .. RAMP_TABLE_SIZE; (RAMP_TABLE_SIZE + 1, 4) float64 (the RAMP op's props["table"])."""
    return np.array([evaluate(np.float32(i) / np.float32(RAMP_TABLE_SIZE))[:4] for i in range(RAMP_TABLE_SIZE + 1)],
                    np.float64)


def random_from_id(random_id: int) -> float:
    """Cycles' object random number from a 32-bit random id: float(id) x (1 / 0xFFFFFFFF), in float32."""
    return float(np.float32(np.float32(random_id & 0xFFFFFFFF) * np.float32(1.0 / 0xFFFFFFFF)))


class Program(NamedTuple):
    """A material's compiled sub-graphs (graph.c Program).

    ops: (k, 1 + OP_ARGS) float64 op records; constants: (c,) float64, registers 0 .. c - 1;
    registers: R, how many a hit needs; outputs: (m, 5) float64 rows (kind OUT_*, shader node, slot or
    weight mode, width, register; OUT_NORMAL to slot 0 is the node's normal, to another slot a normal input);
    ramps: (r,) float64 colour-ramp tables, 256 RGBA rows each; taps: (node name, output, register, width, type)
    of each named node's output the graph computes at the hit (what the ray inspector shows; not read in C);
    blocks: (b, 2) int64 (first register, width) of each computed register block as the compiler made it (empty:
    unknown, every op counts as live in `live_ops`).
    """

    ops: np.ndarray
    constants: np.ndarray
    registers: int
    outputs: np.ndarray
    ramps: np.ndarray
    taps: tuple = ()
    blocks: np.ndarray = np.zeros((0, 2), np.int64)


class ShadingPoint(NamedTuple):
    """What a program reads at n hits (graph.c ShadingPoint).

    attributes, d_du, d_dv: (n, A) float64 the attributes at the hit and their changes along the
    triangle's barycentric u and v (corner 1 - corner 0, corner 2 - corner 0); random: (n,) float64
    the object's random number; N: (n, 3) the shading normal facing the viewer; side: (n,) +1 where the
    front was hit, -1 the back; linear: (n, 3, 3) the object's linear transform (for tangents);
    dPdu, dPdv: (n, 3) the triangle's edges V1 - V0, V2 - V0; Ng: (n, 3) the face normal facing the viewer;
    path: the LightPaths of the rays that found the hits (None: camera rays); I: (n, 3) the unit direction from the
    hit back along the ray that found it (Cycles' sd->wi, the material's wo; None: N, a head-on view);
    P: (n, 3) the hit in world space (not camera-relative); uv: (n, 2) its barycentrics u, v (corner 1, corner 2);
    t: (n,) the distance the ray went to the hit (Cycles' ray_length); info: (n, 8 + 4 k) the object's Object Info
    (geometry.instance_info: location, colour, alpha, pass index, then the RGBA of its k Object and Instancer
    attributes).
    """

    attributes: np.ndarray
    d_du: np.ndarray
    d_dv: np.ndarray
    random: np.ndarray
    N: np.ndarray
    side: np.ndarray
    linear: np.ndarray
    dPdu: np.ndarray
    dPdv: np.ndarray
    Ng: np.ndarray
    path: "LightPaths" = None  # the paths that found the hits (the Light Path node)
    I: np.ndarray = None       # (n, 3) float64 towards where the ray came from (the Fresnel and Layer Weight nodes)
    P: np.ndarray = None       # (n, 3) float64 the world point (the Geometry node's Position)
    uv: np.ndarray = None      # (n, 2) float64 the barycentrics (its Parametric)
    t: np.ndarray = None       # (n,) float64 the distance along the ray to the hit (the Light Path node's Ray Length)
    info: np.ndarray = None    # (n, 8 + 4 k) float64 its Object Info: location, colour, alpha, pass index, attributes
    rays: object = None        # the integrator's ShaderRays of the n hits (AO, BEVEL ops); None: they trace nothing


def object_matrices(sp: ShadingPoint, mode: int) -> np.ndarray:
    """The hit objects' transforms for OBJECT_MATRIX, (n, 12) float64 3 x 4 row by row: mode 0 object to world (its
    linear part and location), 1 world to object, 2 and 3 their linear parts alone, 4 the inverse's linear part
    transposed (normals to world), 5 the linear part transposed (normals to object)."""
    n = len(sp.linear)
    L = np.asarray(sp.linear, np.float64).reshape(n, 3, 3)
    location = np.zeros((n, 3)) if sp.info is None else sp.info[:, :3]
    with np.errstate(all="ignore"):
        inverse = np.linalg.inv(np.where(np.abs(np.linalg.det(L))[:, None, None] > 0.0, L, np.eye(3)))
    linear = {0: L, 1: inverse, 2: L, 3: inverse, 4: np.swapaxes(inverse, 1, 2), 5: np.swapaxes(L, 1, 2)}[mode]
    move = {0: location, 1: -np.einsum("nij,nj->ni", inverse, location)}.get(mode, np.zeros((n, 3)))
    return np.concatenate([linear, move[:, :, None]], axis=2).reshape(n, 12)


def has_links(nodes: list) -> bool:
    """Whether a material's shader nodes ((name, weight, inputs[, factors]) each) have any linked input."""
    for entry in nodes:
        if len(entry) > 3 and entry[3]:
            return True
        if any(isinstance(value, Link) for value in entry[2].values()):
            return True
    return False


def links_under(nodes: list):
    """Yield every Link a material's nodes reach (its inputs' and factors' links, and theirs, down the graph),
    each node's inputs followed once, each (node, output) pair once."""
    followed, given = set(), set()
    stack = [value for entry in nodes for value in entry[2].values()]
    stack += [link for entry in nodes for link, _ in (entry[3] if len(entry) > 3 else ())]
    while stack:
        value = stack.pop()
        if not isinstance(value, Link):
            continue
        if (id(value.node), value.output) not in given:
            given.add((id(value.node), value.output))
            yield value
        if id(value.node) not in followed:
            followed.add(id(value.node))
            stack.extend(value.node.inputs.values())


def with_normal(nodes: list, normal, displacement=None, aovs=()) -> list:
    """A material's nodes with its Set Normal Link (Material.normal), and its true displacement's Link
    (Material.displacement) if given, and the inputs of its AOV Output nodes (Material.aovs: (name, color, value)
    each), as more entries, for what walks its links (links_under, images_of, attributes_of, traces); the nodes
    alone where it has none."""
    extra = [(None, 1.0, {"normal": normal})] if isinstance(normal, Link) else []
    extra += [(None, 1.0, {"displacement": displacement})] if isinstance(displacement, Link) else []
    extra += [(None, 1.0, {"color": color, "value": value}) for _, color, value in aovs]
    return list(nodes) + extra


def traces(nodes: list) -> bool:
    """Whether a material's links reach a node that traces rays (RAYTRACE_OPS: Ambient Occlusion, Bevel)."""
    return any(link.node.kind in RAYTRACE_OPS for link in links_under(nodes))


def images_of(nodes: list) -> list:
    """The textures.Image objects (or None for missing ones) of every image node (IMAGE, ENVIRONMENT) under a
    material's links."""
    found, seen = [], set()
    for link in links_under(nodes):
        if link.node.kind in ("IMAGE", "ENVIRONMENT") and id(link.node) not in seen:
            seen.add(id(link.node))
            found.append(link.node.props.get("image"))
    return found


def attributes_of(nodes: list) -> set:
    """The mesh attribute names a material's links read ("uv:NAME", "color:NAME", "attr:NAME" (an Attribute node's:
    Alpha 1 where missing), "tangent:NAME", "generated", "object", "pointiness", "island" (Random Per Island); an
    empty NAME is the mesh's active one)."""
    names = set()
    for link in links_under(nodes):
        node = link.node
        if node.kind == "TEXCOORD" and (link.output in ("UV", "Generated") and not node.props.get("from_instancer")
                                        or link.output == "Object" and node.props.get("object_matrix") is None):
            names.add({"UV": "uv:", "Generated": "generated", "Object": "object"}[link.output])
        elif node.kind == "UVMAP":
            names.add("uv:" + node.props.get("map", ""))
        elif node.kind == "ATTRIBUTE":
            names.add(node.props.get("attribute", "color:"))
        elif node.kind in ("NORMAL_MAP", "TANGENT_SPACE"):
            names.add("tangent:" + node.props.get("map", ""))
        elif node.kind == "CURVES_INFO":
            names.add(CURVES_INFO_ATTRIBUTES[link.output])
        elif node.kind == "POINT_INFO":
            names.add(POINT_INFO_ATTRIBUTES[link.output])
        elif node.kind == "TANGENT":
            names.add("generated" if node.props.get("direction", "RADIAL") == "RADIAL"
                      else "tangent:" + node.props.get("map", ""))
        elif node.kind == "GEOMETRY" and link.output in ("Tangent", "Pointiness", "Random Per Island"):
            names.add({"Tangent": "generated", "Pointiness": "pointiness", "Random Per Island": "island"}[link.output])
        elif node.kind == "IMAGE" and not isinstance(node.inputs.get("Vector"), Link):
            names.add("uv:")
        elif node.kind == "SKY" and not isinstance(node.inputs.get("Vector"), Link):
            names.add("generated")                  # (a world's shading point has it always)
        elif node.kind in DESCRIBED_BY_KIND:
            texture = DESCRIBED_BY_KIND[node.kind]
            names.update(default for name, _, default in texture.inputs
                         if isinstance(default, str) and default not in COMPUTED_COORDINATES
                         and not isinstance(node.inputs.get(name), Link))
    return names


# The default coordinates of a described node's unlinked input that are computed at the hit, not read from the mesh
# (Compiler.coordinate): "incoming_object", Cycles' LINK_TEXTURE_INCOMING (the IES Texture's Vector), Geometry >
# Incoming taken from world to object space as a normal.
INCOMING_OBJECT = "incoming_object"
COMPUTED_COORDINATES = (INCOMING_OBJECT,)


# The widths of the mesh attributes by name prefix.
ATTRIBUTE_WIDTHS = {"uv": 3, "color": 4, "attr": 4, "tangent": 4, "generated": 3, "object": 3, "pointiness": 1, "island": 1,
                    "curve": 1, "curve_tangent": 3, "curve_normal": 3, "triangle_dpdu": 3, "triangle_dpdv": 3,
                    "point_centre": 4, "point_radius": 3, "point_random": 1,
                    "undisplaced_position": 3, "undisplaced_normal": 3, "motion": 3}


def attribute_width(name: str) -> int:
    """How many floats a mesh attribute takes per corner."""
    return ATTRIBUTE_WIDTHS[name.split(":")[0]]


def layout_of(names) -> dict:
    """The attribute layout of a scene: name -> (offset, width), names sorted."""
    layout, offset = {}, 0
    for name in sorted(names):
        layout[name] = (offset, attribute_width(name))
        offset += attribute_width(name)
    return layout


class Compiler:
    """Turns one material's links into a Program (`compile`): registers, ops, outputs."""

    def __init__(self, layout: dict, image_index, warnings: Optional[list] = None, material: str = "", view=None,
                 window=None):
        self.layout = layout
        self.view = np.eye(4)[:3] if view is None else np.asarray(view, np.float64).reshape(3, 4)   # world -> camera
        self.window = window                    # the camera's frame on screen (MaterialTable.window) or None
        self.image_index = image_index          # textures.Image or None -> index in the render's TextureSet
        self.constants: list = []
        self.ops: list = []
        self.outputs: list = []
        self.ramps: list = []
        self.sky_starts: dict = {}
        self.next = 0                           # registers after the constants are numbered at the end
        self.memo: dict = {}
        self.taps: dict = {}                    # (node name, output) -> (register, width, type) at the hit
        self.offset = 0                         # the bump's evaluation point: 0 the hit, 1 along x, 2 along y
        self.offset_width = None                # the register of that bump's Filter Width (None at the hit)
        self.temporaries = 0
        self.blocks: list = []                  # (first temporary, width) of each block `temporary` made
        self.warnings = warnings if warnings is not None else []
        self.material = material
        self.image_ops: dict = {}               # id of an Image Texture GraphNode -> its IMAGE ops
        self.alpha_read: set = set()            # ids of the Image Texture GraphNodes whose Alpha output is read

    # Registers: constants are numbered 0.. in order; computed registers get negative provisional
    # numbers -1, -2, ... and are renumbered after the constants when the program is done.
    def constant(self, values) -> int:
        """A new constant register (start) holding `values` (float or sequence)."""
        values = np.atleast_1d(np.asarray(values, np.float64)).reshape(-1)
        start = len(self.constants)
        self.constants.extend(values.tolist())
        return start

    def temporary(self, width: int) -> int:
        """A new computed register of `width` floats (a provisional negative number, see `compile`)."""
        start = self.temporaries
        self.temporaries += width
        self.blocks.append((start, width))
        return -1 - start

    def emit(self, name: str, *args) -> None:
        """Append op `name` with its arguments (registers provisional, renumbered by `compile`)."""
        if len(args) > OP_ARGS:
            raise ValueError(f"op {name} has too many arguments")
        self.ops.append([OP[name]] + list(args))

    def value(self, source, width: int, default=0.0) -> int:
        """A register (start) holding `source` (a constant or a Link) as `width` floats."""
        if isinstance(source, Link):
            reg, w, kind = self.link(source)
            if w == width:
                return reg
            out = self.temporary(width)
            if width == 1:
                self.emit("CONVERT", out, reg, 0 if kind == "color" else 1)
            else:
                self.emit("CONVERT", out, reg, 2)
            return out
        value = np.atleast_1d(np.asarray(default if source is None else source, np.float64)).reshape(-1)
        if width == 1:
            return self.constant(value[:1] if len(value) == 1 else [float(np.mean(value[:3]))])
        if len(value) == 1:
            value = np.repeat(value, 3)
        return self.constant(value[:3])

    def link(self, link: Link) -> tuple:
        """(register, width, type) of a link's output, compiled once per bump evaluation point."""
        key = (id(link.node), link.output, self.offset, self.offset_width if self.offset else None)
        if key not in self.memo:
            self.memo[key] = self.compile_node(link.node, link.output)
            if self.offset == 0 and link.node.name:         # (after a Set Normal: the value the rest reads)
                self.taps[(link.node.name, link.output)] = self.memo[key]
        return self.memo[key]

    def attribute(self, name: str, width: int = 3) -> int:
        """A register reading a mesh attribute (zeros where the scene has none of that name)."""
        out = self.temporary(width)
        offset, stored = self.layout.get(name, (-1, width))
        self.emit("ATTR", out, offset, min(width, stored), width)
        return out

    def coordinate(self, name: str, width: int = 3) -> int:
        """A register holding a described node's default coordinate `name`: INCOMING_OBJECT computed at the hit, any
        other a mesh attribute (`attribute`)."""
        if name == INCOMING_OBJECT:
            return self.vector_transform(self.geometry("Incoming"), "NORMAL", "WORLD", "OBJECT")
        return self.attribute(name, width)

    def geometry(self, output: str) -> int:
        """A register (3 floats) holding the Geometry op's `output` (GEOMETRY_OUTPUTS)."""
        out = self.temporary(3)
        self.emit("GEOMETRY", out, GEOMETRY_OUTPUTS.index(output))
        return out

    def transform(self, point: int, matrix: np.ndarray) -> int:
        """A register holding the point in register `point` moved by the (3, 4) affine `matrix` (its 12 floats
        constants, row by row)."""
        out = self.temporary(3)
        self.emit("TRANSFORM", out, point, self.constant(np.asarray(matrix, np.float64).reshape(12)))
        return out

    def vector_transform(self, v: int, kind: str, source: str, target: str) -> int:
        """A register holding the vector in register `v` (a POINT, VECTOR or NORMAL) taken between world, camera and
        object space as Cycles' Vector Transform does (svm_node_vector_transform): through world space, a point by the
        affine transform, a vector by its linear part, a normal by the other direction's transposed linear part, then
        normalised; object space is the hit object's (OBJECT_MATRIX); unchanged between equal spaces."""
        if source == target:
            return v
        if source != "WORLD":
            v = self.space_step(v, kind, source, to_world=True)
        return v if target == "WORLD" else self.space_step(v, kind, target, to_world=False)

    def space_step(self, v: int, kind: str, space: str, to_world: bool) -> int:
        """A register holding the vector in register `v` taken from camera or object `space` to world space, or back
        (vector_transform's steps)."""
        if space == "OBJECT":
            # The hit object's 3 x 4 transform, or its inverse; a normal takes the other's transposed linear part.
            mode = {("POINT", True): 0, ("POINT", False): 1, ("VECTOR", True): 2, ("VECTOR", False): 3,
                    ("NORMAL", True): 4, ("NORMAL", False): 5}[kind, to_world]
            matrix = self.temporary(12)
            self.emit("OBJECT_MATRIX", matrix, mode)
            out = self.temporary(3)
            self.emit("TRANSFORM", out, v, matrix)
            return out if kind != "NORMAL" else self.normalized(out)
        to_camera = self.view
        to_world_matrix = np.linalg.inv(np.vstack([to_camera, [0.0, 0.0, 0.0, 1.0]]))[:3]
        forward, back = (to_world_matrix, to_camera) if to_world else (to_camera, to_world_matrix)
        if kind == "POINT":
            return self.transform(v, forward)
        if kind == "VECTOR":
            return self.transform(v, np.hstack([forward[:, :3], np.zeros((3, 1))]))
        return self.normalized(self.transform(v, np.hstack([back[:, :3].T, np.zeros((3, 1))])))

    def point_info(self, output: str) -> int:
        """A register holding the Point Info `output` in world space, as Cycles' point_position, point_radius and
        point_random: the centre c (w = 1 on points, 0 elsewhere) as L c + t w (L, t the object's linear part and
        translation), the radius as |L (r, r, r) / sqrt(3)|, Random as it is."""
        if output == "Random":
            return self.attribute(POINT_INFO_ATTRIBUTES[output], 1)
        if output == "Radius":
            x, y, z = (shift(self.space_step(self.attribute("point_radius", 3), "VECTOR", "OBJECT", True), k)
                       for k in range(3))
            return self.math("SQRT", self.math("MULTIPLY_ADD", z, z, self.math("MULTIPLY_ADD", y, y,
                                                                                self.math("MULTIPLY", x, x))))
        centre = self.attribute("point_centre", 4)
        linear = self.space_step(centre, "VECTOR", "OBJECT", True)
        matrix = self.temporary(12)
        self.emit("OBJECT_MATRIX", matrix, 0)           # (row by row: the translation at 3, 7, 11)
        out = self.temporary(3)
        for k in range(3):
            self.emit("COPY", shift(out, k), self.math("MULTIPLY_ADD", shift(matrix, 4 * k + 3), shift(centre, 3),
                                                        shift(linear, k)), 1)
        return out

    def normalized(self, n: int) -> int:
        """A register holding the vector in register `n` divided by its length (as Cycles' normalize)."""
        x, y, z = (shift(n, k) for k in range(3))
        inverse_length = self.math("DIVIDE", self.constant([1.0]), self.math(
            "SQRT", self.math("MULTIPLY_ADD", z, z, self.math("MULTIPLY_ADD", y, y, self.math("MULTIPLY", x, x)))))
        out = self.temporary(3)
        for k, component in enumerate((x, y, z)):
            self.emit("COPY", shift(out, k), self.math("MULTIPLY", component, inverse_length), 1)
        return out

    def compile_node(self, node: GraphNode, output: str) -> tuple:
        """Emit a node's ops; return (register, width, type) of `output`."""
        kind, inp, props = node.kind, node.inputs, node.props
        width, vtype = NODE_OUTPUTS.get(kind, {}).get(output, (3, "color"))
        if kind == "RGB":
            return self.constant(np.asarray(props["value"], np.float64)[:3]), 3, props.get("type", "color")
        if kind == "VALUE":
            return self.constant([float(props["value"])]), 1, "float"
        if kind == "TEXCOORD":
            if output in ("Normal", "Reflection"):       # the object-space normal; the mirrored view (world space)
                return self.geometry("Object Normal" if output == "Normal" else "Reflection"), 3, "vector"
            if output == "Camera":                      # the world point in the camera's frame
                return self.transform(self.geometry("Position"), self.view), 3, "vector"
            if output == "Window":                      # where on the frame the point shows, 0..1 across it
                if self.window is None:                 # (a panoramic camera: addon/materials.py warns)
                    return self.constant([0.0, 0.0, 0.0]), 3, "vector"
                out = self.temporary(3)
                self.emit("WINDOW", out, self.transform(self.geometry("Position"), self.view),
                          self.constant(self.window))
                return out, 3, "vector"
            if output == "Object" and props.get("object_matrix") is not None:     # in another object's frame
                return self.transform(self.geometry("Position"), np.linalg.inv(props["object_matrix"])[:3]), 3, "vector"
            if output in ("UV", "Generated") and props.get("from_instancer"):   # the instance's (instance_info)
                out = self.temporary(3)
                self.emit("OBJECT_INFO", out, OBJECT_INFO_COLUMNS["From Instancer " + output][0], 3)
                return out, 3, "vector"
            name = {"UV": "uv:", "Generated": "generated", "Object": "object"}[output]
            return self.attribute(name), 3, "vector"
        if kind == "VECTOR_TRANSFORM":
            v = self.value(inp.get("Vector"), 3, 0.5)
            return self.vector_transform(v, props.get("type", "VECTOR"), props.get("from", "WORLD"),
                                         props.get("to", "OBJECT")), 3, "vector"
        if kind == "RAY_FOOTPRINT":                     # the ray's footprint at the hit (Cycles' sd->dP)
            if self.window is None:
                return self.constant([0.0]), 1, "float"
            out = self.temporary(1)
            self.emit("FOOTPRINT", out, self.transform(self.geometry("Position"), self.view), self.constant(self.window))
            return out, 1, "float"
        if kind == "WIREFRAME":
            size = self.value(inp.get("Size"), 1, 0.01)
            if props.get("pixel_size") and self.window is not None:
                pixels = self.temporary(1)
                self.emit("PIXEL_SIZE", pixels, size, self.transform(self.geometry("Position"), self.view),
                          self.constant(self.window))
                size = pixels
            out = self.temporary(1)
            self.emit("WIREFRAME", out, size)
            return out, 1, "float"
        if kind == "AO":                                # Color x AO, then AO (Cycles' svm_node_ao)
            out = self.temporary(4)
            normal = self.value(inp["Normal"], 3) if isinstance(inp.get("Normal"), Link) else None
            flags = (AO_INSIDE if props.get("inside") else 0) | (AO_ONLY_LOCAL if props.get("only_local") else 0)
            self.emit("AO", out, self.value(inp.get("Color"), 3, 1.0), self.value(inp.get("Distance"), 1, 1.0),
                      normal, int(props.get("samples", 16)), flags)
            return shift(out, 3 if output == "AO" else 0), width, vtype
        if kind == "BEVEL":                             # the averaged normal of the object within Radius
            out = self.temporary(3)
            normal = self.value(inp["Normal"], 3) if isinstance(inp.get("Normal"), Link) else None
            self.emit("BEVEL", out, self.value(inp.get("Radius"), 1, 0.05), normal, int(props.get("samples", 4)))
            return out, 3, "vector"
        if kind == "CAMERA_DATA":
            out = self.temporary(5)
            self.emit("CAMERA_DATA", out, self.transform(self.geometry("Position"), self.view))
            return shift(out, {"View Vector": 0, "View Z Depth": 3, "View Distance": 4}[output]), width, vtype
        if kind == "UVMAP":
            return self.attribute("uv:" + props.get("map", "")), 3, "vector"
        if kind == "ATTRIBUTE":
            name = props.get("attribute", "color:")
            if output in ("Color", "Vector"):
                return self.attribute(name, 3), 3, vtype
            if output == "Alpha":
                if not name.startswith(("color:", "attr:")):
                    return self.constant([1.0]), 1, "float"
                reg = self.attribute(name, 4)
                return reg + 3 if reg >= 0 else reg - 3, 1, "float"
            reg = self.attribute(name, 3)
            out = self.temporary(1)
            self.emit("CONVERT", out, reg, 1)            # Fac: the average
            return out, 1, "float"
        if kind == "PARTICLE_INFO":                     # the instance's particle (instance_info's columns)
            offset, size = PARTICLE_INFO_COLUMNS[output]
            out = self.temporary(size)
            self.emit("OBJECT_INFO", out, int(props["column"]) + offset, size)
            return out, width, vtype
        if kind == "CURVES_INFO":                       # per vertex of the tubes (core/geometry/curves.py curves_info)
            if output == "Tangent Normal":              # the view across the curve's tangent
                out = self.temporary(3)
                self.emit("CURVE_NORMAL", out, self.attribute(CURVES_INFO_ATTRIBUTES[output], 3))
                return out, 3, "vector"
            return self.attribute(CURVES_INFO_ATTRIBUTES[output], 1), 1, "float"
        if kind == "POINT_INFO":                        # per vertex of a point cloud's spheres (points.point_info)
            return self.point_info(output), width, vtype
        if kind == "VOLUME_INFO":                       # Cycles' volume attributes: a Volume object's grids (zeros
            grid = "grid:" + output.lower()             # where the layout has none: every mesh, as in Cycles)
            if output == "Color":
                return self.attribute(grid, 3), 3, vtype
            reg = self.attribute(grid, 3)               # (a float grid's (v, v, v, 1): its first float)
            return reg, 1, "float"
        if kind == "INSTANCE_ATTRIBUTE":               # an Object or Instancer attribute: the instance's RGBA columns
            start = int(props["column"])                # (geometry.instance_info, Scene.instance_attributes)
            out = self.temporary(3 if output != "Alpha" else 1)
            self.emit("OBJECT_INFO", out, start + 3 if output == "Alpha" else start, 1 if output == "Alpha" else 3)
            if output != "Fac":
                return out, width, vtype
            fac = self.temporary(1)
            self.emit("CONVERT", fac, out, 1)           # Fac: the average of its colour
            return fac, 1, "float"
        if kind == "OBJECT_INFO":
            if output == "Material Index":              # the material's own pass index: one number per program
                return self.constant(float(props.get("material_index", 0.0))), 1, "float"
            if output == "Random":
                out = self.temporary(1)
                self.emit("RANDOM", out)
                return out, 1, "float"
            start, width = OBJECT_INFO_COLUMNS[output]   # the instance's (geometry.instance_info)
            out = self.temporary(width)
            self.emit("OBJECT_INFO", out, start, width)
            return out, width, NODE_OUTPUTS[kind][output][1]
        if kind == "LIGHT_PATH":                        # the path that reached the hit (ShadingPoint.path)
            out = self.temporary(1)
            self.emit("LIGHT_PATH", out, LIGHT_PATH_OUTPUTS.index(output))
            return out, 1, "float"
        if kind in ("FRESNEL", "LAYER_WEIGHT"):
            amount = (self.value(inp.get("IOR"), 1, 1.5) if kind == "FRESNEL" else
                      self.value(inp.get("Blend"), 1, 0.5))
            normal = self.value(inp["Normal"], 3) if isinstance(inp.get("Normal"), Link) else None
            out = self.temporary(1 if kind == "FRESNEL" else 2)
            self.emit(kind, out, amount, normal)
            return shift(out, list(NODE_OUTPUTS[kind]).index(output)), 1, "float"
        if kind == "GEOMETRY":
            if output == "Tangent":                     # Cycles' primitive_tangent: radial about Z of Generated
                source = self.attribute("generated", 3)
                out = self.temporary(3)
                self.emit("TANGENT", out, source, 0, TANGENT_AXES.index("Z"))
                return out, 3, "vector"
            if output == "Pointiness":                  # a per-vertex attribute (core/geometry/pointiness.py)
                return self.attribute("pointiness", 1), 1, "float"
            if output == "Random Per Island":           # a per-triangle attribute (core/geometry/islands.py)
                return self.attribute("island", 1), 1, "float"
            out = self.temporary(width)
            self.emit("GEOMETRY", out, GEOMETRY_OUTPUTS.index(output))
            return out, width, vtype
        if kind == "IMAGE":
            if output == "Alpha":
                self.alpha_read.add(id(node))
                if isinstance(props.get("alpha_read"), list):     # (shared with the node's other GraphNodes)
                    props["alpha_read"][0] = True
            vector = (self.value(inp["Vector"], 3) if isinstance(inp.get("Vector"), Link)
                      else self.attribute("uv:"))
            projection = props.get("projection", "FLAT")
            if projection == "BOX":
                return self.image_box(vector, props, output, node)
            if projection in ("SPHERE", "TUBE"):
                vector = self.sphere_or_tube(vector, projection)
            out = self.temporary(4)
            index = self.image_index(props.get("image"))
            self.emit("IMAGE", out, vector, index, textures_.INTERPOLATIONS.get(props.get("interpolation", "Linear"), 0),
                      textures_.EXTENSIONS.get(props.get("extension", "REPEAT"), 0), 0)
            self.image_ops.setdefault(id(node), (node, []))[1].append(self.ops[-1])
            return (out, 3, "color") if output == "Color" else (shift(out, 3), 1, "float")
        if kind == "ENVIRONMENT":
            return self.environment(inp, props, output)
        if kind == "SKY":
            return self.sky(inp, props)
        if kind == "MAPPING":
            args = [self.value(inp.get(name), 3, default) for name, default in
                    (("Vector", 0.0), ("Location", 0.0), ("Rotation", 0.0), ("Scale", 1.0))]
            out = self.temporary(3)
            self.emit("MAPPING", out, *args, MAPPING_TYPES.index(props.get("type", "POINT")))
            return out, 3, "vector"
        if kind == "NORMAL_MAP":
            color = self.value(inp.get("Color"), 3, (0.5, 0.5, 1.0))
            strength = self.value(inp.get("Strength"), 1, 1.0)
            out = self.temporary(3)
            offset, _ = self.layout.get("tangent:" + props.get("map", ""), (-1, 4))
            self.emit("NORMAL_MAP", out, color, strength, offset)
            return out, 3, "vector"
        if kind == "TANGENT_SPACE":                     # a tangent-space offset in object space (tangent_space)
            vector = self.value(inp.get("Vector"), 3)
            out = self.temporary(3)
            offset, _ = self.layout.get("tangent:" + props.get("map", ""), (-1, 4))
            self.emit("TANGENT_SPACE", out, vector, offset)
            return out, 3, "vector"
        if kind == "TANGENT":
            radial = props.get("direction", "RADIAL") == "RADIAL"
            source = self.attribute("generated" if radial else "tangent:" + props.get("map", ""), 3)
            out = self.temporary(3)
            self.emit("TANGENT", out, source, 0 if radial else 1, TANGENT_AXES.index(props.get("axis", "Z")))
            return out, 3, "vector"
        if kind == "BUMP":
            strength = self.value(inp.get("Strength"), 1, 1.0)
            distance = self.value(inp.get("Distance"), 1, 1.0)
            normal = self.value(inp["Normal"], 3) if isinstance(inp.get("Normal"), Link) else None
            height = inp.get("Height", 1.0)
            if not isinstance(height, Link) and normal is not None:
                # Cycles folds a Bump of no Height away (BumpNode::constant_fold): its Normal output is what feeds
                # its Normal, as it is (not made unit: a value turned into a vector stays (v, v, v)).
                return normal, 3, "vector"
            width = self.constant(float(props.get("filter_width", BUMP_FILTER_WIDTH)))
            # Displacement and Bump: the bump over the surface before it moved (Cycles' ENTER_BUMP_EVAL), where the
            # mesh keeps it (core/geometry/displacement.py); each node evaluated anew there, as Cycles copies them.
            position, _ = self.layout.get("undisplaced_position", (-1, 3))
            normal_at, _ = self.layout.get("undisplaced_normal", (-1, 3))
            undisplaced = bool(props.get("undisplaced")) and position >= 0 and normal_at >= 0
            if undisplaced:
                self.emit("UNDISPLACED", 1, position, normal_at)
                self.memo.clear()
            saved, saved_width = self.offset, self.offset_width
            h = []
            for k, where in enumerate((saved, 1, 2)):       # (the heights at the point and its two steps)
                state = (saved, saved_width) if k == 0 else (where, width)
                if state != (self.offset, self.offset_width):
                    self.offset, self.offset_width = state
                    self.emit("OFFSET", *state)
                h.append(self.value(height, 1, 1.0))
            if (self.offset, self.offset_width) != (saved, saved_width):
                self.offset, self.offset_width = saved, saved_width
                self.emit("OFFSET", saved, saved_width)
            out = self.temporary(3)
            self.emit("BUMP", out, strength, distance, h[0], h[1], h[2], normal,
                      1 if props.get("invert") else 0, width)
            if undisplaced:
                self.emit("UNDISPLACED", 0, -1, -1)
                self.memo.clear()
            return out, 3, "vector"
        if kind == "MATH":
            a, b, c = (self.value(inp.get(str(i)), 1, 0.5) for i in range(3))
            out = self.temporary(1)
            self.emit("MATH", out, MATH_OPS.index(props.get("operation", "ADD")), a, b, c,
                      1 if props.get("clamp") else 0)
            return out, 1, "float"
        if kind == "MIX":
            data_type = props.get("data_type", "RGBA")
            w = 1 if data_type == "FLOAT" else 3
            non_uniform = data_type == "VECTOR" and props.get("factor_mode") == "NON_UNIFORM"
            fac = self.value(inp.get("Factor"), 3 if non_uniform else 1, 0.5)
            a, b = self.value(inp.get("A"), w, 0.0), self.value(inp.get("B"), w, 0.0)
            out = self.temporary(w)
            clamp_factor = 1 if props.get("clamp_factor", True) else 0
            if data_type == "FLOAT":
                self.emit("MIX_FLOAT", out, fac, a, b, clamp_factor, 1)
                return out, 1, "float"
            if data_type == "VECTOR":
                self.emit("MIX_FLOAT", out, fac, a, b, clamp_factor, 3 if non_uniform else -3)
                return out, 3, "vector"
            self.emit("MIX_COLOR", out, BLEND_TYPES.index(props.get("blend_type", "MIX")), fac, a, b,
                      1 if props.get("clamp_result") else 0, clamp_factor)
            return out, 3, "color"
        if kind == "RAMP":
            fac = self.value(inp.get("Fac"), 1, 0.5)
            table = np.asarray(props["table"], np.float64).reshape(-1, 4)
            start = sum(len(r) for r in self.ramps)
            self.ramps.append(table.reshape(-1))
            out = self.temporary(4)
            self.emit("RAMP", out, fac, start, len(table), 1 if props.get("interpolate", True) else 0)
            return (out, 3, "color") if output == "Color" else (shift(out, 3), 1, "float")
        if kind == "INVERT":
            fac, color = self.value(inp.get("Fac"), 1, 1.0), self.value(inp.get("Color"), 3, 0.0)
            out = self.temporary(3)
            self.emit("INVERT", out, fac, color)
            return out, 3, "color"
        if kind == "HSV":
            args = [self.value(inp.get(name), 1, default) for name, default in
                    (("Hue", 0.5), ("Saturation", 1.0), ("Value", 1.0), ("Fac", 1.0))]
            color = self.value(inp.get("Color"), 3, 0.8)
            out = self.temporary(3)
            self.emit("HSV", out, *args, color)
            return out, 3, "color"
        if kind in ("SEPARATE_COLOR", "SEPARATE_XYZ"):
            reg = self.value(inp.get("Color" if kind == "SEPARATE_COLOR" else "Vector"), 3, 0.0)
            index = list(NODE_OUTPUTS[kind]).index(output)
            return shift(reg, index), 1, "float"
        if kind in ("COMBINE_COLOR", "COMBINE_XYZ"):
            names = ("Red", "Green", "Blue") if kind == "COMBINE_COLOR" else ("X", "Y", "Z")
            out = self.temporary(3)
            for i, name in enumerate(names):
                self.emit("COPY", shift(out, i), self.value(inp.get(name), 1, 0.0), 1)
            return out, 3, "color" if kind == "COMBINE_COLOR" else "vector"
        if kind == "CLAMP":
            args = [self.value(inp.get(name), 1, default) for name, default in
                    (("Value", 1.0), ("Min", 0.0), ("Max", 1.0))]
            out = self.temporary(1)
            self.emit("CLAMP", out, *args, 1 if props.get("clamp_type") == "RANGE" else 0)
            return out, 1, "float"
        if kind == "MAP_RANGE":
            args = [self.value(inp.get(name), 1, default) for name, default in
                    (("Value", 1.0), ("From Min", 0.0), ("From Max", 1.0), ("To Min", 0.0), ("To Max", 1.0),
                     ("Steps", 4.0))]
            out = self.temporary(1)
            self.emit("MAP_RANGE", out, *args, MAP_RANGE_TYPES.index(props.get("interpolation_type", "LINEAR")),
                      1 if props.get("clamp", True) else 0)
            return out, 1, "float"
        if kind == "SCALE":
            color, factor = self.value(inp.get("Color"), 3, 1.0), self.value(inp.get("Factor"), 1, 1.0)
            out = self.temporary(3)
            self.emit("SCALE", out, color, factor)
            return out, 3, "color"
        if kind in DESCRIBED_BY_KIND:
            return self.texture(DESCRIBED_BY_KIND[kind], inp, props, output)
        raise ValueError(f"material '{self.material}': Primer cannot evaluate node kind {kind!r}")

    def math(self, operation: str, a: int, b: int = None, c: int = None) -> int:
        """A new register holding the Math node's `operation` of registers a, b, c (b, c default to a)."""
        out = self.temporary(1)
        b = a if b is None else b
        self.emit("MATH", out, MATH_OPS.index(operation), a, b, b if c is None else c, 0)
        return out

    def vector_of(self, *registers: int) -> int:
        """A new 3-float register holding the three 1-float `registers` in turn."""
        out = self.temporary(3)
        for k, register in enumerate(registers):
            self.emit("COPY", shift(out, k), register, 1)
        return out

    def sphere_or_tube(self, vector: int, projection: str) -> int:
        """The (u, v, 0) register an Image Texture's SPHERE or TUBE projection makes of the 3-float `vector`, as Cycles'
        map_to_sphere / map_to_tube do after moving the 0..1 box to -1..1 (c = 2 v - 1): Sphere u = 1/2 -
        atan2(x, y) / 2 pi, v = 1 - acos(z / |c|) / pi (u = 0 on the z axis, both 0 at the centre); Tube u = 1/2 -
        atan2(x, y) / 2 pi, v = (z + 1) / 2 (both 0 on the z axis)."""
        x, y, z = (self.math("MULTIPLY_ADD", shift(vector, k), self.constant([2.0]), self.constant([-1.0]))
                   for k in range(3))
        zero, one = self.constant([0.0]), self.constant([1.0])
        across = self.math("MULTIPLY_ADD", y, y, self.math("MULTIPLY", x, x))
        off_axis = self.math("GREATER_THAN", across, zero)
        u = self.math("MULTIPLY", self.math("MULTIPLY_ADD", self.math("ARCTAN2", x, y), self.constant([-0.5 / np.pi]),
                                            self.constant([0.5])), off_axis)
        if projection == "TUBE":
            v = self.math("MULTIPLY", self.math("MULTIPLY_ADD", z, self.constant([0.5]), self.constant([0.5])), off_axis)
            return self.vector_of(u, v, zero)
        length2 = self.math("MULTIPLY_ADD", z, z, across)
        polar = self.math("ARCCOSINE", self.math("DIVIDE", z, self.math("SQRT", length2)))
        v = self.math("MULTIPLY", self.math("MULTIPLY_ADD", polar, self.constant([-1.0 / np.pi]), one),
                      self.math("GREATER_THAN", length2, zero))
        return self.vector_of(u, v, zero)

    def image_box(self, vector: int, props: dict, output: str, node: GraphNode) -> tuple:
        """Emit an Image Texture's (`node`'s) BOX projection as Cycles' svm_node_tex_image_box: the object-space
        normal's |N| (summed to 1) weighs the three axis-aligned looks at the image, one face alone near each axis, two
        or three blended over the band props["blend"] wide; return (register, width, type) of `output`."""
        blend = float(props.get("blend", 0.0))
        limit = 0.5 * (1.0 + blend)
        normal = self.geometry("Object Normal")
        zero, one = self.constant([0.0]), self.constant([1.0])
        signed = [shift(normal, k) for k in range(3)]
        size = [self.math("ABSOLUTE", c) for c in signed]
        total = self.math("ADD", self.math("ADD", size[0], size[1]), size[2])
        nx, ny, nz = (self.math("DIVIDE", c, total) for c in size)
        def both(a, b):
            """a times b (of 0/1 masks: and)."""
            return self.math("MULTIPLY", a, b)

        def alone(a):
            """1 - a (of a 0/1 mask: not)."""
            return self.math("SUBTRACT", one, a)

        def also(a, b):
            """a plus b."""
            return self.math("ADD", a, b)

        def above(a, b, c, factor):
            """1 where a > factor (b + c), else 0."""
            return self.math("GREATER_THAN", a, self.math("MULTIPLY", self.constant([factor]), self.math("ADD", b, c)))

        corner_x = both(above(nx, nx, ny, limit), above(nx, nx, nz, limit))
        corner_y = both(alone(corner_x), both(above(ny, nx, ny, limit), above(ny, ny, nz, limit)))
        corner_z = both(both(alone(corner_x), alone(corner_y)), both(above(nz, nx, nz, limit), above(nz, ny, nz, limit)))
        rest = both(both(alone(corner_x), alone(corner_y)), alone(corner_z))
        if blend > 0.0:
            def ramp(a, b):
                """Cycles' saturate((a / (a + b) - (1 - blend) / 2) / blend)."""
                t = self.math("MULTIPLY_ADD", self.math("DIVIDE", a, self.math("ADD", a, b)), self.constant([1.0 / blend]),
                              self.constant([-0.5 * (1.0 - blend) / blend]))
                return self.math("MINIMUM", self.math("MAXIMUM", t, zero), one)

            def below(a, b, c):
                """1 where a < (1 - limit) (b + c), else 0."""
                return self.math("LESS_THAN", a, self.math("MULTIPLY", self.constant([1.0 - limit]), self.math("ADD", b, c)))

            edge_xy = both(rest, below(nz, ny, nx))
            edge_yz = both(both(rest, alone(edge_xy)), below(nx, ny, nz))
            edge_xz = both(both(both(rest, alone(edge_xy)), alone(edge_yz)), below(ny, nx, nz))
            middle = both(both(both(rest, alone(edge_xy)), alone(edge_yz)), alone(edge_xz))
            x_xy, y_yz, x_xz = ramp(nx, ny), ramp(ny, nz), ramp(nx, nz)
            mid = [self.math("MULTIPLY", self.math("MULTIPLY_ADD", c, self.constant([2.0 - limit]),
                                                   self.constant([limit - 1.0])), self.constant([1.0 / (2.0 * limit - 1.0)]))
                   for c in (nx, ny, nz)]
            weight_x = also(also(corner_x, both(edge_xy, x_xy)), also(both(edge_xz, x_xz), both(middle, mid[0])))
            weight_y = also(also(corner_y, both(edge_xy, alone(x_xy))), also(both(edge_yz, y_yz), both(middle, mid[1])))
            weight_z = also(also(corner_z, both(edge_yz, alone(y_yz))), also(both(edge_xz, alone(x_xz)),
                                                                                 both(middle, mid[2])))
        else:
            weight_x, weight_y, weight_z = also(corner_x, rest), corner_y, corner_z

        def pick(flipped, a):
            """Register a, or 1 - a where `flipped` is 1."""
            return also(both(a, alone(flipped)), both(alone(a), flipped))

        co = [shift(vector, k) for k in range(3)]
        looks = ((weight_x, pick(self.math("LESS_THAN", signed[0], zero), co[1]), co[2]),
                 (weight_y, pick(self.math("GREATER_THAN", signed[1], zero), co[0]), co[2]),
                 (weight_z, pick(self.math("GREATER_THAN", signed[2], zero), co[1]), co[0]))
        index = self.image_index(props.get("image"))
        total = None
        for weight, u, v in looks:
            sample = self.temporary(4)
            self.emit("IMAGE", sample, self.vector_of(u, v, zero), index,
                      textures_.INTERPOLATIONS.get(props.get("interpolation", "Linear"), 0),
                      textures_.EXTENSIONS.get(props.get("extension", "REPEAT"), 0), 0)
            self.image_ops.setdefault(id(node), (node, []))[1].append(self.ops[-1])
            total = [self.math("MULTIPLY", weight, shift(sample, k)) if total is None
                     else self.math("MULTIPLY_ADD", weight, shift(sample, k), total[k]) for k in range(4)]
        if output == "Color":
            return self.vector_of(*total[:3]), 3, "color"
        return total[3], 1, "float"

    def mark_unassociate(self) -> None:
        """Set the unassociate flag (the IMAGE op's last argument) of every Image Texture whose Alpha output is read
        and whose image Cycles associates (props["unassociate"]: a colour image with Alpha Straight or Premultiplied),
        as Cycles' ImageTextureNode::compile sets NODE_IMAGE_ALPHA_UNASSOCIATE where the Alpha output has links: its
        Color output is then the colour divided back by the alpha, for every lookup of that node. Read: by this
        program, or from another GraphNode of the same Blender node (an AOV's, a program compiled before this one),
        which props["alpha_read"], a [bool] the addon shares between them, tells."""
        for key, (node, ops) in self.image_ops.items():
            read = key in self.alpha_read or bool(node.props.get("alpha_read", [False])[0])
            flag = 1 if read and node.props.get("unassociate") else 0
            for op in ops:
                op[6] = flag

    def environment(self, inp: dict, props: dict, output: str) -> tuple:
        """Emit an Environment Texture as Cycles' svm_node_tex_environment looks it up: the direction (its Vector, else
        the Generated coordinates: in a world, the ray's direction), normalised, to (u, v), then the IMAGE op there;
        EQUIRECTANGULAR u = 1/2 - atan2(y, x) / 2 pi, v = 1/2 + atan2(z, |(x, y)|) / pi; MIRROR_BALL the point of a
        mirror ball seen along -y that reflects the direction: (x, y - 1, z) / 2 sqrt((1 - y) / 2), u = (x + 1) / 2,
        v = (z + 1) / 2; return (register, width, type) of `output`."""
        d = self.value(inp["Vector"], 3) if isinstance(inp.get("Vector"), Link) else self.attribute("generated")
        x, y, z = (shift(d, k) for k in range(3))
        zero, half = self.constant([0.0]), self.constant([0.5])
        across2 = self.math("MULTIPLY_ADD", y, y, self.math("MULTIPLY", x, x))
        if props.get("projection", "EQUIRECTANGULAR") == "MIRROR_BALL":
            inverse = self.math("INVERSE_SQRT", self.math("MULTIPLY_ADD", z, z, across2))
            x, y, z = (self.math("MULTIPLY", c, inverse) for c in (x, y, z))
            y = self.math("SUBTRACT", y, self.constant([1.0]))
            div = self.math("MULTIPLY", self.constant([2.0]),
                            self.math("SQRT", self.math("MAXIMUM", self.math("MULTIPLY", y, self.constant([-0.5])), zero)))
            u, v = (self.math("MULTIPLY_ADD", self.math("DIVIDE", c, div), half, half) for c in (x, z))
        else:
            u = self.math("MULTIPLY_ADD", self.math("ARCTAN2", y, x), self.constant([-0.5 / np.pi]), half)
            v = self.math("MULTIPLY_ADD", self.math("ARCTAN2", z, self.math("SQRT", across2)), self.constant([1.0 / np.pi]),
                          half)
        out = self.temporary(4)
        self.emit("IMAGE", out, self.vector_of(u, v, zero), self.image_index(props.get("image")),
                  textures_.INTERPOLATIONS.get(props.get("interpolation", "Linear"), 0), textures_.EXTENSIONS["REPEAT"], 0)
        return (out, 3, "color") if output == "Color" else (shift(out, 3), 1, "float")

    def sky(self, inp: dict, props: dict) -> tuple:
        """Emit a Sky Texture (props["sky"]: a precomputed core/materials/sky.py Sky) at its Vector, else the Generated
        coordinates (in a world: the ray's direction): its floats go to the program's float tables (the ramps), their
        start kept in `sky_starts` by the Sky's id; return (register, width, type) of its Color."""
        d = self.value(inp["Vector"], 3) if isinstance(inp.get("Vector"), Link) else self.attribute("generated")
        floats = props["sky"].floats()
        start = sum(len(r) for r in self.ramps)
        self.ramps.append(floats)
        self.sky_starts[id(props["sky"])] = start
        out = self.temporary(3)
        self.emit("SKY", out, d, start, len(floats))
        return out, 3, "color"

    def texture(self, texture, inp: dict, props: dict, output: str) -> tuple:
        """Emit a described node's op (a procedural texture or a converter): its input registers in the class's order
        (an unlinked input whose default names a texture coordinate reads that attribute), then its numbers (first,
        for a node with a baked table, the table's start among the program's table floats, props["table"] appended to
        them); return (register, width, type) of `output` within the op's block."""
        registers = []
        for name, width, default in texture.inputs:
            if isinstance(default, str):
                source = inp.get(name)
                registers.append(self.value(source, width) if isinstance(source, Link) else self.coordinate(default, width))
            else:
                registers.append(self.value(inp.get(name), width, default))
        numbers = texture.numbers(props, output)
        if getattr(texture, "table", False):
            numbers = [sum(len(r) for r in self.ramps)] + numbers
            self.ramps.append(np.asarray(props["table"], np.float64).reshape(-1))
        out = self.temporary(texture.width())
        self.emit(texture.kind, out, *registers, *numbers)
        offset, width, vtype = texture.output(output)
        return shift(out, offset), width, vtype

    def compile(self, nodes: list, hit_normal=None, aovs=()) -> Program:
        """The program of a material's shader nodes [(node class, weight, inputs dict, factors), ...]:
        linked inputs overwrite their slots, factors multiply the weight, "normal" replaces the normal; a linked
        input in cls.normal_inputs (the Principled's "coat_normal") is a normal written into its slots; a
        `hit_normal` Link (Cycles' Set Normal) is the hit's own normal, an OUT_NORMAL output to node -1. aovs: the
        AOV Output nodes the render writes, [(first AOV channel, 4 (COLOR) or 1 (VALUE), its Color or Value: a
        constant or a Link)], compiled last, after an AOV_START op (OUT_AOV rows)."""
        if isinstance(hit_normal, Link):
            normal = self.value(hit_normal, 3)
            self.outputs.append([OUT_NORMAL, -1, 0, 3, normal])
            # Cycles runs the rest of the graph after its Set Normal: what reads the normal sees the bumped one,
            # each node evaluated anew (ShaderGraph::bump_from_displacement copies the displacement's nodes).
            self.emit("SET_NORMAL", normal)
            self.memo.clear()
        for k, entry in enumerate(nodes):
            cls, inputs = entry[0], entry[2]
            factors = entry[3] if len(entry) > 3 else ()
            slot = 0
            for name, default in zip(cls.inputs, cls.defaults):
                size = np.atleast_1d(np.asarray(default)).size
                value = inputs.get(name)
                if isinstance(value, Link):
                    kind = OUT_NORMAL if name in getattr(cls, "normal_inputs", ()) else OUT_INPUT
                    self.outputs.append([kind, k, slot, size, self.value(value, size)])
                slot += size
            if isinstance(inputs.get("normal"), Link):
                self.outputs.append([OUT_NORMAL, k, 0, 3, self.value(inputs["normal"], 3)])
            for link, mode in factors:
                width = 3 if mode == "color" else 1
                self.outputs.append([OUT_WEIGHT, k, WEIGHT_MODES[mode], width, self.value(link, width)])
        if aovs:
            # (what the shader nodes computed above is reused; the ops from here on feed the AOVs alone)
            self.emit("AOV_START")
            for first, channels, source in aovs:
                width = 3 if channels == 4 else 1
                self.outputs.append([OUT_AOV, first, 0, width, self.value(source, width)])
        self.mark_unassociate()
        c = len(self.constants)
        registers = c + self.temporaries
        if registers > MAX_REGISTERS:
            raise ValueError(f"material '{self.material}': its node graph needs {registers} registers; "
                             f"Primer has {MAX_REGISTERS}")
        renumber = lambda r: c - 1 - r if r < 0 else r                  # noqa: E731
        ops = np.zeros((len(self.ops), 1 + OP_ARGS))
        for i, op in enumerate(self.ops):
            code = op[0]
            args = [(-1 if a is None else renumber(a)) if j in REGISTER_ARGS[OPS[code]] else a
                    for j, a in enumerate(op[1:])]
            ops[i, :1 + len(args)] = [code] + args
        outputs = np.array([[o[0], o[1], o[2], o[3], renumber(o[4])] for o in self.outputs], np.float64).reshape(-1, 5)
        ramps = np.concatenate(self.ramps) if self.ramps else np.zeros(0)
        taps = tuple((name, output, renumber(reg), width, kind) for (name, output), (reg, width, kind)
                     in self.taps.items())
        blocks = np.array([(c + start, width) for start, width in self.blocks], np.int64).reshape(-1, 2)
        return Program(ops, np.array(self.constants, np.float64), registers, outputs, ramps, taps, blocks)


def shift(register: int, by: int) -> int:
    """The register `by` places after `register` (provisional negative numbers count down)."""
    return register + by if register >= 0 else register - by


# Which arguments of each op are registers (renumbered when the program is done); the rest are numbers.
REGISTER_ARGS = {
    "ATTR": {0}, "RANDOM": {0}, "OBJECT_INFO": {0}, "OBJECT_MATRIX": {0}, "IMAGE": {0, 1}, "MAPPING": {0, 1, 2, 3, 4},
    "MATH": {0, 2, 3, 4},
    "MIX_COLOR": {0, 2, 3, 4}, "MIX_FLOAT": {0, 1, 2, 3}, "RAMP": {0, 1}, "INVERT": {0, 1, 2},
    "HSV": {0, 1, 2, 3, 4, 5}, "COPY": {0, 1}, "CLAMP": {0, 1, 2, 3}, "MAP_RANGE": {0, 1, 2, 3, 4, 5, 6},
    "NORMAL_MAP": {0, 1, 2}, "BUMP": {0, 1, 2, 3, 4, 5, 6, 8}, "OFFSET": {1}, "CONVERT": {0, 1}, "SCALE": {0, 1, 2},
    "LIGHT_PATH": {0}, "TANGENT": {0, 1}, "FRESNEL": {0, 1, 2}, "LAYER_WEIGHT": {0, 1, 2},
    "GEOMETRY": {0}, "TRANSFORM": {0, 1, 2}, "CAMERA_DATA": {0, 1}, "WIREFRAME": {0, 1}, "WINDOW": {0, 1, 2}, "SKY": {0, 1},
    "AO": {0, 1, 2, 3}, "BEVEL": {0, 1, 2},
    "PIXEL_SIZE": {0, 1, 2, 3}, "CURVE_NORMAL": {0, 1}, "SET_NORMAL": {0}, "TANGENT_SPACE": {0, 1}, "FOOTPRINT": {0, 1, 2},
    "UNDISPLACED": set(), "AOV_START": set(),
    **{cls.kind: set(range(1 + len(cls.inputs))) for cls in DESCRIBED},
}


# ------------------------------------------------------------------------------------------------
# Running a program over n hits (the reference)
# ------------------------------------------------------------------------------------------------

def safe_divide(a, b):
    """a / b, 0 where b is 0."""
    return np.divide(a, b, out=np.zeros(np.broadcast(a, b).shape), where=b != 0.0)


def math_op(op: int, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Cycles' svm_math for operation MATH_OPS[op] on (n,) float64."""
    name = MATH_OPS[op]
    with np.errstate(all="ignore"):
        if name == "ADD": return a + b
        if name == "SUBTRACT": return a - b
        if name == "MULTIPLY": return a * b
        if name == "DIVIDE": return safe_divide(a, b)
        if name == "MULTIPLY_ADD": return a * b + c
        if name == "POWER":
            bad = (a < 0.0) & (b != np.trunc(b))
            return np.where(bad, 0.0, np.where(b == 0.0, 1.0, np.power(np.where(bad, 1.0, a), b)))
        if name == "LOGARITHM":
            ok = (a > 0.0) & (b > 0.0)
            la, lb = np.log(np.where(ok, a, 1.0)), np.log(np.where(ok, b, 2.0))
            return np.where(ok, safe_divide(la, lb), 0.0)
        if name == "SQRT": return np.where(a > 0.0, np.sqrt(np.maximum(a, 0.0)), 0.0)
        if name == "INVERSE_SQRT": return np.where(a > 0.0, 1.0 / np.sqrt(np.where(a > 0.0, a, 1.0)), 0.0)
        if name == "ABSOLUTE": return np.abs(a)
        if name == "EXPONENT": return np.exp(a)
        if name == "MINIMUM": return np.minimum(a, b)
        if name == "MAXIMUM": return np.maximum(a, b)
        if name == "LESS_THAN": return (a < b).astype(np.float64)
        if name == "GREATER_THAN": return (a > b).astype(np.float64)
        if name == "SIGN": return np.sign(a)
        if name == "COMPARE": return (np.abs(a - b) <= np.maximum(c, 1e-5)).astype(np.float64)
        if name == "ROUND": return np.floor(a + 0.5)
        if name == "FLOOR": return np.floor(a)
        if name == "CEIL": return np.ceil(a)
        if name == "TRUNC": return np.trunc(a)
        if name == "FRACT": return a - np.floor(a)
        if name == "MODULO": return np.where(b != 0.0, np.fmod(a, np.where(b != 0.0, b, 1.0)), 0.0)
        if name == "FLOORED_MODULO":
            bb = np.where(b != 0.0, b, 1.0)
            return np.where(b != 0.0, a - np.floor(a / bb) * bb, 0.0)
        if name == "WRAP":
            span = b - c
            s = np.where(span != 0.0, span, 1.0)
            return np.where(span != 0.0, a - s * np.floor((a - c) / s), c)
        if name == "SNAP": return np.floor(safe_divide(a, b)) * b
        if name == "PINGPONG":
            bb = np.where(b != 0.0, b, 1.0)
            x = (a - bb) / (bb * 2.0)
            return np.where(b != 0.0, np.abs((x - np.floor(x)) * bb * 2.0 - bb), 0.0)
        if name == "SINE": return np.sin(a)
        if name == "COSINE": return np.cos(a)
        if name == "TANGENT": return np.tan(a)
        if name == "ARCSINE": return np.arcsin(np.clip(a, -1.0, 1.0))
        if name == "ARCCOSINE": return np.arccos(np.clip(a, -1.0, 1.0))
        if name == "ARCTANGENT": return np.arctan(a)
        if name == "ARCTAN2": return np.arctan2(a, b)
        if name == "SINH": return np.sinh(a)
        if name == "COSH": return np.cosh(a)
        if name == "TANH": return np.tanh(a)
        if name == "RADIANS": return a * (np.pi / 180.0)
        if name == "DEGREES": return a * (180.0 / np.pi)
        if name == "SMOOTH_MIN": return smooth_min(a, b, c)
        if name == "SMOOTH_MAX": return -smooth_min(-a, -b, c)
    raise ValueError(name)


def smooth_min(a: np.ndarray, b: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Cycles' smoothminf: min(a, b) less a cubic blend k h^3 / 6 where |a - b| < k, h = (k - |a - b|) / k."""
    h = safe_divide(np.maximum(k - np.abs(a - b), 0.0), k)
    return np.where(k != 0.0, np.minimum(a, b) - h * h * h * k * (1.0 / 6.0), np.minimum(a, b))


def mix_color(blend: int, t: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
    """Cycles' svm_mix for BLEND_TYPES[blend]: t (n, 1), colours (n, 3)."""
    name = BLEND_TYPES[blend]
    if name in HSV_BLENDS:
        return mix_hsv(name, t, c1, c2)
    tm = 1.0 - t
    if name == "MIX": return tm * c1 + t * c2
    if name == "DARKEN": return tm * c1 + t * np.minimum(c1, c2)
    if name == "LIGHTEN": return tm * c1 + t * np.maximum(c1, c2)
    if name == "MULTIPLY": return c1 * (tm + t * c2)
    if name == "SCREEN": return 1.0 - (tm + t * (1.0 - c2)) * (1.0 - c1)
    if name == "ADD": return tm * c1 + t * (c1 + c2)
    if name == "SUBTRACT": return tm * c1 + t * (c1 - c2)
    if name == "DIVIDE":
        return np.where(c2 != 0.0, tm * c1 + t * safe_divide(c1, c2), c1)
    if name == "DIFFERENCE": return tm * c1 + t * np.abs(c1 - c2)
    if name == "EXCLUSION": return np.maximum(tm * c1 + t * (c1 + c2 - 2.0 * c1 * c2), 0.0)
    if name == "OVERLAY":
        return np.where(c1 < 0.5, c1 * (tm + 2.0 * t * c2), 1.0 - (tm + 2.0 * t * (1.0 - c2)) * (1.0 - c1))
    if name == "SOFT_LIGHT":
        screen = 1.0 - (1.0 - c2) * (1.0 - c1)
        return tm * c1 + t * ((1.0 - c1) * c2 * c1 + c1 * screen)
    if name == "LINEAR_LIGHT": return c1 + t * (2.0 * c2 - 1.0)
    if name == "BURN":
        tmp = tm + t * c2
        return np.where(tmp <= 0.0, 0.0, np.clip(1.0 - safe_divide(1.0 - c1, tmp), 0.0, 1.0))
    if name == "DODGE":
        tmp = 1.0 - t * c2
        return np.where(c1 != 0.0, np.where(tmp <= 0.0, 1.0, np.minimum(safe_divide(c1, tmp), 1.0)), c1)
    raise ValueError(name)


def mix_hsv(name: str, t: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
    """Cycles' svm_mix_hue, _sat, _val and _color in float32: A takes B's hue (Hue), hue and saturation (Color)
    blended by t where B has a saturation, or its saturation (where A has one) or value interpolated by t: t (n, 1),
    colours (n, 3); (n, 3) float64."""
    t, a, b = t.astype(F32), c1.astype(F32), c2.astype(F32)
    hsv, hsv2 = color_.rgb_to_hsv(a), color_.rgb_to_hsv(b)
    if name in ("HUE", "COLOR"):
        hsv[:, 0] = hsv2[:, 0]
        if name == "COLOR":
            hsv[:, 1] = hsv2[:, 1]
        out = np.where((hsv2[:, 1] != F32(0.0))[:, None], a + t * (color_.hsv_to_rgb(hsv) - a), a)
    elif name == "SATURATION":
        saturated = hsv[:, 1] != F32(0.0)
        hsv[:, 1] = (F32(1.0) - t[:, 0]) * hsv[:, 1] + t[:, 0] * hsv2[:, 1]
        out = np.where(saturated[:, None], color_.hsv_to_rgb(hsv), a)
    else:
        hsv[:, 2] = (F32(1.0) - t[:, 0]) * hsv[:, 2] + t[:, 0] * hsv2[:, 2]
        out = color_.hsv_to_rgb(hsv)
    return out.astype(np.float64)


def euler_matrix(r: np.ndarray) -> np.ndarray:
    """Cycles' euler_to_transform: the rotation (n, 3, 3) of XYZ Euler angles (n, 3), Rz Ry Rx."""
    cx, cy, cz = np.cos(r[:, 0]), np.cos(r[:, 1]), np.cos(r[:, 2])
    sx, sy, sz = np.sin(r[:, 0]), np.sin(r[:, 1]), np.sin(r[:, 2])
    return np.stack([np.stack([cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz], axis=1),
                     np.stack([cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz], axis=1),
                     np.stack([-sy, cy * sx, cy * cx], axis=1)], axis=1)


def safe_normalize(v: np.ndarray) -> np.ndarray:
    """v / |v| per row, 0 where |v| is 0 (n, 3)."""
    length = np.sqrt(np.einsum("ij,ij->i", v, v))
    return np.divide(v, length[:, None], out=np.zeros_like(v), where=length[:, None] > 0.0)


def run(program: Program, sp: ShadingPoint, textures: textures_.TextureSet) -> np.ndarray:
    """The registers (n, R) float64 of a program run at n hits."""
    n = len(sp.random)
    reg = np.zeros((n, max(1, program.registers)))
    c = len(program.constants)
    reg[:, :c] = program.constants
    attributes, where = sp.attributes, (0.0, 0.0)       # (the bump's point: its step du, dv (n,) from the hit)
    moved = None                                        # (inside UNDISPLACED: the hits on the moved surface)
    hit = sp                                    # (the Normal Map's frame: the mesh's normal, never Set Normal's)
    for row in program.ops:
        code, a = int(row[0]), row[1:]
        name = OPS[code]
        i = [int(x) for x in a]
        R = lambda k, w=1: reg[:, i[k]:i[k] + w]              # noqa: E731
        if name == "ATTR":
            if i[1] >= 0:
                reg[:, i[0]:i[0] + i[2]] = attributes[:, i[1]:i[1] + i[2]]
                reg[:, i[0] + i[2]:i[0] + i[3]] = 0.0
            else:
                reg[:, i[0]:i[0] + i[3]] = 0.0
        elif name == "RANDOM":
            reg[:, i[0]] = sp.random
        elif name == "OBJECT_MATRIX":
            reg[:, i[0]:i[0] + 12] = object_matrices(sp, i[1])
        elif name == "OBJECT_INFO":                     # (a column past the instances' reads 0)
            columns = np.zeros((n, i[2]))
            if sp.info is not None:
                found = sp.info[:, i[1]:i[1] + i[2]]
                columns[:, :found.shape[1]] = found
            reg[:, i[0]:i[0] + i[2]] = columns
        elif name == "LIGHT_PATH":
            path = light_paths(n) if sp.path is None else sp.path
            reg[:, i[0]] = light_path_output(i[1], path, np.zeros(n) if sp.t is None else sp.t)
        elif name == "UNDISPLACED":                     # (the bump over the surface before it moved, and back)
            if i[0]:
                moved, sp = sp, undisplaced_point(i[1], i[2], sp)
            elif moved is not None:
                moved, sp = None, moved._replace(N=sp.N)
        elif name == "OFFSET":
            where = bump_step(i[0], reg[:, i[1]] if i[0] else 0.0, sp if moved is None else moved)
            attributes = ((sp.attributes + where[0][:, None] * sp.d_du) + where[1][:, None] * sp.d_dv if i[0]
                          else sp.attributes)
        elif name == "IMAGE":
            reg[:, i[0]:i[0] + 4] = textures.lookup(i[2], reg[:, i[1]], reg[:, i[1] + 1], i[3], i[4], bool(i[5]))
        elif name == "MAPPING":
            v, loc, rot, scale = R(1, 3), R(2, 3), R(3, 3), R(4, 3)
            M = euler_matrix(rot)
            kind = MAPPING_TYPES[i[5]]
            if kind == "POINT":
                out = np.einsum("nij,nj->ni", M, v * scale) + loc
            elif kind == "TEXTURE":
                out = safe_divide(np.einsum("nji,nj->ni", M, v - loc), scale)
            elif kind == "VECTOR":
                out = np.einsum("nij,nj->ni", M, v * scale)
            else:
                out = safe_normalize(np.einsum("nij,nj->ni", M, safe_divide(v, scale)))
            reg[:, i[0]:i[0] + 3] = out
        elif name == "MATH":
            out = math_op(i[1], reg[:, i[2]], reg[:, i[3]], reg[:, i[4]])
            reg[:, i[0]] = np.clip(out, 0.0, 1.0) if i[5] else out
        elif name == "MIX_COLOR":
            t = reg[:, i[2]:i[2] + 1]
            if i[6]:
                t = np.clip(t, 0.0, 1.0)
            out = mix_color(i[1], t, R(3, 3), R(4, 3))
            reg[:, i[0]:i[0] + 3] = np.clip(out, 0.0, 1.0) if i[5] else out
        elif name == "MIX_FLOAT":
            w = abs(i[5])
            t = reg[:, i[1]:i[1] + (3 if i[5] == 3 else 1)]
            if i[4]:
                t = np.clip(t, 0.0, 1.0)
            reg[:, i[0]:i[0] + w] = (1.0 - t) * R(2, w) + t * R(3, w)
        elif name == "RAMP":
            table = program.ramps[i[2]:i[2] + 4 * i[3]].reshape(-1, 4)
            f = np.clip(np.nan_to_num(reg[:, i[1]]), 0.0, 1.0) * (i[3] - 1)
            k = np.clip(f.astype(np.int64), 0, i[3] - 1)
            t = f - k
            out = table[k]
            if i[4]:
                upper = table[np.minimum(k + 1, i[3] - 1)]
                out = np.where((t > 0.0)[:, None], (1.0 - t)[:, None] * out + t[:, None] * upper, out)
            reg[:, i[0]:i[0] + 4] = out
        elif name == "INVERT":
            fac, color = reg[:, i[1]:i[1] + 1], R(2, 3)
            reg[:, i[0]:i[0] + 3] = fac * (1.0 - color) + (1.0 - fac) * color
        elif name == "HSV":                     # Cycles' svm_node_hsv, in float32
            color = R(5, 3).astype(F32)
            hue, saturation, value, fac = (reg[:, i[k]].astype(F32) for k in (1, 2, 3, 4))
            hsv = color_.rgb_to_hsv(color)
            h = hsv[:, 0] + hue + F32(0.5)
            hsv[:, 0] = h - np.floor(h)
            hsv[:, 1] = np.clip(hsv[:, 1] * saturation, F32(0.0), F32(1.0))
            hsv[:, 2] = hsv[:, 2] * value
            rgb = color_.hsv_to_rgb(hsv)
            reg[:, i[0]:i[0] + 3] = np.maximum(fac[:, None] * rgb + (F32(1.0) - fac)[:, None] * color, F32(0.0))
        elif name == "COPY":
            reg[:, i[0]:i[0] + i[2]] = R(1, i[2])
        elif name == "CLAMP":
            value, lo, hi = reg[:, i[1]], reg[:, i[2]], reg[:, i[3]]
            if i[4]:
                lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
            reg[:, i[0]] = np.minimum(np.maximum(value, lo), hi)
        elif name == "MAP_RANGE":
            reg[:, i[0]] = map_range(i[7], i[8], *(reg[:, i[k]] for k in range(1, 7)))
        elif name == "NORMAL_MAP":
            reg[:, i[0]:i[0] + 3] = normal_map(R(1, 3), reg[:, i[2]], i[3], hit, attributes, sp.N)
        elif name == "BUMP":                            # (0 in a light's own shading: lit_by_bump)
            normal = sp.N if i[6] < 0 else R(6, 3)
            reg[:, i[0]:i[0] + 3] = bump(normal, reg[:, i[1]], reg[:, i[2]], reg[:, i[3]], reg[:, i[4]],
                                         reg[:, i[5]], i[7], reg[:, i[8]], sp, moved) * lit_by_bump(sp)[:, None]
        elif name == "CONVERT":
            if i[2] == 0:
                src = R(1, 3)
                reg[:, i[0]] = LUMINANCE[0] * src[:, 0] + LUMINANCE[1] * src[:, 1] + LUMINANCE[2] * src[:, 2]
            elif i[2] == 1:
                src = R(1, 3)
                reg[:, i[0]] = (src[:, 0] + src[:, 1] + src[:, 2]) * (1.0 / 3.0)
            else:
                reg[:, i[0]:i[0] + 3] = reg[:, i[1]:i[1] + 1]
        elif name == "SCALE":
            reg[:, i[0]:i[0] + 3] = R(1, 3) * reg[:, i[2]:i[2] + 1]
        elif name == "TANGENT":
            reg[:, i[0]:i[0] + 3] = tangent(R(1, 3), i[2], i[3], sp)
        elif name == "GEOMETRY":
            reg[:, i[0]:i[0] + (1 if GEOMETRY_OUTPUTS[i[1]] in SCALAR_OUTPUTS else 3)] = geometry(i[1], where, sp)
        elif name == "TRANSFORM":
            M = reg[0, i[2]:i[2] + 12].reshape(3, 4)
            p = R(1, 3)
            reg[:, i[0]:i[0] + 3] = (p[:, 0:1] * M[:, 0] + p[:, 1:2] * M[:, 1]) + p[:, 2:3] * M[:, 2] + M[:, 3]
        elif name == "WINDOW":
            reg[:, i[0]:i[0] + 3] = window(R(1, 3), reg[0, i[2]:i[2] + 8])
        elif name == "WIREFRAME":
            reg[:, i[0]] = wireframe(reg[:, i[1]], where, sp)
        elif name == "AO":
            normal = sp.N if i[3] < 0 else R(3, 3)
            ao = (np.ones(n) if sp.rays is None else
                  sp.rays.ambient_occlusion(safe_normalize(normal), reg[:, i[2]], i[4], i[5]))
            reg[:, i[0]:i[0] + 3] = R(1, 3) * ao[:, None]
            reg[:, i[0] + 3] = ao
        elif name == "BEVEL":
            bevelled = sp.N if sp.rays is None else sp.rays.bevel(reg[:, i[1]], i[3], sp.N, sp.side)
            if i[2] >= 0:                               # Cycles keeps a linked Normal's own detail
                bevelled = safe_normalize(R(2, 3) + (bevelled - sp.N))
            reg[:, i[0]:i[0] + 3] = bevelled
        elif name == "CURVE_NORMAL":
            reg[:, i[0]:i[0] + 3] = curve_normal(R(1, 3), sp)
        elif name == "TANGENT_SPACE":
            reg[:, i[0]:i[0] + 3] = tangent_space(R(1, 3), i[2], sp)
        elif name == "AOV_START":                       # (the reference runs the AOV ops at every hit: shade keeps
            pass                                        #  their values where a camera chain writes them, passes.py)
        elif name == "SET_NORMAL":                      # the ops after it see this normal as the hit's (unit; kept
            unit = safe_normalize(R(0, 3))              # where it is zero, as apply_outputs does)
            sp = sp._replace(N=np.where(np.any(unit != 0.0, axis=1)[:, None], unit, sp.N))
        elif name == "FOOTPRINT":
            reg[:, i[0]] = ray_footprint(R(1, 3), reg[0, i[2]:i[2] + 8], sp)
        elif name == "PIXEL_SIZE":
            reg[:, i[0]] = reg[:, i[1]] * pixel_width(R(2, 3), reg[0, i[3]:i[3] + 8], sp)
        elif name == "CAMERA_DATA":
            reg[:, i[0]:i[0] + 5] = camera_data(R(1, 3))
        elif name == "FRESNEL":
            reg[:, i[0]] = fresnel(reg[:, i[1]], None if i[2] < 0 else R(2, 3), sp)
        elif name == "LAYER_WEIGHT":
            reg[:, i[0]:i[0] + 2] = layer_weight(reg[:, i[1]], None if i[2] < 0 else R(2, 3), sp)
        elif name == "SKY":
            reg[:, i[0]:i[0] + 3] = sky_.evaluate(program.ramps[i[2]:i[2] + i[3]], R(1, 3))
        elif name in DESCRIBED_BY_KIND:
            texture = DESCRIBED_BY_KIND[name]
            k = len(texture.inputs)
            inputs = [R(1 + j, width) for j, (_, width, _) in enumerate(texture.inputs)]
            numbers = i[1 + k:]
            reg[:, i[0]:i[0] + texture.width()] = (texture.evaluate(inputs, numbers, program.ramps)
                                                   if getattr(texture, "table", False) else
                                                   texture.evaluate(inputs, numbers))
    return reg


def geometry(output: int, where: tuple, sp: ShadingPoint) -> np.ndarray:
    """Cycles' Geometry node (svm_node_geometry) output GEOMETRY_OUTPUTS[output], (n, 3) or Backfacing (n, 1), at the
    hit or at the bump's point `where` (its step du, dv in the barycentrics, (n,) or 0: bump_step), as Cycles moves
    Position and Parametric for a bump's height: Position the world point, Normal the shading normal and True Normal the face's
    (both towards the viewer), Incoming the direction back along the ray, Parametric (1 - u - v, u, 0), Backfacing
    1 where the back of the face was hit."""
    name = GEOMETRY_OUTPUTS[output]
    n = len(sp.N)
    du, dv = (np.broadcast_to(np.asarray(d, np.float64), (n,)) for d in where)
    if name == "Position":
        P = np.zeros((n, 3)) if sp.P is None else sp.P
        return (P + du[:, None] * sp.dPdu) + dv[:, None] * sp.dPdv
    if name == "Normal":
        return sp.N
    if name == "True Normal":
        return sp.Ng
    if name == "Incoming":
        return sp.N if sp.I is None else sp.I
    if name == "Object Normal":                 # Cycles' object_inverse_normal_transform: L^T N, normalised
        return safe_normalize(np.einsum("nji,nj->ni", sp.linear, sp.N))
    if name == "Reflection":                    # -reflect(I, N) = 2 (I.N) N - I
        I = sp.N if sp.I is None else sp.I
        return 2.0 * np.einsum("ij,ij->i", I, sp.N)[:, None] * sp.N - I
    if name == "Parametric":
        uv = np.zeros((n, 2)) if sp.uv is None else sp.uv
        u, v = uv[:, 0] + du, uv[:, 1] + dv
        return np.stack([1.0 - u - v, u, np.zeros(n)], axis=1)
    return (sp.side < 0.0).astype(np.float64)[:, None]


def wireframe(size: np.ndarray, where: tuple, sp: ShadingPoint) -> np.ndarray:
    """Cycles' Wireframe node (svm_node_wireframe) with Size in world units (n,): 1 where the hit (or the bump's point
    `where`, its step du, dv: bump_step) lies within Size / 2 of a line through an edge of its triangle, else 0.
    Measured from corner 0: the point u (V1 - V0) + v (V2 - V0), the corners 0, V1 - V0, V2 - V0; |edge x (P - corner)|^2 < |edge|^2 (Size / 2)^2."""
    uv = np.zeros((len(size), 2)) if sp.uv is None else sp.uv
    u = uv[:, 0:1] + np.reshape(where[0], (-1, 1))
    v = uv[:, 1:2] + np.reshape(where[1], (-1, 1))
    P = u * sp.dPdu + v * sp.dPdv
    corners = (np.zeros_like(P), sp.dPdu, sp.dPdv)
    width = (0.5 * size) ** 2
    near = np.zeros(len(size), bool)
    for k in range(3):
        edge = corners[k] - corners[k - 1]
        crossed = np.cross(edge, P - corners[k])
        near |= np.einsum("ij,ij->i", crossed, crossed) < np.einsum("ij,ij->i", edge, edge) * width
    return near.astype(np.float64)


def curve_normal(T: np.ndarray, sp: ShadingPoint) -> np.ndarray:
    """Cycles' Curves Info Tangent Normal (curve_tangent_normal) (n, 3): the direction towards the viewer I with its
    part along the curve's tangent taken away, I - T (T.I) / |T|^2, normalised; T (n, 3) the curve's tangent at the
    hit in object space (turned to world space by the object's linear transform); 0 off strands (T zero)."""
    T = np.einsum("nij,nj->ni", np.asarray(sp.linear, np.float64).reshape(-1, 3, 3), T)
    I = sp.N if sp.I is None else sp.I
    length2 = np.einsum("ij,ij->i", T, T)
    along = np.divide(np.einsum("ij,ij->i", T, I), length2, out=np.zeros(len(T)), where=length2 > 0.0)
    across = safe_normalize(I - along[:, None] * T)
    return np.where((length2 > 0.0)[:, None], across, 0.0)


def orthonormals(N: np.ndarray) -> tuple:
    """Cycles' make_orthonormals (n, 3) x 2 of unit normals N (n, 3): a = (1, 1, 1) x N normalised ((-1, 1, 1) x N
    where N's components are all equal), b = N x a."""
    equal = (N[:, 0] == N[:, 1]) & (N[:, 0] == N[:, 2])
    a = np.stack([N[:, 2] - N[:, 1], np.where(equal, N[:, 0] + N[:, 2], N[:, 0] - N[:, 2]),
                  np.where(equal, -N[:, 1] - N[:, 0], N[:, 1] - N[:, 0])], axis=1)
    a = a / np.sqrt(np.einsum("ij,ij->i", a, a))[:, None]
    return a, np.cross(N, a)


def camera_cones(P: np.ndarray, frame) -> tuple:
    """The ray cones of the camera rays through points P (n, 3) in the camera's frame, as Cycles' compact camera ray
    differentials give them: (their footprint at P (n,), how fast it widens along the ray (n,)). A perspective camera:
    the angular pixel, the mean of |normalize(d + dx) - normalize(d)| over a pixel step dx, dy on the plane at depth
    1, d = P / P.z, and |P| times it; an orthographic one: a pixel's width in scene units, and 0. frame: the window
    (left, right, bottom, top, perspective, width, height)."""
    left, right, bottom, top, perspective, width, height = frame[:7]
    sx, sy = (right - left) / width, (top - bottom) / height
    if not perspective:
        return np.full(len(P), abs(sx)), np.zeros(len(P))
    d = np.stack([safe_divide(P[:, 0], P[:, 2]), safe_divide(P[:, 1], P[:, 2]), np.ones(len(P))], axis=1)
    unit = d / np.sqrt(np.einsum("ij,ij->i", d, d))[:, None]
    spread = 0.0
    for step in ((sx, 0.0, 0.0), (0.0, sy, 0.0)):
        moved = d + np.array(step)
        moved = moved / np.sqrt(np.einsum("ij,ij->i", moved, moved))[:, None] - unit
        spread = spread + np.sqrt(np.einsum("ij,ij->i", moved, moved))
    return np.sqrt(np.einsum("ij,ij->i", P, P)) * (0.5 * spread), 0.5 * spread


def ray_footprint(P: np.ndarray, frame: np.ndarray, sp: ShadingPoint) -> np.ndarray:
    """The ray's footprint (n,) at hits P (n, 3) in the camera's frame, Cycles' sd->dP (pixel_width's dP; the FOOTPRINT
    op, which the Huang hair model reads): a camera ray's from the camera's differentials (camera_cones), after a
    bounce (or a portal), on shadow rays and in a light's own shading the path's ray cone where it carries one, under a
    panoramic camera the path's cone on camera rays too; 0 where it is unknown."""
    panoramic = frame[4] >= 2.0
    footprint = np.zeros(len(P)) if panoramic else camera_cones(P, frame)[0]
    path = sp.path
    if path is not None and sp.t is not None:
        # After a bounce (or a portal), and on shadow rays, the ray cone the path carries (Cycles widens the camera
        # ray's over the whole path; a shadow ray keeps its vertex's footprint); on camera rays, also straight
        # through Transparent surfaces, the camera's own measure above.
        left = (path.bounce > 0) | (path.portal > 0) | ((path.flags & (PATH_SHADOW | PATH_EMISSION)) != 0) | panoramic
        carried = left & (path.cone >= 0.0)
        footprint = np.where(carried, footprints(path, sp.t), footprint)
    return footprint


def pixel_width(P: np.ndarray, frame: np.ndarray, sp: ShadingPoint) -> np.ndarray:
    """The width of a pixel at hits P (n, 3) in the camera's frame, as Cycles' Wireframe node measures it for Pixel Size
    (n,), from a camera ray's differentials: the ray's footprint there, dP (a perspective camera: the distance |P| times
    the mean of |normalize(d + dx) - normalize(d)| over a pixel step dx, dy on the plane at depth 1, d = P / P.z; an
    orthographic one: a pixel's width in scene units), spread along two directions a, b across the face
    (orthonormals of Ng) and each projected onto the plane across the view: dP (|a - (a.I) I| + |b - (b.I) I|) / 2.
    At hits after a bounce (or a Ray Portal), on shadow rays and in a light's own shading the path's ray cone instead,
    where it carries one (LightPath cone, spread: Cycles' compact ray differentials, the camera ray's cone widened over
    the whole path; a light's sample has none, so no wire shows there, as in Cycles); under a panoramic camera the
    path's cone on camera rays too (camera.panorama_cones), 0 where it is unknown.
    frame: the window (left, right, bottom, top, perspective, width, height; perspective >= 2: a panorama's)."""
    footprint = ray_footprint(P, frame, sp)
    I = sp.N if sp.I is None else sp.I
    across = 0.0
    for axis in orthonormals(sp.Ng):
        projected = axis - np.einsum("ij,ij->i", axis, I)[:, None] * I
        across = across + np.sqrt(np.einsum("ij,ij->i", projected, projected))
    return footprint * (0.5 * across)


def window(P: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Cycles' Window coordinates (camera_world_to_ndc) (n, 3) of points P (n, 3) in the camera's frame: where on the
    image they show, 0 .. 1 from its left and bottom edges, z 0; frame: (left, right, bottom, top, perspective), the
    camera's viewplane (core/camera viewplane: on the plane at depth 1 for a perspective camera, whose points are
    divided by their depth first)."""
    left, right, bottom, top, perspective = frame[:5]
    if perspective >= 2.0:
        return panorama_window(P, frame)
    x, y = (safe_divide(P[:, 0], P[:, 2]), safe_divide(P[:, 1], P[:, 2])) if perspective else (P[:, 0], P[:, 1])
    return np.stack([(x - left) / (right - left), (y - bottom) / (top - bottom), np.zeros(len(P))], axis=1)


# A panoramic camera's Window (core/render: MaterialTable.window's fifth number is 2 + the type's place here).
PANORAMA_WINDOWS = ("EQUIRECTANGULAR", "EQUIANGULAR_CUBEMAP_FACE", "MIRRORBALL", "FISHEYE_EQUIDISTANT",
                    "FISHEYE_EQUISOLID", "CENTRAL_CYLINDRICAL", "FISHEYE_LENS_POLYNOMIAL")
# The polynomial fisheye's radius for a direction: Newton's steps from the linear term's root, at most this many, until
# a step moves it less than POLYNOMIAL_STOP (Cycles' direction_to_fisheye_lens_polynomial).
POLYNOMIAL_STEPS = schema.constant("POLYNOMIAL_STEPS", 20, "the polynomial fisheye Window's Newton steps, at most")
POLYNOMIAL_STOP = schema.constant("POLYNOMIAL_STOP", 1e-6, "the polynomial fisheye Window's Newton steps stop below")


def panorama_window(P: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Cycles' Window under a panoramic camera (camera_world_to_ndc, direction_to_panorama) (n, 3) of points P (n, 3)
    in the camera's frame (x right, y up, z forward): their direction turned into the panorama's frame (x forward, y
    left, z up; a mirror ball's y forward) and mapped to its (u, v) as Cycles' direction_to_<type>; z 0. frame: (a, b,
    c, d, 2 + the type's place in PANORAMA_WINDOWS, e, f, g): equirectangular and central cylindrical (range x, y, z,
    w), the equidistant fisheye (fov), the equisolid one (lens, sensor width, sensor height), the polynomial one (k0 ..
    k3, then k4, sensor width, sensor height)."""
    a, b, c, d, code, e, f, g = frame
    kind = PANORAMA_WINDOWS[int(code) - 2]
    P = safe_normalize(P)
    D = (np.stack([P[:, 0], -P[:, 2], P[:, 1]], axis=1) if kind == "MIRRORBALL"
         else np.stack([P[:, 2], -P[:, 0], P[:, 1]], axis=1))
    if kind == "EQUIRECTANGULAR":
        u = (np.arctan2(D[:, 1], D[:, 0]) - b) / a
        v = (np.arccos(np.clip(D[:, 2] / np.sqrt(np.einsum("ij,ij->i", D, D)), -1.0, 1.0)) - d) / c
    elif kind == "EQUIANGULAR_CUBEMAP_FACE":
        u = 0.5 - np.arctan2(D[:, 1], D[:, 0]) * (2.0 / math.pi)
        v = np.arctan2(D[:, 2], D[:, 0]) * (2.0 / math.pi) + 0.5
    elif kind == "MIRRORBALL":
        D = D - np.array([0.0, 1.0, 0.0])
        div = 2.0 * np.sqrt(np.maximum(-0.5 * D[:, 1], 0.0))
        D = np.where((div > 0.0)[:, None], D / np.where(div > 0.0, div, 1.0)[:, None], D)
        u, v = 0.5 * (D[:, 0] + 1.0), 0.5 * (D[:, 2] + 1.0)
    elif kind == "CENTRAL_CYLINDRICAL":
        z = safe_divide(D[:, 2], np.sqrt(D[:, 0] * D[:, 0] + D[:, 1] * D[:, 1]))
        u = (np.arctan2(D[:, 1], D[:, 0]) - a) / (b - a)
        v = (z - c) / (d - c)
    else:                                                           # the fisheyes: a radius towards (y, z)
        across = np.sqrt(D[:, 1] * D[:, 1] + D[:, 2] * D[:, 2])
        if kind == "FISHEYE_EQUIDISTANT":
            r, width, height = np.arctan2(across, D[:, 0]) / a, 1.0, 1.0
        elif kind == "FISHEYE_LENS_POLYNOMIAL":
            r, width, height = polynomial_radius(-np.arccos(np.clip(D[:, 0], -1.0, 1.0)), (a, b, c, d, e)), f, g
        else:
            r, width, height = 2.0 * a * np.sin(0.5 * np.arccos(np.clip(D[:, 0], -1.0, 1.0))), b, c
        y, z = safe_divide(D[:, 1], across), safe_divide(D[:, 2], across)
        u, v = 0.5 - (r * y) / width, (r * z) / height + 0.5
    return np.stack([u, v, np.zeros(len(P))], axis=1)


def polynomial_radius(theta: np.ndarray, k: tuple) -> np.ndarray:
    """The radius r (n,) on the sensor where the polynomial fisheye's angle k0 + k1 r + k2 r^2 + k3 r^3 + k4 r^4 is
    theta (n,) (Cycles' direction_to_fisheye_lens_polynomial): Newton's method from (theta - k0) / k1, each radius
    stopping once a step moves it less than POLYNOMIAL_STOP, POLYNOMIAL_STEPS steps at most."""
    k0, k1, k2, k3, k4 = (float(x) for x in k)
    r = (theta - k0) / k1
    moving = np.ones(len(theta), bool)
    for _ in range(POLYNOMIAL_STEPS):
        r2 = r * r
        F = theta - (k0 + (((k1 * r + k2 * r2) + k3 * (r2 * r)) + k4 * (r2 * r2)))
        dF = ((k1 + 2.0 * k2 * r) + 3.0 * k3 * r2) + 4.0 * k4 * (r2 * r)
        step = np.where(moving, F / dF, 0.0)
        r = r + step
        moving &= np.abs(step) >= POLYNOMIAL_STOP
        if not moving.any():
            break
    return r


def camera_data(P: np.ndarray) -> np.ndarray:
    """Cycles' Camera Data (svm_node_camera) (n, 5) of points P (n, 3) in the camera's frame: the View Vector
    P / |P|, the View Z Depth P.z, the View Distance |P|."""
    distance = np.sqrt(np.einsum("ij,ij->i", P, P))
    return np.concatenate([safe_normalize(P), P[:, 2:3], distance[:, None]], axis=1)


def fresnel_cos(cos_i: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Cycles' fresnel_dielectric_cos: the unpolarized reflectance (n,) of a dielectric of relative index eta (n,)
    seen at cos_i (n,) (its sign ignored), written without the refracted direction; 1 under total internal
    reflection."""
    c = np.abs(cos_i)
    g2 = eta * eta - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        A = (g - c) / (g + c)
        B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(g2 > 0.0, 0.5 * A * A * (1.0 + B * B), 1.0)


def view_cosine(normal: Optional[np.ndarray], sp: ShadingPoint) -> np.ndarray:
    """I.normal (n,): the cosine between the direction back along the ray and a node's Normal input (n, 3), or the
    shading normal where it is unlinked (None), as Cycles' dot(sd->wi, N)."""
    N = sp.N if normal is None else normal
    I = sp.N if sp.I is None else sp.I
    return np.einsum("ij,ij->i", I, N)


def fresnel(ior: np.ndarray, normal: Optional[np.ndarray], sp: ShadingPoint) -> np.ndarray:
    """Cycles' Fresnel node (svm_node_fresnel) (n,): the dielectric reflectance for index max(IOR, 1e-5) at the
    view cosine, the index inverted where the back of the face was hit (light leaving the object)."""
    eta = np.maximum(ior, 1e-5)
    eta = np.where(sp.side < 0.0, 1.0 / eta, eta)
    return fresnel_cos(view_cosine(normal, sp), eta)


def layer_weight(blend: np.ndarray, normal: Optional[np.ndarray], sp: ShadingPoint) -> np.ndarray:
    """Cycles' Layer Weight node (svm_node_layer_weight) (n, 2): Fresnel, the reflectance for the index
    1 / max(1 - Blend, 1e-5) (its inverse where the back was hit), and Facing, 1 - |I.N| raised to the power
    2 Blend (Blend < 0.5) or 0.5 / (1 - Blend), with Blend clamped to [0, 1 - 1e-5] and no power at 0.5."""
    cos_i = view_cosine(normal, sp)
    eta = np.maximum(1.0 - blend, 1e-5)
    eta = np.where(sp.side < 0.0, eta, 1.0 / eta)
    f = np.abs(cos_i)
    b = np.clip(blend, 0.0, 1.0 - 1e-5)
    power = np.where(b < 0.5, 2.0 * b, 0.5 / (1.0 - b))
    with np.errstate(divide="ignore", invalid="ignore"):
        facing = np.where(blend != 0.5, np.power(f, power), f)
    return np.stack([fresnel_cos(cos_i, eta), 1.0 - facing], axis=1)


def tangent(source: np.ndarray, uv_map: int, axis: int, sp: ShadingPoint) -> np.ndarray:
    """Cycles' Tangent node (svm_node_tangent) in world space (n, 3): radial about `axis` (0 X, 1 Y, 2 Z) of the
    Generated coordinates `source` (n, 3), or the UV map's tangent `source` (uv_map 1); turned to world space as
    a normal is (the cofactor of the object's linear transform), then made perpendicular to the shading normal:
    N x normalize(T x N). Zero where the mesh has none."""
    if uv_map:
        T = source
    else:
        g = source - 0.5
        zero = np.zeros(len(g))
        T = (np.stack([zero, -g[:, 2], g[:, 1]], axis=1) if axis == 0 else
             np.stack([-g[:, 2], zero, g[:, 0]], axis=1) if axis == 1 else np.stack([-g[:, 1], g[:, 0], zero], axis=1))
    m0, m1, m2 = sp.linear[:, :, 0], sp.linear[:, :, 1], sp.linear[:, :, 2]
    T = T[:, 0:1] * np.cross(m1, m2) + T[:, 1:2] * np.cross(m2, m0) + T[:, 2:3] * np.cross(m0, m1)
    return np.cross(sp.N, safe_normalize(np.cross(T, sp.N)))


def map_range(kind: int, clamp: int, value, from_min, from_max, to_min, to_max, steps) -> np.ndarray:
    """Cycles' float Map Range (svm_map_range) of MAP_RANGE_TYPES[kind]."""
    name = MAP_RANGE_TYPES[kind]
    if name in ("LINEAR", "STEPPED"):
        factor = safe_divide(value - from_min, from_max - from_min)
        if name == "STEPPED":
            factor = np.where(steps > 0.0, np.floor(factor * (steps + 1.0)) / np.where(steps > 0.0, steps, 1.0), 0.0)
        result = to_min + factor * (to_max - to_min)
        if clamp:
            result = np.where(to_min > to_max, np.clip(result, to_max, to_min), np.clip(result, to_min, to_max))
        return result
    if name == "SMOOTHSTEP":
        def smooth(e0, e1, x):
            t = safe_divide(x - e0, e1 - e0)
            return np.where(x < e0, 0.0, np.where(x >= e1, 1.0, t * t * (3.0 - 2.0 * t)))
        factor = np.where(from_min > from_max, 1.0 - smooth(from_max, from_min, value), smooth(from_min, from_max, value))
    else:
        def smoother(e0, e1, x):
            t = np.clip(safe_divide(x - e0, e1 - e0), 0.0, 1.0)
            return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
        factor = np.where(from_min > from_max, 1.0 - smoother(from_max, from_min, value),
                          smoother(from_min, from_max, value))
    return to_min + factor * (to_max - to_min)


def normal_map(color: np.ndarray, strength: np.ndarray, tangent_offset: int, sp: ShadingPoint,
               attributes: np.ndarray, fallback: Optional[np.ndarray] = None) -> np.ndarray:
    """Cycles' tangent-space Normal Map (svm_node_normal_map), in world space: the mesh's interpolated
    tangent turned by the object's linear transform, the bitangent sign x N x T, strength applied in
    tangent space; the hit's normal `fallback` (n, 3) (after a Set Normal, its normal; None: sp.N) where the mesh
    has no tangents."""
    fallback = sp.N if fallback is None else fallback
    if tangent_offset < 0:
        return fallback.copy()
    c = 2.0 * (color - 0.5)
    s = strength[:, None]
    c = np.concatenate([c[:, :2] * s, (1.0 + np.clip(s, 0.0, 1.0) * (c[:, 2:3] - 1.0))], axis=1)
    t = attributes[:, tangent_offset:tangent_offset + 3]
    sign = attributes[:, tangent_offset + 3]
    T = np.einsum("nij,nj->ni", sp.linear, t)
    n = sp.N * sp.side[:, None]                      # the front side's normal
    B = sign[:, None] * np.cross(n, T)
    out = safe_normalize(c[:, 0:1] * T + c[:, 1:2] * B + c[:, 2:3] * n) * sp.side[:, None]
    bad = ~np.isfinite(out).all(axis=1) | (np.abs(out).sum(axis=1) == 0.0)
    return np.where(bad[:, None], fallback, out)


def tangent_space(v: np.ndarray, tangent_offset: int, sp: ShadingPoint) -> np.ndarray:
    """Cycles' Vector Displacement in tangent space (svm_node_vector_displacement) before its object-to-world step:
    v (n, 3) along the mesh's interpolated tangent T (object space; where the mesh has none, the triangle's edge
    dPdu normalised), the shading normal N taken into object space and the bitangent sign x normalize(N x T), in
    that order (x along T, y along N, z along the bitangent): (n, 3) in object space."""
    n = len(v)
    normal = safe_normalize(np.einsum("nji,nj->ni", sp.linear, sp.N))
    stored = (sp.attributes[:, tangent_offset:tangent_offset + 4] if tangent_offset >= 0 else np.zeros((n, 4)))
    missing = ~np.any(stored != 0.0, axis=1)[:, None]
    T = np.where(missing, safe_normalize(sp.dPdu), stored[:, :3])
    B = safe_normalize(np.cross(normal, T)) * np.where(missing, 1.0, stored[:, 3:4])
    return (T * v[:, 0:1] + normal * v[:, 1:2]) + B * v[:, 2:3]


def bump_differentials(sp: ShadingPoint) -> tuple:
    """The ray's differentials across the surface at n hits as Cycles' Bump reads them, ((n, 3), (n, 3), known (n,)
    bool): the footprint (footprints of sp.path at sp.t; 0: none, as a light's sample, so the bump is flat) along
    make_orthonormals of Ng (differential_from_compact); where the cone is unknown (UNKNOWN_CONE, or no path),
    BUMP_STEP (V1 - V0) and BUMP_STEP (V2 - V0)."""
    n = len(sp.N)
    footprint = np.full(n, UNKNOWN_CONE)
    if sp.path is not None and sp.t is not None:
        footprint = np.where(sp.path.cone >= 0.0, np.maximum(footprints(sp.path, sp.t), 0.0), UNKNOWN_CONE)
    known = footprint >= 0.0
    a, b = orthonormals(sp.Ng)
    return (np.where(known[:, None], footprint[:, None] * a, BUMP_STEP * sp.dPdu),
            np.where(known[:, None], footprint[:, None] * b, BUMP_STEP * sp.dPdv), known)


def bump_step(where: int, width, sp: ShadingPoint) -> tuple:
    """The step (du, dv), (n,) each, in the barycentrics from the hit to a bump's point `where` (0 the hit, 1 and 2
    its two steps) for a Bump of Filter Width `width` ((n,) or scalar): bump_differentials' dPdx (1) or dPdy (2) times
    the width, solved for du dPdu + dv dPdv on the triangle's edges (Cycles' differential_dudv); where the footprint
    is unknown, BUMP_STEP along V1 - V0 (1) or V2 - V0 (2), whatever the width."""
    n = len(sp.N)
    if where == 0:
        return np.zeros(n), np.zeros(n)
    dPdx, dPdy, known = bump_differentials(sp)
    d = dPdx if where == 1 else dPdy
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)      # noqa: E731
    uu, uv, vv, du_d, dv_d = dot(sp.dPdu, sp.dPdu), dot(sp.dPdu, sp.dPdv), dot(sp.dPdv, sp.dPdv), \
        dot(sp.dPdu, d), dot(sp.dPdv, d)
    det = uu * vv - uv * uv
    width = np.asarray(width, np.float64)
    du = width * safe_divide(vv * du_d - uv * dv_d, det)
    dv = width * safe_divide(uu * dv_d - uv * du_d, det)
    return (np.where(known, du, BUMP_STEP if where == 1 else 0.0),
            np.where(known, dv, BUMP_STEP if where == 2 else 0.0))


def lit_by_bump(sp: ShadingPoint) -> np.ndarray:
    """Which of n hits a Bump shades (n,) float64 1 or 0: not a light's own shading (PATH_EMISSION: a light's sample
    on an emitter, the world, a lamp), where Cycles evaluates no bump nodes (KERNEL_FEATURE_NODE_MASK_SURFACE_LIGHT):
    the Bump's Normal is the zero vector there, and a Displacement's Set Normal keeps the hit's normal."""
    if sp.path is None:
        return np.ones(len(sp.N))
    return np.where((np.asarray(sp.path.flags) & PATH_EMISSION) != 0, 0.0, 1.0) * np.ones(len(sp.N))


def undisplaced_point(position: int, normal: int, sp: ShadingPoint) -> ShadingPoint:
    """The ShadingPoint of n hits on a displaced mesh as Cycles' ENTER_BUMP_EVAL makes it: P and the edges dPdu, dPdv
    from the object-space attribute at `position` (the vertices before they moved) taken to world space, N the unit
    normal before they moved (the attribute at `normal`, to world space, flipped where the back was hit); Ng, the
    barycentrics and the attributes as they are."""
    p, q = slice(position, position + 3), slice(normal, normal + 3)
    M = object_matrices(sp, 0).reshape(-1, 3, 4)
    to_world = lambda v: np.einsum("nij,nj->ni", M[:, :, :3], v)          # noqa: E731
    N = safe_normalize(np.einsum("nij,nj->ni", object_matrices(sp, 4).reshape(-1, 3, 4)[:, :, :3],
                                 safe_normalize(sp.attributes[:, q])))
    return sp._replace(P=to_world(sp.attributes[:, p]) + M[:, :, 3], dPdu=to_world(sp.d_du[:, p]),
                       dPdv=to_world(sp.d_dv[:, p]), N=N * sp.side[:, None])


def undisplaced_differentials(sp: ShadingPoint, moved: ShadingPoint) -> tuple:
    """bump_differentials over the surface before it moved (Cycles' saved dP.dx, dP.dy of the undisplaced position):
    the barycentric steps the footprint takes on the moved triangle (bump_step of `moved`, width 1) along the
    edges of the unmoved one (sp.dPdu, sp.dPdv: undisplaced_point). ((n, 3), (n, 3), known (n,) bool)."""
    known = bump_differentials(moved)[2]
    steps = [bump_step(where, 1.0, moved) for where in (1, 2)]
    return tuple(du[:, None] * sp.dPdu + dv[:, None] * sp.dPdv for du, dv in steps) + (known,)


def bump(normal: np.ndarray, strength, distance, h_c, h_x, h_y, invert: int, width, sp: ShadingPoint,
         moved: Optional[ShadingPoint] = None) -> np.ndarray:
    """Cycles' Bump (svm_node_set_bump) (n, 3) from the heights at the hit and at its two steps (bump_step), with
    bump_differentials' dPdx, dPdy and the Filter Width `width` ((n,)): normalize(width |det| N - distance sign(det)
    surfgrad), width 1 where the footprint is unknown (the steps are BUMP_STEP of the edges then). With `moved` (the
    hits on the displaced mesh; sp then undisplaced_point's), the differentials over the surface before it moved, and
    in object space as Cycles' Displacement and Bump (ShaderGraph::finalize's bump_in_object_space: the normal and
    differentials taken into the object's space, the result back to the world's)."""
    dPdx, dPdy, known = bump_differentials(sp) if moved is None else undisplaced_differentials(sp, moved)
    if moved is not None:       # (Displacement and Bump's bump runs in object space: bump_in_object_space)
        n = len(normal)
        inverse = object_matrices(sp, 3).reshape(n, 3, 4)[:, :, :3]
        normal = safe_normalize(np.einsum("nji,nj->ni", sp.linear, normal))
        dPdx, dPdy = (np.einsum("nij,nj->ni", inverse, d) for d in (dPdx, dPdy))
    Rx, Ry = np.cross(dPdy, normal), np.cross(normal, dPdx)
    det = np.einsum("ij,ij->i", dPdx, Rx)
    surfgrad = (h_x - h_c)[:, None] * Rx + (h_y - h_c)[:, None] * Ry
    scale = -distance if invert else distance
    strength = np.maximum(strength, 0.0)
    width = np.where(known, width, 1.0)
    out = safe_normalize((width * np.abs(det))[:, None] * normal - (scale * np.sign(det))[:, None] * surfgrad)
    zero = np.abs(out).sum(axis=1) == 0.0
    mixed = safe_normalize(strength[:, None] * out + (1.0 - strength)[:, None] * normal)
    out = np.where(zero[:, None], normal, mixed)
    return out if moved is None else safe_normalize(np.einsum("nji,nj->ni", inverse, out))


def apply_outputs(program: Program, reg: np.ndarray, weights: list, rows: list, normals: list,
                  Ng: Optional[np.ndarray] = None, wo: Optional[np.ndarray] = None) -> None:
    """Overwrite the shader nodes' per-hit weights (n, 3), rows (n, NODE_PARAMS) and normals ((n, 3) or None)
    with the program's outputs (lists indexed by shader node, changed in place); a normal output to slot > 0
    (a node's normal input, e.g. Coat Normal) goes to the row, unit and, given Ng and wo (n, 3), corrected by
    valid_reflection. Returns the hit's own normal (n, 3) from a normal output to node -1 (Set Normal; zero
    where it has none), or None."""
    hit_normal = None
    for kind, node, slot, width, register in program.outputs.astype(np.int64):
        value = reg[:, register:register + width]
        if kind == OUT_AOV:                         # (a shader AOV's: aov_values)
            continue
        if node < 0:
            hit_normal = safe_normalize(value)
        elif kind == OUT_INPUT:
            rows[node][:, slot:slot + width] = value
        elif kind == OUT_WEIGHT:
            if slot == 0:
                factor = np.clip(value, 0.0, 1.0)
            elif slot == 1:
                factor = 1.0 - np.clip(value, 0.0, 1.0)
            else:
                factor = np.maximum(value, 0.0)
            weights[node] = weights[node] * factor
        elif slot == 0:
            normals[node] = safe_normalize(value)
        else:
            unit = safe_normalize(value)
            if Ng is not None:                      # (zero stays zero: the node reads it as unlinked)
                unit = np.where(np.any(unit != 0.0, axis=1)[:, None], valid_reflection(Ng, wo, unit), 0.0)
            rows[node][:, slot:slot + 3] = unit
    return hit_normal


def aov_values(program: Program, reg: np.ndarray, channels: int) -> Optional[np.ndarray]:
    """The shader AOVs' channels (n, channels) float64 the program's AOV Output nodes write at n hits with registers
    reg (n, R) (OUT_AOV rows; Cycles' svm_node_aov_color and _value): a COLOR AOV its Color and 1 in the alpha
    channel after it, a VALUE AOV its Value, summed where two nodes name the same AOV; None where it has none."""
    rows = [o for o in np.asarray(program.outputs).reshape(-1, 5).astype(np.int64) if o[0] == OUT_AOV]
    if not rows or channels <= 0:
        return None
    out = np.zeros((len(reg), channels))
    for _, first, _, width, register in rows:
        out[:, first:first + width] += reg[:, register:register + width]
        if width == 3:
            out[:, first + 3] += 1.0
    return out


def empty_point(n: int, width: int) -> ShadingPoint:
    """A ShadingPoint of n hits with no attributes (tests and scenes without meshes' data)."""
    z = np.zeros((n, width))
    return ShadingPoint(z, z, z, np.zeros(n), np.tile([0.0, 0.0, 1.0], (n, 1)), np.ones(n),
                        np.tile(np.eye(3), (n, 1, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)), np.tile([0.0, 1.0, 0.0], (n, 1)),
                        np.tile([0.0, 0.0, 1.0], (n, 1)))


def valid_reflection(Ng: np.ndarray, wo: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Cycles' ensure_valid_specular_reflection for a node's own normal N (n, 3) (unit): where the mirror
    direction of wo about N would dip below the face (Ng) by more than a threshold, N turned towards Ng just
    enough (Cycles does this to every BSDF's normal input when Bump Map Correction is on, its default)."""
    R = 2.0 * np.einsum("ij,ij->i", N, wo)[:, None] * N - wo
    Iz = np.einsum("ij,ij->i", wo, Ng)
    threshold = np.minimum(0.9 * Iz, 0.01)
    bad = np.einsum("ij,ij->i", Ng, R) < threshold
    if not bad.any():
        return N
    X = N - np.einsum("ij,ij->i", N, Ng)[:, None] * Ng
    length = np.sqrt(np.einsum("ij,ij->i", X, X))
    X = np.where(length[:, None] > 0.0, X / np.where(length > 0.0, length, 1.0)[:, None], N)
    Ix = np.einsum("ij,ij->i", wo, X)
    a = Ix * Ix + Iz * Iz
    b = 2.0 * (a + Iz * threshold)
    c = (threshold + Iz) ** 2
    root = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    a_safe = np.where(a != 0.0, a, 1.0)
    Nz2 = np.where(Ix < 0.0, 0.25 * (b + root) / a_safe, 0.25 * (b - root) / a_safe)
    Nx, Nz = np.sqrt(np.maximum(1.0 - Nz2, 0.0)), np.sqrt(np.maximum(Nz2, 0.0))
    return np.where(bad[:, None], Nx[:, None] * X + Nz[:, None] * Ng, N)



GraphTablesRecord = schema.record("GraphTables", """Every program of a render's materials (core/materials/graph.py). ops: (k, OP_WIDTH) the op code and its
arguments; programs: (p, PROGRAM_INFO) first op, op count, first constant, constant count, registers, first output,
output count, first ramp float, first entry of emission_nodes. (Numbers that index stay doubles here: one row type for
codes, registers and constants.) emission_ops, emission_nodes: what a light sample runs (graph.emission_live).""", [
    ("ops", ptr(F64), "(k, OP_WIDTH)"),
    ("args", ptr(I32), "(k, OP_WIDTH - 1) the ops' arguments as integers (the interpreter reads these)"),
    ("constants", ptr(F64), "(c,)"),
    ("outputs", ptr(F64), "(o, 5) rows of graph.Program.outputs"),
    ("ramps", ptr(F64), "(r,) the colour ramps' floats"),
    ("programs", ptr(F64), "(p, PROGRAM_INFO)"),
    ("emission_ops", ptr(F64), "(k,) 1: the op runs when only the emission is wanted"),
    ("emission_nodes", ptr(F64), "per program 1 + its material's node count: 1 where Set Normal's output, then each "
                                 "node, is set up when only the emission is wanted"),
    ("textures", ptr("TextureTables"), "the images the programs read"),
    ("count", I64, "p"),
], tables=("OP",))


# Ops that read the ray's cone (graph.LightPath cone, spread): Bump's step and its OFFSET points (bump_differentials),
# the Ray Footprint and Wireframe's Pixel Size (ray_footprint: the path's cone after a bounce, and under a panoramic
# camera). A render none of whose programs holds one skips the camera rays' cones in C (rays.cones_read).
CONE_OPS = ("BUMP", "OFFSET", "FOOTPRINT", "PIXEL_SIZE")


def reads_cone(program: Optional[Program]) -> bool:
    """Whether `program` (or None: no program) holds an op of CONE_OPS, which reads the path's ray cone."""
    if program is None or len(program.ops) == 0:
        return False
    codes = np.asarray(program.ops, np.float64).reshape(len(program.ops), -1)[:, 0].astype(np.int64)
    return bool(np.isin(codes, [OP[name] for name in CONE_OPS]).any())


# Ops that write no register but change what the ops after them read (the bump's point, the surface before it moved,
# Set Normal's normal): `live_ops` keeps them always.
STATE_OPS = ("OFFSET", "UNDISPLACED", "SET_NORMAL")


def live_ops(program: Program, wanted) -> np.ndarray:
    """Which ops of `program` the registers `wanted` (iterable of (first register, width)) depend on: (k,) bool.
    The ops of STATE_OPS are always live; a program without `blocks` has every op live. Conservative: a read of one
    register of a block depends on every op that writes into that block, wherever it stands in the program."""
    ops, blocks, c = program.ops, np.asarray(program.blocks, np.int64).reshape(-1, 2), len(program.constants)
    live = np.zeros(len(ops), bool)
    if len(blocks) == 0:
        live[:] = True
        return live
    block_of = np.full(max(1, program.registers), -1, np.int64)     # register -> its block (-1: a constant)
    for b, (start, width) in enumerate(blocks):
        block_of[start:start + width] = b
    writers, reads = [[] for _ in blocks], []
    for k, row in enumerate(ops):
        name, args = OPS[int(row[0])], [int(x) for x in row[1:]]
        registers = sorted(REGISTER_ARGS[name])
        written = 0 in registers and name != "SET_NORMAL"
        if written and args[0] >= c:
            writers[block_of[args[0]]].append(k)
        reads.append([args[j] for j in registers if (j > 0 or not written) and args[j] >= c])
        live[k] = name in STATE_OPS
    needed = np.zeros(len(blocks), bool)
    stack = [k for k in range(len(ops)) if live[k]]
    for start, width in wanted:
        for r in range(int(start), int(start) + int(width)):
            if r >= c and block_of[r] >= 0 and not needed[block_of[r]]:
                needed[block_of[r]] = True
                stack.extend(writers[block_of[r]])
    while stack:
        k = stack.pop()
        live[k] = True
        for r in reads[k]:
            b = block_of[r]
            if b >= 0 and not needed[b]:
                needed[b] = True
                stack.extend(w for w in writers[b] if not live[w])
    return live


def emission_live(program: Program, nodes: list) -> tuple:
    """What a light sample (only the emission) must run of a material's `program`, its shader `nodes` [(node class,
    weight, row), ...]: (the ops, (k,) bool (live_ops); the nodes whose setup may emit, (1 + n,) bool, entry 0 for
    Set Normal's output (needed where an emitting node reads its normal), entry 1 + j for node j). The emission comes
    out the same as the whole program's: the other nodes add only closures."""
    outputs = np.asarray(program.outputs).reshape(-1, 5)
    nodes_live = np.zeros(1 + len(nodes), bool)
    for j, (cls, _, row) in enumerate(nodes):
        slots = getattr(cls, "emission_slots", None)
        if slots is None:
            continue
        linked = any(int(o[0]) == OUT_INPUT and int(o[1]) == j and int(o[2]) < slots[1]
                     and int(o[2]) + int(o[3]) > slots[0] for o in outputs)
        nodes_live[1 + j] = linked or bool(np.any(np.asarray(row, np.float64)[slots[0]:slots[1]] != 0.0))
        nodes_live[0] |= nodes_live[1 + j] and getattr(cls, "emission_reads_normal", False)
    wanted = []
    for o in outputs:
        node = int(o[1])
        if int(o[0]) == OUT_AOV:                    # (a shader AOV's: no emission depends on it)
            continue
        if node < 0:
            keep = nodes_live[0]
        else:
            keep = nodes_live[1 + node] and (int(o[0]) != OUT_NORMAL or nodes[node][0].emission_reads_normal)
        if keep:
            wanted.append((int(o[4]), int(o[3])))
    return live_ops(program, wanted), nodes_live


class GraphTables:
    """Every program of a render's materials as C reads them (GraphTables): the record, and `rows`: material row ->
    program index."""

    def __init__(self, table, layout: dict):
        programs, emission, self.rows = [], [], {}
        for row in range(len(table.shaders)):
            program = table.program(row, layout)
            if program is not None:
                self.rows[row] = len(programs)
                programs.append(program)
                emission.append(emission_live(program, table.shaders[row].nodes))
        self.record = program_tables(programs, table.textures, emission)


def program_tables(programs: list, textures, emission: Optional[list] = None) -> "GraphTablesRecord":
    """The GraphTables record of `programs` (their ops, constants, outputs and ramps joined, one row of offsets each)
    reading the images of the TextureSet `textures`; emission: each program's emission_live, or None (a program not
    of a material's nodes: every op live, no node)."""
    emission = emission if emission is not None else [(np.ones(len(p.ops), bool), np.zeros(1, bool))
                                                      for p in programs]
    info = np.zeros((max(1, len(programs)), PROGRAM_INFO))
    starts = np.zeros(5, np.int64)                      # ops, constants, outputs, ramp floats, emission nodes so far
    for k, p in enumerate(programs):
        info[k] = [starts[0], len(p.ops), starts[1], len(p.constants), p.registers, starts[2], len(p.outputs),
                   starts[3], starts[4]]
        starts += [len(p.ops), len(p.constants), len(p.outputs), len(p.ramps), len(emission[k][1])]
    joined = lambda arrays, width: (np.concatenate([a.reshape(-1) for a in arrays]) if arrays   # noqa: E731
                                    else np.zeros(width))
    c = library.contiguous
    return GraphTablesRecord(
        ops=c(joined([p.ops for p in programs], 1 + OP_ARGS), np.float64),
        args=c(joined([p.ops.reshape(-1, 1 + OP_ARGS)[:, 1:].astype(np.int32) for p in programs], OP_ARGS), np.int32),
        constants=c(joined([p.constants for p in programs], 1), np.float64),
        outputs=c(joined([p.outputs for p in programs], 5), np.float64),
        ramps=c(joined([p.ramps for p in programs], 4), np.float64), programs=c(info, np.float64),
        emission_ops=c(joined([ops.astype(np.float64) for ops, _ in emission], 1), np.float64),
        emission_nodes=c(joined([nodes.astype(np.float64) for _, nodes in emission], 1), np.float64),
        textures=textures_.texture_tables(textures), count=len(programs))


def graph_tables(table, layout: dict):
    """The GraphTables of a MaterialTable for an attribute layout, or None when no material has links."""
    return GraphTables(table, layout) if table.has_graphs else None
