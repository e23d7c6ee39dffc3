"""What every light does: give a sample of the light arriving at a point, with its pdf.

The lecture's transport: emitted energy, distance attenuation 1/r^2, absorption by the material,
and N.L. Every light answers one question for a batch of shading points: "from which direction L,
over which distance, with what irradiance at normal incidence, and with which probability density
does light arrive?" The integrator multiplies by the BSDF, by max(N.L, 0) and by the shadow ray's
verdict. For a point light of power P at distance r:

    E_normal = P / (4 pi) / r^2      (intensity I = P / (4 pi) W/sr, then 1/r^2)

Lights without extent (point and spot of radius 0, sun of angle 0) are exact: one direction, no
noise, and a pdf of infinity (a delta: no BSDF-sampled direction can find them). Lights with extent
(sphere, sun disk, area) are sampled: each sample returns an unbiased estimate E_normal = L_e / pdf,
with the solid-angle pdf of its direction, so that an integrator can weigh light sampling against
BSDF sampling (multiple importance sampling). Every formula was checked against Cycles 4.x/5.0.

What a light *is* is declared once, on its class, as LightFlags (pbrt's LightType): the integrators ask the
flags, never which light it is. A light type is one class (core/lights/<name>.py), one C file beside it
(core/lights/<name>.c, functions <name>_sample and <name>_hit) and one entry in the table of
core/lights/__init__.py, whose position is the light's `kind` tag; tools/make_boundary.py writes the C side.
"""
from __future__ import annotations

import dataclasses
import enum
import math
from typing import ClassVar, NamedTuple, Optional

import numpy as np

from .. import vectors
from ..visibility import HIDDEN_FROM_CAMERA
from ..native import library, schema
from ..native.schema import F64, I32, I64, U64, ptr
from .linking import ALL_SETS

INV_4PI = 1.0 / (4.0 * math.pi)


class LightSample(NamedTuple):
    """Light arriving at a batch of points, one sample per point.

    L:          (n, 3) float64 unit direction from the point towards the light
    distance:   (n,) float64 distance to the sampled light point (inf for the sun)
    strength:   (n,) float64 irradiance at normal incidence carried by this sample per unit of the
                light's colour (W/m^2), L_e / pdf; zero where the light sends nothing
    pdf:        (n,) float64 solid-angle density of having sampled L (inf for lights without extent)
    color:      (3,) float64 the light's RGB colour
    position:   (n, 3) float64 the sampled light point (undefined for the sun)
    hidden:     (n,) int64 the Ray Visibility bits (geometry.HIDDEN_FROM_*) of the object each sample is on (an
                emissive mesh), or None: its light reaches no closure of a kind that cannot see the object
    emitter:    (n,) int64 the emissive triangle each sample is on (MeshEmitters' index), or None for other lights
    normal:     (n, 3) float64 the unit face normal of the emissive triangle each sample is on, or None for other
                lights: a shadow ray stops off that surface (shadows.robust_rays), not on it
    """

    L: np.ndarray
    distance: np.ndarray
    strength: np.ndarray
    pdf: np.ndarray
    color: np.ndarray
    position: np.ndarray
    hidden: Optional[np.ndarray] = None
    emitter: Optional[np.ndarray] = None
    normal: Optional[np.ndarray] = None

    @property
    def irradiance(self) -> np.ndarray:
        """The RGB irradiance at normal incidence: (n, 3) float64 W/m^2."""
        return self.strength[:, None] * self.color


class LightHit(NamedTuple):
    """Where rays meet a light they were not aimed at (a BSDF-sampled direction), for MIS.

    hit:      (n,) bool the ray meets the light's emitting side before t_max
    t:        (n,) float64 distance to it (inf where not hit)
    radiance: (n, 3) float64 emitted RGB radiance towards the ray's origin (0 where not hit)
    pdf:      (n,) float64 the solid-angle pdf with which `sample` would have chosen that direction
    """

    hit: np.ndarray
    t: np.ndarray
    radiance: np.ndarray
    pdf: np.ndarray


class Cone(NamedTuple):
    """The cone of directions a light with extent covers from each shading point.

    It depends on the points only, not on the sample, so it is built once per light and shared
    by all that light's samples (`Light.cone`).
    axis:    (n, 3) float64 unit direction to the light's centre (may be a broadcast row)
    t, b:    (n, 3) float64 unit vectors completing axis to an orthonormal frame
    cos_max: (n,) float64 cosine of the cone's half-angle
    d:       (n,) float64 distance to the light's centre (inf for the sun)
    """

    axis: np.ndarray
    t: np.ndarray
    b: np.ndarray
    cos_max: np.ndarray
    d: np.ndarray


