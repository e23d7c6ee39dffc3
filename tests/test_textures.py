"""Materials from node graphs: image textures, texture coordinates, normal maps, bump, vertex colours,
object random and the colour nodes, each checked against a closed form on both paths (the compiled C
and the numpy reference), and the two paths against each other for every op.

The scenes look straight down at a 2 x 2 plane (UV 0..1 across it) lit by a sun from straight above
with irradiance E: a diffuse pixel is albedo / pi x E x N.L, an emitting one its emission.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ortho_down
from core import render
from core.geometry import primitives
from core.materials import Material, graph, textures
from core.materials.graph import GraphNode, Link
from core.materials.procedural import hash as hash_
from core.scene import Instance, RenderSettings, Scene, SunLight

E = 2.0
KERNELS = ["compiled", "numpy"]
SIZE = 8


def plane_attributes(mesh, tangent: bool = False, colors=None) -> dict:
    """Per-corner UVs of a plane mapping its extent onto 0..1, and optionally the tangent (+x, sign 1) and
    vertex colours (v, 4) per vertex."""
    v, t = mesh.vertices, mesh.triangles
    lo, hi = v.min(axis=0), v.max(axis=0)
    uv = (v[:, :2] - lo[:2]) / (hi - lo)[:2]
    out = {"uv:": np.concatenate([uv[t], np.zeros((len(t), 3, 1))], axis=2)}
    if tangent:
        out["tangent:"] = np.broadcast_to([1.0, 0.0, 0.0, 1.0], (len(t), 3, 4)).copy()
    if colors is not None:
        out["color:"] = np.asarray(colors, np.float64)[t]
    return out


def scene_of(material: Material, tangent: bool = False, colors=None, sun: bool = True) -> Scene:
    """The plane with `material` under the camera (and the sun)."""
    scene = Scene(camera=ortho_down(height=2.0, scale=2.0))
    scene.materials.append(material)
    mesh = primitives.plane(2.0)
    mesh.attributes = plane_attributes(mesh, tangent, colors)
    scene.add_mesh(mesh, materials=np.array([0]))
    if sun:
        scene.lights.append(SunLight(np.array([0.0, 0.0, -1.0]), strength=E))
    return scene


def shoot(scene: Scene, kernels: str, size: int = SIZE) -> np.ndarray:
    """The rendered RGB (size, size, 3), one sample per pixel at its centre's ray (orthographic, so every
    sample of a pixel sees the same point only with an unjittered camera: we use the pixel's mean)."""
    return render.render(scene, RenderSettings(width=size, height=size, samples=1, kernels=kernels)).image[..., :3]


def check_varying(scene: Scene, kernels: str, expected: np.ndarray, atol: float = 1e-6) -> None:
    """A value that varies across pixels: the reference path, unjittered (rays through the pixel
    centres), renders the closed form; the compiled path (always jittered) renders what the
    reference renders jittered."""
    if kernels == "numpy":
        settings = RenderSettings(width=SIZE, height=SIZE, samples=1, kernels="numpy", jitter=False)
        np.testing.assert_allclose(render.render(scene, settings).image[..., :3], expected, atol=atol)
    else:
        settings = RenderSettings(width=SIZE, height=SIZE, samples=4)
        compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
        reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
        assert compiled.stats.kernels == "compiled"
        np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
        np.testing.assert_allclose(compiled.image[..., :3], expected, atol=0.1)


def pixel_uv(size: int = SIZE):
    """The UV at each pixel centre of the plane seen by shoot: (size, size) u, v (image row 0 at the top)."""
    centres = (np.arange(size) + 0.5) / size
    return np.meshgrid(centres, 1.0 - centres)


def checker(n: int = 4, dark: float = 0.2, light: float = 0.8) -> np.ndarray:
    """An n x n checker (h, w, 4) float32, bottom row first: texel (i, j) is light where i + j is odd."""
    i, j = np.mgrid[0:n, 0:n]
    grey = np.where((i + j) % 2 == 1, light, dark).astype(np.float32)
    return np.dstack([grey, grey, grey, np.ones_like(grey)])


def diffuse_textured(image: textures.Image, interpolation="Closest", vector=None) -> Material:
    """A Diffuse BSDF whose colour is the image."""
    node = GraphNode("IMAGE", {"image": image, "interpolation": interpolation, "extension": "REPEAT"},
                     {} if vector is None else {"Vector": vector})
    return Material(name="Textured", nodes=[("DIFFUSE", (1.0, 1.0, 1.0), {}, [(Link(node, "Color"), "color")])])


