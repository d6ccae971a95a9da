"""Numba kernels of the TG-43 line-source dose rate (arrays and scalars only, SI units).

Lengths in metres, angles in radians. The public functions in :mod:`tg43.dose` validate and
convert the inputs, build the lookup tables (:func:`build_lookup`) and call these kernels.
No ``fastmath`` (bit-stable results for QA), no compilation at import (lazy ``@njit``).

Interpolation (HEBD consensus rules): linear in r for g_L, bilinear in (r, theta) for F; below
the smallest tabulated r the value at the smallest r; beyond the largest r linear extrapolation
from the last two values (clamped at zero so a dose rate is never negative). Grid cells are found
with a uniform-bin lookup table (bin width <= the smallest grid spacing, so at most one grid node
falls in a bin and one comparison finishes the search) instead of a binary search.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


def build_lookup(grid: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Uniform-bin index table for a strictly increasing grid.

    Parameters
    ----------
    grid : ndarray, shape (n,)
        Strictly increasing grid, n >= 2.

    Returns
    -------
    lut : ndarray of int64, shape (n_bins,)
        ``lut[k]`` = the largest i <= n - 2 with ``grid[i] <= grid[0] + k * h``.
    inv_h : float
        1 / h, the inverse bin width (h = half the smallest grid spacing).
    inv_dx : ndarray, shape (n - 1,)
        1 / (grid[i+1] - grid[i]) (a multiplication instead of a division per lookup).
    """
    h = 0.5 * float(np.min(np.diff(grid)))
    n_bins = math.ceil((grid[-1] - grid[0]) / h) + 2
    starts = grid[0] + h * np.arange(n_bins)
    lut = np.searchsorted(grid, starts, side="right") - 1
    lut = np.clip(lut, 0, grid.size - 2).astype(np.int64)
    return lut, 1.0 / h, 1.0 / np.diff(grid)


@njit(cache=True, inline="always")
def _cell(x, grid, lut, inv_h, inv_dx):
    """Interval index i and fraction t with x = grid[i] + t (grid[i+1] - grid[i]).

    Below grid[0]: (0, 0.0) (nearest value); beyond grid[-1]: last interval, t > 1 (linear
    extrapolation).
    """
    n = grid.shape[0]
    if x <= grid[0]:
        return 0, 0.0
    if x >= grid[n - 1]:
        i = n - 2
    else:
        i = lut[int((x - grid[0]) * inv_h)]
        if x >= grid[i + 1]:
            i += 1
    return i, (x - grid[i]) * inv_dx[i]


@njit(cache=True, inline="always")
def _rate_one(
    px, py, pz, sx, sy, sz, ux, uy, uz,
    half_len, r_min, scale,
    g_r, g_v, g_lut, g_inv_h, g_idx,
    f_r, f_t, f_v, fr_lut, fr_inv_h, fr_idx, ft_lut, ft_inv_h, ft_idx,
):  # fmt: skip
    """Dose rate per unit S_K (cGy h^-1 U^-1) at one point from one dwell; NaN if inside.

    ``scale`` = Lambda / G_L(r0, theta0) (units of Lambda times m^2).
    """
    dx = px - sx
    dy = py - sy
    dz = pz - sz
    z = dx * ux + dy * uy + dz * uz
    r2 = dx * dx + dy * dy + dz * dz
    r = math.sqrt(r2)
    if r < r_min:
        return math.nan
    y2 = r2 - z * z
    y = math.sqrt(y2) if y2 > 0.0 else 0.0
    denom = r2 - half_len * half_len
    if y > 0.0:
        # beta = angle subtended by the active segment; tan(beta) = L y / (r^2 - L^2/4),
        # atan2 picks the right quadrant (beta in (0, pi)) because L y > 0.
        geom = math.atan2(2.0 * half_len * y, denom) / (2.0 * half_len * y)
    elif denom > 0.0:
        geom = 1.0 / denom  # exact on-axis limit of G_L
    else:
        return math.nan  # on the active segment
    theta = math.atan2(y, z)
    # g_L(r)
    i, t = _cell(r, g_r, g_lut, g_inv_h, g_idx)
    g = g_v[i] + t * (g_v[i + 1] - g_v[i])
    if g < 0.0:
        g = 0.0
    # F(r, theta), bilinear
    ir, tr = _cell(r, f_r, fr_lut, fr_inv_h, fr_idx)
    it, tt = _cell(theta, f_t, ft_lut, ft_inv_h, ft_idx)
    f0 = f_v[it, ir] + tr * (f_v[it, ir + 1] - f_v[it, ir])
    f1 = f_v[it + 1, ir] + tr * (f_v[it + 1, ir + 1] - f_v[it + 1, ir])
    f = f0 + tt * (f1 - f0)
    if f < 0.0:
        f = 0.0
    return scale * geom * g * f


