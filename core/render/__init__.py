"""Render: the one path from a scene to an image, a chunk of pixels x samples at a time.

F12, `blender -b`, the viewport's progressive passes, adaptive sampling and the ray inspector all
come here; what differs between them is settings, not code. For a render:

1. prepare: validate (validate.py), build the geometry (core/geometry), move the lights into the camera-relative
   frame (core/lights), make the material table (core/materials): a Context;
2. plan passes: one pass of `samples`, or with adaptive sampling a small first pass and then
   passes over the pixels still noisy (core/film/adaptive.py);
3. run each pass as chunks on a thread pool; a chunk is
   a. the samples' positions in their pixels (core/sampling), their camera rays (core/camera),
   b. the integrator: the light each ray brings back (core/integrators),
   c. each pixel's sums (core/film);
   in C (core/integrators/compiled.py) where it applies, else in the readable Python reference;
4. the film's image: each pixel's mean over its samples (a 1-pixel box filter, like Cycles' "Box").

Chunks write to disjoint pixels, so threads need no locks; Embree, numpy and the C code release the
GIL, so large passes run on every core. Nothing depends on the schedule (random numbers hash seed, pixel
and sample; each pixel's sums are added in one order; nothing is filled lazily by the first thread), so a
render gives the same bits on any number of threads (docs/architecture.md, "Threads"). Memory stays bounded by the chunk size, whatever the image
size, and the temporaries come from the heap (core/memory.py).

The render part sits above every part it drives: beside this loop are its validation (validate.py, what
cannot be rendered and why) and the viewport's progressive passes (progressive.py, which call `render`).
"""
from __future__ import annotations

import dataclasses
import math
import os
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from .. import lights as lights_
from .. import memory, vectors
from ..camera import camera as camera_
from ..camera import motion
from ..film import adaptive
from ..film.film import FILM_MAX, ChunkSums, Film, finite_samples, pixel_sums
from ..geometry import instancing
from ..geometry import geometry as geometry_
from ..geometry.geometry import WorldGeometry, build_geometry
from ..integrators import Cancelled, Context, Recorder, StopFlag, for_render
from ..visibility import HIDDEN_FROM_SHADOW, HOLDOUT
from ..integrators import catcher as catcher_
from ..integrators import cryptomatte, features, lightgroups, lightpasses, passes as passes_
from ..integrators import mnee as mnee_
from ..integrators.compiled import Compiled, graph_emission as compiled_graph_emission, why_not
from ..materials import graph as graph_
from ..materials import Material, MaterialTable
from .. import volumes
from ..sampling import sobol as sampling
from ..scene import RenderSettings, Scene
from .validate import validate
from ..integrators import debug
from ..integrators import rays as rays_

AUX_BUFFERS = debug.AUX_BUFFERS
# With the "time" buffer, each chunk is rendered and timed in runs of this many pixels.
TIME_TILE = 64


@dataclass
class RenderStats:
    """What a render did: ray counts, time, and notes about the input."""

    primary_rays: int = 0
    shadow_rays: int = 0
    seconds: float = 0.0
    geometry_seconds: float = 0.0
    trace_seconds: float = 0.0      # inside Embree (nearest hits and shadow rays), summed over threads
    shading_seconds: float = 0.0    # shading the hits, less its shadow rays' Embree time, summed over threads
    triangles: int = 0
    passes: int = 0                 # sampling passes run (1 without adaptive sampling)
    samples_per_pixel: Optional[np.ndarray] = None   # (H, W) int32 camera samples each pixel received
    warnings: list = field(default_factory=list)
    kernels: str = ""               # "compiled", or "numpy" and why (core/integrators/compiled.py)
    first_hit: tuple = ()           # the first-hit passes the integrator wrote (core/integrators/passes.py)

    @property
    def rays(self) -> int:
        """All rays traced."""
        return self.primary_rays + self.shadow_rays


@dataclass
class RenderResult:
    """A rendered image.

    image: (H, W, 4) float32 scene-linear RGBA, row 0 at the top
    aux:   name -> (H, W, c) float32 auxiliary buffer: the debug buffers asked for, and with
           settings.denoising_features the features' "denoising_albedo" and "denoising_normal" (3 each),
           and the first-hit passes settings.passes names (core/integrators/passes.py PASS_CHANNELS), and the
           light passes it names (core/integrators/lightpasses.py LIGHT_PASSES, each divided by its colour pass)
    light_names: the name of the light behind each channel of the per-light buffers
    """

    image: np.ndarray
    aux: dict
    stats: RenderStats
    cancelled: bool = False
    light_names: list = field(default_factory=list)


def panorama_frame(camera, settings) -> tuple:
    """A panoramic camera's Window for the node graphs (graph.panorama_window): (a, b, c, d, 2 + its type's place in
    graph.PANORAMA_WINDOWS, e, f, g) with Cycles' numbers for its type: the equirectangular and central cylindrical
    ranges, the equidistant fisheye's field of view, the equisolid one's lens and sensor (mm), the polynomial one's
    k0 .. k3, then k4 and the sensor."""
    kind = camera.panorama_type
    code = 2.0 + graph_.PANORAMA_WINDOWS.index(kind)
    if kind == "EQUIRECTANGULAR":
        return (camera.longitude_min - camera.longitude_max, -camera.longitude_min,
                camera.latitude_min - camera.latitude_max, math.pi / 2.0 - camera.latitude_min, code, 0.0, 0.0, 0.0)
    if kind == "CENTRAL_CYLINDRICAL":
        return (-camera.cylinder_u_min, -camera.cylinder_u_max, camera.cylinder_v_min / camera.cylinder_radius,
                camera.cylinder_v_max / camera.cylinder_radius, code, 0.0, 0.0, 0.0)
    if kind == "FISHEYE_EQUIDISTANT":
        return (camera.fisheye_fov, 0.0, 0.0, 0.0, code, 0.0, 0.0, 0.0)
    width, height = camera_._panorama_sensor(camera, settings.width, settings.height, tuple(settings.pixel_aspect))
    if kind == "FISHEYE_EQUISOLID":
        return (camera.fisheye_lens, width, height, 0.0, code, 0.0, 0.0, 0.0)
    if kind == "FISHEYE_LENS_POLYNOMIAL":
        k = tuple(float(x) for x in camera.fisheye_polynomial)
        return (*k[:4], code, k[4], width, height)
    return (0.0, 0.0, 0.0, 0.0, code, 0.0, 0.0, 0.0)


