"""The world: the light that arrives from infinitely far in every direction, as in Cycles.

A constant world (one colour) lights a surface from the whole sky: a Lambert plane of albedo rho
under a uniform white world of radiance L receives E = pi L and shows rho L. As in Cycles, a
constant world is not sampled as a light: BSDF-sampled rays that escape the scene find it (for a
diffuse surface, cosine-weighted sampling is already proportional to what it sends). A world with
an equirectangular environment image is importance-sampled: a map of the image's brightness,
weighted by sin(theta) (the solid angle of a row), gives each texel a probability, and the pdf of
a direction is p_texel / (2 pi^2 sin theta) (cycles_lights.md, section 3).

The equirectangular mapping, as Cycles and Blender's Environment Texture use it:
    u = (pi - atan2(y, x)) / (2 pi),   v = 1 - acos(z) / pi     (v = 1 straight up, +Z)
"""
from __future__ import annotations

import dataclasses

import math
from dataclasses import dataclass, field
from typing import ClassVar, Optional

import numpy as np

from ..materials import graph as graph_
from ..native import library, schema
from ..native.schema import F32, F64, I32, I64, ptr
from .base import Light, LightFlags, LightHit, LightSample

# The importance map's width (its height is half) where nothing else sets it (Cycles' default World MIS resolution).
MAP_WIDTH = 1024
# Cycles' Automatic world sampling never maps finer than this, nor coarser unless one Sky Texture brings its sun.
AUTO_MAP_SIZE = (4096, 2048)
SKY_SUN_MAP_SIZE = (512, 256)


