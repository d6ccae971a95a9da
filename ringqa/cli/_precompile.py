"""Compile the engine's leaf kernels in a second process while the command compiles the rest.

numba compiles one function at a time per process. On an empty cache ``ringqa commission``
compiles the geometry kernels, then Newton (whose assembler compiles every effect's kernel inside
it), then the predictor and the output kernels, one after the other (docs/speed.md). The effects'
kernels take array and scalar arguments only, so their signatures are known before any run: a
helper process compiles them into numba's disk cache (:data:`LEAVES`, in the REVERSE of the order
the command asks for them, then the TG-43 kernel, which a commission needs only after its
simulations) while the command compiles the geometry kernels and then Newton from the first
effect on. When the command's Newton reaches a kernel the helper has finished, numba loads it
from the cache instead of compiling it; the two meet somewhere in the list, so on two cores the
leaves cost about half their serial time. Answers do not change: the same kernels with the same
signatures, compiled the same way (``benchmarks/compare_dwells.py``).

The helper starts only when Newton's cache index does not exist (an empty or dropped cache), is
silent, and is ended when the command ends. ``python -m ringqa.cli._precompile`` runs it. After
the kernels it writes the bytecode of ringqa's own modules (:func:`write_bytecode`), which
``ringqa warmup`` writes too.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

_F1 = "f1"  # float64, 1d, C-contiguous
_F2 = "f2"
_F3 = "f3"
_I1 = "i1"  # int64, 1d, C-contiguous
_I = "i8"
_D = "f8"
_B = "b1"

#: (module, kernel, argument types) in the reverse of the order Newton and the driver need them
LEAVES: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("ringqa.simulation._kernels", "closest_rows", (_D, _F2, _F2, _F2, _F1, _F1)),
    ("ringqa.simulation.solvers.recorder", "lump_to_nodes", (_I1, _F1, _F1, _F1)),
    ("ringqa.simulation.solvers.monitor", "max_penetration", (_F1, _F1)),
    ("ringqa.simulation.solvers.predictor", "restore_lengths", (_F1, _I, _I, _F1)),
    ("ringqa.simulation.solvers.predictor", "slide_points",
     (_D, _F2, _F2, _F2, _F1, _D, _F2, _F1)),
    ("ringqa.simulation.solvers.newton", "update_chain", (_F1, _F1, _D, _I, _I, _I, _F1)),
    ("ringqa.simulation.band", "band_solve", (_F2, _I, _F1, _I)),
    ("ringqa.simulation.effects.tether", "tether_kernel",
     (_F1, _F1, _I, _I, _I, _D, _D, _F1, _F2, _B)),
    ("ringqa.simulation.effects.friction", "friction_kernel",
     (_F1, _F1, _F1, _I, _I, _I1, _F1, _F1, _F2, _F2, _F3, _F1, _F1, _I, _D, _D, _D, _D, _D,
      _B, _F1, _F2, _B)),
    ("ringqa.simulation.effects.contact", "apply_normal",
     (_I, _I, _I1, _F1, _F2, _F3, _F1, _F1, _F1, _F2, _B)),
    ("ringqa.simulation.effects.bending", "_hinge_hessians", (_F2, _F2, _F2, _F1, _F2, _I)),
    ("ringqa.simulation.effects.bending", "_gradients", (_F2, _F2, _F2, _F1, _F2, _I)),
    ("ringqa.simulation.effects.bending", "_cos_sin", (_F2, _F2, _I)),
    ("ringqa.simulation.effects.bending", "_links", (_F2, _F2, _I)),
    ("ringqa.simulation.effects.bending", "bending_kernel", (_F1, _I, _I, _I, _F1, _F1, _F2, _B)),
    ("ringqa.simulation.effects.axial", "_link_terms", (_F2, _F1, _D, _F2, _I)),
    ("ringqa.simulation.effects.axial", "axial_kernel", (_F1, _I, _I, _I, _F1, _D, _F1, _F2, _B)),
    ("ringqa.simulation.effects.contact", "contact_geometry",
     (_F1, _I, _I1, _F1, _F1, _F1, _D, _F2, _F2, _F2, _D, _F1, _F1, _F1, _F1, _D, _D, _D, _F1,
      _F2, _F1, _F2, _F3, _F1, _F1, _F1, _F1, _I)),
    ("ringqa.simulation._kernels", "sample_hints", (_D, _F2, _F2, _F1, _I, _I1, _F1, _F1)),
    ("ringqa.simulation._kernels", "chain_on_centreline", (_D, _F2, _F2, _F1, _I, _F1)),
)  # fmt: skip


def numba_types(codes: tuple[str, ...]) -> tuple:
    """numba argument types for the codes of :data:`LEAVES`."""
    from numba import types

    table = {
        "f1": types.float64[::1],
        "f2": types.float64[:, ::1],
        "f3": types.float64[:, :, ::1],
        "i1": types.int64[::1],
        "i8": types.int64,
        "f8": types.float64,
        "b1": types.boolean,
    }
    return tuple(table[c] for c in codes)


def leaf(module: str, name: str):
    """The numba dispatcher of a leaf kernel."""
    return getattr(importlib.import_module(module), name)


def compile_dose() -> None:
    """Compile (or load) the TG-43 kernel through the public API (a commission's last compile)."""
    import tg43

    src = tg43.load_source("flexisource")
    tg43.dose_rate_per_sk(src, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [[10.0, 0.0, 5.0]])


def compile_leaves() -> int:
    """Compile (or load) every leaf kernel, then the TG-43 kernel (a commission needs it last,
    after its simulations); the number of leaves compiled without error."""
    done = 0
    for module, name, codes in LEAVES:
        try:
            leaf(module, name).compile(numba_types(codes))
            done += 1
        except Exception:  # a stale signature only costs time: the command compiles it itself
            continue
    try:
        compile_dose()
    except Exception:  # the command compiles it itself
        pass
    return done


#: the packages whose modules :func:`write_bytecode` compiles (this distribution's)
BYTECODE_PACKAGES = ("ringqa", "tg43")


def write_bytecode(folders=None) -> None:
    """Write the bytecode (``__pycache__/*.pyc``) of every module of ringqa and tg43 that lacks
    an up-to-date one, as pip does for a regular install.

    An editable install (README's ``pip install -e .``) gets its bytecode from the first
    imports, unless the environment says ``PYTHONDONTWRITEBYTECODE`` (some containers and CI
    images do): then every run compiles ringqa's ~150 modules from source again (0.1-0.25 s
    of CPU of the warm example, measured 2026-11-29, docs/speed.md). Python still reads an
    up-to-date ``.pyc`` under that setting, so writing them once here (beside numba's cache
    files in the same ``__pycache__`` folders) saves that on every later run; a module edited
    later is compiled from source until the next write. A folder that cannot be written (a
    read-only install) is left as it is; nothing is raised.

    Parameters
    ----------
    folders : sequence of path-like, optional
        The package folders (default: those of :data:`BYTECODE_PACKAGES`).
    """
    import compileall
    import contextlib
    import io

    if folders is None:
        folders = []
        for name in BYTECODE_PACKAGES:
            with contextlib.suppress(ImportError):
                folders.append(Path(importlib.import_module(name).__file__).parent)
    for folder in folders:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(OSError):
            compileall.compile_dir(str(folder), quiet=2)


def cache_is_cold() -> bool:
    """True when Newton has no disk-cache index (nothing of the engine was compiled here yet).

    Drops a stale engine cache first (``ensure_fresh_kernel_cache``), so the helper's output is
    never deleted by the command's own check later.
    """
    try:
        from ringqa.simulation.model import ensure_fresh_kernel_cache
        from ringqa.simulation.solvers.newton import newton

        ensure_fresh_kernel_cache()
        index = newton._cache._cache_file._index_path
        return not Path(index).exists()
    except Exception:  # no cache (read-only install) or another numba: no helper
        return False


def start_helper() -> subprocess.Popen | None:
    """Start the helper process when the cache is cold; None otherwise."""
    if os.environ.get("RINGQA_NO_PRECOMPILE") or not cache_is_cold():
        return None
    try:
        return subprocess.Popen(
            [sys.executable, "-m", "ringqa.cli._precompile"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except OSError:
        return None


def stop_helper(proc: subprocess.Popen | None) -> None:
    """End the helper if it still runs (the command is done with it)."""
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:  # pragma: no cover - a helper stuck in LLVM
        proc.kill()
        proc.wait()


if __name__ == "__main__":
    compile_leaves()
    write_bytecode()
