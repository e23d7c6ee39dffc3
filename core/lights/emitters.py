"""Emissive meshes as one light: every triangle whose material emits, sampled in proportion to its power.

A triangle of a material with Emission (colour x strength = radiance L_e, the same from both sides,
as in Cycles) lights the scene like an area light. For next-event estimation the emitters are one
light: a triangle is chosen by a light tree (core/lights/light_tree.py): a walk down a bounding-volume
hierarchy over the triangles, each step by the importance of the two children seen from the shading
point (their power, distance and orientation; by power alone where neither can light it), as in
Cycles. Then a direction towards it, by one of two strategies, as Cycles chooses them
(cycles_lights.md, section 1.3):

- near a triangle (its plane closer than about its size), the direction is uniform over the
  spherical triangle it subtends (Arvo, "Stratified sampling of spherical triangles", 1995):
  pdf = 1 / Omega, the triangle's solid angle;
- far from it, a point uniform in its area: pdf = t^2 / (|cos theta_light| A).

A quad lamp (two triangles of one object and material, constant emission, that make a rectangle: `quad_partners`) is
one emitter, one leaf of the tree, sampled near it uniformly over the spherical rectangle it subtends (Urena, Fajardo
and King, "An area-preserving parametrization for spherical rectangles", 2013: pdf = 1 / Omega of the rectangle), far
from it uniformly in its area; no number goes to a pick between its two halves, and one 2D point covers it all
(docs/performance.md, "A quad lamp sampled as one spherical rectangle"). Cycles samples a mesh lamp's two triangles.

The pdf of a direction is the pick probability times that. A BSDF-sampled ray that hits an emissive
triangle asks `pdf_of_hits` for the pdf the light would have given its direction, for MIS: the tree
gives the same pick probability for that triangle from the ray's origin, walking its path (either triangle of a quad:
the quad's pdf).
An emitter that moves over the shutter (object or deformation motion blur) is sampled where it is at the
shading point's time (its corners placed as the geometry places them for the rays, Cycles' triangle_light_sample
with motion_triangle_vertices at the path's time), and a BSDF ray that hits it gets the pdf of its corners at the
ray's time, the same; its leaf in the light tree bounds it over the whole shutter (`shutter_bounds`), so the walk's
probabilities do not depend on the time and stay > 0 wherever it can light a point at some time.
A material's Emission Sampling (None, Front, Back, Front and Back; Auto: both when it emits much)
says from which sides the triangle is sampled; its emission is seen from both sides regardless.
A textured emitter (its node graph gives the emission) is picked by its mean emission at a few points
inside it; the integrator evaluates the graph where each sample lands (integrators/vertex.py textured_samples).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import ClassVar, Optional

import numpy as np

from .. import vectors
from ..native import library, schema
from ..native.schema import F64, I32, I64, U8, out, ptr
from .base import Light, LightFlags, LightSample
from .light_tree import LightTree

FRONT, BACK = 1, 2
# Whether a quad lamp (two triangles that make an exact rectangle, `quad_partners`) is sampled as one spherical
# rectangle (True, the renders') or as its two triangles (False; PRIMER_QUADS=0 in the environment, for comparing:
# docs/performance.md, "A quad lamp sampled as one spherical rectangle").
QUADS = os.environ.get("PRIMER_QUADS", "1") != "0"


@dataclass
class MeshEmitters(Light):
    """All emissive triangles of a scene, camera-relative.

    corners:  (t, 3, 3) float64 each triangle's corners
    normal:   (t, 3) float64 unit front-side normals (counter-clockwise corners)
    area:     (t,) float64
    emission: (t, 3) float64 radiance L_e
    sides:    (t,) int32 FRONT | BACK: from which sides the triangle is sampled (0: never)
    prim:     (t,) int64 WorldGeometry's flat triangle index of each
    power:    (t,) float64 area x mean(L_e), each triangle's power estimate
    tree:     the LightTree over the triangles that picks one for a shading point
    hidden:   (t,) uint8 the Ray Visibility bits (geometry.HIDDEN_FROM_*) of each triangle's object, or None
              where no emitting object hides from diffuse, glossy or transmission rays
    textured: (t,) bool the triangles whose material's node graph gives their emission (a texture): `emission`
              is then only its estimate (for picking), and the integrators evaluate the graph where a sample
              lands (integrators/vertex.py graph_emission); None where there are none
    mesh:     (t,) int32 the instanced mesh (WorldGeometry.instanced) of each emitter that moves or deforms over the
              shutter, -1 for still ones; None where none moves. `corners`, `normal`, `area` are then the frame's,
              and `corners_at` places a moving one at a time in the shutter.
    meshes:   WorldGeometry.instanced, which `mesh` indexes (None where none moves)
    partner:  (t,) int64 the other triangle of the quad lamp each triangle is half of (`quad_partners`: two triangles
              of one object and material, constant emission, sharing a diagonal, together an exact rectangle), -1 for
              a triangle alone; None where there is no quad. A quad is one emitter: the tree's leaf holds its lead
              (the lower index of the two, whose row `sample` returns), sampled as one spherical rectangle
              (Urena et al. 2013); both triangles share its path, so a BSDF ray that hits either gets its pdf.
    rect:     (t, 3, 3) float64 each quad triangle's rectangle [corner, edge u, edge v] (edge u x edge v along the
              front normal; the lead's row is the one read), None where there is no quad
    """

    corners: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    emission: np.ndarray
    sides: np.ndarray
    prim: np.ndarray
    power: np.ndarray
    tree: LightTree
    name: str = "Emissive meshes"
    hidden: Optional[np.ndarray] = None
    textured: Optional[np.ndarray] = None
    mesh: Optional[np.ndarray] = None
    meshes: Optional[list] = None
    partner: Optional[np.ndarray] = None
    rect: Optional[np.ndarray] = None

    flags: ClassVar[LightFlags] = LightFlags.EMITTER
    blender_type: ClassVar[str] = "MESH"

    @property
    def color(self) -> np.ndarray:
        return np.ones(3)

    @property
    def delta(self) -> bool:
        return False

    @property
    def hittable(self) -> bool:
        return True

    def emits(self) -> bool:
        return len(self.prim) > 0 and self.power.sum() > 0

    def finite(self) -> bool:
        return bool(np.isfinite(self.corners).all() and np.isfinite(self.emission).all())

    def moved(self, origin: np.ndarray) -> "MeshEmitters":
        return self                          # built from the camera-relative geometry already

    @classmethod
    def of(cls, corners: np.ndarray, emission: np.ndarray, sides: np.ndarray, prim: np.ndarray,
           textured: Optional[np.ndarray] = None, mesh: Optional[np.ndarray] = None,
           meshes: Optional[list] = None, quad_key: Optional[np.ndarray] = None) -> Optional["MeshEmitters"]:
        """The emitters of triangles with corners (t, 3, 3), radiance (t, 3), sides (t,), textured (t,) bool or
        None; mesh (t,) int32 the instanced mesh of the moving ones (-1: still) of `meshes` (or both None: none
        moves); quad_key (t,) int64: two triangles may be one quad lamp only where their keys are equal and >= 0
        (the same object and material; `quad_partners`), None: no quads; None if none emits."""
        cross, length = face_cross(corners)
        area = 0.5 * length
        power = area * np.abs(emission).mean(axis=1) * (sides > 0)
        keep = np.isfinite(power) & (power > 0.0)
        if not keep.any():
            return None
        corners, emission, sides, prim = corners[keep], emission[keep], sides[keep], prim[keep]
        normal = cross[keep] / length[keep, None]
        sides = sides.astype(np.int32)
        mesh = mesh[keep].astype(np.int32) if mesh is not None and (mesh[keep] >= 0).any() else None
        leaves = None if mesh is None else shutter_bounds(corners, normal, sides, prim, mesh, meshes)
        textured = textured[keep] if textured is not None and textured[keep].any() else None
        partner = rect = None
        if quad_key is not None:
            key = np.asarray(quad_key, np.int64)[keep].copy()
            if mesh is not None:
                key[mesh >= 0] = -1                  # (a moving emitter stays triangles)
            if textured is not None:
                key[textured] = -1                   # (a textured one too: its emission varies)
            partner, rect = quad_partners(corners, normal, emission, sides, key)
        if partner is None:
            tree = LightTree.build(corners, normal, power[keep], sides, leaves)
        else:
            tree = quad_tree(corners, normal, power[keep], sides, leaves, partner)
        return cls(corners, normal, area[keep], emission, sides, prim, power[keep], tree, textured=textured,
                   mesh=mesh, meshes=None if mesh is None else meshes, partner=partner, rect=rect)

    def corners_at(self, index: np.ndarray, times: Optional[np.ndarray] = None) -> tuple:
        """Emitters `index` (n,) int64 where they are at `times` (n,) float64 in the shutter (None: the frame):
        (corners (n, 3, 3), unit normals (n, 3), areas (n,)) float64; a still one's are the frame's, a moving one's
        placed as the geometry places it for rays at that time (InstancedMesh.corner_points)."""
        V, normal, area = self.corners[index], self.normal[index], self.area[index]
        if self.mesh is None or times is None:
            return V, normal, area
        moving = self.mesh[index]
        for m in np.unique(moving[moving >= 0]):
            rows = np.flatnonzero(moving == m)
            mesh = self.meshes[m]
            j, local = mesh.split(self.prim[index[rows]])
            placed = mesh.corner_points(j, local, np.asarray(times, np.float64)[rows])
            cross, length = face_cross(placed)
            V[rows], area[rows] = placed, 0.5 * length      # (V, normal, area: the rows' own copies, fancy-indexed)
            with np.errstate(divide="ignore", invalid="ignore"):
                normal[rows] = np.nan_to_num(cross / length[:, None])
        return V, normal, area

    def pick_probability(self, points: np.ndarray, index: np.ndarray, N: Optional[np.ndarray] = None) -> np.ndarray:
        """P(the tree chooses triangle `index` (n,) int64 from points (n, 3) with normals N (n, 3), zero rows
        or None: unknown): (n,) float64."""
        return self.tree.pick_probability(points, unknown_normals(points, N), index)

    def sample(self, points: np.ndarray, u: np.ndarray, cone=None, N: Optional[np.ndarray] = None,
               times: Optional[np.ndarray] = None) -> LightSample:
        """One emissive triangle per point, chosen by the light tree from the point and its normal N (n, 3)
        (zero rows or None: unknown) with u[:, 0], then a direction towards it from u[:, 0] rescaled within the
        triangle's share and u[:, 1]: the unit-square points that pick one triangle stay stratified (Cycles draws a
        third, jointly stratified Sobol dimension for the pick; a separate number would leave each triangle a
        random subset of the points, and the noise falling only as 1/N). times: (n,) float64 the points' times in
        the shutter, where a moving emitter is sampled (None: the frame)."""
        n = len(points)
        index, pick, reused = self.tree.pick(points, unknown_normals(points, N), u[:, 0])
        u = np.stack([reused, u[:, 1]], axis=1)
        V, normal, area = self.corners_at(index, times)
        allowed, spherical = side_and_way(V, normal, area, self.sides[index], points)
        quad = self.quads(index)
        if quad.any():
            allowed[quad], spherical[quad] = rectangle_side_and_way(self.rect[index[quad]], normal[quad],
                                                                    self.sides[index[quad]], points[quad])
        L, distance, pdf_direction = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
        for rows, sampler in ((spherical & ~quad, "spherical"), (~spherical & ~quad, "area"),
                              (spherical & quad, "rectangle"), (~spherical & quad, "rectangle_area")):
            rows = np.flatnonzero(rows)
            if not len(rows):
                continue
            P, numbers = points[rows], u[rows, :2]
            if sampler == "spherical":
                found = spherical_triangle_sample(P, V[rows], numbers)
            elif sampler == "area":
                found = area_sample(P, V[rows], normal[rows], area[rows], numbers)
            elif sampler == "rectangle":
                found = spherical_rectangle_sample(P, self.rect[index[rows]], numbers)
            else:
                found = rectangle_area_sample(P, self.rect[index[rows]], normal[rows], numbers)
            L[rows], distance[rows], pdf_direction[rows] = found
        pdf = pick * pdf_direction
        ok = allowed & (pdf > 0.0) & np.isfinite(pdf)
        with np.errstate(divide="ignore", invalid="ignore"):
            strength = np.where(ok, 1.0 / pdf, 0.0)
        position = points + L * distance[:, None]
        hidden = None if self.hidden is None else self.hidden[index].astype(np.int64)
        return LightSample(L, distance, strength, np.where(ok, pdf, 0.0), self.emission[index], position, hidden,
                           index, normal)

    def pdf_of_hits(self, origins: np.ndarray, index: np.ndarray, D: np.ndarray, t: np.ndarray,
                    N: Optional[np.ndarray] = None, times: Optional[np.ndarray] = None) -> np.ndarray:
        """The pdf with which `sample` would choose the direction D from `origins` (normals N, as `sample`'s)
        to emitter `index` at distance t (a BSDF-sampled ray that hit it) at the rays' `times` (n,) (a moving
        emitter where it is then; None: the frame): (n,) float64, 0 where the side is not sampled. A hit on either
        triangle of a quad gets the quad's pdf (its lead's: the same pick, the rectangle's direction pdf)."""
        index = self.lead(index)
        V, normal, area = self.corners_at(index, times)
        allowed, spherical = side_and_way(V, normal, area, self.sides[index], origins)
        quad = self.quads(index)
        with np.errstate(divide="ignore", invalid="ignore"):
            omega = solid_angle(origins, V)
            if quad.any():
                R = self.rect[index[quad]]
                allowed[quad], spherical[quad] = rectangle_side_and_way(R, normal[quad], self.sides[index[quad]],
                                                                        origins[quad])
                omega[quad] = rectangle_solid_angle(origins[quad], R)
                area[quad] = rectangle_area(R)
            by_angle = 1.0 / omega
            cos_light = np.abs(np.einsum("ij,ij->i", normal, D))
            by_area = t * t / (cos_light * area)
        pdf = self.pick_probability(origins, index, N) * np.where(spherical, by_angle, by_area)
        return np.where(allowed & np.isfinite(pdf), pdf, 0.0)

    def quads(self, index: np.ndarray) -> np.ndarray:
        """(n,) bool: which of emitters `index` (n,) int64 are half of a quad lamp (sampled as its rectangle)."""
        return np.zeros(len(index), bool) if self.partner is None else self.partner[index] >= 0

    def lead(self, index: np.ndarray) -> np.ndarray:
        """Emitters `index` (n,) int64 with each quad triangle replaced by its quad's lead (the lower index of the
        two, the tree's leaf): (n,) int64."""
        if self.partner is None:
            return index
        other = self.partner[index]
        return np.where(other >= 0, np.minimum(index, other), index)

    def same_emitter(self, index: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """(n,) bool: whether emitter `index` (n,) int64 (a quad: either of its triangles) is WorldGeometry
        triangle `prim` (n,) int64."""
        own = self.prim[index] == prim
        if self.partner is None:
            return own
        other = self.partner[index]
        return own | ((other >= 0) & (self.prim[np.maximum(other, 0)] == prim))

    def index_of_prim(self, prim: np.ndarray) -> np.ndarray:
        """The emitter index of WorldGeometry triangles `prim` (-1 for triangles that are not emitters)."""
        order = np.argsort(self.prim)
        found = np.searchsorted(self.prim[order], prim)
        found = np.clip(found, 0, len(order) - 1)
        return np.where(self.prim[order][found] == prim, order[found], -1)

    def without_attenuation(self, sample: LightSample, points: np.ndarray) -> LightSample:
        return sample._replace(strength=sample.strength * sample.distance * sample.distance)

    def centre_numbers(self) -> np.ndarray:
        return np.array([0.5, 0.5])

    def pack_fields(self, record) -> None:
        """The record says only how many samples and which dimension; the triangles go in `tables`."""

    def tables(self) -> "EmitterTables":
        """The C tables of the emitters (core/lights/lights.h EmitterTables), keeping their arrays alive."""
        return EmitterTables(self)


# Where a textured emitter's mean emission is estimated: barycentrics (u, v) of its centroid and three points
# around it.
ESTIMATE_POINTS = np.array([[1.0 / 3.0, 1.0 / 3.0], [2.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 2.0 / 3.0], [1.0 / 6.0, 1.0 / 6.0]])


def face_cross(V: np.ndarray) -> tuple:
    """Triangles V (n, 3, 3): their edges' cross product (V1 - V0) x (V2 - V0) (n, 3) and its length (n,), twice
    the area."""
    cross = vectors.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
    return cross, np.sqrt(np.einsum("ij,ij->i", cross, cross))


def mean_graph_emission(geometry, materials, prim: np.ndarray, graph_emission) -> np.ndarray:
    """The mean over ESTIMATE_POINTS of what triangles prim (t,) int64 emit by their materials' node graphs,
    seen head-on by a ray other than the camera's: (t, 3) float64, at least 0. graph_emission: what the caller
    evaluates a graph's emission with (core/integrators/direct.py graph_emission; the lights sit below it)."""
    t, k = len(prim), len(ESTIMATE_POINTS)
    P = np.repeat(prim, k)
    u, v = np.tile(ESTIMATE_POINTS[:, 0], t), np.tile(ESTIMATE_POINTS[:, 1], t)
    triangle = geometry.triangle_data(P, smooth=False)
    V = triangle.corners
    I = (1.0 - u - v)[:, None] * V[:, 0] + u[:, None] * V[:, 1] + v[:, None] * V[:, 2]
    D = -triangle.Ng
    emitted = graph_emission(geometry, materials, P, I - D, D, np.ones(len(P)))
    return np.maximum(np.nan_to_num(emitted.reshape(t, k, 3).mean(axis=1)), 0.0)


def unknown_normals(points: np.ndarray, N: Optional[np.ndarray]) -> np.ndarray:
    """N (n, 3) float64, zero rows where the normal is unknown (all of them for None)."""
    return np.zeros_like(points, dtype=np.float64) if N is None else np.asarray(N, np.float64)


def side_and_way(V: np.ndarray, normal: np.ndarray, area: np.ndarray, sides: np.ndarray,
                 points: np.ndarray) -> tuple:
    """Triangles V (n, 3, 3) (unit normals (n, 3), areas (n,), FRONT/BACK bits `sides` (n,)) seen from `points`
    (n, 3): (whether the side each point sees is sampled, whether spherical-triangle sampling serves it rather than
    area sampling), each (n,) bool."""
    # 1. Which side the point sees (height > 0: the point is behind), and whether that side is sampled.
    height = np.einsum("ij,ij->i", normal, V[:, 0] - points)
    allowed = (sides & np.where(height > 0.0, BACK, FRONT)) != 0
    # 2. Spherical-triangle sampling near the triangle, area sampling far from it (Cycles' choice, C's
    #    emitter_spherical: the longest edge squared against delta^2, delta = h / (2 A)).
    longest = np.max(np.stack([np.einsum("ij,ij->i", a, a) for a in
                               (V[:, 1] - V[:, 0], V[:, 2] - V[:, 1], V[:, 0] - V[:, 2])]), axis=0)
    delta = height / (2.0 * area)
    return allowed, longest > delta * delta


def solid_angle(P: np.ndarray, V: np.ndarray) -> np.ndarray:
    """The solid angle of triangles V (n, 3, 3) seen from P (n, 3): Van Oosterom and Strackee's formula."""
    A, B, C = (vectors_unit(V[:, k] - P) for k in range(3))
    triple = np.abs(np.einsum("ij,ij->i", A, vectors.cross(B, C)))
    return 2.0 * np.arctan2(triple, 1.0 + np.einsum("ij,ij->i", A, B) + np.einsum("ij,ij->i", B, C)
                            + np.einsum("ij,ij->i", C, A))


def vectors_unit(v: np.ndarray) -> np.ndarray:
    """v / |v| per row (n, 3)."""
    return v / np.sqrt(np.einsum("ij,ij->i", v, v))[:, None]


def area_sample(P: np.ndarray, V: np.ndarray, normal: np.ndarray, area: np.ndarray, u: np.ndarray):
    """A point uniform in each triangle's area (Heitz's low-distortion map of the square), seen from P:
    (L (n, 3), t (n,), pdf (n,) = t^2 / (|cos theta_light| A))."""
    a, b = u[:, 0].copy(), u[:, 1].copy()
    upper = b > a
    a = np.where(upper, 0.5 * a, a)
    b = np.where(upper, b - a, b)
    lower = ~upper
    b = np.where(lower, 0.5 * b, b)
    a = np.where(lower, a - b, a)
    point = (1.0 - a - b)[:, None] * V[:, 0] + a[:, None] * V[:, 1] + b[:, None] * V[:, 2]
    w = point - P
    t = np.sqrt(np.einsum("ij,ij->i", w, w))
    with np.errstate(divide="ignore", invalid="ignore"):
        L = w / t[:, None]
        cos_light = np.abs(np.einsum("ij,ij->i", normal, L))
        pdf = t * t / (cos_light * area)
    return np.nan_to_num(L), t, np.where(np.isfinite(pdf), pdf, 0.0)


def spherical_triangle_sample(P: np.ndarray, V: np.ndarray, u: np.ndarray):
    """A direction uniform over the spherical triangle V (n, 3, 3) subtends from P (Arvo 1995), and the
    distance to the planar triangle along it: (L (n, 3), t (n,), pdf (n,) = 1 / Omega)."""
    A, B, C = (vectors_unit(V[:, k] - P) for k in range(3))
    # The solid angle Omega (Van Oosterom and Strackee), and the angle alpha at A as its cosine and sine, from the
    # unit normals of the great circles A-B and A-C (n1 x n2 is parallel to A): no inverse trigonometry.
    omega = solid_angle(P, V)
    n1, n2 = vectors.cross(A, B), vectors.cross(A, C)
    n1 = n1 / np.maximum(np.sqrt(np.einsum("ij,ij->i", n1, n1)), 1e-300)[:, None]
    n2 = n2 / np.maximum(np.sqrt(np.einsum("ij,ij->i", n2, n2)), 1e-300)[:, None]
    cos_alpha = np.clip(np.einsum("ij,ij->i", n1, n2), -1.0, 1.0)
    sin_alpha = np.abs(np.einsum("ij,ij->i", A, vectors.cross(n1, n2)))
    # 1. A sub-triangle of area u0 Omega, fixing the third vertex C' on the arc from A to C:
    #    s, t_ = sin and cos of (u0 Omega - alpha), by the angle-difference identities.
    area_hat = u[:, 0] * omega
    sin_hat, cos_hat = np.sin(area_hat), np.cos(area_hat)
    s = sin_hat * cos_alpha - cos_hat * sin_alpha
    t_ = cos_hat * cos_alpha + sin_hat * sin_alpha
    cos_c = np.einsum("ij,ij->i", A, B)
    uu = t_ - cos_alpha
    vv = s + sin_alpha * cos_c
    with np.errstate(divide="ignore", invalid="ignore"):
        q = ((vv * t_ - uu * s) * cos_alpha - vv) / ((vv * s + uu * t_) * sin_alpha)
    q = np.clip(np.nan_to_num(q, nan=1.0), -1.0, 1.0)
    C_perp = C - np.einsum("ij,ij->i", C, A)[:, None] * A
    C_perp = C_perp / np.maximum(np.sqrt(np.einsum("ij,ij->i", C_perp, C_perp)), 1e-300)[:, None]
    C_hat = q[:, None] * A + np.sqrt(np.maximum(1.0 - q * q, 0.0))[:, None] * C_perp
    # 2. A point on the arc from B to C' at the height u1 of the way.
    z = 1.0 - u[:, 1] * (1.0 - np.einsum("ij,ij->i", C_hat, B))
    w = C_hat - np.einsum("ij,ij->i", C_hat, B)[:, None] * B
    w = w / np.maximum(np.sqrt(np.einsum("ij,ij->i", w, w)), 1e-300)[:, None]
    L = z[:, None] * B + np.sqrt(np.maximum(1.0 - z * z, 0.0))[:, None] * w
    L = vectors_unit(L)
    # 3. The distance to the planar triangle along L.
    e1, e2 = V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]
    normal = vectors.cross(e1, e2)
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.einsum("ij,ij->i", V[:, 0] - P, normal) / np.einsum("ij,ij->i", L, normal)
        pdf = np.where(omega > 0.0, 1.0 / omega, 0.0)
    return L, np.where(np.isfinite(distance) & (distance > 0), distance, 0.0), np.where(np.isfinite(pdf), pdf, 0.0)


