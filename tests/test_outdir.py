"""Output that is never half-written: staged folders and atomic single files (ringqa.outdir)."""

from __future__ import annotations

import os
import stat

import pytest

from ringqa.outdir import atomic_write_bytes, atomic_write_text, staged_output


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
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.csv").write_text("old")
    with pytest.raises(RuntimeError), staged_output(out) as stage:
        (stage / "new.csv").write_text("new")
        raise RuntimeError("simulation failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in out.iterdir()) == ["old.csv"]
