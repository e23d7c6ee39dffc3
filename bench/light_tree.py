"""The light tree against the global power CDF: noise at equal samples with many small emitters.

    .venv/bin/python bench/light_tree.py [--size 128] [--samples 8] [--reference 64] [--emitters 2000]
                                         [--scene room|cornell] [--lamp 1] [--seeds 1]
    .venv/bin/python bench/light_tree.py --variance [--emitters 300]

A 12 m x 12 m room lit by `emitters` small emissive triangles under its 3 m ceiling, their radiance spread
over three orders of magnitude, and a few boxes on the floor; a camera looks down on the floor (direct
light, compiled kernels). Each way of picking a triangle renders the same samples; the error is the
project's relMSE of 4x4 block means, mean((B(P) - B(R))^2 / (B(R)^2 + 0.01)), against a reference the
tree renders with `reference` (64) times the samples; then the CDF again with the samples the tree's time buys it (each
time the least of five runs, in processor seconds of all threads, which a shared machine disturbs less than
the clock). The old way is the same tree weighing power alone
(LightTree.by_power), which picks exactly as the global power CDF did; "tree Cycles" is the tree walked by Cycles'
mean of the upper and lower importance bounds' shares (light_tree.CYCLES), "light tree" by the upper bounds' share
alone (light_tree.UPPER, the renders'). The numbers go to docs/performance.md
by hand. --scene cornell renders a Cornell box lit by its ceiling quad instead (cut into --lamp x --lamp squares:
2 lamp^2 emissive triangles), path traced (4 bounces); --seeds averages each error over that many seeds of the
samples (the same reference).

--variance renders nothing: for 40 receivers under the room's emitters and under 400 triangles of random
orientation (one-sided, two-sided, mixed), it prints each rule's relative variance of a one-sample estimate of the
unshadowed direct light, sum_i c_i^2 / p_i / (sum_i c_i)^2 - 1, with c_i what triangle i sends (Lambert's polygon
formula) and p_i its pick probability (enumerated over the tree): the pick's own noise, closed form, no rendering.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from core import render  # noqa: E402
from core.camera import Camera  # noqa: E402
from core.film.compare import relative_mse_of_blocks  # noqa: E402
from core.geometry import primitives  # noqa: E402
from core.lights import emitters as emitters_  # noqa: E402
from core.lights.light_tree import CYCLES, POWER, UPPER  # noqa: E402
from core.scene import Material, Mesh, RenderSettings, Scene  # noqa: E402


def many_emitters_room(count: int, seed: int = 1) -> Scene:
    """The room: floor, boxes, and `count` small downward triangles of 12 radiances under the ceiling."""
    rng = np.random.default_rng(seed)
    matrix = np.eye(4)
    matrix[:3, 3] = [0.0, 0.0, 2.4]
    scene = Scene(camera=Camera(matrix_world=matrix, type="ORTHO", ortho_scale=12.0, clip_start=0.01))
    grey = scene.add_material((0.6, 0.6, 0.6))
    scene.add_mesh(primitives.plane(12.0), materials=np.array([grey]))
    for x, y in rng.uniform(-4.5, 4.5, (6, 2)):
        scene.add_mesh(primitives.box((0.8, 0.8, 1.0), center=(x, y, 0.5)), materials=np.array([grey]))
    lamps = []
    for k, radiance in enumerate(np.geomspace(0.5, 500.0, 12)):
        scene.materials.append(Material(np.zeros(3), f"Lamp {k}", emission=np.full(3, radiance)))
        lamps.append(len(scene.materials) - 1)
    centre = np.column_stack([rng.uniform(-6.0, 6.0, count), rng.uniform(-6.0, 6.0, count),
                              rng.uniform(2.6, 2.95, count)])
    angle = rng.uniform(0.0, 2.0 * np.pi, count)[:, None] + np.array([0.0, 2.0, 4.0]) * np.pi / 3.0
    r = 0.06
    corners = np.stack([centre[:, None, 0] + r * np.cos(-angle), centre[:, None, 1] + r * np.sin(-angle),
                        np.repeat(centre[:, 2:], 3, axis=1)], axis=2)       # clockwise from above: facing down
    mesh = Mesh(corners.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3),
                material_indices=rng.integers(0, len(lamps), count))
    scene.add_mesh(mesh, materials=np.array(lamps))
    return scene


def cornell_box(lamp: int = 1) -> Scene:
    """A 2 m Cornell box (white floor, ceiling and back, red left and green right walls, two white boxes) lit by a
    0.5 m square of radiance 15 under its ceiling facing down, cut into lamp x lamp squares (2 lamp^2 triangles)."""
    scene = Scene(camera=Camera.look_at((0.0, -3.8, 1.0), (0.0, 0.0, 1.0), fov=np.radians(40.0), clip_start=0.01))
    white, red, green = (scene.add_material(c) for c in ((0.73, 0.73, 0.73), (0.65, 0.05, 0.05), (0.12, 0.45, 0.15)))

    def quad(corners, material):
        scene.add_mesh(Mesh(np.array(corners, np.float64), np.array([[0, 1, 2], [0, 2, 3]])),
                       materials=np.array([material]))

    quad([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)           # floor, facing up
    quad([(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)           # ceiling, facing down
    quad([(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)             # back, facing -y
    quad([(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)           # left, facing +x
    quad([(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)             # right, facing -x
    scene.add_mesh(primitives.box((0.6, 0.6, 1.2), center=(-0.35, 0.3, 0.6)), materials=np.array([white]))
    scene.add_mesh(primitives.box((0.6, 0.6, 0.6), center=(0.4, -0.3, 0.3)), materials=np.array([white]))
    scene.materials.append(Material(np.zeros(3), "Lamp", emission=np.full(3, 15.0), emission_sampling="FRONT"))
    edges = np.linspace(-0.25, 0.25, lamp + 1)
    x0, y0 = np.meshgrid(edges[:-1], edges[:-1], indexing="ij")
    x1, y1 = x0 + 0.5 / lamp, y0 + 0.5 / lamp
    z = np.full_like(x0, 1.99)
    cells = np.stack([np.stack(c, axis=-1) for c in ((x0, y0, z), (x0, y1, z), (x1, y1, z), (x1, y0, z))], axis=2)
    vertices = cells.reshape(-1, 3)                                          # (facing down: clockwise from above)
    first = 4 * np.arange(lamp * lamp)[:, None]
    triangles = np.concatenate([first + [0, 1, 2], first + [0, 2, 3]])
    scene.add_mesh(Mesh(vertices, triangles), materials=np.array([len(scene.materials) - 1]))
    return scene


def render_with(scene: Scene, settings: RenderSettings, rule: int, repeat: int = 1):
    """The image (H, W, 3) and processor seconds (all threads) of a render (the least of `repeat` runs: the
    machine is shared), the emitters picked by the tree walked by `rule` (light_tree.CYCLES, UPPER or POWER)."""
    original = emitters_.from_geometry

    def with_rule(*args, **kwargs):
        emitters = original(*args, **kwargs)
        if emitters is not None:
            emitters.tree = emitters.tree.with_rule(rule)
        return emitters

    emitters_.from_geometry = with_rule
    try:
        seconds = []
        for _ in range(repeat):
            start = time.process_time()
            image = render.render(scene, settings).image[..., :3]
            seconds.append(time.process_time() - start)
        return image, min(seconds)
    finally:
        emitters_.from_geometry = original


def lambert_irradiance(P: np.ndarray, N: np.ndarray, V: np.ndarray) -> np.ndarray:
    """The irradiance per unit radiance of triangles V (t, 3, 3) wholly above the horizon of P (3,) with normal N (3,):
    Lambert's polygon formula. (t,) float64"""
    r = V - P
    r = r / np.linalg.norm(r, axis=2, keepdims=True)
    total = np.zeros(len(V))
    for k in range(3):
        a, b = r[:, k], r[:, (k + 1) % 3]
        gamma = np.cross(a, b)
        total += np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0)) * (
            gamma / np.linalg.norm(gamma, axis=1, keepdims=True) @ N)
    return 0.5 * np.abs(total)


