"""Keep numba's on-disk cache of the engine's kernels consistent across the kernel files.

Numba keys a cached function on its own file's time stamp only. The solver kernels (Newton,
the assembler) compile the effects' kernels, the band helpers and the channel kernels into
themselves, so after a change to those files alone (an edit, a ``git rebase``) the cached solver
would keep running the old code. Before the first kernel call :func:`ensure_fresh_kernel_cache`
hashes every module of the engine and, when the hash differs from the one stamped at the last
compile, removes the engine's cached ``*.nbi``/``*.nbc`` files so numba recompiles.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

_ROOT = Path(__file__).resolve().parent
_checked = False


def _engine_files(exclude: str | None = None) -> list[Path]:
    """Every module of the engine (sorted: the hash must not depend on the listing order),
    without the package ``exclude`` (a folder name under ringqa/simulation)."""
    files = sorted(_ROOT.rglob("*.py"))
    if exclude is None:
        return files
    return [f for f in files if f.relative_to(_ROOT).parts[0] != exclude]


def _digest(files: list[Path]) -> str:
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(_ROOT)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def _drop(folder: Path, stamp: Path, digest: str) -> None:
    """Remove the cached kernels under ``folder`` and stamp ``digest``."""
    for cache in folder.rglob("__pycache__"):
        for p in cache.glob("*.nb[ic]"):
            p.unlink(missing_ok=True)
    stamp.parent.mkdir(parents=True, exist_ok=True)
    stamp.write_text(digest)


#: the flexible engine (``model.formulation = "flexible"``): its kernels call the rigid engine's
#: contact, friction and band kernels, so they are dropped with those; an edit of the flexible
#: engine alone drops only its own cache (the rigid engine never calls it)
_FLEXIBLE = "flexible"


def ensure_fresh_kernel_cache() -> None:
    """Drop stale cached kernels (once per process; silent where the cache is not writable)."""
    global _checked
    if _checked:
        return
    _checked = True
    try:
        digest = _digest(_engine_files(exclude=_FLEXIBLE))
        stamp = _ROOT / "solvers" / "__pycache__" / "ringqa_kernels.sha256"
        if not (stamp.is_file() and stamp.read_text().strip() == digest):
            _drop(_ROOT, stamp, digest)
        flex = _ROOT / _FLEXIBLE
        digest = _digest(_engine_files())
        stamp = flex / "__pycache__" / "ringqa_kernels.sha256"
        if not (stamp.is_file() and stamp.read_text().strip() == digest):
            _drop(flex, stamp, digest)
    except OSError:  # pragma: no cover - read-only install: numba caches elsewhere
        pass
