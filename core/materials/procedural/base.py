"""What a procedural texture node is: its Blender node, its inputs and outputs, its settings, its op.

A `TextureNode` subclass describes one of Cycles' texture nodes once. The node-graph compiler
(core/materials/graph.py) reads the description to compile it to one op: the registers of its inputs in the order of
`inputs` (a linked input's register, a constant's, or, for an unlinked input whose default is a name, that texture
coordinate: Cycles' default Generated coordinates), then the integers `numbers` makes of its settings. The op writes
all of its outputs, in the order of `outputs`, into one block of registers. `evaluate` is the op for n hits at once
in numpy; the C file `<c_name>.c` beside it holds `<c_name>_texture`, the op at one hit. The add-on
(addon/materials.py) reads `blender`'s inputs by name and each setting from the bpy attribute `settings` names; a
float property that is no socket (the Brick's Offset and Squash) is an input too, which the add-on reads from the
bpy attribute `properties` names, as a constant.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

F32 = np.float32


class TextureNode:
    """A procedural texture node (a subclass per node; never instantiated: everything is on the class)."""

    kind: ClassVar[str] = ""            # the graph node's kind and the op's name (graph.OPS), e.g. "TEX_CHECKER"
    blender: ClassVar[str] = ""         # Blender's node type, e.g. "ShaderNodeTexChecker"
    c_name: ClassVar[str] = ""          # its C file <c_name>.c and function <c_name>_texture
    # (name, width, default): a float or colour default, or a texture coordinate's name ("generated").
    inputs: ClassVar[tuple] = ()
    # name -> (width, type), in the order the op writes them.
    outputs: ClassVar[dict] = {}
    # setting -> (the bpy attribute of Blender's node, its choices in the op's numbering or None for a bool, default)
    settings: ClassVar[dict] = {}
    # input -> the bpy attribute of a float node property (no socket) read as that input's constant (Brick's Offset)
    properties: ClassVar[dict] = {}

    @classmethod
    def width(cls) -> int:
        """How many registers the op writes: all its outputs."""
        return sum(width for width, _ in cls.outputs.values())

    @classmethod
    def output(cls, name: str) -> tuple:
        """(offset in the op's block, width, type) of an output."""
        offset = 0
        for key, (width, vtype) in cls.outputs.items():
            if key == name:
                return offset, width, vtype
            offset += width
        raise KeyError(f"{cls.__name__} has no output {name!r}")

    @classmethod
    def setting(cls, props: dict, name: str) -> int:
        """A setting as the op's integer: its place among the choices, or 0/1 for a bool."""
        _, choices, default = cls.settings[name]
        value = props.get(name, default)
        return choices.index(value) if choices is not None else int(bool(value))

    @classmethod
    def numbers(cls, props: dict, output: str) -> list:
        """The op's integer arguments after its input registers: its settings, in the order of `settings` (and
        what a subclass adds for `output`)."""
        return [cls.setting(props, name) for name in cls.settings]

    @classmethod
    def differs_in(cls, props: dict, version: tuple):
        """What the Cycles of Blender `version` (major, minor, patch) computes otherwise for these settings, as a note
        for the add-on's warning, or None: Primer follows Cycles 5.0."""
        return None

    @classmethod
    def evaluate(cls, inputs: list, numbers: list) -> np.ndarray:
        """The op at n hits: inputs, one (n, width) float64 array per input; numbers, the op's integers ->
        (n, cls.width()) float64, the outputs side by side."""
        raise NotImplementedError


def as_f32(values: np.ndarray) -> np.ndarray:
    """A register block (n, w) float64 as float32 columns (Cycles' SVM stack holds floats)."""
    return np.asarray(values, np.float64).astype(F32)
