"""The Holdout shader node, as Cycles reads it, on both kernels: where a camera path (the camera ray and its way on
through Transparent BSDFs) meets a surface whose Holdout closure has weight w, the pixel's alpha loses w x the
path's throughput and that part of the surface adds no light (a hole), while the material's other closures shade
with their own weights; every other ray sees the Holdout closure as black (it reflects and emits nothing)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.geometry import primitives
from core.lights import SunLight
from core.scene import RenderSettings, Scene
from test_ray_visibility import KERNELS, behind_a_pane, looking_down, mirror_under_a_lamp

ALBEDO, SUN, THETA = 0.6, 3.0, math.radians(30.0)


def held_out(f: float, *others) -> materials.Material:
    """Mix Shader (Fac f) of the shader nodes `others` (each weighted 1 - f) and a Holdout (weighted f)."""
    nodes = [(name, np.asarray(weight, np.float64) * (1.0 - f), inputs) for name, weight, inputs in others]
    return materials.Material(name="held", nodes=nodes + [("HOLDOUT", (f,) * 3, {})])


def sunlit_plane(f: float, kernels: str, integrator: str, transparent_film: bool) -> tuple:
    """A plane filling the view, Mix(Fac f, Diffuse of ALBEDO, Holdout), under a sun of SUN W/m^2 at THETA."""
    scene = Scene(camera=looking_down(4.0))
    scene.materials.append(held_out(f, ("DIFFUSE", (ALBEDO,) * 3, {})))
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    scene.lights.append(SunLight(np.array([math.sin(THETA), 0.0, -math.cos(THETA)]), strength=SUN))
    return scene, RenderSettings(width=16, height=16, samples=2, integrator=integrator, kernels=kernels,
                                 transparent_background=transparent_film)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["direct", "path"])
@pytest.mark.parametrize("transparent_film", [False, True])
@pytest.mark.parametrize("f", [0.0, 0.25, 0.7, 1.0])
def test_a_holdout_mixed_with_a_diffuse_takes_its_share_of_alpha_and_light(kernels, integrator, transparent_film, f):
    """Mix(Fac f, Diffuse, Holdout) on a sunlit plane: every pixel is colour (1 - f) x albedo x E cos(theta) / pi
    and alpha 1 - f, exactly, on an opaque film as on a transparent one (Cycles' holdout ignores the film);
    f = 1 is a whole hole, (0, 0, 0, 0)."""
    scene, settings = sunlit_plane(f, kernels, integrator, transparent_film)
    image = render.render(scene, settings).image
    colour = (1.0 - f) * ALBEDO * SUN * math.cos(THETA) / math.pi
    np.testing.assert_allclose(image[..., :3], colour, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(image[..., 3], 1.0 - f, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_mirror_sees_a_holdout_node_as_black_not_as_a_hole(kernels):
    """The lamp quad over the mirror (hidden from the camera) made Mix(Fac 0.5, Emission 5, Holdout): the mirror
    shows it at 2.5 (the emission's own weight) where it reflects it and the sky's 1 elsewhere, alpha 1 everywhere;
    a whole Holdout there shows black (0) at alpha 1: only camera paths make holes."""
    scene, settings = mirror_under_a_lamp("", kernels)
    scene.materials[1] = held_out(0.5, ("EMISSION", (1.0,) * 3, {"emission": (5.0,) * 3}))
    image = render.render(scene, settings).image
    assert (image[..., :3] == 2.5).all(axis=-1).sum() > 4 and (image[..., :3] == 1.0).all(axis=-1).sum() > 100
    np.testing.assert_array_equal(image[..., 3], 1.0)
    scene.materials[1] = held_out(1.0)
    image = render.render(scene, settings).image
    assert (image[..., :3] == 0.0).all(axis=-1).sum() > 4 and (image[..., :3] == 1.0).all(axis=-1).sum() > 100
    np.testing.assert_array_equal(image[..., 3], 1.0)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("transparent_film", [False, True])
def test_a_holdout_node_seen_through_a_transparent_bsdf_takes_away_its_share_of_what_the_pane_lets_through(
        kernels, transparent_film):
    """Through a Transparent BSDF of 0.25 grey, the quad Mix(Fac 0.5, Emission 5, Holdout) before a floor glowing 2:
    the pixel is 0.25 x 0.5 x 5 = 0.625 at alpha 1 - 0.25 x 0.5 = 0.875 over the quad, 0.25 x 2 = 0.5 at alpha 1
    over the floor."""
    scene, settings = behind_a_pane([("TRANSPARENT", (0.25,) * 3, {})], "", kernels)
    scene.materials[1] = held_out(0.5, ("EMISSION", (1.0,) * 3, {"emission": (5.0,) * 3}))
    image = render.render(scene, dataclasses.replace(settings, transparent_background=transparent_film)).image
    quad = np.isclose(image, [0.625, 0.625, 0.625, 0.875], rtol=1e-12, atol=0).all(axis=-1)
    floor = np.isclose(image, [0.5, 0.5, 0.5, 1.0], rtol=1e-12).all(axis=-1)
    assert quad.sum() > 4 and floor.sum() > 300 and (quad | floor).sum() > image.shape[0] * image.shape[1] - 30


@pytest.mark.parametrize("integrator", ["direct", "path"])
def test_both_kernels_render_holdout_nodes_alike(integrator):
    """A floor of Mix(0.3, Diffuse, Holdout), a glossy box of Mix(0.6, Glossy, Holdout), a whole Holdout box and a
    Transparent pane over it, under a sky and an emitter: the compiled kernels and the Python reference agree
    pixel for pixel, alpha included (tests/test_compiled.py's comparison)."""
    from core.lights.world import World
    from test_compiled import assert_same_render, compare_paths
    from test_ray_visibility import glow
    scene = Scene(camera=looking_down(6.0), world=World(color=np.full(3, 0.3)))
    scene.materials += [held_out(0.3, ("DIFFUSE", (0.6,) * 3, {})),
                        held_out(0.6, ("GLOSSY", (0.9,) * 3, {"roughness": 0.3})), held_out(1.0),
                        materials.Material(name="clear", nodes=[("TRANSPARENT", (0.5,) * 3, {})]), glow("lamp", 6.0)]
    scene.add_mesh(primitives.plane(40.0), materials=np.array([0]))
    for x, material in [(-1.5, 1), (0.0, 2), (1.5, 0)]:
        scene.add_mesh(primitives.box((0.8, 0.8, 0.8), center=(x, 0.0, 0.4)), materials=np.array([material]))
    scene.add_mesh(primitives.plane(2.0, center=(0.0, 0.4, 1.3)), materials=np.array([3]))
    lamp = np.array([[1, 0, 0, 0], [0, -1, 0, 0.5], [0, 0, -1, 2.5], [0, 0, 0, 1.0]])
    scene.add_mesh(primitives.plane(1.0), lamp, materials=np.array([4]))
    settings = RenderSettings(width=40, height=40, samples=4, integrator=integrator, light_samples=2)
    compiled, reference = compare_paths(scene, settings)
    assert_same_render(compiled, reference)
    # alpha: the floor 0.7, the glossy box 0.4, the whole Holdout box through the pane 1 - 0.5, the floor there 0.85
    alpha = reference.image[..., 3]
    assert all(np.isclose(alpha, a, rtol=0, atol=1e-6).sum() > 4 for a in (0.7, 0.4, 0.5, 0.85))