# Two triangles are one quad lamp only where they make a rectangle to within this: the cosine of the right angles, and
# the gap between the fourth corners as a share of the edges. (A rectangle lamp's float32 vertices, camera-relative,
# round at about 1e-7 of its size: the Cornell box's lamp is right-angled to 1.2e-7. The sampled rectangle, the lead's
# corner and edges made orthogonal, then differs from the two triangles by slivers of at most this share of its area.)
QUAD_TOLERANCE = 1e-6


def quad_partners(corners: np.ndarray, normal: np.ndarray, emission: np.ndarray, sides: np.ndarray,
                  key: np.ndarray) -> tuple:
    """Which triangles pair into quad lamps, sampled as one spherical rectangle: two of equal `key` (>= 0: the same
    object and material) with the same emission and sides, sharing an edge (bit for bit the same two corners) that is
    both's hypotenuse, each right-angled opposite it and the two facing the same way, the corner of each opposite the
    edge the other's mirror through the edge's middle (a rectangle to within QUAD_TOLERANCE, whence coplanar to within
    it too); each triangle in at most one pair (an edge shared by more than two such triangles pairs none).

    corners (t, 3, 3), normal (t, 3), emission (t, 3) float64, sides (t,) int32, key (t,) int64 ->
    (partner (t,) int64, -1 alone; rect (t, 3, 3) float64 [corner, edge u, edge v] of the lead's (the lower index's)
    right angle, edge v made orthogonal to edge u, the same rows for both, edge u x edge v along the normal), or
    (None, None) where none pairs."""
    t = len(corners)
    candidates = np.flatnonzero(key >= 0)
    if len(candidates) < 2:
        return None, None
    V = corners[candidates]
    # The right-angled corner k of each (if any): |cos| of the angle there below the tolerance.
    right = np.full(len(candidates), -1)
    for k in range(3):
        a, b = V[:, (k + 1) % 3] - V[:, k], V[:, (k + 2) % 3] - V[:, k]
        cos = np.einsum("ij,ij->i", a, b) / np.sqrt(np.einsum("ij,ij->i", a, a) * np.einsum("ij,ij->i", b, b))
        right = np.where((np.abs(cos) <= QUAD_TOLERANCE) & (right < 0), k, right)
    # Group the right-angled ones by (key, hypotenuse): its two corners in a canonical order (lexicographic).
    rows = np.flatnonzero(right >= 0)
    k = right[rows]
    B, C = V[rows, (k + 1) % 3], V[rows, (k + 2) % 3]
    swap = (B[:, 0] > C[:, 0]) | ((B[:, 0] == C[:, 0]) & ((B[:, 1] > C[:, 1]) | ((B[:, 1] == C[:, 1]) & (B[:, 2] > C[:, 2]))))
    first, second = np.where(swap[:, None], C, B), np.where(swap[:, None], B, C)
    edge = np.concatenate([key[candidates[rows]].astype(np.float64)[:, None], first, second], axis=1)
    partner = np.full(t, -1, np.int64)
    rect = np.zeros((t, 3, 3))
    if not len(rows):
        return None, None
    _, group, count = np.unique(edge, axis=0, return_inverse=True, return_counts=True)
    group = group.ravel()
    pairs = np.flatnonzero(count[group] == 2)                   # (an edge of exactly two such triangles)
    pairs = pairs[np.argsort(group[pairs], kind="stable")].reshape(-1, 2)
    if not len(pairs):
        return None, None
    i, j = candidates[rows[pairs[:, 0]]], candidates[rows[pairs[:, 1]]]
    ki, kj = k[pairs[:, 0]], k[pairs[:, 1]]
    lead = np.minimum(i, j)
    j, ki, kj = np.maximum(i, j), np.where(i < j, ki, kj), np.where(i < j, kj, ki)
    i = lead
    a, b, c = corners[i, ki], corners[i, (ki + 1) % 3], corners[i, (ki + 2) % 3]
    d = corners[j, kj]
    u, v = b - a, c - a
    size = np.sqrt(np.einsum("ij,ij->i", u, u)) + np.sqrt(np.einsum("ij,ij->i", v, v))
    exact = ((np.abs(a + d - b - c).max(axis=1) <= QUAD_TOLERANCE * size)
             & (np.einsum("ij,ij->i", normal[i], normal[j]) > 0.0)
             & np.all(emission[i] == emission[j], axis=1) & (sides[i] == sides[j]))
    i, j, a, u, v = i[exact], j[exact], a[exact], u[exact], v[exact]
    partner[i], partner[j] = j, i
    v = v - (np.einsum("ij,ij->i", v, u) / np.einsum("ij,ij->i", u, u))[:, None] * u      # (exactly right-angled)
    rect[i] = rect[j] = np.stack([a, u, v], axis=1)
    if not (partner >= 0).any():
        return None, None
    return partner, rect


