"""The plain-slide retry's iteration budget (ringqa.simulation.model.plain_retry_iters).

When Newton fails from the extrapolated predictor, the step is tried once more from the plain
slide before the stepper's fallback stabilisation. After a stalled start a retry that rescues
its step converges like an ordinary step (6-16 iterations over 64 traced runs), while most
retries repeat the failed crawl: the retry then gets ``min(max_iter, PLAIN_RETRY_MAX_ITERS)`` =
20 iterations. After the iteration limit or no progress rescues took up to 45 iterations, so
that retry keeps ``max_iter`` (``PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS = None``). These tests check
the wiring in both loops (the Python loop's ``Model.solve`` and the compiled
:func:`~ringqa.simulation.solvers.march.march`) and, on the shipped scene whose run has both
kinds of retry, that the rescue is kept and only failing retries are shortened.
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


def _run(scene, monkeypatch, budget, march=True):
    monkeypatch.setattr(model_mod, "PLAIN_RETRY_MAX_ITERS", budget[0])
    monkeypatch.setattr(model_mod, "PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS", budget[1])
    monkeypatch.setattr(driver, "USE_MARCH", march)
    return driver.run(scene, np.asarray(scene.motion.advances_m, dtype=float))


def test_retry_gets_the_budget_never_more_than_max_iter(monkeypatch):
    """``Model.solve`` with an extrapolated start that fails: the plain retry is called with
    ``min(solver.max_iter, 20)`` iterations after a stall (status 4): 20 for max_iter 50, 12
    for 12, 8 for 8 (the scene's limit stays the upper bound); after the iteration limit (1) or
    no progress (5) with max_iter (50; 8 for 8), or with ``min(max_iter, 12)`` when
    ``PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS`` is 12. A start that is not extrapolated gets no retry;
    the iterations of both calls are added."""
    base = load_scene(SCENES / "ring13-push100.toml")
    cases = ((50, 4, 20, None), (12, 4, 12, None), (8, 4, 8, None), (50, 1, 50, None),
             (50, 5, 50, None), (8, 1, 8, None), (50, 1, 12, 12), (50, 5, 12, 12), (8, 5, 8, 12),
             (50, 4, 20, 12))  # fmt: skip
    for max_iter, first, expected, crawled in cases:
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
    the last one rescuing its step after the stall (traced, 2026-11-29). With the shipped
    budgets (20 after a stall; max_iter after no progress) against none (50 = max_iter): the
    same 5 stabilised steps and failed attempts, the source and tip within 1e-12 m (round-off at
    most: the contact's far-sample cache is left where the shortened retry stopped), and the
    25-iteration retry after a stall cut to 20: 596 -> 591 iterations. With 12 after a stall
    (below the rescue's 14) the rescue is lost and the run takes more stabilised steps, which
    shows the run does exercise a rescue the shipped budget keeps."""
    scene = load_scene(SCENES / "ring-u-lumen-stepwise.toml")
    old = _run(scene, monkeypatch, (50, 50))
    new = _run(scene, monkeypatch, BUDGET)
    assert old.status == new.status == 0
    assert new.stats.n_stabilised_steps == old.stats.n_stabilised_steps == 5
    assert new.stats.n_failed_attempts == old.stats.n_failed_attempts
    for k in ("source_pos_m", "tip_pos_m"):
        assert np.max(np.abs(getattr(new, k) - getattr(old, k))) <= 1e-12, k
    assert BUDGET == (20, None)
    assert old.stats.n_newton_iters - new.stats.n_newton_iters == 5
    short = _run(scene, monkeypatch, (12, None))
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
