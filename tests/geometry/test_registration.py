"""Reference-path checks and registration to the channel (ringqa.geometry.registration).

The synthetic channel is the parametric 26 mm / 60 deg ring (``ring_channel(26, 60)``): ring
centre at the origin, ring plane z = 0, normal +z (cranial); a 60 mm straight stem, a 28 mm
transition, then the circle of radius R = 13 mm (arc length from about 88 mm to the tip at
L = 147.9 mm). Lumen r_b = 1.5 mm everywhere, so with the mHDR-v2 capsule (radius 0.45 mm) the
source centre can be at most 1.5 - 0.45 = 1.05 mm from the centreline (1.10 mm with the 0.05 mm
tolerance). On the circle the centreline lies exactly in z = 0 (|z| < 1e-15 m), and the
outward radial direction u = (x, y, 0)/|(x, y)| and +z are perpendicular to the tangent: the
closest centreline point of c + d u or c + d z (d < R) is c itself, at distance d.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ringqa.geometry import (
    REGISTER_MODES,
    Channel,
    GeometryError,
    Lumen,
    RegistrationError,
    check_reference_path,
    reference_positions,
    register_reference,
    ring_channel,
    tandem_channel,
)
from ringqa.geometry.registration import FLAG_INFEASIBLE, FLAG_OK, FLAG_OUTSIDE

MM = 1e-3
UM = 1e-6
RC_MHDR = 0.45 * MM  # microSelectron mHDR-v2 capsule: 0.90 mm outer diameter
RC_FLEXI = 0.425 * MM  # Flexisource / Flexitron: 0.85 mm
Z = np.array([0.0, 0.0, 1.0])
FRAME = (np.zeros(3), Z)
EXAMPLE = (
    Path(__file__).resolve().parents[2]
    / "data"
    / "examples"
    / "oncentra_ring26x60"
    / "RP_ring26x60_oncentra43.dcm"
)


@pytest.fixture(scope="module")
def ring() -> Channel:
    """The parametric 26/60 ring channel."""
    return ring_channel(26, 60)[0]


def _on_circle(ring: Channel, from_tip_mm) -> np.ndarray:
    """Centreline points at the given distances from the lumen tip (all on the circle)."""
    s = ring.length_m - np.asarray(from_tip_mm, dtype=float) * MM
    return ring.centreline.position(s)


def _outward(points: np.ndarray) -> np.ndarray:
    """Unit outward radial directions in the ring plane (ring centre at the origin)."""
    u = points * np.array([1.0, 1.0, 0.0])
    return u / np.linalg.norm(u, axis=1)[:, None]


# ---------------------------------------------------------------------------------------------
# (a) a path on the centreline lifted by a known height: planar, height, plane-height


def test_lifted_path_is_planar_at_its_height(ring):
    """12 positions 5, 7.5, ..., 32.5 mm from the tip, lifted by 0.89 mm along +z: all within
    0 of one plane (z = 0.89 mm), parallel to the ring plane (tilt 0), height 0.89 mm (to 1 um,
    with the given frame and with the frame fitted to the channel); each is 0.89 mm from the
    centreline (< 1.05 mm: no flag); the closest arc lengths are those of the feet."""
    from_tip = 5.0 + 2.5 * np.arange(12)
    feet = _on_circle(ring, from_tip)
    path = feet + 0.89 * MM * Z
    for frame in (FRAME, None):
        c = check_reference_path(path, ring, RC_MHDR, frame)
        assert c.planar and c.constant_height and not c.collinear
        assert c.height_m == pytest.approx(0.89 * MM, abs=UM)
        np.testing.assert_allclose(c.heights_m, 0.89 * MM, atol=UM)
        assert c.plane_rms_m < 1e-12
        assert c.plane_tilt_deg < 1e-6
        np.testing.assert_allclose(c.plane_normal, Z, atol=1e-9)
        np.testing.assert_allclose(c.ring_normal, Z, atol=1e-9)
    assert c.frame_source.startswith("fitted to the distal 40 mm")
    np.testing.assert_allclose(c.offset_m, 0.89 * MM, atol=1e-9)
    np.testing.assert_allclose(c.s_m, ring.length_m - from_tip * MM, atol=1e-9)
    np.testing.assert_allclose(c.max_offset_m, 1.05 * MM, atol=1e-12)
    assert c.flags == (FLAG_OK,) * 12 and c.ok
    assert "planar" in c.summary[0] and "0.89 mm above" in c.summary[0]
    assert "stored 2D" in c.summary[0]
    assert c.summary[1].startswith("All 12 positions")


def test_plane_height_registration_brings_the_path_back(ring):
    """plane-height translates by -0.89 mm along the ring normal: back onto the feet (1 um),
    rotation identity, distances 0.89 mm -> 0; the description says 0.89 mm caudally."""
    feet = _on_circle(ring, 5.0 + 2.5 * np.arange(12))
    reg = register_reference(feet + 0.89 * MM * Z, ring, "plane-height", RC_MHDR, FRAME)
    np.testing.assert_allclose(reg.points_m, feet, atol=UM)
    np.testing.assert_allclose(reg.translation_m, -0.89 * MM * Z, atol=UM)
    np.testing.assert_array_equal(reg.rotation, np.eye(3))
    assert reg.rotation_deg == 0.0
    assert reg.rms_before_m == pytest.approx(0.89 * MM, abs=1e-9)
    assert reg.max_before_m == pytest.approx(0.89 * MM, abs=1e-9)
    assert reg.rms_after_m < UM and reg.max_after_m < UM
    assert reg.description == (
        "translated 0.89 mm caudally along the ring normal (onto the ring channel's plane)"
    )
    np.testing.assert_allclose(reg.apply(feet[0] + 0.89 * MM * Z), feet[0], atol=1e-12)
    m = reg.matrix()
    np.testing.assert_allclose(m[:3, 3], -0.89 * MM * Z, atol=1e-12)
    assert reg.after.height_m == pytest.approx(0.0, abs=UM)
    assert "in the ring channel's plane" in reg.after.summary[0]


@given(
    height_mm=st.floats(-1.0, 1.0).filter(lambda h: abs(h) > 0.02),
    start_mm=st.floats(1.0, 20.0),
    step_mm=st.floats(1.0, 4.0),
    n=st.integers(3, 12),
)
def test_plane_height_property(ring, height_mm, start_mm, step_mm, n):
    """Any lift h (|h| 0.02-1 mm) of any run of n >= 3 circle positions: planar, height h
    (1 um), and plane-height puts them back on the feet (1 um), moving them |h| mm caudally for
    h > 0, cranially for h < 0."""
    feet = _on_circle(ring, start_mm + step_mm * np.arange(n))
    path = feet + height_mm * MM * Z
    c = check_reference_path(path, ring, RC_MHDR, FRAME)
    assert c.planar and c.constant_height
    assert c.height_m == pytest.approx(height_mm * MM, abs=UM)
    reg = register_reference(path, ring, "plane-height", RC_MHDR, FRAME)
    np.testing.assert_allclose(reg.points_m, feet, atol=UM)
    assert ("caudally" if height_mm > 0 else "cranially") in reg.description


def test_none_is_the_identity(ring):
    """mode none: the points as given, identity transform, before = after."""
    path = _on_circle(ring, [5.0, 10.0, 15.0, 20.0]) + 0.3 * MM * Z
    reg = register_reference(path, ring, "none", RC_MHDR, FRAME)
    np.testing.assert_array_equal(reg.points_m, path)
    np.testing.assert_array_equal(reg.rotation, np.eye(3))
    np.testing.assert_array_equal(reg.translation_m, np.zeros(3))
    assert reg.rms_before_m == reg.rms_after_m == pytest.approx(0.3 * MM, abs=1e-9)
    assert reg.description.startswith("not registered")
    assert REGISTER_MODES == ("none", "plane-height", "rigid")


# ---------------------------------------------------------------------------------------------
# (b) rigid registration


def _path_over_the_bend(ring) -> np.ndarray:
    """25 centreline points from s = 70 mm (in the transition) to 130 mm (on the circle), 2.5 mm
    apart: the curve's curvature and plane change along them, so no rigid motion but the
    identity maps them onto the centreline again (all six degrees of freedom are fixed)."""
    return ring.centreline.position((70.0 + 2.5 * np.arange(25)) * MM)


def _rotation_angle(r: np.ndarray) -> float:
    return float(np.linalg.norm(Rotation.from_matrix(r).as_rotvec()))


@given(
    rotvec_deg=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    shift_mm=st.tuples(*[st.floats(-0.5, 0.5)] * 3),
)
def test_rigid_with_slide_recovers_a_known_motion(ring, rotvec_deg, shift_mm):
    """A path on the centreline moved by a known rotation R0 (up to 1 deg per axis, about its
    centroid c) and translation t0 (up to 0.5 mm per axis): the six-degree-of-freedom fit
    (slide=True) returns the inverse: rotation R0^T (within 1e-6 rad), positions back on the
    originals (1 um), distance to the centreline ~0, nothing undetermined."""
    p0 = _path_over_the_bend(ring)
    c = p0.mean(axis=0)
    r0 = Rotation.from_rotvec(np.deg2rad(rotvec_deg)).as_matrix()
    moved = (p0 - c) @ r0.T + c + np.asarray(shift_mm) * MM
    reg = register_reference(moved, ring, "rigid", RC_MHDR, FRAME, slide=True)
    assert reg.converged and reg.undetermined == 0
    assert _rotation_angle(reg.rotation @ r0) < 1e-6
    np.testing.assert_allclose(reg.points_m, p0, atol=UM)
    assert reg.rms_after_m < UM
    assert "free to slide" in reg.description


@given(
    rotvec_deg=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    shift_mm=st.tuples(*[st.floats(-0.5, 0.5)] * 3),
)
def test_rigid_keeps_the_mean_position_along_the_channel(ring, rotvec_deg, shift_mm):
    """The default rigid fit (slide=False) keeps the mean closest-point arc length of the input
    (to 1 nm) and never ends farther from the centreline than it started."""
    p0 = _path_over_the_bend(ring)
    c = p0.mean(axis=0)
    r0 = Rotation.from_rotvec(np.deg2rad(rotvec_deg)).as_matrix()
    moved = (p0 - c) @ r0.T + c + np.asarray(shift_mm) * MM
    reg = register_reference(moved, ring, "rigid", RC_MHDR, FRAME)
    assert reg.converged
    assert np.mean(reg.after.s_m) == pytest.approx(np.mean(reg.before.s_m), abs=1e-9)
    assert reg.rms_after_m <= reg.rms_before_m + 1e-12
    assert "along the channel kept" in reg.description


def test_rigid_does_not_slide_round_a_circle(ring):
    """Circle positions 5-30 mm from the tip, rotated 2 deg about the ring axis (a slide of
    13 mm x 0.0349 = 0.454 mm along the channel) and lifted 0.5 mm. The default fit undoes the
    lift only: translation (0, 0, -0.5) mm, rotation 0 (1e-6 rad): the points end on the circle
    2 deg round from where they started (1 um). slide=True cannot fix that rotation either (the
    circle maps onto itself): one undetermined direction, left unchanged, distances ~0."""
    p0 = _on_circle(ring, 5.0 + 2.5 * np.arange(11))
    rz = Rotation.from_rotvec(np.deg2rad(2.0) * Z).as_matrix()
    slid = p0 @ rz.T
    reg = register_reference(slid + 0.5 * MM * Z, ring, "rigid", RC_MHDR, FRAME)
    assert reg.converged
    assert _rotation_angle(reg.rotation) < 1e-6
    np.testing.assert_allclose(reg.translation_m, -0.5 * MM * Z, atol=UM)
    np.testing.assert_allclose(reg.points_m, slid, atol=UM)
    assert reg.rms_after_m < UM
    free = register_reference(slid + 0.5 * MM * Z, ring, "rigid", RC_MHDR, FRAME, slide=True)
    assert free.undetermined == 1
    assert free.rms_after_m < UM
    assert "1 direction(s) not fixed" in free.description


def test_rigid_needs_three_positions_on_the_channel(ring):
    """Two positions on the circle and three 8 mm above it (> 5 mm: outside the channel): the
    rigid fit refuses, naming the count (2 of 5) and the mode."""
    on = _on_circle(ring, [5.0, 10.0])
    off = _on_circle(ring, [15.0, 20.0, 25.0]) + 8.0 * MM * Z
    with pytest.raises(RegistrationError, match=r"mode 'rigid': only 2 of 5 positions"):
        register_reference(np.vstack([on, off]), ring, "rigid", RC_MHDR, FRAME)


def test_rigid_ignores_positions_outside_but_carries_them(ring):
    """A position 8 mm above the circle is not fitted (``used`` False) but moves with the
    others: the transform applied to it gives its registered place."""
    path = np.vstack([_on_circle(ring, 5.0 + 2.5 * np.arange(6)) + 0.4 * MM * Z,
                      _on_circle(ring, [25.0]) + 8.0 * MM * Z])  # fmt: skip
    reg = register_reference(path, ring, "rigid", RC_MHDR, FRAME)
    np.testing.assert_array_equal(reg.used, [True] * 6 + [False])
    np.testing.assert_allclose(reg.points_m[6], reg.apply(path[6]), atol=1e-15)
    np.testing.assert_allclose(reg.translation_m, -0.4 * MM * Z, atol=UM)


# ---------------------------------------------------------------------------------------------
# (c) flags on hand-placed points


def test_infeasible_flags_on_the_circle(ring):
    """Feet 10, 15, 20, 25, 30, 35 mm from the tip, moved outward in the ring plane by 1.00,
    1.09, 1.11, 1.30 mm, inward by 1.20 mm and up by 1.20 mm. The source centre can reach
    1.05 mm (+0.05 mm tolerance = 1.10 mm): 1.00 and 1.09 are fine, 1.11, 1.30, 1.20, 1.20 are
    infeasible. With the Flexisource capsule (1.075 + 0.05 = 1.125 mm) 1.11 mm is fine."""
    feet = _on_circle(ring, [10.0, 15.0, 20.0, 25.0, 30.0, 35.0])
    u = _outward(feet)
    d_mm = np.array([1.00, 1.09, 1.11, 1.30, 1.20, 1.20])
    direction = np.vstack([u[:4], -u[4:5], Z[None, :]])
    path = feet + d_mm[:, None] * MM * direction
    c = check_reference_path(path, ring, RC_MHDR, FRAME)
    np.testing.assert_allclose(c.offset_m, d_mm * MM, atol=1e-9)
    np.testing.assert_allclose(c.s_m, ring.centreline.closest(feet)[0], atol=1e-9)
    assert c.flags == ("", "", FLAG_INFEASIBLE, FLAG_INFEASIBLE, FLAG_INFEASIBLE, FLAG_INFEASIBLE)
    np.testing.assert_array_equal(np.flatnonzero(c.infeasible), [2, 3, 4, 5])
    assert "4 of 6 positions lie farther" in c.summary[1]
    assert "up to 1.30 mm vs 1.05 mm" in c.summary[1]
    assert "positions 2-5" in c.summary[1]
    flexi = check_reference_path(path, ring, RC_FLEXI, FRAME)
    assert flexi.flags == ("", "", "", FLAG_INFEASIBLE, FLAG_INFEASIBLE, FLAG_INFEASIBLE)
    np.testing.assert_allclose(flexi.max_offset_m, 1.075 * MM, atol=1e-12)


def test_outside_channel_flags(ring):
    """Past the tip (2 mm along the tip tangent: s = L + 2 mm), before the entry (3 mm back
    along the stem: s = -3 mm), 6 mm above the circle (> 5 mm) are outside the channel; the
    flag wins over 'infeasible'. Three circle positions complete the path."""
    cl = ring.centreline
    tip = cl.position(ring.length_m) + 2.0 * MM * cl.tangent(ring.length_m)
    entry = cl.position(0.0) - 3.0 * MM * cl.tangent(0.0)
    above = _on_circle(ring, [30.0])[0] + 6.0 * MM * Z
    path = np.vstack([tip, _on_circle(ring, [10.0, 15.0, 20.0]), above, entry])
    rel = np.array([0.0, 2.5, 5.0, 7.5, 10.0, 12.5]) * MM
    c = check_reference_path(path, ring, RC_MHDR, FRAME, relative_m=rel)
    assert c.flags == (FLAG_OUTSIDE, "", "", "", FLAG_OUTSIDE, FLAG_OUTSIDE)
    assert c.s_m[0] == pytest.approx(ring.length_m + 2.0 * MM, abs=1e-9)
    assert c.s_m[5] == pytest.approx(-3.0 * MM, abs=1e-9)
    assert c.offset_m[4] == pytest.approx(6.0 * MM, abs=1e-9)
    np.testing.assert_array_equal(c.on_channel, [False, True, True, True, False, False])
    text = c.summary[-1]
    assert text.startswith("3 of 6 positions are not along channel 'ring'")
    for words in ("before the channel entry", "past the lumen tip", "more than 5 mm"):
        assert words in text
    assert "positions 0, 4-5 (relative 0, 10, 12.5 mm)" in text


def test_max_offset_follows_the_lumen_radius(ring):
    """A lumen stepping from r_b 1.5 mm to 1.0 mm at s = 120 mm: 0.7 mm from the centreline is
    fine before the step (max 1.05 mm) and infeasible after it (max 1.0 - 0.45 = 0.55 mm, +0.05
    tolerance = 0.60 mm)."""
    lumen = Lumen.stepped([120.0 * MM], [1.5 * MM, 1.0 * MM], [1.4 * MM, 0.9 * MM])
    ch = Channel("ring", ring.centreline, lumen, ring.s_ref_m)
    s = np.array([100.0, 110.0, 130.0, 140.0]) * MM
    feet = ring.centreline.position(s)
    c = check_reference_path(feet + 0.7 * MM * Z, ch, RC_MHDR, FRAME)
    np.testing.assert_allclose(c.max_offset_m, np.array([1.05, 1.05, 0.55, 0.55]) * MM, atol=1e-12)
    assert c.flags == ("", "", FLAG_INFEASIBLE, FLAG_INFEASIBLE)


def test_three_dimensional_and_tilted_paths(ring):
    """Feet plus a height growing with the distance from the tip (0.01 mm per mm) lie in a
    plane tilted from the ring plane: planar but not constant height, plane-height refused
    ('tilted'). Heights alternating 0 / 0.1 mm: not planar (RMS about 0.05 mm), refused
    ('not planar')."""
    from_tip = 5.0 + 2.5 * np.arange(10)
    feet = _on_circle(ring, from_tip)
    tilted = feet + (0.01 * from_tip * MM)[:, None] * Z
    c = check_reference_path(tilted, ring, RC_MHDR, FRAME)
    assert c.planar and not c.constant_height and c.plane_tilt_deg > 0.1
    assert "tilted" in c.summary[0]
    with pytest.raises(RegistrationError, match=r"mode 'plane-height'.*tilted"):
        register_reference(tilted, ring, "plane-height", RC_MHDR, FRAME)
    bumpy = feet + (0.1 * MM * (np.arange(10) % 2))[:, None] * Z
    c = check_reference_path(bumpy, ring, RC_MHDR, FRAME)
    assert not c.planar and c.plane_rms_m > 0.02 * MM
    assert c.summary[0].startswith("The reference path is three-dimensional")
    with pytest.raises(RegistrationError, match=r"mode 'plane-height'.*not planar"):
        register_reference(bumpy, ring, "plane-height", RC_MHDR, FRAME)


def test_collinear_path_on_a_tandem():
    """A straight tandem's path is a line: collinear, no plane, not planar; its heights above a
    ring plane z = 0 are the positions' z; plane-height refuses ('straight line'). Without a
    ring frame the check refuses: the tandem's distal end is not a circle."""
    tandem = tandem_channel()
    z_mm = np.array([50.0, 47.5, 45.0, 42.5])
    path = np.column_stack([np.zeros(4), np.zeros(4), z_mm * MM])
    c = check_reference_path(path, tandem, RC_MHDR, FRAME)
    assert c.collinear and not c.planar and c.plane_normal is None and c.plane_tilt_deg is None
    np.testing.assert_allclose(c.heights_m, z_mm * MM, atol=1e-15)
    assert "straight line" in c.summary[0]
    with pytest.raises(RegistrationError, match="straight line"):
        register_reference(path, tandem, "plane-height", RC_MHDR, FRAME)
    with pytest.raises(RegistrationError, match=r"frame: not given.*not a circular arc"):
        check_reference_path(path, tandem, RC_MHDR)


