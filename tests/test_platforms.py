"""The compiled kernels for every platform the extension ships, cross-compiled with Zig (tools/build_kernels.py).

Each library is built into a temporary folder (Zig's cache makes every build after the first quick) and
checked by its headers with tools/binaries.py: its format and processor, the functions it exports, the
libraries it needs. The Linux x86-64 one is loaded here; the Linux arm64 one too where qemu-aarch64 and
an arm64 glibc are installed. `make test` installs ziglang (requirements-platforms.txt); without it the
tests that need a build skip.
"""
from __future__ import annotations

import ctypes
import importlib.util
import os
import platform
import re
import shutil
import subprocess
import sys

import pytest

from core.native import library
from tools import binaries, build_kernels

ROOT = build_kernels.ROOT
HAS_ZIG = bool(os.environ.get("ZIG")) or importlib.util.find_spec("ziglang") is not None
needs_zig = pytest.mark.skipif(not HAS_ZIG, reason="ziglang is not installed (pip install -r requirements-platforms.txt)")


def declared_functions() -> set:
    """Return every C function Python calls: those core describes (core/native/schema.py FUNCTIONS), and the two the
    library answers its layout checks with."""
    from tools import make_boundary
    return set(make_boundary.described().FUNCTIONS) | {"primer_layout", "primer_record_size"}


def c_exports() -> set:
    """Return every function the C sources under core/ mark EXPORT."""
    names = set()
    for path in build_kernels.sources():
        with open(path, encoding="utf-8") as fh:
            names |= set(re.findall(r"^EXPORT\b[^(]*?\b(primer_[a-z0-9_]+)\s*\(", fh.read(), re.MULTILINE))
    return names


@pytest.fixture(scope="module")
def libraries() -> dict:
    """The kernels of every platform the extension zip ships, as the test suite builds them: unoptimised, into
    dist/kernels-check/ (where older than a C file; `make test` builds them first): {platform: path}."""
    if not HAS_ZIG:
        pytest.skip("ziglang is not installed (pip install -r requirements-platforms.txt)")
    return build_kernels.cross_build(build_kernels.CHECK_FOLDER, check=True)


def test_the_python_side_declares_the_functions_the_c_side_exports():
    """The scans below find what they look for: core's Python names the C functions, all of them EXPORTed in C."""
    declared, exported = declared_functions(), c_exports()
    assert {"primer_layout", "primer_record_size", "primer_render_chunk", "primer_intersect"} <= declared
    assert len(declared) >= 19
    assert declared <= exported, declared - exported


@needs_zig
@pytest.mark.parametrize("name", list(build_kernels.TARGETS))
def test_each_library_has_its_platforms_format_and_processor(libraries, name):
    """Linux: ELF shared objects, Windows: a PE DLL, macOS: Mach-O dylibs; x86-64 or arm64 as the platform says."""
    found = binaries.read(libraries[name])
    expected_format = {"linux": "ELF", "windows": "PE", "macos": "Mach-O"}[name.split("-")[0]]
    expected_machine = {"x64": "x86_64", "arm64": "aarch64"}[name.split("-")[1]]
    assert (found.format, found.machine, found.shared) == (expected_format, expected_machine, True)


@needs_zig
@pytest.mark.parametrize("name", list(build_kernels.TARGETS))
def test_each_library_exports_exactly_the_c_exports_by_their_plain_names(libraries, name):
    """Every function core's Python declares is exported, undecorated; the primer_ exports are the EXPORT ones, no more."""
    exports = binaries.read(libraries[name]).exports
    assert declared_functions() <= exports, declared_functions() - exports
    assert {e for e in exports if e.startswith("primer_")} == c_exports()
    if not name.startswith("macos"):               # the Mach-O linker adds __dso_handle and _mh_dylib_header
        assert exports == c_exports(), exports - c_exports()


@needs_zig
@pytest.mark.parametrize("name", list(build_kernels.TARGETS))
def test_each_library_needs_only_what_every_such_system_has(libraries, name):
    """Linux: libc and libm of glibc 2.17 or older; Windows: the system's DLLs (no MinGW runtime); macOS 11: libSystem."""
    found = binaries.read(libraries[name])
    if name.startswith("linux"):
        assert set(found.needed) <= {"libc.so.6", "libm.so.6"} and "libc.so.6" in found.needed, found.needed
        assert tuple(map(int, found.minimum_os.split("."))) <= (2, 17), found.minimum_os
    elif name.startswith("windows"):
        assert found.needed and all(dll.lower() == "kernel32.dll" or dll.lower().startswith("api-ms-win-crt-")
                                    for dll in found.needed), found.needed
    else:
        assert found.needed == ("/usr/lib/libSystem.B.dylib",)
        assert found.minimum_os == "11.0"


@needs_zig
@pytest.mark.parametrize("name", list(build_kernels.TARGETS))
def test_each_library_is_named_as_library_path_names_it_on_its_platform(libraries, name, monkeypatch):
    """With sys.platform and platform.machine() as that platform gives them, library_path() finds the file built for it."""
    _, system, machine, _ = build_kernels.TARGETS[name]
    monkeypatch.setattr(sys, "platform", system)
    monkeypatch.setattr(platform, "machine", lambda: machine)
    assert os.path.basename(library.library_path()) == os.path.basename(libraries[name])
    assert os.path.basename(library.library_path()).startswith(f"_kernels-{system}-{machine.lower()}.")


