"""Shadow caustics: manifold next-event estimation (MNEE), as Cycles' Shadow Caustics.

A light sample seen from a shading point I on a caustics *receiver* (Object > Shading > Caustics > Receive Shadow
Caustics) is hidden behind glass: its shadow ray L meets a caustics *caster* (Cast Shadow Caustics) whose closure
refracts. An ordinary shadow ray sees the glass as opaque; the light that really arrives has been bent by the glass,
along a path I -> x1 -> ... -> xn -> light where every xi obeys Snell's law. MNEE finds that path (Hanika, Droske and
Fascione 2015, "Manifold Next Event Estimation"), for the lamps marked Light > Shadow Caustics.

1. Seed: the straight shadow ray from I towards the light point (or along the sun's direction D) collects the caster
   interfaces it crosses, at most MNEE_MAX_CAUSTIC_CASTERS, each on a smooth-shaded triangle mesh with a refractive
   closure (its relative index eta, looking from the receiver's side; for rough glass a microfacet normal offset h
   sampled from its distribution).
2. Walk: at each interface xi the generalised half vector H = -(wi + eta wo) / |wi + eta wo| (wi towards the receiver,
   wo towards the light, eta inverted where wi is inside) must lie along the shading normal N: its components in the
   tangent frame (s, t), less h, are the constraint C(x). Newton's method on the manifold: the block-tridiagonal
   derivative dC/dx is inverted, every xi steps by -beta dx in its tangent plane and is projected back onto its object
   by a ray from the previous vertex; beta starts at 0.1, doubles after a good step (to 1) and halves after a step
   that leaves the object or stops refracting; the walk ends when max |C| < MNEE_SOLVER_THRESHOLD, and fails after
   MNEE_MAX_ITERATIONS, at beta < MNEE_MINIMUM_STEP_SIZE or when a vertex no longer moves.
3. Weight: the receiver's f cos towards x1, the light's emission over its pdf in its own area measure (the sun: per
   solid angle), the generalised geometry term G = |N1.w0| / |x1 - I|^2 |det dx1/dx_light| (the transfer matrix of the
   chain, Jakob and Marschner 2012; clamped at 2 as Cycles does) and at each interface its transmittance (1 - F)
   (times the microfacet G term over the sampled density for rough glass), then a shadow ray from xn to the light.

This replaces the ordinary light sample of that light at that point (no MIS); where the seed finds no caster, or the
walk or its visibility checks fail, the ordinary light sample stays (whose shadow ray the glass stops). A caster's own
light samples of a caustics light from behind it (through the glass) are dropped, as Cycles does. Lamps: point and
spot (radius 0, a round disk or a sphere: the light point stays where it was sampled), area lamps with a spread (the
point held, its pdf from the last vertex in area measure) and sun lamps; area lamps of Spread 0 (a fixed direction in
Cycles) and the world are not walked (Primer warns).

Cycles' source: intern/cycles/kernel/integrator/mnee.h (kernel_path_mnee_sample and what it calls), called from
shade_surface.h integrate_surface_direct_light. Its compiled twin is core/integrators/mnee.c (one light sample at a
time, the same numbers; the culling of a caster's BSDF rays in core/integrators/path.c).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple, Optional

import numpy as np

from ..lights.base import walks
from ..materials import graph as graph_
from . import shadows

MNEE_MAX_ITERATIONS = 64
MNEE_MAX_INTERSECTION_COUNT = 10
MNEE_SOLVER_THRESHOLD = 0.001
MNEE_MINIMUM_STEP_SIZE = 0.0001
MNEE_MAX_CAUSTIC_CASTERS = 6
MNEE_MIN_DISTANCE = 0.001
MNEE_MIN_PROGRESS_DISTANCE = 0.0001
MNEE_MIN_DETERMINANT = 0.0001
MNEE_PROJECTION_DISTANCE_MULTIPLIER = 2.0
G_CLAMP = 2.0                                   # Cycles' clamp of the generalised geometry term

# WorldGeometry.instance_caustics bits: the object casts (refracts) or receives shadow caustics.
CASTER, RECEIVER = 1, 2


def refractive_kinds() -> np.ndarray:
    """The BSDF kinds (int array) Cycles' MNEE treats as a caster's refractive closure (CLOSURE_IS_REFRACTION or
    CLOSURE_IS_GLASS): smooth glass, rough GGX glass, rough Beckmann glass."""
    from ..materials.beckmann_glass import BeckmannGlass
    from ..materials.glass import Glass
    from ..materials.rough_glass import RoughGlass
    return np.array([Glass.kind, RoughGlass.kind, BeckmannGlass.kind])


def active(ctx) -> bool:
    """Whether a render of `ctx` walks: a caustics light that is walked, a caster and a receiver (Cycles' MNEE kernel
    feature and integrator.use_caustics)."""
    flags = ctx.geometry.instance_caustics
    return (len(flags) > 0 and bool((flags & CASTER).any()) and bool((flags & RECEIVER).any())
            and any(walks(light) for light in ctx.lights))


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products: (..., 3), (..., 3) -> (...)."""
    return np.einsum("...j,...j->...", a, b)


def unit(a: np.ndarray) -> tuple:
    """(a / |a|, |a|) row-wise: (..., 3) -> (..., 3), (...)."""
    length = np.sqrt(dot(a, a))
    return a / np.maximum(length, 1e-300)[..., None], length


