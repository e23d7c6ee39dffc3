"""The shape of core/: its parts import each other without a circle, in the order of their layers, and never bpy.

A part is a folder of core/ (core/film, core/geometry, ...) or a module at its top (core/vectors.py). The
import graph is read from the source with `ast`, every import counted, also those inside functions: a lazy
import is still a dependency (docs/architecture.md, "Layers").
"""
from __future__ import annotations

import ast
import os
from typing import NamedTuple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORE = os.path.join(ROOT, "core")

# The layers of docs/architecture.md, lowest first: a part may import the parts of its own layer and of the
# layers below it, never those above.
LAYERS = (
    ("native", "vectors", "visibility", "memory"),     # the C library's loader, row vectors, ray visibility bits
    ("sampling", "camera", "film"),                     # where samples go, the rays they start, the sums they end in
    ("materials", "volumes"),                           # what a surface and a medium do with light
    ("lights",),                                        # what sends it
    ("scene",),                                         # plain records of all the above
    ("geometry",),                                      # the scene's meshes placed in the world, traced by Embree
    ("integrators",),                                   # light transport, and the recorders listening to it
    ("render",),                                        # the render loop, its validation, the viewport's passes
    ("teaching",),                                      # tools that drive a render: the inspector, the diagram
)

# Modules that exist only inside Blender (the bpy module and its companions).
BLENDER_MODULES = ("bpy", "bpy_extras", "bmesh", "mathutils", "gpu", "blf", "idprop")


class Import(NamedTuple):
    """One import in core/: the module named (absolute), where it is written."""

    module: str
    path: str       # relative to the repository
    line: int


def python_files() -> list:
    """Every .py file under core/, as paths relative to the repository."""
    found = []
    for folder, _, files in os.walk(CORE):
        found += [os.path.relpath(os.path.join(folder, name), ROOT) for name in files if name.endswith(".py")]
    return sorted(found)


def module_of(path: str) -> str:
    """core/film/film.py -> core.film.film; core/render/__init__.py -> core.render."""
    name = path[:-3].replace(os.sep, ".")
    return name[:-len(".__init__")] if name.endswith(".__init__") else name


def imports_of(path: str) -> list:
    """Every import in a file, at its top and inside functions, as absolute module names (for `from X import
    name` both X and X.name: the name may be a module)."""
    module = module_of(path)
    package = module if path.endswith("__init__.py") else module.rsplit(".", 1)[0]
    with open(os.path.join(ROOT, path), encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), path)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [Import(alias.name, path, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.append(Import(target, path, node.lineno))
            found += [Import(f"{target}.{alias.name}", path, node.lineno) for alias in node.names if alias.name != "*"]
        elif (isinstance(node, ast.Call) and isinstance(node.func, (ast.Name, ast.Attribute)) and node.args
              and getattr(node.func, "id", getattr(node.func, "attr", "")) in ("import_module", "__import__")
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            found.append(Import(node.args[0].value, path, node.lineno))
    return found


def part_of(module: str):
    """The part of core a module belongs to (core.film.film -> film, core.vectors -> vectors), or None for a
    module outside core or core's own package."""
    names = module.split(".")
    if names[0] != "core" or len(names) < 2:
        return None
    candidate = os.path.join(CORE, names[1])
    return names[1] if os.path.isdir(candidate) or os.path.isfile(candidate + ".py") else None


def part_graph() -> dict:
    """part -> {part it imports: the first Import that does}, for every part of core/."""
    graph = {}
    for path in python_files():
        here = part_of(module_of(path))
        if here is None:
            continue
        edges = graph.setdefault(here, {})
        for found in imports_of(path):
            there = part_of(found.module)
            if there is not None and there != here:
                edges.setdefault(there, found)
    return graph


def find_circle(graph: dict):
    """A circle of parts [a, b, ..., a] in the graph, or None (depth-first search for an edge back)."""
    state, trail = {}, []

    def visit(part):
        state[part] = "open"
        trail.append(part)
        for there in sorted(graph.get(part, {})):
            if state.get(there) == "open":
                return trail[trail.index(there):] + [there]
            if there not in state:
                circle = visit(there)
                if circle:
                    return circle
        trail.pop()
        state[part] = "done"
        return None

    for part in sorted(graph):
        if part not in state:
            circle = visit(part)
            if circle:
                return circle
    return None


def describe(graph: dict, circle: list) -> str:
    """'a -> b (core/a/x.py:12) -> a (core/b/y.py:3)'."""
    steps = [circle[0]]
    for here, there in zip(circle, circle[1:]):
        found = graph[here][there]
        steps.append(f"{there} ({found.path}:{found.line} imports {found.module})")
    return " -> ".join(steps)


def test_find_circle_finds_a_planted_one():
    """The search itself: a circle of three parts beside a chain is found and named in order."""
    edge = Import("x", "x.py", 1)
    graph = {"a": {"b": edge}, "b": {"c": edge}, "c": {"a": edge, "d": edge}, "d": {}}
    assert find_circle(graph) == ["a", "b", "c", "a"]
    assert find_circle({"a": {"b": edge}, "b": {"c": edge}, "c": {}}) is None


def test_parts_import_no_circle():
    """No part of core imports, directly or through others, a part that imports it back."""
    graph = part_graph()
    assert {"render", "integrators", "geometry", "scene", "lights", "materials", "film"} <= set(graph)
    circle = find_circle(graph)
    assert circle is None, "import circle between parts of core: " + describe(graph, circle)


def test_parts_follow_the_layers():
    """Each part imports only parts of its own layer or below (docs/architecture.md, "Layers")."""
    graph = part_graph()
    layer = {part: index for index, parts in enumerate(LAYERS) for part in parts}
    unplaced = sorted(set(graph) - set(layer))
    assert not unplaced, f"parts of core in no layer (add them to LAYERS and docs/architecture.md): {unplaced}"
    upward = [f"{here} imports {there}, a layer above it ({found.path}:{found.line} imports {found.module})"
              for here, edges in sorted(graph.items()) for there, found in sorted(edges.items())
              if layer[there] > layer[here]]
    assert not upward, "\n".join(upward)


def test_core_never_imports_bpy():
    """core/ runs without Blender: no file imports bpy or the modules that come with it, at its top or lazily."""
    found = [f"{i.path}:{i.line} imports {i.module}" for path in python_files() for i in imports_of(path)
             if i.module.split(".")[0] in BLENDER_MODULES]
    assert not found, "\n".join(found)
