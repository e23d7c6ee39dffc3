"""Light passes in core (core/integrators/lightpasses.py, lightpasses.c), without Blender: Diffuse/Glossy/Transmission
Direct and Indirect (the Volume ones: tests/test_passes_volume.py) on scenes whose answers are known, Cycles' sum rule, Combined = sum of (light pass x colour
pass) + Emission + Environment, on a path-traced scene of several materials, on both kernels; the compiled passes
follow the reference's, and asking for them leaves Combined as it was, bit for bit."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.integrators.lightpasses import COLOR_OF, LIGHT_PASSES, safe_divide_even_color
from core.lights import PointLight, World
from core.scene import RenderSettings, Scene

KERNELS = ["numpy", "compiled"]


def plane_scene(node: tuple) -> Scene:
    """A 4 x 4 plane of the material `node` (a closure node) filling the view of a camera above it, lit by a point
    light off to the side, the world black."""
    scene = Scene(camera=Camera.look_at(np.array([0.0, -1.0, 3.0]), np.zeros(3), fov=math.radians(50)))
    scene.materials.append(materials.Material(name="surface", nodes=[node]))
    scene.add_mesh(primitives.plane(4.0), materials=np.array([0]))
    scene.lights = [PointLight(np.array([0.5, 1.0, 1.5]), power=300.0, color=np.array([1.0, 0.9, 0.8]))]
    return scene


def passes(result) -> dict:
    """Return the render's light passes and the colour passes it returned: name -> (H, W, 3) float64."""
    return {name: result.aux[name].astype(np.float64) for name in (*LIGHT_PASSES, *set(COLOR_OF.values()))
            if name in result.aux}


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_lambert_plane_under_a_point_light_is_all_diffuse_direct(kernels):
    """Max Bounces 0: DiffDir = Combined / DiffCol, the other light passes 0."""
    scene = plane_scene(("DIFFUSE", (0.8, 0.5, 0.3), {}))
    settings = RenderSettings(width=24, height=16, samples=4, integrator="path", max_bounces=0,
                              passes=LIGHT_PASSES + ("diffuse_color",), kernels=kernels)
    result = render.render(scene, settings)
    p = passes(result)
    combined = result.image[..., :3].astype(np.float64)
    assert combined.min() > 0.0
    np.testing.assert_allclose(p["diffuse_color"], np.broadcast_to((0.8, 0.5, 0.3), combined.shape), rtol=1e-6)
    np.testing.assert_allclose(p["diffuse_direct"], combined / p["diffuse_color"], rtol=1e-5)
    for name in LIGHT_PASSES[1:]:
        assert np.all(p[name] == 0.0), name
    assert "glossy_color" not in result.aux                 # divided by, but not asked for: not returned


