"""The ray inspector (core/teaching/inspector.py): one pixel's numbers against closed forms and against the renderer."""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ortho_down, pixel_points_on_plane, sun_direction, unit
from core.teaching import inspector
from core.geometry import primitives
from core import render
from core.integrators import shadows
from core.camera import Camera
from core.geometry.geometry import build_geometry
from core.scene import AreaLight, Mesh, PointLight, RenderSettings, Scene, SpotLight, SunLight

W, H = 16, 12
CAMERA_HEIGHT = 3.0
CLIP_START = 0.01
ALBEDO = np.array([0.6, 0.5, 0.4])


def floor_scene(*lights, camera=None) -> Scene:
    """A 20 x 20 floor at z = 0 of albedo ALBEDO, seen straight down by an orthographic camera 3 above it."""
    scene = Scene(camera=camera or ortho_down(height=CAMERA_HEIGHT, scale=4.0, clip_start=CLIP_START),
                  world_color=np.array([0.1, 0.2, 0.3]))
    scene.add_material(ALBEDO, "Floor")
    scene.add_mesh(primitives.plane(20.0), name="Floor")
    scene.lights.extend(lights)
    return scene


def settings(**kw) -> RenderSettings:
    """1 unjittered sample per pixel at W x H."""
    return RenderSettings(**{"width": W, "height": H, "samples": 1, "jitter": False, "light_samples": 1, **kw})


def floor_point(scene: Scene, x: int, y: int) -> np.ndarray:
    """Where the centre of pixel (x, y) meets the floor: (3,) float64 (tests/conftest.py, a closed form)."""
    return pixel_points_on_plane(scene.camera, W, H, 0.0)[y, x]


