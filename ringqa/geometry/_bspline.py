"""Interpolating B-splines of odd degree with not-a-knot end conditions, in numpy (the banded
solve: one numba kernel).

A small replacement for the one call of ``scipy.interpolate.make_interp_spline(x, y, k)`` that
:mod:`ringqa.geometry.centreline` makes: importing ``scipy.interpolate`` also imports
scipy.optimize, scipy.spatial and scipy.ndimage (about 0.3 s of a warm run's 2 s). The knot
vector is built exactly as scipy builds it (``_not_a_knot``: the data sites without the
``(k+1)/2`` first and last interior ones, end knots repeated ``k+1`` times), the collocation
matrix and the evaluation use the Cox-de Boor recurrences in the form of de Boor's *A Practical
Guide to Splines* (the same as scipy's ``_deBoor_D``), and points outside the base interval are
extrapolated with the end polynomial pieces, as scipy's default ``extrapolate=True`` does. The
coefficients differ from scipy's only by the round-off of a different linear solve (elimination
without pivoting in the band here, a pivoted banded LAPACK LU there).

All functions are pure; units are those of the caller (the centreline passes metres).
"""

from __future__ import annotations

import numpy as np

from ringqa.geometry._kernels import banded_eliminate

__all__ = ["InterpBSpline", "make_interp_spline", "not_a_knot_knots"]

#: Points evaluated at once (the work arrays hold (k + 1) x 3 numbers a point: ~4 MB a chunk)
_CHUNK = 16384


def not_a_knot_knots(x: np.ndarray, k: int) -> np.ndarray:
    """Knot vector of the not-a-knot interpolating spline of odd degree ``k``.

    Parameters
    ----------
    x : (n,) ndarray
        Strictly increasing data sites (any length unit), ``n >= k + 1``.
    k : int
        Odd spline degree (3 or 5 here).

    Returns
    -------
    (n + k + 1,) ndarray
        ``x[0]`` repeated ``k + 1`` times, the interior sites ``x[(k+1)/2 : n-(k+1)/2]``,
        ``x[-1]`` repeated ``k + 1`` times (identical to scipy's ``_not_a_knot``).
    """
    if k % 2 != 1:
        raise ValueError(f"k: only odd degrees are supported, got {k}")
    x = np.asarray(x, dtype=float)
    k2 = (k + 1) // 2
    return np.r_[(x[0],) * (k + 1), x[k2:-k2], (x[-1],) * (k + 1)]


def _intervals(t: np.ndarray, k: int, x: np.ndarray) -> np.ndarray:
    """Index ``l`` of the knot interval ``t[l] <= x < t[l+1]`` for each x, in ``[k, n-1]``.

    Right-continuous like scipy's ``find_interval``: a point on an interior knot belongs to the
    piece on its right; the right end and points beyond it use the last piece, points left of
    ``t[k]`` the first (extrapolation).
    """
    n = t.size - k - 1
    return np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)


def _basis(t: np.ndarray, k: int, x: np.ndarray, ell: np.ndarray, nu: int) -> np.ndarray:
    """``nu``-th derivatives of the ``k + 1`` B-splines ``B_{l-k} .. B_l`` not zero at each x.

    Parameters
    ----------
    t : (n + k + 1,) ndarray
        Knot vector.
    k : int
        Degree.
    x : (m,) ndarray
        Evaluation points.
    ell : (m,) ndarray of int
        Knot interval of each point (:func:`_intervals`).
    nu : int
        Derivative order, ``0 <= nu <= k`` (above k all derivatives are 0).

    Returns
    -------
    (m, k + 1) ndarray
        Column ``a`` holds the derivative of ``B_{l-k+a}`` at x (per unit of x to the power nu).

    Notes
    -----
    Cox-de Boor: the degree is raised from 0 to ``k - nu`` by the value recurrence, then from
    ``k - nu`` to ``k`` by the derivative recurrence (de Boor, ch. X; scipy's ``_deBoor_D``).
    The knot differences never vanish: for ``k <= l <= n-1`` with ``t[l] < t[l+1]`` every pair
    ``t[l+i] > t[l+i-j]`` used spans the interval ``[t[l], t[l+1]]``.
    """
    m = x.size
    h = np.zeros((m, k + 1))
    h[:, 0] = 1.0
    for j in range(1, k + 1):
        hh = h[:, :j].copy()
        h[:, 0] = 0.0
        deriv = j > k - nu
        for i in range(1, j + 1):
            xb = t[ell + i]
            xa = t[ell + i - j]
            if deriv:
                w = j * hh[:, i - 1] / (xb - xa)
                h[:, i - 1] -= w
                h[:, i] = w
            else:
                w = hh[:, i - 1] / (xb - xa)
                h[:, i - 1] += w * (xb - x)
                h[:, i] = w * (x - xa)
    return h


