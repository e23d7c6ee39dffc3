"""Light groups (View Layer > Light Groups) inside real Blender (the bpy module), against Cycles' own
Combined_<name> passes on the same scenes: names, channels and values. No mocks.

Both renderers split one render's light by the source each contribution comes from (Primer:
core/integrators/lightgroups.py). Their samples differ, so the passes are compared converged enough, with the
project's error (relative MSE of 4x4-pixel block means).
"""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy") if os.environ.get("PRIMER_ALLOW_NO_BPY") else __import__("bpy")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from render import configure_cycles_reference, load_primer  # noqa: E402

from test_blender_denoise import render_image  # noqa: E402
from core.film.compare import relative_mse_of_blocks  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.slow]

# scene -> ({object or "World": group}, Primer's samples, Cycles' samples)
SETUPS = {
    "materials_principled": ({"Softbox": "key", "Point": "fill", "World": "fill"}, 256, 512),
    "light_emissive": ({"Ceiling Lamp": "lamp"}, 256, 512),
    "world_light": ({"Sun": "sun", "World": "sky"}, 256, 512),
}


@pytest.fixture(scope="module")
def primer():
    """Primer registered from this checkout, as tools/render.py does."""
    return load_primer()


def render_both(name: str, folder) -> dict:
    """engine -> passes of sample scene `name` with its light groups set up (and an empty group "none")."""
    groups, primer_samples, cycles_samples = SETUPS[name]
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_scenes", name + ".blend"))
    scene = bpy.context.scene
    layer = scene.view_layers[0]
    for group in sorted(set(groups.values())) + ["none"]:
        layer.lightgroups.add(name=group)
    for source, group in groups.items():
        (scene.world if source == "World" else scene.objects[source]).lightgroup = group
    scene.render.resolution_percentage = 50
    scene.primer.use_adaptive_sampling = False
    out = {}
    for engine, samples in (("PRIMER", primer_samples), ("CYCLES", cycles_samples)):
        scene.render.engine = engine
        scene.primer.samples = samples
        if engine == "CYCLES":
            configure_cycles_reference(scene, samples)
        out[engine] = render_image(scene, str(folder / f"{name}_{engine}.exr"), multilayer=True, reference=name)
    return out


@pytest.fixture(scope="module")
def renders(primer, tmp_path_factory):
    folder = tmp_path_factory.mktemp("lightgroups")
    return {name: render_both(name, folder) for name in SETUPS}


@pytest.mark.parametrize("scene", SETUPS)
def test_each_light_group_pass_is_cycles_and_the_groups_add_up_to_combined(renders, scene, primer):
    mine, cycles = renders[scene]["PRIMER"], renders[scene]["CYCLES"]
    groups = sorted(set(SETUPS[scene][0].values()))
    # The noise of these sample counts: Primer's Combined against Cycles' (the passes may differ as much).
    baseline = relative_mse_of_blocks(mine["Combined"][1][..., :3], cycles["Combined"][1][..., :3])
    total = np.zeros_like(mine["Combined"][1][..., :3])
    for group in groups + ["none"]:
        name = f"Combined_{group}"
        assert name in mine and name in cycles, name
        assert mine[name][0] == cycles[name][0] == ["R", "G", "B"]
        total += mine[name][1]
        if group == "none":
            assert not mine[name][1].any() and not cycles[name][1].any()
            continue
        assert cycles[name][1].mean() > 1e-3, name                # the group lights something
        error = relative_mse_of_blocks(mine[name][1], cycles[name][1])
        print(scene, group, f"{error:.2e} (Combined {baseline:.2e})", mine[name][1].mean() / cycles[name][1].mean())
        assert error < max(3.0 * baseline, 2e-4), (group, error, baseline)
        assert mine[name][1].mean() == pytest.approx(cycles[name][1].mean(), rel=0.02)
    # Every source is in a group here: the groups' passes add up to Combined (within the renders' noise).
    assert relative_mse_of_blocks(total, mine["Combined"][1][..., :3]) < max(3.0 * baseline, 2e-4)
    # The empty group is reported (the last Primer render: every scene has one).
    engine = sys.modules[f"{primer.__name__}.addon.engine"]
    assert any("light group 'none' has no light" in warning for warning in engine.last_render.warnings)
