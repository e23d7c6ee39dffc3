"""A light tree over the emissive triangles: which triangle a shading point asks for a light sample.

A binary bounding-volume hierarchy over the triangles, built once per render (Conty Estevez and Kulla,
"Importance sampling of many lights with adaptive tree splitting", 2018, which Cycles' light tree
follows: intern/cycles/scene/light_tree.cpp, kernel/light/tree.h). Every node keeps

- its bounding box (lo, hi) of its triangles' corners,
- its power (energy): the sum of its triangles' area x mean(L_e),
- an orientation bounds cone: every triangle's sampled side faces within theta_o of the cone's
  axis, and emits within theta_e (pi / 2, a Lambert emitter) of its own normal. A triangle sampled from
  both sides has theta_o = pi (it faces every way).

At a shading point P with normal N the tree is walked from the root: at every inner node both
children's importance is computed, the walk goes left with probability p_left (below), the random number
rescaled to [0, 1) for the next step. A triangle's pick probability is the product of the branch
probabilities on its path. A node has two importances, an upper and a lower bound of what it could send P
(Cycles' max and min importance, kernel/light/tree.h light_tree_importance):

    upper = energy x cos(theta_i') x cos(theta') / max(d, diagonal / 4)^2
    lower = energy x cos(theta_i'') x cos(theta'') / d_far^2

with d the distance from P to the box's centre, theta_u the half-angle of the cone from P around
the centre that holds the box (from its 8 corners; Cycles takes the box's bounding sphere, wider),
theta_i' = max(theta_i - theta_u, 0) (theta_i: between N and the centre; cos 1 where N is unknown:
transmission, volumes) and theta' = max(theta - theta_o - theta_u, 0) (theta: between the cone's axis and
the direction from the centre to P), 0 beyond theta_e; theta_i'' = theta_i + theta_u (cos 1 where N is unknown;
Cycles' volumes take a lower bound of 0), theta'' = theta + theta_u + theta_o, the cosines at least 0, the lower
bound 0 unless theta + theta_u <= theta_e - theta_o (so 0 for two-sided triangles, as in Cycles) and 0 where P is
inside the box or the cone around it passes a hemisphere. d_far is the clamped d for an inner node (as Cycles)
and the distance to the box's farthest corner for a leaf (Cycles: to the triangle's farthest corner). Both are 0
where the whole box lies on or below P's tangent plane (Cycles' bbox_is_visible). The upper bound is 0 only where
no triangle of the node can light P (all of it below P's horizon, or all of it facing away), so every triangle
that can contribute keeps a probability > 0: the estimate stays unbiased. Its distance is clamped to a quarter of
the box's diagonal (Cycles' "half the radius"; Primer clamped to half the diagonal before issue 34), so that it
stays finite near and inside the box; Cycles leaves a single emitter's distance (to its centroid) unclamped,
Primer clamps leaves too (a smaller clamp changed nothing measured).

How p_left follows from them is the tree's rule (LightTree.rule):

- UPPER (the renders'): upper_left / (upper_left + upper_right), Conty Estevez and Kulla's;
- CYCLES: Cycles' get_left_probability, the mean of that and lower_left / (lower_left + lower_right) (1/2 where
  both lower bounds are 0; 0 or 1 where one upper bound is 0);
- POWER: energy_left / (energy_left + energy_right), wherever P is (the global power CDF, for comparisons).

Where both upper bounds are 0 the walk goes by power (Cycles gives up: no light sample). Under UPPER and CYCLES,
two children alike to within TWIN_TOLERANCE (`twins`: the two triangles of a quad lamp that is not one emitter,
emitters.quad_partners; an exact rectangle's are one leaf) get 1/2 each, their
importances not computed. CYCLES is implemented and
tested but not used: with Primer's binary tree of one-triangle leaves its lower bounds are 0 for every large node
near P, and the mean then pulls the branch probabilities towards 1/2 level after level, whereas the upper bounds'
share alone follows what the children send. It made the pick's variance 1.7-3.6 times larger on every scene
measured, and a render of the bench room 12 times noisier (docs/performance.md, light tree).

Leaves hold one triangle each. The tree is flat arrays, the same for Python and C (emitters.c):
nodes (k, NODE_FIELDS) float64, rows [lo (3), hi (3), axis (3), theta_o, theta_e, energy, left, right,
cos theta_o, sin theta_o, cos theta_e, cos(theta_e - theta_o) (2 where theta_o > theta_e), twins (1 where an
inner node's two children are `twins`, else 0), centre (3) (lo + hi) / 2, diagonal (3) hi - lo, half (half the
diagonal's length)] (the importance works in cosines: no trigonometry per step; whether two children are twins
depends on the tree alone, so it is decided once, at the build; the box's centre, diagonal and half-length are
made once too, the same numbers the importance made from lo and hi at every step before);
an inner node's children are rows left and right; a leaf has left = -1 - its triangle, right = -1.
Each triangle's path from the root is `depth` steps, bit l of `path` the side (1: right) at step l, so
that `pick_probability` (the MIS pdf of a BSDF ray that hits the triangle) multiplies the same branch
probabilities in the same order as `pick`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..native import schema

# A node row's columns, known to C as TREE_<NAME> (core/native/boundary.gen.h): one layout, made here.
_COLUMNS = schema.constants("TREE", dict(
    lo=0, hi=3, axis=6, theta_o=9, theta_e=10, energy=11, left=12, right=13, cos_o=14, sin_o=15, cos_e=16, cos_eo=17,
    twins=18, centre=19, diagonal=22, half=25, fields=26), "a light-tree node row's columns (light_tree.py)")
(LO, HI, AXIS, THETA_O, THETA_E, ENERGY, LEFT, RIGHT, COS_O, SIN_O, COS_E, COS_EO, TWINS, CENTRE, DIAGONAL, HALF,
 NODE_FIELDS) = (int(_COLUMNS[name]) for name in ("lo", "hi", "axis", "theta_o", "theta_e", "energy", "left", "right",
                                                  "cos_o", "sin_o", "cos_e", "cos_eo", "twins", "centre", "diagonal",
                                                  "half", "fields"))
# The upper bound's distance is at least this share of the node's diagonal (Cycles: half the bounding sphere's radius).
CLAMP = schema.constant("TREE_CLAMP", 0.25, "the upper bound's distance: at least this share of a node's diagonal")
# A box counts as above P's tangent plane only by more than this share of its distance and size (d + half its
# diagonal): an emitter P lies on (a floor that glows) is coplanar to rounding, and the two kernels, whose points
# differ in their last bits, must agree that it is not above. What so little above sends P is found by BSDF rays.
HORIZON = schema.constant("TREE_HORIZON", 1e-6, "how far above P's tangent plane a node's box must lie, a share")
# Two children alike to within this (their boxes as a share of their sizes, cone axes and angles, energy as a share of
# both) are walked as twins: 1/2 each wherever P is, their importances not computed (`twins`; the two triangles of a
# quad lamp, whose importances differ only in the last bits of their corners).
TWIN_TOLERANCE = 1e-6
# Past this depth the build splits at the median (balanced), so that paths fit in 62 bits.
MEDIAN_DEPTH = 40
MAX_DEPTH = 62
# How the walk weighs a node's two children (LightTree.rule, module docstring): Cycles' mean of the shares of the upper
# and of the lower importance bounds; the share of the upper bounds alone (Conty Estevez and Kulla; the renders');
# power alone.
CYCLES, UPPER, POWER = 0, 1, 2


@dataclass
class LightTree:
    """The tree over t triangles.

    nodes: (k, NODE_FIELDS) float64 the nodes, root first (module docstring)
    path:  (t,) int64 each triangle's branch bits from the root (bit l: 1 = right at step l)
    depth: (t,) int64 each triangle's number of steps from the root to its leaf
    rule:  how the walk weighs the children (module docstring): UPPER (the renders'), CYCLES or POWER (for
           comparisons)
    """

    nodes: np.ndarray
    path: np.ndarray
    depth: np.ndarray
    rule: int = UPPER

    @property
    def max_depth(self) -> int:
        return int(self.depth.max()) if len(self.depth) else 0

    @classmethod
    def build(cls, corners: np.ndarray, normal: np.ndarray, power: np.ndarray, sides: np.ndarray,
              bounds=None) -> "LightTree":
        """The tree over triangles: corners (t, 3, 3), unit front normals (t, 3), power (t,), sides (t,) int
        (FRONT 1 | BACK 2): each node split at the middle of the longest axis of its centroids' bounds (at
        the median where that leaves a side empty, or past MEDIAN_DEPTH). Built a level at a time, every
        node of the level at once; the rows are in level order, so parents come before their children.
        bounds: the triangles' own (lo, hi, axis, theta_o, centroid) ((t, 3) x 3, (t,), (t, 3)) where some move
        over the shutter (emitters.shutter_bounds: their bounds over the whole shutter), or None: from corners."""
        t = len(power)
        centroid = corners.mean(axis=1)
        axis_t = np.where((sides == 2)[:, None], -normal, normal)
        box_lo, box_hi, theta_t = corners.min(axis=1), corners.max(axis=1), np.where(sides == 3, math.pi, 0.0)
        if bounds is not None:
            box_lo, box_hi, axis_t, theta_t, centroid = bounds
        nodes = np.zeros((2 * t - 1, NODE_FIELDS))
        path, depth = np.zeros(t, np.int64), np.zeros(t, np.int64)
        order = np.arange(t)                     # the triangles, each node's a contiguous run start .. end
        start, end, row = np.array([0]), np.array([t]), np.array([0])
        count, level, inner_levels = 1, 0, []
        while len(row):
            # 1. Nodes of one triangle are leaves.
            leaf = end - start == 1
            i = order[start[leaf]]
            leaves = nodes[row[leaf]]
            leaves[:, LO:LO + 3], leaves[:, HI:HI + 3] = box_lo[i], box_hi[i]
            leaves[:, AXIS:AXIS + 3] = axis_t[i]
            leaves[:, THETA_O], leaves[:, THETA_E] = theta_t[i], 0.5 * math.pi
            leaves[:, ENERGY], leaves[:, LEFT], leaves[:, RIGHT] = power[i], -1 - i, -1
            nodes[row[leaf]] = leaves
            depth[i] = level
            s, e, parents = start[~leaf], end[~leaf], row[~leaf]
            if not len(s):
                break
            # 2. The others split: their members, segment by segment.
            length = e - s
            offset = np.cumsum(length) - length
            segment = np.repeat(np.arange(len(s)), length)
            position = np.arange(length.sum()) - offset[segment] + s[segment]
            members = order[position]
            c = centroid[members]
            low, high = np.minimum.reduceat(c, offset), np.maximum.reduceat(c, offset)
            k = np.argmax(high - low, axis=1)
            key = c[np.arange(len(c)), k[segment]]
            middle = 0.5 * (high[np.arange(len(s)), k] + low[np.arange(len(s)), k])
            goes_left = key < middle[segment]
            n_left = np.add.reduceat(goes_left.astype(np.int64), offset)
            median = (n_left == 0) | (n_left == length) | (level >= MEDIAN_DEPTH)
            if median.any():
                by_key = np.lexsort((key, segment))
                rank = np.empty(len(c), np.int64)
                rank[by_key] = np.arange(len(c)) - offset[segment[by_key]]
                goes_left = np.where(median[segment], rank < (length // 2)[segment], goes_left)
                n_left = np.where(median, length // 2, n_left)
            order[position] = members[np.lexsort((~goes_left, segment))]     # left ones first, stable
            path[members[~goes_left]] |= 1 << level
            left = count + 2 * np.arange(len(s))
            count += 2 * len(s)
            nodes[parents, LEFT], nodes[parents, RIGHT] = left, left + 1
            inner_levels.append((parents, left, left + 1))
            start, end = np.concatenate([s, s + n_left]), np.concatenate([s + n_left, e])
            row = np.concatenate([left, left + 1])
            level += 1
        # 3. The inner nodes from the deepest level up: bounds, cone, power of their two children.
        for parents, left, right in reversed(inner_levels):
            a, b = nodes[left], nodes[right]
            nodes[parents, LO:LO + 3] = np.minimum(a[:, LO:LO + 3], b[:, LO:LO + 3])
            nodes[parents, HI:HI + 3] = np.maximum(a[:, HI:HI + 3], b[:, HI:HI + 3])
            nodes[parents, AXIS:AXIS + 3], nodes[parents, THETA_O] = cone_union(
                a[:, AXIS:AXIS + 3], a[:, THETA_O], b[:, AXIS:AXIS + 3], b[:, THETA_O])
            nodes[parents, THETA_E] = np.maximum(a[:, THETA_E], b[:, THETA_E])
            nodes[parents, ENERGY] = a[:, ENERGY] + b[:, ENERGY]
            nodes[parents, TWINS] = twins(a, b).astype(np.float64)
        if depth.max() > MAX_DEPTH:
            raise ValueError("light tree deeper than its path bits")
        return cls(with_cosines(nodes), path, depth)

    def by_power(self) -> "LightTree":
        """The same tree weighing nothing but power: it picks each triangle in proportion to its power wherever
        the point is, as the global power CDF did before the tree (for the comparison in bench/light_tree.py)."""
        return self.with_rule(POWER)

    def with_rule(self, rule: int) -> "LightTree":
        """The same tree walked by `rule` (CYCLES, UPPER or POWER)."""
        return LightTree(self.nodes, self.path, self.depth, rule)

    def branch_left(self, P: np.ndarray, N: np.ndarray, node: np.ndarray) -> np.ndarray:
        """The probability of going to the left child of inner nodes `node` (m,) int64 from points P (m, 3)
        with normals N (m, 3) (zero rows: unknown): the left child's share of the upper importance bounds (UPPER),
        or the mean of that and its share of the lower ones (CYCLES; where the lower ones are both 0: 1/2, or 0 or
        1 where one upper bound is 0); by power where both upper bounds are 0 (or POWER). (m,) float64"""
        left = self.nodes[node, LEFT].astype(np.int64)
        right = self.nodes[node, RIGHT].astype(np.int64)
        E_left, E_right = self.nodes[left, ENERGY], self.nodes[right, ENERGY]
        if self.rule == POWER:
            return E_left / (E_left + E_right)
        upper_left, lower_left = importance(P, N, self.nodes[left])
        upper_right, lower_right = importance(P, N, self.nodes[right])
        upper, lower = upper_left + upper_right, lower_left + lower_right
        with np.errstate(divide="ignore", invalid="ignore"):
            by_upper = upper_left / upper
            by_lower = np.where(lower > 0.0, lower_left / lower,
                                0.5 * ((upper_left > 0.0).astype(np.float64) + (upper_right == 0.0)))
            by_power = E_left / (E_left + E_right)
        by_importance = by_upper if self.rule == UPPER else 0.5 * (by_upper + by_lower)
        return np.where(self.nodes[node, TWINS] != 0.0, 0.5,
                        np.where(upper > 0.0, by_importance, by_power))

    def pick(self, P: np.ndarray, N: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One triangle per point, walking down with u (m,) in [0, 1): (index (m,) int64, probability (m,), u
        rescaled to [0, 1) within the triangle's share (m,), uniform again and free to reuse)."""
        m = len(P)
        node, u = np.zeros(m, np.int64), u.astype(np.float64).copy()
        probability = np.ones(m)
        for _ in range(self.max_depth):
            inner_rows = np.flatnonzero(self.nodes[node, RIGHT] >= 0)
            if not len(inner_rows):
                break
            at = node[inner_rows]
            p_left = self.branch_left(P[inner_rows], N[inner_rows], at)
            x = u[inner_rows]
            goes_left = x < p_left
            probability[inner_rows] *= np.where(goes_left, p_left, 1.0 - p_left)
            with np.errstate(divide="ignore", invalid="ignore"):
                x = np.where(goes_left, x / p_left, (x - p_left) / (1.0 - p_left))
            u[inner_rows] = np.minimum(np.maximum(x, 0.0), 1.0 - 2.0 ** -53)
            node[inner_rows] = np.where(goes_left, self.nodes[at, LEFT], self.nodes[at, RIGHT]).astype(np.int64)
        return (-1 - self.nodes[node, LEFT]).astype(np.int64), probability, u

    def pick_probability(self, P: np.ndarray, N: np.ndarray, index: np.ndarray) -> np.ndarray:
        """The probability that `pick` from P (m, 3), N (m, 3) chooses triangle `index` (m,) int64: (m,) float64,
        the same products in the same order."""
        m = len(P)
        node = np.zeros(m, np.int64)
        probability = np.ones(m)
        path, depth = self.path[index], self.depth[index]
        for level in range(self.max_depth):
            rows = np.flatnonzero(depth > level)
            if not len(rows):
                break
            at = node[rows]
            p_left = self.branch_left(P[rows], N[rows], at)
            goes_right = ((path[rows] >> level) & 1) == 1
            probability[rows] *= np.where(goes_right, 1.0 - p_left, p_left)
            node[rows] = np.where(goes_right, self.nodes[at, RIGHT], self.nodes[at, LEFT]).astype(np.int64)
        return probability


    def all_pick_probabilities(self, P: np.ndarray, N: np.ndarray) -> np.ndarray:
        """Every triangle's pick probability from each of the points P (n, 3) with normals N (n, 3), by walking
        every branch of the tree (parents come before their children): (n, t) float64, each row summing to 1 (a
        test's and the bench's closed-form view of `pick`)."""
        node_probability = np.zeros((len(P), len(self.nodes)))
        node_probability[:, 0] = 1.0
        leaf_probability = np.zeros((len(P), len(self.path)))
        for row in range(len(self.nodes)):
            left, right = int(self.nodes[row, LEFT]), int(self.nodes[row, RIGHT])
            if right < 0:
                leaf_probability[:, -1 - left] = node_probability[:, row]
                continue
            p_left = self.branch_left(P, N, np.full(len(P), row))
            node_probability[:, left] = node_probability[:, row] * p_left
            node_probability[:, right] = node_probability[:, row] * (1.0 - p_left)
        return leaf_probability

