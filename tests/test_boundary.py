"""The boundary between Python and C: what a BSDF, a shader node or a light is, declared once on its class, and the
C tables generated from that (tools/make_boundary.py)."""
from __future__ import annotations

import ctypes
import os

import numpy as np
import pytest

from core import lights as lights_
from core import materials
from core.lights import LIGHT_TYPES, LightFlags
from core.materials import BSDF_TYPES, NODE_TYPES, BSDFFlags
from core.materials.closures import Closures, eval_closures, sample_closures
from tools import make_boundary

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
F = BSDFFlags


def test_generated_c_files_are_what_the_python_tables_say():
    """Every generated C file equals what tools/make_boundary.py writes from the Python tables today (a table or
    a record changed in Python without `make kernels` would leave C behind)."""
    assert make_boundary.stale() == []


@pytest.mark.parametrize("bsdf", BSDF_TYPES, ids=lambda cls: cls.__name__)
def test_every_bsdf_says_what_it_is(bsdf):
    """A BSDF's flags say where its light goes (reflection, transmission or both), how its directions count
    (exactly one of diffuse, glossy, singular), and at most one closure type; its kind is its place in the table,
    and its C file (with <name>_eval and <name>_sample) sits beside its Python (one file may hold two BSDFs). A
    BSSRDF (SUBSURFACE) is no BSDF: it only says its closure type."""
    flags = bsdf.flags
    # (a BSSRDF neither reflects nor transmits at its point: its light leaves where the walk does, after no bounce)
    assert flags & (F.REFLECTION | F.TRANSMISSION) or flags == F.SUBSURFACE | F.DIFFUSE_TYPE
    assert (sum(bool(flags & f) for f in (F.DIFFUSE, F.GLOSSY, F.SINGULAR)) == 1 or flags & F.STRAIGHT
            or flags & F.SUBSURFACE)
    assert sum(bool(flags & f) for f in (F.DIFFUSE_TYPE, F.GLOSSY_TYPE, F.TRANSMISSION_TYPE, F.GLASS_TYPE)) <= 1
    assert not (flags & F.STRAIGHT) or flags & F.SINGULAR, "light straight through is a delta"
    assert BSDF_TYPES[bsdf.kind] is bsdf
    source = open(os.path.join(ROOT, "core", "materials", bsdf.c_file() + ".c"), encoding="utf-8").read()
    assert f"{bsdf.c_name()}_eval(" in source and f"{bsdf.c_name()}_sample(" in source


@pytest.mark.parametrize("light", LIGHT_TYPES, ids=lambda cls: cls.__name__)
def test_every_light_says_what_it_is(light):
    """A light type has exactly one of the kinds of light (position, distant, area, infinite, emitter), its kind is
    its place in the table, and its C file has the table's <name>_sample and <name>_hit."""
    assert bin(int(light.flags)).count("1") == 1
    assert LIGHT_TYPES[light.kind] is light
    source = open(os.path.join(ROOT, "core", "lights", light.c_name() + ".c"), encoding="utf-8").read()
    assert f"{light.c_name()}_sample(" in source and f"{light.c_name()}_hit(" in source


def test_every_node_names_its_setup_once():
    """Shader nodes are numbered by their place in the table, their names are unique, and each has a setup: a
    BSDF it adds one closure of, or its own <name>_node in C."""
    assert [cls.kind for cls in NODE_TYPES] == list(range(len(NODE_TYPES)))
    assert len({cls.name for cls in NODE_TYPES}) == len(NODE_TYPES)
    source = open(os.path.join(ROOT, "core", "materials", "nodes.c"), encoding="utf-8").read()
    for cls in NODE_TYPES:
        assert cls.bsdf in BSDF_TYPES if cls.bsdf is not None else f"{cls.name.lower()}_node(" in source


def test_an_unknown_bsdf_kind_is_an_error_not_a_lambert():
    """A closure of a kind outside the table is refused (it once rendered as Lambert)."""
    unknown = len(BSDF_TYPES)
    with pytest.raises(IndexError, match="not in the table"):
        materials.flags_of(np.array([0, unknown]))
    closures = Closures.empty(1)
    closures.kind[0, 0] = unknown
    closures.weight[0, 0] = 1.0
    closures.sample_weight[0, 0] = 1.0
    closures.N[0, 0] = (0.0, 0.0, 1.0)
    wo = np.array([[0.0, 0.0, 1.0]])
    with pytest.raises(IndexError):
        eval_closures(closures, wo, wo)
    with pytest.raises(IndexError):
        sample_closures(closures, wo, np.full((1, 2), 0.5), np.full(1, 0.5))