def emitting(link: Link) -> Material:
    """An Emission shader whose colour is a link (no BSDF: the pixel is the emission)."""
    return Material(name="Emitting", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": link})])


def checker_value(u, v, n=4, dark=0.2, light=0.8):
    """The checker's value at UV (u, v)."""
    return np.where((np.floor(u * n) + np.floor(v * n)) % 2 == 1, light, dark)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_checker_texture_renders_albedo_over_pi_times_irradiance_in_each_square(kernels):
    image = shoot(scene_of(diffuse_textured(textures.Image(checker()))), kernels)
    u, v = pixel_uv()
    expected = checker_value(u, v) / math.pi * E
    np.testing.assert_allclose(image[..., 0], expected, rtol=1e-6)
    np.testing.assert_allclose(image[..., 1], expected, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_srgb_images_are_decoded_with_the_srgb_curve_and_non_color_images_are_not(kernels):
    grey = np.full((2, 2, 4), 0.5, np.float32)
    srgb = shoot(scene_of(diffuse_textured(textures.Image(grey, srgb=True))), kernels)
    data = shoot(scene_of(diffuse_textured(textures.Image(grey, srgb=False))), kernels)
    decoded = ((0.5 + 0.055) / 1.055) ** 2.4                     # IEC 61966-2-1 above the linear toe
    np.testing.assert_allclose(srgb, decoded / math.pi * E, rtol=1e-6)
    np.testing.assert_allclose(data, 0.5 / math.pi * E, rtol=1e-6)
    assert textures.srgb_to_linear(0.02) == pytest.approx(0.02 / 12.92)


LOOKUPS = [textures.TextureSet.lookup, None]        # None: the compiled twin


def lookup(which, tex: textures.TextureSet, x, y, interpolation: int, extension: int) -> np.ndarray:
    """A lookup on the reference (which is TextureSet.lookup) or in C."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    if which is None:
        return textures.compiled_lookup(tex, 0, x, y, interpolation, extension)
    return tex.lookup(0, x, y, interpolation, extension)


@pytest.mark.parametrize("which", LOOKUPS, ids=["numpy", "compiled"])
def test_closest_takes_the_texel_and_linear_averages_the_two_at_a_texel_boundary(which):
    tex = textures.TextureSet.of([textures.Image(np.array([[[0.0, 0, 0, 1], [1.0, 1, 1, 1]]], np.float32))])
    x = np.array([0.5, 0.25, 0.75, 0.4999])
    closest = lookup(which, tex, x, np.full(4, 0.5), 1, 1)[:, 0]
    linear = lookup(which, tex, x, np.full(4, 0.5), 0, 1)[:, 0]
    np.testing.assert_array_equal(closest, [1.0, 0.0, 1.0, 0.0])
    # Texel centres at 0.25 and 0.75: the boundary 0.5 is halfway; linear in between.
    np.testing.assert_allclose(linear, [0.5, 0.0, 1.0, 0.4998], atol=1e-12)


@pytest.mark.parametrize("which", LOOKUPS, ids=["numpy", "compiled"])
def test_extension_modes_outside_the_unit_square(which):
    row = np.array([[[0.1, 0, 0, 1], [0.2, 0, 0, 1], [0.3, 0, 0, 1], [0.4, 0, 0, 1]]], np.float32)
    tex = textures.TextureSet.of([textures.Image(row)])
    x = np.array([1.125, -0.125, 1.375, 0.375])                 # texel centres beyond the right, left edges
    y = np.full(4, 0.5)
    repeat = lookup(which, tex, x, y, 1, textures.EXTENSIONS["REPEAT"])[:, 0]
    extend = lookup(which, tex, x, y, 1, textures.EXTENSIONS["EXTEND"])[:, 0]
    clip = lookup(which, tex, x, y, 1, textures.EXTENSIONS["CLIP"])
    mirror = lookup(which, tex, x, y, 1, textures.EXTENSIONS["MIRROR"])[:, 0]
    np.testing.assert_allclose(repeat, [0.1, 0.4, 0.2, 0.2], rtol=1e-7)
    np.testing.assert_allclose(extend, [0.4, 0.1, 0.4, 0.2], rtol=1e-7)
    np.testing.assert_allclose(clip[:, 0], [0.0, 0.0, 0.0, 0.2], rtol=1e-7)
    np.testing.assert_array_equal(clip[:3, 3], 0.0)            # transparent outside
    np.testing.assert_allclose(mirror, [0.4, 0.1, 0.3, 0.2], rtol=1e-7)


@pytest.mark.parametrize("which", LOOKUPS, ids=["numpy", "compiled"])
def test_cubic_b_spline_reproduces_a_linear_ramp(which):
    """The uniform cubic B-spline's weights sum to 1 and have their mean at t: linear data comes back."""
    ramp = np.zeros((1, 16, 4), np.float32)
    ramp[0, :, 0] = np.arange(16) / 15.0
    tex = textures.TextureSet.of([textures.Image(ramp)])
    x = np.linspace(3.0, 12.0, 7) / 16.0                         # away from the edges
    cubic = lookup(which, tex, x, np.full(7, 0.5), 2, 1)[:, 0]
    np.testing.assert_allclose(cubic, (x * 16.0 - 0.5) / 15.0, atol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_mapping_scale_of_two_repeats_the_pattern_twice(kernels):
    uv = GraphNode("TEXCOORD", {}, {})
    mapping = GraphNode("MAPPING", {"type": "POINT"}, {"Vector": Link(uv, "UV"), "Scale": (2.0, 2.0, 1.0)})
    image = shoot(scene_of(diffuse_textured(textures.Image(checker(2)), vector=Link(mapping, "Vector"))), kernels)
    u, v = pixel_uv()
    np.testing.assert_allclose(image[..., 0], checker_value(2 * u, 2 * v, n=2) / math.pi * E, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("degrees", [20.0, 35.0])
def test_a_normal_map_tilting_the_normal_makes_n_dot_l_the_cosine_of_the_tilt(kernels, degrees):
    theta = math.radians(degrees)
    tilted = np.array([math.sin(theta), 0.0, math.cos(theta)])   # in tangent space (T, B, N)
    color = GraphNode("RGB", {"value": tilted * 0.5 + 0.5})
    normal = GraphNode("NORMAL_MAP", {"map": ""}, {"Color": Link(color, "Color"), "Strength": 1.0})
    material = Material(name="Mapped", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {"normal": Link(normal, "Normal")})])
    image = shoot(scene_of(material, tangent=True), kernels)
    np.testing.assert_allclose(image, 0.5 / math.pi * E * math.cos(theta), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_bump_of_a_sloped_height_tilts_the_normal_by_the_slope(kernels):
    """Height h = u on a plane 2 wide: dh/dx = 1/2, so N' = normalize(-d/2, 0, 1) and N'.L = 1/sqrt(1 + d^2/4)."""
    distance = 0.8
    uv = GraphNode("TEXCOORD", {}, {})
    height = GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "UV")})
    bump = GraphNode("BUMP", {}, {"Height": Link(height, "X"), "Distance": distance, "Strength": 1.0})
    material = Material(name="Bumpy", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {"normal": Link(bump, "Normal")})])
    image = shoot(scene_of(material), kernels)
    np.testing.assert_allclose(image, 0.5 / math.pi * E / math.sqrt(1.0 + distance ** 2 / 4.0), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("tilt", [0.0, 70.0])
def test_a_set_normal_bump_is_the_hits_own_normal_with_no_bump_shadowing(kernels, tilt):
    """Cycles' Set Normal (a Displacement output as bump: Material.normal): the sloped bump's normal N' =
    normalize(-d/2, 0, 1) becomes the hit's own, so a Lambert plane under a sun from direction l is rho / pi E N'.l
    exactly, also with the sun 70 degrees from the plane's normal, where the same bump on the node's Normal alone
    (N' beside the hit's normal) is darker by bump shadowing."""
    distance = 0.8
    uv = GraphNode("TEXCOORD", {}, {})
    height = GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "UV")})
    bump = Link(GraphNode("BUMP", {}, {"Height": Link(height, "X"), "Distance": distance, "Strength": 1.0}), "Normal")
    t = math.radians(tilt)
    towards = np.array([-math.sin(t), 0.0, math.cos(t)])         # towards the sun, leaning to the bump's side
    scenes = []
    for material in (Material(name="Set", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {})], normal=bump),
                     Material(name="Node", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {"normal": bump})])):
        scene = scene_of(material)
        scene.lights = [SunLight(-towards, strength=E)]
        scenes.append(shoot(scene, kernels))
    N = np.array([-distance / 2.0, 0.0, 1.0]) / math.sqrt(1.0 + distance ** 2 / 4.0)
    np.testing.assert_allclose(scenes[0], 0.5 / math.pi * E * float(N @ towards), rtol=1e-6)
    if tilt > 0.0:
        assert scenes[1].mean() < 0.99 * scenes[0].mean()


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("corrected", [True, False])
def test_bump_shadowing_softens_a_bumped_diffuse_normal_only_with_bump_map_correction(kernels, corrected):
    """The sloped bump's N' = normalize(-d/2, 0, 1) on a node's Normal, a sun 70 degrees from the plane's normal on
    the bump's side: a Lambert plane is rho / pi E N'.l x G1, Cycles' bump shadowing term G1 = 2 / (1 + sqrt(1 +
    a2 tan^2 theta_i)) with a2 = tan^2(angle between N' and N) / 8 and theta_i the sun's angle to the plane's normal;
    with Bump Map Correction off (Material.bump_map_correction) it is rho / pi E N'.l exactly."""
    distance = 0.8
    uv = GraphNode("TEXCOORD", {}, {})
    height = GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "UV")})
    bump = Link(GraphNode("BUMP", {}, {"Height": Link(height, "X"), "Distance": distance, "Strength": 1.0}), "Normal")
    t = math.radians(70.0)
    towards = np.array([-math.sin(t), 0.0, math.cos(t)])
    scene = scene_of(Material(name="Node", nodes=[("DIFFUSE", (0.5, 0.5, 0.5), {"normal": bump})],
                              bump_map_correction=corrected))
    scene.lights = [SunLight(-towards, strength=E)]
    image = shoot(scene, kernels)
    N = np.array([-distance / 2.0, 0.0, 1.0]) / math.sqrt(1.0 + distance ** 2 / 4.0)
    a2 = (1.0 / N[2] ** 2 - 1.0) / 8.0
    G1 = 2.0 / (1.0 + math.sqrt(1.0 + a2 * math.tan(t) ** 2)) if corrected else 1.0
    np.testing.assert_allclose(image, 0.5 / math.pi * E * float(N @ towards) * G1, rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_the_nodes_after_a_set_normal_read_its_normal(kernels):
    """Cycles runs a material's surface after its Set Normal: the Geometry node's Normal there is the sloped bump's
    N' = normalize(-d/2, 0, 1) (an Emission coloured |N'|: (d/2, 0, 1) / sqrt(1 + d^2/4)), and a Bump node in the
    surface starts from N' (its Height constant: N' again), not the plane's (0, 0, 1)."""
    distance = 0.8
    uv = GraphNode("TEXCOORD", {}, {})
    height = GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "UV")})
    bump = Link(GraphNode("BUMP", {}, {"Height": Link(height, "X"), "Distance": distance, "Strength": 1.0}), "Normal")
    flat = GraphNode("BUMP", {}, {"Height": 0.0, "Distance": 1.0, "Strength": 1.0})
    expected = np.array([distance / 2.0, 0.0, 1.0]) / math.sqrt(1.0 + distance ** 2 / 4.0)
    for normal in (Link(GraphNode("GEOMETRY", {}, {}), "Normal"), Link(flat, "Normal")):
        absolute = GraphNode("VECTOR_MATH", {"operation": "ABSOLUTE"}, {"Vector": normal})
        material = emitting(Link(absolute, "Vector"))
        material.normal = bump
        image = shoot(scene_of(material, sun=False), kernels)
        np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_tangent_space_vector_goes_x_along_the_tangent_y_along_the_normal_z_along_the_bitangent(kernels):
    """Cycles' tangent-space Vector Displacement frame: on the plane (tangent +x, sign 1, normal +z, so the
    bitangent N x T = +y) the vector (1, 2, 3) is 1 T + 2 N + 3 B = (1, 3, 2) in object space."""
    frame = GraphNode("TANGENT_SPACE", {"map": ""}, {"Vector": (1.0, 2.0, 3.0)})
    image = shoot(scene_of(emitting(Link(frame, "Vector")), tangent=True, sun=False), kernels)
    np.testing.assert_allclose(image, np.broadcast_to([1.0, 3.0, 2.0], image.shape), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_vertex_colours_are_interpolated_across_each_triangle(kernels):
    corners = [[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0]]
    attribute = GraphNode("ATTRIBUTE", {"attribute": "color:"})
    scene = scene_of(emitting(Link(attribute, "Color")), colors=corners, sun=False)
    # The plane's corners (-1,-1), (1,-1), (1,1), (-1,1): bilinear would differ; each triangle is linear.
    u, v = pixel_uv()
    in_first = u >= v                                            # triangle (0, 1, 2)
    c = np.asarray(corners)[:, :3]
    first = (1 - u)[..., None] * c[0] + (u - v)[..., None] * c[1] + v[..., None] * c[2]
    second = (1 - v)[..., None] * c[0] + (u)[..., None] * c[2] + (v - u)[..., None] * c[3]
    check_varying(scene, kernels, np.where(in_first[..., None], first, second))


def test_a_graph_reading_two_outputs_of_one_texture_coordinate_node_asks_for_both_attributes():
    coords = GraphNode("TEXCOORD", {}, {})
    mixed = GraphNode("MIX", {"data_type": "RGBA", "blend_type": "MIX"},
                      {"Factor": 0.5, "A": Link(coords, "UV"), "B": Link(coords, "Generated")})
    assert graph.attributes_of(emitting(Link(mixed, "Result")).nodes) == {"uv:", "generated"}


@pytest.mark.parametrize("kernels", KERNELS)
def test_object_random_differs_per_instance_as_cycles_hashes_object_names(kernels):
    random = GraphNode("OBJECT_INFO", {})
    scene = Scene(camera=ortho_down(height=2.0, scale=2.0))
    scene.materials.append(emitting(Link(random, "Random")))
    left, right = primitives.plane(1.0, 2.0, center=(-0.5, 0.0, 0.0)), primitives.plane(1.0, 2.0, center=(0.5, 0.0, 0.0))
    scene.add_mesh(left, materials=np.array([0]), name="Cube")
    scene.add_mesh(right, materials=np.array([0]), name="Cube.001")
    image = shoot(scene, kernels)
    a, b = graph.object_random("Cube"), graph.object_random("Cube.001")
    assert a != b and 0.0 <= a <= 1.0 and 0.0 <= b <= 1.0
    np.testing.assert_allclose(image[:, :SIZE // 2], a, rtol=1e-7)
    np.testing.assert_allclose(image[:, SIZE // 2:], b, rtol=1e-7)
    # An instance's own random number (Blender's instance.random_id) wins over its name's.
    scene.instances[1] = dataclasses.replace(scene.instances[1], random=graph.random_from_id(123456789))
    np.testing.assert_allclose(shoot(scene, kernels)[:, SIZE // 2:], np.float32(123456789) / np.float32(0xFFFFFFFF),
                               rtol=1e-6)


def test_cycles_object_hash_is_lookup3_of_the_name_hash():
    """hash_string is i = 37 i + c over the bytes; hash_uint2 Bob Jenkins' lookup3 final mix (its published
    hashword of the two words with initval 0)."""
    name_hash = 0
    for ch in b"Cube":
        name_hash = name_hash * 37 + ch
    assert graph.object_random("Cube") == graph.random_from_id(int(hash_.hash_uint2(name_hash, 0)))
    assert hash_.hash_uint2(0, 0) != hash_.hash_uint2(1, 0) != hash_.hash_uint2(0, 1)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_missing_image_renders_magenta_as_cycles_does(kernels):
    node = GraphNode("IMAGE", {"image": None}, {})
    image = shoot(scene_of(emitting(Link(node, "Color")), sun=False), kernels)
    np.testing.assert_allclose(image, np.broadcast_to([1.0, 0.0, 1.0], image.shape))


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_linked_mix_shader_factor_weighs_its_two_shaders_per_hit(kernels):
    """Mix Shader with Fac = u between two emissions 0 and 1: the pixel is u."""
    uv = GraphNode("TEXCOORD", {}, {})
    fac = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "UV")}), "X")
    material = Material(name="Mixed", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": (0.0, 0.0, 0.0)}, [(fac, "one_minus")]),
                                             ("EMISSION", (1.0, 1.0, 1.0), {"emission": (1.0, 1.0, 1.0)}, [(fac, "fac")])])
    u, _ = pixel_uv()
    check_varying(scene_of(material, sun=False), kernels, np.repeat(u[..., None], 3, axis=2))


def op_materials() -> list:
    """One emitting material per op variant, each fed by UV-dependent values (for the twins test)."""
    uv = GraphNode("TEXCOORD", {}, {})
    sep = GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(uv, "UV")})
    x, y = Link(sep, "X"), Link(sep, "Y")
    scaled = Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": x, "1": 4.0, "2": -2.0}), "Value")
    img = textures.Image(np.random.default_rng(1).random((5, 7, 4)).astype(np.float32), srgb=True)
    color = Link(GraphNode("COMBINE_COLOR", {}, {"Red": x, "Green": y, "Blue": 0.3}), "Color")
    links = []
    for op in graph.MATH_OPS:
        links.append(Link(GraphNode("MATH", {"operation": op, "clamp": op == "ADD"}, {"0": scaled, "1": y, "2": 0.25}), "Value"))
    for blend in graph.BLEND_TYPES:
        links.append(Link(GraphNode("MIX", {"data_type": "RGBA", "blend_type": blend, "clamp_result": blend == "ADD"},
                                    {"Factor": y, "A": color, "B": (0.2, 0.6, 0.9)}), "Result"))
    links.append(Link(GraphNode("MIX", {"data_type": "FLOAT"}, {"Factor": x, "A": 0.1, "B": y}), "Result"))
    links.append(Link(GraphNode("MIX", {"data_type": "VECTOR", "factor_mode": "NON_UNIFORM"},
                                {"Factor": color, "A": (0.0, 0.5, 1.0), "B": Link(uv, "UV")}), "Result"))
    for interpolation in ("Linear", "Closest", "Cubic"):
        for extension in ("REPEAT", "EXTEND", "CLIP", "MIRROR"):
            mapped = Link(GraphNode("MAPPING", {"type": "TEXTURE"}, {"Vector": Link(uv, "UV"), "Location": (0.3, -0.2, 0),
                                                                   "Rotation": (0.1, 0.2, 0.7), "Scale": (2.5, 1.5, 1)}), "Vector")
            links.append(Link(GraphNode("IMAGE", {"image": img, "interpolation": interpolation, "extension": extension},
                                        {"Vector": mapped}), "Color"))
    for kind in graph.MAPPING_TYPES:
        links.append(Link(GraphNode("MAPPING", {"type": kind}, {"Vector": color, "Location": (0.1, 0.2, 0.3),
                                                               "Rotation": (0.4, -0.5, 0.6), "Scale": (1.5, 0.5, 2.0)}), "Vector"))
    table = np.random.default_rng(2).random((256, 4))
    for interpolate in (True, False):
        links.append(Link(GraphNode("RAMP", {"table": table, "interpolate": interpolate}, {"Fac": x}), "Color"))
    links.append(Link(GraphNode("INVERT", {}, {"Fac": y, "Color": color}), "Color"))
    links.append(Link(GraphNode("HSV", {}, {"Hue": x, "Saturation": 1.5, "Value": 0.8, "Fac": 0.9, "Color": color}), "Color"))
    for kind in ("MINMAX", "RANGE"):
        links.append(Link(GraphNode("CLAMP", {"clamp_type": kind}, {"Value": scaled, "Min": y, "Max": 0.4}), "Result"))
    for kind in graph.MAP_RANGE_TYPES:
        links.append(Link(GraphNode("MAP_RANGE", {"interpolation_type": kind}, {"Value": scaled, "From Min": -1.0,
                                                                                "From Max": y, "To Min": 0.2, "To Max": 0.9}), "Result"))
    links.append(Link(GraphNode("ATTRIBUTE", {"attribute": "color:"}), "Fac"))
    links.append(Link(GraphNode("SCALE", {}, {"Color": color, "Factor": scaled}), "Color"))
    materials = [emitting(link) for link in links]
    # Lit ones: linked BSDF inputs, normal maps, bump, a linked Mix Shader factor.
    picture = Link(GraphNode("IMAGE", {"image": img, "interpolation": "Linear"}, {}), "Color")
    alpha = Link(GraphNode("IMAGE", {"image": img, "interpolation": "Cubic"}, {}), "Alpha")
    mapped = Link(GraphNode("NORMAL_MAP", {"map": ""}, {"Color": picture, "Strength": 0.7}), "Normal")
    bumped = Link(GraphNode("BUMP", {"invert": True}, {"Height": alpha, "Distance": 0.3, "Strength": 0.8,
                                                       "Normal": mapped}), "Normal")
    materials.append(Material(name="Mapped", nodes=[("DIFFUSE", (0.8, 0.8, 0.8), {"normal": mapped})]))
    materials.append(Material(name="Principled", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {
        "base_color": picture, "roughness": y, "metallic": x, "coat": Link(GraphNode("MATH", {"operation": "SUBTRACT"},
                                                                               {"0": y, "1": 0.5}), "Value"),
        "specular_ior_level": x, "alpha": y, "normal": bumped})]))
    materials.append(Material(name="Glossy", nodes=[("GLOSSY", (1.0, 1.0, 1.0), {"roughness": x, "multiscatter": 1.0,
                                                                                 "color": color}, [(color, "color")])]))
    materials.append(Material(name="Mix", nodes=[("DIFFUSE", (0.9, 0.9, 0.9), {"normal": bumped}, [(x, "one_minus")]),
                                                 ("GLOSSY", (1.0, 1.0, 1.0), {"roughness": 0.3}, [(x, "fac")])]))
    return materials


