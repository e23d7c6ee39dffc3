"""How to render: image size, sampling, the integrator and the lecture's switches."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence


@dataclass
class RenderSettings:
    """How to render: image size, sampling, the integrator and the lecture's switches.

    integrator: the name of the light-transport algorithm in core/integrators ("direct": the
        lecture's direct lighting, each light sampled with shadow rays; "path": path tracing).
    max_bounces, diffuse_bounces, glossy_bounces, transmission_bounces, transparent_max_bounces: a path's
        bounce limits, with Cycles' meaning and defaults (Light Paths > Max Bounces); "direct" is a path
        with max_bounces 0. min_light_bounces: Russian roulette spares a path's first min_light_bounces + 1
        bounces (Cycles' Min Light Bounces). volume_bounces: how many times a path goes on from where it
        scatters in a medium (Cycles' Light Paths > Max Bounces > Volume; 0: it scatters once, its phase ray
        finding light, and ends there; each event is a bounce too).
    caustics_reflective, caustics_refractive: whether light reaches a diffuse surface by a glossy reflection
        or a refraction after it (Cycles' Light Paths > Caustics; off: those closures are left out at hits that
        a diffuse bounce's ray reaches; a path tracer's switches, core/integrators/path.py).
    filter_glossy: Cycles' Light Paths > Filter Glossy (0: off): after bounces of small pdf a path's glossy lobes are
        made rougher, 0.5 sqrt(1 - min pdf / filter_glossy) at least (core/integrators/path.py
        filter_glossy_roughness): less noise, a little blur; a path tracer's setting.
    sample_clamp_direct, sample_clamp_indirect: cap each direct (camera hit) and indirect contribution's
        channel sum at 3 x the value, 0: no cap (Cycles' Light Paths > Clamping; core/integrators/clamp.py).
    fresnel: how Whitted's tracer splits light at glass: "exact" (the dielectric Fresnel equations) or
        "schlick" (Schlick's approximation, the lecture's R0 + (1 - R0)(1 - cos)^5).
    light_sampling: how lights with extent are found: "mis" (light samples and BSDF-sampled rays,
        weighed by multiple importance sampling, as Cycles), "light" (light samples alone) or "bsdf"
        (BSDF-sampled rays alone; lights without extent keep their light samples).

    exposure: Cycles' Film Exposure: the factor on Combined and the passes of light (Emission, Environment, the
        light passes, the light groups, the shadow catchers' matte); data, colour and AO passes and the Shadow
        Catcher pass (a ratio) keep their values, as Cycles' pass_info.use_exposure says.

    pass_alpha_threshold: the view layer's Alpha Threshold: the first surface of a camera path at least this opaque
        (1 - mean transparency) holds the data passes (Normal, UV, ...; 0: the first surface), as Cycles.
    world_vector: where a camera path sees the world, the Vector pass holds the motion of its direction as the camera
        turns (Blender 5.2's Cycles, camera_motion_vector_direction; core/integrators/passes.py world_vector_at),
        not nothing (Cycles before 5.2, the default).
    transparent_glass: Film > Transparent Glass's Roughness Threshold with a transparent film (-1: off): a camera
        path keeps seeing the film clear through glass whose lobe is at most that rough, so the world behind glass is
        alpha, not colour (Cycles' LABEL_TRANSMIT_TRANSPARENT: alpha_x alpha_y <= threshold^4).

    pixel_filter, filter_width: where a camera sample lands around its pixel's centre, as Cycles draws it from
        the filter (core/camera/filter.py): "BOX" (Blender gives it the width 1: the pixel), "GAUSSIAN",
        "BLACKMAN_HARRIS" (Cycles' default, 1.5 px); the width in pixels (Render > Film > Pixel Filter).

    region: (x0, y0, x1, y1) pixel rectangle to render, y from the top row, or None for all.
    shadow_method: "robust" (error-bound offset, no user epsilon) or "epsilon" (the lecture's).
    aux: names of auxiliary buffers to return, from core.integrators.debug.AUX_BUFFERS.
    instancing: "auto" stores a mesh once and traces it as Embree instances when its copies would
        exceed core.geometry.instancing.INSTANCE_TRIANGLES triangles, "always" does so for every mesh placed
        twice or more, "never" copies every placement (core/geometry/instancing.py). The image is the same.
    kernels: "compiled" renders in C (the integrator's compiled twin, core/integrators/*.c) where it
        applies (the same numbers, several times faster); "numpy" keeps every render on the readable
        Python reference path.
    denoising_features: also return the denoising features "denoising_albedo" and "denoising_normal"
        (core/integrators/features.py: albedo and normal of each pixel's first non-specular hit), computed
        by a first-hit pass of a few samples per pixel after the render, with either kernels.
    adaptive: render in passes and stop pixels whose noise is below adaptive_threshold
        (core/film/adaptive.py); samples is then the most a pixel gets. adaptive_threshold 0 and
        adaptive_min_samples 0 choose automatic values from samples.

    The lecture switches (LECTURE_SWITCHES) default to the lecture's choice; turning one
    off shows what goes wrong without it (README, "Lecture switches"):
    smooth_normals:   interpolate vertex normals with the barycentrics (False: the face normal everywhere)
    visibility_normal: "face" decides whether a light can be seen with the face normal Ng.L > 0,
                      "shading" with the interpolated N.L > 0 (light leaks through smooth low-poly meshes)
    reduce_t_max:     stop shadow rays short of the light point (False: t_max = ||P_light - I||, so a
                      surface the light sits on shadows it)
    distance_attenuation: irradiance falls off as 1/r^2 (False: point, spot and area lights do not)
    clamp_n_dot_l:    the cosine factor is max(N.L, 0) (False: N.L, negative light from behind)
    shadow_rays_for_backfacing: also trace shadow rays for lights behind the surface (True: the same
                      image, more rays; the lecture skips them, since their visibility is 0)
    passes: the first-hit render passes to return as Cycles writes them (core/integrators/passes.py
                      PASS_CHANNELS: "position", "uv", "object_index", "diffuse_color", ...; CRYPTO_PASSES:
                      "crypto_object", "crypto_material", "crypto_asset"), and the light passes, from the
                      integrator (core/integrators/lightpasses.py LIGHT_PASSES: "diffuse_direct", ...), only
                      those asked for
    cryptomatte_depth: the (id, coverage) ranks each Cryptomatte pass keeps per pixel (View Layer >
                      Passes > Cryptomatte > Levels; 6 by default, two per RGBA pass)
    ao_distance: how far the Ambient Occlusion pass's rays look (Blender's World > Ambient Occlusion > Distance),
                      and Fast GI's rays
    ao_bounces, ao_factor: Cycles' Fast GI Approximation, Replace (Render > Light Paths > Fast GI: AO Bounces; World >
                      Ambient Occlusion > Factor): a path's BSDF ray past ao_bounces bounces (diffuse ones, and the
                      first glossy one; core/integrators/path.py fast_gi_ray) looks ao_distance far and ends at the
                      surface it meets; escaping, it brings the world's light times ao_factor. 0 for either: off
    ao_additive_factor: Cycles' Fast GI, Add (the world's AO Factor): every path vertex adds ambient occlusion (one
                      ray ao_distance long) times its diffuse closures' weights times this (path.fast_gi_added); 0: off
    mist_start, mist_depth, mist_falloff: the Mist pass's mapping of the distance d from the camera (World > Mist
                      Pass: Start, Depth, Falloff as an exponent: Quadratic 2, Linear 1, Inverse Quadratic 0.5):
                      clamp((d - start) / depth, 0, 1) ^ falloff (core/integrators/passes.py)
    light_groups: the light groups whose passes to write (View Layer > Light Groups' names, in order): each the
                      light of the sources in it, from the integrator (core/integrators/lightgroups.py;
                      membership: Scene.lightgroups)
    shadow_catcher_pass: write the Shadow Catcher pass (RenderResult.aux "shadow_catcher"), and Combined as the
                      shadow catchers' matte itself rather than Cycles' approximation (core/integrators/catcher.py;
                      Cycles' View Layer > Passes > Light > Shadow Catcher)
    aovs: the shader AOVs to write (View Layer > Passes > Shader AOV, in order): (name, "COLOR" or "VALUE") each,
                      what the materials' AOV Output nodes naming them give camera paths (core/integrators/passes.py;
                      RenderResult.aux "aov:NAME", COLOR as RGBA, VALUE one channel)
    """

    integrator: str = "direct"
    light_sampling: str = "mis"
    max_bounces: int = 12
    diffuse_bounces: int = 4
    glossy_bounces: int = 4
    transmission_bounces: int = 12
    transparent_max_bounces: int = 8
    volume_bounces: int = 0
    min_light_bounces: int = 0
    caustics_reflective: bool = True
    caustics_refractive: bool = True
    filter_glossy: float = 0.0
    sample_clamp_direct: float = 0.0
    sample_clamp_indirect: float = 0.0
    fresnel: str = "exact"
    width: int = 640
    height: int = 480
    samples: int = 16
    seed: int = 0
    region: Optional[tuple] = None
    pixel_aspect: tuple = (1.0, 1.0)
    pixel_filter: str = "BOX"
    filter_width: float = 1.0
    exposure: float = 1.0
    transparent_glass: float = -1.0
    pass_alpha_threshold: float = 0.5
    world_vector: bool = False
    jitter: bool = True
    light_samples: int = 4
    shadow_method: str = "robust"
    epsilon: float = 1e-3
    terminator_fix: bool = False
    terminator_offset: float = 0.1
    camera_relative: bool = True
    transparent_background: bool = False
    threads: int = 0
    chunk_size: int = 1 << 16
    instancing: str = "auto"
    kernels: str = "compiled"
    aux: Sequence[str] = ()
    denoising_features: bool = False
    adaptive: bool = False
    adaptive_threshold: float = 0.0
    adaptive_min_samples: int = 0
    smooth_normals: bool = True
    visibility_normal: str = "face"
    reduce_t_max: bool = True
    distance_attenuation: bool = True
    clamp_n_dot_l: bool = True
    shadow_rays_for_backfacing: bool = False
    passes: Sequence[str] = ()
    ao_distance: float = 10.0
    ao_bounces: int = 0
    ao_factor: float = 0.0
    ao_additive_factor: float = 0.0
    mist_start: float = 0.0
    mist_depth: float = 100.0
    mist_falloff: float = 1.0
    cryptomatte_depth: int = 6
    light_groups: Sequence[str] = ()
    shadow_catcher_pass: bool = False
    aovs: Sequence[tuple] = ()

    @property
    def filter(self):
        """The pixel filter (core/camera/filter.py PixelFilter) of pixel_filter and filter_width."""
        from ..camera.filter import PixelFilter
        return PixelFilter(self.pixel_filter, float(self.filter_width))

    def is_lecture_default(self) -> bool:
        """Whether every lecture switch is at the lecture's choice (a fast path may then stand in)."""
        return all(getattr(self, name) == default for name, default in LECTURE_SWITCHES.items())


# The lecture switches of RenderSettings and their defaults (the lecture's choices). shadow_method and
# epsilon are lecture settings too, but every render path supports both, so they are not listed here.
LECTURE_SWITCHES = {
    "smooth_normals": True,
    "visibility_normal": "face",
    "reduce_t_max": True,
    "distance_attenuation": True,
    "clamp_n_dot_l": True,
    "shadow_rays_for_backfacing": False,
}
