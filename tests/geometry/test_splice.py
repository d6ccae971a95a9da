"""Splicing a CT/film correction segment over a library centreline (ringqa.geometry.splice).

Two channels with known geometry: the parametric 26/60 ring, whose centreline from s0 = stem +
transition (88.0 mm) to the tip is the circle of radius R = 13 mm in z = 0 at azimuth
1.5 deg + (s - s0) / R (checked to 1 nm in the fixture), and the straight tandem (the z axis from
z = -60 mm, so s = z + 60 mm, 120 mm long, s_ref = 115 mm).

Blend formulas used below (module docstring of ringqa.geometry.splice): a segment parallel to a
STRAIGHT centreline at a lateral offset g is joined over b by the curve x = g h(sigma),
h = 10 sigma^3 - 15 sigma^4 + 6 sigma^5, sigma = (s - s_a + b) / b; max h' = 15/8 at sigma = 1/2,
max |h''| = 10 / sqrt(3) at sigma = (3 - sqrt 3) / 6.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.geometry import (
    Centreline,
    GeometryError,
    SplicedCentreline,
    SpliceError,
    ring_applicator,
    ring_channel,
    splice_applicator,
    splice_centreline,
    splice_channel,
    tandem_channel,
)
from ringqa.geometry.splice import MAX_GAP_M

MM = 1e-3
R = 13.0 * MM
PHI0 = np.deg2rad(1.5)


@pytest.fixture(scope="module")
def ring():
    """The 26/60 ring channel and the arc length where its circle starts (m)."""
    ch, info = ring_channel(26, 60)
    s0 = (info["stem_mm"] + info["transition_mm"]) * MM
    s = np.linspace(s0, ch.centreline.length_m, 50)
    assert np.abs(ch.centreline.position(s) - circle(s, s0)).max() < 1e-9
    return ch, s0


@pytest.fixture(scope="module")
def tandem():
    """The straight tandem: the z axis, s = z + 60 mm."""
    return tandem_channel()


def circle(s, s0, r=R):
    """Points (m) at library arc lengths ``s`` of the ring's circle, moved to radius ``r``."""
    phi = PHI0 + (np.asarray(s) - s0) / R
    r = np.broadcast_to(r, phi.shape)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), np.zeros_like(phi)])


def on_tandem(s_mm, x_mm=0.0):
    """Points (m) at tandem arc lengths ``s_mm``, moved by ``x_mm`` along +x."""
    s = np.asarray(s_mm, dtype=float)
    return np.column_stack([np.broadcast_to(x_mm, s.shape), 0 * s, s - 60.0]) * MM


def join_angle_deg(cl: Centreline, s_join: float, eps: float = 0.05 * MM) -> float:
    """Angle between the tangents ``eps`` before and after ``s_join`` (deg)."""
    t0, t1 = cl.tangent(np.array([s_join - eps, s_join + eps]))
    return float(np.degrees(np.arccos(np.clip(t0 @ t1, -1.0, 1.0))))


# --------------------------------------------------------------------------------------------
# (a) a segment that is the centreline changes nothing


@pytest.mark.parametrize(
    "range_mm",
    [(93.0, 113.0), (70.0, 86.0)],
    ids=["proximal-ring", "transition"],
)
def test_segment_equal_to_the_centreline_changes_nothing(ring, range_mm):
    """Points of the library centreline itself (every 1 mm, on the circle, or on the curved and
    twisted transition) give dP = dT = dK = 0 at both joins, so the blends add nothing and the
    new centreline is the old one: positions at mapped arc lengths and the length within 1 um,
    gaps, shift < 1 um. Angles and turns < 0.01 deg: the segment's own spline through 1 mm samples
    has end tangents good to ~0.002 deg on the transition (curvature up to 0.09 1/mm)."""
    ch, _ = ring
    cl = ch.centreline
    seg = cl.position(np.arange(range_mm[0], range_mm[1] + 0.5, 1.0) * MM)
    sp = splice_centreline(cl, seg)
    s = np.linspace(0.0, cl.length_m, 3001)
    moved = np.linalg.norm(sp.centreline.position(sp.map_arc_length(s)) - cl.position(s), axis=1)
    assert moved.max() < 1e-6
    assert abs(sp.length_m - cl.length_m) < 1e-6
    assert abs(sp.old_start_m - range_mm[0] * MM) < 1e-9
    assert abs(sp.old_end_m - range_mm[1] * MM) < 1e-9
    assert max(sp.gap_start_m, sp.gap_end_m, sp.max_shift_m) < 1e-6
    assert max(sp.angle_start_deg, sp.angle_end_deg, sp.turn_start_deg, sp.turn_end_deg) < 0.01