class InterpBSpline:
    """A B-spline curve ``sum_i c_i B_{i,k,t}(x)`` with the calling interface scipy's BSpline
    has in this package (``t``, ``k``, ``c``, ``spl(x, nu)``).

    Parameters
    ----------
    t : (n + k + 1,) ndarray
        Knot vector.
    c : (n, d) ndarray
        Coefficients (units of the data).
    k : int
        Degree.
    """

    __slots__ = ("c", "k", "t")

    def __init__(self, t: np.ndarray, c: np.ndarray, k: int):
        self.t = np.asarray(t, dtype=float)
        self.c = np.asarray(c, dtype=float)
        self.k = int(k)

    def __call__(self, x, nu: int = 0) -> np.ndarray:
        """Value (``nu = 0``) or ``nu``-th derivative at ``x``, extrapolating the end pieces.

        Parameters
        ----------
        x : float or ndarray
            Parameter values (unit of the data sites).
        nu : int, optional
            Derivative order (>= 0).

        Returns
        -------
        ndarray
            Shape ``x.shape + (d,)`` (units of the data per unit of x to the power nu).
        """
        x = np.asarray(x, dtype=float)
        xf = x.ravel()
        d = self.c.shape[1:]
        if nu > self.k:
            return np.zeros(x.shape + d)
        if nu < 0:
            raise ValueError(f"nu: derivative order must be >= 0, got {nu}")
        out = np.empty((xf.size, *d))
        for i0 in range(0, xf.size, _CHUNK):  # bounded work arrays for any number of points
            xc = xf[i0 : i0 + _CHUNK]
            ell = _intervals(self.t, self.k, xc)
            h = _basis(self.t, self.k, xc, ell, nu)
            idx = ell[:, None] - self.k + np.arange(self.k + 1)[None, :]
            out[i0 : i0 + xc.size] = np.einsum("ma,ma...->m...", h, self.c[idx])
        return out.reshape(x.shape + d)


def make_interp_spline(x, y, k: int = 3) -> InterpBSpline:
    """Not-a-knot B-spline of odd degree ``k`` through ``(x_i, y_i)``.

    Parameters
    ----------
    x : (n,) array_like
        Strictly increasing finite data sites, ``n >= k + 1``.
    y : (n, d) array_like
        Data values.
    k : int, optional
        Odd degree (3 or 5 here).

    Returns
    -------
    InterpBSpline

    Raises
    ------
    ValueError
        Sites not strictly increasing or too few of them.
    numpy.linalg.LinAlgError
        A singular collocation matrix.

    Notes
    -----
    The collocation matrix ``A[i, j] = B_j(x_i)`` is banded (k+1 non-zeros a row) and, by the
    Schoenberg-Whitney condition, non-singular for the not-a-knot knots of distinct sites; it is
    solved in its band (:func:`_banded_solve`).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.ndim != 1 or y.shape[0] != x.size:
        raise ValueError(f"x, y: shapes {x.shape} and {y.shape} are incompatible")
    if x.size < k + 1:
        raise ValueError(f"x: degree {k} needs at least {k + 1} sites, got {x.size}")
    if not np.all(np.diff(x) > 0.0):
        raise ValueError("x: sites must be strictly increasing")
    t = not_a_knot_knots(x, k)
    n = x.size
    ell = _intervals(t, k, x)
    h = _basis(t, k, x, ell, 0)
    cols = ell[:, None] - k + np.arange(k + 1)[None, :]
    c = _banded_solve(h, cols, y.reshape(n, -1)).reshape(y.shape)
    return InterpBSpline(t, c, k)


def _banded_solve(rows: np.ndarray, cols: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A c = b`` for the collocation matrix given by its non-zeros row by row.

    Parameters
    ----------
    rows : (n, k + 1) ndarray
        Non-zero entries of each row of ``A``.
    cols : (n, k + 1) ndarray of int
        Their column indices.
    b : (n, d) ndarray
        Right-hand sides.

    Returns
    -------
    (n, d) ndarray

    Notes
    -----
    Gaussian elimination without pivoting restricted to the band: a B-spline collocation matrix
    with the Schoenberg-Whitney condition met is totally positive, for which elimination without
    pivoting is stable (de Boor and Pinkus, 1977). The band is stored as ``(n, kl + ku + 1)``
    (memory O(n k), issue 25: the dense ``n x n`` matrix it replaced took 11.9 GiB for 40 000
    points), eliminated by the numba kernel :func:`ringqa.geometry._kernels.banded_eliminate`
    (O(n k^2) time) and back-substituted in numpy.
    """
    n = b.shape[0]
    i = np.arange(n)
    kl = int(np.max(i - cols[:, 0]))
    ku = int(np.max(cols[:, -1] - i))
    band = np.zeros((n, kl + ku + 1))
    band[i[:, None], kl + cols - i[:, None]] = rows
    x = np.array(b, dtype=float, order="C")
    if not banded_eliminate(band, kl, ku, x):
        raise np.linalg.LinAlgError("singular collocation matrix (sites not distinct?)")
    # back substitution in numpy: the same dot products as the dense solve had (bit-equal
    # coefficients, so the engine's answers do not move; a numba loop sums in another order)
    u = band[:, kl:]
    for j in range(n - 1, -1, -1):
        m = min(ku, n - 1 - j)
        x[j] = (x[j] - u[j, 1 : 1 + m] @ x[j + 1 : j + 1 + m]) / u[j, 0]
    if not np.all(np.isfinite(x)):
        raise np.linalg.LinAlgError("singular collocation matrix (sites not distinct?)")
    return x
