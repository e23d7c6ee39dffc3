"""Animations in real Blender (the bpy module), rendered the way `blender -b file.blend -a` and a render
farm's workers render them: one .blend, frames split over processes, each frame's image identical.

A script builds a small animated .blend in a fresh process (a moving camera, a light whose power is
keyframed, a sphere deformed by a keyframed shape key, a cube whose Subdivision levels are keyframed so
its topology changes every frame, a static ground plane; Denoise on, the light and the world in two light
groups). Then the frames are rendered once in a
single process and again split over two "worker" processes, as Flamenco's chunks split them, and
every channel of every multilayer EXR must be equal bit for bit. Nothing is mocked: run_bpy runs bpy
with Primer loaded from this checkout, in isolated user folders (tests/blender_env.py).
"""
from __future__ import annotations

import concurrent.futures
import json
import os

import numpy as np
import pytest

from blender_env import ROOT, run_bpy

pytestmark = pytest.mark.blender
TOOLS = os.path.join(ROOT, "tools")
FRAMES = (1, 2, 3, 4)

# Shared by the scripts below: Primer loaded, a spy that keeps every frame's RenderRecord, output settings.
PRELUDE = """
import json, os, sys
import bpy
from blender_env import report
sys.path.insert(0, {tools!r})
from render import load_primer

primer = load_primer()
engine = sys.modules[primer.__name__ + ".addon.engine"]
records = []
render_frame = engine.render_frame


def recording(*args):
    record = render_frame(*args)
    records.append({{"frame": record.frame, "meshes_read": record.meshes_read, "error": record.error,
                    "warnings": record.warnings, "export_seconds": record.export_seconds}})
    return record


engine.render_frame = recording


def multilayer_output(scene, pattern):
    # Every enabled pass in one 32-bit float EXR per frame (Blender 5.0: a media type; 4.2: a file format).
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE"
    else:
        settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"
    scene.render.filepath = os.path.abspath(pattern)
    scene.render.use_file_extension = True
"""

BUILD = PRELUDE + """
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "PRIMER"
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 32, 100
scene.primer.samples = 4
scene.frame_start, scene.frame_end = 1, 4
scene.render.use_persistent_data = True                  # Primer keeps unchanged meshes between frames
layer = scene.view_layers[0]
layer.use_pass_z = layer.use_pass_normal = True
multilayer_output(scene, "//frames/frame_####")

bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, -1))
bpy.context.object.name = "Ground"
bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, location=(-1.2, 0, 0))
sphere = bpy.context.object
sphere.name = "Deforming"
sphere.shape_key_add(name="Basis")
bulge = sphere.shape_key_add(name="Bulge")
for point in bulge.data:
    point.co.z *= 1.8
bulge.value = 0.0
bulge.keyframe_insert("value", frame=1)
bulge.value = 1.0
bulge.keyframe_insert("value", frame=4)
bpy.ops.mesh.primitive_cube_add(size=1.2, location=(1.2, 0, 0))
cube = bpy.context.object
cube.name = "Remeshed"
subdivision = cube.modifiers.new("Subdivision", "SUBSURF")
for frame, levels in zip((1, 2, 3, 4), (0, 1, 2, 3)):          # new topology every frame
    subdivision.levels = subdivision.render_levels = levels
    subdivision.keyframe_insert("levels", frame=frame)
    subdivision.keyframe_insert("render_levels", frame=frame)
bpy.ops.object.light_add(type="POINT", location=(2, -3, 4))
light = bpy.context.object.data
light.shadow_soft_size = 0.5
light.energy = 400.0
light.keyframe_insert("energy", frame=1)
light.energy = 1200.0
light.keyframe_insert("energy", frame=4)
bpy.context.object.lightgroup = "key"                  # a light group, and the world in another
layer.lightgroups.add(name="key")
layer.lightgroups.add(name="sky")
scene.world = bpy.data.worlds.new("World")
scene.world.color = (0.05, 0.06, 0.08)
scene.world.lightgroup = "sky"
scene.primer.use_denoising = True                      # Denoise: the compositor's Denoise node and its passes
bpy.ops.object.camera_add(location=(0, -8, 1.5), rotation=(1.35, 0, 0))
camera = bpy.context.object
scene.camera = camera
camera.keyframe_insert("location", frame=1)
camera.location.x = 1.0
camera.keyframe_insert("location", frame=4)
bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(sys.argv[1]))
primer.unregister()             # bpy 4.2 crashes at exit while a Python RenderEngine is registered
report(saved=sys.argv[1])
"""

