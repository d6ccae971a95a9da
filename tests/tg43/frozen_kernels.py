"""Frozen copy of the TG-43 kernels as they were before issue 16 (commit c3c3979).

``tg43/_kernels.py`` and the table set-up of ``tg43/dose.py`` (``_tables``, ``_run_threads``)
verbatim, so that the tests can compare the new kernels with the old ones on random geometry
and ``benchmarks/bench_tg43.py`` can time old and new side by side in one run. Not part of the
package API; do not edit (a change here would move the reference the new kernel is checked
against).
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


# --------------------------------------------------------------------------------------------
# the table set-up and thread handling of tg43/dose.py at the same commit

_M_PER_CM = 1e-2
_M_PER_MM = 1e-3


def old_tables(source) -> tuple:
    """Kernel arguments after (points, positions, directions[, weights]), as ``_tables`` built
    them (SI units)."""
    length_m = source.active_length_cm * _M_PER_CM
    half = 0.5 * length_m
    r0 = source.r0_cm * _M_PER_CM
    g_l0 = 2.0 * math.atan(half / r0) / (length_m * r0)  # G_L(r0, 90 deg) in m^-2
    scale = source.dose_rate_constant / g_l0
    g_r = np.ascontiguousarray(source.gl_r_cm * _M_PER_CM)
    g_v = np.ascontiguousarray(source.gl, dtype=float)
    f_r = np.ascontiguousarray(source.f_r_cm * _M_PER_CM)
    f_t = np.ascontiguousarray(np.deg2rad(source.f_theta_deg))
    f_v = np.ascontiguousarray(source.f, dtype=float)
    g_lut, g_inv, g_idx = build_lookup(g_r)
    fr_lut, fr_inv, fr_idx = build_lookup(f_r)
    ft_lut, ft_inv, ft_idx = build_lookup(f_t)
    return (
        half,
        source.r_min_cm * _M_PER_CM,
        scale,
        g_r, g_v, g_lut, g_inv, g_idx,
        f_r, f_t, f_v, fr_lut, fr_inv, fr_idx, ft_lut, ft_inv, ft_idx,
    )  # fmt: skip


def _inputs(positions_mm, directions, points_mm):
    """SI points and positions and unit directions, as the old ``dose.py`` made them."""
    pts = np.ascontiguousarray(points_mm, dtype=float) * _M_PER_MM
    pos = np.ascontiguousarray(positions_mm, dtype=float) * _M_PER_MM
    dirs = np.ascontiguousarray(directions, dtype=float)
    return pts, pos, dirs / np.linalg.norm(dirs, axis=1)[:, None]


def _run_threads(kernel, parallel: bool, *args):
    """Call a threaded kernel on one thread (default) or on all of numba's threads."""
    import numba

    if parallel:
        return kernel(*args)
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        return kernel(*args)
    finally:
        numba.set_num_threads(before)


def old_rate_matrix(source, positions_mm, directions, points_mm, *, parallel=False, tables=None):
    """The old ``dose_rate_per_sk`` without its input checks (NaN inside the source).

    positions_mm, directions (n_dwells, 3) (directions normalised as the old API did);
    points_mm (n_points, 3) -> (n_points, n_dwells) cGy h^-1 U^-1. ``tables``:
    :func:`old_tables` of the source, to keep the set-up out of timings.
    """
    pts, pos, dirs = _inputs(positions_mm, directions, points_mm)
    out = np.empty((pts.shape[0], pos.shape[0]))
    tables = old_tables(source) if tables is None else tables
    _run_threads(rate_matrix, parallel, pts, pos, dirs, *tables, out)
    return out


def old_weighted_sum(
    source, positions_mm, directions, weights, points_mm, *, parallel=False, tables=None
):
    """The old ``plan_dose_gy`` kernel call: ``sum_j weights[j] * rate(point i, dwell j)``.

    ``weights`` (n_dwells,) in Gy per (cGy h^-1 U^-1) (the API's ``times_s * S_K / 3600 / 100``);
    returns (n_points,).
    """
    pts, pos, dirs = _inputs(positions_mm, directions, points_mm)
    w = np.ascontiguousarray(weights, dtype=float)
    out = np.empty(pts.shape[0])
    tables = old_tables(source) if tables is None else tables
    _run_threads(weighted_sum, parallel, pts, pos, dirs, w, *tables, out)
    return out