# ---------------------------------------------------------------------------------------------
# (d) relative positions, duplicates, counts, bad arguments


def test_uneven_relative_positions_are_kept(ring):
    """Relative positions 0, 2.5, 5, 10, 12.5 mm (a gap at 7.5) stay exactly so; their arc
    lengths are s_ref - p; the spacing is uneven (step None)."""
    rel = np.array([0.0, 2.5, 5.0, 10.0, 12.5]) * MM
    pts = ring.centreline.position(ring.s_ref_m - rel)
    pos = reference_positions(pts, ring, relative_m=rel)
    np.testing.assert_array_equal(pos.relative_m, rel)
    np.testing.assert_allclose(pos.s_nominal_m, ring.s_ref_m - rel, atol=1e-15)
    assert pos.uneven and pos.step_m is None and pos.relative_from == "given"
    assert pos.n_in_range == 5


def test_relative_positions_from_a_step(ring):
    """Without relative positions: k * step_m (2.5 mm) or k * the channel's measured step
    (2.0 mm here); even spacing reports the step; no step at all is refused."""
    pts = _on_circle(ring, [5.0, 7.5, 10.0, 12.5])
    pos = reference_positions(pts, ring, step_m=2.5 * MM)
    np.testing.assert_allclose(pos.relative_m, [0.0, 2.5e-3, 5.0e-3, 7.5e-3], atol=1e-15)
    assert pos.step_m == 2.5 * MM and not pos.uneven and pos.relative_from == "step"
    stepped = Channel("ring", ring.centreline, ring.lumen, ring.s_ref_m, measured_step_m=2e-3)
    pos = reference_positions(pts, stepped)
    np.testing.assert_allclose(pos.relative_m, [0.0, 2e-3, 4e-3, 6e-3], atol=1e-15)
    assert pos.relative_from == "channel step" and pos.step_m == 2e-3
    with pytest.raises(RegistrationError, match="neither given"):
        reference_positions(pts, ring)
    with pytest.raises(RegistrationError, match="not both"):
        reference_positions(pts, ring, relative_m=[0, 1e-3, 2e-3, 3e-3], step_m=1e-3)


