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
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import sys
import threading

# glibc's mallopt parameters (malloc.h), and their starting values.
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
GLIBC_DEFAULT = 128 << 10
MMAP_THRESHOLD = 64 << 20
TRIM_THRESHOLD = 256 << 20

_libc = None
_lock = threading.Lock()
_renders = 0          # renders inside temporaries_from_the_heap right now (the viewport's and F12's may overlap)


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
def temporaries_from_the_heap():
    """During the block, serve large temporary arrays from the heap; when the last such block ends,
    restore glibc's starting thresholds and return free memory to the system."""
    global _renders
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
                libc.mallopt(M_MMAP_THRESHOLD, GLIBC_DEFAULT)
                libc.mallopt(M_TRIM_THRESHOLD, GLIBC_DEFAULT)
                libc.malloc_trim(0)
