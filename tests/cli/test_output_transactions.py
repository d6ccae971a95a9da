"""Output folders as transactions (issue 18): replaced whole, foreign folders refused, signals,
left-overs of killed runs and operating-system errors, through the command line."""

from __future__ import annotations

import errno
import importlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import ringqa.simulation as sim
from ringqa.cli import main
from tests.accuracy.conftest import FakeSimulator
from tests.cli.test_commission_cli import fake_world  # noqa: F401  (fixture)

MARKER = ".ringqa-output.json"
REPO = Path(__file__).resolve().parents[2]
SCENE = REPO / "data" / "scenes" / "ring13-push100.toml"
PAPER_LINKS = ["--set", "discretisation.element_length_mm.thin=3.0"]

#: where the report writers look up write_tables (patched to fail or be interrupted)
report = importlib.import_module("ringqa.report")


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


@pytest.mark.usefixtures("fake_world")
def test_rerun_replaces_an_earlier_batch_output_completely(tmp_path, capsys):
    """A batch, then one applicator into the same --out: no applicator folder, batch.json or
    summary.pdf of the batch survives; then a --no-pdf run removes the earlier report.pdf and
    report.html."""
    out = tmp_path / "out"
    args = ["--out", str(out), "--quiet", "--centreline-reference"]
    assert main(["commission", "fake26", "nopath", *args]) == 0
    assert {"fake26", "nopath", "batch.json", "summary.pdf", MARKER} <= set(_names(out))
    assert main(["commission", "nopath", *args]) == 0
    single = _names(out)
    assert "report.pdf" in single and MARKER in single
    assert not {"fake26", "nopath", "batch.json", "summary.pdf"} & set(single)
    assert main(["commission", "nopath", "--no-pdf", *args]) == 0
    assert set(_names(out)) == set(single) - {"report.pdf", "report.html"}  # both with the PDF
    assert json.loads((out / MARKER).read_text())["command"] == "commission"
    assert _names(tmp_path) == ["out"]  # nothing hidden left beside it
    capsys.readouterr()


