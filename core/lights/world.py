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

# The importance map's width (its height is half), whatever the image's (Cycles' default map resolution).
MAP_WIDTH = 1024


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
              without shadows they trace no shadow ray (the add-on does not read Blender 5.2's world Shadows: noted).
              A constant world has no light samples, in Cycles as in Primer (it is found by the rays that escape),
              so neither changes it.
    suns:     the sun lamps it brings (a Sky Texture's sun disc, core/lights/world_graph.py sky_suns), which the
              scene's lights take in when it lights surfaces
    volume:   the closures of its Volume output (as Material.volume): a medium everywhere (core/volumes); empty: none
    seen:     the world's node graph compiled (core/lights/world_graph.py WorldProgram),
              which every ray that escapes (the camera's, a BSDF's, a volume's phase-sampled) evaluates per ray with
              its path, or None: they find `radiance`; light samples always read `radiance` (the bake)
    aovs:     its AOV Output nodes, [(AOV name, Color: (3,) or a graph.Link, Value: float or a graph.Link)] (as
              Material.aovs): what camera chains that escape write into the render's shader AOVs of that name
              (core/lights/world_graph.py compile_aovs, core/integrators/passes.py along_ray)
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
    aovs: list = field(default_factory=list)

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


def bilinear_equirect_grid(image: np.ndarray, w: int, h: int) -> np.ndarray:
    """bilinear_equirect at the centres of a w x h grid, u = (j + 0.5) / w, v = (i + 0.5) / h, done per row and
    column (the same products and sums in the same order, so the same numbers, without a gather per point):
    (h, w, 3) float64."""
    H, W = image.shape[:2]
    x = (np.arange(w) + 0.5) / w * W - 0.5
    y = (np.arange(h) + 0.5) / h * H - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[None, :, None], (y - y0)[:, None, None]
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)
    xa, xb = x0 % W, (x0 + 1) % W
    ya, yb = np.clip(y0, 0, H - 1), np.clip(y0 + 1, 0, H - 1)
    pixels = image[..., :3].astype(np.float64)

    def across(rows: np.ndarray) -> np.ndarray:
        """Rows (h, W, 3) interpolated along u at the grid's columns: (h, w, 3)."""
        return np.take(rows, xa, axis=1) * (1.0 - fx) + np.take(rows, xb, axis=1) * fx

    return across(pixels[ya]) * (1.0 - fy) + across(pixels[yb]) * fy


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
    def of(cls, world: World, width: int = 0) -> Optional["WorldLight"]:
        """The light of a world with an image (None for a constant or dark world). width: the map's."""
        if world.image is None or not world.lights:
            return None
        # As Cycles, the map has its own resolution, whatever the image's: finer than a small image, so that the
        # bilinear ramp around a bright texel (a sun) gets the pdf its radiance needs, not its dim neighbour's.
        w = width or MAP_WIDTH
        h = max(1, w // 2)
        # f at the map's cell centres: the radiance's plain RGB mean, times sin(theta) of the row.
        # The map is made in texture space: no rotation (a direction is rotated before lookup); bilinear_equirect at
        # the cell centres, row by row: the same numbers as point by point.
        L = bilinear_equirect_grid(world.image, w, h) * abs(world.strength)
        L = np.where(np.isfinite(L), np.abs(L), 0.0)
        # (the channels' mean as numpy's mean sums three: (r + g) + b, then / 3)
        f = (L[..., 0] + L[..., 1] + L[..., 2]) / 3.0 * np.sin(math.pi * ((np.arange(h) + 0.5) / h))[:, None]
        row_sums = f.sum(axis=1) / w
        total = row_sums.sum() / h
        if not total > 0.0:
            return None
        columns = np.zeros((h, w + 1))
        columns[:, 1:] = np.cumsum(f, axis=1)
        columns /= np.where(columns[:, -1:] > 0, columns[:, -1:], 1.0)
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
        if world.image is not None:
            image = c(world.image[..., :3], np.float32)
            record.image, record.height, record.width = image, image.shape[0], image.shape[1]
        if sampler is not None:
            for name in ("map", "rows", "columns"):
                setattr(record, name, c(getattr(sampler, name), np.float64))
            record.map_height, record.map_width = sampler.map.shape[0], sampler.map.shape[1]
            record.total = sampler.total
        self.record = record
