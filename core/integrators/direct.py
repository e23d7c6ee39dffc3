"""Direct lighting: the lecture's ray tracer. What a camera ray sees where it hits a surface.

For each camera ray, the nearest hit I with its face normal Ng and shading normal N (flipped towards the viewer)
and the material there (core/materials: its closures and what it emits); then the light the hit emits itself and
the light that reaches it straight from a lamp, an emitter or the world, by light samples with shadow rays and,
where lights with extent can be found that way, one BSDF-sampled ray, weighed by multiple importance sampling
(core/integrators/vertex.py shade_vertex, which every integrator lights its hits with):

    L_out += f(wo, L) max(N.L, 0) * E_normal * V * w_light

For the Lambert BSDF f = albedo / pi: the lecture's absorption. RenderSettings.light_sampling "light" or "bsdf"
keeps one strategy alone (the lecture switch that shows why MIS); the other lecture switches of RenderSettings
undo the lecture's choices one at a time, to show why it makes them. Where rays go on through transparent
surfaces, the path tracer with no bounces but those renders instead (integrators.for_render).

Its compiled twin is core/integrators/direct.c: the same steps in the same order, per sample.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .. import vectors
from ..materials import graph as graph_
from . import clamp as clamp_
from . import features as features_
from . import lightgroups, lightpasses, shader_rays
from . import passes as passes_
from .base import Context, Integrator, Radiance, Recorder
from .rays import camera_cones, camera_hits
from .vertex import PathState, shade_vertex


class DirectLighting(Integrator):
    """Light that reaches a surface straight from a lamp, an emitter or the world: one shadow ray per
    light sample, and one BSDF-sampled ray per hit where lights can be found that way."""

    name: ClassVar[str] = "direct"

    def radiance(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                 sample: np.ndarray, recorder: Recorder, times=None) -> Radiance:
        """Integrator.radiance; times: (n,) the camera rays' times in the shutter when objects move (the hits'
        shadow and BSDF rays meet them where they are then), or None."""
        # 1-3. The camera rays' hits and surfaces, the world where they escape, the lamps they pass.
        direct_cap = clamp_.limits(ctx.settings)[0]
        groups = lightgroups.tally(ctx, len(O))
        L_out, found, hit, surface = camera_hits(ctx, O, D, t_max, recorder, direct_cap, groups, times=times)
        # The denoising features (features.py): what the camera sees itself, then at its hits.
        feats = features_.Features(len(O)) if ctx.settings.denoising_features else None
        if feats is not None:
            feats.albedo += L_out
        # The first-hit passes (passes.py): what the camera rays pass and escape to, then at their hits.
        data = passes_.DataPasses.of(ctx, sample)
        if data is not None:
            passes_.along_ray(ctx, data, np.arange(len(O)), np.ones((len(O), 3)), O, D, found.hit,
                              np.where(found.hit, found.t, t_max))
        if surface is None:
            return Radiance(L_out, found.hit, 0, groups=None if groups is None else groups.L,
                            features=None if feats is None else feats.stacked(), passes=data)
        D_hit = vectors.gather(D, hit)
        # 4. The light each hit sends towards the camera (each contribution capped by Clamp Direct).
        parts = lightpasses.FirstHitParts(len(hit)) if lightpasses.wanted(ctx.settings.passes) else None
        hit_groups = lightgroups.tally(ctx, len(hit))
        emitted, finds = (np.zeros((len(hit), 3)), np.zeros((len(hit), 3))) if feats is not None else (None, None)
        cone, spread = camera_cones(ctx, vectors.gather(O, hit), D_hit)     # (camera rays: a Bump's step)
        # The camera rays' paths, cones and all: the hits' shaders read them, and their BSDF and shadow rays carry
        # them on (the footprint at the hit, the spread kept: rays.path_after), as Cycles' ray differentials do.
        camera_paths = graph_.light_paths(len(hit), cone=cone, spread=spread)
        shader = ctx.materials.shade(surface.material, surface.N, -D_hit, surface, ctx.geometry, path=camera_paths,
                                     rays=shader_rays.for_hits(ctx, surface, pixel[hit], sample[hit]))
        L_hit, shadow_rays, _ = shade_vertex(ctx, surface, -D_hit, pixel[hit], sample[hit], recorder,
                                             PathState(light_path=camera_paths, limit=direct_cap), parts=parts,
                                             groups=hit_groups,
                                             shader=shader, emitted=emitted, found=finds)
        if feats is not None:
            one = np.ones((len(hit), 3))
            looking, feature_throughput = features_.at_vertex(feats, hit, np.ones(len(hit), bool), one, one, shader,
                                                              emitted)
            features_.found(feats, hit, looking, feature_throughput, finds)
        if data is not None:
            passes_.at_vertex(ctx, data, np.arange(len(hit)), hit, 0, surface, shader, -D_hit, np.ones((len(hit), 3)),
                              pixel[hit], sample[hit])
        L_out[hit] += L_hit
        if groups is not None:
            groups.add_rows(hit, hit_groups)
        light = None
        if parts is not None:                    # the light passes: all of it direct (core/integrators/lightpasses.py)
            light = np.zeros((len(O), len(lightpasses.LIGHT_PASSES), 3))
            light[hit, :lightpasses.KINDS] = parts.gathered
        return Radiance(L_out, found.hit, shadow_rays, light=light, groups=None if groups is None else groups.L,
                        features=None if feats is None else feats.stacked(), passes=data)