def region_pixels(settings: RenderSettings) -> np.ndarray:
    """Return the flat indices (row-major, row 0 at the top) of the pixels to render: (p,) int64."""
    W, H = settings.width, settings.height
    x0, y0, x1, y1 = settings.region if settings.region is not None else (0, 0, W, H)
    x0, x1 = max(0, int(x0)), min(W, int(x1))
    y0, y1 = max(0, int(y0)), min(H, int(y1))
    if x1 <= x0 or y1 <= y0:
        return np.zeros(0, np.int64)
    return (np.arange(y0, y1, dtype=np.int64)[:, None] * W + np.arange(x0, x1, dtype=np.int64)).reshape(-1)


# Placing at least this many copied triangles frees enough temporaries (about 300 bytes a triangle) that prepare hands
# the heap's free pages back once the geometry is built.
HAND_BACK_TRIANGLES = 1 << 18


def prepare(scene: Scene, settings: RenderSettings, geometry: Optional[WorldGeometry] = None,
            warnings: Optional[list] = None, light_numbers: Optional[np.ndarray] = None) -> Context:
    """Validate and return what every chunk reads: geometry, camera-relative lights, materials.

    A prebuilt `geometry` (same camera origin) skips the BVH build. Notes about the input go to warnings.
    """
    validate(scene, settings)
    warnings = [] if warnings is None else warnings
    # Camera-relative rendering: subtract the camera position in float64 before float32.
    origin = (np.asarray(scene.camera.matrix_world, np.float64)[:3, 3] if settings.camera_relative
              else np.zeros(3))
    blur_because = object_blur_reason(scene, settings) if scene.camera.shutter is not None else "no motion blur"
    if blur_because not in ("", "no object moves", "no motion blur"):
        warnings.append("motion blur: the moving objects are rendered still where they are at the frame "
                        f"({blur_because})")
    if "vector" in settings.passes and scene.camera.shutter is None:
        scene = passes_.with_vector_deformation(scene, warnings)     # (deforming meshes' vertices then: attributes)
    if geometry is None:
        geometry = build_geometry(scene, origin, instancing.instance_triangles(settings.instancing),
                                  motion_blur=not blur_because)
        # A large build's freed temporaries go back to the system before the world's map and the film are made, so
        # the render's peak is not theirs on top of those (core/memory.py hand_back_free). Not after a small one:
        # there the warm heap's pages are worth more than the memory (core/memory.py).
        if len(geometry.triangles) >= HAND_BACK_TRIANGLES:
            memory.hand_back_free()
    warnings.extend(w for w in geometry.warnings if w not in warnings)
    lamps = lights_.usable(scene.lights, warnings)
    lights = [lights_.linking.found_by_bounces(light.moved(geometry.origin)) for light in lamps]
    aovs = tuple(settings.aovs)                 # the view layer's shader AOVs (passes.py), those the film has room for
    warnings.extend(f"shader AOV '{name}' is not written: Primer keeps {passes_.AOV_CHANNELS_MAX} AOV channels at "
                    "most (a Color AOV takes 4, a Value AOV 1)" for name in passes_.aovs_left_out(aovs))
    materials = MaterialTable.of(scene.materials, scene.default_material, warnings, passes_.aov_slots(aovs))
    materials.view = camera_.world_to_camera(scene.camera)     # (the Camera coordinates and Camera Data nodes)
    if scene.camera.type in ("PERSP", "ORTHO"):                  # (the Window coordinates: the frame on screen)
        materials.window = (*camera_.viewplane(scene.camera, settings.width, settings.height,
                                               tuple(settings.pixel_aspect)), float(scene.camera.type == "PERSP"),
                            float(settings.width), float(settings.height), 0.0)     # (and Pixel Size's pixel)
    elif scene.camera.type == "PANO" and scene.camera.panorama_type in graph_.PANORAMA_WINDOWS:
        materials.window = panorama_frame(scene.camera, settings)
    # The lights a render makes of its scene: the emissive meshes, and the world's image (NaN or infinite parts
    # read as 0, as Cycles renders them).
    world = lights_.world.finite_world(scene.the_world(), warnings)
    # (textured emitters' estimates: their graphs run in C where the library is loaded, in both kernels alike)
    emitters = lights_.emitters.from_geometry(geometry, materials, compiled_graph_emission, warnings)
    sampler = lights_.WorldLight.of(world, compensate=compensates_world(settings, world))
    lights += [light for light in (emitters, sampler) if light is not None]
    ctx = Context(scene, settings, geometry, lights, materials, light_numbers)
    ctx.extra["world_light"] = world
    ctx.extra["stop"] = StopFlag()      # set when the render is cancelled: every chunk reads it as it works
    ctx.extra["emitters"] = emitters
    ctx.extra["world_sampler"] = sampler
    # The first-hit passes the integrator writes (passes.py): those asked for, and the colour passes the light passes
    # are divided by; the Cryptomatte ids hashed once.
    ctx.extra["pass_layout"] = passes_.PassLayout(lightpasses.first_hit_passes(settings.passes),
                                                  settings.cryptomatte_depth, aovs)
    ctx.extra["world_aovs"] = world_aovs(world, ctx.extra["pass_layout"], settings)
    if ctx.extra["pass_layout"].mattes:
        ctx.extra["crypto_ids"] = cryptomatte.id_tables(scene)
    if ctx.extra["pass_layout"].has("vector"):         # (the screen motion of each instance and the camera)
        ctx.extra["vector_tables"] = passes_.vector_tables(scene, settings.width, settings.height,
                                                           settings.pixel_aspect, scene.camera.shutter is not None,
                                                           geometry.attribute_layout,
                                                           panorama_frame(scene.camera, settings)
                                                           if scene.camera.type == "PANO" else (),
                                                           settings.world_vector)
    # The light groups asked for: which group each light, object and the world belongs to (lightgroups.py).
    ctx.extra["light_groups"] = lightgroups.LightGroups.of(scene, settings.light_groups, lamps, lights)
    # Which lights BSDF-sampled rays can find (weighed by MIS), which the camera sees, and whether a
    # BSDF ray is worth tracing at all (not for scenes lit by lights without extent alone).
    ctx.extra["hittable"] = {index for index, light in enumerate(lights) if light.hittable}
    ctx.extra["camera_lamps"] = [index for index, light in enumerate(lights)
                                 if light.hittable and (light.is_(lights_.LightFlags.POSITION | lights_.LightFlags.AREA)
                                                        or light.is_(lights_.LightFlags.DISTANT) and light.use_mis)
                                 and light.camera]
    world_lights = world.lights and (world.varying or np.asarray(world.color, np.float64).max() > 0.0
                                     or world.seen is not None)       # (a graph: what BSDF rays find is per ray)
    ctx.extra["emissive"] = bool(materials.emissive.any() or materials.graph_emits.any())
    # Shadow rays go on through surfaces: transparent ones, and objects hidden from shadow rays.
    # (and holdouts, objects or Holdout nodes, which the path tracer's loop handles, as the camera's paths through
    # transparent surfaces)
    # The media (core/volumes): inside closed meshes whose material has a Volume, and the world's; their rays go on
    # through the boundaries, and every stretch of a ray in a medium loses what Beer-Lambert says.
    groups = ctx.extra["light_groups"]
    media = volumes.Media.of(list(scene.materials) + [scene.default_material or Material()], world.volume, geometry,
                             None if groups is None else groups.instances)
    ctx.extra["media"] = media
    warnings.extend(note for note in (media.notes if media is not None else ()) if note not in warnings)
    if media is not None:                  # (where camera rays may start inside a mesh's medium)
        ctx.extra["media_bounds"] = rays_.media_bounds(geometry, media)
    if media is not None and groups is not None:      # (the group each medium's emission goes to: lightgroups.py)
        groups.media = groups.of_media(geometry, media)
    see_through = any(shader.may_let_light_through for shader in materials.shaders)
    ctx.extra["transparent"] = (see_through
                                or ctx.geometry.hides(HIDDEN_FROM_SHADOW | HOLDOUT) or bool(materials.holds_out.any())
                                or ctx.geometry.shadow_linked or any(map(lights_.linking.shadow_linked, lights))
                                or media is not None
                                # (on a transparent film, a camera path through a Ray Portal that escapes clears the
                                #  film: the direct tracer follows it as the path tracer with no bounces)
                                or settings.transparent_background
                                and any(has_node(shader, ("RAY_PORTAL",)) for shader in materials.shaders))
    # A BSSRDF is walked even with no bounces (Cycles counts no bounce for it): the direct tracer is then the path
    # tracer with none (integrators.for_render).
    ctx.extra["subsurface"] = walks_subsurface(scene)
    # (and where the camera sees a world that lights nothing through clear surfaces: a camera path's ray goes on)
    ctx.extra["bsdf_rays"] = (bool(ctx.extra["hittable"]) or world_lights or ctx.extra["emissive"]
                              or (media is not None and media.emits)
                              or (bool(world.camera) and not settings.transparent_background
                                  and bool(ctx.extra["transparent"])))
    # Where BSDF rays are traced: at every hit where emitters or the world light the scene (only BSDF rays
    # find a constant world, and MIS is what samples emitters well); where only lamps with extent do, at
    # glossy hits alone: a diffuse surface's light samples of a lamp need no help, so a BSDF ray there
    # would cost a ray and change little (the choice is made per hit from its closures: unbiased).
    ctx.extra["bsdf_everywhere"] = (world_lights or ctx.extra["emissive"] or emitters is not None
                                    or settings.light_sampling == "bsdf" or (media is not None and media.emits))
    background = np.asarray(world.color, np.float64)[:3] if world.camera else np.zeros(3)
    ctx.extra["world"] = background
    ctx.extra["camera"] = scene.camera.moved(geometry.origin)      # its rays come out camera-relative
    ctx.extra["background"] = np.array([0.0, 0.0, 0.0, escaping_alpha(media)] if settings.transparent_background
                                        else [*background, 1.0])
    forward = -np.asarray(scene.camera.matrix_world, np.float64)[:3, 2]
    ctx.extra["forward"] = forward / np.linalg.norm(forward)
    ctx.extra["camera_offset"] = geometry.origin - np.asarray(scene.camera.matrix_world, np.float64)[:3, 3]
    # Acne debug view: how far a blocker may rise above the plane a shadow ray leaves and still count
    # as lying in it (core/integrators/debug.py, self_intersections).
    ctx.extra["self_hit_distance"] = (debug.SELF_HIT_FRACTION * debug.scene_scale(geometry)
                                      if "acne" in settings.aux else 0.0)
    # Shadow catchers (core/integrators/catcher.py): the catcher-only scene their caught samples are followed in.
    ctx.extra["catcher"] = catcher_.catcher_context(ctx, warnings)
    return ctx


