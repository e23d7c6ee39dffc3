"""The boundary between Python and C, described once: the records Python hands to C, and the numbers both read.

Each part describes what it hands to C next to the Python that fills it (a light's record in core/lights/base.py,
the camera's in core/camera/camera.py, ...):

    LightRecord = schema.record("LightRecord", "One light, prepared by its class's `pack`.", [
        ("kind", I32, "its place in LIGHT_TYPES"), ("color", F64, 3, "RGB"), ("corners", ptr(F64), "(t, 3, 3)"), ...])

`record` returns a ctypes Structure with typed fields (integers as integers, pointers typed by what they point
at) that refuses what does not fit: a float into an int field, an array of another dtype or layout into a pointer.
tools/make_boundary.py writes the C structs (core/native/boundary.gen.h) from the same descriptions, with a hash
of each record's layout that the library returns (`primer_layout`); a record checks that hash against its own
the first time it crosses (`Record.check`), so a library built from other sources is found, never trusted.
`constant` gives a number both sides read (a table's size, a mode, a bit) its one definition.

This module knows no part: parts describe themselves through it.
"""
from __future__ import annotations

import ctypes
import hashlib
import itertools
import sys
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from . import library

# ----------------------------------------------------------------------------
# Types
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Scalar:
    """A C number type: its spelling in C, its ctypes type, its numpy dtype."""

    c: str
    ctype: type
    dtype: type

    @property
    def integer(self) -> bool:
        """Whether it holds integers."""
        return np.issubdtype(self.dtype, np.integer)


F64 = Scalar("double", ctypes.c_double, np.float64)
F32 = Scalar("float", ctypes.c_float, np.float32)
I64 = Scalar("int64_t", ctypes.c_int64, np.int64)
U64 = Scalar("uint64_t", ctypes.c_uint64, np.uint64)
I32 = Scalar("int32_t", ctypes.c_int32, np.int32)
U32 = Scalar("uint32_t", ctypes.c_uint32, np.uint32)
U16 = Scalar("uint16_t", ctypes.c_uint16, np.uint16)
U8 = Scalar("uint8_t", ctypes.c_uint8, np.uint8)


@dataclass(frozen=True)
class Pointer:
    """A pointer field: to numbers of a Scalar type (an array), to a record (by name), or to anything (None).
    const: C only reads through it."""

    target: Union[Scalar, str, None]
    const: bool = True

    @property
    def c(self) -> str:
        """Its C spelling, e.g. 'const double *'."""
        target = "void" if self.target is None else (self.target if isinstance(self.target, str) else self.target.c)
        return ("const " if self.const else "") + target + " *"


def ptr(target: Union[Scalar, str, None] = None) -> Pointer:
    """A pointer C reads through: to a Scalar's numbers, to a record named `target`, or (None) to anything."""
    return Pointer(target, True)


def out(target: Union[Scalar, str, None] = None) -> Pointer:
    """A pointer C writes through."""
    return Pointer(target, False)


class Constant(int):
    """An integer both sides read, with its C name: a table's size, a mode, a bit."""

    def __new__(cls, name: str, value: int, doc: str = ""):
        self = super().__new__(cls, value)
        self.name, self.doc = name, doc
        return self


@dataclass(frozen=True)
class Field:
    """A record's field: its name, its type (Scalar or Pointer), its array shape (() for one value), and what it is."""

    name: str
    type: Union[Scalar, Pointer]
    shape: tuple
    doc: str


# ----------------------------------------------------------------------------
# What the parts describe (tools/make_boundary.py reads these)
# ----------------------------------------------------------------------------

RECORDS: dict = {}          # name -> the record's ctypes class
FUNCTIONS: dict = {}        # exported name -> (the C function it hands its record to, the record, the result's field)
CONSTANTS: dict = {}        # C name -> (Constant (or float), its group's comment)
TABLES: dict = {}           # a kind field's table name -> callable giving its C names by kind (for the hashes)
# Where each name above was described: (the describing module, the order there), so that the generated C lists
# them in the same order whichever module Python happened to import first.
_PLACE: dict = {}
_COUNTER = itertools.count()


def described_records() -> list:
    """Every record described so far (what core/native/library.py checks the library against)."""
    return list(RECORDS.values())


def _caller(depth: int = 2) -> str:
    """The module name of the caller's caller (depth 2), or further up."""
    return sys._getframe(depth).f_globals.get("__name__", "")


def _described_here(name: str, module: str) -> None:
    """Remember the module that describes `name`, and when."""
    _PLACE[name] = (module, next(_COUNTER))


def where(name: str) -> str:
    """The module that described `name`."""
    return _PLACE.get(name, ("", 0))[0]


def in_order(names) -> list:
    """`names` in the order of the modules that described them (by module name), then as each module did."""
    return sorted(names, key=lambda name: _PLACE.get(name, ("", 0)))


