"""The compiled load-step loop (ringqa.simulation.solvers.march) against the Python loop.

The compiled loop only moves the quasi-static run's per-step Python into one kernel: every
output must be the Python loop's bit for bit (no tolerance), also where it hands a step back
to the stepper (a step Newton does not solve at once: cut or stabilised), on a jam, and when
it pauses for a time budget.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from ringqa.simulation.scenefile import load_scene, scene_with_overrides
from ringqa.simulation.solvers import driver

SCENES = Path(__file__).resolve().parents[3] / "data" / "scenes"


def _both(scene, monkeypatch, **kw):
    monkeypatch.setattr(driver, "USE_MARCH", False)
    ref = driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float), **kw)
    monkeypatch.setattr(driver, "USE_MARCH", True)
    got = driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float), **kw)
    return ref, got


def _same(ref, got):
    for k in ("source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "contact_force_n",
              "newton_iters", "s_m", "offset_m", "nodes_m"):  # fmt: skip
        np.testing.assert_array_equal(getattr(got, k), getattr(ref, k), err_msg=k)
    assert got.status == ref.status
    assert got.message == ref.message
    assert got.work == ref.work
    assert got.stats == ref.stats
    assert got.warnings == ref.warnings
    assert got.max_penetration_m == ref.max_penetration_m


def test_marchable_only_for_quasistatic_runs_it_reproduces():
    """Dynamic runs, the always-on tether and a kept trajectory stay in the Python loop."""
    from ringqa.simulation.model import Model
    from ringqa.simulation.solvers.integrators import integrator_for

    base = load_scene(SCENES / "ring13-push100.toml")
    adv = np.asarray(base.motion.advances_m, dtype=float)
    cases = {
        "shipped": (base, True),
        "dynamic": (scene_with_overrides(base, {"solver.kind": "dynamic"}), False),
        "stabilisation": (scene_with_overrides(base, {"solver.stabilisation": 1e-3}), False),
        "trajectory": (scene_with_overrides(base, {"outputs.trajectory": True}), False),
    }
    for name, (scene, expected) in cases.items():
        model = Model(scene, adv)
        assert driver.marchable(model, scene, integrator_for(model), False) is expected, name
    model = Model(base, adv)
    assert driver.marchable(model, base, integrator_for(model), True) is False  # progress bar


@pytest.mark.slow
def test_compiled_loop_equals_python_loop(monkeypatch):
    """ring13-push100 (friction, 1 mm steps grown on the straight approach) and the same pushed
    back in 5 mm steps (7 steps the first attempt does not solve: handed to the stepper, the
    fallback stabilisation): identical outputs, counters and work."""
    base = load_scene(SCENES / "ring13-push100.toml")
    back = scene_with_overrides(
        base, {"motion.kind": "stepwise", "motion.backward": True, "motion.step_mm": 5.0,
               "motion.span_mm": 40.0},
    )  # fmt: skip
    for scene in (base, back):
        ref, got = _both(scene, monkeypatch)
        _same(ref, got)
    assert ref.stats.n_stabilised_steps > 0  # the hand-back path was taken


def test_compiled_loop_jam_equals_python_loop(monkeypatch):
    """A push-force limit the cable reaches: the same jam, message and rows reached."""
    base = load_scene(SCENES / "ring13-push100.toml")
    scene = scene_with_overrides(base, {"solver.jam_force_n": 0.3})
    ref, got = _both(scene, monkeypatch)
    assert ref.status == 1 and "push force" in ref.message
    _same(ref, got)


def test_compiled_loop_stops_at_its_budget(monkeypatch):
    """A deadline already past: the run stops after its first few steps with the budget
    message, as the Python loop does after its first step."""
    scene = load_scene(SCENES / "ring13-push100.toml")
    adv = np.asarray(scene.motion.advances_m, dtype=float)
    monkeypatch.setattr(driver, "USE_MARCH", True)
    res = driver.run(scene, adv, deadline=time.perf_counter() - 1.0)
    assert res.status == -1
    assert res.settings.get("budget_exceeded") is True
    assert "time budget" in res.message
    assert res.stats.n_steps <= 8