def test_the_flags_group_the_bsdfs_as_cycles_does():
    """The closure labels and types of Cycles (kernel/closure/bsdf*.h, svm/types.h): the velvet is labelled diffuse
    but is of the glossy type; Oren-Nayar and the microfiber sheen are diffuse; glass is its own type."""
    by_name = materials.BSDF_BY_NAME
    assert by_name["VELVET"].is_(F.DIFFUSE) and by_name["VELVET"].is_(F.GLOSSY_TYPE)
    assert not by_name["VELVET"].is_(F.DIFFUSE_TYPE)
    for name in ("DIFFUSE", "OREN_NAYAR", "SHEEN"):
        assert by_name[name].is_(F.DIFFUSE) and by_name[name].is_(F.DIFFUSE_TYPE)
    for name in ("GLASS", "ROUGH_GLASS"):
        assert by_name[name].flags & (F.REFLECTION | F.TRANSMISSION) == F.REFLECTION | F.TRANSMISSION
        assert by_name[name].is_(F.GLASS_TYPE)
    assert by_name["MIRROR"].is_(F.SINGULAR) and by_name["GLOSSY"].is_(F.GLOSSY)
    assert by_name["TRANSPARENT"].is_(F.STRAIGHT)


def test_lamps_are_the_lights_rays_meet_in_space():
    """Point, spot, sun and area lamps are met by Light.hit; the emissive triangles and the world are found as
    geometry and as the sky."""
    lamps = {cls.__name__ for cls in LIGHT_TYPES if cls.is_(lights_.LAMP)}
    assert lamps == {"PointLight", "SpotLight", "SunLight", "AreaLight"}
    assert lights_.MeshEmitters.is_(LightFlags.EMITTER) and lights_.WorldLight.is_(LightFlags.INFINITE)


def test_records_are_typed_integers_as_integers_and_pointers_by_what_they_point_at():
    """A record refuses what does not fit its C field: a float in an integer field, an array of another dtype or a
    strided array in a pointer, a record of another type in a typed pointer; it keeps what it points at alive."""
    from core.lights.base import LightContext, LightRecord
    from core.lights.world import WorldTablesRecord
    from core.sampling.sobol import Sample2dArgs
    record = LightRecord(kind=2, delta=True, samples=4)
    assert (record.kind, record.delta, record.samples) == (2, 1, 4)
    with pytest.raises(TypeError, match="integer"):
        record.samples = 4.0
    args = Sample2dArgs()
    with pytest.raises(TypeError, match="int64"):
        args.pixel = np.zeros(4, np.float64)
    with pytest.raises(TypeError, match="contiguous"):
        args.pixel = np.zeros(8, np.int64)[::2]
    with pytest.raises(TypeError, match="WorldTables"):
        LightContext(world=LightRecord())
    pixels = np.arange(5, dtype=np.int64)
    args.pixel = pixels
    del pixels
    assert np.array_equal(np.ctypeslib.as_array(ctypes.cast(args.pixel, ctypes.POINTER(ctypes.c_int64)), (5,)),
                          np.arange(5))
    assert WorldTablesRecord(camera=True).camera == 1


def test_a_library_built_from_other_sources_is_refused_before_a_record_crosses(monkeypatch):
    """When the library's layout of a record is not the one Python describes (a stale build), the first call that
    hands it over raises, naming the record and `make kernels`, instead of reading fields at the wrong places."""
    from core.native import library, schema
    from core.sampling import sobol
    if not library.available():
        pytest.skip(library.unavailable_reason())
    monkeypatch.setattr(sobol.Sample2dArgs, "_checked", False)
    monkeypatch.setattr(library, "layout_of", lambda name: 12345)
    with pytest.raises(RuntimeError, match="Sample2dArgs.*make kernels"):
        sobol.compiled_sample_2d(0, np.zeros(1, np.int64), np.zeros(1, np.int64), 0)
    assert all(name in schema.RECORDS for name in ("LightRecord", "ChunkParams", "MaterialRecord", "CameraRecord"))


def test_every_record_and_function_is_laid_out_in_c_as_in_python():
    """The library built from the generated header knows each described record with the same layout hash and size
    as Python, and exports each described function."""
    from core.native import library
    schema = make_boundary.described()
    if not library.available():
        pytest.skip(library.unavailable_reason())
    for name, struct in schema.RECORDS.items():
        assert library.layout_of(name) == struct.layout_hash(), name
        assert library.size_of(name) == ctypes.sizeof(struct), name
    lib = library.library()
    for name in schema.FUNCTIONS:
        assert hasattr(lib, name), name


def test_a_stale_library_is_set_aside_and_renders_fall_back_to_the_reference(monkeypatch):
    """A library whose layout of some record is not Python's (built from other C sources) is not used at all: it
    is unavailable with a reason naming the record, and a render takes the numpy path, saying why."""
    from core.integrators import compiled
    from core.native import library, schema
    from core.scene import RenderSettings
    if not library.available():
        pytest.skip(library.unavailable_reason())
    monkeypatch.setattr(library, "_cache", dict(library._cache))
    for record in schema.RECORDS.values():
        monkeypatch.setattr(record, "_checked", False)
    real = library.layout_of
    monkeypatch.setattr(library, "layout_of", lambda name: 1 if name == "LightRecord" else real(name))
    assert not library.available()
    assert "LightRecord" in library.unavailable_reason() and "make kernels" in library.unavailable_reason()
    assert "LightRecord" in compiled.why_not(RenderSettings())
