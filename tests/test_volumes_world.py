"""A heterogeneous world medium (World > Volume with an input fed by nodes: core/volumes/media.py world_field_of),
held to closed forms in both kernels: an absorbing world whose density falls linearly with height keeps exp(-its
integral) on camera rays and on a sun's shadow rays; the kernels render the same scattering world alike."""
from __future__ import annotations

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import SunLight, World
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.render import render
from core.scene import RenderSettings, Scene
from core.volumes.media import WORLD_MEDIUM_NOTE

COLOR = np.array([0.2, 0.5, 0.8])
# The density: 0.3 (2.9 - z) clamped to [0, 1], 0 above the camera's clip start (z = 2.9); its integral up from the
# floor 0.3 x 2.9^2 / 2.
TOP, SLOPE = 2.9, 0.3
INTEGRAL = SLOPE * TOP * TOP / 2.0


def falling() -> Link:
    """A graph: clamp(SLOPE (TOP - z)) of the point's Object z (a world's Object coordinates: the world point)."""
    z = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("TEXCOORD"), "Object")}), "Z")
    return Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD", "clamp": True},
                          {"0": z, "1": -SLOPE, "2": SLOPE * TOP}), "Value")


def scene_under(volume: list, floor: Material) -> Scene:
    """An orthographic camera 3 above a floor (a plane 20 wide at z = 0) in a world of Volume closures `volume`."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=20.0))
    scene.world = World(color=np.zeros(3), volume=volume)
    scene.materials.append(floor)
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    return scene


def image(scene: Scene, kernels: str, **settings) -> np.ndarray:
    """The scene path traced at 4 x 4 (RGB (4, 4, 3)) by `kernels` ("compiled", checked, or "numpy")."""
    settings = {"width": 4, "height": 4, "samples": 2, "integrator": "path", **settings}
    result = render(scene, RenderSettings(**settings, **({"kernels": "numpy"} if kernels == "numpy" else {})))
    assert kernels == "numpy" or result.stats.kernels == "compiled"
    assert [w for w in result.stats.warnings if "world" in w] == [WORLD_MEDIUM_NOTE], result.stats.warnings
    return result.image[..., :3]


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_world_whose_density_falls_linearly_keeps_exp_of_minus_its_integral_on_camera_rays(kernels):
    """An emitting floor seen down through the world's absorption of density 0.3 (2.9 - z): each channel keeps
    exp(-1.2615 (1 - colour)) of its light (ratio tracking against a control linear on each piece: exact)."""
    glow = np.array([1.0, 2.0, 0.5])
    scene = scene_under([("ABSORPTION", 1.0, {"color": COLOR, "density": falling()})],
                        Material(np.zeros(3), "Glow", emission=glow))
    expected = glow * np.exp(-INTEGRAL * (1.0 - COLOR))
    np.testing.assert_allclose(image(scene, kernels), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_suns_shadow_rays_through_a_falling_world_density_keep_exp_of_its_slanted_integral(kernels):
    """A white floor lit by a sun 60 degrees up through that world: the sun's shadow rays leave the world's box
    and go on to infinity (the medium held at its value where they leave it: 0 up there), so the camera sees
    albedo / pi x E sin 60 exp(-1.2615 (1 - colour) (1 + 1 / sin 60)), within ratio tracking's noise (the clamp's kink
    at z = 2.9 is not on the control's line): the mean of 4 x 4 x 8 within 0.2%, each pixel within 2%."""
    scene = scene_under([("ABSORPTION", 1.0, {"color": COLOR, "density": falling()})],
                        Material(np.full(3, 0.8), "Floor"))
    elevation = np.radians(60.0)
    scene.lights.append(SunLight(direction=-np.array([np.cos(elevation), 0.0, np.sin(elevation)]), strength=3.0))
    expected = (0.8 / np.pi * 3.0 * np.sin(elevation)
                * np.exp(-INTEGRAL * (1.0 - COLOR) * (1.0 + 1.0 / np.sin(elevation))))
    found = image(scene, kernels, samples=8)
    print(found.reshape(-1, 3).mean(axis=0) / expected - 1.0, np.abs(found / expected - 1.0).max())
    np.testing.assert_allclose(found.reshape(-1, 3).mean(axis=0), expected, rtol=2e-3)
    np.testing.assert_allclose(found, np.broadcast_to(expected, (4, 4, 3)), rtol=2e-2)


