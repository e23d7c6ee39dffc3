"""Light linking and shadow linking read from Blender (4.0+): the sets and memberships core/lights/linking.py tests.

Blender keeps them in each emitter's `light_linking.receiver_collection` and `blocker_collection`, each object of such
a collection (or child collection, for every object inside it, at any depth) marked Include or Exclude
(`collection.collection_objects[i].light_linking.link_state`, parallel to `collection.objects`; `collection_children`
parallel to `children`). Blender's depsgraph turns them into numbered sets as follows (its light linking cache), and so
does `LinkSets.of`, separately for receivers and blockers:

1. Each linking collection once (emitters that share one share its links): every object it reaches gets the
   collection added to its *included* or *excluded* collections by the state it was reached with (a child
   collection's state holds for everything inside it; an object reached twice takes the last state met, children
   before the collection's own objects).
2. Each distinct pair (included, excluded) of an object is a set, numbered from 1; an object reached by no collection
   is in the default set 0.
3. An emitter's membership: the sets that include its collection, or every set when none does; less the sets that
   exclude it. An emitter without a collection has every set (linking.ALL_SETS).

So an emitter whose collection holds only Excluded objects lights everything else (the default set too), and one with
an Included object lights only the objects included. Blender allows 64 sets and 64 collections of each kind; past
that it drops the links (a printed warning), and so does Primer, with a note.
"""
from __future__ import annotations

import dataclasses

from ..core.lights.linking import ALL_SETS

# Blender's limits (depsgraph light linking: LightSet::MAX_ID, EmitterData::MAX_COLLECTION_ID).
MOST_SETS = 64


def reached(collection):
    """(object name, link state) for every object the linking `collection` reaches, in Blender's order: each child
    collection's objects with the child's state (children of children first), then its own objects with theirs."""
    found = []

    def inside(child, state):
        """Every object of `child` and its children, with the state of the first level."""
        for grandchild in child.children:
            inside(grandchild, state)
        found.extend((obj.name, state) for obj in child.objects)

    for child, link in zip(collection.children, collection.collection_children):
        inside(child, link.light_linking.link_state)
    found.extend((obj.name, link.light_linking.link_state)
                 for obj, link in zip(collection.objects, collection.collection_objects))
    return found


@dataclasses.dataclass
class Links:
    """One kind of linking (receivers or blockers): each object's set, each linking collection's membership."""

    sets: dict            # object name -> its set (1..63; absent: 0)
    memberships: dict     # collection name -> the emitters' membership (64-bit mask)
    notes: list

    @classmethod
    def of(cls, emitters: list, kind: str) -> "Links":
        """The sets and memberships of `kind` ("receiver_collection" or "blocker_collection") for the objects
        `emitters` (original objects with light_linking)."""
        collections, notes = [], []
        for obj in emitters:
            collection = getattr(obj.light_linking, kind, None)
            if collection is not None and collection.name not in collections:
                collections.append(collection.name)
        import bpy
        # 1. Each object's included and excluded collections.
        states = {}
        for name in collections[:MOST_SETS]:
            for obj_name, state in reached(bpy.data.collections[name]):
                included, excluded = states.setdefault(obj_name, (set(), set()))
                (included if state == "INCLUDE" else excluded).add(name)
                (excluded if state == "INCLUDE" else included).discard(name)
        if len(collections) > MOST_SETS:
            notes.append(f"more than {MOST_SETS} {kind.split('_')[0]} collections: Blender and Primer drop the links "
                         f"of {', '.join(collections[MOST_SETS:])}")
        # 2. Each distinct pair a set, numbered from 1 (0: the default set).
        numbers, sets = {}, {}
        for obj_name, (included, excluded) in states.items():
            key = (frozenset(included), frozenset(excluded))
            number = numbers.setdefault(key, len(numbers) + 1)
            if number < MOST_SETS:
                sets[obj_name] = number
        if len(numbers) >= MOST_SETS:
            notes.append(f"more than {MOST_SETS - 1} distinct {kind.split('_')[0]} sets: Blender and Primer treat the "
                         "objects past them as unlinked")
        # 3. Each collection's membership.
        memberships = {}
        for name in collections[:MOST_SETS]:
            including = excluding = 0
            for (included, excluded), number in numbers.items():
                if number < MOST_SETS:
                    including |= (1 << number) if name in included else 0
                    excluding |= (1 << number) if name in excluded else 0
            memberships[name] = (including or ALL_SETS) & ~excluding & ALL_SETS
        return cls(sets, memberships, notes)

    def membership(self, obj, kind: str) -> int:
        """The membership of emitter `obj` (its collection of `kind`'s, ALL_SETS without one)."""
        collection = getattr(getattr(obj, "light_linking", None), kind, None)
        return self.memberships.get(collection.name, ALL_SETS) if collection is not None else ALL_SETS


@dataclasses.dataclass
class LinkSets:
    """Light linking (receivers) and shadow linking (blockers) of a depsgraph's objects."""

    light: Links
    shadow: Links

    @classmethod
    def of(cls, depsgraph) -> "LinkSets":
        """Read them from the objects of `depsgraph` whose light_linking names a collection."""
        emitters = []
        for obj in depsgraph.objects:
            original = getattr(obj, "original", obj)
            linking = getattr(original, "light_linking", None)
            if linking is not None and (linking.receiver_collection is not None
                                        or linking.blocker_collection is not None):
                emitters.append(original)
        return cls(Links.of(emitters, "receiver_collection"), Links.of(emitters, "blocker_collection"))

    @property
    def notes(self) -> list:
        """What Primer (as Blender) drops: links past the 64 sets."""
        return self.light.notes + self.shadow.notes

    def of_object(self, obj) -> dict:
        """core Instance fields of object `obj`: its receiver and blocker sets, its memberships as an emitter."""
        original = getattr(obj, "original", obj)
        return {"light_set": self.light.sets.get(original.name, 0),
                "shadow_set": self.shadow.sets.get(original.name, 0),
                "light_membership": self.light.membership(original, "receiver_collection"),
                "shadow_membership": self.shadow.membership(original, "blocker_collection")}

    def lamp(self, light, obj):
        """The core lamp `light` of object `obj` with its memberships."""
        fields = self.of_object(obj)
        return dataclasses.replace(light, light_membership=fields["light_membership"],
                                   shadow_membership=fields["shadow_membership"])
