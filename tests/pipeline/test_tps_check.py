"""The RT Plan's own dwells against the TPS: an input check with an action level (issue 18).

ringqa and the TPS use the same TG-43 formalism and data, so the plan's own dwells and times,
dosed by ringqa, reproduce the TPS doses at the plan's points within about 1 % when the plan was
read right. A wrong channel time or source strength shows here first: times x 10 give +900 %.
A plan without a source strength cannot be checked (its doses scale with S_K), so the check is
skipped with a note instead of using a default strength.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pydicom
import pytest

from ringqa.pipeline import CommissionSettings, commission
from ringqa.pipeline.verdicts import CHECK_TPS, TPS_CHECK_ACTION_PCT, tps_verdict

EXAMPLE = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"
FAST = CommissionSettings(cable="flexitron")


def _table(diffs, tps=(7.0, 7.0, 4.0)) -> pd.DataFrame:
    return pd.DataFrame({
        "plan": ["rtplan"] * len(diffs) + ["simulated"],
        "point": [f"P{k}" for k in range(len(diffs))] + ["A"],
        "diff_pct": [*diffs, 50.0],
        "tps_dose_gy": [*tps[: len(diffs)], np.nan],
    })  # fmt: skip


def test_tps_verdict_judges_only_the_plans_own_rows():
    """Rows -0.3, 0.9, -1.2 % -> worst 1.2 % at P2, PASS; the simulated row's 50 % is not the
    TPS check's business."""
    v = tps_verdict(_table([-0.3, 0.9, -1.2]))
    assert v.check == CHECK_TPS and v.status == "PASS"
    assert v.value == pytest.approx(1.2)
    assert "P2" in v.text


def test_tps_verdict_acts_beyond_the_level():
    v = tps_verdict(_table([0.2, TPS_CHECK_ACTION_PCT + 0.01]))
    assert v.status == "ACTION"


def test_no_plan_rows_no_verdict():
    assert tps_verdict(_table([])) is None


def _edited_plan(repo_root, tmp_path, edit) -> str:
    ds = pydicom.dcmread(repo_root / EXAMPLE)
    edit(ds)
    out = tmp_path / "RP_edited.dcm"
    ds.save_as(out)
    return str(out)


@pytest.mark.slow
def test_the_example_passes_its_tps_check(repo_root):
    """The shipped plan: its own doses within 1.1 % of the TPS's at A1, A2, Bladder, ICRU."""
    res = commission(repo_root / EXAMPLE, FAST)
    v = next(v for v in res.verdicts if v.check == CHECK_TPS)
    assert v.status == "PASS" and v.value < 1.1
    assert res.verdicts[-1].check.startswith("numerics")


@pytest.mark.slow
def test_channel_times_ten_times_too_long_are_an_action(repo_root, tmp_path):
    """Every ChannelTotalTime x 10 -> the own doses x 10 (+900 %) at every TPS point: ACTION, in
    the conclusion and in the notes, with what to check."""

    def times_x10(ds):
        for setup in ds.ApplicationSetupSequence:
            for ch in setup.ChannelSequence:
                ch.ChannelTotalTime = float(ch.ChannelTotalTime) * 10

    res = commission(_edited_plan(repo_root, tmp_path, times_x10), FAST)
    v = next(v for v in res.verdicts if v.check == CHECK_TPS)
    assert v.status == "ACTION" and v.value == pytest.approx(900.0, rel=0.02)
    assert "TPS" in res.conclusion and "S_K" in res.conclusion
    assert any(n.startswith("TPS check ACTION") for n in res.notes)


@pytest.mark.slow
def test_a_plan_without_source_strength_is_not_checked_with_a_default(repo_root, tmp_path):
    """No ReferenceAirKermaRate: no TPS verdict and no rtplan dose rows (a default S_K would fake
    them), a note that says why and names --sk-u; the standard-plan doses are unchanged (their
    times are scaled to the prescription). With --sk-u (the plan's 40820 U) the check is back."""

    def no_sk(ds):
        for src in ds.SourceSequence:
            del src.ReferenceAirKermaRate

    path = _edited_plan(repo_root, tmp_path, no_sk)
    res = commission(path, FAST)
    assert not any(v.check == CHECK_TPS for v in res.verdicts)
    assert (res.doses["plan"] != "rtplan").all()
    assert any("--sk-u" in n for n in res.notes)
    ref = commission(repo_root / EXAMPLE, FAST)
    std = ref.doses[ref.doses["plan"] != "rtplan"].reset_index(drop=True)
    np.testing.assert_allclose(res.doses["dose_gy"], std["dose_gy"], rtol=1e-12)
    with_sk = commission(path, CommissionSettings(cable="flexitron", sk_U=40820.0))
    assert next(v for v in with_sk.verdicts if v.check == CHECK_TPS).status == "PASS"


def test_reader_notes_reach_the_commissioning_notes(tmp_path):
    """A folder whose centreline.csv has a Latin-1 comment line (German Excel) is read with a note;
    the note reaches the report's notes (issue 18: every stage's warnings reach the report)."""
    from ringqa.geometry.parametric import ring_applicator
    from ringqa.io.points import write_points

    ring = ring_applicator(26, 60).channel("ring")
    write_points(tmp_path / "centreline.csv", ring.centreline.points_m)
    rel_m = np.arange(0.0, 0.0301, 0.0025)
    write_points(tmp_path / "measured_path.csv", ring.centreline.position(ring.s_ref_m - rel_m))
    spec = {"name": "my ring", "lumen": {"kind": "circular", "r_b_mm": 1.5, "r_a_mm": 1.4},
            "measured_step_mm": 2.5, "s_ref_mm": "from_measured_path"}  # fmt: skip
    (tmp_path / "applicator.json").write_text(json.dumps(spec))
    cl = tmp_path / "centreline.csv"
    cl.write_bytes("# Länge gemessen, Bögen geprüft\n".encode("latin-1") + cl.read_bytes())
    res = commission(tmp_path, FAST)
    assert any("centreline.csv" in n and "Latin-1" in n for n in res.notes)
