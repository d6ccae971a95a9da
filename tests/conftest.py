"""Shared fixtures for the whole suite.

- ``shared_dir``: the read-only reference material beside the checkout (``../shared``); tests that
  need it skip with a clear reason when it is absent (a user's clone does not have it). This is
  the ONLY skip in the suite outside tests/simulation and tests/tg43: anything else a test needs
  must exist, and its absence is a failure.
- Hypothesis runs with a deterministic profile so CI results are reproducible.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ringqa",
    derandomize=True,
    database=None,  # no replays of examples another profile or version found: same examples
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ringqa"))

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DIR = Path(os.environ.get("RINGQA_SHARED", REPO_ROOT.parent / "shared")).resolve()


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """The checkout's root folder."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """``../shared`` reference material; skips the test when it is absent."""
    if not (SHARED_DIR / "reference").is_dir():
        pytest.skip(f"reference material not found at {SHARED_DIR} (only in the developers' setup)")
    return SHARED_DIR


@pytest.fixture(scope="session")
def oncentra_plan_path(shared_dir: Path) -> Path:
    """The shared Oncentra 26 mm / 60 degree tandem-and-ring RT Plan."""
    plan_dir = shared_dir / "reference" / "rtplans" / "oncentra_ring26x60"
    path = plan_dir / "RP_ring26x60_oncentra43.dcm"
    assert path.is_file(), f"{path}: missing from the shared reference material"
    return path


@pytest.fixture(autouse=True)
def no_user_config(monkeypatch):
    """No test reads the developer's own clinic configuration (``RINGQA_CONFIG`` empty: none);
    tests of the user configuration set the variable themselves."""
    monkeypatch.setenv("RINGQA_CONFIG", "")


@pytest.fixture(autouse=True)
def no_compile_notice(monkeypatch):
    """The commands' stderr holds only what they say, cold numba cache or warm (the notice and
    the compile helper have their own tests: tests/cli/test_warmup.py)."""
    monkeypatch.setenv("RINGQA_COMPILE_NOTICE", "0")
