"""Cryptomatte: per pixel, which objects, materials and assets cover it and how much, as Cycles writes it.

A matte for compositing without render layers (Friedman and Jones, "Fully automatic ID mattes with support
for motion blur and transparency", 2015). Each name becomes a 32-bit id by MurmurHash3 (seed 0), stored as
the float32 with the same bits; a pixel's ids go in (id, coverage) pairs, two per RGBA pass (CryptoObject00,
CryptoObject01, ...), ranked by coverage. A compositor finds the ids by name again through the manifest
(name -> hex id) stored in the image's metadata.

Coverage follows Cycles (kernel/film/data_passes.h, cryptomatte_passes.h): along each camera sample's chain
(passes.py: the camera ray and its rays straight on through Transparent closures) every surface adds
mean(throughput) x (1 - mean(transparency)) to its id, the one opaque enough for the data passes
(RenderSettings.pass_alpha_threshold) and those behind it alike; the pixel's value is the sum over its samples divided by their
count. So an object behind a plane letting 60 % through covers 0.6 of the pixel in the mean and the plane 0.4, and
the background covers nothing. A pixel keeps slot_count(depth) slots per kind, filled as its samples meet the ids
(fill_slots: Cycles' rule, no eviction; the late ids of a full pixel add to the last slot); a chunk's slots go
into the film's in order (merge_slots), and the image ranks them (ranked).

Names, as Cycles gives them (checked against Cycles' own manifest): the object is the object's name (an
instanced object's own name, not its instancer's); the asset is its topmost parent's name (the object itself
without a parent); the material is the material's name, "default_surface" for triangles without one.
"""
from __future__ import annotations

import json

import numpy as np

# The kinds of matte, Blender's View Layer > Passes > Cryptomatte toggles, and their pass names.
KINDS = ("object", "material", "asset")
PASS_PREFIX = {"object": "CryptoObject", "material": "CryptoMaterial", "asset": "CryptoAsset"}
# Cycles' name for the surface of triangles without a material.
DEFAULT_MATERIAL = "default_surface"


def murmur3_32(data: bytes, seed: int = 0) -> int:
    """MurmurHash3's 32-bit x86 variant of `data` (Austin Appleby's public-domain hash)."""
    c1, c2, mask = 0xCC9E2D51, 0x1B873593, 0xFFFFFFFF
    h = seed & mask
    whole = len(data) - len(data) % 4
    # 1. Four bytes at a time, little-endian: mix each block into the hash.
    for i in range(0, whole, 4):
        k = int.from_bytes(data[i:i + 4], "little")
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        k = (k * c2) & mask
        h ^= k
        h = ((h << 13) | (h >> 19)) & mask
        h = (h * 5 + 0xE6546B64) & mask
    # 2. The last one to three bytes.
    tail = data[whole:]
    if tail:
        k = int.from_bytes(tail, "little")
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        k = (k * c2) & mask
        h ^= k
    # 3. Finalise: fold in the length and avalanche the bits.
    h ^= len(data)
    h ^= h >> 16
    h = (h * 0x85EBCA6B) & mask
    h ^= h >> 13
    h = (h * 0xC2B2AE35) & mask
    h ^= h >> 16
    return h


def name_hash(name: str) -> int:
    """The 32-bit id of `name` as Cryptomatte stores it: an exponent of all zeros or all ones (a denormal,
    an infinity or a NaN once read as a float) has its lowest exponent bit flipped."""
    h = murmur3_32(name.encode("utf-8"))
    exponent = (h >> 23) & 0xFF
    if exponent in (0, 255):
        h ^= 1 << 23
    return h


def name_id(name: str) -> np.float32:
    """The float32 whose bits are name_hash(name): the value a Cryptomatte pass holds for `name`."""
    return np.array([name_hash(name)], np.uint32).view(np.float32)[0]


def layer_key(layer: str) -> str:
    """The metadata key of the matte layer `layer` ("ViewLayer.CryptoObject"): the first 7 hex digits of its
    hash, as in "cryptomatte/542cafa/name"."""
    return f"{murmur3_32(layer.encode('utf-8')):08x}"[:7]


def names_of(scene) -> dict:
    """The names each Cryptomatte kind gives a scene's sources, by index: {"object": [per scene.instances],
    "asset": [per scene.instances], "material": [per scene.materials, then the default surface's]}."""
    return {"object": [instance.name for instance in scene.instances],
            "asset": [instance.asset or instance.name for instance in scene.instances],
            "material": [material.name for material in scene.materials] + [DEFAULT_MATERIAL]}


def id_tables(scene) -> dict:
    """The float32 ids of names_of(scene): {kind: (k,) float32}, a 0 id for a kind without names."""
    return {kind: np.array([name_id(name) for name in names] or [0.0], np.float32)
            for kind, names in names_of(scene).items()}


