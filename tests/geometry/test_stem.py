"""The modelled stem: trimming a channel's straight shaft keeps every dwell where it is."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.geometry import Centreline, Channel, GeometryError, Lumen, ring_applicator
from ringqa.geometry.stem import first_bend_m, trim_to_stem


def _shaft_and_arc(shaft_m=0.2, radius_m=0.013, arc_deg=200.0):
    """A straight shaft along +y, then a circle of radius 13 mm (tangent at the joint)."""
    s1 = np.linspace(0.0, shaft_m, int(shaft_m / 0.5e-3) + 1)
    shaft = np.column_stack([np.full_like(s1, radius_m), s1 - shaft_m, np.zeros_like(s1)])
    phi = np.linspace(0.0, np.deg2rad(arc_deg), 400)[1:]
    arc = np.column_stack([radius_m * np.cos(phi), radius_m * np.sin(phi), np.zeros_like(phi)])
    cl = Centreline.from_points(np.vstack([shaft, arc]))
    lumen = Lumen.stepped([0.1], [1.6e-3, 1.5e-3], [1.5e-3, 1.4e-3])  # a step inside the shaft
    return Channel("ring", cl, lumen, cl.length_m - 5e-3, measured_path_m=np.zeros((3, 3)),
                   measured_step_m=2.5e-3, measured_source="test path")  # fmt: skip


def test_trimming_keeps_positions_and_shifts_arc_lengths():
    """A 200 mm shaft before the arc, trimmed to a 60 mm stem: 140 mm dropped; the point at
    relative position p sits at the same place in space (to 1e-5 mm, the refitted spline) before
    and after; the lumen
    step (at 100 mm) moves to 100 - 140 = -40 mm; the path and its source stay."""
    ch = _shaft_and_arc()
    bend = first_bend_m(ch)
    assert bend == pytest.approx(0.2, abs=1e-3)
    t = trim_to_stem(ch, 0.060)
    assert t.dropped_m == pytest.approx(bend - 0.060, abs=1e-12)
    rel = np.linspace(0.0, 0.1, 21)
    a = ch.centreline.position(ch.s_ref_m - rel)
    b = t.channel.centreline.position(t.channel.s_ref_m - rel)
    assert np.max(np.linalg.norm(a - b, axis=1)) < 1e-8
    assert t.channel.lumen.seg_s[1] == pytest.approx(0.1 - t.dropped_m, abs=1e-12)
    assert t.channel.measured_source == "test path" and t.channel.measured_step_m == 2.5e-3
    assert first_bend_m(t.channel) == pytest.approx(0.060, abs=1e-3)
    # the same cable advance plus the dropped length reaches the same dwell on the whole channel
    # (what the numerical check's whole-channel runs rely on, pipeline.simulate.StemCheck)
    assert t.channel.s_ref_m == pytest.approx(ch.s_ref_m - t.dropped_m, abs=1e-12)
    assert t.channel.length_m == pytest.approx(ch.length_m - t.dropped_m, abs=1e-6)


def test_a_short_stem_is_left_alone():
    """The shipped 26/60 ring has a 60 mm stem: nothing to drop, the same channel back."""
    ring = ring_applicator(26, 60).channel("ring")
    t = trim_to_stem(ring, 0.060)
    assert t.dropped_m == 0.0 and t.channel is ring
    assert trim_to_stem(ring, None).channel is ring


def test_a_bad_stem_length_is_refused():
    with pytest.raises(GeometryError, match=r"stem: -1 m is not a positive length"):
        trim_to_stem(_shaft_and_arc(), -1)
