"""``ringqa commission --uncertainty N`` / ``--sweep SPEC``: the uncertainty figure and the
intervals land beside the report; a bad spec is refused before any simulation."""

from __future__ import annotations

import pandas as pd
import pytest

from ringqa.cli import main
from ringqa.sweep.analysis import SUMMARY_COLUMNS
from tests.report.conftest import pdf_pages_text


@pytest.mark.slow
def test_commission_with_uncertainty_writes_figure_and_intervals(tmp_path, capsys):
    """Two samples of the shipped spec's parameters on ring26x60 (a local cluster of this
    machine's cores): uncertainty.png and uncertainty.csv (the summary's contract columns, every
    dwell of dwells.csv present) are written next to dwells.csv, and the report's last page is
    the uncertainty page."""
    out = tmp_path / "out"
    code = main(["commission", "ring26x60", "--out", str(out), "--quiet", "--uncertainty", "2"])
    assert code == 0, capsys.readouterr().err
    csv = pd.read_csv(out / "uncertainty.csv")
    assert tuple(csv.columns) == SUMMARY_COLUMNS
    dwells = pd.read_csv(out / "dwells.csv")
    simulated = dwells[dwells["path"] == "simulated"]["dwell"]
    assert set(csv["dwell"].dropna().astype(int)) == set(simulated)
    assert (csv[csv["quantity"] == "deviation_mm"]["n_ok"] == 2).all()
    assert (out / "uncertainty.png").stat().st_size > 10_000
    last = pdf_pages_text(out / "report.pdf")[-1]
    assert "Uncertainty of the simulated positions and doses" in last
    assert "2 of 2 sampled commissioning runs succeeded" in last


def test_commission_with_a_bad_sweep_spec_writes_nothing(tmp_path, capsys):
    spec = tmp_path / "bad.toml"
    spec.write_text(
        "samples = 2\nseed = 1\ninput = 'x'\n[parameters.'contact.mu_k']\n"
        "distribution = 'normal'\nmean = 0.2\nsd = 0\n"
    )
    out = tmp_path / "out"
    assert main(["commission", "ring26x60", "--out", str(out), "--sweep", str(spec)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sd = 0: a standard deviation must be > 0" in err
    assert not out.exists()


def test_the_sweep_takes_the_commissioning_settings(tmp_path):
    """``commission --register plane-height --cable microselectron --uncertainty 4``: the sweep
    spec (the shipped one, which has no [settings]) gets the command's registration, cable,
    prescription and action level, so the uncertainty page judges the same comparison as the
    report's verdicts; its samples and input are the command's."""
    import argparse

    from ringqa.cli.commission import sweep_spec_for
    from ringqa.pipeline import CommissionSettings

    settings = CommissionSettings(register="plane-height", cable="microselectron",
                                  prescription_gy=6.5, dose_action_pct=4.0)  # fmt: skip
    args = argparse.Namespace(sweep=None, uncertainty=4)
    spec = sweep_spec_for(args, "ring26x60", settings)
    assert spec.samples == 4
    assert spec.settings["register"] == "plane-height"
    assert spec.settings["cable"] == "microselectron"
    assert spec.settings["prescription_gy"] == 6.5 and spec.settings["dose_action_pct"] == 4.0
