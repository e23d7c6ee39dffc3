"""Shader AOVs in core (core/integrators/passes.py, the AOV Output node compiled by core/materials/graph.py), without
Blender: what camera paths write into them on scenes whose answers are known, in both kernels, and that nothing of
them is compiled or run when no AOV is asked for."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.integrators import passes
from core.materials import graph
from core.materials.graph import GraphNode, Link
from core.scene import RenderSettings, Scene
from test_textures import plane_attributes

KERNELS = ["numpy", "compiled"]
UV = Link(GraphNode("TEXCOORD", {}, {}), "UV")


def floor_scene(aovs: list, size: float = 4.0) -> Scene:
    """A `size` square floor (z = 0, UVs 0..1 across it) with a Diffuse material whose AOV Output nodes are `aovs`
    (Material.aovs), under a camera 3 above it looking straight down (90 degrees: the floor of 4 fills two thirds of
    the frame), the world grey."""
    scene = Scene(camera=Camera.look_at(np.array([0.0, 0.0, 3.0]), np.zeros(3), up=(0.0, 1.0, 0.0),
                                        fov=math.radians(90)),
                  world_color=np.array([0.1, 0.2, 0.3]))
    scene.materials.append(materials.Material(name="floor", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {})], aovs=aovs))
    mesh = primitives.plane(size)
    mesh.attributes = plane_attributes(mesh)
    scene.add_mesh(mesh, materials=np.array([0]))
    return scene


def settings_of(kernels: str, aovs: tuple, **more) -> RenderSettings:
    """Settings of a small render asking for the shader AOVs `aovs` ((name, type) each), `more` overriding."""
    return RenderSettings(**{"width": 24, "height": 24, "samples": 4, "kernels": kernels, "aovs": aovs, **more})


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_color_aov_of_the_uv_coordinate_is_the_uv_pass_in_every_pixel(kernels):
    """A Color AOV fed by the UV coordinate holds, per pixel, the mean over its samples of the UV where they hit the
    floor: the UV pass's (u, v), which is that same mean (both 0 where a sample meets no surface); its alpha channel is
    the share of samples that wrote it, the UV pass's third channel (1 inside the floor, 0 on the world)."""
    scene = floor_scene([("uv", UV, 0.0)])
    result = render.render(scene, settings_of(kernels, (("uv", "COLOR"),), passes=("uv",)))
    assert result.stats.kernels == ("compiled" if kernels == "compiled" else "numpy (kernels set to numpy)")
    aov, uv = result.aux["aov:uv"], result.aux["uv"]
    assert aov.shape == (24, 24, 4)
    np.testing.assert_allclose(aov[..., :2], uv[..., :2], atol=1e-6)
    np.testing.assert_allclose(aov[..., 2], 0.0)
    np.testing.assert_allclose(aov[..., 3], uv[..., 2], atol=1e-6)
    inside, outside = uv[..., 2] == 1.0, uv[..., 2] == 0.0
    assert inside.mean() > 0.3 and outside.mean() > 0.1          # the floor, and the world around it
    assert np.all(aov[outside] == 0.0)                            # no surface: nothing written
    assert 0.0 < aov[inside][:, 0].min() < 0.1 and 0.9 < aov[inside][:, 0].max() < 1.0


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_value_aov_takes_the_value_input_and_an_aov_the_view_layer_lacks_writes_nothing(kernels):
    """Two AOVs in one render: a Value AOV takes the node's Value (0.25; its Color is not read) and a Color AOV its
    Color. A Value AOV fed by the UV (a vector read as a value: the mean of its components, Cycles' vector-to-float
    conversion) is (u + v) / 3 of the UV pass. An AOV Output naming an AOV the view layer lacks ("absent") changes
    nothing, as in Cycles."""
    scene = floor_scene([("v", (1.0, 1.0, 1.0), 0.25), ("c", (0.2, 0.4, 0.8), 0.9), ("mean", (9.0, 9.0, 9.0), UV),
                         ("absent", (5.0, 5.0, 5.0), 5.0)])
    wanted = (("v", "VALUE"), ("c", "COLOR"))
    result = render.render(scene, settings_of(kernels, wanted, passes=("uv",)))
    coverage = result.aux["uv"][..., 2]
    assert result.aux["aov:v"].shape == (24, 24, 1) and "aov:absent" not in result.aux and "aov:mean" not in result.aux
    np.testing.assert_allclose(result.aux["aov:v"][..., 0], 0.25 * coverage, atol=1e-7)
    np.testing.assert_allclose(result.aux["aov:c"], coverage[..., None] * [0.2, 0.4, 0.8, 1.0], atol=1e-7)
    mean = render.render(scene, settings_of(kernels, (("mean", "VALUE"),), passes=("uv",))).aux
    np.testing.assert_allclose(mean["aov:mean"][..., 0], (mean["uv"][..., 0] + mean["uv"][..., 1]) / 3.0, atol=1e-6)
    assert mean["aov:mean"].max() > 0.3


