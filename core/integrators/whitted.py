"""Whitted ray tracing: the lecture's recursion, perfect mirrors and glass followed exactly, direct light elsewhere.

Turner Whitted's tracer (1980), as the lecture's closing code writes it with MAXDEPTH: at every hit,
the light the surface emits and the direct light of every lamp (shadow rays, the direct tracer's
light samples), and for each perfectly specular closure a new ray, traced recursively:

    mirror:  L += tint x L(reflected ray)
    glass:   L += R x L(reflected ray) + T x L(refracted ray)      (R + T = 1 for clear glass)

R is the Fresnel reflectance: exact for a dielectric, or Schlick's approximation
R0 + (1 - R0)(1 - cos)^5 (RenderSettings.fresnel, a lecture switch); past the critical angle all light
is reflected (total internal reflection), and a ray leaving glass bends by 1 / IOR. Nothing is random
but the light samples of lamps with extent: both branches of glass are followed, so a pixel needs no
samples beyond anti-aliasing. Rough surfaces get direct light only (no glossy reflections of other
objects): that is what distinguishes Whitted's tracer from path tracing.

Participating media (core/volumes), as the next lecture adds them: every ray the recursion traces (camera, mirror,
refraction) carries its volume stack (the camera's start-up walk, then entered and left where a ray goes through a
surface) and passes volume-only boundaries as if they were not there; over its way to the surface it meets

    L = T(t) L(surface)  +  emission's integral  +  single scattering,      T(t) = exp(-integral of sigma_t)

Beer-Lambert's T (ratio tracking through heterogeneous media) on the light of the surface, the world and the lamps it
sees, the media's emission in closed form (volumes.emitted), and the light of the lamps scattered towards it by the
phase function at points in the media (volume.in_scattering: the direct tracer's and path tracer's estimate for
camera rays). Shadow rays keep T of their way to the lamp. Light is scattered once only: Whitted has no diffuse
bounces, so neither has it volume bounces.

The recursion stops after max_bounces bounces (glossy_bounces reflections, transmission_bounces
refractions), or where a branch carries less than CUTOFF of the light (its children are dropped: a
small, stated loss). Rays that escape see the world. This integrator runs on the Python reference path.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .. import materials as materials_
from ..visibility import HIDDEN_FROM_CAMERA, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION
from ..geometry.surface import surface_at_hits
from ..materials import glass as glass_
from ..materials import graph as graph_
from ..materials import microfacet as mf
from .. import volumes
from . import features as features_
from . import lightgroups, shader_rays, shadows
from . import passes as passes_
from . import volume as volume_
from .base import Context, Integrator, Radiance, Recorder, check_stop
from .path import through_transparent
from .rays import camera_back, camera_cones, camera_media, lamps_seen, nearest_seen
from .shadows import spawn_ray
from .vertex import PathState, media_beyond, shade_vertex

# A branch whose throughput falls below this in every channel is not followed.
CUTOFF = 1e-4


def schlick(cos_i: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Schlick's approximation of the Fresnel reflectance, R0 + (1 - R0)(1 - cos)^5, with the cosine on the
    denser side when leaving it (so total internal reflection still happens): (n,)."""
    R0 = mf.F0_from_ior(eta)
    sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta)
    cos = np.where(eta < 1.0, np.sqrt(np.maximum(1.0 - sin_t2, 0.0)), cos_i)
    return np.where(sin_t2 >= 1.0, 1.0, R0 + (1.0 - R0) * (1.0 - cos) ** 5)