# --------------------------------------------------------------------------------------------
# (b) the proximal ring displaced 0.5 mm outward


@pytest.fixture(scope="module")
def displaced(ring):
    """The circle from s0 + 10 mm to s0 + 30 mm (21 points) moved 0.5 mm outward (r = 13.5 mm):
    both ends 0.5 mm from the library centreline; automatic blends (7 mm: all on the circle)."""
    ch, s0 = ring
    s = s0 + np.linspace(10.0, 30.0, 21) * MM
    seg = circle(s, s0, R + 0.5 * MM)
    new, sp = splice_channel(ch, seg)
    return ch, s0, seg, new, sp


def test_displaced_ring_passes_through_the_segment(displaced):
    """Every segment point is a data point of the new spline (< 1 um); between them the new
    centreline follows the 13.5 mm circle (the segment's own spline through 21 points ~1 mm apart:
    < 5 um), in the ring plane."""
    _, _, seg, new, sp = displaced
    cl = new.centreline
    _, d = cl.closest(seg, s_hint_m=sp.new_start_m, window_m=0.03)
    assert d.max() < 1e-6
    s = np.linspace(sp.new_start_m, sp.new_end_m, 2001)
    p = cl.position(s)
    assert np.abs(np.hypot(p[:, 0], p[:, 1]) - (R + 0.5 * MM)).max() < 5e-6
    assert np.abs(p[:, 2]).max() < 1e-9


def test_displaced_ring_joins_are_continuous_and_smooth(displaced):
    """At both joins the new centreline is at the segment's end point (< 1 um) and its tangents
    0.05 mm either side differ by < 1 deg: a smooth curve turns by its curvature x 0.1 mm there,
    0.44 deg on the 13 mm circle (measured 0.43 deg). Control: splicing the same points without
    blends (old points, then the segment, then old points) gives a kink (measured 7.2 deg, > 5)
    at the same place, so this measure does see kinks."""
    ch, _, seg, new, sp = displaced
    cl = new.centreline
    np.testing.assert_allclose(cl.position(sp.new_start_m), seg[0], atol=1e-6)
    np.testing.assert_allclose(cl.position(sp.new_end_m), seg[-1], atol=1e-6)
    angles = [join_angle_deg(cl, sp.new_start_m), join_angle_deg(cl, sp.new_end_m)]
    assert max(angles) < 1.0, angles

    old = ch.centreline
    pts = old.points_m
    s_pts, _ = old.closest(pts)
    naive = np.vstack([pts[s_pts < sp.old_start_m - 0.5 * MM], seg, pts[s_pts > sp.old_end_m]])
    naive_cl = Centreline.from_points(naive)
    s_join, _ = naive_cl.closest(seg[0])
    assert join_angle_deg(naive_cl, float(s_join[0])) > 5.0


def blend_length_on_circle_mm(g, b, c=2.0):
    """Length (mm) of a start blend of length ``b`` (mm) joining the 13 mm circle to its
    parallel at 13 + g mm, from the construction: with dP = g e_r, dT = 0 and
    dK = g / (R (R + g)) e_r (all along the join's radial unit vector e_r), the blend is
    r(s) + (g h_p(x) + c^2 dK h_k(y)) e_r, x = 0..1 over the blend, y = 0..1 over its last
    c = 2 mm, so |c'|^2 = 1 + 2 a sin(delta) + a^2 with a = g h_p'(x) / b + c dK h_k'(y) and
    delta = (1 - x) b / R the angle from the join. Trapezoidal rule on 200001 points (error
    < 1e-9 mm)."""
    dk = g / (13.0 * (13.0 + g))
    x = np.linspace(0.0, 1.0, 200001)
    y = np.clip(((x - 1.0) * b + c) / c, 0.0, None)
    a = g * (30 * x**2 - 60 * x**3 + 30 * x**4) / b + c * dk * (1.5 * y**2 - 4 * y**3 + 2.5 * y**4)
    f = np.sqrt(1 + 2 * a * np.sin((1 - x) * b / 13.0) + a * a)
    return b * float(np.sum((f[1:] + f[:-1]) / 2) * (x[1] - x[0]))


