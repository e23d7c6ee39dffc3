"""Media kept per object (issue 35): a volume material whose graph reads the object's Object Info (Random, Color...)
sets up one medium per object that holds it, as Cycles' volume stack holds (object, shader) pairs
(src/kernel/integrator/volume_stack.h; shader_setup_from_volume sets sd->object from the stack entry). Held to
closed forms in both kernels: two boxes sharing one absorbing material whose density Object Info drives let through
exp(-sigma_t(object) d) each, homogeneous (the graph reads nothing of the point: one constant per object) and
heterogeneous (a field that also reads the point's height, in each object's own coordinates); a box nested in another of the same material adds its
own medium to the outer one's; more media than a ray is in at once in Cycles' stack (MAX_MEDIA, less the world's)
leave the innermost out in both kernels, said once. A ray is in a medium once (Cycles' volume_stack_enter skips an (object, shader) pair the stack
holds, the first back face takes it off): one object's overlapping or nested shells, the camera inside two shells;
two overlapping objects of one plain material are two media (media.split_by_object)."""
from __future__ import annotations

from typing import Optional

import numpy as np
import pytest

from core.camera import Camera
from core.geometry import primitives
from core.materials import Material
from core.materials.graph import GraphNode, Link
from core.render import prepare, render
from core.scene import RenderSettings, Scene
from core.scene.scene import Instance, Mesh
from core.volumes import MAX_MEDIA

COLOR = np.array([0.2, 0.5, 0.8])
GLOW = np.array([1.0, 2.0, 0.5])


def camera_above() -> Camera:
    """An orthographic camera 3 above the origin looking straight down at x, y in [-1, 1]."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    return Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.1, clip_end=20.0)


def object_info(output: str) -> Link:
    """A graph: the object's Object Info `output` as one float (Color through Separate Color's Red)."""
    info = Link(GraphNode("OBJECT_INFO", {"material_index": 0.0}), output)
    if output == "Color":
        return Link(GraphNode("SEPARATE_COLOR", {}, {"Color": info}), "Red")
    return info


def times(a, b) -> Link:
    """A graph: a x b (Math > Multiply)."""
    return Link(GraphNode("MATH", {"operation": "MULTIPLY"}, {"0": a, "1": b}), "Value")


def height(scale: float, offset: float) -> Link:
    """A graph: scale x (the point's object z) + offset."""
    z = Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("TEXCOORD"), "Object")}), "Z")
    return Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": z, "1": scale, "2": offset}), "Value")


def shared(density) -> Material:
    """The volume-only absorbing material both boxes hold, its density the graph `density`."""
    return Material(np.zeros(3), "Shared", nodes=[("TRANSPARENT", np.ones(3), {})],
                    volume=[("ABSORPTION", 1.0, {"color": COLOR, "density": density})], volume_only=True)


def place(scene: Scene, box, value: float, output: str) -> None:
    """Add `box` (a mesh) holding material 1, its Object Info `output` (Random, or Color's red) set to `value`."""
    scene.add_mesh(box, materials=np.array([1]), name=f"Box {len(scene.instances)}")
    if output == "Random":
        scene.instances[-1].random = value
    else:
        scene.instances[-1].color = (value, 0.3, 0.9, 1.0)


