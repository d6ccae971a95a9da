"""Output that is never left half-written: staged folders and atomic single files.

Every command writes its files into a hidden staging folder beside the target and moves them into
place only when everything succeeded (:func:`staged_output`). A failed run leaves the target
folder as it was. A single file written on its own (an applicator file, a points file) goes
through :func:`atomic_write_text` / :func:`atomic_write_bytes`: a temporary file in the same
folder, flushed to disk, then renamed over the target, so readers see the old file or the new
one, never a part.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from ringqa.errors import RingQAError


def check_writable(out_dir: str | Path) -> Path:
    """Return ``out_dir`` as a Path after checking it can be created and written.

    Raises
    ------
    RingQAError
        If the folder (or its nearest existing parent) is not writable, or is a file.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise RingQAError(f"--out {out}: exists and is not a folder (choose a folder path)")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not os.access(probe, os.W_OK | os.X_OK):
        raise RingQAError(
            f"--out {out}: folder {probe} is not writable (choose a folder you can write to)"
        )
    return out


@contextlib.contextmanager
def staged_output(out_dir: str | Path) -> Iterator[Path]:
    """Yield a staging folder; on success move its contents into ``out_dir``.

    Files already in ``out_dir`` with the same names are replaced; other files are kept.
    On any exception the staging folder is removed and ``out_dir`` is untouched.
    """
    out = check_writable(out_dir)
    parent = out.parent if out.parent != Path("") else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.staging-", dir=parent))
    try:
        yield stage
        out.mkdir(parents=True, exist_ok=True)
        for item in sorted(stage.rglob("*")):
            target = out / item.relative_to(stage)
            if item.is_dir():
                target.mkdir(parents=True, exist_ok=True)
            else:
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(item, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, mode: int = 0o644) -> Path:
    """Write ``data`` to ``path`` atomically: all of it or (on any error) nothing.

    The bytes go to a temporary file in the target's folder, which is flushed and fsync'ed and
    then renamed over ``path`` (``os.replace``, atomic on POSIX and Windows). On any exception the
    temporary file is removed and ``path`` is left as it was. The folder is created if needed.

    Parameters
    ----------
    path : str or path
        The file to write (replaced if it exists).
    data : bytes
        The whole content.
    mode : int
        Permission bits of the new file (``0o644``: readable by all, as files written with
        ``open()`` under the usual umask; the temporary file itself starts as ``0o600``).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def atomic_write_text(
    path: str | os.PathLike, text: str, *, encoding: str = "utf-8", mode: int = 0o644
) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_write_bytes`).

    Parameters
    ----------
    path : str or path
        The file to write (replaced if it exists).
    text : str
        The whole content, written as is (no newline translation).
    encoding : str
        Text encoding (UTF-8).
    mode : int
        Permission bits of the new file.

    Returns
    -------
    Path
        ``path``.
    """
    return atomic_write_bytes(path, text.encode(encoding), mode=mode)
