"""``ringqa commission`` in-process, with the stand-in applicators and engine (must-show 4)."""

from __future__ import annotations

import importlib
import json

import pandas as pd
import pytest

from ringqa.cli import main
from ringqa.pipeline.inputs import LoadedInput
from tests.pipeline.fakes import fake_engine, fake_simulator, make_applicator

# the module (ringqa.pipeline's attribute 'commission' is the function)
pc = importlib.import_module("ringqa.pipeline.commission")
# where the pipeline looks up its default engine
ps = importlib.import_module("ringqa.pipeline.simulate")

FAKES = {
    "fake26": lambda: make_applicator(),
    "narrow": lambda: make_applicator(name="narrow", r_b=0.3e-3),
    "nopath": lambda: make_applicator(name="nopath", n_measured=0),
    "jam": lambda: make_applicator(name="jam"),
}


@pytest.fixture
def fake_world(monkeypatch):
    """Inputs named in FAKES load stand-in applicators; 'jam' gets an engine that jams."""

    def load(item):
        name = str(item)
        if name not in FAKES:
            from ringqa.errors import RingQAError

            raise RingQAError(f"{name}: no such applicator")
        return LoadedInput(FAKES[name](), None, "folder" if name == "nopath" else "shipped", ())

    ok, jam = fake_simulator(), fake_simulator(jam_after=3)

    def simulator(scene, advances_mm=None, progress=False):
        if scene.channel is current["channel"] and current["name"] == "jam":
            return jam(scene, advances_mm=advances_mm)
        return ok(scene, advances_mm=advances_mm)

    current = {"name": None, "channel": None}

    def loader(item):
        loaded = load(item)
        current["name"], current["channel"] = str(item), loaded.applicator.channel("ring")
        return loaded

    monkeypatch.setattr(pc, "load_input", loader)
    monkeypatch.setattr(ps, "default_engine", lambda: fake_engine(simulator))


def test_single(fake_world, tmp_path, capsys):
    out = tmp_path / "out"
    assert (
        main(["commission", "fake26", "--out", str(out), "--set", "solver.increment_mm=0.5"]) == 0
    )
    assert "fake26 (measured reference)" in capsys.readouterr().out
    data = json.loads((out / "results.json").read_text())
    assert data["settings"]["scene_overrides"] == {"solver.increment_mm": 0.5}
    assert (out / "report.pdf").is_file()


@pytest.mark.parametrize(
    ("name", "message", "status"),
    [
        ("jam", "jammed after advance", 3),  # the simulation failed: exit status 3
        ("narrow", "cannot pass", 2),  # bad input: 2
        ("nopath", "no measured source path", 2),
        ("missing", "no such applicator", 2),
    ],
)
def test_failures_are_one_line_and_leave_nothing(
    fake_world, tmp_path, capsys, name, message, status
):
    out = tmp_path / "out"
    assert main(["commission", name, "--out", str(out)]) == status
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # no report, no staging folder


def test_unwritable_output(fake_world, tmp_path, capsys):
    target = tmp_path / "file.txt"
    target.write_text("x")
    assert main(["commission", "fake26", "--out", str(target)]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_centreline_reference_flag(fake_world, tmp_path):
    out = tmp_path / "out"
    assert main(["commission", "nopath", "--out", str(out), "--centreline-reference"]) == 0
    assert json.loads((out / "results.json").read_text())["reference"] == "centreline"


def test_batch_completes_around_a_failure(fake_world, tmp_path, capsys):
    out = tmp_path / "all"
    code = main(["commission", "fake26", "jam", "nopath", "--out", str(out), "--quiet",
                 "--centreline-reference"])  # fmt: skip
    assert code == 3  # one simulation jammed (the others' files are written)
    captured = capsys.readouterr()
    assert "2 of 3 applicators" in captured.out
    assert "jam" in captured.err and "jammed" in captured.err
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary["verdict"] == "ERROR") == [False, True, False]
    assert (out / "fake26" / "report.pdf").is_file() and (out / "summary.pdf").is_file()