def quad_tree(corners: np.ndarray, normal: np.ndarray, power: np.ndarray, sides: np.ndarray, leaves,
              partner: np.ndarray) -> LightTree:
    """The light tree over the emitters with each quad one leaf (`quad_partners`): its box, cone and power the union
    of its two triangles', the leaf holding its lead (the lower index), both triangles given the lead's path and
    depth (so that pick_probability of either is the quad's). corners (t, 3, 3), normal (t, 3), power (t,), sides
    (t,), leaves: LightTree.build's bounds per triangle or None, partner (t,) int64 (-1: alone)."""
    t = len(power)
    if leaves is None:
        leaves = (corners.min(axis=1), corners.max(axis=1), np.where((sides == BACK)[:, None], -normal, normal),
                  np.where(sides == (FRONT | BACK), np.pi, 0.0), corners.mean(axis=1))
    lo, hi, axis, theta, centroid = (np.array(a) for a in leaves)
    other = np.maximum(partner, 0)
    quad = partner >= 0
    lo[quad] = np.minimum(lo[quad], lo[other[quad]])
    hi[quad] = np.maximum(hi[quad], hi[other[quad]])
    centroid[quad] = 0.5 * (centroid[quad] + centroid[other[quad]])
    power = np.where(quad, power + power[other], power)
    units = np.flatnonzero(~quad | (np.arange(t) < partner))        # alone, or a quad's lead
    tree = LightTree.build(corners[units], normal[units], power[units], sides[units],
                           (lo[units], hi[units], axis[units], theta[units], centroid[units]))
    nodes = tree.nodes.copy()
    leaf = nodes[:, 12] < 0.0                                            # (light_tree.LEFT < 0: a leaf's -1 - unit)
    nodes[leaf, 12] = -1.0 - units[(-1.0 - nodes[leaf, 12]).astype(np.int64)]
    unit_of = np.full(t, -1, np.int64)
    unit_of[units] = np.arange(len(units))
    unit_of[quad] = unit_of[np.minimum(np.arange(t), partner)[quad]]
    return LightTree(nodes, tree.path[unit_of], tree.depth[unit_of], tree.rule)


