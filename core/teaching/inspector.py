"""The ray inspector: every number the renderer computes for one pixel ("use that debug output").

`inspect_pixel` runs the renderer's own integrator (core/integrators, the Python reference) on the
ray through a pixel's centre, with a Recorder that keeps every value it decides on the way. The
inspector computes nothing of its own:

1. the primary ray (core/camera) and its nearest hit (t, the point I, triangle, barycentrics u, v,
   object);
2. the face normal Ng and the shading normal N, both turned towards the viewer
   (core/geometry/surface.py);
3. per light: the direction L and distance r to the light (core/lights), N.L and Ng.L, the
   distance attenuation 1/r^2, whether a shadow ray was cast (not when the light is behind N or
   behind the face), whether it was occluded (core/integrators/shadows.py), and the light's share
   of the pixel: f * E_normal * max(N.L, 0) * visibility (f = albedo / pi for a diffuse surface).

Lights with extent (a point or spot with a radius, a sun with an angle, an
area light) are sampled by the renderer at many random points; the inspector
takes ONE sample, at the light's centre (`centre_numbers`), so its shadow ray
is the one a student would draw. Its contribution is then that one sample's
estimate, not the render's average over the light. Lights without extent are
exact, and for them the contributions sum to the rendered pixel of a 1-sample,
unjittered render.

All positions in a PixelRecord are world space (the camera-relative origin is
added back); never imports bpy.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Optional

import numpy as np

from .. import render as render_
from ..camera import camera as camera_
from ..geometry.geometry import WorldGeometry
from ..integrators import Recorder, for_render
from ..sampling import sobol as sampling
from ..scene import RenderSettings, Scene

# Why a shadow ray was or was not cast (LightRecord.reason).
CAST = "cast"
BEHIND_N = "light behind N (N.L <= 0)"
BEHIND_FACE = "light behind the face (Ng.L <= 0)"
NO_LIGHT = "the light sends nothing here"
NO_SHADOW = "the lamp casts no shadow (Cast Shadow off): nothing can block it"
SKIPPED = "the light skips this point (Light Linking: it does not light this object; or an emitter's own triangle)"


class LightRecord(NamedTuple):
    """What one light does at the inspected hit point (one sample; world space).

    name:            the light's name
    kind:            "POINT" | "SPOT" | "SUN" | "AREA"
    sampled:         True for lights with extent, inspected at one sample at their centre
    L:               (3,) float64 unit direction from I towards the light (sample)
    distance:        r, the distance from I to the light point; inf for the sun
    light_point:     (3,) float64 the light point the shadow ray aims at; None for the sun
    n_dot_l:         N.L with the shading normal (not clamped)
    ng_dot_l:        Ng.L with the face normal (not clamped)
    inverse_square:  1 / r^2 for point, spot and area lights; None for the sun
    irradiance:      (3,) float64 E_normal, irradiance at normal incidence (W/m^2, RGB)
    cast:            whether a shadow ray was traced
    reason:          why it was or was not cast (CAST, BEHIND_N, BEHIND_FACE, NO_LIGHT, NO_SHADOW, SKIPPED)
    occluded:        whether the shadow ray was blocked; None when none was cast
    shadow_origin:   (3,) float64 the shadow ray's origin (offset off the surface); None when not cast
    shadow_end:      (3,) float64 where the shadow ray stops (origin + t_max D); None when not cast
                     (for the sun it is the origin + t_max D with t_max = inf, so it is not finite)
    shadow_t_max:    the shadow ray's t_max; None when not cast
    contribution:    (3,) float64 f cos * E_normal * visibility * mis_weight (radiance, RGB; f cos =
                     albedo / pi N.L on a diffuse surface)
    pdf:             the solid-angle pdf of the light sample's direction (inf for a light without extent)
    mis_weight:      its multiple-importance weight against BSDF sampling (1 where no BSDF ray can find it)
    """

    name: str
    kind: str
    sampled: bool
    L: np.ndarray
    distance: float
    light_point: Optional[np.ndarray]
    n_dot_l: float
    ng_dot_l: float
    inverse_square: Optional[float]
    irradiance: np.ndarray
    cast: bool
    reason: str
    occluded: Optional[bool]
    shadow_origin: Optional[np.ndarray]
    shadow_end: Optional[np.ndarray]
    shadow_t_max: Optional[float]
    contribution: np.ndarray
    pdf: float = math.inf
    mis_weight: float = 1.0


class TextureRecord(NamedTuple):
    """One image texture the hit's material read: image name, where it looked ((x, y) in the image's 0..1
    square, after Mapping), its interpolation and extension (textures.INTERPOLATIONS, EXTENSIONS codes), and
    the RGBA (4,) float64 it got (linear: sRGB images decoded)."""

    image: str
    x: float
    y: float
    interpolation: int
    extension: int
    rgba: np.ndarray


class ClosureRecord(NamedTuple):
    """One closure of the hit's material: the BSDF's name, its weight (3,) (the colour it scatters with), its
    sampling weight (how often one-sample MIS picks it), its normal (3,), and alpha (roughness^2) where the
    BSDF has one (None for Lambert, mirror, smooth glass)."""

    bsdf: str
    weight: np.ndarray
    sample_weight: float
    N: np.ndarray
    alpha: Optional[float]


class MaterialRecord(NamedTuple):
    """What the hit's material reads and makes (core/materials): its name, the active UV map's (u, v) at the
    hit (None without one), the tangent frame (T, B, N) a Normal Map reads (None where no material asks for
    tangents), the image texels its node graph looked up, its closures, and what each of its nodes computed at the
    hit (NodeValue, in the order the graph needs them)."""

    name: str
    uv: Optional[np.ndarray]
    tangent_frame: Optional[tuple]
    textures: tuple
    closures: tuple
    nodes: tuple = ()


class NodeValue(NamedTuple):
    """One output of a node of the hit's material, as the renderer's graph (core/materials/graph.py run) computed
    it at the hit: the node's name, the output socket's name, its value (w,) float64 (1: a float, 3: a colour or
    vector) and its type ("float", "color", "vector")."""

    node: str
    output: str
    value: np.ndarray
    kind: str


class ScatterRecord(NamedTuple):
    """A point where a ray through a medium scatters light towards its start (core/integrators/volume.py): kind
    "free flight" (its distance drawn from the transmittance) or "equi-angular" (drawn for a lamp, lit by it alone),
    P (3,) float64 world space."""

    kind: str
    P: np.ndarray


class PixelRecord(NamedTuple):
    """Everything the renderer computes for the ray through one pixel's centre (world space).

    x, y:           the pixel, row 0 at the top (core/render/__init__.py's convention)
    camera_point:   (3,) float64 the camera's position (the eye)
    origin:         (3,) float64 the primary ray's origin (on the near clip plane)
    direction:      (3,) float64 its unit direction D
    valid:          False outside a fisheye's image circle (no ray is traced; the pixel is black)
    hit:            whether the ray hit a triangle
    t:              distance from origin to I along D; inf when missed
    I:              (3,) float64 the hit point; None when missed
    Ng:             (3,) float64 unit face normal, facing the viewer; None when missed
    N:              (3,) float64 unit shading normal (interpolated on smooth triangles); None when missed
    smooth:         whether N was interpolated from the vertex normals
    u, v:           barycentric coordinates: I = (1-u-v) V0 + u V1 + v V2
    triangle:       index of the hit triangle in the traced geometry; -1 when missed
    object_name:    name of the object (Scene.instances[...].name) the triangle belongs to; "" when missed
    albedo:         (3,) float64 the material's colour (its closures' weights); None when missed
    shadow_method:  "robust" or "epsilon", as in the settings
    lights:         tuple of LightRecord, one per light that sends light (as the renderer uses them)
    radiance:       (3,) float64 the pixel's colour from this one ray: on a hit, the light the surface emits,
                    the lights' contributions and what the BSDF-sampled direction found; the world colour on
                    a miss (black when the film is transparent or outside a fisheye)
    bsdf_sample:    (wi (3,), pdf, the light (3,) it found) of the direction sampled from the hit's closures,
                    or None when none was traced (the scene has no light a BSDF ray can find)
    emission:       (3,) float64 the light the hit surface emits itself; None when missed
    material:       MaterialRecord: the hit's material inputs (UV, tangent frame, texels) and closures; None
                    when missed
    scattering:     ScatterRecord per point where a medium scattered light towards the ray (camera ray and path
                    alike, in the order they were chosen), world space
    lens:           (2,) float64 with depth of field, the ray's point on the aperture (camera-local x right, y
                    up, scene units: sample 0's lens numbers, as the render draws them); the ray leaves from there
                    towards the focal plane. None for a pinhole
    warnings:       notes about the scene (lights skipped, geometry dropped)
    """

    x: int
    y: int
    camera_point: np.ndarray
    origin: np.ndarray
    direction: np.ndarray
    valid: bool
    hit: bool
    t: float
    I: Optional[np.ndarray]
    Ng: Optional[np.ndarray]
    N: Optional[np.ndarray]
    smooth: bool
    u: float
    v: float
    triangle: int
    object_name: str
    albedo: Optional[np.ndarray]
    shadow_method: str
    lights: tuple
    radiance: np.ndarray
    warnings: tuple
    bsdf_sample: Optional[tuple] = None
    emission: Optional[np.ndarray] = None
    path: tuple = ()
    material: Optional[MaterialRecord] = None
    lens: Optional[np.ndarray] = None
    scattering: tuple = ()


class PathVertex(NamedTuple):
    """One vertex of the inspected pixel's path (integrator "path"; vertex 0 is the camera's hit).

    I, N: (3,) float64 the hit point (world) and shading normal; throughput: (3,) float64 the product of
    f cos / pdf of the bounces before it (divided by the roulette's q); gathered: (3,) float64 the light the
    vertex gathered (light samples and what its BSDF ray found, weighed by MIS; emission at vertex 0), before
    the throughput; bsdf_direction: (3,) and bsdf_pdf: the direction sampled there (pdf inf: a delta), or None;
    roulette: (q, went on) of the Russian roulette before this vertex, or None where none was played
    """

    vertex: int
    I: np.ndarray
    N: np.ndarray
    throughput: np.ndarray
    gathered: np.ndarray
    bsdf_direction: Optional[np.ndarray]
    bsdf_pdf: float
    roulette: Optional[tuple]


class InspectorRecorder(Recorder):
    """Keeps every value the integrator decides for the one inspected ray (core/integrators/base.py)."""

    def __init__(self, settings: RenderSettings, origin: np.ndarray):
        self.settings, self.origin = settings, origin
        self.surface = None
        self.lights = {}
        self.bsdf = None
        self.vertex = 0                      # the path vertex whose calls come in (0: the camera's hit)
        self.path: list = []
        self.pending_bsdf = None
        self.pending_roulette = None
        self.scattering: list = []

    def hits(self, O, D, surface, hit) -> None:
        self.surface = surface

    def scatter(self, kind, P) -> None:
        self.scattering.extend(ScatterRecord(kind, p + self.origin) for p in P)

    def shader(self, result) -> None:
        if self.vertex == 0:
            self.result = result

    def light_sample(self, light, count, sample, NL, NgL, cosine, face_allows, lit) -> None:
        if self.vertex > 0:
            return
        s = self.settings
        E_normal = sample.irradiance[0]
        if s.shadow_rays_for_backfacing and E_normal.max() > 0.0:
            reason = CAST
        elif cosine[0] == 0.0:
            reason = BEHIND_N
        elif not face_allows[0]:
            reason = BEHIND_FACE
        elif E_normal.max() <= 0.0:
            reason = NO_LIGHT
        elif not lit[0]:
            reason = SKIPPED
        else:
            reason = CAST
        self.lights[light] = dict(sample=sample, NL=float(NL[0]), NgL=float(NgL[0]), reason=reason,
                                  E_normal=E_normal.copy(), rays=None, seen=None, value=np.zeros(3), mis=1.0,
                                  pdf=float(sample.pdf[0]))

    def shadow_rays(self, light, count, rows, rays, seen) -> None:
        if self.vertex == 0:
            self.lights[light].update(rays=rays, seen=bool(seen[0]))

    def contribution(self, light, rows, value, mis_weight) -> None:
        if self.vertex == 0:
            self.lights[light]["value"] = value[0].copy()
            self.lights[light]["mis"] = float(mis_weight[0])

    def bsdf_sample(self, wi, pdf, found) -> None:
        if self.vertex == 0:
            self.bsdf = (wi[0].copy(), float(pdf[0]), found[0].copy())
        self.pending_bsdf = (wi[0].copy(), float(pdf[0])) if len(wi) else None

    def roulette(self, vertex, owner, q, survived) -> None:
        self.pending_roulette = (float(q[0]), bool(survived[0])) if len(q) else None

    def path_vertex(self, vertex, owner, surface, throughput, L) -> None:
        if len(owner) == 0:
            return
        wi, pdf = self.pending_bsdf if self.pending_bsdf is not None else (None, 0.0)
        self.path.append(PathVertex(vertex, surface.I[0] + self.origin, surface.N[0].copy(), throughput[0].copy(),
                                    L[0].copy(), wi, pdf, self.pending_roulette))
        self.vertex, self.pending_bsdf, self.pending_roulette = vertex + 1, None, None

    def albedo(self) -> np.ndarray:
        """The colour of the hit's material: the sum of its closures' weights (3,) float64."""
        closures = self.result.closures
        return (closures.weight[0] * (closures.kind[0] >= 0)[:, None]).sum(axis=0)

    def light_record(self, index: int, light) -> LightRecord:
        """The LightRecord of light `index` (camera-relative values in, world out)."""
        kept = self.lights[index]
        sample, origin = kept["sample"], self.origin
        r = float(sample.distance[0])
        occluded = shadow_origin = shadow_end = shadow_t_max = None
        if kept["rays"] is not None:
            rays = kept["rays"]
            occluded = not kept["seen"]
            shadow_origin = rays.origins[0] + origin
            shadow_t_max = float(rays.t_max[0])
            with np.errstate(invalid="ignore"):
                shadow_end = shadow_origin + shadow_t_max * rays.directions[0]
        is_sun = not np.isfinite(r)
        reason = NO_SHADOW if kept["reason"] == CAST and not getattr(light, "cast_shadow", True) else kept["reason"]
        return LightRecord(
            name=light.name, kind=light.blender_type, sampled=not light.delta, L=sample.L[0].copy(), distance=r,
            light_point=None if is_sun else sample.position[0] + origin, n_dot_l=kept["NL"], ng_dot_l=kept["NgL"],
            inverse_square=None if is_sun else (1.0 / (r * r) if r > 0 else math.inf), irradiance=kept["E_normal"],
            cast=reason == CAST, reason=reason, occluded=occluded, shadow_origin=shadow_origin,
            shadow_end=shadow_end, shadow_t_max=shadow_t_max, contribution=kept["value"], pdf=kept["pdf"],
            mis_weight=kept["mis"])


def inspect_pixel(scene: Scene, settings: RenderSettings, x: int, y: int,
                  geometry: Optional[WorldGeometry] = None) -> PixelRecord:
    """Trace the ray through the centre of pixel (x, y) (row 0 at the top) and return every value on the way.

    Raises ValueError for a scene that cannot be rendered or a pixel outside the image.
    A prebuilt `geometry` (same origin as the renderer's) skips the BVH build.
    """
    W, H = settings.width, settings.height
    if int(x) != x or int(y) != y:
        raise ValueError(f"pixel coordinates must be whole numbers, got ({x}, {y})")
    if not (0 <= x < W and 0 <= y < H):
        raise ValueError(f"pixel ({x}, {y}) is outside the {W}x{H} image (x in 0..{W - 1}, y in 0..{H - 1}, "
                         f"row 0 at the top)")
    x, y = int(x), int(y)
    # 1. The scene as the renderer traces it, each light with extent sampled once at its centre.
    warnings = []
    ctx = render_.prepare(scene, settings, geometry, warnings)
    ctx.light_numbers = light_numbers_of(ctx.lights)
    cam = scene.camera
    camera_point = np.asarray(cam.matrix_world, np.float64)[:3, 3].copy()
    # 2. The primary ray through the pixel centre.
    origin = ctx.geometry.origin
    camera = ctx.extra["camera"]
    lens = None
    if camera_.has_depth_of_field(camera):      # (the lens point of the render's sample 0 of this pixel)
        lens = sampling.sample_2d(settings.seed, np.array([y * W + x]), np.zeros(1, np.int64),
                                  dimension=camera_.LENS_DIMENSION)
    rays = camera_.generate_rays(camera, W, H, np.array([x + 0.5]), np.array([y + 0.5]),
                                 tuple(settings.pixel_aspect), lens)
    O_world, D = rays.origins[0] + origin, rays.directions[0]
    miss = dict(x=x, y=y, camera_point=camera_point, origin=O_world.copy(), direction=D.copy(),
                lens=None if lens is None else camera_.aperture_points(camera, lens)[0],
                valid=bool(rays.valid[0]), hit=False, t=math.inf, I=None, Ng=None, N=None, smooth=False,
                u=0.0, v=0.0, triangle=-1, object_name="", albedo=None, shadow_method=settings.shadow_method,
                lights=(), warnings=tuple(warnings))
    if not rays.valid[0]:
        return PixelRecord(radiance=np.zeros(3), **miss)
    # 3. The integrator on that one ray, with a recorder listening.
    recorder = InspectorRecorder(settings, origin)
    found = for_render(ctx).radiance(ctx, rays.origins, rays.directions, rays.t_max,
                                                        np.array([y * W + x]), np.zeros(1, np.int64), recorder)
    miss.update(scattering=tuple(recorder.scattering))
    if not found.hit[0]:
        return PixelRecord(radiance=np.zeros(3) if settings.transparent_background else ctx.extra["world"].copy(),
                           **miss)
    surface = recorder.surface
    triangle = int(surface.prim[0])
    owner = ctx.geometry.instance_of(triangle)
    object_name = scene.instances[owner].name if owner >= 0 else ""
    records = tuple(recorder.light_record(index, light) for index, light in enumerate(ctx.lights))
    miss.update(hit=True, t=float(surface.t[0]), I=surface.I[0] + origin, Ng=surface.Ng[0].copy(), N=surface.N[0].copy(),
                smooth=bool(surface.smooth[0]), u=float(surface.u[0]), v=float(surface.v[0]), triangle=triangle,
                object_name=object_name, albedo=recorder.albedo(), lights=records, bsdf_sample=recorder.bsdf,
                emission=recorder.result.emission[0].copy(), path=tuple(recorder.path),
                material=material_record(ctx, surface, recorder.result, -rays.directions[:1]))
    return PixelRecord(radiance=found.L[0].copy(), **miss)


class _RecordingTextures:
    """A TextureSet that keeps every lookup the node graph makes at the inspected hit (one point each)."""

    def __init__(self, textures, images: list):
        self.textures, self.images, self.found = textures, images, []

    def lookup(self, index, x, y, interpolation, extension, unassociate=False):
        """TextureSet.lookup, kept as a TextureRecord (the RGBA the graph reads, divided back where `unassociate`)."""
        rgba = self.textures.lookup(index, x, y, interpolation, extension, unassociate)
        name = self.images[index].name if 0 <= index < len(self.images) else "(missing: magenta)"
        self.found.append(TextureRecord(name, float(x[0]), float(y[0]), int(interpolation), int(extension),
                                        rgba[0].copy()))
        return rgba


def material_record(ctx, surface, result, wo: Optional[np.ndarray] = None) -> MaterialRecord:
    """The MaterialRecord of the inspected hit (row 0 of `surface`, shaded as `result`, seen from wo (1, 3), the
    way back along the camera ray): the material's graph run once more with its image lookups and its nodes'
    outputs kept, the UV and tangent it reads, and its closures."""
    from ..geometry.surface import shading_point
    from ..materials import BSDF_TYPES, graph as graph_  # noqa: F401
    from ..materials import microfacet as mf
    geometry, table = ctx.geometry, ctx.materials
    row = int(surface.material[0])
    name = str(table.names[row]) if row < len(table.names) else "(default)"
    # 1. What the node graph reads at the hit (core/geometry/surface.py): the active UV map, a tangent.
    layout = geometry.attribute_layout
    one = type(surface)(*(a[:1] if isinstance(a, np.ndarray) else a for a in surface))
    point = shading_point(geometry, one)
    values = point.attributes[0]
    uv = values[layout["uv:"][0]:layout["uv:"][0] + 2].copy() if "uv:" in layout else None
    tangent_key = next((key for key in layout if key.startswith("tangent:")), None)
    frame = None
    if tangent_key is not None:                 # as graph.normal_map builds it (the front side's frame)
        t = values[layout[tangent_key][0]:layout[tangent_key][0] + 4]
        n = surface.N[0] * point.side[0]
        T = point.linear[0] @ t[:3]
        frame = (T, t[3] * np.cross(n, T), n)
    # 2. The node graph once more at this hit, its image lookups and every named node's outputs kept.
    textures, nodes = (), ()
    program = table.program(row, layout)
    if program is not None:
        recording = _RecordingTextures(table.textures, table.images)
        seen = point if wo is None else point._replace(I=np.asarray(wo, np.float64))   # (Fresnel, Layer Weight)
        registers = graph_.run(program, seen, recording)[0]
        textures = tuple(recording.found)
        nodes = tuple(NodeValue(name, output, registers[reg:reg + width].copy(), kind)
                      for name, output, reg, width, kind in program.taps)
    # 3. The closures it made.
    c = result.closures
    closures = tuple(ClosureRecord(BSDF_TYPES[int(kind)].name, c.weight[0, k].copy(), float(c.sample_weight[0, k]),
                                   c.N[0, k].copy(), float(c.params[0, k, mf.ALPHA])
                                   if "alpha" in BSDF_TYPES[int(kind)].params else None)
                     for k, kind in enumerate(c.kind[0]) if kind >= 0)
    return MaterialRecord(name, uv, frame, textures, closures, nodes)


def light_numbers_of(lights: list) -> np.ndarray:
    """Return the unit-square point at the centre of each light (Light.centre_numbers): (k, 2) float64."""
    return np.array([light.centre_numbers() for light in lights]).reshape(len(lights), 2)


def light_numbers(scene: Scene) -> np.ndarray:
    """Return the inspector's unit-square sample per usable light: (k, 2) float64.

    With these as a Context's light_numbers, the integrator evaluates exactly the samples the inspector shows.
    """
    from .. import lights as lights_
    return light_numbers_of(lights_.usable(scene.lights, []))
