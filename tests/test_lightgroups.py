"""Light groups in core (core/integrators/lightgroups.py; direct.c, path.c, chunk.c), without Blender: each group's
pass is the light of its sources alone, split from the one render as the integrator adds each contribution.

Light is linear in its sources, so a group's pass is the image of the scene in which only the group's sources
emit: exactly so for lamps without extent (no random numbers), and in expectation for the others. Every source
in some group: the passes add up to Combined, sample for sample. (tests/test_blender_lightgroups.py holds the
passes to Cycles' own.)
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import render
from core.camera import Camera
from core.geometry import primitives
from core.lights import PointLight, World
from core.scene import Material, RenderSettings, Scene

KERNELS = ["numpy", "compiled"]


def lit_room(world: bool = True, emitter: bool = True, lamps=("A", "B")) -> Scene:
    """A floor and a glossy back wall under two point lamps A and B, a square emitter E above, a grey world W."""
    scene = Scene(camera=Camera.look_at(np.array([0.0, -3.0, 2.0]), np.array([0.0, 0.0, 0.3]), fov=math.radians(55)))
    floor = scene.add_material((0.7, 0.6, 0.5))
    scene.materials.append(Material(name="Wall", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0),
                                                          {"base_color": (0.3, 0.5, 0.8), "roughness": 0.3,
                                                           "metallic": 0.5})]))
    scene.add_mesh(primitives.plane(6.0), materials=np.array([floor]), name="Floor")
    upright = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 1.5], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]])
    scene.add_mesh(primitives.plane(6.0, 2.0), matrix=upright, materials=np.array([1]), name="Wall")
    if emitter:
        scene.materials.append(Material(np.zeros(3), "Lamp", emission=np.array([4.0, 3.0, 2.0])))
        down = np.diag([1.0, -1.0, -1.0, 1.0])
        down[:3, 3] = (0.8, 0.3, 1.6)
        scene.add_mesh(primitives.plane(0.6), matrix=down, materials=np.array([len(scene.materials) - 1]), name="E")
    positions = {"A": (-1.0, -0.5, 1.5), "B": (1.2, 0.2, 0.8)}
    colors = {"A": (1.0, 0.9, 0.8), "B": (0.4, 0.6, 1.0)}
    scene.lights = [PointLight(np.array(positions[name]), power=150.0, color=np.array(colors[name]), name=name)
                    for name in lamps]
    if world:
        scene.world = World(color=np.array([0.2, 0.25, 0.3]))
    scene.lightgroups = {"lights": list(lamps), "instances": ["", "", "E"][:len(scene.instances)],
                         "world": "W" if world else ""}
    return scene


def settings(kernels: str, integrator: str = "path", **more) -> RenderSettings:
    return RenderSettings(**{"width": 24, "height": 18, "samples": 4, "integrator": integrator, "max_bounces": 2,
                             "kernels": kernels, **more})


def group(result, name: str) -> np.ndarray:
    return result.aux["lightgroup:" + name].astype(np.float64)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path", "whitted"])
def test_the_groups_add_up_to_combined_when_every_source_is_in_one(kernels, integrator):
    """Lamps A and B, emitter E and world W each in a group: per pixel, their passes sum to Combined."""
    if integrator == "whitted" and kernels == "compiled":
        pytest.skip("Whitted's tracer has no compiled twin")
    scene = lit_room()
    result = render.render(scene, settings(kernels, integrator, light_groups=("A", "B", "E", "W")))
    assert result.stats.kernels.startswith(kernels)
    combined = result.image[..., :3].astype(np.float64)
    passes = {name: group(result, name) for name in "ABEW"}
    for name, image in passes.items():                          # every source lights something (but a constant
        assert image.max() > 0.0 or (integrator, name) == ("whitted", "W"), name    # world, for Whitted's samples)
    np.testing.assert_allclose(sum(passes.values()), combined, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_point_lamps_group_is_the_room_lit_by_that_lamp_alone(kernels):
    """Lamp A has no extent: its light samples use no random numbers, so its group's pass in the full room equals,
    pixel for pixel, the direct light of the room with A as its only source."""
    result = render.render(lit_room(), settings(kernels, "direct", light_groups=("A",)))
    alone = render.render(lit_room(world=False, emitter=False, lamps=("A",)), settings(kernels, "direct"))
    np.testing.assert_allclose(group(result, "A"), alone.image[..., :3], rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_group_of_an_emitter_and_the_world_converges_to_their_light_alone(kernels):
    """Path traced, two bounces: the group of E and W in the full room against the room lit by E and W alone (the
    lamps gone): the same image in expectation (block means within the two renders' noise)."""
    s = settings(kernels, samples=64, light_groups=("EW",))
    scene = lit_room()
    scene.lightgroups["instances"][2] = "EW"
    scene.lightgroups["world"] = "EW"
    mine = group(render.render(scene, s), "EW")
    alone = render.render(lit_room(lamps=()), dataclasses.replace(s, light_groups=(), seed=7)).image[..., :3]
    blocks = lambda image: image.reshape(6, 3, 8, 3, 3).mean(axis=(1, 3))     # 3 x 3 pixel blocks
    assert alone.mean() > 0.05
    assert mine.mean() == pytest.approx(alone.mean(), rel=0.03)
    np.testing.assert_allclose(blocks(mine), blocks(alone), rtol=0.15, atol=0.01)


@pytest.mark.parametrize("kernels", KERNELS)
def test_sources_in_no_group_are_in_no_pass_and_an_empty_group_is_black(kernels):
    """Only A and B in groups: their passes add up to Combined less the light of E and W; the group of nothing
    stays 0."""
    scene = lit_room()
    scene.lightgroups = {"lights": ["A", "B"], "instances": ["", "", ""], "world": ""}
    s = settings(kernels, "direct", light_groups=("A", "B", "nothing"))
    result = render.render(scene, s)
    assert not group(result, "nothing").any()
    lamps = render.render(lit_room(world=False, emitter=False), dataclasses.replace(s, light_groups=()))
    np.testing.assert_allclose(group(result, "A") + group(result, "B"), lamps.image[..., :3], rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("kernels", KERNELS)
def test_asking_for_light_groups_leaves_combined_as_it_was_bit_for_bit(kernels):
    scene = lit_room()
    plain = render.render(scene, settings(kernels))
    grouped = render.render(scene, settings(kernels, light_groups=("A", "E", "W")))
    np.testing.assert_array_equal(plain.image, grouped.image)


def test_the_compiled_groups_follow_the_reference():
    """Both kernels, the same samples: each group's pass agrees (the kernels' usual tolerance for Combined)."""
    scene = lit_room()
    s = settings("numpy", samples=8, light_groups=("A", "B", "E", "W"))
    numpy_ = render.render(scene, s)
    compiled = render.render(scene, dataclasses.replace(s, kernels="compiled"))
    for name in "ABEW":
        a, b = group(numpy_, name), group(compiled, name)
        assert abs(a.mean() - b.mean()) <= 0.02 * a.mean() + 1e-6, name


# Media (core/integrators/volume.py, volume.c): the light a medium scatters goes to the group of the light it
# scatters, as at a surface; the light media emit goes to the group of the object whose medium the ray is in (Cycles'
# film_write_volume_emission: object_lightgroup of the last entry of the ray's volume stack), else the world's.

def volume_only(name: str, closure: str, **inputs) -> Material:
    """A volume-only material (a Transparent surface, rays pass it) of one volume closure."""
    return Material(np.zeros(3), name, nodes=[("TRANSPARENT", np.ones(3), {})], volume=[(closure, 1.0, inputs)],
                    volume_only=True)


def foggy_room(power=(150.0, 150.0), strength: float = 0.8) -> Scene:
    """The lit room (lamps A, B; no emitter, no world) with a box of scattering fog over the floor, in no group, and
    beside it a box of glowing medium (Volume Emission) in group F; each lamp's power and the glow's strength."""
    scene = lit_room(world=False, emitter=False)
    for light, watts in zip(scene.lights, power):
        light.power = watts
    scene.materials.append(volume_only("Fog", "SCATTER", color=np.array([0.8, 0.7, 0.6]), density=0.6))
    scene.add_mesh(primitives.box((2.4, 1.6, 1.2), center=(0.0, 0.2, 0.6)), materials=np.array([2]), name="Fog")
    scene.materials.append(volume_only("Glow", "EMISSION", color=np.array([1.0, 0.5, 0.2]), strength=strength))
    scene.add_mesh(primitives.box((0.5, 0.5, 0.5), center=(-0.6, -1.2, 0.5)), materials=np.array([3]), name="Glow")
    scene.lightgroups["instances"] = ["", "", "", "F"]
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("volume_bounces", [0, 2])
def test_in_fog_the_groups_add_up_to_combined_and_each_is_the_room_lit_by_its_source_alone(kernels, volume_bounces):
    """Fog lit by point lamps A and B, a glowing medium F: per pixel the three passes sum to Combined, and each is
    the image of the room with only its source on (the other lamps at 1 nW, which keeps each lamp's index and so its
    random numbers: equal to rounding), single scattering and with Volume Bounces."""
    s = settings(kernels, volume_bounces=volume_bounces)
    result = render.render(foggy_room(), dataclasses.replace(s, light_groups=("A", "B", "F")))
    assert result.stats.kernels.startswith(kernels)
    assert not any("light group" in note for note in result.stats.warnings)
    combined = result.image[..., :3].astype(np.float64)
    np.testing.assert_allclose(sum(group(result, name) for name in "ABF"), combined, rtol=1e-5, atol=1e-6)
    off = 1e-9
    alone = {"A": foggy_room(power=(150.0, off), strength=0.0), "B": foggy_room(power=(off, 150.0), strength=0.0),
             "F": foggy_room(power=(off, off))}
    for name, scene in alone.items():
        image = render.render(scene, s).image[..., :3]
        assert image.mean() > 0.01, name
        np.testing.assert_allclose(group(result, name), image, rtol=1e-4, atol=1e-6, err_msg=name)


def test_in_fog_the_compiled_groups_follow_the_reference():
    """The fog's groups, both kernels, the same samples (with Volume Bounces): pixel for pixel to rounding."""
    s = settings("numpy", volume_bounces=2, light_groups=("A", "B", "F"))
    numpy_ = render.render(foggy_room(), s)
    compiled = render.render(foggy_room(), dataclasses.replace(s, kernels="compiled"))
    assert compiled.stats.kernels.startswith("compiled")
    for name in "ABF":
        np.testing.assert_allclose(group(compiled, name), group(numpy_, name), rtol=1e-4, atol=1e-6, err_msg=name)


def black_floor_seen_from_above(width: float) -> Scene:
    """A black floor at z = 0 (material 0) under an orthographic camera 3 above it, looking straight down at a square
    `width` wide."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=width, clip_start=0.1, clip_end=20.0))
    scene.materials.append(Material(np.zeros(3), "Black"))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]), name="Floor")
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_medium_emits_into_its_objects_group_and_the_world_medium_into_the_worlds(kernels):
    """Looking straight down on a black floor through a 1 m tall volume-only box F (a medium of nothing but itself)
    under a world medium that emits e per metre: the box's group holds e x 1 m, the world's emission inside it
    (Cycles gives a stretch's emission to the last object of its volume stack), and the world's group the rest of
    the ray's e x length: together Combined."""
    from core.lights import World
    e = np.array([0.3, 0.2, 0.1])
    scene = black_floor_seen_from_above(1.0)
    scene.materials.append(volume_only("Box", "ABSORPTION", density=0.0))
    scene.add_mesh(primitives.box((4.0, 4.0, 1.0), center=(0.0, 0.0, 1.0)), materials=np.array([1]), name="Box")
    scene.world = World(color=np.zeros(3), volume=[("EMISSION", 1.0, {"color": e, "strength": 1.0})])
    scene.lightgroups = {"lights": [], "instances": ["", "F"], "world": "W"}
    result = render.render(scene, RenderSettings(width=4, height=4, samples=1, integrator="path", kernels=kernels,
                                                 light_groups=("F", "W")))
    assert result.stats.kernels.startswith(kernels)
    np.testing.assert_allclose(group(result, "F"), np.broadcast_to(e, (4, 4, 3)), rtol=1e-5)
    np.testing.assert_allclose(group(result, "F") + group(result, "W"), result.image[..., :3], rtol=1e-5, atol=1e-7)
    assert (group(result, "W") > group(result, "F")).all()      # (the ray's other ~1.9 m)


def test_overlapping_media_of_different_groups_emit_alike_in_both_kernels_with_nothing_to_say():
    """The glow inside the fog (a ray may be in both media): the stretch's emission goes to the group of the medium
    entered last (Cycles: the last entry of the volume stack), with nothing to say. The passes sum to Combined (the
    glow's light found behind the fog's transparent walls weighed as Combined weighs it: through_transparent) and
    the compiled kernel's groups are the reference's, pixel for pixel."""
    scene = foggy_room()
    scene.instances[-1].matrix = np.eye(4)
    scene.instances[-1].matrix[:3, 3] = (0.0, 1.2, 0.0)          # (the glow's box moved to y = 0, into the fog)
    s = settings("numpy", width=12, height=9, samples=2, light_groups=("A", "B", "F"))
    numpy_ = render.render(scene, s)
    compiled = render.render(scene, dataclasses.replace(s, kernels="compiled"))
    assert compiled.stats.kernels.startswith("compiled")
    for result in (numpy_, compiled):
        assert not any("light group" in note for note in result.stats.warnings), result.stats.warnings
        np.testing.assert_allclose(sum(group(result, name) for name in "ABF"), result.image[..., :3], rtol=1e-5,
                                   atol=1e-6)
    for name in "ABF":
        np.testing.assert_allclose(group(compiled, name), group(numpy_, name), rtol=1e-4, atol=1e-6, err_msg=name)


def glowing_boxes(boxes, e=np.array([0.4, 0.2, 0.1])) -> Scene:
    """A black floor seen straight down over x, y in [-1, 1] under volume-only boxes [(name, size (3,), centre (3,),
    material row, light group)], the materials 1, 2 emitting e and 2 e per metre (nothing else)."""
    scene = black_floor_seen_from_above(2.0)
    scene.materials.append(volume_only("Glow", "EMISSION", color=e, strength=1.0))
    scene.materials.append(volume_only("Brighter", "EMISSION", color=e, strength=2.0))
    scene.lightgroups = {"lights": [], "instances": [""], "world": ""}
    for name, size, center, row, light_group in boxes:
        scene.add_mesh(primitives.box(size, center=center), materials=np.array([row]), name=name)
        scene.lightgroups["instances"].append(light_group)
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_one_emitting_medium_on_objects_of_two_groups_gives_each_group_its_own_boxs_light_alone(kernels):
    """One homogeneous emitting material (e per metre, its graph reading no Object Info) on two boxes side by side,
    1 m tall, in groups F (left) and G (right): F's pass is e on the left and 0 on the right, G's the mirror, each
    equal to the render of its box alone, as Cycles' volume stack holds (object, shader) pairs and gives each
    object's stretch to object_lightgroup of its object (Primer used to give both to F and say so). The medium is
    kept per group only where the groups differ: one column where both boxes are in F, or where it emits nothing."""
    from core.render import prepare
    e = np.array([0.4, 0.2, 0.1])
    left = ("Left", (2.0, 4.0, 1.0), (-1.0, 0.0, 1.0), 1, "F")
    right = ("Right", (2.0, 4.0, 1.0), (1.0, 0.0, 1.0), 1, "G")
    s = RenderSettings(width=4, height=2, samples=1, integrator="path", kernels=kernels, light_groups=("F", "G"))
    result = render.render(glowing_boxes([left, right], e), s)
    assert result.stats.kernels.startswith(kernels)
    assert not any("light group" in note for note in result.stats.warnings), result.stats.warnings
    west, east = np.s_[:, :2], np.s_[:, 2:]
    np.testing.assert_allclose(group(result, "F")[west], np.broadcast_to(e, (2, 2, 3)), rtol=1e-6)
    np.testing.assert_allclose(group(result, "G")[east], np.broadcast_to(e, (2, 2, 3)), rtol=1e-6)
    assert group(result, "F")[east].max() == 0.0 and group(result, "G")[west].max() == 0.0
    for name, alone in (("F", left), ("G", right)):
        np.testing.assert_allclose(group(result, name), group(render.render(glowing_boxes([alone], e), s), name),
                                   rtol=1e-12, atol=0.0, err_msg=name)
    np.testing.assert_allclose(group(result, "F") + group(result, "G"), result.image[..., :3], rtol=1e-6)
    columns = lambda scene: int((prepare(scene, s).extra["media"].rows == 1).sum())   # noqa: E731 (Glow's)
    assert columns(glowing_boxes([left, right], e)) == 2
    assert columns(glowing_boxes([left, right[:4] + ("F",)], e)) == 1                 # (one group: one medium)
    assert columns(glowing_boxes([left, right], 0.0 * e)) == 1                        # (nothing emitted)


@pytest.mark.parametrize("kernels", KERNELS)
def test_overlapping_media_emit_into_the_group_of_the_one_the_ray_entered_last(kernels):
    """Seen straight down: an outer box F (z 0 .. 2, emitting e per metre, material 1) and inside it an inner box G
    (z 0.5 .. 1.5, 2 e, material 2), both media holding nothing else. Cycles gives a stretch's emission to the group
    of its volume stack's last entry, the medium entered last: F gets e x 0.5 above G and e x 0.5 below it (G left,
    F is last again), G the overlap's (e + 2 e) x 1; together Combined's e x 2 + 2 e x 1. With the outer box of the
    later material (the order Primer listed media in) the groups are the same."""
    e = np.array([0.4, 0.2, 0.1])
    s = RenderSettings(width=4, height=2, samples=1, integrator="path", kernels=kernels, light_groups=("F", "G"))
    for outer, inner in ((1, 2), (2, 1)):
        scene = glowing_boxes([("Outer", (4.0, 4.0, 2.0), (0.0, 0.0, 1.0), outer, "F"),
                               ("Inner", (4.0, 4.0, 1.0), (0.0, 0.0, 1.0), inner, "G")], e)
        result = render.render(scene, s)
        assert result.stats.kernels.startswith(kernels)
        assert not any("light group" in note for note in result.stats.warnings), result.stats.warnings
        e_outer, e_inner = e * outer, e * inner
        np.testing.assert_allclose(group(result, "F"), np.broadcast_to(e_outer, (2, 4, 3)), rtol=1e-5)
        np.testing.assert_allclose(group(result, "G"), np.broadcast_to(e_outer + e_inner, (2, 4, 3)), rtol=1e-5)
        np.testing.assert_allclose(result.image[..., :3], np.broadcast_to(2.0 * e_outer + e_inner, (2, 4, 3)),
                                   rtol=1e-5)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_medium_kept_per_object_emits_into_each_objects_own_group(kernels):
    """Two boxes side by side, 1 m tall, sharing a medium that emits e x Object Info's Random per metre (so it is kept
    per object, core/volumes/media.py per_object), in groups F (left, Random 0.25) and G (right, 0.75), seen
    straight down over a black floor: F holds 0.25 e on the left and nothing on the right, G 0.75 e on the right and
    nothing on the left, as Cycles gives each object's stretch to its own group."""
    from core.materials.graph import GraphNode, Link
    e = np.array([0.4, 0.2, 0.1])
    scene = black_floor_seen_from_above(2.0)
    random = Link(GraphNode("OBJECT_INFO", {"material_index": 0.0}), "Random")
    scene.materials.append(volume_only("Glow", "EMISSION", color=e, strength=random))
    for name, value, x in (("Left", 0.25, -1.0), ("Right", 0.75, 1.0)):
        scene.add_mesh(primitives.box((2.0, 4.0, 1.0), center=(x, 0.0, 1.0)), materials=np.array([1]), name=name)
        scene.instances[-1].random = value
    scene.lightgroups = {"lights": [], "instances": ["", "F", "G"], "world": ""}
    result = render.render(scene, RenderSettings(width=4, height=2, samples=1, integrator="path", kernels=kernels,
                                                 light_groups=("F", "G")))
    assert result.stats.kernels.startswith(kernels)
    left, right = np.s_[:, :2], np.s_[:, 2:]
    np.testing.assert_allclose(group(result, "F")[left], np.broadcast_to(0.25 * e, (2, 2, 3)), rtol=1e-5)
    np.testing.assert_allclose(group(result, "G")[right], np.broadcast_to(0.75 * e, (2, 2, 3)), rtol=1e-5)
    assert group(result, "F")[right].max() == 0.0 and group(result, "G")[left].max() == 0.0
    np.testing.assert_allclose(group(result, "F") + group(result, "G"), result.image[..., :3], rtol=1e-5, atol=1e-7)
    assert not any("different light groups" in note for note in result.stats.warnings)
