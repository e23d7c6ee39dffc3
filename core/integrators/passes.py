"""First-hit render passes: what compositing setups made for Cycles read besides Combined.

Unlike the denoising features, light passes and light groups (which the integrator writes as it goes), these
still come from a separate, cheap pass of camera rays after the render, computed only for the passes a scene asks
for. Cycles' meaning (kernel/film/data_passes.h,
kernel/film/light_passes.h, kernel/integrator/shade_surface.h), followed along each camera sample:

- A camera ray goes on through transparent surfaces (a Transparent BSDF, a Principled BSDF's Alpha) with
  its throughput times their transparency, up to transparent_max_bounces of them.
- The data passes come from the first surface whose alpha (1 - the mean transparency) is at least
  ALPHA_THRESHOLD (Cycles' Alpha Threshold, 0.5):
    position        the world-space hit point, of sample 0 only (not anti-aliased, as in Cycles)
    object_index    the object's Pass Index, of sample 0 only
    material_index  the material's Pass Index, of sample 0 only
    z_depth         the hit's distance along the camera's forward axis (Blender's Depth pass), the mean over
                    the samples that hit, MISS_DEPTH where none did (Cycles keeps sample 0's)
    average_normal  the closures' normals weighed by their mean weight, normalised (the shading normal where
                    no closure says otherwise: normal maps and bump included), world space, the mean over
                    samples (Cycles' Normal pass, surface_shader_average_normal)
    uv              (u, v, 1) of the object's active render UV map, the mean over samples: the third channel
                    is the share of samples that hit a surface (0 where they all missed)
- The colour passes add, at every surface the ray meets before it scatters, throughput times the sum over
  the closures of their weight times their albedo (Cycles' bsdf_albedo): Lambert's albedo is 1; a
  microfacet's is its Fresnel reflectance at the view angle (Cycles reads a roughness-averaged table for
  some Fresnel models; Primer's closures do not keep it); glass splits into its reflected share
  (glossy) and transmitted share (transmission); a smooth glossy lobe, stored as a mirror whose weight
  already holds its Fresnel reflectance, counts with albedo 1:
    diffuse_color, glossy_color, transmission_color
- emission      throughput times what the surfaces the camera sees emit, plus the lamps with extent it
                sees (Cycles writes directly seen lights there too)
- environment   throughput times the world where the camera ray escapes, also with a transparent film
                (Cycles keeps it for compositing the background back in)
- ambient_occlusion  throughput times whether a cosine-distributed ray from the first opaque surface
                (around its shading normal) escapes within ao_distance: 1 open, 0 occluded (grey, 3 channels)
- crypto_object, crypto_material, crypto_asset  Cryptomatte (cryptomatte.py): at every surface the ray
                meets, mean(throughput) x (1 - mean(transparency)) for the surface's object, material or asset
                id; ranked per pixel into settings.cryptomatte_depth (id, coverage) pairs

Each pass is the mean over PASS_SAMPLES camera samples (fewer when the render takes fewer), at the same
jittered positions as the render's first samples, with Primer's 1-pixel box filter (Cycles uses its pixel
filter, 1.5 pixels Blackman-Harris by default: anti-aliased edges differ); pixels without samples are 0.
"""
from __future__ import annotations

import numpy as np

from .. import materials as materials_
from .. import vectors
from ..geometry.surface import hit_attributes, hit_owners, surface_at_hits
from ..materials import graph as graph_
from ..materials.closures import each_kind
from ..materials.lambert import Lambert
from ..sampling import sobol as sampling
from . import cryptomatte, shadows
from .base import Context, check_stop
from .rays import lamps_seen, nearest_seen