def test_point_light_on_a_plane_matches_the_lecture_closed_forms():
    """t = camera height - clip start, N = Ng = +Z, N.L = h / r, 1/r^2, and (albedo/pi) P/(4 pi r^2) N.L."""
    P = np.array([1.0, -0.5, 2.0])
    scene = floor_scene(PointLight(P, power=300.0, name="Key"))
    record = inspector.inspect_pixel(scene, settings(), 3, 2)
    I = floor_point(scene, 3, 2)
    r = np.linalg.norm(P - I)
    assert record.hit and record.valid and record.object_name == "Floor"
    assert record.t == pytest.approx(CAMERA_HEIGHT - CLIP_START, rel=1e-6)
    np.testing.assert_allclose(record.I, I, atol=1e-6)
    np.testing.assert_allclose(record.N, [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(record.Ng, [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(record.origin + record.t * record.direction, record.I, atol=1e-6)
    (light,) = record.lights
    assert light.name == "Key" and light.kind == "POINT" and not light.sampled
    np.testing.assert_allclose(light.L, (P - I) / r, atol=1e-6)
    assert light.distance == pytest.approx(r, rel=1e-6)
    assert light.n_dot_l == pytest.approx(P[2] / r, rel=1e-6)
    assert light.ng_dot_l == pytest.approx(P[2] / r, rel=1e-6)
    assert light.inverse_square == pytest.approx(1.0 / r ** 2, rel=1e-6)
    np.testing.assert_allclose(light.irradiance, 300.0 / (4 * math.pi * r * r), rtol=1e-6)
    assert light.cast and light.reason == inspector.CAST and light.occluded is False
    np.testing.assert_allclose(light.contribution, ALBEDO / math.pi * 300.0 / (4 * math.pi * r * r) * P[2] / r,
                               rtol=1e-6)
    np.testing.assert_allclose(record.radiance, light.contribution, rtol=1e-12)
    # The shadow ray runs from just above I to (just short of) the light.
    assert 0.0 < light.shadow_origin[2] - I[2] < 1e-5
    np.testing.assert_allclose(light.shadow_end, P, atol=1e-5)


def test_sun_has_no_distance_attenuation_and_n_dot_l_is_the_elevation_sine():
    """A sun at 30 degrees elevation: N.L = sin 30, 1/r^2 = None, r = inf, contribution albedo/pi S sin 30."""
    scene = floor_scene(SunLight(sun_direction(30.0, 45.0), strength=2.0, name="Sun"))
    (light,) = inspector.inspect_pixel(scene, settings(), 8, 6).lights
    assert light.inverse_square is None and light.light_point is None and math.isinf(light.distance)
    assert light.n_dot_l == pytest.approx(0.5, rel=1e-9)
    assert light.cast and light.occluded is False and not np.isfinite(light.shadow_end).all()
    np.testing.assert_allclose(light.contribution, ALBEDO / math.pi * 2.0 * 0.5, rtol=1e-9)


def test_blocker_between_hit_and_light_occludes_the_shadow_ray():
    """A small plate above the floor point, below the light: occluded, contribution 0, named object hit below."""
    scene = floor_scene()
    I = floor_point(scene, 8, 6)
    # The light is off to the side, so the plate halfway to it does not hide I from the camera above.
    scene.lights.append(PointLight(I + np.array([2.0, 0.0, 1.0]), power=100.0, name="Lamp"))
    blocker = primitives.plane(0.2, center=I + np.array([1.0, 0.0, 0.5]))
    scene.add_mesh(blocker, name="Blocker")
    record = inspector.inspect_pixel(scene, settings(), 8, 6)
    assert record.object_name == "Floor"
    (light,) = record.lights
    assert light.cast and light.occluded is True
    np.testing.assert_array_equal(light.contribution, 0.0)
    assert light.n_dot_l == pytest.approx(1.0 / math.sqrt(5.0), rel=1e-6)
    # Moving the blocker out of the way lets the light through.
    scene.instances[1].matrix[:3, 3] = [0.0, 3.0, 0.0]
    (light,) = inspector.inspect_pixel(scene, settings(), 8, 6).lights
    assert light.occluded is False and light.contribution.min() > 0.0


def test_light_behind_the_surface_casts_no_shadow_ray():
    """A light below the floor: N.L < 0, so no shadow ray (the lecture) and no contribution."""
    scene = floor_scene(PointLight(np.array([0.5, 0.0, -1.0]), power=100.0))
    (light,) = inspector.inspect_pixel(scene, settings(), 5, 5).lights
    assert not light.cast and light.reason == inspector.BEHIND_N
    assert light.occluded is None and light.shadow_origin is None and light.shadow_end is None
    assert light.n_dot_l < 0.0
    np.testing.assert_array_equal(light.contribution, 0.0)


def tilted_smooth_floor(light) -> Scene:
    """The floor with every corner normal tilted 30 degrees towards +x (a smooth, 'curved' surface)."""
    tilt = np.array([math.sin(math.radians(30.0)), 0.0, math.cos(math.radians(30.0))])
    base = primitives.plane(20.0)
    mesh = Mesh(base.vertices, base.triangles, smooth=True,
                corner_normals=np.broadcast_to(tilt, (len(base.triangles), 3, 3)))
    scene = Scene(camera=ortho_down(height=CAMERA_HEIGHT, scale=4.0, clip_start=CLIP_START))
    scene.add_material(ALBEDO)
    scene.add_mesh(mesh, name="Smooth")
    scene.lights.append(light)
    return scene


def test_light_behind_the_face_but_in_front_of_n_casts_no_shadow_ray():
    """Interpolated N for N.L, face normal for visibility: a light 5 degrees below the plane on N's side is not seen."""
    scene = tilted_smooth_floor(SunLight(sun_direction(-5.0, 0.0), strength=1.0))
    record = inspector.inspect_pixel(scene, settings(), 5, 5)
    (light,) = record.lights
    assert record.smooth
    np.testing.assert_allclose(record.N, [0.5, 0.0, math.cos(math.radians(30.0))], atol=1e-6)
    assert light.n_dot_l > 0.0 > light.ng_dot_l
    assert not light.cast and light.reason == inspector.BEHIND_FACE
    np.testing.assert_array_equal(light.contribution, 0.0)
    # With the terminator fix, smooth triangles leave that decision to the shadow ray.
    (light,) = inspector.inspect_pixel(scene, settings(terminator_fix=True), 5, 5).lights
    assert light.cast


def test_spot_outside_its_cone_sends_nothing_and_casts_no_shadow_ray():
    """A spot pointing away from the hit: E_normal = 0, so no shadow ray (as in direct_light)."""
    scene = floor_scene(SpotLight(np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 1.0]), power=100.0))
    (light,) = inspector.inspect_pixel(scene, settings(), 8, 6).lights
    assert light.n_dot_l > 0 and not light.cast and light.reason == inspector.NO_LIGHT


def test_epsilon_shadow_ray_starts_epsilon_along_l_and_stops_two_epsilon_short():
    """The lecture's shadow ray: O = I + eps L, t_max = r - 2 eps."""
    P = np.array([1.0, 1.0, 2.0])
    scene = floor_scene(PointLight(P, power=100.0))
    record = inspector.inspect_pixel(scene, settings(shadow_method="epsilon", epsilon=0.01), 4, 4)
    (light,) = record.lights
    np.testing.assert_allclose(light.shadow_origin, record.I + 0.01 * light.L, atol=1e-9)
    assert light.shadow_t_max == pytest.approx(light.distance - 0.02, rel=1e-9)


def test_robust_shadow_ray_starts_off_the_surface_along_the_face_normal():
    """The robust offset moves the origin along Ng by the float32 error bound of the hit."""
    P = np.array([1.0, 1.0, 2.0])
    scene = floor_scene(PointLight(P, power=100.0))
    s = settings()
    record = inspector.inspect_pixel(scene, s, 4, 4)
    (light,) = record.lights
    geometry = build_geometry(scene, scene.camera.position)
    I_rel = (record.I - geometry.origin)[None, :]
    vertices = geometry.vertices[geometry.triangles[[record.triangle]]].astype(np.float64)
    offset = shadows.error_bound(I_rel, vertices)[0]
    np.testing.assert_allclose(light.shadow_origin, record.I + offset * record.Ng, atol=1e-9)


def mixed_scene() -> Scene:
    """A perspective view of a floor, a box and a sphere under a point, a spot, a sun (all without extent)."""
    camera = Camera.look_at((0.5, -6.0, 3.0), (0.0, 0.0, 0.5), fov=math.radians(45))
    scene = Scene(camera=camera, world_color=np.array([0.05, 0.05, 0.1]))
    scene.add_material((0.8, 0.8, 0.8))
    scene.add_material((0.8, 0.2, 0.2))
    scene.add_mesh(primitives.plane(20.0), name="Floor")
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0), center=(-1.0, 0.5, 0.5)), name="Box")
    scene.add_mesh(primitives.uv_sphere(0.7, 16, 8, center=(1.0, 0.0, 0.7)), materials=[1], name="Ball")
    scene.meshes[-1].smooth[:] = True
    scene.lights += [
        PointLight(np.array([2.0, -2.0, 3.0]), power=400.0, name="Point"),
        SpotLight(np.array([-2.0, -2.0, 4.0]), unit([0.4, 0.4, -1.0]), power=600.0,
                  spot_size=math.radians(60), name="Spot"),
        SunLight(sun_direction(35.0, 150.0), strength=1.5, name="Sun"),
    ]
    return scene


