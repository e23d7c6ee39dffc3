"""Read what a shared library is from its headers: format, processor, exported functions, libraries it needs.

Usage:
    python tools/binaries.py LIBRARY...

A small reader of the three formats Primer's kernels are built in (tools/build_kernels.py), so that a
library cross-compiled for another platform can be checked on this one without running it:

- ELF (Linux .so): the processor is the header's e_machine; the exports are the dynamic symbol table's
  defined, global, default-visibility functions (what dlsym finds); the needed libraries are the
  dynamic section's DT_NEEDED entries, and the glibc versions the ones its version needs
  (.gnu.version_r) name.
- PE (Windows .dll): the processor is the COFF header's Machine; the exports are the export
  directory's names (what GetProcAddress finds); the needed libraries are the import directory's DLLs.
- Mach-O (macOS .dylib): the processor is the header's cputype; the exports are the dyld export trie
  (what dlsym finds), without the C compiler's leading underscore; the needed libraries are the
  LC_LOAD_DYLIB commands, and the oldest macOS the LC_BUILD_VERSION (or LC_VERSION_MIN_MACOSX) command.

Only 64-bit little-endian files are read; anything else raises BinaryError.
"""
from __future__ import annotations

import dataclasses
import struct
import sys


class BinaryError(Exception):
    """The file is not a 64-bit little-endian ELF, PE or Mach-O shared library this reader understands."""


@dataclasses.dataclass(frozen=True)
class Binary:
    """What the headers of one shared library say."""
    format: str                 # "ELF", "PE" or "Mach-O"
    machine: str                # "x86_64" or "aarch64" (or the header's raw number as text)
    shared: bool                # a shared library (ELF ET_DYN, PE DLL, Mach-O MH_DYLIB)
    exports: frozenset          # exported function names, as C spells them
    needed: tuple               # libraries it loads: sonames, DLL names or dylib paths
    minimum_os: str = ""        # glibc (ELF: the newest GLIBC_x.y it needs) or macOS (Mach-O) version


ELF_MACHINES = {62: "x86_64", 183: "aarch64"}
PE_MACHINES = {0x8664: "x86_64", 0xAA64: "aarch64"}
MACHO_CPUS = {0x01000007: "x86_64", 0x0100000C: "aarch64"}


def read(path: str) -> Binary:
    """Return what the headers of the shared library at `path` say (BinaryError if it is none of the three)."""
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:4] == b"\x7fELF":
        return _elf(data)
    if data[:2] == b"MZ":
        return _pe(data)
    if data[:4] == b"\xcf\xfa\xed\xfe":
        return _macho(data)
    raise BinaryError(f"{path}: not a 64-bit little-endian ELF, PE or Mach-O file (starts {data[:4]!r})")


def _c_string(data: bytes, offset: int) -> str:
    """Return the NUL-terminated string at `offset`."""
    end = data.index(b"\0", offset)
    return data[offset:end].decode("utf-8", "replace")


# ------------------------------------------------------------------------------------------------
# ELF
# ------------------------------------------------------------------------------------------------

def _elf(data: bytes) -> Binary:
    """Read an ELF64 little-endian shared object."""
    if data[4] != 2 or data[5] != 1:
        raise BinaryError("ELF: only 64-bit little-endian files are read")
    e_type, e_machine = struct.unpack_from("<HH", data, 16)
    e_shoff, = struct.unpack_from("<Q", data, 40)
    e_shentsize, e_shnum = struct.unpack_from("<HH", data, 58)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, e_shoff + i * e_shentsize) for i in range(e_shnum)]
    # (name, type, flags, addr, offset, size, link, info, addralign, entsize)
    exports, needed, versions = set(), [], []
    for _, kind, _, _, offset, size, link, info, _, entsize in sections:
        strings = sections[link][4] if link < len(sections) else 0
        if kind == 11:                                  # SHT_DYNSYM
            for at in range(offset + entsize, offset + size, entsize):   # entry 0 is the null symbol
                name, info_byte, other, shndx = struct.unpack_from("<IBBH", data, at)
                bind, sym_type = info_byte >> 4, info_byte & 0xF
                if shndx != 0 and bind in (1, 2) and (other & 3) == 0 and sym_type in (2, 10):  # FUNC, GNU_IFUNC
                    exports.add(_c_string(data, strings + name))
        elif kind == 6:                                 # SHT_DYNAMIC
            for at in range(offset, offset + size, entsize):
                tag, value = struct.unpack_from("<qQ", data, at)
                if tag == 0:
                    break
                if tag == 1:                            # DT_NEEDED
                    needed.append(_c_string(data, strings + value))
        elif kind == 0x6FFFFFFE:                        # SHT_GNU_verneed
            at = offset
            for _ in range(info):
                _, count, _, aux, following = struct.unpack_from("<HHIII", data, at)
                entry = at + aux
                for _ in range(count):
                    _, _, _, name, next_aux = struct.unpack_from("<IHHII", data, entry)
                    versions.append(_c_string(data, strings + name))
                    entry += next_aux
                at += following
    glibc = [tuple(int(part) for part in v[len("GLIBC_"):].split(".")) for v in versions
             if v.startswith("GLIBC_") and v[len("GLIBC_"):].replace(".", "").isdigit()]
    return Binary("ELF", ELF_MACHINES.get(e_machine, str(e_machine)), e_type == 3, frozenset(exports),
                  tuple(needed), ".".join(map(str, max(glibc))) if glibc else "")


# ------------------------------------------------------------------------------------------------
# PE
# ------------------------------------------------------------------------------------------------

