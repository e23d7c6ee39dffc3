"""Primer's settings, stored on the scene as `scene.primer`."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

DEBUG_VIEWS = (
    ("NONE", "Combined", "The rendered image"),
    ("NORMAL", "Shading Normal", "The interpolated normal N used for N.L, as colour (N + 1) / 2"),
    ("FACE_NORMAL", "Face Normal", "The triangle's own normal, used to decide whether a light can be visible"),
    ("DEPTH", "Depth", "Distance along the camera's view axis, normalised to the nearest and farthest hit"),
    ("N_DOT_L", "N.L", "max(N.L, 0) averaged over the lights: the cosine law alone"),
    ("VISIBILITY", "Shadow Rays", "Fraction of shadow rays that reached their light: white lit, black shadowed"),
)


class PrimerSettings(bpy.types.PropertyGroup):
    """Render settings of the Primer engine."""

    samples: IntProperty(name="Samples", default=16, min=1, max=1 << 16, soft_max=1024,
                         description="Camera rays per pixel, on a jittered stratified pattern (anti-aliasing)")
    viewport_samples: IntProperty(name="Viewport Samples", default=16, min=1, max=1 << 16, soft_max=1024,
                                  description="Camera rays per pixel the viewport accumulates after its coarse "
                                              "first pass, in passes of 1, 1, 2, 4, ... samples")
    light_samples: IntProperty(name="Light Samples", default=4, min=1, max=1024, soft_max=64,
                               description="Shadow rays per camera ray for lights with extent (radius, angle, area); "
                                           "lights without extent are exact and need one")
    use_adaptive_sampling: BoolProperty(
        name="Adaptive Sampling", default=True,
        description="Spend samples where pixels need them: after a first pass, only pixels whose noise is "
                    "above the threshold (edges, shadow boundaries, lights with extent) get more")
    adaptive_threshold: FloatProperty(
        name="Noise Threshold", default=0.0, min=0.0, max=1.0, soft_max=0.1, precision=4,
        description="Relative noise at which a pixel stops getting samples; 0 chooses it from Samples "
                    "(0.25 / sqrt(samples)), so more samples always mean less noise")
    adaptive_min_samples: IntProperty(
        name="Min Samples", default=0, min=0, max=4096,
        description="Samples every pixel gets before its noise is judged; 0 chooses max(4, samples / 16)")
    seed: IntProperty(name="Seed", default=0, min=0, description="Seed of the sampling pattern: same seed, same image")
    animate_seed: BoolProperty(name="Animate Seed", default=False,
                               description="Add the frame number to the seed, so noise changes between frames")
    shadow_method: EnumProperty(
        name="Shadow Offset",
        items=(("ROBUST", "Robust", "Offset the shadow ray along the face normal by the floating-point error "
                                    "bound of the hit: no epsilon to tune, correct at any scale"),
               ("EPSILON", "Epsilon (lecture)", "Move the shadow ray's origin by epsilon towards the light and "
                                                "shorten t_max by 2 epsilon, as in the lecture")),
        default="ROBUST", description="How shadow rays avoid hitting the surface they start from (shadow acne)")
    epsilon: FloatProperty(name="Epsilon", default=1e-3, min=0.0, soft_max=1.0, precision=6, unit="LENGTH",
                           description="The lecture's shadow-ray offset, in scene units")
    terminator_fix: BoolProperty(name="Shadow Terminator Fix", default=False,
                                 description="Lift shadow rays on smooth low-poly meshes onto the surface the "
                                             "normals describe (Hanika 2021), hiding faceted terminators")
    threads: IntProperty(name="Threads", default=0, min=0, max=1024,
                         description="Threads tracing rays; 0 uses every core")
    debug_view: EnumProperty(name="Debug View", items=DEBUG_VIEWS, default="NONE",
                             description="Show one of the tracer's intermediate quantities instead of the image")
    debug_passes: BoolProperty(name="Debug Passes", default=True,
                               description="Also write Primer's face normal, N.L and shadow-ray passes")


classes = (PrimerSettings,)


def register():
    """Add scene.primer."""
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.primer = PointerProperty(type=PrimerSettings)


def unregister():
    """Remove scene.primer."""
    del bpy.types.Scene.primer
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
