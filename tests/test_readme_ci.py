"""README's Quick start is what CI runs: the newcomer's two commands are exactly `.ci/run`'s.

The README gives two indented commands under "## Quick start" (set-up + main job, then the
tests); `.ci/run` must run exactly those lines, in that order, so a green CI proves that the
README's instructions work on a fresh machine.
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


def test_readme_gives_exactly_two_commands():
    """One set-up + main-job command and one test command."""
    cmds = _readme_commands()
    assert len(cmds) == 2, cmds
    assert "pip install" in cmds[0] and "ringqa " in cmds[0]
    assert "pytest" in cmds[1]


def test_ci_runs_the_readme_commands():
    """`.ci/run` runs the README's two commands verbatim and nothing else."""
    assert _ci_commands() == _readme_commands()
