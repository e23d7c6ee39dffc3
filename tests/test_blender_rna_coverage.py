"""Never silently wrong, checked against the running Blender's RNA (the bpy module, no mocks): every property of
every struct Primer reads is in addon/coverage.py's table, read where it says, reported by the function it names,
and those notes appear when their settings are set, never in a factory default scene."""
from __future__ import annotations

import importlib
import os
import re
import sys

import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import load_primer  # noqa: E402

pytestmark = [pytest.mark.blender]


@pytest.fixture(scope="module")
def addon():
    """Primer's addon package, registered (scene.primer exists), with Cycles' settings registered too."""
    primer = load_primer()
    return importlib.import_module(primer.__name__ + ".addon")


def module(addon, name: str):
    """The addon/ module `name` (coverage, unmodelled, export, materials, ...)."""
    return importlib.import_module(f"{addon.__name__}.{name}")


def factory_scene() -> dict:
    """Blender's factory default scene, as the names coverage.STRUCTS' paths start from."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    return {"scene": scene, "view_layer": scene.view_layers[0], "object": scene.objects["Cube"],
            "camera": scene.camera, "light": scene.objects["Light"], "world": scene.world,
            "material": scene.objects["Cube"].active_material}


def resolve(names: dict, path: str):
    """The datablock or struct at a dotted `path` (scene.cycles, camera.data.dof, ...) from `names`."""
    first, *rest = path.split(".")
    value = names[first]
    for attribute in rest:
        value = getattr(value, attribute)
    return value


def struct_rna(name: str, path: str, names: dict):
    """The RNA of struct `name`: bpy.types' own, else that of the struct at `path` (add-on settings groups)."""
    cls = getattr(bpy.types, name, None)
    if cls is not None:
        return cls.bl_rna
    rna = resolve(names, path).bl_rna
    assert rna.identifier == name, (path, rna.identifier, name)
    return rna


def test_every_property_is_in_the_table(addon):
    """Each own property of each struct is in a class (else Blender grew a setting: read it, report it or say why
    it changes nothing), in one class only; an entry missing from this Blender must be marked version-specific."""
    coverage = module(addon, "coverage")
    names = factory_scene()
    problems = []
    for struct, path in coverage.STRUCTS.items():
        present = coverage.own_properties(struct_rna(struct, path, names))
        listed = coverage.entries(struct)
        problems += [f"{struct}.{p}: in no class (new in Blender {bpy.app.version_string}?)"
                     for p in present if p not in listed]
        problems += [f"{struct}.{p}: listed, absent from this Blender and not marked '*'" for p in listed
                     if p not in present and p not in coverage.version_specific(struct)]
        all_names = [n.rstrip("*") for groups in coverage.COVERAGE[struct].values() for key in groups
                     for n in key.split()]
        problems += [f"{struct}.{p}: in more than one class or group" for p in sorted(set(all_names))
                     if all_names.count(p) > 1]
        problems += [f"{struct}: unknown class {kind!r}" for kind in coverage.COVERAGE[struct]
                     if kind not in coverage.CLASSES]
    assert set(coverage.COVERAGE) == set(coverage.STRUCTS)
    assert not problems, "\n".join(problems)


def test_read_settings_are_read_and_reported_ones_have_their_function(addon):
    """A READ identifier occurs in addon/'s code (but where Blender's depsgraph applies it); every function a READ
    or REPORTED entry names exists; an OWN entry names one of Primer's settings."""
    coverage = module(addon, "coverage")
    folder = os.path.join(ROOT, "addon")
    source = "\n".join(open(os.path.join(folder, f), encoding="utf-8").read() for f in sorted(os.listdir(folder))
                       if f.endswith(".py") and f != "coverage.py")
    primer_settings = set(bpy.context.scene.primer.bl_rna.properties.keys())
    problems = []
    for struct in coverage.COVERAGE:
        for identifier, (kind, text) in coverage.entries(struct).items():
            if kind == coverage.READ and not text.startswith("depsgraph"):
                quoted = re.findall(r"`(\w+)`", text)
                wanted = quoted[0] if quoted else identifier
                if not re.search(rf"\b{wanted}\b", source):
                    problems.append(f"{struct}.{identifier}: READ, but '{wanted}' is nowhere in addon/")
            if kind in (coverage.READ, coverage.REPORTED):
                for name, attribute in coverage.functions(text):
                    target = module(addon, name)
                    for part in attribute.split("."):
                        target = getattr(target, part, None)
                    if not callable(target):
                        problems.append(f"{struct}.{identifier}: {name}.{attribute} is not a function of addon/")
            if kind == coverage.REPORTED and not coverage.functions(text):
                problems.append(f"{struct}.{identifier}: REPORTED names no function")
            if kind == coverage.OWN and text.split(":")[0] not in primer_settings:
                problems.append(f"{struct}.{identifier}: OWN names '{text}', not a setting of scene.primer")
    assert not problems, "\n".join(problems)


