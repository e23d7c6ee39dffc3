"""The volume closures a material's (or the world's) Volume output sets up, and the render's table of media.

Each volume shader node is a class that says what it is (VolumeFlags: it absorbs, scatters, emits) and turns its
constant inputs into a medium's coefficients, as Cycles' `svm_node_closure_volume` and `svm_node_principled_volume`
do (src/kernel/svm/closure.h):

- Volume Absorption: sigma_a = density x (1 - colour): the colour is what a unit of density lets through;
- Volume Scatter:    sigma_s = density x colour, with the phase function of its Phase menu (phase.py: Henyey-
  Greenstein of anisotropy g, Fournier-Forand, Draine, Rayleigh, Mie);
- Principled Volume: sigma_s = density x colour (HG of its Anisotropy), sigma_a = density x max(1 - colour, 0) x
  max(1 - sqrt(Absorption Color), 0), emission = Emission Color x Emission Strength + a black body's (Blackbody
  Intensity mixes Stefan-Boltzmann's sigma T^4 / pi in, tinted, in the colour of core/materials' Blackbody node);
- Volume Coefficients: the three coefficients as given; an Emission node at a Volume output: emission = colour x
  strength.

A Mix or Add Shader above them weighs each closure (the add-on multiplies the weights out), and closures add:
sigma_a, sigma_s and emission sum; the phase functions mix by their scattering, one phase function per medium here
(Cycles keeps each closure's): Henyey-Greenstein closures of different g become HG of the sigma_s-weighted mean g
(noted by the add-on); where another kind meets a different phase function, the closure that scatters most gives its
phase function (`Coefficients.__add__`), and g keeps the sigma_s-weighted mean cosine. A ray in overlapping media
scatters the same way (`Media.along`, media.c medium_scattering).

`Media` is one table per render: a column per material with a volume (per object that holds it where its volume
graph reads the object's Object Info, as Cycles' volume stack holds (object, shader) pairs, and per placement and
texture space where it is a field, as Cycles reads each object's coordinates in that object's spaces: `per_object`;
per object where its objects' boxes overlap, and per light group where it emits into several: `split_by_object`),
the world's medium, and which materials are volume-only boundaries (a Volume and no Surface: rays pass through them,
as Cycles' SD_HAS_ONLY_VOLUME). A material whose closures have inputs fed by links is a heterogeneous medium
(field.py Field): its column's constant coefficients are zero and its rays are marched (`Stretch.march`), the
march the proposal whose estimates ratio tracking and control variates make unbiased (`Stretch.transmittance`,
`emitted`: field.March).
"""
from __future__ import annotations

import copy
import enum
from typing import ClassVar, NamedTuple, Optional

import numpy as np

from ..native import schema
from ..native.schema import F64, I32, I64, ptr
from . import phase as phase_


class VolumeFlags(enum.IntFlag):
    """What a volume closure does to light along a ray: ABSORBS (sigma_a > 0 takes light away), SCATTERS (sigma_s:
    light leaves the ray and arrives from other directions, by its phase function), EMITS (light added along it)."""

    ABSORBS = 1 << 0
    SCATTERS = 1 << 1
    EMITS = 1 << 2


class Coefficients(NamedTuple):
    """A homogeneous medium: sigma_a, sigma_s, emission (3,) float64 per unit length; g the HG anisotropy (another
    phase function's mean cosine); phase its phase function's kind (phase.PHASE) and parameters its
    PHASE_PARAMETERS numbers (phase.Phase.parameters; HG's are g's own)."""

    sigma_a: np.ndarray
    sigma_s: np.ndarray
    emission: np.ndarray
    g: float = 0.0
    phase: int = 0
    parameters: tuple = (0.0, 0.0, 0.0, 0.0)

    @property
    def sigma_t(self) -> np.ndarray:
        """The extinction sigma_a + sigma_s (3,) float64."""
        return self.sigma_a + self.sigma_s

    def __add__(self, other: "Coefficients") -> "Coefficients":
        """Two closures together: their coefficients add, their anisotropies (mean cosines) mix by their
        scattering; the phase function is HG of that mean where both are HG, else the one that scatters more's."""
        s1, s2 = float(np.sum(self.sigma_s)), float(np.sum(other.sigma_s))
        g = (self.g * s1 + other.g * s2) / (s1 + s2) if s1 + s2 > 0.0 else self.g
        first = self if s1 >= s2 else other                 # (the one that scatters more)
        if s1 > 0.0 and s2 > 0.0 and self.phase == other.phase == phase_.PHASE["HENYEY_GREENSTEIN"]:
            kind, parameters = self.phase, (g, 0.0, 0.0, 0.0)
        else:
            kind, parameters = first.phase, first.parameters
        return Coefficients(self.sigma_a + other.sigma_a, self.sigma_s + other.sigma_s,
                            self.emission + other.emission, g, kind, tuple(parameters))


NOTHING = Coefficients(np.zeros(3), np.zeros(3), np.zeros(3), 0.0)


class VolumeClosure:
    """A volume shader node: its name in the material's volume list, the Blender node it reads, its flags, and
    `coefficients(weight, inputs)`: the medium it sets up with the Mix and Add Shaders' `weight` (float) above it."""

    name: ClassVar[str] = ""
    blender: ClassVar[str] = ""
    flags: ClassVar[VolumeFlags] = VolumeFlags(0)

    @staticmethod
    def coefficients(weight: float, inputs: dict) -> Coefficients:
        """The homogeneous medium (Coefficients) this closure sets up."""
        raise NotImplementedError


def _scattering(sigma_a, sigma_s, emission, inputs: dict) -> Coefficients:
    """A closure's coefficients with the phase function of its Phase menu (inputs["phase"], a Blender identifier;
    Henyey-Greenstein where absent) from its constant inputs (phase.of_node): g its mean cosine."""
    phase = phase_.of_node(inputs.get("phase", "HENYEY_GREENSTEIN"), inputs)
    return Coefficients(sigma_a, sigma_s, emission, float(phase.mean_cosine(1)[0]), int(phase.kind),
                        tuple(float(x) for x in phase.parameters(1)[0]))


def _density(weight: float, inputs: dict) -> float:
    """The node's density times its weight, never negative (Cycles: mix_weight x max(density, 0))."""
    return float(weight) * max(float(inputs.get("density", 1.0)), 0.0)


class VolumeAbsorption(VolumeClosure):
    """Cycles' Volume Absorption: sigma_a = density x (1 - Color); nothing scattered, nothing emitted."""

    name: ClassVar[str] = "ABSORPTION"
    blender: ClassVar[str] = "ShaderNodeVolumeAbsorption"
    flags: ClassVar[VolumeFlags] = VolumeFlags.ABSORBS

    @staticmethod
    def coefficients(weight: float, inputs: dict) -> Coefficients:
        """sigma_a = weight x max(density, 0) x (1 - colour), per channel (Cycles: one_spectrum() - weight)."""
        color = np.asarray(inputs.get("color", np.full(3, 0.8)), np.float64)[:3]
        return Coefficients(_density(weight, inputs) * (1.0 - color), np.zeros(3), np.zeros(3), 0.0)


class VolumeScatter(VolumeClosure):
    """Cycles' Volume Scatter: sigma_s = density x Color, the phase function of its Phase menu (phase.py)."""

    name: ClassVar[str] = "SCATTER"
    blender: ClassVar[str] = "ShaderNodeVolumeScatter"
    flags: ClassVar[VolumeFlags] = VolumeFlags.SCATTERS

    @staticmethod
    def coefficients(weight: float, inputs: dict) -> Coefficients:
        """sigma_s = weight x max(density, 0) x colour; its phase function's numbers clamped as Cycles' setups
        clamp them (HG's g: |g| <= 1 - 1e-3)."""
        color = np.asarray(inputs.get("color", np.full(3, 0.8)), np.float64)[:3]
        return _scattering(np.zeros(3), _density(weight, inputs) * color, np.zeros(3), inputs)


