"""What a Blender scene asks of Cycles that Primer does not render, said once per render with what Primer does instead.

A render that differs from Cycles must say why (never silently wrong). Each function here reads one kind of
datablock and returns its notes (plain sentences for Blender's report and the log); export.py calls them once per
datablock and render. What Primer reads is in export.py, materials.py and lightgroups.py; what it leaves out is
here, so that the two lists together cover every setting that changes a Cycles render (tests/test_blender_unmodelled.py
renders a scene with each setting and checks its note).
"""
from __future__ import annotations

import math

from . import cycles_settings

# View Layer > Passes that Primer does not write: property -> the pass's name in Blender.
UNWRITTEN_PASSES = {"use_pass_shadow": "Shadow (EEVEE)",
                    "use_pass_subsurface_direct": "Subsurface Direct",
                    "use_pass_subsurface_indirect": "Subsurface Indirect",
                    "use_pass_subsurface_color": "Subsurface Color"}
# Cycles' own passes (View Layer > Passes, view_layer.cycles) that Primer does not write: property -> the pass's name.
UNWRITTEN_CYCLES_PASSES = {"use_pass_volume_majorant": "Volume Majorant",
                           "use_pass_volume_scatter": "Volume Scatter", "use_pass_volume_transmit": "Volume Transmit",
                           "pass_debug_sample_count": "Debug Sample Count", "pass_render_time": "Render Time"}


def render_notes(scene) -> list:
    """Render settings of `scene` that change a Cycles render and that Primer does not model."""
    notes = lamp_crossing_notes(scene)
    render = scene.render
    if getattr(render, "use_multiview", False):
        notes.append("Stereoscopy is on; Cycles renders each view from its own eye, Primer renders the scene's camera "
                     "once, without the views' offsets")
    cycles = getattr(scene, "cycles", None)
    if cycles is None:
        return notes
    if (getattr(scene, "primer", None) is not None and cycles_settings.follows_cycles(scene)
            and getattr(cycles, "use_denoising", False) and not scene.primer.use_denoising):
        notes.append("Cycles denoises this scene (Render > Sampling > Denoise); Primer follows its Cycles settings "
                     "but denoises only with its own Denoise (Render > Sampling), which is off: the image keeps its "
                     "noise")
    if getattr(cycles, "volume_biased", False):
        notes.append("Cycles' Biased volume rendering ray-marches heterogeneous media at its Step Rate; Primer renders "
                     "their unbiased mean, as Cycles' default (its own march finer than Cycles' steps)")
    if getattr(cycles, "use_fast_gi", False):
        notes += fast_gi_notes(scene, cycles)
    return notes


def fast_gi_notes(scene, cycles) -> list:
    """What Primer does not render of Cycles' Fast GI Approximation (on in `cycles`): any of it with Primer's own
    settings, which have no Fast GI. (Where the scene follows its Cycles settings it is rendered: export._fast_gi.)"""
    if getattr(scene, "primer", None) is not None and not cycles_settings.follows_cycles(scene):
        return ["Cycles' Fast GI Approximation replaces light after a few bounces by ambient occlusion (or adds it); "
                "Primer renders with its own settings (Render > Settings), which have no Fast GI, and follows whole "
                "paths"]
    return []


def view_layer_notes(view_layer) -> list:
    """Passes, filters and collection settings of `view_layer` that Primer does not render."""
    notes = [f"the {name} pass is not written by Primer (it stays empty)"
             for prop, name in UNWRITTEN_PASSES.items() if getattr(view_layer, prop, False)]
    cycles = getattr(view_layer, "cycles", None)
    notes += [f"the {name} pass is not written by Primer (it stays empty)"
              for prop, name in UNWRITTEN_CYCLES_PASSES.items() if getattr(cycles, prop, False)]
    scene = view_layer.id_data
    if getattr(cycles, "denoising_store_passes", False) and not getattr(getattr(scene, "primer", None),
                                                                       "use_denoising", False):
        notes.append("the Denoising Data passes are not written by Primer (it writes Denoising Albedo and Normal "
                     "with its own Denoise on)")
    if not getattr(view_layer, "use_pass_combined", True):
        notes.append("the Combined pass is off in the view layer; Primer writes it anyway")
    if not getattr(view_layer, "use_solid", True):
        notes.append("the view layer's Filter leaves Surfaces out (Cycles renders none); Primer renders them")
    return notes


def holdout_objects(view_layer) -> set:
    """The names of the objects in the view layer's Holdout collections (Cycles makes each of them a holdout)."""
    names = set()
    for layer in _layer_collections(view_layer.layer_collection):
        if getattr(layer, "holdout", False) and not layer.exclude:
            names.update(obj.name for obj in layer.collection.all_objects)
    return names


def camera_notes(camera_object) -> list:
    """Camera settings that Primer does not model: a custom (OSL) camera."""
    data = getattr(camera_object, "data", None)
    notes = []
    if getattr(data, "type", "PERSP") not in {"PERSP", "ORTHO", "PANO"}:
        notes.append(f"camera '{camera_object.name}' is a {data.type.title()} camera (a shader of its own in Cycles); "
                     "Primer renders it as a perspective camera")
    return notes                        # (depth of field, panoramas' too: export.depth_of_field)