def test_duplicates_are_refused_with_their_indices(ring):
    """Relative positions 0, 2.5, 5, 5, 7.5 mm: positions 2 and 3 repeat; 0, 5, 2.5, 5: 1 and 3
    repeat (not neighbours); 0, 2.5, 7.5, 5: position 3 is not proximal of 2. Positions 1 and
    4 less than 1 um apart (0.5 um) coincide."""
    pts = _on_circle(ring, [5.0, 7.5, 10.0, 12.5, 15.0])
    with pytest.raises(RegistrationError, match=r"positions 2 and 3 have the same relative"):
        reference_positions(pts, ring, relative_m=np.array([0, 2.5, 5, 5, 7.5]) * MM)
    with pytest.raises(RegistrationError, match=r"positions 1 and 3 have the same relative"):
        reference_positions(pts[:4], ring, relative_m=np.array([0, 5, 2.5, 5]) * MM)
    with pytest.raises(RegistrationError, match=r"position 3 \(5 mm\) is not proximal of "
                       r"position 2 \(7.5 mm\)"):  # fmt: skip
        reference_positions(pts[:4], ring, relative_m=np.array([0, 2.5, 7.5, 5]) * MM)
    dup = pts.copy()
    dup[4] = dup[1] + np.array([0.5 * UM, 0.0, 0.0])
    with pytest.raises(RegistrationError, match=r"positions 1 and 4 coincide"):
        reference_positions(dup, ring, step_m=2.5 * MM)


