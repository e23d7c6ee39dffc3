"""Heterogeneous media: a medium whose coefficients a node graph sets point by point, and the march along a ray.

A volume closure whose Density, Color, Absorption or Emission is fed by a link (a Noise Texture, a Gradient of the
object's coordinates, a Math node...) sets up a different medium at every point: its node graph runs at points
inside the medium (`Field.at`), reading the point's object and generated coordinates (Cycles' volume shading point:
sd->P, moved into the object's space, and into its texture space for Generated, volume_normalized_position), and
the closure's formulas (media.py) turn the inputs found there into sigma_a, sigma_s and emission.

Along a ray such a medium is **marched** (`March`): the stretch of the ray inside the media's box is cut into pieces
of at most `step` (the box's diagonal / STEPS_ACROSS) within its fine box (`Field.fine`: a world medium's unpadded
scene box), doubling in length away from it (`doublings`), at most MAX_PIECES, and each piece takes the coefficients at its midpoint; before and after the box only the homogeneous media remain. On those
pieces every closed form of the homogeneous case holds piece by piece: the optical depth tau(s) is piecewise linear,
T(s) = exp(-tau(s)), the emission sums e (1 - exp(-sigma d)) / sigma exp(-tau) over the pieces, and free flight
inverts tau exactly. The march is the **proposal**: its estimates are corrected without bias (issue 35), as Cycles 5.0
samples these media by null scattering (its mean the exact integral; its Step Rate and Max Steps change its noise,
not its mean): every transmittance is residual ratio tracking against a control linear on each piece
(`March.transmittance`, `March.track`), a sampled point weighs the true coefficients there (`March.true_at`) against
the march's pdf, and where the march has a hole (a piece of no extinction at its midpoint) free flight draws a share
of its distances uniformly in the box (`March.uniform_share`), and the emission is the pieces' sum as a control
variate corrected at one point per ray (`March.emitted`). Only the denoising features still read the pieces alone.

Where a path scatters, the closures run again at the point itself to set up its phase functions (`Field.phase_at`:
the Phase menu's functions with their inputs there, links included, as Cycles runs the shader at the scattering point),
mixed by their scattering as Cycles keeps each closure (media.Stretch.phases_at, phase.PhaseMix).

The compiled twin is field.c: `field_record` packs a Field for it (its program, a table of each closure input's
register or constant, its linked Mix Shader factors, its placement), and its march cuts the same pieces.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..native import schema
from ..native.schema import F32, F64, I32, ptr
from .grids import GRID_WIDTH, corners, sample
from .tracking import ray_keys, stream

# How many pieces a ray crossing a heterogeneous medium's box along its diagonal is cut into, and the most pieces one
# stretch of a ray is cut into (media.c's March reads the same two).
STEPS_ACROSS = schema.constant("STEPS_ACROSS", 100, "pieces a march cuts the diagonal of the media's box into")
MAX_PIECES = schema.constant("MAX_PIECES", 256, "the most pieces a march cuts one stretch of a ray into")
MAX_DOUBLINGS = schema.constant("MAX_DOUBLINGS", 60, "the most pieces doubling in length a march cuts either side "
                                "of the fine box (field.py doublings)")
# The most points a heterogeneous medium's graph runs at in one go (its registers: points x the program's registers).
POINTS_AT_ONCE = 1 << 16
# The factor on a piece's second difference of sigma_t (its neighbours' midpoints) that makes its majorant.
EMISSION_DRAW = schema.constant("EMISSION_DRAW", 1 << 40, "the number of a ray's stream that places its "
                                "emission's correction point (past any ratio-tracking walk's)")
UNIFORM_SHARE = schema.constant("UNIFORM_SHARE", 0.25, "the odds that free flight in a heterogeneous medium draws "
                                "its distance uniformly in the media's box (field.py March.uniform_share)")
WORLD_PROBES = schema.constant("WORLD_PROBES", 8, "the points past the media's box where a ray's stretch after it "
                               "reads the world's heterogeneous medium (field.py March: their mean held)")
TRACKING_SAFETY = schema.constant("TRACKING_SAFETY", 8.0, "the factor on a piece's second difference of sigma_t "
                                  "that makes its ratio-tracking majorant")

# Each volume input's width (floats): colours and coefficients 3, the rest 1.
INPUT_WIDTHS = {"color": 3, "absorption_color": 3, "emission_color": 3, "absorption": 3, "scatter": 3,
                "emission": 3, "blackbody_tint": 3, "density": 1, "anisotropy": 1, "emission_strength": 1,
                "strength": 1, "blackbody_intensity": 1, "temperature": 1, "ior": 1, "backscatter": 1, "alpha": 1,
                "diameter": 1}
# The closures' defaults (media.py), where an input is missing.
# (the Phase menu's inputs: phase.of_node's defaults)
PHASE_DEFAULTS = {"ior": 1.33, "backscatter": 0.1, "alpha": 0.5, "diameter": 20.0}
DEFAULTS = {"ABSORPTION": {"color": 0.8, "density": 1.0}, "SCATTER": {"color": 0.8, "density": 1.0, **PHASE_DEFAULTS},
            "PRINCIPLED_VOLUME": {"color": 0.5, "density": 1.0, "absorption_color": 0.0, "emission_color": 1.0},
            "COEFFICIENTS": dict(PHASE_DEFAULTS), "EMISSION": {"color": 1.0, "strength": 1.0}}
# The coordinates a volume point offers its graph (the attribute layout its program is compiled for).
LAYOUT = {"generated": (0, 3), "object": (3, 3)}
# The inputs' order in a VolumeField's table (C: VOLUME_INPUT_COLOR...), and the closures' (C: VOLUME_CLOSURE_...).
VOLUME_INPUT = schema.constants("VOLUME_INPUT", list(INPUT_WIDTHS), "a volume input's row in VolumeField.inputs")
VOLUME_INPUTS = schema.constant("VOLUME_INPUTS", len(INPUT_WIDTHS), "the volume inputs a closure reads")
VOLUME_CLOSURE = schema.constants("VOLUME_CLOSURE", list(DEFAULTS), "a volume closure's kind in VolumeField.kinds")


def linked(entries: list) -> bool:
    """Whether a Volume output's closures [(name, weight, inputs)] have an input fed by a link (a graph.Link), or a
    Volume object's grid read by a Principled Volume's Temperature Attribute."""
    from ..materials.graph import Link
    return any(isinstance(value, Link) or (key in ("factors", "temperature_grid") and value)
               for _, _, inputs in entries for key, value in inputs.items())


class Sample(NamedTuple):
    """A heterogeneous medium's coefficients at n points: sigma_a, sigma_s, emission (n, 3) float64, and gs (n,)
    float64 the sum of each closure's anisotropy times its scattering (sum over channels): g = gs / sum(sigma_s)."""

    sigma_a: np.ndarray
    sigma_s: np.ndarray
    emission: np.ndarray
    gs: np.ndarray