@pytest.mark.parametrize("kernels", KERNELS)
def test_one_light_pass_alone_is_the_same_as_among_all(kernels):
    """Diffuse Direct asked alone (Blender's usual choice: one tick) equals Diffuse Direct among all eight, and no
    other light pass is computed or returned."""
    scene = plane_scene(("DIFFUSE", (0.8, 0.5, 0.3), {}))
    settings = RenderSettings(width=24, height=16, samples=4, integrator="path", max_bounces=1,
                              passes=("diffuse_direct",), kernels=kernels)
    alone = render.render(scene, settings).aux
    among = render.render(scene, dataclasses.replace(settings, passes=LIGHT_PASSES)).aux
    assert alone["diffuse_direct"].max() > 0.0
    np.testing.assert_array_equal(alone["diffuse_direct"], among["diffuse_direct"])
    assert not any(name in alone for name in LIGHT_PASSES[1:])


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_direct_integrator_writes_the_same_light_passes(kernels):
    """integrator "direct" (Max Bounces 0 in Blender) splits its light the same way."""
    scene = plane_scene(("DIFFUSE", (0.8, 0.5, 0.3), {}))
    settings = RenderSettings(width=24, height=16, samples=4, integrator="direct", passes=LIGHT_PASSES,
                              kernels=kernels)
    result = render.render(scene, settings)
    assert set(LIGHT_PASSES) <= set(result.aux) and "diffuse_color" not in result.aux
    assert result.stats.kernels.startswith(kernels)
    combined = result.image[..., :3].astype(np.float64)
    np.testing.assert_allclose(result.aux["diffuse_direct"] * np.array([0.8, 0.5, 0.3]), combined, rtol=1e-5)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_metal_plane_is_all_glossy_direct(kernels):
    """A rough metal under a point light, path traced: GlossDir x GlossCol = Combined, no diffuse light."""
    scene = plane_scene(("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.5}))
    settings = RenderSettings(width=24, height=16, samples=4, integrator="path", max_bounces=2, passes=LIGHT_PASSES,
                              kernels=kernels)
    result = render.render(scene, dataclasses.replace(settings, passes=LIGHT_PASSES + ("glossy_color",)))
    p = passes(result)
    combined = result.image[..., :3].astype(np.float64)
    assert combined.max() > 0.0
    np.testing.assert_allclose(p["glossy_direct"] * p["glossy_color"], combined, rtol=1e-5, atol=1e-7)
    assert np.all(p["diffuse_direct"] == 0.0) and np.all(p["diffuse_indirect"] == 0.0)
    assert np.all(p["glossy_indirect"] == 0.0)          # a plane does not see itself


def sum_scene() -> Scene:
    """A diffuse floor, a glass sphere, a rough metal box, a diffuse-and-glossy coated sphere and a frosted glass
    sheet with a point light under it, under another point light, an emissive panel and a world that lights."""
    scene = Scene(camera=Camera.look_at((0.5, -5.0, 3.0), (0.0, 0.0, 0.4), fov=math.radians(45)))
    scene.add_material((0.8, 0.7, 0.6))
    scene.materials.append(materials.Material(name="glass", nodes=[("GLASS", (1.0, 0.95, 0.9), {"ior": 1.45})]))
    scene.materials.append(materials.Material(name="metal", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"metallic": 1.0, "base_color": (0.9, 0.6, 0.3), "roughness": 0.3})]))
    scene.materials.append(materials.Material(name="plastic", nodes=[
        ("PRINCIPLED", (1, 1, 1), {"base_color": (0.2, 0.4, 0.8), "roughness": 0.2})]))
    scene.materials.append(materials.Material(name="lamp", nodes=[
        ("EMISSION", (1, 1, 1), {"emission": (4.0, 3.0, 2.0)})]))
    scene.add_mesh(primitives.plane(8.0), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.8, 16, 8, center=(0.0, 0.0, 0.8), smooth=True), materials=np.array([1]))
    scene.add_mesh(primitives.box((0.6, 0.6, 1.2), center=(1.3, 0.6, 0.6)), materials=np.array([2]))
    scene.add_mesh(primitives.uv_sphere(0.5, 12, 6, center=(-1.4, 0.3, 0.5), smooth=True), materials=np.array([3]))
    scene.add_mesh(primitives.plane(0.8, center=(-1.2, 1.5, 1.8)), materials=np.array([4]))
    scene.materials.append(materials.Material(name="frosted", nodes=[("GLASS", (1, 1, 1), {"roughness": 0.3})]))
    scene.add_mesh(primitives.plane(1.0, center=(1.6, -1.2, 2.0)), materials=np.array([5]))
    scene.lights = [PointLight(np.array([1.0, -1.5, 3.0]), power=300.0),
                    PointLight(np.array([1.6, -1.2, 1.5]), power=30.0)]       # under the frosted sheet
    scene.world = World(color=np.array([0.1, 0.12, 0.15]), camera=True, lights=True)
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator, bounces", [("path", 4), ("direct", 0)])
def test_light_passes_times_colours_plus_emission_and_environment_make_combined(integrator, bounces, kernels):
    """The sum rule, per pixel: the passes are shares of the very samples Combined adds up (the first-hit passes
    come from the render's own samples), so it holds to float precision."""
    scene = sum_scene()
    wanted = LIGHT_PASSES + ("diffuse_color", "glossy_color", "transmission_color", "emission", "environment")
    settings = RenderSettings(width=40, height=30, samples=8, integrator=integrator, max_bounces=bounces,
                              passes=wanted, kernels=kernels)
    result = render.render(scene, settings)
    assert result.stats.kernels.startswith(kernels)
    p = {name: result.aux[name].astype(np.float64) for name in wanted}
    total = p["emission"] + p["environment"]
    for name in LIGHT_PASSES:
        total += p[name] * (p[COLOR_OF[name]] if name in COLOR_OF else 1.0)
    combined = result.image[..., :3].astype(np.float64)
    np.testing.assert_allclose(total, combined, rtol=1e-4, atol=1e-5)
    # Every kind of light is there: diffuse, glossy and transmission, direct and (path traced) indirect; no medium,
    # so no volume light (tests/test_passes_volume.py).
    for name in LIGHT_PASSES:
        expected = name in COLOR_OF and (integrator == "path" or name.endswith("_direct"))
        assert (p[name].max() > 0.0) == expected, name


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_without_light_passes_the_image_is_unchanged(integrator, kernels):
    """Asking for light passes changes nothing in Combined (same samples, same sums), on either kernel."""
    scene = sum_scene()
    settings = RenderSettings(width=20, height=15, samples=4, integrator=integrator, max_bounces=3, kernels=kernels)
    plain = render.render(scene, settings)
    split = render.render(scene, dataclasses.replace(settings, passes=LIGHT_PASSES))
    assert plain.stats.kernels == split.stats.kernels and plain.stats.kernels.startswith(kernels)
    np.testing.assert_array_equal(plain.image, split.image)


@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_the_compiled_light_passes_follow_the_reference(integrator):
    """The C kernels split the same samples the same way as the Python reference (the images' tolerance of
    tests/test_compiled.py, relative to each pass's largest value)."""
    from test_compiled import IMAGE_ATOL, IMAGE_RTOL
    settings = RenderSettings(width=40, height=30, samples=4, integrator=integrator, max_bounces=4,
                              passes=LIGHT_PASSES)
    assert_light_passes_agree(sum_scene(), settings, IMAGE_RTOL, IMAGE_ATOL)


def assert_light_passes_agree(scene, settings, rtol: float, atol: float) -> None:
    """`scene` rendered with `settings` by the compiled kernel and by the Python reference: the image and every light
    pass agree within rtol and atol (the passes' relative to each one's largest value)."""
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_allclose(compiled.image, reference.image, rtol=rtol, atol=atol)
    for name in LIGHT_PASSES:
        a, b = compiled.aux[name], reference.aux[name]
        np.testing.assert_allclose(a, b, rtol=rtol, atol=atol * max(1.0, float(np.abs(b).max())), err_msg=name)


def test_safe_divide_even_color_fills_channels_with_a_zero_divisor_as_cycles():
    a = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])
    b = np.array([[1.0, 1.0, 1.0], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    np.testing.assert_allclose(safe_divide_even_color(a, b),
                               [[1.0, 2.0, 3.0], [2.5, 2.0, 3.0], [3.0, 3.0, 3.0], [1.0, 1.0, 1.0]])