def reference_exports(path: str, kind: str):
    """Return the exports another tool lists for `path` (binutils or LLVM), or None where that tool is missing."""
    if kind == "ELF" and shutil.which("nm"):
        out = subprocess.run(["nm", "-D", "--defined-only", path], capture_output=True, text=True, check=True).stdout
        return {line.split()[-1] for line in out.splitlines() if line.split()[-2:-1] in (["T"], ["i"])}
    if kind == "PE" and shutil.which("objdump"):
        out = subprocess.run(["objdump", "-p", path], capture_output=True, text=True, check=True).stdout
        table = out.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0]
        return set(re.findall(r"\]\s+(\S+)", table))
    if kind == "Mach-O" and shutil.which("llvm-nm"):
        out = subprocess.run(["llvm-nm", "--extern-only", "--defined-only", path],
                             capture_output=True, text=True, check=True).stdout
        return {line.split()[-1][1:] for line in out.splitlines() if line.split()[-2:-1] == ["T"]}
    return None


@needs_zig
@pytest.mark.parametrize("name", list(build_kernels.TARGETS))
def test_header_reader_agrees_with_nm_and_objdump(libraries, name):
    """tools/binaries.py lists the same exported functions as GNU nm (ELF), objdump (PE) and llvm-nm (Mach-O)."""
    found = binaries.read(libraries[name])
    reference = reference_exports(libraries[name], found.format)
    if reference is None:
        pytest.skip(f"no tool here to read {found.format} exports with")
    assert {e for e in found.exports if e.startswith("primer_")} == reference


def test_header_reader_refuses_a_file_that_is_no_library(tmp_path):
    """A text file is none of the three formats: BinaryError, not a guess."""
    path = tmp_path / "primer.c"
    shutil.copy(os.path.join(ROOT, "core", "native", "primer.c"), path)
    with pytest.raises(binaries.BinaryError):
        binaries.read(str(path))


@needs_zig
@pytest.mark.skipif(not (sys.platform == "linux" and platform.machine() == "x86_64"), reason="needs Linux x86-64")
def test_linux_x86_64_library_loads_and_lays_out_every_record_as_python_does(libraries):
    """The cross-built Linux x86-64 library loads here, and knows every record Python describes with Python's layout
    hash and size."""
    from tools import make_boundary
    schema = make_boundary.described()
    lib = ctypes.CDLL(libraries["linux-x64"])
    lib.primer_layout.restype, lib.primer_layout.argtypes = ctypes.c_uint64, [ctypes.c_char_p]
    lib.primer_record_size.restype, lib.primer_record_size.argtypes = ctypes.c_int64, [ctypes.c_char_p]
    assert len(schema.RECORDS) >= 20
    for name, struct in schema.RECORDS.items():
        assert lib.primer_layout(name.encode()) == struct.layout_hash(), name
        assert lib.primer_record_size(name.encode()) == ctypes.sizeof(struct), name
    assert lib.primer_layout(b"NoSuchRecord") == 0
    for name in declared_functions():
        assert getattr(lib, name) is not None


LOADER = r"""
#include <dlfcn.h>
#include <stdio.h>
#include <stdint.h>
int main(int argc, char **argv) {
    void *library = dlopen(argv[1], RTLD_NOW);
    if (!library) { fprintf(stderr, "%s\n", dlerror()); return 2; }
    uint64_t (*layout)(const char *) = (uint64_t (*)(const char *))dlsym(library, "primer_layout");
    if (!layout) { fprintf(stderr, "no primer_layout\n"); return 3; }
    printf("%llu\n", (unsigned long long)layout("LightRecord"));
    return 0;
}
"""


@needs_zig
@pytest.mark.skipif(not (shutil.which("qemu-aarch64") and os.path.isdir("/usr/aarch64-linux-gnu")),
                    reason="needs qemu-aarch64 and an arm64 glibc in /usr/aarch64-linux-gnu (qemu-user, libc6-arm64-cross)")
def test_linux_arm64_library_loads_under_qemu_and_returns_the_layout(libraries, tmp_path):
    """An arm64 program dlopens the Linux arm64 library under qemu and reads LightRecord's layout hash, Python's."""
    source, loader = tmp_path / "loader.c", tmp_path / "loader"
    source.write_text(LOADER)
    subprocess.run(build_kernels.zig_command() + ["-target", "aarch64-linux-gnu.2.17", str(source), "-o", str(loader),
                                                  "-ldl"], check=True, capture_output=True)
    completed = subprocess.run(["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu", str(loader), libraries["linux-arm64"]],
                               capture_output=True, text=True, timeout=120)
    assert completed.returncode == 0, completed.stderr
    from core.lights.base import LightRecord
    assert int(completed.stdout) == LightRecord.layout_hash()


def test_missing_zig_is_a_clear_error(monkeypatch):
    """Without ZIG and without the ziglang package, the cross-build says what to install instead of failing later."""
    monkeypatch.delenv("ZIG", raising=False)
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "ziglang" else real(name, *a))
    with pytest.raises(build_kernels.ToolchainError, match="ziglang.*requirements-platforms.txt"):
        build_kernels.cross_build("/nonexistent")
