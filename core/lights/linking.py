"""Light linking and shadow linking (Blender 4.0+), as Cycles renders them: which emitter lights which object, and
which objects cast an emitter's shadows.

Blender describes both with collections on the emitter (a lamp, or an object with an emissive material):
`light_linking.receiver_collection` (the objects it lights) and `light_linking.blocker_collection` (the objects that
cast its shadows), each object (or child collection, for every object inside it) marked Include or Exclude. Blender
(its depsgraph's light linking cache) turns them into numbered *sets*, and Cycles reads only the numbers:

- each object has a **receiver light set** (0..63; 0, the default set, for an object in no receiver collection) and a
  **blocker shadow set** (likewise for blocker collections);
- each emitter has a **light set membership** and a **shadow set membership**: 64-bit masks, bit s set when it lights
  the objects of receiver set s (casts shadows through the objects of blocker set s). An emitter without a collection
  has every bit (ALL_SETS).

An emitter lights a receiver when bit (receiver's set) of its membership is set (Cycles' light_link_light_match);
a shadow ray towards an emitter stops at an object when bit (object's blocker set) of the emitter's shadow membership
is set (Cycles' intersection_skip_shadow_link). Blender's rule for the masks (depsgraph_light_linking.cc): an emitter
whose collection some object Includes lights only the sets that include it; one whose collection holds only Excluded
objects lights every set but those that exclude it (so the default set 0 too: everything not excluded). The add-on
computes the sets (addon/linking.py); here are the tests both kernels make of them.

Camera rays see every emitter, and the world is never linked (it lights and is shadowed by everything).
"""
from __future__ import annotations

import numpy as np

# Every set: the membership of an emitter that is not linked.
ALL_SETS = (1 << 64) - 1


def in_sets(membership, sets) -> np.ndarray:
    """Whether bit `sets` of `membership` is set: membership (n,) uint64 (or an int), sets (n,) integers in 0..63
    (or an int) -> (n,) bool."""
    bits = np.left_shift(np.uint64(1), np.asarray(sets, np.uint64))
    return (np.asarray(membership, np.uint64) & bits) != 0


def memberships(geometry, light, ls, column: int) -> np.ndarray:
    """The light (column 2) or shadow (column 3) membership (n,) uint64 of each of a light's samples `ls`: a lamp's
    own (Light.light_membership, shadow_membership), an emitter's by the object its sampled triangle belongs to
    (geometry: the WorldGeometry, its instance_links), the world's every set."""
    n = len(ls.L)
    if ls.emitter is not None:
        return geometry.links(light.prim[ls.emitter], column)
    value = light.light_membership if column == 2 else light.shadow_membership
    return np.full(n, value, np.uint64)


def lights_receivers(geometry, light, ls, receivers: np.ndarray) -> np.ndarray:
    """Whether each sample of `light` lights the object of its receiving triangle `receivers` (n,) int64: (n,) bool
    (Cycles' light_link_light_match)."""
    return in_sets(memberships(geometry, light, ls, 2), geometry.links(receivers, 0))


def shadow_linked(light) -> bool:
    """Whether a lamp's shadows are cast by a blocker set only (its shadow membership is not every set)."""
    return int(light.shadow_membership) != ALL_SETS


def found_by_bounces(light):
    """The lamp as BSDF rays may find it: a shadow-linked lamp is found by light samples alone, weight 1 (as its
    Multiple Importance were off). Cycles finds one by a dedicated shadow ray along the BSDF direction that only its
    blockers stop (shade_dedicated_light.h); a BSDF ray in Primer stops at the first object, blocker or not, so its
    finds would miss the lamp behind a non-blocker. Light samples alone give the same mean, with more noise where
    BSDF sampling would have helped (small lamps on glossy surfaces)."""
    import dataclasses
    if not shadow_linked(light) or not light.use_mis or not dataclasses.is_dataclass(light):
        return light
    return dataclasses.replace(light, use_mis=False)
