"""Panels: Primer's settings in the Render properties, and Blender's own panels enabled for Primer."""
from __future__ import annotations

import bpy

from .engine import PrimerRenderEngine

ENGINE = PrimerRenderEngine.bl_idname


class PrimerPanel:
    """Base of Primer's panels: shown only when Primer is the render engine."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RENDER_PT_primer_sampling(PrimerPanel, bpy.types.Panel):
    """Samples per pixel and per light."""

    bl_label = "Sampling"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.scene.primer
        col = layout.column()
        col.prop(props, "samples")
        col.prop(props, "light_samples")
        col.prop(props, "seed")
        col.prop(props, "animate_seed")
        col.prop(props, "threads")


class RENDER_PT_primer_shadows(PrimerPanel, bpy.types.Panel):
    """How shadow rays leave the surface."""

    bl_label = "Shadow Rays"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.scene.primer
        col = layout.column()
        col.prop(props, "shadow_method")
        sub = col.column()
        sub.active = props.shadow_method == "EPSILON"
        sub.prop(props, "epsilon")
        col.prop(props, "terminator_fix")


class RENDER_PT_primer_debug(PrimerPanel, bpy.types.Panel):
    """The tracer's intermediate quantities ("use that debug output")."""

    bl_label = "Debug"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.scene.primer
        layout.prop(props, "debug_view")
        layout.prop(props, "debug_passes")


class DATA_PT_primer_light(PrimerPanel, bpy.types.Panel):
    """The light properties Primer models, in Cycles' units."""

    bl_label = "Light"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)

    def draw(self, context):
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True
        col = layout.column()
        col.prop(light, "color")
        col.prop(light, "energy")
        col.prop(light, "exposure")
        col.prop(light, "normalize")
        if light.type in {"POINT", "SPOT"}:
            col.prop(light, "shadow_soft_size", text="Radius")
            col.prop(light, "use_soft_falloff")
        elif light.type == "SUN":
            col.prop(light, "angle")
        elif light.type == "AREA":
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {"SQUARE", "DISK"}:
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")
            col.prop(light, "spread")


class DATA_PT_primer_spot(PrimerPanel, bpy.types.Panel):
    """Spot cone size and blend."""

    bl_label = "Spot Shape"
    bl_context = "data"
    bl_parent_id = "DATA_PT_primer_light"

    @classmethod
    def poll(cls, context):
        return context.light is not None and context.light.type == "SPOT" and super().poll(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        col = layout.column()
        col.prop(context.light, "spot_size", text="Beam Size")
        col.prop(context.light, "spot_blend", text="Blend")
        col.prop(context.light, "show_cone")


classes = (
    RENDER_PT_primer_sampling,
    RENDER_PT_primer_shadows,
    RENDER_PT_primer_debug,
    DATA_PT_primer_light,
    DATA_PT_primer_spot,
)

# Blender's own panels that also describe what Primer renders (camera, output, objects, materials...).
_EXCLUDED_PANELS = {"DATA_PT_light", "DATA_PT_EEVEE_light", "DATA_PT_spot", "DATA_PT_EEVEE_light_distance"}


def _compatible_panels():
    """Return Blender's panels that list Workbench/EEVEE engines and are not light- or EEVEE-specific."""
    panels = []
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if not engines or panel.__name__ in _EXCLUDED_PANELS or "EEVEE" in panel.__name__.upper() \
                and not panel.__name__.startswith("EEVEE_MATERIAL_PT_"):
            continue
        if "BLENDER_RENDER" in engines or panel.__name__.startswith("EEVEE_MATERIAL_PT_"):
            panels.append(panel)
    return panels


def register():
    """Register Primer's panels and add Primer to Blender's compatible panels."""
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.add(ENGINE)


def unregister():
    """Undo `register`."""
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.discard(ENGINE)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