# A worker: opens the .blend (its settings travel in it), sends the frames to its own folder, and renders
# either a chunk as `blender -b f.blend -s S -e E -j J -a` does, or single frames as `-f N` does.
WORKER = PRELUDE + """
job = json.loads(sys.argv[1])
bpy.ops.wm.open_mainfile(filepath=os.path.abspath(job["blend"]))
scene = bpy.context.scene
if job.get("persistent") is not None:
    scene.render.use_persistent_data = job["persistent"]
multilayer_output(scene, os.path.join(job["out"], "frame_####"))
if "chunk" in job:                                      # -s S -e E -j J -a
    scene.frame_start, scene.frame_end, scene.frame_step = job["chunk"]
    bpy.ops.render.render(animation=True)
else:                                                   # -f N, one frame after another in one process
    pattern = scene.render.filepath
    for frame in job["stills"]:
        # write_still keeps the '#' (`blender -f` fills them in): name the frame's file here.
        scene.render.filepath, scene.render.use_file_extension = pattern, True
        path = scene.render.frame_path(frame=frame)
        scene.render.filepath, scene.render.use_file_extension = path, False
        scene.frame_set(frame)
        bpy.ops.render.render(write_still=True)
primer.unregister()
report(records=records, files=sorted(os.listdir(job["out"])))
"""


# Flamenco's "Simple Blender Render" job (Flamenco 3), as its job compiler writes each task's command line for
# the workers. Written here from its documented behaviour; Flamenco itself (a Go manager and workers) cannot
# run on this machine, so its workers are stood in for by processes that run that command line.
def flamenco_chunks(frames: str, chunk_size: int) -> list:
    """Flamenco's frame chunks of a frame list ('1-10,20-25,40', '1..4'): the sorted distinct frames, taken
    chunk_size at a time; in each chunk a run of three or more frames is written 'a-b', the others singly."""
    wanted = set()
    for part in frames.replace("..", "-").split(","):
        ends = [int(end) for end in part.split("-")]
        wanted.update(range(ends[0], ends[-1] + 1))
    ordered = sorted(wanted)
    chunks = []
    for first in range(0, len(ordered), chunk_size):
        runs, chunk = [], ordered[first:first + chunk_size]
        for frame in chunk:
            if runs and frame == runs[-1][-1] + 1:
                runs[-1].append(frame)
            else:
                runs.append([frame])
        chunks.append(",".join(f"{run[0]}-{run[-1]}" if len(run) > 2 else ",".join(map(str, run)) for run in runs))
    return chunks


def flamenco_commands(blendfile: str, frames: str, chunk_size: int, output: str, file_format: str) -> list:
    """The `blender` arguments of each render task: the job's default blenderArgs ('-b -y'), the .blend, then
    --render-output (the job's path, ending in ######), --render-format (the scene's file_format, read when
    the job was submitted) and --render-frame (the chunk in Blender's 'a..b' notation)."""
    return [["-b", "-y", blendfile, "--render-output", output, "--render-format", file_format,
             "--render-frame", chunk.replace("-", "..")] for chunk in flamenco_chunks(frames, chunk_size)]


def test_flamenco_chunks_as_its_job_compiler_makes_them():
    """Frame lists split as Flamenco's job compiler splits them (the cases of its own tests)."""
    assert flamenco_chunks("1-10,20-25,40", 4) == ["1-4", "5-8", "9,10,20,21", "22-25", "40"]
    assert flamenco_chunks("1..10,20..25,40,3..8", 4) == ["1-4", "5-8", "9,10,20,21", "22-25", "40"]
    assert flamenco_chunks("47", 4) == ["47"] and flamenco_chunks("1-3", 3) == ["1-3"]
    assert flamenco_chunks("1-4", 3) == ["1-3", "4"]