# The C record of one light: everything that does not depend on the shading point, filled by each light's `pack`.
LightRecord = schema.record("LightRecord", "One light, prepared by its class's `pack` (core/lights/<name>.py): everything that does not\n"
                            "depend on the shading point.", [
    ("kind", I32, "its place in core/lights/__init__.py's LIGHT_TYPES: LIGHT_*"),
    ("samples", I32, "light samples per camera sample (1 for lights without extent)"),
    ("dimension", I64, "the sampling dimension of its pattern: 16 + 4 index"),
    ("delta", I32, "1: no extent (exact, one direction)"),
    ("hittable", I32, "1: rays can meet it (it has extent): BSDF rays find it, weighed by MIS"),
    ("camera", I32, "1: camera rays see it (Ray Visibility > Camera)"),
    ("hidden", I32, "the HIDDEN_FROM_* bits (core/visibility.py) of the rays that do not see it (Ray Visibility): its light\n"
                    "samples leave out the closures those rays serve, and such rays pass it"),
    ("use_mis", I32, "1: bounces find it (Light.hit) and MIS weighs the two ways; 0: light samples alone, weight 1 (Cycles'\n"
                     "Multiple Importance off; camera rays still see it)"),
    ("max_bounces", I32, "its light samples are taken at a path's vertices up to this bounce (0: the camera's hits); bounces\n"
                         "still find it beyond (Cycles' per-light Max Bounces, light_select_reached_max_bounces)"),
    ("cast_shadow", I32, "1: shadow rays test what stands between it and a shading point; 0: none are traced (its light\n"
                         "passes through everything: Blender's Cast Shadow off, Cycles' light.use_shadow)"),
    ("color", F64, 3, "RGB"),
    ("position", F64, 3, "point and spot: the centre; area: the centre"),
    ("direction", F64, 3, "spot: unit axis; sun: unit direction towards the sun; area: unit normal"),
    ("axis_u", F64, 3, "area: the two edge vectors"),
    ("axis_v", F64, 3, ""),
    ("ellipse", I32, "area: 1 for DISK and ELLIPSE"),
    ("soft_falloff", I32, "round lights: 1 for a disk facing the shading point"),
    ("area", F64, "area: emitting area"),
    ("radiance", F64, "area: P / (pi A); sphere: P / (4 pi^2 R^2)"),
    ("power", F64, ""),
    ("radius", F64, ""),
    ("strength", F64, "sun: irradiance at normal incidence (delta) or carried by each sample (disk)"),
    ("sun_t", F64, 3, "sun disk: the cone's frame and half-angle"),
    ("sun_b", F64, 3, ""),
    ("sun_cos_max", F64, ""),
    ("limb", I32, "sun: 1 for a Sky Texture's disc (SunLight.limb): rays that meet it see Cycles' limb-darkened\n"
                  "radiance, bottom to top, where the others see `radiance` x color"),
    ("limb_bottom", F64, 3, "sun with limb: the RGB radiance at the disc's bottom and top edges (sky.disc_xyz's)"),
    ("limb_top", F64, 3, ""),
    ("limb_sun", F64, 5, "sun with limb: the sky's sun elevation, rotation, disc size, earth's edge (radians); 0"),
    ("spot_frame", I32, "1: the spot has a (scaled) frame: use spot_inverse"),
    ("spot_inverse", F64, 9, "world to spot-local, row-major"),
    ("spot_cos_half", F64, ""),
    ("spot_blend_width", F64, ""),
    ("spread_narrow", I32, "area: 1 when spread < pi"),
    ("spread_tan_half", F64, ""),
    ("spread_norm", F64, ""),
    ("group", I32, "its light group (core/integrators/lightgroups.py), -1: none or by emitter (EmitterTables.group)"),
    ("light_membership", U64, "the receiver sets it lights (core/lights/linking.py; emitters: by object)"),
    ("shadow_membership", U64, "the blocker shadow sets that cast its shadows; emitters: by object"),
    ("caustics", I32, "Shadow Caustics (core/integrators/mnee.c): bit 1, a caustics light (a caster's BSDF rays on a path\n"
                      "that left a receiver do not find it); bit 2, the compiled kernels walk for its light samples\n"
                      "(base.walks)"),
    ("has_ies", I32, "point, spot and area lamps: 1 when an IES Texture scales the light leaving it (core/lights/ies.py)"),
    ("has_falloff", I32, "point, spot and area lamps: 1 when a Light Falloff node scales the light by the distance t to the\n"
                         "lit point (Light.falloff): t^falloff_power, times t^2 / (falloff_smooth + t^2) where that is > 0"),
    ("falloff_power", F64, "0 (Quadratic), 1 (Linear) or 2 (Constant)"),
    ("falloff_smooth", F64, "the Light Falloff's Smooth"),
    ("ies", ptr(F64), "its profile's table (ies.table: h angles, v angles, intensity by h then v), or NULL: a file\n"
                      "Cycles could not read, a factor of ies_strength everywhere"),
    ("ies_h", I32, "the table's horizontal and vertical angle counts"),
    ("ies_v", I32, ""),
    ("ies_strength", F64, "the node's Strength (x 100 without a table)"),
    ("ies_frame", F64, 9, "world directions leaving the lamp -> the node's Vector: the transposed object matrix, row-major"),
    ("lamp_graph", ptr("LampGraph"), "point, spot and area lamps: the program of a tree that varies over the lamp\n"
                                     "(core/lights/lamp_graph.py), whose Color x Strength scales each sample's colour, or NULL"),
], tables=("LIGHT",))


