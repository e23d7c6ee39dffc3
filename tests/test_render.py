"""The render loop: regions, auxiliary buffers, determinism, cancelling, progress, image files."""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pytest

from conftest import ortho_down, pixel_points_on_plane, sun_direction
from core.film import image_io
from core.geometry import primitives
from core import render
from core.camera import Camera
from core.scene import AreaLight, PointLight, RenderSettings, Scene, SpotLight, SunLight


def showcase_scene() -> Scene:
    """A ground plane, a smooth sphere and a box under a point, a spot, an area and a sun light."""
    scene = Scene(camera=Camera.look_at((0.0, -7.0, 3.5), (0.0, 0.0, 0.6), fov=math.radians(45)),
                  world_color=np.array([0.05, 0.06, 0.08]))
    scene.add_material((0.8, 0.8, 0.8))
    scene.add_material((0.8, 0.25, 0.2))
    scene.add_mesh(primitives.plane(20.0))
    scene.add_mesh(primitives.uv_sphere(0.8, 24, 12, center=(0.8, 0.0, 0.8)), materials=[1])
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(-1.2, 0.6, 0.5)))
    scene.lights += [
        PointLight(np.array([2.0, -2.0, 3.0]), power=300.0),
        SpotLight(np.array([-2.0, -2.0, 4.0]), np.array([0.4, 0.4, -1.0]) / math.sqrt(1.32), power=500.0,
                  spot_size=math.radians(50)),
        AreaLight(np.array([0.0, 2.0, 3.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                  np.array([0.0, 0.0, -1.0]), power=200.0, shape="DISK"),
        SunLight(sun_direction(30.0, 120.0), strength=0.3, angle=math.radians(5)),
    ]
    return scene


def test_same_seed_gives_the_same_image_whatever_the_threads_and_chunks():
    """Random numbers hash (seed, pixel, sample): thread count and chunk size cannot change the image."""
    scene = showcase_scene()
    base = RenderSettings(width=64, height=48, samples=4, light_samples=2, seed=7)
    a = render.render(scene, base).image
    b = render.render(scene, RenderSettings(**{**base.__dict__, "threads": 1, "chunk_size": 999})).image
    c = render.render(scene, RenderSettings(**{**base.__dict__, "seed": 8})).image
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert a[..., :3].mean() > 0.01


def test_two_renders_with_two_threads_are_bit_for_bit_equal():
    """A farm's frame must not depend on which thread finished first: adaptive passes (the noise test between them),
    first-hit passes and light passes, in chunks small enough that two threads finish them out of order, give the
    same bits twice on two threads and on one or three threads."""
    scene = showcase_scene()
    base = RenderSettings(width=48, height=36, samples=32, light_samples=1, seed=3, adaptive=True,
                          adaptive_min_samples=8, adaptive_threshold=0.02, chunk_size=600, threads=2,
                          passes=("average_normal", "diffuse_direct", "diffuse_color", "z_depth"))
    runs = [render.render(scene, base) for _ in range(2)]
    others = [render.render(scene, dataclasses.replace(base, threads=t)) for t in (1, 3)]
    counts = runs[0].stats.samples_per_pixel
    assert runs[0].stats.passes > 1 and counts.min() < counts.max()       # adaptive passes did run, over fewer pixels
    for result in runs[1:] + others:
        assert np.array_equal(result.image, runs[0].image)
        assert np.array_equal(result.stats.samples_per_pixel, counts)
        assert sorted(result.aux) == sorted(runs[0].aux) and len(result.aux) == 4
        for name, values in runs[0].aux.items():
            assert np.array_equal(result.aux[name], values), name


def test_small_passes_run_on_one_thread_and_large_ones_on_every_thread_within_the_chunk_size():
    """Threads only pay on enough samples each (render.PARALLEL_MIN_SAMPLES); a chunk never exceeds chunk_size samples."""
    least = render.PARALLEL_MIN_SAMPLES
    small = render._plan_chunks(pixels=least // 16, spp=16, chunk_size=1 << 16, threads=2)
    assert small[1] == 1
    large = render._plan_chunks(pixels=320 * 240, spp=16, chunk_size=1 << 16, threads=2)
    assert large[1] == 2 and large[0] * 16 <= 1 << 16
    some = render._plan_chunks(pixels=3 * least // 16, spp=16, chunk_size=1 << 20, threads=4)
    assert some[1] == 3 and -(-(3 * least // 16) // some[0]) >= 3     # three threads, a chunk each


def test_an_empty_region_renders_nothing_without_failing():
    """A render border of zero width leaves no pixel to sample: the image stays clear, no rays."""
    result = render.render(showcase_scene(), RenderSettings(width=16, height=12, samples=4, region=(3, 3, 3, 6)))
    assert result.stats.rays == 0 and not result.image.any()
    assert render._plan_chunks(pixels=0, spp=4, chunk_size=1 << 16, threads=2) == (1, 1)


def test_a_pass_is_cut_into_equal_chunks_every_thread_gets_as_many_of():
    """76,800 pixels of 4 samples in chunks of at most 65,536 samples on 2 threads: not 4 full chunks
    and a small fifth (one thread idle for a fifth of the pass) but 6 of 12,800 pixels."""
    per_chunk, workers = render._plan_chunks(pixels=76_800, spp=4, chunk_size=1 << 16, threads=2)
    assert (per_chunk, workers) == (12_800, 2)
    for pixels, spp, threads in [(76_800, 16, 2), (100_003, 8, 3), (5_000, 64, 4)]:
        per_chunk, workers = render._plan_chunks(pixels, spp, 1 << 16, threads)
        chunks = -(-pixels // per_chunk)
        assert per_chunk * spp <= 1 << 16 and chunks % workers == 0
        assert pixels - (chunks - 1) * per_chunk >= per_chunk - chunks     # the last chunk is nearly full


def test_region_renders_only_its_pixels():
    """A region (render border) fills exactly its rectangle with the same values as a full render."""
    scene = showcase_scene()
    full = render.render(scene, RenderSettings(width=40, height=30, samples=2)).image
    part = render.render(scene, RenderSettings(width=40, height=30, samples=2, region=(10, 5, 30, 20))).image
    inside = np.zeros((30, 40), bool)
    inside[5:20, 10:30] = True
    assert np.array_equal(part[inside], full[inside])
    assert np.count_nonzero(part[~inside]) == 0


def test_depth_buffer_is_distance_along_the_view_axis():
    """The depth buffer of a perspective view of a plane equals the hit point's distance along the camera axis."""
    camera = Camera.look_at((0.0, -4.0, 3.0), (0.0, 0.0, 0.0), fov=math.radians(50))
    scene = Scene(camera=camera)
    scene.add_mesh(primitives.plane(100.0))
    result = render.render(scene, RenderSettings(width=32, height=24, samples=1, jitter=False,
                                                 aux=("depth", "normal", "face_normal")))
    points = pixel_points_on_plane(camera, 32, 24, 0.0)
    expected = (points - camera.position) @ camera.forward
    np.testing.assert_allclose(result.aux["depth"][..., 0], expected, rtol=1e-6)
    np.testing.assert_allclose(result.aux["normal"], np.broadcast_to([0.0, 0.0, 1.0], (24, 32, 3)), atol=1e-12)


def test_background_shows_world_colour_and_alpha():
    """Pixels that hit nothing show the world colour with alpha 1, or alpha 0 with a transparent film."""
    scene = Scene(camera=ortho_down(scale=4.0), world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_mesh(primitives.plane(2.0))
    opaque = render.render(scene, RenderSettings(width=8, height=8, samples=1, jitter=False)).image
    np.testing.assert_allclose(opaque[0, 0], [0.1, 0.2, 0.3, 1.0], rtol=1e-6)
    clear = render.render(scene, RenderSettings(width=8, height=8, samples=1, jitter=False,
                                                transparent_background=True)).image
    assert clear[0, 0, 3] == 0.0 and clear[4, 4, 3] == 1.0


def test_visibility_and_n_dot_l_buffers_per_light():
    """Per-light buffers: N.L is the cosine law, visibility 0 inside the shadow of a box and 1 outside."""
    scene = Scene(camera=ortho_down(height=5.0, scale=10.0))
    scene.add_mesh(primitives.plane(10.0))
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(0.0, 0.0, 2.0)))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=1.0))
    scene.lights.append(SunLight(sun_direction(30.0), strength=1.0))      # comes from +x, 30 degrees up
    result = render.render(scene, RenderSettings(width=60, height=60, samples=1, jitter=False,
                                                 aux=("n_dot_l", "visibility")))
    n_dot_l, visible = result.aux["n_dot_l"], result.aux["visibility"]
    assert n_dot_l.shape == (60, 60, 2)
    np.testing.assert_allclose(n_dot_l[5, 5], [1.0, 0.5], rtol=1e-6)
    assert visible[5, 5].tolist() == [1.0, 1.0]
    # Ground at x = -3.5, y = 0: the low sun's ray towards +x passes through the box (z 1.5..2.5 at x -0.9..0.5).
    assert visible[30, 9].tolist() == [1.0, 0.0]
    # The camera sees the top of the box in the middle, lit by both suns.
    assert visible[30, 30].tolist() == [1.0, 1.0]


def test_cancel_returns_promptly():
    """A render whose cancel callback answers True stops within a fraction of a second and says so."""
    scene = showcase_scene()
    settings = RenderSettings(width=640, height=480, samples=64, chunk_size=1 << 14)
    start = time.perf_counter()
    result = render.render(scene, settings, cancel=lambda: time.perf_counter() - start > 0.2)
    elapsed = time.perf_counter() - start
    assert result.cancelled
    assert elapsed < 2.0
    assert result.image.shape == (480, 640, 4)


def test_progress_is_reported_up_to_completion():
    """Progress goes from above 0 to exactly 1, monotonically, with growing ray counts."""
    reports = []
    render.render(showcase_scene(), RenderSettings(width=64, height=64, samples=2, chunk_size=1024),
                  progress=lambda fraction, stats: reports.append((fraction, stats.rays)))
    fractions = [f for f, _ in reports]
    assert len(reports) > 4 and fractions == sorted(fractions) and fractions[-1] == 1.0
    assert reports[-1][1] > reports[0][1] > 0


def test_invalid_settings_and_missing_camera_are_clear_errors():
    """Rendering without a camera, or with nonsense settings, raises ValueError with a readable message."""
    with pytest.raises(ValueError, match="no camera"):
        render.render(Scene(camera=None), RenderSettings())
    with pytest.raises(ValueError, match="samples"):
        render.render(showcase_scene(), RenderSettings(samples=0))
    with pytest.raises(ValueError, match="shadow method"):
        render.render(showcase_scene(), RenderSettings(shadow_method="guess"))


def test_empty_scene_and_no_lights_render_the_world():
    """No meshes or no lights: the image is the world colour (and black surfaces), never an error."""
    empty = Scene(camera=ortho_down(), world_color=np.array([0.2, 0.2, 0.2]))
    image = render.render(empty, RenderSettings(width=8, height=8, samples=1)).image
    np.testing.assert_allclose(image[..., :3], 0.2, rtol=1e-6)
    dark = Scene(camera=ortho_down())
    dark.add_mesh(primitives.plane(10.0))
    image = render.render(dark, RenderSettings(width=8, height=8, samples=1)).image
    assert np.count_nonzero(image[..., :3]) == 0 and (image[..., 3] == 1).all()


def test_exr_is_linear_and_png_is_srgb(tmp_path):
    """EXR keeps scene-linear floats exactly; PNG stores the sRGB encoding (0.5 linear -> 188/255)."""
    rgba = np.zeros((4, 6, 4), np.float32)
    rgba[..., 0] = 0.5
    rgba[..., 1] = 2.5
    rgba[..., 3] = 1.0
    image_io.write_image(str(tmp_path / "a.exr"), rgba)
    np.testing.assert_array_equal(image_io.read_image(str(tmp_path / "a.exr")), rgba)
    image_io.write_image(str(tmp_path / "a.png"), rgba)
    import OpenImageIO as oiio
    raw = oiio.ImageBuf(str(tmp_path / "a.png")).get_pixels(oiio.UINT8)
    assert raw[0, 0].tolist() == [188, 255, 0, 255]


def test_spot_light_without_a_frame_lights_the_scene():
    """A SpotLight whose optional frame is None (an unscaled cone) is a valid light, not a NaN one."""
    scene = Scene(camera=ortho_down(scale=1.0))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.plane(2.0))
    scene.lights.append(SpotLight(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]), power=100.0,
                                  spot_size=math.radians(120.0), spot_blend=0.0))
    result = render.render(scene, RenderSettings(width=4, height=4, samples=1, jitter=False))
    assert result.stats.warnings == []
    assert (result.image[..., 0] > 0).all()


def test_objects_without_material_slots_and_with_their_own_render_in_their_colours():
    """Instances of one mesh with an empty slot table (default grey), their own table, or the mesh's indices."""
    scene = Scene(camera=ortho_down(scale=3.0, height=2.0), world_color=np.zeros(3))
    red = scene.add_material((1.0, 0.0, 0.0))
    green = scene.add_material((0.0, 1.0, 0.0))
    index = scene.add_mesh(primitives.plane(1.0, center=(-1.0, 0.0, 0.0)))          # mesh slot 0 -> red
    from core.scene import DEFAULT_BASE_COLOR, Instance
    for x, table in ((0.0, np.array([green])), (1.0, np.array([], np.int64))):
        matrix = np.eye(4)
        matrix[0, 3] = x + 1.0
        scene.instances.append(Instance(index, matrix, table, f"Plane {x}"))
    scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=math.pi))     # radiance = albedo
    image = render.render(scene, RenderSettings(width=3, height=1, samples=1, jitter=False)).image
    np.testing.assert_allclose(image[0, 0, :3], [1.0, 0.0, 0.0], rtol=1e-6)
    np.testing.assert_allclose(image[0, 1, :3], [0.0, 1.0, 0.0], rtol=1e-6)
    np.testing.assert_allclose(image[0, 2, :3], DEFAULT_BASE_COLOR[:3], rtol=1e-6)