class PrincipledVolume(VolumeClosure):
    """Cycles' Principled Volume with constant inputs: scattering of Color, absorption of what Color and Absorption
    Color leave, and emission (Emission Color x Emission Strength)."""

    name: ClassVar[str] = "PRINCIPLED_VOLUME"
    blender: ClassVar[str] = "ShaderNodeVolumePrincipled"
    flags: ClassVar[VolumeFlags] = VolumeFlags.ABSORBS | VolumeFlags.SCATTERS | VolumeFlags.EMITS

    @staticmethod
    def coefficients(weight: float, inputs: dict) -> Coefficients:
        """As svm_node_principled_volume: sigma_s = d colour, sigma_a = d max(1 - colour, 0) max(1 - sqrt(absorption
        colour), 0), emission = weight x strength x emission colour (d = weight x max(density, 0))."""
        d = _density(weight, inputs)
        color = np.asarray(inputs.get("color", np.full(3, 0.5)), np.float64)[:3]
        absorption = np.sqrt(np.maximum(np.asarray(inputs.get("absorption_color", np.zeros(3)), np.float64)[:3], 0.0))
        g = float(inputs.get("anisotropy", 0.0))
        g = float(np.sign(g) * min(abs(g), 1.0 - 1e-3))
        sigma_a = (np.maximum(1.0 - color, 0.0) * np.maximum(1.0 - absorption, 0.0) * d if d > 0.0 else np.zeros(3))
        sigma_s = color * d if d > 0.0 else np.zeros(3)
        strength = float(inputs.get("emission_strength", 0.0))
        emission = (float(weight) * strength * np.asarray(inputs.get("emission_color", np.ones(3)), np.float64)[:3]
                    if strength > 0.0 else np.zeros(3))
        return Coefficients(sigma_a, sigma_s, emission + float(weight) * black_body(inputs), g)


# Stefan-Boltzmann's constant (W / (m^2 K^4)) over pi, scaled by 1e-6 as Cycles scales it (a radiance per unit length
# that a flame of a few thousand kelvin keeps near 1).
STEFAN_BOLTZMANN = schema.constant("STEFAN_BOLTZMANN", 5.670373e-8 * 1e-6 / np.pi,
                                   "Stefan-Boltzmann's constant / pi x 1e-6 (a black body's volume emission)")


def black_body(inputs: dict) -> np.ndarray:
    """The Principled Volume's black-body emission (3,) float64 (Cycles: svm_node_principled_volume): intensity =
    sigma mix(1, T^4, Blackbody Intensity), times Blackbody Tint and the Rec.709 colour of T, unclipped (negative
    outside Rec.709's gamut, as Cycles uses it here; scene linear is Rec.709 in Blender's configuration); nothing
    where Blackbody Intensity is 0."""
    from ..materials.converters.blackbody import blackbody
    amount = float(inputs.get("blackbody_intensity", 0.0))
    if amount <= 0.0:
        return np.zeros(3)
    t = max(float(inputs.get("temperature", 1000.0)), 0.0)
    intensity = STEFAN_BOLTZMANN * (1.0 + amount * (t ** 4 - 1.0))
    if intensity <= 0.0:
        return np.zeros(3)
    tint = np.asarray(inputs.get("blackbody_tint", np.ones(3)), np.float64)[:3]
    return tint * intensity * blackbody(np.array([t], np.float32), clip=False)[0].astype(np.float64)


class VolumeCoefficients(VolumeClosure):
    """Blender 5.0's Volume Coefficients: the medium's coefficients given directly (absorption, scattering, emission,
    per channel), each times the Mix and Add Shaders' weight, as Cycles' svm_node_volume_coefficients."""

    name: ClassVar[str] = "COEFFICIENTS"
    blender: ClassVar[str] = "ShaderNodeVolumeCoefficients"
    flags: ClassVar[VolumeFlags] = VolumeFlags.ABSORBS | VolumeFlags.SCATTERS | VolumeFlags.EMITS

    @staticmethod
    def coefficients(weight: float, inputs: dict) -> Coefficients:
        """weight x each of Absorption, Scatter and Emission Coefficients; the phase function as Volume Scatter's."""
        read = lambda key: float(weight) * np.asarray(inputs.get(key, np.zeros(3)), np.float64)[:3]
        return _scattering(read("absorption"), read("scatter"), read("emission"), inputs)


class VolumeEmission(VolumeClosure):
    """An Emission node at a Volume output: the medium emits Color x Strength per unit length (Cycles'
    emission_setup in a volume shader); it neither absorbs nor scatters."""

    name: ClassVar[str] = "EMISSION"
    blender: ClassVar[str] = "ShaderNodeEmission"
    flags: ClassVar[VolumeFlags] = VolumeFlags.EMITS

    @staticmethod
    def coefficients(weight: float, inputs: dict) -> Coefficients:
        """emission = weight x strength x colour."""
        color = np.asarray(inputs.get("color", np.ones(3)), np.float64)[:3]
        return Coefficients(np.zeros(3), np.zeros(3), float(weight) * float(inputs.get("strength", 1.0)) * color, 0.0)


# The table of volume closures: a material's volume entries name one by `name`; the add-on reads `blender` nodes.
VOLUME_TYPES = (VolumeAbsorption, VolumeScatter, PrincipledVolume, VolumeCoefficients, VolumeEmission)
VOLUME_BY_NAME = {cls.name: cls for cls in VOLUME_TYPES}
VOLUME_BY_BLENDER = {cls.blender: cls for cls in VOLUME_TYPES}
ABSORPTION = VolumeAbsorption.name


def medium_of(entries: list) -> Coefficients:
    """The homogeneous medium of a Volume output's closures [(name, weight float, inputs dict)]: their sum."""
    total = NOTHING
    for name, weight, inputs in entries:
        if name not in VOLUME_BY_NAME:
            raise ValueError(f"unknown volume closure {name!r}: one of {sorted(VOLUME_BY_NAME)}")
        total = total + VOLUME_BY_NAME[name].coefficients(weight, inputs)
    return total