def constant(name: str, value, doc: str = "", module: Optional[str] = None):
    """A number both sides read, defined once here: returns it (a Constant for an int), known to C by `name`.
    module: the describing module (default: the caller's)."""
    if name in CONSTANTS and CONSTANTS[name][0] != value:
        raise ValueError(f"constant {name} is {CONSTANTS[name][0]} and {value}")
    made = Constant(name, value, doc) if isinstance(value, (int, np.integer)) and not isinstance(value, bool) else value
    if name not in CONSTANTS:
        _described_here(name, module or _caller())
    CONSTANTS[name] = (made, doc)
    return made


def constants(prefix: str, names, doc: str = "") -> dict:
    """Integers numbered by their place in `names` (or a dict name -> value), as C's PREFIX_NAME: name -> Constant."""
    values = dict(names) if isinstance(names, dict) else {name: index for index, name in enumerate(names)}
    module = _caller()
    made = {}
    for name, value in values.items():
        made[name] = constant(f"{prefix}_{name.upper()}", int(value), doc, module)
    return made


def table(name: str, names) -> None:
    """Declare the table `name` whose kinds a record's `kind` field holds: `names` a callable giving the C name of
    each kind in order (read when a layout is hashed, so that the table may be filled after the record is made)."""
    TABLES[name] = names


class Record(ctypes.Structure):
    """A record C reads: typed fields made from its Fields; see the module docstring."""

    _description: tuple = ()
    _doc: str = ""
    _tables: tuple = ()
    _checked: bool = False

    def __init__(self, **values):
        super().__init__()
        for name, value in values.items():
            setattr(self, name, value)

    def copy(self) -> "Record":
        """A copy of the record (the same arrays kept alive)."""
        other = type(self).from_buffer_copy(self)
        other.__dict__["_keep"] = dict(self.__dict__.get("_keep", {}))
        return other

    def __setattr__(self, name: str, value) -> None:
        field = self._by_name().get(name)
        if field is None:
            if name.startswith("_"):
                object.__setattr__(self, name, value)
                return
            raise AttributeError(f"{type(self).__name__} has no field {name!r}")
        if isinstance(field.type, Pointer):
            address, keep = _address(field, value, type(self).__name__)
            self.__dict__.setdefault("_keep", {})[name] = keep
            super().__setattr__(name, address)
        elif field.shape:
            array = np.asarray(value, field.type.dtype)
            if field.type.integer and not np.array_equal(array, np.asarray(value)):
                raise TypeError(f"{type(self).__name__}.{name} holds integers, not {value!r}")
            flat = np.broadcast_to(array, field.shape).ravel()
            np.frombuffer(getattr(self, name), dtype=field.type.dtype, count=flat.size)[:] = flat
        else:
            if field.type.integer:
                if isinstance(value, (bool, np.bool_)):
                    value = int(value)
                if not isinstance(value, (int, np.integer)):
                    raise TypeError(f"{type(self).__name__}.{name} is an integer, not {value!r}")
                value = int(value)
            else:
                value = float(value)
            super().__setattr__(name, value)

    @classmethod
    def _by_name(cls) -> dict:
        if "_fields_by_name" not in cls.__dict__:
            cls._fields_by_name = {f.name: f for f in cls._description}
        return cls._fields_by_name

    @classmethod
    def layout(cls) -> str:
        """A canonical text of the record's layout (its fields' names, C types and shapes, and the kinds of the tables
        its kind fields hold): what its hash is of."""
        lines = [cls.__name__]
        for f in cls._description:
            lines.append(f"{f.name}:{f.type.c}:{','.join(str(int(n)) for n in f.shape)}")
        for name in cls._tables:
            lines.append(f"table {name}:" + ",".join(TABLES[name]()))
        return "\n".join(lines)

    @classmethod
    def layout_hash(cls) -> int:
        """The record's layout hash: 63 bits of SHA-256 of `layout` (what C's primer_layout returns for it)."""
        return int.from_bytes(hashlib.sha256(cls.layout().encode()).digest()[:8], "little") >> 1

    @classmethod
    def check(cls) -> None:
        """Refuse a library whose C struct is not this record's layout (built from other sources), once per record,
        and likewise for the records it points at."""
        if cls._checked:
            return
        for f in cls._description:
            if isinstance(f.type, Pointer) and isinstance(f.type.target, str) and f.type.target != cls.__name__:
                RECORDS[f.type.target].check()          # (a record that points at its own kind: a chain)
        theirs = library.layout_of(cls.__name__)
        if theirs != cls.layout_hash():
            raise RuntimeError(f"{cls.__name__}'s layout in {library.library_name()} is not the one Python describes "
                               "(built from other sources: make kernels)")
        size = library.size_of(cls.__name__)
        if ctypes.sizeof(cls) != size:
            raise RuntimeError(f"{cls.__name__} is {ctypes.sizeof(cls)} bytes here and {size} in C (make kernels)")
        cls._checked = True


