"""`make bench`: Primer against Cycles, speed against error, on this machine; then the report.

    .venv/bin/python bench/run.py [--quick] [--skip PHASE ...] [--real SCENE ...]

Phases, in order (each Blender job in its own process, with empty Blender user folders):
  scenes     the Cycles references (cached in bench/refs/) and both engines' sample ladders
  denoise    Primer with and without Render > Denoise on common.DENOISE_SCENES: error against time
  integrators  DIRECT, WHITTED and PATH on the path-traced scenes: time and error against Cycles' path tracing
  profile    Primer's time per phase on every scene
  rays       Primer's rays per second against embreex's on the same rays
  scaling    time and peak memory against triangles, pixels, lights and instances (core alone)
  memory     peak memory of a million-triangle mesh rendered in Blender, Primer against Cycles (bench/memory.py)
  stability  the hard cases of tests/hard_cases.py with both shadow offsets
  real       real scenes made by others (tools/real_scenes.py's cache), direct and path traced: both engines'
             ladders against a Cycles reference, and where Primer's time goes (skipped for scenes not fetched)
Then bench/report.py writes bench/REPORT.md, the plots in docs/images/bench/ and the "## Benchmark"
section of docs/performance.md. --quick measures a little of everything in a few minutes and writes
its report to bench/out/quick/ instead, leaving the committed report alone. Skipped phases keep their
measurements from bench/results/results.json (the last full run). --real SCENE ... measures only those real
scenes (tools/real_scenes.py names, both integrators) in the real phase and keeps the other real scenes' rows
from the last results: to add or re-measure one scene without the others' hour.
"""
from __future__ import annotations

import argparse
import datetime
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

PHASES = ("scenes", "denoise", "integrators", "profile", "rays", "scaling", "memory", "stability", "real")
# The path-traced sample scenes, where each integrator's cost is set against its error (the integrators phase).
INTEGRATOR_SCENES = ("cornell_box", "materials_glass")
RAYS_SCENES = ("modifiers_instances", "light_area", "cornell_box")
SCALING = {"triangles": [1e3, 1e4, 1e5, 1e6, 1e7], "pixels": [160 * 90, 320 * 180, 640 * 360, 1280 * 720,
                                                           1920 * 1080, 3840 * 2160],
           "lights": [1, 2, 4, 8, 16, 32, 64], "instances": [1, 10, 100, 1e3, 1e4, 1e5], "instances_fine": [1, 1e5],
           "samples_4k": [16]}
SCALING_QUICK = {"triangles": [1e3, 1e5], "pixels": [160 * 90, 640 * 360], "lights": [1, 8], "instances": [1, 100],
                 "instances_fine": [1, 100]}
SCALING_TIMEOUT = 240           # seconds per scaling point; a point past it is reported as skipped


def machine() -> dict:
    """Return what this machine and software are: CPU model, cores, memory, versions, date, commit."""
    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            names = [line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2 ** 30
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=common.ROOT, capture_output=True,
                            text=True).stdout.strip() or "unknown"
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=common.ROOT,
                           capture_output=True, text=True).stdout.strip()

    def version(package: str) -> str:
        try:
            return importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            return "not installed"

    return {"cpu": cpu, "cores": os.cpu_count(), "memory_gb": memory, "python": platform.python_version(),
            "bpy": version("bpy"), "embreex": version("embreex"), "numpy": version("numpy"),
            "openimageio": version("OpenImageIO"), "flip": version("flip-evaluator"),
            "matplotlib": version("matplotlib"), "system": platform.platform(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "commit": commit + (" (with uncommitted changes)" if dirty else "")}


def blender_job(*args: str, quick: bool) -> None:
    """Run bench/scenes.py with `args` in a fresh Blender process with empty user folders; raise on failure."""
    from blender_env import isolated_env          # tests/blender_env.py: empty HOME and Blender user folders

    folder = os.path.join(common.OUT, "blender-home")
    command = [sys.executable, os.path.join(common.BENCH, "scenes.py"), *args] + (["--quick"] if quick else [])
    done = subprocess.run(command, cwd=common.ROOT, env=isolated_env(folder), capture_output=True, text=True)
    for line in done.stdout.splitlines():
        if line.startswith(("profile ", "reference ")) or ": repeat " in line:
            print("   ", line, flush=True)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).splitlines()[-30:])
        raise RuntimeError(f"bench/scenes.py {' '.join(args)} failed ({done.returncode}):\n{tail}")