def map_size(sampling: str, resolution: int, environments: list, suns: int, guided: bool = True) -> tuple:
    """The world's importance map (width, height) as Cycles' world Sampling sets it (scene/light.cpp,
    device_update_background): MANUAL: resolution x resolution / 2; AUTOMATIC: the largest of its Environment
    Textures' (width, height) `environments` and, unless exactly one Sky Texture sun disc reads the plain direction
    (`suns` 1 and `guided`: Cycles' sun guiding), at least 4096 x 2048 (else at least 512 x 256). (0, 0) for NONE:
    the world is no light (the rays that escape find it, at weight 1)."""
    if sampling == "NONE":
        return (0, 0)
    if sampling == "MANUAL":
        return (max(int(resolution), 1), max(int(resolution) // 2, 1))
    x = max([int(w) for w, _ in environments] + [0])
    y = max([int(h) for _, h in environments] + [0])
    floor = SKY_SUN_MAP_SIZE if (suns == 1 and guided) else AUTO_MAP_SIZE
    return (max(x, floor[0]), max(y, floor[1]))


@dataclass
class World:
    """The world's light (Blender's World > Surface: a Background shader).

    color:    (3,) float64 radiance of a constant world (colour x strength), linear RGB
    image:    (H, W, 3) float32 linear radiance of an equirectangular environment, or None
    strength: multiplies the image (the Background node's Strength)
    rotation: (3, 3) float64 world-to-texture rotation (the Mapping node's), applied before (u, v)
    camera:   whether camera rays see it (Ray Visibility > Camera)
    lights:   whether it lights the scene (some kind of bounce sees it: Ray Visibility > Diffuse, Glossy, ...)
    hidden:   the HIDDEN_FROM_* bits of the bounces that do not see it (Ray Visibility > Diffuse, Glossy,
              Transmission, Volume Scatter off, as Cycles' SHADER_EXCLUDE_*): rays of those kinds that escape find
              nothing, its light samples light no closure of those kinds (integrators/vertex.py closures_left_out)
              and no scattering point where Volume Scatter is off
    max_bounces, cast_shadow: an image world's light samples stop after that bounce (Cycles' world Max Bounces), and
              without shadows they trace no shadow ray (Blender 5.2's world Shadows; weighed by MIS as Cycles' one
              sample per hit: integrators/vertex.py mis_count).
              A constant world has no light samples, in Cycles as in Primer (it is found by the rays that escape),
              so neither changes it.
    suns:     the sun lamps it brings (a Sky Texture's sun disc, core/lights/world_graph.py sky_suns), which the
              scene's lights take in when it lights surfaces
    volume:   the closures of its Volume output (as Material.volume): a medium everywhere (core/volumes); empty: none
    seen:     the world's node graph compiled (core/lights/world_graph.py WorldProgram),
              which every ray that escapes (the camera's, a BSDF's, a volume's phase-sampled) evaluates per ray with
              its path, or None: they find `radiance`; light samples read `radiance` (the bake), unless samples_seen
    samples_seen: its light samples run `seen` (not None) with the path at the vertex they light (EMISSION alone as
              the flags, that vertex's depths), as Cycles evaluates the world's shader per light sample: a graph that
              reads Light Path's depths, which the bake (a first bounce's: Ray Depth 1, the others 0) fixes; the
              importance map stays the bake's
    aovs:     its AOV Output nodes, [(AOV name, Color: (3,) or a graph.Link, Value: float or a graph.Link)] (as
              Material.aovs): what camera chains that escape write into the render's shader AOVs of that name
              (core/lights/world_graph.py compile_aovs, core/integrators/passes.py along_ray)
    map_size: (width, height) of its importance map (Cycles' World MIS resolution: map_size()), (0, 0): not sampled
              as a light (Cycles' Sampling None), None: MAP_WIDTH x MAP_WIDTH / 2. Noise only: the estimate is the same
    """

    color: np.ndarray = field(default_factory=lambda: np.zeros(3))
    image: Optional[np.ndarray] = None
    strength: float = 1.0
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    camera: bool = True
    lights: bool = True
    hidden: int = 0
    name: str = "World"
    max_bounces: int = 1024
    cast_shadow: bool = True
    suns: list = field(default_factory=list)
    volume: list = field(default_factory=list)
    seen: Optional[object] = None
    samples_seen: bool = False
    aovs: list = field(default_factory=list)
    map_size: Optional[tuple] = None

    @property
    def varying(self) -> bool:
        """Whether the world's radiance depends on the direction (an environment image)."""
        return self.image is not None

    def radiance(self, directions: np.ndarray) -> np.ndarray:
        """Return the radiance arriving from each direction: (n, 3) unit -> (n, 3) float64."""
        if self.image is None:
            return np.broadcast_to(np.asarray(self.color, np.float64)[:3], (len(directions), 3)).copy()
        u, v = direction_to_uv(directions @ np.asarray(self.rotation, np.float64).T)
        return bilinear_equirect(self.image, u, v) * self.strength

    def radiance_seen(self, directions: np.ndarray, paths=None) -> np.ndarray:
        """The radiance (n, 3) float64 rays along unit `directions` (n, 3) find where they escape, with the
        graph.LightPaths of their paths (None: camera rays): `seen` evaluated for each ray with its path where the
        world has a graph (as Cycles evaluates its world for every ray that escapes), else `radiance`."""
        if self.seen is None or not len(directions):
            return self.radiance(directions)
        return self.seen.along(directions, graph_.light_paths(len(directions)) if paths is None else paths)


def finite_world(world: World, warnings: Optional[list] = None) -> World:
    """Return `world` as Cycles renders it when its colour, strength or image holds a NaN or an infinity: each such
    channel or texel 0, a non-finite strength 0 (Cycles' film drops every non-finite contribution, ensure_finite:
    a black world that lights nothing), with one warning; the world itself when all is finite."""
    from ..materials.finite import finite_color
    color, bad_color = finite_color(world.color)
    strength = float(world.strength)
    bad_strength = not math.isfinite(strength)
    image, bad_texels = world.image, 0
    if image is not None:
        bad = ~np.isfinite(image)
        bad_texels = int(bad.any(axis=-1).sum())
        if bad_texels:
            image = np.where(bad, np.float32(0.0), image).astype(np.float32)
    if not (bad_color or bad_strength or bad_texels):
        return world
    what = [text for text, bad in (("colour", bad_color), ("strength", bad_strength),
                                   (f"image ({bad_texels} texels)", bad_texels)) if bad]
    if warnings is not None:
        warnings.append(f"the world's {' and '.join(what)} NaN or infinite; Primer reads it as 0, as Cycles renders it "
                        "(its film drops every non-finite contribution)")
    return dataclasses.replace(world, color=color, image=image, strength=0.0 if bad_strength else strength)


def direction_to_uv(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Equirectangular (u, v) of unit directions: (n, 3) -> two (n,) float64 in [0, 1]."""
    u = (math.pi - np.arctan2(d[:, 1], d[:, 0])) / (2.0 * math.pi)
    v = 1.0 - np.arccos(np.clip(d[:, 2], -1.0, 1.0)) / math.pi
    return u, v


def uv_to_direction(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The unit direction of equirectangular (u, v): phi = pi - 2 pi u, theta = pi (1 - v) -> (n, 3)."""
    phi = math.pi - 2.0 * math.pi * u
    theta = math.pi * (1.0 - v)
    sin_theta = np.sin(theta)
    return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), np.cos(theta)], axis=1)


