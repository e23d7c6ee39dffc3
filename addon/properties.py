"""Primer's settings, stored on the scene as `scene.primer`."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

DEBUG_VIEWS = (
    ("NONE", "Combined", "The rendered image"),
    ("NORMAL", "Shading Normal", "The interpolated normal N used for N.L, as colour (N + 1) / 2"),
    ("FACE_NORMAL", "Face Normal", "The triangle's own normal, used to decide whether a light can be visible"),
    ("NORMAL_ANGLE", "Normal Disagreement", "Angle between shading and face normal, heat map from 0 to 30 degrees: "
                                            "where smooth shading bends the normal"),
    ("BARYCENTRIC", "Barycentrics", "The hit's barycentric coordinates (1-u-v, u, v) as red, green, blue"),
    ("HIT_DISTANCE", "Hit Distance t", "t of I = O + tD along the camera ray, from white (nearest) to black (farthest)"),
    ("DEPTH", "Depth", "Distance along the camera's view axis, normalised to the nearest and farthest hit"),
    ("N_DOT_L", "N.L", "max(N.L, 0) averaged over the lights (or the chosen light): the cosine law alone. With Clamp N.L off, N.L itself, negative in blue"),
    ("VISIBILITY", "Shadow Rays", "Fraction of shadow rays that reached their light (all lights, or the chosen "
                                  "one): white lit, black shadowed"),
    ("ACNE", "Shadow Acne", "Fraction of shadow rays blocked by the surface they started from, heat map 0 to 1"),
    ("RAYS", "Rays per Pixel", "Camera and shadow rays cast per pixel, heat map up to the image's maximum"),
    ("TIME", "Time per Pixel", "Seconds per pixel (each run of 64 pixels timed, shared by rays), heat map up to "
                               "the image's maximum"),
    ("SHUTTER_TIME", "Shutter Time", "The mean time in the shutter of the pixel's camera rays, black when it opens, "
                                     "white when it closes (grey without motion blur; rows with a rolling shutter)"),
)


def _is_light(_settings, obj) -> bool:
    """Only lights can be chosen for the per-light debug views."""
    return obj.type == "LIGHT"


def _denoising_toggled(settings, context) -> None:
    """Set the compositor's Denoise node up, or take it out (addon/compositor.py)."""
    from . import compositor
    compositor.on_toggle(settings, context)


