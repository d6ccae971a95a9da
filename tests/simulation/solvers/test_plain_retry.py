"""The plain-slide retry's iteration budget (ringqa.simulation.model.plain_retry_iters).

When Newton fails from the extrapolated predictor, the step is tried once more from the plain
slide before the stepper's fallback stabilisation. The retry's budget can be cut
(``PLAIN_RETRY_MAX_ITERS`` after a stall, ``PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS`` after the
iteration limit or no progress): over 64 traced runs the rescues after a stall took 6-16
iterations while most retries repeated the failed crawl, and a budget of 20 after a stall saved
~1 % of the README job's engine CPU. Both are ``None`` (``max_iter``): the retry is the solve the
plain slide would have had, so whether a step was extrapolated (which the continuation rule
decides: test_continuation.py) cannot turn a step Newton solves into a stabilised one; with
20, a 25-iteration rescue on tests/simulation/test_convergence.py's friction scene was lost once
a round-off-short step kept its extrapolation. These tests check the wiring of a budget in both
loops (the Python loop's ``Model.solve`` and the compiled
:func:`~ringqa.simulation.solvers.march.march`), what a budget of 20 keeps and loses on
ring-u-lumen-stepwise, and that the shipped budget keeps the 25-iteration rescue.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import ringqa.simulation.model as model_mod
from ringqa.simulation.model import Model
from ringqa.simulation.scenefile import load_scene, scene_with_overrides
from ringqa.simulation.solvers import driver

SCENES = Path(__file__).resolve().parents[3] / "data" / "scenes"
#: the shipped budgets (read before any test patches them)
BUDGET = (model_mod.PLAIN_RETRY_MAX_ITERS, model_mod.PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS)
#: the budget measured and shipped before (20 after a stall; max_iter after a crawl)
STALL_20 = (20, None)


def _run(scene, monkeypatch, budget, march=True):
    monkeypatch.setattr(model_mod, "PLAIN_RETRY_MAX_ITERS", budget[0])
    monkeypatch.setattr(model_mod, "PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS", budget[1])
    monkeypatch.setattr(driver, "USE_MARCH", march)
    return driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float))


def test_retry_gets_the_budget_never_more_than_max_iter(monkeypatch):
    """``Model.solve`` with an extrapolated start that fails: with ``PLAIN_RETRY_MAX_ITERS`` 20
    the plain retry is called with ``min(solver.max_iter, 20)`` iterations after a stall
    (status 4): 20 for max_iter 50, 12 for 12, 8 for 8 (the scene's limit stays the upper
    bound); after the iteration limit (1) or no progress (5) with max_iter (50; 8 for 8), or
    with ``min(max_iter, 12)`` when ``PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS`` is 12. With the
    shipped ``None`` every retry gets max_iter (50, 12). A start that is not extrapolated gets
    no retry; the iterations of both calls are added."""
    base = load_scene(SCENES / "ring13-push100.toml")
    assert BUDGET == (None, None)
    cases = ((50, 4, 20, 20, None), (12, 4, 12, 20, None), (8, 4, 8, 20, None),
             (50, 1, 50, 20, None), (50, 5, 50, 20, None), (8, 1, 8, 20, None),
             (50, 1, 12, 20, 12), (50, 5, 12, 20, 12), (8, 5, 8, 20, 12), (50, 4, 20, 20, 12),
             (50, 4, 50, None, None), (12, 4, 12, None, None), (50, 1, 50, None, None),
             (50, 4, 50, None, 12))  # fmt: skip
    for max_iter, first, expected, stalled, crawled in cases:
        monkeypatch.setattr(model_mod, "PLAIN_RETRY_MAX_ITERS", stalled)
        monkeypatch.setattr(model_mod, "PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS", crawled)
        scene = scene_with_overrides(base, {"solver.max_iter": max_iter})
        model = Model(scene, np.asarray(scene.motion.advances_m, dtype=float))
        seen = []

        def fake(*args, seen=seen, first=first):
            seen.append(args[6])  # max_iter
            return (first if len(seen) == 1 else 4, args[6], 1.0)

        model._newton_call = fake
        q = model.initial_state(0.0)
        st = model.step(q.copy(), np.zeros_like(q), 1.0)
        model._extrapolated = True
        status, iters, _ = model.solve(model.effects, q, st)
        assert seen == [max_iter, expected], (max_iter, first)
        assert (status, iters) == (4, max_iter + expected)
        seen.clear()
        model._extrapolated = False
        model.solve(model.effects, q, st)
        assert seen == [max_iter]


def test_rescue_kept_failing_retries_shortened(monkeypatch):
    """ring-u-lumen-stepwise: 6 extrapolated starts fail, 3 with no progress (after 21, 21, 41
    iterations) and 3 stalled (11, 7, 11); their plain retries took 21, 8, 32 and 11, 25 and 14,
    the last one rescuing its step after the stall (traced, 2026-11-29). With a budget of 20
    after a stall (max_iter after no progress) against none (50 = max_iter): the
    same 5 stabilised steps and failed attempts, the source and tip within 1e-12 m (round-off at
    most: the contact's far-sample cache is left where the shortened retry stopped), and the
    25-iteration retry after a stall cut to 20: 596 -> 591 iterations. With 12 after a stall
    (below the rescue's 14) the rescue is lost and the run takes more stabilised steps, which
    shows the run does exercise a rescue a budget of 20 keeps."""
    scene = load_scene(SCENES / "ring-u-lumen-stepwise.toml")
    old = _run(scene, monkeypatch, (50, 50))
    new = _run(scene, monkeypatch, STALL_20)
    assert old.status == new.status == 0
    assert new.stats.n_stabilised_steps == old.stats.n_stabilised_steps == 5
    assert new.stats.n_failed_attempts == old.stats.n_failed_attempts
    for k in ("source_pos_m", "tip_pos_m"):
        assert np.max(np.abs(getattr(new, k) - getattr(old, k))) <= 1e-12, k
    assert old.stats.n_newton_iters - new.stats.n_newton_iters == 5
    short = _run(scene, monkeypatch, (12, None))
    assert short.stats.n_stabilised_steps > old.stats.n_stabilised_steps


def test_budget_same_in_compiled_and_python_loop(monkeypatch):
    """The retry, shortened (20 after a stall) and shipped (max_iter), in the compiled loop
    equals the Python loop's bit for bit (outputs, counters, work) on ring-u-lumen-stepwise,
    whose run takes the retry path."""
    scene = load_scene(SCENES / "ring-u-lumen-stepwise.toml")
    for budget in (STALL_20, BUDGET):
        ref = _run(scene, monkeypatch, budget, march=False)
        got = _run(scene, monkeypatch, budget, march=True)
        for k in ("source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "contact_force_n",
                  "newton_iters", "s_m", "offset_m", "nodes_m"):  # fmt: skip
            np.testing.assert_array_equal(getattr(got, k), getattr(ref, k), err_msg=k)
        assert got.stats == ref.stats
        assert got.work == ref.work
        assert got.stats.n_stabilised_steps > 0


def test_shipped_budget_keeps_the_rescue_an_extrapolated_step_needs(monkeypatch):
    """tests/simulation/test_convergence.py's friction scene (Flexitron pushed into the analytic
    13 mm ring, Stribeck) at a 1 mm increment, dwells every 5 mm from 60 mm: the step to 75 mm
    is round-off short of 1 mm. Under the exact-equality rule it was not extrapolated and Newton
    solved it from the plain slide in 25 iterations (a snap-through); now it continues the
    step before, its extrapolated start stalls after 18 iterations and the plain retry needs
    the same 25 (traced, 2026-11-29). The shipped budget (max_iter) keeps that rescue: the
    same 5 stabilised steps as the old rule's run and the dwells within what Newton's residual
    test admits, ~1e-7 m (measured 7.3e-13 m). A budget of 20 loses it: the step and the next
    are stabilised (7) and the 75 mm dwell lands on another branch (measured 0.11 mm away, more
    than 0.05 mm asserted; 0.070 mm is the run's whole error against a 0.0625 mm increment)."""
    from ringqa.simulation.scene import Effects, SolverSettings
    from tests.simulation.builders import flexitron, ring_channel
    from tests.simulation.builders import scene as make_scene

    scene = make_scene(ring_channel(), flexitron(), effects=Effects(friction="stribeck"),
                       solver=SolverSettings(increment_m=1e-3))  # fmt: skip
    adv = np.arange(60.0, 101.0, 5.0) * 1e-3

    def run(budget, rtol):
        monkeypatch.setattr(model_mod, "EXTRAPOLATE_RTOL", rtol)
        monkeypatch.setattr(model_mod, "PLAIN_RETRY_MAX_ITERS", budget[0])
        monkeypatch.setattr(model_mod, "PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS", budget[1])
        res = driver.run(scene, adv)
        monkeypatch.undo()
        assert res.status == 0
        return res

    old = run(STALL_20, 0.0)  # main before 2026-11-29's continuation rule
    new = run(BUDGET, model_mod.EXTRAPOLATE_RTOL)
    cut = run(STALL_20, model_mod.EXTRAPOLATE_RTOL)
    assert new.stats.n_stabilised_steps == old.stats.n_stabilised_steps == 5
    assert np.max(np.linalg.norm(new.source_pos_m - old.source_pos_m, axis=1)) < 1e-7
    assert np.max(np.linalg.norm(new.tip_pos_m - old.tip_pos_m, axis=1)) < 1e-7
    assert cut.stats.n_stabilised_steps > old.stats.n_stabilised_steps
    assert np.max(np.linalg.norm(cut.source_pos_m - old.source_pos_m, axis=1)) > 5e-5
