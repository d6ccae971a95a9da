"""1D point-source approximation of TG-43U1, for comparison with the 2D line-source model.

    D_rate(r) = S_K * Lambda * (G_P(r) / G_P(r0)) * g_P(r) * phi_an(r),   G_P(r) = 1 / r^2

with ``g_P(r) = g_L(r) * G_L(r, theta0) G_P(r0) / (G_L(r0, theta0) G_P(r))`` (TG-43U1 eq. 11), so
``D_rate = S_K Lambda [G_L(r, theta0) / G_L(r0, theta0)] g_L(r) phi_an(r)``.

The consensus files used here do not tabulate phi_an, so it is DERIVED from F by the
solid-angle-weighted integral (TG-43U1 eq. 12)::

    phi_an(r) = integral_0^pi G_L(r, theta) F(r, theta) sin(theta) dtheta / (2 G_L(r, theta0))

at each radius of the F table (F linear in theta between table rows, trapezoid rule on a 0.01 deg
grid), with r = 0 taking the value at the next radius. Between radii phi_an and g_P are linear
in r, with the same extrapolation rules as the 2D model.
"""

from __future__ import annotations

import numpy as np

from tg43.dose import _as_xyz, _check_source
from tg43.errors import TG43Error
from tg43.reference import geometry_factor_line, radial_dose_function
from tg43.source import Source


def point_source_tables(source: Source) -> tuple[np.ndarray, np.ndarray]:
    """Derived 1D anisotropy factor phi_an at the radii of the F table.

    Returns
    -------
    r_cm : ndarray, shape (n_r,)
        The F table's radii, cm.
    phi_an : ndarray, shape (n_r,)
        Dimensionless 1D anisotropy factor.
    """
    _check_source(source)
    cached = source._cache.get("phi_an")
    if cached is not None:
        return cached
    theta_deg = np.linspace(0.0, 180.0, 18001)
    theta = np.deg2rad(theta_deg)
    length = source.active_length_cm
    phi = np.empty(source.f_r_cm.size)
    for k, r in enumerate(source.f_r_cm):
        if r <= 0.0:
            phi[k] = np.nan
            continue
        f = np.interp(theta_deg, source.f_theta_deg, source.f[:, k])
        g = geometry_factor_line(r, theta, length)
        g90 = geometry_factor_line(r, np.pi / 2, length)
        phi[k] = np.trapezoid(g * f * np.sin(theta), theta) / (2.0 * g90)
    first = int(np.argmax(np.isfinite(phi)))
    phi[:first] = phi[first]
    result = (source.f_r_cm.copy(), phi)
    for arr in result:
        arr.setflags(write=False)
    source._cache["phi_an"] = result
    return result


def dose_rate_per_sk_point_1d(source: Source, positions_mm, points_mm) -> np.ndarray:
    """Dose rate per unit S_K with the 1D point-source approximation (no source direction).

    Parameters
    ----------
    source : Source
        From :func:`tg43.load_source`.
    positions_mm : array_like, shape (n_dwells, 3)
        Dwell centres, mm.
    points_mm : array_like, shape (n_points, 3)
        Calculation points, mm.

    Returns
    -------
    ndarray, shape (n_points, n_dwells)
        cGy h^-1 U^-1.

    Raises
    ------
    TG43Error
        Bad shapes, NaN/inf, or a point nearer a dwell than ``source.r_min_cm``.
    """
    _check_source(source)
    pos = _as_xyz(positions_mm, "positions_mm")
    pts = _as_xyz(points_mm, "points_mm", allow_single=True)
    r_cm = np.linalg.norm(pts[:, None, :] - pos[None, :, :], axis=2) / 10.0
    bad = (r_cm < source.r_min_cm) | (r_cm <= 0.5 * source.active_length_cm)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise TG43Error(
            f"points_mm: row {i} is {r_cm[i, j] * 10:.4g} mm from dwell {j}, inside the "
            f"{source.name} source for the point-source model (valid beyond "
            f"{max(source.r_min_cm, 0.5 * source.active_length_cm) * 10:.4g} mm); move the point"
        )
    r_tab, phi = point_source_tables(source)
    i = np.clip(np.searchsorted(r_tab, r_cm, side="right") - 1, 0, r_tab.size - 2)
    t = np.where(r_cm <= r_tab[0], 0.0, (r_cm - r_tab[i]) / (r_tab[i + 1] - r_tab[i]))
    phi_r = np.maximum(phi[i] + t * (phi[i + 1] - phi[i]), 0.0)
    length = source.active_length_cm
    g0 = geometry_factor_line(source.r0_cm, np.pi / 2, length)
    return (
        source.dose_rate_constant
        * geometry_factor_line(r_cm, np.pi / 2, length)
        / g0
        * radial_dose_function(source, r_cm)
        * phi_r
    )
