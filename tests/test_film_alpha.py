"""The film's alpha and background, as Cycles writes them: fisheye corners, world, transparent film."""
from __future__ import annotations

import numpy as np
import pytest

from core.geometry import primitives
from core import render
from core.camera import Camera
from core.materials import Material
from core.scene import RenderSettings, Scene, SunLight, World


def fisheye_scene() -> Scene:
    """A sunlit 2 x 2 plane seen from 3 above through a 180-degree equidistant fisheye on a wide image."""
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 3.0)
    scene = Scene(camera=Camera(matrix_world=matrix, type="PANO", panorama_type="FISHEYE_EQUIDISTANT"),
                  world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_mesh(primitives.plane(2.0))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=1.0))
    return scene


def test_fisheye_corners_are_opaque_black_and_misses_show_the_world():
    """Outside the image circle: (0, 0, 0, 1); a miss inside it: the world colour, alpha 1."""
    image = render.render(fisheye_scene(), RenderSettings(width=40, height=20, samples=4)).image
    np.testing.assert_array_equal(image[0, 0], [0.0, 0.0, 0.0, 1.0])          # corner, outside the circle
    np.testing.assert_allclose(image[10, 6], [0.1, 0.2, 0.3, 1.0], rtol=1e-6)  # inside the circle, the sky
    np.testing.assert_allclose(image[10, 20], [0.8 / np.pi] * 3 + [1.0], rtol=1e-6)   # the plane, straight down
    np.testing.assert_array_equal(image[..., 3], 1.0)


def test_transparent_film_clears_the_world_but_not_the_fisheye_corners():
    """With a transparent film a miss is (0, 0, 0, 0) (premultiplied); the corners stay opaque black."""
    image = render.render(fisheye_scene(), RenderSettings(width=40, height=20, samples=4,
                                                          transparent_background=True)).image
    np.testing.assert_array_equal(image[0, 0], [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(image[10, 6], [0.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(image[10, 20], [0.8 / np.pi] * 3 + [1.0], rtol=1e-6)


def pane_before_the_world() -> Scene:
    """A clear Transparent pane of colour (0.3, 0.6, 0.9) filling the view of an orthographic camera 3 above it, and
    the world_color (0.1, 0.2, 0.3) behind it: a world the camera sees and that lights nothing; a sun."""
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 3.0)
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=1.0),
                  world_color=np.array([0.1, 0.2, 0.3]))
    scene.materials.append(Material(np.zeros(3), "Pane", nodes=[("TRANSPARENT", np.array([0.3, 0.6, 0.9]), {})]))
    scene.add_mesh(primitives.plane(4.0), materials=np.array([0]))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=1.0))     # (a clear pane reflects none of it)
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_path_through_a_clear_pane_sees_the_world_the_camera_sees(kernels):
    """Cycles keeps a camera ray's flags through transparent surfaces: a world visible to the camera only shows
    through the pane, times its colour, (0.03, 0.12, 0.27) with alpha 1; with a transparent film it shows nothing and
    the film is as clear as the pane lets light through: alpha 1 - mean(0.3, 0.6, 0.9) = 0.4 (Cycles' average of the
    escaping throughput), with no warning."""
    scene = pane_before_the_world()
    image = render.render(scene, RenderSettings(width=4, height=4, samples=2, kernels=kernels)).image
    np.testing.assert_allclose(image[..., :3], np.broadcast_to([0.03, 0.12, 0.27], (4, 4, 3)), rtol=1e-6)
    np.testing.assert_allclose(image[..., 3], 1.0, rtol=1e-6)
    for integrator in ("path", "direct"):
        clear = render.render(scene, RenderSettings(width=4, height=4, samples=2, kernels=kernels,
                                                    integrator=integrator, transparent_background=True))
        np.testing.assert_allclose(clear.image[..., :3], 0.0, atol=1e-7)
        np.testing.assert_allclose(clear.image[..., 3], 0.4, rtol=1e-6)
        assert not any("Film > Transparent" in warning for warning in clear.stats.warnings), clear.stats.warnings


