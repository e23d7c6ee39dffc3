"""Light groups (View Layer > Light Groups): a `Combined_<name>` pass per group, as Cycles names and fills them.

A light group collects lamps, emissive objects and the world (their *Light Group* property); its pass holds
the light that reaches the camera from those sources alone, by every path. The exporter records which group
each source belongs to (core Scene.lightgroups) and asks for the view layer's groups (RenderSettings.light_groups);
the integrator splits every contribution by the group of its source as it renders, as Cycles does, in one render
(core/integrators/lightgroups.py). Here: the names Blender and Cycles use.
"""
from __future__ import annotations

from ..core.integrators.lightgroups import BUFFER_PREFIX  # noqa: F401 (the core buffer of a group's pass)

# The pass of group NAME (Cycles' name).
PASS_PREFIX = "Combined_"


def group_names(view_layer) -> list:
    """The view layer's light groups, in its order (none before Blender 3.2)."""
    return [group.name for group in getattr(view_layer, "lightgroups", ())]


def source_group(datablock) -> str:
    """The light group an object or world belongs to ("" for none)."""
    return str(getattr(datablock, "lightgroup", "") or "")


def empty_groups(groups, membership: dict) -> list:
    """The groups that no lamp, object or world belongs to (their passes stay black)."""
    used = set(membership["lights"]) | set(membership["instances"]) | {membership["world"]}
    return [group for group in groups if group not in used]