def manifest(names) -> str:
    """The manifest of `names`: a JSON object name -> 8 hex digits of its id."""
    return json.dumps({name: f"{name_hash(name):08x}" for name in dict.fromkeys(names)}, separators=(",", ":"))


def metadata(view_layer: str, kind: str, names) -> dict:
    """The image metadata that lets a compositor find `names` (their manifest) in the matte `kind` of the
    view layer `view_layer`: key -> value, as Cycles writes it."""
    layer = f"{view_layer}.{PASS_PREFIX[kind]}"
    prefix = f"cryptomatte/{layer_key(layer)}/"
    return {prefix + "name": layer, prefix + "hash": "MurmurHash3_32", prefix + "conversion": "uint32_to_float32",
            prefix + "manifest": manifest(names)}


def pass_count(depth: int) -> int:
    """How many RGBA passes (two ranks each) hold `depth` ranks."""
    return max(1, (int(depth) + 1) // 2)


def slot_count(depth: int) -> int:
    """The (id, weight) slots a pixel keeps per kind of matte for `depth` ranks: two per RGBA pass, as Cycles."""
    return 2 * pass_count(depth)


def fill_slots(pixel: np.ndarray, ids: np.ndarray, weight: np.ndarray, pixels: int, slots: int) -> np.ndarray:
    """Each pixel's slots after its entries went in one by one, in their order, by Cycles' rule
    (film_write_cryptomatte_slots): an entry adds its weight to the slot of its id, or takes the first empty
    slot, or, all slots taken, adds to the last; entries of weight 0 (or not finite) take no slot. pixel (m,) int64 in 0 ..
    pixels - 1, ids (m,) float32 (never 0, the empty id), weight (m,) float64, in order.
    Returns (pixels, slots, 2) float64: per slot the id (a float32's value; 0: empty) and the summed weight."""
    out = np.zeros((pixels, slots, 2))
    keep = (weight > 0.0) & np.isfinite(weight)
    if not keep.any():
        return out
    order = np.flatnonzero(keep)
    pixel, bits, weight = pixel[keep], np.asarray(ids, np.float32)[keep].view(np.uint32), weight[keep]
    # 1. Each (pixel, id): its summed weight and where it first came.
    key = (pixel.astype(np.uint64) << np.uint64(32)) | bits.astype(np.uint64)
    unique, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    total = np.bincount(inverse.reshape(-1), weights=weight)
    where = (unique >> np.uint64(32)).astype(np.int64)
    ident = (unique & np.uint64(0xFFFFFFFF)).astype(np.uint32)
    # 2. Within a pixel, the ids in order of first coming: their slots, the late ones sharing the last.
    arrival = order[first]
    by_arrival = np.lexsort((arrival, where))
    where, ident, total = where[by_arrival], ident[by_arrival], total[by_arrival]
    rank = np.arange(len(where)) - np.searchsorted(where, where, side="left")
    slot = np.minimum(rank, slots - 1)
    np.add.at(out[:, :, 1], (where, slot), total)
    own = rank < slots
    out[where[own], slot[own], 0] = ident[own].view(np.float32)
    return out


def merge_slots(film: np.ndarray, chunk: np.ndarray) -> np.ndarray:
    """The film's slots (p, slots, 2) after a chunk's slots (p, slots, 2) of the same pixels went in, in order, as
    entries (fill_slots): (p, slots, 2) float64."""
    p, slots, _ = film.shape
    both = np.concatenate([film, chunk], axis=1)
    pixel = np.repeat(np.arange(p), 2 * slots)
    return fill_slots(pixel, both[:, :, 0].reshape(-1).astype(np.float32), both[:, :, 1].reshape(-1), p, slots)


def ranked(slots: np.ndarray, count: np.ndarray, depth: int) -> np.ndarray:
    """A Cryptomatte pass from each pixel's slots (p, slots, 2) and samples `count` (p,): (p, 4 pass_count(depth))
    float32, the (id, coverage) pairs in order of falling coverage (equal ones in slot order, as Cycles' sort), the
    coverage the slot's weight over the pixel's samples; empty slots (0, 0)."""
    p, n, _ = slots.shape
    out = np.zeros((p, 2 * 2 * pass_count(depth)), np.float32)
    order = np.argsort(-slots[:, :, 1], axis=1, kind="stable")
    ordered = np.take_along_axis(slots, order[:, :, None], axis=1)
    samples = np.maximum(np.asarray(count, np.float64), 1.0)[:, None]
    pairs = min(n, out.shape[1] // 2)
    out[:, 0:2 * pairs:2] = ordered[:, :pairs, 0].astype(np.float32)
    out[:, 1:2 * pairs:2] = (ordered[:, :pairs, 1] / samples).astype(np.float32)
    return out
