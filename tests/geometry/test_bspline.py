"""The numpy B-spline (ringqa.geometry._bspline) and rotation maths against scipy.

scipy is the reference here only (it stays a dependency: other modules use it); the package no
longer imports scipy.interpolate or scipy.spatial.transform on the commissioning path.

Tolerances: the knots are built by the same arithmetic as scipy's ``_not_a_knot`` (copies of the
data sites), so they are compared for exact equality. The coefficients come from a different
solve of the same well-conditioned banded system (elimination without pivoting in the band here,
LAPACK's pivoted banded LU in scipy; condition number ~15 on the shipped centrelines): they agree
to a few ulp of max|y|, measured ~1e-16 relative. A nu-th derivative multiplies that by the
basis derivatives, O(1 / h_min^nu), so derivatives are compared relative to
max(max|derivative|, max|y| / h_min^nu); 1e-12 leaves a margin of ~100 over the ~1e-14 seen and
still fails on any error in the recurrences or the knots (O(1) differences).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import make_interp_spline as scipy_spline
from scipy.spatial.transform import Rotation

from ringqa.geometry._bspline import make_interp_spline
from ringqa.geometry.registration import matrix_to_rotvec, rotvec_to_matrix
from ringqa.io.applicator_file import load_applicator

RTOL = 1e-12


def _assert_same_spline(x: np.ndarray, y: np.ndarray, k: int) -> None:
    """Knots identical; values and derivatives nu = 0..k+1 equal to RTOL at the sites, the
    knots, a dense grid and one end interval beyond each end (extrapolation), relative to the
    larger of max|derivative| and max|y| / h_min^nu (h_min: the smallest site spacing)."""
    ref = scipy_spline(x, y, k=k)
    spl = make_interp_spline(x, y, k=k)
    np.testing.assert_array_equal(spl.t, ref.t)
    assert spl.k == k
    h_min = float(np.diff(x).min())
    # extrapolation by one end interval: an end polynomial piece evaluated 2 interval widths
    # from its base magnifies coefficient round-off by at most 2^k (much farther out the
    # comparison measures that magnification, not the spline; the centreline never does it)
    xs = np.r_[
        np.linspace(x[0] - (x[1] - x[0]), x[0], 9),
        np.linspace(x[0], x[-1], 257),
        np.linspace(x[-1], x[-1] + (x[-1] - x[-2]), 9),
        x,
        ref.t,
    ]
    for nu in range(k + 2):
        want = ref(xs, nu)
        got = spl(xs, nu)
        assert got.shape == want.shape
        # round-off in the coefficients is ~eps max|y|; a nu-th derivative of the basis is
        # O(1 / h_min^nu): that is the scale of derivative round-off (it dominates where the
        # derivative is small, e.g. exactly 0 for data from a lower-degree polynomial)
        scale = max(float(np.abs(want).max()), float(np.abs(y).max()) / h_min**nu)
        err = float(np.abs(got - want).max()) / scale
        assert err <= RTOL, f"k={k} nu={nu}: relative difference {err:.2e}"


@given(
    k=st.sampled_from([3, 5]),
    n=st.integers(min_value=6, max_value=60),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_random_sites_match_scipy(k, n, seed):
    """Random sites (spacings varying by up to 100x) and random 3-D values."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.01, 1.0, n))
    y = rng.normal(size=(n, 3))
    _assert_same_spline(x, y, k)


@pytest.mark.parametrize("k", [3, 5])
def test_minimum_point_count(k):
    """k + 1 sites: no interior knot, the spline is the interpolating polynomial; a cubic
    through 4 samples of t^3 reproduces it (second derivative 6 t)."""
    x = np.array([0.0, 0.5, 1.7, 2.0, 3.1, 4.0])[: k + 1]
    y = np.c_[x**3, x, np.ones_like(x)]
    _assert_same_spline(x, y, k)
    spl = make_interp_spline(x, y, k=k)
    np.testing.assert_allclose(spl(np.array([0.25, 1.0]), 2)[:, 0], [1.5, 6.0], rtol=1e-12)


@pytest.mark.parametrize("name", ["ring26x60", "ring34x45"])
def test_shipped_centrelines_match_scipy(name):
    """The shipped applicators' channel centrelines at their final arc-length parameters."""
    app = load_applicator(name)
    for ch in app.channels:
        pts = ch.centreline.points_m
        t = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
        _assert_same_spline(t, pts, ch.centreline.degree)


def test_refuses_bad_sites():
    """Non-increasing sites and too few sites are refused (ValueError, as scipy)."""
    y = np.zeros((6, 3))
    with pytest.raises(ValueError, match="strictly increasing"):
        make_interp_spline(np.array([0.0, 1, 1, 2, 3, 4]), y, k=3)
    with pytest.raises(ValueError, match="at least 6"):
        make_interp_spline(np.arange(5.0), y[:5], k=5)


def _axes_angles(rng, m):
    ax = rng.normal(size=(m, 3))
    ax /= np.linalg.norm(ax, axis=1)[:, None]
    special = [0.0, 1e-12, 1e-6, 9.99e-4, 1.001e-3, 0.5, 3.0, np.pi - 1e-9, np.pi - 1e-4]
    ang = np.r_[special, rng.uniform(0.0, np.pi, m - len(special))]
    return ax, ang


