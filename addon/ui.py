"""Panels: Primer's settings in the Render properties, and Blender's own panels enabled for Primer."""
from __future__ import annotations

import bpy

from . import cycles_settings
from .engine import PrimerRenderEngine

ENGINE = PrimerRenderEngine.bl_idname


class PrimerOnly:
    """Mixin of every Primer panel, wherever it sits: shown only when Primer is the render engine."""

    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class PrimerPanel(PrimerOnly):
    """Base of Primer's panels in the Properties editor."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"


class Followed:
    """Draws a followed setting (addon/cycles_settings.py FOLLOWED) from where the render reads it: scene.cycles
    when the scene follows Cycles (editing it edits Cycles' setting), else scene.primer."""

    def __init__(self, scene):
        """Read the scene's choice once per draw."""
        self.primer = scene.primer
        self.cycles = scene.cycles if cycles_settings.follows_cycles(scene) else None

    def value(self, name: str):
        """The setting's value where the render reads it."""
        if self.cycles is None:
            return getattr(self.primer, name)
        return getattr(self.cycles, cycles_settings.FOLLOWED[name])

    def prop(self, layout, name: str, **kw) -> None:
        """Draw the setting `name` (Primer's name) where the render reads it."""
        if self.cycles is None:
            layout.prop(self.primer, name, **kw)
        else:
            layout.prop(self.cycles, cycles_settings.FOLLOWED[name], **kw)


class RENDER_PT_primer_sampling(PrimerPanel, bpy.types.Panel):
    """Where the settings come from; samples per pixel and per light."""

    bl_label = "Sampling"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.scene.primer
        followed = Followed(context.scene)
        col = layout.column()
        col.prop(props, "settings_source")
        if followed.cycles is not None:
            col.label(text="Samples, seed, bounces, clamping, caustics: Cycles' (path tracing)", icon="INFO")
        adaptive = followed.value("use_adaptive_sampling")
        followed.prop(col, "samples", text="Max Samples" if adaptive else "Samples")
        col.prop(props, "viewport_samples")
        col.prop(props, "light_samples")
        followed.prop(col, "use_adaptive_sampling", text="Adaptive Sampling")
        sub = col.column(align=True)
        sub.active = adaptive
        followed.prop(sub, "adaptive_threshold", text="Noise Threshold")
        followed.prop(sub, "adaptive_min_samples", text="Min Samples")
        col.prop(props, "use_denoising")
        followed.prop(col, "seed", text="Seed")
        followed.prop(col, "animate_seed", text="Animate Seed")
        # Blender keeps the engine between frames: Primer then reads only the meshes that changed.
        col.prop(context.scene.render, "use_persistent_data", text="Persistent Data")
        col.prop(props, "threads")
        col.prop(props, "instancing")
        col.prop(props, "kernels")


class RENDER_PT_primer_light_paths(PrimerPanel, bpy.types.Panel):
    """The integrator and a path's bounce limits (Cycles' Light Paths)."""

    bl_label = "Light Paths"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.scene.primer
        followed = Followed(context.scene)
        integrator = "PATH" if followed.cycles is not None else props.integrator
        col = layout.column()
        row = col.row()
        row.active = followed.cycles is None                # following Cycles: path tracing
        row.prop(props, "integrator")
        sub = col.column(align=True, heading="Max Bounces")
        sub.active = integrator != "DIRECT"
        for name, text in (("max_bounces", "Total"), ("diffuse_bounces", "Diffuse"), ("glossy_bounces", "Glossy"),
                           ("transmission_bounces", "Transmission"), ("volume_bounces", "Volume")):
            followed.prop(sub, name, text=text)
        followed.prop(col, "transparent_bounces", text="Transparent Bounces")
        row = col.row()
        row.active = integrator == "PATH"
        followed.prop(row, "min_light_bounces", text="Min Light Bounces")
        row = col.row()
        row.active = integrator == "WHITTED"
        row.prop(props, "fresnel")
        sub = col.column(align=True, heading="Clamping")
        sub.active = integrator != "WHITTED"
        followed.prop(sub, "sample_clamp_direct", text="Direct Light")
        followed.prop(sub, "sample_clamp_indirect", text="Indirect Light")
        sub = col.column(align=True, heading="Caustics")
        sub.active = integrator == "PATH"
        followed.prop(sub, "filter_glossy", text="Filter Glossy")
        followed.prop(sub, "caustics_reflective", text="Reflective")
        followed.prop(sub, "caustics_refractive", text="Refractive")


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


class RENDER_PT_primer_motion_blur(PrimerPanel, bpy.types.Panel):
    """Render > Motion Blur as Cycles reads it: the camera blurred over the shutter (addon/motion.py)."""

    bl_label = "Motion Blur"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        scene = context.scene
        layout.active = scene.render.use_motion_blur
        col = layout.column()
        col.prop(scene.render, "motion_blur_position", text="Position")
        col.prop(scene.render, "motion_blur_shutter")
        cycles = getattr(scene, "cycles", None)
        if cycles is not None:
            col.separator()
            col.prop(cycles, "rolling_shutter_type", text="Rolling Shutter")
            sub = col.column()
            sub.active = cycles.rolling_shutter_type != "NONE"
            sub.prop(cycles, "rolling_shutter_duration")
        layout.label(text="Primer blurs the camera; moving objects are named in a warning", icon="INFO")


class RENDER_PT_primer_motion_blur_curve(PrimerPanel, bpy.types.Panel):
    """The shutter curve: how open the shutter is over its time."""

    bl_label = "Shutter Curve"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_primer_motion_blur"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        render = context.scene.render
        self.layout.active = render.use_motion_blur
        self.layout.template_curve_mapping(render, "motion_blur_shutter_curve")


class OBJECT_PT_primer_motion_blur(PrimerPanel, bpy.types.Panel):
    """An object's Motion Blur and Steps, as Cycles reads them (a camera's steps: its transforms over the shutter)."""

    bl_label = "Motion Blur"
    bl_context = "object"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        obj = context.object
        return super().poll(context) and obj is not None and getattr(obj, "cycles", None) is not None

    def draw_header(self, context):
        self.layout.active = context.scene.render.use_motion_blur
        self.layout.prop(context.object.cycles, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        obj = context.object
        layout.active = context.scene.render.use_motion_blur and obj.cycles.use_motion_blur
        col = layout.column()
        col.prop(obj.cycles, "motion_steps", text="Steps")
        if obj.type != "CAMERA":
            col.prop(obj.cycles, "use_deform_motion", text="Deformation")


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
        layout.prop(props, "debug_light")
        layout.prop(props, "debug_passes")


class RENDER_PT_primer_lecture(PrimerPanel, bpy.types.Panel):
    """The lecture's choices as switches: flip one and see why the lecture makes it."""

    bl_label = "Lecture"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_primer_debug"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.scene.primer
        col = layout.column(heading="Normals")
        col.prop(props, "smooth_normals")
        col.prop(props, "visibility_normal")
        col = layout.column(heading="Shadow Rays")
        col.prop(props, "shadow_method")
        sub = col.column()
        sub.active = props.shadow_method == "EPSILON"
        sub.prop(props, "epsilon")
        col.prop(props, "reduce_t_max")
        col.prop(props, "shadow_rays_for_backfacing", text="Back-Facing Lights")
        col = layout.column(heading="Transport")
        col.prop(props, "distance_attenuation")
        col.prop(props, "clamp_n_dot_l")
        col.prop(props, "light_sampling")


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
    RENDER_PT_primer_light_paths,
    RENDER_PT_primer_shadows,
    RENDER_PT_primer_motion_blur,
    RENDER_PT_primer_motion_blur_curve,
    RENDER_PT_primer_debug,
    RENDER_PT_primer_lecture,
    DATA_PT_primer_light,
    DATA_PT_primer_spot,
    OBJECT_PT_primer_motion_blur,
)

# Blender's own panels that also describe what Primer renders: every panel Workbench uses
# ("BLENDER_RENDER": camera, output, object, mesh data...), minus those Primer replaces or has
# no use for, plus the material slot and surface panels of EEVEE and the camera's Depth of Field (which Primer renders
# with the settings Cycles reads there).
_EXCLUDED_PANELS = {
    "DATA_PT_light", "DATA_PT_spot", "DATA_PT_preview",
    "RENDER_PT_freestyle", "RENDER_PT_simplify", "RENDER_PT_simplify_viewport", "RENDER_PT_simplify_render",
}
_MATERIAL_PANELS = {"EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "DATA_PT_camera_dof",
                    "DATA_PT_camera_dof_aperture"}


def _compatible_panels():
    """Return Blender's panels that Primer shows too."""
    panels = []
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        name = panel.__name__
        if engines is None or name in _EXCLUDED_PANELS or name.startswith("DATA_PT_lightprobe"):
            continue
        if "BLENDER_RENDER" in engines or name in _MATERIAL_PANELS:
            panels.append(panel)
    return panels


def register():
    """Register Primer's panels and add Primer to Blender's compatible panels."""
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in _compatible_panels():
        # A new set per panel: many panels share one set object through their base class,
        # and adding to it in place would also show Primer in the panels excluded above.
        panel.COMPAT_ENGINES = set(panel.COMPAT_ENGINES) | {ENGINE}


def unregister():
    """Undo `register`."""
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES = set(panel.COMPAT_ENGINES) - {ENGINE}
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