def test_too_few_positions_are_refused(ring):
    """Two positions: refused with the count. Five positions whose relative positions 0, 2.5,
    150, 160, 170 mm put three of them beyond the channel entry (s_ref = 142.9 mm): only 2 of
    5 on the channel, refused."""
    pts = _on_circle(ring, [5.0, 7.5, 10.0, 12.5, 15.0])
    with pytest.raises(RegistrationError, match=r"points_m: 2 position\(s\); .* at least 3"):
        reference_positions(pts[:2], ring, step_m=2.5 * MM)
    with pytest.raises(RegistrationError, match=r"points_m: 2 position\(s\)"):
        check_reference_path(pts[:2], ring, RC_MHDR, FRAME)
    with pytest.raises(RegistrationError, match=r"only 2 of 5 lie on channel 'ring'"):
        reference_positions(pts, ring, relative_m=np.array([0, 2.5, 150, 160, 170]) * MM)


def test_bad_arguments_name_the_argument(ring):
    """Unknown mode, slide without rigid, a capsule radius in mm, a non-unit normal, a path in
    mm: each refused with a RingQAError (GeometryError) naming the argument."""
    pts = _on_circle(ring, [5.0, 7.5, 10.0])
    with pytest.raises(RegistrationError, match=r"mode: 'icp' is not a registration mode"):
        register_reference(pts, ring, "icp", RC_MHDR, FRAME)
    with pytest.raises(RegistrationError, match=r"slide: only mode 'rigid'"):
        register_reference(pts, ring, "none", RC_MHDR, FRAME, slide=True)
    with pytest.raises(RegistrationError, match=r"capsule_radius_m: 450 mm"):
        check_reference_path(pts, ring, 0.45, FRAME)
    with pytest.raises(RegistrationError, match=r"frame: the normal must be a unit"):
        check_reference_path(pts, ring, RC_MHDR, (np.zeros(3), 2 * Z))
    with pytest.raises(RegistrationError, match=r"points_m: .* metres"):
        check_reference_path(pts * 1e4, ring, RC_MHDR, FRAME)
    assert issubclass(RegistrationError, GeometryError)


