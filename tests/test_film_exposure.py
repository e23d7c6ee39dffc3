"""Film Exposure (Cycles' Render > Film > Exposure): Combined and the passes of light scaled by it, the data and
colour passes and alpha as they are (Cycles' pass_info.use_exposure). Both kernels."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.geometry import primitives
from core.lights import World
from core.materials import Material
from core.scene import RenderSettings, Scene

PASSES = ("emission", "environment", "diffuse_direct", "diffuse_color", "z_depth", "average_normal")


def lit_plane_with_a_glowing_square() -> Scene:
    """A grey Lambert plane under a coloured world, and an emissive square on it: every pass above has something."""
    scene = Scene(camera=ortho_down(height=1.0, scale=2.0), world=World(color=np.array([0.5, 1.0, 2.0])))
    scene.materials.append(Material(np.full(3, 0.5), "Floor"))
    scene.add_mesh(primitives.plane(1.4), materials=np.array([0]))
    scene.materials.append(Material(np.zeros(3), "Glow", emission=np.array([1.0, 0.5, 0.25])))
    glow = primitives.plane(0.5)
    glow.vertices[:, 2] += 0.01
    scene.add_mesh(glow, materials=np.array([1]))
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_exposure_scales_combined_and_the_light_passes_and_nothing_else(kernels):
    """The same samples at exposure 1 and 2.5: Combined's colour, Emission, Environment and Diffuse Direct are 2.5
    times as bright (to float32 rounding); alpha, Diffuse Color, Depth and Normal are the same numbers."""
    scene = lit_plane_with_a_glowing_square()
    settings = RenderSettings(width=8, height=8, samples=4, kernels=kernels, transparent_background=True,
                              passes=PASSES)
    plain = render.render(scene, settings)
    exposed = render.render(scene, RenderSettings(**{**settings.__dict__, "exposure": 2.5}))
    np.testing.assert_allclose(exposed.image[..., :3], 2.5 * plain.image[..., :3], rtol=1e-6)
    np.testing.assert_array_equal(exposed.image[..., 3], plain.image[..., 3])
    assert plain.image[..., 3].min() == 0.0 and plain.image[..., 3].max() == 1.0     # (the sky, the plane)
    for name in ("emission", "environment", "diffuse_direct"):
        assert plain.aux[name].max() > 0.0, name
        np.testing.assert_allclose(exposed.aux[name], 2.5 * plain.aux[name], rtol=1e-6, err_msg=name)
    for name in ("diffuse_color", "z_depth", "average_normal"):
        np.testing.assert_array_equal(exposed.aux[name], plain.aux[name], err_msg=name)


def test_light_groups_are_exposed_and_the_shadow_catcher_ratio_is_not():
    """render.expose: a light group's image is scaled, the Shadow Catcher pass (Combined over the catcher's light:
    the exposure cancels in Cycles) and the AO pass keep theirs."""
    ones = np.ones((2, 2, 3), np.float32)
    image, aux = render.expose(np.ones((2, 2, 4), np.float32),
                               {"lightgroup:key": ones, "shadow_catcher": ones, "ambient_occlusion": ones}, 3.0)
    assert (image[..., :3] == 3.0).all() and (image[..., 3] == 1.0).all()
    assert (aux["lightgroup:key"] == 3.0).all()
    assert (aux["shadow_catcher"] == 1.0).all() and (aux["ambient_occlusion"] == 1.0).all()
