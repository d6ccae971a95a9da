"""``ringqa accuracy`` end to end on the fake simulator (the engine is replaced, not the study)."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pandas as pd

import ringqa.simulation as sim
from ringqa.cli import main
from tests.accuracy.conftest import FakeSimulator

SCENE = Path(__file__).resolve().parents[2] / "data" / "scenes" / "ring13-push100.toml"
#: the fake's error model (conftest) is sized for the paper's 3 mm thin links: with them its
#: reference converges within the default levels
PAPER_LINKS = ["--set", "discretisation.element_length_mm.thin=3.0"]


#: issue 6 contract columns, written out (not imported from the code under test)
CONTRACT_COLUMNS = ("time_s", "max_err_mm", "median_err_mm", "max_err_deg", "status", "pareto")


def test_cli_accuracy_writes_the_contract_files(tmp_path, monkeypatch, capsys):
    """accuracy.csv (contract columns, one row per run), accuracy.png, recommended.toml (a
    loadable scene), exit 0; a second invocation resumes (no new simulator calls)."""
    fake = FakeSimulator()
    monkeypatch.setattr(sim, "simulate", fake, raising=False)
    out = tmp_path / "acc"
    rc = main(["accuracy", str(SCENE), "--out", str(out), "--target-mm", "0.1", "--repeats", "1",
               "--quiet", *PAPER_LINKS])  # fmt: skip
    assert rc == 0, capsys.readouterr()
    table = pd.read_csv(out / "accuracy.csv")
    assert set(CONTRACT_COLUMNS) <= set(table.columns)
    assert table["pareto"].any()
    assert (out / "accuracy.png").stat().st_size > 10_000
    rec = tomllib.loads((out / "recommended.toml").read_text())
    from ringqa.simulation.scenefile import load_scene

    assert load_scene(rec).solver.kind == "quasistatic"
    info = json.loads((out / "study.json").read_text())
    assert info["reference"]["converged"] is True
    calls = fake.calls
    assert main(["accuracy", str(SCENE), "--out", str(out), "--repeats", "1", "--quiet",
                 *PAPER_LINKS]) == 0  # fmt: skip
    assert fake.calls == calls


def test_cli_accuracy_unreachable_target_exits_1(tmp_path, monkeypatch):
    monkeypatch.setattr(sim, "simulate", FakeSimulator(), raising=False)
    out = tmp_path / "acc"
    rc = main(["accuracy", str(SCENE), "--out", str(out), "--target-mm", "1e-9", "--repeats", "1",
               "--quiet"])  # fmt: skip
    assert rc == 1
    assert (out / "accuracy.csv").is_file() and not (out / "recommended.toml").exists()


def test_cli_accuracy_bad_target_exits_2(tmp_path, capsys):
    rc = main(["accuracy", str(SCENE), "--out", str(tmp_path / "x"), "--target-mm", "-1"])
    assert rc == 2
    assert "--target-mm" in capsys.readouterr().err
