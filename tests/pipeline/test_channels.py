"""Every channel of an input: which channels run by default, their labels, and channels with
dwells but no centreline (reported, never dropped)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ringqa.pipeline.commission import (
    ChannelRuns,
    channel_label,
    default_channels,
    unsimulated_channels,
)
from tests.pipeline.fakes import make_applicator


def test_a_ring_applicator_runs_its_ring_only():
    """The ring set's tandem keeps its role (dwells the same in every plan): default = ring."""
    app = make_applicator(tandem=True)
    assert default_channels(app) == ("ring",)


def test_labels_are_plan_numbers_else_names():
    app = make_applicator()
    ring = app.channels[0]
    assert channel_label(ring) == "ring"
    numbered = type(ring)(ring.name, ring.centreline, ring.lumen, ring.s_ref_m, label="4")
    assert channel_label(numbered) == "4"


def test_a_plan_channel_without_centreline_is_reported():
    """Plan channels 1 and 2 have dwells, 3 has none; the applicator has a centreline for
    channel 1 only: channel 2 is reported (number, name, dwell count), 3 is not (no dwells)."""
    app = make_applicator()
    ring = app.channels[0]
    app = SimpleNamespace(channels=(type(ring)(ring.name, ring.centreline, ring.lumen,
                                               ring.s_ref_m, label="1"),))  # fmt: skip
    plan = SimpleNamespace(channels=(
        SimpleNamespace(number=1, name="R", positions_mm=np.zeros((3, 3))),
        SimpleNamespace(number=2, name="IU", positions_mm=np.ones((4, 3))),
        SimpleNamespace(number=3, name="X", positions_mm=np.zeros((0, 3))),
    ))  # fmt: skip
    notes = unsimulated_channels(SimpleNamespace(applicator=app, rtplan=plan))
    assert len(notes) == 1
    assert notes[0].startswith("Channel 2 (IU) has 4 dwells but no centreline")
    assert not ChannelRuns((), notes).passed
