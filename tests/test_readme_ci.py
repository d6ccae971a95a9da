"""README's Quick start is what CI runs: the newcomer's three commands are exactly `.ci/run`'s.

The README gives three indented commands under "## Quick start": the set-up (once; the user
install, without test tools), the main job (repeated without reinstalling anything), and the
developers' test tools and tests; `.ci/run` must run exactly those lines, in that order, so a
green CI proves that the README's instructions work on a fresh machine.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    section = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return [m.group(1).strip() for m in re.finditer(r"^ {4}(\S.*)$", section, re.MULTILINE)]


def _ci_commands() -> list[str]:
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    return [ln.strip() for ln in lines if ln.strip() and not ln.startswith(("#", "set ", "cd "))]


def test_readme_gives_set_up_run_and_tests():
    """A set-up command (pip, no test tools, no ringqa run), the main job (ringqa only: its
    repeat reinstalls nothing) and the developers' command (the test tools, then pytest)."""
    cmds = _readme_commands()
    assert len(cmds) == 3, cmds
    setup, job, tests = cmds
    assert "pip install" in setup and "[test]" not in setup and "ringqa " not in setup
    assert job.startswith(".venv/bin/ringqa commission ") and "pip" not in job
    assert '".[test]"' in tests and "pytest" in tests


def test_ci_runs_the_readme_commands():
    """`.ci/run` runs the README's three commands verbatim and nothing else."""
    assert _ci_commands() == _readme_commands()