def test_bad_set(fake_world, tmp_path, capsys):
    assert main(["commission", "fake26", "--out", str(tmp_path / "o"), "--set", "novalue"]) == 2
    assert "KEY=VALUE" in capsys.readouterr().err


EXAMPLE = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"


@pytest.mark.slow
def test_oncentra_example(repo_root, tmp_path):
    """Must-show 1: the report lists measured, simulated and centreline dwells with distances,
    Point A = 7 Gy within 0.1 %, and the RT Plan's TPS points beside the TPS doses."""
    out = tmp_path / "onc"
    assert main(["commission", str(repo_root / EXAMPLE), "--out", str(out)]) == 0
    dwells = pd.read_csv(out / "dwells.csv")
    assert set(dwells["path"]) == {"measured", "simulated", "centreline"}
    assert dwells.loc[dwells.path != "measured", "dist_to_measured_mm"].notna().all()
    doses = pd.read_csv(out / "doses.csv")
    a = doses[(doses.plan == "measured") & (doses.kind == "point_a")]["dose_gy"]
    assert a.mean() == pytest.approx(7.0, rel=1e-3)
    own = doses[doses.plan == "rtplan"]
    assert set(own["point"]) == {"A1", "A2", "Bladder", "ICRU"} and own["tps_dose_gy"].notna().all()
    assert (out / "report.pdf").stat().st_size > 10_000


@pytest.mark.slow
def test_all_shipped(tmp_path, capsys):
    """Must-show 2: one command, six reports and the cross-applicator summary."""
    out = tmp_path / "all"
    assert main(["commission", "--all-shipped", "--out", str(out), "--quiet"]) == 0
    summary = pd.read_csv(out / "summary.csv")
    assert len(summary) == 6 and set(summary["reference"]) == {"centreline"}
    assert all((out / name / "report.pdf").is_file() for name in summary["applicator"])
    assert (out / "summary.pdf").is_file()


@pytest.mark.slow
def test_folder_of_applicators(tmp_path):
    """A folder holding two shipped rings saved as applicator JSON files is a batch of two."""
    from ringqa.io.applicator_file import load_applicator, save_applicator

    rings = tmp_path / "rings"
    rings.mkdir()
    for name in ("ring26x60", "ring30x45"):
        save_applicator(load_applicator(name), rings / f"{name}.json")
    out = tmp_path / "out"
    code = main(["commission", str(rings), "--out", str(out), "--quiet", "--no-pdf",
                 "--centreline-reference"])  # fmt: skip
    assert code == 0
    assert len(pd.read_csv(out / "summary.csv")) == 2


