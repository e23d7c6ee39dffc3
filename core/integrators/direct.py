"""Direct lighting: the lecture's ray tracer. What a camera ray sees where it hits a surface.

For each camera ray, the nearest hit I with its face normal Ng and shading normal N (flipped
towards the viewer), the material there (core/materials: its closures and what it emits); then
the light it emits itself, and for every light, and every sample of a light with extent:

    L_out += f(wo, L) max(N.L, 0) * E_normal * V * w_light    (core/materials, core/lights, shadows.py)

where E_normal = L_e / pdf is the light sample's irradiance at normal incidence and V the shadow
ray's verdict. For the Lambert BSDF f = albedo / pi: the lecture's absorption. Lights with extent
(area lights, round lights, sun disks, emissive meshes, an environment) can also be found the other
way round: one direction sampled from the BSDF, traced, adds the light it meets,

    L_out += (f cos / pdf_bsdf) * L_e * w_bsdf,

and multiple importance sampling (Veach's power heuristic, as Cycles weighs them) gives each
strategy the weight w = (n p)^2 / sum over strategies of (n p)^2, so that each light is counted
once, by whichever strategy finds it best. A constant world is found by BSDF rays only, as in Cycles.
RenderSettings.light_sampling "light" or "bsdf" keeps one strategy alone (the lecture switch that
shows why MIS). Work is done only
where it matters: interpolated normals only for smooth triangles, shadow rays only for lights in
front of both N and the face, and only where the light sends something. The lecture switches of
RenderSettings undo these choices one at a time, to show why the lecture makes them.

Its compiled twin is core/integrators/direct.c: the same steps in the same order, per sample.
"""
from __future__ import annotations

from typing import ClassVar, NamedTuple

import numpy as np

from .. import materials as materials_
from ..materials import graph as graph_
from .. import vectors
from ..visibility import (HIDDEN_FROM_CAMERA, HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY,
                          HIDDEN_FROM_TRANSMISSION, HOLDOUT)
from ..geometry.surface import surface_at_hits
from ..lights.base import LAMP
from ..sampling import sobol as sampling
from . import clamp as clamp_
from . import lightpasses
from . import shadows
from .base import Context, Integrator, Radiance, Recorder


