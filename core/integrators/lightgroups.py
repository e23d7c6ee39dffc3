"""Light groups (View Layer > Light Groups): each sample's light split by the group of the source it came from.

A light group collects lamps, emissive objects and the world (their Light Group property). Its pass, Cycles'
`Combined_<name>`, holds the light that reaches the camera from those sources alone, by every path. Light is
linear in its sources, so the integrator can tell each contribution's source as it adds it, as Cycles does
(kernel/film/light_passes.h, film_write_*: a contribution goes to the light group of the lamp, the emissive
object or the world it ends at):

- a light sample goes to its light's group: a lamp's, the world's, or for the emissive meshes the group of the
  object whose triangle was sampled;
- what a BSDF ray finds goes to the group of what it finds: a lamp with extent, the object hit, the world;
- what the camera sees itself goes to the group of what it sees: an emitting surface (the object's group),
  a lamp with extent, the world where the ray escapes;
- what a medium scatters goes to the group of the light it scatters, as at a surface (the light samples and the
  phase ray's finds at each scattering point: core/integrators/volume.py, volume.c);
- what media emit along a ray goes to one group, as Cycles' film_write_volume_emission gives the stretch's whole
  emission (every entry's shader evaluated, their closures summed) to object_lightgroup of the shader data's object,
  which volume_shader_eval leaves at the last entry of the ray's volume stack: the group of the object whose medium
  the ray entered last of those it is in (`emission_groups`; Primer's stacks keep the order the media were entered
  in, Media.enter), else the world's (the world's medium's entry, the stack's first, is the world's light object,
  whose group is the world's). A medium on objects of different groups is kept per object where it emits
  (core/volumes/media.py split_by_object), as Cycles' stack holds (object, shader) pairs.

Each is the same value the Combined pass receives (MIS weights, clamping and the path's throughput included),
so the groups' passes add up to Combined wherever every source is in some group. Both kernels write them: the
Python reference through a GroupLight per batch, the compiled chunk (direct.c, path.c, chunk.c) per camera lane.
The film keeps their per-pixel sums in FILM_BUFFER (3 channels per group) and the render divides by the samples.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..lights.base import LightFlags
from ..native import schema

# The film's buffer of the groups' per-pixel sums: 3 channels per group, in RenderSettings.light_groups' order.
FILM_BUFFER = "light_groups"
# The render's buffer of the group NAME (RenderResult.aux), (H, W, 3).
BUFFER_PREFIX = "lightgroup:"
# The group of a source in none of the groups asked for.
NONE = -1
# The most groups the compiled chunk splits light into (its per-ray buffers are on the stack); more render in Python.
MAX_GROUPS = schema.constant("MAX_LIGHT_GROUPS", 64, "the most light groups the compiled chunk splits light into")


@dataclass
class LightGroups:
    """Which group (0 .. count - 1, or NONE) each source of a render belongs to.

    count:     the groups asked for (RenderSettings.light_groups)
    lights:    (l,) int64 the group of each of the render's lights (Context.lights): lamps by their own, the world's
               image by the world's, NONE for the emissive meshes (they go by the object of each triangle)
    instances: (i,) int64 the group of each Scene.instances entry (what it emits)
    world:     the world's group
    media:     (V,) int64 the group of each medium (core/volumes Media's columns): that of the objects whose material
               holds it (`of_media`), or None before the media are known
    """

    count: int
    lights: np.ndarray
    instances: np.ndarray
    world: int
    media: Optional[np.ndarray] = None

    @classmethod
    def of(cls, scene, names, lamps: list, lights: list) -> Optional["LightGroups"]:
        """The groups `names` (a sequence of group names, or empty: None) of `scene` (its Scene.lightgroups
        membership), for the render's `lights`: the usable lamps `lamps` (scene.lights' entries, in the render's
        order) and then the emitters and the world's image (the rest of `lights`)."""
        names = list(names)
        if not names:
            return None
        index = {name: k for k, name in enumerate(names)}
        members = getattr(scene, "lightgroups", None) or {}

        def group(name) -> int:
            return index.get(str(name or ""), NONE)

        of_light = {id(light): group(name) for light, name in zip(scene.lights, members.get("lights", ()))}
        world = group(members.get("world", ""))
        per_light = [of_light.get(id(lamp), NONE) for lamp in lamps]
        for light in lights[len(lamps):]:
            per_light.append(world if light.is_(LightFlags.INFINITE) else NONE)
        instances = [group(name) for name in members.get("instances", ())]
        instances += [NONE] * (len(scene.instances) - len(instances))
        return cls(len(names), np.array(per_light, np.int64), np.array(instances, np.int64), world)

    def of_prims(self, geometry, prim: np.ndarray) -> np.ndarray:
        """The group (k,) int64 of the objects the triangles `prim` (k,) int64 belong to."""
        # (an owner of -1, no object, reads the NONE appended last)
        return np.append(self.instances, NONE)[geometry.owners(np.asarray(prim, np.int64))]

    def of_sample(self, geometry, index: int, light, ls):
        """The group of light `index`'s samples `ls`: its own (int), or for the emissive meshes each sample's
        triangle's object's (n,) int64."""
        if getattr(light, "prim", None) is not None and ls.emitter is not None:
            return self.of_prims(geometry, light.prim[np.asarray(ls.emitter, np.int64)])
        return int(self.lights[index])

    def of_media(self, geometry, media) -> np.ndarray:
        """The group (V,) int64 of each column of `media` (core/volumes Media): the group of the objects whose
        triangles carry its medium (an emitting medium on objects of different groups has a column per group:
        Media.of's object_groups; where one does not emit, the first object's group, which nothing reads), NONE
        where none does, in one pass over the triangles."""
        from ..volumes.media import triangle_chunks
        V = len(media.g)
        first = np.full(V, np.iinfo(np.int64).max)                # the first object (instance index) of each
        for prims, triangles in triangle_chunks(geometry):
            column = media.column_of(triangles.material, media.objects_of(geometry, prims))   # (per object: its own)
            rows = np.flatnonzero(column >= 0)
            if len(rows) == 0:
                continue
            owners = geometry.owners(prims[rows])
            owners = np.where(owners >= 0, owners, np.iinfo(np.int64).max)
            np.minimum.at(first, column[rows], owners)
        out = np.full(V, NONE, np.int64)
        known = first < len(self.instances)
        out[known] = self.instances[first[known]]
        return out

    def emission_groups(self, inside: np.ndarray) -> np.ndarray:
        """The group (k,) int64 that the media's emission along rays with stacks `inside` (k, V) goes to: that of
        the medium the ray entered last of those it is in (the highest place: Media.start; Cycles: the object of the
        last entry of its volume stack), else the world's."""
        inside = np.asarray(inside)
        out = np.full(len(inside), self.world, np.int64)
        if inside.ndim == 2 and inside.shape[1] and self.media is not None and len(self.media):
            last = np.argmax(inside, axis=1)
            out = np.where(inside.max(axis=1) > 0, self.media[last], out)
        return out

    def emitter_groups(self, geometry, emitters) -> np.ndarray:
        """The group (t,) int32 of each emissive triangle's object (the compiled chunk's table)."""
        return self.of_prims(geometry, emitters.prim).astype(np.int32)


