"""The dynamic pause's time step (ringqa.simulation.solvers.schedule, issue 18).

A pause of 50 ms at ``solver.time_step_s`` = 1 ms: the step doubles after every pause step
solved without a cut, up to PAUSE_MAX_FACTOR (16) time steps, so an uncut pause is
1 + 2 + 4 + 8 + 16 = 31 ms and then 19 ms left: 19 < 1.25 x 16 ms, so the last step takes the
whole remainder (no sliver step) and lands on the pause's end, where the dwell is recorded.
A cut step shrinks the pause step to the sub-step that worked; a moving step resets it, and so
does a pause step in which a node still moved faster than PAUSE_REST_SPEED_FRACTION (0.2) of
motion.speed (0.5 m/s here: 0.1 m/s).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ringqa.simulation.solvers.schedule import (
    PAUSE_MAX_FACTOR,
    PAUSE_REST_SPEED_FRACTION,
    Leg,
    Schedule,
)

DT = 1e-3


@pytest.fixture()
def schedule():
    """A dynamic schedule on a stand-in model (only the fields Schedule reads)."""
    motion = SimpleNamespace(kind="stepwise", backward=False, dwell_s=0.05)
    model = SimpleNamespace(
        scene=SimpleNamespace(motion=motion), dynamic=True, u_start=0.0, increment=1e-3,
        time_step=DT, speed=0.5,
    )  # fmt: skip
    return Schedule(model, np.array([0.01]), history_free=False)


def _pause(schedule, dwell_s, cuts=None, speeds=None):
    """Walk one pause as the driver does; ``cuts`` maps a step's index to its sub-step count,
    ``speeds`` to its fastest node's speed (m/s; else 0). Returns the steps (s)."""
    cuts = cuts or {}
    speeds = speeds or {}
    leg = Leg(0, 0.0, [0], 0.0, dwell_s)
    left = dwell_s
    steps = []
    while left > 1e-15:
        du, dt = schedule.next_step(0.0, leg, left)
        assert du == 0.0
        steps.append(dt)
        schedule.adapt(cuts.get(len(steps) - 1, 1), 12, speeds.get(len(steps) - 1, 0.0))
        left -= dt
    return steps


def test_an_uncut_pause_doubles_its_step_and_lands_on_its_end(schedule):
    steps = _pause(schedule, 0.05)
    assert steps == pytest.approx([1e-3, 2e-3, 4e-3, 8e-3, 16e-3, 19e-3], abs=1e-15)
    assert sum(steps) == pytest.approx(0.05, abs=1e-15)


def test_the_pause_step_stops_growing_at_its_cap(schedule):
    steps = _pause(schedule, 0.2)
    assert max(steps) == pytest.approx(PAUSE_MAX_FACTOR * DT, rel=1e-12)
    assert sum(steps) == pytest.approx(0.2, abs=1e-15)


def test_a_cut_shrinks_the_pause_step_and_moving_resets_it(schedule):
    # steps 1, 2, 4 ms; the 4 ms step is cut in 4: the next is 1 ms, then it grows again
    steps = _pause(schedule, 0.02, cuts={2: 4})
    assert steps[:5] == pytest.approx([1e-3, 2e-3, 4e-3, 1e-3, 2e-3], abs=1e-15)
    _pause(schedule, 0.05)
    moving = Leg(1, 0.005, [0], 0.005, 0.0)
    du, dt = schedule.next_step(0.0, moving, 0.0)
    assert du > 0 and dt == pytest.approx(DT)
    assert _pause(schedule, 0.003)[0] == pytest.approx(DT)


def test_the_pause_step_grows_only_once_the_cable_has_slowed_down(schedule):
    # steps 0 and 1 still slide at 0.3 m/s (> 0.1 m/s): 1, 1 ms; then 1, 2, 4 ms ...
    fast = 1.5 * PAUSE_REST_SPEED_FRACTION * 0.5
    steps = _pause(schedule, 0.02, speeds={0: fast, 1: fast})
    assert steps[:5] == pytest.approx([1e-3, 1e-3, 1e-3, 2e-3, 4e-3], abs=1e-15)


def test_a_fast_pause_step_sets_the_step_back(schedule):
    fast = 1.5 * PAUSE_REST_SPEED_FRACTION * 0.5
    steps = _pause(schedule, 0.02, speeds={2: fast})
    assert steps[:5] == pytest.approx([1e-3, 2e-3, 4e-3, 1e-3, 2e-3], abs=1e-15)
