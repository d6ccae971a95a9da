"""``ringqa --help`` and the command line's start stay light (issue 27): building the parser
imports neither pandas nor numba nor matplotlib (``ringqa commission``'s setting options are
added when its parser is first used), and ``--version`` / ``ringqa.__version__`` look the
package metadata up only when asked. Each check runs in a fresh interpreter and reads its
``sys.modules``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("pandas", "numba", "matplotlib", "scipy", "reportlab", "plotly", "pydicom")


def _modules_after(code: str) -> dict:
    """Run ``code`` in a fresh interpreter (this checkout first on the path); the heavy
    libraries and ``importlib.metadata`` it left imported, and what it printed."""
    probe = (
        "import json, sys\n"
        f"{code}\n"
        f"print('MODULES' + json.dumps([m for m in {(*HEAVY, 'importlib.metadata')!r} "
        "if m in sys.modules]))\n"
    )
    p = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True,
                       check=True)  # fmt: skip
    line = next(x for x in p.stdout.splitlines() if x.startswith("MODULES"))
    return {"modules": json.loads(line[7:]), "stdout": p.stdout}


def test_importing_the_command_line_and_building_its_parser_is_light():
    """``import ringqa.cli`` and the parser ``main`` builds (every sub-command registered):
    none of the heavy libraries, no package metadata."""
    got = _modules_after("import ringqa.cli\nringqa.cli.build_parser(deferred=True)")
    assert got["modules"] == []


def test_ringqa_help_imports_no_heavy_library():
    """``ringqa --help`` through :func:`ringqa.cli.main` (exit 0): the usage printed, nothing
    heavy imported (before: pandas, numba and scipy through the settings table, 0.9 s CPU)."""
    got = _modules_after(
        "import ringqa.cli\n"
        "try:\n    ringqa.cli.main(['--help'])\nexcept SystemExit as e:\n    assert e.code == 0"
    )
    assert "usage: ringqa" in got["stdout"] and "commission" in got["stdout"]
    assert got["modules"] == []


@pytest.mark.parametrize("command", ["commission", "sweep", "simulate", "tg43-demo", "import"])
def test_a_deferred_parser_has_the_same_arguments_and_help(command):
    """Each sub-command's parser built deferred (as ``main`` builds it) prints the same help and
    holds the same options, in the same order, as built at once."""
    from ringqa.cli import build_parser

    def sub(parser):
        action = next(a for a in parser._actions if a.dest == "command")
        return action.choices[command]

    eager, lazy = sub(build_parser()), sub(build_parser(deferred=True))
    assert lazy.format_help() == eager.format_help()
    assert [a.option_strings for a in lazy._actions] == [a.option_strings for a in eager._actions]
    assert [a.dest for a in lazy._actions] == [a.dest for a in eager._actions]


def test_a_deferred_commission_parser_parses_as_before():
    """The deferred ``commission`` parser parses a command line to the same namespace (its
    setting options included) and refuses a missing ``--out`` the same way."""
    from ringqa.cli import build_parser

    argv = ["commission", "plan.dcm", "--register", "plane-height", "--out", "o", "--stem-mm",
            "40", "--no-cross-check", "--set", "solver.increment_mm=0.5"]  # fmt: skip
    eager, lazy = build_parser().parse_args(argv), build_parser(deferred=True).parse_args(argv)
    assert vars(lazy) == vars(eager)
    assert lazy.register == "plane-height" and lazy.stem_mm == 40.0 and lazy.cross_check is False
    with pytest.raises(SystemExit) as exc:
        build_parser(deferred=True).parse_args(["commission", "plan.dcm"])
    assert exc.value.code == 2


def test_version_is_looked_up_when_asked(capsys):
    """``ringqa --version`` prints ``ringqa <version>``, the installed package's (what
    ``importlib.metadata`` says), and ``import ringqa`` alone does not import the metadata
    machinery."""
    from importlib.metadata import version

    from ringqa.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"ringqa {version('ringqa')}\n"
    got = _modules_after("import ringqa")
    assert "importlib.metadata" not in got["modules"]
    got = _modules_after("import ringqa\nprint('V=' + ringqa.__version__)")
    assert f"V={version('ringqa')}" in got["stdout"]


def test_main_builds_the_named_commands_arguments_and_only_those(capsys):
    """``ringqa commission --help`` through :func:`ringqa.cli.main` prints the whole help (its
    setting options included); ``ringqa config --help`` in a fresh interpreter leaves
    ``commission``'s arguments deferred (no pandas, no numba)."""
    from ringqa.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["commission", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "--register" in out and "--stem-mm" in out and "--no-cross-check" in out
    got = _modules_after(
        "import ringqa.cli\n"
        "try:\n    ringqa.cli.main(['config', '--help'])\nexcept SystemExit as e:\n"
        "    assert e.code == 0"
    )
    assert "usage: ringqa config" in got["stdout"]
    assert got["modules"] == []


EXAMPLE = ROOT / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"


def test_the_main_job_reads_its_rt_plan_beside_the_pipelines_imports(tmp_path):
    """README's main job with a core free (``ringqa commission <RT Plan> --register
    plane-height``, stopped at its second fork): the command forks the RT Plan's reader first,
    before pandas and the pipeline's steps are imported, then the commissioning; it never
    imports pydicom itself (the plan is read in the reader, and taken by the commissioning)."""
    probe = (
        "import json, os, sys\n"
        "import ringqa.parallel, ringqa.pipeline.second_core as sc\n"
        "ringqa.parallel.second_core_free = lambda: True\n"
        "sc.kernels_cached = lambda: True\n"
        "WATCH = ('pandas', 'pydicom', 'ringqa.pipeline.simulate', 'ringqa.pipeline.commission')\n"
        "seen = []\n"
        "def before():\n"
        "    seen.append([m for m in WATCH if m in sys.modules])\n"
        "    if len(seen) == 2:\n"
        "        print('FORKS' + json.dumps(seen), flush=True)\n"
        "        os._exit(0)\n"
        "os.register_at_fork(before=before)\n"
        "from ringqa.cli import main\n"
        f"main(['commission', {str(EXAMPLE)!r}, '--register', 'plane-height', '--out', "
        f"{str(tmp_path / 'out')!r}, '--quiet'])\n"
        "print('FORKS' + json.dumps(seen))\n"
    )
    env = {**os.environ, "RINGQA_COMPILE_NOTICE": "0", "RINGQA_NO_PRECOMPILE": "1"}
    p = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True,
                       env=env, timeout=120, check=True)  # fmt: skip
    line = next(x for x in p.stdout.splitlines() if x.startswith("FORKS"))
    reader, commissioning = json.loads(line[5:])
    assert reader == []
    assert commissioning == ["pandas", "ringqa.pipeline.simulate", "ringqa.pipeline.commission"]