def test_a_pane_part_transparent_clears_the_film_by_its_transparent_share_in_both_kernels():
    """A pane of 0.7 Transparent (0.3, 0.6, 0.9) + 0.3 Diffuse (0.8, 0.5, 0.2) under the sun, transparent film: alpha
    1 - 0.7 x 0.6 = 0.58 on average, the colour the diffuse share's sunlight alone; Python and C agree."""
    scene = pane_before_the_world()
    scene.materials[0] = Material(np.zeros(3), "Pane", nodes=[("TRANSPARENT", 0.7 * np.array([0.3, 0.6, 0.9]), {}),
                                                              ("DIFFUSE", 0.3 * np.array([0.8, 0.5, 0.2]), {})])
    images = [render.render(scene, RenderSettings(width=8, height=8, samples=64, kernels=kernels,
                                                  integrator="path", transparent_background=True)).image
              for kernels in ("numpy", "compiled")]
    for image in images:
        assert image[..., 3].mean() == pytest.approx(0.58, abs=0.01)
        np.testing.assert_allclose(image[..., :3].mean(axis=(0, 1)), 0.3 * np.array([0.8, 0.5, 0.2]) / np.pi,
                                   rtol=1e-6)
    np.testing.assert_allclose(images[0], images[1], atol=1e-9)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_a_ray_portal_or_an_absorbing_slab_clears_the_film_by_what_it_lets_through(kernels, integrator):
    """A Ray Portal pane of colour (0.3, 0.6, 0.9) in place (a transparent bounce in Cycles): alpha 0.4, black, no
    warning; a volume-only slab 0.7 deep absorbing density 1.5 (1 - (0.2, 0.5, 0.8)): alpha 1 - mean(exp(-1.5 (1 -
    colour) 0.7)), black, no warning (Cycles' alpha: 1 - the mean transmittance, measured the same)."""
    from test_volumes import COLOR, camera_above, fog
    settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator=integrator,
                              transparent_background=True)
    portal = pane_before_the_world()
    portal.materials[0] = Material(np.zeros(3), "Portal", nodes=[("RAY_PORTAL", np.array([0.3, 0.6, 0.9]), {})])
    result = render.render(portal, settings)
    np.testing.assert_allclose(result.image, np.broadcast_to([0.0, 0.0, 0.0, 0.4], (4, 4, 4)), atol=1e-7)
    assert not any("Film > Transparent" in warning for warning in result.stats.warnings)
    slab = Scene(camera=camera_above(), world_color=np.array([0.1, 0.2, 0.3]))
    slab.materials.append(fog(color=COLOR, density=1.5))
    slab.add_mesh(primitives.box((4.0, 4.0, 0.7), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    result = render.render(slab, settings)
    np.testing.assert_allclose(result.image[..., :3], 0.0, atol=1e-7)
    np.testing.assert_allclose(result.image[..., 3], 1.0 - np.exp(-1.5 * (1.0 - COLOR) * 0.7).mean(), atol=1e-6)
    assert not any("Film > Transparent" in warning for warning in result.stats.warnings)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["path", "direct"])
def test_the_worlds_volume_hides_the_background_by_what_it_absorbs_on_the_way_to_infinity(kernels, integrator):
    """A world absorbing with colour (1, 1, 0.2) (sigma_a = d (0, 0, 0.8)) lets nothing through to infinity in blue
    and all in red and green: a camera ray that misses every surface leaves alpha 1 - mean(0 | 1) = 1/3, and through
    a volume-only slab in front 1 - mean((1, 1, 0) exp(-1.5 (1 - colour) 0.7)), the world's absorption before the
    slab included; Cycles 5.0 measured the same (1/3 at the sky)."""
    from test_volumes import COLOR, camera_above, fog
    settings = RenderSettings(width=4, height=4, samples=2, kernels=kernels, integrator=integrator,
                              transparent_background=True)
    world = World(color=np.array([0.1, 0.2, 0.3]),
                  volume=[("ABSORPTION", 1.0, {"color": np.array([1.0, 1.0, 0.2]), "density": 0.05})])
    sky = Scene(camera=camera_above())
    sky.world = world
    sky.add_mesh(primitives.plane(0.1, center=(5.0, 5.0, -1.0)))      # (a mesh far outside the view)
    image = render.render(sky, settings).image
    np.testing.assert_allclose(image, np.broadcast_to([0.0, 0.0, 0.0, 1.0 / 3.0], (4, 4, 4)), atol=1e-7)
    slab = Scene(camera=camera_above())
    slab.world = world
    slab.materials.append(fog(color=COLOR, density=1.5))
    slab.add_mesh(primitives.box((4.0, 4.0, 0.7), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    image = render.render(slab, settings).image
    through = np.array([1.0, 1.0, 0.0]) * np.exp(-1.5 * (1.0 - COLOR) * 0.7)
    np.testing.assert_allclose(image[..., 3], 1.0 - through.mean(), atol=1e-6)


def glass_sheet(roughness: float) -> Scene:
    """A glass sheet (IOR 1.5, one face) filling an orthographic camera's view from 3 above, under a white world."""
    matrix = np.eye(4)
    matrix[:3, 3] = (0.0, 0.0, 3.0)
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=1.0),
                  world=World(color=np.array([1.0, 1.0, 1.0])))
    scene.materials.append(Material(np.zeros(3), "Glass", nodes=[("GLASS", (1.0, 1.0, 1.0),
                                                                   {"ior": 1.5, "roughness": roughness})]))
    scene.add_mesh(primitives.plane(4.0), materials=np.array([0]))
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_transparent_glass_clears_the_film_by_the_light_the_glass_lets_through(kernels):
    """Film > Transparent Glass (Cycles' LABEL_TRANSMIT_TRANSPARENT): a camera path through a smooth sheet keeps the
    film clear, so the white world behind it is alpha, not colour: alpha = colour = R = ((1.5 - 1) / 2.5)^2 = 0.04
    (the reflected share sees the world above), where without it the film is opaque and white. A sheet of roughness
    0.3 is clear under a threshold of 0.5 (alpha_x alpha_y = 0.3^4 <= 0.5^4) and opaque under 0.2."""
    def film(roughness, threshold):
        settings = RenderSettings(width=8, height=8, samples=256, kernels=kernels, integrator="path", max_bounces=4,
                                  transparent_background=True, transparent_glass=threshold, adaptive=False)
        image = render.render(glass_sheet(roughness), settings).image.astype(np.float64)
        return image[..., :3].mean(), image[..., 3].mean()
    colour, alpha = film(0.0, 0.0)
    assert alpha == pytest.approx(0.04, abs=0.006) and colour == pytest.approx(alpha, abs=1e-6)
    colour, alpha = film(0.0, -1.0)                 # (off: the film only clears where the world is seen directly)
    assert alpha == 1.0 and colour == pytest.approx(1.0, abs=1e-6)
    assert film(0.3, 0.5)[1] < 0.2 and film(0.3, 0.2)[1] == 1.0