def test_the_compiled_graph_computes_what_the_reference_computes_for_every_op():
    materials = op_materials()
    count = len(materials)
    columns = 8
    rows = -(-count // columns)
    scene = Scene(camera=ortho_down(center=(columns / 2, rows / 2, 0.0), height=2.0, scale=float(max(columns, rows))))
    scene.materials = materials
    for index in range(count):
        mesh = primitives.plane(1.0, center=(index % columns + 0.5, index // columns + 0.5, 0.0))
        mesh.attributes = plane_attributes(mesh, tangent=True, colors=np.random.default_rng(index).random((4, 4)))
        scene.add_mesh(mesh, materials=np.array([index]), name=f"Op{index}")
    scene.lights.append(SunLight(np.array([0.3, -0.2, -1.0]), strength=E, angle=0.2))
    settings = RenderSettings(width=64, height=64, samples=2)
    compiled = render.render(scene, dataclasses.replace(settings, kernels="compiled"))
    reference = render.render(scene, dataclasses.replace(settings, kernels="numpy"))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
    assert np.isfinite(reference.image).all() and reference.image[..., :3].std() > 0.05


@pytest.mark.parametrize("which", LOOKUPS, ids=["numpy", "compiled"])
def test_stored_texels_read_as_value_over_their_maximum_grey_as_rgb_and_alpha_one_where_missing(which):
    """8-bit texels read as x / 255, 16-bit ones as x / 65535; one channel is grey (R = G = B, alpha 1), two are
    grey and alpha, three have alpha 1: the same RGBA whatever the image was stored as."""
    images = [textures.Image(np.array([[[0, 51, 255, 102]]], np.uint8)),
              textures.Image(np.array([[[13107]]], np.uint16)),
              textures.Image(np.array([[[51, 204]]], np.uint8)),
              textures.Image(np.array([[[0.25, 0.5, 2.0]]], np.float32))]
    tex = textures.TextureSet.of(images)
    expected = [(0.0, 0.2, 1.0, 0.4), (0.2, 0.2, 0.2, 1.0), (0.2, 0.2, 0.2, 0.8), (0.25, 0.5, 2.0, 1.0)]
    for index, rgba in enumerate(expected):
        x = y = np.array([0.5])
        if which is None:
            found = textures.compiled_lookup(tex, index, x, y, 1, 1)
        else:
            found = tex.lookup(index, x, y, 1, 1)
        np.testing.assert_allclose(found[0], rgba, rtol=1e-12, atol=1e-15)


def test_an_8_bit_image_takes_a_quarter_of_the_memory_of_floats():
    """Images keep their stored type: 8-bit RGBA texels are one byte per channel, not four."""
    pixels = np.random.default_rng(1).integers(0, 256, (64, 128, 4), dtype=np.uint8)
    tex = textures.TextureSet.of([textures.Image(pixels), textures.Image(np.ones((2, 2, 3), np.float64))])
    assert tex.bytes.nbytes == pixels.size and tex.bytes.dtype == np.uint8
    assert tex.floats.dtype == np.float32 and tex.floats.size == 2 * 2 * 3     # float64 read as float32, no copy kept
    np.testing.assert_array_equal(tex.texels(0), pixels)


def test_images_decoded_once_share_one_buffer_from_render_to_render_and_others_are_copied():
    """Read-only images (decoded once for the renders that follow one another) give the same texel buffer when the
    next render has the same ones; a writeable image, or another set of images, is copied anew; the texels are the
    images' either way."""
    rng = np.random.default_rng(2)
    a, b = (rng.integers(0, 256, (8, 16, 3), dtype=np.uint8) for _ in range(2))
    for pixels in (a, b):
        pixels.flags.writeable = False
    first = textures.TextureSet.of([textures.Image(a), textures.Image(b)])
    again = textures.TextureSet.of([textures.Image(a), textures.Image(b)])
    assert again.bytes is first.bytes and not again.bytes.flags.writeable
    swapped = textures.TextureSet.of([textures.Image(b), textures.Image(a)])
    assert swapped.bytes is not first.bytes
    np.testing.assert_array_equal(swapped.texels(0), b)
    np.testing.assert_array_equal(swapped.texels(1), a)
    c = a.copy()                                       # writeable: it may change between renders
    mine = textures.TextureSet.of([textures.Image(c), textures.Image(b)])
    c[0, 0] = 255 - c[0, 0]
    mine_again = textures.TextureSet.of([textures.Image(c), textures.Image(b)])
    assert mine_again.bytes is not mine.bytes
    np.testing.assert_array_equal(mine_again.texels(0), c)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_normal_map_at_the_principled_normal_turns_the_base_not_the_coat(kernels):
    """Cycles gives the Principled coat the hit's own normal (Coat Normal unlinked), whatever feeds the node's
    Normal input: over a black base with no specular, where the coat is the only lobe, a normal map tilting
    N by 30 degrees changes nothing; over a white base it changes the diffuse light by cos 30."""
    theta = math.radians(30.0)
    tilted = np.array([math.sin(theta), 0.0, math.cos(theta)])
    color = GraphNode("RGB", {"value": tilted * 0.5 + 0.5})
    mapped = Link(GraphNode("NORMAL_MAP", {"map": ""}, {"Color": Link(color, "Color"), "Strength": 1.0}), "Normal")

    def coated(base, normal):
        inputs = {"base_color": base, "specular_ior_level": 0.0, "coat": 1.0, "coat_roughness": 0.3}
        if normal:
            inputs["normal"] = mapped
        return Material(name="Coated", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), inputs)])

    flat = shoot(scene_of(coated((0.0, 0.0, 0.0), False), tangent=True), kernels)
    bumped = shoot(scene_of(coated((0.0, 0.0, 0.0), True), tangent=True), kernels)
    assert flat.min() > 0.0                                        # the coat reflects the sun straight back
    np.testing.assert_allclose(bumped, flat, rtol=1e-9)
    white_flat = shoot(scene_of(coated((1.0, 1.0, 1.0), False), tangent=True), kernels)
    white_bumped = shoot(scene_of(coated((1.0, 1.0, 1.0), True), tangent=True), kernels)
    np.testing.assert_allclose(white_bumped - flat, (white_flat - flat) * math.cos(theta), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_coat_normal_fed_by_the_normals_map_turns_the_coat_too(kernels):
    """With Coat Normal fed by the node that feeds Normal (glTF's shared map: coat_follows_normal), the coat
    over a black base follows the normal map: tilted 30 degrees, its highlight of the overhead sun moves off
    the camera's direction and the plane darkens."""
    tilted = np.array([math.sin(math.radians(30.0)), 0.0, math.cos(math.radians(30.0))])
    color = GraphNode("RGB", {"value": tilted * 0.5 + 0.5})
    mapped = Link(GraphNode("NORMAL_MAP", {"map": ""}, {"Color": Link(color, "Color"), "Strength": 1.0}), "Normal")
    inputs = {"base_color": (0.0, 0.0, 0.0), "specular_ior_level": 0.0, "coat": 1.0, "coat_roughness": 0.3}
    flat = shoot(scene_of(Material(name="Flat", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), inputs)]), tangent=True),
                 kernels)
    shared = {**inputs, "normal": mapped, "coat_follows_normal": 1.0}
    bumped = shoot(scene_of(Material(name="Shared", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), shared)]), tangent=True),
                   kernels)
    assert bumped.max() < 0.5 * flat.min()


