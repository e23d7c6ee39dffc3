"""The world's Ray Visibility for bounces (World > Settings > Ray Visibility > Diffuse, Glossy, Transmission), as
Cycles' background SHADER_EXCLUDE_* flags: rays of a hidden kind find nothing where they escape, and the world's light
samples light no closure of that kind. Closed forms on both kernels (Volume Scatter: test_volume_scatter_visibility)."""
from __future__ import annotations

import numpy as np
import pytest

from core import render
from core.geometry import primitives
from core.materials import Material
from core.scene import RenderSettings, Scene, World
from core.visibility import HIDDEN_FROM_DIFFUSE, HIDDEN_FROM_GLOSSY, HIDDEN_FROM_TRANSMISSION

from test_emitters_world import environment, ortho_down

W = np.array([0.5, 1.0, 2.0])


def image(scene: Scene, kernels: str, samples: int = 4) -> np.ndarray:
    """The scene at 4 x 4, path traced: RGB (4, 4, 3) float64."""
    settings = RenderSettings(width=4, height=4, samples=samples, kernels=kernels, integrator="path", max_bounces=4)
    return render.render(scene, settings).image[..., :3]


def plane_under(world: World, material: Material) -> Scene:
    """An infinite plane of `material` under `world`, seen straight down by an orthographic camera."""
    scene = Scene(camera=ortho_down(height=1.0, scale=2.0), world=world)
    scene.materials.append(material)
    scene.add_mesh(primitives.plane(1e4), materials=np.array([0]))
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_world_hidden_from_diffuse_rays_lights_a_lambert_plane_not_at_all_and_a_mirror_fully(kernels):
    """A constant world W: a Lambert plane of albedo rho shows rho W (every BSDF ray escapes), 0 with the world hidden
    from diffuse rays, rho W again with it hidden from glossy ones; a mirror of colour 0.9 shows 0.9 W, 0 with the
    world hidden from glossy rays and 0.9 W with it hidden from diffuse ones."""
    rho = np.array([0.25, 0.5, 0.75])
    for hidden, lambert, mirror in ((0, rho * W, 0.9 * W), (HIDDEN_FROM_DIFFUSE, 0.0 * W, 0.9 * W),
                                    (HIDDEN_FROM_GLOSSY, rho * W, 0.0 * W)):
        world = World(color=W, hidden=hidden)
        np.testing.assert_allclose(image(plane_under(world, Material(rho, "Lambert")), kernels),
                                   np.broadcast_to(lambert, (4, 4, 3)), rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(image(plane_under(world, Material(np.full(3, 0.9), "Mirror", bsdf="MIRROR")),
                                         kernels), np.broadcast_to(mirror, (4, 4, 3)), rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_an_image_world_hidden_from_diffuse_rays_sends_no_light_samples_to_diffuse_closures(kernels):
    """An environment image over a Lambert plane: hidden from diffuse rays, neither its light samples nor the BSDF
    rays bring anything (exactly 0); hidden from glossy rays only, the plane is the very image it is unhidden."""
    def scene(hidden: int) -> Scene:
        return plane_under(World(image=environment(), hidden=hidden), Material(np.full(3, 0.5), "Lambert"))

    seen = image(scene(0), kernels, samples=16)
    assert seen.min() > 0.0
    np.testing.assert_array_equal(image(scene(HIDDEN_FROM_DIFFUSE), kernels, samples=16), 0.0)
    np.testing.assert_allclose(image(scene(HIDDEN_FROM_GLOSSY), kernels, samples=16), seen, rtol=1e-12)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_world_hidden_from_transmission_rays_is_seen_in_glass_only_by_its_fresnel_reflection(kernels):
    """A smooth glass plane (IOR 1.5) in a constant world W, seen head-on: W exactly (reflected F + refracted 1 - F,
    the world on both sides); hidden from transmission rays, only the reflection F(0) = ((1.5 - 1) / 2.5)^2 = 0.04 of
    W (the refracted rays escape unseen): the mean of 4096 paths each W or 0, within 5 standard errors."""
    glass = Material(name="Glass", nodes=[("GLASS", (1.0, 1.0, 1.0), {"ior": 1.5})])
    np.testing.assert_allclose(image(plane_under(World(color=W), glass), kernels),
                               np.broadcast_to(W, (4, 4, 3)), rtol=1e-6)
    hidden = image(plane_under(World(color=W, hidden=HIDDEN_FROM_TRANSMISSION), glass), kernels, samples=256)
    F, n = 0.04, 16 * 256
    assert abs(hidden.mean(axis=(0, 1)) / W - F).max() < 5.0 * np.sqrt(F * (1.0 - F) / n), hidden.mean(axis=(0, 1))
