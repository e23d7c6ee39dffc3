"""tools/node_table.py, the per-node comparison of Primer against Cycles (docs/nodes.md): its measure's closed form,
and a quick run over three nodes in Blender (one Primer evaluates, one it warns it does not)."""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from blender_env import ROOT, isolated_env

sys.path.insert(0, os.path.join(ROOT, "tools"))
import node_table  # noqa: E402


def test_identical_images_measure_zero_and_ratio_one():
    """B(P) = B(C): every block's squared difference is 0, and mean(P) / mean(C) = 1."""
    image = np.random.default_rng(3).random((16, 16, 3))
    assert node_table.block_measure(image, image) == (0.0, 1.0)


def test_a_constant_offset_measures_the_formulas_value():
    """C = c everywhere, P = c + d: each block gives d^2 / (c^2 + 0.01), and the ratio is (c + d) / c."""
    c, d = 0.3, 0.02
    cycles = np.full((16, 16, 3), c)
    relmse, ratio = node_table.block_measure(cycles + d, cycles)
    assert relmse == pytest.approx(d * d / (c * c + 0.01), rel=1e-12)
    assert ratio == pytest.approx((c + d) / c, rel=1e-12)


def test_block_means_average_each_four_by_four_square():
    """An image whose 4 x 4 blocks hold 0..15 each (a ramp inside) has every block mean 7.5."""
    ramp = np.arange(16, dtype=np.float64).reshape(4, 4)
    image = np.tile(ramp, (2, 3))[..., None]
    np.testing.assert_array_equal(node_table.block_means(image), np.full((2, 3, 1), 7.5))


def test_status_thresholds_and_warnings():
    """exact <= 1e-6 < close <= 1.5e-4 < differs; a warning makes it not evaluated, whatever the measure."""
    assert node_table.status_of(1e-6, []) == "exact"
    assert node_table.status_of(1.5e-4, []) == "close"
    assert node_table.status_of(2e-4, []) == "differs"
    assert node_table.status_of(0.0, ["operation X is not supported"]) == "not evaluated"


@pytest.mark.blender
@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs bpy (Blender as a Python module)")
def test_tool_reports_evaluated_nodes_by_measure_and_unevaluated_ones_by_warning(tmp_path):
    """RGB to BW and Math's Multiply render Cycles' values (exact); Math's Truncate, which Primer does not evaluate,
    is listed as not evaluated with Primer's warning, never as matching."""
    out, rows = tmp_path / "nodes.md", tmp_path / "rows.json"
    completed = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "node_table.py"), "--only", "RGBToBW",
                                "Math", "--modes", "default", "MULTIPLY", "TRUNC", "--out", str(out),
                                "--json", str(rows)],
                               cwd=str(tmp_path), env=isolated_env(str(tmp_path)), capture_output=True, text=True,
                               timeout=120)
    assert completed.returncode == 0, completed.stdout[-3000:] + completed.stderr[-3000:]
    table = {(r["node"], r["mode"]): r for r in json.loads(rows.read_text())["rows"]}
    assert table[("RGB to BW", "default")]["status"] == "exact"
    assert table[("Math", "MULTIPLY")]["status"] == "exact"
    truncate = table[("Math", "TRUNC")]
    if truncate["warnings"]:                        # Primer does not evaluate Truncate (yet)
        assert truncate["status"] == "not evaluated"
        assert any("TRUNC" in w for w in truncate["warnings"])
        assert "not evaluated: operation TRUNC" in out.read_text()
    else:
        assert truncate["status"] == "exact"