def tilted_map(degrees: float) -> Link:
    """A Normal Map node's output tilting the normal by `degrees` towards the tangent (+x), constant."""
    theta = math.radians(degrees)
    color = GraphNode("RGB", {"value": np.array([math.sin(theta), 0.0, math.cos(theta)]) * 0.5 + 0.5})
    return Link(GraphNode("NORMAL_MAP", {"map": ""}, {"Color": Link(color, "Color"), "Strength": 1.0}), "Normal")


def coat_scene(inputs: dict, sun_degrees: float = 0.0) -> Scene:
    """The plane with a coated Principled of `inputs` (no specular) under a sun `sun_degrees` from the zenith
    towards +x."""
    scene = scene_of(Material(name="Coated", nodes=[("PRINCIPLED", (1.0, 1.0, 1.0), {
        "specular_ior_level": 0.0, "coat": 1.0, "coat_roughness": 0.2, **inputs})]), tangent=True, sun=False)
    phi = math.radians(sun_degrees)
    scene.lights.append(SunLight(-np.array([math.sin(phi), 0.0, math.cos(phi)]), strength=E))
    return scene


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_coat_normal_map_of_its_own_turns_the_coat_alone(kernels):
    """Coat Normal fed by its own map (Cycles' coat_normal): over a black base, where the coat is the only lobe,
    the plane renders as when the coat follows that map through Normal, whatever feeds Normal; the coat's
    highlight moves to the mirror of the view about the coat's normal (the sun 2 x 20 degrees off the zenith);
    the diffuse base keeps the flat Normal: its light goes as N.L = cos 40 (the coat's mu, so what it lets
    through, is the same for both suns)."""
    black, white = {"base_color": (0.0, 0.0, 0.0)}, {"base_color": (1.0, 1.0, 1.0)}
    own = {"coat_normal": tilted_map(20.0), "normal": tilted_map(-10.0)}
    follows = {"normal": tilted_map(20.0), "coat_follows_normal": 1.0}
    for sun in (0.0, 40.0):
        np.testing.assert_allclose(shoot(coat_scene({**black, **own}, sun), kernels),
                                   shoot(coat_scene({**black, **follows}, sun), kernels), rtol=1e-9)
    mapped = {"coat_normal": tilted_map(20.0)}
    overhead, mirrored = shoot(coat_scene({**black, **mapped}, 0.0), kernels), shoot(coat_scene({**black, **mapped},
                                                                                                 40.0), kernels)
    flat_overhead, flat_mirrored = shoot(coat_scene(black, 0.0), kernels), shoot(coat_scene(black, 40.0), kernels)
    assert mirrored.min() > 3.0 * overhead.max() and flat_overhead.min() > 3.0 * flat_mirrored.max()
    base_overhead = shoot(coat_scene({**white, **mapped}, 0.0), kernels) - overhead
    base_mirrored = shoot(coat_scene({**white, **mapped}, 40.0), kernels) - mirrored
    assert base_overhead.min() > 0.05
    np.testing.assert_allclose(base_mirrored, base_overhead * math.cos(math.radians(40.0)), rtol=1e-6)


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_coat_normal_fed_by_the_normals_own_map_renders_as_coat_follows_normal(kernels):
    """Coat Normal linked to the map that feeds Normal (a second copy of the graph) renders what
    coat_follows_normal (the node's own normal, no copy) renders, with a sheen mixing the two normals too."""
    inputs = {"base_color": (0.6, 0.4, 0.2), "sheen": 0.5, "normal": tilted_map(25.0)}
    linked = shoot(coat_scene({**inputs, "coat_normal": tilted_map(25.0)}, 30.0), kernels)
    follows = shoot(coat_scene({**inputs, "coat_follows_normal": 1.0}, 30.0), kernels)
    assert follows.min() > 0.0
    np.testing.assert_allclose(linked, follows, rtol=1e-9, atol=1e-12)


