"""Cryptomatte written by Primer inside real Blender (the bpy module), against Cycles' own on the same scene:
pass names and channels, ids, coverage, the manifest in the image's metadata, and the matte the compositor's
Cryptomatte node cuts from each. No mocks.

Both renders take 16 samples with a 1-pixel box filter (tools/render.py configure_cycles_reference) at
different positions inside each pixel, so edge pixels differ by a sample or two; the ids are compared where
Cycles sees one name alone (coverage 1, and the same in all 8 neighbours).
"""
from __future__ import annotations

import json
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import configure_cycles_reference, load_primer  # noqa: E402

from test_blender_denoise import render_image  # noqa: E402

pytestmark = pytest.mark.blender

SAMPLES = 16
KINDS = ("Object", "Material", "Asset")


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def read_metadata(path: str) -> dict:
    """Return the EXR's Cryptomatte metadata: key -> value."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    found = {}
    part = 0
    while inp.seek_subimage(part, 0):
        for attribute in inp.spec().extra_attribs:
            if attribute.name.startswith("cryptomatte/"):
                found[attribute.name] = attribute.value
        part += 1
    inp.close()
    return found


def open_scene():
    """The materials_principled sample scene (six spheres, one without a material, one with alpha), two spheres
    parented to an empty "Rig" (their asset), every Cryptomatte toggle on."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", "materials_principled.blend"))
    scene = bpy.context.scene
    rig = bpy.data.objects.new("Rig", None)
    scene.collection.objects.link(rig)
    for name in ("Sphere 0", "Sphere 1"):
        child = bpy.data.objects[name]
        child.parent = rig
        child.matrix_parent_inverse = rig.matrix_world.inverted()
    layer = scene.view_layers[0]
    for kind in KINDS:
        setattr(layer, f"use_pass_cryptomatte_{kind.lower()}", True)
    scene.render.resolution_percentage = 50
    scene.primer.samples = SAMPLES
    scene.primer.use_adaptive_sampling = False
    return scene


def render_both(folder) -> dict:
    """engine -> (passes, metadata) of Primer's and Cycles' multilayer EXRs."""
    scene = open_scene()
    out = {}
    for engine in ("PRIMER", "CYCLES"):
        scene.render.engine = engine
        if engine == "CYCLES":
            configure_cycles_reference(scene, SAMPLES)
        path = str(folder / f"crypto_{engine}.exr")
        out[engine] = (render_image(scene, path, multilayer=True), read_metadata(path))
    return out


@pytest.fixture(scope="module")
def renders(primer, tmp_path_factory):
    return render_both(tmp_path_factory.mktemp("cryptomatte"))


def ranks(passes: dict, kind: str) -> np.ndarray:
    """(H, W, 2 * ranks) float32: the (id, coverage) pairs of matte `kind`, its RGBA passes side by side."""
    names = sorted(name for name in passes if name.startswith("Crypto" + kind))
    return np.concatenate([passes[name][1] for name in names], axis=-1)


def alone(image: np.ndarray) -> np.ndarray:
    """Pixels where one id covers the whole pixel and all 8 neighbours too: (H, W) bool."""
    first, coverage = image[..., 0], image[..., 1]
    mask = coverage == 1.0
    padded = np.pad(first, 1, mode="edge")
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            mask &= padded[1 + dy:1 + dy + first.shape[0], 1 + dx:1 + dx + first.shape[1]] == first
    return mask


def test_primer_writes_cryptomatte_passes_under_cycles_names_and_channels(renders):
    mine, cycles = renders["PRIMER"][0], renders["CYCLES"][0]
    expected = [name for name in cycles if name.startswith("Crypto")]
    assert len(expected) == 9                                # 3 kinds x 3 passes at the default depth of 6
    for name in expected:
        assert name in mine, name
        assert mine[name][0] == cycles[name][0], (name, mine[name][0], cycles[name][0])
        assert mine[name][1].shape == cycles[name][1].shape, name


