"""The commissioning cross-check with the flexible-element engine (issue 28)."""

from __future__ import annotations

import os
from types import SimpleNamespace

import numpy as np
import pytest

from ringqa.errors import SceneError
from ringqa.pipeline.simulate import (
    CROSS_CHECK_FLEXIBLE_ERROR_MM,
    CROSS_CHECK_MIN_MM,
    Engine,
    cross_check_run,
)
from ringqa.pipeline.verdicts import numerics_verdict
from tests.pipeline.fakes import sim_result

needs_fork = pytest.mark.skipif(
    not hasattr(os, "fork") or (os.cpu_count() or 1) < 2, reason="needs fork and 2 cores"
)

ADV = np.array([10.0, 20.0, 30.0])
RIGID_MM = np.c_[ADV, np.zeros(3), np.zeros(3)]


def _engine(offset_mm=0.0, raise_exc=None, status=0):
    """A stand-in engine: the flexible run's dwells are the rigid ones moved by offset_mm in y."""

    def simulate(scene, advances_mm, progress=False):
        if raise_exc is not None:
            raise raise_exc
        pos = RIGID_MM + np.array([0.0, offset_mm, 0.0])
        return sim_result(status, "m", advances_mm, pos * 1e-3, solve_time_s=0.5)

    def with_overrides(scene, ov):
        return SimpleNamespace(**{**vars(scene), **ov})

    return Engine(simulate, None, with_overrides, lambda s: {})


def _check(engine, rigid_error_mm=0.01):
    scene = SimpleNamespace(name="x", solver=SimpleNamespace(increment_m=1e-3))
    return cross_check_run(
        engine, scene, ADV, rigid_error_mm,
        lambda run: np.linalg.norm(run.pos_m * 1e3 - RIGID_MM, axis=1),
        lambda run: run.pos_m * 1e3,
    )  # fmt: skip


def test_agreement_within_the_limit_passes():
    xc = _check(_engine(0.05))
    assert xc.ok and not xc.fails
    assert xc.max_mm == pytest.approx(0.05)
    assert xc.limit_mm == CROSS_CHECK_MIN_MM  # 2 x (0.01 + 0.06) = 0.14 < 0.2
    assert "agree to 0.050 mm" in xc.text and "within the 0.20 mm" in xc.text
    assert xc.solve_time_s == 0.5
    assert numerics_verdict(0.01, 0.1, xc).status == "PASS"


def test_disagreement_above_the_limit_fails_the_numerics():
    xc = _check(_engine(0.3))
    assert xc.fails
    v = numerics_verdict(0.01, 0.1, xc)
    assert v.status == "FAIL"
    assert "disagrees by up to 0.300 mm" in v.text


def test_the_limit_grows_with_the_numerical_errors():
    """max(0.2 mm, 2 x (rigid error + the flexible engine's)): a rigid error of 0.2 mm allows
    2 x 0.25 = 0.5 mm, so a 0.3 mm disagreement is within it."""
    xc = _check(_engine(0.3), rigid_error_mm=0.2)
    assert xc.limit_mm == pytest.approx(2 * (0.2 + CROSS_CHECK_FLEXIBLE_ERROR_MM))
    assert not xc.fails


def test_a_scene_the_flexible_engine_refuses_is_said_not_failed():
    xc = _check(_engine(raise_exc=SceneError("effects.torsion: not modelled")))
    assert not xc.ok and not xc.fails
    assert "not made" in xc.text and "effects.torsion" in xc.text
    assert numerics_verdict(0.01, 0.1, xc).status == "PASS"


def test_a_jammed_flexible_run_is_not_compared():
    xc = _check(_engine(status=1))
    assert not xc.ok and not xc.fails and np.isnan(xc.max_mm)


def test_on_by_default_and_switched_off_is_said():
    """``ringqa commission`` cross-checks unless told not to (config key and settings default);
    switched off, the numerical check's text says so."""
    from ringqa.config import KEYS
    from ringqa.pipeline import CommissionSettings
    from ringqa.pipeline.simulate import CROSS_CHECK_OFF_TEXT

    assert CommissionSettings().cross_check is True
    assert {k.key: k.default for k in KEYS}["simulation.cross_check"] is True
    assert "switched off" in CROSS_CHECK_OFF_TEXT and "--no-cross-check" in CROSS_CHECK_OFF_TEXT