# Channels of each pass buffer (core/render.py RenderResult.aux).
PASS_CHANNELS = {
    "position": 3, "uv": 3, "object_index": 1, "material_index": 1, "z_depth": 1, "average_normal": 3,
    "diffuse_color": 3, "glossy_color": 3, "transmission_color": 3,
    "emission": 3, "environment": 3, "ambient_occlusion": 3,
}
# Cryptomatte's passes: core buffer -> matte kind (cryptomatte.KINDS); their channels follow the depth.
CRYPTO_PASSES = {"crypto_object": "object", "crypto_material": "material", "crypto_asset": "asset"}
# Passes averaged over the samples that hit (the others do not count), with their value where none hit.
HIT_MEAN = {"z_depth": 1e10}
# Passes Cycles takes from sample 0 alone (overwritten, not averaged).
FIRST_SAMPLE_ONLY = ("position", "object_index", "material_index")
# Camera samples per pixel the passes average (at most the render's samples).
PASS_SAMPLES = 16
# A surface at least this opaque (1 - mean transparency) holds the data passes (Cycles' pass_alpha_threshold).
ALPHA_THRESHOLD = 0.5
# Sampling dimension of the ambient occlusion ray's direction.
AO_DIMENSION = 120
# The UV map the UV pass reads: the mesh's active render map (core/scene Mesh.attributes).
UV_ATTRIBUTE = "uv:"


def pass_channels(name: str, depth: int) -> int:
    """Return the channels of the pass `name`: PASS_CHANNELS', or 4 per two Cryptomatte ranks of `depth`."""
    return 4 * cryptomatte.pass_count(depth) if name in CRYPTO_PASSES else PASS_CHANNELS[name]


def pass_samples(samples: int) -> int:
    """Return the camera samples per pixel the passes average for a render of `samples` samples."""
    return max(1, min(int(samples), PASS_SAMPLES))


def closure_albedos(shader) -> tuple:
    """Return (diffuse, glossy, transmission) colours (m, 3) float64 of hits with the ShaderResult `shader`:
    each the sum of its closures' weight x albedo (module docstring), by closure type (BSDFFlags.*_TYPE): the
    diffuse type's reflection to Diffuse, the glossy type's to Glossy, the transmission type's transmission to
    Transmission, and glass's reflection and transmission to Glossy and Transmission."""
    F = materials_.BSDFFlags
    c = shader.closures
    m = len(c.kind)
    diffuse, glossy, transmission = np.zeros((m, 3)), np.zeros((m, 3)), np.zeros((m, 3))
    for slot in range(c.kind.shape[1]):
        for bsdf, rows in each_kind(c, slot):
            if not bsdf.is_(F.DIFFUSE_TYPE | F.GLOSSY_TYPE | F.TRANSMISSION_TYPE | F.GLASS_TYPE):
                continue
            weight = c.weight[rows, slot]
            R, T = bsdf.albedo(c.params[rows, slot], c.N[rows, slot], shader.wo[rows])
            if bsdf.is_(F.DIFFUSE_TYPE):
                diffuse[rows] += weight * R
            if bsdf.is_(F.GLOSSY_TYPE | F.GLASS_TYPE):
                glossy[rows] += weight * R
            if bsdf.is_(F.TRANSMISSION_TYPE | F.GLASS_TYPE):
                transmission[rows] += weight * T
    return diffuse, glossy, transmission


class _Shaded:
    """A ShaderResult with the view direction each hit was seen from (wo (m, 3) float64)."""

    def __init__(self, shader, wo: np.ndarray):
        self.closures, self.emission, self.transparency, self.wo = (shader.closures, shader.emission,
                                                                    shader.transparency, wo)


