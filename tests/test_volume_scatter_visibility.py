"""Ray Visibility > Volume Scatter, as Cycles: a lamp, an emitter or the world hidden from it lights no scattering
point (Cycles' SHADER_EXCLUDE_SCATTER drops its light samples there and phase rays pass it), and phase rays pass an
object hidden from it. Closed forms on both kernels, direct and path traced (no volume bounces: the scattering
points' own light is all that changes)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.geometry import primitives
from core.materials import Material
from core.render import render
from core.scene import RenderSettings, Scene, SunLight, World
from core.visibility import HIDDEN_FROM_VOLUME_SCATTER

from test_volumes import camera_above, fog, glowing_floor

SIGMA = np.array([0.5, 1.0, 2.0])                       # the slab's sigma_s = sigma_t per channel (Volume Scatter)
DEPTH = 0.6
CASES = [(kernels, integrator) for kernels in ("numpy", "compiled") for integrator in ("direct", "path")]


def image(scene: Scene, kernels: str, integrator: str, samples: int = 4) -> np.ndarray:
    """The scene at 4 x 4, RGB (4, 4, 3) float64."""
    settings = RenderSettings(width=4, height=4, samples=samples, kernels=kernels, integrator=integrator)
    return render(scene, settings).image[..., :3]


def scattering_slab(scene: Scene) -> None:
    """A wide scattering slab (isotropic, sigma_s = SIGMA) DEPTH deep, from z = 0.7 up."""
    scene.materials.append(fog(closure="SCATTER", color=SIGMA, density=1.0, anisotropy=0.0))
    scene.add_mesh(primitives.box((40.0, 40.0, DEPTH), center=(0.0, 0.0, 0.7 + DEPTH / 2)),
                   materials=np.array([len(scene.materials) - 1]))


@pytest.mark.parametrize("kernels, integrator", CASES)
def test_a_sun_hidden_from_volume_scatter_lights_the_floor_through_the_fog_but_not_the_fog(kernels, integrator):
    """A grey floor (0.8) under the slab and a sun at 50 degrees: hidden from Volume Scatter, the pixel is the floor
    alone, 0.8 / pi E sin 50 exp(-sigma d / sin 50) exp(-sigma d) (its shadow rays are no scattering); seen, the fog
    adds its single scattering on top."""
    E, elevation = 3.0, math.radians(50.0)

    def scene(hidden: bool) -> Scene:
        made = Scene(camera=camera_above())
        made.materials.append(Material(np.full(3, 0.8), "Floor"))
        made.add_mesh(primitives.plane(40.0), materials=np.array([0]))
        scattering_slab(made)
        sun = SunLight(direction=-np.array([math.cos(elevation), 0.0, math.sin(elevation)]), strength=E)
        sun.hidden_from = HIDDEN_FROM_VOLUME_SCATTER if hidden else 0
        made.lights.append(sun)
        return made

    floor = 0.8 / math.pi * E * math.sin(elevation) * np.exp(-SIGMA * DEPTH / math.sin(elevation) - SIGMA * DEPTH)
    hidden = image(scene(True), kernels, integrator)
    np.testing.assert_allclose(hidden, np.broadcast_to(floor, (4, 4, 3)), rtol=2e-4)   # (the shadow ray's offset)
    seen = image(scene(False), kernels, integrator)
    assert (seen.mean(axis=(0, 1)) > 1.05 * floor).all()


@pytest.mark.parametrize("kernels, integrator", CASES)
def test_an_emitter_hidden_from_volume_scatter_is_seen_through_the_fog_but_lights_none_of_it(kernels, integrator):
    """An emitting floor (1, 2, 0.5) under the slab, its object hidden from Volume Scatter: the camera sees it through
    the fog, exp(-sigma d) of it, and the fog scatters none of its light (no light samples of it at scattering
    points, and phase rays pass it); seen by Volume Scatter, the fog glows on top."""
    def scene(hidden: bool) -> Scene:
        made = Scene(camera=camera_above())
        glowing_floor(made)
        made.instances[-1].visible_volume_scatter = not hidden
        scattering_slab(made)
        return made

    through = np.array([1.0, 2.0, 0.5]) * np.exp(-SIGMA * DEPTH)
    np.testing.assert_allclose(image(scene(True), kernels, integrator), np.broadcast_to(through, (4, 4, 3)),
                               rtol=1e-4)                # (the rays' offsets at the slab's faces)
    assert (image(scene(False), kernels, integrator).mean(axis=(0, 1)) > 1.05 * through).all()


@pytest.mark.parametrize("kernels, integrator", CASES)
def test_a_world_hidden_from_volume_scatter_is_seen_through_the_fog_but_lights_none_of_it(kernels, integrator):
    """A constant world W = (0.2, 0.4, 0.6) (found by escaping rays alone) around the slab, seen from above: hidden
    from Volume Scatter, the pixel is W exp(-sigma d) (to the rays' offsets at its faces); seen, the fog adds
    the world it scatters."""
    def scene(scatter: bool) -> Scene:
        made = Scene(camera=camera_above())
        made.world = World(color=np.array([0.2, 0.4, 0.6]), hidden=0 if scatter else HIDDEN_FROM_VOLUME_SCATTER)
        scattering_slab(made)
        return made

    through = np.array([0.2, 0.4, 0.6]) * np.exp(-SIGMA * DEPTH)
    np.testing.assert_allclose(image(scene(False), kernels, integrator), np.broadcast_to(through, (4, 4, 3)),
                               rtol=1e-4)                # (the rays' offsets at the slab's faces)
    assert (image(scene(True), kernels, integrator).mean(axis=(0, 1)) > 1.05 * through).all()


@pytest.mark.parametrize("kernels, integrator", CASES)
def test_phase_rays_pass_an_object_hidden_from_volume_scatter(kernels, integrator):
    """The slab in a constant world W over a black floor that hides the world below: hidden from Volume Scatter,
    the floor stops the camera's rays (black behind the fog) but not the phase rays, so the pixel is the same
    fog's light as with no floor at all, that image less W exp(-sigma d) (what the camera saw through it); seen by them, it takes the light from below away."""
    W = np.array([0.2, 0.4, 0.6])

    def scene(floor: str) -> Scene:
        made = Scene(camera=camera_above())
        made.world = World(color=W)
        scattering_slab(made)
        if floor != "none":
            made.materials.append(Material(np.zeros(3), "Black"))
            made.add_mesh(primitives.plane(40.0), materials=np.array([len(made.materials) - 1]))
            made.instances[-1].visible_volume_scatter = floor == "seen"
        return made

    bare = image(scene("none"), kernels, integrator, samples=16)
    hidden = image(scene("hidden"), kernels, integrator, samples=16)
    np.testing.assert_allclose(hidden, bare - W * np.exp(-SIGMA * DEPTH), rtol=1e-4)
    seen = image(scene("seen"), kernels, integrator, samples=16)
    assert (seen.mean(axis=(0, 1)) < 0.9 * hidden.mean(axis=(0, 1))).all()
