"""``ringqa commission``'s RT Plan read in a forked process (``commission_ahead``'s reader):
the warnings the reading gives are shown once, by the process that takes the plan, and only
when the plan is used; a reading that fails shows nothing (the commissioning then reads the
file itself and shows them as it always has)."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pytest

from ringqa.cli import commission as cli
from ringqa.io import rtplan as rtplan_mod
from ringqa.pipeline.settings import CommissionSettings

EXAMPLE = (Path(__file__).resolve().parents[2] / "data" / "examples" / "oncentra_ring26x60"
           / "RP_ring26x60_oncentra43.dcm")  # fmt: skip
needs_fork = pytest.mark.skipif(
    not hasattr(os, "fork") or (os.cpu_count() or 1) < 2, reason="needs fork and 2 cores"
)


@needs_fork
@pytest.mark.parametrize("fails", [False, True])
def test_the_readers_warnings_are_shown_where_the_plan_is_taken(monkeypatch, fails):
    """A reading that warns (as pydicom does for an unknown character set escape): the warning
    is not shown by the reader but by the taker, once, with its category and place; when the
    reading then fails, nothing is shown and no plan handed over."""
    real = rtplan_mod.read_rtplan

    def read(path):
        warnings.warn("Found unknown escape sequence", UserWarning, stacklevel=1)
        if fails:
            raise rtplan_mod.RTPlanError(path, "is broken", "export it again")
        return real(path)

    monkeypatch.setattr(rtplan_mod, "read_rtplan", read)
    reader = cli._read_plan_ahead(str(EXAMPLE))
    assert reader is not None and reader.forked
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        loaded, load_s = cli._loaded_ahead(str(EXAMPLE), CommissionSettings(), reader)
    reader.cancel()
    if fails:
        assert (loaded, load_s, shown) == (None, 0.0, [])
        return
    assert loaded is not None and loaded.rtplan.path == real(EXAMPLE).path
    assert [(w.category, str(w.message), w.filename) for w in shown] == [
        (UserWarning, "Found unknown escape sequence", __file__)
    ]