def pick_variance(emitters, P: np.ndarray, N: np.ndarray) -> float:
    """The mean over receivers P, N (n, 3) of the relative variance of the one-sample unshadowed direct light
    (module docstring) with the emitters' tree as it is."""
    p = emitters.tree.all_pick_probabilities(P, N)
    c = np.array([emitters.emission.mean(axis=1) * lambert_irradiance(x, n, emitters.corners) for x, n in zip(P, N)])
    height = np.einsum("tk,ntk->nt", emitters.normal, emitters.corners[None, :, 0] - P[:, None])
    c *= (emitters.sides[None] & np.where(height > 0.0, 2, 1)) != 0          # sampled from P's side
    with np.errstate(divide="ignore", invalid="ignore"):
        variance = np.where(c > 0.0, c * c / p, 0.0).sum(axis=1) / c.sum(axis=1) ** 2 - 1.0
    return float(variance.mean())


def variance_table(count: int) -> None:
    """Print each rule's pick variance (module docstring) in the room and in scattered triangles."""
    from core.lights import MeshEmitters
    rng = np.random.default_rng(5)
    room = many_emitters_room(count)
    mesh, instance = room.meshes[-1], room.instances[-1]
    radiance = np.array([room.materials[instance.materials[k]].emission for k in mesh.material_indices])
    scenes = {f"room, {count} emitters": (mesh.vertices[mesh.triangles], radiance, np.ones(count, np.int32),
                                          np.column_stack([rng.uniform(-6.0, 6.0, (40, 2)), np.zeros(40)]))}
    for name, sides in (("one-sided", 1), ("two-sided", 3), ("mixed", None)):
        r = np.random.default_rng(13)
        corners = r.random((400, 1, 3)) * 4.0 + r.normal(size=(400, 3, 3)) * 0.1
        emission = r.random((400, 3)) ** 3 * 10.0
        sides = r.integers(1, 4, 400) if sides is None else np.full(400, sides)
        scenes[f"400 scattered, {name}"] = (corners, emission, sides.astype(np.int32),
                                            np.column_stack([rng.uniform(-1.0, 5.0, (40, 2)), np.full(40, -1.5)]))
    for name, (corners, emission, sides, P) in scenes.items():
        emitters = MeshEmitters.of(corners, emission, sides, np.arange(len(corners)))
        N = np.tile([0.0, 0.0, 1.0], (len(P), 1))
        row = []
        for rule_name, rule in (("power", POWER), ("Cycles", CYCLES), ("upper", UPPER)):
            emitters.tree = emitters.tree.with_rule(rule)
            row.append(f"{rule_name} {pick_variance(emitters, P, N):.4f}")
        print(f"{name:26s}", "  ".join(row), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--emitters", type=int, default=None, help="the room's emitters (2000; 300 with --variance)")
    parser.add_argument("--reference", type=int, default=64, help="the reference's samples per test sample")
    parser.add_argument("--kernels", default="compiled")
    parser.add_argument("--scene", choices=("room", "cornell"), default="room")
    parser.add_argument("--lamp", type=int, default=1, help="the Cornell box's lamp cut into lamp x lamp squares")
    parser.add_argument("--seeds", type=int, default=1, help="errors averaged over this many seeds")
    parser.add_argument("--variance", action="store_true", help="the pick's closed-form variance per rule instead")
    args = parser.parse_args()
    if args.variance:
        variance_table(args.emitters or 300)
        return
    scene = many_emitters_room(args.emitters or 2000) if args.scene == "room" else cornell_box(args.lamp)
    bounces = {} if args.scene == "room" else {"integrator": "path", "max_bounces": 4}

    def settings(samples, seed):
        return RenderSettings(width=args.size, height=args.size, samples=samples, light_samples=1, seed=seed,
                              kernels=args.kernels, adaptive=False, **bounces)

    reference, seconds = render_with(scene, settings(args.reference * args.samples, 99), UPPER)
    print(f"reference: {args.reference * args.samples} samples, {seconds:.1f} s, mean {reference.mean():.4f}")
    times = {}

    def error(samples, rule, repeat):
        """The image of seed 1, its processor seconds, and the relMSE averaged over the seeds."""
        image, seconds = render_with(scene, settings(samples, 1), rule, repeat=repeat)
        errors = [relative_mse_of_blocks(image, reference)]
        for seed in range(2, args.seeds + 1):
            errors.append(relative_mse_of_blocks(render_with(scene, settings(samples, seed), rule)[0], reference))
        return image, seconds, float(np.mean(errors))

    for name, rule in (("power CDF", POWER), ("tree Cycles", CYCLES), ("light tree", UPPER)):
        image, seconds, relmse = error(args.samples, rule, 5)
        times[rule] = seconds
        print(f"{name:11s}: {args.samples} samples, {seconds:6.2f} s, mean {image.mean():.4f}, relMSE {relmse:.5f}")
    # Equal time: the power CDF with as many more samples as the tree's time buys it.
    samples = max(args.samples, round(args.samples * times[UPPER] / times[POWER]))
    image, seconds, relmse = error(samples, POWER, 5)
    print(f"power CDF  : {samples} samples, {seconds:6.2f} s, mean {image.mean():.4f}, relMSE {relmse:.5f} "
          "(equal time)")


if __name__ == "__main__":
    main()