@njit(cache=True, parallel=True)
def rate_matrix(
    points, positions, directions,
    half_len, r_min, scale,
    g_r, g_v, g_lut, g_inv_h, g_idx,
    f_r, f_t, f_v, fr_lut, fr_inv_h, fr_idx, ft_lut, ft_inv_h, ft_idx,
    out,
):  # fmt: skip
    """Fill ``out[i, j]`` with the dose rate per S_K at point i from dwell j.

    points (n_p, 3), positions (n_d, 3) in m; directions (n_d, 3) unit vectors towards the tip;
    out (n_p, n_d) in cGy h^-1 U^-1. Returns the number of (point, dwell) pairs that are inside
    the source (their entries are NaN). Points are split over threads (``numba.set_num_threads``);
    every entry is computed the same way whatever the thread count (bit-stable).
    """
    n_p = points.shape[0]
    n_d = positions.shape[0]
    for i in prange(n_p):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        for j in range(n_d):
            out[i, j] = _rate_one(
                px, py, pz,
                positions[j, 0], positions[j, 1], positions[j, 2],
                directions[j, 0], directions[j, 1], directions[j, 2],
                half_len, r_min, scale,
                g_r, g_v, g_lut, g_inv_h, g_idx,
                f_r, f_t, f_v, fr_lut, fr_inv_h, fr_idx, ft_lut, ft_inv_h, ft_idx,
            )  # fmt: skip
    n_bad = 0
    for i in range(n_p):
        for j in range(n_d):
            if math.isnan(out[i, j]):
                n_bad += 1
    return n_bad


@njit(cache=True, parallel=True)
def weighted_sum(
    points, positions, directions, weights,
    half_len, r_min, scale,
    g_r, g_v, g_lut, g_inv_h, g_idx,
    f_r, f_t, f_v, fr_lut, fr_inv_h, fr_idx, ft_lut, ft_inv_h, ft_idx,
    out,
):  # fmt: skip
    """``out[i] = sum_j weights[j] * rate(point i, dwell j)`` without storing the matrix.

    Points are split over threads; each point's sum runs over the dwells in order, so the
    result is the same bit for bit whatever the thread count. Returns the number of points
    whose sum is NaN (a point inside a source).
    """
    n_p = points.shape[0]
    n_d = positions.shape[0]
    for i in prange(n_p):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        acc = 0.0
        for j in range(n_d):
            acc += weights[j] * _rate_one(
                px, py, pz,
                positions[j, 0], positions[j, 1], positions[j, 2],
                directions[j, 0], directions[j, 1], directions[j, 2],
                half_len, r_min, scale,
                g_r, g_v, g_lut, g_inv_h, g_idx,
                f_r, f_t, f_v, fr_lut, fr_inv_h, fr_idx, ft_lut, ft_inv_h, ft_idx,
            )  # fmt: skip
        out[i] = acc
    n_bad = 0
    for i in range(n_p):
        if math.isnan(out[i]):
            n_bad += 1
    return n_bad
