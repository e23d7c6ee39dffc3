"""The sample scenes inside Blender (bpy): Cycles references, the speed-against-error ladders, Primer's
profile, and Primer's rays per second against embreex's on the same rays.

Run by bench/run.py, one process per job (bpy keeps global state):

    .venv/bin/python bench/scenes.py ladder NAME [--quick]     -> bench/out/scenes/NAME.json
    .venv/bin/python bench/scenes.py profile [--quick]         -> bench/out/profile.json
    .venv/bin/python bench/scenes.py rays NAME [--quick]       -> bench/out/rays_NAME.json

Timing: each measurement is the wall time of one `bpy.ops.render.render()` call, so Primer's export
from the depsgraph, BVH build, tracing and writing the passes are all included, as are Cycles' scene
sync, BVH build and kernel. The image is saved afterwards, outside the timed call. Both engines run in
the same process, alternating, after one untimed warm-up render each; the median of the repeats is
quoted.
"""
from __future__ import annotations

import argparse
import importlib
import os
import statistics
import sys
import time
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (puts the checkout, tools/ and tests/ on sys.path)

from render import configure_cycles_reference, configure_output, load_primer  # noqa: E402  tools/render.py

REFERENCE_SEEDS = (1001, 1002)      # never 0: the ladder's Cycles renders use seed 0 and must not share samples


# ----------------------------------------------------------------------------
# Rendering inside Blender
# ----------------------------------------------------------------------------

def open_scene(name: str):
    """Open the bench scene NAME (sample_scenes/NAME.blend, or a rigged real scene: common.blend_of) with Primer
    registered; return the scene, set to write float EXR."""
    import bpy

    load_primer()                   # first, so that the file's engine PRIMER exists when it opens
    bpy.ops.wm.open_mainfile(filepath=common.blend_of(name))
    scene = bpy.context.scene
    configure_output(scene, os.path.join(common.OUT, "unused.exr"))
    return scene


def use_primer(scene, samples: int, threads: int = 0) -> None:
    """Switch the scene to Primer with `samples` camera samples per pixel (light samples as the file has them)."""
    scene.render.engine = "PRIMER"
    scene.primer.samples = samples
    scene.primer.threads = threads


def use_cycles(scene, samples: int, seed: int = 0) -> None:
    """Switch the scene to Cycles as Primer's reference (tools/render.py) with `samples` and `seed`."""
    configure_cycles_reference(scene, samples)
    scene.cycles.seed = seed


def render_timed() -> float:
    """Render the current scene with its engine and return the wall time of bpy.ops.render.render()."""
    import bpy

    start = time.perf_counter()
    bpy.ops.render.render()
    return time.perf_counter() - start


def save_render(scene, path: str):
    """Save the last render result as a linear float EXR at `path` and return it read back: (H, W, 4) float32."""
    import bpy

    os.makedirs(os.path.dirname(path), exist_ok=True)
    bpy.data.images["Render Result"].save_render(filepath=path, scene=scene)
    return common.read_exr(path)


def primer_record():
    """Return Primer's RenderRecord of the last render (addon/engine.py), failing loudly on a render error."""
    record = sys.modules["primer.addon.engine"].last_render
    if record.error:
        raise RuntimeError(f"Primer failed: {record.error}")
    return record


# ----------------------------------------------------------------------------
# The converged reference
# ----------------------------------------------------------------------------

