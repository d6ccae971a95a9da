"""Shared fixtures of the needle tests: the default settings and the paper's sweep (run once)."""

from __future__ import annotations

import pytest

from ringqa.needle.scene import load_settings
from ringqa.needle.sweep import run_sweep


@pytest.fixture(scope="session")
def needle_settings():
    """The shipped needle-paper settings (the defaults of ``ringqa needle``)."""
    return load_settings()


@pytest.fixture(scope="session")
def paper_sweep(needle_settings):
    """The whole paper sweep (34 rows, 28 channels) with the default settings, on two processes:
    the real code path of ``ringqa needle --sweep paper`` (about 10 s on the 2-core machine)."""
    return run_sweep(needle_settings, "paper", workers=2, progress=False)


@pytest.fixture(scope="session")
def paper_peaks(paper_sweep):
    """The sweep's peaks table (pandas)."""
    return paper_sweep.peaks_table()
