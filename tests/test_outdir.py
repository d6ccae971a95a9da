"""Output that is never half-written: staged folders and atomic single files (ringqa.outdir)."""

from __future__ import annotations

import errno
import json
import os
import signal
import stat
import time

import pytest

from ringqa.errors import RingQAError
from ringqa.outdir import (
    MARKER_NAME,
    OutputInterrupted,
    atomic_write_bytes,
    atomic_write_text,
    check_writable,
    folder_state,
    remove_leftovers,
    staged_output,
)


def _earlier_output(out, files=("old.csv",)):
    """A folder as an earlier ringqa run leaves it (marker + files)."""
    with staged_output(out) as stage:
        for name in files:
            (stage / name).write_text("old")
    return out


def _dead_pid():
    """A process id that is not running (a child that has exited and been reaped)."""
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_atomic_write_replaces_the_file_whole(tmp_path):
    """A new file is created (with its folder), an existing one replaced; the mode is 0o644 and
    no temporary file is left beside it."""
    target = tmp_path / "sub" / "f.txt"
    atomic_write_text(target, "first\n")
    atomic_write_text(target, "second\n")
    assert target.read_text() == "second\n"
    assert stat.S_IMODE(os.stat(target).st_mode) == 0o644
    assert sorted(p.name for p in target.parent.iterdir()) == ["f.txt"]


def test_atomic_write_leaves_nothing_after_an_exception(tmp_path, monkeypatch):
    """The rename fails (as on a full disk): the old content stays, no temporary file is left,
    and the error reaches the caller."""
    target = tmp_path / "f.bin"
    target.write_bytes(b"old")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        atomic_write_bytes(target, b"new content")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["f.bin"]


def test_atomic_write_of_a_new_file_leaves_no_file_after_an_exception(tmp_path, monkeypatch):
    """Flushing to disk fails after the temporary file was written: neither the target nor the
    temporary file exists afterwards."""

    def broken_fsync(fd):
        raise OSError("I/O error")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="I/O error"):
        atomic_write_text(tmp_path / "f.txt", "text")
    assert list(tmp_path.iterdir()) == []


def test_staged_output_leaves_the_target_as_it_was_on_failure(tmp_path):
    """An exception inside the block: the target folder keeps its old file, gets no new one, and
    no staging folder is left."""
    out = _earlier_output(tmp_path / "out")
    with pytest.raises(RuntimeError), staged_output(out) as stage:
        (stage / "new.csv").write_text("new")
        raise RuntimeError("simulation failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "old.csv"]


def test_staged_output_replaces_an_earlier_output_whole(tmp_path):
    """A second run into an earlier ringqa output: no file (nor subfolder) of the first run
    survives; the marker names the software; nothing hidden is left beside the folder."""
    out = _earlier_output(tmp_path / "out", ("report.pdf", "a.csv"))
    with staged_output(out) as stage:
        (stage / "sub").mkdir()
        (stage / "sub" / "b.csv").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "sub"]
    assert json.loads((out / MARKER_NAME).read_text())["software"] == "ringqa"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_foreign_folder_is_refused_before_the_block_and_left_untouched(tmp_path):
    """A non-empty folder without the marker: refused at entry, naming a file; the block never
    runs and the folder keeps its file."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.docx").write_text("precious")
    ran = []
    with pytest.raises(RingQAError, match=r"holds files ringqa did not write \(e.g. thesis.docx\)"):
        with staged_output(out):
            ran.append(1)
    assert not ran
    assert [p.name for p in out.iterdir()] == ["thesis.docx"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_empty_existing_folder_and_own_cache_are_accepted(tmp_path):
    """An empty folder is written into; a folder holding only the command's own files (``ours``)
    is accepted and those files are carried into the new folder."""
    empty = tmp_path / "empty"
    empty.mkdir()
    with staged_output(empty) as stage:
        (stage / "a.csv").write_text("a")
    assert sorted(p.name for p in empty.iterdir()) == [MARKER_NAME, "a.csv"]
    cached = tmp_path / "cached"
    cached.mkdir()
    (cached / "runs.jsonl").write_text("{}\n")
    assert folder_state(cached).kind == "foreign"
    assert folder_state(cached, ours=("runs.jsonl",)).kind == "ringqa"
    with staged_output(cached, ours=("runs.jsonl",)) as stage:
        (stage / "a.csv").write_text("a")
    assert (cached / "runs.jsonl").read_text() == "{}\n"


def test_leftovers_of_dead_processes_are_removed(tmp_path, capsys):
    """A staging folder named with a pid that no longer runs is removed (one line on stderr); one
    of a live process (this one) and an unrelated hidden folder are kept."""
    out = tmp_path / "out"
    dead = tmp_path / f".out.staging-{_dead_pid()}-abcd1234"
    live = tmp_path / f".out.staging-{os.getpid()}-abcd1234"
    other = tmp_path / ".other.staging-1-x"
    for d in (dead, live, other):
        d.mkdir()
        (d / "partial.csv").write_text("x")
    check_writable(out)
    assert not dead.exists() and live.exists() and other.exists()
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"removed left-over staging folder {dead} from an interrupted run" in err


def test_an_earlier_output_set_aside_by_a_killed_run_is_restored(tmp_path):
    """Killed between its two renames: the target is missing, the earlier output sits aside
    under a dead pid; the next run puts it back."""
    aside = tmp_path / f".out.old-{_dead_pid()}-zz"
    _earlier_output(aside)
    lines = []
    remove_leftovers(tmp_path / "out", say=lines.append)
    assert (tmp_path / "out" / "old.csv").is_file() and not aside.exists()
    assert len(lines) == 1 and "restored" in lines[0]


def test_failed_rename_keeps_the_earlier_output(tmp_path, monkeypatch):
    """The rename of the staging folder into place fails (full disk): the earlier output is put
    back, no hidden folder is left, the error reaches the caller."""
    out = _earlier_output(tmp_path / "out")
    real = os.replace

    def broken(src, dst):
        if ".staging-" in str(src):
            raise OSError(errno.ENOSPC, "No space left on device", str(dst))
        return real(src, dst)

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError, match="No space"), staged_output(out) as stage:
        (stage / "new.csv").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "old.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_sigterm_inside_the_block_removes_the_staging_folder(tmp_path):
    """SIGTERM while staging: OutputInterrupted (exit status 143) is raised, the staging folder
    is removed, the target is not created, and the previous handler is back afterwards."""
    before = signal.getsignal(signal.SIGTERM)
    out = tmp_path / "out"
    with pytest.raises(OutputInterrupted) as info, staged_output(out) as stage:
        (stage / "a.csv").write_text("a")
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)  # the handler raises before this ends
    assert info.value.exit_status == 143
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_signal_during_the_renames_waits_until_they_are_done(tmp_path, monkeypatch):
    """SIGTERM arriving while the folders are renamed is held back: the renames finish, then
    OutputInterrupted is raised with output_complete set (the new output is whole)."""
    import ringqa.outdir as od

    out = _earlier_output(tmp_path / "out")
    real = od.commit_folder

    def signalled(stage, out, ours=()):
        os.kill(os.getpid(), signal.SIGTERM)
        real(stage, out, ours)

    monkeypatch.setattr(od, "commit_folder", signalled)
    with pytest.raises(OutputInterrupted) as info, staged_output(out) as stage:
        (stage / "new.csv").write_text("new")
    assert info.value.output_complete
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "new.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
