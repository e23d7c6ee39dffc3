"""Image files decoded once for renders that follow one another (addon/materials.py _decoded), with real Blender (the
bpy module, no mocks): a file on disk and a packed file give the same pixels from the second export on without being
decoded again, and a file that changed between exports is decoded anew."""
from __future__ import annotations

import importlib.util
import os

import pytest

from blender_env import ROOT, run_bpy

pytestmark = pytest.mark.blender

if importlib.util.find_spec("bpy") is None:
    if os.environ.get("PRIMER_ALLOW_NO_BPY"):
        pytest.skip("bpy (Blender as a Python module) is not installed", allow_module_level=True)
    raise ImportError("tests/test_image_decoding.py needs bpy (Blender as a Python module): pip install bpy")

SCRIPT = """
import sys, os, time
import bpy
import numpy as np
from blender_env import report
sys.path.insert(0, {tools!r})
from render import load_primer
primer = load_primer()
materials = sys.modules[primer.__name__ + ".addon.materials"]
bpy.ops.wm.read_factory_settings(use_empty=True)


def write_png(path, rgb):
    image = bpy.data.images.new("tmp", 2, 1)
    image.pixels = [c for pixel in rgb for c in pixel + [1.0]]
    image.filepath_raw = path
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)


on_disk = os.path.abspath("a.png")
write_png(on_disk, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
file_image = bpy.data.images.load(on_disk)
packed = bpy.data.images.load(on_disk, check_existing=False)
packed.pack()
packed.filepath = "//nowhere/b.png"

decoded = []
real = materials._oiio_read
materials._oiio_read = lambda oiio, path, *rule: decoded.append(path) or real(oiio, path, *rule)
read = []
for export in range(3):
    if export == 2:                                   # the file changes on disk: new contents, a later time
        time.sleep(0.05)
        write_png(on_disk, [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]])
    materials.begin_export()
    read.append([materials._read_pixels(image) for image in (file_image, packed)])
report(decodes=len(decoded),
       same_file=bool(read[1][0] is read[0][0]), same_packed=bool(read[1][1] is read[0][1] and read[2][1] is read[0][1]),
       writeable=bool(read[0][0].flags.writeable),
       first=read[0][0][..., :3].tolist(), changed=read[2][0][..., :3].tolist(), packed=read[2][1][..., :3].tolist())
"""


def test_an_image_file_is_decoded_once_until_it_changes(tmp_path):
    result = run_bpy(SCRIPT.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    assert result["same_file"] and result["same_packed"]          # the second export decoded nothing
    assert result["decodes"] == 3                                 # each once, and the changed file again
    assert not result["writeable"]                                # shared between renders: read-only
    assert result["first"] == [[[255, 0, 0], [0, 255, 0]]]
    assert result["changed"] == [[[0, 0, 255], [255, 255, 255]]]
    assert result["packed"] == [[[255, 0, 0], [0, 255, 0]]]      # the packed bytes did not change


BYTES_SCRIPT = """
import sys, os
import bpy
import numpy as np
from blender_env import report
sys.path.insert(0, {tools!r})
from render import load_primer
primer = load_primer()
materials = sys.modules[primer.__name__ + ".addon.materials"]
bpy.ops.wm.read_factory_settings(use_empty=True)
width, height = 640, 200                         # 512 000 values: more than one step of bytes_of_unit_floats
rng = np.random.default_rng(3)
k = rng.integers(0, 256, (height, width, 4)).astype(np.uint8)
k[..., 3] = 255
image = bpy.data.images.new("tmp", width, height)
image.pixels.foreach_set((k.astype(np.float32) / np.float32(255.0)).ravel())
path = os.path.abspath("bytes.png")
image.filepath_raw = path
image.file_format = "PNG"
image.save()
bpy.data.images.remove(image)
packed = bpy.data.images.load(path, check_existing=False)
packed.pack()
packed.alpha_mode = "NONE"                       # (a packed byte image not Straight: Blender's byte buffer)
packed.filepath = "//nowhere/bytes.png"
materials.begin_export()
read = materials._read_pixels(packed)
x = np.concatenate([rng.uniform(-0.5, 1.5, 300001), [np.inf, -np.inf, 0.5 / 255, 2.5 / 255, 254.5 / 255]])
x = x.astype(np.float32)
closed = np.rint(np.clip(x, 0.0, 1.0) * np.float32(255.0)).astype(np.uint8)
report(dtype=str(read.dtype), same_bytes=bool(np.array_equal(read, k)),
       same_steps=bool(np.array_equal(materials.bytes_of_unit_floats(x.copy()), closed)))
"""


def test_a_packed_byte_image_reads_back_its_own_bytes(tmp_path):
    """Blender's byte buffer of a packed 8-bit PNG (Image.pixels gives k / 255) comes back as the file's bytes k,
    over more than one step of bytes_of_unit_floats, and that helper is rint(255 clip(x, 0, 1)) exactly, out of
    range values included."""
    result = run_bpy(BYTES_SCRIPT.format(tools=os.path.join(ROOT, "tools")), str(tmp_path))
    assert result["dtype"] == "uint8"
    assert result["same_bytes"]
    assert result["same_steps"]