def closure_at(name: str, weight: float, inputs: dict, voxels=None) -> Sample:
    """One closure's coefficients at n points, its inputs (n, width) float64 each (media.py's formulas, per point).
    voxels: for a Principled Volume whose Temperature Attribute reads a grid, (values (n, K), odds (n, K)) the grid's
    voxels around each point and their interpolation weights: Cycles looks that grid up stochastically, so its black
    body's glow is the voxels' glows (each of Temperature x max(value, 0)) averaged with those odds."""
    from .media import STEFAN_BOLTZMANN
    get = lambda key: inputs[key]                                        # noqa: E731
    n = len(next(iter(inputs.values())))
    zero = np.zeros((n, 3))
    clamp_g = lambda g: np.sign(g) * np.minimum(np.abs(g), 1.0 - 1e-3)  # noqa: E731
    if name == "COEFFICIENTS":
        sigma_s = weight * get("scatter")
        return Sample(weight * get("absorption"), sigma_s, weight * get("emission"),
                      clamp_g(get("anisotropy")[:, 0]) * sigma_s.sum(axis=1))
    if name == "EMISSION":
        return Sample(zero, zero, weight * get("strength") * get("color"), np.zeros(n))
    d = weight * np.maximum(get("density"), 0.0)                        # (n, 1)
    color = get("color")
    if name == "ABSORPTION":
        return Sample(d * (1.0 - color), zero, zero, np.zeros(n))
    g = clamp_g(get("anisotropy")[:, 0])
    if name == "SCATTER":
        sigma_s = d * color
        return Sample(zero, sigma_s, zero, g * sigma_s.sum(axis=1))
    # Principled Volume (svm_node_principled_volume).
    absorption = np.sqrt(np.maximum(get("absorption_color"), 0.0))
    sigma_s = np.where(d > 0.0, color * d, 0.0)
    sigma_a = np.where(d > 0.0, np.maximum(1.0 - color, 0.0) * np.maximum(1.0 - absorption, 0.0) * d, 0.0)
    strength = get("emission_strength")
    emission = np.where(strength > 0.0, weight * strength * get("emission_color"), 0.0)
    amount = get("blackbody_intensity")[:, 0]
    if (amount > 0.0).any():
        from ..materials.converters.blackbody import blackbody
        each = [(get("temperature")[:, 0], None)] if voxels is None else [
            (get("temperature")[:, 0] * np.maximum(voxels[0][:, c], 0.0), voxels[1][:, c])
            for c in range(voxels[0].shape[1])]
        for temperature, odds in each:
            t = np.maximum(temperature, 0.0)
            intensity = STEFAN_BOLTZMANN * (1.0 + amount * (t ** 4 - 1.0))
            glow = (get("blackbody_tint") * intensity[:, None]
                    * blackbody(t.astype(np.float32), clip=False).astype(np.float64).reshape(n, 3))
            glow = glow if odds is None else odds[:, None] * glow
            emission = emission + weight * np.where(((amount > 0.0) & (intensity > 0.0))[:, None], glow, 0.0)
    return Sample(sigma_a, sigma_s, emission, g * sigma_s.sum(axis=1))


