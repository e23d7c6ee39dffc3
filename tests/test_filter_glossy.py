"""Cycles' Filter Glossy (Light Paths > Filter Glossy, core/integrators/path.py filter_glossy_roughness): after
bounces of small pdf a path's microfacet lobes are made at least 0.5 sqrt(1 - min pdf / filter) rough (Cycles'
shader_bsdf_blur). Held to the rule itself, closure by closure, and the two kernels to each other."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core import materials, render
from core.camera import Camera
from core.geometry import primitives
from core.integrators.path import filter_glossy_roughness
from core.lights import SunLight
from core.materials import microfacet as mf
from core.materials.glass import Glass
from core.materials.microfacet import Microfacet
from core.materials.mirror import Mirror
from core.materials.rough_glass import RoughGlass
from core.scene import RenderSettings, Scene


def test_a_diffuse_bounce_makes_every_later_glossy_lobe_at_least_half_root_of_one_minus_its_pdf_rough():
    """A Lambert bounce's pdf is cos / pi: with Filter Glossy 1 the next hit's lobes are raised to
    0.5 sqrt(1 - cos / pi); a singular bounce (pdf inf), no bounce yet (inf) or the setting off blur nothing, and a
    filter of 0.5 blurs only below pdf 0.5."""
    pdf = np.array([1.0 / np.pi, 0.1, np.inf, 2.0, 0.4])
    np.testing.assert_allclose(filter_glossy_roughness(1.0, pdf),
                               [0.5 * np.sqrt(1.0 - 1.0 / np.pi), 0.5 * np.sqrt(0.9), 0.0, 0.0, 0.5 * np.sqrt(0.6)])
    np.testing.assert_allclose(filter_glossy_roughness(0.5, pdf)[[1, 4]], [0.5 * np.sqrt(0.8), 0.5 * np.sqrt(0.2)])
    assert filter_glossy_roughness(0.0, pdf) is None


def closures(node: str, blur: float, **inputs):
    """The closures (kind, params) of one head-on hit of a Glossy or Glass node with `inputs`, blurred by `blur`."""
    cls = {"GLOSSY": materials.nodes.GlossyNode, "GLASS": materials.nodes.GlassNode}[node]
    N = np.array([[0.0, 0.0, 1.0]])
    result = materials.nodes.shade_nodes([(cls, np.ones(3), cls.row(inputs))], N, N, blur=np.array([blur]))
    c = result.closures
    kept = c.kind[0] >= 0
    return c.kind[0][kept], c.params[0][kept]


def test_a_blurred_mirror_is_a_ggx_lobe_of_the_blur_and_a_rough_lobe_keeps_the_larger_roughness():
    """Roughness 0 (a mirror) blurred by 0.3 is a GGX lobe of alpha 0.3 (its Fresnel not folded into its weight);
    roughness 0.8 (alpha 0.64) stays 0.64; smooth glass blurred is rough glass of alpha 0.3, and nothing changes
    without a blur."""
    kind, p = closures("GLOSSY", 0.3, roughness=0.0)
    assert list(kind) == [Microfacet.kind] and p[0, mf.ALPHA] == pytest.approx(0.3)
    assert p[0, mf.ALPHA_Y] == pytest.approx(0.3)
    kind, p = closures("GLOSSY", 0.3, roughness=0.8)
    assert list(kind) == [Microfacet.kind] and p[0, mf.ALPHA] == pytest.approx(0.64)
    kind, p = closures("GLOSSY", 0.0, roughness=0.0)
    assert list(kind) == [Mirror.kind]
    kind, p = closures("GLASS", 0.3, roughness=0.0)
    assert list(kind) == [RoughGlass.kind] and p[0, mf.ALPHA] == pytest.approx(0.3)
    kind, p = closures("GLASS", 0.0, roughness=0.0)
    assert list(kind) == [Glass.kind]


def mirror_ball_on_a_floor() -> Scene:
    """A smooth metal ball on a white diffuse floor under a sun, seen from above at an angle: the floor sees the
    ball (and the sun's caustic) only after a diffuse bounce, which Filter Glossy blurs."""
    matrix = np.eye(4)
    angle = np.radians(50.0)
    matrix[:3, :3] = [[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]]
    matrix[:3, 3] = [0.0, -3.0, 2.6]
    scene = Scene(camera=Camera(matrix_world=matrix, lens=35.0))
    scene.materials.append(materials.Material(name="floor", nodes=[("DIFFUSE", (0.8, 0.8, 0.8), {})]))
    scene.materials.append(materials.Material(name="ball", nodes=[("GLOSSY", (0.9, 0.7, 0.5), {"roughness": 0.0})]))
    scene.add_mesh(primitives.plane(8.0), materials=np.array([0]))
    scene.add_mesh(primitives.uv_sphere(0.6, 24, 12, center=(0.0, 0.0, 0.6)), materials=np.array([1]))
    scene.lights.append(SunLight(direction=np.array([-0.3, 0.2, -1.0]), strength=3.0))
    return scene


def test_both_kernels_blur_the_same_and_the_blur_changes_the_light_the_floor_gets_from_the_ball():
    """Path traced with two bounces, Filter Glossy 1: the reference and the compiled kernel give the same pixels,
    and they differ from the image without the filter (the ball seen from the floor is blurred)."""
    settings = RenderSettings(width=16, height=12, samples=8, integrator="path", max_bounces=2, filter_glossy=1.0)
    scene = mirror_ball_on_a_floor()
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy")).image[..., :3]
    compiled = render.render(scene, settings).image[..., :3]
    np.testing.assert_allclose(compiled, reference, rtol=1e-6, atol=1e-7)
    sharp = render.render(scene, dataclasses.replace(settings, filter_glossy=0.0)).image[..., :3]
    assert np.abs(sharp - compiled).max() > 1e-3


def test_the_blur_raises_chiangs_variances_and_huangs_roughness_but_not_the_tilt_nor_the_old_hair_bsdf():
    """Cycles' bsdf_hair_chiang_blur / bsdf_hair_huang_blur: a blur of 0.3 makes Chiang's v, s and m0 at least 0.3
    (the cuticle tilt alpha kept, larger values kept), Huang's roughness at least 0.3, and leaves the Hair BSDF's
    Reflection and Transmission (not in Cycles' bsdf_blur) as they were."""
    from core.materials import hair, huang
    for cls, blurred in ((hair.ChiangHair, {"v": 0.3, "s": 0.3, "m0": 0.3}), (huang.HuangHair, {"roughness": 0.3}),
                         (hair.HairReflection, {}), (hair.HairTransmission, {})):
        params = np.zeros((2, materials.base.PARAMS))
        params[:, :len(cls.params)] = 0.01 * (1 + np.arange(len(cls.params)))
        params[1, :len(cls.params)] += 0.5                               # (the second row rougher than the blur)
        row = params.copy()
        materials.nodes.roughen(np.full(2, cls.kind), params, np.full(2, 0.3))
        expect = row.copy()
        for name, value in blurred.items():
            expect[0, cls.params.index(name)] = value
        np.testing.assert_array_equal(params, expect, err_msg=cls.name)


@pytest.mark.parametrize("node", ["PRINCIPLED_HAIR", "PRINCIPLED_HAIR_HUANG"])
def test_both_kernels_blur_a_hair_ball_the_same_and_the_blur_changes_what_the_floor_sees(node):
    """The ball shaded with Chiang's or Huang's Principled Hair (a mesh: Cycles' hair on triangles), roughness 0.05,
    Filter Glossy 1: reference and compiled kernel agree (Huang's: but for the few pixels where its eval's quadrature,
    seeded by the directions' bits, draws another estimate; tests/test_hair.py), and differ from the image without
    the filter."""
    settings = RenderSettings(width=12, height=10, samples=6, integrator="path", max_bounces=2, filter_glossy=1.0)
    scene = mirror_ball_on_a_floor()
    inputs = {"roughness": 0.05, **({"radial_roughness": 0.05} if node == "PRINCIPLED_HAIR" else {})}
    scene.materials[1] = materials.Material(name="ball", nodes=[(node, (1.0, 1.0, 1.0), inputs)])
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy")).image[..., :3]
    compiled = render.render(scene, settings).image[..., :3]
    if node == "PRINCIPLED_HAIR_HUANG":
        assert np.isclose(compiled, reference, rtol=1e-6, atol=1e-7).all(axis=2).mean() > 0.95
        assert abs(compiled.mean() / reference.mean() - 1.0) < 0.01
    else:
        np.testing.assert_allclose(compiled, reference, rtol=1e-6, atol=1e-7)
    sharp = render.render(scene, dataclasses.replace(settings, filter_glossy=0.0)).image[..., :3]
    assert np.abs(sharp - compiled).max() > 1e-2