def test_rotvec_to_matrix_matches_scipy():
    """Rodrigues' formula against scipy's quaternion route, angles from 0 to just below pi
    (including both sides of the 1e-3 series switch): 1e-12 absolute on entries of size <= 1."""
    ax, ang = _axes_angles(np.random.default_rng(7), 200)
    for a, th in zip(ax, ang, strict=True):
        v = a * th
        np.testing.assert_allclose(
            rotvec_to_matrix(v), Rotation.from_rotvec(v).as_matrix(), rtol=0, atol=1e-12
        )


def test_matrix_to_rotvec_matches_scipy():
    """Round trip and scipy's as_rotvec, 1e-12 absolute (rad); at exactly pi the sign of the
    axis is arbitrary, so either sign is accepted there."""
    ax, ang = _axes_angles(np.random.default_rng(8), 200)
    ang[-1] = np.pi
    for a, th in zip(ax, ang, strict=True):
        v = a * th
        m = Rotation.from_rotvec(v).as_matrix()
        got = matrix_to_rotvec(m)
        want = Rotation.from_matrix(m).as_rotvec()
        if th > np.pi - 1e-6:
            assert min(np.abs(got - want).max(), np.abs(got + want).max()) <= 1e-12
            assert min(np.abs(got - v).max(), np.abs(got + v).max()) <= 1e-7
        else:
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
            np.testing.assert_allclose(got, v, rtol=0, atol=1e-12)
    # exactly pi about z
    got = matrix_to_rotvec(np.diag([-1.0, -1.0, 1.0]))
    np.testing.assert_allclose(np.abs(got), [0.0, 0.0, np.pi], rtol=0, atol=1e-15)


def _dense_solve(rows: np.ndarray, cols: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The dense elimination the banded kernel replaced (issue 25), kept as the reference: the
    n x n collocation matrix, elimination without pivoting restricted to the band, back
    substitution."""
    n = b.shape[0]
    a = np.zeros((n, n))
    a[np.arange(n)[:, None], cols] = rows
    kl = int(np.max(np.arange(n) - cols[:, 0]))
    ku = int(np.max(cols[:, -1] - np.arange(n)))
    x = np.array(b, dtype=float)
    for j in range(n - 1):
        r1 = min(j + kl + 1, n)
        c1 = min(j + ku + 1, n)
        f = a[j + 1 : r1, j] / a[j, j]
        a[j + 1 : r1, j + 1 : c1] -= f[:, None] * a[j, j + 1 : c1]
        x[j + 1 : r1] -= f[:, None] * x[j]
    for j in range(n - 1, -1, -1):
        c1 = min(j + ku + 1, n)
        x[j] = (x[j] - a[j, j + 1 : c1] @ x[j + 1 : c1]) / a[j, j]
    return x


@given(
    k=st.sampled_from([3, 5]),
    n=st.integers(min_value=6, max_value=120),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_banded_solve_equals_the_dense_elimination(k, n, seed):
    """The band-stored elimination does the dense one's operations in the same order, element by
    element (the numba kernel), and the back substitution's dot products are numpy's matmul on
    the same slices: the coefficients are bit-equal (so the engine's answers cannot move). The
    band has the width the not-a-knot knots give, kl = ku = k: memory O(n k), not O(n^2)."""
    from ringqa.geometry._bspline import _banded_solve, _basis, _intervals, not_a_knot_knots

    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.01, 1.0, n))
    y = rng.normal(size=(n, 3))
    t = not_a_knot_knots(x, k)
    ell = _intervals(t, k, x)
    rows = _basis(t, k, x, ell, 0)
    cols = ell[:, None] - k + np.arange(k + 1)[None, :]
    want = _dense_solve(rows, cols, y)
    got = _banded_solve(rows, cols, y)
    np.testing.assert_array_equal(got, want)
    assert int(np.max(np.arange(n) - cols[:, 0])) + int(np.max(cols[:, -1] - np.arange(n))) <= 2 * k


def test_banded_solve_refuses_a_singular_matrix():
    """A zero pivot (a collocation row of zeros: no B-spline is non-zero at a site, which the
    Schoenberg-Whitney condition excludes) raises LinAlgError instead of returning inf/NaN."""
    from ringqa.geometry._bspline import _banded_solve

    rows = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    cols = np.array([[0, 1], [1, 2], [1, 2]])
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        _banded_solve(rows, cols, np.ones((3, 1)))


def test_a_dense_centreline_is_fitted_in_its_band():
    """20 000 points on a 13 mm-radius quarter circle (1 um apart): the dense solve needed a
    20 000^2 matrix (3.2 GB); the band needs 20 000 x 11 numbers. The spline through them is the
    circle: positions at the sites to 1e-12 m (interpolation), the mid-site curvature 1/R to
    1e-6 relative (the data lie on the circle to 1e-17 m)."""
    r = 13e-3
    phi = np.linspace(0.0, 0.5 * np.pi, 20_000)
    y = np.c_[r * np.cos(phi), r * np.sin(phi), np.zeros_like(phi)]
    x = r * phi
    spl = make_interp_spline(x, y, k=5)
    assert np.abs(spl(x) - y).max() < 1e-12
    xm = 0.5 * (x[1:] + x[:-1])[::997]
    d1 = spl(xm, 1)
    d2 = spl(xm, 2)
    kappa = np.linalg.norm(np.cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3
    np.testing.assert_allclose(kappa, 1.0 / r, rtol=1e-6)
