"""The ``ringqa`` script's quick exit (``ringqa.cli.console_main``): exit status, output flushed,
exit handlers run - the things a normal interpreter exit does that ``os._exit`` would skip."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _run(*args: str, **env: str) -> subprocess.CompletedProcess:
    environ = {**os.environ, "RINGQA_COMPILE_NOTICE": "0", "RINGQA_CONFIG": "", **env}
    environ["PYTHONPATH"] = os.pathsep.join([str(ROOT), environ.get("PYTHONPATH", "")])
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, env=environ, timeout=120
    )


def test_output_piped_complete_and_status_zero():
    """``ringqa config show`` exits 0 and its piped stdout is the same text as the same command
    through :func:`ringqa.cli.main` with a normal exit: flushed before ``os._exit``."""
    proc = _run("-m", "ringqa", "config", "show")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() != ""
    # the same text as a normal (slow) exit of the same command run through main()
    normal = _run("-c", "import sys; from ringqa.cli import main; "
                        "sys.exit(main(['config', 'show']))").stdout  # fmt: skip
    assert proc.stdout == normal


@pytest.mark.parametrize(
    ("args", "code"),
    [
        (("commission", "no-such-applicator-xyz", "--out", "OUT"), 2),  # a user error: exit 2
        (("--no-such-option",), 2),  # argparse's own exit, not through os._exit
    ],
)
def test_exit_status_passed_on(tmp_path, args, code):
    """The command's status is the process's: 2 for input the user must fix."""
    args = tuple(str(tmp_path / "out") if a == "OUT" else a for a in args)
    proc = _run("-m", "ringqa", *args)
    assert proc.returncode == code, proc.stderr
    assert "Traceback" not in proc.stderr


def test_exit_handlers_run(tmp_path):
    """An ``atexit`` handler registered during the command still runs (``console_main`` runs
    the exit handlers before ``os._exit``): the marker file it writes exists afterwards."""
    marker = tmp_path / "marker"
    code = (
        "import atexit, sys; from pathlib import Path; import ringqa.cli as c; "
        f"atexit.register(lambda: Path({str(marker)!r}).write_text('ran')); "
        "sys.argv = ['ringqa', 'config', 'show']; c.console_main()"
    )
    proc = _run("-c", code)
    assert proc.returncode == 0, proc.stderr
    assert marker.read_text() == "ran"


def test_collector_threshold_while_the_script_runs():
    """While the script's command runs the cyclic collector's generation-0 threshold is
    ``GC_THRESHOLD_0`` (1 000 000: the warm example's run then makes no collection, where
    100 000 made four of 0.2 s CPU); a cycle made after the start is still collected once that
    many objects have been made (the collector is not switched off)."""
    from ringqa.cli import GC_THRESHOLD_0

    code = (
        "import atexit, gc, sys, weakref; import ringqa.cli as c\n"
        "class Node: pass\n"
        "def report():\n"
        "    a = Node(); a.self = a; alive = weakref.ref(a); del a\n"
        "    junk = [[] for _ in range(gc.get_threshold()[0] + 10)]\n"
        "    print('GC', gc.get_threshold()[0], alive() is None, len(junk) > 0)\n"
        "atexit.register(report)\n"
        "sys.argv = ['ringqa', 'config', 'show']; c.console_main()"
    )
    proc = _run("-c", code)
    assert proc.returncode == 0, proc.stderr
    line = [x for x in proc.stdout.splitlines() if x.startswith("GC ")]
    assert line == [f"GC {GC_THRESHOLD_0} True True"]


@pytest.mark.parametrize(("given", "seen"), [(None, "1"), ("3", "3")])
def test_openblas_one_thread_unless_the_user_says(monkeypatch, given, seen):
    """The script runs OpenBLAS with one thread (``SCRIPT_ENVIRONMENT``: its extra threads only
    spin, 0.13-0.17 s of CPU in the warm example's start-up), set before numpy is imported;
    a value the user has set is kept."""
    code = (
        "import atexit, os, sys; import ringqa.cli as c\n"
        "atexit.register(lambda: print('BLAS', os.environ.get('OPENBLAS_NUM_THREADS'), "
        "'numpy' in sys.modules))\n"
        "print('BEFORE', 'numpy' in sys.modules)\n"
        "sys.argv = ['ringqa', 'config', 'show']; c.console_main()"
    )
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    proc = _run("-c", code, **({} if given is None else {"OPENBLAS_NUM_THREADS": given}))
    assert proc.returncode == 0, proc.stderr
    lines = [x for x in proc.stdout.splitlines() if x.startswith(("BEFORE", "BLAS"))]
    assert lines[0] == "BEFORE False"  # numpy not imported before the script sets it
    assert lines[-1].split()[:2] == ["BLAS", seen]
