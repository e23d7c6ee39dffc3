"""Scene reuse: keep the exported scene and its BVH, and re-export only what the depsgraph says changed.

Blender tells a render engine what changed since its last look through `depsgraph.updates`: one
record per changed datablock (`id`), with `is_updated_geometry`, `is_updated_transform` and
`is_updated_shading`. `SceneCache.sync` reads them and does the least work that keeps the scene
correct:

=========================================  =================================================  ===========
change                                     re-exported                                        BVH rebuilt
=========================================  =================================================  ===========
first sync                                 everything                                         yes
an object's geometry (edit, modifier)      that object's mesh and placement                   yes
an object's transform                      that object's placement (matrix, material slots);  yes
                                           instances it makes move with it
an object's shading (materials edited or   that object's material slots                       if they
linked, objects added)                                                                        changed
a light, or a light object                 the lights                                         no
a material                                 the material colours                               no
the world                                  the world colour                                   no
objects added, removed, hidden (scene or   the new placements; gone ones are dropped          if any
collection updates)                                                                           changed
the camera or the view                     nothing (the viewport restarts its samples)        no
=========================================  =================================================  ===========

Meshes are cached by the `session_uid` of their evaluated mesh, which Blender renews whenever it
evaluates the geometry again (and never reuses within a session), so a mesh shared by linked
duplicates or instances is read once. Placements (one per object instance) are cached by the
original object, the instancer and the instance's persistent id. The BVH is rebuilt from the cached
meshes; its origin (camera-relative rendering) stays where it was built, since core.render works
with any origin.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Optional

import bpy
import numpy as np

from . import export, linking
from ..core import scene as core_scene
from ..core.geometry import instancing
from ..core.geometry.geometry import WorldGeometry, build_geometry, link_table, terminator_table
from ..core.materials import DEFAULT_SURFACE


@dataclass
class SyncReport:
    """What one sync read from Blender and rebuilt: tests assert "only what changed" on it."""

    meshes: list = field(default_factory=list)     # names of meshes whose arrays were read
    objects: list = field(default_factory=list)    # names of objects whose placement was read
    relinked: list = field(default_factory=list)   # names of objects whose material slots now differ
    lights: int = 0                                # lights exported
    materials: int = 0                             # material colours read
    world: bool = False                            # world colour read
    walked: bool = False                           # the instance list was walked
    bvh: bool = False                              # the BVH was rebuilt
    scene_changed: bool = False                    # the scene's own settings changed (Scene update)
    camera_changed: bool = False                   # a camera object or camera data changed

    @property
    def changed(self) -> bool:
        """Whether the rendered image may differ: the viewport then restarts its samples."""
        return bool(self.meshes or self.objects or self.relinked or self.lights or self.materials or self.world
                    or self.bvh or self.scene_changed or self.camera_changed)


@dataclass
class Changes:
    """depsgraph.updates sorted by what they mean for Primer (objects as original session uids)."""

    geometry: set = field(default_factory=set)     # objects whose evaluated geometry changed
    transform: set = field(default_factory=set)    # objects that moved
    shading: set = field(default_factory=set)      # objects whose materials may have changed
    lights: bool = False
    materials: bool = False
    world: bool = False
    scene: bool = False                            # scene settings, visibility, objects added or removed
    camera: bool = False

    @property
    def objects(self) -> set:
        """Every object whose placement must be read again."""
        return self.geometry | self.transform | self.shading


def classify(updates) -> Changes:
    """Return the Changes that a depsgraph's update records describe."""
    changes = Changes()
    for update in updates:
        datablock = update.id
        if isinstance(datablock, bpy.types.Object):
            if datablock.type == "LIGHT":
                changes.lights = True
            elif datablock.type == "CAMERA":
                changes.camera = True
            else:
                uid = datablock.original.session_uid
                if update.is_updated_geometry:
                    changes.geometry.add(uid)
                if update.is_updated_transform:
                    changes.transform.add(uid)
                if update.is_updated_shading:
                    changes.shading.add(uid)
        elif isinstance(datablock, bpy.types.Light):
            changes.lights = True
        elif isinstance(datablock, (bpy.types.Material, bpy.types.ShaderNodeTree)):
            changes.materials = True
        elif isinstance(datablock, bpy.types.World):
            changes.world = True
        elif isinstance(datablock, bpy.types.Camera):
            changes.camera = True
        elif isinstance(datablock, (bpy.types.Scene, bpy.types.Collection)):
            changes.scene = True
    return changes


@dataclass
class _MeshEntry:
    """A cached mesh: the core Mesh (None when it has no triangles) and the objects that use it."""

    mesh: Optional[core_scene.Mesh]
    owners: set