def two_boxes(density, values=(0.25, 0.75), output: str = "Random") -> Scene:
    """A glowing floor (GLOW) at z = 0 under two boxes from z = 0.5 to 1.5 side by side (x < 0 and x > 0) holding
    one shared medium; each box's Object Info `output` the value of `values` in turn."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=GLOW))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(shared(density))
    for value, x in zip(values, (-1.0, 1.0)):
        place(scene, primitives.box((2.0, 4.0, 1.0), center=(x, 0.0, 1.0)), value, output)
    return scene


def halves(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """A 4 x 4 image whose two left columns are `left` (3,) and two right ones `right`."""
    image = np.empty((4, 4, 3))
    image[:, :2], image[:, 2:] = left, right
    return image


def rendered(scene: Scene, kernels: str) -> tuple:
    """The scene at 4 x 4, 2 samples, by the path tracer in `kernels`: (RGB (4, 4, 3), stats)."""
    result = render(scene, RenderSettings(width=4, height=4, samples=2, integrator="path", kernels=kernels))
    assert (result.stats.kernels == "compiled") == (kernels == "compiled"), result.stats.kernels
    return result.image[..., :3], result.stats


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("output, scale", [("Random", 4.0), ("Color", 5.0)])
def test_two_boxes_of_one_material_whose_density_is_their_object_info_keep_exp_of_their_own_sigma_t(
        output, scale, kernels):
    """Density = scale x Object Info (Random 0.25 and 0.75, or Color's red 0.2 and 0.6): sigma_t 1 and 3 x (1 -
    colour) over the boxes' depth 1, each its own medium (Primer used to read 0 there: no medium at all); the graph
    reads nothing of the point, so each is one constant medium (no field to march), with nothing to say."""
    values = (0.25, 0.75) if output == "Random" else (0.2, 0.6)
    scene = two_boxes(times(object_info(output), scale), values, output)
    image, stats = rendered(scene, kernels)
    expected = halves(GLOW * np.exp(-1.0 * (1.0 - COLOR)), GLOW * np.exp(-3.0 * (1.0 - COLOR)))
    np.testing.assert_allclose(image, expected, rtol=1e-5)
    assert not any("Shared" in w or "volume" in w for w in stats.warnings), stats.warnings
    media = prepare(scene, RenderSettings(width=4, height=4)).extra["media"]
    assert len(media.g) == 2 and not media.fields                  # (two constant media, one per box)
    np.testing.assert_allclose(media.sigma_t, [1.0 * (1.0 - COLOR), 3.0 * (1.0 - COLOR)])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_two_boxes_of_one_heterogeneous_material_scaled_by_their_random_keep_exp_of_their_own_integrals(kernels):
    """Density = Random x 1.6 x (2 z + 0.5) from z = 0.5 to 1.5 (its integral 2.5): Random 0.25 and 0.75 give
    optical depths 1 and 3 x (1 - colour), each box its own field (marched; a linear density is exact)."""
    scene = two_boxes(times(times(object_info("Random"), 1.6), height(2.0, 0.5)))
    image, stats = rendered(scene, kernels)
    expected = halves(GLOW * np.exp(-1.0 * (1.0 - COLOR)), GLOW * np.exp(-3.0 * (1.0 - COLOR)))
    np.testing.assert_allclose(image, expected, rtol=1e-5)
    assert not any("Shared" in w for w in stats.warnings), stats.warnings
    media = prepare(scene, RenderSettings(width=4, height=4)).extra["media"]
    assert len(media.fields) == 2 and [f.random for f in media.fields] == [0.25, 0.75]


def test_objects_whose_object_info_reads_alike_share_one_medium():
    """Two boxes of the same Random (and Color, pass index...) are one medium: a column per distinct Object Info."""
    scene = two_boxes(times(object_info("Random"), 4.0), values=(0.5, 0.5))
    media = prepare(scene, RenderSettings(width=4, height=4)).extra["media"]
    assert len(media.g) == 1
    np.testing.assert_allclose(rendered(scene, "compiled")[0], halves(*[GLOW * np.exp(-2.0 * (1.0 - COLOR))] * 2),
                               rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_box_nested_in_another_of_the_same_material_adds_its_own_medium_to_the_outer_ones(kernels):
    """An outer box (Random 0.25: density 1) from z = 0.5 to 1.5 over the whole view, and inside its right half an
    inner box (Random 0.75: density 3) from z = 0.75 to 1.25: the left keeps exp(-1 (1 - colour)), the right
    exp(-(1 + 3 x 0.5) (1 - colour)): leaving the inner box's medium leaves the outer one's on the stack (one medium
    per material would have counted the same column twice at one density)."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=GLOW))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(shared(times(object_info("Random"), 4.0)))
    place(scene, primitives.box((4.0, 4.0, 1.0), center=(0.0, 0.0, 1.0)), 0.25, "Random")
    place(scene, primitives.box((2.0, 3.0, 0.5), center=(1.0, 0.0, 1.0)), 0.75, "Random")
    image, _ = rendered(scene, kernels)
    expected = halves(GLOW * np.exp(-1.0 * (1.0 - COLOR)), GLOW * np.exp(-2.5 * (1.0 - COLOR)))
    np.testing.assert_allclose(image, expected, rtol=1e-5)