def test_empty_folder_is_refused(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert main(["commission", str(tmp_path / "empty"), "--out", str(tmp_path / "o")]) == 2
    assert "no applicator in this folder" in capsys.readouterr().err


def test_real_jam_is_clean(tmp_path, capsys):
    """The real engine with a 0.05 N jam threshold jams on the way into ring26x60: exit 3 (a
    simulation failure), one line naming the jam, and no output folder."""
    out = tmp_path / "out"
    args = ["commission", "ring26x60", "--out", str(out), "--set", "solver.jam_force_n=0.05"]
    code = main([*args, "--quiet"])
    assert code == 3
    err = capsys.readouterr().err.strip()
    assert "jammed" in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_user_folder_with_measured_path(tmp_path):
    """A user's folder (applicator.json + centreline.csv + measured_path.csv): the measured path is
    the ring26x60 centreline at s_ref - p (p = 0, 2.5, ..., 50 mm, all on the circle) moved 0.5 mm
    radially outward, so centreline vs measured is 0.5 mm at every dwell (radial -0.5 mm), and the
    report compares against the MEASURED path."""
    import json as _json

    import numpy as np

    from ringqa.io.applicator_file import load_applicator
    from ringqa.io.points import write_points

    ring = load_applicator("ring26x60").channel("ring")
    folder = tmp_path / "my_ring"
    folder.mkdir()
    s = np.linspace(0, ring.centreline.length_m, 600)
    write_points(folder / "centreline.csv", ring.centreline.position(s))
    p = ring.centreline.position(ring.s_ref_m - np.arange(21) * 2.5e-3)
    outward = p.copy()
    outward[:, 2] = 0
    outward /= np.linalg.norm(outward, axis=1)[:, None]
    write_points(folder / "measured_path.csv", p + 0.5e-3 * outward)
    meta = {"format": "ringqa-applicator", "format_version": 1, "name": "my_ring", "units": "mm",
            "lumen": {"kind": "circular", "r_b_mm": 1.5, "r_a_mm": 1.4},
            "s_ref_mm": ring.s_ref_m * 1e3, "measured_step_mm": 2.5,
            "ring_frame": {"centre_mm": [0, 0, 0], "normal": [0, 0, 1], "lateral": [1, 0, 0],
                           "radius_mm": 13.0}}  # fmt: skip
    (folder / "applicator.json").write_text(_json.dumps(meta))
    out = tmp_path / "out"
    assert main(["commission", str(folder), "--out", str(out), "--quiet", "--no-pdf"]) == 0
    dwells = pd.read_csv(out / "dwells.csv")
    cl = dwells[dwells.path == "centreline"]
    assert len(cl) == 21
    np.testing.assert_allclose(cl["dist_to_measured_mm"], 0.5, atol=0.01)
    np.testing.assert_allclose(cl["radial_mm"], -0.5, atol=0.01)
    assert json.loads((out / "results.json").read_text())["reference"] == "measured"


@pytest.mark.slow
def test_batch_of_two_plans_of_the_same_model_keeps_both(tmp_path, repo_root, capsys):
    """Two copies of the example RT Plan (the same applicator model, same name) in one batch:
    two subfolders (the name, then the name with "-2"), each with its report and ringqa's marker,
    and two rows in summary.csv (coarse settings: only the folders and rows are checked)."""
    import shutil

    plan = repo_root / EXAMPLE
    a, b = tmp_path / "RP_a.dcm", tmp_path / "RP_b.dcm"
    shutil.copy(plan, a)
    shutil.copy(plan, b)
    out = tmp_path / "out"
    fast = [
        "--set",
        "solver.increment_mm=1.0",
        "--set",
        "discretisation.element_length_mm.cable=3.0",
    ]
    code = main(["commission", str(a), str(b), "--out", str(out), "--quiet", *fast])
    assert code == 0, capsys.readouterr().err
    summary = pd.read_csv(out / "summary.csv")
    assert len(summary) == 2
    folders = sorted(p for p in out.iterdir() if p.is_dir())
    assert len(folders) == 2 and folders[1].name == folders[0].name + "-2"
    for f in folders:
        assert (f / "report.pdf").stat().st_size > 10_000
        assert (f / ".ringqa-output.json").exists()


def test_labels_name_the_batch_folders_and_the_reports(fake_world, tmp_path):
    """``--label SN-1 --label SN-1`` on two inputs: folders SN-1 and SN-1-2 (a repeated label
    never shares a folder), summary.csv's ``folder`` column and each report's "Label" field
    say which is which."""
    from tests.report.conftest import pdf_pages_text

    out = tmp_path / "out"
    argv = ["commission", "fake26", "fake26", "--out", str(out), "--quiet",
            "--label", "SN-1", "--label", "SN-1"]  # fmt: skip
    assert main(argv) == 0
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["SN-1", "SN-1-2"]
    assert list(pd.read_csv(out / "summary.csv")["folder"]) == ["SN-1", "SN-1-2"]
    first_page = pdf_pages_text(out / "SN-1-2" / "report.pdf")[0]
    assert "Label SN-1-2" in " ".join(first_page.split())


def test_label_on_a_single_run_is_printed(fake_world, tmp_path):
    from tests.report.conftest import pdf_pages_text

    out = tmp_path / "out"
    assert main(["commission", "fake26", "--out", str(out), "--quiet", "--label", "SN 4711"]) == 0
    assert "Label SN 4711" in " ".join(pdf_pages_text(out / "report.pdf")[0].split())


def test_labels_must_be_one_per_input(fake_world, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["commission", "fake26", "fake26", "--out", str(out), "--label", "A"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "1 label(s) for 2 input(s)" in err
    assert not out.exists()


def test_strict_exit_status(fake_world, tmp_path, capsys):
    """A verdict ACTION (a 0.0001 % dose action level, which any dose difference exceeds):
    exit status 0 without --strict, 1 with it or with report.strict = true; the files are
    written either way. --help documents the statuses."""
    args = ["commission", "fake26", "--dose-action-pct", "0.0001", "--quiet", "--no-pdf"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    data = json.loads((tmp_path / "a" / "results.json").read_text())
    assert any(v["status"] == "ACTION" for v in data["verdicts"]) and not data["passed"]
    assert main([*args, "--strict", "--out", str(tmp_path / "b")]) == 1
    assert (tmp_path / "b" / "results.json").is_file()
    site = tmp_path / "site.toml"
    site.write_text("[report]\nstrict = true\n")
    assert main([*args, "--config", str(site), "--out", str(tmp_path / "c")]) == 1
    # all PASS/WARN (a 50 % action level) with --strict: 0
    assert main(["commission", "fake26", "--strict", "--quiet", "--no-pdf", "--dose-action-pct",
                 "50", "--out", str(tmp_path / "d")]) == 0  # fmt: skip
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["commission", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for line in ("0 every verdict PASS or WARN", "1 a verdict FAIL or ACTION with --strict",
                 "2 bad input", "3 the simulation", "130", "143"):  # fmt: skip
        assert line in text, line


def test_log_file_is_an_audit_trail(fake_world, tmp_path):
    """--log-file: the input, every setting with its origin, every verdict of results.json,
    every file written with its SHA-256 (computed here with hashlib), the exit status and the
    wall time."""
    import hashlib

    out, log = tmp_path / "out", tmp_path / "audit.log"
    assert main(["--log-file", str(log), "commission", "fake26", "--out", str(out),
                 "--quiet", "--dose-action-pct", "4"]) == 0  # fmt: skip
    text = log.read_text(encoding="utf-8")
    assert "input: fake26 (shipped" in text
    assert "setting: tolerances.dose_action_pct = 4.0 (command line)" in text
    assert "setting: tolerances.position_required_mm = 2.0 (default)" in text
    data = json.loads((out / "results.json").read_text())
    for v in data["verdicts"]:
        assert f"verdict: fake26: {v['status']} {v['check']}: " in text, v["check"]
    files = sorted(p for p in out.rglob("*") if p.is_file())
    assert len(files) >= 6
    for p in files:
        digest = hashlib.sha256(p.read_bytes()).hexdigest()
        assert f"file written: {p.relative_to(out).as_posix()} (" in text
        assert digest in text, p.name
    assert "exit status 0 (" in text and "wall time" in text


def test_files_not_hashed_for_a_log_nobody_reads(tmp_path, monkeypatch, caplog):
    """audit_files reads and hashes the written files only when the log's INFO lines go
    somewhere (``-v``, ``--log-file``): at the command line's default level (warnings) no file
    is hashed; at INFO each file is logged with its size and SHA-256 (hashlib here)."""
    import hashlib
    import logging

    import ringqa.provenance
    from ringqa.cli.commission import audit_files

    (tmp_path / "a.csv").write_text("x\n1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.json").write_text("{}")
    hashed = []
    real = ringqa.provenance.sha256_of
    monkeypatch.setattr(ringqa.provenance, "sha256_of", lambda p: hashed.append(p) or real(p))
    caplog.set_level(logging.WARNING, logger="ringqa")
    audit_files(tmp_path)
    assert hashed == [] and "file written" not in caplog.text
    caplog.set_level(logging.INFO, logger="ringqa")
    audit_files(tmp_path)
    assert len(hashed) == 2
    for name in ("a.csv", "sub/b.json"):
        digest = hashlib.sha256((tmp_path / name).read_bytes()).hexdigest()
        assert f"file written: {name} ({(tmp_path / name).stat().st_size} bytes, SHA-256 " \
               f"{digest})" in caplog.text  # fmt: skip
    assert "2 file(s) written in" in caplog.text


@pytest.mark.slow
def test_example_is_the_readme_quick_start(tmp_path):
    """``ringqa commission --example`` gives README's quick start (its command read from
    README.md, the example plan registered with plane-height): the same verdicts, values and
    summary numbers."""
    import re
    import shlex
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    job = next(m.group(1) for m in re.finditer(r"^ {4}(\S.*)$", section, re.M)
               if "ringqa commission" in m.group(1))  # fmt: skip
    words = shlex.split(job)[1:]  # without .venv/bin/ringqa
    words[words.index("--out") + 1] = str(tmp_path / "readme")
    assert words[0] == "commission" and "--register" in words
    root = Path(__file__).resolve().parents[2]
    words = [str(root / w) if w.endswith(".dcm") else w for w in words]
    assert main([*words, "--no-pdf", "--quiet"]) == 0
    assert main(["commission", "--example", "--out", str(tmp_path / "ex"), "--no-pdf",
                 "--quiet"]) == 0  # fmt: skip
    a = json.loads((tmp_path / "readme" / "results.json").read_text())
    b = json.loads((tmp_path / "ex" / "results.json").read_text())
    assert [(v["check"], v["status"]) for v in a["verdicts"]] == [
        (v["check"], v["status"]) for v in b["verdicts"]
    ]
    for va, vb in zip(a["verdicts"], b["verdicts"], strict=True):
        assert va["value"] == pytest.approx(vb["value"], abs=1e-9), va["check"]
    assert a["summary"]["registration"] == b["summary"]["registration"] == "plane-height"
    for key, value in a["summary"].items():
        if isinstance(value, float) and key != "solve_time_s":
            assert b["summary"][key] == pytest.approx(value, abs=1e-9, nan_ok=True), key
    assert a["conclusion"] == b["conclusion"]


@pytest.mark.parametrize(
    "command",
    ["tg43-demo", "import", "simulate", "accuracy", "commission", "needle", "config", "sweep",
     "warmup"],
)  # fmt: skip
def test_help_has_no_markup(command, capsys):
    """Every command's --help reads as text: no reST markup (``x``, :func:, **x**) and no
    developer history ("contract of issue 3")."""
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = capsys.readouterr().out
    for word in ("``", ":func:", ":class:", ":mod:", "**", "contract of issue"):
        assert word not in text, (command, word)


def test_unknown_scene_lists_the_shipped_ones(tmp_path, capsys):
    """``ringqa simulate ring99``: exit 2, one line naming the shipped scenes."""
    assert main(["simulate", "ring99", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "ring26-flexitron" in err and "ring13-push100" in err


def test_audit_reuses_the_markers_checksums(tmp_path, monkeypatch, caplog):
    """A folder with ringqa's marker (ringqa.outdir.write_markers lists every file with its
    size, time and SHA-256): audit_files hashes only what the marker does not vouch for - the
    marker itself and a file changed after it was written - and every logged digest is the
    file's own (hashlib here)."""
    import hashlib
    import logging

    import ringqa.provenance
    from ringqa.cli.commission import audit_files
    from ringqa.outdir import MARKER_NAME, write_markers

    (tmp_path / "a.csv").write_text("x\n1\n")
    (tmp_path / "b.json").write_text("{}")
    write_markers(tmp_path)
    (tmp_path / "b.json").write_text('{"changed": 1}')  # another size: not the listed file
    hashed = []
    real = ringqa.provenance.sha256_of
    monkeypatch.setattr(ringqa.provenance, "sha256_of", lambda p: hashed.append(p) or real(p))
    caplog.set_level(logging.INFO, logger="ringqa")
    audit_files(tmp_path)
    assert sorted(p.name for p in hashed) == sorted(["b.json", MARKER_NAME])
    for name in ("a.csv", "b.json", MARKER_NAME):
        digest = hashlib.sha256((tmp_path / name).read_bytes()).hexdigest()
        assert f"file written: {name} ({(tmp_path / name).stat().st_size} bytes, SHA-256 " \
               f"{digest})" in caplog.text  # fmt: skip