LightContext = schema.record("LightContext", "What the lights a render makes of its scene need besides their records.", [
    ("emitters", ptr("EmitterTables"), "the emissive triangles (core/lights/emitters.py), or NULL"),
    ("world", ptr("WorldTables"), "the world (core/lights/world.py)"),
])
schema.table("LIGHT", lambda: [cls.c_name() for cls in Light.types])


class LightFlags(enum.IntFlag):
    """What a light is (pbrt's LightType: DeltaPosition, DeltaDirection, Area, Infinite).

    POSITION  at a point in space (point and spot lamps): a delta position with radius 0, else a round lamp that
              rays meet (Light.hit)
    DISTANT   at infinity in one direction (the sun): a delta direction with angle 0, else a disk that rays
              escaping the scene meet
    AREA      a surface in space (area lamps) that rays meet
    INFINITE  all around the scene at infinity (the world): rays find it where they escape
    EMITTER   the scene's own emissive triangles: rays find them as the surfaces they hit
    """

    POSITION = 1 << 0
    DISTANT = 1 << 1
    AREA = 1 << 2
    INFINITE = 1 << 3
    EMITTER = 1 << 4


# Blender's lamps: lights rays meet by Light.hit (not as scene geometry, not by escaping it).
LAMP = LightFlags.POSITION | LightFlags.DISTANT | LightFlags.AREA


