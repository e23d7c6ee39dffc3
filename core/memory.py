"""Memory for the render's temporary arrays.

numpy makes a new array for every intermediate result, and a render makes thousands
of them, mostly between 0.1 and 10 MB, each alive for a few operations. On Linux,
glibc's malloc gives every block above M_MMAP_THRESHOLD (128 KiB at first, rising
as such blocks are freed) a fresh mapping from the kernel, which zeroes it page by
page on first touch and takes it back on free; and it trims the heap's free top
beyond M_TRIM_THRESHOLD. So a chain of numpy operations pays for page faults again
and again. Raising both thresholds serves those blocks from the heap instead:
measured on this machine, a chain of four operations on 65,536 float64 went from
1.35 ms to 0.31 ms, and sample-scene renders took 10-15% less time. Blocks above
64 MiB (whole images) still get their own mappings. When the last render running
ends, both thresholds go back to glibc's starting values (128 KiB; glibc no longer
raises them by itself after that) and malloc_trim hands the free memory back, so
the host process (Blender) keeps nothing. Elsewhere (macOS, Windows, other C
libraries) this does nothing.

A render may instead leave the heap warm (keep=True): its free memory stays with the
process, so that the next render finds its buffers' pages already mapped. Every page
the kernel has to map anew costs about 2.5 us on the machine the benchmark runs on,
and a render of 320 x 240 pixels at 16 samples maps 6,000-7,500 of them: 7-8% of its
time. The Blender add-on keeps the heap warm between renders in a row (F12 and the
viewport's passes) and calls `release_if_idle()` from a persistent bpy timer that looks
every two seconds, so Blender still ends up keeping nothing once it has been idle a few
seconds.
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import sys
import threading
import time

# glibc's mallopt parameters (malloc.h), and their starting values.
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
GLIBC_DEFAULT = 128 << 10
MMAP_THRESHOLD = 64 << 20
TRIM_THRESHOLD = 256 << 20

_libc = None
_lock = threading.Lock()
_renders = 0          # renders inside temporaries_from_the_heap right now (the viewport's and F12's may overlap)
_warm = False         # the thresholds are raised with no render running (a render kept the heap warm)
_idle_since = None    # time.monotonic() when the last render that kept the heap warm ended


def _glibc():
    """Return glibc through ctypes, or None where the C library is another one."""
    global _libc
    if _libc is None:
        _libc = False
        if sys.platform.startswith("linux"):
            try:
                libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
                if hasattr(libc, "mallopt") and hasattr(libc, "malloc_trim"):
                    _libc = libc
            except OSError:
                pass
    return _libc or None


@contextlib.contextmanager
def temporaries_from_the_heap(keep: bool = False):
    """During the block, serve large temporary arrays from the heap; when the last such block ends,
    restore glibc's starting thresholds and return free memory to the system, unless `keep`: then
    the heap stays warm for the next render until `release()`."""
    global _renders, _warm, _idle_since
    libc = _glibc()
    if libc is None:
        yield
        return
    with _lock:
        _renders += 1
        libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
        libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    try:
        yield
    finally:
        with _lock:
            _renders -= 1
            if _renders == 0:
                if keep:
                    _warm, _idle_since = True, time.monotonic()
                else:
                    _restore(libc)


def is_warm() -> bool:
    """Whether a render left the heap warm and nobody has released it yet."""
    return _warm


def release() -> bool:
    """Return the warm heap's free memory to the system and restore glibc's thresholds, unless a
    render is running; return whether there was anything to release."""
    libc = _glibc()
    with _lock:
        if libc is None or not _warm or _renders:
            return False
        _restore(libc)
        return True


def release_if_idle(seconds: float) -> bool:
    """release() once no render has run for `seconds`; return whether the heap was released."""
    with _lock:
        idle = _idle_since is not None and time.monotonic() - _idle_since >= seconds
    return release() if idle else False


def hand_back_free() -> bool:
    """Return the heap's free pages to the system now (malloc_trim), keeping glibc's thresholds as they are; return
    whether it could (glibc only).

    For the end of a render's set-up (render.prepare, once it has built the geometry): placing a million triangles
    frees some hundreds of MB of temporaries (float64 points and normals, the batches' parts) that the heap would
    otherwise keep through the whole render, under the world's importance map and the film, which come after; the
    render's own buffers then map about 10 MB of fresh pages (a few ms)."""
    libc = _glibc()
    if libc is None:
        return False
    libc.malloc_trim(0)
    return True


def _restore(libc) -> None:
    """Put glibc's thresholds back to their starting values and trim the heap (the lock is held)."""
    global _warm, _idle_since
    libc.mallopt(M_MMAP_THRESHOLD, GLIBC_DEFAULT)
    libc.mallopt(M_TRIM_THRESHOLD, GLIBC_DEFAULT)
    libc.malloc_trim(0)
    _warm, _idle_since = False, None
