"""The accuracy study's logic on a fake simulator with a known error model (see conftest)."""

from __future__ import annotations

import tomllib

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.accuracy import AccuracyError, pareto_mask, recommend, run_study
from ringqa.accuracy.study import (
    CONTRACT_COLUMNS,
    angle_errors_deg,
    default_grid,
    position_errors_mm,
)
from ringqa.simulation.scenefile import scene_with_overrides
from tests.accuracy.conftest import C_EL, C_INC, FakeSimulator, exact_positions_mm

GRID = {
    "discretisation.element_length_mm.thin": [3.0, 1.5, 0.75],
    "solver.increment_mm": [4.0, 1.0, 0.5, 0.25],
}


def test_pareto_mask_by_hand():
    """Points (t, e): A(1, 10) B(2, 5) C(3, 6) D(4, 1) E(5, nan): C is beaten by B (faster and
    more accurate), E has no error; the front is A, B, D."""
    mask = pareto_mask([1, 2, 3, 4, 5], [10, 5, 6, 1, np.nan])
    assert mask.tolist() == [True, True, False, True, False]


def test_recommend_picks_cheapest_meeting_target():
    """Rows (time, err): (1, 0.5) (2, 0.08) (3, 0.02) (0.5, 0.01 but jammed) (0.1, 0.001 model):
    for 0.1 mm the answer is the 2 s run; 0.01 mm: none numerical; with model changes the model
    row wins."""
    t = pd.DataFrame(
        {
            "time_s": [1, 2, 3, 0.5, 0.1],
            "max_err_mm": [0.5, 0.08, 0.02, 0.01, 0.001],
            "status": [0, 0, 0, 1, 0],
            "kind": ["numerical"] * 4 + ["model"],
            "run": range(5),
        }
    )
    assert recommend(t, 0.1)["time_s"] == 2
    assert recommend(t, 0.01) is None
    assert recommend(t, 0.01, include_model_changes=True)["time_s"] == 0.1


def test_error_measures_by_hand():
    """Positions 3-4-5: |(3, 4, 0)| = 5 mm; directions (1,0,0) vs (1,1,0)/sqrt2: 45 deg."""
    e = position_errors_mm([[3.0, 4.0, 0.0]], [[0.0, 0.0, 0.0]])
    assert e.tolist() == pytest.approx([5.0])
    a = angle_errors_deg([[1.0, 0.0, 0.0]], [[1.0, 1.0, 0.0]])
    assert a.tolist() == pytest.approx([45.0])
    assert angle_errors_deg([[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]]).tolist() == [0.0]


def test_study_table_front_and_recommendation(fake_scene, fake_simulator, tmp_path):
    """Error model e = 0.02 h^2 + 0.05 inc (mm) (h = 3, inc = 1: 0.23 mm): the measured errors
    match it to 11 % (the reference's own error is <= 10 % of the smallest); the recommendation is
    the fastest run meeting 0.1 mm (checked by brute force); jammed runs (inc 4 > 3 mm) appear
    with status 1 and no error; errors fall strictly along the front."""
    study = run_study(fake_scene, grid=GRID, target_mm=0.1, out_dir=tmp_path,
                      simulator=fake_simulator, repeats=2)  # fmt: skip
    t = study.table
    for col in CONTRACT_COLUMNS:
        assert col in t.columns
    jam = t["solver.increment_mm"] == 4.0
    assert (t.loc[jam, "status"] == 1).all() and t.loc[jam, "max_err_mm"].isna().all()
    assert not t.loc[jam, "pareto"].any()
    # measured error vs the model (reference error is ~0 by construction, <= 10 % of smallest)
    ok = t["status"] == 0
    h = t.loc[ok, "discretisation.element_length_mm.thin"]
    inc = t.loc[ok, "solver.increment_mm"]
    expected = C_EL * h**2 + C_INC * inc
    assert np.allclose(t.loc[ok, "max_err_mm"], expected, rtol=0.11)
    # brute-force recommendation: cheapest among those meeting 0.1 mm
    meets = t[ok & (t["max_err_mm"] <= 0.1)]
    assert study.recommended["time_s"] == meets["time_s"].min()
    front = t[t["pareto"]].sort_values("time_s")
    assert np.all(np.diff(front["max_err_mm"]) < 0)  # errors fall monotonically along the front
    for name in ("accuracy.csv", "accuracy.png", "recommended.toml", "reference.csv",
                 "runs.jsonl", "study.json"):  # fmt: skip
        assert (tmp_path / name).is_file(), name
    csv = pd.read_csv(tmp_path / "accuracy.csv")
    assert set(CONTRACT_COLUMNS) <= set(csv.columns) and len(csv) == len(t)
    rec = tomllib.loads((tmp_path / "recommended.toml").read_text())
    thin = next(s for s in rec["instrument"]["sections"] if s["name"] == "thin")
    assert thin["element_length_mm"] == study.recommended["discretisation.element_length_mm.thin"]
    assert rec["solver"]["increment_mm"] == study.recommended["solver.increment_mm"]


