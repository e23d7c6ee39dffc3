"""The Ray Portal BSDF (Blender 4.2+): a ray that takes it goes on from another place, in another direction.

Cycles' CLOSURE_BSDF_RAY_PORTAL_ID (closure/bsdf_ray_portal.h, integrate_surface_ray_portal in
integrator/shade_surface.h). Like the Transparent BSDF it is a delta that reflects nothing (eval is 0) and counts
as a *transparent* bounce (Light Paths > Max Bounces > Transparent): the ray keeps the kind it had (a camera ray
stays a camera ray), the path keeps its flags. Unlike it, the ray is teleported: it leaves from the node's
*Position* (unlinked: the hit point itself, Cycles' LINK_POSITION) along its *Direction* (zero, the default:
the incoming ray's own direction, -wo). Where the position is the hit point the ray leaves from just off the
surface as any bounce's; elsewhere from the position itself, with no offset (Cycles forgets the object it left,
so that the ray may meet the very same face again).

What a portal changes beyond its own bounce, as in Cycles:

- MIS is skipped for what the teleported ray finds (PATH_RAY_MIS_SKIP): a lamp or emitter it meets counts with
  weight 1, as the light samples of the bounce before the portal cannot see through it;
- shadow rays that meet a surface with a portal closure are blocked there, whatever else the surface lets
  through (shade_shadow.h: "Disable transparent shadows for ray portals");
- the first-hit data passes (normal, roughness, ...) skip it as they skip transparent surfaces.

The ray's direction is normalised (Cycles traces the Direction as given: a non-unit one scales distances).
Parameters (PARAMS slots): POSITION_SET (1: the Position input is linked), POSITION (3), DIRECTION (3).
Its C twin is core/materials/portal.c; the integrators' teleport is vertex.bsdf_ray and direct.c bsdf_rays.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .base import BSDF, PARAMS, BsdfSample
from .base import BSDFFlags as F
from .nodes import Node, per_hit_rows

POSITION_SET, POSITION, DIRECTION = 0, 1, 4


class Portal(BSDF):
    """A delta that teleports: wi = the unit Direction (or -wo where it is zero), weight 1, pdf inf; eval 0."""

    name: ClassVar[str] = "RAY_PORTAL"
    flags: ClassVar[F] = F.TRANSMISSION | F.SINGULAR | F.STRAIGHT | F.PORTAL
    params: ClassVar[tuple] = ("position_set", "position_x", "position_y", "position_z", "direction_x", "direction_y",
                               "direction_z")

    @staticmethod
    def eval(params, N, wo, wi):
        return np.zeros((len(wi), 3)), np.zeros(len(wi))

    @staticmethod
    def sample(params, N, wo, u):
        return BsdfSample(direction(params, wo), np.ones((len(wo), 3)), np.full(len(wo), np.inf))


def direction(params: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """The portal's unit direction (m, 3): its DIRECTION slots (m, PARAMS) normalised, -wo (m, 3) where they are 0."""
    D = params[:, DIRECTION:DIRECTION + 3]
    length = np.sqrt(np.einsum("ij,ij->i", D, D))
    return np.where((length > 0.0)[:, None], D / np.where(length > 0.0, length, 1.0)[:, None], -wo)


def origins(params: np.ndarray, I: np.ndarray, origin) -> tuple:
    """Where portal rays leave from: (O (m, 3), moved (m,) bool) for camera-relative hits at I (m, 3): the Position
    (a world point) made camera-relative (minus the geometry's `origin` (3,)) where it is linked and more than 1e-9
    (squared) away from the hit (Cycles' test), else the hit (moved False: the caller steps it off the surface)."""
    P = params[:, POSITION:POSITION + 3] - np.asarray(origin, np.float64).reshape(1, 3)
    gap = P - I
    moved = (params[:, POSITION_SET] != 0.0) & (np.einsum("ij,ij->i", gap, gap) > 1e-9)
    return np.where(moved[:, None], P, I), moved


class PortalNode(Node):
    """Ray Portal BSDF (ShaderNodeBsdfRayPortal): one Portal closure of the node's weight (its colour), with its
    Position (position_set 1 where the input is linked; else the hit point) and Direction (0: the ray's own)."""

    name = "RAY_PORTAL"
    inputs = ("position_set", "position", "direction")
    defaults = (0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    @staticmethod
    def setup(b, weight, p):
        n = len(weight)
        p = per_hit_rows(p, n)
        params = np.zeros((n, PARAMS))
        params[:, POSITION_SET] = p[:, 0]
        params[:, POSITION:POSITION + 3] = p[:, 1:4]
        params[:, DIRECTION:DIRECTION + 3] = p[:, 4:7]
        b.add(Portal.kind, weight, params)


def shadow_transparency(shader) -> np.ndarray:
    """What a shadow ray passes (n, 3) at n hits of a ShaderResult, as Cycles' shadow rays see a portal: they set up no
    closures, so no portal either (SD_RAY_PORTAL stays unset), but the portal's weight joins the transparent
    extinction; which counts only where a Transparent closure (or alpha) made the surface transparent at all. A
    surface that is a portal and no Transparent BSDF stops shadow rays; Mix(Transparent, Portal) lets them through as
    if both were transparent."""
    from .base import has
    portal = np.where(has(shader.closures.kind, F.PORTAL)[..., None], shader.closures.weight, 0.0).sum(axis=1)
    clear = (shader.transparency != 0.0).any(axis=1)
    return np.where(clear[:, None], shader.transparency + portal, 0.0)
