"""NaN and infinite parameters never reach the image (issue 31): materials, lights and the world read them as Cycles
renders them (core/materials/finite.py, core/lights/world.py finite_world), and the film replaces a sample that is
still not finite by 0, counts it and says where (core/film/film.py finite_samples), on both kernels."""
from __future__ import annotations

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.lights import PointLight, SunLight, World
from core.materials import Material
from core.render import render
from core.scene import RenderSettings, Scene

INF, NAN = np.inf, np.nan


def plane_scene(nodes=None, base_color=(0.6, 0.5, 0.4), emission=(0.0, 0.0, 0.0), world=None, lights=()):
    """A plane seen from above at an angle (the world fills the top rows), lit by a sun, its material and world given."""
    matrix = np.eye(4)
    angle = np.radians(60.0)
    matrix[:3, :3] = [[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]]
    matrix[:3, 3] = [0.0, -4.0, 2.5]
    scene = Scene(camera=Camera(matrix_world=matrix, clip_start=0.1, clip_end=100.0))
    if nodes is not None:
        scene.materials.append(Material(name="Plane", nodes=nodes))
    else:
        scene.materials.append(Material(np.asarray(base_color, np.float64), "Plane", emission=np.asarray(emission)))
    scene.add_mesh(primitives.plane(8.0), materials=[0])
    scene.world = world if world is not None else World(color=np.array([0.2, 0.3, 0.4]))
    scene.lights.append(SunLight(direction=np.array([0.3, 0.0, -1.0]) / np.hypot(0.3, 1.0), strength=2.0))
    scene.lights.extend(lights)
    return scene


def principled(**inputs):
    """One Principled BSDF node of base colour (0.6, 0.5, 0.4) with `inputs` over it."""
    return [("PRINCIPLED", np.ones(3), {"base_color": np.array([0.6, 0.5, 0.4]), **inputs})]


def rendered(scene, kernels):
    """The scene at 16 x 12 pixels, 4 samples, path traced: (image (H, W, 4) float32, warnings)."""
    result = render(scene, RenderSettings(width=16, height=12, samples=4, kernels=kernels, integrator="path"))
    return result.image, result.stats.warnings


