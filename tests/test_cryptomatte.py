"""Cryptomatte in core (core/integrators/cryptomatte.py): the ids are Cryptomatte's hashes of the names, and
each pixel's coverage is the share of its samples that see a name, weighed by what lets light through."""
from __future__ import annotations

import dataclasses

import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.integrators import cryptomatte
from core.scene import RenderSettings, Scene

MATTES = ("crypto_object", "crypto_material", "crypto_asset")


def test_murmur3_gives_the_published_test_vectors():
    assert cryptomatte.murmur3_32(b"") == 0
    assert cryptomatte.murmur3_32(b"", seed=1) == 0x514E28B7
    assert cryptomatte.murmur3_32(b"hello") == 0x248BFA47
    assert cryptomatte.murmur3_32(b"The quick brown fox jumps over the lazy dog") == 0x2E4FF723


def test_names_hash_to_the_ids_in_cycles_own_manifest():
    # Read off the manifest Cycles 5.0 wrote for a default scene (cube "Cube", material "Material", a sphere
    # without a material): name -> id, and the metadata keys of the three mattes of "ViewLayer".
    seen = {"Cube": "a8fce865", "Material": "3913209d", "default_surface": "78d05529", "Light": "c77d43e5"}
    assert {name: f"{cryptomatte.name_hash(name):08x}" for name in seen} == seen
    assert cryptomatte.layer_key("ViewLayer.CryptoObject") == "542cafa"
    assert cryptomatte.layer_key("ViewLayer.CryptoMaterial") == "c7dbf5e"
    assert cryptomatte.layer_key("ViewLayer.CryptoAsset") == "aa21542"


def test_an_id_is_always_a_finite_normal_float():
    # A hash whose exponent bits are all 0 or all 1 would read as a denormal, an infinity or a NaN.
    raw = {f"name{i}": cryptomatte.murmur3_32(f"name{i}".encode()) for i in range(3000)}
    odd = [name for name, h in raw.items() if (h >> 23) & 0xFF in (0, 255)]
    assert odd, "no name in the sample had an extreme exponent"
    for name in odd:
        assert cryptomatte.name_hash(name) == raw[name] ^ (1 << 23)
        value = cryptomatte.name_id(name)
        assert np.isfinite(value) and abs(value) >= np.finfo(np.float32).tiny


def test_ranks_fall_with_coverage_and_coverage_is_the_mean_over_samples():
    a, b, c = (cryptomatte.name_id(n) for n in ("a", "b", "c"))
    # Pixel 0: 4 samples; b once, then a three times. Pixel 1: c at half weight twice. Pixel 2: nothing.
    pixel = np.array([0, 0, 0, 0, 1, 1])
    ids = np.array([b, a, a, a, c, c], np.float32)
    weight = np.array([1.0, 1.0, 1.0, 1.0, 0.5, 0.5])
    slots = cryptomatte.fill_slots(pixel, ids, weight, pixels=3, slots=cryptomatte.slot_count(6))
    assert slots.shape == (3, 6, 2)
    assert slots[0, 0, 0] == b and slots[0, 1, 0] == a          # in the order they came
    out = cryptomatte.ranked(slots, np.array([4, 4, 4]), depth=6)
    assert out.shape == (3, 12) and out.dtype == np.float32
    assert out[0, 0] == a and out[0, 1] == 0.75 and out[0, 2] == b and out[0, 3] == 0.25
    assert out[1, 0] == c and out[1, 1] == 0.25
    assert np.all(out[2] == 0.0) and np.all(out[0, 4:] == 0.0)


def test_a_pixel_with_more_ids_than_slots_adds_the_late_ones_to_the_last_slot_as_cycles():
    ids = np.array([cryptomatte.name_id(n) for n in "abcde"], np.float32)
    # A depth of 1 keeps two slots (one RGBA pass): a, then b, where c, d and e land too; a again stays in a's.
    pixel = np.zeros(6, np.int64)
    order = np.array([ids[0], ids[1], ids[2], ids[3], ids[0], ids[4]], np.float32)
    slots = cryptomatte.fill_slots(pixel, order, np.ones(6), pixels=1, slots=cryptomatte.slot_count(1))
    assert slots[0, 0, 0] == ids[0] and slots[0, 0, 1] == 2.0
    assert slots[0, 1, 0] == ids[1] and slots[0, 1, 1] == 4.0


def test_merging_a_chunks_slots_is_putting_its_entries_in_after_the_films():
    rng = np.random.default_rng(3)
    ids = np.array([cryptomatte.name_id(n) for n in "abcdefg"], np.float32)
    pixel = rng.integers(0, 5, 60)
    chosen = ids[rng.integers(0, len(ids), 60)]
    weight = rng.random(60)
    slots = cryptomatte.slot_count(4)
    whole = cryptomatte.fill_slots(pixel, chosen, weight, 5, slots)
    early = cryptomatte.fill_slots(pixel[:30], chosen[:30], weight[:30], 5, slots)
    late = cryptomatte.fill_slots(pixel[30:], chosen[30:], weight[30:], 5, slots)
    merged = cryptomatte.merge_slots(early, late)
    assert np.all(merged[:, :, 0] == whole[:, :, 0])
    # (a late id that shares the last slot in a chunk counts under that slot's id when merged: only the totals agree)
    assert np.allclose(merged[:, :, 1].sum(axis=1), whole[:, :, 1].sum(axis=1))