def bilinear_equirect(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Linear interpolation of an equirectangular image at (u, v), texel centres at (i + 0.5) / W, row 0
    at the bottom (v = 0) as Blender stores images; u repeats, v extends: (n,) -> (n, 3) float64."""
    H, W = image.shape[:2]
    x = u * W - 0.5
    y = v * H - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)
    xa, xb = x0 % W, (x0 + 1) % W
    ya, yb = np.clip(y0, 0, H - 1), np.clip(y0 + 1, 0, H - 1)
    pixels = image.astype(np.float64, copy=False)
    top = pixels[ya, xa, :3] * (1.0 - fx) + pixels[ya, xb, :3] * fx
    bottom = pixels[yb, xa, :3] * (1.0 - fx) + pixels[yb, xb, :3] * fx
    return top * (1.0 - fy) + bottom * fy


def bilinear_grid(values: np.ndarray, w: int, h: int) -> np.ndarray:
    """One channel (H, W) of an equirectangular image, linear between texel centres (u repeats, v extends), at the
    centres of a w x h grid: along u on the image's own rows first, then along v: (h, w) float64."""
    H, W = values.shape
    x = (np.arange(w) + 0.5) / w * W - 0.5
    y = (np.arange(h) + 0.5) / h * H - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[None, :], (y - y0)[:, None]
    xa, xb = x0.astype(np.int64) % W, (x0.astype(np.int64) + 1) % W
    ya, yb = np.clip(y0.astype(np.int64), 0, H - 1), np.clip(y0.astype(np.int64) + 1, 0, H - 1)
    rows = values[:, xa] * (1.0 - fx) + values[:, xb] * fx          # (H, w)
    out = rows[ya]
    out *= 1.0 - fy
    below = rows[yb]
    below *= fy
    out += below
    return out


def reference_map(values: np.ndarray, sines: np.ndarray, w: int, h: int) -> tuple:
    """The importance map of a one-channel image `values` (H, W) float64 on a w x h grid: (f (h, w): linear between
    texel centres times the row's sine `sines` (h,); columns (h, w + 1): each row's running sums from 0, normalised
    to end at 1 where the row has any; totals (h,): each row's sum before that), all float64."""
    f = bilinear_grid(values, w, h)
    f *= sines[:, None]
    return (f, *running_sums(f))


def running_sums(f: np.ndarray, columns: Optional[np.ndarray] = None) -> tuple:
    """Each row's running sums of the map `f` (h, w) float64: (columns (h, w + 1) from 0, normalised to end at 1 where
    the row has any; totals (h,): each row's sum). `columns`: an (h, w + 1) float64 array to write them into (its
    old values are overwritten), else a new one."""
    h, w = f.shape
    if columns is None:
        columns = np.empty((h, w + 1))
    columns[:, 0] = 0.0
    np.cumsum(f, axis=1, out=columns[:, 1:])
    totals = columns[:, -1].copy()
    columns /= np.where(columns[:, -1:] > 0, columns[:, -1:], 1.0)
    return columns, totals


def compensated_map(f: np.ndarray, sines: np.ndarray, columns: Optional[np.ndarray] = None) -> tuple:
    """The importance map `f` (h, w) float64 (radiance x sin(theta), rows' sines `sines` (h,)) less its mean radiance
    over the sphere, floored at 0, with its rows' running sums and totals as reference_map gives them.

    MIS compensation (Karlik, Sik, Vevoda, Skrivan and Krivanek 2019): where the world is as bright as its mean or
    dimmer, BSDF-sampled rays find it well on their own, so its light samples need not go there. Sampling by
    max(L - mean(L), 0) sends them to the bright parts alone, and the power heuristic (whose light pdf is this map's)
    gives the BSDF rays full weight where the map is 0: the same estimate, with less noise where glossy and diffuse
    closures meet a world of a few bright lights. It is unbiased only where every light sample has a BSDF ray as
    its MIS partner (render.prepare's `compensate`). The mean is over solid angle: dw = 2 pi^2 sin(theta) du dv, so
    mean(L) = (1 / 4 pi) sum(f) 2 pi^2 / (w h) = (pi / 2) mean(f). A map all at or below its mean (a constant world)
    comes out all 0: not sampled, found by BSDF rays alone.

    The compensated map is made in `f`'s place, and its running sums in `columns` (h, w + 1) float64 when given (the
    uncompensated map's, which it replaces): a 4096 x 2048 map is 64 MiB an array, and the map's memory stays that of
    one map and one table of sums instead of three maps and two tables at once (the same numbers)."""
    delta = 0.5 * math.pi * float(f.mean())
    f -= delta * sines[:, None]
    np.maximum(f, 0.0, out=f)
    return (f, *running_sums(f, columns))


WorldMapArgs = schema.function("primer_world_map", "world_map_rows", schema.record("WorldMapArgs", "primer_world_map's arguments: rows row_start .. row_end - 1 of a world's importance map (world.reference_map's numbers).", [
    ("values", ptr(F64), "(H, W) the image's channel mean"),
    ("sines", ptr(F64), "(h,) each map row's sin(theta)"),
    ("width", I64, "W"),
    ("height", I64, "H"),
    ("map_width", I64, "w"),
    ("map_height", I64, "h"),
    ("row_start", I64, "the first row made"),
    ("row_end", I64, "past the last"),
    ("map", schema.out(F64), "(h, w) the map's values"),
    ("columns", schema.out(F64), "(h, w + 1) each row's normalised running sums, or NULL: not made"),
    ("totals", schema.out(F64), "(h,) each row's sum"),
]))

CompensatedMapArgs = schema.function("primer_compensated_map", "compensated_rows", schema.record("CompensatedMapArgs", "primer_compensated_map's arguments: rows row_start .. row_end - 1 of a world's importance map made less its mean (world.compensated_map's numbers), in place.", [
    ("sines", ptr(F64), "(h,) each map row's sin(theta)"),
    ("less", F64, "the mean taken off, per unit sine"),
    ("map_width", I64, "w"),
    ("row_start", I64, "the first row made"),
    ("row_end", I64, "past the last"),
    ("map", schema.out(F64), "(h, w) the map's values, made less in place"),
    ("columns", schema.out(F64), "(h, w + 1) each row's normalised running sums"),
    ("totals", schema.out(F64), "(h,) each row's sum"),
]))


def compiled_map(values: np.ndarray, sines: np.ndarray, w: int, h: int, compensate: bool = False) -> tuple:
    """reference_map by world.c (world_map_rows), in bands of rows, one per thread: the same numbers; compensate:
    compensated_map's of them (compensated_rows), the plain map's running sums not made."""
    values = np.ascontiguousarray(values, np.float64)
    sines = np.ascontiguousarray(sines, np.float64)
    f, columns, totals = np.empty((h, w)), np.empty((h, w + 1)), np.empty(h)
    library.in_row_bands(h, lambda start, end: library.call("primer_world_map", WorldMapArgs(
        values=values, sines=sines, width=values.shape[1], height=values.shape[0], map_width=w, map_height=h,
        row_start=start, row_end=end, map=f, columns=None if compensate else columns, totals=totals)))
    if compensate:
        less = 0.5 * math.pi * float(f.mean())           # (compensated_map's mean: numpy's sum, the same number)
        library.in_row_bands(h, lambda start, end: library.call("primer_compensated_map", CompensatedMapArgs(
            sines=sines, less=less, map_width=w, row_start=start, row_end=end, map=f, columns=columns,
            totals=totals)))
    return f, columns, totals


@dataclass
class WorldLight(Light):
    """The environment image as a light: importance-sampled by a map of brightness x sin(theta).

    map:   (h, w) float64 the map's values f = mean(|L|) sin(theta) at cell centres
    rows:  (h + 1,) float64 cumulative distribution over rows; columns (h, w + 1) within each row
    total: the mean of the map (its integral over the unit square)
    """

    world: World
    map: np.ndarray
    rows: np.ndarray
    columns: np.ndarray
    total: float
    name: str = "World"

    flags: ClassVar[LightFlags] = LightFlags.INFINITE
    blender_type: ClassVar[str] = "WORLD"

    @property
    def color(self) -> np.ndarray:
        return np.ones(3)

    @property
    def max_bounces(self) -> int:
        """The world's Max Bounces: its light samples stop after that bounce."""
        return self.world.max_bounces

    @property
    def hidden_from(self) -> int:
        """The HIDDEN_FROM_* bits of the bounces that do not see the world (World.hidden)."""
        return int(self.world.hidden)

    @property
    def cast_shadow(self) -> bool:
        """The world's Shadows: without them its light samples trace no shadow ray."""
        return self.world.cast_shadow

    @property
    def hittable(self) -> bool:
        return True

    def emits(self) -> bool:
        return self.total > 0.0

    def finite(self) -> bool:
        return bool(np.isfinite(self.map).all())

    def moved(self, origin: np.ndarray) -> "WorldLight":
        return self                          # infinitely far: no position

    @classmethod
    def of(cls, world: World, width: int = 0, kernels: str = "compiled",
           compensate: bool = False) -> Optional["WorldLight"]:
        """The light of a world with an image (None for a constant or dark world, or one not sampled: map size (0,
        0)). width: the map's (its height half), else the world's map_size, else MAP_WIDTH; kernels "compiled" makes
        the map in C where the library is loaded (world.c world_map_rows: the same numbers), "numpy" here;
        compensate: sample by the map less its mean (compensated_map), for renders whose BSDF rays find the world
        with MIS wherever its light samples go."""
        size = (width, max(1, width // 2)) if width else world.map_size or (MAP_WIDTH, MAP_WIDTH // 2)
        if world.image is None or not world.lights or min(size) <= 0:
            return None
        # As Cycles, the map has its own resolution, whatever the image's: finer than a small image, so that the
        # bilinear ramp around a bright texel (a sun) gets the pdf its radiance needs, not its dim neighbour's.
        w, h = int(size[0]), int(size[1])
        # f at the map's cell centres: the radiance's mean over the channels (of the magnitudes, the non-finite read as
        # 0), linear between texel centres, times sin(theta) of the row. The map is made in texture space: no rotation
        # (a direction is rotated before lookup).
        pixels = np.abs(np.asarray(world.image[..., :3], np.float64))
        pixels = np.where(np.isfinite(pixels), pixels, 0.0)
        mean = (pixels[..., 0] + pixels[..., 1] + pixels[..., 2]) * (abs(world.strength) / 3.0)
        del pixels                                   # (not kept beside the map's arrays)
        sines = np.sin(math.pi * ((np.arange(h) + 0.5) / h))
        if kernels == "compiled" and library.available():
            f, columns, totals = compiled_map(mean, sines, w, h, compensate)
        else:
            f, columns, totals = reference_map(mean, sines, w, h)
            if compensate:
                f, columns, totals = compensated_map(f, sines, columns)     # in the uncompensated map's place
        row_sums = totals / w
        total = row_sums.sum() / h
        if not total > 0.0:
            return None
        rows = np.zeros(h + 1)
        rows[1:] = np.cumsum(row_sums)
        rows /= rows[-1]
        return cls(world, f, rows, columns, float(total))

    def pdf(self, directions: np.ndarray) -> np.ndarray:
        """The solid-angle pdf of sampling each direction: f / (total 2 pi^2 sin theta): (n, 3) -> (n,)."""
        h, w = self.map.shape
        u, v = direction_to_uv(directions @ np.asarray(self.world.rotation, np.float64).T)
        x = np.clip((u * w).astype(np.int64), 0, w - 1)
        y = np.clip((v * h).astype(np.int64), 0, h - 1)
        sin_theta = np.sin(math.pi * v)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = self.map[y, x] / (self.total * 2.0 * math.pi * math.pi * sin_theta)
        return np.where(sin_theta > 0.0, pdf, 0.0)

    def sample(self, points: np.ndarray, u: np.ndarray, cone=None, N=None) -> LightSample:
        """A direction by the map: a row by the marginal distribution, a column within it, linear
        inside the cell; strength = L / pdf per unit colour (colour: the radiance's RGB)."""
        n = len(points)
        h, w = self.map.shape
        y = np.clip(np.searchsorted(self.rows, u[:, 0], side="right") - 1, 0, h - 1)
        dy = (u[:, 0] - self.rows[y]) / np.maximum(self.rows[y + 1] - self.rows[y], 1e-300)
        # The column: how many entries of the row's cdf are <= u1, by binary search over each sample's row.
        below, above = np.zeros(n, np.int64), np.full(n, w + 1, np.int64)
        while (above > below).any():
            mid = (below + above) // 2
            go = (above > below) & (self.columns[y, np.minimum(mid, w)] <= u[:, 1])
            stop = (above > below) & ~go
            below = np.where(go, mid + 1, below)
            above = np.where(stop, mid, above)
        x = np.clip(below - 1, 0, w - 1)
        lo, hi = self.columns[y, x], self.columns[y, x + 1]
        dx = (u[:, 1] - lo) / np.maximum(hi - lo, 1e-300)
        uu, vv = (x + np.clip(dx, 0.0, 1.0)) / w, (y + np.clip(dy, 0.0, 1.0)) / h
        local = uv_to_direction(uu, vv)
        L = local @ np.asarray(self.world.rotation, np.float64)      # back from texture space
        sin_theta = np.sin(math.pi * vv)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.where(sin_theta > 0.0, self.map[y, x] / (self.total * 2.0 * math.pi * math.pi * sin_theta), 0.0)
        radiance = self.world.radiance(L)
        with np.errstate(divide="ignore", invalid="ignore"):
            strength = np.where(pdf > 0.0, 1.0 / pdf, 0.0)
        return LightSample(L, np.full(n, np.inf), strength, pdf, radiance, np.zeros((n, 3)))

    def without_attenuation(self, sample: LightSample, points: np.ndarray) -> LightSample:
        return sample

    def centre_numbers(self) -> np.ndarray:
        return np.array([0.5, 0.5])

    def pack_fields(self, record) -> None:
        """The record says only how many samples and which dimension; the map goes in WorldTables."""


WorldTablesRecord = schema.record("WorldTables", "The world (core/lights/world.py World and WorldLight): a constant colour or an equirectangular image.", [
    ("image", ptr(F32), "(H, W, 3) linear radiance, or NULL for a constant world"),
    ("map", ptr(F64), "(h, w) importance map, or NULL"),
    ("rows", ptr(F64), "(h + 1,) cumulative over rows"),
    ("columns", ptr(F64), "(h, w + 1) cumulative within each row"),
    ("width", I64, "the image's W"),
    ("height", I64, "the image's H"),
    ("map_width", I64, "w"),
    ("map_height", I64, "h"),
    ("total", F64, "the map's sum"),
    ("color", F64, 3, "a constant world's radiance"),
    ("strength", F64, ""),
    ("rotation", F64, 9, "world to texture, row-major"),
    ("camera", I32, "1: camera rays see it"),
    ("lights", I32, "1: it lights surfaces"),
    ("hidden", I32, "the HIDDEN_FROM_* bits of the bounces that do not see it (World.hidden)"),
    ("seen", ptr("WorldGraph"), "the program camera rays evaluate where they escape (World.seen), or NULL"),
    ("samples_seen", I32, "1: its light samples run `seen` with their vertex's path (World.samples_seen)"),
])


class WorldTables:
    """The world (and its importance map, where it has one) in C's dtypes, and the record (WorldTables) that points
    at them. sampler: the WorldLight, or None."""

    def __init__(self, world: World, sampler: Optional[WorldLight]):
        c = library.contiguous
        record = WorldTablesRecord(color=np.asarray(world.color, np.float64)[:3], strength=float(world.strength),
                                   rotation=np.asarray(world.rotation, np.float64).ravel(), camera=world.camera,
                                   lights=world.lights, hidden=int(world.hidden))
        if world.seen is not None:
            record.seen = world.seen.record()
            record.samples_seen = int(bool(world.samples_seen))
        if world.image is not None:
            image = c(world.image[..., :3], np.float32)
            record.image, record.height, record.width = image, image.shape[0], image.shape[1]
        if sampler is not None:
            for name in ("map", "rows", "columns"):
                setattr(record, name, c(getattr(sampler, name), np.float64))
            record.map_height, record.map_width = sampler.map.shape[0], sampler.map.shape[1]
            record.total = sampler.total
        self.record = record