def run_ladders(names: list, quick: bool) -> dict:
    """Render the references and ladders of the scenes `names`; return {"rows": [...], "references": {...}}."""
    rows, references = [], {}
    for name in names:
        start = time.perf_counter()
        blender_job("ladder", name, quick=quick)
        result = common.read_json(os.path.join(common.OUT, "scenes", f"{name}.json"))
        rows += result["rows"]
        references[name] = result["reference"]
        print(f"  {name}: {time.perf_counter() - start:.0f} s", flush=True)
    return {"rows": rows, "references": references}


def run_scenes(plan: common.Plan) -> dict:
    """Render the references and ladders of every sample scene; return {"rows": [...], "references": {...}}."""
    return run_ladders(plan.scenes, plan.quick)


def run_real(plan: common.Plan, only: list = (), previous: dict = None) -> dict:
    """Rig each real scene once (bench/out/real/), then render its reference and ladders; return {"rows": [...],
    "references": {...}, "skipped": [(name, why)]} (a scene not in tools/real_scenes.py's cache is skipped).
    With `only` (scene names), measure only those and take the other scenes' rows, references and skips from
    `previous` (the last results' real phase)."""
    import real_scenes                              # tools/real_scenes.py

    names = [name for name in plan.real_scenes if not only or common.real_label(name)[0] in only]
    ready, skipped = [], []
    for name in names:
        blend = common.blend_of(name)
        if not os.path.exists(blend):
            scene, integrator = common.real_label(name)
            rigged, notes = real_scenes.rig(scene, integrator, *common.real_size(scene), out=blend)
            if not rigged:
                skipped.append((name, "; ".join(notes) + ": run `tools/real_scenes.py fetch` (docs/real_scenes.md)"))
                print(f"  {name}: skipped ({skipped[-1][1]})", flush=True)
                continue
        ready.append(name)
    measured = {**run_ladders(ready, plan.quick), "skipped": skipped}
    if not only:
        return measured
    kept = [name for name in plan.real_scenes if name not in names]
    previous = previous or {}
    return {"rows": [r for r in previous.get("rows", []) if r["scene"] in kept] + measured["rows"],
            "references": {**{k: v for k, v in previous.get("references", {}).items() if k in kept},
                           **measured["references"]},
            "skipped": [s for s in previous.get("skipped", []) if s[0] in kept] + skipped}


def run_denoise(plan: common.Plan) -> dict:
    """Render every denoise scene with and without Render > Denoise; return {"rows": [...], "references": {...}}."""
    rows, references = [], {}
    for name in common.DENOISE_SCENES:
        blender_job("denoise", name, quick=plan.quick)
        result = common.read_json(os.path.join(common.OUT, f"denoise_{name}.json"))
        rows += result["rows"]
        references[name] = result["reference"]
    return {"rows": rows, "references": references}