def test_a_coat_normal_map_renders_the_same_compiled_and_in_numpy():
    """The compiled Principled with its own Coat Normal (nodes.c, graph.c) renders what the numpy one does."""
    inputs = {"base_color": (0.5, 0.6, 0.7), "sheen": 0.3, "coat_tint": (0.9, 0.7, 0.5),
              "coat_normal": tilted_map(30.0), "normal": tilted_map(-15.0)}
    for sun in (0.0, 25.0, 60.0):
        np.testing.assert_allclose(shoot(coat_scene(inputs, sun), "compiled"), shoot(coat_scene(inputs, sun), "numpy"),
                                   rtol=1e-9, atol=1e-12)


def udim_set(colors: dict, missing=(), plain_first: bool = True) -> textures.TextureSet:
    """A TextureSet of a plain 1-texel image (row 0, when `plain_first`) and a UDIM image whose tile `number`
    is a 2 x 2 image of colour colors[number] (RGB), with the tiles in `missing` unreadable (None)."""
    tiles = {number: textures.Image(np.broadcast_to(np.array([*rgb, 1.0], np.float32), (2, 2, 4)).copy())
             for number, rgb in colors.items()}
    tiles.update({number: None for number in missing})
    images = [textures.Image(np.array([[[0.5, 0.5, 0.5]]], np.float32))] if plain_first else []
    return textures.TextureSet.of(images + [textures.TiledImage(tiles, "udim")])


def test_the_udim_tile_of_a_uv_is_1001_plus_its_column_plus_ten_times_its_row_truncated_as_cycles():
    """Cycles' svm_node_tex_image: tx = (int)u, ty = (int)v (toward zero), a tile where 0 <= tx < 10 and 0 <= ty:
    1001 + tx + 10 ty. So -0.5 still lies in column 0, and u = 10 or -1 lie in none."""
    u = np.array([0.5, 1.5, 9.99, 0.25, 3.5, -0.5, 10.0, -1.0, 2.5, 0.5])
    v = np.array([0.5, 0.5, 0.0, 1.75, 4.0, 0.5, 0.5, 0.5, -0.25, -1.5])
    number, tx, ty = textures.tile_of(u, v)
    np.testing.assert_array_equal(number, [1001, 1002, 1010, 1011, 1044, 1001, -1, -1, 1003, -1])
    inside = number >= 0
    np.testing.assert_array_equal(number[inside], 1001 + np.trunc(u[inside]) + 10 * np.trunc(v[inside]))
    np.testing.assert_array_equal(tx[inside], np.trunc(u[inside]))
    np.testing.assert_array_equal(ty[inside], np.trunc(v[inside]))


@pytest.mark.parametrize("which", ["numpy", "compiled"])
def test_a_udim_lookup_reads_the_tile_its_uv_names_and_magenta_where_there_is_none(which):
    """Tiles 1001 (red), 1002 (green), 1011 (blue) and an unreadable 1012: each UV reads its tile's colour, a UV in
    the unreadable tile, in a tile the image lacks, or outside every tile reads Cycles' missing magenta."""
    tex = udim_set({1001: (1.0, 0.0, 0.0), 1002: (0.0, 1.0, 0.0), 1011: (0.0, 0.0, 1.0)}, missing=(1012,))
    u = np.array([0.3, 1.7, 0.5, 1.5, 2.5, 10.5, -1.5])
    v = np.array([0.6, 0.2, 1.5, 1.5, 0.5, 0.5, 0.5])
    expected = [(1, 0, 0, 1), (0, 1, 0, 1), (0, 0, 1, 1)] + [textures.MISSING] * 4
    for interpolation in (0, 1, 2):
        if which == "numpy":
            found = tex.lookup(1, u, v, interpolation, textures.EXTENSIONS["REPEAT"])
        else:
            found = textures.compiled_lookup(tex, 1, u, v, interpolation, textures.EXTENSIONS["REPEAT"])
        np.testing.assert_allclose(found, np.array(expected, np.float64), atol=1e-7)


def test_a_udim_tile_is_sampled_at_the_fraction_of_the_uv_on_both_kernels_alike():
    """A tile's lookup is the plain image's at (u - tx, v - ty), in C as in numpy (to float64 rounding), for every
    interpolation and extension; a plain image in the same set reads as it does alone, bit for bit."""
    rng = np.random.default_rng(7)
    tiles = {1001: textures.Image(rng.random((5, 7, 4)).astype(np.float32)),
             1002: textures.Image(rng.integers(0, 256, (4, 3, 3), dtype=np.uint8), srgb=True),
             1012: textures.Image(rng.integers(0, 65536, (3, 6, 1), dtype=np.uint16))}
    plain = textures.Image(rng.random((6, 5, 4)).astype(np.float32))
    tex = textures.TextureSet.of([plain, textures.TiledImage(dict(tiles), "udim")])
    alone = textures.TextureSet.of([plain])
    u = rng.uniform(-1.2, 3.2, 400)
    v = rng.uniform(-1.2, 2.2, 400)
    number, tx, ty = textures.tile_of(u, v)
    for interpolation in (0, 1, 2):
        for extension in textures.EXTENSIONS.values():
            reference = tex.lookup(1, u, v, interpolation, extension)
            compiled = textures.compiled_lookup(tex, 1, u, v, interpolation, extension)
            np.testing.assert_allclose(compiled, reference, rtol=1e-12, atol=1e-15)
            for tile, image in tiles.items():
                here = number == tile
                one = textures.TextureSet.of([image])
                np.testing.assert_array_equal(reference[here], one.lookup(0, u[here] - tx[here], v[here] - ty[here],
                                                                           interpolation, extension))
            np.testing.assert_array_equal(reference[~np.isin(number, list(tiles))],
                                          np.broadcast_to(textures.MISSING, (np.sum(~np.isin(number, list(tiles))), 4)))
            np.testing.assert_array_equal(textures.compiled_lookup(tex, 0, u, v, interpolation, extension),
                                          textures.compiled_lookup(alone, 0, u, v, interpolation, extension))


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_udim_texture_renders_each_tile_where_the_uvs_reach_it(kernels):
    """The plane's UVs scaled by a Mapping to span u 0..2: its left half shows tile 1001 (red), its right half tile
    1002 (green), albedo / pi x E each, on both kernels."""
    uv = GraphNode("TEXCOORD", {}, {})
    mapping = GraphNode("MAPPING", {"type": "POINT"}, {"Vector": Link(uv, "UV"), "Scale": (2.0, 1.0, 1.0)})
    red, green = np.array([0.8, 0.1, 0.1, 1.0], np.float32), np.array([0.1, 0.7, 0.2, 1.0], np.float32)
    udim = textures.TiledImage({1001: textures.Image(np.broadcast_to(red, (2, 2, 4)).copy()),
                                1002: textures.Image(np.broadcast_to(green, (2, 2, 4)).copy())}, "udim")
    material = diffuse_textured(udim, vector=Link(mapping, "Vector"))
    u, _ = pixel_uv()
    albedo = np.where((2.0 * u)[..., None] < 1.0, red[:3], green[:3])
    check_varying(scene_of(material), kernels, albedo / math.pi * E, atol=1e-6)


def uv_ramp(n: int = 16) -> textures.Image:
    """An n x n image whose red is u and green is v at each texel centre (Linear interpolation then reads (u, v) back
    exactly inside the outer half texels)."""
    centres = ((np.arange(n) + 0.5) / n).astype(np.float32)
    u, v = np.meshgrid(centres, centres)
    return textures.Image(np.dstack([u, v, np.zeros_like(u), np.ones_like(u)]), srgb=False)


def constant_vector(x: float, y: float, z: float) -> Link:
    """A Combine XYZ's Vector of constants."""
    return Link(GraphNode("COMBINE_XYZ", {}, {"X": x, "Y": y, "Z": z}), "Vector")


# (projection, the 0..1 box point looked up, the (u, v) Cycles' map_to_sphere / map_to_tube / box give it)
PROJECTED = [("SPHERE", (1.0, 0.5, 0.5), (0.25, 0.5)),                  # +x on the equator: a quarter turn
             ("SPHERE", (0.5, 1.0, 1.0), (0.5, 0.75)),                  # +y tilted 45 degrees up
             ("SPHERE", (0.5, 0.5, 0.5), (0.0, 0.0)),                   # the centre
             ("TUBE", (0.0, 0.5, 0.75), (0.75, 0.75)),                  # -x, half way up
             ("TUBE", (0.5, 0.5, 0.9), (0.0, 0.0)),                     # on the axis
             ("BOX", (0.3, 0.6, 0.1), (0.4, 0.3))]                      # a +z face: (1 - y, x)


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("projection, point, uv", PROJECTED)
def test_image_projections_map_a_known_point_to_cycles_uv(kernels, projection, point, uv):
    node = GraphNode("IMAGE", {"image": uv_ramp(), "interpolation": "Linear", "extension": "EXTEND",
                               "projection": projection, "blend": 0.2}, {"Vector": constant_vector(*point)})
    image = shoot(scene_of(emitting(Link(node, "Color")), sun=False), kernels)
    expected = np.clip(uv, 0.5 / 16, 1.0 - 0.5 / 16)                   # (EXTEND holds the outer texels)
    np.testing.assert_allclose(image[..., :2], np.broadcast_to(expected, (SIZE, SIZE, 2)), atol=1e-6)