@pytest.mark.parametrize("kind", KINDS)
def test_ids_equal_cycles_where_one_name_covers_a_pixel(renders, kind):
    mine, cycles = ranks(renders["PRIMER"][0], kind), ranks(renders["CYCLES"][0], kind)
    mask = alone(cycles)
    assert mask.mean() > 0.3, mask.mean()
    assert len(np.unique(cycles[..., 0][mask])) >= (2 if kind == "Asset" else 4)
    assert np.array_equal(mine[..., 0][mask].view(np.uint32), cycles[..., 0][mask].view(np.uint32))
    assert np.array_equal(mine[..., 1][mask], cycles[..., 1][mask])


@pytest.mark.parametrize("kind", KINDS)
def test_each_names_coverage_over_the_image_matches_cycles(renders, kind):
    """Summed over the image, each id's coverage (its area in pixels, edges and the alpha sphere's share
    included) is within 1 % of Cycles' (sample positions differ at edges)."""
    def areas(image):
        found = {}
        for rank in range(0, image.shape[-1], 2):
            ids, coverage = image[..., rank].view(np.uint32).ravel(), image[..., rank + 1].ravel()
            for i in np.unique(ids[coverage > 0]):
                found[int(i)] = found.get(int(i), 0.0) + float(coverage[ids == i].sum())
        return found

    mine, cycles = areas(ranks(renders["PRIMER"][0], kind)), areas(ranks(renders["CYCLES"][0], kind))
    assert set(mine) == set(cycles)
    for i, area in cycles.items():
        assert abs(mine[i] - area) <= 0.01 * area + 2.0, (kind, hex(i), mine[i], area)


@pytest.mark.parametrize("kind", KINDS)
def test_the_manifest_names_every_id_as_cycles_does(renders, kind):
    (mine_passes, mine_meta), (_, cycles_meta) = renders["PRIMER"], renders["CYCLES"]
    layer = f"ViewLayer.Crypto{kind}"
    keys = {value: key.rsplit("/", 1)[0] for key, value in cycles_meta.items() if key.endswith("/name")}
    prefix = keys[layer]
    for field in ("name", "hash", "conversion"):
        assert mine_meta[f"{prefix}/{field}"] == cycles_meta[f"{prefix}/{field}"], field
    manifest, theirs = json.loads(mine_meta[f"{prefix}/manifest"]), json.loads(cycles_meta[f"{prefix}/manifest"])
    ids = ranks(mine_passes, kind)
    seen = {int(i) for i in np.unique(ids[..., 0::2].view(np.uint32)[ids[..., 1::2] > 0])}
    assert seen <= {int(h, 16) for h in manifest.values()}    # every id in the image has a name
    for name, value in manifest.items():
        if name in theirs:
            assert theirs[name] == value, name


def test_the_compositor_cryptomatte_node_cuts_the_same_matte_from_primer_as_from_cycles(primer, tmp_path):
    """A Cryptomatte node picking "Sphere 2" from the render gives the same matte for both engines."""
    scene = open_scene()
    from addon.compositor import compositor_tree
    tree = compositor_tree(scene, create=True)
    layers = next(node for node in tree.nodes if node.bl_idname == "CompositorNodeRLayers")
    matte = tree.nodes.new("CompositorNodeCryptomatteV2")
    matte.source = "RENDER"
    matte.scene = scene
    matte.layer_name = "ViewLayer.CryptoObject"
    matte.matte_id = "Sphere 2"
    output = next(node for node in tree.nodes if node.bl_idname in ("NodeGroupOutput", "CompositorNodeComposite"))
    tree.links.new(layers.outputs["Image"], matte.inputs["Image"])
    tree.links.new(matte.outputs["Matte"], output.inputs[0])
    scene.render.use_compositing = True
    mattes = {}
    for engine in ("PRIMER", "CYCLES"):
        scene.render.engine = engine
        if engine == "CYCLES":
            configure_cycles_reference(scene, SAMPLES)
        mattes[engine] = render_image(scene, str(tmp_path / f"matte_{engine}.exr"))
    mine, cycles = (mattes[e][..., 0] for e in ("PRIMER", "CYCLES"))
    assert 0.02 < (cycles > 0.5).mean() < 0.5                # the sphere, not nothing and not everything
    assert np.abs(mine - cycles).mean() < 0.01
    assert ((mine > 0.5) != (cycles > 0.5)).mean() < 0.01
