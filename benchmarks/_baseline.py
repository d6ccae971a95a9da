"""The "before" checkout of a before/after benchmark (bench_coldstart.py, bench_report.py).

``--baseline DIR`` names a checkout (e.g. a ``git worktree`` of the commit before a change) that
is measured as "before" through PYTHONPATH beside this one ("after"); ``none`` measures this
checkout alone (the default: a fixed sibling path was wrong from every checkout but one). A
baseline that is this checkout itself is no baseline and is left out.
"""

from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def add_baseline_option(ap: argparse.ArgumentParser) -> None:
    """``--baseline DIR`` (default ``none``: this checkout alone)."""
    ap.add_argument(
        "--baseline",
        default="none",
        help="a checkout measured as 'before' (e.g. a git worktree of the commit before the "
        "change); default none: this checkout alone",
    )


def trees(baseline: str) -> dict[str, Path]:
    """``{"before": DIR, "after": this checkout}``, or ``{"after": ...}`` alone when the
    baseline is ``none`` or this checkout itself."""
    if baseline == "none" or Path(baseline).resolve() == ROOT:
        return {"after": ROOT}
    return {"before": Path(baseline).resolve(), "after": ROOT}