class WhittedTracing(Integrator):
    """Recursive perfect reflection and refraction with direct light at every hit (module docstring)."""

    name: ClassVar[str] = "whitted"

    def radiance(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                 sample: np.ndarray, recorder: Recorder) -> Radiance:
        s = ctx.settings
        n = len(O)
        L_out = np.zeros((n, 3))
        owner = np.arange(n)
        throughput = np.ones((n, 3))
        glossy = np.zeros(n, np.int64)
        transmission = np.zeros(n, np.int64)
        camera_hit = np.zeros(n, bool)
        shadow_rays = 0
        world = ctx.extra.get("world_light")
        depth = 0
        groups = lightgroups.tally(ctx, n)          # each ray's light by source (core/integrators/lightgroups.py)
        feats = features_.Features(n) if s.denoising_features else None     # (of the camera's hits alone)
        data = passes_.DataPasses.of(ctx, sample)       # the first-hit passes (passes.py): of the camera's rays alone
        crossing = np.zeros(0, bool)            # which of this depth's rays went through a surface (none at 0)
        cone, spread = camera_cones(ctx, O, D)     # each ray's cone (graph.LightPath), widened along the specular chain
        media = ctx.extra.get("media")
        inside = None if media is None else camera_media(ctx, O)     # each ray's volume stack (core/volumes)
        while len(owner):
            check_stop(ctx)
            # 1. The rays of this depth: what they hit past volume-only boundaries, and on the way there the lamps
            #    they pass and the light their media emit and scatter towards them (T: what the media let through).
            #    (Each ray passes the objects hidden from its kind: the camera's, a mirror reflection's (glossy), a
            #    refraction's (transmission); rays.nearest_seen.)
            kind = HIDDEN_FROM_CAMERA if depth == 0 else np.where(crossing, HIDDEN_FROM_TRANSMISSION, HIDDEN_FROM_GLOSSY)
            seen = lightgroups.tally(ctx, len(owner))     # what these rays see, by source
            # (the camera's rays write the features and first-hit passes of the media they cross as they go)
            looks = dict(feats=feats, data=data) if depth == 0 else {}
            found, L_way, T, inside, rays, L_scattered = self.along_ray(ctx, O, D, t_max, kind, inside, throughput,
                                                                        pixel[owner], sample[owner], depth, recorder,
                                                                        seen, **looks)
            shadow_rays += rays
            if depth == 0:
                camera_hit = found.hit.copy()
            else:
                t_hit = np.where(found.hit, found.t, np.inf)
                for kind, mask in (("reflect", ~crossing), ("refract", crossing)):
                    if mask.any():
                        recorder.rays(kind, O[mask], D[mask], t_hit[mask])
            missed = np.flatnonzero(~found.hit)
            if world is not None and world.camera and not (depth == 0 and s.transparent_background):
                P = graph_.PATH                     # (each ray's path: the world's graph is evaluated for it)
                flags = (P["camera"] if depth == 0 else
                         np.where(crossing[missed], P["transmit"], P["reflect"]) | P["glossy"] | P["singular"])
                L_world = world.radiance_seen(D[missed], graph_.light_paths(len(missed), flags, depth, 0,
                                                                            glossy[missed], transmission[missed]))
                L_world = L_world * T[missed]
                np.add.at(L_out, owner[missed], throughput[missed] * L_world)
                if seen is not None:
                    seen.add(missed, L_world, seen.groups.world)
            np.add.at(L_out, owner, throughput * L_way)
            if groups is not None:
                groups.add_rows(owner, seen, throughput)
            throughput = throughput * T                 # (what reaches the hits through the media)
            if feats is not None and depth == 0:
                feats.albedo += L_out - L_scattered     # what the camera sees itself (not what media scatter to it)
            if data is not None and depth == 0 and media is None:     # (with media: along_ray, piece by piece)
                passes_.along_ray(ctx, data, owner, np.ones((n, 3)), O, D, found.hit, np.where(found.hit, found.t, t_max))
            hit = np.flatnonzero(found.hit)
            if len(hit) == 0:
                break
            surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit], O[hit], D[hit],
                                      found.t[hit], flat_only=not s.smooth_normals)
            if depth == 0:
                recorder.hits(O, D, surface, found.hit)
            # 2. Emission and direct light at every hit (light samples only: no BSDF rays, no MIS).
            wo = -D[hit]
            rows = owner[hit]
            # (the Light Path node: a camera ray, or a mirror's or glass's singular ray, reflected or through)
            P = graph_.PATH
            flags = (P["camera"] if depth == 0 else
                     np.where(crossing[hit], P["transmit"], P["reflect"]) | P["glossy"] | P["singular"])
            light_path = graph_.light_paths(len(hit), flags, depth, 0, glossy[hit], transmission[hit],
                                            cone=cone[hit], spread=spread[hit])
            state = PathState(dimension=depth * (1 << 16), light_path=light_path, bounce=depth,
                              inside=None if inside is None else inside[hit])     # (shadow rays keep T too)
            hit_groups = lightgroups.tally(ctx, len(hit))
            L_hit, rays, _ = shade_vertex(ctx, surface, wo, pixel[rows], sample[rows], recorder, state,
                                          light_samples_only=True, groups=hit_groups)
            shadow_rays += rays
            np.add.at(L_out, rows, throughput[hit] * L_hit)
            if groups is not None:
                groups.add_rows(rows, hit_groups, throughput[hit])
            recorder.path_vertex(depth, rows, surface, throughput[hit], L_hit)
            # 3. The specular closures' rays: a mirror's reflection, glass's reflection and refraction.
            shader = ctx.materials.shade(surface.material, surface.N, wo, surface, ctx.geometry, light_path,
                                         rays=shader_rays.for_hits(ctx, surface, pixel[rows], sample[rows], depth * (1 << 16)))
            if feats is not None and depth == 0:
                # (throughput: what the media let through to the hit, as the path tracer's camera vertex)
                features_.at_vertex(feats, rows, np.ones(len(hit), bool), throughput[hit], np.ones((len(hit), 3)),
                                    shader, shader.emission)
            if data is not None and depth == 0:
                passes_.at_vertex(ctx, data, np.arange(len(hit)), rows, 0, surface, shader, wo, throughput[hit],
                                  pixel[rows], sample[rows])
            children = self.specular_rays(s, surface, shader, wo, throughput[hit], glossy[hit], transmission[hit])
            if children is None or depth + 1 > s.max_bounces:
                break
            index, O, D, throughput, glossy, transmission = children
            # (each child leaves with the footprint at its hit and the spread kept: rays.path_after)
            cone, spread = graph_.footprints(light_path, found.t[hit])[index], spread[hit][index]
            crossing = np.einsum("ij,ij->i", surface.Ng[index], D) < 0.0
            if inside is not None:              # (a refraction enters or leaves the medium its surface bounds)
                inside = media_beyond(ctx, surface, index, inside[hit][index], crossing)
            owner = rows[index]
            t_max = np.full(len(owner), np.inf)
            depth += 1
        return Radiance(L_out, camera_hit, shadow_rays, groups=None if groups is None else groups.L,
                        features=None if feats is None else feats.stacked(), passes=data)

    def along_ray(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, kind, inside, throughput,
                  pixel: np.ndarray, sample: np.ndarray, depth: int, recorder: Recorder, seen=None, feats=None,
                  data=None) -> tuple:
        """What rays O, D (k, 3) up to t_max (k,) of `kind` (HIDDEN_FROM_* bit, int or (k,)) meet, past volume-only
        boundaries: (the Hits of their first surface, t from O; the light L (k, 3) that reaches O on the way: lamps
        passed, and the media's emission and single scattering; T (k, 3) what the media let through to the surface
        or the world; the stacks (k, V) there, or None without media; shadow rays traced; the part (k, 3) of L the
        media scattered). inside: (k, V) the stacks the rays start with, or None; throughput (k, 3) what they carry
        (the scattering's channel odds); seen: a lightgroups.GroupLight of the k rays that receives L by source, or
        None. feats, data: for the camera's rays (the k rays are the camera's), its denoising Features and first-hit
        DataPasses, which the media write into piece by piece as the path tracer's camera rays do (features.in_media,
        passes.along_ray), or None."""
        media = ctx.extra.get("media")
        found = nearest_seen(ctx, O, D, t_max, kind)
        T = np.ones((len(O), 3))
        if media is None:
            lamps = lamps_seen(ctx, O, D, np.where(found.hit, found.t, t_max), seen, escaped=~found.hit)
            return found, lamps, T, None, 0, np.zeros((len(O), 3))
        n = len(O)
        kind = np.broadcast_to(np.asarray(kind, np.int64), (n,))
        hit, t, prim, u, v = np.zeros(n, bool), np.full(n, np.inf), np.zeros(n, np.int64), np.zeros(n), np.zeros(n)
        L, inside, o, gone = np.zeros((n, 3)), inside.copy(), O.copy(), np.zeros(n)     # (o: each piece's start)
        S = np.zeros((n, 3))                                    # (the part of L the media scatter)
        alive, step, shadow_rays = np.arange(n), found, 0
        for piece in range(shadows.VOLUME_BOUNDS_MAX + 1):
            # a. The stretch to the surface met (or on to the world): lamps, emission and scattering, seen through T.
            end = np.where(step.hit, step.t, t_max[alive] - gone[alive])
            stretch = media.along(inside[alive], o[alive], D[alive])
            part = volume_.part_tally(seen, len(alive))
            emitted = volumes.emitted(stretch, end)
            lightgroups.add_emitted(part, np.arange(len(alive)), emitted, stretch)
            light = lamps_seen(ctx, o[alive], D[alive], end, part, escaped=~step.hit, sigma=stretch) + emitted
            if media.scatters:
                scattered, rays = volume_.in_scattering(ctx, o[alive], D[alive], end, inside[alive],
                                                        throughput[alive] * T[alive], pixel[alive], sample[alive],
                                                        depth * (1 << 16) + piece * (1 << 24), depth,
                                                        through_transparent, recorder, part)
                light, shadow_rays = light + scattered, shadow_rays + rays
                S[alive] += T[alive] * scattered
            L[alive] += T[alive] * light
            if feats is not None:           # (a scattering medium's albedo, and the odds the path passes it)
                features_.in_media(feats, stretch, end, camera_back(ctx), owner=alive, throughput=T[alive])
            if data is not None:            # (lamps passed, the media's emission, the world through them)
                passes_.along_ray(ctx, data, alive, T[alive], o[alive], D[alive], step.hit, end, stretch)
            if seen is not None:
                seen.add_rows(alive, part, T[alive])
            T[alive] *= stretch.transmittance(np.where(step.hit, step.t, np.inf))
            # b. The surfaces met: a volume-only boundary is crossed (into or out of its medium), any other is the hit.
            met = np.flatnonzero(step.hit)
            rows = alive[met]
            surface = surface_at_hits(ctx.geometry, step.prim[met], step.u[met], step.v[met], o[rows], D[rows],
                                      step.t[met])
            cross = media.boundary[surface.material] & (piece < shadows.VOLUME_BOUNDS_MAX)
            stop = rows[~cross]
            hit[stop], t[stop], prim[stop] = True, gone[stop] + step.t[met][~cross], step.prim[met][~cross]
            u[stop], v[stop] = step.u[met][~cross], step.v[met][~cross]
            alive = rows[cross]
            if len(alive) == 0:
                break
            inside[alive] = media.crossed(inside[alive], surface.material[cross], surface.backfacing[cross],
                                          np.ones(len(alive), bool), media.objects_of(ctx.geometry, surface.prim[cross]))
            # c. On from just past the boundary, for what is left of the ray.
            P = spawn_ray(surface.I[cross], surface.Ng[cross], D[alive],
                          shadows.error_bound(surface.I[cross], surface.vertices[cross]))
            gone[alive] += np.einsum("ij,ij->i", P - o[alive], D[alive])
            o[alive] = P
            step = nearest_seen(ctx, o[alive], D[alive], t_max[alive] - gone[alive], kind[alive])
        return type(found)(hit, t, prim, u, v, None), L, T, inside, shadow_rays, S

    def specular_rays(self, s, surface, shader, wo, throughput, glossy, transmission):
        """The child rays of every perfectly specular (singular) reflection and smooth glass closure: (hit index (k,), O (k, 3), D (k, 3), throughput
        (k, 3), glossy and transmission bounce counts (k,)), or None when there are none."""
        closures = shader.closures
        parts = []
        cos_i = np.clip(np.einsum("ij,ij->i", surface.N, wo), 0.0, 1.0)
        for slot in range(closures.kind.shape[1]):
            kind, weight = closures.kind[:, slot], closures.weight[:, slot]
            N = closures.N[:, slot]
            singular = materials_.has(kind, materials_.BSDFFlags.SINGULAR)
            mirror = np.flatnonzero(singular & materials_.reflective(kind))
            if len(mirror):
                R = 2.0 * cos_i[mirror, None] * N[mirror] - wo[mirror]
                parts.append((mirror, R, weight[mirror], 1, 0))
            glass = np.flatnonzero(singular & materials_.has(kind, materials_.BSDFFlags.GLASS_TYPE))
            if len(glass):
                p = closures.params[glass, slot]
                eta = p[:, mf.IOR]
                R_share, T_share = glass_.shares(p, cos_i[glass])
                if s.fresnel == "schlick":
                    F = schlick(cos_i[glass], eta)[:, None]
                    tir = (1.0 - (1.0 - cos_i[glass] ** 2) / eta ** 2) <= 0.0
                    R_share = np.where(tir[:, None], 1.0, F) * p[:, glass_.REFLECT_TINT:glass_.REFLECT_TINT + 3]
                    T_share = np.where(tir[:, None], 0.0, 1.0 - F) * p[:, glass_.TRANSMIT_TINT:glass_.TRANSMIT_TINT + 3]
                reflected = 2.0 * cos_i[glass, None] * N[glass] - wo[glass]
                refracted, exists = glass_.refract(wo[glass], N[glass], eta)
                parts.append((glass, reflected, weight[glass] * R_share, 1, 0))
                parts.append((glass[exists], refracted[exists], (weight[glass] * T_share)[exists], 0, 1))
        if not parts:
            return None
        index = np.concatenate([rows for rows, *_ in parts])
        D = np.concatenate([d for _, d, *_ in parts])
        weight = np.concatenate([w for _, _, w, *_ in parts])
        g = glossy[index] + np.concatenate([np.full(len(rows), a) for rows, _, _, a, _ in parts])
        t = transmission[index] + np.concatenate([np.full(len(rows), b) for rows, _, _, _, b in parts])
        tp = throughput[index] * weight
        keep = np.flatnonzero((tp.max(axis=1) > CUTOFF) & (g <= s.glossy_bounces) & (t <= s.transmission_bounces))
        if len(keep) == 0:
            return None
        index, D, tp, g, t = index[keep], D[keep], tp[keep], g[keep], t[keep]
        # Each ray leaves from a point safely off the surface, on the side it goes to.
        step = (shadows.error_bound(surface.I[index], surface.vertices[index]) if s.shadow_method == "robust"
                else np.full(len(index), s.epsilon))
        O = spawn_ray(surface.I[index], surface.Ng[index], D, step)
        return index, O, D / np.linalg.norm(D, axis=1)[:, None], tp, g, t