@pytest.mark.parametrize("method", ["robust", "epsilon"])
def test_contributions_sum_to_the_rendered_pixel_of_an_unjittered_one_sample_render(method):
    """For lights without extent the inspector's sum is the 1-spp unjittered render, pixel by pixel."""
    scene = mixed_scene()
    s = settings(width=40, height=30, shadow_method=method, epsilon=1e-3)
    image = render.render(scene, s).image
    geometry = build_geometry(scene, scene.camera.position)
    seen = {"occluded": 0, "lit": 0, "behind": 0, "objects": set()}
    for y in range(0, 30, 3):
        for x in range(0, 40, 3):
            record = inspector.inspect_pixel(scene, s, x, y, geometry=geometry)
            np.testing.assert_allclose(record.radiance, image[y, x, :3], rtol=1e-5, atol=1e-7)
            seen["objects"].add(record.object_name)
            for light in record.lights:
                seen["occluded"] += light.occluded is True
                seen["lit"] += light.occluded is False
                seen["behind"] += not light.cast
    # The sampled pixels show every case the inspector distinguishes.
    assert seen["occluded"] and seen["lit"] and seen["behind"]
    assert {"Floor", "Box", "Ball", ""} <= seen["objects"]


def extended_scene() -> Scene:
    """The mixed scene with lights that have extent: a sphere light, a disk area light, a sun with an angle."""
    scene = mixed_scene()
    scene.lights = [
        PointLight(np.array([2.0, -2.0, 3.0]), power=400.0, radius=0.5, name="Sphere"),
        AreaLight(np.array([0.0, 1.0, 3.0]), np.array([1.5, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                  np.array([0.0, 0.0, -1.0]), power=300.0, shape="DISK", name="Disk"),
        SunLight(sun_direction(35.0, 150.0), strength=1.5, angle=math.radians(10.0), name="Sun"),
    ]
    return scene


@pytest.mark.parametrize("terminator_fix", [False, True])
def test_each_lights_share_is_albedo_over_pi_irradiance_cosine_visibility_and_they_sum_to_the_pixel(terminator_fix):
    """With one centre sample per light, each light's contribution is albedo / pi * E_normal * max(N.L, 0) * V
    * w_mis from the record's own numbers, and the contributions and the BSDF sample's light sum to the
    ray's radiance."""
    scene = extended_scene()
    s = settings(width=40, height=30, terminator_fix=terminator_fix)
    geometry = build_geometry(scene, scene.camera.position)
    checked = 0
    for y in range(0, 30, 3):
        for x in range(0, 40, 3):
            record = inspector.inspect_pixel(scene, s, x, y, geometry=geometry)
            if not record.hit:
                continue
            for light in record.lights:
                visibility = 1.0 if light.cast and not light.occluded else 0.0
                expected = (record.albedo / math.pi * light.irradiance * max(light.n_dot_l, 0.0) * visibility
                            * light.mis_weight)
                np.testing.assert_allclose(light.contribution, expected, rtol=1e-12, atol=1e-15)
                assert 0.0 <= light.mis_weight <= 1.0
            found = record.bsdf_sample[2] if record.bsdf_sample is not None else 0.0
            np.testing.assert_allclose(record.radiance, record.emission + sum(light.contribution for light in record.lights)
                                       + found, rtol=1e-12, atol=1e-15)
            checked += 1
    assert checked > 50


def test_lights_with_extent_are_inspected_at_their_centre():
    """The one sample of an area light is its centre; of a sphere light and a sun disk, the direction to the centre."""
    scene = extended_scene()
    record = inspector.inspect_pixel(scene, settings(width=40, height=30), 20, 20)
    sphere, disk, sun = record.lights
    assert sphere.sampled and disk.sampled and sun.sampled
    np.testing.assert_allclose(disk.light_point, [0.0, 1.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(sphere.L, unit(np.array([2.0, -2.0, 3.0]) - record.I), atol=1e-9)
    np.testing.assert_allclose(sun.L, -sun_direction(35.0, 150.0), atol=1e-12)
    assert disk.inverse_square == pytest.approx(1.0 / np.sum((disk.light_point - record.I) ** 2), rel=1e-9)


def test_miss_shows_the_world_and_fisheye_corner_is_black():
    """A ray that misses reports no hit and the world colour; outside a fisheye's circle no ray is traced."""
    scene = floor_scene(PointLight(np.array([0.0, 0.0, 2.0])))
    scene.camera = Camera.look_at((0.0, -5.0, 1.0), (0.0, 0.0, 3.0))     # looking up, over the floor
    record = inspector.inspect_pixel(scene, settings(), 8, 0)
    assert not record.hit and record.lights == () and record.I is None
    np.testing.assert_allclose(record.radiance, [0.1, 0.2, 0.3])
    matrix = np.eye(4)
    matrix[:3, 3] = [0.0, 0.0, 3.0]
    scene.camera = Camera(matrix_world=matrix, type="PANO", panorama_type="FISHEYE_EQUIDISTANT")
    corner = inspector.inspect_pixel(scene, settings(), 0, 0)
    assert not corner.valid and not corner.hit
    np.testing.assert_array_equal(corner.radiance, 0.0)
    assert inspector.inspect_pixel(scene, settings(), 8, 6).hit


def test_pixel_outside_the_image_is_a_clear_error():
    """Coordinates outside the image raise ValueError naming the valid range."""
    scene = floor_scene()
    with pytest.raises(ValueError, match="outside the 16x12 image"):
        inspector.inspect_pixel(scene, settings(), 16, 0)
    with pytest.raises(ValueError, match="outside"):
        inspector.inspect_pixel(scene, settings(), 0, -1)
    with pytest.raises(ValueError, match="whole numbers"):
        inspector.inspect_pixel(scene, settings(), 2.5, 1)


def test_triangles_know_their_object():
    """WorldGeometry.instance maps every triangle to its Scene.instances entry, also for shared meshes."""
    scene = floor_scene()
    box = scene.add_mesh(primitives.box(), name="BoxA")
    moved = np.eye(4)
    moved[:3, 3] = [3.0, 0.0, 0.0]
    scene.instances.append(type(scene.instances[0])(box, moved, None, "BoxB"))
    geometry = build_geometry(scene, np.zeros(3))
    names = [scene.instances[i].name for i in geometry.instance]
    assert names.count("Floor") == 2 and names.count("BoxA") == 12 and names.count("BoxB") == 12
    centres = geometry.vertices[geometry.triangles].mean(axis=1)
    assert np.all(centres[np.array(names) == "BoxB", 0] > 2.0)


@pytest.mark.parametrize("switch", [{"smooth_normals": False}, {"visibility_normal": "shading"},
                                    {"reduce_t_max": False, "shadow_method": "epsilon"},
                                    {"distance_attenuation": False}, {"clamp_n_dot_l": False},
                                    {"shadow_rays_for_backfacing": True}],
                         ids=lambda change: ",".join(change))
def test_inspector_follows_every_lecture_switch_as_the_render_does(switch):
    """With a lecture switch flipped, the inspector's sum is still the 1-spp unjittered render's pixel."""
    scene = mixed_scene()
    s = settings(width=40, height=30, **switch)
    image = render.render(scene, s).image
    geometry = build_geometry(scene, scene.camera.position)
    for y in range(0, 30, 3):
        for x in range(0, 40, 3):
            record = inspector.inspect_pixel(scene, s, x, y, geometry=geometry)
            np.testing.assert_allclose(record.radiance, image[y, x, :3], rtol=1e-5, atol=1e-7)


def test_the_inspector_shows_the_uv_the_texel_the_tangent_frame_and_the_closures_of_a_textured_hit():
    """A checker-textured plane with a tangent: at each inspected pixel the UV is the pixel centre's, the texel
    is the checker's value there (Closest), the tangent frame is the plane's (T = x, B = y, N = z), and the one
    closure is a diffuse of the texel's colour; the panel lists them."""
    from addon.inspector_view import panel_sections
    from test_textures import SIZE, checker, checker_value, diffuse_textured, pixel_uv, scene_of
    from core.materials import textures
    scene = scene_of(diffuse_textured(textures.Image(checker())), tangent=True)
    u, v = pixel_uv()
    for x, y in ((3, 5), (6, 1), (7, 7)):
        record = inspector.inspect_pixel(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, jitter=False), x, y)
        material = record.material
        np.testing.assert_allclose(material.uv, (u[y, x], v[y, x]), atol=1e-6)
        (texel,) = material.textures
        assert texel.image == "Image" and (texel.x, texel.y) == pytest.approx((u[y, x], v[y, x]), abs=1e-6)
        np.testing.assert_allclose(texel.rgba, [checker_value(u[y, x], v[y, x])] * 3 + [1.0], atol=1e-7)
        T, B, N = material.tangent_frame
        np.testing.assert_allclose(np.abs([T @ (1, 0, 0), B @ (0, 1, 0), N @ (0, 0, 1)]), 1.0, atol=1e-6)
        (closure,) = material.closures
        assert closure.bsdf == "DIFFUSE" and closure.alpha is None
        np.testing.assert_allclose(closure.weight, texel.rgba[:3], atol=1e-7)
        titles = dict(panel_sections(record))
        assert any(label.startswith("Texel") for label, _ in titles["Material"])
        assert ("Name", "Textured") in titles["Material"]


def test_a_lamp_not_linked_to_the_object_traces_no_shadow_ray_and_says_why():
    """Light Linking: a lamp that lights only receiver set 1 at a floor point in the default set 0 casts no shadow ray
    (the reason named) and brings nothing; linked to set 0, it lights the point."""
    scene = floor_scene()
    I = floor_point(scene, 8, 6)
    scene.lights.append(PointLight(I + np.array([0.5, 0.0, 1.0]), power=100.0, name="Lamp", light_membership=0b10))
    (light,) = inspector.inspect_pixel(scene, settings(), 8, 6).lights
    assert not light.cast and light.reason == inspector.SKIPPED
    assert light.contribution.max() == 0.0
    scene.lights[0].light_membership = 0b1
    (linked,) = inspector.inspect_pixel(scene, settings(), 8, 6).lights
    assert linked.cast and linked.contribution.min() > 0.0


def test_a_lamp_without_cast_shadow_traces_no_shadow_ray_and_lights_the_point_behind_a_blocker():
    """Cast Shadow off (Cycles' light.use_shadow): the inspector shows no shadow ray (cast False, occluded None, the
    reason named) and the floor point behind the blocker gets the lamp's unblocked share, as the render does."""
    scene = floor_scene()
    I = floor_point(scene, 8, 6)
    scene.lights.append(PointLight(I + np.array([2.0, 0.0, 1.0]), power=100.0, name="Lamp", cast_shadow=False))
    scene.add_mesh(primitives.plane(0.2, center=I + np.array([1.0, 0.0, 0.5])), name="Blocker")
    (light,) = inspector.inspect_pixel(scene, settings(), 8, 6).lights
    assert not light.cast and light.reason == inspector.NO_SHADOW
    assert light.occluded is None and light.shadow_origin is None
    assert light.contribution.min() > 0.0


def test_with_depth_of_field_the_inspected_ray_leaves_its_lens_point_for_the_focal_plane():
    """A camera 3 above the floor with a lens of radius 0.4 focused on the floor: the inspected ray leaves from a
    point within the aperture, the render's sample-0 lens point (offset from the eye by it, across the view), and
    still meets the floor where the pinhole ray through the pixel's centre does (the floor is the focal plane)."""
    pinhole = Camera.look_at((0.0, 0.0, CAMERA_HEIGHT), (0.0, 0.001, 0.0), fov=math.radians(40))
    lens = Camera.look_at((0.0, 0.0, CAMERA_HEIGHT), (0.0, 0.001, 0.0), fov=math.radians(40), aperture_size=0.4,
                          focus_distance=CAMERA_HEIGHT)
    sharp = inspector.inspect_pixel(floor_scene(camera=pinhole), settings(), 5, 4)
    record = inspector.inspect_pixel(floor_scene(camera=lens), settings(), 5, 4)
    assert sharp.lens is None and record.lens is not None
    assert 0.0 < np.linalg.norm(record.lens) <= 0.4
    R = np.asarray(lens.matrix_world, np.float64)[:3, :3]
    start = record.origin - record.camera_point                 # (the ray starts at the clip distance: back along it
    on_lens = start - (start @ R[:, 2]) / (record.direction @ R[:, 2]) * record.direction   # to the lens plane)
    np.testing.assert_allclose(on_lens, R[:, :2] @ record.lens, atol=1e-9)
    np.testing.assert_allclose(record.I, sharp.I, atol=1e-5)
    assert not np.allclose(record.direction, sharp.direction)


def test_the_inspector_shows_what_each_node_computed_at_the_hit():
    """A plane whose Diffuse colour is 2 u + 0.1 of its UV, through named nodes (Texture Coordinate 'Coords' ->
    Separate XYZ 'Split' -> Math 'Twice' (multiply by 2) -> Math 'Lift' (add 0.1)): at each inspected pixel each
    node's output is its closed form at the pixel centre's UV (u, v), the diffuse closure's weight is Lift's value,
    and the panel lists every node; an unnamed node is not listed."""
    from addon.inspector_view import panel_sections
    from test_textures import SIZE, pixel_uv, scene_of
    from core.materials.graph import GraphNode, Link
    from core.scene import Material
    coords = GraphNode("TEXCOORD", {}, {}, "Coords")
    split = GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(coords, "UV")}, "Split")
    twice = GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": Link(split, "X"), "1": 2.0}, "Twice")
    lift = GraphNode("MATH", {"operation": "ADD"}, {"0": Link(twice, "Value"), "1": 0.1}, "Lift")
    grey = GraphNode("COMBINE_XYZ", {}, {"X": Link(lift, "Value"), "Y": Link(lift, "Value"), "Z": Link(lift, "Value")})
    material = Material(name="Ramp", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {}, [(Link(grey, "Vector"), "color")])])
    scene = scene_of(material)
    u, v = pixel_uv()
    for x, y in ((1, 6), (5, 2)):
        record = inspector.inspect_pixel(scene, RenderSettings(width=SIZE, height=SIZE, samples=1, jitter=False), x, y)
        values = {(n.node, n.output): n.value for n in record.material.nodes}
        assert set(values) == {("Coords", "UV"), ("Split", "X"), ("Twice", "Value"), ("Lift", "Value")}
        np.testing.assert_allclose(values[("Coords", "UV")], (u[y, x], v[y, x], 0.0), atol=1e-6)
        np.testing.assert_allclose(values[("Split", "X")], [u[y, x]], atol=1e-6)
        np.testing.assert_allclose(values[("Twice", "Value")], [2.0 * u[y, x]], atol=2e-6)
        np.testing.assert_allclose(values[("Lift", "Value")], [2.0 * u[y, x] + 0.1], atol=2e-6)
        (closure,) = record.material.closures
        np.testing.assert_allclose(closure.weight, values[("Lift", "Value")][0], atol=1e-6)
        labels = [label for label, _ in dict(panel_sections(record))["Material"]]
        assert {"Node 'Coords' UV", "Node 'Split' X", "Node 'Twice' Value", "Node 'Lift' Value"} <= set(labels)


