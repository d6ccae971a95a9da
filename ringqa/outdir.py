"""Output folders that are never left half-written.

Every command writes its files into a hidden staging folder beside the target and moves them into
place only when everything succeeded. A failed run leaves the target folder as it was.
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
