"""Centreline: analytic curves (line, circle, helix), closest point, branches, validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, reject
from hypothesis import strategies as st

from ringqa.geometry import Centreline, GeometryError
from ringqa.geometry import _kernels as K

UM = 1e-6


def helix_points(r, c, theta):
    """Points of the helix (r cos t, r sin t, c t)."""
    return np.c_[r * np.cos(theta), r * np.sin(theta), c * theta]


# --- straight line ---------------------------------------------------------------------------


def test_line_is_exact():
    """Points on a 3-D line (uneven spacing) -> r(s) = p0 + s u exactly; curvature 0; a point
    at perpendicular distance 2 mm from s = 17 mm gives s = 17 mm, d = 2 mm (1 um)."""
    u = np.array([1.0, 2.0, -2.0]) / 3.0
    p0 = np.array([0.01, -0.02, 0.005])
    t = np.cumsum(np.r_[0.0, np.linspace(1e-3, 4e-3, 14)])
    cl = Centreline.from_points(p0 + t[:, None] * u)
    assert cl.length_m == pytest.approx(t[-1], rel=1e-12)
    s = np.linspace(0.0, t[-1], 33)
    assert np.abs(cl.position(s) - (p0 + s[:, None] * u)).max() < 1e-3 * UM
    assert np.abs(cl.tangent(s) - u).max() < 1e-9
    assert np.abs(cl.curvature(s)).max() < 1e-6
    assert np.abs(cl.torsion(s)).max() == 0.0
    n = cl.normal(s)
    assert np.isfinite(n).all()
    assert np.abs(np.linalg.norm(n, axis=1) - 1).max() < 1e-12
    assert np.abs(n @ u).max() < 1e-9
    perp = np.cross(u, [0.0, 0.0, 1.0])
    perp /= np.linalg.norm(perp)
    q = p0 + 0.017 * u + 0.002 * perp
    s_c, d_c = cl.closest(q)
    assert abs(s_c[0] - 0.017) < UM
    assert abs(d_c[0] - 0.002) < UM


def test_straight_extensions_beyond_the_ends():
    """Beyond the ends the curve continues straight: a point 5 mm behind the proximal end of a
    line has s = -5 mm, d = 0; position(-5 mm) = p0 - 5 mm u."""
    u = np.array([0.0, 0.0, 1.0])
    pts = np.c_[np.zeros(8), np.zeros(8), np.linspace(0, 0.02, 8)]
    cl = Centreline.from_points(pts)
    s, d = cl.closest(np.array([[0.0, 0.0, -0.005], [0.0, 0.001, 0.027]]))
    assert s == pytest.approx([-0.005, 0.027], abs=UM)
    assert d == pytest.approx([0.0, 0.001], abs=UM)
    assert np.allclose(cl.position(-0.005), -0.005 * u, atol=1e-12)
    pos, tan, nor = K.frame_at(cl.table.knots, cl.table.coef, cl.table.s, cl.table.nor, 0.03)
    assert np.allclose(pos, [0, 0, 0.03]) and np.allclose(tan, u)
    assert abs(nor @ tan) < 1e-12


# --- circle ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def circle():
    """A 13 mm radius circle (the 26 mm ring), 300 degrees, 150 points."""
    r = 0.013
    th = np.linspace(0.0, np.deg2rad(300), 150)
    return r, Centreline.from_points(np.c_[r * np.cos(th), r * np.sin(th), np.zeros_like(th)])


def test_circle_frame_and_curvature(circle):
    """On r = 13 mm: r(s) = R(cos s/R, sin s/R, 0), tangent (-sin, cos, 0), normal towards the
    centre -(cos, sin, 0), binormal +z, curvature 1/R = 76.923 1/m, torsion 0 (1 um / 1e-6)."""
    r, cl = circle
    assert cl.length_m == pytest.approx(r * np.deg2rad(300), rel=1e-9)
    s = np.linspace(0.0, cl.length_m, 101)
    th = s / r
    radial = np.c_[np.cos(th), np.sin(th), 0 * th]
    assert np.abs(cl.position(s) - r * radial).max() < 0.01 * UM
    assert np.abs(cl.tangent(s) - np.c_[-np.sin(th), np.cos(th), 0 * th]).max() < 1e-6
    assert np.abs(cl.normal(s) + radial).max() < 1e-6
    assert np.abs(cl.binormal(s) - [0, 0, 1]).max() < 1e-6
    assert np.abs(cl.curvature(s) * r - 1.0).max() < 1e-6
    assert np.abs(cl.torsion(s)).max() < 1e-6 / r


def test_circle_closest_point(circle):
    """A point at angle a, radius rho, height z has s = R a and d = hypot(rho - R, z) (1 um),
    from inside, outside and above the ring, globally and with a hint 1 mm off. (Angles 40-260
    degrees, radius <= 1.4 R: nearer the arc than the straight extensions beyond its ends.)"""
    r, cl = circle
    rng = np.random.default_rng(3)
    a = rng.uniform(np.deg2rad(40), np.deg2rad(260), 200)
    rho = rng.uniform(0.3 * r, 1.4 * r, 200)
    z = rng.uniform(-0.004, 0.004, 200)
    q = np.c_[rho * np.cos(a), rho * np.sin(a), z]
    s_exp = r * a
    d_exp = np.hypot(rho - r, z)
    s, d = cl.closest(q)
    assert np.abs(s - s_exp).max() < UM
    assert np.abs(d - d_exp).max() < UM
    s2, d2 = cl.closest(q, s_hint_m=s_exp + 1e-3, window_m=2e-3)
    assert np.abs(s2 - s_exp).max() < UM
    assert np.abs(d2 - d_exp).max() < UM


# --- helix -----------------------------------------------------------------------------------


def test_helix_curvature_torsion_frame():
    """Helix R = 10 mm, c = 3 mm/rad: s = sqrt(R^2+c^2) t, curvature R/(R^2+c^2) = 91.743 1/m,
    torsion c/(R^2+c^2) = 27.523 1/m, normal -(cos t, sin t, 0), binormal (c sin t, -c cos t, R)/w
    (positions 1 um; curvature, torsion relative 1e-6; unit vectors 1e-6)."""
    r, c = 0.010, 0.003
    w = np.hypot(r, c)
    theta = np.linspace(0, 3 * np.pi, 400)
    cl = Centreline.from_points(helix_points(r, c, theta))
    assert cl.length_m == pytest.approx(w * 3 * np.pi, rel=1e-9)
    s = np.linspace(0.002, cl.length_m - 0.002, 57)
    t = s / w
    assert np.abs(cl.position(s) - helix_points(r, c, t)).max() < 0.01 * UM
    assert np.abs(cl.curvature(s) / (r / w**2) - 1).max() < 1e-6
    assert np.abs(cl.torsion(s) / (c / w**2) - 1).max() < 1e-6
    assert np.abs(cl.normal(s) + np.c_[np.cos(t), np.sin(t), 0 * t]).max() < 1e-6
    b_exp = np.c_[c * np.sin(t), -c * np.cos(t), r + 0 * t] / w
    assert np.abs(cl.binormal(s) - b_exp).max() < 1e-6


def test_helix_closest_point():
    """A point on the helix's principal normal at distance 2 mm towards the axis is closest to
    that helix point (the normal line is perpendicular to the tangent and stays within the radius
    of curvature), so s and d = 2 mm are known exactly (1 um)."""
    r, c = 0.010, 0.003
    w = np.hypot(r, c)
    cl = Centreline.from_points(helix_points(r, c, np.linspace(0, 3 * np.pi, 400)))
    s_exp = np.linspace(0.003, cl.length_m - 0.003, 40)
    t = s_exp / w
    q = helix_points(r, c, t) - 0.002 * np.c_[np.cos(t), np.sin(t), 0 * t]
    s, d = cl.closest(q)
    assert np.abs(s - s_exp).max() < UM
    assert np.abs(d - 0.002).max() < UM
    s, d = cl.closest(q, s_hint_m=s_exp - 0.5e-3, window_m=1.5e-3)
    assert np.abs(s - s_exp).max() < UM


# --- property: true minimiser ----------------------------------------------------------------


@st.composite
def smooth_curve_and_point(draw):
    coeffs = draw(
        st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=12, max_size=12).map(np.array)
    )
    q = draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array))
    return coeffs.reshape(4, 3), q


@given(smooth_curve_and_point())
def test_closest_point_is_a_true_minimiser(data):
    """Random smooth curves (a 30 mm line plus 2 low Fourier modes of up to 8 mm) and random
    points in their box: the kernel's distance is a real distance to the curve at its s, and no
    point of a 200 000-sample brute-force scan of the same curve is closer (by more than 1 nm)."""
    coeffs, q = data
    theta = np.linspace(0.0, 1.0, 50)
    base = np.c_[0.03 * theta, np.zeros_like(theta), np.zeros_like(theta)]
    modes = (
        np.sin(np.pi * theta)[:, None] * coeffs[0]
        + np.cos(2 * np.pi * theta)[:, None] * coeffs[1]
        + np.sin(3 * np.pi * theta)[:, None] * coeffs[2] * 0.5
    ) * 0.008
    pts = base + modes
    try:
        cl = Centreline.from_points(pts)
    except GeometryError:  # a cusp (see test_a_curve_with_a_cusp_is_refused): not a channel
        reject()
    lo, hi = pts.min(axis=0) - 0.005, pts.max(axis=0) + 0.005
    p = lo + (q + 1.0) / 2.0 * (hi - lo)
    s, d = cl.closest(p)
    assert np.isfinite(s[0]) and np.isfinite(d[0])
    assert abs(np.linalg.norm(cl.position(s[0]) - p) - d[0]) < 1e-12
    dense = cl.position(np.linspace(0.0, cl.length_m, 200_001))
    d_brute = np.linalg.norm(dense - p, axis=1).min()
    assert d[0] <= d_brute + 1e-9


def test_a_curve_with_a_cusp_is_refused():
    """Points whose interpolating spline stops and turns back (a cusp: zero speed, no arc-length
    parameter) are refused with a GeometryError, not a scipy error. The points: a 30 mm line plus
    8 mm Fourier modes large enough to fold it (hypothesis found them)."""
    theta = np.linspace(0.0, 1.0, 50)
    coeffs = np.array([[0, 0.75, 0], [0, 0, 1], [1, -1, 1]])
    modes = (np.sin(np.pi * theta)[:, None] * coeffs[0]
             + np.cos(2 * np.pi * theta)[:, None] * coeffs[1]
             + np.sin(3 * np.pi * theta)[:, None] * coeffs[2] * 0.5) * 0.008  # fmt: skip
    pts = np.c_[0.03 * theta, 0 * theta, 0 * theta] + modes
    with pytest.raises(GeometryError, match="arc-length parametrisation did not converge"):
        Centreline.from_points(pts)


# --- near branches ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def stem_and_ring():
    """A 40 mm straight stem along +x at y = -13 mm, z = 0, then a 13 mm ring rising 3 mm per
    turn for 1.1 turns: after one turn the ring passes 3 mm above its own start."""
    r = 0.013
    stem_x = np.linspace(-0.040, 0.0, 41)[:-1]
    stem = np.c_[stem_x, np.full_like(stem_x, -r), np.zeros_like(stem_x)]
    th = np.linspace(0.0, 2 * np.pi * 1.1, 250)
    ring = np.c_[r * np.sin(th), -r * np.cos(th), 0.003 * th / (2 * np.pi)]
    return Centreline.from_points(np.vstack([stem, ring]))


def test_hint_never_jumps_to_a_near_branch(stem_and_ring):
    """Points on the ring's first turn at angles 0.2-0.5 rad, raised 1.4 mm (1.6 mm below the
    second turn, 3 mm above): globally and with a hint (2 mm window) they belong to the first
    turn, s ~ 40 mm + 13 mm * angle, d = 1.4 mm. Raised 1.6 mm they are nearer the second turn
    (global answer s > 40 mm + one turn, d ~ 1.4 mm) but with the first-turn hint they stay on
    the first turn (d ~ 1.6 mm) and equal the brute-force minimiser over the window."""
    cl = stem_and_ring
    r = 0.013
    w = np.hypot(r, 0.003 / (2 * np.pi))
    ang = np.linspace(0.2, 0.5, 7)
    s_exp = 0.040 + w * ang
    base = np.c_[r * np.sin(ang), -r * np.cos(ang), 0.003 * ang / (2 * np.pi)]
    for dz, d_exp in ((1.4e-3, 1.4e-3), (1.6e-3, 1.6e-3)):
        q = base + np.array([0.0, 0.0, dz])
        s_h, d_h = cl.closest(q, s_hint_m=s_exp + 0.5e-3, window_m=2e-3)
        assert np.abs(s_h - s_exp).max() < 0.1e-3  # the spline rounds the stem-ring kink
        assert np.abs(d_h - d_exp).max() < 0.02e-3
        for i in range(q.shape[0]):
            ss = np.linspace(s_exp[i] - 1.5e-3, s_exp[i] + 2.5e-3, 20_001)
            dd = np.linalg.norm(cl.position(ss) - q[i], axis=1)
            assert d_h[i] <= dd.min() + 1e-9
        s_g, d_g = cl.closest(q)
        if dz < 1.5e-3:
            assert np.abs(s_g - s_h).max() < UM
        else:
            assert (s_g > 0.040 + w * 2 * np.pi).all()
            assert (d_g < 1.45e-3).all()


def test_windowed_search_equals_brute_force_in_the_window(stem_and_ring):
    """Windowed answers are the minimiser over [hint - w, hint + w] of a dense brute-force scan
    of the same curve (1 um)."""
    cl = stem_and_ring
    rng = np.random.default_rng(7)
    hints = rng.uniform(0.0, cl.length_m, 60)
    q = cl.position(hints) + rng.normal(0.0, 1.5e-3, (60, 3))
    s, d = cl.closest(q, s_hint_m=hints, window_m=2e-3)
    for i in range(60):
        ss = np.linspace(hints[i] - 2e-3, hints[i] + 2e-3, 40_001)
        dd = np.linalg.norm(cl.position(ss) - q[i], axis=1)
        j = int(np.argmin(dd))
        assert d[i] <= dd[j] + 1e-9
        assert abs(s[i] - ss[j]) < 1e-6 or abs(d[i] - dd[j]) < 1e-9


# --- validation ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("points", "fragment"),
    [
        (np.zeros((3, 3)), "at least 4 points"),
        (np.zeros((5, 2)), "(n, 3)"),
        (np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0], [2, 0, 0.0]]) * 1e-3, "coincide"),
        (np.array([[0, 0, 0], [1, 0, 0], [np.nan, 0, 0], [2, 0, 0.0]]) * 1e-3, "not finite"),
        (np.array([[0, 0, 0], [10, 0, 0], [20, 0, 0], [30, 0, 0.0]]) * 1.0, "metres"),
        ("abc", "points_m"),
    ],
)
def test_bad_points_are_refused_with_a_named_argument(points, fragment):
    """Each bad input raises GeometryError naming points_m and the problem."""
    with pytest.raises(GeometryError) as err:
        Centreline.from_points(points)
    assert "points_m" in str(err.value)
    assert fragment in str(err.value)


def test_table_is_dense_and_contiguous(circle):
    """The table samples at <= 0.25 mm, float64 C-contiguous, normals unit and orthogonal."""
    _, cl = circle
    t = cl.table
    assert t.spacing_m <= 0.25e-3 + 1e-15
    for name in ("knots", "coef", "s", "pos", "tan", "nor", "kappa"):
        arr = getattr(t, name)
        assert arr.dtype == np.float64 and arr.flags.c_contiguous, name
    assert np.abs(np.linalg.norm(t.nor, axis=1) - 1).max() < 1e-12
    assert np.abs(np.sum(t.nor * t.tan, axis=1)).max() < 1e-12


def test_tiny_windows_and_windows_beyond_the_ends(circle):
    """A window narrower than the table spacing (0.05 mm) still returns the exact minimiser
    inside it (clamped to the window edge when the true one lies outside); a window entirely past
    the tip answers on the straight extension: for the 300-degree circle of radius R the point
    tip + 3 mm * tangent + 1 mm * normal has s = L + 3 mm, d = 1 mm."""
    r, cl = circle
    a = np.deg2rad(100.0)
    q = np.array([0.8 * r * np.cos(a), 0.8 * r * np.sin(a), 0.0])
    s, d = cl.closest(q, s_hint_m=r * a + 0.02e-3, window_m=0.05e-3)
    assert abs(s[0] - r * a) < UM and abs(d[0] - 0.2 * r) < UM
    s, d = cl.closest(q, s_hint_m=r * a + 1e-3, window_m=0.05e-3)
    assert abs(s[0] - (r * a + 0.95e-3)) < 1e-9  # clamped to the window's lower edge
    tip, tan = cl.position(cl.length_m), cl.tangent(cl.length_m)
    nor = cl.normal(cl.length_m)
    q2 = tip + 3e-3 * tan + 1e-3 * nor
    s, d = cl.closest(q2, s_hint_m=cl.length_m + 3e-3, window_m=1e-3)
    assert abs(s[0] - (cl.length_m + 3e-3)) < UM and abs(d[0] - 1e-3) < UM


def test_more_points_than_the_limit_are_refused_with_the_count_and_the_fix():
    """MAX_POINTS + 1 points on a line are refused before any fit, naming the count, the limit
    and how to resample; the limit itself is accepted by point_count_problem."""
    from ringqa.geometry.centreline import MAX_POINTS, point_count_problem

    assert point_count_problem(MAX_POINTS) is None
    n = MAX_POINTS + 1
    pts = np.c_[np.linspace(0.0, 0.1, n), np.zeros(n), np.zeros(n)]
    with pytest.raises(GeometryError) as err:
        Centreline.from_points(pts)
    msg = str(err.value)
    assert f"{n:,} points" in msg and f"{MAX_POINTS:,}" in msg and "resample" in msg


def test_a_dense_centreline_equals_a_sparse_one():
    """40 000 points (the issue's dense input, 3.7 um apart) on a 13 mm-radius half circle give
    the same curve as 400 points: length R pi to 1e-9 relative (the arc-length fit's
    tolerance), curvature 1/R to 1e-6 relative at the table samples away from the ends."""
    r = 13e-3
    for n in (400, 40_000):
        phi = np.linspace(0.0, np.pi, n)
        cl = Centreline.from_points(np.c_[r * np.cos(phi), r * np.sin(phi), np.zeros(n)])
        assert abs(cl.length_m - r * np.pi) <= 1e-9 * r * np.pi
        kappa = cl.table.kappa[10:-10]
        np.testing.assert_allclose(kappa, 1.0 / r, rtol=1e-6)
