"""Movie textures: one frame of a movie, decoded by Blender itself, as Cycles reads it.

Cycles asks Blender for a movie's frame through the image's Image User; from Python the only pixels Blender hands out
are the first frame's (Image.pixels), and OpenImageIO's wheel reads no movies. So Primer asks a second Blender: the
Blender running Primer (bpy.app.binary_path, in the background) or, where Primer runs inside the bpy module, the same
Python importing bpy, runs addon/movie_frame.py, which renders the frame through the sequencer into an OpenEXR file.
Each frame is decoded once per file version and kept in the temporary folder; a render reads it from there."""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "movie_frame.py")
# How long a second Blender may take to start and decode one frame before Primer gives up on it.
TIMEOUT_SECONDS = 120.0


def frame_file(movie: str, frame: int, width: int, height: int, colorspace: str, binary: str) -> str:
    """The OpenEXR file (a path) that holds frame `frame` (1 = the first) of the movie file `movie` at `width` x
    `height` in scene-linear values, decoding it with a second Blender (`binary`, or this Python's bpy where it is '')
    unless an earlier render did; OSError with Blender's last words where it cannot."""
    if not os.path.isfile(movie):
        raise FileNotFoundError(f"no file {movie}")
    stat = os.stat(movie)
    key = f"{os.path.abspath(movie)}|{stat.st_mtime_ns}|{stat.st_size}|{frame}|{width}|{height}|{colorspace}"
    folder = os.path.join(tempfile.gettempdir(), "primer-movie-frames")
    out = os.path.join(folder, hashlib.sha1(key.encode()).hexdigest() + ".exr")
    if os.path.isfile(out):
        return out
    os.makedirs(folder, exist_ok=True)
    partial = out[:-4] + f".{os.getpid()}.exr"
    arguments = [movie, str(frame), str(width), str(height), colorspace, partial]
    command = ([binary, "-b", "--factory-startup", "--python", SCRIPT, "--", *arguments] if binary
               else [sys.executable, SCRIPT, *arguments])
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT_SECONDS)
    except subprocess.TimeoutExpired as error:
        raise OSError(f"decoding the frame took over {TIMEOUT_SECONDS:g} s") from error
    if done.returncode != 0 or not os.path.isfile(partial):
        last = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
        raise OSError(f"Blender could not decode the frame ({last[0]})")
    os.replace(partial, out)                        # (whole files only: another render may be reading the folder)
    return out