@dataclass(eq=False)
class _Placement:
    """One object instance: which cached mesh, where (matrix (4, 4) float64), with which scene materials."""

    mesh_key: object
    matrix: np.ndarray
    materials: np.ndarray
    name: str
    owner: int          # original object's session uid
    parent: int         # the instancer's session uid (the owner itself when not instanced)
    visible: tuple = ()             # export.instance_keywords' items: Ray Visibility, Holdout, terminator offsets
    attributes: Optional[dict] = None   # Object and Instancer attributes, Particle Info (materials.object_attributes)
    dupli: tuple = ()               # export.from_instancer's items: Generated and UV From Instancer (and texspace)

    def same_as(self, other: "_Placement") -> bool:
        """Whether `other` places the same mesh at the same spot with the same materials and visibility."""
        return (other is not None and self.mesh_key == other.mesh_key and np.array_equal(self.matrix, other.matrix)
                and np.array_equal(self.materials, other.materials) and self.visible == other.visible)


class _MaterialTable(export.MaterialTable):
    """The export's material table, kept between updates: colours are read again when materials change."""

    def refresh(self, depsgraph, warnings: list) -> int:
        """Read every known material's colour again from the evaluated depsgraph; return how many were read."""
        by_uid = {m.original.session_uid: m for m in depsgraph.ids if isinstance(m, bpy.types.Material)}
        for uid, index in self.index.items():
            material = by_uid.get(uid)
            if material is not None:
                self.materials[index] = export.materials_.export_material(material, warnings)
        return len(self.index)


def _instancing_mode(depsgraph) -> str:
    """Return the scene's Instancing setting as RenderSettings.instancing has it ("auto" without Primer's settings)."""
    props = getattr(depsgraph.scene_eval, "primer", None)
    mode = str(getattr(props, "instancing", "AUTO")).lower()
    return mode if mode in instancing.INSTANCING_MODES else "auto"


