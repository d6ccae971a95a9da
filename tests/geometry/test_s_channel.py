"""The paper's S-shaped needle channel (ringqa.geometry.s_channel): roots, closure, planarity,
torsion, tangent continuity, lumen and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringqa.geometry import GeometryError, s_channel, s_channel_layout
from ringqa.geometry.s_channel import bend_angle, max_radius_mm, s_centreline_mm
from ringqa.units import m_to_mm, mm_to_m

RADII = (20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0, 55.0, 60.0)


def test_the_quoted_roots():
    """r = 20 mm: a 5-12-13 triangle: sin t1 = 5/13, cos t1 = 12/13 solves
    (w - 2r) cos t + 2r = H sin t (-10 * 12/13 + 40 = 80 * 5/13 = 30.77), t1 = 22.62 deg and
    d2 = (H - 2 r sin t1) / cos t1 = (80 - 200/13) * 13/12 = 70 mm. r = 60 mm: 3-4-5:
    -90 * 0.8 + 120 = 80 * 0.6 = 48, t1 = 36.87 deg, d2 = (80 - 72) / 0.8 = 10 mm."""
    t, d2 = bend_angle(20.0)
    assert t == pytest.approx(math.atan2(5.0, 12.0), abs=1e-12)
    assert math.degrees(t) == pytest.approx(22.6, abs=0.05)
    assert d2 == pytest.approx(70.0, abs=1e-9)
    t, d2 = bend_angle(60.0)
    assert t == pytest.approx(math.atan2(3.0, 4.0), abs=1e-12)
    assert math.degrees(t) == pytest.approx(36.9, abs=0.05)
    assert d2 == pytest.approx(10.0, abs=1e-9)


@pytest.mark.parametrize("radius", RADII)
def test_planar_s_closes_on_width_and_height(radius):
    """tau = 0: the exit ends at (h, w, 0) = (120, 30, 0) mm from the start of the entry (both
    equations hold), to 1 um; the centreline is d1 + 2 r t1 + d2 + d3 long (1 um); the bends
    have curvature 1/r at their middles (1 %)."""
    lay = s_channel_layout(radius)
    ch = s_channel(radius)
    cl = ch.centreline
    end = m_to_mm(cl.position(cl.length_m))
    assert end == pytest.approx([120.0, 30.0, 0.0], abs=1e-3)
    assert m_to_mm(cl.length_m) == pytest.approx(
        10.0 + 2 * radius * lay.bend_angle_rad + lay.middle_mm + 30.0, abs=1e-3
    )
    for a, b in (lay.bend1_mm, lay.bend2_mm):
        kappa = float(cl.curvature(mm_to_m(0.5 * (a + b))))
        assert kappa == pytest.approx(1.0 / mm_to_m(radius), rel=0.01)


def test_planar_s_is_planar_and_torsion_leaves_the_plane():
    """tau = 0: every point has z = 0 (1e-9 mm; the bends lie in the x-y plane). tau = pi/2:
    bend 2 turns towards +z, so the exit leaves the plane by r (1 - cos t1) + d3 sin t1 > 10 mm
    (r = 35 mm)."""
    pts = s_centreline_mm(s_channel_layout(35.0, 0.0))
    assert np.abs(pts[:, 2]).max() < 1e-9
    cl = s_channel(35.0, 0.0).centreline
    s = np.linspace(0.0, cl.length_m, 400)
    assert np.abs(cl.position(s)[:, 2]).max() < 1e-12
    lay = s_channel_layout(35.0, math.pi / 2)
    end = s_centreline_mm(lay)[-1]
    t1 = lay.bend_angle_rad
    assert end[2] == pytest.approx(35.0 * (1 - math.cos(t1)) + 30.0 * math.sin(t1), abs=1e-6)
    assert end[2] > 10.0


@pytest.mark.parametrize("tau", [0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4, math.pi])
def test_second_bending_plane_is_turned_by_pi_minus_tau(tau):
    """Bend 1 lies in the x-y plane (binormal b1 = +z). Bend 2's normal is bend 1's end normal
    n_a turned about the tangent t_a by pi - tau: n_2 = -cos(tau) n_a + sin(tau) z, so its
    binormal b2 = t_a x n_2 = -cos(tau) z + sin(tau) (t_a x z) and b1 . b2 = -cos(tau): the
    angle between the two bending planes is pi - tau (1e-3 rad, read off the fitted spline's
    Frenet frame at the middle of each bend)."""
    lay = s_channel_layout(35.0, tau)
    cl = s_channel(35.0, tau).centreline
    b1 = cl.binormal(mm_to_m(0.5 * sum(lay.bend1_mm)))
    b2 = cl.binormal(mm_to_m(0.5 * sum(lay.bend2_mm)))
    assert b1 == pytest.approx([0.0, 0.0, 1.0], abs=1e-6)
    angle = math.acos(float(np.clip(np.dot(b1, b2), -1.0, 1.0)))
    assert angle == pytest.approx(math.pi - tau, abs=1e-3)


@pytest.mark.parametrize("tau", [0.0, math.pi / 2, math.pi])
@pytest.mark.parametrize("radius", [20.0, 60.0])
def test_tangent_is_continuous_at_the_joints(radius, tau):
    """The exact points have no kink: consecutive chords turn by at most the bend's angle per
    sample, spacing / r (0.25 / 20 = 0.0125 rad; +1 %), also across the four joints (a tangent
    mismatch at a joint, e.g. a wrongly rotated second bend, would show as a larger turn). The
    fitted centreline's tangent at each joint equals the exact piece tangent within h / (4 r)
    (3.1e-3 at r = 20 mm; observed h / (7.6 r)): the quintic spline smooths the jump of curvature
    1/r over about one point spacing h = 0.25 mm. Entry and exit run along +x for tau = 0, the
    middle straight along (cos t1, sin t1, 0)."""
    lay = s_channel_layout(radius, tau)
    pts = s_centreline_mm(lay)
    chords = np.diff(pts, axis=0)
    u = chords / np.linalg.norm(chords, axis=1)[:, None]
    turn = np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0))
    assert turn.max() <= 1.01 * 0.25 / radius
    cl = s_channel(radius, tau).centreline
    t1 = lay.bend_angle_rad
    mid = np.array([math.cos(t1), math.sin(t1), 0.0])
    tol = 0.25 / (4.0 * radius)
    for s_mm, expected in (
        (lay.bend1_mm[0], [1.0, 0.0, 0.0]),
        (lay.bend1_mm[1], mid),
        (lay.bend2_mm[0], mid),
    ):
        assert cl.tangent(mm_to_m(s_mm)) == pytest.approx(expected, abs=tol)
    if tau == 0.0:
        assert cl.tangent(mm_to_m(lay.bend2_mm[1])) == pytest.approx([1, 0, 0], abs=tol)


def test_lumen_and_dwell_reference():
    """D = 2.6 mm: r_b = 1.3 mm, r_a = 1.2 mm (Table 1); D = 2.8 mm: 1.4 / 1.3 mm (the printing
    tolerance adds 0.1 mm to both); s_ref = length - 5 mm."""
    ch = s_channel(35.0, 0.0, 2.6)
    assert m_to_mm(ch.lumen.seg_rb[0]) == pytest.approx(1.3)
    assert m_to_mm(ch.lumen.seg_ra[0]) == pytest.approx(1.2)
    ch = s_channel(35.0, 0.0, 2.8)
    assert m_to_mm(ch.lumen.seg_rb[0]) == pytest.approx(1.4)
    assert m_to_mm(ch.lumen.seg_ra[0]) == pytest.approx(1.3)
    assert m_to_mm(ch.length_m - ch.s_ref_m) == pytest.approx(5.0)


def test_largest_radius():
    """d2 = 0 at tan(t/2) = w / H = 30 / 80: sin t = 2 (3/8) / (1 + 9/64) = 48/73, so
    r_max = 80 / (2 * 48/73) = 60.833 mm. Just below it the S exists with d2 > 0; above it the
    generator says so and names the limit."""
    assert max_radius_mm() == pytest.approx(80.0 * 73.0 / 96.0, abs=1e-9)
    assert bend_angle(60.8)[1] > 0.0
    with pytest.raises(GeometryError, match=r"largest is 60\.8 mm"):
        s_channel(61.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"radius_mm": 35.0, "torsion_rad": -0.1}, "torsion_rad = -0.1: .* 0..pi"),
        ({"radius_mm": 35.0, "torsion_rad": 3.2}, "torsion_rad = 3.2: .* 0..pi"),
        ({"radius_mm": 0.0}, "radius_mm = 0: .* > 0 mm"),
        ({"radius_mm": float("nan")}, "radius_mm: expected a finite number"),
        ({"radius_mm": 35.0, "diameter_mm": 0.1}, "diameter_mm = 0.1"),
    ],
)
def test_bad_input_names_the_argument(kwargs, match):
    with pytest.raises(GeometryError, match=match):
        s_channel(**kwargs)
