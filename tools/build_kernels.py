"""Compile Primer's C code into the shared library core/native/library.py loads (`make kernels`).

Usage:
    python tools/build_kernels.py [--cc CC | --zig] [--force]
    python tools/build_kernels.py --all-platforms [--check [--except-host]] [--out DIR] [--force]

core/native/primer.c includes every part's C file (core/lights/*.c, core/materials/*.c, ...) into one
translation unit; the generated ones (*.gen.h, *.gen.c: the tables' kinds, flags and switches, the records) are
written again first from the Python they describe (tools/make_boundary.py). The library is named after the platform it runs on (core/native/library.py
`library_name`). The first form compiles it for this machine with the host C compiler, into
core/native/ (`make kernels`). The second cross-compiles it for every platform the extension ships
(TARGETS: Linux x64 and arm64, Windows x64, macOS arm64 and x64) with Zig's C compiler, from the
`ziglang` package (requirements-platforms.txt), into DIR (default dist/kernels/); tools/build_extension.py
puts those five in the zip. Each library is rebuilt only when a C file under core/ is newer than it
(or with --force), and each cross-compiled one is checked by its headers (tools/binaries.py): format,
processor, and the exported primer_layout. With --check they are built unoptimised (-O0) into dist/kernels-check/
instead: the test suite's builds (tests/test_platforms.py, tests/test_extension.py), which check each library's
format, exports and loading, never its speed, and take a fifth of the time of an -O3 build (on 2 cores, about
2.5 minutes for the five from a cold cache instead of 13). A check build never goes into a release zip.
`make test` compiles this machine's library with Zig (--zig: the compiler and target of the library that ships,
its -O3 in 120 s of CPU where GCC's takes 280 s, the same pixels, as fast) and lets it stand for this platform's
check build (--except-host), so that the same file is not compiled twice.

Zig caches every object it compiles, keyed by the source files' paths as well as their contents, so the
cross-builds compile a copy of core/'s C files in a folder named by their digest (under $XDG_CACHE_HOME or
~/.cache, primer-kernels/): a new clone of the same sources (CI's) then finds Zig's objects, and a changed C file
makes a new folder, so a copy is never stale.

Flags: no fused multiply-add (-ffp-contract=off), so that the kernels round exactly as the numpy code
they mirror does, step by step. -O3 turns the loops over blocks of samples into SIMD instructions
(core/native/primer.h compiles those for AVX2 as well, where the compiler can); two flags let it, and
neither changes a result: -fno-math-errno (sqrt is one instruction, with no errno to set) and
-fno-trapping-math (a lane may compute a value it then throws away, such as a division by zero). The
cross-compiled libraries take the same flags, stripped of debug information (-s); the Linux ones link
against glibc 2.17, so that they load on any Linux Blender runs on, and the macOS ones ask for macOS 11.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import hashlib
import importlib.util
import os
import shlex
import shutil
import subprocess
import sys
import threading
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

FLAGS = ["-std=c99", "-Wall", "-Wextra", "-fPIC", "-shared", "-ffp-contract=off",
         "-fno-math-errno", "-fno-trapping-math", "-fvisibility=hidden"]


# Blender's platform name -> (Zig's target, sys.platform and platform.machine() there, the processor
# tools/binaries.py reads from the library's header).
TARGETS = {
    "linux-x64": ("x86_64-linux-gnu.2.17", "linux", "x86_64", "x86_64"),
    "linux-arm64": ("aarch64-linux-gnu.2.17", "linux", "aarch64", "aarch64"),
    "windows-x64": ("x86_64-windows-gnu", "win32", "AMD64", "x86_64"),
    "macos-arm64": ("aarch64-macos.11.0", "darwin", "arm64", "aarch64"),
    "macos-x64": ("x86_64-macos.11.0", "darwin", "x86_64", "x86_64"),
}
FORMATS = {"linux": "ELF", "win32": "PE", "darwin": "Mach-O"}
CROSS_FOLDER = os.path.join(ROOT, "dist", "kernels")
CHECK_FOLDER = os.path.join(ROOT, "dist", "kernels-check")
# Optimisation of the libraries that ship (and of this machine's), and of the test suite's cross-builds. Zig's -O0
# would add what its debug mode has and the release builds have not: an undefined-behaviour sanitizer (five times the
# size and compile time) and a stack protector (on Linux arm64 a symbol of ld.so the shipped library never needs).
RELEASE = ["-O3"]
CHECK = ["-O0", "-fno-sanitize=all", "-fno-stack-protector"]


class ToolchainError(Exception):
    """The cross-compiler is missing or failed; the message says what to do."""


def sources() -> list:
    """Return every C source and header under core/ (the unity file includes them)."""
    found = []
    for folder, _, files in os.walk(os.path.join(ROOT, "core")):
        found += [os.path.join(folder, name) for name in files if name.endswith((".c", ".h"))]
    return sorted(found)


def up_to_date(target: str) -> bool:
    """Whether the library `target` exists and is newer than every C file under core/."""
    return os.path.exists(target) and os.path.getmtime(target) >= max(os.path.getmtime(p) for p in sources())


def host_platform() -> str | None:
    """Return the TARGETS entry of this machine (sys.platform and platform.machine()), or None."""
    from core.native import library
    here = library.library_name()
    return next((name for name in TARGETS if cross_name(name) == here), None)


def compiler_stamp(target: str) -> str:
    """Return the file beside the host library that names the compiler command it was built with."""
    return target + ".cc"


def build(cc: str, force: bool = False, zig: bool = False) -> str:
    """Compile core/native/primer.c if any C file changed (with `cc`, or with `zig` Zig's C compiler for this
    machine's platform of TARGETS: the compiler and target of the library that ships); return the library's path."""
    from core.native import library
    source = os.path.join(ROOT, "core", "native", "primer.c")
    target = library.library_path()
    compiler = zig_compiler(host_platform()) if zig and host_platform() else shlex.split(cc)
    if not force and up_to_date(target) and stamped(target) == " ".join(compiler):
        return target
    command = compiler + RELEASE + FLAGS + [source, "-o", target + ".tmp", "-lm"]
    print(" ".join(command), flush=True)
    subprocess.run(command, check=True)
    os.replace(target + ".tmp", target)
    with open(compiler_stamp(target), "w", encoding="utf-8") as fh:
        fh.write(" ".join(compiler))
    return target


def stamped(target: str) -> str:
    """Return the compiler command the host library `target` was built with ("" if unknown)."""
    try:
        with open(compiler_stamp(target), encoding="utf-8") as fh:
            return fh.read().strip()
    except OSError:
        return ""


def source_copy() -> str:
    """Copy every C file under core/ into a folder named by their paths' and contents' digest (once); return the copy
    of core/native/primer.c there. Zig then keys its objects by the same paths in every clone of the same sources."""
    sha = hashlib.sha256()
    files = sources()
    for path in files:
        with open(path, "rb") as fh:
            sha.update(os.path.relpath(path, ROOT).encode() + b"\0" + fh.read() + b"\0")
    cache_home = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = os.path.join(cache_home, "primer-kernels", sha.hexdigest()[:20])
    if not os.path.isdir(folder):
        os.makedirs(os.path.dirname(folder), exist_ok=True)
        scratch = tempfile.mkdtemp(prefix="sources-", dir=os.path.dirname(folder))
        for path in files:
            copy = os.path.join(scratch, os.path.relpath(path, ROOT))
            os.makedirs(os.path.dirname(copy), exist_ok=True)
            shutil.copyfile(path, copy)
        try:
            os.rename(scratch, folder)          # whole or not at all; another build may have made it meanwhile
        except OSError:
            shutil.rmtree(scratch, ignore_errors=True)
    return os.path.join(folder, "core", "native", "primer.c")


def zig_command() -> list:
    """Return the command that runs Zig's C compiler: $ZIG (a command, e.g. `python -m ziglang`) + cc, else this Python's ziglang.

    ToolchainError when neither is there.
    """
    if os.environ.get("ZIG"):
        return shlex.split(os.environ["ZIG"]) + ["cc"]
    if importlib.util.find_spec("ziglang") is None:
        raise ToolchainError(f"the ziglang package is not installed in {sys.executable}: cross-compiling the kernels "
                             "for every platform needs Zig's C compiler (`make extension` installs it; or "
                             "`pip install -r requirements-platforms.txt`, or set ZIG to a zig command)")
    return [sys.executable, "-m", "ziglang", "cc"]


def zig_compiler(platform_name: str) -> list:
    """Return the command of Zig's C compiler for one platform of TARGETS (its target; no flags)."""
    return zig_command() + ["-target", TARGETS[platform_name][0]]


def cross_name(platform_name: str) -> str:
    """Return the file name of one platform's library, as core/native/library.py names it on that platform."""
    from core.native import library
    _, system, machine, _ = TARGETS[platform_name]
    return library.library_name(system, machine)


def cross_build_one(platform_name: str, folder: str, force: bool = False, optimise: tuple = tuple(RELEASE)) -> str:
    """Cross-compile core/native/primer.c for one platform of TARGETS into `folder` at `optimise` (RELEASE or CHECK),
    check it; return its path."""
    from tools import binaries
    zig_target, system, _, processor = TARGETS[platform_name]
    target = os.path.join(folder, cross_name(platform_name))
    host = reusable_host_library(platform_name, optimise)
    if host:                                       # this machine's, built by Zig for the same target
        part = f"{target}.{os.getpid()}.{threading.get_ident()}.part"    # test processes may copy it at once
        shutil.copyfile(host, part)
        os.replace(part, target)
    elif force or not up_to_date(target):
        source = source_copy()
        with tempfile.TemporaryDirectory(prefix=f"kernels-{platform_name}-") as scratch:
            # Built in a scratch folder: the Windows link also writes an import library and a .pdb beside the DLL.
            output = os.path.join(scratch, os.path.basename(target))
            command = zig_compiler(platform_name) + [*optimise] + FLAGS + ["-s", source, "-o", output]
            command += ["-lm"] if system == "linux" else []
            print(" ".join(command), flush=True)
            completed = subprocess.run(command, capture_output=True, text=True)
            if completed.returncode != 0:
                raise ToolchainError(f"zig cc for {zig_target} failed:\n{completed.stdout}{completed.stderr}")
            if completed.stderr.strip():
                print(completed.stderr, file=sys.stderr, flush=True)
            shutil.move(output, target)
    found = binaries.read(target)
    expected = (FORMATS[system], processor, True)
    if (found.format, found.machine, found.shared) != expected or "primer_layout" not in found.exports:
        raise ToolchainError(f"{target} is a {found.format} {found.machine} file (shared: {found.shared}), "
                             f"not a {expected[0]} {expected[1]} shared library exporting primer_layout")
    return target


def reusable_host_library(platform_name: str, optimise: tuple) -> str | None:
    """Return this machine's library when a check build (CHECK) of `platform_name` may be it: the host library is
    up to date and was built by Zig for that platform's target (`make test` builds it so: tools/build_kernels.py
    --zig); its format, exports and loading are what a check build is for, and it saves compiling the same file
    twice. None otherwise."""
    from core.native import library
    target = library.library_path()
    if tuple(optimise) != tuple(CHECK) or platform_name != host_platform() or not up_to_date(target):
        return None
    return target if stamped(target) == " ".join(zig_compiler(platform_name)) else None


def cross_build(folder: str = CROSS_FOLDER, force: bool = False, platforms=tuple(TARGETS), check: bool = False) -> dict:
    """Cross-compile the kernels for `platforms` (default: all of TARGETS) into `folder`, optimised for release or,
    with `check`, unoptimised for the tests; return {platform: path}."""
    zig_command()                                   # a missing toolchain fails before any thread starts
    os.makedirs(folder, exist_ok=True)
    with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        optimise = tuple(CHECK if check else RELEASE)
        futures = {name: pool.submit(cross_build_one, name, folder, force, optimise) for name in platforms}
        return {name: future.result() for name, future in futures.items()}


def main() -> int:
    """Parse the command line, build the host library or every platform's, and return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cc", default=os.environ.get("CC", "cc"), help="C compiler (default: $CC or cc)")
    parser.add_argument("--force", action="store_true", help="rebuild even if the library is up to date")
    parser.add_argument("--zig", action="store_true",
                        help="compile this machine's library with Zig (ziglang package) for its platform's target, "
                             "as the shipped one is, instead of --cc")
    parser.add_argument("--all-platforms", action="store_true",
                        help="cross-compile for every platform the extension ships, with Zig (ziglang package)")
    parser.add_argument("--check", action="store_true",
                        help="with --all-platforms: unoptimised (-O0) builds for the tests, into dist/kernels-check")
    parser.add_argument("--except-host", action="store_true",
                        help="with --check: leave out this machine's platform, whose check is its own library built "
                             "with --zig (`make test` builds that one beside these)")
    parser.add_argument("--out", default=None,
                        help="folder of --all-platforms' libraries (default: dist/kernels, or dist/kernels-check)")
    args = parser.parse_args()
    # The C side of the Python tables and records first (tools/make_boundary.py): the library is built from them.
    from tools import make_boundary
    for path in make_boundary.write():
        print(f"wrote {path} (tools/make_boundary.py)", flush=True)
    if not args.all_platforms:
        try:
            path = build(args.cc, args.force, args.zig)
        except ToolchainError as error:
            print(f"build_kernels: {error}", file=sys.stderr)
            return 1
        print(f"kernels: {os.path.relpath(path, ROOT)}")
        return 0
    started = time.perf_counter()
    try:
        folder = args.out or (CHECK_FOLDER if args.check else CROSS_FOLDER)
        platforms = [name for name in TARGETS if not (args.except_host and args.check and name == host_platform())]
        paths = cross_build(os.path.abspath(folder), args.force, platforms, check=args.check)
    except ToolchainError as error:
        print(f"build_kernels: {error}", file=sys.stderr)
        return 1
    for name, path in paths.items():
        print(f"kernels {name:12s} {os.path.relpath(path, ROOT)} ({os.path.getsize(path) / 1e3:.0f} kB)")
    print(f"kernels for {len(paths)} platforms in {time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