def two_boxes(sheet: bool = False) -> tuple:
    """Two unit boxes side by side on the x axis seen from above, one without a material; optionally a
    sheet over the left one that lets 60 % of the light through (a Transparent BSDF of 0.6 with a diffuse of
    0.4: alpha 0.4, under the 0.5 the data passes stop at)."""
    scene = Scene(camera=Camera.look_at(np.array([0.0, 0.0, 5.0]), np.zeros(3), up=(0.0, 1.0, 0.0),
                                        fov=math.radians(40)),
                  world_color=np.array([0.1, 0.1, 0.1]))
    scene.add_material((0.5, 0.5, 0.5), name="Paint")
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(-0.6, 0.0, 0.0)), materials=[0], name="Left")
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(0.6, 0.0, 0.0)), materials=[-1], name="Right")
    scene.instances[0].asset = "Rig"
    if sheet:
        scene.materials.append(materials.Material(name="Veil", nodes=[("TRANSPARENT", (0.6, 0.6, 0.6), {}),
                                                                        ("DIFFUSE", (0.4, 0.4, 0.4), {})]))
        scene.add_mesh(primitives.plane(1.0, center=(-0.6, 0.0, 1.0)), materials=[1], name="Sheet")
    settings = RenderSettings(width=48, height=32, samples=16, passes=MATTES)
    return scene, settings


def ids_at(image: np.ndarray, row: int, col: int) -> tuple:
    """(id, coverage) pairs of a pixel of a Cryptomatte image (H, W, 4k) float32."""
    values = image[row, col]
    return [(values[i], float(values[i + 1])) for i in range(0, len(values), 2) if values[i + 1] > 0.0]


def test_objects_materials_and_assets_get_their_names_ids_and_full_coverage_inside():
    scene, settings = two_boxes()
    aux = render.render(scene, settings).aux
    middle = settings.height // 2
    left, right = np.argmin(np.abs(np.linspace(-1, 1, 48) + 0.33)), np.argmin(np.abs(np.linspace(-1, 1, 48) - 0.33))
    assert ids_at(aux["crypto_object"], middle, left) == [(cryptomatte.name_id("Left"), 1.0)]
    assert ids_at(aux["crypto_object"], middle, right) == [(cryptomatte.name_id("Right"), 1.0)]
    assert ids_at(aux["crypto_asset"], middle, left) == [(cryptomatte.name_id("Rig"), 1.0)]
    assert ids_at(aux["crypto_asset"], middle, right) == [(cryptomatte.name_id("Right"), 1.0)]
    assert ids_at(aux["crypto_material"], middle, left) == [(cryptomatte.name_id("Paint"), 1.0)]
    assert ids_at(aux["crypto_material"], middle, right) == [(cryptomatte.name_id("default_surface"), 1.0)]
    assert ids_at(aux["crypto_object"], 0, 0) == []                 # the world: no id
    # Each pixel's coverage adds up to the share of its samples that hit, in multiples of 1 / 16.
    total = aux["crypto_object"][..., 1::2].sum(axis=-1)
    assert total.max() <= 1.0 + 1e-6
    edge = (total > 0.0) & (total < 1.0)
    assert edge.any()
    assert np.allclose(total * 16, np.round(total * 16), atol=1e-5)


def test_a_sheet_covers_its_opacity_and_what_lies_behind_the_light_it_lets_through():
    # Each sample's path goes on through the sheet's Transparent closure with its share of the sampling weight (0.6)
    # and weight 1, as in Cycles: the box behind covers 0.6 in the mean, the sheet its alpha at every sample.
    scene, settings = two_boxes(sheet=True)
    settings = dataclasses.replace(settings, samples=256)
    aux = render.render(scene, settings).aux
    middle = settings.height // 2
    left = np.argmin(np.abs(np.linspace(-1, 1, 48) + 0.33))
    pairs = dict(ids_at(aux["crypto_object"], middle - 1, left))
    assert set(pairs) == {cryptomatte.name_id("Left"), cryptomatte.name_id("Sheet")}
    assert pairs[cryptomatte.name_id("Sheet")] == pytest.approx(0.4, abs=1e-6)
    assert pairs[cryptomatte.name_id("Left")] == pytest.approx(0.6, abs=0.04)


def test_cryptomatte_needs_a_depth_of_one_to_sixteen():
    scene, settings = two_boxes()
    settings.cryptomatte_depth = 0
    with pytest.raises(ValueError, match="cryptomatte_depth"):
        render.render(scene, settings)
