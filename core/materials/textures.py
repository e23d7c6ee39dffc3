"""Image textures: every image a render's materials use, kept as stored, looked up as Cycles does.

An image is stored at the precision and with the channels its file has: 8-bit values stay bytes (a texel
x / 255 when read), 16-bit ones 16-bit integers (x / 65535), half and full floats float32; grey stays one
channel (read as RGB = grey, alpha 1), grey with alpha two, RGB three (alpha 1). Rows run bottom first
(Blender's convention: UV (0, 0) is the image's lower-left corner). All images of a render share one flat
buffer per precision; an image is its format, offset, width, height and channels there. Images in the sRGB
colour space keep their sRGB-encoded values and are decoded to linear after interpolation, as Cycles does
("compress as sRGB", kernel/svm/image.h); every other colour space is stored as it is read (Non-Color,
Linear Rec.709: already the numbers to use). An 8-bit RGBA image of 16384 x 16384 texels takes 1 GiB so,
4 GiB as floats.

Lookups follow Cycles' CPU kernel (kernel/device/cpu/image.h): a texel's centre is at (i + 0.5) /
width; Closest takes the texel the point lies in, Linear interpolates the four nearest centres,
Cubic weighs the sixteen nearest with the uniform cubic B-spline; Repeat wraps, Extend clamps to the
edge, Clip is transparent black outside the image, Mirror reflects. core/materials/textures.c is the
compiled twin.

A UDIM image (TiledImage) is one row of the set with no texels of its own and a list of tiles in the set's tile
table: numbers 1001, 1002 ... and the rows of the tiles' images. A lookup at (x, y) picks tile 1001 + tx + 10 ty
with tx, ty the integer parts of x and y (C's truncation, as Cycles' svm_node_tex_image does: -1 < x < 0 is
tile column 0) and samples it at (x - tx, y - ty); where 0 <= tx < 10 and 0 <= ty fails, or no tile has that
number, it is Cycles' missing image, magenta. A plain image has no tiles, and its lookup is what it was.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from ..native import library, schema
from ..native.schema import F32, F64, I32, I64, U8, U16, out, ptr

INTERPOLATIONS = {"Linear": 0, "Closest": 1, "Cubic": 2, "Smart": 2}
EXTENSIONS = {"REPEAT": 0, "EXTEND": 1, "CLIP": 2, "MIRROR": 3}
schema.constants("TEX", {"LINEAR": 0, "CLOSEST": 1, "CUBIC": 2}, "an image node's interpolation (INTERPOLATIONS)")
schema.constants("EXT", EXTENSIONS, "an image node's extension (EXTENSIONS)")
# What Cycles returns for an image it could not load (TEX_IMAGE_MISSING_R, G, B, A): magenta.
MISSING = (1.0, 0.0, 1.0, 1.0)


# Storage formats of an image's texels (TextureSet.format), and the scale that reads each as 0..1.
FORMAT_FLOAT, FORMAT_BYTE, FORMAT_SHORT = schema.constants("TEX", ("float", "byte", "short"),
                                                          "how an image's texels are stored").values()
FORMAT_OF = {np.dtype(np.float32): FORMAT_FLOAT, np.dtype(np.uint8): FORMAT_BYTE, np.dtype(np.uint16): FORMAT_SHORT}
SCALE = {FORMAT_FLOAT: 1.0, FORMAT_BYTE: 1.0 / 255.0, FORMAT_SHORT: 1.0 / 65535.0}


@dataclass(eq=False)
class Image:
    """One image: pixels (h, w, c) with c in 1..4, uint8, uint16 or float32 (other types become float32), bottom
    row first; srgb: decode sRGB after lookup."""

    pixels: np.ndarray
    srgb: bool = False
    name: str = "Image"

    def __post_init__(self):
        pixels = np.asarray(self.pixels)
        if pixels.dtype not in FORMAT_OF:
            pixels = pixels.astype(np.float32)
        if pixels.ndim == 2:
            pixels = pixels[:, :, None]
        self.pixels = np.ascontiguousarray(pixels[:, :, :4])

    @property
    def format(self) -> int:
        """FORMAT_FLOAT, FORMAT_BYTE or FORMAT_SHORT."""
        return FORMAT_OF[self.pixels.dtype]

    def rgba(self) -> np.ndarray:
        """The texels as (h, w, 4) float32 RGBA, still encoded as stored (sRGB stays sRGB)."""
        return as_rgba(self.pixels).astype(np.float32)


def reduction(height: int, width: int, limit: int = 0, resolution: float = 1.0) -> float:
    """The factor (a power of 2, at most 1) by which Cycles shrinks an image of height x width under Simplify's
    Texture Limit `limit` (0: none) and Texture Resolution `resolution` (Blender 5.2; 1: none), as Cycles 5.2's
    ImageManager::device_load_image and ImageCache::load_full compute it in float32: the resolution lowered to
    limit / larger side where that side passes the limit, then rounded down to a power of 2, 2^floor(log2). (Blender
    5.0's halving until the larger side fits the limit gives the same factor.)"""
    scale = np.float32(resolution)
    largest = max(int(height), int(width))
    if limit > 0 and largest > limit:
        scale = min(scale, np.float32(limit) / np.float32(largest))
    if not scale < np.float32(1.0):
        return 1.0
    return float(np.float32(2.0) ** np.floor(np.log2(np.float32(scale))))


def limited(pixels: np.ndarray, limit: int, resolution: float = 1.0, rounding: HalfRounding = None) -> np.ndarray:
    """An image's pixels (h, w, c), bottom row first, as Cycles keeps them under Simplify > Texture Limit `limit`
    (0: none) and Blender 5.2's Texture Resolution `resolution` (1: none): shrunk by `reduction` (scale 2^-n) with
    util_image_resize_pixels' box filter, each texel the mean of its k x k block (k = 2^n) of the stored values, the
    output int(side x scale) (at least 1) and the remainder past whole blocks (top rows, right columns) dropped.
    Cycles' own float32 arithmetic: integers read as value x (1 / 255) (65535; Blender's build turns the division
    into that product: measured, the exact halves of 4 x 4 means then round as Cycles'), summed row by row in
    float32, times 1 / count, rounded back as util_image_cast_from_float rounds them: bytes as Cycles', bit for
    bit. Half floats (float16, as Cycles keeps a half-float file) are averaged in float32 and made half again as the
    running Blender's Cycles makes them, `rounding` (HalfRounding, needed for half floats only; half_of)."""
    h, w = pixels.shape[:2]
    scale = reduction(h, w, limit, resolution)
    if scale == 1.0:
        return pixels
    k = int(np.float32(1.0) / np.float32(scale) + np.float32(0.5))
    oh, ow = max(int(np.float32(h) * np.float32(scale)), 1), max(int(np.float32(w) * np.float32(scale)), 1)
    top = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(pixels.dtype)
    values = pixels.astype(np.float32) * (np.float32(1.0) / np.float32(top)) if top else pixels.astype(np.float32)
    if values.ndim == 2:
        values = values[:, :, None]
    kh, kw = min(k, h), min(k, w)                   # (a side shorter than k: Cycles averages what there is)
    blocks = values[:oh * kh, :ow * kw].reshape(oh, kh, ow, kw, -1).transpose(0, 2, 1, 3, 4).reshape(oh, ow, kh * kw, -1)
    total = np.cumsum(blocks, axis=2, dtype=np.float32)[:, :, -1]     # (sequential: Cycles' order, rows then texels)
    mean = (total * (np.float32(1.0) / np.float32(kh * kw))).reshape((oh, ow) + pixels.shape[2:])
    if pixels.dtype == np.float16:                  # (Cycles' float_to_half_image, util_image_cast_from_float)
        return np.ascontiguousarray(half_of(mean, rounding))
    if top is None:
        return np.ascontiguousarray(mean)
    scaled = np.float32(top) * mean + np.float32(0.5)
    rounded = np.where(mean < 0.0, 0.0, np.where(mean > np.float32(1.0) - np.float32(0.5) / np.float32(top), top,
                                                 np.trunc(scaled)))
    return np.ascontiguousarray(rounded.astype(pixels.dtype))


@dataclass(eq=False)
class TiledImage:
    """A UDIM image: tiles {tile number (1001, 1002 ...): Image, or None for a tile that could not be read
    (magenta there, as Cycles' missing image)}; looked up at the tile the UV's integer part names."""

    tiles: dict
    name: str = "Image"

    @property
    def srgb(self) -> bool:
        """Whether its tiles are sRGB (all are, or none: one image's colour space)."""
        return any(tile is not None and tile.srgb for tile in self.tiles.values())


# Tile numbers as Cycles reads them: 1001 + column + 10 row, with 10 columns.
FIRST_TILE, TILE_COLUMNS = 1001, 10


def tile_of(x: np.ndarray, y: np.ndarray):
    """The UDIM tile each point (x, y) (n,) float64 lies in, as Cycles' svm_node_tex_image picks it: (tile number
    (n,) int64, -1 where there is none; column tx and row ty (n,) int64, the integer parts of x and y rounded toward
    zero). A tile exists where 0 <= tx < 10 and 0 <= ty, i.e. -1 < x < 10 and -1 < y."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    inside = (x > -1.0) & (x < TILE_COLUMNS) & (y > -1.0) & (y < 1e9)
    tx = np.trunc(np.where(inside, x, 0.0)).astype(np.int64)
    ty = np.trunc(np.where(inside, y, 0.0)).astype(np.int64)
    return np.where(inside, FIRST_TILE + tx + TILE_COLUMNS * ty, -1), tx, ty


def as_rgba(texels: np.ndarray) -> np.ndarray:
    """Texels (..., c) of any stored format as float64 RGBA (..., 4): scaled to 0..1 from integers, grey to
    RGB, a missing alpha 1."""
    values = texels.astype(np.float64)
    if texels.dtype != np.float32:
        values = values * SCALE[FORMAT_OF[texels.dtype]]
    c = texels.shape[-1]
    grey = values[..., :1]
    if c == 1:
        return np.concatenate([grey, grey, grey, np.ones_like(grey)], axis=-1)
    if c == 2:
        return np.concatenate([grey, grey, grey, values[..., 1:2]], axis=-1)
    if c == 3:
        return np.concatenate([values, np.ones_like(grey)], axis=-1)
    return values


# The last buffer _joined made, by format: (its parts, the buffer).
_LAST_JOINED: dict = {}


def _read_only(array: np.ndarray) -> bool:
    """Whether nothing can write the texels of `array`: it and every array it is a view of are read-only."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        array = array.base
    return True


def _where(array: np.ndarray) -> tuple:
    """Which texels `array` is: its address, shape, strides and type."""
    return array.__array_interface__["data"][0], array.shape, array.strides, array.dtype.str


def _joined(parts: list, dtype) -> np.ndarray:
    """One buffer (a,) `dtype` of the texels of `parts` (arrays of one format), one after another (zeros (4,) for no
    parts). Read-only parts are images decoded once for the renders that follow one another (addon/materials.py
    _decoded): when every part is read-only and they are the same texels as the last call's, that call's buffer is
    given again (their texels cannot have changed), not copied anew."""
    if not parts:
        return np.zeros(4, dtype)
    key = np.dtype(dtype).str
    last = _LAST_JOINED.get(key)
    fixed = all(_read_only(part) for part in parts)
    if fixed and last is not None and [_where(part) for part in parts] == [_where(part) for part in last[0]]:
        return last[1]                              # (last[0] keeps those texels alive: no other array is there)
    buffer = np.concatenate([part.reshape(-1) for part in parts]).astype(dtype, copy=False)
    if fixed:
        buffer.flags.writeable = False
        _LAST_JOINED[key] = (list(parts), buffer)
    else:
        _LAST_JOINED.pop(key, None)
    return buffer


@dataclass
class TextureSet:
    """Every image of a render in one buffer per storage format (textures.c TextureTables).

    floats (a,) float32, shorts (b,) uint16, bytes (c,) uint8: the texels of the images of each format, one after
    another; format, offset (in values of its buffer), width, height, channels, srgb: (k,) int64 per image;
    tile_count, tile_start (k,) int64: a UDIM image's tiles are entries tile_start .. tile_start + tile_count - 1
    of tile_number, tile_image (t,) int64 (a tile's number and its image's row, -1 where it could not be read);
    tile_count is 0 for every other image
    """

    floats: np.ndarray = field(default_factory=lambda: np.zeros(4, np.float32))
    shorts: np.ndarray = field(default_factory=lambda: np.zeros(4, np.uint16))
    bytes: np.ndarray = field(default_factory=lambda: np.zeros(4, np.uint8))
    format: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    offset: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    width: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    height: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    channels: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    srgb: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    tile_count: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    tile_start: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    tile_number: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    tile_image: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    @classmethod
    def of(cls, images: list) -> "TextureSet":
        """The images (Image or TiledImage each) in their formats' buffers, row i being images[i]; a TiledImage's
        tiles are rows after all of them, in the order of their numbers."""
        if not images:
            return cls()
        rows = list(images)
        tile_count, tile_start, tile_number, tile_image = [], [], [], []
        for image in images:
            tiles = sorted(image.tiles.items()) if isinstance(image, TiledImage) else []
            tile_count.append(len(tiles))
            tile_start.append(len(tile_number))
            for number, tile in tiles:
                tile_number.append(int(number))
                tile_image.append(-1 if tile is None else len(rows))
                if tile is not None:
                    rows.append(tile)
        buffers = {FORMAT_FLOAT: [], FORMAT_BYTE: [], FORMAT_SHORT: []}
        offset, form, shape = [], [], []
        for image in rows:
            tiled = isinstance(image, TiledImage)           # a row without texels of its own
            form.append(FORMAT_FLOAT if tiled else image.format)
            parts = buffers[form[-1]]
            offset.append(sum(part.size for part in parts))
            shape.append((0, 0, 0) if tiled else image.pixels.shape)
            if not tiled:
                parts.append(image.pixels)

        def joined(form, dtype):
            return _joined(buffers[form], dtype)

        shape = np.array(shape, np.int64)
        pad = [0] * (len(rows) - len(images))
        return cls(joined(FORMAT_FLOAT, np.float32), joined(FORMAT_SHORT, np.uint16), joined(FORMAT_BYTE, np.uint8),
                   np.array(form, np.int64), np.array(offset, np.int64),
                   shape[:, 1].copy(), shape[:, 0].copy(), shape[:, 2].copy(),
                   np.array([1 if image.srgb else 0 for image in rows], np.int64),
                   np.array(tile_count + pad, np.int64), np.array(tile_start + pad, np.int64),
                   np.array(tile_number, np.int64), np.array(tile_image, np.int64))

    def texels(self, index: int) -> np.ndarray:
        """Image `index`'s texels (h, w, c) as stored (a view into its format's buffer)."""
        form = int(self.format[index])
        data = {FORMAT_FLOAT: self.floats, FORMAT_BYTE: self.bytes, FORMAT_SHORT: self.shorts}[form]
        w, h, c = int(self.width[index]), int(self.height[index]), int(self.channels[index])
        start = int(self.offset[index])
        return data[start:start + w * h * c].reshape(h, w, c)

    def lookup(self, index: int, x: np.ndarray, y: np.ndarray, interpolation: int, extension: int,
               unassociate: bool = False) -> np.ndarray:
        """Image `index` at texture coordinates (x, y) (n,) float64 -> RGBA (n, 4) float64, linear.
        index -1 is the missing image (magenta). unassociate: the interpolated colour divided by its alpha where that
        is neither 0 nor 1, before the sRGB decoding (Cycles' NODE_IMAGE_ALPHA_UNASSOCIATE, `unassociated`)."""
        n = len(x)
        if index < 0:
            return np.tile(np.array(MISSING), (n, 1))
        if len(self.tile_count) and self.tile_count[index] > 0:
            return self.tiled_lookup(index, x, y, interpolation, extension, unassociate)
        data = self.texels(index)
        if interpolation == 1:
            rgba = closest(data, x, y, extension)
        elif interpolation == 2:
            rgba = cubic(data, x, y, extension)
        else:
            rgba = linear(data, x, y, extension)
        if unassociate:
            rgba = unassociated(rgba)
        if self.srgb[index]:
            rgba[:, :3] = srgb_to_linear(rgba[:, :3])
        return rgba


    def tiled_lookup(self, index: int, x: np.ndarray, y: np.ndarray, interpolation: int,
                     extension: int, unassociate: bool = False) -> np.ndarray:
        """UDIM image `index` at (x, y) (n,) float64 -> RGBA (n, 4) float64: each point's tile (tile_of) looked up at
        (x - tx, y - ty) (`unassociate` as `lookup`); magenta where no tile is, or the tile could not be read."""
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        number, tx, ty = tile_of(x, y)
        out = np.tile(np.array(MISSING), (len(x), 1))
        start = int(self.tile_start[index])
        for entry in range(start, start + int(self.tile_count[index])):
            here = np.flatnonzero(number == self.tile_number[entry])
            if len(here):
                out[here] = self.lookup(int(self.tile_image[entry]), x[here] - tx[here], y[here] - ty[here],
                                        interpolation, extension, unassociate)
        return out


def unassociated(rgba: np.ndarray) -> np.ndarray:
    """Interpolated texels (n, 4) float64 with their colour divided by their alpha where it is neither 0 nor 1 (the
    alpha kept), as Cycles' svm_image_texture does for NODE_IMAGE_ALPHA_UNASSOCIATE: the straight colour of an image
    whose colours were multiplied by their alpha when read (`associated`)."""
    alpha = rgba[:, 3:4]
    divide = (alpha != 0.0) & (alpha != 1.0)
    out = rgba.copy()
    out[:, :3] = np.where(divide, rgba[:, :3] / np.where(divide, alpha, 1.0), rgba[:, :3])
    return out


def opaque_value(dtype) -> float:
    """The stored value of alpha 1 in pixels of `dtype`: 255 for uint8, 65535 for uint16, else 1."""
    return float(np.iinfo(dtype).max) if np.dtype(dtype).kind in "ui" else 1.0


def alpha_channel(pixels: np.ndarray) -> int:
    """The channel of pixels (h, w, c) that Cycles reads as alpha: 1 of grey and alpha (c 2), 3 of four or more
    channels, -1 for none (c 1 or 3)."""
    c = pixels.shape[2] if pixels.ndim == 3 else 1
    return 1 if c == 2 else 3 if c >= 4 else -1


def has_alpha_below_one(pixels: np.ndarray) -> bool:
    """Whether pixels (h, w, c) have an alpha channel (alpha_channel) with some value below 1."""
    k = alpha_channel(pixels)
    return k >= 0 and bool((pixels[..., k] < opaque_value(pixels.dtype)).any())


class HalfRounding(enum.Enum):
    """How the running Blender's Cycles makes a float32 half (util/half.h float_to_half_image, CPU), which Cycles
    does for half-float images shrunk by Simplify (limited) and associated with their alpha (associated). Cycles
    changed it in Blender 5.1 (commit b5c7dd95c, "Half float denormals and optimizations"); the add-on picks one
    per render from bpy.app.version (half_rounding_of)."""

    TRUNCATED = "truncated"         # Blender 4.2 .. 5.0: half_truncated
    NEAREST_EVEN = "nearest even"   # Blender 5.1 and later: half_rounded


def half_rounding_of(version: tuple) -> HalfRounding:
    """The HalfRounding of Cycles in Blender `version` (a tuple such as bpy.app.version, (5, 0, 1)): NEAREST_EVEN
    from 5.1 on, TRUNCATED before."""
    return HalfRounding.NEAREST_EVEN if tuple(version)[:2] >= (5, 1) else HalfRounding.TRUNCATED


def half_of(values: np.ndarray, rounding: HalfRounding) -> np.ndarray:
    """float32 values (...) made half -> (...) float16 as `rounding` says (half_truncated or half_rounded);
    ValueError without a rounding (a half made by a silent guess would be Cycles' of one Blender only)."""
    if rounding is HalfRounding.TRUNCATED:
        return half_truncated(values)
    if rounding is HalfRounding.NEAREST_EVEN:
        return half_rounded(values)
    raise ValueError(f"half floats need a HalfRounding (Cycles' differs between Blender versions), not {rounding!r}")


def half_rounded(values: np.ndarray) -> np.ndarray:
    """float32 values (...) as halves the way Blender 5.1+'s Cycles float_to_half_image makes them: clamped to
    -65504 .. 65504 by Cycles' clamp, min(max(f, -65504), 65504) (inf to +-65504, and NaN, which fails every
    comparison, to -65504), then rounded to the nearest half, ties to even, subnormals (below 2^-14, steps of 2^-24)
    kept, the sign kept (-0 stays -0) -> (...) float16."""
    f = np.asarray(values, np.float32)
    f = np.where(f > np.float32(-65504.0), f, np.float32(-65504.0))
    f = np.where(f < np.float32(65504.0), f, np.float32(65504.0))
    return f.astype(np.float16)                     # (numpy's conversion: nearest, ties to even, subnormals kept)


def half_widened(halves: np.ndarray, rounding: HalfRounding) -> np.ndarray:
    """float16 halves (...) read as float32 (...) the way the Cycles of `rounding` reads them on the CPU
    (half_to_float_image): exactly from Blender 5.1 on (NEAREST_EVEN); in 4.2 .. 5.0 (TRUNCATED) by moving the
    exponent's bias alone, exact for normal halves, but a zero or subnormal half (exponent 0) read as
    2^-15 (1 + m / 1024) with its sign (0 as 3.05e-5), and inf, NaN as 65536 (1 + m / 1024)."""
    h = np.ascontiguousarray(halves, np.float16)
    if rounding is not HalfRounding.TRUNCATED:
        return h.astype(np.float32)
    u = h.view(np.uint16).astype(np.uint32)
    bits = ((u & 0x8000) << 16) | (((u & 0x7C00) + 0x1C000) << 13) | ((u & 0x03FF) << 13)
    return bits.astype(np.uint32).view(np.float32)


def half_truncated(values: np.ndarray) -> np.ndarray:
    """float32 values (...) as halves the way Cycles' CPU float_to_half_image of Blender 4.2 .. 5.0 makes them: the
    mantissa truncated (not rounded), magnitudes below 2^-14 (subnormals) flushed to 0, those of 65536 and above (and
    inf, NaN) clamped to 65504 (65504 .. 65536 truncate to 65504 too), the sign kept (NaN's too) -> (...) float16."""
    u = np.ascontiguousarray(values, np.float32).view(np.uint32).astype(np.int64)
    sign = (u & 0x80000000) >> 16
    exponent = u & 0x7F800000
    bits = ((u & 0x7FFFFFFF) >> 13) - 0x1C000
    bits = np.where(exponent < 0x38800000, 0, np.where(exponent > 0x47000000, 0x7BFF, bits))
    return (bits | sign).astype(np.uint16).view(np.float16)


def associated(pixels: np.ndarray, rounding: HalfRounding = None) -> np.ndarray:
    """RGBA pixels (h, w, 4) with straight alpha as Cycles associates them when it loads an image
    (util_image_multiply_native, before any colour decoding: sRGB values stay encoded): each colour times its alpha
    in the stored type, bytes as (c a) // 255 and shorts as (c a) // 65535 (truncated), half floats as the float32
    product of the halves as Cycles reads them (half_widened) made half as `rounding` says (HalfRounding, needed for
    half floats only; half_of), floats as the float32 product; the alpha kept. Cycles does so for exactly 4 channels
    (grey and alpha stays straight): other pixels, and pixels with no alpha below 1, are given back as they are (no
    copy)."""
    if pixels.ndim != 3 or pixels.shape[2] != 4 or not has_alpha_below_one(pixels):
        return pixels
    out = pixels.copy()
    if pixels.dtype.kind in "ui":
        wide = pixels.astype(np.uint32)
        out[..., :3] = (wide[..., :3] * wide[..., 3:4]) // np.uint32(opaque_value(pixels.dtype))
    elif pixels.dtype == np.float16:
        wide = half_widened(pixels, rounding)       # (Cycles' read of both halves, then the product made half)
        out[..., :3] = half_of(wide[..., :3] * wide[..., 3:4], rounding)
    else:
        out[..., :3] = pixels[..., :3] * pixels[..., 3:4]
    return out


def alpha_ignored(pixels: np.ndarray) -> np.ndarray:
    """Pixels (h, w, c) with their alpha (alpha_channel) set to 1, as Cycles reads an image whose Alpha mode is None
    (IMAGE_ALPHA_IGNORE); pixels without alpha, or with no alpha below 1, are given back as they are (no copy)."""
    if not has_alpha_below_one(pixels):
        return pixels
    out = pixels.copy()
    out[..., alpha_channel(pixels)] = opaque_value(pixels.dtype)
    return out


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """The exact sRGB decoding curve (IEC 61966-2-1), as Cycles' color_srgb_to_linear: c (...) float64."""
    c = np.asarray(c, np.float64)
    return np.where(c < 0.04045, np.where(c < 0.0, 0.0, c * (1.0 / 12.92)),
                    ((np.maximum(c, 0.04045) + 0.055) * (1.0 / 1.055)) ** 2.4)


def floor_frac(x: np.ndarray):
    """(integer part (n,) int64 rounded down, fraction (n,) float64) of x (Cycles' frac)."""
    i = np.floor(x)
    return i.astype(np.int64), x - i


def wrap(i: np.ndarray, size: int, extension: int) -> np.ndarray:
    """Texel indices i (n,) int64 wrapped by an extension mode (Clip: left as they are)."""
    if extension == 0:
        return np.mod(i, size)
    if extension == 1:
        return np.clip(i, 0, size - 1)
    if extension == 3:
        m = np.mod(np.abs(i + (i < 0)), 2 * size)
        return np.where(m >= size, 2 * size - m - 1, m)
    return i


def read(data: np.ndarray, ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
    """Texels as RGBA (n, 4) float64 (as_rgba) at (ix, iy) of `data` (h, w, c) as stored; transparent black
    outside the image (Cycles' read_clip)."""
    h, w = data.shape[:2]
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    out = as_rgba(data[np.where(inside, iy, 0), np.where(inside, ix, 0)])
    return np.where(inside[:, None], out, 0.0)


def closest(data: np.ndarray, x: np.ndarray, y: np.ndarray, extension: int) -> np.ndarray:
    """The texel each point lies in."""
    h, w = data.shape[:2]
    ix, _ = floor_frac(np.asarray(x, np.float64) * w)
    iy, _ = floor_frac(np.asarray(y, np.float64) * h)
    return read(data, wrap(ix, w, extension), wrap(iy, h, extension))


def linear(data: np.ndarray, x: np.ndarray, y: np.ndarray, extension: int) -> np.ndarray:
    """Bilinear interpolation between the four nearest texel centres."""
    h, w = data.shape[:2]
    ix, tx = floor_frac(np.asarray(x, np.float64) * w - 0.5)
    iy, ty = floor_frac(np.asarray(y, np.float64) * h - 0.5)
    x0, x1 = wrap(ix, w, extension), wrap(ix + 1, w, extension)
    y0, y1 = wrap(iy, h, extension), wrap(iy + 1, h, extension)
    tx, ty = tx[:, None], ty[:, None]
    return ((1.0 - ty) * ((1.0 - tx) * read(data, x0, y0) + tx * read(data, x1, y0))
            + ty * ((1.0 - tx) * read(data, x0, y1) + tx * read(data, x1, y1)))


def spline_weights(t: np.ndarray) -> list:
    """The uniform cubic B-spline's four weights at fraction t (n,) (Cycles' SET_CUBIC_SPLINE_WEIGHTS)."""
    return [(((-1.0 / 6.0) * t + 0.5) * t - 0.5) * t + 1.0 / 6.0,
            ((0.5 * t - 1.0) * t) * t + 2.0 / 3.0,
            ((-0.5 * t + 0.5) * t + 0.5) * t + 1.0 / 6.0,
            (1.0 / 6.0) * t * t * t]


def cubic(data: np.ndarray, x: np.ndarray, y: np.ndarray, extension: int) -> np.ndarray:
    """Bicubic B-spline over the sixteen nearest texel centres."""
    h, w = data.shape[:2]
    ix, tx = floor_frac(np.asarray(x, np.float64) * w - 0.5)
    iy, ty = floor_frac(np.asarray(y, np.float64) * h - 0.5)
    u, v = spline_weights(tx), spline_weights(ty)
    out = np.zeros((len(ix), 4))
    if extension == 2:                              # Clip: nothing of the image within reach
        far = (ix < -2) | (ix > w) | (iy < -2) | (iy > h)
    for b in range(4):
        row = np.zeros((len(ix), 4))
        yb = wrap(iy + b - 1, h, extension)
        for a in range(4):
            row += u[a][:, None] * read(data, wrap(ix + a - 1, w, extension), yb)
        out += v[b][:, None] * row
    if extension == 2:
        out[far] = 0.0
    return out


TextureTablesRecord = schema.record("TextureTables", "A render's images (core/materials/textures.py TextureSet): the texels of each format in one buffer.", [
    ("floats", ptr(F32), "the float images' texels, rows bottom first"),
    ("shorts", ptr(U16), "the 16-bit images'"),
    ("bytes", ptr(U8), "the 8-bit images'"),
    ("format", ptr(I64), "(k,) TEX_FLOAT, TEX_BYTE or TEX_SHORT"),
    ("offset", ptr(I64), "(k,) first value of each image in its format's buffer"),
    ("width", ptr(I64), "(k,)"),
    ("height", ptr(I64), "(k,)"),
    ("channels", ptr(I64), "(k,)"),
    ("srgb", ptr(I64), "(k,) 1: decode the sRGB curve after interpolation"),
    ("tile_count", ptr(I64), "(k,) a UDIM image's number of tiles, 0 for any other image"),
    ("tile_start", ptr(I64), "(k,) its first entry in tile_number and tile_image"),
    ("tile_number", ptr(I64), "(t,) each tile's number, 1001 + column + 10 row"),
    ("tile_image", ptr(I64), "(t,) each tile's image row, -1 where it could not be read (magenta)"),
    ("count", I64, "k"),
])

TextureLookupArgs = schema.function("primer_texture_lookup", "texture_lookup_rows", schema.record("TextureLookupArgs", "primer_texture_lookup's arguments: TextureSet.lookup of image `index` at n points.", [
    ("textures", ptr("TextureTables"), ""),
    ("index", I64, ""),
    ("interpolation", I32, "TEX_LINEAR, TEX_CLOSEST, TEX_CUBIC"),
    ("extension", I32, "EXT_REPEAT, EXT_EXTEND, EXT_CLIP, EXT_MIRROR"),
    ("unassociate", I32, "1: the colour divided by its alpha (textures.unassociated)"),
    ("n", I64, ""),
    ("x", ptr(F64), "(n,)"),
    ("y", ptr(F64), "(n,)"),
    ("rgba", out(F64), "(n, 4)"),
]))


def texture_tables(textures: TextureSet) -> TextureTablesRecord:
    """The C record of a TextureSet, keeping its arrays alive."""
    c = library.contiguous
    return TextureTablesRecord(floats=c(textures.floats, np.float32), shorts=c(textures.shorts, np.uint16),
                               bytes=c(textures.bytes, np.uint8), count=len(textures.width),
                               **{name: c(getattr(textures, name), np.int64)
                                  for name in ("format", "offset", "width", "height", "channels", "srgb", "tile_count",
                                               "tile_start", "tile_number", "tile_image")})


def compiled_lookup(textures: TextureSet, index: int, x: np.ndarray, y: np.ndarray, interpolation: int,
                    extension: int, unassociate: bool = False) -> np.ndarray:
    """TextureSet.lookup in C (textures.c), for the tests: RGBA (n, 4) float64."""
    x, y = library.contiguous(x, np.float64), library.contiguous(y, np.float64)
    out_ = np.empty((len(x), 4))
    library.call("primer_texture_lookup", TextureLookupArgs(
        textures=texture_tables(textures), index=index, interpolation=interpolation, extension=extension,
        unassociate=int(bool(unassociate)), n=len(x),
        x=x, y=y, rgba=out_))
    return out_