# (struct, its path, property, value (or a function making it), settings it needs first [(path, property, value)],
#  the unmodelled.py function, what it is called with, a phrase of its note). The table must say REPORTED by it.
CASES = [
    ("RenderSettings", "scene.render", "use_multiview", True, [], "render_notes", "scene", "Stereoscopy"),
    ("CyclesRenderSettings", "scene.cycles", "use_fast_gi", True, [("scene.primer", "settings_source", "PRIMER")],
     "render_notes", "scene", "which have no Fast GI"),
    ("CyclesRenderSettings", "scene.cycles", "volume_biased", True, [], "render_notes", "scene", "Biased volume"),
    ("ViewLayer", "view_layer", "use_solid", False, [], "view_layer_notes", "view_layer", "Surfaces out"),
    ("ViewLayer", "view_layer", "use_pass_combined", False, [], "view_layer_notes", "view_layer", "Combined pass"),
    ("CyclesRenderLayerSettings", "view_layer.cycles", "denoising_store_passes", True, [], "view_layer_notes",
     "view_layer", "Denoising Data passes"),
    ("Camera", "camera.data", "type", "CUSTOM", [], "camera_notes", "camera", "Custom camera"),
    ("CyclesWorldSettings", "world.cycles", "is_caustics_light", True, [], "world_notes", "world", "shadow caustics"),
]


@pytest.mark.parametrize("case", CASES, ids=[f"{c[0]}.{c[2]}" for c in CASES])
def test_a_reported_setting_is_noted_when_set(addon, case):
    """Setting a REPORTED property away from its default makes its function's note appear, once; the table names
    that function for it (a READ setting, for the values Primer does not read). (A setting this Blender lacks is
    skipped.)"""
    struct, path, prop, value, needs, function, argument, phrase = case
    coverage, unmodelled = module(addon, "coverage"), module(addon, "unmodelled")
    kind, text = coverage.entries(struct)[prop]
    assert kind in (coverage.REPORTED, coverage.READ), (kind, text)
    assert ("unmodelled", function) in coverage.functions(text), text
    names = factory_scene()
    target = resolve(names, path)
    if prop not in target.bl_rna.properties or (isinstance(value, str) and target.bl_rna.properties[prop].type == "ENUM"
                                                and value not in target.bl_rna.properties[prop].enum_items.keys()):
        pytest.skip(f"{struct}.{prop} = {value!r} is not in Blender {bpy.app.version_string}")
    notes = getattr(unmodelled, function)
    assert not [n for n in notes(names[argument]) if phrase in n]
    for need_path, need_prop, need_value in needs:
        setattr(resolve(names, need_path), need_prop, need_value)
    assert not [n for n in notes(names[argument]) if phrase in n], "noted before the setting itself was set"
    setattr(target, prop, value() if callable(value) else value)
    found = [n for n in notes(names[argument]) if phrase in n]
    assert len(found) == 1, notes(names[argument])


def test_a_factory_scene_has_no_notes(addon):
    """Blender's factory default scene gets none of unmodelled.py's notes (Cycles' default pixel filter is followed)."""
    unmodelled = module(addon, "unmodelled")
    names = factory_scene()
    notes = (unmodelled.render_notes(names["scene"]) + unmodelled.view_layer_notes(names["view_layer"])
             + unmodelled.camera_notes(names["camera"]) + unmodelled.world_notes(names["world"])
             + unmodelled.material_notes(names["material"]))
    for obj in names["scene"].objects:
        notes += unmodelled.object_notes(obj) + (unmodelled.light_notes(obj) if obj.type == "LIGHT" else [])
    assert notes == [], notes
