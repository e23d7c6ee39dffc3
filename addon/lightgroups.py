"""Light groups (View Layer > Light Groups): a `Combined_<name>` pass per group, as Cycles names and fills them.

A light group collects lamps, emissive objects and the world (their *Light Group* property); its pass holds
the light that reaches the camera from those sources alone, by every path (direct and bounced). Light is
linear in its sources, so that is the image of the scene in which only the group's sources emit: Primer
renders the frame once more per group, with the other lamps left out, the other objects' materials without
emission (a dark copy of each emitting material) and, unless the world is in the group, a black world. The
surfaces, and so every path the light takes, stay the same.

Cycles instead splits one render's paths by the source each ends at. Both have the same expected value; the
noise differs (each group's render draws its own samples, with the same seed), so the passes add up to
Combined within noise rather than to the last digit, and each group costs one more render of the frame.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..core.materials import Material

# The pass of group NAME (Cycles' name), and the core buffer that holds it.
PASS_PREFIX = "Combined_"
BUFFER_PREFIX = "lightgroup:"


def group_names(view_layer) -> list:
    """The view layer's light groups, in its order (none before Blender 3.2)."""
    return [group.name for group in getattr(view_layer, "lightgroups", ())]


def source_group(datablock) -> str:
    """The light group an object or world belongs to ("" for none)."""
    return str(getattr(datablock, "lightgroup", "") or "")


def dark(material: Material) -> Material:
    """`material` without emission: its Emission shaders at weight 0, its Principled Emission black."""
    nodes = []
    for entry in material.nodes:
        name, weight, inputs = entry[:3]
        if name == "EMISSION":
            weight = np.zeros(3)
        elif "emission" in inputs:
            inputs = {**inputs, "emission": (0.0, 0.0, 0.0)}
        nodes.append((name, weight, inputs) + tuple(entry[3:]))
    return dataclasses.replace(material, emission=np.zeros(3), nodes=nodes)


def emits(material: Material) -> bool:
    """Whether a material may emit: a constant emission, an Emission shader or a Principled Emission input."""
    if np.max(np.abs(np.asarray(material.emission, np.float64))) > 0.0:
        return True
    return any(entry[0] == "EMISSION" or "emission" in entry[2] for entry in material.nodes)


def scene_of_group(scene, membership: dict, group: str):
    """A copy of the core `scene` in which only the sources of light group `group` emit.

    membership: {"lights": [group per scene.lights], "instances": [group per scene.instances], "world": group}.
    """
    lights = [light for light, name in zip(scene.lights, membership["lights"]) if name == group]
    materials = list(scene.materials)
    darker = {}
    for index, material in enumerate(scene.materials):
        if emits(material):
            darker[index] = len(materials)
            materials.append(dark(material))
    instances = []
    for instance, name in zip(scene.instances, membership["instances"]):
        if name != group and darker:
            slots = instance.materials
            if slots is None:                   # the mesh's indices are scene materials: make them a table
                indices = scene.meshes[instance.mesh].material_indices
                count = int(np.max(indices)) + 1 if indices is not None and len(indices) else 1
                slots = np.arange(count, dtype=np.int64)
            slots = np.array([darker.get(int(m), int(m)) for m in slots], np.int64)
            instance = dataclasses.replace(instance, materials=slots)
        instances.append(instance)
    world = scene.world
    if world is not None and membership["world"] != group:
        world = dataclasses.replace(world, color=np.zeros(3), image=None)
    out = dataclasses.replace(scene, lights=lights, materials=materials, instances=instances, world=world)
    if membership["world"] != group:
        out.world_color = np.zeros(3)
    return out


def empty_groups(groups: list, membership: dict) -> list:
    """The groups that no lamp, object or world belongs to (their passes stay black)."""
    used = set(membership["lights"]) | set(membership["instances"]) | {membership["world"]}
    return [group for group in groups if group not in used]


def render_groups(core_render, exported, groups: list, progress, cancel) -> dict:
    """Render each light group's image: {BUFFER_PREFIX + name: (H, W, 3) float32}; stops when cancel() says."""
    settings = dataclasses.replace(exported.settings, passes=(), aux=(), denoising_features=False)
    out = {}
    for k, group in enumerate(groups):
        if cancel():
            break
        scene = scene_of_group(exported.scene, exported.lightgroups, group)
        result = core_render.render(scene, settings, progress=lambda fraction, stats, k=k: progress(
            (k + fraction) / len(groups), stats, group), cancel=cancel, keep_memory=True)
        out[BUFFER_PREFIX + group] = np.ascontiguousarray(result.image[..., :3], np.float32)
    return out