# ---------------------------------------------------------------------------------------------
# (e) the shipped Oncentra 26/60 example


@pytest.fixture(scope="module")
def oncentra():
    """The example's applicator (ring channel with the library's measured path)."""
    from ringqa.io.rtplan import applicator_from_rtplan, read_rtplan

    assert EXAMPLE.is_file(), f"{EXAMPLE}: the shipped example is missing"
    app = applicator_from_rtplan(read_rtplan(EXAMPLE))
    return app, app.channel("ring")


def test_example_path_is_2d_at_0p89_mm(oncentra):
    """The library path 'VCC_RingCTMR_26x60_192-Ir-mxDR-v2 v1.1' (30 positions, 2.5 mm apart):
    planar (RMS 1e-17 m from its plane), parallel to the ring plane (tilt < 1e-6 deg), every
    position 0.89 mm cranial of the ring channel's plane (measured 0.890000000 mm; 1 nm), with
    the applicator's frame and with the frame fitted to the channel's distal 40 mm."""
    app, ring = oncentra
    path = ring.measured_path_m
    assert path.shape == (30, 3)
    for frame in ((app.ring_centre_m, app.ring_normal), None):
        c = check_reference_path(path, ring, RC_MHDR, frame)
        assert c.planar and c.constant_height
        assert c.height_m == pytest.approx(0.89 * MM, abs=1e-9)
        np.testing.assert_allclose(c.heights_m, 0.89 * MM, atol=1e-9)
        assert c.plane_tilt_deg < 1e-6
    assert "0.89 mm above" in c.summary[0]


