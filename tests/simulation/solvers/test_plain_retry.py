"""The plain-slide retry's iteration budget (ringqa.simulation.model.PLAIN_RETRY_MAX_ITERS).

When Newton fails from the extrapolated predictor, the step is tried once more from the plain
slide before the stepper's fallback stabilisation. A retry that rescues its step converges like
an ordinary step (8-16 iterations measured over 47 runs); most retries instead repeat the failed
crawl up to ``solver.max_iter``. The retry therefore gets ``min(max_iter, PLAIN_RETRY_MAX_ITERS)``
iterations. These tests check the wiring in both loops (the Python loop's ``Model.solve`` and the
compiled :func:`~ringqa.simulation.solvers.march.march`) and, on the shipped scene whose run has
both kinds of retry, that the rescue is kept and only failing retries are shortened.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import ringqa.simulation.model as model_mod
from ringqa.simulation.model import Model
from ringqa.simulation.scenefile import load_scene, scene_with_overrides
from ringqa.simulation.solvers import driver

SCENES = Path(__file__).resolve().parents[3] / "data" / "scenes"
#: the shipped budget (read before any test patches it)
BUDGET = model_mod.PLAIN_RETRY_MAX_ITERS


def _run(scene, monkeypatch, budget, march=True):
    monkeypatch.setattr(model_mod, "PLAIN_RETRY_MAX_ITERS", budget)
    monkeypatch.setattr(driver, "USE_MARCH", march)
    return driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float))


def test_retry_gets_the_budget_never_more_than_max_iter():
    """``Model.solve`` with an extrapolated start that fails: the plain retry is called with
    ``min(solver.max_iter, PLAIN_RETRY_MAX_ITERS)`` = min(50, 20) = 20, and with
    ``solver.max_iter = 12`` with 12 (the scene's limit stays the upper bound); a start that is
    not extrapolated gets no retry; the iterations of both calls are added."""
    base = load_scene(SCENES / "ring13-push100.toml")
    for max_iter, expected in ((50, 20), (12, 12)):
        scene = scene_with_overrides(base, {"solver.max_iter": max_iter})
        model = Model(scene, np.asarray(scene.motion.advances_m, dtype=float))
        seen = []

        def fake(*args, seen=seen):
            seen.append(args[6])  # max_iter
            return (1, args[6], 1.0)

        model._newton_call = fake
        q = model.initial_state(0.0)
        st = model.step(q.copy(), np.zeros_like(q), 1.0)
        model._extrapolated = True
        status, iters, _ = model.solve(model.effects, q, st)
        assert seen == [max_iter, expected]
        assert (status, iters) == (1, max_iter + expected)
        seen.clear()
        model._extrapolated = False
        model.solve(model.effects, q, st)
        assert seen == [max_iter]


def test_rescue_kept_failing_retries_shortened(monkeypatch):
    """ring-u-lumen-stepwise: 11 first attempts fail (5 no progress, 6 stalled); one plain retry
    rescues its step in 14 iterations, the others fail after 8, 11, 21, 25 and 32 (traced,
    2026-11-29). With the budget 20 against no budget (50 = max_iter): the same 5 stabilised
    steps and failed attempts, the source and tip within 1e-12 m (round-off at most: the
    contact's far-sample cache is left where the shortened retry stopped), and the three long
    retries cut to 20: 1 + 5 + 12 = 18 iterations fewer (596 -> 578). With a budget of 12 (below
    the rescue's 14) the rescue is lost and the run takes more stabilised steps, which shows the
    run does exercise a rescue the default budget keeps."""
    scene = load_scene(SCENES / "ring-u-lumen-stepwise.toml")
    old = _run(scene, monkeypatch, 50)
    new = _run(scene, monkeypatch, BUDGET)
    assert old.status == new.status == 0
    assert new.stats.n_stabilised_steps == old.stats.n_stabilised_steps == 5
    assert new.stats.n_failed_attempts == old.stats.n_failed_attempts
    for k in ("source_pos_m", "tip_pos_m"):
        assert np.max(np.abs(getattr(new, k) - getattr(old, k))) <= 1e-12, k
    assert BUDGET == 20
    assert old.stats.n_newton_iters - new.stats.n_newton_iters == 18
    short = _run(scene, monkeypatch, 12)
    assert short.stats.n_stabilised_steps > old.stats.n_stabilised_steps


def test_budget_same_in_compiled_and_python_loop(monkeypatch):
    """The shortened retry in the compiled loop equals the Python loop's bit for bit (outputs,
    counters, work) on ring-u-lumen-stepwise, whose run takes the retry path."""
    scene = load_scene(SCENES / "ring-u-lumen-stepwise.toml")
    ref = _run(scene, monkeypatch, BUDGET, march=False)
    got = _run(scene, monkeypatch, BUDGET, march=True)
    for k in ("source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "contact_force_n",
              "newton_iters", "s_m", "offset_m", "nodes_m"):  # fmt: skip
        np.testing.assert_array_equal(getattr(got, k), getattr(ref, k), err_msg=k)
    assert got.stats == ref.stats
    assert got.work == ref.work
    assert got.stats.n_stabilised_steps > 0
