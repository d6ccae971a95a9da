"""A straightforward NumPy implementation of the same TG-43 line-source formula.

Written independently of the numba kernel (binary search via ``np.searchsorted``, ``arccos`` for
theta, the TG-43 two-angle form of beta) so that the two can check each other, and used as the
baseline of ``benchmarks/bench_tg43.py``. Works in cm, like the consensus tables.
"""

from __future__ import annotations

import numpy as np

from tg43.source import Source


def geometry_factor_line(r_cm, theta_rad, length_cm: float) -> np.ndarray:
    """TG-43 line-source geometry function G_L(r, theta), cm^-2.

    ``beta / (L r sin theta)`` with beta = theta_2 - theta_1 (angles from the two ends of the
    active length, TG-43U1 Fig. 1); on the axis (sin theta = 0) the limit ``1 / (r^2 - L^2/4)``.

    Parameters
    ----------
    r_cm : array_like
        Distance from the source centre, cm.
    theta_rad : array_like
        Polar angle from the source axis (towards the tip), rad.
    length_cm : float
        Active length L, cm.
    """
    r = np.asarray(r_cm, dtype=float)
    th = np.asarray(theta_rad, dtype=float)
    r, th = np.broadcast_arrays(r, th)
    y = r * np.sin(th)
    z = r * np.cos(th)
    half = 0.5 * length_cm
    on_axis = y <= 1e-12 * np.maximum(r, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        theta2 = np.arctan2(y, z - half)  # angle seen from the tip end
        theta1 = np.arctan2(y, z + half)  # angle seen from the cable end
        beta = theta2 - theta1
        off = beta / (length_cm * y)
        on = 1.0 / (r * r - half * half)
    return np.where(on_axis, on, off)


def _cell(x: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    i = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, grid.size - 2)
    t = (x - grid[i]) / (grid[i + 1] - grid[i])
    t = np.where(x <= grid[0], 0.0, t)  # below the grid: value at the smallest r
    return i, t


def radial_dose_function(source: Source, r_cm) -> np.ndarray:
    """g_L(r): linear in r, nearest below the table, linear extrapolation beyond (>= 0)."""
    r = np.asarray(r_cm, dtype=float)
    i, t = _cell(r, source.gl_r_cm)
    return np.maximum(source.gl[i] + t * (source.gl[i + 1] - source.gl[i]), 0.0)


def anisotropy_function(source: Source, r_cm, theta_deg) -> np.ndarray:
    """F(r, theta): bilinear in (r, theta in degrees), same r rules as g_L (>= 0)."""
    r, th = np.broadcast_arrays(np.asarray(r_cm, float), np.asarray(theta_deg, float))
    ir, tr = _cell(r, source.f_r_cm)
    it, tt = _cell(np.clip(th, 0.0, 180.0), source.f_theta_deg)
    f = source.f
    f0 = f[it, ir] + tr * (f[it, ir + 1] - f[it, ir])
    f1 = f[it + 1, ir] + tr * (f[it + 1, ir + 1] - f[it + 1, ir])
    return np.maximum(f0 + tt * (f1 - f0), 0.0)


def dose_rate_per_sk_numpy(
    source: Source, positions_mm, directions, points_mm, *, chunk: int = 200_000
) -> np.ndarray:
    """Same quantity as :func:`tg43.dose_rate_per_sk`, in plain NumPy (no input checks).

    Returns shape (n_points, n_dwells), cGy h^-1 U^-1; points inside the source give inf/NaN.
    """
    pos = np.asarray(positions_mm, float) / 10.0
    dirs = np.asarray(directions, float)
    pts = np.asarray(points_mm, float) / 10.0
    length = source.active_length_cm
    g0 = geometry_factor_line(source.r0_cm, np.deg2rad(source.theta0_deg), length)
    out = np.empty((pts.shape[0], pos.shape[0]))
    rows = max(1, chunk // max(1, pos.shape[0]))
    for start in range(0, pts.shape[0], rows):
        p = pts[start : start + rows]
        d = p[:, None, :] - pos[None, :, :]
        r = np.linalg.norm(d, axis=2)
        cos_t = np.einsum("ijk,jk->ij", d, dirs) / r
        theta = np.arccos(np.clip(cos_t, -1.0, 1.0))
        out[start : start + rows] = (
            source.dose_rate_constant
            * geometry_factor_line(r, theta, length)
            / g0
            * radial_dose_function(source, r)
            * anisotropy_function(source, r, np.rad2deg(theta))
        )
    return out


def plan_dose_gy_numpy(source, positions_mm, directions, times_s, sk_U, points_mm) -> np.ndarray:
    """Plan dose in Gy with :func:`dose_rate_per_sk_numpy` (no decay, no checks)."""
    pts = np.asarray(points_mm, float)
    weights = np.asarray(times_s, float) * float(sk_U) / 3600.0 / 100.0
    out = np.empty(pts.shape[0])
    rows = max(1, 200_000 // max(1, weights.size))
    for start in range(0, pts.shape[0], rows):
        block = pts[start : start + rows]
        rate = dose_rate_per_sk_numpy(source, positions_mm, directions, block)
        out[start : start + rows] = rate @ weights
    return out