def test_reference_is_really_converged(fake_scene, fake_simulator):
    """The reference's TRUE error (vs the exact circle) must be within a tenth of the smallest
    reported error (+1 % slack): with e ~ 0.05 inc (first order) levels differ by halves, so the
    rule stops when the last difference is <= 0.1 x smallest, and the remaining error (a geometric
    tail equal to that last difference) is too."""
    study = run_study(fake_scene, grid=GRID, simulator=fake_simulator, repeats=1, max_levels=6)
    ref = study.reference
    assert ref.converged
    assert ref.agreement_mm <= 0.1 * ref.smallest_error_mm
    finest = ref.levels[-1].overrides
    res = FakeSimulator()(scene_with_overrides(fake_scene, finest))
    adv = np.array(fake_scene.motion.advances_m) * 1e3
    true_err = np.max(np.linalg.norm(res.source_pos_m * 1e3 - exact_positions_mm(adv), axis=1))
    assert true_err <= 0.1 * ref.smallest_error_mm * 1.01


def test_unconverged_reference_is_reported(fake_scene, fake_simulator):
    """With only 2 levels the two finest differ by ~smallest/4 > smallest/10: not converged."""
    study = run_study(fake_scene, grid=GRID, simulator=fake_simulator, repeats=1, max_levels=2)
    assert not study.reference.converged
    assert any("not converged" in w for w in study.warnings)


def test_recommended_setting_reproduces_its_error(fake_scene, fake_simulator):
    """Re-running the recommended overrides gives the claimed max error (deterministic model)."""
    study = run_study(fake_scene, grid=GRID, simulator=fake_simulator, repeats=1)
    again = FakeSimulator()(scene_with_overrides(fake_scene, study.recommended_overrides))
    finest = study.reference.levels[-1].overrides
    ref = FakeSimulator()(scene_with_overrides(fake_scene, finest))
    err = np.max(np.linalg.norm((again.source_pos_m - ref.source_pos_m) * 1e3, axis=1))
    assert err == pytest.approx(study.recommended["max_err_mm"], rel=1e-9)
    assert err <= 0.1


def test_resume_skips_finished_runs(fake_scene, tmp_path):
    """A second study in the same folder runs nothing new; an interrupted cache line is ignored;
    resume=False starts afresh."""
    sim1 = FakeSimulator()
    run_study(fake_scene, grid=GRID, out_dir=tmp_path, simulator=sim1, repeats=1)
    assert sim1.calls > 0
    with open(tmp_path / "runs.jsonl", "a") as fh:
        fh.write('{"key": "cut-off')  # a line cut by an interruption
    sim2 = FakeSimulator()
    s2 = run_study(fake_scene, grid=GRID, out_dir=tmp_path, simulator=sim2, repeats=1)
    assert sim2.calls == 0
    assert s2.recommended is not None
    sim3 = FakeSimulator()
    run_study(fake_scene, grid=GRID, out_dir=tmp_path, simulator=sim3, repeats=1, resume=False)
    assert sim3.calls == sim1.calls