def veiled_scene() -> Scene:
    """floor_scene's floor writing 2 into the Value AOV "v", under a veil 1 above it (a Transparent BSDF 0.6 mixed with
    a Diffuse 0.4: alpha 0.4) that fills the frame and writes 1."""
    scene = floor_scene([("v", (0.0, 0.0, 0.0), 2.0)], size=8.0)
    scene.materials.append(materials.Material(name="veil", nodes=[("TRANSPARENT", (0.6, 0.6, 0.6), {}),
                                                                  ("DIFFUSE", (0.4, 0.4, 0.4), {})],
                                              aovs=[("v", (0.0, 0.0, 0.0), 1.0)]))
    scene.add_mesh(primitives.plane(8.0, center=(0.0, 0.0, 1.0)), materials=np.array([1]), name="Veil")
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_transparent_surface_in_front_adds_its_aov_and_lets_the_one_behind_add_until_the_alpha_threshold(kernels):
    """Cycles writes a camera path's AOVs at every surface it passes straight through until its first at least as
    opaque as the view layer's Alpha Threshold, unweighed by what those let through: a veil of alpha 0.4 under the
    default threshold 0.5 writes 1, and the floor behind it 2 for the share of paths that go on through it (0.6, its
    Transparent closure's share of the sampling): 1 + 0.6 x 2 = 2.2 in the mean. Under a threshold of 0.3 the veil is
    opaque enough: 1 exactly in every pixel."""
    scene = veiled_scene()
    settings = settings_of(kernels, (("v", "VALUE"),), width=16, height=16, samples=16)
    np.testing.assert_allclose(render.render(scene, dataclasses.replace(settings, pass_alpha_threshold=0.3))
                               .aux["aov:v"], 1.0, atol=1e-7)
    value = render.render(scene, settings).aux["aov:v"][..., 0]
    assert set(np.round(value * 16).astype(int).ravel()) <= set(range(16, 16 + 2 * 16 + 1, 2))   # 1 + 2 k / 16
    assert abs(value.mean() - 2.2) < 0.05


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_the_compiled_aovs_follow_the_reference(integrator):
    """The C kernels write the same AOVs from the same samples as the Python reference: a Color AOV of the UV and a
    Value AOV through the veil, with every first-hit pass asked for too."""
    scene = veiled_scene()
    scene.materials[0].aovs.append(("uv", UV, 0.0))
    settings = RenderSettings(width=20, height=16, samples=4, integrator=integrator, max_bounces=2,
                              aovs=(("uv", "COLOR"), ("v", "VALUE")), passes=tuple(passes.PASS_CHANNELS))
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    for name in ("aov:uv", "aov:v"):
        assert np.abs(reference.aux[name]).max() > 0.0
        np.testing.assert_allclose(compiled.aux[name], reference.aux[name], atol=1e-6, err_msg=name)


def test_no_aov_asked_for_compiles_no_aov_ops():
    """Model only what a scene needs: without AOVs asked for, a material's AOV Output nodes compile to nothing (its
    program has no AOV_START op and no AOV output; a material with constant inputs keeps no program at all); with
    one, its ops follow an AOV_START op, after the surface's."""
    scene = floor_scene([("uv", UV, 0.0)])
    table = materials.MaterialTable.of(scene.materials)
    assert table.shaders[0].graph is None and table.program(0, {"uv:": (0, 3)}) is None
    table = materials.MaterialTable.of(scene.materials, aovs=passes.aov_slots((("uv", "COLOR"),)))
    program = table.program(0, {"uv:": (0, 3)})
    codes = [graph.OPS[int(code)] for code in program.ops[:, 0]]
    assert codes[0] == "AOV_START" and "ATTR" in codes[1:]
    assert [int(row[0]) for row in program.outputs] == [graph.OUT_AOV]