def test_the_inspector_and_the_diagram_show_where_a_medium_scatters_along_the_ray():
    """A scattering slab (0.6 deep, its top at z = 1.3) under a sun and a point lamp, seen from straight above: the
    inspected ray scatters at a free-flight point on the ray inside the slab, and at an equi-angular point for the
    lamp, both on the camera ray between the slab's faces; the panel lists them; the ray diagram of the row draws
    them (its magenta crosses)."""
    from addon.inspector_view import panel_sections
    from test_volumes import camera_above, fog
    from core.teaching import diagram
    scene = Scene(camera=camera_above())
    scene.materials.append(fog(closure="SCATTER", color=np.array([0.5, 1.0, 2.0]), density=1.0))
    scene.add_mesh(primitives.box((40.0, 40.0, 0.6), center=(0.0, 0.0, 1.0)), materials=np.array([0]))
    scene.lights.append(SunLight(direction=np.array([0.0, -0.6, -0.8]), strength=3.0))
    scene.lights.append(PointLight(np.array([0.3, 0.0, 2.0]), power=100.0, name="Lamp"))
    s = RenderSettings(width=8, height=8, samples=1, jitter=False, integrator="path")
    record = inspector.inspect_pixel(scene, s, 3, 4)
    kinds = [point.kind for point in record.scattering]
    assert kinds.count("free flight") == 1 and kinds.count("equi-angular") == 1, kinds
    for point in record.scattering:
        t = (point.P - record.origin) @ record.direction
        np.testing.assert_allclose(point.P, record.origin + t * record.direction, atol=1e-9)   # on the camera ray
        assert 0.7 - 1e-9 <= point.P[2] <= 1.3 + 1e-9
    assert len(dict(panel_sections(record))["Medium"]) == 2
    picture = diagram.ray_diagram(scene, s, row=4, every=2, size=128)
    assert any(segment.kind == "scatter" and len(segment.start) for segment in picture.segments)
    assert np.any(np.all(np.abs(picture.image[..., :3] - diagram.COLORS["scatter"]) < 1e-6, axis=-1))
