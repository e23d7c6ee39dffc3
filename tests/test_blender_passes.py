"""Cycles' first-hit passes written by Primer inside real Blender (the bpy module), against Cycles' own passes
of the same sample scenes: names, channels and values. No mocks.

Both renders take 16 samples with a 1-pixel box filter (tools/render.py configure_cycles_reference), but at
different positions inside each pixel: where a pixel covers an edge, its values differ. The comparisons
therefore use the pixels "inside" an object: the same Object Index as all 8 neighbours, in both renders.
"""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import configure_cycles_reference, configure_output, load_primer  # noqa: E402

from test_blender_denoise import read_channels  # noqa: E402

pytestmark = pytest.mark.blender

TOGGLES = ("position", "uv", "object_index", "material_index", "diffuse_color", "glossy_color",
           "transmission_color", "emit", "environment", "ambient_occlusion", "z", "normal", "mist")
SAMPLES = 16


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def render_both(name: str, folder, percentage: int = 50) -> tuple:
    """Render sample scene `name` with every first-hit pass on, objects and materials numbered (Pass Index
    1, 2, ... and 10, 11, ...), with Primer and with Cycles: two dicts pass -> (channels, (H, W, c) float32).
    In light_emissive the green Principled cylinder also glows (Emission Strength 2), as the ceiling lamp is
    seen edge-on."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", name + ".blend"))
    scene = bpy.context.scene
    layer = scene.view_layers[0]
    for toggle in TOGGLES:
        setattr(layer, "use_pass_" + toggle, True)
    for i, obj in enumerate(scene.objects):
        obj.pass_index = i + 1
    for i, material in enumerate(bpy.data.materials):
        material.pass_index = 10 + i
    if name == "light_emissive":
        principled = bpy.data.materials["Green"].node_tree.nodes["Principled BSDF"]
        principled.inputs["Emission Strength"].default_value = 2.0
    if scene.world is not None:                 # (the Mist pass over the scenes' depths, 4 to 12 from the camera)
        scene.world.mist_settings.start, scene.world.mist_settings.depth = 3.0, 10.0
        scene.world.mist_settings.falloff = "LINEAR"
    scene.render.resolution_percentage = percentage
    return render_passes_both(scene, folder, name)


def render_passes_both(scene, folder, stem: str) -> tuple:
    """`scene` rendered at SAMPLES samples (no adaptive sampling) by Primer and by Cycles into multilayer EXRs
    `stem`_ENGINE.exr in `folder`: two dicts pass -> (channels, (H, W, c) float32)."""
    scene.primer.samples = SAMPLES
    scene.primer.use_adaptive_sampling = False
    out = []
    for engine in ("PRIMER", "CYCLES"):
        scene.render.engine = engine
        if engine == "CYCLES":
            configure_cycles_reference(scene, SAMPLES)
        path = str(folder / f"{stem}_{engine}.exr")
        scene.render.image_settings.media_type = "IMAGE"
        configure_output(scene, path)
        scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
        bpy.ops.render.render(write_still=True)
        out.append(read_channels(path))
    return tuple(out)


@pytest.fixture(scope="module")
def renders(primer, tmp_path_factory):
    """Primer's and Cycles' passes of three sample scenes: name -> (primer, cycles)."""
    folder = tmp_path_factory.mktemp("passes")
    return {name: render_both(name, folder) for name in ("materials_principled", "materials_glass", "light_emissive",
                                                         "materials_textures")}


def inside(primer_passes: dict, cycles_passes: dict) -> np.ndarray:
    """Return the pixels whose Object Index equals all 8 neighbours' in both renders, and each other's: (H, W) bool."""
    a, b = primer_passes["Object Index"][1][..., 0], cycles_passes["Object Index"][1][..., 0]
    mask = a == b
    for image in (a, b):
        padded = np.pad(image, 1, mode="edge")
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                mask &= padded[1 + dy:1 + dy + image.shape[0], 1 + dx:1 + dx + image.shape[1]] == image
    return mask


SCENES = ("materials_principled", "materials_glass", "light_emissive")
CYCLES_NAMES = {"Position": ["X", "Y", "Z"], "UV": ["A", "U", "V"], "Object Index": ["X"], "Material Index": ["X"],
                "Diffuse Color": ["R", "G", "B"], "Glossy Color": ["R", "G", "B"], "Transmission Color": ["R", "G", "B"],
                "Emission": ["R", "G", "B"], "Environment": ["R", "G", "B"], "Ambient Occlusion": ["R", "G", "B"],
                "Mist": ["Z"]}


def test_primer_writes_each_pass_under_the_name_and_channels_cycles_writes(renders):
    mine, cycles = renders["materials_principled"]
    for name in CYCLES_NAMES:
        assert name in cycles and name in mine, name
        assert mine[name][0] == cycles[name][0], (name, mine[name][0], cycles[name][0])
        assert mine[name][1].shape == cycles[name][1].shape, name


@pytest.mark.parametrize("scene", SCENES)
def test_object_and_material_index_equal_cycles_inside_objects_and_almost_everywhere(renders, scene):
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    assert mask.mean() > 0.6, mask.mean()
    for name in ("Object Index", "Material Index"):
        a, b = mine[name][1][..., 0], cycles[name][1][..., 0]
        assert len(np.unique(b[mask])) >= 3, name                    # the scene shows several objects
        assert np.array_equal(a[mask], b[mask]), name
        assert (a == b).mean() > 0.95, (name, (a == b).mean())       # sample 0 differs at edges only


@pytest.mark.parametrize("scene", SCENES)
def test_position_is_within_a_pixel_footprint_of_cycles_inside_objects(renders, scene):
    """Both take sample 0's hit point, at different places in the pixel: the distance is measured in pixel
    footprints (the distance between neighbouring pixels' positions in Cycles' pass)."""
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    a, b = mine["Position"][1], cycles["Position"][1]
    footprint = np.zeros(b.shape[:2])
    step_x = np.linalg.norm(np.diff(b, axis=1), axis=-1)
    step_y = np.linalg.norm(np.diff(b, axis=0), axis=-1)
    footprint[:, :-1] = step_x
    footprint[:, 1:] = np.maximum(footprint[:, 1:], step_x)
    footprint[:-1] = np.maximum(footprint[:-1], step_y)
    footprint[1:] = np.maximum(footprint[1:], step_y)
    ratio = np.linalg.norm(a - b, axis=-1)[mask] / np.maximum(footprint[mask], 1e-9)
    assert np.median(ratio) < 0.6, np.median(ratio)
    assert np.percentile(ratio, 99) < 1.5, np.percentile(ratio, 99)


@pytest.mark.parametrize("scene", SCENES)
def test_uv_matches_cycles_inside_objects(renders, scene):
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    a, b = mine["UV"][1], cycles["UV"][1]          # channels A, U, V (the EXR's order)
    assert np.array_equal(a[mask][:, 0], b[mask][:, 0])                     # A: 1 wherever every sample hit
    error = np.abs(a[mask][:, 1:] - b[mask][:, 1:]).max(axis=1)     # larger only where a UV seam crosses a pixel
    assert np.median(error) < 0.002 and np.percentile(error, 99) < 0.02, (np.median(error), np.percentile(error, 99))
    assert np.abs(a[..., 1:].mean() - b[..., 1:].mean()) < 0.003


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("name", ["Diffuse Color", "Glossy Color", "Transmission Color"])
def test_colour_passes_match_cycles_inside_objects(renders, scene, name):
    """Diffuse, glossy and transmission colours (weights x albedo): the mean inside objects within 3% of Cycles'
    (Primer's microfacet albedo is its Fresnel reflectance at the view angle, Cycles' a roughness average),
    and 90% of those pixels within 0.02 of Cycles'."""
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    a, b = mine[name][1][mask], cycles[name][1][mask]
    scale = max(float(b.mean()), 1e-3)
    assert abs(float(a.mean()) - float(b.mean())) < 0.03 * scale + 1e-4, (a.mean(0), b.mean(0))
    assert (np.abs(a - b).max(axis=1) < 0.02).mean() > 0.9, (np.abs(a - b).max(axis=1) < 0.02).mean()


