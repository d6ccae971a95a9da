"""A call made in a forked child process while this process goes on: the second core.

:class:`ForkedCall` runs ``fn()`` in a child made with ``os.fork`` (it shares everything this
process has loaded, nothing is pickled on the way in) and hands the result back pickled through
a pipe. Whatever the child could not hand back (a result or an exception that cannot be pickled,
a child that died) is made here instead when :meth:`ForkedCall.result` is called, so the caller
always sees what calling ``fn()`` here would have given: the same value, or the same exception.
Where ``os.fork`` is missing, on one core, or with ``fork=False`` the call is simply made here.
:func:`worker_pool` is the pool of forked worker processes a batch uses (commissioning, PDFs;
:func:`default_workers` of them), the calibration's fit too.

A foundation module (no ringqa imports): the pipeline, the report and the calibration share it.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
from collections.abc import Callable, Iterator
from typing import Any


def default_workers() -> int:
    """Worker processes of a batch by default (commissioning, the PDFs):
    ``min(2, os.cpu_count())`` (1 where the operating system has no ``fork``)."""
    return min(2, os.cpu_count() or 1) if hasattr(os, "fork") else 1


def can_fork() -> bool:
    """``os.fork`` exists and the machine has at least 2 cores."""
    return hasattr(os, "fork") and (os.cpu_count() or 1) >= 2


def running_outside(pgrp: int) -> tuple[int, ...] | None:
    """Pids of the processes outside process group ``pgrp`` that are running or runnable now
    (state ``R`` in ``/proc/<pid>/stat``); None where ``/proc`` cannot say (not Linux)."""
    try:
        entries = list(os.scandir("/proc"))
    except OSError:
        return None
    pids = []
    for entry in entries:
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat", "rb") as fh:
                stat = fh.read()
        except OSError:  # ended meanwhile, or not ours to read
            continue
        fields = stat[stat.rfind(b")") + 2 :].split()  # state, ppid, pgrp, ... after "pid (comm) "
        if len(fields) > 2 and fields[0] == b"R" and int(fields[2]) != pgrp:
            pids.append(int(entry.name))
    return tuple(pids)


def others_running() -> int | None:
    """How many processes outside this command's process group are running or runnable now
    (:func:`running_outside`); None where that cannot be told.

    The command's own processes (the forked commissioning, its engine runs, the figure
    children) share its process group and are not counted; nor is a process that has ended,
    whatever it left in the load average (about 1.8 ms for 80 processes).
    """
    if not hasattr(os, "getpgrp"):
        return None
    pids = running_outside(os.getpgrp())
    return None if pids is None else len(pids)


def second_core_free() -> bool:
    """A core is free for this command's independent work: the machine's 1-minute load
    average leaves one (< cores - 0.5; this process counts as 1), or, where it does not, no
    process outside this command's process group is running now (:func:`others_running`,
    at most cores - 2 of them).

    A single command forks its independent work only then: on a machine whose cores are
    busy with other work the fork's overhead (about 0.15 s CPU on the example: kernel cache
    loads in the child, pickling) would make it slower (measured under a load of 2.4 on 2
    cores: 3.21 -> 3.36 s). The load average alone also counted the command's own runs of
    the last minute: a quiet 2-core machine on which the main job was repeated read "busy"
    from the second run on, and the repeats ran everything on one core (README's warm main
    job 2.6 s the first time, then 4.2-4.4 s; 2026-11-29).
    """
    cores = os.cpu_count() or 1
    try:
        if os.getloadavg()[0] < cores - 0.5:
            return True
    except (AttributeError, OSError):
        return True
    others = others_running()
    return others is not None and others <= cores - 2


class ForkedCall:
    """``fn()`` running in a forked child; :meth:`result` waits for it (see the module text).

    Parameters
    ----------
    fn : callable
        Called without arguments, in the child (or here, see above).
    fork : bool
        False: make the call here, in :meth:`result`.
    """

    def __init__(self, fn: Callable[[], Any], fork: bool = True):
        self._fn = fn
        self._pid = 0
        self._fd = -1
        if not (fork and can_fork()):
            return
        try:
            r, w = os.pipe()
            pid = os.fork()
        except OSError:
            return
        if pid == 0:  # the child: run, hand the pickled outcome over, leave without clean-up
            code = 1
            try:
                os.close(r)
                signal.signal(signal.SIGINT, signal.SIG_DFL)
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                try:
                    outcome: tuple = ("ok", fn())
                except Exception as exc:
                    outcome = ("raised", exc)
                try:
                    data = pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
                except Exception:  # made here instead
                    data = pickle.dumps(("failed", None))
                with os.fdopen(w, "wb") as f:
                    f.write(data)
                code = 0
            finally:
                os._exit(code)
        os.close(w)
        self._pid, self._fd = pid, r

    @property
    def forked(self) -> bool:
        """The call runs in a child process."""
        return self._pid != 0

    def result(self):
        """The call's result (from the child, else made here); its exception is raised."""
        if self._pid:
            try:
                with os.fdopen(self._fd, "rb") as f:
                    data = f.read()
            finally:
                self._fd = -1
                self.cancel()
            try:
                tag, value = pickle.loads(data)
            except Exception:  # a killed child, or an outcome that does not unpickle
                tag, value = "failed", None
            if tag == "ok":
                return value
            if tag == "raised":
                raise value
        return self._fn()

    def cancel(self) -> None:
        """Stop the child (its result is not needed) and reap it."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1
        if self._pid:
            pid, self._pid = self._pid, 0
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(pid, 0)


def worker_signals() -> None:
    """In a forked worker: Ctrl-C is the parent's to handle (it stops the workers), SIGTERM
    ends it at once."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


#: the ``job`` of the pool being made (:func:`worker_pool`): inherited by its forked workers,
#: never pickled (a stand-in engine, a batch's results need not be picklable)
_JOB: Any = None


def job() -> Any:
    """In a worker of :func:`worker_pool`: the ``job`` the pool was made with."""
    return _JOB


@contextlib.contextmanager
def worker_pool(
    processes: int, initializer: Callable[[], None] = worker_signals, job: Any = None
) -> Iterator[Any]:
    """A ``multiprocessing`` pool of ``processes`` forked workers (each starts with
    ``initializer``, which should call :func:`worker_signals`). ``job`` (whatever the workers'
    tasks need: :func:`job` returns it in them) is in place before the workers are forked and
    is dropped here when the block ends; the workers are stopped and reaped then, however it
    ends."""
    import multiprocessing

    global _JOB
    _JOB = job
    try:
        pool = multiprocessing.get_context("fork").Pool(processes, initializer)
        try:
            yield pool
        finally:
            pool.terminate()
            pool.join()
    finally:
        _JOB = None
