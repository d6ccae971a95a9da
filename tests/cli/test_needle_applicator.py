"""``ringqa needle --applicator``: the catheter pushed through a free-form (3-D printed style)
channel, data/applicators/free-form-s (a 60 deg then a 90 deg bend, both of radius 20 mm, in
different planes; the first bend spans arc length 60-80.9 mm, the second 90.9-122.3 mm)."""

from __future__ import annotations

import json

import pandas as pd

from ringqa.cli import main
from ringqa.paths import data_dir


def test_needle_through_the_free_form_channel(tmp_path):
    """Both peaks lie in their bends (1st in 60-91 mm, 2nd in 91-123 mm), and each is at least
    the frictionless force of pushing the catheter round a bend, EI / (2 rho^2)
    (shared/reference/mechanics.md item 1) with the catheter on the outer wall: rho = 20 mm +
    (1.3 - 0.99) mm = 20.31 mm, 1.2e-2 / (2 * 0.02031^2) = 14.55 N."""
    out = tmp_path / "ff"
    folder = data_dir() / "applicators" / "free-form-s"
    assert main(["needle", "--applicator", str(folder), "--out", str(out), "--quiet"]) == 0
    row = pd.read_csv(out / "peaks.csv").iloc[0]
    assert 60.0 <= row["peak1_depth_mm"] <= 91.0
    assert 91.0 <= row["peak2_depth_mm"] <= 123.0
    assert row["peak1_n"] >= 14.5 and row["peak2_n"] >= 14.5
    assert json.loads((out / "run.json").read_text())["status"] == 0


def test_a_lumen_narrower_than_the_catheter_is_refused(tmp_path, capsys):
    """A 1.9 mm lumen cannot take the paper's 1.98 mm catheter: exit 2, one line, nothing
    written."""
    src = data_dir() / "applicators" / "free-form-s"
    (tmp_path / "app").mkdir()
    (tmp_path / "app" / "centreline.csv").write_text((src / "centreline.csv").read_text())
    doc = json.loads((src / "applicator.json").read_text())
    (tmp_path / "app" / "applicator.json").write_text(json.dumps({**doc, "lumen_diameter_mm": 1.9}))
    out = tmp_path / "out"
    assert main(["needle", "--applicator", str(tmp_path / "app"), "--out", str(out)]) == 2
    assert "cannot pass" in capsys.readouterr().err
    assert not out.exists()