def rectangle_area(R: np.ndarray) -> np.ndarray:
    """The areas (n,) of rectangles R (n, 3, 3) [corner, edge u, edge v]."""
    c = vectors.cross(R[:, 1], R[:, 2])
    return np.sqrt(np.einsum("ij,ij->i", c, c))


def rectangle_side_and_way(R: np.ndarray, normal: np.ndarray, sides: np.ndarray, points: np.ndarray) -> tuple:
    """side_and_way for quads: rectangles R (n, 3, 3) (unit normals (n, 3), sides (n,)) seen from points (n, 3):
    (whether the side seen is sampled, whether the spherical rectangle serves it rather than area sampling), (n,)
    bool each; spherical where its diagonal squared exceeds delta^2, delta = h / (2 A) (the triangles' rule, with the
    quad's longest chord and area)."""
    height = np.einsum("ij,ij->i", normal, R[:, 0] - points)
    allowed = (sides & np.where(height > 0.0, BACK, FRONT)) != 0
    diagonal = R[:, 1] + R[:, 2]
    delta = height / (2.0 * rectangle_area(R))
    return allowed, np.einsum("ij,ij->i", diagonal, diagonal) > delta * delta


def rectangle_constants(R: np.ndarray) -> np.ndarray:
    """What rectangles R (n, 3, 3) [corner, edge u, edge v] give their frame from wherever they are seen (emitters.c
    rectangle_constants, made once for a quad lamp's EmitterTables.rect_frame): (n, 12) float64 x, y the unit edges,
    z = x cross y, lx, ly the edge lengths, the area |edge u x edge v|; each by the C's operations in its order (the
    same numbers as the C makes per sample)."""
    U, V = R[:, 1], R[:, 2]
    lx = np.sqrt(U[:, 0] * U[:, 0] + U[:, 1] * U[:, 1] + U[:, 2] * U[:, 2])
    ly = np.sqrt(V[:, 0] * V[:, 0] + V[:, 1] * V[:, 1] + V[:, 2] * V[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):        # (a lone triangle's row: zeros, never read)
        x, y = U / lx[:, None], V / ly[:, None]

    def cross(a, b):
        """a x b (n, 3) written out as emitters.c cross_product."""
        return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                         a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)

    n = cross(U, V)
    area = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])
    return np.concatenate([x, y, cross(x, y), lx[:, None], ly[:, None], area[:, None]], axis=1)


