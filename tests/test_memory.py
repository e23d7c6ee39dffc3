"""Render temporaries from the heap (core/memory.py): overlapping renders, and the host process left as found."""
from __future__ import annotations

import sys

import pytest

from core import memory


def test_overlapping_renders_restore_the_thresholds_only_when_the_last_one_ends(monkeypatch):
    """The viewport's render and an F12 render may overlap: the first to end must not undo the other's setting."""
    calls = []

    class FakeLibc:
        def mallopt(self, parameter, value):
            calls.append((parameter, value))
            return 1

        def malloc_trim(self, pad):
            calls.append(("trim", pad))
            return 1

    monkeypatch.setattr(memory, "_glibc", lambda: FakeLibc())
    with memory.temporaries_from_the_heap():
        with memory.temporaries_from_the_heap():
            pass
        assert (memory.M_MMAP_THRESHOLD, memory.GLIBC_DEFAULT) not in calls     # one render still runs
    assert calls[-3:] == [(memory.M_MMAP_THRESHOLD, memory.GLIBC_DEFAULT),
                          (memory.M_TRIM_THRESHOLD, memory.GLIBC_DEFAULT), ("trim", 0)]
    assert memory._renders == 0


def fake_libc(monkeypatch) -> list:
    """Put a C library that only records its calls in place of glibc; return the record."""
    calls = []
    fake = type("FakeLibc", (), {"mallopt": lambda self, p, v: calls.append((p, v)),
                                 "malloc_trim": lambda self, pad: calls.append(("trim", pad))})()
    monkeypatch.setattr(memory, "_glibc", lambda: fake)
    return calls


def test_an_exception_inside_a_render_still_restores_the_thresholds(monkeypatch):
    """A cancelled or failed render leaves the allocator as it found it."""
    calls = fake_libc(monkeypatch)
    with pytest.raises(RuntimeError):
        with memory.temporaries_from_the_heap():
            raise RuntimeError("cancelled")
    assert calls[-1] == ("trim", 0) and memory._renders == 0


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc only")
def test_glibc_is_found_on_linux():
    """On Linux the real C library answers mallopt (so the speed-up is not silently lost)."""
    libc = memory._glibc()
    assert libc is not None
    assert libc.mallopt(memory.M_TRIM_THRESHOLD, memory.GLIBC_DEFAULT) == 1


def test_a_warm_heap_stays_until_released_and_never_under_a_running_render(monkeypatch):
    """keep=True leaves the raised thresholds (the next render finds its pages mapped); release()
    then restores glibc's values and trims, but not while a render runs, and only once."""
    calls = fake_libc(monkeypatch)
    with memory.temporaries_from_the_heap(keep=True):
        pass
    assert ("trim", 0) not in calls and calls[-1] == (memory.M_TRIM_THRESHOLD, memory.TRIM_THRESHOLD)
    with memory.temporaries_from_the_heap(keep=True):
        assert not memory.release()                    # a render runs: nothing is taken from under it
    assert ("trim", 0) not in calls
    assert memory.release()
    assert calls[-3:] == [(memory.M_MMAP_THRESHOLD, memory.GLIBC_DEFAULT),
                          (memory.M_TRIM_THRESHOLD, memory.GLIBC_DEFAULT), ("trim", 0)]
    assert not memory.release()                        # already released
    assert memory._renders == 0


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc only")
def test_warm_heap_saves_the_page_faults_of_the_next_render():
    """Renders in a row on a warm heap map almost no new pages; a render after a release, thousands."""
    import resource

    from core import render
    from core.scene import RenderSettings
    from test_render import showcase_scene

    scene = showcase_scene()
    settings = RenderSettings(width=320, height=240, samples=8, threads=1)

    def faults(keep):
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        render.render(scene, settings, keep_memory=keep)
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

    faults(False)
    cold = faults(True)                 # the heap was trimmed before it
    # (the heap may still grow to its high-water mark over the next renders, more so after other tests left the
    # process's arenas in another state: the fewest of three renders in a row is the warm heap's)
    warm = min(faults(True) for _ in range(3))
    memory.release()
    # (How many pages a trimmed heap needs again depends on what ran before in this process: from a
    # few hundred inside the whole suite to thousands alone. Renders in a row on a warm heap need
    # next to none: about 20 here, against 3,000 for a render after a release.)
    assert warm <= 0.25 * cold, (warm, cold)


def test_a_warm_heap_is_released_only_after_the_idle_time(monkeypatch):
    """release_if_idle waits until no render has run for the given seconds, then releases once."""
    calls = fake_libc(monkeypatch)
    with memory.temporaries_from_the_heap(keep=True):
        pass
    assert not memory.release_if_idle(60.0) and memory.is_warm()
    monkeypatch.setattr(memory, "_idle_since", memory._idle_since - 61.0)
    assert memory.release_if_idle(60.0) and not memory.is_warm()
    assert calls[-1] == ("trim", 0)


def test_preparing_a_large_geometry_hands_the_heaps_free_pages_back_and_a_small_one_keeps_them(monkeypatch):
    """render.prepare hands the heap's free pages back (malloc_trim, hand_back_free) once it has built a geometry of
    HAND_BACK_TRIANGLES copied triangles or more, and touches nothing below that (a small scene keeps the warm heap);
    the allocator's thresholds are left as they are either way."""
    from conftest import ortho_down
    from core import render
    from core.geometry import primitives
    from core.scene import RenderSettings, Scene
    scene = Scene(camera=ortho_down(height=3.0))
    scene.add_material((0.5, 0.5, 0.5))
    scene.add_mesh(primitives.box((1.0, 1.0, 1.0)), materials=[0])
    calls = fake_libc(monkeypatch)
    render.prepare(scene, RenderSettings(width=4, height=4, samples=1))
    assert calls == []
    monkeypatch.setattr(render, "HAND_BACK_TRIANGLES", 13)                      # one more than the box's triangles
    render.prepare(scene, RenderSettings(width=4, height=4, samples=1))
    assert calls == []
    monkeypatch.setattr(render, "HAND_BACK_TRIANGLES", 12)
    render.prepare(scene, RenderSettings(width=4, height=4, samples=1))
    assert calls == [("trim", 0)]