def trace_passes(ctx: Context, wanted: tuple, O: np.ndarray, D: np.ndarray, t_max: np.ndarray,
                 pixel: np.ndarray, sample: np.ndarray) -> dict:
    """Return name -> (n, c) float64 of the passes `wanted` (PASS_CHANNELS' names) for camera rays O, D (n, 3)
    float64 up to t_max (n,), as the module docstring says. pixel, sample: (n,) int64 random-number keys."""
    s = ctx.settings
    n = len(O)
    out = {name: np.zeros((n, PASS_CHANNELS[name] + (name in HIT_MEAN))) for name in wanted if name in PASS_CHANNELS}
    mattes = [name for name in wanted if name in CRYPTO_PASSES]
    matte_parts = []                            # (camera sample, object, material, instance, coverage) per surface
    data = [name for name in ("position", "uv", "object_index", "material_index", "ambient_occlusion", "z_depth",
                              "average_normal") if name in wanted]
    colours = [name for name in ("diffuse_color", "glossy_color", "transmission_color") if name in wanted]
    owner = np.arange(n)
    throughput = np.ones((n, 3))
    pending = np.ones(n, bool)                  # the data passes are not written yet
    world = ctx.extra.get("world_light")
    geometry = ctx.geometry
    for bounce in range(max(0, int(s.transparent_max_bounces)) + 1):
        check_stop(ctx)
        # 1. What the rays meet: the world where they escape (lamps with extent in front of what they hit).
        found = nearest_seen(ctx, O, D, t_max)
        hit = np.flatnonzero(found.hit)
        missed = np.flatnonzero(~found.hit)
        if "environment" in wanted and world is not None and world.camera and len(missed):
            out["environment"][owner[missed]] += throughput[missed] * world.radiance(D[missed])
        if "emission" in wanted:
            out["emission"][owner] += throughput * lamps_seen(ctx, O, D, np.where(found.hit, found.t, t_max))
        if len(hit) == 0:
            break
        surface = surface_at_hits(geometry, found.prim[hit], found.u[hit], found.v[hit], vectors.gather(O, hit),
                                  vectors.gather(D, hit), found.t[hit], flat_only=not s.smooth_normals)
        owner, throughput, pending = owner[hit], throughput[hit], pending[hit]
        wo = -vectors.gather(D, hit)
        ray = graph_.RAY_CAMERA if bounce == 0 else graph_.RAY_BOUNCE
        shader = ctx.materials.shade(surface.material, surface.N, wo, surface, geometry, ray)
        # 2. Emission and the closures' colours, seen through what the ray passed.
        if "emission" in wanted:
            out["emission"][owner] += throughput * shader.emission
        if colours:
            albedos = dict(zip(("diffuse_color", "glossy_color", "transmission_color"),
                               closure_albedos(_Shaded(shader, wo))))
            for name in colours:
                out[name][owner] += throughput * albedos[name]
        # 3. The data passes, at the first surface opaque enough.
        transparency = np.clip(shader.transparency, 0.0, None)
        opaque = pending & (1.0 - transparency.mean(axis=1) >= ALPHA_THRESHOLD)
        if mattes:
            coverage = throughput.mean(axis=1) * (1.0 - transparency.mean(axis=1))
            _, instance, _ = hit_owners(geometry, surface.prim)
            matte_parts.append((owner, instance, surface.material, coverage))
        if data and opaque.any():
            rows = np.flatnonzero(opaque)
            write_data_passes(ctx, out, data, rows, owner[rows], surface, shader, throughput[rows], pixel, sample)
        pending &= ~opaque
        # 4. On through the transparent part.
        through = np.flatnonzero(transparency.max(axis=1) > 0.0)
        if len(through) == 0:
            break
        step = shadows.error_bound(surface.I[through], surface.vertices[through])
        O = surface.I[through] - step[:, None] * surface.Ng[through]
        D = -wo[through]
        t_max = np.full(len(through), np.inf)
        owner, pending = owner[through], pending[through]
        throughput = throughput[through] * transparency[through]
    if mattes:
        out["cryptomatte"] = matte_ids(ctx, mattes, matte_parts)
    return out


def matte_ids(ctx: Context, mattes: list, parts: list) -> dict:
    """Return {"sample": (m,) int64 camera samples, "coverage": (m,) float64, name: (m,) float32 ids for each
    Cryptomatte pass in `mattes`} of the surfaces `parts` (trace_passes' (sample, instance, material,
    coverage) tuples), with the names cryptomatte.py's docstring gives (their ids hashed once per render,
    ctx.extra["crypto_ids"], else here)."""
    if parts:
        sample, instance, material, coverage = (np.concatenate(column) for column in zip(*parts))
    else:
        sample = instance = material = np.zeros(0, np.int64)
        coverage = np.zeros(0)
    out = {"sample": sample, "coverage": coverage}
    tables = ctx.extra.get("crypto_ids") or cryptomatte.id_tables(ctx.scene)
    for name in mattes:
        kind = CRYPTO_PASSES[name]
        table = tables[kind]
        index = material if kind == "material" else instance
        out[name] = table[np.clip(np.asarray(index, np.int64), 0, len(table) - 1)]
    return out


