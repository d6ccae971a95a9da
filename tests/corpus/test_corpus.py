"""The bad-input corpus (issue 18): every case ends as accepted and correct, a named warning, or a
clean refusal; never a traceback, never a half-written or stale output folder.

The inputs are generated once per session from the shipped examples
(``tests/corpus/make_corpus.py``) and each case runs in-process through ``ringqa.cli.main``.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import pytest

import ringqa.io.points as points
from ringqa.cli import main
from tests.corpus.make_corpus import CATEGORIES, Case, build

MARKER = ".ringqa-output.json"
#: the file each command's complete output holds besides the marker
REPORT_FILES = {"import": "plan.json", "commission": "results.json", "simulate": "run.json"}

#: the corpus is generated once, at collection, into this folder (removed by the fixture)
CORPUS_DIR = Path(tempfile.mkdtemp(prefix="ringqa-corpus-"))
ALL = build(CORPUS_DIR)


@pytest.fixture(scope="session")
def corpus() -> Path:
    """The corpus inputs (generated once per session); removed at the end."""
    yield CORPUS_DIR
    shutil.rmtree(CORPUS_DIR, ignore_errors=True)


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _argv(case: Case, corpus: Path, out: Path) -> list[str]:
    return [a.replace("{c}", str(corpus)).replace("{out}", str(out)) for a in case.argv]


def _run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's own refusals (a value that is not a number)
        return int(exc.code or 0)


def _break_writer(monkeypatch, action) -> None:
    """Every CSV writer (each command writes one into its staging folder) calls ``action``."""
    real = pd.DataFrame.to_csv

    def to_csv(self, path=None, *a, **k):
        if path is not None and ".staging-" in str(path):
            action(path)
        return real(self, path, *a, **k)

    monkeypatch.setattr(pd.DataFrame, "to_csv", to_csv)
    real_text = points.atomic_write_text

    def write_text(path, *a, **k):
        if ".staging-" in str(path):
            action(path)
        return real_text(path, *a, **k)

    monkeypatch.setattr(points, "atomic_write_text", write_text)


def _arrange(case: Case, corpus: Path, out: Path, monkeypatch, capsys) -> dict:
    """Set up the case's fault; return what must hold afterwards."""
    after: dict = {}
    setup = case.setup
    if setup == "out_is_file":
        out.write_text("a file, not a folder")
        after["unchanged"] = {out: out.read_bytes()}
    elif setup == "foreign":
        out.mkdir()
        (out / "notes.txt").write_text("mine")
        after["unchanged_tree"] = (out, _tree(out))
    elif setup == "input_folder":
        shutil.copytree(corpus / "ok", out)
        after["unchanged_tree"] = (out, _tree(out))
    elif setup in ("earlier", "sigterm_earlier", "earlier_user_file", "earlier_signed"):
        assert _run(_argv(case, corpus, out)) == 0
        (out / "dwells.csv").write_text("the earlier run's content, to be replaced")
        marker = json.loads((out / MARKER).read_text())
        for entry in marker["files"]:  # the earlier run's dwells.csv as its marker lists it
            if entry["path"] == "dwells.csv":
                content = b"the earlier run's content, to be replaced"
                entry.update(size=len(content), sha256=hashlib.sha256(content).hexdigest())
        (out / MARKER).write_text(json.dumps(marker))
        if setup == "earlier_user_file":
            (out / "notes.txt").write_text("the physicist's notes")
        if setup == "earlier_signed":
            (out / "plan.json").write_text('{"signed": "J. Jansen"}')
        if setup == "earlier":  # the marker lists every file: a new run replaces them
            after["changed_files"] = [out / "dwells.csv"]
        else:
            after["unchanged_tree"] = (out, _tree(out))
        capsys.readouterr()
    elif setup == "saved_during_rerun":
        assert _run(_argv(case, corpus, out)) == 0
        capsys.readouterr()

        def save_scan(path):
            (out / "scan.tif").write_bytes(b"film scan")

        _break_writer(monkeypatch, save_scan)
        after["kept"] = {out / "scan.tif": b"film scan"}
    elif setup == "saved_during":

        def save_notes(path):
            out.mkdir(exist_ok=True)
            (out / "notes.txt").write_text("saved while ringqa ran")

        _break_writer(monkeypatch, save_notes)
        after["kept"] = {out / "notes.txt": b"saved while ringqa ran"}
    elif setup == "symlink":
        real = out.parent / "real-folder"
        real.mkdir()
        (real / "mine.txt").write_text("mine")
        out.symlink_to(real)
        after["unchanged_tree"] = (real, _tree(real))
    elif setup == "stdout_epipe":

        class Closed:
            def write(self, text):
                raise BrokenPipeError(errno.EPIPE, "Broken pipe")

            def flush(self):
                raise BrokenPipeError(errno.EPIPE, "Broken pipe")

        monkeypatch.setattr(sys, "stdout", Closed())
    elif setup == "umask022":
        after["restore_umask"] = os.umask(0o022)
    elif setup == "no_raw_escape":
        after["no_raw_escape"] = True
    elif setup == "staging":
        left = out.parent / f".{out.name}.staging-{_dead_pid()}-k1ll3d00"
        left.mkdir()
        (left / "dwells.csv").write_text("partial")
    elif setup == "old_leftover":
        old = out.parent / f".{out.name}.old-{_dead_pid()}-k1ll3d00"
        old.mkdir()
        (old / "plan.json").write_text("{}")
        listed = {"path": "plan.json", "size": 2, "sha256": hashlib.sha256(b"{}").hexdigest()}
        (old / MARKER).write_text(
            json.dumps({"software": "ringqa", "files": [listed], "folders": []})
        )
    elif setup == "readonly":
        out.parent.chmod(0o555)
        if os.access(out.parent, os.W_OK):  # root: chmod does not stop writes
            out.parent.chmod(0o755)
            pytest.skip("running as root: a read-only folder is still writable")
        after["restore_mode"] = out.parent
    elif setup in ("enospc", "eacces"):
        code = errno.ENOSPC if setup == "enospc" else errno.EACCES

        def fail(path):
            raise OSError(code, os.strerror(code), str(path))

        _break_writer(monkeypatch, fail)
    elif setup in ("sigterm", "sigint") or setup == "sigterm_earlier":
        pass
    if setup in ("sigterm", "sigint", "sigterm_earlier", "sighup"):
        signum = {"sigint": signal.SIGINT, "sighup": signal.SIGHUP}.get(setup, signal.SIGTERM)
        interactive = signal.default_int_handler if signum == signal.SIGINT else signal.SIG_DFL
        after["restore_signal"] = (signum, signal.signal(signum, interactive))

        def interrupt(path):
            os.kill(os.getpid(), signum)
            time.sleep(5)  # the handler raises before this ends

        _break_writer(monkeypatch, interrupt)
    return after