def test_the_aovs_past_the_channels_kept_are_left_out_with_a_warning():
    """The film keeps AOV_CHANNELS_MAX AOV channels (a Color AOV takes 4): the AOVs past them are not written, and the
    render says which."""
    many = tuple((f"a{k}", "COLOR") for k in range(passes.AOV_CHANNELS_MAX // 4 + 1))
    assert passes.aovs_left_out(many) == [many[-1][0]]
    assert passes.aov_slots((("x", "VALUE"), ("y", "COLOR"), ("x", "COLOR"))) == {"x": (0, 1), "y": (1, 4)}
    scene = floor_scene([("a0", (0.5, 0.5, 0.5), 0.0)])
    result = render.render(scene, settings_of("numpy", many, width=4, height=4, samples=1))
    assert f"aov:{many[-1][0]}" not in result.aux and "aov:a0" in result.aux
    assert any(many[-1][0] in warning for warning in result.stats.warnings)


def test_an_aov_of_an_unknown_type_is_refused():
    """An AOV type other than Blender's COLOR and VALUE is refused with a clear message."""
    scene = floor_scene([])
    with pytest.raises(ValueError, match="shader AOVs must be"):
        render.render(scene, settings_of("numpy", (("x", "VECTOR"),), width=4, height=4, samples=1))


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_surface_seen_only_in_a_mirror_writes_no_aov(kernels):
    """AOVs are written along camera chains only (Cycles: PATH_RAY_TRANSPARENT_BACKGROUND, cleared at a real bounce): a
    glowing ceiling writing 1, behind the camera and seen only in the mirror floor that fills the frame, leaves the
    AOV 0 in every pixel, though the render shows it."""
    scene = floor_scene([], size=40.0)
    scene.materials[0] = materials.Material(name="mirror", bsdf="MIRROR", base_color=np.ones(3))
    scene.materials.append(materials.Material(name="ceiling", nodes=[("EMISSION", (1.0, 1.0, 1.0),
                                                                      {"emission": (2.0, 2.0, 2.0)})],
                                              aovs=[("v", (0.0, 0.0, 0.0), 1.0)]))
    scene.add_mesh(primitives.plane(40.0, center=(0.0, 0.0, 5.0)), materials=np.array([1]), name="Ceiling")
    result = render.render(scene, settings_of(kernels, (("v", "VALUE"),), width=8, height=8, max_bounces=2))
    assert np.all(result.aux["aov:v"] == 0.0)
    assert result.image[..., :3].mean() > 1.0


GENERATED = Link(GraphNode("TEXCOORD", {}, {}), "Generated")


def world_aov_scene(**world) -> Scene:
    """A camera at the origin looking along (1, 1, 1) (40 degrees: every ray's direction has positive components),
    its world's colour the ray's direction (its Generated coordinate) and its AOV Output nodes a Color AOV "d" of that
    direction and a Value AOV "v" of 0.7 (lighting nothing), and a quad 2 wide (UVs 0..1, a Diffuse writing 0.25 into
    "v") over a quarter of the view; `world` overrides the World's fields."""
    from core.lights import World, world_graph
    towards = np.ones(3) / math.sqrt(3.0)
    scene = Scene(camera=Camera.look_at(np.zeros(3), towards, up=(0.0, 0.0, 1.0), fov=math.radians(40)))
    scene.world = World(**{"lights": False, "seen": world_graph.compile_world(GENERATED, 1.0),
                           "aovs": [("d", GENERATED, 0.0), ("v", (0.0, 0.0, 0.0), 0.7)], **world})
    scene.materials.append(materials.Material(name="quad", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {})],
                                              aovs=[("v", (0.0, 0.0, 0.0), 0.25)]))
    mesh = primitives.plane(2.0)
    mesh.attributes = plane_attributes(mesh)
    side = np.cross(towards, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    matrix = np.eye(4)                   # (the quad faces the camera, 5 away, its corner on the view's centre)
    matrix[:3, :3] = np.stack([side, np.cross(towards, side), -towards], axis=1)
    matrix[:3, 3] = 5.0 * towards + side + np.cross(towards, side)
    scene.add_mesh(mesh, matrix, materials=np.array([0]))
    return scene


WORLD_AOVS = (("d", "COLOR"), ("v", "VALUE"))


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_world_aov_of_the_ray_direction_is_the_environment_pass_where_camera_rays_escape(kernels):
    """Cycles runs the world's AOV Output nodes where a camera path escapes before its opaque-enough surface: a Color
    AOV of the direction (the world's Generated coordinate) is per pixel the mean over samples of the escaping rays'
    directions, which is the Environment pass of a world whose colour is that direction; its alpha the share of
    samples that escaped, 1 - the UV pass's coverage. A Value AOV of 0.7 in the world and 0.25 on the quad is
    0.25 c + 0.7 (1 - c) in every pixel of coverage c (both exact)."""
    result = render.render(world_aov_scene(), settings_of(kernels, WORLD_AOVS, passes=("uv", "environment")))
    d, v, coverage = result.aux["aov:d"], result.aux["aov:v"][..., 0], result.aux["uv"][..., 2]
    np.testing.assert_allclose(d[..., :3], result.aux["environment"], atol=1e-6)
    np.testing.assert_allclose(d[..., 3], 1.0 - coverage, atol=1e-6)
    np.testing.assert_allclose(v, 0.25 * coverage + 0.7 * (1.0 - coverage), atol=1e-6)
    assert (coverage == 1.0).mean() > 0.1 and (coverage == 0.0).mean() > 0.3     # the quad, and the world around
    escaped = d[coverage == 0.0]
    assert np.all(escaped[:, :3] > 0.1) and np.ptp(escaped[:, 0]) > 0.2          # (the direction varies across)


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_world_writes_aovs_behind_a_veil_but_not_past_the_alpha_threshold(kernels):
    """A veil of alpha 0.4 filling the frame writes 1 into "v"; the world behind it 0.7 for the share of paths that go
    on through it (0.6): 1 + 0.6 x 0.7 = 1.42 in the mean, each pixel 1 + 0.7 k / 16. Under a threshold of 0.3 the
    veil is opaque enough and the world writes nothing: 1 exactly."""
    scene = world_aov_scene()
    scene.materials.append(materials.Material(name="veil", nodes=[("TRANSPARENT", (0.6, 0.6, 0.6), {}),
                                                                  ("DIFFUSE", (0.4, 0.4, 0.4), {})],
                                              aovs=[("v", (0.0, 0.0, 0.0), 1.0)]))
    veil = scene.instances[0].matrix.copy()
    veil[:3, 3] = 2.0 * np.ones(3) / math.sqrt(3.0)
    veil[:3, :3] *= 5.0
    scene.instances.clear()
    scene.add_mesh(primitives.plane(1.0), veil, materials=np.array([1]), name="Veil")
    settings = settings_of(kernels, (("v", "VALUE"),), width=16, height=16, samples=16)
    np.testing.assert_allclose(render.render(scene, dataclasses.replace(settings, pass_alpha_threshold=0.3))
                               .aux["aov:v"], 1.0, atol=1e-7)
    value = render.render(scene, settings).aux["aov:v"][..., 0]
    k = (value - 1.0) * 16 / 0.7
    np.testing.assert_allclose(k, np.round(k), atol=1e-5)
    assert abs(value.mean() - 1.42) < 0.05


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_world_writes_no_aov_unseen_by_the_camera_or_on_a_transparent_film_without_the_environment_pass(kernels):
    """As Cycles: a world hidden from the camera (Ray Visibility > Camera) runs no background shader for camera rays,
    and on a transparent film the background of camera rays is evaluated only for the Environment pass: the world
    writes nothing then (the quad's 0.25 stays), and with the Environment pass asked for it writes as on an opaque
    film."""
    opaque = render.render(world_aov_scene(), settings_of(kernels, WORLD_AOVS, passes=("uv",))).aux
    coverage = opaque["uv"][..., 2]
    hidden = render.render(world_aov_scene(camera=False), settings_of(kernels, WORLD_AOVS, passes=("uv",))).aux
    clear = render.render(world_aov_scene(), settings_of(kernels, WORLD_AOVS, passes=("uv",),
                                                         transparent_background=True)).aux
    for aux in (hidden, clear):
        np.testing.assert_allclose(aux["aov:v"][..., 0], 0.25 * coverage, atol=1e-7)
        assert np.all(aux["aov:d"] == 0.0)
    kept = render.render(world_aov_scene(), settings_of(kernels, WORLD_AOVS, passes=("uv", "environment"),
                                                        transparent_background=True)).aux
    for name in ("aov:d", "aov:v"):
        np.testing.assert_allclose(kept[name], opaque[name], atol=1e-7)


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_the_compiled_world_aovs_follow_the_reference(integrator):
    """The C kernels write the world's AOVs as the Python reference does, from the same samples."""
    settings = RenderSettings(width=20, height=16, samples=4, integrator=integrator, max_bounces=2,
                              aovs=WORLD_AOVS, passes=("uv", "environment"))
    compiled = render.render(world_aov_scene(), dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(world_aov_scene(), dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    for name in ("aov:d", "aov:v"):
        np.testing.assert_allclose(compiled.aux[name], reference.aux[name], atol=1e-6, err_msg=name)