def write_data_passes(ctx: Context, out: dict, data: list, rows: np.ndarray, owner: np.ndarray, surface, shader,
                      throughput: np.ndarray, pixel: np.ndarray, sample: np.ndarray) -> None:
    """Write the data passes `data` of the hits `rows` (k,) int64 (of `surface`, `shader`) into `out`'s rows
    `owner` (k,) int64 (the camera samples they belong to); throughput (k, 3) float64 weighs the AO pass."""
    geometry = ctx.geometry
    prim = surface.prim[rows]
    attribute_rows, instance, _ = hit_owners(geometry, prim)
    if "position" in data:
        out["position"][owner] = surface.I[rows] + geometry.origin
    if "object_index" in data:
        indices = np.array([float(getattr(i, "pass_index", 0)) for i in ctx.scene.instances] or [0.0])
        out["object_index"][owner, 0] = indices[np.clip(instance, 0, len(indices) - 1)]
    if "material_index" in data:
        table = [float(getattr(m, "pass_index", 0)) for m in ctx.scene.materials]
        indices = np.array(table + [float(getattr(ctx.scene.default_material, "pass_index", 0))])
        out["material_index"][owner, 0] = indices[np.clip(surface.material[rows], 0, len(indices) - 1)]
    if "uv" in data:
        uv = np.zeros((len(rows), 3))
        uv[:, 2] = 1.0
        layout = geometry.attribute_layout.get(UV_ATTRIBUTE)
        if layout is not None:
            values, _, _ = hit_attributes(geometry, attribute_rows, surface.u[rows], surface.v[rows])
            uv[:, :2] = values[:, layout[0]:layout[0] + 2]
        out["uv"][owner] = uv
    if "z_depth" in data:            # a last channel counts the samples that hit (HIT_MEAN)
        camera = surface.I[rows] + ctx.extra["camera_offset"]
        out["z_depth"][owner] = np.stack([camera @ ctx.extra["forward"], np.ones(len(rows))], axis=-1)
    if "average_normal" in data:
        out["average_normal"][owner] = average_normal(shader.closures, shader.N, rows)
    if "ambient_occlusion" in data:
        out["ambient_occlusion"][owner] += throughput * ambient_occlusion(
            ctx, surface.I[rows], surface.Ng[rows], surface.vertices[rows], shader.N[rows], pixel[owner],
            sample[owner])[:, None]


def average_normal(closures, N: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Return the unit normals (k, 3) float64 of the hits `rows` (k,) int64: their closures' normals weighed by
    |mean(weight)| (the Transparent BSDF left out), or the shading normal N (m, 3) where they have none."""
    kind, weight, normals = closures.kind[rows], closures.weight[rows], closures.N[rows]
    w = np.where((kind >= 0) & ~materials_.has(kind, materials_.BSDFFlags.STRAIGHT), np.abs(weight.mean(axis=-1)), 0.0)
    total = np.einsum("nk,nkj->nj", w, normals)
    length = np.linalg.norm(total, axis=-1, keepdims=True)
    return np.where(length > 0.0, total / np.where(length > 0.0, length, 1.0), N[rows])


def ambient_occlusion(ctx: Context, I: np.ndarray, Ng: np.ndarray, vertices: np.ndarray, N: np.ndarray,
                      pixel: np.ndarray, sample: np.ndarray) -> np.ndarray:
    """Return 1 where a cosine-distributed ray about N (k, 3) from the hit points I (k, 3) float64 escapes
    within ctx.settings.ao_distance, else 0: (k,) float64. Ng: (k, 3) face normals; vertices (k, 3, 3)."""
    u = sampling.sample_2d(ctx.settings.seed, pixel, sample, dimension=AO_DIMENSION)
    wi = Lambert.sample(None, N, None, u).wi
    below = np.einsum("ij,ij->i", Ng, wi) < 0.0      # a direction under the surface sees nothing: occluded
    origin = shadows.spawn_ray(I, Ng, wi, shadows.error_bound(I, vertices))
    blocked = ctx.geometry.tracer.occluded(origin, wi, np.full(len(I), float(ctx.settings.ao_distance)))
    return np.where(blocked | below, 0.0, 1.0)