class Media:
    """The render's media: a column per material with a volume (or, where its volume graph reads the object's Object
    Info, or where it is a field on objects of different placements or texture spaces, a column per object or per
    group of objects that read alike: `Media.of`, `per_object`; one per object whose box overlaps
    another's of the material, one per light group of an emitting one: `split_by_object`), and the world's medium.
    A ray's stack holds each medium once, in the order entered (`start`, `enter`, `leave`).

    column:   (m + 1,) int64 each material row's column, -1 where it has no volume or its media are kept per object
    keyed:    (m + 1,) int64 each material row's row of object_column (its media kept per object), -1 where not
    object_column: (K, n) int64 the column of the medium object o (Scene.instances) holds of keyed material k, -1
              where it holds none; has_medium (m + 1,) bool the rows with a medium either way
    sigma_a, sigma_s, emission: (V, 3) float64 each column's coefficients; g (V,) float64 its anisotropy (mean
              cosine); phase (V,) int64 its phase function's kind, parameters (V, PHASE_PARAMETERS) its numbers
    world:    the world's Coefficients (zero where the world has no volume)
    boundary: (m + 1,) bool the material rows that are volume-only boundaries (a Volume and no Surface)
    shadowless: (V,) bool the columns whose objects all hide from shadow rays (Ray Visibility > Shadow off): shadow
              rays pass through such a medium as if it were not there, as in Cycles (shadows.transmittance)
    notes:    what the render should be told (a medium on objects both hidden from and seen by shadow rays)
    """

    def __init__(self, media: list, boundary, world: Optional[Coefficients] = None, fields: Optional[dict] = None,
                 shadowless=None, world_field=None, keyed: Optional[dict] = None, objects: int = 0):
        """media: one Coefficients or None per material row; boundary: (m + 1,) bool; world: Coefficients or None;
        fields: material row -> its heterogeneous medium (core/volumes/field.py Field; that row's Coefficients are
        then zero), or None; shadowless: (m + 1,) bool the material rows whose media shadow rays pass, or None;
        world_field: the world's heterogeneous medium (a Field, `world_field_of`; world then None), or None;
        keyed: material row -> [(owners (j,) int64 Scene.instances entries, Coefficients, Field or None)] the media
        of a row kept per object (one column each; that row's `media` entry is then ignored), or None; objects: n,
        the Scene.instances entries."""
        keyed = keyed or {}
        rows = [i for i, medium in enumerate(media) if medium is not None and i not in keyed]
        fields = fields or {}
        # Each column: (its Coefficients, its Field or None, its material row): the rows' own, then the kept ones.
        columns = [(media[i], fields.get(i), i) for i in rows]
        self.keyed = np.full(len(media), -1, np.int64)
        self.object_column = np.full((len(keyed), max(int(objects), 1)), -1, np.int64)
        for k, row in enumerate(sorted(keyed)):
            self.keyed[row] = k
            for owners, coefficients, field in keyed[row]:
                self.object_column[k, np.asarray(owners, np.int64)] = len(columns)
                columns.append((coefficients, field, row))
        # The heterogeneous media: each Field and its column (the world's last, column -1: every ray is in it once).
        self.fields = [f for _, f, _ in columns if f is not None] + ([world_field] if world_field is not None else [])
        self.field_columns = np.array([v for v, (_, f, _) in enumerate(columns) if f is not None]
                                      + ([-1] if world_field is not None else []), np.int64)
        self.world_field = world_field
        self.column = np.full(len(media), -1, np.int64)
        self.column[rows] = np.arange(len(rows))
        self.has_medium = (self.column >= 0) | (self.keyed >= 0)
        self.rows = np.array([row for _, _, row in columns], np.int64)      # (V,) each column's material row
        pick = [c for c, _, _ in columns]
        self.sigma_a = np.array([c.sigma_a for c in pick], np.float64).reshape(-1, 3)
        self.sigma_s = np.array([c.sigma_s for c in pick], np.float64).reshape(-1, 3)
        self.emission = np.array([c.emission for c in pick], np.float64).reshape(-1, 3)
        self.g = np.array([c.g for c in pick], np.float64)
        self.phase = np.array([c.phase for c in pick], np.int64)
        self.parameters = np.array([c.parameters for c in pick], np.float64).reshape(-1, phase_.PHASE_PARAMETERS)
        self.world = NOTHING if world is None else world
        self.boundary = np.asarray(boundary, bool)
        self.shadowless = (np.zeros(len(columns), bool) if shadowless is None
                           else np.asarray(shadowless, bool)[self.rows])
        self.notes = []

    @classmethod
    def of(cls, materials: list, world_volume: Optional[list] = None, geometry=None,
           object_groups: Optional[np.ndarray] = None) -> Optional["Media"]:
        """The media of a scene's material records (each with `volume`, a list of closures, `volume_only`, and for a
        heterogeneous medium `volume_space`), the default material last, and the world's Volume
        closures; None when no medium is anywhere. geometry: the render's (its origin, each heterogeneous
        medium's box of triangles, and the objects whose Object Info, placement or texture space a volume graph
        reads: `per_object`), or None.
        object_groups: (n,) int64 each Scene.instances entry's light group (lightgroups.LightGroups.instances), or
        None: an emitting medium on objects of different groups is kept per group (`split_by_object`)."""
        from . import field as field_
        fields, keyed = {}, {}
        for row, m in enumerate(materials):
            entries = getattr(m, "volume", None)
            kept = (per_object(entries, getattr(m, "volume_space", None), geometry, row)
                    if entries and field_.linked(entries) and geometry is not None else None)
            if kept is not None:
                keyed[row] = kept
            elif entries and field_.linked(entries):
                fields[row] = field_.Field(entries, getattr(m, "volume_space", None),
                                           None if geometry is None else geometry.origin,
                                           None if geometry is None else material_bounds(geometry, row))
        media = [(NOTHING if row in fields or row in keyed else medium_of(m.volume))
                 if getattr(m, "volume", None) else None for row, m in enumerate(materials)]
        if geometry is not None:            # (media a ray may be in twice over, or that emit into several groups)
            split_by_object(media, fields, keyed, geometry, object_groups)
        world_field = world_field_of(world_volume, geometry) if world_volume and field_.linked(world_volume) else None
        world = medium_of(world_volume) if world_volume and world_field is None else None
        boundary = [bool(getattr(m, "volume_only", False)) for m in materials]
        if all(medium is None for medium in media) and world is None and world_field is None:
            return None
        hidden, seen = shadow_visibility(geometry, [medium is not None for medium in media])
        objects = 0 if geometry is None else len(geometry.instance_random)
        made = cls(media, boundary, world, fields, hidden & ~seen, world_field, keyed, objects)
        if world_field is not None:
            made.notes.append(WORLD_MEDIUM_NOTE)
        if (hidden & seen).any():
            names = ", ".join(repr(getattr(materials[row], "name", row)) for row in np.flatnonzero(hidden & seen))
            made.notes.append(f"volumes: the medium of {names} is on objects hidden from shadow rays and on objects "
                              "seen by them; Primer's shadow rays cross it everywhere (Cycles passes it only "
                              "inside the hidden objects)")
        return made

    def objects_of(self, geometry, prim: np.ndarray) -> Optional[np.ndarray]:
        """The objects (k,) int64 (Scene.instances entries, geometry.owners) of the hit triangles `prim` (k,) int64
        where some medium is kept per object (column_of needs them), else None (no need to look)."""
        if not (self.keyed >= 0).any():
            return None
        return geometry.owners(np.asarray(prim, np.int64))

    def column_of(self, material: np.ndarray, objects: Optional[np.ndarray] = None) -> np.ndarray:
        """The column (k,) int64 of the medium a surface of material rows `material` (k,) on objects `objects` (k,)
        int64 (objects_of; None where no medium is kept per object) bounds: -1 where it bounds none (C:
        media.c medium_column)."""
        column = self.column[material]
        keyed = self.keyed[material]
        mine = np.flatnonzero(keyed >= 0)
        if len(mine):
            column = column.copy()
            owner = np.asarray(objects, np.int64)[mine]
            column[mine] = np.where(owner >= 0, self.object_column[keyed[mine], np.maximum(owner, 0)], -1)
        return column

    def without_world(self) -> "Media":
        """These media with the world's left out (its Coefficients zero, its Field dropped): the shadow catchers'
        catcher-only scene, whose rays Cycles never puts in the world's volume (core/integrators/catcher.py)."""
        kept = copy.copy(self)
        kept.world = NOTHING
        if self.world_field is not None:
            mine = self.field_columns >= 0
            kept.fields = [f for f, m in zip(self.fields, mine) if m]
            kept.field_columns = self.field_columns[mine]
            kept.world_field = None
        kept.notes = []
        return kept

    @property
    def heterogeneous(self) -> bool:
        """Whether some medium varies from point to point (a Field)."""
        return len(self.fields) > 0

    @property
    def sigma_t(self) -> np.ndarray:
        """Each column's extinction (V, 3) float64."""
        return self.sigma_a + self.sigma_s

    @property
    def scatters(self) -> bool:
        """Whether some medium scatters or emits (absorption alone needs no scattering events)."""
        return bool((self.sigma_s > 0.0).any() or (self.emission > 0.0).any()
                    or (self.world.sigma_s > 0.0).any() or (self.world.emission > 0.0).any()
                    or any(f.scatters or f.emits for f in self.fields))

    @property
    def emits(self) -> bool:
        """Whether some medium emits light (then every ray gathers what it finds: media emission is found by rays)."""
        return bool((self.emission != 0.0).any() or (self.world.emission != 0.0).any()
                    or any(f.emits for f in self.fields))

    @property
    def scattering(self) -> bool:
        """Whether some medium scatters light (sigma_s > 0): a scattering event, not absorption and emission alone."""
        return bool((self.sigma_s > 0.0).any() or (self.world.sigma_s > 0.0).any()
                    or any(f.scatters for f in self.fields))

    def tables(self, bounds: tuple) -> "MediaTablesRecord":
        """The C record (MediaTables) of the media: each column's extinction and emission, each material row's
        column and whether it is a boundary, the world's medium, and `bounds` (low (3,), high (3,)), the box of the
        triangles with a medium (core/integrators/rays.media_bounds). The record keeps its arrays alive."""
        contiguous = lambda array, dtype: np.ascontiguousarray(np.asarray(array, dtype).reshape(-1)
                                                               if np.size(array) else np.zeros(1, dtype))
        return MediaTablesRecord(
            count=len(self.g), room=self.room, sigma_t=contiguous(self.sigma_t, np.float64),
            emission=contiguous(self.emission, np.float64), sigma_s=contiguous(self.sigma_s, np.float64),
            g=contiguous(self.g, np.float64), phase=contiguous(self.phase, np.int32),
            parameters=contiguous(self.parameters, np.float64), column=contiguous(self.column, np.int32),
            keyed=contiguous(self.keyed, np.int32), object_column=contiguous(self.object_column, np.int32),
            objects=int(self.object_column.shape[1]),
            boundary=contiguous(self.boundary, np.int32), shadowless=contiguous(self.shadowless, np.int32),
            world_sigma_t=np.asarray(self.world.sigma_t, np.float64),
            world_emission=np.asarray(self.world.emission, np.float64),
            world_sigma_s=np.asarray(self.world.sigma_s, np.float64), world_g=float(self.world.g),
            world_phase=int(self.world.phase), world_parameters=np.asarray(self.world.parameters, np.float64),
            emits=self.emits,
            scatters=self.scattering,
            low=np.asarray(bounds[0], np.float64), high=np.asarray(bounds[1], np.float64), **self.field_tables())

    def field_tables(self) -> dict:
        """MediaTables' heterogeneous media: their VolumeField records chained (`fields`, None: none), the box that
        holds them all and the march's step (the smallest of theirs), as field.py March reads them."""
        from . import field as field_
        if not self.fields:
            return dict(fields=None, field_low=np.zeros(3), field_high=np.zeros(3), field_step=1.0,
                        field_fine_low=np.zeros(3), field_fine_high=np.zeros(3))
        chain, shared = None, {}                # (the fields of one program share its tables: per_object)
        for field, column in reversed(list(zip(self.fields, self.field_columns))):
            chain = field_.field_record(field, int(column), chain, shared)
        return dict(fields=chain, field_low=np.min([f.low for f in self.fields], axis=0),
                    field_high=np.max([f.high for f in self.fields], axis=0),
                    field_step=min(f.step for f in self.fields),
                    field_fine_low=np.min([f.fine_low for f in self.fields], axis=0),
                    field_fine_high=np.max([f.fine_high for f in self.fields], axis=0))

    def start(self, n: int) -> np.ndarray:
        """The stacks (n, V) int16 of rays that start in no mesh's medium (the world's is always there). A stack
        holds, per column, the medium's place in the order the ray entered the media it is in (1: the first of
        them, 0: not in it), as Cycles' volume stack lists its (object, shader) entries: each medium once."""
        return np.zeros((n, len(self.g)), np.int16)

    @property
    def room(self) -> int:
        """How many media a ray's stack holds at once: MAX_MEDIA (Cycles' 32 entries less the end marker), one less
        where the world has a Volume (its entry is the stack's first in Cycles, integrator_volume_stack_init)."""
        return int(MAX_MEDIA) - int(self.world is not NOTHING or self.world_field is not None)

    def enter(self, inside: np.ndarray, rows: np.ndarray, column: np.ndarray) -> None:
        """Rays `rows` (k,) int64 (each once) of stacks `inside` (n, V) enter the media `column` (k,) int64, in
        place: each put last in its stack's order, unless already there (Cycles' volume_stack_enter_exit: an entry
        already on the stack is not added again) or the stack already holds `room` media (Cycles: "If we exceed the
        stack limit, ignore")."""
        rows, column = np.asarray(rows, np.int64), np.asarray(column, np.int64)
        new = (inside[rows, column] == 0) & ((inside[rows] > 0).sum(axis=1) < self.room)
        rows, column = rows[new], column[new]
        if len(rows):
            inside[rows, column] = inside[rows].max(axis=1) + 1

    @staticmethod
    def leave(inside: np.ndarray, rows: np.ndarray, column: np.ndarray) -> None:
        """Rays `rows` (k,) int64 (each once) of stacks `inside` (n, V) leave the media `column` (k,) int64, in
        place: taken off their stacks, the media entered after them one place down; a medium the ray is not in is
        left alone (Cycles' volume_stack_enter_exit)."""
        rows, column = np.asarray(rows, np.int64), np.asarray(column, np.int64)
        place = inside[rows, column]
        rows, column, place = rows[place > 0], column[place > 0], place[place > 0]
        if len(rows):
            inside[rows] -= (inside[rows] > place[:, None]).astype(inside.dtype)
            inside[rows, column] = 0

    def extinction(self, inside: np.ndarray) -> np.ndarray:
        """sigma_t (n, 3) float64 of rays with stacks inside (n, V): the world's plus each medium's the ray is in
        (overlapping media add, as in Cycles' volume stack)."""
        return self.world.sigma_t + (inside > 0).astype(np.float64) @ self.sigma_t

    def along(self, inside: np.ndarray, O: Optional[np.ndarray] = None, D: Optional[np.ndarray] = None) -> "Stretch":
        """What rays with stacks inside (n, V) cross: the sums of their media's coefficients (the world's included)
        and the anisotropy of their scattering (the sigma_s-weighted mean where media of different g overlap); with
        the rays O, D (n, 3), the heterogeneous media they are in, marched where asked (Stretch.march). Their phase
        function: HG of that mean where every medium that scatters there is HG, else the phase function of the
        medium that scatters most (the world first, then the columns in order, on a tie)."""
        weights = (inside > 0).astype(np.float64)          # (each medium the ray is in, once: Media.start)
        sigma_s = self.world.sigma_s + weights @ self.sigma_s
        scattering = self.world.sigma_s.sum() * self.world.g + weights @ (self.sigma_s.sum(axis=1) * self.g)
        total = sigma_s.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.where(total > 0.0, scattering / total, 0.0)
        # Each medium's share of the scattering (the world's first), and the phase function it brings.
        shares = np.concatenate([np.full((len(weights), 1), self.world.sigma_s.sum()),
                                 weights * self.sigma_s.sum(axis=1)], axis=1)
        kinds = np.concatenate([[self.world.phase], self.phase]).astype(np.int64)
        numbers = np.concatenate([np.asarray(self.world.parameters, np.float64)[None], self.parameters])
        hg = kinds == phase_.PHASE["HENYEY_GREENSTEIN"]
        numbers[hg, 0] = np.concatenate([[self.world.g], self.g])[hg]     # (HG's number: its own g)
        other = ((shares > 0.0) & (kinds != phase_.PHASE["HENYEY_GREENSTEIN"])).any(axis=1)
        first = np.argmax(shares, axis=1)
        kind = np.where(other, kinds[first], phase_.PHASE["HENYEY_GREENSTEIN"])
        parameters = np.where(other[:, None], numbers[first], 0.0)
        parameters[~other, 0] = g[~other]
        counts = None
        if self.fields and O is not None:
            columns = self.field_columns
            counts = np.where(columns >= 0, weights[:, np.maximum(columns, 0)] if inside.shape[1] else 0, 1)
            counts = np.broadcast_to(counts, (len(inside), len(columns))).astype(np.float64)
        return Stretch(self.world.sigma_t + weights @ self.sigma_t, sigma_s,
                       self.world.emission + weights @ self.emission, g, O, D, counts, self.fields or None, kind,
                       parameters, inside)

    def crossed(self, inside: np.ndarray, material: np.ndarray, backfacing: np.ndarray,
                crossing: np.ndarray, objects: Optional[np.ndarray] = None) -> np.ndarray:
        """The stacks (k, V) of rays that cross (crossing (k,) bool) surfaces of `material` (k,) rows on `objects`
        (k,) (objects_of): entering the medium the surface bounds (column_of) through a front face, leaving it through
        a back face (backfacing (k,) bool); a copy.
        Entering a medium the ray is already in, or leaving one it is not in, changes nothing (Cycles'
        volume_stack_enter_exit: a mesh whose shells overlap, or a ray through two coincident faces, is one medium)."""
        inside = inside.copy()
        column = self.column_of(material, objects)
        rows = np.flatnonzero(crossing & (column >= 0))
        back = np.asarray(backfacing, bool)[rows]
        self.enter(inside, rows[~back], column[rows[~back]])
        self.leave(inside, rows[back], column[rows[back]])
        return inside


