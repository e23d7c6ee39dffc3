"""One frame of a movie as Blender decodes it, written to an OpenEXR file: run by Blender (`blender -b --python
movie_frame.py -- MOVIE FRAME WIDTH HEIGHT COLORSPACE OUT`) or by a Python with the bpy module (`python
movie_frame.py MOVIE ...`).

Blender's Python API gives the pixels of a movie's first frame only (Image.pixels), and OpenImageIO's wheel has no
FFmpeg; Blender's sequencer decodes any frame with the FFmpeg Blender (and so Cycles) reads movies with. The scene of
this fresh Blender, at the movie's size, shows the movie as a strip in the image's colour space at `FRAME` and
renders it: the EXR holds the frame in scene-linear values, bottom row first as Blender's images are. addon/movie.py
runs it and reads the file."""
import sys

import bpy


def write_frame(movie: str, frame: int, width: int, height: int, colorspace: str, out: str) -> None:
    """Render frame `frame` (1 = the movie's first) of `movie`, `width` x `height` pixels, read in `colorspace`,
    into the OpenEXR `out` (scene-linear float32)."""
    scene = bpy.context.scene
    render = scene.render
    render.resolution_x, render.resolution_y, render.resolution_percentage = width, height, 100
    render.use_sequencer, render.use_compositing, render.dither_intensity = True, False, 0.0
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    render.image_settings.exr_codec = "ZIP"
    editor = scene.sequence_editor_create()
    strips = editor.strips if hasattr(editor, "strips") else editor.sequences
    strip = strips.new_movie("movie", movie, channel=1, frame_start=1, fit_method="ORIGINAL")
    strip.colorspace_settings.name = colorspace
    scene.frame_start, scene.frame_end = 1, max(frame, 1)
    scene.frame_set(frame)
    render.filepath = out
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    arguments = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    path, number, columns, rows, space, target = arguments
    write_frame(path, int(number), int(columns), int(rows), space, target)
