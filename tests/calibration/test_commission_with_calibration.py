"""``ringqa commission`` with the calibration's outputs (issue 26, item 3) and with the clinic's
own measured file (``--measured``, item 1)."""

from __future__ import annotations

import json

import pytest

from ringqa.cli import main
from ringqa.provenance import sha256_of
from tests.calibration.conftest import synthetic
from tests.calibration.test_calibrate_cli import _film
from tests.report.conftest import pdf_pages_text


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A calibration of mu_k on a synthetic film of ring26x60 (Flexitron cable)."""
    tmp = tmp_path_factory.mktemp("cal")
    film = _film(tmp, synthetic(noise_mm=0.1, seed=5))
    out = tmp / "cal"
    assert main(["calibrate", "ring26x60", "--measured", str(film), "--fit", "contact.mu_k",
                 "--cable", "flexitron", "--out", str(out)]) == 0  # fmt: skip
    return out


def test_report_names_the_calibration_file_and_its_sha256(calibrated, tmp_path):
    """--config calibrated_cable.toml: results.json settings.calibration gives the file, its
    SHA-256 (recomputed here), the calibrate command and the SHA-256 of calibration.json (also
    recomputed); the PDF's settings page prints the file's SHA-256; the file is among the
    provenance's inputs; the fitted mu_k is the scene's."""
    toml = calibrated / "calibrated_cable.toml"
    out = tmp_path / "site"
    assert main(["commission", "ring30x60", "--config", str(toml), "--out", str(out)]) == 0
    data = json.loads((out / "results.json").read_text())
    rec = data["settings"]["calibration"]
    assert rec["sha256"] == sha256_of(toml)
    assert rec["calibration_json_sha256"] == sha256_of(calibrated / "calibration.json")
    assert rec["command"].startswith("ringqa calibrate ring26x60 --measured ") and rec[
        "file"
    ].endswith("calibrated_cable.toml")
    fitted = json.loads((calibrated / "calibration.json").read_text())
    mu_k = fitted["parameters"]["contact.mu_k"]["value"]
    assert data["settings"]["scene_overrides"]["contact.mu_k"] == pytest.approx(mu_k, rel=1e-5)
    assert rec["sha256"] in data["provenance"]["inputs"].values()
    text = " ".join(pdf_pages_text(out / "report.pdf")).replace("\r", "").replace("\n", "")
    assert rec["sha256"][:32] in text


def test_a_plain_configuration_names_no_calibration(tmp_path):
    """A configuration without [calibration]: no settings.calibration key (the results of
    every other run are unchanged)."""
    cfg = tmp_path / "site.toml"
    cfg.write_text('[scene]\n"contact.mu_k" = 0.18\n')
    out = tmp_path / "site"
    assert main(["commission", "ring26x60", "--config", str(cfg), "--no-pdf",
                 "--out", str(out)]) == 0  # fmt: skip
    data = json.loads((out / "results.json").read_text())
    assert "calibration" not in data["settings"] and "measured_points" not in data


def test_commission_rt_plan_with_measured_subset(tmp_path, capsys):
    """``ringqa commission PLAN.dcm --measured film.csv``: results.json measured_points names
    the plan's path (library) and the measured positions with their sd and status."""
    from ringqa.datasets import example_plan
    from tests.pipeline.test_measured_points import _film_subset

    film, rel = _film_subset(tmp_path)
    out = tmp_path / "site"
    code = main(["commission", str(example_plan()), "--measured", str(film), "--no-pdf",
                 "--out", str(out)])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    mp = json.loads((out / "results.json").read_text())["measured_points"]
    assert mp["plan_path"] == "library" and mp["relative_position_mm"] == rel.tolist()
    assert set(mp["status"]) <= {"PASS", "WARN", "FAIL", "NOT RESOLVABLE", "-"}


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["ring26x60", "ring30x60"], r"--measured .*: give one applicator"),
        (["ring26x60"], r"nothere\.csv: file not found"),
    ],
)
def test_commission_measured_refusals(tmp_path, capsys, args, match):
    import re

    out = tmp_path / "site"
    code = main(["commission", *args, "--measured", str(tmp_path / "nothere.csv"),
                 "--out", str(out)])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and re.search(match, err), err
    assert not out.exists()