class Field:
    """A heterogeneous medium: a material's Volume closures [(name, weight, inputs)] with linked inputs, evaluated
    point by point (`at`).

    space: (world-to-object (3, 4) float64, texture space location (3,), size (3,)[, grids]) of the object that holds
    it (its object and generated coordinates; None: the identity and the unit box around the origin); grids: a
    Volume object's [grids.Grid], which its graph reads as the attributes "grid:NAME" and "attr:NAME" (an Attribute
    node's, Volume Info's), four floats each after the coordinates; origin: (3,) the
    world point the render's coordinates are relative to (geometry.origin); bounds: (low (3,), high (3,)) the
    camera-relative box of its triangles (the march's extent and step); step: the march's longest piece (None: the
    box's diagonal / STEPS_ACROSS); fine: (low (3,), high (3,)) the box within `bounds` where the march keeps pieces
    of `step`, past which they double in length (a world medium's unpadded scene box; None: `bounds`); unbounded:
    the world's medium (`world_field`), which every ray is in and which
    goes on past its box (March: held at its value where the ray leaves the box); info: (W,) float64 the Object Info
    row its graph reads (a medium kept per object, media.Media.of: that object's row of geometry.instance_info) and
    random its Object Info Random; None: Location the placement of `space`, every other column and Random 0."""

    def __init__(self, entries: list, space=None, origin=None, bounds=None, step=None, unbounded=False, info=None,
                 random=0.0, fine=None):
        from ..materials import graph as graph_
        self.entries = entries
        self.unbounded = bool(unbounded)
        self.origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64)
        matrix, location, size, *rest = space if space is not None else (np.eye(4)[:3], np.zeros(3), np.ones(3))
        self.grids = list(rest[0]) if rest and rest[0] else []
        self.layout = dict(LAYOUT)
        for g, grid in enumerate(self.grids):
            self.layout["grid:" + grid.name] = self.layout["attr:" + grid.name] = (6 + GRID_WIDTH * g, GRID_WIDTH)
        self.matrix = np.asarray(matrix, np.float64).reshape(3, 4)
        self.location, self.size = np.asarray(location, np.float64), np.asarray(size, np.float64)
        # (and object to world: the Vector Transform's and Object Info's Location, graph.object_matrices)
        placed = np.linalg.inv(np.vstack([self.matrix, [0.0, 0.0, 0.0, 1.0]]))[:3]
        self.linear, self.placement = placed[:, :3], placed[:, 3]
        # (the Object Info its graph reads: C's VolumeField.info, random)
        self.info = np.concatenate([self.placement, np.zeros(5)]) if info is None else np.asarray(info, np.float64)
        self.random = float(random)
        self.low, self.high = ((np.full(3, -np.inf), np.full(3, np.inf)) if bounds is None
                               else (np.asarray(bounds[0], np.float64), np.asarray(bounds[1], np.float64)))
        diagonal = float(np.linalg.norm(self.high - self.low)) if np.isfinite(self.high - self.low).all() else 1.0
        # (the box within it where a march keeps pieces of `step`, past which they double: March)
        self.fine_low, self.fine_high = ((self.low, self.high) if fine is None
                                         else (np.asarray(fine[0], np.float64), np.asarray(fine[1], np.float64)))
        self.step = max(diagonal, 1e-6) / STEPS_ACROSS if step is None else float(step)
        # One shader "node" per closure, its linked inputs the slots the program writes (graph.Compiler.compile).
        self.slots, nodes = [], []
        for k, (name, weight, inputs) in enumerate(entries):
            keys = tuple(key for key, value in inputs.items() if isinstance(value, graph_.Link))
            shim = type("VolumeInputs", (), {"inputs": keys, "defaults": tuple(np.zeros(INPUT_WIDTHS[key])
                                                                                for key in keys)})
            nodes.append((shim, weight, {key: inputs[key] for key in keys}, list(inputs.get("factors", ()))))
            self.slots.append(keys)
        # Each closure's grid its black body's Temperature Attribute reads (stochastically in Cycles), or -1.
        names = [grid.name for grid in self.grids]
        self.hot = np.array([names.index(inputs["temperature_grid"]) if inputs.get("temperature_grid") in names
                             else -1 for _, _, inputs in entries], np.int32)
        # Each closure's phase function (phase.PHASE; its numbers set up point by point from its inputs, phase_at).
        from .phase import PHASE
        self.phases = np.array([PHASE[inputs.get("phase", "HENYEY_GREENSTEIN")] if name in ("SCATTER", "COEFFICIENTS")
                                else PHASE["HENYEY_GREENSTEIN"] for name, _, inputs in entries], np.int32)
        # The images its graph reads, in a TextureSet of its own (a missing one: -1, magenta).
        from ..materials.textures import TextureSet
        images = [image for image in graph_.images_of(nodes) if image is not None]
        rows = {id(image): row for row, image in enumerate(images)}
        self.textures = TextureSet.of(images)
        self.program = graph_.Compiler(self.layout, lambda image: rows.get(id(image), -1),
                                       material="volume").compile(nodes)

    @property
    def scatters(self) -> bool:
        """Whether some closure of it may scatter."""
        from .media import VOLUME_BY_NAME, VolumeFlags
        return any(VOLUME_BY_NAME[name].flags & VolumeFlags.SCATTERS for name, _, _ in self.entries)

    @property
    def emits(self) -> bool:
        """Whether some closure of it may emit: an input that sets its emission fed by a link or not 0 (a Principled
        Volume's Emission Strength or Blackbody Intensity, an Emission's Strength, the Emission Coefficients)."""
        from ..materials import graph as graph_
        may = lambda value: isinstance(value, graph_.Link) or np.any(np.asarray(value) != 0.0)   # noqa: E731
        for name, _, inputs in self.entries:
            if name == "PRINCIPLED_VOLUME" and (may(inputs.get("emission_strength", 0.0))
                                                 or may(inputs.get("blackbody_intensity", 0.0))):
                return True
            if name == "EMISSION" and may(inputs.get("strength", 1.0)):
                return True
            if name == "COEFFICIENTS" and may(inputs.get("emission", 0.0)):
                return True
        return False

    def coordinates(self, P: np.ndarray) -> np.ndarray:
        """The generated and object coordinates of camera-relative points P (n, 3), then each grid's RGBA there:
        (n, 6 + 4 G) float64."""
        world = P + self.origin
        local = world @ self.matrix[:, :3].T + self.matrix[:, 3]
        generated = np.divide(local - self.location, 2.0 * self.size, out=np.zeros_like(local),
                              where=self.size != 0.0) + 0.5
        return np.concatenate([generated, local] + [sample(grid, local) for grid in self.grids], axis=1)

    def at(self, P: np.ndarray) -> Sample:
        """The medium's coefficients at camera-relative points P (n, 3) float64."""
        n = len(P)
        total = Sample(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n))
        for _, part, _ in self.closures(P):
            total = Sample(*(a + b for a, b in zip(total, part)))
        return total

    def at_all(self, P: np.ndarray) -> Sample:
        """`at` of camera-relative points P (n, 3) float64, POINTS_AT_ONCE at a time (the graph's registers stay
        small)."""
        if len(P) <= POINTS_AT_ONCE:
            return self.at(P)
        parts = [self.at(P[start:start + POINTS_AT_ONCE]) for start in range(0, len(P), POINTS_AT_ONCE)]
        return Sample(*(np.concatenate(values) for values in zip(*parts)))

    def phase_at(self, P: np.ndarray) -> tuple:
        """The phase functions of its closures at camera-relative points P (n, 3) float64 (C closures): kinds (n, C)
        int64, their numbers (n, C, PHASE_PARAMETERS) float64 set up from each closure's inputs there
        (phase.parameters_at: links included), and weights (n, C) float64 each closure's sigma_s there summed over
        channels, after the linked Mix Shader factors (0: it does not scatter there)."""
        from .phase import PHASE, PHASE_PARAMETERS, parameters_at
        n, C = len(P), len(self.entries)
        kinds = np.full((n, C), PHASE["HENYEY_GREENSTEIN"], np.int64)
        parameters, weights = np.zeros((n, C, PHASE_PARAMETERS)), np.zeros((n, C))
        for k, part, values in self.closures(P):
            share = part.sigma_s.sum(axis=1)
            if not (share > 0.0).any():
                continue
            get = lambda key: np.asarray(values[key], np.float64)[:, 0]                  # noqa: E731
            kinds[:, k] = self.phases[k]
            parameters[:, k] = parameters_at(int(self.phases[k]), get("anisotropy"), get("ior"), get("backscatter"),
                                             get("alpha"), get("diameter"))
            weights[:, k] = share
        return kinds, parameters, weights

    def placed(self, info: np.ndarray, random: float, bounds, to_object=None, step=None, texspace=None) -> "Field":
        """This medium held by another object (media.per_object): a copy (its program shared) whose graph reads the
        Object Info row `info` (W,) and `random`, marched in `bounds` (low (3,), high (3,)) in pieces of at most
        `step` (None: its box's diagonal / STEPS_ACROSS); with
        `to_object` (3, 4) that object's world-to-object matrix, its Object coordinates (and Generated) and object
        transform that object's; with `texspace` (location (3,), size (3,)) its Generated coordinates read in that
        texture space (None: this medium's)."""
        import copy
        made = copy.copy(self)
        made.info, made.random = np.asarray(info, np.float64), float(random)
        if texspace is not None:
            made.location, made.size = (np.asarray(texspace[0], np.float64).reshape(3),
                                        np.asarray(texspace[1], np.float64).reshape(3))
        if to_object is not None:
            made.matrix = np.asarray(to_object, np.float64).reshape(3, 4)
            placed = np.linalg.inv(np.vstack([made.matrix, [0.0, 0.0, 0.0, 1.0]]))[:3]
            made.linear, made.placement = placed[:, :3], placed[:, 3]
        made.low, made.high = (np.asarray(bounds[0], np.float64), np.asarray(bounds[1], np.float64))
        made.fine_low, made.fine_high = made.low, made.high
        made.step = (max(float(np.linalg.norm(made.high - made.low)), 1e-6) / STEPS_ACROSS if step is None
                     else float(step))
        return made

    def closures(self, P: np.ndarray, info=None, random=None):
        """Each closure k's coefficients at camera-relative points P (n, 3) float64: (k, Sample (after its linked
        Mix Shader factors), its inputs there {key: (n, width) float64}, and "factor" (n,) the product of its linked
        Mix Shader factors where it has some) in turn. info (n, W), random (n,): each point's Object Info, where not
        the medium's own (Field.info, random)."""
        from ..materials import graph as graph_
        n = len(P)
        width = 6 + GRID_WIDTH * len(self.grids)
        point = graph_.empty_point(n, width)._replace(attributes=self.coordinates(P), P=P + self.origin,
                                                  path=graph_.light_paths(n, flags=graph_.PATH["volume_scatter"]),
                                                  linear=np.broadcast_to(self.linear, (n, 3, 3)),
                                                  info=np.broadcast_to(self.info, (n, len(self.info)))
                                                  if info is None else info,
                                                  random=np.full(n, self.random) if random is None else random)
        registers = graph_.run(self.program, point, self.textures)
        found, factors = {}, {}
        for kind, node, slot, width, register in self.program.outputs.astype(np.int64):
            if kind == graph_.OUT_WEIGHT:               # (a Mix Shader's linked factor above the closure)
                value = np.clip(registers[:, register], 0.0, 1.0)
                factors[node] = factors.get(node, 1.0) * (value if slot == 0 else 1.0 - value)
            else:
                found[(int(node), int(slot))] = (int(width), int(register))
        for k, (name, weight, inputs) in enumerate(self.entries):
            values, slot = {}, 0
            for key in self.slots[k]:
                width, register = found[(k, slot)]
                values[key] = registers[:, register:register + width]
                slot += INPUT_WIDTHS[key]
            for key, width in INPUT_WIDTHS.items():
                if key not in values:
                    value = inputs.get(key, DEFAULTS.get(name, {}).get(key, 0.0))
                    value = np.atleast_1d(np.asarray(value, np.float64)).reshape(-1)
                    value = np.repeat(value[:1], width) if len(value) < width else value[:width]
                    values[key] = np.broadcast_to(value, (n, width))
            voxels = None
            if self.hot[k] >= 0:
                world = P + self.origin
                voxels = corners(self.grids[self.hot[k]], world @ self.matrix[:, :3].T + self.matrix[:, 3])
            part = closure_at(name, float(weight), values, voxels)
            if k in factors:
                f = factors[k]
                values["factor"] = f                    # (n,) its linked Mix Shader factors' product
                part = Sample(part.sigma_a * f[:, None], part.sigma_s * f[:, None], part.emission * f[:, None],
                              part.gs * f)
            yield k, part, values


def doublings(gap: np.ndarray, step: float) -> np.ndarray:
    """The fewest pieces (n,) int64 doubling from `step` (step, 2 step, 4 step, ...) that cover the lengths gap (n,)
    float64: the least k with step (2^k - 1) >= gap (0 for no gap; C: field.c doublings)."""
    gap = np.asarray(gap, np.float64)
    k = np.zeros(len(gap), np.int64)
    for _ in range(MAX_DOUBLINGS):
        k += step * (np.exp2(k) - 1.0) < gap
    return k