class Light:
    """The interface every light implements (a dataclass of its parameters, in Cycles' units).

    kind:          its tag: the position of its class in core/lights/__init__.py's LIGHT_TYPES (set there),
                   and the `kind` field of its C record
    flags:         what it is (LightFlags)
    blender_type:  Blender's name of the light type ("POINT", "SPOT", "SUN", "AREA")

    A light samples with 2 random numbers, a point of the unit square (`sample`'s u (n, 2)); a light made of parts
    picks one with them too (the emitters' triangle by the first number, rescaled), never with a third.
    """

    kind: ClassVar[int] = -1
    flags: ClassVar[LightFlags] = LightFlags(0)
    types: ClassVar[tuple] = ()     # every light class by kind (core/lights/__init__.py fills it)
    blender_type: ClassVar[str] = ""
    # Whether objects block its light (Cycles' Cast Shadow): a lamp's dataclass field, always for the others.
    cast_shadow: bool = True
    # Whether its light samples find their way through caustics casters (Cycles' Shadow Caustics, Light >
    # Shadow Caustics; core/integrators/mnee.py): a lamp's dataclass field, False for the others.
    caustics = False
    # The HIDDEN_FROM_* bits of the bounces that do not see it (Ray Visibility): a lamp's dataclass field, else 0.
    hidden_from: int = 0
    # Whether bounces find it and MIS weighs the two ways (Cycles' Multiple Importance): a lamp's field, else always.
    use_mis: bool = True
    # The last bounce at which its light is sampled (Cycles' per-light Max Bounces): a lamp's field, else 1024.
    max_bounces: int = 1024
    # The receiver light sets it lights and the blocker shadow sets that cast its shadows (core/lights/linking.py):
    # a lamp's fields; emitters carry them per object (WorldGeometry.instance_links), the world is never linked.
    light_membership: int = ALL_SETS
    shadow_membership: int = ALL_SETS

    @classmethod
    def is_(cls, flags: LightFlags) -> bool:
        """Whether the light has any of `flags`."""
        return bool(cls.flags & flags)

    @classmethod
    def c_name(cls) -> str:
        """The name of its C file and functions: its module's (point for core/lights/point.py)."""
        return cls.__module__.rsplit(".", 1)[-1]
    # Fields holding points (moved with the camera-relative origin) and the light's output.
    point_fields: ClassVar[tuple] = ()
    output_field: ClassVar[str] = "power"

    @property
    def delta(self) -> bool:
        """Whether the light has no extent, so one exact evaluation replaces sampling."""
        return False

    def emits(self) -> bool:
        """Whether the light sends any light or takes any away (a colour and an output other than 0: Cycles renders a
        lamp of negative power, whose light is subtracted)."""
        return bool(np.any(np.asarray(self.color, np.float64) * float(getattr(self, self.output_field)) != 0.0))

    def finite(self) -> bool:
        """Whether every parameter is a finite number."""
        values = [np.asarray(getattr(self, f.name), np.float64) for f in dataclasses.fields(self)
                  if f.name not in ("name", "shape", "camera", "cast_shadow", "hidden_from", "use_mis", "max_bounces",
                                 "light_membership", "shadow_membership", "ies", "falloff", "lamp_nodes")
                  and getattr(self, f.name) is not None]
        return all(np.isfinite(x).all() for x in values)

    def moved(self, origin: np.ndarray) -> "Light":
        """Return the light in the camera-relative frame: its points minus `origin` (its node program told)."""
        moved = {name: np.asarray(getattr(self, name), np.float64) - origin for name in self.point_fields}
        if getattr(self, "lamp_nodes", None) is not None:
            moved["lamp_nodes"] = self.lamp_nodes.moved(np.asarray(origin, np.float64))
        return dataclasses.replace(self, **moved)

    def cone(self, points: np.ndarray) -> Optional[Cone]:
        """Return the cone of directions the light covers from each point, or None (no cone)."""
        return None

    def sample(self, points: np.ndarray, u: np.ndarray, cone: Optional[Cone] = None,
               N: Optional[np.ndarray] = None, paths=None) -> LightSample:
        """Return the light arriving at each point, one sample per point.

        points: (n, 3) float64 shading points in the light's frame; u: (n, 2) float64 uniform numbers
        in [0, 1) (ignored by lights without extent); cone: `self.cone(points)`, if already made;
        N: (n, 3) float64 the points' normals (zero rows or None: unknown), read only by a light made of
        many parts that picks one by them (the emitters' light tree); paths: the graph.LightPaths (n rows) of the
        paths at the points, which a lamp's node tree reads (`emitted`; None: no bounces).
        """
        raise NotImplementedError

    def hit(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray, paths=None) -> LightHit:
        """Return where rays meet the light's emitting surface (lights without one are never hit).

        origins, directions: (n, 3) float64; t_max: (n,) float64; paths: the graph.LightPaths (n rows) the rays
        carry after their bounce, which a lamp's node tree reads (`emitted`; None: no bounces).
        """
        n = len(origins)
        return LightHit(np.zeros(n, bool), np.full(n, np.inf), np.zeros((n, 3)), np.zeros(n))

    @property
    def hittable(self) -> bool:
        """Whether rays can meet the light (it has an emitting surface or solid angle): BSDF-sampled rays
        then find it too, and multiple importance sampling weighs the two ways."""
        return False

    @property
    def unseen_by(self) -> int:
        """The HIDDEN_FROM_* bits of the rays that do not see the light: `hidden_from`, and the camera's where it is off."""
        return int(self.hidden_from) | (0 if getattr(self, "camera", True) else HIDDEN_FROM_CAMERA)

    def falloff_factor(self, distance: np.ndarray) -> np.ndarray:
        """What the lamp's Light Falloff node (its `falloff`: the power of the distance and Smooth, export.lamp_wiring)
        multiplies the light it sends over distances t (n,) float64 by, as Cycles' svm_node_light_falloff with the light
        sample's ray length: t^power (Quadratic 0, Linear 1, Constant 2), times t^2 / (Smooth + t^2) where Smooth > 0;
        ones without one, and where t is infinite (Cycles skips the node for distant lights)."""
        power, smooth = getattr(self, "falloff", (0, 0.0))
        t = np.asarray(distance, np.float64)
        if power == 0 and not smooth > 0.0:
            return np.ones(np.shape(t))
        finite = np.isfinite(t)
        t = np.where(finite, t, 1.0)
        factor = t ** power
        if smooth > 0.0:
            factor = factor * (t * t / (smooth + t * t))
        return np.where(finite, factor, 1.0)

    def ies_factor(self, leaving: np.ndarray) -> np.ndarray:
        """What the lamp's IES Texture (its `ies`, core/lights/ies.py IESLamp) multiplies the light leaving it along
        world directions (n, 3) float64 by: (n,) float64, ones without one."""
        ies = getattr(self, "ies", None)
        return np.ones(len(leaving)) if ies is None else ies.factor(leaving)

    def emitted(self, P: np.ndarray, leaving: np.ndarray, t: np.ndarray, paths=None) -> np.ndarray:
        """The lamp's colour, (3,) float64, or without a constant tree its colour times what its node program (its
        `lamp_nodes`, core/lights/lamp_graph.py) gives at its points P (n, 3) for light leaving along unit directions
        (n, 3) towards points t (n,) away, reaching paths `paths` (graph.LightPaths of n rows, or None: no bounces):
        (n, 3) float64."""
        color = np.asarray(self.color, np.float64)[:3]
        nodes = getattr(self, "lamp_nodes", None)
        return color if nodes is None else color * nodes.at(self, P, leaving, t, paths)

    def without_attenuation(self, sample: LightSample, points: np.ndarray) -> LightSample:
        """Return the sample with its 1/r^2 falloff undone (the lecture switch "distance attenuation" off).

        The default: multiply by r^2 to the sampled point. points: (n, 3) float64 in the light's frame.
        """
        return sample._replace(strength=sample.strength * sample.distance * sample.distance)

    def centre_numbers(self) -> np.ndarray:
        """Return the unit-square point (2,) float64 that `sample` maps to the light's centre (the inspector's sample)."""
        return np.zeros(2)

    def pack(self, index: int, light_samples: int) -> LightRecord:
        """Return the light's C record: the fields every light has, then its own (`pack_fields`)."""
        record = LightRecord(kind=self.kind, delta=self.delta, samples=1 if self.delta else max(1, int(light_samples)),
                             dimension=light_dimension(index),
                             color=np.asarray(self.color, np.float64)[:3], hittable=self.hittable,
                             camera=bool(getattr(self, "camera", True)), cast_shadow=bool(self.cast_shadow),
                             hidden=self.unseen_by, use_mis=bool(self.use_mis),
                             max_bounces=int(min(self.max_bounces, 1 << 30)), group=-1,
                             light_membership=int(self.light_membership), shadow_membership=int(self.shadow_membership))
        if getattr(self, "ies", None) is not None:
            self.ies.pack(record)
        if getattr(self, "lamp_nodes", None) is not None:
            record.lamp_graph = self.lamp_nodes.record(self)
        power, smooth = getattr(self, "falloff", (0, 0.0))
        if power != 0 or smooth > 0.0:
            record.has_falloff, record.falloff_power, record.falloff_smooth = 1, float(power), float(smooth)
        record.caustics = (1 if getattr(self, "caustics", False) else 0) | (2 if walks(self) else 0)
        self.pack_fields(record)
        return record

    def pack_fields(self, record: LightRecord) -> None:
        """Write the light's own constants into its C record."""
        raise NotImplementedError