def twins(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Whether node rows left and right (m, NODE_FIELDS) are alike to within TWIN_TOLERANCE in all that their
    importance reads: boxes (each bound within the tolerance times the sum of both boxes' extents), cone axes and
    angles, energies (within the tolerance times their sum), and both leaves or both inner nodes. The walk gives
    such twins 1/2 each (an unbiased choice wherever P is: the same 1/2 in pick and pick_probability; it is what their
    importances would give, to within the tolerance) and C skips their importances (emitters.c reads the parent's
    TWINS field, which `build` sets from this once per inner node). (m,) bool"""
    size = np.zeros(len(left))
    for c in range(3):
        size = size + (left[:, HI + c] - left[:, LO + c]) + (right[:, HI + c] - right[:, LO + c])
    alike = ((left[:, RIGHT] < 0.0) == (right[:, RIGHT] < 0.0)) & (
        np.abs(left[:, ENERGY] - right[:, ENERGY]) <= TWIN_TOLERANCE * (left[:, ENERGY] + right[:, ENERGY]))
    alike &= np.all(np.abs(left[:, LO:HI + 3] - right[:, LO:HI + 3]) <= (TWIN_TOLERANCE * size)[:, None], axis=1)
    alike &= np.all(np.abs(left[:, AXIS:ENERGY] - right[:, AXIS:ENERGY]) <= TWIN_TOLERANCE, axis=1)
    return alike


def with_cosines(nodes: np.ndarray) -> np.ndarray:
    """The nodes (k, NODE_FIELDS) with their cos theta_o, sin theta_o, cos theta_e and cos(theta_e - theta_o) (2 where
    theta_o > theta_e: no lower bound) filled in from the angles, and their boxes' centre, diagonal and half its
    length from lo and hi (summed in emitters.c dot3's order, so that both kernels read the same numbers)."""
    lo, hi = nodes[:, LO:LO + 3], nodes[:, HI:HI + 3]
    nodes[:, CENTRE:CENTRE + 3] = 0.5 * (lo + hi)
    diagonal = hi - lo
    nodes[:, DIAGONAL:DIAGONAL + 3] = diagonal
    nodes[:, HALF] = 0.5 * np.sqrt(diagonal[:, 0] * diagonal[:, 0] + diagonal[:, 1] * diagonal[:, 1]
                                   + diagonal[:, 2] * diagonal[:, 2])
    nodes[:, COS_O], nodes[:, SIN_O] = np.cos(nodes[:, THETA_O]), np.sin(nodes[:, THETA_O])
    nodes[:, COS_E] = np.cos(nodes[:, THETA_E])
    gap = nodes[:, THETA_E] - nodes[:, THETA_O]
    nodes[:, COS_EO] = np.where(gap >= 0.0, np.cos(gap), 2.0)
    return nodes


def importance(P: np.ndarray, N: np.ndarray, node: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The importance bounds of nodes (m, NODE_FIELDS) seen from P (m, 3) with normals N (m, 3) (zero: unknown):
    (upper (m,), lower (m,)) float64, the module docstring's; the upper 0 only where nothing of the node can
    light P, the lower 0 wherever some of it may not (Cycles' light_tree_importance).

    In cosines: cos(a - b) = cos a cos b + sin a sin b, all angles in [0, pi] (sines >= 0)."""
    lo, hi = node[:, LO:LO + 3], node[:, HI:HI + 3]
    v = node[:, CENTRE:CENTRE + 3] - P
    d = np.sqrt(np.einsum("ij,ij->i", v, v))
    diagonal, half = node[:, DIAGONAL:DIAGONAL + 3], node[:, HALF]
    inside_box = np.all((P >= lo) & (P <= hi), axis=1) | (d <= 0.0)
    # theta_u: the half-angle around the direction w to the centre that holds the box's corners.
    # cos^2 of each corner's angle where all lie in front (else the cone passes a hemisphere).
    with np.errstate(divide="ignore", invalid="ignore"):
        w = v / d[:, None]
        cos2_u = np.ones(len(P))
        behind = np.zeros(len(P), bool)
        farthest2 = np.zeros(len(P))
        for corner in range(8):
            to_corner = np.stack([np.where((corner >> c) & 1, hi[:, c], lo[:, c]) for c in range(3)], axis=1) - P
            along = np.einsum("ij,ij->i", w, to_corner)
            length2 = np.einsum("ij,ij->i", to_corner, to_corner)
            behind |= ~(along > 0.0)
            cos2_u = np.minimum(cos2_u, along * along / length2)
            farthest2 = np.maximum(farthest2, length2)
    everywhere = inside_box | behind
    cos_u = np.sqrt(np.minimum(cos2_u, 1.0))
    sin_u = np.sqrt(np.maximum(1.0 - cos2_u, 0.0))
    # The receiver: cos(max(theta_i - theta_u, 0)), at least 0; 1 where N is unknown; 0 where the whole box lies
    # on or below P's tangent plane. The lower bound: cos(theta_i + theta_u), at least 0.
    cos_i = np.einsum("ij,ij->i", N, w)
    sin_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0))
    known_normal = np.einsum("ij,ij->i", N, N) > 0.0
    height = np.einsum("ij,ij->i", N, v) + 0.5 * np.einsum("ij,ij->i", np.abs(N), diagonal)
    above = ~known_normal | (height > HORIZON * (d + half))
    cos_incidence = np.where(~known_normal | (cos_i >= cos_u), 1.0, np.maximum(cos_i * cos_u + sin_i * sin_u, 0.0))
    cos_incidence_least = np.where(~known_normal, 1.0, np.maximum(cos_i * cos_u - sin_i * sin_u, 0.0))
    # The emitter: theta' = max(theta - theta_u - theta_o, 0), cos theta' where theta' < theta_e, else 0. The lower
    # bound: cos(theta + theta_u + theta_o) where theta + theta_u <= theta_e - theta_o (theta, theta_u <= pi / 2).
    cos_t = -np.einsum("ij,ij->i", node[:, AXIS:AXIS + 3], w)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    cos_1 = cos_t * cos_u + sin_t * sin_u                       # cos(theta - theta_u), where theta > theta_u
    sin_1 = np.maximum(sin_t * cos_u - cos_t * sin_u, 0.0)
    cos_2 = cos_1 * node[:, COS_O] + sin_1 * node[:, SIN_O]     # cos(theta - theta_u - theta_o)
    cos_outgoing = np.where((cos_t >= cos_u) | (cos_1 >= node[:, COS_O]), 1.0,
                            np.where(cos_2 > node[:, COS_E], np.maximum(cos_2, 0.0), 0.0))
    cos_3 = cos_t * cos_u - sin_t * sin_u                       # cos(theta + theta_u)
    sin_3 = sin_t * cos_u + cos_t * sin_u
    cos_4 = cos_3 * node[:, COS_O] - sin_3 * node[:, SIN_O]     # cos(theta + theta_u + theta_o)
    cos_outgoing_least = np.where((cos_t >= 0.0) & (cos_3 >= node[:, COS_EO]), np.maximum(cos_4, 0.0), 0.0)
    # The distances: the upper bound's to the centre, at least CLAMP x the diagonal (finite near and inside the
    # box); the lower bound's the same for an inner node, to the farthest corner for a leaf (one triangle).
    distance = np.maximum(d, CLAMP * 2.0 * half)
    far = np.where(node[:, RIGHT] < 0.0, np.sqrt(farthest2), distance)
    upper = node[:, ENERGY] / (distance * distance) * np.where(
        ~above, 0.0, np.where(everywhere, 1.0, cos_incidence * cos_outgoing))
    lower = np.where(everywhere | ~above, 0.0,
                     node[:, ENERGY] / (far * far) * (cos_incidence_least * cos_outgoing_least))
    return upper, lower


def cone_union(a: np.ndarray, theta_a: np.ndarray, b: np.ndarray, theta_b: np.ndarray):
    """The narrowest cones around pairs of orientation cones: unit axes a, b (m, 3), half-angles (m,) ->
    (axis (m, 3), theta_o (m,)) float64."""
    swap = theta_b > theta_a
    a, b = np.where(swap[:, None], b, a), np.where(swap[:, None], a, b)
    theta_a, theta_b = np.where(swap, theta_b, theta_a), np.where(swap, theta_a, theta_b)
    cos_d = np.einsum("ij,ij->i", a, b)
    theta_d = np.arccos(np.clip(cos_d, -1.0, 1.0))
    theta_o = 0.5 * (theta_a + theta_d + theta_b)
    perpendicular = b - cos_d[:, None] * a
    length = np.sqrt(np.einsum("ij,ij->i", perpendicular, perpendicular))
    turn = theta_o - theta_a                                    # turn a towards b by this much
    with np.errstate(divide="ignore", invalid="ignore"):
        turned = np.cos(turn)[:, None] * a + np.sin(turn)[:, None] * (perpendicular / length[:, None])
        turned = turned / np.sqrt(np.einsum("ij,ij->i", turned, turned))[:, None]
    inside = np.minimum(theta_d + theta_b, math.pi) <= theta_a   # b lies inside a
    everywhere = ~inside & ((theta_o >= math.pi) | (length < 1e-12))   # (opposite axes: no plane to turn in)
    axis = np.where((inside | everywhere)[:, None], a, turned)
    return axis, np.where(inside, theta_a, np.where(everywhere, math.pi, theta_o))