# The most media (columns: volume materials, and the media of one kept per object) a ray is in at once, as in Cycles:
# its volume stack has MAX_VOLUME_STACK_SIZE = 32 entries (kernel/types.h), one of them the end marker and, where the
# world has a Volume, one the world's (Scene::get_volume_stack_size keeps room for both), so a ray is in at most 31
# objects' media, 30 with a world volume (Media.room); one more it enters is left out (volume_stack_enter_exit: "If we
# exceed the stack limit, ignore"). Both kernels' stacks do the same (Media.enter; media.c stack_add, sparse: a render
# may have any number of media).
MAX_MEDIA = schema.constant("MAX_MEDIA", 31, "the most media a ray is in at once (Cycles' MAX_VOLUME_STACK_SIZE less "
                                             "its end marker; Media.room: less the world's entry too where it has one)")

MediaTablesRecord = schema.record("MediaTables", "The render's homogeneous media (core/volumes/media.py Media.tables), for media.c.", [
    ("count", I64, "V: the media (columns: per volume material, or per object: Media.column_of)"),
    ("room", I64, "the most media a ray is in at once (Media.room: MAX_MEDIA, less 1 where the world has a volume)"),
    ("sigma_t", ptr(F64), "(V, 3) each column's extinction sigma_a + sigma_s"),
    ("emission", ptr(F64), "(V, 3) each column's emission per unit length"),
    ("sigma_s", ptr(F64), "(V, 3) each column's scattering coefficient"),
    ("g", ptr(F64), "(V,) each column's Henyey-Greenstein anisotropy (another phase function's mean cosine)"),
    ("phase", ptr(I32), "(V,) each column's phase function (PHASE_...)"),
    ("parameters", ptr(F64), "(V, PHASE_PARAMETERS) and its numbers (phase.Phase.parameters)"),
    ("column", ptr(I32), "(m + 1,) each material row's column, -1 where it has no volume (or keeps it per object)"),
    ("keyed", ptr(I32), "(m + 1,) each material row's row of object_column (media kept per object), -1: none"),
    ("object_column", ptr(I32), "(K, objects) the column of the medium object o holds of keyed material k, or -1"),
    ("objects", I64, "the Scene.instances entries (object_column's row length)"),
    ("boundary", ptr(I32), "(m + 1,) 1: the row is a volume-only boundary (a Volume and no Surface)"),
    ("shadowless", ptr(I32), "(V,) 1: shadow rays pass the column's medium (its objects hide from them)"),
    ("world_sigma_t", F64, 3, "the world's medium's extinction (0: none)"),
    ("world_emission", F64, 3, "and its emission"),
    ("world_sigma_s", F64, 3, "and its scattering"),
    ("world_g", F64, "and its anisotropy"),
    ("world_phase", I32, "and its phase function"),
    ("world_parameters", F64, int(phase_.PHASE_PARAMETERS), "and that phase function's numbers"),
    ("emits", I32, "1: some medium emits (Media.emits: phase rays gather what they find)"),
    ("scatters", I32, "1: some medium scatters (Media.scattering: paths gather single scattering, volume.c)"),
    ("low", F64, 3, "the box of the triangles with a medium (camera rays starting inside it walk, camera_media)"),
    ("high", F64, 3, ""),
    ("fields", ptr("VolumeField"), "the heterogeneous media (field.py Field), chained; NULL: none"),
    ("field_low", F64, 3, "the box of all of them (where a march cuts pieces)"),
    ("field_high", F64, 3, ""),
    ("field_step", F64, "the march's longest piece (the smallest of their boxes' diagonals / STEPS_ACROSS)"),
    ("field_fine_low", F64, 3, "the box of their fine boxes (Field.fine: where pieces keep field_step; past it they "
                               "double)"),
    ("field_fine_high", F64, 3, ""),
    ("groups", ptr(I32), "(V,) each column's light group (lightgroups.LightGroups.media; -1: none), or NULL: no "
                         "light groups (compiled.py sets it)"),
])


