"""What a Blender scene asks of Cycles that Primer does not render, said once per render with what Primer does instead.

A render that differs from Cycles must say why (never silently wrong). Each function here reads one kind of
datablock and returns its notes (plain sentences for Blender's report and the log); export.py calls them once per
datablock and render. What Primer reads is in export.py, materials.py and lightgroups.py; what it leaves out is
here, so that the two lists together cover every setting that changes a Cycles render (tests/test_blender_unmodelled.py
renders a scene with each setting and checks its note).
"""
from __future__ import annotations

# View Layer > Passes that Primer does not write: property -> the pass's name in Blender.
UNWRITTEN_PASSES = {"use_pass_mist": "Mist", "use_pass_vector": "Vector", "use_pass_shadow": "Shadow Catcher",
                    "use_pass_subsurface_direct": "Subsurface Direct",
                    "use_pass_subsurface_indirect": "Subsurface Indirect",
                    "use_pass_subsurface_color": "Subsurface Color"}


def render_notes(scene) -> list:
    """Render settings of `scene` that change a Cycles render and that Primer does not model."""
    notes = []
    if getattr(scene.render, "use_motion_blur", False):
        notes.append("motion blur is on; Primer renders every object at the frame's instant (no motion blur)")
    cycles = getattr(scene, "cycles", None)
    kind = str(getattr(cycles, "pixel_filter_type", "BOX"))
    width = float(getattr(cycles, "filter_width", 1.0))
    if cycles is not None and (kind != "BOX" or abs(width - 1.0) > 1e-6):
        notes.append(f"Cycles filters pixels with a {kind.replace('_', '-').title()} filter {width:g} px wide here; "
                     "Primer averages each pixel's own samples (a 1-pixel box): edges and fine detail come out a "
                     "little sharper")
    return notes


def view_layer_notes(view_layer) -> list:
    """Passes and collection settings of `view_layer` that Primer does not render."""
    notes = [f"the {name} pass is not written by Primer (it stays empty)"
             for prop, name in UNWRITTEN_PASSES.items() if getattr(view_layer, prop, False)]
    aovs = [aov.name for aov in getattr(view_layer, "aovs", ())]
    if aovs:
        notes.append(f"shader AOVs ({', '.join(aovs)}) are not written by Primer (they stay empty)")
    for layer in _layer_collections(view_layer.layer_collection):
        if getattr(layer, "indirect_only", False) and not layer.exclude:
            notes.append(f"collection '{layer.name}' is Indirect Only; Primer renders it as an ordinary collection "
                         "(seen by the camera too)")
    return notes


def holdout_objects(view_layer) -> set:
    """The names of the objects in the view layer's Holdout collections (Cycles makes each of them a holdout)."""
    names = set()
    for layer in _layer_collections(view_layer.layer_collection):
        if getattr(layer, "holdout", False) and not layer.exclude:
            names.update(obj.name for obj in layer.collection.all_objects)
    return names


def camera_notes(camera_object) -> list:
    """Camera settings that Primer does not model (depth of field)."""
    data = getattr(camera_object, "data", None)
    dof = getattr(data, "dof", None)
    if dof is None or not dof.use_dof:
        return []
    focus = f"object '{dof.focus_object.name}'" if dof.focus_object is not None else f"{dof.focus_distance:g} m"
    return [f"camera '{camera_object.name}' has depth of field (f/{dof.aperture_fstop:g}, focus {focus}); Primer "
            "renders through a pinhole: everything in focus"]


def object_notes(obj) -> list:
    """Object settings that Primer does not model: shadow catcher, light and shadow linking, particle hair."""
    notes = []
    if obj.type != "LIGHT" and getattr(obj, "is_shadow_catcher", False):     # (lamps read True; Cycles ignores it)
        notes.append(f"object '{obj.name}' is a shadow catcher in Cycles; Primer renders it as an ordinary object")
    linking = getattr(obj, "light_linking", None)
    if linking is not None:
        for prop, what in (("receiver_collection", "light linking"), ("blocker_collection", "shadow linking")):
            collection = getattr(linking, prop, None)
            if collection is not None:
                notes.append(f"object '{obj.name}' uses {what} (collection '{collection.name}'); Primer lets it light "
                             "(and shadow) everything")
    for system in getattr(obj, "particle_systems", ()):
        settings = system.settings
        if settings.type == "HAIR" and settings.render_type == "PATH":
            notes.append(f"object '{obj.name}': hair of particle system '{system.name}' is not rendered by Primer")
    return notes


def light_notes(obj) -> list:
    """Lamp settings that Primer does not model: a negative power, Cycles' per-lamp sampling settings."""
    light = obj.data
    cycles = getattr(getattr(getattr(obj, "original", obj), "data", light), "cycles", None)    # (as the user set it)
    notes = []
    if float(getattr(light, "energy", 0.0)) < 0.0:
        notes.append(f"light '{obj.name}' has a negative power; Cycles takes its light away from the scene, Primer "
                     "leaves the light out")
    if cycles is not None:
        if not getattr(cycles, "use_multiple_importance_sampling", True):
            notes.append(f"light '{obj.name}' has Multiple Importance off; Primer weighs it by MIS as every light "
                         "(the same image, with other noise)")
        if int(getattr(cycles, "max_bounces", 1024)) < 1024:
            notes.append(f"light '{obj.name}' has Max Bounces {cycles.max_bounces}; Primer lights every bounce with it")
        if getattr(cycles, "is_caustics_light", False):
            notes.append(f"light '{obj.name}' is a shadow caustics light; Primer renders no manifold caustics")
    return notes


def world_notes(world) -> list:
    """World settings that Primer does not model: a volume."""
    from .materials import linked_node, node_tree, output_node
    tree = node_tree(world) if world is not None else None
    output = output_node(tree, "ShaderNodeOutputWorld") if tree is not None else None
    if output is not None and "Volume" in output.inputs and linked_node(output, "Volume") is not None:
        return ["the world's Volume is not rendered (Primer renders no volumes): no fog"]
    return []


def _layer_collections(layer) -> list:
    """Every layer collection under `layer` (itself included), depth first."""
    out = [layer]
    for child in layer.children:
        out.extend(_layer_collections(child))
    return out