# Each bad scene, and the finite scene Cycles renders in its place (what the bad value reads as).
CASES = {
    "principled base colour inf": (lambda: plane_scene(principled(base_color=np.array([INF, INF, INF]))),
                                   lambda: plane_scene(principled(base_color=np.zeros(3))), "Principled base_color"),
    "principled base colour nan": (lambda: plane_scene(principled(base_color=np.array([NAN, 0.5, 0.4]))),
                                   lambda: plane_scene(principled(base_color=np.array([0.0, 0.5, 0.4]))),
                                   "Principled base_color"),
    "principled roughness inf": (lambda: plane_scene(principled(roughness=INF)),
                                 lambda: plane_scene(principled(roughness=1.0)), "Principled roughness"),
    "principled roughness nan": (lambda: plane_scene(principled(roughness=NAN)),
                                 lambda: plane_scene(principled(roughness=0.0)), "Principled roughness"),
    "principled emission inf": (lambda: plane_scene(principled(emission=np.array([INF, 1.0, 1.0]))),
                                lambda: plane_scene(principled(emission=np.array([0.0, 1.0, 1.0]))),
                                "Principled emission"),
    "principled ior nan": (lambda: plane_scene(principled(ior=NAN)),
                           lambda: plane_scene(principled(ior=0.0)), "Principled ior"),
    "node weight nan": (lambda: plane_scene([("DIFFUSE", np.array([NAN, 0.5, 0.5]), {})]),
                        lambda: plane_scene([("DIFFUSE", np.array([0.0, 0.5, 0.5]), {})]), "Diffuse weight"),
    "diffuse colour inf": (lambda: plane_scene(base_color=(INF, 0.5, 0.4)),
                           lambda: plane_scene(base_color=(0.0, 0.5, 0.4)), "base colour"),
    "emission nan": (lambda: plane_scene(emission=(NAN, 2.0, 2.0)),
                     lambda: plane_scene(emission=(0.0, 2.0, 2.0)), "emission"),
    "world colour nan": (lambda: plane_scene(world=World(color=np.array([NAN, NAN, NAN]))),
                         lambda: plane_scene(world=World(color=np.zeros(3))), "the world's colour"),
    "world colour inf": (lambda: plane_scene(world=World(color=np.array([INF, 0.3, 0.4]))),
                         lambda: plane_scene(world=World(color=np.array([0.0, 0.3, 0.4]))), "the world's colour"),
    "world strength nan": (lambda: plane_scene(world=World(image=np.full((8, 16, 3), 0.5, np.float32), strength=NAN)),
                           lambda: plane_scene(world=World(image=np.full((8, 16, 3), 0.5, np.float32), strength=0.0)),
                           "the world's strength"),
    "world image inf": (lambda: plane_scene(world=World(image=np.full((8, 16, 3), INF, np.float32))),
                        lambda: plane_scene(world=World(image=np.zeros((8, 16, 3), np.float32))), "the world's image"),
    "lamp power inf": (lambda: plane_scene(lights=[PointLight(position=np.array([0.0, 0.0, 1.0]), power=INF)]),
                       lambda: plane_scene(), "light 'Point'"),
    "lamp colour nan": (lambda: plane_scene(lights=[PointLight(position=np.array([0.0, 0.0, 1.0]), power=100.0,
                                                               color=np.array([NAN, 1.0, 1.0]))]),
                        lambda: plane_scene(), "light 'Point'"),
}


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_nan_and_infinite_parameters_render_finite_as_cycles_reads_them(case, kernels):
    """The scene renders finite, exactly as the scene with the value Cycles reads in its place (0, or a clamped
    input's bound; a lamp with a non-finite parameter sends nothing), with one warning naming what was read."""
    bad, good, named = CASES[case]
    image, warnings = rendered(bad(), kernels)
    expected, expected_warnings = rendered(good(), kernels)
    assert np.isfinite(image).all()
    np.testing.assert_array_equal(image, expected)
    new = [w for w in warnings if w not in expected_warnings]
    assert len(new) == 1 and named in new[0] and ("NaN or infinite" in new[0]), new


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_a_sample_beyond_the_float32_film_goes_in_as_zero_counted_and_located(kernels):
    """A lamp of finite but enormous power (1e300 W) makes samples no float32 film holds: the film takes each such
    channel as 0, as Cycles' film does (ensure_finite), and one warning counts them and names the first pixel."""
    scene = plane_scene(lights=[PointLight(position=np.array([0.0, 0.0, 1.0]), power=1e300)])
    image, warnings = rendered(scene, kernels)
    assert np.isfinite(image).all()
    notes = [w for w in warnings if "were NaN or infinite and went into the image as 0" in w]
    assert len(notes) == 1 and "the first at pixel x" in notes[0]
    count = int(notes[0].split()[0])
    assert 0 < count <= 16 * 12 * 4


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
def test_the_auxiliary_buffers_take_a_sample_beyond_the_film_as_zero_too(kernels):
    """The 1e300 W lamp again, with the light passes, a light group and the denoising features asked for: every
    buffer stays finite (each sample's channel beyond the film goes in as 0, as in the image)."""
    from core.integrators.lightpasses import LIGHT_PASSES
    scene = plane_scene(lights=[PointLight(position=np.array([0.0, 0.0, 1.0]), power=1e300)])
    scene.lightgroups = {"lights": ["lamp"], "instances": [""] * len(scene.instances), "world": ""}
    result = render(scene, RenderSettings(width=16, height=12, samples=4, kernels=kernels, integrator="path",
                                          passes=LIGHT_PASSES, light_groups=("lamp",), denoising_features=True))
    assert result.stats.kernels.startswith(kernels)
    for name in (*LIGHT_PASSES, "lightgroup:lamp", "denoising_albedo", "denoising_normal"):
        assert np.isfinite(result.aux[name]).all(), name


# An input out of its range and the value Cycles clamps it to (kernel/svm/closure.h: saturatef, fmaxf(ior, 1e-5)).
CLAMPED = [("PRINCIPLED", {"roughness": -0.5}, {"roughness": 0.0}),
           ("PRINCIPLED", {"roughness": 2.0}, {"roughness": 1.0}),
           ("GLOSSY", {"roughness": -1.0, "color": (0.8, 0.8, 0.8)}, {"roughness": 0.0, "color": (0.8, 0.8, 0.8)}),
           ("PRINCIPLED", {"ior": -1.0, "transmission": 1.0}, {"ior": 1e-5, "transmission": 1.0}),
           ("GLASS", {"ior": 0.0}, {"ior": 1e-5})]


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize("node,bad,clamped", CLAMPED)
def test_an_input_out_of_range_renders_as_the_value_cycles_clamps_it_to(kernels, node, bad, clamped):
    """Negative or above-1 roughness, an IOR of 0 or below: the same image as the clamped value, bit for bit."""
    def image(inputs):
        return rendered(plane_scene(nodes=[(node, (1.0, 1.0, 1.0), inputs)],
                                    lights=[PointLight(position=np.array([0.5, -0.5, 2.0]), power=200.0)]), kernels)[0]
    out_of_range = image(bad)
    assert np.isfinite(out_of_range).all()
    np.testing.assert_array_equal(out_of_range, image(clamped))
