"""A lamp's node tree evaluated per light sample and per ray that meets the lamp (issue 33).

Cycles evaluates a lamp's shader wherever it asks for the lamp's light (light_sample_shader_eval: for each light
sample, and for each BSDF ray that meets the lamp), at a shading point shader_setup_from_sample sets up from the
sample (kernel/geom/shader_data.h, kernel/light/point.h, spot.h, area.h, distant.h), with EMISSION alone as the
path's flags and the path's own counts (svm_node_light_path reads the integrator state's): a light sample's those
of the vertex it lights (Ray Depth one more, as for every EMISSION or SHADOW evaluation), a BSDF ray's those after
its bounce (path_state_next counted it), so the two ways to one lamp may see different depths, as in Cycles; and the
lamp's own object (ls->object = klight->object_id): Object Info's Location, Color, Alpha, Object Index and Random
are the lamp object's, its Material Index 0, an Attribute node's Object attributes the lamp object's:

- P the point on the lamp (a round lamp's disc facing the lit point, its sphere without Soft Falloff, the point
  itself at radius 0; the area lamp's point; a sun's: the direction its light travels, as a point), N = Ng the
  lamp's normal there: the direction leaving the lamp towards the lit point on a disc, a point or a sun, the sphere's
  outward normal, an area lamp's -Z axis; I (Cycles' wi) the direction leaving the lamp towards the lit point; the
  ray's length t (the Light Falloff's and Light Path's; a sun's FLT_MAX);
- the lamp's object transform M (its matrix, scale included): Texture Coordinate > Normal is M^T N normalised
  (object_inverse_normal_transform), Object M^-1 P, Generated the same (a lamp has no generated attribute, and
  svm_node_attr falls back to the object coordinates), UV the lamp's own (svm_node_attr's PRIMITIVE_LAMP case):
  a point lamp's map_to_sphere(M^-1 N), a spot's projection 0.5 + (x, y) cot(angle / 2) / (2 z) of the leaving
  direction in the spot's frame (z along its axis: the whole image fills the cone), an area lamp's 0.5 + its point
  along each edge / the edge's length, a sun's 0.5 + (M^-1 rows x, y) . D / (2 sin(angle / 4) |D - w|), D towards
  the sun, w the way its light travels (distant_light_uv; Cycles' half_inv_sin_half_angle is of its half angle).

The emission is the Emission node's Color x Strength there; the lamp's record multiplies its light by it (the light
sample's pdf is the lamp's own: Cycles samples lamps without regard to their shader). A lamp whose tree is constant
carries no program (its colour holds the constant, addon/export.py light_node_factor), so it pays nothing.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from ..materials import graph as graph_
from ..materials import textures as textures_
from ..native import schema
from ..native.schema import F64, I32, I64, ptr

# The attributes a lamp's shading point has (Cycles' lamp: UV, and Generated = Object coordinates).
LAMP_ATTRIBUTES = ("generated", "object", "uv:")
# How a lamp's UV is made (LampGraph.uv_kind): Cycles' point, spot and area lamps'.
_UV = schema.constants("UV", ["sphere", "spot", "area", "sun"], "how a lamp's UV is made (LampGraph.uv_kind)")
UV_SPHERE, UV_SPOT, UV_AREA, UV_SUN = _UV["sphere"], _UV["spot"], _UV["area"], _UV["sun"]
# A sun's ray length (Cycles' FLT_MAX).
SUN_T = float(np.finfo(np.float32).max)


# The Object Info columns a lamp's row has at least (graph.OBJECT_INFO_COLUMNS' Location, Color, Alpha and Object
# Index; a column past a row reads 0, as its From Instancer ones do for a lamp).
INFO_COLUMNS = max(start + width for name, (start, width) in graph_.OBJECT_INFO_COLUMNS.items()
                   if not name.startswith("From Instancer"))


LampGraphRecord = schema.record("LampGraph", "A lamp's Emission compiled into one program (core/lights/lamp_graph.py LampEmission).", [
    ("graph", ptr("GraphTables"), "its one program and the images it reads"),
    ("color", I32, "the register of the Emission's Color (3)"),
    ("strength", I32, "the register of its Strength"),
    ("generated", I32, "where the Generated coordinates start among a point's attributes"),
    ("object", I32, "where the Object coordinates start"),
    ("uv", I32, "where the UV starts"),
    ("width", I32, "attribute floats per point"),
    ("uv_kind", I32, "UV_SPHERE (point), UV_SPOT, UV_AREA or UV_SUN: how the lamp's UV is made"),
    ("sphere", I32, "1: a round lamp without Soft Falloff: N is the sphere's normal (else the leaving direction)"),
    ("linear", F64, 9, "the lamp object's linear transform M, row-major"),
    ("inverse", F64, 9, "M^-1, row-major"),
    ("location", F64, 3, "the object's location in the world"),
    ("origin", F64, 3, "the origin of the light's (camera-relative) frame in the world: the world point is P + origin\n"
                       "(a sun's: the direction leaving it, Cycles' P = Ng)"),
    ("half_cot", F64, "spot: cot(spot_size / 2) / 2; sun: 1 / (2 sin(angle / 4)) (Cycles' half_inv_sin_half_angle)"),
    ("info", ptr(F64), "(info_width,) the lamp object's Object Info row (geometry.instance_info's columns: location,\n"
                       "colour, alpha, pass index, then its Object and Instancer attributes)"),
    ("info_width", I64, "its columns"),
    ("random", F64, "the lamp object's random number (Object Info's Random)"),
])


def map_to_sphere(co: np.ndarray) -> np.ndarray:
    """Cycles' map_to_sphere of directions co (n, 3) float64 (any length): (n, 2) float64, u = 1/2 - atan2(x, y) / 2pi
    (0 on the z axis), v = 1 - acos(z / |co|) / pi; zeros where co is zero."""
    length2 = np.einsum("ij,ij->i", co, co)
    on_axis = (co[:, 0] == 0.0) & (co[:, 1] == 0.0)
    u = np.where(on_axis, 0.0, 0.5 - np.arctan2(co[:, 0], co[:, 1]) / (2.0 * math.pi))
    with np.errstate(divide="ignore", invalid="ignore"):
        v = 1.0 - np.arccos(np.clip(co[:, 2] / np.sqrt(length2), -1.0, 1.0)) / math.pi
    positive = length2 > 0.0
    return np.stack([np.where(positive, u, 0.0), np.where(positive, v, 0.0)], axis=1)


@dataclasses.dataclass
class LampEmission:
    """A lamp's Emission Color and Strength as one program over the lamp's shading point (module docstring).

    program, registers (colour, strength), textures, layout: as core/lights/world_graph.py WorldProgram's;
    matrix: (4, 4) float64 the lamp object's transform (world); origin: (3,) float64 the origin of the frame the
    light's points are in (Light.moved); uv_kind: UV_SPHERE, UV_SPOT, UV_AREA or UV_SUN; half_cot: a spot's
    cot(angle / 2) / 2, a sun's 1 / (2 sin(angle / 4)) (Cycles' half_inv_sin_half_angle, 0 at angle 0); info:
    (w,) float64 the lamp object's Object Info row (geometry.instance_info's columns, w >= INFO_COLUMNS); random:
    its random number (graph.object_random of its name, an instance's random_id).
    """

    program: "graph_.Program"
    registers: tuple
    textures: "textures_.TextureSet"
    layout: dict
    matrix: np.ndarray
    uv_kind: int = UV_SPHERE
    half_cot: float = 0.0
    origin: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    info: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(INFO_COLUMNS))
    random: float = 0.0

    def moved(self, origin: np.ndarray) -> "LampEmission":
        """The same program for a light whose points are now relative to `origin` (Light.moved)."""
        return dataclasses.replace(self, origin=np.asarray(self.origin, np.float64) + origin)

    def at(self, light, P: np.ndarray, leaving: np.ndarray, t: np.ndarray, paths=None) -> np.ndarray:
        """The Emission's Color x Strength (n, 3) float64 at points P (n, 3) on `light` (in its frame), light leaving
        along unit directions `leaving` (n, 3) towards points t (n,) away (non-finite values 0, as Cycles' film drops
        them), for paths `paths` (graph.LightPaths of n rows: the counts of the path the light reaches, lamp_paths;
        None: a path of no bounces)."""
        n = len(P)
        M = np.asarray(self.matrix, np.float64)
        linear = M[:3, :3]
        inverse = np.linalg.inv(linear)
        N = self.normal(light, P, leaving)
        world = np.asarray(leaving, np.float64) if self.uv_kind == UV_SUN else P + self.origin   # (a sun: P = Ng)
        local = (world - M[:3, 3]) @ inverse.T
        uv = self.uv(light, P, N, leaving, inverse)
        width = sum(w for _, w in self.layout.values())
        attributes = np.zeros((n, width))
        for name, value in (("generated", local), ("object", local), ("uv:", uv)):
            offset, w = self.layout[name]
            attributes[:, offset:offset + w] = value[:, :w]
        point = graph_.empty_point(n, width)._replace(
            attributes=attributes, N=N, Ng=N, I=leaving, P=world, uv=np.zeros((n, 2)),
            t=np.full(n, SUN_T) if self.uv_kind == UV_SUN else np.asarray(t, np.float64), linear=np.broadcast_to(linear, (n, 3, 3)).copy(),
            path=lamp_paths(n, paths), info=np.broadcast_to(self.info, (n, len(self.info))).copy(),
            random=np.full(n, float(self.random)))
        reg = graph_.run(self.program, point, self.textures)
        c, s = self.registers
        out = reg[:, c:c + 3] * reg[:, s:s + 1]
        return np.where(np.isfinite(out), out, 0.0)

    def normal(self, light, P: np.ndarray, leaving: np.ndarray) -> np.ndarray:
        """N = Ng at the lamp's points P (n, 3): an area lamp's normal, a sphere's outward normal (a round lamp
        without Soft Falloff), else the leaving direction (Cycles' Ng = -D on a point or a disc)."""
        if self.uv_kind == UV_AREA:
            return np.broadcast_to(np.asarray(light.direction, np.float64), P.shape).copy()
        if self.uv_kind == UV_SUN:
            return np.asarray(leaving, np.float64).copy()
        if getattr(light, "radius", 0.0) > 0.0 and not getattr(light, "soft_falloff", True):
            return graph_.safe_normalize(P - np.asarray(light.position, np.float64))
        return np.asarray(leaving, np.float64)

    def uv(self, light, P: np.ndarray, N: np.ndarray, leaving: np.ndarray, inverse: np.ndarray) -> np.ndarray:
        """The lamp's UV (n, 3) (z 0) at its points P with normals N and leaving directions (module docstring)."""
        n = len(P)
        if self.uv_kind == UV_AREA:
            inplane = P - np.asarray(light.center, np.float64)
            columns = []
            for axis in (np.asarray(light.axis_u, np.float64), np.asarray(light.axis_v, np.float64)):
                columns.append(inplane @ axis / float(axis @ axis) + 0.5)
            return np.stack(columns + [np.zeros(n)], axis=1)
        if self.uv_kind == UV_SUN:                  # (Cycles' distant_light_uv, D towards the sun, co leaving it)
            D = -np.asarray(leaving, np.float64)
            co = -np.asarray(light.towards(), np.float64)
            with np.errstate(divide="ignore", invalid="ignore"):
                factor = self.half_cot / np.linalg.norm(D - co, axis=1)
            return np.stack([0.5 + (D @ inverse[0]) * factor, 0.5 + (D @ inverse[1]) * factor, np.zeros(n)], axis=1)
        if self.uv_kind == UV_SPOT:
            local = graph_.safe_normalize(leaving @ inverse.T)
            with np.errstate(divide="ignore", invalid="ignore"):
                factor = self.half_cot / -local[:, 2]
            return np.stack([0.5 + local[:, 0] * factor, 0.5 + local[:, 1] * factor, np.zeros(n)], axis=1)
        return np.concatenate([map_to_sphere(N @ inverse.T), np.zeros((n, 1))], axis=1)

    def record(self, light) -> LampGraphRecord:
        """The program as C reads it (LampGraph), keeping its arrays alive."""
        M = np.asarray(self.matrix, np.float64)
        sphere = getattr(light, "radius", 0.0) > 0.0 and not getattr(light, "soft_falloff", True)
        return LampGraphRecord(
            graph=graph_.program_tables([self.program], self.textures), color=self.registers[0],
            strength=self.registers[1], generated=self.layout["generated"][0], object=self.layout["object"][0],
            uv=self.layout["uv:"][0], width=sum(w for _, w in self.layout.values()), uv_kind=self.uv_kind,
            sphere=int(sphere and self.uv_kind not in (UV_AREA, UV_SUN)), linear=M[:3, :3].reshape(-1).tolist(),
            inverse=np.linalg.inv(M[:3, :3]).reshape(-1).tolist(), location=M[:3, 3].tolist(),
            origin=np.asarray(self.origin, np.float64).tolist(), half_cot=float(self.half_cot),
            info=np.ascontiguousarray(self.info, np.float64), info_width=len(self.info), random=float(self.random))


def lamp_paths(n: int, paths=None) -> "graph_.LightPaths":
    """The LightPaths (n rows) a lamp's tree sees (Cycles' light_sample_shader_eval): EMISSION alone as the flags, the
    counts of `paths` (graph.LightPaths of n rows, or None: no bounces), no ray footprint."""
    if paths is None:
        return graph_.light_paths(n, flags=graph_.PATH_EMISSION)
    return graph_.as_light_paths(paths, n)._replace(flags=np.full(n, graph_.PATH_EMISSION, np.int64),
                                                     cone=np.zeros(n), spread=np.zeros(n))


def compile_lamp(color, strength, matrix: np.ndarray, uv_kind: int = UV_SPHERE, spot_size: float = 0.0,
                 info=None, random: float = 0.0) -> LampEmission:
    """Compile an Emission's color and strength (constants or graph.Links) over a lamp's shading point; matrix (4, 4)
    the lamp object's transform, uv_kind how its UV is made, spot_size a spot's full angle or a sun's (radians),
    info (w,) its object's Object Info row (None: its location, the rest 0), random its random number."""
    from .world_graph import compile_emission
    program, registers, textures, layout, _ = compile_emission(color, strength, set(LAMP_ATTRIBUTES), "a lamp")
    half_cot = 0.5 / math.tan(0.5 * spot_size) if uv_kind == UV_SPOT and spot_size > 0.0 else 0.0
    if uv_kind == UV_SUN:
        # (Cycles' half_inv_sin_half_angle, computed from its half angle: 1 / (2 sin(angle / 4)), 0 at angle 0)
        half_cot = 0.5 / math.sin(0.25 * spot_size) if spot_size > 0.0 else 0.0
    if info is None:
        info = np.zeros(INFO_COLUMNS)
        info[:3] = np.asarray(matrix, np.float64)[:3, 3]
    return LampEmission(program, registers, textures, layout, np.asarray(matrix, np.float64).copy(), uv_kind, half_cot,
                        info=np.asarray(info, np.float64).copy(), random=float(random))