def run_scaling(quick: bool) -> dict:
    """Measure every scaling point in its own process; points past the timeout are noted as skipped."""
    points, notes = [], []
    for kind, values in (SCALING_QUICK if quick else SCALING).items():
        for value in values:
            command = [sys.executable, os.path.join(common.BENCH, "scaling.py"), kind, str(int(value))]
            try:
                done = subprocess.run(command, cwd=common.ROOT, capture_output=True, text=True,
                                      timeout=SCALING_TIMEOUT)
            except subprocess.TimeoutExpired:
                points.append({"kind": kind, "value": value, "skipped": f"over {SCALING_TIMEOUT} s"})
                notes.append(f"{kind} = {value:g} was skipped: it took longer than {SCALING_TIMEOUT} s.")
                print(f"  {kind} {value:g}: skipped (timeout)", flush=True)
                continue
            if done.returncode != 0:
                reason = (done.stderr.strip().splitlines() or ["failed"])[-1]
                points.append({"kind": kind, "value": value, "skipped": reason})
                notes.append(f"{kind} = {value:g} failed: {reason}")
                print(f"  {kind} {value:g}: failed: {reason}", flush=True)
                continue
            point = json.loads(done.stdout.strip().splitlines()[-1])
            points.append(point)
            print(f"  {kind} {value:g}: {point['seconds']:.2f} s, {point['peak_mb'] / 1024:.2f} GB", flush=True)
    from scaling import DEFAULTS

    baseline = min((p["baseline_mb"] for p in points if "baseline_mb" in p), default=0.0)
    return {"points": points, "notes": notes, "defaults": DEFAULTS, "baseline_mb": baseline}


MEMORY_TRIANGLES = 1_000_000      # the memory phase's mesh (--quick: a tenth)
MEMORY_REPEATS = 2                 # each engine's process, alternating; the smaller peak of each is kept


def run_memory(quick: bool) -> dict:
    """Peak memory of Primer's and Cycles' render of the same million-triangle grid, each in fresh Blender processes
    (bench/memory.py) with empty user folders, alternating; per engine the run of the smaller peak."""
    from blender_env import isolated_env          # tests/blender_env.py: empty HOME and Blender user folders

    triangles = MEMORY_TRIANGLES // (10 if quick else 1)
    env = isolated_env(os.path.join(common.OUT, "blender-home"))
    runs: dict = {"PRIMER": [], "CYCLES": []}
    for _ in range(MEMORY_REPEATS):
        for engine in runs:
            command = [sys.executable, os.path.join(common.BENCH, "memory.py"), engine, str(triangles)]
            done = subprocess.run(command, cwd=common.ROOT, env=env, capture_output=True, text=True)
            if done.returncode != 0:
                raise RuntimeError(f"bench/memory.py {engine} failed:\n" + "\n".join(done.stderr.splitlines()[-20:]))
            runs[engine].append(json.loads(done.stdout.strip().splitlines()[-1]))
    best = {engine: min(points, key=lambda p: p["peak_mb"]) for engine, points in runs.items()}
    for engine, point in best.items():
        print(f"  {engine}: peak {point['peak_mb']:.0f} MB (mesh built {point['built_mb']:.0f} MB), "
              f"{point['seconds']:.1f} s", flush=True)
    return {"triangles": triangles, "engines": best, "runs": runs}


def run_stability() -> list:
    """Run every hard case with both shadow offsets; return the table rows."""
    import hard_cases            # tests/hard_cases.py, shared with tests/test_hard_cases.py

    return hard_cases.table()


def print_summary(results: dict) -> None:
    """Print the headline and the stability table to the terminal."""
    import report

    lines, mean, _ = report.headline_table(results)
    print("\nHeadline (Primer's time to Cycles' 64-sample relMSE / Cycles' time):")
    print("\n".join(lines))
    print(f"geometric mean of the interpolated ratios: {report.fmt(mean)}")
    print("\nStability (fraction of wrong pixels):")
    print("\n".join(report.stability_table(results)))