def test_displaced_ring_report_numbers(displaced):
    """Hand-derived expectations.

    - blends: automatic. A 5 mm blend would add up to 10/sqrt(3) g / b^2 = 0.115 1/mm of
      outward curvature, more than the circle's 1/13 = 0.077 (the bend would reverse); keeping a
      quarter of it needs b >= sqrt(5.77 g R / 0.75) = 7.07 mm on a straight approximation; the
      exact check on the curved blend passes at 7.0 mm (the 0.5 mm steps: 5, 5.5, ..., 7.0);
    - gaps: 13.5 - 13 = 0.5 mm (to 1 nm); the offset circle is parallel: angles < 0.01 deg;
    - largest shift 0.5 mm (the whole segment; the blends less), to 5 um (segment spline ends);
    - turn in each blend: below the straight channel's atan(15/8 * 0.5 / 7) = 7.63 deg, above
      7.0 (the bend reduces it by O(b/R));
    - normals: the change is in the ring plane and keeps the bend: no rotation (< 0.01 deg);
    - length: the arc at 13.5 mm, 20 * 13.5 / 13 = 20.769 mm, plus two blends of
      blend_length_on_circle_mm(0.5, 7) (7.1551 mm): +1.0795 mm, to 0.05 um;
    - the replaced range is s0 + 10 .. s0 + 30 mm on the library.
    """
    _, s0, _, _, sp = displaced
    assert isinstance(sp, SplicedCentreline)
    assert sp.blend_start_m == pytest.approx(7.0 * MM, abs=1e-12)
    assert sp.blend_end_m == pytest.approx(7.0 * MM, abs=1e-12)
    assert abs(sp.gap_start_m - 0.5 * MM) < 1e-9 and abs(sp.gap_end_m - 0.5 * MM) < 1e-9
    assert max(sp.angle_start_deg, sp.angle_end_deg) < 0.01
    assert abs(sp.max_shift_m - 0.5 * MM) < 5e-6
    assert 7.0 < sp.turn_start_deg < 7.63 and 7.0 < sp.turn_end_deg < 7.63
    assert sp.max_normal_turn_deg < 0.01
    arc = 20.0 * 13.5 / 13.0
    expected = arc - 20.0 + 2 * (blend_length_on_circle_mm(0.5, 7.0) - 7.0)
    assert sp.length_change_m / MM == pytest.approx(expected, abs=0.05e-3)
    assert abs(sp.old_start_m - (s0 + 10 * MM)) < 1e-9
    assert abs(sp.old_end_m - (s0 + 30 * MM)) < 1e-9
    assert abs((sp.new_end_m - sp.new_start_m) / MM - arc) < 2e-6
    mm = sp.as_mm_dict()
    assert abs(mm["max_shift_mm"] - 0.5) < 0.005 and mm["blend_start_mm"] == pytest.approx(7.0)


def test_short_blend_reverses_the_bend(ring):
    """The same 0.5 mm displacement with blend_m = 5 mm: the blend bends outward by up to
    0.115 1/mm > 1/13 (above), so the normal turns over (> 90 deg, measured 180) - the U-shaped
    lumen's flat side would face the inside there; the report shows it. The length is again
    20.769 - 20 + 2 (blend_length_on_circle_mm(0.5, 5) - 5) mm (0.05 um)."""
    ch, s0 = ring
    s = s0 + np.linspace(10.0, 30.0, 21) * MM
    sp = splice_centreline(ch.centreline, circle(s, s0, R + 0.5 * MM), blend_m=5 * MM)
    assert sp.blend_start_m == sp.blend_end_m == 5 * MM
    assert sp.max_normal_turn_deg > 90.0
    expected = 20.0 * 13.5 / 13.0 - 20.0 + 2 * (blend_length_on_circle_mm(0.5, 5.0) - 5.0)
    assert sp.length_change_m / MM == pytest.approx(expected, abs=0.05e-3)


