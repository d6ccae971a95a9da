"""Lumen cross-sections: analytic wall distances and normals, brute-force check, continuity."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.geometry import GeometryError, Lumen
from ringqa.geometry.lumen import FlatSide

MM = 1e-3
NOR = np.array([1.0, 0.0, 0.0])  # centreline normal (towards the centre of the bend)
LAT = np.array([0.0, 1.0, 0.0])  # lateral direction in the normal plane (tangent is +z)


def test_circular_distance_and_normal():
    """Circle r_b = 1.5 mm: a point at 0.6 mm along (3, 4)/5 has d = 0.9 mm, n = (0.6, 0.8, 0);
    at 1.8 mm it has d = -0.3 mm with the same normal."""
    lum = Lumen.circular(1.5 * MM, 1.4 * MM)
    e = np.array([0.6, 0.8, 0.0])
    d, n = lum.wall_distance(0.01, 0.6 * MM * e, NOR)
    assert d == pytest.approx(0.9 * MM, abs=1e-15)
    assert np.allclose(n, e, atol=1e-15)
    d, n = lum.wall_distance(0.01, 1.8 * MM * e, NOR)
    assert d == pytest.approx(-0.3 * MM, abs=1e-15)
    assert np.allclose(n, e, atol=1e-15)
    d, n = lum.wall_distance(0.01, np.zeros(3), NOR)
    assert d == pytest.approx(1.5 * MM) and np.allclose(np.linalg.norm(n), 1.0)


def test_stepped_radius_changes_at_the_breaks():
    """Breaks at 10 and 20 mm, radii 2.0 / 1.5 / 1.25 mm: the centre point's distance is the
    segment radius; a break belongs to the distal segment."""
    lum = Lumen.stepped(
        [10 * MM, 20 * MM], [2.0 * MM, 1.5 * MM, 1.25 * MM], [1.9 * MM, 1.4 * MM, 1.2 * MM]
    )
    for s, r in ((-5, 2.0), (9.99, 2.0), (10.0, 1.5), (19.9, 1.5), (20, 1.25), (500, 1.25)):
        d, _ = lum.wall_distance(s * MM, np.zeros(3), NOR)
        assert d == pytest.approx(r * MM, abs=1e-15), s
    assert lum.radii_at(15 * MM) == pytest.approx((1.5 * MM, 1.4 * MM, np.inf), rel=1e-12)
    seg_s, seg_rb, seg_ra, seg_flat = lum.kernel_arrays()
    assert seg_s.shape == (4,) and seg_rb.shape == seg_ra.shape == seg_flat.shape == (3,)


@pytest.fixture
def ushape():
    """r_b = 1.5 mm, flat at 1.2 mm on the outside of the bend (-NOR): half chord 0.9 mm."""
    return Lumen.u_shaped(1.5 * MM, 1.4 * MM, 1.2 * MM)


@pytest.mark.parametrize(
    ("u_mm", "v_mm", "d_mm", "n_uv"),
    [
        (0.5, 0.0, 0.7, (1.0, 0.0)),  # towards the flat: flat 1.2 - 0.5
        (-0.5, 0.0, 1.0, (-1.0, 0.0)),  # towards the bend centre: circle 1.5 - 0.5
        (0.0, 1.0, 0.5, (0.0, 1.0)),  # lateral: circle
        (1.3, 0.0, -0.1, (1.0, 0.0)),  # beyond the flat
        (0.0, -1.7, -0.2, (0.0, -1.0)),  # beyond the circle, lateral
        (1.4, 1.0, -np.hypot(0.2, 0.1), (0.2 / np.hypot(0.2, 0.1), 0.1 / np.hypot(0.2, 0.1))),
    ],
)
def test_u_shaped_analytic(ushape, u_mm, v_mm, d_mm, n_uv):
    """Hand-derived (u = along -normal towards the flat, v lateral), e.g. the last case: beyond
    the corner (1.2, 0.9): radial projection lands past the flat, the flat projection past the
    chord, so d = -|(1.4, 1.0) - (1.2, 0.9)| = -0.2236 mm, n along (0.2, 0.1)."""
    off = (-u_mm * NOR + v_mm * LAT) * MM
    d, n = ushape.wall_distance(0.0, off, NOR)
    assert d == pytest.approx(d_mm * MM, abs=1e-12)
    assert np.allclose(n, -n_uv[0] * NOR + n_uv[1] * LAT, atol=1e-9)


def _brute_signed_distance(rb, flat, u, v):
    """Signed distance to disk(rb) cut at u <= flat, by dense sampling of the boundary."""
    half = np.sqrt(rb**2 - flat**2)
    phi0 = np.arctan2(half, flat)
    phi = np.linspace(phi0, 2 * np.pi - phi0, 200_001)
    arc = np.c_[rb * np.cos(phi), rb * np.sin(phi)]
    chord = np.c_[np.full(20_001, flat), np.linspace(-half, half, 20_001)]
    bnd = np.vstack([arc, chord])
    dist = np.linalg.norm(bnd - [u, v], axis=1).min()
    inside = (u * u + v * v <= rb * rb) and (u <= flat)
    return dist if inside else -dist


@given(
    st.floats(-2.5, 2.5, allow_nan=False),
    st.floats(-2.5, 2.5, allow_nan=False),
    st.floats(0.3, 1.45, allow_nan=False),
)
def test_u_shaped_matches_brute_force(u_mm, v_mm, flat_mm):
    """For any point and flat distance the kernel's signed distance equals a brute-force distance
    to the densely sampled boundary (sign from membership) to 0.1 um (sampling error < 0.03 um)."""
    lum = Lumen.u_shaped(1.5 * MM, 1.4 * MM, flat_mm * MM)
    off = (-u_mm * NOR + v_mm * LAT) * MM
    d, n = lum.wall_distance(0.0, off, NOR)
    expected = _brute_signed_distance(1.5, flat_mm, u_mm, v_mm) * MM
    assert d == pytest.approx(expected, abs=1e-7)
    assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-12)
    assert abs(n @ np.array([0.0, 0.0, 1.0])) < 1e-12


def test_u_shaped_distance_is_continuous_and_lipschitz(ushape):
    """A signed distance function is 1-Lipschitz: along a fine path crossing the circle/flat
    junction (corner at u = 1.2, v = 0.9 mm) from inside to outside, |d(x) - d(y)| <= |x - y|."""
    t = np.linspace(0.0, 1.0, 4001)
    a = np.array([0.2, 0.2])
    b = np.array([1.6, 1.4])
    uv = a + t[:, None] * (b - a)
    offs = (-uv[:, :1] * NOR + uv[:, 1:] * LAT) * MM
    d, _ = ushape.wall_distance(np.zeros(t.size), offs, NOR)
    step = np.linalg.norm(np.diff(offs, axis=0), axis=1)
    assert (np.abs(np.diff(d)) <= step * (1 + 1e-9) + 1e-18).all()
    assert d[0] > 0 > d[-1]


def test_u_shaped_only_in_its_range():
    """u_shaped(..., s_start, s_end): circular before s_start and after s_end (a point 1.3 mm
    towards the flat is 0.2 mm inside there, 0.1 mm outside the flat within the range)."""
    lum = Lumen.u_shaped(1.5 * MM, 1.4 * MM, 1.2 * MM, s_start_m=0.06, s_end_m=0.12)
    off = -1.3 * MM * NOR
    for s, d_exp in ((0.03, 0.2), (0.07, -0.1), (0.13, 0.2)):
        d, _ = lum.wall_distance(s, off, NOR)
        assert d == pytest.approx(d_exp * MM, abs=1e-12)


@pytest.mark.parametrize(
    ("call", "fragment"),
    [
        (lambda: Lumen.circular(1.5, 1.4), "metres"),
        (lambda: Lumen.circular(1.4e-3, 1.5e-3), "smaller than r_b"),
        (lambda: Lumen.circular(-1e-3, 0.5e-3), "r_b_m"),
        (lambda: Lumen.u_shaped(1.5e-3, 1.4e-3, -1.6e-3), "flat_m"),
        (lambda: FlatSide("outward"), "flat_towards"),
        (lambda: FlatSide("ring_outside"), "frame's centre and normal"),
        (lambda: Lumen.stepped([0.01], [1e-3], [0.9e-3]), "2 radii"),
        (lambda: Lumen.stepped([0.02, 0.01], [1e-3] * 3, [0.9e-3] * 3), "increase"),
    ],
)
def test_bad_lumens_are_refused(call, fragment):
    """Each invalid lumen raises GeometryError naming the argument."""
    with pytest.raises(GeometryError, match=fragment):
        call()


def test_a_flat_at_or_beyond_the_circle_does_not_cut_it():
    """The paper's U: a flat at (1.5 mm) or beyond (2.0 mm) the 1.5 mm circle leaves the circular
    cross-section: a point 1.3 mm towards the flat is 0.2 mm inside, as in the circle."""
    for flat_mm in (1.5, 2.0):
        lum = Lumen.u_shaped(1.5 * MM, 1.4 * MM, flat_mm * MM)
        assert not lum.cuts_circle.any()
        d, _ = lum.wall_distance(0.0, -1.3 * MM * NOR, NOR)
        assert d == pytest.approx(0.2 * MM, abs=1e-12)
        assert "at or beyond the circle" in lum.describe()


def test_flat_side_directions_are_fixed_in_the_ring_frame():
    """On a ring of centre 0 and normal +z: at the point (13, 0, 2) mm with tangent +y the
    ring's outside is +x (flat along +x: 'away' = -x); cranial is +z ('away' = -z); following the
    bend, 'away' is the centreline normal itself. A fixed direction along the tangent has no
    cross-section direction (NaN)."""
    pos = np.array([[13e-3, 0.0, 2e-3]])
    tan = np.array([[0.0, 1.0, 0.0]])
    nor = np.array([[-1.0, 0.0, 0.0]])
    ring = dict(ring_centre_m=np.zeros(3), ring_normal=np.array([0.0, 0.0, 2.0]))
    assert FlatSide("ring_outside", **ring).away(pos, tan, nor)[0] == pytest.approx([-1, 0, 0])
    assert FlatSide("cranial", **ring).away(pos, tan, nor)[0] == pytest.approx([0, 0, -1])
    assert FlatSide("caudal", **ring).away(pos, tan, nor)[0] == pytest.approx([0, 0, 1])
    assert FlatSide().away(pos, tan, nor)[0] == pytest.approx(nor[0])
    along = FlatSide("cranial", **ring).away(pos, np.array([[0.0, 0.0, 1.0]]), nor)
    assert np.isnan(along).all()