def test_default_grid_covers_the_settings(fake_scene):
    """16 element x increment runs, 2 tolerances, 2 stabilisations, the other solver kind,
    4 effect toggles."""
    grid = default_grid(fake_scene)
    assert len(grid) == 16 + 2 + 2 + 1 + 4
    assert {"solver.kind": "dynamic", "effects.inertia": True} in grid
    assert {"effects.friction": "none"} in grid
    thin = sorted({g["discretisation.element_length_mm.thin"] for g in grid if
                   "discretisation.element_length_mm.thin" in g})  # fmt: skip
    assert thin == [0.75, 1.5, 3.0, 6.0]


def test_model_change_rows_are_marked(fake_scene, fake_simulator):
    """Friction off moves the fake source by 0.5 mm on top of the base discretisation error
    0.02 * 3^2 + 0.05 * 1 = 0.23 mm: a 'model' row with ~0.73 mm error, never recommended even
    though it meets the 1 mm target."""
    grid = [{"solver.increment_mm": 0.5}, {"effects.friction": "none"}]
    study = run_study(fake_scene, grid=grid, simulator=fake_simulator, repeats=1, target_mm=1.0)
    row = study.table[study.table["kind"] == "model"].iloc[0]
    assert row["max_err_mm"] == pytest.approx(0.73, rel=0.02)
    assert study.recommended["kind"] == "numerical"


def test_bad_target_is_an_input_error(fake_scene, fake_simulator):
    with pytest.raises(AccuracyError, match="target"):
        run_study(fake_scene, grid=GRID, target_mm=-1, simulator=fake_simulator)


def test_tail_estimate_by_hand():
    """Differences 0.4, 0.2, 0.1 (ratio 1/2): remaining error 0.1 * 0.5 / 0.5 = 0.1; ratio 0.8
    with last 0.0035: 0.0035 * 0.8 / 0.2 = 0.014; growing differences: NaN."""
    from ringqa.accuracy.study import tail_estimate

    assert tail_estimate([float("nan"), 0.4, 0.2, 0.1]) == pytest.approx((0.1, 0.5))
    assert tail_estimate([0.0042, 0.0042 * 0.8])[0] == pytest.approx(0.0042 * 0.8 * 4)
    assert np.isnan(tail_estimate([0.1, 0.2])[0])
    assert np.isnan(tail_estimate([0.1])[0])


@given(
    st.lists(
        st.tuples(st.floats(1e-3, 1e3), st.floats(1e-4, 10.0) | st.just(float("nan"))),
        min_size=1,
        max_size=30,
    )
)
def test_pareto_front_is_exactly_the_non_dominated_set(points):
    """Every front point is beaten by no run in both time and error; every other run with an
    error is beaten (<= both, < one) by some front point; runs without an error are never on it."""
    t = np.array([p[0] for p in points])
    e = np.array([p[1] for p in points])
    mask = pareto_mask(t, e)
    ok = np.isfinite(e)
    for i in range(len(t)):
        beaten = ok & (t <= t[i]) & (e <= e[i]) & ((t < t[i]) | (e < e[i]))
        if not ok[i]:
            assert not mask[i]
        elif mask[i]:
            assert not beaten.any()
        else:
            assert (beaten & mask).any()


def test_dose_points_from_the_applicator_or_a_fitted_circle():
    """The ring26 scene uses its applicator's report points; an analytic arc uses the stand-in
    (points around the circle fitted to the dwells). Moving every dwell 1 mm changes the dose at
    the points by a clearly non-zero amount (> 0.5 %: ~5-12 %/mm near a source) and not moving
    them changes nothing."""
    from ringqa.accuracy.study import dose_error_pct, dose_model_for
    from ringqa.simulation.scenefile import load_scene

    ring = load_scene("ring26-flexitron")
    ch = ring.channel
    adv = np.array(ring.motion.advances_m)
    pos = ch.centreline.position(adv) * 1e3
    dirs = ch.centreline.tangent(adv)
    model = dose_model_for(ring, pos)
    assert "applicator ring26x60" in model.how and len(model.points_mm) == 6
    ref = model.dose(pos, dirs)
    assert dose_error_pct(model, pos, dirs, ref) == 0.0
    assert dose_error_pct(model, pos + np.array([1.0, 0.0, 0.0]), dirs, ref) > 0.5
    arc = load_scene("ring13-push100")
    pa = arc.channel.centreline.position(np.array(arc.motion.advances_m)) * 1e3
    assert "stand-in" in dose_model_for(arc, pa).how