def test_example_infeasible_and_outside_positions(oncentra):
    """Measured on the shipped data (not hand-derived): with the mHDR-v2 capsule (max offset
    1.05 mm) 13 positions are infeasible, relative 10-32.5 mm (indices 4-13: 1.12-1.18 mm from
    the centreline) and 62.5-67.5 mm (25-27: 1.22, 1.55, 2.45 mm, where the channel descends
    towards the stem but the 2D path stays in the ring plane); the two most proximal (70, 72.5
    mm) have their closest centreline point past the lumen tip (the 2D path runs on round the
    ring into the gap). With the Flexisource capsule (1.075 mm): 7 infeasible."""
    app, ring = oncentra
    frame = (app.ring_centre_m, app.ring_normal)
    rel = 2.5 * MM * np.arange(30)
    c = check_reference_path(ring.measured_path_m, ring, RC_MHDR, frame, relative_m=rel)
    np.testing.assert_array_equal(np.flatnonzero(c.infeasible), [*range(4, 14), 25, 26, 27])
    np.testing.assert_array_equal(np.flatnonzero(c.outside), [28, 29])
    assert np.all(c.s_m[28:] > ring.length_m)
    assert c.offset_m[27] == pytest.approx(2.449 * MM, abs=0.001 * MM)
    assert c.summary[1].startswith("13 of 30 positions lie farther")
    flexi = check_reference_path(ring.measured_path_m, ring, RC_FLEXI, frame)
    np.testing.assert_array_equal(np.flatnonzero(flexi.infeasible), [6, 11, 12, 13, 25, 26, 27])


