"""Numba kernels of the TG-43 line-source dose rate (arrays and scalars only, SI units).

Lengths in metres, angles in radians. The public functions in :mod:`tg43.dose` validate and
convert the inputs, build the per-source tables once (:func:`build_tables`) and call
:func:`rows` (one thread) or :func:`rows_parallel` (points split over numba's threads).
No ``fastmath`` (bit-stable results for QA), no compilation at import (lazy ``@njit``).

Each point is done in two passes over the dwells:

1. the arithmetic, written without branches so that LLVM vectorises it over the dwells (SIMD,
   the same IEEE operations lane by lane): r, theta, the geometry factor G_L and the bins of
   the three index tables. Both arctangents come from :func:`_atan2_upper`, FDLIBM's ``atan``
   polynomial inlined (libm's ``atan2`` is an opaque call that took 60 % of the old kernel's
   time); it is within 2 ulp of libm's.
2. the table reads, scalar: g_L(r) and F(r, theta) from per-source cell tables.

Interpolation (HEBD consensus rules): linear in r for g_L, bilinear in (r, theta) for F; below
the smallest tabulated r the value at the smallest r; beyond the largest r linear extrapolation
from the last two values (clamped at zero so a dose rate is never negative). No table is uniform,
so a cell is found with a uniform-bin index table (bin width = half the smallest grid spacing, so
at most one grid node falls in a bin) plus one comparison with that node (``split``), read from
the same bin (no dependent second load). Cell tables hold what the interpolation needs per cell
(left node, 1 / width, value, value difference), computed once per source.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

# Coefficients and constants from FDLIBM s_atan.c and e_atan2.c: atan(x) = x - x (s1 + s2) for
# |x| < 7/16, and the hi + lo parts of pi/4, pi/2 and pi. Their notice:
#   Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
#   Developed at SunPro, a Sun Microsystems, Inc. business.
#   Permission to use, copy, modify, and distribute this software is freely granted, provided
#   that this notice is preserved.
_AT0 = 3.33333333333329318027e-01
_AT1 = -1.99999999998764832476e-01
_AT2 = 1.42857142725034663711e-01
_AT3 = -1.11111104054623557880e-01
_AT4 = 9.09088713343650656196e-02
_AT5 = -7.69187620504482999495e-02
_AT6 = 6.66107313738753120669e-02
_AT7 = -5.83357013379057348645e-02
_AT8 = 4.97687799461593236017e-02
_AT9 = -3.65315727442169155270e-02
_AT10 = 1.62858201153657823623e-02
_PIO4_HI = 7.85398163397448278999e-01
_PIO4_LO = 3.06161699786838301793e-17
_PIO2_HI = 1.57079632679489655800e00
_PIO2_LO = 6.12323399573676603587e-17
_PI_HI = 3.14159265358979311600e00
_PI_LO = 1.22464679914735317722e-16
_TAN_PI_8 = 0.41421356237309503  # tan(pi/8) < 7/16: the reduced argument stays in range


# --------------------------------------------------------------------------------------------
# per-source tables


def build_lookup(grid: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Uniform-bin index table for a strictly increasing grid.

    Parameters
    ----------
    grid : ndarray, shape (n,)
        Strictly increasing grid, n >= 2.

    Returns
    -------
    lut : ndarray of int64, shape (n_bins,)
        ``lut[k]`` = the largest i <= n - 2 with ``grid[i] <= grid[0] + k * h``.
    split : ndarray, shape (n_bins,)
        ``grid[lut[k] + 1]``, the only node that can lie inside bin k: x in bin k at or beyond
        it is in cell ``lut[k] + 1``; ``inf`` where ``lut[k]`` is already the last cell.
    inv_h : float
        1 / h, the inverse bin width (h = half the smallest grid spacing).
    """
    h = 0.5 * float(np.min(np.diff(grid)))
    n_bins = math.ceil((grid[-1] - grid[0]) / h) + 2
    starts = grid[0] + h * np.arange(n_bins)
    lut = np.searchsorted(grid, starts, side="right") - 1
    lut = np.clip(lut, 0, grid.size - 2).astype(np.int64)
    split = np.where(lut < grid.size - 2, grid[np.minimum(lut + 1, grid.size - 1)], np.inf)
    return lut, np.ascontiguousarray(split, dtype=float), 1.0 / h