class Stretch(NamedTuple):
    """The media n rays cross (Media.along): sigma_t, sigma_s, emission (n, 3) float64, g (n,) float64 of the
    homogeneous ones; for heterogeneous ones (core/volumes/field.py), the rays O, D (n, 3), counts (n, F) how many
    times each ray is in each Field of `fields` (None: no ray is in one); phase (n,) int64 and parameters (n,
    PHASE_PARAMETERS) their phase function (None: HG of g); inside (n, V) the stacks they were made of (the light
    groups' emission group: lightgroups.LightGroups.emission_groups), or None."""

    sigma_t: np.ndarray
    sigma_s: np.ndarray
    emission: np.ndarray
    g: np.ndarray
    O: Optional[np.ndarray] = None
    D: Optional[np.ndarray] = None
    counts: Optional[np.ndarray] = None
    fields: Optional[list] = None
    phase: Optional[np.ndarray] = None
    parameters: Optional[np.ndarray] = None
    inside: Optional[np.ndarray] = None

    def rows(self, index) -> "Stretch":
        """The stretch of the rays `index`."""
        pick = lambda x: None if x is None else x[index]                   # noqa: E731
        return Stretch(self.sigma_t[index], self.sigma_s[index], self.emission[index], self.g[index],
                       pick(self.O), pick(self.D), pick(self.counts), self.fields, pick(self.phase),
                       pick(self.parameters), pick(self.inside))

    def phases(self) -> "phase_.Phases":
        """The homogeneous media's phase functions (phase.Phases, n rows): HG of g where none is given."""
        if self.phase is None:
            return phase_.Phases.henyey_greenstein(self.g)
        return phase_.Phases(self.phase, self.parameters)

    def phases_at(self, rows: np.ndarray, P: np.ndarray, g: np.ndarray) -> "phase_.PhaseMix":
        """The phase functions (phase.PhaseMix, m rows) at scattering points P (m, 3) of the rays `rows` (m,) int64
        (in a heterogeneous medium), g (m,) the march's sigma_s-weighted mean anisotropy there: the mixture, as
        Cycles keeps each closure at the point, of the homogeneous media's phase function (weight their sigma_s
        summed over channels) and every closure of each heterogeneous medium that scatters there (field.Field.phase_at,
        weight its sigma_s times the ray's count in it), in that order, at most PHASE_LOBES of them; HG of g where
        none scatters there. C: field.c's phase_at."""
        own = self.phases().rows(rows)
        m = len(rows)
        kinds, lobes, weights = [own.kind], [own.parameters], [self.sigma_s[rows].sum(axis=1)]
        for f, field in enumerate(self.fields or ()):
            count = self.counts[rows, f]
            some = np.flatnonzero(count > 0.0)
            if len(some) == 0 or not field.scatters:
                continue
            k, p, w = field.phase_at(P[some])
            for c in range(k.shape[1]):
                kind, numbers, weight = np.zeros(m, np.int64), np.zeros((m, phase_.PHASE_PARAMETERS)), np.zeros(m)
                kind[some], numbers[some], weight[some] = k[:, c], p[:, c], count[some] * w[:, c]
                kinds.append(kind)
                lobes.append(numbers)
                weights.append(weight)
        kinds, lobes, weights = np.stack(kinds, axis=1), np.stack(lobes, axis=1), np.stack(weights, axis=1)
        weights = np.where(weights > 0.0, weights, 0.0)
        order = np.argsort(weights <= 0.0, axis=1, kind="stable")[:, :phase_.PHASE_LOBES]   # (lobes first, in order)
        kinds, weights = np.take_along_axis(kinds, order, 1), np.take_along_axis(weights, order, 1)
        lobes = np.take_along_axis(lobes, order[:, :, None], 1)
        none = ~(weights[:, 0] > 0.0)
        kinds[none, 0], weights[none, 0] = phase_.PHASE["HENYEY_GREENSTEIN"], 1.0
        lobes[none, 0] = phase_.Phases.henyey_greenstein(g[none]).parameters
        return phase_.PhaseMix(kinds, lobes, weights)

    @property
    def varying(self) -> np.ndarray:
        """Which rays are in a heterogeneous medium: (n,) bool."""
        if self.counts is None:
            return np.zeros(len(self.g), bool)
        return (self.counts > 0.0).any(axis=1)

    @property
    def scatters(self) -> np.ndarray:
        """Which rays cross a medium that scatters (or may: a heterogeneous one that scatters): (n,) bool."""
        scatters = (self.sigma_s > 0.0).any(axis=1)
        if self.counts is not None:
            for f, field in enumerate(self.fields):
                if field.scatters:
                    scatters = scatters | (self.counts[:, f] > 0.0)
        return scatters

    def march(self, t: np.ndarray, rows: np.ndarray) -> "March":
        """The march (core/volumes/field.py March) of the rays `rows` (k,) int64 (in a heterogeneous medium) over
        distances t (k,)."""
        from .field import March
        homogeneous = (self.sigma_t[rows], self.sigma_s[rows], self.emission[rows], self.g[rows])
        return March(self.fields, self.counts[rows], homogeneous, self.O[rows], self.D[rows], t)

    def transmittance(self, t: np.ndarray) -> np.ndarray:
        """What the media let through (n, 3) float64 over distances t (n,) (inf: a ray that escapes): Beer-Lambert,
        through heterogeneous media an unbiased estimate (ratio tracking on the march, field.March.transmittance)."""
        T = transmittance(self.sigma_t, t)
        rows = np.flatnonzero(self.varying)
        if len(rows):
            t = np.broadcast_to(np.asarray(t, np.float64), (len(self.g),))
            T[rows] = self.march(t[rows], rows).transmittance(t[rows])
        return T