def main(argv=None) -> int:
    """Run the benchmark phases, save the measurements and write the report."""
    parser = argparse.ArgumentParser(description="Primer's benchmark against Cycles.")
    parser.add_argument("--quick", action="store_true", help="a few minutes: three scenes, short ladders")
    parser.add_argument("--skip", nargs="*", default=[], choices=PHASES, help="phases to take from the last results")
    parser.add_argument("--real", nargs="*", default=[], choices=common.REAL_SCENES, metavar="SCENE",
                        help="the real phase measures only these scenes, the others' rows kept from the last results")
    args = parser.parse_args(argv)
    plan = common.Plan(args.quick)
    started = time.perf_counter()
    results_path = (os.path.join(common.OUT, "quick", "results.json") if args.quick
                    else os.path.join(common.RESULTS, "results.json"))
    previous = common.read_json(os.path.join(common.RESULTS, "results.json"), {}) or {}
    results = {"machine": machine(), "plan": plan.as_dict(), "load": {"start": os.getloadavg()[0]}}
    # The commit whose run measured each phase: this one, or for a skipped phase the one its numbers come from.
    measured_at = previous.get("machine", {}).get("phase_commits", {})
    results["machine"]["phase_commits"] = {
        phase: measured_at.get(phase, previous.get("machine", {}).get("commit", "?")) if phase in args.skip
        else results["machine"]["commit"] for phase in PHASES}
    # The commit whose run measured each real scene (--real measures some and keeps the others' rows).
    real_at = previous.get("machine", {}).get("real_commits", {})
    results["machine"]["real_commits"] = {
        name: (results["machine"]["phase_commits"]["real"] if "real" in args.skip or not args.real
               or common.real_label(name)[0] in args.real
               else real_at.get(name, measured_at.get("real", previous.get("machine", {}).get("commit", "?"))))
        for name in plan.real_scenes}
    for phase in PHASES:
        if phase in args.skip:
            results[phase] = previous.get(phase, [] if phase in ("rays", "stability", "integrators") else {})
            print(f"{phase}: taken from the last results", flush=True)
            continue
        print(f"{phase}:", flush=True)
        start = time.perf_counter()
        if phase == "scenes":
            results[phase] = run_scenes(plan)
        elif phase == "denoise":
            results[phase] = run_denoise(plan)
        elif phase == "integrators":
            results[phase] = []
            for name in INTEGRATOR_SCENES:
                blender_job("integrators", name, quick=plan.quick)
                results[phase].append(common.read_json(os.path.join(common.OUT, f"integrators_{name}.json")))
        elif phase == "profile":
            blender_job("profile", quick=plan.quick)
            results[phase] = common.read_json(os.path.join(common.OUT, "profile.json"))
        elif phase == "rays":
            results[phase] = []
            for name in RAYS_SCENES[:1] if plan.quick else RAYS_SCENES:
                blender_job("rays", name, quick=plan.quick)
                results[phase].append(common.read_json(os.path.join(common.OUT, f"rays_{name}.json")))
        elif phase == "scaling":
            results[phase] = run_scaling(plan.quick)
        elif phase == "memory":
            results[phase] = run_memory(plan.quick)
        elif phase == "real":
            results[phase] = run_real(plan, args.real, previous.get("real"))
        else:
            results[phase] = run_stability()
        results.setdefault("phase_seconds", {})[phase] = time.perf_counter() - start
        results.setdefault("load", {})[phase] = os.getloadavg()[0]
        print(f"  ({time.perf_counter() - start:.0f} s)", flush=True)
    results["machine"]["total_minutes"] = (time.perf_counter() - started) / 60.0
    if "scenes" in args.skip:                     # (the scenes' numbers, and the scenes measured again alone, are
        results["machine"]["reference_note"] = ""     # the last run's: no reference was rendered in this one)
        results["machine"]["scene_commits"] = previous.get("machine", {}).get("scene_commits", {})
    else:
        references = results["scenes"].get("references", {}).values()
        fresh = [r for r in references if r.get("rendered_now")]
        results["machine"]["reference_note"] = (
            f"{len(fresh)} Cycles reference(s) rendered in this run, {sum(r['seconds'] for r in fresh) / 60:.1f} "
            f"minutes of it" if fresh else "the Cycles references came from the bench/refs/ cache")
    common.write_json(results_path, results)
    import report

    folder = os.path.join(common.OUT, "quick") if args.quick else common.BENCH
    path = report.build(results, folder, folder if args.quick else common.PLOTS, docs=not args.quick)
    print_summary(results)
    print(f"\nreport: {os.path.relpath(path, common.ROOT)}  ({results['machine']['total_minutes']:.1f} minutes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