def test_reference_refinement_respects_the_time_budget(fake_scene, fake_simulator):
    """The fake's time grows 4x per level (elements x steps); with a budget below 4x the second
    level's time the third level is never started and the study says so."""
    study = run_study(fake_scene, grid=GRID, simulator=fake_simulator, repeats=1, max_levels=6,
                      max_ref_time_s=1e-9)  # fmt: skip
    assert len(study.reference.levels) == 2
    assert not study.reference.converged
    assert any("refinement stopped before level 3" in w for w in study.warnings)


def test_cache_is_not_reused_by_a_changed_engine(fake_scene, tmp_path, monkeypatch):
    """Runs cached by one engine build are re-run when the engine's source changes."""
    import ringqa.accuracy.cache as cache_mod  # where the run keys look the fingerprint up

    grid = {"solver.increment_mm": [1.0, 0.5]}
    sim1 = FakeSimulator()
    run_study(fake_scene, grid=grid, out_dir=tmp_path, simulator=sim1, repeats=1)
    monkeypatch.setattr(cache_mod, "engine_fingerprint", lambda: "another-engine")
    sim2 = FakeSimulator()
    run_study(fake_scene, grid=grid, out_dir=tmp_path, simulator=sim2, repeats=1)
    assert sim2.calls == sim1.calls > 0


def test_cached_run_with_nan_positions_round_trips():
    """A failed run's NaN rows are written as JSON null (ringqa.jsonio's policy: runs.jsonl is
    standard JSON) and read back as NaN; finite values come back exactly."""
    from ringqa.accuracy.cache import RunRecord

    pos = np.array([[1.0, 2.0, 3.0], [np.nan, np.nan, np.nan]])
    rec = RunRecord("k", {"solver.increment_mm": np.float64(0.5)}, -1, "failed", (0.25,), 7, 12,
                    pos, np.array([[0.0, 0.0, 1.0], [np.nan, np.nan, np.nan]]))  # fmt: skip
    line = rec.as_json()
    assert "NaN" not in line and "[null, null, null]" in line
    assert '"solver.increment_mm": 0.5' in line  # a number, not the string "0.5"
    back = RunRecord.from_json(line)
    np.testing.assert_array_equal(back.positions_mm, pos)
    assert back.overrides == {"solver.increment_mm": 0.5} and back.times_s == (0.25,)


def test_progress_weights_follow_the_run_cost(fake_scene, fake_simulator):
    """The progress bar's weights (ringqa.accuracy.runs.run_costs): for every default grid run
    the predicted units are proportional to the fake simulator's solve time (elements x steps,
    tests/accuracy/conftest.py) within 5 % (the rigid capsule, one element in every run, is
    the only part that does not scale); reference level k costs 4^k times the finest grid run
    (element length and increment both 1/4 of the scene's: 16 units), i.e. 64, 256, 1024."""
    from ringqa.accuracy.grid import dedupe_grid, default_grid
    from ringqa.accuracy.runs import run_costs

    grid = dedupe_grid(fake_scene, [{}, *default_grid(fake_scene)])
    costs = run_costs(fake_scene, grid, 3, repeats=1)
    times = [
        fake_simulator(scene_with_overrides(fake_scene, ov) if ov else fake_scene).solve_time_s
        for ov in grid
    ]
    ratio = np.asarray(times) / np.asarray(costs[: len(grid)])
    assert ratio.max() / ratio.min() < 1.05
    assert costs[len(grid) :] == [64.0, 256.0, 1024.0]
    assert run_costs(fake_scene, grid, 1, repeats=3)[0] == 3.0  # the scene's own run, 3 repeats