def test_more_objects_media_than_a_ray_is_in_at_once_render_compiled_to_the_references_pixels_and_say_so_once():
    """MAX_MEDIA boxes of distinct Random sharing one such material render compiled with nothing to say; one more
    too (the compiled volume stack is sparse, as Cycles': any number of media, MAX_MEDIA at once along a ray), to the
    Python reference's pixels, with one warning that says how many media and why."""
    scene = two_boxes(times(object_info("Random"), 4.0), values=())
    settings = dict(width=4, height=4, samples=1, integrator="path")
    for k in range(int(MAX_MEDIA) + 1):
        if k == int(MAX_MEDIA):
            result = render(scene, RenderSettings(**settings))
            assert result.stats.kernels == "compiled" and not result.stats.warnings, result.stats
        place(scene, primitives.box((0.3, 0.3, 0.3), center=(0.4 * (k % 5) - 0.8, 0.4 * (k // 5) - 0.6, 1.0)),
              0.05 * (k + 1), "Random")
    compiled = render(scene, RenderSettings(**settings))
    reference = render(scene, RenderSettings(kernels="numpy", **settings))
    assert compiled.stats.kernels == "compiled"
    np.testing.assert_allclose(compiled.image, reference.image, rtol=1e-6, atol=4e-7)
    assert len(np.unique(compiled.image[..., 0])) > 3                 # (boxes of different densities seen)
    notes = [w for w in compiled.stats.warnings if "volumes" in w]
    n = int(MAX_MEDIA) + 1
    assert len(notes) == 1 and f"{n} media ({n} of them kept per object" in notes[0], notes
    assert f"at most {int(MAX_MEDIA)} at once" in notes[0] and "MAX_VOLUME_STACK_SIZE 32" in notes[0], notes


WORLD_FOG = 0.05        # (the world's absorbing medium's density in the nested boxes' test that has one)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("world", [False, True])
def test_a_ray_in_more_media_at_once_than_cycles_stack_holds_leaves_the_innermost_out_in_both_kernels(world, kernels):
    """Cycles' volume stack has 32 entries, one the end marker and, with a world volume, one the world's: room + 1
    nested boxes (31 + 1; 30 + 1 with a world fog) centred at z = 1 (box k: Random 0.01 (k + 1), density 4 x Random,
    2 - 0.03 k wide and half that high): a ray down the middle is in each box over its height, the media adding, and
    both kernels hold all but the one entered last (the innermost), as Cycles leaves out what its stack has no room
    for: exp(-sum over the held boxes of density_k height_k (1 - colour)), times the world fog's exp(-0.05 x 2.9
    (1 - colour)) over the ray from the near clip plane (z = 2.9) to the floor where there is one. (Primer's compiled
    stack held 16 before: the 17 to 31 nested media now render there as in the reference.)"""
    scene = two_boxes(times(object_info("Random"), 4.0), values=())
    if world:
        from core.lights import World
        scene.world = World(color=np.zeros(3), volume=[("ABSORPTION", 1.0, {"color": COLOR, "density": WORLD_FOG})])
    room = int(MAX_MEDIA) - int(world)
    n = room + 1
    sizes = 2.0 - 0.03 * np.arange(n)
    for k, size in enumerate(sizes):
        place(scene, primitives.box((size, size, size / 2.0), center=(0.0, 0.0, 1.0)), 0.01 * (k + 1), "Random")
    assert prepare(scene, RenderSettings(width=4, height=4)).extra["media"].room == room
    tau = float(np.sum((4.0 * 0.01 * (np.arange(n) + 1) * sizes / 2.0)[:room])) + (WORLD_FOG * 2.9 if world else 0.0)
    image, stats = rendered(scene, kernels)
    middle = image[1:3, 1:3]                    # (x, y = +-0.25: inside the innermost box, 1.07 wide)
    # (rtol 4e-4: the ray steps off each of its 64 surfaces by their robust offset, shortening the depths a little;
    # the innermost medium left out is 40 % of the light)
    np.testing.assert_allclose(middle, np.broadcast_to(GLOW * np.exp(-tau * (1.0 - COLOR)), middle.shape), rtol=4e-4)
    assert any(f"a ray is in at most {room} at once" in w for w in stats.warnings), stats.warnings


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_field_kept_per_object_reads_each_objects_own_object_coordinates(kernels):
    """The same box mesh placed twice by matrices (at x = -1 and, lifted by 0.25, at x = 1: z from 0.75 to 1.75)
    with density Random x 1.6 x (2 z_object + 1.5), z_object from -0.5 to 0.5 in each (its integral 1.5): each box
    keeps exp(-1.6 Random 1.5 (1 - colour)) whatever its height, as Cycles reads each object's own coordinates (the
    world's z would give the lifted box 1.6 Random 2.0)."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=GLOW))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(shared(times(times(object_info("Random"), 1.6), height(2.0, 1.5))))
    mesh = primitives.box((2.0, 4.0, 1.0))
    for x, z, value in ((-1.0, 1.0, 0.25), (1.0, 1.25, 0.75)):
        matrix = np.eye(4)
        matrix[:3, 3] = (x, 0.0, z)
        scene.meshes.append(mesh)
        scene.instances.append(Instance(len(scene.meshes) - 1, matrix, np.array([1]), f"Box {x}"))
        scene.instances[-1].random = value
    image, _ = rendered(scene, kernels)
    expected = halves(GLOW * np.exp(-1.6 * 0.25 * 1.5 * (1.0 - COLOR)), GLOW * np.exp(-1.6 * 0.75 * 1.5 * (1.0 - COLOR)))
    np.testing.assert_allclose(image, expected, rtol=1e-5)


def absorbing(scene_boxes, camera: Optional[Camera] = None) -> Scene:
    """A glowing floor (GLOW) at z = 0 seen by `camera` (None: camera_above) through one object holding the shared
    absorbing material of density 1 (sigma_t = 1 - COLOR), its mesh the shells `scene_boxes` [(size (3,), centre
    (3,))] together."""
    scene = Scene(camera=camera or camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=GLOW))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(shared(1.0))
    shells = [primitives.box(size, center=center) for size, center in scene_boxes]
    mesh = Mesh(np.concatenate([m.vertices for m in shells]),
                np.concatenate([m.triangles + 8 * k for k, m in enumerate(shells)]), name="Shells")
    scene.add_mesh(mesh, materials=np.array([1]), name="Shells")
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("shells, depth", [
    ([((4.0, 4.0, 1.0), (0.0, 0.0, 1.0))] * 2, 1.0),                                    # (two coincident shells)
    ([((4.0, 4.0, 1.0), (0.0, 0.0, 1.0)), ((3.9, 3.9, 0.99), (0.0, 0.0, 1.0))], 0.995),  # (one just inside)
    ([((4.0, 4.0, 1.0), (0.0, 0.0, 1.0)), ((4.0, 4.0, 1.0), (0.0, 0.0, 1.5))], 1.0),    # (overlapping halfway)
])
def test_a_ray_in_one_objects_medium_twice_over_is_in_it_once_as_in_cycles_stack(shells, depth, kernels):
    """One object whose mesh holds two shells, seen from above: Cycles' volume_stack_enter skips an (object, shader)
    already on the stack and volume_stack_exit takes it off at the first back face, so the ray is in the medium
    from the first front face to the first back face, once: two coincident shells z 0.5 .. 1.5 let through
    exp(-sigma_t 1), not exp(-2 sigma_t) (the ray steps past both faces at once there, too); a shell just inside
    (z 0.505 .. 1.495) exp(-sigma_t (1.5 - 0.505)); a
    second shell raised by 0.5 (z 1 .. 2) exp(-sigma_t (2 - 1)), where counting entries gave 2 and 1.5."""
    image, stats = rendered(absorbing(shells), kernels)
    np.testing.assert_allclose(image, np.broadcast_to(GLOW * np.exp(-depth * (1.0 - COLOR)), image.shape), rtol=1e-5)
    assert not any("volume" in w for w in stats.warnings), stats.warnings


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_camera_inside_two_shells_of_one_object_starts_in_their_medium_once(kernels):
    """The camera at z = 3 inside an object of two shells, z 0.5 .. 3.5 and just inside it 0.505 .. 3.495 (the walk
    for the media a camera ray starts in meets a back face of each; Cycles' integrator_volume_stack_init adds an
    object once): the ray is in the medium until the inner shell's back face takes it off the stack, the floor seen
    through exp(-sigma_t (2.99 - 0.505)) (an orthographic ray starts at Clip Start, 0.01 below the camera), where
    counting entries gave 2 x 2.485 + 0.005."""
    matrix = np.eye(4)
    matrix[2, 3] = 3.0
    camera = Camera(matrix_world=matrix, type="ORTHO", ortho_scale=2.0, clip_start=0.01, clip_end=20.0)
    scene = absorbing([((4.0, 4.0, 3.0), (0.0, 0.0, 2.0)), ((3.9, 3.9, 2.99), (0.0, 0.0, 2.0))], camera)
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, np.broadcast_to(GLOW * np.exp(-2.485 * (1.0 - COLOR)), image.shape), rtol=1e-5)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("marched", [False, True])
def test_two_overlapping_objects_of_one_plain_material_are_two_media(marched, kernels):
    """Two objects holding the shared absorbing material (density 1, no Object Info read; marched: the 1 a graph's,
    Math 1 x 1, a heterogeneous medium), the second raised by 0.5 (z 0.5 .. 1.5 and 1 .. 2): Cycles' stack holds
    (object, shader) pairs, so where they overlap the ray is in both, exp(-sigma_t (0.5 + 2 x 0.5 + 0.5)); Primer
    keeps such a medium per object (its objects' boxes overlap), and one medium where they are apart."""
    scene = absorbing([((4.0, 4.0, 1.0), (0.0, 0.0, 1.0))])
    if marched:
        scene.materials[1] = shared(times(1.0, 1.0))
    scene.add_mesh(primitives.box((4.0, 4.0, 1.0), center=(0.0, 0.0, 1.5)), materials=np.array([1]), name="Raised")
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, np.broadcast_to(GLOW * np.exp(-2.0 * (1.0 - COLOR)), image.shape), rtol=1e-5)
    media = prepare(scene, RenderSettings(width=4, height=4)).extra["media"]
    assert len(media.g) == 2 and len(media.fields) == (2 if marched else 0)
    apart = two_boxes(1.0)
    assert len(prepare(apart, RenderSettings(width=4, height=4)).extra["media"].g) == 1


def coordinate(kind: str, axis: str = "Z") -> Link:
    """A graph: the point's `kind` (Object or Generated) coordinate along `axis`."""
    return Link(GraphNode("SEPARATE_XYZ", {}, {"Vector": Link(GraphNode("TEXCOORD"), kind)}), axis)


def gradient(kind: str) -> Link:
    """A graph: 2 x (the point's `kind` z) + 0.5 (Generated, 0 .. 1 in the texture space) or + 1.5 (Object, -0.5 ..
    0.5 in the box): a density linear in the texture space's (the object's) height, positive in the box."""
    offset = 0.5 if kind == "Generated" else 1.5
    return Link(GraphNode("MATH", {"operation": "MULTIPLY_ADD"}, {"0": coordinate(kind), "1": 2.0, "2": offset}),
                "Value")


def placed_boxes(density, placements) -> Scene:
    """The glowing floor under one box mesh (2 x 4 x 1 about its origin: z_object from -0.5 to 0.5) placed by each of
    `placements` [(x, z, height scale, texspace or None)] (its centre at x, z, stretched along z by the scale), each
    holding the shared absorbing material of density `density` (a graph reading no Object Info)."""
    scene = Scene(camera=camera_above())
    scene.materials.append(Material(np.zeros(3), "Glow", emission=GLOW))
    scene.add_mesh(primitives.plane(20.0), materials=np.array([0]))
    scene.materials.append(shared(density))
    scene.meshes.append(primitives.box((2.0, 4.0, 1.0)))
    for x, z, stretch, texspace in placements:
        matrix = np.diag([1.0, 1.0, stretch, 1.0])
        matrix[:3, 3] = (x, 0.0, z)
        scene.instances.append(Instance(len(scene.meshes) - 1, matrix, np.array([1]), f"Box {x}", texspace=texspace))
    return scene


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("kind", ["Generated", "Object"])
def test_a_field_on_boxes_of_different_placements_and_texture_spaces_reads_each_objects_own_coordinates(kind, kernels):
    """Density 2 h + 0.5 (h the point's Generated z) or 2 h + 1.5 (its Object z; the graph reads no Object Info) on
    one box mesh placed
    twice: at x = -1, z 0.5 .. 1.5, texture space location 0, size (1, 1, 0.5) (Generated z = z_object + 0.5, 0 .. 1),
    and at x = 1 stretched 1.5 times, z 0.5 .. 2, texture space location (0, 0, 0.25), size 1 (Generated z =
    (z_object - 0.25) / 2 + 0.5, 0.125 .. 0.625). Cycles shades each object's volume in its own object and texture
    space: the left lets through exp(-1.5 (1 - colour)) either way (mean density 1.5 over depth 1); the right
    exp(-1.25 x 1.5 (1 - colour)) by Generated, exp(-1.5 x 1.5 (1 - colour)) by Object (Primer used to read both in
    the left box's space, and warned). Each box is its own
    field, nothing said."""
    scene = placed_boxes(gradient(kind), [(-1.0, 1.0, 1.0, ((0.0, 0.0, 0.0), (1.0, 1.0, 0.5))),
                                          (1.0, 1.25, 1.5, ((0.0, 0.0, 0.25), (1.0, 1.0, 1.0)))])
    image, stats = rendered(scene, kernels)
    right = 1.25 * 1.5 if kind == "Generated" else 1.5 * 1.5
    expected = halves(GLOW * np.exp(-1.5 * (1.0 - COLOR)), GLOW * np.exp(-right * (1.0 - COLOR)))
    np.testing.assert_allclose(image, expected, rtol=1e-5)
    assert not any("volume" in w or "Shared" in w for w in stats.warnings), stats.warnings
    media = prepare(scene, RenderSettings(width=4, height=4)).extra["media"]
    assert len(media.fields) == 2
    np.testing.assert_allclose([f.size for f in media.fields], [(1.0, 1.0, 0.5), (1.0, 1.0, 1.0)])


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_one_box_placed_twice_with_one_texture_space_reads_alike_in_each_placement(kernels):
    """The box mesh placed at x = -1 (z 0.5 .. 1.5) and at x = 1 lifted by 0.25 (z 0.75 .. 1.75), both of texture
    space location 0, size 0.5 (Generated z = z_object + 0.5): density 2 Generated z + 0.5 lets through
    exp(-1.5 (1 - colour)) in both halves, as each is read in its own placement (in the first's, the lifted one's
    Generated z would run 0.25 .. 1.25: exp(-2 (1 - colour)))."""
    texspace = ((0.0, 0.0, 0.0), (0.5, 0.5, 0.5))
    scene = placed_boxes(gradient("Generated"), [(-1.0, 1.0, 1.0, texspace), (1.0, 1.25, 1.0, texspace)])
    image, _ = rendered(scene, kernels)
    np.testing.assert_allclose(image, halves(*[GLOW * np.exp(-1.5 * (1.0 - COLOR))] * 2), rtol=1e-5)


def test_objects_of_one_placement_and_texture_space_share_one_field_and_only_those():
    """A field whose graph reads no Object Info is one medium on objects alike in placement and texture space (two
    boxes built in world space, placed by the identity, and none given: the material's volume_space), and a medium
    per object only where they differ: the same two boxes given texture spaces of different sizes are two fields,
    and of one size one field again."""
    def fields(texspaces) -> list:
        scene = two_boxes(gradient("Generated"))
        for instance, texspace in zip(scene.instances[1:], texspaces):
            instance.texspace = texspace
        return prepare(scene, RenderSettings(width=4, height=4)).extra["media"].fields

    assert len(fields([None, None])) == 1
    one = ((0.0, 0.0, 1.0), (1.0, 2.0, 0.5))
    assert len(fields([one, one])) == 1
    two = fields([one, ((0.0, 0.0, 1.0), (1.0, 2.0, 1.0))])
    assert len(two) == 2 and [tuple(f.size) for f in two] == [(1.0, 2.0, 0.5), (1.0, 2.0, 1.0)]
