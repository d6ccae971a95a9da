"""ringqa.parallel: when a command may use the second core (second_core_free)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from ringqa import parallel

BUSY = [sys.executable, "-c", "while True: pass"]
linux_only = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs /proc")


def _seen_running(pid: int, pgrp: int, seconds: float = 3.0) -> bool:
    """``pid`` shows up in :func:`parallel.running_outside` within ``seconds``."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if pid in (parallel.running_outside(pgrp) or ()):
            return True
        time.sleep(0.02)
    return False


@linux_only
def test_a_busy_process_of_another_session_is_counted():
    """A CPU-bound process in its own session (another user's job) is state R in /proc: it is
    listed as running outside this process group."""
    proc = subprocess.Popen(BUSY, start_new_session=True)
    try:
        assert _seen_running(proc.pid, os.getpgrp())
    finally:
        proc.kill()
        proc.wait()


@linux_only
def test_the_commands_own_forked_work_is_not_counted():
    """A busy child forked by this command shares its process group: never listed, however
    long it runs (while the same child is listed when asked about another group, so the test
    sees it running)."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child spins until killed
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        while True:
            pass
    try:
        assert _seen_running(pid, pgrp=-1)  # it does run ...
        for _ in range(20):  # ... but is not another command's work
            assert pid not in (parallel.running_outside(os.getpgrp()) or ())
            time.sleep(0.01)
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)


@pytest.mark.parametrize(
    ("load", "others", "free"),
    [
        (0.4, 5, True),  # the load average leaves a core: fork, whatever runs this instant
        (1.9, 0, True),  # the load is this command's own last runs: nothing else runs now
        (1.9, 1, False),  # another job runs now on a 2-core machine
        (1.9, None, False),  # cannot tell (no /proc): trust the load average
    ],
)
def test_second_core_free_on_two_cores(monkeypatch, load, others, free):
    """On 2 cores: free when the 1-minute load is below 1.5, else only when no process outside
    this command runs now (at most cores - 2 = 0 of them)."""
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (load, load, load))
    monkeypatch.setattr(parallel, "others_running", lambda: others)
    assert parallel.second_core_free() is free
