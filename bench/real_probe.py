"""One real scene's speed against Cycles in a few minutes (issue 34), between full `make bench` runs.

    .venv/bin/python bench/real_probe.py real-SCENE-INTEGRATOR [PRIMER_COUNTS [CYCLES_COUNT]]
    .venv/bin/python bench/real_probe.py real-gltf_damaged_helmet-path 8,16,32,64,128 64

The scene is the bench's rigged real scene (bench/out/real/, rigged by the bench's real phase, `bench/run.py
--real SCENE`) and its Cycles reference at 1024 samples is the bench's own (bench/refs/, rendered here
when missing: minutes). Both engines render in one Blender process after a warm-up each, Primer's ladder first, as
the bench's ladder does; each render prints its wall seconds, its relMSE against the reference, its mean against
the reference's and where Primer's time went; the last line interpolates Primer's seconds to Cycles' relMSE on
the log-log line through the two Primer counts around it, and the ratio to Cycles' seconds (the bench's ratio, from
one run).
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
import scenes  # noqa: E402


class Plan:
    """The bench's reference samples (common.Plan's full run)."""
    reference_samples = 1024


def seconds_to(error: float, ladder: list):
    """Primer's seconds to `error` on the log-log line through the two ladder points (relMSE, seconds) around it,
    or None where the ladder does not bracket it."""
    points = sorted(ladder)
    below = [p for p in points if p[0] <= error]
    above = [p for p in points if p[0] > error]
    if not below or not above:
        return None
    (e0, t0), (e1, t1) = below[-1], above[0]
    f = (math.log(error) - math.log(e0)) / (math.log(e1) - math.log(e0))
    return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))


def main(argv: list) -> None:
    """Render the ladders and print the measurements (module docstring)."""
    name = argv[0]
    primer_counts = [int(x) for x in (argv[1] if len(argv) > 1 else "16,32,64,128").split(",")]
    cycles_count = int(argv[2]) if len(argv) > 2 else 64
    ref, meta, _ = scenes.reference(name, Plan)
    scene = scenes.open_scene(name)
    scenes.use_primer(scene, 1)
    scenes.render_timed()
    scenes.use_cycles(scene, 1)
    scenes.render_timed()
    ladder = []
    for engine, n in [("PRIMER", n) for n in primer_counts] + [("CYCLES", cycles_count)]:
        (scenes.use_primer if engine == "PRIMER" else scenes.use_cycles)(scene, n)
        seconds = scenes.render_timed()
        image = scenes.save_render(scene, os.path.join(common.OUT, "probe", name, f"{engine.lower()}_{n}.exr"))
        error = common.rel_mse(image, ref)
        line = (f"{name} {engine} {n:4d} {seconds:6.2f}s relMSE {error:.3e} "
                f"mean {image[..., :3].mean() / ref[..., :3].mean():.4f}")
        if engine == "PRIMER":
            ladder.append((error, seconds))
            spent = scenes.time_spent(scenes.primer_record(), seconds)
            line += " " + " ".join(f"{k}={spent[k]:.3g}" for k in ("export", "bvh", "embree", "shading", "rays"))
        print(line, flush=True)
    to = seconds_to(error, ladder)
    print(f"{name} SUMMARY Cycles {seconds:.2f} s relMSE {error:.3e}; Primer to the same relMSE "
          + (f"{to:.2f} s, ratio {to / seconds:.3f}" if to is not None else "not bracketed by its ladder"), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