# A Flamenco worker's `blender` process: the arguments of one task, applied in order as Blender's command
# line applies them (the .blend opens where it stands; --render-frame renders each listed frame on its own,
# writing it as an animation frame to the output path with its #'s filled in).
CLI_WORKER = PRELUDE + """
args = json.loads(sys.argv[1])
scene = None
while args:
    arg = args.pop(0)
    if arg in ("-b", "-y"):                             # background; trust the file's scripts
        continue
    if arg == "--render-output":
        scene.render.filepath = args.pop(0)
    elif arg == "--render-format":
        file_format = args.pop(0)
        settings = scene.render.image_settings
        if file_format == "OPEN_EXR_MULTILAYER" and hasattr(settings, "media_type"):
            settings.media_type = "MULTI_LAYER_IMAGE"   # Blender 5.0: multilayer is a media type
        else:
            settings.file_format = file_format
    elif arg == "--render-frame":
        for part in args.pop(0).split(","):
            first, _, last = part.partition("..")
            for frame in range(int(first), int(last or first) + 1):
                scene.frame_start = scene.frame_end = frame
                bpy.ops.render.render(animation=True)
    else:                                               # the .blend
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(arg))
        scene = bpy.context.scene
primer.unregister()
report(records=records)
"""


def read_channels(path: str) -> dict:
    """Return every channel of a (multi-part, multilayer) EXR: full channel name -> (H, W) float32."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(path)
    assert inp is not None, f"cannot read {path}: {oiio.geterror()}"
    channels, part = {}, 0
    try:
        while inp.seek_subimage(part, 0):
            spec = inp.spec()
            pixels = np.asarray(inp.read_image(part, 0, 0, spec.nchannels, oiio.FLOAT), np.float32)
            pixels = pixels.reshape(spec.height, spec.width, spec.nchannels)
            for index, name in enumerate(spec.channelnames):
                channels[name] = pixels[..., index]
            part += 1
    finally:
        inp.close()
    return channels


def pass_channels(channels: dict, name: str) -> np.ndarray:
    """Return the channels of the view layer's pass `name` (ViewLayer.<pass>.<channel>) stacked: (H, W, c)."""
    found = [values for key, values in sorted(channels.items()) if key.startswith(f"ViewLayer.{name}.")]
    assert found, f"no pass {name!r} among {sorted(channels)}"
    return np.stack(found, axis=-1)


def rgb(channels: dict, name: str) -> np.ndarray:
    """Return the R, G, B channels of the view layer's pass `name`: (H, W, 3)."""
    return np.stack([channels[f"ViewLayer.{name}.{c}"] for c in "RGB"], axis=-1)