def rectangle_frame(P: np.ndarray, R: np.ndarray) -> tuple:
    """Rectangles R (n, 3, 3) seen from P (n, 3) in Urena et al.'s local frame (x along edge u, y along edge v, z
    their normal turned away from P): (x, y, z (n, 3), x0, x1, y0, y1, z0 (n,) the rectangle's extent, z0 <= 0,
    nz (4, n) the z components of the unit normals of the four planes through P and its edges, turn (3, n) = S the
    solid angle, cos(g2 + g3), sin(g2 + g3): g_k the asin terms, the interior angles pi/2 - g_k, S = -sum(g), and
    the paper's k - pi as a unit complex number).

    No arcsin: each corner's cos g_k + i sin g_k, sin g_k = -nz_k nz_k+1, cos g_k = |z0| |corner k + 1| /
    (rho_k rho_k+1) (rho_k the length of plane k's raw normal: no cancellation in sqrt(1 - sin^2)), multiplied in
    pairs A (corners 0, 1) and B (2, 3); -AB = exp(i (pi - S)) with pi - S in (-pi, pi): one arctan2, no wrap-around
    (nor cancellation against 2 pi). Where P is on the plane (z0 not < 0, every cos g_k 0), S is the four arcsin's
    sum."""
    lx = np.sqrt(np.einsum("ij,ij->i", R[:, 1], R[:, 1]))
    ly = np.sqrt(np.einsum("ij,ij->i", R[:, 2], R[:, 2]))
    x, y = R[:, 1] / lx[:, None], R[:, 2] / ly[:, None]
    z = vectors.cross(x, y)
    d = R[:, 0] - P
    z0 = np.einsum("ij,ij->i", d, z)
    away = z0 > 0.0
    z = np.where(away[:, None], -z, z)
    z0 = np.where(away, -z0, z0)
    x0, y0 = np.einsum("ij,ij->i", d, x), np.einsum("ij,ij->i", d, y)
    x1, y1 = x0 + lx, y0 + ly
    raw = np.stack([-y0, x1, y1, -x0])
    rho = np.sqrt(raw * raw + z0 * z0)
    following, rho_following = np.roll(raw, -1, axis=0), np.roll(rho, -1, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        nz = raw / rho
        sin_g = -nz * np.roll(nz, -1, axis=0)                     # (unclamped: arctan2 takes them as they are)
        cos_g = -z0 * np.sqrt(raw * raw + following * following + z0 * z0) / (rho * rho_following)
    re_A, im_A = cos_g[0] * cos_g[1] - sin_g[0] * sin_g[1], cos_g[0] * sin_g[1] + sin_g[0] * cos_g[1]
    re_B, im_B = cos_g[2] * cos_g[3] - sin_g[2] * sin_g[3], cos_g[2] * sin_g[3] + sin_g[2] * cos_g[3]
    S = np.pi - np.arctan2(-(re_A * im_B + im_A * re_B), -(re_A * re_B - im_A * im_B))
    on_plane = ~(z0 < 0.0)
    if on_plane.any():
        g = np.arcsin(np.clip(sin_g[:, on_plane], -1.0, 1.0))
        S[on_plane] = -(g[0] + g[1] + g[2] + g[3])
    return x, y, z, x0, x1, y0, y1, z0, nz, np.stack([S, re_B, im_B])


def rectangle_solid_angle(P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The solid angle (n,) of rectangles R (n, 3, 3) seen from points P (n, 3) (Urena et al. 2013; 0 seen
    edge-on)."""
    return np.nan_to_num(rectangle_frame(P, R)[-1][0])


def spherical_rectangle_sample(P: np.ndarray, R: np.ndarray, u: np.ndarray):
    """A direction uniform over the spherical rectangle that rectangles R (n, 3, 3) subtend from P (n, 3) by the
    unit-square points u (n, 2) (Urena, Fajardo and King, "An area-preserving parametrization for spherical
    rectangles", 2013; u[:, 0] picks the x of the point by the solid angle left of it, u[:, 1] its y uniformly in
    the height of the direction's projection): (L (n, 3), t (n,) distance to the point, pdf (n,) = 1 / Omega)."""
    x, y, z, x0, x1, y0, y1, z0, nz, turn = rectangle_frame(P, R)
    S = np.nan_to_num(turn[0])
    b0, b1 = nz[0], nz[2]
    # 1. x: the solid angle left of it is u0 S (the paper's au = u0 S + k, k = pi + g2 + g3 with the pi taken out
    #    by flipping the signs of cos and sin, and of b1 with them): sin and cos of u0 S turned by g2 + g3.
    sin_a, cos_a = np.sin(u[:, 0] * S), np.cos(u[:, 0] * S)
    sin_au, cos_au = sin_a * turn[1] + cos_a * turn[2], cos_a * turn[1] - sin_a * turn[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        fu = np.where(sin_au != 0.0, (cos_au * b0 + b1) / sin_au, 0.0)
        cu = np.clip(np.copysign(1.0 / np.sqrt(fu * fu + b0 * b0), fu), -1.0, 1.0)
        xu = -(cu * z0) / np.maximum(np.sqrt(np.maximum(1.0 - cu * cu, 0.0)), 1e-300)
    xu = np.clip(np.nan_to_num(xu), x0, x1)
    # 2. y: uniform in h = cos of the angle to the y axis between its values at the two ends.
    d2 = xu * xu + z0 * z0
    h0, h1 = y0 / np.sqrt(d2 + y0 * y0), y1 / np.sqrt(d2 + y1 * y1)
    hv = h0 + u[:, 1] * (h1 - h0)
    with np.errstate(divide="ignore", invalid="ignore"):
        yv = np.where(hv * hv < 1.0 - 1e-12, hv * np.sqrt(d2 / (1.0 - hv * hv)), y1)
    w = xu[:, None] * x + yv[:, None] * y + z0[:, None] * z
    t = np.sqrt(np.einsum("ij,ij->i", w, w))
    with np.errstate(divide="ignore", invalid="ignore"):
        L = w / t[:, None]
        pdf = np.where(S > 0.0, 1.0 / S, 0.0)
    ok = np.isfinite(t) & (t > 0.0) & np.isfinite(pdf)
    return np.where(ok[:, None], np.nan_to_num(L), 0.0), np.where(ok, t, 0.0), np.where(ok, pdf, 0.0)


def rectangle_area_sample(P: np.ndarray, R: np.ndarray, normal: np.ndarray, u: np.ndarray):
    """A point uniform in rectangles R (n, 3, 3), corner + u0 edge u + u1 edge v, seen from P (n, 3): (L (n, 3),
    t (n,), pdf (n,) = t^2 / (|cos theta_light| A))."""
    w = R[:, 0] + u[:, :1] * R[:, 1] + u[:, 1:2] * R[:, 2] - P
    t = np.sqrt(np.einsum("ij,ij->i", w, w))
    with np.errstate(divide="ignore", invalid="ignore"):
        L = w / t[:, None]
        cos_light = np.abs(np.einsum("ij,ij->i", normal, L))
        pdf = t * t / (cos_light * rectangle_area(R))
    return np.nan_to_num(L), t, np.where(np.isfinite(pdf), pdf, 0.0)


def from_geometry(geometry, materials, graph_emission, notes: Optional[list] = None) -> Optional[MeshEmitters]:
    """The emitters of a WorldGeometry: the triangles whose material (a row of the MaterialTable) emits.

    Each material's `emission_sides` (FRONT | BACK, 0 for Emission Sampling None) and its emission
    estimate (a constant shader's emission) decide; copied and instanced triangles alike. graph_emission
    (core/integrators/direct.py graph_emission, from the caller) estimates what textured emitters emit.
    notes: a list for what the emitters leave out (nothing today), or None. Emitters that move or deform over the shutter (an
    instanced mesh with motion) are sampled where they are at each point's time (MeshEmitters.corners_at).
    """
    emission = np.array([np.asarray(shader.emission, np.float64) for shader in materials.shaders])
    sides = np.array([getattr(shader, "emission_sides", FRONT | BACK) for shader in materials.shaders], np.int32)
    by_graph = materials.graph_emits
    emissive = ((emission.max(axis=1) > 0.0) | by_graph) & (sides > 0)
    if not emissive.any():
        return None
    corners, rows_of, prims, meshes_of = [], [], [], []
    if len(geometry.triangles):
        prim = np.flatnonzero(emissive[geometry.material])
        if len(prim):
            corners.append(geometry.corner_points(prim))
            rows_of.append(geometry.material[prim])
            prims.append(prim)
            meshes_of.append(np.full(len(prim), -1, np.int32))
    for m, mesh in enumerate(geometry.instanced):
        rows = mesh.material[mesh.material_row]                  # (k, t) each placement's materials
        j, local = np.nonzero(emissive[rows])
        if len(j):
            corners.append(mesh.corner_points(j, local))
            rows_of.append(rows[j, local])
            prims.append(mesh.first_prim + j * len(mesh.triangles) + local)
            # (a moving or deforming placement: sampled where it is at each point's time)
            meshes_of.append(np.full(len(j), m if mesh.motion is not None or mesh.vertex_steps is not None else -1,
                                     np.int32))
    if not corners:
        return None
    material, prim = np.concatenate(rows_of), np.concatenate(prims).astype(np.int64)
    mesh_of = np.concatenate(meshes_of)
    radiance, textured = emission[material], by_graph[material]
    if textured.any():
        # A textured emitter is picked by its mean emission at a few points inside it (an estimate: where it is 0,
        # only BSDF rays find the triangle, with MIS weight 1); what a sample brings is evaluated where it lands.
        radiance[textured] = mean_graph_emission(geometry, materials, prim[textured], graph_emission)
    moving = (mesh_of >= 0).any()
    # Quad lamps (quad_partners) only within one object and material: the same emission, sides, visibility, light
    # group and links.
    quad_key = (geometry.owners(prim) + 1) * len(materials.shaders) + material if QUADS else None
    emitters = MeshEmitters.of(np.concatenate(corners), radiance, sides[material], prim,
                               textured if textured.any() else None, mesh_of if moving else None,
                               list(geometry.instanced) if moving else None, quad_key)
    if emitters is not None:
        emitters.hidden = hidden_bits_of(geometry, emitters.prim)
    return emitters


# Times in the shutter at which a moving emitter's leaf bounds are taken: this many per interval between its steps.
BOUND_TIMES_PER_STEP = 16


def shutter_bounds(corners: np.ndarray, normal: np.ndarray, sides: np.ndarray, prim: np.ndarray, mesh: np.ndarray,
                   meshes: list) -> tuple:
    """The light tree's leaves of emitters that may move: each one's box and orientation cone over the whole shutter
    (a still one's its own), so that its importance bounds what it sends at any time.

    corners (t, 3, 3), normal (t, 3), sides (t,), prim (t,), mesh (t,) int32 (-1: still) of `meshes`
    (InstancedMesh) -> (lo (t, 3), hi (t, 3), axis (t, 3), theta_o (t,), centroid (t, 3)) float64. A moving one
    is placed at BOUND_TIMES_PER_STEP times per interval between its steps; its box is padded by twice the most
    a corner travels between two of them, its cone (the union of its normals, the sampled side's) by twice the most
    its normal turns (the paths between the times are smooth: shorter than that)."""
    from .light_tree import cone_union
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    axis = np.where((sides == BACK)[:, None], -normal, normal)
    theta = np.where(sides == (FRONT | BACK), np.pi, 0.0)
    centroid = corners.mean(axis=1)
    for m in np.unique(mesh[mesh >= 0]):
        rows = np.flatnonzero(mesh == m)
        instanced = meshes[m]
        j, local = instanced.split(prim[rows])
        steps = max(2, 0 if instanced.motion is None else len(instanced.motion),
                    0 if instanced.vertex_steps is None else len(instanced.vertex_steps))
        times = np.linspace(0.0, 1.0, BOUND_TIMES_PER_STEP * (steps - 1) + 1)
        n = len(rows)
        low, high = np.full((n, 3), np.inf), np.full((n, 3), -np.inf)
        cone_axis, cone_theta = None, np.zeros(n)
        travel, turn = np.zeros(n), np.zeros(n)
        degenerate = np.zeros(n, bool)
        before = before_normal = None
        for time in times:
            V = instanced.corner_points(j, local, np.full(n, time))
            low, high = np.minimum(low, V.min(axis=1)), np.maximum(high, V.max(axis=1))
            cross, length = face_cross(V)
            degenerate |= ~(length > 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                n_t = np.nan_to_num(cross / length[:, None])
            a_t = np.where((sides[rows] == BACK)[:, None], -n_t, n_t)
            if before is not None:
                travel = np.maximum(travel, np.sqrt(np.einsum("ikj,ikj->ik", V - before, V - before)).max(axis=1))
                turn = np.maximum(turn, np.arccos(np.clip(np.einsum("ij,ij->i", n_t, before_normal), -1.0, 1.0)))
                cone_axis, cone_theta = cone_union(cone_axis, cone_theta, a_t, np.zeros(n))
            else:
                cone_axis = a_t
            before, before_normal = V, n_t
        lo[rows], hi[rows] = low - 2.0 * travel[:, None], high + 2.0 * travel[:, None]
        centroid[rows] = 0.5 * (low + high)
        everywhere = (sides[rows] == (FRONT | BACK)) | degenerate
        axis[rows] = cone_axis
        theta[rows] = np.where(everywhere, np.pi, np.minimum(cone_theta + 2.0 * turn, np.pi))
    return lo, hi, axis, theta, centroid


def hidden_bits_of(geometry, prim: np.ndarray) -> Optional[np.ndarray]:
    """Ray Visibility > Diffuse, Glossy, Transmission, Volume Scatter of the objects of the emissive triangles `prim`
    (t,) int64: as in Cycles, the light samples of an object hidden from a kind of ray light no closure of that kind
    (integrators/vertex.py closures_left_out) and, hidden from Volume Scatter, no scattering point (volume.py). (t,) uint8 their HIDDEN_FROM_* bits, or None where none is hidden."""
    from ..visibility import HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION, HIDDEN_FROM_VOLUME_SCATTER
    bits = HIDDEN_FROM_DIFFUSE | HIDDEN_FROM_GLOSSY | HIDDEN_FROM_TRANSMISSION | HIDDEN_FROM_VOLUME_SCATTER
    if not geometry.hides(bits):
        return None
    owner = geometry.owners(prim)
    hidden = np.where(owner >= 0, geometry.instance_hidden[np.maximum(owner, 0)] & bits, 0).astype(np.uint8)
    return hidden if hidden.any() else None


EmitterTablesRecord = schema.record("EmitterTables", "The emissive triangles as one light (core/lights/emitters.py MeshEmitters), camera-relative.", [
    ("corners", ptr(F64), "(t, 3, 3)"),
    ("normal", ptr(F64), "(t, 3) unit front-side normals"),
    ("area", ptr(F64), "(t,)"),
    ("emission", ptr(F64), "(t, 3) radiance"),
    ("sides", ptr(I32), "(t,) FRONT 1 | BACK 2"),
    ("nodes", ptr(F64), "(k, TREE_FIELDS) the light tree's nodes (core/lights/light_tree.py), root first"),
    ("path", ptr(I64), "(t,) each emitter's branch bits from the root (bit l: 1 = right)"),
    ("depth", ptr(I64), "(t,) each emitter's steps from the root to its leaf"),
    ("rule", I32, "how the tree's walk weighs a node's children (LightTree.rule): 0 Cycles' mean of the upper and\n"
                  "lower importance bounds' shares, 1 the upper bounds' share alone (the renders'), 2 power alone"),
    ("sorted_prim", ptr(I64), "(t,) WorldGeometry's flat triangle index of each, ascending"),
    ("order", ptr(I64), "(t,) the emitter of each sorted_prim"),
    ("count", I64, "t"),
    ("hidden", ptr(U8), "(t,) each triangle's object's Ray Visibility bits (HIDDEN_FROM_*), or NULL"),
    ("textured", ptr(U8), "(t,) 1: its material's node graph gives its emission (direct.c), or NULL"),
    ("prim", ptr(I64), "(t,) WorldGeometry's flat triangle index of each"),
    ("group", ptr(I32), "(t,) each triangle's object's light group (core/integrators/lightgroups.py), or NULL"),
    ("mesh", ptr(I32), "(t,) the instanced mesh (GeometryTables.meshes) of each emitter that moves over the shutter,\n"
                       "-1 still (MeshEmitters.mesh), or NULL: none moves"),
    ("geometry", ptr(), "the scene's GeometryTables (core/geometry/tables.py), where a moving emitter is placed at a\n"
                        "time (with mesh; untyped: the lights sit below the geometry), or NULL"),
    ("partner", ptr(I64), "(t,) the other triangle of each one's quad lamp (MeshEmitters.partner), -1 alone, or NULL:\n"
                          "no quads"),
    ("rect", ptr(F64), "(t, 3, 3) each quad triangle's rectangle [corner, edge u, edge v] (MeshEmitters.rect), or NULL"),
    ("rect_frame", ptr(F64), "(t, 12) each quad triangle's rectangle's constants (rectangle_constants: unit edges x, y,\n"
                             "z = x cross y, edge lengths lx, ly, area), or NULL: emitters.c makes them per sample"),
])


class EmitterTables:
    """MeshEmitters' arrays in C's dtypes and the record (EmitterTables) that points at them (its `geometry`, which
    moving emitters need, is the renderer's GeometryTables: set by core/integrators/compiled.py)."""

    def __init__(self, emitters: MeshEmitters):
        c = library.contiguous
        order = np.argsort(emitters.prim, kind="stable").astype(np.int64)
        tree = emitters.tree
        self.record = EmitterTablesRecord(
            corners=c(emitters.corners, np.float64), normal=c(emitters.normal, np.float64),
            area=c(emitters.area, np.float64), emission=c(emitters.emission, np.float64),
            sides=c(emitters.sides, np.int32), nodes=c(tree.nodes, np.float64), path=c(tree.path, np.int64),
            depth=c(tree.depth, np.int64), rule=tree.rule, sorted_prim=c(emitters.prim[order], np.int64), order=order,
            count=len(emitters.prim), hidden=None if emitters.hidden is None else c(emitters.hidden, np.uint8),
            textured=None if emitters.textured is None else c(emitters.textured, np.uint8),
            prim=c(emitters.prim, np.int64), mesh=None if emitters.mesh is None else c(emitters.mesh, np.int32),
            partner=None if emitters.partner is None else c(emitters.partner, np.int64),
            rect=None if emitters.rect is None else c(emitters.rect, np.float64),
            rect_frame=None if emitters.rect is None else c(rectangle_constants(emitters.rect), np.float64))


EmitterPickArgs = schema.record("EmitterPickArgs", "primer_emitter_pick's (and _probability's) arguments: LightTree.pick for n points.", [
    ("emitters", ptr("EmitterTables"), ""),
    ("n", I64, ""),
    ("points", ptr(F64), "(n, 3)"),
    ("normals", ptr(F64), "(n, 3) (zero: unknown)"),
    ("u", ptr(F64), "(n,) the pick's numbers (primer_emitter_pick) or NULL"),
    ("index", out(I64), "(n,) the emitters picked (primer_emitter_pick), or those whose probability is asked"),
    ("probability", out(F64), "(n,)"),
])
schema.function("primer_emitter_pick", "emitter_pick_rows", EmitterPickArgs)
schema.function("primer_emitter_pick_probability", "emitter_pick_probability_rows", EmitterPickArgs)
EmitterPdfArgs = schema.record("EmitterPdfArgs", "primer_emitter_pdf's arguments: MeshEmitters.pdf_of_hits for n rays (the frame).", [
    ("emitters", ptr("EmitterTables"), ""),
    ("n", I64, ""),
    ("origins", ptr(F64), "(n, 3)"),
    ("normals", ptr(F64), "(n, 3) (zero: unknown)"),
    ("directions", ptr(F64), "(n, 3) unit"),
    ("t", ptr(F64), "(n,) the distances to the hits"),
    ("index", ptr(I64), "(n,) the emitters hit"),
    ("pdf", out(F64), "(n,)"),
])
schema.function("primer_emitter_pdf", "emitter_pdf_rows", EmitterPdfArgs)


def compiled_pick(emitters: MeshEmitters, points: np.ndarray, N: np.ndarray, u: np.ndarray):
    """LightTree.pick in C (emitters.c), for the tests: points, N (n, 3), u (n,) -> (index (n,) int64,
    probability (n,) float64)."""
    c = library.contiguous
    index, probability = np.empty(len(points), np.int64), np.empty(len(points))
    library.call("primer_emitter_pick", EmitterPickArgs(
        emitters=emitters.tables().record, n=len(points), points=c(points, np.float64), normals=c(N, np.float64),
        u=c(u, np.float64), index=index, probability=probability))
    return index, probability


def compiled_pick_probability(emitters: MeshEmitters, points: np.ndarray, N: np.ndarray,
                              index: np.ndarray) -> np.ndarray:
    """LightTree.pick_probability in C (emitters.c), for the tests: (n,) float64."""
    c = library.contiguous
    probability = np.empty(len(points))
    library.call("primer_emitter_pick_probability", EmitterPickArgs(
        emitters=emitters.tables().record, n=len(points), points=c(points, np.float64), normals=c(N, np.float64),
        index=np.array(index, np.int64), probability=probability))
    return probability


def compiled_pdf_of_hits(emitters: MeshEmitters, origins: np.ndarray, index: np.ndarray, D: np.ndarray, t: np.ndarray,
                         N: Optional[np.ndarray] = None) -> np.ndarray:
    """MeshEmitters.pdf_of_hits in C (emitters.c emitter_pdf, what direct.c gives a BSDF ray's hit), for the tests:
    origins, D (n, 3), index (n,) int64, t (n,), N (n, 3) or None -> (n,) float64."""
    c = library.contiguous
    pdf = np.empty(len(origins))
    library.call("primer_emitter_pdf", EmitterPdfArgs(
        emitters=emitters.tables().record, n=len(origins), origins=c(origins, np.float64),
        normals=c(unknown_normals(origins, N), np.float64), directions=c(D, np.float64), t=c(t, np.float64),
        index=c(index, np.int64), pdf=pdf))
    return pdf
