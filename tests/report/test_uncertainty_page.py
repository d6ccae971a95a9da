"""The report's uncertainty page (``commission --sweep``): which verdicts hold across the sampled
parameters, laid out as one extra report section."""

from __future__ import annotations

import math

import pandas as pd

from ringqa.report import write_report
from ringqa.report.uncertainty import interval_verdicts, uncertainty_section
from tests.report.conftest import pdf_pages_text


def _summary() -> pd.DataFrame:
    """Two dwells and two points in the sweep's summary.csv layout."""
    rows = [
        {"dwell": 1, "point": "", "quantity": "deviation_mm", "mean": 0.4, "p97_5": 0.9},
        {"dwell": 2, "point": "", "quantity": "deviation_mm", "mean": 1.2, "p97_5": 2.1},
        {"dwell": 1, "point": "", "quantity": "shift_mm", "mean": 9.0, "p97_5": 9.0},
        {"dwell": "", "point": "A_left", "quantity": "dose_diff_pct", "p2_5": -3.0, "p97_5": 4.9},
        {"dwell": "", "point": "surface", "quantity": "dose_diff_pct", "p2_5": -5.1, "p97_5": 1.0},
        {"dwell": "", "point": "deep", "quantity": "dose_diff_pct", "p2_5": math.nan,
         "p97_5": math.nan},
    ]  # fmt: skip
    df = pd.DataFrame(rows)
    for col in ("mean", "sd", "p2_5", "p97_5"):
        if col not in df:
            df[col] = math.nan
    return df


def test_interval_verdicts_against_the_tolerances():
    """Required 2 mm, action 5 %: dwell 1 (p97.5 0.9 mm) holds, dwell 2 (2.1 mm) does not;
    A_left's interval [-3.0, +4.9] % lies within +/-5 %, the surface's [-5.1, +1.0] % does not,
    and a point without successful samples (NaN) never holds. Other quantities are ignored."""
    v = interval_verdicts(_summary(), required_mm=2.0, action_pct=5.0)
    assert [(d, ok) for d, _, _, ok in v["dwells"]] == [("1", True), ("2", False)]
    assert [(p, ok) for p, _, _, ok in v["points"]] == [
        ("A_left", True), ("surface", False), ("deep", False)
    ]  # fmt: skip


def test_the_report_gains_the_uncertainty_page(fake_result, tmp_path):
    """The section is the report's last page, with the sample count, what does not hold (the
    stand-in run's required tolerance and action level from its settings) and the dose table."""
    # the stand-in's standard points; "deep" is no dose point of the run: not judged
    names = {"A_left": "point_a_left", "surface": "surface_left"}
    summary = _summary().replace({"point": names})
    section = uncertainty_section(summary, None, {"n_ok": 7, "n_runs": 8})
    write_report(fake_result, tmp_path / "out", sections=[section],
                 extra_files={"uncertainty.csv": b"dwell\n"})  # fmt: skip
    last = pdf_pages_text(tmp_path / "out" / "report.pdf")[-1]
    assert "Uncertainty of the simulated positions and doses" in last
    assert "7 of 8 sampled commissioning runs" in last
    required = fake_result.settings.position_limits_mm[1]
    expect = "holds at all 2 dwells" if required >= 2.1 else "does NOT hold at 1 of 2 dwells"
    assert expect in last
    assert "surface_left" in last and "point_a_left" in last and "deep" not in last
    assert (tmp_path / "out" / "uncertainty.csv").read_bytes() == b"dwell\n"
