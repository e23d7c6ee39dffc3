"""The compiled library: every part's C file, built into one shared library (`make kernels`).

This module only finds, loads and checks the library. It knows no part of the renderer: each part
declares the C functions it calls (`function`) and defines the records it hands to C (`record`),
next to the Python code it mirrors (core/lights, core/camera, core/integrators, core/film, ...).

`make kernels` compiles it for the machine that builds Primer (tools/build_kernels.py compiles
core/native/primer.c, which includes each part's C file); the extension zip carries one library for
each platform Blender publishes (`build_kernels.py --all-platforms`, docs/platforms.md). Where it is
missing or does not load (another platform, no compiler), Primer says so in the log once and renders
on the readable Python path: the same image, more slowly. ctypes releases Python's GIL while a C function runs,
so the render's threads run on every core at once.
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

# The interface version: core/native/primer.c returns the same number, or the library is stale.
ABI = 34

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


def library() -> Optional[ctypes.CDLL]:
    """Return the loaded library, or None (the reason is logged once and kept in `unavailable_reason`)."""
    if "library" in _cache:
        return _cache["library"]
    path, lib, reason = library_path(), None, ""
    if not os.path.exists(path):
        reason = f"{os.path.basename(path)} is not built for this platform (make kernels)"
    else:
        try:
            lib = ctypes.CDLL(path)
            lib.primer_abi.restype, lib.primer_abi.argtypes = ctypes.c_int64, []
            if lib.primer_abi() != ABI:
                reason, lib = f"{os.path.basename(path)} was built from other C sources (make kernels)", None
        except (OSError, AttributeError) as error:
            reason, lib = f"{os.path.basename(path)} does not load ({error})", None
    if lib is None:
        log.info("Compiled kernels unavailable: %s; rendering on the numpy path", reason)
    _cache["library"], _cache["reason"] = lib, reason
    return lib


def available() -> bool:
    """Whether the library loaded."""
    return library() is not None


def unavailable_reason() -> str:
    """Why the library did not load ('' when it did)."""
    library()
    return _cache["reason"]


P, I64, F64 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_double


def function(name: str, restype, argtypes: list):
    """Return the library's C function `name` with its signature set (pointers as P, counts as I64).

    Raises RuntimeError when the library is not loaded: callers check `available()` first.
    """
    lib = library()
    if lib is None:
        raise RuntimeError(f"compiled kernels unavailable: {unavailable_reason()}")
    c_function = getattr(lib, name)
    c_function.restype, c_function.argtypes = restype, argtypes
    return c_function


def record(name: str, fields: list, size_function: Optional[str] = None) -> type:
    """Return a ctypes Structure of doubles; a field given as (name, k) is an array of k doubles.

    Only doubles, so that the layout is the same on every compiler. size_function: the name of
    the C function that returns sizeof the C struct, checked the first time a record is made.
    """
    spec = [(field, F64) if isinstance(field, str) else (field[0], F64 * field[1]) for field in fields]
    return type(name, (ctypes.Structure,), {"_fields_": spec, "_size_function": size_function})


def check_size(struct: type) -> None:
    """Raise RuntimeError when the C side's struct has another size than `struct` (a stale library)."""
    name = getattr(struct, "_size_function", None)
    if name is None or getattr(struct, "_size_checked", False):
        return
    size = function(name, I64, [])()
    if size != ctypes.sizeof(struct):
        raise RuntimeError(f"{struct.__name__} is {ctypes.sizeof(struct)} bytes here and {size} in C (make kernels)")
    struct._size_checked = True


def pointer(array: Optional[np.ndarray], dtype) -> Optional[int]:
    """Return the address of a C-contiguous array of `dtype` (None for None); refuse anything else."""
    if array is None:
        return None
    if array.dtype != dtype or not array.flags.c_contiguous:
        raise TypeError(f"C argument must be C-contiguous {np.dtype(dtype)}, got {array.dtype} "
                        f"{'contiguous' if array.flags.c_contiguous else 'strided'}")
    return array.ctypes.data


def contiguous(array: np.ndarray, dtype) -> np.ndarray:
    """Return `array` as a C-contiguous array of `dtype` (no copy when it already is one)."""
    return np.ascontiguousarray(array, dtype=dtype)
