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