def reference(name: str, plan: common.Plan) -> tuple:
    """Return (image (H, W, 4) float32, metadata dict, rendered now?) of the scene's Cycles reference, cached
    in bench/refs/.

    Cycles renders the scene twice at half the samples with different seeds; the reference is their mean,
    and half their squared difference estimates the reference's own noise (its error floor).
    """
    import bpy

    import numpy as np

    blend = common.blend_of(name)
    settings = {"engine": "CYCLES", "samples": plan.reference_samples, "seeds": list(REFERENCE_SEEDS),
                "light_paths": "the Primer integrator's", "filter": "BOX 1 px", "denoising": False, "adaptive_sampling": False,
                "view_transform": "Standard", "file": "OpenEXR float32 (linear)",
                "configured_by": "tools/render.py configure_cycles_reference"}
    key = common.digest(blend, settings, bpy.app.version_string, os.path.join(common.ROOT, "tools", "render.py"))
    path = os.path.join(common.REFS, f"{name}-{key}.exr")
    meta_path = path[:-4] + ".json"
    meta = common.read_json(meta_path)
    if meta is not None and os.path.isfile(path):
        return common.read_exr(path), meta, False
    scene = open_scene(name)
    halves, seconds = [], 0.0
    for seed in REFERENCE_SEEDS:
        use_cycles(scene, plan.reference_samples // len(REFERENCE_SEEDS), seed)
        seconds += render_timed()
        halves.append(save_render(scene, os.path.join(common.OUT, "scenes", name, f"reference_seed{seed}.exr")))
    image = (0.5 * (halves[0].astype(np.float64) + halves[1])).astype(np.float32)
    # Var(mean of two) = E[(h1 - h2)^2] / 4 per pixel: the reference's expected squared error.
    noise = (halves[0][..., :3].astype(np.float64) - halves[1][..., :3]) ** 2 / 4.0
    r = image[..., :3].astype(np.float64)
    meta = {"settings": settings, "bpy": bpy.app.version_string, "blend": os.path.relpath(blend, common.ROOT),
            "seconds": seconds, "size": list(image.shape[:2]),
            "noise_rmse": float(np.sqrt(noise.mean())),
            "noise_relmse": float(np.mean(noise / (r * r + common.REL_MSE_GUARD)))}
    from core.film.image_io import write_image

    os.makedirs(common.REFS, exist_ok=True)
    write_image(path + ".part.exr", image)
    os.replace(path + ".part.exr", path)
    common.write_json(meta_path, meta)
    return image, meta, True


# ----------------------------------------------------------------------------
# Jobs
# ----------------------------------------------------------------------------

def ladder(name: str, plan: common.Plan) -> dict:
    """Time Primer and Cycles at every sample count of the plan and measure each image's error; Primer's rows
    also carry where its time went (export, BVH, Embree, shading, write: the render's RenderRecord)."""
    ref, ref_meta, fresh = reference(name, plan)
    primer_ladder, cycles_ladder, repeats = plan.ladders(name)
    scene = open_scene(name)
    folder = os.path.join(common.OUT, "scenes", name)
    # Warm-up: the first render of each engine in a process loads kernels and modules.
    use_primer(scene, 1)
    render_timed()
    use_cycles(scene, 1)
    render_timed()
    runs = [("PRIMER", n) for n in primer_ladder] + [("CYCLES", n) for n in cycles_ladder]
    times = {run: [] for run in runs}
    images, spent = {}, {}
    for repeat in range(repeats):
        # Alternate the engines: Primer first on even steps, Cycles first on odd ones.
        pairs = [(("PRIMER", p), ("CYCLES", c)) for p, c in zip(primer_ladder, cycles_ladder)]
        extra = runs[len(pairs):len(primer_ladder)] + runs[len(primer_ladder) + len(pairs):]
        order = []
        for step, (a, b) in enumerate(pairs):
            order += [a, b] if (step + repeat) % 2 == 0 else [b, a]
        order += extra
        for engine, samples in order:
            if engine == "PRIMER":
                use_primer(scene, samples)
            else:
                use_cycles(scene, samples)
            seconds = render_timed()
            if engine == "PRIMER":
                spent.setdefault(samples, []).append(time_spent(primer_record(), seconds))
            times[(engine, samples)].append(seconds)
            if repeat == 0:
                images[(engine, samples)] = save_render(scene, os.path.join(folder, f"{engine.lower()}_{samples}.exr"))
        print(f"{name}: repeat {repeat + 1}/{repeats} done", flush=True)
    rows = []
    for engine, samples in runs:
        image = images[(engine, samples)]
        if image.shape != ref.shape:
            raise RuntimeError(f"{name}: {engine} wrote {image.shape}, the reference is {ref.shape}")
        rows.append({"scene": name, "engine": engine, "samples": samples,
                     "seconds": statistics.median(times[(engine, samples)]), "all_seconds": times[(engine, samples)],
                     **common.errors(image, ref)})
        if engine == "PRIMER":          # the repeat of median wall time
            rows[-1]["spent"] = sorted(spent[samples], key=lambda s: s["wall"])[len(spent[samples]) // 2]
    return {"scene": name, "reference": {**ref_meta, "rendered_now": fresh}, "rows": rows}


def time_spent(record, wall: float) -> dict:
    """Where a Primer render's wall time went, from its RenderRecord (addon/engine.py): seconds per part."""
    stats = record.stats
    return {"wall": wall, "primer": record.seconds, "export": record.export_seconds, "bvh": stats.geometry_seconds,
            "embree": stats.trace_seconds, "shading": stats.shading_seconds, "render": stats.seconds,
            "write": record.write_seconds, "rays": stats.rays, "triangles": stats.triangles}


def denoise(name: str, plan: common.Plan) -> dict:
    """Time Primer with and without Render > Denoise (Blender's Denoise node fed with Primer's passes) at every
    sample count of the plan's denoise ladder and measure each composited image's error against Cycles'."""
    ref, ref_meta, fresh = reference(name, plan)
    scene = open_scene(name)
    folder = os.path.join(common.OUT, "denoise", name)
    scene.render.use_compositing = True
    for denoised in (False, True):              # warm-up: kernels, modules, the denoiser's first filter
        scene.primer.use_denoising = denoised
        use_primer(scene, 1)
        render_timed()
    runs = [(samples, denoised) for samples in plan.denoise_ladder for denoised in (False, True)]
    times = {run: [] for run in runs}
    images = {}
    for repeat in range(plan.repeats):
        for samples, denoised in (runs if repeat % 2 == 0 else runs[::-1]):
            scene.primer.use_denoising = denoised
            use_primer(scene, samples)
            times[(samples, denoised)].append(render_timed())
            record = primer_record()
            if denoised and record.warnings:
                raise RuntimeError(f"{name}: Denoise did not run: {record.warnings}")
            if repeat == 0:
                label = "denoised" if denoised else "plain"
                images[(samples, denoised)] = save_render(scene, os.path.join(folder, f"{label}_{samples}.exr"))
    rows = [{"scene": name, "samples": samples, "denoised": denoised,
             "seconds": statistics.median(times[(samples, denoised)]), "all_seconds": times[(samples, denoised)],
             **common.errors(images[(samples, denoised)], ref)} for samples, denoised in runs]
    return {"scene": name, "reference": {**ref_meta, "rendered_now": fresh}, "rows": rows}


def profile(plan: common.Plan, samples: int = 16) -> dict:
    """Return Primer's time per phase for every scene at `samples`, on one thread and on all cores."""
    out = {}
    for name in plan.scenes:
        scene = open_scene(name)
        use_primer(scene, 1)
        render_timed()                  # warm-up
        entry = {}
        for threads in (1, 0):
            use_primer(scene, samples, threads)
            runs = []
            for _ in range(plan.repeats):
                wall = render_timed()
                runs.append(time_spent(primer_record(), wall))
            runs.sort(key=lambda r: r["wall"])
            entry["one_thread" if threads == 1 else "all_cores"] = runs[len(runs) // 2]    # the median run
        out[name] = entry
        print(f"profile {name}: {entry['one_thread']['wall']:.2f} s on one thread", flush=True)
    return {"samples": samples, "scenes": out}


def rays(name: str, plan: common.Plan, percentage: int = 200, samples: int = 16) -> dict:
    """Primer's end-to-end rays per second on one scene, against embreex's on the very same rays.

    Primer renders the scene through bpy (timed end to end). Then the exported scene is rendered again
    with core alone while every ray batch that reaches Embree is recorded (the float32 arrays Embree
    gets), each with the path vertex it belongs to (-1: camera rays; k: the shadow rays of vertex k and the
    BSDF rays leaving it, which find vertex k + 1), and the batches are replayed through embreex directly,
    timing only embreex's calls: first one batch after another on one thread (also per vertex), then on a
    pool of one thread per core.
    """
    import numpy as np

    scene = open_scene(name)
    scene.render.resolution_percentage = percentage
    # Every pixel gets its samples (adaptive sampling off): the recording (Python reference) and the timed
    # renders (compiled) then trace the same camera rays, however their noise estimates differ.
    scene.primer.use_adaptive_sampling = False
    use_primer(scene, 1)
    render_timed()
    use_primer(scene, samples)
    render_timed()
    record = primer_record()

    # Render once more, untimed, recording every ray batch that reaches Embree (the float32 arrays
    # Embree gets) and the triangles of the BVH.
    Tracer = importlib.import_module("primer.core.geometry.intersect").Tracer
    to_f32 = importlib.import_module("primer.core.geometry.intersect")._f32_rays
    direct = importlib.import_module("primer.core.integrators.direct")
    path = importlib.import_module("primer.core.integrators.path")
    shadows = importlib.import_module("primer.core.integrators.shadows")
    batches, meshes = [], []
    original = {name: getattr(Tracer, name) for name in ("__init__", "intersect", "occluded")}
    # Which path vertex the integrator is at: camera_hits traces the camera rays, shade_vertex(..., PathState) a vertex.
    at = {"vertex": -1, "shadow": False}
    hooks = {(direct, "camera_hits"): direct.camera_hits, (path, "camera_hits"): path.camera_hits,
             (direct, "shade_vertex"): direct.shade_vertex, (path, "shade_vertex"): path.shade_vertex,
             (shadows, "transmittance"): shadows.transmittance}

    def transmittance(*args, **kwargs):             # shadow rays through transparent surfaces: nearest-hit queries
        at["shadow"] = True
        try:
            return hooks[(shadows, "transmittance")](*args, **kwargs)
        finally:
            at["shadow"] = False

    def camera_hits(*args, **kwargs):
        at["vertex"] = -1
        return hooks[(direct, "camera_hits")](*args, **kwargs)

    def shade(*args, **kwargs):
        state = kwargs.get("path", args[6] if len(args) > 6 else None)
        at["vertex"] = state.vertex if state is not None else 0
        return hooks[(direct, "shade_vertex")](*args, **kwargs)

    def init(self, vertices, triangles, *args, **kwargs):
        if kwargs.get("instanced"):
            raise RuntimeError("the rays phase replays one triangle soup; this scene has instanced meshes")
        meshes.append((np.ascontiguousarray(vertices, np.float32), np.ascontiguousarray(triangles, np.int32)))
        original["__init__"](self, vertices, triangles, *args, **kwargs)

    def recording(query):
        def traced(self, origins, directions, t_max, times=None):
            o, d, t = to_f32(origins, directions, t_max)
            active = t >= 0.0           # (t_max < 0 would mark a ray Embree skips)
            kind = "shadow" if query == "occluded" or at["shadow"] else ("camera" if at["vertex"] < 0 else "bsdf")
            batches.append((query, np.ascontiguousarray(o[active]), np.ascontiguousarray(d[active]),
                            np.ascontiguousarray(t[active]), at["vertex"], kind))
            return original[query](self, origins, directions, t_max, times)
        return traced

    # The compiled render traces its rays inside its C chunk; for the recording, the Python reference
    # renders instead: it asks Tracer.intersect and Tracer.occluded the very same rays, to float32
    # rounding (tests/test_compiled.py: the same rays traced, pixel for pixel).
    Tracer.__init__, Tracer.intersect, Tracer.occluded = init, recording("intersect"), recording("occluded")
    direct.camera_hits = path.camera_hits = camera_hits
    direct.shade_vertex = path.shade_vertex = shade
    shadows.transmittance = transmittance
    scene.primer.kernels = "NUMPY"
    try:
        render_timed()
    finally:
        for method_name, method in original.items():
            setattr(Tracer, method_name, method)
        for (owner, attribute), value in hooks.items():
            setattr(owner, attribute, value)
        scene.primer.kernels = "COMPILED"
    # Primer's statistics count camera rays and shadow rays (once each, where a shadow ray through transparent
    # surfaces asks Embree once per surface); the recording also has the BSDF rays (bounces, and the BSDF rays
    # that find lights with extent), which the stats leave out.
    counted = {kind: sum(len(b[1]) for b in batches if b[5] == kind) for kind in ("camera", "shadow", "bsdf")}
    # Every recorded query is a ray Primer traces: its own counts of camera and shadow rays, and the BSDF rays
    # (bounces, and those that find lights with extent), which its counts leave out (the excess).
    n_rays = sum(counted.values())
    if n_rays < record.rays or len(meshes) != 1:
        raise RuntimeError(f"recorded {counted} rays in {len(meshes)} BVH(s); the render traced "
                           f"{record.stats.primary_rays} camera and {record.stats.shadow_rays} shadow rays")
    vertices, triangles = meshes[0]

    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    raw = rtcore_scene.EmbreeScene(robust=True)
    mesh = TriangleMesh(raw, vertices, triangles)    # noqa: F841  (keeps the mesh alive)
    raw.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), query="OCCLUDED")    # build the BVH

    def run(batch) -> float:
        query, o, d, t = batch[:4]      # t: a fresh copy, since embreex writes the hit distances into it
        start = time.perf_counter()
        if query == "intersect":
            raw.run(o, d, dists=t, output=1)
        else:
            raw.run(o, d, dists=t, query="OCCLUDED")
        return time.perf_counter() - start

    def fresh():
        return [(query, o, d, t.copy(), vertex, kind) for query, o, d, t, vertex, kind in batches]

    # Rounds of: Primer's render end to end, then embreex on one thread, then on all cores. This
    # machine has slow and fast spells; within one round all three meet the same spell, so the
    # ratio of each round is the fair one, and the report gives the median of those ratios.
    walls, renders, one_thread, all_cores, seconds_in_embree = [], [], [], [], []
    vertices = sorted({b[4] for b in batches})
    by_vertex = {vertex: [] for vertex in vertices}
    cores = os.cpu_count() or 1
    for _ in range(plan.rays_rounds):
        walls.append(render_timed())
        record = primer_record()
        renders.append(record.stats.seconds)
        seconds_in_embree.append(record.stats.trace_seconds)
        spent = {vertex: 0.0 for vertex in vertices}
        for b in fresh():
            spent[b[4]] += run(b)
        for vertex in vertices:
            by_vertex[vertex].append(spent[vertex])
        one_thread.append(sum(spent.values()))
        copies = fresh()
        with ThreadPoolExecutor(max_workers=cores) as pool:
            start = time.perf_counter()
            list(pool.map(run, copies))
            all_cores.append(time.perf_counter() - start)
    stats = record.stats
    return {"scene": name, "percentage": percentage, "size": [scene.render.resolution_x * percentage // 100,
                                                              scene.render.resolution_y * percentage // 100],
            "samples": samples, "triangles": int(len(triangles)),
            "rays": n_rays, "primary_rays": stats.primary_rays, "shadow_rays": stats.shadow_rays,
            "bsdf_rays": n_rays - record.rays, "queries": counted,
            # Per path vertex (-1: the camera rays): its rays (shadow + BSDF), and embreex's one-thread time on them.
            "vertices": [{"vertex": vertex,
                          "shadow_rays": sum(len(b[1]) for b in batches if b[4] == vertex and b[5] == "shadow"),
                          "nearest_rays": sum(len(b[1]) for b in batches if b[4] == vertex and b[5] != "shadow"),
                          "embreex_one_thread": statistics.median(by_vertex[vertex])} for vertex in vertices],
            "batches": len(batches), "cores": cores, "rounds": len(walls),
            "primer_wall": statistics.median(walls), "primer_render": statistics.median(renders),
            "primer_embree_thread_seconds": statistics.median(seconds_in_embree),
            "embreex_one_thread": statistics.median(one_thread), "embreex_all_cores": statistics.median(all_cores),
            # Primer's rays per second over embreex's on all cores, round by round: embreex's time / Primer's.
            "share_by_round": [full / wall for full, wall in zip(all_cores, walls)]}


def integrators(name: str, plan: common.Plan) -> dict:
    """Each of Primer's integrators (DIRECT, WHITTED, PATH) on a path-traced scene: the time of a render and
    its error against the scene's Cycles reference (Cycles path tracing with the file's bounce limits), at a
    few sample counts. Direct light and Whitted's recursion leave light out (a bias no sample count removes);
    path tracing converges to the reference."""
    ref, _, _ = reference(name, plan)
    scene = open_scene(name)
    folder = os.path.join(common.OUT, "integrators", name)
    use_primer(scene, 1)
    render_timed()                                  # warm-up
    ladder_of = {"DIRECT": [4, 16, 64], "WHITTED": [4, 16] if plan.quick else [4, 16, 64],
                 "PATH": [4, 16, 64] if plan.quick else [4, 16, 64, 256]}
    rows = []
    for integrator, samples_list in ladder_of.items():
        scene.primer.integrator = integrator
        for samples in samples_list:
            use_primer(scene, samples)
            seconds = render_timed()
            record = primer_record()
            image = save_render(scene, os.path.join(folder, f"{integrator.lower()}_{samples}.exr"))
            rows.append({"scene": name, "integrator": integrator, "samples": samples, "seconds": seconds,
                         "kernels": record.stats.kernels, **common.errors(image, ref)})
            print(f"{name}: {integrator} {samples} done", flush=True)
    return {"scene": name, "rows": rows}


def main(argv=None) -> int:
    """Run one job and write its JSON into bench/out/."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("job", choices=("ladder", "profile", "rays", "denoise", "integrators"))
    parser.add_argument("name", nargs="?")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    plan = common.Plan(args.quick)
    try:
        if args.job == "ladder":
            common.write_json(os.path.join(common.OUT, "scenes", f"{args.name}.json"), ladder(args.name, plan))
        elif args.job == "profile":
            common.write_json(os.path.join(common.OUT, "profile.json"), profile(plan))
        elif args.job == "denoise":
            common.write_json(os.path.join(common.OUT, f"denoise_{args.name}.json"), denoise(args.name, plan))
        elif args.job == "integrators":
            common.write_json(os.path.join(common.OUT, f"integrators_{args.name}.json"), integrators(args.name, plan))
        else:
            common.write_json(os.path.join(common.OUT, f"rays_{args.name}.json"), rays(args.name, plan))
    finally:
        if "primer" in sys.modules:         # bpy 4.2 crashes at exit while Primer is registered
            sys.modules["primer"].unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
