"""The light tree against the global power CDF: noise at equal samples with many small emitters.

    .venv/bin/python bench/light_tree.py [--size 128] [--samples 8] [--reference 64] [--emitters 2000]

A 12 m x 12 m room lit by `emitters` small emissive triangles under its 3 m ceiling, their radiance spread
over three orders of magnitude, and a few boxes on the floor; a camera looks down on the floor (direct
light, compiled kernels). Each way of picking a triangle renders the same samples; the error is the
project's relMSE of 4x4 block means, mean((B(P) - B(R))^2 / (B(R)^2 + 0.01)), against a reference the
tree renders with `reference` (64) times the samples; then the CDF again with the samples the tree's time buys it (each
time the least of five runs, in processor seconds of all threads, which a shared machine disturbs less than
the clock). The old way is the same tree weighing power alone
(LightTree.by_power), which picks exactly as the global power CDF did. The numbers go to docs/performance.md
by hand.
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


def render_with(scene: Scene, settings: RenderSettings, by_power: bool, repeat: int = 1):
    """The image (H, W, 3) and processor seconds (all threads) of a render (the least of `repeat` runs: the
    machine is shared), the emitters picked by the tree or by power alone."""
    original = emitters_.from_geometry

    def power_only(*args, **kwargs):
        emitters = original(*args, **kwargs)
        if emitters is not None:
            emitters.tree = emitters.tree.by_power()
        return emitters

    emitters_.from_geometry = power_only if by_power else original
    try:
        seconds = []
        for _ in range(repeat):
            start = time.process_time()
            image = render.render(scene, settings).image[..., :3]
            seconds.append(time.process_time() - start)
        return image, min(seconds)
    finally:
        emitters_.from_geometry = original


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--emitters", type=int, default=2000)
    parser.add_argument("--reference", type=int, default=64, help="the reference's samples per test sample")
    parser.add_argument("--kernels", default="compiled")
    args = parser.parse_args()
    scene = many_emitters_room(args.emitters)

    def settings(samples, seed):
        return RenderSettings(width=args.size, height=args.size, samples=samples, light_samples=1, seed=seed,
                              kernels=args.kernels, adaptive=False)

    reference, seconds = render_with(scene, settings(args.reference * args.samples, 99), by_power=False)
    print(f"reference: {args.reference * args.samples} samples, {seconds:.1f} s, mean {reference.mean():.4f}")
    times = {}
    for name, by_power in (("power CDF", True), ("light tree", False)):
        image, seconds = render_with(scene, settings(args.samples, 1), by_power, repeat=5)
        times[by_power] = seconds
        print(f"{name:10s}: {args.samples} samples, {seconds:6.2f} s, mean {image.mean():.4f}, "
              f"relMSE {relative_mse_of_blocks(image, reference):.5f}")
    # Equal time: the power CDF with as many more samples as the tree's time buys it.
    samples = max(args.samples, round(args.samples * times[False] / times[True]))
    image, seconds = render_with(scene, settings(samples, 1), True, repeat=5)
    print(f"power CDF : {samples} samples, {seconds:6.2f} s, mean {image.mean():.4f}, "
          f"relMSE {relative_mse_of_blocks(image, reference):.5f} (equal time)")


if __name__ == "__main__":
    main()