def _address(field: Field, value, record: str):
    """The address a pointer field gets for `value`, and what must stay alive meanwhile."""
    if value is None:
        return None, None
    target = field.type.target
    if isinstance(value, np.ndarray):
        if isinstance(target, Scalar) and value.dtype != target.dtype:
            raise TypeError(f"{record}.{field.name} points at {np.dtype(target.dtype)}, not {value.dtype}")
        if not value.flags.c_contiguous:
            raise TypeError(f"{record}.{field.name} needs a C-contiguous array")
        if not field.type.const and not value.flags.writeable:
            raise TypeError(f"{record}.{field.name} is written by C: the array must be writeable")
        return value.ctypes.data, value
    if isinstance(value, (ctypes.Structure, ctypes.Array)):
        if isinstance(target, str) and isinstance(value, ctypes.Structure) and type(value).__name__ != target:
            raise TypeError(f"{record}.{field.name} points at a {target}, not a {type(value).__name__}")
        return ctypes.addressof(value), value
    if isinstance(value, int):
        return value, None
    raise TypeError(f"{record}.{field.name} is a pointer; got {type(value).__name__}")


def _ctype(field: Field):
    """The ctypes type of a field."""
    base = ctypes.c_void_p if isinstance(field.type, Pointer) else field.type.ctype
    for n in reversed(field.shape):
        base = base * int(n)
    return base


def record(name: str, doc: str, fields: list, tables: tuple = ()) -> type:
    """Describe the record `name` C reads, and return its ctypes class (a Record).

    fields: (name, type, doc), (name, type, n, doc) or (name, type, (n, m), doc) each: a type is a Scalar (F64, I32,
    ...) or a Pointer (ptr(F64), out(I64), ptr("OtherRecord"), ptr()); n, m may be Constants (shown by name in C).
    tables: names of the tables (`table`) whose kinds its fields hold, part of its layout.
    """
    described = []
    for entry in fields:
        if len(entry) == 3:
            fname, ftype, fdoc = entry
            shape = ()
        else:
            fname, ftype, shape, fdoc = entry
            shape = shape if isinstance(shape, tuple) else (shape,)
        described.append(Field(fname, ftype, tuple(shape), fdoc))
    if name in RECORDS:
        raise ValueError(f"record {name} is described twice")
    cls = type(name, (Record,), {"_fields_": [(f.name, _ctype(f)) for f in described],
                                 "_description": tuple(described), "_doc": doc, "_tables": tuple(tables),
                                 "__doc__": doc})
    RECORDS[name] = cls
    _described_here(name, _caller())
    return cls


def function(name: str, calls: str, args: type, result: Optional[str] = None) -> type:
    """Describe the C function `name` the library exports: it takes one record of arguments (`args`) and hands it
    to the C function `calls`, which reads the fields itself (`static void calls(const Args *a)`; with `result`,
    it returns what goes into that field); tools/make_boundary.py writes it. Returns `args`. Python calls it with
    core/native/library.py's `call`."""
    if name in FUNCTIONS:
        raise ValueError(f"function {name} is described twice")
    FUNCTIONS[name] = (calls, args, result)
    _described_here(name, _caller())
    return args


def c_shape(n) -> str:
    """An array bound in C: a Constant's name, else the number."""
    return n.name if isinstance(n, Constant) else str(int(n))


def c_struct(cls: type) -> str:
    """The C struct of a record, with its fields' comments."""
    lines = [f"/* {line} */" if i == 0 else f" * {line}" for i, line in enumerate(cls._doc.splitlines())]
    if len(lines) > 1:
        lines[0] = "/* " + lines[0][3:-3]
        lines[-1] += " */"
    out = lines + [f"struct {cls.__name__} {{"]
    for f in cls._description:
        spelling = f.type.c
        bounds = "".join(f"[{c_shape(n)}]" for n in f.shape)
        declaration = f"    {spelling}{'' if spelling.endswith('*') else ' '}{f.name}{bounds};"
        out.append(f"{declaration:<44s}/* {f.doc} */" if f.doc else declaration)
    out.append("};")
    return "\n".join(out) + "\n"


def c_export(name: str) -> str:
    """The exported C function `name`: one record of arguments, handed as it is to the function it calls."""
    calls, args, result = FUNCTIONS[name]
    body = f"a->{result} = {calls}(a);" if result else f"{calls}(a);"
    return f"EXPORT void {name}({args.__name__} *a)\n{{\n    {body}\n}}\n"


def hashes() -> dict:
    """Every record's name -> its layout hash."""
    return {name: cls.layout_hash() for name, cls in RECORDS.items()}


def layout_text(name: Optional[str] = None) -> str:
    """The canonical layout of one record, or of all of them."""
    names = [name] if name else list(RECORDS)
    return "\n\n".join(RECORDS[n].layout() for n in names)


library.DESCRIBED.append(described_records)