class SceneCache:
    """The exported scene of one depsgraph, kept up to date from its updates.

    scene:    core Scene (its camera is a placeholder: the viewport supplies the view's camera)
    geometry: WorldGeometry with the BVH of `scene`
    warnings: notes made while exporting, as in addon/export.py
    """

    def __init__(self):
        self.scene: Optional[core_scene.Scene] = None
        self.geometry: Optional[WorldGeometry] = None
        self.warnings: list = []
        self.meshes: dict = {}
        self.placements: dict = {}
        self.material_table = _MaterialTable()
        self.lights: list = []
        self.links: dict = {}                 # object name -> its Light and Shadow Linking fields (addon/linking.py)
        self.link_sets = None                 # the LinkSets they came from (a lamp's memberships: read again on change)
        self.world = None                  # core World (its colour, visibility)
        self.totals = SyncReport()         # summed over all syncs
        self.instancing = "auto"           # RenderSettings.instancing the BVH was built with
        self.override = None               # the view layer's Material Override
        self.use_volumes = True            # the view layer's Filter > Volumes

    def sync(self, depsgraph, origin=None, updates=None) -> SyncReport:
        """Bring the cached scene up to date with `depsgraph`; return what was read and rebuilt.

        updates: the depsgraph's update records (default: depsgraph.updates); ignored on the first
        sync, which exports everything. origin: (3,) world point for a new BVH (the view's eye).
        """
        # 1. Sort the updates; the first sync counts as every kind of change.
        first = self.scene is None
        export.materials_.set_frame(depsgraph.scene_eval.frame_current)     # the frame sequences are read at
        self.override = getattr(depsgraph.view_layer_eval, "material_override", None)   # View Layer > Material Override
        self.use_volumes = bool(getattr(depsgraph.view_layer, "use_volumes", True))   # View Layer > Filter > Volumes
        changes = classify(depsgraph.updates if updates is None else updates)
        report = SyncReport(scene_changed=changes.scene, camera_changed=changes.camera)
        walk = first or changes.scene or changes.lights or bool(changes.objects)
        # 2. World and materials: colours only, no BVH.
        if first or changes.world:
            world = export.rendered_world(depsgraph.scene_eval, depsgraph.view_layer, depsgraph)
            self.world = export.world_light_settings(world, export.export_world(world, self.warnings))
            report.world = True
        if changes.materials and not first:
            report.materials = self.material_table.refresh(depsgraph, self.warnings)
        # 3. Walk the instances when objects changed: read only the touched ones.
        placements_changed = False
        if walk:
            report.walked = True
            links = self.links
            placements_changed = self._walk(depsgraph, changes, first, report)
            relinked = self.links != links                 # (Light Linking's sets changed, alone or not)
        else:
            relinked = False
        # 4. Rebuild the scene (cheap lists) and, when placements changed, the BVH.
        rebuilt = first or placements_changed or report.lights or report.materials or report.world or relinked
        if rebuilt:
            self.scene = self._core_scene()
        mode = _instancing_mode(depsgraph)
        if first or placements_changed or mode != self.instancing:
            self.instancing = mode
            if origin is None:
                camera = depsgraph.scene_eval.camera
                origin = np.array(camera.matrix_world.translation) if camera is not None else np.zeros(3)
            self.geometry = build_geometry(self.scene, np.asarray(origin, np.float64),
                                           instancing.instance_triangles(mode))
            report.bvh = True
        else:                                               # (the same placements: their sets, offsets may be new)
            if relinked:
                self.geometry.instance_links = link_table(self.scene.instances)
            if rebuilt:
                self.geometry.instance_terminator = terminator_table(self.scene.instances)
        self.warnings = list(dict.fromkeys(self.warnings))       # each note once
        self._add_to_totals(report)
        return report

    def _walk(self, depsgraph, changes: Changes, first: bool, report: SyncReport) -> bool:
        """Walk depsgraph.object_instances, reading what changed; return whether any placement changed."""
        # 1. Meshes of objects whose geometry changed are stale, whatever their uid says.
        for key in [k for k, entry in self.meshes.items() if entry.owners & changes.geometry]:
            del self.meshes[key]
        # Lights are few: read them all again when any changed, and when anything moved (a light in an
        # instanced collection moves with its instancer, and only the instancer is tagged).
        links = linking.LinkSets.of(depsgraph)          # Light and Shadow Linking's sets, read again each walk
        relight = first or changes.lights or changes.scene or bool(changes.transform) or links != self.link_sets
        self.link_sets = links
        lights, placements = [], {}
        moved = changes.geometry | changes.transform
        unsupported_noted: set = set()
        self.links = {}
        for instance in depsgraph.object_instances:
            obj = instance.object
            # 2. Lights: export them all again when any may have changed.
            if obj.type == "LIGHT":
                if relight:
                    light = export.export_light(obj, np.array(instance.matrix_world, np.float64), self.warnings,
                                                instance)
                    if light is not None:
                        lights.append(links.lamp(light, obj))
                continue
            self.links[obj.name] = links.of_object(obj)
            if not instance.show_self:
                continue
            if obj.type in export.UNSUPPORTED_GEOMETRY or obj.type == "VOLUME":
                if obj.name not in unsupported_noted and first:
                    unsupported_noted.add(obj.name)
                    self.warnings.append(f"object '{obj.name}' is of type {obj.type}, which Primer's viewport does "
                                         "not render" + (" (its final render does: F12)" if obj.type == "VOLUME"
                                                         else ""))
                continue
            if obj.type != "MESH" or obj.data is None:
                continue
            # 3. Reuse the placement of an untouched instance (neither it nor its instancer changed).
            owner = obj.original.session_uid
            parent = instance.parent.original.session_uid if instance.is_instance and instance.parent else 0
            key = (owner, parent, tuple(instance.persistent_id) if instance.is_instance else ())
            old = self.placements.get(key)
            # (Object > Visibility changes tag no transform nor geometry: compared here, they are few and cheap.)
            if old is not None and not first and owner not in moved and parent not in moved \
                    and old.mesh_key in self.meshes and old.visible == tuple(export.instance_keywords(obj).items()):
                placements[key] = old
                if owner in changes.shading:
                    # Shading updates (materials edited, objects added) may re-link material slots.
                    placements[key] = self._relink(old, obj, report)
                continue
            # 4. Read the placement, and the mesh when it is not cached.
            placements[key] = self._read_placement(obj, instance, key, owner, report)
        # 5. Forget meshes no placement uses; note which objects use the rest.
        used: dict = {}
        for placement in placements.values():
            used.setdefault(placement.mesh_key, set()).update((placement.owner, placement.parent))
        self.meshes = {k: dataclasses.replace(e, owners=used[k]) for k, e in self.meshes.items() if k in used}
        if relight:
            self.lights = lights
            report.lights = len(lights)
        changed = placements.keys() != self.placements.keys() or any(
            not p.same_as(self.placements.get(k)) for k, p in placements.items())
        self.placements = placements
        return changed

    def _read_placement(self, obj, instance, key: tuple, owner: int, report: SyncReport) -> "_Placement":
        """Return the placement of one object instance, reading its mesh into the cache if needed."""
        data = obj.data
        uid = data.session_uid
        mesh_key = uid if uid else ("unshared", key)
        if mesh_key not in self.meshes:
            mesh = export._mesh_arrays(data)
            self.meshes[mesh_key] = _MeshEntry(mesh if len(mesh.triangles) else None, {owner})
            report.meshes.append(data.name)
        report.objects.append(obj.name)
        slots = self.material_table.slot_map(obj, self.warnings, self.override)
        self._read_attributes(obj, mesh_key, slots)
        matrix = np.array(instance.matrix_world, np.float64)
        dupli = tuple(export.from_instancer(instance).items())
        # (the texture space a heterogeneous medium it holds reads its Generated coordinates in: Instance.texspace)
        texspace = export.note_volume_space(obj, matrix, slots, self.material_table.materials, {})
        if texspace is not None:
            dupli += (("texspace", texspace),)
        return _Placement(mesh_key, matrix, slots, obj.name, owner, key[1] or owner,
                          tuple(export.instance_keywords(obj).items()), export.materials_.object_attributes(instance),
                          dupli)

    def _read_attributes(self, obj, mesh_key, slots: np.ndarray) -> None:
        """Read into the cached mesh the per-corner attributes its materials' node graphs use (export.mesh_attributes)."""
        entry = self.meshes.get(mesh_key)
        if entry is None or entry.mesh is None:
            return
        wanted = set()
        for slot in slots[slots >= 0].tolist():
            material = self.material_table.materials[slot]
            wanted |= export.graph_.attributes_of(export.graph_.with_normal(material.nodes, material.normal,
                                                                            material.displacement))
        if wanted:
            export.mesh_attributes(obj.data, entry.mesh, wanted, self.warnings)

    def _relink(self, old: "_Placement", obj, report: SyncReport) -> "_Placement":
        """Return `old` with the object's material slots read again (a new placement only if they changed)."""
        materials = self.material_table.slot_map(obj, self.warnings, self.override)
        self._read_attributes(obj, old.mesh_key, materials)
        if np.array_equal(materials, old.materials):
            return old
        report.relinked.append(obj.name)
        return dataclasses.replace(old, materials=materials)

    def _core_scene(self) -> core_scene.Scene:
        """Return a new core Scene from the cache (meshes shared, lists fresh, so running renders keep theirs)."""
        world = self.world
        materials = self._with_volume_spaces(list(self.material_table.materials))
        if world is not None:
            materials, world = export.media_of_layer(self.use_volumes, materials, world)
        scene = core_scene.Scene(camera=core_scene.Camera(),
                                 world_color=np.array(world.color if world is not None and world.camera else np.zeros(3)),
                                 world=world, lights=list(self.lights), materials=materials,
                                 default_material=DEFAULT_SURFACE)
        mesh_index: dict = {}
        for placement in self.placements.values():
            entry = self.meshes[placement.mesh_key]
            if entry.mesh is None:
                continue
            if placement.mesh_key not in mesh_index:
                scene.meshes.append(entry.mesh)
                mesh_index[placement.mesh_key] = len(scene.meshes) - 1
            scene.instances.append(core_scene.Instance(mesh_index[placement.mesh_key], placement.matrix,
                                                       placement.materials, placement.name,
                                                       **dict(placement.visible),
                                                       **self.links.get(placement.name, {}),
                                                       attributes=placement.attributes, **dict(placement.dupli)))
        scene.instance_attributes = list(export.materials_.INSTANCE_ATTRIBUTES)
        return scene

    def _with_volume_spaces(self, materials: list) -> list:
        """`materials` with each heterogeneous medium's space (Material.volume_space) that of the first placement
        holding it, as export.note_volume_space gives the final render: its placement's inverse and texture space."""
        from ..core.volumes import field as field_
        spaces: dict = {}
        for placement in self.placements.values():
            texspace = dict(placement.dupli).get("texspace")
            if texspace is None:
                continue
            slots = np.asarray(placement.materials)
            for slot in sorted(set(slots[slots >= 0].tolist())):
                volume = materials[slot].volume
                if (slot not in spaces and volume and field_.linked(volume)
                        and getattr(materials[slot], "volume_space", None) is None):
                    spaces[slot] = (np.linalg.inv(np.asarray(placement.matrix, np.float64))[:3], *texspace)
        return [dataclasses.replace(m, volume_space=spaces[i]) if i in spaces else m for i, m in enumerate(materials)]

    def _add_to_totals(self, report: SyncReport) -> None:
        """Add one sync's counts to `totals`."""
        t = self.totals
        t.meshes += report.meshes
        t.objects += report.objects
        t.lights += report.lights
        t.materials += report.materials
        t.world = t.world or report.world
        t.bvh = t.bvh or report.bvh
