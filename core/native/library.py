"""The compiled library: every part's C file, built into one shared library (`make kernels`).

This module only finds, loads and calls the library. It knows no part of the renderer: each part describes
the records it hands to C and the C functions it calls (core/native/schema.py) next to the Python code they
mirror (core/lights, core/camera, core/integrators, core/film, ...), and calls them with `call`.

`make kernels` compiles it for the machine that builds Primer (tools/build_kernels.py compiles
core/native/primer.c, which includes each part's C file); the extension zip carries one library for
each platform Blender publishes (`build_kernels.py --all-platforms`, docs/platforms.md). Where it is
missing or does not load (another platform, no compiler), Primer says so in the log once and renders
on the readable Python path: the same image, more slowly. Where it was built from other sources than the
Python describes, the first record that crosses says so (its layout hash differs: schema.Record.check).
ctypes releases Python's GIL while a C function runs, so the render's threads run on every core at once.
"""
from __future__ import annotations

import ctypes
import logging
import os
import platform
import sys
from typing import Optional

import numpy as np

log = logging.getLogger(__name__)

# Where a render's arithmetic runs: "compiled" (C, where it applies) or "numpy" (the reference).
KERNELS = ("compiled", "numpy")

FOLDER = os.path.dirname(os.path.abspath(__file__))


def library_name(system: Optional[str] = None, machine: Optional[str] = None) -> str:
    """Return the library's file name for a sys.platform and platform.machine(): _kernels-<platform>-<machine>.<ext>.

    Windows says win32 and AMD64, macOS darwin and arm64 or x86_64, Linux linux and x86_64 or aarch64
    (tools/build_kernels.py names the library it builds for each of them this way). Default: this machine.
    """
    system, machine = system or sys.platform, machine or platform.machine()
    extension = {"win32": ".dll", "darwin": ".dylib"}.get(system, ".so")
    return f"_kernels-{system}-{machine.lower()}{extension}"


def library_path() -> str:
    """Return where this platform's library lives: core/native/_kernels-<platform>-<machine>.<ext>."""
    return os.path.join(FOLDER, library_name())


_cache: dict = {}
# What the library must agree with: callables giving the records described so far (core/native/schema.py adds
# its own when it is imported, so that this module, below it, imports nothing of it).
DESCRIBED: list = []


def library() -> Optional[ctypes.CDLL]:
    """Return the loaded library, or None (the reason is logged once and kept in `unavailable_reason`).

    A library without `primer_layout` predates the described boundary (schema.py): it is refused."""
    if "library" in _cache:
        return _cache["library"]
    path, lib, reason = library_path(), None, ""
    if not os.path.exists(path):
        reason = f"{os.path.basename(path)} is not built for this platform (make kernels)"
    else:
        try:
            lib = ctypes.CDLL(path)
            lib.primer_layout.restype, lib.primer_layout.argtypes = ctypes.c_uint64, [ctypes.c_char_p]
            lib.primer_record_size.restype, lib.primer_record_size.argtypes = ctypes.c_int64, [ctypes.c_char_p]
        except (OSError, AttributeError) as error:
            reason, lib = f"{os.path.basename(path)} does not load or predates this boundary ({error}; make kernels)", None
    if lib is None:
        log.info("Compiled kernels unavailable: %s; rendering on the numpy path", reason)
    _cache["library"], _cache["loaded"], _cache["reason"], _cache["functions"] = lib, lib, reason, {}
    return lib


def available() -> bool:
    """Whether the library loaded and lays out every record described so far as Python does (core/native/schema.py;
    a library built from other C sources is set aside, with the reason logged once, and Primer renders on the
    numpy path)."""
    if library() is None:
        return False
    stale = [name for described in DESCRIBED for name in stale_records(described())]
    if stale:
        reason = (f"{library_name()} was built from other C sources than this Python ({', '.join(stale[:3])} "
                  "differ; make kernels)")
        log.info("Compiled kernels unavailable: %s; rendering on the numpy path", reason)
        _cache["library"], _cache["reason"] = None, reason
        return False
    return True


def unavailable_reason() -> str:
    """Why the library did not load ('' when it did)."""
    library()
    return _cache["reason"]


def _loaded() -> ctypes.CDLL:
    """The library; RuntimeError when it is not loaded (callers check `available()` first)."""
    lib = _cache.get("loaded") or library()
    if lib is None:
        raise RuntimeError(f"compiled kernels unavailable: {unavailable_reason()}")
    return lib


def layout_of(name: str) -> int:
    """The layout hash the library was built with for the record `name` (0: it knows no such record)."""
    return int(_loaded().primer_layout(name.encode()))


def size_of(name: str) -> int:
    """sizeof the record `name` in the library (-1: it knows no such record)."""
    return int(_loaded().primer_record_size(name.encode()))


def stale_records(records) -> list:
    """The names of the records (schema.Record classes) whose layout in the library is not the one Python describes:
    a library built from other C sources (empty: they all agree). Checked once per record."""
    out = []
    for record in records:
        try:
            record.check()
        except RuntimeError:
            out.append(record.__name__)
    return out


def call(name: str, args):
    """Call the library's C function `name` with its record of arguments (schema.function), checked first
    against the library's layout, and return the record (results the function stores are in its fields)."""
    args.check()
    lib = _loaded()
    function = _cache["functions"].get(name)
    if function is None:
        function = getattr(lib, name)
        function.restype, function.argtypes = None, [ctypes.c_void_p]
        _cache["functions"][name] = function
    function(ctypes.addressof(args))
    return args


def contiguous(array: np.ndarray, dtype) -> np.ndarray:
    """Return `array` as a C-contiguous array of `dtype` (no copy when it already is one)."""
    return np.ascontiguousarray(array, dtype=dtype)


def in_row_bands(rows: int, band) -> None:
    """Call band(start, end) for a band of rows per thread, covering rows 0 .. rows - 1 (the library lets Python's
    other threads run while it works, so a C function per band fills the cores)."""
    from concurrent.futures import ThreadPoolExecutor
    threads = max(1, min(os.cpu_count() or 1, rows))
    bounds = np.linspace(0, rows, threads + 1).astype(np.int64)
    with ThreadPoolExecutor(threads) as pool:
        list(pool.map(lambda k: band(int(bounds[k]), int(bounds[k + 1])), range(threads)))