def object_notes(obj) -> list:
    """Object settings that Primer does not model: adaptive subdivision. (Light and shadow linking are modelled:
    addon/linking.py; shadow catchers: export.ray_visibility, core/integrators/catcher.py.)"""
    notes = []
    adaptive = any(modifier.type == "SUBSURF" and modifier.show_render and getattr(modifier, "use_adaptive_subdivision",
                                                                                    False)
                   for modifier in getattr(obj, "modifiers", ())) \
        or getattr(getattr(obj, "cycles", None), "use_adaptive_subdivision", False)     # (Blender 4.2 to 4.5)
    if adaptive:
        notes.append(f"object '{obj.name}' has adaptive subdivision (Cycles dices it by its size on screen); Primer "
                     "renders the mesh the modifier evaluates")
    return notes


def lamp_crossing_notes(scene) -> list:
    """Cycles counts every lamp with a size that a ray passes (kernel/integrator/shade_light.h) as a transparent
    bounce and ends the path at Transparent Max Bounces, so a ray through as many lamps misses what lies behind them
    (measured in Cycles 5.0: a floor lit by a uniform world under a 20 m area lamp keeps all of its light with the
    default 8, and loses 99 % of it with 1 or 0); Primer's rays pass every lamp. Noted when the scene has that many."""
    scene = getattr(scene, "original", scene)           # (the settings as the user set them)
    limit = int(getattr(getattr(scene, "cycles", None), "transparent_max_bounces", 8))
    sized = [obj for obj in scene.objects if obj.type == "LIGHT" and not obj.hide_render and (
        obj.data.type == "AREA" or (obj.data.type in {"POINT", "SPOT"} and obj.data.shadow_soft_size > 0.0))]
    if sized and len(sized) >= limit:
        return [f"{len(sized)} lamps with a size and Transparent Max Bounces {limit}: Cycles counts each lamp a ray "
                "passes as a transparent bounce and ends the ray there, missing what lies behind; Primer's rays pass "
                "every lamp"]
    return []


def light_notes(obj) -> list:
    """Lamp settings that Primer does not model: a shadow caustics light (Cycles' manifold next-event estimation) of a
    kind core/integrators/mnee.py does not walk (area lamps of Spread 0). Point, spot (round or spheres), area and sun
    lamps are walked by both kernels (core/integrators/mnee.py, mnee.c)."""
    light = obj.data
    cycles = getattr(getattr(getattr(obj, "original", obj), "data", light), "cycles", None)    # (as the user set it)
    notes = []
    if cycles is not None and getattr(cycles, "is_caustics_light", False):
        if light.type == "AREA" and float(getattr(light, "spread", math.pi)) <= 0.0:
            notes.append(f"light '{obj.name}' is a shadow caustics light; Primer walks no manifold caustics for "
                         "area lamps of Spread 0: casters cast their ordinary shadow of it")
    return notes


def world_notes(world) -> list:
    """World settings that Primer does not model: Cycles' world light settings (its Volume and Ray Visibility are
    read: addon/export.py export_world)."""
    notes = []
    cycles = getattr(world, "cycles", None)
    if cycles is not None:
        if getattr(cycles, "is_caustics_light", False):
            notes.append("the world is a shadow caustics light; Primer walks no manifold caustics for the world (only "
                         "for point, spot, area and sun lamps): casters cast their ordinary shadow of it")
    return notes


def shadowless_world_notes(casts_shadow: bool, sampled: bool, other_lights: bool) -> list:
    """The world's Shadows off (Blender 5.2) where Primer does not match Cycles: a world whose light is sampled
    (`sampled`: an image or a baked graph) in a scene with `other_lights` (lamps, emissive materials). Primer weighs
    the world's unshadowed light samples by MIS as Cycles' one sample of it alone (vertex.mis_count); Cycles picks
    one light per hit among them all (its light tree), which weighs them less."""
    if casts_shadow or not sampled or not other_lights:
        return []
    return ["the world casts no shadows (World > Settings > Surface > Cast Shadow off) beside other lights: Cycles "
            "picks one light per hit among them, which weighs the world's unshadowed light samples less than Primer "
            "does (measured: an image sky and an area lamp over a box on a floor, 1.7 % brighter than Cycles, 10 % "
            "where the box hides the sky)"]


def material_notes(material) -> list:
    """Material settings that Primer does not model: Blender 4's Homogeneous Volume on a material with a Volume
    (Cycles evaluates the medium once per ray then). (Bump Map Correction is read: materials.export_material.)"""
    cycles = getattr(material, "cycles", None)
    notes = []
    tree = getattr(material, "node_tree", None)
    output = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"), None) if tree else None
    volume = output is not None and "Volume" in output.inputs and output.inputs["Volume"].is_linked
    if cycles is not None and getattr(cycles, "homogeneous_volume", False) and volume:
        notes.append(f"material '{material.name}' has Homogeneous Volume on: Cycles evaluates its medium once per "
                     "ray; Primer evaluates a medium fed by nodes point by point")
    return notes


def _layer_collections(layer) -> list:
    """Every layer collection under `layer` (itself included), depth first."""
    out = [layer]
    for child in layer.children:
        out.extend(_layer_collections(child))
    return out