@needs_fork
def test_the_cross_check_beside_the_rigid_runs_equals_it_after_them(monkeypatch):
    """ring26x60 (shipped, the real engines): the flexible run forked at the start, beside the
    rigid runs, gives exactly (tolerance 0) the disagreement of running it after them here; its
    settings are the commissioning element lengths x CROSS_CHECK_ELEMENT_FACTOR at the same
    increment; the agreement is within the limit (0.2 mm). Switched off (``cross_check=False``)
    the text says so and nothing is run; not asked (None), no line."""
    from ringqa import parallel as forked_mod
    from ringqa.io.applicator_file import load_applicator
    from ringqa.pipeline import simulate
    from ringqa.pipeline.dwells import reference_dwells

    app = load_applicator("ring26x60")
    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm

    def run(cross=True):
        return simulate.simulate_dwells(app, ring, rel, cable="flexitron", scene_overrides={},
                                        stem_mm=60.0, cross_check=cross)  # fmt: skip

    monkeypatch.setattr(simulate, "kernels_cached", lambda: True)
    monkeypatch.setattr(forked_mod, "second_core_free", lambda: True)
    together = run().numerics.cross_check
    monkeypatch.setattr(forked_mod, "second_core_free", lambda: False)
    in_turn = run().numerics.cross_check
    assert together.concurrent and not in_turn.concurrent
    assert together.ok and not together.fails
    np.testing.assert_array_equal(together.disagreement_mm, in_turn.disagreement_mm)
    np.testing.assert_array_equal(together.flexible_pos_mm, in_turn.flexible_pos_mm)
    np.testing.assert_array_equal(together.relative_position_mm, np.asarray(rel, dtype=float))
    assert together.max_mm < CROSS_CHECK_MIN_MM
    assert together.settings["model.formulation"] == "flexible"
    assert together.settings["discretisation.element_length_mm.thin"] == pytest.approx(
        2.0 * simulate.CROSS_CHECK_ELEMENT_FACTOR
    )
    assert "beside the rigid runs" in together.text
    assert together.as_dict()["concurrent"] is True
    off = run(False).numerics
    assert off.cross_check is None and off.text[-1] == simulate.CROSS_CHECK_OFF_TEXT
    quiet = run(None).numerics
    assert quiet.cross_check is None and simulate.CROSS_CHECK_OFF_TEXT not in quiet.text


@needs_fork
def test_a_jam_of_the_rigid_runs_leaves_no_cross_check_process(monkeypatch):
    """The rigid runs jam (a push-force limit far below the push needed) after the cross-check
    was forked: the jam is raised, and the forked flexible run is stopped and reaped when its
    pending check is dropped (no child left blocked on its pipe)."""
    import gc

    from ringqa import parallel as forked_mod
    from ringqa.io.applicator_file import load_applicator
    from ringqa.pipeline import simulate
    from ringqa.pipeline.dwells import reference_dwells

    app = load_applicator("ring26x60")
    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    pids = []
    real = simulate.start_cross_check

    def spy(*a, **k):
        pending = real(*a, **k)
        pids.append(pending.call._pid)
        return pending

    monkeypatch.setattr(simulate, "start_cross_check", spy)
    monkeypatch.setattr(simulate, "kernels_cached", lambda: True)
    monkeypatch.setattr(forked_mod, "second_core_free", lambda: True)
    with pytest.raises(simulate.SimulationJammedError, match="jam"):
        simulate.simulate_dwells(app, ring, rel, cable="flexitron", stem_mm=60.0,
                                 scene_overrides={"solver.jam_force_n": 1e-3},
                                 cross_check=True)  # fmt: skip
    gc.collect()
    assert pids and pids[0] > 0
    with pytest.raises(ChildProcessError):
        os.waitpid(pids[0], os.WNOHANG)