def _pe(data: bytes) -> Binary:
    """Read a PE32+ DLL."""
    pe, = struct.unpack_from("<I", data, 0x3C)
    if data[pe:pe + 4] != b"PE\0\0":
        raise BinaryError("PE: no PE signature after the DOS header")
    machine, section_count, _, _, _, optional_size, characteristics = struct.unpack_from("<HHIIIHH", data, pe + 4)
    optional = pe + 24
    if struct.unpack_from("<H", data, optional)[0] != 0x20B:
        raise BinaryError("PE: only PE32+ (64-bit) files are read")
    directory_count, = struct.unpack_from("<I", data, optional + 108)
    directories = [struct.unpack_from("<II", data, optional + 112 + 8 * i) for i in range(directory_count)]
    table = optional + optional_size
    sections = [struct.unpack_from("<8sIIII", data, table + 40 * i) for i in range(section_count)]

    def at(rva: int) -> int:
        """Return the file offset of a relative virtual address."""
        for _, virtual_size, address, raw_size, raw_offset in sections:
            if address <= rva < address + max(virtual_size, raw_size):
                return raw_offset + rva - address
        raise BinaryError(f"PE: address {rva:#x} lies in no section")

    exports, needed = set(), []
    export_rva, export_size = directories[0] if directories else (0, 0)
    if export_size:
        name_count, _, names_rva = struct.unpack_from("<III", data, at(export_rva) + 24)
        for i in range(name_count):
            exports.add(_c_string(data, at(struct.unpack_from("<I", data, at(names_rva) + 4 * i)[0])))
    import_rva, import_size = directories[1] if len(directories) > 1 else (0, 0)
    if import_size:
        entry = at(import_rva)
        while True:
            lookup, _, _, name, thunk = struct.unpack_from("<IIIII", data, entry)
            if not (lookup or name or thunk):
                break
            needed.append(_c_string(data, at(name)))
            entry += 20
    return Binary("PE", PE_MACHINES.get(machine, hex(machine)), bool(characteristics & 0x2000),
                  frozenset(exports), tuple(needed))


# ------------------------------------------------------------------------------------------------
# Mach-O
# ------------------------------------------------------------------------------------------------

def _uleb(data: bytes, offset: int) -> tuple:
    """Return (value, next offset) of the unsigned LEB128 number at `offset`."""
    value = shift = 0
    while True:
        byte = data[offset]
        offset += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, offset


def _trie_names(data: bytes, start: int, end: int) -> set:
    """Return every name in the dyld export trie data[start:end]."""
    names, stack, seen = set(), [(0, "")], set()
    while stack:
        node, prefix = stack.pop()
        if node in seen or start + node >= end:
            raise BinaryError("Mach-O: malformed export trie")
        seen.add(node)
        terminal_size, offset = _uleb(data, start + node)
        if terminal_size:
            names.add(prefix)
        offset += terminal_size
        children = data[offset]
        offset += 1
        for _ in range(children):
            label_end = data.index(b"\0", offset)
            label = data[offset:label_end].decode("utf-8", "replace")
            child, offset = _uleb(data, label_end + 1)
            stack.append((child, prefix + label))
    return names


def _version(encoded: int) -> str:
    """Return a Mach-O version number (xxxx.yy.zz in nibbles) as text, e.g. '11.0'."""
    major, minor, patch = encoded >> 16, (encoded >> 8) & 0xFF, encoded & 0xFF
    return f"{major}.{minor}" + (f".{patch}" if patch else "")


def _macho(data: bytes) -> Binary:
    """Read a 64-bit Mach-O dylib."""
    _, cputype, _, filetype, command_count, _, _, _ = struct.unpack_from("<IiIIIIII", data, 0)
    offset, exports, needed, minimum = 32, None, [], ""
    for _ in range(command_count):
        command, size = struct.unpack_from("<II", data, offset)
        if command in (0x22, 0x80000022):               # LC_DYLD_INFO(_ONLY): export_off, export_size
            export_offset, export_size = struct.unpack_from("<II", data, offset + 40)
            if export_size:
                exports = _trie_names(data, export_offset, export_offset + export_size)
        elif command == 0x80000033:                     # LC_DYLD_EXPORTS_TRIE
            export_offset, export_size = struct.unpack_from("<II", data, offset + 8)
            exports = _trie_names(data, export_offset, export_offset + export_size)
        elif command in (0xC, 0x18, 0x80000018, 0x1F):  # LC_LOAD_DYLIB, _WEAK_, LC_REEXPORT_DYLIB
            name_offset, = struct.unpack_from("<I", data, offset + 8)
            needed.append(_c_string(data, offset + name_offset))
        elif command == 0x32:                           # LC_BUILD_VERSION: platform, minos
            minimum = _version(struct.unpack_from("<I", data, offset + 12)[0])
        elif command == 0x24 and not minimum:           # LC_VERSION_MIN_MACOSX
            minimum = _version(struct.unpack_from("<I", data, offset + 8)[0])
        offset += size
    if exports is None:
        raise BinaryError("Mach-O: no export trie (LC_DYLD_INFO or LC_DYLD_EXPORTS_TRIE)")
    functions = frozenset(name[1:] for name in exports if name.startswith("_"))
    return Binary("Mach-O", MACHO_CPUS.get(cputype, hex(cputype)), filetype == 6, functions, tuple(needed), minimum)


def main(argv: list) -> int:
    """Print what each library's headers say."""
    for path in argv:
        binary = read(path)
        print(f"{path}: {binary.format} {binary.machine}{' shared' if binary.shared else ''}"
              f"{', needs ' + binary.minimum_os if binary.minimum_os else ''}; loads {', '.join(binary.needed)}")
        print("  exports " + " ".join(sorted(binary.exports)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