def test_out_of_plane_gap_lengthens_the_blend(ring):
    """The proximal ring lifted 0.2 mm out of its plane (a CT slice offset): the blends add
    out-of-plane curvature 5.77 g / b^2, rotating the normal about the tangent by
    atan(5.77 * 0.2 / b^2 * 13): 31 deg with b = 5 mm (explicit: measured > 25 deg). The
    automatic blend grows until the rotation is <= 20 deg (criterion on the blend itself;
    measured on the fitted centreline < 21 deg), so b > 5 mm, about sqrt(5.77 * 0.2 * 13 /
    tan 20 deg) = 6.3 mm."""
    ch, s0 = ring
    s = s0 + np.linspace(10.0, 30.0, 21) * MM
    seg = circle(s, s0) + np.array([0.0, 0.0, 0.2 * MM])
    fixed = splice_centreline(ch.centreline, seg, blend_m=5 * MM)
    assert fixed.max_normal_turn_deg > 25.0
    auto = splice_centreline(ch.centreline, seg)
    assert 6.0 * MM <= auto.blend_start_m <= 7.0 * MM
    assert auto.max_normal_turn_deg < 21.0


def test_displaced_ring_keeps_s_ref_and_lumen(displaced):
    """s_ref (tip - 5 mm) lies distal of the change: it moves by the length change and stays at
    the same physical point (< 1 um). The U-shaped lumen starts at 60 mm (end of the stem),
    proximal of the change: unchanged; its cross-sections and the measured path are kept."""
    ch, _, _, new, sp = displaced
    assert not sp.changes(ch.s_ref_m)
    assert new.s_ref_m == pytest.approx(ch.s_ref_m + sp.length_change_m, abs=1e-12)
    moved = np.linalg.norm(
        new.centreline.position(new.s_ref_m) - ch.centreline.position(ch.s_ref_m)
    )
    assert moved < 1e-6
    tip = np.linalg.norm(
        new.centreline.position(new.length_m) - ch.centreline.position(ch.length_m)
    )
    assert tip < 1e-6
    np.testing.assert_array_equal(new.lumen.seg_s, ch.lumen.seg_s)
    np.testing.assert_array_equal(new.lumen.seg_flat, ch.lumen.seg_flat)
    assert new.name == ch.name and new.measured_path_m is ch.measured_path_m


def test_tangential_segment_leaves_the_library_alone(ring):
    """A bulge that meets the centreline tangentially: r = R + 0.5 mm sin^2(pi x), x = 0..1 over
    the same 20 mm. At its ends dP = dT = 0; only its curvature differs (by 0.5 * 2 pi^2 / 20^2
    = 0.025 1/mm), blended in over the last 2 mm: the automatic blends stay at 5 mm, the library
    moves by at most 0.0173 c^2 dK = 0.0173 * 4 * 0.025 = 1.7 um before the join (measured
    1.67 um), the direction turns by at most c dK max|h_k'| = 2 * 0.025 * 0.05 rad = 0.14 deg
    (measured against the nearest library tangent: < 0.25 deg), the joins show no kink (< 1 deg,
    as on the plain circle), the normals stay in the ring plane and the largest shift is the
    bulge's 0.5 mm (1 um)."""
    ch, s0 = ring
    s = s0 + np.linspace(10.0, 30.0, 21) * MM
    bulge = 0.5 * MM * np.sin(np.pi * np.linspace(0.0, 1.0, 21)) ** 2
    sp = splice_centreline(ch.centreline, circle(s, s0, R + bulge))
    assert max(sp.gap_start_m, sp.gap_end_m) < 1e-9
    assert max(sp.angle_start_deg, sp.angle_end_deg) < 0.01
    assert max(sp.turn_start_deg, sp.turn_end_deg) < 0.25
    s_blend = np.linspace(sp.new_start_m - 5 * MM, sp.new_start_m, 501)
    _, moved = ch.centreline.closest(
        sp.centreline.position(s_blend), s_hint_m=sp.old_start_m, window_m=0.01
    )
    assert moved.max() < 2e-6
    assert join_angle_deg(sp.centreline, sp.new_start_m) < 1.0
    assert join_angle_deg(sp.centreline, sp.new_end_m) < 1.0
    assert abs(sp.max_shift_m - 0.5 * MM) < 1e-6
    assert sp.blend_start_m == sp.blend_end_m == 5 * MM
    assert sp.max_normal_turn_deg < 0.01


# --------------------------------------------------------------------------------------------
# a straight channel: the blend formulas exactly