def same_values(a, b) -> bool:
    """``a`` and ``b`` hold the same values: the same types, arrays with the same dtype, shape,
    strides and bits (NaN equal to NaN), the same items and attributes, recursively (which
    objects are shared inside each need not be the same: a pickled copy shares less)."""
    import numpy as np

    if type(a) is not type(b):
        return False
    if isinstance(a, np.ndarray):
        return (a.dtype == b.dtype and a.shape == b.shape and a.strides == b.strides
                and a.tobytes() == b.tobytes())  # fmt: skip
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(same_values(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return list(a) == list(b) and all(same_values(a[k], b[k]) for k in a)
    if isinstance(a, type):
        return a is b
    if hasattr(a, "__dict__"):
        return same_values(vars(a), vars(b))
    if isinstance(a, int | float | complex | str | bytes | type(None)):
        return a == b or (a != a and b != b)
    return same_values(a.__reduce_ex__(4)[1:], b.__reduce_ex__(4)[1:])  # e.g. __slots__


def test_the_rt_plan_read_ahead_loads_the_same_input():
    """The commissioning's input loaded with the RT Plan a forked reader read
    (``commission_ahead``'s reader) is the input ``load_commission_input`` loads (the same
    values, array by array: applicator, plan, files), in a process that never imports
    pydicom; a file the reader cannot read gives no input (the commissioning then reads it and
    says why)."""
    probe = (
        "import pickle, sys\n"
        "from ringqa.cli import commission as cli\n"
        "from ringqa.pipeline.commission import load_commission_input\n"
        "from ringqa.pipeline.settings import CommissionSettings\n"
        "s = CommissionSettings(register='plane-height')\n"
        f"reader = cli._read_plan_ahead({str(EXAMPLE)!r})\n"
        "assert reader.forked\n"
        f"loaded, load_s = cli._loaded_ahead({str(EXAMPLE)!r}, s, reader)\n"
        "reader.cancel()\n"
        "print('PYDICOM', 'pydicom' in sys.modules, load_s > 0)\n"
        f"again = load_commission_input({str(EXAMPLE)!r}, s)\n"
        "from tests.cli.test_lazy_imports import same_values\n"
        "same = [same_values(getattr(loaded, k), getattr(again, k))\n"
        "        for k in ('applicator', 'rtplan', 'kind', 'files', 'notes')]\n"
        "print('SAME', same)\n"
        f"bad = cli._read_plan_ahead({str(ROOT / 'README.md')!r})\n"
        f"print('OTHER', bad is None, cli._loaded_ahead('x.dcm', s, cli._read_plan_ahead("
        f"{str(ROOT / 'missing.dcm')!r})))\n"
    )
    p = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True,
                       timeout=120, check=True)  # fmt: skip
    out = p.stdout
    assert "PYDICOM False True" in out
    assert "SAME [True, True, True, True, True]" in out
    assert "OTHER True (None, 0.0)" in out
