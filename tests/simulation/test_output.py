"""Simulation outputs: dwells.csv contract columns, run.json keys, HDF5 units; the CLI's exits."""

from __future__ import annotations

import json
import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import ringqa.simulation as sim
from ringqa.cli import main
from ringqa.provenance import display_path
from ringqa.simulation.output import write_outputs
from ringqa.simulation.scenefile import load_scene, scene_to_dict

#: the issue-4 contract, written out here so that a change to the code's list cannot pass
CONTRACT_COLUMNS = ("advance_mm", "x_mm", "y_mm", "z_mm", "dir_x", "dir_y", "dir_z", "push_force_n",
                    "s_mm", "offset_mm")  # fmt: skip

SCENE = Path(__file__).resolve().parents[2] / "data" / "scenes" / "arc-frictionless.toml"


def fake_result(scene, status=0, advances_mm=None):
    """Source on the centreline at each advance, offset 0.5 mm along +z (so offset_mm = 0.5)."""
    adv = (
        np.array(scene.motion.advances_m) if advances_mm is None else np.asarray(advances_mm) / 1e3
    )
    cl = scene.channel.centreline
    pos = cl.position(adv) + np.array([0.0, 0.0, 0.5e-3])
    n = adv.size
    return types.SimpleNamespace(
        status=status,
        message={0: "success", 1: "jammed: push force above 50 N", -1: "failed"}[status],
        advances_mm=adv * 1e3,
        source_pos_m=pos,
        source_dir=cl.tangent(adv),
        tip_pos_m=pos,
        push_force_n=np.linspace(0.1, 0.5, n),
        contact_force_n=np.zeros((n, 4)),
        newton_iters=np.full(n, 4),
        s_m=adv,
        offset_m=np.full(n, 0.5e-3),
        n_elements=120,
        solve_time_s=0.01,
        settings={"kind": scene.solver.kind, "increment_m": scene.solver.increment_m},
        warnings=("transition zone shrunk",),
        work={"input": 1.0, "elastic": 0.9},
        trajectory={"advance_m": adv, "push_force_n": np.ones(n)},
    )


def test_outputs_follow_the_contract(tmp_path):
    """dwells.csv: contract columns in mm (offset 0.5 mm, s_mm = advance for the fake);
    run.json: status, solve_time_s, n_elements, settings, the scene (re-loadable), provenance;
    trajectory.h5: units and format_version attributes."""
    import h5py

    scene = load_scene(SCENE)
    res = fake_result(scene)
    write_outputs(tmp_path, res, scene, inputs=[SCENE], trajectory=True)
    table = pd.read_csv(tmp_path / "dwells.csv")
    assert list(table.columns[: len(CONTRACT_COLUMNS)]) == list(CONTRACT_COLUMNS)
    assert len(table) == len(scene.motion.advances_m)
    assert table["offset_mm"].to_numpy() == pytest.approx(0.5)
    assert table["s_mm"].to_numpy() == pytest.approx(table["advance_mm"].to_numpy(), abs=1e-6)
    run = json.loads((tmp_path / "run.json").read_text())
    for key in ("status", "solve_time_s", "n_elements", "settings", "scene", "provenance"):
        assert key in run
    assert run["status"] == 0 and run["n_elements"] == 120 and run["newton_iters_total"] > 0
    assert display_path(SCENE) in run["provenance"]["inputs"]  # ringqa:data/scenes/...
    again = load_scene(run["scene"])
    assert scene_to_dict(again) == scene_to_dict(scene)
    with h5py.File(tmp_path / "trajectory.h5") as h5:
        assert h5.attrs["format_version"] == "1.0"
        assert h5["dwells/source_position"].attrs["units"] == "mm"
        assert h5["dwells/source_position"][:] == pytest.approx(res.source_pos_m * 1e3)
        assert h5["trajectory/advance_m"].attrs["units"] == "m"


class _FakeEngine:
    def __init__(self, status=0):
        self.status = status
        self.scenes = []

    def __call__(self, scene, advances_mm=None, progress=False):
        self.scenes.append(scene)
        return fake_result(scene, self.status, advances_mm)


@pytest.mark.parametrize(("status", "code"), [(0, 0), (1, 1), (-1, 3)])
def test_cli_simulate_exit_codes(tmp_path, monkeypatch, status, code):
    """0 success, 1 jammed, 3 failed; outputs written in every case (a jam is a result)."""
    engine = _FakeEngine(status)
    monkeypatch.setattr(sim, "simulate", engine, raising=False)
    out = tmp_path / "out"
    rc = main(["simulate", str(SCENE), "--out", str(out), "--set", "solver.increment_mm=0.25",
               "--quiet"])  # fmt: skip
    assert rc == code
    assert engine.scenes[0].solver.increment_m == pytest.approx(2.5e-4)
    assert json.loads((out / "run.json").read_text())["status"] == status
    assert (out / "dwells.csv").is_file() and not (out / "trajectory.h5").exists()


def test_cli_simulate_bad_input_exits_2_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sim, "simulate", _FakeEngine(), raising=False)
    out = tmp_path / "out"
    rc = main(["simulate", str(SCENE), "--out", str(out), "--set", "solver.increment_mm=-1"])
    assert rc == 2
    assert "solver.increment_mm: got -1" in capsys.readouterr().err
    assert not out.exists()


def test_cli_simulate_trajectory_flag(tmp_path, monkeypatch):
    monkeypatch.setattr(sim, "simulate", _FakeEngine(), raising=False)
    out = tmp_path / "out"
    assert main(["simulate", str(SCENE), "--out", str(out), "--trajectory", "--quiet"]) == 0
    assert (out / "trajectory.h5").is_file()
