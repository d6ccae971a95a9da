"""Whether the commissioning's independent work may go to forked processes, told without
importing the pipeline's steps (pandas, the engine's runs): the command line decides it before
its heavy imports, so that the work that needs neither (reading an RT Plan) can start beside
them (:func:`ringqa.cli.commission.commission_ahead`, docs/speed.md).

:func:`kernels_cached` is the pipeline's test (:mod:`ringqa.pipeline.simulate` uses it);
:func:`default_engine_may_fork` is :func:`ringqa.pipeline.simulate.second_core_worthwhile` for
the default engine.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from ringqa import parallel

#: when this module was imported (s since the epoch): the process's start where /proc is missing
_IMPORTED_AT = time.time()


def kernels_cached() -> bool:
    """The engine's Newton kernel has a numba disk-cache index older than this process (False
    when that cannot be told): its runs may go to forked processes. On a first run, with numba
    compiling, each process would compile the same kernels again (measured: the example's
    first run 22 -> 34 s of compile wall)."""
    try:
        from ringqa.simulation.solvers.newton import newton

        index = Path(newton._cache._cache_file._index_path)
        proc = Path(f"/proc/{os.getpid()}")
        started = proc.stat().st_ctime if proc.exists() else _IMPORTED_AT
        return index.stat().st_mtime < started
    except Exception:
        return False


def default_engine_may_fork() -> bool:
    """Independent work of a run with the default engine may go to a forked process: its
    kernels are cached (:func:`kernels_cached`) and a core is free
    (:func:`ringqa.parallel.second_core_free`); what
    :func:`ringqa.pipeline.simulate.second_core_worthwhile` says for ``engine=None``."""
    return kernels_cached() and parallel.second_core_free()