def emitted(stretch: Stretch, t: np.ndarray) -> np.ndarray:
    """The light (n, 3) float64 a homogeneous medium's emission sends along rays over distances t (n,), as it arrives
    at their start: the integral of exp(-sigma_t s) emission over 0 <= s < t, emission (1 - exp(-sigma_t t)) /
    sigma_t (emission t where nothing is in the way; 0 where nothing is emitted)."""
    t = np.asarray(t, np.float64)[:, None]
    e, sigma = stretch.emission, stretch.sigma_t
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        value = np.where(sigma > 0.0, e * -np.expm1(-sigma * t) / np.where(sigma > 0.0, sigma, 1.0), e * t)
    value = np.where(e != 0.0, value, 0.0)
    rows = np.flatnonzero(stretch.varying)
    if len(rows) and (any(f.emits for f in stretch.fields) or (stretch.emission[rows] != 0.0).any()):
        value[rows] = stretch.march(t[rows, 0], rows).emitted()   # (heterogeneous media: summed over the pieces)
    return value


def triangle_chunks(geometry, size: int = 1 << 20):
    """The geometry's triangles a million at a time: (prims (k,) int64, their unsmoothed triangle_data) pairs."""
    for start in range(0, geometry.triangle_count, size):
        prims = np.arange(start, min(start + size, geometry.triangle_count))
        yield prims, geometry.triangle_data(prims, smooth=False)


def shadow_visibility(geometry, volume_rows: list) -> tuple:
    """Which material rows with a medium (volume_rows: (m + 1,) bool) are on some object hidden from shadow rays,
    and which on some object that shadow rays see: two (m + 1,) bool (both False with no geometry)."""
    from ..visibility import HIDDEN_FROM_SHADOW
    hidden, seen = np.zeros(len(volume_rows), bool), np.zeros(len(volume_rows), bool)
    if geometry is None or not geometry.hides(HIDDEN_FROM_SHADOW):
        return hidden, seen
    for prims, triangles in triangle_chunks(geometry):
        shadowless = geometry.hidden(prims, HIDDEN_FROM_SHADOW)
        hidden[triangles.material[shadowless]] = True
        seen[triangles.material[~shadowless]] = True
    wanted = np.asarray(volume_rows, bool)
    return hidden & wanted, seen & wanted


def material_bounds(geometry, row: int) -> tuple:
    """The camera-relative box (low (3,), high (3,) float64) of the triangles of material `row`; the whole scene's
    box where none has it."""
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for _, triangles in triangle_chunks(geometry):
        mine = triangles.material == row
        if mine.any():
            corners = triangles.corners[mine].reshape(-1, 3)
            low, high = np.minimum(low, corners.min(axis=0)), np.maximum(high, corners.max(axis=0))
    if not np.isfinite(low).all():
        return geometry.bounds()
    return low, high