def test_straight_offset_follows_the_blend_formula(tandem):
    """Tandem (z axis) with a segment 0.5 mm along +x from s = 40 to 80 mm (41 points).

    - start blend, s = 35..40 mm: x = 0.5 h(sigma); at s = 37.5 mm (sigma 1/2) x = 0.25 mm;
      at s = 36 mm (sigma 0.2) x = 0.5 (10 * 0.008 - 15 * 0.0016 + 6 * 0.00032) = 0.02896 mm;
    - turn: atan(15/8 * 0.5 / 5) = 10.6197 deg (0.01 deg);
    - largest curvature: (10 / sqrt 3) 0.5 / 25 / (1 + y'^2)^1.5 with y' = 0.1 h'(0.2113)
      = 0.0833 there: 0.11428 1/mm (1 %);
    - length change, both blends: (g^2/b) int h'^2 - (g^4 / 4 b^3) int h'^4
      + (g^6 / 8 b^5) int h'^6 = 0.071429 - 0.000463 + 0.000007 = 0.070973 mm
      (int h'^2 = 10/7, int h'^4 = 30^4 B(9, 9) = 3.702, int h'^6 = 30^6 B(13, 13) = 10.78), to
      0.5 um;
    - s_ref = 115 mm, distal: moves by that length change, same point (1 um).
    """
    g, b = 0.5, 5.0
    seg = on_tandem(np.arange(40.0, 80.5, 1.0), x_mm=g)
    new, sp = splice_channel(tandem, seg)
    cl = new.centreline
    s = np.linspace(sp.new_start_m - 6 * MM, sp.new_start_m, 6001)
    p = cl.position(s) / MM
    z = p[:, 2] + 60.0
    assert np.all(np.diff(z) > 0)
    np.testing.assert_allclose(np.interp([37.5, 36.0], z, p[:, 0]), [0.25, 0.028960], atol=1e-6)
    assert sp.turn_start_deg == pytest.approx(np.degrees(np.arctan(15 / 8 * g / b)), abs=0.01)
    assert sp.turn_end_deg == pytest.approx(sp.turn_start_deg, abs=0.01)
    assert sp.max_curvature_per_m * MM == pytest.approx(0.11428, rel=0.01)
    assert sp.length_change_m / MM == pytest.approx(0.070973, abs=5e-4)
    assert sp.new_start_m / MM == pytest.approx(40.0 + 0.070973 / 2, abs=1e-5)
    assert new.s_ref_m == pytest.approx(tandem.s_ref_m + sp.length_change_m, abs=1e-12)
    moved = np.linalg.norm(cl.position(new.s_ref_m) - tandem.centreline.position(tandem.s_ref_m))
    assert moved < 1e-6


def test_segment_meeting_at_an_angle_reports_the_kink(tandem):
    """x = 1 mm sin(pi (s - 40) / 20), s = 40..60 mm: both ends ON the axis (gap 0) but at
    atan(pi / 20) = 8.93 deg to it (curvature 0 there). The report gives that kink as the join
    angle; the blend turns the direction gradually from the axis to the segment's, so its largest
    turn is the same 8.93 deg, and the new centreline has no kink at the joins (< 1 deg over
    0.1 mm). The blend's largest curvature is |dT| / b max|h_t''| with |dT| = 2 sin(8.93 deg / 2)
    = 0.1557, h_t = -4 s^3 + 7 s^4 - 3 s^5, max|h_t''| = 3.94 (at s = 0.757): 0.1227 1/mm (2 %).
    """
    s_mm = np.linspace(40.0, 60.0, 21)
    x_mm = np.sin(np.pi * (s_mm - 40.0) / 20.0)
    seg = on_tandem(s_mm) + np.column_stack([x_mm, 0 * x_mm, 0 * x_mm]) * MM
    sp = splice_centreline(tandem.centreline, seg)
    kink = np.degrees(np.arctan(np.pi / 20))
    assert sp.gap_start_m < 1e-9 and sp.gap_end_m < 1e-9
    assert sp.angle_start_deg == pytest.approx(kink, abs=0.02)
    assert sp.angle_end_deg == pytest.approx(kink, abs=0.02)
    assert sp.turn_start_deg == pytest.approx(kink, abs=0.02)
    assert join_angle_deg(sp.centreline, sp.new_start_m) < 1.0
    assert join_angle_deg(sp.centreline, sp.new_end_m) < 1.0
    assert sp.max_curvature_per_m * MM == pytest.approx(0.1227, rel=0.02)