# (projection, direction, the (u, v) of Cycles' direction_to_equirectangular / direction_to_mirrorball)
ENVIRONMENT = [("EQUIRECTANGULAR", (0.0, 2.0, 0.0), (0.25, 0.5)),
               ("EQUIRECTANGULAR", (1.0, 0.0, 1.0), (0.5, 0.75)),
               ("MIRROR_BALL", (0.0, -3.0, 0.0), (0.5, 0.5)),            # straight back at the viewer: the centre
               ("MIRROR_BALL", (1.0, 0.0, 0.0), (0.5 + 0.5 / math.sqrt(2.0), 0.5)),
               ("MIRROR_BALL", (0.0, 0.0, -2.0), (0.5, 0.5 - 0.5 / math.sqrt(2.0)))]


@pytest.mark.parametrize("kernels", KERNELS)
@pytest.mark.parametrize("projection, direction, uv", ENVIRONMENT)
def test_an_environment_texture_in_a_surface_maps_a_direction_to_cycles_uv(kernels, projection, direction, uv):
    node = GraphNode("ENVIRONMENT", {"image": uv_ramp(), "interpolation": "Linear", "projection": projection},
                     {"Vector": constant_vector(*direction)})
    image = shoot(scene_of(emitting(Link(node, "Color")), sun=False), kernels)
    np.testing.assert_allclose(image[..., :2], np.broadcast_to(uv, (SIZE, SIZE, 2)), atol=1e-6)


def test_a_texture_limit_halves_an_image_into_the_means_of_its_blocks_as_cycles():
    """Simplify > Texture Limit (textures.limited, Cycles' file_load_image): a 256 x 256 byte checker of single texels
    under a limit of 128 becomes 128 x 128 texels of the 2 x 2 means, 0.5 rounded to byte 128; a 5 x 3 float image
    under a limit of 2 is halved twice (4 x 4 blocks): one texel, the mean of the 4 x 3 texels there are; no limit or
    a larger one keeps the pixels."""
    checker = ((np.indices((256, 256)).sum(axis=0) % 2) * 255).astype(np.uint8)[:, :, None]
    halved = textures.limited(checker, 128)
    assert halved.shape == (128, 128, 1) and halved.dtype == np.uint8 and (halved == 128).all()
    small = np.arange(15, dtype=np.float32).reshape(3, 5, 1)
    quarter = textures.limited(small, 2)
    assert quarter.shape == (1, 1, 1)
    assert quarter[0, 0, 0] == pytest.approx(small[:, :4].mean(), rel=1e-6)
    assert textures.limited(checker, 0) is checker and textures.limited(checker, 256) is checker


@pytest.mark.parametrize("height, width, limit, resolution, scale", [
    (64, 64, 0, 1.0, 1.0), (64, 64, 0, 0.5, 0.5), (64, 64, 0, 0.75, 0.5), (62, 62, 0, 0.3, 0.25),
    (64, 64, 0, 0.25, 0.25), (64, 64, 0, 1e-5, 2.0 ** -17), (256, 256, 128, 1.0, 0.5), (192, 96, 128, 1.0, 0.5),
    (256, 256, 128, 0.3, 0.25), (192, 192, 128, 0.6, 0.5), (1536, 1024, 1024, 0.9, 0.5), (64, 64, 128, 0.5, 0.5)])
def test_texture_resolution_and_limit_shrink_an_image_by_the_power_of_2_below_the_smaller_factor(
        height, width, limit, resolution, scale):
    """Blender 5.2's Simplify > Texture Resolution with Texture Limit (textures.reduction, Cycles 5.2's
    device_load_image and load_full): the factor is min(resolution, limit / larger side) rounded down to a power of
    2, measured in Cycles 5.2.3 for the 64, 62, 256 and 192 texel cases (0.75 and 0.6 shrink by half, 0.3 to a
    quarter, a limit under the resolution wins)."""
    assert textures.reduction(height, width, limit, resolution) == scale


def test_texture_limit_alone_shrinks_by_the_factor_of_blender_50s_halving_loop():
    """Without Texture Resolution, Cycles 5.2's factor (the power of 2 below limit / larger side) is Blender 5.0's
    file_load_image loop (halve until the larger side fits the limit), for every side 1 .. 4100 and limit."""
    for limit in (128, 256, 512, 1024, 2048, 4096):
        for side in range(1, 4100):
            halved = 1.0
            while side * halved > limit:
                halved *= 0.5
            assert textures.reduction(side, 1, limit) == halved, (side, limit)