def test_example_registrations(oncentra):
    """Measured on the shipped data (regression values, 28 positions on the channel):
    none: RMS 1.165 mm, max 2.449 mm from the centreline. plane-height: 0.89 mm caudally along
    the ring normal; RMS 0.694, max 1.830 mm; only relative 67.5 mm stays infeasible.
    rigid (mean position along the channel kept): rotation 0.85 deg, RMS 0.456, max 1.193 mm.
    rigid with slide: turns the path about 23 deg round the ring (5 mm along it)."""
    app, ring = oncentra
    frame = (app.ring_centre_m, app.ring_normal)
    path = ring.measured_path_m
    none = register_reference(path, ring, "none", RC_MHDR, frame)
    assert none.rms_before_m == pytest.approx(1.165 * MM, abs=0.001 * MM)
    assert none.max_before_m == pytest.approx(2.449 * MM, abs=0.001 * MM)
    assert int(none.used.sum()) == 28
    ph = register_reference(path, ring, "plane-height", RC_MHDR, frame)
    np.testing.assert_allclose(ph.translation_m, -0.89 * MM * app.ring_normal, atol=1e-9)
    assert ph.rms_after_m == pytest.approx(0.694 * MM, abs=0.001 * MM)
    assert ph.max_after_m == pytest.approx(1.830 * MM, abs=0.001 * MM)
    np.testing.assert_array_equal(np.flatnonzero(ph.after.infeasible), [27])
    rigid = register_reference(path, ring, "rigid", RC_MHDR, frame)
    assert rigid.converged
    assert rigid.rotation_deg == pytest.approx(0.85, abs=0.01)
    assert rigid.rms_after_m == pytest.approx(0.456 * MM, abs=0.001 * MM)
    assert rigid.max_after_m == pytest.approx(1.193 * MM, abs=0.001 * MM)
    free = register_reference(path, ring, "rigid", RC_MHDR, frame, slide=True)
    assert free.converged and free.rotation_deg > 20.0
    slide = np.mean(free.after.s_m[free.used] - free.before.s_m[free.used])
    assert slide > 4.0 * MM


def test_path_placement_direction_and_offset():
    """path_placement (the readers' gross check): a path on ring26x60's ring channel, most distal
    first, runs -1 with a median step of -2.5 mm; reversed +1; moved 20 mm, every position off."""
    from ringqa.geometry import ring_applicator
    from ringqa.geometry.registration import path_placement

    ring = ring_applicator(26, 60).channel("ring")
    path = ring.centreline.position(ring.s_ref_m - np.arange(20) * 2.5e-3)
    place = path_placement(path, ring)
    assert place.direction == -1 and place.n_off == 0 and place.n_along == 20
    assert place.median_step_m == pytest.approx(-2.5e-3, abs=1e-6)
    assert place.median_offset_m < 1e-6
    assert path_placement(path[::-1], ring).direction == 1
    shifted = path_placement(path + np.array([0.0, 0.0, 0.02]), ring)
    assert shifted.n_off == 20 and shifted.median_offset_m == pytest.approx(0.02, abs=1e-4)