def run_worker(folder, blend: str, name: str, **job) -> dict:
    """Run WORKER in its own process and folder; return its report with the frames it wrote, read back."""
    work = os.path.join(folder, name)
    out = os.path.join(work, "frames")
    os.makedirs(out, exist_ok=True)
    job.update(blend=blend, out=out)
    result = run_bpy(WORKER.format(tools=TOOLS), work, json.dumps(job))
    result["frames"] = {int(f[len("frame_"):-len(".exr")]): read_channels(os.path.join(out, f))
                        for f in result["files"]}
    return result


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """The animation rendered by one process (with and without Persistent Data) and split over two workers."""
    folder = str(tmp_path_factory.mktemp("animation"))
    blend = os.path.join(folder, "animation.blend")
    run_bpy(BUILD.format(tools=TOOLS), folder, blend)
    jobs = {
        "single": dict(chunk=(1, 4, 1)),                               # blender -b animation.blend -a
        "fresh": dict(chunk=(1, 4, 1), persistent=False),              # the same without Persistent Data
        "odd": dict(chunk=(1, 4, 2)),                                  # -s 1 -e 4 -j 2 -a: frames 1, 3
        "even": dict(stills=(4, 2)),                                   # -f 4, then -f 2, backwards
    }
    # Flamenco: frames 1-4 in chunks of 3 ("1..3" and "4"), each task in its own worker process, all writing
    # to the job's shared output folder; the format is the one the .blend was saved with.
    shared = os.path.join(folder, "flamenco", "render", "animation", "2026-11-26_140000")
    commands = flamenco_commands(blend, "1-4", 3, os.path.join(shared, "######"), "OPEN_EXR_MULTILAYER")
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        futures = {name: pool.submit(run_worker, folder, blend, name, **job) for name, job in jobs.items()}
        tasks = [pool.submit(run_bpy, CLI_WORKER.format(tools=TOOLS), make_folder(folder, f"task{i}"),
                             json.dumps(command)) for i, command in enumerate(commands)]
        results = {name: future.result() for name, future in futures.items()}
        results["flamenco"] = {"commands": commands, "records": [r for t in tasks for r in t.result()["records"]],
                               "files": sorted(os.listdir(shared)),
                               "frames": {int(f[:-len(".exr")]): read_channels(os.path.join(shared, f))
                                          for f in os.listdir(shared)}}
        return results


def make_folder(parent: str, name: str) -> str:
    """Return the folder parent/name, made if missing."""
    path = os.path.join(parent, name)
    os.makedirs(path, exist_ok=True)
    return path


def test_every_frame_is_identical_whichever_process_renders_it(renders):
    """Each frame rendered by a worker (chunk with a frame step, or -f frames out of order) equals, in every
    channel of every pass and bit for bit, the same frame of a single process that rendered them all."""
    single = renders["single"]["frames"]
    assert sorted(single) == list(FRAMES)
    split = {**renders["odd"]["frames"], **renders["even"]["frames"]}
    assert sorted(renders["odd"]["frames"]) == [1, 3] and sorted(renders["even"]["frames"]) == [2, 4]
    for frame in FRAMES:
        assert sorted(split[frame]) == sorted(single[frame])
        for channel, values in single[frame].items():
            assert np.array_equal(split[frame][channel], values), f"frame {frame}, channel {channel} differs"


def test_a_flamenco_job_split_over_workers_gives_the_single_process_frames(renders):
    """Simple Blender Render's tasks ("--render-frame 1..3" and "4", with the job's ###### output path and
    the .blend's multilayer format), each run by its own worker process, write frames 000001-000004.exr
    equal bit for bit, in every channel of every pass (the light groups' and the compositor's denoised
    Combined among them), to one process rendering the whole animation."""
    flamenco = renders["flamenco"]
    assert [c[-1] for c in flamenco["commands"]] == ["1..3", "4"]
    assert flamenco["files"] == [f"{frame:06d}.exr" for frame in FRAMES]
    assert sorted(r["frame"] for r in flamenco["records"]) == list(FRAMES)
    assert all(r["error"] == "" for r in flamenco["records"])
    single = renders["single"]["frames"]
    for frame in FRAMES:
        assert sorted(flamenco["frames"][frame]) == sorted(single[frame])
        for channel, values in single[frame].items():
            assert np.array_equal(flamenco["frames"][frame][channel], values), f"frame {frame}, {channel} differs"


def test_meshes_kept_between_frames_render_as_a_fresh_export(renders):
    """Keeping unchanged meshes between frames (Persistent Data) changes no bit of any frame."""
    for frame in FRAMES:
        fresh, kept = renders["fresh"]["frames"][frame], renders["single"]["frames"][frame]
        for channel, values in fresh.items():
            assert np.array_equal(kept[channel], values), f"frame {frame}, channel {channel} differs"


def test_only_changed_meshes_are_read_after_the_first_frame(renders):
    """With Persistent Data, frame 1 reads every mesh and later frames only the deforming sphere and the
    cube whose topology changes; without it, every frame reads every mesh."""
    kept = {r["frame"]: sorted(r["meshes_read"]) for r in renders["single"]["records"]}
    assert len(kept[1]) == 3
    for frame in FRAMES[1:]:
        assert kept[frame] == ["Deforming", "Remeshed"], kept
    fresh = {r["frame"]: r["meshes_read"] for r in renders["fresh"]["records"]}
    assert all(len(fresh[frame]) == 3 for frame in FRAMES), fresh
    assert all(r["error"] == "" for name in renders for r in renders[name]["records"])


