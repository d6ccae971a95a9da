"""Every shipped scene runs on the engine: success, a finite dwell row per advance, and the
contract dwell table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ringqa.accuracy import scaled_overrides
from ringqa.simulation import simulate
from ringqa.simulation.output import dwell_table
from ringqa.simulation.scenefile import load_scene, scene_with_overrides

#: the issue-4 contract, written out here so that a change to the code's list cannot pass
CONTRACT_COLUMNS = ("advance_mm", "x_mm", "y_mm", "z_mm", "dir_x", "dir_y", "dir_z", "push_force_n",
                    "s_mm", "offset_mm")  # fmt: skip

SCENES = sorted((Path(__file__).resolve().parents[2] / "data" / "scenes").glob("*.toml"))


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_shipped_scene_runs(path):
    scene = load_scene(path)
    res = simulate(scene)
    assert res.status == 0, res.message
    n = len(scene.motion.advances_m)
    table = dwell_table(res)
    assert len(table) == n
    assert list(table.columns[: len(CONTRACT_COLUMNS)]) == list(CONTRACT_COLUMNS)
    assert np.all(np.isfinite(table[list(CONTRACT_COLUMNS)].to_numpy()))


@pytest.mark.slow
def test_ring26_the_papers_u_lumen_is_the_circle_for_the_cable():
    """The default commissioning scene with the applicator's lumen (the paper's U: flat side at
    the 1.5 mm circle) replaced by the circular 3 mm lumen (r_a 1.4 mm): success, the source sits
    at most 1.5 - 0.425 = 1.075 mm (+10 % of the clearance for the contact penetration) off the
    centreline, and the two lumens give the same run (a flat at the circle does not cut it; the
    U's break at the stem tapers equal radii: round-off only); a flat that cuts the circle
    (1.2 mm, the earlier assumption) moves the source."""
    scene = load_scene(
        "ring26-flexitron",
        {"channel.lumen": "circular", "channel.r_b_mm": 1.5, "channel.r_a_mm": 1.4},
    )
    res = simulate(scene)
    assert res.status == 0, res.message
    assert np.max(res.offset_m) * 1e3 <= 1.075 + 0.1075
    u = simulate(load_scene("ring26-flexitron"))
    assert u.status == 0
    assert np.max(np.abs(u.offset_m - res.offset_m)) * 1e3 < 1e-9
    cut = simulate(load_scene("ring26-flexitron", {"channel.lumen": "u", "channel.r_b_mm": 1.5,
                                                   "channel.flat_mm": 1.2,
                                                   "channel.u_start_mm": 60.0}))  # fmt: skip
    assert cut.status == 0
    assert np.max(np.abs(cut.offset_m - res.offset_m)) * 1e3 > 0.01


def _refined(scene, f: float):
    """``scene`` with every element length and the increment times ``f``."""
    return scene_with_overrides(scene, scaled_overrides(scene, f, f))


def _max_median_mm(a, b) -> tuple[float, float]:
    d = np.linalg.norm(a.source_pos_m - b.source_pos_m, axis=1) * 1e3
    return float(np.max(d)), float(np.median(d))


@pytest.mark.slow
def test_performance_scene_meets_the_accuracy_target():
    """Issue 4 must-show 4, the accuracy half (the time half is benchmarks/bench_engine.py, not a
    timed test): ring13-push100 as shipped (2 mm thin links, 1 mm increments) against the same
    scene with element lengths and increment / 4. Target: max source-centre distance over the 61
    dwells <= 0.05 mm (measured 0.027 mm). The median is the element error, O(l^2): 3 mm links
    give a median of 0.034 mm, so 2 mm links about (2/3)^2 x 0.034 = 0.015 mm; asserted <= 0.025
    mm. The reference must itself be converged for the criterion to mean anything: the 8x run
    agrees with the 4x run to a fifth of the target (<= 0.01 mm; measured 0.0046 mm)."""
    scene = load_scene("ring13-push100")
    shipped, x4, x8 = (simulate(_refined(scene, f)) for f in (1.0, 0.25, 0.125))
    assert shipped.status == 0 and x4.status == 0 and x8.status == 0
    err_max, err_median = _max_median_mm(shipped, x4)
    assert err_max <= 0.05
    assert err_median <= 0.025
    assert _max_median_mm(x4, x8)[0] <= 0.01