# The nodes whose outputs are the object's own, not the point's (its row of geometry.instance_info, its random
# number): a volume graph that reads one keeps a medium per object (Cycles' volume stack holds (object, shader) pairs).
OBJECT_NODES = ("OBJECT_INFO", "INSTANCE_ATTRIBUTE", "PARTICLE_INFO")
# The nodes that read nothing of the point they run at: a volume graph of these alone over the object's nodes is one
# constant medium per object (Beer-Lambert, no march).
POINTLESS_NODES = frozenset(("VALUE", "RGB", "VECTOR", "MATH", "MIX", "RAMP", "INVERT", "HSV", "CLAMP", "MAP_RANGE",
                             "SEPARATE_COLOR", "SEPARATE_XYZ", "COMBINE_COLOR", "COMBINE_XYZ", "SCALE", "LIGHT_PATH",
                             "VECTOR_MATH", "VECTOR_ROTATE", "GAMMA", "BRIGHT_CONTRAST", "RGB_TO_BW", "BLACKBODY",
                             "WAVELENGTH", "SEPARATE_COLOR_MODE", "COMBINE_COLOR_MODE", "RGB_CURVES",
                             "VECTOR_CURVES", "FLOAT_CURVE", "MAP_RANGE_VECTOR") + OBJECT_NODES)


def _links(entries: list) -> list:
    """Every Link under a Volume output's closures [(name, weight, inputs)] (graph.links_under), factors included."""
    from ..materials import graph as graph_
    nodes = [(name, weight, {k: v for k, v in inputs.items() if k != "factors"}, inputs.get("factors", ()))
             for name, weight, inputs in entries]
    return list(graph_.links_under(nodes))


def reads_object(entries: list) -> bool:
    """Whether a Volume output's closures [(name, weight, inputs)] read their object's Object Info (other than its
    Material Index, the material's own constant), an Object or Instancer attribute or Particle Info: then their
    medium is kept per object (`per_object`)."""
    return any(link.node.kind in OBJECT_NODES and not (link.node.kind == "OBJECT_INFO"
                                                       and link.output == "Material Index")
               for link in _links(entries))


def per_object(entries: list, space, geometry, row: int) -> Optional[list]:
    """The media of material `row`'s Volume closures [(name, weight, inputs)] on the objects of `geometry` that hold
    its triangles, one per object as Cycles evaluates each object's volume (its volume stack holds (object, shader)
    pairs, each shaded in that object's space): [(owners (j,) int64, Coefficients, Field or None)], one per group
    of objects that read alike (a column of Media each).
    Where the graph reads the object's Object Info (reads_object), a group's objects have alike Object Info rows and
    Random: a graph of POINTLESS_NODES alone is one homogeneous medium per group, its closures' inputs read at one
    point with that Object Info (Field.closures, every group's at once), then medium_of (as a constant graph); any
    other is a Field per group (marched; its program compiled once, Field.placed), reading that Object Info.
    A Field's group's objects also share their placement and texture space: its Object coordinates are read in that
    object's space and its Generated ones in that object's texture space (geometry.instance_texspace; where an object
    gives none, the material's), each bounded by the group's triangles. A field whose graph reads no Object Info is
    split only where its objects' placements or texture spaces differ: None where they are all alike (or some of its
    triangles belong to no object, or its graph reads nothing of the point), the material's one Field then (Media.of).
    space: the material's volume_space (its placement, texture space and grids)."""
    from . import field as field_
    reads = reads_object(entries)
    constant = all(link.node.kind in POINTLESS_NODES for link in _links(entries))
    if not reads and constant:
        return None
    owners, low, high, loose = object_boxes(geometry, [row])[row]    # (low, high (j, 3): the owners' boxes)
    if len(owners) == 0:
        return [] if reads else None
    if not reads and (loose or len(owners) < 2):
        return None
    info = geometry.instance_info[owners] if len(geometry.instance_info) else np.zeros((len(owners), 8))
    random = geometry.instance_random[owners]
    # Each object's world-to-object matrix (its linear part and Location: a field's Object coordinates are its own).
    linear = (geometry.instance_linear[owners] if len(geometry.instance_linear)
              else np.broadcast_to(np.eye(3), (len(owners), 3, 3)))
    flat = ~(np.abs(np.linalg.det(linear)) > 1e-300)      # (a flattened object: its own space has no inverse)
    placement = np.concatenate([np.where(flat[:, None, None], np.eye(3), linear), info[:, :3, None]], axis=2)
    to_object = np.linalg.inv(np.concatenate([placement, np.broadcast_to([[[0.0, 0.0, 0.0, 1.0]]],
                                                                          (len(owners), 1, 4))], axis=1))[:, :3]
    # Each object's texture space (location, size): its own, else the material's (else the unit box at the origin).
    given = (np.concatenate([np.asarray(space[1], np.float64).reshape(3), np.asarray(space[2], np.float64).reshape(3)])
             if space is not None else np.concatenate([np.zeros(3), np.ones(3)]))
    texspace = np.broadcast_to(given, (len(owners), 6)).copy()
    if len(getattr(geometry, "instance_texspace", ())):
        own = geometry.instance_texspace[owners]
        texspace = np.where(np.isfinite(own).all(axis=1)[:, None], own, texspace)
    where = np.concatenate([to_object.reshape(-1, 12), texspace], axis=1)
    keys = (np.concatenate([info, random[:, None]] + ([] if constant else [where]), axis=1) if reads else where)
    _, first, group = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    group = np.asarray(group).reshape(-1)
    if not reads and len(first) < 2:
        return None                                    # (one placement and texture space: the material's one field)
    order = np.argsort(first)                          # (the groups in the order of their first object)
    field = field_.Field(entries, space, geometry.origin, None, info=info[0], random=float(random[0]))
    if not constant:
        # (each object's field in its own box, marched in pieces as the material's one field would be: the box of all
        # these objects' triangles / STEPS_ACROSS, not each small box's, which would cut every ray finer)
        step = max(float(np.linalg.norm(high.max(axis=0) - low.min(axis=0))), 1e-6) / field_.STEPS_ACROSS
        return [(owners[group == g], NOTHING,
                 field.placed(info[first[g]], float(random[first[g]]),
                              (low[group == g].min(axis=0), high[group == g].max(axis=0)),
                              to_object[first[g]], step, (texspace[first[g], :3], texspace[first[g], 3:])))
                for g in order]
    fixed = [[] for _ in order]                        # (each group's closures, their linked inputs read there)
    for k, _, values in field.closures(np.zeros((len(order), 3)), info[first[order]], random[first[order]]):
        name, weight, inputs = entries[k]
        for j in range(len(order)):
            given = {key: value for key, value in inputs.items() if key not in field.slots[k] and key != "factors"}
            for key in field.slots[k]:                  # (the linked inputs, as the constants they are here)
                value = np.asarray(values[key][j], np.float64)
                given[key] = float(value[0]) if len(value) == 1 else value
            factor = float(np.asarray(values["factor"]).reshape(-1)[j]) if "factor" in values else 1.0
            fixed[j].append((name, float(weight) * factor, given))
    return [(owners[group == g], medium_of(fixed[j]), None) for j, g in enumerate(order)]


