"""``ringqa needle`` end to end: one channel, a reduced sweep, and bad input (exit 2, one line,
nothing written)."""

from __future__ import annotations

import json
import math

import pandas as pd
import pytest

import ringqa.needle.sweep as sweep_module
from ringqa.cli import main

#: issue-14 contract columns, written out (not imported from the code under test)
FORCE_COLUMNS = ("depth_mm", "force_n")
PEAK_COLUMNS = ("peak1_n", "peak1_depth_mm", "plateau_n", "plateau_depth_mm", "peak2_n",
                "peak2_depth_mm")  # fmt: skip
SWEEP_PEAKS = ("family", "radius_mm", "torsion_rad", "diameter_mm", "nominal_diameter_mm",
               "peak1_n", "plateau_n", "peak2_n", "status")  # fmt: skip
SWEEP_FORCES = ("family", "radius_mm", "torsion_rad", "diameter_mm", "depth_mm", "force_n")


def test_one_channel_writes_the_contract_files(tmp_path, capsys):
    """Default: the paper's r = 35 mm, tau = 0, 2.6 mm channel: force_depth.csv (0..120 mm every
    0.25 mm, 481 rows, finite), force_depth.png, peaks.csv (one row: 1st peak before the
    2nd, plateau below both), run.json (status 0, settings scene, timings, versions), exit 0 and
    a one-line summary."""
    out = tmp_path / "one"
    assert main(["needle", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    assert len(printed) == 1 and "1st peak" in printed[0]
    forces = pd.read_csv(out / "force_depth.csv")
    assert list(forces.columns[:2]) == list(FORCE_COLUMNS)
    assert len(forces) == 481 and forces["depth_mm"].iloc[-1] == pytest.approx(120.0)
    assert forces["force_n"].notna().all()
    peaks = pd.read_csv(out / "peaks.csv")
    assert len(peaks) == 1 and set(PEAK_COLUMNS) <= set(peaks.columns)
    row = peaks.iloc[0]
    assert row["peak1_depth_mm"] < row["plateau_depth_mm"] < row["peak2_depth_mm"]
    assert row["plateau_n"] < row["peak1_n"] < row["peak2_n"]
    assert (out / "force_depth.png").stat().st_size > 10_000
    rec = json.loads((out / "run.json").read_text())
    assert rec["status"] == 0 and rec["channel"]["radius_mm"] == 35.0
    assert rec["scene"]["instrument"]["preset"] == "catheter"
    assert rec["timings"]["solve_time_s"] > 0 and "numba" in rec["versions"]
    assert "depth" in rec and "plateau" in rec["definitions"]


def test_geometry_options_and_set(tmp_path):
    """--radius-mm/--torsion-rad/--diameter-mm choose the paper channel (the others keep their
    defaults); --set changes a setting (0.5 mm increments: 241 depths)."""
    out = tmp_path / "r60"
    rc = main(["needle", "--out", str(out), "--radius-mm", "60", "--torsion-rad", "0.5",
               "--set", "solver.increment_mm=0.5", "--quiet"])  # fmt: skip
    assert rc == 0
    peaks = pd.read_csv(out / "peaks.csv").iloc[0]
    assert (peaks["radius_mm"], peaks["torsion_rad"], peaks["diameter_mm"]) == (60.0, 0.5, 2.6)
    assert len(pd.read_csv(out / "force_depth.csv")) == 241


def test_scene_with_its_own_channel(tmp_path):
    """A SCENE without geometry options runs its own channel (needle-s-curve: two 60 deg bends of
    R 40 mm, 113.8 mm long, so the insertion stops there); its two bends are found."""
    out = tmp_path / "own"
    assert main(["needle", "needle-s-curve", "--out", str(out), "--quiet"]) == 0
    rec = json.loads((out / "run.json").read_text())
    assert rec["channel"]["source"] == "scene file"
    assert len(rec["bends_mm"]) == 2
    assert rec["depth"]["insertion_mm"] == pytest.approx(20 + 2 * 40 * math.pi / 3 + 10, abs=0.01)
    peaks = pd.read_csv(out / "peaks.csv").iloc[0]
    assert math.isnan(peaks["radius_mm"]) and peaks["peak2_n"] > peaks["peak1_n"] > 0


def test_sweep_writes_the_contract_files(tmp_path, monkeypatch, capsys):
    """--sweep paper on a reduced grid (radii 20 and 60 mm, torsions 0 and pi; the diameter
    family whole): 4 + 4 + 6 = 14 rows from 10 channels on two processes; peaks.csv and
    force_depth.csv with the contract columns, both figures, run.json; exit 0."""
    monkeypatch.setattr(sweep_module, "PAPER_RADII_MM", (20.0, 60.0))
    monkeypatch.setattr(sweep_module, "PAPER_TORSIONS_RAD", (0.0, math.pi))
    out = tmp_path / "sweep"
    assert main(["needle", "--sweep", "paper", "--out", str(out), "--quiet"]) == 0
    assert "14 rows, 10 channels" in capsys.readouterr().out
    peaks = pd.read_csv(out / "peaks.csv")
    assert list(peaks.columns[:5]) == list(SWEEP_PEAKS[:5]) and set(SWEEP_PEAKS) <= set(peaks)
    assert len(peaks) == 14 and (peaks["status"] == 0).all()
    forces = pd.read_csv(out / "force_depth.csv")
    assert list(forces.columns[:6]) == list(SWEEP_FORCES) and len(forces) == 14 * 481
    for name in ("figure8_force_depth.png", "figure9_peaks.png"):
        assert (out / name).stat().st_size > 20_000
    rec = json.loads((out / "run.json").read_text())
    assert rec["n_rows"] == 14 and rec["n_simulated"] == 10 and rec["workers"] == 2


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--radius-mm", "8"], "--radius-mm 8: too tight for the catheter to pass"),
        (["--diameter-mm", "1.9"], "--diameter-mm 1.9: the channel must be wider than the"),
        (["--torsion-rad", "3.5"], "--torsion-rad 3.5: the torsion must lie in 0..pi"),
        (["--torsion-rad", "-0.1"], "--torsion-rad -0.1: the torsion must lie in 0..pi"),
        (["--sweep", "curvature"], "--sweep curvature: unknown family 'curvature'"),
        (["--sweep", "paper", "--radius-mm", "30"], "--radius-mm: not with --sweep"),
        (["--set", "solver.increment_mm=-1"], "solver.increment_mm"),
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, args, words):
    out = tmp_path / "bad"
    assert main(["needle", "--out", str(out), "--quiet", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ringqa needle: error: ")
    assert words in err[0]
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_sweep_reports_a_run_the_engine_refuses(tmp_path, monkeypatch):
    """A channel the engine refuses to set up (here: a SimulationError forced for r = 20 mm)
    becomes two rows with status -1, the reason and no forces; the other rows are simulated, the
    files are written, and the exit status is 3 (a run failed)."""
    from ringqa.errors import SimulationError

    real = sweep_module.run_channel

    def refuse_r20(channel, settings, *args, **kwargs):
        if channel.name.startswith("s-r20-"):
            raise SimulationError("forced for the test")
        return real(channel, settings, *args, **kwargs)

    monkeypatch.setattr(sweep_module, "run_channel", refuse_r20)
    monkeypatch.setattr(sweep_module, "PAPER_RADII_MM", (20.0, 60.0))
    out = tmp_path / "sweep"
    rc = main(["needle", "--sweep", "radius", "--workers", "1", "--out", str(out), "--quiet"])
    assert rc == 3
    peaks = pd.read_csv(out / "peaks.csv")
    bad = peaks[peaks["radius_mm"] == 20.0]
    assert (bad["status"] == -1).all() and (bad["message"] == "forced for the test").all()
    assert bad["peak1_n"].isna().all()
    assert (peaks.loc[peaks["radius_mm"] == 60.0, "status"] == 0).all()
    assert json.loads((out / "run.json").read_text())["status"] == -1