class PrimerSettings(bpy.types.PropertyGroup):
    """Render settings of the Primer engine."""

    settings_source: EnumProperty(
        name="Settings", default="AUTOMATIC",
        items=(("AUTOMATIC", "Automatic", "Cycles' settings for a scene that has none of Primer's own (a file made "
                                          "for Cycles, or a new one), Primer's once one of them was set", 0),
               ("CYCLES", "Cycles", "The scene's Cycles settings (samples, noise threshold, seed, bounces, "
                                    "clamping, caustics) and path tracing, as Cycles renders the file", 1),
               ("PRIMER", "Primer", "Primer's own settings below: the lecture's integrators and switches", 2)),
        description="Where samples, seed, bounces, clamping and caustics come from (addon/cycles_settings.py)")
    integrator: EnumProperty(
        name="Integrator", default="DIRECT",
        # (Explicit numbers: a .blend file stores the number, so an item keeps its number forever.)
        items=(("DIRECT", "Direct Light", "The lecture's ray tracer: light straight from lamps, emitters and the "
                                          "world (Cycles with Max Bounces 0)", 0),
               ("WHITTED", "Whitted", "The lecture's recursion: perfect mirrors and glass followed exactly (both "
                                      "branches, Fresnel), direct light at every hit; up to Max Bounces deep", 2),
               ("PATH", "Path Tracing", "Light after any number of bounces, with the bounce limits of Light Paths "
                                        "(as Cycles renders it)", 1)),
        description="How light is carried to the camera (core/integrators)")
    max_bounces: IntProperty(name="Total", default=12, min=0, max=1024, soft_max=64,
                             description="Most bounces a path makes, as Cycles' Light Paths > Max Bounces > Total")
    diffuse_bounces: IntProperty(name="Diffuse", default=4, min=0, max=1024, soft_max=64,
                                 description="Most diffuse bounces a path makes (Cycles' Max Bounces > Diffuse)")
    glossy_bounces: IntProperty(name="Glossy", default=4, min=0, max=1024, soft_max=64,
                                description="Most glossy and mirror bounces a path makes (Cycles' Max Bounces > Glossy)")
    transmission_bounces: IntProperty(name="Transmission", default=12, min=0, max=1024, soft_max=64,
                                      description="Most refractions a path makes (Cycles' Max Bounces > Transmission)")
    volume_bounces: IntProperty(name="Volume", default=0, min=0, max=1024, soft_max=64,
                                description="How many times a path goes on from where it scatters in a medium "
                                            "(Cycles' Max Bounces > Volume; 0: light scattered once)")
    transparent_bounces: IntProperty(name="Transparent", default=8, min=0, max=1024, soft_max=64,
                                     description="Most transparent surfaces (Transparent BSDF, alpha) a ray passes, "
                                                 "with every integrator (Cycles' Max Bounces > Transparent)")
    fresnel: EnumProperty(
        name="Fresnel", default="EXACT",
        items=(("EXACT", "Exact", "The Fresnel equations of a dielectric"),
               ("SCHLICK", "Schlick", "Schlick's approximation R0 + (1 - R0)(1 - cos)^5, as in the lecture's code")),
        description="How Whitted's tracer splits light between reflection and refraction at glass")
    min_light_bounces: IntProperty(name="Min Light Bounces", default=0, min=0, max=1024, soft_max=64,
                                   description="Bounces (plus one) before Russian roulette may end a path, as in "
                                               "Cycles: more is less noise in deep paths, and slower")
    caustics_reflective: BoolProperty(
        name="Reflective Caustics", default=True,
        description="Light reflected by glossy and mirror surfaces reaches diffuse ones (off: those reflections are "
                    "left out after a diffuse bounce, less noise and less light, as Cycles' Caustics > Reflective)")
    caustics_refractive: BoolProperty(
        name="Refractive Caustics", default=True,
        description="Light refracted by glass reaches diffuse surfaces (off: glass lets no light through after a "
                    "diffuse bounce, less noise and less light, as Cycles' Caustics > Refractive)")
    filter_glossy: FloatProperty(
        name="Filter Glossy", default=0.0, min=0.0, max=10.0, soft_max=2.0,
        description="After blurry bounces, glossy surfaces are made rougher, at least 0.5 sqrt(1 - pdf / this) "
                    "(less noise from small bright things seen in them, a little blur; 0: off, exact), as Cycles' "
                    "Light Paths > Filter Glossy")
    sample_clamp_direct: FloatProperty(
        name="Direct Light", default=0.0, min=0.0, max=1e8, soft_max=100.0,
        description="Cap on what one sample adds through the camera's hit (its channel sum at 3x this); 0: no cap. "
                    "Less noise from rare bright samples, but the image is darker where it bites (Cycles' Clamping)")
    sample_clamp_indirect: FloatProperty(
        name="Indirect Light", default=0.0, min=0.0, max=1e8, soft_max=100.0,
        description="Cap on what one sample adds after a bounce (its channel sum at 3x this); 0: no cap, Primer's "
                    "unbiased default (Cycles' default is 10)")
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
    use_denoising: BoolProperty(
        name="Denoise", default=False, update=_denoising_toggled,
        description="Denoise the composited image with Open Image Denoise: Primer writes the Denoising Albedo and "
                    "Denoising Normal passes and puts a Denoise node fed with them into the compositor")
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
                           description="The lecture's shadow-ray offset in scene units: too small leaves acne, "
                                       "too large loses contact shadows")
    terminator_fix: BoolProperty(name="Shadow Terminator Fix", default=False,
                                 description="Cycles' shadow terminator: lift shadow rays on smooth low-poly meshes "
                                             "onto the surface the normals describe (Hanika 2021) by each object's "
                                             "Geometry Offset, and bend its shading by its Shading Offset")
    threads: IntProperty(name="Threads", default=0, min=0, max=1024,
                         description="Threads tracing rays; 0 uses every core")
    instancing: EnumProperty(
        name="Instancing",
        items=(("AUTO", "Automatic", "Store a mesh once and trace it as instances when its copies would exceed "
                                     "262,144 triangles; copy smaller ones, which trace faster"),
               ("ALWAYS", "Always", "Store every mesh placed twice or more once, and trace its placements as "
                                    "instances (least memory)"),
               ("NEVER", "Never", "Copy every placement into one triangle soup (memory grows with the copies)")),
        default="AUTO",
        description="How meshes placed many times (linked duplicates, collection and geometry-node instances) "
                    "are traced; the image is the same")
    kernels: EnumProperty(
        name="Kernels",
        items=(("COMPILED", "Compiled", "Render in C (the integrator's compiled twin) where it applies: "
                                        "the same image, several times faster"),
               ("NUMPY", "NumPy", "Run every render on the readable Python reference (core/integrators/direct.py), "
                                  "to compare or to step through")),
        default="COMPILED",
        description="Which twin of the render loop runs; lecture switches and debug views always use numpy")
    debug_view: EnumProperty(name="Debug View", items=DEBUG_VIEWS, default="NONE",
                             description="Show one of the tracer's intermediate quantities instead of the image")
    debug_passes: BoolProperty(name="Debug Passes", default=False,
                               description="Also write every debug view as a 'Primer ...' render pass "
                                           "(costs time: acne and time per pixel are the slowest)")
    debug_light: PointerProperty(name="Light", type=bpy.types.Object, poll=_is_light,
                                 description="The light whose N.L and shadow rays the debug views and passes show; "
                                             "empty: the mean over all lights")

    # The lecture switches: each defaults to the lecture's choice (core.scene.LECTURE_SWITCHES).
    smooth_normals: BoolProperty(name="Smooth Normals", default=True,
                                 description="Interpolate vertex normals with the barycentrics; off, every "
                                             "triangle shades with its face normal and the facets show")
    visibility_normal: EnumProperty(
        name="Visibility Normal",
        items=(("FACE", "Face Normal (lecture)", "A light behind the triangle's plane cannot be visible"),
               ("SHADING", "Shading Normal", "Trust the interpolated normal: light leaks through smooth surfaces")),
        default="FACE",
        description="Decide whether a light can be visible with the face normal, not the interpolated one, "
                    "which may face a light behind the triangle")
    reduce_t_max: BoolProperty(name="Reduce t_max", default=True,
                               description="End shadow rays short of the light, so a surface the light sits on "
                                           "does not shadow it")
    distance_attenuation: BoolProperty(name="Distance Attenuation", default=True,
                                       description="Light spreads over a sphere of area 4 pi r^2, so irradiance "
                                                   "falls off as 1/r^2")
    clamp_n_dot_l: BoolProperty(name="Clamp N.L", default=True,
                                description="Below the horizon N.L turns negative; clamp it at 0, or lights "
                                            "behind the normal subtract light")
    light_sampling: EnumProperty(
        name="Light Sampling",
        items=(("MIS", "Multiple Importance", "Light samples and BSDF-sampled rays, each weighed by how well it "
                                              "finds each light (the power heuristic, as Cycles)"),
               ("LIGHT", "Light Samples Only", "Only sample the lights: noisy where a glossy surface reflects a "
                                               "large light"),
               ("BSDF", "BSDF Samples Only", "Only follow directions sampled from the material: noisy for small "
                                             "lights; lights without extent keep their light samples")),
        default="MIS",
        description="How lights with extent (area lights, round lights, emissive meshes, the world) are found")
    shadow_rays_for_backfacing: BoolProperty(name="Shadow Rays for Back-Facing Lights", default=False,
                                             description="A light behind the surface is invisible anyway: casting "
                                                         "its shadow ray costs rays and changes nothing")


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
