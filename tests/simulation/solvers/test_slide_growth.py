"""The quasi-static load step grows while the cable just slides (schedule.SLIDE_GROW_MAX_ITERS,
issue 16).

With friction the quasi-static path depends on history, so the step stays at
``solver.increment_m`` - except after a step that Newton solved in one iteration from the slid
predictor: there the cable slides along the channel with kinetic friction everywhere and the
step's end state does not depend on where the slide was cut. The step then doubles (up to
JUMP_FACTOR = 8 increments) and the first harder step sets it back to the increment; a grown step
that fails is cut into increment-long sub-steps before the fallback stabilisation.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import ringqa.simulation.solvers.schedule as schedule_mod
from ringqa.simulation import simulate
from ringqa.simulation.scenefile import load_scene
from ringqa.simulation.solvers.schedule import JUMP_FACTOR, Leg, Schedule

INC = 1e-3


def _schedule(stab: float = 0.0) -> Schedule:
    """A quasi-static, history-dependent schedule on a stand-in model (the fields it reads)."""
    motion = SimpleNamespace(kind="constant", backward=False, dwell_s=0.0)
    model = SimpleNamespace(
        scene=SimpleNamespace(motion=motion), dynamic=False, u_start=0.0, increment=INC,
        time_step=1e-3, speed=0.5, stab=stab,
    )  # fmt: skip
    return Schedule(model, np.array([0.1]), history_free=False)


def _steps(schedule: Schedule, iters: list[int]) -> list[float]:
    """Steps (m) handed out when the k-th step is solved in ``iters[k]`` Newton iterations."""
    leg = Leg(0, 0.1, [0], 0.1, 0.0)
    u, out = 0.0, []
    for it in iters:
        du, _ = schedule.next_step(u, leg, 0.0)
        out.append(round(du / INC, 9))
        schedule.adapt(1, it)
        u += du
    return out


def test_the_step_doubles_after_one_iteration_steps_and_resets_after_a_harder_one():
    """Steps 1, 2, 4, 8, 8 increments while every step takes 1 iteration (cap JUMP_FACTOR = 8);
    a 2-iteration step sets the next back to 1 increment, and it grows again from there."""
    got = _steps(_schedule(), [1, 1, 1, 1, 1, 2, 1, 1])
    assert JUMP_FACTOR == 8
    assert got == [1, 2, 4, 8, 8, 8, 1, 2]


def test_no_growth_with_the_always_on_tether():
    """The always-on tether (solver.stabilisation > 0) dissipates per step: the step must not
    change with how easy the last one was."""
    assert _steps(_schedule(stab=1e-3), [1, 1, 1, 1]) == [1, 1, 1, 1]


def test_ring26_takes_fewer_steps_to_the_same_dwells(monkeypatch):
    """ring26-flexitron (quasi-static, Stribeck friction, 1 mm increments): its straight
    approach is solved in one Newton iteration per step. Measured: 146 -> 93 steps, 573 -> 518
    iterations, dwells equal to 2e-16 m, input work equal to 1e-12 J. Bounds: at most 100 steps
    (the increment-only run needs 146), dwells within 1e-9 m (the Newton tolerance's scale, far
    inside the 0.01 mm accuracy rule), the input work within 1e-9 relative (the work balance is
    the rectangle rule on the push force, which is constant along a pure slide)."""
    scene = load_scene("ring26-flexitron")
    monkeypatch.setattr(schedule_mod, "SLIDE_GROW_MAX_ITERS", -1)
    fixed = simulate(scene)
    monkeypatch.undo()
    grown = simulate(scene)
    assert fixed.status == grown.status == 0
    assert fixed.stats.n_steps == 146
    assert grown.stats.n_steps <= 100
    assert grown.stats.n_newton_iters < fixed.stats.n_newton_iters
    assert np.max(np.abs(grown.source_pos_m - fixed.source_pos_m)) < 1e-9
    assert grown.work["input"] == pytest.approx(fixed.work["input"], rel=1e-9)