def test_changed_topology_is_read_again_every_frame(renders):
    """The cube whose subdivision level changes every frame is read again every frame even with Persistent
    Data, and its frames equal those of a process that read everything (a kept mesh of the wrong topology
    would show in Depth)."""
    for record in renders["single"]["records"]:
        assert "Remeshed" in record["meshes_read"], record
    for frame in FRAMES:
        assert np.array_equal(pass_channels(renders["single"]["frames"][frame], "Depth"),
                              pass_channels(renders["fresh"]["frames"][frame], "Depth"))


def test_frames_differ_where_the_camera_moved_and_the_light_changed(renders):
    """Consecutive frames differ in Combined and Depth; every pass the view layer enables is in each file:
    the denoiser's guides and both light groups too, whose passes add up to the (noisy) Combined."""
    frames = renders["single"]["frames"]
    for frame in FRAMES:
        passes = {key.split(".")[-2] for key in frames[frame]}
        assert {"Combined", "Depth", "Normal", "Denoising Albedo", "Denoising Normal", "Combined_key",
                "Combined_sky"} <= passes, passes
        key, sky = rgb(frames[frame], "Combined_key"), rgb(frames[frame], "Combined_sky")
        assert key.mean() > sky.mean() > 0
        np.testing.assert_allclose(key + sky, rgb(frames[frame], "Combined"), rtol=1e-4, atol=1e-5)
        # The compositor's output (Blender writes it as the Composite layer): the denoised Combined.
        denoised = np.stack([frames[frame][f"Composite.Combined.{c}"] for c in "RGB"], axis=-1)
        assert np.isfinite(denoised).all() and not np.array_equal(denoised, rgb(frames[frame], "Combined"))
    for a, b in zip(FRAMES, FRAMES[1:]):
        assert not np.array_equal(pass_channels(frames[a], "Combined"), pass_channels(frames[b], "Combined"))


STATIC = PRELUDE + """
out = os.path.abspath("frames")
bpy.ops.wm.read_factory_settings(use_empty=False)          # cube, light, camera: nothing moves
scene = bpy.context.scene
scene.render.engine = "PRIMER"
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 32, 100
scene.primer.samples = 2
scene.objects["Light"].data.shadow_soft_size = 1.0               # soft shadows: noise to compare
results = {{}}


def animation(name, start, end, **settings):
    records.clear()
    scene.frame_start, scene.frame_end = start, end
    for key, value in settings.items():
        setattr(scene.primer, key, value)
    multilayer_output(scene, os.path.join(out, name, "frame_####"))
    try:
        bpy.ops.render.render(animation=True)
        error = ""
    except RuntimeError as exc:
        error = str(exc)
    folder = os.path.join(out, name)
    results[name] = {{"error": error, "records": list(records),
                     "files": sorted(os.listdir(folder)) if os.path.isdir(folder) else []}}


animation("seed_fixed", 1, 2, animate_seed=False)
animation("seed_animated", 1, 2, animate_seed=True)
scene.primer.animate_seed = False
# Blender's properties never hold an empty range: setting End before Start moves Start (and back).
scene.frame_start, scene.frame_end = 3, 2
results["range_after_end_before_start"] = [scene.frame_start, scene.frame_end]
scene.frame_end, scene.frame_start = 2, 3
results["range_after_start_after_end"] = [scene.frame_start, scene.frame_end]
# The command line can: `blender -b f.blend -s 5 -e 2 -a` renders no frame, and Primer says why.
results["empty_note"] = engine.empty_range_note(5, 2)
results["no_note"] = engine.empty_range_note(2, 2)
scene.view_layers[0].use_pass_z = scene.view_layers[0].use_pass_normal = True
animation("all_passes", 1, 1, use_denoising=True, debug_passes=True)
scene.primer.use_denoising = scene.primer.debug_passes = False
scene.view_layers[0].use_pass_z = scene.view_layers[0].use_pass_normal = False
# An output folder below a file: no one, root included, can write there.
open(os.path.join(out, "a_file"), "w").close()
records.clear()
scene.frame_start, scene.frame_end = 1, 2
multilayer_output(scene, os.path.join(out, "a_file", "frames", "frame_####"))
try:
    bpy.ops.render.render(animation=True)
    blender_error = ""
except RuntimeError as exc:
    blender_error = str(exc)
# Nothing lost: the frame stays in the Render Result, which can be saved elsewhere.
kept = os.path.join(out, "kept.exr")
bpy.data.images["Render Result"].save_render(filepath=kept, scene=scene)
results["unwritable"] = {{"error": blender_error, "records": list(records), "kept": kept}}
primer.unregister()
report(results=results, out=out)
"""


