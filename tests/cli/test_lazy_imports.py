"""``ringqa --help`` and the command line's start stay light (issue 27): building the parser
imports neither pandas nor numba nor matplotlib (``ringqa commission``'s setting options are
added when its parser is first used), and ``--version`` / ``ringqa.__version__`` look the
package metadata up only when asked. Each check runs in a fresh interpreter and reads its
``sys.modules``."""

from __future__ import annotations

import json
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