class GroupLight:
    """The light of m rows (hits or rays) split by group: L (m, count, 3) float64."""

    def __init__(self, groups: LightGroups, m: int):
        """Start with nothing gathered by m rows."""
        self.groups = groups
        self.L = np.zeros((m, groups.count, 3))

    def add(self, rows, value: np.ndarray, group) -> None:
        """Add value (k, 3) to the rows `rows` (k,) int64 in their groups `group` (int or (k,) int; NONE: nowhere)."""
        rows = np.asarray(rows, np.int64)
        group = np.broadcast_to(np.asarray(group, np.int64), rows.shape)
        kept = group >= 0
        if kept.any():
            np.add.at(self.L, (rows[kept], group[kept]), np.asarray(value)[kept])

    def scale(self, factor: np.ndarray) -> None:
        """Multiply each row by its factor (m,) (clamping's cap)."""
        self.L *= np.asarray(factor, np.float64)[:, None, None]

    def add_rows(self, rows, other: "GroupLight", factor=None) -> None:
        """Add the rows of `other` (k rows) into the rows `rows` (k,) int64, each times factor (k, 3) (a throughput,
        a BSDF weight) or 1."""
        values = other.L if factor is None else other.L * np.asarray(factor, np.float64)[:, None, :]
        np.add.at(self.L, np.asarray(rows, np.int64), values)


def add_emitted(groups: Optional[GroupLight], rows, value: np.ndarray, stretch) -> None:
    """Add the media's emission value (k, 3) along rays (the Stretch `stretch` of k rows, which carries their stacks)
    to `groups`' rows `rows` (k,) (or None: nothing), in each ray's emission group (LightGroups.emission_groups)."""
    if groups is None or stretch is None or getattr(stretch, "inside", None) is None:
        return
    groups.add(rows, value, groups.groups.emission_groups(stretch.inside))


def tally(ctx, m: int) -> Optional[GroupLight]:
    """A GroupLight of m rows where the render splits light by group (Context.extra["light_groups"]), else None."""
    groups = ctx.extra.get("light_groups")
    return GroupLight(groups, m) if groups is not None else None
