"""The coarse approach (ringqa.simulation.solvers.schedule, APPROACH_COARSE_FACTOR and
APPROACH_SETTLE_INCREMENTS; docs/engine.md "Fewer load steps").

Before the first waypoint a history-dependent quasi-static run records nothing, and the path's
memory of how it was stepped fades as the cable slides on. So on the approach a hard step resets
the step to 2 increments instead of 1, up to the settling point (the last point of the increment
grid from the start at least 4 increments before the first waypoint); from there the steps are
the increment's again. The reference for the answers is the same run with the rule off (the
increment-only approach): the rule must leave every dwell where it was, to far below the
scene's numerical error (0.129 mm on ring26-flexitron), while taking fewer steps.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

import ringqa.simulation.solvers.schedule as schedule_mod
from ringqa.simulation import simulate
from ringqa.simulation.scenefile import load_scene, scene_with_overrides
from ringqa.simulation.solvers import driver
from ringqa.simulation.solvers.schedule import SETTLE_SLACK_M, Leg, Schedule

INC = 1e-3


def _schedule(target_m: float, stab: float = 0.0, history_free: bool = False) -> Schedule:
    """A quasi-static schedule from advance 0 to ``target_m`` on a stand-in model."""
    motion = SimpleNamespace(kind="constant", backward=False, dwell_s=0.0)
    model = SimpleNamespace(
        scene=SimpleNamespace(motion=motion), dynamic=False, u_start=0.0, increment=INC,
        time_step=1e-3, speed=0.5, stab=stab,
    )  # fmt: skip
    return Schedule(model, np.array([target_m]), history_free=history_free)


def _walk(schedule: Schedule, target_m: float, iters: int) -> list[float]:
    """Steps (m) to ``target_m`` when every step takes ``iters`` Newton iterations."""
    leg = Leg(0, target_m, [0], target_m, 0.0)
    u, out = 0.0, []
    while abs(target_m - u) > 1e-12:
        du, _ = schedule.next_step(u, leg, 0.0)
        out.append(du)
        schedule.adapt(1, iters)
        u += du
    return out


def test_the_settling_point_lies_on_the_increment_grid_four_increments_short():
    """From 0 to 100 mm in 1 mm increments: floor(100 - 4) = 96 increments, so 96 mm (plus the
    5e-13 m slack that lets a whole step land on it). An approach of 7 increments has room for
    the first step and one coarse step (7 - 4 = 3 = 2 + 1): 3 mm; 6 increments have none. No
    coarse approach with the rule off (factor 1), with the always-on tether, or without
    history (those runs already jump)."""
    assert _schedule(0.1).settle_u == 0.096 + SETTLE_SLACK_M
    assert _schedule(0.007).settle_u == 0.003 + SETTLE_SLACK_M
    assert _schedule(0.006).settle_u is None
    assert _schedule(0.1, stab=1e-3).settle_u is None
    assert _schedule(0.1, history_free=True).settle_u is None


def test_hard_steps_reset_to_two_increments_until_the_settling_point(monkeypatch):
    """Every step hard (5 iterations), 0 -> 20 mm, settling point 16 mm: the first step is one
    increment (nothing reset it yet), then 2 mm steps to 15 mm, one increment (cut to land on
    the settling point), and the increment to the waypoint: 1 + 7 x 2 + 1 + 4 x 1 = 20 mm in 13
    steps, against 20 steps with the rule off."""
    got = np.array(_walk(_schedule(0.02), 0.02, 5)) / INC
    np.testing.assert_allclose(got, [1] + [2] * 7 + [1] * 5, rtol=0, atol=1e-6)
    monkeypatch.setattr(schedule_mod, "APPROACH_COARSE_FACTOR", 1)
    assert len(_walk(_schedule(0.02), 0.02, 5)) == 20


def test_a_whole_step_lands_on_the_settling_point_unchanged():
    """0 -> 21 mm, settling point 17 mm = 1 + 8 x 2 mm: the last coarse step is a whole 2 mm
    step, exactly the one before it (the extrapolated predictor needs the same step; aimed at
    the grid point computed apart it came out ~1e-17 m short); then 4 increments."""
    got = _walk(_schedule(0.021), 0.021, 5)
    assert got[1:9] == [2 * INC] * 8
    np.testing.assert_allclose(np.array(got[9:]) / INC, [1] * 4, rtol=0, atol=1e-6)


def test_easy_steps_still_double_up_to_eight_increments():
    """1-iteration steps (the cable sliding) double as before, 1, 2, 4, 8 increments, capped at
    JUMP_FACTOR = 8 increments also on the coarse approach."""
    got = _walk(_schedule(0.1), 0.1, 1)
    np.testing.assert_allclose(np.array(got[:6]) / INC, [1, 2, 4, 8, 8, 8], rtol=0, atol=1e-9)


def test_ring26_fewer_steps_same_dwells_both_loops(monkeypatch):
    """ring26-flexitron (Stribeck friction, 1 mm increments; its first dwell 85.3 mm from the
    start). Measured: 93 -> 84 load steps, 518 -> 483 Newton iterations, dwells moved <= 3.1e-10
    m, directions <= 3.7e-8 rad. Bounds: fewer steps and iterations; dwells within 1e-9 m and
    directions within 1e-7 rad of the increment-only approach (the scene's numerical error is
    0.129 mm and 0.39 deg); the compiled loop equal to the Python loop bit for bit; every
    iteration counted towards a dwell (the first dwell's count includes the coarse leg's)."""
    scene = load_scene("ring26-flexitron")
    adv = np.asarray(scene.motion.advances_m, dtype=float)
    monkeypatch.setattr(schedule_mod, "APPROACH_COARSE_FACTOR", 1)
    fine = simulate(scene)
    monkeypatch.setattr(schedule_mod, "APPROACH_COARSE_FACTOR", 2)
    monkeypatch.setattr(driver, "USE_MARCH", False)
    python = driver.run(scene, adv)
    monkeypatch.setattr(driver, "USE_MARCH", True)
    got = driver.run(scene, adv)
    assert fine.status == got.status == 0
    assert got.stats.n_steps < fine.stats.n_steps
    assert got.stats.n_newton_iters < fine.stats.n_newton_iters
    assert np.max(np.abs(got.source_pos_m - fine.source_pos_m)) < 1e-9
    assert np.max(np.abs(got.tip_pos_m - fine.tip_pos_m)) < 1e-9
    assert np.max(np.abs(got.source_dir - fine.source_dir)) < 1e-7
    for k in ("source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "contact_force_n",
              "newton_iters", "s_m", "offset_m", "nodes_m"):  # fmt: skip
        np.testing.assert_array_equal(getattr(got, k), getattr(python, k), err_msg=k)
    assert got.stats == python.stats
    assert got.work == python.work
    for res in (fine, got):
        assert int(np.sum(res.newton_iters)) == res.stats.n_newton_iters


def test_the_settling_stretch_is_what_keeps_the_first_dwell(monkeypatch):
    """Without the settling stretch (0 increments) the coarse steps reach the first dwell
    directly: measured 1.3e-6 m off the increment-only approach (decaying about 7x per dwell),
    against 3e-10 m with 4 increments. Bound: more than 1e-7 m without, so the stretch is
    needed and the test above measures it."""
    scene = load_scene("ring26-flexitron")
    monkeypatch.setattr(schedule_mod, "APPROACH_COARSE_FACTOR", 1)
    fine = simulate(scene)
    monkeypatch.setattr(schedule_mod, "APPROACH_COARSE_FACTOR", 2)
    monkeypatch.setattr(schedule_mod, "APPROACH_SETTLE_INCREMENTS", 0)
    direct = simulate(scene)
    d = np.linalg.norm(direct.source_pos_m - fine.source_pos_m, axis=1)
    assert d[0] > 1e-7
    assert d[0] > 3 * d[2]  # the difference fades over the dwells


def test_the_last_steps_before_the_first_dwell_are_the_increments():
    """The kept trajectory (every accepted step, the Python loop): on ring26-flexitron the steps
    ending after the settling point are at most one increment, at least one step before it is
    two increments (a hard step's reset), and the settling point is a step's end."""
    scene = scene_with_overrides(load_scene("ring26-flexitron"), {"outputs.trajectory": True})
    res = simulate(scene)
    u = np.concatenate([[-2.4e-3], res.trajectory["advance_m"]])
    first = float(np.min(np.asarray(scene.motion.advances_m)))
    settle = -2.4e-3 + np.floor((first + 2.4e-3) / INC - 4 + 1e-9) * INC
    steps = np.diff(u)
    before = u[1:] <= settle + 1e-9
    after = (u[1:] > settle + 1e-9) & (u[1:] <= first + 1e-12)
    assert np.any(np.abs(u - settle) < 1e-9)
    assert np.all(steps[after] <= INC + 1e-12)
    assert np.any(np.abs(steps[before] - 2 * INC) < 1e-12)
