"""The compiled kernels stay quick to compile: no function of the library grows to megabytes of machine code.

core/native/primer.c is one translation unit whose INLINE functions are inlined at every call (core/native/primer.h).
A large one with two call sites is compiled twice into its callers, and GCC's optimisation passes take superlinear
time in a function's size: at stop 39 the path tracer's `trace_paths` and `direct_light`, each inlined at two call
sites of `integrate`, made `integrate` 1.6 MB of code at -O1, and the -O2 build of the library ran for over
12 minutes of CPU (the -O3 build of CI's `make test` was the longest step of its set-up); marked NOINLINE, the
largest function is 0.3 MB at -O3 and the build takes about 4 minutes of CPU. The ELF symbol table of this
machine's library gives each function's size.
"""
from __future__ import annotations

import os
import struct
import sys

import pytest

from core.native import library

LARGEST_FUNCTION = 700 * 1024      # bytes of machine code; the largest is about 0.3 MB at -O3, 0.24 MB at -O1


def function_sizes(path: str) -> dict:
    """Each function symbol of the ELF64 little-endian shared library `path`: name -> size in bytes (.symtab; GCC's
    clones keep their suffix, e.g. `integrate.constprop.0`)."""
    with open(path, "rb") as fh:
        data = fh.read()
    assert data[:4] == b"\x7fELF" and data[4] == 2 and data[5] == 1, "an ELF64 little-endian library"
    section_offset, = struct.unpack_from("<Q", data, 0x28)
    entry_size, count = struct.unpack_from("<HH", data, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, section_offset + i * entry_size) for i in range(count)]
    sizes = {}
    for _, kind, _, _, offset, size, link, _, _, symbol_size in sections:
        if kind != 2:                                       # SHT_SYMTAB
            continue
        strings = sections[link][4]
        for at in range(offset, offset + size, symbol_size):
            name, info, _, _, _, length = struct.unpack_from("<IBBHQQ", data, at)
            if info & 0xF == 2:                             # STT_FUNC
                end = data.index(b"\0", strings + name)
                sizes[data[strings + name:end].decode()] = length
    return sizes


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the ELF symbol table of a Linux build")
def test_no_kernel_function_is_so_large_that_the_compiler_slows_down():
    """The largest function of this machine's library is under LARGEST_FUNCTION bytes (a large INLINE function at a
    second call site shows up here first)."""
    path = library.library_path()
    if not os.path.isfile(path):
        pytest.skip("the kernels are not built (make kernels)")
    sizes = function_sizes(path)
    assert len(sizes) > 100 and "integrate" in {name.split(".")[0] for name in sizes}, \
        "the library's symbol table lists its functions"
    largest = max(sizes, key=sizes.get)
    assert sizes[largest] < LARGEST_FUNCTION, \
        f"{largest} is {sizes[largest] / 1024:.0f} kB of code: a large INLINE function called from several places?"
