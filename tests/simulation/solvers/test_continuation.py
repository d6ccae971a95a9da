"""When a load step continues the previous one (the predictor's extrapolation, both loops).

A quasi-static forward load step adds half the previous step's Newton correction to its slid
start only when it continues that step (``ringqa.simulation.solvers.predictor
.continuation_scale``): it starts where that one ended and is as long. The step is
``du = min(target - u, inc)`` with ``u`` accumulated by ``u + du``, so ``target - u`` falls
round-off short of ``inc`` (~1e-18 m) at many steps into a waypoint one increment away. Until
2026-11-29 "as long" was exact float equality and such a step lost the extrapolation (and with
it the answer depended on round-off); now it is equality to ``EXTRAPOLATE_RTOL`` = 1e-9
relative. The Python loop (``Model.predict``) and the compiled loop (``march``) share the rule
and must agree bit for bit.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import ringqa.simulation.model as model_mod
from ringqa.simulation.scenefile import load_scene
from ringqa.simulation.solvers import driver
from ringqa.simulation.solvers.predictor import continuation_scale

SCENES = Path(__file__).resolve().parents[3] / "data" / "scenes"
RTOL, SCALE_MAX = model_mod.EXTRAPOLATE_RTOL, model_mod.EXTRAPOLATE_SCALE_MAX
INC = 1e-3


def _round_off_short_step():
    """Nine 1 mm steps from 0 accumulate to u = 0.009000000000000001 m; the next waypoint is
    10 mm (0.01 m), so the step into it is ``0.01 - u`` = 0.0009999999999999992 m, 8.7e-19 m
    (4 ulp) short of the increment, though it is the same step as the nine before it."""
    u = 0.0
    for _ in range(9):
        u = u + INC
    du = min(10 * INC - u, INC)
    return u, du


def test_a_step_round_off_short_of_the_increment_continues_the_previous_one():
    """The step above continues the 1 mm step before it (factor 1) under the shipped rule, in the
    compiled kernel and in the Python function both loops call; the exact equality of before
    (rtol 0) refused it. A step that is really shorter (half the increment), one that does not
    start where the last prediction ended (1 um off) and one after a hard step (NaN) do not
    continue; with ``scale_max`` 1 the half step gets 0.5 and a longer step (2x) still 0."""
    u, du = _round_off_short_step()
    assert du != INC and abs(du - INC) < 1e-17  # really round-off short
    for rule in (continuation_scale, continuation_scale.py_func):
        assert rule(du, u + du, INC, u, RTOL, SCALE_MAX) == 1.0
        assert rule(du, u + du, INC, u, 0.0, SCALE_MAX) == 0.0  # the rule before 2026-11-29
        assert rule(INC, u + INC, INC, u, RTOL, SCALE_MAX) == 1.0
        assert rule(0.5 * INC, u + 0.5 * INC, INC, u, RTOL, SCALE_MAX) == 0.0
        assert rule(du, u + du + 1e-6, INC, u, RTOL, SCALE_MAX) == 0.0
        assert rule(du, u + du, INC, math.nan, RTOL, SCALE_MAX) == 0.0
        assert rule(0.5 * INC, u + 0.5 * INC, INC, u, RTOL, 1.0) == 0.5
        assert rule(2 * INC, u + 2 * INC, INC, u, RTOL, 1.0) == 0.0


def _traced_run(scene, monkeypatch):
    """The Python loop's run with every forward predicted step recorded before the predictor:
    (du, the previous du, it starts where the last prediction ended, extrapolated)."""
    seen = []
    predict = model_mod.Model.predict

    def traced(self, q, du, u_new, slide):
        forward = slide and du > 0.0 and self.extrapolate
        before = (du, self._pred_du, abs(self._pred_u + du - u_new) <= 1e-9 * abs(du))
        predict(self, q, du, u_new, slide)
        if forward:
            seen.append((*before, self._extrapolated))

    monkeypatch.setattr(model_mod.Model, "predict", traced)
    monkeypatch.setattr(driver, "USE_MARCH", False)
    res = driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float))
    monkeypatch.undo()
    return res, seen


def _loop(scene, monkeypatch, march, rtol=RTOL, scale_max=SCALE_MAX):
    monkeypatch.setattr(model_mod, "EXTRAPOLATE_RTOL", rtol)
    monkeypatch.setattr(model_mod, "EXTRAPOLATE_SCALE_MAX", scale_max)
    monkeypatch.setattr(driver, "USE_MARCH", march)
    res = driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float))
    monkeypatch.undo()
    return res


def _same(ref, got):
    for k in ("source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "contact_force_n",
              "newton_iters", "nodes_m"):  # fmt: skip
        np.testing.assert_array_equal(getattr(got, k), getattr(ref, k), err_msg=k)
    assert got.stats == ref.stats
    assert got.work == ref.work


def test_round_off_short_steps_keep_their_extrapolation_in_both_loops(monkeypatch):
    """ring13-push100 (Flexitron in a 13 mm ring, Stribeck friction, dwells 1 mm apart): every
    forward step that starts where the last ended after an easy step and is as long as it to
    1e-9 is extrapolated, at least one of them round-off short (measured: 10 of its 69
    steps, 1e-19-1e-17 m short; before the fix none of the 10 was). Those steps then take 4.30
    instead of 5.40 iterations (318 -> 307 in all): fewer iterations, and the dwells move by
    at most what Newton's residual test admits, ~1e-7 m (docs/engine.md, "Fewer Newton
    iterations": the test admits ~1e-7 m of correction; measured 6e-12 m). The compiled loop
    gives the Python loop's outputs bit for bit, with the shorter steps scaled too
    (``EXTRAPOLATE_SCALE_MAX`` = 1, not shipped: 307 -> 305 iterations here)."""
    scene = load_scene(SCENES / "ring13-push100.toml")
    ref, seen = _traced_run(scene, monkeypatch)
    cont = [s for s in seen if s[2] and abs(s[0] - s[1]) <= 1e-9 * s[0]]
    short = [s for s in cont if s[0] != s[1]]
    assert len(short) >= 1
    assert all(s[3] for s in cont)
    old = _loop(scene, monkeypatch, True, rtol=0.0)
    assert ref.stats.n_newton_iters < old.stats.n_newton_iters
    assert ref.stats.n_stabilised_steps == old.stats.n_stabilised_steps == 0
    assert np.max(np.abs(ref.source_pos_m - old.source_pos_m)) < 1e-7
    assert np.max(np.abs(ref.tip_pos_m - old.tip_pos_m)) < 1e-7
    _same(ref, _loop(scene, monkeypatch, True))
    scaled = _loop(scene, monkeypatch, False, scale_max=1.0)
    assert scaled.stats.n_newton_iters != ref.stats.n_newton_iters  # the switch reaches it
    _same(scaled, _loop(scene, monkeypatch, True, scale_max=1.0))