def test_texture_resolution_keeps_the_means_of_whole_blocks_from_the_bottom_left():
    """Texture Resolution 0.5 on a 5 x 7 float image stored bottom row first (Cycles' order): 2 x 3 texels, each the
    mean of its 2 x 2 block; the top row and the right column, past whole blocks, dropped (measured: Cycles 5.2.3
    shrinks a 62 x 62 byte image at 0.3 into 15 x 15 means of 4 x 4 blocks from the bottom-left corner)."""
    pixels = np.arange(35, dtype=np.float32).reshape(5, 7, 1)
    half = textures.limited(pixels, 0, 0.5)
    assert half.shape == (2, 3, 1) and half.dtype == np.float32
    expected = pixels[:4, :6, 0].reshape(2, 2, 3, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(half[..., 0], expected, rtol=1e-7)
    assert textures.limited(pixels, 0, 1.0) is pixels
    assert textures.limited(pixels, 0, 0.3).shape == (1, 1, 1)          # (4 x 4 blocks: one, of the 4 x 4 there are)


@pytest.mark.parametrize("block, cycles", [
    ([[18, 239, 238, 66], [246, 44, 89, 202], [123, 74, 32, 48], [254, 64, 177, 62]], 124),
    ([[64, 17, 66, 166], [134, 113, 115, 42], [112, 213, 56, 112], [74, 89, 51, 232]], 104),
    ([[252, 44, 134, 140], [129, 107, 94, 104], [160, 246, 183, 144], [136, 6, 55, 138]], 130),
    ([[9, 138, 180, 248], [51, 52, 146, 82], [186, 49, 7, 43], [177, 97, 241, 46]], 109)])
def test_a_byte_mean_halfway_between_two_bytes_rounds_as_cycles_float32_arithmetic(block, cycles):
    """A 4 x 4 block of bytes (rows bottom first) whose mean is exactly halfway between two bytes (123.5, 103.5,
    129.5, 109.5) shrinks at Texture Resolution 0.25 to the byte Cycles 5.2.3 rendered (measured: 825 such halves in a
    256 x 256 image, 808 up and 17 down, all as textures.limited's float32 arithmetic; division by 255 instead of
    the product by 1 / 255 rounds the first two down)."""
    pixels = np.array(block, np.uint8)[:, :, None]
    assert textures.limited(pixels, 0, 0.25)[0, 0, 0] == cycles


def test_a_half_float_image_keeps_its_means_rounded_to_half_as_cycles():
    """A half-float image (float16, as Cycles keeps a half EXR) shrunk by 2 in Blender 5.1+ (NEAREST_EVEN): the mean
    1 + 2^-12 of a block (1, 1, 1, 1 + 2^-10) is no half, rounded to the nearest, 1; 1 + 3 x 2^-12 rounds to
    1 + 2^-10 (measured: a 64 x 64 half EXR at Texture Resolution 0.5 renders as Cycles 5.2.3's to 0, where float32
    means were 4.9e-4 off, half's precision); a float32 image keeps its float32 mean."""
    step = 2.0 ** -10
    half = np.array([[1.0, 1.0 + step, 1.0, 1.0 + 3 * step], [1.0, 1.0, 1.0, 1.0]], np.float16)[:, :, None]
    shrunk = textures.limited(half, 0, 0.5, textures.HalfRounding.NEAREST_EVEN)
    assert shrunk.dtype == np.float16 and shrunk[0, :, 0].tolist() == [1.0, 1.0 + step]
    assert textures.limited(half.astype(np.float32), 0, 0.5)[0, 0, 0] == np.float32(1.0 + step / 4)


# 2 x 2 blocks of halves whose float32 mean is no half (or a subnormal one): (block, mean, Cycles 4.2 .. 5.0's half of
# it, truncated, subnormals flushed; Cycles 5.1+'s, the nearest).
HALF_BLOCKS = (
    ((1.0, 1.0 + 2.0 ** -10, 1.0 + 2.0 ** -10, 1.0 + 2.0 ** -10), 1.0 + 3.0 * 2.0 ** -12, 1.0, 1.0 + 2.0 ** -10),
    ((2.0 ** -14, 0.0, 0.0, 0.0), 2.0 ** -16, 0.0, 2.0 ** -16),                  # a subnormal mean (half's step 2^-24)
    ((65504.0, 65504.0, 65504.0, 65472.0), 65496.0, 65472.0, 65504.0),           # 3/4 of a step (32) above 65472
)


@pytest.mark.parametrize("block, mean, truncated, rounded", HALF_BLOCKS)
def test_half_float_means_are_truncated_before_blender_5_1_and_rounded_to_nearest_even_after(block, mean, truncated,
                                                                                            rounded):
    """A 2 x 2 block of halves shrunk by Simplify to its mean: Cycles 4.2 .. 5.0 (TRUNCATED) keeps the half below it,
    with subnormals flushed to 0 (1 + 3 x 2^-12 -> 1, 2^-16 -> 0, 65496 -> 65472); Cycles 5.1+ (NEAREST_EVEN) the
    nearest (1 + 2^-10, 2^-16 kept, 65504)."""
    pixels = np.array(block, np.float16).reshape(2, 2, 1)
    assert np.float32(sum(block)) * np.float32(0.25) == np.float32(mean)
    made = {rule: textures.limited(pixels, 0, 0.5, rule) for rule in textures.HalfRounding}
    assert all(out.dtype == np.float16 and out.shape == (1, 1, 1) for out in made.values())
    assert float(made[textures.HalfRounding.TRUNCATED][0, 0, 0]) == truncated
    assert float(made[textures.HalfRounding.NEAREST_EVEN][0, 0, 0]) == rounded


def test_half_floats_are_not_made_without_a_rule():
    """A half image shrunk or associated without saying which Cycles' rule makes its halves is an error, never one
    Blender's rounding silently (bytes, shorts and floats need none)."""
    halves = np.ones((2, 2, 4), np.float16) * np.float16(0.5)
    with pytest.raises(ValueError):
        textures.limited(halves, 0, 0.5)
    with pytest.raises(ValueError):
        textures.associated(halves)
    assert textures.limited(np.zeros((2, 2, 1), np.uint8), 0, 0.5).dtype == np.uint8


@pytest.mark.parametrize("version, rounding", [((4, 2, 0), "TRUNCATED"), ((5, 0, 1), "TRUNCATED"),
                                               ((5, 1, 0), "NEAREST_EVEN"), ((5, 2, 3), "NEAREST_EVEN"),
                                               ((6, 0, 0), "NEAREST_EVEN")])
def test_the_half_rule_follows_the_blender_version_cycles_changed_it_in(version, rounding):
    """Cycles' float_to_half_image truncates up to Blender 5.0 and rounds to nearest even from 5.1 (commit
    b5c7dd95c): the add-on's rule (materials.half_rounding_now) is half_rounding_of(bpy.app.version)."""
    assert textures.half_rounding_of(version) is textures.HalfRounding[rounding]


def test_a_constant_colour_ramp_changes_colour_at_the_first_of_cycles_257_table_points_past_its_stop():
    """Cycles bakes a Color Ramp at i / 256, i = 0 .. 256, and reads entry floor(f x 256): a Constant ramp whose stop
    is at 0.141 (the donut tutorial's sprinkles) shows its first colour up to 37 / 256 = 0.1445, where a 256-entry
    table at i / 255 would switch at 36 / 255 = 0.1412 (one sprinkle in a hundred took the wrong colour). Both
    kernels, on emitting planes whose Fac straddles the two points."""
    stop, before, after = 0.141, (1.0, 0.5, 0.2, 1.0), (0.6, 1.0, 0.2, 1.0)
    table = graph.ramp_table(lambda position: before if position < stop else after)
    assert table.shape == (graph.RAMP_TABLE_SIZE + 1, 4)
    facs = (0.1405, 0.1420, 0.1440, 0.1450, 0.1500)
    expected = [before, before, before, after, after]            # 37 / 256 = 0.14453
    scene = Scene(camera=ortho_down(center=(len(facs) / 2, 0.5, 0.0), height=2.0, scale=float(len(facs))))
    scene.materials = [emitting(Link(GraphNode("RAMP", {"table": table, "interpolate": False}, {"Fac": fac}),
                                     "Color")) for fac in facs]
    for index in range(len(facs)):
        scene.add_mesh(primitives.plane(1.0, center=(index + 0.5, 0.5, 0.0)), materials=np.array([index]),
                       name=f"Fac{index}")
    settings = RenderSettings(width=5 * 8, height=8, samples=1)
    for kernels in ("numpy", "compiled"):
        image = render.render(scene, dataclasses.replace(settings, kernels=kernels)).image
        for index, colour in enumerate(expected):
            np.testing.assert_allclose(image[4, index * 8 + 4, :3], colour[:3], rtol=1e-6, err_msg=kernels)


# ------------------------------------------------------------------------------------------------
# Straight alpha as Cycles reads it (issue 33): associated when loaded, divided back where the Alpha output is read
# ------------------------------------------------------------------------------------------------

def test_cycles_associates_straight_alpha_in_the_stored_type_truncating_bytes_and_shorts():
    """util_image_multiply_native: a byte colour c with alpha a becomes (c a) // 255, a short (c a) // 65535 (both
    truncated), a float c a; the alpha stays; grey and alpha (2 channels) and opaque pixels are left as they are."""
    c = np.arange(256, dtype=np.uint8)
    a = np.uint8(128)
    pixels = np.stack([c, c[::-1], np.full(256, 7, np.uint8), np.full(256, a, np.uint8)], axis=-1)[None]
    out = textures.associated(pixels)
    np.testing.assert_array_equal(out[0, :, 0], (c.astype(np.int64) * 128) // 255)
    np.testing.assert_array_equal(out[0, :, 1], (c[::-1].astype(np.int64) * 128) // 255)
    np.testing.assert_array_equal(out[0, :, 3], 128)
    assert out[0, 200, 0] == 100 and round(200 * 128 / 255) == 100 and out[0, 199, 0] == 99   # 99.89: truncated
    shorts = np.array([[[60000, 1, 65535, 30000]]], np.uint16)
    np.testing.assert_array_equal(textures.associated(shorts)[0, 0], [60000 * 30000 // 65535, 0, 30000, 30000])
    floats = np.array([[[0.8, 0.5, 2.0, 0.25]]], np.float32)
    np.testing.assert_array_equal(textures.associated(floats)[0, 0], np.float32([0.2, 0.125, 0.5, 0.25]))
    grey_alpha = np.array([[[200, 128]]], np.uint8)
    opaque = np.array([[[200, 100, 50, 255]]], np.uint8)
    assert textures.associated(grey_alpha) is grey_alpha and textures.associated(opaque) is opaque


def test_cycles_makes_halves_by_truncation_up_to_5_0_and_to_nearest_even_from_5_1():
    """float_to_half_image, CPU: Blender 4.2 .. 5.0 truncates the mantissa (1 + 3/4096 -> 1; 65500 -> 65472),
    flushes magnitudes below 2^-14 to 0 and clamps 65536 and above (inf, NaN too) to 65504, signs kept; 5.1+ clamps
    to +-65504 (NaN, failing Cycles' max, to -65504) and rounds to nearest, ties to even (1 + 3/4096 -> 1 + 1/1024,
    65500 -> 65504, 1 + 1/2048 -> 1), subnormals kept in steps of 2^-24."""
    values = np.array([1.0 + 3.0 / 4096.0, -(1.0 + 3.0 / 4096.0), 2.0 ** -15, 3.0 * 2.0 ** -24, 1e6, 65500.0,
                       np.inf, -np.inf, np.nan, 1.0 + 2.0 ** -11, 0.5], np.float32)
    np.testing.assert_array_equal(textures.half_truncated(values).astype(np.float64),
                                  [1.0, -1.0, 0.0, 0.0, 65504.0, 65472.0, 65504.0, -65504.0, 65504.0, 1.0, 0.5])
    np.testing.assert_array_equal(textures.half_rounded(values).astype(np.float64),
                                  [1.0 + 2.0 ** -10, -(1.0 + 2.0 ** -10), 2.0 ** -15, 3.0 * 2.0 ** -24, 65504.0,
                                   65504.0, 65504.0, -65504.0, -65504.0, 1.0, 0.5])
    for rounding, make in ((textures.HalfRounding.TRUNCATED, textures.half_truncated),
                           (textures.HalfRounding.NEAREST_EVEN, textures.half_rounded)):
        np.testing.assert_array_equal(textures.half_of(values, rounding).view(np.uint16), make(values).view(np.uint16))


def test_cycles_5_0_reads_a_zero_half_as_2_to_the_minus_15_and_5_1_exactly():
    """half_to_float_image, CPU: Blender 4.2 .. 5.0 only moves the exponent's bias, so a zero half reads 2^-15 (a
    subnormal 2^-15 (1 + m / 1024)), inf 65536, normal halves exactly; 5.1+ reads every half exactly."""
    halves = np.array([0.0, -0.0, 2.0 ** -24, 1.5, 65504.0, np.inf], np.float16)
    np.testing.assert_array_equal(textures.half_widened(halves, textures.HalfRounding.TRUNCATED),
                                  np.float32([2.0 ** -15, -(2.0 ** -15), 2.0 ** -15 * (1 + 2.0 ** -10), 1.5, 65504.0,
                                              65536.0]))
    np.testing.assert_array_equal(textures.half_widened(halves, textures.HalfRounding.NEAREST_EVEN),
                                  halves.astype(np.float32))


def test_a_half_float_product_is_made_half_as_the_running_blenders_cycles():
    """Half floats are associated as the float32 product of the halves as read, made half by the Blender's rule:
    (1 + 2^-10) x 0.75 = 0.75 + 1.5 x 2^-11 (half's step there) is cut to 0.75 + 2^-11 up to 5.0 and rounded to
    0.75 + 2^-10 from 5.1; 2^-10 x 2^-5 = 2^-15 flushed to 0, then kept; colour 4 with alpha 0 is 4 x 2^-15 = 2^-13
    in 5.0 (its zero alpha read as 2^-15), 0 from 5.1."""
    half = np.array([[[1.0 + 1.0 / 1024.0, 0.5, 0.0, 0.75], [2.0 ** -10, 1.0, 0.0, 2.0 ** -5],
                      [4.0, 0.5, 1.0, 0.0]]], np.float16)
    truncated = textures.associated(half, textures.HalfRounding.TRUNCATED)
    rounded = textures.associated(half, textures.HalfRounding.NEAREST_EVEN)
    assert truncated.dtype == rounded.dtype == np.float16
    np.testing.assert_array_equal(truncated[0].astype(np.float64),
                                  [[0.75 + 2.0 ** -11, 0.375, 0.0, 0.75], [0.0, 2.0 ** -5, 0.0, 2.0 ** -5],
                                   [2.0 ** -13, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(rounded[0].astype(np.float64),
                                  [[0.75 + 2.0 ** -10, 0.375, 0.0, 0.75], [2.0 ** -15, 2.0 ** -5, 0.0, 2.0 ** -5],
                                   [0.0, 0.0, 0.0, 0.0]])


def test_alpha_none_sets_the_alpha_to_one_and_keeps_the_colours():
    """IMAGE_ALPHA_IGNORE: every alpha channel (grey and alpha too) becomes 1 (255 for bytes), colours as stored."""
    rgba = np.array([[[200, 100, 50, 0], [1, 2, 3, 128]]], np.uint8)
    np.testing.assert_array_equal(textures.alpha_ignored(rgba), [[[200, 100, 50, 255], [1, 2, 3, 255]]])
    grey_alpha = np.array([[[0.5, 0.25]]], np.float32)
    np.testing.assert_array_equal(textures.alpha_ignored(grey_alpha), [[[0.5, 1.0]]])
    rgb = np.zeros((1, 1, 3), np.uint8)
    assert textures.alpha_ignored(rgb) is rgb


@pytest.mark.parametrize("which", LOOKUPS, ids=["numpy", "compiled"])
def test_unassociating_divides_the_interpolated_colour_by_the_interpolated_alpha(which):
    """Two float texels (c0, a0), (c1, a1) associated, read halfway by Linear: the colour (c0 a0 + c1 a1) / 2 divided
    by the alpha (a0 + a1) / 2, the alpha kept; where the alpha is 0 or 1 nothing is divided."""
    c0, a0, c1, a1 = 0.8, 0.5, 0.2, 0.25
    texels = np.array([[[c0 * a0, c0 * a0, c0 * a0, a0], [c1 * a1, 0.0, 0.0, a1], [0.3, 0.3, 0.3, 0.0],
                        [0.6, 0.6, 0.6, 1.0]]], np.float32)
    tex = textures.TextureSet.of([textures.Image(texels)])
    x = np.array([0.25, 0.625, 0.875])               # halfway between texels 0 and 1; texel 2 alone; texel 3 alone
    y = np.full(3, 0.5)
    if which is None:
        out = textures.compiled_lookup(tex, 0, x, y, 0, 1, unassociate=True)
        kept = textures.compiled_lookup(tex, 0, x, y, 0, 1)
    else:
        out = tex.lookup(0, x, y, 0, 1, unassociate=True)
        kept = tex.lookup(0, x, y, 0, 1)
    f32 = texels.astype(np.float64)
    mean = (f32[0, 0] + f32[0, 1]) / 2.0
    np.testing.assert_allclose(kept[0], mean, rtol=1e-12)
    np.testing.assert_allclose(out[0, :3], mean[:3] / mean[3], rtol=1e-12)
    assert out[0, 3] == pytest.approx(mean[3], rel=1e-12)
    np.testing.assert_allclose(out[1:], kept[1:], rtol=0, atol=0)        # alpha 0 and alpha 1: left as they are


@pytest.mark.parametrize("interpolation", [0, 1, 2])
def test_the_compiled_lookup_unassociates_as_the_reference_for_plain_and_udim_images(interpolation):
    """Random associated byte texels (sRGB) in a plain image and in a UDIM tile, looked up anywhere with the
    unassociate flag: C equals numpy."""
    rng = np.random.default_rng(3)
    straight = rng.integers(0, 256, (5, 7, 4)).astype(np.uint8)
    stored = textures.associated(straight)
    tex = textures.TextureSet.of([textures.Image(stored, srgb=True),
                                  textures.TiledImage({1001: textures.Image(stored, srgb=True)})])
    x, y = rng.uniform(-0.5, 1.5, 300), rng.uniform(-0.5, 1.5, 300)
    for index in (0, 1):
        for extension in range(4):
            reference = tex.lookup(index, x, y, interpolation, extension, unassociate=True)
            compiled = textures.compiled_lookup(tex, index, x, y, interpolation, extension, unassociate=True)
            np.testing.assert_allclose(compiled, reference, rtol=1e-12, atol=1e-15)


def alpha_material(image: textures.Image, unassociate: bool, read_alpha: bool) -> Material:
    """An Emission of an image's Color, weighed by its Alpha where `read_alpha` (the Alpha output then read)."""
    node = GraphNode("IMAGE", {"image": image, "interpolation": "Closest", "extension": "REPEAT",
                               "unassociate": unassociate}, {})
    factors = [(Link(node, "Alpha"), "fac")] if read_alpha else []
    return Material(name="Alpha", nodes=[("EMISSION", (1.0, 1.0, 1.0), {"emission": Link(node, "Color")}, factors)])


@pytest.mark.parametrize("kernels", KERNELS)
def test_an_image_texture_gives_the_colour_and_alpha_cycles_gives_for_each_alpha_mode(kernels):
    """A straight sRGB byte texel c = (200, 60, 10) with alpha a = 128, read as Cycles reads it per mode, the pixel
    the Color output (times the Alpha output where it is read):
    Straight, Alpha unused: the associated c a // 255, decoded: srgb((c a // 255) / 255);
    Straight, Alpha read: that divided back by a / 255 before decoding: srgb((c a // 255) / a), times a / 255;
    Channel Packed or Non-Color (colours straight, no division): srgb(c / 255) (times a / 255 where read);
    None: srgb(c / 255), alpha 1."""
    c, a = np.array([200, 60, 10]), 128
    straight = np.array([[[*c, a]]], np.uint8)
    associated = textures.Image(textures.associated(straight), srgb=True)
    packed = textures.Image(straight, srgb=True)
    ignored = textures.Image(textures.alpha_ignored(straight), srgb=True)
    srgb = textures.srgb_to_linear
    cases = [(associated, True, False, srgb((c * a // 255) / 255.0)),
             (associated, True, True, srgb((c * a // 255) / float(a)) * (a / 255.0)),
             (packed, False, False, srgb(c / 255.0)),
             (packed, False, True, srgb(c / 255.0) * (a / 255.0)),
             (ignored, False, True, srgb(c / 255.0))]
    for image, unassociate, read_alpha, expected in cases:
        pixels = shoot(scene_of(alpha_material(image, unassociate, read_alpha), sun=False), kernels, size=2)
        np.testing.assert_allclose(pixels, np.broadcast_to(expected, pixels.shape), rtol=1e-6)


def test_only_a_node_whose_alpha_output_is_read_divides_back():
    """The unassociate flag is set on the IMAGE ops of the node whose Alpha output the program reads, or another
    program reads (props["alpha_read"]) (box projection too, all three looks), and only where its image is
    associated (props["unassociate"])."""
    image = textures.Image(np.full((1, 1, 4), 0.5, np.float32))

    def flags(props: dict, read_alpha: bool) -> list:
        node = GraphNode("IMAGE", {"image": image, **props}, {})
        factors = [(Link(node, "Alpha"), "fac")] if read_alpha else []
        program = graph.Compiler(graph.layout_of({"uv:"}), lambda im: 0).compile(
            [(type("Emission", (), {"inputs": ("emission",), "defaults": ((0.0, 0.0, 0.0),)}), 1.0,
              {"emission": Link(node, "Color")}, factors)])
        return [int(op[6]) for op in program.ops if int(op[0]) == graph.OP["IMAGE"]]

    assert set(flags({"unassociate": True}, True)) == {1}
    assert set(flags({"unassociate": True}, False)) == {0}
    assert set(flags({"unassociate": False}, True)) == {0}
    # (read by another program of the same Blender node, an AOV's or the displacement's: the addon's shared flag)
    assert set(flags({"unassociate": True, "alpha_read": [True]}, False)) == {1}
    assert set(flags({"unassociate": True, "alpha_read": [False]}, False)) == {0}
    shared = [False]
    flags({"unassociate": True, "alpha_read": shared}, True)
    assert shared == [True]                          # (what this program read, told to the node's other GraphNodes)
    box = flags({"unassociate": True, "projection": "BOX", "blend": 0.2}, True)
    assert len(box) == 6 and set(box) == {1}         # three looks for Color, three for Alpha