@pytest.fixture(scope="module")
def static(tmp_path_factory):
    """A still scene (Blender's default cube) rendered as short animations with various settings and bad input."""
    folder = str(tmp_path_factory.mktemp("static"))
    return run_bpy(STATIC.format(tools=TOOLS), folder)


def static_frame(static, name: str, frame: int) -> np.ndarray:
    """Return Combined of one frame of one of STATIC's animations: (H, W, 4)."""
    path = os.path.join(static["out"], name, f"frame_{frame:04d}.exr")
    return pass_channels(read_channels(path), "Combined")


def test_animate_seed_changes_the_noise_between_frames_and_only_then(static):
    """In a scene where nothing moves, frames 1 and 2 are equal with Animate Seed off (seed fixed) and differ
    with it on (seed + frame, as Cycles' Animated Seed)."""
    assert np.array_equal(static_frame(static, "seed_fixed", 1), static_frame(static, "seed_fixed", 2))
    assert not np.array_equal(static_frame(static, "seed_animated", 1), static_frame(static, "seed_animated", 2))
    # Frame 1 with the seed animated is seed 0 + 1, not the fixed seed 0.
    assert not np.array_equal(static_frame(static, "seed_animated", 1), static_frame(static, "seed_fixed", 1))


def test_multilayer_exr_holds_every_enabled_pass(static):
    """With Denoise, Z, Normal and the debug passes on, the multilayer EXR holds each of Primer's passes."""
    path = os.path.join(static["out"], "all_passes", "frame_0001.exr")
    passes = {key.split(".")[-2] for key in read_channels(path)}
    wanted = {"Combined", "Depth", "Normal", "Denoising Albedo", "Denoising Normal", "Primer Face Normal",
              "Primer NdotL", "Primer Shadow", "Primer Rays"}
    assert wanted <= passes, sorted(passes)


def test_empty_frame_range_is_reported_clearly(static):
    """Blender's properties keep Start <= End; for an empty range from the command line (-s 5 -e 2 -a, where
    Blender renders nothing), Primer's message names both frames and how to fix it."""
    results = static["results"]
    for start, end in (results["range_after_end_before_start"], results["range_after_start_after_end"]):
        assert start <= end
    assert "frame range is empty (End 2 is before Start 5)" in results["empty_note"]
    assert "-s/-e" in results["empty_note"]
    assert results["no_note"] == ""


def test_unwritable_output_path_is_reported_and_the_frame_kept(static):
    """An output folder that cannot be made: Primer warns before rendering, naming the path; Blender stops
    with its own "cannot save" error, without crashing; the rendered frame is saved from the Render Result."""
    result = static["results"]["unwritable"]
    assert [r["frame"] for r in result["records"]] == [1]
    warnings = result["records"][0]["warnings"]
    assert any("cannot write frame 1" in w and "a_file" in w for w in warnings), warnings
    assert "cannot save" in result["error"]
    kept = pass_channels(read_channels(result["kept"]), "Combined")
    assert np.array_equal(kept, static_frame(static, "seed_fixed", 1))