def _axis(grid: np.ndarray) -> tuple:
    """(cells, lut, split, x0, inv_h) of one table axis; cells (n - 1, 2) = [x_i, 1 / dx_i]."""
    lut, split, inv_h = build_lookup(grid)
    cells = np.column_stack([grid[:-1], 1.0 / np.diff(grid)])
    return np.ascontiguousarray(cells), lut, split, float(grid[0]), inv_h


def build_tables(
    half_len: float,
    r_min: float,
    scale: float,
    g_r: np.ndarray,
    g_v: np.ndarray,
    f_r: np.ndarray,
    f_t: np.ndarray,
    f_v: np.ndarray,
) -> tuple:
    """Kernel arguments after (points, dwells, weights) for one source.

    Parameters
    ----------
    half_len : float
        Half the active length, m.
    r_min : float
        Smallest valid distance from the source centre, m.
    scale : float
        Lambda / G_L(r0, theta0), cGy h^-1 U^-1 m^2.
    g_r, g_v : ndarray, shape (n_g,)
        Radii (m, strictly increasing) and g_L values.
    f_r : ndarray, shape (n_r,)
        Radii of the F table, m, strictly increasing.
    f_t : ndarray, shape (n_t,)
        Polar angles of the F table, rad, strictly increasing from 0 to pi.
    f_v : ndarray, shape (n_t, n_r)
        F(r, theta).

    Returns
    -------
    tuple
        ``half_len, r_min, scale``, then for g_L ``g_cell`` (n_g - 1, 4) = [r_i, 1 / dr_i, g_i,
        g_(i+1) - g_i] with its ``lut, split, x0, inv_h`` (:func:`build_lookup`), the same five
        for the F radii (``cells`` (n_r - 1, 2) = [r_i, 1 / dr_i]) and angles, and ``f_cell``
        (n_t, n_r - 1, 2) = [F(theta, r_i), F(theta, r_(i+1)) - F(theta, r_i)].
    """
    g_r = np.asarray(g_r, dtype=float)
    g_v = np.asarray(g_v, dtype=float)
    f_v = np.asarray(f_v, dtype=float)
    g_axis = _axis(g_r)
    g_cell = np.ascontiguousarray(np.column_stack([g_axis[0], g_v[:-1], np.diff(g_v)]))
    f_cell = np.ascontiguousarray(np.stack([f_v[:, :-1], np.diff(f_v, axis=1)], axis=2))
    return (
        float(half_len), float(r_min), float(scale),
        g_cell, *g_axis[1:],
        *_axis(np.asarray(f_r, dtype=float)),
        *_axis(np.asarray(f_t, dtype=float)),
        f_cell,
    )  # fmt: skip


