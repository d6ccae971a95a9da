"""The code is ruff-clean (lint rules and formatting configured in pyproject.toml).

ruff is in the [test] extra, so it must be installed: without it these tests fail (they used to
skip, which hid an unchecked tree)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    "args", [["check", "."], ["format", "--check", "."]], ids=["lint", "format"]
)
def test_ruff(args):
    """`ruff check .` and `ruff format --check .` report nothing."""
    done = subprocess.run(
        [sys.executable, "-m", "ruff", *args], cwd=ROOT, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout + done.stderr