def _check_out(case: Case, out: Path, after: dict) -> None:
    """``--out`` absent or complete (marker + report file), no hidden folder left beside it."""
    leftovers = [p.name for p in out.parent.glob(f".{out.name}.*")]
    assert not leftovers, leftovers
    for path, content in after.get("kept", {}).items():  # a user's file is never deleted
        assert path.read_bytes() == content, path
    if "kept" in after:
        return
    if "unchanged" in after:
        for path, content in after["unchanged"].items():
            assert path.read_bytes() == content
        return
    if "unchanged_tree" in after:
        folder, tree = after["unchanged_tree"]
        assert _tree(folder) == tree
        return
    if out.exists():
        assert (out / MARKER).is_file(), sorted(p.name for p in out.iterdir())
        report = REPORT_FILES[case.argv[0]]
        batch = (out / "batch.json").is_file()
        assert (out / ("summary.csv" if batch else report)).is_file()
    for path in after.get("changed_files", []):
        assert path.read_text() != "the earlier run's content, to be replaced", path
    if case.exit_code != 0 and case.check is None:  # a refusal writes nothing
        assert not out.exists()


def _check_warning(case: Case, out: Path, text: str) -> None:
    assert case.warning in text, text
    report = REPORT_FILES[case.argv[0]]
    data = json.loads((out / report).read_text())
    names = [w["name"] if isinstance(w, dict) else str(w) for w in data.get("warnings", [])]
    assert any(case.warning in n for n in names), data.get("warnings")
    if report == "results.json":  # the notes lead with it: the report's first page shows them
        assert any(n.startswith(f"Warning [{case.warning}]") for n in data["notes"])


def _params():
    for k in ALL:
        marks = [pytest.mark.slow] if k.slow else []
        yield pytest.param(k, id=f"{k.category}-{k.name}", marks=marks)


@pytest.mark.parametrize("case", list(_params()))
def test_case(case: Case, corpus: Path, tmp_path: Path, monkeypatch, capfd):
    out = tmp_path / f"out-{case.name}"
    argv = _argv(case, corpus, out)
    for key, value in case.env:
        monkeypatch.setenv(key, value)
    after = _arrange(case, corpus, out, monkeypatch, capfd)
    try:
        code = _run(argv)
    finally:
        if "restore_umask" in after:
            os.umask(after["restore_umask"])
        if "restore_mode" in after:
            after["restore_mode"].chmod(0o755)
        if "restore_signal" in after:
            signal.signal(*after["restore_signal"])
        monkeypatch.undo()
    cap = capfd.readouterr()
    text = cap.out + cap.err
    word = case.word.replace("{out}", str(out))
    assert "Traceback" not in text, text
    if after.get("no_raw_escape"):
        assert "\x1b" not in text, text
    assert code == case.exit_code, text
    assert word in text, text
    _check_out(case, out, after)
    if case.warning:
        _check_warning(case, out, text)
    if case.check is not None:
        case.check(out)


def test_corpus_covers_every_category_with_at_least_60_cases():
    """Issue 18: at least 60 cases across plans, libraries, folders, scenes, options, output
    and signals; every case one of: accepted (and checked), a named warning, a clean refusal."""
    assert len(ALL) >= 60
    assert {k.category for k in ALL} == set(CATEGORIES)
    for k in ALL:
        if k.exit_code == 0 and not k.warning and not k.setup:
            assert k.check is not None, f"{k.name}: accepted without a check of its output"