def object_boxes(geometry, rows: list) -> dict:
    """Each object's box of the triangles of each material row of `rows`, in one pass: row -> (owners (j,) int64 the
    Scene.instances entries that hold its triangles, low (j, 3), high (j, 3) float64 their boxes, whether some of
    its triangles belong to no object)."""
    objects = len(geometry.instance_random)
    low = {row: np.full((objects, 3), np.inf) for row in rows}
    high = {row: np.full((objects, 3), -np.inf) for row in rows}
    loose = {row: False for row in rows}
    wanted = np.asarray(sorted(rows), np.int64)
    for prims, triangles in triangle_chunks(geometry):
        mine = np.flatnonzero(np.isin(triangles.material, wanted))
        if len(mine) == 0:
            continue
        owner = geometry.owners(prims[mine])
        material = triangles.material[mine]
        for row in np.unique(material):
            at = material == row
            loose[int(row)] |= bool((owner[at] < 0).any())
            keep = at & (owner >= 0)
            corners = triangles.corners[mine[keep]]                       # (k, 3, 3)
            np.minimum.at(low[int(row)], owner[keep], corners.min(axis=1))
            np.maximum.at(high[int(row)], owner[keep], corners.max(axis=1))
    out = {}
    for row in rows:
        owners = np.flatnonzero(np.isfinite(low[row][:, 0]))
        out[row] = (owners, low[row][owners], high[row][owners], loose[row])
    return out


def overlapping_boxes(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Which of j boxes low, high (j, 3) overlap some other of them (their insides meet; touching is not
    overlapping): (j,) bool, compared 512 at a time."""
    j = len(low)
    out = np.zeros(j, bool)
    for start in range(0, j, 512):
        a = slice(start, min(start + 512, j))
        meet = ((low[a, None, :] < high[None, :, :]) & (low[None, :, :] < high[a, None, :])).all(axis=2)
        meet[np.arange(a.stop - a.start), np.arange(a.start, a.stop)] = False
        out[a] = meet.any(axis=1)
    return out


def split_by_object(media: list, fields: dict, keyed: dict, geometry, object_groups=None) -> None:
    """Keep per object (in `keyed`, in place: Media's columns kept per object) the media that Cycles' volume stack,
    which holds (object, shader) pairs, tells apart and a stack of media could not: a medium on objects whose boxes
    overlap (a ray in two of them is in the medium twice, where the stack holds each medium once: Media.enter), and
    with object_groups ((n,) int64 each Scene.instances entry's light group, or None) an emitting medium on objects
    of different light groups (each object's emission goes to its own group: lightgroups.LightGroups.of_media).
    Only the objects that need it get a column of their own; the others of one group keep sharing one, so a medium
    on objects apart and in one group stays one column. media, fields, keyed: Media.of's (material row -> its
    Coefficients, Field, media kept per object)."""
    rows = [row for row, medium in enumerate(media) if medium is not None]
    if not rows or len(geometry.instance_random) < 2:
        return
    boxes = object_boxes(geometry, rows)

    def emits(row) -> bool:
        if row in keyed:
            return any((np.asarray(c.emission) != 0.0).any() or (f is not None and f.emits) for _, c, f in keyed[row])
        return bool((np.asarray(media[row].emission) != 0.0).any() or (row in fields and fields[row].emits))

    for row in rows:
        owners, low, high, loose = boxes[row]
        if len(owners) < 2 or loose:
            continue
        own = np.where(overlapping_boxes(low, high), owners, -1)        # (an object of its own, or -1: shared)
        group = (np.asarray(object_groups, np.int64)[owners] if object_groups is not None and emits(row)
                 else np.zeros(len(owners), np.int64))
        keys = np.stack([group, own], axis=1)
        if row not in keyed and len(np.unique(keys, axis=0)) < 2:
            continue
        at = {int(o): k for k, o in enumerate(owners)}
        kept = keyed.get(row) or [(owners, media[row], fields.get(row))]
        split = []
        for members, coefficients, field in kept:
            members = np.asarray(members, np.int64)
            mine = keys[[at[int(o)] for o in members]]
            _, first, which = np.unique(mine, axis=0, return_index=True, return_inverse=True)
            which = np.asarray(which).reshape(-1)
            for n, k in enumerate(np.argsort(first)):               # (in the order of their first object)
                split.append((members[which == k], coefficients,
                              None if field is None else field if n == 0 else copy.copy(field)))
        keyed[row] = split
        fields.pop(row, None)


# Cycles' box of the world's medium: +-WORLD_REACH around the world's origin on each axis (scene/volume.cpp: "World
# volume is unbounded, use some practical large number instead"), and how far past the scene's box (by its diagonal)
# Primer marches the world's heterogeneous medium before holding it (field.py March).
WORLD_REACH = 10000.0
WORLD_PAD = 6.0
# What a render with a heterogeneous world medium is told of the approximation past the padded box (docs/blender.md,
# Volumes: measured within the noise on a Noise fog under a sun; 1 % too bright padded by 2 diagonals, 7 % by 0.5).
WORLD_MEDIUM_NOTE = (f"volumes: the world's heterogeneous medium is marched within {WORLD_PAD:g} diagonals of the "
                     "scene's box (Cycles: out to +-10 km) and held past it at its mean over 8 points along each ray")


def world_bounds(geometry) -> tuple:
    """The camera-relative box (low (3,), high (3,) float64) Primer marches a heterogeneous world medium in, the
    march's step float and the fine box (low (3,), high (3,)) within it where the pieces keep that step (past it
    they double: field.py March): the box of the scene's triangles and the camera (the point 0) padded by WORLD_PAD
    times its diagonal on each side, within Cycles' box +-WORLD_REACH around the world's origin; the step the
    unpadded box's diagonal / STEPS_ACROSS (the diagonal at least 1 cm); the fine box the unpadded one (within the
    padded). No geometry: the box +-WORLD_REACH, the step 0.1, the fine box the box."""
    from .field import STEPS_ACROSS
    origin = np.zeros(3) if geometry is None else np.asarray(geometry.origin, np.float64)
    reach_low, reach_high = -origin - WORLD_REACH, -origin + WORLD_REACH
    if geometry is None:
        return reach_low, reach_high, 0.1, (reach_low, reach_high)
    low, high = (np.asarray(x, np.float64) for x in geometry.bounds())
    low, high = np.minimum(low, 0.0), np.maximum(high, 0.0)
    diagonal = max(float(np.linalg.norm(high - low)), 1e-2)
    scene_low, scene_high = low, high
    low, high = low - WORLD_PAD * diagonal, high + WORLD_PAD * diagonal
    low, high = np.maximum(low, reach_low), np.minimum(high, reach_high)
    high = np.maximum(high, low)
    fine_low = np.clip(scene_low, low, high)
    return low, high, diagonal / STEPS_ACROSS, (fine_low, np.clip(scene_high, fine_low, high))


def world_field_of(world_volume: list, geometry=None):
    """The world's heterogeneous medium (field.Field, unbounded) of its Volume closures [(name, weight, inputs)]
    (some input fed by a link): its graph reads a point's world position as Cycles' world volume shader does (its
    Object, Generated and Position coordinates all the world point P: svm/tex_coord.h, a background's Generated is
    its P), marched in `world_bounds`."""
    from . import field as field_
    low, high, step, fine = world_bounds(geometry)
    space = (np.eye(4)[:3], np.full(3, 0.5), np.full(3, 0.5))      # (generated = (P - 0.5) / 1 + 0.5 = P)
    return field_.Field(world_volume, space, None if geometry is None else geometry.origin, (low, high), step,
                        unbounded=True, fine=fine)


def transmittance(sigma_t: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Beer-Lambert: the share exp(-sigma_t t) (n, 3) float64 of light that crosses distances t (n,) (inf: a ray
    that escapes) through extinctions sigma_t (n, 3); 1 where sigma_t is 0, whatever the distance."""
    t = np.asarray(t, np.float64)[:, None]
    with np.errstate(invalid="ignore", over="ignore"):
        return np.where(sigma_t > 0.0, np.exp(-sigma_t * t), 1.0)