def walks(light) -> bool:
    """Whether MNEE (core/integrators/mnee.py) walks for light samples of `light`: a caustics light of a kind it
    models (point and spot lamps, area lamps with a spread, suns)."""
    if not getattr(light, "caustics", False):
        return False
    kind = getattr(light, "blender_type", "")
    if kind in ("POINT", "SPOT"):
        return True
    if kind == "AREA":                    # (Spread 0, a fixed direction in Cycles, is left out)
        return light.spread > 0.0 and light.area() > 0.0
    return kind == "SUN"


def light_dimension(index: int) -> int:
    """Return the sampling dimension of light `index`'s pattern (core/sampling): 16 + 4 index."""
    return 16 + 4 * index


# ---------------------------------------------------------------------------
# Geometry that several lights share
# ---------------------------------------------------------------------------

def direction_to(points: np.ndarray, targets: np.ndarray):
    """Return (unit direction, distance) from each point to its target (a zero vector where they coincide).

    points, targets: (n, 3) float64 -> (n, 3) float64, (n,) float64
    """
    w = targets - points
    distance = np.sqrt(np.einsum("ij,ij->i", w, w))
    inverse = np.divide(1.0, distance, out=np.zeros_like(distance), where=distance > 0.0)
    w *= inverse[:, None]
    return w, distance