def test_s_ref_inside_the_change_is_interpolated(tandem):
    """Segment s = 100..113 mm (offset 0.3 mm) with 3 mm blends: the change reaches 116 mm, so
    s_ref = 115 mm lies in the end blend; it is mapped linearly between the join points (between
    the new end of the segment and 116 mm + the length change) and `changes` says so."""
    seg = on_tandem(np.arange(100.0, 113.5, 1.0), x_mm=0.3)
    new, sp = splice_channel(tandem, seg, blend_m=3 * MM)
    assert sp.changes(tandem.s_ref_m)
    lo = sp.new_end_m
    hi = 116 * MM + sp.length_change_m
    frac = (115 - 113) / 3
    assert new.s_ref_m == pytest.approx(lo + frac * (hi - lo), abs=1e-12)


def test_map_arc_length_keeps_infinities_and_order(displaced):
    """+-inf (the lumen's outer bounds) stay infinite; the map increases strictly."""
    *_, sp = displaced
    out = sp.map_arc_length(np.array([-np.inf, 0.0, 0.1, np.inf]))
    assert out[0] == -np.inf and out[-1] == np.inf and out[1] == 0.0
    s = np.linspace(0.0, sp.old_length_m, 5001)
    assert np.all(np.diff(sp.map_arc_length(s)) > 0)
    assert isinstance(sp.map_arc_length(0.05), float)


def test_splice_applicator_replaces_one_channel():
    """The ring channel is replaced, the tandem and the ring frame are the same objects/values,
    and the metadata records the correction in mm."""
    app = ring_applicator(26, 60)
    ring = app.channel("ring")
    s = np.arange(95.0, 110.5, 1.0) * MM
    seg = ring.centreline.position(s) + np.array([0.0, 0.0, 0.2 * MM])
    new_app, sp = splice_applicator(app, "ring", seg)
    assert new_app.channel("tandem") is app.channel("tandem")
    assert new_app.channel("ring").centreline is sp.centreline
    np.testing.assert_array_equal(new_app.ring_centre_m, app.ring_centre_m)
    rec = new_app.metadata["centreline_correction"]["ring"]
    assert rec["gap_start_mm"] == pytest.approx(0.2, abs=1e-6)
    assert "centreline_correction" not in app.metadata
    with pytest.raises(GeometryError, match="no channel 'needle'"):
        splice_applicator(app, "needle", seg)


# --------------------------------------------------------------------------------------------
# (c) refusals


def _ring_seg(ring, offset_mm=0.0, start=93.0, stop=113.0, step=1.0):
    _, s0 = ring
    s = np.arange(start, stop + step / 2, step) * MM
    return circle(s, s0, R + offset_mm * MM)


def test_refuses_a_segment_that_does_not_meet_the_centreline(ring):
    """The segment moved 3.2 mm outward: its first point is 3.2 mm away (> 1.0 mm): one line
    naming the argument, which end, how far, and the fix."""
    ch, _ = ring
    with pytest.raises(SpliceError) as err:
        splice_centreline(ch.centreline, _ring_seg(ring, offset_mm=3.2))
    msg = str(err.value)
    assert msg.startswith("segment_m: the correction segment does not meet the centreline")
    assert "its first point (point 0) is 3.2 mm away" in msg
    assert "its last point (point 20) is 3.2 mm away" in msg
    assert "within 1.0 mm" in msg and "\n" not in msg
    assert err.value.points == (0, 20)


def test_refuses_one_end_off_and_names_it(ring):
    """Only the last point is off (1.4 mm, > 1 mm): only it is named; with max_gap_m = 2 mm the
    same segment is accepted and its gap reported."""
    ch, _ = ring
    seg = _ring_seg(ring)
    seg[-1] *= (R + 1.4 * MM) / R
    with pytest.raises(SpliceError, match=r"its last point \(point 20\) is 1\.4 mm away") as err:
        splice_centreline(ch.centreline, seg)
    assert "first point" not in str(err.value)
    sp = splice_centreline(ch.centreline, seg, max_gap_m=2 * MM)
    assert sp.gap_end_m == pytest.approx(1.4 * MM, abs=1e-9)
    assert MAX_GAP_M == 1.0 * MM