def slope_integral(u: np.ndarray) -> np.ndarray:
    """g(u) = integral over y in [0, 1] of (y - 1/2) exp(-u y) (any shape, float64): a piece's linear part's weight
    under Beer-Lambert, u its optical depth; the series -u/12 + u^2/24 - u^3/80 below 1e-3 (C: field.c
    slope_integral)."""
    u = np.asarray(u, np.float64)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        big = (-np.expm1(-u) - u * np.exp(-u)) / (u * u) + np.expm1(-u) / (2.0 * u)
    small = u * (-1.0 / 12.0 + u * (1.0 / 24.0 - u / 80.0))
    return np.where(np.abs(u) < 1e-3, small, big)


class March:
    """The pieces of n rays O + s D over [0, t) through heterogeneous media (`Media.fields`, counts (n, F) in each)
    and homogeneous ones (a Stretch's constant part): piece 0 before the media's box, pieces 1..K inside it (each of
    its midpoint's coefficients), the last one after it.

    edges: (n, K + 3) float64 the pieces' ends (the last may be inf); sigma_t, sigma_s, emission: (n, K + 2, 3) each
    piece's coefficients; gs: (n, K + 2) its anisotropy-weighted scattering; tau: (n, K + 3, 3) the optical depth at
    each edge."""

    def __init__(self, fields: list, counts: np.ndarray, homogeneous, O: np.ndarray, D: np.ndarray, t: np.ndarray):
        n = len(O)
        t = np.asarray(t, np.float64)
        low = np.min([f.low for f in fields], axis=0)
        high = np.max([f.high for f in fields], axis=0)
        step = min(f.step for f in fields)
        # 1. Where the rays are in the media's box: [a, b) within [0, t).
        with np.errstate(divide="ignore", invalid="ignore"):
            inverse = 1.0 / D
            t0, t1 = (low - O) * inverse, (high - O) * inverse
        near = np.nan_to_num(np.minimum(t0, t1), nan=-np.inf).max(axis=1)
        far = np.nan_to_num(np.maximum(t0, t1), nan=np.inf).min(axis=1)
        a = np.clip(near, 0.0, t)
        b = np.clip(far, a, t)
        b = np.where(np.isfinite(b), b, a)
        # 2. The pieces inside the box, their midpoints' coefficients.
        # Pieces of `step` within the fine box (Field.fine: the scene's own box, where the media's detail is), and
        # outside it pieces that double from `step` away from it (a world medium's padding: graded_pieces).
        fine_low = np.min([f.fine_low for f in fields], axis=0)
        fine_high = np.max([f.fine_high for f in fields], axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            f0, f1 = (fine_low - O) * inverse, (fine_high - O) * inverse
        c = np.clip(np.nan_to_num(np.minimum(f0, f1), nan=-np.inf).max(axis=1), a, b)
        d = np.clip(np.nan_to_num(np.maximum(f0, f1), nan=np.inf).min(axis=1), c, b)
        before, after = doublings(c - a, step), doublings(b - d, step)
        middle = np.clip(np.ceil((d - c) / step), np.where(before + after > 0, 0, 1),
                         MAX_PIECES - before - after).astype(np.int64)
        pieces = before + middle + after
        K = int(pieces.max()) if n else 1
        j = np.arange(K)[None, :]
        length = np.where(middle > 0, (d - c) / np.maximum(middle, 1), 0.0)[:, None]
        within = j < pieces[:, None]
        # (piece j's start and midpoint: before the fine box c - step (2^(before - j) - 1), a for the first; in it
        # c + length (j - before); after it d + step (2^(j - before - middle) - 1))
        k_in, k_after = j - before[:, None], j - (before + middle)[:, None]
        start = np.where(j < before[:, None], c[:, None] - step * (np.exp2(np.maximum(before[:, None] - j, 0)) - 1.0),
                         np.where(k_after < 0, c[:, None] + length * k_in,
                                  d[:, None] + step * (np.exp2(np.maximum(k_after, 0)) - 1.0)))
        start = np.where(j == 0, a[:, None], start)
        inner = np.where(within, start, b[:, None])
        end = np.concatenate([inner[:, 1:], b[:, None]], axis=1)
        end = np.where(j + 1 < pieces[:, None], end, b[:, None])
        mids = np.where((k_in >= 0) & (k_after < 0), c[:, None] + length * (k_in + 0.5), 0.5 * (inner + end))
        self.edges = np.concatenate([np.zeros((n, 1)), inner, b[:, None], t[:, None]], axis=1)
        sig_a, sig_s, emit, gs = (np.zeros((n, K, 3)), np.zeros((n, K, 3)), np.zeros((n, K, 3)), np.zeros((n, K)))
        rows, cols = np.nonzero(within & (b > a)[:, None])
        if len(rows):
            mid = mids[rows, cols]
            P = O[rows] + mid[:, None] * D[rows]
            for f, field in enumerate(fields):
                count = counts[rows, f].astype(np.float64)
                some = np.flatnonzero(count > 0.0)
                if len(some) == 0:
                    continue
                for start in range(0, len(some), POINTS_AT_ONCE):        # (the graph's registers stay small)
                    part = some[start:start + POINTS_AT_ONCE]
                    found = field.at(P[part])
                    r, c, w = rows[part], cols[part], count[part]
                    sig_a[r, c] += w[:, None] * found.sigma_a
                    sig_s[r, c] += w[:, None] * found.sigma_s
                    emit[r, c] += w[:, None] * found.emission
                    gs[r, c] += w * found.gs
        # 2b. An unbounded medium (the world's: Field.unbounded) before and after the box, held along the rest of the
        # ray (the outer pieces): their coefficients' mean over WORLD_PROBES points, after the box b + L (2^k - 1)
        # (k = 0, 1, ...; L the box's diagonal), before it max(a - L (2^k - 1), 0) (the stretch after the box is
        # mostly a ray's way to infinity, which any density at a probe stops; the mean for the light it scatters
        # and emits).
        out_a, out_s, out_e, out_g = np.zeros((n, 2, 3)), np.zeros((n, 2, 3)), np.zeros((n, 2, 3)), np.zeros((n, 2))
        side = high - low
        L = (float(np.sqrt((side[0] * side[0] + side[1] * side[1]) + side[2] * side[2]))
             if np.isfinite(side).all() else 0.0)
        for f, field in enumerate(fields):
            if not field.unbounded:
                continue
            count = counts[:, f].astype(np.float64)
            for side, (x, width) in enumerate(((a, a), (b, t - b))):
                some = np.flatnonzero((count > 0.0) & (width > 0.0))
                if len(some):
                    found = field.at_all(O[some] + x[some, None] * D[some])
                    for k in range(1, int(WORLD_PROBES)):
                        at = (x[some] + L * (2.0 ** k - 1.0) if side == 1
                              else np.maximum(x[some] - L * (2.0 ** k - 1.0), 0.0))
                        probe = field.at_all(O[some] + at[:, None] * D[some])
                        found = Sample(*(old + new for old, new in zip(found, probe)))
                    found = Sample(*(value / float(WORLD_PROBES) for value in found))
                    w = count[some]
                    out_a[some, side] += w[:, None] * found.sigma_a
                    out_s[some, side] += w[:, None] * found.sigma_s
                    out_e[some, side] += w[:, None] * found.emission
                    out_g[some, side] += w * found.gs
        # 3. The homogeneous media all along, the pieces' optical depths.
        hom_t, hom_s, hom_e, hom_g = homogeneous
        hom_gs = hom_g * hom_s.sum(axis=1)
        pad = lambda x, h, o: np.concatenate([h[:, None] + o[:, :1], h[:, None] + x, h[:, None] + o[:, 1:]],  # noqa
                                             axis=1)
        self.sigma_t = pad(sig_a + sig_s, hom_t, out_a + out_s)
        self.sigma_s = pad(sig_s, hom_s, out_s)
        self.emission = pad(emit, hom_e, out_e)
        self.gs = np.concatenate([(hom_gs + out_g[:, 0])[:, None], hom_gs[:, None] + gs,
                                  (hom_gs + out_g[:, 1])[:, None]], axis=1)
        width = np.diff(self.edges, axis=1)                             # (n, K + 2), the last may be inf
        with np.errstate(invalid="ignore"):
            depth = np.where(self.sigma_t > 0.0, self.sigma_t * width[:, :, None], 0.0)
        self.tau = np.concatenate([np.zeros((n, 1, 3)), np.cumsum(depth, axis=1)], axis=1)
        # 4. What ratio tracking corrects the march's estimates by (transmittance, true_at).
        self.fields, self.counts, self.hom, self.pieces = fields, counts, homogeneous, pieces
        self.O, self.D = np.asarray(O, np.float64), np.asarray(D, np.float64)
        self.track()

    def track(self) -> None:
        """Set up residual ratio tracking on the pieces (C: field.c march_track). The control on each inner piece is
        linear through its midpoint's sigma_t (per channel) with the slope of its neighbours' midpoints (central, or
        one-sided at the box's ends; 0 for a lone piece): exact for a density linear along the ray, and its optical
        depth at the pieces' edges is the march's tau (the line is symmetric about the midpoint). Each inner piece's
        majorant mu is TRACKING_SAFETY x the largest second difference of the midpoints over the channels (a
        boundary piece takes its neighbour's), at least 1 / the stretch inside the box (about one tentative
        collision per ray where the midpoints lie on a line); 0 on the outer pieces. Keeps slope (n, K + 2, 3),
        mid (n, K + 2), mu (n, K + 2), M (n, K + 3) the majorant's integral at the edges, and the rays' stream keys
        (tracking.ray_keys)."""
        n, P = self.sigma_t.shape[:2]
        K = P - 2
        sig = self.sigma_t
        self.mid = 0.5 * (self.edges[:, :-1] + self.edges[:, 1:])
        j = np.arange(1, K + 1)
        left, right = (j >= 2)[None, :] & np.ones((n, 1), bool), j[None, :] + 1 <= self.pieces[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            d_left = (sig[:, 1:-1] - sig[:, :-2]) / np.where(left, self.mid[:, 1:-1] - self.mid[:, :-2], 1.0)[:, :, None]
            d_right = (sig[:, 2:] - sig[:, 1:-1]) / np.where(right, self.mid[:, 2:] - self.mid[:, 1:-1], 1.0)[:, :, None]
            central = (sig[:, 2:] - sig[:, :-2]) / np.where(left & right, self.mid[:, 2:] - self.mid[:, :-2],
                                                            1.0)[:, :, None]
        both, l3, r3 = (left & right)[:, :, None], left[:, :, None], right[:, :, None]
        slope = np.where(both, central, np.where(r3, d_right, np.where(l3, d_left, 0.0)))
        self.slope = np.zeros_like(sig)
        self.slope[:, 1:-1] = slope
        # (the emission's control slope the same way: March.emitted)
        e = self.emission
        with np.errstate(invalid="ignore", divide="ignore"):
            e_left = (e[:, 1:-1] - e[:, :-2]) / np.where(left, self.mid[:, 1:-1] - self.mid[:, :-2], 1.0)[:, :, None]
            e_right = (e[:, 2:] - e[:, 1:-1]) / np.where(right, self.mid[:, 2:] - self.mid[:, 1:-1], 1.0)[:, :, None]
            e_central = (e[:, 2:] - e[:, :-2]) / np.where(left & right, self.mid[:, 2:] - self.mid[:, :-2],
                                                          1.0)[:, :, None]
        self.eslope = np.zeros_like(e)
        self.eslope[:, 1:-1] = np.where(both, e_central, np.where(r3, e_right, np.where(l3, e_left, 0.0)))
        # The second differences where both neighbours are inner; a boundary piece takes its inner neighbour's.
        d2 = np.where(both, (sig[:, 2:] - sig[:, 1:-1]) - (sig[:, 1:-1] - sig[:, :-2]), 0.0).max(axis=2)
        d2 = np.maximum(d2, -np.where(both, (sig[:, 2:] - sig[:, 1:-1]) - (sig[:, 1:-1] - sig[:, :-2]),
                                      0.0).min(axis=2))
        spread = d2.copy()
        if K >= 2:
            last = self.pieces - 1                                      # (the ray's last inner piece, 0-based)
            rows = np.arange(n)
            spread[:, 0] = np.where(self.pieces >= 3, d2[:, 1], 0.0)
            spread[rows, last] = np.where(self.pieces >= 3, d2[rows, np.maximum(last - 1, 0)], spread[rows, last])
        a, b = self.edges[:, 1], self.edges[:, -2]
        with np.errstate(divide="ignore"):
            floor = np.where(b > a, 1.0 / np.where(b > a, b - a, 1.0), 0.0)
        self.mu = np.zeros((n, P))
        self.mu[:, 1:-1] = np.where((b > a)[:, None], np.maximum(TRACKING_SAFETY * spread, floor[:, None]), 0.0)
        width = np.diff(self.edges, axis=1)
        with np.errstate(invalid="ignore"):
            reach = np.where(self.mu > 0.0, self.mu * width, 0.0)
        self.M = np.concatenate([np.zeros((n, 1)), np.cumsum(reach, axis=1)], axis=1)
        self.keys = ray_keys(self.O, self.D)
        # A hole: an inner piece whose midpoint has no extinction in any channel (free flight on the march never
        # lands there, though the field may be dense elsewhere in it): those rays' free flight has a uniform share.
        hole = ((sig[:, 1:-1] <= 0.0).all(axis=2) & (width[:, 1:-1] > 0.0)).any(axis=1)
        self.share = np.where(hole & (b > a), UNIFORM_SHARE, 0.0)

    def control_depth(self, s: np.ndarray) -> tuple:
        """The control's optical depth (n, 3) from the rays' starts to distances s (n,): the march's tau at the
        piece's start, its midpoint's sigma_t over the way into it, and the slope's part
        slope / 2 ((s - mid)^2 - (width / 2)^2); with the piece k (n,)."""
        k = self.piece(s)
        rows = np.arange(len(s))
        start, mid = self.edges[rows, k], self.mid[rows, k]
        sigma, slope = self.sigma_t[rows, k], self.slope[rows, k]
        half = mid - start
        with np.errstate(invalid="ignore"):
            flat = np.where(sigma > 0.0, sigma * (s - start)[:, None], 0.0)
            bent = np.where(slope != 0.0, (0.5 * slope) * ((s - mid) * (s - mid) - half * half)[:, None], 0.0)
        return self.tau[rows, k] + flat + bent, k

    def fields_at(self, rows: np.ndarray, s: np.ndarray) -> tuple:
        """The media's true coefficients at distances s (m,) along the rays `rows` (m,) int64 (inside the box): the
        homogeneous part plus each field's at the point O + s D times the ray's count in it (summed as the march
        sums its midpoints): (sigma_t (m, 3), sigma_s (m, 3), emission (m, 3), gs (m,))."""
        m = len(rows)
        P = self.O[rows] + s[:, None] * self.D[rows]
        sig_a, sig_s, emit, gs = np.zeros((m, 3)), np.zeros((m, 3)), np.zeros((m, 3)), np.zeros(m)
        for f, field in enumerate(self.fields):
            count = self.counts[rows, f].astype(np.float64)
            some = np.flatnonzero(count > 0.0)
            for start in range(0, len(some), POINTS_AT_ONCE):
                part = some[start:start + POINTS_AT_ONCE]
                found = field.at(P[part])
                w = count[part]
                sig_a[part] += w[:, None] * found.sigma_a
                sig_s[part] += w[:, None] * found.sigma_s
                emit[part] += w[:, None] * found.emission
                gs[part] += w * found.gs
        hom_t, hom_s, hom_e, hom_g = (x[rows] for x in self.hom)
        return (hom_t + (sig_a + sig_s), hom_s + sig_s, hom_e + emit, hom_g * hom_s.sum(axis=1) + gs)

    def true_at(self, s: np.ndarray) -> tuple:
        """(sigma_t, sigma_s (n, 3), g (n,)) of the media at distances s (n,) themselves (not their pieces'
        midpoints): what an estimate divides the march's pdf into. C: field.c march_true_at."""
        if self.mu is None:
            return self.at(s)
        k = self.piece(s)
        inner = np.flatnonzero((k >= 1) & (k <= self.sigma_t.shape[1] - 2))
        sigma_t, sigma_s, g = self.at(s)
        if len(inner):
            t_, s_, _, gs = self.fields_at(inner, s[inner])
            total = s_.sum(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                g[inner] = np.where(total > 0.0, gs / np.where(total > 0.0, total, 1.0), 0.0)
            sigma_t[inner], sigma_s[inner] = t_, s_
        return sigma_t, sigma_s, g

    @classmethod
    def uniform(cls, sigma_t: np.ndarray, sigma_s: np.ndarray, emission: np.ndarray, g: np.ndarray,
                t: np.ndarray) -> "March":
        """The one-piece march of n rays over [0, t) (n,) through homogeneous media of coefficients (n, 3) each and
        anisotropies g (n,)."""
        march = cls.__new__(cls)
        n = len(t)
        march.edges = np.stack([np.zeros(n), np.asarray(t, np.float64)], axis=1)
        march.sigma_t, march.sigma_s, march.emission = sigma_t[:, None], sigma_s[:, None], emission[:, None]
        march.gs = (g * sigma_s.sum(axis=1))[:, None]
        with np.errstate(invalid="ignore"):
            depth = np.where(sigma_t > 0.0, sigma_t * march.edges[:, 1:2], 0.0)
        march.tau = np.stack([np.zeros((n, 3)), depth], axis=1)
        march.mu = None
        return march

    def collision(self, odds: np.ndarray, u: np.ndarray) -> tuple:
        """Free flight untruncated, as a path that scatters or goes on decides (Cycles' distance sampling): with
        odds `uniform_share` a distance uniform in the box's stretch [a, b) (u[:, 0] < share, rescaled), else a
        channel picked by `odds` (n, 3) with u[:, 1], an optical depth -log(1 - u[:, 0]) of it (u[:, 0] rescaled).
        Returns (s (n,) the distances, pdf (n,) their density (the mixture of sigma(s) exp(-tau(s)) over the
        channels and the uniform share), passed (n,) bool the rays whose depth lies past their end (no collision),
        p_pass (n,) the probability of that (the channels' mixture of exp(-tau(end)) times 1 - share))."""
        n = len(u)
        rows = np.arange(n)
        share, a, b = self.uniform_share()
        pick, u0 = self.split(share, u[:, 0])
        channel = np.minimum((u[:, 1:2] >= np.cumsum(odds, axis=1)).sum(axis=1), 2)
        tau = self.tau[rows, :, channel]
        target = -np.log1p(-np.minimum(u0, 1.0 - 1e-16))
        passed = ~pick & (target >= tau[:, -1])
        k = np.minimum((tau[:, 1:] <= target[:, None]).sum(axis=1), self.sigma_t.shape[1] - 1)
        sigma = self.sigma_t[rows, k, channel]
        with np.errstate(invalid="ignore", divide="ignore"):
            s = self.edges[rows, k] + np.where(sigma > 0.0, (target - tau[rows, k]) / np.where(sigma > 0.0, sigma, 1.0),
                                               0.0)
        with np.errstate(invalid="ignore"):         # (a one-piece march: a, b its end and start, never picked)
            s = np.where(pick, a + u0 * (b - a), s)
        s = np.where(passed, self.edges[:, -1], s)
        at = np.where(passed, 0.0, s)
        pdf = self.collision_pdf(odds, at)
        with np.errstate(invalid="ignore", over="ignore"):
            p_pass = (odds * np.exp(-self.tau[:, -1])).sum(axis=1) * (1.0 - share)
        return s, np.where(passed, 0.0, pdf), passed, p_pass

    def uniform_share(self) -> tuple:
        """The odds (n,) that free flight draws its distance uniformly in the stretch [a, b) (n,) each of the rays
        inside the media's box instead of on the march: UNIFORM_SHARE where the march has a hole there (an inner
        piece of no extinction at its midpoint: March.track), so that a density the midpoints miss is still reached
        (the estimates weigh the true coefficients there), else 0. C: field.c march_share."""
        a, b = self.edges[:, 1], self.edges[:, -2]
        if self.mu is None:
            return np.zeros(len(a)), a, b
        return self.share, a, b

    @staticmethod
    def split(share: np.ndarray, u: np.ndarray) -> tuple:
        """Whether each number u (n,) picks the uniform share (u < share) and u rescaled to [0, 1) in its part."""
        pick = u < share
        with np.errstate(invalid="ignore", divide="ignore"):
            return pick, np.where(pick, u / np.where(share > 0.0, share, 1.0), (u - share) / (1.0 - share))

    def share_pdf(self, share: np.ndarray, a: np.ndarray, b: np.ndarray, s: np.ndarray, march: np.ndarray) -> np.ndarray:
        """The mixture (n,) of the march's density `march` (n,) at s (n,) and the uniform share over [a, b)."""
        inside = (s >= a) & (s < b) & (share > 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return march * (1.0 - share) + np.where(inside, share / np.where(inside, b - a, 1.0), 0.0)

    def collision_pdf(self, odds: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The density (n,) of `collision` drawing distances s (n,) (before the rays' ends): the channels' mixture
        of sigma(s) exp(-tau(s)), with the uniform share."""
        sigma_t, _, _ = self.at(s)
        with np.errstate(invalid="ignore", over="ignore"):
            march = (odds * sigma_t * np.exp(-self.depth(s))).sum(axis=1)
        share, a, b = self.uniform_share()
        return self.share_pdf(share, a, b, s, march)

    def piece(self, s: np.ndarray) -> np.ndarray:
        """The piece (n,) int64 each ray's distance s (n,) lies in (the last piece at or past the end)."""
        index = (self.edges[:, 1:-1] <= s[:, None]).sum(axis=1)
        return np.minimum(index, self.sigma_t.shape[1] - 1)

    def depth(self, s: np.ndarray) -> np.ndarray:
        """The optical depth tau (n, 3) float64 from each ray's start to its distance s (n,) (inf: to its end)."""
        k = self.piece(s)
        rows = np.arange(len(s))
        start = self.edges[rows, k]
        sigma = self.sigma_t[rows, k]
        with np.errstate(invalid="ignore"):
            more = np.where(sigma > 0.0, sigma * (s - start)[:, None], 0.0)
        return self.tau[rows, k] + more

    def transmittance(self, s: np.ndarray) -> np.ndarray:
        """An unbiased estimate (n, 3) float64 of the true transmittance exp(-integral_0^s sigma_t) to distances s
        (n,) (inf: the rays' ends): residual ratio tracking (Novak et al. 2014) on the pieces, exp(-control depth)
        times prod (1 - (sigma_t(x) - control(x)) / mu) over the tentative collisions x < s drawn at the
        pieces' majorants mu from the rays' streams (tracking.stream: the i-th collision the i-th number, so every
        distance along a ray sees the same walk). Its mean is exact for any mu > 0; exp(-tau(s)) of the march where
        it has no field (March.uniform). C: field.c march_transmittance."""
        if self.mu is None:
            return np.exp(-self.depth(s))
        s = np.asarray(s, np.float64)
        n = len(s)
        rows = np.arange(n)
        depth, k = self.control_depth(s)
        start, mu = self.edges[rows, k], self.mu[rows, k]
        with np.errstate(invalid="ignore"):
            reach = self.M[rows, k] + np.where(mu > 0.0, mu * (s - start), 0.0)
        T = np.exp(-depth)
        target = np.zeros(n)
        walking = (reach > 0.0) & (T > 0.0).any(axis=1)     # (the control lets nothing through: T is 0)
        i = 0
        while walking.any():
            go = np.flatnonzero(walking)
            target[go] += -np.log1p(-stream(self.keys[go], i))
            stop = target[go] >= reach[go]
            walking[go[stop]] = False
            go = go[~stop]
            if len(go):
                j = np.minimum((self.M[go, 1:] <= target[go, None]).sum(axis=1), self.mu.shape[1] - 1)
                m = self.mu[go, j]
                x = self.edges[go, j] + (target[go] - self.M[go, j]) / m
                control = self.sigma_t[go, j] + self.slope[go, j] * (x - self.mid[go, j])[:, None]
                T[go] *= 1.0 - (self.fields_at(go, x)[0] - control) / m[:, None]
            i += 1
        return T

    def at(self, s: np.ndarray) -> tuple:
        """(sigma_t, sigma_s (n, 3), g (n,)) of the pieces at distances s (n,)."""
        k = self.piece(s)
        rows = np.arange(len(s))
        sigma_s = self.sigma_s[rows, k]
        total = sigma_s.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.where(total > 0.0, self.gs[rows, k] / total, 0.0)
        return self.sigma_t[rows, k], sigma_s, g

    def emitted(self) -> np.ndarray:
        """The light (n, 3) float64 the media's emission sends to the rays' starts: the sum over pieces of
        e (1 - exp(-sigma d)) / sigma (e d where sigma is 0) times exp(-tau) at the piece's start, and where an
        emitting field is in the box a correction that makes it unbiased there (one point), and a homogeneous
        medium's emission after the box weighed by ratio tracking's T at the box's end (C: march_emitted)."""
        width = np.diff(self.edges, axis=1)[:, :, None]
        e, sigma = self.emission, self.sigma_t
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            each = np.where(sigma > 0.0, e * -np.expm1(-sigma * width) / np.where(sigma > 0.0, sigma, 1.0), e * width)
            each = np.where(e != 0.0, each, 0.0) * np.exp(-self.tau[:, :-1])
        total = np.nan_to_num(each, nan=0.0).sum(axis=1)
        if self.mu is None:
            return total
        # The pieces' sum corrected without bias inside the box, a control variate: the control's emission linear on
        # each piece (its midpoint's, the neighbours' slope k) times the march's T, whose integral adds
        # k w^2 g(sigma w) exp(-tau) per piece (slope_integral); one point s uniform in [a, b) (the ray's stream,
        # number EMISSION_DRAW) adds (e(s) T(s) - e_c(s) T_m(s)) (b - a), e and T the true emission there and ratio
        # tracking's estimate (exact, noiseless, for an emission linear along the ray in a medium the control's
        # T fits).
        width = np.diff(self.edges, axis=1)[:, 1:-1, None]
        with np.errstate(invalid="ignore", over="ignore"):
            bent = np.where(self.eslope[:, 1:-1] != 0.0, self.eslope[:, 1:-1] * (width * width)
                            * slope_integral(self.sigma_t[:, 1:-1] * width) * np.exp(-self.tau[:, 1:-2]), 0.0)
        total = total + np.nan_to_num(bent, nan=0.0).sum(axis=1)
        emits = np.zeros(len(total), bool)
        for f, field in enumerate(self.fields):
            if field.emits:
                emits |= self.counts[:, f] > 0.0
        a, b = self.edges[:, 1], self.edges[:, -2]
        rows = np.flatnonzero(emits & (b > a))
        if len(rows):
            s = a + stream(self.keys, EMISSION_DRAW) * (b - a)
            T = self.transmittance(s)[rows]
            k = self.piece(s)[rows]
            e_true = self.fields_at(rows, s[rows])[2]
            control = self.emission[rows, k] + self.eslope[rows, k] * (s[rows] - self.mid[rows, k])[:, None]
            e_march = control * np.exp(-self.depth(s)[rows])
            total[rows] += (e_true * T - e_march) * (b - a)[rows, None]
        # A homogeneous medium's emission after the box: its closed form times ratio tracking's T at the box's end.
        rows = np.flatnonzero((self.emission[:, -1] != 0.0).any(axis=1) & (b > a))
        if len(rows):
            e, sigma, w = self.emission[rows, -1], self.sigma_t[rows, -1], np.diff(self.edges, axis=1)[rows, -1, None]
            with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
                after = np.where(sigma > 0.0, e * -np.expm1(-sigma * w) / np.where(sigma > 0.0, sigma, 1.0), e * w)
                after = np.where(e != 0.0, after, 0.0)
                T = self.transmittance(b)[rows]
                total[rows] += np.nan_to_num(after * (T - np.exp(-self.tau[rows, -2])), nan=0.0)
        return total

    def totals(self) -> tuple:
        """(tau_t, tau_s) (n, 3): the optical depths of extinction and of scattering over the whole rays (finite
        parts), for picking a channel in proportion to albedo."""
        width = np.diff(self.edges, axis=1)
        width = np.where(np.isfinite(width), width, 0.0)[:, :, None]
        return (self.sigma_t * width).sum(axis=1), (self.sigma_s * width).sum(axis=1)

    def free_flight(self, odds: np.ndarray, u: np.ndarray) -> tuple:
        """Free-flight sampling on the pieces: (s (n,), pdf (n,)) from numbers u (n, 2) (u[:, 0] < uniform_share:
        uniform in the box's stretch, rescaled; else u[:, 1] the channel by `odds` (n, 3), u[:, 0] rescaled the
        distance, inverting tau of that channel truncated at the end); pdf 0: none."""
        n = len(u)
        rows = np.arange(n)
        share, a, b = self.uniform_share()
        pick, u0 = self.split(share, u[:, 0])
        channel = np.minimum((u[:, 1:2] >= np.cumsum(odds, axis=1)).sum(axis=1), 2)
        tau = self.tau[rows, :, channel]                                # (n, K + 3)
        end = tau[:, -1]
        with np.errstate(over="ignore", invalid="ignore"):
            target = -np.log1p(-u0 * -np.expm1(-end))
        k = np.minimum(np.maximum((tau[:, 1:] <= target[:, None]).sum(axis=1), 0), self.sigma_t.shape[1] - 1)
        sigma = self.sigma_t[rows, k, channel]
        with np.errstate(invalid="ignore", divide="ignore"):
            s = self.edges[rows, k] + np.where(sigma > 0.0, (target - tau[rows, k]) / np.where(sigma > 0.0, sigma, 1.0),
                                               0.0)
        with np.errstate(invalid="ignore"):         # (a one-piece march: a, b its end and start, never picked)
            s = np.minimum(np.where(pick, a + u0 * (b - a), s), self.edges[:, -1])
        pdf = self.pdf(odds, s)
        ok = (odds.sum(axis=1) > 0.0) & (pick | (end > 0.0)) & np.isfinite(s) & (pdf > 0.0)
        return np.where(ok, s, 0.0), np.where(ok, pdf, 0.0)

    def pdf(self, odds: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The density (n,) of free-flight sampling choosing distances s (n,): the channels' mixture of
        sigma(s) exp(-tau(s)) / (1 - exp(-tau(end))), with the uniform share."""
        sigma, _, _ = self.at(s)
        tau = self.depth(s)
        reach = -np.expm1(-self.tau[:, -1])
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            each = np.where((odds > 0.0) & (reach > 0.0),
                            odds * sigma * np.exp(-tau) / np.where(reach > 0.0, reach, 1.0), 0.0)
        share, a, b = self.uniform_share()
        return self.share_pdf(share, a, b, s, each.sum(axis=1))


def inputs_table(field: "Field") -> tuple:
    """What C reads of a Field's closures (VolumeField): kinds (C,) int32, weights (C,) float64, inputs (C,
    VOLUME_INPUTS, 5) float64 each input's register (-1: a constant), the register's width, and its constant (3), and
    factors (f, 3) float64: a linked Mix Shader factor's closure, register, and 1 where the closure takes the factor
    (0: 1 - it)."""
    from ..materials import graph as graph_
    found, factors = {}, []
    for kind, node, slot, width, register in field.program.outputs.astype(np.int64):
        if kind == graph_.OUT_WEIGHT:
            factors.append((float(node), float(register), 1.0 if slot == 0 else 0.0))
        else:
            found[(int(node), int(slot))] = (int(width), int(register))
    C = len(field.entries)
    kinds = np.array([VOLUME_CLOSURE[name] for name, _, _ in field.entries], np.int32)
    weights = np.array([float(weight) for _, weight, _ in field.entries], np.float64)
    table = np.zeros((C, len(INPUT_WIDTHS), 5))
    for k, (name, _, inputs) in enumerate(field.entries):
        slot, linked = 0, {}
        for key in field.slots[k]:
            linked[key] = found[(k, slot)]
            slot += INPUT_WIDTHS[key]
        for row, (key, width) in enumerate(INPUT_WIDTHS.items()):
            value = inputs.get(key, DEFAULTS.get(name, {}).get(key, 0.0))
            value = np.atleast_1d(np.asarray(value if key not in linked else 0.0, np.float64)).reshape(-1)
            value = np.repeat(value[:1], 3) if len(value) < 3 else value[:3]
            got, register = linked.get(key, (width, -1))
            table[k, row] = [register, got, *value]
    return kinds, weights, table, np.array(factors, np.float64).reshape(-1, 3)


def field_record(field: "Field", column: int, following=None, shared=None) -> "VolumeFieldRecord":
    """The C record (VolumeField) of a Field whose media column is `column`, followed by the record `following`
    (None: the last). The record keeps its arrays alive. shared: a dict in which the fields of one program (a medium
    kept per object: Field.placed) share their program's tables, closures and grids (one record of each), or None."""
    from ..materials import graph as graph_
    c = np.ascontiguousarray
    shared = {} if shared is None else shared
    key = (id(field.program), id(field.textures), id(field.grids))
    if key not in shared:
        kinds, weights, table, factors = inputs_table(field)
        shared[key] = dict(
            graph=graph_.program_tables([field.program], field.textures), closures=len(kinds),
            scatters=int(field.scatters), emits=int(field.emits), kinds=c(kinds), weights=c(weights),
            inputs=c(table.reshape(-1)), factors=c(factors.reshape(-1) if len(factors) else np.zeros(3)),
            factor_count=len(factors), phases=c(field.phases), hot=c(field.hot), **grid_tables(field.grids))
    return VolumeFieldRecord(
        next=following, column=int(column), matrix=field.matrix.reshape(-1), location=field.location,
        size=field.size, origin=field.origin, linear=field.linear.reshape(-1), placement=field.placement,
        info=c(field.info, np.float64), info_width=len(field.info), random=float(field.random), **shared[key])


# The columns of a grid's row in VolumeField.grid_table: where its values start in `voxels`, X, Y, Z, C, lower (3),
# to_index (12), 1 where it is sampled tricubic (Grid.cubic).
GRID_COLUMNS = schema.constant("GRID_COLUMNS", 21, "the floats of a grid's row in VolumeField.grid_table")


def grid_tables(grids: list) -> dict:
    """What C reads of a Field's grids: grid_count, grid_table (G, GRID_COLUMNS) float64, voxels (all the grids'
    values, each (X, Y, Z, C) row-major) float32."""
    table = np.zeros((max(len(grids), 1), GRID_COLUMNS))
    start = 0
    for g, grid in enumerate(grids):
        X, Y, Z, C = grid.values.shape
        table[g, :8] = [start, X, Y, Z, C, *grid.lower]
        table[g, 8:20] = np.asarray(grid.to_index, np.float64).reshape(12)
        table[g, 20] = 1.0 if grid.cubic else 0.0
        start += grid.values.size
    voxels = (np.concatenate([np.ascontiguousarray(grid.values, np.float32).reshape(-1) for grid in grids])
              if grids else np.zeros(1, np.float32))
    return {"grid_count": len(grids), "grid_table": np.ascontiguousarray(table.reshape(-1)),
            "voxels": np.ascontiguousarray(voxels)}


VolumeFieldRecord = schema.record("VolumeField", "A heterogeneous medium (core/volumes/field.py Field): its program and closures, for media.c's march.", [
    ("graph", ptr("GraphTables"), "its one program and the images it reads"),
    ("next", ptr("VolumeField"), "the render's next heterogeneous medium, or NULL"),
    ("column", I32, "its column of the MediaTables (how often a ray is in it: the volume stack's count there; -1: the world's, every ray once)"),
    ("closures", I32, "C: its Volume output's closures"),
    ("scatters", I32, "1: some closure of it may scatter (Field.scatters)"),
    ("emits", I32, "1: some closure of it may emit (Field.emits)"),
    ("kinds", ptr(I32), "(C,) each closure's VOLUME_CLOSURE_*"),
    ("weights", ptr(F64), "(C,) the Mix and Add Shaders' weight above each"),
    ("inputs", ptr(F64), "(C, VOLUME_INPUTS, 5) each input's register (-1: its constant), width, constant (3)"),
    ("factors", ptr(F64), "(f, 3) a linked Mix Shader factor: its closure, register, 1 (the factor) or 0 (1 - it)"),
    ("factor_count", I32, "f"),
    ("matrix", F64, 12, "world to object, 3 x 4 row by row"),
    ("location", F64, 3, "the texture space's location (Generated coordinates)"),
    ("size", F64, 3, "and its size"),
    ("origin", F64, 3, "the world point the render's camera-relative coordinates are relative to"),
    ("linear", F64, 9, "object to world's linear part, row by row (the program's object transform)"),
    ("placement", F64, 3, "object to world's location (the program's Object Info Location)"),
    ("phases", ptr(I32), "(C,) each closure's phase function (PHASE_...; its numbers set up from its inputs)"),
    ("hot", ptr(I32), "(C,) the grid of each closure's black body's Temperature Attribute (glows averaged), or -1"),
    ("grid_count", I32, "G: a Volume object's grids its program reads (core/volumes/grids.py), or 0"),
    ("grid_table", ptr(F64), "(G, GRID_COLUMNS) each grid's start, X, Y, Z, C, lower (3), to_index (12), cubic"),
    ("voxels", ptr(F32), "the grids' values, each (X, Y, Z, C) row-major"),
    ("info", ptr(F64), "(W,) the Object Info row its program reads (Field.info: the placement and zeros, or a medium "
                       "kept per object's own row of geometry.instance_info)"),
    ("info_width", I32, "W"),
    ("random", F64, "the Object Info Random its program reads (0, or the object's: Field.random)"),
])
