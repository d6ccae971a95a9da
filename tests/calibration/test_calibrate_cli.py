"""``ringqa calibrate`` end to end on a synthetic film measurement, and its refusals."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ringqa.cli import main
from ringqa.config import read_config_file
from ringqa.io.points import write_points
from ringqa.units import mm_to_m
from tests.calibration.conftest import synthetic


def _film(tmp_path, m, rows=None, name="film.csv", sd=True):
    """The synthetic measurement as a film CSV (relative positions, sd_mm, method film)."""
    p = tmp_path / name
    rows = range(m.relative_position_mm.size) if rows is None else rows
    lines = ["# method = film", "x_mm,y_mm,z_mm,relative_position_mm" + (",sd_mm" if sd else "")]
    for k in rows:
        x, y, z = m.measured_mm[k]
        lines.append(f"{x:.6f},{y:.6f},{z:.6f},{m.relative_position_mm[k]:g}"
                     + (",0.3" if sd else ""))  # fmt: skip
    p.write_text("\n".join(lines) + "\n")
    return p


def test_calibrate_writes_the_contract_files(tmp_path, capsys):
    m = synthetic(noise_mm=0.1, seed=5)
    film = _film(tmp_path, m)
    out = tmp_path / "cal"
    code = main(["calibrate", "ring26x60", "--measured", str(film), "--fit", "contact.mu_k",
                 "--cable", "flexitron", "--out", str(out)])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    for name in ("calibration.json", "calibrated_cable.toml", "residuals.csv",
                 "calibration.png", "calibration.pdf"):  # fmt: skip
        assert (out / name).is_file(), name
    data = json.loads((out / "calibration.json").read_text())
    p = data["parameters"]["contact.mu_k"]
    assert abs(p["value"] - 0.15) < 0.015 and p["identifiable"] is True
    assert p["standard_error"] > 0
    assert data["n_points"] == 9 and data["applicators"][0]["method"] == "film"
    assert data["residual_after"]["median_mm"] < data["residual_before"]["median_mm"]
    with open(out / "residuals.csv", newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.reader(fh))
    assert rows[0][:3] == ["applicator", "point", "relative_position_mm"]
    assert rows[0][-4:-1] == ["residual_before_mm", "residual_after_mm", "sd_mm"]
    assert len(rows) == 10 and float(rows[1][-2]) == pytest.approx(0.3)
    cfg = read_config_file(out / "calibrated_cable.toml")
    assert cfg["simulation.cable"] == "flexitron"
    assert cfg["scene.contact.mu_k"] == pytest.approx(p["value"], rel=1e-5)
    from ringqa.sweep import load_spec

    spec = load_spec(out / "calibration_sweep.toml")  # the fit's uncertainty as a sweep
    (par,) = spec.parameters
    assert par.key == "contact.mu_k" and par.distribution == "normal"


@pytest.mark.parametrize(
    ("rows", "args", "match"),
    [
        ([0, 1, 2], ["--fit", "contact.mu_k", "instrument.ei_scale"],
         r"3 measured point\(s\).*needs at least 4"),
        ([0, 2, 1, 3, 4, 5], [], r"relative_position_mm does not increase.*line 4"),
        (None, ["--fit", "contact.mu_x"], r"--fit contact\.mu_x: cannot be fitted"),
    ],
)  # fmt: skip
def test_bad_input_refused_nothing_written(tmp_path, capsys, rows, args, match):
    m = synthetic(noise_mm=0.0)
    film = _film(tmp_path, m, rows)
    out = tmp_path / "cal"
    code = main(["calibrate", "ring26x60", "--measured", str(film), "--cable", "flexitron",
                 "--out", str(out), *args])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2
    import re

    assert re.search(match, err), err
    assert not out.exists()


def test_point_outside_the_lumen_is_left_out_and_named(tmp_path, capsys):
    """A point moved 3 mm off the channel (the lumen allows about 1 mm): flagged, excluded
    from the fit, listed in calibration.json and residuals.csv."""
    m = synthetic(noise_mm=0.0)
    pts = m.measured_mm.copy()
    pts[4] += np.array([0.0, 0.0, 3.0])
    film = tmp_path / "film.csv"
    write_points(film, mm_to_m(pts), m.relative_position_mm)
    out = tmp_path / "cal"
    code = main(["calibrate", "ring26x60", "--measured", str(film), "--fit", "contact.mu_k",
                 "--cable", "flexitron", "--method", "ct", "--out", str(out)])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    data = json.loads((out / "calibration.json").read_text())
    app = data["applicators"][0]
    assert app["n_used"] == 8 and app["excluded"][0]["relative_position_mm"] == 25.0
    assert app["sd_assumed"] is True and app["method"] == "ct"
