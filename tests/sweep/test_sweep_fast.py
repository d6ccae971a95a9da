"""The cheap sample (ringqa.sweep.fast): one engine run at the commissioning settings, its
numerical error measured once per sweep, a per-sample time budget, failures reported with the
parameter they go with, and a centreline displacement that makes no impossible channel."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.sweep import load_spec
from ringqa.sweep.analysis import failure_report, sensitivity, sensitivity_reason
from ringqa.sweep.execute import auto_batch_size
from ringqa.sweep.fast import (
    calibrate,
    calibrate_one,
    cheap_sample,
    prepared,
    record_from_positions,
)
from ringqa.sweep.runner import run_sample
from ringqa.sweep.sampling import design
from ringqa.sweep.store import StoredSamples
from ringqa.sweep.study import calibration_indices, job_of


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    from tests.sweep.conftest import write_spec

    spec = load_spec(write_spec(tmp_path_factory.mktemp("fast"), samples=8))
    return spec, job_of(spec), design(spec)


def test_cheap_samples_within_their_reported_error_of_full_runs(small):
    """Calibrate on samples 0-2 (cheap and full each), then samples 3-6, NOT calibrated: every
    dwell of the cheap sample lies within its reported numerical error of the full commissioning
    run with the same parameters (the full run's refined positions). The bound is the
    calibration's max of (cheap-full distance + the full run's own error), so it is at least the
    full runs' error (> 0) and the cheap samples are not the full runs (distance > 0)."""
    _spec, job, table = small
    bound = calibrate([calibrate_one(job, i, table[i]) for i in range(3)], 14)
    assert bound.error_mm.shape == (14,) and np.all(bound.error_mm > 0)
    for i in range(3, 7):
        cheap = cheap_sample(job, i, table[i], bound.error_mm)
        full = run_sample(job, i, table[i])
        assert cheap.ok and full.ok
        dist = np.linalg.norm(cheap.positions_mm - full.positions_mm, axis=1)
        assert 0 < dist.max()
        assert np.all(dist <= cheap.dwell["numerical_error_mm"]), (i, dist, bound.error_mm)


def test_cheap_outputs_are_the_pipelines_for_the_same_positions(small):
    """Given the full run's own positions, the cheap path's deviations (distance, along,
    radial, out of plane) equal the full commissioning run's to rounding: the prepared
    reference, registration and ring frame are the pipeline's."""
    _spec, job, table = small
    prep = prepared(job)
    full = run_sample(job, 2, table[2])
    pos_m = np.zeros((prep.advances_mm.size, 3))
    pos_m[prep.rows] = full.positions_mm * 1e-3
    dirs = np.tile([1.0, 0.0, 0.0], (prep.advances_mm.size, 1))
    rec = record_from_positions(prep, pos_m, dirs)
    for q in ("deviation_mm", "along_mm", "radial_mm", "out_of_plane_mm"):
        np.testing.assert_allclose(rec["dwell"][q], full.dwell[q], atol=1e-9)


def test_a_sample_past_its_budget_fails_and_says_so(small):
    _spec, job, table = small
    rec = cheap_sample(job, 0, table[0], None, budget_s=1e-9)
    assert not rec.ok and rec.message.startswith("BudgetExceeded: ")
    assert "time budget" in rec.message


def test_auto_batch_size_and_calibration_indices():
    """0.1 s samples: 5 per task for 0.5 s of work; with 16 workers and 64 samples at most 1
    per task (4 tasks per worker); indices spread over the design."""
    assert auto_batch_size(0.1, 10_000, 2) == 5
    assert auto_batch_size(0.1, 64, 16) == 1
    assert auto_batch_size(5.0, 1000, 4) == 1
    assert calibration_indices(100, 5) == [0, 25, 50, 74, 99]
    assert calibration_indices(3, 5) == [0, 1, 2]


def _stored(values, ok, messages):
    n = len(ok)
    return StoredSamples(
        index=np.arange(n),
        values=np.asarray(values, float),
        ok=np.asarray(ok, bool),
        message=list(messages),
        seconds=np.zeros(n),
        cpu_seconds=np.zeros(n),
        worker=[""] * n,
        arrays={
            k: np.where(np.asarray(ok)[:, None], 1.0 + np.asarray(values, float)[:, :1], np.nan)
            for k in ("x_mm", "y_mm", "z_mm", "deviation_mm", "dose_diff_pct")
        },
        parameters=("a", "d"),
        dwells=(1,),
        points=("p",),
    )


def test_failure_report_names_the_parameter_the_failures_go_with():
    """Failures exactly at |d| >= 0.35 (d centred on 0) and a uniform ``a`` with no link: the
    report calls out |d| with its threshold and none of the successes past it."""
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 1, 40)
    d = np.linspace(-0.4, 0.4, 40)
    ok = np.abs(d) < 0.35
    msgs = ["" if g else "SceneError: cannot pass" for g in ok]
    rep = failure_report(_stored(np.column_stack([a, d]), ok, msgs), ("a", "d"), (0.5, 0.0))
    assert rep["n_failed"] == int((~ok).sum()) and rep["reasons"] == {
        "SceneError": int((~ok).sum())
    }
    top = rep["links"][0]
    assert top["form"] == "|d|" and top["side"] == ">=" and top["ok_share"] == 0.0
    assert top["threshold"] == pytest.approx(np.abs(d[~ok]).min())
    assert "conditional on success" in rep["text"] and "|d| >=" in rep["text"]
    assert all(link["parameter"] != "a" for link in rep["links"])


def test_sensitivity_reason_when_too_few_samples_succeed():
    """3 successes for 2 varied parameters: no regression coefficients, and the file's
    ``method`` column says why in one line."""
    vals = np.array([[0.1, 0.2], [0.3, 0.1], [0.5, 0.4], [0.7, 0.9]])
    s = _stored(vals, [True, True, True, False], ["", "", "", "SceneError: x"])
    reason = sensitivity_reason(s, ("a", "d"))
    assert "3 successful samples for 2 varied parameters" in reason
    sens = sensitivity(s, ("a", "d"), None)
    assert (sens["method"] == reason).all() and sens["src"].isna().all()


def test_shipped_spec_displacement_makes_no_impossible_channel():
    """The shipped example's centreline displacement (sd 0.2 mm), 24 samples: every displaced
    channel's tightest bend stays within 10 % of the nominal channel's (6.1 mm radius; the
    rigid 4.5 mm capsule needs >= 0.9 mm in this lumen). Before the rotation-minimising frame,
    samples 6 and 7 (0.36 and -0.37 mm) had a 0.8 mm kink where the stem meets the bend."""
    from ringqa.pipeline.uncertainty import Perturbation, perturbed_engine

    spec = load_spec("data/sweeps/ring26-uncertainty.toml", {"samples": 24})
    job, table = job_of(spec), design(spec)
    ch = prepared(job).channel
    j = spec.names.index("centreline.displacement_mm")

    def min_radius_mm(channel):
        s = np.linspace(0.0, channel.centreline.length_m, 3000)
        return 1e-3 / float(np.max(channel.centreline.curvature(s)))

    nominal = min_radius_mm(ch)
    for i in range(24):
        p = Perturbation.from_values({spec.names[j]: table[i][j]}, (spec.seed, i))
        scene = perturbed_engine(p).scene_for_channel(ch, "flexitron")
        assert min_radius_mm(scene.channel) >= 0.9 * nominal, (i, table[i][j])
