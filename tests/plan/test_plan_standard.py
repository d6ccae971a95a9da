"""Standard plans, transfers and the dose sanity checks of issue 5 (must-show 3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tg43
from ringqa.errors import RingQAError
from ringqa.plan import (
    DosePointSpec,
    DwellSet,
    Plan,
    applicator_dose_points,
    path_directions,
    points_array_mm,
    relative_difference_pct,
    resample_path,
    standard_plan,
)

RING_RADIUS_MM = 13.0
#: The hand-derived values below assume the lateral surface 4 mm outside the centreline
#: (surface points at 17 mm, 5 mm deeper at 22 mm from the ring centre).
SPEC = DosePointSpec(surface_offset_mm=4.0)


def _ring_plan(source, ring_frame, path):
    rel, pos, dirs = resample_path(path, 2.5, 5.0)
    pts = applicator_dose_points(ring_frame, SPEC)
    plan = standard_plan([DwellSet("ring", rel, pos, dirs)], points_array_mm(pts[:2]), source)
    return plan, pts


def test_path_directions_point_distally(ring_path):
    """On a circle of radius R traversed with azimuth phi0 - p/R, the distal direction at
    azimuth phi is the counter-clockwise tangent (-sin phi, cos phi, 0); central differences of a
    chord of angle h = 2.5/13 have the exact direction (error 0) for a circle inside the path."""
    path = ring_path()
    d = path_directions(path)
    phi = np.arctan2(path[:, 1], path[:, 0])
    expected = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)])
    np.testing.assert_allclose(d[1:-1], expected[1:-1], atol=1e-12)
    # one-sided ends: chord direction, off by half the chord angle = 2.5 / 13 / 2 rad = 5.5 deg
    ang = np.degrees(np.arccos(np.clip(np.sum(d[[0, -1]] * expected[[0, -1]], axis=1), -1, 1)))
    np.testing.assert_allclose(ang, np.degrees(2.5 / 13.0 / 2.0), rtol=1e-6)


def test_resample_every_second_position(ring_path):
    """2.5 mm path -> 5 mm plan: positions 0, 2, 4, ... of the path exactly (30 -> 15 dwells)."""
    path = ring_path()
    rel, pos, _ = resample_path(path, 2.5, 5.0)
    np.testing.assert_allclose(rel, np.arange(15) * 5.0)
    np.testing.assert_allclose(pos, path[::2], atol=1e-12)


def test_point_a_gets_the_prescription(mhdr, ring_frame, ring_path):
    """Mean of Point A left/right = 7 Gy within 0.1 %, recomputed independently of the plan's
    own dose path: sum_j rate_ij t_j S_K / 3600 s/h / 100 cGy/Gy from tg43.dose_rate_per_sk."""
    plan, pts = _ring_plan(mhdr, ring_frame, ring_path())
    a = points_array_mm(pts[:2])
    rate = tg43.dose_rate_per_sk(mhdr, plan.positions_mm, plan.directions, a)
    dose = rate @ plan.times_s * plan.sk_U / 3600.0 / 100.0
    assert np.mean(dose) == pytest.approx(7.0, rel=1e-3)
    assert np.all(plan.times_s == plan.times_s[0])  # equal dwell times


def test_identical_transfer_gives_zero_difference(mhdr, ring_frame, ring_path):
    """Transferring the plan onto identical positions and directions: 0.000 % at every point."""
    plan, pts = _ring_plan(mhdr, ring_frame, ring_path())
    same = plan.transfer(plan.positions_mm.copy(), plan.directions.copy(), "centreline")
    xyz = points_array_mm(pts)
    diff = relative_difference_pct(same.dose_gy(xyz), plan.dose_gy(xyz))
    assert np.all(np.round(np.abs(diff), 3) == 0.0)
    np.testing.assert_array_equal(same.times_s, plan.times_s)


def test_single_dwell_radial_shift_matches_hand_calculation(mhdr):
    """One dwell at (13, 0, 0) pointing +y; surface point at (17, 0, 0) (theta = 90 deg, F = 1).

    Moving the dwell 1 mm radially outward (to x = 14) changes r from 4 to 3 mm, so the dose ratio
    is G_L(0.3)/G_L(0.4) * g_L(0.3)/g_L(0.4) with G_L(r, 90) = 2 atan(L / 2r) / (L r), L = 0.36 cm:
    G_L(0.3) = 1.080839/0.108 = 10.0078, G_L(0.4) = 0.845702/0.144 = 5.8729, ratio 1.7041,
    times the g_L ratio interpolated linearly in the consensus table.
    """
    plan = Plan("measured", ("ring",), [0.0], [[13.0, 0, 0]], [[0, 1.0, 0]], [10.0], mhdr)
    moved = plan.transfer([[14.0, 0, 0]], [[0, 1.0, 0]], "moved")
    point = [[17.0, 0.0, 0.0]]
    L = mhdr.active_length_cm

    def geometry(r):
        return 2 * np.arctan(L / (2 * r)) / (L * r)

    def gl(r):
        return np.interp(r, mhdr.gl_r_cm, mhdr.gl)

    expected = geometry(0.3) / geometry(0.4) * gl(0.3) / gl(0.4)
    assert geometry(0.3) / geometry(0.4) == pytest.approx(1.7041, abs=2e-4)
    ratio = moved.dose_gy(point)[0] / plan.dose_gy(point)[0]
    assert ratio == pytest.approx(expected, rel=1e-6)


def test_radial_shift_outward_raises_surface_dose_as_tg43_says(mhdr, ring_frame, ring_path):
    """A ring plan symmetric about the y axis (15 dwells, 70 mm of arc centred on azimuth 90 deg);
    all dwells 1 mm radially outward (R 13 -> 14 mm). The lateral points are then nearer the
    nearest dwells, so their dose RISES, more at the surface (4 -> ~3 mm) than at 5 mm depth
    (9 -> ~8 mm), about equally left and right (anisotropy); Point A (33 mm away) changes by < 2 %.
    Magnitude: equal to a direct TG-43 sum (dose_rate_per_sk matrix times the transferred times)
    to 1e-9, and below the single-nearest-dwell inverse-square gains (4/3)^2 - 1 = 77.8 % and
    (9/8)^2 - 1 = 26.6 % (the other dwells, farther away, gain relatively less)."""
    path = ring_path(n=29, phi0_deg=90.0 + np.degrees(35.0 / 13.0))
    plan, pts = _ring_plan(mhdr, ring_frame, path)
    radial = plan.positions_mm.copy()
    radial[:, :2] *= (RING_RADIUS_MM + 1.0) / RING_RADIUS_MM
    moved = plan.transfer(radial, plan.directions, "moved")
    xyz = points_array_mm(pts)
    diff = dict(
        zip(
            [p.name for p in pts],
            relative_difference_pct(moved.dose_gy(xyz), plan.dose_gy(xyz)),
            strict=True,
        )
    )
    direct = tg43.dose_rate_per_sk(mhdr, radial, plan.directions, xyz) @ plan.times_s
    direct *= plan.sk_U / 3600.0 / 100.0
    np.testing.assert_allclose(moved.dose_gy(xyz), direct, rtol=1e-9)
    for side in ("left", "right"):
        assert 100 * ((4 / 3) ** 2 - 1) > diff[f"surface_{side}"] > diff[f"depth5_{side}"] > 0
        assert diff[f"depth5_{side}"] < 100 * ((9 / 8) ** 2 - 1)
        assert abs(diff[f"point_a_{side}"]) < 2.0
    for kind in ("point_a", "surface", "depth5"):
        # mirror-symmetric positions, but the source directions run the other way round on the
        # mirror side, and F(theta) is not symmetric about 90 deg: equal within 2 % of each other
        assert diff[f"{kind}_left"] == pytest.approx(diff[f"{kind}_right"], rel=0.02, abs=0.01)


def test_one_sided_plan_changes_that_side_most(mhdr, ring_frame, ring_path):
    """Dwells only on the left half of the ring (x > 0): shifting them 1 mm outward changes the
    left vaginal points over twice as much as the right ones (which are >= 2 R away), and
    the left points get more dose than the right ones in the first place."""
    path = ring_path(n=40, phi0_deg=90.0, step_mm=1.0)  # azimuth 90 -> about -86 deg: x > 0
    rel, pos, dirs = resample_path(path, 1.0, 5.0)
    assert np.all(pos[:, 0] > 0)
    pts = applicator_dose_points(ring_frame, SPEC)
    plan = standard_plan([DwellSet("ring", rel, pos, dirs)], points_array_mm(pts[:2]), mhdr)
    radial = pos.copy()
    radial[:, :2] *= 14.0 / 13.0
    xyz = points_array_mm(pts)
    base = plan.dose_gy(xyz)
    diff = np.abs(relative_difference_pct(plan.transfer(radial, dirs, "m").dose_gy(xyz), base))
    d = dict(zip([p.name for p in pts], diff, strict=True))
    b = dict(zip([p.name for p in pts], base, strict=True))
    for kind in ("point_a", "surface", "depth5"):
        assert b[f"{kind}_left"] > b[f"{kind}_right"]
    for kind in ("surface", "depth5"):
        assert d[f"{kind}_left"] > 2 * d[f"{kind}_right"]


@given(shift=st.floats(-3.0, 3.0), axis=st.integers(0, 2))
def test_rigid_shift_of_plan_and_points_changes_nothing(ring_path, shift, axis):
    """Moving dwells AND points by the same vector leaves every dose unchanged (TG-43 depends on
    relative geometry only): 0 % within 1e-9 %."""
    source = tg43.load_source("mhdr-v2")
    path = ring_path()
    rel, pos, dirs = resample_path(path, 2.5, 5.0)
    plan = Plan("measured", ("ring",) * len(rel), rel, pos, dirs, np.full(len(rel), 3.0), source)
    v = np.zeros(3)
    v[axis] = shift
    xyz = np.array([[17.0, 0, 0], [-22.0, 0, 0], [20, 0, 26.9]])
    moved = plan.transfer(pos + v, dirs, "shifted")
    diff = relative_difference_pct(moved.dose_gy(xyz + v), plan.dose_gy(xyz))
    np.testing.assert_allclose(diff, 0.0, atol=1e-9)


def test_bad_plans_raise_named_errors(mhdr):
    with pytest.raises(RingQAError, match="same length"):
        Plan("x", ("ring", "ring"), [0.0], [[0, 0, 0]], [[0, 0, 1]], [1.0], mhdr)
    with pytest.raises(RingQAError, match="dwell times"):
        Plan("x", ("ring",), [0.0], [[0, 0, 0]], [[0, 0, 1]], [-1.0], mhdr)
    with pytest.raises(RingQAError, match="coincide"):
        path_directions([[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    with pytest.raises(RingQAError, match="prescription"):
        standard_plan([DwellSet("r", [0.0], [[13, 0, 0]], [[0, 1, 0]])], [[20, 0, 27]], mhdr,
                      prescription_gy=0.0)  # fmt: skip
    with pytest.raises(RingQAError, match="no dwells"):
        standard_plan([], [[20, 0, 27]], mhdr)