def dwell_rows(positions: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Dwells as the kernels read them: shape (6, n_dwells), rows x, y, z (m), ux, uy, uz.

    One contiguous row per component, so that the geometry pass loads whole vectors of dwells.
    """
    out = np.empty((6, positions.shape[0]))
    out[:3] = positions.T
    out[3:] = directions.T
    return out


# --------------------------------------------------------------------------------------------
# arctangent (inlined, branch-free, so the geometry pass vectorises)


@njit(inline="always")
def _atan_s(u):
    """s(u) with atan(u) = u - u s(u), |u| <= 7/16 (FDLIBM's polynomial, < 1 ulp)."""
    z = u * u
    w = z * z
    s1 = z * (_AT0 + w * (_AT2 + w * (_AT4 + w * (_AT6 + w * (_AT8 + w * _AT10)))))
    s2 = w * (_AT1 + w * (_AT3 + w * (_AT5 + w * (_AT7 + w * _AT9))))
    return s1 + s2


@njit(inline="always")
def _atan2_upper(y, x):
    """atan2(y, x) in [0, pi] for y >= 0 (y and x not both zero), within 2 ulp of libm.

    Reduced to atan(n / d) with 0 <= n <= d (swap y and |x| above 45 deg), then to
    pi/4 + atan((n - d) / (d + n)) above 22.5 deg, so the polynomial argument stays below
    tan(pi/8); one division. Written with selects only, no branches.
    """
    ax = abs(x)
    swap = y > ax
    n = ax if swap else y
    d = y if swap else ax
    big = n > _TAN_PI_8 * d
    num = n - d if big else n
    den = d + n if big else d
    u = num / den
    s = _atan_s(u)
    a = _PIO4_HI - ((u * s - _PIO4_LO) - u) if big else u - u * s
    a = (_PIO2_HI - a) + _PIO2_LO if swap else a
    return (_PI_HI - a) + _PI_LO if x < 0.0 else a


# --------------------------------------------------------------------------------------------
# kernels


@njit(cache=True, error_model="numpy")
def rows(
    lo, hi, points, dwells, weights,
    half_len, r_min, scale,
    g_cell, g_lut, g_split, g_x0, g_inv_h,
    fr_cell, fr_lut, fr_split, fr_x0, fr_inv_h,
    ft_cell, ft_lut, ft_split, ft_x0, ft_inv_h,
    f_cell, rates, sums, matrix,
):  # fmt: skip
    """Dose rate per S_K from every dwell at points ``lo <= i < hi`` (one thread).

    Parameters
    ----------
    lo, hi : int
        Range of point rows to compute.
    points : ndarray, shape (n_p, 3)
        Points, m.
    dwells : ndarray, shape (6, n_d)
        :func:`dwell_rows`: centres (m) and unit directions towards the tip.
    weights : ndarray, shape (n_d,)
        Weight of each dwell for ``sums`` (unused when ``matrix``).
    half_len, r_min, scale, g_cell ... f_cell
        :func:`build_tables`.
    rates : ndarray, shape (n_p, n_d)
        Filled with the dose rate per S_K (cGy h^-1 U^-1) when ``matrix``; NaN for a pair inside
        the source (r < r_min, or on the active segment). Any (0, 0) array otherwise.
    sums : ndarray, shape (n_p,)
        Filled with ``sum_j weights[j] * rate[i, j]``, summed over j in order, when not
        ``matrix``. Any (0,) array otherwise.
    matrix : bool
        Which output to fill.

    Returns
    -------
    int
        Number of (point, dwell) pairs inside the source among the rows done.
    """
    n_d = dwells.shape[1]
    two_h = 2.0 * half_len
    h2 = half_len * half_len
    g_top = float(g_lut.shape[0] - 1)
    fr_top = float(fr_lut.shape[0] - 1)
    ft_top = float(ft_lut.shape[0] - 1)
    r_j = np.empty(n_d)
    geom_j = np.empty(n_d)
    theta_j = np.empty(n_d)
    buf = np.empty(n_d)
    kg_j = np.empty(n_d, dtype=np.int64)
    kr_j = np.empty(n_d, dtype=np.int64)
    kt_j = np.empty(n_d, dtype=np.int64)
    n_bad = 0
    for i in range(lo, hi):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        # pass 1: geometry, angles and table bins (vectorised over the dwells)
        for j in range(n_d):
            dx = px - dwells[0, j]
            dy = py - dwells[1, j]
            dz = pz - dwells[2, j]
            z = dx * dwells[3, j] + dy * dwells[4, j] + dz * dwells[5, j]
            r2 = dx * dx + dy * dy + dz * dz
            r = math.sqrt(r2)
            y2 = r2 - z * z
            y = math.sqrt(y2) if y2 > 0.0 else 0.0
            denom = r2 - h2
            # G_L: beta / (L y) with beta the angle subtended by the active segment,
            # tan(beta) = L y / (r^2 - L^2/4); on the axis the exact limit 1 / (r^2 - L^2/4);
            # on the active segment (or nearer than r_min) NaN
            two_hy = two_h * y
            on_axis = 1.0 / denom if denom > 0.0 else math.nan
            geom = _atan2_upper(two_hy, denom) / two_hy if y > 0.0 else on_axis
            r_j[j] = r
            geom_j[j] = geom if r >= r_min else math.nan
            theta = _atan2_upper(y, z)
            theta_j[j] = theta
            # bins of the index tables (0 below a table, the last bin beyond it; NaN-safe)
            x = (r - g_x0) * g_inv_h
            x = x if x > 0.0 else 0.0
            kg_j[j] = int(x if x < g_top else g_top)
            x = (r - fr_x0) * fr_inv_h
            x = x if x > 0.0 else 0.0
            kr_j[j] = int(x if x < fr_top else fr_top)
            x = (theta - ft_x0) * ft_inv_h
            x = x if x > 0.0 else 0.0
            kt_j[j] = int(x if x < ft_top else ft_top)
        # pass 2: g_L(r) and F(r, theta) from the cell tables
        row = rates[i] if matrix else buf
        for j in range(n_d):
            r = r_j[j]
            theta = theta_j[j]
            # g_L: cell and fraction; below the table the value at its first node (x clamped)
            k = kg_j[j]
            c = g_lut[k] + (1 if r >= g_split[k] else 0)
            t = ((r if r > g_x0 else g_x0) - g_cell[c, 0]) * g_cell[c, 1]
            g = g_cell[c, 2] + t * g_cell[c, 3]
            g = 0.0 if g < 0.0 else g
            # F: radius cell
            k = kr_j[j]
            cr = fr_lut[k] + (1 if r >= fr_split[k] else 0)
            tr = ((r if r > fr_x0 else fr_x0) - fr_cell[cr, 0]) * fr_cell[cr, 1]
            # F: angle cell
            k = kt_j[j]
            ct = ft_lut[k] + (1 if theta >= ft_split[k] else 0)
            tt = ((theta if theta > ft_x0 else ft_x0) - ft_cell[ct, 0]) * ft_cell[ct, 1]
            f0 = f_cell[ct, cr, 0] + tr * f_cell[ct, cr, 1]
            f1 = f_cell[ct + 1, cr, 0] + tr * f_cell[ct + 1, cr, 1]
            f = f0 + tt * (f1 - f0)
            f = 0.0 if f < 0.0 else f
            v = scale * geom_j[j] * g * f
            row[j] = v
            n_bad += 1 if v != v else 0
        if not matrix:
            acc = 0.0
            for j in range(n_d):
                acc += weights[j] * buf[j]
            sums[i] = acc
    return n_bad


@njit(cache=True, parallel=True)
def rows_parallel(
    chunk, points, dwells, weights,
    half_len, r_min, scale,
    g_cell, g_lut, g_split, g_x0, g_inv_h,
    fr_cell, fr_lut, fr_split, fr_x0, fr_inv_h,
    ft_cell, ft_lut, ft_split, ft_x0, ft_inv_h,
    f_cell, rates, sums, matrix,
):  # fmt: skip
    """:func:`rows` for all points, blocks of ``chunk`` points split over numba's threads.

    Every output element is computed by the same :func:`rows` arithmetic (each point's sum runs
    over its dwells in order), so the numbers are the same bit for bit whatever the thread
    count and whatever the order in which the threads take the blocks.

    Parameters
    ----------
    chunk : int
        Points per block (>= 1); each block is one :func:`rows` call.
    points ... matrix
        As for :func:`rows`.

    Returns
    -------
    int
        Number of (point, dwell) pairs inside the source.
    """
    n_p = points.shape[0]
    n_chunks = (n_p + chunk - 1) // chunk
    bad = np.zeros(n_chunks, dtype=np.int64)
    for b in prange(n_chunks):
        lo = b * chunk
        hi = min(lo + chunk, n_p)
        bad[b] = rows(
            lo, hi, points, dwells, weights,
            half_len, r_min, scale,
            g_cell, g_lut, g_split, g_x0, g_inv_h,
            fr_cell, fr_lut, fr_split, fr_x0, fr_inv_h,
            ft_cell, ft_lut, ft_split, ft_x0, ft_inv_h,
            f_cell, rates, sums, matrix,
        )  # fmt: skip
    n_bad = 0
    for b in range(n_chunks):
        n_bad += bad[b]
    return n_bad