@pytest.mark.parametrize(
    ("make", "pattern", "points"),
    [
        (lambda s: s[:3], r"at least 4 points, got 3", ()),
        (
            lambda s: np.vstack([s[:5], s[3:]]),
            r"point 5 repeats point 3.*remove duplicated",
            (3, 5),
        ),
        (lambda s: np.vstack([s[:8], s[5], s[8:]]), r"repeats point 5", (5, 8)),
        (lambda s: s[::-1], r"runs from distal to proximal.*reverse their order", (0, 20)),
        (lambda s: s * 1e3, r"look like millimetres.*give metres", ()),
        (lambda s: np.vstack([s[:4], [np.nan, 0, 0], s[5:]]), r"point 4 is not finite", (4,)),
        (lambda s: s[:, :2], r"shape \(21, 2\)", ()),
    ],
    ids=["too-few", "duplicate", "duplicate-far", "backwards", "millimetres", "nan", "shape"],
)
def test_refusals_name_the_problem_and_fix(ring, make, pattern, points):
    ch, _ = ring
    with pytest.raises(SpliceError, match=pattern) as err:
        splice_centreline(ch.centreline, make(_ring_seg(ring)))
    assert str(err.value).startswith("segment_m: ")
    assert err.value.points == points


def test_refuses_a_segment_that_folds_back(tandem):
    """Up the axis from 40 to 50 mm (points 0-10), then back down to 45 mm 0.5 mm aside: the
    chord after point 10 points back (turn 180 - atan(0.5) = 153 deg)."""
    up = on_tandem(np.arange(40.0, 50.5, 1.0))
    down = on_tandem(np.arange(49.0, 44.5, -1.0), x_mm=0.5)
    on = on_tandem(np.arange(46.0, 60.5, 1.0), x_mm=1.0)
    on[-1, 0] = 0.0
    with pytest.raises(SpliceError, match=r"turns back by 153 degrees at point 10.*overlaps"):
        splice_centreline(tandem.centreline, np.vstack([up, down, on]))


def test_refuses_a_segment_that_loops(tandem):
    """A smooth loop (no sharp turn): up the axis 40 -> 51 mm, then once round a 3 mm circle
    in the x-z plane (x = 3 (1 - cos t), z = 52 + 3 sin t, 10 deg per point, rising 0.4 mm in y
    so that it does not pass through its own start), then on up 53 -> 61 mm at y = 0.4 mm. The
    loop's points stop advancing along the channel after t = 90 deg."""
    t = np.linspace(0.0, 2 * np.pi, 37)
    loop = np.column_stack([3.0 * (1 - np.cos(t)), 0.4 * t / (2 * np.pi), 52.0 + 3.0 * np.sin(t)])
    up1 = np.column_stack([np.zeros(12), np.zeros(12), np.linspace(40.0, 51.0, 12)])
    up2 = np.column_stack([np.zeros(9), np.full(9, 0.4), np.linspace(53.0, 61.0, 9)])
    seg = (np.vstack([up1, loop, up2]) - [0.0, 0.0, 60.0]) * MM
    with pytest.raises(SpliceError, match=r"point \d+ is not distal of point \d+ along"):
        splice_centreline(tandem.centreline, seg)


@pytest.mark.parametrize(
    ("start", "stop", "pattern"),
    [
        (3.0, 30.0, r"starts 3\.0 mm after the channel entry.*blend_m = 5\.0 mm"),
        (80.0, 117.0, r"ends 3\.0 mm before the channel tip.*smaller blend_m"),
    ],
)
def test_refuses_a_segment_without_room_for_the_join(tandem, start, stop, pattern):
    seg = on_tandem(np.arange(start, stop + 0.5, 1.0))
    with pytest.raises(SpliceError, match=pattern):
        splice_centreline(tandem.centreline, seg)
    splice_centreline(tandem.centreline, seg, blend_m=2 * MM)  # fits with a 2 mm blend


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"blend_m": 0.0}, r"blend_m: must be a positive length"),
        ({"blend_m": 5.0}, r"blend_m: 5 m is implausibly long"),
        ({"max_gap_m": -1e-3}, r"max_gap_m: must be a positive length"),
        ({"max_gap_m": "a"}, r"max_gap_m: 'a' is not a number"),
    ],
)
def test_refuses_bad_settings(tandem, kwargs, pattern):
    seg = on_tandem(np.arange(40.0, 60.5, 1.0))
    with pytest.raises(SpliceError, match=pattern):
        splice_centreline(tandem.centreline, seg, **kwargs)


def test_error_describes_points_with_other_names(ring):
    """The io layer renames points to file lines: describe(names) puts them in the problem."""
    ch, _ = ring
    with pytest.raises(SpliceError) as err:
        splice_centreline(ch.centreline, _ring_seg(ring)[::-1])
    names = [f"line {i + 2}" for i in range(21)]
    text = err.value.describe(names)
    assert "its first point (line 2)" in text and "its last (line 22)" in text