def make_orthonormals(N: np.ndarray) -> tuple:
    """Two unit tangents (a, b) (k, 3) with a x b = N, from unit normals N (k, 3) (Cycles' make_orthonormals)."""
    same = (N[:, 0] == N[:, 1]) & (N[:, 0] == N[:, 2])
    a = np.where(same[:, None],
                 np.stack([N[:, 2] - N[:, 1], N[:, 0] + N[:, 2], -N[:, 1] - N[:, 0]], axis=1),
                 np.stack([N[:, 2] - N[:, 1], N[:, 0] - N[:, 2], N[:, 1] - N[:, 0]], axis=1))
    a, _ = unit(a)
    return a, np.cross(N, a)


def inverse22(M: np.ndarray) -> tuple:
    """(det (k,), inverse (k, 2, 2), ok (k,) bool): 2x2 inverses, not ok where |det| < MNEE_MIN_DETERMINANT."""
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    ok = np.abs(det) >= MNEE_MIN_DETERMINANT
    safe = np.where(ok, det, 1.0)
    inv = np.stack([np.stack([M[:, 1, 1], -M[:, 0, 1]], -1), np.stack([-M[:, 1, 0], M[:, 0, 0]], -1)], 1)
    return det, inv / safe[:, None, None], ok


def mat_vec(M: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(k, 2, 2) times (k, 2) -> (k, 2)."""
    return np.einsum("kij,kj->ki", M, x)


def mat_mat(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """(k, 2, 2) times (k, 2, 2) -> (k, 2, 2)."""
    return np.einsum("kij,kjl->kil", A, B)


class Vertex(NamedTuple):
    """Manifold vertices on caster triangles, one per row, camera-relative (k rows).

    p, dp_du, dp_dv: (k, 3) the point and an orthonormal tangent frame of its triangle's plane (about ng);
    n, dn_du, dn_dv: (k, 3) the interpolated shading normal and its derivatives along dp_du, dp_dv; ng: (k, 3) the
    triangle's front face normal; prim: (k,) int64; u, v: (k,) barycentrics; owner: (k,) int64 its object
    """

    p: np.ndarray
    dp_du: np.ndarray
    dp_dv: np.ndarray
    n: np.ndarray
    ng: np.ndarray
    dn_du: np.ndarray
    dn_dv: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray
    owner: np.ndarray


def vertex_at(geometry, prim: np.ndarray, u: np.ndarray, v: np.ndarray) -> Vertex:
    """The manifold vertices (Vertex, k rows) at barycentrics (u, v) (k,) of triangles prim (k,) int64: the point,
    its smooth normal and their derivatives, in a tangent frame that turns consistently over the surface (Cycles'
    mnee_setup_manifold_vertex). Flat triangles: the face normal, no curvature."""
    tri = geometry.triangle_data(prim, smooth=True)
    V0, V1, V2 = tri.corners[:, 0], tri.corners[:, 1], tri.corners[:, 2]
    w = 1.0 - u - v
    p = w[:, None] * V0 + u[:, None] * V1 + v[:, None] * V2
    normals = np.repeat(tri.Ng[:, None, :], 3, axis=1)
    if tri.smooth.any():
        normals[tri.smooth] = tri.corner_normals
    N0, N1, N2 = normals[:, 0], normals[:, 1], normals[:, 2]
    n, n_len = unit(w[:, None] * N0 + u[:, None] * N1 + v[:, None] * N2)
    # d/du of n = f / |f|: f' / |f| - f <f, f'> / |f|^3 (the part of f' / |f| across n).
    dn_du = (N1 - N0) / n_len[:, None]
    dn_dv = (N2 - N0) / n_len[:, None]
    dn_du = dn_du - n * dot(n, dn_du)[:, None]
    dn_dv = dn_dv - n * dot(n, dn_dv)[:, None]
    # Orthonormalise the edges (dp_du, dp_dv), and the normal's derivatives by the same linear map.
    dp_du, dp_dv = V1 - V0, V2 - V0
    inv = 1.0 / np.sqrt(dot(dp_du, dp_du))
    dp_du, dn_du = dp_du * inv[:, None], dn_du * inv[:, None]
    along = dot(dp_du, dp_dv)
    dp_dv, dn_dv = dp_dv - along[:, None] * dp_du, dn_dv - along[:, None] * dn_du
    inv = 1.0 / np.sqrt(dot(dp_dv, dp_dv))
    dp_dv, dn_dv = dp_dv * inv[:, None], dn_dv * inv[:, None]
    # A frame about the face normal that does not depend on the triangle; the derivatives turned into it.
    a, b = make_orthonormals(tri.Ng)
    cos_t, sin_t = dot(dp_du, a), -dot(dp_dv, a)
    du = cos_t[:, None] * dn_du - sin_t[:, None] * dn_dv
    dv = sin_t[:, None] * dn_du + cos_t[:, None] * dn_dv
    return Vertex(p, a, b, n, tri.Ng, du, dv, prim, u, v, geometry.owners(prim))


class Chain(NamedTuple):
    """A specular chain of c vertices for k rows: verts (list of c Vertex), eta (k, c) the relative index across
    each interface seen from its front side, h (k, c, 2) the sampled microfacet offsets, slot (k, c) int64 the refractive
    closure's slot at each vertex."""

    verts: list
    eta: np.ndarray
    h: np.ndarray
    slot: np.ndarray


def constraints(chain: Chain, I: np.ndarray, target: np.ndarray, fixed: np.ndarray) -> tuple:
    """The constraint C (k, c, 2) and its block-tridiagonal derivatives A, B, Cn (k, c, 2, 2) (by the previous, own
    and next vertex), and ok (k,) bool: False where two vertices lie within MNEE_MIN_DISTANCE. I: (k, 3) the receiver
    points; target: (k, 3) the light points, or the directions to the light where `fixed` (k,) bool (a sun)."""
    verts, c = chain.verts, len(chain.verts)
    k = len(I)
    C = np.zeros((k, c, 2))
    A, B, Cn = np.zeros((k, c, 2, 2)), np.zeros((k, c, 2, 2)), np.zeros((k, c, 2, 2))
    ok = np.ones(k, bool)

    def across(d, H):
        """The part (k, 3) of vectors d (k, 3) across unit H (k, 3)."""
        return d - H * dot(d, H)[:, None]

    def frame_rows(dH_du, dH_dv, s, t):
        """The 2x2 blocks (k, 2, 2) [[dH_du.s, dH_dv.s], [dH_du.t, dH_dv.t]]."""
        return np.stack([np.stack([dot(dH_du, s), dot(dH_dv, s)], -1), np.stack([dot(dH_du, t), dot(dH_dv, t)], -1)], 1)

    for i, x in enumerate(verts):
        wi, ili = unit((I if i == 0 else verts[i - 1].p) - x.p)
        if i == c - 1:
            wo, ilo = unit(np.where(fixed[:, None], target, target - x.p))
            ilo = np.where(fixed, 1.0, ilo)
        else:
            wo, ilo = unit(verts[i + 1].p - x.p)
        ok &= (ili >= MNEE_MIN_DISTANCE) & (ilo >= MNEE_MIN_DISTANCE)
        ili, ilo = 1.0 / np.maximum(ili, 1e-300), 1.0 / np.maximum(ilo, 1e-300)
        eta = np.where(dot(wi, x.ng) < 0.0, 1.0 / chain.eta[:, i], chain.eta[:, i])
        H, lh = unit(-(wi + eta[:, None] * wo))
        ilh = 1.0 / np.maximum(lh, 1e-300)
        ilo, ili = ilo * eta * ilh, ili * ilh
        # The shading frame (s, t) about n.
        dpn = dot(x.dp_du, x.n)
        s, ls_ = unit(x.dp_du - dpn[:, None] * x.n)
        inv_s = 1.0 / np.maximum(ls_, 1e-300)
        t = np.cross(x.n, s)
        if i > 0:
            pv = verts[i - 1]
            dH_du = -across((pv.dp_du - wi * dot(wi, pv.dp_du)[:, None]) * ili[:, None], H)
            dH_dv = -across((pv.dp_dv - wi * dot(wi, pv.dp_dv)[:, None]) * ili[:, None], H)
            A[:, i] = frame_rows(dH_du, dH_dv, s, t)
        last_fixed = fixed if i == c - 1 else np.zeros(k, bool)
        own_du = (-x.dp_du * (ili + ilo)[:, None] + wi * (dot(wi, x.dp_du) * ili)[:, None]
                  + wo * (dot(wo, x.dp_du) * ilo)[:, None])
        own_dv = (-x.dp_dv * (ili + ilo)[:, None] + wi * (dot(wi, x.dp_dv) * ili)[:, None]
                  + wo * (dot(wo, x.dp_dv) * ilo)[:, None])
        fix_du = ili[:, None] * (-x.dp_du + wi * dot(wi, x.dp_du)[:, None])
        fix_dv = ili[:, None] * (-x.dp_dv + wi * dot(wi, x.dp_dv)[:, None])
        dH_du = -across(np.where(last_fixed[:, None], fix_du, own_du), H)
        dH_dv = -across(np.where(last_fixed[:, None], fix_dv, own_dv), H)
        ds_du = -inv_s[:, None] * (dot(x.dp_du, x.dn_du)[:, None] * x.n + dpn[:, None] * x.dn_du)
        ds_dv = -inv_s[:, None] * (dot(x.dp_du, x.dn_dv)[:, None] * x.n + dpn[:, None] * x.dn_dv)
        ds_du, ds_dv = ds_du - s * dot(s, ds_du)[:, None], ds_dv - s * dot(s, ds_dv)[:, None]
        dt_du = np.cross(x.dn_du, s) + np.cross(x.n, ds_du)
        dt_dv = np.cross(x.dn_dv, s) + np.cross(x.n, ds_dv)
        B[:, i] = np.stack([np.stack([dot(dH_du, s) + dot(H, ds_du), dot(dH_dv, s) + dot(H, ds_dv)], -1),
                            np.stack([dot(dH_du, t) + dot(H, dt_du), dot(dH_dv, t) + dot(H, dt_dv)], -1)], 1)
        if i < c - 1:
            nv = verts[i + 1]
            dH_du = -across((nv.dp_du - wo * dot(wo, nv.dp_du)[:, None]) * ilo[:, None], H)
            dH_dv = -across((nv.dp_dv - wo * dot(wo, nv.dp_dv)[:, None]) * ilo[:, None], H)
            Cn[:, i] = frame_rows(dH_du, dH_dv, s, t)
        C[:, i] = np.stack([dot(s, H), dot(t, H)], -1) - chain.h[:, i]
    return C, A, B, Cn, ok


def solve_steps(C: np.ndarray, A: np.ndarray, B: np.ndarray, Cn: np.ndarray) -> tuple:
    """(dx (k, c, 2), ok (k,)): the tangent steps that zero the linearised constraint, by block-tridiagonal LU (Cycles'
    mnee_solve_matrix_h_to_x); not ok where a pivot block is singular."""
    k, c = C.shape[:2]
    Li = np.zeros((k, c, 2, 2))
    R = np.zeros((k, c, 2))
    _, Li[:, 0], ok = inverse22(B[:, 0])
    R[:, 0] = C[:, 0]
    for i in range(1, c):
        M = mat_mat(A[:, i], Li[:, i - 1])
        _, Li[:, i], good = inverse22(B[:, i] - mat_mat(M, Cn[:, i - 1]))
        ok &= good
        R[:, i] = C[:, i] - mat_vec(M, R[:, i - 1])
    dx = np.zeros((k, c, 2))
    dx[:, c - 1] = mat_vec(Li[:, c - 1], R[:, c - 1])
    for i in range(c - 2, -1, -1):
        dx[:, i] = mat_vec(Li[:, i], R[:, i] - mat_vec(Cn[:, i], dx[:, i + 1]))
    return dx, ok


def project(geometry, origins: np.ndarray, start_Ng: np.ndarray, start_corners: np.ndarray, goal: np.ndarray,
            owner: np.ndarray, stretch: float = MNEE_PROJECTION_DISTANCE_MULTIPLIER) -> tuple:
    """Rays from `origins` (k, 3) (on triangles with face normals start_Ng (k, 3) and corners start_corners (k, 3, 3))
    towards `goal` (k, 3), out to `stretch` times that distance, passing up to MNEE_MAX_INTERSECTION_COUNT other
    surfaces: (found (k,) bool where they met object `owner` (k,), prim, u, v)."""
    D, length = unit(goal - origins)
    t_left = length * stretch
    O = shadows.spawn_ray(origins, start_Ng, D, shadows.error_bound(origins, start_corners))
    k = len(origins)
    found = np.zeros(k, bool)
    prim, u, v = np.full(k, -1, np.int64), np.zeros(k), np.zeros(k)
    alive = np.flatnonzero(t_left > 0.0)
    for _ in range(MNEE_MAX_INTERSECTION_COUNT):
        if not len(alive):
            break
        hits = geometry.tracer.intersect(O[alive], D[alive], t_left[alive])
        alive, hits_at = alive[hits.hit], np.flatnonzero(hits.hit)
        hp = hits.prim[hits_at]
        mine = geometry.owners(hp) == owner[alive]
        rows = alive[mine]
        found[rows], prim[rows], u[rows], v[rows] = True, hp[mine], hits.u[hits_at][mine], hits.v[hits_at][mine]
        on = ~mine
        alive, hp, ht = alive[on], hp[on], hits.t[hits_at][on]
        if not len(alive):
            break
        tri = geometry.triangle_data(hp, smooth=False)
        P = O[alive] + D[alive] * ht[:, None]
        O[alive] = shadows.spawn_ray(P, tri.Ng, D[alive], shadows.error_bound(P, tri.corners))
        t_left[alive] -= ht
    return found, prim, u, v


def newton(geometry, chain: Chain, I: np.ndarray, Ng: np.ndarray, corners: np.ndarray, target: np.ndarray,
           fixed: np.ndarray) -> tuple:
    """Walk the chains (k rows) onto the specular manifold (Cycles' mnee_newton_solver): (the chain at the solution,
    solved (k,) bool). I, Ng, corners: the receiver points, their face normals (towards the light) and triangles."""
    k, c = len(I), len(chain.verts)
    verts = list(chain.verts)
    beta = np.full(k, 0.1)
    resolve = np.ones(k, bool)
    running = np.ones(k, bool)
    solved = np.zeros(k, bool)
    dx = np.zeros((k, c, 2))
    for _ in range(MNEE_MAX_ITERATIONS):
        if not running.any():
            break
        now = Chain(verts, chain.eta, chain.h, chain.slot)
        again = running & resolve
        if again.any():
            C, A, B, Cn, ok = constraints(now, I, target, fixed)
            running &= ~(again & ~ok)
            norm = np.sqrt((C * C).sum(axis=2)).max(axis=1)
            done = again & ok & (norm < MNEE_SOLVER_THRESHOLD)
            solved |= done
            running &= ~done
            step, good = solve_steps(C, A, B, Cn)
            redo = again & running
            running &= ~(redo & ~good)
            dx = np.where(redo[:, None, None], step, dx)
        # Tentative vertices: a step in each tangent plane, projected back onto the vertex's object.
        reduce = np.zeros(k, bool)
        moving = running.copy()
        tentative = []
        for i, x in enumerate(verts):
            rows = np.flatnonzero(moving & ~reduce)
            step = beta[:, None] * (dx[:, i, 0:1] * x.dp_du + dx[:, i, 1:2] * x.dp_dv)
            goal = x.p - step
            if i == 0:                # (the first step may end below the receiver: step the other way)
                below = dot(Ng, goal - I) <= 0.0
                goal = np.where(below[:, None], x.p + step, goal)
                origin, o_Ng, o_corners = I, Ng, corners
            else:
                pv = verts[i - 1]
                origin = pv.p
                o_Ng = pv.ng
                o_corners = geometry.triangle_data(pv.prim, smooth=False).corners
            new = x
            if len(rows):
                found, prim, u, v = project(geometry, origin[rows], o_Ng[rows], o_corners[rows], goal[rows],
                                            x.owner[rows])
                reduce[rows[~found]] = True
                hit = rows[found]
                if len(hit):
                    landed = vertex_at(geometry, prim[found], u[found], v[found])
                    new = Vertex(*(np.array(a) for a in x))
                    for field_, value in zip(Vertex._fields, landed):
                        getattr(new, field_)[hit] = value
                    stuck = np.sqrt(dot(new.p[hit] - x.p[hit], new.p[hit] - x.p[hit])) < MNEE_MIN_PROGRESS_DISTANCE
                    running[hit[stuck]] = False
                    moving[hit[stuck]] = False
            tentative.append(new)
        # Every tentative interface must still refract: the receiver's and the light's sides on opposite sides of n.
        check = running & ~reduce
        for i, x in enumerate(tentative):
            wi = (I if i == 0 else tentative[i - 1].p) - x.p
            if i == c - 1:
                wo = np.where(fixed[:, None], target, target - x.p)
            else:
                wo = tentative[i + 1].p - x.p
            reduce |= check & (dot(x.n, wi) * dot(x.n, wo) >= 0.0)
        shrink = running & reduce
        beta = np.where(shrink, beta * 0.5, beta)
        resolve = np.where(shrink, False, resolve)
        running &= ~(shrink & (beta < MNEE_MINIMUM_STEP_SIZE))
        accept = running & ~reduce
        if accept.any():
            verts = [Vertex(*(np.where(accept.reshape((-1,) + (1,) * (np.ndim(a) - 1)), a, b) for a, b in zip(t, x)))
                     for t, x in zip(tentative, verts)]
        resolve = np.where(accept, True, resolve)
        beta = np.where(accept, np.minimum(1.0, 2.0 * beta), beta)
    return Chain(verts, chain.eta, chain.h, chain.slot), solved


def transfer(chain: Chain, I: np.ndarray, target: np.ndarray, fixed: np.ndarray, light_Ng: np.ndarray) -> tuple:
    """(|det dx1/dx_light| (k,), ok (k,)): how the first vertex moves with the light point (in the light's area
    measure about light_Ng (k, 3); for a sun with the direction, per solid angle), from the chain's constraint
    derivatives (Cycles' mnee_compute_transfer_matrix)."""
    C, A, B, Cn, ok = constraints(chain, I, target, fixed)
    k, c = len(I), len(chain.verts)
    U = np.zeros((k, max(c - 1, 1), 2, 2))
    _, Li, good = inverse22(B[:, 0])
    ok &= good
    for i in range(1, c):
        U[:, i - 1] = mat_mat(Li, Cn[:, i - 1])
        _, Li, good = inverse22(B[:, i] - mat_mat(A[:, i], U[:, i - 1]))
        ok &= good
    m = chain.verts[-1]
    s, _ = unit(m.dp_du - dot(m.dp_du, m.n)[:, None] * m.n)
    t = np.cross(m.n, s)
    wi, _ = unit((I if c == 1 else chain.verts[-2].p) - m.p)
    eta = np.where(dot(wi, m.ng) < 0.0, 1.0 / chain.eta[:, -1], chain.eta[:, -1])
    # The light fixed: a direction (theta, phi) about n; else a point moving in its tangent plane.
    wo_d = target
    H, lh = unit(-(wi + eta[:, None] * wo_d))
    ilo_d = -eta / np.maximum(lh, 1e-300)
    cos_theta = dot(wo_d, m.n)
    sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
    cos_phi = dot(wo_d, s)
    sin_phi = np.sqrt(np.maximum(1.0 - cos_phi * cos_phi, 0.0))
    dH_a = ilo_d[:, None] * (cos_theta[:, None] * (cos_phi[:, None] * s + sin_phi[:, None] * t)
                             - sin_theta[:, None] * m.n)
    dH_b = (ilo_d * sin_theta)[:, None] * (-sin_phi[:, None] * s + cos_phi[:, None] * t)
    dH_a, dH_b = dH_a - H * dot(dH_a, H)[:, None], dH_b - H * dot(dH_b, H)[:, None]
    fixed_rows = np.stack([np.stack([dot(dH_a, s), dot(dH_b, s)], -1), np.stack([dot(dH_a, t), dot(dH_b, t)], -1)], 1)
    fixed_scale = 1.0 / np.maximum(MNEE_MIN_DISTANCE, np.abs(sin_theta))
    wo_p, lo = unit(target - m.p)
    Hp, lhp = unit(-(wi + eta[:, None] * wo_p))
    ilo_p = eta / np.maximum(lo, 1e-300) / np.maximum(lhp, 1e-300)
    du, dv = make_orthonormals(light_Ng)
    dH_u = (du - wo_p * dot(wo_p, du)[:, None]) * ilo_p[:, None]
    dH_v = (dv - wo_p * dot(wo_p, dv)[:, None]) * ilo_p[:, None]
    dH_u, dH_v = -(dH_u - Hp * dot(dH_u, Hp)[:, None]), -(dH_v - Hp * dot(dH_v, Hp)[:, None])
    point_rows = np.stack([np.stack([dot(dH_u, s), dot(dH_v, s)], -1), np.stack([dot(dH_u, t), dot(dH_v, t)], -1)], 1)
    dc_dlight = np.where(fixed[:, None, None], fixed_rows, point_rows)
    T = -mat_mat(Li, dc_dlight)
    for i in range(c - 2, -1, -1):
        T = -mat_mat(U[:, i], T)
    det = np.abs(T[:, 0, 0] * T[:, 1, 1] - T[:, 0, 1] * T[:, 1, 0])
    return det * np.where(fixed, fixed_scale, 1.0), ok


def sample_h(kind: np.ndarray, alpha_x: np.ndarray, alpha_y: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Microfacet offsets h (k, 2) in the tangent frame, sampled in the half-vector measure of GGX or Beckmann (kind)
    with roughness alpha (k,) from numbers u (k, 2) (Cycles' mnee_sample_bsdf_dh); 0 where smooth."""
    from ..materials.beckmann_glass import BeckmannGlass
    iso = alpha_x == alpha_y
    phi_iso = u[:, 1] * 2.0 * math.pi
    with np.errstate(divide="ignore", invalid="ignore"):
        phi_an = np.arctan(alpha_y / np.maximum(alpha_x, 1e-300) * np.tan(2.0 * math.pi * u[:, 1] + 0.5 * math.pi))
        phi_an = np.where(u[:, 1] > 0.5, phi_an + math.pi, phi_an)
        phi = np.where(iso, phi_iso, phi_an)
        cp, sp = np.cos(phi), np.sin(phi)
        alpha2 = np.where(iso, alpha_x * alpha_x,
                          1.0 / (cp * cp / np.maximum(alpha_x * alpha_x, 1e-300)
                                 + sp * sp / np.maximum(alpha_y * alpha_y, 1e-300)))
        tan2 = np.where(kind == BeckmannGlass.kind, alpha2 * -np.log(1.0 - u[:, 0]), alpha2 * u[:, 0] / (1.0 - u[:, 0]))
    cos2 = 1.0 / (1.0 + tan2)
    sin_t = np.sqrt(np.maximum(1.0 - cos2, 0.0))
    rough = (alpha_x > 0.0) & (alpha_y > 0.0)
    return np.where(rough[:, None], np.stack([cp * sin_t, sp * sin_t], -1), 0.0)


def interface_weight(kind: np.ndarray, weight: np.ndarray, params: np.ndarray, N: np.ndarray, wi: np.ndarray,
                     wo: np.ndarray) -> np.ndarray:
    """What one interface passes (k, 3): the closure's weight times its transmittance (1 - F) at the refracting
    microfacet, times G |h.wi| / |n.wi (n.h)^2| (smooth glass: 1): Cycles' mnee_eval_bsdf_contribution. N: (k, 3) the
    closure normals on wi's side; wi, wo (k, 3): towards the receiver's and the light's sides."""
    from ..materials import microfacet as mf
    from ..materials.beckmann_glass import BeckmannGlass
    from ..materials.glass import shares
    ior = params[:, mf.IOR]
    cosNI, cosNO = dot(N, wi), dot(N, wo)
    Ht, _ = unit(-(ior[:, None] * wo + wi))
    cosHI = dot(Ht, wi)
    cosM = dot(N, Ht)
    alpha2 = params[:, mf.ALPHA] * params[:, mf.ALPHA]      # (isotropic: a glass closure's slots past 9 hold tints)
    beck = kind == BeckmannGlass.kind
    lam = np.where(beck, mf.lambda_beckmann(alpha2, cosNI) + mf.lambda_beckmann(alpha2, cosNO),
                   mf.lambda_ggx(alpha2, cosNI) + mf.lambda_ggx(alpha2, cosNO))
    G = np.where(alpha2 > 0.0, 1.0 / (1.0 + lam), 1.0)
    _, T = shares(params, cosHI)
    scale = G * np.abs(cosHI / np.where(np.abs(cosNI * cosM * cosM) > 0.0, cosNI * cosM * cosM, np.inf))
    return weight * T * scale[:, None]


def light_values(light, ls, rows: np.ndarray, last: np.ndarray) -> tuple:
    """(emission over pdf (r,) float64 in the light's area measure, or per solid angle for a sun; light_Ng (r, 3) the
    light's normal there; target (r, 3) the light point, or the sun's direction; fixed (r,) bool): light `light`'s
    samples `rows` seen from the chains' last vertices `last` (r, 3), the light point held where it was sampled
    (Cycles' light_sample_update)."""
    r = len(rows)
    if getattr(light, "blender_type", "") == "SUN":
        return ls.strength[rows], -ls.L[rows], ls.L[rows].copy(), np.ones(r, bool)
    P = ls.position[rows]
    kind = getattr(light, "blender_type", "")
    sphere = kind in ("POINT", "SPOT") and light.radius > 0.0 and not light.soft_falloff
    if kind == "AREA" or sphere:
        # The light point held; its radiance towards the last vertex over the pdf of that direction there, turned into
        # the light's area measure (Cycles' area_light_mnee_sample_update, and point_light_mnee_sample_update's
        # sphere: its cone's pdf times |cos| / t^2 at the point).
        D, t = unit(P - last)
        seen = light.hit(last, D, t * (1.0 + 1e-9) + 1e-9)
        if sphere:
            normal, _ = unit(P - np.asarray(light.position, np.float64))
        else:
            normal = np.broadcast_to(np.asarray(light.direction, np.float64), (r, 3))
        cos_light = -dot(D, normal)
        pdf_area = seen.pdf * np.abs(cos_light) / (t * t)
        color = np.broadcast_to(ls.color if ls.color.ndim == 1 else ls.color[rows], (r, 3))
        per_colour = seen.radiance.sum(axis=1) / np.maximum(color.sum(axis=1), 1e-300)
        values = np.where(seen.hit & (pdf_area > 0.0), per_colour / np.where(pdf_area > 0.0, pdf_area, 1.0), 0.0)
        return values, normal.copy(), P, np.zeros(r, bool)
    # A point (or a disk facing the point) of intensity I = P / (4 pi) in the direction it leaves: Cycles' pdf in
    # area measure eval_fac 4 pi, the light facing the last vertex.
    D, t = unit(P - last)
    values = np.empty(r)
    for j in range(r):                    # (each sample's own light point)
        here = replace(light, radius=0.0, position=P[j])
        values[j] = here.sample(last[j:j + 1], np.zeros((1, 2))).strength[0] * t[j] * t[j]
    return values, -D, P, np.zeros(r, bool)


class Result(NamedTuple):
    """What MNEE found for light samples `rows` (r of them): done (r,) bool where a path was found (the ordinary light
    sample is replaced), value (r, 3) its contribution before the light's colour and 1 / count, rays the shadow rays
    from the last interfaces to the light (shadows.ShadowRays of the done rows), first (r, 3) the directions from the
    receivers to their first interfaces (where done)."""

    done: np.ndarray
    value: np.ndarray
    rays: Optional[shadows.ShadowRays]
    first: Optional[np.ndarray] = None


def seed_chains(ctx, surface, rows: np.ndarray, ls, u_h: np.ndarray) -> tuple:
    """Follow each shadow ray of samples `rows` from its receiver towards the light, collecting caster interfaces
    (Cycles' first step of kernel_path_mnee_sample): (count (r,) int64, 0 where none or where the chain cannot be
    walked; a list per row of (prim, u, v, eta, h (2,), slot))."""
    from ..geometry.surface import surface_at_hits
    geometry = ctx.geometry
    r = len(rows)
    kinds = refractive_kinds()
    finite = np.isfinite(ls.distance[rows])
    D = ls.L[rows].copy()
    t_left = np.where(finite, ls.distance[rows], np.inf)
    side = np.where(dot(surface.Ng[rows], D) < 0.0, -1.0, 1.0)
    O = shadows.spawn_ray(surface.I[rows], surface.Ng[rows] * side[:, None], D,
                          shadows.error_bound(surface.I[rows], surface.vertices[rows]))
    links = [[] for _ in range(r)]
    bad = np.zeros(r, bool)
    alive = np.arange(r)
    for _ in range(MNEE_MAX_INTERSECTION_COUNT):
        if not len(alive):
            break
        hits = geometry.tracer.intersect(O[alive], D[alive], t_left[alive])
        at = np.flatnonzero(hits.hit)
        alive = alive[at]
        if not len(alive):
            break
        prim, hu, hv, ht = hits.prim[at], hits.u[at], hits.v[at], hits.t[at]
        flags = geometry.caustics_flags(prim)
        cast = (flags & CASTER) != 0
        hit_surface = surface_at_hits(geometry, prim, hu, hv, O[alive], D[alive], ht)
        if cast.any():
            c = np.flatnonzero(cast)
            part = type(hit_surface)(*(None if a is None else a[c] for a in hit_surface))
            shader = ctx.materials.shade(part.material, part.N, -D[alive[c]], part, geometry,
                                         graph_.light_paths(len(c), flags=graph_.PATH_SHADOW))
            cl = shader.closures
            refr = np.isin(cl.kind, kinds)
            has = refr.any(axis=1)
            slot = np.argmax(refr, axis=1)
            for j, row in enumerate(alive[c]):
                if bad[row]:
                    continue
                if len(links[row]) >= MNEE_MAX_CAUSTIC_CASTERS or not part.smooth[j] or not has[j]:
                    bad[row] = True
                    continue
                params = cl.params[j, slot[j]]
                from ..materials import microfacet as mf
                eta = 1.0 / params[mf.IOR] if part.backfacing is not None and part.backfacing[j] else params[mf.IOR]
                ax = ay = params[mf.ALPHA]          # (glass closures are isotropic: their slots past 9 hold tints)
                h = sample_h(np.array([cl.kind[j, slot[j]]]), np.array([ax]), np.array([ay]), u_h[row:row + 1])[0]
                links[row].append((int(prim[c[j]]), float(hu[c[j]]), float(hv[c[j]]), float(eta), h, int(slot[j])))
        P = hit_surface.I
        O[alive] = shadows.spawn_ray(P, hit_surface.Ng, D[alive], shadows.error_bound(P, hit_surface.vertices))
        t_left[alive] = np.where(finite[alive], t_left[alive] - ht, np.inf)
    count = np.array([0 if bad[j] else len(links[j]) for j in range(r)], np.int64)
    return count, links


def sample(ctx, surface, shader, wo: np.ndarray, rows: np.ndarray, light, ls, u_h: np.ndarray,
           paths=None) -> Result:
    """MNEE for light `light`'s samples `ls` at the receiver hits `rows` (r,) of `surface` (their closures in
    `shader`, viewer directions wo (m, 3)); u_h (r, 2) the numbers that sample rough interfaces' microfacets.
    paths: the graph.LightPaths of the m hits (their bounces so far: a chain that would pass the render's bounce
    limits is not walked, as Cycles checks: the chain's vertices are bounces, the receiver's a diffuse one; so the
    direct tracer, a path of Max Bounces 0, never walks), or None: a camera ray's hits."""
    from .. import materials as materials_
    from ..geometry.surface import surface_at_hits
    geometry = ctx.geometry
    r = len(rows)
    done = np.zeros(r, bool)
    value = np.zeros((r, 3))
    count, links = seed_chains(ctx, surface, rows, ls, u_h)
    s = ctx.settings
    bounce, diffuse, transmission = ((0, 0, 0) if paths is None else
                                     (paths.bounce[rows], paths.diffuse[rows], paths.transmission[rows]))
    # (Cycles' limits are the settings + 1; the direct tracer is a path of Max Bounces 0, which never walks)
    max_bounces = 0 if s.integrator == "direct" else s.max_bounces
    over = ((transmission + count - 1 > s.transmission_bounces) | (diffuse + 1 > s.diffuse_bounces)
            | (bounce + count > max_bounces))
    count = np.where(over, 0, count)
    ray_parts = []
    for c in range(1, MNEE_MAX_CAUSTIC_CASTERS + 1):
        group = np.flatnonzero(count == c)
        if not len(group):
            continue
        g_rows = rows[group]
        verts = []
        for i in range(c):
            prim = np.array([links[j][i][0] for j in group], np.int64)
            verts.append(vertex_at(geometry, prim, np.array([links[j][i][1] for j in group]),
                                   np.array([links[j][i][2] for j in group])))
        chain = Chain(verts, np.array([[links[j][i][3] for i in range(c)] for j in group]),
                      np.array([[links[j][i][4] for i in range(c)] for j in group]),
                      np.array([[links[j][i][5] for i in range(c)] for j in group], np.int64))
        I = surface.I[g_rows]
        Ng = surface.Ng[g_rows] * np.where(dot(surface.Ng[g_rows], ls.L[g_rows]) < 0.0, -1.0, 1.0)[:, None]
        corners = surface.vertices[g_rows]
        sun = getattr(light, "blender_type", "") == "SUN"
        fixed = np.full(len(group), sun)
        target = ls.L[g_rows] if sun else ls.position[g_rows]
        chain, solved = newton(geometry, chain, I, Ng, corners, target, fixed)
        if not solved.any():
            continue
        keep = np.flatnonzero(solved)
        chain = Chain([Vertex(*(a[keep] for a in x)) for x in chain.verts], chain.eta[keep], chain.h[keep],
                      chain.slot[keep])
        group, g_rows, I, Ng, corners, target, fixed = (group[keep], g_rows[keep], I[keep], Ng[keep], corners[keep],
                                                        target[keep], fixed[keep])
        k = len(keep)
        # The light seen from the last interface; the receiver's f cos towards the first.
        last = chain.verts[-1]
        emitted, light_Ng, target, fixed = light_values(light, ls, g_rows, last.p)
        w0, w0_len = unit(chain.verts[0].p - I)
        part = shader.closures.rows(g_rows)
        f_cos, _ = materials_.eval_closures(part, wo[g_rows], w0)
        dx1_dxl, ok = transfer(chain, I, target, fixed, light_Ng)
        G = np.minimum(np.abs(dot(w0, chain.verts[0].n)) / (w0_len * w0_len) * dx1_dxl, G_CLAMP)
        through = f_cos * (emitted * G)[:, None]
        # Each interface: seen from where the path comes from, nothing else in the way, and what it lets through.
        start, start_Ng, start_corners = I, Ng, corners
        for i, x in enumerate(chain.verts):
            D, dist = unit(x.p - start)
            O = shadows.spawn_ray(start, start_Ng, D, shadows.error_bound(start, start_corners))
            hits = geometry.tracer.intersect(O, D, dist + MNEE_MIN_DISTANCE)
            wrong = hits.hit & ((geometry.owners(np.where(hits.hit, hits.prim, 0)) != x.owner)
                                | (np.abs(np.where(hits.hit, hits.t, 0.0) - dist) > MNEE_MIN_DISTANCE))
            ok &= ~wrong
            at = surface_at_hits(geometry, x.prim, x.u, x.v, O, D, dist)
            here = ctx.materials.shade(at.material, at.N, -D, at, geometry,
                                       graph_.light_paths(k, flags=graph_.PATH_SHADOW))
            cl = here.closures
            slot = chain.slot[:, i]
            kind = cl.kind[np.arange(k), slot]
            ok &= np.isin(kind, refractive_kinds())
            if i == c - 1:
                wnext = np.where(fixed[:, None], target, target - x.p)
            else:
                wnext = chain.verts[i + 1].p - x.p
            wnext, _ = unit(wnext)
            through *= interface_weight(kind, cl.weight[np.arange(k), slot], cl.params[np.arange(k), slot],
                                        cl.N[np.arange(k), slot], -D, wnext)
            start, start_corners = x.p, geometry.triangle_data(x.prim, smooth=False).corners
            start_Ng = x.ng
        # The shadow ray from the last interface to the light.
        L_last, t_last = unit(np.where(fixed[:, None], target, target - last.p))
        t_last = np.where(fixed, np.inf, t_last)
        face = last.ng * np.where(dot(last.ng, L_last) < 0.0, -1.0, 1.0)[:, None]
        rays = shadows.robust_rays(last.p, face, shadows.error_bound(last.p, start_corners),
                                   np.where(fixed[:, None], last.p, target), L_last, t_last)
        good = ok & np.isfinite(through).all(axis=1)
        done[group[good]] = True
        value[group[good]] = through[good]
        ray_parts.append((group[good], shadows.ShadowRays(rays.origins[good], rays.directions[good], rays.t_max[good]),
                          w0[good]))
    if not ray_parts:
        return Result(done, value, None, None)
    first = np.zeros((r, 3))
    # (the shadow rays in the order of the done rows)
    order = np.argsort(np.concatenate([g for g, _, _ in ray_parts]))
    origins, directions, t_max = (np.concatenate([getattr(ray, f) for _, ray, _ in ray_parts])[order]
                                          for f in ("origins", "directions", "t_max"))
    first[done] = np.concatenate([w for _, _, w in ray_parts])[order]
    return Result(done, value, shadows.ShadowRays(origins, directions, t_max), first)


def notes(ctx) -> list:
    """What a render of `ctx` leaves out of Cycles' shadow caustics (warnings, list of str): caustics lights that are
    not walked (area lamps of Spread 0), by either kernel (the compiled one, core/integrators/mnee.c, walks the same
    lights as this reference)."""
    lights = [light for light in ctx.lights if getattr(light, "caustics", False)]
    if not lights or not len(ctx.geometry.instance_caustics):
        return []
    flags = ctx.geometry.instance_caustics
    if not ((flags & CASTER).any() and (flags & RECEIVER).any()):
        return []
    out = []
    left = sorted({getattr(light, "name", "light") for light in lights if not walks(light)})
    if left:
        out.append(f"shadow caustics: {', '.join(left)} (area lamps of Spread 0) are not walked; casters cast their "
                   "ordinary shadow of them")
    return out
