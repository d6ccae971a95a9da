"""`ringqa import` in-process: the contract files of issue 3, notices, one-line errors (exit 2)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from ringqa.cli import main
from ringqa.io.points import read_point_set, read_points
from ringqa.provenance import display_path

EXAMPLE = ("data", "examples", "oncentra_ring26x60", "RP_ring26x60_oncentra43.dcm")


def test_import_oncentra_example(tmp_path, repo_root, capsys):
    """Contract files from the example plan: 13 dwells (6 ring 33.7216 s, 7 tandem), 4 points,
    both centrelines, the ring's 30-position measured path, provenance with the input's hash."""
    out = tmp_path / "imp"
    plan = repo_root.joinpath(*EXAMPLE)
    assert main(["import", str(plan), "--out", str(out)]) == 0
    dw = pd.read_csv(out / "dwells.csv")
    need = ["channel", "dwell", "relative_position_mm", "x_mm", "y_mm", "z_mm", "time_s"]
    assert list(dw.columns[:7]) == need and "dir_x" not in dw
    assert (dw.channel == 1).sum() == 6 and (dw.channel == 2).sum() == 7
    np.testing.assert_allclose(dw[dw.channel == 1].time_s, 202.329602 / 6, atol=1e-6)
    pts = pd.read_csv(out / "points.csv")
    assert list(pts.columns[:5]) == ["name", "x_mm", "y_mm", "z_mm", "tps_dose_gy"]
    assert dict(zip(pts.name, pts.tps_dose_gy, strict=True))["A1"] == 7.157785
    assert read_points(out / "centreline_ch1.csv").shape == (284, 3)
    assert read_points(out / "centreline_ch2.csv").shape == (287, 3)
    path = read_point_set(out / "measured_path_ch1.csv", kind="path")
    assert path.points_m.shape == (30, 3)
    # the ring dwell at relative position 5 mm is measured-path position 2 (5 / 2.5)
    ring0 = dw[dw.channel == 1].iloc[0][["x_mm", "y_mm", "z_mm"]].to_numpy(float)
    np.testing.assert_allclose(path.points_m[2] * 1e3, ring0, atol=1e-5)
    assert not (out / "measured_path_ch2.csv").exists()
    prov = json.loads((out / "provenance.json").read_text())
    assert display_path(plan, plan.parent) in prov["inputs"]  # no install paths
    summary = json.loads((out / "plan.json").read_text())
    assert summary["source"]["sk_U"] == 40820.0 and summary["source"]["tg43_name"] == "mhdr-v2"
    assert "13 dwells" not in capsys.readouterr().out  # per channel, not summed


def test_import_synthetic_plan_with_orientations_and_no_library(rtplan_factory, tmp_path, capsys):
    spec = {"number": 7, "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 20.0)],
            "orient": [(0, 0, 1), (0, 1, 0)]}  # fmt: skip
    out = tmp_path / "imp"
    assert main(["import", str(rtplan_factory([spec], orientation=True)), "--out", str(out)]) == 0
    dw = pd.read_csv(out / "dwells.csv")
    assert {"dir_x", "dir_y", "dir_z"} <= set(dw.columns)
    np.testing.assert_allclose(dw[["dir_x", "dir_y", "dir_z"]].to_numpy(), [[0, 0, 1], [0, 1, 0]])
    assert not list(out.glob("centreline_ch*.csv"))
    assert "no Oncentra applicator library" in capsys.readouterr().err


def test_import_broken_plan_is_one_line_exit_2(rtplan_factory, tmp_path, capsys):
    out = tmp_path / "imp"
    assert main(["import", str(rtplan_factory([])), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ringqa import: error: ") and "no channels" in err
    assert err.count("\n") == 1
    assert not out.exists()