def world_aovs(world, layout, settings: RenderSettings):
    """The world's AOV Output nodes compiled for the render's shader AOVs (lights_.world_graph.compile_aovs), or None
    where escaping camera rays write none, as in Cycles: no AOV asked for or named, a world the camera does not see
    (its background shader is skipped), or a transparent film without the Environment pass (Cycles evaluates a
    transparent film's background for that pass alone: integrate_background's eval_background)."""
    if world is None or not world.aovs or not layout.aovs or not world.camera:
        return None
    if settings.transparent_background and not layout.has("environment"):
        return None
    return lights_.world_graph.compile_aovs(world.aovs, layout.aovs)


def has_node(shader, names: tuple) -> bool:
    """Whether a material's shader (its node list or node graph) has a shader node of one of `names` (a node
    class's name: "RAY_PORTAL", "HAIR", ...)."""
    entries = list(getattr(shader, "nodes", None) or ()) + list(getattr(shader, "graph", None) or ())
    return any(getattr(entry[0], "name", entry[0]) in names for entry in entries)


def sample_keys(pixels: np.ndarray, spp: int, first: Optional[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Return (pixel, sample) of a chunk's spp samples per pixel, pixel by pixel: two (p spp,) int64.

    Sample j of pixel k is number first[k] + j of that pixel's pattern (first None: 0).
    """
    pixel = np.repeat(pixels, spp)
    sample = np.tile(np.arange(spp, dtype=np.int64), len(pixels))
    if first is not None:
        sample += np.repeat(first, spp)
    return pixel, sample


def camera_rays(ctx: Context, s: RenderSettings, pixel: np.ndarray, sample: np.ndarray, spp: int):
    """Return the camera rays (core/camera Rays, camera-relative) of samples `sample` of pixels `pixel`:
    both (n,) int64; the positions in the pixel are the samples' jittered points (dimension 0 of the
    pattern), or without jitter the centres of a grid of spp cells, moved by the pixel filter
    (core/camera/filter.py: drawn from its density, as Cycles does); with motion blur each ray's time in the shutter
    (core/camera/motion.py, TIME_DIMENSION)."""
    W, H = s.width, s.height
    if s.jitter:
        offset = sampling.sample_2d(s.seed, pixel, sample, dimension=0)
    else:
        offset = sampling.stratum_centres(sample, spp)
    offset = s.filter.positions(offset)
    camera = ctx.extra["camera"]
    lens = (sampling.sample_2d(s.seed, pixel, sample, dimension=camera_.LENS_DIMENSION)
            if camera_.has_depth_of_field(camera) else None)       # (depth of field: each ray's point on the lens)
    time = None                                                     # (motion blur: each ray's time in the shutter)
    if camera.shutter is not None:
        u = sampling.sample_2d(s.seed, pixel, sample, dimension=motion.TIME_DIMENSION)[:, 0]
        time = motion.ray_times(camera.shutter, u, pixel // W, H)
    return camera_.generate_rays(camera, W, H, (pixel % W) + offset[:, 0], (pixel // W) + offset[:, 1],
                                 tuple(s.pixel_aspect), lens, time)


def light_pass_images(film: Film, first_hit: dict, wanted) -> dict:
    """Return the light passes `wanted` names, from the film's sums and the colour passes in `first_hit` (name ->
    (H, W, 3)): name -> (H, W, 3) float32 (core/integrators/lightpasses.py divide_by_color)."""
    H, W = film.height, film.width
    sums = film.aux[lightpasses.FILM_BUFFER].reshape(H, W, -1)
    return lightpasses.divide_by_color(sums, film.noise.count.reshape(H, W).astype(np.float64), first_hit, wanted)


def rgb_means(film: Film, buffer: str, names) -> dict:
    """Return the film's sums `buffer` (3 channels per name) as images: name -> (H, W, 3) float32, each pixel's mean
    over its samples (0 where it has none). The denoising features and the light groups come out this way."""
    H, W = film.height, film.width
    count = film.noise.count.reshape(H, W, 1).astype(np.float64)
    sums = film.aux[buffer].reshape(H, W, -1)
    mean = np.divide(sums, count, out=np.zeros_like(sums), where=count > 0)
    return {name: np.ascontiguousarray(mean[..., 3 * k:3 * k + 3], np.float32) for k, name in enumerate(names)}


def reference_chunk(ctx: Context, pixels: np.ndarray, spp: int, seed: int,
                    first: Optional[np.ndarray] = None, recorder: Optional[Recorder] = None) -> ChunkSums:
    """Render `spp` samples in each of `pixels` with the Python reference: samples first .. first + spp - 1.

    pixels: (p,) int64 flat pixel indices; first: (p,) int64 samples each pixel already has (None: 0).
    recorder: listens to the integrator (the debug buffers make their own when asked for).
    """
    s = dataclasses.replace(ctx.settings, samples=spp, seed=seed)
    p = len(pixels)
    # a. Sample positions inside each pixel: the next spp points of its progressive pattern
    #    (core/sampling), or without jitter the centres of a grid of spp cells; their camera rays,
    #    camera-relative (the camera moved by the geometry's origin).
    pixel, sample = sample_keys(pixels, spp, first)
    rays = camera_rays(ctx, s, pixel, sample, spp)
    # As in Cycles: outside a fisheye's image circle the film is opaque black; camera rays that miss
    # show the world, or leave the film clear (alpha 0, premultiplied RGB 0) when transparent.
    n = len(pixel)
    rgba = np.zeros((n, 4))
    rgba[:, 3] = 1.0
    rgba[rays.valid] = ctx.extra["background"]
    traced = np.flatnonzero(rays.valid)
    # b. The integrator: the light each traced ray brings back.
    if recorder is None and s.aux:
        recorder = debug.DebugRecorder(s.aux, len(ctx.lights), ctx.geometry, ctx.extra["camera_offset"],
                                       ctx.extra["forward"], ctx.extra["self_hit_distance"])
    integrator = for_render(ctx)
    start = time.perf_counter()
    moving = {} if not ctx.geometry.tracer.moving else dict(times=rays.time[traced])   # (object motion blur)
    found = integrator.radiance(dataclasses.replace(ctx, settings=s), vectors.gather(rays.origins, traced),
                                vectors.gather(rays.directions, traced), rays.t_max[traced], pixel[traced],
                                sample[traced], recorder or Recorder(), **moving)
    shading_seconds = time.perf_counter() - start
    hit = traced[found.hit]
    rgba[traced, :3] = found.L                   # what each ray brought back (misses: the world, lamps)
    rgba[hit, 3] = 1.0
    if found.holdout is not None:
        rgba[traced, 3] -= found.holdout         # the holes holdout objects make (Cycles' holdout transparency)
    caught = None
    if ctx.extra.get("catcher") is not None:     # shadow catchers: the matte and the catcher-only light (catcher.py)
        found = found._replace(light=None if found.light is None else np.array(found.light),
                               groups=None if found.groups is None else np.array(found.groups))
        caught = catcher_.sample_rows(dataclasses.replace(ctx, settings=s), rgba, traced,
                                      vectors.gather(rays.origins, traced), vectors.gather(rays.directions, traced),
                                      rays.t_max[traced], pixel[traced], sample[traced], found.light, found.groups)
    # c. Each pixel's sums (the film divides by the count); a NaN or infinite sample goes in as 0, counted.
    nonfinite = finite_samples(rgba, p, spp)
    per_pixel, squares = pixel_sums(rgba, p, spp, s.adaptive)
    hits = np.bincount(hit // spp, minlength=p)
    aux = {}
    if isinstance(recorder, debug.DebugRecorder):
        traced_per_pixel = rays.valid.reshape(p, spp).sum(axis=1).astype(np.float64)
        aux = recorder.pixel_sums(hit // spp, traced_per_pixel)
        aux.update(debug.camera_ray_sums(s.aux, rays, p, spp))
    # The light passes', denoising features' and light groups' sums (lightpasses.py, features.py, lightgroups.py),
    # each sample's channel that is NaN or beyond the film's range as 0, as in the image.
    data = found.passes
    for name, values in ((lightpasses.FILM_BUFFER, found.light), (features.FILM_BUFFER, found.features),
                         (lightgroups.FILM_BUFFER, found.groups),
                         (passes_.FILM_BUFFER, data.values if data is not None and data.layout.sums else None)):
        if values is None:
            continue
        values = values.reshape(len(traced), -1)
        per_sample = np.zeros((n, values.shape[1]))
        per_sample[traced] = np.where(np.abs(values) <= FILM_MAX, values, 0.0)
        aux[name] = per_sample.reshape(p, spp, -1).sum(axis=1)
    if caught is not None:
        aux[catcher_.FILM_BUFFER] = np.where(np.abs(caught) <= FILM_MAX, caught, 0.0).reshape(p, spp, -1).sum(axis=1)
    if data is not None and data.layout.mattes:
        aux[passes_.MATTE_BUFFER] = matte_slots(data, traced // spp, p)
    return ChunkSums(per_pixel, squares, hits, aux, len(traced), found.shadow_rays, spp,
                     shading_seconds=shading_seconds, nonfinite=nonfinite)


def matte_slots(data, pixel_of: np.ndarray, p: int) -> np.ndarray:
    """The Cryptomatte slots (p, kinds slots 2) float64 of a chunk's p pixels from its camera rays' entries
    (passes.DataPasses.mattes; pixel_of (n,) int64 each camera ray's pixel), in the order each pixel's samples met
    them: sample by sample, along each sample's path (cryptomatte.fill_slots)."""
    layout = data.layout
    out = np.zeros((p, len(layout.mattes), layout.slots, 2))
    if not data.mattes:
        return out.reshape(p, -1)
    owner = np.concatenate([entry[0] for entry in data.mattes])
    vertex = np.concatenate([np.full(len(entry[0]), entry[1]) for entry in data.mattes])
    ids = np.concatenate([entry[2] for entry in data.mattes])
    weight = np.concatenate([entry[3] for entry in data.mattes])
    order = np.lexsort((vertex, owner))
    for k in range(len(layout.mattes)):
        out[:, k] = cryptomatte.fill_slots(pixel_of[owner[order]], ids[order, k].astype(np.float32), weight[order], p,
                                           layout.slots)
    return out.reshape(p, -1)


def timed_reference_chunk(ctx: Context, pixels: np.ndarray, spp: int, seed: int,
                          first: Optional[np.ndarray] = None) -> ChunkSums:
    """`reference_chunk` in runs of TIME_TILE pixels, each run timed: its result plus the "time" buffer,
    each run's wall time shared out to its pixels by their rays (debug.share_time)."""
    parts = []
    for i in range(0, len(pixels), TIME_TILE):
        start = time.perf_counter()
        part = reference_chunk(ctx, pixels[i:i + TIME_TILE], spp, seed, None if first is None else first[i:i + TIME_TILE])
        seconds = time.perf_counter() - start
        part.aux["time"] = debug.share_time(seconds, part.aux["rays"][:, 0])[:, None]
        if "rays" not in ctx.settings.aux:
            del part.aux["rays"]
        parts.append(part)
    aux = {name: np.concatenate([part.aux[name] for part in parts]) for name in parts[0].aux}
    return ChunkSums(np.concatenate([part.rgba for part in parts]), np.concatenate([part.squares for part in parts]),
                     np.concatenate([part.hits for part in parts]), aux, sum(part.primary for part in parts),
                     sum(part.shadow for part in parts), spp,
                     shading_seconds=sum(part.shading_seconds for part in parts),
                     nonfinite=np.concatenate([part.nonfinite for part in parts]))


# The most samples a chunk of the Python reference holds: one step of its vertex loop over them (numpy over every
# ray at once) takes a few hundredths of a second on one core, so a cancel, checked between steps, is answered
# well within half a second, also on a loaded machine (tests/test_cancel.py: 0.03-0.14 s with both cores busy
# elsewhere). The compiled chunk checks before each block of 64 samples instead.
REFERENCE_CHUNK = 1 << 14

# How often the render loop asks cancel() while chunks run (a cancel is answered within this and a block's time).
CANCEL_POLL_SECONDS = 0.05


def _run_chunks(pool, in_flight: int, chunks: list, work: Callable, store: Callable,
                cancel: Optional[Callable[[], bool]], progress: Callable[[float], None],
                stats: RenderStats, start: float, stop: Optional[StopFlag] = None) -> bool:
    """Run work(chunk) for every chunk on the pool and store(chunk, result) each; return whether cancelled.

    At most `in_flight` chunks are submitted at once: more than the pool's workers keeps them busy
    while results are stored, fewer runs a pass on fewer threads; and cancelling never waits for a
    long queue. store, progress and cancel are called from this (the calling) thread only; cancel every
    CANCEL_POLL_SECONDS. When it says stop, `stop` is set (the running chunks stop part way, raising
    Cancelled, and are not stored) and this returns once they have.
    """
    queue = iter(chunks)
    running = {}

    def refill():
        for chunk in queue:
            running[pool.submit(work, chunk)] = chunk
            if len(running) >= in_flight:
                break

    refill()
    done = 0
    while running:
        finished, _ = wait(running, timeout=CANCEL_POLL_SECONDS, return_when=FIRST_COMPLETED)
        for future in finished:
            chunk = running.pop(future)
            try:
                result = future.result()
            except Cancelled:
                continue
            store(chunk, result)
            done += 1
        if (cancel is not None and cancel()) or (stop is not None and stop):
            if stop is not None:
                stop.set()
            for future in running:
                future.cancel()
            wait(running)                       # (the running ones stop at their next check)
            return True
        if finished:
            refill()
            stats.seconds = time.perf_counter() - start
            progress(done / max(1, len(chunks)))
    return False


# Below this many samples per thread, another thread costs more than it brings. Embree releases the
# GIL for whole batches and numpy inside each operation, but the Python between operations holds it,
# and on short arrays the handovers dominate. Measured on a 2-core machine (adaptive renders at 128
# samples, median of 7): light_area took 0.73 s with 2^14, 0.80 s with 2^15 and 0.90 s with 2^17,
# against 0.87 s for splitting every pass into two chunks per thread, which also burnt 25% more CPU.
PARALLEL_MIN_SAMPLES = 1 << 14

# From this many pixels on, the noise test between adaptive passes is shared out between the threads
# (adaptive.unconverged_compiled's bands). Measured on a 2-core machine: 3840 x 2160 took 250-310 ms a
# pass instead of 330-360, 1920 x 1080 58-71 ms instead of 70-75; at 320 x 240 the bands cost more
# than they bring (4.5 ms against 3), as waking a worker thread takes up to a few ms.
BANDED_PIXELS = 1 << 21


def _plan_chunks(pixels: int, spp: int, chunk_size: int, threads: int) -> tuple[int, int]:
    """Return (pixels per chunk, threads to use) for a pass over `pixels` pixels of `spp` samples.

    A chunk holds at most chunk_size samples (memory stays bounded). A pass too small to give every
    thread PARALLEL_MIN_SAMPLES runs on fewer threads (adaptive sampling's later passes often on one);
    otherwise it is cut into one chunk per thread at least, so that every core works.
    """
    if pixels <= 0:
        return 1, 1                       # nothing to render (an empty region): no chunks at all
    workers = max(1, min(threads, (pixels * spp) // PARALLEL_MIN_SAMPLES))
    # As few chunks as chunk_size allows, rounded up to a multiple of the workers, all of one size:
    # so that every worker gets the same share.
    chunks = -(-pixels * spp // max(1, chunk_size))
    chunks = workers * -(-chunks // workers)
    return max(1, -(-pixels // chunks)), workers


def _usable_cores() -> int:
    """Return the number of cores this process may run on (its CPU affinity, where the OS tells)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:              # macOS and Windows have no sched_getaffinity
        return os.cpu_count() or 1


def compensates_world(settings: RenderSettings, world) -> bool:
    """Whether the world's light samples go by its map less its mean (lights/world.py compensated_map): where every
    light sample of it has a BSDF ray as its MIS partner that sees the same light (the direct and path tracers with
    MIS and the lecture's defaults), and where the split between the two does not change the image (no clamping;
    no Fast GI, whose escaping rays see the world dimmer than its light samples do; the world's Shadows on and no
    Max Bounces of its own, vertex.mis_count: as in Cycles, the split decides the image there)."""
    return (settings.integrator in ("direct", "path") and settings.light_sampling == "mis"
            and world.cast_shadow and world.max_bounces >= 1024
            and settings.is_lecture_default() and not settings.sample_clamp_direct
            and not settings.sample_clamp_indirect and not (settings.ao_bounces and settings.ao_factor))


def volume_reason(ctx: Context, warnings: list) -> str:
    """Why a scene with media takes the Python reference ('' where the compiled kernel renders it, and without media).
    The compiled kernel renders homogeneous media (core/volumes/media.c, core/integrators/volume.c), with any Volume
    Bounces (volume.c volume_chain), and marches heterogeneous ones (core/volumes/field.c), any number of them (its
    volume stack is sparse); that a ray is in at most Media.room of them at once (Cycles' limit, in both kernels) is
    said once in `warnings` where a scene has more, and so is that Whitted's tracer, which renders media on the Python
    reference, scatters once (no Volume Bounces). With Fast GI (Replace) and an object's own AO Distance, that the
    phase rays of scattering points look the render's is said once too. (prepare says which light group the emission
    of overlapping media of different groups goes to.)"""
    media = ctx.extra.get("media")
    if media is None:
        return ""
    s = ctx.settings
    if s.integrator == "whitted":
        # (Whitted's tracer renders media on the Python reference: Beer-Lambert, emission, single scattering)
        if s.volume_bounces > 0 and media.scatters:
            note = (f"volumes: Whitted's tracer scatters light in media once (it has no diffuse bounces, so no volume "
                    f"bounces either): Volume Bounces {s.volume_bounces} renders as 0")
            if note not in warnings:
                warnings.append(note)
        return ""
    if media.scatters and s.denoising_features:
        # (features.in_media: Cycles' rule in expectation, with its unguided odds of passing a medium)
        note = ("volumes: the Denoising Albedo and Normal take scattering media as Cycles does with its unguided odds "
                "of passing them (Cycles 5.0 guides that choice along camera rays: a few per cent apart)"
                + ("; heterogeneous media through their march, each piece at its midpoint's coefficients (the image "
                   "corrects the march by ratio tracking)" if media.heterogeneous else ""))
        if note not in warnings:
            warnings.append(note)
    if (media.scatters and s.integrator == "path" and s.ao_bounces and s.ao_factor
            and len(getattr(ctx.geometry, "instance_ao_distance", ())) and ctx.geometry.instance_ao_distance.any()):
        # (Fast GI's phase rays: volume.scattered_light looks the render's AO Distance far)
        note = ("Fast GI (Replace): the rays that leave a point where a path scattered in a medium look the render's "
                f"AO Distance ({s.ao_distance:g}) far; Cycles takes the object's own AO Distance (Object > Visibility) "
                "of the first medium in the ray's volume stack where that object has one")
        if note not in warnings:
            warnings.append(note)
    if len(media.g) > media.room:
        # (both kernels' stacks are Cycles': any number of media, Media.room of them at once along a ray)
        kept = int((media.keyed >= 0).sum())
        note = (f"volumes: {len(media.g)} media"
                + (f" ({len(media.g) - int((media.column >= 0).sum())} of them kept per object for {kept} "
                   f"material{'s' if kept > 1 else ''}: a volume that reads Object Info, a field on objects of other "
                   "placements or texture spaces, on objects that overlap, or emitting into several light "
                   "groups)" if kept else "")
                + f"; a ray is in at most {media.room} at once and leaves out a further one it enters, as Cycles' "
                  f"volume stack does (MAX_VOLUME_STACK_SIZE 32 less its end marker"
                  + (" and the world's volume" if media.room < int(volumes.MAX_MEDIA) else "") + ")")
        if note not in warnings:
            warnings.append(note)
    return ""


def object_blur_reason(scene: Scene, settings: RenderSettings) -> str:
    """Why a render of `scene` with motion blur places its moving and deforming objects (Instance.motion,
    Instance.deformation) still, or '' where the integrator places them at each ray's time (every ray of a path, as
    Cycles: build_geometry's motion_blur)."""
    if not any(geometry_.moves(instance) or geometry_.deforms(instance, scene.meshes[instance.mesh])
               for instance in scene.instances):
        return "no object moves"
    if settings.integrator not in ("path", "direct"):
        return f"the {settings.integrator} integrator does not carry the rays' times"
    world = scene.the_world()
    if any(getattr(m, "volume", None) for m in scene.materials) or getattr(world, "volume", None):
        return "volumes do not carry the rays' times"
    if walks_subsurface(scene):
        return "subsurface walks do not carry the rays' times"
    if any(instance.is_shadow_catcher for instance in scene.instances):
        return "shadow catchers do not carry the rays' times"
    if settings.aux:
        return "debug buffers do not carry the rays' times"
    return ""


def escaping_alpha(media) -> float:
    """The film's alpha where a camera ray misses every surface on a transparent film: 1 - the mean over channels of
    the world's medium's transmittance to infinity (0 where its sigma_t > 0, 1 where it is 0), as Cycles makes a
    transparent background's alpha 1 - mean(throughput) with the world's volume in the throughput; 1 with a
    heterogeneous world medium (one that is not 0 where rays leave its box takes all light to infinity: media.py
    world_bounds)."""
    if media is None:
        return 0.0
    if getattr(media, "world_field", None) is not None:
        return 1.0
    return float(1.0 - np.mean(np.asarray(media.world.sigma_t, np.float64) <= 0.0))


def walks_subsurface(scene: Scene) -> bool:
    """Whether a material of `scene` has a Subsurface Scattering node, or a Principled BSDF whose Subsurface Weight
    is linked or above 0: a BSSRDF closure the path tracer walks (core/integrators/subsurface.py)."""
    for material in scene.materials:
        for node in material.nodes or ():
            if node[0] == "SUBSURFACE":
                return True
            value = node[2].get("subsurface", 0.0) if node[0] == "PRINCIPLED" else 0.0
            if not isinstance(value, (int, float, np.floating, np.ndarray)) or np.any(np.asarray(value) > 0.0):
                return True
    return False


def subsurface_warnings(scene: Scene, settings: RenderSettings, warnings: list) -> None:
    """Add to `warnings` what the subsurface walk of `scene` leaves out (both kernels walk BSSRDFs the same way,
    core/integrators/subsurface.py and subsurface.c; the direct tracer as Cycles does at Max Bounces 0): Whitted's
    tracer gives it no light. (A walk's exit takes the media across from its entry, as Cycles: subsurface.media_across.)"""
    if not walks_subsurface(scene):
        return
    if settings.integrator == "whitted":
        note = ("subsurface: Whitted's tracer does not walk subsurface scattering; the Subsurface Weight's share of "
                "the surface gets no light (the path and direct tracers walk it, as Cycles)")
        if note not in warnings:
            warnings.append(note)


def render(scene: Scene, settings: RenderSettings,
           progress: Optional[Callable[[float, RenderStats], None]] = None,
           cancel: Optional[Callable[[], bool]] = None,
           geometry: Optional[WorldGeometry] = None, keep_memory: bool = False) -> RenderResult:
    """Render `scene` and return a float32 (H, W, 4) scene-linear RGBA image.

    progress(fraction, stats) is called after each chunk; cancel() is polled between chunks, and a
    True answer stops the render promptly (the result then holds the chunks finished so far and
    cancelled=True). Both are called from the calling thread. A prebuilt `geometry` (same camera
    origin) skips the BVH build. keep_memory: leave the freed buffers with the process for the next
    render (core/memory.py); the caller then calls memory.release() when no render follows.
    """
    start = time.perf_counter()
    stats = RenderStats()
    # 1. What every chunk reads.
    ctx = prepare(scene, settings, geometry, stats.warnings)
    geometry = ctx.geometry
    stats.geometry_seconds = time.perf_counter() - start
    stats.triangles = geometry.triangle_count
    W, H = settings.width, settings.height
    volumes_because = volume_reason(ctx, stats.warnings)
    subsurface_warnings(scene, settings, stats.warnings)
    numpy_because = (why_not(settings) or volumes_because
                     or ("" if Compiled.applies(ctx) else "Embree's packet queries are unavailable"))
    compiled = Compiled(ctx, ctx.extra["background"]) if not numpy_because else None
    stats.kernels = "compiled" if compiled else f"numpy ({numpy_because})"
    stats.warnings.extend(note for note in mnee_.notes(ctx) if note not in stats.warnings)
    # 2. The passes, and the pixels to render (wholly outside a fisheye's image circle: opaque black).
    passes = (adaptive.pass_sizes(settings.samples, settings.adaptive_min_samples) if settings.adaptive
              else [settings.samples])
    threshold = settings.adaptive_threshold or adaptive.automatic_threshold(settings.samples)
    film_sums = debug.aux_channels(settings.aux, len(ctx.lights))
    light_passes = lightpasses.wanted(settings.passes)
    if light_passes:
        film_sums[lightpasses.FILM_BUFFER] = lightpasses.FILM_CHANNELS
    if settings.light_groups:
        film_sums[lightgroups.FILM_BUFFER] = 3 * len(settings.light_groups)
    if settings.denoising_features:
        film_sums[features.FILM_BUFFER] = features.FILM_CHANNELS
    layout = ctx.extra["pass_layout"]
    stats.first_hit = tuple(layout.names + layout.mattes)
    merge = {}
    if layout.sums:
        film_sums[passes_.FILM_BUFFER] = layout.channels
    if layout.mattes:               # (Cryptomatte's slots are not summed: a chunk's go into the pixel's in order)
        film_sums[passes_.MATTE_BUFFER] = len(layout.mattes) * layout.slots * 2
        merge[passes_.MATTE_BUFFER] = layout.merge_mattes
    if ctx.extra["catcher"] is not None:
        film_sums[catcher_.FILM_BUFFER] = catcher_.FILM_CHANNELS
    film = Film(W, H, film_sums, compiled=compiled is not None, keep_estimates=len(passes) > 1, merge=merge)
    region = region_pixels(settings)
    outside = camera_.outside_image_circle(scene.camera, W, H, region, tuple(settings.pixel_aspect),
                                           settings.filter.reach)
    if outside.any():
        film.noise.total[region[outside], 3] = 1.0
        region = region[~outside]
    threads = settings.threads if settings.threads > 0 else _usable_cores()
    # 3. The chunk: compiled where it applies, else the reference (timed per tile for the "time" buffer).
    if compiled is not None:
        chunk = compiled.chunk
    elif "time" in settings.aux:
        chunk = lambda pixels, spp, seed, first: timed_reference_chunk(ctx, pixels, spp, seed, first)
    else:
        chunk = lambda pixels, spp, seed, first: reference_chunk(ctx, pixels, spp, seed, first)
    tracer = geometry.tracer
    queried = (tracer.intersect_seconds, tracer.occluded_seconds)
    cancelled = False
    stop = ctx.extra["stop"]
    with memory.temporaries_from_the_heap(keep_memory), ThreadPoolExecutor(max_workers=threads) as pool:
        pixels = region
        for index, spp in enumerate(passes):
            # a. Which pixels still need samples: all of them at first, then the noisy ones.
            if index > 0:
                pixels = unconverged(region, film, threshold, passes[0], pool, threads)
                if len(pixels) == 0:
                    break
            # b. A pass of `spp` more samples over them, chunk by chunk: each pixel continues its own
            #    progressive pattern where it left off, so all its passes together stay stratified.
            last = index == len(passes) - 1
            chunk_size = settings.chunk_size if compiled is not None else min(settings.chunk_size, REFERENCE_CHUNK)
            per_chunk, workers = _plan_chunks(len(pixels), spp, chunk_size, threads)
            done_before = film.noise.count[pixels]               # samples each pixel has, before this pass
            chunks = [(pixels[i:i + per_chunk], done_before[i:i + per_chunk])
                      for i in range(0, len(pixels), per_chunk)]

            def work(c, spp=spp, last=last):
                # Each worker adds its chunk's sums itself (chunks own their pixels): no noise
                # estimates after the last pass, as no noise test follows.
                sums = chunk(c[0], spp, settings.seed, c[1])
                film.add(c[0], sums, estimates=not last)
                return sums

            def store(c, sums):
                stats.primary_rays += sums.primary
                stats.shadow_rays += sums.shadow
                stats.shading_seconds += sums.shading_seconds

            in_flight = 2 * threads if workers == threads else workers
            cancelled = _run_chunks(pool, in_flight, chunks, work, store, cancel,
                                    lambda f: progress((index + f) / len(passes), stats) if progress else None,
                                    stats, start, stop)
            stats.passes += 1
            if cancelled:
                break
    if progress is not None and not cancelled:
        progress(1.0, stats)
    # 4. The image: each pixel's mean over all its samples; debug buffers as debug.aux_images makes them.
    image = film.image()
    note = film.nonfinite_note()
    if note is not None:
        stats.warnings.append(note)
    aux = debug.aux_images(film.aux, film.hits, settings.aux, H, W)
    if ctx.extra["catcher"] is not None:         # shadow catchers: Combined as the matte, the Shadow Catcher pass
        image, shadow = catcher_.images(film.aux[catcher_.FILM_BUFFER].reshape(H, W, -1), image,
                                        film.noise.count.reshape(H, W), settings.transparent_background,
                                        settings.shadow_catcher_pass)
        if settings.shadow_catcher_pass:
            aux[catcher_.PASS_BUFFER] = shadow
    elif settings.shadow_catcher_pass:           # (no catcher: the pass is 1 everywhere, as Cycles writes it)
        aux[catcher_.PASS_BUFFER] = np.ones((H, W, 3), np.float32)
    # The first-hit passes (passes.py), and the light passes divided by their colour passes (lightpasses.py).
    # (The light passes alone, the volume ones having no colour pass, leave the layout empty: they are written all the
    # same.)
    first_hit = passes_.images(film.aux, film.noise.count, layout, settings.cryptomatte_depth, H, W) if layout else {}
    if light_passes:
        first_hit.update(light_pass_images(film, first_hit, settings.passes))
    aux.update({name: image for name, image in first_hit.items()
                if name in settings.passes or name.startswith(passes_.AOV_PREFIX)})
    if settings.light_groups:
        aux.update(rgb_means(film, lightgroups.FILM_BUFFER,
                             [lightgroups.BUFFER_PREFIX + name for name in settings.light_groups]))
    if settings.denoising_features:
        aux.update(rgb_means(film, features.FILM_BUFFER, features.FEATURE_BUFFERS))
    if settings.exposure != 1.0:
        image, aux = expose(image, aux, settings.exposure)
    stats.samples_per_pixel = film.noise.count.reshape(H, W).astype(np.int32)
    stats.seconds = time.perf_counter() - start
    # Embree's share: the shadow rays' queries ran inside shading, so they move from there to trace.
    shadow_query = tracer.occluded_seconds - queried[1]
    stats.trace_seconds = tracer.intersect_seconds - queried[0] + shadow_query
    stats.shading_seconds -= shadow_query
    return RenderResult(image, aux, stats, cancelled, [light.name for light in ctx.lights])


# The passes of light Film Exposure scales, beside Combined (Cycles' pass_info.use_exposure): the first-hit
# passes of emitted and world light, the light passes and the light groups.
EXPOSED_PASSES = ("emission", "environment", *lightpasses.LIGHT_PASSES)


def expose(image: np.ndarray, aux: dict, exposure: float) -> tuple:
    """Cycles' Film Exposure: Combined's colour (not its alpha) and the passes of light (EXPOSED_PASSES, the light
    groups) times `exposure`, the rest as they are. image (H, W, 4) float32, aux name -> (H, W, c) -> (image, aux)."""
    image = image.copy()
    image[..., :3] *= np.float32(exposure)
    exposed = {name: buffer * np.float32(exposure) for name, buffer in aux.items()
               if name in EXPOSED_PASSES or name.startswith(lightgroups.BUFFER_PREFIX)}
    return image, {**aux, **exposed}


def unconverged(region: np.ndarray, film: Film, threshold: float, first: int, pool, threads: int) -> np.ndarray:
    """Return the pixels of `region` that need another pass (core/film/adaptive.py), in C where it is loaded."""
    if not film.compiled:
        return adaptive.unconverged(region, film.noise, threshold, film.width, film.height, first)
    bands = threads if film.width * film.height >= BANDED_PIXELS else 1
    return adaptive.unconverged_compiled(region, film.noise, threshold, film.width, film.height, first,
                                         pool=pool, bands=bands, estimates=film.estimates)