def test_both_kernels_render_a_scattering_world_that_thins_with_height_to_the_same_pixels():
    """A world Volume Scatter (g 0.4) of density 0.3 (2.9 - z) in a room under an area and a point lamp and a sun
    (whose shadow rays leave the box to infinity), a smoke box inside it, Volume Bounces 1: the kernels march,
    track and scatter alike (test_volumes_compiled's tolerance for tracked pixels)."""
    import math
    from test_volumes_compiled import assert_same_tracked_pixels, both, looking, room, smoke
    scene = room(looking())
    smoke(scene)
    scene.lights.append(SunLight(direction=np.array([0.3, 0.2, -1.0]) / math.sqrt(1.13), strength=2.0))
    scene.world = World(color=np.array([0.3, 0.4, 0.5]),
                        volume=[("SCATTER", 1.0, {"color": np.full(3, 0.8), "density": falling(), "anisotropy": 0.4})])
    reference, compiled, stats = both(scene, volume_bounces=1, width=8, height=6, samples=2)
    assert stats.kernels == "compiled"
    assert [w for w in stats.warnings if "world" in w] == [WORLD_MEDIUM_NOTE], stats.warnings
    assert_same_tracked_pixels(reference, compiled, rtol=0.05)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_heterogeneous_slab_in_a_heterogeneous_world_keeps_exp_of_both_integrals(kernels):
    """An emitting floor seen down through an absorbing slab of density 2 z + 0.5 (z from 0.5 to 1.5: integral 2.5)
    inside the falling world (integral 1.2615): the two fields share one march (the slab's finer step in the world's
    box), and each channel keeps exp(-(2.5 + 1.2615) (1 - colour)) of the floor's light."""
    from test_volumes_heterogeneous import height, scene_with, slab
    scene = scene_with(slab(color=COLOR, density=height(2.0, 0.5)))
    scene.world = World(color=np.zeros(3), volume=[("ABSORPTION", 1.0, {"color": COLOR, "density": falling()})])
    expected = np.array([1.0, 2.0, 0.5]) * np.exp(-(2.5 + INTEGRAL) * (1.0 - COLOR))
    np.testing.assert_allclose(image(scene, kernels), np.broadcast_to(expected, (4, 4, 3)), rtol=1e-5)


def test_a_heterogeneous_world_medium_makes_an_escaping_camera_rays_alpha_opaque():
    """On a transparent film a camera ray that escapes through a heterogeneous world medium has alpha 1 (its way to
    infinity is held at the probes' mean density: render.escaping_alpha), as through a homogeneous one; no world
    medium: 0."""
    from core.render import escaping_alpha
    from core.volumes import Media
    world = [("SCATTER", 1.0, {"color": np.ones(3), "density": falling()})]
    media = Media.of([Material(np.zeros(3), "Default")], world)
    assert media.world_field is not None and media.world_field.unbounded and list(media.field_columns) == [-1]
    assert escaping_alpha(media) == 1.0 and escaping_alpha(None) == 0.0


def test_a_heterogeneous_worlds_march_keeps_its_step_in_the_scenes_box_and_doubles_its_pieces_past_it():
    """A world medium is marched in the scene's box padded by WORLD_PAD diagonals; the pieces keep the step (the
    scene box's diagonal / STEPS_ACROSS, at most) inside the scene's own box and double in length past it, so a ray
    escaping from the scene's middle crosses the padding in about log2(padding / step) pieces, not MAX_PIECES; and
    the optical depth of the density 0.3 (2.9 - z) on them (the ratio-tracking control) stays exact."""
    import types
    from core.volumes.field import MAX_PIECES, March, doublings
    from core.volumes.media import world_field_of
    box = types.SimpleNamespace(origin=np.zeros(3), bounds=lambda: (np.array([-1.0, -1.0, 0.0]), np.ones(3)))
    field = world_field_of([("ABSORPTION", 1.0, {"color": COLOR, "density": falling()})], box)
    O, D = np.array([[0.0, 0.0, 0.5]]), np.array([[0.0, 0.0, 1.0]])
    zero = np.zeros((1, 3))
    march = March([field], np.ones((1, 1)), (zero, zero, zero, np.zeros(1)), O, D, np.array([np.inf]))
    edges = march.edges[0]
    inner = np.diff(edges[1:-1])
    step = field.step
    fine = inner[edges[1:-2] < 0.5 - 1e-12]                     # (the pieces within the scene box: z < 1)
    np.testing.assert_allclose(fine, 0.5 / np.ceil(0.5 / step), rtol=1e-9)   # (equal, at most the step)
    padding = field.high[2] - 1.0
    assert march.pieces[0] == len(fine) + doublings(np.array([padding]), step)[0] < MAX_PIECES // 4
    np.testing.assert_allclose(inner[len(fine):-1], step * 2.0 ** np.arange(len(inner) - len(fine) - 1), rtol=1e-9)
    # (the control's optical depth to the 4th doubled edge, whose pieces and their neighbours are below the kink
    # at z = 2.9: exact for the linear density, SLOPE (TOP - z) integrated from z = 0.5)
    s = 0.5 + step * 15.0
    depth = march.control_depth(np.array([s]))[0][0]
    integral = SLOPE * ((TOP - 0.5) ** 2 - (TOP - 0.5 - s) ** 2) / 2.0
    np.testing.assert_allclose(depth, integral * (1.0 - COLOR), rtol=1e-9)