@pytest.mark.parametrize("scene", SCENES)
def test_emission_and_environment_match_cycles(renders, scene):
    """Emission inside objects (the ceiling lamp of light_emissive) and the world where every sample missed."""
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    for name in ("Emission", "Environment"):
        a, b = mine[name][1], cycles[name][1]
        same = (np.abs(a[mask] - b[mask]).max(axis=1) <= 1e-3 * max(1.0, float(b.max()))).mean()
        assert same > 0.99, (name, same)            # not all: a lamp seen edge-on can cover a pixel's corner
    missed = (mine["UV"][1][..., 0] == 0) & (cycles["UV"][1][..., 0] == 0)
    if scene != "light_emissive":
        assert missed.mean() > 0.05
        a, b = mine["Environment"][1][missed], cycles["Environment"][1][missed]
        assert np.allclose(a, b, rtol=1e-3, atol=1e-5), np.abs(a - b).max()
        assert b.max() > 0.0
    else:
        a, b = mine["Emission"][1], cycles["Emission"][1]
        glowing = mask & np.all(np.abs(b - 2.0) < 1e-3, axis=-1)          # the green cylinder: 2 x white
        assert glowing.sum() > 20
        assert np.allclose(a[glowing], 2.0, atol=1e-3)
        assert abs(a.mean() - b.mean()) < 0.03 * b.mean(), (a.mean(), b.mean())


