"""Direct lighting: the lecture's ray tracer. What a camera ray sees where it hits a surface.

For each camera ray, the nearest hit I with its face normal Ng and shading normal N (flipped
towards the viewer), the material there (core/materials: its closures and what it emits); then
the light it emits itself, and for every light, and every sample of a light with extent:

    L_out += f(wo, L) max(N.L, 0) * E_normal * V          (core/materials, core/lights, shadows.py)

where E_normal = L_e / pdf is the light sample's irradiance at normal incidence and V the shadow
ray's verdict. For the Lambert BSDF f = albedo / pi: the lecture's absorption. Work is done only
where it matters: interpolated normals only for smooth triangles, shadow rays only for lights in
front of both N and the face, and only where the light sends something. The lecture switches of
RenderSettings undo these choices one at a time, to show why the lecture makes them.

Its compiled twin is core/integrators/direct.c: the same steps in the same order, per sample.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .. import materials as materials_
from .. import vectors
from ..geometry.surface import surface_at_hits
from ..sampling import sobol as sampling
from . import shadows
from .base import Context, Integrator, Radiance, Recorder


class DirectLighting(Integrator):
    """Light that reaches a surface straight from a lamp, with one shadow ray per light sample."""

    name: ClassVar[str] = "direct"

    def radiance(self, ctx: Context, O: np.ndarray, D: np.ndarray, t_max: np.ndarray, pixel: np.ndarray,
                 sample: np.ndarray, recorder: Recorder) -> Radiance:
        s = ctx.settings
        n = len(O)
        L_out = np.zeros((n, 3))
        # 1. The nearest hit of each camera ray (t), and the surface there: I, Ng, N.
        found = ctx.geometry.tracer.intersect(O, D, t_max)
        hit = np.flatnonzero(found.hit)
        if len(hit) == 0:
            recorder.hits(O, D, None, found.hit)
            return Radiance(L_out, found.hit, 0)
        D_hit = vectors.gather(D, hit)
        surface = surface_at_hits(ctx.geometry, found.prim[hit], found.u[hit], found.v[hit],
                                  vectors.gather(O, hit), D_hit, found.t[hit], flat_only=not s.smooth_normals)
        recorder.hits(O, D, surface, found.hit)
        # 2. The light each hit reflects towards the camera.
        L_hit, shadow_rays = self.shade(ctx, surface, -D_hit, pixel[hit], sample[hit], recorder)
        L_out[hit] = L_hit
        return Radiance(L_out, found.hit, shadow_rays)

    def shade(self, ctx: Context, surface, wo: np.ndarray, pixel: np.ndarray, sample: np.ndarray,
              recorder: Recorder):
        """Return (the radiance (m, 3) float64 each hit reflects towards wo, shadow rays traced).

        wo: (m, 3) float64 unit directions towards the viewer; pixel, sample: (m,) int64 each hit's
        keys for its random numbers.
        """
        s = ctx.settings
        m = len(surface.I)
        # 1. The material at each hit: its closures (BSDFs with weights) and the light it emits itself.
        shader = ctx.materials.shade(surface.material, surface.N, wo)
        recorder.shader(shader)
        L_out = shader.emission.copy()
        shadow_rays = 0
        offsets = shadows.error_bound(surface.I, surface.vertices) if s.shadow_method == "robust" else None
        for index, light in enumerate(ctx.lights):
            count = 1 if light.delta or ctx.light_numbers is not None else max(1, int(s.light_samples))
            cone = light.cone(surface.I)                   # shared by all the light's samples
            for j in range(count):
                # 1. Where does the light come from? One sample of the light's progressive pattern:
                #    camera sample s takes its points s*count .. s*count+count-1 (core/sampling), so
                #    the points of any number of camera samples together cover the light evenly.
                if light.delta:
                    u = np.zeros((m, 2))
                elif ctx.light_numbers is not None:
                    u = np.broadcast_to(np.asarray(ctx.light_numbers[index], np.float64), (m, 2))
                else:
                    u = sampling.sample_2d(s.seed, pixel, sample * count + j, dimension=16 + 4 * index)
                ls = light.sample(surface.I, u, cone)
                if not s.distance_attenuation:
                    ls = light.without_attenuation(ls, surface.I)
                # 2. The lecture's two tests: N.L > 0 (shading normal, the clamp) and Ng.L > 0 (the
                #    face normal decides whether the light can be visible; `visibility_normal`
                #    switches it). The terminator fix lifts smooth points onto the curved surface,
                #    where the face normal no longer decides; its shadow ray does.
                NL = np.einsum("ij,ij->i", surface.N, ls.L)
                NgL = np.einsum("ij,ij->i", surface.Ng, ls.L)
                facing = NgL > 0.0 if s.visibility_normal == "face" else NL > 0.0
                face_allows = facing | surface.smooth if s.terminator_fix else facing
                cosine = np.maximum(NL, 0.0) if s.clamp_n_dot_l else NL
                lit = (cosine != 0.0) & face_allows
                if s.shadow_rays_for_backfacing:
                    lit[:] = True                     # cast them anyway, to count what the lecture saves
                lit &= ls.strength > 0.0
                recorder.light_sample(index, count, ls, NL, NgL, cosine, face_allows, lit)
                rows = np.flatnonzero(lit)
                if len(rows) == 0:
                    continue
                # 3. One shadow ray per lit sample, from a point safely off the surface.
                rays = self.shadow_rays(s, surface, rows, ls, NL, NgL, offsets)
                seen = shadows.visible(ctx.geometry.tracer, rays)
                recorder.shadow_rays(index, count, rows, rays, seen)
                shadow_rays += len(rows)
                # 4. What gets through: f cos (the closures at L) E_normal / count, coloured by the light.
                part = materials_.Closures(*(array[rows] for array in shader.closures))
                f_cos, _ = materials_.eval_closures(part, wo[rows], ls.L[rows], signed_cosine=not s.clamp_n_dot_l)
                weight = ls.strength[rows] * (1.0 / count)
                value = (weight[:, None] * ls.color) * f_cos * seen[:, None]
                recorder.contribution(index, rows, value)
                L_out[rows] += value
        return L_out, shadow_rays

    @staticmethod
    def shadow_rays(s, surface, rows: np.ndarray, ls, NL: np.ndarray, NgL: np.ndarray, offsets) -> shadows.ShadowRays:
        """Return the shadow rays of the hits `rows` towards their light samples (robust or epsilon offsets)."""
        I = surface.I[rows]
        Ng = surface.Ng[rows]
        if s.terminator_fix:
            I = shadows.lift_terminator(surface, rows, NL[rows], NgL[rows], s.terminator_offset)
        elif s.shadow_rays_for_backfacing or s.visibility_normal != "face":
            # Switches that cast rays towards lights behind the face: offset to the light's side.
            Ng = Ng * np.where(NgL[rows] < 0.0, -1.0, 1.0)[:, None]
        if s.shadow_method == "robust":
            return shadows.robust_rays(I, Ng, offsets[rows], ls.position[rows], ls.L[rows], ls.distance[rows],
                                       s.reduce_t_max)
        return shadows.epsilon_rays(I, ls.L[rows], ls.distance[rows], s.epsilon, s.reduce_t_max)