def power_heuristic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Veach's power heuristic a^2 / (a^2 + b^2), with a = inf (a delta strategy) giving 1 and a = 0 giving 0.

    a, b: (n,) float64 the two strategies' pdfs, each times its number of samples.
    """
    with np.errstate(invalid="ignore", over="ignore"):
        w = a * a / (a * a + b * b)
    return np.where(np.isinf(a), 1.0, np.where(a > 0.0, np.nan_to_num(w), 0.0))


class DirectLighting(Integrator):
    """Light that reaches a surface straight from a lamp, an emitter or the world: one shadow ray per
    light sample, and one BSDF-sampled ray per hit where lights can be found that way."""

    name: ClassVar[str] = "direct"

    def radiance(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                 sample: np.ndarray, recorder: Recorder) -> Radiance:
        if ctx.extra.get("transparent", False):
            # Rays go on through transparent surfaces (Cycles' transparent bounces, apart from Max Bounces 0):
            # the path tracer with no bounces but those (core/integrators/path.py).
            from .path import PathTracing
            return PathTracing(direct_only=True).radiance(ctx, O, D, t_max, pixel, sample, recorder)
        # 1-3. The camera rays' hits and surfaces, the world where they escape, the lamps they pass.
        direct_cap = clamp_.limits(ctx.settings)[0]
        L_out, found, hit, surface = camera_hits(ctx, O, D, t_max, recorder, direct_cap)
        if surface is None:
            return Radiance(L_out, found.hit, 0)
        D_hit = vectors.gather(D, hit)
        # 4. The light each hit sends towards the camera (each contribution capped by Clamp Direct).
        parts = lightpasses.FirstHitParts(len(hit)) if lightpasses.wanted(ctx.settings.passes) else None
        L_hit, shadow_rays, _ = self.shade(ctx, surface, -D_hit, pixel[hit], sample[hit], recorder, limit=direct_cap,
                                           parts=parts)
        L_out[hit] += L_hit
        light = None
        if parts is not None:                    # the light passes: all of it direct (core/integrators/lightpasses.py)
            light = np.zeros((len(O), len(lightpasses.LIGHT_PASSES), 3))
            light[hit, :lightpasses.KINDS] = parts.gathered
        return Radiance(L_out, found.hit, shadow_rays, light=light)

    def shade(self, ctx: Context, surface, wo: np.ndarray, pixel: np.ndarray, sample: np.ndarray,
              recorder: Recorder, dimension: int = 0, vertex: int = 0, trace_all: bool = False,
              light_samples_only: bool = False, ray=None, carried_pdf=None, caustics=None, throughput=None,
              limit=np.inf, shader=None, seen_by=HIDDEN_FROM_CAMERA, parts=None, carried_origin=None,
              carried_N=None):
        """Return (the radiance (m, 3) float64 each hit sends towards wo, shadow rays traced, the BsdfRay
        each traced hit sent out, or None).

        wo: (m, 3) float64 unit directions towards the viewer; pixel, sample: (m,) int64 each hit's
        keys for its random numbers. A path (core/integrators/path.py) calls this at every vertex:
        `dimension` shifts its random numbers, vertices after the first leave their emission to the
        ray that found them (vertex > 0), and every hit traces its BSDF ray (trace_all). Whitted's tracer
        lights every hit by light samples alone (light_samples_only: no BSDF ray, no MIS). ray: which kind of ray
        found the hits (graph.RAY_*, scalar or (m,); default: the camera's at vertex 0), for the Light Path node.
        caustics: (m,) int the closures a caustics filter takes away (closures.FILTER_*), or None. throughput
        (m, 3) or None (1) and limit (scalar or (m,), inf: none): each contribution the hits gather is capped at
        `limit` seen through its path's throughput (sample clamping, core/integrators/clamp.py). shader: the
        hits' ShaderResult when the caller has it already (a path's holdouts change it), else evaluated here.
        seen_by: the kind of ray that reached each hit (HIDDEN_FROM_* bit, int or (m,)): a Transparent closure's
        ray goes on as that kind (ray_kind). parts: a lightpasses.FirstHitParts that receives the light samples'
        and the BSDF ray's contributions split by closure kind, and the BSDF rays' shares (the light passes), or None.
        carried_pdf, carried_origin, carried_N: (m,), (m, 3), (m, 3) the pdf, ray origin and light-tree normal of each
        path's last real bounce (bsdf_ray), or None.
        """
        s = ctx.settings
        m = len(surface.I)
        # 1. The material at each hit: its closures (BSDFs with weights) and the light it emits itself.
        if ray is None:
            ray = graph_.RAY_CAMERA if vertex == 0 else graph_.RAY_BOUNCE
        if shader is None:
            shader = ctx.materials.shade(surface.material, surface.N, wo, surface, ctx.geometry, ray, caustics)
        recorder.shader(shader)
        clamping = np.any(np.isfinite(limit))
        L_out = shader.emission.copy() if vertex == 0 else np.zeros((m, 3))
        if clamping and vertex == 0:
            L_out = clamp_.clamped(L_out, throughput, limit)
        shadow_rays = 0
        offsets = shadows.error_bound(surface.I, surface.vertices) if s.shadow_method == "robust" else None
        # Which hits trace a BSDF ray (every hit where emitters or the world light the scene, glossy hits
        # where only lamps with extent do) and so weigh their light samples by MIS.
        traced = np.ones(m, bool) if trace_all else wants_bsdf_ray(ctx, shader)
        if light_samples_only:
            traced = np.zeros(m, bool)
        mis = (traced & (s.light_sampling == "mis")) if ctx.extra.get("bsdf_rays", False) else np.zeros(m, bool)
        # Hits whose closures let light through from behind (rough glass) sample lights on both sides.
        refracts = lets_light_through(shader)
        tree_N = tree_normals(s, surface, refracts)
        for index, light in enumerate(ctx.lights):
            if (s.light_sampling == "bsdf" and not light_samples_only and not light.delta
                    and index in ctx.extra.get("hittable", ())):
                continue                      # found by BSDF rays alone
            count = light_count(ctx, light)
            cone = light.cone(surface.I)                   # shared by all the light's samples
            for j in range(count):
                # a. Where does the light come from? One sample of the light's progressive pattern:
                #    camera sample s takes its points s*count .. s*count+count-1 (core/sampling), so
                #    the points of any number of camera samples together cover the light evenly.
                u = light_numbers(ctx, light, index, pixel, sample * count + j, m, dimension)
                ls = light.sample(surface.I, u, cone, N=tree_N)
                if getattr(light, "textured", None) is not None:
                    ls = textured_samples(ctx, light, surface.I, ls)
                if not s.distance_attenuation:
                    ls = light.without_attenuation(ls, surface.I)
                # b. The lecture's two tests: N.L > 0 (shading normal, the clamp) and Ng.L > 0 (the
                #    face normal decides whether the light can be visible; `visibility_normal`
                #    switches it). The terminator fix lifts smooth points onto the curved surface,
                #    where the face normal no longer decides; its shadow ray does.
                NL = np.einsum("ij,ij->i", surface.N, ls.L)
                NgL = np.einsum("ij,ij->i", surface.Ng, ls.L)
                facing = NgL > 0.0 if s.visibility_normal == "face" else NL > 0.0
                face_allows = (facing | surface.smooth if s.terminator_fix else facing) | refracts
                cosine = np.maximum(NL, 0.0) if s.clamp_n_dot_l else NL
                cosine = np.where(refracts, np.abs(NL), cosine)
                lit = (cosine != 0.0) & face_allows
                if s.shadow_rays_for_backfacing:
                    lit[:] = True                     # cast them anyway, to count what the lecture saves
                lit &= ls.strength > 0.0
                recorder.light_sample(index, count, ls, NL, NgL, cosine, face_allows, lit)
                rows = np.flatnonzero(lit)
                if len(rows) == 0:
                    continue
                # c. One shadow ray per lit sample, from a point safely off the surface.
                rays = self.shadow_rays(s, surface, rows, ls, NL, NgL, offsets, refracts[rows] & (NgL[rows] < 0.0))
                if ctx.extra.get("transparent", False):
                    through = shadows.transmittance(ctx, rays, s.transparent_max_bounces)
                    seen = through.any(axis=1)
                else:
                    seen = shadows.visible(ctx.geometry.tracer, rays)
                    through = seen[:, None].astype(np.float64)
                recorder.shadow_rays(index, count, rows, rays, seen)
                shadow_rays += len(rows)
                # d. What gets through: f cos (the closures at L) E_normal / count, coloured by the
                #    light, weighed against BSDF sampling where a BSDF ray could find this light.
                part = materials_.Closures(*(array[rows] for array in shader.closures))
                left_out = None if ls.hidden is None else closures_left_out(part.kind, ls.hidden[rows])
                f_cos, pdf_bsdf = materials_.eval_closures(part, wo[rows], ls.L[rows],
                                                           signed_cosine=not s.clamp_n_dot_l, left_out=left_out)
                weight = ls.strength[rows] * (1.0 / count)
                mis_weight = np.ones(len(rows))
                if not light.delta and index in ctx.extra["hittable"] and mis[rows].any():
                    mis_weight = np.where(mis[rows], power_heuristic(count * ls.pdf[rows], pdf_bsdf), 1.0)
                    weight = weight * mis_weight
                color = ls.color if ls.color.ndim == 1 else ls.color[rows]
                value = (weight[:, None] * color) * f_cos * through
                if clamping:
                    value = clamp_.clamped(value, None if throughput is None else throughput[rows],
                                           limit if np.ndim(limit) == 0 else limit[rows], count)
                recorder.contribution(index, rows, value, mis_weight)
                L_out[rows] += value
                if parts is not None:
                    parts.gathered[rows] += lightpasses.split(value, lightpasses.kind_shares(
                        part, wo[rows], ls.L[rows], signed_cosine=not s.clamp_n_dot_l, left_out=left_out))
        # 2. The light one BSDF-sampled direction finds (lamps with extent, emitters, the world).
        ray = None
        if not light_samples_only and (trace_all or (ctx.extra.get("bsdf_rays", False) and s.light_sampling != "light"
                                                     and traced.any())):
            gather = s.light_sampling != "light" and ctx.extra.get("bsdf_rays", False)
            found, ray = self.bsdf_ray(ctx, surface, shader, wo, pixel, sample, offsets, mis, traced, recorder,
                                       dimension, gather, carried_pdf, seen_by, tree_N=tree_N,
                                       carried_origin=carried_origin, carried_N=carried_N)
            found = clamp_.clamped(found, throughput, limit) if clamping else found
            L_out += found
            if parts is not None and ray is not None:
                c = materials_.Closures(*(None if array is None else array[ray.rows] for array in shader.closures))
                parts.ray_shares = lightpasses.sample_shares(c, wo[ray.rows], ray.D, ray.kind, ray.delta, ray.transmit)
                parts.gathered[ray.rows] += lightpasses.split(found[ray.rows], parts.ray_shares)
        return L_out, shadow_rays, ray

    def bsdf_ray(self, ctx: Context, surface, shader, wo, pixel, sample, offsets, mis: np.ndarray,
                 traced: np.ndarray, recorder: Recorder, dimension: int = 0, gather: bool = True,
                 carried_pdf=None, seen_by=HIDDEN_FROM_CAMERA, *, tree_N: np.ndarray, carried_origin=None,
                 carried_N=None):
        """Return (the light (m, 3) one direction sampled from each hit's closures finds, the BsdfRay).

        The light: a lamp with extent in front of what the ray hits, an emissive surface it hits, or the
        world it escapes to, each weighed by MIS against that light's own samples (weight 1 for a constant
        world); nothing unless `gather`. mis, traced: (m,) bool which hits weigh by MIS, which trace a ray.
        carried_pdf: (m,) the pdf of the path's last real bounce (inf: the camera's), for rays that go on
        through a transparent surface. seen_by: the kind of ray that reached each hit (HIDDEN_FROM_* bit, int or
        (m,)); each ray passes the objects hidden from its own kind (ray_kind). tree_N: (m, 3) the normals the hits'
        light samples gave the light tree (tree_normals), for the emitters' MIS pdf. carried_origin, carried_N: (m, 3)
        the ray origin and light-tree normal of the path's last real bounce (with carried_pdf): a ray straight through
        a transparent surface weighs what it finds with the pdfs the light samples at that bounce would have given
        its direction, measured from there (Cycles' mis_origin), not from the transparent surface."""
        s = ctx.settings
        m = len(surface.I)
        u = sampling.sample_2d(s.seed, pixel, sample, dimension=BSDF_DIMENSION + dimension)
        pick = sampling.sample_2d(s.seed, pixel, sample, dimension=BSDF_DIMENSION + 1 + dimension)[:, 0]
        bs = materials_.sample_closures(shader.closures, wo, u, pick)
        found = np.zeros((m, 3))
        go = np.flatnonzero((bs.pdf > 0.0) & traced)
        if len(go) == 0:
            recorder.bsdf_sample(bs.wi, bs.pdf, found)
            return found, None
        # The ray leaves from a point safely off the surface, on the side it goes to.
        side = np.where(np.einsum("ij,ij->i", surface.Ng[go], bs.wi[go]) < 0.0, -1.0, 1.0)
        step = offsets[go] if offsets is not None else np.full(len(go), s.epsilon)
        O = surface.I[go] + (step * side)[:, None] * surface.Ng[go]
        D = bs.wi[go]
        transmit = np.einsum("ij,ij->i", surface.Ng[go], D) < 0.0
        seen_as = ray_kind(bs.kind[go], transmit, np.broadcast_to(np.asarray(seen_by, np.int64), (m,))[go])
        hits = nearest_seen(ctx, O, D, np.full(len(go), np.inf), seen_as)
        pdf_b = np.where(bs.delta[go], np.inf, bs.pdf[go])
        # A ray that went straight through a transparent surface is still the last real bounce's ray: its MIS
        # weighs with that bounce's pdf (inf for the camera's), as Cycles keeps it across transparent bounces.
        clear = materials_.has(bs.kind[go], materials_.BSDFFlags.STRAIGHT)
        mis_O, mis_N = O, tree_N[go]
        if carried_pdf is not None and clear.any():
            pdf_b = np.where(clear, carried_pdf[go], pdf_b)
            if carried_origin is not None:
                mis_O = np.where(clear[:, None], carried_origin[go], O)
                mis_N = np.where(clear[:, None], carried_N[go], mis_N)
        ray = BsdfRay(go, O, D, hits, bs.weight[go], bs.kind[go], bs.delta[go], transmit, pdf_b, seen_as, mis_O, mis_N)
        t_hit = np.where(hits.hit, hits.t, np.inf)
        for kind, mask in (("reflect", ~ray.transmit), ("refract", ray.transmit)):
            if mask.any():
                recorder.rays(kind, O[mask], D[mask], t_hit[mask])
        if not gather:
            recorder.bsdf_sample(bs.wi, bs.pdf, found)
            return found, ray
        use_mis = mis[go] & (~bs.delta[go] | (clear & np.isfinite(pdf_b)))
        holdouts = ctx.geometry.hides(HOLDOUT)
        found[go] = bs.weight[go] * gather_light(ctx, O, D, hits, pdf_b, use_mis,
                                                 seen_as == HIDDEN_FROM_CAMERA if holdouts else None, N=mis_N,
                                                 mis_O=mis_O)
        recorder.bsdf_sample(bs.wi, bs.pdf, found)
        return found, ray

    @staticmethod
    def shadow_rays(s, surface, rows: np.ndarray, ls, NL: np.ndarray, NgL: np.ndarray, offsets,
                    behind=None) -> shadows.ShadowRays:
        """Return the shadow rays of the hits `rows` towards their light samples (robust or epsilon offsets);
        behind (r,) bool: lights behind the face of a surface that lets light through, reached from its back."""
        I = surface.I[rows]
        Ng = surface.Ng[rows]
        if s.terminator_fix:
            I = shadows.lift_terminator(surface, rows, NL[rows], NgL[rows], s.terminator_offset)
        elif s.shadow_rays_for_backfacing or s.visibility_normal != "face":
            # Switches that cast rays towards lights behind the face: offset to the light's side.
            Ng = Ng * np.where(NgL[rows] < 0.0, -1.0, 1.0)[:, None]
        if behind is not None and behind.any():
            I = np.where(behind[:, None], surface.I[rows], I)
            Ng = np.where(behind[:, None], -surface.Ng[rows], Ng)
        if s.shadow_method == "robust":
            return shadows.robust_rays(I, Ng, offsets[rows], ls.position[rows], ls.L[rows], ls.distance[rows],
                                       s.reduce_t_max)
        return shadows.epsilon_rays(I, ls.L[rows], ls.distance[rows], s.epsilon, s.reduce_t_max)


def gather_light(ctx: Context, O: np.ndarray, D: np.ndarray, hits, pdf_b: np.ndarray, use_mis: np.ndarray,
                 camera=None, N=None, mis_O=None) -> np.ndarray:
    """The light (k, 3) that rays O + t D (k, 3) bring back, ending at `hits` (the tracer's Hits): lamps with
    extent in front of the hit, the emission of the surface hit, or the world where the ray escapes, each
    weighed by MIS (where `use_mis` (k,) bool) with pdf_b (k,), the pdf of the bounce that sent the ray.
    camera: (k,) bool which rays are still a camera path's (through Transparent closures), or None: a holdout
    object such a ray hits emits nothing (it is a hole in the film, path.hold_out). N: (k, 3) the normals the light
    tree weighed the emitters by at the rays' origins (tree_normals), or None (unknown): the emitters' MIS pdf
    picks each triangle with the probability their light samples gave it. mis_O: (k, 3) where the light samples that
    MIS weighs against were taken (the last real bounce's ray origin, N its normal there), or None (O): a ray that
    went straight on through transparent surfaces from there still has the direction D, and a light it finds at
    distance t from O is at |O + t D - mis_O| from there (Cycles' mis_origin); an emitter's radiance is the actual
    hit's; a lamp is met where the line from mis_O meets it past O (the same point, but for a round lamp with soft
    falloff: the disk facing mis_O, the one its light samples there saw), with the radiance it sends along D."""
    light_L = np.zeros((len(O), 3))
    t_limit = np.where(hits.hit, hits.t, np.inf)
    away = np.zeros(len(O), bool) if mis_O is None else (mis_O != O).any(axis=1)
    # From mis_O: how far each ray's end (inf: none) and its start O are.
    t_mis = t_limit
    moved = np.flatnonzero(away)
    if len(moved):
        t_mis = np.where(away & hits.hit, np.linalg.norm(O + np.where(hits.hit, hits.t, 0.0)[:, None] * D - mis_O,
                                                         axis=1), t_limit)
        t_start = np.linalg.norm(O[moved] - mis_O[moved], axis=1)
    # a. Lamps with extent in front of the hit (they never block, as in Cycles).
    for index in ctx.extra["hittable"]:
        light = ctx.lights[index]
        if not light.is_(LAMP):                   # emitters and the world are found below
            continue
        lh = light.hit(O, D, t_limit)
        found, radiance, pdf_l = lh.hit, lh.radiance, lh.pdf
        if len(moved):
            # The lamp as the light samples at mis_O see it (a round lamp with soft falloff is a disk facing that
            # point), met on this stretch of the line, past O: its pdf from there, the radiance it sends along D.
            seen = light.hit(mis_O[moved], D[moved], t_mis[moved])
            past = seen.hit & (seen.t > t_start)
            found, radiance, pdf_l = found.copy(), radiance.copy(), pdf_l.copy()
            found[moved] = past
            radiance[moved] = np.where(past[:, None], seen.radiance, 0.0)
            pdf_l[moved] = np.where(past, seen.pdf, 0.0)
        if not found.any():
            continue
        w = np.where(use_mis, power_heuristic(pdf_b, light_count(ctx, light) * pdf_l), 1.0)
        light_L += radiance * w[:, None]
    # b. An emissive surface the ray hits: its emission, weighed against the emitters' own samples.
    struck = np.flatnonzero(hits.hit)
    emitters = ctx.extra.get("emitters")
    if len(struck) and ctx.extra.get("emissive", False):
        where = surface_at_hits(ctx.geometry, hits.prim[struck], hits.u[struck], hits.v[struck], O[struck],
                                D[struck], hits.t[struck])
        # (Each material's emission as its light samples see it: head-on, so that both strategies of
        #  MIS weigh the same radiance; a coat tint's change with angle is seen by the camera only.)
        emitted = ctx.materials.emission[where.material]
        textured = ctx.materials.graph_emits[where.material]
        if textured.any():                        # a texture's emission, evaluated where the ray landed
            rows = np.flatnonzero(textured)
            emitted = emitted.copy()
            emitted[rows] = graph_emission(ctx.geometry, ctx.materials, hits.prim[struck][rows], O[struck][rows],
                                           D[struck][rows], hits.t[struck][rows])
        if camera is not None and camera[struck].any():
            emitted = np.where((camera[struck] & ctx.geometry.hidden(hits.prim[struck], HOLDOUT))[:, None], 0.0,
                               emitted)
        pdf_l, n_l = np.zeros(len(struck)), 1
        if emitters is not None:
            index = emitters.index_of_prim(hits.prim[struck])
            known = index >= 0
            if known.any():
                origin = O if mis_O is None else mis_O
                pdf_l[known] = emitters.pdf_of_hits(origin[struck][known], index[known], D[struck][known],
                                                    t_mis[struck][known],
                                                    N=None if N is None else N[struck][known])
            n_l = light_count(ctx, emitters)
        w = np.where(use_mis[struck], power_heuristic(pdf_b[struck], n_l * pdf_l), 1.0)
        light_L[struck] += emitted * w[:, None]
    # c. The world, where the ray escapes: a constant world with weight 1, an image by MIS.
    world = ctx.extra.get("world_light")
    missed = np.flatnonzero(~hits.hit)
    if world is not None and world.lights and len(missed):
        L_world = world.radiance(D[missed])
        w = np.ones(len(missed))
        sampler = ctx.extra.get("world_sampler")
        if sampler is not None:
            w = np.where(use_mis[missed], power_heuristic(pdf_b[missed],
                         light_count(ctx, sampler) * sampler.pdf(D[missed])), 1.0)
        light_L[missed] += L_world * w[:, None]
    return light_L


def textured_samples(ctx: Context, emitters, points: np.ndarray, ls):
    """The emitters' samples `ls` of points (n, 3), with what each textured triangle emits where its sample
    landed (its node graph evaluated there) in place of the triangle's estimate: a LightSample with (n, 3) colour."""
    color = np.array(np.broadcast_to(ls.color, (len(points), 3)))
    rows = np.flatnonzero(emitters.textured[ls.emitter] & (ls.strength > 0.0))
    if len(rows):
        color[rows] = graph_emission(ctx.geometry, ctx.materials, emitters.prim[ls.emitter[rows]], points[rows],
                                     ls.L[rows], ls.distance[rows])
    return ls._replace(color=color)


def graph_emission(geometry, materials, prim: np.ndarray, O: np.ndarray, D: np.ndarray, t: np.ndarray) -> np.ndarray:
    """What the surfaces at O + t D on triangles prim (n,) int64 emit back along -D (n, 3) float64, by their
    materials' node graphs (a texture's emission), for a ray other than the camera's (graph.RAY_BOUNCE).

    The barycentrics come from the point itself (a light sample's point has no ray hit of its own), as in the
    C twin (direct.c graph_emission)."""
    if len(prim) == 0:
        return np.zeros((0, 3))
    V = geometry.triangle_data(prim, smooth=False).corners
    u, v = barycentrics(V, O + t[:, None] * D)
    where = surface_at_hits(geometry, prim, u, v, O, D, t)
    return materials.shade(where.material, where.N, -D, where, geometry, graph_.RAY_BOUNCE).emission


def barycentrics(V: np.ndarray, P: np.ndarray) -> tuple:
    """The barycentrics (u, v) (n,) float64 of points P (n, 3) in the planes of triangles V (n, 3, 3): P = (1 - u
    - v) V0 + u V1 + v V2 for points on them (the nearest such point otherwise)."""
    e1, e2, d = V[:, 1] - V[:, 0], V[:, 2] - V[:, 0], P - V[:, 0]
    d11, d12, d22 = (np.einsum("ij,ij->i", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    p1, p2 = np.einsum("ij,ij->i", d, e1), np.einsum("ij,ij->i", d, e2)
    det = d11 * d22 - d12 * d12
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(det > 0.0, (d22 * p1 - d12 * p2) / det, 1.0 / 3.0)
        v = np.where(det > 0.0, (d11 * p2 - d12 * p1) / det, 1.0 / 3.0)
    return u, v


# The sampling dimensions of the BSDF-sampled direction (2D) and of the closure it picks (core/sampling).
BSDF_DIMENSION = 2


class BsdfRay(NamedTuple):
    """The BSDF-sampled rays of the hits that traced one, and what they hit (a path continues from there).

    rows (k,) int64 the hits that traced a ray; O, D (k, 3) their origins and unit directions; hits: the
    tracer's Hits of them; weight (k, 3) f cos / pdf; kind (k,) int32 the sampled closure's BSDF kind;
    delta (k,) bool whether it was a delta closure; transmit (k,) bool whether it went through the surface;
    pdf (k,) the pdf MIS weighs what the ray finds with (inf: none); seen_as (k,) int64 the ray's kind, the
    HIDDEN_FROM_* bit of the objects it passes (ray_kind); mis_O, mis_N (k, 3) the origin and light-tree normal
    that MIS measures the light pdfs from (those of the path's last real bounce: O and its tree normal, unless the
    ray went straight through a transparent surface)
    """

    rows: np.ndarray
    O: np.ndarray
    D: np.ndarray
    hits: object
    weight: np.ndarray
    kind: np.ndarray
    delta: np.ndarray
    transmit: np.ndarray
    pdf: np.ndarray = None
    seen_as: np.ndarray = None
    mis_O: np.ndarray = None
    mis_N: np.ndarray = None


def closures_left_out(kind: np.ndarray, hidden: np.ndarray) -> np.ndarray:
    """Which closures (n, K) bool a light sample leaves out when it is on an object hidden from some kinds of ray
    (Cycles' rule for an emitter's Ray Visibility, by closure type): closures of the diffuse type if it is hidden
    from diffuse rays, of the glossy type if from glossy rays, of the transmission type if from transmission rays,
    glass only if from both glossy and transmission rays (a BSDF ray of such a closure could never find the
    object, so its light samples do not count for it either).

    kind: (n, K) int the closures' BSDF kinds; hidden: (n,) int each sample's object's HIDDEN_FROM_* bits.
    """
    bits = np.asarray(hidden, np.int64)[:, None]
    flags = materials_.flags_of(kind)
    F = materials_.BSDFFlags
    both = HIDDEN_FROM_GLOSSY | HIDDEN_FROM_TRANSMISSION
    return ((((flags & F.DIFFUSE_TYPE) != 0) & ((bits & HIDDEN_FROM_DIFFUSE) != 0))
            | (((flags & F.GLOSSY_TYPE) != 0) & ((bits & HIDDEN_FROM_GLOSSY) != 0))
            | (((flags & F.TRANSMISSION_TYPE) != 0) & ((bits & HIDDEN_FROM_TRANSMISSION) != 0))
            | (((flags & F.GLASS_TYPE) != 0) & ((bits & both) == both)))


def lets_light_through(shader) -> np.ndarray:
    """Which hits have a closure that takes light from behind the surface by light samples (a transmission that
    is not a delta: rough glass): (m,) bool. Their light samples come from both sides (smooth glass is a delta:
    only its BSDF rays find light)."""
    flags = materials_.flags_of(shader.closures.kind)
    F = materials_.BSDFFlags
    return (((flags & F.TRANSMISSION) != 0) & ((flags & F.SINGULAR) == 0)).any(axis=1)


def tree_normals(settings, surface, refracts: np.ndarray) -> np.ndarray:
    """The normals (m, 3) float64 the light tree weighs the emitters by at the hits: the shading normal N, below
    whose horizon no light sample counts (N.L clamped at 0); zero (unknown: light from every side) where a
    closure lets light through from behind, or where N.L is not clamped."""
    if not settings.clamp_n_dot_l:
        return np.zeros_like(surface.N)
    return np.where(refracts[:, None], 0.0, surface.N)


def wants_bsdf_ray(ctx: Context, shader) -> np.ndarray:
    """Which hits trace a BSDF-sampled ray: all where emitters or the world light the scene, else those
    with a closure other than Lambert (a glossy lobe that light samples of a large lamp find poorly)."""
    kind = shader.closures.kind
    glossy = ((kind >= 0) & ~materials_.has(kind, materials_.BSDFFlags.DIFFUSE)).any(axis=1)
    return glossy | bool(ctx.extra.get("bsdf_everywhere", False))


def light_count(ctx: Context, light) -> int:
    """Samples per hit of `light`: 1 for a light without extent or for the inspector's one sample, else
    the settings' light samples."""
    return 1 if light.delta or ctx.light_numbers is not None else max(1, int(ctx.settings.light_samples))


def light_numbers(ctx: Context, light, index: int, pixel: np.ndarray, number: np.ndarray, m: int,
                  offset: int = 0) -> np.ndarray:
    """The light's unit-square numbers for m samples (and a third for lights that pick, e.g. a triangle):
    zeros for a light without extent, the inspector's fixed point, or the light's progressive pattern
    (its dimensions shifted by `offset` at a path's later vertices)."""
    width = getattr(light, "random_numbers", 2)
    if light.delta:
        return np.zeros((m, width))
    if ctx.light_numbers is not None:
        fixed = np.zeros(width)
        fixed[:2] = np.asarray(ctx.light_numbers[index], np.float64)
        fixed[2:] = 0.5
        return np.broadcast_to(fixed, (m, width))
    dimension = 16 + 4 * index + offset
    u = sampling.sample_2d(ctx.settings.seed, pixel, number, dimension=dimension)
    if width == 2:
        return u
    pick = sampling.sample_2d(ctx.settings.seed, pixel, number, dimension=dimension + 2)[:, :1]
    return np.concatenate([u, pick], axis=1)


def camera_hits(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, recorder: Recorder,
                limit=np.inf) -> tuple:
    """What camera rays O, D (n, 3) up to t_max (n,) meet: (L (n, 3) the world where they escape, where the
    camera sees it, plus the lamps with extent they pass, each ray's capped at `limit` (sample clamping); the
    tracer's hits; the hit rows (m,) int64; the hits' Surface, or None when nothing was hit)."""
    s = ctx.settings
    # 1. The nearest hit of each camera ray (t), past objects hidden from the camera.
    found = nearest_seen(ctx, O, D, t_max)
    hit = np.flatnonzero(found.hit)
    # 2. What rays that hit nothing see: the world, where it is visible to the camera.
    L_out = np.zeros((len(O), 3))
    world = ctx.extra.get("world_light")
    if world is not None and world.camera and not s.transparent_background:
        missed = np.flatnonzero(~found.hit)
        L_out[missed] = world.radiance(D[missed])
    # 3. Lamps seen by the camera in front of what it hits (area lights, round lights).
    L_out += lamps_seen(ctx, O, D, np.where(found.hit, found.t, t_max))
    # What the camera sees itself is a direct contribution (Clamp Direct).
    if np.isfinite(limit):
        L_out = clamp_.clamped(L_out, None, limit)
    if len(hit) == 0:
        recorder.hits(O, D, None, found.hit)
        return L_out, found, hit, None
    # The surface at each hit: I, Ng, N.
    surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit], vectors.gather(O, hit),
                              vectors.gather(D, hit), found.t[hit], flat_only=not s.smooth_normals)
    recorder.hits(O, D, surface, found.hit)
    return L_out, found, hit, surface


def nearest_seen(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, kind=HIDDEN_FROM_CAMERA):
    """The nearest hits (the tracer's Hits) of rays O, D (n, 3) up to t_max (n,) on the objects these rays see: a
    ray goes on past the triangles of objects hidden from its kind (Object > Visibility > Ray Visibility), as if
    they were not there; t stays the distance from O. kind: the rays' HIDDEN_FROM_* bit, one int or (n,) int
    (camera rays by default; ray_kind gives a bounce's)."""
    geometry = ctx.geometry
    found = geometry.tracer.intersect(O, D, t_max)
    kind = np.broadcast_to(np.asarray(kind, np.int64), (len(O),))
    if not geometry.hides(int(np.bitwise_or.reduce(kind)) if len(kind) else 0):
        return found
    hit, t, prim, u, v = (np.array(array) for array in found)
    rows = np.flatnonzero(hit & geometry.hidden(prim, kind))
    while len(rows):
        # On from just past the hidden triangle, for what is left of the ray.
        surface = surface_at_hits(geometry, prim[rows], u[rows], v[rows], O[rows], D[rows], t[rows])
        side = np.where(np.einsum("ij,ij->i", surface.Ng, D[rows]) < 0.0, -1.0, 1.0)
        P = surface.I + (shadows.error_bound(surface.I, surface.vertices) * side)[:, None] * surface.Ng
        gone = np.einsum("ij,ij->i", P - O[rows], D[rows])
        again = geometry.tracer.intersect(P, D[rows], t_max[rows] - gone)
        hit[rows], t[rows], prim[rows] = again.hit, np.where(again.hit, gone + again.t, np.inf), again.prim
        u[rows], v[rows] = again.u, again.v
        rows = rows[again.hit & geometry.hidden(again.prim, kind[rows])]
    return type(found)(hit, t, prim, u, v)


def goes_through(kind: np.ndarray, transmit: np.ndarray) -> np.ndarray:
    """Which sampled directions count as going through the surface (Cycles' LABEL_TRANSMIT): a diffuse closure's
    by its class (a Lambert reflects, a translucent surface transmits), any other's by the side of the face it
    leaves to, `transmit` (k,) bool. kind: (k,) int the sampled closures' BSDF kinds. Returns (k,) bool."""
    flags = materials_.flags_of(kind)
    F = materials_.BSDFFlags
    diffuse = (flags & F.DIFFUSE) != 0
    return np.where(diffuse, (flags & F.TRANSMISSION) != 0, transmit)


def ray_kind(kind: np.ndarray, transmit: np.ndarray, previous) -> np.ndarray:
    """The kind of the rays a bounce sends, as the HIDDEN_FROM_* bit (k,) int64 of the objects they pass (Cycles'
    path_state_ray_visibility): a ray through the surface (goes_through) is a transmission ray, a diffuse
    reflection's a diffuse ray, any other reflection's (glossy, mirror) a glossy ray; straight through a
    Transparent closure the ray keeps the kind of the ray that arrived, `previous` (int or (k,) int).

    kind: (k,) int the sampled closures' BSDF kinds; transmit: (k,) bool whether each ray went through the face.
    """
    F = materials_.BSDFFlags
    reflected = np.where(materials_.has(kind, F.DIFFUSE), HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY)
    bounced = np.where(goes_through(kind, transmit), HIDDEN_FROM_TRANSMISSION, reflected)
    return np.where(materials_.has(kind, F.STRAIGHT), previous, bounced).astype(np.int64)


def lamps_seen(ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray) -> np.ndarray:
    """The radiance (n, 3) of lamps with extent that camera rays meet before t_max (lamps never block)."""
    seen = np.zeros((len(O), 3))
    for index in ctx.extra.get("camera_lamps", ()):
        seen += ctx.lights[index].hit(O, D, t_max).radiance
    return seen