@pytest.mark.parametrize("scene", SCENES)
def test_ambient_occlusion_mean_matches_cycles(renders, scene):
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    a, b = mine["Ambient Occlusion"][1][mask], cycles["Ambient Occlusion"][1][mask]
    assert 0.1 < b.mean() < 0.95
    assert abs(a.mean() - b.mean()) < 0.01, (a.mean(), b.mean())


def test_passes_not_asked_for_are_neither_registered_nor_computed(primer, tmp_path):
    """With every first-hit toggle off the render holds no such pass, and the core computed none."""
    engine = sys.modules[primer.__name__ + ".addon.engine"]
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", "materials_principled.blend"))
    scene = bpy.context.scene
    for toggle in TOGGLES:
        setattr(scene.view_layers[0], "use_pass_" + toggle, False)
    scene.render.resolution_percentage = 10
    scene.primer.samples = 2
    path = str(tmp_path / "none.exr")
    scene.render.image_settings.media_type = "IMAGE"
    configure_output(scene, path)
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    bpy.ops.render.render(write_still=True)
    assert not set(read_channels(path)) & set(CYCLES_NAMES)
    assert engine.last_render.stats.first_hit == ()


@pytest.mark.parametrize("scene", SCENES + ("materials_textures",))
def test_depth_and_normal_equal_cycles_inside_objects_normal_maps_included(renders, scene):
    """Depth: the distance along the camera's axis at sample 0's point, as Cycles (each engine's sample 0 lies
    elsewhere in the pixel: inside objects 95 % of pixels within the depth's change to the next pixel in Cycles'
    image, the median within 1 %); Normal: the closures' normals (a normal map's, on materials_textures' bumpy
    sphere) averaged as Cycles does, within 2 degrees; inside the background (no object in the pixel or its
    neighbours) 1e10 and 0 in both."""
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    background = mask & (cycles["Object Index"][1][..., 0] == 0)
    objects = mask & ~background
    a, b = mine["Depth"][1][..., 0], cycles["Depth"][1][..., 0]
    padded = np.pad(b, 1, mode="edge")
    step = np.max([np.abs(padded[1 + dy:1 + dy + b.shape[0], 1 + dx:1 + dx + b.shape[1]] - b)
                   for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    assert (np.abs(a - b)[objects] <= step[objects] + 1e-6 * b[objects]).mean() > 0.95
    assert np.median(np.abs(a[objects] - b[objects]) / b[objects]) < 1e-2
    assert background.any() and np.all(a[background] == 1e10) and np.all(b[background] == 1e10)
    N, M = mine["Normal"][1][objects], cycles["Normal"][1][objects]
    cosine = np.einsum("ij,ij->i", N, M) / (np.linalg.norm(N, axis=-1) * np.linalg.norm(M, axis=-1))
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    assert np.median(angle) < 1.0 and np.percentile(angle, 90) < 2.0, (np.median(angle), np.percentile(angle, 90))
    assert np.all(mine["Normal"][1][background] == 0.0) and np.all(cycles["Normal"][1][background] == 0.0)


@pytest.mark.parametrize("scene", SCENES)
def test_mist_matches_cycles_inside_objects_and_is_one_in_the_background(renders, scene):
    """The Mist pass with the worlds' Mist Pass set to Start 3, Depth 10, Linear:
    inside objects, each pixel's mean over its 16 samples within 0.02 of Cycles' in 95 % of the pixels and the mean
    within 1 %; 1 where a pixel and its neighbours see no object, in both."""
    mine, cycles = renders[scene]
    mask = inside(mine, cycles)
    background = mask & (cycles["Object Index"][1][..., 0] == 0)
    objects = mask & ~background
    a, b = mine["Mist"][1][..., 0], cycles["Mist"][1][..., 0]
    print(scene, float(np.abs(a - b)[objects].mean()), float(a[objects].mean()), float(b[objects].mean()))
    assert b[objects].std() > 0.01                                   # the mist varies over the scene
    assert (np.abs(a - b)[objects] < 0.02).mean() > 0.95
    assert a[objects].mean() == pytest.approx(b[objects].mean(), rel=0.01)
    assert background.any() and np.allclose(a[background], 1.0) and np.allclose(b[background], 1.0)


def test_shader_aovs_match_cycles_inside_objects(primer, tmp_path):
    """Shader AOVs (issue 33): every material of materials_principled gets an AOV Output of its UV into a Color AOV
    and, inside a node group, one of 0.5 into a Value AOV. Primer writes both passes under the AOVs' names with Cycles'
    channels; inside objects with a material the Value AOV is 0.5 in both, the Color AOV's alpha 1 and its colour the
    UV's mean within the UV pass's tolerance (the samples sit at other places in each pixel). The world's AOV Output
    nodes write where camera rays escape: 0.25 into the Value AOV and the ray's direction (its Generated coordinate)
    into the Color AOV, alpha 1, in both (the direction within a pixel's spread)."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", "materials_principled.blend"))
    scene = bpy.context.scene
    layer = scene.view_layers[0]
    layer.use_pass_object_index = True
    for i, obj in enumerate(scene.objects):
        obj.pass_index = i + 1
    aov = layer.aovs.add()
    aov.name, aov.type = "AovUV", "COLOR"
    aov = layer.aovs.add()
    aov.name, aov.type = "AovHalf", "VALUE"
    group = bpy.data.node_groups.new("Half", "ShaderNodeTree")     # (the Value AOV's node inside a node group)
    half = group.nodes.new("ShaderNodeOutputAOV")
    half.aov_name = "AovHalf"
    half.inputs["Value"].default_value = 0.5
    for material in bpy.data.materials:
        tree = material.node_tree
        if tree is None:
            continue
        uv = tree.nodes.new("ShaderNodeOutputAOV")
        uv.aov_name = "AovUV"
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], uv.inputs["Color"])
        tree.nodes.new("ShaderNodeGroup").node_tree = group
    world = scene.world.node_tree                  # (the world's AOV Outputs: where camera rays escape)
    quarter = world.nodes.new("ShaderNodeOutputAOV")
    quarter.aov_name, quarter.inputs["Value"].default_value = "AovHalf", 0.25
    direction = world.nodes.new("ShaderNodeOutputAOV")
    direction.aov_name = "AovUV"
    world.links.new(world.nodes.new("ShaderNodeTexCoord").outputs["Generated"], direction.inputs["Color"])
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 96, 72, 100
    mine, cycles = render_passes_both(scene, tmp_path, "aov")
    for name in ("AovUV", "AovHalf"):
        assert mine[name][0] == cycles[name][0] and mine[name][1].shape == cycles[name][1].shape, name
    mask = inside(mine, cycles)
    index = cycles["Object Index"][1][..., 0]
    empty = mask & (index == 0)
    shaded = [obj.pass_index for obj in scene.objects if any(slot.material for slot in obj.material_slots)]
    objects = mask & np.isin(index, shaded)         # (an object without a material: the default surface, no AOV)
    assert objects.mean() > 0.3, objects.mean()
    channels = mine["AovUV"][0]
    a, b = (dict(zip(channels, np.moveaxis(passes["AovUV"][1], -1, 0))) for passes in (mine, cycles))
    np.testing.assert_array_equal(a["A"][objects], 1.0)
    np.testing.assert_array_equal(b["A"][objects], 1.0)
    error = np.maximum(np.abs(a["R"] - b["R"]), np.abs(a["G"] - b["G"]))[objects]
    assert np.median(error) < 0.002 and np.percentile(error, 99) < 0.02, (np.median(error), np.percentile(error, 99))
    np.testing.assert_allclose(mine["AovHalf"][1][objects], 0.5, atol=1e-6)
    np.testing.assert_allclose(cycles["AovHalf"][1][objects], 0.5, atol=1e-6)
    assert empty.mean() > 0.05, empty.mean()
    for passes in (mine, cycles):
        np.testing.assert_allclose(passes["AovHalf"][1][empty], 0.25, atol=1e-6)
    np.testing.assert_array_equal(a["A"][empty], 1.0)
    np.testing.assert_array_equal(b["A"][empty], 1.0)
    error = np.max([np.abs(a[c] - b[c])[empty] for c in "RGB"], axis=0)
    print("world direction AOV", float(np.median(error)), float(error.max()))
    assert error.max() < 0.005, error.max()