def sample_cone(cone: Cone, u: np.ndarray) -> np.ndarray:
    """Return unit directions uniform in solid angle within each cone: u (n, 2) float64 -> (n, 3) float64."""
    cos_theta = 1.0 - u[:, 0] * (1.0 - cone.cos_max)
    sin_theta = np.sqrt(np.maximum(0.0, 1.0 - cos_theta * cos_theta))
    cos_phi, sin_phi = vectors.cos_sin(2.0 * math.pi * u[:, 1])
    return (cone.t * (sin_theta * cos_phi)[:, None] + cone.b * (sin_theta * sin_phi)[:, None]
            + cone.axis * cos_theta[:, None])


def cone_pdf(cos_max: np.ndarray) -> np.ndarray:
    """Return the solid-angle pdf 1 / (2 pi (1 - cos a)) of a direction uniform in a cone of half-angle a."""
    with np.errstate(divide="ignore"):
        return 1.0 / (2.0 * math.pi * (1.0 - cos_max))


def delta_pdf(n: int) -> np.ndarray:
    """The pdf of a light without extent: infinite (a delta), for n points."""
    return np.full(n, np.inf)


# The light table's C functions over arrays, for the tests (core/lights/lights.c).
SampleLightArgs = schema.function("primer_sample_light", "sample_light_rows", schema.record("SampleLightArgs", "primer_sample_light's arguments: Light.sample for n points.", [
    ("light", ptr("LightRecord"), ""),
    ("context", ptr("LightContext"), "the emitters' and the world's tables, or NULL"),
    ("n", I64, ""),
    ("points", ptr(F64), "(n, 3)"),
    ("u", ptr(F64), "(n, 3): the unit-square point and a pick"),
    ("L", schema.out(F64), "(n, 3)"),
    ("distance", schema.out(F64), "(n,)"),
    ("strength", schema.out(F64), "(n,)"),
    ("pdf", schema.out(F64), "(n,)"),
    ("position", schema.out(F64), "(n, 3)"),
    ("color", schema.out(F64), "(n, 3)"),
]))
LightHitArgs = schema.function("primer_light_hit", "light_hit_rows", schema.record("LightHitArgs", "primer_light_hit's arguments: Light.hit for n rays.", [
    ("light", ptr("LightRecord"), ""),
    ("n", I64, ""),
    ("origins", ptr(F64), "(n, 3)"),
    ("directions", ptr(F64), "(n, 3)"),
    ("t_max", ptr(F64), "(n,)"),
    ("hit", schema.out(schema.U8), "(n,)"),
    ("t", schema.out(F64), "(n,)"),
    ("radiance", schema.out(F64), "(n, 3)"),
    ("pdf", schema.out(F64), "(n,)"),
]))


def compiled_sample(light: Light, points: np.ndarray, u: np.ndarray, context=None) -> LightSample:
    """Light.sample in C (the light's C file, through the generated light table), for the tests.

    context: the compiled LightContext (core/integrators/compiled.py) for emitters and the world.
    """
    n = len(points)
    u3 = np.zeros((n, 3))
    u3[:, :u.shape[1]] = u
    L, position, color = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    distance, strength, pdf = np.empty(n), np.empty(n), np.empty(n)
    library.call("primer_sample_light", SampleLightArgs(
        light=light.pack(0, 1), context=context, n=n, points=library.contiguous(points, np.float64), u=u3, L=L,
        distance=distance, strength=strength, pdf=pdf, position=position, color=color))
    return LightSample(L, distance, strength, pdf, color, position)


def compiled_hit(light: Light, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray) -> LightHit:
    """Light.hit in C (the generated light table), for the tests."""
    n = len(origins)
    hit, t, radiance, pdf = np.empty(n, np.uint8), np.empty(n), np.empty((n, 3)), np.empty(n)
    c = library.contiguous
    library.call("primer_light_hit", LightHitArgs(
        light=light.pack(0, 1), n=n, origins=c(origins, np.float64), directions=c(directions, np.float64),
        t_max=c(t_max, np.float64), hit=hit, t=t, radiance=radiance, pdf=pdf))
    return LightHit(hit.astype(bool), t, radiance, pdf)