@pytest.mark.usefixtures("fake_world")
def test_foreign_folder_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    """A non-empty folder ringqa did not write: exit 2, one line naming the folder and a file,
    nothing simulated, the folder untouched."""
    out = tmp_path / "results"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    pc = importlib.import_module("ringqa.pipeline.commission")
    monkeypatch.setattr(pc, "load_input", lambda item: pytest.fail("work started"))
    assert main(["commission", "fake26", "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line == (
        f"ringqa commission: error: --out {out}: holds files ringqa did not write: notes.txt; "
        "ringqa never deletes them (move them out of the folder, or choose an empty or new "
        "folder)"
    )
    assert _tree(out) == {"notes.txt": b"mine"}
    assert _names(tmp_path) == ["results"]


@pytest.mark.usefixtures("fake_world")
def test_empty_existing_folder_is_written(tmp_path, capsys):
    out = tmp_path / "empty"
    out.mkdir()
    assert main(["commission", "fake26", "--out", str(out), "--no-pdf"]) == 0
    assert {"results.json", MARKER} <= set(_names(out))
    capsys.readouterr()


@pytest.mark.usefixtures("fake_world")
def test_leftover_staging_of_a_dead_process_is_removed(tmp_path, capsys):
    """A staging folder named with a pid that no longer runs (a SIGKILLed run): removed at the
    start of the next run, with one line on stderr."""
    out = tmp_path / "out"
    left = tmp_path / f".out.staging-{_dead_pid()}-k1ll3d00"
    left.mkdir()
    (left / "dwells.csv").write_text("partial")
    assert main(["commission", "fake26", "--out", str(out), "--no-pdf"]) == 0
    err = _one_line(capsys.readouterr().err)
    assert f"removed left-over staging folder {left} from an interrupted run" in err
    assert _names(tmp_path) == ["out"]


@pytest.mark.usefixtures("fake_world")
def test_full_disk_during_the_move_exits_2_and_keeps_the_earlier_output(
    tmp_path, capsys, monkeypatch
):
    """ENOSPC when the staging folder is renamed into place: one line naming --out, the reason
    and the fix, exit 2; the earlier output unchanged and no hidden folder left."""
    out = tmp_path / "out"
    assert main(["commission", "fake26", "--out", str(out), "--no-pdf"]) == 0
    before = _tree(out)
    capsys.readouterr()
    real_replace, real_rename = os.replace, os.rename

    def full(real):
        def rename(src, dst, *a, **k):
            if ".staging-" in str(src):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(src))
            return real(src, dst, *a, **k)

        return rename

    monkeypatch.setattr(os, "replace", full(real_replace))
    monkeypatch.setattr(os, "rename", full(real_rename))
    assert main(["commission", "nopath", "--centreline-reference", "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line == (
        f"ringqa commission: cannot write {out}: No space left on device (free disk space, or "
        "choose a folder on another disk)"
    )
    assert _tree(out) == before
    assert _names(tmp_path) == ["out"]


@pytest.mark.usefixtures("fake_world")
def test_read_only_while_writing_exits_2_with_nothing_written(tmp_path, capsys, monkeypatch):
    """EROFS while a file is written into the staging folder: one line, exit 2, nothing left."""

    def read_only(result, folder):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(Path(folder) / "dwells.csv"))

    monkeypatch.setattr(report, "write_tables", read_only)
    out = tmp_path / "out"
    assert main(["commission", "fake26", "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"ringqa commission: cannot write {out}: Read-only file system (")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("root", ["/proc", "/sys"])
@pytest.mark.usefixtures("fake_world")
def test_out_under_proc_or_sys_exits_2_in_one_line(capsys, root):
    if not Path(root).is_dir():
        pytest.skip(f"no {root} here")
    out = Path(root) / "ringqa-test-out" / "out"
    assert main(["commission", "fake26", "--out", str(out), "--no-pdf"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("ringqa commission:") and str(out) in line
    assert not out.parent.exists()


@pytest.mark.parametrize(("signum", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
@pytest.mark.usefixtures("fake_world")
def test_signal_while_staging_exits_non_zero_and_leaves_nothing(
    tmp_path, capsys, monkeypatch, signum, status
):
    """The process receives SIGTERM / SIGINT while the report is being staged: exit 143 / 130,
    one line, the staging folder removed, no output folder, the handler restored. (A shell
    starts background jobs with SIGINT ignored, and ringqa keeps an ignored signal ignored, so
    the test gives the signal its interactive handler first.)"""
    interactive = signal.default_int_handler if signum == signal.SIGINT else signal.SIG_DFL
    previous = signal.signal(signum, interactive)
    try:
        _interrupt_while_staging(tmp_path, capsys, monkeypatch, signum, status)
    finally:
        signal.signal(signum, previous)


def _interrupt_while_staging(tmp_path, capsys, monkeypatch, signum, status):
    before = signal.getsignal(signal.SIGTERM)

    def interrupted(result, folder):
        (Path(folder) / "dwells.csv").write_text("partial")
        os.kill(os.getpid(), signum)
        time.sleep(5)  # the handler raises before this ends

    monkeypatch.setattr(report, "write_tables", interrupted)
    assert main(["commission", "fake26", "--out", str(tmp_path / "out")]) == status
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"ringqa commission: interrupted by {signal.Signals(signum).name}")
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) is before


@pytest.mark.usefixtures("fake_world")
def test_sigterm_inside_an_import_is_still_an_interruption(tmp_path, capsys, monkeypatch):
    """SIGTERM while the report imports a library whose class body has a descriptor (as
    matplotlib's ScalarFormatter does): Python 3.11 turns the OutputInterrupted raised in
    ``__set_name__`` into ``RuntimeError`` from it (a real ``--all-shipped`` run exited 1 with a
    traceback that way). Still exit 143, one line, nothing left, the handler restored."""
    before = signal.getsignal(signal.SIGTERM)

    class Descriptor:
        def __set_name__(self, owner, name):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # the handler raises before this ends

    def importing(result, folder):
        (Path(folder) / "dwells.csv").write_text("partial")
        type("Formatter", (), {"order": Descriptor()})  # a class body being executed

    monkeypatch.setattr(report, "write_tables", importing)
    assert main(["commission", "fake26", "--out", str(tmp_path / "out")]) == 143
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("ringqa commission: interrupted by SIGTERM")
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_runtime_error_without_a_signal_keeps_its_traceback():
    """A RuntimeError that no signal caused is a bug: it is raised, not turned into an exit
    status (the cause chain is looked at, not the type)."""
    from ringqa.cli import _interruption_in
    from ringqa.outdir import OutputInterrupted

    plain = RuntimeError("a bug")
    assert _interruption_in(plain) is None
    try:
        try:
            raise OutputInterrupted(signal.SIGTERM)
        except OutputInterrupted as stop:
            raise RuntimeError("Error calling __set_name__") from stop
    except RuntimeError as wrapped:
        found = _interruption_in(wrapped)
    assert isinstance(found, OutputInterrupted) and found.exit_status == 143


def test_accuracy_resumes_from_the_cache_of_an_interrupted_run(tmp_path, monkeypatch, capsys):
    """An interrupted first study leaves only runs.jsonl (no marker): the next run accepts the
    folder, reuses every cached run, and the replaced folder still holds the cache."""
    fake = FakeSimulator()
    monkeypatch.setattr(sim, "simulate", fake, raising=False)
    out = tmp_path / "acc"
    cmd = ["accuracy", str(SCENE), "--out", str(out), "--repeats", "1", "--quiet", *PAPER_LINKS]
    assert main(cmd) == 0
    for p in out.iterdir():
        if p.name != "runs.jsonl":
            p.unlink()
    calls = fake.calls
    assert main(cmd) == 0
    assert fake.calls == calls
    assert {"runs.jsonl", "accuracy.csv", MARKER} <= set(_names(out))
    assert main(cmd) == 0 and fake.calls == calls  # and again, from a marked folder
    capsys.readouterr()


@pytest.mark.slow
def test_sigterm_during_a_real_batch_leaves_no_staging_and_no_output(tmp_path):
    """A real `ringqa commission --all-shipped` process gets SIGTERM once its staging folder
    exists: it exits non-zero and leaves neither the staging folder nor a partial --out."""
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "ringqa", "commission", "--all-shipped", "--out", str(out)],
        env=env,
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 180
        staging = []
        while time.monotonic() < deadline and proc.poll() is None and not staging:
            staging = list(tmp_path.glob(".out.staging-*"))
            time.sleep(0.01)
        assert staging, f"no staging folder appeared (exit {proc.poll()})"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    assert "interrupted by SIGTERM" in err
    assert list(tmp_path.iterdir()) == []


class _Broken:
    """A standard output whose reader went away (``| head``) or whose disk is full."""

    def __init__(self, err: int) -> None:
        self.err = err

    def write(self, text):
        raise OSError(self.err, os.strerror(self.err))

    def flush(self):
        raise OSError(self.err, os.strerror(self.err))


@pytest.mark.parametrize("err", [errno.EPIPE, errno.ENOSPC])
def test_a_closed_or_full_stdout_does_not_fail_a_finished_run(tmp_path, capsys, monkeypatch, err):
    """stdout raising EPIPE / ENOSPC on every write: the run still exits 0, its folder is
    complete, and stderr says once that stdout could not be written (exit status the run's)."""
    out = tmp_path / "demo"
    monkeypatch.setattr(sys, "stdout", _Broken(err))
    assert main(["tg43-demo", "--out", str(out)]) == 0
    assert (out / MARKER).is_file() and (out / "provenance.json").is_file()
    line = _one_line(capsys.readouterr().err)
    assert "standard output could not be written" in line and "(0)" in line


def test_log_file_on_a_full_device_is_refused_before_any_work(tmp_path, capsys):
    """--log-file /dev/full: opening works, the first line cannot be written: exit 2 at once,
    one line naming the option and the reason; no output folder."""
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full on this system")
    out = tmp_path / "demo"
    assert main(["--log-file", "/dev/full", "tg43-demo", "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "--log-file /dev/full: cannot be written: No space left on device" in line
    assert not out.exists()


def test_log_file_that_fills_up_during_the_run_gives_one_warning(tmp_path, capsys, monkeypatch):
    """The log file's disk fills after the first line: one warning line, no logging traceback,
    the run's exit status (0) and a complete folder."""
    import ringqa.cli as cli

    real = cli._open_log_file

    def filling(path):
        fh = real(path)
        fh.stream.write = _Broken(errno.ENOSPC).write
        return fh

    monkeypatch.setattr(cli, "_open_log_file", filling)
    out = tmp_path / "demo"
    assert (
        main(["-v", "--log-file", str(tmp_path / "run.log"), "tg43-demo", "--out", str(out)]) == 0
    )
    err = capsys.readouterr().err
    assert "Traceback" not in err and "Logging error" not in err
    assert err.count("--log-file") == 1 and "No space left on device" in err
    assert (out / MARKER).is_file()


@pytest.mark.parametrize("kind", ["symlink", "dot", "log_inside"])
def test_bad_out_or_log_file_is_refused_before_any_work(tmp_path, capsys, monkeypatch, kind):
    """A symbolic-link --out, --out ., a --log-file inside --out: exit 2 at once with the
    reason; nothing written anywhere."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    argv = {
        "symlink": ["tg43-demo", "--out", "link"],
        "dot": ["tg43-demo", "--out", "."],
        "log_inside": ["--log-file", "o/log.txt", "tg43-demo", "--out", "o"],
    }[kind]
    word = {"symlink": "symbolic link", "dot": "current folder", "log_inside": "inside --out"}
    assert main(argv) == 2
    assert word[kind] in _one_line(capsys.readouterr().err)
    assert _names(tmp_path) == ["link", "real"] and _names(tmp_path / "real") == []


def test_control_characters_are_escaped_on_the_terminal(capsys):
    """An ANSI escape and a carriage return in text printed while a command runs (a plan's
    applicator name in a message) reach the terminal as visible escapes."""
    from ringqa.cli import terminal_streams

    with terminal_streams():
        print("applicator ring\x1b[2J\rPASS")
        print("note", file=sys.stderr)
    out = capsys.readouterr()
    assert out.out == "applicator ring\\x1b[2J\\x0dPASS\n" and out.err == "note\n"
